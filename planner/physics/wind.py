r"""The wind triangle: airspeed, ground speed and wind, in one place.

Layer 1 of the planner (pure, vectorised functions in SI units). Every part of the
planner that relates what the aircraft does through the air to what it does over the
ground calls these functions: the mission legs of ``check`` and ``select``
(:mod:`planner.chain.kinematics`), the return-home points, and the flight state read from a log
(:mod:`planner.chain.flightstate`).

Conventions: the wind is given by the direction it blows *from* (a bearing, 0 = north,
clockwise) or as a velocity towards east and north; courses are bearings of the track
over ground.

References
----------
.. [1] R. W. Beard and T. W. McLain, *Small Unmanned Aircraft: Theory and Practice*.
   Princeton, NJ, USA: Princeton Univ. Press, 2012, sec. 2.3 (the wind triangle).
"""

from __future__ import annotations

import numpy as np

__all__ = ["airspeed_from_ground", "capped_groundspeed", "course_deg", "wind_triangle",
           "wind_vector"]


def course_deg(east, north):
    """Bearing of a track or a velocity over ground from its east and north components.

    Parameters
    ----------
    east, north : numeric
        Components (a displacement [m] or a velocity [m/s]; the unit cancels).

    Returns
    -------
    course : numeric
        0 = north, clockwise, in [0, 360); 0 for a zero vector. [deg]
    """
    return np.degrees(np.arctan2(east, north)) % 360.0


def wind_vector(wind_speed_ms, wind_from_deg):
    """Wind velocity towards east and north from its speed and the bearing it blows from.

    Parameters
    ----------
    wind_speed_ms : numeric
        [m/s]
    wind_from_deg : numeric
        Direction the wind blows from, 0 = north, clockwise. [deg]

    Returns
    -------
    wind_e, wind_n : numeric
        [m/s]
    """
    a = np.radians(wind_from_deg)
    return -wind_speed_ms * np.sin(a), -wind_speed_ms * np.cos(a)


def wind_triangle(course_deg, wind_e, wind_n, *, airspeed=None, groundspeed=None):
    r"""
    Solve the wind triangle for a track over ground.

    Give either the airspeed (find the ground speed) or the ground speed (find the
    airspeed).

    Parameters
    ----------
    course_deg : numeric
        Track over ground, 0 = north, clockwise. [deg]
    wind_e, wind_n : numeric
        Wind velocity towards east and north. [m/s]
    airspeed, groundspeed : numeric
        [m/s]

    Returns
    -------
    airspeed, groundspeed : numeric
        Ground speed is NaN where the aircraft cannot make good the track (a
        crosswind above the airspeed, or a headwind at least as strong as the
        airspeed). [m/s]

    Notes
    -----
    With :math:`w_a` the along-track and :math:`w_c` the cross-track wind ([1]_,
    sec. 2.3), :math:`V_g = w_a + \sqrt{V_a^2 - w_c^2}` and
    :math:`V_a = \sqrt{(V_g - w_a)^2 + w_c^2} = |\mathbf{V}_g - \mathbf{w}|`.
    """
    chi = np.radians(course_deg)
    along = wind_e * np.sin(chi) + wind_n * np.cos(chi)
    cross = wind_e * np.cos(chi) - wind_n * np.sin(chi)
    if groundspeed is not None:
        gs = np.asarray(groundspeed, dtype=float)
        return np.hypot(gs - along, cross), gs
    va = np.asarray(airspeed, dtype=float)
    disc = va**2 - cross**2
    with np.errstate(invalid="ignore"):
        gs = along + np.sqrt(np.where(disc >= 0, disc, np.nan))
    gs = np.where(gs > 1e-6, gs, np.nan)
    return va, gs


def airspeed_from_ground(groundspeed_ms, course_deg, wind_e, wind_n):
    """True airspeed of a measured ground velocity in a known wind. [m/s]

    The wind triangle of :func:`wind_triangle` solved for the airspeed:
    :math:`V_a = |\\mathbf{V}_g - \\mathbf{w}|`.
    """
    return wind_triangle(course_deg, wind_e, wind_n, groundspeed=groundspeed_ms)[0]


def capped_groundspeed(course_deg, wind_e, wind_n, groundspeed, max_airspeed):
    """A multirotor holding a ground speed, up to its maximum airspeed.

    Where the commanded ground speed would need more than ``max_airspeed``, the
    aircraft flies at ``max_airspeed`` and its ground speed drops (ArduCopter
    ``WPNAV_SPEED``, PX4 ``MPC_XY_CRUISE`` hold a ground speed).

    Returns
    -------
    airspeed, groundspeed : ndarray
        [m/s]
    capped : ndarray of bool
        Where the maximum airspeed limits the ground speed.
    """
    va, gs = wind_triangle(course_deg, wind_e, wind_n, groundspeed=groundspeed)
    capped = va > max_airspeed
    _, gs_cap = wind_triangle(course_deg, wind_e, wind_n,
                              airspeed=np.full(np.shape(va), max_airspeed))
    return np.where(capped, max_airspeed, va), np.where(capped, gs_cap, gs), capped
