"""Mission files from legs: a sortie written back in the format the mission came in.

The inverse of the readers, for missions the planner makes (the sorties of
:func:`planner.chain.sizing.plan_sorties`): a legs-form YAML file
(:mod:`planner.io.mission.yaml_mission`), a Mission Planner ``.waypoints`` file
(``QGC WPL 110``) or a QGroundControl ``.plan``. Each function returns the file's text;
the command writes it through :mod:`planner.io.files`.

A mission read from a waypoint file keeps the file's items (``Mission.file``, a
:class:`planner.io.mission.route.MissionFile`), and a sortie is written with them:

- every item whose legs the sortie flies whole is written as the file had it (its
  command, frame, parameters and, in a ``.plan``, every key QGroundControl wrote: a
  ``VTOL_TAKEOFF``, a landing, a loiter, a terrain-frame altitude stay what they were);
  ``DO_JUMP`` loops are written unrolled, as flown;
- the non-navigation items between them (camera, gimbal, gripper, servo, relay,
  ``DO_LAND_START`` …) are written in their place;
- a sortie that starts part-way re-issues, where its route starts, the state those items
  had set at that point of the mission (the last camera trigger distance or interval,
  image or video capture, camera mode, region of interest, mount, servos and relays,
  VTOL transition), and one that ends part-way stops the camera before it turns home
  (``DO_SET_CAM_TRIGG_DIST`` 0, ``IMAGE_STOP_CAPTURE``, as QGroundControl's structure
  scan stops it after its last waypoint);
- a leg cut part-way is written as a waypoint (a cruise), a ``NAV_LOITER_TIME`` (a hover),
  a ``NAV_LOITER_TURNS`` of the turns flown (a loiter in turns) or a ``NAV_LOITER_TO_ALT``
  (a fixed-wing climb over a point); the planner's transit legs as a take-off of the
  file's own kind (``NAV_TAKEOFF`` or ``NAV_VTOL_TAKEOFF``, its parameters kept) at home,
  waypoints, and a landing of the file's own kind at home's latitude and longitude (the
  landing flies there at the current altitude, then descends: ``NAV_LAND``/
  ``NAV_VTOL_LAND`` with a position, never 0, 0, which ArduPlane reads as "here");
- the speeds every leg was planned at are written: a ``DO_CHANGE_SPEED`` wherever the
  speed in force differs from the one the leg was planned at, the aircraft's own speed
  (:class:`~planner.physics.mission.NavDefaults`) where the plan flew its default, type 1
  (ground speed) for a multirotor and type 0 (airspeed) for a fixed-wing aircraft (QGroundControl
  ``SpeedSection.cc``; ArduPlane reads type 1 as its minimum ground speed), types 2 and 3
  for the climb and descent rates;
- a ``.plan`` keeps the input's envelope: ``geoFence`` and ``rallyPoints`` (QGroundControl
  uploads mission, fence and rally points in turn, so an empty fence would replace the
  vehicle's), ``firmwareType``, ``vehicleType``, ``cruiseSpeed``, ``hoverSpeed`` and
  ``globalPlanAltitudeMode`` as they were;
- a ``.waypoints`` file keeps its home row.

A mission without a file (YAML) is written leg by leg the same way, altitudes relative
to home (frame 3), positions back to latitude and longitude through the leg frame
(:func:`planner.physics.geo.aeqd_to_latlon`). Every file written reads back into the same
legs (:func:`planner.io.mission.load_mission` with the same aircraft).
"""

from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass
from typing import Any

import yaml

from planner.errors import InputError
from planner.physics.geo import aeqd_to_latlon
from planner.physics.mission import Leg, Mission, NavDefaults
from planner.io.mission.route import (LAND_CMDS, POSITIONED_CMDS, TAKEOFF_CMDS, MavItem,
                                      MissionFile)

__all__ = ["mission_items", "sortie_items", "to_plan", "to_waypoints", "to_yaml", "WRITERS"]

#: MAVLink commands written.
NAV_WAYPOINT, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LAND, NAV_TAKEOFF = 16, 18, 19, 21, 22
NAV_LOITER_TO_ALT, DO_CHANGE_SPEED = 31, 178
DO_SET_CAM_TRIGG_DIST, IMAGE_STOP_CAPTURE, VIDEO_STOP_CAPTURE = 206, 2001, 2501
#: Relative-altitude frame (MAV_FRAME_GLOBAL_RELATIVE_ALT) and the frame of items without a
#: position (MAV_FRAME_MISSION).
FRAME_RELATIVE, FRAME_MISSION = 3, 2
#: Below this an altitude change or a distance is no move. [m]
MIN_MOVE_M = 0.01

