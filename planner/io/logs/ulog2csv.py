"""PX4 topic exports (pyulog's ``ulog2csv``) → flight record.

Flight Review and many publications share a PX4 flight as the CSV files pyulog's
``ulog2csv`` writes from the ``.ulg``: one file per topic and instance, named
``<prefix>_<topic>_<instance>.csv`` (pyulog ``ulog2csv.py``:
``f'{output_file_prefix}_{name_without_slash}_{d.multi_id}.csv'``, the prefix being the
``.ulg`` file name without ``.ulg``), one header row, ``timestamp`` (µs since boot, an
integer) first, arrays flattened as ``name[i]``. :func:`read_ulog2csv` reads a folder of
such files, or a ``.zip`` of them, into the same flight record as the ``.ulg`` reader
(:func:`planner.io.logs.ulog.read_ulog`):

* the same topics and fields, by the ``.ulg`` reader's own ``FIELD_MAP``. The prefix is
  the shortest one left when a topic of that map and ``_<instance>`` are taken off the end
  of a file name (topic names hold underscores and digits:
  ``flight3_actuator_controls_0_0.csv`` is topic ``actuator_controls_0``, instance 0, and
  ``flight3_airspeed_wind_0.csv`` is ``airspeed_wind``, not ``wind``); files of other
  topics are not read;
* the same time base and start-time rule: the kept ``battery_status`` instance's samples
  (µs since boot → s), ``time_s`` zero at its first one, every other channel interpolated
  onto it by :func:`planner.io.logs._common.build_record`; the UTC start from
  ``vehicle_gps_position.time_utc_usec``;
* ``experiment`` is the prefix, which is the ``.ulg`` file's stem.

An export holds no parameters and no info messages: the vehicle type comes from
``vehicle_status.system_type`` (the ``MAV_TYPE`` PX4 publishes there; else its
``vehicle_type`` and ``is_vtol``), the firmware,
pack capacity and cell count are unknown (None).

Propulsion battery
------------------
With several ``battery_status`` instances the reader keeps the one that *carries the
current*: the largest charge ∫|I| dt over its own samples (``current_a``, else
``current_filtered_a``; −1 and NaN are "not measured"); a tie keeps the lowest instance.
A solar or payload channel logged beside the propulsion pack carries little charge and
is left out (the Solar Surfer's ``battery_status_0`` is its solar converter, ≤ 0.2 A in
flight 3, and ``battery_status_1`` its 4S pack). ``battery_instance`` chooses one
instead. The ``.ulg`` reader keeps instance 0 whenever it measures any current; the two
agree when instance 0 carries the most charge, as on logs of one pack.

Bad input
---------
:class:`~planner.errors.InputError` naming the folder or file and what was expected: no
CSV file of a known topic, files of several exports in one folder, no ``battery_status``
file (unless ``require_battery=False``), a battery instance that does not exist, a file
without a numeric ``timestamp`` column where the battery's is needed, and a topic whose
timestamps do not overlap the battery's at all (topics with different time bases: files
of two flights, or one converted to other units). A partial export gives what is valid,
with a :class:`~planner.io.logs.LogWarning` for what was left out: a file that ends
inside a row (its last row is dropped), an empty, unreadable or timestamp-less file of a
known topic (skipped).
"""

from __future__ import annotations

import io
import os
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from planner.errors import InputError
from planner.io.logs._common import (
    Message,
    Meta,
    build_record,
    resolve_channels,
    serial_or_none,
    start_time_unix,
)
from planner.io.logs.dataflash import MAV_TYPE_CLASS, mav_type_name
from planner.io.logs.ulog import FIELD_MAP, GPS_TIME_TOPICS, NAV_STATE_NAMES

__all__ = ["TOPICS", "battery_charge_as", "read_ulog2csv", "topic_files"]

#: Topics read from an export: those of the ``.ulg`` reader's FIELD_MAP and GPS time.
TOPICS = tuple(sorted({f.message for fs in FIELD_MAP.values() for f in fs}
                      | set(GPS_TIME_TOPICS), key=len, reverse=True))
