"""Benchmark: the pre-flight prediction scored on real flights, ``endurance backtest`` on
the DJI Matrice 100 delivery flights (Rodrigues et al., "Data Collected with Package
Delivery Quadcopter Drone", Carnegie Mellon University, doi:10.1184/R1/12683453, CC BY 4.0;
Scientific Data 8, 155, 2021), read through the shipped column map ``dji_m100`` that joins
each flight's payload, commanded speed and altitude from the data set's own
``m100_parameters.csv``.

Each flight predicted from before take-off (plan rebuilt from its track at the
commanded speed and altitude, forecast from the anemometer at rest before take-off, the
take-off mass with the flight's own payload) by ``aircraft/dji_m100_rotor_losses.yaml``
re-calibrated on other flights only:

* **held out** — 47 flights: the 9 "random flights" of Choudhry et al.
  (ICRA 2021: 268–272, 276–279) and every R1 flight whose number is divisible by 5,
  calibrated once on all the other flights (the ``--held-out`` list), flown three times:
  every leg at constant speed (``--kinematics none``); with the navigation fitted on the
  training flights (``--kinematics fitted``, the default: take-off, acceleration and stop
  at each waypoint, two-rate landing) but without the rotor disks' tilt the training
  flights show (``BacktestOptions(tilt=False)``, the model before it read one); and with
  both (the default); and the default once more with the pack's literature start
  values (``BacktestOptions(battery="file")`` on the TB47D without its ``model:``), the
  charge as it was drawn before the pack's integral model was fitted per fold on the
  training flights' charge (:func:`planner.identify.backtest.calibrate_pack`);
* **5-fold** — every recording of the data set (209: 196 cruise flights, 4 hovers and 9
  ground tests, the last 13 left out with their reasons), 5 folds by flight on a local
  Dask cluster of ``--workers`` process workers (the way ``endurance backtest --workers``
  runs).

Printed: flights scored and left out, the energy, charge and flight-time error (bias,
median and P90 |error| in % of the measured), the error of the level cruise's power at
constant speed, the energy's and the cruise power's bias by commanded speed, the wall time and the CPU time (this process
and its workers: what the run costs whatever else the machine runs). Target: 200 flights
with 5-fold calibration in under 2 minutes on 2 cores.

Run: ``python benchmarks/bench_backtest.py [--workers 2] [--only held-out|5-fold]``
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
ENERGY = REPO.parent / "shared" / "data" / "energy"

import pandas as pd

from planner.identify.backtest import BacktestOptions, run_backtest, summarise
from planner.io.flightdata import load_flight_data
from planner.parameters import load_aircraft_and_battery

#: The data set's site: Pittsburgh PA, about 300 m above sea level (GNSS altitude of the
#: take-off points 270–300 m, PROVENANCE.md). [m]
SITE_ALTITUDE_M = 300.0
FILES = ("m100_flights_part1_flights001-149.csv.gz", "m100_flights_part2_flights150-279.csv.gz")


def held_out_flights() -> list[str]:
    """The 47 held-out flights: Choudhry et al.'s random flights and every R1 flight
    whose number is divisible by 5."""
    par = pd.read_csv(ENERGY / "m100_parameters.csv")
    r1 = par.loc[(par.route == "R1") & (par.flight % 5 == 0), "flight"].tolist()
    return [str(f) for f in [268, 269, 270, 271, 272, 276, 277, 278, 279] + r1]


def cpu_s() -> float:
    me, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF,
                                                  resource.RUSAGE_CHILDREN))
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def show(name: str, table: pd.DataFrame, wall: float, cpu: float) -> None:
    s = summarise(table)
    print(f"\n{name}: {s['flights']} flights, {s['scored']} scored, {s['left_out']} left out "
          f"({'; '.join(f'{n} {why}' for why, n in s['left_out_reasons'].items()) or '-'})")
    for what in ("energy", "charge", "time", "cruise_power"):
        e = s[what]
        if not e.get("n"):
            continue
        print(f"  {what.replace('_', ' '):<12} bias {e['bias_pct']:+6.1f} %  median |error| "
              f"{e['median_abs_pct']:5.1f} %  P90 {e['p90_abs_pct']:5.1f} %  "
              f"max {e['max_abs_pct']:5.1f} %  ({e['n']} flights)")
    for what, by in (("energy", s.get("energy_error_against", {}).get("speed_ms")),
                     ("cruise power", s.get("cruise_power_against_speed"))):
        if by:
            print(f"  {what} bias by speed: " + ", ".join(
                f"{k} m/s {g['bias_pct']:+.1f} %" for k, g in by.items()))
    print(f"  wall time {wall:.1f} s, CPU time {cpu:.1f} s (this process and its workers)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--only", choices=("held-out", "5-fold"))
    args = ap.parse_args(argv)
    if not ENERGY.is_dir():
        print(f"no data: {ENERGY} is absent")
        return 0
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/dji_m100_rotor_losses.yaml")
    t0, c0 = time.perf_counter(), cpu_s()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data, _ = load_flight_data([ENERGY / f for f in FILES], column_map="dji_m100")
    read_wall, read_cpu = time.perf_counter() - t0, cpu_s() - c0
    print(f"read {data['experiment'].nunique()} recordings, {len(data)} samples in "
          f"{read_wall:.1f} s (CPU {read_cpu:.1f} s)")
    if args.only in (None, "held-out"):
        for kin, tilt in (("none", True), ("fitted", False), ("fitted", True)):
            t0, c0 = time.perf_counter(), cpu_s()
            table = run_backtest(data, aircraft, pack, BacktestOptions(
                held_out=tuple(held_out_flights()), site_altitude_m=SITE_ALTITUDE_M,
                kinematics=kin, tilt=tilt))
            show(f"held out (47 flights, calibrated on the other flights), kinematics {kin}, "
                 f"{'with' if tilt else 'without'} the tilt read on the training flights",
                 table, time.perf_counter() - t0 + read_wall, cpu_s() - c0 + read_cpu)
        t0, c0 = time.perf_counter(), cpu_s()
        table = run_backtest(data, aircraft, replace(pack, model=None), BacktestOptions(
            held_out=tuple(held_out_flights()), site_altitude_m=SITE_ALTITUDE_M,
            battery="file"))
        show("held out (47 flights), the default but the pack's literature integral model "
             "(not fitted on the flights' charge)", table,
             time.perf_counter() - t0 + read_wall, cpu_s() - c0 + read_cpu)
    if args.only in (None, "5-fold"):
        from dask.distributed import Client, LocalCluster
        t0, c0 = time.perf_counter(), cpu_s()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1,
                                   processes=True, dashboard_address=None)
            client = Client(cluster)
            try:
                table = run_backtest(data, aircraft, pack, BacktestOptions(
                    folds=5, site_altitude_m=SITE_ALTITUDE_M), client=client)
            finally:
                client.close()
                cluster.close()
        show(f"5-fold by flight, every recording, {args.workers} Dask workers, kinematics "
             "fitted", table,
             time.perf_counter() - t0 + read_wall, cpu_s() - c0 + read_cpu)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
