"""Identify an aircraft's power parameters from flights.

The physics model driven by the measured flight state (the mission chain's
:meth:`~planner.chain.mission_chain.MissionChain.power_at` with the state of
:func:`planner.chain.flightstate.from_record`) is fitted
to the measured electric power of the airborne samples by least squares
(:func:`scipy.optimize.least_squares`):

* multirotor — efficiency η (electrical → shaft), body drag area f and the
  system load P_S (the figure of merit stays as given: in hover it is not
  separable from η); where the flights log the axial speed, also the drag the rotor
  disks' tilt balances (:func:`tilt_drag_area`);
* fixed-wing — C_D0, K, η and P_S (η is separable from the polar only
  through climbs and descents; a poorly determined parameter is reported). This steady
  fit suits flights flown by the steady model (the fleet's simulated flights); the
  ``fit-aircraft`` command fits real fixed-wing flights by the energy-rate balance
  instead (:func:`planner.identify.fixed_wing_fit.fit_fixed_wing`).

Standard errors come from the Jacobian, inflated for the autocorrelation of
neighbouring samples: the covariance is multiplied by (1 + ρ₁)/(1 − ρ₁), with
ρ₁ the lag-1 autocorrelation of the residuals (AR(1) effective sample size,
:func:`planner.identify.stats.covariance`).

A multirotor with ``power_model: rotor_losses`` (:mod:`planner.physics.power.rotor_losses`) is
fitted by :func:`fit_rotor_losses`:

* the power with the rotors stopped, P_stop (``system_power_w``), is *measured*, as the
  median power of the rotors-stopped ground samples (within
  :data:`STOPPED_HEIGHT_M` of the first altitude, ground speed below
  :data:`STOPPED_SPEED_MS`, power below :data:`STOPPED_POWER_FRACTION` of the median
  airborne power), and held; without such samples the file's value is held and the
  report says so;
* free: the motor no-load loss P_nl, the copper loss P_cu, the profile power ratio r₀
  (written as ``figure_of_merit`` = 1/(κ + r₀)) and the drag area f; the drive
  efficiency η_d and the induced factor κ stay as given;
* least squares in watts on the airborne samples; standard errors cluster-robust with one
  cluster per flight (:func:`planner.identify.stats.cluster_covariance`; AR(1)-inflated when the
  training data are one flight);
* the lead of the power channel over the state channels (``power_lead_s``) is chosen
  among :data:`LEADS_S` by the training RMS alone;
* as for the ``momentum`` model, where the flights log the axial speed the drag the rotor
  disks' tilt balances (``tilt_drag_area_m2``) is read from it (:func:`tilt_drag_area`),
  the tilt every plan then flies; a fit of named ``parameters`` holds the file's;
* a parameter that ends on one of its bounds is reported as a misfit of the model's form
  (``at_bound``), not as a value.

Validation never uses samples the fit saw: whole flights are held out where
there are several (``validate``), else the last 30 % of the single flight's
time. The error is reported before (the aircraft file as given) and after.

Fit status (every fit)
----------------------
A parameter that ends on one of its bounds, or outside its physical range, is a
**misfit** of the model's form on these flights, not a value (``fit_status``
``misfit: …``; ``fit-aircraft`` writes it into the file and exits 1). Physical ranges:
η at most :data:`MAX_EFFICIENCY` (an electric motor with its ESC); a constant load P_S no
more than what the aircraft draws on the ground with its rotors stopped or idle (the 95th
percentile of its ground samples, plus :data:`GROUND_MARGIN_W` and three standard errors)
and at most half the lowest airborne power. Each misfit names its likely cause from the
flights: too little excitation (the flights barely move: 95 % of the airborne samples
below :data:`MOVING_MS`, so the drag cannot be seen; or a power that varies by less than
:data:`MIN_POWER_CV`), one regime only (:data:`ONE_REGIME_SHARE` of the airborne samples
in hover, or in cruise), or a model whose form does not fit.

A constant load outside its physical range is what the rotors' model cannot follow, put
where it costs the least: the multirotor fit is then done again with P_S held at the
aircraft file's value — as ``diagnose`` calibrates the same aircraft (its baseline holds
P_S and fits η and the drag area) — and that fit is written, its status naming the free
fit it replaces. ``diagnose`` and ``fit-aircraft`` then differ only in what each
averages over (``diagnose``: bin means of B seconds and its own airborne phases).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from planner.chain import flightstate
from planner.io import record
from planner.chain.mission_chain import MissionChain
from planner.errors import FitError, InputError
from planner.parameters import Aircraft
from planner.parameters.aircraft import MODEL_ONLY_KEYS
from planner.physics.power.rotor_losses import (
    RotorLossesPower,
    battery_power_from_unit_terms,
    rotor_losses_components,
)
from planner.identify import stats
from planner.physics.limits import DESCENT_INFLOW_WEIGHT_MAX, DESCENT_INFLOW_WEIGHT_MIN

#: Parameters fitted, start-value source, bounds, per aircraft type.
PARAMETERS = {
    "multirotor": {"efficiency": (0.2, 1.0), "drag_area_m2": (0.0, 2.0),
                   "system_power_w": (0.0, 2000.0),
                   "descent_inflow_weight": (DESCENT_INFLOW_WEIGHT_MIN,
                                             DESCENT_INFLOW_WEIGHT_MAX)},
    "fixed_wing": {"cd0": (0.002, 0.3), "k": (0.005, 0.5), "efficiency": (0.1, 1.0),
                   "system_power_w": (0.0, 2000.0)},
}
#: Bounds of the fixed-wing propeller's profile power, fitted with the polar when the
#: aircraft has a propeller (:mod:`planner.physics.power.propeller`). [W]
PROPELLER_PROFILE_BOUNDS_W = (0.0, 2000.0)
#: Free parameters of the rotor_losses model and their bounds (r₀ is fitted as the
#: profile power ratio; its upper bound is FM = 0.2). [W], [W], [unitless], [m²]
ROTOR_LOSSES_PARAMETERS = {"no_load_power_w": (0.0, 2000.0),
                           "copper_loss_power_w": (0.0, 2000.0),
                           "profile_power_ratio": (0.0, 3.85),
                           "drag_area_m2": (0.0, 2.0),
                           "descent_inflow_weight": (DESCENT_INFLOW_WEIGHT_MIN,
                                                     DESCENT_INFLOW_WEIGHT_MAX)}
#: Least vertical descent in the training flights, in time and in flights, for the fit to
#: free the slow-descent inflow weight (``descent_inflow_weight``); with less it is held
#: at the file's value and the report says why. [s], [flights]
MIN_DESCENT_S, MIN_DESCENT_FLIGHTS = 60.0, 3
#: Leads of the power channel over the flight-state channels tried by the fit. [s]
LEADS_S = (0.0, 0.15, 0.3)
#: Rotors-stopped ground samples: within this height of the first altitude [m], ...
STOPPED_HEIGHT_M = 1.0
#: ... slower than this over ground [m/s], ...
STOPPED_SPEED_MS = 0.3
#: ... and drawing less than this share of the median airborne power (the M100's
#: propellers idling on the ground draw 36 W, 8 % of its 450 W in flight; its
#: avionics 2–10 W, under 2 %). [unitless]
STOPPED_POWER_FRACTION = 0.05
#: Fewest rotors-stopped samples to measure P_stop from. [samples]
STOPPED_MIN_SAMPLES = 10
#: A parameter whose standard error exceeds this share of its value is "poorly determined"
#: (:func:`planner.identify.stats.poorly_determined`). Wider than the battery fit's 10 %:
#: the power terms trade against each other (η against the drag area and the constant
#: load), and a small term is reported when the flights pin it within half its value;
#: this module's choice, not a published threshold. [unitless]
POOR_RELATIVE_STDERR = 0.5
#: Highest efficiency of an electric motor with its ESC, battery to shaft (module notes,
#: "Fit status"). [unitless]
MAX_EFFICIENCY = 0.95
#: Allowance above the ground power for a constant load (sensor noise, heaters): as
#: diagnose's (:data:`planner.identify.diagnose.effects.GROUND_POWER_MARGIN_W`). [W]
GROUND_MARGIN_W = 5.0
#: Ground speed below which an airborne sample counts as hovering, and the speed 95 % of
#: the samples must exceed for the drag to be seen. [m/s]
MOVING_MS = 3.0
#: A power that varies by less than this coefficient of variation cannot tell η from a
#: constant load. [unitless]
MIN_POWER_CV = 0.05
#: Share of the airborne samples in one regime (hover or cruise) beyond which the fit sees
#: one regime only. [unitless]
ONE_REGIME_SHARE = 0.9


def get_param(aircraft: Aircraft, name: str) -> float:
    """The value of a fitted parameter in an aircraft: ``efficiency`` and ``system_power_w``
    of the aircraft, the others of its multirotor or fixed-wing block. [unit of the
    parameter]
    """
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
    specific_force: np.ndarray | None = None
    #: True where ``airspeed`` and ``climb_rate`` are the rotor disks' measured in-plane
    #: and axial speed (:attr:`planner.chain.flightstate.FlightState.disk_frame`).
    disk_frame: np.ndarray | None = None

    def subset(self, mask: np.ndarray) -> Samples:
        """The samples where ``mask`` is true (an optional channel that is None stays
        None)."""
        return Samples(*(None if getattr(self, f) is None else getattr(self, f)[mask]
                         for f in Samples.__dataclass_fields__))


def _check_fittable(exp_id, exp: pd.DataFrame) -> None:
    """Raise :class:`InputError` unless the experiment has power and flight state."""
    if record.voltage_only(exp):
        raise InputError(f"experiment {exp_id}: {record.NO_CURRENT} (battery voltage only): "
                         "fitting an aircraft needs the measured power")
    if not record.has_power(exp) or not {"climb_rate_ms", "groundspeed_ms"} & set(exp.columns):
        raise InputError(f"experiment {exp_id}: needs power and flight state "
                         "(climb_rate_ms, groundspeed_ms or airspeed_ms) to fit an aircraft")


def airborne_samples(data: pd.DataFrame, site_altitude_m: float = 0.0,
                     airborne_height_m: float | None = None, states=None) -> Samples:
    """Flight state and measured power of the airborne samples of every experiment
    (:func:`airborne_mask`); ``states``: the experiments' flight states where the caller
    has them already (:func:`_states` of ``data``)."""
    parts = []
    for exp_id, exp, state in (_states(data, site_altitude_m) if states is None else states):
        t = exp["time_s"].to_numpy(float)
        p = exp["power_w"].to_numpy(float)
        (v, climb), rho = state.rotor_velocities(), state.air_density
        ok = airborne_mask(exp, state, airborne_height_m) & np.isfinite(p) & np.isfinite(v)
        dt = np.gradient(t) if len(t) > 1 else np.ones_like(t)
        parts.append((np.full(ok.sum(), exp_id, dtype=object), t[ok], v[ok], climb[ok],
                      rho[ok], p[ok], dt[ok], np.full(ok.sum(), state.disk_frame)))
    parts = [part for part in parts if len(part[1])]
    if not parts:
        raise InputError("no airborne samples in the data (ground tests only?)")
    cols = [np.concatenate([part[i] for part in parts]) for i in range(8)]
    return Samples(*cols[:7], disk_frame=cols[7])


def vertical_descent(s: Samples) -> tuple[float, int]:
    """Time [s] the samples spend in vertical descent
    (:func:`planner.chain.flightstate.vertical_descent` of their in-plane airspeed) and the
    number of flights it comes from."""
    down = flightstate.vertical_descent(s.airspeed, s.climb_rate)
    return float(np.sum(s.dt[down])), int(np.unique(s.experiment[down]).size)


def _descent_held(s_trn: Samples) -> str | None:
    """Why the training flights cannot free ``descent_inflow_weight`` (too little vertical
    descent), or None."""
    seconds, flights = vertical_descent(s_trn)
    if seconds >= MIN_DESCENT_S and flights >= MIN_DESCENT_FLIGHTS:
        return None
    return (f"the training flights descend vertically for {seconds:.0f} s in {flights} "
            f"flight(s), fewer than the {MIN_DESCENT_S:g} s in {MIN_DESCENT_FLIGHTS} that "
            "show the power of a slow descent")


def _descent_weight_freed(names: list[str], parameters, s_trn: Samples,
                          aircraft: Aircraft) -> tuple[list[str], dict[str, str]]:
    """The parameters to fit, without ``descent_inflow_weight`` where the fit chooses
    them itself (``parameters`` None) and the training samples ``s_trn`` cannot free it
    (:func:`_descent_held`), and what is held with why."""
    if "descent_inflow_weight" not in names or parameters is not None:
        return names, {}
    why = _descent_held(s_trn)
    if why is None:
        return names, {}
    w = aircraft.multirotor.descent_inflow_weight
    return ([n for n in names if n != "descent_inflow_weight"],
            {"descent_inflow_weight": f"held at the file's {w:g}: {why}"})


def _predict(aircraft: Aircraft, s: Samples, mass: np.ndarray) -> np.ndarray:
    chain = MissionChain(aircraft, None)
    force = s.specific_force
    disk = False if s.disk_frame is None else s.disk_frame
    if force is None or not aircraft.has_rotor_losses:
        return chain.power_at(s.airspeed, s.climb_rate, s.air_density, mass, disk_frame=disk)
    ok = np.isfinite(force)
    measured = chain.power_at(s.airspeed, s.climb_rate, s.air_density, mass,
                              thrust=mass * np.where(ok, force, 9.80665), disk_frame=disk)
    if ok.all():
        return measured
    return np.where(ok, measured, chain.power_at(s.airspeed, s.climb_rate, s.air_density,
                                                 mass, disk_frame=disk))


def sample_masses(s: Samples, mass_kg) -> np.ndarray:
    """The all-up mass of every sample [kg]: ``mass_kg`` is one mass for every flight, or a
    mapping experiment id → that flight's mass (a mass per flight, e.g. empty + pack + the
    payload of :func:`planner.io.record.experiment_payloads`)."""
    if not isinstance(mass_kg, dict):
        return np.full(len(s.time_s), float(mass_kg))
    missing = sorted(set(map(str, s.experiment)) - set(mass_kg))
    if missing:
        raise InputError(f"no mass for experiment(s) {', '.join(missing[:10])}; expected one "
                         "per flight")
    ids, inverse = np.unique(s.experiment.astype(str), return_inverse=True)
    return np.array([float(mass_kg[i]) for i in ids])[inverse]


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


#: Fewest airborne samples of an aircraft fit, and of its training split. [samples]
MIN_AIRBORNE_SAMPLES, MIN_TRAINING_SAMPLES = 20, 10


def _fit_split(s: Samples, validate, train):
    """:func:`split_experiments` of samples that are enough to fit an aircraft
    (:data:`MIN_AIRBORNE_SAMPLES`, :data:`MIN_TRAINING_SAMPLES`), else InputError."""
    if len(s.measured_w) < MIN_AIRBORNE_SAMPLES:
        raise InputError(f"only {len(s.measured_w)} airborne samples: too few to fit "
                         f"an aircraft (expected at least {MIN_AIRBORNE_SAMPLES})")
    trn, val, how = split_experiments(s, validate, train)
    if trn.sum() < MIN_TRAINING_SAMPLES:
        raise InputError(f"the training split has fewer than {MIN_TRAINING_SAMPLES} "
                         "airborne samples")
    return trn, val, how


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
        out[str(exp_id)] = (100.0 * (float(np.sum(pred[m] * s.dt[m])) - e_m) / e_m
                            if e_m > 0 else float("nan"))
    return out


def fit_aircraft(data: pd.DataFrame, aircraft: Aircraft, *, mass_kg: float,
                 parameters: list[str] | None = None, train: list[str] | None = None,
                 validate: list[str] | None = None, site_altitude_m: float = 0.0,
                 airborne_height_m: float | None = None, **kwargs) -> dict[str, Any]:
    """Fit the aircraft's power parameters to measured flights.

    Parameters
    ----------
    data : DataFrame
        Flight record(s) with power and flight state.
    aircraft : Aircraft
        Start values and the fixed parameters.
    mass_kg : float or dict
        All-up mass of the flights, or of each flight (experiment id → mass). [kg]
    parameters : list of str, optional
        Which of :data:`PARAMETERS` to fit (default all for the type).
    train, validate : list of str, optional
        Experiment ids; default: every third flight validates.
    site_altitude_m : float
        Site altitude for the ISA density when the record has no pressure. [m]
    airborne_height_m : float, optional
        Airborne = more than this above the experiment's first sample (default: the
        flight phases other than ground, take-off and landing). [m]
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
    if aircraft.has_rotor_losses:
        return fit_rotor_losses(data, aircraft, mass_kg=mass_kg, parameters=parameters,
                                train=train, validate=validate,
                                site_altitude_m=site_altitude_m,
                                airborne_height_m=airborne_height_m, **kwargs)
    table = dict(PARAMETERS[aircraft.type])
    if aircraft.is_multirotor and aircraft.multirotor.descent_inflow_weight is None:
        del table["descent_inflow_weight"]      # a model without inflow (propeller)
    if not aircraft.is_multirotor and aircraft.fixed_wing.propeller_diameter_m:
        table["propeller_profile_power_w"] = PROPELLER_PROFILE_BOUNDS_W
    names = parameters or list(table)
    unknown = set(names) - set(table)
    if unknown:
        raise InputError(f"cannot fit {sorted(unknown)} for a {aircraft.type}; "
                         f"expected some of {', '.join(table)}")
    states = _states(data, site_altitude_m)
    s = airborne_samples(data, airborne_height_m=airborne_height_m, states=states)
    trn, val, how = _fit_split(s, validate, train)
    s_trn, s_val = s.subset(trn), s.subset(val)
    mass_trn = sample_masses(s_trn, mass_kg)
    names, held = _descent_weight_freed(names, parameters, s_trn, aircraft)
    x0 = np.array([get_param(aircraft, n) for n in names])
    lo = np.array([table[n][0] for n in names])
    hi = np.array([table[n][1] for n in names])
    x0 = np.clip(x0, lo + 1e-9, hi - 1e-9)
    scale = np.maximum(np.abs(x0), 1e-3)
    scale[[n == "descent_inflow_weight" for n in names]] = 1.0  # unitless, −1 … 2

    def residual(x):
        ac = with_params(aircraft, dict(zip(names, x)))
        return _predict(ac, s_trn, mass_trn) - s_trn.measured_w

    sol = _solve(residual, x0, lo, hi, scale, kwargs)
    ground = ground_power(data, site_altitude_m, set(s_trn.experiment))
    misfit = misfits(dict(zip(names, map(float, sol.x))), dict(zip(names, lo)),
                     dict(zip(names, hi)), s_trn, ground, _stderr(sol, names, warn=False)[0])
    free = None
    if aircraft.is_multirotor and "system_power_w" in names and parameters is None and \
            any(m["parameter"] == "system_power_w" for m in misfit):
        # the constant load the rotors' model cannot follow: fit again with it held at the
        # file's value, as diagnose does, and write that (module notes, "Fit status")
        free = (dict(zip(names, map(float, sol.x))), misfit)
        keep = [i for i, n in enumerate(names) if n != "system_power_w"]
        names = [n for n in names if n != "system_power_w"]
        x0, lo, hi, scale = x0[keep], lo[keep], hi[keep], scale[keep]
        sol = _solve(residual, x0, lo, hi, scale, kwargs)
        misfit = misfits(dict(zip(names, map(float, sol.x))), dict(zip(names, lo)),
                         dict(zip(names, hi)), s_trn, ground,
                         _stderr(sol, names, warn=False)[0])
    fitted = with_params(aircraft, dict(zip(names, sol.x)))
    stderr, poor = _stderr(sol, names)
    result = {
        "aircraft": fitted, "parameters": dict(zip(names, map(float, sol.x))),
        "start": dict(zip(names, map(float, x0))), "stderr": stderr,
        "poorly_determined": poor, "split": how,
        "train_experiments": sorted(set(s_trn.experiment)),
        "validation_experiments": sorted(set(s_val.experiment)),
        "experiments": list(dict.fromkeys(s.experiment)),
        "ground_power": ground, "held": held,
    }
    result.update(_status(misfit, free, aircraft))
    if parameters is None:
        result = with_tilt(result, aircraft, states, mass_kg, airborne_height_m)
    result.update(_scores(aircraft, result["aircraft"], s, s, trn, val, mass_kg))
    return result


