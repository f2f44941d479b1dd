r"""Direct evidence of ``diagnose``: what a record's own channels show without a model.

Two effects have a measurement of their own wherever the record carries the channels:

Current sensor against an independent power channel (``current_offset``)
    Where the logged power is not the logged voltage × the logged current (a power module
    that measures the power itself), the two sensors can be compared sample by sample:
    :math:`d = I - P/V` is the current the current sensor reads beyond the power channel's.
    Fitted as :math:`d = b + s\,P/V` by least squares (standard errors AR(1)-inflated
    within each experiment, :func:`planner.identify.stats.covariance`): a constant
    difference :math:`b` is a zero error of one sensor or a load between them; a
    proportional one :math:`s` is a scale (gain) error. :math:`b` is named when it lies
    :data:`MIN_Z` standard errors from zero and is at least :data:`MIN_OFFSET_SHARE` of the
    median current.

Pack resistance against the pack temperature (``temperature``)
    The terminal voltage of a pack is :math:`V = E(q) - R\,I`: over one sample interval
    the open-circuit voltage :math:`E` barely moves, so the voltage's step against the
    current's step measures the DC resistance, :math:`R_j = -\sum \Delta V \Delta I /
    \sum \Delta I^2` per experiment *j* (the first differences of the logged channels; the
    standard error from their residual, AR(1)-inflated). A cold pack's resistance rises
    as Arrhenius, :math:`\ln R = \ln R_{25} + (E_a/R_g)(1/T - 1/T_{25})` (Jaguemont,
    Boulon and Dubé 2016, Applied Energy 164, 99–114): a weighted regression of
    :math:`\ln R_j` on :math:`x_j = 1/T_j - 1/T_{25}` over the experiments
    (:math:`T_j` the current-weighted mean pack temperature), with a between-experiment
    variance :math:`\tau^2` for what differs from pack to pack (DerSimonian and Laird
    1986, Controlled Clinical Trials 7, 177–188, as a meta-regression). The coefficients'
    covariance is Knapp and Hartung's (2003, Statistics in Medicine 22, 2693–2710): the
    DerSimonian–Laird one scaled by the weighted residual variance
    :math:`q = \sum w_j (y_j - \hat y_j)^2 / (k - 2)` where q > 1 (the "modified" form,
    never narrower than DerSimonian–Laird's: Röver, Knapp and Friede 2015, BMC Medical
    Research Methodology 15, 99). With 16 flights τ² is itself uncertain, and the Wald
    error that takes it as known is too narrow (IntHout, Ioannidis and Borm 2014, BMC
    Medical Research Methodology 14, 25). It is named on
    the rules of the search (:mod:`planner.identify.diagnose.search`): held out
    experiment by experiment (leave one out), the prediction of :math:`\ln R_j` with the
    temperature must beat the one without by :data:`planner.identify.diagnose.search.MIN_GAIN_PCT`
    in RMS, with a one-sided sign-flip test p below
    :data:`planner.identify.diagnose.search.ALPHA_HELDOUT`; :math:`E_a` must lie
    :data:`MIN_Z` standard errors from zero and within :data:`ACTIVATION_RANGE_J_PER_MOL`.
"""

from __future__ import annotations

import math

import numpy as np

from planner.identify import stats

__all__ = ["ACTIVATION_RANGE_J_PER_MOL", "MIN_OFFSET_SHARE", "MIN_Z", "mode_changes",
           "power_channel", "resistance_temperature"]

