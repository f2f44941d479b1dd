"""``endurance replay``: predicted vs measured for a real log."""

from __future__ import annotations

import math
import sys

from planner.cli.commands.common import (add_options, add_battery_instance, battery_instance,
                                         flight_payloads, fmt, name_width, output_path,
                                         parse_float, parse_fraction, plot_path,
                                         write_json)
from planner.io.flightdata import load_flight_data
from planner.parameters import load_aircraft, load_battery


def register(sub) -> None:
    """Add the ``replay`` command with its options to the subcommand parsers ``sub``."""
    p = sub.add_parser("replay", help="predicted vs measured power and charge for real logs",
                       description="Drive the battery model with the measured power (and, "
                                   "with --aircraft, the power model with the measured "
                                   "flight state) and compare with what the battery gave.")
    p.add_argument("logs", nargs="+", metavar="LOG",
                   help="log files (.bin, .px4log, .tlog, .ulg, a folder or zip of PX4 topic "
                        "CSV files) or flight-record CSV")
    add_options(p, aircraft={"required": False,
                             "help": "aircraft YAML: enables the power-level comparison"},
                battery="battery-pack YAML (default: the literature model for the log's "
                        "cell count)",
                map="column map YAML for CSV data that is not a flight record")
    add_battery_instance(p)
    add_options(p, payload="payload mass [kg] of every flight (default: each flight's own "
                           "payload_kg in the data, else 0)",
                reserve=True,
                site_altitude="site altitude AMSL [m] for ISA density when the log has no "
                              "pressure and temperature (default 0)",
                json="write the comparison as JSON",
                plot="write a PNG: measured vs predicted power and charge")
    p.add_argument("--csv", metavar="F",
                   help="write the flight record with the per-sample predicted power (W) "
                        "and charge (mAh) beside the measured ones")
    p.set_defaults(func=run)


def run(args) -> int:
    """``endurance replay``: predict each logged flight's charge, energy and voltage from its
    own power and compare with the log; returns 0 (2 when no flight can be replayed)."""
    from planner.identify.replay import replay

    json_out = output_path(args.json, "--json")
    plot_out = plot_path(args.plot)
    csv_out = output_path(args.csv, "--csv")
    reserve = parse_fraction(args.reserve, "--reserve")
    site = parse_float(args.site_altitude, "--site-altitude", -500.0, 9000.0, "m")
    aircraft = load_aircraft(args.aircraft) if args.aircraft else None
    if args.payload is not None:   # checked before the data are read
        flight_payloads(None, args.payload, "--payload", aircraft)
    pack = load_battery(args.battery) if args.battery else None
    if aircraft is not None and pack is None and aircraft.battery_path:
        from planner.parameters import default_battery_path
        pack = load_battery(default_battery_path(aircraft))
    failed: list[str] = []
    data, metas = load_flight_data(args.logs, column_map=args.map, failed=failed,
                                   battery_instance=battery_instance(args))
    for message in failed:  # a batch: each bad file named, the others replayed
        print(f"error: {message}", file=sys.stderr)
    payload = flight_payloads(data, args.payload, "--payload", aircraft)
    result = replay(data, metas, pack=pack, aircraft=aircraft, payload_kg=payload,
                    reserve=reserve, site_altitude_m=site)
    print(render(result))
    if json_out:
        write_json(result.to_dict(), json_out)
    if csv_out:
        from planner.io.record import write_record
        from planner.identify.replay import replay_table
        from planner.io.record import has_power
        write_record(replay_table(data, result), csv_out, require_power=has_power(data),
                     option="--csv")
    if plot_out:
        from planner.cli.plots import common as plots
        written = plots.save_replay_plot(result, plot_out)
        if len(written) > 1:
            print(f"wrote     {', '.join(map(str, written))} ({len(written)} pages of at "
                  f"most {plots.PER_PAGE} logs)")
    if failed:
        print(f"error: {len(failed)} of {len(args.logs)} files could not be read (named "
              "above); the others were replayed", file=sys.stderr)
        return 2
    return 0


def time_error_lines(e) -> list[str]:
    """The pilot's check of one log: had the model been asked at 25/50/75 % of the flight
    when the log's final charge would be drawn (at the mean power of the 60 s before),
    how far off the real end it was; a miss longer than the flight is explained by the
    power it assumed."""
    b = e.battery
    te = b.time_error_s
    if not te:
        return []
    out = ["  time to draw the log's final charge at the power of the 60 s before each "
           "point, predicted − real: " + ", ".join(f"from {k.replace('pct', ' %')} "
                                                  f"{v:+.0f} s" for k, v in te.items())]
    far = [k for k, v in te.items() if abs(v) > e.duration_s]
    if far:
        pw = b.time_error_power_w
        out.append("  note: " + ", ".join(
            f"from {k.replace('pct', ' %')} the power assumed was {pw.get(k, math.nan):.0f} W"
            for k in far) + f" against {b.mean_power_w:.0f} W over the whole log: a "
            "prediction from a stretch unlike the rest of the flight misses by more than the "
            f"{e.duration_s:.0f} s flight")
    return out


