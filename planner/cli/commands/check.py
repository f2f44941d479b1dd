"""``endurance check``: will this mission land with the reserve?"""

from __future__ import annotations

import dataclasses
import math

from planner.io import files
from planner.chain.mission_chain import MissionChain
from planner.chain.result import MissionResult
from planner.cli.commands.route import add_route_options, route_paths, write_route
from planner.cli.commands.summary_lines import endurance_line
from planner.cli.commands.common import (
    add_options, flags_for, fmt, output_path, parse_float, parse_fraction, parse_int,
    parse_mass, parse_payload, parse_temperature, parse_wind_option, plot_path, write_json)
from planner.errors import InputError
from planner.chain.failsafe import (
    FIRMWARES,
    PX4_STABLE_VERSION,
    FailsafePlan,
    failsafe_parameters,
    parse_firmware_version,
    px4_release,
)
from planner.io.mission import NavDefaults, load_mission
from planner.parameters import load_aircraft_and_battery
from planner.chain.uncertainty import (
    DEFAULT_FORECAST_SPREADS,
    DEFAULT_MODEL_ERROR_SD,
    MAX_DEFAULT_WEATHER_DRAWS,
    SAMPLES_PER_WEATHER_DRAW,
    Spreads,
    UncertaintyResult,
    monte_carlo,
)


def register(sub) -> None:
    """Add the ``check`` command with its options to the subcommand parsers ``sub``."""
    p = sub.add_parser("check", help="pre-flight endurance check: GO / NO-GO with margins",
                       description="Predict power and charge leg by leg and check the landing "
                                   "and return-home reserves. Exit 0 = GO, 1 = NO-GO, "
                                   "2 = bad input.")
    add_options(p, mission=True, aircraft=True, battery=True,
                wind="SPEED@FROM_DEG, e.g. 6@270: 6 m/s from the west (overrides the "
                     "mission's)",
                temperature="outside air temperature [°C] (overrides the mission's; "
                            "default ISA)",
                reserve="landing reserve as a fraction of nominal capacity (default 0.2 = "
                        "20%%)",
                payload=True, json=True, plot="write a PNG of power and remaining charge")
    add_route_options(p)
    p.add_argument("--failsafe", metavar="FIRMWARE",
                   help="derive the battery failsafe parameters of this firmware from the "
                        "mission's worst return home: ardupilot or px4")
    p.add_argument("--firmware-version", metavar="VERSION",
                   help="with --failsafe px4: the PX4 release whose threshold ranges and "
                        "failsafe hold apply, e.g. v1.14.3 (default: the current stable "
                        f"release, v{'.'.join(map(str, PX4_STABLE_VERSION))})")
    p.add_argument("--params-out", help="write the failsafe parameters as a Mission Planner "
                                        "/ MAVProxy .param file (ardupilot) or a "
                                        "QGroundControl parameter file (px4); not written "
                                        "when the failsafe plan is NO-GO")
    u = p.add_argument_group("probabilistic verdict (Monte Carlo through the mission chain)")
    u.add_argument("--uncertainty", action="store_true",
                   help="draw the uncertain inputs and give P(landing with the reserve); "
                        "GO when it is at least --confidence")
    u.add_argument("--samples", default="2000", help="Monte Carlo samples (default 2000)")
    u.add_argument("--weather-samples", metavar="N",
                   help="weather draws, one chain run each (default one per "
                        f"{SAMPLES_PER_WEATHER_DRAW} samples, at most "
                        f"{MAX_DEFAULT_WEATHER_DRAWS}: 400 of 2000); the probability moves "
                        "in steps of 1/N")
    u.add_argument("--seed", default="0", help="random seed: the same seed gives the same "
                                               "answer (default 0)")
    u.add_argument("--confidence", default="0.95",
                   help="required P(landing with the reserve) (default 0.95)")
    u.add_argument("--wind-sd", metavar="SPEED@DEG",
                   help="spread of the forecast wind: speed [m/s] @ direction [deg], one "
                        "standard deviation, e.g. 2@30; 0@0: not drawn (default "
                        f"{DEFAULT_FORECAST_SPREADS['wind_sd_ms'][0]:g}@{DEFAULT_FORECAST_SPREADS['wind_direction_sd_deg'][0]:g}, a "
                        "weather forecast's error, named in the output)")
    u.add_argument("--gust", metavar="F", help="gust factor: peak gust over mean wind (≥ 1), "
                                               "e.g. 1.4 for 10G14 kt")
    u.add_argument("--temperature-sd", metavar="C",
                   help="spread of the air temperature [°C], one standard deviation; 0: "
                        f"not drawn (default {DEFAULT_FORECAST_SPREADS['temperature_sd_c'][0]:g} °C, a weather "
                        "forecast's error, named in the output)")
    u.add_argument("--soh", metavar="F±SD",
                   help="pack state of health: share of its usable charge it still gives, "
                        "with a spread, e.g. 0.9±0.05 (or 0.9+-0.05)")
    u.add_argument("--payload-sd", metavar="KG", help="spread of the payload [kg], one "
                                                      "standard deviation")
    u.add_argument("--model-error-sd", metavar="F",
                   help="spread of the power model's own error, a fraction of the power "
                        "(0.05 or 5%%); 0: not drawn (default: the aircraft file's "
                        "energy_error_sd, which fit-aircraft writes, else "
                        f"{DEFAULT_MODEL_ERROR_SD:g})")
    p.add_argument("--quiet", action="store_true", help="print only the verdict line")
    p.set_defaults(func=run)


