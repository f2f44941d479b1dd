"""Benchmark: start-up of ``endurance check`` on the shipped survey.

Target (issue "A house whose folders are its layers"): the CPU time of

    python -m planner check missions/survey_route.yaml --aircraft aircraft/solo_survey.yaml

at most 1.2 times that of ``python -c "import numpy, yaml, numba, scipy.optimize"`` (the
libraries the command cannot do without): a command imports only what it uses (pandas,
scipy.signal, scipy.stats, scipy.integrate, Dask and matplotlib are imported where used).

A third command measures what the check avoids: the same imports, then one call of a
trivial compiled kernel loaded from numba's on-disk cache. Numba initialises its
compiler's type and lowering registries on the first call of any compiled function in a
process, cached or not; the check of the shipped survey runs its loops (the circuit model
of the Solo's pack, the rotor inflow, the per-leg integral model) interpreted within the
budget of :mod:`planner.physics.kernel`, so it does not pay it.

All three are timed in the same run, alternately, as child processes: CPU time (user +
system) of each child from ``os.wait4``, the median of the repetitions. One unmeasured run
of each first (numba's cache of compiled kernels filled, the bytecode of the planner
written as an installed package has it, files in the page cache); the children run with
``PYTHONDONTWRITEBYTECODE`` unset for that reason.

Run: ``python benchmarks/bench_startup.py [--repeat 7]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

CHECK = [sys.executable, "-m", "planner", "check", "missions/survey_route.yaml",
         "--aircraft", "aircraft/solo_survey.yaml"]
BASELINE = [sys.executable, "-c", "import numpy, yaml, numba, scipy.optimize"]
#: A module with one trivial kernel in numba's on-disk cache.
KERNEL_MODULE = ("import numba\n\n\n@numba.njit(cache=True)\ndef one(x):\n"
                 "    return x + 1.0\n")
KERNEL = [sys.executable, "-c",
          "import numpy, yaml, numba, scipy.optimize; import startup_kernel; "
          "startup_kernel.one(1.0)"]


def cpu_seconds(argv: list[str], env: dict | None = None) -> float:
    """CPU time (user + system) of one run of ``argv`` in the repository root. [s]"""
    proc = subprocess.Popen(argv, cwd=REPO, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=env)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} exited {proc.returncode}")
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=7, help="measured runs of each")
    args = ap.parse_args()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    with tempfile.TemporaryDirectory() as tmp:
        Path(tmp, "startup_kernel.py").write_text(KERNEL_MODULE)
        kernel_env = dict(env, PYTHONPATH=tmp)
        runs = {"check": (CHECK, env), "base": (BASELINE, env), "kernel": (KERNEL, kernel_env)}
        for argv, e in runs.values():
            cpu_seconds(argv, e)
        times: dict[str, list[float]] = {name: [] for name in runs}
        for _ in range(args.repeat):
            for name, (argv, e) in runs.items():
                times[name].append(cpu_seconds(argv, e))
    c, b, k = (statistics.median(times[n]) for n in ("check", "base", "kernel"))

    def line(label: str, name: str, value: float) -> str:
        return (f"{label:<56} {value:.3f} s CPU (median of {args.repeat}; "
                f"min {min(times[name]):.3f} s)")

    print(line("endurance check (survey_route.yaml, solo_survey.yaml):", "check", c))
    print(line("import numpy, yaml, numba, scipy.optimize:", "base", b))
    print(line("the same + first call of one cached numba kernel:", "kernel", k))
    print(f"ratio check / imports: {c / b:.2f} (target <= 1.2)")
    print(f"numba's first-call initialisation (the check runs its loops interpreted "
          f"instead): {k - b:.3f} s CPU")


if __name__ == "__main__":
    main()
