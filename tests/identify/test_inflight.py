"""The in-flight estimator: what it learns, what it predicts, and what it survives.

The flights are simulated by the project's own models (tests/helpers/watch_flights.py):
these tests check that the estimator recovers what the simulation put in — a pack whose
capacity differs from its label, a power model off by a known factor — and that its
predictions agree with the mission chain that the pre-flight check uses.
"""

import math
from dataclasses import replace

import numpy as np
import pytest
from watch_flights import flight_events, hover_mission, solo

from planner.chain.mission_chain import MissionChain
from planner.identify.inflight import (
    PX4_AVRG_CURRENT_A,
    PX4_FILTER_TAU_S,
    InflightEstimator,
    OcvCurve,
    WatchSettings,
    px4_filter_alpha,
)
from planner.io.mavlink_mission import remaining_from_legs
from planner.io.mavlink_stream import Event
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.mission import Environment, Leg, Mission

TRUE_CAPACITY = 4000.0      # the simulated pack; its label says 5200 mAh


@pytest.fixture(scope="module")
def hover(tmp_path_factory):
    """A 20-min hover of the Solo with a 4000 mAh pack labelled 5200 mAh."""
    aircraft, true_pack = solo(TRUE_CAPACITY)
    rec, events = flight_events(tmp_path_factory.mktemp("hover"), hover_mission(1200.0),
                                aircraft, true_pack, rate_hz=1.0, seed=3)
    return aircraft, rec, events


def _run(events, est, marks):
    out = {}
    marks = list(marks)
    for ev in events:
        est.feed(ev)
        while marks and est.t >= marks[0]:
            out[marks.pop(0)] = est.predict()
    return out


def test_an_unknown_capacity_is_learnt_from_the_voltage(hover):
    aircraft, rec, events = hover
    _, label = solo()
    est = InflightEstimator(aircraft, label, settings=WatchSettings(capacity_known=False))
    preds = _run(events, est, [900.0])
    cap = preds[900.0]
    assert cap["capacity_mah"] == pytest.approx(TRUE_CAPACITY, rel=0.10)
    assert cap["capacity_mah_p5"] < TRUE_CAPACITY < cap["capacity_mah_p95"]
    # the label alone (5200) would be 30 % off
    assert abs(cap["capacity_mah"] - TRUE_CAPACITY) < 0.5 * abs(5200 - TRUE_CAPACITY)


def test_the_time_to_the_reserve_tightens_and_holds_the_truth(hover):
    aircraft, rec, events = hover
    _, label = solo()
    reserve = 0.2
    q_res = (1 - reserve) * TRUE_CAPACITY
    t_res = float(np.interp(q_res, rec["consumed_mah"], rec["time_s"]))
    est = InflightEstimator(aircraft, label, settings=WatchSettings(capacity_known=False,
                                                                    reserve=reserve))
    preds = _run(events, est, [200.0, 500.0, 800.0])
    widths = []
    for t, p in preds.items():
        truth = t_res - p["time_s"]
        assert p["time_to_reserve_p5_s"] <= truth <= p["time_to_reserve_p95_s"], (t, truth, p)
        widths.append(p["time_to_reserve_p95_s"] - p["time_to_reserve_p5_s"])
    assert widths[-1] < widths[0] / 2


def test_a_power_model_off_by_a_factor_is_rescaled_in_flight(tmp_path):
    aircraft, pack = solo()
    true_aircraft = replace(aircraft, efficiency=aircraft.efficiency / 1.25)
    rec, events = flight_events(tmp_path, hover_mission(300.0), true_aircraft, pack,
                                rate_hz=2.0, seed=5)
    est = InflightEstimator(aircraft, pack)
    _run(events, est, [])
    p = est.predict()
    # hover power above the system load scales with 1/efficiency; the system load does not
    assert 1.18 < p["power_scale"] < 1.27
    assert est.k.sd < 0.05


