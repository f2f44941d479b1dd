"""``endurance backtest``: many flights predicted from before take-off, scored against the
logs."""

from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from planner.cli.commands.common import (
    add_options, flight_payloads, parse_float, parse_fraction, parse_int, write_json)
from planner.errors import InputError
from planner.io import files
from planner.io.tables import cell_error, row_label

#: Files written into the output folder.
OUTPUTS = ("backtest.parquet", "backtest.csv", "report.txt", "report.json",
           "predicted_vs_measured.png")
#: Columns of a weather table besides the flight's id, and their units.
WEATHER_COLUMNS = {"wind_speed_ms": "m/s", "wind_from_deg": "deg", "temperature_c": "°C"}


def register(sub) -> None:
    """Add the ``backtest`` command with its options to the subcommand parsers ``sub``."""
    p = sub.add_parser(
        "backtest", help="predict many flights as before take-off; score against the logs",
        description="Predict each flight as its operator would have before take-off (the plan "
                    "from a mission file matched by name, else rebuilt from the flown track "
                    "at the commanded speed and altitude; the forecast from before take-off; "
                    "the aircraft calibrated on other flights only, k-fold) with the chain "
                    "of 'check', and compare with what the flight did. Writes DIR/backtest."
                    "parquet and .csv (one row per flight), DIR/report.txt and .json, and "
                    "DIR/predicted_vs_measured.png.")
    p.add_argument("data", nargs="+", metavar="DATA",
                   help="logs or CSV files (with --map: e.g. the M100 flights)")
    add_options(p, aircraft="aircraft YAML (start values of the per-fold calibration)",
                battery="pack flown (default: the aircraft's)",
                map="column map for CSV data that is not a flight record (e.g. dji_m100: "
                    "joins each flight's payload, commanded speed and altitude)",
                out={"required": True, "metavar": "DIR", "help": "output folder (created)"})
    p.add_argument("--folds", default="5", help="calibration folds (default 5): each flight "
                                                "predicted by an aircraft fitted on the others")
    p.add_argument("--by", choices=("flight", "day"), default="flight",
                   help="fold by flight (dealt in turn) or by the day flown (default flight)")
    p.add_argument("--held-out", metavar="IDS",
                   help="comma-separated flights to predict, calibrated on all the others "
                        "(instead of --folds)")
    p.add_argument("--flights", metavar="IDS",
                   help="comma-separated flights to use (default: all in the data)")
    p.add_argument("--missions", metavar="FOLDER",
                   help="mission files named after the flights (<flight>.plan, .waypoints, "
                        ".txt, .yaml); a flight without one is rebuilt from its track")
    p.add_argument("--weather", metavar="CSV",
                   help="per-flight forecast: columns experiment, wind_speed_ms, "
                        "wind_from_deg[, temperature_c] (default: the log's samples before "
                        "take-off)")
    add_options(p, payload="payload [kg] of every flight (default: each flight's payload_kg "
                           "in the data, else 0)",
                site_altitude="site altitude AMSL [m] for ISA density (default 0)",
                reserve=True)
    p.add_argument("--uncertainty", nargs="?", const="400", default=None, metavar="N",
                   help="also run check --uncertainty's Monte Carlo for each flight (N samples, "
                        "default 400; its default spreads: the forecast's error and the "
                        "model's own energy error on the training flights) and count the "
                        "flights whose measured energy and charge fell inside P5-P95")
    p.add_argument("--kinematics", choices=("fitted", "file", "none"), default="fitted",
                   help="how the plan is flown: 'fitted' (default) with the vehicle's "
                        "navigation (take-off, acceleration and stops at waypoints, two-rate "
                        "landing) fitted per fold on the training flights; 'file' with the "
                        "aircraft file's navigation: block, if any; 'none' every leg at "
                        "constant speed")
    p.add_argument("--battery-model", choices=("fitted", "file"), default="fitted",
                   help="the pack's integral capacity model: 'fitted' (default) delta and "
                        "epsilon fitted per fold on the charge the training flights drew "
                        "(beta held at the pack file's); 'file' the pack file's model")
    p.add_argument("--workers", default="1",
                   help="process workers of a local Dask cluster running the folds "
                        "(default 1: no cluster)")
    p.set_defaults(func=run, output_folders=("--out",))


def _ids(text: str | None) -> list[str] | None:
    return [s.strip() for s in text.split(",") if s.strip()] if text else None


