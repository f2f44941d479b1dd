"""Hover (loiter) and least-power endurance of a pack at its take-off mass, to the
reserve ([UAV23] eq. 15 at constant power): the check's one-line flight times."""

from pathlib import Path

import pytest

from planner.chain.mission_chain import MissionChain
from planner.cli.main import main
from planner.parameters import load_aircraft_and_battery
from planner.physics.mission import Environment, Leg, Mission

REPO = Path(__file__).resolve().parents[2]


def run(aircraft, mission, env=Environment()):
    ac, pack = load_aircraft_and_battery(REPO / "aircraft" / aircraft, None)
    return MissionChain(ac, pack).run(mission, env, detail=True)


@pytest.mark.parametrize("aircraft", ["solo_survey.yaml", "quad_7in.yaml"])
def test_hover_endurance_is_a_hover_mission_plus_its_margin(aircraft):
    """A mission that only hovers on the ground for 300 s at the hold's own power: the
    hover endurance from full is those 300 s plus the margin as extra hover (the integral
    model's stress is additive at constant power, [UAV23] eq. 14–15)."""
    mission = Mission("hover", [Leg("hover", duration_s=300.0)])
    result = run(aircraft, mission)
    r = result.mission_result(0)
    e = r.endurance
    assert r.legs["power_w"].iloc[0] == pytest.approx(e["hold_power_w"], rel=1e-9)
    assert e["hold_s"] == pytest.approx(300.0 + r.margin_time_s, rel=1e-6)
    # the same charge at another constant power: t ∝ P^ε ([UAV23] eq. 15)
    eps = result.packs[0].model.epsilon
    assert e["least_power_s"] / e["hold_s"] == pytest.approx(
        (e["least_power_w"] / e["hold_power_w"]) ** eps, rel=1e-9)
    # at the speed of least power the power is at most the hover's (the optimiser may
    # stop at the aircraft's least airspeed, a hair above the hover power)
    assert e["least_power_w"] <= e["hold_power_w"] * 1.001


def test_a_bigger_reserve_shortens_the_endurance():
    ac, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml", None)
    mission = Mission("hover", [Leg("hover", duration_s=60.0)])
    e20 = MissionChain(ac, pack, reserve=0.2).run(mission, Environment(), detail=True)
    e40 = MissionChain(ac, pack, reserve=0.4).run(mission, Environment(), detail=True)
    assert e40.endurance(0)["hold_s"] < e20.endurance(0)["hold_s"]


def test_check_prints_the_endurance_line(capsys):
    status = main(["check", str(REPO / "missions/mapping_plane.yaml"), "--aircraft",
                   str(REPO / "aircraft/x8_mapper.yaml")])
    out = capsys.readouterr().out
    assert status in (0, 1)
    line = next(l for l in out.splitlines() if l.startswith("Endurance"))
    assert "loiter" in line and "speed of least power" in line and "min" in line
