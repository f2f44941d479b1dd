"""Column maps: how the columns of someone else's CSV log become the flight record.

A map (a YAML file, or the name of one shipped in ``planner/io/logs/maps``) names the CSV
column behind each flight-record column (docs/record.md), with scale and offset, derived
columns (speed from velocity components, …), extra columns kept as they are, and the
log's metadata. Its keys are declared once, in the tables below, and validated by the one
validator of YAML input (:mod:`planner.io.schema`): every problem of a map is reported at
once, naming the file and the key path. :func:`load_map` returns the normalised mapping
:func:`planner.io.logs.csvmap.read_csv_log` applies.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from planner.errors import InputError
from planner.io import files
from planner.io import schema as S
from planner.io.record import COLUMNS
from planner.physics.limits import CAPACITY_MAX_MAH, CAPACITY_MIN_MAH, CELLS_SERIES_MAX

__all__ = ["COLUMN_KEYS", "DERIVED_KEYS", "FLIGHTS_KEYS", "MAPS_DIR", "META_KEYS",
           "PER_FLIGHT", "ROTATE_OPS", "TIME_KEYS", "TOP_KEYS", "load_map", "map_columns",
           "match_map"]


#: Where the maps shipped with the planner live.
MAPS_DIR = Path(__file__).resolve().parent / "maps"

#: Ops that rotate a body-frame velocity by the attitude quaternion: seven CSV columns.
ROTATE_OPS = ("enu_up", "enu_horizontal", "enu_course")
#: Every op of ``derived``, and the number of CSV columns each takes.
OPS = {"hypot": (2, 3), "product": (2,), "course": (2,), "sum": (2,), "difference": (2,),
       **{op: (7,) for op in ROTATE_OPS}}

_NOTE = S.text("free text")

TOP_KEYS = {
    "name": S.text("name of the map"),
    "source": S.text("where the data and the map come from"),
    "experiment": S.Key(S.ANY, meaning=(
        "CSV column with the experiment id, or `{column: ...}` (absent: the file name)")),
    "time": S.Key(S.ANY, required=True, meaning=(
        "the CSV time column, or `{column: ..., scale: ..., offset: ..., zero: ...}`")),
    "columns": S.block("record column ← `{column, scale, offset, relative, missing}` (or "
                       "the CSV column's name)"),
    "derived": S.block("record column ← `{op, of, scale, offset}`: from several CSV columns"),
    "extra": S.block("new name ← `{column, scale, offset}`: CSV columns kept as they are"),
    "meta": S.block("what the file does not say (table below)"),
    "flights": S.block("a per-flight table joined by experiment id (table below): what each "
                       "flight carried or was commanded (payload, speed, altitude)"),
    "license": S.text("licence of the data"),
    "notes": _NOTE,
    "header": S.Key(S.LIST, meaning=(
        "the names of the columns, in order, of a file that has no header row (its first "
        "row is data); the map's other keys use these names")),
}

TIME_KEYS = {
    "column": S.text("the CSV time column", required=True),
    "scale": S.positive(default=1.0, meaning="to seconds (0.001 for ms, 1e-6 for µs)"),
    "offset": S.Key(S.NUMBER, default=0.0, unit="s", meaning="added after the scale"),
    "zero": S.Key(S.BOOL, default=True, meaning="time from 0 at each experiment's first row"),
    "note": _NOTE,
}

COLUMN_KEYS = {
    "column": S.text("the CSV column", required=True),
    "scale": S.Key(S.NUMBER, default=1.0, meaning="to the record column's unit"),
    "offset": S.Key(S.NUMBER, default=0.0, meaning="added after the scale"),
    "relative": S.Key(S.BOOL, default=False, meaning=(
        "minus its first valid value in each experiment (altitude above the start)")),
    "missing": S.Key(S.ANY, meaning="raw values that mean \"not measured\": a number or a list"),
    "note": _NOTE,
}

EXTRA_KEYS = {key: COLUMN_KEYS[key] for key in ("column", "scale", "offset", "note")}

DERIVED_KEYS = {
    "op": S.text("`hypot` of two or three columns, `product`, `sum`, `difference`, `course` "
                 "from north and east speeds; `enu_up`, `enu_horizontal`, `enu_course` of a "
                 "body-frame velocity x, y, z rotated by the attitude quaternion x, y, z, w",
                 required=True, choices=tuple(OPS)),
    "of": S.Key(S.LIST, required=True, meaning="the CSV columns the op takes"),
    "scale": COLUMN_KEYS["scale"],
    "offset": COLUMN_KEYS["offset"],
    "note": _NOTE,
}

META_KEYS = {
    "vehicle_type": S.text("`multirotor`, `fixed_wing`, `vtol`, …"),
    "vehicle": S.text("the vehicle's name"),
    "firmware": S.text("the autopilot firmware"),
    "battery_capacity_mah": S.between(CAPACITY_MIN_MAH, CAPACITY_MAX_MAH, unit="mAh",
                                      meaning="capacity of the pack flown"),
    "battery_cells": S.count(CELLS_SERIES_MAX, meaning="cells in series of the pack flown"),
    "aircraft": S.text("the aircraft file that flew the log"),
    "battery": S.text("the pack file that flew the log"),
}

#: Record columns a map may fill (the experiment and the time have keys of their own).
MAPPABLE = tuple(c for c in COLUMNS if c not in ("experiment", "time_s"))

FLIGHTS_KEYS = {
    "file": S.text("the per-flight CSV: found next to the data file, else relative to the "
                   "map", required=True),
    "key": S.text("its column holding the experiment id", required=True),
    "columns": S.block("record column ← `{column, scale, offset}` of the per-flight table "
                       "(one value per flight: `payload_kg`, `cycle`)"),
    "extra": S.block("new name ← `{column, scale, offset}` (or the column's name): "
                     "per-flight values kept as they are (text kept as text)"),
    "note": _NOTE,
}
#: Record columns a per-flight table may fill: one value per experiment.
PER_FLIGHT = ("payload_kg", "cycle")


def load_map(source: str | os.PathLike | dict) -> dict:
    """Load and validate a column map (a YAML file, a shipped map name, or a dict).

    ``source`` may be a path, or the name of a map in :data:`MAPS_DIR`
    (``"dji_m100"``). Returns the normalised map: ``name``, ``source``, ``where``,
    ``experiment`` (a CSV column or None), ``time``, ``columns``, ``derived``, ``extra``
    (each entry with every key, defaults filled in) and ``meta``.

    Raises
    ------
    InputError
        A missing or unreadable file, or every problem of the map at once, naming the
        file and the key path.
    """
    raw, where = _read(source)
    problems = S.Problems(where)
    top = S.check_mapping(raw, TOP_KEYS, where, problems=problems)
    out = {"name": top["name"], "source": top["source"], "where": where,
           "experiment": _experiment(top["experiment"], problems),
           "time": _entry(top["time"], TIME_KEYS, "time", problems),
           "columns": _entries(top["columns"], COLUMN_KEYS, "columns", MAPPABLE, problems),
           "derived": _entries(top["derived"], DERIVED_KEYS, "derived", MAPPABLE, problems),
           "extra": _entries(top["extra"], EXTRA_KEYS, "extra", None, problems),
           "meta": _meta(top["meta"], where, problems),
           "flights": _flights(top["flights"], problems),
           "header": _header(top.get("header"), problems)}
    problems.done()
    if not out["columns"] and not out["derived"]:
        raise InputError(f"{where}: the map has no 'columns'")
    for spec in out["extra"].values():
        spec.update(relative=False, missing=[])
    return out


def _header(value, problems: S.Problems) -> list[str] | None:
    """``header``: distinct column names."""
    if value is None:
        return None
    names = [str(v).strip() for v in value]
    if not names or len(set(names)) != len(names) or not all(names):
        problems.add(f"header must list distinct, non-empty column names, got {value!r}")
        return None
    return names


def map_columns(cmap: dict) -> set[str]:
    """The CSV columns a loaded map reads (the time, the experiment, every mapped,
    derived and extra column)."""
    need = {cmap["time"]["column"]} if cmap.get("time") else set()
    if cmap.get("experiment"):
        need.add(cmap["experiment"])
    for block in ("columns", "extra"):
        need |= {spec["column"] for spec in cmap[block].values()}
    for spec in cmap["derived"].values():
        need |= set(spec["of"] or ())
    return need


def match_map(header: list[str], first_row: list[str]) -> tuple[str, dict, str]:
    """The shipped map (:data:`MAPS_DIR`) that reads a CSV file: one with a header whose
    names hold every column the map reads, or, for a map of a file without a header, a
    first row of as many numbers as the map's ``header`` names. The most specific match
    (most columns read) wins.

    Parameters
    ----------
    header : list of str
        The file's first row as column names (stripped, byte-order mark removed).
    first_row : list of str
        The same row as values (for files without a header).

    Returns
    -------
    (name, map, why)
        The map's file name without ``.yaml``, the loaded map and how it matched.

    Raises
    ------
    InputError
        No shipped map reads the file (the message lists them).
    """
    found = []
    for path in sorted(MAPS_DIR.glob("*.yaml")):
        cmap = load_map(path)
        need = map_columns(cmap)
        if cmap["header"] is not None:
            numeric = all(_is_number(v) for v in first_row)
            if numeric and len(first_row) == len(cmap["header"]):
                found.append((len(need), path.stem, cmap,
                              f"no header row, {len(first_row)} numeric columns"))
        elif need <= set(header):
            found.append((len(need), path.stem, cmap,
                          f"columns {', '.join(sorted(need))}"))
    if not found:
        names = ", ".join(p.stem for p in sorted(MAPS_DIR.glob("*.yaml")))
        raise InputError(f"no shipped column map reads a file with the columns "
                         f"{', '.join(header[:12])}{' …' if len(header) > 12 else ''} "
                         f"(maps: {names}); write one (docs/formats.md, column maps)")
    found.sort(key=lambda f: -f[0])
    _, name, cmap, why = found[0]
    return name, cmap, why


def _is_number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def _read(source) -> tuple[Any, str]:
    """The map's mapping and its name for messages."""
    if isinstance(source, dict):
        return source, "<column map>"
    path = Path(source)
    if not path.exists() and (MAPS_DIR / f"{path.name}.yaml").exists():
        path = MAPS_DIR / f"{path.name}.yaml"
    if not path.exists():
        raise InputError(f"{path}: column map not found")
    return files.load_yaml(path, "definition", "column map", empty_ok=False), str(path)