def read_weather(path: str) -> dict[str, dict[str, float]]:
    """A per-flight weather table: experiment → {wind_speed_ms, wind_from_deg,
    temperature_c}; a missing column or a cell that is not a number is an error naming
    the file, the column and the row."""
    try:
        raw = pd.read_csv(files.input_path(path, "table", "weather table"), dtype=str)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a readable CSV file ({type(exc).__name__})") from None
    raw.columns = [str(c).strip() for c in raw.columns]
    key = next((c for c in ("experiment", "flight") if c in raw.columns), None)
    need = [c for c in ("wind_speed_ms", "wind_from_deg") if c not in raw.columns]
    if key is None or need:
        missing = ([] if key else ["experiment"]) + need
        raise InputError(f"{path}: no column {', '.join(missing)}; expected experiment, "
                         "wind_speed_ms [m/s], wind_from_deg [deg] and optionally "
                         "temperature_c [°C]")
    out: dict[str, dict[str, float]] = {}
    for i, r in raw.iterrows():          # one row per flight: a short table
        values = {}
        for col, unit in WEATHER_COLUMNS.items():
            if col not in raw.columns or pd.isna(r[col]):
                if col != "temperature_c":
                    raise cell_error(path, col, row_label(i, i + 2), f"a number [{unit}]",
                                     r[col])
                continue
            try:
                values[col] = float(r[col])
            except ValueError:
                raise cell_error(path, col, row_label(i, i + 2), f"a number [{unit}]",
                                 r[col]) from None
        if not 0.0 <= values["wind_speed_ms"] < 100.0:
            raise cell_error(path, "wind_speed_ms", row_label(i, i + 2),
                             "a wind speed in [0, 100) m/s", r["wind_speed_ms"])
        out[str(r[key]).strip()] = values
    return out


def run(args) -> int:
    """``endurance backtest``: predict each flight as before take-off, score it against the log
    and write the tables, report and plot; returns 0."""
    from planner.identify.backtest import run_backtest, summarise

    aircraft, pack, path = _definitions(args)
    options = _options(args)
    t0 = time.perf_counter()
    data, payload = _data(args, aircraft, options)
    with _dask(parse_int(args.workers, "--workers", 1, 1024)) as client:
        table = run_backtest(data, aircraft, pack, options, payload_kg=payload, client=client)
    summary = summarise(table)
    summary.update(elapsed_s=time.perf_counter() - t0, aircraft=args.aircraft,
                   battery=str(path), data=[str(d) for d in args.data],
                   calibration=(f"held out {len(options.held_out)} flights, calibrated on the "
                                "others" if options.held_out else
                                f"{options.folds}-fold by {args.by}"),
                   kinematics=_KINEMATICS[args.kinematics])
    text = render(summary)
    print(text)
    _write(Path(args.out), table, summary, text)
    return 0


def _definitions(args):
    """The aircraft, the pack and the pack's file."""
    from planner.parameters import default_battery_path, load_aircraft, load_battery

    aircraft = load_aircraft(args.aircraft)
    path = args.battery or default_battery_path(aircraft)
    if path is None:
        raise InputError(f"{args.aircraft}: no pack known: give --battery")
    if args.payload is not None:            # checked before the data are read
        flight_payloads(None, args.payload, "--payload", aircraft)
    return aircraft, load_battery(path), path


def _options(args):
    """The backtest's options from the command line."""
    from planner.identify.backtest import BacktestOptions

    missions = Path(args.missions) if args.missions else None
    if missions is not None and not missions.is_dir():
        raise InputError(f"--missions {args.missions}: not a folder")
    return BacktestOptions(
        folds=parse_int(args.folds, "--folds", 2, 1000), by=args.by,
        held_out=tuple(_ids(args.held_out) or ()) or None,
        site_altitude_m=parse_float(args.site_altitude, "--site-altitude", -500.0, 9000.0,
                                    "m"),
        reserve=parse_fraction(args.reserve, "--reserve"), missions_dir=missions,
        weather=read_weather(args.weather) if args.weather else None,
        kinematics=args.kinematics, battery=args.battery_model,
        uncertainty_samples=(parse_int(args.uncertainty, "--uncertainty", 20, 100_000)
                             if args.uncertainty else 0))


def _data(args, aircraft, options):
    """The flight data (the ``--flights`` subset) and the payload given for every flight."""
    from planner.io.flightdata import load_flight_data

    failed: list[str] = []
    data, _ = load_flight_data(args.data, column_map=args.map, failed=failed)
    for message in failed:
        print(f"error: {message}", file=sys.stderr)
    subset = _ids(args.flights)
    if subset:
        unknown = sorted(set(subset) - set(data["experiment"].astype(str)))
        if unknown:
            raise InputError(f"--flights: {', '.join(unknown[:10])} not in the data")
        data = data[data["experiment"].astype(str).isin(subset)].reset_index(drop=True)
    payload = (flight_payloads(data, args.payload, "--payload", aircraft)
               if args.payload is not None else None)
    if options.weather is not None:
        extra = sorted(set(options.weather) - set(data["experiment"].astype(str)))
        if extra:
            print(f"note: the weather table names {len(extra)} flight(s) the data lack "
                  f"({', '.join(extra[:5])}{' …' if len(extra) > 5 else ''})")
    return data, payload


