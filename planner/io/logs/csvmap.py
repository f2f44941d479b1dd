"""CSV files (any column names) → flight record, through a column map YAML.

A map says, per flight-record column, which CSV column it comes from and how
to scale it; plus how to find the time and the experiment id, and columns
derived from several CSV columns. ``planner/io/logs/maps/dji_m100.yaml`` is the
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
      climb_rate_ms: {op: enu_up, of: [vx, vy, vz, qx, qy, qz, qw]}
                                       # enu_up / enu_horizontal / enu_course: a body-frame
                                       # velocity rotated by the attitude quaternion
                                       # (x, y, z, w: scalar last, as ROS logs it) into
                                       # east-north-up: its up component, its horizontal
                                       # speed, its course (deg from north)
    extra:                             # CSV columns kept under a new name (not in §4)
      anemometer_speed_ms: {column: wind_speed}
    meta: {vehicle_type: multirotor, battery_capacity_mah: 4500, battery_cells: 6}

Time base
---------
The CSV rows are the samples; nothing is interpolated. Rows keep their file
order; time must not go backwards within an experiment (checked by
:func:`planner.io.record.validate_record`, which names the row).
"""

from __future__ import annotations

import difflib
import os
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from planner.errors import InputError
from planner.io import files
from planner.io.logs._common import Meta, course_deg
from planner.io.logs.columnmap import MAPS_DIR, ROTATE_OPS, load_map, match_map
from planner.io.record import (
    COLUMNS,
    add_consumed,
    complete_record,
    drop_truncated_last_line,
    validate_record,
)
from planner.io.tables import cell_error, row_label

__all__ = ["FIELD_MAP", "MAPS_DIR", "load_map", "read_csv_log"]

#: Default (identity) map: a flight-record CSV, every column under its own name.
FIELD_MAP: dict[str, dict] = {name: {"column": name, "scale": 1.0, "offset": 0.0}
                              for name in COLUMNS if name not in ("experiment", "time_s")}


def _enu(op: str, v_body: np.ndarray, quat_xyzw: np.ndarray) -> np.ndarray:
    """Up component, horizontal speed or course [deg from north] of a body-frame velocity
    rotated into east-north-up by the attitude quaternion (x, y, z, w). Rows with a missing
    value or a quaternion far from unit length give NaN; a course is NaN below
    :data:`planner.io.logs._common.COURSE_MIN_SPEED_MS`."""
    from scipy.spatial.transform import Rotation

    norm = np.linalg.norm(quat_xyzw, axis=1)
    ok = np.isfinite(v_body).all(axis=1) & np.isfinite(norm) & (np.abs(norm - 1.0) < 0.1)
    out = np.full(len(v_body), np.nan)
    if not ok.any():
        return out
    w = Rotation.from_quat(quat_xyzw[ok]).apply(v_body[ok])
    east, north, up = w[:, 0], w[:, 1], w[:, 2]
    if op == "enu_up":
        out[ok] = up
    elif op == "enu_horizontal":
        out[ok] = np.hypot(east, north)
    else:
        out[ok] = course_deg(north, east, np.hypot(east, north))
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
    if map is not None and str(map) == "auto":
        name, cmap, why = match_map(*_first_row(path))
        meta["column_map"] = name
        meta["column_map_match"] = why
    else:
        cmap = load_map(map) if map is not None else None
    raw = _read_raw(path, cmap["header"] if cmap is not None else None)
    if cmap is None:
        df = complete_record(validate_record(raw, path, require_power=require_battery,
                                             csv_lines=True))
        for c in df.columns:
            if c in FIELD_MAP:
                meta["channels"][c] = c
        meta["samples"] = len(df)
        return df, meta.values
    csv = _Csv(raw, path, cmap["where"])
    out, groups = _experiment_and_time(csv, cmap, meta)
    _mapped(out, csv, cmap, groups, meta)
    _derived(out, csv, cmap, meta)
    if cmap["flights"] is not None:
        _join_flights(out, path, cmap, meta)
    df = _record(pd.DataFrame(out), path, meta, require_battery)
    _describe(df, cmap, meta)
    return df, meta.values


def _first_row(path: Path) -> tuple[list[str], list[str]]:
    """The file's first row, as names (stripped) and as values, a byte-order mark
    removed: what :func:`match_map` matches the shipped maps against."""
    try:
        head = pd.read_csv(files.input_path(path, "log", "CSV log"), header=None, nrows=1,
                           dtype=str, encoding="utf-8-sig")
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError, ValueError,
            OSError, EOFError) as exc:
        raise InputError(f"{path}: not a readable CSV file ({type(exc).__name__})") from None
    row = [str(v).strip() for v in head.iloc[0].tolist()]
    return row, row


