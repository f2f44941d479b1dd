"""The jerk-limited move, take-off and landing of planner.physics.motion: closed forms
(the seven-segment profile's minimum time, research notes on ArduCopter's SCurve), the
cases and their boundaries, and a numerical integration of the profile."""

import numpy as np
import pytest

from planner.physics.motion import landing, speed_change, straight_move, takeoff, time_to_speed


def integrate(length, v, a, j, dt=1e-4):
    """Brute-force minimum time: bisection on the peak speed of a simulated
    accelerate-cruise-brake profile (constant jerk segments), integrated in time."""
    def ramp(vp):
        # simulate 0 -> vp with limits a, j; return time and distance
        t = d = s = acc = 0.0
        while s < vp - 1e-9:
            # jerk down when the speed left to gain equals what the ramp-down adds
            if s + acc * acc / (2 * j) >= vp:
                acc = max(acc - j * dt, 0.0)
                if acc == 0.0:
                    break
            else:
                acc = min(acc + j * dt, a)
            s += acc * dt
            d += s * dt
            t += dt
        return t, d
    lo, hi = 0.0, v
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        _, d = ramp(mid)
        lo, hi = (mid, hi) if 2 * d <= length else (lo, mid)
    t, d = ramp(lo)
    return 2 * t + (length - 2 * d) / lo


def test_both_limits_reached_closed_form():
    """T = L/V + V/A + A/J when speed and acceleration are reached (ArduCopter 4.1
    defaults V 10, A 2.5, J 1 on a 200 m leg: 26.5 s)."""
    m = straight_move(200.0, 10.0, 2.5, 1.0)
    assert m.time_s == pytest.approx(200 / 10 + 10 / 2.5 + 2.5 / 1.0)
    assert m.peak_speed_ms == pytest.approx(10.0)
    assert m.accel_time_s == pytest.approx(10 / 2.5 + 2.5)
    assert m.accel_mean_speed_ms == pytest.approx(5.0)
    assert m.accel_mean_accel_ms2 == pytest.approx(10 / 6.5)


@pytest.mark.parametrize("length", [65.0 - 1e-6, 40.0, 31.25 + 1e-6])
def test_speed_not_reached_closed_form(length):
    """2A³/J² <= L < V(V/A + A/J): T = A/J + sqrt((A/J)² + 4L/A)."""
    a, j = 2.5, 1.0
    m = straight_move(length, 10.0, a, j)
    assert m.time_s == pytest.approx(a / j + np.sqrt((a / j) ** 2 + 4 * length / a))
    assert m.cruise_time_s == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize("length", [0.1, 5.0, 31.0])
def test_neither_limit_reached_closed_form(length):
    """L < 2A³/J² (31.25 m here): T = 4 (L/(2J))^(1/3)."""
    m = straight_move(length, 10.0, 2.5, 1.0)
    assert m.time_s == pytest.approx(4 * (length / 2.0) ** (1 / 3))


def test_acceleration_never_reached_closed_form():
    """V J < A²: T = L/V + 2 sqrt(V/J) on a long leg (PX4-like A 3, J 1, V 4)."""
    m = straight_move(100.0, 4.0, 3.0, 1.0)
    assert m.time_s == pytest.approx(100 / 4 + 2 * np.sqrt(4.0))


def test_continuous_at_the_case_boundaries():
    """No jump where the formula changes (31.25 m and 65 m for V 10, A 2.5, J 1)."""
    for boundary in (2 * 2.5 ** 3, 10 * (10 / 2.5 + 2.5)):
        t = straight_move(np.array([boundary * (1 - 1e-9), boundary * (1 + 1e-9)]),
                          10.0, 2.5, 1.0).time_s
        assert abs(t[1] - t[0]) < 1e-6


def test_matches_a_numerical_integration():
    for length in (8.0, 40.0, 120.0):
        assert straight_move(length, 6.0, 2.0, 1.5).time_s == pytest.approx(
            integrate(length, 6.0, 2.0, 1.5), rel=2e-3)


def test_rest_to_speed_and_speed_to_rest_are_half_a_profile():
    """From cruise speed to rest costs half the stop-and-go overhead (V/A + A/J)/2."""
    up = straight_move(200.0, 5.0, 3.0, 4.0, start_speed=5.0)
    down = straight_move(200.0, 5.0, 3.0, 4.0, end_speed=5.0)
    half = 0.5 * (5 / 3 + 3 / 4)
    assert up.time_s == pytest.approx(200 / 5 + half)
    assert down.time_s == pytest.approx(200 / 5 + half)
    assert up.accel_time_s == 0.0 and down.brake_time_s == 0.0


