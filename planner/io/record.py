"""The flight record: the canonical measured-data table (``docs/record.md``).

Every log reader produces it and ``fit``, ``replay`` and ``diagnose`` accept it:
one row per sample, time-ordered within each experiment, SI units (mAh at the
edge for ``consumed_mah``). :data:`COLUMNS` is the schema; :func:`validate_record`
checks a table against it; :func:`read_record` / :func:`write_record` are the
CSV edge; :func:`add_power`, :func:`add_consumed` fill derived columns; and
:func:`interpolate_onto` / :func:`resample_record` put channels on one time base.

Only ``time_s`` and either ``power_w`` or both ``voltage_v`` and ``current_a``
are required. Unknown extra columns are kept and ignored. A missing required
column, a time that goes backwards within an experiment, or a value that is not
a number gives an :class:`~planner.errors.InputError` naming the file, the
column and the first bad row.
"""

from __future__ import annotations

import csv
import gzip
import io
import itertools
import os
import re
import warnings
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from planner.errors import InputError
from planner.io import files
from planner.io.tables import cell_error, row_label
from planner.physics.units import AS_PER_MAH

__all__ = [
    "COLUMNS",
    "MAX_FLIGHT_S",
    "MAX_TIME_GAP_S",
    "REQUIRED",
    "Column",
    "add_consumed",
    "add_power",
    "complete_record",
    "cumulative_trapezoid",
    "experiment_payloads",
    "experiments",
    "interpolate_onto",
    "read_header",
    "read_record",
    "resample_record",
    "validate_record",
    "write_record",
]


@dataclass(frozen=True)
class Column:
    """One column of the flight record."""

    name: str
    unit: str
    kind: str  # "float" | "text" | "int"
    meaning: str


#: The columns of the flight record (``docs/record.md``), in canonical order, with their
#: units.
COLUMNS: dict[str, Column] = {c.name: c for c in (
    Column("experiment", "text", "text", "id of one discharge / one flight; absent = one experiment"),
    Column("time_s", "s", "float", "time since the start of the experiment"),
    Column("voltage_v", "V", "float", "pack terminal voltage"),
    Column("current_a", "A", "float", "pack current, discharge positive"),
    Column("power_w", "W", "float", "electric power drawn from the pack (= V·I when absent)"),
    Column("consumed_mah", "mAh", "float",
           "charge drawn since start as the logger integrated it (else integrated from current)"),
    Column("temperature_c", "°C", "float", "pack (cell) temperature"),
    Column("ambient_temperature_c", "°C", "float", "outside air temperature"),
    Column("pressure_pa", "Pa", "float", "static (barometric) pressure"),
    Column("cycle", "integer", "int", "charge-cycle count of the pack at this experiment"),
    Column("payload_kg", "kg", "float",
           "payload carried in this experiment (constant within one; the take-off mass is "
           "the aircraft's empty mass + the pack + this)"),
    Column("altitude_m", "m", "float", "altitude above home"),
    Column("climb_rate_ms", "m/s", "float", "vertical speed, up positive"),
    Column("groundspeed_ms", "m/s", "float", "horizontal speed over ground"),
    Column("course_deg", "deg", "float", "direction of travel over ground, 0 = north, clockwise"),
    Column("airspeed_ms", "m/s", "float", "true airspeed"),
    Column("wind_n_ms", "m/s", "float", "wind velocity towards north"),
    Column("wind_e_ms", "m/s", "float", "wind velocity towards east"),
    Column("throttle", "0..1", "float", "throttle demand"),
    Column("specific_force_ms2", "m/s²", "float",
           "magnitude of the accelerometer's specific force (about 9.81 in hover)"),
    Column("axial_speed_ms", "m/s", "float",
           "velocity along a multirotor's thrust axis (body z, up positive): the velocity "
           "through its tilted rotor disk; in level cruise about speed × sin(tilt)"),
    Column("mode", "text", "text", "flight mode name"),
)}

#: Always required; plus ``power_w`` or both ``voltage_v`` and ``current_a``.
REQUIRED = ("time_s",)

#: What a record with battery voltage and no current (a vehicle without a current sensor)
#: can and cannot give: said once by the readers, the row reason of ``replay`` and ``fleet``.
NO_CURRENT = "no current: not replayable"
NO_CURRENT_NOTE = (f"battery voltage but no current sensor ({NO_CURRENT}): the charge drawn "
                   "and the electric power cannot be replayed without current")

#: Physical range of a column: finite values outside it are sensor glitches or corrupt
#: data (a 1e308 speed, a −300 °C air temperature, a pressure of 0 Pa). They become
#: missing values with a warning, so one bad sample does not void a log.
PLAUSIBLE: dict[str, tuple[float, float]] = {
    "voltage_v": (0.0, 1000.0),
    "current_a": (-2000.0, 2000.0),
    "power_w": (-1e6, 1e6),
    "consumed_mah": (-1e7, 1e7),
    "temperature_c": (-100.0, 200.0),
    "ambient_temperature_c": (-100.0, 100.0),
    "pressure_pa": (1e3, 2e5),            # about 30 km altitude up to deep below sea level
    "altitude_m": (-12_000.0, 30_000.0),
    "climb_rate_ms": (-300.0, 300.0),
    "groundspeed_ms": (0.0, 300.0),
    "airspeed_ms": (-50.0, 300.0),
    "course_deg": (-360.0, 720.0),
    "wind_n_ms": (-150.0, 150.0),
    "wind_e_ms": (-150.0, 150.0),
    "specific_force_ms2": (0.0, 1000.0),  # IMUs of small UAVs saturate at 16 g (157 m/s²)
    "axial_speed_ms": (-100.0, 100.0),
    "payload_kg": (0.0, 1000.0),
}

