"""``endurance export LOG --csv F``: any supported log → flight-record CSV (docs/record.md)."""

from __future__ import annotations

import argparse
from pathlib import Path

from planner.errors import InputError


def export(log: str | Path, csv: str | Path, *, map: str | Path | None = None,
           require_battery: bool = True, battery_instance: int | None = None
           ) -> tuple[str, dict]:
    """Read ``log`` and write its flight record to ``csv``.

    Returns the one-line summary and the reader's metadata.
    """
    from planner.io.logs import read_log
    from planner.io.record import write_record

    opts = {"require_battery": require_battery}
    if map is not None:
        opts["map"] = map
    if battery_instance is not None:
        opts["battery_instance"] = battery_instance
    df, meta = read_log(log, **opts)
    if len(df) == 0:
        raise InputError(f"{log}: no samples to export")
    from planner.io.record import voltage_only

    # a voltage-only log (no current sensor) is exported as it is: the reader said once
    # that its charge and power cannot be replayed
    write_record(df, csv, require_power=require_battery and not voltage_only(df),
                 option="--csv")
    channels = [c for c in df.columns if c not in ("experiment", "time_s")]
    n_exp = df["experiment"].nunique() if "experiment" in df else 1
    if n_exp > 1:
        span = df.groupby("experiment", sort=False)["time_s"].agg(lambda s: s.iloc[-1] - s.iloc[0])
        duration = float(span.sum())
    else:
        duration = float(df["time_s"].iloc[-1] - df["time_s"].iloc[0])
    summary = (f"{log}: {len(df)} samples, {duration:.1f} s"
               + (f" in {n_exp} experiments" if n_exp > 1 else "")
               + f", {len(channels)} channels ({', '.join(channels)}) -> {csv}"
               + (f"\ncolumn map {meta['column_map']} (matched: {meta['column_map_match']})"
                  if meta.get("column_map") else ""))
    return summary, meta


def _run(args: argparse.Namespace) -> int:
    from planner.cli.commands.common import battery_instance
    summary, _ = export(args.log, args.csv, map=args.map,
                        require_battery=not args.allow_no_battery,
                        battery_instance=battery_instance(args))
    print(summary)
    return 0


def register(subparsers) -> None:
    """Add the ``export`` command with its options to the subcommand parsers ``subparsers``."""
    p = subparsers.add_parser(
        "export", help="any supported log -> flight record CSV",
        description="Read an ArduPilot .bin, PX4 .px4log/.ulg, MAVLink .tlog, a PX4 topic "
        "export (a folder or zip of pyulog ulog2csv files) or a CSV file (with --map) and "
        "write the flight record (docs/record.md) as CSV. One row per battery sample; the other "
        "channels are interpolated onto the battery times.")
    p.add_argument("log", metavar="LOG", help="log file (.bin, .px4log, .ulg, .tlog, .csv) or "
                                              "a folder or zip of PX4 topic CSV files")
    p.add_argument("--csv", required=True, metavar="F", help="flight-record CSV to write")
    p.add_argument("--map", metavar="MAP.yaml", default=None,
                   help="column map for a CSV input (e.g. planner/io/logs/maps/dji_m100.yaml, "
                        "or a shipped map's name); 'auto': the shipped map that reads the "
                        "file's columns, named in the output")
    p.add_argument("--allow-no-battery", action="store_true",
                   help="export a log without battery voltage/current (kinematics only)")
    from planner.cli.commands.common import add_battery_instance
    add_battery_instance(p)
    p.set_defaults(func=_run)