def render(result) -> str:
    """The replay report: per flight its duration [s], the charge measured and predicted
    [mAh], the charge RMSE [mAh], the final charge error and the airborne energy error [%
    of measured] and the power RMSE [W], then the notes of each flight."""
    from planner.io.record import NO_CURRENT

    lines = ["Errors    measured − predicted throughout, in % of measured: final = charge "
             "drawn at the end ([UAV23] eq. 30), E = airborne energy"]
    w = name_width([e.experiment for e in result.experiments], "experiment")
    head = (f"{'experiment':<{w}} {'dur s':>6} {'meas mAh':>9} {'pred mAh':>9} "
            f"{'RMSE mAh':>9} {'final %':>8} {'P RMSE W':>9} {'E err %':>8}")
    lines += [head, "-" * len(head)]
    for e in result.experiments:
        b, p = e.battery, e.power
        if b is None and p is None and any(n.startswith(NO_CURRENT) for n in e.notes):
            lines.append(f"{e.experiment:<{w}} {fmt(e.duration_s, 0, 6)}  {NO_CURRENT}")
            continue
        lines.append(
            f"{e.experiment:<{w}} {fmt(e.duration_s, 0, 6)} "
            f"{fmt(b.measured_final_mah if b else math.nan, 0, 9)} "
            f"{fmt(b.predicted_final_mah if b else math.nan, 0, 9)} "
            f"{fmt(b.rmse_mah if b else math.nan, 1, 9)} "
            f"{fmt(b.final_error_pct if b else math.nan, 2, 8)} "
            f"{fmt(p.rmse_w if p else math.nan, 1, 9)} "
            f"{fmt(-p.energy_error_pct if p else math.nan, 1, 8)}")
    lines.append("-" * len(head))
    for e in result.experiments:
        if not e.battery and e.notes:
            lines.append(f"{e.experiment}:")
        if e.battery:
            lines.append(f"{e.experiment}: battery model {e.battery.model}")
            lines += time_error_lines(e)
            if e.battery.measured_final_mah < 0:
                lines.append(f"  note: the log's consumed-charge counter ends at "
                             f"{e.battery.measured_final_mah:.0f} mAh, below zero: a current "
                             "sensor offset or a counter reset; its battery errors mean "
                             "little and it carries no weight in the overall figure")
            if e.battery.reserve_reached_s is not None:
                lines.append(f"  reserve reached at {e.battery.reserve_reached_s:.0f} s")
        if e.power:
            lines.append(f"  power model driven by {e.power.airspeed_source}; density from "
                         f"{e.power.density_source}")
            for name, ph in e.power.phases.items():
                # no error where the measured power gives none to divide by
                err = (f"{-ph['error_pct']:+.1f} %" if math.isfinite(ph["error_pct"])
                       else "– %")
                lines.append(f"    {name:<8} {ph['duration_s']:6.0f} s  measured "
                             f"{ph['measured_w']:7.1f} W  predicted {ph['predicted_w']:7.1f} W "
                             f" ({err})")
        for note in e.notes:
            lines.append(f"  note: {note}")
    o = result.overall
    if "battery" in o and not (ob := o["battery"])["logs_weighted"]:
        rmse = (f"RMSE {ob['rmse_mah']:.1f} mAh; " if math.isfinite(ob["rmse_mah"]) else "")
        lines.append(f"Overall battery: {rmse}no log has a measured charge to compare with "
                     "(no usable consumed_mah or current_a)")
    elif "battery" in o:
        ob = o["battery"]
        lines.append(f"Overall battery: RMSE {ob['rmse_mah']:.1f} mAh, final error "
                     f"{ob['final_error_pct']:+.2f} % (measured − predicted, of measured; "
                     f"weighted by the charge each log drew, {ob['logs_weighted']} log"
                     f"{'s' if ob['logs_weighted'] != 1 else ''}; unweighted mean "
                     f"{ob['unweighted_final_error_pct']:+.2f} %)")
    if "power" in o:
        lines.append(f"Overall power: RMSE {o['power']['rmse_w']:.1f} W, energy error "
                     f"{-o['power']['energy_error_pct']:+.1f} % (measured − predicted, of "
                     "measured)")
    return "\n".join(lines)
