"""Mission + aircraft + environment → per-leg kinematics and power profile.

Layer 3 of the planner (DESIGN §2). Everything here is vectorised over legs
(and, for pack selection, over take-off masses): the legs of a mission become
columns of a :class:`LegTable`, and no step loops over legs or samples.

Wind enters through the wind triangle: airspeed drives power, ground speed
drives leg time. A multirotor holds its commanded *ground* speed (ArduPilot
WPNAV_SPEED, PX4 MPC_XY_CRUISE) up to its maximum airspeed, beyond which it
flies at that airspeed and its ground speed drops; a fixed-wing aircraft holds
its commanded *airspeed*. Hovering in wind costs forward-flight power at an
airspeed equal to the wind speed. Fixed-wing aircraft fly ``hover`` legs, and
``climb``/``descend`` legs, as circles of the loiter radius over the point,
with the load factor of the banked turn.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from planner.physics import atmosphere
from planner.errors import InputError
from planner.physics.mission import LEG_KINDS, MAX_FLIGHT_S, Environment, Mission
from planner.parameters import Aircraft
from planner.physics.wind import capped_groundspeed, wind_triangle, wind_vector

#: Points per leg at which the return-home reserve is checked.
RTL_POINTS_PER_LEG = 5
#: ISA temperature lapse rate and gravity, re-exported for the layers above.
LAPSE_RATE = atmosphere.LAPSE_RATE
G = atmosphere.G


@dataclass
class LegTable:
    """Per-leg kinematics of a mission (one array element per leg).

    Attributes
    ----------
    kind : ndarray of str
        Leg kind as flown (fixed-wing ``hover`` → ``loiter``).
    origin : list of str
        Where each leg came from in the mission file.
    duration_s : ndarray
        [s]
    distance_m : ndarray
        Horizontal distance over ground. [m]
    course_deg : ndarray
        Track over ground. [deg]
    airspeed_ms, groundspeed_ms : ndarray
        [m/s]
    climb_rate_ms : ndarray
        Vertical speed, up positive. [m/s]
    load_factor : ndarray
        Lift over weight (banked turns). [unitless]
    air_density : ndarray
        At the leg's mean altitude. [kg m⁻³]
    start_en_m, end_en_m : ndarray, shape (n, 2)
        Positions east/north of home. [m]
    start_alt_m, end_alt_m : ndarray
        Altitudes above home. [m]
    start_time_s, end_time_s : ndarray
        [s]
    problems : list of (int, str)
        Legs the aircraft cannot fly, with the reason (NO-GO).
    notes : list of str
        Things the user should know (ground speed reduced, …).
    """

    kind: np.ndarray
    origin: list[str]
    duration_s: np.ndarray
    distance_m: np.ndarray
    course_deg: np.ndarray
    airspeed_ms: np.ndarray
    groundspeed_ms: np.ndarray
    climb_rate_ms: np.ndarray
    load_factor: np.ndarray
    air_density: np.ndarray
    start_en_m: np.ndarray
    end_en_m: np.ndarray
    start_alt_m: np.ndarray
    end_alt_m: np.ndarray
    start_time_s: np.ndarray = field(init=False)
    end_time_s: np.ndarray = field(init=False)
    problems: list[tuple[int, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def __post_init__(self):
        self.end_time_s = np.cumsum(self.duration_s)
        self.start_time_s = self.end_time_s - self.duration_s

    def __len__(self) -> int:
        return len(self.kind)


def air_density_at(altitude_amsl_m, environment: Environment, temperature_c=None):
    """Air density at altitude in a mission's environment (:func:`atmosphere.site_density`).

    ``temperature_c`` (``--temperature``) overrides the environment's site temperature.
    [kg m⁻³]
    """
    t_site = temperature_c if temperature_c is not None else environment.temperature_c
    return atmosphere.site_density(altitude_amsl_m, environment.site_altitude_m, t_site,
                                   environment.pressure_pa)


def _column(legs, name, default=np.nan):
    return np.array([default if getattr(leg, name) is None else getattr(leg, name)
                     for leg in legs], dtype=float)


def leg_table(mission: Mission, aircraft: Aircraft, environment: Environment | None = None,
              *, temperature_c: float | None = None) -> LegTable:
    """Kinematics of every leg: times, speeds, climb rates, density.

    Parameters
    ----------
    mission : Mission
    aircraft : Aircraft
    environment : Environment, optional
        Overrides the mission's own environment (``--wind`` on the CLI).
    temperature_c : float, optional
        Outside air temperature at the site (``--temperature``). [°C]

    Returns
    -------
    LegTable
    """
    env = environment or mission.environment
    legs = mission.legs
    n = len(legs)
    kind = np.array([leg.kind for leg in legs], dtype=object)
    unknown = set(kind) - set(LEG_KINDS)
    if unknown:
        raise ValueError(f"unknown leg kinds {sorted(unknown)}")
    start = np.array([leg.start_en_m for leg in legs], dtype=float).reshape(n, 2)
    end = np.array([leg.end_en_m for leg in legs], dtype=float).reshape(n, 2)
    alt0 = _column(legs, "start_alt_m", 0.0)
    alt1 = _column(legs, "end_alt_m", 0.0)
    speed = _column(legs, "speed_ms")
    is_air = np.array([np.nan if leg.speed_is_airspeed is None else float(leg.speed_is_airspeed)
                       for leg in legs])
    rate = _column(legs, "climb_rate_ms")
    hold = _column(legs, "duration_s", 0.0)
    radius = _column(legs, "loiter_radius_m")

    mr = aircraft.is_multirotor
    fw = aircraft.fixed_wing
    w_e, w_n = wind_vector(env.wind_speed_ms, env.wind_from_deg)
    wind = float(env.wind_speed_ms)
    vmax = aircraft.max_airspeed_ms
    speed = np.where(np.isnan(speed), aircraft.cruise_speed_ms, speed)
    is_air = np.where(np.isnan(is_air), 0.0 if mr else 1.0, is_air).astype(bool)

    delta = end - start
    dist = np.hypot(delta[:, 0], delta[:, 1])
    course = np.degrees(np.arctan2(delta[:, 0], delta[:, 1])) % 360.0
    dalt = alt1 - alt0

    cruise = kind == "cruise"
    vertical = (kind == "climb") | (kind == "descend")
    hover = kind == "hover"
    loiter = kind == "loiter"
    if not mr:  # fixed-wing holds position by circling
        kind = np.where(hover, "loiter", kind)
        loiter, hover = loiter | hover, np.zeros(n, bool)

    airspeed = np.full(n, np.nan)
    ground = np.zeros(n)
    duration = np.zeros(n)
    climb = np.zeros(n)
    load = np.ones(n)
    problems: list[tuple[int, str]] = []
    notes: list[str] = []

    # -- cruise: wind triangle along the track
    va_air, gs_air = wind_triangle(course, w_e, w_n, airspeed=speed)
    va_gnd, gs_gnd, capped = capped_groundspeed(course, w_e, w_n, speed, vmax)
    over = ~is_air & capped                     # cannot hold the ground speed
    va = np.where(is_air, va_air, va_gnd)
    gs = np.where(is_air, gs_air, gs_gnd)
    short = dist < 1e-6
    gs = np.where(cruise & short, np.where(np.isnan(gs), 0.0, gs), gs)
    bad = cruise & ~short & ~(gs > 0)
    for i in np.flatnonzero(bad):
        problems.append((int(i), f"wind {wind:.1f} m/s from {env.wind_from_deg:.0f}° is "
                                 f"stronger than the aircraft can fly on course "
                                 f"{course[i]:.0f}° (max airspeed {vmax:.1f} m/s)"))
    slowed = np.flatnonzero(cruise & over & ~bad)
    if slowed.size:
        notes.append(f"{slowed.size} leg(s) flown at the maximum airspeed {vmax:.1f} m/s: "
                     "the headwind lowers the ground speed below the commanded one")
    gs_ok = np.where(bad, np.nan, gs)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_cruise = np.where(short, 0.0, dist / gs_ok)
    airspeed = np.where(cruise, va, airspeed)
    ground = np.where(cruise, gs_ok, ground)
    duration = np.where(cruise, t_cruise, duration)
    with np.errstate(divide="ignore", invalid="ignore"):
        climb = np.where(cruise & (duration > 0), dalt / duration, climb)

    # -- vertical legs
    default_rate = np.where(dalt >= 0, aircraft.climb_rate_ms, aircraft.descent_rate_ms)
    vrate = np.where(np.isnan(rate), default_rate, np.abs(rate))
    t_vert = np.abs(dalt) / vrate
    duration = np.where(vertical, t_vert, duration)
    climb = np.where(vertical, np.sign(dalt) * vrate, climb)

    # -- holds
    duration = np.where(hover | loiter, hold, duration)

    if mr:
        still = vertical | hover | (loiter & (np.isnan(radius)))
        airspeed = np.where(still, wind, airspeed)
        ground = np.where(still, 0.0, ground)
        # a multirotor circling at ground speed V in wind W: mean-square airspeed V² + W²
        circling = loiter & ~np.isnan(radius)
        airspeed = np.where(circling, np.sqrt(speed**2 + wind**2), airspeed)
        ground = np.where(circling, speed, ground)
        if wind > vmax and np.any(still | circling):
            i = int(np.flatnonzero(still | circling)[0])
            problems.append((i, f"wind {wind:.1f} m/s is above the aircraft's maximum "
                                f"airspeed {vmax:.1f} m/s: it cannot hold position"))
    else:
        circle = vertical | loiter
        r = np.where(np.isnan(radius), fw.loiter_radius_m, radius)
        v_loiter = fw.loiter_airspeed_ms or fw.cruise_airspeed_ms
        v_circ = np.where(loiter & ~np.isnan(_column(legs, "speed_ms")), speed, v_loiter)
        airspeed = np.where(circle, v_circ, airspeed)
        ground = np.where(circle, v_circ, ground)
        load = np.where(circle, np.sqrt(1.0 + (airspeed**2 / (G * r)) ** 2), load)
        if fw.stall_speed_ms is not None:
            stall = fw.stall_speed_ms * np.sqrt(load)  # stall speed rises in a turn
            for i in np.flatnonzero(airspeed < stall):
                problems.append((int(i), f"airspeed {airspeed[i]:.1f} m/s is below the "
                                         f"stall speed {stall[i]:.1f} m/s"))
        wind_max = np.flatnonzero(circle & (wind >= airspeed))
        if wind_max.size:
            problems.append((int(wind_max[0]), f"wind {wind:.1f} m/s is not below the "
                                               "loiter airspeed: the aircraft drifts away"))

    total = float(np.nansum(duration))
    if total > MAX_FLIGHT_S:
        raise InputError(f"{mission.source or mission.name}: the legs take {total / 3600:.1f} h "
                         f"at their planned speeds, longer than the planner simulates (at most "
                         f"{MAX_FLIGHT_S / 3600:.0f} h of flight)")
    amsl = env.site_altitude_m + 0.5 * (alt0 + alt1)
    rho = np.broadcast_to(np.asarray(air_density_at(amsl, env, temperature_c), float), (n,))
    return LegTable(kind=np.asarray(kind), origin=[leg.origin for leg in legs],
                    duration_s=np.nan_to_num(duration, nan=0.0), distance_m=dist,
                    course_deg=course, airspeed_ms=np.nan_to_num(airspeed, nan=0.0),
                    groundspeed_ms=np.nan_to_num(ground, nan=0.0), climb_rate_ms=climb,
                    load_factor=load, air_density=rho.copy(), start_en_m=start, end_en_m=end,
                    start_alt_m=alt0, end_alt_m=alt1, problems=problems, notes=notes)


def leg_power(table: LegTable, aircraft: Aircraft, mass_kg):
    """Battery power of every leg. ``mass_kg`` may be an array of shape (k, 1). [W]"""
    return aircraft.battery_power(table.airspeed_ms, table.climb_rate_ms, table.air_density,
                                  mass_kg, load_factor=table.load_factor)


def hold_state(aircraft: Aircraft, air_density, wind_speed_ms=0.0):
    """Flight state of holding position: ``(airspeed, climb_rate, air_density,
    load_factor)``.

    A multirotor hovers (its airspeed is the wind speed); a fixed-wing aircraft flies its
    default loiter circle (:func:`loiter_state`).
    """
    if aircraft.is_multirotor:
        return (float(wind_speed_ms), 0.0, air_density, 1.0)
    v, n = loiter_state(aircraft)
    return (v, 0.0, air_density, n)


def hold_power(aircraft: Aircraft, mass_kg, air_density, wind_speed_ms=0.0):
    """Power to hold position: hover (multirotor) or loiter (fixed-wing). [W]

    The figure behind the margin "as extra hover or loiter time".
    """
    v, climb, rho, n = hold_state(aircraft, air_density, wind_speed_ms)
    return aircraft.battery_power(v, climb, rho, mass_kg, load_factor=n)


def loiter_state(aircraft: Aircraft) -> tuple[float, float]:
    """Airspeed [m/s] and load factor of a fixed-wing aircraft's default loiter circle."""
    fw = aircraft.fixed_wing
    v = fw.loiter_airspeed_ms or fw.cruise_airspeed_ms
    return v, float(np.sqrt(1.0 + (v**2 / (G * fw.loiter_radius_m)) ** 2))


