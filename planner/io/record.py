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

import itertools
import os
import warnings
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
    "REQUIRED",
    "Column",
    "add_consumed",
    "add_power",
    "complete_record",
    "cumulative_trapezoid",
    "experiments",
    "interpolate_onto",
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
}

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
                    require_power: bool = True, csv_lines: bool | None = None) -> pd.DataFrame:
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

    Returns
    -------
    DataFrame
        A copy with the known numeric columns as float64 (``cycle`` may hold
        NaN), ``experiment`` and ``mode`` as strings; unknown columns untouched.

    Raises
    ------
    InputError
        A missing required column, a non-numeric value in a numeric column, a
        missing or non-finite ``time_s``, or a time that goes backwards within
        one experiment; the message names the source, the column and the first
        bad row (:func:`planner.io.tables.cell_error`).
    """
    where = _where(source)
    if csv_lines is None:
        csv_lines = str(source).lower().endswith((".csv", ".csv.gz")) if source else False
    _check_columns(df, where, require_power)
    out = df.copy()
    _numbers(out, df, where, csv_lines)
    _implausible_as_missing(out, df, where, csv_lines)
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
            raise InputError(f"{where}: missing required column '{name}' "
                             f"(columns: {', '.join(map(str, df.columns)) or 'none'})")
    if require_power and "power_w" not in df.columns and "voltage_v" not in df.columns:
        missing = [c for c in ("voltage_v", "current_a") if c not in df.columns]
        raise InputError(f"{where}: missing required column '{missing[0]}' "
                         "(need 'power_w' or both 'voltage_v' and 'current_a')")
    if df.columns.duplicated().any():
        dup = df.columns[df.columns.duplicated()][0]
        raise InputError(f"{where}: column '{dup}' appears more than once")


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
                            csv_lines: bool) -> None:
    """Values outside :data:`PLAUSIBLE` become NaN, with a warning per column."""
    for name, (low, high) in PLAUSIBLE.items():
        if name not in out.columns:
            continue
        values = out[name].to_numpy(float)
        with np.errstate(invalid="ignore"):
            odd = (values < low) | (values > high)
        if name in _BATTERY:  # an infinite battery reading is reported where it is used
            odd &= np.isfinite(values)
        if odd.any():
            first = int(np.flatnonzero(odd)[0])
            warnings.warn(f"{where}: column '{name}': {int(odd.sum())} value(s) outside "
                          f"[{low:g}, {high:g}] {COLUMNS[name].unit}, first "
                          f"{_row_label(df, first, csv_lines)} = {values[first]:g}: read as "
                          "missing", stacklevel=3)
            out[name] = np.where(odd, np.nan, values)


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


def read_record(path: str | os.PathLike, *, derive: bool = True,
                require_power: bool = True) -> pd.DataFrame:
    """Read a flight-record CSV file and validate it.

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
        The file is missing, empty or not CSV, or fails :func:`validate_record`.
    """
    path = files.input_path(path, "table", "flight-record CSV")
    try:
        df = pd.read_csv(path, dtype={"experiment": str, "mode": str}, low_memory=False)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, expected a CSV file") from None
    except pd.errors.EmptyDataError:
        raise InputError(f"{path}: empty file, expected a flight-record CSV") from None
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError, OSError) as exc:
        raise InputError(f"{path}: not a readable CSV file ({exc})") from None
    df.columns = [str(c).strip() for c in df.columns]
    df = drop_truncated_last_line(df, path)
    out = validate_record(df, path, require_power=require_power, csv_lines=True)
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
