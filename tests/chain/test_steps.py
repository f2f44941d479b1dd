"""The steps of the mission chain (planner.chain.steps), each called alone and checked
against an independent statement of what it computes."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.chain import steps
from planner.chain.kinematics import RTL_POINTS_PER_LEG
from planner.chain.mission_chain import MissionChain
from planner.errors import InputError
from planner.io.mission import load_mission
from planner.parameters import load_aircraft_and_battery
from planner.physics.battery import integral
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.mission import Environment, Leg, Mission

REPO = Path(__file__).resolve().parents[2]


def solo(circuit=False):
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    if not circuit:
        pack = replace(pack, circuit=None, thermal=None)
    return aircraft, pack, load_mission(REPO / "missions/survey_quad.yaml",
                                        vehicle_type=aircraft.type)


def inputs_of(aircraft, packs, mission, **kw):
    chain = MissionChain(aircraft, packs)
    return steps.chain_inputs(aircraft, chain.packs, chain.models, mission, None, **kw)


def first_steps(aircraft, packs, mission, **kw):
    inputs = inputs_of(aircraft, packs, mission, **kw)
    states = steps.flight_states(inputs)
    return inputs, states, steps.power_step(inputs, states)


# --------------------------------------------------------------------------- 1. inputs

def test_inputs_take_off_mass_is_the_airframe_the_packs_and_the_payload():
    ac, pack, mission = solo()
    two = replace(pack, count=2)
    inputs = inputs_of(ac, [pack, two], mission, payload_kg=0.4)
    assert inputs.mass.tolist() == pytest.approx(
        [ac.empty_mass_kg + pack.mass_kg + 0.4, ac.empty_mass_kg + 2 * pack.mass_kg + 0.4])
    assert inputs.pack["cap"][1] == pytest.approx(2 * pack.capacity_mah * 3.6)
    assert inputs.keep and not inputs_of(ac, [pack] * 17, mission).keep


def test_inputs_refuse_bad_samples_and_unknown_keys():
    ac, pack, mission = solo()
    with pytest.raises(InputError, match="pack sample 1"):
        inputs_of(ac, [pack, pack], mission, pack_samples={"delta": [1.0, -1.0]})
    with pytest.raises(ValueError, match="unknown key"):
        inputs_of(ac, [pack], mission, pack_samples={"gamma": [1.0]})
    soh = inputs_of(ac, [pack, pack], mission, pack_samples={"soh": [1.0, 0.8]})
    assert soh.pack["usable"][1] == pytest.approx(0.8 * soh.pack["usable"][0])


# --------------------------------------------------------------------------- 2. states

def test_flight_states_hold_a_return_home_point_per_fifth_of_every_leg():
    ac, pack, mission = solo()
    inputs, states, _ = first_steps(ac, [pack], mission)
    assert states.points == RTL_POINTS_PER_LEG * states.legs
    assert states.rtl["distance_m"][0] == pytest.approx(0.0, abs=1e-9)   # the first: home
    assert states.hold[0] == mission.environment.wind_speed_ms           # hover in the wind
    with pytest.raises(ValueError, match="rtl_subset"):
        steps.flight_states(inputs, rtl_subset=[0, 1])


# --------------------------------------------------------------------------- 3. power

def test_power_step_gives_each_state_the_aircraft_power_model():
    """The de-duplicated power table must give back, for every leg, return-home state and
    the hold, what the aircraft's power model says for that state and mass."""
    ac, pack, mission = solo()
    inputs, states, power = first_steps(ac, [pack], mission)
    p = np.exp(power.table.log_power(inputs.mass))[0]
    t = states.table
    direct = ac.battery_power(t.airspeed_ms, t.climb_rate_ms, t.air_density, inputs.mass[0],
                              load_factor=t.load_factor)
    np.testing.assert_allclose(p[power.leg], direct, rtol=1e-12)
    va, climb, rho, n = states.rtl["back"]
    np.testing.assert_allclose(p[power.back], ac.battery_power(va, climb, rho, inputs.mass[0],
                                                               load_factor=n), rtol=1e-12)


# --------------------------------------------------------------------------- 4. battery

def test_leg_figures_follow_the_integral_model_and_the_loaded_current():
    """Per leg: stress = duration/(δ P^ε) ([UAV23] eq. 14), charge = S^(1/β); energy
    = Σ P t; the current solves P = (V_oc − R I) I with the OCV at the mid-leg state of
    charge."""
    ac, pack, mission = solo()
    pack = replace(pack, internal_resistance_ohm=0.03)
    inputs, states, power = first_steps(ac, [pack], mission)
    legs = steps.leg_figures(inputs, states, power, slice(0, 1))
    m, dur = pack.model, states.table.duration_s
    p = legs.power_w[0]
    s = np.cumsum(dur * integral.stress_rate(p, m.delta, m.epsilon))
    np.testing.assert_allclose(legs.stress_end[0], s, rtol=1e-12)
    c = integral.charge_from_stress(s, m.beta)
    np.testing.assert_allclose(legs.charge_end_as[0], c, rtol=1e-12)
    assert legs.energy_wh[0] == pytest.approx(np.sum(p * dur) / 3600.0, rel=1e-12)
    soc = 1.0 - 0.5 * (np.r_[0.0, c[:-1]] + c) / inputs.pack["cap"][0]
    v_oc, i = pack.cells_series * lipo_ocv(soc), legs.current_a[0]
    np.testing.assert_allclose((v_oc - 0.03 * i) * i, p, rtol=1e-10)
    assert legs.peak_current_a[0] == pytest.approx(i.max())
    assert legs.undeliverable_leg[0] == -1