#: Fewest training flights whose per-flight energy errors give the fitted aircraft its
#: ``energy_error_sd``: with fewer, the spread of one or two numbers is no spread.
MIN_FLIGHTS_ENERGY_ERROR_SD = 3


def energy_error_sd(fitted: Aircraft, s_trn: Samples, mass_kg) -> tuple[float | None, int]:
    """The spread of the fitted model's whole-flight energy error on its training flights:
    the root mean square of (predicted − measured) / measured energy of each flight's
    airborne part (:func:`per_experiment_energy_error`), about zero because
    ``check --uncertainty`` draws the error centred on the model; and the flights it
    rests on. None with fewer than :data:`MIN_FLIGHTS_ENERGY_ERROR_SD` flights. [unitless]

    An in-sample figure: the flights the parameters were fitted to, so it is a lower
    bound of the error on other flights."""
    m = sample_masses(s_trn, mass_kg)
    errors = np.array(list(per_experiment_energy_error(fitted, s_trn, m).values())) / 100.0
    errors = errors[np.isfinite(errors)]
    if errors.size < MIN_FLIGHTS_ENERGY_ERROR_SD:
        return None, int(errors.size)
    return float(np.sqrt(np.mean(errors**2))), int(errors.size)
def ground_power(data: pd.DataFrame, site_altitude_m: float, ids=None) -> dict | None:
    """The power the aircraft draws on the ground (phase ``ground`` of
    :func:`planner.chain.flightstate.flight_phases`, rotors stopped or idle) over the
    experiments ``ids`` (default all): ``low_w`` and ``high_w`` (5th and 95th percentile)
    and ``samples``; None with fewer than :data:`STOPPED_MIN_SAMPLES`. [W]"""
    values = []
    for exp_id, exp in record.experiments(data):
        if ids is not None and str(exp_id) not in ids:
            continue
        if not record.has_power(exp):
            continue
        st = flightstate.from_record(exp.reset_index(drop=True), site_altitude_m)
        p = st.measured_power_w
        values.append(p[(st.phase == "ground") & np.isfinite(p)])
    values = np.concatenate(values) if values else np.zeros(0)
    if values.size < STOPPED_MIN_SAMPLES:
        return None
    return {"low_w": float(np.percentile(values, 5)), "high_w": float(np.percentile(values, 95)),
            "samples": int(values.size)}


