"""``endurance diagnose``: what the models get wrong on measured data, the cause, the gain.

Argparse and printing only; the work is done by :func:`planner.identify.diagnose.diagnose`.
"""

from __future__ import annotations

from pathlib import Path

import yaml

from planner.io import files
from planner.cli.commands.common import (add_options, add_battery_instance, battery_instance,
                                         output_path, parse_float, parse_mass, plot_path,
                                         write_json)
from planner.errors import InputError
from planner.parameters import aircraft_from_mapping, battery_from_mapping


def register(sub) -> None:
    """Add the ``diagnose`` command with its options to the subcommand parsers ``sub``."""
    from planner.identify.diagnose.effects import EFFECTS

    p = sub.add_parser(
        "diagnose", help="find what the models get wrong, name the cause, measure the gain",
        description="Calibrate the integral capacity model (and, with --aircraft, the power "
                    "model) on training splits of the data, then fit each candidate effect ("
                    + ", ".join(EFFECTS) + ") and keep only those whose gain on held-out "
                    "experiments or time blocks is statistically and practically significant "
                    "(docs/commands.md).")
    p.add_argument("data", nargs="+", metavar="DATA",
                   help="flight-record CSV files or logs (.bin, .px4log, .tlog, .ulg, mapped CSV)")
    add_options(p, battery="battery-pack YAML flown (start values of the integral model; "
                           "default: the aircraft's pack, else the literature model for the "
                           "log's cell count)",
                aircraft={"required": False,
                          "help": "aircraft YAML: enables the power-level effects"},
                map=True)
    add_battery_instance(p)
    p.add_argument("--json", help="write the findings as JSON (docs/commands.md); - for standard "
                                  "output")
    p.add_argument("--plot", help="write a PNG: residuals against time and against each "
                                  "finding's driver, before and after")
    p.add_argument("--out", help="write the extended battery YAML (capacity-level findings; "
                                 "or the aircraft YAML when only power-level effects are "
                                 "found; both: the aircraft goes to <stem>_aircraft.yaml)")
    add_options(p, payload="payload carried at take-off [kg] by every flight (default: each "
                            "flight's payload_kg in the data, else 0)",
                mass="all-up mass at take-off [kg] (overrides aircraft + pack + payload)",
                site_altitude="site altitude AMSL [m] of the standard (ISA) density "
                              "(default 0)")
    p.add_argument("--effects", help="comma-separated subset of the effects to test")
    p.set_defaults(func=run)


def run(args) -> int:
    """``endurance diagnose``: search the records for what the models miss and print the
    findings, their evidence and the detection limits; returns 0."""
    from planner.identify.diagnose import diagnose, load_definitions

    json_out = output_path(args.json, "--json")
    plot_out = plot_path(args.plot)
    out = output_path(args.out, "--out")
    site = parse_float(args.site_altitude, "--site-altitude", -500.0, 9000.0, "m")
    effects = [s.strip() for s in args.effects.split(",") if s.strip()] if args.effects \
        else None
    pack, aircraft = load_definitions(args.battery, args.aircraft)
    if args.payload is None:
        payload = None          # each flight's own payload_kg where the data give one
    elif aircraft is not None:
        payload = parse_mass(args.payload, "--payload", aircraft)
    else:
        payload = parse_float(args.payload, "--payload", 0.0, 1000.0, "kg")
    if aircraft is not None:
        mass = (parse_mass(args.mass, "--mass", aircraft, "all-up mass", 0.01, 1.5)
                if args.mass else None)
    else:
        mass = parse_float(args.mass, "--mass", 0.01, 10000.0, "kg") if args.mass else None
    if out and pack is None and aircraft is None:
        raise InputError("--out needs --battery or --aircraft (the definition to extend)")
    result = diagnose(list(args.data), pack, aircraft, payload_kg=payload, mass_kg=mass,
                      site_altitude_m=site, effects=effects, column_map=args.map,
                      battery_instance=battery_instance(args))
    print(result.summary())
    if json_out:
        write_json(result.to_dict(), json_out)
        print(f"wrote {json_out}")
    if plot_out:
        from planner.cli.plots.diagnose import save_diagnose_plot
        save_diagnose_plot(result, plot_out)
        print(f"wrote {plot_out}")
    if out:
        for path in write_extended(result, out):
            print(f"wrote {path}")
    return 0


def write_extended(result, out) -> list[str]:
    """Write the extended pack (and/or aircraft) YAML; returns the paths written."""
    levels = {f["level"] for f in result.findings}
    pack = result.extended_pack() if result.pack is not None else None
    aircraft = result.extended_aircraft()
    targets = []
    if pack is not None and ("capacity" in levels or aircraft is None or "power" not in levels):
        targets.append(("battery", pack, Path(out)))
        if aircraft is not None and "power" in levels:
            targets.append(("aircraft", aircraft,
                            Path(out).with_name(Path(out).stem + "_aircraft.yaml")))
    elif aircraft is not None:
        targets.append(("aircraft", aircraft, Path(out)))
    if not targets:
        raise InputError(f"--out {out}: no level could be calibrated, nothing to write")
    written = []
    names = ", ".join(f["effect"] for f in result.findings) or "no effect found"
    for kind, obj, path in targets:
        if kind == "battery":
            mapping = obj.to_mapping(folder=path.parent)
            mapping["source"] = obj.model.source
            battery_from_mapping(mapping, str(path))        # what we write must load back
        else:
            mapping = obj.to_mapping(folder=path.parent)
            aircraft_from_mapping(mapping, str(path))
        header = (f"# written by endurance diagnose ({names}); "
                  f"{kind} parameters calibrated and extended on {', '.join(result.sources)}\n")
        extra = _unstored(result, kind)
        if extra:
            header += "".join(f"# not stored in the schema: {line}\n" for line in extra)
        files.write_text(path, header + yaml.safe_dump(mapping, sort_keys=False,
                                                       allow_unicode=True), "--out")
        written.append(str(path))
    return written


def _unstored(result, kind) -> list[str]:
    """Findings the YAML schema cannot hold (so the file says so)."""
    lines = []
    for f in result.findings:
        p = f["parameters"]
        if kind == "aircraft" and f["effect"] == "wind":
            lines.append(f"wind {p['wind_speed_ms']:.1f} m/s from {p['wind_from_deg']:.0f}° "
                         f"(weather, not aircraft: check --wind "
                         f"{p['wind_speed_ms']:.1f}@{p['wind_from_deg']:.0f})")
        if kind == "aircraft" and f["effect"] == "payload_change":
            lines.append(f"payload change {p['mass_step_kg']:+.3f} kg in flight")
        if kind == "aircraft" and f["effect"] == "air_density":
            lines.append(f"air density exponent {p['density_exponent']:.2f} (check "
                         "--temperature and the site altitude)")
        if kind == "battery" and f["effect"] == "current_offset":
            lines.append(f"current sensor offset {p['current_offset_a']:+.3f} A (a logger "
                         "property; δ, ε, β here are free of it)")
    return lines
