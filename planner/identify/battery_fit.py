r"""Identify the integral capacity model δ, ε, β from measured discharges.

The fit follows [UAV23] eq. 18: least squares on

.. math:: \hat C_j(t_i)^\beta - C_j(t_i)^\beta
          = \int_0^{t_i} \frac{dt}{\delta P_j(t)^\varepsilon} - C_j(t_i)^\beta

over every sample *i* of every training experiment *j*, where :math:`C` is the
measured charge drawn (A·s) and :math:`P` the measured electric power (W). The
model itself is :mod:`planner.physics.battery.integral`; nothing of it is re-implemented
here. The layout follows pvlib's ``fit_pvefficiency_adr`` (start values, bounds
and scales declared at the top of :func:`fit_integral`, ``**kwargs`` passed to
:func:`scipy.optimize.least_squares`) and the failure handling follows scipy's
``curve_fit``: inputs are checked to be finite, no optimum raises
:class:`~planner.errors.FitError` with the solver's message, an indeterminate or
poor covariance gives a warning (:class:`scipy.optimize.OptimizeWarning`).

Choices (documented once, here)
-------------------------------
Measured data
    ``power_w`` is used where given, else ``voltage_v * current_a``. The charge
    drawn is ``consumed_mah`` (from its first sample) where given, else the
    trapezoid integral of ``current_a``. A power of zero is a rest: the model
    draws nothing, while the measured current still counts (a sensor offset
    shows up there). A column that is absent *or entirely empty* for an
    experiment counts as absent for it; a column with some missing or infinite
    samples is an error.
Default split
    [UAV23]'s: the experiments with the lowest and the highest
    time-averaged power train, all others validate (one or two experiments:
    all train, nothing validates). ``train=``/``validate=`` override it.
Parametrisation
    Internally the fit uses :math:`u = \ln \delta_{ref}` with
    :math:`\delta_{ref} = \delta P_{ref}^\varepsilon` (the run time scale at the
    reference power :math:`P_{ref}`, the geometric time-mean power of the
    training data), ε and β. This removes most of the δ–ε correlation; the
    results and their covariance are transformed back to δ, ε, β.
Standard errors
    Neighbouring samples of one discharge are not independent: the measured
    charge is integrated current, so current noise makes its error a random
    walk, and the lag-1 autocorrelation of the residuals is close to 1. The
    plain :math:`s^2 (J^T J)^{-1}` would be far too small, and an AR(1)
    effective sample size :math:`n(1-\rho)/(1+\rho)` still under-states the
    spread about twofold for such data (checked on synthetic data). The
    covariance is therefore a sandwich for a random-walk residual, per
    experiment *j*: :math:`r_i = \sum_{k \le i} e_k` with independent
    increments of variance :math:`\sigma_j^2 \Delta t_k`, so

    .. math:: \Sigma = (J^T J)^{-1} \Big[\sum_j \sigma_j^2 \sum_k \Delta t_k\,
              T_k T_k^T\Big] (J^T J)^{-1}, \qquad T_k = \sum_{i \ge k} J_i .

    :math:`\sigma_j^2` is the mean of :math:`(r_{i+m} - r_i)^2/(t_{i+m} - t_i)`
    with the lag *m* = :data:`RW_LAG_FRACTION` (1 %) of the experiment's
    samples (at least 1): long enough to see through short-range correlation
    of the increments (the trapezoid rule makes them MA(1), which halves the
    one-step variance), short against the record. On model-generated data the
    errors divided by these standard errors have unit spread. Smooth model
    error on real data is treated as a random walk of the same size, which
    errs on the safe (large) side. The plain i.i.d. value and the residuals'
    lag-1 autocorrelation are reported for comparison.
Poorly determined
    A parameter whose relative standard error exceeds
    :data:`RELATIVE_STDERR_LIMIT` (10 %: the rule of
    :func:`planner.identify.stats.poorly_determined`), a Jacobian that is singular or
    whose column-normalised condition number exceeds :data:`CONDITION_LIMIT`, or a
    parameter that ends on a bound: a warning, and the parameter is listed in
    :attr:`IntegralFit.poorly_determined`. 10 % because a battery fit's δ and ε set
    the endurance directly: a 10 % error in δ is a 10 % error in the flight time.
Fit status
    A parameter that ends on a bound of the solver, or outside its physical range
    (:data:`EPSILON_PHYSICAL`: the energy to empty :math:`E = \delta P^{1+\varepsilon}
    C^\beta` cannot grow with the power faster than :math:`P^{1/2}`, nor fall faster than
    :math:`P^{-3/2}`), is a **misfit** (``fit_status`` ``misfit: …``), not a value: the
    status names the parameter, where it ended, the validation error and the likely
    cause — one regime only (every training discharge draws one constant power, all at
    about the same), too little excitation (the training powers span less than
    :data:`MIN_POWER_SPAN`), or a model whose form does not fit. ``fit-battery`` writes the
    status into the pack file and exits 1.
Metrics (per experiment, every split)
    RMSE of :math:`r = C - \hat C` [mAh] ([UAV23] eq. 29); final normalised error
    :math:`R = r_{final} / C_{final} \cdot 100` [%] (eq. 30); time error
    [s] (eq. 20): predicted minus measured time to draw the measured final
    charge. Where the model has not drawn that charge by the end of the record,
    the predicted time is extrapolated at the experiment's mean stress rate
    (exact for a constant power). A positive time error means the model is slow
    to draw the charge: it over-predicts endurance.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Collection, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import OptimizeWarning, least_squares

from planner.io import record as rec
from planner.physics.battery import integral
from planner.errors import FitError, InputError
from planner.identify import stats
from planner.physics.units import AS_PER_MAH

__all__ = [
    "CONDITION_LIMIT",
    "MIN_DURATION_S",
    "MIN_SAMPLES",
    "RELATIVE_STDERR_LIMIT",
    "Experiment",
    "ExperimentMetrics",
    "IntegralFit",
    "default_split",
    "experiment_metrics",
    "fit_integral",
    "load_records",
    "prepare_experiments",
]

#: An experiment needs at least this many samples ... [unitless]
MIN_SAMPLES = 10
#: ... and at least this duration to be fitted or scored. [s]
MIN_DURATION_S = 60.0
#: Power samples between this negative value and 0 are sensor noise at rest,
#: below it they are charging, which the model does not describe. [W]
NEGATIVE_POWER_TOLERANCE_W = 0.5
#: Relative standard error above which a parameter is "poorly determined". [unitless]
RELATIVE_STDERR_LIMIT = 0.10
#: Lag of the differences that estimate the random-walk diffusion, as a
#: fraction of an experiment's samples (at least one sample). [unitless]
RW_LAG_FRACTION = 0.01
#: Condition number of the column-normalised Jacobian above which the fit is
#: "ill-conditioned". [unitless]
CONDITION_LIMIT = 1e6
#: Physical range of ε (module notes, "Fit status"): [UAV23]'s LiPo packs give −1.03 to
#: −1.1, a Peukert-like loss of energy with power. [unitless]
EPSILON_PHYSICAL = (-2.5, -0.5)
#: Least ratio of the highest to the lowest mean training power that excites ε. [unitless]
MIN_POWER_SPAN = 1.5
#: Largest coefficient of variation of the power within a discharge for it to count as a
#: constant-power one. [unitless]
CONSTANT_POWER_CV = 0.05

_PARAMS = ("delta", "epsilon", "beta")


# --------------------------------------------------------------------------- data

@dataclass(frozen=True, eq=False)
class Experiment:
    """One discharge, ready to fit (SI units, time from 0).

    Attributes
    ----------
    name : str
        Experiment id.
    source : str or None
        File (or other source) it came from, for messages.
    time_s : ndarray
        Time since the first sample. [s]
    power_w : ndarray
        Electric power drawn; ``<= 0`` is a rest. [W]
    charge_as : ndarray
        Measured charge drawn since the first sample. [A s]
    voltage_v : ndarray or None
        Pack terminal voltage where measured. [V]
    current_a : ndarray or None
        Pack current where measured (discharge positive). [A]
    """

    name: str
    source: str | None
    time_s: np.ndarray
    power_w: np.ndarray
    charge_as: np.ndarray
    voltage_v: np.ndarray | None = None
    current_a: np.ndarray | None = None

    @property
    def duration_s(self) -> float:
        """[s]"""
        return float(self.time_s[-1])

    @property
    def mean_power_w(self) -> float:
        """Time-averaged power, rests included. [W]"""
        p = np.clip(self.power_w, 0.0, None)
        return float(np.trapezoid(p, self.time_s) / self.duration_s)

    @property
    def final_charge_as(self) -> float:
        """[A s]"""
        return float(self.charge_as[-1])

    @property
    def label(self) -> str:
        """The experiment named for messages, with its file where known."""
        return f"{self.source}: experiment '{self.name}'" if self.source else \
            f"experiment '{self.name}'"


def load_records(paths: Sequence[str | os.PathLike]) -> list[tuple[str, pd.DataFrame]]:
    """Read flight-record CSV files (docs/record.md) for fitting.

    Each file is read with :func:`planner.io.record.read_record` (no derived
    columns: missing samples must be seen, not bridged). A file without an
    ``experiment`` column is one experiment named after the file stem.

    Returns
    -------
    list of (source, DataFrame)
    """
    out = []
    for path in paths:
        df = rec.read_record(path, derive=False)
        if "experiment" not in df.columns:
            df = df.assign(experiment=Path(path).stem)
        out.append((str(path), df))
    return out


def _frames(record) -> list[tuple[str | None, pd.DataFrame]]:
    if isinstance(record, pd.DataFrame):
        return [(None, record)]
    if isinstance(record, (str, os.PathLike)):
        return load_records([record])
    if isinstance(record, Sequence) and record and all(isinstance(r, Experiment)
                                                       for r in record):
        return record  # type: ignore[return-value]
    out: list[tuple[str | None, pd.DataFrame]] = []
    for item in record:
        if isinstance(item, pd.DataFrame):
            out.append((None, item))
        elif isinstance(item, tuple) and len(item) == 2:
            out.append(item)
        else:
            out.extend(load_records([item]))
    return out


def _column(sub: pd.DataFrame, name: str) -> np.ndarray | None:
    """The column as floats, or None when absent or entirely empty."""
    if name not in sub.columns:
        return None
    values = sub[name].to_numpy(dtype=float)
    if np.isnan(values).all():
        return None
    return values


def _row(sub: pd.DataFrame, i: int, source: str | None) -> str:
    """Name sample ``i`` of an experiment as :mod:`planner.io.record` does (CSV: file line)."""
    label = sub.index[i]
    if source and str(source).lower().endswith((".csv", ".csv.gz")) and isinstance(label,
                                                                                  (int, np.integer)):
        return f"row {label + 1} (line {label + 2})"
    return f"row {label!r}"


def _finite(values: np.ndarray, column: str, where: str, sub: pd.DataFrame,
            source: str | None) -> None:
    bad = ~np.isfinite(values)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise InputError(f"{where}: column '{column}' {_row(sub, i, source)}: "
                         f"expected a finite number, got {float(values[i]):g}")


def _measured_from_first(sub: pd.DataFrame) -> pd.DataFrame:
    """The experiment from its first row with every battery reading: a logger's first
    sample left unmeasured (a cycler's overflow value read as missing) is dropped; a gap
    later on is still an error (missing samples are seen, not bridged)."""
    cols = [c for c in ("voltage_v", "current_a", "power_w") if c in sub.columns]
    if not cols or len(sub) == 0:
        return sub
    ok = sub[cols].notna().all(axis=1).to_numpy()
    first = int(np.argmax(ok)) if ok.any() else 0
    return sub.iloc[first:] if first > 0 else sub


def _experiment(name: str, source: str | None, sub: pd.DataFrame) -> Experiment:
    where = f"{source}: experiment '{name}'" if source else f"experiment '{name}'"
    sub = _measured_from_first(sub)
    t = sub["time_s"].to_numpy(dtype=float)
    _finite(t, "time_s", where, sub, source)
    if len(t) < MIN_SAMPLES or t[-1] - t[0] < MIN_DURATION_S:
        raise InputError(f"{where}: too short to fit: {len(t)} samples over "
                         f"{t[-1] - t[0] if len(t) else 0:g} s (need at least {MIN_SAMPLES} "
                         f"samples and {MIN_DURATION_S:g} s)")
    if np.any(np.diff(t) < 0):
        i = int(np.flatnonzero(np.diff(t) < 0)[0]) + 1
        raise InputError(f"{where}: column 'time_s' {_row(sub, i, source)}: time goes "
                         "backwards; expected rows in time order")
    voltage = _column(sub, "voltage_v")
    current = _column(sub, "current_a")
    power = _column(sub, "power_w")
    consumed = _column(sub, "consumed_mah")
    if power is None:
        if voltage is None or current is None:
            raise InputError(f"{where}: no power: need column 'power_w' or both "
                             "'voltage_v' and 'current_a'")
        _finite(voltage, "voltage_v", where, sub, source)
        _finite(current, "current_a", where, sub, source)
        power = voltage * current
    else:
        if voltage is not None and current is not None:  # fill gaps from V·I
            power = np.where(np.isnan(power), voltage * current, power)
        _finite(power, "power_w", where, sub, source)
    if consumed is not None:
        _finite(consumed, "consumed_mah", where, sub, source)
        charge = (consumed - consumed[0]) * AS_PER_MAH
    elif current is not None:
        _finite(current, "current_a", where, sub, source)
        charge = rec.cumulative_trapezoid(current, t)
    else:
        raise InputError(f"{where}: no charge measurement: need column 'current_a' "
                         "(integrated) or 'consumed_mah'")
    negative = power < -NEGATIVE_POWER_TOLERANCE_W
    if negative.any():
        i = int(np.flatnonzero(negative)[0])
        raise InputError(f"{where}: column 'power_w' {_row(sub, i, source)}: negative power "
                         f"{power[i]:g} W (charging); the model describes discharge only: "
                         "expected power >= 0 W (0 = rest)")
    if not np.any(power > 0):
        raise InputError(f"{where}: the load is never on (power <= 0 W throughout)")
    if not charge[-1] > 0:
        raise InputError(f"{where}: the measured charge drawn is {charge[-1]:g} A·s at the end; "
                         "expected a discharge (current positive)")
    return Experiment(name=name, source=source, time_s=t - t[0],
                      power_w=np.where(power > 0, power, 0.0), charge_as=charge,
                      voltage_v=voltage, current_a=current)


def prepare_experiments(record, source: str | None = None,
                        only: Collection[str] | None = None,
                        short: list[str] | None = None,
                        named: Collection[str] = ()) -> list[Experiment]:
    """Split a flight record into checked :class:`Experiment` objects.

    Parameters
    ----------
    record : DataFrame, path, or sequence of DataFrames / paths / (source, DataFrame)
        Flight record(s), docs/record.md.
    source : str, optional
        Name of a DataFrame's origin for messages.
    only : collection of str, optional
        Keep only these experiment ids; the others are neither checked nor
        returned (e.g. short tests that neither train nor validate).
    short : list, optional
        Given, an experiment too short to fit that is not in ``named`` is left out and
        the reason appended to it, instead of raising (a stress test of a few samples
        beside the discharges of a default split).
    named : collection of str
        Experiments the user chose (training, validation): never left out.

    Raises
    ------
    InputError
        No power, no charge measurement, an experiment too short (fewer than
        :data:`MIN_SAMPLES` samples or shorter than :data:`MIN_DURATION_S`),
        negative (charging) power, non-finite values, or the same experiment id
        twice; the message names the file and the experiment.
    """
    frames = _frames(record)
    if frames and isinstance(frames[0], Experiment):
        return list(frames)  # type: ignore[arg-type]
    out: list[Experiment] = []
    seen: dict[str, str | None] = {}
    for src, df in frames:
        src = src if src is not None else source
        df = rec.validate_record(df, src)
        if rec.voltage_only(df):
            raise InputError(f"{src or 'data'}: missing required column 'current_a' "
                             f"({rec.NO_CURRENT}: a battery fit needs the current or power)")
        for key, sub in rec.experiments(df):
            name = str(key) if key is not None else (Path(src).stem if src else "1")
            if name in seen:
                raise InputError(f"{src or '<DataFrame>'}: experiment id '{name}' appears again "
                                 f"(already in {seen[name] or 'an earlier table'}); "
                                 "expected unique experiment ids")
            seen[name] = src
            if only is None or name in only:
                try:
                    out.append(_experiment(name, src, sub))
                except InputError as exc:
                    if short is None or name in named or "too short to fit" not in str(exc):
                        raise
                    short.append(str(exc))
    if not out and short:
        raise InputError(short[0])
    if not out and only is not None and seen:
        raise InputError(f"{source or next(iter(seen.values())) or '<DataFrame>'}: no experiment "
                         f"named {', '.join(map(repr, sorted(only)))}; the data hold "
                         f"{', '.join(map(repr, list(seen)[:8]))}{' …' if len(seen) > 8 else ''}")
    if not out:
        names = [str(src) for src, _ in frames if src is not None] or [source or "<DataFrame>"]
        raise InputError(f"{', '.join(names)}: no samples to fit")
    return out


def default_split(experiments: Sequence[Experiment]) -> tuple[list[str], list[str]]:
    """The split of [UAV23]: lowest and highest mean power train, the rest validate."""
    names = [e.name for e in experiments]
    if len(names) <= 2:
        return names, []
    power = np.array([e.mean_power_w for e in experiments])
    lo, hi = int(np.argmin(power)), int(np.argmax(power))
    if lo == hi:  # all equal
        hi = (lo + 1) % len(names)
    train = [names[i] for i in sorted({lo, hi})]
    return train, [n for n in names if n not in train]


def _resolve_split(experiments, train, validate) -> tuple[list[str], list[str]]:
    names = [e.name for e in experiments]

    def check(chosen, option):
        chosen = list(chosen)
        unknown = [c for c in chosen if c not in names]
        if unknown:
            raise InputError(f"{option}: no experiment named {', '.join(map(repr, unknown))} "
                             f"(experiments: {', '.join(names)})")
        return chosen

    if train is None and validate is None:
        return default_split(experiments)
    if train is not None:
        train = check(train, "train")
    if validate is not None:
        validate = check(validate, "validate")
    if train is None:
        train = [n for n in names if n not in validate]
    if validate is None:
        validate = [n for n in names if n not in train]
    both = sorted(set(train) & set(validate))
    if both:
        raise InputError(f"experiment(s) {', '.join(both)} given for both training and "
                         "validation; expected disjoint sets")
    if not train:
        raise InputError("no training experiment: expected at least one")
    return train, validate


# --------------------------------------------------------------------------- metrics

@dataclass(frozen=True)
class ExperimentMetrics:
    """How well the model predicts one experiment ([UAV23] eq. 20, 29, 30)."""

    experiment: str
    """Experiment id."""
    split: str
    """``"train"``, ``"validate"`` or ``"unused"``."""
    samples: int
    """Number of samples. [unitless]"""
    duration_s: float
    """Length of the record. [s]"""
    mean_power_w: float
    """Time-averaged power, rests included. [W]"""
    final_charge_mah: float
    """Measured charge drawn at the end, :math:`C_{final}`. [mAh]"""
    predicted_final_charge_mah: float
    """Model charge drawn at the end, :math:`\\hat C_{final}`. [mAh]"""
    rmse_mah: float
    """Root-mean-square of :math:`r = C - \\hat C` over the samples (eq. 29). [mAh]"""
    final_error_pct: float
    """:math:`r_{final}/C_{final} \\cdot 100` (eq. 30). [%]"""
    time_error_s: float
    """Predicted minus measured time to draw :math:`C_{final}` (eq. 20). [s]"""

    def to_dict(self) -> dict[str, Any]:
        """The metrics as a JSON-ready dict (the field names and units above)."""
        return asdict(self)


def _time_error(exp: Experiment, stress: np.ndarray, beta: float) -> float:
    target = float(integral.stress_from_charge(exp.final_charge_as, beta))
    t = exp.time_s
    if stress[-1] >= target:
        i = int(np.searchsorted(stress, target, side="left"))
        if i == 0:
            t_hat = float(t[0])
        else:
            s0, s1 = stress[i - 1], stress[i]
            frac = (target - s0) / (s1 - s0) if s1 > s0 else 1.0
            t_hat = float(t[i - 1] + frac * (t[i] - t[i - 1]))
    else:
        mean_rate = stress[-1] / exp.duration_s
        t_hat = exp.duration_s + (target - stress[-1]) / mean_rate if mean_rate > 0 else np.inf
    return t_hat - exp.duration_s


def experiment_metrics(exp: Experiment, delta: float, epsilon: float, beta: float,
                       split: str = "unused") -> ExperimentMetrics:
    """Score the model δ, ε, β on one experiment ([UAV23] eq. 20, 29, 30)."""
    c_hat = integral.charge(exp.time_s, exp.power_w, delta, epsilon, beta)
    r = exp.charge_as - c_hat
    stress = integral.stress_from_charge(c_hat, beta)
    c_final = exp.final_charge_as
    return ExperimentMetrics(
        experiment=exp.name, split=split, samples=len(exp.time_s),
        duration_s=exp.duration_s, mean_power_w=exp.mean_power_w,
        final_charge_mah=c_final / AS_PER_MAH,
        predicted_final_charge_mah=float(c_hat[-1]) / AS_PER_MAH,
        rmse_mah=float(np.sqrt(np.mean(r**2))) / AS_PER_MAH,
        final_error_pct=float(r[-1] / c_final * 100.0),
        time_error_s=float(_time_error(exp, np.asarray(stress, float), beta)))


# --------------------------------------------------------------------------- fit

class _Stack:
    """Training experiments concatenated for vectorised cumulative integrals."""

    def __init__(self, experiments: Sequence[Experiment], p_ref: float):
        self.t = np.concatenate([e.time_s for e in experiments])
        self.p = np.concatenate([e.power_w for e in experiments])
        self.c = np.concatenate([e.charge_as for e in experiments])
        lengths = np.array([len(e.time_s) for e in experiments])
        starts = np.concatenate(([0], np.cumsum(lengths)[:-1]))
        dt = np.diff(self.t)
        dt[starts[1:] - 1] = 0.0  # no integral across experiments
        self.half_dt = 0.5 * dt
        self.start_of = np.repeat(starts, lengths)
        self.starts, self.lengths = starts, lengths
        on = self.p > 0
        self.log_p = np.where(on, np.log(np.where(on, self.p / p_ref, 1.0)), 0.0)
        self.p_ref = p_ref
        c = np.clip(self.c, 0.0, None)
        self.log_c = np.where(c > 0, np.log(np.where(c > 0, c, 1.0)), 0.0)

    def cumulative(self, y: np.ndarray) -> np.ndarray:
        """Trapezoid integral of ``y`` from each experiment's start (axis 0)."""
        inc = self.half_dt.reshape((-1,) + (1,) * (y.ndim - 1)) * (y[1:] + y[:-1])
        cs = np.concatenate((np.zeros((1,) + y.shape[1:]), np.cumsum(inc, axis=0)))
        return cs - cs[self.start_of]

    def rate(self, u: float, epsilon: float) -> np.ndarray:
        delta = np.exp(u) * self.p_ref ** (-epsilon)
        return np.asarray(integral.stress_rate(self.p, delta, epsilon), float)


@dataclass(frozen=True)
class IntegralFit:
    """The integral capacity model fitted to measured discharges (:func:`fit_integral`):
    the parameters, their uncertainty, the split, the scores and the solver's report."""

    delta: float
    """δ of :math:`t = \\delta P^\\varepsilon C^\\beta`. [s W^-ε (A s)^-β]"""
    epsilon: float
    """ε, the power exponent. [unitless]"""
    beta: float
    """β, the charge exponent (the held value when ``"beta" in fixed``). [unitless]"""
    stderr: dict[str, float]
    """Standard error of ``delta``, ``epsilon`` and ``beta`` (random-walk sandwich, module
    notes); 0 for a held parameter, infinite for an indeterminate one. [units of each]"""
    correlation: list[list[float]]
    """Correlation matrix of δ, ε, β in that order (NaN where undefined). [unitless]"""
    fixed: list[str]
    """Names of the held parameters (``["beta"]`` or none)."""
    train: list[str]
    """Experiment ids fitted on."""
    validate: list[str]
    """Experiment ids scored only."""
    metrics: list[ExperimentMetrics]
    """The scores of every experiment, in the order of the data."""
    poorly_determined: list[str]
    """Parameters the training data do not determine (module notes, "Poorly determined")."""
    reference_power_w: float
    """:math:`P_{ref}`, the geometric time-mean power of the training data. [W]"""
    samples: int
    """Training samples fitted. [unitless]"""
    residual_rms: float
    """RMS of the stress residuals. [(A s)^β]"""
    stderr_method: str
    """How ``stderr`` was computed, in words."""
    stderr_iid: dict[str, float]
    """The plain i.i.d. standard errors, for comparison. [units of each]"""
    autocorrelation: float
    """Lag-1 autocorrelation of the residuals within the experiments, ρ. [unitless]"""
    condition_number: float
    """Condition number of the column-normalised Jacobian. [unitless]"""
    nfev: int
    """Residual evaluations of the solver. [unitless]"""
    message: str
    """The solver's message."""
    fit_status: str = "ok"
    """``ok``, or ``misfit: …`` naming each parameter on a bound or outside its physical
    range and the likely cause (module notes, "Fit status")."""
    misfit: tuple = ()
    """The misfits, each a dict: ``parameter``, ``value``, ``why``, ``cause``."""

    @property
    def well_determined(self) -> bool:
        """No parameter is poorly determined."""
        return not self.poorly_determined

    @property
    def charge_error_sd(self) -> float | None:
        """The spread of the model's charge error from one discharge to the next: the
        root mean square of the training experiments' final errors (eq. 30), as a
        fraction of the charge drawn; None without a finite one. [unitless]"""
        e = np.array([m.final_error_pct for m in self.metrics if m.split == "train"], float)
        e = e[np.isfinite(e)]
        return float(np.sqrt(np.mean((e / 100.0) ** 2))) if e.size else None

    @property
    def covariance(self) -> tuple[tuple[float, ...], ...] | None:
        """The covariance of δ, ε, β (standard errors × correlation; a held β has no
        variance), as a pack file's ``model.covariance``; None when it is
        indeterminate."""
        sd = np.array([self.stderr[k] for k in ("delta", "epsilon", "beta")], float)
        corr = np.array(self.correlation, float)
        if corr.shape != (3, 3) or not np.all(np.isfinite(sd)):
            return None
        corr = np.where(np.isfinite(corr), corr, 0.0)
        np.fill_diagonal(corr, 1.0)
        cov = corr * np.outer(sd, sd)
        cov = 0.5 * (cov + cov.T)
        if np.linalg.eigvalsh(cov).min() < -1e-9 * max(float(np.abs(cov).max()), 1e-300):
            return None
        return tuple(tuple(float(x) for x in row) for row in cov)

    @property
    def parameters(self) -> dict[str, float]:
        """``delta``, ``epsilon``, ``beta``: the keywords of
        :func:`planner.physics.battery.integral.charge` and :class:`IntegralModel`."""
        return {"delta": self.delta, "epsilon": self.epsilon, "beta": self.beta}

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form, without ``metrics`` (each has its own ``to_dict``), with
        ``well_determined``."""
        out = {k: getattr(self, k) for k in _FIT_KEYS}
        out["well_determined"] = self.well_determined
        out["misfit"] = [dict(m) for m in self.misfit]
        return {k: out[k] for k in (*_FIT_KEYS[:9], "well_determined", *_FIT_KEYS[9:])}


#: Fields of :class:`IntegralFit` in its JSON, ``metrics`` aside.
_FIT_KEYS = ("delta", "epsilon", "beta", "stderr", "correlation", "fixed", "train",
             "validate", "poorly_determined", "reference_power_w", "samples",
             "residual_rms", "stderr_method", "stderr_iid", "autocorrelation",
             "condition_number", "nfev", "message", "fit_status", "misfit")

#: Start values, bounds and scales of the fitted coordinates (δ's start is solved in
#: closed form; module notes, "Parametrisation").
_START = {"epsilon": -1.03, "beta": integral.LITERATURE_BETA}
_BOUNDS = {"log_delta_ref": (-np.inf, np.inf), "epsilon": (-3.0, 0.5), "beta": (0.5, 1.5)}
_SCALES = {"log_delta_ref": 0.01, "epsilon": 0.01, "beta": 0.01}


def fit_integral(record, *, beta: float | None = None, train: Sequence[str] | None = None,
                 validate: Sequence[str] | None = None, source: str | None = None,
                 **kwargs) -> IntegralFit:
    r"""
    Fit the integral capacity model to measured discharges ([UAV23] eq. 18).

    Parameters
    ----------
    record : DataFrame, path, or sequence of DataFrames / paths / :class:`Experiment`
        Flight record(s) with ``time_s``, power (``power_w`` or ``voltage_v``
        and ``current_a``) and charge (``current_a`` or ``consumed_mah``);
        several experiments are told apart by ``experiment`` (docs/record.md).
    beta : float, optional
        Hold β at this value (e.g. 0.9648, [UAV23]'s) and fit δ, ε only.
    train, validate : sequence of str, optional
        Experiment ids to fit on and to score only. Default: the [UAV23]
        split (lowest and highest mean power train, the rest validate); giving
        one of them makes the other "all the rest".
    source : str, optional
        Name of a DataFrame's origin, for messages.
    **kwargs
        Passed to :func:`scipy.optimize.least_squares` (e.g. ``max_nfev``,
        ``ftol``, ``x_scale``).

    Returns
    -------
    IntegralFit
        The parameters (``fit.parameters`` are the keywords of
        ``integral.charge``), their standard errors and correlation, the split,
        every experiment's metrics and the solver's diagnostics.

    Raises
    ------
    InputError
        Bad data (see :func:`prepare_experiments`) or an unknown experiment id.
    FitError
        The solver found no optimum (its message is given).

    Warns
    -----
    scipy.optimize.OptimizeWarning
        A parameter is poorly determined (relative standard error above
        :data:`RELATIVE_STDERR_LIMIT`, singular or ill-conditioned Jacobian,
        or a parameter on its bound).

    Notes
    -----
    Residual of sample *i* of training experiment *j*:
    :math:`\int_0^{t_i} dt/(\delta P_j^\varepsilon) - C_j(t_i)^\beta`, with
    the integral by the trapezoid rule, as :func:`planner.physics.battery.integral.charge`
    computes it. Every sample weighs the same. See the module notes for the
    parametrisation, the standard errors and the thresholds.
    """
    experiments = prepare_experiments(record, source)
    train, validate = _resolve_split(experiments, train, validate)
    by_name = {e.name: e for e in experiments}
    if beta is not None and not (_BOUNDS["beta"][0] <= beta <= _BOUNDS["beta"][1]):
        raise ValueError(f"beta must be in {list(_BOUNDS['beta'])}, got {beta}")
    problem = _StressProblem([by_name[n] for n in train], beta)
    res = problem.solve(**kwargs)
    u, eps, b = problem.unpack(res.x)
    delta = float(np.exp(u) * problem.p_ref ** (-eps))
    values = {"delta": delta, "epsilon": float(eps), "beta": float(b)}
    unc = _uncertainty(problem, res, delta)
    poorly = _poorly_determined(problem, res, values, unc)
    split_of = {n: "train" for n in train} | {n: "validate" for n in validate}
    metrics = [experiment_metrics(e, delta, float(eps), float(b), split_of.get(e.name, "unused"))
               for e in experiments]
    misfit = _misfits(problem, res, values, [by_name[n] for n in train], metrics)
    status = "ok" if not misfit else "misfit: " + "; ".join(
        f"{m['parameter']} {m['why']}: {m['cause']}" for m in misfit)
    if misfit:
        warnings.warn(f"fit_integral: {status}", OptimizeWarning, stacklevel=2)
    return IntegralFit(
        **values, stderr=unc.stderr, correlation=unc.correlation,
        fixed=["beta"] if problem.fix_beta else [], train=list(train),
        validate=list(validate), metrics=metrics, poorly_determined=poorly,
        reference_power_w=problem.p_ref, samples=int(res.fun.size),
        residual_rms=float(np.sqrt(unc.rss / res.fun.size)),
        stderr_method="random-walk sandwich", stderr_iid=unc.stderr_iid,
        autocorrelation=unc.autocorrelation, condition_number=unc.condition,
        nfev=int(res.nfev), message=str(res.message), fit_status=status,
        misfit=tuple(misfit))


def _misfits(problem: "_StressProblem", res, values: dict[str, float],
             trained: Sequence[Experiment], metrics) -> list[dict]:
    """The parameters on a bound or outside their physical range, with the likely cause
    (module notes, "Fit status")."""
    out = []
    for i, name in enumerate(problem.names):
        lo, hi = problem.lower[i], problem.upper[i]
        if name == "log_delta_ref" or not np.isfinite(lo):
            continue
        if np.isclose(res.x[i], lo, atol=1e-6) or np.isclose(res.x[i], hi, atol=1e-6):
            out.append({"parameter": name, "value": float(res.x[i]),
                        "why": f"ended on its bound {res.x[i]:g}"})
    eps = values["epsilon"]
    if "epsilon" not in {m["parameter"] for m in out} and not \
            EPSILON_PHYSICAL[0] <= eps <= EPSILON_PHYSICAL[1]:
        out.append({"parameter": "epsilon", "value": eps,
                    "why": (f"{eps:+.3f} is outside its physical range "
                            f"[{EPSILON_PHYSICAL[0]:g}, {EPSILON_PHYSICAL[1]:g}] (the energy to "
                            f"empty would go as P^{1 + eps:+.2f})")})
    if not out:
        return out
    cause = _likely_cause(trained)
    val = [m for m in metrics if m.split == "validate"]
    if val:
        worst = max(val, key=lambda m: abs(m.final_error_pct))
        cause += (f"; validation final error up to {worst.final_error_pct:+.0f} % "
                  f"({worst.experiment})")
    for m in out:
        m["cause"] = cause
    return out


def _likely_cause(trained: Sequence[Experiment]) -> str:
    """Why the training discharges cannot pin ε and β, in words."""
    powers = np.array([e.mean_power_w for e in trained])
    constant = []
    for e in trained:
        p = e.power_w[e.power_w > 0]
        constant.append(p.size > 0 and float(np.std(p) / np.mean(p)) < CONSTANT_POWER_CV)
    span = float(powers.max() / max(powers.min(), 1e-9)) if powers.size else 1.0
    listed = ", ".join(f"{p:.0f} W" for p in powers[:6])
    if all(constant) and span < MIN_POWER_SPAN:
        return (f"one regime only: every training discharge draws one constant power "
                f"({listed}); the power exponent needs discharges at clearly different "
                f"powers (at least {MIN_POWER_SPAN:g}× apart)")
    if span < MIN_POWER_SPAN:
        return (f"too little excitation: the training discharges' mean powers ({listed}) span "
                f"only {span:.2f}× (needs {MIN_POWER_SPAN:g}×)")
    return ("the model's form does not fit these discharges (the training powers span "
            f"{span:.1f}×): check the data for charging, rests or a pack change")


class _StressProblem:
    """The least-squares problem of :func:`fit_integral` in the fitted coordinates
    :math:`u = \\ln\\delta_{ref}`, ε and (unless held) β (module notes)."""

    def __init__(self, fit_on: Sequence[Experiment], beta: float | None):
        self.fix_beta = beta is not None
        self.beta = beta
        self.p_ref = _reference_power(fit_on)
        self.stack = _Stack(fit_on, self.p_ref)
        self.names = ["log_delta_ref", "epsilon"] + ([] if self.fix_beta else ["beta"])
        self.lower = np.array([_BOUNDS[n][0] for n in self.names])
        self.upper = np.array([_BOUNDS[n][1] for n in self.names])
        # closed-form δ_ref for the start ε, β: S ∝ 1/δ_ref is linear
        b0 = beta if self.fix_beta else _START["beta"]
        s_unit = self.stack.cumulative(self.stack.rate(0.0, _START["epsilon"]))
        y0 = np.asarray(integral.stress_from_charge(self.stack.c, b0), float)
        inv = np.dot(s_unit, y0) / np.dot(s_unit, s_unit)
        self.x0 = np.array([-np.log(inv), _START["epsilon"]] + ([] if self.fix_beta else [b0]))
        self.y_scale = float(np.max(np.abs(y0))) or 1.0

    def unpack(self, x) -> tuple[float, float, float]:
        """(u, ε, β) of a point of the fitted coordinates."""
        return x[0], x[1], (self.beta if self.fix_beta else x[2])

    def residual(self, x) -> np.ndarray:
        """Model stress minus measured :math:`C^\\beta`, scaled. [unitless]"""
        u, eps, b = self.unpack(x)
        s = self.stack.cumulative(self.stack.rate(u, eps))
        return (s - np.asarray(integral.stress_from_charge(self.stack.c, b), float)) \
            / self.y_scale

    def jacobian(self, x) -> np.ndarray:
        """Analytic Jacobian of :meth:`residual`. [unitless]"""
        u, eps, b = self.unpack(x)
        rate = self.stack.rate(u, eps)
        cols = [-rate, -self.stack.log_p * rate]
        s_cols = self.stack.cumulative(np.stack(cols, axis=1))
        out = [s_cols[:, 0], s_cols[:, 1]]
        if not self.fix_beta:
            cb = np.asarray(integral.stress_from_charge(self.stack.c, b), float)
            out.append(-cb * self.stack.log_c)
        return np.stack(out, axis=1) / self.y_scale

    def solve(self, **kwargs):
        """:func:`scipy.optimize.least_squares` from the start values; FitError without
        an optimum."""
        kwargs.setdefault("x_scale", np.array([_SCALES[n] for n in self.names]))
        kwargs.setdefault("jac", self.jacobian)
        kwargs.setdefault("method", "trf")
        try:
            res = least_squares(self.residual, self.x0, bounds=(self.lower, self.upper),
                                **kwargs)
        except ValueError as exc:  # e.g. residuals not finite at the start
            raise FitError(f"fit_integral: no optimum found: {exc}") from None
        if res.status <= 0 or not np.all(np.isfinite(res.x)):
            raise FitError(f"fit_integral: no optimum found: {res.message}")
        return res


def _reference_power(fit_on: Sequence[Experiment]) -> float:
    """Geometric time-mean of the training power while the load is on (100 W if it
    never is). [W]"""
    num = sum(np.trapezoid(np.where(e.power_w > 0, np.log(np.where(e.power_w > 0, e.power_w,
                                                                     1.0)), 0.0), e.time_s)
              for e in fit_on)
    den = sum(np.trapezoid((e.power_w > 0).astype(float), e.time_s) for e in fit_on)
    return float(np.exp(num / den)) if den > 0 else 100.0


@dataclass(frozen=True)
class _Uncertainty:
    """Standard errors and correlation of δ, ε, β (module notes, "Standard errors")."""

    stderr: dict[str, float]
    stderr_iid: dict[str, float]
    correlation: list[list[float]]
    autocorrelation: float
    condition: float
    singular: bool
    rss: float


def _uncertainty(problem: _StressProblem, res, delta: float) -> _Uncertainty:
    """The random-walk sandwich in the fitted coordinates
    (:func:`planner.identify.stats.random_walk_covariance`), taken to δ, ε, β by
    δ = exp(u) P_ref^-ε."""
    r = res.fun * problem.y_scale
    jac = problem.jacobian(res.x) * problem.y_scale
    stack = problem.stack
    cov_x, cov_iid, rho = stats.random_walk_covariance(
        jac, r, stack.t, stack.starts, stack.lengths, lag_fraction=RW_LAG_FRACTION)
    p = len(problem.names)
    g = np.zeros((3, p))
    g[0, 0], g[0, 1] = delta, -delta * np.log(problem.p_ref)
    g[1, 1] = 1.0
    if not problem.fix_beta:
        g[2, 2] = 1.0

    def natural(c):
        if cov_x.singular:
            return np.where(g @ g.T != 0, np.inf, 0.0)
        return g @ c @ g.T

    cov = natural(cov_x.matrix)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    sd_iid = np.sqrt(np.clip(np.diag(natural(cov_iid.matrix)), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    return _Uncertainty(
        stderr={k: float(sd[i]) for i, k in enumerate(_PARAMS)},
        stderr_iid={k: float(sd_iid[i]) for i, k in enumerate(_PARAMS)},
        correlation=np.where(np.isfinite(corr), corr, np.nan).tolist(),
        autocorrelation=float(rho), condition=float(cov_x.condition),
        singular=cov_x.singular, rss=float(np.dot(r, r)))


def _poorly_determined(problem: _StressProblem, res, values: dict[str, float],
                       unc: _Uncertainty) -> list[str]:
    """The free parameters the training data do not determine (module notes), with an
    :class:`~scipy.optimize.OptimizeWarning` that says why."""
    free = ["delta", "epsilon"] + ([] if problem.fix_beta else ["beta"])
    poorly: list[str] = []
    reasons: list[str] = []
    if unc.singular:
        poorly = list(free)
        reasons.append("the Jacobian is singular (the training data cannot tell the "
                       "parameters apart)")
    elif unc.condition > CONDITION_LIMIT:
        poorly = list(free)
        reasons.append(f"the Jacobian is ill-conditioned (condition number "
                       f"{unc.condition:.3g} > {CONDITION_LIMIT:g})")
    loose = stats.poorly_determined({k: values[k] for k in free}, unc.stderr,
                                    RELATIVE_STDERR_LIMIT)
    for k in loose:
        if k not in poorly:
            poorly.append(k)
            rel = unc.stderr[k] / abs(values[k]) if values[k] else np.inf
            reasons.append(f"{k} has a relative standard error of {100 * rel:.3g} % "
                           f"(> {100 * RELATIVE_STDERR_LIMIT:g} %)")
    for i, name in enumerate(problem.names):
        lo, hi = problem.lower[i], problem.upper[i]
        if np.isfinite(lo) and (np.isclose(res.x[i], lo, atol=1e-6)
                                or np.isclose(res.x[i], hi, atol=1e-6)):
            k = "epsilon" if name == "epsilon" else "beta"
            if k not in poorly:
                poorly.append(k)
            reasons.append(f"{k} ended on its bound {res.x[i]:g}")
    if poorly:
        hints = []
        if "epsilon" in poorly or "delta" in poorly:
            hints.append("train on experiments at clearly different powers")
        if "beta" in poorly and not problem.fix_beta:
            hints.append("or hold beta fixed (e.g. at the literature's 0.9648)")
        warnings.warn("fit_integral: poorly determined parameter(s) "
                      f"{', '.join(poorly)}: {'; '.join(reasons)}"
                      + (f"; {' '.join(hints)}" if hints else ""),
                      OptimizeWarning, stacklevel=3)
    return poorly
