"""The leg table with and without the aircraft's navigation block
(planner.chain.kinematics): without it the legs are flown at constant speed as before;
with it a multirotor's take-off spins up and accelerates, its legs are jerk-limited
rest-to-rest moves with a dwell, its landing slows near the ground (closed forms of
planner.physics.motion), and the check predicts a longer, costlier flight."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from planner.chain import kinematics
from planner.chain.mission_chain import MissionChain
from planner.parameters import Navigation, load_aircraft_and_battery
from planner.physics.atmosphere import G
from planner.physics.mission import Environment, Leg, Mission

REPO = Path(__file__).resolve().parents[2]
CALM = Environment(temperature_c=15.0)
NAV = Navigation(takeoff_spinup_s=5.0, climb_rate_ms=3.0, descent_rate_ms=3.0,
                 landing_slow_height_m=20.0, landing_descent_rate_ms=1.0,
                 horizontal_accel_ms2=2.0, horizontal_jerk_ms3=1.0, vertical_accel_ms2=1.0,
                 stop_at_waypoints=True, waypoint_dwell_s=2.0, source="test")


def m100(nav=None):
    air, pack = load_aircraft_and_battery(REPO / "aircraft" / "dji_m100_rotor_losses.yaml")
    return dataclasses.replace(air, navigation=nav), pack


def triangle(speed=8.0, alt=60.0, env=CALM):
    pts = [(0.0, 0.0), (300.0, 0.0), (300.0, 200.0), (0.0, 0.0)]
    legs = [Leg("climb", start_alt_m=0.0, end_alt_m=alt, origin="take-off")]
    legs += [Leg("cruise", a, b, alt, alt, speed_ms=speed, origin=f"side {i + 1}")
             for i, (a, b) in enumerate(zip(pts[:-1], pts[1:]))]
    legs.append(Leg("descend", start_alt_m=alt, end_alt_m=0.0, origin="landing"))
    return Mission("triangle", legs, env, payload_kg=0.25)


def sides():
    return np.array([300.0, 200.0, np.hypot(300.0, 200.0)])


def test_without_navigation_one_row_per_leg_at_constant_speed():
    air, _ = m100()
    assert air.navigation is None
    t = kinematics.leg_table(triangle(), air)
    assert len(t) == 5 and list(t.leg_index) == [0, 1, 2, 3, 4]
    np.testing.assert_allclose(t.duration_s[1:4], sides() / 8.0)
    assert t.duration_s[0] == pytest.approx(60.0 / air.climb_rate_ms)
    assert t.duration_s[4] == pytest.approx(60.0 / air.descent_rate_ms)


def test_with_navigation_the_closed_form_times():
    air, _ = m100(NAV)
    t = kinematics.leg_table(triangle(), air)
    L, V, A, J = sides(), 8.0, 2.0, 1.0
    legs = np.bincount(t.leg_index, weights=t.duration_s)
    assert legs[0] == pytest.approx(5.0 + 60.0 / 3.0 + 3.0 / 1.0)      # spin-up, climb
    np.testing.assert_allclose(legs[1:4], L / V + V / A + A / J + 2.0)  # moves and dwells
    assert legs[4] == pytest.approx(40.0 / 3.0 + 20.0 / 1.0)           # two-rate landing
    assert t.duration_s.sum() == pytest.approx(legs.sum())
    # the rows follow the path: positions continuous, the ends of each leg kept
    np.testing.assert_allclose(t.start_en_m[1:], t.end_en_m[:-1], atol=1e-9)
    np.testing.assert_allclose(t.start_alt_m[1:], t.end_alt_m[:-1], atol=1e-9)
    np.testing.assert_allclose(np.bincount(t.leg_index, weights=t.distance_m)[1:4], L)
    assert t.end_alt_m[-1] == 0.0 and set(t.origin) >= {"side 1 (accelerating)",
                                                        "landing (landing slow stage)"}


def test_accelerating_rows_fly_the_tilted_thrust_at_the_mean_speed():
    air, _ = m100(NAV)
    t = kinematics.leg_table(triangle(), air)
    acc = np.array(["(accelerating)" in o for o in t.origin])
    assert acc.sum() == 3
    mean_a = 8.0 / (8.0 / 2.0 + 2.0 / 1.0)
    np.testing.assert_allclose(t.load_factor[acc], np.sqrt(1.0 + (mean_a / G) ** 2))
    np.testing.assert_allclose(t.groundspeed_ms[acc], 4.0)
    np.testing.assert_allclose(t.airspeed_ms[acc], 4.0)                 # calm air


def test_wind_gives_the_phases_their_airspeed():
    env = Environment(temperature_c=15.0, wind_speed_ms=3.0, wind_from_deg=90.0)
    air, _ = m100(NAV)
    t = kinematics.leg_table(triangle(env=env), air)
    first = t.origin.index("side 1 (accelerating)")    # eastwards into a wind from the east
    assert t.airspeed_ms[first] == pytest.approx(4.0 + 3.0)


def test_check_predicts_longer_and_costlier_with_navigation():
    base = MissionChain(*m100()).check(triangle(), CALM)
    nav = MissionChain(*m100(NAV)).check(triangle(), CALM)
    assert nav.duration_s > base.duration_s + 3 * (8 / 2 + 2 / 1) + 5.0
    assert nav.energy_wh > base.energy_wh


def test_fly_through_waypoints_accelerate_only_at_the_ends():
    nav = dataclasses.replace(NAV, stop_at_waypoints=False)
    air, _ = m100(nav)
    t = kinematics.leg_table(triangle(), air)
    legs = np.bincount(t.leg_index, weights=t.duration_s)
    half = 0.5 * (8.0 / 2.0 + 2.0 / 1.0)
    np.testing.assert_allclose(legs[1:4], sides() / 8.0 + [half, 0.0, half])
    assert not any("dwell" in o for o in t.origin)


def test_fixed_wing_ignores_the_navigation_block():
    air, pack = load_aircraft_and_battery(REPO / "aircraft" / "x8_mapper.yaml")
    legs = [Leg("climb", start_alt_m=0, end_alt_m=80.0),
            Leg("cruise", (0, 0), (2000.0, 0.0), 80.0, 80.0),
            Leg("descend", start_alt_m=80.0, end_alt_m=0)]
    m = Mission("plane", legs, CALM)
    before = kinematics.leg_table(m, air)
    after = kinematics.leg_table(m, dataclasses.replace(air, navigation=NAV))
    np.testing.assert_array_equal(before.duration_s, after.duration_s)
    np.testing.assert_array_equal(before.airspeed_ms, after.airspeed_ms)


def test_a_problem_names_its_mission_leg():
    env = Environment(temperature_c=15.0, wind_speed_ms=30.0, wind_from_deg=90.0)
    air, _ = m100()
    plain = kinematics.leg_table(triangle(env=env), air)
    t = kinematics.leg_table(triangle(env=env), dataclasses.replace(air, navigation=NAV))
    assert plain.problems and len(t.problems) == len(plain.problems)
    assert ([(t.origin[r], why) for r, why in t.problems]
            == [(plain.origin[r], why) for r, why in plain.problems])


def test_return_home_with_navigation_moves_and_lands_as_the_autopilot():
    air, _ = m100(NAV)
    t = kinematics.leg_table(triangle(), air)
    pts = kinematics.return_home_points(t, air, CALM, None)
    far = pts["distance_m"] > 100.0
    d, h = pts["distance_m"][far], pts["altitude_m"][far]
    v = air.cruise_speed_ms                          # the way home at the cruise speed
    np.testing.assert_allclose(pts["t_back"][far], d / v + v / 2.0 + 2.0 / 1.0)
    high = np.clip(h, 0, None)
    np.testing.assert_allclose(pts["t_down"][far], np.maximum(high - 20.0, 0) / 3.0
                               + np.minimum(high, 20.0) / 1.0)
    plain, _ = m100()
    base = kinematics.return_home_points(kinematics.leg_table(triangle(), plain), plain,
                                         CALM, None)
    assert base["t_down"].max() == pytest.approx(60.0 / plain.descent_rate_ms)
