r"""Fixed-wing calibration from minimal flight data: the energy-rate fit.

Short flights of a small fixed wing are rarely steady: throttle pulses, glides, speed
and height traded against each other. The power the battery gives then goes partly into
the aircraft's kinetic and potential energy, and a fit of the steady power curve to the
raw samples mistakes that for drag. :func:`fit_fixed_wing` fits the energy-rate balance
instead (:mod:`planner.physics.power.energy_rate`; [UAV23] eq. 2 with the acceleration
term kept, as Sharpe & Hansman 2024 do):

.. math:: \eta\,(P - P_S) = \tfrac12\rho V^3 S\,C_{D0} + \frac{2K(mg)^2}{\rho S V}
          + m g \dot h + m V \dot V

sample by sample over each flight's airborne part, by linear least squares in
:math:`\eta`, :math:`C_{D0}` and :math:`K` (the residual is in watts of thrust power)
within the physical bounds of the aircraft file's schema.

The signals
-----------
* true airspeed and air density of the flight state
  (:func:`planner.chain.flightstate.from_record`: the logged airspeed; the density from
  the logged pressure and temperature);
* the climb rate from the barometric altitude (the ISA pressure altitude of the logged
  static pressure, as the authors use the barometer), else from ``altitude_m``, else the
  logged climb rate;
* every signal resampled to the record's median sample interval and smoothed by a
  Gaussian of :data:`SMOOTHING_S` (σ = 4 s, Sharpe & Hansman's low-pass of the derivative
  estimates); :math:`\dot V` and :math:`\dot h` are derivatives of that Gaussian.

Airborne part: from the first to the last sample whose smoothed airspeed is above the
aircraft's minimum airspeed (its stall speed), less :data:`TRIM_S` at each end (the
take-off run and the landing, as the authors' "first 10 seconds is dirty"); samples
below the minimum airspeed inside it are left out. A flight without one is bad input.

Glides and the system load
--------------------------
Samples whose raw power is below :data:`GLIDE_POWER_FRACTION` of the flight's median
airborne power, in runs of at least :data:`GLIDE_MIN_S`, are motor-off glides. Their
median power is the system load :math:`P_S` (avionics; "the average measured power
consumption during motor-off periods", Sharpe & Hansman), held in the fit; without
glides the file's value is held. In a glide the balance has no thrust: the drag follows
from the energy rate alone, without η, and glides pin the polar's level. The report gives
the glides' own drag coefficient (on their samples at least σ inside each motor-off run)
beside the fitted polar's at the same lift coefficient: a stopped or windmilling
propeller's drag is in the glides' and not in the powered flight's.

The parabolic polar has its least drag at :math:`C_L = 0`; a cambered wing at low Reynolds
number has it at a positive lift. The report also gives the same balance with a term
linear in :math:`C_L` (``shifted_polar``: where the least drag is and how much), a
diagnostic the planner's polar cannot carry, and names it in a misfit of K.

Standard errors, bounds, misfit, plausibility
---------------------------------------------
Standard errors from the design matrix and the residuals thinned to one row per
correlation time of the smoothing (2√π σ), AR(1)-inflated for what correlation is left
(:func:`planner.identify.stats.covariance`). Bounds: η in [0.05, 1]; C_D0 in (0, 0.5];
K between an Oswald factor of 1 and 0.3 when the aspect ratio is known (the planar wing's
elliptic limit, and the schema's lowest), else (0, 1]. A parameter that ends on a bound
is a **misfit** (``fit_status``): the data want a value outside the physical range (the
unconstrained least-squares value is reported) and the likely cause is named
(:data:`MISFIT_CAUSES`). Each parameter is also set against the range of real airframes
(:data:`PLAUSIBLE`, with its source); outside it is reported, not a misfit.

Validation uses samples the fit never saw, as :func:`planner.identify.aircraft_fit.fit_aircraft`:
held-out flights, else the last 30 % of one flight. Battery-power errors are given for
the planner's steady model (``replay`` and ``check``: :math:`\dot V` dropped) and for the
energy-rate model.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd
from scipy.ndimage import gaussian_filter1d
from scipy.optimize import lsq_linear

from planner.chain import flightstate
from planner.chain.mission_chain import MissionChain
from planner.errors import InputError
from planner.identify.aircraft_fit import chosen_parameters, split_experiments, with_params
from planner.identify.stats import covariance
from planner.io import record
from planner.parameters import Aircraft
from planner.physics import atmosphere
from planner.physics.power.energy_rate import (
    energy_rate,
    glide_drag_coefficient,
    lift_coefficient,
    lift_power,
    polar_power_terms,
    shifted_polar,
)

__all__ = ["FIT_PARAMETERS", "GLIDE_MIN_S", "GLIDE_POWER_FRACTION", "MISFIT_CAUSES",
           "PLAUSIBLE", "SMOOTHING_S", "TRIM_S", "EnergyRateSamples",
           "corrected_samples", "energy_rate_samples", "fit_fixed_wing", "fitted_mapping",
           "polar_curve", "power_curve"]

#: Gaussian low-pass of every signal and of the derivatives (Sharpe & Hansman 2024: σ = 4 s
#: on the derivative estimates). [s]
SMOOTHING_S = 4.0
#: Left out at each end of the airborne part: take-off run and landing (Sharpe & Hansman's
#: analysis drops the first and last 10 s). [s]
TRIM_S = 10.0
#: A sample is motor-off when its power is below this share of the flight's median
#: airborne power (the Solar Surfer's glides draw 9 W against 83 W; 0 W against 193 W).
GLIDE_POWER_FRACTION = 0.15
#: Shortest motor-off run taken as a glide. [s]
GLIDE_MIN_S = 3.0
#: Fewest glide samples to measure the system load from. [samples]
GLIDE_MIN_SAMPLES = 10
#: Parameters of the fit, in the aircraft file's names.
FIT_PARAMETERS = ("cd0", "k", "efficiency")
#: Oswald factors bounding K when the aspect ratio is known: the elliptic planar wing's
#: limit (Munk) and the aircraft schema's lowest value. [unitless]
OSWALD_BOUNDS = (0.3, 1.0)
#: A parameter whose standard error exceeds this share of its value is poorly determined.
POOR_RELATIVE_STDERR = 0.5

#: Range of real airframes of each parameter: (low, high, source).
PLAUSIBLE = {
    "cd0": (0.015, 0.06,
            "Raymer, Aircraft Design: A Conceptual Approach, eq. 12.23 with Table 12.3 "
            "(C_fe 0.0045-0.0065 for light aircraft and prop seaplanes, times a wetted-area "
            "ratio of 2.5-3.5: 0.011-0.023) up to the small-UAV sets of Beard & McLain, "
            "Small Unmanned Aircraft, 2012, App. E (Aerosonde 0.043), with room for floats "
            "and low Reynolds numbers (a judgement, not a published bound)"),
    "oswald_efficiency": (0.6, 0.95,
                          "Raymer eq. 12.48 (straight wing: 0.70 at AR 12, 0.78 at AR 9) to "
                          "Beard & McLain's Aerosonde (0.9); 1 is the elliptic planar "
                          "wing's limit"),
    "efficiency": (0.4, 0.7,
                   "peak propeller efficiency of the UIUC propeller database (10th-90th "
                   "percentile 0.58-0.78 over 358 wind-tunnel sweeps, Brandt et al.) times "
                   "a motor and ESC efficiency of 0.7-0.9 (assumed)"),
}

#: Likely cause of a parameter ending on its (low, high) bound.
MISFIT_CAUSES = {
    ("efficiency", "high"): "the battery gives less power than the drag and the energy "
                            "changes need: a source the battery current does not see (a "
                            "solar input), a current sensor that reads low, or a mass or an "
                            "airspeed given too high",
    ("efficiency", "low"): "the battery gives far more power than the drag and the energy "
                           "changes need: a load outside the model, a current sensor that "
                           "reads high, or a mass given too low",
    ("k", "low"): "the drag rises less with the lift coefficient than an elliptic wing's "
                  "induced drag allows: the polar's least drag is not at C_L = 0 (a cambered "
                  "wing at low Reynolds number), so C_D0 + K C_L^2 is the wrong form over the "
                  "C_L flown; or the span, wing area or mass given is off",
    ("k", "high"): "the drag rises steeply with the lift coefficient: flight near the stall "
                   "or in banked turns (load factor above 1, not in the model), or a mass "
                   "given too high",
    ("cd0", "low"): "no drag left at low lift: the airspeed reads high, or the climb and "
                    "acceleration terms take the power (an altitude or airspeed lag)",
    ("cd0", "high"): "the drag at low lift is beyond any airframe: an airspeed that reads "
                     "low, a wrong wing area, or a windmilling propeller in the glides",
}
_BOUNDS = {"efficiency": (0.05, 1.0), "cd0": (1e-4, 0.5), "k": (1e-4, 1.0)}
_STEADY = "steady model (dV/dt dropped, as replay and check)"


@dataclass
class EnergyRateSamples:
    """Airborne samples of the energy-rate fit, stacked over experiments (SI units)."""

    experiment: np.ndarray
    time_s: np.ndarray
    power_w: np.ndarray          # smoothed battery power [W]
    raw_power_w: np.ndarray      # as logged [W]
    airspeed: np.ndarray         # smoothed true airspeed [m/s]
    acceleration: np.ndarray     # dV/dt [m/s²]
    climb_rate: np.ndarray       # dh/dt [m/s]
    air_density: np.ndarray      # [kg/m³]
    dt: np.ndarray               # sample interval [s]
    glide: np.ndarray            # motor-off glide sample [bool]
    sources: dict

    def subset(self, mask) -> EnergyRateSamples:
        """The samples where ``mask`` is true (a boolean or index array over the samples), the
        sources kept."""
        return EnergyRateSamples(*(getattr(self, f)[mask] for f in (
            "experiment", "time_s", "power_w", "raw_power_w", "airspeed", "acceleration",
            "climb_rate", "air_density", "dt", "glide")), self.sources)

    def __len__(self) -> int:
        return len(self.time_s)


def _filled(t, x) -> np.ndarray | None:
    ok = np.isfinite(x)
    if ok.mean() <= flightstate.CHANNEL_COVERAGE:
        return None
    return np.interp(t, t[ok], x[ok])


def _glide_runs(mask: np.ndarray, dt: float) -> np.ndarray:
    """``mask`` kept only in runs of at least :data:`GLIDE_MIN_S`."""
    m = np.asarray(mask, bool)
    if not m.any():
        return m
    edges = np.diff(np.r_[0, m.astype(np.int8), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    keep = np.zeros(m.size + 1, np.int64)
    long = (ends - starts) * dt >= GLIDE_MIN_S
    np.add.at(keep, starts[long], 1)
    np.add.at(keep, ends[long], -1)
    return np.cumsum(keep)[:-1] > 0


def _experiment(exp_id, exp: pd.DataFrame, v_min: float, site_altitude_m: float,
                smoothing_s: float, trim_s: float):
    if record.voltage_only(exp):
        raise InputError(f"experiment {exp_id}: {record.NO_CURRENT} (battery voltage only): "
                         "fitting an aircraft needs the measured power")
    if not record.has_power(exp):
        raise InputError(f"experiment {exp_id}: needs the battery power to fit an aircraft")
    exp = record.add_power(exp)
    st = flightstate.from_record(exp, site_altitude_m)
    t = exp["time_s"].to_numpy(float)
    dt = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    if not dt > 0:
        raise InputError(f"experiment {exp_id}: needs samples over time to fit an aircraft")
    grid = np.arange(t[0], t[-1] + 0.5 * dt, dt)

    def on_grid(x):
        x = np.asarray(x, float)
        ok = np.isfinite(x)
        return np.interp(grid, t[ok], x[ok]) if ok.any() else np.full(grid.size, np.nan)

    def col(name):
        return exp[name].to_numpy(float) if name in exp.columns else np.full(t.size, np.nan)

    p = _filled(t, col("pressure_pa"))
    alt = _filled(t, col("altitude_m"))
    if p is not None and np.all(p > 0):
        h, hsource = atmosphere.pressure_altitude(p), "barometric altitude (pressure_pa)"
    elif alt is not None:
        h, hsource = alt, "altitude_m"
    else:
        climb = _filled(t, col("climb_rate_ms"))
        if climb is None:
            raise InputError(f"experiment {exp_id}: needs pressure_pa, altitude_m or "
                             "climb_rate_ms to fit a fixed wing's energy rate")
        h = record.cumulative_trapezoid(climb, t)
        hsource = "integrated climb_rate_ms"
    sigma = smoothing_s / dt
    raw_p = on_grid(st.measured_power_w)
    v_raw = on_grid(st.airspeed_ms)

    def smooth(x, order=0):
        return gaussian_filter1d(x, sigma, order=order, mode="nearest") / dt**order

    v = smooth(v_raw)
    airborne = v > v_min
    if not airborne.any():
        raise InputError(f"experiment {exp_id}: no airborne part (the airspeed never exceeds "
                         f"the aircraft's minimum airspeed {v_min:g} m/s); expected a flight")
    i0, i1 = np.flatnonzero(airborne)[[0, -1]]
    window = (grid >= grid[i0] + trim_s) & (grid <= grid[i1] - trim_s) & airborne
    if window.sum() * dt < 3 * smoothing_s:
        raise InputError(f"experiment {exp_id}: airborne for {(grid[i1] - grid[i0]):.0f} s "
                         f"above {v_min:g} m/s: too short to fit (expected more than "
                         f"{2 * trim_s + 3 * smoothing_s:.0f} s)")
    out = dict(time_s=grid, power_w=smooth(raw_p), raw_power_w=raw_p, airspeed=v,
               acceleration=smooth(v_raw, 1), climb_rate=smooth(on_grid(h), 1),
               air_density=smooth(on_grid(st.air_density)))
    out = {k: x[window] for k, x in out.items()}
    ok = np.all([np.isfinite(x) for x in out.values()], axis=0)
    out = {k: x[ok] for k, x in out.items()}
    med = float(np.median(out["raw_power_w"])) if ok.any() else math.nan
    glide = _glide_runs(out["raw_power_w"] < GLIDE_POWER_FRACTION * med, dt)
    sources = {"airspeed": st.airspeed_source, "air density": st.density_source,
               "climb rate": f"derivative of the {hsource}",
               "window": (float(grid[i0]), float(grid[i1]))}
    return out, dt, glide, sources


def energy_rate_samples(data: pd.DataFrame, aircraft: Aircraft, *,
                        site_altitude_m: float = 0.0, smoothing_s: float = SMOOTHING_S,
                        trim_s: float = TRIM_S) -> EnergyRateSamples:
    """The smoothed airborne samples of every experiment (module notes)."""
    if aircraft.is_multirotor:
        raise InputError(f"{aircraft.name}: the energy-rate fit is for a fixed wing")
    v_min = aircraft.min_airspeed_ms
    parts, sources = [], {}
    for exp_id, exp in record.experiments(data):
        exp = exp.reset_index(drop=True)
        out, dt, glide, src = _experiment(exp_id, exp, v_min, site_altitude_m, smoothing_s,
                                          trim_s)
        sources[str(exp_id)] = src
        n = out["time_s"].size
        parts.append((np.full(n, str(exp_id), dtype=object), out["time_s"], out["power_w"],
                      out["raw_power_w"], out["airspeed"], out["acceleration"],
                      out["climb_rate"], out["air_density"], np.full(n, dt), glide))
    if not parts:
        raise InputError("no flight in the data")
    cols = [np.concatenate([p[i] for p in parts]) for i in range(10)]
    return EnergyRateSamples(*cols, sources)


def _regressors(s: EnergyRateSamples, mass: float, wing_area: float, system_power: float):
    """Columns of η, C_D0, K and the right-hand side of the balance (module notes)."""
    a, b = polar_power_terms(s.airspeed, s.air_density, mass, wing_area)
    x = s.power_w - system_power
    c = energy_rate(mass, s.airspeed, s.acceleration, s.climb_rate)
    return {"efficiency": x, "cd0": -a, "k": -b}, c


def _k_bounds(aspect_ratio: float | None) -> tuple[float, float]:
    if aspect_ratio is None:
        return _BOUNDS["k"]
    e_lo, e_hi = OSWALD_BOUNDS
    return 1.0 / (math.pi * aspect_ratio * e_hi), 1.0 / (math.pi * aspect_ratio * e_lo)


def _solve(cols: dict, rhs: np.ndarray, names: list[str], fixed: dict, bounds: dict):
    """Bounded and unconstrained least squares of ``rhs`` on the free columns."""
    rhs = rhs - sum(cols[n] * v for n, v in fixed.items())
    a = np.column_stack([cols[n] for n in names])
    norms = np.linalg.norm(a, axis=0)
    norms[norms == 0] = 1.0
    an = a / norms
    lo = np.array([bounds[n][0] for n in names]) * norms
    hi = np.array([bounds[n][1] for n in names]) * norms
    sol = lsq_linear(an, rhs, bounds=(lo, hi), method="bvls")
    free, *_ = np.linalg.lstsq(an, rhs, rcond=None)
    x = sol.x / norms
    return x, free / norms, a @ x - rhs, a


def polar_curve(cl, cd0: float, k: float) -> np.ndarray:
    """:math:`C_D = C_{D0} + K C_L^2` ([UAV23] eq. 2–4's polar). [unitless]"""
    cl = np.asarray(cl, float)
    return cd0 + k * cl * cl


def power_curve(airspeed, aircraft: Aircraft, mass_kg: float, air_density: float):
    """Level, steady battery power of ``aircraft`` against true airspeed (the chain's model,
    :meth:`planner.chain.mission_chain.MissionChain.power_at`). [W]"""
    v = np.asarray(airspeed, float)
    return MissionChain(aircraft, None).power_at(v, np.zeros_like(v), air_density, mass_kg)


def _metrics(pred, meas, dt) -> dict[str, float]:
    r = pred - meas
    e_m = float(np.sum(meas * dt))
    return {"rmse_w": float(np.sqrt(np.mean(r**2))), "bias_w": float(np.mean(r)),
            "energy_error_pct": 100.0 * (float(np.sum(pred * dt)) - e_m) / e_m
            if e_m else math.nan}


def _energy_rate_prediction(ac: Aircraft, s: EnergyRateSamples, mass: float) -> np.ndarray:
    f = ac.fixed_wing
    a, b = polar_power_terms(s.airspeed, s.air_density, mass, f.wing_area_m2)
    req = a * f.cd0 + b * f.k + energy_rate(mass, s.airspeed, s.acceleration, s.climb_rate)
    return np.maximum(req, 0.0) / ac.efficiency + ac.system_power_w


def _steady_prediction(ac: Aircraft, s: EnergyRateSamples, mass: float) -> np.ndarray:
    return MissionChain(ac, None).power_at(s.airspeed, s.climb_rate, s.air_density, mass)


def _scores(before: Aircraft, after: Aircraft, s: EnergyRateSamples, trn, val, mass):
    out: dict[str, Any] = {"samples": {"train": int(trn.sum()), "validation": int(val.sum())}}
    for name, rows in (("train", trn), ("validation", val)):
        if rows.sum() < 2:
            continue
        sub = s.subset(rows)
        out[name] = {"before": _metrics(_steady_prediction(before, sub, mass),
                                        sub.raw_power_w, sub.dt),
                     "after": _metrics(_steady_prediction(after, sub, mass),
                                       sub.raw_power_w, sub.dt),
                     "after_energy_rate": _metrics(_energy_rate_prediction(after, sub, mass),
                                                   sub.raw_power_w, sub.dt)}
        if name == "validation":
            per: dict[str, dict[str, float]] = {"before": {}, "after": {}}
            for exp_id in dict.fromkeys(sub.experiment):
                m = sub.experiment == exp_id
                e = sub.subset(m)
                per["before"][str(exp_id)] = _metrics(_steady_prediction(before, e, mass),
                                                      e.raw_power_w, e.dt)["energy_error_pct"]
                per["after"][str(exp_id)] = _metrics(_steady_prediction(after, e, mass),
                                                     e.raw_power_w, e.dt)["energy_error_pct"]
            out["per_experiment_energy_error_pct"] = per
    return out


def _shifted(s: EnergyRateSamples, mass: float, wing_area: float, p_s: float,
             aspect_ratio: float | None) -> dict[str, float]:
    """The same balance with a polar whose least drag may sit at a positive lift,
    C_D = C_D0 + K_1 C_L + K C_L^2 (unconstrained least squares): what the data say of
    the parabolic form's fixed minimum at C_L = 0."""
    cols, rhs = _regressors(s, mass, wing_area, p_s)
    a = np.column_stack([cols["efficiency"], cols["cd0"], -lift_power(s.airspeed, mass),
                         cols["k"]])
    norms = np.linalg.norm(a, axis=0)
    x, *_ = np.linalg.lstsq(a / norms, rhs, rcond=None)
    eta, cd0, k1, k = x / norms
    cd_min, cl_min = shifted_polar(cd0, k1, k)
    r = a @ (x / norms) - rhs
    out = {"efficiency": float(eta), "cd_min": float(cd_min), "cl_min": float(cl_min),
           "k": float(k), "energy_rate_rmse_w": float(np.sqrt(np.mean(r**2)))}
    if aspect_ratio is not None and k > 0:
        out["k_as_oswald"] = 1.0 / (math.pi * aspect_ratio * k)
    return out


def _glides(s: EnergyRateSamples, mass: float, wing_area: float, cd0: float, k: float,
            smoothing_s: float):
    """The glides' polar from the energy rate alone, on their samples at least one
    smoothing σ inside each motor-off run (nearer its ends the smoothing mixes in the
    thrust of the powered flight around it)."""
    from scipy.ndimage import binary_erosion

    dt = float(np.median(s.dt)) if len(s) else 1.0
    n = int(round(smoothing_s / dt))
    core = binary_erosion(s.glide, structure=np.ones(2 * n + 1, bool)) if n else s.glide
    out = {"samples": int(s.glide.sum()), "duration_s": float(np.sum(s.dt[s.glide])),
           "core_samples": int(core.sum()), "core_duration_s": float(np.sum(s.dt[core]))}
    if core.sum() < GLIDE_MIN_SAMPLES:
        return out
    g = s.subset(core)
    cl = lift_coefficient(g.airspeed, g.air_density, mass, wing_area)
    cd = glide_drag_coefficient(g.airspeed, g.acceleration, g.climb_rate, g.air_density,
                                mass, wing_area)
    cl_m, cd_m = float(np.median(cl)), float(np.median(cd))
    out.update({"lift_coefficient": cl_m, "drag_coefficient": cd_m,
                "lift_to_drag": float(np.median(cl / cd)),
                "fitted_drag_coefficient": float(np.median(polar_curve(cl, cd0, k))),
                "drag_vs_fitted_pct": 100.0 * float(np.median(cd / polar_curve(cl, cd0, k)
                                                              - 1.0)),
                "airspeed_ms": float(np.median(g.airspeed)),
                "power_w": float(np.median(g.raw_power_w))})
    return out


def _plausibility(values: dict[str, float]) -> dict[str, dict]:
    out = {}
    for name, (lo, hi, source) in PLAUSIBLE.items():
        v = values.get(name)
        if v is None or not math.isfinite(v):
            continue
        verdict = "inside" if lo <= v <= hi else ("below" if v < lo else "above")
        out[name] = {"value": v, "range": [lo, hi], "verdict": verdict, "source": source}
    return out


def _fit_names(aircraft: Aircraft, parameters: list[str] | None,
               aspect_ratio: float | None) -> list[str]:
    """The parameters to fit, checked against :data:`FIT_PARAMETERS` (and the aircraft a
    fixed wing, the aspect ratio a positive number)."""
    if aircraft.is_multirotor:
        raise InputError(f"{aircraft.name}: the energy-rate fit is for a fixed wing")
    names = chosen_parameters(parameters, FIT_PARAMETERS, "a fixed wing",
                              "in the motor-off glides")
    if aspect_ratio is not None and not (math.isfinite(aspect_ratio) and aspect_ratio > 0):
        raise InputError(f"aspect ratio must be a positive number, got {aspect_ratio!r}")
    return names


def _thinning(s: EnergyRateSamples, smoothing_s: float) -> int:
    """One row in this many is independent: the smoothing window's correlation time
    (2√π σ) over the median sample interval."""
    return max(1, round(2 * math.sqrt(math.pi) * smoothing_s / float(np.median(s.dt))))


def _glide_system_power(s_trn: EnergyRateSamples, aircraft: Aircraft,
                        thin: int) -> tuple[float, float, str]:
    """The system load measured in the motor-off glides of the training flights: (median
    [W], its standard error [W] (1.2533 σ/√n_eff, the median's), source), else the file's
    value held with a NaN error."""
    glide_power = s_trn.raw_power_w[s_trn.glide]
    if glide_power.size >= GLIDE_MIN_SAMPLES:
        p_s = max(float(np.median(glide_power)), 0.0)
        n_eff = max(glide_power.size / thin, 1.0)
        p_s_se = 1.2533 * float(np.std(glide_power)) / math.sqrt(n_eff)
        return p_s, p_s_se, f"median of {glide_power.size} motor-off glide samples"
    return (float(aircraft.system_power_w), math.nan,
            f"held at the file's value: only {glide_power.size} motor-off glide "
            "sample(s) in the training flights")


def _at_bounds(names: list[str], x, free, bounds: dict) -> tuple[list[str], list[dict]]:
    """The parameters that ended on a bound, and for each a misfit record (parameter,
    bound side, value, unconstrained value, likely cause from :data:`MISFIT_CAUSES`)."""
    at_bound, misfit = [], []
    for n, v, u in zip(names, x, free):
        lo, hi = bounds[n]
        span = hi - lo
        side = "low" if v - lo <= 1e-6 * span else "high" if hi - v <= 1e-6 * span else None
        if side is None:
            continue
        at_bound.append(n)
        misfit.append({"parameter": n, "bound": side, "value": float(v),
                       "unconstrained": float(u), "cause": MISFIT_CAUSES[(n, side)]})
    return at_bound, misfit


def _oswald(aspect_ratio: float | None, k: float, stderr: dict,
            misfit: list[dict]) -> tuple[float | None, float | None]:
    """Oswald factor e = 1/(π A K) (the induced-drag factor K = 1/(π e A)) and its standard
    error, with the unconstrained value noted on a K misfit; (None, None) without A."""
    if aspect_ratio is None:
        return None, None
    e = 1.0 / (math.pi * aspect_ratio * k)
    e_se = e * stderr["k"] / k if "k" in stderr else math.nan
    for m in misfit:
        if m["parameter"] == "k":
            u = m["unconstrained"]
            m["oswald_unconstrained"] = (1.0 / (math.pi * aspect_ratio * u) if u > 0
                                         else math.inf)
    return e, e_se


def _fit_status(misfit: list[dict]) -> str:
    """``ok``, or ``misfit: …`` naming each parameter on a bound and its likely cause."""
    if not misfit:
        return "ok"
    return "misfit: " + "; ".join(
        f"{m['parameter']} ended on its {m['bound']} bound {m['value']:.4g} (the data "
        f"alone give {m['unconstrained']:.4g}"
        + (f", Oswald factor {m['oswald_unconstrained']:.2f}"
           if "oswald_unconstrained" in m else "") + f"): {m['cause']}" for m in misfit)


def fit_fixed_wing(data: pd.DataFrame, aircraft: Aircraft, *, mass_kg: float,
                   parameters: list[str] | None = None, train: list[str] | None = None,
                   validate: list[str] | None = None, site_altitude_m: float = 0.0,
                   aspect_ratio: float | None = None, smoothing_s: float = SMOOTHING_S,
                   trim_s: float = TRIM_S, acceleration: bool = True) -> dict[str, Any]:
    r"""Fit a fixed wing's polar and propulsive efficiency by the energy-rate balance.

    Parameters
    ----------
    data : DataFrame
        Flight record(s) with power, airspeed and altitude or pressure.
    aircraft : Aircraft
        A fixed wing: wing area, minimum airspeed and the values held.
    mass_kg : float
        All-up mass. [kg]
    parameters : list of str, optional
        Which of ``cd0``, ``k``, ``efficiency`` to fit (default all three); the system
        load is measured in the glides.
    train, validate : list of str, optional
        Experiment ids (as :func:`planner.identify.aircraft_fit.split_experiments`).
    site_altitude_m : float
        Site altitude for the ISA density when the record has no pressure. [m]
    aspect_ratio : float, optional
        Wing aspect ratio: bounds K by the Oswald factors of :data:`OSWALD_BOUNDS` and
        gives the fitted Oswald factor.
    smoothing_s, trim_s : float
        :data:`SMOOTHING_S`, :data:`TRIM_S`. [s]
    acceleration : bool
        Keep the :math:`m V \dot V` term (default); False fits the seed's steady balance
        on the same samples, for comparison.

    Returns
    -------
    dict
        As :func:`planner.identify.aircraft_fit.fit_aircraft` (``aircraft``,
        ``parameters``, ``start``, ``stderr``, ``poorly_determined``, ``at_bound``,
        ``split``, ``train``/``validation`` battery-power metrics before and after, with
        ``after_energy_rate``), plus ``method``, ``fit_status`` (``ok`` or ``misfit: …``),
        ``misfit`` (parameter, bound, unconstrained value, likely cause), ``plausibility``,
        ``oswald_efficiency`` and ``aspect_ratio``, ``system_power`` (value, source),
        ``glides``, ``shifted_polar`` (the balance with the polar's least drag free, a
        diagnostic), ``energy_rate_rmse_w``, ``sources`` and ``samples_table``
        (:func:`corrected_samples`).
    """
    names = _fit_names(aircraft, parameters, aspect_ratio)
    mass = float(mass_kg)
    s = energy_rate_samples(data, aircraft, site_altitude_m=site_altitude_m,
                            smoothing_s=smoothing_s, trim_s=trim_s)
    if len(s) < 20:
        raise InputError(f"only {len(s)} airborne samples: too few to fit an aircraft "
                         "(expected at least 20)")
    if not acceleration:
        s.acceleration = np.zeros_like(s.acceleration)
    trn, val, how = split_experiments(SimpleNamespace(experiment=s.experiment,
                                                      time_s=s.time_s), validate, train)
    if trn.sum() < 10:
        raise InputError("the training split has fewer than 10 airborne samples")
    s_trn = s.subset(trn)
    p_s, p_s_se, p_s_source = _glide_system_power(s_trn, aircraft, _thinning(s, smoothing_s))
    start = {"cd0": aircraft.fixed_wing.cd0, "k": aircraft.fixed_wing.k,
             "efficiency": aircraft.efficiency}
    fixed = {n: v for n, v in start.items() if n not in names}
    bounds = dict(_BOUNDS, k=_k_bounds(aspect_ratio))
    cols, rhs = _regressors(s_trn, mass, aircraft.fixed_wing.wing_area_m2, p_s)
    x, free, resid, a = _solve(cols, rhs, names, fixed, bounds)
    values = dict(zip(names, map(float, x)))
    thin = _thinning(s, smoothing_s)
    cov = covariance(a[::thin], resid[::thin])
    if cov.singular:
        warnings.warn("covariance of the aircraft fit is indeterminate (singular design)")
    stderr = dict(zip(names, map(float, cov.stderr)))
    at_bound, misfit = _at_bounds(names, x, free, bounds)
    fitted = with_params(aircraft, {**values, "system_power_w": p_s})
    fw = fitted.fixed_wing
    shifted = _shifted(s_trn, mass, fw.wing_area_m2, p_s, aspect_ratio)
    for m in misfit:
        if m["parameter"] == "k" and m["bound"] == "low" and shifted["cl_min"] > 0.1:
            m["cause"] += (f" (the same balance with the least drag free puts it at C_L "
                           f"{shifted['cl_min']:.2f}, C_D {shifted['cd_min']:.4f})")
    e, e_se = _oswald(aspect_ratio, fw.k, stderr, misfit)
    plaus_values = {"cd0": fw.cd0, "efficiency": fitted.efficiency}
    if e is not None:
        plaus_values["oswald_efficiency"] = e
    poor = [n for n in names if n not in at_bound and (
        not math.isfinite(stderr[n]) or stderr[n] > POOR_RELATIVE_STDERR * abs(values[n]))]
    status = _fit_status(misfit)
    parameters_out = {**values, "system_power_w": p_s}
    stderr_out = {**stderr, "system_power_w": p_s_se}
    result: dict[str, Any] = {
        "aircraft": fitted, "parameters": parameters_out,
        "start": {**{n: float(start[n]) for n in names},
                  "system_power_w": float(aircraft.system_power_w)},
        "stderr": stderr_out, "poorly_determined": poor, "at_bound": at_bound,
        "split": how, "method": "energy rate: eta (P - P_S) = D V + m g dh/dt + m V dV/dt "
                                "([UAV23] eq. 2 with the acceleration term kept)",
        "fit_status": status, "misfit": misfit,
        "plausibility": _plausibility(plaus_values),
        "aspect_ratio": aspect_ratio, "oswald_efficiency": e,
        "oswald_efficiency_stderr": e_se,
        "system_power": {"value_w": p_s, "stderr_w": p_s_se, "source": p_s_source},
        "shifted_polar": shifted,
        "glides": {str(k): _glides(s_trn.subset(s_trn.experiment == k), mass,
                                   fw.wing_area_m2, fw.cd0, fw.k, smoothing_s)
                   for k in dict.fromkeys(s_trn.experiment)},
        "energy_rate_rmse_w": float(np.sqrt(np.mean(resid**2))),
        "sources": s.sources, "mass_kg": mass,
        "smoothing_s": smoothing_s, "trim_s": trim_s,
        "train_experiments": sorted(set(s.experiment[trn])),
        "validation_experiments": sorted(set(s.experiment[val])),
        "stderr_note": f"residuals thinned to one in {thin} rows (the smoothing's "
                       "correlation time), AR(1)-inflated",
    }
    result.update(_scores(aircraft, fitted, s, trn, val, mass))
    result["samples_table"] = corrected_samples(s, fitted, mass, trn)
    for m in misfit:
        warnings.warn(f"{m['parameter']} ended on its {m['bound']} bound: a misfit "
                      f"({m['cause']})")
    if poor:
        warnings.warn(f"poorly determined by these flights: {', '.join(poor)} (standard "
                      f"error above {POOR_RELATIVE_STDERR:.0%} of the value)")
    return result


def corrected_samples(s: EnergyRateSamples, aircraft: Aircraft, mass: float,
                      train=None) -> pd.DataFrame:
    r"""The samples corrected for the energy rate with the fitted η and :math:`P_S`:
    the drag coefficient :math:`C_D = (\eta (P - P_S) - m V \dot V - m g \dot h) /
    (\tfrac12 \rho V^3 S)` against :math:`C_L`, and the battery power of level, steady
    flight :math:`P - (m V \dot V + m g \dot h)/\eta` against the airspeed (Sharpe &
    Hansman's corrected data)."""
    s_area = aircraft.fixed_wing.wing_area_m2
    eta, p_s = aircraft.efficiency, aircraft.system_power_w
    rate = energy_rate(mass, s.airspeed, s.acceleration, s.climb_rate)
    a, _ = polar_power_terms(s.airspeed, s.air_density, mass, s_area)
    return pd.DataFrame({
        "experiment": s.experiment, "time_s": s.time_s, "airspeed_ms": s.airspeed,
        "air_density": s.air_density,
        "lift_coefficient": lift_coefficient(s.airspeed, s.air_density, mass, s_area),
        "drag_coefficient": (eta * (s.power_w - p_s) - rate) / a,
        "level_power_w": s.power_w - rate / eta, "power_w": s.raw_power_w,
        "glide": s.glide,
        "train": np.ones(len(s), bool) if train is None else np.asarray(train, bool)})


def fitted_mapping(mapping: dict, result: dict) -> dict:
    """The fitted aircraft's YAML mapping with ``fit_status`` and, when the aspect ratio
    is known, the polar written as ``aspect_ratio`` and ``oswald_efficiency`` (inside the
    schema's 0.3–1 by the fit's bounds)."""
    out = dict(mapping)
    block = dict(out.get("fixed_wing", {}))
    e, ar = result.get("oswald_efficiency"), result.get("aspect_ratio")
    if e is not None and ar is not None and OSWALD_BOUNDS[0] <= e <= OSWALD_BOUNDS[1] + 1e-12:
        block.pop("k", None)
        block["aspect_ratio"] = float(ar)
        block["oswald_efficiency"] = float(min(e, OSWALD_BOUNDS[1]))
        out["fixed_wing"] = block
    out["fit_status"] = result["fit_status"]
    return out
