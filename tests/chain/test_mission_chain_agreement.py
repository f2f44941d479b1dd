"""select and check are one code path: every shipped pack, every shipped mission.

The mission chain (planner.chain.mission_chain) flies a catalog on its pack axis for ``select`` and one
pack for ``check``. These tests hold the two answers together pack by pack, on the
shipped catalog and pack files, the shipped missions, warm and cold, with the packs'
circuit and thermal blocks and without them.
"""

import json
from pathlib import Path

import pytest

from planner.chain import selection as sel
from planner.chain.mission_chain import MissionChain
from planner.cli.main import main
from planner.io.mission import load_mission
from planner.parameters import load_aircraft, load_battery, load_catalog

REPO = Path(__file__).resolve().parents[2]
CATALOG = REPO / "aircraft/packs/catalog.yaml"
PACK_FILES = sorted((REPO / "aircraft/batteries").glob("*.yaml"))
MISSIONS = [("solo_survey.yaml", "missions/survey_quad.yaml"),
            ("solo_survey.yaml", "missions/survey_route.plan"),
            ("x8_mapper.yaml", "missions/mapping_plane.yaml")]


def all_packs():
    return load_catalog(CATALOG) + [load_battery(p) for p in PACK_FILES]


@pytest.mark.parametrize("battery_model", ["infer", "integral"])
@pytest.mark.parametrize("temperature", [25.0, 0.0])
@pytest.mark.parametrize("aircraft_name, mission_path", MISSIONS)
def test_select_reports_what_check_says_for_every_shipped_pack(aircraft_name, mission_path,
                                                               temperature, battery_model):
    ac = load_aircraft(REPO / "aircraft" / aircraft_name)
    mission = load_mission(REPO / mission_path, vehicle_type=ac.type)
    packs = all_packs()
    ev = sel.evaluate_packs(mission, ac, packs, temperature_c=temperature,
                            battery_model=battery_model)
    circuits = 0
    for i, pack in enumerate(packs):
        r = MissionChain(ac, pack, temperature_c=temperature,
                         battery_model=battery_model).check(mission)
        assert ev.check_go[i] == r.go == ev.feasible[i], (pack.name, ev.reasons(i),
                                                          r.reasons)
        assert ev.charge_used_mah[i] == pytest.approx(r.charge_used_mah, abs=0.1)
        assert ev.margin_mah[i] == pytest.approx(r.margin_mah, abs=0.1)
        assert ev.usable_mah[i] == pytest.approx(r.usable_mah, abs=0.1)
        assert ev.binding(i) == r.binding
        circuits += ev.result.battery_models[i] == "circuit"
    # the "with circuit blocks" runs really fly some packs through the circuit
    assert (circuits > 0) == (battery_model == "infer")


def test_the_solo_pack_at_0_c_gets_one_answer_from_select_and_check(tmp_path):
    """The case that split the two commands: select said "OK, best, +609 mAh" for the
    3DR Solo pack at 0 °C where check grounded the mission (NO-GO, −230 mAh)."""
    mission = str(REPO / "missions/survey_quad.yaml")
    solo = str(REPO / "aircraft/solo_survey.yaml")
    out_s, out_c = tmp_path / "select.json", tmp_path / "check.json"
    main(["select", mission, "--aircraft", solo, "--packs", str(CATALOG),
          "--temperature", "0", "--json", str(out_s)])
    code = main(["check", mission, "--aircraft", solo, "--temperature", "0",
                 "--battery", str(REPO / "aircraft/batteries/solo_5200_4s.yaml"),
                 "--json", str(out_c)])
    selected = json.loads(out_s.read_text())
    checked = json.loads(out_c.read_text())
    entry = next(p for p in selected["packs"] if p["name"].startswith("3DR Solo"))
    assert code == 1 and checked["verdict"] == "NO-GO"
    assert entry["check_verdict"] == "NO-GO" and not entry["feasible"]
    assert entry["margin_mah"] == pytest.approx(checked["margin_mah"], abs=0.1)
    assert entry["charge_used_mah"] == pytest.approx(checked["charge_used_mah"], abs=0.1)


def test_a_pack_select_rejects_for_its_cells_is_no_go_in_check_with_the_same_reason(tmp_path):
    """The 6S DJI TB47D on the 4S-only 3DR Solo: check said GO (+1255 mAh) where select
    rejected it ("6S pack, the aircraft allows 4S")."""
    mission = str(REPO / "missions/survey_quad.yaml")
    solo = str(REPO / "aircraft/solo_survey.yaml")
    out_s, out_c = tmp_path / "select.json", tmp_path / "check.json"
    main(["select", mission, "--aircraft", solo, "--packs", str(CATALOG),
          "--json", str(out_s)])
    code = main(["check", mission, "--aircraft", solo, "--json", str(out_c),
                 "--battery", str(REPO / "aircraft/batteries/dji_tb47d.yaml")])
    entry = next(p for p in json.loads(out_s.read_text())["packs"]
                 if p["name"].startswith("DJI TB47D"))
    checked = json.loads(out_c.read_text())
    assert not entry["feasible"] and entry["binding"] == "cells"
    assert code == 1 and checked["verdict"] == "NO-GO"
    assert checked["reasons"][0] == entry["reasons"][0] == "6S pack, the aircraft allows 4S"


def test_a_thrust_to_weight_below_the_minimum_is_no_go_in_check_as_in_select(tmp_path):
    """A Solo whose rotors give 1.12 × its take-off weight: GO in check, rejected by select
    (minimum 1.5)."""
    text = (REPO / "aircraft/solo_survey.yaml").read_text()
    pack = REPO / "aircraft/batteries/solo_5200_4s.yaml"
    ac = load_aircraft(REPO / "aircraft/solo_survey.yaml")
    mission = load_mission(REPO / "missions/survey_quad.yaml", vehicle_type=ac.type)
    mass = MissionChain(ac, load_battery(pack)).check(mission).takeoff_mass_kg
    thrust = 1.12 * mass * 9.80665
    path = tmp_path / "solo_weak.yaml"
    path.write_text(text.replace("battery: batteries/", f"battery: {REPO}/aircraft/batteries/")
                    .replace("multirotor:\n", f"multirotor:\n  max_thrust_n: {thrust:.3f}\n"))
    out_s, out_c = tmp_path / "select.json", tmp_path / "check.json"
    main(["select", str(REPO / "missions/survey_quad.yaml"), "--aircraft", str(path),
          "--packs", str(pack), "--json", str(out_s), "--no-sorties"])
    code = main(["check", str(REPO / "missions/survey_quad.yaml"), "--aircraft", str(path),
                 "--json", str(out_c)])
    entry = json.loads(out_s.read_text())["packs"][0]
    checked = json.loads(out_c.read_text())
    assert entry["thrust_to_weight"] == pytest.approx(1.12, abs=1e-3)
    assert not entry["feasible"] and entry["binding"] == "thrust"
    assert code == 1 and checked["verdict"] == "NO-GO"
    assert checked["reasons"][0] == entry["reasons"][0]
    assert "thrust-to-weight 1.12" in checked["reasons"][0] and "minimum 1.5" in \
        checked["reasons"][0]