def misfits(values: dict[str, float], low: dict[str, float], high: dict[str, float],
            s: Samples, ground: dict | None, stderr: dict[str, float]) -> list[dict]:
    """The parameters on a bound or outside their physical range, each with the likely
    cause (module notes, "Fit status"): ``parameter``, ``value``, ``why``, ``cause``."""
    out = []
    for n, v in values.items():
        lo, hi = low[n], high[n]
        if min(v - lo, hi - v) <= 1e-4 * (hi - lo):
            out.append({"parameter": n, "value": v,
                        "why": f"ended on its {'low' if v - lo < hi - v else 'high'} bound "
                               f"{v:.4g}"})
        elif n == "efficiency" and v > MAX_EFFICIENCY:
            out.append({"parameter": n, "value": v,
                        "why": f"{v:.3f} is above any electric motor with its ESC "
                               f"({MAX_EFFICIENCY:g})"})
        elif n == "system_power_w":
            se = stderr.get(n, 0.0)
            se = se if math.isfinite(se) else 0.0
            air = float(np.percentile(s.measured_w, 5))
            if ground is not None and v > ground["high_w"] + GROUND_MARGIN_W + 3.0 * se:
                out.append({"parameter": n, "value": v,
                            "why": (f"{v:.0f} W is more than the aircraft draws on the ground "
                                    f"with its rotors stopped or idle ({ground['low_w']:.0f}–"
                                    f"{ground['high_w']:.0f} W): what the fit puts there is "
                                    "drawn only while the rotors turn")})
            elif v > 0.5 * air:
                out.append({"parameter": n, "value": v,
                            "why": (f"{v:.0f} W is more than half the lowest airborne power "
                                    f"({air:.0f} W)")})
    cause = likely_cause(s)
    for m in out:
        m["cause"] = cause
    return out


