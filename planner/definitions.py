"""Aircraft and battery-pack definitions: dataclasses and their YAML loaders.

Keys, units and defaults follow DESIGN §8. Each file is validated when loaded
and every problem is reported at once in one line naming the file and the key
(:class:`planner.errors.InputError`). The tables ``BATTERY_KEYS``,
``AIRCRAFT_KEYS``, ``FIXED_WING_KEYS`` and ``MULTIROTOR_KEYS`` are the schema;
``POWER_MODEL_KEYS`` lists the keys each multirotor power model needs. The constants
under "limits" (``MASS_MAX_KG``, ``SPEED_MAX_MS``, ...) bound the numbers to what small
electric UAVs can have, with the reason for each.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from planner import schema as S
from planner.atmosphere import G
from planner.battery import integral
from planner.errors import InputError
from planner.units import AS_PER_MAH

# --------------------------------------------------------------------------- limits
# Physical limits of the numbers in aircraft and battery files. The planner is for
# small electric UAVs; these bounds are wide enough for the largest electric UAVs flown
# and keep every model finite (a value like 1e308 otherwise overflows, or ends in NaN
# and inf deep inside a run). Each is checked when the file is loaded.

#: Any mass: empty aircraft, maximum take-off, one pack. NASA's solar Helios, the
#: largest electric UAV flown, weighed up to about 930 kg. [kg]
MASS_MAX_KG = 1000.0
#: Any airspeed or ground speed. Record-setting racing quadcopters have flown near
#: 130 m/s; small survey UAVs cruise at 5–30 m/s, and above ~100 m/s (Mach 0.3) the
#: incompressible drag polar stops holding anyway. [m/s]
SPEED_MAX_MS = 150.0
#: Least fixed-wing airspeed. The induced power B/V of the polar grows without bound as
#: V → 0; no wing, not even a paper dart, flies at 1 m/s. [m/s]
AIRSPEED_MIN_MS = 1.0
#: Least multirotor cruise ground speed: at 0.1 m/s a 1 km leg already lasts close to
#: three hours. (The top airspeed takes AIRSPEED_MIN_MS: the best-speed search of
#: ``check`` starts at 0.5 m/s.) [m/s]
GROUNDSPEED_MIN_MS = 0.1
#: Default climb and descent rates. Autopilot defaults are 1–3 m/s (ArduCopter
#: WPNAV_SPEED_UP 2.5 m/s, WPNAV_SPEED_DN 1.5 m/s); 50 m/s leaves room for racing
#: quadcopters. [m/s]
VERTICAL_SPEED_MAX_MS = 50.0
#: Any electric power (avionics and payload load, efficiency reference). A 1000 kg
#: multirotor hovers on some 200–400 kW. [W]
POWER_MAX_W = 1.0e6
#: Capacity of one pack: from a 1 mAh coin cell (smaller than any flight pack) to
#: 1000 Ah, far above the tens of Ah of the largest UAV packs. [mAh]
CAPACITY_MIN_MAH, CAPACITY_MAX_MAH = 1.0, 1.0e6
#: Continuous discharge rating. Marketed LiPo ratings stop near 150 C. [1/h]
DISCHARGE_C_MAX = 1000.0
#: Wing reference area: a 15 cm micro air vehicle has about 0.02 m², Helios (75 m span,
#: 2.4 m chord) about 180 m². [m²]
WING_AREA_MIN_M2, WING_AREA_MAX_M2 = 0.005, 500.0
#: Steepest bank of a sustained loiter turn (load factor 2). Autopilots default lower:
#: ArduPlane ROLL_LIMIT_DEG 45°, PX4 FW_R_LIM 50°. [deg]
LOITER_BANK_MAX_DEG = 60.0
#: Widest loiter circle: beyond 10 km a loiter is a route, not a hold. [m]
LOITER_RADIUS_MAX_M = 1.0e4
#: Rotor diameter: nano-quadcopter propellers are about 30 mm, the rotors of
#: crewed-size electric multicopters about 2 m (the existing 5 m bound stays). [m]
ROTOR_DIAMETER_MIN_M, ROTOR_DIAMETER_MAX_M = 0.02, 5.0
#: Static propeller coefficients (rev/s convention) lie near C_T 0.05–0.2 and C_P
#: 0.02–0.1 for small propellers (Brandt and Selig 2011); the lower bounds are 10 times
#: below that, where the rotor speed of the propeller model runs away. [unitless]
CT_MIN, CP_MIN = 0.005, 0.002
#: Rotor tip speed: small propellers run their tips at some 100–250 m/s; at 10 m/s a
#: rotor barely turns, and a tip at the speed of sound (340 m/s, ISA sea level) is
#: beyond the model. [m/s]
TIP_SPEED_MIN_MS, TIP_SPEED_MAX_MS = 10.0, 340.0
#: Maximum total thrust: a thrust-to-weight ratio of 10 on a 1000 kg aircraft. [N]
THRUST_MAX_N = 1.0e5
#: Lower end of a multirotor's airspeed range in the best-speed searches: it hovers at
#: 0 m/s, but the range speed search needs a positive start. [m/s]
MULTIROTOR_MIN_AIRSPEED_MS = 0.5
#: Least propulsion efficiency, battery to useful power: the propulsion fits allow no
#: less than 0.1–0.2; below 0.05 the aircraft is a heater. [unitless]
EFFICIENCY_MIN = 0.05

# --------------------------------------------------------------------------- battery

BATTERY_KEYS = {
    "name": S.Key(S.TEXT, required=True),
    "cells_series": S.Key(S.INTEGER, required=True, low=1, high=40),
    "cells_parallel": S.Key(S.INTEGER, default=1, low=1, high=100),
    "capacity_mah": S.between(CAPACITY_MIN_MAH, CAPACITY_MAX_MAH, required=True),
    "mass_kg": S.positive(required=True, high=MASS_MAX_KG),
    "max_discharge_c": S.positive(high=DISCHARGE_C_MAX),
    "internal_resistance_ohm": S.non_negative(high=10.0),
    "cell_voltage_empty_v": S.Key(S.NUMBER, default=3.5, low=2.0, high=4.2),
    "usable_fraction": S.Key(S.NUMBER, default=1.0, low=0.0, low_open=True, high=1.0),
    "model": S.Key(S.MAPPING),
    "circuit": S.Key(S.MAPPING),
    "thermal": S.Key(S.MAPPING),
    "chemistry": S.Key(S.TEXT, default="lipo"),
    "price": S.non_negative(high=1.0e9),  # any currency; keeps totals finite
    "count": S.Key(S.INTEGER, default=1, low=1, high=16),
    "source": S.Key(S.TEXT),
}

MODEL_KEYS = {
    # δ's unit follows ε and β (t = δ P^ε C^β), so only its magnitude is bounded: fitted
    # and literature values lie near 10–30, and within 1e±20 P^ε C^β stays finite
    "delta": S.between(1.0e-20, 1.0e20, required=True),
    "epsilon": S.Key(S.NUMBER, required=True, low=-3.0, high=0.5),
    "beta": S.Key(S.NUMBER, default=integral.LITERATURE_BETA, low=0.5, high=1.5),
    # extensions written by `endurance diagnose --out` (DESIGN §6)
    "temperature_coefficient_per_c": S.Key(S.NUMBER, default=0.0, low=-0.2, high=0.2),
    "reference_temperature_c": S.Key(S.NUMBER, default=25.0, low=-40, high=80),
    "fade_per_cycle": S.Key(S.NUMBER, default=0.0, low=-0.01, high=0.05),
    "cycle": S.Key(S.NUMBER, default=0.0, low=0.0, high=1.0e5),  # LiPo: 300–1000 cycles
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

    def extend_charge(self, base_as, temperature_c=None) -> np.ndarray:
        r"""The integral model's charge with the extensions applied sample by sample. [A s]

        :math:`\hat C(t) = (1 + \varphi n) \int_0^t (1 + k\,h(T))\, dC_0` with
        :math:`C_0` the integral model's own charge along the profile
        (:func:`planner.battery.integral.charge`) and :math:`h = \max(T_{ref} - T, 0)`
        at the mid-point of each interval: each increment of charge is scaled by
        the pack temperature of that moment, as diagnose fits it
        (:mod:`planner.diagnose.effects`). For a constant temperature this is
        ``charge_scale(T)·C_0``.

        Parameters
        ----------
        base_as : array_like
            :math:`C_0` per sample. [A s]
        temperature_c : array_like, optional
            Pack temperature, one finite value per sample (fill gaps with
            :func:`filled_temperature`); ``None``: no temperature correction. [°C]
        """
        base = np.asarray(base_as, dtype=float)
        if temperature_c is None or not self.temperature_coefficient_per_c:
            return self.charge_scale() * base
        scale = self.charge_scale(temperature_c)
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
                self.cells_series, self.capacity_mah * AS_PER_MAH))

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
        return self.total_capacity_mah * AS_PER_MAH

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

    def circuit_parameters(self):
        """The equivalent-circuit parameters of the installed packs (``circuit:`` block,
        with capacity and R0 from the pack where the block leaves them out)."""
        from planner.battery.circuit import CircuitParameters

        return CircuitParameters.from_pack(self)

    def thermal_parameters(self):
        """The lumped thermal parameters of the ``thermal:`` block (None without one)."""
        from planner.battery.thermal import ThermalParameters

        if self.thermal is None:
            return None
        return ThermalParameters.from_mapping(self.thermal, self.path or self.name)

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
    "empty_mass_kg": S.positive(required=True, high=MASS_MAX_KG),
    "battery": S.Key(S.TEXT),
    "efficiency": S.between(EFFICIENCY_MIN, 1.0, required=True),
    "system_power_w": S.non_negative(default=0.0, high=POWER_MAX_W),
    "climb_rate_ms": S.positive(high=VERTICAL_SPEED_MAX_MS),
    "descent_rate_ms": S.positive(high=VERTICAL_SPEED_MAX_MS),
    "max_takeoff_mass_kg": S.positive(high=MASS_MAX_KG),
    "efficiency_slope": S.Key(S.NUMBER, default=0.0, low=-1.0, high=1.0),
    "efficiency_reference_power_w": S.between(1.0, POWER_MAX_W),
    "cells_series_allowed": S.Key(S.LIST),
    "fixed_wing": S.Key(S.MAPPING),
    "multirotor": S.Key(S.MAPPING),
    "source": S.Key(S.TEXT),
}

FIXED_WING_KEYS = {
    "wing_area_m2": S.between(WING_AREA_MIN_M2, WING_AREA_MAX_M2, required=True),
    "cd0": S.Key(S.NUMBER, required=True, low=0.0, low_open=True, high=0.5),
    "k": S.Key(S.NUMBER, low=0.0, low_open=True, high=1.0),
    "aspect_ratio": S.Key(S.NUMBER, low=1.0, high=60.0),
    "oswald_efficiency": S.Key(S.NUMBER, low=0.3, high=1.0),
    "cruise_airspeed_ms": S.between(AIRSPEED_MIN_MS, SPEED_MAX_MS, required=True),
    "stall_speed_ms": S.between(AIRSPEED_MIN_MS, SPEED_MAX_MS),
    "max_airspeed_ms": S.between(AIRSPEED_MIN_MS, SPEED_MAX_MS),
    # at least min_loiter_radius() of the loiter airspeed and stall speed (_fixed_wing);
    # the default 60 m is widened to it when the aircraft is too fast to turn that tight
    "loiter_radius_m": S.positive(default=60.0, high=LOITER_RADIUS_MAX_M),
    "loiter_airspeed_ms": S.between(AIRSPEED_MIN_MS, SPEED_MAX_MS),
}

MULTIROTOR_KEYS = {
    "rotors": S.Key(S.INTEGER, required=True, low=1, high=32),
    "rotor_diameter_m": S.between(ROTOR_DIAMETER_MIN_M, ROTOR_DIAMETER_MAX_M, required=True),
    "ct": S.between(CT_MIN, 1.0),
    "cp": S.between(CP_MIN, 1.0),
    "drag_area_m2": S.non_negative(default=0.0, high=10.0),
    "power_model": S.Key(S.TEXT, choices=("propeller", "momentum")),
    "cruise_speed_ms": S.between(GROUNDSPEED_MIN_MS, SPEED_MAX_MS, default=5.0),
    "max_airspeed_ms": S.between(AIRSPEED_MIN_MS, SPEED_MAX_MS, default=15.0),
    "induced_factor": S.Key(S.NUMBER, default=1.15, low=1.0, high=2.0),
    "figure_of_merit": S.Key(S.NUMBER, low=0.2, high=1.0),
    "tip_speed_ms": S.between(TIP_SPEED_MIN_MS, TIP_SPEED_MAX_MS),
    "max_thrust_n": S.positive(high=THRUST_MAX_N),
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

    @property
    def min_airspeed_ms(self) -> float:
        """Least airspeed of steady flight. [m/s]

        Fixed-wing: the stall speed, else half the cruise airspeed. Multirotor:
        :data:`MULTIROTOR_MIN_AIRSPEED_MS` (it hovers; the bound keeps the best-speed
        searches away from zero).
        """
        if self.is_multirotor:
            return MULTIROTOR_MIN_AIRSPEED_MS
        fw = self.fixed_wing
        return fw.stall_speed_ms or 0.5 * fw.cruise_airspeed_ms

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


def min_loiter_radius(loiter_airspeed_ms: float, stall_speed_ms: float | None = None,
                      bank_max_deg: float = LOITER_BANK_MAX_DEG) -> float:
    r"""
    Tightest level loiter circle a fixed-wing can fly at its loiter airspeed. [m]

    Parameters
    ----------
    loiter_airspeed_ms : float
        Airspeed of the loiter. [m/s]
    stall_speed_ms : float, optional
        Wings-level stall speed; the stall speed in a turn rises as :math:`\sqrt n`. [m/s]
    bank_max_deg : float, default :data:`LOITER_BANK_MAX_DEG`
        Steepest bank allowed. [deg]

    Returns
    -------
    radius : float
        ``inf`` when the loiter airspeed is not above the stall speed. [m]

    Notes
    -----
    .. math:: r_{min} = rac{V^2}{g 	an\phi_{max}}, \qquad
              \cos\phi_{max} = \max\left(\cos\phi_{bank}, (V_s/V)^2
ight)

    Level coordinated turn (Anderson, *Aircraft Performance and Design*, ch. 6): the
    load factor is :math:`n = 1/\cos\phi` and must stay below :math:`(V/V_s)^2` so that
    the wing does not stall in the turn.
    """
    cos_max = np.cos(np.radians(bank_max_deg))
    if stall_speed_ms is not None:
        cos_max = max(cos_max, (stall_speed_ms / loiter_airspeed_ms) ** 2)
    if cos_max >= 1.0:
        return float("inf")
    tan_max = np.sqrt(1.0 - cos_max**2) / cos_max
    return float(loiter_airspeed_ms**2 / (G * tan_max))


def _fixed_wing(data: Any, where: str, problems: list[str]) -> FixedWing | None:
    n = len(problems)
    bad: set[str] = set()
    d = S.check_mapping(data, FIXED_WING_KEYS, where, "fixed_wing.", problems, bad)

    def given(key):  # present and valid on its own: usable in checks across keys
        return d[key] is not None and key not in bad

    k = d["k"]
    if k is None:
        if d["aspect_ratio"] is None or d["oswald_efficiency"] is None:
            problems.append("fixed_wing needs 'k' or both 'aspect_ratio' and "
                            "'oswald_efficiency' (K = 1/(π e AR))")
        elif given("aspect_ratio") and given("oswald_efficiency"):
            from planner.power import fixed_wing
            k = float(fixed_wing.induced_drag_factor(d["aspect_ratio"], d["oswald_efficiency"]))
    elif d["aspect_ratio"] is not None:
        problems.append("fixed_wing: give either 'k' or 'aspect_ratio'/'oswald_efficiency', "
                        "not both")
    stall = d["stall_speed_ms"] if given("stall_speed_ms") else None
    cruise = d["cruise_airspeed_ms"] if given("cruise_airspeed_ms") else None
    top = d["max_airspeed_ms"] if given("max_airspeed_ms") else None
    loiter = d["loiter_airspeed_ms"] if given("loiter_airspeed_ms") else None
    if stall is not None and cruise is not None and cruise <= stall:
        problems.append(f"fixed_wing.cruise_airspeed_ms ({cruise}) must be above "
                        f"stall_speed_ms ({stall})")
    if top is not None and stall is not None and top <= stall:
        problems.append(f"fixed_wing.max_airspeed_ms must be above the stall speed "
                        f"(fixed_wing.stall_speed_ms {stall:g} m/s), got {top!r}")
    elif top is not None and cruise is not None and top < cruise:
        problems.append(f"fixed_wing.max_airspeed_ms must be at least the cruise airspeed "
                        f"(fixed_wing.cruise_airspeed_ms {cruise:g} m/s), got {top!r}")
    if loiter is not None and stall is not None and loiter <= stall:
        problems.append(f"fixed_wing.loiter_airspeed_ms must be above the stall speed "
                        f"(fixed_wing.stall_speed_ms {stall:g} m/s), got {loiter!r}")
    elif loiter is not None and top is not None and loiter > top:
        problems.append(f"fixed_wing.loiter_airspeed_ms must be at most the maximum airspeed "
                        f"(fixed_wing.max_airspeed_ms {top:g} m/s), got {loiter!r}")
    if len(problems) > n:
        return None
    v_loiter = loiter or cruise
    radius = d["loiter_radius_m"]
    r_min = min_loiter_radius(v_loiter, stall)
    if data.get("loiter_radius_m") is None:  # the default circle, widened for a fast aircraft
        radius = max(radius, float(np.ceil(r_min * 10.0)) / 10.0)
    elif radius < r_min:
        above = f", above the stall speed {stall:g} m/s" if stall is not None else ""
        problems.append(f"fixed_wing.loiter_radius_m must be at least {r_min:.1f} m (a level "
                        f"turn at the loiter airspeed {v_loiter:g} m/s with at most "
                        f"{LOITER_BANK_MAX_DEG:g}° of bank{above}), got {radius!r}")
        return None
    return FixedWing(wing_area_m2=d["wing_area_m2"], cd0=d["cd0"], k=k,
                     cruise_airspeed_ms=cruise, stall_speed_ms=stall,
                     max_airspeed_ms=top, loiter_radius_m=radius,
                     loiter_airspeed_ms=loiter)


def _multirotor(data: Any, where: str, problems: list[str]) -> Multirotor | None:
    n = len(problems)
    bad: set[str] = set()
    d = S.check_mapping(data, MULTIROTOR_KEYS, where, "multirotor.", problems, bad)
    model = d["power_model"]
    if model is None:  # "infer", as ModelChain.infer_dc_model
        model = "propeller" if d["ct"] is not None and d["cp"] is not None else "momentum"
    missing = [key for key in POWER_MODEL_KEYS.get(model, ()) if d[key] is None]
    if missing:
        problems.append(f"multirotor.power_model '{model}' needs "
                        + " and ".join(f"'multirotor.{m}'" for m in missing))
    if (d["ct"] is None) != (d["cp"] is None):
        problems.append("multirotor: give both 'ct' and 'cp' or neither")
    cruise, top = d["cruise_speed_ms"], d["max_airspeed_ms"]
    if not bad & {"cruise_speed_ms", "max_airspeed_ms"} and cruise > top:
        problems.append(f"multirotor.cruise_speed_ms must be at most the maximum airspeed "
                        f"(multirotor.max_airspeed_ms {top:g} m/s), got {cruise!r}")
    if model == "momentum" and not bad & {"figure_of_merit", "induced_factor"}:
        # momentum theory: profile power P0/P_ideal = 1/FM − κ must not be negative
        from planner.power.momentum import DEFAULT_FIGURE_OF_MERIT
        fm, kappa = d["figure_of_merit"], d["induced_factor"]
        if fm is None and kappa * DEFAULT_FIGURE_OF_MERIT > 1.0:
            problems.append(f"multirotor.induced_factor must be at most "
                            f"{1.0 / DEFAULT_FIGURE_OF_MERIT:.3g} with the default "
                            f"figure of merit {DEFAULT_FIGURE_OF_MERIT:g} (profile power "
                            f">= 0), got {kappa!r}")
        elif fm is not None and kappa * fm > 1.0:
            problems.append(f"multirotor.figure_of_merit must be at most 1/induced_factor "
                            f"= {1.0 / kappa:.3g} (profile power >= 0), got {fm!r}")
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


# --------------------------------------------------------------------------- catalog

#: Top-level keys of a catalog file.
CATALOG_KEYS = {
    "packs": S.Key(S.LIST, required=True),
    "name": S.Key(S.TEXT),
    "source": S.Key(S.TEXT),
}


def catalog_from_mapping(data: Any, where: str) -> list[BatteryPack]:
    """Validate a catalog mapping (``packs:`` list of DESIGN §8 packs) and build the packs.

    Each pack is validated with :func:`planner.definitions.battery_from_mapping`
    under the name ``"{where}: packs[i]"``; every problem of every pack is reported
    at once in one line.

    Raises
    ------
    InputError
        A missing or empty ``packs`` list, an unknown top-level key, or any problem in
        any pack (``catalog.yaml: packs[2]: mass_kg must be > 0, got -1``).
    """
    d = S.check_mapping(data, CATALOG_KEYS, where)
    items = d["packs"]
    if not items:
        raise InputError(f"{where}: 'packs' is empty, expected a list of battery packs")
    packs, problems = [], []
    for i, item in enumerate(items):
        try:
            packs.append(battery_from_mapping(item, f"{where}: packs[{i}]"))
        except InputError as exc:
            problems.append(str(exc))
    if problems:
        raise InputError("; ".join(problems))
    return packs


def load_catalog(path: str | Path) -> list[BatteryPack]:
    """Load a pack catalog: a YAML file with a ``packs:`` list, or a folder of pack files.

    Parameters
    ----------
    path : str or Path
        A catalog file (``packs:`` list of battery mappings, DESIGN §8, each with
        optional ``price`` and ``count``), or a folder whose ``*.yaml``/``*.yml``
        files are single packs or catalogs themselves (read in name order).

    Returns
    -------
    list of BatteryPack
    """
    path = Path(path)
    if path.is_dir():
        files = sorted(p for p in path.iterdir()
                       if p.suffix.lower() in (".yaml", ".yml") and p.is_file())
        if not files:
            raise InputError(f"{path}: folder holds no pack files (*.yaml)")
        packs, problems = [], []
        for f in files:
            try:
                data = S.load_yaml(f)
                if isinstance(data, dict) and "packs" in data:
                    packs.extend(catalog_from_mapping(data, str(f)))
                else:
                    packs.append(battery_from_mapping(data, str(f)))
            except InputError as exc:
                problems.append(str(exc))
        if problems:
            raise InputError("; ".join(problems))
        return packs
    return catalog_from_mapping(S.load_yaml(path), str(path))



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
    "load_catalog",
    "catalog_from_mapping",
]
