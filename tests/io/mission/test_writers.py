"""Sortie mission files (``select --sorties-out``) and the mission writers behind them."""

from pathlib import Path

import numpy as np
import pytest

from planner.chain.mission_chain import MissionChain
from planner.cli.main import main
from testkit.missions import write_waypoints
from planner.io.mission import load_mission, writers
from planner.parameters import load_aircraft, load_catalog

REPO = Path(__file__).resolve().parents[3]
SOLO = REPO / "aircraft/solo_survey.yaml"
CATALOG = REPO / "aircraft/packs/catalog.yaml"


def same_legs(a, b, tol_m=0.02):
    assert [leg.kind for leg in a.legs] == [leg.kind for leg in b.legs]
    for la, lb in zip(a.legs, b.legs):
        assert np.allclose(la.end_en_m, lb.end_en_m, atol=tol_m)
        assert la.end_alt_m == pytest.approx(lb.end_alt_m, abs=1e-3)
        assert (la.duration_s or 0.0) == pytest.approx(lb.duration_s or 0.0, abs=1e-3)
        assert la.speed_ms == lb.speed_ms


@pytest.mark.parametrize("name", ["survey_route.waypoints", "survey_route.plan",
                                  "survey_route.yaml", "survey_quad.yaml"])
@pytest.mark.parametrize("fmt", ["waypoints", "plan", "yaml"])
def test_written_missions_read_back_into_the_same_legs(name, fmt, tmp_path):
    mission = load_mission(REPO / "missions" / name, vehicle_type="multirotor")
    if fmt != "yaml" and mission.home is None:
        with pytest.raises(Exception, match="no home position"):
            writers.to_waypoints(mission)
        return
    text = {"waypoints": writers.to_waypoints, "plan": writers.to_plan,
            "yaml": writers.to_yaml}[fmt](mission)
    path = tmp_path / f"m.{fmt}"
    path.write_text(text)
    same_legs(mission, load_mission(path, vehicle_type="multirotor"))


@pytest.fixture(scope="module")
def long_survey(tmp_path_factory):
    """A 400-waypoint survey no single pack of the catalog flies: two sorties."""
    folder = tmp_path_factory.mktemp("long")
    wp = folder / "survey.waypoints"
    write_waypoints(wp, n=400)
    mission = load_mission(wp, vehicle_type="multirotor")
    (folder / "survey.plan").write_text(writers.to_plan(mission))
    (folder / "survey.yaml").write_text(writers.to_yaml(mission))
    # one pack that needs two sorties (a catalog of one keeps the sortie search short)
    (folder / "solo.yaml").write_text(
        f"name: Solo pack\npacks:\n  - file: {REPO / 'aircraft/batteries/solo_5200_4s.yaml'}\n")
    return folder


@pytest.mark.parametrize("suffix", [".waypoints", ".plan", ".yaml"])
def test_each_sortie_file_is_in_the_input_format_and_passes_check(long_survey, suffix,
                                                                   tmp_path, capsys):
    src = long_survey / f"survey{suffix}"
    out = tmp_path / "sorties"
    out.mkdir()
    status = main(["select", str(src), "--aircraft", str(SOLO), "--packs",
                   str(long_survey / "solo.yaml"), "--sorties-out", str(out)])
    text = capsys.readouterr().out
    assert status == 1 and "Swap 1" in text
    written = sorted(out.iterdir())
    assert [p.name for p in written] == [f"survey_sortie{k}{suffix}"
                                         for k in range(1, len(written) + 1)]
    assert len(written) >= 2
    # the plan's pack flies each file on its own (the sorties are planned with it)
    aircraft = load_aircraft(SOLO)
    plan_pack = text.split("Sorties   fewest: ")[1].split(" flight(s) with ")[1].split(" (")[0]
    pack = next(p for p in load_catalog(long_survey / "solo.yaml") if p.name == plan_pack)
    swap = text.split("Swap 1")[1].split("\n")[0]
    east = float(swap.split(" m E ")[0].split(", ")[-1])
    for k, path in enumerate(written, 1):
        mission = load_mission(path, vehicle_type=aircraft.type)
        result = MissionChain(aircraft, pack).check(mission)
        assert result.verdict == "GO", (path.name, result.reasons)
        first_cruise = next(leg for leg in mission.legs if leg.kind == "cruise")
        if k == 2:   # starts with a transit from home to where the first one stopped
            assert first_cruise.start_en_m == pytest.approx((0.0, 0.0), abs=1e-6)
            assert first_cruise.end_en_m[0] == pytest.approx(east, abs=1.0)
        assert mission.legs[-1].kind == "descend" and mission.legs[-1].end_alt_m == 0


def test_sorties_out_bad_input_exits_2(long_survey, tmp_path, capsys):
    src = long_survey / "survey.waypoints"
    status = main(["select", str(src), "--aircraft", str(SOLO), "--packs", str(CATALOG),
                   "--sorties-out", str(tmp_path / "missing")])
    err = capsys.readouterr().err
    assert status == 2 and "--sorties-out" in err and "not an existing folder" in err
    other = tmp_path / "m.mission"
    other.write_text((long_survey / "survey.waypoints").read_text())
    status = main(["select", str(other), "--aircraft", str(SOLO), "--packs", str(CATALOG),
                   "--sorties-out", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 2 and "cannot write missions in the format" in err