#: Universal gas constant. [J/(mol K)]
R_GAS = 8.314462618
#: 25 °C. [K]
T25_K = 298.15
#: Least distance from zero of a named parameter, in standard errors. [unitless]
MIN_Z = 3.0
#: Least constant current difference that counts, as a share of the median current
#: (0.5 % of the charge drawn over a flight). [unitless]
MIN_OFFSET_SHARE = 0.005
#: Largest current-sensor zero error that is still a sensor's, as a share of the median
#: current (:data:`planner.identify.diagnose.effects.MAX_OFFSET_SHARE`). [unitless]
MAX_SENSOR_OFFSET_SHARE = 0.1
#: Largest median relative difference of the logged power and V·I for the power to count
#: as computed from the logged current. [unitless]
POWER_FROM_CURRENT_TOL = 1e-3
#: Plausible activation energy of a lithium cell's DC resistance: electrolyte
#: conduction some 10–20 kJ/mol, charge transfer 40–70 (Jaguemont et al. 2016). [J/mol]
ACTIVATION_RANGE_J_PER_MOL = (5_000.0, 100_000.0)
#: Least experiments with a resistance for the temperature regression. [unitless]
MIN_RESISTANCE_EXPERIMENTS = 4
#: Least spread of the experiments' mean pack temperatures. [°C]
MIN_RESISTANCE_SPREAD_C = 3.0
#: A current step counts for the resistance when larger than this share of the median
#: current. [unitless]
MIN_STEP_SHARE = 0.01


def _groups(df):
    if "experiment" not in df:
        return np.zeros(len(df), int)
    return df["experiment"].astype(str).to_numpy()


def power_channel(df) -> dict:
    """The logged power against the logged voltage × current (module notes).

    Returns ``{"independent": False}`` where the power is V·I of the logged current (or
    a channel is missing); else ``independent`` True with the fitted difference
    ``current_offset_a`` and its ``_stderr`` [A], the ``scale_difference`` and its
    ``_stderr`` [unitless], the ``median_current_a`` and ``median_voltage_v``, the
    ``samples`` and whether the offset is ``significant``.
    """
    if not {"power_w", "voltage_v", "current_a"} <= set(df.columns):
        return {"independent": False, "why": "the record has no power, voltage or current "
                                             "channel to compare"}
    p = df["power_w"].to_numpy(float)
    v = df["voltage_v"].to_numpy(float)
    i = df["current_a"].to_numpy(float)
    ok = np.isfinite(p) & np.isfinite(v) & np.isfinite(i) & (v > 0.5)
    vi = v * i
    big = ok & (np.abs(vi) > 1.0)
    if big.sum() < 10 or np.median(np.abs(p[big] - vi[big]) / np.abs(vi[big])) <= \
            POWER_FROM_CURRENT_TOL:
        return {"independent": False, "why": "the power is the logged voltage × the logged "
                                             "current, not a channel of its own"}
    i_p = p[ok] / v[ok]
    d = i[ok] - i_p
    X = np.column_stack([np.ones(d.size), i_p])
    coef, *_ = np.linalg.lstsq(X, d, rcond=None)
    r = d - X @ coef
    cov = stats.covariance(X, r, _groups(df)[ok])
    se = cov.stderr
    med_i = float(np.median(np.abs(i[ok])))
    b, sb = float(coef[0]), float(se[0])
    out = {"independent": True, "current_offset_a": b, "current_offset_a_stderr": sb,
           "scale_difference": float(coef[1]), "scale_difference_stderr": float(se[1]),
           "median_current_a": med_i, "median_voltage_v": float(np.median(v[ok])),
           "samples": int(ok.sum())}
    z = abs(b) / sb if sb > 0 else math.inf
    out["significant"] = bool(z >= MIN_Z and abs(b) >= MIN_OFFSET_SHARE * med_i)
    # the size the test above (|z| ≥ MIN_Z) passes with 80 % probability: √λ ≈ MIN_Z +
    # z_0.8 = 3.84 standard errors, not the 2.80 of a test at 5 %
    out["limit_a"] = max(math.sqrt(stats.noncentrality_for_power(1, critical=MIN_Z**2)) * sb
                         if math.isfinite(sb) else math.inf, MIN_OFFSET_SHARE * med_i)
    return out


