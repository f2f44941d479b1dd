"""Benchmark: the fixed-wing model on two real flights of one aircraft (MIT's Solar Surfer).

Data: ``../shared/data/fixed_wing/solar_surfer`` beside the repository (PROVENANCE.md):
PX4 topic exports (pyulog ``ulog2csv``) of two flights of the 9.4 kg, 4S, 1.499 m² Solar
Surfer seaplane on 3 May 2023, read by ``planner.io.logs.ulog2csv``. Flight 3 is the data
set of P. Sharpe and R. J. Hansman, "Physics-Informed Regression and Uncertainty
Quantification of Aircraft Performance from Minimal Flight Data", AIAA SciTech 2024
(repository peterdsharpe/aircraft-polar-reconstruction-from-flight-test, MIT licence);
flight 1 (repository amiramalik33/1682X, no licence) is used for validation only.

1. **The fit** — ``fit-aircraft``'s energy-rate fit
   (:func:`planner.identify.fixed_wing_fit.fit_fixed_wing`) on each whole flight, 9.4 kg,
   aspect ratio 12.15 (4.267 m span over 1.499 m²): C_D0, K (Oswald e), η with standard
   errors, P_S in the glides, plausibility, fit status; the glides' own polar point.
2. **Against the published reconstruction (flight 3)** — the level power against
   equivalent airspeed at ρ₀ = 1.225 kg/m³ (the authors' convention: calibrated airspeed
   with sea-level density) and the polar C_D(C_L), beside Sharpe & Hansman's. The paper
   prints no coefficients and its figures are images, so their curves here are a re-run
   of their final solver (``figures/results_solver.py``, AeroSandbox/IPOPT) on the same
   files: the point estimate (:data:`SHARPE_RERUN`) and its bootstrap 95 % band (400
   resamples; the paper used 3000) — a re-run, not their printed numbers. Also the fit
   with the air density from the pitot sensor's temperature instead of the barometer
   board's (which the flight record carries: 38–42 °C in flight 3).
3. **Predicting the other flight** — the aircraft fitted on one flight predicts the other's
   battery power and energy over its airborne part (airspeed above the 8 m/s stall
   speed): replayed from the flight state (the chain's steady model driven by the logged
   airspeed, climb rate and density, as ``replay``), and pre-flight from a mission file of
   the flown circuit at the flown airspeed, through ``endurance check``. Against the naive
   alternative a user has: the seed's eq. 6 (η = 0.5, P_S = 0, e = 0.8 assumed) with
   C_D0 from one cruise point of the training flight (its level, motor-on median power at
   its median airspeed), as ``aircraft/phoenix_s.yaml`` derives its C_D0.

Run: ``python benchmarks/bench_fixed_wing_real.py [--plot DIR]`` (about 20 s); ``--plot``
writes ``solar_surfer_flight3_vs_sharpe.png`` and the two fits' figures there.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from planner.chain import flightstate  # noqa: E402
from planner.chain.mission_chain import MissionChain  # noqa: E402
from planner.cli.main import main as cli  # noqa: E402
from planner.identify.aircraft_fit import with_params  # noqa: E402
from planner.identify.fixed_wing_fit import (  # noqa: E402
    fit_fixed_wing,
    fitted_mapping,
    polar_curve,
)
from planner.io.logs import read_log  # noqa: E402
from planner.parameters import load_aircraft  # noqa: E402
from planner.physics.power.energy_rate import polar_power_terms  # noqa: E402

DATA = REPO.parent / "shared" / "data" / "fixed_wing" / "solar_surfer"
AIRCRAFT = REPO / "aircraft" / "solar_surfer.yaml"
FLIGHTS = ("flight3", "flight1")
MASS_KG = 9.4                      # the paper's as-flown all-up mass
ASPECT_RATIO = 12.15               # 4.267 m (14 ft) span over 1.499 m²
RHO0 = 1.225                       # the authors' density [kg/m³]
WAYPOINT_S = 5.0                   # one waypoint of the flown circuit every [s]
G = 9.81                           # the authors' gravity [m/s²]

#: Sharpe & Hansman's final solver (figures/results_solver.py) re-run on flight 3's files:
#: point estimate. Not printed in their paper (its figures are images): a re-run.
SHARPE_RERUN = {"CD0": 0.039448, "CLCD0": 0.555072, "CD2": 0.072813, "CD3": 0.0, "CD4": 0.0,
                "scale": 1.0, "J_eff_max": 1.578048, "J_pitch_speed": 1.822626,
                "softness": 1.154346, "avionics_w": 0.0, "mean_current_a": 9.016919,
                "mean_airspeed_ms": 10.793074, "mean_voltage_v": 15.125348,
                "mass_kg": 9.4, "wing_area_m2": 1.499}
#: The re-run's electric power (W) of level steady flight at these calibrated airspeeds:
#: point estimate, and the bootstrap median and 95 % interval of 400 resamples.
SHARPE_RERUN_POWER = {
    8: (120.0, 124.0, 117.0, 137.0), 9: (96.0, 95.6, 92.9, 97.8),
    10: (92.0, 91.6, 89.4, 93.4), 11: (100.8, 101.9, 98.3, 105.4),
    12: (119.6, 121.6, 116.7, 127.6), 13: (147.3, 149.5, 143.9, 158.2),
    14: (184.1, 186.8, 180.3, 195.7), 15: (230.2, 232.2, 225.7, 240.1),
    16: (286.3, 285.7, 280.5, 292.0), 18: (430.8, 420.4, 400.1, 437.9)}


# ------------------------------------------------------------------ Sharpe & Hansman
def _softmax(a, b, softness):
    """AeroSandbox's ``softmax(a, b, softness=s)``: s·log(e^(a/s) + e^(b/s))."""
    return softness * np.logaddexp(np.asarray(a) / softness, np.asarray(b) / softness)


