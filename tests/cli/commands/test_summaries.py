"""Summaries that explain themselves: the rejection reasons of select printed whole, the
sweeps naming the limit a row exceeds, the check's return-home column named as the margin
it is."""

import json
from pathlib import Path

from planner.cli.main import main
from planner.parameters import load_aircraft

REPO = Path(__file__).resolve().parents[3]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
SURVEY = str(REPO / "missions/survey_quad.yaml")
CATALOG = str(REPO / "aircraft/packs/catalog.yaml")


def test_select_prints_every_rejection_reason_whole(tmp_path, capsys):
    js = tmp_path / "s.json"
    main(["select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--json", str(js)])
    out = capsys.readouterr().out
    packs = json.loads(js.read_text())["packs"]
    rejected = [p for p in packs if not p["feasible"] and p["reasons"]]
    assert rejected and any(len(p["reasons"][0]) > 70 for p in rejected)
    for p in rejected:
        assert f"{p['binding']}: {p['reasons'][0]}" in out
    assert not any(line.rstrip().endswith("...") for line in out.splitlines())


def test_sweeps_name_the_limit_a_row_exceeds(capsys):
    mtow = load_aircraft(SOLO).max_takeoff_mass_kg
    main(["sweep", "payload", "--aircraft", SOLO, "--range", "0:1", "--points", "5"])
    out = capsys.readouterr().out
    assert "exceeded" not in out
    over = [line for line in out.splitlines() if "take-off mass over" in line]
    assert over and all(f"the {mtow:.2f} kg maximum" in line for line in over)
    # exactly the rows whose take-off mass is above the maximum
    for line in out.splitlines():
        parts = line.split()
        if len(parts) > 2 and parts[0].replace(".", "").isdigit():
            assert (float(parts[1]) > mtow) == ("take-off mass over" in line)


def test_check_names_the_return_home_column_as_a_margin(capsys):
    main(["check", SURVEY, "--aircraft", SOLO])
    out = capsys.readouterr().out
    assert "RTL margin mAh" in out and "RTL mAh" not in out
