"""``endurance fit-aircraft``: identify an aircraft's power parameters from flights."""

from __future__ import annotations

import warnings
from pathlib import Path

import yaml

from planner.io import files
from planner.cli.commands.common import (add_options, add_battery_instance, battery_instance,
                                         flight_payloads, fmt, mass_text, output_path,
                                         parse_float, parse_mass, plot_path, write_json)
from planner.io.flightdata import load_flight_data
from planner.errors import InputError
from planner.parameters import default_battery_path, load_aircraft, load_battery


def register(sub) -> None:
    """Add the ``fit-aircraft`` command with its options to the subcommand parsers ``sub``."""
    p = sub.add_parser("fit-aircraft", help="fit efficiency, drag and system load to flights",
                       description="Fit the aircraft's power parameters (multirotor: η, drag "
                                   "area, P_S; multirotor with power_model rotor_losses: "
                                   "P_stop measured on the ground, motor no-load and copper "
                                   "losses, figure of merit, drag area, power lead; "
                                   "fixed-wing: C_D0, K, η by the energy-rate balance, P_S "
                                   "measured in the glides) to the measured "
                                   "power of logged flights, and validate on flights (or the "
                                   "last 30 %% of one flight) the fit never saw. Exit 1 when "
                                   "a parameter ends on its bound or outside its physical "
                                   "range (a misfit, written as fit_status, with the likely "
                                   "cause).")
    p.add_argument("data", nargs="+", metavar="DATA", help="logs or flight-record CSV files")
    add_options(p, aircraft="aircraft YAML (start values)",
                out={"required": True, "help": "write the fitted aircraft YAML here"},
                battery="pack flown (default: the aircraft's)",
                payload="payload mass [kg] of every flight (default: each flight's own "
                        "payload_kg in the data, else 0)",
                mass=True, map=True)
    add_battery_instance(p)
    p.add_argument("--parameters", help="comma-separated subset to fit")
    p.add_argument("--train", help="comma-separated experiments to fit on")
    p.add_argument("--validate", help="comma-separated experiments to hold out")
    add_options(p, site_altitude="site altitude AMSL [m] for ISA density when not logged")
    p.add_argument("--airborne-height", help="airborne = more than this many metres above "
                                             "each flight's first sample (default: the "
                                             "flight phases other than ground and take-off)")
    add_options(p, json="write the fit report as JSON",
                plot="fixed wing: write a PNG of the fitted power curve and polar over the "
                     "energy-rate corrected samples")
    p.set_defaults(func=run)


def _list(text):
    return [s.strip() for s in text.split(",") if s.strip()] if text else None


def run(args) -> int:
    """``endurance fit-aircraft``: fit the aircraft's power model to flight records and write
    the aircraft file; returns 0, or 1 when the fit is a misfit (``fit_status``)."""
    from planner.identify.aircraft_fit import fit_aircraft

    json_out = output_path(args.json, "--json")
    plot_out = plot_path(args.plot)
    output_path(args.out, "--out")
    aircraft = load_aircraft(args.aircraft)
    fixed_wing = aircraft.type == "fixed_wing"
    if plot_out and not fixed_wing:
        raise InputError("--plot: the figure is drawn for a fixed wing's fit")
    if args.mass is not None:
        mass = parse_mass(args.mass, "--mass", aircraft, "all-up mass", 0.01, 1.5)
    else:
        path = args.battery or default_battery_path(aircraft)
        if path is None:
            raise InputError(f"{args.aircraft}: no pack known: give --battery or --mass")
        if args.payload is not None:
            parse_mass(args.payload, "--payload", aircraft)
        base = aircraft.empty_mass_kg + load_battery(path).total_mass_kg
    site = parse_float(args.site_altitude, "--site-altitude", -500, 9000, "m")
    data, _ = load_flight_data(args.data, column_map=args.map,
                               battery_instance=battery_instance(args))
    if args.mass is None:
        payload = flight_payloads(data, args.payload, "--payload", aircraft)
        mass = ({k: base + v for k, v in payload.items()} if isinstance(payload, dict)
                else base + payload)
        if fixed_wing and isinstance(mass, dict):
            raise InputError("--payload: the fixed-wing fit flies one mass; the data give a "
                             "payload per flight: give --payload or --mass")
    opts = {"airborne_height_m": None if args.airborne_height is None else
            parse_float(args.airborne_height, "--airborne-height", 0.0, 1000.0)}
    fit = fit_aircraft
    if fixed_wing:
        # real fixed-wing flights: the energy-rate fit (planner.identify.fixed_wing_fit)
        from planner.identify.fixed_wing_fit import fit_fixed_wing
        from planner.parameters.aircraft import aspect_ratio_of
        if opts.pop("airborne_height_m") is not None:
            raise InputError("--airborne-height: a fixed wing is airborne above its minimum "
                             "airspeed (its stall speed)")
        fit, opts = fit_fixed_wing, {"aspect_ratio": aspect_ratio_of(args.aircraft)}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = fit(data, aircraft, mass_kg=mass, parameters=_list(args.parameters),
                         train=_list(args.train), validate=_list(args.validate),
                         site_altitude_m=site, **opts)
        except InputError as exc:
            if not str(exc).startswith("no airborne samples"):
                raise
            # the data as a whole have none: name the files they came from
            raise InputError(f"{', '.join(str(d) for d in args.data)}: {exc}") from None
    for w in caught:
        print(f"warning: {w.message}")
    if fixed_wing:
        from planner.cli.commands import fixed_wing_report
        print(fixed_wing_report.render(result, mass))
    else:
        print(render(result, mass))
    fitted = result["aircraft"]
    mapping = fitted.to_mapping(folder=Path(args.out).parent)
    src = ", ".join(str(d) for d in args.data)
    mapping["source"] = (f"fit-aircraft on {src} ({result['split']}; "
                         f"{result['samples']['train']} airborne samples; mass "
                         f"{mass_text(mass)}); "
                         f"start values from {args.aircraft}")
    if fixed_wing:
        from planner.identify.fixed_wing_fit import fitted_mapping
        mapping = fitted_mapping(mapping, result)
    else:
        mapping["fit_status"] = result.get("fit_status", "ok")
    files.write_text(args.out, yaml.safe_dump(mapping, sort_keys=False, allow_unicode=True),
                     "--out")
    if json_out:
        report = {k: v for k, v in result.items() if k not in ("aircraft", "samples_table")}
        report["mass_kg"] = mass      # one value, or one per flight
        write_json(report, json_out)
    if plot_out:
        from planner.cli.commands import fixed_wing_report
        fixed_wing_report.save_plot(result, mass, plot_out)
    return 1 if result.get("fit_status", "ok") != "ok" else 0


