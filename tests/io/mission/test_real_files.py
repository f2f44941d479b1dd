"""The 40 real mission files of ``../shared/data/missions_real``, read as the firmware
flies them.

Each file is pinned: read, or refused for the reason a firmware or QGroundControl
refuses it too (``tools/missions_real.py`` classes every refusal; none may be a reader
gap). Then, file by file, what the reader used to get wrong, each against the firmware
source it follows: ArduCopter's circle rate for LOITER_TURNS, a copter's LOITER_TIME
hover, arcs flown as arcs, a cruise's climb bounded by the aircraft's rate, QGC's
"calc above terrain" and older item forms, a structure scan planned as QGC generates
it, DO_JUMP_TAG, PX4's land-and-continue, routes below home refused.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from pymavlink import mavwp

from planner.chain.kinematics import hold_power, leg_table
from planner.chain.mission_chain import MissionChain
from planner.errors import InputError
from planner.io.mission import NavDefaults, load_mission
from planner.parameters import load_aircraft, load_aircraft_and_battery
from planner.physics.geo import latlon_to_aeqd
from tools import missions_real

REPO = Path(__file__).resolve().parents[3]
SOLO = REPO / "aircraft/solo_survey.yaml"
X8 = REPO / "aircraft/x8_mapper.yaml"

#: Every file: None (read) or the refusal's reason (a regular expression).
EXPECTED = {
    "ap_copter_arc_wp.txt": None,
    "ap_copter_do_change_speed.txt": None,
    "ap_copter_inf_loop.txt": None,
    "ap_copter_loiter_to_alt.txt": None,
    "ap_copter_loiterturns.txt": None,
    "ap_copter_nav_delay.txt": None,
    "ap_copter_spline_terrain.txt": None,
    "ap_copter_terrain_mission.txt": r"line 5: .* 8028 km from home .*on another continent",
    "ap_plane_cmac_turns.txt": r"line 9: DO_JUMP repeat count -1 repeats for ever",
    "ap_plane_deepstall.txt": None,
    "ap_plane_do_change_speed.txt": None,
    "ap_plane_ksfo_vtol.txt": None,
    "ap_plane_loiter_to_alt.txt": r"line 6: MAV_CMD_NAV_LOITER_UNLIM \(17\) loiters without end",
    "ap_plane_mission_item_types.txt": None,
    "ap_quadplane_basic.txt": None,
    "dronekit_mpmission.txt": r"line 3 \(item 1\): MAV_CMD_NAV_TAKEOFF \(22\) altitude 100 m "
                              r"\(frame 0, above mean sea level\) is 484 m below home",
    "mavproxy_cmac-foamy-mission-ccw.txt": r"line 8: DO_JUMP repeat count -1",
    "mavproxy_cmac-foamy-mission-cw.txt": r"line 8: DO_JUMP repeat count -1",
    "mavproxy_springvalley-foamy-mission-ccw.txt": r"line 8: DO_JUMP repeat count -1",
    "mavproxy_springvalley-foamy-mission-cw.txt": r"line 8: DO_JUMP repeat count -1",
    "mavproxy_springvalleybottom-foamy-mission-ccw.txt": r"line 8: DO_JUMP repeat count -1",
    "mavproxy_springvalleybottom-foamy-mission-cw.txt": r"line 8: DO_JUMP repeat count -1",
    "mavsdk_mission_planner_sample.txt": r"line 2: item 0 is MAV_CMD_NAV_TAKEOFF \(22\), not "
                                         r"the home position",
    "mavsdk_qgroundcontrol_sample.plan": None,
    "mavsdk_qgroundcontrol_sample_with_digicam_control.plan":
        r"no navigation command, only MAV_CMD_DO_DIGICAM_CONTROL \(203\): nothing to fly",
    "mavsdk_qgroundcontrol_sample_with_structured_scan.plan": None,
    "mavsdk_qgroundcontrol_sample_with_survey.plan": None,
    "mavsdk_qgroundcontrol_sample_with_survey_missing_items.plan":
        r"mission\.items\[2\]: survey item has no TransectStyleComplexItem\.Items",
    "mavsdk_qgroundcontrol_sample_with_survey_wrong_version.plan":
        r"mission\.items\[2\]: Survey items do not support version 9",
    "mavsdk_qgroundcontrol_sample_without_mission.plan": r"no 'mission' key",
    "mavsdk_qgroundcontrol_sample_wrong_mission_version.plan": None,
    "mavsdk_qgroundcontrol_sample_wrong_overall_version.plan":
        r"version is 42 \(expected 1: QGroundControl refuses it, 'File version 42 is newer",
    "px4_fw_mission.plan": r"not valid JSON \(line 82 column 87",
    "px4_mc_mission_geofence_avoid.plan": None,
    "px4_triangle_gripper_delivery.plan": None,
    "px4_vtol_mission.plan": None,
    "qgc_ArduPilotSITL-ArduCopter.plan": None,
    "qgc_ArduPilotSITL-ArduPlane.plan": None,
    "qgc_SectionTest.plan": None,
    "qgc_TerrainTest-PX4-MultiRotor.plan": None,
}


@pytest.fixture(scope="module")
def real(shared_data) -> Path:
    return shared_data / "missions_real"


@pytest.fixture(scope="module")
def solo() -> NavDefaults:
    return NavDefaults.of(load_aircraft(SOLO))


def read(path, defaults, **kw):
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        mission = load_mission(path, defaults=defaults, **kw)
    return mission, [str(w.message) for w in said]


def test_every_real_file_is_read_or_refused_for_the_firmwares_reason(real):
    outcomes = missions_real.read_all(real)
    assert sorted(o.name for o in outcomes) == sorted(EXPECTED)
    for o in outcomes:
        reason = EXPECTED[o.name]
        if reason is None:
            assert o.status == missions_real.READ, (o.name, o.detail)
        else:
            assert o.status == missions_real.FIRMWARE, (o.name, o.detail)
            assert re.search(reason, o.detail), (o.name, o.detail)
    counts = missions_real.counts(outcomes)
    assert counts == {missions_real.READ: 23, missions_real.FIRMWARE: 17, missions_real.GAP: 0}


@pytest.mark.parametrize("name", sorted(k for k, v in EXPECTED.items() if v is not None))
def test_each_refusal_is_one_line_naming_file_item_and_expectation(real, name, solo):
    path = real / name
    with pytest.raises(InputError) as info:
        load_mission(path, defaults=solo)
    msg = str(info.value)
    assert msg.startswith(f"{path}: ") and "\n" not in msg
    assert "expected" in msg or "QGroundControl" in msg, msg


# ------------------------------------------------------------ ArduCopter LOITER_TURNS

def test_copter_loiter_turns_circle_at_arducopter_circle_rate(real, solo):
    """ap_copter_loiterturns.txt has no DO_CHANGE_SPEED: it used to be refused ("needs a
    speed"). ArduCopter circles at CIRCLE_RATE 20 deg/s (AC_Circle.h), capped by
    min(WPNAV_SPEED, sqrt(0.5 WPNAV_ACCEL r)): radius 5 m and 10 m both turn at 20 deg/s
    (1.75 and 3.49 m/s, below the caps of 2.50 and 3.54 m/s), so a turn takes 18 s."""
    mission, _ = read(real / "ap_copter_loiterturns.txt", solo)
    loiters = [leg for leg in mission.legs if leg.kind == "loiter"]
    assert [leg.loiter_radius_m for leg in loiters] == [5.0, 5.0, 10.0]
    assert [leg.duration_s for leg in loiters] == pytest.approx([18.0, 36.0, 18.0])
    assert [leg.speed_ms for leg in loiters] == pytest.approx(
        [math.radians(20) * r for r in (5, 5, 10)])


def test_copter_circle_speed_is_capped_by_the_speed_in_force(tmp_path, solo):
    """A 100 m circle at 20 deg/s would be 34.9 m/s: the copter flies WPNAV_SPEED."""
    lat, lon = 48.0, 10.0
    rows = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{lat}\t{lon}\t500\t1",
            "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t30\t1",
            "2\t0\t3\t18\t1\t0\t100\t0\t0\t0\t30\t1",
            "3\t0\t3\t21\t0\t0\t0\t0\t0\t0\t0\t1"]
    path = tmp_path / "c.waypoints"
    path.write_text("\n".join(rows) + "\n")
    loiter = next(leg for leg in load_mission(path, defaults=solo).legs
                  if leg.kind == "loiter")
    assert loiter.speed_ms == solo.cruise_speed_ms == 8.0
    assert loiter.duration_s == pytest.approx(2 * math.pi * 100 / 8.0)


# ------------------------------------------------------------ LOITER_TIME: copter hovers

def test_copter_loiter_time_hovers_and_plane_circles_its_own_radius(real, solo):
    """qgc_ArduPilotSITL-ArduCopter.plan item 7: LOITER_TIME 30 s with param3 = 50 m. A
    copter holds position (ModeAuto::do_loiter_time re-uses the unlimited loiter); it
    used to circle 50 m at cruise speed. ArduPlane circles at WP_LOITER_RAD whatever
    param3 says (verify_loiter_time)."""
    mission, _ = read(real / "qgc_ArduPilotSITL-ArduCopter.plan", solo)
    held = [leg for leg in mission.legs if leg.origin == "mission.items[7]"
            and leg.duration_s]
    assert [(leg.kind, leg.duration_s, leg.loiter_radius_m) for leg in held] == [
        ("hover", 30.0, None)]
    x8 = NavDefaults.of(load_aircraft(X8))
    plane, _ = read(real / "qgc_ArduPilotSITL-ArduCopter.plan", x8)
    circle = [leg for leg in plane.legs if leg.origin == "mission.items[7]"
              and leg.duration_s]
    assert [(leg.kind, leg.loiter_radius_m) for leg in circle] == [("loiter", None)]


def test_copter_loiter_time_costs_a_hover(real, solo):
    """The 30 s hold costs the hover power (it cost 17.5 % less charge, circling at the
    10 m/s of the plan's DO_CHANGE_SPEED, cheaper than hovering for a quadcopter)."""
    aircraft, pack = load_aircraft_and_battery(SOLO)
    mission, _ = read(real / "qgc_ArduPilotSITL-ArduCopter.plan", solo)
    result = MissionChain(aircraft, pack).check(mission)
    i = next(k for k, leg in enumerate(mission.legs) if leg.kind == "hover")
    legs = result.legs
    assert legs.airspeed_ms.iloc[i] == 0.0 and legs.groundspeed_ms.iloc[i] == 0.0
    rho = leg_table(mission, aircraft).air_density[i]
    assert float(legs.power_w.iloc[i]) == pytest.approx(
        float(hold_power(aircraft, result.takeoff_mass_kg, rho)), rel=1e-9)


# ------------------------------------------------------------ arcs

def _arc_length(start, end, angle_deg):
    """R |θ| with R = chord / (2 sin(|θ|/2)) (ArduPilot autotest circle_from_arc)."""
    chord = math.dist(start, end)
    if angle_deg == 0 or chord == 0:
        return chord
    theta = math.radians(abs(angle_deg))
    return chord / (2 * math.sin(theta / 2)) * theta


def test_copter_arc_waypoints_fly_their_arcs(real, solo):
    """ap_copter_arc_wp.txt: NAV_ARC_WAYPOINT items were dropped (852 m flown). Each arc
    is flown from the previous point with its central angle (param2 in this file, as
    ArduPilot's first arcs wrote it): at least 1070 m, and the arcs' lengths within
    0.05 % of R·θ, read with pymavlink."""
    mission, said = read(real / "ap_copter_arc_wp.txt", solo)
    flown = sum(leg.distance_m for leg in mission.legs)
    assert flown >= 1070
    loader = mavwp.MAVWPLoader()
    loader.load(str(real / "ap_copter_arc_wp.txt"))
    home = loader.wp(0)
    expected = 0.0
    prev = (0.0, 0.0)
    for k in range(2, loader.count() - 1):            # after the take-off, before RTL
        w = loader.wp(k)
        here = tuple(float(v) for v in latlon_to_aeqd(w.x, w.y, home.x, home.y))
        angle = w.param1 or w.param2 if w.command == 36 else 0
        expected += _arc_length(prev, here, angle)
        prev = here
    expected += math.hypot(*prev)                     # RTL
    assert flown == pytest.approx(expected, rel=5e-4)
    assert any("param2" in s for s in said)


def test_clockwise_arc_bulges_as_arducopter_flies_it(tmp_path, solo):
    """WPArcs: a clockwise 180° arc flown south passes east of the chord; the helix of
    -2700° over 90 m has radius 45 m (WPArcs2 'helix up')."""
    home = (-35.3632621, 149.1652375)
    north = 90.0 / 111_000
    rows = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{home[0]}\t{home[1]}\t584\t1",
            "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t20\t1",
            f"2\t0\t3\t16\t0\t0\t0\t0\t{home[0] + north}\t{home[1]}\t20\t1",
            f"3\t0\t3\t36\t180\t0\t0\t0\t{home[0]}\t{home[1]}\t20\t1",
            f"4\t0\t3\t36\t-2700\t0\t0\t0\t{home[0] + north}\t{home[1]}\t20\t1",
            "5\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1"]
    path = tmp_path / "arc.waypoints"
    path.write_text("\n".join(rows) + "\n")
    legs = load_mission(path, defaults=solo).legs
    south = [leg for leg in legs if leg.origin == "line 5"]
    helix = [leg for leg in legs if leg.origin == "line 6"]
    chord = legs[1].distance_m
    assert max(leg.end_en_m[0] for leg in south) == pytest.approx(chord / 2, rel=1e-3)
    assert sum(leg.distance_m for leg in south) == pytest.approx(math.pi * chord / 2,
                                                                 rel=5e-4)
    assert sum(leg.distance_m for leg in helix) == pytest.approx(
        chord / 2 * math.radians(2700), rel=5e-4)
    # a copter holds sqrt(ACCEL_C r) on a tight arc: 2 x 2.5 m/s² x 45 m -> 15 m/s > 8
    assert all(leg.speed_ms is None for leg in south + helix)


def test_plane_skips_arc_waypoints(real):
    """ArduPlane has no case for NAV_ARC_WAYPOINT in start_command: AP_Mission skips it
    (ap_plane_mission_item_types.txt says so in its comment)."""
    x8 = NavDefaults.of(load_aircraft(X8))
    mission, said = read(real / "ap_plane_mission_item_types.txt", x8)
    assert not [leg for leg in mission.legs if leg.origin == "line 16"]
    assert any("NAV_ARC_WAYPOINT (36) skipped" in s for s in said)


# ------------------------------------------------------------ jumps, comments

def test_comment_lines_jump_tags_and_jumps(real):
    """ap_plane_mission_item_types.txt: '#' lines (skipped, as pymavlink skips them; the
    file used to be refused at line 2), JUMP_TAG 7 / DO_JUMP_TAG 7 x1 (the tag's triangle
    flown twice), DO_JUMP repeat 0 (not followed), DO_JUMP -> 20 x1 (flown twice)."""
    x8 = NavDefaults.of(load_aircraft(X8))
    mission, _ = read(real / "ap_plane_mission_item_types.txt", x8)
    origins = [leg.origin for leg in mission.legs if leg.kind == "cruise"]
    assert origins.count("line 34") == 2          # first corner after JUMP_TAG 7
    assert origins.count("line 38") == 2          # third corner, before DO_JUMP_TAG
    assert origins.count("line 44") == 2          # first corner of the DO_JUMP loop
    assert origins.count("line 14") == 1          # the repeat-0 jump's target: once
    loader = mavwp.MAVWPLoader()
    assert loader.load(str(real / "ap_plane_mission_item_types.txt")) == 28


def test_missing_jump_tag_ends_the_mission(tmp_path, solo):
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t48.0\t10.0\t500\t1",
            "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t30\t1",
            "2\t0\t3\t16\t0\t0\t0\t0\t48.001\t10.0\t30\t1",
            "3\t0\t0\t601\t9\t1\t0\t0\t0\t0\t0\t1",
            "4\t0\t3\t16\t0\t0\t0\t0\t48.002\t10.0\t30\t1"]
    path = tmp_path / "t.waypoints"
    path.write_text("\n".join(rows) + "\n")
    with pytest.warns(UserWarning, match=r"line 5: DO_JUMP_TAG to tag 9, which no JUMP_TAG "
                                         r"carries: the mission ends here"):
        legs = load_mission(path, defaults=solo).legs
    assert [leg.origin for leg in legs] == ["line 3", "line 4"]


