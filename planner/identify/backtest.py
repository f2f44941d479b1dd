"""Backtest: each flight predicted as its operator would have before take-off, scored
against what the flight did.

For every flight (experiment) of a flight record:

1. **The plan.** A mission file matched by name (``missions_dir/<experiment>.<ext>``,
   any format :func:`planner.io.mission.load_mission` reads), else a plan rebuilt from
   the flown track: the take-off point, the turning points of the horizontal track
   (Ramer–Douglas–Peucker simplification, :data:`TURN_TOLERANCE_M`), flown at the
   commanded speed and altitude of the per-flight table (columns ``commanded_speed_ms``
   and ``commanded_altitude``; else the flight's median moving ground speed and its
   median height at the turning points, said so), a vertical climb from and descent to
   the take-off point. The row's ``plan`` column says which.
2. **The forecast.** Only what was known before take-off: a per-flight weather table
   (``weather``: wind speed [m/s], direction it blows from [deg], air temperature [°C]),
   else the record's own samples before the motors spun up (wind from ``wind_n_ms`` /
   ``wind_e_ms`` or an on-board anemometer at rest, the outside air temperature, the
   static pressure), else calm air at ISA. Never an in-flight sample.
3. **The aircraft.** Calibrated on *other* flights only: the flights are split into
   ``folds`` groups (by flight, or by day flown), and each group is predicted by the
   aircraft fitted (:func:`planner.identify.aircraft_fit.fit_aircraft`, each training
   flight at its own take-off mass) on the flights of the other groups
   (:func:`calibrate_fold`). A list of held-out flights instead makes one fold. The
   pack's integral capacity model, which turns the power into the charge drawn, is
   fitted on the same training flights' charge (:func:`calibrate_pack`).
4. **The prediction** is the pre-flight check's (:meth:`MissionChain.check`, the chain of
   ``endurance check``) at the flight's take-off mass (empty + pack + its payload); with
   ``uncertainty_samples`` also its Monte Carlo band, the power model's error drawn with
   the spread of the fold's own plans on its training flights (:func:`with_plan_error`).

Measured, over the flight (first to last sample drawing more than
:data:`FLYING_POWER_FRACTION` of the median airborne power, so the rotors' spin-up and
the landing are in it): the energy ∫P dt [Wh], the charge ∫I dt [mAh], the flight time
[s], the lowest voltage [V]; the landing charge is the pack's usable charge less the
charge drawn (as the check counts it, from a full pack). And leg by leg, the power of
the level cruise at constant speed, which a long mission spends most of its charge in and
these short flights little: the median power of the samples in level flight at the
plan's speed (:func:`measured_cruise_power`) against the check's level legs flown at
constant speed (:func:`predicted_cruise_power`). A flight that cannot be scored
(never airborne, too short, no plan, no payload or forecast where the tables give others
one) keeps its row with the ``reason``; the others are scored.
"""

from __future__ import annotations

import math
import re
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from planner.chain.kinematics import ACCELERATING, BRAKING
from planner.chain.mission_chain import MissionChain
from planner.chain.uncertainty import Spreads, covariance_problem, monte_carlo
from planner.errors import InputError, PlannerError
from planner.identify.aircraft_fit import fit_aircraft
from planner.identify.battery_fit import fit_integral
from planner.identify.navigation_fit import fit_navigation
from planner.io import record
from planner.io.mission import load_mission
from planner.parameters import Aircraft, BatteryPack
from planner.physics.mission import Environment, Leg, Mission, NavDefaults
from planner.physics.wind import course_deg

__all__ = [
    "FLYING_POWER_FRACTION",
    "MIN_FLIGHT_S",
    "ROW_COLUMNS",
    "TURN_TOLERANCE_M",
    "BacktestOptions",
    "calibrate_fold",
    "folds_of",
    "forecast",
    "measured",
    "plan_from_track",
    "predict_flight",
    "run_backtest",
    "summarise",
]

#: Flying = drawing more than this share of the median airborne power (the M100 idles
#: its propellers at 36 W on the ground, 8 % of its 450–600 W airborne; a copter's
#: spin-up before lift-off draws 20–60 %). [unitless]
FLYING_POWER_FRACTION = 0.2
#: Airborne = more than this above the experiment's first altitude. [m]
AIRBORNE_HEIGHT_M = 1.0
#: A flight shorter than this is not scored. [s]
MIN_FLIGHT_S = 30.0
#: Tolerance of the track's simplification into turning points: GNSS wander and the
#: drift of a vertical climb stay within it, a route's corner does not. [m]
TURN_TOLERANCE_M = 10.0
#: Legs shorter than this are dropped from a rebuilt plan. [m]
MIN_LEG_M = 5.0
#: Moving = faster than this over ground. [m/s]
MOVING_MS = 1.0
#: Level cruise, where the cruise power is scored: climbing or descending slower than
#: this [m/s], ...
CRUISE_CLIMB_MS = 0.3
#: ... at the plan's speed within this share of it, ... [unitless]
CRUISE_SPEED_TOLERANCE = 0.15
#: ... for at least this long in all. [s]
MIN_CRUISE_S = 5.0
#: Metres per degree of latitude (WGS-84 mean, about 111.2 km; the tracks span < 1 km,
#: an equirectangular projection about the take-off point is exact to < 0.1 %). [m/deg]
M_PER_DEG = 6_371_008.8 * math.pi / 180.0
#: Mission file extensions matched by name.
MISSION_EXTENSIONS = (".plan", ".waypoints", ".txt", ".yaml", ".yml")

