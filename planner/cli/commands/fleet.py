"""``endurance fleet``: many logs on Dask → flight table, pack health, fleet accuracy."""

from __future__ import annotations

import sys

from planner.cli.commands.common import parse_float, parse_fraction, parse_int
from planner.errors import InputError
from planner.parameters import load_aircraft, load_battery


#: How the fleet is run and judged: Dask, calibration, retirement (argparse settings).
RUN_OPTIONS = {
    "--no-calibration": dict(action="store_true", help="skip the fleet-wide aircraft "
                             "calibration (and DIR/samples.parquet)"),
    "--workers": dict(default=None, help="process workers of the local Dask cluster "
                      "(default: one per core)"),
    "--scheduler": dict(metavar="ADDRESS", help="an existing Dask scheduler "
                        "(tcp://host:8786) instead of a local cluster"),
    "--retire": dict(default="0.8", help="retirement threshold, state of health (default "
                     "0.8 = 80 %%)"),
    "--within": dict(default="50", help="flag the packs that reach --retire within this "
                     "many flights (default 50)"),
}


def register(sub) -> None:
    """Add the ``fleet`` command with its options to the subcommand parsers ``sub``."""
    p = sub.add_parser("fleet", help="many logs on Dask: per-flight table, pack health, "
                                     "fleet accuracy",
                       description="Read every log, replay it through the planner's models, "
                                   "and write DIR/flights.parquet (one row per flight), the "
                                   "health of each pack with a pack file per pack in "
                                   "DIR/packs/, and DIR/report.md. A rerun skips the logs "
                                   "already in the table.")
    p.add_argument("logs", nargs="+", metavar="LOG_OR_FOLDER",
                   help="log files (.bin, .px4log, .tlog, .ulg) or folders searched for them")
    p.add_argument("--aircraft", required=True, nargs="+", action="extend", metavar="A.yaml",
                   help="aircraft YAML; several for a mixed fleet (each log's aircraft is "
                        "the --packs CSV's column aircraft, a file's stem or the aircraft's "
                        "name, else the one of the log's vehicle type)")
    p.add_argument("--out", required=True, metavar="DIR",
                   help="output folder (created; may not contain an input)")
    p.add_argument("--battery", help="the new pack's YAML, for every aircraft (default: each "
                                     "aircraft's own pack)")
    p.add_argument("--packs", metavar="PACKS.csv",
                   help="CSV log,pack[,cycle][,aircraft]: the pack flown in logs that carry no "
                        "battery serial, and the aircraft that flew them (log = file name)")
    for flag, settings in RUN_OPTIONS.items():
        p.add_argument(flag, **settings)
    p.set_defaults(func=run, output_folders=("--out",))


def run(args) -> int:
    """``endurance fleet``: replay a folder of logs on Dask workers and write the accuracy,
    pack health and calibration tables; returns 0 (130 when interrupted)."""
    from planner.fleet import FleetInterrupted, read_pack_map, run_fleet

    if args.workers is not None and args.scheduler:
        raise InputError("--workers applies to the local cluster; with --scheduler the "
                         "cluster's own workers run the logs")
    workers = parse_int(args.workers, "--workers", 1, 1024) if args.workers else None
    retire = parse_fraction(args.retire, "--retire")
    if retire <= 0:
        raise InputError(f"--retire: expected a state of health in (0, 1), got {args.retire!r}")
    within = parse_float(args.within, "--within", 0.0, 1.0e6)
    from pathlib import Path

    from planner.cli.plots.fleet import write_figures
    from planner.parameters import default_battery_path

    aircraft, packs = {}, {}
    common = load_battery(args.battery) if args.battery else None
    for path in dict.fromkeys(args.aircraft):
        key = Path(path).stem
        if key in aircraft:
            raise InputError(f"--aircraft {path}: a second aircraft file named {key}; expected "
                             "files with different names (the name is the aircraft's key)")
        aircraft[key] = load_aircraft(path)
        packs[key] = common if common is not None else (
            load_battery(default_battery_path(aircraft[key])) if aircraft[key].battery_path
            else None)
    pack_map = read_pack_map(args.packs, aircraft) if args.packs else None
    try:
        result = run_fleet(args.logs, out_dir=args.out, aircraft=aircraft, pack=packs,
                           pack_map=pack_map, workers=workers, scheduler=args.scheduler,
                           retire=retire, within=within, calibrate=not args.no_calibration,
                           figures=write_figures)
    except FleetInterrupted as stop:
        # after a progress line rewritten in place, on a line of its own
        kept = (f"{stop.kept} flight{'' if stop.kept == 1 else 's'} kept in {stop.table}"
                if stop.table.exists() else "no flight finished yet, nothing kept")
        print(("\n" if sys.stderr.isatty() else "")
              + f"interrupted: {kept}; run the same command again to finish (the flights "
              "in the table are not read again)", file=sys.stderr)
        return 130
    ok = int((result.table["status"] == "ok").sum())
    counts = [f"{len(result.failed)} failed"]
    if result.not_replayable:
        counts.append(f"{len(result.not_replayable)} not replayable")
    for status in ("mismatch", "not airborne"):
        if result.count(status):
            counts.append(f"{result.count(status)} {status}")
    print(f"{result.processed} logs summarised in {result.elapsed_s:.1f} s "
          f"({', '.join(counts)}), {result.skipped} already in the table; "
          f"{ok} flights in {result.outputs[0]}")
    for log, err in result.failed:
        print(f"failed: {err}", file=sys.stderr)
    for log, err in result.not_replayable:
        print(f"not replayed: {err}", file=sys.stderr)
    for log, _, reason in result.left_out:
        print(f"{Path(log).name}: {reason}", file=sys.stderr)
    for h in result.health:
        if h.retires_within(within):
            print(f"pack {h.pack_id}: state of health {100 * h.soh:.1f} %, reaches "
                  f"{100 * retire:.0f} % in {max(h.flights_to_retire, 0):.0f} flights")
    for cal in result.calibrations:
        if cal.aircraft is None:
            print(f"aircraft {cal.key}: not calibrated ({cal.note})")
            continue
        before = cal.validation.get("before", {}).get("energy_error_pct", float("nan"))
        after = cal.validation.get("after", {}).get("energy_error_pct", float("nan"))
        print(f"aircraft {cal.key}: calibrated on {cal.train_flights} flights; energy error "
              f"on {cal.validation_flights} held-out flights {before:+.1f} % as given, "
              f"{after:+.1f} % calibrated ({cal.file})")
    print(f"report: {result.outputs[-1]}")
    return 0