def power_channel_finding(ev: dict) -> dict:
    """The ``current_offset`` finding of a significant :func:`power_channel` result."""
    b, sb = ev["current_offset_a"], ev["current_offset_a_stderr"]
    v = ev["median_voltage_v"]
    high = "high" if b > 0 else "low"
    params = {"current_offset_a": b, "current_offset_a_stderr": sb,
              "scale_difference": ev["scale_difference"],
              "scale_difference_stderr": ev["scale_difference_stderr"],
              "separate_load_w": b * v, "median_voltage_v": v,
              "drift_mah_per_hour": 1000.0 * b, "drift_mah_per_hour_stderr": 1000.0 * sb}
    scale = ""
    if abs(ev["scale_difference"]) > MIN_Z * ev["scale_difference_stderr"]:
        scale = (f"; beyond it the two disagree by {100 * ev['scale_difference']:+.1f} % of the "
                 "current (a scale error of one of them)")
    cause = (f"Current sensor reads {abs(b):.3f} ± {sb:.3f} A too {high} against the logged "
             f"power: the logged current minus the logged power / voltage is a constant "
             f"{b:+.3f} A over {ev['samples']} samples{scale}. Direct evidence: the power "
             "channel is logged independently of the current")
    return {"effect": "current_offset", "level": "sensors", "cause": cause,
            "parameters": params,
            "evidence": {"samples": float(ev["samples"]),
                         "z": abs(b) / sb if sb > 0 else math.inf},
            "alternatives": [f"a separate load of {abs(b) * v:.1f} W drawn between the power "
                             "sensor and the current sensor (the current sensor sees it, "
                             "the power channel does not)",
                             f"a zero error of the power channel of {-b * v:+.1f} W"],
            "added_after": [], "heldout": None, "unit": "A",
            "headline": (f"Current sensor {1000 * abs(b):.0f} mA too {high} against the "
                         "logged power (or a load between the two sensors)"),
            "driver": "logged current − logged power / voltage [A]"}


# ============================================================================ resistance

def experiment_resistance(current: np.ndarray, voltage: np.ndarray, temperature: np.ndarray
                          ) -> tuple[float, float, float] | None:
    """(R [Ω], its standard error [Ω], the current-weighted mean temperature [°C]) of one
    experiment from the first differences of its channels (module notes); None without
    current steps."""
    i = np.asarray(current, float)
    v = np.asarray(voltage, float)
    ok = np.isfinite(i) & np.isfinite(v)
    if ok.sum() < 20:
        return None
    di = np.diff(i[ok])
    dv = np.diff(v[ok])
    med = float(np.median(np.abs(i[ok])))
    step = np.abs(di) > MIN_STEP_SHARE * max(med, 1e-6)
    if step.sum() < 10:
        return None
    sxx = float(np.dot(di, di))
    r = -float(np.dot(dv, di)) / sxx
    e = dv + r * di
    s2 = float(np.dot(e, e)) / max(e.size - 1, 1)
    se = math.sqrt(s2 / sxx * stats.ar1_inflation(stats.lag1_autocorrelation(e)))
    t = np.asarray(temperature, float)[ok]
    w = np.abs(i[ok]) * np.isfinite(t)
    temp = float(np.sum(np.nan_to_num(t) * w) / np.sum(w)) if w.sum() > 0 else math.nan
    return r, se, temp


def _meta_regression(y, var, x):
    """Weighted least squares of y on [1, x] with a between-experiment variance τ²
    (DerSimonian–Laird, module notes): (coefficients, covariance, τ², weights); the
    covariance is the modified Knapp–Hartung one (module notes)."""
    X = np.column_stack([np.ones_like(x), x])
    w = 1.0 / var
    W = np.diag(w)
    A = np.linalg.inv(X.T @ W @ X)
    beta = A @ X.T @ W @ y
    q = float(np.sum(w * (y - X @ beta) ** 2))
    p = 2
    P = W - W @ X @ A @ X.T @ W
    tau2 = max(0.0, (q - (len(y) - p)) / float(np.trace(P)))
    w = 1.0 / (var + tau2)
    W = np.diag(w)
    A = np.linalg.inv(X.T @ W @ X)
    beta = A @ X.T @ W @ y
    if len(y) > p:
        A = A * max(1.0, float(np.sum(w * (y - X @ beta) ** 2)) / (len(y) - p))
    return beta, A, tau2, w


