"""Route -> legs (planner.io.mission.route), driven through small .waypoints files."""

import math
import warnings

import pytest

from planner.errors import InputError
from planner.io.mission import load_mission
from planner.physics.geo import en_to_latlon

HOME = (48.0468, 10.4452, 598.0)


def ll(east, north):
    return en_to_latlon(east, north, HOME[0], HOME[1])


def wpl(tmp_path, rows, name="m.waypoints"):
    """Write a .waypoints file: rows are (command, frame, p1..p4, lat, lon, alt)."""
    lines = ["QGC WPL 110",
             f"0\t1\t0\t16\t0\t0\t0\t0\t{HOME[0]}\t{HOME[1]}\t{HOME[2]}\t1"]
    for i, (cmd, frame, *rest) in enumerate(rows, start=1):
        lines.append("\t".join(str(v) for v in (i, 0, frame, cmd, *rest, 1)))
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def wp(east, north, alt, hold=0, frame=3):
    lat, lon = ll(east, north)
    return (16, frame, hold, 0, 0, 0, f"{lat:.9f}", f"{lon:.9f}", alt)


TAKEOFF = (22, 3, 0, 0, 0, 0, 0, 0, 40)
RTL = (20, 3, 0, 0, 0, 0, 0, 0, 0)


def kinds(m):
    return [leg.kind for leg in m.legs]


def test_takeoff_waypoints_and_rtl(tmp_path):
    m = load_mission(wpl(tmp_path, [TAKEOFF, wp(300, 0, 40), wp(300, 400, 60), RTL]))
    assert kinds(m) == ["climb", "cruise", "cruise", "cruise", "descend"]
    climb, a, b, home, down = m.legs
    assert (climb.start_alt_m, climb.end_alt_m) == (0, 40) and climb.end_en_m == (0, 0)
    assert a.distance_m == pytest.approx(300, abs=0.01) and a.course_deg == pytest.approx(90)
    assert (b.start_alt_m, b.end_alt_m) == (40, 60)      # altitude changes along a cruise
    assert b.end_en_m == pytest.approx((300, 400), abs=0.01)
    # RTL: home at the current altitude, then down to 0 at home
    assert home.end_en_m == (0, 0) and home.start_alt_m == home.end_alt_m == 60
    assert home.distance_m == pytest.approx(500, abs=0.01)
    assert down.end_en_m == (0, 0) and (down.start_alt_m, down.end_alt_m) == (60, 0)
    assert home.origin == down.origin == "line 6"
    assert climb.origin == "line 3"
    assert m.home == HOME and m.environment.site_altitude_m == HOME[2]


def test_do_change_speed_applies_to_the_following_legs(tmp_path):
    rows = [TAKEOFF, wp(100, 0, 40),
            (178, 3, 1, 7.5, -1, 0, 0, 0, 0),             # ground speed 7.5
            wp(200, 0, 40), wp(300, 0, 40),
            (178, 3, 0, 14, -1, 0, 0, 0, 0),              # airspeed 14
            wp(400, 0, 40),
            (178, 3, 0, -1, -1, 0, 0, 0, 0),              # -1: no change
            wp(500, 0, 40), RTL]
    m = load_mission(wpl(tmp_path, rows))
    cruise = [(leg.speed_ms, leg.speed_is_airspeed) for leg in m.legs if leg.kind == "cruise"]
    assert cruise == [(None, None), (7.5, False), (7.5, False), (14, True), (14, True),
                      (14, True)]
    # a multirotor navigates at ground speed whatever the speed type
    m = load_mission(wpl(tmp_path, rows), vehicle_type="multirotor")
    assert [leg.speed_is_airspeed for leg in m.legs if leg.kind == "cruise"][3] is False


def test_climb_and_descent_rates_from_change_speed(tmp_path):
    rows = [(178, 3, 2, 2.5, -1, 0, 0, 0, 0), (178, 3, 3, 1.2, -1, 0, 0, 0, 0),
            TAKEOFF, (21, 3, 0, 0, 0, 0, 0, 0, 0)]
    m = load_mission(wpl(tmp_path, rows))
    assert [(leg.kind, leg.climb_rate_ms) for leg in m.legs] == [("climb", 2.5),
                                                                  ("descend", 1.2)]


