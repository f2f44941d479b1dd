"""The rest of a mission from where the aircraft is: mission items → legs.

In flight the question is not the whole mission but what is left of it: from the present
position to the item the vehicle is flying to (``MISSION_CURRENT``), then the items after
it, to the landing. :func:`remaining_from_items` builds that from the vehicle's own items
(downloaded, or read from a ``.waypoints``/``.plan`` file with :func:`items_from_file`)
through the same route conversion as the mission files
(:func:`planner.io.mission.route.mav_items_to_steps`, :func:`~planner.io.mission.route.route_to_legs`):
the route is flown from home to the present position and altitude first, and those legs
are dropped, so the remaining legs start where the aircraft is. A mission given as legs
(a ``.yaml`` file) has no item numbers: :func:`remaining_from_legs` follows the aircraft
along its legs by position instead. :func:`return_home` is the way home from here:
straight home at the present altitude, then down.

Conventions: a ``DO_JUMP`` back to an item before the present one is taken as done (its
repeats are not counted again); a mission whose remaining items fly no leg (the vehicle
is past its last item) has no remaining mission (None).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

from planner.errors import InputError
from planner.io.mavlink_stream import MissionItems
from planner.io.mission.route import MavItem, RouteStep, mav_items_to_steps, route_to_legs
from planner.physics.geo import latlon_to_aeqd
from planner.physics.mission import Environment, Leg, Mission

__all__ = ["HERE", "here_en", "items_from_file", "remaining_from_items",
           "remaining_from_legs", "return_home"]

#: Origin of the legs that bring the route from home to the present position (dropped).
HERE = "present position"


def items_from_file(path: str | Path) -> MissionItems | None:
    """A ``.waypoints`` or ``.plan`` file's items as the vehicle numbers them after upload
    (``origin`` ``"item N"``, N counted from 1 after home); None for a ``.yaml`` mission
    (legs, no items)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in (".waypoints", ".txt"):
        from planner.io.mission.wpl import read_wpl

        home, items = read_wpl(path)
        home_t = tuple(float(v) for v in home.params[4:7])
    elif suffix == ".plan":
        from planner.io.mission.qgc_plan import read_plan

        plan, items = read_plan(path)
        home_t = tuple(float(v) for v in plan["plannedHomePosition"][:3])
    else:
        return None
    items = [dataclasses.replace(it, origin=f"item {it.seq}") for it in items]
    return MissionItems(tuple(items), home_t, str(path), len(items) + 1)


def _here_steps(here_ll, alt_m: float) -> list[RouteStep]:
    return [RouteStep("takeoff", alt_m=max(float(alt_m), 0.0), origin=HERE),
            RouteStep("waypoint", lat_deg=float(here_ll[0]), lon_deg=float(here_ll[1]),
                      alt_m=max(float(alt_m), 0.0), origin=HERE)]


def remaining_from_items(mission: MissionItems, seq: int, here_ll, alt_m: float, home, *,
                         vehicle_type: str | None = None, seq_offset: int = 0,
                         payload_kg: float = 0.0, environment: Environment | None = None
                         ) -> Mission | None:
    """The rest of ``mission`` from the present position (module notes).

    Parameters
    ----------
    mission : MissionItems
    seq : int
        The item the vehicle flies to (``MISSION_CURRENT.seq``).
    here_ll : (lat_deg, lon_deg)
        Present position.
    alt_m : float
        Present altitude above home. [m]
    home : (lat_deg, lon_deg, alt_amsl_m)
    vehicle_type : str, optional
        ``multirotor`` or ``fixed_wing`` (see :func:`mav_items_to_steps`).
    seq_offset : int
        Added to the items' numbers to get the vehicle's (a file read for PX4, which
        numbers from 0: −1).
    payload_kg : float
    environment : Environment, optional

    Returns
    -------
    Mission or None
        None when no leg remains or the items cannot be flown.
    """
    if home is None or not all(map(math.isfinite, (*here_ll, alt_m))):
        return None
    seq = int(seq)
    rest: list[MavItem] = []
    for it in mission.items:
        if it.seq + seq_offset < seq:
            continue
        if it.command == 177 and math.isfinite(it.params[0]) \
                and round(it.params[0]) + seq_offset < seq:
            continue             # a jump back before the present item: done
        rest.append(it)
    if not rest:
        return None
    where = f"mission ({mission.source})"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            steps = mav_items_to_steps(rest, float(home[2]), where=where,
                                       vehicle_type=vehicle_type)
            legs = route_to_legs(_here_steps(here_ll, alt_m) + steps, float(home[0]),
                                 float(home[1]), where=where)
    except InputError:
        return None
    legs = [leg for leg in legs if leg.origin != HERE]
    if not legs:
        return None
    env = environment or Environment(site_altitude_m=float(home[2]))
    return Mission(name="rest of the mission", legs=legs, environment=env,
                   payload_kg=payload_kg, home=tuple(home), source=mission.source)


