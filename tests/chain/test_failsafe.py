"""Battery failsafe parameters from the mission (``check --failsafe``).

The thresholds are flown: the project's flight simulator (``testkit.flight``, the
equivalent-circuit pack with its own current integration, as an autopilot's current
sensor counts it) flies out to the mission's worst return point and holds there until the
autopilot's remaining-charge counter reaches the threshold, then returns home and lands.
At the suggested threshold it must land with the reserve; at a threshold 20 % lower it
must not (a threshold that is far too cautious would pass the first check and fail this
one).
"""

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from planner.chain import failsafe as fs
from planner.chain.failsafe import PX4_STABLE_VERSION, failsafe_parameters, px4_release
from planner.chain.mission_chain import MissionChain
from planner.cli.main import main
from planner.io.mission import load_mission
from planner.parameters import battery_from_mapping, load_aircraft, load_aircraft_and_battery
from planner.physics.battery.chemistry import chemistry
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.mission import Environment, Leg, Mission
from testkit.flight import simulate_flight

REPO = Path(__file__).resolve().parents[2]
SURVEY = REPO / "missions/survey_quad.yaml"
ROUTE = REPO / "missions/survey_route.yaml"
SOLO = REPO / "aircraft/solo_survey.yaml"
X8 = REPO / "aircraft/x8_mapper.yaml"
MAPPING = REPO / "missions/mapping_plane.yaml"
CATALOG = REPO / "aircraft/packs/catalog.yaml"
#: The PX4 ranges of the release used by default.
PX4_RANGES = px4_release(PX4_STABLE_VERSION).ranges


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


def land_after_trigger(aircraft, pack, env, point, trigger_drawn_mah, seed=3, hold_after_s=0.0):
    """Charge drawn on landing (by the simulator's current sensor) when the failsafe fires
    at the point as soon as ``trigger_drawn_mah`` has been drawn and acts ``hold_after_s``
    later (PX4's hold). [mAh]"""
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
    flight = Mission("rtl", _fly_to(point, t_hold + hold_after_s, True), env)
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
    """A shorter out-and-back whose return fits PX4's BAT_CRIT_THR range: the return fires
    at BAT_CRIT_THR of BAT1_CAPACITY above the reserve, after PX4's COM_FAIL_ACT_T hold."""
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
    hold = plan.value("COM_FAIL_ACT_T")
    assert hold == px4_release(PX4_STABLE_VERSION).hold_s
    drawn = land_after_trigger(aircraft, pack, env, (w["east_m"], w["north_m"],
                                                     w["altitude_m"]), cap_fw * (1 - crit),
                               hold_after_s=hold)
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
    assert math.isclose(ap.value("BATT_LOW_VOLT") * 10, round(ap.value("BATT_LOW_VOLT") * 10))
    assert ap.value("BATT_FS_VOLTSRC") == 1          # the Solo pack states its resistance
    assert (ap.value("BATT_FS_LOW_ACT"), ap.value("BATT_FS_CRT_ACT")) == (2, 1)  # Copter
    px4 = failsafe_parameters(result, "px4")
    for name, (lo, hi) in PX4_RANGES.items():
        assert lo <= px4.value(name) <= hi
    assert -1.0 <= px4.value("BAT1_R_INTERNAL") <= 0.2
    assert px4.value("BAT1_N_CELLS") == 4
    assert px4.go and not px4.reasons
    # the survey's return needs more than the 10 % of PX4 before v1.11: NO-GO, said
    old = failsafe_parameters(result, "px4", firmware_version="v1.10.2")
    assert not old.go and any("BAT_CRIT_THR" in r and "0.1" in r for r in old.reasons)


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


# --------------------------------------------------------------------------- the pack's curve

def _catalog_pack(name_start: str, **changes):
    """A pack of the shipped catalog (written inline there), with ``changes``."""
    data = yaml.safe_load(CATALOG.read_text())
    entry = next(p for p in data["packs"] if p.get("name", "").startswith(name_start))
    return battery_from_mapping({**entry, **changes}, str(CATALOG))


