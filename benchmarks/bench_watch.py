"""Benchmark of ``endurance watch``: speed and memory on a long stream, and its predictions
scored on real flights.

Speed and memory (``--speed``): a 1-hour flight at 50 messages a second (simulated by
the project's models: it measures the software, not a model) is written as a tlog, then
(a) replayed through the decoder and the estimator in this process with a prediction every
second of flight — CPU per message, the memory the Python heap holds; and (b) played over
loopback at 20× real time to ``endurance watch udpin:127.0.0.1:PORT`` in its own process —
whether it keeps up (messages decoded over messages sent), its CPU per message and its
resident memory through the hour.

Scores on real flights (``--scores``; they need ``../shared/data``):

* the McGill PX4 hexacopter's 44-min hover to "Critical battery level!": the predicted time
  to critical at 5, 10, 20, 30 and 40 min after take-off against the truth, played over
  loopback (``--via loopback``, default) or replayed from the file (``--via file``), with
  the pack's capacity unknown; the reserve is PX4's own critical level
  (``--reserve px4-critical``: the firmware's code and the parameters it sent); then the
  same with a label capacity (sensitivity: 4500, 5500, 6500 mAh, from the file);
* every real log with current in ``../shared/data/logs`` (ArduPilot, PX4) and every DJI
  M100 flight (through the record player, ``--map dji_m100``): the charge drawn from 25, 50
  and 75 % of each flight to its landing, predicted at the present condition over the
  flight's true remaining time, against the measured one;

side by side with PX4's estimator (its 50-s filtered current) and a consumption-rate
extrapolation (the mean current since take-off).

Run::

    python benchmarks/bench_watch.py --speed
    python benchmarks/bench_watch.py --scores [--via file]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
import tracemalloc
from dataclasses import replace
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
SHARED = REPO.parent / "shared" / "data"

from planner.identify.inflight import InflightEstimator, WatchSettings  # noqa: E402
from planner.io.mavlink_stream import (  # noqa: E402
    MavlinkDecoder,
    RecordSource,
    TlogSource,
)
from planner.parameters import BatteryPack, load_aircraft_and_battery  # noqa: E402
from tools.play_tlog import free_port, play  # noqa: E402

MCGILL = "logs/px4_hexa_mcgill_2022-05-24_hover_to_critical.tlog"
MCGILL_HOVERS = "logs/px4_hexa_mcgill_2022-06-02_three_hovers.tlog"
#: Real logs with a current sensor: (file, cells, capacity [mAh] or None: unknown).
LOGS = [
    ("logs/ardupilot_copter_quad_ac33dev_dronekit_log171.bin", 4, 5200),
    ("logs/ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin", 4, 6000),
    ("logs/ardupilot_copter_ac313_pixhawk_2014-10-18_20-44.bin", 4, 6000),
    ("logs/px4_octo_legacy_sdlog2_01_07_59.px4log", 6, None),
    ("logs/px4_quad_fmuv6c_indoor_quadrotor_local.ulg", 8, None),
    ("logs/px4_quad_fmuv3_esc_status_log.ulg", 6, None),
    ("logs/px4_quad_fmuv6xrt_corrupt_unregistered_msg_id.ulg", 4, None),
    ("logs/px4_vtol_cubeorange_sample_log_small.ulg", 6, 30000),
    (MCGILL, 6, None),
    (MCGILL_HOVERS, 6, None),
]
M100 = ["energy/m100_flights_part1_flights001-149.csv.gz",
        "energy/m100_flights_part2_flights150-279.csv.gz"]
MARKS_MIN = (5, 10, 20, 30, 40)
SHARES = (0.25, 0.50, 0.75)
#: Flights shorter than this are not scored. [s]
MIN_FLIGHT_S = 30.0


# --------------------------------------------------------------------------- helpers

def tlog_events(path):
    dec = MavlinkDecoder()
    for m in TlogSource(path, rate=0).messages():
        yield from dec.decode(m, m._recv)


#: Specific energy of a LiPo pack, for the mass of a pack known by its cells and capacity.
#: [Wh/kg]
LIPO_WH_PER_KG = 180.0


def generic_pack(cells: int, capacity_mah: float) -> BatteryPack:
    """A LiPo pack of which only the cell count (and a capacity) is known: 3.7 V a cell,
    :data:`LIPO_WH_PER_KG`."""
    mass = 3.7 * cells * capacity_mah / 1000.0 / LIPO_WH_PER_KG
    return BatteryPack(name=f"{cells}S LiPo", cells_series=cells, capacity_mah=capacity_mah,
                       mass_kg=mass)


def watch_loopback(tlog: Path, args: list[str], speed: float) -> tuple[list[dict], dict]:
    """``endurance watch`` on 127.0.0.1 while the player plays ``tlog``: (rows, usage)."""
    port = free_port()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "w.jsonl"
        w = subprocess.Popen([sys.executable, "-m", "planner", "watch",
                              f"udpin:127.0.0.1:{port}", "--jsonl", str(out), "--passive",
                              *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                             text=True, cwd=REPO)
        _wait_bound(port, w)
        rss = []
        t0 = time.monotonic()
        sampler_stop = [False]

        def sample():
            while not sampler_stop[0]:
                rss.append((time.monotonic() - t0, _rss_kb(w.pid)))
                time.sleep(5.0)

        import threading
        th = threading.Thread(target=sample, daemon=True)
        th.start()
        sent = play(tlog, port, speed=speed, max_seconds=3600)
        time.sleep(2.0)
        cpu = _cpu_s(w.pid)
        sampler_stop[0] = True
        w.send_signal(signal.SIGINT)
        _, err = w.communicate(timeout=120)
        if w.returncode != 0:
            raise RuntimeError(err)
        rows = [json.loads(x) for x in out.read_text().splitlines()]
    return rows, {"sent": sent, "cpu_s": cpu, "rss_kb": rss, "wall_s": time.monotonic() - t0}


def _wait_bound(port, proc):
    for _ in range(600):
        probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            probe.bind(("127.0.0.1", port))
        except OSError:
            return
        finally:
            probe.close()
        if proc.poll() is not None:
            raise RuntimeError(proc.stderr.read())
        time.sleep(0.1)
    raise RuntimeError("the watcher did not bind")


def _rss_kb(pid) -> int:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def _cpu_s(pid) -> float:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except OSError:
        return float("nan")


# --------------------------------------------------------------------------- speed

def long_stream(path: Path) -> int:
    """Write a 1-hour, ~50 messages/s tlog (simulated hover); return its messages."""
    from planner.physics.mission import Environment, Leg, Mission
    from testkit.flight import simulate_flight
    from testkit.writers import write_tlog

    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    big = replace(pack, capacity_mah=30000.0, model=None)
    mission = Mission("hour", [Leg("climb", start_alt_m=0, end_alt_m=20, origin="up"),
                               Leg("hover", start_alt_m=20, end_alt_m=20, duration_s=3580.0,
                                   origin="hover"),
                               Leg("descend", start_alt_m=20, end_alt_m=0, origin="down")],
                      Environment(wind_speed_ms=3.0, wind_from_deg=200.0))
    rec = simulate_flight(mission, aircraft, big, rate_hz=12.0, seed=11)
    write_tlog(rec, path, capacity_mah=30000.0, home=(48.0468, 10.4452, 598.0))
    return sum(1 for _ in TlogSource(path, rate=0).messages())


def bench_speed() -> dict:
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hour.tlog"
        n = long_stream(path)
        # (a) in this process, a prediction every second of flight: CPU, then (a second
        # pass, traced) the Python heap
        msgs = list(TlogSource(path, rate=0).messages())

        def replay(trace):
            est = InflightEstimator(aircraft, replace(pack, capacity_mah=30000.0, model=None))
            dec = MavlinkDecoder()
            heap, last, predictions = [], None, 0
            cpu0 = time.process_time()
            for k, m in enumerate(msgs):
                for ev in dec.decode(m, m._recv):
                    est.feed(ev)
                if est.t is not None and (last is None or est.t - last >= 1.0):
                    last = est.t
                    est.predict()
                    predictions += 1
                if trace and k % 20000 == 0:
                    heap.append(tracemalloc.get_traced_memory()[0])
            cpu = time.process_time() - cpu0
            if trace:
                heap.append(tracemalloc.get_traced_memory()[0])
            return cpu, predictions, heap

        cpu, predictions, _ = replay(False)
        tracemalloc.start()
        _, _, heap = replay(True)
        tracemalloc.stop()
        # (b) over loopback at 20x, the watcher in its own process
        rows, usage = watch_loopback(path, ["--aircraft", "aircraft/solo_survey.yaml",
                                            "--capacity", "30000"], speed=20.0)
    decoded = rows[-1].get("messages") if rows else 0
    rss = [kb for _, kb in usage["rss_kb"] if kb]
    return {
        "messages": n, "duration_s": 3600.0, "rate_hz": n / 3600.0,
        "in_process": {"cpu_ms_per_message": 1e3 * cpu / n, "predictions": predictions,
                       "heap_mb_first_last_max": [heap[1] / 2**20, heap[-1] / 2**20,
                                                  max(heap) / 2**20]},
        "loopback_20x": {"sent": usage["sent"], "decoded": decoded,
                         "cpu_ms_per_message": 1e3 * usage["cpu_s"] / max(usage["sent"], 1),
                         "wall_s": usage["wall_s"], "predictions": len(rows),
                         "rss_mb_after_1min_last_max": [rss[min(12, len(rss) - 1)] / 1024,
                                                        rss[-1] / 1024, max(rss) / 1024]
                         if rss else None},
    }


# --------------------------------------------------------------------------- McGill

def mcgill_truth(path: Path) -> dict:
    """Take-off, the critical warning and the firmware's battery parameters, on the
    watcher's own clock."""
    params, out = {}, {"takeoff_s": None, "critical_s": None}
    for ev in tlog_events(path):
        if ev.kind == "landed" and not ev.data[0] and out["takeoff_s"] is None:
            out["takeoff_s"] = ev.time_s
        elif ev.kind == "text" and "Critical battery" in ev.data[1] and out["critical_s"] is None:
            out["critical_s"] = ev.time_s
        elif ev.kind == "param":
            params[ev.data[0]] = ev.data[1]
    ve = params.get("BAT_V_EMPTY", params.get("BAT1_V_EMPTY"))
    vc = params.get("BAT_V_CHARGED", params.get("BAT1_V_CHARGED"))
    thr = params.get("BAT_CRIT_THR")
    out["reserve_cell_v"] = ve + thr * (vc - ve)
    out["params"] = {"BAT_V_EMPTY": ve, "BAT_V_CHARGED": vc, "BAT_CRIT_THR": thr}
    return out


