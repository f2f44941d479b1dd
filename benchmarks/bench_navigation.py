"""Benchmark: the navigation model's gain on real DJI Matrice 100 flights, pre-flight.

Data: the CMU package-delivery flights of a DJI M100 (Rodrigues et al., Scientific Data 8,
155, 2021, DOI 10.1184/R1/12683453, CC BY 4.0), ``../shared/data/energy`` beside the
repository (see its PROVENANCE.md), read through the repository's column map
``planner/io/logs/maps/dji_m100.yaml``; commanded speed, altitude, payload (grams) and
route per flight from ``m100_parameters.csv``.

Held out: 47 flights — the 9 "random flights" of Choudhry et al. (ICRA 2021) in this copy
(268–272, 276–279) and every route-R1 flight whose number is divisible by 5. The
navigation (:func:`planner.identify.navigation_fit.fit_navigation`) is fitted on every
OTHER flight of the data set.

Each held-out flight's plan is rebuilt from what was known before it flew: take-off at
home, a vertical climb to the commanded altitude, a straight leg at the commanded speed to
each turning point of the route (where the vehicle stopped at altitude), back home, and a
descent to the ground; the take-off mass is the aircraft file's empty mass and pack plus
the flight's payload. The chain (``MissionChain.check``, the pre-flight check) predicts
its flight time and energy with the aircraft file ``aircraft/dji_m100_rotor_losses.yaml``
as shipped and with the same file plus the fitted navigation. Measured: from the first to
the last sample whose power is above ``MOTORS_ON_W``; the energy is the power integrated
over that time.

The power model of that aircraft file was fitted on 187 flights that include the 38 R1
held-out flights (not the 9 random ones): both predictions share it, so the difference
between the two rows is the navigation model's; the absolute errors of the R1 flights are
not fully held out.

Run: ``python benchmarks/bench_navigation.py`` (about 20 s on 2 shared cores).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from planner.chain.mission_chain import MissionChain  # noqa: E402
from planner.identify.navigation_fit import fit_navigation  # noqa: E402
from planner.io.flightdata import load_flight_data  # noqa: E402
from planner.parameters import load_aircraft_and_battery  # noqa: E402
from planner.physics.mission import Environment, Leg, Mission  # noqa: E402

DATA = REPO.parent / "shared" / "data" / "energy"
FILES = ("m100_flights_part1_flights001-149.csv.gz", "m100_flights_part2_flights150-279.csv.gz")
AIRCRAFT = REPO / "aircraft" / "dji_m100_rotor_losses.yaml"
RANDOM_FLIGHTS = (268, 269, 270, 271, 272, 276, 277, 278, 279)
SITE_ALTITUDE_M = 300.0
MOTORS_ON_W = 100.0
#: Ground speed below which the vehicle stopped at a turning point; shortest leg kept. [m/s], [m]
STOP_SPEED_MS, MIN_LEG_M = 1.0, 5.0
#: Metres per degree of latitude and of longitude at the equator (WGS-84 mean).
M_PER_DEG_LAT, M_PER_DEG_LON = 110540.0, 111320.0


def held_out(par: pd.DataFrame, flights) -> list[int]:
    """The 47 held-out flights present in the data."""
    ids = [f for f in RANDOM_FLIGHTS] + [f for f in par.index
                                         if par.route[f] == "R1" and f % 5 == 0]
    have = set(flights)
    return [f for f in dict.fromkeys(ids) if f in have]


def positions(flights) -> pd.DataFrame:
    """East and north of home [m] per sample of the held-out flights (upstream GNSS)."""
    raw = pd.concat([pd.read_csv(DATA / f, usecols=["flight", "time", "position_x",
                                                    "position_y"]) for f in FILES])
    raw = raw[raw.flight.isin(flights)].copy()
    first = raw.groupby("flight")[["position_x", "position_y"]].transform("first")
    raw["east_m"] = ((raw.position_x - first.position_x) * M_PER_DEG_LON
                     * np.cos(np.radians(first.position_y)))
    raw["north_m"] = (raw.position_y - first.position_y) * M_PER_DEG_LAT
    return raw


def plan(f: int, rec: pd.DataFrame, pos: pd.DataFrame, par: pd.DataFrame) -> Mission:
    """The flight's plan from what was known before it flew (see the module)."""
    alt_cmd = float(str(par.altitude[f]).split("-")[0])
    v = float(par.speed[f])
    alt, gs = rec.altitude_m.to_numpy(), rec.groundspeed_ms.to_numpy()
    e, n = pos.east_m.to_numpy(), pos.north_m.to_numpy()
    m = min(len(alt), len(e))
    alt, gs, e, n = alt[:m], gs[:m], e[:m], n[:m]
    airborne = alt > 0.5 * alt_cmd
    moving = gs > STOP_SPEED_MS
    idx = np.flatnonzero(airborne & moving)
    stop = ~moving & airborne
    stop[: idx[0]] = False
    stop[idx[-1] + 1:] = False
    d = np.diff(np.concatenate(([0], stop.astype(np.int8), [0])))
    a, b = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    mid = (a + b) // 2
    points = list(zip(e[mid], n[mid])) + [(0.0, 0.0)]
    legs = [Leg("climb", (0.0, 0.0), (0.0, 0.0), 0.0, alt_cmd)]
    prev = (0.0, 0.0)
    for p in points:
        if np.hypot(p[0] - prev[0], p[1] - prev[1]) > MIN_LEG_M:
            legs.append(Leg("cruise", prev, p, alt_cmd, alt_cmd, speed_ms=v))
            prev = p
    legs.append(Leg("descend", (0.0, 0.0), (0.0, 0.0), alt_cmd, 0.0))
    return Mission(f"m100-{f}", legs, Environment(site_altitude_m=SITE_ALTITUDE_M),
                   payload_kg=float(par.payload[f]) / 1000.0)


