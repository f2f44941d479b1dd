"""Mission files from legs: a sortie written back in the format the mission came in.

The inverse of the readers, for missions the planner makes (the sorties of
:func:`planner.chain.sizing.plan_sorties`): a legs-form YAML file (:mod:`planner.io.mission.
yaml_mission`), a Mission Planner ``.waypoints`` file (``QGC WPL 110``) or a
QGroundControl ``.plan``. Each function returns the file's text; the command writes it
through :mod:`planner.io.files`.

The waypoint formats carry the legs as MAVLink mission items that
:func:`planner.mission.route.mav_items_to_steps` flies back into the same legs: a climb
over home is ``NAV_TAKEOFF``; a cruise is ``NAV_WAYPOINT`` at its end (after a
``DO_CHANGE_SPEED`` where the leg has a speed of its own); a hover is a
``NAV_WAYPOINT`` where the aircraft is with its hold time (param1), a loiter
``NAV_LOITER_TIME`` there (radius in param3); a vertical move elsewhere is
a ``NAV_WAYPOINT`` over the same point at the new altitude; the final descent to the
ground is ``NAV_LAND`` where the aircraft is. Altitudes are relative to home (frame 3);
positions go back to latitude and longitude through the leg frame
(:func:`planner.physics.geo.aeqd_to_latlon`). Climb and descent rates of single legs are
not carried (the aircraft's defaults apply).
"""

from __future__ import annotations

import json
import math

import yaml

from planner.errors import InputError
from planner.physics.geo import aeqd_to_latlon
from planner.physics.mission import Mission

__all__ = ["mission_items", "to_plan", "to_waypoints", "to_yaml", "WRITERS"]

#: MAVLink commands written.
NAV_WAYPOINT, NAV_LOITER_TIME, NAV_LAND, NAV_TAKEOFF, DO_CHANGE_SPEED = 16, 19, 21, 22, 178
#: Relative-altitude frame (MAV_FRAME_GLOBAL_RELATIVE_ALT).
FRAME_RELATIVE = 3
#: Below this an altitude change or a distance is no move. [m]
MIN_MOVE_M = 0.01


def _home(mission: Mission) -> tuple[float, float, float]:
    if mission.home is None:
        raise InputError(f"{mission.source or mission.name}: the mission has no home position: "
                         "a waypoint file cannot be written (expected a mission read from "
                         "a .plan, .waypoints or a YAML file with home)")
    return mission.home


def mission_items(mission: Mission) -> list[tuple[int, int, list[float]]]:
    """The mission's legs as MAVLink items after home: ``(command, frame, params[7])``."""
    lat0, lon0, _ = _home(mission)
    items: list[tuple[int, int, list[float]]] = []
    speed = None
    for k, leg in enumerate(mission.legs):
        lat, lon = (float(v) for v in aeqd_to_latlon(leg.end_en_m[0], leg.end_en_m[1],
                                                     lat0, lon0))
        alt = float(leg.end_alt_m)
        at_home = math.hypot(*leg.start_en_m) < MIN_MOVE_M
        if leg.kind == "climb" and at_home and not items:
            items.append((NAV_TAKEOFF, FRAME_RELATIVE, [0, 0, 0, math.nan, lat, lon, alt]))
        elif leg.kind == "descend" and alt <= MIN_MOVE_M and k == len(mission.legs) - 1:
            items.append((NAV_LAND, FRAME_RELATIVE, [0, 0, 0, math.nan, 0.0, 0.0, 0.0]))
        elif leg.kind in ("climb", "descend"):
            if abs(leg.end_alt_m - leg.start_alt_m) >= MIN_MOVE_M:
                items.append((NAV_WAYPOINT, FRAME_RELATIVE, [0, 0, 0, math.nan, lat, lon, alt]))
        elif leg.kind == "cruise":
            if leg.speed_ms is not None and leg.speed_ms != speed:
                kind = 0 if leg.speed_is_airspeed else 1
                items.append((DO_CHANGE_SPEED, FRAME_RELATIVE,
                              [kind, float(leg.speed_ms), -1, 0, 0.0, 0.0, 0.0]))
                speed = leg.speed_ms
            if leg.distance_m >= MIN_MOVE_M or abs(leg.end_alt_m - leg.start_alt_m) >= MIN_MOVE_M:
                items.append((NAV_WAYPOINT, FRAME_RELATIVE, [0, 0, 0, math.nan, lat, lon, alt]))
        elif leg.kind == "hover":   # a waypoint where the aircraft is, with a hold time
            items.append((NAV_WAYPOINT, FRAME_RELATIVE,
                          [float(leg.duration_s or 0.0), 0, 0, math.nan, lat, lon, alt]))
        else:  # loiter: circle where the aircraft is
            radius = leg.loiter_radius_m or 0.0
            items.append((NAV_LOITER_TIME, FRAME_RELATIVE,
                          [float(leg.duration_s or 0.0), 0, radius, math.nan, lat, lon, alt]))
    return items