def return_home_points(table: LegTable, aircraft: Aircraft, env: Environment, temp):
    """Geometry and flight states of the return-home points along a mission.

    :data:`RTL_POINTS_PER_LEG` points on every leg; from each, the aircraft flies
    straight home at its cruise speed (a multirotor holds ground speed up to its
    maximum airspeed, a fixed-wing aircraft airspeed) at its current altitude, then
    descends over home (a fixed-wing aircraft in a loiter circle).

    Returns the points' leg, fraction along the leg, time, position, distance home and
    the two flight states (straight back at cruise speed, descent at home) with their
    durations; none depends on the pack.
    """
    ac = aircraft
    n = len(table)
    f = np.linspace(0.0, 1.0, RTL_POINTS_PER_LEG)
    pos = table.start_en_m[:, None, :] + f[None, :, None] * (
        table.end_en_m - table.start_en_m)[:, None, :]
    alt = table.start_alt_m[:, None] + f * (table.end_alt_m - table.start_alt_m)[:, None]
    time = table.start_time_s[:, None] + f * table.duration_s[:, None]
    pos, alt, time = pos.reshape(-1, 2), alt.ravel(), time.ravel()
    leg_of = np.repeat(np.arange(n), len(f))
    frac = np.tile(f, n)

    dist = np.hypot(pos[:, 0], pos[:, 1])
    course = np.degrees(np.arctan2(-pos[:, 0], -pos[:, 1])) % 360.0
    w_e, w_n = wind_vector(env.wind_speed_ms, env.wind_from_deg)
    if ac.is_multirotor:
        va, gs, _ = capped_groundspeed(course, w_e, w_n, np.full(dist.shape, ac.cruise_speed_ms),
                                       ac.max_airspeed_ms)
    else:
        va, gs = wind_triangle(course, w_e, w_n,
                                    airspeed=np.full(dist.shape, ac.cruise_speed_ms))
    alt_pos = np.maximum(alt, 0.0)
    rho = np.broadcast_to(np.asarray(
        air_density_at(env.site_altitude_m + alt_pos, env, temp), float), dist.shape)
    home = dist < 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        t_back = np.where(home, 0.0, dist / gs)
    va = np.where(home | ~np.isfinite(va), ac.cruise_speed_ms, va)
    t_down = alt_pos / ac.descent_rate_ms
    if ac.is_multirotor:
        down = (np.full(dist.shape, float(env.wind_speed_ms)), -ac.descent_rate_ms, rho, 1.0)
    else:
        v, nload = loiter_state(ac)
        down = (np.full(dist.shape, float(v)), -ac.descent_rate_ms, rho, nload)
    return {"leg": leg_of, "frac": frac, "time_s": time, "east_m": pos[:, 0],
            "north_m": pos[:, 1], "altitude_m": alt, "distance_m": dist,
            "t_back": t_back, "t_down": t_down, "back": (va, 0.0, rho, 1.0), "down": down}