def run(args) -> int:
    """``endurance check``: fly the mission through the chain and print the verdict leg by leg
    (and the failsafe parameters, the Monte Carlo verdict, the map, if asked); returns 0 for
    GO, 1 for NO-GO."""
    json_out = output_path(args.json, "--json")
    params_out = output_path(args.params_out, "--params-out")
    firmware = parse_firmware(args.failsafe, params_out)
    version = parse_version(args.firmware_version, firmware)
    plot_out = plot_path(args.plot)
    reserve = parse_fraction(args.reserve, "--reserve")
    aircraft, pack = load_aircraft_and_battery(args.aircraft, args.battery)
    temperature = parse_temperature(args)
    payload = parse_payload(args, aircraft)
    wind = parse_wind_option(args, aircraft)
    mission = load_mission(args.mission, defaults=NavDefaults.of(aircraft))
    map_out, kml_out = route_paths(args, mission)
    env = mission.environment
    if wind is not None:
        env = dataclasses.replace(env, wind_speed_ms=wind[0], wind_from_deg=wind[1])
    if payload is not None:
        mission.payload_kg = payload
    else:
        check_mission_payload(mission, args.mission, aircraft)
    if not mission.legs:
        raise InputError(f"{args.mission}: the mission has no legs")
    if not args.uncertainty:
        alone = [f for d, f in _SPREAD_FLAGS.items() if getattr(args, _SPREAD_DEST.get(d, d),
                                                                None) is not None]
        if alone:
            raise InputError(f"{alone[0]}: a spread of the --uncertainty run, which was not "
                             f"asked for: give --uncertainty with it, or leave it out")
    spreads, mc = ((parse_spreads(args, aircraft), parse_mc(args)) if args.uncertainty
                   else (None, None))
    chain = MissionChain(aircraft, pack, reserve=reserve, temperature_c=temperature)
    unc = None
    if args.uncertainty:
        with flags_for(**_SPREAD_FLAGS, samples="--samples", confidence="--confidence",
                       weather_draws="--weather-samples"):
            unc = monte_carlo(chain, mission, env, spreads, **mc)
        run_result = unc.nominal
    else:
        run_result = chain.run(mission, env, detail=True)
    result = run_result.mission_result(0)
    plan = (failsafe_parameters(run_result, firmware, return_charge_mah=None if unc is None
                                else unc.rtl_charge_p95_mah, firmware_version=version)
            if firmware else None)
    if not args.quiet:
        print(render(result, mission.name))
        if unc is not None:
            print(render_uncertainty(unc))
        if plan is not None:
            print(render_failsafe(plan))
    else:
        print(result.verdict_line())
        if unc is not None:
            print(uncertainty_verdict_line(unc))
    if json_out:
        data = result.to_dict()
        data["mission"] = mission.name
        data["environment"] = dataclasses.asdict(result.environment)
        if plan is not None:
            data["failsafe"] = plan.to_dict()
        if unc is not None:
            data["uncertainty"] = unc.to_dict()
        write_json(data, json_out)
    if params_out and plan.go:
        header = (f"{FIRMWARE_NAMES[plan.firmware]} battery failsafe parameters for "
                  f"{mission.name}\n{result.aircraft}, {result.battery}\n"
                  f"reserve {100 * result.reserve_fraction:.0f} % of nominal; worst return "
                  f"{plan.return_charge_mah:.0f} mAh from {plan.worst_point['distance_home_m']:.0f}"
                  f" m ({plan.return_source})\nwritten by endurance check --failsafe")
        files.write_text(params_out, plan.param_file(header), "--params-out")
    if plot_out:
        from planner.cli.plots import common as plots
        title = f"{mission.name}: {result.verdict}" + (
            "" if unc is None else f"; {unc.verdict} with {100 * unc.confidence:.0f} % "
                                   f"confidence (P = {100 * unc.p_landing:.1f} %)")
        plots.save_mission_plot(result, plot_out, title=title, uncertainty=unc)
    write_route(map_out, kml_out, result, mission, title=f"{mission.name}: {result.verdict}")
    if plan is not None and not plan.go:
        return 1
    if unc is not None:
        return 0 if unc.go else 1
    return 0 if result.go else 1


