r"""The navigation of a multirotor fitted from its flight records (:class:`Navigation`).

:func:`fit_navigation` reads how the autopilot flew: the spin-up before lift-off, the
climb and descent rates, the height and rate of the landing's slow stage, the
horizontal acceleration and jerk of its starts from rest, and the dwell at its stops.
Each number is the median over flights (or events) of a per-flight (per-event) measure,
so a gust or a manual correction in a few flights does not move it;
:func:`navigation_measures` gives each number with the count of flights or events it
came from (the fitted :class:`Navigation`'s ``source`` says them too).

The record (:mod:`planner.io.record`): ``experiment``, ``time_s``, ``groundspeed_ms``,
``climb_rate_ms``, ``altitude_m`` (above the take-off point) and ``power_w``. Per flight:

* **spin-up**: from the first sample whose power exceeds :data:`SPINUP_POWER_SHARE` of
  the flight's median airborne power to the lift-off (the altitude first above
  :data:`LIFTOFF_HEIGHT_M`), less the time the fitted climb takes to rise that high
  (:func:`planner.physics.motion.takeoff`'s climb profile);
* **climb rate**: the median climb rate of the vertical climb after lift-off (climb
  rate above :data:`VERTICAL_MIN_MS`, ground speed below :data:`REST_SPEED_MS`);
* **descent**: the final descent is what follows the flight's last horizontal move;
  its rate above and below the slow height is the median descent speed there; the slow
  height is the altitude of the last sample descending faster than halfway between the
  two rates (a flight that never descends fast, say from 25 m, gives only the slow
  rate; when no flight descends fast, the slow rate holds over every height the flights
  came down from, the highest of them the slow height: the slow descent is not
  extrapolated into a fast one the data never showed);
* **vertical acceleration**: from the climb rate's rise, 10 % → 90 % of the climb rate,
  ``0.8 V / Δt``;
* **horizontal acceleration and jerk**: every start from rest at altitude (ground speed
  from below :data:`REST_SPEED_MS` to its plateau ``V``, the median speed above 80 % of
  the move's top): the times from rest to 10 %, 50 % and 90 % of ``V`` are fitted by
  :func:`planner.physics.motion.time_to_speed` (robust least squares, ``soft_l1``);
* **horizontal deceleration and jerk of the stops**: the same fit on every stop, time
  reversed (from the first sample at rest after a move back to 10, 50 and 90 % of its
  ``V``): an autopilot may brake harder than it starts (the DJI M100 does);
* **dwell**: the median length of the rests at altitude between two moves, less the
  part of the two speed ramps below :data:`REST_SPEED_MS` that the profile already
  counts;
* **stops at waypoints**: when the moves end at rest (the count of rests between moves
  is at least :data:`STOP_SHARE` of the moves after the first).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import least_squares

from planner.errors import InputError
from planner.parameters import Navigation
from planner.physics import motion

__all__ = ["NAVIGATION_RECORD_COLUMNS", "fit_navigation", "navigation_measures"]

#: The flight-record columns the fit reads.
NAVIGATION_RECORD_COLUMNS = ("experiment", "time_s", "groundspeed_ms", "climb_rate_ms",
                             "altitude_m", "power_w")

#: Ground speed below which the vehicle is at rest horizontally. [m/s]
REST_SPEED_MS = 0.5
#: Climb or descent speed above which the vehicle is moving vertically. [m/s]
VERTICAL_MIN_MS = 0.5
#: Altitude above the take-off point that counts as airborne. [m]
LIFTOFF_HEIGHT_M = 1.0
#: Share of the median airborne power above which the motors are spinning. [unitless]
SPINUP_POWER_SHARE = 0.2
#: Margin around the slow height left out of the two descent rates. [m]
SLOW_HEIGHT_MARGIN_M = 3.0
#: Least rests per move that make the vehicle one that stops at its waypoints.
STOP_SHARE = 0.5
#: Shortest move, from rest to rest, that counts as a start. [s]
MIN_MOVE_S = 5.0


def _runs(flag):
    """Start and end (exclusive) indices of the runs of True in ``flag``."""
    d = np.diff(np.concatenate(([0], flag.astype(np.int8), [0])))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def _crossing_time(t, x, level, start, end):
    """Time ``x`` first reaches ``level`` in each run from ``start`` to ``end``
    (linear between the samples around the crossing). [s]"""
    out = np.full(len(start), np.nan)
    for k, (a, b, lv) in enumerate(zip(start, end, level)):  # one step per move
        hit = np.flatnonzero(x[a:b] >= lv)
        if not hit.size:
            continue
        i = a + hit[0]
        if i == 0 or x[i] == x[i - 1]:
            out[k] = t[i]
        else:
            out[k] = t[i - 1] + (lv - x[i - 1]) / (x[i] - x[i - 1]) * (t[i] - t[i - 1])
    return out


def _stops(t, gs, a, b, v):
    """The moves' stops at rest, ``(V, t10, t50, t90)`` per move that ends at rest: the
    times from the first sample at rest after the move back to the last time the speed
    was 10, 50 and 90 % of ``V`` — a start from rest with time reversed (the jerk-limited
    profile is the same backwards). [m/s], [s]"""
    n = len(t)
    ends = b < n                                   # the move ends at rest in the record
    if not ends.any():
        return np.zeros((0, 4))
    a, b, v = a[ends], b[ends], v[ends]
    tr, gr = -t[::-1], gs[::-1]
    lead = n - 1 - b                               # the first sample at rest after it
    times = [_crossing_time(tr, gr, q * v, lead, n - a) - tr[lead] for q in (0.1, 0.5, 0.9)]
    return np.column_stack([v, *times])


def _flight(t, gs, vz, alt, p):
    """The per-flight measures (NaN where the flight does not show them), its starts
    from rest and its stops ``(V, t10, t50, t90)`` and its rests between moves [s]."""
    nan = np.nan
    out = {"spinup_s": nan, "climb_rate_ms": nan, "descent_rate_ms": nan,
           "landing_descent_rate_ms": nan, "landing_slow_height_m": nan,
           "slow_descent_top_m": nan,
           "vertical_accel_ms2": nan, "moves": 0, "rests": 0}
    air = alt > LIFTOFF_HEIGHT_M
    if air.sum() < 10:
        return out, np.zeros((0, 4)), np.zeros((0, 4)), np.zeros(0)
    lift = int(np.argmax(air))
    p_air = float(np.median(p[air]))
    on = np.flatnonzero(p[:lift + 1] > SPINUP_POWER_SHARE * p_air)
    if on.size:
        out["spinup_s"] = float(t[lift] - t[on[0]])
    # the flight's moves: runs of ground speed above rest while airborne
    moving = (gs > REST_SPEED_MS) & air
    a, b = _runs(moving)
    long = (t[np.maximum(b - 1, a)] - t[a]) >= MIN_MOVE_S
    a, b = a[long], b[long]
    first_move = a[0] if a.size else len(t)
    last_move = b[-1] if b.size else lift
    # climb: vertical climb between lift-off and the first move
    climb = (np.arange(len(t)) >= lift) & (np.arange(len(t)) < first_move) & \
        (vz > VERTICAL_MIN_MS) & (gs < REST_SPEED_MS * 2)
    if climb.sum() >= 5:
        vc = float(np.median(vz[climb]))
        out["climb_rate_ms"] = vc
        seg = slice(max(lift - 20, 0), first_move)
        tt, zz = t[seg], vz[seg]
        i10 = np.flatnonzero(zz >= 0.1 * vc)
        i90 = np.flatnonzero(zz >= 0.9 * vc)
        if i10.size and i90.size and t[seg][i90[0]] > tt[i10[0]]:
            out["vertical_accel_ms2"] = float(0.8 * vc / (tt[i90[0]] - tt[i10[0]]))
    # final descent: after the last move, airborne, descending
    after = np.arange(len(t)) >= last_move
    desc = after & air & (-vz > VERTICAL_MIN_MS * 0.5)
    if desc.sum() >= 5:
        h, w = alt[desc], -vz[desc]
        top = float(alt[after & air].max())
        fast_guess = np.median(w[h > 0.5 * top]) if (h > 0.5 * top).any() else nan
        slow_guess = np.median(w[h < min(10.0, 0.5 * top)]) if (h < min(10.0, 0.5 * top)).any() \
            else nan
        if np.isfinite(fast_guess) and np.isfinite(slow_guess) and fast_guess > 1.5 * slow_guess:
            mid = 0.5 * (fast_guess + slow_guess)
            fast_idx = np.flatnonzero(w >= mid)
            hs = float(h[fast_idx[-1]])
            out["landing_slow_height_m"] = hs
            hi = h > hs + SLOW_HEIGHT_MARGIN_M
            lo = (h < hs - SLOW_HEIGHT_MARGIN_M) & (h > LIFTOFF_HEIGHT_M)
            if hi.sum() >= 5:
                out["descent_rate_ms"] = float(np.median(w[hi]))
            if lo.sum() >= 5:
                out["landing_descent_rate_ms"] = float(np.median(w[lo]))
        elif np.isfinite(slow_guess):
            out["landing_descent_rate_ms"] = float(np.median(w[h > LIFTOFF_HEIGHT_M]))
            out["slow_descent_top_m"] = top
    # starts from rest: V, times from the move's start to 10, 50 and 90 % of V
    starts = stops = np.zeros((0, 4))
    rests = np.zeros(0)
    if a.size:
        top_speed = np.maximum.reduceat(gs, a)   # rests between moves are slower
        v = np.array([np.median(gs[i:j][gs[i:j] >= 0.8 * m]) for i, j, m in
                      zip(a, b, top_speed)])
        t0 = t[np.maximum(a - 1, 0)]
        lead = np.maximum(a - 1, 0)                 # from the last sample at rest
        times = [_crossing_time(t, gs, q * v, lead, b) - t0 for q in (0.1, 0.5, 0.9)]
        starts = np.column_stack([v, *times])
        stops = _stops(t, gs, a, b, v)
        out["moves"] = int(a.size)
        # rests at altitude between two moves
        gap = t[a[1:]] - t[np.maximum(b[:-1] - 1, 0)]
        between = np.array([np.all(air[j:i]) for j, i in zip(b[:-1], a[1:])], bool)
        rests = gap[between]
        out["rests"] = int(rests.size)
    return out, starts, stops, rests


def navigation_measures(record: pd.DataFrame) -> tuple[dict[str, float], dict[str, int],
                                                       pd.DataFrame]:
    """Each navigation number from the flight records, with the count of flights or events
    it came from, and the per-flight table.

    Returns
    -------
    values : dict of str to float
        The fields of :class:`~planner.parameters.Navigation` (SI; NaN where no flight
        shows it), and ``stop_at_waypoints`` as 0 or 1.
    counts : dict of str to int
        Flights (or starts, rests) each value came from.
    flights : DataFrame
        One row per flight: its measures.

    Raises
    ------
    InputError
        A column missing from the record, or no flight with an airborne part.
    """
    missing = [c for c in NAVIGATION_RECORD_COLUMNS if c not in record.columns]
    if missing:
        raise InputError("the navigation fit needs the flight-record columns "
                         + ", ".join(missing))
    rows, starts, stops, rests = [], [], [], []
    for exp, g in record.groupby("experiment", sort=False):   # one step per flight
        g = g.sort_values("time_s")
        cols = [g[c].to_numpy(float) for c in ("time_s", "groundspeed_ms", "climb_rate_ms",
                                                 "altitude_m", "power_w")]
        m, s, e, r = _flight(*cols)
        rows.append({"experiment": exp, **m})
        starts.append(s)
        stops.append(e)
        rests.append(r)
    flights = pd.DataFrame(rows)

    def usable(parts):
        x = np.concatenate(parts) if parts else np.zeros((0, 4))
        return x[np.all(np.isfinite(x), axis=1) & (x[:, 0] > 2 * REST_SPEED_MS)]

    st, sp = usable(starts), usable(stops)
    rest = np.concatenate(rests) if rests else np.zeros(0)
    if flights.empty or flights["climb_rate_ms"].notna().sum() == 0:
        raise InputError("the navigation fit found no flight that takes off and climbs "
                         f"(altitude above {LIFTOFF_HEIGHT_M:g} m, climb rate above "
                         f"{VERTICAL_MIN_MS:g} m/s)")
    values: dict[str, float] = {}
    counts: dict[str, int] = {}
    for key, col in (("takeoff_spinup_s", "spinup_s"), ("climb_rate_ms", "climb_rate_ms"),
                     ("descent_rate_ms", "descent_rate_ms"),
                     ("landing_slow_height_m", "landing_slow_height_m"),
                     ("landing_descent_rate_ms", "landing_descent_rate_ms"),
                     ("vertical_accel_ms2", "vertical_accel_ms2")):
        x = flights[col].to_numpy(float)
        x = x[np.isfinite(x) & (x >= 0)]
        values[key] = float(np.median(x)) if x.size else np.nan
        counts[key] = int(x.size)
    tops = flights["slow_descent_top_m"].to_numpy(float)
    tops = tops[np.isfinite(tops)]
    if not np.isfinite(values["descent_rate_ms"]) and tops.size and \
            np.isfinite(values["landing_descent_rate_ms"]):
        # no flight descends fast: the slow rate over every height the flights came down from
        values["descent_rate_ms"] = values["landing_descent_rate_ms"]
        values["landing_slow_height_m"] = float(tops.max())
        counts["descent_rate_ms"] = counts["landing_slow_height_m"] = int(tops.size)
    if np.isfinite(values["takeoff_spinup_s"]) and np.isfinite(values["vertical_accel_ms2"]):
        # rising LIFTOFF_HEIGHT_M from rest at the vertical acceleration, then the rate
        vc, az, h = values["climb_rate_ms"], values["vertical_accel_ms2"], LIFTOFF_HEIGHT_M
        rise = np.sqrt(2 * h / az) if h < vc * vc / (2 * az) else vc / (2 * az) + h / vc
        values["takeoff_spinup_s"] = max(values["takeoff_spinup_s"] - float(rise), 0.0)
    a, j = _fit_accel_jerk(st)
    values["horizontal_accel_ms2"], values["horizontal_jerk_ms3"] = a, j
    counts["horizontal_accel_ms2"] = counts["horizontal_jerk_ms3"] = int(len(st))
    ab, jb = _fit_accel_jerk(sp)
    values["horizontal_brake_accel_ms2"], values["horizontal_brake_jerk_ms3"] = ab, jb
    counts["horizontal_brake_accel_ms2"] = counts["horizontal_brake_jerk_ms3"] = int(len(sp))
    moves = int(flights["moves"].sum())
    stops = int(flights["rests"].sum())
    after_first = moves - int((flights["moves"] > 0).sum())
    values["stop_at_waypoints"] = float(after_first > 0 and stops >= STOP_SHARE * after_first)
    counts["stop_at_waypoints"] = after_first
    # the ramps below REST_SPEED_MS at each end are part of the profile already
    if np.isfinite(a) and np.isfinite(j) and rest.size:
        v_typ = np.median(st[:, 0]) if len(st) else 2 * REST_SPEED_MS
        ramp = float(motion.time_to_speed(REST_SPEED_MS, v_typ, a, j))
        brake = (float(motion.time_to_speed(REST_SPEED_MS, v_typ, ab, jb))
                 if np.isfinite(ab) and np.isfinite(jb) else ramp)
        values["waypoint_dwell_s"] = max(float(np.median(rest)) - ramp - brake, 0.0)
    else:
        values["waypoint_dwell_s"] = float(np.median(rest)) if rest.size else 0.0
    counts["waypoint_dwell_s"] = int(rest.size)
    return values, counts, flights


def _fit_accel_jerk(starts: np.ndarray) -> tuple[float, float]:
    """A and J of the starts from rest: the times to 10, 50 and 90 % of V
    (:func:`~planner.physics.motion.time_to_speed` plus a per-start delay: the start
    is seen only from the last sample at rest), robust least squares on log A, log J."""
    if len(starts) < 3:
        return np.nan, np.nan
    v = starts[:, 0]
    t10, t50, t90 = starts[:, 1], starts[:, 2], starts[:, 3]

    def resid(x):
        a, j = np.exp(x)
        m10, m50, m90 = (motion.time_to_speed(q * v, v, a, j) for q in (0.1, 0.5, 0.9))
        # the delay between the last rest sample and the true start cancels in differences
        return np.concatenate([(t50 - t10) - (m50 - m10), (t90 - t50) - (m90 - m50)])

    fit = least_squares(resid, np.log([1.5, 1.0]), loss="soft_l1", f_scale=0.5,
                        bounds=(np.log([0.05, 0.05]), np.log([30.0, 500.0])))
    a, j = np.exp(fit.x)
    return float(a), float(j)


def fit_navigation(record: pd.DataFrame, source: str) -> Navigation:
    """The :class:`~planner.parameters.Navigation` of the vehicle that flew ``record``
    (the module's measures, :func:`navigation_measures`); ``source`` names the data, and
    the returned ``source`` adds each value's count of flights or events.

    Raises
    ------
    InputError
        A column missing, no flight that takes off, or a value no flight shows (the
        message names it).
    """
    values, counts, _ = navigation_measures(record)
    for key in ("horizontal_brake_accel_ms2", "horizontal_brake_jerk_ms3"):
        if not np.isfinite(values[key]):    # no stops: the starts' limits hold for them
            values[key] = None
            counts.pop(key)
    lacking = [k for k, v in values.items() if v is not None and not np.isfinite(v)]
    if lacking:
        raise InputError(f"{source}: the flights do not show the navigation's "
                         + ", ".join(lacking))
    stop = bool(values.pop("stop_at_waypoints"))
    counted = "; ".join(f"{k} from {counts[k]} "
                        + ("stops" if k.startswith("horizontal_brake") else
                           "starts" if k.startswith("horizontal") else
                           "rests" if k == "waypoint_dwell_s" else
                           "moves" if k == "stop_at_waypoints" else "flights")
                        for k in counts)
    return Navigation(**values, stop_at_waypoints=stop,
                      source=f"fitted on {source} (medians; {counted})")
