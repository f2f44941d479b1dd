"""Benchmark: a one-hour mission at 1 s steps through the coupled circuit + thermal model.

Target (issue): well under 500 ms. Run ``python benchmarks/bench_circuit.py``;
prints the best of several runs in milliseconds.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from planner.physics.battery.circuit import CircuitParameters, simulate
from planner.physics.battery.thermal import ThermalParameters

TARGET_MS = 500.0


def mission_power(time_s: np.ndarray) -> np.ndarray:
    """Electric power of a one-hour multirotor mission: take-off peak, cruise legs, loiter."""
    rng = np.random.default_rng(0)
    p = np.where(time_s < 30.0, 1200.0, 420.0)                       # take-off and climb
    p = p + np.where((time_s // 600) % 2 == 1, 80.0, 0.0)             # faster legs
    p = p + rng.normal(0.0, 20.0, time_s.size)                        # gusts
    return np.where(time_s > 3300.0, 350.0, p)                        # descent


def main(repeats: int = 7) -> float:
    params = CircuitParameters(
        capacity_ah=11.0, r0_ohm=([0.0, 0.2, 1.0], [0.009, 0.0055, 0.005]),
        r1_ohm=0.0025, c1_f=12_000.0, hysteresis_v=0.01, hysteresis_gamma=30.0,
        cells_series=6, cells_parallel=3)
    thermal = ThermalParameters(r_th_k_per_w=1.2, c_th_j_per_k=1800.0, t_air_c=15.0)
    t = np.arange(0.0, 3600.0, 1.0)
    power = mission_power(t)
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        res = simulate(params, t, power_w=power, temperature_c=thermal, v_cutoff_cell=3.3)
        best = min(best, time.perf_counter() - start)
    ms = best * 1e3
    print(f"circuit + thermal, one-hour mission at 1 s steps ({t.size} steps): "
          f"{ms:.1f} ms (best of {repeats}; target < {TARGET_MS:.0f} ms) - "
          f"final SoC {res.soc[-1]:.3f}, peak temperature {res.temperature_c.max():.1f} °C")
    return ms


if __name__ == "__main__":
    sys.exit(0 if main() < TARGET_MS else 1)