def score_mcgill(via: str, capacity: str, speed: float = 20.0) -> dict:
    """The McGill hover through ``endurance watch`` (over loopback, or the file)."""
    path = SHARED / MCGILL
    truth = mcgill_truth(path)
    args = ["--aircraft", "aircraft/dji_m100.yaml", "--reserve", "px4-critical",
            "--capacity", capacity]
    if via == "loopback":
        rows, _ = watch_loopback(path, args, speed)
    else:
        from planner.cli.main import main
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "w.jsonl"
            cwd = os.getcwd()
            os.chdir(REPO)
            try:
                with open(os.devnull, "w") as null:
                    saved, sys.stdout = sys.stdout, null
                    try:
                        main(["watch", str(path), *args, "--rate", "0", "--every", "10",
                              "--jsonl", str(out)])
                    finally:
                        sys.stdout = saved
            finally:
                os.chdir(cwd)
            rows = [json.loads(x) for x in out.read_text().splitlines()]
    return {"via": via, "capacity": capacity, "curve": "lipo (default)", "truth": truth,
            "marks": _marks(rows, truth)}


def _marks(rows, truth):
    times = np.array([r["time_s"] for r in rows])
    out = []
    half = 0.5 * (truth["critical_s"] - truth["takeoff_s"]) / 60.0
    for minutes in (*MARKS_MIN, half):
        t = truth["takeoff_s"] + 60.0 * minutes
        r = rows[int(np.argmin(np.abs(times - t)))]
        out.append({"minutes": minutes, "at_s": r["time_s"],
                    "truth_s": truth["critical_s"] - r["time_s"],
                    "ours_s": r["time_to_reserve_s"], "p5_s": r["time_to_reserve_p5_s"],
                    "p95_s": r["time_to_reserve_p95_s"], "px4_s": r["px4_time_to_reserve_s"],
                    "rate_s": r["rate_time_to_reserve_s"], "capacity_mah": r["capacity_mah"]})
    return out