#: Other units a column is often written in by mistake: (unit, factor to the column's
#: unit, offset). Named when every value of a column is outside :data:`PLAUSIBLE` and the
#: values in that unit are inside it.
OTHER_UNITS: dict[str, tuple[tuple[str, float, float], ...]] = {
    "voltage_v": (("mV", 1e-3, 0.0), ("µV", 1e-6, 0.0)),
    "current_a": (("mA", 1e-3, 0.0), ("cA", 1e-2, 0.0), ("µA", 1e-6, 0.0)),
    "power_w": (("mW", 1e-3, 0.0), ("µW", 1e-6, 0.0)),
    "consumed_mah": (("µAh", 1e-3, 0.0), ("mAs", 1 / 3600, 0.0)),
    "temperature_c": (("K", 1.0, -273.15), ("c°C", 1e-2, 0.0), ("m°C", 1e-3, 0.0)),
    "ambient_temperature_c": (("K", 1.0, -273.15), ("c°C", 1e-2, 0.0), ("m°C", 1e-3, 0.0)),
    "pressure_pa": (("hPa", 100.0, 0.0), ("kPa", 1e3, 0.0), ("mPa", 1e-3, 0.0)),
    "altitude_m": (("mm", 1e-3, 0.0), ("cm", 1e-2, 0.0)),
    "climb_rate_ms": (("mm/s", 1e-3, 0.0), ("cm/s", 1e-2, 0.0)),
    "groundspeed_ms": (("mm/s", 1e-3, 0.0), ("cm/s", 1e-2, 0.0)),
    "airspeed_ms": (("mm/s", 1e-3, 0.0), ("cm/s", 1e-2, 0.0)),
    "course_deg": (("c°", 1e-2, 0.0),),
    "wind_n_ms": (("mm/s", 1e-3, 0.0), ("cm/s", 1e-2, 0.0)),
    "wind_e_ms": (("mm/s", 1e-3, 0.0), ("cm/s", 1e-2, 0.0)),
    "specific_force_ms2": (("mm/s²", 1e-3, 0.0), ("mg", 9.80665e-3, 0.0)),
    "axial_speed_ms": (("mm/s", 1e-3, 0.0), ("cm/s", 1e-2, 0.0)),
    "payload_kg": (("g", 1e-3, 0.0),),
}
#: Magnitude from which a value is a no-data sentinel (−3.4e38 is −FLT_MAX), not a reading.
SENTINEL = 1e30

#: Longest gap between two samples of one flight (in a log, or within one experiment of a
#: record); a time stamp beyond it is damage (a garbage ``TimeUS``, 163 000 years after
#: boot, in a duplicated chunk) or a clock reset, and the samples on the far side of the
#: gap are dropped. [s]
MAX_TIME_GAP_S = 6 * 3600.0
#: Longest experiment of a record: one flight or one bench discharge lasts less than a
#: day; a longer time axis is in another unit (ms, µs). [s]
MAX_FLIGHT_S = 24 * 3600.0
#: Largest median step between two samples of an experiment: a logger samples its battery
#: at least every few minutes; a larger step is a time axis in another unit. [s]
MAX_MEDIAN_STEP_S = 1e4
#: Longest header line of a flight-record CSV. [bytes]
HEADER_MAX_BYTES = 1 << 20
#: A compressed record may expand to at most this many times its size (and to at least
#: :data:`GZIP_MIN_BOUND`): flight records compress 3 to 20 times; a file that expands
#: further is a decompression bomb.
GZIP_MAX_RATIO = 100
#: Size a compressed record may always expand to. [bytes]
GZIP_MIN_BOUND = 16 * 2**20

_BATTERY = {"voltage_v", "current_a", "power_w", "consumed_mah"}
_TEXT = {n for n, c in COLUMNS.items() if c.kind == "text"}
_NUMERIC = [n for n, c in COLUMNS.items() if c.kind != "text"]
# Channels that hold a state (step signal): previous-value interpolation.
_STEP = {"mode", "cycle", "experiment"}


def _where(source) -> str:
    return str(source) if source is not None else "<DataFrame>"


def _row_label(df: pd.DataFrame, pos: int, csv_lines: bool) -> str:
    if csv_lines:
        # data row pos (0-based) is on line pos + 2 of a CSV file with one header line
        return row_label(pos, pos + 2)
    label = df.index[pos]
    label = label.item() if hasattr(label, "item") else label
    return f"row {label!r}"


def validate_record(df: pd.DataFrame, source: str | os.PathLike | None = None, *,
                    require_power: bool = True, csv_lines: bool | None = None,
                    strict: bool = False) -> pd.DataFrame:
    """Check a flight record against its columns (``docs/record.md``) and return a
    normalised copy.

    Parameters
    ----------
    df : DataFrame
        The table to check.
    source : str or path, optional
        Where the table came from; every error message starts with it.
    require_power : bool, default True
        Require battery data: ``power_w``, or ``voltage_v`` (with ``current_a``; a
        voltage-only record, from a vehicle without a current sensor, is read and
        exported but cannot be replayed: :data:`NO_CURRENT`). ``False``
        accepts a kinematics-only record (e.g. a SITL log without battery data).
    csv_lines : bool, optional
        Name bad rows by CSV line number as well (default: when ``source`` is
        a ``.csv`` path).
    strict : bool, default False
        A record file as given by a user (:func:`read_record`): a column none of whose
        values is plausible (a unit mistake, a no-data sentinel) and a power that is not
        about voltage × current are errors, not missing samples.

    Returns
    -------
    DataFrame
        A copy with the known numeric columns as float64 (``cycle`` may hold
        NaN), ``experiment`` and ``mode`` as strings; unknown columns untouched.

    Raises
    ------
    InputError
        A missing required column, a non-numeric value in a numeric column, a
        missing or non-finite ``time_s``, a time that goes backwards within
        one experiment, or (``require_power``) no battery value in any row; the message
        names the source, the column and the first bad row
        (:func:`planner.io.tables.cell_error`).
    """
    where = _where(source)
    if csv_lines is None:
        csv_lines = str(source).lower().endswith((".csv", ".csv.gz")) if source else False
    _check_columns(df, where, require_power)
    out = df.copy()
    _numbers(out, df, where, csv_lines)
    _implausible_as_missing(out, df, where, csv_lines, strict)
    if require_power:
        _check_battery_values(out, df, where, csv_lines, strict)
    if strict:
        _check_power_units(out, df, where, csv_lines)
    for name in _TEXT:
        if name in out.columns:
            out[name] = out[name].astype("str")
    if "experiment" in out.columns and out["experiment"].isna().any():
        first = int(np.flatnonzero(out["experiment"].isna().to_numpy())[0])
        raise InputError(f"{where}: column 'experiment' {_row_label(df, first, csv_lines)}: "
                         "missing experiment id")
    _check_time(out, df, where, csv_lines)
    return out


