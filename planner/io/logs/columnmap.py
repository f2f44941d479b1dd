"""Column maps: how the columns of someone else's CSV log become the flight record.

A map (a YAML file, or the name of one shipped in ``planner/io/logs/maps``) names the CSV
column behind each flight-record column (docs/record.md), with scale and offset, derived
columns (speed from velocity components, …), extra columns kept as they are, and the
log's metadata. :func:`load_map` validates it once and returns the normalised mapping
:func:`planner.logs.csvmap.read_csv_log` applies.
"""

from __future__ import annotations

import difflib
import math
import os
from pathlib import Path

import yaml

from planner.io import files
from planner.errors import InputError
from planner.io.record import COLUMNS

__all__ = ["MAPS_DIR", "load_map"]


#: Where the maps shipped with the planner live.
MAPS_DIR = Path(__file__).resolve().parents[1] / "logs" / "maps"

_TOP_KEYS = {"name", "source", "experiment", "time", "columns", "derived", "extra", "meta",
             "license", "notes"}
_COL_KEYS = {"column", "scale", "offset", "relative", "missing", "note"}
_TIME_KEYS = {"column", "scale", "offset", "zero", "note"}
_DERIVED_KEYS = {"op", "of", "scale", "offset", "note"}
#: Ops that rotate a body-frame velocity by the attitude quaternion: seven CSV columns.
ROTATE_OPS = {"enu_up", "enu_horizontal", "enu_course"}
_OPS = {"hypot", "product", "course", "sum", "difference"} | ROTATE_OPS
_META_KEYS = {"vehicle_type", "vehicle", "firmware", "battery_capacity_mah", "battery_cells",
              "aircraft", "battery"}


def _unknown(where: str, key: str, allowed: set) -> InputError:
    close = difflib.get_close_matches(str(key), sorted(allowed), n=3)
    hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else \
        f"; expected one of {', '.join(sorted(allowed))}"
    return InputError(f"{where}: unknown key '{key}'{hint}")


