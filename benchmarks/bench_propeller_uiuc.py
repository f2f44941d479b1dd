"""The fixed-wing propulsive-efficiency curve against real propellers (UIUC database).

Data: the UIUC Propeller Database subset in ``../shared/data/props/uiuc`` (J. B. Brandt,
R. W. Deters, G. K. Ananda, O. D. Dantsker and M. S. Selig, UIUC Propeller Database,
Vols 1–4, https://m-selig.ae.illinois.edu/props/propDB.html): every wind-tunnel sweep of
J, C_T, C_P, η at about one rotational speed.

Each sweep is fitted (:mod:`testkit.uiuc`) with

* the planner's propeller model, momentum theory with profile loss,
  C_P = C_T J + κ C_T λ_i + C_P0 (:mod:`planner.physics.power.propeller`), and
* a constant propulsive efficiency (the polar model without a propeller),

and scored by the RMS error of the efficiency over its rows with positive thrust.
Prints the distribution over the sweeps, per family and overall.

Run: ``python benchmarks/bench_propeller_uiuc.py``
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from testkit.uiuc import UIUC, fit_sweep, sweeps  # noqa: E402


def main() -> int:
    all_sweeps = sweeps()
    if not all_sweeps:
        print(f"no UIUC sweeps under {UIUC}")
        return 1
    fits = [(s.family, f) for s in all_sweeps if (f := fit_sweep(s)) is not None]
    print(f"{len(fits)} sweeps with at least 3 rows of positive thrust "
          f"(of {len(all_sweeps)}), {sum(f.rows for _, f in fits)} rows")
    print(f"{'family':<8} {'sweeps':>6}  {'η RMSE momentum+profile':>24}  "
          f"{'η RMSE constant η':>18}  {'better':>6}  {'κ median':>8}  {'κ at 1':>6}  "
          f"{'C_P0 median':>11}")
    groups = sorted({fam for fam, _ in fits}) + ["all"]
    for fam in groups:
        sel = [f for g, f in fits if fam in ("all", g)]
        m = np.array([f.eta_rmse for f in sel])
        c = np.array([f.eta_rmse_constant for f in sel])
        k = np.array([f.induced_factor for f in sel])
        p0 = np.array([f.profile_cp for f in sel])
        print(f"{fam:<8} {len(sel):>6}  {np.median(m):>9.4f} (P90 {np.percentile(m, 90):.4f})"
              f"  {np.median(c):>8.4f} (P90 {np.percentile(c, 90):.3f})  "
              f"{100 * np.mean(m < c):>5.0f}%  {np.median(k):>8.2f}  "
              f"{100 * np.mean(k <= 1.0 + 1e-6):>5.0f}%  {np.median(p0):>11.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