def _experiment(value, problems: S.Problems) -> str | None:
    """``experiment``: a column name, or ``{column: ...}``."""
    if isinstance(value, dict):
        value = S.check_mapping(value, {"column": TIME_KEYS["column"], "note": _NOTE}, "",
                                "experiment.", problems)["column"]
    if value is not None and not isinstance(value, str):
        problems.add(f"experiment must be a column name, got {value!r}")
        return None
    return value


def _entry(spec, keys: dict[str, S.Key], path: str, problems: S.Problems) -> dict | None:
    """One entry (``time``, ``columns.voltage_v`` …): a CSV column's name or a mapping of
    ``keys``; every key filled in."""
    if spec is None:
        return None
    if isinstance(spec, str) and "column" in keys:
        spec = {"column": spec}
    if not isinstance(spec, dict):
        problems.add(f"{path} must be {'a column name or ' if 'column' in keys else ''}"
                     f"a mapping of {', '.join(keys)}, got {spec!r}")
        return None
    d = S.check_mapping(spec, keys, "", f"{path}.", problems)
    d.pop("note", None)
    if "of" in d:
        _check_of(d, path, problems)
    if "missing" in d:
        d["missing"] = _missing(d["missing"], f"{path}.missing", problems)
    return d


def _entries(block, keys: dict[str, S.Key], path: str, allowed, problems: S.Problems) -> dict:
    """Every entry of ``columns``, ``derived`` or ``extra`` (names checked against
    ``allowed``; ``extra``: any name but a record column's)."""
    if block is None:
        return {}
    if allowed is not None:
        S.unknown_keys(block, allowed, problems, f"{path}.")
    out = {}
    for name, spec in block.items():
        if allowed is None and name in COLUMNS:
            problems.add(f"{path}.{name} is a flight-record column; map it under 'columns'")
        elif allowed is None or name in allowed:
            entry = _entry(spec, keys, f"{path}.{name}", problems)
            if entry is not None:
                out[name] = entry
    return out