def sharpe_cd(cl, p=SHARPE_RERUN):
    d = np.abs(np.asarray(cl, float) - p["CLCD0"])
    return p["CD0"] + p["CD2"] * d**2 + p["CD3"] * d**3 + p["CD4"] * d**4


def sharpe_eta(pj, p=SHARPE_RERUN):
    x = pj / p["J_eff_max"]
    y = (pj - p["J_pitch_speed"]) / (p["J_eff_max"] - p["J_pitch_speed"])
    return p["scale"] * -_softmax(-x, -y, p["softness"])


def sharpe_power(v, p=SHARPE_RERUN):
    """Their steady electric power at calibrated airspeed ``v`` (ρ = 1.225): the drag
    power over the propulsive efficiency at the self-consistent advance-ratio proxy
    (their ``steady_state_required_electrical_power``), solved by bisection. [W]"""
    v = np.atleast_1d(np.asarray(v, float))
    q = 0.5 * RHO0 * v**2
    cl = p["mass_kg"] * G / (q * p["wing_area_m2"])
    drag_power = sharpe_cd(cl, p) * q * p["wing_area_m2"] * v

    def residual(pj):
        eta = sharpe_eta(pj, p)
        current = drag_power / (p["mean_voltage_v"] * eta)
        rpm = _softmax(current / p["mean_current_a"], 1e-3, 0.01) ** (1 / 3)
        return pj - (v / p["mean_airspeed_ms"]) / rpm

    lo, hi = np.full(v.shape, 0.05), np.full(v.shape, p["J_pitch_speed"] - 1e-6)
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        neg = residual(mid) < 0
        lo, hi = np.where(neg, mid, lo), np.where(neg, hi, mid)
    pj = 0.5 * (lo + hi)
    return drag_power / sharpe_eta(pj, p) + p["avionics_w"]


