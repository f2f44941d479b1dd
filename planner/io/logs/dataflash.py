"""ArduPilot DataFlash ``.bin`` and PX4 legacy sdlog2 ``.px4log`` logs → flight record.

Both formats use the same framing: every message is ``0xA3 0x95 <type>``
followed by a fixed-length body described by an ``FMT`` message (type 0x80).
The types, sizes, scales and names of the fields follow pymavlink's
:class:`pymavlink.DFReader.DFFormat` and its format-character table
:data:`pymavlink.DFReader.FORMAT_TO_STRUCT` (``c``/``C``/``e``/``E`` are
centi-units, ``L`` is degrees·1e7, divided exactly as pymavlink divides), so
the numbers decoded here are bit-for-bit those of ``DFReader_binary``.

Fast path
---------
1. The whole file is read once into a numpy byte array.
2. Every ``0xA3 0x95`` pair is found with vectorised compares (in chunks, to
   bound the temporaries); the ``FMT`` messages among them are decoded and
   validated (name, format characters, length = struct size + 3).
3. The message chain is built with numpy: each candidate's successor is the
   candidate at ``offset + length`` (its ``FMT`` length); where that is not a
   header (damaged bytes) the reader *resyncs* at the next header whose own
   successor is again a header. Only the few breaks of the chain are walked
   in Python. Skipped bytes and a truncated last message are reported as a
   warning (and in ``meta["warnings"]``).
4. Only the needed message types are decoded, each with one numpy structured
   dtype over its gathered rows (``np.frombuffer``-style view).

Time base
---------
Times come from each message's ``TimeUS`` (µs) or ``TimeMS`` (ms) since boot;
old GPS messages carry GPS time-of-week in ``TimeMS`` and boot time in ``T``;
messages without a time field (old ``MODE``, ``PARM``) take the time of the
last timed message before them, as pymavlink does. In sdlog2 logs every
message takes ``TIME.StartTime`` of the logging cycle it belongs to (the last
``TIME`` before it). The battery message stream (``BAT``/``BATT``/``CURR``)
is the time base of the record; every other channel is interpolated onto it,
linearly for continuous channels and previous-value for the flight mode, with
no extrapolation beyond a channel's own span (NaN there) and no bridging of
dropouts longer than max(2 s, 10 sample periods).
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np
import pandas as pd
from pymavlink import mavutil
from pymavlink.DFReader import FORMAT_TO_STRUCT

from planner.errors import InputError
from planner.io.logs._common import GPS_EPOCH_UNIX, GPS_LEAP_S, Field, Message, Meta, battery_meta
from planner.io.logs._common import build_record, resolve_channels, start_time_unix

__all__ = ["FIELD_MAP", "DataFlashLog", "MessageFormat", "read_dataflash"]

HEAD1, HEAD2 = 0xA3, 0x95
FMT_TYPE = 0x80
FMT_LEN = 89  # 3 header + B B 4s 16s 64s

# struct code (from pymavlink's FORMAT_TO_STRUCT) -> numpy dtype
_STRUCT_TO_NUMPY = {
    "b": "i1", "B": "u1", "h": "<i2", "H": "<u2", "i": "<i4", "I": "<u4",
    "q": "<i8", "Q": "<u8", "f": "<f4", "d": "<f8", "e": "<f2",
    "4s": "S4", "16s": "S16", "64s": "S64",
}
_INT_CHARS = frozenset(c for c, (s, mul, typ) in FORMAT_TO_STRUCT.items()
                       if mul is None and typ is int or c in "qQ")

# --------------------------------------------------------------------------- FIELD_MAP
_PLANE = ("fixed_wing", "vtol")   # ArduPlane, QuadPlanes included
#: flight-record column ← message.field · scale + offset; first source with data wins.
#: ArduPilot (BAT/BATT/CURR, GPS, BARO, ARSP, CTUN, RCOU, EKF2/NKF2/XKF2, MODE) and
#: PX4 sdlog2 (BATT V/C, SENS, LPOS, GPS, AIRS, ATSP, STAT) in one table: where the
#: two share a message name (BATT, GPS, ARSP) the field names differ. sdlog2 ARSP is
#: a rate setpoint, not airspeed, so it is not listed (sdlog2 airspeed is AIRS).
FIELD_MAP: dict[str, tuple[Field, ...]] = {
    "voltage_v": (
        Field("BAT", "Volt"),                       # ArduPilot ≥ 3.6, V
        Field("BATT", "Volt"),
        Field("CURR", "Volt", int_scale=0.01),      # AC ≤ 3.3: int16 cV; later float V
        Field("BATT", "V"),                         # sdlog2, V
    ),
    "current_a": (
        Field("BAT", "Curr"),
        Field("BATT", "Curr"),
        Field("CURR", "Curr", int_scale=0.01),      # int16 cA in AC ≤ 3.3
        Field("BATT", "C"),                         # sdlog2, A
    ),
    "consumed_mah": (                               # counts from boot: record keeps Δ
        Field("BAT", "CurrTot"),
        Field("BATT", "CurrTot"),
        Field("CURR", "CurrTot"),
        Field("BATT", "Discharged"),                # sdlog2, mAh
    ),
    "temperature_c": (
        Field("BAT", "Temp"),                       # 'c' → °C; 0 = no sensor
        Field("BATT", "Temp"),
    ),
    "pressure_pa": (
        Field("BARO", "Press"),                     # Pa
        Field("SENS", "BaroPres", scale=100.0),     # sdlog2, mbar
    ),
    "ambient_temperature_c": (
        Field("BARO", "Temp"),                      # baro (board) temperature
        Field("SENS", "BaroTemp"),
    ),
    "altitude_m": (
        Field("BARO", "Alt"),                       # above the ground calibration (home)
        Field("CTUN", "BarAlt"),
        Field("GPS", "RelAlt", valid=("Status", 3)),
        Field("LPOS", "Z", scale=-1.0),             # sdlog2, NED down → up, above origin
        Field("GPS", "Alt", relative=True, valid=("Status", 3)),  # AMSL → above start
        Field("GPOS", "Alt", relative=True),
    ),
    "climb_rate_ms": (
        Field("GPS", "VZ", scale=-1.0, valid=("Status", 3)),  # ArduPilot GPS VZ is down +
        Field("BARO", "CRt"),
        Field("CTUN", "CRt", int_scale=0.01),       # int16 cm/s in AC ≤ 3.x
        Field("LPOS", "VZ", scale=-1.0),            # sdlog2 NED
        Field("GPS", "VelD", scale=-1.0, valid=("Fix", 3)),
    ),
    "groundspeed_ms": (
        Field("GPS", "Spd", valid=("Status", 3)),
        Field("GPS", ("VelN", "VelE"), op="hypot", valid=("Fix", 3)),  # sdlog2
        Field("LPOS", ("VX", "VY"), op="hypot"),
    ),
    "course_deg": (
        Field("GPS", "GCrs", valid=("Status", 3)),
        Field("GPS", ("VelN", "VelE"), op="course", valid=("Fix", 3)),  # m/s
    ),
    "airspeed_ms": (
        Field("ARSP", "Airspeed"),                  # ArduPilot airspeed sensor
        Field("CTUN", "Aspd", vehicle=_PLANE),
        Field("CTUN", "As", vehicle=_PLANE),
        Field("AIRS", "TrueSpeed"),                 # sdlog2 (ARSP there is a rate setpoint)
    ),
    "wind_n_ms": (
        Field("XKF2", "VWN"), Field("NKF2", "VWN"), Field("EKF2", "VWN"),
    ),
    "wind_e_ms": (
        Field("XKF2", "VWE"), Field("NKF2", "VWE"), Field("EKF2", "VWE"),
    ),
    "throttle": (
        Field("CTUN", "ThO", vehicle="multirotor"),                 # float 0..1
        Field("CTUN", "ThrOut", int_scale=0.001, vehicle="multirotor"),  # int 0..1000
        Field("CTUN", "ThO", scale=0.01, vehicle=_PLANE),     # percent
        Field("CTUN", "ThrOut", scale=0.01, vehicle=_PLANE),
        Field("ATSP", "ThrustSP"),                                  # sdlog2 0..1
        Field("RCOU", "C3", scale=0.001, offset=-1.0, vehicle=_PLANE),  # PWM µs
        Field("RCOU", "Chan3", scale=0.001, offset=-1.0, vehicle=_PLANE),
    ),
    "mode": (
        Field("MODE", "ModeNum"), Field("MODE", "Mode"),
        Field("STAT", "MainState"),                 # sdlog2
    ),
}

#: instance/core fields per message: keep the lowest instance (0), note the others.
#: (sdlog2 BATT.C is a current, so the field names are listed per message.)
_INSTANCED = {"BAT": ("Instance", "Inst", "I"), "BATT": ("Instance", "Inst"),
              "CURR": ("Instance", "Inst"), "GPS": ("I", "Instance"),
              "BARO": ("I", "Instance"), "ARSP": ("I", "Instance"), "XKF2": ("C", "Core")}

#: message names whose ``TimeMS`` is not the boot clock
_GPS_NAMES = ("GPS", "GPS2")


#: fields each message contributes to the record (decode only these)
_NEEDED: dict[str, set] = {}
for _sources in FIELD_MAP.values():
    for _f in _sources:
        _NEEDED.setdefault(_f.message, set()).update(_f.fields)
        if _f.valid:
            _NEEDED[_f.message].add(_f.valid[0])


@dataclass
class MessageFormat:
    """One FMT definition (pymavlink ``DFFormat`` semantics) plus its numpy dtype."""

    type: int
    name: str
    length: int
    format: str
    columns: list[str]
    dtype: np.dtype | None      # None when the definition cannot be decoded

    @classmethod
    def from_fmt(cls, mtype: int, name: str, length: int, fmt: str, columns: str):
        """The format of an FMT message; ``dtype`` None when the format characters do not
        add up to the message length (its messages are then skipped)."""
        cols = [c for c in columns.split(",")] if columns else []
        try:
            codes = [FORMAT_TO_STRUCT[c][0] for c in fmt]
        except KeyError:
            return cls(mtype, name, length, fmt, cols, None)
        size = struct.calcsize("<" + "".join(codes))
        if size + 3 != length or len(cols) < len(fmt):
            return cls(mtype, name, length, fmt, cols, None)
        names, seen = [], set()
        for i, c in enumerate(cols[:len(fmt)]):
            n = c if c and c not in seen else f"_{i}_{c}"
            seen.add(n)
            names.append(n)
        dtype = np.dtype({"names": names,
                          "formats": [_STRUCT_TO_NUMPY[s] for s in codes],
                          "itemsize": size})
        return cls(mtype, name, length, fmt, cols[:len(fmt)], dtype)

    def char(self, column: str) -> str:
        """The format character of a column (``f``, ``I``, ``c`` …)."""
        return self.format[self.columns.index(column)]


def _decode_text(b: bytes) -> str:
    """pymavlink's ``DFMessage.__getattr__`` + ``null_term`` for a string field."""
    try:
        s = b.decode("utf-8")
    except UnicodeDecodeError:
        s = b.decode("ISO-8859-1")
    i = s.find("\0")
    return s if i < 0 else s[:i]


