"""CSV files (any column names) → flight record, through a column map YAML.

A map says, per flight-record column, which CSV column it comes from and how
to scale it; plus how to find the time and the experiment id, and columns
derived from several CSV columns. ``planner/logs/maps/dji_m100.yaml`` is the
map of the DJI Matrice 100 data set. Without a map the CSV must already be a
flight record (:data:`FIELD_MAP`, the identity map, is used).

Map schema (YAML)::

    name: free text                    # optional
    source: free text                  # optional: where the data and the map come from
    experiment: flight                 # CSV column with the experiment id
                                       # (or {column: flight}); absent = the file stem
    time:                              # required
      column: time
      scale: 1.0                       # to seconds (0.001 for ms, 1e-6 for µs)
      offset: 0.0
      zero: true                       # time_s from 0 at each experiment's first row
    columns:                           # record column ← CSV column · scale + offset
      voltage_v: {column: battery_voltage, scale: 1.0, offset: 0.0}
      altitude_m: {column: position_z, relative: true, missing: [0]}
                                       # relative: minus its first valid value per
                                       # experiment; missing: raw values meaning "none"
    derived:                           # from several CSV columns
      groundspeed_ms: {op: hypot, of: [velocity_x, velocity_y], scale: 1.0}
      power_w: {op: product, of: [battery_voltage, battery_current]}
      course_deg: {op: course, of: [v_north, v_east]}
    extra:                             # CSV columns kept under a new name (not in §4)
      anemometer_speed_ms: {column: wind_speed}
    meta: {vehicle_type: multirotor, battery_capacity_mah: 4500, battery_cells: 6}

Time base
---------
The CSV rows are the samples; nothing is interpolated. Rows keep their file
order; time must not go backwards within an experiment (checked by
:func:`planner.record.validate_record`, which names the row).
"""

from __future__ import annotations

import difflib
import math
import os
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from planner.errors import InputError
from planner.logs._common import Meta
from planner.record import COLUMNS, add_consumed, drop_truncated_last_line, validate_record

__all__ = ["FIELD_MAP", "MAPS_DIR", "load_map", "read_csv_log"]

#: Where the maps shipped with the planner live.
MAPS_DIR = Path(__file__).with_name("maps")

#: Default (identity) map: a flight-record CSV, every column under its own name.
FIELD_MAP: dict[str, dict] = {name: {"column": name, "scale": 1.0, "offset": 0.0}
                              for name in COLUMNS if name not in ("experiment", "time_s")}

_TOP_KEYS = {"name", "source", "experiment", "time", "columns", "derived", "extra", "meta",
             "license", "notes"}