def _check_columns(df, where: str, require_power: bool) -> None:
    """A table with the required columns, each once."""
    if not isinstance(df, pd.DataFrame):
        raise InputError(f"{where}: expected a table (DataFrame), got {type(df).__name__}")
    for name in REQUIRED:
        if name not in df.columns:
            raise InputError(f"{where}: missing required column '{name}'"
                             f"{_like(name, df.columns)} (columns: "
                             f"{_shown_columns(df.columns) or 'none'})")
    if require_power and "power_w" not in df.columns and "voltage_v" not in df.columns:
        missing = [c for c in ("voltage_v", "current_a") if c not in df.columns]
        raise InputError(f"{where}: missing required column '{missing[0]}'"
                         f"{_like(missing[0], df.columns) or _like('power_w', df.columns)} "
                         "(need 'power_w' or both 'voltage_v' and 'current_a')")
    if df.columns.duplicated().any():
        dup = df.columns[df.columns.duplicated()][0]
        raise InputError(f"{where}: column '{dup}' appears more than once")


def _shown_columns(columns, most: int = 30) -> str:
    names = [str(c) for c in columns]
    return ", ".join(names[:most]) + (f" … ({len(names)} in all)" if len(names) > most else "")


def _like(name: str, columns) -> str:
    """``" (is 'Time_S' it?)"``: a column whose name is close to a missing one."""
    import difflib

    pool = {str(c).strip().lower(): str(c) for c in columns}
    close = difflib.get_close_matches(name, list(pool), n=1, cutoff=0.6)
    return f" (is {pool[close[0]]!r} it? the names are exact)" if close else ""


def _numbers(out: pd.DataFrame, df: pd.DataFrame, where: str, csv_lines: bool) -> None:
    """The known numeric columns of ``out`` as float64 (blank and ``nan``/``n/a`` text as
    NaN); the first cell that is no number is an error."""
    for name in _NUMERIC:
        if name not in out.columns:
            continue
        col = out[name]
        if pd.api.types.is_bool_dtype(col):
            bad = np.ones(len(col), bool)  # True/False is not a measurement
        elif pd.api.types.is_numeric_dtype(col):
            out[name] = col.astype("float64")
            continue
        else:
            num = pd.to_numeric(col, errors="coerce")
            text = col.astype("string").str.strip()
            bad = (num.isna() & col.notna() & (text != "") & ~text.str.lower().isin(
                ["nan", "na", "n/a", "null", "none"])).to_numpy(bool, na_value=False)
            if not bad.any():
                out[name] = num.astype("float64")
                continue
        first = int(np.flatnonzero(bad)[0])
        raise cell_error(where, name, _row_label(df, first, csv_lines), "a number",
                         df[name].iloc[first])


def _implausible_as_missing(out: pd.DataFrame, df: pd.DataFrame, where: str,
                            csv_lines: bool, strict: bool = False) -> None:
    """Values outside :data:`PLAUSIBLE` become NaN, with a warning per column; ``strict``:
    a column none of whose finite values is plausible is an error naming the unit it
    looks like (:data:`OTHER_UNITS`) or the sentinel it holds."""
    for name, (low, high) in PLAUSIBLE.items():
        if name not in out.columns:
            continue
        values = out[name].to_numpy(float)
        with np.errstate(invalid="ignore"):
            odd = (values < low) | (values > high)
        if name in _BATTERY:  # an infinite battery reading is reported where it is used
            odd &= np.isfinite(values)
        finite = np.isfinite(values)
        if strict and odd.any() and odd.sum() >= min(2, len(values)) \
                and not (finite & ~odd).any():
            first = int(np.flatnonzero(odd)[0])
            raise InputError(
                f"{where}: column '{name}' {_row_label(df, first, csv_lines)}: "
                f"{values[first]:g}{_unit_hint(name, values[finite & odd])}; no value of "
                f"the column is inside [{low:g}, {high:g}] {COLUMNS[name].unit}")
        if odd.any():
            first = int(np.flatnonzero(odd)[0])
            warnings.warn(f"{where}: column '{name}': {int(odd.sum())} value(s) outside "
                          f"[{low:g}, {high:g}] {COLUMNS[name].unit}, first "
                          f"{_row_label(df, first, csv_lines)} = {values[first]:g}: read as "
                          "missing", stacklevel=3)
            out[name] = np.where(odd, np.nan, values)


def _unit_hint(name: str, values: np.ndarray) -> str:
    """``": in mV? (15.52 V)"``: the unit in which most of ``values`` are plausible, or
    that they are a no-data sentinel."""
    if not len(values):
        return ""
    unit = COLUMNS[name].unit
    mid = float(np.median(values))
    if abs(mid) >= SENTINEL:
        return ": a no-data value (a sentinel such as -3.4e38), not a reading"
    low, high = PLAUSIBLE[name]
    for other, factor, offset in OTHER_UNITS.get(name, ()):
        scaled = values * factor + offset
        if np.mean((scaled >= low) & (scaled <= high)) > 0.9:
            return f": in {other}? ({mid:g} {other} = {mid * factor + offset:.4g} {unit})"
    return ""


