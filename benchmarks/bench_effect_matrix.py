"""The effect matrix of ``diagnose`` on real data: every effect of its vocabulary
× every real source that can carry it × record richness × timing × size.

Sources, injection laws, richness, timings, sizes and what is scored: the module notes of
:mod:`testkit.matrix` and :mod:`testkit.injections` (the laws are written there, never the
planner's own models). Data: ``../shared/data`` (PROVENANCE.md in each folder).

Per cell it prints and writes (``--json``): the runs, how often the injected effect is
named first and anywhere, the runs with a false cause (and which), the record's own
findings named (``own``: effects the real data carry themselves,
:class:`testkit.matrix.RealEffect`, never a false cause), how often diagnose's detection
limit calls the injected size identifiable, how often the output says the effect is not
identifiable where it is not named, how often the fitted parameter lies within two
standard errors of the injected one (where named first), the median limit against the
median size, and the CPU time per run; then the verdict against the issue's criterion
at realistic size (``clean``: silent in ≥ 95 %, the record's own findings aside;
``identifiable``: named first in ≥ 80 %, within 2 SE in most; ``not identifiable``: said
so wherever not named, false causes in ≤ 5 %). After the cells: the criterion read run by
run (:func:`testkit.matrix.run_by_run`) and how often an effect is named first against its
size over the run's own detection limit (:func:`testkit.matrix.limit_calibration`; each
run's size, limit and outcome are in the JSON's ``per_run``).

OpenBLAS runs one thread (``OPENBLAS_NUM_THREADS=1``, set here before numpy loads): the
matrices are small, and on a shared 2-core machine its spinning threads cost more CPU
than they save. Run::

    python benchmarks/bench_effect_matrix.py [--runs 10] [--seed 0] [--sources m100,p42a]
        [--injections payload,wind] [--richness plain] [--sizes realistic]
        [--rate 1] [--flights 16] [--json matrix.json]
    python benchmarks/bench_effect_matrix.py --speed     # 16 M100 flights; a 1-h 10-Hz flight
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from testkit import matrix as M  # noqa: E402


def _pct(a, b):
    return f"{100 * a / b:3.0f}" if b else "  -"


def row(st: dict) -> str:
    """One cell's line of the table."""
    n = max(st["runs"] - sum(st["errors"].values()), 0)
    lim = [x for x in st["limits"] if math.isfinite(x)]
    size = float(np.median(st["sizes"])) if st["sizes"] else math.nan
    med_lim = float(np.median(st["limits"])) if st["limits"] else math.nan
    kind, ok = M.verdict(st) if st["size"] == "realistic" and n else ("-", None)
    false = ",".join(f"{k}:{v}" for k, v in st["false"].most_common()) or "-"
    own = ",".join(f"{k}:{v}" for k, v in st.get("own", {}).items())
    cpu = float(np.median(st["cpu_s"])) if st["cpu_s"] else math.nan
    return (f"{st['cell']:<46} {n:3d} {_pct(st['named_first'], n)} {_pct(st['named_any'], n)} "
            f"{_pct(st['false_runs'], n)} {_pct(st['identifiable'], n)} "
            f"{_pct(st['said_not_identifiable'], max(n - st['named_any'], 0))} "
            f"{st['within_2se']:2d}/{st['checked_2se']:<2d} {size:9.3g} {med_lim:9.3g} "
            f"{cpu:5.2f}  {kind[:5]:<5} {'' if ok is None else ('met' if ok else 'NOT MET')}"
            f"  false: {false}" + (f"  own: {own}" if own else "")
            + (f"  errors: {dict(st['errors'])}" if st["errors"] else "")
            + ("" if lim or not st["limits"] else ""))


HEADER = (f"{'cell':<46} {'n':>3} {'1st':>3} {'any':>3} {'fls':>3} {'idf':>3} {'sNI':>3} "
          f"{'2SE':>5} {'size':>9} {'limit':>9} {'cpu s':>5}  verdict")


