"""Real DJI Matrice 100 flights with one physically injected effect, for diagnose's
benchmark (``benchmarks/bench_diagnose_real.py``) and its tests.

Data: the M100 package-delivery flights of Rodrigues et al. (Scientific Data 8, 155,
2021, doi:10.1184/R1/12683453, CC BY 4.0) in ``../shared/data/energy`` (flights 1–149),
read with the shipped column map. Injected data are the real flights changed by a
physical law, not data made by the planner's own models.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from planner.io.flightdata import load_flight_data
from planner.identify.diagnose import diagnose
from planner.physics.units import AS_PER_MAH

REPO = Path(__file__).resolve().parents[1]

DATA = REPO.parent / "shared/data/energy/m100_flights_part1_flights001-149.csv.gz"


PAYLOAD_KG = 0.25


BIAS_A = 0.3


def load(anemometer_airspeed: bool = False):
    """The flights 1–149 as flight records (the shipped map). With
    ``anemometer_airspeed``, each record also has an airspeed: the ground velocity (the
    map's ground speed and east-north-up course) less the flight's steady wind from the
    anemometer (:func:`anemometer_wind`); the course is then dropped again, so that
    diagnose flies that airspeed and tests no wind of its own."""
    if not anemometer_airspeed:
        df, _ = load_flight_data(DATA, column_map="dji_m100")
        return df
    import yaml

    spec = yaml.safe_load((REPO / "planner/io/logs/maps/dji_m100.yaml").read_text())
    spec["derived"]["course_deg"] = {"op": "enu_course",
                                     "of": spec["derived"]["groundspeed_ms"]["of"]}
    df, _ = load_flight_data(DATA, column_map=spec)
    wind = anemometer_wind()
    exp = df["experiment"].astype(str)
    w_e = exp.map({k: v[0] for k, v in wind.items()}).to_numpy(float)
    w_n = exp.map({k: v[1] for k, v in wind.items()}).to_numpy(float)
    course = np.radians(df["course_deg"].to_numpy(float))
    gs = df["groundspeed_ms"].to_numpy(float)
    v_e = np.where(np.isfinite(course), gs * np.sin(course), 0.0)
    v_n = np.where(np.isfinite(course), gs * np.cos(course), 0.0)
    df["airspeed_ms"] = np.hypot(v_e - w_e, v_n - w_n)   # NaN without a wind: ground speed
    return df.drop(columns="course_deg")


def subset(df, rng, n=16):
    ids = df["experiment"].unique()
    pick = rng.choice(ids, size=min(n, len(ids)), replace=False)
    return df[df["experiment"].isin(pick)].reset_index(drop=True)


@functools.lru_cache(maxsize=2)
def _raw(path):
    """The upstream columns the wind and turnaround need, read once per file (not to be
    changed by callers)."""
    import pandas as pd

    return pd.read_csv(path, usecols=[
        "flight", "time", "wind_speed", "wind_angle", "position_x", "position_y",
        "position_z", "velocity_x", "velocity_y", "velocity_z", "orientation_x",
        "orientation_y", "orientation_z", "orientation_w"])


#: Largest heading offset of the anemometer's angle tried per flight. [deg]
MAX_HEADING_OFFSET_DEG = 45.0


def anemometer_wind(path=DATA) -> dict[str, np.ndarray]:
    r"""Each flight's steady wind (east, north) [m/s] from its on-board anemometer.

    The anemometer (upstream ``wind_speed``, ``wind_angle``) reads the air flow relative to
    the vehicle, rotor wash included: as a vector :math:`\vec a` of its speed towards the
    compass direction ``wind_angle`` + δ, the ground velocity is :math:`\vec v_g = \vec w +
    k\,\vec a` for a steady wind :math:`\vec w` (the velocity of the air), with a scale
    k < 1 for the flow the sensor sees. Fitted by least squares per flight over the
    airborne samples (more than 7 m above the first valid altitude) on the east and north
    components of the body-frame velocity rotated by the attitude quaternion (as the
    column map's ``enu_*`` ops do). Of the readings of the angle (world or body frame,
    towards or from it), this one leaves the steadiest wind within a flight: on flights
    1–149, with k = 0.6 and δ = 0, the wind's within-flight spread (the two components'
    standard deviations, combined) is 3.2 m/s, against 5.1–8.3 m/s for the other readings
    (each at the best of the scales tried, 0.4–1) and 5.1 m/s for the ground velocity
    alone. Fitted per flight, k has median 0.66.

    The angle is a magnetic one (upstream README), and its offset from the frame of the
    velocities is not the same on every flight: δ is fitted per flight too, the offset
    within ±:data:`MAX_HEADING_OFFSET_DEG` that leaves the steadiest wind (least squares
    over a 2.5° grid, then refined). On the M100 flights it is −15 to −35° on flights
    1–7 (their RMS misfit of the ground velocity falls by 9–36 %) and −12 to +12° on
    flights 268–279. No model uses this wind; :func:`wind_step` compares it with the power
    model's residual.
    """
    from scipy.optimize import minimize_scalar
    from scipy.spatial.transform import Rotation

    raw = _raw(path)
    q = raw[["orientation_x", "orientation_y", "orientation_z", "orientation_w"]].to_numpy()
    ok = np.abs(np.linalg.norm(q, axis=1) - 1.0) < 0.1
    raw, q = raw[ok], q[ok]
    v = Rotation.from_quat(q).apply(raw[["velocity_x", "velocity_y", "velocity_z"]].to_numpy())
    alt = raw["position_z"].where(raw["position_z"] != 0.0)
    alt = alt - alt.groupby(raw["flight"]).transform("first")
    theta = np.radians(raw["wind_angle"].to_numpy())
    a_e = raw["wind_speed"].to_numpy() * np.sin(theta)
    a_n = raw["wind_speed"].to_numpy() * np.cos(theta)
    air = (alt > 7.0).to_numpy() & np.isfinite(a_e) & np.isfinite(v).all(axis=1)
    out = {}
    flights = raw["flight"].to_numpy()
    for f in np.unique(flights[air]):
        m = air & (flights == f)
        n = int(m.sum())
        if n < 100:
            continue
        y = np.concatenate([v[m, 0], v[m, 1]])
        X = np.zeros((2 * n, 3))
        X[:n, 0] = X[n:, 1] = 1.0

        def fit(delta_deg, ae=a_e[m], an=a_n[m]):
            c, s = np.cos(np.radians(delta_deg)), np.sin(np.radians(delta_deg))
            X[:n, 2], X[n:, 2] = ae * c + an * s, an * c - ae * s     # angle + δ
            coef, *_ = np.linalg.lstsq(X, y, rcond=None)
            return float(np.sum((y - X @ coef) ** 2)), coef

        grid = np.arange(-MAX_HEADING_OFFSET_DEG, MAX_HEADING_OFFSET_DEG + 1e-9, 2.5)
        best = grid[int(np.argmin([fit(d)[0] for d in grid]))]
        lo = max(best - 2.5, -MAX_HEADING_OFFSET_DEG)
        hi = min(best + 2.5, MAX_HEADING_OFFSET_DEG)
        delta = minimize_scalar(lambda d: fit(d)[0], bounds=(lo, hi), method="bounded",
                                options={"xatol": 1e-3}).x
        out[str(f)] = fit(float(delta))[1][:2]
    return out


def turnaround(path=DATA) -> dict[str, tuple[float, float]]:
    """Each flight's turnaround from its GNSS track: the time [s since the flight's first
    sample] it is farthest from its first fix, and the bearing of that point from it
    [deg from north]."""
    out = {}
    for f, g in _raw(path).groupby("flight"):
        lon, lat = g["position_x"].to_numpy(), g["position_y"].to_numpy()
        ok = (lon != 0.0) & np.isfinite(lon) & np.isfinite(lat)
        if ok.sum() < 10:
            continue
        east = (lon - lon[ok][0]) * 111.32e3 * np.cos(np.radians(lat[ok][0]))
        north = (lat - lat[ok][0]) * 110.57e3
        d = np.where(ok, np.hypot(east, north), -1.0)
        j = int(np.argmax(d))
        t = g["time"].to_numpy()
        out[str(f)] = (float(t[j] - t[0]), float(np.degrees(np.arctan2(east[j], north[j])) % 360))
    return out


def clean_residual(data, aircraft, pack):
    """diagnose's power level on clean ``data``: the level, the rows of its calibrated
    baseline's fit on all the data, their residual measured − modelled [W] and the
    baseline's values."""
    report = diagnose(data, pack, aircraft, payload_kg=PAYLOAD_KG).levels["power"]
    level, fit = report.result.level, report.result.base_fit or report.result.final_fit
    # the fit's residual is modelled − measured
    return level, np.flatnonzero(fit.train), -fit.train_resid, report.base_values