#: Non-navigation commands that set a state lasting until changed: the key under which
#: the last one is re-issued at the start of a sortie.
_STATE_KEYS = {206: "camera trigger distance", 214: "camera trigger interval",
               2000: "image capture", 2001: "image capture", 2500: "video capture",
               2501: "video capture", 530: "camera mode", 531: "camera zoom",
               532: "camera focus", 202: "camera configuration", 80: "region of interest",
               195: "region of interest", 196: "region of interest",
               197: "region of interest", 201: "region of interest", 205: "mount",
               1000: "mount", 187: "actuators", 3000: "VTOL transition"}
#: Commands that fly legs (written from them, never copied as non-navigation items).
_NAVIGATION = POSITIONED_CMDS | {20, 93}
#: Commands never written as they stand: jumps (written unrolled) and speed changes (written
#: from the speeds the legs were planned at).
_NOT_COPIED = {177, 178, 600, 601}


@dataclass
class OutItem:
    """One item of a written file: MAVLink fields and, for a ``.plan``, the JSON object."""

    command: int
    frame: int
    params: list[float]
    raw: dict | None = None
    autocontinue: int = 1


def _home(mission: Mission) -> tuple[float, float, float]:
    if mission.home is None:
        raise InputError(f"{mission.source or mission.name}: the mission has no home position: "
                         "a waypoint file cannot be written (expected a mission read from "
                         "a .plan, .waypoints or a YAML file with home)")
    return mission.home


def _state_key(item: MavItem) -> Any:
    key = _STATE_KEYS.get(item.command)
    if item.command in (181, 183) and math.isfinite(item.params[0]):
        key = (item.command, round(item.params[0]))           # relay / servo number
    return key


def _copy(item: MavItem) -> OutItem:
    raw = None
    if isinstance(item.raw, dict):
        raw = copy.deepcopy(item.raw)
        if not (isinstance(raw.get("params"), list) and len(raw["params"]) == 7):
            # QGroundControl's older item forms, written in the current one
            for key in ("coordinate", "param1", "param2", "param3", "param4"):
                raw.pop(key, None)
            raw["params"] = [None if math.isnan(v) else v for v in item.params]
            raw["type"] = "SimpleItem"
    return OutItem(item.command, item.frame, list(item.params), raw, item.autocontinue)


