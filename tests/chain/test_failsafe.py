"""Battery failsafe parameters from the mission (``check --failsafe``).

The thresholds are flown: the project's flight simulator (``testkit.flight``, the
equivalent-circuit pack with its own current integration, as an autopilot's current
sensor counts it) flies out to the mission's worst return point and holds there until the
autopilot's remaining-charge counter reaches the threshold, then returns home and lands.
At the suggested threshold it must land with the reserve; at a threshold 20 % lower it
must not (a threshold that is far too cautious would pass the first check and fail this
one).
"""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from planner.chain.mission_chain import MissionChain
from planner.cli.main import main
from planner.chain.failsafe import PX4_RANGES, failsafe_parameters
from planner.io.mission import load_mission
from planner.physics.mission import Environment, Leg, Mission
from planner.parameters import load_aircraft_and_battery
from testkit.flight import simulate_flight

REPO = Path(__file__).resolve().parents[2]
SURVEY = REPO / "missions/survey_quad.yaml"
SOLO = REPO / "aircraft/solo_survey.yaml"


def _solo_survey():
    aircraft, pack = load_aircraft_and_battery(SOLO)
    mission = load_mission(SURVEY, vehicle_type=aircraft.type)
    result = MissionChain(aircraft, pack).run(mission, detail=True)
    return aircraft, pack, mission, result


def _fly_to(point, hold_s, home_after):
    """Climb over home, fly to ``point`` (east, north, altitude), hold, and (optionally)
    return straight home and land — the path of an RTL from that point."""
    east, north, alt = point
    legs = [Leg("climb", start_alt_m=0.0, end_alt_m=alt, origin="climb"),
            Leg("cruise", (0.0, 0.0), (east, north), alt, alt, origin="out"),
            Leg("hover", (east, north), (east, north), alt, alt, duration_s=hold_s,
                origin="hold")]
    if home_after:
        legs += [Leg("cruise", (east, north), (0.0, 0.0), alt, alt, origin="rtl"),
                 Leg("descend", start_alt_m=alt, end_alt_m=0.0, origin="land")]
    return legs


def land_after_trigger(aircraft, pack, env, point, trigger_drawn_mah, seed=3):
    """Charge drawn on landing (by the simulator's current sensor) when the failsafe fires
    at the point as soon as ``trigger_drawn_mah`` has been drawn. [mAh]"""
    temp = env.temperature_c
    probe = Mission("probe", _fly_to(point, 3000.0, False), env)
    rec = simulate_flight(probe, aircraft, pack, environment=env, temperature_c=temp,
                          seed=seed, turbulence=0.03)
    drawn = rec.consumed_mah.to_numpy()
    k = int(np.argmax(drawn >= trigger_drawn_mah))
    assert drawn[k] >= trigger_drawn_mah, "the probe flight never reached the threshold"
    # time at the point before the trigger: the trigger time less climb and transit
    from planner.chain import kinematics as profile
    table = profile.leg_table(probe, aircraft, env, temperature_c=temp)
    t_hold = float(rec.time_s.iloc[k]) - float(table.start_time_s[2])
    assert t_hold > 0, "the threshold fires before the aircraft reaches the point"
    flight = Mission("rtl", _fly_to(point, t_hold, True), env)
    rec = simulate_flight(flight, aircraft, pack, environment=env, temperature_c=temp,
                          seed=seed, turbulence=0.03)
    return float(rec.consumed_mah.iloc[-1])


def test_ardupilot_low_threshold_at_the_worst_point_lands_with_the_reserve_and_20pct_lower_does_not():
    aircraft, pack, mission, result = _solo_survey()
    plan = failsafe_parameters(result, "ardupilot")
    w = plan.worst_point
    point = (w["east_m"], w["north_m"], w["altitude_m"])
    cap = plan.value("BATT_CAPACITY")
    low = plan.value("BATT_LOW_MAH")
    may_draw = float(result.usable_mah[0] - result.reserve_mah[0])   # lands with the reserve
    env = result.environment
    at_threshold = land_after_trigger(aircraft, pack, env, point, cap - low)
    assert at_threshold <= may_draw, (at_threshold, may_draw)
    lower = land_after_trigger(aircraft, pack, env, point, cap - 0.8 * low)
    assert lower > may_draw, (lower, may_draw)


def test_px4_critical_threshold_lands_with_the_reserve_where_the_firmware_range_holds_it():
    """A shorter out-and-back whose return fits PX4's BAT_CRIT_THR range [0.05, 0.10]:
    the return fires at BAT_CRIT_THR of BAT1_CAPACITY above the reserve."""
    aircraft, pack = load_aircraft_and_battery(SOLO)
    env = Environment(wind_speed_ms=5.0, wind_from_deg=250.0, temperature_c=14.0)
    far = (250.0, 250.0)
    legs = [Leg("climb", start_alt_m=0, end_alt_m=40, origin="climb"),
            Leg("cruise", (0, 0), far, 40, 40, origin="out"),
            Leg("hover", far, far, 40, 40, duration_s=300, origin="survey"),
            Leg("cruise", far, (0, 0), 40, 40, origin="back"),
            Leg("descend", start_alt_m=40, end_alt_m=0, origin="land")]
    result = MissionChain(aircraft, pack).run(Mission("short", legs, env), detail=True)
    plan = failsafe_parameters(result, "px4")
    crit = plan.value("BAT_CRIT_THR")
    lo, hi = PX4_RANGES["BAT_CRIT_THR"]
    assert lo <= crit <= hi and not any("BAT_CRIT_THR" in w for w in plan.warnings)
    cap_fw = plan.value("BAT1_CAPACITY")
    w = plan.worst_point
    drawn = land_after_trigger(aircraft, pack, env, (w["east_m"], w["north_m"],
                                                     w["altitude_m"]), cap_fw * (1 - crit))
    assert drawn <= result.usable_mah[0] - result.reserve_mah[0]
    # the thresholds are ordered as PX4 requires: low > critical > emergency
    assert plan.value("BAT_LOW_THR") > crit > plan.value("BAT_EMERGEN_THR")
    assert plan.value("COM_LOW_BAT_ACT") == 3