def _number(where: str, key: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{where}: {key} must be a number, got {value!r}")
    try:
        finite = math.isfinite(value)
    except OverflowError:                    # an integer too large for a float
        finite = False
    if not finite:
        shown = repr(value) if isinstance(value, float) else f"an integer of {len(str(value))} digits"
        raise InputError(f"{where}: {key} must be a finite number, got {shown}")
    return float(value)


def load_map(source: str | os.PathLike | dict) -> dict:
    """Load and validate a column map (a YAML file, a shipped map name, or a dict).

    ``source`` may be a path, or the name of a map in :data:`MAPS_DIR`
    (``"dji_m100"``). Returns the normalised map; every problem raises
    :class:`InputError` naming the file and the key.
    """
    if isinstance(source, dict):
        raw, where = source, "<column map>"
    else:
        path = Path(source)
        if not path.exists() and (MAPS_DIR / f"{path.name}.yaml").exists():
            path = MAPS_DIR / f"{path.name}.yaml"
        where = str(path)
        if not path.exists():
            raise InputError(f"{path}: column map not found")
        try:
            raw = files.load_yaml(path, "definition", "column map")
        except yaml.YAMLError as exc:
            raise InputError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(raw, dict):
        raise InputError(f"{where}: a column map must be a mapping with 'time' and 'columns'")
    for key in raw:
        if key not in _TOP_KEYS:
            raise _unknown(where, key, _TOP_KEYS)
    out: dict = {"name": raw.get("name"), "source": raw.get("source"), "where": where}

    exp = raw.get("experiment")
    if isinstance(exp, dict):
        if set(exp) - {"column", "note"}:
            raise _unknown(f"{where}: experiment", next(iter(set(exp) - {"column", "note"})),
                           {"column"})
        exp = exp.get("column")
    if exp is not None and not isinstance(exp, str):
        raise InputError(f"{where}: experiment must be a column name, got {exp!r}")
    out["experiment"] = exp

    t = raw.get("time")
    if t is None:
        raise InputError(f"{where}: missing required key 'time' (the CSV time column)")
    if isinstance(t, str):
        t = {"column": t}
    if not isinstance(t, dict) or "column" not in t:
        raise InputError(f"{where}: time must be a column name or {{column: ..., scale: ...}}")
    for key in t:
        if key not in _TIME_KEYS:
            raise _unknown(f"{where}: time", key, _TIME_KEYS)
    out["time"] = {"column": str(t["column"]),
                   "scale": _number(where, "time.scale", t.get("scale", 1.0)),
                   "offset": _number(where, "time.offset", t.get("offset", 0.0)),
                   "zero": bool(t.get("zero", True))}
    if not out["time"]["scale"] > 0:
        raise InputError(f"{where}: time.scale must be > 0, got {out['time']['scale']}")

    cols = raw.get("columns") or {}
    if not isinstance(cols, dict):
        raise InputError(f"{where}: columns must be a mapping record_column: {{column: ...}}")
    out["columns"] = {}
    for ours, spec in cols.items():
        if ours not in COLUMNS or ours in ("experiment", "time_s"):
            raise _unknown(f"{where}: columns", ours,
                           set(COLUMNS) - {"experiment", "time_s"})
        if isinstance(spec, str):
            spec = {"column": spec}
        if not isinstance(spec, dict) or "column" not in spec:
            raise InputError(f"{where}: columns.{ours} must be {{column: <csv column>, ...}}")
        for key in spec:
            if key not in _COL_KEYS:
                raise _unknown(f"{where}: columns.{ours}", key, _COL_KEYS)
        missing = spec.get("missing", [])
        if not isinstance(missing, list):
            missing = [missing]
        out["columns"][ours] = {
            "column": str(spec["column"]),
            "scale": _number(where, f"columns.{ours}.scale", spec.get("scale", 1.0)),
            "offset": _number(where, f"columns.{ours}.offset", spec.get("offset", 0.0)),
            "relative": bool(spec.get("relative", False)),
            "missing": [_number(where, f"columns.{ours}.missing", m) for m in missing],
        }

    der = raw.get("derived") or {}
    if not isinstance(der, dict):
        raise InputError(f"{where}: derived must be a mapping record_column: {{op: ..., of: ...}}")
    out["derived"] = {}
    for ours, spec in der.items():
        if ours not in COLUMNS or ours in ("experiment", "time_s"):
            raise _unknown(f"{where}: derived", ours, set(COLUMNS) - {"experiment", "time_s"})
        if not isinstance(spec, dict):
            raise InputError(f"{where}: derived.{ours} must be {{op: ..., of: [...]}}")
        for key in spec:
            if key not in _DERIVED_KEYS:
                raise _unknown(f"{where}: derived.{ours}", key, _DERIVED_KEYS)
        op = spec.get("op")
        if op not in _OPS:
            raise InputError(f"{where}: derived.{ours}.op must be one of "
                             f"{', '.join(sorted(_OPS))}, got {op!r}")
        of = spec.get("of")
        sizes = (2, 3) if op == "hypot" else (7,) if op in ROTATE_OPS else (2,)
        if not isinstance(of, list) or len(of) not in sizes or not all(isinstance(c, str)
                                                                     for c in of):
            what = ("two CSV columns (three for hypot)" if op == "hypot" else
                    "seven CSV columns: the body-frame velocity x, y, z and the attitude "
                    "quaternion x, y, z, w" if op in ROTATE_OPS else "two CSV columns")
            raise InputError(f"{where}: derived.{ours}.of must list {what}, got {of!r}")
        out["derived"][ours] = {
            "op": op, "of": of,
            "scale": _number(where, f"derived.{ours}.scale", spec.get("scale", 1.0)),
            "offset": _number(where, f"derived.{ours}.offset", spec.get("offset", 0.0)),
        }

    extra = raw.get("extra") or {}
    if not isinstance(extra, dict):
        raise InputError(f"{where}: extra must be a mapping new_name: {{column: ...}}")
    out["extra"] = {}
    for name, spec in extra.items():
        if name in COLUMNS:
            raise InputError(f"{where}: extra.{name} is a flight-record column; "
                             "map it under 'columns'")
        if isinstance(spec, str):
            spec = {"column": spec}
        if not isinstance(spec, dict) or "column" not in spec:
            raise InputError(f"{where}: extra.{name} must be {{column: <csv column>}}")
        for key in spec:
            if key not in _COL_KEYS:
                raise _unknown(f"{where}: extra.{name}", key, _COL_KEYS)
        out["extra"][name] = {
            "column": str(spec["column"]),
            "scale": _number(where, f"extra.{name}.scale", spec.get("scale", 1.0)),
            "offset": _number(where, f"extra.{name}.offset", spec.get("offset", 0.0)),
            "relative": False, "missing": [],
        }

    meta = raw.get("meta") or {}
    if not isinstance(meta, dict):
        raise InputError(f"{where}: meta must be a mapping")
    for key in meta:
        if key not in _META_KEYS:
            raise _unknown(f"{where}: meta", key, _META_KEYS)
    for key, (low, high) in (("battery_cells", (1, 40)),
                             ("battery_capacity_mah", (1.0, 1e7))):
        if key in meta:
            value = meta[key]
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not low <= value <= high
                    or (key == "battery_cells" and not float(value).is_integer())):
                raise InputError(f"{where}: meta.{key}: expected a "
                                 f"{'whole ' if key == 'battery_cells' else ''}number in "
                                 f"[{low:g}, {high:g}], got {value!r}")
    out["meta"] = dict(meta)
    if not out["columns"] and not out["derived"]:
        raise InputError(f"{where}: the map has no 'columns'")
    return out


