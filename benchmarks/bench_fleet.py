"""Benchmark: ``endurance fleet`` throughput, a plain serial loop vs Dask with 1 and 2 workers.

The fleet: the shipped example logs (``logs/``) and the real logs of ``../shared/data/logs``
copied into a temporary folder under different names until there are ``--logs`` of them
(default 160). Every copy is read, replayed and calibrated
(:func:`planner.fleet.summary.summarise_log`) — the content hash that skips a log on a
*rerun* is of the previous table, which the benchmark does not have.

* **serial** — the loop a user would write without Dask: ``summarise_log`` on each log in
  this process, one after the other;
* **Dask, N workers** — :func:`planner.fleet.summarise_all` on a ``LocalCluster`` of N
  process workers with one thread each, the way ``endurance fleet --workers N`` runs.
  The cluster's start is timed apart (it is paid once per command); the logs' time
  includes each worker's first imports.

Figures: wall time, logs per second, CPU time per log (the workers' own
``time.process_time``: what a log costs whatever else the machine runs), logs per second
per worker, the speed-up of two workers over one, and each worker's peak resident memory
(``ru_maxrss``). On a machine whose cores are shared with other work the wall-clock
scaling is a lower bound; the CPU time per log is the figure to size a cluster with.

Run: ``python benchmarks/bench_fleet.py [--logs N] [--repeat R]``
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
SHARED = REPO.parent / "shared" / "data" / "logs"

from planner import files  # noqa: E402
from planner.fleet import LOG_SUFFIXES, batch_size, summarise_all  # noqa: E402
from planner.fleet.summary import summarise_log  # noqa: E402
from planner.parameters import load_aircraft_and_battery  # noqa: E402


def make_fleet(folder: Path, count: int) -> list[Path]:
    """Copies of the shipped and the real logs under new names, ``count`` in all."""
    sources = sorted(p for d in (REPO / "logs", SHARED) if d.is_dir() for p in d.iterdir()
                     if p.name.lower().endswith(LOG_SUFFIXES))
    if not sources:
        raise SystemExit("no logs found in logs/ or ../shared/data/logs")
    out = []
    for k in range(count):
        src = sources[k % len(sources)]
        dst = folder / f"flight_{k:05d}_{src.name}"
        shutil.copyfile(src, dst)
        out.append(dst)
    return out


def peak_rss_mb() -> float:
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def serial(logs, aircraft, pack) -> tuple[float, float]:
    """(wall time, CPU time) of the plain loop. [s]"""
    t, cpu = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rows = [summarise_log(str(p), aircraft=aircraft, pack=pack) for p in logs]
    dt, dcpu = time.perf_counter() - t, time.process_time() - cpu
    assert len(rows) == len(logs)
    return dt, dcpu


def on_dask(logs, aircraft, pack, workers: int, batch: int | None = None
            ) -> tuple[float, float, list[float], int, float]:
    from dask.distributed import Client, LocalCluster

    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    # each worker's first imports and compiled kernels, as the serial loop's warm-up
    summarise_all(logs[:2 * workers], aircraft=aircraft, pack=pack, pack_map=None, skip=set(),
                  client=client, batch=1)
    start = time.perf_counter() - t0
    try:
        cpu0 = sum(client.run(time.process_time).values())
        t = time.perf_counter()
        rows, _ = summarise_all(logs, aircraft=aircraft, pack=pack, pack_map=None, skip=set(),
                                client=client, batch=batch)
        dt = time.perf_counter() - t
        cpu = sum(client.run(time.process_time).values()) - cpu0
        rss = sorted(client.run(peak_rss_mb).values())
        failed = sum(r["status"] != "ok" for r in rows)
    finally:
        client.close()
        cluster.close()
    return start, dt, rss, failed, cpu


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=160)
    ap.add_argument("--repeat", type=int, default=2, help="best of R runs of each")
    args = ap.parse_args()
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    files.reset()
    with tempfile.TemporaryDirectory() as tmp:
        logs = make_fleet(Path(tmp), args.logs)
        size = sum(p.stat().st_size for p in logs) / 2**20
        print(f"fleet: {len(logs)} logs, {size:.1f} MB, machine: {os.cpu_count()} cores")
        serial(logs[:5], aircraft, pack)                  # imports and compiled kernels
        t_serial, cpu_serial = min(serial(logs, aircraft, pack) for _ in range(args.repeat))
        print(f"serial loop                      : {t_serial:6.2f} s  "
              f"{len(logs) / t_serial:6.1f} logs/s  CPU {1e3 * cpu_serial / len(logs):5.1f} ms "
              f"per log  (peak RSS {peak_rss_mb():.0f} MB)")
        best = {}
        for workers, batch in ((1, None), (2, None), (2, 1)):
            runs = [on_dask(logs, aircraft, pack, workers, batch) for _ in range(args.repeat)]
            start, dt, rss, failed, cpu = min(runs, key=lambda r: r[1])
            best[workers, batch] = dt
            what = (f"{batch_size(len(logs), workers)} logs per task" if batch is None
                    else "1 log per task")
            print(f"Dask {workers} worker{'s' if workers > 1 else ' '}, {what:<17}: "
                  f"{dt:6.2f} s  {len(logs) / dt:6.1f} logs/s  CPU {1e3 * cpu / len(logs):5.1f} "
                  f"ms per log  {len(logs) / dt / workers:6.1f} logs/s per worker  (cluster start and warm-up {start:.1f} s; peak RSS per worker "
                  f"{', '.join(f'{m:.0f}' for m in rss)} MB; {failed} failed logs)")
        b1, b2 = best[1, None], best[2, None]
        print(f"speed-up 2 workers / 1 worker: {b1 / b2:.2f}x; 2 workers / serial loop: "
              f"{t_serial / b2:.2f}x; batched / one log per task (2 workers): "
              f"{best[2, 1] / b2:.2f}x")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