#: The per-flight table's columns (units in the names).
ROW_COLUMNS = (
    "experiment", "fold", "status", "reason", "plan", "forecast", "payload_kg",
    "takeoff_mass_kg", "speed_ms", "altitude_m", "wind_ms", "date",
    "measured_energy_wh", "predicted_energy_wh", "energy_error_pct",
    "measured_charge_mah", "predicted_charge_mah", "charge_error_pct",
    "measured_time_s", "predicted_time_s", "time_error_pct",
    "measured_landing_mah", "predicted_landing_mah",
    "measured_min_voltage_v", "predicted_min_voltage_v", "verdict", "landed_with_reserve",
    "measured_cruise_power_w", "predicted_cruise_power_w", "cruise_power_error_pct",
    "energy_p5_wh", "energy_p95_wh", "energy_inside_band", "charge_p5_mah", "charge_p95_mah",
    "charge_inside_band", "battery_model")


@dataclass(frozen=True)
class BacktestOptions:
    """How a backtest calibrates and predicts.

    folds : number of groups the flights are split into (≥ 2). [count]
    by : ``"flight"`` (flights dealt in turn into the groups, in their order) or
        ``"day"`` (every flight of a day in one group; needs a ``date`` column).
    held_out : experiments to predict, calibrated on all the others (one fold; ``folds``
        and ``by`` unused).
    site_altitude_m : site altitude for the ISA density where the forecast has no
        pressure. [m]
    reserve : landing reserve as a fraction of nominal capacity. [unitless]
    missions_dir : folder of mission files matched by experiment name.
    weather : per-flight forecast table: experiment → {wind_speed_ms, wind_from_deg,
        temperature_c}.
    parameters : the aircraft parameters fitted per fold (default: every one of its
        power model).
    kinematics : how the chain flies the plan: ``"fitted"`` (default) with the vehicle's
        navigation — take-off, jerk-limited legs, stops, two-rate landing
        (:mod:`planner.physics.motion`) — fitted per fold on the training flights
        (:func:`~planner.identify.navigation_fit.fit_navigation`), the aircraft file's own
        ``navigation:`` block where the training flights do not show it; ``"file"`` the
        aircraft file's block as it is; ``"none"`` every leg at constant speed.
    uncertainty_samples : with more than 0, each flight's prediction is also run through
        ``check --uncertainty``'s Monte Carlo (:func:`~planner.chain.uncertainty.monte_carlo`)
        with this many samples and its default spreads — the forecast's error and the
        calibrated model's own per-flight energy error on the fold's training flights
        (``energy_error_sd``) — and the row says whether the measured energy and charge
        fell inside its P5–P95 band. [count]
    tilt : with False the calibrated aircraft flies without the rotor disks' tilt its
        training flights show (``tilt_drag_area_m2``, read by
        :func:`~planner.identify.aircraft_fit.fit_aircraft` where they log the axial
        speed): the model as it was before it read one, to measure what the tilt gains.
    battery : the pack's integral capacity model (which turns the predicted power into
        the charge drawn): ``"fitted"`` (default) δ and ε fitted per fold on the charge
        the training flights drew (:func:`calibrate_pack`), β held at the pack file's;
        ``"file"`` the pack file's model as it is (the literature start values where it
        has no ``model:`` block).
    """

    folds: int = 5
    by: str = "flight"
    held_out: tuple[str, ...] | None = None
    site_altitude_m: float = 0.0
    reserve: float = 0.2
    missions_dir: Path | None = None
    weather: dict[str, dict[str, float]] | None = field(default=None, repr=False)
    parameters: tuple[str, ...] | None = None
    kinematics: str = "fitted"
    uncertainty_samples: int = 0
    tilt: bool = True
    battery: str = "fitted"


# ------------------------------------------------------------------------- folds
def folds_of(flights: list[str], options: BacktestOptions,
             days: dict[str, str] | None = None) -> list[tuple[list[str], list[str]]]:
    """(training flights, predicted flights) of every fold. A flight is never in its
    own fold's training set."""
    flights = list(dict.fromkeys(map(str, flights)))
    if options.held_out:
        held = [f for f in map(str, options.held_out) if f in set(flights)]
        train = [f for f in flights if f not in set(held)]
        return [(train, held)]
    k = int(options.folds)
    if k < 2:
        raise InputError(f"folds: {k}; expected at least 2 (a flight is predicted by an "
                         "aircraft calibrated on the others)")
    if options.by == "day":
        if not days:
            raise InputError("folds by day: the data give no date per flight (a per-flight "
                             "'date' column); expected folds by flight")
        order = sorted({days.get(f, "") for f in flights})
        group = {d: i % k for i, d in enumerate(order)}
        label = {f: group[days.get(f, "")] for f in flights}
        if len(order) < k:
            raise InputError(f"folds by day: {len(order)} day(s) in the data, fewer than the "
                             f"{k} folds asked for")
    elif options.by == "flight":
        if len(flights) < k:
            raise InputError(f"{len(flights)} flight(s), fewer than the {k} folds asked for")
        label = {f: i % k for i, f in enumerate(flights)}
    else:
        raise InputError(f"folds by {options.by!r}; expected 'flight' or 'day'")
    out = []
    for i in range(k):
        test = [f for f in flights if label[f] == i]
        out.append(([f for f in flights if label[f] != i], test))
    return out