_COL_KEYS = {"column", "scale", "offset", "relative", "missing", "note"}
_TIME_KEYS = {"column", "scale", "offset", "zero", "note"}
_DERIVED_KEYS = {"op", "of", "scale", "offset", "note"}
_OPS = {"hypot", "product", "course", "sum", "difference"}
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
    if not math.isfinite(value):
        raise InputError(f"{where}: {key} must be a finite number, got {value!r}")
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
        try:
            raw = yaml.safe_load(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise InputError(f"{path}: column map not found") from None
        except (OSError, UnicodeDecodeError) as exc:
            raise InputError(f"{path}: cannot read column map ({exc})") from None
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
        if not isinstance(of, list) or len(of) != 2 or not all(isinstance(c, str) for c in of):
            raise InputError(f"{where}: derived.{ours}.of must list two CSV columns, got {of!r}")
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


def _per_experiment_first(values: np.ndarray, groups: list[np.ndarray]) -> np.ndarray:
    """``values`` minus its first finite value within each experiment."""
    out = values.copy()
    for rows in groups:
        v = values[rows]
        ok = np.flatnonzero(np.isfinite(v))
        if len(ok):
            out[rows] = v - v[ok[0]]
    return out


def read_csv_log(path: str | os.PathLike, *, map: str | os.PathLike | dict | None = None,
                 require_battery: bool = True) -> tuple[pd.DataFrame, dict]:
    """Read a CSV file into the flight record through a column map.

    Parameters
    ----------
    path : str or path
        The CSV file (``.csv`` or ``.csv.gz``).
    map : path, name or dict, optional
        The column map (see the module docstring); ``None`` reads the file as
        a flight-record CSV.
    require_battery : bool, default True
        Require ``power_w`` or both ``voltage_v`` and ``current_a``.

    Returns
    -------
    (DataFrame, dict)
        The flight record (``power_w`` = V·I and ``consumed_mah`` = ∫I dt
        added when absent) and the metadata.
    """
    path = Path(path)
    meta = Meta(str(path), "csv")
    cmap = load_map(map) if map is not None else None
    try:
        raw = pd.read_csv(path, low_memory=False)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: empty file") from None
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError, OSError, EOFError) as exc:
        raise InputError(f"{path}: not a readable CSV file ({type(exc).__name__}: "
                         f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
    raw.columns = [str(c).strip() for c in raw.columns]
    raw = drop_truncated_last_line(raw, path)

    if cmap is None:
        from planner.record import complete_record
        df = validate_record(raw, path, require_power=require_battery, csv_lines=True)
        df = complete_record(df)
        for c in df.columns:
            if c in FIELD_MAP:
                meta["channels"][c] = c
        meta["samples"] = len(df)
        return df, meta.values

    where = cmap["where"]

    def need(col: str, role: str) -> pd.Series:
        if col not in raw.columns:
            close = difflib.get_close_matches(col, list(raw.columns), n=2)
            hint = f" (did you mean {', '.join(repr(c) for c in close)}?)" if close else ""
            raise InputError(f"{path}: column '{col}' named in {where} ({role}) is not in "
                             f"the file{hint}")
        return raw[col]

    def numeric(col: str, role: str) -> np.ndarray:
        s = need(col, role)
        num = pd.to_numeric(s, errors="coerce")
        bad = num.isna() & s.notna()
        if bad.any():
            first = int(np.flatnonzero(bad.to_numpy())[0])
            raise InputError(f"{path}: column '{col}' row {first + 1} (line {first + 2}): "
                             f"expected a number, got {s.iloc[first]!r}")
        return num.to_numpy(float)

    n = len(raw)
    out: dict[str, np.ndarray] = {}
    if cmap["experiment"]:
        out["experiment"] = need(cmap["experiment"], "experiment").astype("str").to_numpy(object)
    else:
        out["experiment"] = np.full(n, path.name.split(".")[0], dtype=object)
    groups = list(pd.Series(out["experiment"]).groupby(out["experiment"], sort=False)
                  .indices.values()) if n else []

    tspec = cmap["time"]
    t = numeric(tspec["column"], "time") * tspec["scale"] + tspec["offset"]
    if tspec["zero"]:
        t = _per_experiment_first(t, groups)
    out["time_s"] = t
    meta["channels"]["time_s"] = tspec["column"]

    for ours, spec in cmap["columns"].items():
        if ours == "mode":
            out[ours] = need(spec["column"], ours).astype("str").to_numpy(object)
        else:
            v = numeric(spec["column"], ours)
            for m in spec["missing"]:
                v = np.where(v == m, np.nan, v)
            v = v * spec["scale"] + spec["offset"]
            if spec["relative"]:
                v = _per_experiment_first(v, groups)
            out[ours] = v
        meta["channels"][ours] = spec["column"]
    for ours, spec in cmap["derived"].items():
        a, b = (numeric(c, ours) for c in spec["of"])
        op = spec["op"]
        if op == "hypot":
            v = np.hypot(a, b)
        elif op == "product":
            v = a * b
        elif op == "sum":
            v = a + b
        elif op == "difference":
            v = a - b
        else:  # course from (north, east)
            v = np.degrees(np.arctan2(b, a)) % 360.0
            v[np.hypot(a, b) * spec["scale"] < 0.2] = np.nan
            spec = {**spec, "scale": 1.0}
        out[ours] = v * spec["scale"] + spec["offset"]
        meta["channels"][ours] = f"{op}({', '.join(spec['of'])})"
    for name, spec in cmap["extra"].items():
        out[name] = numeric(spec["column"], name) * spec["scale"] + spec["offset"]
        meta["channels"][name] = spec["column"]

    df = pd.DataFrame(out)
    df = validate_record(df, path, require_power=require_battery, csv_lines=True)
    if "power_w" not in df and "voltage_v" in df and "current_a" in df:
        df["power_w"] = df["voltage_v"].to_numpy(float) * df["current_a"].to_numpy(float)
        meta["channels"]["power_w"] = "voltage_v * current_a"
    if "consumed_mah" not in df and "current_a" in df:
        df = add_consumed(df)
        meta["channels"]["consumed_mah"] = "trapezoid integral of current_a per experiment"
    known = [c for c in COLUMNS if c in df.columns]
    df = df[known + [c for c in df.columns if c not in COLUMNS]]

    for key, value in cmap["meta"].items():
        meta[key] = value
    meta["map"] = where
    meta["experiments"] = int(df["experiment"].nunique()) if len(df) else 0
    meta["samples"] = len(df)
    durations = df.groupby("experiment", sort=False)["time_s"].agg(lambda s: s.iloc[-1] - s.iloc[0])
    meta["duration_s"] = float(durations.sum()) if len(df) else 0.0
    for c in df.columns:
        if c in ("experiment", "time_s"):
            continue
        dt = df.groupby("experiment", sort=False)["time_s"].diff().to_numpy(float)
        dt = dt[np.isfinite(dt) & (dt > 0)]
        meta["rates_hz"][c] = float(1.0 / np.median(dt)) if len(dt) else None
    return df, meta.values

