"""fit_navigation (planner.identify.navigation_fit): known parameters recovered from
flight records built from the navigation profile (planner.physics.motion), and the real
DJI M100 flights' climb and descent rates."""

import numpy as np
import pandas as pd
import pytest

from planner.errors import InputError
from planner.identify.navigation_fit import fit_navigation, navigation_measures

DT = 0.1
TRUE = dict(spinup=5.0, climb=3.0, az=1.0, descent=3.0, slow_h=20.0, slow=1.0, A=2.0, J=1.0,
            dwell=2.0)


def ramp(v, a, j):
    """Acceleration samples of a jerk-limited 0 → v ramp (v >= a²/j)."""
    tj, ta = a / j, v / a - a / j
    up = np.arange(0, tj, DT) * j
    return np.concatenate([up, np.full(int(round(ta / DT)), a), up[::-1]])


def flight(name, v, sides, alt=60.0, p=TRUE):
    """A flight record: idle, spin-up, climb (trapezoid), rest-to-rest moves with dwells,
    two-rate descent."""
    n_idle, n_spin = 30, int(round(p["spinup"] / DT))
    # climb: vertical acceleration to the climb rate, rate, and braking to rest
    ru = np.full(int(round(p["climb"] / p["az"] / DT)), p["az"])
    t_const = (alt - p["climb"] ** 2 / p["az"]) / p["climb"]
    az = np.concatenate([ru, np.zeros(int(round(t_const / DT))), -ru])
    vz_climb = np.cumsum(az) * DT
    gs, vz = [np.zeros(n_idle + n_spin), vz_climb], [np.zeros(n_idle + n_spin), vz_climb]
    gs[1] = np.zeros_like(vz_climb)
    r = ramp(v, p["A"], p["J"])
    ab, jb = p.get("Ab", p["A"]), p.get("Jb", p["J"])
    rb = ramp(v, ab, jb)
    for L in sides:
        d_ramps = 0.5 * v * (v / p["A"] + p["A"] / p["J"] + v / ab + ab / jb)
        acc = np.concatenate([r, np.zeros(int(round((L - d_ramps) / v / DT))), -rb])
        speed = np.clip(np.cumsum(acc) * DT, 0, None)
        n_dwell = int(round(p["dwell"] / DT))
        gs += [speed, np.zeros(n_dwell)]
        vz += [np.zeros(len(speed)), np.zeros(n_dwell)]
    fast = int(round((alt - p["slow_h"]) / p["descent"] / DT))
    slow = int(round(p["slow_h"] / p["slow"] / DT))
    vz += [np.full(fast, -p["descent"]), np.full(slow, -p["slow"]), np.zeros(30)]
    gs += [np.zeros(fast + slow + 30)]
    gs, vz = np.concatenate(gs), np.concatenate(vz)
    altitude = np.concatenate([[0.0], np.cumsum(vz[:-1]) * DT])
    power = np.where(np.arange(len(gs)) < n_idle, 2.0, 500.0)
    power[-30:] = 2.0
    return pd.DataFrame({"experiment": name, "time_s": np.arange(len(gs)) * DT,
                         "groundspeed_ms": gs, "climb_rate_ms": vz, "altitude_m": altitude,
                         "power_w": power})


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(3)
    return pd.concat([flight(f"f{k}", v, rng.uniform(120, 400, 3))
                      for k, v in enumerate([4.0, 6.0, 8.0, 10.0, 12.0, 6.0])],
                     ignore_index=True)


def test_recovers_known_parameters(record):
    nav = fit_navigation(record, "built flights")
    assert nav.climb_rate_ms == pytest.approx(3.0, rel=0.01)
    assert nav.descent_rate_ms == pytest.approx(3.0, rel=0.01)
    assert nav.landing_descent_rate_ms == pytest.approx(1.0, rel=0.01)
    assert nav.landing_slow_height_m == pytest.approx(20.0, abs=0.5)
    assert nav.vertical_accel_ms2 == pytest.approx(1.0, rel=0.1)
    assert nav.takeoff_spinup_s == pytest.approx(5.0, abs=0.3)
    assert nav.horizontal_accel_ms2 == pytest.approx(2.0, rel=0.05)
    assert nav.horizontal_jerk_ms3 == pytest.approx(1.0, rel=0.1)
    assert nav.waypoint_dwell_s == pytest.approx(2.0, abs=0.3)
    assert nav.stop_at_waypoints is True
    assert "6 flights" in nav.source and "18 starts" in nav.source
    # it stops as it starts
    assert nav.horizontal_brake_accel_ms2 == pytest.approx(2.0, rel=0.05)
    assert nav.horizontal_brake_jerk_ms3 == pytest.approx(1.0, rel=0.1)