def resistance_temperature(exps: list[dict]) -> dict:
    """The pack's DC resistance against its temperature over the experiments (module
    notes). Returns ``testable`` False with ``why``; else the per-experiment resistances,
    ``activation_energy_j_per_mol`` and ``resistance_at_25c_ohm`` with standard errors,
    the held-out ``gain_pct`` and ``paired_p_value``, ``significant``, ``implausible``
    (a reason or None) and the detection ``limit_j_per_mol``."""
    from planner.identify.diagnose.search import ALPHA_HELDOUT, MIN_GAIN_PCT, sign_flip_test

    rows = []
    for e in exps:
        if e.get("temperature") is None or e.get("current") is None or \
                e.get("voltage") is None:
            continue
        got = experiment_resistance(e["current"], e["voltage"], e["temperature"])
        if got is not None and got[0] > 0 and math.isfinite(got[2]):
            rows.append((e["name"], *got))
    if not any(e.get("temperature") is not None for e in exps):
        return {"testable": False, "why": "no pack temperature (temperature_c) in the data"}
    if len(rows) < MIN_RESISTANCE_EXPERIMENTS:
        return {"testable": False,
                "why": (f"only {len(rows)} experiment(s) with a pack temperature and current "
                        f"steps to measure the resistance on (needs "
                        f"{MIN_RESISTANCE_EXPERIMENTS}): the voltage's step against the "
                        "current's step is the resistance")}
    names = [r[0] for r in rows]
    res = np.array([r[1] for r in rows])
    se = np.array([r[2] for r in rows])
    temp = np.array([r[3] for r in rows])
    if float(np.ptp(temp)) < MIN_RESISTANCE_SPREAD_C:
        return {"testable": False,
                "why": (f"the experiments' mean pack temperatures span only "
                        f"{float(np.ptp(temp)):.1f} °C (needs {MIN_RESISTANCE_SPREAD_C:g} °C)")}
    y = np.log(res)
    var = (se / res) ** 2
    x = 1.0 / (temp + 273.15) - 1.0 / T25_K
    beta, cov, tau2, w = _meta_regression(y, var, x)
    slope, s_slope = float(beta[1]), float(math.sqrt(cov[1, 1]))
    # held out: each experiment predicted from the others, with and without the temperature
    loss1, loss0 = np.zeros(len(y)), np.zeros(len(y))
    for j in range(len(y)):
        m = np.arange(len(y)) != j
        b_j, _, t2, _ = _meta_regression(y[m], var[m], x[m])
        ww = 1.0 / (var[m] + t2)
        mean_j = float(np.sum(ww * y[m]) / np.sum(ww))
        loss1[j] = (y[j] - b_j[0] - b_j[1] * x[j]) ** 2
        loss0[j] = (y[j] - mean_j) ** 2
    gain = 100.0 * (1.0 - math.sqrt(loss1.mean() / loss0.mean())) if loss0.mean() > 0 else 0.0
    p_pair = sign_flip_test(loss0 - loss1)
    ea, s_ea = slope * R_GAS, s_slope * R_GAS
    z = abs(slope) / s_slope if s_slope > 0 else math.inf
    implausible = None
    if ea <= 0:
        implausible = (f"the fit has the resistance fall in the cold ({ea / 1000:+.1f} kJ/mol): "
                       "a lithium cell's resistance rises as it cools")
    elif not ACTIVATION_RANGE_J_PER_MOL[0] <= ea <= ACTIVATION_RANGE_J_PER_MOL[1]:
        implausible = (f"an activation energy of {ea / 1000:.0f} kJ/mol is outside the "
                       f"{ACTIVATION_RANGE_J_PER_MOL[0] / 1000:g}–"
                       f"{ACTIVATION_RANGE_J_PER_MOL[1] / 1000:g} kJ/mol of lithium cells")
    significant = (gain >= MIN_GAIN_PCT and p_pair < ALPHA_HELDOUT and z >= MIN_Z
                   and implausible is None)
    mse = float(np.mean(1.0 / w))          # per-experiment variance of ln R, τ² included
    var_x = float(np.var(x))
    prac = math.sqrt(((1 - MIN_GAIN_PCT / 100) ** -2 - 1) * mse / var_x) * R_GAS \
        if var_x > 0 else math.inf
    stat = stats.paired_test_factor() * s_ea
    r25, s_r25 = float(math.exp(beta[0])), float(math.exp(beta[0]) * math.sqrt(cov[0, 0]))
    return {"testable": True, "experiments": names, "resistance_ohm": res.tolist(),
            "resistance_ohm_stderr": se.tolist(), "temperature_c": temp.tolist(),
            "activation_energy_j_per_mol": ea, "activation_energy_j_per_mol_stderr": s_ea,
            "resistance_at_25c_ohm": r25, "resistance_at_25c_ohm_stderr": s_r25,
            "between_experiments_log_sd": math.sqrt(tau2), "gain_pct": gain,
            "paired_p_value": p_pair, "z": z, "significant": significant,
            "implausible": implausible, "limit_j_per_mol": max(stat, prac, MIN_Z * s_ea)}


