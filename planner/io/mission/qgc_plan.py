"""QGroundControl ``.plan`` files (JSON), read as QGroundControl loads them.

Schema (QGroundControl ``PlanMasterController.cc``, ``MissionController.cc``,
``SimpleMissionItem.cc``;
https://docs.qgroundcontrol.com/master/en/qgc-dev-guide/file_formats/plan.html)::

    {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
     "mission": {"plannedHomePosition": [lat, lon, alt_amsl],
                 "cruiseSpeed": 15, "hoverSpeed": 5, "vehicleType": 2,
                 "firmwareType": 3, "version": 2,
                 "items": [{"type": "SimpleItem", "command": 22, "frame": 3,
                            "params": [p1, p2, p3, p4, lat, lon, alt],
                            "doJumpId": 1, "autoContinue": true,
                            "AltitudeMode": 1, "Altitude": 30, "AMSLAltAboveTerrain": null},
                           {"type": "ComplexItem", "complexItemType": "survey",
                            "TransectStyleComplexItem": {"Items": [simple items ...]}}]},
     "geoFence": {...}, "rallyPoints": {...}}

What is read, and how
---------------------
- The plan ``version`` must be 1 where given: QGroundControl refuses any other
  (``JsonHelper::validateExternalQGCJsonFile``: "File version 42 is newer than current
  supported version 1"). The ``mission`` object is required; the mission's own
  ``version`` is not checked (QGroundControl does not read it back on a plan).
- ``null`` params are read as NaN ("unset"); the non-standard JSON ``NaN`` and
  ``Infinity`` that Python's reader accepts are refused, as is a home position
  that is not finite or out of range. QGroundControl's parser accepts no comments,
  and neither does this one.
- The older item forms QGroundControl converts on loading are converted the same way
  (``MissionItem::_convertJsonV1ToV2``: ``param1`` .. ``param4`` keys;
  ``_convertJsonV2ToV3``: a ``coordinate`` ``[lat, lon, alt]`` after a 4-entry
  ``params``).
- A "calc above terrain" item (``AltitudeMode`` 3) whose ``params[6]`` is ``null``
  (QGroundControl fills it with terrain height + ``Altitude`` once it has terrain data)
  is read as ``Altitude`` metres above the ground, the terrain assumed flat at home's
  altitude, with a warning; where ``AMSLAltAboveTerrain`` is given, that altitude.
- Survey and corridor-scan complex items are flown through the simple items
  QGroundControl saved in ``TransectStyleComplexItem.Items`` (a survey of a version
  QGroundControl refuses is refused: ``SurveyComplexItem.cc`` loads versions 2 to 5).
  A ``StructureScan`` (version 3) is planned as ``StructureScanComplexItem::
  appendMissionItems`` generates it: the structure polygon pushed out by the camera's
  ``DistanceToSurface`` (``QGCMapPolygon::offset``), ``Layers`` = max(ceil((StructureHeight
  − ScanBottomAlt) / AdjustedFootprintFrontal), 1) loops around it, the first half a
  footprint from the top (``StartFromTop``) or the bottom, each loop from the first
  vertex back to it, with the camera triggered every ``AdjustedFootprintSide`` metres;
  an entrance and an exit waypoint at ``EntranceAltitude`` over the first vertex.
  Landing-pattern complex items are not supported (refused, saying so).
- ``firmwareType`` (MAV_AUTOPILOT: 3 ArduPilot, 12 PX4) chooses the firmware's rules
  where they differ (:func:`planner.io.mission.route.mav_items_to_steps`);
  ``vehicleType`` (MAV_TYPE) the vehicle where the aircraft does not say.
- ``cruiseSpeed`` and ``hoverSpeed`` are QGroundControl's planning speeds, used only for
  its time estimates and never sent to the vehicle (``MissionController``, the offline
  editing settings): they do not set a speed here either. The vehicle flies its own
  cruise speed until a ``DO_CHANGE_SPEED``; a plan speed different from the aircraft's
  is said in a warning.
- The geofence and rally points are not read for the flight; they are kept (with the
  firmware, the vehicle and QGroundControl's speeds) for writing sorties back.
"""

from __future__ import annotations

import copy
import json
import math
import warnings
from pathlib import Path
from typing import Any