def wind_step(df, aircraft, pack) -> dict[str, float]:
    """The clean flights' power residual at the turnaround against their own wind.

    For the flights in sets of 16 (file order), the calibrated power model's residual
    (measured − modelled) over the cruise bins (ground speed > 2 m/s, |climb| < 0.5 m/s)
    of the return leg minus that of the outbound leg, split at the turnaround
    (:func:`turnaround`), against the anemometer's wind along the outbound bearing
    (:func:`anemometer_wind`; positive: a tailwind out). The model flies the ground speed
    (the map has no wind), so a tailwind out, a lower airspeed out and a higher one back,
    leaves a step of about 2·w·dP/dV: returned beside (``model_slope_w_per_ms``), from
    the calibrated model's own power curve at the flights' median cruise ground speed.
    """
    from scipy.stats import pearsonr

    from planner.identify.diagnose.search import with_params

    wind, turn = anemometer_wind(), turnaround()
    ids = df["experiment"].unique()
    steps, along, speeds, bearings, base, rho = [], [], [], [], [], []
    for k in range(0, len(ids), 16):
        data = df[df["experiment"].isin(ids[k:k + 16])].reset_index(drop=True)
        level, rows, resid, values = clean_residual(data, aircraft, pack)
        base.append(values)
        rho.append(float(np.median(level.rho_std)))   # the density the model flew
        exp, t = level.exp[rows], level.time[rows]
        cruise = (level.gs[rows] > 2.0) & (np.abs(level.climb[rows]) < 0.5)
        for e in np.unique(exp):
            name = level.names[e]
            if name not in wind or name not in turn:
                continue
            t_far, bearing = turn[name]
            out = cruise & (exp == e) & (t < t_far)
            back = cruise & (exp == e) & (t >= t_far)
            if out.sum() < 5 or back.sum() < 5:
                continue
            u = np.array([np.sin(np.radians(bearing)), np.cos(np.radians(bearing))])
            steps.append(resid[back].mean() - resid[out].mean())
            along.append(float(wind[name] @ u))
            speeds.append(np.median(level.gs[rows][cruise & (exp == e)]))
            bearings.append(bearing)
    steps, along = np.array(steps), np.array(along)
    slope, _ = np.polyfit(along, steps, 1)
    r, p_value = pearsonr(along, steps)
    v = float(np.median(speeds))
    eta = float(np.median([b["efficiency"] for b in base]))
    f = float(np.median([b["drag_area_m2"] for b in base]))
    model = with_params(aircraft, {"efficiency": eta, "drag_area_m2": f})
    mass = aircraft.empty_mass_kg + pack.mass_kg + PAYLOAD_KG
    dp_dv = float(np.diff(model.battery_power(np.array([v - 1.0, v + 1.0]), 0.0,
                                              float(np.median(rho)), mass))[0] / 2.0)
    return {"flights": len(steps), "bearing_deg": float(np.median(bearings)),
            "step_median_w": float(np.median(steps)),
            "step_negative_share": float(np.mean(steps < 0)),
            "along_wind_median_ms": float(np.median(along)),
            "tailwind_out_share": float(np.mean(along > 0)), "correlation": float(r),
            "p_value": float(p_value), "slope_w_per_ms": float(slope),
            "model_slope_w_per_ms": 2.0 * dp_dv, "efficiency": eta, "drag_area_m2": f,
            "cruise_speed_ms": v}