def lco_curve():
    """A LiPo (LiCoO2 pouch) cell's open-circuit curve from its C/10 discharge
    (``../shared/data/battery/enertech_lco_pouch``; read here, never copied)."""
    from planner.physics.battery.ocv import OcvTable

    raw = np.loadtxt(SHARED / "battery/enertech_lco_pouch/raw/0.1C_discharge_U.txt")
    t, v = raw[:, 0], raw[:, 1]
    soc = 1.0 - t / t[-1]
    order = np.argsort(soc)
    grid = np.linspace(0.0, 1.0, 101)
    vg = np.interp(grid, soc[order], np.maximum.accumulate(v[order]))
    return OcvTable(grid, np.maximum.accumulate(vg + np.arange(grid.size) * 1e-6),
                    "Enertech LiCoO2 pouch cell, C/10 discharge")


def score_mcgill_curve(capacity: str, curve) -> dict:
    """The same hover through the estimator in this process, with another open-circuit
    curve as the pack's (``circuit.ocv``): how much the curve matters."""
    from planner.parameters import CircuitBlock

    path = SHARED / MCGILL
    truth = mcgill_truth(path)
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/dji_m100.yaml")
    known = capacity != "unknown"
    if known:
        pack = replace(pack, capacity_mah=float(capacity), model=None)
    if curve is not None:
        pack = replace(pack, circuit=CircuitBlock(ocv=curve))
    est = InflightEstimator(aircraft, pack, settings=WatchSettings(
        capacity_known=known, reserve_firmware="px4-critical"))
    rows, last = [], None
    for ev in tlog_events(path):
        est.feed(ev)
        if est.t is not None and (last is None or est.t - last >= 10.0):
            last = est.t
            rows.append(est.predict())
    return {"via": "file", "capacity": capacity,
            "curve": "lipo (default)" if curve is None else curve.source, "truth": truth,
            "marks": _marks(rows, truth)}