#: PX4 ``vehicle_status.vehicle_type`` → vehicle class, for exports without
#: ``system_type`` (msg/VehicleStatus.msg: 1 rotary wing, 2 fixed wing, 3 rover).
VEHICLE_TYPE_CLASS = {1: "multirotor", 2: "fixed_wing", 3: "rover"}
_NAME = re.compile(r"^(?P<stem>.+)_(?P<instance>\d+)\.csv$", re.IGNORECASE)


@dataclass(frozen=True)
class TopicFile:
    """One CSV file of an export: ``<prefix>_<topic>_<instance>.csv``."""

    name: str           # as it appears (the member name inside a zip)
    prefix: str
    topic: str
    instance: int


def _match(name: str) -> TopicFile | None:
    base = name.replace("\\", "/").rsplit("/", 1)[-1]
    m = _NAME.match(base)
    if m is None:
        return None
    stem = m["stem"]
    for topic in TOPICS:                       # longest names first
        if stem.endswith("_" + topic) and len(stem) > len(topic) + 1:
            return TopicFile(name, stem[:-len(topic) - 1], topic, int(m["instance"]))
    return None


class _Source:
    """The CSV files of a folder or a zip: names and bytes (bounded)."""

    def __init__(self, path: Path):
        from planner.io import files

        self.path = path
        self.zip: zipfile.ZipFile | None = None
        if path.is_dir():
            try:
                self.names = sorted(p.name for p in path.iterdir()
                                    if p.name.lower().endswith(".csv") and p.is_file())
            except OSError as exc:
                raise InputError(f"{path}: cannot list the folder "
                                 f"({exc.strerror or exc})") from None
            return
        files.input_path(path, "log", "PX4 topic export (a folder or .zip of CSV files)")
        try:
            self.zip = zipfile.ZipFile(path)
            infos = [i for i in self.zip.infolist()
                     if not i.is_dir() and i.filename.lower().endswith(".csv")]
        except (zipfile.BadZipFile, OSError, ValueError) as exc:
            raise InputError(f"{path}: not a readable zip file ({exc})") from None
        self.infos = {i.filename: i for i in infos}
        self.names = sorted(self.infos)

    def read(self, name: str) -> bytes:
        from planner.io import files

        if self.zip is None:
            return files.read_bytes(self.path / name, "log", "topic CSV file")
        info = self.infos[name]
        if info.file_size > files.SIZE_LIMITS["log"]:
            raise InputError(f"{self.path}: member {name} is {info.file_size / 2**20:.0f} MB "
                             "uncompressed, larger than a log can be")
        try:
            return self.zip.read(info)
        except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
            raise _Unreadable(str(exc)) from None

    def where(self, name: str) -> str:
        return str(self.path / name) if self.zip is None else f"{self.path}:{name}"


class _Unreadable(Exception):
    pass


def _export_prefixes(names) -> list[str]:
    """Prefixes of the exports among ``names``: those left by a known topic that are not
    a longer spelling of another (``flight3_airspeed`` of ``flight3_airspeed_wind_0``)."""
    cands = {tf.prefix for tf in map(_match, names) if tf is not None}
    return sorted(p for p in cands if not any(p != q and p.startswith(q + "_") for q in cands))


def _with_prefix(names, prefix: str) -> list[TopicFile]:
    known = set(TOPICS)
    out = []
    for name in names:
        m = _NAME.match(name.replace("\\", "/").rsplit("/", 1)[-1])
        if m is None or not m["stem"].startswith(prefix + "_"):
            continue
        topic = m["stem"][len(prefix) + 1:]
        if topic in known:
            out.append(TopicFile(name, prefix, topic, int(m["instance"])))
    return out


def topic_files(path: str | os.PathLike) -> list[TopicFile]:
    """The files of known topics in a folder or zip, with prefix, topic and instance."""
    src = _Source(Path(path))
    return [tf for p in _export_prefixes(src.names) for tf in _with_prefix(src.names, p)]


