"""Sizing: endurance against battery mass, range against payload, sorties."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.chain import selection as sel
from planner.chain import sizing
from planner.chain.mission_chain import MissionChain
from planner.errors import InputError
from planner.physics.mission import Environment, Leg, Mission
from planner.parameters import (
    IntegralModel,
    aircraft_from_mapping,
    load_aircraft,
    load_battery,
    load_catalog,
)
from planner.physics.units import AS_PER_MAH as MAH

REPO = Path(__file__).resolve().parents[2]


def ideal_hover_quad(empty_mass_kg=1.2):
    """A multirotor for which the textbook hover-endurance result holds exactly.

    Momentum theory with a constant figure of merit, no body drag and no system
    power: hover power P = (κ + r₀) T v_h / η with v_h = √(T / 2ρA), so P ∝ m^{3/2}
    (the idle-speed floor only acts in fast descents).
    """
    return aircraft_from_mapping({
        "name": "ideal hover quad", "type": "multirotor", "empty_mass_kg": empty_mass_kg,
        "efficiency": 0.8, "system_power_w": 0.0,
        "multirotor": {"rotors": 4, "rotor_diameter_m": 0.3, "power_model": "momentum",
                       "figure_of_merit": 0.6, "drag_area_m2": 0.0}}, "ideal.yaml")


def test_hover_endurance_optimum_is_twice_the_rest_of_the_mass():
    r"""Constant specific energy e: capacity C ∝ m_b. With ε = −1 and β = 1 the integral
    model draws charge in proportion to energy (t = δ C / P at constant power, i.e. δ acts
    as a constant voltage), and hover power ∝ m^{3/2} (momentum theory, see
    :func:`ideal_hover_quad`), so the time to the reserve is

    .. math:: t \propto \frac{m_b}{(m_0 + m_b)^{3/2}}, \qquad
              \frac{dt}{dm_b} = 0 \Rightarrow m_b = 2 m_0,

    the classical result for battery-electric hover (mass fraction 2/3). m₀ is the empty
    mass plus the payload. Checked within 2 % (it is met to the optimiser's tolerance)."""
    ac = ideal_hover_quad(1.2)
    payload = 0.3
    m0 = 1.2 + payload
    model = IntegralModel(delta=14.8, epsilon=-1.0, beta=1.0)
    m_b = np.linspace(0.05, 8.0, 160)
    sweep = sizing.endurance_sweep(ac, m_b, specific_energy_wh_per_kg=160.0, cells_series=4,
                                   model=model, payload_kg=payload, reserve=0.2,
                                   environment=Environment(temperature_c=15.0))
    opt = sweep.optimum
    assert opt["battery_mass_kg"] == pytest.approx(2 * m0, rel=0.02)
    assert opt["mass_fraction"] == pytest.approx(2 / 3, rel=0.02)
    assert not opt["at_grid_edge"]
    # the whole curve has the analytic shape, not only its maximum
    shape = m_b / (m0 + m_b) ** 1.5
    ratio = sweep.endurance_s / shape
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)
    # the constant: t = δ (f_u − r) C / P, checked at the optimum mass
    i = int(np.argmax(sweep.endurance_s))
    c_as = sweep.capacity_mah[i] * MAH
    assert sweep.endurance_s[i] == pytest.approx(14.8 * 0.8 * c_as / sweep.hold_power_w[i])
    assert sweep.capacity_mah[i] == pytest.approx(m_b[i] * 160.0 / (4 * 3.7) * 1000)


def test_literature_model_endurance_has_an_interior_maximum_and_limits():
    ac = load_aircraft(REPO / "aircraft/solo_survey.yaml")
    sweep = sizing.endurance_sweep(ac, np.linspace(0.05, 4.0, 120),
                                   specific_energy_wh_per_kg=150.0, cells_series=4)
    opt = sweep.optimum
    assert not opt["at_grid_edge"]
    assert 0.05 < opt["battery_mass_kg"] < 4.0
    t = sweep.endurance_s
    i = int(np.argmax(t))
    assert t[0] < t[i] > t[-1]
    # the 2.0 kg take-off limit cuts the curve: the best feasible mass is at the limit
    assert not sweep.feasible.all() and sweep.feasible[0]
    assert opt["constrained_battery_mass_kg"] <= 2.0 - 1.0 + 1e-9
    assert opt["constrained_endurance_s"] < opt["endurance_s"]
    assert any("literature" in n for n in sweep.notes)


def test_range_sweep_falls_with_payload_and_best_speed_is_no_worse():
    ac = load_aircraft(REPO / "aircraft/x8_mapper.yaml")
    pack = load_battery(REPO / "aircraft/batteries/multistar_10ah_4s.yaml")
    sweep = sizing.range_sweep(ac, pack, np.linspace(0.0, 1.5, 16))
    assert np.all(np.diff(sweep.range_m) < 0)
    assert np.all(sweep.best_range_m >= sweep.range_m * (1 - 1e-3))
    free = ac.max_takeoff_mass_kg - ac.empty_mass_kg - pack.total_mass_kg
    np.testing.assert_array_equal(sweep.feasible, sweep.payload_kg <= free + 1e-12)
    # range = speed × time at constant power to the reserve
    t = sweep.cruise_endurance_s[0]
    assert sweep.range_m[0] == pytest.approx(ac.cruise_speed_ms * t)