def _mult_divisor(char: str):
    """``(divide, factor)`` exactly as pymavlink applies the format multiplier."""
    mul = FORMAT_TO_STRUCT[char][1]
    if mul is None:
        return None
    if 0.0 < mul < 1.0:
        return ("div", 1 / mul)
    return ("mul", mul)


class DataFlashLog:
    """Index of one DataFlash/sdlog2 file; decodes message types on demand.

    Parameters
    ----------
    path : str or path
        The log file.
    data : bytes, optional
        The file contents, when already in memory.

    Attributes
    ----------
    formats : dict[int, MessageFormat]
    offsets : ndarray of int32 (int64 for files over 2 GB)
        File offsets of every message of the chain, in file order.
    types : ndarray of uint8
        Message type of each entry of ``offsets``.
    problems : list of str
        What was skipped (damaged bytes, truncated message, bad FMT): warnings.
    notes : list of str
        Harmless quirks of the file (e.g. a redefined FMT type).
    """

    CHUNK = 1 << 18

    def __init__(self, path: str | os.PathLike, data: bytes | None = None):
        self.path = Path(path)
        if data is None:
            try:
                with open(self.path, "rb") as fh:
                    data = fh.read()
            except FileNotFoundError:
                raise InputError(f"{self.path}: file not found") from None
            except IsADirectoryError:
                raise InputError(f"{self.path}: is a directory, expected a log file") from None
            except OSError as exc:
                raise InputError(f"{self.path}: cannot read ({exc.strerror or exc})") from None
        self.buf = np.frombuffer(data, dtype=np.uint8)
        self.size = len(self.buf)
        self.problems: list[str] = []
        self.notes: list[str] = []
        if self.size == 0:
            raise InputError(f"{self.path}: empty file")
        self._index()

    # ---------------------------------------------------------------- scanning
    def _headers(self) -> np.ndarray:
        """Offsets of every 0xA3 0x95 pair with a type byte after it (int32/int64)."""
        buf, n = self.buf, self.size
        found = []
        for start in range(0, max(n - 2, 0), self.CHUNK):
            stop = min(start + self.CHUNK, n - 2)
            hit = np.flatnonzero((buf[start:stop] == HEAD1) & (buf[start + 1:stop + 1] == HEAD2))
            if len(hit):
                found.append((hit + start).astype(self._itype))
        if not found:
            return np.zeros(0, self._itype)
        return np.concatenate(found)

    def _read_fmts(self, cand: np.ndarray) -> None:
        """Decode and validate every FMT candidate; the last valid definition wins."""
        self.formats: dict[int, MessageFormat] = {}
        fmt_pos = cand[self.buf[cand + 2] == FMT_TYPE]
        fmt_pos = fmt_pos[fmt_pos.astype(np.int64) + FMT_LEN <= self.size]
        if not len(fmt_pos):
            return
        rows = self._rows(fmt_pos + 3, FMT_LEN - 3)
        dt = np.dtype([("type", "u1"), ("length", "u1"), ("name", "S4"),
                       ("format", "S16"), ("columns", "S64")])
        recs = rows.view(dt)[:, 0]
        conflicts: list[str] = []
        bad_len: set[str] = set()
        fmt_chars = set(FORMAT_TO_STRUCT)
        for rec in recs.tolist():
            mtype, length, name, fmt, columns = rec
            try:
                name = name.decode("ascii")
                fmt = fmt.decode("ascii")
                columns = columns.decode("ascii")
            except UnicodeDecodeError:
                continue
            if (not name or not (name[0].isalpha() and name.isalnum()) or length < 3
                    or not set(fmt) <= fmt_chars
                    or not all(c.isalnum() or c in ",_[]." for c in columns)):
                continue                     # not a real FMT (bytes inside a payload)
            mf = MessageFormat.from_fmt(mtype, name, length, fmt, columns)
            old = self.formats.get(mtype)
            if old is not None and (old.name, old.length, old.format) != (
                    mf.name, mf.length, mf.format):
                conflicts.append(f"{old.name}->{mf.name}")
            if mf.dtype is None and mtype != FMT_TYPE:
                bad_len.add(name)
            self.formats[mtype] = mf        # the last definition wins, as in pymavlink
        if conflicts:
            self.notes.append(f"FMT type(s) redefined ({', '.join(conflicts)}); "
                              "the last definition is used, as pymavlink does")
        for name in sorted(bad_len):
            self.problems.append(f"FMT for {name} does not match its length; "
                                 "its messages are skipped")

    def _index(self) -> None:
        """Build the message chain: ``self.offsets`` and ``self.types`` (see the module doc)."""
        it = self._itype = np.int32 if self.size < 2**31 - 1024 else np.int64
        pos, typ, nxt = self._messages()
        chain = self._chain(pos, nxt, it)
        # a message running past the end of the file is truncated
        ends = nxt[chain]
        complete = ends <= self.size
        if not complete.all():
            first_bad = int(chain[~complete][0])
            self.problems.append(f"last message ({self._type_name(int(typ[first_bad]))}) is "
                                 f"truncated: skipped {self.size - int(pos[first_bad])} "
                                 "byte(s) at the end")
            chain, ends = chain[complete], ends[complete]
        self.offsets = pos[chain]
        self.types = typ[chain]
        del pos, typ, nxt, chain
        if not len(self.offsets):
            raise InputError(f"{self.path}: no complete DataFlash message found")
        self._count_skipped(ends, complete.all())
        self.counts = np.bincount(self.types, minlength=256)
        self.name_to_type = {f.name: t for t, f in self.formats.items()}
        self._cache: dict = {}

    def _messages(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(offset, type, end) of every header of a type with a format: the candidates
        for the chain."""
        cand = self._headers()
        self._read_fmts(cand)
        if not self.formats:
            raise InputError(f"{self.path}: not a DataFlash/sdlog2 log (no FMT messages found)")
        lengths = np.zeros(256, self._itype)
        for t, f in self.formats.items():
            lengths[t] = f.length
        if FMT_TYPE not in self.formats:
            lengths[FMT_TYPE] = FMT_LEN
        typ = self.buf[cand + 2]
        known = lengths[typ] > 0
        pos, typ = cand[known], typ[known]
        if len(pos) == 0:
            raise InputError(f"{self.path}: no DataFlash message found")
        return pos, typ, pos + lengths[typ]

    def _chain(self, pos: np.ndarray, nxt: np.ndarray, it) -> np.ndarray:
        """Indices into ``pos`` of the message chain: each message followed by the header
        at its end; after damage, the next header that is itself followed by a header."""
        m, n = len(pos), self.size
        # successor: first header at/after the end of each message
        succ = np.searchsorted(pos, nxt).astype(it)
        inb = succ < m
        hit = np.zeros(m, bool)
        hit[inb] = pos[succ[inb]] == nxt[inb]
        del inb
        good = np.flatnonzero(hit | (nxt == n)).astype(it)   # chain-confirmed headers
        # resync after damage: the next header that is itself followed by a header
        bad = np.flatnonzero(~hit)
        del hit
        if len(bad) and len(good):
            j = np.searchsorted(good, succ[bad])
            succ[bad] = np.where(j < len(good), good[np.minimum(j, len(good) - 1)], m)
        elif len(bad):
            succ[bad] = m                   # no header is chain-confirmed: no resync point
        del bad
        # walk the chain; runs where succ == k + 1 are taken whole
        breaks = np.flatnonzero(succ != np.arange(1, m + 1, dtype=it))
        segs, k = [], int(good[0]) if len(good) else 0
        del good
        for _ in range(m + 1):                       # bounded: succ[k] > k
            if k >= m:
                break
            j = int(np.searchsorted(breaks, k))
            if j == len(breaks):
                segs.append((k, m - 1))
                break
            b = int(breaks[j])
            segs.append((k, b))
            k = int(succ[b])
        return (np.concatenate([np.arange(a, b + 1, dtype=it) for a, b in segs])
                if segs else np.zeros(0, it))

    def _count_skipped(self, ends: np.ndarray, complete: bool) -> None:
        """``skipped_bytes``: the bytes outside the chain (before the first message,
        between messages, after the last unless it is erased flash), with a warning."""
        gaps = []
        if self.offsets[0] > 0:
            gaps.append((0, int(self.offsets[0])))
        inner = np.flatnonzero(self.offsets[1:] != ends[:-1])
        gaps += [(int(ends[i]), int(self.offsets[i + 1] - ends[i])) for i in inner]
        tail = self.size - int(ends[-1])
        if tail > 0 and complete:
            tail_bytes = self.buf[int(ends[-1]):]
            if not (np.all(tail_bytes == 0) or np.all(tail_bytes == 0xFF)):
                gaps.append((int(ends[-1]), tail))
        if gaps:
            total = sum(g[1] for g in gaps)
            self.problems.append(f"skipped {total} byte(s) of damaged data in {len(gaps)} "
                                 f"place(s) (first at byte offset {gaps[0][0]})")
        self.skipped_bytes = sum(g[1] for g in gaps)

    def _rows(self, starts: np.ndarray, size: int) -> np.ndarray:
        """Copy of ``size`` bytes at each offset, as one contiguous (n, size) array."""
        if size <= 0 or not len(starts):
            return np.zeros((len(starts), max(size, 0)), np.uint8)
        windows = np.lib.stride_tricks.sliding_window_view(self.buf, size)
        return np.ascontiguousarray(windows[starts])

    def _type_name(self, t: int) -> str:
        f = self.formats.get(t)
        return f.name if f else str(t)

    # ---------------------------------------------------------------- decoding
    def count(self, name: str) -> int:
        """Messages of type ``name`` in the chain."""
        t = self.name_to_type.get(name)
        return int(self.counts[t]) if t is not None else 0

    def message_counts(self) -> dict[str, int]:
        """Messages in the chain per type name."""
        return {self.formats[t].name: int(c) for t, c in enumerate(self.counts)
                if c and t in self.formats}

    def records(self, name: str) -> tuple[np.ndarray, np.ndarray] | None:
        """Raw structured records of one message type and their chain indices."""
        t = self.name_to_type.get(name)
        if t is None or not self.counts[t]:
            return None
        fmt = self.formats[t]
        if fmt.dtype is None:
            return None
        idx = np.flatnonzero(self.types == t).astype(self._itype)
        pos = self.offsets[idx]
        size = fmt.dtype.itemsize
        return self._rows(pos + 3, size).view(fmt.dtype)[:, 0], idx

    def decode(self, name: str, fields=None) -> dict[str, np.ndarray] | None:
        """Fields of one message type, with pymavlink's types and scaling.

        Parameters
        ----------
        name : str
            Message name (``CURR``, ``GPS``, ...).
        fields : iterable of str, optional
            Only these fields (those the message has); default all.

        Returns
        -------
        dict or None
            Field name → array: integer fields int64 (uint64 for ``Q``), float
            and scaled fields float64 (the exact value pymavlink returns),
            strings ``object`` arrays of ``str``, ``a`` (int16[32]) fields int16
            arrays of shape (n, 32); plus ``_chain``, the chain index of each
            message. ``None`` when the log has no such message.
        """
        key = (name, None if fields is None else tuple(sorted(set(fields))))
        if key in self._cache:
            return self._cache[key]
        got = self.records(name)
        if got is None:
            self._cache[key] = None
            return None
        rec, idx = got
        fmt = self.formats[self.name_to_type[name]]
        want = None if fields is None else set(fields)
        out: dict[str, np.ndarray] = {}
        for col, char, dname in zip(fmt.columns, fmt.format, rec.dtype.names):
            if want is not None and col not in want:
                continue
            raw = rec[dname]
            if char in "nNZ":
                out[col] = np.array([_decode_text(b) for b in raw.tolist()], dtype=object)
                continue
            if char == "a":
                out[col] = np.frombuffer(np.ascontiguousarray(raw).tobytes(),
                                         dtype="<i2").reshape(len(raw), 32)
                continue
            mult = _mult_divisor(char)
            if mult is not None:
                v = raw.astype(np.float64)
                out[col] = v / mult[1] if mult[0] == "div" else v * mult[1]
            elif raw.dtype.kind == "f":
                out[col] = raw.astype(np.float64)
            elif raw.dtype.kind == "u" and raw.dtype.itemsize == 8:
                out[col] = raw.astype(np.uint64)
            else:
                out[col] = raw.astype(np.int64)
        out["_chain"] = idx
        self._cache[key] = out
        return out

    def integer_fields(self, name: str) -> frozenset:
        """The fields of message ``name`` stored as integers."""
        fmt = self.formats[self.name_to_type[name]]
        return frozenset(c for c, ch in zip(fmt.columns, fmt.format) if ch in _INT_CHARS)

    @cached_property
    def is_px4(self) -> bool:
        """sdlog2 (PX4 legacy) rather than ArduPilot: TIME.StartTime clocks the log."""
        t = self.name_to_type.get("TIME")
        if t is None or "StartTime" not in self.formats[t].columns:
            return False
        return not any(f.columns and f.columns[0] in ("TimeUS", "TimeMS")
                       for f in self.formats.values())

    def _time_field(self, fmt: MessageFormat) -> tuple[str, float] | None:
        """The field that clocks messages of this type (pymavlink's clock rules)."""
        tf = self._time_field_rule(fmt)
        if tf is None or fmt.char(tf[0]) not in _INT_CHARS:
            return None          # a time must be an integer count (damaged FMT otherwise)
        return tf

    def _time_field_rule(self, fmt: MessageFormat) -> tuple[str, float] | None:
        if fmt.dtype is None or not fmt.columns:
            return None
        if self.is_px4:
            return ("StartTime", 1e-6) if fmt.name == "TIME" and "StartTime" in fmt.columns \
                else None
        if fmt.columns[0] == "TimeUS":
            return "TimeUS", 1e-6
        if fmt.name in _GPS_NAMES:
            return ("T", 1e-3) if "T" in fmt.columns else None   # TimeMS is GPS time here
        if fmt.columns[0] == "TimeMS" and not fmt.name.startswith(("ACC", "GYR")):
            return "TimeMS", 1e-3
        return None

    def _field_at(self, chain_idx: np.ndarray, fmt: MessageFormat, col: str) -> np.ndarray:
        """One numeric field of the messages at ``chain_idx`` (all of type ``fmt``)."""
        name = fmt.dtype.names[fmt.columns.index(col)]
        ftype, off = fmt.dtype.fields[name][:2]
        raw = self._rows(self.offsets[chain_idx] + (3 + off), ftype.itemsize)
        return raw.view(ftype)[:, 0]

    def times(self, chain_idx: np.ndarray) -> np.ndarray:
        """Time [s since boot] of the messages at ``chain_idx`` (sorted chain indices).

        A message with its own time field uses it; any other takes the time of
        the last timed message before it in the file (pymavlink does the same;
        in sdlog2 logs that is the ``TIME`` message of its logging cycle).
        """
        chain_idx = np.asarray(chain_idx)
        out = np.full(len(chain_idx), np.nan)
        if not len(chain_idx):
            return out
        timed = np.zeros(256, bool)
        clock = {}
        for t, fmt in self.formats.items():
            tf = self._time_field(fmt)
            if tf is not None and self.counts[t]:
                timed[t] = True
                clock[t] = (fmt, tf)
        types = self.types[chain_idx]
        own = timed[types]
        src = chain_idx.copy()
        if not own.all():
            # nearest earlier timed message: search backwards among timed ones
            timed_idx = np.flatnonzero(timed[self.types]).astype(self._itype)
            j = np.searchsorted(timed_idx, chain_idx[~own], side="right") - 1
            src_other = (np.where(j >= 0, timed_idx[np.maximum(j, 0)], -1) if len(timed_idx)
                         else np.full(len(j), -1))
            del timed_idx
            src[~own] = src_other
        ok = src >= 0
        src_types = np.where(ok, self.types[np.maximum(src, 0)], -1)
        for t, (fmt, (col, scale)) in clock.items():
            sel = np.flatnonzero(ok & (src_types == t))
            if len(sel):
                out[sel] = self._field_at(src[sel], fmt, col).astype(np.float64) * scale
        return out

    def message(self, name: str, fields=None) -> Message | None:
        """One message type as a :class:`Message` (lowest instance only).

        ``fields``: decode only these (plus the instance field); default all.
        """
        if fields is not None:
            fields = set(fields) | set(_INSTANCED.get(name, ()))
        data = self.decode(name, fields)
        if data is None:
            return None
        t = self.times(data["_chain"])
        inst_field = next((f for f in _INSTANCED.get(name, ()) if f in data), None)
        instance = None
        if inst_field is not None:
            vals = data[inst_field]
            inst = np.unique(vals)
            if len(inst) > 1:
                instance = inst.min()
                sel = vals == instance
                data = {k: v[sel] for k, v in data.items()}
                t = t[sel]
        return Message(name, t, data, self.integer_fields(name), instance)

    def instances(self, name: str) -> list:
        """Instance numbers logged for ``name`` (empty when not instanced)."""
        data = self.decode(name, _INSTANCED.get(name, ()))
        if data is None:
            return []
        f = next((f for f in _INSTANCED.get(name, ()) if f in data), None)
        return [] if f is None else sorted(np.unique(data[f]).tolist())

    def params(self) -> dict[str, float]:
        """The log's parameters (``PARM`` messages), name → value; the last value wins."""
        data = self.decode("PARM", ("Name", "Value"))
        if data is None or "Name" not in data or "Value" not in data:
            return {}
        return dict(zip(data["Name"].tolist(), data["Value"].tolist()))

    def texts(self, name: str, field: str) -> list[str]:
        """The text field ``field`` of every message ``name`` (``MSG.Message``)."""
        data = self.decode(name, (field,))
        if data is None or field not in data:
            return []
        return [str(s) for s in data[field].tolist()]


# --------------------------------------------------------------------------- metadata

_AP_TYPES = (  # (text in the firmware banner, MAV_TYPE, vehicle_type)
    ("Rover", mavutil.mavlink.MAV_TYPE_GROUND_ROVER, "rover"),
    ("Plane", mavutil.mavlink.MAV_TYPE_FIXED_WING, "fixed_wing"),
    ("Copter", mavutil.mavlink.MAV_TYPE_QUADROTOR, "multirotor"),
    ("Heli", mavutil.mavlink.MAV_TYPE_HELICOPTER, "helicopter"),
    ("Sub", mavutil.mavlink.MAV_TYPE_SUBMARINE, "submarine"),
    ("Blimp", mavutil.mavlink.MAV_TYPE_AIRSHIP, "airship"),
)
_VER_BUILD = {1: "rover", 2: "multirotor", 3: "fixed_wing", 7: "submarine",
              13: "helicopter", 12: "airship"}

#: MAV_TYPE (PX4 parameter / HEARTBEAT.type) → vehicle_type of the aircraft YAML
MAV_TYPE_CLASS = {1: "fixed_wing", 2: "multirotor", 3: "multirotor", 4: "helicopter",
                  10: "rover", 13: "multirotor", 14: "multirotor", 15: "multirotor",
                  16: "fixed_wing", 19: "vtol", 20: "vtol", 21: "vtol", 22: "vtol",
                  23: "vtol", 24: "vtol", 25: "vtol", 29: "multirotor"}


def mav_type_name(mav_type) -> str | None:
    """The name of a MAV_TYPE number (``quadrotor``), as pymavlink's enum has it; None
    for an unknown number."""
    try:
        entry = mavutil.mavlink.enums["MAV_TYPE"][int(mav_type)]
    except (KeyError, TypeError, ValueError):
        return None
    return entry.name.removeprefix("MAV_TYPE_").lower()


def vehicle_meta(meta: Meta, mav_type) -> str | None:
    """``vehicle`` and ``vehicle_type`` of ``meta`` from a MAV_TYPE (a PX4 parameter, a
    HEARTBEAT's type; None: unknown); returns the vehicle type."""
    vclass = MAV_TYPE_CLASS.get(int(mav_type)) if mav_type is not None else None
    meta["vehicle"] = mav_type_name(mav_type)
    meta["vehicle_type"] = vclass
    return vclass


def _ardupilot_identity(log: DataFlashLog, params: dict) -> tuple:
    """(firmware banner, MAV_TYPE, vehicle_type) as pymavlink's DFReader infers it."""
    firmware, mav_type, vclass = None, mavutil.mavlink.MAV_TYPE_FIXED_WING, None
    for text in log.texts("MSG", "Message"):
        for key, mt, vc in _AP_TYPES:
            if key in text and (text.startswith(("Ardu", "APM:")) or "Ardu" in text):
                firmware, mav_type, vclass = text, mt, vc
                break
        if firmware:
            break
    ver = log.decode("VER")
    if ver is not None and "BU" in ver and len(ver["BU"]):
        vclass = _VER_BUILD.get(int(ver["BU"][0]), vclass)
        if firmware is None and "FWS" in ver:
            firmware = str(ver["FWS"][0])
        for key, mt, vc in _AP_TYPES:
            if vc == vclass:
                mav_type = mt
    if vclass == "fixed_wing" and any(k.startswith("Q_ENABLE") and v > 0
                                      for k, v in params.items()):
        vclass = "vtol"
    return firmware, mav_type, vclass


def read_dataflash(path: str | os.PathLike, *, require_battery: bool = True,
                   data: bytes | None = None) -> tuple[pd.DataFrame, dict]:
    """Read an ArduPilot ``.bin`` or PX4 sdlog2 ``.px4log`` into the flight record.

    Parameters
    ----------
    path : str or path
        The log.
    require_battery : bool, default True
        Raise :class:`InputError` when the log has no battery voltage/current.
    data : bytes, optional
        File contents already in memory.

    Returns
    -------
    (DataFrame, dict)
        The flight record (docs/record.md, one row per battery message) and the
        metadata: ``source``, ``format`` (``dataflash`` | ``px4log``),
        ``vehicle_type``, ``vehicle``, ``firmware``, ``battery_capacity_mah``,
        ``battery_cells``, ``rates_hz``, ``channels`` (source of each column),
        ``message_counts``, ``params``, ``warnings`` and more.

    Raises
    ------
    InputError
        Empty file, not a DataFrame log, no battery data (unless
        ``require_battery=False``).
    """
    path = Path(path)
    log = DataFlashLog(path, data)
    px4 = log.is_px4
    meta = Meta(str(path), "px4log" if px4 else "dataflash")
    for p in log.problems:
        meta.warn(f"{path}: {p}")
    meta["notes"] = list(log.notes)
    params = log.params()
    meta["params"] = params
    meta["message_counts"] = log.message_counts()
    if px4:
        ver = log.decode("VER")
        if ver is not None and len(ver.get("FwGit", [])):
            meta["firmware"] = f"PX4 {ver['FwGit'][0]}" + (
                f" ({ver['Arch'][0]})" if "Arch" in ver else "")
        vclass = vehicle_meta(meta, params.get("MAV_TYPE"))
        battery_meta(meta, params, capacity=("BAT_CAPACITY", "BAT1_CAPACITY"),
                     cells=("BAT_N_CELLS", "BAT1_N_CELLS"))
        ap_mav_type = None
    else:
        firmware, ap_mav_type, vclass = _ardupilot_identity(log, params)
        meta["firmware"] = firmware
        product = firmware.split(" V")[0] if firmware else None
        frame = next((t for t in log.texts("MSG", "Message") if t.startswith("Frame:")), None)
        if frame:
            meta["frame"] = frame.split(":", 1)[1].strip()
        meta["vehicle"] = " ".join(x for x in (product, meta.values.get("frame")) if x) or None
        # ArduPilot logs no cell count (only voltage thresholds)
        battery_meta(meta, params, capacity=("BATT_CAPACITY",), serial=("BATT_SERIAL_NUM",))
    meta["vehicle_type"] = vclass

    def mode_names(raw: np.ndarray, f: Field) -> np.ndarray:
        if f.message == "STAT":
            return np.array([mavutil.mode_string_px4(int(v)) for v in raw], dtype=object)
        if raw.dtype.kind in "OUS":
            return np.array([str(v).upper() for v in raw], dtype=object)
        mapping = mavutil.mode_mapping_bynumber(ap_mav_type) or {}
        return np.array([mapping.get(int(v), f"Mode({int(v)})") for v in raw], dtype=object)

    cache: dict[str, Message | None] = {}

    def get(name: str) -> Message | None:
        if name not in cache:
            cache[name] = log.message(name, _NEEDED.get(name))
        return cache[name]

    channels = resolve_channels(FIELD_MAP, get, vehicle_type=vclass, mode_names=mode_names)
    if "current_a" in channels:
        bmsg = channels["current_a"].message
        inst = log.instances(bmsg)
        if len(inst) > 1:
            meta["battery_instances"] = inst
            meta.warn(f"{path}: {len(inst)} batteries logged in {bmsg}; kept instance "
                      f"{inst[0]} (the others: {inst[1:]})")
    df = build_record(channels, meta, experiment=path.stem, require_battery=require_battery)
    meta["skipped_bytes"] = log.skipped_bytes
    if not px4:
        # GPS week and milliseconds of the week: GWk/GMS, in old logs Week/TimeMS
        gps = log.message("GPS", {"GWk", "GMS", "Week", "TimeMS", "Status"})
        names = next((n for n in (("GWk", "GMS"), ("Week", "TimeMS"))
                      if gps is not None and set(n) <= set(gps.data)), None)
        if names is not None:
            week = np.asarray(gps.data[names[0]], float)
            fix = np.asarray(gps.data.get("Status", np.full(week.shape, 3)), float) >= 3
            unix = np.where(fix & (week > 0), GPS_EPOCH_UNIX + week * 604_800.0
                            + np.asarray(gps.data[names[1]], float) / 1000.0 - GPS_LEAP_S,
                            np.nan)
            meta["start_time_unix"] = start_time_unix(meta.values["time_base_start_s"],
                                                      gps.t, unix)
    return df, meta.values
