"""Aircraft and battery-pack definitions: dataclasses and their YAML loaders.

Keys, units and defaults follow DESIGN §8. Each file is validated when loaded
and every problem is reported at once in one line naming the file and the key
(:class:`planner.errors.InputError`). The tables ``BATTERY_KEYS``,
``AIRCRAFT_KEYS``, ``FIXED_WING_KEYS`` and ``MULTIROTOR_KEYS`` are the schema;
``POWER_MODEL_KEYS`` lists the keys each multirotor power model needs.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from planner import schema as S
from planner.battery import integral
from planner.errors import InputError

# --------------------------------------------------------------------------- battery

BATTERY_KEYS = {
    "name": S.Key(S.TEXT, required=True),
    "cells_series": S.Key(S.INTEGER, required=True, low=1, high=40),
    "cells_parallel": S.Key(S.INTEGER, default=1, low=1, high=100),
    "capacity_mah": S.positive(required=True),
    "mass_kg": S.positive(required=True),
    "max_discharge_c": S.positive(),
    "internal_resistance_ohm": S.non_negative(high=10.0),
    "cell_voltage_empty_v": S.Key(S.NUMBER, default=3.5, low=2.0, high=4.2),
    "usable_fraction": S.Key(S.NUMBER, default=1.0, low=0.0, low_open=True, high=1.0),
    "model": S.Key(S.MAPPING),
    "circuit": S.Key(S.MAPPING),
    "thermal": S.Key(S.MAPPING),
    "chemistry": S.Key(S.TEXT, default="lipo"),
    "price": S.non_negative(),
    "count": S.Key(S.INTEGER, default=1, low=1, high=16),
    "source": S.Key(S.TEXT),
}

MODEL_KEYS = {
    "delta": S.positive(required=True),
    "epsilon": S.Key(S.NUMBER, required=True, low=-3.0, high=0.5),
    "beta": S.Key(S.NUMBER, default=integral.LITERATURE_BETA, low=0.5, high=1.5),
    # extensions written by `endurance diagnose --out` (DESIGN §6)
    "temperature_coefficient_per_c": S.Key(S.NUMBER, default=0.0, low=-0.2, high=0.2),
    "reference_temperature_c": S.Key(S.NUMBER, default=25.0, low=-40, high=80),
    "fade_per_cycle": S.Key(S.NUMBER, default=0.0, low=-0.01, high=0.05),
    "cycle": S.Key(S.NUMBER, default=0.0, low=0.0),
    "source": S.Key(S.TEXT),
}


#: Largest cell count for which the literature start-value polynomials are used as such.
LITERATURE_MAX_CELLS = 6


def filled_temperature(temperature_c) -> np.ndarray | None:
    """Temperatures with missing samples filled from the nearest valid ones; ``None``
    when there are none. [°C]"""
    if temperature_c is None:
        return None
    temp = np.asarray(temperature_c, dtype=float).ravel()
    ok = np.isfinite(temp)
    if not ok.any():
        return None
    if not ok.all():
        idx = np.arange(temp.size)
        temp = np.interp(idx, idx[ok], temp[ok])
    return temp


@dataclass(frozen=True)
class IntegralModel:
    """Parameters of the integral capacity model (DESIGN §5).

    Attributes
    ----------
    delta, epsilon, beta : float
        ``t = delta * P**epsilon * C**beta`` with t in s, P in W, C in A·s.
    literature : bool
        True when δ, ε are the literature start values δ₀(N), ε₀(N), not a fit.
    temperature_coefficient_per_c : float
        Relative change of the charge drawn per °C below the reference
        temperature (diagnose extension; 0 = none). [1/°C]
    reference_temperature_c : float
        [°C]
    fade_per_cycle, cycle : float
        Relative rise of the charge drawn per charge cycle and the pack's cycle
        count (diagnose extension). [1/cycle], [cycles]
    """

    delta: float
    epsilon: float
    beta: float = integral.LITERATURE_BETA
    literature: bool = False
    temperature_coefficient_per_c: float = 0.0
    reference_temperature_c: float = 25.0
    fade_per_cycle: float = 0.0
    cycle: float = 0.0
    source: str | None = None

    @classmethod
    def from_literature(cls, cells_series: int,
                        capacity_as: float | None = None) -> IntegralModel:
        r"""The literature start values δ₀(N), ε₀(N) for a pack of N cells.

        The start-value polynomials describe the model in its Peukert form,
        β = 1: :math:`\delta_0(N)` then behaves as an effective pack voltage
        (δ₀(3) = 13.3, δ₀(4) = 18.1, δ₀(6) = 24.8 give 11.2 V, 15.6 V and
        23.8 V at 100 W over one hour). Paired as they stand with β = 0.9648
        they would draw 35–40 % more charge than the energy allows. So, with
        the pack's nominal charge :math:`C_n` known, β = 0.9648 is kept and δ
        is rescaled to :math:`\delta_0 C_n^{1-\beta}`: the two forms then agree
        on a full discharge at constant power. Without a capacity, β = 1.

        Above :data:`LITERATURE_MAX_CELLS` cells the polynomials stop growing
        (they turn negative above 10): δ is extrapolated from 6 cells as
        δ₀(6)·(N/6)^(−ε₀(6)), so that it keeps scaling with the pack voltage.

        Parameters
        ----------
        cells_series : int
        capacity_as : float, optional
            Nominal charge of the pack. [A s]
        """
        delta = integral.literature_delta(cells_series)
        eps = integral.literature_epsilon(cells_series)
        if cells_series > LITERATURE_MAX_CELLS:
            # the polynomials peak near 6 cells and turn negative above 10: extrapolate
            # from 6 cells with δ ∝ N^(−ε), i.e. δ scaling as the pack voltage
            n0 = LITERATURE_MAX_CELLS
            eps = integral.literature_epsilon(n0)
            delta = integral.literature_delta(n0) * (cells_series / n0) ** (-eps)
        if capacity_as is None:
            return cls(delta, eps, 1.0, literature=True)
        beta = integral.LITERATURE_BETA
        return cls(delta * capacity_as ** (1.0 - beta), eps, beta, literature=True)

    def charge_scale(self, temperature_c=None):
        """Factor on the charge drawn from the extensions (1 = none). [unitless]

        ``temperature_c`` may be a number or an array (one factor per value). [°C]
        """
        scale = 1.0 + self.fade_per_cycle * self.cycle
        if temperature_c is None or not self.temperature_coefficient_per_c:
            return scale
        below = np.maximum(self.reference_temperature_c - np.asarray(temperature_c, float), 0.0)
        out = scale * (1.0 + self.temperature_coefficient_per_c * below)
        return out if np.ndim(out) else float(out)

    def charge(self, time_s, power_w, temperature_c=None) -> np.ndarray:
        r"""Charge drawn along a sampled power profile, with the extensions. [A s]

        :math:`\hat C(t) = (1 + \varphi n) \int_0^t (1 + k\,h(T))\, dC_0` with
        :math:`C_0` the integral model (:func:`planner.battery.integral.charge`)
        and :math:`h = \max(T_{ref} - T, 0)` at the mid-point of each interval:
        each increment of charge is scaled by the pack temperature of that
        moment, as diagnose fits it (:mod:`planner.diagnose.effects`). For a
        constant temperature this is ``charge_scale(T)·C_0``.

        Parameters
        ----------
        time_s, power_w : array_like
            Sample times [s] and electric power [W] (≤ 0 is a rest).
        temperature_c : array_like, optional
            Pack temperature per sample; missing values are filled from the
            nearest valid sample. Without it (or all missing) no temperature
            correction. [°C]
        """
        base = integral.charge(time_s, power_w, self.delta, self.epsilon, self.beta)
        temp = filled_temperature(temperature_c) if self.temperature_coefficient_per_c else None
        if temp is None:
            return self.charge_scale() * base
        scale = self.charge_scale(temp)
        inc = np.diff(base) * 0.5 * (scale[1:] + scale[:-1])
        return np.concatenate(([0.0], np.cumsum(inc)))

    def to_mapping(self) -> dict[str, Any]:
        out: dict[str, Any] = {"delta": float(self.delta), "epsilon": float(self.epsilon),
                               "beta": float(self.beta)}
        if self.temperature_coefficient_per_c:
            out["temperature_coefficient_per_c"] = float(self.temperature_coefficient_per_c)
            out["reference_temperature_c"] = float(self.reference_temperature_c)
        if self.fade_per_cycle:
            out["fade_per_cycle"] = float(self.fade_per_cycle)
            out["cycle"] = float(self.cycle)
        if self.source:
            out["source"] = self.source
        return out


@dataclass(frozen=True)
class BatteryPack:
    """A battery pack (DESIGN §8). Capacity is per pack; ``count`` packs fly in parallel.

    Attributes
    ----------
    name : str
    cells_series, cells_parallel : int
    capacity_mah : float
        Nominal capacity of one pack. [mAh]
    mass_kg : float
        Mass of one pack. [kg]
    max_discharge_c : float or None
        Continuous discharge rating. [1/h]
    internal_resistance_ohm : float or None
        Pack DC resistance. [Ω]
    cell_voltage_empty_v : float
        Cut-off per cell under load. [V]
    usable_fraction : float
        Share of nominal capacity that can be drawn. [unitless]
    model : IntegralModel
    circuit, thermal : dict or None
        Equivalent-circuit and thermal blocks (see :mod:`planner.battery.circuit`).
    count : int
        Identical packs in parallel.
    """

    name: str
    cells_series: int
    capacity_mah: float
    mass_kg: float
    cells_parallel: int = 1
    max_discharge_c: float | None = None
    internal_resistance_ohm: float | None = None
    cell_voltage_empty_v: float = 3.5
    usable_fraction: float = 1.0
    model: IntegralModel | None = None
    circuit: dict | None = None
    thermal: dict | None = None
    chemistry: str = "lipo"
    price: float | None = None
    count: int = 1
    source: str | None = None
    path: str | None = None

    def __post_init__(self):
        if self.model is None:
            object.__setattr__(self, "model", IntegralModel.from_literature(
                self.cells_series, self.capacity_mah * integral.AS_PER_MAH))

    # totals over `count` packs in parallel
    @property
    def total_capacity_mah(self) -> float:
        return self.capacity_mah * self.count

    @property
    def total_mass_kg(self) -> float:
        return self.mass_kg * self.count

    @property
    def capacity_as(self) -> float:
        """Nominal charge of the installed packs. [A s]"""
        return self.total_capacity_mah * integral.AS_PER_MAH

    @property
    def usable_as(self) -> float:
        """Charge that may be drawn, nominal × usable fraction. [A s]"""
        return self.capacity_as * self.usable_fraction

    @property
    def max_current_a(self) -> float | None:
        """Continuous current limit from the C rating. [A]"""
        if self.max_discharge_c is None:
            return None
        return self.max_discharge_c * self.total_capacity_mah / 1000.0

    @property
    def resistance_ohm(self) -> float:
        """Installed pack resistance (``count`` packs in parallel); 0 when unknown. [Ω]"""
        return (self.internal_resistance_ohm or 0.0) / self.count

    def with_model(self, model: IntegralModel) -> BatteryPack:
        return replace(self, model=model)

    def to_mapping(self) -> dict[str, Any]:
        """The pack as a YAML-ready mapping (keys of DESIGN §8)."""
        out: dict[str, Any] = {"name": self.name, "cells_series": self.cells_series,
                               "cells_parallel": self.cells_parallel,
                               "capacity_mah": float(self.capacity_mah),
                               "mass_kg": float(self.mass_kg)}
        for key in ("max_discharge_c", "internal_resistance_ohm", "price"):
            if getattr(self, key) is not None:
                out[key] = float(getattr(self, key))
        out["cell_voltage_empty_v"] = float(self.cell_voltage_empty_v)
        out["usable_fraction"] = float(self.usable_fraction)
        if self.chemistry != "lipo":
            out["chemistry"] = self.chemistry
        if self.count != 1:
            out["count"] = self.count
        if not self.model.literature:
            out["model"] = self.model.to_mapping()
        for key in ("circuit", "thermal"):
            if getattr(self, key):
                out[key] = getattr(self, key)
        if self.source:
            out["source"] = self.source
        return out


def battery_from_mapping(data: Any, where: str) -> BatteryPack:
    """Validate a battery mapping (DESIGN §8) and build the pack."""
    problems: list[str] = []
    d = S.check_mapping(data, BATTERY_KEYS, where, problems=problems)
    model = None
    if d["model"] is not None:
        m = S.check_mapping(d["model"], MODEL_KEYS, where, "model.", problems)
        if not problems:
            model = IntegralModel(m["delta"], m["epsilon"], m["beta"], literature=False,
                                  temperature_coefficient_per_c=m["temperature_coefficient_per_c"],
                                  reference_temperature_c=m["reference_temperature_c"],
                                  fade_per_cycle=m["fade_per_cycle"], cycle=m["cycle"],
                                  source=m["source"])
    if problems:
        raise InputError(f"{where}: " + "; ".join(problems))
    for block in ("circuit", "thermal"):
        if d[block] is not None:
            _validate_block(block, d[block], where)
    return BatteryPack(name=d["name"], cells_series=d["cells_series"],
                       cells_parallel=d["cells_parallel"], capacity_mah=d["capacity_mah"],
                       mass_kg=d["mass_kg"], max_discharge_c=d["max_discharge_c"],
                       internal_resistance_ohm=d["internal_resistance_ohm"],
                       cell_voltage_empty_v=d["cell_voltage_empty_v"],
                       usable_fraction=d["usable_fraction"], model=model,
                       circuit=d["circuit"], thermal=d["thermal"], chemistry=d["chemistry"],
                       price=d["price"], count=d["count"], source=d["source"], path=where)


def _validate_block(block: str, data: dict, where: str) -> None:
    """Check a ``circuit:``/``thermal:`` block with the circuit model's own validator."""
    try:
        from planner.battery import circuit
    except ImportError:  # pragma: no cover - circuit model not installed
        return
    validator = getattr(circuit, f"validate_{block}_block", None)
    if validator is not None:
        validator(data, where)