# ------------------------------------------------------------------ data
def record(flight: str, pitot_temperature: bool = False) -> pd.DataFrame:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df, meta = read_log(DATA / flight)
    df.attrs["t0_s"] = meta["time_base_start_s"]
    if pitot_temperature:
        dp = pd.read_csv(DATA / flight / f"{flight}_differential_pressure_0.csv")
        t = df["time_s"].to_numpy() + meta["time_base_start_s"]
        df = df.assign(ambient_temperature_c=np.interp(t, dp["timestamp"] * 1e-6,
                                                       dp["temperature"]))
    return df


def fit(df, aircraft, flight, acceleration=True):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        r = fit_fixed_wing(df, aircraft, mass_kg=MASS_KG, train=[flight],
                           aspect_ratio=ASPECT_RATIO, acceleration=acceleration)
    r["warnings"] = [str(w.message) for w in caught]
    return r


def airborne(df, aircraft):
    """Rows of the airborne part: first to last sample above the stall speed (1 s mean)."""
    v = df["airspeed_ms"].rolling(5, center=True, min_periods=1).mean().to_numpy()
    up = np.flatnonzero(v > aircraft.min_airspeed_ms)
    rows = np.zeros(len(df), bool)
    rows[up[0]:up[-1] + 1] = True
    return rows


def measured(df, rows) -> tuple[float, float]:
    """Energy [Wh] and duration [s] of the rows."""
    t, p = df["time_s"].to_numpy()[rows], df["power_w"].to_numpy()[rows]
    return float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t))) / 3600, float(t[-1] - t[0])


def replay_power(aircraft, df, rows):
    """The chain's steady model from the flight state (as ``replay``): per-sample RMSE
    [W], energy error [%] over ``rows``, and the share of rows with a logged climb rate."""
    state = flightstate.from_record(df)
    pred = MissionChain(aircraft, None).power_at(state.airspeed_ms, state.climb_rate_ms,
                                                 state.air_density, MASS_KG)[rows]
    meas = state.measured_power_w[rows]
    t = state.time_s[rows]
    e_p = np.sum(0.5 * (pred[1:] + pred[:-1]) * np.diff(t))
    e_m = np.sum(0.5 * (meas[1:] + meas[:-1]) * np.diff(t))
    climb_ok = float(np.isfinite(df["climb_rate_ms"].to_numpy()[rows]).mean()) \
        if "climb_rate_ms" in df else 0.0
    return (float(np.sqrt(np.mean((pred - meas) ** 2))), 100 * (e_p - e_m) / e_m, climb_ok,
            float(e_p) / 3600)


def with_baro_climb(df):
    """The record with its climb rate filled, where the log has none, from the barometric
    altitude (pressure altitude, 1 s centred slope)."""
    from planner.physics.atmosphere import pressure_altitude
    p = df["pressure_pa"].interpolate(limit_direction="both").to_numpy()
    h = pd.Series(pressure_altitude(p)).rolling(25, center=True, min_periods=1).mean()
    vz = np.gradient(h.to_numpy(), df["time_s"].to_numpy())
    c = df["climb_rate_ms"].to_numpy(float)
    return df.assign(climb_rate_ms=np.where(np.isfinite(c), c, vz))


def naive(aircraft, df, rows):
    """The seed's eq. 6 with η = 0.5, P_S = 0, e = 0.8 and C_D0 from one cruise point of
    the flight: its level (|climb| < 0.5 m/s), motor-on (above 15 % of the airborne
    median) median power within 1 m/s of its median airspeed."""
    state = flightstate.from_record(with_baro_climb(df))
    v, climb, rho = (x[rows] for x in (state.airspeed_ms, state.climb_rate_ms,
                                       state.air_density))
    p = state.measured_power_w[rows]
    v_med = float(np.median(v))
    cruise = (np.abs(climb) < 0.5) & (p > 0.15 * np.median(p)) & (np.abs(v - v_med) < 1.0)
    p_c, rho_c = float(np.median(p[cruise])), float(np.median(rho[cruise]))
    k = 1.0 / (math.pi * 0.8 * ASPECT_RATIO)
    a, b = polar_power_terms(v_med, rho_c, MASS_KG, aircraft.fixed_wing.wing_area_m2)
    cd0 = float((0.5 * p_c - b * k) / a)
    ac = with_params(aircraft, {"efficiency": 0.5, "system_power_w": 0.0, "cd0": cd0,
                                "k": k})
    return ac, {"cruise_power_w": p_c, "airspeed_ms": v_med, "samples": int(cruise.sum()),
                "cd0": cd0, "k": k}


