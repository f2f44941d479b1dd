"""Benchmark: start-up of ``endurance check`` on the shipped survey.

Target (issue "A house whose folders are its layers"): the CPU time of

    python -m planner check missions/survey_route.yaml --aircraft aircraft/solo_survey.yaml

at most 1.2 times that of ``python -c "import numpy, yaml, numba, scipy.optimize"`` (the
libraries the command cannot do without): a command imports only what it uses (pandas,
scipy.signal, scipy.stats, scipy.integrate, Dask and matplotlib are imported where used).

Both are timed in the same run, alternately, as child processes: CPU time (user + system)
of each child from ``os.wait4``, the median of the repetitions. One unmeasured run of each
first (numba's cache of compiled kernels filled, files in the page cache).

Run: ``python benchmarks/bench_startup.py [--repeat 7]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHECK = [sys.executable, "-m", "planner", "check", "missions/survey_route.yaml",
         "--aircraft", "aircraft/solo_survey.yaml"]
BASELINE = [sys.executable, "-c", "import numpy, yaml, numba, scipy.optimize"]


def cpu_seconds(argv: list[str]) -> float:
    """CPU time (user + system) of one run of ``argv`` in the repository root. [s]"""
    proc = subprocess.Popen(argv, cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited {proc.returncode}")
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=7, help="measured runs of each")
    args = ap.parse_args()
    cpu_seconds(CHECK)
    cpu_seconds(BASELINE)
    check, base = [], []
    for _ in range(args.repeat):
        check.append(cpu_seconds(CHECK))
        base.append(cpu_seconds(BASELINE))
    c, b = statistics.median(check), statistics.median(base)
    print(f"endurance check (survey_route.yaml, solo_survey.yaml): {c:.3f} s CPU "
          f"(median of {args.repeat}; min {min(check):.3f} s)")
    print(f"import numpy, yaml, numba, scipy.optimize:           {b:.3f} s CPU "
          f"(median of {args.repeat}; min {min(base):.3f} s)")
    print(f"ratio: {c / b:.2f} (target <= 1.2)")


if __name__ == "__main__":
    main()