def load_battery(path: str | Path) -> BatteryPack:
    """Load and validate a battery-pack YAML file."""
    return battery_from_mapping(S.load_yaml(path), str(path))


# --------------------------------------------------------------------------- aircraft

AIRCRAFT_TYPES = ("fixed_wing", "multirotor")

AIRCRAFT_KEYS = {
    "name": S.Key(S.TEXT, required=True),
    "type": S.Key(S.TEXT, required=True, choices=AIRCRAFT_TYPES),
    "empty_mass_kg": S.positive(required=True),
    "battery": S.Key(S.TEXT),
    "efficiency": S.Key(S.NUMBER, required=True, low=0.0, low_open=True, high=1.0),
    "system_power_w": S.non_negative(default=0.0),
    "climb_rate_ms": S.positive(),
    "descent_rate_ms": S.positive(),
    "max_takeoff_mass_kg": S.positive(),
    "efficiency_slope": S.Key(S.NUMBER, default=0.0, low=-1.0, high=1.0),
    "efficiency_reference_power_w": S.positive(),
    "cells_series_allowed": S.Key(S.LIST),
    "fixed_wing": S.Key(S.MAPPING),
    "multirotor": S.Key(S.MAPPING),
    "source": S.Key(S.TEXT),
}

FIXED_WING_KEYS = {
    "wing_area_m2": S.positive(required=True),
    "cd0": S.Key(S.NUMBER, required=True, low=0.0, low_open=True, high=0.5),
    "k": S.Key(S.NUMBER, low=0.0, low_open=True, high=1.0),
    "aspect_ratio": S.Key(S.NUMBER, low=1.0, high=60.0),
    "oswald_efficiency": S.Key(S.NUMBER, low=0.3, high=1.0),
    "cruise_airspeed_ms": S.positive(required=True),
    "stall_speed_ms": S.positive(),
    "max_airspeed_ms": S.positive(),
    "loiter_radius_m": S.positive(default=60.0),
    "loiter_airspeed_ms": S.positive(),
}

