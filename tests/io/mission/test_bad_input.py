"""Bad input in mission files: unbounded holds, negative holds, non-finite coordinates,
altitudes outside the atmosphere model, and legs too long for a flat frame.

Each case was found by an audit; before the fix it gave a traceback, a hang, an error
without the file or the item, or a silently wrong answer.
"""

import json
import math
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad

from planner.errors import InputError
from planner.physics import geo
from planner.io.mission import load_mission
from planner.io.mission.route import MAX_HOLD_S, MAX_LOITER_TURNS

REPO = Path(__file__).resolve().parents[3]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
WPL = REPO / "missions/survey_route.waypoints"
PLAN = REPO / "missions/survey_route.plan"


def run(*args):
    return subprocess.run([sys.executable, "-m", "planner", *map(str, args)],
                          capture_output=True, text=True, cwd=REPO, timeout=120, check=False)


def check_exits_2(path, *needles):
    """``check`` on a bad mission: exit 2, one line naming the file and each needle."""
    p = run("check", path, "--aircraft", SOLO)
    assert p.returncode == 2, (p.returncode, p.stdout[-500:], p.stderr[-2000:])
    assert "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert str(path) in p.stderr
    for needle in needles:
        assert needle in p.stderr, (needle, p.stderr)
    return p.stderr


def edit_wpl(tmp_path, line, name="m.waypoints", **fields):
    """The shipped survey_route.waypoints with fields of one (1-based) line replaced.

    Fields are by 1-based column number: ``c4="19"`` sets the command.
    """
    lines = WPL.read_text().splitlines()
    cols = lines[line - 1].split("\t")
    for key, value in fields.items():
        cols[int(key[1:]) - 1] = str(value)
    lines[line - 1] = "\t".join(cols)
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def edit_plan(tmp_path, change, name="m.plan"):
    data = json.loads(PLAN.read_text())
    change(data["mission"])
    path = tmp_path / name
    path.write_text(json.dumps(data))          # NaN and Infinity written as Python does
    return path


