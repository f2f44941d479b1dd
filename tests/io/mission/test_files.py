"""The three mission file formats: the same route gives the same legs; file errors."""

import json
import re
import warnings

import pytest

from planner.errors import InputError
from planner.io.mission import NavDefaults, load_mission

ROUTE = ("survey_route.yaml", "survey_route.plan", "survey_route.waypoints")


@pytest.fixture(scope="module")
def route_missions(repo):
    with warnings.catch_warnings():
        warnings.simplefilter("error")        # the examples load cleanly
        return [load_mission(repo / "missions" / name) for name in ROUTE]


def test_same_route_same_legs_in_three_formats(route_missions):
    ref = route_missions[0]
    for other in route_missions[1:]:
        assert [leg.kind for leg in other.legs] == [leg.kind for leg in ref.legs]
        for a, b in zip(ref.legs, other.legs):
            assert b.distance_m == pytest.approx(a.distance_m, abs=0.5)
            assert b.end_en_m == pytest.approx(a.end_en_m, abs=0.5)
            assert (b.start_alt_m, b.end_alt_m) == pytest.approx((a.start_alt_m, a.end_alt_m))
            assert b.duration_s == a.duration_s
            assert (b.speed_ms, b.speed_is_airspeed) == (a.speed_ms, a.speed_is_airspeed)
        assert other.home == pytest.approx(ref.home)
        assert other.environment == ref.environment


def test_survey_route_shape(route_missions):
    legs = route_missions[1].legs                       # the .plan
    kinds = [leg.kind for leg in legs]
    assert kinds[0] == "climb" and legs[0].end_alt_m == 50
    assert kinds[-2:] == ["cruise", "descend"]          # RTL
    assert legs[-1].end_en_m == (0.0, 0.0) and legs[-1].end_alt_m == 0
    assert kinds.count("hover") == 1
    assert next(leg for leg in legs if leg.kind == "hover").duration_s == 30
    yaml_wps = {leg.origin for leg in route_missions[0].legs if leg.origin.startswith("waypoints")}
    assert 8 <= len(yaml_wps) <= 12
    assert all((leg.speed_ms, leg.speed_is_airspeed) == (6, False)
               for leg in legs if leg.kind == "cruise")
    assert [leg.origin for leg in legs[:2]] == ["mission.items[1]", "mission.items[3]"]
    assert route_missions[2].legs[1].origin == "line 5"
    assert route_missions[0].legs[1].origin == "waypoints[1]"


# ---------------------------------------------------------------- .plan

def plan(tmp_path, items, name="p.plan", **mission):
    body = {"fileType": "Plan", "groundStation": "QGroundControl", "version": 1,
            "mission": {"plannedHomePosition": [48.0, 10.0, 500.0], "cruiseSpeed": 15,
                        "hoverSpeed": 5, "items": items, "version": 2, **mission}}
    path = tmp_path / name
    path.write_text(json.dumps(body))
    return path


def simple(cmd, params, frame=3, **extra):
    return {"type": "SimpleItem", "command": cmd, "frame": frame, "params": params,
            "autoContinue": True, **extra}


TAKEOFF = simple(22, [0, 0, 0, None, 48.0, 10.0, 30])
WP = simple(16, [0, 0, 0, None, 48.001, 10.0, 30])
RTL = simple(20, [0, 0, 0, 0, 0, 0, 0], frame=2)


def test_plan_planning_speeds_are_not_flown(tmp_path):
    """QGroundControl never uploads cruiseSpeed/hoverSpeed (its offline estimate settings,
    MissionController.cc): the vehicle flies its own speed until a DO_CHANGE_SPEED. They
    used to set the legs' speed (5 m/s here, the aircraft flying 8)."""
    path = plan(tmp_path, [TAKEOFF, WP, RTL], vehicleType=2)
    assert load_mission(path).legs[1].speed_ms is None
    assert load_mission(path, vehicle_type="fixed_wing").legs[1].speed_ms is None
    solo = NavDefaults("multirotor", 8.0, 2.5, 1.5)
    with pytest.warns(UserWarning, match=r"mission\.hoverSpeed 5 m/s is QGroundControl's "
                                         r"planning speed, never sent to the vehicle: the "
                                         r"aircraft flies its own 8 m/s"):
        legs = load_mission(path, defaults=solo).legs
    assert legs[1].speed_ms is None and legs[1].speed_is_airspeed is None


