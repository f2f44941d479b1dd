r"""Identification of the equivalent-circuit and thermal parameters from test data.

Functions take plain arrays (time [s], voltage [V], current [A], discharge
positive; temperature [°C], heat [W]) of whatever was measured — a cell or a
pack — and return the fitted values with standard errors. Conversions to per
cell values are done by :func:`fit_pulse_test`.

* R0 from the voltage step at each current edge (:func:`fit_r0_pulse_edges`,
  [HESS] eq. 3 and the amended VDA rule ``R = ΔV/ΔI`` of [UAV23] eq. 11).
* R1, C1 from the voltage during and after each short pulse, mainly the
  relaxation (:func:`fit_rc_relaxation`, least squares).
* OCV(SoC) from a low-rate discharge, and a low-rate charge when available
  (:func:`fit_ocv_low_rate`).
* OCV(SoC) and the DC resistance together from constant-current discharges at
  two or more rates, as a charger/discharger logs them
  (:func:`fit_rate_discharges`).
* Hysteresis γ and M from the voltage after current reversals
  (:func:`fit_hysteresis`).
* Thermal R_th and C_th from a temperature trace and the heat that drove it
  (:func:`fit_thermal`).

The pulse test's current profile is :func:`planner.identify.protocols.pulse_test_profile`.

Standard errors are the usual least-squares ones, ``s² (JᵀJ)⁻¹`` with
``s² = RSS/(n − p)``, propagated to derived quantities (``C1 = τ/R1``) by the
delta method. They assume white measurement noise; with correlated errors
they are optimistic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares, minimize_scalar
from scipy.signal import lfilter

from planner.physics.battery.circuit import CircuitParameters, simulate
from planner.physics.battery.ocv import OcvTable, ocv_table
from planner.physics.battery.thermal import lumped_temperature
from planner.errors import FitError, InputError
from planner.identify import stats


@dataclass
class Fit:
    """Fitted parameters with their standard errors.

    Attributes
    ----------
    params : dict
        Fitted values under the keyword names of the model (``r1_ohm``, ...).
    stderr : dict
        Standard error of each entry of ``params`` that has one.
    rmse : float
        Root-mean-square residual of the fit (unit of the fitted signal).
    n : int
        Number of samples used.
    details : dict
        Per-pulse (or per-edge) values behind the result.
    """

    params: dict[str, Any]
    stderr: dict[str, Any]
    rmse: float = float("nan")
    n: int = 0
    details: dict[str, Any] = field(default_factory=dict)


# --------------------------------------------------------------------------- helpers

def _arrays(time_s, *others, names=("voltage_v", "current_a")):
    t = np.asarray(time_s, dtype=float).ravel()
    out = [t]
    for arr, name in zip(others, names):
        a = np.asarray(arr, dtype=float).ravel()
        if a.size != t.size:
            raise InputError(f"{name} has {a.size} values, time_s has {t.size}")
        out.append(a)
    for arr, name in zip(out, ("time_s",) + tuple(names)):
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{name} has a non-finite value at sample "
                             f"{int(np.flatnonzero(~np.isfinite(arr))[0])}")
    if t.size < 3:
        raise InputError("need at least 3 samples")
    if np.any(np.diff(t) <= 0):
        raise InputError("time_s must increase")
    return out


def _charge_as(t, i):
    """Charge drawn before each sample, current held from each sample to the next. [A s]"""
    return np.r_[0.0, np.cumsum(i[:-1] * np.diff(t))]


def _cov(jac, rss):
    """:func:`planner.identify.stats.scaled_covariance`, s² (JᵀJ)⁻¹ with s² = RSS/(n − p),
    warning when the data cannot determine the parameters."""
    cov = stats.scaled_covariance(jac, rss)
    cov.warn_if_singular("the fit", RuntimeWarning, stacklevel=3)
    return cov.matrix


# --------------------------------------------------------------------------- R0

def _line_at(t, v, t_edge):
    """Value at ``t_edge`` of the least-squares line through (t, v); v[0] if one point."""
    if t.size < 2:
        return float(v[-1])
    x = t - t_edge
    _slope, icept = np.polyfit(x, v, 1)
    return float(icept)


def fit_r0_pulse_edges(time_s, voltage_v, current_a, *, min_step_a: float | None = None,
                       soc=None, edge_window_s: float = 1.0) -> Fit:
    r"""
    Ohmic resistance from the voltage step at each current edge.

    Parameters
    ----------
    time_s, voltage_v, current_a : array_like
        The record; sample ``k`` is the voltage with current ``i[k]`` flowing
        (held to the next sample). [s], [V], [A]
    min_step_a : float, optional
        Smallest current step taken as an edge; default half the largest step. [A]
    soc : array_like, optional
        State of charge per sample, reported per edge. [unitless]
    edge_window_s : float, default 1
        Length of record on each side of the edge through which a straight
        line is fitted and extrapolated to the edge; 0 = the single samples
        either side. [s]

    Returns
    -------
    Fit
        ``params['r0_ohm']`` the mean over edges, ``stderr['r0_ohm']`` its
        standard error; ``details`` per edge: ``time_s``, ``delta_i_a``,
        ``delta_v_v``, ``r0_ohm``, ``soc``.

    Notes
    -----
    .. math:: R_0 = -\frac{\hat v(t_k^+) - \hat v(t_k^-)}{i_k - i_{k-1}}

    ([HESS] eq. 3; [UAV23] eq. 11, ``R = ΔV/ΔI`` at the switching instant). The
    voltages just before and just after the edge are the values at the edge
    instant of straight lines fitted to ``edge_window_s`` of samples on each
    side (same current as the sample next to the edge): this removes the
    drift of the RC branch and the OCV within one sample interval and
    averages the measurement noise. The line must be short against the RC
    time constant.
    """
    t, v, i = _arrays(time_s, voltage_v, current_a)
    di = np.diff(i)
    if min_step_a is None:
        min_step_a = 0.5 * float(np.max(np.abs(di))) if di.size else 0.0
    if not min_step_a > 0:
        raise FitError("no current steps in the record: R0 needs current edges")
    edges = np.flatnonzero(np.abs(di) >= min_step_a) + 1
    if edges.size == 0:
        raise FitError(f"no current step of at least {min_step_a:g} A in the record")
    r0, dvs, dis = [], [], []
    n = t.size
    for k in edges:
        # pre-edge: samples k-1, k-2, ... with the current of k-1, within the window
        j0 = k - 1
        while j0 - 1 >= 0 and i[j0 - 1] == i[k - 1] and t[k] - t[j0 - 1] <= edge_window_s:
            j0 -= 1
        # the pre-edge samples describe the state at their own time; extrapolate to t_k
        v_pre = _line_at(t[j0:k], v[j0:k], t[k]) if k - j0 >= 2 else float(v[k - 1])
        j1 = k + 1
        while j1 < n and i[j1] == i[k] and t[j1] - t[k] < edge_window_s:
            j1 += 1
        v_post = _line_at(t[k:j1], v[k:j1], t[k]) if j1 - k >= 2 else float(v[k])
        dv = v_post - v_pre
        dvs.append(dv)
        dis.append(di[k - 1])
        r0.append(-dv / di[k - 1])
    r0 = np.asarray(r0)
    mean = float(np.mean(r0))
    se = float(np.std(r0, ddof=1) / math.sqrt(r0.size)) if r0.size > 1 else float("nan")
    details = {"time_s": t[edges], "delta_i_a": np.asarray(dis), "delta_v_v": np.asarray(dvs),
               "r0_ohm": r0}
    if soc is not None:
        details["soc"] = np.asarray(soc, dtype=float).ravel()[edges]
    return Fit({"r0_ohm": mean}, {"r0_ohm": se}, n=int(r0.size), details=details)


# --------------------------------------------------------------------------- R1, C1

def _pulses(i, t, thr, max_pulse_s, min_rest_s):
    """(start, end) sample indices of short pulses followed by a rest."""
    on = np.abs(i) > thr
    out = []
    k = 0
    n = i.size
    while k < n:
        if not on[k]:
            k += 1
            continue
        start = k
        while k < n and on[k]:
            k += 1
        end = k  # first rest sample
        rest_end = end
        while rest_end < n and not on[rest_end]:
            rest_end += 1
        if (end < n and t[end] - t[start] <= max_pulse_s
                and t[min(rest_end, n - 1)] - t[end] >= min_rest_s):
            out.append((start, end, rest_end))
    return out


def _rc_regressors(t, i, tau):
    """Columns of the window model for a given τ: 1, −q, −i, −g(τ), −decay(τ)."""
    dt = np.diff(t)
    q = np.r_[0.0, np.cumsum(i[:-1] * dt)]
    if np.allclose(dt, dt[0]):
        a = math.exp(-dt[0] / tau)
        g = np.r_[0.0, lfilter([1.0 - a], [1.0, -a], i[:-1])]
        decay = a ** np.arange(t.size)
    else:
        a = np.exp(-dt / tau)
        g = np.zeros(t.size)
        for k in range(t.size - 1):
            g[k + 1] = a[k] * g[k] + (1.0 - a[k]) * i[k]
        decay = np.r_[1.0, np.cumprod(a)]
    return np.column_stack([np.ones(t.size), -q, -i, -g, -decay])


def _fit_window(t, v, i, tau_bounds, r0_fixed=None, slope=True):
    """Variable-projection fit of one pulse window; returns values, covariance, rss."""
    cols = [c for c in (0, 1, 2, 3, 4) if (slope or c != 1) and (r0_fixed is None or c != 2)]

    def solve(log_tau):
        x = _rc_regressors(t, i, math.exp(log_tau))
        y = v if r0_fixed is None else v + r0_fixed * i
        beta, *_ = np.linalg.lstsq(x[:, cols], y, rcond=None)
        res = y - x[:, cols] @ beta
        return beta, float(res @ res)

    lo, hi = math.log(tau_bounds[0]), math.log(tau_bounds[1])
    grid = np.linspace(lo, hi, 41)
    rss = [solve(g)[1] for g in grid]
    j = int(np.argmin(rss))
    a, b = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
    opt = minimize_scalar(lambda g: solve(g)[1], bounds=(a, b), method="bounded",
                          options={"xatol": 1e-6})
    log_tau = float(opt.x)
    beta, rss_min = solve(log_tau)
    # Jacobian of the model in (beta..., log_tau)
    x = _rc_regressors(t, i, math.exp(log_tau))[:, cols]
    h = 1e-4
    xp = _rc_regressors(t, i, math.exp(log_tau + h))[:, cols]
    xm = _rc_regressors(t, i, math.exp(log_tau - h))[:, cols]
    d_tau = (xp @ beta - xm @ beta) / (2 * h)
    jac = np.column_stack([x, d_tau])
    cov = _cov(jac, rss_min)
    return beta, log_tau, cov, rss_min, (lo, hi)


def fit_rc_relaxation(time_s, voltage_v, current_a, *, r0_ohm: float | None = None,
                      soc=None, ocv=None, threshold_a: float | None = None,
                      max_pulse_s: float = 120.0, min_rest_s: float = 20.0,
                      pre_s: float = 5.0, tau_bounds_s: tuple[float, float] | None = None) -> Fit:
    r"""
    RC-branch resistance and capacitance from short pulses and their relaxation.

    Every pulse of at most ``max_pulse_s`` that is followed by at least
    ``min_rest_s`` of rest is fitted on its own window (``pre_s`` before the
    pulse to the end of the following rest) by least squares on

    .. math:: v_k = E_0 - s\,q_k - R_0 i_k - R_1 g_k(\tau) - v_{1,0}\, d_k(\tau)

    where ``q`` is the charge drawn since the window start (``s`` a local
    OCV slope, which also absorbs the small hysteresis change of a pulse),
    ``g`` the exact zero-order-hold response of the RC branch to the current
    with unit resistance and time constant ``τ``, and ``d`` the decay of the
    RC voltage left at the window start. For fixed ``τ`` the model is linear
    (variable projection); ``τ`` is found by a bounded 1-D search.
    ``C1 = τ/R1``. The results of all windows are pooled by inverse-variance
    weighting.

    Parameters
    ----------
    time_s, voltage_v, current_a : array_like
        [s], [V], [A]
    r0_ohm : float, optional
        Hold R0 at this value instead of fitting it in each window. [Ω]
    soc : array_like, optional
        State of charge per sample, reported per window. [unitless]
    ocv : callable, optional
        OCV(SoC) of what was measured (with ``soc``): its change within each
        window is subtracted and the local slope ``s`` is not fitted, which
        removes the main confounding of the RC response. [V]
    threshold_a : float, optional
        Current magnitude above which a sample is "on"; default 5 % of the
        largest current. [A]
    max_pulse_s, min_rest_s, pre_s : float
        Longest pulse fitted (longer discharges are skipped), shortest rest
        after it, and record kept before it. [s]
    tau_bounds_s : (float, float), optional
        Search range of τ; default (2 sample intervals, 2 × the longest window). [s]

    Returns
    -------
    Fit
        ``params``: ``r1_ohm``, ``c1_f``, ``tau1_s``, ``r0_ohm`` (pooled);
        ``details``: the per-window arrays.

    Raises
    ------
    FitError
        No pulse with a following rest in the record.
    """
    t, v, i = _arrays(time_s, voltage_v, current_a)
    thr = 0.05 * float(np.max(np.abs(i))) if threshold_a is None else float(threshold_a)
    pulses = _pulses(i, t, thr, max_pulse_s, min_rest_s)
    if not pulses:
        raise FitError("no short pulse followed by a rest in the record: R1 and C1 need "
                       f"pulses of at most {max_pulse_s:g} s with {min_rest_s:g} s of rest after")
    dt_min = float(np.min(np.diff(t)))
    ocv_v = None
    v_use = v
    if ocv is not None:
        if soc is None:
            raise InputError("fit_rc_relaxation: give soc together with ocv")
        ocv_v = np.asarray(ocv(np.asarray(soc, dtype=float).ravel()), dtype=float)
        v_use = v - ocv_v
    rows = []
    for start, end, rest_end in pulses:
        k0 = int(np.searchsorted(t, t[start] - pre_s))
        k0 = max(min(k0, start - 1), 0)
        k1 = min(rest_end, t.size)
        tw, vw, iw = t[k0:k1], v_use[k0:k1], i[k0:k1]
        bounds = tau_bounds_s or (2.0 * dt_min, 2.0 * (tw[-1] - tw[0]))
        beta, log_tau, cov, rss, (lo, hi) = _fit_window(tw, vw, iw, bounds, r0_ohm,
                                                        slope=ocv_v is None)
        names = [n for n in ("e0", "slope", "r0", "r1", "v10")
                 if (ocv_v is None or n != "slope") and (r0_ohm is None or n != "r0")]
        idx_r0 = names.index("r0") if "r0" in names else None
        idx_r1 = names.index("r1")
        r0 = beta[idx_r0] if idx_r0 is not None else r0_ohm
        r1 = beta[idx_r1]
        idx_tau = cov.shape[0] - 1
        tau = math.exp(log_tau)
        at_bound = min(log_tau - lo, hi - log_tau) < 1e-3
        c1 = tau / r1 if r1 > 0 else float("inf")
        var_r1 = cov[idx_r1, idx_r1]
        var_lt = cov[idx_tau, idx_tau]
        cov_rl = cov[idx_r1, idx_tau]
        # delta method for C1 = exp(log_tau) / R1
        g_r1, g_lt = -c1 / r1, c1
        var_c1 = g_r1 ** 2 * var_r1 + g_lt ** 2 * var_lt + 2 * g_r1 * g_lt * cov_rl
        rows.append({
            "start_s": tw[0], "pulse_a": float(np.mean(i[start:end])),
            "soc": float(np.asarray(soc, dtype=float).ravel()[start]) if soc is not None
            else float("nan"),
            "r0_ohm": float(r0),
            "r0_se": float(math.sqrt(cov[idx_r0, idx_r0])) if idx_r0 is not None else 0.0,
            "r1_ohm": float(r1), "r1_se": float(math.sqrt(max(var_r1, 0))),
            "tau_s": tau, "tau_se": tau * math.sqrt(max(var_lt, 0)),
            "c1_f": float(c1), "c1_se": float(math.sqrt(max(var_c1, 0))),
            "rmse": math.sqrt(rss / tw.size), "n": int(tw.size), "tau_at_bound": at_bound})
    details = {key: np.array([r[key] for r in rows]) for key in rows[0]}
    ok = (~details["tau_at_bound"]) & (details["r1_ohm"] > 0) & np.isfinite(details["c1_se"])
    if not np.any(ok):
        raise FitError("R1 and C1 are not identifiable from the pulses (time constant at the "
                       "search bound or R1 <= 0 in every window)")

    se_key = {"r1_ohm": "r1_se", "c1_f": "c1_se", "tau_s": "tau_se", "r0_ohm": "r0_se"}

    def pool(key):
        x, se = details[key][ok], details[se_key[key]][ok]
        if np.all(se > 0) and np.all(np.isfinite(se)):
            w = 1.0 / se ** 2
            return float(np.sum(w * x) / np.sum(w)), float(1.0 / math.sqrt(np.sum(w)))
        if x.size > 1:
            return float(np.mean(x)), float(np.std(x, ddof=1) / math.sqrt(x.size))
        return float(np.mean(x)), float("nan")

    params, stderr = {}, {}
    for key in ("r1_ohm", "c1_f", "tau_s", "r0_ohm"):
        name = "tau1_s" if key == "tau_s" else key
        params[name], stderr[name] = pool(key)
    rmse = float(np.sqrt(np.sum(details["rmse"] ** 2 * details["n"]) / np.sum(details["n"])))
    return Fit(params, stderr, rmse=rmse, n=int(np.sum(details["n"])), details=details)


# --------------------------------------------------------------------------- pulse test

def fit_pulse_test(time_s, voltage_v, current_a, *, capacity_ah: float, soc0: float = 1.0,
                   cells_series: int = 1, cells_parallel: int = 1, ocv=None,
                   hysteresis: bool = False, soc_tolerance: float = 0.03) -> Fit:
    """
    Per-cell R0(SoC), R1, C1 (and optionally γ, M) from a pulse test of a cell or pack.

    Steps: R0 at every current edge (:func:`fit_r0_pulse_edges`), grouped
    into a table against the state of charge; R1 and C1 from the pulse
    windows (:func:`fit_rc_relaxation`). With ``hysteresis=True`` (needs
    ``ocv``), the hysteresis is then fitted on the whole record
    (:func:`fit_hysteresis`; the pulse test's discharge→charge pulses are the
    reversals), its voltage subtracted, and R1 and C1 fitted again.

    Parameters
    ----------
    time_s, voltage_v, current_a : array_like
        The record of the tested cell or pack. [s], [V], [A]
    capacity_ah : float
        Capacity of what was tested (for the state of charge). [A h]
    soc0 : float
        State of charge at the start. [unitless]
    cells_series, cells_parallel : int
        Layout of what was tested (1, 1 for a cell).
    ocv : callable, optional
        Cell OCV(SoC), e.g. from :func:`fit_ocv_low_rate`. When given, the
        OCV change within each pulse window is subtracted instead of fitting
        a local slope, which makes R1 and C1 much better determined (on
        synthetic 1 C pulses with 0.5 mV noise the standard error of R1 falls
        from about 2.5 % to 1.5 %, and that of C1 from 2 % to 0.4 %); without
        it, a hysteresis change during the charge pulses also biases R1 and C1
        by a few per cent.
    hysteresis : bool, default False
        Also fit the hysteresis (see above).
    soc_tolerance : float
        Edges within this state of charge of each other form one R0 table point.

    Returns
    -------
    Fit
        ``params`` ready for a ``circuit:`` block (per cell): ``r0_ohm`` as
        ``{soc: [...], ohm: [...]}`` (a number with one state of charge),
        ``r1_ohm``, ``c1_f`` (and ``hysteresis_v``, ``hysteresis_gamma``);
        ``stderr`` the same keys (``r0_ohm`` a list per table point).
    """
    t, v, i = _arrays(time_s, voltage_v, current_a)
    if hysteresis and ocv is None:
        raise InputError("fit_pulse_test: hysteresis=True needs the ocv")
    soc = soc0 - _charge_as(t, i) / (capacity_ah * 3600.0)
    edges = fit_r0_pulse_edges(t, v, i, soc=soc)
    ocv_pack = None if ocv is None else (lambda s: cells_series * np.asarray(ocv(s)))
    rc = fit_rc_relaxation(t, v, i, soc=soc, ocv=ocv_pack)
    scale = cells_parallel / cells_series  # pack ohm -> cell ohm
    e_soc, e_r0 = edges.details["soc"], edges.details["r0_ohm"]
    order = np.argsort(-e_soc)
    groups: list[list[int]] = []
    for j in order:
        if groups and abs(e_soc[groups[-1][0]] - e_soc[j]) <= soc_tolerance:
            groups[-1].append(j)
        else:
            groups.append([j])
    tab_soc, tab_r0, tab_se = [], [], []
    for g in sorted(groups, key=lambda g: float(np.mean(e_soc[g]))):
        r = e_r0[g] * scale
        tab_soc.append(round(float(np.mean(e_soc[g])), 4))
        tab_r0.append(float(np.mean(r)))
        tab_se.append(float(np.std(r, ddof=1) / math.sqrt(len(g))) if len(g) > 1
                      else float("nan"))
    if len(tab_soc) == 1:
        r0_param: Any = tab_r0[0]
        r0_se: Any = tab_se[0]
    else:
        r0_param = {"soc": tab_soc, "ohm": tab_r0}
        r0_se = tab_se
    params = {"r0_ohm": r0_param, "r1_ohm": rc.params["r1_ohm"] * scale,
              "c1_f": rc.params["c1_f"] / scale}
    stderr = {"r0_ohm": r0_se, "r1_ohm": rc.stderr["r1_ohm"] * scale,
              "c1_f": rc.stderr["c1_f"] / scale}
    details = {"edges": edges.details, "windows": rc.details}
    if hysteresis:
        cell = CircuitParameters(capacity_ah=capacity_ah / cells_parallel,
                                 r0_ohm=r0_param if not isinstance(r0_param, dict)
                                 else (r0_param["soc"], r0_param["ohm"]),
                                 r1_ohm=params["r1_ohm"], c1_f=params["c1_f"], ocv=ocv,
                                 cells_series=cells_series, cells_parallel=cells_parallel)
        hf = fit_hysteresis(t, v, i, cell, soc0=soc0)
        with_h = replace(cell, hysteresis_v=hf.params["hysteresis_v"],
                         hysteresis_gamma=hf.params["hysteresis_gamma"])
        h_path = simulate(with_h, t, current_a=i, soc0=soc0,
                          hysteresis0_v=hf.params["h0_v"]).hysteresis_v
        rc = fit_rc_relaxation(t, v - h_path, i, soc=soc, ocv=ocv_pack)
        params.update(r1_ohm=rc.params["r1_ohm"] * scale, c1_f=rc.params["c1_f"] / scale,
                      hysteresis_v=hf.params["hysteresis_v"],
                      hysteresis_gamma=hf.params["hysteresis_gamma"])
        stderr.update(r1_ohm=rc.stderr["r1_ohm"] * scale, c1_f=rc.stderr["c1_f"] / scale,
                      hysteresis_v=hf.stderr["hysteresis_v"],
                      hysteresis_gamma=hf.stderr["hysteresis_gamma"])
        details["windows"] = rc.details
        details["hysteresis"] = hf
    return Fit(params, stderr, rmse=rc.rmse, n=t.size, details=details)


# --------------------------------------------------------------------------- OCV

def fit_ocv_low_rate(time_s, voltage_v, current_a, *, capacity_ah: float | None = None,
                     soc0: float = 1.0, resistance_ohm: float = 0.0, n_points: int = 51,
                     threshold_a: float | None = None) -> tuple[OcvTable, Fit]:
    r"""
    OCV(SoC) from a low-rate discharge (and charge, when the record has one).

    The state of charge comes from coulomb counting. On each branch the
    open-circuit voltage is estimated as ``v + R·i`` (``resistance_ohm``, the
    total DC resistance; 0 by default) and averaged in ``n_points`` SoC bins.
    When the record has both a discharge and a charge branch at the same
    magnitude of current, their mean cancels the resistive drop and a
    symmetric hysteresis, and half their gap is reported as
    ``params['half_gap_v']``. The result is made strictly increasing.

    Parameters
    ----------
    time_s, voltage_v, current_a : array_like
        [s], [V], [A]
    capacity_ah : float, optional
        Capacity for the state of charge; default the charge discharged
        in the record (a full discharge). [A h]
    soc0 : float
        State of charge at the start. [unitless]

    Returns
    -------
    table : OcvTable
    fit : Fit
        ``params``: ``capacity_ah`` used, ``half_gap_v`` (NaN with one
        branch); ``stderr``: ``ocv_v`` per bin (the spread within the bins).
    """
    t, v, i = _arrays(time_s, voltage_v, current_a)
    q = _charge_as(t, i)
    if capacity_ah is None:
        capacity_ah = float(np.max(q) - np.min(q)) / 3600.0
    if not capacity_ah > 0:
        raise FitError("the record draws no charge: cannot scale the state of charge")
    soc = soc0 - q / (capacity_ah * 3600.0)
    thr = 0.2 * float(np.max(np.abs(i))) if threshold_a is None else float(threshold_a)
    edges = np.linspace(0.0, 1.0, n_points + 1)
    centers = 0.5 * (edges[:-1] + edges[1:])
    branches = []
    for mask in (i > thr, i < -thr):
        if np.count_nonzero(mask) < 2 * n_points:
            continue
        s, est = soc[mask], v[mask] + resistance_ohm * i[mask]
        idx = np.clip(np.digitize(s, edges) - 1, 0, n_points - 1)
        mean = np.full(n_points, np.nan)
        se = np.full(n_points, np.nan)
        for b in range(n_points):
            sel = est[idx == b]
            if sel.size:
                mean[b] = sel.mean()
                se[b] = sel.std(ddof=1) / math.sqrt(sel.size) if sel.size > 1 else np.nan
        branches.append((mean, se))
    if not branches:
        raise FitError("no low-rate discharge or charge branch long enough in the record")
    if len(branches) == 2:
        both = np.isfinite(branches[0][0]) & np.isfinite(branches[1][0])
        ocv = np.where(both, 0.5 * (branches[0][0] + branches[1][0]), np.nan)
        se = np.where(both, 0.5 * np.hypot(branches[0][1], branches[1][1]), np.nan)
        half_gap = float(np.nanmean(0.5 * (branches[1][0] - branches[0][0])[both]))
    else:
        ocv, se = branches[0]
        half_gap = float("nan")
    keep = np.isfinite(ocv)
    if np.count_nonzero(keep) < 2:
        raise FitError("the record covers too little of the state of charge for an OCV table")
    s_k, v_k = centers[keep], ocv[keep]
    v_k = np.maximum.accumulate(v_k)
    v_k = v_k + 1e-6 * np.arange(v_k.size)   # strictly increasing
    table = ocv_table(s_k, v_k, where="fit_ocv_low_rate")
    return table, Fit({"capacity_ah": capacity_ah, "half_gap_v": half_gap},
                      {"ocv_v": se[keep]}, n=t.size, details={"soc": s_k})


# --------------------------------------------------------------------------- rates

#: Samples within this fraction of a discharge's level (the median loaded current)
#: make its constant-current phase.
CC_TOLERANCE = 0.10
#: Two current levels must differ by this factor to tell R from the OCV.
MIN_LEVEL_RATIO = 1.2


def current_level(current_a) -> float:
    """Level of a discharge: the median of its loaded samples (above half the
    largest current); 0 when it draws no current. [A]"""
    i = np.asarray(current_a, dtype=float)
    imax = float(np.max(i)) if i.size else 0.0
    if not imax > 0:
        return 0.0
    return float(np.median(i[i > 0.5 * imax]))


def fit_rate_discharges(discharges, *, capacity_ah: float | None = None, n_points: int = 40,
                        settle_s: float = 60.0, names=None) -> tuple[OcvTable, Fit]:
    r"""
    OCV(SoC) and the DC resistance from constant-current discharges at two or more rates.

    Each discharge starts full (SoC 1) and runs at a constant current, as a
    charger/discharger logs it; only the samples within :data:`CC_TOLERANCE`
    of the discharge's level are used (a constant-voltage tail at the cut-off,
    where the current tapers, and the ramp at the start are left out; the
    charge they draw still counts for the state of charge). At one state of charge the loaded voltage of a
    discharge at current :math:`I` is :math:`V = \mathrm{OCV}(z) - R\,I`, so
    two or more currents at the same :math:`z` separate the two: in each SoC
    bin where at least two current levels (:data:`MIN_LEVEL_RATIO` apart) have
    three or more settled samples each, :math:`V` is regressed on :math:`I`;
    :math:`R` is the median of the bins' slopes (robust to the few bins near
    the ends of the shorter discharges) and its standard error
    :math:`1.25\,s/\sqrt{n_{bins}}`. The OCV is then :math:`V + R I` averaged in
    every bin any discharge covers (and the rested voltage before the load,
    at SoC 1), made increasing.

    ``R`` is the resistance after ``settle_s`` of load: the ohmic R0 plus the
    polarisation that has built up by then (the DC resistance), the one that
    sets the voltage under a sustained load.

    Parameters
    ----------
    discharges : sequence of (time_s, voltage_v, current_a)
        [s], [V], [A] (discharge positive), each from full.
    capacity_ah : float, optional
        Capacity that scales the state of charge; default the largest charge
        delivered by any discharge (a full low-rate discharge). [A h]
    n_points : int
        SoC bins.
    settle_s : float
        Samples in the first ``settle_s`` of each discharge are left out of the
        regression (the polarisation is still building). [s]
    names : sequence of str, optional
        Names of the discharges for messages.

    Returns
    -------
    table : OcvTable
    fit : Fit
        ``params``: ``r0_ohm`` (the DC resistance), ``capacity_ah``;
        ``stderr``: ``r0_ohm``; ``rmse``: voltage residual of ``OCV(z) − R I``
        over the settled samples [V]; ``details``: ``levels_a``,
        ``soc_bins``, ``r_by_bin``.

    Raises
    ------
    FitError
        A discharge with fewer than 3 settled samples at its constant current,
        or currents that do not span two levels over a common range of state
        of charge.
    """
    names = list(names) if names is not None else [f"discharge {k + 1}"
                                                   for k in range(len(discharges))]
    data, levels = [], []
    for name, (t, v, i) in zip(names, discharges):
        t, v, i = _arrays(t, v, i)
        level = current_level(i)
        if not level > 0:
            raise FitError(f"{name}: draws no current")
        on_level = (np.abs(i - level) <= CC_TOLERANCE * level) & (t - t[0] >= settle_s)
        if on_level.sum() < 3:
            raise FitError(f"{name}: fewer than 3 samples at a constant current "
                           f"({level:.3g} A ± {100 * CC_TOLERANCE:.0f} %) after the first "
                           f"{settle_s:g} s")
        data.append((v, i, _charge_as(t, i), on_level))
        levels.append(level)
    if not data:
        raise FitError("no discharges given")
    q_max = max(float(d[2][-1]) for d in data)
    cap_as = (capacity_ah * 3600.0) if capacity_ah is not None else q_max
    if not cap_as > 0:
        raise FitError("the discharges draw no charge: cannot scale the state of charge")
    edges = np.linspace(0.0, 1.0, n_points + 1)
    soc, volt, cur, lev, rest = [], [], [], [], []
    for (v, i, q, loaded), level in zip(data, levels):
        z = 1.0 - q / cap_as
        soc.append(z[loaded])
        volt.append(v[loaded])
        cur.append(i[loaded])
        lev.append(np.full(int(loaded.sum()), level))
        rested = (i < 0.02 * level) & (q < 1e-3 * cap_as)
        rest.extend(v[rested].tolist())
    soc, volt, cur, lev = (np.concatenate(a) for a in (soc, volt, cur, lev))
    idx = np.clip(np.digitize(soc, edges) - 1, 0, n_points - 1)
    r_bins, z_bins = [], []
    for b in range(n_points):
        sel = idx == b
        if not sel.any():
            continue
        lv = lev[sel]
        lo, hi = lv <= lv.min() * MIN_LEVEL_RATIO ** 0.5, lv >= lv.max() / MIN_LEVEL_RATIO ** 0.5
        if lv.max() < MIN_LEVEL_RATIO * lv.min() or lo.sum() < 3 or hi.sum() < 3:
            continue
        a = np.c_[np.ones(int(sel.sum())), -cur[sel]]
        coef, *_ = np.linalg.lstsq(a, volt[sel], rcond=None)
        r_bins.append(float(coef[1]))
        z_bins.append(0.5 * (edges[b] + edges[b + 1]))
    if not r_bins:
        raise FitError("the resistance needs discharges at two or more currents (at least "
                       f"{MIN_LEVEL_RATIO:g}× apart) over a common range of state of charge; "
                       f"got levels {', '.join(f'{x:.3g} A' for x in levels)}")
    r_arr = np.asarray(r_bins)
    r = float(np.median(r_arr))
    if not r > 0:
        raise FitError(f"the fitted resistance is {1000 * r:.3g} mΩ: the voltage does not fall "
                       "with the current; check the current sign and the cell count")
    se = (1.2533 * float(np.std(r_arr, ddof=1)) / math.sqrt(r_arr.size)
          if r_arr.size > 1 else float("nan"))
    est = volt + r * cur
    centers = 0.5 * (edges[:-1] + edges[1:])
    ocv = np.array([est[idx == b].mean() if np.any(idx == b) else np.nan
                    for b in range(n_points)])
    keep = np.isfinite(ocv)
    s_k, v_k = list(centers[keep]), list(ocv[keep])
    if rest and (not s_k or s_k[-1] < 1.0):
        s_k.append(1.0)
        v_k.append(max(float(np.mean(rest)), v_k[-1] if v_k else -np.inf))
    if len(s_k) < 2:
        raise FitError("the discharges cover too little of the state of charge for an OCV "
                       "table")
    v_k = np.maximum.accumulate(np.asarray(v_k))
    v_k = v_k + 1e-6 * np.arange(v_k.size)   # strictly increasing
    table = ocv_table(s_k, v_k, where="fit_rate_discharges")
    resid = volt - (table(soc) - r * cur)
    return table, Fit({"r0_ohm": r, "capacity_ah": cap_as / 3600.0},
                      {"r0_ohm": se}, rmse=float(np.sqrt(np.mean(resid ** 2))), n=int(soc.size),
                      details={"levels_a": levels, "soc_bins": np.asarray(z_bins),
                               "r_by_bin": r_arr})


# --------------------------------------------------------------------------- hysteresis

def _unit_hysteresis(dq_abs_over_q, sign, gamma):
    """h with M = 1 and h0 = 0, and the decay of h0, for the exact per-step update.

    Step ``k`` (charge ``dq[k]``, current sign ``sign[k]``) takes ``h[k]`` to
    ``h[k+1] = e h[k] − (1 − e) sign[k]``, ``e = exp(−γ dq[k])``. Within a run
    of steps of one sign this is ``h = −s + (h_start + s) exp(−γ Σ dq)``, so
    each run is one vectorised expression.
    """
    n = sign.size
    h = np.zeros(n)
    steps_dq = dq_abs_over_q[:-1]
    steps_s = sign[:-1]
    dec = np.r_[1.0, np.exp(-gamma * np.cumsum(steps_dq))]
    if n < 2:
        return h, dec
    cuts = np.flatnonzero(np.diff(steps_s) != 0) + 1
    starts = np.r_[0, cuts]
    ends = np.r_[cuts, steps_s.size]
    h_start = 0.0
    for a, b in zip(starts, ends):
        sgn = steps_s[a]
        decay = np.exp(-gamma * np.cumsum(steps_dq[a:b]))
        h[a + 1:b + 1] = -sgn + (h_start + sgn) * decay
        h_start = h[b]
    return h, dec


def fit_hysteresis(time_s, voltage_v, current_a, params: CircuitParameters, *,
                   soc0: float = 1.0, temperature_c=25.0,
                   gamma_bounds: tuple[float, float] = (0.1, 5000.0)) -> Fit:
    r"""
    Hysteresis rate γ and magnitude M from the voltage after current reversals.

    The other parameters (OCV, R0, R1, C1, capacity) are taken as known: the
    record is simulated without hysteresis, and the residual
    ``r = v − v_no_hyst`` (pack) is fitted by ``n_s·h(t)``, where ``h``
    follows the exact per-step hysteresis update of
    :mod:`planner.physics.battery.circuit` from an unknown initial ``h0``. For fixed
    γ, ``M`` and ``h0`` enter linearly; γ is found by a bounded search on log γ.

    Parameters
    ----------
    time_s, voltage_v, current_a : array_like
        [s], [V], [A]
    params : CircuitParameters
        Known parameters (their hysteresis values are ignored).
    soc0 : float
    temperature_c : numeric
        Cell temperature, as in :func:`planner.physics.battery.circuit.simulate`. [°C]

    Returns
    -------
    Fit
        ``params``: ``hysteresis_gamma``, ``hysteresis_v`` (per cell), ``h0_v``.

    Raises
    ------
    FitError
        The record has no current reversal (charge ↔ discharge): γ is then
        not identifiable.
    """
    t, v, i = _arrays(time_s, voltage_v, current_a)
    thr = 0.05 * float(np.max(np.abs(i)))
    signs = np.sign(i[np.abs(i) > thr])
    reversals = int(np.count_nonzero(np.diff(signs) != 0))
    if reversals == 0:
        raise FitError("the record has no current reversal (charge <-> discharge): the "
                       "hysteresis rate gamma needs reversals")
    base = replace(params, hysteresis_v=0.0, hysteresis_gamma=0.0)
    sim = simulate(base, t, current_a=i, soc0=soc0, temperature_c=temperature_c)
    resid = v - sim.voltage_v
    ns, npar = params.cells_series, params.cells_parallel
    cap = params.capacity_ah * 3600.0 * np.asarray(params.capacity_factor(sim.temperature_c))
    icell = i / npar
    eta = np.where(icell < 0, params.coulombic_efficiency, 1.0)
    dq = np.abs(eta * icell * np.r_[np.diff(t), 0.0]) / cap
    sign = np.sign(icell)

    def solve(log_g):
        h, dec = _unit_hysteresis(dq, sign, math.exp(log_g))
        x = ns * np.column_stack([h, dec])
        beta, *_ = np.linalg.lstsq(x, resid, rcond=None)
        res = resid - x @ beta
        return beta, float(res @ res), x

    lo, hi = math.log(gamma_bounds[0]), math.log(gamma_bounds[1])
    grid = np.linspace(lo, hi, 49)
    rss = [solve(g)[1] for g in grid]
    j = int(np.argmin(rss))
    opt = minimize_scalar(lambda g: solve(g)[1], method="bounded",
                          bounds=(grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]),
                          options={"xatol": 1e-6})
    log_g = float(opt.x)
    beta, rss_min, x = solve(log_g)
    hstep = 1e-4
    d_g = (solve(log_g + hstep)[2] @ beta - solve(log_g - hstep)[2] @ beta) / (2 * hstep)
    cov = _cov(np.column_stack([x, d_g]), rss_min)
    gamma = math.exp(log_g)
    m_v, h0 = float(beta[0]), float(beta[1])
    if m_v < 0:
        raise FitError(f"fitted hysteresis magnitude is negative ({m_v:.4f} V): the record "
                       "does not show hysteresis of the expected sign")
    return Fit({"hysteresis_gamma": gamma, "hysteresis_v": m_v, "h0_v": h0},
               {"hysteresis_gamma": gamma * math.sqrt(max(cov[2, 2], 0)),
                "hysteresis_v": math.sqrt(max(cov[0, 0], 0)),
                "h0_v": math.sqrt(max(cov[1, 1], 0))},
               rmse=math.sqrt(rss_min / t.size), n=t.size,
               details={"reversals": reversals,
                        "gamma_at_bound": min(log_g - lo, hi - log_g) < 1e-3})


# --------------------------------------------------------------------------- thermal

def fit_thermal(time_s, temperature_c, heat_w, t_air_c, *, t0_c: float | None = None) -> Fit:
    r"""
    Thermal resistance and heat capacity from a temperature trace.

    Output-error least squares of :func:`planner.physics.battery.thermal.lumped_temperature`
    on the measured temperature, in ``(log R_th, log C_th, T0)``; the start
    values come from the ARX regression
    ``T[k+1] − T_air = a (T[k] − T_air) + c Q[k]``.

    Parameters
    ----------
    time_s : array_like [s]
    temperature_c : array_like
        Measured temperature. [°C]
    heat_w : numeric
        Heat that drove it, held from each sample to the next (e.g. ``I² R``). [W]
    t_air_c : numeric
        Air temperature. [°C]
    t0_c : float, optional
        Hold the initial temperature at this value instead of fitting it. [°C]

    Returns
    -------
    Fit
        ``params``: ``r_th_k_per_w``, ``c_th_j_per_k``, ``tau_s``, ``t0_c``.

    Raises
    ------
    FitError
        No heating in the record, or no convergence.
    """
    t, temp = _arrays(time_s, temperature_c, names=("temperature_c",))
    q = np.broadcast_to(np.asarray(heat_w, dtype=float), t.shape).astype(float)
    air = np.broadcast_to(np.asarray(t_air_c, dtype=float), t.shape).astype(float)
    if not np.any(q[:-1] != 0):
        raise FitError("the heat input is zero throughout: R_th and C_th need heating")
    dt = np.diff(t)
    # start values (ARX on a uniform-ish grid)
    y = temp[1:] - air[:-1]
    x = np.column_stack([temp[:-1] - air[:-1], q[:-1]])
    (a, c), *_ = np.linalg.lstsq(x, y, rcond=None)
    h = float(np.median(dt))
    if 0 < a < 1 and c > 0:
        r0 = c / (1 - a)
        tau0 = -h / math.log(a)
    else:
        r0 = max(float(np.max(temp - air)) / max(float(np.mean(q)), 1e-9), 1e-3)
        tau0 = (t[-1] - t[0]) / 5
    c0 = tau0 / r0
    fixed_t0 = t0_c is not None

    def model(theta):
        r, cth = math.exp(theta[0]), math.exp(theta[1])
        start = t0_c if fixed_t0 else theta[2]
        return lumped_temperature(t, q, air, r, cth, start)

    theta0 = [math.log(r0), math.log(c0)] + ([] if fixed_t0 else [float(temp[0])])
    sol = least_squares(lambda th: model(th) - temp, theta0, method="lm", x_scale="jac")
    if not sol.success:
        raise FitError(f"thermal fit did not converge: {sol.message}")
    rss = float(sol.fun @ sol.fun)
    cov = _cov(sol.jac, rss)
    r, cth = math.exp(sol.x[0]), math.exp(sol.x[1])
    se_lr, se_lc = math.sqrt(max(cov[0, 0], 0)), math.sqrt(max(cov[1, 1], 0))
    se_tau = r * cth * math.sqrt(max(cov[0, 0] + cov[1, 1] + 2 * cov[0, 1], 0))
    params = {"r_th_k_per_w": r, "c_th_j_per_k": cth, "tau_s": r * cth,
              "t0_c": float(t0_c) if fixed_t0 else float(sol.x[2])}
    stderr = {"r_th_k_per_w": r * se_lr, "c_th_j_per_k": cth * se_lc, "tau_s": se_tau,
              "t0_c": 0.0 if fixed_t0 else math.sqrt(max(cov[2, 2], 0))}
    return Fit(params, stderr, rmse=math.sqrt(rss / t.size), n=t.size)