def likely_cause(s: Samples) -> str:
    """Why the flights cannot pin the power parameters, in words (module notes)."""
    v, p = np.abs(s.airspeed), s.measured_w
    hover = float(np.mean((v < 1.0) & (np.abs(s.climb_rate) < 0.5)))
    v95 = float(np.percentile(v, 95))
    cv = float(np.std(p) / np.mean(p)) if np.mean(p) > 0 else 0.0
    cruise = float(np.mean(np.abs(v - np.median(v)) < 1.0)) if v95 >= MOVING_MS else 0.0
    if v95 < MOVING_MS:
        return (f"too little excitation: the flights barely move (95 % of the airborne "
                f"samples below {v95:.1f} m/s), so the drag cannot be seen and the efficiency "
                "trades against the constant load")
    if cv < MIN_POWER_CV:
        return (f"too little excitation: the power varies by only {100 * cv:.1f} % over the "
                "airborne samples, so the efficiency cannot be told from a constant load")
    if hover >= ONE_REGIME_SHARE:
        return (f"one regime only: {100 * hover:.0f} % of the airborne samples hover, so the "
                "efficiency, the drag area and a constant load trade against each other")
    if cruise >= ONE_REGIME_SHARE:
        return (f"one regime only: {100 * cruise:.0f} % of the airborne samples cruise within "
                f"1 m/s of {np.median(v):.1f} m/s")
    return (f"the model's form does not fit how the power varies over the regimes flown "
            f"({100 * hover:.0f} % hover, speeds up to {v95:.1f} m/s, power varying "
            f"{100 * cv:.0f} %)")


