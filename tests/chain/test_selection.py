"""Pack selection: the vectorised evaluation is the pre-flight check, pack by pack."""

from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.chain import selection as sel
from planner.physics.battery.elements import loaded_current
from planner.chain.mission_chain import MissionChain
from planner.errors import InputError
from planner.io.mission import load_mission
from planner.physics.mission import Environment, Leg, Mission
from planner.parameters import IntegralModel, load_aircraft, load_battery, load_catalog
from planner.chain.powertable import PowerTable

REPO = Path(__file__).resolve().parents[2]
CATALOG = REPO / "aircraft/packs/catalog.yaml"


def aircraft(name):
    """The shipped aircraft, open to any cell count: the random catalogs below hold
    3–6S packs, and these tests exercise the check's constraints on all of them."""
    return replace(load_aircraft(REPO / "aircraft" / name), cells_series_allowed=None)


def random_catalog(seed, k=40, specific_energy=(120.0, 240.0)):
    """Random LiPo-like packs: 3–6S, 1.2–14 Ah, some with a fitted model, some ×2.

    No equivalent-circuit block, so every pack goes through the vectorised path.
    """
    rng = np.random.default_rng(seed)
    packs = []
    for i in range(k):
        cells = int(rng.integers(3, 7))
        cap = float(rng.uniform(1200, 14000))
        e = float(rng.uniform(*specific_energy))
        model = None
        if rng.random() < 0.4:
            model = IntegralModel(delta=float(rng.uniform(0.8, 1.25)) * 4.0 * cells,
                                  epsilon=float(rng.uniform(-1.06, -0.98)),
                                  beta=float(rng.uniform(0.95, 1.0)))
        packs.append(load_battery(REPO / "aircraft/batteries/multistar_10ah_4s.yaml").__class__(
            name=f"random {i}", cells_series=cells, capacity_mah=cap,
            mass_kg=cap / 1000 * cells * 3.7 / e,
            max_discharge_c=float(rng.uniform(2.0, 40.0)) if rng.random() < 0.9 else None,
            internal_resistance_ohm=float(rng.uniform(0.003, 0.08)) * cells / 4
            * (12.0 if rng.random() < 0.15 else 1.0),
            usable_fraction=float(rng.choice([1.0, 0.95])), model=model,
            count=int(rng.choice([1, 1, 1, 2])), price=float(rng.uniform(50, 600))))
    return packs


def out_and_back(distance, alt=40.0, hold=60.0, course=60.0, env=None):
    a = np.radians(course)
    far = (distance * np.sin(a), distance * np.cos(a))
    legs = [Leg("climb", start_alt_m=0, end_alt_m=alt, origin="climb"),
            Leg("cruise", (0, 0), far, alt, alt, origin="out"),
            Leg("hover", far, far, alt, alt, duration_s=hold, origin="hold"),
            Leg("cruise", far, (0, 0), alt, alt, origin="back"),
            Leg("descend", start_alt_m=alt, end_alt_m=0, origin="land")]
    return Mission("out and back", legs, env or Environment(4.0, 250.0, 15.0), payload_kg=0.2)


def one_way(distance, alt=30.0):
    """Fly away and land there: the landing reserve can hold while home is out of reach."""
    legs = [Leg("climb", end_alt_m=alt, origin="climb"),
            Leg("cruise", (0, 0), (distance, 0), alt, alt, origin="away"),
            Leg("descend", (distance, 0), (distance, 0), alt, 0, origin="land")]
    return Mission("one way", legs, Environment(3.0, 90.0, 10.0), payload_kg=0.1)


CASES = [("solo_survey.yaml", "missions/survey_quad.yaml"),
         ("solo_survey.yaml", "out_and_back"),
         ("solo_survey.yaml", "one_way"),
         ("x8_mapper.yaml", "missions/mapping_plane.yaml"),
         ("quad_7in.yaml", "out_and_back"),
         ("dji_m100.yaml", "missions/survey_route.yaml")]