def test_a_vehicle_that_brakes_harder_than_it_starts():
    """Moves that start at A = 2 m/s², J = 1 m/s³ and stop at 3.5 m/s², 3.5 m/s³ (as the
    DJI M100 brakes about twice as hard as it starts): the stops, read time reversed,
    give the brake's limits, the starts keep theirs, and the dwell between moves is
    still the hover alone."""
    hard = dict(TRUE, Ab=3.5, Jb=3.5)
    rng = np.random.default_rng(7)
    rec = pd.concat([flight(f"f{k}", v, rng.uniform(120, 400, 3), p=hard)
                     for k, v in enumerate([4.0, 6.0, 8.0, 10.0, 12.0, 6.0])],
                    ignore_index=True)
    nav = fit_navigation(rec, "built flights")
    assert nav.horizontal_brake_accel_ms2 == pytest.approx(3.5, rel=0.1)
    # the jerk within 20 %: its phases last 1 s here, ten samples of the built ramp
    assert nav.horizontal_brake_jerk_ms3 == pytest.approx(3.5, rel=0.2)
    assert nav.horizontal_accel_ms2 == pytest.approx(2.0, rel=0.05)
    assert nav.waypoint_dwell_s == pytest.approx(2.0, abs=0.3)
    assert "18 stops" in nav.source


def test_flights_that_never_descend_fast_give_a_slow_descent_from_their_height():
    """Flights at 18 m whose whole descent is slow (from their altitude down): the
    fit keeps the slow rate over every height they came down from, and does not invent a
    fast rate the data never showed."""
    low = dict(TRUE, slow_h=18.0)
    rng = np.random.default_rng(5)
    rec = pd.concat([flight(f"f{k}", v, rng.uniform(120, 300, 3), alt=18.0, p=low)
                     for k, v in enumerate([4.0, 6.0, 8.0, 10.0])], ignore_index=True)
    nav = fit_navigation(rec, "low flights")
    assert nav.landing_descent_rate_ms == pytest.approx(1.0, rel=0.02)
    assert nav.descent_rate_ms == nav.landing_descent_rate_ms
    assert nav.landing_slow_height_m == pytest.approx(18.0, abs=1.0)


def test_counts_name_flights_and_events(record):
    values, counts, flights = navigation_measures(record)
    assert len(flights) == 6
    assert counts["climb_rate_ms"] == 6 and counts["horizontal_accel_ms2"] == 18
    assert counts["waypoint_dwell_s"] == 12          # two rests between three moves


def test_a_record_without_a_take_off_is_refused(record):
    with pytest.raises(InputError, match="takes off"):
        fit_navigation(record.assign(altitude_m=0.0), "ground tests")
    with pytest.raises(InputError, match="power_w"):
        fit_navigation(record.drop(columns="power_w"), "no power")


def test_real_m100_climb_and_descent(shared_data):
    """DJI M100 flights of Rodrigues et al. (Sci. Data 8, 155, 2021), route R1 of flights
    1-149: the climb ≈ 2.9 m/s and the descent ≈ 3 m/s of the design notes (median
    2.94 m/s climb, 2.7-3.0 m/s descent above ~20 m, 1.0 m/s below). Tolerance 0.25 m/s:
    the per-flight medians spread over 2.5-3.0 m/s (descent inter-quartile range), and the
    fit's own choice of the fast band (from 3 m above the slow height, where the vehicle
    is still speeding up) lowers the descent by up to 0.2 m/s."""
    from planner.io.flightdata import load_flight_data
    energy = shared_data / "energy"
    par = pd.read_csv(energy / "m100_parameters.csv")
    r1 = {str(f) for f in par.flight[par.route == "R1"]}
    data, _ = load_flight_data(energy / "m100_flights_part1_flights001-149.csv.gz",
                               column_map="dji_m100")
    nav = fit_navigation(data[data.experiment.astype(str).isin(r1)], "M100 R1")
    assert nav.climb_rate_ms == pytest.approx(2.9, abs=0.25)
    assert nav.descent_rate_ms == pytest.approx(3.0, abs=0.25)
    assert nav.landing_descent_rate_ms == pytest.approx(1.0, abs=0.1)
    assert nav.stop_at_waypoints is True
    assert 1.0 < nav.horizontal_accel_ms2 < 4.0
    # it brakes harder than it starts (3.8 against 2.0 m/s² on the 182 R1 flights)
    assert nav.horizontal_brake_accel_ms2 > 1.4 * nav.horizontal_accel_ms2
