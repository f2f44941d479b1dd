"""Machinery shared by the log readers: FIELD_MAP entries, channels, one time base.

Each reader decodes its format into *messages* (a time array plus one array per
field, in the reader's own clock, seconds) and hands them to
:func:`resolve_channels` with its module-level ``FIELD_MAP``. ``FIELD_MAP`` maps
each flight-record column to an ordered tuple of :class:`Field` sources; the
first source whose message and field(s) exist and hold data wins. Then
:func:`build_record` puts every channel onto the time base (see
:mod:`planner.io.logs` for the rule) and returns the flight-record DataFrame (docs/record.md).
"""

from __future__ import annotations

import bisect
import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from dataclasses import field as dc_field

import numpy as np
import pandas as pd

from planner.errors import InputError
from planner.io.record import (
    COLUMNS,
    MAX_TIME_GAP_S,
    NO_CURRENT_NOTE,
    cumulative_trapezoid,
    interpolate_onto,
)
from planner.physics.limits import CELLS_SERIES_MAX
from planner.physics.units import AS_PER_MAH

#: Columns that come from the battery message (they define the time base).
BATTERY_COLUMNS = ("voltage_v", "current_a", "consumed_mah", "temperature_c")
#: Step-like channels: previous-value interpolation, held after the last sample.
STATE_COLUMNS = ("mode",)
#: Below this horizontal speed a course computed from velocity components is NaN: at rest
#: (hovering) the direction of travel is undefined. [m/s]
COURSE_MIN_SPEED_MS = 0.2


def course_deg(north, east, speed) -> np.ndarray:
    """Course of a velocity, degrees from north, clockwise, in [0, 360); NaN where
    ``speed`` (the horizontal speed, m/s) is below :data:`COURSE_MIN_SPEED_MS`.
    ``north``, ``east``: the velocity components (any one unit). [deg]"""
    course = np.degrees(np.arctan2(east, north)) % 360.0
    course[np.asarray(speed) < COURSE_MIN_SPEED_MS] = np.nan
    return course


def _outside_stacklevel() -> int:
    import os
    import sys
    here = os.path.dirname(os.path.abspath(__file__))
    level, f = 1, sys._getframe(1)
    while f is not None and os.path.dirname(os.path.abspath(f.f_code.co_filename)) == here:
        f = f.f_back
        level += 1
    return level


class LogWarning(UserWarning):
    """A log was read, but part of it was skipped or is suspicious."""


@dataclass(frozen=True)
class Field:
    """One source of a flight-record column: ``column ← message.field · scale + offset``.

    Parameters
    ----------
    message : str
        Message (DataFlash/MAVLink) or topic (ULog) name.
    field : str or tuple of str
        Field name; a tuple for ``op`` over several fields.
    scale, offset : float
        ``value = raw · scale + offset`` (after ``op``).
    op : {None, "hypot", "course"}
        ``hypot``: √(a² + b²) of two fields (speed from velocity components);
        ``course``: ``atan2(east, north)`` in degrees 0..360 from fields
        ``(north, east)``; ``scale`` then only converts the components to m/s
        for the rule that course is NaN below ``COURSE_MIN_SPEED_MS`` (undefined
        at rest).
    int_scale : float, optional
        DataFlash only: the scale to use instead when the field is stored as an
        integer (old ArduPilot ``CURR.Volt``/``Curr`` are int16 cV/cA, newer
        firmware logs float V/A under the same names).
    relative : bool
        Subtract the first valid value (AMSL altitude → altitude above start).
    missing : tuple of float
        Raw values that mean "not measured" (→ NaN), e.g. −1 or INT16_MAX.
    valid : (str, float), optional
        Keep only samples where ``message.<name> >= value`` (GPS fix type).
    vehicle : str or tuple of str, optional
        Use this source only for this vehicle type (``multirotor``,
        ``fixed_wing``, ``vtol``, ...): the same field means different things
        per type (ArduCopter CTUN.ThrOut is 0..1000, ArduPlane's is percent).
    """

    message: str
    field: str | tuple[str, ...]
    scale: float = 1.0
    offset: float = 0.0
    op: str | None = None
    int_scale: float | None = None
    relative: bool = False
    missing: tuple[float, ...] = ()
    valid: tuple[str, float] | None = None
    vehicle: str | tuple[str, ...] | None = None

    @property
    def fields(self) -> tuple[str, ...]:
        """The message field(s) read, as a tuple."""
        return self.field if isinstance(self.field, tuple) else (self.field,)

    def describe(self) -> str:
        """``message.field`` (or ``message.op(a,b)``), for the metadata's ``channels``."""
        f = "+".join(self.fields) if self.op is None else f"{self.op}({','.join(self.fields)})"
        return f"{self.message}.{f}"