def mission_for(ac, what):
    if what == "out_and_back":
        return out_and_back(1200 if ac.is_multirotor else 6000)
    if what == "one_way":
        return one_way(3500)
    return load_mission(REPO / what, vehicle_type=ac.type)


@pytest.mark.parametrize("method", ["exact", "table"])
@pytest.mark.parametrize("aircraft_name, what", CASES)
def test_vectorised_evaluation_agrees_with_mission_chain_pack_by_pack(aircraft_name, what,
                                                                      method):
    ac = aircraft(aircraft_name)
    mission = mission_for(ac, what)
    packs = random_catalog(7, k=30)
    ev = sel.evaluate_packs(mission, ac, packs, method=method)
    assert ev.method == method
    for i, pack in enumerate(packs):
        r = MissionChain(ac, pack).check(mission)
        cap = r.capacity_mah
        assert ev.check_go[i] == r.go, (i, ev.constraints(i), r.reasons)
        assert ev.takeoff_mass_kg[i] == pytest.approx(r.takeoff_mass_kg, rel=1e-12)
        assert ev.charge_used_mah[i] == pytest.approx(r.charge_used_mah, rel=1e-6)
        # the margin within 0.1 % (of itself, or of the capacity near zero)
        assert ev.margin_mah[i] == pytest.approx(r.margin_mah, rel=1e-3, abs=1e-3 * cap)
        assert ev.rtl_min_margin_mah[i] == pytest.approx(r.rtl_min_margin_mah, rel=1e-3,
                                                         abs=1e-3 * cap)
        assert ev.margin_time_s[i] == pytest.approx(r.margin_time_s, rel=1e-3, abs=0.1)
        assert ev.energy_wh[i] == pytest.approx(r.energy_wh, rel=1e-6)
        if np.isfinite(r.peak_current_a):
            assert ev.peak_current_a[i] == pytest.approx(r.peak_current_a, rel=1e-6)
        pnr, pnr_r = ev.point_of_no_return(i), r.point_of_no_return
        assert (pnr is None) == (pnr_r is None)
        if pnr is not None:
            assert pnr["time_s"] == pytest.approx(pnr_r["time_s"])
            assert pnr["leg_origin"] == pnr_r["leg_origin"]


def test_the_agreement_test_covers_every_kind_of_rejection():
    """So that the comparison above is not vacuous: the random catalog on these missions
    gives GO packs and every reason ``check`` has."""
    seen = Counter()
    for aircraft_name, what in CASES:
        ac = aircraft(aircraft_name)
        ev = sel.evaluate_packs(mission_for(ac, what), ac, random_catalog(7, k=30))
        for i in range(len(ev)):
            seen.update(ev.constraints(i) or ["feasible"])
    for code in ("feasible", "takeoff_mass", "power", "c_rating", "runs_out",
                 "landing_reserve", "return_home"):
        assert seen[code] > 0, (code, seen)


def test_return_home_reason_without_landing_reserve_problem():
    ac = aircraft("solo_survey.yaml")
    ev = sel.evaluate_packs(one_way(3500), ac, random_catalog(7, k=30))
    only_rtl = [i for i in range(len(ev)) if ev.constraints(i) == ["return_home"]]
    assert only_rtl
    assert all("point of no return" in ev.reasons(i)[0] for i in only_rtl)


def brute_force_lightest(ac, mission, packs, min_tw=1.5):
    """MissionChain.run per pack, plus the selection-only constraints, lightest wins."""
    ok = []
    for p in packs:
        r = MissionChain(ac, p).check(mission)
        cells_ok = not ac.cells_series_allowed or p.cells_series in ac.cells_series_allowed
        thrust = ac.multirotor.max_thrust_n if ac.is_multirotor else None
        tw_ok = thrust is None or thrust / (r.takeoff_mass_kg * 9.80665) >= min_tw
        if r.go and cells_ok and tw_ok:
            ok.append(p)
    return min(ok, key=lambda p: p.total_mass_kg) if ok else None


