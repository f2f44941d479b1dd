"""Identify an aircraft's power parameters from flights.

The physics model driven by the measured flight state (the mission chain's
:meth:`~planner.chain.MissionChain.power_at` with the state of
:func:`planner.flightstate.from_record`) is fitted
to the measured electric power of the airborne samples by least squares
(:func:`scipy.optimize.least_squares`):

* multirotor — efficiency η (electrical → shaft), body drag area f and the
  system load P_S (the figure of merit stays as given: in hover it is not
  separable from η);
* fixed-wing — C_D0, K, η and P_S (η is separable from the polar only
  through climbs and descents; a poorly determined parameter is reported).

Standard errors come from the Jacobian, inflated for the autocorrelation of
neighbouring samples: the covariance is multiplied by (1 + ρ₁)/(1 − ρ₁), with
ρ₁ the lag-1 autocorrelation of the residuals (AR(1) effective sample size,
:func:`planner.stats.covariance`).

Validation never uses samples the fit saw: whole flights are held out where
there are several (``validate``), else the last 30 % of the single flight's
time. The error is reported before (the aircraft file as given) and after.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from planner import flightstate, record
from planner.chain import MissionChain
from planner.errors import FitError, InputError
from planner.parameters import Aircraft
from planner.stats import covariance

#: Parameters fitted, start-value source, bounds, per aircraft type.
PARAMETERS = {
    "multirotor": {"efficiency": (0.2, 1.0), "drag_area_m2": (0.0, 2.0),
                   "system_power_w": (0.0, 2000.0)},
    "fixed_wing": {"cd0": (0.002, 0.3), "k": (0.005, 0.5), "efficiency": (0.1, 1.0),
                   "system_power_w": (0.0, 2000.0)},
}
#: A parameter whose standard error exceeds this share of its value is "poorly determined".
POOR_RELATIVE_STDERR = 0.5


def get_param(aircraft: Aircraft, name: str) -> float:
    if name in ("efficiency", "system_power_w"):
        return float(getattr(aircraft, name))
    block = aircraft.multirotor if aircraft.is_multirotor else aircraft.fixed_wing
    return float(getattr(block, name))


def with_params(aircraft: Aircraft, values: dict[str, float]) -> Aircraft:
    """A copy of ``aircraft`` with the named parameters replaced."""
    top = {k: v for k, v in values.items() if k in ("efficiency", "system_power_w")}
    inner = {k: v for k, v in values.items() if k not in top}
    out = replace(aircraft, **top)
    if inner:
        if aircraft.is_multirotor:
            out = replace(out, multirotor=replace(aircraft.multirotor, **inner))
        else:
            out = replace(out, fixed_wing=replace(aircraft.fixed_wing, **inner))
    return out


@dataclass
class Samples:
    """Airborne samples of the power fit (stacked over experiments)."""

    experiment: np.ndarray
    time_s: np.ndarray
    airspeed: np.ndarray
    climb_rate: np.ndarray
    air_density: np.ndarray
    measured_w: np.ndarray
    dt: np.ndarray


def airborne_samples(data: pd.DataFrame, site_altitude_m: float = 0.0) -> Samples:
    """Flight state and measured power of the airborne samples of every experiment."""
    parts = []
    for exp_id, exp in record.experiments(data):
        exp = exp.reset_index(drop=True)
        if "power_w" not in exp or not {"climb_rate_ms", "groundspeed_ms"} & set(exp.columns):
            raise InputError(f"experiment {exp_id}: needs power and flight state "
                             "(climb_rate_ms, groundspeed_ms or airspeed_ms) to fit an aircraft")
        t = exp["time_s"].to_numpy(float)
        p = exp["power_w"].to_numpy(float)
        state = flightstate.from_record(exp, site_altitude_m)
        v, climb, rho, phase = (state.airspeed_ms, state.climb_rate_ms, state.air_density,
                                state.phase)
        ok = (phase != "ground") & (phase != "takeoff") & np.isfinite(p) & np.isfinite(v)
        dt = np.gradient(t) if len(t) > 1 else np.ones_like(t)
        parts.append((np.full(ok.sum(), str(exp_id), dtype=object), t[ok], v[ok], climb[ok],
                      rho[ok], p[ok], dt[ok]))
    parts = [part for part in parts if len(part[1])]
    if not parts:
        raise InputError("no airborne samples in the data (ground tests only?)")
    cols = [np.concatenate([part[i] for part in parts]) for i in range(7)]
    return Samples(*cols)


def _predict(aircraft: Aircraft, s: Samples, mass: np.ndarray) -> np.ndarray:
    return MissionChain(aircraft, None).power_at(s.airspeed, s.climb_rate, s.air_density, mass)


def _subset(s: Samples, mask: np.ndarray) -> Samples:
    return Samples(*(getattr(s, f)[mask] for f in Samples.__dataclass_fields__))


def split_experiments(s: Samples, validate: list[str] | None, train: list[str] | None):
    """Training and validation masks: whole flights, else the last 30 % of one flight."""
    ids = list(dict.fromkeys(s.experiment))
    if validate or train:
        unknown = set(validate or []) | set(train or [])
        unknown -= set(ids)
        if unknown:
            raise InputError(f"unknown experiment(s) {sorted(unknown)}; the data has "
                             f"{', '.join(ids[:10])}{' …' if len(ids) > 10 else ''}")
        both = set(validate or []) & set(train or [])
        if both:
            raise InputError(f"experiment(s) {sorted(both)} both train and validate; expected "
                             "held-out flights the fit has not seen")
        val = set(validate or []) or (set(ids) - set(train))
        trn = set(train or []) or (set(ids) - val)
        if not trn:
            raise InputError(f"no training flight left (the data has {', '.join(ids[:10])}); "
                             "expected at least one")
        return np.isin(s.experiment, list(trn)), np.isin(s.experiment, list(val)), "given"
    if len(ids) >= 2:
        val = set(ids[2::3]) or {ids[-1]}           # every third flight held out
        trn = set(ids) - val
        return (np.isin(s.experiment, list(trn)), np.isin(s.experiment, list(val)),
                "every third flight held out")
    cut = s.time_s.min() + 0.7 * (s.time_s.max() - s.time_s.min())
    return s.time_s < cut, s.time_s >= cut, "last 30 % of the flight held out"


def _metrics(pred, meas, dt):
    r = pred - meas
    e_m = float(np.sum(meas * dt))
    return {"rmse_w": float(np.sqrt(np.mean(r**2))), "bias_w": float(np.mean(r)),
            "energy_error_pct": 100.0 * float(np.sum(pred * dt) - e_m) / e_m if e_m else
            float("nan")}


def per_experiment_energy_error(aircraft, s: Samples, mass) -> dict[str, float]:
    """Energy error (predicted − measured, % of measured) of each flight's airborne part."""
    pred = _predict(aircraft, s, mass)
    out = {}
    for exp_id in dict.fromkeys(s.experiment):
        m = s.experiment == exp_id
        e_m = float(np.sum(s.measured_w[m] * s.dt[m]))
        out[str(exp_id)] = 100.0 * (float(np.sum(pred[m] * s.dt[m])) - e_m) / e_m
    return out


