"""``endurance hybrid``: the supercapacitor bank on a real mission profile."""

import json
from pathlib import Path

from planner.cli.main import main

REPO = Path(__file__).resolve().parents[3]


def test_supercap_shaves_the_climb_peak_of_a_mission(tmp_path):
    out = tmp_path / "h.json"
    code = main(["hybrid", str(REPO / "missions/survey_route.yaml"), "--aircraft",
                 str(REPO / "aircraft/solo_survey.yaml"), "--temperature", "0",
                 "--json", str(out)])
    assert code == 0
    d = json.loads(out.read_text())
    assert d["peak_battery_current_a"] < d["peak_battery_current_alone_a"]
    assert d["sag_margin_v"] > d["sag_margin_alone_v"]
    assert 0 < d["j2"] < d["j1"] < 1            # as the seed paper's Table 3 orders them


def test_pack_without_resistance_is_bad_input(tmp_path, capsys):
    code = main(["hybrid", str(REPO / "missions/survey_route.yaml"), "--aircraft",
                 str(REPO / "aircraft/dji_m100.yaml")])
    assert code == 2
    assert "r0_ohm" in capsys.readouterr().err
