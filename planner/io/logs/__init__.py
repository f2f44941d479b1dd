"""Log readers: every supported log format → the flight record (``docs/record.md``).

:func:`read_log` picks the reader from the file's first bytes (the extension
only breaks ties) and returns ``(DataFrame, metadata)`` like pvlib's iotools:

========================  ==============================  ==========================
format                    reader                          recognised by
========================  ==============================  ==========================
ArduPilot DataFlash .bin  :func:`dataflash.read_dataflash` ``A3 95`` + FMT message
PX4 legacy sdlog2 .px4log :func:`dataflash.read_dataflash` same framing, TIME messages
MAVLink telemetry .tlog   :func:`tlog.read_tlog`           8-byte time + ``FE``/``FD``
PX4 ULog .ulg             :func:`ulog.read_ulog`           ``ULog\\x01\\x12\\x35``
CSV (+ column map)        :func:`csvmap.read_csv_log`      ``.csv``/``.csv.gz``
PX4 ulog2csv export       :func:`ulog2csv.read_ulog2csv`   a folder or ``.zip``
========================  ==============================  ==========================

Each reader has one module-level ``FIELD_MAP``: flight-record column ← message
field with scale and offset, alternatives in order of preference.

Time base (all binary formats)
------------------------------
The battery message stream (ArduPilot ``BAT``/``BATT``/``CURR``, sdlog2
``BATT``, ULog ``battery_status``, MAVLink ``BATTERY_STATUS``/``SYS_STATUS``)
is the time base: one record row per battery sample, ``time_s`` zero at the
first one. Every other channel is interpolated onto those times from its own
samples: linearly for continuous channels, previous-value (sample-and-hold,
held after the last change) for the flight mode. There is no extrapolation:
before a channel's first and after its last sample it is NaN, and a dropout
longer than max(2 s, 10 of its sample periods) is not bridged.
``consumed_mah`` is the logger's own counter minus its value at the first
sample (the counters run from boot), else the trapezoid integral of the
current. Battery samples whose time is missing or not increasing are dropped
with a warning.

Metadata keys (all readers): ``source``, ``format``, ``vehicle_type``
(``multirotor``/``fixed_wing``/``vtol``/...), ``vehicle``, ``firmware``,
``battery_capacity_mah`` (None when the parameter is unset, ≤ 0),
``battery_cells``, ``battery_serial`` (text: a smart battery's ULog
``battery_status.serial_number`` or ArduPilot's ``BATT_SERIAL_NUM``; None when 0 or
unset) and, with a ULog serial, ``battery_cycle_count``, ``rates_hz`` (native rate
of each column's source), ``time_base_start_s`` (the first record sample in the
reader's own clock), ``start_time_unix`` (its UTC, seconds since 1970: a tlog's receive
time, a DataFlash log's GPS week and milliseconds; None without a clock),
``channels`` (the message field behind each column), ``samples``,
``duration_s``, ``warnings`` (also issued as :class:`LogWarning`).
"""

from __future__ import annotations

import os

import pandas as pd

from planner.errors import InputError
from planner.io.logs._common import LogWarning

__all__ = ["FORMATS", "LogWarning", "detect_format", "read_log"]

ULOG_MAGIC = b"ULog\x01\x12\x35"

#: format name → (module, reader function name, extensions)
FORMATS = {
    "dataflash": ("planner.io.logs.dataflash", "read_dataflash", (".bin", ".px4log")),
    "tlog": ("planner.io.logs.tlog", "read_tlog", (".tlog",)),
    "ulog": ("planner.io.logs.ulog", "read_ulog", (".ulg",)),
    "csv": ("planner.io.logs.csvmap", "read_csv_log", (".csv", ".csv.gz", ".txt")),
    "ulog2csv": ("planner.io.logs.ulog2csv", "read_ulog2csv", (".zip",)),
}


def _looks_like_tlog(head: bytes) -> bool:
    # 8-byte big-endian µs timestamp, then a MAVLink v1 (0xFE) or v2 (0xFD) frame
    if len(head) < 10 or head[8] not in (0xFE, 0xFD):
        return False
    t_us = int.from_bytes(head[:8], "big")
    return 946684800e6 <= t_us <= 4102444800e6    # 2000 … 2100


def _looks_like_text(head: bytes) -> bool:
    if not head:
        return False
    text = head.decode("utf-8", errors="replace")
    odd = sum(1 for c in text if not (c.isprintable() or c in "\r\n\t"))
    return "," in text and odd <= len(text) // 100


