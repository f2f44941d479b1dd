"""Benchmark: pre-flight check of a 500-waypoint mission.

Target (issue "Pre-flight endurance check"): under 50 ms of compute after
import, with nothing in the leg → profile → battery path looping per sample.
The alternative it is compared with is what a user would write by hand: step
the same power profile through the integral model at 1 s in a Python loop.

Run: ``python benchmarks/bench_check.py``
"""

from __future__ import annotations

import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path


REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from planner.chain.mission_chain import MissionChain
from planner.io.mission import load_mission
from testkit.missions import write_waypoints
from planner.parameters import load_aircraft_and_battery


def naive_loop(result, pack, dt=0.1) -> float:
    """The time-stepped Python loop a user would otherwise write (0.1 s steps)."""
    m = pack.model
    stress = 0.0
    for p, dur in zip(result.legs.power_w.tolist(), result.legs.duration_s.tolist()):
        t = 0.0
        while t < dur:
            h = min(dt, dur - t)
            stress += h / (m.delta * p**m.epsilon)
            t += h
    return stress ** (1 / m.beta) / 3.6


def main() -> None:
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    integral_only = MissionChain(aircraft, replace(pack, circuit=None, thermal=None))
    with_circuit = MissionChain(aircraft, pack)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "survey500.waypoints"
        write_waypoints(path)
        load_times, run_times, circuit_times = [], [], []
        for _ in range(15):
            t0 = time.perf_counter()
            mission = load_mission(path, vehicle_type="multirotor")
            t1 = time.perf_counter()
            result = integral_only.check(mission)
            t2 = time.perf_counter()
            with_circuit.check(mission)
            t3 = time.perf_counter()
            load_times.append(t1 - t0)
            run_times.append(t2 - t1)
            circuit_times.append(t3 - t2)
    t0 = time.perf_counter()
    naive = naive_loop(result, pack)
    t_naive = time.perf_counter() - t0
    lo, ru = statistics.median(load_times) * 1e3, statistics.median(run_times) * 1e3
    ci = statistics.median(circuit_times) * 1e3
    print(f"mission: {len(mission.legs)} legs from 500 waypoints, "
          f"{result.duration_s / 60:.1f} min flight, verdict {result.verdict}")
    print(f"load .waypoints      {lo:7.2f} ms (median of 15)")
    print(f"check, integral model (profile+battery+RTL) {ru:7.2f} ms (median of 15)")
    print(f"total                {lo + ru:7.2f} ms   target < 50 ms: "
          f"{'PASS' if lo + ru < 50 else 'FAIL'}")
    print(f"check with the pack's circuit + thermal blocks (1 s steps through the mission "
          f"and on to the cut-off) {ci:7.2f} ms")
    print(f"naive 0.1-s Python loop over the same power profile (battery only): "
          f"{t_naive * 1e3:7.2f} ms, charge {naive:.0f} mAh vs {result.charge_used_mah:.0f} mAh")


if __name__ == "__main__":
    main()
