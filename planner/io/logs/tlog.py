"""MAVLink telemetry logs (``.tlog``) → flight record, through pymavlink.

A tlog is the ground station's recording of the MAVLink stream: every
message is prefixed by an 8-byte receive timestamp (µs since 1970), which is
the clock used here. Only messages from the vehicle (the system that sends
``SYS_STATUS``/``BATTERY_STATUS``, or a non-GCS ``HEARTBEAT``) are used.

Messages are decoded (and CRC-checked) by pymavlink's MAVLink 1/2 dialect
parser, frame by frame (:func:`_frames`). ``mavutil.mavlink_connection`` is not
used: it chooses what to do from the file name (a path containing ``/bin/`` is
*executed*, one with ``:`` is taken for a UDP address), and its log readers
rescan the rest of the file byte by byte after each damaged message (minutes
for a damaged megabyte). On intact logs both give the same messages (the
tests compare them); the frame reader is also about twice as fast.

Battery: ``BATTERY_STATUS`` (battery 0) when it carries a current, else
``SYS_STATUS``. Unknown values by the MAVLink definition become NaN: current
−1 (not measured), voltage 0 or UINT16_MAX, consumed −1, temperature
INT16_MAX.

Time base
---------
The battery message stream is the time base of the record: ``time_s`` is zero
at its first sample; every other channel is interpolated onto it, linearly for
continuous channels and previous-value for the flight mode (``HEARTBEAT``
``custom_mode`` → name with pymavlink's mode tables), with no extrapolation
beyond a channel's own span (NaN there) and no bridging of dropouts longer
than max(2 s, 10 sample periods). Without battery data the reader raises
:class:`~planner.errors.InputError` unless ``require_battery=False``, in which
case the fastest other channel is the time base.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd
from pymavlink import mavutil

from planner.errors import InputError
from planner.io.logs._common import Field, Message, Meta, battery_meta, build_record
from planner.io.logs._common import resolve_channels, start_time_unix
from planner.io.logs.dataflash import vehicle_meta

__all__ = ["FIELD_MAP", "read_tlog"]

_INT16_MAX = 32767
_UINT16_MAX = 65535

#: flight-record column ← message.field · scale + offset; first source with data wins.
FIELD_MAP: dict[str, tuple[Field, ...]] = {
    "voltage_v": (
        # mV: sum of the valid cells (MAVLink puts the total in cell 0 when the cells
        # are not measured, the rest UINT16_MAX)
        Field("BATTERY_STATUS", "voltages", scale=1e-3, missing=(0,)),
        Field("SYS_STATUS", "voltage_battery", scale=1e-3, missing=(0, _UINT16_MAX)),  # mV
    ),
    "current_a": (
        Field("BATTERY_STATUS", "current_battery", scale=0.01, missing=(-1,)),  # cA
        Field("SYS_STATUS", "current_battery", scale=0.01, missing=(-1,)),      # cA
    ),
    "consumed_mah": (
        Field("BATTERY_STATUS", "current_consumed", missing=(-1,)),             # mAh
    ),
    "temperature_c": (
        Field("BATTERY_STATUS", "temperature", scale=0.01, missing=(_INT16_MAX,)),  # c°C
    ),
    "pressure_pa": (
        Field("SCALED_PRESSURE", "press_abs", scale=100.0),                     # hPa
    ),
    "ambient_temperature_c": (
        Field("SCALED_PRESSURE", "temperature", scale=0.01),                    # c°C
    ),
    "altitude_m": (
        Field("GLOBAL_POSITION_INT", "relative_alt", scale=1e-3),               # mm above home
        Field("VFR_HUD", "alt", relative=True),                                 # AMSL m
    ),
    "climb_rate_ms": (
        Field("VFR_HUD", "climb"),                                              # up +
        Field("GLOBAL_POSITION_INT", "vz", scale=-0.01),                        # cm/s down +
    ),
    "groundspeed_ms": (
        Field("VFR_HUD", "groundspeed"),
        Field("GLOBAL_POSITION_INT", ("vx", "vy"), op="hypot", scale=0.01),
    ),
    "course_deg": (
        Field("GLOBAL_POSITION_INT", ("vx", "vy"), op="course", scale=0.01),    # N, E cm/s
    ),
    "airspeed_ms": (
        Field("VFR_HUD", "airspeed"),
    ),
    "wind_n_ms": (
        Field("WIND", "wind_n"),      # derived below from direction (from) and speed
    ),
    "wind_e_ms": (
        Field("WIND", "wind_e"),
    ),
    "throttle": (
        Field("VFR_HUD", "throttle", scale=0.01),                               # percent
    ),
    "mode": (
        Field("HEARTBEAT", "custom_mode_name"),   # custom_mode (+ base_mode, type) → name
    ),
}

#: fields kept per message type (the first ones are used by position in read_tlog)
_FIELDS: dict[str, tuple[str, ...]] = {
    "BATTERY_STATUS": ("id", "voltages", "current_battery", "current_consumed", "temperature"),
    "HEARTBEAT": ("type", "autopilot", "base_mode", "custom_mode"),
    "WIND": ("direction", "speed"),
}
for _sources in FIELD_MAP.values():
    for _f in _sources:
        if _f.message not in ("BATTERY_STATUS", "HEARTBEAT", "WIND"):
            _FIELDS[_f.message] = tuple(dict.fromkeys(_FIELDS.get(_f.message, ()) + _f.fields))
_TYPES = sorted(set(_FIELDS) | {"STATUSTEXT", "PARAM_VALUE"})
#: parameters kept in meta["params"] (a tlog repeats the whole parameter list)
_PARAM_PREFIXES = ("BATT", "BAT_", "BAT1", "BAT2", "MAV_TYPE", "FRAME", "Q_ENABLE",
                   "SYS_AUTOSTART")
_GCS_TYPES = {mavutil.mavlink.MAV_TYPE_GCS, getattr(mavutil.mavlink, "MAV_TYPE_ONBOARD_CONTROLLER", 18),
              getattr(mavutil.mavlink, "MAV_TYPE_ANTENNA_TRACKER", 5)}


def _frames(data: bytes, stats: dict):
    """Yield the wanted messages of a tlog, decoded and CRC-checked by pymavlink.

    Each frame is found from its 8-byte receive time (plausible: 2000 … 2100)
    and its MAVLink 1 (``FE``) or 2 (``FD``) marker; a message of a wanted type
    is decoded by pymavlink's dialect parser, which checks the CRC; any other
    frame is stepped over by its length. After a bad frame or stray bytes the
    scan moves on one byte, so damage costs time linear in its size. (pymavlink's
    own log readers rescan the rest of the file byte by byte after every bad
    message, which takes minutes on a damaged megabyte.) ``stats`` receives
    ``bad`` (messages failing the CRC), ``skipped`` (bytes outside frames),
    ``places`` and ``truncated`` (bytes of a partial last frame).
    """
    from pymavlink.dialects.v20 import all as dialect  # parses MAVLink 1 and 2

    link = dialect.MAVLink(None)
    wanted = {getattr(dialect, f"MAVLINK_MSG_ID_{t}") for t in _TYPES
              if hasattr(dialect, f"MAVLINK_MSG_ID_{t}")}
    n, ofs, gap_start = len(data), 0, None
    lo, hi = int(946684800e6), int(4102444800e6)
    stats.update(bad=0, skipped=0, places=0, truncated=0)

    def skip_one():
        nonlocal ofs, gap_start
        if gap_start is None:
            gap_start = ofs
        ofs += 1

    def close_gap():
        nonlocal gap_start
        if gap_start is not None:
            stats["skipped"] += ofs - gap_start
            stats["places"] += 1
            gap_start = None

    while ofs + 14 <= n:
        marker = data[ofs + 8]
        if marker == 0xFE:
            end = ofs + 16 + data[ofs + 9]
            msgid = data[ofs + 13]
        elif marker == 0xFD and ofs + 18 <= n:
            end = ofs + 20 + data[ofs + 9] + (13 if data[ofs + 10] & 0x01 else 0)
            msgid = int.from_bytes(data[ofs + 15:ofs + 18], "little")
        else:
            skip_one()
            continue
        t_us = int.from_bytes(data[ofs:ofs + 8], "big")
        if not lo <= t_us <= hi:
            skip_one()
            continue
        if end > n:                                  # the file ends inside this frame
            break
        if msgid in wanted:
            try:
                m = link.decode(bytearray(data[ofs + 8:end]))
            except Exception:        # noqa: BLE001 - pymavlink raises several kinds
                stats["bad"] += 1
                skip_one()
                continue
            close_gap()
            m._timestamp = t_us * 1e-6
            yield m
        else:
            close_gap()
        ofs = end
    close_gap()
    stats["truncated"] = n - ofs


def _collect(path: Path):
    """Read the tlog once: rows per type ``(src, t, *_FIELDS[type])``, texts, params."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    rows: dict[str, list] = {}
    texts: list[str] = []
    params: dict[str, float] = {}
    stats: dict = {}
    for m in _frames(data, stats):
        mtype = m.get_type()
        src = m.get_srcSystem()
        if mtype == "STATUSTEXT":
            texts.append(str(m.text))
            continue
        if mtype == "PARAM_VALUE":
            pid = m.param_id
            pid = pid if isinstance(pid, str) else pid.decode(errors="replace")
            if pid.startswith(_PARAM_PREFIXES):
                params[pid] = float(m.param_value)
            continue
        vals = []
        for f in _FIELDS[mtype]:
            v = getattr(m, f, None)
            if isinstance(v, (list, tuple)):   # BATTERY_STATUS.voltages
                v = sum(c for c in v if c != _UINT16_MAX)
            vals.append(v)
        rows.setdefault(mtype, []).append((src, m._timestamp, *vals))
    return rows, texts, params, stats