# --------------------------------------------------------------------------- sorties

def long_survey(lanes=16, lane_m=1500.0, spacing=60.0, alt=40.0):
    legs = [Leg("climb", end_alt_m=alt, origin="climb"),
            Leg("cruise", (0, 0), (200, 0), alt, alt, origin="to field")]
    x, y = 200.0, 0.0
    for k in range(lanes):
        ny = lane_m if k % 2 == 0 else 0.0
        legs.append(Leg("cruise", (x, y), (x, ny), alt, alt, origin=f"lane {k + 1}"))
        y = ny
        if k < lanes - 1:
            legs.append(Leg("cruise", (x, y), (x + spacing, y), alt, alt,
                            origin=f"turn {k + 1}"))
            x += spacing
    legs.append(Leg("cruise", (x, y), (0, 0), alt, alt, origin="home"))
    legs.append(Leg("descend", (0, 0), (0, 0), alt, 0, origin="land"))
    return Mission("long survey", legs, Environment(3.0, 250.0, 15.0), payload_kg=0.35)


def small_catalog():
    packs = {p.name: p for p in load_catalog(REPO / "aircraft/packs/catalog.yaml")}
    return [packs[n] for n in ("DJI TB47D 4500 mAh 6S", "Molicel P42A 4S2P 8.4 Ah Li-ion",
                               "3DR Solo Smart Battery 5200 mAh 4S",
                               "Generic 3S 2200 mAh LiPo")]


def test_too_long_survey_is_split_into_the_fewest_sorties_that_each_pass_check():
    # the Solo's airframe, open to any cell count: the small catalog mixes 3S to 6S packs
    ac = replace(load_aircraft(REPO / "aircraft/solo_survey.yaml"), cells_series_allowed=None)
    mission = long_survey()
    packs = small_catalog()
    ev = sel.evaluate_packs(mission, ac, packs)
    assert not ev.feasible.any()                         # no single flight does it
    plan = sizing.plan_long_mission(mission, ac, packs, ev)
    n = len(mission.legs)
    chain = MissionChain(ac, plan.pack)
    # every sortie passes the pre-flight check on its own
    for s in plan.sorties:
        r = chain.check(s.mission)
        assert r.go, (s.number, r.reasons)
        assert s.mission.legs[0].start_en_m == (0.0, 0.0)
        assert s.mission.legs[-1].end_en_m == pytest.approx((0.0, 0.0))
        assert s.mission.legs[-1].end_alt_m == 0.0
    # the sorties cover the route exactly once, in order
    assert plan.sorties[0].start == 0.0 and plan.sorties[-1].end == n
    for a, b in zip(plan.sorties, plan.sorties[1:]):
        assert a.end == b.start
    assert len(plan.splits) == plan.count - 1
    assert any(0.0 < s.fraction < 1.0 for s in plan.splits)   # a lane cut mid-way
    # minimal: the count meets the charge bound, so one fewer sortie cannot work —
    # (n − 1) sorties hold less integral-model stress than the route alone needs
    whole = chain.check(mission)
    limit = whole.usable_mah - whole.reserve_mah   # the chain's, cut-off included
    needed = (whole.charge_used_mah / limit) ** plan.pack.model.beta
    assert plan.count - 1 < needed <= plan.count
    assert plan.minimal and plan.count == plan.lower_bound >= 2
    # and no other pack of the catalog flies it in fewer sorties (ties: not lighter)
    for i, p in enumerate(packs):
        if p is plan.pack or ev.binding(i) not in ("runs_out", "landing_reserve",
                                                   "return_home"):
            continue
        try:
            other = sizing.plan_sorties(mission, ac, p)
        except InputError:                                 # cannot fly it even in parts
            continue
        assert (other.count, other.pack.total_mass_kg) >= (plan.count,
                                                           plan.pack.total_mass_kg)


def test_split_times_and_positions_are_on_the_route():
    ac = load_aircraft(REPO / "aircraft/solo_survey.yaml")
    mission = long_survey()
    pack = small_catalog()[0]
    plan = sizing.plan_sorties(mission, ac, pack)
    table_end = MissionChain(ac, pack).check(mission).legs
    for s in plan.splits:
        leg = mission.legs[s.leg]
        start = np.array(leg.start_en_m)
        end = np.array(leg.end_en_m)
        np.testing.assert_allclose([s.east_m, s.north_m], start + s.fraction * (end - start))
        t0 = table_end.start_time_s[s.leg]
        assert s.time_s == pytest.approx(t0 + s.fraction * table_end.duration_s[s.leg])