def test_leg_figures_name_the_first_leg_a_pack_cannot_deliver():
    ac, pack, mission = solo()
    weak = replace(pack, internal_resistance_ohm=2.5)
    inputs, states, power = first_steps(ac, [pack, weak], mission)
    legs = steps.leg_figures(inputs, states, power, slice(0, 2))
    j = int(legs.undeliverable_leg[1])
    assert legs.undeliverable_leg[0] == -1 and j >= 0
    assert np.all(np.isfinite(legs.current_a[1, :j])) and np.isnan(legs.current_a[1, j])
    assert legs.p_undeliverable_w[1] > legs.p_max_w[1]


def test_charge_budget_is_lowered_by_the_cut_off_and_keeps_the_reserve():
    ac, pack, mission = solo(circuit=True)
    inputs, states, power = first_steps(ac, [pack], mission, temperature_c=-10.0)
    circuit = steps.circuit_model(inputs, states, power)
    budget = steps.charge_budget(inputs, circuit)
    assert circuit.which == [0]
    assert budget.usable[0] == pytest.approx(min(inputs.pack["usable"][0],
                                                 circuit.usable_as[0]))
    assert budget.limit[0] == pytest.approx(budget.usable[0] - 0.2 * budget.cap[0])


def test_circuit_model_runs_each_pack_and_mass_once():
    """Samples of one pack file at one take-off mass share one circuit run; the packs on
    the integral model get no circuit figures."""
    ac, pack, mission = solo(circuit=True)
    plain = replace(pack, circuit=None, thermal=None)
    inputs, states, power = first_steps(ac, [pack, plain, pack], mission)
    run = steps.circuit_model(inputs, states, power)
    assert run.which == [0, 2]
    np.testing.assert_array_equal(run.usable_as[0], run.usable_as[1])
    assert np.isnan(run.figures["min_voltage_v"][1])
    alone = steps.circuit_packs(inputs, states, power, [0])
    assert alone["usable_as"][0] == pytest.approx(run.usable_as[0], rel=1e-12)


# --------------------------------------------------------------------------- 5. return home

def test_return_home_at_the_mission_end_is_the_landing_margin():
    ac, pack, mission = solo()
    inputs, states, power = first_steps(ac, [pack], mission)
    circuit = steps.circuit_model(inputs, states, power)
    budget = steps.charge_budget(inputs, circuit)
    legs = steps.leg_figures(inputs, states, power, slice(0, 1))
    home = steps.return_home(inputs, states, power, budget, legs, slice(0, 1))
    margin = home.point_margin_as()[0]
    assert margin[-1] == pytest.approx(budget.limit[0] - legs.used_as[0], rel=1e-12)
    assert home.min_margin_as[0] == pytest.approx(margin.min(), rel=1e-12)
    back = home.return_charge_as()[0]
    assert back[-1] == pytest.approx(0.0, abs=1e-9) and np.all(back >= -1e-9)


def test_return_home_finds_the_point_of_no_return_of_a_one_way_trip():
    ac, pack, _ = solo()
    away = Mission("one way", [Leg("climb", end_alt_m=30, origin="climb"),
                               Leg("cruise", (0, 0), (0, 9000), 30, 30, origin="away"),
                               Leg("descend", (0, 9000), (0, 9000), 30, 0, origin="land")],
                   Environment(temperature_c=20.0))
    inputs, states, power = first_steps(ac, [pack], away)
    budget = steps.charge_budget(inputs, steps.circuit_model(inputs, states, power))
    legs = steps.leg_figures(inputs, states, power, slice(0, 1))
    home = steps.return_home(inputs, states, power, budget, legs, slice(0, 1))
    j = int(home.pnr_index[0])
    assert j >= 0 and states.rtl["leg"][j] == 1
    margin = home.point_margin_as()[0]
    assert margin[j] < 0 <= margin[j - 1]


# --------------------------------------------------------------------------- 6. constraints

def test_constraints_mark_what_each_pack_breaks():
    ac, pack, mission = solo()
    packs = [pack, replace(pack, max_discharge_c=0.5), replace(pack, usable_fraction=0.2)]
    inputs, states, power = first_steps(ac, packs, mission)
    circuit = steps.circuit_model(inputs, states, power)
    budget = steps.charge_budget(inputs, circuit)
    flown = steps.PackFigures(inputs, states)
    rows = slice(0, 3)
    legs = steps.leg_figures(inputs, states, power, rows)
    flown.store(rows, inputs, states, power, legs,
                steps.return_home(inputs, states, power, budget, legs, rows))
    v = steps.constraints(inputs, states, circuit, budget, flown)
    code = {c: v[:, k] for k, c in enumerate(steps.CHECK_CONSTRAINTS)}
    assert not v[0].any()
    assert code["c_rating"].tolist() == [False, True, False]
    assert code["runs_out"][2] and not code["landing_reserve"][2]
    run = MissionChain(ac, packs).run(mission)
    np.testing.assert_array_equal(run.violated, v)