def check_mission_payload(mission, path, aircraft) -> None:
    """The payload a mission file carries, within the heaviest take-off of the aircraft
    (else it was written in grams)."""
    from planner.parameters.aircraft import in_grams

    bound, why = aircraft.heaviest_takeoff()
    if mission.payload_kg > bound:
        raise InputError(f"{path}: payload_kg {mission.payload_kg:g} kg is more than {why} "
                         f"{bound:.3g} kg{in_grams(mission.payload_kg, bound) or '; expected kg'}")


def parse_spreads(args, aircraft=None) -> Spreads:
    """The ``--wind-sd``, ``--gust``, ``--temperature-sd``, ``--soh`` and ``--payload-sd``
    flags → :class:`~planner.chain.uncertainty.Spreads`."""
    wind_sd, dir_sd = (None, None)    # None: the default forecast spread
    if args.wind_sd is not None:
        try:
            a, b = args.wind_sd.split("@")
            wind_sd, dir_sd = float(a), float(b)
        except ValueError:
            raise InputError(f"--wind-sd: expected SPEED@DEG (standard deviations in m/s and "
                             f"degrees), e.g. 2@30, got {args.wind_sd!r}") from None
        if not (math.isfinite(wind_sd) and 0 <= wind_sd <= 30):
            raise InputError(f"--wind-sd: speed spread must be in [0, 30] m/s, got "
                             f"{args.wind_sd!r}")
        if not (math.isfinite(dir_sd) and 0 <= dir_sd <= 180):
            raise InputError(f"--wind-sd: direction spread must be in [0, 180] degrees, got "
                             f"{args.wind_sd!r}")
    gust = parse_float(args.gust, "--gust", 1.0, 5.0) if args.gust is not None else 1.0
    t_sd = (parse_float(args.temperature_sd, "--temperature-sd", 0.0, 30.0)
            if args.temperature_sd is not None else None)
    soh, soh_sd = 1.0, 0.0
    if args.soh is not None:
        text = args.soh.replace("+-", "±").replace("+/-", "±")
        try:
            parts = [float(x) for x in text.split("±")]
        except ValueError:
            parts = []
        if len(parts) not in (1, 2):
            raise InputError(f"--soh: expected F±SD, e.g. 0.9±0.05 (or 0.9+-0.05), got "
                             f"{args.soh!r}")
        soh, soh_sd = parts[0], (parts[1] if len(parts) == 2 else 0.0)
        if not (math.isfinite(soh) and 0 < soh <= 1.5 and math.isfinite(soh_sd)
                and soh_sd >= 0):
            raise InputError(f"--soh: expected a state of health in (0, 1.5] and a spread "
                             f"≥ 0, got {args.soh!r}")
    if args.payload_sd is None:
        pay_sd = 0.0
    elif aircraft is not None:      # a spread beyond the heaviest take-off: grams?
        pay_sd = parse_mass(args.payload_sd, "--payload-sd", aircraft, "payload spread")
    else:
        pay_sd = parse_float(args.payload_sd, "--payload-sd", 0.0, 100.0, "kg")
    model_sd = (parse_fraction(args.model_error_sd, "--model-error-sd")
                if args.model_error_sd is not None else None)
    return Spreads(wind_sd_ms=wind_sd, wind_direction_sd_deg=dir_sd, gust_factor=gust,
                   temperature_sd_c=t_sd, soh=soh, soh_sd=soh_sd, payload_sd_kg=pay_sd,
                   model_error_sd=model_sd)


