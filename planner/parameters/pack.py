"""Battery packs: the integral capacity model's parameters and the pack file (DESIGN §8).

:func:`load_battery` is the one reader of pack files. Every file is validated when it is
loaded and every problem is reported at once in one line naming the file and the key
(:class:`planner.errors.InputError`); the ``circuit:`` and ``thermal:`` blocks become
typed objects then (:mod:`planner.parameters.blocks`). ``BATTERY_KEYS`` and ``MODEL_KEYS``
are the schema, with the bounds of :mod:`planner.physics.limits`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from planner.io import schema as S
from planner.physics.battery import integral
from planner.physics.battery.chemistry import CHEMISTRY_NAMES
from planner.physics.battery.circuit import CircuitParameters
from planner.physics.battery.thermal import ThermalParameters
from planner.errors import InputError
from planner.parameters.blocks import (
    CircuitBlock,
    circuit_block,
    circuit_to_mapping,
    thermal_from_mapping,
    thermal_to_mapping,
)
from planner.physics.limits import CAPACITY_MAX_MAH, CAPACITY_MIN_MAH, DISCHARGE_C_MAX, MASS_MAX_KG
from planner.physics.units import AS_PER_MAH

__all__ = ["BATTERY_KEYS", "MODEL_KEYS", "BatteryPack", "IntegralModel",
           "battery_from_mapping", "load_battery"]

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
    "chemistry": S.Key(S.TEXT, default="lipo", choices=CHEMISTRY_NAMES),
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
    # parameter covariance of the fit, rows and columns delta, epsilon, beta (written by
    # `endurance fit-battery`; the Monte Carlo of `check --uncertainty` samples it)
    "covariance": S.Key(S.LIST),
    "source": S.Key(S.TEXT),
}

#: Order of the rows and columns of ``model.covariance``.
COVARIANCE_PARAMETERS = ("delta", "epsilon", "beta")


def check_covariance(value, where: str, problems: list[str]):
    """``model.covariance`` → a 3×3 tuple of tuples, or None with the problem noted.

    It must be a symmetric 3×3 matrix of finite numbers (rows and columns δ, ε, β) that is
    positive semi-definite: a variance is never negative, in any direction.
    """
    key = "model.covariance"
    try:
        m = np.array(value, dtype=float)
    except (TypeError, ValueError):
        m = None
    if m is None or m.shape != (3, 3):
        problems.append(f"{key} must be a 3×3 list of numbers (rows and columns delta, "
                        "epsilon, beta)")
        return None
    if not np.all(np.isfinite(m)):
        problems.append(f"{key} must hold finite numbers")
        return None
    scale = float(np.max(np.abs(m))) or 1.0
    if not np.allclose(m, m.T, rtol=1e-6, atol=1e-12 * scale):
        problems.append(f"{key} must be symmetric")
        return None
    low = float(np.linalg.eigvalsh(m).min())
    if low < -1e-9 * scale:
        problems.append(f"{key} is not positive semi-definite (smallest eigenvalue "
                        f"{low:.3g}): no distribution has it")
        return None
    return tuple(tuple(float(x) for x in row) for row in m)


#: Largest cell count for which the literature start-value polynomials are used as such.
LITERATURE_MAX_CELLS = 6


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
    covariance : tuple of tuple of float or None
        Covariance of δ, ε, β from the fit (rows and columns in that order); None when
        the file stores none.
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
    covariance: tuple | None = None

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
        (:func:`planner.physics.battery.integral.charge`) and :math:`h = \max(T_{ref} - T, 0)`
        at the mid-point of each interval: each increment of charge is scaled by
        the pack temperature of that moment, as diagnose fits it
        (:mod:`planner.identify.diagnose.effects`). For a constant temperature this is
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
        if self.covariance is not None:
            out["covariance"] = [list(row) for row in self.covariance]
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
    circuit : CircuitBlock or None
        The ``circuit:`` block (:mod:`planner.parameters.blocks`).
    thermal : ThermalParameters or None
        The ``thermal:`` block.
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
    circuit: CircuitBlock | None = None
    thermal: ThermalParameters | None = None
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

    def circuit_parameters(self) -> CircuitParameters:
        """The equivalent-circuit parameters of the installed packs.

        The ``circuit:`` block (the defaults of :class:`CircuitBlock` without one), with
        the capacity and R0 of the pack where the block leaves them out (converted per
        cell); ``count`` packs in parallel add to ``cells_parallel``.
        """
        n_s, n_p = int(self.cells_series), int(self.cells_parallel)
        r_pack = self.internal_resistance_ohm
        params = (self.circuit or CircuitBlock()).parameters(
            capacity_ah=self.capacity_mah / 1000.0 / n_p,
            r0_ohm=None if r_pack is None else r_pack * n_p / n_s,
            cells_series=n_s, cells_parallel=n_p, where=str(self.path or self.name))
        if self.count > 1:
            params = replace(params, cells_parallel=params.cells_parallel * self.count)
        return params

    def thermal_parameters(self) -> ThermalParameters | None:
        """The lumped thermal parameters of the ``thermal:`` block (None without one)."""
        return self.thermal

    def to_mapping(self, folder: str | Path | None = None) -> dict[str, Any]:
        """The pack as a YAML-ready mapping (keys of DESIGN §8).

        ``folder``: where the mapping will be written; the ``circuit.ocv_csv`` path,
        relative to this pack's own file, is rewritten relative to it.
        """
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
        if self.circuit is not None:
            out["circuit"] = circuit_to_mapping(self.circuit)
            csv = self.circuit.ocv_csv
            if folder is not None and csv and not Path(csv).is_absolute() and self.path:
                table = (Path(self.path).parent / csv).resolve()
                out["circuit"]["ocv_csv"] = os.path.relpath(table, Path(folder).resolve())
        if self.thermal is not None:
            out["thermal"] = thermal_to_mapping(self.thermal)
        if self.source:
            out["source"] = self.source
        return out


def battery_from_mapping(data: Any, where: str, base_dir: str | Path | None = None
                         ) -> BatteryPack:
    """Validate a battery mapping (DESIGN §8) and build the pack.

    Parameters
    ----------
    data : mapping
    where : str
        The file (and entry), for messages.
    base_dir : str or Path, optional
        Folder that relative paths in the mapping (``circuit.ocv_csv``) are read from;
        default the folder of ``where``.
    """
    problems: list[str] = []
    d = S.check_mapping(data, BATTERY_KEYS, where, problems=problems)
    model = None
    if d["model"] is not None:
        m = S.check_mapping(d["model"], MODEL_KEYS, where, "model.", problems)
        cov = (None if m.get("covariance") is None
               else check_covariance(m["covariance"], where, problems))
        if not problems:
            model = IntegralModel(m["delta"], m["epsilon"], m["beta"], literature=False,
                                  temperature_coefficient_per_c=m["temperature_coefficient_per_c"],
                                  reference_temperature_c=m["reference_temperature_c"],
                                  fade_per_cycle=m["fade_per_cycle"], cycle=m["cycle"],
                                  source=m["source"], covariance=cov)
    if problems:
        raise InputError(f"{where}: " + "; ".join(problems))
    circuit = None if d["circuit"] is None else circuit_block(d["circuit"], where, base_dir)
    thermal = None if d["thermal"] is None else thermal_from_mapping(d["thermal"], where)
    return BatteryPack(name=d["name"], cells_series=d["cells_series"],
                       cells_parallel=d["cells_parallel"], capacity_mah=d["capacity_mah"],
                       mass_kg=d["mass_kg"], max_discharge_c=d["max_discharge_c"],
                       internal_resistance_ohm=d["internal_resistance_ohm"],
                       cell_voltage_empty_v=d["cell_voltage_empty_v"],
                       usable_fraction=d["usable_fraction"], model=model,
                       circuit=circuit, thermal=thermal, chemistry=d["chemistry"],
                       price=d["price"], count=d["count"], source=d["source"], path=where)


def load_battery(path: str | Path) -> BatteryPack:
    """Load and validate a battery-pack YAML file."""
    return battery_from_mapping(S.load_yaml(path), str(path))