MULTIROTOR_KEYS = {
    "rotors": S.Key(S.INTEGER, required=True, low=1, high=32),
    "rotor_diameter_m": S.positive(required=True, high=5.0),
    "ct": S.positive(high=1.0),
    "cp": S.positive(high=1.0),
    "drag_area_m2": S.non_negative(default=0.0, high=10.0),
    "power_model": S.Key(S.TEXT, choices=("propeller", "momentum")),
    "cruise_speed_ms": S.positive(default=5.0),
    "max_airspeed_ms": S.positive(default=15.0),
    "induced_factor": S.Key(S.NUMBER, default=1.15, low=1.0, high=2.0),
    "figure_of_merit": S.Key(S.NUMBER, low=0.2, high=1.0),
    "tip_speed_ms": S.positive(),
    "max_thrust_n": S.positive(),
}

#: Keys each multirotor power model needs (besides rotors and diameter).
POWER_MODEL_KEYS = {"propeller": ("ct", "cp"), "momentum": ()}

#: Default vertical speeds when the aircraft file gives none. [m/s]
#: Multirotor: ArduCopter WPNAV_SPEED_UP 2.5 m/s and WPNAV_SPEED_DN 1.5 m/s;
#: fixed-wing: a gentle 2 m/s spiral climb and descent.
DEFAULT_VERTICAL_SPEEDS = {"multirotor": (2.5, 1.5), "fixed_wing": (2.0, 2.0)}