# --------------------------------------------------------------------------- landing charge

def segments(events, est_factory) -> list[tuple]:
    """Airborne spans (flight, take-off, landing) as the estimator judges them."""
    est = est_factory()
    flight, on, out = "", None, []
    last_t = None
    for ev in events:
        if ev.kind == "flight":
            if on is not None and last_t - on >= MIN_FLIGHT_S:
                out.append((flight, on, last_t))
            flight, on = ev.data[0], None
        est.feed(ev)
        last_t = est.t
        if est.airborne and on is None:
            on = est.t
        elif not est.airborne and on is not None:
            if est.t - on >= MIN_FLIGHT_S:
                out.append((flight, on, est.t))
            on = None
    if on is not None and last_t - on >= MIN_FLIGHT_S:
        out.append((flight, on, last_t))
    return out


def score_landing(name: str, events_fn, est_factory) -> list[dict]:
    """Charge drawn from 25/50/75 % of each flight to its landing: predicted vs measured."""
    segs = segments(events_fn(), est_factory)
    # the marks of each flight of the record (a record's flights each start at 0 s)
    marks: dict[str, list] = {}
    for k, (flight, on, off) in enumerate(segs):
        marks.setdefault(flight, []).extend((on + s * (off - on), k, s) for s in SHARES)
    for v in marks.values():
        v.sort()
    est = est_factory()
    flight = ""
    pending = list(marks.get(flight, []))
    q_mark, q_land, results = {}, {}, []
    open_k = set()
    for ev in events_fn():
        if ev.kind == "flight":
            flight = ev.data[0]
            pending = list(marks.get(flight, []))
        est.feed(ev)
        if est.t is None:
            continue
        while pending and est.t >= pending[0][0]:
            t, k, s = pending.pop(0)
            q_mark[(k, s)] = (est.q_now, est.horizon_charge(segs[k][2] - est.t))
            open_k.add(k)
        for k in list(open_k):
            if est.t >= segs[k][2]:
                q_land[k] = est.q_now
                open_k.discard(k)
    for k in open_k:
        q_land[k] = est.q_now
    for (k, s), (q0, h) in q_mark.items():
        truth = q_land[k] - q0
        results.append({"log": name, "flight": segs[k][0], "share": s, "truth_mah": truth,
                        "ours_mah": h["p50"], "p5_mah": h["p5"], "p95_mah": h["p95"],
                        "px4_mah": h["px4"], "rate_mah": h["rate"],
                        "flight_s": segs[k][2] - segs[k][1]})
    return results