def parse_mc(args) -> dict:
    """``--samples``, ``--weather-samples``, ``--seed``, ``--confidence`` → keyword
    arguments of :func:`~planner.chain.uncertainty.monte_carlo`."""
    conf = parse_fraction(args.confidence, "--confidence")
    if conf <= 0:
        raise InputError(f"--confidence: must be in (0, 1), got {args.confidence!r}")
    samples = parse_int(args.samples, "--samples", 20, 1_000_000)
    weather = (parse_int(args.weather_samples, "--weather-samples", 2, samples)
               if args.weather_samples is not None else None)
    return {"samples": samples, "weather_draws": weather,
            "seed": parse_int(args.seed, "--seed", 0, 2**63 - 1), "confidence": conf}


def uncertainty_verdict_line(u: UncertaintyResult) -> str:
    """The Monte Carlo verdict in one line: GO or NO-GO at the confidence asked, the
    probability [%] of landing with the reserve, samples and seed."""
    return (f"{u.verdict} with {100 * u.confidence:.0f} % confidence: P(landing with the "
            f"reserve) = {100 * u.p_landing:.1f} % "
            f"{'≥' if u.go else '<'} {100 * u.confidence:.0f} % ({u.samples} samples, seed "
            f"{u.seed})")


def render_uncertainty(u: UncertaintyResult) -> str:
    """The Monte Carlo block: probabilities and their resolution, percentiles, CVaR and the
    variance split with where every spread comes from."""
    lm, rm = u.landing_mah, u.rtl_margin_mah
    lines = ["", f"Uncertainty  Monte Carlo through the mission chain: {u.samples} samples, "
                 f"{u.weather_draws} weather draw{'s' if u.weather_draws > 1 else ''}, seed "
                 f"{u.seed}",
             f"  P(landing with the reserve)        {100 * u.p_landing:5.1f} %",
             f"  P(every return home with it too)   {100 * u.p_all_reserves:5.1f} %",
             f"  P resolution 1/{u.independent_draws} = {_pct(u.p_resolution)} % "
             f"({_resolution_of(u)})",
             f"  charge left on landing  P5 {lm['p5']:.0f}  P50 {lm['p50']:.0f}  P95 "
             f"{lm['p95']:.0f} mAh (reserve {u.reserve_mah:.0f} mAh); CVaR5 "
             f"{u.cvar5_landing_mah:.0f} mAh (mean of the worst 5 %)",
             f"  return-home margin      P5 {rm['p5']:+.0f}  P50 {rm['p50']:+.0f}  P95 "
             f"{rm['p95']:+.0f} mAh (smallest along the mission)",
             "  spread of the landing charge by input (Shapley shares of its variance, "
             "additive quadratic regression" + (f"; they sum to R² = {100 * u.r2:.1f} %):"
                                                 if math.isfinite(u.r2) else "):")]
    width = max(len(src["name"]) for src in u.sources)
    for src in u.sources:
        share = "" if src["share"] is None else f"{100 * src['share']:5.1f} %"
        lines.append(f"    {src['name']:<{width}}  {share:>7}  {src['spread']:<14} "
                     f"{_origin_flag(src['origin'])}")
    if u.driver:
        lines.append(f"  drives the spread most: {u.driver}")
    if u.coarse:
        lines.append(f"Warning   P moves in steps of {_pct(u.p_resolution)} %, more than a "
                     f"tenth of the {100 * (1 - u.confidence):g} % a GO leaves to failures: "
                     "raise --samples or --weather-samples")
    lines.append("")
    lines.append(uncertainty_verdict_line(u))
    return "\n".join(lines)