def _point_to_segment(p, a, b) -> tuple[float, float]:
    """Distance from ``p`` to segment ``a``–``b`` (3-D) and the fraction along it."""
    d = [b[i] - a[i] for i in range(3)]
    dd = sum(x * x for x in d)
    f = 0.0 if dd <= 0 else max(0.0, min(1.0, sum((p[i] - a[i]) * d[i]
                                                 for i in range(3)) / dd))
    q = [a[i] + f * d[i] for i in range(3)]
    return math.dist(p, q), f


def remaining_from_legs(mission: Mission, here_en, alt_m: float, from_leg: int = 0
                        ) -> tuple[Mission | None, int]:
    """The rest of a legs mission, found by position (module notes).

    The leg nearest the present position (east, north, altitude; the legs from
    ``from_leg`` on, so progress only goes forward) is cut where the aircraft is; a hover
    or loiter leg there is kept whole.

    Returns
    -------
    (Mission or None, int)
        The rest (None when nothing remains) and the index of the leg being flown.
    """
    legs = mission.legs
    if not legs or not all(map(math.isfinite, (*here_en, alt_m))):
        return None, from_leg
    p = (float(here_en[0]), float(here_en[1]), float(alt_m))
    best, best_j, best_f = math.inf, from_leg, 0.0
    for j in range(max(from_leg, 0), len(legs)):
        leg = legs[j]
        a = (*leg.start_en_m, leg.start_alt_m)
        b = (*leg.end_en_m, leg.end_alt_m)
        d, f = _point_to_segment(p, a, b)
        if d < best - 1e-9:
            best, best_j, best_f = d, j, f
    leg = legs[best_j]
    first = []
    if leg.kind in ("hover", "loiter"):
        first = [leg]
    elif best_f < 1.0:
        first = [dataclasses.replace(leg, start_en_m=(p[0], p[1]), start_alt_m=p[2])]
    rest = first + list(legs[best_j + 1:])
    if not rest:
        return None, best_j
    return (Mission(name="rest of the mission", legs=rest, environment=mission.environment,
                    payload_kg=mission.payload_kg, home=mission.home, source=mission.source),
            best_j)


def return_home(here_en, alt_m: float, *, environment: Environment | None = None,
                payload_kg: float = 0.0, home=None) -> Mission:
    """Straight home from here at the present altitude, then down to land (module notes)."""
    e, n = float(here_en[0]), float(here_en[1])
    alt = max(float(alt_m), 0.0)
    legs = []
    if math.hypot(e, n) >= 0.5:
        legs.append(Leg("cruise", start_en_m=(e, n), end_en_m=(0.0, 0.0), start_alt_m=alt,
                        end_alt_m=alt, origin="return home"))
    if alt >= 0.01 or not legs:
        legs.append(Leg("descend", start_en_m=(0.0, 0.0), end_en_m=(0.0, 0.0),
                        start_alt_m=max(alt, 0.01), end_alt_m=0.0, origin="land"))
    return Mission(name="return home", legs=legs, environment=environment or Environment(),
                   payload_kg=payload_kg, home=home, source="")


def here_en(here_ll, home) -> tuple[float, float]:
    """Present position east and north of home. [m]"""
    if home is None or not all(map(math.isfinite, here_ll)):
        return (math.nan, math.nan)
    e, n = latlon_to_aeqd(float(here_ll[0]), float(here_ll[1]), float(home[0]),
                          float(home[1]))
    return float(e), float(n)