def test_distances_add_up_and_vectorised():
    L = np.linspace(0.5, 400.0, 50)
    m = straight_move(L, 8.0, 2.0, 1.0)
    np.testing.assert_allclose(m.accel_distance_m + m.cruise_distance_m + m.brake_distance_m, L)
    assert np.all(np.diff(m.time_s) > 0)
    assert np.all(m.time_s >= L / 8.0)


def test_infinite_jerk_is_the_trapezoid():
    assert straight_move(100.0, 5.0, 1.0, np.inf).time_s == pytest.approx(100 / 5 + 5 / 1)
    assert straight_move(9.0, 5.0, 1.0, np.inf).time_s == pytest.approx(2 * np.sqrt(9.0))


def test_speed_change_and_time_to_speed_agree():
    t, d = speed_change(0.0, 8.0, 2.0, 1.0)
    assert t == pytest.approx(8 / 2 + 2 / 1) and d == pytest.approx(4.0 * t)
    assert time_to_speed(8.0, 8.0, 2.0, 1.0) == pytest.approx(t)
    assert time_to_speed(4.0, 8.0, 2.0, 1.0) == pytest.approx(t / 2)   # symmetric ramp
    u = np.linspace(0, 8, 33)
    assert np.all(np.diff(time_to_speed(u, 8.0, 2.0, 1.0)) > 0)


def test_takeoff_and_landing():
    """Climb H/V + V/A with a spin-up; landing at 3 m/s to 20 m, then 1 m/s."""
    spin, climb = takeoff(100.0, 3.0, 1.0, 5.0)
    assert spin == 5.0 and climb == pytest.approx(100 / 3 + 3 / 1)
    fast, slow = landing(100.0, 3.0, 20.0, 1.0)
    assert fast == pytest.approx(80 / 3) and slow == pytest.approx(20.0)
    fast, slow = landing(10.0, 3.0, 20.0, 1.0)          # below the slow height
    assert fast == 0.0 and slow == pytest.approx(10.0)


def test_a_harder_brake_shortens_the_move_by_the_difference_of_the_two_ramps():
    """With its own deceleration and jerk limits, a rest-to-rest move that reaches its
    speed takes the start's ramp at (A, J), the stop's at (A_b, J_b) and the rest at V:
    T = L/V + (V/A + A/J)/2 + (V/A_b + A_b/J_b)/2 (each ramp covers V times half its
    time); the brake's time is its own, and the default (no brake limits) is the
    symmetric move."""
    L, V, A, J, Ab, Jb = 300.0, 10.0, 2.0, 1.6, 3.8, 3.0
    m = straight_move(L, V, A, J, brake_accel=Ab, brake_jerk=Jb)
    expected = L / V + 0.5 * (V / A + A / J) + 0.5 * (V / Ab + Ab / Jb)
    assert float(m.time_s) == pytest.approx(expected, rel=1e-9)
    assert float(m.brake_time_s) == pytest.approx(V / Ab + Ab / Jb, rel=1e-9)
    assert float(m.accel_time_s) == pytest.approx(V / A + A / J, rel=1e-9)
    assert float(m.accel_distance_m + m.cruise_distance_m + m.brake_distance_m) == \
        pytest.approx(L)
    same = straight_move(L, V, A, J, brake_accel=A, brake_jerk=J)
    assert float(same.time_s) == pytest.approx(float(straight_move(L, V, A, J).time_s))


def test_a_short_move_with_a_harder_brake_peaks_where_its_two_ramps_fill_the_leg():
    """A leg too short to reach V: the peak speed is where the start's ramp (A, J) and
    the stop's (A_b, J_b) together cover the leg, higher than with the symmetric brake,
    and the move is quicker."""
    L, V, A, J, Ab, Jb = 20.0, 12.0, 2.0, 1.6, 3.8, 3.0
    m = straight_move(L, V, A, J, brake_accel=Ab, brake_jerk=Jb)
    peak = float(m.peak_speed_ms)
    _, d1 = speed_change(0.0, peak, A, J)
    _, d3 = speed_change(peak, 0.0, Ab, Jb)
    assert float(d1 + d3) == pytest.approx(L, rel=1e-6)
    assert float(m.cruise_time_s) == pytest.approx(0.0, abs=1e-6)
    sym = straight_move(L, V, A, J)
    assert peak > float(sym.peak_speed_ms)
    assert float(m.time_s) < float(sym.time_s)