def landing_scores(include_m100: bool = True) -> list[dict]:
    out = []
    for rel, cells, cap in LOGS:
        path = SHARED / rel
        if not path.is_file():
            continue
        if rel.endswith(".tlog"):
            def events(path=path):
                return tlog_events(path)
        else:
            src = RecordSource(path, rate=0)

            def events(src=src):
                return src.events()
        aircraft, _ = load_aircraft_and_battery(REPO / "aircraft/dji_m100.yaml")
        pack = generic_pack(cells, cap or 5000.0)
        known = cap is not None

        def factory(aircraft=aircraft, pack=pack, known=known):
            return InflightEstimator(aircraft, pack, settings=WatchSettings(
                capacity_known=known))
        try:
            out += score_landing(Path(rel).name, events, factory)
        except Exception as exc:          # noqa: BLE001 - a log that cannot be read
            print(f"  {rel}: not scored ({exc})", file=sys.stderr)
    if include_m100:
        aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/dji_m100.yaml")
        for rel in M100:
            path = SHARED / rel
            if not path.is_file():
                continue
            src = RecordSource(path, rate=0, column_map="dji_m100")

            def factory(aircraft=aircraft, pack=pack):
                return InflightEstimator(aircraft, pack)
            out += score_landing("m100", src.events, factory)
    return out


def summarise_landing(rows: list[dict]) -> dict:
    out = {}
    groups = {"all": rows, "m100": [r for r in rows if r["log"] == "m100"],
              "logs": [r for r in rows if r["log"] != "m100"]}
    for gname, g in groups.items():
        for s in SHARES:
            sel = [r for r in g if r["share"] == s and r["ours_mah"] is not None]
            if not sel:
                continue
            err = np.array([r["ours_mah"] - r["truth_mah"] for r in sel])
            px4 = np.array([r["px4_mah"] - r["truth_mah"] for r in sel])
            rate = np.array([np.nan if r["rate_mah"] is None else r["rate_mah"] - r["truth_mah"]
                             for r in sel])
            rel = np.array([r["truth_mah"] for r in sel])
            inside = np.mean([r["p5_mah"] <= r["truth_mah"] <= r["p95_mah"] for r in sel])
            out[f"{gname}@{int(s * 100)}%"] = {
                "cases": len(sel),
                "ours_median_abs_err_pct": float(np.median(np.abs(err) / rel) * 100),
                "px4_median_abs_err_pct": float(np.median(np.abs(px4) / rel) * 100),
                "rate_median_abs_err_pct": float(np.nanmedian(np.abs(rate) / rel) * 100),
                "ours_median_abs_err_mah": float(np.median(np.abs(err))),
                "px4_median_abs_err_mah": float(np.median(np.abs(px4))),
                "rate_median_abs_err_mah": float(np.nanmedian(np.abs(rate))),
                "inside_p5_p95": float(inside)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--speed", action="store_true")
    ap.add_argument("--scores", action="store_true")
    ap.add_argument("--via", choices=("loopback", "file"), default="loopback")
    ap.add_argument("--no-m100", action="store_true")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    result = {}
    if args.speed:
        result["speed"] = bench_speed()
        print(json.dumps(result["speed"], indent=1))
    if args.scores:
        if not SHARED.is_dir():
            print(f"skipped: {SHARED} is absent")
            return
        result["mcgill"] = [score_mcgill(args.via, "unknown")]
        lco = lco_curve()
        for curve in (None, lco):
            for cap in ("unknown", "4500", "5500", "6500"):
                result["mcgill"].append(score_mcgill_curve(cap, curve))
        for run in result["mcgill"]:
            print(f"McGill hover, capacity {run['capacity']}, curve {run['curve']} "
                  f"({run['via']}): critical at "
                  f"{run['truth']['critical_s']:.1f} s, take-off {run['truth']['takeoff_s']:.1f} s,"
                  f" firmware {run['truth']['params']}")
            for m in run["marks"]:
                print(f"  {m['minutes']:>4.1f} min: truth {m['truth_s']:6.0f} s  ours "
                      f"{m['ours_s']:6.0f} s [P5 {m['p5_s']:6.0f}, P95 {m['p95_s']:6.0f}]  "
                      f"PX4 {m['px4_s']:6.0f} s  rate {m['rate_s']:6.0f} s")
        rows = landing_scores(include_m100=not args.no_m100)
        result["landing_rows"] = rows
        result["landing"] = summarise_landing(rows)
        print(json.dumps(result["landing"], indent=1))
    if args.json:
        args.json.write_text(json.dumps(result, indent=1, default=float))


if __name__ == "__main__":
    main()