def circuit_mission(flight: str, df, rows, folder: Path) -> tuple[Path, dict]:
    """A waypoint mission of the flown circuit (GPS track every 5 s of the airborne part,
    the barometric height), at the flight's median true airspeed, in the wind the GPS and
    airspeed give (least squares of the wind triangle) and the logged air."""
    from scipy.optimize import least_squares

    from planner.physics.atmosphere import pressure_altitude
    t0 = df.attrs["t0_s"]
    t = df["time_s"].to_numpy() + t0
    ta, tb = t[rows][0], t[rows][-1]
    gps = pd.read_csv(DATA / flight / f"{flight}_vehicle_gps_position_0.csv")
    tg = gps["timestamp"].to_numpy() * 1e-6
    g = gps[(tg >= ta) & (tg <= tb) & (gps["fix_type"] >= 3)]
    tg = g["timestamp"].to_numpy() * 1e-6
    lat, lon = g["lat"].to_numpy() * 1e-7, g["lon"].to_numpy() * 1e-7
    tas = np.interp(tg, t, df["airspeed_ms"].to_numpy())
    vn, ve = g["vel_n_m_s"].to_numpy(), g["vel_e_m_s"].to_numpy()
    wind = least_squares(lambda w: np.hypot(vn - w[0], ve - w[1]) - tas, [0.0, 0.0]).x
    speed = float(np.hypot(*wind))
    from_deg = float(np.degrees(np.arctan2(-wind[1], -wind[0])) % 360)
    h = pressure_altitude(df["pressure_pa"].interpolate(limit_direction="both").to_numpy())
    h0 = float(np.median(h[~rows][: max(1, np.argmax(rows))][-50:]))   # on the water
    pick = np.searchsorted(tg, np.arange(ta, tb, WAYPOINT_S))
    pick = np.unique(np.clip(pick, 0, len(tg) - 1))[1:]
    v_med = float(np.median(df["airspeed_ms"].to_numpy()[rows]))
    wps = [{"lat": round(float(lat[i]), 7), "lon": round(float(lon[i]), 7),
            "alt_m": round(max(float(np.interp(tg[i], t, h)) - h0, 5.0), 1)} for i in pick]
    dp = pd.read_csv(DATA / flight / f"{flight}_differential_pressure_0.csv")
    air_t = float(np.median(np.interp(t[rows], dp["timestamp"] * 1e-6, dp["temperature"])))
    mission = {
        "name": f"Solar Surfer {flight}: the flown circuit",
        "home": {"lat": round(float(lat[0]), 7), "lon": round(float(lon[0]), 7),
                 "alt_m": round(float(np.median(g["alt"])) * 1e-3, 1)},
        "environment": {"wind_speed_ms": round(speed, 2), "wind_from_deg": round(from_deg, 1),
                        "temperature_c": round(air_t, 1),
                        "pressure_pa": round(float(np.nanmedian(
                            df["pressure_pa"].to_numpy()[rows])), 0)},
        "takeoff_alt_m": wps[0]["alt_m"], "airspeed_ms": round(v_med, 2),
        "waypoints": wps, "return_home": False, "land": True,
        "source": f"benchmarks/bench_fixed_wing_real.py from {flight}'s GPS track"}
    path = folder / f"{flight}_circuit.yaml"
    path.write_text(yaml.safe_dump(mission, sort_keys=False))
    return path, {"waypoints": len(wps), "airspeed_ms": v_med, "wind_ms": speed,
                  "wind_from_deg": from_deg, "temperature_c": air_t}