def _read_raw(path: Path, header: list[str] | None = None) -> pd.DataFrame:
    """The CSV file as pandas reads it (a byte-order mark removed; ``header``: the names
    of a file without a header row), its header names stripped, a cut last line
    dropped."""
    try:
        kw = {"header": None, "names": header} if header else {}
        raw = pd.read_csv(files.input_path(path, "log", "CSV log"), low_memory=False,
                          encoding="utf-8-sig", **kw)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: empty file") from None
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError, OSError, EOFError) as exc:
        raise InputError(f"{path}: not a readable CSV file ({type(exc).__name__}: "
                         f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
    raw.columns = [str(c).strip() for c in raw.columns]
    return drop_truncated_last_line(raw, path)


class _Csv:
    """The CSV columns a map names, each checked where it is used."""

    def __init__(self, raw: pd.DataFrame, path: Path, where: str):
        self.raw, self.path, self.where = raw, path, where

    def need(self, col: str, role: str) -> pd.Series:
        """The column ``col`` (for the record column ``role``), or an error naming both."""
        if col not in self.raw.columns:
            close = difflib.get_close_matches(col, list(self.raw.columns), n=2)
            hint = f" (did you mean {', '.join(repr(c) for c in close)}?)" if close else ""
            raise InputError(f"{self.path}: column '{col}' named in {self.where} ({role}) is "
                             f"not in the file{hint}")
        return self.raw[col]

    def numeric(self, col: str, role: str) -> np.ndarray:
        """The column ``col`` as numbers (blank cells NaN); text is an error at its row."""
        s = self.need(col, role)
        num = pd.to_numeric(s, errors="coerce")
        bad = num.isna() & s.notna()
        if bad.any():
            first = int(np.flatnonzero(bad.to_numpy())[0])
            raise cell_error(self.path, col, row_label(first, first + 2), "a number",
                             s.iloc[first])
        return num.to_numpy(float)


def _experiment_and_time(csv: _Csv, cmap: dict, meta: Meta):
    """The ``experiment`` and ``time_s`` columns, and the rows of each experiment."""
    n = len(csv.raw)
    if cmap["experiment"]:
        exp = csv.need(cmap["experiment"], "experiment").astype("str").to_numpy(object)
    else:
        exp = np.full(n, csv.path.name.split(".")[0], dtype=object)
    groups = list(pd.Series(exp).groupby(exp, sort=False).indices.values()) if n else []
    tspec = cmap["time"]
    t = csv.numeric(tspec["column"], "time") * tspec["scale"] + tspec["offset"]
    if tspec["zero"]:
        t = _per_experiment_first(t, groups)
    meta["channels"]["time_s"] = tspec["column"]
    return {"experiment": exp, "time_s": t}, groups


def _mapped(out: dict, csv: _Csv, cmap: dict, groups, meta: Meta) -> None:
    """The record columns and extra columns read from one CSV column each."""
    for ours, spec in cmap["columns"].items():
        if ours == "mode":
            out[ours] = csv.need(spec["column"], ours).astype("str").to_numpy(object)
        else:
            v = csv.numeric(spec["column"], ours)
            for m in spec["missing"]:
                v = np.where(v == m, np.nan, v)
            v = v * spec["scale"] + spec["offset"]
            out[ours] = _per_experiment_first(v, groups) if spec["relative"] else v
        meta["channels"][ours] = spec["column"]
    for name, spec in cmap["extra"].items():
        out[name] = csv.numeric(spec["column"], name) * spec["scale"] + spec["offset"]
        meta["channels"][name] = spec["column"]


def _flights_file(path: Path, cmap: dict) -> Path | None:
    """The per-flight table of a map: next to the data file, else relative to the map."""
    name = Path(cmap["flights"]["file"])
    candidates = [name] if name.is_absolute() else [path.parent / name]
    if not name.is_absolute() and cmap["where"] != "<column map>":
        candidates.append(Path(cmap["where"]).parent / name)
    return next((c for c in candidates if c.is_file()), None)


def _join_flights(out: dict, path: Path, cmap: dict, meta: Meta) -> None:
    """The per-flight table's values (``flights`` of the map) joined to every sample by
    experiment id. A missing table, or experiments it does not name, give a warning and
    NaN (missing) values: the samples are kept."""
    spec = cmap["flights"]
    table_path = _flights_file(path, cmap)
    if table_path is None:
        warnings.warn(f"{path}: the per-flight table {spec['file']} named in {cmap['where']} "
                      "is not next to the data: no per-flight values (payload) joined",
                      stacklevel=3)
        return
    raw = _read_raw(table_path)
    table = _Csv(raw, table_path, cmap["where"])
    keys = table.need(spec["key"], "flights.key").astype("str").str.strip().to_numpy(object)
    dup = pd.Series(keys).duplicated().to_numpy()
    if dup.any():
        first = int(np.flatnonzero(dup)[0])
        raise InputError(f"{table_path}: column '{spec['key']}' {row_label(first, first + 2)}: "
                         f"experiment {keys[first]!r} named twice; expected one row per flight")
    exp = out["experiment"]
    ids = pd.unique(exp)
    unknown = [e for e in ids if e not in set(keys)]
    if unknown:
        warnings.warn(f"{table_path}: no row for experiment(s) "
                      f"{', '.join(map(str, unknown[:10]))}{' …' if len(unknown) > 10 else ''}"
                      " of the data: their per-flight values are missing", stacklevel=3)
    where = pd.Index(keys).get_indexer(exp)
    for name, col in [*spec["columns"].items(), *spec["extra"].items()]:
        s = table.need(col["column"], f"flights.{name}")
        num = pd.to_numeric(s, errors="coerce").to_numpy(float)
        if name in spec["columns"] or not (np.isnan(num) & s.notna().to_numpy()).any():
            if name in spec["columns"]:
                table.numeric(col["column"], f"flights.{name}")   # text: an error at its row
            values = num * col["scale"] + col["offset"]
            out[name] = np.where(where >= 0, values[np.maximum(where, 0)], np.nan)
        else:                                       # a text column (a route, "25-50-100")
            values = s.astype("str").to_numpy(object)
            out[name] = np.where(where >= 0, values[np.maximum(where, 0)], None)
        meta["channels"][name] = f"{table_path.name}:{col['column']}"


#: The ops of ``derived`` over two (or three) columns.
_BINARY = {"product": np.multiply, "sum": np.add, "difference": np.subtract}


def _derived(out: dict, csv: _Csv, cmap: dict, meta: Meta) -> None:
    """The record columns derived from several CSV columns (``op`` over ``of``)."""
    for ours, spec in cmap["derived"].items():
        a, b, *rest = (csv.numeric(c, ours) for c in spec["of"])
        op, scale = spec["op"], spec["scale"]
        if op in ROTATE_OPS:
            v = _enu(op, np.column_stack([a, b, rest[0]]), np.column_stack(rest[1:]))
            scale = 1.0 if op == "enu_course" else scale
        elif op == "hypot":
            v = np.hypot(a, b) if not rest else np.sqrt(a * a + b * b + rest[0] ** 2)
        elif op in _BINARY:
            v = _BINARY[op](a, b)
        else:  # course from (north, east): the scale converts the speed for the threshold
            v, scale = course_deg(a, b, np.hypot(a, b) * scale), 1.0
        out[ours] = v * scale + spec["offset"]
        meta["channels"][ours] = f"{op}({', '.join(spec['of'])})"


def _record(df: pd.DataFrame, path: Path, meta: Meta, require_battery: bool) -> pd.DataFrame:
    """The mapped table checked as a flight record, with power and charge where absent,
    in canonical column order."""
    df = validate_record(df, path, require_power=require_battery, csv_lines=True)
    if "power_w" not in df and "voltage_v" in df and "current_a" in df:
        df["power_w"] = df["voltage_v"].to_numpy(float) * df["current_a"].to_numpy(float)
        meta["channels"]["power_w"] = "voltage_v * current_a"
    if "consumed_mah" not in df and "current_a" in df:
        df = add_consumed(df)
        meta["channels"]["consumed_mah"] = "trapezoid integral of current_a per experiment"
    known = [c for c in COLUMNS if c in df.columns]
    return df[known + [c for c in df.columns if c not in COLUMNS]]


def _describe(df: pd.DataFrame, cmap: dict, meta: Meta) -> None:
    """The metadata of a mapped log: the map's ``meta``, experiments, samples, duration
    [s] and each column's rate [Hz]."""
    for key, value in cmap["meta"].items():
        meta[key] = value
    meta["map"] = cmap["where"]
    meta["experiments"] = int(df["experiment"].nunique()) if len(df) else 0
    meta["samples"] = len(df)
    durations = df.groupby("experiment", sort=False)["time_s"].agg(lambda s: s.iloc[-1] - s.iloc[0])
    meta["duration_s"] = float(durations.sum()) if len(df) else 0.0
    dt = df.groupby("experiment", sort=False)["time_s"].diff().to_numpy(float)
    dt = dt[np.isfinite(dt) & (dt > 0)]
    rate = float(1.0 / np.median(dt)) if len(dt) else None
    for c in df.columns:
        if c not in ("experiment", "time_s"):
            meta["rates_hz"][c] = rate
