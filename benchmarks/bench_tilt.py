"""Figures: the tilt the DJI Matrice 100 flies, and how it starts and stops.

Data: the CMU package-delivery flights of a DJI M100 (Rodrigues et al., Scientific Data 8,
155, 2021, doi:10.1184/R1/12683453, CC BY 4.0), ``../shared/data/energy`` beside the
repository, read through the column map ``dji_m100`` (each flight's payload, commanded
speed, altitude and route from the data set's ``m100_parameters.csv``).

Printed:

* the median axial speed through the rotor disks (the body-frame ``velocity_z``) of each
  route-R1 flight's level cruise (climbing slower than 0.3 m/s, ground speed within 15 %
  of the commanded, above 80 % of the commanded altitude), by commanded speed;
* the drag area the disks' tilt balances (``planner.identify.aircraft_fit.tilt_drag_area``,
  what ``fit-aircraft`` writes as ``tilt_drag_area_m2``) on every flight, and on the
  flights of each class: the wind the anemometer read at rest before take-off (the
  backtest's forecast), the route (R1 against the others), the payload;
* the times the speed takes from 10 % to 90 % of the commanded at each start from rest
  and from 90 % to 10 % at each stop, route-R1 flights, by commanded speed (medians).

Run: ``python benchmarks/bench_tilt.py`` (about 20 s).
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from planner.chain import flightstate  # noqa: E402
from planner.identify.aircraft_fit import tilt_drag_area  # noqa: E402
from planner.identify.backtest import BacktestOptions, forecast  # noqa: E402
from planner.io import record  # noqa: E402
from planner.io.flightdata import load_flight_data  # noqa: E402
from testkit.matrix import level_cruise  # noqa: E402

ENERGY = REPO.parent / "shared" / "data" / "energy"
FILES = ("m100_flights_part1_flights001-149.csv.gz", "m100_flights_part2_flights150-279.csv.gz")
SITE_ALTITUDE_M = 300.0
#: The airborne height of the shipped file's fit (its ``source:`` command). [m]
AIRBORNE_HEIGHT_M = 7.0
#: Empty aircraft with its TB47D pack (aircraft/dji_m100.yaml). [kg]
BARE_KG = 2.355


def level_axial_speeds(data: pd.DataFrame, par: pd.DataFrame) -> pd.Series:
    """Median axial speed of each R1 flight's level cruise, by commanded speed. [m/s]"""
    rows = []
    for f, g in data.groupby(data["experiment"].astype(int)):
        p = par.loc[f]
        if p["route"] != "R1":
            continue
        ok = level_cruise(g, p["speed"], pd.to_numeric(p["altitude"], errors="coerce"))
        if ok is not None and ok.sum() >= 50:
            rows.append((p["speed"], float(np.nanmedian(g["axial_speed_ms"].to_numpy(float)[ok]))))
    t = pd.DataFrame(rows, columns=["speed", "axial"])
    return t.groupby("speed")["axial"].median()


def ramp_times(data: pd.DataFrame) -> pd.DataFrame:
    """Seconds from 10 % to 90 % of the commanded speed at each start, and from 90 % to
    10 % at each stop, of the route-R1 flights: medians and counts by speed."""
    rows = []
    for _, g in data[data["route"] == "R1"].groupby("experiment"):
        v = float(g["commanded_speed_ms"].iloc[0])
        t = g["time_s"].to_numpy(float)
        gs = np.abs(g["groundspeed_ms"].to_numpy(float))
        high, low = gs > 0.9 * v, gs < 0.1 * v
        for a in np.flatnonzero(np.diff(high.astype(int)) == 1) + 1:    # reaching 90 %
            before = np.flatnonzero(low[:a])
            if before.size and a - before[-1] < 200:
                rows.append((v, "start", t[a] - t[before[-1]]))
        for b in np.flatnonzero(np.diff(high.astype(int)) == -1):       # leaving 90 %
            after = np.flatnonzero(low[b:])
            if after.size and after[0] < 200:
                rows.append((v, "stop", t[b + after[0]] - t[b]))
    r = pd.DataFrame(rows, columns=["speed", "ramp", "seconds"])
    return r.groupby(["speed", "ramp"])["seconds"].agg(["median", "count"]).unstack("ramp")


def main() -> int:
    if not ENERGY.is_dir():
        print(f"no data: {ENERGY} is absent")
        return 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data, _ = load_flight_data([ENERGY / f for f in FILES], column_map="dji_m100")
    par = pd.read_csv(ENERGY / "m100_parameters.csv").set_index("flight")
    data = data[data["experiment"].astype(int).isin(par.index)]
    print("median axial speed of the R1 flights' level cruise [m/s], by commanded speed:")
    print("  " + ", ".join(f"{v:g} m/s: {a:.2f}" for v, a in
                           level_axial_speeds(data, par).items()))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        states = [(str(e), g.reset_index(drop=True),
                   flightstate.from_record(g.reset_index(drop=True), SITE_ALTITUDE_M))
                  for e, g in record.experiments(data)]
    mass = {e: BARE_KG + par.loc[int(e), "payload"] / 1000.0 for e, _, _ in states}
    opts = BacktestOptions(site_altitude_m=SITE_ALTITUDE_M)
    wind = {}
    for e, exp, _ in states:
        env = forecast(exp, e, opts)
        wind[e] = env[0].wind_speed_ms if not isinstance(env, str) else np.nan
    route = {e: par.loc[int(e), "route"] for e in mass}
    payload = {e: par.loc[int(e), "payload"] for e in mass}
    classes = {"every flight": set(mass)}
    for lo, hi in ((0, 1), (1, 2), (2, 3), (3, 10)):
        classes[f"wind at rest {lo}-{hi} m/s"] = {e for e, w in wind.items() if lo <= w < hi}
    classes["route R1"] = {e for e, r in route.items() if r == "R1"}
    classes["other routes"] = {e for e, r in route.items() if r != "R1"}
    for g in sorted(set(payload.values())):
        classes[f"payload {g:g} g"] = {e for e, p in payload.items() if p == g}
    print("\ndrag area the disks' tilt balances (tilt_drag_area, steady level samples):")
    for name, ids in classes.items():
        r = tilt_drag_area(states, mass, ids, AIRBORNE_HEIGHT_M)
        text = (f"{r['value']:.4f} ± {r['stderr']:.4f} m² ({r['samples']} samples, "
                f"{r['flights']} flights)" if "value" in r else r["reason"])
        print(f"  {name:<24} {text}")
    print("\nroute R1, 10 → 90 % of the commanded speed (start) and 90 → 10 % (stop) [s]:")
    print(ramp_times(data).round(2).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