def yaml_file(tmp_path, text, name="m.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def wpl_rows(tmp_path, rows, home=(48.0468, 10.4452, 598.0), name="r.waypoints"):
    """A .waypoints file from rows (command, frame, p1..p4, lat, lon, alt)."""
    lines = ["QGC WPL 110", "\t".join(map(str, (0, 1, 0, 16, 0, 0, 0, 0, *home, 1)))]
    for i, (cmd, frame, *rest) in enumerate(rows, start=1):
        lines.append("\t".join(str(v) for v in (i, 0, frame, cmd, *rest, 1)))
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


TAKEOFF = (22, 3, 0, 0, 0, 0, 0, 0, 40)
RTL = (20, 3, 0, 0, 0, 0, 0, 0, 0)


# ------------------------------------------------- 1. holds and loiters are bounded

def test_bounds_are_24_hours_and_255_turns():
    assert MAX_HOLD_S == 86400 and MAX_LOITER_TURNS == 255


def test_waypoints_hold_of_1e308_exits_2_naming_line_and_item(tmp_path):
    path = edit_wpl(tmp_path, 15, c5="1e308")        # line 15 is item 13, the 30 s hold
    check_exits_2(path, "line 15 (item 13)", "hold time", "1e+308", "0 to 86400 s")


def test_waypoints_loiter_time_of_1e12_exits_2(tmp_path):
    path = edit_wpl(tmp_path, 15, c4="19", c5="1e12")
    check_exits_2(path, "line 15 (item 13)", "NAV_LOITER_TIME", "1e+12", "0 to 86400 s")


def test_plan_loiter_time_of_1e9_exits_2_without_hanging(tmp_path):
    def change(m):
        m["items"][3]["command"] = 19
        m["items"][3]["params"][0] = 1e9
    path = edit_plan(tmp_path, change)
    check_exits_2(path, "mission.items[4]", "NAV_LOITER_TIME", "1e+09", "86400")


def test_yaml_hover_of_1e308_exits_2(tmp_path):
    path = yaml_file(tmp_path, """
        legs:
          - climb: {altitude_m: 30}
          - hover: {duration_s: 1e308}
        """)
    check_exits_2(path, "legs[2].hover.duration_s must be <= 86400 (24 h)")


@pytest.mark.parametrize("leg, needle", [
    ("loiter: {duration_s: 1e6}", "legs[2].loiter.duration_s must be <= 86400 (24 h)"),
    ("loiter: {turns: 1000, radius_m: 50, airspeed_ms: 12}",
     "legs[2].loiter.turns must be <= 255"),
    ("loiter: {turns: 250, radius_m: 500, airspeed_ms: 5}",
     "legs[2].loiter 250 turns of 500 m at 5 m/s: loiter time 157080 s is out of range"),
])
def test_yaml_loiters_are_bounded(tmp_path, leg, needle):
    path = yaml_file(tmp_path, f"legs:\n  - climb: {{altitude_m: 30}}\n  - {leg}\n")
    with pytest.raises(InputError) as info:
        load_mission(path)
    assert str(path) in str(info.value) and needle in str(info.value)


def test_yaml_waypoint_hold_is_bounded(tmp_path):
    path = yaml_file(tmp_path, """
        home: {lat: 48.0, lon: 10.0, alt_m: 500}
        waypoints:
          - {lat: 48.001, lon: 10.0, alt_m: 30, hold_s: 1e6}
        """)
    with pytest.raises(InputError, match=r"m\.yaml: waypoints\[1\]\.hold_s must be <= 86400"):
        load_mission(path)


def test_yaml_cruise_longer_than_half_the_earth_exits_2(tmp_path):
    path = yaml_file(tmp_path, """
        legs:
          - climb: {altitude_m: 30}
          - cruise: {distance_m: 1e308, course_deg: 0}
        """)
    check_exits_2(path, "legs[2].cruise.distance_m must be <=", "half the Earth")


def test_loiter_turns_are_bounded_in_waypoints(tmp_path):
    path = wpl_rows(tmp_path, [TAKEOFF, (18, 3, 1000, 0, 50, 0, 0, 0, 40), RTL])
    with pytest.raises(InputError, match=r"r\.waypoints: line 4 \(item 2\): "
                                         r"MAV_CMD_NAV_LOITER_TURNS \(18\) param1 \(turns\) "
                                         r"1000 is out of range \(expected 0 to 255"):
        load_mission(path)
    # 255 turns of 200 m at 1 m/s take 3.5 days
    path = wpl_rows(tmp_path, [TAKEOFF, (178, 2, 0, 1, -1, 0, 0, 0, 0),
                               (18, 3, 255, 0, 200, 0, 0, 0, 40), RTL])
    with pytest.raises(InputError, match=r"line 5: 255 turns of 200 m at 1 m/s: loiter time "
                                         r"320442 s is out of range \(expected 0 to 86400 s"):
        load_mission(path)


def test_nav_delay_is_bounded_and_minus_one_is_ignored(tmp_path):
    path = wpl_rows(tmp_path, [TAKEOFF, (93, 3, 1e6, 0, 0, 0, 0, 0, 0), RTL])
    with pytest.raises(InputError, match=r"line 4 \(item 2\): MAV_CMD_NAV_DELAY \(93\) "
                                         r"param1 \(delay\) 1e\+06 s is out of range"):
        load_mission(path)
    path = wpl_rows(tmp_path, [TAKEOFF, (93, 3, -1, 0, 0, 0, 0, 0, 0), RTL])
    with pytest.warns(UserWarning, match=r"NAV_DELAY \(93\) ignored"):
        load_mission(path)


def test_holds_repeated_by_do_jump_are_bounded_in_all(tmp_path):
    # a 24 h hold (allowed) flown 101 times through DO_JUMP: 101 days
    rows = [TAKEOFF, (16, 3, 86400, 0, 0, 0, 48.047, 10.446, 40),
            (177, 3, 2, 100, 0, 0, 0, 0, 0), RTL]
    with pytest.raises(InputError, match=r"r\.waypoints: line 4: the holds and loiters of "
                                         r"the mission add up to 172800 s here \(expected at "
                                         r"most 86400 s"):
        load_mission(wpl_rows(tmp_path, rows))


# ------------------------------------------------- 2. negative holds

def test_negative_hold_in_waypoints_exits_2(tmp_path):
    path = edit_wpl(tmp_path, 15, c5="-30")
    check_exits_2(path, "line 15 (item 13)", "hold time", "-30 s", "0 to 86400 s")


def test_negative_hold_in_plan_is_refused(tmp_path):
    def change(m):
        m["items"][3]["params"][0] = -5
    with pytest.raises(InputError, match=r"m\.plan: mission\.items\[4\]: "
                                         r"MAV_CMD_NAV_WAYPOINT \(16\) param1 \(hold time\) "
                                         r"-5 s is out of range"):
        load_mission(edit_plan(tmp_path, change))


def test_null_hold_in_plan_is_no_hold(tmp_path):
    def change(m):
        m["items"][3]["params"][0] = None
    mission = load_mission(edit_plan(tmp_path, change))
    assert all(leg.origin != "mission.items[4]" or leg.kind == "cruise"
               for leg in mission.legs)


# ------------------------------------------------- 3. NaN and infinite coordinates

def test_plan_home_nan_exits_2_instead_of_a_wrong_go(tmp_path):
    def change(m):
        m["plannedHomePosition"][0] = math.nan
    path = edit_plan(tmp_path, change)
    check_exits_2(path, "mission.plannedHomePosition", "finite")


@pytest.mark.parametrize("index, value", [(4, math.nan), (5, math.inf), (6, -math.inf)])
def test_plan_item_nan_or_inf_is_refused(tmp_path, index, value):
    def change(m):
        m["items"][3]["params"][index] = value
    with pytest.raises(InputError, match=rf"m\.plan: mission\.items\[4\]\.param{index + 1} "
                                         r"must be a finite number or null"):
        load_mission(edit_plan(tmp_path, change))


@pytest.mark.parametrize("home, needle", [
    ([48.0, 10.0, math.inf], "plannedHomePosition must be [lat, lon, alt_amsl]"),
    ([95.0, 10.0, 500.0], "plannedHomePosition latitude/longitude 95, 10 out of range"),
])
def test_plan_home_out_of_range_is_refused(tmp_path, home, needle):
    def change(m):
        m["plannedHomePosition"] = home
    with pytest.raises(InputError) as info:
        load_mission(edit_plan(tmp_path, change))
    assert needle in str(info.value)


@pytest.mark.parametrize("column, name, value", [(9, "latitude", "nan"), (9, "latitude", "inf"),
                                                  (10, "longitude", "-inf"),
                                                  (11, "altitude", "nan")])
def test_waypoints_nan_or_inf_coordinate_exits_2(tmp_path, column, name, value):
    path = edit_wpl(tmp_path, 6, **{f"c{column}": value})
    check_exits_2(path, f"line 6 (item 4): {name} is '{value}' (expected a finite number)")


def test_waypoints_home_out_of_range_is_refused(tmp_path):
    path = edit_wpl(tmp_path, 2, c9="148.0468")
    with pytest.raises(InputError, match=r"m\.waypoints: line 2 \(item 0\): home "
                                         r"latitude/longitude 148\.047, 10\.4452 out of range"):
        load_mission(path)


def test_yaml_nan_latitude_is_refused(tmp_path):
    path = yaml_file(tmp_path, """
        home: {lat: .nan, lon: 10.0, alt_m: 500}
        waypoints:
          - {lat: 48.001, lon: .inf, alt_m: 30}
        """)
    with pytest.raises(InputError) as info:
        load_mission(path)
    msg = str(info.value)
    assert "home.lat must be finite, got nan" in msg
    assert "waypoints[1].lon must be finite, got inf" in msg


# ------------------------------------------------- 4. altitudes within the atmosphere model

def test_waypoint_altitude_out_of_range_names_file_item_and_value(tmp_path):
    path = edit_wpl(tmp_path, 6, c11="20000")        # 20000 m above a home at 598 m
    msg = check_exits_2(path, "line 6 (item 4)", "altitude 20000 m (frame 3, above home)",
                        "20598 m above mean sea level", "-500 to 11000 m AMSL",
                        "-1098 to 10402 m above home")
    assert "20625" not in msg                          # the leg's mean, not the file's value


def test_amsl_frame_altitude_is_checked_as_written(tmp_path):
    path = wpl_rows(tmp_path, [TAKEOFF, (16, 0, 0, 0, 0, 0, 48.047, 10.446, 12000), RTL])
    with pytest.raises(InputError, match=r"r\.waypoints: line 4 \(item 2\): "
                                         r"MAV_CMD_NAV_WAYPOINT \(16\) altitude 12000 m "
                                         r"\(frame 0, above mean sea level\) puts the aircraft "
                                         r"at 12000 m above mean sea level"):
        load_mission(path)


def test_home_altitude_out_of_range_is_refused(tmp_path):
    path = edit_wpl(tmp_path, 2, c11="12000")
    with pytest.raises(InputError, match=r"line 2 \(item 0\): home altitude 12000 m above "
                                         r"mean sea level is outside the atmosphere model"):
        load_mission(path)

    def change(m):
        m["plannedHomePosition"][2] = -800
    with pytest.raises(InputError, match=r"m\.plan: mission\.plannedHomePosition altitude "
                                         r"-800 m above mean sea level is outside"):
        load_mission(edit_plan(tmp_path, change))


def test_plan_takeoff_altitude_out_of_range_exits_2(tmp_path):
    def change(m):
        m["items"][0]["params"][6] = 15000
    path = edit_plan(tmp_path, change)
    check_exits_2(path, "mission.items[1]", "NAV_TAKEOFF", "altitude 15000 m",
                  "15598 m above mean sea level")


@pytest.mark.parametrize("text, needle", [
    ("""
     home: {lat: 48.0, lon: 10.0, alt_m: 598}
     waypoints:
       - {lat: 48.001, lon: 10.0, alt_m: 20000}
     """, "waypoints[1].alt_m 20000 m puts the aircraft at 20598 m above mean sea level"),
    ("""
     home: {lat: 48.0, lon: 10.0, alt_m: 598}
     takeoff_alt_m: 10500
     waypoints:
       - {lat: 48.001, lon: 10.0, alt_m: 50}
     """, "takeoff_alt_m 10500 m puts the aircraft at 11098 m"),
    ("""
     environment: {site_altitude_m: 2000}
     legs:
       - climb: {altitude_m: 9500}
     """, "legs[1].climb.altitude_m 9500 m puts the aircraft at 11500 m"),
    ("""
     environment: {site_altitude_m: 2000}
     legs:
       - climb: {altitude_m: 100}
       - climb: {height_m: 9000}
     """, "legs[2].climb.height_m 9000 m (to 9100 m above home) puts the aircraft at 11100 m"),
    ("""
     legs:
       - climb: {altitude_m: 100}
       - cruise: {distance_m: 100, course_deg: 0, altitude_m: -700}
     """, "legs[2].cruise.altitude_m -700 m puts the aircraft at -700 m"),
    ("""
     environment: {site_altitude_m: 12000}
     legs:
       - climb: {altitude_m: 100}
     """, "environment.site_altitude_m must be <= 11000 (the atmosphere model's range"),
])
def test_yaml_altitudes_out_of_range(tmp_path, text, needle):
    path = yaml_file(tmp_path, text)
    with pytest.raises(InputError) as info:
        load_mission(path)
    assert str(path) in str(info.value) and needle in str(info.value)


# ------------------------------------------------- 5. long legs: great circles

def _haversine_km(lat1, lon1, lat2, lon2, radius_km=6371.0088):
    """Independent reference: the haversine formula on a sphere."""
    p1, p2 = np.radians(lat1), np.radians(lat2)
    dp, dl = p2 - p1, np.radians(lon2 - lon1)
    a = np.sin(dp / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    return 2 * radius_km * np.arcsin(np.sqrt(a))


def _route(tmp_path, home, points, name="far.yaml"):
    text = (f"home: {{lat: {home[0]}, lon: {home[1]}, alt_m: 100}}\n"
            "takeoff_alt_m: 50\nwaypoints:\n")
    text += "".join(f"  - {{lat: {la}, lon: {lo}, alt_m: 50}}\n" for la, lo in points)
    path = tmp_path / name
    path.write_text(text)
    return path


def test_48n_to_equator_is_a_great_circle_not_a_flat_4719_km(tmp_path):
    legs = load_mission(_route(tmp_path, (48.0, 10.0), [(0.0, 10.0)])).legs
    out, back = (leg for leg in legs if leg.kind == "cruise")
    ref = _haversine_km(48, 10, 0, 10)                               # 5 337.5 km
    arc, _ = quad(lambda p: geo.meridian_radius(np.degrees(p)), 0, np.radians(48))
    assert out.distance_m / 1e3 == pytest.approx(ref, rel=2e-3)      # was 4 719 km
    assert out.distance_m == pytest.approx(arc, rel=5e-3)            # WGS-84: 5 318 km
    assert out.course_deg == pytest.approx(180.0)
    assert back.distance_m == pytest.approx(out.distance_m, rel=1e-9)


@pytest.mark.parametrize("home, point", [
    ((80.0, 0.0), (80.0, 180.0)),             # over the pole: 20 degrees, 2 224 km
    ((48.0, 10.0), (-47.9, -169.9)),          # near the antipode
    ((-33.9, 151.2), (51.5, -0.1)),           # Sydney - London
])
def test_long_legs_from_home_have_great_circle_length_and_bearing(tmp_path, home, point):
    legs = load_mission(_route(tmp_path, home, [point])).legs
    out = next(leg for leg in legs if leg.kind == "cruise")
    assert out.distance_m / 1e3 == pytest.approx(_haversine_km(*home, *point), rel=5e-3)
    _, bearing = geo.great_circle(*home, *point)
    assert out.course_deg == pytest.approx(bearing, abs=0.2)    # ellipsoid correction only


def test_long_leg_away_from_home_is_refused(tmp_path):
    path = _route(tmp_path, (48.0, 10.0), [(0.0, 10.0), (0.0, 50.0)])
    with pytest.raises(InputError, match=r"far\.yaml: waypoints\[2\]: the 4453 km leg from "
                                         r"waypoints\[1\] reaches \d+ km from home without "
                                         r"passing through it.*expected legs within about "
                                         r"490 km of home"):
        load_mission(path)
    p = run("check", path, "--aircraft", SOLO)
    assert p.returncode == 2 and "waypoints[2]" in p.stderr and "Traceback" not in p.stderr


def test_route_within_some_hundred_km_is_accepted(tmp_path):
    # a 300 km box east of home: every leg within 0.1 % of its great circle
    points = [(48.0, 13.0), (50.0, 13.0), (50.0, 10.0)]
    legs = [leg for leg in load_mission(_route(tmp_path, (48.0, 10.0), points)).legs
            if leg.kind == "cruise"]
    ends = [(48.0, 10.0), *points, (48.0, 10.0)]
    for leg, a, b in zip(legs, ends, ends[1:]):
        assert leg.distance_m / 1e3 == pytest.approx(_haversine_km(*a, *b), rel=4e-3)


def test_short_legs_unchanged_from_the_tangent_plane():
    """The leg frame agrees with the ellipsoid tangent plane near home (the old frame)."""
    rng = np.random.default_rng(2)
    for home in [(48.0468, 10.4452), (-33.9, 151.2), (64.1, -21.9), (0.0, 179.9)]:
        east, north = rng.uniform(-20e3, 20e3, 300), rng.uniform(-20e3, 20e3, 300)
        lat, lon = geo.en_to_latlon(east, north, *home)
        e2, n2 = geo.latlon_to_aeqd(lat, lon, *home)
        old = np.hypot(np.diff(east), np.diff(north))
        new = np.hypot(np.diff(e2), np.diff(n2))
        keep = old > 100
        assert_allclose(new[keep], old[keep], rtol=1e-4)         # 0.01 %, well within 0.1 %


def test_shipped_route_legs_unchanged(repo):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        legs = load_mission(repo / "missions/survey_route.waypoints").legs
    home = (48.0468, 10.4452)
    lines = (repo / "missions/survey_route.waypoints").read_text().splitlines()
    rows = [line.split("\t") for line in lines[2:]]
    pts = [(float(r[8]), float(r[9])) for r in rows if r[3] == "16"]
    e, n = geo.latlon_to_en(*np.array(pts).T, *home)                # the old frame
    cruise = [leg for leg in legs if leg.kind == "cruise"]
    assert_allclose([leg.end_en_m for leg in cruise[:len(pts)]], np.c_[e, n], atol=2e-3)


def test_leg_frame_round_trip_and_home_distance():
    rng = np.random.default_rng(3)
    for home in [(48.0, 10.0), (89.0, 0.0), (-60.0, -170.0)]:
        lat, lon = rng.uniform(-89, 89, 400), rng.uniform(-180, 180, 400)
        e, n = geo.latlon_to_aeqd(lat, lon, *home)
        lat2, lon2 = geo.aeqd_to_latlon(e, n, *home)
        assert_allclose(lat2, lat, atol=1e-9)
        assert_allclose(np.angle(np.exp(1j * np.radians(lon2 - lon))), 0, atol=1e-9)
        d = geo.great_circle_distance(home[0], home[1], lat, lon)
        assert_allclose(np.hypot(e, n), d, rtol=1e-12)


def test_frame_error_is_zero_through_home_and_small_near_it():
    assert geo.frame_error(10.0, 10.0, 80.0, 10.0, 48.0, 10.0) < 1e-9   # through home
    assert geo.frame_error(48.1, 10.0, 48.2, 10.3, 48.0, 10.0) < 1e-5
    assert geo.frame_error(0.0, 10.0, 0.0, 50.0, 48.0, 10.0) > 0.1
    # about r^2 / 6R^2 for a short leg across the line of sight at r from home
    r = geo.FRAME_ERROR_KM / 6371.0
    lat = 48.0 + np.degrees(r)
    assert geo.frame_error(lat, 9.99, lat, 10.01, 48.0, 10.0) == pytest.approx(1e-3, rel=0.05)


@pytest.mark.parametrize("block, needle", [
    ("environment: {wind_speed_ms: 1.0e+308}", "environment.wind_speed_ms"),
    ("environment: {temperature_c: -200}", "environment.temperature_c"),
])
def test_yaml_environment_is_bounded(tmp_path, block, needle):
    path = tmp_path / "m.yaml"
    path.write_text(f"{block}\nlegs:\n  - climb: {{height_m: 30}}\n"
                    "  - hover: {duration_s: 60}\n  - descend: {height_m: 30}\n")
    with pytest.raises(InputError, match=needle.replace(".", r"\.")):
        load_mission(path)


@pytest.mark.parametrize("speed", ["1.0e-300", "1.0e+308"])
def test_yaml_speeds_are_bounded(tmp_path, speed):
    path = tmp_path / "m.yaml"
    path.write_text("legs:\n  - climb: {height_m: 30}\n"
                    f"  - cruise: {{distance_m: 500, groundspeed_ms: {speed}}}\n"
                    "  - descend: {height_m: 30}\n")
    with pytest.raises(InputError, match="groundspeed_ms"):
        load_mission(path)


@pytest.mark.parametrize("where", ["payload_kg", "home", "plan_param", "plan_home"])
def test_an_integer_too_large_for_a_float_is_bad_input(tmp_path, where):
    """Found by the fuzzer: a 400-digit integer made float() raise OverflowError (exit 3)."""
    big = int("9" * 400)
    if where.startswith("plan"):
        plan = json.loads((REPO / "missions/survey_route.plan").read_text())
        if where == "plan_param":
            plan["mission"]["items"][1]["params"][4] = big
        else:
            plan["mission"]["plannedHomePosition"][0] = big
        path = tmp_path / "m.plan"
        path.write_text(json.dumps(plan))
        check_exits_2(path, "finite number")
    else:
        text = (f"name: t\npayload_kg: {big}\nlegs:\n  - climb: {{altitude_m: 30}}\n"
                if where == "payload_kg" else
                f"name: t\nhome: {{lat: {big}, lon: 3, alt_m: 1}}\nwaypoints:\n"
                "  - {lat: 1, lon: 2, alt_m: 3}\n")
        path = tmp_path / "m.yaml"
        path.write_text(text)
        check_exits_2(path, "must be finite, got a number of 400 digits")
