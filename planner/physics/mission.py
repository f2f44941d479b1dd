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
    """

    name: str
    legs: list[Leg]
    environment: Environment = field(default_factory=Environment)
    payload_kg: float = 0.0
    home: tuple[float, float, float] | None = None
    source: str = ""