def test_the_forecast_headwind_home_raises_the_threshold():
    """The wind of the forecast enters the return: the survey's far corner is north-east
    of home, so a 15 m/s wind from the south-west is a headwind all the way home: the Solo
    flies at its maximum airspeed, 20 m/s, and makes 5 m/s over ground instead of the
    commanded 8 m/s, so the return takes longer at a higher power."""
    aircraft, pack = load_aircraft_and_battery(SOLO)
    mission = load_mission(SURVEY, vehicle_type=aircraft.type)
    chain = MissionChain(aircraft, pack)
    need = {}
    for speed in (0.0, 15.0):
        env = replace(mission.environment, wind_speed_ms=speed, wind_from_deg=215.0)
        plan = failsafe_parameters(chain.run(mission, env, detail=True), "ardupilot")
        need[speed] = (plan.return_charge_mah, plan.value("BATT_LOW_MAH"))
    assert need[15.0][0] > 1.2 * need[0.0][0], need
    assert need[15.0][1] > need[0.0][1], need


def test_values_are_within_the_firmware_documented_ranges_and_steps():
    *_, result = _solo_survey()
    ap = failsafe_parameters(result, "ardupilot")
    for name in ("BATT_LOW_MAH", "BATT_CRT_MAH"):   # @Increment: 50, mAh
        assert ap.value(name) % 50 == 0
    assert ap.value("BATT_LOW_MAH") > ap.value("BATT_CRT_MAH") > 0
    assert ap.value("BATT_LOW_VOLT") >= ap.value("BATT_CRT_VOLT")
    assert math.isclose(ap.value("BATT_LOW_VOLT") * 10, round(ap.value("BATT_LOW_VOLT") * 10))
    assert ap.value("BATT_FS_VOLTSRC") == 1          # the Solo pack states its resistance
    assert (ap.value("BATT_FS_LOW_ACT"), ap.value("BATT_FS_CRT_ACT")) == (2, 1)  # Copter
    px4 = failsafe_parameters(result, "px4")
    for name, (lo, hi) in PX4_RANGES.items():
        assert lo <= px4.value(name) <= hi
    assert -1.0 <= px4.value("BAT1_R_INTERNAL") <= 0.2
    assert px4.value("BAT1_N_CELLS") == 4
    # the survey's return needs more than PX4's 10 %: said, not hidden
    assert any("BAT_CRIT_THR" in w for w in px4.warnings)


def test_param_files_have_the_ground_station_formats():
    *_, result = _solo_survey()
    text = failsafe_parameters(result, "ardupilot").param_file("header")
    rows = [line for line in text.splitlines() if not line.startswith("#")]
    assert rows and all(len(r.split(",")) == 2 for r in rows)
    names = [r.split(",")[0] for r in rows]
    assert names[:3] == ["BATT_CAPACITY", "BATT_LOW_MAH", "BATT_CRT_MAH"]
    text = failsafe_parameters(result, "px4").param_file("header")
    rows = [line.split("\t") for line in text.splitlines() if not line.startswith("#")]
    assert all(len(r) == 5 and r[:2] == ["1", "1"] for r in rows)
    types = {r[2]: r[4] for r in rows}
    assert types["BAT1_N_CELLS"] == "6" and types["BAT_CRIT_THR"] == "9"


def test_cli_writes_the_param_file_and_the_json(tmp_path, capsys):
    out, js = tmp_path / "fs.param", tmp_path / "r.json"
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--failsafe", "ardupilot",
                   "--params-out", str(out), "--json", str(js)])
    assert status in (0, 1)
    text = capsys.readouterr().out
    assert "BATT_LOW_MAH" in text and "worst point" in text
    assert "BATT_LOW_MAH," in out.read_text()
    import json
    data = json.loads(js.read_text())
    names = [p["name"] for p in data["failsafe"]["parameters"]]
    assert "BATT_CRT_MAH" in names
    assert all(p["derivation"] for p in data["failsafe"]["parameters"])


@pytest.mark.parametrize("argv, message", [
    (["--failsafe", "inav"], "--failsafe: unknown firmware 'inav'"),
    (["--params-out", "x.param"], "--params-out: needs --failsafe"),
])
def test_cli_bad_firmware_exits_2(argv, message, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), *argv])
    assert status == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "x.param").exists()
