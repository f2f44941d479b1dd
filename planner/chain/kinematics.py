r"""Mission + aircraft + environment → per-leg kinematics and power profile.

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

With the aircraft's ``navigation:`` block (:class:`~planner.parameters.Navigation`), a
multirotor flies the plan as its autopilot does (:func:`_navigate`): the take-off spins
the motors up on the ground and climbs with a vertical acceleration limit, every
straight leg is a jerk-limited move (:func:`planner.physics.motion.straight_move`: from
rest to rest when the vehicle stops at its waypoints, with a dwell there), and the
landing slows down near the ground. Each mission leg then becomes up to
:data:`NAV_SLOTS` rows of the table (empty ones dropped), each at one flight state:
accelerating and braking at the phase's mean speed with the load factor
:math:`\sqrt{1 + (a/g)^2}` of the thrust tilted to give the mean acceleration (the
kinetic energy is not recovered: a multirotor brakes with thrust). Without the block, and
for fixed-wing aircraft, the legs are flown at constant speed as before.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from planner.physics import atmosphere, motion
from planner.errors import InputError
from planner.physics.mission import LEG_KINDS, MAX_FLIGHT_S, Environment, Leg, Mission
from planner.physics.power.fixed_wing import bank_load_factor
from planner.parameters import Aircraft
from planner.physics.units import S_PER_H
from planner.physics.wind import capped_groundspeed, course_deg, wind_triangle, wind_vector

#: Points per leg at which the return-home reserve is checked.
RTL_POINTS_PER_LEG = 5

#: The rows a mission leg may become with a navigation model, in flight order: spin-up
#: (a take-off) or accelerating (a straight leg); the leg itself; braking; the slow
#: stage of a landing; the dwell at a waypoint stop.
NAV_SLOTS = ("spin-up or accelerating", "leg", "braking", "landing slow stage", "dwell")

#: Height below which a leg starts or ends on the ground (a take-off, a landing). [m]
GROUND_HEIGHT_M = 0.5

#: Load factor of the spin-up on the ground: flown at the hover state. Measured on the DJI
#: M100 flights (Rodrigues et al., Sci. Data 8, 155, 2021; power > 100 W before the
#: altitude passes 1 m, 182 flights) the median spin-up power is 0.84 of the median
#: airborne power; the power models hold a thrust of at least the weight (load factor
#: >= 1), so the spin-up is counted at hover power: about 0.1 Wh too much on an M100
#: flight of 40 Wh (0.16 × 5.4 s × 500 W).
SPINUP_LOAD_FACTOR = 1.0
#: A mission ends on the ground when its last leg ends at most this high above home; at
#: home when at most this far from it. [m]
LANDED_ALTITUDE_M = 0.5
HOME_RADIUS_M = 1.0

#: Origin of the legs the chain adds to a mission that never comes home.
ADDED_RETURN_ORIGIN = "return home (added)"


#: Altitude below home a leg may reach (rounding of a file's altitudes) before the route
#: counts as below the take-off point; change of altitude below which a cruise is level.
#: [m]
BELOW_HOME_TOLERANCE_M = 0.5
MIN_ALT_CHANGE_M = 0.01

#: Suffix of the origin of the row in which a straight leg gains its speed, and of the
#: row in which it loses it (the rows between fly the leg at constant speed).
ACCELERATING = " (accelerating)"
BRAKING = " (braking)"


def flyable_legs(mission: Mission, aircraft: Aircraft) -> tuple[Mission, str | None]:
    """The mission's legs checked and bounded as the aircraft flies them.

    * A leg that reaches below home (more than :data:`BELOW_HOME_TOLERANCE_M`) is refused:
      the route lies below the take-off point, which PX4 refuses ("Waypoint below home",
      ``MissionFeasibilityChecker::checkHomePositionAltitude``); a waypoint file says
      the ground is lower by giving those altitudes in the terrain frame (10), which its
      reader reads above the terrain, never below home.
    * A cruise leg whose change of altitude over its horizontal time (at its speed, else
      the aircraft's cruise speed) is faster than the aircraft's climb or descent rate is
      flown as a cruise changing altitude at that rate, the rest of the change over its
      end point (as the waypoint readers fly it, after ArduCopter's
      ``ModeAuto::loiter_to_alt_run``).

    Returns the mission (a new one when legs were split) and the note that says so.

    Raises
    ------
    InputError
        A leg below home: one line naming the file and the leg.
    """
    where = mission.source or mission.name
    for leg in mission.legs:
        low = min(float(leg.start_alt_m), float(leg.end_alt_m))
        if low < -BELOW_HOME_TOLERANCE_M:
            raise InputError(f"{where}: {leg.origin or 'a leg'}: altitude {low:g} m is "
                             f"{-low:g} m below home: the route lies below the take-off "
                             "point (expected altitudes at or above home, as PX4 requires: "
                             "'Waypoint below home'; over lower ground, give a waypoint "
                             "file's altitudes in the terrain frame 10)")
    out: list[Leg] = []
    split = []
    for leg in mission.legs:
        dz = float(leg.end_alt_m) - float(leg.start_alt_m)
        v = leg.speed_ms or aircraft.cruise_speed_ms
        rate = aircraft.climb_rate_ms if dz > 0 else aircraft.descent_rate_ms
        d = leg.distance_m
        if (leg.kind != "cruise" or d <= 0 or not v or not rate
                or abs(dz) <= rate * d / v + MIN_ALT_CHANGE_M):
            out.append(leg)
            continue
        mid = float(leg.start_alt_m) + np.copysign(rate * d / v, dz)
        out.append(leg.with_(end_alt_m=float(mid)))
        out.append(Leg("climb" if dz > 0 else "descend", leg.end_en_m, leg.end_en_m,
                       float(mid), float(leg.end_alt_m), origin=leg.origin, item=leg.item))
        split.append(f"{leg.origin or f'leg {len(out) - 1}'} ({abs(dz) * v / d:.1f} m/s)")
    if not split:
        return mission, None
    note = (f"{len(split)} cruise leg(s) change altitude faster than the aircraft's climb "
            f"{aircraft.climb_rate_ms:g} m/s or descent {aircraft.descent_rate_ms:g} m/s: "
            + ", ".join(split[:3]) + (" …" if len(split) > 3 else "")
            + "; flown at that rate, the rest of the change over the leg's end point")
    return Mission(name=mission.name, legs=out, environment=mission.environment,
                   payload_kg=mission.payload_kg, home=mission.home, source=mission.source,
                   file=mission.file), note


def closed_mission(mission: Mission) -> tuple[Mission, str | None]:
    """The mission as the aircraft must fly it to be judged: one that ends in the air
    (its last leg above :data:`LANDED_ALTITUDE_M`) has not landed, and the flight is not
    over until it is home and down. The return is added as the chain's return home flies
    it from any point (:func:`return_home_points`): straight home at the aircraft's cruise
    speed at the last altitude, then the descent over home. A mission that lands, at
    home or elsewhere, is left as it is.

    Returns the mission (a new one when legs were added) and the note that says so
    (None when nothing was added).
    """
    if not mission.legs:
        return mission, None
    last = mission.legs[-1]
    alt = float(last.end_alt_m)
    if not np.isfinite(alt) or alt <= LANDED_ALTITUDE_M:
        return mission, None
    end = (float(last.end_en_m[0]), float(last.end_en_m[1]))
    dist = float(np.hypot(*end))
    added = []
    if dist > HOME_RADIUS_M:
        added.append(Leg("cruise", end, (0.0, 0.0), alt, alt, origin=ADDED_RETURN_ORIGIN))
    added.append(Leg("descend", (0.0, 0.0), (0.0, 0.0), alt, 0.0,
                     origin=ADDED_RETURN_ORIGIN))
    n = len(mission.legs)
    legs = f"leg {n + 1}" if len(added) == 1 else f"legs {n + 1}–{n + len(added)}"
    note = (f"the mission ends {dist:.0f} m from home at {alt:.0f} m without landing "
            f"({last.origin or f'leg {n}'}): the return home at cruise speed and the "
            f"landing are added ({legs}) and judged with the rest")
    closed = Mission(name=mission.name, legs=list(mission.legs) + added,
                     environment=mission.environment, payload_kg=mission.payload_kg,
                     home=mission.home, source=mission.source, file=mission.file)
    return closed, note


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
    leg_index : ndarray of int
        The mission leg of each row (a leg is several rows with a navigation model;
        absent: one row per leg).
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
    leg_index: np.ndarray | None = None

    def __post_init__(self):
        self.end_time_s = np.cumsum(self.duration_s)
        self.start_time_s = self.end_time_s - self.duration_s
        if self.leg_index is None:
            self.leg_index = np.arange(len(self.kind))

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
    origin = [leg.origin for leg in mission.legs]
    leg_index = None
    if aircraft.is_multirotor and aircraft.navigation is not None:
        origin, leg_index = _navigate(plan, aircraft, env, origin)
    total = float(np.nansum(plan.duration))
    if total > MAX_FLIGHT_S:
        raise InputError(f"{mission.source or mission.name}: the legs take {total / S_PER_H:.1f} h "
                         f"at their planned speeds, longer than the planner simulates (at most "
                         f"{MAX_FLIGHT_S / S_PER_H:.0f} h of flight)")
    n = len(plan.kind)
    amsl = env.site_altitude_m + 0.5 * (plan.alt0 + plan.alt1)
    rho = np.broadcast_to(np.asarray(air_density_at(amsl, env, temperature_c), float), (n,))
    return LegTable(kind=np.asarray(plan.kind), origin=origin,
                    duration_s=np.nan_to_num(plan.duration, nan=0.0),
                    distance_m=plan.distance, course_deg=plan.course,
                    airspeed_ms=np.nan_to_num(plan.airspeed, nan=0.0),
                    groundspeed_ms=np.nan_to_num(plan.ground, nan=0.0),
                    climb_rate_ms=plan.climb, load_factor=plan.load, air_density=rho.copy(),
                    start_en_m=plan.start, end_en_m=plan.end, start_alt_m=plan.alt0,
                    end_alt_m=plan.alt1, problems=plan.problems, notes=plan.notes,
                    leg_index=leg_index)


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


def _navigate(plan: _LegPlan, aircraft: Aircraft, env: Environment, origin: list[str]):
    """Fly the legs of ``plan`` as the autopilot does (``aircraft.navigation``): each
    mission leg becomes the rows of :data:`NAV_SLOTS` (empty ones dropped), in place.

    * A climb from the ground: the spin-up (on the ground, at the hover state,
      :data:`SPINUP_LOAD_FACTOR`), then the climb with the vertical acceleration
      (:func:`planner.physics.motion.takeoff`) at its mean climb rate.
    * A straight (``cruise``) leg: :func:`planner.physics.motion.straight_move` at the
      ground speed the wind triangle gave, from rest to rest when the vehicle stops at
      waypoints (then a dwell), else from and to the speed of the legs around it; the
      accelerating and braking rows at their mean ground speed (the airspeed through the
      wind) with the load factor of their mean acceleration.
    * A descent to the ground: at the descent rate down to the slow height, then at the
      landing rate (:func:`planner.physics.motion.landing`).
    * Climbs and descents without a rate of their own take the navigation's rates.

    Returns the rows' origins and their mission leg; the problems keep naming their leg
    (mapped to the leg's own row).
    """
    nav = aircraft.navigation
    n, k = len(plan.kind), len(NAV_SLOTS)
    kind = plan.kind
    cruise = kind == "cruise"
    climb_leg, descend_leg = kind == "climb", kind == "descend"
    dalt = plan.alt1 - plan.alt0
    own_rate = ~np.isnan(plan.rate)
    up_rate = np.where(own_rate, np.abs(plan.rate), nav.climb_rate_ms)
    down_rate = np.where(own_rate, np.abs(plan.rate), nav.descent_rate_ms)
    from_ground = climb_leg & (plan.alt0 <= GROUND_HEIGHT_M)
    to_ground = descend_leg & (plan.alt1 <= GROUND_HEIGHT_M) & (dalt < 0)

    dur = np.zeros((n, k))
    dur[:, 1] = plan.duration
    air = np.repeat(plan.airspeed[:, None], k, axis=1)
    gnd = np.repeat(plan.ground[:, None], k, axis=1)
    load = np.repeat(plan.load[:, None], k, axis=1)
    rows_kind = np.repeat(kind[:, None], k, axis=1).astype(object)
    # fraction of the leg's path (horizontal or vertical) at the end of each row
    frac_end = np.ones((n, k))
    frac_end[:, 0] = 0.0
    wind = float(env.wind_speed_ms)

    # climbs: spin-up on the ground, climb with the vertical acceleration
    spin, t_climb = motion.takeoff(np.abs(dalt), up_rate, nav.vertical_accel_ms2,
                                   nav.takeoff_spinup_s)
    dur[:, 0] = np.where(from_ground, spin, dur[:, 0])
    dur[:, 1] = np.where(climb_leg & (dalt > 0), t_climb, dur[:, 1])
    rows_kind[:, 0] = np.where(from_ground, "hover", rows_kind[:, 0])
    air[:, 0] = np.where(from_ground, wind, air[:, 0])
    gnd[:, 0] = np.where(from_ground, 0.0, gnd[:, 0])
    load[:, 0] = np.where(from_ground, SPINUP_LOAD_FACTOR, load[:, 0])

    # descents: the navigation's rate, and the slow stage of a landing
    fast, slow = motion.landing(-dalt, down_rate, nav.landing_slow_height_m,
                                nav.landing_descent_rate_ms)
    plain_down = descend_leg & ~to_ground & (dalt < 0)
    dur[:, 1] = np.where(plain_down, -dalt / down_rate, dur[:, 1])
    dur[:, 1] = np.where(to_ground, fast, dur[:, 1])
    dur[:, 3] = np.where(to_ground, slow, 0.0)
    rows_kind[:, 3] = "descend"
    with np.errstate(invalid="ignore", divide="ignore"):
        frac_end[:, 1] = np.where(to_ground, np.where(-dalt > 0, (fast * down_rate) / -dalt,
                                                      1.0), frac_end[:, 1])

    # straight legs: the jerk-limited move at the ground speed held
    v = np.where(cruise & np.isfinite(plan.ground), plan.ground, 0.0)
    if nav.stop_at_waypoints:
        v0 = v1 = np.zeros(n)
    else:
        prev_v = np.concatenate(([0.0], np.where(cruise, v, 0.0)[:-1]))
        next_v = np.concatenate((np.where(cruise, v, 0.0)[1:], [0.0]))
        v0, v1 = np.minimum(v, prev_v), np.minimum(v, next_v)
    go = cruise & (v > 0) & (plan.distance > 0)
    brake_a, brake_j = nav.brake_limits
    m = motion.straight_move(plan.distance, np.where(go, v, 1.0), nav.horizontal_accel_ms2,
                             nav.horizontal_jerk_ms3, v0, v1, brake_a, brake_j)
    dur[:, 0] = np.where(go, m.accel_time_s, dur[:, 0])
    dur[:, 1] = np.where(go, m.cruise_time_s, dur[:, 1])
    dur[:, 2] = np.where(go, m.brake_time_s, 0.0)
    dwell = cruise & bool(nav.stop_at_waypoints)
    dur[:, 4] = np.where(dwell, nav.waypoint_dwell_s, 0.0)
    rows_kind[:, 4] = "hover"
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(go, plan.distance, 1.0)
        frac_end[:, 0] = np.where(go, m.accel_distance_m / d, frac_end[:, 0])
        frac_end[:, 1] = np.where(go, (m.accel_distance_m + m.cruise_distance_m) / d,
                                  frac_end[:, 1])
    # the phases' airspeed: the mean ground velocity along the course less the wind
    w_e, w_n = wind_vector(env.wind_speed_ms, env.wind_from_deg)
    delta = plan.end - plan.start
    with np.errstate(invalid="ignore", divide="ignore"):
        u = delta / np.where(plan.distance > 0, plan.distance, 1.0)[:, None]
    for slot, speed, acc in ((0, m.accel_mean_speed_ms, m.accel_mean_accel_ms2),
                             (2, m.brake_mean_speed_ms, m.brake_mean_accel_ms2)):
        va = np.hypot(speed * u[:, 0] - w_e, speed * u[:, 1] - w_n)
        air[:, slot] = np.where(go, va, air[:, slot])
        gnd[:, slot] = np.where(go, speed, gnd[:, slot])
        load[:, slot] = np.where(go, np.sqrt(1.0 + (acc / atmosphere.G) ** 2), load[:, slot])
        rows_kind[:, slot] = np.where(go, "cruise", rows_kind[:, slot])
    # a dwell and a landing's slow stage hold position
    for slot in (3, 4):
        air[:, slot], gnd[:, slot], load[:, slot] = wind, 0.0, 1.0

    # the rows: positions and altitudes along each leg, climb rate over the row
    frac_end[:, 2] = np.where(to_ground, frac_end[:, 1], frac_end[:, 2])
    frac_end = np.maximum.accumulate(np.clip(np.nan_to_num(frac_end, nan=1.0), 0.0, 1.0),
                                     axis=1)
    frac_start = np.concatenate((np.zeros((n, 1)), frac_end[:, :-1]), axis=1)
    horizontal = cruise[:, None]
    slot = np.arange(k)[None, :]
    # a leg that does not move over ground: at its start before its own row, at its end
    # from there on
    h0 = np.where(horizontal, frac_start, (slot > 1).astype(float))
    h1 = np.where(horizontal, frac_end, (slot > 0).astype(float))
    pos0 = plan.start[:, None, :] + h0[..., None] * delta[:, None, :]
    pos1 = plan.start[:, None, :] + h1[..., None] * delta[:, None, :]
    alt0 = plan.alt0[:, None] + frac_start * dalt[:, None]
    alt1 = plan.alt0[:, None] + frac_end * dalt[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        climb = np.where(dur > 0, (alt1 - alt0) / dur, 0.0)
    climb[:, 1] = np.where(dur[:, 1] > 0, climb[:, 1], plan.climb)
    hdist = np.where(horizontal, (frac_end - frac_start) * plan.distance[:, None], 0.0)

    keep = (dur > 0) | (np.arange(k) == 1)[None, :]
    keep &= ~np.isnan(dur) | (np.arange(k) == 1)[None, :]
    flat = keep.ravel()
    leg_of = np.repeat(np.arange(n), k)[flat]
    slot_of = np.tile(np.arange(k), n)[flat]
    names = [o or f"leg {i + 1}" for i, o in enumerate(origin)]
    suffix = ("", "", BRAKING, " (landing slow stage)", " (waypoint dwell)")
    first = np.where(from_ground, " (spin-up)", np.where(cruise, ACCELERATING, ""))
    row_origin = [names[i] + (first[i] if s == 0 else suffix[s])
                  for i, s in zip(leg_of.tolist(), slot_of.tolist())]
    main_row = {int(i): int(r) for r, (i, s) in enumerate(zip(leg_of, slot_of)) if s == 1}

    plan.kind = rows_kind.ravel()[flat].astype(str)
    plan.duration = dur.ravel()[flat]
    plan.airspeed, plan.ground = air.ravel()[flat], gnd.ravel()[flat]
    plan.load, plan.climb = load.ravel()[flat], climb.ravel()[flat]
    plan.start, plan.end = pos0.reshape(-1, 2)[flat], pos1.reshape(-1, 2)[flat]
    plan.alt0, plan.alt1 = alt0.ravel()[flat], alt1.ravel()[flat]
    plan.distance = hdist.ravel()[flat]
    plan.course = np.repeat(plan.course, k)[flat]
    plan.problems = [(main_row[i], why) for i, why in plan.problems]
    return row_origin, leg_of


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
    descends over home (a fixed-wing aircraft in a loiter circle). With a multirotor's
    navigation block the way home is a jerk-limited move from rest to rest and the
    descent the two-rate landing, flown at the descent's mean rate.

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
    down_rate = ac.descent_rate_ms
    nav = ac.navigation if ac.is_multirotor else None
    if nav is not None:
        # the autopilot's move home (from and to rest) and its two-rate landing
        brake_a, brake_j = nav.brake_limits
        move = motion.straight_move(dist, np.where(gs > 0, gs, 1.0), nav.horizontal_accel_ms2,
                                    nav.horizontal_jerk_ms3, brake_accel=brake_a,
                                    brake_jerk=brake_j)
        t_back = np.where(home | ~(gs > 0), t_back, move.time_s)
        fast, slow = motion.landing(alt_pos, nav.descent_rate_ms, nav.landing_slow_height_m,
                                    nav.landing_descent_rate_ms)
        t_down = fast + slow
        with np.errstate(invalid="ignore", divide="ignore"):
            down_rate = np.where(t_down > 0, alt_pos / t_down, nav.descent_rate_ms)
    if ac.is_multirotor:
        down = (np.full(dist.shape, float(env.wind_speed_ms)), -down_rate, rho, 1.0)
    else:
        v, nload = loiter_state(ac)
        down = (np.full(dist.shape, float(v)), -ac.descent_rate_ms, rho, nload)
    return {"leg": leg_of, "frac": frac, "time_s": time, "east_m": pos[:, 0],
            "north_m": pos[:, 1], "altitude_m": alt, "distance_m": dist,
            "t_back": t_back, "t_down": t_down, "back": (va, 0.0, rho, 1.0), "down": down}