def render(r, mass) -> str:
    """The aircraft fit's report: experiments used and held out, each parameter with its
    standard error and unit, the fit's status and the errors on the held-out flights at
    take-off mass ``mass`` [kg]."""
    n_all = len(r.get("experiments", r["train_experiments"]))
    held = ", ".join(r["validation_experiments"][:5]) or "none"
    lines = [f"Fit on {len(r['train_experiments'])} of {n_all} experiment(s) "
             f"({', '.join(r['train_experiments'][:5])}"
             f"{' …' if len(r['train_experiments']) > 5 else ''}), "
             f"{r['samples']['train']} airborne samples, mass {mass_text(mass)}; validation: "
             f"{r['split']} ({held}{' …' if len(r['validation_experiments']) > 5 else ''}; "
             f"{r['samples']['validation']} samples)", ""]
    width = max([19] + [len(k) for k in (*r["parameters"], *r.get("held", {}))])
    lines.append(f"{'parameter':<{width}} {'start':>10} {'fitted':>10} {'± stderr':>10}")
    units = {"no_load_power_w": "W", "copper_loss_power_w": "W", "drag_area_m2": "m²",
             "tilt_drag_area_m2": "m²", "system_power_w": "W"}
    for k, v in r["parameters"].items():
        if k in r.get("at_bound", ()):
            lines.append(f"{k:<{width}} {fmt(r['start'][k], 4, 10)} {'—':>10} {'—':>10}  "
                         f"ended on its bound ({v:.4g}): a misfit of the model's form, not a "
                         "value")
            continue
        flag = "  poorly determined" if k in r["poorly_determined"] else ""
        lines.append(f"{k:<{width}} {fmt(r['start'][k], 4, 10)} {fmt(v, 4, 10)} "
                     f"{fmt(r['stderr'][k], 4, 10)} {units.get(k, ''):<2}{flag}")
    for k, why in r.get("held", {}).items():
        lines.append(f"{k:<{width}} {why}")
    tilt = r.get("tilt", {})
    if "value" in tilt:
        lines.append(f"tilt_drag_area_m2: the drag the rotor disks' measured tilt balances, "
                     f"read on {tilt['samples']} steady level samples of {tilt['flights']} "
                     "flight(s) (axial speed); drag_area_m2 is the drag the tilt does not show")
    if "stopped_power" in r:
        sp = r["stopped_power"]
        lines.append(f"system_power_w (rotors stopped) {sp['value_w']:.1f} W: {sp['source']}")
        lines.append(f"power lead {r['lead_s']:g} s, chosen by the training RMS ("
                     + ", ".join(f"{k} s: {v:.1f} W" for k, v in
                                 r["lead_train_rmse_w"].items()) + ")")
        lines.append("standard errors cluster-robust, one cluster per flight")
    lines.append("")
    if "free_fit" in r:
        free = r["free_fit"]["parameters"]
        lines.append("free fit, not written: " + ", ".join(
            f"{k} {v:.4g}" for k, v in free.items()))
    for split in ("train", "validation"):
        if split in r:
            b, a = r[split]["before"], r[split]["after"]
            lines.append(f"{split:<10} power RMSE {b['rmse_w']:7.1f} → {a['rmse_w']:7.1f} W, "
                         f"energy error {b['energy_error_pct']:+6.1f} → "
                         f"{a['energy_error_pct']:+6.1f} %")
    if r.get("energy_error_sd") is not None:
        lines.append(f"training flights: RMS energy error {100 * r['energy_error_sd']:.1f} % "
                     f"over {r['energy_error_flights']} flight(s), written as energy_error_sd "
                     "(the power error check --uncertainty draws)")
    if "per_experiment_energy_error_pct" in r:
        after = r["per_experiment_energy_error_pct"]["after"]
        vals = sorted(after.values())
        if vals:
            lines.append(f"held-out flights: energy error after the fit, median "
                         f"{vals[len(vals) // 2]:+.1f} %, range {vals[0]:+.1f} … "
                         f"{vals[-1]:+.1f} % over {len(vals)} flight(s)")
    lines.append(f"fit_status: {r.get('fit_status', 'ok')}")
    return "\n".join(lines)