def test_do_jump_expansion(tmp_path):
    rows = [TAKEOFF,                       # 1
            wp(100, 0, 40),                # 2
            wp(100, 100, 40),              # 3
            wp(0, 100, 40),                # 4
            (177, 3, 2, 2, 0, 0, 0, 0, 0),  # 5: jump to 2, twice -> block flown 3 times
            RTL]                           # 6
    m = load_mission(wpl(tmp_path, rows))
    cruise = [leg for leg in m.legs if leg.kind == "cruise"]
    assert [leg.origin for leg in cruise] == (["line 4", "line 5", "line 6"] * 3
                                              + ["line 8"])
    # first pass 3 x 100 m; each repeat starts with the diagonal back to the first point
    assert sum(leg.distance_m for leg in cruise[:9]) == pytest.approx(
        300 + 2 * (100 * math.sqrt(2) + 200), abs=0.1)


def test_do_jump_limits(tmp_path):
    loop = [TAKEOFF, wp(100, 0, 40), wp(0, 0, 40)]
    with pytest.raises(InputError, match=r"m\.waypoints: line 6: DO_JUMP expands to more "
                                         r"than 100"):
        load_mission(wpl(tmp_path, loop + [(177, 3, 2, 101, 0, 0, 0, 0, 0), RTL]))
    with pytest.raises(InputError, match=r"line 6: DO_JUMP repeat count -1 repeats for ever"):
        load_mission(wpl(tmp_path, loop + [(177, 3, 2, -1, 0, 0, 0, 0, 0), RTL]))
    with pytest.raises(InputError, match=r"line 6: DO_JUMP target 9 is not an item"):
        load_mission(wpl(tmp_path, loop + [(177, 3, 9, 1, 0, 0, 0, 0, 0), RTL]))
    # exactly 100 is allowed
    m = load_mission(wpl(tmp_path, loop + [(177, 3, 2, 100, 0, 0, 0, 0, 0), RTL]))
    assert sum(leg.kind == "cruise" for leg in m.legs) == 2 * 101


def test_hold_loiters_and_land(tmp_path):
    lat, lon = ll(200, 0)
    rows = [TAKEOFF,
            wp(100, 0, 40, hold=15),
            (19, 3, 60, 0, -35, 0, f"{lat:.9f}", f"{lon:.9f}", 40),   # LOITER_TIME, r = 35
            (178, 3, 0, 12, -1, 0, 0, 0, 0),
            (18, 3, 2, 0, 50, 0, 0, 0, 0),                           # LOITER_TURNS here
            (21, 3, 0, 0, 0, 0, 0, 0, 0)]                            # LAND here
    m = load_mission(wpl(tmp_path, rows))
    assert kinds(m) == ["climb", "cruise", "hover", "cruise", "loiter", "loiter", "descend"]
    hover, loiter_time, loiter_turns, land = m.legs[2], m.legs[4], m.legs[5], m.legs[6]
    assert hover.duration_s == 15 and hover.end_en_m == m.legs[1].end_en_m
    # ArduPlane circles a LOITER_TIME at its own WP_LOITER_RAD: param3 gives the direction
    assert (loiter_time.duration_s, loiter_time.loiter_radius_m) == (60, None)
    assert loiter_turns.duration_s == pytest.approx(2 * 2 * math.pi * 50 / 12)
    assert loiter_turns.end_en_m == loiter_time.end_en_m       # 0, 0 = current position
    assert land.end_en_m == loiter_turns.end_en_m and land.end_alt_m == 0


def test_loiter_turns_without_speed_is_an_error(tmp_path):
    with pytest.raises(InputError, match=r"m\.waypoints: line 5: a loiter of 2 turns needs "
                                         r"a radius and a speed"):
        load_mission(wpl(tmp_path, [TAKEOFF, wp(100, 0, 40), (18, 3, 2, 0, 50, 0, 0, 0, 0)]))


def test_loiter_unlimited_is_an_error(tmp_path):
    with pytest.raises(InputError, match=r"m\.waypoints: line 5: MAV_CMD_NAV_LOITER_UNLIM "
                                         r"\(17\) loiters without end"):
        load_mission(wpl(tmp_path, [TAKEOFF, wp(100, 0, 40), (17, 3, 0, 0, 0, 0, 0, 0, 40)]))