# ------------------------------------------------------------------- calibration
def calibrate_fold(aircraft: Aircraft, train_record: pd.DataFrame, options: BacktestOptions,
                   masses: dict[str, float]) -> Aircraft:
    """The aircraft calibrated on one fold's training flights only: its power parameters
    fitted (:func:`~planner.identify.aircraft_fit.fit_aircraft`) with each training
    flight at its own take-off mass ``masses`` [kg]. Every fit of the vehicle from logs
    that the prediction uses belongs here, so that it sees the training flights only."""
    ids = [str(e) for e, _ in record.experiments(train_record)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = fit_aircraft(train_record, aircraft, mass_kg={e: masses[e] for e in ids},
                           parameters=list(options.parameters) if options.parameters
                           else None, train=ids, site_altitude_m=options.site_altitude_m)
    fitted = fit["aircraft"]
    if not options.tilt and fitted.is_multirotor:
        fitted = replace(fitted, multirotor=replace(fitted.multirotor, tilt_drag_area_m2=None))
    if options.kinematics == "none":
        return replace(fitted, navigation=None)
    if options.kinematics == "fitted":
        try:
            nav = fit_navigation(train_record, f"{len(ids)} training flights")
        except InputError:      # the flights lack the channels: the file's block stays
            return fitted
        return replace(fitted, navigation=nav)
    return fitted


def calibrate_pack(pack: BatteryPack, train_record: pd.DataFrame,
                   options: BacktestOptions) -> tuple[BatteryPack, str]:
    """The pack with its integral capacity model fitted on one fold's training flights
    only, and what was done, in words.

    [UAV23] eq. 18 (:func:`~planner.identify.battery_fit.fit_integral`) on each training
    flight from spin-up to touch-down, as the charge is scored (:func:`measured`): the
    measured power (a negative reading at rest is a rest, 0 W) and the charge ∫I dt. These
    flights draw a fraction of the pack each, too little to tell β from δ: β is held at
    the pack's own, and δ, ε are fitted. Where the flights have no current, or the fit
    fails or is a misfit (a parameter on its bound), the pack file's model stays, said
    so."""
    if options.battery != "fitted":
        return pack, "the pack file's integral model"
    parts = []
    if "current_a" in train_record:
        flying, _ = in_flight(train_record)
        for e, g in record.experiments(flying):
            sub = g[["time_s", "power_w", "current_a"]]
            sub = sub[np.isfinite(sub["current_a"]) & np.isfinite(sub["power_w"])]
            if len(sub) >= 3:
                parts.append(sub.assign(experiment=str(e),
                                        power_w=sub["power_w"].clip(lower=0.0)))
    beta = pack.model.beta
    if not parts:
        return pack, "the pack file's integral model (no training flight logs its current)"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = fit_integral(pd.concat(parts, ignore_index=True), beta=beta,
                               train=[p["experiment"].iloc[0] for p in parts], validate=[])
    except PlannerError as exc:
        return pack, f"the pack file's integral model (the fit failed: {exc})"
    if fit.fit_status != "ok":
        return pack, f"the pack file's integral model (the fit is a {fit.fit_status})"
    q = fit.parameters
    # a band drawn from a covariance that allows δ ≤ 0 has no meaning: then not drawn
    cov = fit.covariance
    problem = covariance_problem(q["delta"], beta, cov) if cov is not None else None
    model = replace(pack.model, delta=float(q["delta"]), epsilon=float(q["epsilon"]),
                    beta=beta, literature=False, covariance=None if problem else cov,
                    charge_error_sd=fit.charge_error_sd,
                    source=f"fitted on {len(parts)} training flights")
    return (replace(pack, model=model),
            f"the pack's integral model fitted on {len(parts)} training flights: "
            f"δ {q['delta']:.4g}, ε {q['epsilon']:.4f}, β {beta:.4g} (held)"
            + (f"; its covariance is not drawn: {problem}" if problem else ""))


# ---------------------------------------------------------------------- measured
def _flying(exp: pd.DataFrame) -> tuple[np.ndarray, np.ndarray] | None:
    """(time [s], flying mask) of the flight: first to last sample above
    :data:`FLYING_POWER_FRACTION` of the median airborne power; None when never
    airborne."""
    t = exp["time_s"].to_numpy(float)
    p = exp["power_w"].to_numpy(float)
    if "altitude_m" in exp:
        h = exp["altitude_m"].to_numpy(float)
        ok = np.isfinite(h)
        h = h - h[ok][0] if ok.any() else h
        with np.errstate(invalid="ignore"):
            air = h > AIRBORNE_HEIGHT_M
    else:
        air = np.isfinite(p)
    air &= np.isfinite(p)
    if air.sum() < 3:
        return None
    above = np.flatnonzero(p > FLYING_POWER_FRACTION * np.median(p[air]))
    mask = np.zeros(len(t), bool)
    mask[above[0]:above[-1] + 1] = True
    return t, mask


def in_flight(data: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """Each experiment of ``data`` from spin-up to touch-down (:func:`_flying`: the span
    over which a flight is scored), and the experiments left out because they have no
    power or were never airborne (ground tests)."""
    if "experiment" not in data:
        data = data.assign(experiment="flight")
    keep, left = [], []
    for e, g in record.experiments(data):
        fly = _flying(g) if record.has_power(g) else None
        if fly is None:
            left.append(str(e))
        else:
            keep.append(g.loc[fly[1]])
    out = pd.concat(keep) if keep else data.iloc[:0]
    return out, left


def measured(exp: pd.DataFrame) -> dict[str, float] | str:
    """What the flight did (module notes), or the reason it cannot be scored."""
    if not record.has_power(exp):
        return "no battery power in the data"
    fly = _flying(exp)
    if fly is None:
        return "never airborne (a ground test?)"
    t, mask = fly
    tt, p = t[mask], exp["power_w"].to_numpy(float)[mask]
    duration = float(tt[-1] - tt[0])
    if duration < MIN_FLIGHT_S:
        return f"flight {duration:.0f} s long: too short to score (under {MIN_FLIGHT_S:g} s)"
    ok = np.isfinite(p)
    out = {"measured_energy_wh": float(np.trapezoid(p[ok], tt[ok])) / 3600.0,
           "measured_time_s": duration, "measured_charge_mah": float("nan"),
           "measured_min_voltage_v": float("nan")}
    if "current_a" in exp:
        i = exp["current_a"].to_numpy(float)[mask]
        ok = np.isfinite(i)
        out["measured_charge_mah"] = float(np.trapezoid(i[ok], tt[ok])) / 3.6
    if "voltage_v" in exp:
        v = exp["voltage_v"].to_numpy(float)[mask]
        if np.isfinite(v).any():
            out["measured_min_voltage_v"] = float(np.nanmin(v))
    return out


def measured_cruise_power(exp: pd.DataFrame, speed_ms: float) -> float:
    """Median battery power of the flight's level cruise at the plan's speed: airborne
    (:func:`_flying`), climbing or descending slower than :data:`CRUISE_CLIMB_MS`, ground
    speed within :data:`CRUISE_SPEED_TOLERANCE` of ``speed_ms``; NaN with less than
    :data:`MIN_CRUISE_S` of it or without the channels. [W]"""
    fly = _flying(exp) if record.has_power(exp) else None
    if fly is None or not {"climb_rate_ms", "groundspeed_ms"} <= set(exp.columns) \
            or not np.isfinite(speed_ms) or speed_ms <= 0:
        return float("nan")
    t, mask = fly
    p = exp["power_w"].to_numpy(float)
    gs = np.abs(exp["groundspeed_ms"].to_numpy(float))
    with np.errstate(invalid="ignore"):
        ok = (mask & (np.abs(exp["climb_rate_ms"].to_numpy(float)) < CRUISE_CLIMB_MS)
              & (np.abs(gs - speed_ms) < CRUISE_SPEED_TOLERANCE * speed_ms) & np.isfinite(p))
    dt = np.gradient(t) if t.size > 1 else np.zeros_like(t)
    if float(np.sum(dt[ok])) < MIN_CRUISE_S:
        return float("nan")
    return float(np.median(p[ok]))


def predicted_cruise_power(res) -> float:
    """Duration-weighted mean battery power of the check's level legs flown at constant
    speed (kind ``cruise``, climbing slower than :data:`CRUISE_CLIMB_MS`, not an
    acceleration or a braking row of the navigation); NaN where it has none. [W]"""
    lc = res.leg_columns
    kind = np.asarray(lc["kind"]).astype(str)
    origin = [str(o) for o in lc["origin"]]
    steady = np.array([not o.endswith((ACCELERATING, BRAKING)) for o in origin], bool)
    d = np.asarray(lc["duration_s"], float)
    ok = ((kind == "cruise") & steady & (np.abs(np.asarray(lc["climb_rate_ms"], float))
                                        < CRUISE_CLIMB_MS) & (d > 0))
    if not ok.any():
        return float("nan")
    return float(np.sum(np.asarray(lc["power_w"], float)[ok] * d[ok]) / np.sum(d[ok]))


# --------------------------------------------------------------------- forecast
def forecast(exp: pd.DataFrame, experiment: str, options: BacktestOptions
             ) -> tuple[Environment, str] | str:
    """The weather known before take-off (module notes) and where it came from, or the
    reason there is none while the weather table gives other flights one."""
    site = options.site_altitude_m
    if options.weather is not None:
        w = options.weather.get(experiment)
        if w is None:
            return "no forecast for this flight in the weather table"
        return (Environment(wind_speed_ms=w.get("wind_speed_ms", 0.0),
                            wind_from_deg=w.get("wind_from_deg", 0.0),
                            temperature_c=w.get("temperature_c"), site_altitude_m=site),
                "weather table")
    fly = _flying(exp) if record.has_power(exp) else None
    first = int(np.argmax(fly[1])) if fly is not None else len(exp)
    before = exp.iloc[:first]
    said, env = [], {"site_altitude_m": site}

    def median(col):
        v = before[col].to_numpy(float) if col in before else np.array([])
        v = v[np.isfinite(v)]
        return float(np.median(v)) if v.size else None

    n, e = median("wind_n_ms"), median("wind_e_ms")
    speed, angle = median("anemometer_speed_ms"), median("anemometer_angle_deg")
    if n is not None and e is not None:
        env["wind_speed_ms"] = math.hypot(n, e)
        env["wind_from_deg"] = float(course_deg(-e, -n))
        said.append("wind")
    elif speed is not None and angle is not None:
        env["wind_speed_ms"], env["wind_from_deg"] = speed, angle % 360.0
        said.append("anemometer at rest")
    for col, key in (("ambient_temperature_c", "temperature_c"), ("pressure_pa", "pressure_pa")):
        value = median(col)
        if value is not None:
            env[key] = value
            said.append(key.split("_")[0])
    text = (f"before take-off ({', '.join(said)})" if said else
            "none before take-off: calm air, ISA")
    return Environment(**env), text


# ------------------------------------------------------------------------- plans
def _rdp(xy: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the Ramer–Douglas–Peucker simplification of the polyline ``xy`` (n × 2)
    within ``tol`` (Douglas & Peucker, Cartographica 10(2), 1973). Iterative, each split
    one vectorised distance over its span."""
    keep = np.zeros(len(xy), bool)
    keep[[0, -1]] = True
    stack = [(0, len(xy) - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        seg = xy[b] - xy[a]
        rel = xy[a + 1:b] - xy[a]
        length = float(np.hypot(*seg))
        d = (np.abs(seg[0] * rel[:, 1] - seg[1] * rel[:, 0]) / length if length > 0
             else np.hypot(rel[:, 0], rel[:, 1]))
        k = int(np.argmax(d))
        if d[k] > tol:
            keep[a + 1 + k] = True
            stack += [(a, a + 1 + k), (a + 1 + k, b)]
    return np.flatnonzero(keep)


def _numbers(text) -> list[float]:
    return [float(x) for x in re.findall(r"[-+]?\d+(?:\.\d+)?", str(text))]


def _per_flight(exp: pd.DataFrame, col: str):
    """The flight's value of a per-flight column (None when absent or missing)."""
    if col not in exp:
        return None
    v = exp[col].dropna()
    return v.iloc[0] if len(v) else None


def plan_from_track(exp: pd.DataFrame, experiment: str, payload_kg: float,
                    environment: Environment) -> tuple[Mission, str] | str:
    """A plan rebuilt from the flown track (module notes), with the text saying so, or
    the reason it cannot be."""
    if not {"latitude_deg", "longitude_deg"} <= set(exp.columns):
        return "no plan and no track (no mission file, no latitude/longitude in the data)"
    lat = exp["latitude_deg"].to_numpy(float)
    lon = exp["longitude_deg"].to_numpy(float)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(lat) & np.isfinite(lon) & ((lat != 0) | (lon != 0))
    fly = _flying(exp)
    if fly is None or ok.sum() < 3:
        return "no track (no position logged)"
    _, mask = fly
    rows = np.flatnonzero(mask & ok)
    if rows.size < 3:
        return "no track while flying"
    lat0, lon0 = lat[rows[0]], lon[rows[0]]
    east = (lon[rows] - lon0) * M_PER_DEG * math.cos(math.radians(lat0))
    north = (lat[rows] - lat0) * M_PER_DEG
    xy = np.column_stack([east, north])
    if np.hypot(east, north).max() < 2 * TURN_TOLERANCE_M:
        return "no route flown (a hover or a ground test): no plan to rebuild"
    turns = _rdp(xy, TURN_TOLERANCE_M)
    h = exp["altitude_m"].to_numpy(float)[rows] if "altitude_m" in exp else None
    if h is not None:
        h = h - np.nanmin(h[:3])
    alt_text = _per_flight(exp, "commanded_altitude")
    commanded_alt = _numbers(alt_text) if alt_text is not None else []
    said = []
    if len(commanded_alt) == 1 and commanded_alt[0] > 0:
        alts = np.full(len(turns), commanded_alt[0])
        said.append(f"altitude {commanded_alt[0]:g} m from the per-flight table")
    elif h is not None:
        alts = np.round(np.nan_to_num(h[turns]))
        said.append("altitude of each turning point from the track")
    else:
        return "no altitude: neither a commanded altitude nor a logged one"
    speed = _per_flight(exp, "commanded_speed_ms")
    speed = float(speed) if speed is not None and float(speed) > 0 else None
    if speed is None:
        gs = exp["groundspeed_ms"].to_numpy(float)[rows] if "groundspeed_ms" in exp else None
        moving = gs[gs > MOVING_MS] if gs is not None else np.array([])
        if not moving.size:
            return "no speed: neither a commanded speed nor a logged ground speed"
        speed = float(np.median(moving))
        said.insert(0, f"speed {speed:.1f} m/s the median moving ground speed")
    else:
        said.insert(0, f"speed {speed:g} m/s from the per-flight table")
    pts = [(float(xy[i, 0]), float(xy[i, 1]), float(a)) for i, a in zip(turns, alts)]
    cruise_alt = max(p[2] for p in pts)
    first_alt = pts[1][2] if len(pts) > 1 and pts[1][2] > 0 else cruise_alt
    legs = [Leg("climb", (0.0, 0.0), (0.0, 0.0), 0.0, first_alt, origin="take-off")]
    prev, prev_alt = (0.0, 0.0), first_alt
    for x, y, a in pts[1:-1] + [(0.0, 0.0, pts[-1][2] if pts[-1][2] > 0 else prev_alt)]:
        a = a if a > 0 else prev_alt
        if math.hypot(x - prev[0], y - prev[1]) >= MIN_LEG_M:
            legs.append(Leg("cruise", prev, (x, y), prev_alt, a, speed_ms=speed,
                            origin=f"turning point {len(legs)}"))
            prev, prev_alt = (x, y), a
    if math.hypot(*prev) >= MIN_LEG_M:
        legs.append(Leg("cruise", prev, (0.0, 0.0), prev_alt, prev_alt, speed_ms=speed,
                        origin="return to take-off point"))
    legs.append(Leg("descend", (0.0, 0.0), (0.0, 0.0), prev_alt, 0.0, origin="landing"))
    mission = Mission(f"backtest-{experiment}", legs, environment, payload_kg=payload_kg,
                      source="rebuilt from the flown track")
    return mission, (f"rebuilt from the track: {len(legs) - 2} legs, " + ", ".join(said))


def _mission_file(missions_dir: Path | None, experiment: str, source: str | None):
    if missions_dir is None:
        return None
    stems = [experiment] + ([Path(source).name.split(".")[0]] if source else [])
    for stem in stems:
        for ext in MISSION_EXTENSIONS:
            p = Path(missions_dir) / f"{stem}{ext}"
            if p.is_file():
                return p
    return None


# -------------------------------------------------------------------- prediction
def predict_flight(aircraft: Aircraft, pack: BatteryPack, exp: pd.DataFrame,
                   experiment: str, payload_kg: float, options: BacktestOptions,
                   source: str | None = None) -> dict[str, Any]:
    """One flight's row: the plan, the forecast, the check's prediction and what was
    measured (or the reason it is left out)."""
    row: dict[str, Any] = {"experiment": experiment, "payload_kg": payload_kg,
                           "takeoff_mass_kg": aircraft.empty_mass_kg + pack.total_mass_kg
                           + payload_kg}
    row["date"] = _per_flight(exp, "date")
    meas = measured(exp)
    if isinstance(meas, str):
        return {**row, "status": "left out", "reason": meas}
    row.update(meas)
    env = forecast(exp, experiment, options)
    if isinstance(env, str):
        return {**row, "status": "left out", "reason": env}
    environment, row["forecast"] = env
    row["wind_ms"] = environment.wind_speed_ms
    path = _mission_file(options.missions_dir, experiment, source)
    if path is not None:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mission = load_mission(path, defaults=NavDefaults.of(aircraft))
        except InputError as exc:
            return {**row, "status": "left out", "reason": f"mission file: {exc}"}
        mission = replace(mission, payload_kg=payload_kg)
        row["plan"] = f"mission file {path.name}"
    else:
        built = plan_from_track(exp, experiment, payload_kg, environment)
        if isinstance(built, str):
            return {**row, "status": "left out", "reason": built}
        mission, row["plan"] = built
    speeds = [leg.speed_ms for leg in mission.legs if leg.speed_ms]
    row["speed_ms"] = float(np.median(speeds)) if speeds else float("nan")
    row["altitude_m"] = float(max(max(leg.start_alt_m, leg.end_alt_m)
                                  for leg in mission.legs))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = MissionChain(aircraft, pack, reserve=options.reserve).check(
                mission, environment, payload_kg=payload_kg)
    except PlannerError as exc:
        return {**row, "status": "left out", "reason": f"the check failed: {exc}"}
    row.update(predicted_energy_wh=res.energy_wh, predicted_charge_mah=res.charge_used_mah,
               predicted_time_s=res.duration_s, predicted_landing_mah=res.landing_charge_mah,
               predicted_min_voltage_v=res.min_voltage_v, verdict=res.verdict,
               measured_landing_mah=res.usable_mah - row["measured_charge_mah"])
    row["landed_with_reserve"] = bool(row["measured_landing_mah"] >= res.reserve_mah)
    row["measured_cruise_power_w"] = measured_cruise_power(exp, row["speed_ms"])
    row["predicted_cruise_power_w"] = predicted_cruise_power(res)
    for name in ("energy", "charge", "time", "cruise"):
        unit = {"energy": "wh", "charge": "mah", "time": "s", "cruise": "power_w"}[name]
        m, p = row[f"measured_{name}_{unit}"], row[f"predicted_{name}_{unit}"]
        error = 100.0 * (p - m) / m if m and np.isfinite(m) else float("nan")
        row["cruise_power_error_pct" if name == "cruise" else f"{name}_error_pct"] = error
    if options.uncertainty_samples:
        row.update(_band(aircraft, pack, mission, environment, payload_kg, options, row))
    row["status"] = "scored"
    return row


def _band(aircraft, pack, mission, environment, payload_kg, options, row) -> dict[str, Any]:
    """The P5–P95 band of the energy and the charge of ``check --uncertainty``'s Monte
    Carlo (default spreads) and whether the measured values fell inside it."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            u = monte_carlo(MissionChain(aircraft, pack, reserve=options.reserve), mission,
                            environment, Spreads(), samples=int(options.uncertainty_samples),
                            payload_kg=payload_kg)
    except PlannerError:
        return {}
    out: dict[str, Any] = {}
    for name, samples, unit in (("energy", u.energy_samples_wh, "wh"),
                                ("charge", u.charge_samples_mah, "mah")):
        lo, hi = np.percentile(samples, [5, 95])
        m = row[f"measured_{name}_{unit}"]
        out[f"{name}_p5_{unit}"], out[f"{name}_p95_{unit}"] = float(lo), float(hi)
        out[f"{name}_inside_band"] = bool(lo <= m <= hi) if np.isfinite(m) else None
    return out


def _fold_rows(aircraft, pack, data, train, test, options, masses, payloads, sources,
               fold: int) -> list[dict]:
    """Calibrate on ``train``, predict every flight of ``test``: their rows."""
    by_id = {str(e): g for e, g in record.experiments(data)}
    base = {"fold": fold}
    try:
        train_rec = pd.concat([by_id[e] for e in train], ignore_index=True)
        calibrated = calibrate_fold(aircraft, train_rec, options, masses)
    except PlannerError as exc:
        return [{**base, "experiment": e, "status": "left out",
                 "reason": f"calibration on the other flights failed: {exc}"} for e in test]
    pack, base["battery_model"] = calibrate_pack(pack, train_rec, options)
    if options.uncertainty_samples:
        calibrated = with_plan_error(calibrated, pack, by_id, train, payloads, options,
                                     sources)
    rows = []
    for e in test:
        exp = by_id[e].reset_index(drop=True)
        rows.append({**base, **predict_flight(calibrated, pack, exp, e, payloads[e], options,
                                              sources.get(e))})
    return rows


#: Most training flights the plans' own error is measured on (:func:`with_plan_error`),
#: evenly spaced among them. [count]
PLAN_ERROR_FLIGHTS = 60
#: Fewest training flights it needs; with fewer the aircraft's own spread stays.
MIN_PLAN_ERROR_FLIGHTS = 3


def with_plan_error(calibrated: Aircraft, pack: BatteryPack, by_id: dict, train: list[str],
                    payloads: dict, options: BacktestOptions, sources: dict) -> Aircraft:
    """The calibrated aircraft with the spread of its plans' energy error as its
    ``energy_error_sd``: the root mean square of (predicted − measured) / measured energy
    of up to :data:`PLAN_ERROR_FLIGHTS` training flights, each predicted from its plan and
    its forecast as the held-out ones are. ``fit-aircraft``'s ``energy_error_sd`` is the
    error of the power model driven by each flight's measured state; a plan adds what
    the plan, the navigation and the forecast get wrong, and ``check --uncertainty``'s band
    for a plan draws it. Training flights only: the flights predicted are never in it."""
    usable = [e for e in train if e in payloads]
    pick = [usable[i] for i in np.unique(np.linspace(
        0, len(usable) - 1, min(PLAN_ERROR_FLIGHTS, len(usable))).round().astype(int))] \
        if usable else []
    plain = replace(options, uncertainty_samples=0)
    errors = []
    for e in pick:
        row = predict_flight(calibrated, pack, by_id[e].reset_index(drop=True), e,
                             payloads[e], plain, sources.get(e))
        err = row.get("energy_error_pct")
        if row.get("status") == "scored" and err is not None and np.isfinite(err):
            errors.append(err / 100.0)
    if len(errors) < MIN_PLAN_ERROR_FLIGHTS:
        return calibrated
    return replace(calibrated, energy_error_sd=float(np.sqrt(np.mean(np.square(errors)))))


def _payloads(data: pd.DataFrame, payload_kg: float | None) -> tuple[dict, dict]:
    """Payload of every flight [kg] (``payload_kg`` for all when given, else the
    record's) and the reasons of flights without one while others have one."""
    ids = [str(e) for e, _ in record.experiments(data)]
    if payload_kg is not None:
        return {e: float(payload_kg) for e in ids}, {}
    own = record.experiment_payloads(data)
    if own is None:
        return {e: 0.0 for e in ids}, {}
    missing = {e: "no payload for this flight in the per-flight table"
               for e in ids if not np.isfinite(own.get(e, float("nan")))}
    return {e: (own[e] if e not in missing else 0.0) for e in ids}, missing


def run_backtest(data: pd.DataFrame, aircraft: Aircraft, pack: BatteryPack,
                 options: BacktestOptions, *, payload_kg: float | None = None,
                 sources: dict[str, str] | None = None, client=None) -> pd.DataFrame:
    """Every flight of ``data`` predicted from before take-off by an aircraft calibrated
    on the other flights (module notes): one row per flight (:data:`ROW_COLUMNS`).

    ``payload_kg`` overrides the record's payload of every flight; ``sources`` maps an
    experiment to its log file (mission files are matched by its name too); ``client``:
    a Dask client that runs the folds (else they run here, one after the other).
    """
    if "experiment" not in data:
        data = data.assign(experiment="flight")
    data = data.assign(experiment=data["experiment"].astype(str))
    payloads, no_payload = _payloads(data, payload_kg)
    base_mass = aircraft.empty_mass_kg + pack.total_mass_kg
    masses = {e: base_mass + p for e, p in payloads.items()}
    ids = list(payloads)
    rows: list[dict] = []
    # flights that cannot be scored are left out of the training sets too
    usable, reasons = [], dict(no_payload)
    for e, g in record.experiments(data):
        e = str(e)
        if e in reasons:
            continue
        m = measured(g.reset_index(drop=True))
        if isinstance(m, str):
            reasons[e] = m
        else:
            usable.append(e)
    if options.held_out:
        unknown = [f for f in options.held_out if str(f) not in set(ids)]
        if unknown:
            rows += [{"experiment": str(f), "status": "left out",
                      "reason": "held out, but not in the data"} for f in unknown]
    days = ({str(e): str(_per_flight(g, "date")) for e, g in record.experiments(data)}
            if "date" in data else None)
    folds = folds_of(usable, options, days)
    rows += [{"experiment": e, "status": "left out", "reason": r,
              "payload_kg": payloads.get(e), "date": days.get(e) if days else None}
             for e, r in reasons.items()
             if not options.held_out or e in set(map(str, options.held_out))]
    jobs = [(train, test, k) for k, (train, test) in enumerate(folds) if test]
    sources = {str(k): v for k, v in (sources or {}).items() if k is not None}
    if client is None:
        for train, test, k in jobs:
            rows += _fold_rows(aircraft, pack, data, train, test, options, masses, payloads,
                               sources, k)
    else:
        # the record goes to every worker once; each fold picks its flights from it
        shared = client.scatter(data, broadcast=True, hash=False)
        futures = [client.submit(_fold_rows, aircraft, pack, shared, train, test, options,
                                 masses, payloads, sources, k, pure=False)
                   for train, test, k in jobs]
        for got in client.gather(futures):
            rows += got
    table = pd.DataFrame(rows)
    for c in ROW_COLUMNS:
        if c not in table:
            table[c] = None
    order = {e: i for i, e in enumerate(ids)}
    table["_o"] = table["experiment"].map(lambda e: order.get(e, len(order)))
    table = table.sort_values("_o", kind="stable").drop(columns="_o")
    return table[list(ROW_COLUMNS)].reset_index(drop=True)


# ----------------------------------------------------------------------- summary
def _stats(err: pd.Series) -> dict[str, float]:
    e = err.dropna().to_numpy(float)
    if not e.size:
        return {"n": 0}
    a = np.abs(e)
    return {"n": int(e.size), "bias_pct": float(np.mean(e)),
            "median_abs_pct": float(np.median(a)), "p90_abs_pct": float(np.quantile(a, 0.9)),
            "max_abs_pct": float(a.max())}


def summarise(table: pd.DataFrame, worst: int = 5) -> dict[str, Any]:
    """Bias, median and P90 |error| of energy, charge and flight time; the worst flights;
    the energy error against speed, payload, altitude and wind; who was left out and
    why."""
    ok = table[table["status"] == "scored"]
    out: dict[str, Any] = {"flights": len(table), "scored": len(ok),
                           "left_out": int((table["status"] != "scored").sum())}
    reasons = table.loc[table["status"] != "scored", "reason"].fillna("?")
    out["left_out_reasons"] = {str(k): int(v) for k, v in reasons.value_counts().items()}
    models = table.get("battery_model", pd.Series(dtype=object)).dropna()
    out["battery_models"] = list(dict.fromkeys(str(m) for m in models))
    for name in ("energy", "charge", "time"):
        out[name] = _stats(ok[f"{name}_error_pct"])
    cruise = ok["cruise_power_error_pct"].astype(float)
    out["cruise_power"] = _stats(cruise)
    if cruise.notna().any():
        g = cruise.groupby(ok["speed_ms"].astype(float).round(1))
        out["cruise_power_against_speed"] = {
            str(k): {"n": int(v.notna().sum()), "bias_pct": float(v.mean()),
                     "median_abs_pct": float(v.abs().median())}
            for k, v in g if v.notna().any()}
    if len(ok):
        w = ok.reindex(ok["energy_error_pct"].abs().sort_values(ascending=False).index)
        out["worst"] = [{"experiment": r.experiment, "energy_error_pct": r.energy_error_pct,
                         "time_error_pct": r.time_error_pct, "plan": r.plan}
                        for r in w.head(worst).itertuples()]
        out["verdicts"] = {str(k): int(v) for k, v in ok["verdict"].value_counts().items()}
        out["landed_with_reserve"] = int(ok["landed_with_reserve"].astype(bool).sum())
        against = {}
        wind_bins = pd.cut(ok["wind_ms"].astype(float), [-0.01, 1, 2, 3, 5, 100],
                           labels=["0-1", "1-2", "2-3", "3-5", ">5"])
        for col, key in (("speed_ms", ok["speed_ms"].round(1)),
                         ("payload_kg", ok["payload_kg"].round(3)),
                         ("altitude_m", ok["altitude_m"].round(0)),
                         ("wind_ms", wind_bins.astype(str))):
            g = ok.groupby(key, observed=True)["energy_error_pct"]
            against[col] = {str(k): {"n": len(v), "bias_pct": float(v.mean()),
                                     "median_abs_pct": float(v.abs().median())}
                            for k, v in g}
        out["energy_error_against"] = against
        band = {}
        for name in ("energy", "charge"):
            col = f"{name}_inside_band"
            if col in ok and ok[col].notna().any():
                inside = ok[col].dropna().astype(bool)
                band[name] = {"inside": int(inside.sum()), "n": int(inside.size),
                              "coverage_pct": 100.0 * float(inside.mean())}
        if band:
            out["band"] = band
    return out