def _status(misfit: list[dict], free, aircraft: Aircraft) -> dict:
    """``fit_status`` (``ok`` or ``misfit: …``), ``misfit`` and, where the free fit was
    replaced by one with the constant load held, ``free_fit`` (its values and misfits)."""
    parts = [f"{m['parameter']} {m['why']} ({m['cause']})" for m in misfit]
    out: dict[str, Any] = {"misfit": misfit}
    if free is not None:
        values, bad = free
        held = float(aircraft.system_power_w)
        cause = bad[0]["cause"]
        parts = ["the free fit: " + ", ".join(f"{m['parameter']} {m['why']}" for m in bad)
                 + f" ({cause}); written instead: the fit with system_power_w held at the "
                 f"file's {held:g} W, as diagnose calibrates"] + parts
        out["free_fit"] = {"parameters": values, "misfit": bad}
        why = next(m["why"] for m in bad if m["parameter"] == "system_power_w")
        warnings.warn(f"system_power_w {why}: the fit is done again with it held at the "
                      f"file's {held:g} W", stacklevel=3)
    for m in out["misfit"]:
        warnings.warn(f"{m['parameter']} {m['why']}: a misfit ({m['cause']})", stacklevel=3)
    out["fit_status"] = "ok" if not parts else "misfit: " + "; ".join(parts)
    return out


def _scores(aircraft, fitted, before: Samples, after: Samples, trn, val, mass_kg) -> dict:
    """Power RMSE and energy error of the start and the fitted aircraft on the training
    and (with at least 2 samples) validation rows, the per-flight energy error of the
    validation flights, and the fitted aircraft carrying its training flights'
    :func:`energy_error_sd` (``aircraft``, ``energy_error_sd``, ``energy_error_flights``).
    ``before`` and ``after`` are the samples each aircraft is flown on: the same, unless
    the fit chose a state lead."""
    sd, flights = energy_error_sd(fitted, after.subset(trn), mass_kg)
    out: dict[str, Any] = {"aircraft": replace(fitted, energy_error_sd=sd),
                           "energy_error_sd": sd, "energy_error_flights": flights}
    for name, rows in (("train", trn), ("validation", val)):
        if name == "validation" and rows.sum() < 2:
            break
        b, a = before.subset(rows), after.subset(rows)
        m = sample_masses(b, mass_kg)
        out[name] = {"before": _metrics(_predict(aircraft, b, m), b.measured_w, b.dt),
                     "after": _metrics(_predict(fitted, a, m), a.measured_w, a.dt)}
        if name == "train":
            out["samples"] = {"train": int(trn.sum()), "validation": int(val.sum())}
        else:
            out["per_experiment_energy_error_pct"] = {
                "before": per_experiment_energy_error(aircraft, b, m),
                "after": per_experiment_energy_error(fitted, a, m)}
    return out


def _stderr(sol, names, warn: bool = True):
    """Standard errors of the fitted parameters (AR(1)-inflated,
    :func:`planner.identify.stats.covariance`) and the poorly determined ones (with a
    warning unless ``warn`` is False)."""
    cov = stats.covariance(sol.jac, sol.fun)
    stderr = dict(zip(names, map(float, cov.stderr)))
    if not warn:
        return stderr, []
    cov.warn_if_singular("the aircraft fit")
    return stderr, _poorly_determined(dict(zip(names, map(float, sol.x))), stderr)


def _poorly_determined(values: dict[str, float], stderr: dict[str, float]) -> list[str]:
    """:func:`planner.identify.stats.poorly_determined` at :data:`POOR_RELATIVE_STDERR`,
    with a warning that names them."""
    poor = stats.poorly_determined(values, stderr, POOR_RELATIVE_STDERR)
    if poor:
        warnings.warn(f"poorly determined by these flights: {', '.join(poor)} "
                      f"(standard error above {POOR_RELATIVE_STDERR:.0%} of the value)",
                      stacklevel=2)
    return poor


# ------------------------------------------------------------------ rotor_losses model
def _states(data: pd.DataFrame, site_altitude_m: float):
    """(experiment id, experiment, FlightState) of every experiment with power and state."""
    out = []
    for exp_id, exp in record.experiments(data):
        exp = exp.reset_index(drop=True)
        _check_fittable(exp_id, exp)
        out.append((str(exp_id), exp, flightstate.from_record(exp, site_altitude_m)))
    return out


def _height(exp: pd.DataFrame) -> np.ndarray:
    """Altitude above the experiment's first valid altitude (NaN where unknown). [m]"""
    alt = exp["altitude_m"].to_numpy(float) if "altitude_m" in exp else np.full(len(exp),
                                                                                 np.nan)
    ok = np.isfinite(alt)
    return alt - alt[ok][0] if ok.any() else alt


def airborne_mask(exp: pd.DataFrame, state, airborne_height_m: float | None) -> np.ndarray:
    """Airborne samples: more than ``airborne_height_m`` above the first sample (the
    Choudhry et al. 2021 benchmark's definition), else the flight phases other than
    ``ground``, ``takeoff`` and ``landing`` (:func:`planner.chain.flightstate.flight_phases`)."""
    if airborne_height_m is None:
        return flightstate.flown(state.phase)
    if "altitude_m" not in exp:
        raise InputError("an airborne height needs altitude_m in the flight record")
    with np.errstate(invalid="ignore"):
        return _height(exp) > airborne_height_m


#: Steady level flight, where the tilt is read (:func:`tilt_drag_area`): climbing or
#: descending slower than this [m/s], ...
TILT_LEVEL_CLIMB_MS = 0.3
#: ... faster than this (below, the tilt's axial speed, under 0.1 m/s on the M100, is
#: within the channel's offset: its median in hover is 0.03 m/s) [m/s], ...
TILT_MIN_SPEED_MS = 3.0
#: ... and changing speed by less than this (an acceleration tilts the disks further).
#: [m/s²]
TILT_STEADY_ACCEL_MS2 = 0.3
#: Fewest such samples the tilt is read on. [count]
TILT_MIN_SAMPLES = 100