def _reintegrate(g):
    t = g["time_s"].to_numpy()
    i = g["current_a"].to_numpy()
    q = np.concatenate(([0.0], np.cumsum(0.5 * (i[1:] + i[:-1]) * np.diff(t))))
    return q / AS_PER_MAH


def inject(df, effect, mass_kg, at=0.5):
    out = df.copy()
    for idx in out.groupby("experiment", sort=False).groups.values():
        g = out.loc[idx]
        if effect == "payload_drop":
            alt = g["altitude_m"].to_numpy()
            up = np.flatnonzero(alt > alt[0] + 7.0)
            if up.size < 10:
                continue
            t0, t1 = g["time_s"].iloc[up[0]], g["time_s"].iloc[up[-1]]
            t_drop = t0 + at * (t1 - t0)
            after = (g["time_s"] >= t_drop).to_numpy() & (alt > alt[0] + 1.0)
            f = ((mass_kg - PAYLOAD_KG) / mass_kg) ** 1.5
            scale = np.where(after, f, 1.0)
            out.loc[idx, "current_a"] = g["current_a"].to_numpy() * scale
        elif effect == "current_bias":
            out.loc[idx, "current_a"] = g["current_a"].to_numpy() + BIAS_A
        g = out.loc[idx]
        out.loc[idx, "power_w"] = g["voltage_v"].to_numpy() * g["current_a"].to_numpy()
        if "consumed_mah" in out:
            out.loc[idx, "consumed_mah"] = _reintegrate(g)
    return out