def test_a_liion_pack_gets_its_chemistry_curve_not_the_lipo_one():
    """The catalog's Molicel P42A 4S2P (chemistry: liion) on the Solo survey: the landing
    reserve leaves 20 % charge, where an NMC cell rests near 3.48 V and a LiPo near 3.73 V;
    PX4's empty voltage and the return's loaded current are the NMC curve's."""
    aircraft = load_aircraft(SOLO)
    pack = _catalog_pack("Molicel P42A 4S2P")
    mission = load_mission(ROUTE, vehicle_type=aircraft.type)
    result = MissionChain(aircraft, pack).run(mission, detail=True)
    plan = failsafe_parameters(result, "px4")
    soc = float(result.reserve_mah[0] + result.capacity_mah[0] - result.usable_mah[0]) \
        / float(result.capacity_mah[0])
    nmc = chemistry("liion").ocv
    assert plan.value("BAT1_V_EMPTY") == pytest.approx(math.ceil(nmc(soc) * 100 - 1e-9) / 100)
    assert float(lipo_ocv(soc)) - plan.value("BAT1_V_EMPTY") > 0.2
    assert plan.value("BAT1_V_CHARGED") == pytest.approx(4.19)
    assert "liion_nmc" in plan.parameter("BAT1_V_EMPTY").derivation


def test_a_fitted_ocv_table_in_the_pack_file_is_used(tmp_path):
    """A pack file whose circuit block names an OCV table (as fit-battery writes it): the
    failsafe voltages come from that table, not from the chemistry."""
    (tmp_path / "cell_ocv.csv").write_text("soc [1],ocv [V]\n0,3.0\n1,4.2\n")
    data = yaml.safe_load((REPO / "aircraft/batteries/solo_5200_4s.yaml").read_text())
    data["circuit"] = {**(data.get("circuit") or {}), "ocv_csv": "cell_ocv.csv"}
    data.pop("thermal", None)
    path = tmp_path / "pack.yaml"
    path.write_text(yaml.safe_dump(data))
    from planner.parameters import load_battery
    pack = load_battery(path)
    aircraft = load_aircraft(SOLO)
    result = MissionChain(aircraft, pack).run(load_mission(ROUTE, vehicle_type=aircraft.type),
                                              detail=True)
    plan = failsafe_parameters(result, "px4")
    soc = 1.0 - float(result.usable_mah[0] - result.reserve_mah[0]) / float(
        result.capacity_mah[0])
    assert plan.value("BAT1_V_EMPTY") == pytest.approx(
        math.ceil((3.0 + 1.2 * soc) * 100 - 1e-9) / 100)
    assert plan.value("BAT1_V_CHARGED") == pytest.approx(4.2)
    assert "cell_ocv.csv" in plan.parameter("BAT1_V_EMPTY").derivation


def test_cli_refuses_an_unknown_chemistry_naming_file_key_and_choices(tmp_path, capsys):
    data = yaml.safe_load((REPO / "aircraft/batteries/lipo_4s_1500.yaml").read_text())
    data["chemistry"] = "banana"
    path = tmp_path / "banana.yaml"
    path.write_text(yaml.safe_dump(data))
    status = main(["check", str(ROUTE), "--aircraft", str(SOLO), "--battery", str(path),
                   "--failsafe", "ardupilot"])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err
    assert str(path) in err and "chemistry" in err and "'banana'" in err
    for name in ("lipo", "lihv", "liion_nmc", "liion_nca", "lifepo4", "liion"):
        assert name in err


# --------------------------------------------------------------------------- low vs critical

def _out_and_back(pack, distance_m):
    aircraft = load_aircraft(SOLO)
    # at the cold laws' reference temperature: the pack gives its stated usable charge
    env = Environment(wind_speed_ms=0.0, wind_from_deg=0.0, temperature_c=25.0)
    far = (distance_m, 0.0)
    legs = [Leg("climb", start_alt_m=0, end_alt_m=40, origin="climb"),
            Leg("cruise", (0, 0), far, 40, 40, origin="out"),
            Leg("cruise", far, (0, 0), 40, 40, origin="back"),
            Leg("descend", start_alt_m=40, end_alt_m=0, origin="land")]
    return MissionChain(aircraft, pack).run(Mission("far", legs, env), detail=True)


def test_solo_low_and_critical_voltages_are_never_equal_nor_closer_than_the_noise():
    """ArduPilot tests the critical voltage first (AP_BattMonitor_Backend::update_failsafes):
    the Solo's 15.1 / 15.0 V would land it where it is instead of bringing it home. Either
    the two lie further apart than twice the sensor noise plus the unseen sag, or the
    voltage failsafe is off and says why."""
    *_, result = _solo_survey()
    plan = failsafe_parameters(result, "ardupilot")
    low, crit = plan.value("BATT_LOW_VOLT"), plan.value("BATT_CRT_VOLT")
    if low == 0.0 or crit == 0.0:
        assert low == crit == 0.0
        assert "off" in plan.parameter("BATT_LOW_VOLT").derivation
        assert "critical level first" in plan.parameter("BATT_LOW_VOLT").derivation
    else:
        assert low - crit >= 2 * fs.VOLTAGE_NOISE_V
    assert plan.value("BATT_LOW_TIMER") == fs.BATT_LOW_TIMER_S