def tilt_drag_area(states, mass_kg, experiments, airborne_height_m: float | None = None
                   ) -> dict[str, Any]:
    r"""The drag area the rotor disks' measured tilt balances (``tilt_drag_area_m2``).

    In steady level flight the thrust's forward component balances the body drag,
    :math:`T\sin\alpha = D`, :math:`T\cos\alpha = W`, so the axial speed through the
    disks, :math:`V_z = V\sin\alpha`, gives the drag :math:`D = W\tan\alpha` and the
    power spent on it :math:`DV` (Leishman 2006 ch. 5; the model's
    :func:`planner.physics.power.momentum.tilted_disk_velocities`). On the steady level
    samples (:data:`TILT_LEVEL_CLIMB_MS`, :data:`TILT_MIN_SPEED_MS`,
    :data:`TILT_STEADY_ACCEL_MS2`) of the ``experiments`` whose record has the axial
    speed, least squares through the origin of :math:`DV` on :math:`\tfrac12\rho V^3`
    (in watts, so the fast samples, whose power the tilt moves most, weigh most); the
    standard error cluster-robust, one cluster per flight.

    Returns ``{"value": f_t [m²], "stderr": [m²], "samples", "flights"}``, or
    ``{"reason": …}`` where the flights do not show it (no axial speed, fewer than
    :data:`TILT_MIN_SAMPLES` samples, or a tilt within two standard errors of none: on
    the ArduCopter 3.1.3 flights of ``../shared/data/logs``, hovering and drifting at
    3–7 m/s in an unknown wind, the attitude and the GPS velocity give 0.008 and
    −0.04 m²).
    """
    from planner.physics.atmosphere import G

    xs, ys, groups = [], [], []
    with_axial = 0
    for exp_id, exp, st in states:
        if exp_id not in experiments or not st.disk_frame:
            continue
        with_axial += 1
        t, v, vc = st.time_s, st.airspeed_ms, st.climb_rate_ms
        accel = np.gradient(v, t) if t.size > 2 else np.zeros_like(v)
        speed = np.hypot(v, vc)
        with np.errstate(invalid="ignore", divide="ignore"):
            sin = np.clip(st.axial_speed_ms / speed, -0.95, 0.95)
            ok = (airborne_mask(exp, st, airborne_height_m) & (np.abs(vc) < TILT_LEVEL_CLIMB_MS)
                  & (v > TILT_MIN_SPEED_MS) & (np.abs(accel) < TILT_STEADY_ACCEL_MS2)
                  & np.isfinite(sin) & np.isfinite(st.air_density))
        if not ok.any():
            continue
        m = float(mass_kg[exp_id]) if isinstance(mass_kg, dict) else float(mass_kg)
        drag = m * G * sin[ok] / np.sqrt(1.0 - sin[ok] ** 2)
        xs.append(0.5 * st.air_density[ok] * v[ok] ** 3)
        ys.append(drag * v[ok])
        groups.append(np.full(ok.sum(), exp_id, dtype=object))
    if not with_axial:
        return {"reason": "the flights have no axial speed (axial_speed_ms)"}
    n = sum(x.size for x in xs)
    if n < TILT_MIN_SAMPLES:
        return {"reason": f"{n} steady level samples faster than {TILT_MIN_SPEED_MS:g} m/s "
                          f"(fewer than {TILT_MIN_SAMPLES})"}
    x, y, g = np.concatenate(xs), np.concatenate(ys), np.concatenate(groups)
    f = float(x @ y / (x @ x))
    cov = stats.cluster_covariance(x[:, None], y - f * x, g)
    se = float(np.sqrt(cov.matrix[0, 0]))
    if not f > 2.0 * se:
        return {"reason": f"the steady level samples show no tilt beyond its error "
                          f"({f:.3g} ± {se:.2g} m² on {n} samples: too slow, or a wind the "
                          "ground speed does not show)"}
    return {"value": f, "stderr": se, "samples": int(n), "flights": int(np.unique(g).size)}


def with_tilt(result: dict[str, Any], aircraft: Aircraft, states, mass_kg,
              airborne_height_m: float | None) -> dict[str, Any]:
    """The fit's ``result`` with the tilt read on its training flights
    (:func:`tilt_drag_area`) in its aircraft, parameters and standard errors, or, where
    the flights do not show it, the file's tilt held (in ``held``, with the reason).
    Read only by a fit of every parameter (no ``parameters`` list) and only for a model
    that flies one (``momentum``, ``rotor_losses``)."""
    if not aircraft.is_multirotor or aircraft.multirotor.power_model not in \
            MODEL_ONLY_KEYS["tilt_drag_area_m2"]:
        return result
    tilt = tilt_drag_area(states, mass_kg, set(map(str, result["train_experiments"])),
                          airborne_height_m)
    given = aircraft.multirotor.tilt_drag_area_m2
    if "reason" in tilt:
        if given is not None:
            result.setdefault("held", {})["tilt_drag_area_m2"] = (
                f"held at the file's {given:g} m²: {tilt['reason']}")
        result["tilt"] = tilt
        return result
    result["aircraft"] = with_params(result["aircraft"], {"tilt_drag_area_m2": tilt["value"]})
    result["parameters"]["tilt_drag_area_m2"] = tilt["value"]
    result["stderr"]["tilt_drag_area_m2"] = tilt["stderr"]
    result["start"]["tilt_drag_area_m2"] = math.nan if given is None else float(given)
    result["tilt"] = tilt
    return result


def rotor_losses_samples(states, lead_s: float = 0.0,
                         airborne_height_m: float | None = None) -> Samples:
    """Airborne samples with the flight state read ``lead_s`` after each power sample
    (linear interpolation within the experiment, held at its ends) and the specific
    force where the record has it (NaN elsewhere)."""
    parts = []
    for exp_id, exp, st in states:
        t = st.time_s
        ok = airborne_mask(exp, st, airborne_height_m) & np.isfinite(st.measured_power_w)

        def later(x):
            return x if lead_s == 0.0 or t.size < 2 else np.interp(t + lead_s, t, x)

        force = (later(st.specific_force_ms2) if st.specific_force_ms2 is not None
                 else np.full(t.size, np.nan))
        v, climb = st.rotor_velocities()
        dt = np.gradient(t) if len(t) > 1 else np.ones_like(t)
        parts.append((np.full(ok.sum(), exp_id, dtype=object), t[ok],
                      later(v)[ok], later(climb)[ok],
                      later(st.air_density)[ok], st.measured_power_w[ok], dt[ok], force[ok],
                      np.full(ok.sum(), st.disk_frame)))
    parts = [part for part in parts if len(part[1])]
    if not parts:
        raise InputError("no airborne samples in the data (ground tests only?)")
    return Samples(*(np.concatenate([part[i] for part in parts]) for i in range(9)))


def stopped_power(states, airborne_power_w: float) -> tuple[float | None, int]:
    """Median power of the rotors-stopped ground samples (module notes), ≥ 0, and their
    count; None with fewer than :data:`STOPPED_MIN_SAMPLES`. [W]"""
    values = []
    for _, exp, st in states:
        h = _height(exp)
        gs = exp["groundspeed_ms"].to_numpy(float) if "groundspeed_ms" in exp else \
            np.full(len(exp), np.nan)
        p = st.measured_power_w
        with np.errstate(invalid="ignore"):
            ok = ((np.abs(h) < STOPPED_HEIGHT_M) & (gs < STOPPED_SPEED_MS)
                  & (p < STOPPED_POWER_FRACTION * airborne_power_w) & np.isfinite(p))
        values.append(p[ok])
    values = np.concatenate(values) if values else np.array([])
    if values.size < STOPPED_MIN_SAMPLES:
        return None, int(values.size)
    return max(float(np.median(values)), 0.0), int(values.size)