@dataclass(frozen=True)
class FixedWing:
    """Fixed-wing parameters: drag polar ``C_D = C_D0 + K C_L²``."""

    wing_area_m2: float
    cd0: float
    k: float
    cruise_airspeed_ms: float
    stall_speed_ms: float | None = None
    max_airspeed_ms: float | None = None
    loiter_radius_m: float = 60.0
    loiter_airspeed_ms: float | None = None

    @property
    def top_airspeed_ms(self) -> float:
        """Highest airspeed the aircraft flies (default 1.5 × cruise). [m/s]"""
        return self.max_airspeed_ms or 1.5 * self.cruise_airspeed_ms


@dataclass(frozen=True)
class Multirotor:
    """Multirotor parameters (propeller-coefficient and momentum-theory models)."""

    rotors: int
    rotor_diameter_m: float
    power_model: str
    ct: float | None = None
    cp: float | None = None
    drag_area_m2: float = 0.0
    cruise_speed_ms: float = 5.0
    max_airspeed_ms: float = 15.0
    induced_factor: float = 1.15
    figure_of_merit: float | None = None
    tip_speed_ms: float | None = None
    max_thrust_n: float | None = None


@dataclass(frozen=True)
class Aircraft:
    """An aircraft (DESIGN §8) without its battery and payload.

    Attributes
    ----------
    empty_mass_kg : float
        Everything but battery and payload. [kg]
    efficiency : float
        Battery → useful mechanical power, η. [unitless]
    system_power_w : float
        Avionics and payload electrical load P_S. [W]
    climb_rate_ms, descent_rate_ms : float
        Default vertical speeds. [m/s]
    battery_path : str or None
        Default pack file, resolved against the aircraft file.
    """

    name: str
    type: str
    empty_mass_kg: float
    efficiency: float
    system_power_w: float = 0.0
    climb_rate_ms: float = 2.5
    descent_rate_ms: float = 1.5
    battery_path: str | None = None
    max_takeoff_mass_kg: float | None = None
    efficiency_slope: float = 0.0
    efficiency_reference_power_w: float | None = None
    cells_series_allowed: tuple[int, ...] | None = None
    fixed_wing: FixedWing | None = None
    multirotor: Multirotor | None = None
    source: str | None = None
    path: str | None = None

    @property
    def is_multirotor(self) -> bool:
        return self.type == "multirotor"

    @property
    def cruise_speed_ms(self) -> float:
        """Default horizontal speed (multirotor: ground speed; fixed-wing: airspeed). [m/s]"""
        return (self.multirotor.cruise_speed_ms if self.is_multirotor
                else self.fixed_wing.cruise_airspeed_ms)

    @property
    def max_airspeed_ms(self) -> float:
        return (self.multirotor.max_airspeed_ms if self.is_multirotor
                else self.fixed_wing.top_airspeed_ms)

    def battery_power(self, airspeed, climb_rate, air_density, mass, load_factor=1.0):
        """Electric power drawn from the pack in steady flight.

        Thin wrapper: passes the stored parameters to the pure power models
        (:mod:`planner.power.fixed_wing`, :mod:`planner.power.multirotor`,
        :mod:`planner.power.momentum`). All arguments broadcast.

        Parameters
        ----------
        airspeed : numeric
            True airspeed (multirotor hovering in wind: the wind speed). [m/s]
        climb_rate : numeric
            Vertical speed, up positive. [m/s]
        air_density : numeric
            [kg m⁻³]
        mass : numeric
            All-up mass. [kg]
        load_factor : numeric
            Lift over weight (turns). [unitless]

        Returns
        -------
        power : numeric
            Battery power. [W]
        """
        power = self._constant_efficiency_power(airspeed, climb_rate, air_density, mass,
                                                load_factor)
        if not self.efficiency_slope or not self.efficiency_reference_power_w:
            return power
        # efficiency against load (diagnose's efficiency_curve):
        # 1/η(M) = 1/η0 − η1/η0² (M/M_ref − 1), M the mechanical power
        eta0, ps = self.efficiency, self.system_power_w
        mech = (np.asarray(power, float) - ps) * eta0
        inv = 1.0 / eta0 - self.efficiency_slope / eta0**2 * (
            mech / self.efficiency_reference_power_w - 1.0)
        return mech * np.maximum(inv, 1.0) + ps

    def _constant_efficiency_power(self, airspeed, climb_rate, air_density, mass,
                                   load_factor=1.0):
        if self.is_multirotor:
            m = self.multirotor
            if m.power_model == "propeller":
                from planner.power import multirotor
                return multirotor.propeller_battery_power(
                    mass * load_factor, air_density, m.rotors, m.rotor_diameter_m, m.ct, m.cp,
                    self.efficiency, climb_rate=climb_rate, airspeed=airspeed,
                    drag_area=m.drag_area_m2, system_power=self.system_power_w)
            from planner.power import momentum
            return momentum.momentum_battery_power(
                mass, air_density, m.rotors, m.rotor_diameter_m, self.efficiency,
                airspeed=airspeed, climb_rate=climb_rate, drag_area=m.drag_area_m2,
                induced_factor=m.induced_factor, figure_of_merit=m.figure_of_merit,
                tip_speed=m.tip_speed_ms, system_power=self.system_power_w,
                load_factor=load_factor)
        from planner.power import fixed_wing
        f = self.fixed_wing
        required = fixed_wing.required_power(airspeed, air_density, mass, f.wing_area_m2, f.cd0,
                                             f.k, climb_rate=climb_rate,
                                             load_factor=load_factor)
        return fixed_wing.battery_power(required, self.efficiency, self.system_power_w)

    def to_mapping(self) -> dict[str, Any]:
        out: dict[str, Any] = {"name": self.name, "type": self.type,
                               "empty_mass_kg": float(self.empty_mass_kg)}
        if self.battery_path:
            out["battery"] = self.battery_path
        out["efficiency"] = float(self.efficiency)
        out["system_power_w"] = float(self.system_power_w)
        out["climb_rate_ms"] = float(self.climb_rate_ms)
        out["descent_rate_ms"] = float(self.descent_rate_ms)
        if self.max_takeoff_mass_kg is not None:
            out["max_takeoff_mass_kg"] = float(self.max_takeoff_mass_kg)
        if self.efficiency_slope and self.efficiency_reference_power_w:
            out["efficiency_slope"] = float(self.efficiency_slope)
            out["efficiency_reference_power_w"] = float(self.efficiency_reference_power_w)
        if self.cells_series_allowed:
            out["cells_series_allowed"] = list(self.cells_series_allowed)
        block = self.multirotor if self.is_multirotor else self.fixed_wing
        out[self.type] = {k: (float(v) if isinstance(v, float) else v)
                          for k, v in block.__dict__.items() if v is not None}
        if self.source:
            out["source"] = self.source
        return out


