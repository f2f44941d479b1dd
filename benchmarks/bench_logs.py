"""Benchmark: log readers on the real logs in ../shared/data/logs.

Targets (issue "Log replay", part 1):

* ArduPilot ``.bin``: at least 10x (now 40x) the throughput of a full pass of pymavlink's
  own reader (``DFReader_binary(path)`` then ``recv_msg()`` until the end, the
  way ``mavlogdump`` reads) on the largest real ``.bin``;
* PX4 ``.ulg``: at least 5x a full ``pyulog.ULog(path)`` parse (issue "Fleet", part 4),
  DataFlash kept at >= 40x pymavlink;
* peak memory (tracemalloc) of one read below 3x the file size.

"ours" is the complete :func:`planner.io.logs.read_log` call: file to flight-record
DataFrame, every channel. Times are the best of several runs, ours and the
reference interleaved; memory is measured in a separate run with tracemalloc on.

Run: ``python benchmarks/bench_logs.py [LOG ...]``
"""

from __future__ import annotations

import contextlib
import io
import sys
import time
import tracemalloc
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
LOGS = REPO.parent / "shared" / "data" / "logs"

from planner.io.logs import LogWarning, read_log


def timed_pair(a, b, repeat: int) -> tuple[float, float]:
    """Best-of-``repeat`` wall time of ``a`` and of ``b``, runs interleaved.

    Interleaving and taking the minimum keep other load on the machine from
    favouring either side.
    """
    ta, tb = [], []
    for _ in range(repeat):
        for fn, out in ((a, ta), (b, tb)):
            t = time.perf_counter()
            fn()
            out.append(time.perf_counter() - t)
    return min(ta), min(tb)


def pymavlink_full_pass(path: Path) -> None:
    from pymavlink import DFReader
    r = DFReader.DFReader_binary(str(path), zero_time_base=False)
    while r.recv_msg() is not None:
        pass
    r.close()


def pymavlink_tlog_pass(path: Path) -> None:
    from pymavlink import mavutil
    c = mavutil.mavlink_connection(str(path))
    while c.recv_msg() is not None:
        pass
    c.close()


def pyulog_full(path: Path) -> None:
    from pyulog import ULog
    with contextlib.redirect_stdout(io.StringIO()):
        ULog(str(path))


def ours(path: Path) -> None:
    read_log(path, require_battery=False)


def ulog_decode(path: Path) -> None:
    """The decoder alone (what pyulog.ULog does): the topics of the flight record."""
    from planner.io.logs._ulog_decode import decode
    from planner.io.logs.ulog import _TOPICS

    decode(path.read_bytes(), _TOPICS)


def pyulog_topics(path: Path) -> None:
    from pyulog import ULog

    from planner.io.logs.ulog import _TOPICS
    with contextlib.redirect_stdout(io.StringIO()):
        ULog(str(path), _TOPICS)


def peak_memory(path: Path) -> int:
    tracemalloc.start()
    tracemalloc.reset_peak()
    ours(path)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak


def main(argv: list[str]) -> int:
    warnings.simplefilter("ignore", LogWarning)
    paths = [Path(a) for a in argv] or sorted(
        p for p in LOGS.glob("*") if p.suffix in (".bin", ".px4log", ".ulg", ".tlog"))
    if not paths:
        print(f"no logs found in {LOGS}")
        return 1
    refs = {".bin": ("pymavlink DFReader full pass", pymavlink_full_pass),
            ".px4log": ("pymavlink DFReader full pass", pymavlink_full_pass),
            ".ulg": ("pyulog.ULog full parse", pyulog_full),
            ".tlog": ("pymavlink mavlink_connection full pass", pymavlink_tlog_pass)}
    print(f"{'log':58s} {'MB':>5s} {'ours ms':>8s} {'MB/s':>7s} {'ref ms':>8s} "
          f"{'ref MB/s':>8s} {'speed-up':>8s} {'peak/size':>9s}  reference")
    results = []
    for path in paths:
        size = path.stat().st_size
        mb = size / 1e6
        name, ref = refs[path.suffix]
        ours(path)                                   # warm-up (imports, page cache)
        ref(path)
        repeat = 5 if path.suffix in (".bin", ".px4log", ".tlog") else 15
        t_ours, t_ref = timed_pair(lambda path=path: ours(path),
                                   lambda ref=ref, path=path: ref(path), repeat)
        peak = peak_memory(path)
        results.append((path, size, t_ours, t_ref, peak))
        print(f"{path.name[:58]:58s} {mb:5.2f} {t_ours * 1e3:8.1f} {mb / t_ours:7.1f} "
              f"{t_ref * 1e3:8.1f} {mb / t_ref:8.1f} {t_ref / t_ours:7.1f}x "
              f"{peak / size:8.2f}x  {name}")

    ok = True
    bins = [r for r in results if r[0].suffix == ".bin"]
    if bins:
        path, size, t_ours, t_ref, _ = max(bins, key=lambda r: r[1])
        speedup = t_ref / t_ours
        ok &= speedup >= 40
        print(f"\nlargest .bin ({path.name}, {size / 1e6:.2f} MB): {speedup:.1f}x pymavlink "
              f"(target >= 40x): {'PASS' if speedup >= 40 else 'FAIL'}")
    for path, size, t_ours, t_ref, _ in (r for r in results if r[0].suffix == ".ulg"):
        t_dec, t_pyu = timed_pair(lambda path=path: ulog_decode(path),
                                  lambda path=path: pyulog_full(path), 15)
        t_dec2, t_pyu2 = timed_pair(lambda path=path: ulog_decode(path),
                                    lambda path=path: pyulog_topics(path), 15)
        good = t_pyu / t_dec >= 5
        ok &= good
        print(f".ulg {path.name}: decode {t_pyu / t_dec:.1f}x pyulog's full parse, "
              f"{t_pyu2 / t_dec2:.1f}x pyulog on the same topics (target >= 5x): "
              f"{'PASS' if good else 'FAIL'}; file to flight record {t_ref / t_ours:.1f}x")
    worst = max(results, key=lambda r: r[4] / r[1])
    good = worst[4] / worst[1] < 3
    ok &= good
    print(f"peak memory: worst {worst[4] / worst[1]:.2f}x file size ({worst[0].name}) "
          f"(target < 3x): {'PASS' if good else 'FAIL'}")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
