"""Waypoint route -> mission legs: the one conversion every waypoint format shares.

A route is a list of :class:`RouteStep` (take off, fly to a waypoint, hold,
loiter, change speed, return to launch, land). The YAML ``waypoints:`` form
builds steps directly; QGroundControl ``.plan`` and Mission Planner
``.waypoints`` files are first read into MAVLink mission items
(:class:`MavItem`), which :func:`mav_items_to_steps` turns into steps
(expanding ``DO_JUMP``). :func:`route_to_legs` then flies the steps from home
and emits :class:`~planner.physics.mission.Leg` objects, so the same route gives
the same legs whatever file it came from.

Conventions
-----------
- Take-off is a vertical climb from the current position to the take-off
  altitude; the take-off item's latitude/longitude is not flown to.
- A navigation item whose latitude and longitude are both 0 (or unset: NaN,
  ``null`` in a ``.plan``) means
  "the current position"; if its relative altitude is also 0, the current
  altitude is kept (ArduPilot's convention).
- A waypoint less than :data:`MIN_CRUISE_M` away horizontally becomes a
  ``climb``/``descend`` (or nothing, if the altitude does not change either).
- Return-to-launch flies home at the current altitude, then descends to 0.
  ArduPilot's ``RTL_ALT`` (climb to a minimum return altitude first) and
  ``RTL_LOIT_TIME`` are autopilot parameters, not mission items, and are
  ignored.
- Land with a position flies there at the current altitude first; without one
  it descends where the aircraft is. Items after RTL or LAND are not flown
  (with a warning).
- ``climb``, ``descend`` and ``hover`` legs carry no horizontal speed
  (``speed_ms=None``); ``cruise`` and ``loiter`` legs carry the speed in
  force.
- ``DO_JUMP`` is expanded as ArduPilot flies it: each jump item keeps its own
  counter for the whole mission (an inner loop of nested loops is not
  re-armed); at most :data:`MAX_JUMPS` jumps in all.
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
- every altitude, as height above mean sea level (the site altitude plus the
  altitude above home), lies in the range of the atmosphere model,
  :data:`planner.physics.atmosphere.ALTITUDE_RANGE_M`, checked here so that the
  message names the file, the item and the value as written.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from planner.physics.atmosphere import ALTITUDE_RANGE_M
from planner.errors import InputError
from planner.physics.geo import FRAME_ERROR_KM, frame_error, great_circle_distance, latlon_to_aeqd
from planner.physics.mission import Leg
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

ACTIONS = ("takeoff", "waypoint", "hold", "loiter", "rtl", "land", "speed",
           "climb_rate", "descent_rate")


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
        Target position (``waypoint``, ``loiter``, ``land``); ``None`` = the
        current position. [deg]
    alt_m : float or None
        Target altitude above home (``takeoff``, ``waypoint``, ``loiter``);
        ``None`` = the current altitude. [m]
    hold_s : float or None
        Hold time at a ``waypoint``; ``duration_s`` of a ``hold`` or timed
        ``loiter``. [s]
    turns : float or None
        Turns of a ``loiter`` (instead of a duration).
    radius_m : float or None
        Loiter radius. [m]
    speed_ms : float or None
        New speed (``speed``), or the new climb/descent rate (``climb_rate``,
        ``descent_rate``). [m/s]
    speed_is_airspeed : bool or None
        Kind of a ``speed`` (see :class:`~planner.physics.mission.Leg`).
    origin : str
        Where the step came from, for messages.
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


def route_to_legs(steps: list[RouteStep], home_lat_deg: float, home_lon_deg: float, *,
                  where: str, speed_ms: float | None = None,
                  speed_is_airspeed: bool | None = None) -> list[Leg]:
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
    lat = np.array([np.nan if s.lat_deg is None else s.lat_deg for s in steps], dtype=float)
    lon = np.array([np.nan if s.lon_deg is None else s.lon_deg for s in steps], dtype=float)
    east, north = latlon_to_aeqd(lat, lon, home_lat_deg, home_lon_deg)
    east, north = np.atleast_1d(east), np.atleast_1d(north)
    home_ll = (float(home_lat_deg), float(home_lon_deg))

    legs: list[Leg] = []
    pos = (0.0, 0.0)
    here = (home_ll, "home")      # (latitude, longitude) of pos, and where it came from
    alt = 0.0
    climb_rate = descent_rate = None

    def vertical(target_alt: float, origin: str) -> None:
        nonlocal alt
        if abs(target_alt - alt) < MIN_ALT_CHANGE_M:
            return
        kind = "climb" if target_alt > alt else "descend"
        rate = climb_rate if kind == "climb" else descent_rate
        legs.append(Leg(kind, start_en_m=pos, end_en_m=pos, start_alt_m=alt,
                        end_alt_m=target_alt, climb_rate_ms=rate, origin=origin))
        alt = target_alt

    def check_frame(start: tuple[float, float], end: tuple[float, float], origin: str,
                    start_origin: str) -> None:
        err = frame_error(*start, *end, *home_ll)
        if err <= MAX_FRAME_ERROR:
            return
        length = great_circle_distance(*start, *end)
        far = max(great_circle_distance(*home_ll, *start), great_circle_distance(*home_ll, *end))
        raise InputError(
            f"{where}: {origin}: the {length / 1e3:.0f} km leg from {start_origin} reaches "
            f"{far / 1e3:.0f} km from home without passing through it, where the planner's "
            f"flat frame about home misstates its length by {err:.2%} (expected legs within "
            f"about {FRAME_ERROR_KM:g} km of home, or straight to or from home, error at most "
            f"{MAX_FRAME_ERROR:.1%}; plan far-apart legs from a nearer home)")

    def move(target: tuple[float, float], target_alt: float, origin: str,
             target_ll: tuple[float, float]) -> None:
        nonlocal pos, alt, here
        if math.hypot(target[0] - pos[0], target[1] - pos[1]) < MIN_CRUISE_M:
            vertical(target_alt, origin)
            return
        # within a quarter of FRAME_ERROR_KM of home the frame error is below 1/16 of
        # the limit (it grows as r²): skip the exact test for the usual short missions
        if max(math.hypot(*pos), math.hypot(*target)) > 250.0 * FRAME_ERROR_KM:
            check_frame(here[0], target_ll, origin, here[1])
        legs.append(Leg("cruise", start_en_m=pos, end_en_m=target, start_alt_m=alt,
                        end_alt_m=target_alt, speed_ms=speed_ms,
                        speed_is_airspeed=speed_is_airspeed, origin=origin))
        pos, alt, here = target, target_alt, (target_ll, origin)

    for i, step in enumerate(steps):
        act = step.action
        if np.isnan(east[i]):
            target, target_ll = pos, here[0]
        else:
            target, target_ll = (float(east[i]), float(north[i])), (float(lat[i]), float(lon[i]))
        target_alt = alt if step.alt_m is None else float(step.alt_m)
        if act == "takeoff":
            if target_alt < alt:
                warnings.warn(f"{where}: {step.origin}: take-off altitude {target_alt:g} m is "
                              f"below the current {alt:g} m; ignored", stacklevel=2)
            else:
                vertical(target_alt, step.origin)
        elif act == "waypoint":
            move(target, target_alt, step.origin, target_ll)
            if step.hold_s:
                legs.append(Leg("hover", start_en_m=pos, end_en_m=pos, start_alt_m=alt,
                                end_alt_m=alt, duration_s=float(step.hold_s),
                                origin=step.origin))
        elif act == "hold":
            if step.duration_s:
                legs.append(Leg("hover", start_en_m=pos, end_en_m=pos, start_alt_m=alt,
                                end_alt_m=alt, duration_s=float(step.duration_s),
                                origin=step.origin))
        elif act == "loiter":
            move(target, target_alt, step.origin, target_ll)
            duration = step.duration_s
            if step.turns is not None:
                if not step.radius_m or not speed_ms:
                    raise InputError(
                        f"{where}: {step.origin}: a loiter of {step.turns:g} turns needs a "
                        "radius and a speed (set a speed before it) to give its duration")
                duration = step.turns * 2.0 * math.pi * step.radius_m / speed_ms
                problem = hold_problem(duration, "loiter time")
                if problem:
                    raise InputError(
                        f"{where}: {step.origin}: {step.turns:g} turns of {step.radius_m:g} m "
                        f"at {speed_ms:g} m/s: {problem}")
            if not duration:
                continue
            legs.append(Leg("loiter", start_en_m=pos, end_en_m=pos, start_alt_m=alt,
                            end_alt_m=alt, speed_ms=speed_ms,
                            speed_is_airspeed=speed_is_airspeed,
                            duration_s=float(duration),
                            loiter_radius_m=step.radius_m or None, origin=step.origin))
        elif act in ("rtl", "land"):
            if act == "rtl":
                target, target_ll = (0.0, 0.0), home_ll
            move(target, alt, step.origin, target_ll)
            vertical(0.0, step.origin)
            rest = [s.origin for s in steps[i + 1:] if s.action not in ("speed", "climb_rate",
                                                                        "descent_rate")]
            if rest:
                warnings.warn(f"{where}: {len(rest)} item(s) after {step.origin} "
                              f"({'RTL' if act == 'rtl' else 'LAND'}) are not flown, "
                              f"from {rest[0]}", stacklevel=2)
            break
        elif act == "speed":
            speed_ms, speed_is_airspeed = step.speed_ms, step.speed_is_airspeed
        elif act == "climb_rate":
            climb_rate = step.speed_ms
        elif act == "descent_rate":
            descent_rate = step.speed_ms
        else:  # pragma: no cover - steps are built by this package
            raise ValueError(f"unknown route action {act!r}")
    if not legs:
        raise InputError(f"{where}: the mission has no flight legs "
                         "(expected a take-off or at least one waypoint)")
    too_long = total_hold_problem(legs)
    if too_long:
        raise InputError(f"{where}: {too_long[0]}: {too_long[1]}")
    return legs


# --------------------------------------------------------------------------
# MAVLink mission items (shared by .plan and .waypoints)

#: MAV_CMD numbers understood here, with their names for messages.
MAV_CMD_NAMES = {
    16: "NAV_WAYPOINT", 17: "NAV_LOITER_UNLIM", 18: "NAV_LOITER_TURNS",
    19: "NAV_LOITER_TIME", 20: "NAV_RETURN_TO_LAUNCH", 21: "NAV_LAND", 22: "NAV_TAKEOFF",
    31: "NAV_LOITER_TO_ALT", 82: "NAV_SPLINE_WAYPOINT", 84: "NAV_VTOL_TAKEOFF",
    85: "NAV_VTOL_LAND", 93: "NAV_DELAY", 177: "DO_JUMP", 178: "DO_CHANGE_SPEED",
    # ignored ones, named in the warning
    80: "NAV_ROI", 112: "CONDITION_DELAY", 113: "CONDITION_CHANGE_ALT",
    114: "CONDITION_DISTANCE", 115: "CONDITION_YAW", 176: "DO_SET_MODE",
    179: "DO_SET_HOME", 181: "DO_SET_RELAY", 183: "DO_SET_SERVO", 189: "DO_LAND_START",
    195: "DO_SET_ROI_LOCATION", 197: "DO_SET_ROI_NONE", 201: "DO_SET_ROI",
    202: "DO_DIGICAM_CONFIGURE", 203: "DO_DIGICAM_CONTROL", 205: "DO_MOUNT_CONTROL",
    206: "DO_SET_CAM_TRIGG_DIST", 214: "DO_SET_CAM_TRIGG_INTERVAL", 530: "SET_CAMERA_MODE",
    531: "SET_CAMERA_ZOOM", 532: "SET_CAMERA_FOCUS", 1000: "DO_GIMBAL_MANAGER_PITCHYAW",
    2000: "IMAGE_START_CAPTURE", 2001: "IMAGE_STOP_CAPTURE", 2500: "VIDEO_START_CAPTURE",
    2501: "VIDEO_STOP_CAPTURE", 3000: "DO_VTOL_TRANSITION",
}

_WAYPOINT_CMDS = {16, 31, 82}
_POSITIONED_CMDS = {16, 17, 18, 19, 21, 22, 31, 82, 84, 85}
_FRAMES_AMSL = {0, 5}          # MAV_FRAME_GLOBAL, GLOBAL_INT
_FRAMES_RELATIVE = {3, 6}      # GLOBAL_RELATIVE_ALT(_INT)
_FRAMES_TERRAIN = {10, 11}     # GLOBAL_TERRAIN_ALT(_INT)


@dataclass(frozen=True)
class MavItem:
    """One MAVLink mission item as stored in a mission file.

    Attributes
    ----------
    seq : int
        Sequence number (the ``.waypoints`` index, the ``.plan`` doJumpId);
        the target of ``DO_JUMP``.
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
    """

    seq: int
    command: int
    frame: int
    params: tuple[float, ...]
    origin: str
    amsl_alt_above_terrain_m: float | None = None


def cmd_name(command: int) -> str:
    name = MAV_CMD_NAMES.get(command)
    return f"MAV_CMD_{name} ({command})" if name else f"MAV_CMD {command}"


def expand_jumps(items: list[MavItem], *, where: str) -> list[MavItem]:
    """Expand ``DO_JUMP`` items (param1 target seq, param2 repeat count).

    Raises
    ------
    InputError
        A jump to a missing target, a negative (endless) repeat count, or more
        than :data:`MAX_JUMPS` jumps in all.
    """
    index_of = {}
    for i, item in enumerate(items):
        index_of.setdefault(item.seq, i)
    done: dict[int, int] = {}
    out: list[MavItem] = []
    jumps = 0
    i = 0
    while i < len(items):
        item = items[i]
        if item.command != 177:
            out.append(item)
            i += 1
            continue
        p1, p2 = item.params[0], item.params[1]
        if not (math.isfinite(p1) and math.isfinite(p2)):
            raise InputError(f"{where}: {item.origin}: DO_JUMP needs a target (param1) and a "
                             "repeat count (param2)")
        target, repeat = round(p1), round(p2)
        if target not in index_of:
            raise InputError(f"{where}: {item.origin}: DO_JUMP target {target} is not an "
                             f"item of the mission (expected one of {sorted(index_of)})")
        if repeat < 0:
            raise InputError(f"{where}: {item.origin}: DO_JUMP repeat count {repeat} repeats "
                             "for ever: the mission has no end (expected 0..100)")
        if done.get(i, 0) < repeat:
            done[i] = done.get(i, 0) + 1
            jumps += 1
            if jumps > MAX_JUMPS:
                raise InputError(f"{where}: {item.origin}: DO_JUMP expands to more than "
                                 f"{MAX_JUMPS} repeats in all (expected at most {MAX_JUMPS})")
            i = index_of[target]
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


def mav_items_to_steps(items: list[MavItem], home_alt_amsl_m: float, *, where: str,
                       vehicle_type: str | None = None) -> list[RouteStep]:
    """Turn MAVLink mission items (without home) into route steps.

    Parameters
    ----------
    items : list of MavItem
        Mission items after home, in file order.
    home_alt_amsl_m : float
        Home altitude above mean sea level, for items in the global (AMSL)
        frame. [m]
    where : str
        The file name, for messages.
    vehicle_type : {"multirotor", "fixed_wing"} or None
        For a multirotor, ``DO_CHANGE_SPEED`` is a ground speed whatever its
        speed type (ArduCopter and PX4 multicopters navigate at ground speed).

    Returns
    -------
    steps : list of RouteStep

    Raises
    ------
    InputError
        ``NAV_LOITER_UNLIM`` (unbounded), a bad ``DO_JUMP``, a navigation
        item in an unsupported frame or without a finite position, an infinite
        coordinate, an altitude outside the atmosphere model, a hold time < 0
        or above :data:`MAX_HOLD_S`, more than :data:`MAX_LOITER_TURNS` turns.
    """
    ignored: dict[int, list[str]] = {}
    terrain_warned = False
    steps: list[RouteStep] = []
    for item in expand_jumps(items, where=where):
        cmd, p = item.command, item.params
        origin = item.origin
        lat = lon = alt = None
        if cmd in _POSITIONED_CMDS:
            if cmd == 17:
                raise InputError(f"{where}: {origin}: {cmd_name(cmd)} loiters without end, "
                                 "so the mission has no duration (expected LOITER_TIME or "
                                 "LOITER_TURNS)")
            if any(math.isinf(v) for v in p[4:7]):
                raise InputError(f"{where}: {_label(item)}: {cmd_name(cmd)} latitude, "
                                 f"longitude, altitude {p[4]:g}, {p[5]:g}, {p[6]:g} (expected "
                                 "finite numbers)")
            if _finite(p[4]) != _finite(p[5]):
                raise InputError(f"{where}: {_label(item)}: {cmd_name(cmd)} latitude, "
                                 f"longitude {p[4]:g}, {p[5]:g} (expected both numbers, or "
                                 "both unset for the current position)")
            if _finite(p[4]) and _finite(p[5]) and not (p[4] == 0 and p[5] == 0):
                lat, lon = float(p[4]), float(p[5])
                if not (-90 <= lat <= 90 and -180 <= lon <= 180):
                    raise InputError(f"{where}: {origin}: latitude/longitude {lat:g}, {lon:g} "
                                     "out of range (expected -90..90, -180..180 degrees)")
            if not _finite(p[6]):
                if cmd not in (21, 85):
                    raise InputError(f"{where}: {origin}: {cmd_name(cmd)} altitude is "
                                     f"{p[6]!r} (expected a number)")
            elif cmd not in (21, 85):
                if item.frame in _FRAMES_RELATIVE:
                    alt = float(p[6])
                elif item.frame in _FRAMES_AMSL:
                    alt = float(p[6]) - home_alt_amsl_m
                elif item.frame in _FRAMES_TERRAIN:
                    if _finite(item.amsl_alt_above_terrain_m):
                        alt = float(item.amsl_alt_above_terrain_m) - home_alt_amsl_m
                    else:
                        alt = float(p[6])
                        if not terrain_warned:
                            warnings.warn(f"{where}: {origin}: terrain-relative altitude "
                                          "treated as relative to home", stacklevel=2)
                            terrain_warned = True
                else:
                    raise InputError(f"{where}: {origin}: frame {item.frame} not supported for "
                                     f"{cmd_name(cmd)} (expected 0 global, 3 relative or 10 "
                                     "terrain)")
                problem = altitude_problem(alt, home_alt_amsl_m)
                if problem:
                    ref = ("above mean sea level" if item.frame in _FRAMES_AMSL
                           else "above home" if item.frame in _FRAMES_RELATIVE
                           else "above terrain")
                    raise InputError(f"{where}: {_label(item)}: {cmd_name(cmd)} altitude "
                                     f"{p[6]:g} m (frame {item.frame}, {ref}) {problem}")
                if lat is None and item.frame in _FRAMES_RELATIVE and p[6] == 0:
                    alt = None  # "here, at the current altitude"
        if cmd in _WAYPOINT_CMDS:
            hold = None
            if cmd != 31 and not math.isnan(p[0]):   # NaN (null): no hold
                problem = hold_problem(p[0], "param1 (hold time)")
                if problem:
                    raise InputError(f"{where}: {_label(item)}: {cmd_name(cmd)} {problem}")
                hold = float(p[0]) if p[0] > 0 else None
            steps.append(RouteStep("waypoint", lat, lon, alt, hold_s=hold, origin=origin))
        elif cmd in (18, 19):
            if not _finite(p[0]) or p[0] < 0:
                what = "turns" if cmd == 18 else "seconds"
                raise InputError(f"{where}: {origin}: {cmd_name(cmd)} param1 ({what}) must be "
                                 f">= 0, got {p[0]!r}")
            if cmd == 19 and hold_problem(p[0]):
                raise InputError(f"{where}: {_label(item)}: {cmd_name(cmd)} "
                                 f"{hold_problem(p[0], 'param1 (loiter time)')}")
            if cmd == 18 and p[0] > MAX_LOITER_TURNS:
                raise InputError(f"{where}: {_label(item)}: {cmd_name(cmd)} param1 (turns) "
                                 f"{p[0]:g} is out of range (expected 0 to {MAX_LOITER_TURNS}, "
                                 "the most ArduPilot stores)")
            radius = abs(float(p[2])) if _finite(p[2]) and p[2] != 0 else None
            steps.append(RouteStep("loiter", lat, lon, alt, radius_m=radius, origin=origin,
                                   turns=float(p[0]) if cmd == 18 else None,
                                   duration_s=float(p[0]) if cmd == 19 else None))
        elif cmd in (22, 84):
            steps.append(RouteStep("takeoff", alt_m=alt, origin=origin))
        elif cmd == 20:
            steps.append(RouteStep("rtl", origin=origin))
        elif cmd in (21, 85):
            steps.append(RouteStep("land", lat, lon, origin=origin))
        elif cmd == 93:
            if math.isnan(p[0]) or p[0] == -1:   # -1: wait for a time of day, not modelled
                ignored.setdefault(cmd, []).append(origin)
                continue
            problem = hold_problem(p[0], "param1 (delay)")
            if problem:
                raise InputError(f"{where}: {_label(item)}: {cmd_name(cmd)} {problem[:-1]}, "
                                 "or -1 for a time of day)")
            steps.append(RouteStep("hold", duration_s=float(p[0]), origin=origin))
        elif cmd == 178:
            kind = int(p[0]) if _finite(p[0]) else 0
            if not _finite(p[1]) or p[1] <= 0:  # -1 (or 0): no change
                continue
            if p[1] > MAX_SPEED_MS:
                raise InputError(f"{where}: {_label(item)}: {cmd_name(cmd)} speed {p[1]:g} m/s; "
                                 f"expected at most {MAX_SPEED_MS:g} m/s (or -1 for no change)")
            if kind in (0, 1):
                airspeed = kind == 0 and vehicle_type != "multirotor"
                steps.append(RouteStep("speed", speed_ms=float(p[1]),
                                       speed_is_airspeed=airspeed, origin=origin))
            elif kind in (2, 3):
                steps.append(RouteStep("climb_rate" if kind == 2 else "descent_rate",
                                       speed_ms=float(p[1]), origin=origin))
            else:
                ignored.setdefault(cmd, []).append(origin)
        else:
            ignored.setdefault(cmd, []).append(origin)
    for cmd, origins in ignored.items():
        n = len(origins)
        warnings.warn(f"{where}: {cmd_name(cmd)} ignored ({n} item{'s' * (n > 1)}, first at "
                      f"{origins[0]})", stacklevel=2)
    return steps