class _Writer:
    """Turns a mission's legs into items, with the file's own items where it has them."""

    def __init__(self, mission: Mission, defaults: NavDefaults | None,
                 vehicle_type: str | None):
        self.mission = mission
        self.file: MissionFile | None = mission.file
        self.defaults = defaults
        self.vehicle = (vehicle_type or (defaults.vehicle_type if defaults else None)
                        or (self.file.vehicle_type if self.file else None) or "multirotor")
        self.home = _home(mission)
        self.out: list[OutItem] = []
        self.state: tuple = (None, None, None, None)     # speed, airspeed?, climb, descent
        self.camera: dict[Any, MavItem] = {}

    # -- speeds
    def _speed_item(self, kind: int, value: float | None, default: float | None) -> None:
        v = value if value is not None else default
        self.out.append(OutItem(DO_CHANGE_SPEED, FRAME_MISSION,
                                [float(kind), float(v) if v is not None else -2.0, -1.0, 0.0,
                                 0.0, 0.0, 0.0]))

    def ensure(self, speed=..., is_air=..., climb=..., descent=...) -> None:
        """Write ``DO_CHANGE_SPEED`` items so that the given speeds are in force
        (``...``: unchanged; ``None``: the aircraft's default)."""
        s, a, c, d = self.state
        d0 = self.defaults
        if speed is not ... and (speed, is_air if speed is not None else None) != (
                s, a if s is not None else None):
            air = is_air if is_air is not None else self.vehicle == "fixed_wing"
            self._speed_item(0 if air else 1, speed, d0.cruise_speed_ms if d0 else None)
            s, a = speed, is_air
        if climb is not ... and climb != c:
            self._speed_item(2, climb, d0.climb_rate_ms if d0 else None)
            c = climb
        if descent is not ... and descent != d:
            self._speed_item(3, descent, d0.descent_rate_ms if d0 else None)
            d = descent
        self.state = (s, a, c, d)

    def ensure_leg(self, leg: Leg) -> None:
        if leg.kind in ("cruise", "loiter"):
            self.ensure(speed=leg.speed_ms, is_air=leg.speed_is_airspeed)
        elif leg.kind == "climb":
            self.ensure(climb=leg.climb_rate_ms)
        elif leg.kind == "descend":
            self.ensure(descent=leg.climb_rate_ms)

    # -- generated items
    def latlon(self, en: tuple[float, float]) -> tuple[float, float]:
        lat, lon = aeqd_to_latlon(en[0], en[1], self.home[0], self.home[1])
        return float(lat), float(lon)

    def template(self, commands: frozenset) -> MavItem | None:
        if self.file is None:
            return None
        found = [it for it in self.file.items if it.command in commands]
        if not found:
            return None
        return found[0] if commands is TAKEOFF_CMDS else found[-1]

    def takeoff(self, leg: Leg) -> None:
        t = self.template(TAKEOFF_CMDS)
        if t is not None:
            p = list(t.params[:4]) + list(t.params[4:6]) + [float(leg.end_alt_m)]
            if not all(math.isfinite(v) for v in p[4:6]):
                p[4:6] = [0.0, 0.0]
            self.out.append(OutItem(t.command, FRAME_RELATIVE, p))
        else:
            lat, lon = self.latlon(leg.end_en_m)
            self.out.append(OutItem(NAV_TAKEOFF, FRAME_RELATIVE,
                                    [0.0, 0.0, 0.0, math.nan, lat, lon, float(leg.end_alt_m)]))

    def land(self, en: tuple[float, float]) -> None:
        t = self.template(LAND_CMDS)
        lat, lon = self.latlon(en)
        if t is not None:
            self.out.append(OutItem(t.command, FRAME_RELATIVE,
                                    list(t.params[:4]) + [lat, lon, 0.0]))
        else:
            vtol = self.template(TAKEOFF_CMDS)
            cmd = 85 if vtol is not None and vtol.command == 84 else NAV_LAND
            self.out.append(OutItem(cmd, FRAME_RELATIVE, [0.0, 0.0, 0.0, math.nan, lat, lon,
                                                          0.0]))

    def waypoint(self, en, alt, hold: float = 0.0) -> None:
        lat, lon = self.latlon(en)
        self.out.append(OutItem(NAV_WAYPOINT, FRAME_RELATIVE,
                                [hold, 0.0, 0.0, math.nan, lat, lon, float(alt)]))

    def generated(self, leg: Leg, source: MavItem | None = None,
                  whole: tuple[Leg, ...] = ()) -> None:
        """Items flying one leg (the planner's own, or a part of the file's)."""
        if not (leg.kind == "loiter" and source is not None
                and source.command == NAV_LOITER_TURNS):
            self.ensure_leg(leg)
        lat, lon = self.latlon(leg.end_en_m)
        alt = float(leg.end_alt_m)
        if leg.kind in ("climb", "descend"):
            if abs(leg.end_alt_m - leg.start_alt_m) < MIN_MOVE_M:
                return
            if leg.loiter_radius_m:                   # a fixed-wing climb circling a point
                self.out.append(OutItem(NAV_LOITER_TO_ALT, FRAME_RELATIVE,
                                        [0.0, float(leg.loiter_radius_m), 0.0, 0.0, lat, lon,
                                         alt]))
            else:
                self.waypoint(leg.end_en_m, alt)
        elif leg.kind == "cruise":
            if leg.distance_m >= MIN_MOVE_M or abs(leg.end_alt_m - leg.start_alt_m) >= MIN_MOVE_M:
                self.waypoint(leg.end_en_m, alt)
        elif leg.kind == "hover":
            self.out.append(OutItem(NAV_LOITER_TIME, FRAME_RELATIVE,
                                    [float(leg.duration_s or 0.0), 0.0, 0.0, 0.0, lat, lon,
                                     alt]))
        else:    # loiter
            full = next((g for g in whole if g.kind == "loiter"), None)
            if (source is not None and source.command == NAV_LOITER_TURNS and full is not None
                    and full.duration_s):
                turns = source.params[0] * float(leg.duration_s or 0.0) / full.duration_s
                self.out.append(OutItem(NAV_LOITER_TURNS, FRAME_RELATIVE,
                                        [turns, 0.0, source.params[2], 0.0, lat, lon, alt]))
            else:
                radius = leg.loiter_radius_m or 0.0
                self.out.append(OutItem(NAV_LOITER_TIME, FRAME_RELATIVE,
                                        [float(leg.duration_s or 0.0), 0.0, radius, 0.0, lat,
                                         lon, alt]))

    # -- the file's own items
    def do_items(self, first: int, last: int) -> list[tuple[int, MavItem]]:
        """The file's non-navigation items flown between item indices first and last."""
        f = self.file
        return [(j, f.items[j]) for j in range(max(first, 0), max(last, 0))
                if f.items[j].command not in _NAVIGATION
                and f.items[j].command not in _NOT_COPIED]

    def copy_do(self, items: list[tuple[int, MavItem]]) -> None:
        for _, it in items:
            self.out.append(_copy(it))
            if (key := _state_key(it)) is not None:
                self.camera[key] = it

    def reissue(self, before: int) -> None:
        """The state the file's items had set before item ``before``, re-issued."""
        state: dict[Any, tuple[int, MavItem]] = {}
        for j, it in self.do_items(0, before):
            if (key := _state_key(it)) is not None:
                state[key] = (j, it)
        for _, it in sorted(state.values(), key=lambda pair: pair[0]):
            self.out.append(_copy(it))
        self.camera = {key: it for key, (_, it) in state.items()}

    def stop_camera(self) -> None:
        trig = self.camera.get("camera trigger distance")
        if trig is not None and trig.params[0] > 0:
            self.out.append(OutItem(DO_SET_CAM_TRIGG_DIST, FRAME_MISSION, [0.0] * 7))
        cap = self.camera.get("image capture")
        if cap is not None and cap.command == 2000:
            self.out.append(OutItem(IMAGE_STOP_CAPTURE, FRAME_MISSION, [0.0] * 7))
        vid = self.camera.get("video capture")
        if vid is not None and vid.command == 2500:
            self.out.append(OutItem(VIDEO_STOP_CAPTURE, FRAME_MISSION, [0.0] * 7))
        self.camera = {}

    def leg_items(self, legs: list[Leg], i: int, source: MavItem | None = None,
                  whole: tuple[Leg, ...] = ()) -> int:
        """Items flying leg ``i`` (and the landing after it): the index of the next leg."""
        leg, n = legs[i], len(legs)
        nxt = legs[i + 1] if i + 1 < n else None
        if i == 0 and leg.kind == "climb" and math.hypot(*leg.start_en_m) < MIN_MOVE_M:
            self.ensure_leg(leg)
            self.takeoff(leg)
        elif leg.kind == "descend" and i == n - 1 and leg.end_alt_m <= MIN_MOVE_M:
            self.ensure_leg(leg)
            self.land(leg.end_en_m)
        elif (leg.kind == "cruise" and nxt is not None and i + 1 == n - 1
              and nxt.kind == "descend" and nxt.end_alt_m <= MIN_MOVE_M
              and nxt.item == leg.item
              and abs(leg.end_alt_m - leg.start_alt_m) < MIN_MOVE_M):
            # fly to the landing point at the current altitude and land there: one item
            self.ensure_leg(leg)
            self.ensure_leg(nxt)
            self.land(leg.end_en_m)
            return i + 2
        else:
            self.generated(leg, source, whole)
        return i + 1

    def run(self) -> list[OutItem]:
        legs = self.mission.legs
        f = self.file
        n = len(legs)
        i = 0
        last = None                    # index of the last file item written
        started = False
        while i < n:
            k = legs[i].item if f is not None else None
            if k is None or k >= len(f.items):
                if last is not None:
                    # the route ends here: what the file does on leaving its last item,
                    # and the camera stopped before the transit home
                    self.copy_do(self.do_items(last + 1, self._next_nav(last)))
                    self.stop_camera()
                    last = None
                i = self.leg_items(legs, i)
                continue
            j = i
            while j < n and legs[j].item == k:
                j += 1
            whole = f.legs.get(k, ())
            state = f.states.get(k, (None, None, None, None))
            if not started:
                started = True
                if i == 0:
                    self.copy_do(self.do_items(0, k))     # the mission's own start
                else:
                    self.reissue(k)
            else:
                self.copy_do(self.do_items((last if last is not None else k) + 1, k))
            self.ensure(*state)
            if tuple(legs[i:j]) == whole:
                self.out.append(_copy(f.items[k]))
            else:
                m = i
                while m < j:
                    m = self.leg_items(legs, m, f.items[k], whole)
                self.ensure(*state)
            last = k
            i = j
        if last is not None:
            self.copy_do(self.do_items(last + 1, len(f.items)))
        return self.out

    def _next_nav(self, after: int) -> int:
        items = self.file.items
        return next((j for j in range(after + 1, len(items))
                     if items[j].command in _NAVIGATION), len(items))


