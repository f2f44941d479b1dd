"""``endurance select`` (rank a pack catalog for a mission) and ``endurance sweep``
(endurance against battery mass, range against payload)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from planner.io import files
from planner.cli.commands.common import (
    add_options, flags_for, fmt, name_width, output_path, parse_float, parse_fraction,
    parse_int, parse_mass, parse_payload, parse_temperature, parse_wind_option, plot_path,
    write_json)
from planner.chain.sizing import sortie_margin
from planner.cli.commands.route import (add_route_options, route_paths, write_route,
                                        write_sorties_route)
from planner.errors import InputError
from planner.physics.atmosphere import G
from planner.io.mission import NavDefaults, load_mission
from planner.parameters import default_battery_path, load_aircraft, load_battery, load_catalog


def register(sub) -> None:
    """Add the ``select`` and ``sweep`` commands with their options to the subcommand parsers
    ``sub``."""
    p = sub.add_parser("select", help="rank a battery-pack catalog for a mission",
                       description="Fly the mission with every pack of a catalog (pack mass "
                                   "included in the take-off mass), check the landing and "
                                   "return-home reserves, C rating, cell count, take-off "
                                   "mass and thrust, and rank the packs. Exit 0 = some pack "
                                   "is feasible, 1 = none is (sorties are proposed), "
                                   "2 = bad input.")
    add_options(p, mission="mission file: .yaml, QGroundControl .plan or Mission Planner "
                           ".waypoints/.txt", aircraft=True)
    p.add_argument("--packs", required=True,
                   help="catalog YAML with a 'packs:' list, or a folder of pack YAMLs")
    p.add_argument("--objective", default="mass", choices=("mass", "margin", "price"),
                   help="rank by lightest pack (default), largest landing margin "
                        "(as extra hover/loiter time) or lowest price")
    add_options(p, wind=True, temperature=True,
                reserve="landing reserve as a fraction of nominal capacity (default 0.2)",
                payload=True)
    p.add_argument("--min-thrust-to-weight", default="1.5",
                   help="multirotor: least max thrust / take-off weight (default 1.5; "
                        "needs multirotor.max_thrust_n in the aircraft file)")
    p.add_argument("--top", help="show only the best N packs in the table (JSON: all)")
    add_options(p, json="write the ranked packs as JSON to this file",
                plot="write a PNG of pack mass against landing margin")
    add_route_options(p, "the chosen pack's route (or the sorties, each in its colour)")
    p.add_argument("--no-sorties", action="store_true",
                   help="when no pack is feasible, do not plan sorties")
    p.add_argument("--sorties-out", metavar="DIR",
                   help="write one mission file per sortie into this folder (created), in "
                        "the mission's own format (.plan, .waypoints or YAML)")
    p.set_defaults(func=run_select, output_folders=("--sorties-out",))

    s = sub.add_parser("sweep", help="sizing sweeps: endurance vs battery mass, range vs "
                                     "payload",
                       description="battery-mass: hover/loiter time to the reserve against "
                                   "battery mass for a chemistry's specific energy, with the "
                                   "optimum mass fraction. payload: still-air range against "
                                   "payload for a pack. Tables to the terminal or CSV, plots "
                                   "as PNG.")
    s.add_argument("kind", choices=("battery-mass", "payload"), help="which sweep")
    add_options(s, aircraft=True, battery="pack YAML (default: the aircraft's); "
                                         "battery-mass: gives cells, chemistry, model and "
                                         "specific energy")
    s.add_argument("--chemistry", choices=("lipo", "liion"),
                   help="battery-mass: chemistry defaults (LiPo 150 Wh/kg at 3.7 V, Li-ion "
                        "220 Wh/kg at 3.6 V; assumed typical pack values)")
    s.add_argument("--specific-energy", help="battery-mass: pack specific energy [Wh/kg]")
    s.add_argument("--cells", help="battery-mass: cells in series")
    s.add_argument("--cell-voltage", help="battery-mass: nominal cell voltage [V]")
    s.add_argument("--range", dest="sweep_range",
                   help="LO:HI of battery mass (battery-mass) or payload (payload) [kg]")
    s.add_argument("--points", default=None, help="number of sweep points")
    add_options(s, payload="battery-mass: payload [kg] (default 0)", reserve=True,
                temperature=True)
    s.add_argument("--altitude", default=None, help="flight altitude above the site [m]")
    add_options(s, site_altitude="site altitude AMSL [m]",
                wind="battery-mass: SPEED@FROM_DEG during the hold",
                csv="write the full sweep table as CSV", plot="write a PNG of the sweep")
    s.set_defaults(func=run_sweep)


# --------------------------------------------------------------------------- select

def run_select(args) -> int:
    """``endurance select``: rank the catalog's packs on the mission and plan sorties when none
    suffices; returns 0 when a pack flies it, else 1."""
    from planner.chain import selection as sel
    from planner.chain.sizing import plan_long_mission

    json_out = output_path(args.json, "--json")
    plot_out = plot_path(args.plot)
    sorties_dir = sorties_folder(args.sorties_out, args.mission, args.no_sorties)
    reserve = parse_fraction(args.reserve, "--reserve")
    top = None if args.top is None else parse_int(args.top, "--top", 1, 10**9)
    min_tw = parse_float(args.min_thrust_to_weight, "--min-thrust-to-weight", 0.0, 20.0)
    aircraft = load_aircraft(args.aircraft)
    temperature = parse_temperature(args)
    payload = parse_payload(args, aircraft)
    wind = parse_wind_option(args, aircraft)
    packs = load_catalog(args.packs)
    mission = load_mission(args.mission, defaults=NavDefaults.of(aircraft))
    if not mission.legs:
        raise InputError(f"{args.mission}: the mission has no legs")
    map_out, kml_out = route_paths(args, mission)
    if payload is None:
        from planner.cli.commands.check import check_mission_payload
        check_mission_payload(mission, args.mission, aircraft)
    env = mission.environment
    if wind is not None:
        env = dataclasses.replace(env, wind_speed_ms=wind[0], wind_from_deg=wind[1])
    selection = sel.select_pack(mission, aircraft, packs, env, objective=args.objective,
                                reserve=reserve, temperature_c=temperature,
                                payload_kg=payload, min_thrust_to_weight=min_tw)
    e = selection.evaluation
    plan, plan_error = None, None
    if selection.best is None and not args.no_sorties:
        try:
            plan = plan_long_mission(mission, aircraft, packs, e, env, reserve=reserve,
                                     temperature_c=temperature, payload_kg=payload)
        except InputError as exc:
            plan_error = str(exc)
    print(render_selection(selection, args.packs, env, top))
    if plan is not None:
        print(render_plan(plan))
        if sorties_dir is not None:
            for path in write_sorties(plan, args.mission, sorties_dir,
                                      NavDefaults.of(aircraft)):
                print(f"wrote     {path}")
    elif plan_error:
        print(f"\nSorties   not possible: {plan_error}")
    if json_out:
        data = selection.to_dict()
        data["environment"] = dataclasses.asdict(env)
        data["catalog"] = str(args.packs)
        data["sorties"] = None if plan is None else plan.to_dict()
        if plan_error:
            data["sorties_error"] = plan_error
        write_json(data, json_out)
    if plot_out:
        from planner.cli.plots import select as plots_select
        plots_select.save_pareto_plot(
            selection, plot_out,
            title=f"{mission.name}: {aircraft.name}, {len(e)} packs "
                  f"({int(e.feasible.sum())} feasible)", plan=plan)
    if selection.best is not None:
        best = e.mission_result(selection.best)
        write_route(map_out, kml_out, best, mission,
                    title=f"{mission.name}: {best.battery}, {best.verdict}")
    elif plan is not None:
        write_sorties_route(map_out, kml_out, plan, mission,
                            title=f"{mission.name}: {plan.count} sorties with {plan.pack.name}")
    return 0 if selection.best is not None else 1


def render_selection(selection, catalog, env, top=None) -> str:
    """The ranked table and summary a pilot reads in the terminal."""
    e = selection.evaluation
    what = "hover" if e.aircraft_type == "multirotor" else "loiter"
    objective = {"mass": "lightest feasible pack", "margin": "largest landing margin",
                 "price": "cheapest feasible pack"}[selection.objective]
    lines = [f"Mission   {e.mission_name} ({e.duration_s / 60:.1f} min flown as planned)",
             f"Aircraft  {e.aircraft_name}, payload {e.payload_kg:.2f} kg"
             + (f", max take-off {e.max_takeoff_mass_kg:.2f} kg"
                if e.max_takeoff_mass_kg is not None else ""),
             (f"Catalog   {catalog}: "
              + (f"{len(e)} packs" if len(e) != 1 else "1 pack (a catalog of one)")
              + f", {int(e.feasible.sum())} feasible; "
              f"objective: {objective}"),
             f"Weather   wind {env.wind_speed_ms:.1f} m/s from {env.wind_from_deg:.0f}°"
             + (f", {env.temperature_c:.0f} °C" if env.temperature_c is not None else ", ISA")
             + f"; reserve {100 * e.reserve_fraction:.0f} %", ""]
    order = selection.order if top is None else selection.order[:top]
    names = [e.packs[i].name + (f" x{e.packs[i].count}" if e.packs[i].count > 1 else "")
             for i in order]
    w = name_width(names, "pack", 20)
    head = (f"{'#':>3} {'pack':<{w}} {'S':>2} {'mAh':>6} {'pack kg':>7} {'TOW kg':>6} "
            f"{'used mAh':>8} {'margin mAh':>10} {'margin min':>10} {'peak A':>6} "
            f"{'max A':>6}  status")
    lines += [head, "-" * len(head)]
    for r, (i, name) in enumerate(zip(order, names), 1):
        p = e.packs[i]
        if e.feasible[i]:
            status = "OK"
        else:
            reasons = e.reasons(i)
            status = f"{e.binding(i)}: {reasons[0] if reasons else ''}"
        lines.append(
            f"{r:>3} {name:<{w}} {p.cells_series:>2} {fmt(e.capacity_mah[i], 0, 6)} "
            f"{fmt(e.pack_mass_kg[i], 3, 7)} {fmt(e.takeoff_mass_kg[i], 2, 6)} "
            f"{fmt(e.charge_used_mah[i], 0, 8)} {fmt(e.margin_mah[i], 0, 10)} "
            f"{fmt(e.margin_time_s[i] / 60, 1, 10)} {fmt(e.peak_current_a[i], 1, 6)} "
            f"{fmt(e.max_current_a[i], 0, 6)}  {status}")
    if top is not None and top < len(e):
        lines.append(f"    ... {len(e) - top} more (--top to show them, --json for all)")
    lines.append("-" * len(head))
    for note in e.notes:
        lines.append(f"Note      {note}")
    lines.append("")
    if selection.best is not None:
        b = selection.best
        p = e.packs[b]
        lines.append(f"Best      {p.name}" + (f" x{p.count}" if p.count > 1 else "")
                     + f": {e.pack_mass_kg[b]:.3f} kg, take-off {e.takeoff_mass_kg[b]:.2f} kg,"
                     f" lands with {100 * e.remaining_fraction[b]:.1f} %, margin "
                     f"{e.margin_mah[b]:+.0f} mAh"
                     + (f" = {e.margin_time_s[b] / 60:+.1f} min of {what}"
                        if math.isfinite(e.margin_time_s[b]) else ""))
    else:
        lines.append("NO-GO     no single pack of the catalog flies the mission with the "
                     "reserves")
    return "\n".join(lines)


def sorties_folder(folder: str | None, mission_path: str, no_sorties: bool):
    """``--sorties-out``: a folder (created when the sorties are written; its parent must
    exist), for a mission format that can be written."""
    from planner.io.mission.writers import WRITERS

    if folder is None:
        return None
    if no_sorties:
        raise InputError("--sorties-out: cannot be given with --no-sorties")
    files.check_target(folder, "--sorties-out", folder=True)
    suffix = Path(mission_path).suffix.lower()
    if suffix not in WRITERS:
        raise InputError(f"--sorties-out: cannot write missions in the format of "
                         f"{mission_path} (expected .plan, .waypoints, .txt, .yaml or .yml)")
    return Path(folder)


def write_sorties(plan, mission_path: str, folder: Path, defaults) -> list[Path]:
    """One mission file per sortie, in the format of ``mission_path``, flying the speeds
    the sortie was planned at (``defaults``: the aircraft's own)."""
    from planner.io.mission import writers

    src = Path(mission_path)
    write = writers.WRITE[writers.WRITERS[src.suffix.lower()]]
    try:
        folder.mkdir(exist_ok=True)
    except OSError as exc:
        raise InputError(f"--sorties-out {folder}: cannot create the folder "
                         f"({exc.strerror or exc})") from None
    out = []
    for s in plan.sorties:
        text = write(s.mission, defaults=defaults)
        path = folder / f"{src.stem}_sortie{s.number}{src.suffix}"
        files.write_text(path, text, "--sorties-out")
        out.append(path)
    return out


def render_plan(plan) -> str:
    """The sortie plan in words: the fewest sorties, the pack, the margin policy and each
    sortie's legs, split points and charge [mAh]."""
    p = plan.pack
    lines = ["", f"Sorties   fewest: {plan.count} flight(s) with {p.name}"
             + (f" x{p.count}" if p.count > 1 else "")
             + f" ({p.total_mass_kg:.3f} kg); the charge bound allows no fewer than "
             f"{plan.lower_bound}" + (" — minimal" if plan.minimal else "")]
    for k, s in enumerate(plan.splits, 1):
        lines.append(f"Swap {k:<4} in {s.origin}, {100 * s.fraction:.0f} % along the leg "
                     f"(t = {s.time_s:.0f} s in the plan, {s.east_m:.0f} m E "
                     f"{s.north_m:.0f} m N, {s.altitude_m:.0f} m up)")
    for s in plan.sorties:
        r = s.result
        need, _ = sortie_margin(r, p)
        lines.append(f"Flight {s.number:<3}{len(s.mission.legs)} legs, "
                     f"{r.duration_s / 60:.1f} min, {r.charge_used_mah:.0f} mAh, margin "
                     f"{r.margin_mah:+.0f} mAh (policy ≥ {need:.0f} mAh): {r.verdict}")
    for note in plan.notes:
        lines.append(f"Note      {note}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- sweep

def _parse_range(text, default, aircraft=None, what="payload"):
    """``--range LO:HI`` [kg]; with ``aircraft``, HI at most its heaviest take-off (else
    the masses were typed in grams)."""
    if text is None:
        return default
    try:
        lo_s, hi_s = text.split(":")
        lo, hi = float(lo_s), float(hi_s)
    except ValueError:
        raise InputError(f"--range: expected LO:HI in kg, e.g. 0.2:3, got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo < 0 or hi <= lo:
        raise InputError(f"--range: expected 0 <= LO < HI, got {text!r}")
    if aircraft is not None:
        from planner.parameters.aircraft import in_grams

        bound, why = aircraft.heaviest_takeoff()
        if hi > bound:
            raise InputError(f"--range {text}: {hi:g} kg of {what} is more than {why} "
                             f"{bound:.3g} kg{in_grams(hi, bound) or '; expected kg'}")
    return lo, hi


def run_sweep(args) -> int:
    """``endurance sweep battery-mass|payload``: the endurance against battery mass, or the
    range against payload, as a table (and CSV, PNG); returns 0."""
    from planner.chain import sizing
    from planner.physics.mission import Environment

    csv_out = output_path(args.csv, "--csv")
    plot_out = plot_path(args.plot)
    reserve = parse_fraction(args.reserve, "--reserve")
    site = parse_float(args.site_altitude, "--site-altitude", -500.0, 9000.0, "m")
    aircraft = load_aircraft(args.aircraft)
    temperature = parse_temperature(args)
    env = Environment(temperature_c=temperature, site_altitude_m=site)
    wind = parse_wind_option(args, aircraft)
    if wind is not None:
        env = dataclasses.replace(env, wind_speed_ms=wind[0], wind_from_deg=wind[1])
    battery_path = args.battery or default_battery_path(aircraft)
    pack = load_battery(battery_path) if battery_path else None

    if args.kind == "battery-mass":
        altitude = parse_float(args.altitude or "0", "--altitude", 0.0, 10000.0, "m")
        chem = args.chemistry or (pack.chemistry if pack is not None else "lipo")
        defaults = sizing.CHEMISTRIES.get(chem, sizing.CHEMISTRIES["lipo"])
        cell_v = (parse_float(args.cell_voltage, "--cell-voltage", 1.0, 5.0)
                  if args.cell_voltage else defaults["cell_voltage_v"])
        if args.cells is not None:
            try:
                cells = int(args.cells)
            except ValueError:
                raise InputError(f"--cells: expected a whole number, got {args.cells!r}") \
                    from None
            if not 1 <= cells <= 40:
                raise InputError(f"--cells: expected 1..40, got {args.cells!r}")
        elif pack is not None:
            cells = pack.cells_series
        elif aircraft.cells_series_allowed:
            cells = aircraft.cells_series_allowed[0]
        else:
            cells = 4
        source = "given"
        if args.specific_energy is not None:
            e_spec = parse_float(args.specific_energy, "--specific-energy", 10.0, 1000.0)
        elif pack is not None and args.chemistry is None:
            e_spec = pack.capacity_mah / 1000.0 * pack.cells_series * cell_v / pack.mass_kg
            source = f"from {pack.name}"
        else:
            e_spec = defaults["specific_energy_wh_per_kg"]
            source = f"{chem} default (assumed)"
        model = (pack.model if pack is not None and not pack.model.literature
                 and pack.cells_series == cells and args.chemistry is None else None)
        payload = parse_mass(args.payload or "0", "--payload", aircraft)
        m0 = aircraft.empty_mass_kg + payload
        lo, hi = _parse_range(args.sweep_range, (0.05 * m0, 4.0 * m0), aircraft, "battery")
        lo = max(lo, 1e-3)
        n = 200 if args.points is None else parse_int(args.points, "--points", 3, 100_000)
        with flags_for(reserve="--reserve"):
            sweep = sizing.endurance_sweep(
                aircraft, np.linspace(lo, hi, n), specific_energy_wh_per_kg=e_spec,
                cells_series=cells, cell_voltage_v=cell_v, model=model,
                usable_fraction=pack.usable_fraction if pack is not None else 1.0,
                payload_kg=payload, reserve=reserve, environment=env, altitude_m=altitude,
                temperature_c=temperature)
        print(render_endurance(sweep, source, aircraft))
        if csv_out:
            _write_csv(sweep.to_frame(), csv_out)
        if plot_out:
            from planner.cli.plots import select as plots_select
            plots_select.save_endurance_plot(sweep, plot_out)
        return 0

    if args.payload is not None:
        raise InputError(f"--payload {args.payload}: the payload sweep varies the payload "
                         "over --range LO:HI (--payload is for the battery-mass sweep)")
    if pack is None:
        raise InputError(f"{args.aircraft}: no 'battery' key and no --battery given "
                         "(the payload sweep needs a pack)")
    altitude = parse_float(args.altitude or "50", "--altitude", 0.0, 10000.0, "m")
    free = (aircraft.max_takeoff_mass_kg - aircraft.empty_mass_kg - pack.total_mass_kg
            if aircraft.max_takeoff_mass_kg is not None else aircraft.empty_mass_kg)
    lo, hi = _parse_range(args.sweep_range, (0.0, max(free, 0.1 * aircraft.empty_mass_kg)),
                          aircraft, "payload")
    n = 41 if args.points is None else parse_int(args.points, "--points", 3, 100_000)
    with flags_for(reserve="--reserve"):
        sweep = sizing.range_sweep(aircraft, pack, np.linspace(lo, hi, n), reserve=reserve,
                                   environment=env, altitude_m=altitude,
                                   temperature_c=temperature)
    print(render_range(sweep, aircraft))
    if csv_out:
        _write_csv(sweep.to_frame(), csv_out)
    if plot_out:
        from planner.cli.plots import select as plots_select
        plots_select.save_range_plot(sweep, plot_out)
    return 0


def _write_csv(frame, path):
    files.write_text(path, frame.to_csv(index=False, float_format="%.6g"), "--csv")


def _rows(n, shown=15):
    return np.unique(np.linspace(0, n - 1, min(n, shown)).round().astype(int))


def _sweep_table(sweep, aircraft, columns) -> list[str]:
    """Up to 15 evenly spread rows of a sweep (:func:`_rows`) as a fixed-width table:
    ``columns`` (title with its unit, width, decimals, the frame's column or a function of
    the row), then the aircraft limits the row exceeds (:func:`_limits`)."""
    head = " ".join(f"{title:>{w}}" for title, w, _, _ in columns) + "  limits"
    lines = [head, "-" * len(head)]
    f = sweep.to_frame()
    for i in _rows(len(f)):
        r = f.iloc[i]
        cells = " ".join(f"{(v(r) if callable(v) else r[v]):>{w}.{d}f}"
                         for _, w, d, v in columns)
        lines.append(f"{cells}  {_limits(aircraft, r)}")
    return lines + ["-" * len(head)]


def _limits(aircraft, row, min_thrust_to_weight: float = 1.5) -> str:
    """``ok``, or the aircraft limits a row of a sweep exceeds, named with their values
    (the sweeps' defaults: maximum take-off mass, least thrust-to-weight 1.5)."""
    if row.feasible:
        return "ok"
    out = []
    mtow = getattr(aircraft, "max_takeoff_mass_kg", None)
    if mtow is not None and row.takeoff_mass_kg > mtow:
        out.append(f"take-off mass over the {mtow:.2f} kg maximum")
    thrust = (aircraft.multirotor.max_thrust_n
              if aircraft is not None and aircraft.is_multirotor else None)
    if thrust is not None:
        tw = thrust / (row.takeoff_mass_kg * G)
        if tw < min_thrust_to_weight:
            out.append(f"thrust/weight {tw:.2f} below {min_thrust_to_weight:g}")
    return "; ".join(out) or "exceeds the take-off mass or thrust limit"


def render_endurance(sweep, source, aircraft=None) -> str:
    """The endurance–battery-mass sweep as a table with its optimum (within and beyond the
    aircraft's limits) and notes."""
    o = sweep.optimum
    lines = [f"Aircraft  {sweep.aircraft}, payload {sweep.payload_kg:g} kg",
             (f"Battery   {sweep.cells_series}S at {sweep.cell_voltage_v:g} V/cell, "
              f"{sweep.specific_energy_wh_per_kg:.0f} Wh/kg ({source}); reserve "
              f"{100 * sweep.reserve_fraction:.0f} %"), ""]
    lines += _sweep_table(sweep, aircraft, [
        ("battery kg", 10, 3, "battery_mass_kg"), ("fraction", 8, 2, "mass_fraction"),
        ("TOW kg", 7, 2, "takeoff_mass_kg"), ("mAh", 7, 0, "capacity_mah"),
        ("power W", 8, 1, "hold_power_w"), (sweep.hold + " min", 11, 1, "endurance_min")])
    free = (f"{o['battery_mass_kg']:.3f} kg of battery (mass fraction "
            f"{o['mass_fraction']:.2f}): {o['endurance_s'] / 60:.1f} min of {sweep.hold}")
    if o.get("constrained_battery_mass_kg") is None:
        lines.append("Optimum   none: no swept battery mass is within the take-off mass and "
                     "thrust limits")
        lines.append(f"Unlimited {free}, beyond the aircraft's limits")
    elif abs(o["constrained_battery_mass_kg"] - o["battery_mass_kg"]) > 1e-6:
        mb = o["constrained_battery_mass_kg"]
        lines.append(f"Optimum   {mb:.3f} kg of battery (mass fraction "
                     f"{mb / (mb + sweep.takeoff_mass_kg[0] - sweep.battery_mass_kg[0]):.2f}): "
                     f"{o['constrained_endurance_s'] / 60:.1f} min of {sweep.hold}, "
                     "the most within the take-off mass and thrust limits")
        lines.append(f"Unlimited {free}, beyond the aircraft's limits")
    else:
        lines.append(f"Optimum   {free}, within the take-off mass and thrust limits")
    for note in sweep.notes:
        lines.append(f"Note      {note}")
    return "\n".join(lines)


def render_range(sweep, aircraft=None) -> str:
    """The range–payload sweep as a table with its notes."""
    lines = [(f"Aircraft  {sweep.aircraft} with {sweep.pack}; reserve "
              f"{100 * sweep.reserve_fraction:.0f} %"), ""]
    lines += _sweep_table(sweep, aircraft, [
        ("payload kg", 10, 3, "payload_kg"), ("TOW kg", 7, 2, "takeoff_mass_kg"),
        ("power W", 8, 1, "cruise_power_w"), ("range km", 9, 2, "range_km"),
        ("best V m/s", 10, 1, "best_range_speed_ms"), ("best km", 8, 2, "best_range_km"),
        ("hold min", 8, 1, lambda r: r.hold_endurance_s / 60)])
    for note in sweep.notes:
        lines.append(f"Note      {note}")
    return "\n".join(lines)