def test_voltage_levels_far_apart_are_set_from_the_curve_and_the_timer():
    """A 3.5 km out-and-back on the P42A pack: the return is long enough that the two
    levels lie apart on the NMC curve by more than the firmware's noise and the sag its
    estimate does not see; each voltage is the resting voltage of its mAh level plus the
    charge drawn over BATT_LOW_TIMER."""
    pack = _catalog_pack("Molicel P42A 4S2P")
    result = _out_and_back(pack, 3500.0)
    plan = failsafe_parameters(result, "ardupilot")
    low, crit = plan.value("BATT_LOW_VOLT"), plan.value("BATT_CRT_VOLT")
    assert low > crit > 0.0
    r = fs.pack_resistance_ohm(pack)
    assert low - crit >= 2 * fs.VOLTAGE_NOISE_V + 10.0 * r   # at least 10 A of unseen sag
    nmc, cap = chemistry("liion").ocv, float(result.capacity_mah[0])
    soc_low = plan.value("BATT_LOW_MAH") / cap
    assert low >= 4 * float(nmc(soc_low))                    # fires no later than the mAh
    assert low - 4 * float(nmc(soc_low)) < 0.1 + 4 * 0.02    # by the timer's charge at most
    # the shorter mission on the same pack: too close to tell apart, so off
    near = failsafe_parameters(_out_and_back(pack, 1500.0), "ardupilot")
    assert near.value("BATT_LOW_VOLT") == near.value("BATT_CRT_VOLT") == 0.0
    assert "mΩ" in near.parameter("BATT_LOW_VOLT").derivation


def test_without_a_resistance_the_voltage_failsafe_is_off_and_says_why():
    pack = _catalog_pack("Molicel P42A 4S2P", internal_resistance_ohm=None)
    plan = failsafe_parameters(_out_and_back(pack, 3500.0), "ardupilot")
    assert plan.value("BATT_LOW_VOLT") == plan.value("BATT_CRT_VOLT") == 0.0
    assert "no resistance" in plan.parameter("BATT_LOW_VOLT").derivation


def test_copter_levels_rtl_at_low_land_at_critical_and_low_above_critical():
    *_, result = _solo_survey()
    plan = failsafe_parameters(result, "ardupilot")
    base = float(result.reserve_mah[0] + result.capacity_mah[0] - result.usable_mah[0])
    assert plan.value("BATT_LOW_MAH") >= base + plan.return_charge_mah
    assert plan.value("BATT_CRT_MAH") >= base + plan.descent_charge_mah
    assert plan.value("BATT_LOW_MAH") > plan.value("BATT_CRT_MAH")
    assert [lv["action"] for lv in plan.levels] == ["RTL", "Land"]


# --------------------------------------------------------------------------- the plane

def _x8_mapping():
    aircraft, pack = load_aircraft_and_battery(X8)
    mission = load_mission(MAPPING, vehicle_type=aircraft.type)
    return aircraft, pack, mission, MissionChain(aircraft, pack).run(mission, detail=True)


def test_arduplane_critical_land_covers_the_landing_sequence_not_a_descent():
    """ArduPlane's BATT_FS_CRT_ACT 2 "Land" flies to the mission's landing sequence
    (ArduPlane/events.cpp): from the far end of the mapping lines that is the way home and
    the three-turn loiter and descent, not a descent from the highest point (9 mAh)."""
    aircraft, pack, mission, result = _x8_mapping()
    plan = failsafe_parameters(result, "ardupilot")
    base = float(result.reserve_mah[0] + result.capacity_mah[0] - result.usable_mah[0])
    k = fs.landing_sequence_start(result.table)
    assert k == len(mission.legs) - 2                       # the loiter before the descent
    loiter = float(result.detail["charge_mah"][0, k])
    assert plan.value("BATT_CRT_MAH") >= base + plan.return_charge_mah + 0.9 * loiter
    assert plan.value("BATT_LOW_MAH") > plan.value("BATT_CRT_MAH")
    assert (plan.value("BATT_FS_LOW_ACT"), plan.value("BATT_FS_CRT_ACT")) == (1, 2)
    assert "landing sequence" in plan.parameter("BATT_CRT_MAH").derivation