def fit_aircraft(data: pd.DataFrame, aircraft: Aircraft, *, mass_kg: float,
                 parameters: list[str] | None = None, train: list[str] | None = None,
                 validate: list[str] | None = None, site_altitude_m: float = 0.0,
                 **kwargs) -> dict[str, Any]:
    """Fit the aircraft's power parameters to measured flights.

    Parameters
    ----------
    data : DataFrame
        Flight record(s) with power and flight state.
    aircraft : Aircraft
        Start values and the fixed parameters.
    mass_kg : float
        All-up mass of the flights. [kg]
    parameters : list of str, optional
        Which of :data:`PARAMETERS` to fit (default all for the type).
    train, validate : list of str, optional
        Experiment ids; default: every third flight validates.
    **kwargs
        Passed to :func:`scipy.optimize.least_squares`.

    Returns
    -------
    dict
        ``aircraft`` (the fitted Aircraft), ``parameters``, ``stderr``,
        ``poorly_determined``, ``train``/``validation`` metrics before and after,
        ``per_experiment_energy_error_pct`` (before/after, validation flights),
        ``split``.
    """
    table = PARAMETERS[aircraft.type]
    names = parameters or list(table)
    unknown = set(names) - set(table)
    if unknown:
        raise InputError(f"cannot fit {sorted(unknown)} for a {aircraft.type}; "
                         f"expected some of {', '.join(table)}")
    s = airborne_samples(data, site_altitude_m)
    if len(s.measured_w) < 20:
        raise InputError(f"only {len(s.measured_w)} airborne samples: too few to fit "
                         "an aircraft (expected at least 20)")
    trn, val, how = split_experiments(s, validate, train)
    if trn.sum() < 10:
        raise InputError("the training split has fewer than 10 airborne samples")
    s_trn, s_val = _subset(s, trn), _subset(s, val)
    mass_trn = np.full(len(s_trn.time_s), float(mass_kg))
    x0 = np.array([get_param(aircraft, n) for n in names])
    lo = np.array([table[n][0] for n in names])
    hi = np.array([table[n][1] for n in names])
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
    scale = np.maximum(np.abs(x0), 1e-3)

    def residual(x):
        ac = with_params(aircraft, dict(zip(names, x)))
        return _predict(ac, s_trn, mass_trn) - s_trn.measured_w

    try:
        sol = least_squares(residual, x0, bounds=(lo, hi), x_scale=scale, **kwargs)
    except ValueError as exc:
        raise FitError(f"aircraft fit failed: {exc}") from None
    if not sol.success:
        raise FitError(f"aircraft fit did not converge: {sol.message}")
    fitted = with_params(aircraft, dict(zip(names, sol.x)))
    stderr, poor = _stderr(sol, names)
    result = {
        "aircraft": fitted, "parameters": dict(zip(names, map(float, sol.x))),
        "start": dict(zip(names, map(float, x0))), "stderr": stderr,
        "poorly_determined": poor, "split": how,
        "train_experiments": sorted(set(s_trn.experiment)),
        "validation_experiments": sorted(set(s_val.experiment)),
        "train": {"before": _metrics(_predict(aircraft, s_trn, mass_trn), s_trn.measured_w,
                                     s_trn.dt),
                  "after": _metrics(_predict(fitted, s_trn, mass_trn), s_trn.measured_w,
                                    s_trn.dt)},
        "samples": {"train": int(trn.sum()), "validation": int(val.sum())},
    }
    if val.sum() >= 2:
        mass_val = np.full(len(s_val.time_s), float(mass_kg))
        result["validation"] = {
            "before": _metrics(_predict(aircraft, s_val, mass_val), s_val.measured_w, s_val.dt),
            "after": _metrics(_predict(fitted, s_val, mass_val), s_val.measured_w, s_val.dt)}
        result["per_experiment_energy_error_pct"] = {
            "before": per_experiment_energy_error(aircraft, s_val, mass_val),
            "after": per_experiment_energy_error(fitted, s_val, mass_val)}
    return result


def _stderr(sol, names):
    cov = covariance(sol.jac, sol.fun)
    if cov.singular:
        warnings.warn("covariance of the aircraft fit is indeterminate (singular Jacobian)")
    stderr = dict(zip(names, map(float, cov.stderr)))
    poor = [k for k, v in zip(names, sol.x) if not np.isfinite(stderr[k])
            or stderr[k] > POOR_RELATIVE_STDERR * max(abs(v), 1e-12)]
    if poor:
        warnings.warn(f"poorly determined by these flights: {', '.join(poor)} "
                      f"(standard error above {POOR_RELATIVE_STDERR:.0%} of the value)")
    return stderr, poor
