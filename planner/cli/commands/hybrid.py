"""``endurance hybrid``: a mission's power peaks on a battery ∥ supercapacitor pack."""

from __future__ import annotations

import dataclasses

import numpy as np

from planner.cli.commands.common import (add_options, check_speed, output_path, parse_float,
                                         parse_int, parse_wind, write_json)
from planner.errors import InputError
from planner.io.mission import NavDefaults, load_mission
from planner.parameters import load_aircraft_and_battery


def register(sub) -> None:
    """Add the ``hybrid`` command with its options to the subcommand parsers ``sub``."""
    p = sub.add_parser("hybrid", help="battery + supercapacitor: peak current, J1, J2, sag",
                       description="Fly the mission's power profile on the pack alone and on "
                                   "the pack with a passive Maxwell BCAP1500 supercapacitor "
                                   "bank in parallel (series count matched to the pack), and "
                                   "report the battery's peak current, the figures of merit "
                                   "J1 (charge throughput) and J2 (ohmic loss), and the "
                                   "voltage-sag margin with and without.")
    add_options(p, mission=True, aircraft=True, battery=True)
    p.add_argument("--supercap-parallel", default="1",
                   help="strings of supercapacitor cells in parallel (default 1)")
    add_options(p, temperature="pack temperature [°C] (default 25)", wind="SPEED@FROM_DEG")
    p.add_argument("--step", default="0.5", help="time step [s] (default 0.5)")
    add_options(p, json="write the comparison as JSON")
    p.set_defaults(func=run)


def run(args) -> int:
    """``endurance hybrid``: simulate the battery–supercapacitor pack on a load profile and
    print its figures of merit; returns 0."""
    from planner.physics.battery.hybrid import BCAP1500, matched_bank, simulate_hybrid
    from planner.chain.mission_chain import MissionChain

    json_out = output_path(args.json, "--json")
    aircraft, pack = load_aircraft_and_battery(args.aircraft, args.battery)
    mission = load_mission(args.mission, defaults=NavDefaults.of(aircraft))
    env = mission.environment
    if args.wind:
        speed, direction = parse_wind(args.wind)
        check_speed(speed, "--wind", args.wind, aircraft, "wind")
        env = dataclasses.replace(env, wind_speed_ms=speed, wind_from_deg=direction)
    temp = (parse_float(args.temperature, "--temperature", -20, 60, "°C") if args.temperature
            else 25.0)
    step = parse_float(args.step, "--step", 0.01, 10.0)
    n_par = parse_int(args.supercap_parallel, "--supercap-parallel", 1, 100)
    battery = pack.circuit_parameters()
    bank = matched_bank(BCAP1500, battery, cells_parallel=n_par)
    bank_mass = bank.bank_mass_kg or 0.0
    # the load both packs are compared on: the mission's power without the bank's mass
    result = MissionChain(aircraft, pack, temperature_c=temp).check(mission, env)
    legs = result.legs
    end = np.cumsum(legs.duration_s.to_numpy())
    if not len(end) or end[-1] <= 0:
        raise InputError(f"{args.mission}: the mission has no duration")
    t = np.arange(0.0, end[-1], step)
    p = legs.power_w.to_numpy()[np.clip(np.searchsorted(end, t, side="right"), 0,
                                        len(end) - 1)]
    run_ = simulate_hybrid(battery, bank, t, power_w=p, temperature_c=temp,
                           v_cutoff_cell=pack.cell_voltage_empty_v)
    s = run_.summary()
    mass = s.supercap_mass_kg
    print(f"Mission   {mission.name}: {end[-1] / 60:.1f} min, peak power "
          f"{np.max(p):.0f} W; pack {pack.name} at {temp:.0f} °C")
    print(f"Bank      {bank.cells_series}S{n_par}P Maxwell BCAP1500 ({s.supercap_cells} cells"
          + (f", {mass:.2f} kg" if mass else "") + ")")
    print(f"{'':<28}{'battery alone':>15}{'with supercap':>15}")
    print(f"{'peak battery current [A]':<28}{s.peak_battery_current_alone_a:15.1f}"
          f"{s.peak_battery_current_a:15.1f}")
    print(f"{'lowest loaded voltage [V]':<28}{s.min_voltage_alone_v:15.2f}{s.min_voltage_v:15.2f}")
    print(f"{'sag margin to cut-off [V]':<28}{s.sag_margin_alone_v:15.2f}{s.sag_margin_v:15.2f}")
    print(f"J1 (battery charge throughput, hybrid / alone) = {s.j1:.3f}; "
          f"J2 (battery ohmic loss, hybrid / alone) = {s.j2:.3f}")
    mtow = aircraft.max_takeoff_mass_kg
    with_bank = result.takeoff_mass_kg + bank_mass
    over = mtow is not None and with_bank > mtow
    print(f"Mass      take-off {result.takeoff_mass_kg:.2f} kg, {with_bank:.2f} kg with the "
          f"{bank_mass:.2f} kg bank" + (f" (maximum {mtow:.2f} kg)" if mtow is not None else "")
          + "; both columns fly the mission's power without the bank's mass")
    if over:
        print(f"Warning   the bank puts the aircraft {with_bank - mtow:.2f} kg over its maximum "
              "take-off mass: this hybrid cannot fly this mission")
    if json_out:
        write_json(dataclasses.asdict(s) | {"bank": f"{bank.cells_series}S{n_par}P BCAP1500",
                                           "temperature_c": temp,
                                           "takeoff_mass_kg": result.takeoff_mass_kg,
                                           "takeoff_mass_with_bank_kg": with_bank,
                                           "max_takeoff_mass_kg": mtow,
                                           "over_max_takeoff_mass": bool(over)}, json_out)
    return 0
