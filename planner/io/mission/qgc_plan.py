"""QGroundControl ``.plan`` files (JSON).

Schema (https://docs.qgroundcontrol.com/master/en/qgc-dev-guide/file_formats/plan.html)::

    {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
     "mission": {"plannedHomePosition": [lat, lon, alt_amsl],
                 "cruiseSpeed": 15, "hoverSpeed": 5, "vehicleType": 2,
                 "firmwareType": 3, "version": 2,
                 "items": [{"type": "SimpleItem", "command": 22, "frame": 3,
                            "params": [p1, p2, p3, p4, lat, lon, alt],
                            "doJumpId": 1, "autoContinue": true,
                            "AMSLAltAboveTerrain": null, ...},
                           {"type": "ComplexItem", "complexItemType": "survey",
                            "TransectStyleComplexItem": {"Items": [simple items ...]}}]},
     "geoFence": {...}, "rallyPoints": {...}}

``null`` params are read as NaN ("unset"); the non-standard JSON ``NaN`` and
``Infinity`` that Python's reader accepts are refused, as is a home position
that is not finite or out of range. Survey, corridor-scan and structure-scan
complex items are flown through the simple items QGroundControl saved in
``TransectStyleComplexItem.Items``; other complex items (landing patterns) are
not supported. The geofence and rally points are not read.

The default speed is ``hoverSpeed`` for a multirotor and ``cruiseSpeed`` for a
fixed-wing (and VTOL) aircraft, the type taken from the ``vehicle_type``
argument or else from ``mission.vehicleType`` (MAV_TYPE); with neither, the
aircraft's own default applies.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from planner.io import files
from planner.physics.atmosphere import ALTITUDE_RANGE_M
from planner.errors import InputError
from planner.physics.mission import Environment, Mission, too_many
from planner.io.mission.route import MAX_SPEED_MS, MavItem, mav_items_to_steps, route_to_legs

#: MAV_TYPE values flown as fixed-wing (fixed wing and the VTOL types).
MAV_TYPES_FIXED_WING = frozenset({1, 19, 20, 21, 22, 23, 24, 25})
#: MAV_TYPE values flown as multirotor (quad, coaxial, helicopter, hexa, octo, tri, dodeca).
MAV_TYPES_MULTIROTOR = frozenset({2, 3, 4, 13, 14, 15, 29})
#: Complex items that carry their simple items in ``TransectStyleComplexItem.Items``.
TRANSECT_ITEMS = ("survey", "CorridorScan", "StructureScan")


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


def _simple_item(item: Any, key: str, seq: int, where: Path) -> MavItem:
    if not isinstance(item, dict):
        raise InputError(f"{where}: {key} must be an object (a mission item), "
                         f"got {type(item).__name__}")
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
    jump_id = item.get("doJumpId")
    return MavItem(seq=int(jump_id) if _is_int(jump_id) else seq,
                   command=int(item["command"]), frame=int(item["frame"]),
                   params=tuple(values), origin=key,
                   amsl_alt_above_terrain_m=None if terrain is None else float(terrain))


def read_plan(path: str | Path) -> tuple[dict, list[MavItem]]:
    """Read a ``.plan`` file into its ``mission`` object and flat list of mission items.

    Raises
    ------
    InputError
        Unreadable or broken JSON, a missing or wrong key, a complex item that
        cannot be expanded.
    """
    path = Path(path)
    try:
        data = json.loads(files.read_text(path, "mission", "mission file",
                                          encoding="utf-8-sig"))
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON (line {exc.lineno} column {exc.colno}: "
                         f"{exc.msg}); expected a QGroundControl plan") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read the file ({exc})") from None
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a JSON object with a 'mission' key "
                         "(a QGroundControl plan)")
    if data.get("fileType", "Plan") != "Plan":
        raise InputError(f"{path}: fileType is {data.get('fileType')!r} (expected 'Plan')")
    mission = data.get("mission")
    if not isinstance(mission, dict):
        raise InputError(f"{path}: mission must be an object with 'items' and "
                         "'plannedHomePosition'")
    home = mission.get("plannedHomePosition")
    if (not isinstance(home, list) or len(home) < 3
            or not all(_is_finite(v) for v in home[:3])):
        raise InputError(f"{path}: mission.plannedHomePosition must be [lat, lon, alt_amsl] "
                         f"(finite numbers), got {home!r}")
    if home[0] == 0 and home[1] == 0:
        raise InputError(f"{path}: mission.plannedHomePosition is 0, 0 (expected the home "
                         "latitude and longitude)")
    if not (-90 <= home[0] <= 90 and -180 <= home[1] <= 180):
        raise InputError(f"{path}: mission.plannedHomePosition latitude/longitude {home[0]:g}, "
                         f"{home[1]:g} out of range (expected -90..90, -180..180 degrees)")
    lo, hi = ALTITUDE_RANGE_M
    if not lo <= home[2] <= hi:
        raise InputError(f"{path}: mission.plannedHomePosition altitude {home[2]:g} m above "
                         f"mean sea level is outside the atmosphere model (expected {lo:g} to "
                         f"{hi:g} m)")
    items = mission.get("items")
    if not isinstance(items, list) or not items:
        raise InputError(f"{path}: mission.items must be a non-empty list of mission items")
    if (msg := too_many(str(path), "mission items", len(items))) is not None:
        raise InputError(msg)
    flat: list[MavItem] = []
    for i, item in enumerate(items):
        key = f"mission.items[{i + 1}]"
        kind = item.get("type") if isinstance(item, dict) else None
        if kind == "SimpleItem":
            flat.append(_simple_item(item, key, len(flat) + 1, path))
        elif kind == "ComplexItem":
            ctype = item.get("complexItemType")
            if ctype not in TRANSECT_ITEMS:
                raise InputError(f"{path}: {key}: complex item {ctype!r} not supported "
                                 f"(expected one of {', '.join(TRANSECT_ITEMS)})")
            transect = item.get("TransectStyleComplexItem")
            sub = transect.get("Items") if isinstance(transect, dict) else None
            if not isinstance(sub, list) or not sub:
                raise InputError(f"{path}: {key}: {ctype} item has no "
                                 "TransectStyleComplexItem.Items to fly (expected the list of "
                                 "simple items QGroundControl saves; re-save the plan)")
            for j, s in enumerate(sub):
                flat.append(_simple_item(s, f"{key}.TransectStyleComplexItem.Items[{j + 1}]",
                                         len(flat) + 1, path))
            if (msg := too_many(str(path), "mission items with the survey's",
                                len(flat))) is not None:
                raise InputError(msg)
        else:
            raise InputError(f"{path}: {key}.type must be 'SimpleItem' or 'ComplexItem', "
                             f"got {kind!r}")
    return mission, flat


def plan_vehicle_type(mission: dict) -> str | None:
    """``"multirotor"``, ``"fixed_wing"`` or ``None`` from ``mission.vehicleType``."""
    mav_type = mission.get("vehicleType")
    if mav_type in MAV_TYPES_FIXED_WING:
        return "fixed_wing"
    if mav_type in MAV_TYPES_MULTIROTOR:
        return "multirotor"
    return None


def load_plan(path: str | Path, *, vehicle_type: str | None = None) -> Mission:
    """Load a QGroundControl ``.plan`` file.

    Parameters
    ----------
    path : str or Path
    vehicle_type : {"multirotor", "fixed_wing"} or None
        Overrides ``mission.vehicleType`` for the default speed.

    Returns
    -------
    Mission
        Named after the file; home from ``plannedHomePosition``; the
        environment's site altitude is the home altitude.
    """
    path = Path(path)
    mission, items = read_plan(path)
    lat, lon, alt = (float(v) for v in mission["plannedHomePosition"][:3])
    vtype = vehicle_type or plan_vehicle_type(mission)
    key = {"multirotor": "hoverSpeed", "fixed_wing": "cruiseSpeed"}.get(vtype)
    speed = mission.get(key) if key else None
    if speed is not None and (not _is_finite(speed) or not 0 < speed <= MAX_SPEED_MS):
        raise InputError(f"{path}: mission.{key} must be a number in (0, {MAX_SPEED_MS:g}] m/s, "
                         f"got {speed!r}")
    steps = mav_items_to_steps(items, alt, where=str(path), vehicle_type=vtype)
    legs = route_to_legs(steps, lat, lon, where=str(path),
                         speed_ms=None if speed is None else float(speed))
    return Mission(name=path.stem, legs=legs, environment=Environment(site_altitude_m=alt),
                   home=(lat, lon, alt), source=str(path))