@dataclass
class Message:
    """Decoded samples of one message type (one instance) in the reader's clock."""

    name: str
    t: np.ndarray                                   # s
    data: Mapping[str, np.ndarray]
    integer_fields: frozenset = frozenset()
    instance: object = None


@dataclass
class Channel:
    """One flight-record column in its native sampling."""

    column: str
    t: np.ndarray
    values: np.ndarray
    source: str
    message: str

    @property
    def rate_hz(self) -> float | None:
        """Mean sample rate of the channel (None with fewer than two samples). [Hz]"""
        if len(self.t) < 2:
            return None
        span = float(self.t[-1] - self.t[0])
        return (len(self.t) - 1) / span if span > 0 else None


@dataclass
class Meta:
    """Builder for the metadata dict every reader returns."""

    source: str
    format: str
    values: dict = dc_field(default_factory=dict)

    def __post_init__(self):
        self.values.update({
            "source": self.source, "format": self.format, "vehicle_type": None,
            "vehicle": None, "firmware": None, "battery_capacity_mah": None,
            "battery_cells": None, "battery_serial": None, "rates_hz": {}, "channels": {}, "warnings": [],
        })

    def warn(self, message: str, stacklevel: int | None = None):
        """Record ``message`` in ``warnings`` and issue it as a :class:`LogWarning`.

        The warning points at the first caller outside :mod:`planner.io.logs`.
        """
        self.values["warnings"].append(message)
        warnings.warn(message, LogWarning, stacklevel=_outside_stacklevel())

    def __setitem__(self, key, value):
        self.values[key] = value

    def __getitem__(self, key):
        return self.values[key]


def capacity_or_none(value) -> float | None:
    """Battery capacity parameter in mAh; ≤ 0 or missing means unset."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) and v > 0 else None


#: GPS time zero, 1980-01-06 00:00:00 UTC. [s since 1970]
GPS_EPOCH_UNIX = 315_964_800
#: GPS − UTC leap seconds (since 2017-01-01; older logs' start times are late by the
#: difference, at most a few seconds). [s]
GPS_LEAP_S = 18
#: Receive or GPS times outside 2000 … 2100 are not a clock. [s since 1970]
UNIX_TIME_RANGE = (946_684_800.0, 4_102_444_800.0)


def start_time_unix(start_s: float, clock_s, unix_s) -> float | None:
    """UTC of a log's first sample (``start_s`` in the reader's clock) from pairs of the
    reader's clock and UTC (GPS time): the median offset between the two. [s since 1970]"""
    c = np.asarray(clock_s, float)
    u = np.asarray(unix_s, float)
    ok = np.isfinite(c) & np.isfinite(u) & (u > UNIX_TIME_RANGE[0]) & (u < UNIX_TIME_RANGE[1])
    if not ok.any() or not np.isfinite(start_s):
        return None
    return float(start_s + np.median(u[ok] - c[ok]))


def serial_or_none(value) -> str | None:
    """A battery serial number (PX4 ``battery_status.serial_number``, ArduPilot
    ``BATT_SERIAL_NUM``): the most frequent positive whole value of a number or an array,
    as text; 0, −1 (unset), missing or non-finite means none."""
    v = np.atleast_1d(np.asarray(value if value is not None else [], dtype=float)).ravel()
    v = v[np.isfinite(v) & (v > 0)]
    if v.size == 0:
        return None
    vals, counts = np.unique(np.round(v), return_counts=True)
    return str(int(vals[np.argmax(counts)]))