def test_plan_survey_complex_item_is_expanded(tmp_path):
    transect = [simple(16, [0, 0, 0, None, 48.001, 10.0, 30], doJumpId=3),
                simple(206, [25, 0, 1, 0, 0, 0, 0], frame=2, doJumpId=4),
                simple(16, [0, 0, 0, None, 48.002, 10.0, 30], doJumpId=5)]
    survey = {"type": "ComplexItem", "complexItemType": "survey", "version": 5,
              "polygon": [[48.001, 9.999], [48.002, 10.001]],
              "TransectStyleComplexItem": {"Items": transect, "CameraCalc": {}}}
    path = plan(tmp_path, [TAKEOFF, survey, RTL], vehicleType=2)
    with pytest.warns(UserWarning, match=r"DO_SET_CAM_TRIGG_DIST \(206\) ignored .*"
                                         r"mission\.items\[2\]\.TransectStyleComplexItem\.Items\[2\]"):
        m = load_mission(path)
    assert [leg.kind for leg in m.legs] == ["climb", "cruise", "cruise", "cruise", "descend"]
    assert m.legs[2].origin == "mission.items[2].TransectStyleComplexItem.Items[3]"
    assert m.legs[2].end_en_m[1] == pytest.approx(222.4, rel=1e-2)


def test_plan_do_jump_uses_do_jump_ids(tmp_path):
    items = [dict(TAKEOFF, doJumpId=1), dict(WP, doJumpId=2),
             simple(16, [0, 0, 0, None, 48.001, 10.001, 30], doJumpId=3),
             simple(177, [2, 1, 0, 0, 0, 0, 0], frame=2, doJumpId=4), dict(RTL, doJumpId=5)]
    m = load_mission(plan(tmp_path, items))
    assert [leg.origin for leg in m.legs if leg.kind == "cruise"] == [
        "mission.items[2]", "mission.items[3]", "mission.items[2]", "mission.items[3]",
        "mission.items[5]"]


def test_plan_amsl_and_terrain_frames(tmp_path):
    items = [TAKEOFF, simple(16, [0, 0, 0, None, 48.001, 10.0, 560], frame=0),
             simple(16, [0, 0, 0, None, 48.002, 10.0, 40], frame=10, AMSLAltAboveTerrain=575),
             RTL]
    m = load_mission(plan(tmp_path, items))
    assert [leg.end_alt_m for leg in m.legs[1:3]] == [60, 75]


PLAN_ERRORS = [
    ("broken JSON", '{"mission": {"items": [}', r"p\.plan: not valid JSON \(line 1 column"),
    ("not a plan", '{"fileType": "GeoFence", "mission": {}}', r"p\.plan: fileType is 'GeoFence'"),
    ("no home", json.dumps({"mission": {"items": [TAKEOFF]}}),
     r"p\.plan: mission\.plannedHomePosition must be \[lat, lon, alt_amsl\]"),
    ("no items", json.dumps({"mission": {"items": [], "plannedHomePosition": [48, 10, 0]}}),
     r"p\.plan: mission\.items must be a non-empty list"),
    ("bad params", json.dumps({"mission": {"plannedHomePosition": [48, 10, 0], "items": [
        TAKEOFF, simple(16, [0, 0, 0, 48.0, 10.0, 30])]}}),
     r"p\.plan: mission\.items\[2\]\.params must be a list of 7"),
    ("text param", json.dumps({"mission": {"plannedHomePosition": [48, 10, 0], "items": [
        simple(16, [0, 0, 0, None, "48.0", 10.0, 30])]}}),
     r"p\.plan: mission\.items\[1\]\.param5 must be a number or null"),
    ("complex without items", json.dumps({"mission": {
        "plannedHomePosition": [48, 10, 0], "items": [
            TAKEOFF, {"type": "ComplexItem", "complexItemType": "survey", "version": 5}]}}),
     r"p\.plan: mission\.items\[2\]: survey item has no TransectStyleComplexItem\.Items"),
    ("structure scan version", json.dumps({"mission": {
        "plannedHomePosition": [48, 10, 0], "items": [
            TAKEOFF, {"type": "ComplexItem", "complexItemType": "StructureScan",
                      "version": 2}]}}),
     r"p\.plan: mission\.items\[2\]: StructureScan version 2 not supported "
     r"\(QGroundControl loads version 3 only"),
    ("landing pattern", json.dumps({"mission": {
        "plannedHomePosition": [48, 10, 0], "items": [
            TAKEOFF, {"type": "ComplexItem", "complexItemType": "fwLandingPattern"}]}}),
     r"p\.plan: mission\.items\[2\]: complex item 'fwLandingPattern' not supported"),
    ("loiter unlimited", json.dumps({"mission": {
        "plannedHomePosition": [48, 10, 0], "items": [
            TAKEOFF, simple(17, [0, 0, 0, None, 48.001, 10.0, 30])]}}),
     r"p\.plan: mission\.items\[2\]: MAV_CMD_NAV_LOITER_UNLIM"),
]