def check_energy(mission: Path, aircraft, folder: Path, name: str) -> dict:
    """``endurance check`` of the mission with the aircraft: its JSON."""
    ac_path = folder / f"{name}.yaml"
    m = aircraft.to_mapping(folder=folder)
    ac_path.write_text(yaml.safe_dump(m, sort_keys=False))
    out = folder / f"{name}_check.json"
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        code = cli(["check", str(mission), "--aircraft", str(ac_path), "--json", str(out)])
    if code not in (0, 1):
        raise RuntimeError(f"endurance check exited {code} for {name}")
    return json.loads(out.read_text())


# ------------------------------------------------------------------ report
def print_fit(flight, r):
    p, se = r["parameters"], r["stderr"]
    print(f"\n{flight}: C_D0 {p['cd0']:.4f} ± {se['cd0']:.4f}, K {p['k']:.4f} ± {se['k']:.4f} "
          f"(Oswald e {r['oswald_efficiency']:.2f} ± {r['oswald_efficiency_stderr']:.2f}), "
          f"η {p['efficiency']:.3f} ± {se['efficiency']:.3f}, P_S {p['system_power_w']:.1f} "
          f"± {se['system_power_w']:.1f} W ({r['system_power']['source']})")
    for m in r["misfit"]:
        e = m.get("oswald_unconstrained")
        print(f"  misfit: {m['parameter']} on its {m['bound']} bound; unconstrained "
              f"{m['unconstrained']:.4f}" + (f" (Oswald e {e:.2f})" if e else ""))
    for name, q in r["plausibility"].items():
        print(f"  {name} {q['value']:.3g}: {q['verdict']} {q['range'][0]:g}-{q['range'][1]:g}")
    g = r["glides"][flight]
    if "drag_coefficient" in g:
        print(f"  glides {g['duration_s']:.0f} s ({g['core_duration_s']:.0f} s clear of the "
              f"powered flight) at {g['airspeed_ms']:.1f} m/s: C_L "
              f"{g['lift_coefficient']:.2f}, C_D {g['drag_coefficient']:.4f} (L/D "
              f"{g['lift_to_drag']:.1f}) from the energy rate alone; "
              f"{g['drag_vs_fitted_pct']:+.0f} % against the fitted polar")
    sh = r["shifted_polar"]
    print(f"  least drag left free (diagnostic): C_D,min {sh['cd_min']:.4f} at C_L "
          f"{sh['cl_min']:.2f}, K {sh['k']:.4f}, η {sh['efficiency']:.3f}, residual RMS "
          f"{sh['energy_rate_rmse_w']:.1f} W")
    t = r["train"]
    print(f"  energy-rate residual RMS {r['energy_rate_rmse_w']:.1f} W; battery power on "
          f"its own flight: RMSE {t['after']['rmse_w']:.1f} W, energy "
          f"{t['after']['energy_error_pct']:+.1f} % (steady model), "
          f"{t['after_energy_rate']['rmse_w']:.1f} W, "
          f"{t['after_energy_rate']['energy_error_pct']:+.1f} % (with dV/dt)")


def ours_power(r, v):
    """Level, steady battery power of a fit at equivalent airspeed ``v`` (ρ₀). [W]"""
    ac = r["aircraft"]
    a, b = polar_power_terms(v, RHO0, MASS_KG, ac.fixed_wing.wing_area_m2)
    return (a * ac.fixed_wing.cd0 + b * ac.fixed_wing.k) / ac.efficiency + ac.system_power_w


