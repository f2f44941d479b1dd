"""Waypoint route -> mission legs: the one conversion every waypoint format shares.

A route is a list of :class:`RouteStep` (take off, fly to a waypoint, fly an arc, hold,
loiter, loiter to an altitude, change speed, return to launch, land). The YAML
``waypoints:`` form builds steps directly; QGroundControl ``.plan`` and Mission Planner
``.waypoints`` files are first read into MAVLink mission items (:class:`MavItem`), which
:func:`fly_mav_items` flies as the firmware does: :func:`expand_jumps` unrolls
``DO_JUMP`` and ``DO_JUMP_TAG``, :func:`mav_items_to_steps` turns the items into steps,
and :func:`route_to_legs` flies the steps from home and emits
:class:`~planner.physics.mission.Leg` objects, so the same route gives the same legs
whatever file it came from.

How each command is flown (the firmware source followed is named)
-----------------------------------------------------------------
- ``NAV_TAKEOFF`` / ``NAV_VTOL_TAKEOFF``: a vertical climb from the current position to
  the take-off altitude; the item's latitude/longitude is not flown to.
- A navigation item whose latitude and longitude are both 0 (or unset: NaN, ``null`` in
  a ``.plan``) means "the current position"; if its relative altitude is also 0, the
  current altitude is kept (ArduCopter ``ModeAuto::loc_from_cmd``).
- ``NAV_WAYPOINT`` / ``NAV_SPLINE_WAYPOINT``: a cruise to the point, then param1 seconds of
  hover (ignored by ArduPlane). A waypoint less than :data:`MIN_CRUISE_M` away
  horizontally is a ``climb``/``descend`` (or nothing if the altitude does not change).
- A cruise climbs or descends no faster than the aircraft can: where the file asks for
  more (a waypoint high above a near one), the leg is split into the cruise at the
  aircraft's climb (or descent) rate and, at the point, the rest of the climb (ArduCopter
  limits each axis of the waypoint leg, ``AC_WPNav`` ``WPNAV_SPEED_UP``/``_DN``, and
  finishes a ``LOITER_TO_ALT`` climb over the point, ``ModeAuto::loiter_to_alt_run``;
  ArduPlane reaches the point low and climbs on). This needs the aircraft's rates
  (:class:`~planner.physics.mission.NavDefaults`, or ``DO_CHANGE_SPEED`` types 2 and 3).
- ``NAV_ARC_WAYPOINT`` (36): a circular arc in the east/north plane from the current
  position to the point, param1 degrees of central angle (positive clockwise; more than
  360° is a helix), the altitude changing linearly (MAVLink ``common.xml``; ArduCopter
  4.7, autotest ``WPArcs``), flown as straight pieces of at most :data:`ARC_STEP_DEG`
  (their length is within 0.03 % of the arc's), a multirotor's speed held to
  ``sqrt(ACCEL_C · radius)`` with ``ACCEL_C`` = 2 ``WPNAV_ACCEL`` (``SCurve.cpp``). Its
  first implementation put the angle in param2 (ArduPilot's ``ArcWPMissionTest.txt``
  before it moved to param1): a param2 angle is read when param1 is 0. ArduPlane has no
  case for it in ``start_command``, so ``AP_Mission`` skips it: a fixed-wing aircraft flies
  straight on to the next item.
- ``NAV_LOITER_TIME``: a multirotor hovers over the point (ArduCopter
  ``ModeAuto::do_loiter_time`` re-uses the unlimited loiter, a position hold); a fixed-wing
  aircraft circles at its own loiter radius (ArduPlane ``verify_loiter_time``: "mission
  radius is always aparm.loiter_radius"; PX4 fixed-wing: param3).
- ``NAV_LOITER_TURNS``: param1 turns of radius \\|param3\\| (0: the aircraft's own). A
  multirotor circles at ArduCopter's circle rate (``AC_Circle``: ``CIRCLE_RATE`` 20 deg/s,
  the speed capped at ``min(WPNAV_SPEED, sqrt(0.5 · WPNAV_ACCEL · radius))``), a
  fixed-wing aircraft at the speed in force (or its cruise speed).
- ``NAV_LOITER_TO_ALT``: flies to the point, then climbs or descends over it (a fixed-wing
  aircraft circling at radius \\|param2\\|).
- ``NAV_RETURN_TO_LAUNCH`` flies home at the current altitude, then descends to 0.
  ArduPilot's ``RTL_ALT`` (climb to a minimum return altitude first) and
  ``RTL_LOIT_TIME`` are autopilot parameters, not mission items, and are ignored.
- ``NAV_LAND`` / ``NAV_VTOL_LAND`` with a position flies there at the current altitude
  first; without one it descends where the aircraft is. On PX4 a mission goes on after
  a landing amid it (the commander does not disarm while the mission is not finished,
  and the navigator inserts a take-off before the next item with a position: a
  land-and-continue delivery); on ArduPilot the copter disarms on landing
  (``ModeAuto::verify_land``) and the items after it are not flown (with a warning).
- A mission that starts on the ground with an item other than a take-off climbs
  vertically at home to that item's altitude first, as PX4's navigator inserts a
  take-off; ArduCopter refuses to start such a mission on the ground ("Auto: Missing
  Takeoff Cmd", ``ModeAuto::init``), which is said in a warning.
- ``DO_JUMP`` and ``DO_JUMP_TAG`` are expanded as ``AP_Mission`` flies them: each jump item
  keeps its own counter for the whole mission, a repeat count of 0 is never followed,
  -1 repeats for ever (refused: the mission has no end); a jump to a tag goes to the
  first ``JUMP_TAG`` with it, and a jump to a missing tag ends the mission (MAVLink
  ``MAV_CMD_DO_JUMP_TAG``); at most :data:`MAX_JUMPS` jumps in all.
- ``DO_CHANGE_SPEED``: a multirotor's speed types 0 and 1 are both its ground speed
  (ArduCopter ``set_speed_NE``; PX4 ``set_cruising_speed``); ArduPlane takes type 0 as
  the airspeed and type 1 as its minimum ground speed (``MIN_GROUNDSPEED``, not a target:
  ignored here), and ignores types 2 and 3; -2 returns to the default speed.
- ``climb``, ``descend`` and ``hover`` legs carry no horizontal speed
  (``speed_ms=None``); ``cruise`` and ``loiter`` legs carry the speed in force.
- Legs are straight lines in the leg frame of :mod:`planner.physics.geo`: a leg to,
  from or through home has its great-circle length at any range; any other
  leg must stay within about :data:`~planner.physics.geo.FRAME_ERROR_KM` of
  home, where the frame is within :data:`MAX_FRAME_ERROR` of the great circle.

Bounds on input
---------------
- A hold, a timed loiter or a loiter in turns lasts at most :data:`MAX_HOLD_S`
  (24 h: beyond any battery-powered flight, so a larger value is a typing
  error; it also keeps the mission's time series, sampled every second by the
  check, to a size that fits in memory), and so do all the holds of a mission
  together (``DO_JUMP`` repeats included);
- a loiter has at most :data:`MAX_LOITER_TURNS` turns (ArduPilot stores the
  turns of ``NAV_LOITER_TURNS`` in one byte, ``AP_Mission``);
- hold times are >= 0; latitudes, longitudes and altitudes are finite;
- no navigation item lies below home unless the file says the ground is lower there
  (a terrain frame): PX4 refuses a waypoint below home (``MissionFeasibilityChecker::
  checkHomePositionAltitude``, "Waypoint below home"), and an absolute altitude below
  the take-off point is a file written for another site;
- every altitude, as height above mean sea level (the site altitude plus the
  altitude above home), lies in the range of the atmosphere model,
  :data:`planner.physics.atmosphere.ALTITUDE_RANGE_M`, checked here so that the
  message names the file, the item and the value as written.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from planner.physics.atmosphere import ALTITUDE_RANGE_M
from planner.errors import InputError
from planner.physics.geo import (FRAME_ERROR_KM, aeqd_to_latlon, frame_error,
                                 great_circle_distance, latlon_to_aeqd)
from planner.physics.mission import Leg, NavDefaults
from planner.physics.limits import SPEED_MAX_MS

#: Horizontal distance below which a waypoint is a vertical move. [m]
MIN_CRUISE_M = 0.5
#: Altitude change below which a vertical move is dropped. [m]
MIN_ALT_CHANGE_M = 0.01
#: Most DO_JUMP jumps expanded in one mission.
MAX_JUMPS = 100
#: Longest single hold, timed loiter or loiter in turns (24 h). [s]
MAX_HOLD_S = 86400.0
#: Fastest speed a mission may ask for: the aircraft files' bound. [m/s]
MAX_SPEED_MS = SPEED_MAX_MS
#: Most turns of one loiter (ArduPilot keeps them in one byte). [unitless]
MAX_LOITER_TURNS = 255
#: Largest relative error of a leg's length in the local frame (0.1 %). [unitless]
MAX_FRAME_ERROR = 1e-3
#: Largest central angle of one straight piece of an arc waypoint: the pieces are
#: shorter than the arc by 1 - sin(2.5°)/2.5° = 0.03 %. [deg]
ARC_STEP_DEG = 5.0
#: Most central angle of one arc waypoint (20 turns of a helix). [deg]
MAX_ARC_DEG = 7200.0
#: A home further than this from a leg is "on another continent" in the messages. [km]
FAR_HOME_KM = 1000.0
#: A waypoint this far from home whose latitude and longitude, swapped, lie within
#: :data:`SWAP_NEAR_KM` of home was written with the two swapped. [km]
SWAP_FAR_KM = 100.0
#: See :data:`SWAP_FAR_KM`. [km]
SWAP_NEAR_KM = 20.0

ACTIONS = ("takeoff", "waypoint", "arc", "hold", "loiter", "loiter_to_alt", "rtl", "land",
           "speed", "climb_rate", "descent_rate")

#: The speeds in force: horizontal speed, whether it is an airspeed, climb and descent
#: rates (``None``: the aircraft's default).
SpeedState = tuple


def hold_problem(value: float, what: str = "hold time") -> str | None:
    """Why a hold or loiter duration is not accepted, or ``None``.

    Parameters
    ----------
    value : float
        The duration as written. [s]
    what : str
        Its name in the message.

    Returns
    -------
    str or None
        E.g. ``"hold time 1e+308 s is out of range (expected 0 to 86400 s, 24 h)"``.
    """
    if math.isfinite(value) and 0.0 <= value <= MAX_HOLD_S:
        return None
    return (f"{what} {value:g} s is out of range (expected 0 to {MAX_HOLD_S:g} s, "
            f"{MAX_HOLD_S / 3600:g} h)")


def total_hold_problem(legs: list[Leg]) -> tuple[str, str] | None:
    """Where and why the holds of a mission add up to more than :data:`MAX_HOLD_S`.

    Parameters
    ----------
    legs : list of Leg

    Returns
    -------
    (origin, message) or None
        The origin of the ``hover``/``loiter`` leg at which the running total
        first passes the bound, and the message; ``None`` if it never does.
    """
    total = 0.0
    for leg in legs:
        if leg.kind in ("hover", "loiter") and leg.duration_s:
            total += leg.duration_s
            if total > MAX_HOLD_S:
                return leg.origin, (f"the holds and loiters of the mission add up to "
                                    f"{total:g} s here (expected at most {MAX_HOLD_S:g} s, "
                                    f"{MAX_HOLD_S / 3600:g} h, in all, DO_JUMP repeats "
                                    "included)")
    return None


def altitude_problem(alt_m: float, site_alt_amsl_m: float) -> str | None:
    """Why an altitude above home is outside the atmosphere model, or ``None``.

    Parameters
    ----------
    alt_m : float
        Altitude above home. [m]
    site_alt_amsl_m : float
        Altitude of home above mean sea level. [m]

    Returns
    -------
    str or None
        The height above mean sea level and the range of
        :data:`planner.physics.atmosphere.ALTITUDE_RANGE_M`, as heights above home too.
    """
    lo, hi = ALTITUDE_RANGE_M
    amsl = site_alt_amsl_m + alt_m
    if not math.isfinite(amsl):
        return f"is {alt_m!r} (expected a finite number)"
    if lo <= amsl <= hi:
        return None
    return (f"puts the aircraft at {amsl:g} m above mean sea level (home at "
            f"{site_alt_amsl_m:g} m AMSL), outside the atmosphere model (expected "
            f"{lo:g} to {hi:g} m AMSL, i.e. {lo - site_alt_amsl_m:g} to "
            f"{hi - site_alt_amsl_m:g} m above home)")


@dataclass(frozen=True)
class RouteStep:
    """One step of a waypoint route.

    Attributes
    ----------
    action : str
        One of :data:`ACTIONS`.
    lat_deg, lon_deg : float or None
        Target position (``waypoint``, ``arc``, ``loiter``, ``loiter_to_alt``, ``land``);
        ``None`` = the current position. [deg]
    alt_m : float or None
        Target altitude above home (``takeoff``, ``waypoint``, ``arc``, ``loiter``,
        ``loiter_to_alt``); ``None`` = the current altitude. [m]
    hold_s : float or None
        Hold time at a ``waypoint``. [s]
    duration_s : float or None
        Duration of a ``hold`` or timed ``loiter``. [s]
    turns : float or None
        Turns of a ``loiter`` (instead of a duration).
    radius_m : float or None
        Loiter radius (``None``: the aircraft's own: a multirotor hovers through a
        timed loiter, a fixed-wing aircraft circles at its loiter radius). [m]
    speed_ms : float or None
        New speed (``speed``; ``None`` = back to the aircraft's default), or the new climb
        or descent rate (``climb_rate``, ``descent_rate``). [m/s]
    speed_is_airspeed : bool or None
        Kind of a ``speed`` (see :class:`~planner.physics.mission.Leg`).
    origin : str
        Where the step came from, for messages.
    item : int or None
        Index of the mission item the step flies (copied to its legs' ``item``).
    angle_deg : float or None
        Central angle of an ``arc``, positive clockwise. [deg]
    fly_on : bool
        A ``land`` after which the mission goes on (PX4 land-and-continue).
    """

    action: str
    lat_deg: float | None = None
    lon_deg: float | None = None
    alt_m: float | None = None
    hold_s: float | None = None
    duration_s: float | None = None
    turns: float | None = None
    radius_m: float | None = None
    speed_ms: float | None = None
    speed_is_airspeed: bool | None = None
    origin: str = ""
    item: int | None = None
    angle_deg: float | None = None
    fly_on: bool = False


def circle_speed(radius_m: float, speed_ms: float, defaults: NavDefaults | None) -> float:
    """Ground speed of a multirotor circling in a ``LOITER_TURNS``. [m/s]

    ArduCopter's ``AC_Circle``: the angular rate is ``CIRCLE_RATE``, capped so that the
    speed stays within ``min(WPNAV_SPEED, sqrt(0.5 · WPNAV_ACCEL · radius))``
    (``AC_Circle::calc_velocities``)::

        velocity_max = MIN(_pos_control.get_max_speed_xy(),
                           safe_sqrt(0.5f*_pos_control.get_max_accel_xy()*_radius));

    Parameters
    ----------
    radius_m : float
        Circle radius. [m]
    speed_ms : float
        The horizontal speed in force (``WPNAV_SPEED`` or a ``DO_CHANGE_SPEED``). [m/s]
    defaults : NavDefaults or None
        Circle rate and acceleration (ArduCopter's defaults without it).
    """
    d = defaults or NavDefaults("multirotor", speed_ms, 1.0, 1.0)
    omega = math.radians(abs(d.circle_rate_dps))
    return min(omega * radius_m, speed_ms, math.sqrt(0.5 * d.accel_ms2 * radius_m))


def arc_center(start: tuple[float, float], end: tuple[float, float],
               angle_deg: float) -> tuple[float, float] | None:
    """Centre of the circular arc from ``start`` to ``end`` turning ``angle_deg`` clockwise
    (east/north, metres), or ``None`` when no circle joins them (a whole number of
    turns between two distinct points)."""
    phi = -math.radians(angle_deg)                  # clockwise: negative in east/north
    c, s = math.cos(phi), math.sin(phi)
    # end - C = R(phi) (start - C)  =>  (I - R) C = end - R start
    a11, a12, a21, a22 = 1.0 - c, s, -s, 1.0 - c
    det = a11 * a22 - a12 * a21
    if abs(det) < 1e-9:
        return None
    bx = end[0] - (c * start[0] - s * start[1])
    by = end[1] - (s * start[0] + c * start[1])
    return ((a22 * bx - a12 * by) / det, (a11 * by - a21 * bx) / det)


def _check_swapped(steps, lat, lon, east, north, home_lat: float, home_lon: float,
                   where: str) -> None:
    """A waypoint more than :data:`SWAP_FAR_KM` from home whose coordinates, swapped, lie
    within :data:`SWAP_NEAR_KM` of it (or of the other waypoints) had its latitude and
    longitude swapped: an error naming the item."""
    with np.errstate(invalid="ignore"):
        far = np.hypot(east, north) > SWAP_FAR_KM * 1e3
    if not far.any():
        return
    ok = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lon) <= 90.0)
    for i in np.flatnonzero(far & ok):
        e, n = latlon_to_aeqd(lon[i], lat[i], home_lat, home_lon)
        near = float(np.hypot(e, n))
        if near <= SWAP_NEAR_KM * 1e3:
            d = float(np.hypot(east[i], north[i]))
            raise InputError(
                f"{where}: {steps[i].origin}: ({lat[i]:.6g}, {lon[i]:.6g}) is {d / 1e3:.0f} km "
                f"from home ({home_lat:.6g}, {home_lon:.6g}): latitude and longitude swapped? "
                f"({lon[i]:.6g}, {lat[i]:.6g}) is {near / 1e3:.2g} km from home")
    if far[np.isfinite(east)].all() and abs(home_lon) <= 90.0:
        # every point far from home: the home itself may be the swapped one
        e, n = latlon_to_aeqd(lat, lon, home_lon, home_lat)
        with np.errstate(invalid="ignore"):
            if np.nanmedian(np.hypot(e, n)) <= SWAP_NEAR_KM * 1e3:
                raise InputError(
                    f"{where}: home ({home_lat:.6g}, {home_lon:.6g}) is "
                    f"{float(np.nanmin(np.hypot(east, north))) / 1e3:.0f} km from every "
                    f"waypoint: latitude and longitude swapped? ({home_lon:.6g}, "
                    f"{home_lat:.6g}) is among them")


def _check_speeds(steps, defaults: NavDefaults | None, where: str) -> None:
    """A mission speed above the aircraft's maximum airspeed that is within it in km/h was
    typed in km/h: an error naming the item."""
    top = defaults.max_speed_ms if defaults is not None else None
    if not top:
        return
    for step in steps:
        v = step.speed_ms
        if step.action == "speed" and v is not None and v > top and v / 3.6 <= top:
            raise InputError(f"{where}: {step.origin}: speed {v:g} m/s is above the "
                             f"aircraft's maximum airspeed {top:g} m/s: km/h? ({v:g} km/h = "
                             f"{v / 3.6:.3g} m/s); expected m/s")


class _RouteFlight:
    """The aircraft flying a route from home: where it is, the speeds in force, the legs so
    far. Each step's action is one method (:data:`_STEP_ACTIONS`), chosen by name."""

    def __init__(self, home_ll: tuple[float, float], *, where: str,
                 speed_ms: float | None, speed_is_airspeed: bool | None,
                 defaults: NavDefaults | None, vehicle: str | None, climb_first: bool,
                 states: dict[int, SpeedState] | None):
        self.home_ll = home_ll
        self.where = where
        self.defaults = defaults
        self.vehicle = vehicle
        self.climb_first = climb_first
        self.states = states
        self.legs: list[Leg] = []
        self.pos = (0.0, 0.0)
        self.here = (home_ll, "home")   # (latitude, longitude) of pos, and where it came from
        self.alt = 0.0
        self.speed_ms = speed_ms
        self.speed_is_airspeed = speed_is_airspeed
        self.climb_rate: float | None = None
        self.descent_rate: float | None = None
        self.on_ground = True
        self.item: int | None = None
        self.warned: set[str] = set()

    def warn_once(self, key: str, message: str) -> None:
        if key not in self.warned:
            self.warned.add(key)
            warnings.warn(message, stacklevel=4)

    # ---------------------------------------------------------------- the moves

    def vertical(self, target_alt: float, origin: str, radius: float | None = None) -> None:
        """Climb or descend where the aircraft is (nothing below :data:`MIN_ALT_CHANGE_M`)."""
        if abs(target_alt - self.alt) < MIN_ALT_CHANGE_M:
            return
        kind = "climb" if target_alt > self.alt else "descend"
        rate = self.climb_rate if kind == "climb" else self.descent_rate
        self.legs.append(Leg(kind, start_en_m=self.pos, end_en_m=self.pos,
                             start_alt_m=self.alt, end_alt_m=target_alt, climb_rate_ms=rate,
                             loiter_radius_m=radius, origin=origin, item=self.item))
        self.alt = target_alt
        self.on_ground = self.on_ground and self.alt <= MIN_ALT_CHANGE_M

    def hover(self, duration_s: float, origin: str) -> None:
        """Hold the position for ``duration_s``. [s]"""
        self.legs.append(Leg("hover", start_en_m=self.pos, end_en_m=self.pos,
                             start_alt_m=self.alt, end_alt_m=self.alt,
                             duration_s=float(duration_s), origin=origin, item=self.item))

    def check_frame(self, start: tuple[float, float], end: tuple[float, float], origin: str,
                    start_origin: str) -> None:
        """Refuse a leg the flat frame about home misstates by more than
        :data:`MAX_FRAME_ERROR` (module notes)."""
        home_ll = self.home_ll
        err = frame_error(*start, *end, *home_ll)
        if err <= MAX_FRAME_ERROR:
            return
        length = great_circle_distance(*start, *end)
        far = max(great_circle_distance(*home_ll, *start), great_circle_distance(*home_ll, *end))
        note = ""
        if far > FAR_HOME_KM * 1e3:
            note = (f"; the file's home ({home_ll[0]:.5f}, {home_ll[1]:.5f}) is on another "
                    "continent from its route: the home the file gives is not where the "
                    "mission is flown (ArduPilot replaces it with the vehicle's home at "
                    "upload, AP_Mission::write_home_to_storage)")
        raise InputError(
            f"{self.where}: {origin}: the {length / 1e3:.0f} km leg from {start_origin} reaches "
            f"{far / 1e3:.0f} km from home without passing through it, where the planner's "
            f"flat frame about home misstates its length by {err:.2%} (expected legs within "
            f"about {FRAME_ERROR_KM:g} km of home, or straight to or from home, error at most "
            f"{MAX_FRAME_ERROR:.1%}; plan far-apart legs from a nearer home){note}")

    def limits(self, speed: float | None) -> tuple[float | None, float | None, float | None]:
        """Horizontal speed, climb and descent rates in force (None: unknown). [m/s]"""
        d = self.defaults
        v = speed or self.speed_ms or (d.cruise_speed_ms if d else None)
        up = self.climb_rate or (d.climb_rate_ms if d else None)
        down = self.descent_rate or (d.descent_rate_ms if d else None)
        return v, up, down

    def move(self, target: tuple[float, float], target_alt: float, origin: str,
             target_ll: tuple[float, float], *, speed: float | None = None,
             level: bool = False, radius: float | None = None) -> None:
        """Fly to ``target`` at ``target_alt``: a cruise, climbing no faster than the
        aircraft can (the rest of the climb over the point; ArduCopter ``AC_WPNav``
        ``WPNAV_SPEED_UP``/``_DN``); ``level``: when the rates are unknown, cruise at the
        current altitude and climb over the point."""
        dist = math.hypot(target[0] - self.pos[0], target[1] - self.pos[1])
        if dist < MIN_CRUISE_M:
            self.vertical(target_alt, origin, radius)
            return
        if self.on_ground and self.climb_first and target_alt > self.alt + MIN_ALT_CHANGE_M:
            if not self.legs:
                self.warn_once("takeoff", f"{self.where}: {origin}: the mission does not start "
                               "with a take-off: flown with a vertical climb at home to the "
                               "item's altitude, as PX4 inserts a take-off (ArduCopter refuses "
                               "to start it on the ground: 'Auto: Missing Takeoff Cmd')")
            self.vertical(target_alt, origin)
        # within a quarter of FRAME_ERROR_KM of home the frame error is below 1/16 of
        # the limit (it grows as r²): skip the exact test for the usual short missions
        if max(math.hypot(*self.pos), math.hypot(*target)) > 250.0 * FRAME_ERROR_KM:
            self.check_frame(self.here[0], target_ll, origin, self.here[1])
        mid = self.cruise_end_altitude(dist, target_alt, speed, level)
        self.legs.append(Leg("cruise", start_en_m=self.pos, end_en_m=target,
                             start_alt_m=self.alt, end_alt_m=mid,
                             speed_ms=speed if speed is not None else self.speed_ms,
                             speed_is_airspeed=(False if speed is not None
                                                else self.speed_is_airspeed),
                             origin=origin, item=self.item))
        self.pos, self.alt, self.here = target, mid, (target_ll, origin)
        self.on_ground = False
        self.vertical(target_alt, origin, radius)

    def cruise_end_altitude(self, dist: float, target_alt: float, speed: float | None,
                            level: bool) -> float:
        """Altitude at the end of a cruise of ``dist`` metres towards ``target_alt``: the
        target, unless the climb or descent rate in force cannot reach it over the cruise
        (the rest is flown over the point). [m]"""
        dz = target_alt - self.alt
        v, up, down = self.limits(speed)
        rate = up if dz > 0 else down
        if v and rate and abs(dz) > rate * dist / v + MIN_ALT_CHANGE_M:
            return self.alt + math.copysign(rate * dist / v, dz)
        if level and not (v and rate):
            return self.alt
        return target_alt

    def arc(self, target: tuple[float, float], target_alt: float, origin: str,
            target_ll: tuple[float, float], angle_deg: float) -> None:
        """An arc of ``angle_deg`` to ``target``, flown as straight pieces of at most
        :data:`ARC_STEP_DEG`, a multirotor's speed held to ``sqrt(ACCEL_C · radius)``
        (ArduCopter ``SCurve.cpp``; module notes)."""
        start = self.pos
        dist = math.hypot(target[0] - start[0], target[1] - start[1])
        center = arc_center(start, target, angle_deg) if angle_deg else None
        if dist < MIN_CRUISE_M or center is None:
            if dist >= MIN_CRUISE_M and angle_deg:
                self.warn_once(f"arc{origin}", f"{self.where}: {origin}: an arc of "
                               f"{angle_deg:g}° cannot join two distinct points (a whole "
                               "number of turns): flown straight")
            self.move(target, target_alt, origin, target_ll)
            return
        radius = math.hypot(start[0] - center[0], start[1] - center[1])
        v, _, _ = self.limits(None)
        speed = None
        if self.vehicle == "multirotor" and v:
            accel_c = 2.0 * (self.defaults.accel_ms2 if self.defaults else NavDefaults(
                "multirotor", v, 1.0, 1.0).accel_ms2)
            if math.sqrt(accel_c * radius) < v:
                speed = math.sqrt(accel_c * radius)
        n = max(1, math.ceil(abs(angle_deg) / ARC_STEP_DEG))
        alt0 = self.alt
        rel = (start[0] - center[0], start[1] - center[1])
        for k in range(1, n + 1):
            if k == n:
                point, point_ll = target, target_ll
            else:
                phi = -math.radians(angle_deg) * k / n
                c, s = math.cos(phi), math.sin(phi)
                point = (center[0] + c * rel[0] - s * rel[1],
                         center[1] + s * rel[0] + c * rel[1])
                plat, plon = aeqd_to_latlon(point[0], point[1], *self.home_ll)
                point_ll = (float(plat), float(plon))
            self.move(point, alt0 + (target_alt - alt0) * k / n, origin, point_ll,
                      speed=speed)

    def turns_duration(self, step: RouteStep
                       ) -> tuple[float, float | None, float | None, bool | None]:
        """(duration [s], radius [m], speed [m/s], is_airspeed) of a loiter given in turns
        (a multirotor at ArduCopter's circle speed, :func:`circle_speed`)."""
        d, multirotor = self.defaults, self.vehicle == "multirotor"
        if multirotor:
            radius = step.radius_m or (d.circle_radius_m if d else None)
        else:
            radius = step.radius_m or (d.loiter_radius_m if d else None)
        v, _, _ = self.limits(None)
        if not radius or not v:
            raise InputError(
                f"{self.where}: {step.origin}: a loiter of {step.turns:g} turns needs a radius "
                "and a speed (set a speed before it, or give the aircraft) to give its "
                "duration")
        is_air = self.speed_is_airspeed
        if multirotor:
            v, is_air = circle_speed(radius, v, d), False
        duration = step.turns * 2.0 * math.pi * radius / v
        problem = hold_problem(duration, "loiter time")
        if problem:
            raise InputError(
                f"{self.where}: {step.origin}: {step.turns:g} turns of {radius:g} m "
                f"at {v:g} m/s: {problem}")
        return duration, (radius if step.radius_m or multirotor else None), v, is_air

    # ---------------------------------------------------------------- the steps

    def start(self, step: RouteStep, east: float, north: float, lat: float,
              lon: float) -> tuple[tuple[float, float], tuple[float, float], float]:
        """Begin a step: record the speeds in force for its item; return its target (east,
        north [m]; latitude, longitude [deg]; altitude above home [m]), the current
        position and altitude where the step leaves them unset."""
        self.item = step.item
        if self.states is not None and self.item is not None and self.item not in self.states:
            self.states[self.item] = (self.speed_ms, self.speed_is_airspeed, self.climb_rate,
                                      self.descent_rate)
        if np.isnan(east):
            target, target_ll = self.pos, self.here[0]
        else:
            target, target_ll = (float(east), float(north)), (float(lat), float(lon))
        return target, target_ll, self.alt if step.alt_m is None else float(step.alt_m)

    def takeoff(self, step, target, target_ll, target_alt) -> None:
        if target_alt < self.alt:
            warnings.warn(f"{self.where}: {step.origin}: take-off altitude {target_alt:g} m "
                          f"is below the current {self.alt:g} m; ignored", stacklevel=3)
        else:
            self.vertical(target_alt, step.origin)
            self.on_ground = False

    def waypoint(self, step, target, target_ll, target_alt) -> None:
        self.move(target, target_alt, step.origin, target_ll)
        if step.hold_s:
            self.hover(step.hold_s, step.origin)

    def arc_step(self, step, target, target_ll, target_alt) -> None:
        self.arc(target, target_alt, step.origin, target_ll, float(step.angle_deg or 0.0))

    def hold(self, step, target, target_ll, target_alt) -> None:
        if step.duration_s:
            self.hover(step.duration_s, step.origin)

    def loiter(self, step, target, target_ll, target_alt) -> None:
        """Fly to the point, then loiter there: a multirotor without a radius holds its
        position (ArduCopter ``ModeAuto::do_loiter_time``), else it circles."""
        self.move(target, target_alt, step.origin, target_ll)
        duration, radius, speed, is_air = (step.duration_s, step.radius_m, self.speed_ms,
                                           self.speed_is_airspeed)
        if step.turns is not None:
            if not step.turns:
                return
            duration, radius, speed, is_air = self.turns_duration(step)
        if not duration:
            return
        if self.vehicle == "multirotor" and radius is None:      # a position hold
            self.hover(duration, step.origin)
            return
        self.legs.append(Leg("loiter", start_en_m=self.pos, end_en_m=self.pos,
                             start_alt_m=self.alt, end_alt_m=self.alt, speed_ms=speed,
                             speed_is_airspeed=is_air, duration_s=float(duration),
                             loiter_radius_m=radius or None, origin=step.origin,
                             item=self.item))

    def loiter_to_alt(self, step, target, target_ll, target_alt) -> None:
        self.move(target, target_alt, step.origin, target_ll, level=True,
                  radius=step.radius_m)

    def land(self, step, target, target_ll, target_alt) -> None:
        """To the point (home for ``rtl``) at the current altitude, then down to 0."""
        if step.action == "rtl":
            target, target_ll = (0.0, 0.0), self.home_ll
        self.move(target, self.alt, step.origin, target_ll)
        self.vertical(0.0, step.origin)
        self.on_ground = True

    def speed(self, step, target, target_ll, target_alt) -> None:
        self.speed_ms, self.speed_is_airspeed = step.speed_ms, (
            None if step.speed_ms is None else step.speed_is_airspeed)

    def climb_rate_step(self, step, target, target_ll, target_alt) -> None:
        self.climb_rate = step.speed_ms

    def descent_rate_step(self, step, target, target_ll, target_alt) -> None:
        self.descent_rate = step.speed_ms

    def ends_after(self, step: RouteStep, later: list[RouteStep]) -> bool:
        """Whether the route ends at a landing ``step``: it does unless it is a PX4
        land-and-continue with items after it; items left unflown are said in a warning."""
        rest = [s.origin for s in later if s.action not in ("speed", "climb_rate",
                                                            "descent_rate")]
        if step.action == "land" and step.fly_on and rest:
            return False
        if rest:
            warnings.warn(f"{self.where}: {len(rest)} item(s) after {step.origin} "
                          f"({'RTL' if step.action == 'rtl' else 'LAND'}) are not flown, "
                          f"from {rest[0]}", stacklevel=3)
        return True

    def finish(self) -> list[Leg]:
        """The legs, refused when there is none or when their holds add up to more than
        :data:`MAX_HOLD_S`."""
        if not self.legs:
            raise InputError(f"{self.where}: the mission has no flight legs "
                             "(expected a take-off or at least one waypoint)")
        too_long = total_hold_problem(self.legs)
        if too_long:
            raise InputError(f"{self.where}: {too_long[0]}: {too_long[1]}")
        return self.legs


#: Route action → the :class:`_RouteFlight` method that flies it.
_STEP_ACTIONS = {
    "takeoff": _RouteFlight.takeoff, "waypoint": _RouteFlight.waypoint,
    "arc": _RouteFlight.arc_step, "hold": _RouteFlight.hold, "loiter": _RouteFlight.loiter,
    "loiter_to_alt": _RouteFlight.loiter_to_alt, "rtl": _RouteFlight.land,
    "land": _RouteFlight.land, "speed": _RouteFlight.speed,
    "climb_rate": _RouteFlight.climb_rate_step,
    "descent_rate": _RouteFlight.descent_rate_step,
}
#: Actions that end on the ground.
_LANDINGS = ("rtl", "land")


def route_to_legs(steps: list[RouteStep], home_lat_deg: float, home_lon_deg: float, *,
                  where: str, speed_ms: float | None = None,
                  speed_is_airspeed: bool | None = None,
                  defaults: NavDefaults | None = None, vehicle_type: str | None = None,
                  climb_first: bool = False,
                  states: dict[int, SpeedState] | None = None) -> list[Leg]:
    """Fly a route from home (on the ground, altitude 0) and return its legs.

    Parameters
    ----------
    steps : list of RouteStep
    home_lat_deg, home_lon_deg : float
        Home point, origin of the legs' east/north frame. [deg]
    where : str
        The file name, for messages.
    speed_ms : float or None
        Speed in force at the start (the file's default speed). [m/s]
    speed_is_airspeed : bool or None
        Kind of that speed.
    defaults : NavDefaults or None
        The aircraft's speeds and rates: bound the climb of a cruise, give a loiter in
        turns its speed where no ``DO_CHANGE_SPEED`` did.
    vehicle_type : {"multirotor", "fixed_wing"} or None
        How a loiter in turns is flown (``defaults.vehicle_type`` where not given).
    climb_first : bool
        A route that leaves the ground towards a point elsewhere climbs over the point
        where it is first (a firmware's inserted take-off); the YAML waypoints form
        leaves it to its ``takeoff_alt_m``.
    states : dict or None
        Filled with the speeds in force (:data:`SpeedState`) as each step's item starts.

    Returns
    -------
    legs : list of Leg

    Raises
    ------
    InputError
        A loiter given in turns without a radius or speed, or lasting more than
        :data:`MAX_HOLD_S`; holds adding up to more than that; a leg the local
        frame cannot represent within :data:`MAX_FRAME_ERROR` (far from home
        and not through it); a route with no flight legs.
    """
    vehicle = vehicle_type or (defaults.vehicle_type if defaults is not None else None)
    lat = np.array([np.nan if s.lat_deg is None else s.lat_deg for s in steps], dtype=float)
    lon = np.array([np.nan if s.lon_deg is None else s.lon_deg for s in steps], dtype=float)
    east, north = latlon_to_aeqd(lat, lon, home_lat_deg, home_lon_deg)
    east, north = np.atleast_1d(east), np.atleast_1d(north)
    _check_swapped(steps, lat, lon, east, north, home_lat_deg, home_lon_deg, where)
    _check_speeds(steps, defaults, where)
    flight = _RouteFlight((float(home_lat_deg), float(home_lon_deg)), where=where,
                          speed_ms=speed_ms, speed_is_airspeed=speed_is_airspeed,
                          defaults=defaults, vehicle=vehicle, climb_first=climb_first,
                          states=states)
    for i, step in enumerate(steps):
        action = _STEP_ACTIONS.get(step.action)
        if action is None:  # pragma: no cover - steps are built by this package
            raise ValueError(f"unknown route action {step.action!r}")
        action(flight, step, *flight.start(step, east[i], north[i], lat[i], lon[i]))
        if step.action in _LANDINGS and flight.ends_after(step, steps[i + 1:]):
            break
    return flight.finish()


# --------------------------------------------------------------------------
# MAVLink mission items (shared by .plan and .waypoints)

#: MAV_CMD numbers understood here, with their names for messages.
MAV_CMD_NAMES = {
    16: "NAV_WAYPOINT", 17: "NAV_LOITER_UNLIM", 18: "NAV_LOITER_TURNS",
    19: "NAV_LOITER_TIME", 20: "NAV_RETURN_TO_LAUNCH", 21: "NAV_LAND", 22: "NAV_TAKEOFF",
    31: "NAV_LOITER_TO_ALT", 36: "NAV_ARC_WAYPOINT", 82: "NAV_SPLINE_WAYPOINT",
    84: "NAV_VTOL_TAKEOFF", 85: "NAV_VTOL_LAND", 93: "NAV_DELAY", 177: "DO_JUMP",
    178: "DO_CHANGE_SPEED", 600: "JUMP_TAG", 601: "DO_JUMP_TAG",
    # ignored ones, named in the warning
    80: "NAV_ROI", 94: "NAV_PAYLOAD_PLACE", 112: "CONDITION_DELAY",
    113: "CONDITION_CHANGE_ALT", 114: "CONDITION_DISTANCE", 115: "CONDITION_YAW",
    176: "DO_SET_MODE", 179: "DO_SET_HOME", 181: "DO_SET_RELAY", 183: "DO_SET_SERVO",
    187: "DO_SET_ACTUATOR", 189: "DO_LAND_START", 195: "DO_SET_ROI_LOCATION",
    196: "DO_SET_ROI_WPNEXT_OFFSET", 197: "DO_SET_ROI_NONE", 201: "DO_SET_ROI",
    202: "DO_DIGICAM_CONFIGURE", 203: "DO_DIGICAM_CONTROL", 205: "DO_MOUNT_CONTROL",
    206: "DO_SET_CAM_TRIGG_DIST", 211: "DO_GRIPPER", 214: "DO_SET_CAM_TRIGG_INTERVAL",
    530: "SET_CAMERA_MODE", 531: "SET_CAMERA_ZOOM", 532: "SET_CAMERA_FOCUS",
    1000: "DO_GIMBAL_MANAGER_PITCHYAW", 2000: "IMAGE_START_CAPTURE",
    2001: "IMAGE_STOP_CAPTURE", 2500: "VIDEO_START_CAPTURE", 2501: "VIDEO_STOP_CAPTURE",
    3000: "DO_VTOL_TRANSITION",
}

_WAYPOINT_CMDS = {16, 82}
#: Navigation commands with a position (param5..7).
POSITIONED_CMDS = frozenset({16, 17, 18, 19, 21, 22, 31, 36, 82, 84, 85})
#: Commands that take off, and that land.
TAKEOFF_CMDS, LAND_CMDS = frozenset({22, 84}), frozenset({21, 85})
_JUMP_CMDS = {177, 600, 601}
_FRAMES_AMSL = {0, 5}          # MAV_FRAME_GLOBAL, GLOBAL_INT
_FRAMES_RELATIVE = {3, 6}      # GLOBAL_RELATIVE_ALT(_INT)
_FRAMES_TERRAIN = {10, 11}     # GLOBAL_TERRAIN_ALT(_INT)
#: MAV_AUTOPILOT values of a .plan's ``firmwareType``.
FIRMWARES = {3: "ardupilot", 12: "px4"}


@dataclass(frozen=True)
class MavItem:
    """One MAVLink mission item as stored in a mission file.

    Attributes
    ----------
    seq : int
        Sequence number the vehicle gets (the ``.waypoints`` position, as pymavlink's
        ``MAVWPLoader`` renumbers; the ``.plan`` doJumpId, which QGroundControl turns
        into the sequence number): the target of ``DO_JUMP``.
    command : int
        MAV_CMD number.
    frame : int
        MAV_FRAME number.
    params : tuple of 7 float
        param1..param4, latitude, longitude, altitude (NaN where unset).
    origin : str
        Where it is in the file (``"line 7"``, ``"mission.items[3]"``).
    amsl_alt_above_terrain_m : float or None
        QGroundControl's AMSL altitude for terrain-frame items. [m]
    raw : object or None
        The ``.plan`` item object as written (kept to write it back).
    autocontinue : int
        The file's autocontinue field.
    altitude_mode : int or None
        QGroundControl's ``AltitudeMode`` of the item (3: "calc above terrain").
    """

    seq: int
    command: int
    frame: int
    params: tuple[float, ...]
    origin: str
    amsl_alt_above_terrain_m: float | None = None
    raw: Any = None
    autocontinue: int = 1
    altitude_mode: int | None = None


@dataclass
class MissionFile:
    """What a waypoint-file reader keeps to write the mission back (sorties).

    Attributes
    ----------
    format : {"plan", "waypoints"}
    home : MavItem
        The home item (the ``.waypoints`` row 0; a ``.plan``'s planned home).
    items : list of MavItem
        The items as flown, ``DO_JUMP`` repeats unrolled; a leg's ``item`` indexes it.
    states : dict
        The speeds in force (:data:`SpeedState`) as each navigation item started.
    legs : dict
        The legs each item gave, by item index.
    firmware : {"ardupilot", "px4"} or None
    vehicle_type : {"multirotor", "fixed_wing"} or None
    plan : dict or None
        A ``.plan``'s JSON object with its mission items removed (geofence, rally points,
        firmware, vehicle, QGroundControl's speeds).
    """

    format: str
    home: MavItem
    items: list[MavItem]
    states: dict[int, SpeedState] = field(default_factory=dict)
    legs: dict[int, tuple[Leg, ...]] = field(default_factory=dict)
    firmware: str | None = None
    vehicle_type: str | None = None
    plan: dict | None = None


def cmd_name(command: int) -> str:
    """A MAVLink command number in words, e.g. ``MAV_CMD_NAV_WAYPOINT (16)``."""
    name = MAV_CMD_NAMES.get(command)
    return f"MAV_CMD_{name} ({command})" if name else f"MAV_CMD {command}"


def expand_jumps(items: list[MavItem], *, where: str) -> list[MavItem]:
    """The items as flown: ``DO_JUMP`` (param1 target seq, param2 repeat count) and
    ``DO_JUMP_TAG`` (param1 tag, param2 repeat count) followed, ``JUMP_TAG`` markers
    dropped (``AP_Mission::get_next_cmd``; MAVLink ``MAV_CMD_DO_JUMP_TAG``).

    Raises
    ------
    InputError
        A jump to a missing target, a negative (endless) repeat count, or more
        than :data:`MAX_JUMPS` jumps in all.
    """
    index_of: dict[int, int] = {}
    tags: dict[int, int] = {}
    for i, item in enumerate(items):
        index_of.setdefault(item.seq, i)
        if item.command == 600 and math.isfinite(item.params[0]):
            tags.setdefault(round(item.params[0]), i)
    done: dict[int, int] = {}
    out: list[MavItem] = []
    jumps = 0
    i = 0
    while i < len(items):
        item = items[i]
        if item.command not in (177, 601):
            if item.command != 600:
                out.append(item)
            i += 1
            continue
        name = "DO_JUMP" if item.command == 177 else "DO_JUMP_TAG"
        p1, p2 = item.params[0], item.params[1]
        if not (math.isfinite(p1) and math.isfinite(p2)):
            what = "a target (param1)" if item.command == 177 else "a tag (param1)"
            raise InputError(f"{where}: {item.origin}: {name} needs {what} and a "
                             "repeat count (param2)")
        target, repeat = round(p1), round(p2)
        if item.command == 177 and target not in index_of:
            raise InputError(f"{where}: {item.origin}: DO_JUMP target {target} is not an "
                             f"item of the mission (expected one of {sorted(index_of)})")
        if repeat < 0:
            raise InputError(f"{where}: {item.origin}: {name} repeat count {repeat} repeats "
                             "for ever: the mission has no end (expected 0..100; the "
                             "firmware flies the loop until a failsafe or the pilot ends "
                             "it, AP_Mission AP_MISSION_JUMP_REPEAT_FOREVER)")
        if done.get(i, 0) < repeat:
            if item.command == 601 and target not in tags:
                warnings.warn(f"{where}: {item.origin}: DO_JUMP_TAG to tag {target}, which no "
                              "JUMP_TAG carries: the mission ends here (MAVLink: a jump to "
                              "a missing tag completes the mission)", stacklevel=2)
                break
            done[i] = done.get(i, 0) + 1
            jumps += 1
            if jumps > MAX_JUMPS:
                raise InputError(f"{where}: {item.origin}: {name} expands to more than "
                                 f"{MAX_JUMPS} repeats in all (expected at most {MAX_JUMPS})")
            i = index_of[target] if item.command == 177 else tags[target]
        else:
            i += 1
    return out


def _finite(x: float) -> bool:
    return x is not None and math.isfinite(x)


def _label(item: MavItem) -> str:
    """Where an item is, for messages: ``"line 15 (item 13)"``."""
    if item.origin.endswith(f"[{item.seq}]"):
        return item.origin
    return f"{item.origin} (item {item.seq})"


@dataclass
class _ItemRules:
    """What turning one file's items into steps needs: the file, home's altitude, whose
    rules apply, and the warnings said so far (each once) and the items ignored."""

    where: str
    home_alt_amsl_m: float
    vehicle_type: str | None
    firmware: str | None
    ignored: dict[int, list[str]] = field(default_factory=dict)
    warned: set[str] = field(default_factory=set)

    @property
    def fixed_wing(self) -> bool:
        return self.vehicle_type == "fixed_wing"

    @property
    def ardupilot(self) -> bool:
        return self.firmware in (None, "ardupilot")

    @property
    def px4(self) -> bool:
        return self.firmware == "px4"

    def warn_once(self, key: str, message: str) -> None:
        if key not in self.warned:
            self.warned.add(key)
            warnings.warn(message, stacklevel=4)

    def ignore(self, item: MavItem) -> None:
        """An item that does not change the flight: named in one warning per command."""
        self.ignored.setdefault(item.command, []).append(item.origin)

    def refuse(self, item: MavItem, problem: str) -> InputError:
        """The error of an item: ``"{file}: line 15 (item 13): MAV_CMD_… problem"``."""
        return InputError(f"{self.where}: {_label(item)}: {cmd_name(item.command)} {problem}")


def _item_latlon(item: MavItem, rules: _ItemRules) -> tuple[float | None, float | None]:
    """The latitude and longitude of a navigation item [deg]; ``None`` for "the current
    position" (both 0 or both unset: ArduCopter ``ModeAuto::loc_from_cmd``)."""
    p, where, origin = item.params, rules.where, item.origin
    if any(math.isinf(v) for v in p[4:7]):
        raise rules.refuse(item, f"latitude, longitude, altitude {p[4]:g}, {p[5]:g}, "
                                 f"{p[6]:g} (expected finite numbers)")
    if _finite(p[4]) != _finite(p[5]):
        raise rules.refuse(item, f"latitude, longitude {p[4]:g}, {p[5]:g} (expected both "
                                 "numbers, or both unset for the current position)")
    if not (_finite(p[4]) and _finite(p[5])) or (p[4] == 0 and p[5] == 0):
        return None, None
    lat, lon = float(p[4]), float(p[5])
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise InputError(f"{where}: {origin}: latitude/longitude {lat:g}, {lon:g} "
                         "out of range (expected -90..90, -180..180 degrees)")
    return lat, lon


def _frame_altitude(item: MavItem, rules: _ItemRules) -> float:
    """param7 as an altitude above home by the item's frame (MAVLink ``MAV_FRAME``:
    global = above mean sea level, relative = above home, terrain = above the ground,
    QGroundControl's AMSL altitude where the ``.plan`` gives it, else the ground taken as
    flat at home's altitude, with a warning). [m]"""
    p, where, origin = item.params, rules.where, item.origin
    if item.frame in _FRAMES_RELATIVE:
        return float(p[6])
    if item.frame in _FRAMES_AMSL:
        return float(p[6]) - rules.home_alt_amsl_m
    if item.frame not in _FRAMES_TERRAIN:
        raise InputError(f"{where}: {origin}: frame {item.frame} not supported for "
                         f"{cmd_name(item.command)} (expected 0 global, 3 relative or 10 "
                         "terrain)")
    if _finite(item.amsl_alt_above_terrain_m):
        return float(item.amsl_alt_above_terrain_m) - rules.home_alt_amsl_m
    alt = float(p[6])
    if item.altitude_mode == 3:
        rules.warn_once(f"calc{origin}", f"{where}: {origin}: 'calc above terrain' altitude "
                        f"(AltitudeMode 3) {alt:g} m without the terrain height "
                        "QGroundControl adds to it (param7 null): read as that height above "
                        "the ground, the terrain assumed flat at home's altitude")
    else:
        rules.warn_once("terrain", f"{where}: {origin}: terrain-relative altitude treated as "
                        "relative to home (the terrain assumed flat at home's altitude)")
    return alt


def _item_altitude(item: MavItem, rules: _ItemRules, lat: float | None) -> float | None:
    """The altitude above home a navigation item flies to [m] (``None``: the current one,
    for a landing or for "here" at relative altitude 0); refused outside the atmosphere
    model or below home (PX4 ``MissionFeasibilityChecker::checkHomePositionAltitude``)."""
    p, cmd = item.params, item.command
    if cmd in LAND_CMDS:
        return None
    if not _finite(p[6]):
        raise InputError(f"{rules.where}: {item.origin}: {cmd_name(cmd)} altitude is "
                         f"{p[6]!r} (expected a number)")
    alt = _frame_altitude(item, rules)
    ref = ("above mean sea level" if item.frame in _FRAMES_AMSL
           else "above home" if item.frame in _FRAMES_RELATIVE else "above terrain")
    problem = altitude_problem(alt, rules.home_alt_amsl_m)
    if problem:
        raise rules.refuse(item, f"altitude {p[6]:g} m (frame {item.frame}, {ref}) {problem}")
    if alt < -MIN_ALT_CHANGE_M and item.frame not in _FRAMES_TERRAIN:
        raise rules.refuse(
            item, f"altitude {p[6]:g} m (frame {item.frame}, {ref}) is {-alt:g} m below home "
                  f"({rules.home_alt_amsl_m:g} m above mean sea level): the route lies below "
                  "the take-off point (expected altitudes above home, as PX4 requires: "
                  "'Waypoint below home', MissionFeasibilityChecker::"
                  "checkHomePositionAltitude; over lower ground, give the altitude in the "
                  "terrain frame 10)")
    if lat is None and item.frame in _FRAMES_RELATIVE and p[6] == 0:
        return None  # "here, at the current altitude"
    return alt


def _item_place(item: MavItem, rules: _ItemRules
                ) -> tuple[float | None, float | None, float | None]:
    """Latitude, longitude [deg] and altitude above home [m] of a navigation item
    (``None``: where the aircraft is)."""
    lat, lon = _item_latlon(item, rules)
    return lat, lon, _item_altitude(item, rules, lat)


# One function per MAV_CMD family: the item (the k-th as flown) → its route step, or None.


def _nav_waypoint(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_WAYPOINT``, ``NAV_SPLINE_WAYPOINT``: to the point, then param1 s of hover,
    which ArduPlane ignores (``Plane::verify_nav_wp``; ArduCopter
    ``ModeAuto::verify_nav_wp`` waits ``loiter_time_max``)."""
    lat, lon, alt = _item_place(item, rules)
    p = item.params
    hold = None
    if not math.isnan(p[0]):   # NaN (null): no hold
        problem = hold_problem(p[0], "param1 (hold time)")
        if problem:
            raise rules.refuse(item, problem)
        hold = float(p[0]) if p[0] > 0 else None
    if hold and rules.fixed_wing and rules.ardupilot:
        rules.warn_once("hold", f"{rules.where}: {item.origin}: a waypoint's hold time "
                        "(param1) is ignored by ArduPlane (a fixed-wing aircraft does not "
                        "stop)")
        hold = None
    return RouteStep("waypoint", lat, lon, alt, hold_s=hold, origin=item.origin, item=k)


def _nav_arc_waypoint(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_ARC_WAYPOINT``: param1 degrees of arc (param2 in ArduPilot's first
    ``ArcWPMissionTest.txt``); ArduPlane has no case for it in ``start_command``, so
    ``AP_Mission`` skips it."""
    lat, lon, alt = _item_place(item, rules)
    p, where, origin = item.params, rules.where, item.origin
    if rules.fixed_wing:
        rules.warn_once("arc", f"{where}: {origin}: {cmd_name(item.command)} skipped: "
                        "ArduPlane has no case for it in start_command, so AP_Mission skips "
                        "it (PX4 refuses it at upload); the aircraft flies on to the next item")
        return None
    angle = p[0] if _finite(p[0]) else 0.0
    if angle == 0 and _finite(p[1]) and p[1] != 0:
        angle = p[1]
        rules.warn_once("arc2", f"{where}: {origin}: arc angle read from param2, as "
                        "ArduPilot's first arc waypoints wrote it (MAVLink puts it in param1)")
    if abs(angle) > MAX_ARC_DEG:
        raise rules.refuse(item, f"angle {angle:g}° is out of range (expected "
                                 f"-{MAX_ARC_DEG:g} to {MAX_ARC_DEG:g} degrees)")
    return RouteStep("arc", lat, lon, alt, angle_deg=float(angle), origin=origin, item=k)


def _nav_loiter_to_alt(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_LOITER_TO_ALT``: to the point, then the climb over it (ArduCopter
    ``ModeAuto::loiter_to_alt_run``), a fixed wing circling at radius |param2|
    (ArduPlane ``verify_loiter_to_alt``)."""
    lat, lon, alt = _item_place(item, rules)
    p = item.params
    radius = abs(float(p[1])) if rules.fixed_wing and _finite(p[1]) and p[1] != 0 else None
    return RouteStep("loiter_to_alt", lat, lon, alt, radius_m=radius, origin=item.origin,
                     item=k)


def _nav_loiter_unlim(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_LOITER_UNLIM``: refused, the firmware never completes it
    (``verify_loiter_unlimited`` returns false)."""
    raise InputError(f"{rules.where}: {item.origin}: {cmd_name(item.command)} loiters "
                     "without end, so the mission has no duration (expected LOITER_TIME or "
                     "LOITER_TURNS; the firmware never completes it: verify_loiter_unlimited "
                     "returns false)")


def _nav_loiter(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_LOITER_TURNS`` (param1 turns, at most the byte ``AP_Mission`` stores) and
    ``NAV_LOITER_TIME`` (param1 s): radius |param3|; a timed loiter of a multirotor is a
    position hold (ArduCopter ``ModeAuto::do_loiter_time``) and ArduPlane's circles at its
    own radius (``verify_loiter_time``), PX4 fixed wing's at param3."""
    lat, lon, alt = _item_place(item, rules)
    p, cmd, turns = item.params, item.command, item.command == 18
    if not _finite(p[0]) or p[0] < 0:
        what = "turns" if turns else "seconds"
        raise InputError(f"{rules.where}: {item.origin}: {cmd_name(cmd)} param1 ({what}) "
                         f"must be >= 0, got {p[0]!r}")
    if not turns and hold_problem(p[0]):
        raise rules.refuse(item, hold_problem(p[0], "param1 (loiter time)"))
    if turns and p[0] > MAX_LOITER_TURNS:
        raise rules.refuse(item, f"param1 (turns) {p[0]:g} is out of range (expected 0 to "
                                 f"{MAX_LOITER_TURNS}, the most ArduPilot stores)")
    radius = abs(float(p[2])) if _finite(p[2]) and p[2] != 0 else None
    if not turns and not (rules.fixed_wing and rules.px4):
        radius = None    # a multirotor hovers; ArduPlane circles at WP_LOITER_RAD
    return RouteStep("loiter", lat, lon, alt, radius_m=radius, origin=item.origin,
                     turns=float(p[0]) if turns else None,
                     duration_s=None if turns else float(p[0]), item=k)


def _nav_takeoff(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_TAKEOFF``, ``NAV_VTOL_TAKEOFF``: a vertical climb where the aircraft is
    (ArduCopter ``ModeAuto::takeoff_start``)."""
    _, _, alt = _item_place(item, rules)
    return RouteStep("takeoff", alt_m=alt, origin=item.origin, item=k)


def _nav_return_to_launch(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_RETURN_TO_LAUNCH``: home at the current altitude, then down (``RTL_ALT`` is
    a parameter, not an item)."""
    return RouteStep("rtl", origin=item.origin, item=k)


def _nav_land(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_LAND``, ``NAV_VTOL_LAND``: to the point, then down; PX4 flies on after it
    (land-and-continue), ArduCopter disarms (``ModeAuto::verify_land``)."""
    lat, lon, _ = _item_place(item, rules)
    return RouteStep("land", lat, lon, origin=item.origin, item=k, fly_on=rules.px4)


def _nav_delay(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``NAV_DELAY``: a hover of param1 s (-1: a time of day, not modelled); ArduPlane
    does not delay in fixed-wing flight (``Plane::do_nav_delay``)."""
    p, cmd = item.params, item.command
    if math.isnan(p[0]) or p[0] == -1:   # -1: wait for a time of day, not modelled
        rules.ignore(item)
        return None
    problem = hold_problem(p[0], "param1 (delay)")
    if problem:
        raise rules.refuse(item, f"{problem[:-1]}, or -1 for a time of day)")
    if rules.fixed_wing and rules.ardupilot:
        rules.warn_once("delay", f"{rules.where}: {item.origin}: {cmd_name(cmd)} skipped: "
                        "ArduPlane does not delay while flying as a fixed wing (do_nav_delay)")
        return None
    return RouteStep("hold", duration_s=float(p[0]), origin=item.origin, item=k)


def _do_change_speed(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``DO_CHANGE_SPEED`` (param1 type, param2 speed, -2 the default): types 0 and 1 are a
    multirotor's ground speed (ArduCopter ``set_speed_NE``, PX4 ``set_cruising_speed``);
    ArduPlane takes 0 as the airspeed, 1 as ``MIN_GROUNDSPEED`` and ignores 2 and 3
    (``Plane::do_change_speed``); types 2 and 3 are the climb and descent rates."""
    p, cmd, origin = item.params, item.command, item.origin
    kind = int(p[0]) if _finite(p[0]) else 0
    if not _finite(p[1]) or (p[1] <= 0 and p[1] != -2):  # -1 (or 0): no change
        return None
    if p[1] > MAX_SPEED_MS:
        raise InputError(f"{rules.where}: {_label(item)}: {cmd_name(cmd)} speed {p[1]:g} m/s; "
                         f"expected at most {MAX_SPEED_MS:g} m/s (or -1 for no change)")
    speed = None if p[1] == -2 else float(p[1])      # -2: back to the default
    fixed_wing, px4 = rules.fixed_wing, rules.px4
    if fixed_wing and rules.ardupilot and kind != 0:
        rules.warn_once(f"speed{kind}", f"{rules.where}: {origin}: {cmd_name(cmd)} type {kind} "
                        + ("sets ArduPlane's minimum ground speed (MIN_GROUNDSPEED), not a "
                           "target speed: no effect on the flight planned here"
                           if kind == 1 else "is ignored by ArduPlane")
                        + " (Plane::do_change_speed)")
        return None
    if kind in (0, 1) or (fixed_wing and px4):
        airspeed = (kind == 0 and rules.vehicle_type != "multirotor") or (fixed_wing and px4)
        return RouteStep("speed", speed_ms=speed, speed_is_airspeed=airspeed, origin=origin,
                         item=k)
    if kind in (2, 3):
        return RouteStep("climb_rate" if kind == 2 else "descent_rate", speed_ms=speed,
                         origin=origin, item=k)
    rules.ignore(item)
    return None


def _do_jump(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """``DO_JUMP``, ``JUMP_TAG``, ``DO_JUMP_TAG``: followed by :func:`expand_jumps`."""
    return None


def _not_modelled(item: MavItem, k: int, rules: _ItemRules) -> RouteStep | None:
    """Any other command: it does not change the flight planned here (a camera, a
    servo, a region of interest); named in a warning."""
    rules.ignore(item)
    return None


#: MAV_CMD number → the function that turns such an item into a route step.
ITEM_STEPS = {
    16: _nav_waypoint, 82: _nav_waypoint, 36: _nav_arc_waypoint,
    17: _nav_loiter_unlim, 18: _nav_loiter, 19: _nav_loiter, 31: _nav_loiter_to_alt,
    22: _nav_takeoff, 84: _nav_takeoff, 20: _nav_return_to_launch,
    21: _nav_land, 85: _nav_land, 93: _nav_delay, 178: _do_change_speed,
    177: _do_jump, 600: _do_jump, 601: _do_jump,
}


def mav_items_to_steps(items: list[MavItem], home_alt_amsl_m: float, *, where: str,
                       vehicle_type: str | None = None, firmware: str | None = None,
                       expanded: bool = False) -> list[RouteStep]:
    """Turn MAVLink mission items (without home) into route steps, each by the function
    of its command (:data:`ITEM_STEPS`).

    Parameters
    ----------
    items : list of MavItem
        Mission items after home, in file order (or as flown, ``expanded``).
    home_alt_amsl_m : float
        Home altitude above mean sea level, for items in the global (AMSL)
        frame. [m]
    where : str
        The file name, for messages.
    vehicle_type : {"multirotor", "fixed_wing"} or None
        For a multirotor, ``DO_CHANGE_SPEED`` is a ground speed whatever its
        speed type (ArduCopter and PX4 multicopters navigate at ground speed), a
        ``LOITER_TIME`` is a hover; a fixed-wing aircraft skips arcs.
    firmware : {"ardupilot", "px4"} or None
        Whose rules apply where they differ (``None``: ArduPilot's, the firmware of the
        ``.waypoints`` format): a landing amid the mission, a fixed-wing ``LOITER_TIME``
        radius and ``DO_CHANGE_SPEED``.
    expanded : bool
        The items are already as flown (:func:`expand_jumps`); a step's ``item`` is then
        the index in ``items``.

    Returns
    -------
    steps : list of RouteStep

    Raises
    ------
    InputError
        ``NAV_LOITER_UNLIM`` (unbounded), a bad ``DO_JUMP``, a navigation
        item in an unsupported frame or without a finite position, an infinite
        coordinate, an altitude outside the atmosphere model or below home, a hold
        time < 0 or above :data:`MAX_HOLD_S`, more than :data:`MAX_LOITER_TURNS` turns.
    """
    if not expanded:
        items = expand_jumps(items, where=where)
    rules = _ItemRules(where, home_alt_amsl_m, vehicle_type, firmware)
    steps = [step for k, item in enumerate(items)
             if (step := ITEM_STEPS.get(item.command, _not_modelled)(item, k, rules))
             is not None]
    for cmd, origins in rules.ignored.items():
        n = len(origins)
        warnings.warn(f"{where}: {cmd_name(cmd)} ignored ({n} item{'s' * (n > 1)}, first at "
                      f"{origins[0]})", stacklevel=2)
    return steps


def fly_mav_items(items: list[MavItem], home: MavItem, *, where: str, fmt: str,
                  vehicle_type: str | None = None, firmware: str | None = None,
                  defaults: NavDefaults | None = None,
                  plan: dict | None = None) -> tuple[list[Leg], MissionFile]:
    """The legs of a waypoint file's items, and what is kept to write it back.

    Parameters
    ----------
    items : list of MavItem
        The mission items after home, in file order.
    home : MavItem
        Home: latitude, longitude and altitude above mean sea level in params 5..7.
    where : str
        The file name, for messages.
    fmt : {"plan", "waypoints"}
    vehicle_type, firmware : see :func:`mav_items_to_steps`
    defaults : NavDefaults or None
        The aircraft's speeds (:func:`route_to_legs`).
    plan : dict or None
        A ``.plan``'s JSON without its items (kept in :class:`MissionFile`).
    """
    vehicle = vehicle_type or (defaults.vehicle_type if defaults is not None else None)
    flown = expand_jumps(items, where=where)
    steps = mav_items_to_steps(flown, home.params[6], where=where, vehicle_type=vehicle,
                               firmware=firmware, expanded=True)
    states: dict[int, SpeedState] = {}
    legs = route_to_legs(steps, home.params[4], home.params[5], where=where,
                         defaults=defaults, vehicle_type=vehicle, climb_first=True,
                         states=states)
    by_item: dict[int, list[Leg]] = {}
    for leg in legs:
        if leg.item is not None:
            by_item.setdefault(leg.item, []).append(leg)
    file = MissionFile(format=fmt, home=home, items=flown, states=states,
                       legs={k: tuple(v) for k, v in by_item.items()}, firmware=firmware,
                       vehicle_type=vehicle, plan=plan)
    return legs, file