# ------------------------------------------------------------ vertical speed

def test_cruise_climb_is_bounded_by_the_aircraft_rate(real, solo):
    """ap_copter_loiter_to_alt.txt: a 25 m climb over 6 m was a 33 m/s climb (46.6 A,
    NO-GO). ArduCopter flies the leg at most at WPNAV_SPEED_UP and finishes the climb
    over the point (ModeAuto::loiter_to_alt_run): the cruise climbs at 2.5 m/s, the rest
    is a climb over the point."""
    mission, _ = read(real / "ap_copter_loiter_to_alt.txt", solo)
    for leg in mission.legs:
        if leg.kind == "cruise":
            t = leg.distance_m / solo.cruise_speed_ms
            assert abs(leg.end_alt_m - leg.start_alt_m) <= solo.climb_rate_ms * t + 1e-6
    kinds = [(leg.kind, leg.origin) for leg in mission.legs]
    assert ("cruise", "line 4") in kinds and ("climb", "line 4") in kinds
    assert mission.legs[2].end_alt_m == 30.0
    aircraft, pack = load_aircraft_and_battery(SOLO)
    result = MissionChain(aircraft, pack).check(mission)
    assert result.go and result.peak_current_a < 20.0, result.reasons


def test_split_leg_takes_as_long_as_the_axis_limited_line(tmp_path, solo):
    """ArduCopter limits each axis of a waypoint leg: 100 m up over 40 m at 2.5 m/s takes
    40 s, and so do the cruise and climb it is split into."""
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t48.0\t10.0\t500\t1",
            "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t10\t1",
            f"2\t0\t3\t16\t0\t0\t0\t0\t{48.0 + 40 / 111_200}\t10.0\t110\t1"]
    path = tmp_path / "s.waypoints"
    path.write_text("\n".join(rows) + "\n")
    cruise, climb = load_mission(path, defaults=solo).legs[1:]
    t = cruise.distance_m / 8.0 + (climb.end_alt_m - climb.start_alt_m) / 2.5
    assert t == pytest.approx(100 / 2.5, rel=1e-3)
    assert (cruise.end_alt_m - cruise.start_alt_m) / (cruise.distance_m / 8.0) == \
        pytest.approx(2.5)


