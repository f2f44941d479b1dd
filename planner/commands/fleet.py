"""``endurance fleet``: many logs on Dask → flight table, pack health, fleet accuracy."""

from __future__ import annotations

import sys

from planner.commands.common import parse_float, parse_fraction, parse_int
from planner.parameters import load_aircraft, load_battery


def register(sub) -> None:
    p = sub.add_parser("fleet", help="many logs on Dask: per-flight table, pack health, "
                                     "fleet accuracy",
                       description="Read every log, replay it through the planner's models, "
                                   "and write DIR/flights.parquet (one row per flight), the "
                                   "health of each pack with a pack file per pack in "
                                   "DIR/packs/, and DIR/report.md. A rerun skips the logs "
                                   "already in the table.")
    p.add_argument("logs", nargs="+", metavar="LOG_OR_FOLDER",
                   help="log files (.bin, .px4log, .tlog, .ulg) or folders searched for them")
    p.add_argument("--aircraft", required=True, help="aircraft YAML")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output folder (created; may not contain an input)")
    p.add_argument("--battery", help="the new pack's YAML (default: the aircraft's pack)")
    p.add_argument("--packs", metavar="PACKS.csv",
                   help="CSV log,pack[,cycle]: the pack flown in logs that carry no battery "
                        "serial (log = file name)")
    p.add_argument("--workers", default=None,
                   help="process workers of the local Dask cluster (default: one per core)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing Dask scheduler (tcp://host:8786) instead of a local "
                        "cluster")
    p.add_argument("--retire", default="0.8",
                   help="retirement threshold, state of health (default 0.8 = 80 %%)")
    p.add_argument("--within", default="50",
                   help="flag the packs that reach --retire within this many flights "
                        "(default 50)")
    p.set_defaults(func=run)


def run(args) -> int:
    from planner.fleet import read_pack_map, run_fleet

    if args.workers is not None and args.scheduler:
        from planner.errors import InputError
        raise InputError("--workers applies to the local cluster; with --scheduler the "
                         "cluster's own workers run the logs")
    workers = parse_int(args.workers, "--workers", 1, 1024) if args.workers else None
    retire = parse_fraction(args.retire, "--retire")
    if retire <= 0:
        from planner.errors import InputError
        raise InputError(f"--retire: expected a state of health in (0, 1), got {args.retire!r}")
    within = parse_float(args.within, "--within", 0.0, 1.0e6)
    aircraft = load_aircraft(args.aircraft)
    pack = load_battery(args.battery) if args.battery else None
    if pack is None and aircraft.battery_path:
        from planner.parameters import default_battery_path
        pack = load_battery(default_battery_path(aircraft))
    pack_map = read_pack_map(args.packs) if args.packs else None
    result = run_fleet(args.logs, out_dir=args.out, aircraft=aircraft, pack=pack,
                       pack_map=pack_map, workers=workers, scheduler=args.scheduler,
                       retire=retire, within=within)
    ok = int((result.table["status"] == "ok").sum())
    print(f"{result.processed} logs summarised in {result.elapsed_s:.1f} s "
          f"({len(result.failed)} failed), {result.skipped} already in the table; "
          f"{ok} flights in {result.outputs[0]}")
    for log, err in result.failed:
        print(f"failed: {err}", file=sys.stderr)
    for h in result.health:
        if h.retires_within(within):
            print(f"pack {h.pack_id}: state of health {100 * h.soh:.1f} %, reaches "
                  f"{100 * retire:.0f} % in {max(h.flights_to_retire, 0):.0f} flights")
    print(f"report: {result.outputs[-1]}")
    return 0