def _pct(fraction: float) -> str:
    """A probability step in per cent with its significant digits."""
    return f"{100 * fraction:.3g}"


def _resolution_of(u: UncertaintyResult) -> str:
    """Which draws set the probability's resolution."""
    if u.independent_draws == u.weather_draws and u.weather_draws > 1:
        return f"the weather drawn {u.weather_draws} times; --weather-samples"
    if u.independent_draws == u.samples:
        return f"{u.samples} samples"
    return f"{u.independent_draws} levels of the payload and power error; --samples"


FIRMWARE_NAMES = {"ardupilot": "ArduPilot", "px4": "PX4"}


def parse_firmware(text: str | None, params_out: str | None) -> str | None:
    """``--failsafe`` → firmware name (None without it); ``--params-out`` needs it."""
    if text is None:
        if params_out is not None:
            raise InputError("--params-out: needs --failsafe ardupilot or --failsafe px4")
        return None
    name = text.strip().lower()
    if name not in FIRMWARES:
        raise InputError(f"--failsafe: unknown firmware {text!r}: expected "
                         f"{' or '.join(FIRMWARES)}")
    return name


def parse_version(text: str | None, firmware: str | None):
    """``--firmware-version`` → (major, minor, patch) for ``--failsafe px4`` (None without
    it)."""
    if text is None:
        return None
    if firmware != "px4":
        raise InputError("--firmware-version: selects the PX4 release of --failsafe px4 "
                         "(the ArduPilot derivation follows one source, AP_BattMonitor)")
    try:
        version = parse_firmware_version(text)
        px4_release(version)
        return version
    except InputError as exc:
        raise InputError(f"--firmware-version: {exc}") from None


def render_failsafe(plan: FailsafePlan) -> str:
    """The failsafe parameters with one line of derivation each, and the plan's verdict."""
    w = plan.worst_point
    release = f" {plan.firmware_version}" if plan.firmware_version else ""
    lines = ["", f"Failsafe  {FIRMWARE_NAMES[plan.firmware]}{release} battery parameters: "
                 f"worst return {plan.return_charge_mah:.0f} mAh from "
                 f"{w['distance_home_m']:.0f} m ({w['leg_origin']}, t = {w['time_s']:.0f} s, "
                 f"{plan.return_source})"]
    width = max(len(p.name) for p in plan.parameters)
    for p in plan.parameters:
        value = f"{p.text_value()} {p.unit}".strip()
        lines.append(f"  {p.name:<{width}} = {value:<10} {p.derivation}")
    for text in plan.warnings:
        lines.append(f"Warning   {text}")
    for text in plan.reasons:
        lines.append(f"NO-GO     failsafe plan: {text}")
    if not plan.go:
        lines.append("NO-GO     no failsafe parameters of this firmware land with the reserve "
                     "(no parameter file is written)")
    return "\n".join(lines)