@pytest.mark.parametrize("text, pattern", [e[1:] for e in PLAN_ERRORS],
                         ids=[e[0] for e in PLAN_ERRORS])
def test_plan_errors(tmp_path, text, pattern):
    path = tmp_path / "p.plan"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_mission(path)
    assert str(info.value).startswith(str(path))
    assert re.search(pattern, str(info.value)), str(info.value)


# ---------------------------------------------------------------- .waypoints

GOOD = ("QGC WPL 110\n"
        "0\t1\t0\t16\t0\t0\t0\t0\t48.0\t10.0\t500.0\t1\n"
        "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t30\t1\n"
        "2\t0\t3\t16\t0\t0\t0\t0\t48.001\t10.0\t30\t1\n"
        "3\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1\n")


def test_waypoints_crlf_and_txt_extension(tmp_path):
    path = tmp_path / "w.txt"
    path.write_bytes(GOOD.replace("\n", "\r\n").encode())
    m = load_mission(path)
    assert [leg.kind for leg in m.legs] == ["climb", "cruise", "cruise", "descend"]
    assert m.name == "w" and m.home == (48.0, 10.0, 500.0)


WPL_ERRORS = [
    ("missing header", GOOD.split("\n", 1)[1],
     r"w\.waypoints: line 1: expected the header 'QGC WPL 110', got '0"),
    ("wrong version", GOOD.replace("110", "120", 1), r"line 1: expected the header"),
    ("too few fields", GOOD.replace("2\t0\t3\t16\t0\t0\t0\t0\t", "2\t0\t3\t16\t0\t0\t"),
     r"w\.waypoints: line 4: expected 12 tab-separated fields .* got 10"),
    ("text in a number", GOOD.replace("48.001", "48.0o1"),
     r"w\.waypoints: line 4: latitude is '48\.0o1' \(expected a number\)"),
    ("float command", GOOD.replace("\t22\t", "\t22.5\t"),
     r"w\.waypoints: line 3: command is '22\.5' \(expected an integer\)"),
    ("no home", "QGC WPL 110\n", r"w\.waypoints: no mission items"),
    ("home at 0,0", GOOD.replace("48.0\t10.0\t500.0", "0\t0\t0"),
     r"w\.waypoints: line 2: home position is 0, 0"),
    ("duplicate index", GOOD.replace("3\t0\t3\t20", "2\t0\t3\t20"),
     r"w\.waypoints: line 5: index 2 already used at line 4"),
    ("unsupported frame", GOOD.replace("2\t0\t3\t16", "2\t0\t2\t16"),
     r"w\.waypoints: line 4: frame 2 not supported"),
]


@pytest.mark.parametrize("text, pattern", [e[1:] for e in WPL_ERRORS],
                         ids=[e[0] for e in WPL_ERRORS])
def test_waypoints_errors(tmp_path, text, pattern):
    path = tmp_path / "w.waypoints"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_mission(path)
    assert re.search(pattern, str(info.value)), str(info.value)
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------- dispatch

def test_dispatch_errors(tmp_path):
    with pytest.raises(InputError, match=r"m\.kml: unknown mission file type '\.kml'"):
        load_mission(tmp_path / "m.kml")
    with pytest.raises(InputError, match=r"nope\.yaml: file not found"):
        load_mission(tmp_path / "nope.yaml")
    (tmp_path / "w.waypoints").write_text(GOOD)
    with pytest.raises(InputError, match=r"vehicle type 'quad' not known"):
        load_mission(tmp_path / "w.waypoints", vehicle_type="quad")