def aircraft_from_mapping(data: Any, where: str) -> Aircraft:
    """Validate an aircraft mapping (DESIGN §8) and build the aircraft."""
    problems: list[str] = []
    d = S.check_mapping(data, AIRCRAFT_KEYS, where, problems=problems)
    kind = d["type"]
    fw = mr = None
    if kind in AIRCRAFT_TYPES:
        other = "multirotor" if kind == "fixed_wing" else "fixed_wing"
        if d[other] is not None:
            problems.append(f"'{other}' block given for an aircraft of type '{kind}'")
        if d[kind] is None:
            problems.append(f"missing required key '{kind}' (a mapping of the "
                            f"{kind.replace('_', '-')} parameters)")
        elif kind == "fixed_wing":
            fw = _fixed_wing(d[kind], where, problems)
        else:
            mr = _multirotor(d[kind], where, problems)
    allowed = None
    if d["cells_series_allowed"] is not None:
        cells = d["cells_series_allowed"]
        if not cells or not all(isinstance(c, int) and not isinstance(c, bool) and c > 0
                                for c in cells):
            problems.append(f"cells_series_allowed must be a list of whole numbers > 0, "
                            f"got {cells!r}")
        else:
            allowed = tuple(cells)
    if problems:
        raise InputError(f"{where}: " + "; ".join(problems))
    climb, descent = DEFAULT_VERTICAL_SPEEDS[kind]
    return Aircraft(name=d["name"], type=kind, empty_mass_kg=d["empty_mass_kg"],
                    efficiency=d["efficiency"], system_power_w=d["system_power_w"],
                    climb_rate_ms=d["climb_rate_ms"] or climb,
                    descent_rate_ms=d["descent_rate_ms"] or descent,
                    battery_path=d["battery"], max_takeoff_mass_kg=d["max_takeoff_mass_kg"],
                    efficiency_slope=d["efficiency_slope"],
                    efficiency_reference_power_w=d["efficiency_reference_power_w"],
                    cells_series_allowed=allowed, fixed_wing=fw, multirotor=mr,
                    source=d["source"], path=where)