def _check_battery_values(out: pd.DataFrame, df: pd.DataFrame, where: str,
                          csv_lines: bool, strict: bool = False) -> None:
    """A record that should carry battery data has a value in some row (``strict``: a
    reading, a power or a voltage that is not about zero)."""
    cols = [c for c in ("power_w", "voltage_v", "current_a") if c in out.columns]
    if not cols or not len(out):
        return
    floor = {"power_w": 1e-6, "voltage_v": 0.1, "current_a": np.inf} if strict else {}
    for c in cols:
        v = np.abs(out[c].to_numpy(float))
        with np.errstate(invalid="ignore"):
            if (np.isfinite(v) & (v >= floor.get(c, 0.0))).any():
                return
    rows = (f"{_row_label(df, 0, csv_lines)} to {_row_label(df, len(df) - 1, csv_lines)}"
            if len(df) > 1 else _row_label(df, 0, csv_lines))
    raise InputError(f"{where}: column{'s' if len(cols) > 1 else ''} "
                     f"{', '.join(repr(c) for c in cols)} {rows}: no battery reading in any "
                     "row (every one empty, not a number, implausible"
                     + (" or about zero" if strict else "") + "); expected the pack's power, "
                     "or its voltage and current")


#: Ratio of ``power_w`` to voltage × current outside which one of the three is in another
#: unit (a separate power sensor and V·I agree within a few per cent).
POWER_RATIO_RANGE = (0.2, 5.0)


def _check_power_units(out: pd.DataFrame, df: pd.DataFrame, where: str,
                       csv_lines: bool) -> None:
    """``power_w`` about ``voltage_v`` × ``current_a`` where all three are given."""
    if not {"power_w", "voltage_v", "current_a"} <= set(out.columns):
        return
    p, v, i = (out[c].to_numpy(float) for c in ("power_w", "voltage_v", "current_a"))
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        ok = np.isfinite(p) & np.isfinite(v) & np.isfinite(i) & (v > 1.0) & \
            (np.abs(i) > 0.5)
        if ok.sum() < 10:
            return
        ratio = p[ok] / (v[ok] * i[ok])
    r = float(np.median(ratio))
    low, high = POWER_RATIO_RANGE
    if low <= r <= high:
        return
    first = int(np.flatnonzero(ok)[0])
    guess = ("power_w in mW?" if 300 <= r <= 3000 else
             "current_a in mA (or voltage_v in mV)?" if 3e-4 <= r <= 3e-3 else
             "current_a in cA?" if 3e-3 < r <= 3e-2 else
             "one of the three in another unit?")
    raise InputError(f"{where}: column 'power_w' {_row_label(df, first, csv_lines)}: "
                     f"{r:.3g} × voltage_v × current_a (the median over {int(ok.sum())} rows; "
                     f"expected about 1, W = V × A): {guess}")


def _check_time(out: pd.DataFrame, df: pd.DataFrame, where: str, csv_lines: bool) -> None:
    """Finite times that never go backwards within one experiment."""
    t = out["time_s"].to_numpy(float)
    bad = ~np.isfinite(t)
    if bad.any():
        first = int(np.flatnonzero(bad)[0])
        raise cell_error(where, "time_s", _row_label(df, first, csv_lines),
                         "a finite time in s", df["time_s"].iloc[first])
    if len(t) < 2:
        return
    if "experiment" in out.columns:
        exp = out["experiment"].to_numpy(object)
        back = (exp[1:] == exp[:-1]) & (np.diff(t) < 0)
        # else an experiment that reappears after another one: its time must go on
        first = (int(np.flatnonzero(back)[0]) + 1 if back.any()
                 else _first_out_of_order_group(exp, t))
    else:
        back = np.diff(t) < 0
        first = int(np.flatnonzero(back)[0]) + 1 if back.any() else None
    if first is not None:
        raise InputError(
            f"{where}: column 'time_s' {_row_label(df, first, csv_lines)}: time goes "
            f"backwards ({t[first - 1]:g} s then {t[first]:g} s)"
            + (f" within experiment {out['experiment'].iloc[first]!r}"
               if "experiment" in out.columns else "")
            + "; rows must be time-ordered within each experiment")


def _first_out_of_order_group(exp: np.ndarray, t: np.ndarray) -> int | None:
    """Row where an experiment resumes (after another one) at an earlier time."""
    starts = np.flatnonzero(np.r_[True, exp[1:] != exp[:-1]])
    if len(starts) == len(pd.unique(exp)):
        return None
    last_t: dict = {}
    bounds = np.r_[starts, len(exp)]
    for a, b in itertools.pairwise(bounds):
        key = exp[a]
        if key in last_t and t[a] < last_t[key]:
            return int(a)
        last_t[key] = t[b - 1]
    return None


def experiments(df: pd.DataFrame):
    """Yield ``(experiment_id, sub_frame)`` in order of first appearance.

    A record without an ``experiment`` column is one experiment with id ``None``.
    """
    if "experiment" not in df.columns:
        yield None, df
        return
    yield from df.groupby("experiment", sort=False)


def experiment_payloads(df: pd.DataFrame) -> dict[str, float] | None:
    """The payload of each experiment [kg] from the record's ``payload_kg`` column (its
    median within the experiment; NaN where the experiment has none), or None when the
    record has no payload at all."""
    if "payload_kg" not in df.columns or not np.isfinite(
            df["payload_kg"].to_numpy(float)).any():
        return None
    out = {}
    for exp_id, exp in experiments(df):
        v = exp["payload_kg"].to_numpy(float)
        v = v[np.isfinite(v)]
        out[str(exp_id)] = float(np.median(v)) if v.size else float("nan")
    return out


