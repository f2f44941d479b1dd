"""Benchmark: 10 000 packs × one 200-leg mission, vectorised over packs.

Target (issue "Battery pack selection and mission sizing"): the whole catalog
evaluated — mass loop closed, power, integral-model charge, landing and return-home
reserves, C rating, take-off mass — in under 1 s. The alternative it is compared
with is a loop of :meth:`planner.check.MissionChain.run` over the same packs, timed
on a few hundred packs and extrapolated to 10 000.

Run: ``python benchmarks/bench_select.py``
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from planner.check import MissionChain
from planner.definitions import BatteryPack, load_aircraft
from planner.mission.legs import Environment, Leg, Mission
from planner.select import evaluate_packs

N_PACKS = 10_000
N_LOOP = 300
REPEATS = 7


def survey(n_legs: int = 200, alt: float = 50.0) -> Mission:
    """A lawnmower survey of exactly ``n_legs`` legs, in a 5 m/s wind."""
    legs = [Leg("climb", end_alt_m=alt, origin="climb")]
    x, y = 0.0, 0.0
    for i in range(n_legs - 3):
        row = i // 2
        if i % 2 == 0:
            nx, ny = (150.0 if row % 2 == 0 else 50.0), 100.0 + 10.0 * row
        else:
            nx, ny = x, y + 10.0
        legs.append(Leg("cruise", (x, y), (nx, ny), alt, alt, origin=f"wp {i + 1}"))
        x, y = nx, ny
    legs.append(Leg("cruise", (x, y), (0.0, 0.0), alt, alt, origin="home"))
    legs.append(Leg("descend", start_alt_m=alt, end_alt_m=0.0, origin="land"))
    return Mission("200-leg survey", legs, Environment(5.0, 250.0, 15.0), payload_kg=0.3)


def catalog(k: int, seed: int = 1) -> list[BatteryPack]:
    """Random LiPo packs: 3–6S, 1.5–22 Ah, 120–200 Wh/kg, 3–30 C, 40 % with a fit."""
    rng = np.random.default_rng(seed)
    packs = []
    for i in range(k):
        cells = int(rng.integers(3, 7))
        cap = float(rng.uniform(1500, 22000))
        model = None
        if rng.random() < 0.4:
            from planner.definitions import IntegralModel
            model = IntegralModel(float(rng.uniform(3.5, 5.0)) * cells,
                                  float(rng.uniform(-1.05, -0.99)), 0.9648)
        packs.append(BatteryPack(
            name=f"pack {i}", cells_series=cells, capacity_mah=cap,
            mass_kg=cap / 1000 * cells * 3.7 / float(rng.uniform(120, 200)),
            max_discharge_c=float(rng.uniform(3, 30)),
            internal_resistance_ohm=float(rng.uniform(0.004, 0.02)) * cells, model=model))
    return packs


def main() -> None:
    mission = survey()
    packs = catalog(N_PACKS)
    print(f"mission: {len(mission.legs)} legs, wind 5 m/s; catalog: {len(packs)} packs")
    for name in ("solo_survey", "dji_m100", "x8_mapper"):
        ac = load_aircraft(REPO / "aircraft" / f"{name}.yaml")
        times = []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            ev = evaluate_packs(mission, ac, packs)
            times.append(time.perf_counter() - t0)
        t_vec = statistics.median(times)
        t0 = time.perf_counter()
        for p in packs[:N_LOOP]:
            MissionChain(ac, p).check(mission)
        t_loop = (time.perf_counter() - t0) / N_LOOP * N_PACKS
        print(f"{ac.name} ({ac.type}, power via {ev.method}):")
        print(f"  vectorised evaluate_packs   {t_vec * 1e3:8.0f} ms  (median of {REPEATS}; "
              f"best {min(times) * 1e3:.0f} ms)  target < 1000 ms: "
              f"{'PASS' if t_vec < 1.0 else 'FAIL'}")
        print(f"  loop of MissionChain.run    {t_loop * 1e3:8.0f} ms  (timed on {N_LOOP} packs, "
              f"extrapolated to {N_PACKS})  -> {t_loop / t_vec:.0f}x faster vectorised")
        print(f"  {int(ev.feasible.sum())} feasible packs")


if __name__ == "__main__":
    main()