def _fixed_wing(data: Any, where: str, problems: list[str]) -> FixedWing | None:
    n = len(problems)
    d = S.check_mapping(data, FIXED_WING_KEYS, where, "fixed_wing.", problems)
    k = d["k"]
    if k is None:
        if d["aspect_ratio"] is None or d["oswald_efficiency"] is None:
            problems.append("fixed_wing needs 'k' or both 'aspect_ratio' and "
                            "'oswald_efficiency' (K = 1/(π e AR))")
        else:
            from planner.power import fixed_wing
            k = float(fixed_wing.induced_drag_factor(d["aspect_ratio"], d["oswald_efficiency"]))
    elif d["aspect_ratio"] is not None:
        problems.append("fixed_wing: give either 'k' or 'aspect_ratio'/'oswald_efficiency', "
                        "not both")
    stall, cruise = d["stall_speed_ms"], d["cruise_airspeed_ms"]
    if stall is not None and cruise is not None and cruise <= stall:
        problems.append(f"fixed_wing.cruise_airspeed_ms ({cruise}) must be above "
                        f"stall_speed_ms ({stall})")
    if len(problems) > n:
        return None
    return FixedWing(wing_area_m2=d["wing_area_m2"], cd0=d["cd0"], k=k,
                     cruise_airspeed_ms=cruise, stall_speed_ms=stall,
                     max_airspeed_ms=d["max_airspeed_ms"], loiter_radius_m=d["loiter_radius_m"],
                     loiter_airspeed_ms=d["loiter_airspeed_ms"])