def read_tlog(path: str | os.PathLike, *, require_battery: bool = True
              ) -> tuple[pd.DataFrame, dict]:
    """Read a MAVLink ``.tlog`` into the flight record.

    Parameters
    ----------
    path : str or path
        The telemetry log.
    require_battery : bool, default True
        Raise :class:`InputError` ("…: no battery voltage/current in this log")
        when neither ``BATTERY_STATUS`` nor ``SYS_STATUS`` measures the battery.

    Returns
    -------
    (DataFrame, dict)
        The flight record and the metadata (see :func:`planner.io.logs.read_log`).
    """
    path = Path(path)
    meta = Meta(str(path), "tlog")
    if not path.is_file():
        raise InputError(f"{path}: file not found")
    if path.stat().st_size == 0:
        raise InputError(f"{path}: empty file")
    rows, texts, params, stats = _collect(path)
    if sum(len(v) for v in rows.values()) == 0:
        raise InputError(f"{path}: no MAVLink messages found (not a telemetry log?)")
    vehicle_sys, hb_type = _vehicle(rows)
    _warn_damage(path, stats, meta)
    vclass = vehicle_meta(meta, hb_type)
    meta["firmware"] = next((t for t in texts if t.startswith(("Ardu", "APM:", "PX4 v"))), None)
    meta["params"] = params
    battery_meta(meta, params, capacity=("BATT_CAPACITY", "BAT1_CAPACITY", "BAT_CAPACITY"),
                 cells=("BAT1_N_CELLS", "BAT_N_CELLS"), serial=("BATT_SERIAL_NUM",))
    meta["message_counts"] = {k: len(v) for k, v in rows.items()}
    meta["system_id"] = vehicle_sys
    cache: dict = {}

    def cached(mtype):
        if mtype not in cache:
            cache[mtype] = _message(rows, mtype, vehicle_sys)
        return cache[mtype]

    channels = resolve_channels(_field_map(cached("BATTERY_STATUS")), cached,
                                vehicle_type=vclass,
                                mode_names=lambda raw, f: np.asarray(raw, dtype=object))
    df = build_record(channels, meta, experiment=path.stem, require_battery=require_battery)
    # a tlog's clock is the ground station's receive time (UTC)
    t0 = meta.values["time_base_start_s"]
    meta["start_time_unix"] = start_time_unix(t0, [t0], [t0])
    return df, meta.values