@pytest.mark.parametrize("seed", [3, 11, 29])
def test_chosen_pack_is_the_lightest_feasible_one_by_brute_force(seed):
    base = aircraft("solo_survey.yaml")
    ac = replace(base, cells_series_allowed=(3, 4, 5),
                 multirotor=replace(base.multirotor, max_thrust_n=33.0))
    mission = load_mission(REPO / "missions/survey_quad.yaml", vehicle_type=ac.type)
    packs = random_catalog(seed, k=40)
    selection = sel.select_pack(mission, ac, packs)
    expected = brute_force_lightest(ac, mission, packs)
    assert expected is not None
    assert selection.best_pack is expected
    # not trivially the lightest pack of the catalog: lighter packs were rejected
    lighter = [i for i, p in enumerate(packs) if p.total_mass_kg < expected.total_mass_kg]
    assert lighter and not selection.evaluation.feasible[lighter].any()
    # ranking: feasible packs first, by mass
    e = selection.evaluation
    feas = [i for i in selection.order if e.feasible[i]]
    assert list(selection.order[:len(feas)]) == feas
    assert np.all(np.diff(e.pack_mass_kg[feas]) >= 0)


def test_a_pack_that_violates_its_c_rating_is_rejected_with_that_reason():
    ac = aircraft("solo_survey.yaml")
    mission = load_mission(REPO / "missions/survey_quad.yaml", vehicle_type=ac.type)
    good = replace(load_battery(REPO / "aircraft/batteries/solo_5200_4s.yaml"),
                   circuit=None, thermal=None, name="solo 10C")
    weak = replace(good, max_discharge_c=2.0, name="solo 2C")
    ev = sel.evaluate_packs(mission, ac, [good, weak])
    assert ev.feasible[0]
    assert not ev.feasible[1] and ev.binding(1) == "c_rating"
    assert ev.constraints(1) == ["c_rating"]
    assert "C rating" in ev.reasons(1)[0] and "exceeds" in ev.reasons(1)[0]
    assert ev.peak_current_a[1] > ev.max_current_a[1] == pytest.approx(2.0 * 5.2)


def test_cell_count_and_thrust_to_weight_constraints():
    base = aircraft("solo_survey.yaml")
    mission = load_mission(REPO / "missions/survey_quad.yaml", vehicle_type=base.type)
    pack = replace(load_battery(REPO / "aircraft/batteries/solo_5200_4s.yaml"),
                   circuit=None, thermal=None)
    heavy = replace(pack, count=2, name="two solo packs")
    ac = replace(base, cells_series_allowed=(6,))
    ev = sel.evaluate_packs(mission, ac, [pack])
    assert ev.constraints(0) == ["cells"] and "allows 6S" in ev.reasons(0)[0]
    # max thrust 30 N: 1.85 kg needs 27.2 N at T/W 1.5; 2.35 kg does not pass
    ac = replace(base, multirotor=replace(base.multirotor, max_thrust_n=30.0),
                 max_takeoff_mass_kg=3.0)
    ev = sel.evaluate_packs(mission, ac, [pack, heavy])
    assert ev.thrust_to_weight[0] == pytest.approx(30.0 / (1.85 * 9.80665))
    assert ev.feasible[0] and ev.constraints(1)[0] == "thrust"
    assert "thrust-to-weight" in ev.reasons(1)[0]
    ev = sel.evaluate_packs(mission, base, [pack])
    assert any("thrust-to-weight not checked" in n for n in ev.notes)


def test_literature_model_packs_are_named_in_the_notes():
    ac = aircraft("solo_survey.yaml")
    mission = load_mission(REPO / "missions/survey_quad.yaml", vehicle_type=ac.type)
    packs = load_catalog(CATALOG)
    ev = sel.evaluate_packs(mission, ac, packs)
    n_lit = sum(p.model.literature for p in packs)
    assert n_lit and any(f"{n_lit} of {len(packs)} pack(s)" in n and "literature" in n
                         for n in ev.notes)
    d = sel.Selection(ev, "mass", sel.rank_packs(ev)).to_dict()
    models = {p["name"]: p["battery_model"] for p in d["packs"]}
    assert models["Multistar 10.0 Ah 4S1P"] == "from the pack file"
    assert models["3DR Solo Smart Battery 5200 mAh 4S"] == "literature"


