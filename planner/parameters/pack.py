"""Battery packs: the integral capacity model's parameters and the pack file (docs/formats.md).

:func:`load_battery` is the one reader of pack files. Every file is validated when it is
loaded and every problem is reported at once in one line naming the file and the key
(:class:`planner.errors.InputError`); the ``circuit:`` and ``thermal:`` blocks become
typed objects then (:mod:`planner.parameters.blocks`). ``BATTERY_KEYS`` and ``MODEL_KEYS``
declare each key once (type, unit, bound from :mod:`planner.physics.limits`, default,
meaning): they validate the file, give :class:`BatteryPack` and :class:`IntegralModel`
their defaults and print the tables of ``docs/formats.md``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from planner.physics.battery.chemistry import CHEMISTRY_NAMES
from planner.io import files
from planner.io import schema as S
from planner.parameters.blocks import (
    CircuitBlock,
    circuit_block,
    circuit_to_mapping,
    thermal_from_mapping,
    thermal_to_mapping,
)
from planner.physics.battery import integral
from planner.physics.battery.circuit import CircuitParameters
from planner.physics.battery.thermal import ThermalParameters
from planner.physics import limits as L
from planner.physics.units import AS_PER_MAH

__all__ = ["BATTERY_KEYS", "MODEL_KEYS", "BatteryPack", "IntegralModel",
           "battery_from_mapping", "load_battery"]

BATTERY_KEYS = {
    "name": S.text("name shown in the reports", required=True),
    "cells_series": S.count(L.CELLS_SERIES_MAX, required=True, meaning="cells in series"),
    "cells_parallel": S.count(L.CELLS_PARALLEL_MAX, default=1, meaning="cells in parallel"),
    "capacity_mah": S.between(L.CAPACITY_MIN_MAH, L.CAPACITY_MAX_MAH, required=True, unit="mAh",
                              meaning="nominal capacity of one pack"),
    "mass_kg": S.positive(required=True, high=L.MASS_MAX_KG, unit="kg",
                          meaning="mass of one pack"),
    "max_discharge_c": S.positive(high=L.DISCHARGE_C_MAX, unit="1/h", meaning=(
        "continuous discharge rating (C rate): the current limit is C × capacity")),
    "internal_resistance_ohm": S.non_negative(high=L.PACK_RESISTANCE_MAX_OHM, unit="Ω",
                                              meaning="DC resistance of one pack"),
    "cell_voltage_empty_v": S.between(L.CELL_CUTOFF_MIN_V, L.CELL_CUTOFF_MAX_V, default=3.5,
                                      unit="V", meaning="cut-off voltage per cell, under load"),
    "usable_fraction": S.share(0.0, 1.0, default=1.0, low_open=True, meaning=(
        "share of the nominal capacity that may be drawn")),
    "model": S.block("fitted integral capacity model (table below; absent: the literature "
                     "start values)"),
    "circuit": S.block("equivalent circuit per cell (table below)"),
    "thermal": S.block("lumped thermal model (table below)"),
    "chemistry": S.text("cell chemistry: its OCV curve, voltage window and cold laws "
                        "(planner.physics.battery.chemistry)", default="lipo",
                        choices=CHEMISTRY_NAMES),
    "price": S.non_negative(high=L.PRICE_MAX, meaning="price of one pack, any currency (for `select`)"),
    "count": S.count(L.PACKS_MAX, default=1, meaning="identical packs flown in parallel"),
    "source": S.text("where the numbers come from"),
    "fit_status": S.text("what `fit-battery` said of its fit: `ok`, or `misfit: <parameter> …` "
                         "(read, not used)"),
}

MODEL_KEYS = {
    "delta": S.between(L.INTEGRAL_DELTA_MIN, L.INTEGRAL_DELTA_MAX, required=True, meaning=(
        "δ of t = δ P^ε C^β ([UAV23] eq. 14), t in s, P in W, C in A s")),
    "epsilon": S.between(L.INTEGRAL_EPSILON_MIN, L.INTEGRAL_EPSILON_MAX, required=True,
                         meaning="ε, the power exponent"),
    "beta": S.between(L.INTEGRAL_BETA_MIN, L.INTEGRAL_BETA_MAX, default=integral.LITERATURE_BETA,
                      meaning="β, the charge exponent"),
    # extensions written by `endurance diagnose --out` (docs/diagnose_real_flights.md)
    "temperature_coefficient_per_c": S.between(
        -L.CHARGE_TEMPERATURE_COEFF_MAX_PER_C, L.CHARGE_TEMPERATURE_COEFF_MAX_PER_C, default=0.0,
        unit="1/°C", meaning="relative rise of the charge drawn per °C below the reference"),
    "reference_temperature_c": S.between(
        L.MODEL_REFERENCE_TEMPERATURE_MIN_C, L.MODEL_REFERENCE_TEMPERATURE_MAX_C, default=25.0,
        unit="°C", meaning="reference temperature of `temperature_coefficient_per_c`"),
    "fade_per_cycle": S.between(L.FADE_PER_CYCLE_MIN, L.FADE_PER_CYCLE_MAX, default=0.0,
                                unit="1/cycle",
                                meaning="relative rise of the charge drawn per charge cycle"),
    "cycle": S.between(0.0, L.CYCLES_MAX, default=0.0, unit="cycles",
                       meaning="the pack's charge cycles, for `fade_per_cycle`"),
    # parameter covariance of the fit, rows and columns delta, epsilon, beta (written by
    # `endurance fit-battery`; the Monte Carlo of `check --uncertainty` samples it)
    "covariance": S.Key(S.LIST, meaning=(
        "3×3 covariance of δ, ε, β from `endurance fit-battery` (the uncertainty of "
        "`endurance check` samples it)")),
    "charge_error_sd": S.share(0.0, 0.5, meaning=(
        "spread of the model's charge error from one discharge to the next, a fraction of "
        "the charge drawn: the RMS final error on the training discharges, written by "
        "`endurance fit-battery` (the uncertainty of `endurance check` draws it)")),
    "source": S.text("where the numbers come from"),
}

_PACK = S.defaults(BATTERY_KEYS)
_MODEL = S.defaults(MODEL_KEYS)

#: Order of the rows and columns of ``model.covariance``.
COVARIANCE_PARAMETERS = ("delta", "epsilon", "beta")


def check_covariance(value, where: str, problems: S.Problems):
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
        problems.add(f"{key} must be a 3×3 list of numbers (rows and columns delta, "
                     "epsilon, beta)")
        return None
    if not np.all(np.isfinite(m)):
        problems.add(f"{key} must hold finite numbers")
        return None
    scale = float(np.max(np.abs(m))) or 1.0
    if not np.allclose(m, m.T, rtol=1e-6, atol=1e-12 * scale):
        problems.add(f"{key} must be symmetric")
        return None
    low = float(np.linalg.eigvalsh(m).min())
    if low < -1e-9 * scale:
        problems.add(f"{key} is not positive semi-definite (smallest eigenvalue "
                     f"{low:.3g}): no distribution has it")
        return None
    return tuple(tuple(float(x) for x in row) for row in m)


#: Largest cell count for which the literature start-value polynomials are used as such.
LITERATURE_MAX_CELLS = 6


@dataclass(frozen=True)
class IntegralModel:
    """Parameters of the integral capacity model ([UAV23] eq. 14) and its extensions.

    Each field but ``literature`` is the key of :data:`MODEL_KEYS` of that name (defaults
    from there).

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
    charge_error_sd : float or None
        Spread of the model's charge error from one discharge to the next, a fraction of
        the charge drawn (the fit's RMS final error on its training discharges); None
        when the file stores none. [unitless]
    """

    delta: float
    epsilon: float
    beta: float = _MODEL["beta"]
    literature: bool = False
    temperature_coefficient_per_c: float = _MODEL["temperature_coefficient_per_c"]
    reference_temperature_c: float = _MODEL["reference_temperature_c"]
    fade_per_cycle: float = _MODEL["fade_per_cycle"]
    cycle: float = _MODEL["cycle"]
    source: str | None = None
    covariance: tuple | None = None
    charge_error_sd: float | None = None

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
        """The ``model:`` block as a YAML-ready mapping (extensions only where set)."""
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
        if self.charge_error_sd is not None:
            out["charge_error_sd"] = float(self.charge_error_sd)
        if self.source:
            out["source"] = self.source
        return out


@dataclass(frozen=True)
class BatteryPack:
    """A battery pack (``docs/formats.md``). Capacity is per pack; ``count`` packs fly in
    parallel.

    Each field but ``path`` (the file it was read from) is the key of
    :data:`BATTERY_KEYS` of that name (unit and meaning there, defaults from there); a
    pack without ``model`` flies the literature start values
    (:meth:`IntegralModel.from_literature`).

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
    cells_parallel: int = _PACK["cells_parallel"]
    max_discharge_c: float | None = None
    internal_resistance_ohm: float | None = None
    cell_voltage_empty_v: float = _PACK["cell_voltage_empty_v"]
    usable_fraction: float = _PACK["usable_fraction"]
    model: IntegralModel | None = None
    circuit: CircuitBlock | None = None
    thermal: ThermalParameters | None = None
    chemistry: str = _PACK["chemistry"]
    price: float | None = None
    count: int = _PACK["count"]
    source: str | None = None
    path: str | None = None

    def __post_init__(self):
        if self.model is None:
            object.__setattr__(self, "model", IntegralModel.from_literature(
                self.cells_series, self.capacity_mah * AS_PER_MAH))

    # totals over `count` packs in parallel
    @property
    def total_capacity_mah(self) -> float:
        """Nominal capacity of the installed packs. [mAh]"""
        return self.capacity_mah * self.count

    @property
    def total_mass_kg(self) -> float:
        """Mass of the installed packs. [kg]"""
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
        """A copy of the pack with another integral model."""
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
        """The pack as a YAML-ready mapping (the keys of :data:`BATTERY_KEYS`).

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
        if self.chemistry != _PACK["chemistry"]:
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
    """Validate a battery mapping (:data:`BATTERY_KEYS`, :data:`MODEL_KEYS` and the
    blocks of :mod:`planner.parameters.blocks`) and build the pack.

    Parameters
    ----------
    data : mapping
    where : str
        The file (and entry), for messages.
    base_dir : str or Path, optional
        Folder that relative paths in the mapping (``circuit.ocv_csv``) are read from;
        default the folder of ``where``.

    Raises
    ------
    InputError
        Every problem of the mapping at once, in one line naming ``where`` and each key.
    """
    d, problems = S.check_definition(data, "battery pack", BATTERY_KEYS, where)
    model = None if d["model"] is None else _model(d["model"], where, problems)
    problems.done()
    circuit = None if d["circuit"] is None else circuit_block(d["circuit"], where, base_dir)
    thermal = None if d["thermal"] is None else thermal_from_mapping(d["thermal"], where)
    return BatteryPack(**S.fields_from(BatteryPack, d, model=model, circuit=circuit,
                                       thermal=thermal, path=where))


def _model(data: dict, where: str, problems: S.Problems) -> IntegralModel | None:
    """The ``model:`` block (None with its problems recorded)."""
    n = len(problems)
    m = S.check_mapping(data, MODEL_KEYS, where, "model.", problems)
    cov = (None if m["covariance"] is None
           else check_covariance(m["covariance"], where, problems))
    if len(problems) > n:
        return None
    return IntegralModel(**S.fields_from(IntegralModel, m, covariance=cov, literature=False))


def load_battery(path: str | Path) -> BatteryPack:
    """Load and validate a battery-pack YAML file (:func:`battery_from_mapping`)."""
    return battery_from_mapping(files.load_yaml(path, empty_ok=False), str(path))