@contextlib.contextmanager
def _dask(workers: int):
    """A local Dask client of ``workers`` process workers, or None for one."""
    if workers <= 1:
        yield None
        return
    import warnings

    from dask.distributed import Client, LocalCluster
    with warnings.catch_warnings():     # no dashboard: its port is of no use here
        warnings.simplefilter("ignore")
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def _write(out: Path, table: pd.DataFrame, summary: dict, text: str) -> None:
    """The per-flight table (Parquet, CSV), the report (text, JSON) and the plot."""
    out.mkdir(exist_ok=True)
    with files.output_file(out / OUTPUTS[0], "--out") as tmp:
        table.astype({"date": "string"}).to_parquet(tmp, index=False)
    files.write_text(out / OUTPUTS[1], table.to_csv(index=False), "--out")
    files.write_text(out / OUTPUTS[2], text + "\n", "--out")
    write_json({**summary, "flights_table": [r for r in _records(table)]},
               out / OUTPUTS[3], "--out")
    from planner.cli.plots.backtest import save_backtest_plot
    save_backtest_plot(table, out / OUTPUTS[4], "--out")
    print(f"per-flight table: {out / OUTPUTS[0]} and {OUTPUTS[1]}; report: {OUTPUTS[2]}, "
          f"{OUTPUTS[3]}; plot: {OUTPUTS[4]}")


def _records(table: pd.DataFrame):
    for r in table.to_dict("records"):
        yield {k: (None if isinstance(v, float) and not np.isfinite(v) else v)
               for k, v in r.items()}


def _line(name: str, s: dict, unit: str = "%") -> str:
    if not s.get("n"):
        return f"{name:<12} no flight scored"
    return (f"{name:<12} bias {s['bias_pct']:+6.1f} {unit}, median |error| "
            f"{s['median_abs_pct']:5.1f} {unit}, P90 {s['p90_abs_pct']:5.1f} {unit}, "
            f"worst {s['max_abs_pct']:5.1f} {unit}  ({s['n']} flights)")


#: What each ``--kinematics`` choice flies, for the report.
_KINEMATICS = {"fitted": "with the navigation fitted per fold on the training flights "
                         "(spin-up, climb, acceleration and stop at each waypoint, two-rate "
                         "landing)",
               "file": "with the aircraft file's navigation: block (constant speed where it "
                       "has none)",
               "none": "at constant speed, leg by leg (no navigation model)"}


def _by(title: str, groups: dict | None) -> list[str]:
    """A table of errors by group (n, bias and median |error| in %), none without groups."""
    if not groups:
        return []
    return ["", f"{title}:"] + [
        f"  {k:>6}  n {g['n']:3d}  bias {g['bias_pct']:+6.1f} %  median |error| "
        f"{g['median_abs_pct']:5.1f} %" for k, g in groups.items()]


def _pack_line(models: list[str]) -> str:
    """What turned the power into charge: the one fold's pack model, or how many folds
    fitted their own."""
    if not models:
        return ""
    if len(models) == 1:
        return f"charge drawn by {models[0]}"
    first = models[0].removeprefix("the pack's integral model ")
    return (f"charge drawn by the pack's integral model of each fold ({len(models)} fits), "
            f"e.g. {first}")


def render(s: dict) -> str:
    """The report: the errors, who was left out and why, the worst flights, and the
    energy error against speed, payload, altitude and wind."""
    lines = [(f"Backtest of {s['flights']} flight(s): {s['scored']} scored, {s['left_out']} "
              f"left out; aircraft {s['aircraft']} calibrated per fold ({s['calibration']})"),
             f"plans flown {s['kinematics']}" if s.get("kinematics") else "",
             _pack_line(s.get("battery_models") or []),
             "",
             "prediction error (predicted − measured, % of measured):",
             _line("energy", s["energy"]), _line("charge", s["charge"]),
             _line("flight time", s["time"])]
    if s.get("cruise_power", {}).get("n"):
        lines.append(_line("cruise power", s["cruise_power"])
                     + ": level legs at constant speed")
    for name, b in s.get("band", {}).items():
        lines.append(f"{name} inside the P5-P95 band of check --uncertainty: {b['inside']} of "
                     f"{b['n']} flights ({b['coverage_pct']:.0f} %)")
    if s["scored"]:
        lines.append(f"verdicts: {', '.join(f'{k} {v}' for k, v in s['verdicts'].items())}; "
                     f"{s['landed_with_reserve']} of {s['scored']} flights landed with the "
                     "reserve (from a full pack)")
    if s["left_out"]:
        lines += ["", "left out:"] + [f"  {n:4d}  {why}"
                                      for why, n in s["left_out_reasons"].items()]
    if s.get("worst"):
        lines += ["", "worst flights (energy error):"] + [
            f"  {w['experiment']:>8}  energy {w['energy_error_pct']:+6.1f} %, time "
            f"{w['time_error_pct']:+6.1f} %  plan {w['plan']}" for w in s["worst"]]
    for col, title, unit in (("speed_ms", "speed", "m/s"), ("payload_kg", "payload", "kg"),
                             ("altitude_m", "altitude", "m"), ("wind_ms", "wind", "m/s")):
        lines += _by(f"energy error by {title} [{unit}]",
                     s.get("energy_error_against", {}).get(col))
        if col == "speed_ms":
            lines += _by("cruise power error by speed [m/s]",
                         s.get("cruise_power_against_speed"))
    lines += ["", f"wall time {s['elapsed_s']:.1f} s"]
    return "\n".join(lines)