def _read_csv(src: _Source, tf: TopicFile, meta: Meta) -> dict[str, np.ndarray] | None:
    """A topic file's columns (None, with a warning, when it cannot be used)."""
    where = src.where(tf.name)
    try:
        raw = src.read(tf.name)
    except _Unreadable as exc:
        meta.warn(f"{where}: unreadable ({exc}); topic {tf.topic} skipped")
        return None
    if not raw.strip():
        meta.warn(f"{where}: empty file; topic {tf.topic} skipped")
        return None
    cut = not raw.endswith(b"\n")
    try:
        df = pd.read_csv(io.BytesIO(raw), low_memory=False)
    except (pd.errors.ParserError, UnicodeDecodeError, ValueError) as exc:
        meta.warn(f"{where}: not a readable CSV file ({str(exc).splitlines()[0][:120]}); "
                  f"topic {tf.topic} skipped")
        return None
    if cut and len(df):
        df = df.iloc[:-1]
        meta.warn(f"{where}: the file ends inside a row (a partial export); its last row "
                  "was dropped")
    if "timestamp" not in df.columns:
        meta.warn(f"{where}: no 'timestamp' column (expected µs since boot first, as "
                  f"ulog2csv writes); topic {tf.topic} skipped")
        return None
    ts = pd.to_numeric(df["timestamp"], errors="coerce")
    if len(ts) and ts.isna().all():
        meta.warn(f"{where}: 'timestamp' is not a number; topic {tf.topic} skipped")
        return None
    if len(df) == 0:
        return None
    data = {str(c): df[c].to_numpy() for c in df.columns}
    data["timestamp"] = ts.to_numpy(float)
    return data


def battery_charge_as(data: dict[str, np.ndarray]) -> float:
    """Charge an instance of ``battery_status`` carried, ∫|I| dt over its own samples
    (``current_a``, else ``current_filtered_a``; −1 = not measured). [A s]"""
    t = np.asarray(data.get("timestamp", []), float) * 1e-6
    for name in ("current_a", "current_filtered_a"):
        if name not in data or np.asarray(data[name]).dtype.kind not in "biuf":
            continue
        c = np.asarray(data[name], float)
        ok = np.isfinite(c) & (c != -1.0) & np.isfinite(t)
        if ok.sum() >= 2:
            tt, cc = t[ok], np.abs(c[ok])
            return float(np.sum(0.5 * (cc[1:] + cc[:-1]) * np.clip(np.diff(tt), 0, None)))
        if ok.any():
            return 0.0
    return -1.0                 # no current measured at all


def _span(data) -> tuple[float, float] | None:
    t = np.asarray(data["timestamp"], float) * 1e-6
    t = t[np.isfinite(t)]
    return (float(t.min()), float(t.max())) if t.size else None