def _plane_lands_after(aircraft, pack, mission, k, env, point, trigger_drawn_mah):
    """Charge drawn on landing when ArduPlane's Land fires at ``point`` once
    ``trigger_drawn_mah`` is drawn: to the landing sequence (legs ``k``…) and through it."""
    from planner.chain import kinematics
    probe = Mission("probe", _fly_to(point, 4000.0, False), env)
    rec = simulate_flight(probe, aircraft, pack, environment=env,
                          temperature_c=env.temperature_c, seed=5, turbulence=0.03)
    drawn = rec.consumed_mah.to_numpy()
    i = int(np.argmax(drawn >= trigger_drawn_mah))
    assert drawn[i] >= trigger_drawn_mah, "the probe flight never reached the threshold"
    t_hold = float(rec.time_s.iloc[i]) - float(kinematics.leg_table(
        probe, aircraft, env, temperature_c=env.temperature_c).start_time_s[2])
    assert t_hold > 0
    start = mission.legs[k]
    legs = _fly_to(point, t_hold, False) + [
        Leg("cruise", point[:2], start.start_en_m, point[2], start.start_alt_m,
            origin="to the landing")] + list(mission.legs[k:])
    rec = simulate_flight(Mission("land", legs, env), aircraft, pack, environment=env,
                          temperature_c=env.temperature_c, seed=5, turbulence=0.03)
    return float(rec.consumed_mah.iloc[-1])


def test_arduplane_land_at_the_critical_level_reaches_the_runway_with_the_reserve():
    """Flown by the simulator: out to the worst point, hold until BATT_CRT_MAH is left, then
    to the landing sequence and through it: lands with the reserve; with BATT_CRT_MAH 20 %
    lower it does not."""
    aircraft, pack, mission, result = _x8_mapping()
    plan = failsafe_parameters(result, "ardupilot")
    k = fs.landing_sequence_start(result.table)
    w = plan.levels[1]["where"]
    point = (w["east_m"], w["north_m"], w["altitude_m"])
    cap, crt = plan.value("BATT_CAPACITY"), plan.value("BATT_CRT_MAH")
    may_draw = float(result.usable_mah[0] - result.reserve_mah[0])
    env = result.environment
    assert _plane_lands_after(aircraft, pack, mission, k, env, point, cap - crt) <= may_draw
    assert _plane_lands_after(aircraft, pack, mission, k, env, point,
                              cap - 0.8 * crt) > may_draw


def test_px4_x8_return_fires_with_the_charge_home_and_the_hold():
    """The mapping plane needs 799 mAh to get home from the far end of the lines; PX4's
    v1.17 ranges let BAT_CRIT_THR cover it with the COM_FAIL_ACT_T hold (v1.10's 0.10 of
    7100 mAh fired the return at 710 mAh: NO-GO there, not a clamp)."""
    *_, result = _x8_mapping()
    plan = failsafe_parameters(result, "px4")
    assert plan.go and not plan.reasons
    cap_fw = plan.value("BAT1_CAPACITY")
    # at least 5 s of loiter at the hold power, drawn at the full pack's 16.8 V
    hold_mah = 5.0 * float(result.hold_power_w[0]) / 16.8 / 3.6
    assert plan.value("BAT_CRIT_THR") * cap_fw >= plan.return_charge_mah + hold_mah
    assert plan.value("COM_FAIL_ACT_T") == 5.0
    lo, hi = PX4_RANGES["BAT_CRIT_THR"]
    assert lo <= plan.value("BAT_CRIT_THR") <= hi
    old = failsafe_parameters(result, "px4", firmware_version="1.10")
    assert not old.go
    assert any("BAT_CRIT_THR" in r and "at most 0.1" in r for r in old.reasons)
    with pytest.raises(ValueError):
        old.param_file()


@pytest.mark.parametrize("version, hold_param, crit_max", [
    ("v1.10.2", None, 0.10), ("1.12.3", None, 0.25), ("1.13", "COM_BAT_ACT_T", 0.25),
    ("1.14.0", "COM_FAIL_ACT_T", 0.25), ("v1.15.4", "COM_FAIL_ACT_T", 0.25),
    ("v1.16.1", "COM_FAIL_ACT_T", 0.50), ("1.17.0", "COM_FAIL_ACT_T", 0.50)])
def test_px4_release_table(version, hold_param, crit_max):
    row = px4_release(version)
    assert row.hold_param == hold_param
    assert row.ranges["BAT_CRIT_THR"][1] == crit_max
    assert row.ranges["BAT_LOW_THR"][0] == 0.12


