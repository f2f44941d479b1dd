"""Benchmark: 10 000 packs × one 200-leg mission, vectorised over packs.

Targets (issues "Battery pack selection and mission sizing" and "One mission chain"):
the whole catalog evaluated — mass loop closed, power, integral-model charge, landing
and return-home reserves, C rating, take-off mass — in under 1 s with the integral
model, and in under 3 s when every pack carries circuit and thermal blocks (the
equivalent circuit and lumped thermal model run along the mission and on to the
cut-off, vectorised over packs). The alternative it is compared with is a loop of
:meth:`planner.chain.mission_chain.MissionChain.check` over the same packs, timed on a few hundred
packs and extrapolated to 10 000.

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

from planner.chain.mission_chain import MissionChain
from planner.physics.mission import Environment, Leg, Mission
from planner.parameters import BatteryPack, load_aircraft
from planner.chain.selection import evaluate_packs

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


def with_circuit(packs: list[BatteryPack], seed: int = 2) -> list[BatteryPack]:
    """The same packs, each with an RC branch and a lumped thermal model of its own."""
    from dataclasses import replace

    from planner.parameters.blocks import CircuitBlock
    from planner.physics.battery.thermal import ThermalParameters

    rng = np.random.default_rng(seed)
    out = []
    for p in packs:
        circuit = CircuitBlock(r1_ohm=float(rng.uniform(0.001, 0.004)),
                               c1_f=float(rng.uniform(5000, 20000)))
        thermal = ThermalParameters(float(rng.uniform(1.0, 4.0)), float(p.mass_kg * 1000.0))
        out.append(replace(p, circuit=circuit, thermal=thermal))
    return out


def catalog(k: int, seed: int = 1) -> list[BatteryPack]:
    """Random LiPo packs: 3–6S, 1.5–22 Ah, 120–200 Wh/kg, 3–30 C, 40 % with a fit."""
    rng = np.random.default_rng(seed)
    packs = []
    for i in range(k):
        cells = int(rng.integers(3, 7))
        cap = float(rng.uniform(1500, 22000))
        model = None
        if rng.random() < 0.4:
            from planner.parameters import IntegralModel
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
        print(f"  loop of MissionChain.check  {t_loop * 1e3:8.0f} ms  (timed on {N_LOOP} packs, "
              f"extrapolated to {N_PACKS})  -> {t_loop / t_vec:.0f}x faster vectorised")
        print(f"  {int(ev.feasible.sum())} feasible packs")
    ac = load_aircraft(REPO / "aircraft" / "solo_survey.yaml")
    circ = with_circuit(packs)
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        ev = evaluate_packs(mission, ac, circ)
        times.append(time.perf_counter() - t0)
    t_vec = statistics.median(times)
    t0 = time.perf_counter()
    for p in circ[:N_LOOP // 3]:
        MissionChain(ac, p).check(mission)
    t_loop = (time.perf_counter() - t0) / (N_LOOP // 3) * N_PACKS
    print(f"{ac.name}, every pack with circuit + thermal blocks:")
    print(f"  vectorised evaluate_packs   {t_vec * 1e3:8.0f} ms  (median of 3)  target "
          f"< 3000 ms: {'PASS' if t_vec < 3.0 else 'FAIL'}")
    print(f"  loop of MissionChain.check  {t_loop * 1e3:8.0f} ms  (timed on {N_LOOP // 3} "
          f"packs, extrapolated to {N_PACKS})  -> {t_loop / t_vec:.0f}x faster vectorised")
    print(f"  {int(ev.feasible.sum())} feasible packs, "
          f"{int(np.sum(ev.usable_mah * 3.6 < [p.usable_as for p in circ]))} limited by "
          "the cut-off")


if __name__ == "__main__":
    main()