def _vehicle(rows: dict) -> tuple:
    """(system id, MAV_TYPE) of the vehicle: the system that reports its battery, else the
    first non-GCS heartbeat."""
    vehicle_sys = None
    for mtype in ("BATTERY_STATUS", "SYS_STATUS"):
        if rows.get(mtype):
            vehicle_sys = rows[mtype][0][0]
            break
    for src, _, typ, ap, *_ in rows.get("HEARTBEAT", []):
        if typ in _GCS_TYPES or ap == mavutil.mavlink.MAV_AUTOPILOT_INVALID:
            continue
        if vehicle_sys is None:
            vehicle_sys = src
        if src == vehicle_sys:
            return vehicle_sys, typ
    return vehicle_sys, None


def _warn_damage(path: Path, stats: dict, meta: Meta) -> None:
    """One warning for what the frame reader skipped (:func:`_frames`)."""
    damage = []
    if stats["skipped"]:
        damage.append(f"skipped {stats['skipped']} byte(s) outside MAVLink frames in "
                      f"{stats['places']} place(s)")
    if stats["bad"]:
        damage.append(f"{stats['bad']} message(s) failed the MAVLink checksum")
    if stats["truncated"]:
        damage.append(f"the last {stats['truncated']} byte(s) are a partial message "
                      "(truncated log)")
    if damage:
        meta.warn(f"{path}: damaged telemetry log, read the intact messages ("
                  + "; ".join(damage) + ")")


