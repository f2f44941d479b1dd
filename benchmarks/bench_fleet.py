"""Benchmark: ``endurance fleet`` throughput, a plain serial loop vs Dask with 1 and 2 workers.

The fleet (``--source``):

* ``generated`` (default) — :func:`testkit.fleet.generate_fleet`: flights of three aircraft
  on twelve packs, ``.bin``, ``.tlog`` and ``.ulg`` in turn, with the ``--packs`` CSV
  (simulated by the planner's own models; a throughput figure, not a validation);
* ``copies`` — the shipped example logs (``logs/``) and the real logs of
  ``../shared/data/logs`` copied under different names (larger logs, some damaged).

``--logs`` of them (default 1000). Every log is read, replayed and calibrated, with its
calibration samples (:func:`planner.fleet.summary.summarise_log`) — the content hash that
skips a log on a *rerun* is of the previous table, which the benchmark does not have.

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

Target: two workers at least 1.7× one worker on a 2-core machine.

Run: ``python benchmarks/bench_fleet.py [--logs N] [--repeat R] [--source generated|copies]``
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

from planner.io import files  # noqa: E402
from planner.fleet import (  # noqa: E402
    LOG_SUFFIXES,
    batch_size,
    log_items,
    read_pack_map,
    summarise_all,
)
from planner.fleet.summary import summarise_log  # noqa: E402
from planner.parameters import load_aircraft_and_battery  # noqa: E402

TARGET = 1.7


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


def generated_fleet(folder: Path, count: int):
    """:func:`testkit.fleet.generate_fleet` with at least ``count`` logs: (logs, models,
    pack map)."""
    import math

    from testkit.fleet import PACKS, aircraft_files, generate_fleet

    g = generate_fleet(folder, flights_per_pack=math.ceil(count / len(PACKS)))
    models = {k: load_aircraft_and_battery(p) for k, p in aircraft_files().items()}
    logs = sorted(g.logs.iterdir())[:count]
    return logs, models, read_pack_map(g.packs_csv, {k: a for k, (a, _) in models.items()})


def peak_rss_mb() -> float:
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def serial(logs, models, pack_map) -> tuple[float, float]:
    """(wall time, CPU time) of the plain loop. [s]"""
    t, cpu = time.perf_counter(), time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rows = [summarise_log(path, pack_id, source, cycle, models=models,
                              aircraft_key=key, samples=True)
                for path, pack_id, source, cycle, key in log_items(logs, pack_map)]
    dt, dcpu = time.perf_counter() - t, time.process_time() - cpu
    assert len(rows) == len(logs)
    return dt, dcpu


def on_dask(logs, models, pack_map, workers: int, batch: int | None = None
            ) -> tuple[float, float, list[float], int, float]:
    from dask.distributed import Client, LocalCluster

    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    client = Client(cluster)
    # each worker's first imports and compiled kernels, as the serial loop's warm-up
    summarise_all(logs[:2 * workers], models=models, pack_map=pack_map, skip=set(),
                  client=client, batch=1, samples=True)
    start = time.perf_counter() - t0
    try:
        cpu0 = sum(client.run(time.process_time).values())
        t = time.perf_counter()
        rows, _ = summarise_all(logs, models=models, pack_map=pack_map, skip=set(),
                                client=client, batch=batch, samples=True)
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
    ap.add_argument("--logs", type=int, default=1000)
    ap.add_argument("--repeat", type=int, default=2, help="best of R runs of each")
    ap.add_argument("--source", choices=("generated", "copies"), default="generated")
    args = ap.parse_args()
    files.reset()
    with tempfile.TemporaryDirectory() as tmp:
        if args.source == "generated":
            t = time.perf_counter()
            logs, models, pack_map = generated_fleet(Path(tmp), args.logs)
            made = f"generated in {time.perf_counter() - t:.0f} s"
        else:
            aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
            models, pack_map = {"solo_survey": (aircraft, pack)}, {}
            logs, made = make_fleet(Path(tmp), args.logs), "copies of logs/ and shared/data"
        size = sum(p.stat().st_size for p in logs) / 2**20
        print(f"fleet ({args.source}, {made}): {len(logs)} logs, {size:.1f} MB, machine: "
              f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")
        serial(logs[:5], models, pack_map)                # imports and compiled kernels
        t_serial, cpu_serial = min(serial(logs, models, pack_map) for _ in range(args.repeat))
        print(f"serial loop                      : {t_serial:6.2f} s  "
              f"{len(logs) / t_serial:6.1f} logs/s  CPU {1e3 * cpu_serial / len(logs):5.1f} ms "
              f"per log  (peak RSS {peak_rss_mb():.0f} MB)")
        best = {}
        for workers, batch in ((1, None), (2, None), (2, 1)):
            runs = [on_dask(logs, models, pack_map, workers, batch) for _ in range(args.repeat)]
            start, dt, rss, failed, cpu = min(runs, key=lambda r: r[1])
            best[workers, batch] = dt
            what = (f"{batch_size(len(logs), workers)} logs per task" if batch is None
                    else "1 log per task")
            print(f"Dask {workers} worker{'s' if workers > 1 else ' '}, {what:<17}: "
                  f"{dt:6.2f} s  {len(logs) / dt:6.1f} logs/s  CPU {1e3 * cpu / len(logs):5.1f} "
                  f"ms per log  {len(logs) / dt / workers:6.1f} logs/s per worker  (cluster start and warm-up {start:.1f} s; peak RSS per worker "
                  f"{', '.join(f'{m:.0f}' for m in rss)} MB; {failed} failed logs)")
        b1, b2 = best[1, None], best[2, None]
        ok = b1 / b2 >= TARGET
        print(f"speed-up 2 workers / 1 worker: {b1 / b2:.2f}x (target ≥ {TARGET}x: "
              f"{'PASS' if ok else 'FAIL'}); 2 workers / serial loop: "
              f"{t_serial / b2:.2f}x; batched / one log per task (2 workers): "
              f"{best[2, 1] / b2:.2f}x; load average after {os.getloadavg()[0]:.1f}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