def detect_format(path: str | os.PathLike, *, csv_ok: bool = False) -> str:
    """Name of the reader for ``path``: ``dataflash``, ``tlog``, ``ulog``, ``csv`` or
    ``ulog2csv`` (a folder or zip: PX4 topic CSV files).

    A text file is taken as CSV when its name ends in ``.csv``, ``.csv.gz`` or
    ``.txt``, or with ``csv_ok`` (a column map was given).

    Raises
    ------
    InputError
        Missing or empty file, or content that matches no supported format.
    """
    from planner.io import files

    if os.path.isdir(path) or str(path).lower().endswith(".zip"):
        return "ulog2csv"
    path = files.input_path(path, "log", "log file")
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096)
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if not head:
        raise InputError(f"{path}: empty file")
    name = path.name.lower()
    if head.startswith(ULOG_MAGIC):
        return "ulog"
    if head.startswith(b"PK\x03\x04"):
        return "ulog2csv"
    if head[:3] == b"\xa3\x95\x80" or (head[:2] == b"\xa3\x95" and b"\xa3\x95\x80" in head):
        return "dataflash"
    if _looks_like_tlog(head):
        return "tlog"
    if head.startswith(b"FMT,"):
        raise InputError(f"{path}: a text DataFlash log is not supported; read the .bin "
                         "(or convert it with pymavlink's mavlogdump.py)")
    if head[:2] == b"\x1f\x8b" and name.endswith(".csv.gz"):
        return "csv"
    for fmt, (_, _, exts) in FORMATS.items():
        if name.endswith(exts) and fmt != "csv":
            # right extension but no magic: let the reader say what is wrong
            if fmt == "dataflash" and b"\xa3\x95" in head:
                return fmt
            if fmt == "tlog" and (b"\xfe" in head or b"\xfd" in head):
                return fmt
            raise InputError(f"{path}: not a {fmt} log (the file does not start like one: "
                             f"first bytes {head[:8].hex(' ')})")
    if name.endswith((".csv", ".csv.gz", ".txt")) or (csv_ok and _looks_like_text(head)):
        return "csv"
    if _looks_like_text(head):
        raise InputError(f"{path}: a text file, not a recognised log; a CSV file needs a "
                         ".csv name (and a column map for columns other than the flight record's)")
    raise InputError(f"{path}: not a recognised log (ArduPilot .bin, PX4 .px4log/.ulg, "
                     f"MAVLink .tlog or CSV); first bytes {head[:8].hex(' ')}")


def read_log(path: str | os.PathLike, **opts) -> tuple[pd.DataFrame, dict]:
    """Read any supported log into the flight record.

    Parameters
    ----------
    path : str or path
        The log file.
    **opts
        ``require_battery`` (bool, default True): without battery voltage and
        current raise :class:`InputError`, or (False) read the other channels
        on the fastest stream's times. ``map`` (path, shipped map name or dict):
        the column map of a CSV file (see :mod:`planner.io.logs.csvmap`).
        ``battery_instance`` (int or None): the ``battery_status`` instance of a PX4
        topic export (see :mod:`planner.io.logs.ulog2csv`).

    Returns
    -------
    (DataFrame, dict)
        The flight record and its metadata (see the module docstring).

    Raises
    ------
    InputError
        The file is missing, empty, not a supported log, damaged beyond use,
        or has no battery data (with ``require_battery=True``).
    """
    import importlib

    allowed = {"require_battery", "map", "battery_instance"}
    unknown = set(opts) - allowed
    if unknown:
        raise TypeError(f"read_log() got unexpected option(s) {sorted(unknown)}; "
                        f"expected {sorted(allowed)}")
    fmt = detect_format(path, csv_ok=opts.get("map") is not None)
    if "map" in opts and fmt != "csv":
        if opts["map"] is not None:
            raise InputError(f"{path}: a column map applies to CSV files only "
                             f"(this is a {fmt} log)")
        opts.pop("map")
    if opts.get("battery_instance") is not None and fmt != "ulog2csv":
        raise InputError(f"{path}: a battery instance applies to a PX4 topic export (a "
                         f"folder or zip of ulog2csv files); this is a {fmt} log")
    if fmt != "ulog2csv":
        opts.pop("battery_instance", None)
    module, func, _ = FORMATS[fmt]
    reader = getattr(importlib.import_module(module), func)
    return reader(path, **opts)