def compare(r, r_pitot):
    print("\n== 2. Flight 3 against Sharpe & Hansman's reconstruction (their solver "
          "re-run on the same files; ρ₀ = 1.225 kg/m³, 9.4 kg)")
    check = sharpe_power(np.array(sorted(SHARPE_RERUN_POWER)))
    table = np.array([SHARPE_RERUN_POWER[k][0] for k in sorted(SHARPE_RERUN_POWER)])
    print(f"   (their steady power re-implemented here matches the re-run's table within "
          f"{np.max(np.abs(check / table - 1)) * 100:.1f} %)")
    print(f"{'EAS m/s':>7} {'C_L':>5} | {'ours W':>7} {'pitot-T W':>9} | {'S&H W':>6} "
          f"{'95 % band W':>13} | {'ours C_D':>8} {'S&H C_D':>8}")
    ac = r["aircraft"].fixed_wing
    for v in sorted(SHARPE_RERUN_POWER):
        pt, _, lo, hi = SHARPE_RERUN_POWER[v]
        cl = MASS_KG * G / (0.5 * RHO0 * v * v * ac.wing_area_m2)
        print(f"{v:7.0f} {cl:5.2f} | {ours_power(r, v):7.1f} {ours_power(r_pitot, v):9.1f} | "
              f"{pt:6.1f} {f'[{lo:.0f}, {hi:.0f}]':>13} | "
              f"{float(polar_curve(cl, ac.cd0, ac.k)):8.4f} {float(sharpe_cd(cl)):8.4f}")
    vv = np.linspace(7.5, 18, 421)
    for name, fn in (("ours", lambda x: ours_power(r, x)),
                     ("ours, pitot temperature", lambda x: ours_power(r_pitot, x)),
                     ("Sharpe & Hansman (re-run)", sharpe_power)):
        pp = fn(vv)
        i = int(np.argmin(pp))
        print(f"   {name}: least power {pp[i]:.1f} W at {vv[i]:.2f} m/s EAS")
    cl = np.linspace(0.3, 1.8, 301)
    for name, cd in (("ours", polar_curve(cl, ac.cd0, ac.k)),
                     ("ours, pitot temperature", polar_curve(
                         cl, r_pitot["aircraft"].fixed_wing.cd0,
                         r_pitot["aircraft"].fixed_wing.k)),
                     ("Sharpe & Hansman (re-run)", sharpe_cd(cl))):
        j = int(np.argmax(cl / cd))
        print(f"   {name}: (L/D)max {cl[j] / cd[j]:.1f} at C_L {cl[j]:.2f}")


def predict(fits, folder: Path):
    print("\n== 3. Predicting the other flight (airborne part: above the 8 m/s stall speed)")
    base = load_aircraft(AIRCRAFT)
    rows_out = []
    for train, test in (("flight3", "flight1"), ("flight1", "flight3")):
        df = record(test)
        rows = airborne(df, base)
        e_m, dur = measured(df, rows)
        mission, info = circuit_mission(test, df, rows, folder)
        naive_ac, nv = naive(base, record(train), airborne(record(train), base))
        print(f"\n{train} -> {test}: measured {e_m:.2f} Wh over {dur:.0f} s airborne; "
              f"mission of the circuit: {info['waypoints']} waypoints at "
              f"{info['airspeed_ms']:.1f} m/s, wind {info['wind_ms']:.1f} m/s from "
              f"{info['wind_from_deg']:.0f}°, {info['temperature_c']:.0f} °C")
        print(f"   naive: C_D0 {nv['cd0']:.4f} from {nv['cruise_power_w']:.0f} W at "
              f"{nv['airspeed_ms']:.1f} m/s ({nv['samples']} level motor-on samples of "
              f"{train}), K {nv['k']:.4f}, η 0.5, P_S 0")
        print(f"   {'model':<22} {'replay RMSE W':>13} {'replay E %':>10} "
              f"{'baro-climb E %':>14} {'check Wh':>9} {'check E %':>9} {'check s':>8}")
        for name, ac in ((f"fitted on {train}", fits[train]["aircraft"]),
                         ("naive (eq. 6)", naive_ac)):
            rmse, err, climb_ok, _ = replay_power(ac, df, rows)
            _, err_baro, _, _ = replay_power(ac, with_baro_climb(df), rows)
            c = check_energy(mission, ac, folder, f"{train}_{name.split()[0]}")
            err_c = 100 * (c["energy_wh"] - e_m) / e_m
            print(f"   {name:<22} {rmse:13.1f} {err:+10.1f} {err_baro:+14.1f} "
                  f"{c['energy_wh']:9.2f} {err_c:+9.1f} {c['duration_s']:8.0f}")
            rows_out.append((train, test, name, rmse, err, err_baro, c["energy_wh"], err_c))
        print(f"   (the record's climb rate, PX4's local-position vz, is logged for "
              f"{100 * climb_ok:.0f} % of the airborne part; replay takes 0 m/s elsewhere)")
    return rows_out


