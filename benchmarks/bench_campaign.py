"""Benchmark: the seed paper's campaign on the virtual bench, and how robust its findings are.

Times the campaign (11 discharges at 1 Hz, about 59 000 samples) and the six
fits of the cross-validation (m_const, m_2step, m_APRBS; β held and free),
then repeats the campaign over seeds 0–9 (measurement noise and APRBS
schedules) and prints, per seed and β mode: the model with the lowest
held-out RMSE, the largest held-out |final normalised error| of m_const and
of all models, and the mean held-out RMSE per model. The last block repeats
the sweep with the bench's diffusion state switched off (plain equivalent
circuit: the only rate effect is the IR drop).

Run: ``python benchmarks/bench_campaign.py``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from planner.identify import bench, campaign


def sweep(pack: bench.BenchPack, seeds) -> None:
    print(f"{'seed':>4} {'β':<5} {'best':<8} {'m_const max|R|':>15} {'all max|R|':>11}  "
          "mean held-out RMSE [mAh] m_const / m_2step / m_APRBS")
    for seed in seeds:
        report = campaign.cross_validate(campaign.run_campaign(pack, seed=seed))
        for mode in ("held", "free"):
            t = report.table[(report.table.beta_mode == mode)
                             & (report.table.split == "validate")]
            worst_const = t[t.model == "m_const"].final_error_pct.abs().max()
            s = report.summary(mode)
            s = s[s.kind == "all"].set_index("model").mean_rmse_mah
            print(f"{seed:>4} {mode:<5} {report.best_model(mode):<8} {worst_const:>13.3f} % "
                  f"{t.final_error_pct.abs().max():>9.3f} %  "
                  f"{s['m_const']:.1f} / {s['m_2step']:.1f} / {s['m_APRBS']:.1f}")
        for w in report.warnings:
            print(f"     warning: {w}")


def main() -> int:
    pack = bench.seed_pack()
    t0 = time.perf_counter()
    records = campaign.run_campaign(pack, seed=0)
    t1 = time.perf_counter()
    campaign.cross_validate(records)
    t2 = time.perf_counter()
    print(f"campaign: {records.experiment.nunique()} discharges, {len(records)} samples in "
          f"{t1 - t0:.2f} s; six fits and the cross-validation in {t2 - t1:.2f} s")
    print()
    print("bench as shipped (equivalent circuit + diffusion state)")
    sweep(pack, range(10))
    print()
    print("diffusion off (available_fraction = 1: IR drop only)")
    sweep(pack.with_changes(available_fraction=1.0), range(3))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