def measured(rec: pd.DataFrame) -> tuple[float, float]:
    """Flight time [s] and energy [Wh] while the motors turn."""
    t, p = rec.time_s.to_numpy(), rec.power_w.to_numpy()
    on = np.flatnonzero(p > MOTORS_ON_W)
    s = slice(on[0], on[-1] + 1)
    return float(t[on[-1]] - t[on[0]]), float(np.trapezoid(p[s], t[s]) / 3600.0)


def summary(err: np.ndarray) -> str:
    a = np.abs(err)
    return (f"bias {np.mean(err):+6.1f} %  median |err| {np.median(a):5.1f} %  "
            f"P90 |err| {np.quantile(a, 0.9):5.1f} %")


def main(argv=None) -> int:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args(argv)
    warnings.simplefilter("ignore")
    t0 = time.time()
    par = pd.read_csv(DATA / "m100_parameters.csv").set_index("flight")
    data, _ = load_flight_data([DATA / f for f in FILES], column_map="dji_m100")
    flights = sorted({int(x) for x in data.experiment.unique()})
    test = held_out(par, flights)
    train = data[~data.experiment.astype(int).isin(test)]
    nav = fit_navigation(train, f"{train.experiment.nunique()} DJI M100 flights "
                         "(Rodrigues et al. 2021) not held out")
    print(f"{len(test)} held-out flights; navigation fitted on "
          f"{train.experiment.nunique()} other flights:")
    for k, v in dataclasses.asdict(nav).items():
        if k != "source":
            print(f"  {k:<24} {v:.3g}" if not isinstance(v, bool) else f"  {k:<24} {v}")
    air, pack = load_aircraft_and_battery(AIRCRAFT)
    chains = {"constant speed": MissionChain(air, pack),
              "navigation model": MissionChain(dataclasses.replace(air, navigation=nav),
                                               pack)}
    pos = positions(test)
    rows = []
    for f in test:
        rec = data[data.experiment.astype(int) == f]
        mission = plan(f, rec, pos[pos.flight == f], par)
        t_meas, e_meas = measured(rec)
        row = {"flight": f, "time_s": t_meas, "energy_wh": e_meas}
        for name, chain in chains.items():
            r = chain.check(mission, mission.environment)
            row[f"{name} time_s"], row[f"{name} energy_wh"] = r.duration_s, r.energy_wh
        rows.append(row)
    out = pd.DataFrame(rows)
    print(f"\nPredicted against measured, {len(out)} held-out flights "
          f"(mean measured {out.time_s.mean():.0f} s, {out.energy_wh.mean():.1f} Wh):")
    for name in chains:
        et = 100.0 * (out[f"{name} time_s"] / out.time_s - 1.0)
        ee = 100.0 * (out[f"{name} energy_wh"] / out.energy_wh - 1.0)
        print(f"  {name:<17} time   {summary(et.to_numpy())}")
        print(f"  {'':<17} energy {summary(ee.to_numpy())}")
    print(f"\n({time.time() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