def to_waypoints(mission: Mission) -> str:
    """A Mission Planner ``.waypoints`` file (``QGC WPL 110``): home is item 0 (global
    frame, altitude above mean sea level), then :func:`mission_items`."""
    lat0, lon0, alt0 = _home(mission)
    rows = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{lat0:.8f}\t{lon0:.8f}\t{alt0:.3f}\t1"]
    for seq, (cmd, frame, p) in enumerate(mission_items(mission), 1):
        values = "\t".join("0" if math.isnan(v) else f"{v:.8f}" if i >= 4 and i < 6
                           else f"{v:.6g}" for i, v in enumerate(p))
        rows.append(f"{seq}\t0\t{frame}\t{cmd}\t{values}\t1")
    return "\n".join(rows) + "\n"


def to_plan(mission: Mission, vehicle_type: str = "multirotor") -> str:
    """A QGroundControl ``.plan`` (JSON, version 1, mission version 2)."""
    lat0, lon0, alt0 = _home(mission)
    items = [{"autoContinue": True, "command": cmd, "doJumpId": seq, "frame": frame,
              "params": [None if math.isnan(v) else v for v in p], "type": "SimpleItem"}
             for seq, (cmd, frame, p) in enumerate(mission_items(mission), 1)]
    plan = {"fileType": "Plan", "geoFence": {"circles": [], "polygons": [], "version": 2},
            "groundStation": "QGroundControl",
            "mission": {"firmwareType": 0, "items": items,
                        "plannedHomePosition": [lat0, lon0, alt0],
                        "vehicleType": 2 if vehicle_type == "multirotor" else 1,
                        "version": 2},
            "rallyPoints": {"points": [], "version": 2}, "version": 1}
    return json.dumps(plan, indent=4) + "\n"


def to_yaml(mission: Mission) -> str:
    """A legs-form YAML mission (dead-reckoned from home: each cruise by distance and
    course, altitudes above home)."""
    legs = []
    for leg in mission.legs:
        if leg.kind in ("climb", "descend"):
            entry = {"altitude_m": round(float(leg.end_alt_m), 3)}
            if leg.climb_rate_ms is not None:
                entry["rate_ms"] = float(leg.climb_rate_ms)
            if abs(leg.end_alt_m - leg.start_alt_m) < MIN_MOVE_M:
                continue
        elif leg.kind == "cruise":
            if leg.distance_m < MIN_MOVE_M and abs(leg.end_alt_m - leg.start_alt_m) < MIN_MOVE_M:
                continue
            entry = {"distance_m": round(leg.distance_m, 3),
                     "course_deg": round(leg.course_deg, 4),
                     "altitude_m": round(float(leg.end_alt_m), 3)}
            if leg.speed_ms is not None:
                key = "airspeed_ms" if leg.speed_is_airspeed else "groundspeed_ms"
                entry[key] = float(leg.speed_ms)
        elif leg.kind == "hover":
            entry = {"duration_s": round(float(leg.duration_s or 0.0), 3)}
        else:
            entry = {"duration_s": round(float(leg.duration_s or 0.0), 3)}
            if leg.loiter_radius_m is not None:
                entry["radius_m"] = float(leg.loiter_radius_m)
            if leg.speed_ms is not None:
                entry["airspeed_ms"] = float(leg.speed_ms)
        legs.append({leg.kind: entry})
    env = mission.environment
    data = {"name": mission.name, "payload_kg": float(mission.payload_kg),
            "environment": {"wind_speed_ms": float(env.wind_speed_ms),
                            "wind_from_deg": float(env.wind_from_deg),
                            **({} if env.temperature_c is None
                               else {"temperature_c": float(env.temperature_c)}),
                            **({} if env.pressure_pa is None
                               else {"pressure_pa": float(env.pressure_pa)}),
                            "site_altitude_m": float(env.site_altitude_m)}}
    if mission.home is not None:
        lat, lon, alt = mission.home
        data["home"] = {"lat": float(lat), "lon": float(lon), "alt_m": float(alt)}
    data["legs"] = legs
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


#: Writer of each mission file suffix.
WRITERS = {".yaml": "yaml", ".yml": "yaml", ".waypoints": "waypoints", ".plan": "plan"}