# ------------------------------------------------------------ QGroundControl forms

def test_calc_above_terrain_items_are_read_with_a_flat_terrain_warning(real, solo):
    """AltitudeMode 3 with params[6] null (QGC fills it once it has terrain): read as
    Altitude above the ground, said to assume flat terrain; the file was refused."""
    mission, said = read(real / "qgc_TerrainTest-PX4-MultiRotor.plan", solo)
    alts = {leg.origin: leg.end_alt_m for leg in mission.legs}
    assert alts["mission.items[6]"] == 80.0 and alts["mission.items[8]"] == 40.0
    assert any("mission.items[6]: 'calc above terrain' altitude (AltitudeMode 3) 80 m"
               in s and "terrain assumed flat" in s for s in said)


def test_older_coordinate_item_form_is_converted(real, solo):
    """qgc_SectionTest.plan: 'coordinate' + 4 params (MissionItem::_convertJsonV2ToV3)."""
    mission, _ = read(real / "qgc_SectionTest.plan", solo)
    items = json.loads((real / "qgc_SectionTest.plan").read_text())["mission"]["items"]
    home = json.loads((real / "qgc_SectionTest.plan").read_text())["mission"][
        "plannedHomePosition"]
    wp = items[4]["coordinate"]
    end = latlon_to_aeqd(wp[0], wp[1], home[0], home[1])
    assert mission.legs[-1].end_en_m == pytest.approx(tuple(map(float, end)), abs=1e-6)
    assert mission.legs[-1].end_alt_m == 20