def test_sortie_mission_flies_out_to_the_cut_and_home_from_it():
    legs = [Leg("climb", end_alt_m=50, origin="climb"),
            Leg("cruise", (0, 0), (1000, 0), 50, 50, origin="a"),
            Leg("hover", (1000, 0), (1000, 0), 50, 50, duration_s=100, origin="h"),
            Leg("cruise", (1000, 0), (1000, 800), 50, 60, origin="b"),
            Leg("cruise", (1000, 800), (0, 0), 60, 60, origin="c"),
            Leg("descend", (0, 0), (0, 0), 60, 0, origin="land")]
    mission = Mission("m", legs)
    s = sizing.sortie_mission(mission, 2.5, 3.25, number=2)
    kinds = [leg.kind for leg in s.legs]
    assert kinds == ["climb", "cruise", "hover", "cruise", "cruise", "descend"]
    climb, out, hold, part, home, land = s.legs
    assert climb.end_alt_m == 50 and out.end_en_m == (1000.0, 0.0)
    assert hold.duration_s == pytest.approx(50.0)
    assert part.start_en_m == (1000.0, 0.0) and part.end_en_m == pytest.approx((1000.0, 200.0))
    assert part.end_alt_m == pytest.approx(52.5)
    assert home.start_en_m == part.end_en_m and home.end_en_m == (0.0, 0.0)
    assert home.start_alt_m == pytest.approx(52.5) and land.start_alt_m == pytest.approx(52.5)
    for a, b in zip(s.legs, s.legs[1:]):                # continuous route
        assert b.start_en_m == pytest.approx(a.end_en_m)
    assert "sortie 2" in out.origin and "(50–100 %)" in hold.origin
    # the first sortie starts like the mission, the last ends like it
    first = sizing.sortie_mission(mission, 0.0, 1.5)
    last = sizing.sortie_mission(mission, 4.0, 6.0)
    assert first.legs[0] is legs[0] and last.legs[-1] is legs[-1]
    with pytest.raises(ValueError):
        sizing.sortie_mission(mission, 3.0, 3.0)


def test_lower_bound_is_the_stress_ratio():
    pack = load_battery(REPO / "aircraft/batteries/multistar_10ah_4s.yaml")
    limit_mah = (pack.usable_as - 0.2 * pack.capacity_as) / MAH
    beta = pack.model.beta
    assert sizing.sortie_lower_bound(0.5 * limit_mah, limit_mah, beta) == 1
    assert sizing.sortie_lower_bound(limit_mah, limit_mah, beta) == 1
    used = 2.5 ** (1 / pack.model.beta) * limit_mah
    assert sizing.sortie_lower_bound(used, limit_mah, beta) == 3
    assert sizing.sortie_lower_bound(used, 0.0, beta) > 10**6      # nothing usable
    assert math.isclose((used / limit_mah) ** pack.model.beta, 2.5)


def test_a_pack_that_cannot_reach_the_route_is_refused():
    ac = load_aircraft(REPO / "aircraft/solo_survey.yaml")
    tiny = replace(small_catalog()[0], capacity_mah=400.0, name="tiny")
    far = Mission("far", [Leg("climb", end_alt_m=40), Leg("cruise", (0, 0), (6000, 0), 40, 40),
                          Leg("hover", (6000, 0), (6000, 0), 40, 40, duration_s=600),
                          Leg("cruise", (6000, 0), (0, 0), 40, 40), Leg("descend", start_alt_m=40)])
    with pytest.raises(InputError, match="cannot fly any part"):
        sizing.plan_sorties(far, ac, tiny)


def test_the_plot_draws_the_sortie_plan_and_names_why_packs_were_rejected():
    """Operator's-view point 10: the sortie plan (the answer when no pack suffices) is
    drawn, each sortie ending above the landing limit, and the rejected packs of the Pareto
    plot carry their binding constraint."""
    from planner.cli.plots import select as plots_select

    ac = replace(load_aircraft(REPO / "aircraft/solo_survey.yaml"), cells_series_allowed=None)
    mission = long_survey()
    packs = small_catalog()
    selection = sel.select_pack(mission, ac, packs, mission.environment)
    assert selection.best is None
    plan = sizing.plan_long_mission(mission, ac, packs, selection.evaluation)
    ax = plots_select.plot_sorties(plan)
    labels = [line.get_label() for line in ax.get_lines()]
    sorties = [lab for lab in labels if lab.startswith("sortie ")]
    assert len(sorties) == plan.count
    limit = next(line for line in ax.get_lines() if "landing limit" in line.get_label())
    level = limit.get_ydata()[0]
    for line in ax.get_lines():
        if line.get_label().startswith("sortie "):
            assert line.get_ydata()[-1] >= level - 1e-6     # each lands above the limit
    ax2 = plots_select.plot_pareto(selection)
    names = [c.get_label() for c in ax2.collections]
    rejected = [n for n in names if n.startswith("rejected: ")]
    e = selection.evaluation
    words = {plots_select.REJECT_WORDS[e.binding(i)] for i in range(len(e))}
    assert {n.split(": ", 1)[1].rsplit(" (", 1)[0] for n in rejected} == words