def test_objectives_margin_and_price():
    ac = aircraft("x8_mapper.yaml")
    mission = load_mission(REPO / "missions/mapping_plane.yaml", vehicle_type=ac.type)
    packs = random_catalog(5, k=30)
    by_margin = sel.select_pack(mission, ac, packs, objective="margin")
    by_price = sel.select_pack(mission, ac, packs, objective="price")
    e = by_margin.evaluation
    feasible = np.flatnonzero(e.feasible)
    assert len(feasible) >= 3
    assert by_margin.best == feasible[np.argmax(e.margin_time_s[feasible])]
    prices = np.array([p.price for p in packs])
    assert by_price.best == feasible[np.argmin(prices[feasible])]
    with pytest.raises(InputError, match="objective"):
        sel.rank_packs(e, "weight")


def test_packs_with_an_equivalent_circuit_fly_through_it_as_in_check():
    ac = aircraft("solo_survey.yaml")
    mission = load_mission(REPO / "missions/survey_quad.yaml", vehicle_type=ac.type)
    pack = load_battery(REPO / "aircraft/batteries/solo_5200_4s.yaml")
    if pack.circuit is None and pack.thermal is None:
        pytest.skip("the example pack has no circuit block")
    ev = sel.evaluate_packs(mission, ac, [pack, replace(pack, circuit=None, thermal=None)],
                            temperature_c=-5.0)
    r = MissionChain(ac, pack, temperature_c=-5.0).check(mission)
    assert ev.result.battery_models == ["circuit", "integral"]
    assert ev.usable_mah[0] < ev.usable_mah[1]          # the cold cut-off comes earlier
    assert ev.margin_mah[0] == pytest.approx(r.margin_mah)
    assert ev.usable_mah[0] == pytest.approx(r.usable_mah)
    assert ev.check_go[0] == r.go
    assert ev.reasons(0) == r.reasons


def test_power_table_matches_the_model_also_across_the_descent_power_floor():
    """Interpolation in mass is checked against the model; states with a kink (the
    idle-speed floor of a fast descent) are split into pieces or evaluated exactly."""
    ac = aircraft("solo_survey.yaml")
    rng = np.random.default_rng(0)
    n = 60
    airspeed = np.concatenate([rng.uniform(0, 20, n), [3.0, 3.0, 5.0]])
    climb = np.concatenate([rng.uniform(-3, 3, n), [-1.5, -6.0, -8.0]])
    rho = np.concatenate([rng.uniform(1.0, 1.25, n), [1.2, 1.2, 1.1]])
    masses = rng.uniform(1.05, 4.0, 500)
    table = PowerTable(ac, airspeed, climb, rho, 1.0, masses, method="table")
    exact = PowerTable(ac, airspeed, climb, rho, 1.0, masses, method="exact")
    assert table.method == "table" and exact.method == "exact"
    got = table.power(masses)[:, table.inverse]          # back to the states as given
    want = exact.power(masses)[:, exact.inverse]
    direct = ac.battery_power(airspeed, climb, rho, masses[:, None])
    np.testing.assert_allclose(want, direct, rtol=1e-13)
    np.testing.assert_allclose(got, want, rtol=1e-8)
    assert table.pieces                                    # the kinked states were split
    assert table.model_calls < 0.3 * exact.model_calls


