"""Mission + aircraft + environment → per-leg kinematics and power profile.

Part of the mission chain (``docs/architecture.md``). Everything here is vectorised over legs
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
from planner.physics.power.fixed_wing import bank_load_factor
from planner.parameters import Aircraft
from planner.physics.units import S_PER_H
from planner.physics.wind import capped_groundspeed, course_deg, wind_triangle, wind_vector

#: Points per leg at which the return-home reserve is checked.
RTL_POINTS_PER_LEG = 5


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


class _LegPlan:
    """The legs of a mission as planned, as columns (SI units), and what the steps of
    :func:`leg_table` work out from them: the airspeed, ground speed, duration, climb
    rate and load factor of every leg, the problems and the notes.

    A leg without a speed flies the aircraft's cruise speed (a multirotor's a ground
    speed, a fixed-wing aircraft's an airspeed, unless the leg says which).
    """

    def __init__(self, legs, aircraft: Aircraft):
        n = len(legs)
        self.kind = np.array([leg.kind for leg in legs], dtype=object)
        unknown = set(self.kind) - set(LEG_KINDS)
        if unknown:
            raise ValueError(f"unknown leg kinds {sorted(unknown)}")
        self.start = np.array([leg.start_en_m for leg in legs], float).reshape(n, 2)
        self.end = np.array([leg.end_en_m for leg in legs], float).reshape(n, 2)
        self.alt0, self.alt1 = _column(legs, "start_alt_m", 0.0), _column(legs, "end_alt_m", 0.0)
        self.given_speed = _column(legs, "speed_ms")
        self.speed = np.where(np.isnan(self.given_speed), aircraft.cruise_speed_ms,
                              self.given_speed)
        is_air = np.array([np.nan if leg.speed_is_airspeed is None
                           else float(leg.speed_is_airspeed) for leg in legs])
        self.is_air = np.where(np.isnan(is_air), 0.0 if aircraft.is_multirotor else 1.0,
                               is_air).astype(bool)
        self.rate, self.hold = _column(legs, "climb_rate_ms"), _column(legs, "duration_s", 0.0)
        self.radius = _column(legs, "loiter_radius_m")
        delta = self.end - self.start
        self.distance = np.hypot(delta[:, 0], delta[:, 1])
        self.course = course_deg(delta[:, 0], delta[:, 1])
        self.airspeed = np.full(n, np.nan)
        self.ground, self.duration, self.climb = np.zeros(n), np.zeros(n), np.zeros(n)
        self.load = np.ones(n)
        self.problems: list[tuple[int, str]] = []
        self.notes: list[str] = []


def leg_table(mission: Mission, aircraft: Aircraft, environment: Environment | None = None,
              *, temperature_c: float | None = None) -> LegTable:
    """Kinematics of every leg: times, speeds, climb rates, density.

    The steps: the legs as columns; cruise legs through the wind triangle
    (:func:`_cruise`); climbs and descents (:func:`_vertical`); holds; then a
    multirotor's hover and circles (:func:`_multirotor_holds`) or a fixed-wing
    aircraft's circles (:func:`_fixed_wing_circles`); the air density at each leg.

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

    Raises
    ------
    InputError
        The legs take longer than :data:`~planner.physics.mission.MAX_FLIGHT_S`.
    """
    env = environment or mission.environment
    plan = _LegPlan(mission.legs, aircraft)
    if not aircraft.is_multirotor:  # fixed-wing holds position by circling
        plan.kind = np.where(plan.kind == "hover", "loiter", plan.kind)
    _cruise(plan, aircraft, env)
    _vertical(plan, aircraft)
    holding = (plan.kind == "hover") | (plan.kind == "loiter")
    plan.duration = np.where(holding, plan.hold, plan.duration)
    if aircraft.is_multirotor:
        _multirotor_holds(plan, aircraft, env)
    else:
        _fixed_wing_circles(plan, aircraft, env)
    total = float(np.nansum(plan.duration))
    if total > MAX_FLIGHT_S:
        raise InputError(f"{mission.source or mission.name}: the legs take {total / S_PER_H:.1f} h "
                         f"at their planned speeds, longer than the planner simulates (at most "
                         f"{MAX_FLIGHT_S / S_PER_H:.0f} h of flight)")
    n = len(plan.kind)
    amsl = env.site_altitude_m + 0.5 * (plan.alt0 + plan.alt1)
    rho = np.broadcast_to(np.asarray(air_density_at(amsl, env, temperature_c), float), (n,))
    return LegTable(kind=np.asarray(plan.kind), origin=[leg.origin for leg in mission.legs],
                    duration_s=np.nan_to_num(plan.duration, nan=0.0),
                    distance_m=plan.distance, course_deg=plan.course,
                    airspeed_ms=np.nan_to_num(plan.airspeed, nan=0.0),
                    groundspeed_ms=np.nan_to_num(plan.ground, nan=0.0),
                    climb_rate_ms=plan.climb, load_factor=plan.load, air_density=rho.copy(),
                    start_en_m=plan.start, end_en_m=plan.end, start_alt_m=plan.alt0,
                    end_alt_m=plan.alt1, problems=plan.problems, notes=plan.notes)


def _cruise(plan: _LegPlan, aircraft: Aircraft, env: Environment) -> None:
    """Cruise legs: the wind triangle along the track (a ground speed held up to the
    maximum airspeed, or an airspeed), the time over the distance, the climb rate of a
    leg that changes altitude; a leg the wind does not let the aircraft fly is a
    problem."""
    cruise = plan.kind == "cruise"
    w_e, w_n = wind_vector(env.wind_speed_ms, env.wind_from_deg)
    vmax = aircraft.max_airspeed_ms
    va_air, gs_air = wind_triangle(plan.course, w_e, w_n, airspeed=plan.speed)
    va_gnd, gs_gnd, capped = capped_groundspeed(plan.course, w_e, w_n, plan.speed, vmax)
    over = ~plan.is_air & capped                     # cannot hold the ground speed
    va = np.where(plan.is_air, va_air, va_gnd)
    gs = np.where(plan.is_air, gs_air, gs_gnd)
    short = plan.distance < 1e-6
    gs = np.where(cruise & short, np.where(np.isnan(gs), 0.0, gs), gs)
    bad = cruise & ~short & ~(gs > 0)
    for i in np.flatnonzero(bad):
        plan.problems.append((int(i), f"wind {float(env.wind_speed_ms):.1f} m/s from "
                                      f"{env.wind_from_deg:.0f}° is stronger than the "
                                      f"aircraft can fly on course {plan.course[i]:.0f}° "
                                      f"(max airspeed {vmax:.1f} m/s)"))
    slowed = np.flatnonzero(cruise & over & ~bad)
    if slowed.size:
        plan.notes.append(f"{slowed.size} leg(s) flown at the maximum airspeed {vmax:.1f} "
                          "m/s: the headwind lowers the ground speed below the commanded one")
    gs_ok = np.where(bad, np.nan, gs)
    with np.errstate(divide="ignore", invalid="ignore"):
        t_cruise = np.where(short, 0.0, plan.distance / gs_ok)
    plan.airspeed = np.where(cruise, va, plan.airspeed)
    plan.ground = np.where(cruise, gs_ok, plan.ground)
    plan.duration = np.where(cruise, t_cruise, plan.duration)
    with np.errstate(divide="ignore", invalid="ignore"):
        plan.climb = np.where(cruise & (plan.duration > 0),
                              (plan.alt1 - plan.alt0) / plan.duration, plan.climb)


def _vertical(plan: _LegPlan, aircraft: Aircraft) -> None:
    """Climb and descent legs: at the leg's rate, else the aircraft's."""
    vertical = (plan.kind == "climb") | (plan.kind == "descend")
    dalt = plan.alt1 - plan.alt0
    default_rate = np.where(dalt >= 0, aircraft.climb_rate_ms, aircraft.descent_rate_ms)
    vrate = np.where(np.isnan(plan.rate), default_rate, np.abs(plan.rate))
    plan.duration = np.where(vertical, np.abs(dalt) / vrate, plan.duration)
    plan.climb = np.where(vertical, np.sign(dalt) * vrate, plan.climb)


def _multirotor_holds(plan: _LegPlan, aircraft: Aircraft, env: Environment) -> None:
    """A multirotor holds position in the wind (its airspeed is the wind speed) on
    climbs, descents, hovers and loiters without a radius, and circles at its ground
    speed in a loiter with one; a wind above its maximum airspeed is a problem."""
    wind = float(env.wind_speed_ms)
    vertical = (plan.kind == "climb") | (plan.kind == "descend")
    loiter = plan.kind == "loiter"
    still = vertical | (plan.kind == "hover") | (loiter & (np.isnan(plan.radius)))
    plan.airspeed = np.where(still, wind, plan.airspeed)
    plan.ground = np.where(still, 0.0, plan.ground)
    # a multirotor circling at ground speed V in wind W: mean-square airspeed V² + W²
    circling = loiter & ~np.isnan(plan.radius)
    plan.airspeed = np.where(circling, np.sqrt(plan.speed**2 + wind**2), plan.airspeed)
    plan.ground = np.where(circling, plan.speed, plan.ground)
    vmax = aircraft.max_airspeed_ms
    if wind > vmax and np.any(still | circling):
        i = int(np.flatnonzero(still | circling)[0])
        plan.problems.append((i, f"wind {wind:.1f} m/s is above the aircraft's maximum "
                                 f"airspeed {vmax:.1f} m/s: it cannot hold position"))


def _fixed_wing_circles(plan: _LegPlan, aircraft: Aircraft, env: Environment) -> None:
    """A fixed-wing aircraft flies climbs, descents and loiters as circles of the loiter
    radius at its loiter airspeed, with the load factor of the banked turn; below the
    stall speed in the turn, or in a wind not below that airspeed, is a problem."""
    fw, wind = aircraft.fixed_wing, float(env.wind_speed_ms)
    loiter = plan.kind == "loiter"
    circle = (plan.kind == "climb") | (plan.kind == "descend") | loiter
    r = np.where(np.isnan(plan.radius), fw.loiter_radius_m, plan.radius)
    v_loiter = fw.loiter_airspeed_ms or fw.cruise_airspeed_ms
    v_circ = np.where(loiter & ~np.isnan(plan.given_speed), plan.speed, v_loiter)
    plan.airspeed = np.where(circle, v_circ, plan.airspeed)
    plan.ground = np.where(circle, v_circ, plan.ground)
    plan.load = np.where(circle, bank_load_factor(plan.airspeed, r), plan.load)
    if fw.stall_speed_ms is not None:
        stall = fw.stall_speed_ms * np.sqrt(plan.load)  # stall speed rises in a turn
        for i in np.flatnonzero(plan.airspeed < stall):
            plan.problems.append((int(i), f"airspeed {plan.airspeed[i]:.1f} m/s is below the "
                                          f"stall speed {stall[i]:.1f} m/s"))
    wind_max = np.flatnonzero(circle & (wind >= plan.airspeed))
    if wind_max.size:
        plan.problems.append((int(wind_max[0]), f"wind {wind:.1f} m/s is not below the "
                                                "loiter airspeed: the aircraft drifts away"))


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
    return v, float(bank_load_factor(v, fw.loiter_radius_m))


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
    course = course_deg(-pos[:, 0], -pos[:, 1])
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
