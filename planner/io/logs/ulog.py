"""PX4 ULog ``.ulg`` logs → flight record.

Only the topics named in :data:`FIELD_MAP` are decoded, by the project's own vectorised
and bounded decoder (:mod:`planner.io.logs._ulog_decode`), which gives pyulog's arrays field
for field in a fraction of its time and recovers from damage as pyulog does, within
bounds on time and memory whatever the bytes. Field names changed across PX4
versions (``voltage_filtered_v`` up to v1.11, ``voltage_v`` after; ``wind_estimate``
before the ``wind`` topic; ``baro_temp_celcius`` before ``ambient_temperature``);
the ``FIELD_MAP`` lists the alternatives in order of preference.

Time base
---------
ULog timestamps are µs since boot, per sample (the file header's start time
can be 0 or far from the data, so it is not used). The ``battery_status``
stream is the time base of the record: ``time_s`` is zero at its first
sample; every other channel is interpolated onto it, linearly for continuous
channels and previous-value for the flight mode (``vehicle_status.nav_state``
→ name), with no extrapolation beyond a channel's own span (NaN there) and no
bridging of dropouts longer than max(2 s, 10 sample periods).

Several batteries: instance 0 is kept when it measures current (else the
first instance that does); the others are listed in ``meta["battery_instances"]``
and in a warning. A damaged file is read as far as it can be recovered; what was
skipped becomes a warning.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from planner.errors import InputError
from planner.io.logs._common import Field, Message, Meta, battery_meta, build_record
from planner.io.logs._common import resolve_channels, serial_or_none, start_time_unix
from planner.io.logs._ulog_decode import ULogError, decode
from planner.io.logs.dataflash import vehicle_meta

__all__ = ["FIELD_MAP", "NAV_STATE_NAMES", "read_ulog"]

#: flight-record column ← topic.field · scale + offset; first source with data wins.
FIELD_MAP: dict[str, tuple[Field, ...]] = {
    "voltage_v": (
        Field("battery_status", "voltage_v"),
        Field("battery_status", "voltage_filtered_v"),
    ),
    "current_a": (
        Field("battery_status", "current_a", missing=(-1.0,)),   # −1 = not measured
        Field("battery_status", "current_filtered_a", missing=(-1.0,)),
    ),
    "consumed_mah": (
        Field("battery_status", "discharged_mah"),               # counts from boot: Δ kept
    ),
    "temperature_c": (
        Field("battery_status", "temperature"),                  # NaN/0 = no sensor
    ),
    "pressure_pa": (
        Field("vehicle_air_data", "baro_pressure_pa"),
    ),
    "ambient_temperature_c": (
        Field("vehicle_air_data", "ambient_temperature"),        # ≥ v1.14
        Field("vehicle_air_data", "baro_temp_celcius"),          # older (sic)
    ),
    "altitude_m": (
        Field("vehicle_local_position", "z", scale=-1.0, valid=("z_valid", 1)),  # NED, origin
        Field("vehicle_global_position", "alt", relative=True),
        Field("vehicle_air_data", "baro_alt_meter", relative=True),
    ),
    "climb_rate_ms": (
        Field("vehicle_local_position", "vz", scale=-1.0, valid=("v_z_valid", 1)),
        Field("vehicle_global_position", "vel_d", scale=-1.0),
    ),
    "groundspeed_ms": (
        Field("vehicle_local_position", ("vx", "vy"), op="hypot", valid=("v_xy_valid", 1)),
        Field("vehicle_global_position", ("vel_n", "vel_e"), op="hypot"),
    ),
    "course_deg": (
        Field("vehicle_local_position", ("vx", "vy"), op="course", valid=("v_xy_valid", 1)),
        Field("vehicle_global_position", ("vel_n", "vel_e"), op="course"),
    ),
    "airspeed_ms": (
        Field("airspeed_validated", "true_airspeed_m_s"),
    ),
    "wind_n_ms": (
        Field("wind", "windspeed_north"),
        Field("wind_estimate", "windspeed_north"),
    ),
    "wind_e_ms": (
        Field("wind", "windspeed_east"),
        Field("wind_estimate", "windspeed_east"),
    ),
    "throttle": (
        Field("actuator_controls_0", "control[3]"),              # ≤ v1.13
        Field("vehicle_thrust_setpoint", "xyz[0]", vehicle="fixed_wing"),
        Field("vehicle_thrust_setpoint", "xyz[2]", scale=-1.0),  # multicopter: up = −z
    ),
    "mode": (
        Field("vehicle_status", "nav_state"),
    ),
}

#: vehicle_status.nav_state → name (PX4 msg/VehicleStatus.msg; retired numbers kept
#: with their historic names).
NAV_STATE_NAMES = {
    0: "MANUAL", 1: "ALTCTL", 2: "POSCTL", 3: "AUTO_MISSION", 4: "AUTO_LOITER",
    5: "AUTO_RTL", 6: "POSITION_SLOW", 7: "AUTO_RTGS", 8: "AUTO_LANDENGFAIL",
    9: "AUTO_LANDGPSFAIL", 10: "ACRO", 11: "FREE2", 12: "DESCEND", 13: "TERMINATION",
    14: "OFFBOARD", 15: "STAB", 16: "RATTITUDE", 17: "AUTO_TAKEOFF", 18: "AUTO_LAND",
    19: "AUTO_FOLLOW_TARGET", 20: "AUTO_PRECLAND", 21: "ORBIT", 22: "AUTO_VTOL_TAKEOFF",
    23: "EXTERNAL1", 24: "EXTERNAL2", 25: "EXTERNAL3", 26: "EXTERNAL4", 27: "EXTERNAL5",
    28: "EXTERNAL6", 29: "EXTERNAL7", 30: "EXTERNAL8",
}

#: Topics with the GPS receiver's UTC (``time_utc_usec``), in order of preference: the
#: flight's start time. ``sensor_gps`` is the raw receiver topic of PX4 ≥ v1.14.
GPS_TIME_TOPICS = ("vehicle_gps_position", "sensor_gps")
_TOPICS = sorted({f.message for fs in FIELD_MAP.values() for f in fs} | set(GPS_TIME_TOPICS))


def _firmware(info: dict) -> str | None:
    rel = info.get("ver_sw_release")
    text = None
    if isinstance(rel, int) and rel:
        major, minor, patch, kind = (rel >> 24) & 0xFF, (rel >> 16) & 0xFF, \
            (rel >> 8) & 0xFF, rel & 0xFF
        suffix = ("" if kind == 255 else "-rc" if kind >= 192 else "-beta" if kind >= 128
                  else "-alpha" if kind >= 64 else "-dev")
        text = f"PX4 v{major}.{minor}.{patch}{suffix}"
    git = info.get("ver_sw")
    if git:
        text = f"{text or 'PX4'} ({str(git)[:8]})"
    return text


def _has_current(d) -> bool:
    for name in ("current_a", "current_filtered_a"):
        if name in d.data:
            c = np.asarray(d.data[name], float)
            if np.any(np.isfinite(c) & (c != -1.0)):
                return True
    return False


def read_ulog(path: str | os.PathLike, *, require_battery: bool = True
              ) -> tuple[pd.DataFrame, dict]:
    """Read a PX4 ``.ulg`` file into the flight record.

    Parameters
    ----------
    path : str or path
        The log.
    require_battery : bool, default True
        Raise :class:`InputError` when there is no battery voltage/current.

    Returns
    -------
    (DataFrame, dict)
        The flight record (one row per ``battery_status`` sample of the kept
        instance) and the metadata (see :func:`planner.io.logs.read_log`).
    """
    path = Path(path)
    meta = Meta(str(path), "ulog")
    ulog, damaged = _decode(path, meta)
    vclass = _parameters(ulog, path, meta)
    topics = _Topics(ulog)
    topics.battery = _battery_instance(topics.by_topic.get("battery_status", []), path, meta)
    channels = resolve_channels(FIELD_MAP, topics.get, vehicle_type=vclass,
                                mode_names=_mode_names)
    try:
        df = build_record(channels, meta, experiment=path.stem,
                          require_battery=require_battery)
    except InputError as exc:
        if damaged:
            raise InputError(f"{exc} - the file is damaged, see the warning above") from None
        raise
    _start_time(topics, meta)
    return df, meta.values


def _decode(path: Path, meta: Meta):
    """The decoded file (:func:`planner.io.logs._ulog_decode.decode`) and whether it is
    damaged; damage, truncation and dropouts said in ``meta``."""
    from planner.io import files

    buf = files.read_bytes(path, "log", "log file")
    if not buf:
        raise InputError(f"{path}: empty file")
    try:
        ulog = decode(buf, _TOPICS)
    except ULogError as exc:
        raise InputError(f"{path}: not a readable ULog file ({exc})") from None
    damaged = ulog.file_corruption
    if damaged:
        detail = "; ".join(dict.fromkeys(ulog.problems))[:300] or "file corruption detected"
        meta.warn(f"{path}: damaged ULog, read what could be recovered ({detail})")
    if ulog.truncated_bytes:
        damaged = True
        meta.warn(f"{path}: truncated ULog: the file ends inside a message, "
                  f"skipped the last {ulog.truncated_bytes} byte(s)")
    if ulog.dropouts_ms:
        lost = sum(ulog.dropouts_ms)
        meta["dropouts"] = len(ulog.dropouts_ms)
        meta["notes"] = [f"{len(ulog.dropouts_ms)} logging dropout(s), {lost} ms in total"]
    return ulog, damaged


def _parameters(ulog, path: Path, meta: Meta) -> str | None:
    """The parameters, firmware, vehicle and pack in ``meta``; returns the vehicle type."""
    raw_params = dict(ulog.initial_parameters)
    # a parameter is an int32 or a float; one whose type a damaged file garbled is ignored
    params = {k: v for k, v in raw_params.items()
              if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)}
    garbled = sorted(set(raw_params) - set(params))
    if garbled:
        meta.warn(f"{path}: damaged ULog: {len(garbled)} parameter(s) with an unreadable "
                  f"type ignored ({', '.join(garbled[:3])}{' …' if len(garbled) > 3 else ''})")
    info = ulog.msg_info_dict
    meta["params"] = params
    meta["firmware"] = _firmware(info)
    meta["hardware"] = info.get("ver_hw")
    mav_type = params.get("MAV_TYPE")
    if mav_type is not None and not (np.isfinite(mav_type) and float(mav_type).is_integer()):
        meta.warn(f"{path}: MAV_TYPE {mav_type} is not a vehicle type: ignored")
        mav_type = None
    vclass = vehicle_meta(meta, mav_type)
    battery_meta(meta, params, capacity=("BAT1_CAPACITY", "BAT_CAPACITY"),
                 cells=("BAT1_N_CELLS", "BAT_N_CELLS"))
    return vclass


def _battery_instance(batteries: list, path: Path, meta: Meta):
    """The ``battery_status`` instance the record follows: instance 0 if it measures
    current, else the first that does, else the first; its serial and cycle count in
    ``meta``."""
    if not batteries:
        return None
    keep = next((d for d in batteries if d.multi_id == 0 and _has_current(d)), None) or \
        next((d for d in batteries if _has_current(d)), batteries[0])
    if len(batteries) > 1:
        meta["battery_instances"] = [d.multi_id for d in batteries]
        meta["battery_instance"] = keep.multi_id
        meta.warn(f"{path}: {len(batteries)} battery_status instances; kept instance "
                  f"{keep.multi_id}, ignored "
                  f"{[d.multi_id for d in batteries if d is not keep]}")
    meta["battery_serial"] = serial_or_none(keep.data.get("serial_number"))
    cycles = keep.data.get("cycle_count")
    if meta["battery_serial"] is not None and cycles is not None and len(cycles):
        meta["battery_cycle_count"] = int(np.max(cycles))     # a smart battery's count
    return keep


class _Topics:
    """The decoded topics, each as a :class:`Message` in seconds of the log's clock."""

    def __init__(self, ulog):
        self.by_topic: dict[str, list] = {}
        for d in ulog.data_list:
            self.by_topic.setdefault(d.name, []).append(d)
        for lst in self.by_topic.values():
            lst.sort(key=lambda d: d.multi_id)
        self.battery = None

    def get(self, topic: str) -> Message | None:
        """The topic's first instance (``battery_status``: the kept one), or None."""
        lst = self.by_topic.get(topic)
        if not lst:
            return None
        d = self.battery if topic == "battery_status" else lst[0]
        if "timestamp" not in d.data:          # damaged format definition
            return None
        t = np.asarray(d.data["timestamp"], dtype=np.float64) * 1e-6
        return Message(topic, t, d.data, instance=d.multi_id)


def _mode_names(raw: np.ndarray, f: Field) -> np.ndarray:
    return np.array([NAV_STATE_NAMES.get(int(v), f"NAV_STATE({int(v)})") for v in raw],
                    dtype=object)


def _start_time(topics: _Topics, meta: Meta) -> None:
    """``start_time_unix`` from the GPS receiver's UTC, where the log has it."""
    for topic in GPS_TIME_TOPICS:
        gps = topics.get(topic)
        if gps is not None and "time_utc_usec" in gps.data:
            # 0 until the receiver has a fix: start_time_unix keeps only times in 2000–2100
            start = start_time_unix(meta.values["time_base_start_s"], gps.t,
                                    np.asarray(gps.data["time_utc_usec"], float) * 1e-6)
            if start is not None:
                meta["start_time_unix"] = start
                return