def test_loaded_current_takes_one_resistance_per_pack():
    """The chain calls loaded_current once for a whole block of packs: a resistance per
    row must give what the scalar call gives for that row."""
    v = np.array([16.0, 16.0, 16.0])
    pw = np.array([100.0, 1270.0, 1290.0])      # the last beyond V²/4R for 0.05 Ω
    rows = loaded_current(pw[None, :], v[None, :], np.array([[0.0], [0.05]]))
    for row, r in zip(rows, (0.0, 0.05)):
        want = pw / v if r == 0 else (v - np.sqrt(np.maximum(v**2 - 4 * r * pw, 0))) / (2 * r)
        want = np.where(v**2 - 4 * r * pw >= 0, want, np.nan)
        np.testing.assert_allclose(row, want, rtol=1e-12)
    assert np.isnan(rows[1, 2]) and np.isfinite(rows[0, 2])


def test_large_pack_without_model_gets_the_extrapolated_literature_model():
    """A 12S pack with no fitted model: δ extrapolated from 6 cells (definitions), and the
    vectorised evaluation still agrees with ``check``."""
    ac = aircraft("solo_survey.yaml")
    mission = load_mission(REPO / "missions/survey_quad.yaml", vehicle_type=ac.type)
    big = load_battery(REPO / "aircraft/batteries/solo_5200_4s.yaml").__class__(
        name="12S without model", cells_series=12, capacity_mah=5000, mass_kg=1.0)
    assert big.model.literature and big.model.delta > 0
    ev = sel.evaluate_packs(mission, ac, [big])
    r = MissionChain(ac, big).check(mission)
    assert ev.margin_mah[0] == pytest.approx(r.margin_mah, rel=1e-3, abs=5.0)


# --------------------------------------------------------------------------- catalog

def test_shipped_catalog_spans_the_issue_range_with_sources():
    packs = load_catalog(CATALOG)
    assert len(packs) >= 15
    cells = {p.cells_series for p in packs}
    assert min(cells) == 3 and max(cells) == 12
    caps = [p.capacity_mah for p in packs]
    assert min(caps) <= 1500 and max(caps) >= 20000
    assert all(p.source for p in packs)
    assert all(p.model.delta > 0 for p in packs)
    # where a resistance is given, the source says where it comes from (or "assumed")
    assert all("ohm" in p.source.lower() or "resistance" in p.source.lower()
               for p in packs if p.internal_resistance_ohm)
    assert sum("assumed" in p.source for p in packs) >= 10


def test_catalog_folder_of_pack_files(tmp_path):
    for name in ("solo_5200_4s.yaml", "multistar_10ah_4s.yaml"):
        (tmp_path / name).write_text((REPO / "aircraft/batteries" / name).read_text())
    (tmp_path / "more.yaml").write_text(
        "packs:\n  - {name: a, cells_series: 3, capacity_mah: 2000, mass_kg: 0.2}\n")
    packs = load_catalog(tmp_path)
    assert sorted(p.name for p in packs) == ["3DR Solo Smart Battery 5200 mAh 4S",
                                             "Multistar 10.0 Ah 4S1P", "a"]


@pytest.mark.parametrize("text, needles", [
    (("packs:\n  - {name: a, cells_series: 3, capacity_mah: 2000, mass_kg: 0.2}\n"
      "  - {name: b, cells_series: 4, capacity_mah: 3000, mass_kg: 0.3, weight_kg: 1}\n"),
     ["packs[2]", "weight_kg"]),
    ("packs:\n  - {name: a, cells_series: 3, capacity_mah: 2000, mass_kg: -0.2}\n",
     ["packs[1]", "mass_kg", "> 0"]),
    (("packs:\n  - {name: a, cells_series: 3, capacity_mah: 2000, mass_kg: 0.2, price: -1}\n"
      "  - {name: b, cells_series: 3, capacity_mah: 2000}\n"),
     ["packs[1]", "price", "packs[2]", "mass_kg"]),
    ("packs: []\n", ["empty"]),
    ("pack:\n  - {name: a}\n", ["unknown key 'pack'", "packs"]),
    ("packs: {name: a}\n", ["packs must be a list"]),
])
def test_bad_catalogs_name_file_pack_and_key(tmp_path, text, needles):
    path = tmp_path / "cat.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as err:
        load_catalog(path)
    message = str(err.value)
    assert str(path) in message and "\n" not in message
    for needle in needles:
        assert needle in message
