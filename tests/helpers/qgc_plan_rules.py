"""QGroundControl's loader rules for a ``.plan`` file, written out for the tests.

An independent check of what QGroundControl accepts, from its own source
(mavlink/qgroundcontrol ``src/MissionManager``, ``src/JsonHelper.cc``):

* ``PlanMasterController::loadFromFile`` / ``JsonHelper::validateExternalQGCJsonFile``:
  ``fileType`` "Plan", ``groundStation`` a string, ``version`` 1 ("File version %1 is
  newer than current supported version 1"), and the objects ``mission``, ``geoFence`` and
  ``rallyPoints`` all required ("The following required keys are missing: ...").
* ``MissionController::_loadJsonMissionFileV2``: ``plannedHomePosition`` an array with an
  altitude, ``items`` an array, ``firmwareType`` a number; ``vehicleType``,
  ``cruiseSpeed``, ``hoverSpeed`` numbers where present; an item's ``type`` "SimpleItem"
  or "ComplexItem" ("Unknown item type"); a ``DO_JUMP``'s param1 a ``doJumpId`` of the
  plan ("Could not find doJumpId").
* ``MissionItem::load``: ``frame`` and ``command`` numbers, ``params`` 7 entries ("params
  key must contains 7 values"), the first four numbers or ``null``, ``autoContinue`` a
  bool; ``SimpleMissionItem::load``: ``AltitudeMode``, ``Altitude`` and
  ``AMSLAltAboveTerrain`` all present if one is.
* ``SurveyComplexItem`` versions 2 to 5 and ``TransectStyleComplexItem.Items`` required;
  ``StructureScan`` version 3 with its keys.
* ``GeoFenceController::load``: a version 1 (or missing) section is ignored; else version
  2 with ``circles`` and ``polygons`` arrays; ``QGCFencePolygon``: version 1,
  ``inclusion`` bool, ``polygon`` of ``[lat, lon]``; ``QGCFenceCircle``: ``inclusion`` and
  ``circle: {center: [lat, lon], radius}``.
* ``RallyPointController::load``: version 1 ignored; else version 2 and ``points`` of
  ``[lat, lon, alt]``.

:func:`qgc_problems` returns what QGroundControl would refuse (an empty list: it loads).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def _num(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _num_or_null(x: Any) -> bool:
    return x is None or _num(x)


def _coord(x: Any, altitude: bool) -> bool:
    n = 3 if altitude else 2
    return isinstance(x, list) and len(x) >= n and all(_num(v) for v in x[:n])


def _simple(item: dict, where: str, problems: list[str]) -> None:
    if not _num(item.get("frame")) or not _num(item.get("command")):
        problems.append(f"{where}: frame and command must be numbers")
    params = item.get("params")
    if "coordinate" in item:                       # the older form QGC converts
        if not (isinstance(params, list) and len(params) == 4
                and _coord(item["coordinate"], True)):
            problems.append(f"{where}: coordinate form needs 4 params and [lat, lon, alt]")
        return
    if not isinstance(params, list) or len(params) != 7:
        problems.append(f"{where}: params key must contains 7 values")
        return
    if not all(_num_or_null(v) for v in params[:4]):
        problems.append(f"{where}: params 1-4 must be double or null")
    if not isinstance(item.get("autoContinue"), bool):
        problems.append(f"{where}: autoContinue must be a bool")
    alt_keys = [k for k in ("AltitudeMode", "Altitude", "AMSLAltAboveTerrain") if k in item]
    if alt_keys and len(alt_keys) != 3:
        problems.append(f"{where}: AltitudeMode, Altitude, AMSLAltAboveTerrain all required "
                        f"once one is given (has {alt_keys})")


def _complex(item: dict, where: str, problems: list[str]) -> None:
    ctype = item.get("complexItemType")
    version = item.get("version")
    if ctype == "survey":
        if version not in (2, 3, 4, 5):
            problems.append(f"{where}: Survey items do not support version {version}")
        transect = item.get("TransectStyleComplexItem")
        if not isinstance(transect, dict) or "Items" not in transect:
            problems.append(f"{where}: The following required keys are missing: Items")
    elif ctype == "StructureScan":
        if version != 3:
            problems.append(f"{where}: StructureScan version {version} not supported")
        for key in ("polygon", "ScanBottomAlt", "StructureHeight", "Layers", "CameraCalc",
                    "EntranceAltitude", "GimbalPitch", "StartFromTop"):
            if key not in item:
                problems.append(f"{where}: The following required keys are missing: {key}")
    elif ctype not in ("CorridorScan", "fwLandingPattern", "vtolLandingPattern"):
        problems.append(f"{where}: Unsupported complex item type: {ctype}")


def _fence(fence: Any, problems: list[str]) -> None:
    if not isinstance(fence, dict):
        problems.append("geoFence must be an object")
        return
    if fence.get("version", 1) == 1:
        return                                   # ignored by QGroundControl
    if fence.get("version") != 2:
        problems.append("GeoFence supports version 2")
    for key in ("circles", "polygons"):
        if not isinstance(fence.get(key), list):
            problems.append(f"geoFence.{key} must be an array")
    for i, poly in enumerate(fence.get("polygons") or []):
        if (not isinstance(poly, dict) or poly.get("version") != 1
                or not isinstance(poly.get("inclusion"), bool)
                or not isinstance(poly.get("polygon"), list)
                or not all(_coord(v, False) for v in poly["polygon"])):
            problems.append(f"geoFence.polygons[{i}] is not a version 1 fence polygon")
    for i, circ in enumerate(fence.get("circles") or []):
        c = circ.get("circle") if isinstance(circ, dict) else None
        if (not isinstance(circ.get("inclusion"), bool) or not isinstance(c, dict)
                or not _coord(c.get("center"), False) or not _num(c.get("radius"))):
            problems.append(f"geoFence.circles[{i}] is not a fence circle")


def _rally(rally: Any, problems: list[str]) -> None:
    if not isinstance(rally, dict):
        problems.append("rallyPoints must be an object")
        return
    if rally.get("version", 1) == 1:
        return
    if rally.get("version") != 2:
        problems.append("Rally Points supports version 2")
    points = rally.get("points")
    if not isinstance(points, list) or not all(_coord(p, True) for p in points):
        problems.append("rallyPoints.points must be [lat, lon, alt] arrays")


def qgc_problems(path: str | Path) -> list[str]:
    """Why QGroundControl would refuse the plan at ``path`` (empty: it loads it)."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        return [f"not JSON: {exc}"]
    problems: list[str] = []
    if not isinstance(data, dict):
        return ["not a JSON object"]
    if data.get("fileType") != "Plan":
        problems.append("Incorrect file type key expected:Plan")
    if not isinstance(data.get("groundStation"), str):
        problems.append("groundStation must be a string")
    if data.get("version") != 1:
        problems.append(f"File version {data.get('version')} is not supported")
    missing = [k for k in ("mission", "geoFence", "rallyPoints") if k not in data]
    if missing:
        problems.append(f"The following required keys are missing: {', '.join(missing)}")
        return problems
    mission = data["mission"]
    if not isinstance(mission, dict):
        return problems + ["mission must be an object"]
    if not _coord(mission.get("plannedHomePosition"), True):
        problems.append("plannedHomePosition must be [lat, lon, alt]")
    if not _num(mission.get("firmwareType")):
        problems.append("firmwareType must be a number")
    for key in ("vehicleType", "cruiseSpeed", "hoverSpeed"):
        if key in mission and not _num(mission[key]):
            problems.append(f"{key} must be a number")
    items = mission.get("items")
    if not isinstance(items, list):
        return problems + ["items must be an array"]
    jump_ids = {it.get("doJumpId") for it in items if isinstance(it, dict)}
    for i, item in enumerate(items):
        where = f"items[{i}]"
        kind = item.get("type") if isinstance(item, dict) else None
        if kind == "SimpleItem":
            _simple(item, where, problems)
            if item.get("command") == 177 and item["params"][0] not in jump_ids:
                problems.append(f"{where}: Could not find doJumpId: {item['params'][0]}")
        elif kind == "ComplexItem":
            _complex(item, where, problems)
        else:
            problems.append(f"{where}: Unknown item type: {kind}")
    _fence(data["geoFence"], problems)
    _rally(data["rallyPoints"], problems)
    return problems