def cumulative_trapezoid(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Cumulative trapezoid integral of ``y`` over ``x``, starting at 0.

    A NaN sample is bridged by linear interpolation between its finite
    neighbours; NaN at either end contributes nothing (the integral stays
    flat there).
    """
    y = np.asarray(y, float)
    x = np.asarray(x, float)
    if len(y) == 0:
        return np.zeros(0)
    ok = np.isfinite(y)
    first = last = None
    if not ok.all():
        if ok.sum() == 0:
            return np.full(len(y), np.nan)
        y = np.interp(x, x[ok], y[ok])
        first, last = np.flatnonzero(ok)[[0, -1]]
    seg = 0.5 * (y[1:] + y[:-1]) * np.diff(x)
    if first is not None:
        seg[:first] = 0.0       # before the first and after the last finite sample
        seg[last:] = 0.0
    return np.concatenate(([0.0], np.cumsum(seg)))


def _any_finite(df: pd.DataFrame, name: str) -> bool:
    return name in df.columns and bool(np.isfinite(df[name].to_numpy(float)).any())


def has_power(df: pd.DataFrame) -> bool:
    """Whether the record (or one experiment of it) can give the electric power: a
    ``power_w`` sample, or ``voltage_v`` and ``current_a`` samples (docs/record.md). Columns
    that hold only NaN (another experiment's channels) do not count."""
    return _any_finite(df, "power_w") or (_any_finite(df, "voltage_v")
                                           and _any_finite(df, "current_a"))


def voltage_only(df: pd.DataFrame) -> bool:
    """A record with battery voltage but no current and no power (no current sensor)."""
    return _any_finite(df, "voltage_v") and not has_power(df)


def add_power(df: pd.DataFrame) -> pd.DataFrame:
    """Return ``df`` with ``power_w = voltage_v * current_a`` where power is absent.

    An existing ``power_w`` column is kept; only its NaN samples are filled
    where both voltage and current are known.
    """
    if "voltage_v" not in df.columns or "current_a" not in df.columns:
        return df
    p = df["voltage_v"].to_numpy(float) * df["current_a"].to_numpy(float)
    out = df.copy()
    if "power_w" in out.columns:
        have = out["power_w"].to_numpy(float)
        out["power_w"] = np.where(np.isnan(have), p, have)
    else:
        out["power_w"] = p
    return out


def add_consumed(df: pd.DataFrame) -> pd.DataFrame:
    """Return ``df`` with ``consumed_mah`` integrated from ``current_a`` if absent.

    Trapezoid rule per experiment, from 0 at its first sample:
    ``consumed_mah = ∫ I dt / 3.6`` (A·s → mAh). An existing column (the
    logger's own count) is kept as it is.
    """
    if "consumed_mah" in df.columns or "current_a" not in df.columns:
        return df
    out = df.copy()
    consumed = np.full(len(out), np.nan)
    t_all = out["time_s"].to_numpy(float)
    i_all = out["current_a"].to_numpy(float)
    if "experiment" in out.columns:
        groups = out.groupby("experiment", sort=False).indices.values()
    else:
        groups = [np.arange(len(out))]
    for rows in groups:
        consumed[rows] = cumulative_trapezoid(i_all[rows], t_all[rows]) / AS_PER_MAH
    out["consumed_mah"] = consumed
    return out


def complete_record(df: pd.DataFrame) -> pd.DataFrame:
    """Add ``power_w`` and ``consumed_mah`` where they are absent (see above)."""
    return add_consumed(add_power(df))


def _ordered(df: pd.DataFrame) -> pd.DataFrame:
    known = [c for c in COLUMNS if c in df.columns]
    return df[known + [c for c in df.columns if c not in COLUMNS]]


def drop_truncated_last_line(df: pd.DataFrame, path: str | os.PathLike,
                             sep: str = ",") -> pd.DataFrame:
    """Drop the last row of a CSV table when the file's last line was cut short.

    A file that ends without a newline, in a line with fewer fields than the
    header, was truncated (a log copied while it was written, a download cut
    off): its last row is partial, so it is skipped with a warning rather than
    read as a sample with blank fields. Compressed files are left as read.
    """
    path = Path(path)
    if df.empty or path.suffix.lower() == ".gz":
        return df
    try:
        with open(path, "rb") as fh:
            header = fh.readline()
            fh.seek(0, os.SEEK_END)
            size = fh.tell()
            fh.seek(max(0, size - 65536))
            tail = fh.read()
    except OSError:
        return df
    if not tail or tail.endswith(b"\n"):
        return df
    last = tail.rsplit(b"\n", 1)[-1]
    if last.count(sep.encode()) >= header.count(sep.encode()):
        return df
    warnings.warn(f"{path}: the last line is incomplete ({last.count(sep.encode()) + 1} of "
                  f"{header.count(sep.encode()) + 1} fields; file truncated?): skipped",
                  stacklevel=2)
    return df.iloc[:-1]


def read_header(path: str | os.PathLike) -> list[str]:
    """The column names of a flight-record CSV (``.csv`` or ``.csv.gz``) as its header line
    gives them, stripped, duplicates included (pandas would rename a second ``voltage_v``
    to ``voltage_v.1``).

    Raises
    ------
    InputError
        Not a regular file, empty, a header that is not UTF-8 text or longer than
        :data:`HEADER_MAX_BYTES`, a damaged compressed file.
    """
    path = files.input_path(path, "table", "flight-record CSV")
    if _compressed(path):
        data, _ = _gunzip(path)
        return _header_names(path, data[:HEADER_MAX_BYTES + 1].split(b"\n", 1)[0])
    try:
        with open(path, "rb") as fh:
            line = fh.readline(HEADER_MAX_BYTES + 1)
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    return _header_names(path, line)


def _compressed(path: Path) -> bool:
    return path.name.lower().endswith(".gz")


def _header_names(path: Path, line: bytes) -> list[str]:
    if len(line) > HEADER_MAX_BYTES:
        raise InputError(f"{path}: the first line is longer than {HEADER_MAX_BYTES >> 20} MB; "
                         "expected a header line of column names (docs/record.md)")
    if not line.strip():
        raise InputError(f"{path}: empty file, expected a flight-record CSV")
    try:
        text = line.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: header (line 1): not UTF-8 text (byte {exc.start}); "
                         "expected a header line of column names") from None
    names = next(csv.reader([text.rstrip("\r\n")]), [])
    return [n.strip() for n in names]


def _gunzip(path: Path) -> tuple[bytes, str | None]:
    """The bytes of a gzip-compressed file, bounded (:data:`GZIP_MAX_RATIO`): a file cut
    short gives what it holds and the reason to warn; damaged data is an error."""
    raw = files.read_bytes(path, "table", "flight-record CSV")
    bound = max(GZIP_MIN_BOUND, GZIP_MAX_RATIO * len(raw))
    if raw[:2] != b"\x1f\x8b":
        raise InputError(f"{path}: not gzip-compressed data (its name ends in .gz); expected a "
                         "flight-record CSV compressed with gzip, or name it .csv")
    out, size, rest, cut = [], 0, raw, None
    while rest:
        d = zlib.decompressobj(wbits=31)
        try:
            while True:
                chunk = d.decompress(rest, 1 << 20)
                out.append(chunk)
                size += len(chunk)
                if size > bound:
                    raise InputError(f"{path}: expands to more than {bound >> 20} MB, "
                                     f"{GZIP_MAX_RATIO} times its size (a decompression "
                                     "bomb?); expected a compressed flight-record CSV")
                rest = d.unconsumed_tail
                if d.eof or (not chunk and not rest):
                    break
        except zlib.error as exc:
            raise InputError(f"{path}: damaged compressed data ({exc}); the file cannot be "
                             "read, expected a whole gzip file") from None
        if not d.eof:
            cut = "the compressed data ends early (file cut short?)"
            break
        rest = d.unused_data
        if rest and rest[:2] != b"\x1f\x8b":
            if rest.strip(b"\x00"):
                cut = f"{len(rest)} byte(s) after the compressed data ignored"
            break
    return b"".join(out), cut


def _check_fields(path: Path, data: bytes | None, n_names: int) -> bool:
    """Every row has as many fields as the header names (a row with more or fewer is
    ambiguous: which value is which column's?). Checked by counting separators, in blocks
    (files with quoted fields are left to the CSV parser). Returns whether the last line
    was cut short (fewer fields and no newline: a file copied while it was written)."""
    if data is not None:
        blocks = (data[k:k + (1 << 20)] for k in range(0, len(data), 1 << 20))
    else:
        fh = open(path, "rb")
        blocks = iter(lambda: fh.read(1 << 20), b"")
    try:
        line_no, carry = 0, b""
        for block in blocks:
            buf = carry + block
            cut = buf.rfind(b"\n")
            if cut < 0:
                carry = buf
                if len(carry) > 64 << 20:
                    raise InputError(f"{path}: a line longer than 64 MB; expected one row "
                                     "per line")
                continue
            body, carry = buf[:cut + 1], buf[cut + 1:]
            if b'"' in body:
                return False
            a = np.frombuffer(body, np.uint8)
            nl = np.flatnonzero(a == 10)
            commas = np.cumsum(a == 44, dtype=np.int64)[nl]
            per_line = np.diff(commas, prepend=0) + 1
            length = np.diff(nl, prepend=-1) - 1
            blank = (length == 0) | ((length == 1) & (a[nl - 1] == 13))
            bad = (per_line != n_names) & ~blank
            if line_no == 0:
                bad[0] = False                                   # the header
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                _bad_fields(path, line_no + k + 1, int(per_line[k]), n_names)
            line_no += len(nl)
        if carry.strip() and b'"' not in carry:
            got = carry.count(b",") + 1
            if got > n_names:
                _bad_fields(path, line_no + 1, got, n_names)
            return got < n_names and line_no > 0
        return False
    finally:
        if data is None:
            fh.close()


def _bad_fields(path: Path, line: int, got: int, n_names: int):
    raise InputError(f"{path}: {row_label(line - 2, line)}: {got} fields, the header names "
                     f"{n_names} columns; which value belongs to which column is ambiguous "
                     "(expected one field per column)")


def _parse(path: Path, data: bytes | None, names: list[str]) -> pd.DataFrame:
    """The table under the header, the columns in the order of ``names`` (made unique)."""
    unique = [f"Unnamed: {k}" if not n else n if names.index(n) == k else f"{n}\x00{k}"
              for k, n in enumerate(names)]
    text = {u: str for u, n in zip(unique, names) if n in _TEXT}
    source = io.BytesIO(data) if data is not None else path
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", pd.errors.ParserWarning)
        try:
            df = pd.read_csv(source, header=0, names=unique, index_col=False, dtype=text,
                             low_memory=False, compression=None)
        except pd.errors.EmptyDataError:
            raise InputError(f"{path}: empty file, expected a flight-record CSV") from None
        except pd.errors.ParserError as exc:
            m = re.search(r"Expected (\d+) fields in line (\d+), saw (\d+)", str(exc))
            if m:
                _bad_fields(path, int(m[2]), int(m[3]), len(names))
            raise InputError(f"{path}: not a readable CSV file "
                             f"({str(exc).strip().splitlines()[-1]})") from None
        except (UnicodeDecodeError, ValueError, OSError, EOFError) as exc:
            raise InputError(f"{path}: not a readable CSV file ({type(exc).__name__}: "
                             f"{str(exc).splitlines()[0] if str(exc) else ''})") from None
    for w in caught:
        if issubclass(w.category, pd.errors.ParserWarning):
            _bad_fields(path, 2, len(names) + 1, len(names))   # pandas' first-row case
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return df


def _one_of_each(path: Path, df: pd.DataFrame, names: list[str]) -> pd.DataFrame:
    """A column named twice: the same values are read once (with a warning); different
    values make the record ambiguous, an error naming the column and the first row."""
    seen: dict[str, list[int]] = {}
    for k, n in enumerate(names):
        if n:
            seen.setdefault(n, []).append(k)
    drop = []
    for name, where in seen.items():
        if len(where) < 2:
            continue
        a = df.iloc[:, where[0]]
        for k in where[1:]:
            b = df.iloc[:, k]
            na, nb = pd.to_numeric(a, errors="coerce"), pd.to_numeric(b, errors="coerce")
            both = (na.notna() & nb.notna()).to_numpy()
            same = np.where(both, na.to_numpy(float) == nb.to_numpy(float),
                            (a.astype("string").fillna("") ==
                             b.astype("string").fillna("")).to_numpy(bool, na_value=False))
            if not same.all():
                r = int(np.flatnonzero(~same)[0])
                raise InputError(
                    f"{path}: column '{name}' {row_label(r, r + 2)}: the header names "
                    f"'{name}' {len(where)} times (fields {where[0] + 1} and {k + 1}) with "
                    f"different values ({_cell(a.iloc[r])} and {_cell(b.iloc[r])}); which is the "
                    "record's is ambiguous, expected each column once")
            drop.append(df.columns[k])
        warnings.warn(f"{path}: column '{name}': the header names it {len(where)} times "
                      "(the same values): read once", stacklevel=3)
    return df.drop(columns=drop) if drop else df


def _cell(value) -> str:
    value = value.item() if hasattr(value, "item") else value
    return repr(value)


def _time_axis(out: pd.DataFrame, where: str) -> pd.DataFrame:
    """The time axis of a record file, per experiment: a median step or a duration that
    no flight has is a unit mistake (an error naming the unit it looks like); samples
    beyond a gap of more than :data:`MAX_TIME_GAP_S` within an experiment are dropped
    (the longest stretch is kept), as the log readers do."""
    if len(out) < 2:
        return out
    t = out["time_s"].to_numpy(float)
    group = (pd.factorize(out["experiment"])[0] if "experiment" in out.columns
             else np.zeros(len(out), int))
    same = group[1:] == group[:-1]
    dt = np.diff(t)
    steps = pd.Series(dt[same & (dt > 0)], index=group[1:][same & (dt > 0)])
    if len(steps):
        median = steps.groupby(level=0).median()
        worst = int(median.idxmax())
        if median[worst] >= MAX_MEDIAN_STEP_S:
            rows = np.flatnonzero(group == worst)
            span = float(t[rows[-1]] - t[rows[0]])
            raise InputError(
                f"{where}: column 'time_s' {_csv_row(out, rows[0])}: the median step between "
                f"samples is {median[worst]:g} s{_of(out, rows[0])}, a sample every "
                f"{median[worst] / 3600:.3g} h{_time_unit(median[worst], span)}")
    # the gap rule: the longest stretch of each experiment without a gap
    gap = np.r_[False, same & (dt > MAX_TIME_GAP_S)]
    if gap.any():
        first = int(np.flatnonzero(gap)[0])
        stretch = np.cumsum(np.r_[True, ~same] | gap)
        sizes = pd.Series(stretch).groupby(group).agg(lambda s: s.value_counts().idxmax())
        keep = np.isin(stretch, sizes.to_numpy())
        warnings.warn(f"{where}: column 'time_s' {_csv_row(out, first)}: time jumps by "
                      f"{t[first] - t[first - 1]:g} s{_of(out, first)} (a gap of more than "
                      f"{MAX_TIME_GAP_S / 3600:g} h: damaged data or a clock reset); kept "
                      f"the longest stretch, dropped {int((~keep).sum())} row(s)",
                      stacklevel=3)
        out = out[keep]
        t, group = t[keep], group[keep]
    starts = np.flatnonzero(np.r_[True, group[1:] != group[:-1]])
    ends = np.r_[starts[1:], len(t)] - 1
    span = t[ends] - t[starts]
    if (span > MAX_FLIGHT_S).any():
        k = int(np.argmax(span))
        a, b = int(starts[k]), int(ends[k])
        step = float(np.median(np.diff(t[a:b + 1]))) if b > a else 0.0
        raise InputError(
            f"{where}: column 'time_s' {_csv_row(out, a)} to {_csv_row(out, b)}: "
            f"{span[k] / 3600:.3g} h{_of(out, a)}, longer than a flight or a discharge "
            f"({MAX_FLIGHT_S / 3600:g} h){_time_unit(step, float(span[k]))}")
    return out


def _csv_row(df: pd.DataFrame, pos: int) -> str:
    label = int(df.index[pos])
    return row_label(label, label + 2)


def _of(df: pd.DataFrame, pos: int) -> str:
    return (f" in experiment {df['experiment'].iloc[pos]!r}" if "experiment" in df.columns
            else "")


def _time_unit(step_s: float, span_s: float) -> str:
    """``": in µs? (0.2 s steps, 353 s in all)"``: the unit a time axis looks like."""
    for unit, factor in (("ms", 1e3), ("µs", 1e6), ("ns", 1e9)):
        if step_s / factor <= 100.0 and span_s / factor <= MAX_FLIGHT_S:
            return (f": time in {unit}? ({step_s / factor:.3g} s steps, "
                    f"{span_s / factor:.4g} s in all; expected seconds)")
    return "; expected seconds since the start of the experiment"


def read_record(path: str | os.PathLike, *, derive: bool = True,
                require_power: bool = True) -> pd.DataFrame:
    """Read a flight-record CSV file and validate it.

    The header is read here (a column named twice with different values is ambiguous:
    an error; pandas would rename one), every row must have one field per column, a
    compressed file cut short gives the rows it holds with a warning, a column none of
    whose values is plausible is a unit mistake (:data:`OTHER_UNITS`), a time axis with
    a median step or an experiment longer than any flight has is in another unit, and the
    samples beyond a gap of more than :data:`MAX_TIME_GAP_S` within an experiment are
    dropped, as the log readers do.

    Parameters
    ----------
    path : str or path
        A CSV file (optionally ``.csv.gz``) with a header line of column names.
    derive : bool, default True
        Add ``power_w`` (V·I) and ``consumed_mah`` (∫I dt) where absent.
    require_power : bool, default True
        See :func:`validate_record`.

    Raises
    ------
    InputError
        The file is missing, empty, not CSV, damaged or ambiguous, or fails
        :func:`validate_record`: one line naming the file, the column and the row.
    """
    path = files.input_path(path, "table", "flight-record CSV")
    data, cut = None, None
    if _compressed(path):
        data, cut = _gunzip(path)
        if cut is not None:
            whole = data.rfind(b"\n") + 1
            lines = data.count(b"\n", 0, whole)
            warnings.warn(f"{path}: {cut}: read the {lines} whole line(s) before it",
                          stacklevel=2)
            data = data[:whole]
        names = _header_names(path, data[:HEADER_MAX_BYTES + 1].split(b"\n", 1)[0])
    else:
        names = read_header(path)
    partial = _check_fields(path, data, len(names))
    df = _one_of_each(path, _parse(path, data, names), names)
    df.columns = [str(c).split("\x00")[0] for c in df.columns]
    if partial and len(df):
        warnings.warn(f"{path}: the last line is incomplete (fewer fields than the header; "
                      "file truncated?): skipped", stacklevel=2)
        df = df.iloc[:-1]
    if not len(df):
        raise InputError(f"{path}: no data rows (a header line of {len(names)} column(s) "
                         "and nothing after it); expected a flight record with samples")
    out = validate_record(df, path, require_power=require_power, csv_lines=True, strict=True)
    out = _time_axis(out, str(path)).reset_index(drop=True)
    if derive:
        out = complete_record(out)
    return out


def write_record(df: pd.DataFrame, path: str | os.PathLike, *,
                 require_power: bool = True, option: str = "output") -> Path:
    """Validate ``df`` and write it as a flight-record CSV (canonical column order).

    Returns the path written. Floats are written with full precision
    (round-trip exact); NaN is an empty field. ``option`` names the output in messages
    (the command line's option).
    """
    path = Path(path)
    out = _ordered(validate_record(df, path, require_power=require_power, csv_lines=False))
    files.write_text(path, out.to_csv(index=False, float_format=None), option)
    return path


# --------------------------------------------------------------------------- time base

def interpolate_onto(t_new, t, y, method: str = "linear", *,
                     max_gap_s: float | None = None, hold_last: bool = False) -> np.ndarray:
    """Put one channel ``y(t)`` onto the times ``t_new``.

    Parameters
    ----------
    t_new : array
        Target times (any order). [s]
    t, y : array
        The channel's own samples; ``t`` is sorted here (stable) and NaN times
        dropped. [s], [any]
    method : {"linear", "previous"}
        ``linear`` for continuous channels; ``previous`` (sample-and-hold) for
        states such as the flight mode (works on any dtype, text included).
    max_gap_s : float, optional
        Linear only: target times inside a gap between two channel samples
        longer than this get NaN (a dropout is not bridged).
    hold_last : bool, default False
        ``previous`` only: hold the last value beyond the channel's last sample
        (a state stays until changed). Otherwise NaN/None there.

    Returns
    -------
    ndarray
        Values at ``t_new``; NaN (None for text) outside the channel's own span
        ``[t[0], t[-1]]`` - there is no extrapolation.
    """
    t_new = np.asarray(t_new, float)
    t = np.asarray(t, float)
    y = np.asarray(y)
    keep = np.isfinite(t)
    if method == "linear":
        y = y.astype(float)
        keep &= np.isfinite(y)
    t, y = t[keep], y[keep]
    if len(t) and np.any(np.diff(t) < 0):
        order = np.argsort(t, kind="stable")
        t, y = t[order], y[order]
    text = y.dtype.kind in "OUS"
    if method == "previous":
        out = np.full(len(t_new), None if text else np.nan, dtype=object if text else float)
        if not len(t):
            return out
        i = np.searchsorted(t, t_new, side="right") - 1
        inside = i >= 0
        if not hold_last:
            inside &= t_new <= t[-1]
        out[inside] = y[i[inside]]
        return out
    if method != "linear":
        raise ValueError(f"method must be 'linear' or 'previous', got {method!r}")
    out = np.full(len(t_new), np.nan)
    if len(t) == 0:
        return out
    if len(t) == 1:
        out[t_new == t[0]] = y[0]
        return out
    # collapse duplicate times (keep the last sample at each time)
    if np.any(np.diff(t) == 0):
        last = np.r_[np.diff(t) != 0, True]
        t, y = t[last], y[last]
    inside = (t_new >= t[0]) & (t_new <= t[-1])
    out[inside] = np.interp(t_new[inside], t, y)
    if max_gap_s is not None and len(t) > 1:
        gaps = np.flatnonzero(np.diff(t) > max_gap_s)
        if len(gaps):
            j = np.searchsorted(t, t_new, side="right") - 1
            in_gap = np.isin(j, gaps) & (t_new > t[np.clip(j, 0, len(t) - 1)])
            out[in_gap] = np.nan
    return out


def resample_record(df: pd.DataFrame, period_s: float) -> pd.DataFrame:
    """Resample a flight record onto a uniform time grid per experiment.

    The grid runs from each experiment's first to its last time in steps of
    ``period_s``. Continuous channels are linearly interpolated, state
    channels (``mode``, ``cycle``) take the previous value; text columns not in
    the schema take the previous value too.
    """
    if not period_s > 0:
        raise ValueError(f"period_s must be > 0, got {period_s!r}")
    parts = []
    for key, sub in experiments(df):
        t = sub["time_s"].to_numpy(float)
        grid = np.arange(t[0], t[-1] + 0.5 * period_s, period_s) if len(t) else np.zeros(0)
        grid = grid[grid <= t[-1] + 1e-9] if len(t) else grid
        cols = {}
        for name in sub.columns:
            if name == "time_s":
                cols[name] = grid
            elif name == "experiment":
                cols[name] = np.full(len(grid), key, dtype=object)
            elif name in _STEP or not pd.api.types.is_numeric_dtype(sub[name]):
                cols[name] = interpolate_onto(grid, t, sub[name].to_numpy(), "previous",
                                              hold_last=True)
            else:
                cols[name] = interpolate_onto(grid, t, sub[name].to_numpy(float))
        parts.append(pd.DataFrame(cols, columns=list(sub.columns)))
    if not parts:
        return df.iloc[:0].copy()
    return pd.concat(parts, ignore_index=True)