def test_px4_hold_is_counted_only_where_the_release_has_one():
    *_, result = _x8_mapping()
    names = {v: [p.name for p in failsafe_parameters(result, "px4",
                                                     firmware_version=v).parameters]
             for v in ("1.12", "1.13", "1.17")}
    assert "COM_FAIL_ACT_T" not in names["1.12"] and "COM_BAT_ACT_T" not in names["1.12"]
    assert "COM_BAT_ACT_T" in names["1.13"] and "COM_FAIL_ACT_T" in names["1.17"]
    crit = {v: failsafe_parameters(result, "px4", firmware_version=v).levels[0]["charge_mah"]
            for v in ("1.12", "1.13", "1.17")}
    assert crit["1.12"] < crit["1.17"] < crit["1.13"]        # 0 s, 5 s, 10 s of hold


WITHIN = re.compile(r"; (\d+\.\d+) is within the (\d+(?:\.\d+)?)–(\d+(?:\.\d+)?) PX4 "
                    r"v(\d+)\.(\d+) allows (\w+)")


@pytest.mark.parametrize("battery", [None, "p42a"])
def test_px4_text_says_within_only_what_is_within_the_release_range(battery):
    """Every "f is within the a–b PX4 vX.Y allows NAME" of the derivations is true, names
    the release used and the parameter itself, and the parameter's value is that f (the
    value said to be within the range is the one set, not an earlier figure of the
    derivation)."""
    aircraft = load_aircraft(SOLO)
    pack = _catalog_pack("Molicel P42A 4S2P") if battery else load_aircraft_and_battery(
        SOLO)[1]
    result = MissionChain(aircraft, pack).run(load_mission(ROUTE, vehicle_type=aircraft.type),
                                              detail=True)
    plan = failsafe_parameters(result, "px4")
    said = 0
    for p in plan.parameters:
        for m in WITHIN.finditer(p.derivation):
            f, lo, hi = (float(m.group(k)) for k in (1, 2, 3))
            assert lo <= f <= hi, p.derivation
            assert (int(m.group(4)), int(m.group(5))) == PX4_STABLE_VERSION[:2]
            assert p.value == pytest.approx(f)
            assert m.group(6) == p.name
            said += 1
    assert said >= 1


# --------------------------------------------------------------------------- the command line

def test_cli_px4_old_release_is_no_go_and_writes_no_file(tmp_path, capsys):
    out = tmp_path / "x8.params"
    status = main(["check", str(MAPPING), "--aircraft", str(X8), "--failsafe", "px4",
                   "--firmware-version", "v1.10.0", "--params-out", str(out)])
    text = capsys.readouterr().out
    assert status == 1
    assert "NO-GO     failsafe plan: BAT_CRIT_THR" in text
    assert "PX4 v1.10" in text
    assert not out.exists()


def test_cli_px4_default_release_writes_a_qgc_file(tmp_path, capsys):
    out = tmp_path / "x8.params"
    status = main(["check", str(MAPPING), "--aircraft", str(X8), "--failsafe", "px4",
                   "--params-out", str(out)])
    text = capsys.readouterr().out
    assert status == 0
    assert "PX4 v1.17 (the current stable release" in text
    rows = [r.split("\t") for r in out.read_text().splitlines() if not r.startswith("#")]
    assert {r[2] for r in rows} >= {"BAT_CRIT_THR", "COM_FAIL_ACT_T", "BAT1_CAPACITY"}


def test_mavproxy_loads_the_ardupilot_param_file(tmp_path):
    """pymavlink's mavparm (MAVProxy's loader) reads every parameter back."""
    from pymavlink import mavparm
    *_, result = _solo_survey()
    plan = failsafe_parameters(result, "ardupilot")
    path = tmp_path / "fs.param"
    path.write_text(plan.param_file("Solo survey\nwritten by a test"))
    loaded = mavparm.MAVParmDict()
    assert loaded.load(str(path))
    for p in plan.parameters:
        assert loaded[p.name] == pytest.approx(p.value)


@pytest.mark.parametrize("argv, message", [
    (["--failsafe", "px4", "--firmware-version", "one"], "--firmware-version: expected"),
    (["--failsafe", "px4", "--firmware-version", "2.0"], "--firmware-version: PX4 v2.0.0"),
    (["--failsafe", "ardupilot", "--firmware-version", "4.5"],
     "--firmware-version: selects the PX4 release"),
])
def test_cli_bad_firmware_version_exits_2(argv, message, capsys):
    status = main(["check", str(ROUTE), "--aircraft", str(SOLO), *argv])
    err = capsys.readouterr().err
    assert status == 2 and message in err and "Traceback" not in err