def _message(rows: dict, mtype: str, vehicle_sys) -> Message | None:
    """The vehicle's messages of one type as arrays (battery 0 only; the WIND direction
    and speed as north and east components; the HEARTBEAT's mode by name)."""
    lst = [r for r in rows.get(mtype, []) if vehicle_sys is None or r[0] == vehicle_sys]
    if mtype == "BATTERY_STATUS":
        lst = [r for r in lst if (r[2] or 0) == 0]          # battery id 0
    if mtype == "HEARTBEAT":
        lst = [r for r in lst if r[2] not in _GCS_TYPES]
    if not lst:
        return None
    t = np.array([r[1] for r in lst], dtype=np.float64)
    data: dict[str, np.ndarray] = {}
    for i, k in enumerate(_FIELDS[mtype]):
        col = [r[2 + i] for r in lst]
        data[k] = np.array([np.nan if v is None else v for v in col], dtype=np.float64)
    if mtype == "WIND" and "direction" in data and "speed" in data:
        # WIND.direction is where the wind comes FROM (deg); record wants the
        # velocity the air moves with (towards), north/east components
        frm = np.radians(data["direction"])
        data["wind_n"] = -data["speed"] * np.cos(frm)
        data["wind_e"] = -data["speed"] * np.sin(frm)
    if mtype == "HEARTBEAT":
        # pymavlink's name for the mode (ArduPilot tables by vehicle type, PX4 modes)
        data["custom_mode_name"] = np.array(
            [mavutil.mode_string_v10(_Heartbeat(*r[2:6])) for r in lst], dtype=object)
    return Message(mtype, t, data)


def _field_map(battery_status: Message | None) -> dict:
    """:data:`FIELD_MAP`, without ``BATTERY_STATUS`` when it measures no current."""
    if battery_status is not None:
        cur = battery_status.data.get("current_battery", np.array([-1.0]))
        if not np.any(cur != -1):
            return {k: tuple(f for f in v if f.message != "BATTERY_STATUS")
                    for k, v in FIELD_MAP.items()}
    return dict(FIELD_MAP)


class _Heartbeat:
    """Minimal stand-in for a HEARTBEAT message (what ``mode_string_v10`` reads)."""

    def __init__(self, type, autopilot, base_mode, custom_mode):
        self.type = type
        self.autopilot = autopilot
        self.base_mode = base_mode
        self.custom_mode = custom_mode

    @staticmethod
    def get_type():
        """The message type pymavlink asks for."""
        return "HEARTBEAT"
