r"""How a multirotor's autopilot flies a straight move, a take-off and a landing.

Pure, vectorised functions (numpy broadcasting; SI units) of the kinematic model of a
vehicle's navigation:

* :func:`speed_change` — a jerk-limited change of speed (constant jerk ``J`` up to the
  acceleration limit ``A``, then constant ``A``, then constant ``-J``): the ramps of
  ArduCopter's S-curves (``libraries/AP_Math/SCurve.cpp``, ``SCurve::calculate_path``,
  whose jerk is at most ``WPNAV_JERK``, ``libraries/AC_WPNav/AC_WPNav.cpp``
  ``calc_scurve_jerk_and_snap``) and of PX4's ``VelocitySmoothing``
  (``src/lib/motion_planning/VelocitySmoothing.cpp``: phases T1 jerk, T2 acceleration,
  T3 jerk; limits ``MPC_ACC_HOR``, ``MPC_JERK_AUTO``,
  ``src/modules/mc_pos_control/multicopter_autonomous_params.c``);
* :func:`straight_move` — the minimum-time move over a distance ``L`` with limits
  ``V``, ``A``, ``J``, from a start speed to an end speed (rest-to-rest, rest-to-speed,
  speed-to-rest): its time, its peak speed and its three phases (accelerating,
  cruising, braking) with each phase's time-weighted mean speed and acceleration;
* :func:`takeoff` — the spin-up on the ground, then the climb with a vertical
  acceleration limit (ArduCopter ``WPNAV_SPEED_UP``, ``WPNAV_ACCEL_Z``; PX4
  ``MPC_Z_V_AUTO_UP``, ``MPC_TKO_SPEED``, ``FlightTaskAuto.cpp``);
* :func:`landing` — the descent at one rate down to a height, then at a slower rate
  (ArduCopter ``LAND_SPEED`` below ``LAND_ALT_LOW``, ``ArduCopter/config.h`` and
  ``ArduCopter/Parameters.cpp``; PX4 ``MPC_LAND_SPEED`` below ``MPC_LAND_ALT2``,
  ``FlightTaskAuto.cpp``).

The rest-to-rest minimum time (the constant-jerk seven-segment profile) is, with
:math:`VJ \ge A^2` (the acceleration limit is reached before the speed limit):

.. math::

    T = \begin{cases}
        L/V + V/A + A/J & L \ge V (V/A + A/J) \\
        A/J + \sqrt{(A/J)^2 + 4L/A} & 2A^3/J^2 \le L < V(V/A + A/J) \\
        4 \sqrt[3]{L/(2J)} & L < 2A^3/J^2
    \end{cases}

and with :math:`VJ < A^2`: :math:`T = L/V + 2\sqrt{V/J}` when
:math:`L \ge 2V\sqrt{V/J}`, else :math:`4\sqrt[3]{L/(2J)}`. ArduCopter's S-curve is
snap-limited too (raised-cosine jerk pulses), so its legs take a little longer than this
lower bound. An infinite jerk gives the trapezoidal profile (``T = L/V + V/A``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Move", "landing", "speed_change", "straight_move", "takeoff", "time_to_speed"]

#: Bisection steps of the peak speed of a move between two non-zero speeds (each halves
#: the bracket: 60 steps reach the float resolution).
PEAK_BISECTION_STEPS = 60


def _ratio(a, j):
    """``a / j`` with an infinite jerk giving 0."""
    a, j = np.asarray(a, float), np.asarray(j, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.isinf(j), 0.0, a / j)


def speed_change(v_from, v_to, accel, jerk):
    """Time and distance of a jerk-limited change of speed from ``v_from`` to ``v_to``.

    The speed change :math:`\\Delta v = |v_{to} - v_{from}|` takes
    :math:`\\Delta v/A + A/J` when the acceleration limit is reached
    (:math:`\\Delta v \\ge A^2/J`), else :math:`2\\sqrt{\\Delta v/J}`; the profile is
    point-symmetric about its middle, so its distance is the time times the mean of the
    two speeds.

    Parameters
    ----------
    v_from, v_to : array_like
        Speeds at the start and end (>= 0). [m/s]
    accel : array_like
        Acceleration limit A (> 0). [m/s²]
    jerk : array_like
        Jerk limit J (> 0; ``inf``: a trapezoidal profile). [m/s³]

    Returns
    -------
    time_s, distance_m : ndarray
    """
    dv = np.abs(np.asarray(v_to, float) - np.asarray(v_from, float))
    a = np.asarray(accel, float)
    a_over_j = _ratio(a, jerk)
    reached = dv >= a * a_over_j
    with np.errstate(divide="ignore", invalid="ignore"):
        t_short = np.where(np.isinf(np.asarray(jerk, float)), 0.0,
                           2.0 * np.sqrt(dv / np.asarray(jerk, float)))
    t = np.where(reached, dv / a + a_over_j, t_short)
    t = np.where(dv > 0.0, t, 0.0)
    return t, t * 0.5 * (np.asarray(v_from, float) + np.asarray(v_to, float))


def time_to_speed(u, speed, accel, jerk):
    r"""Time a jerk-limited start from rest to ``speed`` takes to reach the speed ``u``.

    With the acceleration limit reached (:math:`V \ge A^2/J`): :math:`\sqrt{2u/J}` up to
    :math:`A^2/(2J)`, then :math:`A/J + (u - A^2/(2J))/A` up to :math:`V - A^2/(2J)`, then
    :math:`T - \sqrt{2(V - u)/J}` with :math:`T = V/A + A/J`; else (peak acceleration
    :math:`\sqrt{VJ}`): :math:`\sqrt{2u/J}` up to :math:`V/2`, then
    :math:`2\sqrt{V/J} - \sqrt{2(V - u)/J}`. The inverse of the ramp of
    :func:`speed_change`, for fitting ``A`` and ``J`` to measured starts.

    Parameters
    ----------
    u : array_like
        Speed reached (0 <= u <= speed). [m/s]
    speed, accel, jerk : array_like
        V [m/s], A [m/s²], J [m/s³] (finite).

    Returns
    -------
    ndarray
        [s]
    """
    u, V, A, J = np.broadcast_arrays(*(np.asarray(x, float) for x in (u, speed, accel, jerk)))
    u = np.clip(u, 0.0, V)
    reached = V >= A * A / J
    v1 = np.where(reached, 0.5 * A * A / J, 0.5 * V)
    total = np.where(reached, V / A + A / J, 2.0 * np.sqrt(V / J))
    first = np.sqrt(2.0 * u / J)
    middle = A / J + (u - v1) / A
    last = total - np.sqrt(2.0 * np.maximum(V - u, 0.0) / J)
    return np.where(u <= v1, first, np.where(reached & (u <= V - v1), middle, last))


def _rest_to_rest_peak(length, speed, accel, jerk):
    """Peak speed of the minimum-time rest-to-rest move (closed form). [m/s]"""
    L, A = np.asarray(length, float), np.asarray(accel, float)
    a_over_j = _ratio(A, jerk)
    # acceleration reached: v²/A + v A/J = L
    v_long = 0.5 * (-A * a_over_j + np.sqrt((A * a_over_j) ** 2 + 4.0 * A * L))
    # acceleration not reached: 2 v^{3/2} / √J = L
    with np.errstate(invalid="ignore", over="ignore"):
        v_short = np.cbrt((0.5 * L) ** 2 * np.asarray(jerk, float))
    v_peak = np.where(L >= 2.0 * A * a_over_j ** 2, v_long, v_short)
    return np.minimum(np.asarray(speed, float), v_peak)


@dataclass(frozen=True)
class Move:
    """A straight move as an autopilot flies it (:func:`straight_move`), arrays.

    Attributes
    ----------
    time_s : ndarray
        Whole move. [s]
    peak_speed_ms : ndarray
        Highest speed reached (the speed limit when the move is long enough). [m/s]
    accel_time_s, cruise_time_s, brake_time_s : ndarray
        The phases: speeding up to the peak, at the peak, slowing to the end speed. [s]
    accel_distance_m, cruise_distance_m, brake_distance_m : ndarray
        [m]
    accel_mean_speed_ms, brake_mean_speed_ms : ndarray
        Time-weighted mean speed of the accelerating and braking phases (the mean of the
        phase's two speeds: the jerk-limited ramp is point-symmetric). [m/s]
    accel_mean_accel_ms2, brake_mean_accel_ms2 : ndarray
        Time-weighted mean magnitude of the acceleration of those phases
        (speed change over time; 0 for an empty phase). [m/s²]
    """

    time_s: np.ndarray
    peak_speed_ms: np.ndarray
    accel_time_s: np.ndarray
    cruise_time_s: np.ndarray
    brake_time_s: np.ndarray
    accel_distance_m: np.ndarray
    cruise_distance_m: np.ndarray
    brake_distance_m: np.ndarray
    accel_mean_speed_ms: np.ndarray
    brake_mean_speed_ms: np.ndarray
    accel_mean_accel_ms2: np.ndarray
    brake_mean_accel_ms2: np.ndarray


def straight_move(length, speed, accel, jerk, start_speed=0.0, end_speed=0.0,
                  brake_accel=None, brake_jerk=None) -> Move:
    """The minimum-time jerk-limited straight move (see the module's formulas).

    Parameters
    ----------
    length : array_like
        Distance along the straight line (>= 0). [m]
    speed : array_like
        Speed limit V (> 0): the commanded speed. [m/s]
    accel : array_like
        Acceleration limit A (> 0; ArduCopter ``WPNAV_ACCEL``, PX4 ``MPC_ACC_HOR``). [m/s²]
    jerk : array_like
        Jerk limit J (> 0, ``inf`` for none; ``WPNAV_JERK``, ``MPC_JERK_AUTO``). [m/s³]
    start_speed, end_speed : array_like, default 0
        Speeds at the ends (0: from or to rest; at most ``speed``). A move too short to
        change from one to the other is flown at the mean of the two. [m/s]
    brake_accel, brake_jerk : array_like, optional
        Limits of the slowing down where they differ from the speeding up (a DJI M100
        brakes harder than it starts: :data:`planner.parameters.aircraft.NAVIGATION_DEFAULTS`);
        default ``accel`` and ``jerk``. [m/s²], [m/s³]

    Returns
    -------
    Move
        All fields broadcast to the shape of the inputs.
    """
    L, V, A, J, v0, v1, Ab, Jb = np.broadcast_arrays(*(np.asarray(x, float) for x in (
        length, speed, accel, jerk, start_speed, end_speed,
        accel if brake_accel is None else brake_accel,
        jerk if brake_jerk is None else brake_jerk)))
    v0, v1 = np.minimum(v0, V), np.minimum(v1, V)
    rest = (v0 == 0.0) & (v1 == 0.0)
    symmetric = (Ab == A) & (Jb == J)
    one_limit = bool(np.all(symmetric))

    def change(a, b):       # a change to a lower speed is a braking: the brake's limits
        t_up, d_up = speed_change(a, b, A, J)
        if one_limit:
            return t_up, d_up
        t_dn, d_dn = speed_change(a, b, Ab, Jb)
        up = b >= a
        return np.where(up, t_up, t_dn), np.where(up, d_up, d_dn)

    # general ends: bisection on the peak speed between max(v0, v1) and V
    lo = np.maximum(v0, v1)
    hi = V.copy()
    _, d_lo1 = change(v0, lo)
    _, d_lo2 = change(lo, v1)
    too_short = (d_lo1 + d_lo2) >= L        # not even the change of speed fits
    for _ in range(PEAK_BISECTION_STEPS):
        mid = 0.5 * (lo + hi)
        _, d1 = change(v0, mid)
        _, d2 = change(mid, v1)
        over = (d1 + d2) > L
        hi = np.where(over, mid, hi)
        lo = np.where(over, lo, mid)
    _, d1 = change(v0, V)
    _, d2 = change(V, v1)
    peak = np.where((d1 + d2) <= L, V, lo)
    peak = np.where(rest & symmetric, _rest_to_rest_peak(L, V, A, J), peak)
    peak = np.where(too_short & ~rest, np.maximum(v0, v1), peak)
    t1, d1 = change(v0, peak)
    t3, d3 = change(peak, v1)
    d_cruise = np.maximum(L - d1 - d3, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t2 = np.where(peak > 0.0, d_cruise / peak, 0.0)
        # a move too short for its change of speed: flown at the mean of the two speeds
        mean_ends = 0.5 * (v0 + v1)
        t_short = np.where(mean_ends > 0.0, L / mean_ends, 0.0)
    short = too_short & ~rest
    t1, t3, t2 = (np.where(short, 0.0, t1), np.where(short, 0.0, t3),
                  np.where(short, t_short, t2))
    d1, d3 = np.where(short, 0.0, d1), np.where(short, 0.0, d3)
    d_cruise = np.where(short, L, d_cruise)
    with np.errstate(divide="ignore", invalid="ignore"):
        a1 = np.where(t1 > 0.0, np.abs(peak - v0) / t1, 0.0)
        a3 = np.where(t3 > 0.0, np.abs(peak - v1) / t3, 0.0)
    return Move(time_s=t1 + t2 + t3, peak_speed_ms=np.where(short, mean_ends, peak),
                accel_time_s=t1, cruise_time_s=t2, brake_time_s=t3,
                accel_distance_m=d1, cruise_distance_m=d_cruise, brake_distance_m=d3,
                accel_mean_speed_ms=0.5 * (v0 + peak), brake_mean_speed_ms=0.5 * (peak + v1),
                accel_mean_accel_ms2=a1, brake_mean_accel_ms2=a3)


def takeoff(height, climb_rate, vertical_accel, spinup_s=0.0):
    """Time of a take-off: the spin-up on the ground, then a rest-to-rest climb.

    The climb is a trapezoidal vertical move (acceleration ``vertical_accel`` up to
    ``climb_rate`` and back to rest: :math:`H/V_z + V_z/A_z` when the climb rate is
    reached, else :math:`2\\sqrt{H/A_z}`), as ArduCopter's ``WPNAV_SPEED_UP`` and
    ``WPNAV_ACCEL_Z`` or PX4's ``MPC_Z_V_AUTO_UP`` with its acceleration limit
    (``FlightTaskAuto.cpp``, ``_getMaxZSpeed``: the arrival speed is 0).

    Parameters
    ----------
    height : array_like
        Climb above the ground. [m]
    climb_rate : array_like
        [m/s]
    vertical_accel : array_like
        (``inf``: the climb rate at once). [m/s²]
    spinup_s : array_like, default 0
        Motors turning on the ground before lift-off. [s]

    Returns
    -------
    spinup_s, climb_s : ndarray
    """
    move = straight_move(height, climb_rate, vertical_accel, np.inf)
    spin = np.broadcast_to(np.asarray(spinup_s, float), np.shape(move.time_s)).copy()
    return spin, move.time_s


def landing(height, descent_rate, slow_height, slow_rate):
    """Times of a two-rate landing: at ``descent_rate`` down to ``slow_height`` above the
    ground, then at ``slow_rate`` to the ground (ArduCopter: ``LAND_SPEED_HIGH`` or
    ``WPNAV_SPEED_DN``, then ``LAND_SPEED`` below ``LAND_ALT_LOW``; PX4: the auto descent
    speed, then ``MPC_LAND_SPEED`` below ``MPC_LAND_ALT2``).

    Parameters
    ----------
    height : array_like
        Height above the ground at the start of the descent. [m]
    descent_rate, slow_rate : array_like
        Descent speeds (> 0). [m/s]
    slow_height : array_like
        Height below which the slow rate is flown. [m]

    Returns
    -------
    fast_s, slow_s : ndarray
        Time at each rate. [s]
    """
    h = np.maximum(np.asarray(height, float), 0.0)
    low = np.minimum(h, np.asarray(slow_height, float))
    return (h - low) / np.asarray(descent_rate, float), low / np.asarray(slow_rate, float)