def _unit_terms(aircraft: Aircraft, s: Samples, mass: np.ndarray, drag_area: float):
    """:func:`planner.power.rotor_losses.rotor_losses_components` of the samples at unit
    r₀, P_nl and P_cu (for :func:`~planner.power.rotor_losses.battery_power_from_unit_terms`),
    with the arguments :meth:`Aircraft.rotor_losses_power` passes and the measured thrust
    where the samples have a specific force, as :func:`_predict`."""
    m = aircraft.multirotor
    airspeed, climb = aircraft.disk_velocities(
        s.airspeed, s.climb_rate, s.air_density, mass,
        disk_frame=False if s.disk_frame is None else s.disk_frame)

    def at(thrust):
        return rotor_losses_components(
            mass, s.air_density, m.rotors, m.rotor_diameter_m, 1.0, airspeed=airspeed,
            climb_rate=climb, drag_area=drag_area, induced_factor=m.induced_factor,
            profile_power_ratio=1.0, tip_speed=m.tip_speed_ms, no_load_power=1.0,
            copper_loss_power=1.0, reference_mass=m.reference_mass_kg, thrust=thrust,
            descent_inflow_weight=m.descent_inflow_weight)

    force = s.specific_force
    if force is None or not np.isfinite(force).any():
        return at(None)
    ok = np.isfinite(force)
    measured = at(mass * np.where(ok, force, 9.80665))
    if ok.all():
        return measured
    trim = at(None)
    return RotorLossesPower(**{k: np.where(ok, getattr(measured, k), getattr(trim, k))
                               for k in RotorLossesPower.__dataclass_fields__})


def _rotor_losses_aircraft(aircraft: Aircraft, values: dict[str, float]) -> Aircraft:
    values = dict(values)
    if "profile_power_ratio" in values:
        r0 = values.pop("profile_power_ratio")
        values["figure_of_merit"] = 1.0 / (aircraft.multirotor.induced_factor + r0)
    return with_params(aircraft, values)


def _profile_ratio(aircraft: Aircraft) -> float:
    from planner.physics.power.momentum import DEFAULT_FIGURE_OF_MERIT
    m = aircraft.multirotor
    return 1.0 / (m.figure_of_merit or DEFAULT_FIGURE_OF_MERIT) - m.induced_factor


def fit_rotor_losses(data: pd.DataFrame, aircraft: Aircraft, *, mass_kg: float,
                     parameters: list[str] | None = None, train: list[str] | None = None,
                     validate: list[str] | None = None, site_altitude_m: float = 0.0,
                     airborne_height_m: float | None = None, leads_s=LEADS_S,
                     **kwargs) -> dict[str, Any]:
    """Fit the ``rotor_losses`` multirotor model to measured flights (module notes).

    Parameters as :func:`fit_aircraft`; ``parameters`` are names among
    ``no_load_power_w``, ``copper_loss_power_w``, ``figure_of_merit``, ``drag_area_m2``
    and ``descent_inflow_weight`` (by default freed only where the training flights
    descend vertically, :func:`_descent_weight_freed`); ``airborne_height_m`` selects
    the airborne samples by height above the first sample instead of the flight phases;
    ``leads_s`` the leads tried. [s]

    Returns
    -------
    dict
        As :func:`fit_aircraft` (with ``held``), plus ``at_bound`` (parameters ending on
        a bound: misfit of the model's form), ``stopped_power`` (value, samples, source), ``lead_s``
        (chosen), ``lead_train_rmse_w`` (per lead tried) and ``profile_power_ratio``.
    """
    chosen = _rotor_losses_chosen(parameters)
    states = _states(data, site_altitude_m)
    given_lead = float(aircraft.multirotor.power_lead_s or 0.0)
    samples = {lead: rotor_losses_samples(states, lead, airborne_height_m)
               for lead in dict.fromkeys([*leads_s, given_lead])}
    s0 = samples[given_lead]
    trn, val, how = _fit_split(s0, validate, train)
    chosen, held = _descent_weight_freed(chosen, parameters, s0.subset(trn), aircraft)
    names = ["profile_power_ratio" if n == _FM else n for n in chosen]
    p_air = float(np.median(s0.measured_w))
    stop = _held_stopped_power(states, set(s0.experiment[trn]), p_air, aircraft)
    base = with_params(aircraft, {"system_power_w": stop["value_w"]})
    x0, lo, hi, scale = _rotor_losses_start(base, names, p_air)
    fits = {lead: _fit_at_lead(samples[lead].subset(trn), base, mass_kg, lead, names,
                               (x0, lo, hi, scale), kwargs)
            for lead in leads_s}
    lead = min(fits, key=lambda k: fits[k][0])
    _, sol, ref, s_trn = fits[lead]
    fitted = _rotor_losses_aircraft(ref, dict(zip(names, sol.x)))
    cov = stats.cluster_covariance(sol.jac, sol.fun, s_trn.experiment)
    cov.warn_if_singular("the aircraft fit")
    values, se, starts, at_bound, r0 = _figure_of_merit_values(
        aircraft, names, sol.x, cov.stderr, x0, lo, hi)
    values = {n: values[n] for n in chosen}
    cause = likely_cause(s_trn)
    misfit = [{"parameter": n, "value": float(values.get(n, math.nan)),
               "why": "ended on its bound", "cause": cause} for n in at_bound]
    for n in at_bound:
        warnings.warn(f"{n} ended on its bound: a misfit of the model's form on these "
                      f"flights, not a value ({cause})")
    poor = _poorly_determined(values, se)
    result = {
        "aircraft": fitted, "parameters": values, "start": starts,
        "stderr": {n: se[n] for n in chosen}, "poorly_determined": poor,
        "at_bound": at_bound, "split": how, "stopped_power": stop, "held": held,
        "lead_s": lead, "lead_train_rmse_w": {f"{k:g}": v[0] for k, v in fits.items()},
        "profile_power_ratio": r0,
        "train_experiments": sorted(set(s0.experiment[trn])),
        "validation_experiments": sorted(set(s0.experiment[val])),
        "experiments": list(dict.fromkeys(s0.experiment)),
        "misfit": misfit,
        "fit_status": "ok" if not misfit else "misfit: " + "; ".join(
            f"{m['parameter']} {m['why']} ({m['cause']})" for m in misfit),
    }
    if parameters is None:
        result = with_tilt(result, aircraft, states, mass_kg, airborne_height_m)
    result.update(_scores(aircraft, result["aircraft"], samples[given_lead], samples[lead],
                          trn, val, mass_kg))
    return result


#: The figure of merit, fitted as the profile power ratio r₀ = 1/FM − κ.
_FM = "figure_of_merit"
#: The names :func:`fit_rotor_losses` fits.
_ROTOR_LOSSES_PUBLIC = ["no_load_power_w", "copper_loss_power_w", _FM, "drag_area_m2",
                       "descent_inflow_weight"]