def test_the_px4_baseline_follows_px4s_alpha_filter():
    assert px4_filter_alpha(1.0) == pytest.approx(1.0 / 51.0)
    aircraft, pack = solo()
    est = InflightEstimator(aircraft, pack)
    est.feed(Event("state", 0.0, (True, "AUTO", "multirotor", 3)))
    i_avg = PX4_AVRG_CURRENT_A
    t = 0.0
    for k in range(200):
        est.feed(Event("battery", t, (16.0, 8.0, math.nan, math.nan)))
        if k:
            i_avg += 0.5 / (0.5 + PX4_FILTER_TAU_S) * (8.0 - i_avg)
        t += 0.5
    assert est.px4_i == pytest.approx(i_avg, rel=1e-9)
    assert 8.0 < est.px4_i < 8.0 + 7.0 * math.exp(-99.5 / 50.5) * 1.01


def test_a_silent_link_ages_the_estimate(hover):
    aircraft, rec, events = hover
    _, label = solo()
    est = InflightEstimator(aircraft, label)
    _run([e for e in events if e.time_s <= 400.0], est, [])
    fresh = est.predict()
    aged = est.predict(est.t + 60.0)
    assert not fresh["stale"] and aged["stale"] and aged["link_age_s"] == pytest.approx(60.0)
    assert aged["time_to_reserve_s"] == pytest.approx(fresh["time_to_reserve_s"] - 60.0, abs=3)
    drawn = fresh["charge_above_reserve_mah"] - aged["charge_above_reserve_mah"]
    assert drawn == pytest.approx(fresh["current_a"] * 60.0 / 3.6, rel=0.1)


def test_a_reboot_keeps_the_charge_counted_before_it(hover):
    aircraft, rec, events = hover
    _, label = solo()
    est = InflightEstimator(aircraft, label)
    before = [e for e in events if e.time_s <= 300.0]
    _run(before, est, [])
    q_before = est.q_now
    est.feed(Event("reboot", 5.0, ()))
    # the autopilot's counter starts again from 0 after its reboot
    est.feed(Event("battery", 5.5, (rec["voltage_v"].iloc[301], rec["current_a"].iloc[301],
                                    0.0, math.nan)))
    est.feed(Event("battery", 6.5, (rec["voltage_v"].iloc[302], rec["current_a"].iloc[302],
                                    4.0, math.nan)))
    assert est.q_now == pytest.approx(q_before + 4.0, abs=0.5)
    assert est.reboots == 1 and est.predict()["time_to_reserve_s"] > 0


def test_damaged_and_impossible_values_are_dropped_not_learnt(hover):
    aircraft, rec, events = hover
    _, label = solo()
    clean = InflightEstimator(aircraft, label)
    dirty = InflightEstimator(aircraft, label)
    t0 = events[399].time_s
    bad = [Event("battery", t0, (1e9, 5.0, 10.0, 0.5)),
           Event("battery", t0, (0.001, 5.0, 10.0, 0.5)),            # a voltage jump
           Event("position", t0, (95.0, 0.0, 10.0, 10.0, 0, 0, 0)),
           Event("hud", t0, (1e12, 1.0, 0.0, 0.5)),
           Event("wind", t0, (float("inf"), 0.0, math.nan)),
           Event("battery", t0 - 90.0, (15.0, 10.0, 1.0, 0.5))]      # 90 s out of order
    for ev in events[:400]:
        clean.feed(ev)
        dirty.feed(ev)
    for ev in bad:
        dirty.feed(ev)
    for ev in events[400:800]:
        clean.feed(ev)
        dirty.feed(ev)
    a, b = clean.predict(), dirty.predict()
    assert dirty.rejected == 5 and dirty.dropped == 1 and clean.rejected == 0
    for key in ("time_to_reserve_s", "charge_above_reserve_mah", "power_scale",
                "capacity_mah"):
        assert b[key] == pytest.approx(a[key], rel=1e-9), key


