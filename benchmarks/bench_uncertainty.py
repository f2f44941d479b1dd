"""Benchmark: Monte Carlo of the 500-waypoint survey (``check --uncertainty``).

Targets (issue "Decisions an operator flies with"): 10 000 samples under 1 s with the
integral model and under 5 s with the circuit and thermal model, on the 2-core machine.
The samples ride on the chain's pack axis, one chain run per weather draw
(:mod:`planner.chain.uncertainty`): the weather is drawn once per 5 samples, at most 400
times (a 0.25 % resolution of the probability), so the run costs about 400 runs of the
chain; the targets were met with 16 weather draws, a probability in steps of 1/16. The alternative a user would write is a loop of the
pre-flight check, one sample at a time: timed on 50 samples and scaled to 10 000.

Run: ``python benchmarks/bench_uncertainty.py [--samples N]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from bench_check import write_waypoints  # noqa: E402

from planner.chain.mission_chain import MissionChain  # noqa: E402
from planner.io.mission import load_mission  # noqa: E402
from planner.parameters import load_aircraft_and_battery  # noqa: E402
from planner.chain.uncertainty import Spreads, monte_carlo  # noqa: E402

SPREADS = Spreads(wind_sd_ms=2.0, wind_direction_sd_deg=30.0, gust_factor=1.3,
                  temperature_sd_c=5.0, soh=0.97, soh_sd=0.03, payload_sd_kg=0.05)


def timed(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def naive(chain, mission, n, seed=0):
    """One deterministic check per sample, the loop a user would write."""
    rng = np.random.default_rng(seed)
    env = mission.environment
    out = []
    for _ in range(n):
        e = replace(env, wind_speed_ms=max(env.wind_speed_ms + 2.0 * rng.standard_normal(), 0),
                    wind_from_deg=(env.wind_from_deg + 30 * rng.standard_normal()) % 360)
        pack = replace(chain.pack, usable_fraction=min(
            chain.pack.usable_fraction * (0.97 + 0.03 * rng.standard_normal()), 1.0))
        r = MissionChain(chain.aircraft, pack, reserve=chain.reserve).run(
            mission, e, payload_kg=0.05 * abs(rng.standard_normal()), detail=False)
        out.append(float(r.usable_mah[0] - r.charge_used_mah[0]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--samples", type=int, default=10_000)
    args = parser.parse_args()
    n = args.samples
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    integral_only = MissionChain(aircraft, replace(pack, circuit=None, thermal=None))
    with_circuit = MissionChain(aircraft, pack)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "survey500.waypoints"
        write_waypoints(path)
        mission = load_mission(path, vehicle_type="multirotor")
    load = os.getloadavg()[0]
    print(f"mission: {len(mission.legs)} legs from 500 waypoints; {n} samples; spreads: wind "
          f"±2 m/s ±30°, gust factor 1.3, ±5 °C, SoH 0.97±0.03, payload ±0.05 kg")
    print(f"machine: {os.cpu_count()} cores, load average {load:.1f} at the start")
    monte_carlo(integral_only, mission, spreads=SPREADS, samples=200, seed=0)  # compile
    t_int, u = timed(lambda: monte_carlo(integral_only, mission, spreads=SPREADS, samples=n,
                                         seed=0), 5)
    print(f"integral model:        {t_int:6.3f} s (median of 5)   target < 1 s: "
          f"{'PASS' if t_int < 1 else 'FAIL'}   ({u.weather_draws} weather draws; "
          f"P(landing with the reserve) {100 * u.p_landing:.1f} %, landing P5/P50/P95 "
          f"{u.landing_mah['p5']:.0f}/{u.landing_mah['p50']:.0f}/{u.landing_mah['p95']:.0f}"
          f" mAh, driver {u.driver})")
    t_cir, uc = timed(lambda: monte_carlo(with_circuit, mission, spreads=SPREADS, samples=n,
                                          seed=0), 3)
    print(f"circuit + thermal:     {t_cir:6.3f} s (median of 3)   target < 5 s: "
          f"{'PASS' if t_cir < 5 else 'FAIL'}   (P(landing with the reserve) "
          f"{100 * uc.p_landing:.1f} %)")
    k = 50
    t_loop, _ = timed(lambda: naive(integral_only, mission, k), 1)
    print(f"loop of one-sample checks, integral model: {t_loop:.3f} s for {k} samples → "
          f"{t_loop / k * n:.1f} s for {n} ({t_loop / k * n / t_int:.0f}× slower)")
    print(f"load average at the end {os.getloadavg()[0]:.1f} (figures above a load of 2 "
          "share the 2 cores with other work)")


if __name__ == "__main__":
    main()
