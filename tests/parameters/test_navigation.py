"""The aircraft file's navigation: block (planner.parameters.aircraft.Navigation): the
autopilots' cited defaults, overrides, problems named by key, and the round trip."""

from pathlib import Path

import pytest
import yaml

from planner.errors import InputError
from planner.parameters import Navigation, aircraft_from_mapping, load_aircraft

REPO = Path(__file__).resolve().parents[2]
M100 = REPO / "aircraft" / "dji_m100_rotor_losses.yaml"


def with_block(block):
    data = yaml.safe_load(M100.read_text())
    data["navigation"] = block
    return data


def test_shipped_files_have_no_block_unless_they_say_so():
    assert load_aircraft(REPO / "aircraft" / "quad_7in.yaml").navigation is None


@pytest.mark.parametrize("autopilot, accel, jerk, cited", [
    ("arducopter-4.1", 2.5, 1.0, "WPNAV_ACCEL"),   # AC_WPNav.h, AC_WPNav.cpp
    ("px4", 3.0, 4.0, "MPC_JERK_AUTO"),            # multicopter_autonomous_params.c
])
def test_firmware_defaults_are_cited(autopilot, accel, jerk, cited):
    nav = Navigation.defaults(autopilot)
    assert (nav.horizontal_accel_ms2, nav.horizontal_jerk_ms3) == (accel, jerk)
    assert cited in nav.source and nav.stop_at_waypoints is False


def test_dji_defaults_say_they_are_measured():
    nav = Navigation.defaults("dji")
    assert nav.stop_at_waypoints is True and "measured" in nav.source


def test_defaults_with_overrides():
    a = aircraft_from_mapping(with_block({"defaults": "px4", "climb_rate_ms": 2.0}), "x.yaml")
    assert a.navigation.climb_rate_ms == 2.0
    assert a.navigation.landing_descent_rate_ms == 0.7       # MPC_LAND_SPEED


def test_problems_name_the_key():
    with pytest.raises(InputError, match=r"x\.yaml: navigation\.horizontal_jerk_ms3 must be > 0"):
        aircraft_from_mapping(with_block({"defaults": "px4", "horizontal_jerk_ms3": -1}),
                              "x.yaml")
    with pytest.raises(InputError, match=r"navigation needs 'navigation\.takeoff_spinup_s'"):
        aircraft_from_mapping(with_block({"climb_rate_ms": 2.0}), "x.yaml")
    with pytest.raises(InputError, match="unknown key 'navigation.climb_rate'"):
        aircraft_from_mapping(with_block({"defaults": "dji", "climb_rate": 2.0}), "x.yaml")
    with pytest.raises(ValueError, match="unknown autopilot"):
        Navigation.defaults("betaflight")


def test_round_trip_through_the_mapping():
    a = aircraft_from_mapping(with_block({"defaults": "arducopter-4.1"}), "x.yaml")
    b = aircraft_from_mapping(a.to_mapping(), "y.yaml")
    assert b.navigation == a.navigation


def test_the_m100_navigation_file_holds_the_measured_dji_values():
    nav = load_aircraft(REPO / "aircraft" / "dji_m100_navigation.yaml").navigation
    dji = Navigation.defaults("dji")
    assert {k: v for k, v in vars(nav).items() if k != "source"} == \
        {k: v for k, v in vars(dji).items() if k != "source"}
