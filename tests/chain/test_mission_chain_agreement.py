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
        assert ev.check_go[i] == r.go, (pack.name, ev.reasons(i), r.reasons)
        assert ev.charge_used_mah[i] == pytest.approx(r.charge_used_mah, abs=0.1)
        assert ev.margin_mah[i] == pytest.approx(r.margin_mah, abs=0.1)
        assert ev.usable_mah[i] == pytest.approx(r.usable_mah, abs=0.1)
        check_codes = [c for c in ev.constraints(i) if c not in ("cells", "thrust")]
        assert check_codes == ([] if r.go else [r.binding] + check_codes[1:])
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