def _flights(block, problems: S.Problems) -> dict | None:
    """``flights``: the per-flight table's file, key column, record columns and extras."""
    if block is None:
        return None
    d = S.check_mapping(block, FLIGHTS_KEYS, "", "flights.", problems)
    return {"file": d["file"], "key": d["key"],
            "columns": _entries(d["columns"], EXTRA_KEYS, "flights.columns", PER_FLIGHT,
                                problems),
            "extra": _entries(d["extra"], EXTRA_KEYS, "flights.extra", None, problems)}


def _check_of(d: dict, path: str, problems: S.Problems) -> None:
    """``of`` holds as many CSV column names as the op takes."""
    op, of = d["op"], d["of"]
    if op not in OPS or of is None:
        return
    if len(of) not in OPS[op] or not all(isinstance(c, str) for c in of):
        what = ("two CSV columns (three for hypot)" if op == "hypot" else
                "seven CSV columns: the body-frame velocity x, y, z and the attitude "
                "quaternion x, y, z, w" if op in ROTATE_OPS else "two CSV columns")
        problems.add(f"{path}.of must list {what}, got {of!r}")


def _missing(value, path: str, problems: S.Problems) -> list[float]:
    """``missing``: the raw values that mean "not measured", as a list of numbers."""
    values = value if isinstance(value, list) else [] if value is None else [value]
    number = S.Key(S.NUMBER)
    return [float(v) for v in values if S.check_value(v, number, path, problems) is not None]


def _meta(block, where: str, problems: S.Problems) -> dict:
    """``meta``: the keys the map gives, checked."""
    if block is None:
        return {}
    d = S.check_mapping(block, META_KEYS, where, "meta.", problems)
    return {key: d[key] for key in block if key in META_KEYS}