def test_before_any_battery_sample_the_prediction_is_empty_not_an_error():
    aircraft, pack = solo()
    est = InflightEstimator(aircraft, pack)
    est.feed(Event("state", 0.0, (False, "STABILIZE", "multirotor", 3)))
    p = est.predict()
    assert p["time_to_reserve_s"] is None and p["link_age_s"] is None


def test_the_rest_of_the_mission_costs_what_the_chain_says_for_a_fresh_pack():
    """At take-off (a full pack), the rest of the mission costs the mission chain's own
    charge: the in-flight conversion of the chain's fresh-pack charges is exact there."""
    aircraft, pack = solo()
    m = Mission("square", [
        Leg("climb", start_alt_m=0, end_alt_m=30, origin="a"),
        Leg("cruise", start_en_m=(0, 0), end_en_m=(600, 0), start_alt_m=30, end_alt_m=30,
            origin="b"),
        Leg("cruise", start_en_m=(600, 0), end_en_m=(600, 600), start_alt_m=30, end_alt_m=30,
            origin="c"),
        Leg("cruise", start_en_m=(600, 600), end_en_m=(0, 0), start_alt_m=30, end_alt_m=30,
            origin="d"),
        Leg("descend", start_alt_m=30, end_alt_m=0, origin="e")], Environment())
    est = InflightEstimator(aircraft, pack, mission=m, settings=WatchSettings(samples=40))
    est.feed(Event("state", 0.0, (True, "AUTO", "multirotor", 3)))
    est.feed(Event("battery", 0.0, (16.8, 0.2, 0.0, 1.0)))
    est.feed(Event("local", 0.0, (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)))
    est.feed(Event("wind", 0.0, (0.0, 0.0, 0.0)))      # calm, as the chain flies it
    p = est.predict()
    chain = MissionChain(aircraft, pack, battery_model="integral", reserve=0.0)
    fresh = chain.run(m, Environment(), detail=False).charge_used_mah[0]
    assert p["mission_remaining_mah"] == pytest.approx(fresh, rel=0.03)
    # the return from home, on the ground: nothing but a touch
    assert p["return_home_mah"] < 5


def test_the_return_becomes_due_before_the_charge_to_get_home_runs_out():
    aircraft, pack = solo()
    far = Mission("out", [Leg("cruise", start_en_m=(0, 0), end_en_m=(20000, 0),
                              start_alt_m=30, end_alt_m=30, origin="out"),
                          Leg("descend", start_en_m=(20000, 0), end_en_m=(20000, 0),
                              start_alt_m=30, end_alt_m=0, origin="land")], Environment())
    est = InflightEstimator(aircraft, pack, mission=far, settings=WatchSettings(samples=40))
    est.feed(Event("state", 0.0, (True, "AUTO", "multirotor", 3)))
    est.feed(Event("battery", 0.0, (16.6, 15.0, 0.0, 1.0)))
    est.feed(Event("local", 0.0, (0.0, 0.0, 30.0, 0.0, 8.0, 0.0)))
    p = est.predict()
    assert p["landing_margin_mah"] < 0                  # the far end cannot be reached
    assert p["point_of_no_return_in_s"] is not None and not p["return_due"]
    pnr = p["point_of_no_return_in_s"]
    # fly out at 8 m/s to just past the median point of no return
    t = pnr + 30.0
    east = 8.0 * t
    drawn = 15.0 * t / 3.6
    est.feed(Event("battery", t, (15.2, 15.0, drawn, math.nan)))
    est.feed(Event("local", t, (east, 0.0, 30.0, 0.0, 8.0, 0.0)))
    later = est.predict()
    assert later["return_due"]
    assert later["return_home_mah"] > later["charge_above_reserve_mah_p5"]


def test_the_curve_inverse_is_the_curve_read_backwards():
    c = OcvCurve(lipo_ocv)
    s = np.linspace(0.02, 0.98, 49)
    assert np.allclose(c.soc(lipo_ocv(s)), s, atol=2e-3)