class _Export:
    """One log's topic export: its files by topic and instance, the topics read so far (each
    read once), and the files the record's channels came from."""

    def __init__(self, path: Path):
        self.path = path
        self.src = _Source(path)
        self.meta = Meta(str(path), "ulog2csv")
        prefixes = _export_prefixes(self.src.names)
        if not prefixes:
            what = (f"{len(self.src.names)} CSV file(s), none of a known topic"
                    if self.src.names else "no CSV files")
            raise InputError(f"{path}: {what}; expected a PX4 topic export "
                             "(<prefix>_<topic>_<instance>.csv files written by pyulog's "
                             "ulog2csv, with battery_status)")
        if len(prefixes) > 1:
            raise InputError(f"{path}: files of {len(prefixes)} exports "
                             f"({', '.join(prefixes[:4])}{' …' if len(prefixes) > 4 else ''}); "
                             "expected one log's topics (one prefix) per folder or zip")
        self.prefix = prefixes[0]
        self.meta["prefix"] = self.prefix
        self.meta["params"] = {}
        self.by_topic: dict[str, dict[int, TopicFile]] = {}
        for tf in _with_prefix(self.src.names, self.prefix):
            self.by_topic.setdefault(tf.topic, {})[tf.instance] = tf
        self.cache: dict[tuple[str, int], dict | None] = {}
        self.used_files: dict[str, str] = {}
        self.keep: int | None = None          # the battery_status instance kept

    def data_of(self, topic: str, instance: int) -> dict | None:
        """The columns of one topic file (``None``: unusable, warned)."""
        key = (topic, instance)
        if key not in self.cache:
            self.cache[key] = _read_csv(self.src, self.by_topic[topic][instance], self.meta)
        return self.cache[key]

    def get(self, topic: str) -> Message | None:
        """The topic as a message (the kept battery instance, else the first instance),
        noting its file."""
        insts = self.by_topic.get(topic)
        if not insts:
            return None
        inst = self.keep if topic == "battery_status" else min(insts)
        if inst is None:
            return None
        d = self.data_of(topic, inst)
        if d is None:
            return None
        self.used_files[topic] = self.src.where(insts[inst].name)
        return Message(topic, np.asarray(d["timestamp"], float) * 1e-6, d, instance=inst)

    def choose_battery(self, battery_instance: int | None, require_battery: bool) -> None:
        """Keep the chosen ``battery_status`` instance, else the one that carries the most
        charge; note the pack's serial number and cycle count."""
        path, meta, prefix = self.path, self.meta, self.prefix
        batteries = self.by_topic.get("battery_status", {})
        if battery_instance is not None and battery_instance not in batteries:
            have = (f"the export has instance(s) {', '.join(map(str, sorted(batteries)))}"
                    if batteries else "the export has no battery_status file")
            raise InputError(f"{path}: no battery_status instance {battery_instance} "
                             f"({prefix}_battery_status_{battery_instance}.csv); {have}")
        if batteries:
            charges = {i: battery_charge_as(d) for i in sorted(batteries)
                       if (d := self.data_of("battery_status", i)) is not None}
            if battery_instance is not None:
                if charges.get(battery_instance) is None and \
                        self.data_of("battery_status", battery_instance) is None:
                    raise InputError(f"{self.src.where(batteries[battery_instance].name)}: "
                                     "unusable (see the warning above); expected a "
                                     "battery_status export with a numeric timestamp column")
                self.keep = battery_instance
            elif charges:
                self.keep = max(charges, key=lambda i: (charges[i], -i))
            if len(batteries) > 1 and self.keep is not None:
                meta["battery_instances"] = sorted(batteries)
                meta["battery_instance"] = self.keep
                meta["battery_charge_mah"] = {i: (c / 3.6 if c >= 0 else None)
                                              for i, c in charges.items()}
                why = ("chosen" if battery_instance is not None
                       else "the one that carries the current")
                meta.warn(f"{path}: {len(batteries)} battery_status instances; kept instance "
                          f"{self.keep} ({why}), ignored "
                          f"{[i for i in sorted(batteries) if i != self.keep]}")
        if self.keep is None and require_battery:
            raise InputError(f"{path}: no usable battery_status file ({prefix}_battery_status_"
                             "<N>.csv); expected a PX4 topic export with the battery topic "
                             "(export can read the other channels without it)")
        if self.keep is not None:
            bat = self.data_of("battery_status", self.keep)
            meta["battery_serial"] = serial_or_none(bat.get("serial_number"))
            cycles = bat.get("cycle_count")
            if meta["battery_serial"] is not None and cycles is not None and len(cycles):
                meta["battery_cycle_count"] = int(np.nanmax(np.asarray(cycles, float)))

    def vehicle_class(self) -> str | None:
        """The vehicle class from ``vehicle_status`` (MAV_TYPE, else PX4's vehicle type)."""
        status = self.by_topic.get("vehicle_status", {})
        vclass = None
        if status:
            d = self.data_of("vehicle_status", min(status)) or {}

            def last(name):
                v = np.asarray(d.get(name, []))
                return int(v[-1]) if v.dtype.kind in "biuf" and v.size and \
                    np.isfinite(v[-1]) else None

            mav_type, px4_type = last("system_type"), last("vehicle_type")
            if mav_type is not None:
                self.meta["vehicle"] = mav_type_name(mav_type)
                vclass = MAV_TYPE_CLASS.get(mav_type)
            elif px4_type is not None:
                # PX4 msg/VehicleStatus.msg: VEHICLE_TYPE_ROTARY_WING = 1, _FIXED_WING = 2,
                # _ROVER = 3; is_vtol for a VTOL in either
                vclass = "vtol" if last("is_vtol") else VEHICLE_TYPE_CLASS.get(px4_type)
        self.meta["vehicle_type"] = vclass
        return vclass

    def check_time_bases(self, channels) -> None:
        """Every channel's topic overlaps the battery's time span (one clock)."""
        base_span = _span(self.data_of("battery_status", self.keep)) \
            if self.keep is not None else None
        if base_span is None:
            return
        for ch in channels.values():
            if ch.message == "battery_status":
                continue
            d = self.data_of(ch.message, min(self.by_topic[ch.message]))
            span = _span(d)
            if span is None or len(d["timestamp"]) < 2:
                continue
            if span[1] < base_span[0] or span[0] > base_span[1]:
                raise InputError(
                    f"{self.used_files[ch.message]}: timestamps {span[0]:.1f}–{span[1]:.1f} s "
                    f"do not overlap the battery's {base_span[0]:.1f}–{base_span[1]:.1f} s "
                    "(topics with different time bases); expected every topic in µs since "
                    "boot on the log's one clock, as ulog2csv writes")

    def gps_start_time(self) -> None:
        """The log's start in Unix time, from the first GPS topic with UTC time."""
        for topic in GPS_TIME_TOPICS:
            gps = self.get(topic)
            if gps is not None and "time_utc_usec" in gps.data:
                start = start_time_unix(self.meta.values["time_base_start_s"], gps.t,
                                        np.asarray(gps.data["time_utc_usec"], float) * 1e-6)
                if start is not None:
                    self.meta["start_time_unix"] = start
                    break