def cells_or_none(value) -> int | None:
    """Series cell count parameter; missing, non-finite or outside 1 to
    :data:`~planner.physics.limits.CELLS_SERIES_MAX` means unset."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    if not math.isfinite(v) or not 1 <= round(v) <= CELLS_SERIES_MAX:
        return None
    return round(v)


def battery_meta(meta: Meta, params: Mapping, *, capacity=(), cells=(), serial=()) -> None:
    """The pack's ``battery_capacity_mah``, ``battery_cells`` and ``battery_serial`` in
    ``meta`` from the log's parameters: each from the first of its parameter names the log
    holds (firmware versions name them differently); a kind without names is left as
    it is."""
    def first(names):
        return next((params[n] for n in names if n in params), None)

    if capacity:
        meta["battery_capacity_mah"] = capacity_or_none(first(capacity))
    if cells:
        meta["battery_cells"] = cells_or_none(first(cells))
    if serial:
        meta["battery_serial"] = serial_or_none(first(serial))


def _apply(f: Field, msg: Message) -> np.ndarray:
    raws = [np.asarray(msg.data[name]) for name in f.fields]
    vals = [r.astype(float) for r in raws]
    for r, v in zip(raws, vals):
        for m in f.missing:
            v[r == m] = np.nan
    if f.op is None:
        v = vals[0]
        scale = f.scale
        if f.int_scale is not None and f.fields[0] in msg.integer_fields:
            scale = f.int_scale
        v = v * scale + f.offset
    elif f.op == "hypot":
        v = np.hypot(vals[0], vals[1]) * f.scale + f.offset
    elif f.op == "course":
        v = course_deg(vals[0], vals[1], np.hypot(vals[0], vals[1]) * f.scale)
    else:  # pragma: no cover - a FIELD_MAP bug
        raise ValueError(f"unknown op {f.op!r}")
    return v


def resolve_channels(field_map: Mapping[str, tuple[Field, ...]],
                     get: Callable[[str], Message | None], *,
                     vehicle_type: str | None = None,
                     mode_names: Callable[[np.ndarray, Field], np.ndarray] | None = None,
                     ) -> dict[str, Channel]:
    """Pick, for every column of ``field_map``, the first source with data.

    ``get(message_name)`` returns the decoded :class:`Message` or ``None``.
    The ``mode`` column is passed through ``mode_names(raw, field)``; ``throttle`` is
    clipped to [0, 1].
    """
    out: dict[str, Channel] = {}
    for column, sources in field_map.items():
        for f in sources:
            if f.vehicle is not None and vehicle_type not in (
                    (f.vehicle,) if isinstance(f.vehicle, str) else f.vehicle):
                continue
            msg = get(f.message)
            if msg is None or len(msg.t) == 0 or any(n not in msg.data for n in f.fields):
                continue
            if column not in STATE_COLUMNS and any(
                    np.asarray(msg.data[n]).dtype.kind not in "biuf" for n in f.fields):
                continue            # a text field where a number belongs (damaged FMT)
            keep = np.isfinite(msg.t)
            if f.valid is not None:
                vname, vmin = f.valid
                if vname in msg.data:
                    keep &= np.asarray(msg.data[vname], float) >= vmin
            if column in STATE_COLUMNS:
                raw = np.asarray(msg.data[f.fields[0]])[keep]
                vals = mode_names(raw, f) if mode_names is not None else raw.astype(str)
                vals = np.asarray(vals, dtype=object)
                if len(vals) == 0:
                    continue
            else:
                vals = _apply(f, msg)[keep]
                ok = np.flatnonzero(np.isfinite(vals))
                if not len(ok):
                    continue
                if f.relative:              # above the first valid sample
                    vals = vals - vals[ok[0]]
            out[column] = Channel(column, np.asarray(msg.t, float)[keep], vals,
                                  f.describe(), msg.name)
            break
    if "throttle" in out:  # 0..1 by definition of the record; PWM-derived values overshoot
        out["throttle"].values = np.clip(out["throttle"].values, 0.0, 1.0)
    return out


def increasing_subset(t: np.ndarray) -> np.ndarray:
    """Indices of the longest strictly increasing run of finite times (not contiguous).

    One damaged timestamp (a garbage ``TimeUS`` far in the future, a clock
    reset) then costs only the samples that are really out of order, not all
    the samples after it. O(n log n); the clean case is one vectorised check.
    """
    t = np.asarray(t, float)
    fin = np.flatnonzero(np.isfinite(t))
    tt = t[fin]
    if len(tt) < 2 or np.all(np.diff(tt) > 0):
        return fin
    tails: list[float] = []          # smallest tail time of an increasing run of length k+1
    tail_idx: list[int] = []
    prev = np.full(len(tt), -1, dtype=np.int64)
    for i, v in enumerate(tt.tolist()):
        k = bisect.bisect_left(tails, v)
        if k == len(tails):
            tails.append(v)
            tail_idx.append(i)
        else:
            tails[k] = v
            tail_idx[k] = i
        prev[i] = tail_idx[k - 1] if k > 0 else -1
    out = []
    i = tail_idx[-1]
    while i >= 0:
        out.append(i)
        i = prev[i]
    return fin[np.array(out[::-1], dtype=np.int64)]


def _clean(ch: Channel, meta: Meta, dropped: dict) -> np.ndarray:
    """Indices of a channel's samples with finite, strictly increasing time, in the
    largest stretch without a gap longer than :data:`MAX_TIME_GAP_S`."""
    idx = increasing_subset(ch.t)
    if len(idx) > 1:
        gaps = np.flatnonzero(np.diff(np.asarray(ch.t, float)[idx]) > MAX_TIME_GAP_S)
        if len(gaps):
            starts, ends = np.r_[0, gaps + 1], np.r_[gaps + 1, len(idx)]
            k = int(np.argmax(ends - starts))
            idx = idx[starts[k]:ends[k]]
    n_bad = len(ch.t) - len(idx)
    if n_bad:
        dropped[ch.message] = max(dropped.get(ch.message, 0), n_bad)
    return idx


def build_record(channels: dict[str, Channel], meta: Meta, *, experiment: str,
                 base: str | None = None, require_battery: bool = True) -> pd.DataFrame:
    """Assemble the flight record on the battery time base.

    Parameters
    ----------
    channels : dict
        Output of :func:`resolve_channels` (plus any reader-specific channels).
    meta : Meta
        Filled with ``rates_hz``, ``channels``, ``samples``, ``duration_s``.
    experiment : str
        Value of the ``experiment`` column (the log file stem).
    base : str, optional
        Column whose message defines the time base; default the message of
        ``current_a``, else ``voltage_v``.
    require_battery : bool
        Without battery voltage/current: raise :class:`InputError` (default),
        or use the fastest other channel as the time base.
    """
    base_ch = channels[_time_base(channels, meta, base, require_battery)]
    dropped: dict[str, int] = {}
    keep = _clean(base_ch, meta, dropped)
    if len(keep) == 0:
        raise InputError(f"{meta.source}: no valid {base_ch.message} samples (time base)")
    t0_abs = base_ch.t[keep]
    cols: dict[str, np.ndarray] = {"experiment": np.full(len(t0_abs), experiment, dtype=object),
                                   "time_s": t0_abs - t0_abs[0]}
    for column in COLUMNS:
        ch = channels.get(column)
        vals = None if ch is None else _on_time_base(ch, base_ch, keep, t0_abs, meta, dropped)
        if vals is not None:
            cols[column] = vals
            meta["channels"][column] = ch.source
            meta["rates_hz"][column] = ch.rate_hz
    if dropped:
        meta.warn(f"{meta.source}: dropped sample(s) whose time is missing, out of order or "
                  "beyond a gap of more than 6 h "
                  "(damaged data or a clock reset): "
                  + ", ".join(f"{n} {m}" for m, n in dropped.items()))
    _battery_columns(cols, meta)
    text = {"experiment", "mode"}
    df = pd.DataFrame({c: (pd.array(cols[c], dtype="str") if c in text else cols[c])
                       for c in COLUMNS if c in cols})
    meta["samples"] = len(df)
    meta["duration_s"] = float(cols["time_s"][-1]) if len(df) else 0.0
    meta["time_base"] = base_ch.source.split(".")[0]
    meta["time_base_start_s"] = float(t0_abs[0])
    return df


def _time_base(channels: dict[str, Channel], meta: Meta, base: str | None,
               require_battery: bool) -> str:
    """The column whose samples are the record's rows: the battery's current (else its
    voltage); without battery data the fastest other stream, or an error."""
    if base is None:
        base = next((c for c in ("current_a", "voltage_v") if c in channels), None)
    if base is not None:
        return base
    if require_battery:
        raise InputError(f"{meta.source}: no battery voltage/current in this log; "
                         "expected a log with battery data (an export that allows no "
                         "battery reads the other channels)")
    if not channels:
        raise InputError(f"{meta.source}: no usable data in this log")
    cont = [c for c in channels.values() if c.column not in STATE_COLUMNS] or \
        list(channels.values())
    base = max(cont, key=lambda c: len(c.t)).column
    meta.warn(f"{meta.source}: no battery voltage/current; time base is the "
              f"{channels[base].message} stream")
    return base


def _on_time_base(ch: Channel, base_ch: Channel, keep: np.ndarray, t0_abs: np.ndarray,
                  meta: Meta, dropped: dict) -> np.ndarray | None:
    """A channel on the time base (see :mod:`planner.io.logs`); None when it holds no
    value there."""
    column = ch.column
    if ch.message == base_ch.message and len(ch.t) == len(base_ch.t) and \
            np.array_equal(ch.t, base_ch.t):
        vals = np.asarray(ch.values)[keep]
    else:
        good = _clean(ch, meta, dropped)
        t_ch, v_ch = ch.t[good], np.asarray(ch.values)[good]
        if column in STATE_COLUMNS:
            vals = interpolate_onto(t0_abs, t_ch, v_ch, "previous", hold_last=True)
        else:
            dt = np.diff(t_ch)
            max_gap = max(2.0, 10.0 * float(np.median(dt))) if len(dt) else None
            vals = interpolate_onto(t0_abs, t_ch, v_ch, "linear", max_gap_s=max_gap)
    if column in STATE_COLUMNS:
        return None if all(v is None for v in vals) else vals
    if not np.isfinite(np.asarray(vals, float)).any():
        return None
    if column == "temperature_c":
        v = np.asarray(vals, float)
        v[v == 0.0] = np.nan        # 0 °C exactly = no sensor on these autopilots
        return v if np.isfinite(v).any() else None
    if column == "consumed_mah":
        v = np.asarray(vals, float)
        ok = np.flatnonzero(np.isfinite(v))
        return v - v[ok[0]]         # autopilot counters count from boot
    return vals


def _battery_columns(cols: dict, meta: Meta) -> None:
    """Power (V·I) and charge drawn (∫I dt) where the log gives none; without a current
    sensor, the autopilot's dead charge counter dropped and the record said not
    replayable."""
    if "voltage_v" in cols and "current_a" not in cols and "power_w" not in cols:
        # no current sensor (PX4 logs current −1, ArduPilot no CURR): the autopilot's
        # consumed-charge counter then stays at zero and means nothing
        if "consumed_mah" in cols and not np.nanmax(np.abs(cols["consumed_mah"])) > 0:
            del cols["consumed_mah"]
            meta["channels"].pop("consumed_mah", None)
            meta["rates_hz"].pop("consumed_mah", None)
        meta.warn(f"{meta.source}: {NO_CURRENT_NOTE}")
    if "voltage_v" in cols and "current_a" in cols and "power_w" not in cols:
        cols["power_w"] = np.asarray(cols["voltage_v"], float) * np.asarray(cols["current_a"],
                                                                            float)
        meta["channels"]["power_w"] = "voltage_v * current_a"
    if "consumed_mah" not in cols and "current_a" in cols:
        cols["consumed_mah"] = cumulative_trapezoid(cols["current_a"], cols["time_s"]) / AS_PER_MAH
        meta["channels"]["consumed_mah"] = "trapezoid integral of current_a"