def test_a_legs_mission_is_followed_forward_as_the_aircraft_flies():
    m = Mission("line", [Leg("cruise", start_en_m=(0, 0), end_en_m=(1000, 0), start_alt_m=30,
                             end_alt_m=30, origin="a"),
                         Leg("cruise", start_en_m=(1000, 0), end_en_m=(0, 0), start_alt_m=30,
                             end_alt_m=30, origin="b")], Environment())
    rest, j = remaining_from_legs(m, (800.0, 0.0), 30.0, 0)
    assert j == 0 and rest.legs[0].distance_m == pytest.approx(200.0)
    rest, j = remaining_from_legs(m, (800.0, 0.0), 30.0, 1)   # on the way back
    assert j == 1 and rest.legs[0].distance_m == pytest.approx(800.0)


def _px4_estimator(params):
    aircraft, pack = solo()
    est = InflightEstimator(aircraft, replace(pack, cells_series=6, model=None),
                            settings=WatchSettings(reserve_firmware="px4-critical"))
    for name, value in params.items():
        est.feed(Event("param", 0.0, (name, value)))
    est.feed(Event("state", 0.0, (True, "POSCTL", "multirotor", 12)))
    est.feed(Event("hud", 0.0, (0.0, 0.0, 0.0, 0.7)))
    est.feed(Event("battery", 0.0, (22.0, 7.5, 0.0, 0.5)))
    est.theta[2] = 0.09
    return est


def test_px4s_critical_level_follows_its_code_with_the_vehicles_parameters():
    """PX4 v1.11 battery.cpp: cell voltage + V_LOAD_DROP × throttle (R_INTERNAL < 0), linear
    between V_EMPTY and V_CHARGED; critical below CRIT_THR. The loaded cell voltage there
    plus our sag I R / N is the level's open-circuit voltage."""
    est = _px4_estimator({"BAT_V_EMPTY": 3.6, "BAT_V_CHARGED": 4.2, "BAT_CRIT_THR": 0.07,
                          "BAT_V_LOAD_DROP": 0.3, "BAT_R_INTERNAL": -1.0})
    ocv = 3.6 + 0.07 * 0.6 - 0.3 * 0.7 + 7.5 * 0.09 / 6
    assert est.firmware_level_soc("px4-critical") == pytest.approx(
        float(est.curve.soc(ocv)), abs=1e-9)
    assert est.firmware_reserve() == pytest.approx(0.07)
    # with BAT_R_INTERNAL set, the compensation is R_INTERNAL × current instead
    est2 = _px4_estimator({"BAT_V_EMPTY": 3.6, "BAT_V_CHARGED": 4.2, "BAT_CRIT_THR": 0.07,
                           "BAT_R_INTERNAL": 0.01})
    ocv2 = 3.6 + 0.07 * 0.6 - 0.01 * 7.5 + 7.5 * 0.09 / 6
    assert est2.firmware_level_soc("px4-critical") == pytest.approx(
        float(est2.curve.soc(ocv2)), abs=1e-9)
    # the low level lies above the critical one
    assert est.firmware_level_soc("px4-low") > est.firmware_level_soc("px4-critical")


def test_the_descent_is_part_of_the_charge_to_landing():
    aircraft, pack = solo()
    est = InflightEstimator(aircraft, pack)
    est.feed(Event("state", 0.0, (True, "AUTO", "multirotor", 3)))
    for k in range(120):
        t = float(k)
        est.feed(Event("battery", t, (16.0, 14.0, 14.0 * t / 3.6, math.nan)))
        est.feed(Event("local", t, (0.0, 0.0, 60.0, 0.0, 0.0, 0.0)))
    with_landing = est.horizon_charge(100.0)
    without = est.horizon_charge(100.0, land=False)
    # 60 m at 1.5 m/s: the last 40 s descend, which costs less than hovering
    assert with_landing["p50"] < without["p50"]
    assert without["p50"] == pytest.approx(14.0 * 100 / 3.6, rel=0.15)