def plot(fits, r_pitot, folder: Path):
    from planner.cli.commands.fixed_wing_report import curves, save_plot
    from planner.cli.plots.fixed_wing import save_fixed_wing_plot

    v = np.linspace(8, 18, 101)
    cl = np.linspace(0.3, 1.8, 101)
    ours = curves(fits["flight3"], MASS_KG, "ours: energy-rate fit, C_D0 + K C_L^2",
                  air_density=RHO0)
    pitot = curves(r_pitot, MASS_KG, "ours, density from the pitot temperature",
                   air_density=RHO0)
    ref = {"label": "Sharpe & Hansman, their solver re-run", "airspeed_ms": v,
           "power_w": sharpe_power(v), "cl": cl, "cd": sharpe_cd(cl)}
    out = folder / "solar_surfer_flight3_vs_sharpe.png"
    pts = fits["flight3"]["samples_table"].copy()
    ratio = np.sqrt(pts["air_density"] / RHO0)        # to equivalent airspeed at ρ₀
    p_s = fits["flight3"]["parameters"]["system_power_w"]
    pts["airspeed_ms"] = pts["airspeed_ms"] * ratio
    pts["level_power_w"] = p_s + (pts["level_power_w"] - p_s) * ratio
    save_fixed_wing_plot(pts, [ours, pitot], out,
                         references=[ref], density_note="equivalent, ρ₀ = 1.225 kg/m³",
                         title="Solar Surfer flight 3: energy-rate fit vs Sharpe & Hansman")
    print(f"\nwrote {out}")
    for flight, r in fits.items():
        p = folder / f"solar_surfer_{flight}_fit.png"
        save_plot(r, MASS_KG, p)
        print(f"wrote {p}")


def run(plot_dir: str | None) -> int:
    if not DATA.is_dir():
        print(f"data not found: {DATA}")
        return 2
    base = load_aircraft(AIRCRAFT)
    print("== 1. The energy-rate fit on each whole flight (9.4 kg, aspect ratio 12.15)")
    fits = {f: fit(record(f), base, f) for f in FLIGHTS}
    for f in FLIGHTS:
        print_fit(f, fits[f])
    r_pitot = fit(record("flight3", pitot_temperature=True), base, "flight3")
    print("\nflight3 with the air density from the pitot sensor's temperature:")
    print_fit("flight3", r_pitot)
    print("\nflight3 with the seed's steady balance (m V dV/dt dropped), for comparison:")
    print_fit("flight3", fit(record("flight3"), base, "flight3", acceleration=False))
    compare(fits["flight3"], r_pitot)
    with tempfile.TemporaryDirectory() as tmp:
        predict(fits, Path(tmp))
    if plot_dir:
        folder = Path(plot_dir)
        folder.mkdir(parents=True, exist_ok=True)
        plot(fits, r_pitot, folder)
    return 0


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", metavar="DIR", help="write the figures (PNG) to DIR")
    sys.exit(run(ap.parse_args().plot))