def _multirotor(data: Any, where: str, problems: list[str]) -> Multirotor | None:
    n = len(problems)
    d = S.check_mapping(data, MULTIROTOR_KEYS, where, "multirotor.", problems)
    model = d["power_model"]
    if model is None:  # "infer", as ModelChain.infer_dc_model
        model = "propeller" if d["ct"] is not None and d["cp"] is not None else "momentum"
    missing = [key for key in POWER_MODEL_KEYS.get(model, ()) if d[key] is None]
    if missing:
        problems.append(f"multirotor.power_model '{model}' needs "
                        + " and ".join(f"'multirotor.{m}'" for m in missing))
    if (d["ct"] is None) != (d["cp"] is None):
        problems.append("multirotor: give both 'ct' and 'cp' or neither")
    if len(problems) > n:
        return None
    return Multirotor(rotors=d["rotors"], rotor_diameter_m=d["rotor_diameter_m"],
                      power_model=model, ct=d["ct"], cp=d["cp"],
                      drag_area_m2=d["drag_area_m2"], cruise_speed_ms=d["cruise_speed_ms"],
                      max_airspeed_ms=d["max_airspeed_ms"], induced_factor=d["induced_factor"],
                      figure_of_merit=d["figure_of_merit"], tip_speed_ms=d["tip_speed_ms"],
                      max_thrust_n=d["max_thrust_n"])


def load_aircraft(path: str | Path) -> Aircraft:
    """Load and validate an aircraft YAML file."""
    return aircraft_from_mapping(S.load_yaml(path), str(path))


def default_battery_path(aircraft: Aircraft) -> Path | None:
    """The aircraft's default pack file, resolved against the aircraft file's folder."""
    if not aircraft.battery_path:
        return None
    base = Path(aircraft.path).parent if aircraft.path else Path(".")
    return base / aircraft.battery_path


def load_aircraft_and_battery(aircraft_path, battery_path=None) -> tuple[Aircraft, BatteryPack]:
    """Load an aircraft and its pack (``battery_path`` or the aircraft's default)."""
    aircraft = load_aircraft(aircraft_path)
    path = battery_path or default_battery_path(aircraft)
    if path is None:
        raise InputError(f"{aircraft_path}: no 'battery' key and no --battery given "
                         "(expected a battery-pack YAML)")
    return aircraft, load_battery(path)


__all__ = [
    "Aircraft",
    "BatteryPack",
    "FixedWing",
    "IntegralModel",
    "Multirotor",
    "aircraft_from_mapping",
    "battery_from_mapping",
    "load_aircraft",
    "load_aircraft_and_battery",
    "load_battery",
]