def test_structure_scan_is_planned_as_qgc_generates_it(real, solo):
    """StructureScanComplexItem::appendMissionItems: 2 layers (ceil((100-50)/25)) from
    the top at 87.5 and 62.5 m, each a loop of the polygon pushed out 50 m, entrance and
    exit at 50 m: 18 items (QGC's lastSequenceNumber formula (4+1+2)·2+2+2)."""
    from planner.io.mission.qgc_plan import read_plan
    _, items = read_plan(real / "mavsdk_qgroundcontrol_sample_with_structured_scan.plan")
    scan = [it for it in items if "structure scan" in it.origin]
    assert len(scan) == (4 + 1 + 2) * 2 + 2 + 2
    assert [it.command for it in scan].count(206) == 4
    wps = [it for it in scan if it.command == 16]
    assert [it.params[6] for it in wps] == [50] + [87.5] * 5 + [62.5] * 5 + [50]
    # each flight vertex lies 50 m from both structure edges it joins (the offset)
    poly = json.loads((real / "mavsdk_qgroundcontrol_sample_with_structured_scan.plan")
                      .read_text())["mission"]["items"][1]["polygon"]
    h = (poly[0][0], poly[0][1])
    p = np.array([latlon_to_aeqd(a, b, *h) for a, b in poly], dtype=float)
    v = np.array([latlon_to_aeqd(w.params[4], w.params[5], *h) for w in wps[1:5]],
                 dtype=float)
    for i in range(4):
        for a, b in ((p[i - 1], p[i]), (p[i], p[(i + 1) % 4])):
            e, w = b - a, v[i] - a
            d = abs(e[0] * w[1] - e[1] * w[0]) / np.linalg.norm(e)
            assert d == pytest.approx(50.0, abs=0.05)
    mission, _ = read(real / "mavsdk_qgroundcontrol_sample_with_structured_scan.plan", solo)
    assert {leg.end_alt_m for leg in mission.legs} >= {50.0, 87.5, 62.5}