def sortie_items(mission: Mission, defaults: NavDefaults | None = None,
                 vehicle_type: str | None = None) -> list[OutItem]:
    """The items of a mission (a sortie) after home, as written to a waypoint file.

    Parameters
    ----------
    mission : Mission
    defaults : NavDefaults or None
        The aircraft's own speeds: written where a leg flies the default after a
        ``DO_CHANGE_SPEED`` (without them, ``DO_CHANGE_SPEED`` -2, "back to the default").
    vehicle_type : {"multirotor", "fixed_wing"} or None
        Chooses the ``DO_CHANGE_SPEED`` type (else ``defaults``, else the file's).
    """
    return _Writer(mission, defaults, vehicle_type).run()


def mission_items(mission: Mission, defaults: NavDefaults | None = None,
                  vehicle_type: str | None = None) -> list[tuple[int, int, list[float]]]:
    """The mission's items after home: ``(command, frame, params[7])``."""
    return [(it.command, it.frame, it.params)
            for it in sortie_items(mission, defaults, vehicle_type)]


def _num(v: float) -> str:
    """A number as written to a ``.waypoints`` file: exact (the shortest text that reads
    back to the same float), NaN written 0 as Mission Planner does."""
    if math.isnan(v):
        return "0"
    if float(v).is_integer() and abs(v) < 1e15:
        return str(int(v))
    return repr(float(v))


