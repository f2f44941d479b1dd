"""YAML missions: the legs form, the waypoints form, the examples and bad input."""

import math
import re
import textwrap

import pytest

from planner.errors import InputError
from planner.io.mission import Leg, load_mission


def write(tmp_path, text, name="m.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def rough_duration_s(mission, default_speed=10.0, default_rate=2.0):
    """Flight time from the legs' own speeds (the examples give all of them)."""
    total = 0.0
    for leg in mission.legs:
        if leg.kind == "cruise":
            total += leg.distance_m / (leg.speed_ms or default_speed)
        elif leg.kind in ("climb", "descend"):
            total += abs(leg.end_alt_m - leg.start_alt_m) / (leg.climb_rate_ms or default_rate)
        else:
            total += leg.duration_s
    return total


# ---------------------------------------------------------------- legs form

def test_legs_form_geometry_is_dead_reckoned(tmp_path):
    path = write(tmp_path, """
        legs:
          - climb: {altitude_m: 60, rate_ms: 3}
          - cruise: {distance_m: 1000, course_deg: 90, airspeed_ms: 12}
          - hover: {duration_s: 30}
          - cruise: {distance_m: 500, course_deg: 180, groundspeed_ms: 8, altitude_m: 40}
          - descend: {altitude_m: 0}
    """)
    m = load_mission(path)
    assert [leg.kind for leg in m.legs] == ["climb", "cruise", "hover", "cruise", "descend"]
    climb, east, hover, south, down = m.legs
    assert (climb.start_alt_m, climb.end_alt_m, climb.climb_rate_ms) == (0.0, 60.0, 3.0)
    assert east.start_en_m == (0.0, 0.0)
    assert east.end_en_m == pytest.approx((1000.0, 0.0), abs=1e-9)
    assert east.distance_m == pytest.approx(1000.0)
    assert east.course_deg == pytest.approx(90.0)
    assert (east.speed_ms, east.speed_is_airspeed) == (12.0, True)
    assert hover.start_en_m == east.end_en_m and hover.duration_s == 30.0
    assert south.end_en_m == pytest.approx((1000.0, -500.0), abs=1e-9)
    assert (south.start_alt_m, south.end_alt_m) == (60.0, 40.0)
    assert (south.speed_ms, south.speed_is_airspeed) == (8.0, False)
    assert (down.start_alt_m, down.end_alt_m, down.climb_rate_ms) == (40.0, 0.0, None)
    assert down.end_en_m == south.end_en_m
    assert [leg.origin for leg in m.legs] == [f"legs[{i}]" for i in range(1, 6)]
    assert m.name == "m" and m.payload_kg == 0.0 and m.home is None
    assert m.source == str(path)


def test_relative_heights_and_loiter_turns(tmp_path):
    path = write(tmp_path, """
        name: turns
        payload_kg: 0.5
        legs:
          - climb: {height_m: 40}
          - climb: {height_m: 20, rate_ms: 2}
          - loiter: {turns: 3, radius_m: 60, airspeed_ms: 14}
          - loiter: {duration_s: 120}
          - descend: {height_m: 15, rate_ms: 1}
          - descend: {}
    """)
    m = load_mission(path)
    assert [(leg.start_alt_m, leg.end_alt_m) for leg in m.legs] == [
        (0, 40), (40, 60), (60, 60), (60, 60), (60, 45), (45, 0)]
    turns = m.legs[2]
    assert turns.duration_s == pytest.approx(3 * 2 * math.pi * 60 / 14)
    assert (turns.loiter_radius_m, turns.speed_ms, turns.speed_is_airspeed) == (60, 14, True)
    assert m.legs[3].loiter_radius_m is None and m.legs[3].speed_ms is None
    assert m.name == "turns" and m.payload_kg == 0.5


def test_environment_and_defaults(tmp_path):
    path = write(tmp_path, """
        home: {lat: 48.0, lon: 10.0, alt_m: 550}
        environment: {wind_speed_ms: 5, wind_from_deg: 450, temperature_c: -5}
        legs: [{hover: {duration_s: 10}}]
    """)
    env = load_mission(path).environment
    assert (env.wind_speed_ms, env.wind_from_deg, env.temperature_c) == (5, 90, -5)
    assert env.pressure_pa is None
    assert env.site_altitude_m == 550           # defaults to the home altitude


def test_example_survey_quad(repo):
    m = load_mission(repo / "missions" / "survey_quad.yaml")
    kinds = [leg.kind for leg in m.legs]
    assert kinds[0] == "climb" and kinds[-1] == "descend" and "hover" in kinds
    assert kinds.count("cruise") >= 10
    # back home and on the ground
    assert m.legs[-1].end_en_m == pytest.approx((0, 0), abs=1.0)
    assert m.legs[-1].end_alt_m == 0
    assert 12 * 60 <= rough_duration_s(m) <= 18 * 60
    assert m.environment.wind_speed_ms > 0
    for a, b in zip(m.legs, m.legs[1:]):      # legs are continuous
        assert b.start_en_m == a.end_en_m and b.start_alt_m == a.end_alt_m


def test_example_mapping_plane(repo):
    m = load_mission(repo / "missions" / "mapping_plane.yaml")
    assert "loiter" in {leg.kind for leg in m.legs}
    cruise = [leg for leg in m.legs if leg.kind == "cruise"]
    assert all(leg.speed_is_airspeed for leg in cruise)
    assert m.legs[-1].end_en_m == pytest.approx((0, 0), abs=1.0)
    assert 30 * 60 <= rough_duration_s(m) <= 40 * 60


def test_waypoints_form(tmp_path):
    path = write(tmp_path, """
        home: {lat: 48.0, lon: 10.0, alt_m: 500}
        takeoff_alt_m: 30
        speed_ms: 5
        waypoints:
          - {lat: 48.001, lon: 10.0, alt_m: 30}
          - {lat: 48.001, lon: 10.0, alt_m: 45, hold_s: 20, airspeed_ms: 12}
          - {lat: 48.001, lon: 10.001, alt_m: 45}
        return_home: false
    """)
    m = load_mission(path)
    assert [leg.kind for leg in m.legs] == ["climb", "cruise", "climb", "hover", "cruise",
                                            "descend"]
    assert m.legs[1].end_en_m[1] == pytest.approx(111.2, rel=1e-2)
    assert (m.legs[1].speed_ms, m.legs[1].speed_is_airspeed) == (5, None)
    assert (m.legs[2].start_alt_m, m.legs[2].end_alt_m) == (30, 45)   # same point: vertical
    assert m.legs[3].duration_s == 20
    assert (m.legs[4].speed_ms, m.legs[4].speed_is_airspeed) == (12, True)
    assert m.legs[5].end_en_m == m.legs[4].end_en_m                    # land where it is
    assert m.legs[5].origin == "land" and m.legs[2].origin == "waypoints[2]"
    assert m.home == (48.0, 10.0, 500) and m.environment.site_altitude_m == 500


def test_waypoints_form_return_without_landing(tmp_path):
    path = write(tmp_path, """
        home: {lat: 48.0, lon: 10.0, alt_m: 500}
        waypoints: [{lat: 48.001, lon: 10.0, alt_m: 30}]
        land: false
    """)
    m = load_mission(path)
    assert [leg.kind for leg in m.legs] == ["cruise", "cruise"]
    assert m.legs[-1].end_en_m == (0.0, 0.0) and m.legs[-1].end_alt_m == 30


# ---------------------------------------------------------------- bad input

BAD = [
    ("unknown top key",
     "legs: [{hover: {duration_s: 5}}]\npayload_kgs: 1\n",
     r"m\.yaml: unknown key 'payload_kgs' \(did you mean 'payload_kg'\?\)"),
    ("unknown leg key",
     "legs:\n  - cruise: {distnce_m: 5, course_deg: 0}\n",
     (r"m\.yaml: unknown key 'legs\[1\]\.cruise\.distnce_m' "
      r"\(did you mean 'legs\[1\]\.cruise\.distance_m'\?\)")),
    ("unknown environment key",
     "environment: {wind_sped_ms: 3}\nlegs: [{hover: {duration_s: 5}}]\n",
     r"unknown key 'environment\.wind_sped_ms' \(did you mean 'environment\.wind_speed_ms'\?\)"),
    ("wrong type",
     "legs:\n  - hover: {duration_s: 5}\n  - cruise: {distance_m: far, course_deg: 0}\n",
     r"m\.yaml: legs\[2\]\.cruise\.distance_m must be a number, got 'far'"),
    ("bool is not a number",
     "legs:\n  - hover: {duration_s: true}\n",
     r"legs\[1\]\.hover\.duration_s must be a number"),
    ("negative distance",
     ("legs:\n  - climb: {altitude_m: 10}\n  - hover: {duration_s: 1}\n"
      "  - cruise: {distance_m: -5, course_deg: 0}\n"),
     r"m\.yaml: legs\[3\]\.cruise\.distance_m must be >= 0, got -5"),
    ("negative duration",
     "legs: [{hover: {duration_s: -1}}]\n", r"legs\[1\]\.hover\.duration_s must be >= 0"),
    ("zero speed",
     "legs: [{cruise: {distance_m: 5, course_deg: 0, airspeed_ms: 0}}]\n",
     r"legs\[1\]\.cruise\.airspeed_ms must be >= 0\.1 \(slower, the leg never ends\), got 0"),
    ("zero radius",
     "legs: [{loiter: {duration_s: 5, radius_m: 0}}]\n",
     r"legs\[1\]\.loiter\.radius_m must be > 0, got 0"),
    ("empty legs", "legs: []\n", r"m\.yaml: legs is empty"),
    ("no legs at all", "name: x\n", r"m\.yaml: no legs: or waypoints:"),
    ("empty file", "", r"m\.yaml: empty file"),
    ("unknown leg kind",
     "legs:\n  - climb: {altitude_m: 10}\n  - crusie: {distance_m: 5, course_deg: 0}\n",
     r"m\.yaml: legs\[2\] has unknown leg kind 'crusie' \(did you mean 'cruise'\?"),
    ("leg not a one-key mapping",
     "legs:\n  - {climb: {altitude_m: 10}, hover: {duration_s: 5}}\n",
     r"legs\[1\] must be a one-key mapping"),
    ("both speeds",
     "legs: [{cruise: {distance_m: 5, course_deg: 0, airspeed_ms: 5, groundspeed_ms: 5}}]\n",
     r"give only one of 'legs\[1\]\.cruise\.airspeed_ms' or 'legs\[1\]\.cruise\.groundspeed_ms'"),
    ("turns without a speed",
     "legs: [{loiter: {turns: 2, radius_m: 50}}]\n",
     r"legs\[1\]\.loiter turns needs radius_m and airspeed_ms"),
    ("climb that goes down",
     "legs:\n  - climb: {altitude_m: 50}\n  - climb: {altitude_m: 20}\n",
     r"legs\[2\]\.climb goes from 50 m to 20 m"),
    ("missing course",
     "legs: [{cruise: {distance_m: 5}}]\n",
     r"missing required key 'legs\[1\]\.cruise\.course_deg' \(a number\)"),
    ("waypoint-only key in legs form",
     "takeoff_alt_m: 20\nlegs: [{hover: {duration_s: 5}}]\n",
     r"unknown key 'takeoff_alt_m' \(only used with waypoints:"),
    ("waypoints without home",
     "waypoints: [{lat: 48, lon: 10, alt_m: 20}]\n", r"m\.yaml: missing required key 'home'"),
    ("waypoint latitude out of range",
     "home: {lat: 48, lon: 10, alt_m: 0}\nwaypoints: [{lat: 98, lon: 10, alt_m: 20}]\n",
     r"waypoints\[1\]\.lat must be <= 90, got 98"),
    ("empty waypoints",
     "home: {lat: 48, lon: 10, alt_m: 0}\nwaypoints: []\n", r"m\.yaml: waypoints is empty"),
    ("broken YAML",
     "legs:\n  - climb: {altitude_m: 10\n  - hover: 3\n", r"m\.yaml: not valid YAML at line"),
]


@pytest.mark.parametrize("text, pattern", [b[1:] for b in BAD], ids=[b[0] for b in BAD])
def test_bad_input_names_file_and_key(tmp_path, text, pattern):
    path = write(tmp_path, text)
    with pytest.raises(InputError) as info:
        load_mission(path)
    message = str(info.value)
    assert message.startswith(str(path) + ":")
    assert "\n" not in message
    assert re.search(pattern, message), message


def test_every_problem_is_reported_at_once(tmp_path):
    path = write(tmp_path, """
        payload_kg: -1
        legs:
          - cruise: {distance_m: -5, course_deg: 0}
          - hover: {duration: 5}
    """)
    with pytest.raises(InputError) as info:
        load_mission(path)
    message = str(info.value)
    for key in ("payload_kg must be >= 0", "legs[1].cruise.distance_m",
                "unknown key 'legs[2].hover.duration' (did you mean 'legs[2].hover.duration_s'?)",
                "missing required key 'legs[2].hover.duration_s' (a number)"):
        assert key in message


def test_scientific_notation_without_dot_is_a_number(tmp_path):
    # YAML 1.1 (PyYAML) reads 2e3 as the string "2e3"
    path = write(tmp_path, "legs: [{cruise: {distance_m: 2e3, course_deg: 0}}]\n")
    assert load_mission(path).legs[0].distance_m == pytest.approx(2000)


def test_result_is_legs(tmp_path):
    m = load_mission(write(tmp_path, "legs: [{hover: {duration_s: 5}}]\n"))
    assert all(isinstance(leg, Leg) for leg in m.legs)