def speed() -> int:
    """The two speed figures of the issue: 16 M100 flights (clean, and with a payload
    released mid-flight), and a one-hour 10-Hz flight
    (ArduCopter log 171, 243 s of real 10-Hz channels, repeated back to back to one hour:
    36 000 samples, with the Solo aircraft so that every level runs)."""
    import pandas as pd

    from planner.identify.diagnose import diagnose

    warnings.simplefilter("ignore")
    src = M.sources()
    d = src["m100"].draw(np.random.default_rng(0))
    rec = M.reduce(d.record, "plain")
    diagnose(rec, d.pack, d.aircraft, payload_kg=d.payload_kg, site_altitude_m=300.0)

    def cpu_over_draws(record_of) -> list[float]:
        """CPU time of diagnose on the first 5 draws, each given as ``record_of(draw,
        seed)`` returns it: (record, payload [kg]). [s]"""
        out = []
        for seed in range(5):
            d = src["m100"].draw(np.random.default_rng(seed))
            rec, payload = record_of(d, seed)
            t0 = time.process_time()
            diagnose(rec, d.pack, d.aircraft, payload_kg=payload, site_altitude_m=300.0)
            out.append(time.process_time() - t0)
        return out

    cpu = cpu_over_draws(lambda d, seed: (M.reduce(d.record, "everything"), d.payload_kg))
    print(f"16 M100 flights (all channels, 5 draws): CPU {np.median(cpu):.2f} s median, "
          f"{max(cpu):.2f} s max (target < 5 s)")

    # the same flights with a payload released mid-flight, plain record: the step passes,
    # and on route R1 a wind is fitted as its rival (search, "Rival effects")
    def released(d, seed):
        injd = M.inject("payload", d, np.random.default_rng(seed), M.SIZES["realistic"],
                        "mid")
        return M.reduce(injd.record, "plain"), injd.payload_kg

    cpu = cpu_over_draws(released)
    print(f"16 M100 flights with a payload released mid-flight (plain record, 5 draws): "
          f"CPU {np.median(cpu):.2f} s median, {max(cpu):.2f} s max (target < 5 s)")

    d171 = src["log171"].draw(np.random.default_rng(0))
    rec = d171.record.drop(columns=["consumed_mah"], errors="ignore")
    t = rec["time_s"].to_numpy(float)
    t = t - t[0]
    span = float(t[-1] + np.median(np.diff(t)))
    reps = int(np.ceil(3600.0 / span))
    parts = [rec.assign(time_s=t + k * span, experiment="hour") for k in range(reps)]
    long = pd.concat(parts, ignore_index=True)
    long = long[long["time_s"] < 3600.0].reset_index(drop=True)
    t0 = time.process_time()
    res = diagnose(long, d171.pack, d171.aircraft)
    one = time.process_time() - t0
    print(f"levels run on the hour: {', '.join(res.levels)}")
    print(f"one-hour 10-Hz flight ({len(long)} samples): CPU {one:.2f} s (target < 3 s)")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sources", help="comma-separated sources (default: all)")
    ap.add_argument("--injections", help="comma-separated injections (default: all)")
    ap.add_argument("--richness", help="comma-separated richness levels (default: all)")
    ap.add_argument("--timings", help="comma-separated timings of the payload change")
    ap.add_argument("--sizes", default="realistic,2x",
                    help="comma-separated sizes of " + ", ".join(M.SIZES) + " (half and "
                         "quarter probe the detection limits from beneath; only realistic is "
                         "judged)")
    ap.add_argument("--rate", type=float, metavar="HZ",
                    help="the records as a telemetry stream at this rate carries them (each "
                         "richness becomes e.g. plain@1Hz; the same injections)")
    ap.add_argument("--flights", type=int, default=M.FLIGHTS,
                    help="flights an M100 draw holds (default %(default)s; the detection "
                         "limits scale with their number)")
    ap.add_argument("--json", help="write the cells' tallies here")
    ap.add_argument("--speed", action="store_true", help="the two speed figures only")
    ap.add_argument("--descent", choices=("file", "calibrated"), default="file",
                    help="the M100's slow-descent inflow weight: the aircraft file's "
                         "(Leishman's curve), or calibrated by fit-aircraft on the flights "
                         "not drawn (testkit.matrix.calibrated_aircraft)")
    args = ap.parse_args(argv)
    M.CALIBRATE_DESCENT = args.descent == "calibrated"
    if not 3 <= args.flights <= 60:
        ap.error(f"--flights: {args.flights}; expected 3 to 60 flights (a payload class "
                 "of route R1 has about 60)")
    M.FLIGHTS = args.flights
    known = {"sources": M.sources(), "injections": M.EXPECT, "richness": M.RICHNESS,
             "timings": M.TIMINGS, "sizes": M.SIZES}
    for opt, names in known.items():
        text = getattr(args, opt)
        bad = sorted(set(text.split(",")) - set(names)) if text else []
        if bad:
            ap.error(f"--{opt}: unknown {', '.join(bad)}; expected some of "
                     f"{', '.join(sorted(names))}")
    if args.rate is not None and not (0.0 < args.rate <= 1000.0):
        ap.error(f"--rate: {args.rate:g} Hz; expected a telemetry rate above 0 and at most "
                 "1000 Hz")
    if not M.available():
        print(f"skipped: the real data are not at {M.DATA}")
        return 0
    if args.speed:
        return speed()
    pick = lambda text: set(text.split(",")) if text else None  # noqa: E731
    sources, kinds, rich, timings = (pick(args.sources), pick(args.injections),
                                     pick(args.richness), pick(args.timings))
    cells = [c for c in M.all_cells(sources, tuple(args.sizes.split(",")))
             if (not kinds or c.injection in kinds) and (not rich or c.richness in rich)
             and (not timings or c.timing is None or c.timing in timings)]
    if args.rate is not None:
        cells = [dataclasses.replace(c, richness=f"{c.richness}@{args.rate:g}Hz")
                 for c in cells]
    print(f"effect matrix: {len(cells)} cells, {args.runs} runs a cell (deterministic "
          f"single-record sources fewer), seed {args.seed}, M100 descent weight: "
          f"{args.descent}, {M.FLIGHTS} flights an M100 draw")
    print("columns: runs, % named first, % named anywhere, % with a false cause, % the "
          "detection limit calls identifiable, % said not identifiable where not named, "
          "within 2 SE / checked, median size and limit (the detection entry's unit), "
          "median CPU s a run")
    print(HEADER)
    draws: dict = {}
    out = []
    for cell in cells:
        st = M.run_cell(cell, args.runs, args.seed, draws)
        print(row(st), flush=True)
        for w in st["winds"]:
            print(f"{'':<6}wind named {w['named_ms']:.1f} m/s from {w['named_from_deg']:.0f}°; "
                  f"the {w['flights']} flights' anemometer: {w['measured_ms']:.1f} m/s from "
                  f"{w['measured_from_deg']:.0f}° ({w['z']:.1f} combined SE apart)")
        kind, ok = M.verdict(st) if cell.size == "realistic" else (None, None)
        st = {k: (dict(v) if isinstance(v, dict) else v) for k, v in st.items()}
        st["verdict"], st["met"] = kind, ok
        out.append(st)
    real = [s for s in out if s["size"] == "realistic"]
    met = sum(1 for s in real if s["met"])
    print(f"realistic size: {met} of {len(real)} cells meet the issue's criterion")
    for kind in ("clean", "identifiable", "not identifiable"):
        ks = [s for s in real if s["verdict"] == kind]
        if ks:
            print(f"  {kind}: {sum(1 for s in ks if s['met'])} of {len(ks)}")
    print(M.run_by_run_text(M.run_by_run(real)))
    print(M.expected_text(real))
    unset = sum(s.get("not_settled", 0) for s in real)
    print(f"a payload change said not settled (seen on the training flights, not confirmed "
          f"on the held-out ones, its bound reaching the limit): {unset} of "
          f"{sum(s['runs'] for s in real)} runs, "
          f"{sum(s.get('not_settled', 0) for s in real if s['expect'] is None)} of them with "
          "nothing injected")
    print("named first against the injected size over the run's detection limit (every "
          "size; the limit is named with 80 % probability):")
    for line in M.limit_calibration_text(M.limit_calibration(out)):
        print("  " + line)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1, default=float))
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