def render(r: MissionResult, name: str) -> str:
    """The per-leg table and summary a pilot reads in the terminal."""
    env = r.environment
    lines = [f"Mission   {name}",
             f"Aircraft  {r.aircraft}, take-off mass {r.takeoff_mass_kg:.3f} kg",
             f"Battery   {r.battery}: {r.capacity_mah:.0f} mAh nominal, "
             f"{r.usable_mah:.0f} mAh usable ({r.battery_model} integral model)",
             f"Weather   wind {env.wind_speed_ms:.1f} m/s from {env.wind_from_deg:.0f}°"
             + (f", air {env.temperature_c:.0f} °C" if env.temperature_c is not None
               else ", ISA air")
             + f", site {env.site_altitude_m:.0f} m AMSL", ""]
    head = (f"{'#':>3} {'leg':<8} {'time s':>7} {'dist m':>7} {'TAS m/s':>7} {'GS m/s':>6} "
            f"{'vz m/s':>6} {'power W':>8} {'curr A':>7} {'volt V':>7} {'mAh':>7} "
            f"{'left %':>6} {'RTL margin mAh':>14}")
    lines += [head, "-" * len(head)]
    unflyable = set(r.unflyable_legs)
    for i, row in enumerate(r.leg_rows(), 1):
        if i in unflyable:  # the aircraft cannot fly it: its figures mean nothing
            lines.append(f"{i:>3} {row.kind:<8} {'–':>7} {fmt(row.distance_m, 0, 7)} "
                         f"{'cannot be flown (see NO-GO below)':>56}")
            continue
        left = ("empty" if row.remaining_fraction < 0 else
                fmt(100 * row.remaining_fraction, 1, 6))
        lines.append(
            f"{i:>3} {row.kind:<8} {fmt(row.duration_s, 0, 7)} {fmt(row.distance_m, 0, 7)} "
            f"{fmt(row.airspeed_ms, 1, 7)} {fmt(row.groundspeed_ms, 1, 6)} "
            f"{fmt(row.climb_rate_ms, 1, 6)} {fmt(row.power_w, 1, 8)} "
            f"{fmt(row.current_a, 1, 7)} {fmt(row.voltage_v, 2, 7)} "
            f"{fmt(row.charge_mah, 0, 7)} {left:>6} "
            f"{fmt(row.rtl_margin_mah, 0, 14)}")
    lines.append("-" * len(head))
    lines.append(f"Total     {r.duration_s / 60:.1f} min, {r.energy_wh:.1f} Wh, "
                 f"{r.charge_used_mah:.0f} mAh drawn; peak {r.peak_current_a:.1f} A, "
                 f"lowest loaded voltage {r.min_voltage_v:.2f} V")
    lines.append(f"Reserve   {r.reserve_mah:.0f} mAh ({100 * r.reserve_fraction:.0f} % of "
                 f"nominal); smallest return-home margin {r.rtl_min_margin_mah:+.0f} mAh")
    if r.best_speeds:
        b = r.best_speeds
        lines.append(f"Speeds    level flight, still air: max endurance "
                     f"{b['max_endurance_airspeed_ms']:.1f} m/s ({b['max_endurance_power_w']:.0f} W), "
                     f"max range {b['max_range_airspeed_ms']:.1f} m/s "
                     f"({b['max_range_power_w']:.0f} W)")
    if endurance_line(r):
        lines.append(endurance_line(r))
    if r.circuit:
        c = r.circuit
        lines.append(f"Voltage   {c['model']}: pack {c['pack_temperature_c']:.0f} → "
                     f"{c['max_temperature_c']:.0f} °C, lowest loaded {c['min_voltage_v']:.2f} V, "
                     f"sag margin {c['voltage_margin_v']:+.2f} V above the cut-off "
                     f"(worst: {c['worst_leg_origin']}); cut-off reached after "
                     f"{c['charge_to_cutoff_mah']:.0f} mAh")
    if r.point_of_no_return:
        p = r.point_of_no_return
        lines.append(f"PNR       point of no return at t = {p['time_s']:.0f} s, "
                     f"{p['distance_home_m']:.0f} m from home ({p['leg_origin']})")
    for w in r.warnings:
        lines.append(f"Warning   {w}")
    for why in r.reasons:
        lines.append(f"NO-GO     {why}")
    lines.append("")
    lines.append(r.verdict_line())
    return "\n".join(lines)


#: The spread settings of ``monte_carlo`` and the flags that set them.
_SPREAD_FLAGS = {"wind_sd_ms": "--wind-sd", "wind_direction_sd_deg": "--wind-sd",
                 "gust_factor": "--gust", "temperature_sd_c": "--temperature-sd",
                 "soh": "--soh", "payload_sd_kg": "--payload-sd",
                 "model_error_sd": "--model-error-sd"}


#: The ``args`` attribute of a spread setting, where it is not the setting's own name.
_SPREAD_DEST = {"wind_sd_ms": "wind_sd", "wind_direction_sd_deg": "wind_sd",
                "gust_factor": "gust", "temperature_sd_c": "temperature_sd",
                "payload_sd_kg": "payload_sd"}


def _origin_flag(origin: str) -> str:
    """An uncertainty source's origin with the setting named by its flag."""
    head, sep, rest = origin.partition(":")
    return _SPREAD_FLAGS.get(head, head) + sep + rest