from planner.io import files
from planner.physics.atmosphere import ALTITUDE_RANGE_M
from planner.errors import InputError
from planner.physics.geo import aeqd_to_latlon, latlon_to_aeqd
from planner.physics.mission import Environment, Mission, NavDefaults, too_many
from planner.io.mission.route import (FIRMWARES, POSITIONED_CMDS, MavItem, cmd_name,
                                      fly_mav_items)

#: MAV_TYPE values flown as fixed-wing (fixed wing and the VTOL types).
MAV_TYPES_FIXED_WING = frozenset({1, 19, 20, 21, 22, 23, 24, 25})
#: MAV_TYPE values flown as multirotor (quad, coaxial, helicopter, hexa, octo, tri, dodeca).
MAV_TYPES_MULTIROTOR = frozenset({2, 3, 4, 13, 14, 15, 29})
#: Complex items that carry their simple items in ``TransectStyleComplexItem.Items``,
#: with the versions QGroundControl loads (``SurveyComplexItem.cc``,
#: ``CorridorScanComplexItem.cc``).
TRANSECT_ITEMS = {"survey": (2, 3, 4, 5), "CorridorScan": (1, 2)}
#: The structure scan, planned here as QGroundControl generates it (version 3 only).
STRUCTURE_SCAN, STRUCTURE_SCAN_VERSION = "StructureScan", 3
#: The plan file version QGroundControl reads (``PlanMasterController.h``
#: ``kPlanFileVersion``).
PLAN_VERSION = 1
#: QGroundControl's ``AltitudeMode`` "calc above terrain".
ALT_MODE_CALC_ABOVE_TERRAIN = 3