def resistance_finding(ev: dict, exps: list[dict]) -> dict:
    """The ``temperature`` finding of a significant :func:`resistance_temperature`."""
    ea, s_ea = ev["activation_energy_j_per_mol"], ev["activation_energy_j_per_mol_stderr"]
    r25 = ev["resistance_at_25c_ohm"]
    t_lo = float(min(ev["temperature_c"]))
    r_lo = r25 * math.exp(ea / R_GAS * (1.0 / (t_lo + 273.15) - 1.0 / T25_K))
    cur = np.concatenate([e["current"] for e in exps if e.get("current") is not None])
    vol = np.concatenate([e["voltage"] for e in exps if e.get("voltage") is not None])
    i_med, v_med = float(np.nanmedian(cur)), float(np.nanmedian(vol))
    extra = 100.0 * i_med * (r_lo - r25) / v_med
    params = {"activation_energy_j_per_mol": ea, "activation_energy_j_per_mol_stderr": s_ea,
              "resistance_at_25c_ohm": r25,
              "resistance_at_25c_ohm_stderr": ev["resistance_at_25c_ohm_stderr"],
              "coldest_c": t_lo, "resistance_at_coldest_ohm": r_lo,
              "extra_current_at_coldest_pct": extra}
    cause = (f"Cold pack: the voltage sags more for the same current step as the pack is "
             f"colder: DC resistance {1000 * r25:.1f} mΩ at 25 °C and {1000 * r_lo:.1f} mΩ at "
             f"{t_lo:.0f} °C (Arrhenius, activation energy {ea / 1000:.1f} ± "
             f"{s_ea / 1000:.1f} kJ/mol, over {len(ev['experiments'])} experiments); at "
             f"{t_lo:.0f} °C the pack draws {extra:.1f} % more current for the same power at "
             f"{i_med:.1f} A. Direct evidence: the pack temperature against the voltage sag")
    return {"effect": "temperature", "level": "resistance", "cause": cause,
            "parameters": params,
            "evidence": {"gain_alone_pct": ev["gain_pct"], "paired_p_value": ev["paired_p_value"],
                         "z": ev["z"], "test_units": float(len(ev["experiments"]))},
            "alternatives": [], "added_after": [],
            "heldout": {"gain_pct": ev["gain_pct"], "final_gain_pp": 0.0},
            "unit": "J/mol",
            "headline": (f"Cold pack: resistance {1000 * r25:.0f} → {1000 * r_lo:.0f} mΩ from "
                         f"25 to {t_lo:.0f} °C ({ea / 1000:.0f} kJ/mol)"),
            "driver": "pack temperature [°C]"}


# ============================================================================ flight mode

def mode_changes(sub) -> list[tuple[float, str, str]]:
    """(time [s from the experiment's first sample], old mode, new mode) of every change
    of the ``mode`` channel of one experiment."""
    if "mode" not in sub:
        return []
    mode = sub["mode"].reset_index(drop=True)
    t = sub["time_s"].to_numpy(float)
    t = t - t[0]
    known = mode[mode.notna()].astype(str)
    prev = known.shift()
    change = (known != prev) & prev.notna()
    return [(float(t[k]), str(prev[k]), str(known[k])) for k in known.index[change]]
