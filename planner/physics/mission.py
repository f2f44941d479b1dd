"""Mission legs: the common form every mission file is turned into.

A mission is a sequence of legs flown one after the other. Geometry is in a
local east/north frame centred on the home point (metres), altitudes are above
home (metres, up positive). Speeds left as ``None`` are filled from the
aircraft's defaults by :mod:`planner.chain.kinematics`.

Leg kinds
---------
``climb``    vertical climb (multirotor) or climbing flight (fixed-wing) from
             ``start_alt_m`` to ``end_alt_m`` at ``climb_rate_ms``.
``descend``  the same downwards (``climb_rate_ms`` is the descent rate, > 0).
``cruise``   from ``start_en_m`` to ``end_en_m``; altitude may change along it.
``hover``    hold position for ``duration_s`` (fixed-wing: flown as a loiter).
``loiter``   circle of ``loiter_radius_m`` for ``duration_s`` (multirotor:
             flown as a hover unless a radius and speed are given).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from planner.physics.units import S_PER_H
from planner.physics.wind import course_deg

LEG_KINDS = ("climb", "cruise", "hover", "loiter", "descend")

#: Most legs, waypoints or mission items a mission file may hold: a survey of a few
#: square kilometres has some hundreds; far more is an accident or hostile input, and
#: bounds the work of every command. Key paths in messages count from 1, as the
#: tables' rows do.
MAX_ITEMS = 10_000
#: Longest total flight time the planner simulates (the legs at their planned speeds);
#: beyond it a mission is refused, which bounds the memory of the time-stepped battery
#: models. [s]
MAX_FLIGHT_S = 24 * S_PER_H


def too_many(where: str, what: str, n: int) -> str | None:
    """The message refusing ``n`` ``what`` (legs, waypoints, items), or None."""
    if n > MAX_ITEMS:
        return (f"{where}: {n} {what}, more than a mission file may hold (at most "
                f"{MAX_ITEMS})")
    return None


@dataclass(frozen=True)
class Leg:
    """One leg of a mission.

    Attributes
    ----------
    kind : str
        One of :data:`LEG_KINDS`.
    start_en_m, end_en_m : tuple of float
        Start and end position, east and north of home. [m]
    start_alt_m, end_alt_m : float
        Start and end altitude above home. [m]
    speed_ms : float or None
        Commanded horizontal speed; ``None`` = aircraft default. [m/s]
    speed_is_airspeed : bool or None
        ``True``: ``speed_ms`` is an airspeed (fixed-wing, ``airspeed_ms``);
        ``False``: a ground speed (``groundspeed_ms``, multirotor waypoint
        navigation); ``None``: the aircraft type decides (fixed-wing airspeed,
        multirotor ground speed).
    climb_rate_ms : float or None
        Vertical speed magnitude for ``climb``/``descend``; ``None`` = aircraft
        default. [m/s]
    duration_s : float or None
        Hold time of ``hover``/``loiter``. [s]
    loiter_radius_m : float or None
        Turn radius of a ``loiter``. [m]
    origin : str
        Where the leg came from, for messages (``"legs[3]"``, ``"line 7"``).
    item : int or None
        Index of the mission-file item the leg flies, in the reader's list of the items
        as flown (``Mission.file``; a ``DO_JUMP`` repeat is a new index); ``None`` for a
        leg the planner made (a sortie's transit) or a YAML leg. Lets a sortie be
        written back with the file's own items.
    """

    kind: str
    start_en_m: tuple[float, float] = (0.0, 0.0)
    end_en_m: tuple[float, float] = (0.0, 0.0)
    start_alt_m: float = 0.0
    end_alt_m: float = 0.0
    speed_ms: float | None = None
    speed_is_airspeed: bool | None = None
    climb_rate_ms: float | None = None
    duration_s: float | None = None
    loiter_radius_m: float | None = None
    origin: str = ""
    item: int | None = None

    @property
    def distance_m(self) -> float:
        """Horizontal distance from start to end. [m]"""
        return float(np.hypot(self.end_en_m[0] - self.start_en_m[0],
                              self.end_en_m[1] - self.start_en_m[1]))

    @property
    def course_deg(self) -> float:
        """Direction of travel over ground, 0 = north, clockwise. [deg]"""
        return float(course_deg(self.end_en_m[0] - self.start_en_m[0],
                                self.end_en_m[1] - self.start_en_m[1]))

    def with_(self, **changes) -> Leg:
        """A copy of the leg with some fields changed."""
        return replace(self, **changes)


@dataclass(frozen=True)
class Environment:
    """Weather and site for a mission.

    Attributes
    ----------
    wind_speed_ms : float
        Steady horizontal wind speed. [m/s]
    wind_from_deg : float
        Direction the wind blows *from*, 0 = north, clockwise. [deg]
    temperature_c : float or None
        Outside air temperature at the site; ``None`` = ISA. [°C]
    pressure_pa : float or None
        Measured static pressure at the site; ``None`` = ISA from altitude. [Pa]
    site_altitude_m : float
        Altitude of home above mean sea level. [m]
    """

    wind_speed_ms: float = 0.0
    wind_from_deg: float = 0.0
    temperature_c: float | None = None
    pressure_pa: float | None = None
    site_altitude_m: float = 0.0


@dataclass
class Mission:
    """A mission: legs, environment and payload.

    Attributes
    ----------
    name : str
    legs : list of Leg
    environment : Environment
    payload_kg : float
        Payload carried for the whole mission. [kg]
    home : tuple (lat_deg, lon_deg, alt_amsl_m) or None
        Home point where known (waypoint missions).
    source : str
        File the mission was read from.
    file : object or None
        What the reader kept of a waypoint file to write it back (the items as flown,
        the vehicle, firmware, geofence and rally points): a
        :class:`planner.io.mission.route.MissionFile`; ``None`` for a YAML mission.
    """

    name: str
    legs: list[Leg]
    environment: Environment = field(default_factory=Environment)
    payload_kg: float = 0.0
    home: tuple[float, float, float] | None = None
    source: str = ""
    file: Any = None


#: ArduCopter's default circle rate, ``CIRCLE_RATE`` (``AC_CIRCLE_RATE_DEFAULT``,
#: libraries/AC_WPNav/AC_Circle.h). [deg/s]
CIRCLE_RATE_DPS = 20.0
#: ArduCopter's default circle radius, ``CIRCLE_RADIUS`` (``AC_CIRCLE_RADIUS_DEFAULT``
#: 1000 cm, AC_Circle.h), used by a ``LOITER_TURNS`` of radius 0. [m]
CIRCLE_RADIUS_M = 10.0
#: ArduCopter's default waypoint acceleration, ``WPNAV_ACCEL`` 250 cm/s² (Copter 4.1 and
#: later, libraries/AC_WPNav/AC_WPNav.h ``WPNAV_ACCELERATION``). [m/s²]
WPNAV_ACCEL_MS2 = 2.5


@dataclass(frozen=True)
class NavDefaults:
    """What the aircraft flies where a mission file does not say: its navigation defaults.

    A mission file names speeds only where it changes them (``DO_CHANGE_SPEED``); the
    firmware flies its own parameters elsewhere (ArduCopter ``WPNAV_SPEED``,
    ``WPNAV_SPEED_UP``/``_DN``; PX4 ``MPC_XY_CRUISE``, ``MPC_Z_V_AUTO_UP``/``_DN``;
    ArduPlane ``AIRSPEED_CRUISE``, ``WP_LOITER_RAD``), which the aircraft file stands for.
    The readers use them to give a loiter in turns its duration, to bound the climb of a
    leg, and the writers to fly a sortie's transit at the aircraft's own speed.

    Attributes
    ----------
    vehicle_type : {"multirotor", "fixed_wing"}
    cruise_speed_ms : float
        Horizontal speed (multirotor: ground speed; fixed-wing: airspeed). [m/s]
    climb_rate_ms, descent_rate_ms : float
        Vertical speeds, both > 0. [m/s]
    loiter_radius_m : float or None
        Fixed-wing loiter radius (ArduPlane ``WP_LOITER_RAD``). [m]
    circle_rate_dps : float
        Multirotor circle rate (ArduCopter ``CIRCLE_RATE``). [deg/s]
    circle_radius_m : float
        Multirotor circle radius of a ``LOITER_TURNS`` of radius 0 (``CIRCLE_RADIUS``). [m]
    accel_ms2 : float
        Multirotor horizontal acceleration limit (``WPNAV_ACCEL``). [m/s²]
    max_speed_ms : float or None
        The aircraft's maximum airspeed: a mission speed beyond it was typed in another
        unit where it is plausible in km/h. [m/s]
    """

    vehicle_type: str
    cruise_speed_ms: float
    climb_rate_ms: float
    descent_rate_ms: float
    loiter_radius_m: float | None = None
    circle_rate_dps: float = CIRCLE_RATE_DPS
    circle_radius_m: float = CIRCLE_RADIUS_M
    accel_ms2: float = WPNAV_ACCEL_MS2
    max_speed_ms: float | None = None

    @classmethod
    def of(cls, aircraft: Any) -> NavDefaults:
        """From an aircraft (:class:`planner.parameters.Aircraft` or any object with its
        ``type``, ``cruise_speed_ms``, ``climb_rate_ms``, ``descent_rate_ms`` and, for a
        fixed-wing aircraft, ``fixed_wing.loiter_radius_m``)."""
        fw = getattr(aircraft, "fixed_wing", None)
        return cls(vehicle_type=aircraft.type, cruise_speed_ms=float(aircraft.cruise_speed_ms),
                   climb_rate_ms=float(aircraft.climb_rate_ms),
                   descent_rate_ms=float(aircraft.descent_rate_ms),
                   loiter_radius_m=(float(fw.loiter_radius_m) if fw is not None
                                    and getattr(fw, "loiter_radius_m", None) else None),
                   max_speed_ms=(float(aircraft.max_airspeed_ms)
                                 if getattr(aircraft, "max_airspeed_ms", None) else None))