#: Scales of the rotor_losses parameters for the solver. [W], [W], [unitless], [m²],
#: [unitless]
_ROTOR_LOSSES_SCALES = {"no_load_power_w": 100.0, "copper_loss_power_w": 100.0,
                        "profile_power_ratio": 0.5, "drag_area_m2": 0.05,
                        "descent_inflow_weight": 1.0}


def chosen_parameters(parameters: list[str] | None, allowed, what: str,
                      system_power_note: str) -> list[str]:
    """The parameters a fit is asked for (default all of ``allowed``), checked: one not in
    ``allowed`` is an :class:`InputError` naming ``what`` is fitted (``a fixed wing``) and,
    for ``system_power_w``, where the system load is measured instead."""
    chosen = list(parameters or allowed)
    unknown = set(chosen) - set(allowed)
    if unknown:
        extra = (f" (system_power_w is measured {system_power_note})"
                 if "system_power_w" in unknown else "")
        raise InputError(f"cannot fit {sorted(unknown)} for {what}; expected some of "
                         f"{', '.join(allowed)}{extra}")
    return chosen


def _rotor_losses_chosen(parameters: list[str] | None) -> list[str]:
    """The parameters asked for (default all of :data:`_ROTOR_LOSSES_PUBLIC`), checked."""
    return chosen_parameters(parameters, _ROTOR_LOSSES_PUBLIC, "a rotor_losses multirotor",
                             "from the rotors-stopped ground samples")


def _held_stopped_power(states, train_ids: set, p_air: float, aircraft: Aircraft) -> dict:
    """P_stop held in the fit: measured on the training flights' rotors-stopped samples
    (:func:`stopped_power`), else the file's value; ``value_w`` [W], ``samples`` and
    ``source``."""
    p_stop, n_stop = stopped_power([st for st in states if st[0] in train_ids], p_air)
    if p_stop is None:
        source = (f"held at the file's value: only {n_stop} rotors-stopped ground "
                  f"sample(s) in the training flights")
        p_stop = float(aircraft.system_power_w)
    else:
        source = f"median of {n_stop} rotors-stopped ground samples"
    return {"value_w": p_stop, "samples": n_stop, "source": source}


def _rotor_losses_start(base: Aircraft, names: list[str], p_air: float):
    """Start values (the file's, else 10 % and 20 % of the median airborne power ``p_air``
    for P_nl and P_cu), bounds and scales of the fitted parameters."""
    start = {"no_load_power_w": base.multirotor.no_load_power_w or 0.1 * p_air,
             "copper_loss_power_w": base.multirotor.copper_loss_power_w or 0.2 * p_air,
             "profile_power_ratio": _profile_ratio(base),
             "drag_area_m2": base.multirotor.drag_area_m2,
             "descent_inflow_weight": base.multirotor.descent_inflow_weight}
    x0 = np.array([start[n] for n in names])
    lo = np.array([ROTOR_LOSSES_PARAMETERS[n][0] for n in names])
    hi = np.array([ROTOR_LOSSES_PARAMETERS[n][1] for n in names])
    x0 = np.clip(x0, lo + 1e-3 * (hi - lo), hi - 1e-3 * (hi - lo))
    scale = np.array([_ROTOR_LOSSES_SCALES[n] for n in names])
    return x0, lo, hi, scale


def _fit_at_lead(s_trn: Samples, base: Aircraft, mass_kg, lead: float, names, start,
                 kwargs):
    """Least squares of the rotor_losses power on the training samples read ``lead``
    seconds late: (training RMS [W], solution, reference aircraft, samples). With a mass
    per flight the reference mass of the copper loss is the training samples' mean mass."""
    x0, lo, hi, scale = start
    m_trn = sample_masses(s_trn, mass_kg)
    ref = with_params(base, {"reference_mass_kg": float(np.mean(m_trn)),
                             "power_lead_s": lead})
    cache: dict[tuple[float, float], Any] = {}

    def residual(x):
        # the aerodynamics depend on f and the descent inflow weight w alone: one
        # evaluation per pair tried
        v = dict(zip(names, x))
        mr = ref.multirotor
        f = float(v.get("drag_area_m2", mr.drag_area_m2))
        w = float(v.get("descent_inflow_weight", mr.descent_inflow_weight))
        if (f, w) not in cache:
            if len(cache) > 4:
                cache.clear()
            cache[f, w] = _unit_terms(with_params(ref, {"descent_inflow_weight": w}),
                                      s_trn, m_trn, f)
        pred = battery_power_from_unit_terms(
            cache[f, w], v.get("profile_power_ratio", _profile_ratio(ref)),
            v.get("no_load_power_w", mr.no_load_power_w),
            v.get("copper_loss_power_w", mr.copper_loss_power_w), mr.drive_efficiency,
            ref.system_power_w)
        return pred - s_trn.measured_w

    sol = _solve(residual, x0, lo, hi, scale, kwargs)
    return float(np.sqrt(np.mean(sol.fun**2))), sol, ref, s_trn


def _solve(residual, x0, lo, hi, scale, kwargs):
    """:func:`scipy.optimize.least_squares` within the bounds; FitError when it fails or
    does not converge."""
    try:
        sol = least_squares(residual, x0, bounds=(lo, hi), x_scale=scale, **kwargs)
    except ValueError as exc:
        raise FitError(f"aircraft fit failed: {exc}") from None
    if not sol.success:
        raise FitError(f"aircraft fit did not converge: {sol.message}")
    return sol


def _figure_of_merit_values(aircraft: Aircraft, names, x, stderr, x0, lo, hi):
    """Values, standard errors, start values and parameters on a bound (within 10⁻⁴ of
    the range), with the profile power ratio r₀ given as the figure of merit
    FM = 1/(κ + r₀) (standard error by the delta method, FM² σ(r₀)); and r₀."""
    se = dict(zip(names, map(float, stderr)))
    values = dict(zip(names, map(float, x)))
    starts = dict(zip(names, map(float, x0)))
    at_bound = [n for n, v, a, b, w in zip(names, x, lo, hi, hi - lo)
                if min(v - a, b - v) <= 1e-4 * w]
    r0 = values.pop("profile_power_ratio", None)
    r0_se = se.pop("profile_power_ratio", None)
    r0_start = starts.pop("profile_power_ratio", None)
    if r0 is not None:
        kappa = aircraft.multirotor.induced_factor
        fm = 1.0 / (kappa + r0)
        values[_FM], se[_FM] = fm, fm * fm * r0_se
        starts[_FM] = 1.0 / (kappa + r0_start)
        at_bound = [_FM if n == "profile_power_ratio" else n for n in at_bound]
    return values, se, starts, at_bound, r0