def test_vertical_waypoint_and_frames(tmp_path):
    rows = [TAKEOFF,
            wp(0.3, 0.2, 55),                      # < 0.5 m away: a climb, not a cruise
            wp(0, 0, 55),                          # same place, same altitude: nothing
            wp(100, 0, HOME[2] + 70, frame=0),     # global frame: AMSL
            (16, 3, 0, 0, 0, 0, 0, 0, 30),         # 0, 0 = here: descend to 30
            RTL]
    m = load_mission(wpl(tmp_path, rows))
    assert kinds(m) == ["climb", "climb", "cruise", "descend", "cruise", "descend"]
    assert (m.legs[1].start_alt_m, m.legs[1].end_alt_m) == (40, 55)
    assert m.legs[1].end_en_m == (0.0, 0.0)
    assert m.legs[2].end_alt_m == pytest.approx(70)
    assert (m.legs[3].start_alt_m, m.legs[3].end_alt_m) == (pytest.approx(70), 30)


def test_terrain_frame_and_ignored_commands_warn(tmp_path):
    rows = [TAKEOFF, wp(100, 0, 40, frame=10),
            (206, 3, 25, 0, 1, 0, 0, 0, 0), (206, 3, 0, 0, 1, 0, 0, 0, 0), RTL]
    with pytest.warns(UserWarning) as record:
        m = load_mission(wpl(tmp_path, rows))
    text = " | ".join(str(w.message) for w in record)
    assert "line 4: terrain-relative altitude treated as relative" in text
    assert "MAV_CMD_DO_SET_CAM_TRIGG_DIST (206) ignored (2 items, first at line 5)" in text
    assert m.legs[1].end_alt_m == 40


def test_items_after_rtl_are_not_flown(tmp_path):
    with pytest.warns(UserWarning, match=r"1 item\(s\) after line 5 \(RTL\) are not flown"):
        m = load_mission(wpl(tmp_path, [TAKEOFF, wp(100, 0, 40), RTL, wp(0, 100, 40)]))
    assert kinds(m) == ["climb", "cruise", "cruise", "descend"]


def test_clean_route_gives_no_warnings(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_mission(wpl(tmp_path, [TAKEOFF, wp(100, 0, 40), RTL]))


def test_only_home_has_no_legs(tmp_path):
    with pytest.raises(InputError, match=r"m\.waypoints: the mission has no flight legs"):
        load_mission(wpl(tmp_path, []))


def test_yaml_waypoint_climbs_are_bounded_as_a_waypoint_files_are(tmp_path):
    """The YAML waypoints form goes through the same route: given the aircraft's rates, a
    100 m climb over 40 m is a cruise at the climb rate and a climb over the point."""
    from planner.io.mission import NavDefaults
    path = tmp_path / "w.yaml"
    path.write_text("home: {lat: 48.0, lon: 10.0, alt_m: 500}\ntakeoff_alt_m: 10\n"
                    f"waypoints:\n  - {{lat: {48.0 + 40 / 111_200}, lon: 10.0, alt_m: 110}}\n")
    legs = load_mission(path, defaults=NavDefaults("multirotor", 8.0, 2.5, 1.5)).legs
    assert [leg.kind for leg in legs][:3] == ["climb", "cruise", "climb"]
    cruise = legs[1]
    assert (cruise.end_alt_m - cruise.start_alt_m) == pytest.approx(2.5 * cruise.distance_m / 8)
    assert legs[2].end_alt_m == 110


def test_swapped_latitude_and_longitude_named(tmp_path):
    """A waypoint typed (lon, lat) lands thousands of km from home: the error names the item
    and the swap, not a frame error or a 4000 km leg."""
    lat, lon = ll(300, 0)
    bad = (16, 3, 0, 0, 0, 0, f"{lon:.9f}", f"{lat:.9f}", 40)
    with pytest.raises(InputError, match=r"line 5: .*latitude and longitude swapped\?"):
        load_mission(wpl(tmp_path, [TAKEOFF, wp(100, 0, 40), bad, RTL]))


def test_speed_in_km_h_named(tmp_path):
    """A DO_CHANGE_SPEED of 54 against a 25 m/s aircraft is 15 m/s typed in km/h."""
    from planner.physics.mission import NavDefaults
    nav = NavDefaults("fixed_wing", 18.0, 3.0, 2.0, loiter_radius_m=80.0, max_speed_ms=25.0)
    rows = [TAKEOFF, (178, 3, 0, 54, -1, 0, 0, 0, 0), wp(300, 0, 40), RTL]
    with pytest.raises(InputError, match=r"line 4: speed 54 m/s .* km/h\?"):
        load_mission(wpl(tmp_path, rows), defaults=nav)
    rows[1] = (178, 3, 0, 20, -1, 0, 0, 0, 0)
    assert load_mission(wpl(tmp_path, rows), defaults=nav).legs