def test_plan_mission_version_is_not_checked_as_qgc_does_not(real, solo):
    mission, _ = read(real / "mavsdk_qgroundcontrol_sample_wrong_mission_version.plan", solo)
    assert mission.legs


# ------------------------------------------------------------ landing amid the mission

def test_px4_land_and_continue_flies_the_items_after_the_landing(real, solo):
    """px4_triangle_gripper_delivery.plan: LAND, DO_GRIPPER, WP 10 m. PX4 does not disarm
    amid a mission and inserts a take-off before the next item with a position: the last
    waypoint is flown (it was dropped)."""
    mission, _ = read(real / "px4_triangle_gripper_delivery.plan", solo)
    after = [(leg.kind, leg.origin) for leg in mission.legs][3:]
    assert after == [("descend", "mission.items[2]"), ("climb", "mission.items[4]"),
                     ("cruise", "mission.items[4]")]
    assert mission.legs[-1].end_alt_m == 10.0


def test_ardupilot_land_ends_the_mission(tmp_path, solo):
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t48.0\t10.0\t500\t1",
            "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t30\t1",
            "2\t0\t3\t21\t0\t0\t0\t0\t48.001\t10.0\t0\t1",
            "3\t0\t3\t16\t0\t0\t0\t0\t48.002\t10.0\t30\t1"]
    path = tmp_path / "l.waypoints"
    path.write_text("\n".join(rows) + "\n")
    with pytest.warns(UserWarning, match=r"1 item\(s\) after line 4 \(LAND\) are not flown"):
        legs = load_mission(path, defaults=solo).legs
    assert legs[-1].kind == "descend" and legs[-1].end_alt_m == 0