def _nav_state_names(raw: np.ndarray, f) -> np.ndarray:
    """PX4 ``nav_state`` numbers → flight-mode names."""
    return np.array([NAV_STATE_NAMES.get(int(v), f"NAV_STATE({int(v)})")
                     if np.isfinite(float(v)) else None for v in raw], dtype=object)


def read_ulog2csv(path: str | os.PathLike, *, require_battery: bool = True,
                  battery_instance: int | None = None) -> tuple[pd.DataFrame, dict]:
    """Read a PX4 topic export (a folder or ``.zip`` of ``ulog2csv`` files) into the
    flight record (module notes).

    Parameters
    ----------
    path : str or path
        The folder or zip.
    require_battery : bool, default True
        Raise :class:`InputError` when there is no battery voltage/current.
    battery_instance : int, optional
        The ``battery_status`` instance to keep (default: the one that carries the
        current).

    Returns
    -------
    (DataFrame, dict)
        The flight record (one row per sample of the kept battery instance) and the
        metadata (see :func:`planner.io.logs.read_log`), plus ``files`` (topic file of
        each channel's topic), ``prefix``, and with several batteries
        ``battery_instances``, ``battery_instance`` and ``battery_charge_mah``.
    """
    export = _Export(Path(path))
    export.choose_battery(battery_instance, require_battery)
    vclass = export.vehicle_class()
    channels = resolve_channels(FIELD_MAP, export.get, vehicle_type=vclass,
                                mode_names=_nav_state_names)
    if "throttle" in channels:
        channels["throttle"].values = np.clip(channels["throttle"].values, 0.0, 1.0)
    export.check_time_bases(channels)
    meta = export.meta
    meta["files"] = dict(sorted(export.used_files.items()))
    df = build_record(channels, meta, experiment=export.prefix, require_battery=require_battery)
    export.gps_start_time()
    return df, meta.values