def to_waypoints(mission: Mission, vehicle_type: str | None = None, *,
                 defaults: NavDefaults | None = None) -> str:
    """A Mission Planner ``.waypoints`` file (``QGC WPL 110``): home is item 0 (the input's
    home row, else global frame, altitude above mean sea level), then
    :func:`sortie_items`."""
    lat0, lon0, alt0 = _home(mission)
    f = mission.file
    if f is not None:
        h = f.home
        home = [h.frame, h.command, *h.params]
    else:
        home = [0, 16, 0.0, 0.0, 0.0, 0.0, lat0, lon0, alt0]
    rows = ["QGC WPL 110", "\t".join(["0", "1", str(home[0]), str(home[1]),
                                      *map(_num, home[2:]), "1"])]
    for seq, it in enumerate(sortie_items(mission, defaults, vehicle_type), 1):
        rows.append("\t".join([str(seq), "0", str(it.frame), str(it.command),
                               *map(_num, it.params), str(it.autocontinue)]))
    return "\n".join(rows) + "\n"


def to_plan(mission: Mission, vehicle_type: str | None = None, *,
            defaults: NavDefaults | None = None) -> str:
    """A QGroundControl ``.plan`` (JSON, version 1): the input plan's envelope (geofence,
    rally points, firmware, vehicle, planning speeds) with :func:`sortie_items`."""
    lat0, lon0, alt0 = _home(mission)
    f = mission.file
    vehicle = (vehicle_type or (defaults.vehicle_type if defaults else None)
               or (f.vehicle_type if f else None) or "multirotor")
    items = []
    for seq, it in enumerate(sortie_items(mission, defaults, vehicle_type), 1):
        raw = it.raw if it.raw is not None else {
            "autoContinue": bool(it.autocontinue), "command": it.command, "frame": it.frame,
            "params": [None if math.isnan(v) else v for v in it.params],
            "type": "SimpleItem"}
        raw["doJumpId"] = seq
        items.append(raw)
    if f is not None and f.plan is not None:
        plan = copy.deepcopy(f.plan)
        plan["mission"]["items"] = items
        plan["mission"]["plannedHomePosition"] = [lat0, lon0, alt0]
    else:
        firmware = {"ardupilot": 3, "px4": 12}.get(f.firmware if f else None,
                                                   3 if f is not None else 0)
        plan = {"fileType": "Plan", "geoFence": {"circles": [], "polygons": [], "version": 2},
                "groundStation": "QGroundControl",
                "mission": {"firmwareType": firmware, "items": items,
                            "plannedHomePosition": [lat0, lon0, alt0],
                            "vehicleType": 2 if vehicle == "multirotor" else 1,
                            "version": 2},
                "rallyPoints": {"points": [], "version": 2}, "version": 1}
    return json.dumps(plan, indent=4) + "\n"


def to_yaml(mission: Mission, vehicle_type: str | None = None, *,
            defaults: NavDefaults | None = None) -> str:
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


#: Writer of each mission file suffix (``.txt`` is the ``.waypoints`` text format, as
#: the readers take it).
WRITERS = {".yaml": "yaml", ".yml": "yaml", ".waypoints": "waypoints", ".txt": "waypoints",
           ".plan": "plan"}
#: The writer function of each kind.
WRITE = {"yaml": to_yaml, "waypoints": to_waypoints, "plan": to_plan}