# ------------------------------------------------------------ below home

def test_route_below_home_is_refused_unless_in_the_terrain_frame(tmp_path, real, solo):
    with pytest.raises(InputError, match=r"484 m below home \(584 m above mean sea level\): "
                                         r"the route lies below the take-off point"):
        load_mission(real / "dronekit_mpmission.txt", defaults=solo)
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t48.0\t10.0\t500\t1",
            "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t30\t1",
            "2\t0\t10\t16\t0\t0\t0\t0\t48.001\t10.0\t30\t1",
            "3\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1"]
    path = tmp_path / "t.waypoints"
    path.write_text("\n".join(rows) + "\n")
    with pytest.warns(UserWarning, match="terrain-relative altitude treated as relative"):
        assert load_mission(path, defaults=solo).legs[1].end_alt_m == 30
    path.write_text("\n".join(rows).replace("\t10\t16\t", "\t3\t16\t").replace(
        "10.0\t30\t1\n3", "10.0\t-20\t1\n3") + "\n")
    with pytest.raises(InputError, match=r"line 4 \(item 2\): MAV_CMD_NAV_WAYPOINT \(16\) "
                                         r"altitude -20 m \(frame 3, above home\) is 20 m "
                                         r"below home"):
        load_mission(path, defaults=solo)


def test_planning_speed_warning_for_every_qgc_plan(real, solo):
    """QGroundControl's hoverSpeed (5 m/s) is not flown by a Solo set to 8 m/s."""
    mission, said = read(real / "px4_mc_mission_geofence_avoid.plan", solo)
    assert all(leg.speed_ms is None for leg in mission.legs)
    assert any("mission.hoverSpeed 5 m/s is QGroundControl's planning speed" in s
               for s in said)


@pytest.mark.parametrize("name", ["dronekit_mpmission.txt", "ap_plane_cmac_turns.txt",
                                  "mavsdk_qgroundcontrol_sample_wrong_overall_version.plan",
                                  "mavsdk_mission_planner_sample.txt"])
def test_check_on_a_refused_real_file_exits_2_with_one_line(real, name, capsys):
    from planner.cli.main import main
    path = real / name
    aircraft = X8 if name.startswith("ap_plane") else SOLO
    status = main(["check", str(path), "--aircraft", str(aircraft)])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1 and str(path) in err, err
    assert re.search(EXPECTED[name], err), err