def _is_number(x: Any) -> bool:
    """A JSON number, not a bool (may be the non-standard NaN or Infinity)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _is_finite(x: Any) -> bool:
    """A finite JSON number (not a bool, not the non-standard NaN or Infinity)."""
    try:
        return _is_number(x) and math.isfinite(x)
    except OverflowError:                    # a JSON integer too large for a float
        return False


def _is_int(x: Any) -> bool:
    return (isinstance(x, int) and not isinstance(x, bool)) or (
        isinstance(x, float) and x.is_integer())


def _current_form(item: dict, key: str, where: Path) -> dict:
    """The item in the current ``SimpleItem`` form: QGroundControl's conversions of the
    older forms (``MissionItem::_convertJsonV1ToV2``, ``_convertJsonV2ToV3``)."""
    item = dict(item)
    if item.get("type") == "missionItem" or ("params" not in item and "param1" in item):
        item["params"] = [item.pop(f"param{n}", None) for n in range(1, 5)]
        item["type"] = "SimpleItem"
    if "coordinate" in item:
        coord = item.pop("coordinate")
        params = item.get("params")
        if (not isinstance(coord, list) or len(coord) != 3
                or not isinstance(params, list) or len(params) != 4):
            raise InputError(f"{where}: {key}.coordinate must be [lat, lon, alt] after a "
                             f"params list of 4 (QGroundControl's older item form), got "
                             f"{coord!r} and params {params!r}")
        item["params"] = list(params) + list(coord)
    return item


def _simple_item(item: Any, key: str, seq: int, where: Path) -> MavItem:
    if not isinstance(item, dict):
        raise InputError(f"{where}: {key} must be an object (a mission item), "
                         f"got {type(item).__name__}")
    raw = item
    item = _current_form(item, key, where)
    for name in ("command", "frame"):
        if not _is_int(item.get(name)):
            raise InputError(f"{where}: {key}.{name} must be an integer, got "
                             f"{item.get(name)!r}")
    params = item.get("params")
    if not isinstance(params, list) or len(params) != 7:
        raise InputError(f"{where}: {key}.params must be a list of 7 numbers or nulls, got "
                         f"{params!r}")
    values = []
    for j, v in enumerate(params):
        if v is None:
            values.append(math.nan)
        elif _is_finite(v):
            values.append(float(v))
        elif _is_number(v):
            raise InputError(f"{where}: {key}.param{j + 1} must be a finite number or null, "
                             f"got {v!r}")
        else:
            raise InputError(f"{where}: {key}.param{j + 1} must be a number or null, got {v!r}")
    terrain = item.get("AMSLAltAboveTerrain")
    if terrain is not None and not _is_finite(terrain):
        raise InputError(f"{where}: {key}.AMSLAltAboveTerrain must be a finite number or "
                         f"null, got {terrain!r}")
    mode = item.get("AltitudeMode")
    frame = int(item["frame"])
    command = int(item["command"])
    if (mode == ALT_MODE_CALC_ABOVE_TERRAIN and command in POSITIONED_CMDS
            and math.isnan(values[6])):
        height = item.get("Altitude")
        if not _is_finite(height):
            raise InputError(f"{where}: {key}: a 'calc above terrain' item (AltitudeMode 3) "
                             f"with param7 null needs its Altitude above the ground, got "
                             f"{height!r}")
        values[6] = float(height)
        frame = 10                    # a height above the terrain, as the terrain frame
    jump_id = item.get("doJumpId")
    auto = item.get("autoContinue", True)
    return MavItem(seq=int(jump_id) if _is_int(jump_id) else seq,
                   command=command, frame=frame, params=tuple(values), origin=key,
                   amsl_alt_above_terrain_m=None if terrain is None else float(terrain),
                   raw=raw, autocontinue=int(bool(auto)),
                   altitude_mode=mode if _is_int(mode) else None)


def _number(obj: dict, name: str, key: str, where: Path, *, positive: bool = False) -> float:
    value = obj.get(name)
    if not _is_finite(value) or value < 0 or (positive and value == 0):
        what = "a number > 0" if positive else "a number >= 0"
        raise InputError(f"{where}: {key}.{name} must be {what}, got {value!r}")
    return float(value)


def _offset_polygon(points: list[tuple[float, float]],
                    distance: float) -> list[tuple[float, float]]:
    """QGroundControl's ``QGCMapPolygon::offset``: each edge moved ``distance`` to its
    left (east/north frame; outwards for the clockwise polygons QGroundControl draws),
    the new vertices where consecutive moved edges meet."""
    n = len(points)
    edges = []
    for i in range(n):
        (x1, y1), (x2, y2) = points[i], points[(i + 1) % n]
        length = math.hypot(x2 - x1, y2 - y1)
        if length == 0:
            raise ValueError("two vertices of the polygon coincide")
        nx, ny = -(y2 - y1) / length * distance, (x2 - x1) / length * distance
        edges.append(((x1 + nx, y1 + ny), (x2 + nx, y2 + ny)))
    out = []
    for i in range(n):
        (ax, ay), (bx, by) = edges[i - 1]
        (cx, cy), (dx, dy) = edges[i]
        den = (bx - ax) * (dy - cy) - (by - ay) * (dx - cx)
        if abs(den) < 1e-12:
            raise ValueError("two consecutive edges of the polygon are parallel")
        t = ((cx - ax) * (dy - cy) - (cy - ay) * (dx - cx)) / den
        out.append((ax + t * (bx - ax), ay + t * (by - ay)))
    return out


def _simple_dict(command: int, frame: int, params: list[float]) -> dict:
    return {"autoContinue": True, "command": command, "frame": frame,
            "params": [None if isinstance(v, float) and math.isnan(v) else v for v in params],
            "type": "SimpleItem"}


def structure_scan_items(item: dict, key: str, home: tuple[float, float, float],
                         seq0: int, where: Path) -> list[MavItem]:
    """The mission items QGroundControl generates for a ``StructureScan`` complex item.

    Follows ``StructureScanComplexItem::appendMissionItems`` and ``_recalcLayerInfo``
    (mavlink/qgroundcontrol ``src/MissionManager/StructureScanComplexItem.cc``): entrance
    waypoint over the first vertex of the flight polygon at ``EntranceAltitude``;
    ``DO_SET_ROI_WPNEXT_OFFSET`` (pitch ``GimbalPitch``, yaw offset 90°); per layer a
    waypoint at every vertex and back at the first, ``DO_SET_CAM_TRIGG_DIST``
    (``AdjustedFootprintSide``) after the first and ``DO_SET_CAM_TRIGG_DIST`` 0 after the
    last; ``DO_SET_ROI_NONE``; the exit waypoint over the first vertex. All waypoints
    relative to home (frame 3).

    Raises
    ------
    InputError
        A version other than 3, a missing or non-numeric key, a polygon of fewer than 3
        vertices or one QGroundControl cannot offset.
    """
    version = item.get("version")
    if version != STRUCTURE_SCAN_VERSION:
        raise InputError(f"{where}: {key}: StructureScan version {version!r} not supported "
                         f"(QGroundControl loads version {STRUCTURE_SCAN_VERSION} only: "
                         "'StructureScan version %2 not supported')")
    cam = item.get("CameraCalc")
    if not isinstance(cam, dict):
        raise InputError(f"{where}: {key}.CameraCalc must be an object (the camera's "
                         f"footprint and distance), got {cam!r}")
    ckey = f"{key}.CameraCalc"
    frontal = _number(cam, "AdjustedFootprintFrontal", ckey, where, positive=True)
    side = _number(cam, "AdjustedFootprintSide", ckey, where)
    distance = _number(cam, "DistanceToSurface", ckey, where)
    bottom = _number(item, "ScanBottomAlt", key, where)
    height = _number(item, "StructureHeight", key, where)
    entrance = _number(item, "EntranceAltitude", key, where)
    pitch = item.get("GimbalPitch", 0)
    pitch = float(pitch) if _is_finite(pitch) else 0.0
    from_top = item.get("StartFromTop")
    if not isinstance(from_top, bool):
        raise InputError(f"{where}: {key}.StartFromTop must be true or false, got "
                         f"{from_top!r}")
    polygon = item.get("polygon")
    if (not isinstance(polygon, list) or len(polygon) < 3 or not all(
            isinstance(v, list) and len(v) >= 2 and all(_is_finite(x) for x in v[:2])
            for v in polygon)):
        raise InputError(f"{where}: {key}.polygon must be a list of at least 3 [lat, lon] "
                         f"vertices, got {polygon!r}")
    lat = [float(v[0]) for v in polygon]
    lon = [float(v[1]) for v in polygon]
    east, north = latlon_to_aeqd(lat, lon, home[0], home[1])
    try:
        flight = _offset_polygon(list(zip(map(float, east), map(float, north))), distance)
    except ValueError as exc:
        raise InputError(f"{where}: {key}.polygon: {exc}: QGroundControl cannot offset it "
                         "by the camera distance") from None
    flat, flon = aeqd_to_latlon([p[0] for p in flight], [p[1] for p in flight],
                                home[0], home[1])
    verts = list(zip(map(float, flat), map(float, flon)))
    layers = max(math.ceil(max(height - bottom, 0.0) / frontal), 1)
    given = item.get("Layers")
    if _is_finite(given) and int(given) != layers:
        warnings.warn(f"{where}: {key}: Layers {given!r} recomputed as QGroundControl does "
                      f"from the heights and the frontal footprint: {layers}", stacklevel=3)
    nan = math.nan
    out: list[tuple[int, int, list[float], str]] = []

    def wp(v: tuple[float, float], alt: float, what: str) -> None:
        out.append((16, 3, [0.0, 0.0, 0.0, nan, v[0], v[1], alt], what))

    wp(verts[0], entrance, "entrance")
    out.append((196, 2, [0.0, 0.0, 0.0, 0.0, pitch, 0.0, 90.0], "camera to the structure"))
    half = frontal / 2.0
    layer_alt = (height - half) if from_top else (bottom + half)
    n = len(verts)
    for layer in range(layers):
        for j in range(n + 1):
            wp(verts[j % n], layer_alt, f"layer {layer + 1}")
            if j == 0:
                out.append((206, 2, [side, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
                            f"layer {layer + 1}"))
        out.append((206, 2, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], f"layer {layer + 1}"))
        layer_alt += -frontal if from_top else frontal
    out.append((197, 2, [0.0] * 7, "camera neutral"))
    wp(verts[0], entrance, "exit")
    return [MavItem(seq=seq0 + j, command=cmd, frame=frame, params=tuple(params),
                    origin=f"{key} (structure scan, {what})",
                    raw=_simple_dict(cmd, frame, params))
            for j, (cmd, frame, params, what) in enumerate(out)]


def _complex_item(item: dict, key: str, home: tuple[float, float, float], seq0: int,
                  where: Path) -> list[MavItem]:
    ctype = item.get("complexItemType")
    if ctype == STRUCTURE_SCAN:
        return structure_scan_items(item, key, home, seq0, where)
    if ctype not in TRANSECT_ITEMS:
        raise InputError(f"{where}: {key}: complex item {ctype!r} not supported (expected "
                         f"one of {', '.join([*TRANSECT_ITEMS, STRUCTURE_SCAN])}; a landing "
                         "pattern's items are generated by QGroundControl: export the "
                         "mission as a .waypoints file)")
    version = item.get("version")
    if version is not None and version not in TRANSECT_ITEMS[ctype]:
        name = "Survey items do not" if ctype == "survey" else f"{ctype} does not"
        raise InputError(f"{where}: {key}: {name} support version {version!r} (QGroundControl "
                         f"loads {', '.join(map(str, TRANSECT_ITEMS[ctype]))})")
    transect = item.get("TransectStyleComplexItem")
    sub = transect.get("Items") if isinstance(transect, dict) else None
    if not isinstance(sub, list) or not sub:
        raise InputError(f"{where}: {key}: {ctype} item has no "
                         "TransectStyleComplexItem.Items to fly (expected the list of "
                         "simple items QGroundControl saves, which it requires too: 'The "
                         "following required keys are missing: Items')")
    return [_simple_item(s, f"{key}.TransectStyleComplexItem.Items[{j + 1}]", seq0 + j, where)
            for j, s in enumerate(sub)]


def _home(mission: dict, path: Path) -> tuple[float, float, float]:
    home = mission.get("plannedHomePosition")
    if (not isinstance(home, list) or len(home) < 3
            or not all(_is_finite(v) for v in home[:3])):
        raise InputError(f"{path}: mission.plannedHomePosition must be [lat, lon, alt_amsl] "
                         f"(finite numbers), got {home!r}")
    if not (-90 <= home[0] <= 90 and -180 <= home[1] <= 180):
        raise InputError(f"{path}: mission.plannedHomePosition latitude/longitude {home[0]:g}, "
                         f"{home[1]:g} out of range (expected -90..90, -180..180 degrees)")
    lo, hi = ALTITUDE_RANGE_M
    if not lo <= home[2] <= hi:
        raise InputError(f"{path}: mission.plannedHomePosition altitude {home[2]:g} m above "
                         f"mean sea level is outside the atmosphere model (expected {lo:g} to "
                         f"{hi:g} m)")
    return float(home[0]), float(home[1]), float(home[2])


def read_plan(path: str | Path) -> tuple[dict, list[MavItem]]:
    """Read a ``.plan`` file into its JSON object and flat list of mission items.

    Returns
    -------
    data : dict
        The whole plan as written.
    items : list of MavItem
        The mission items, complex items expanded into the simple items they fly.

    Raises
    ------
    InputError
        Unreadable or broken JSON, a plan version QGroundControl refuses, a missing or
        wrong key, a complex item that cannot be expanded, nothing to fly.
    """
    path = Path(path)
    try:
        data = json.loads(files.read_text(path, "mission", "mission file",
                                          encoding="utf-8-sig"))
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON (line {exc.lineno} column {exc.colno}: "
                         f"{exc.msg}); expected a QGroundControl plan (whose JSON parser, "
                         "like this one, takes no comments)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the file ({exc})") from None
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a JSON object with a 'mission' key "
                         "(a QGroundControl plan)")
    if data.get("fileType", "Plan") != "Plan":
        raise InputError(f"{path}: fileType is {data.get('fileType')!r} (expected 'Plan')")
    version = data.get("version", PLAN_VERSION)
    if version != PLAN_VERSION:
        if _is_number(version) and version > PLAN_VERSION:
            why = f"File version {version} is newer than current supported version 1"
        else:
            why = f"File version {version!r} is no longer supported"
        raise InputError(f"{path}: version is {version!r} (expected {PLAN_VERSION}: "
                         f"QGroundControl refuses it, '{why}')")
    if "mission" not in data:
        raise InputError(f"{path}: no 'mission' key (expected the mission object; "
                         "QGroundControl: 'The following required keys are missing: "
                         "mission')")
    mission = data.get("mission")
    if not isinstance(mission, dict):
        raise InputError(f"{path}: mission must be an object with 'items' and "
                         "'plannedHomePosition'")
    home = _home(mission, path)
    items = mission.get("items")
    if not isinstance(items, list) or not items:
        raise InputError(f"{path}: mission.items must be a non-empty list of mission items")
    if (msg := too_many(str(path), "mission items", len(items))) is not None:
        raise InputError(msg)
    flat: list[MavItem] = []
    for i, item in enumerate(items):
        key = f"mission.items[{i + 1}]"
        kind = item.get("type") if isinstance(item, dict) else None
        if kind in ("SimpleItem", "missionItem"):
            flat.append(_simple_item(item, key, len(flat) + 1, path))
        elif kind == "ComplexItem":
            flat.extend(_complex_item(item, key, home, len(flat) + 1, path))
            if (msg := too_many(str(path), "mission items with the survey's",
                                len(flat))) is not None:
                raise InputError(msg)
        else:
            raise InputError(f"{path}: {key}.type must be 'SimpleItem' or 'ComplexItem', "
                             f"got {kind!r}")
    navigation = [it for it in flat if it.command in POSITIONED_CMDS or it.command == 20]
    if not navigation:
        only = sorted({cmd_name(it.command) for it in flat})
        raise InputError(f"{path}: mission.items: no navigation command, only "
                         f"{', '.join(only)}: nothing to fly (expected a take-off or a "
                         "waypoint; ArduCopter refuses to start a mission without a take-off "
                         "on the ground, 'Auto: Missing Takeoff Cmd')")
    if home[0] == 0 and home[1] == 0:
        raise InputError(f"{path}: mission.plannedHomePosition is 0, 0 (expected the home "
                         "latitude and longitude)")
    return data, flat


def plan_vehicle_type(mission: dict) -> str | None:
    """``"multirotor"``, ``"fixed_wing"`` or ``None`` from ``mission.vehicleType``."""
    mav_type = mission.get("vehicleType")
    if mav_type in MAV_TYPES_FIXED_WING:
        return "fixed_wing"
    if mav_type in MAV_TYPES_MULTIROTOR:
        return "multirotor"
    return None


def load_plan(path: str | Path, *, vehicle_type: str | None = None,
              defaults: NavDefaults | None = None) -> Mission:
    """Load a QGroundControl ``.plan`` file.

    Parameters
    ----------
    path : str or Path
    vehicle_type : {"multirotor", "fixed_wing"} or None
        Overrides ``mission.vehicleType``.
    defaults : NavDefaults or None
        The aircraft's speeds and rates (:func:`planner.io.mission.route.route_to_legs`).

    Returns
    -------
    Mission
        Named after the file; home from ``plannedHomePosition``; the
        environment's site altitude is the home altitude; ``Mission.file`` keeps the
        items, geofence, rally points, firmware and vehicle to write sorties back.
    """
    path = Path(path)
    data, items = read_plan(path)
    mission = data["mission"]
    lat, lon, alt = _home(mission, path)
    vtype = vehicle_type or (defaults.vehicle_type if defaults else None) \
        or plan_vehicle_type(mission)
    firmware = FIRMWARES.get(mission.get("firmwareType"))
    if defaults is not None:
        key = "hoverSpeed" if defaults.vehicle_type == "multirotor" else "cruiseSpeed"
        planned = mission.get(key)
        if _is_finite(planned) and abs(planned - defaults.cruise_speed_ms) > 0.01:
            warnings.warn(f"{path}: mission.{key} {planned:g} m/s is QGroundControl's planning "
                          "speed, never sent to the vehicle: the aircraft flies its own "
                          f"{defaults.cruise_speed_ms:g} m/s until a DO_CHANGE_SPEED",
                          stacklevel=2)
    kept = copy.deepcopy({k: v for k, v in data.items() if k != "mission"})
    kept["mission"] = copy.deepcopy({k: v for k, v in mission.items() if k != "items"})
    home = MavItem(seq=0, command=16, frame=0, params=(0.0, 0.0, 0.0, 0.0, lat, lon, alt),
                   origin="mission.plannedHomePosition")
    legs, file = fly_mav_items(items, home, where=str(path), fmt="plan", vehicle_type=vtype,
                               firmware=firmware, defaults=defaults, plan=kept)
    return Mission(name=path.stem, legs=legs, environment=Environment(site_altitude_m=alt),
                   home=(lat, lon, alt), source=str(path), file=file)
