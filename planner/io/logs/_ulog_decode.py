r"""A vectorised, bounded decoder of PX4 ULog files (``.ulg``).

It reads what :func:`planner.logs.ulog.read_ulog` needs — the info and parameter
messages, the subscriptions, and the data of the wanted topics — and gives the same arrays
as ``pyulog.ULog(path, topics)``, field for field (``tests/test_ulog_decode.py`` holds it to
that on every ULog at hand), about ten times faster and safe on any bytes:

* the message headers (u16 size, u8 type) are walked by one compiled loop
  (:func:`_walk`), which follows pyulog's recovery from corruption exactly (an unknown
  type with an impossible size: one byte on, then the next sync sequence; an unknown
  type of plausible size: a sync sequence within its payload);
* the data messages of a topic are gathered with one fancy index into the file's bytes
  and viewed through a numpy structured dtype built from the format definition, with the
  trailing ``_padding`` fields dropped as pyulog drops them;
* nothing is sized by a field of the file before the field is checked against the file:
  a format is refused when it refers to itself, nests deeper than
  :data:`MAX_NESTING`, or describes a record larger than the 65 535 bytes a ULog message
  can hold; a data section holds at most one message per three bytes of the file.

The ULog format: https://docs.px4.io/main/en/dev_log/ulog_file_format.html
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numba
import numpy as np

__all__ = ["ULogFile", "ULogTopic", "decode", "ULogError"]

HEADER_BYTES = b"ULog\x01\x12\x35"
SYNC_BYTES = np.frombuffer(b"\x2F\x73\x13\x20\x25\x0C\xBB\x12", np.uint8)
#: Deepest nesting of format definitions taken.
MAX_NESTING = 16
#: Largest record a ULog data message can carry (u16 size less the msg_id). [bytes]
MAX_RECORD_BYTES = 0xFFFF - 2

#: ULog field type → (numpy dtype, size in bytes), as pyulog reads them.
TYPES = {
    "int8_t": (np.int8, 1), "uint8_t": (np.uint8, 1), "int16_t": (np.int16, 2),
    "uint16_t": (np.uint16, 2), "int32_t": (np.int32, 4), "uint32_t": (np.uint32, 4),
    "int64_t": (np.int64, 8), "uint64_t": (np.uint64, 8), "float": (np.float32, 4),
    "double": (np.float64, 8), "bool": (np.int8, 1), "char": (np.int8, 1),
}
_SCALAR = {"int8_t": "<b", "uint8_t": "<B", "int16_t": "<h", "uint16_t": "<H",
           "int32_t": "<i", "uint32_t": "<I", "int64_t": "<q", "uint64_t": "<Q",
           "float": "<f", "double": "<d", "bool": "<?", "char": "<c"}

# message types
_DEFINITION_TYPES = frozenset(b"IMFPQB")
_DATA_KNOWN = np.zeros(256, np.bool_)
_DATA_KNOWN[list(b"IMPQALCDOS")] = True


class ULogError(Exception):
    """The file is not a ULog file at all (its header is wrong)."""


@dataclass
class ULogTopic:
    """The data of one topic instance (pyulog's ``ULog.Data``)."""

    name: str
    multi_id: int
    msg_id: int
    data: dict[str, np.ndarray]


@dataclass
class ULogFile:
    """What was decoded.

    Attributes
    ----------
    data_list : list of ULogTopic
        Sorted by (name, multi_id), topics with data only.
    initial_parameters : dict
    msg_info_dict : dict
    dropouts_ms : list of int
    file_corruption : bool
    problems : list of str
        What was skipped, in words.
    truncated_bytes : int
        Bytes of a message cut by the end of the file.
    """

    data_list: list[ULogTopic]
    initial_parameters: dict
    msg_info_dict: dict
    dropouts_ms: list[int] = field(default_factory=list)
    file_corruption: bool = False
    problems: list[str] = field(default_factory=list)
    truncated_bytes: int = 0


@numba.njit(cache=True)
def _find_sync(buf, start, stop):
    """First offset in [start, stop) where the 8 sync bytes begin; −1 if none."""
    n = min(stop, buf.size) - 7
    for i in range(start, n):
        if (buf[i] == 0x2F and buf[i + 1] == 0x73 and buf[i + 2] == 0x13
                and buf[i + 3] == 0x20 and buf[i + 4] == 0x25 and buf[i + 5] == 0x0C
                and buf[i + 6] == 0xBB and buf[i + 7] == 0x12):
            return i
    return -1


@numba.njit(cache=True)
def _walk(buf, start, read_until, known, has_sync, cap):
    """Walk the data section from ``start`` as pyulog does (module notes).

    Returns (offsets, sizes, types, count, corrupt, truncated_at, has_sync): the messages
    of known type, whether bytes were skipped to recover, where a message cut by the end
    of the file starts (−1: none). With ``cap`` 0 it only counts them (the first of two
    passes, so that the arrays are allocated at their exact size).
    """
    n = buf.size
    offs = np.empty(cap, np.int64)
    sizes = np.empty(cap, np.int64)
    types = np.empty(cap, np.uint8)
    k = 0
    corrupt = False
    truncated = -1
    o = start
    while o + 3 <= n:
        size = int(buf[o]) | (int(buf[o + 1]) << 8)
        typ = buf[o + 2]
        end = o + 3 + size
        if end > n:
            truncated = o
            break
        if end > read_until:
            break
        if known[typ]:
            if cap:
                offs[k] = o
                sizes[k] = size
                types[k] = typ
            k += 1
            o = end
            continue
        if typ == 0 or size == 0 or size > 10000:
            corrupt = True
            p = _find_sync(buf, o + 1, n) if has_sync else -1
            if p >= 0:
                o = p + 8
            else:
                has_sync = False
                o = o + 1
        else:
            p = _find_sync(buf, o + 3, end) if has_sync else -1
            if p >= 0:
                corrupt = True
                o = p + 8
            else:
                o = end
    return offs[:min(k, cap)], sizes[:min(k, cap)], types[:min(k, cap)], k, corrupt, \
        truncated, has_sync


def _text(data: bytes) -> str:
    return data.decode("utf-8", "ignore")


def _parse_format(data: bytes) -> tuple[str, list[tuple[str, int, str]]]:
    """``name:type field;type[n] field;…`` → name, [(type, array size, field)]."""
    text = _text(data)
    name, _, rest = text.partition(":")
    if not _:
        raise ValueError("format without ':'")
    fields = []
    for item in rest.split(";"):
        if not item:
            continue
        type_str, name_str = item.split(" ")[:2]
        a = type_str.find("[")
        if a == -1:
            fields.append((type_str, 0, name_str))
        else:
            size = int(type_str[a + 1:type_str.find("]")])
            if size < 0 or size > 0xFFFF:
                raise ValueError(f"invalid array size {size}")
            fields.append((type_str[:a], size, name_str))
    return name, fields


def _info(data: bytes, multiple: bool = False):
    """(type, key, value) of an info or parameter message, as pyulog decodes it."""
    if multiple:
        data = data[1:]
    key_len = data[0]
    type_key = _text(data[1:1 + key_len]).split(" ")
    type_, key = type_key[0], type_key[1]
    raw = data[1 + key_len:]
    if type_.startswith("char["):
        value = _text(raw)
    elif type_ in _SCALAR:
        value = struct.unpack(_SCALAR[type_], raw)[0]
    else:
        value = raw
    return type_, key, value


def _record_size(name: str, formats: dict, memo: dict, stack: tuple = ()) -> int:
    """Bytes of one record of format ``name``; ValueError when unknown, cyclic, too deep
    or larger than a ULog message can carry."""
    if name in memo:
        return memo[name]
    if name in stack:
        raise ValueError(f"format {name} contains itself")
    if len(stack) >= MAX_NESTING:
        raise ValueError(f"formats nested more than {MAX_NESTING} deep")
    if name not in formats:
        raise ValueError(f"no format for {name}")
    total = 0
    for type_name, size, _ in formats[name]:
        one = TYPES[type_name][1] if type_name in TYPES else \
            _record_size(type_name, formats, memo, stack + (name,))
        total += one * max(size, 1)
        if total > MAX_RECORD_BYTES:
            raise ValueError(f"format {name} describes more than {MAX_RECORD_BYTES} bytes")
    memo[name] = total
    return total


def _flatten(name: str, formats: dict, prefix: str = "") -> list[tuple[str, str]]:
    """(field name, type) of every scalar of a format, nested types flattened (pyulog)."""
    out = []
    for type_name, size, fname in formats[name]:
        if type_name in TYPES:
            if size > 0:
                out += [(f"{prefix}{fname}[{i}]", type_name) for i in range(size)]
            else:
                out.append((f"{prefix}{fname}", type_name))
        elif size > 0:
            for i in range(size):
                out += _flatten(type_name, formats, f"{prefix}{fname}[{i}].")
        else:
            out += _flatten(type_name, formats, f"{prefix}{fname}.")
    return out


def _dtype(name: str, formats: dict, memo: dict) -> np.dtype:
    """Structured dtype of a topic's records, trailing padding dropped (pyulog)."""
    _record_size(name, formats, memo)           # refuses cycles, depth, oversize first
    fields = _flatten(name, formats)
    while fields and fields[-1][0].startswith("_padding"):
        fields.pop()
    return np.dtype([(f, TYPES[t][0]) for f, t in fields]).newbyteorder("<")


_SKIPPED = (IndexError, ValueError, KeyError, OverflowError, struct.error)


@dataclass
class _Defs:
    """What the definitions section holds, and where the data section starts."""

    end: int
    formats: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    appended: list = field(default_factory=list)


@dataclass
class _Messages:
    """The data section's messages of known type: offset, payload size and type of each."""

    offs: np.ndarray
    sizes: np.ndarray
    types: np.ndarray
    truncated: int = -1

    def of(self, kind: str) -> np.ndarray:
        """Indices of the messages of one type (``"A"``, ``"D"``, …)."""
        return np.flatnonzero(self.types == ord(kind))


def decode(buf: bytes, topics) -> ULogFile:
    """Decode a ULog file's bytes (module notes); ``topics``: the topic names wanted.

    Raises
    ------
    ULogError
        The header is missing or wrong.
    """
    if len(buf) < 16:
        raise ULogError("Invalid file format (Header too short)")
    if buf[:7] != HEADER_BYTES:
        raise ULogError("Invalid file format (Failed to parse header)")
    arr = np.frombuffer(buf, np.uint8)
    out = ULogFile(data_list=[], initial_parameters={}, msg_info_dict={})
    defs = _definitions(buf, out)
    out.initial_parameters, out.msg_info_dict = defs.params, defs.info
    msgs = _data_section(arr, defs, out)
    _data_info(buf, msgs, out)
    subs, filtered = _subscriptions(buf, msgs, set(topics), defs.formats, out)
    out.data_list = _topics(arr, msgs, subs, filtered, out)
    out.truncated_bytes = 0 if msgs.truncated < 0 else len(buf) - msgs.truncated
    return out


def _definitions(buf: bytes, out: ULogFile) -> _Defs:
    """The info, format, parameter and flag messages before the first data-section
    message; a bad one is skipped as corruption, as pyulog does."""
    n = len(buf)
    defs = _Defs(end=16)
    o = 16
    while o + 3 <= n:
        size, typ = struct.unpack_from("<HB", buf, o)
        data = buf[o + 3:o + 3 + size]
        if typ in b"ALC":
            break
        nxt = o + 3 + size
        try:
            if typ == ord("I"):
                _, key, value = _info(data)
                defs.info[key] = value
            elif typ == ord("F"):
                name, fields = _parse_format(data)
                defs.formats[name] = fields
            elif typ == ord("P"):
                _, key, value = _info(data)
                defs.params[key] = value
            elif typ == ord("B"):
                defs.appended = _flag_bits(data, size) or defs.appended
            elif typ not in (ord("M"), ord("Q")) and (typ == 0 or size == 0 or size > 10000):
                out.file_corruption = True        # (multi-info, defaults: not needed)
                nxt = o + 1
        except ULogError:
            raise
        except _SKIPPED:
            if not out.file_corruption:
                out.problems.append("file corruption detected while reading the definitions")
            out.file_corruption = True
        o = nxt
    defs.end = o
    return defs


def _flag_bits(data: bytes, size: int) -> list[int]:
    """The offsets of appended data of a flag-bits message (none: an empty list)."""
    if size < 40:
        raise IndexError("flag bits message too short")
    incompat = data[8:16]
    offsets = list(struct.unpack_from("<3Q", data, 16))
    while offsets and offsets[-1] == 0:
        offsets.pop()
    if incompat[0] & ~1 or any(incompat[1:]):
        raise ULogError("Unknown incompatible flag set: cannot parse the log")
    return offsets if incompat[0] & 1 else []


def _data_section(arr: np.ndarray, defs: _Defs, out: ULogFile) -> _Messages:
    """Every message of known type in the data section (and its appended segments),
    walked by the compiled loop in two passes (count, then fill)."""
    n = arr.size
    segments, start = [], defs.end
    for off in defs.appended:
        segments.append((start, off))
        start = off
    segments.append((start, 1 << 62))
    parts, has_sync, truncated = [], True, -1
    for a, b in segments:
        if a >= n:
            continue
        count = _walk(arr, a, b, _DATA_KNOWN, has_sync, 0)[3]
        offs, sizes, types, _, bad, cut, has_sync = _walk(arr, a, b, _DATA_KNOWN, has_sync,
                                                          count)
        parts.append((offs, sizes, types))
        out.file_corruption |= bad
        if cut >= 0:
            truncated = cut
    if out.file_corruption and not out.problems:
        out.problems.append("file corruption: bytes skipped to the next sync sequence")
    if not parts:
        return _Messages(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, np.uint8),
                         truncated)
    return _Messages(*(np.concatenate([p[i] for p in parts]) for i in range(3)), truncated)


def _data_info(buf: bytes, msgs: _Messages, out: ULogFile) -> None:
    """Info messages of the data section (changed parameters are not initial ones, so
    parameters are not read here) and the dropouts."""
    for k in msgs.of("I"):
        o, size = int(msgs.offs[k]), int(msgs.sizes[k])
        try:
            _, key, value = _info(buf[o + 3:o + 3 + size])
            out.msg_info_dict[key] = value
        except _SKIPPED:
            out.file_corruption = True
    out.dropouts_ms = [int.from_bytes(buf[int(o) + 3:int(o) + 5], "little")
                       for o in msgs.offs[msgs.of("O")] if int(o) + 5 <= len(buf)]


def _subscriptions(buf: bytes, msgs: _Messages, wanted: set, formats: dict,
                   out: ULogFile) -> tuple[dict, set]:
    """Subscriptions of the wanted topics (msg_id → offset, name, multi_id, dtype) as
    pyulog keeps them: the last 'A' of a msg_id replaces an earlier one (whose data is
    dropped); and the msg_ids of the other topics."""
    memo: dict = {}
    subs: dict[int, tuple] = {}
    filtered: set[int] = set()
    for k in msgs.of("A"):
        o, size = int(msgs.offs[k]), int(msgs.sizes[k])
        data = buf[o + 3:o + 3 + size]
        try:
            multi_id, msg_id = struct.unpack_from("<BH", data, 0)
            name = _text(data[3:])
            if name not in wanted:
                filtered.add(msg_id)
                continue
            subs[msg_id] = (o, name, multi_id, _dtype(name, formats, memo))
        except _SKIPPED as exc:
            out.file_corruption = True
            out.problems.append(f"subscription at byte {o} skipped ({exc})")
    return subs, filtered


def _topics(arr: np.ndarray, msgs: _Messages, subs: dict, filtered: set,
            out: ULogFile) -> list[ULogTopic]:
    """The data of each subscription: its data messages (from the subscription on),
    gathered in one go through a strided view of the file's bytes."""
    d_idx = np.flatnonzero((msgs.types == ord("D")) & (msgs.sizes >= 2))
    d_off, d_size = msgs.offs[d_idx], msgs.sizes[d_idx]
    d_id = arr[d_off + 3].astype(np.int64) | (arr[d_off + 4].astype(np.int64) << 8)
    known = np.fromiter(list(subs) + list(filtered), np.int64)
    unknown = np.unique(d_id[~np.isin(d_id, known)])
    if unknown.size:
        out.file_corruption = True
        out.problems += [f"no subscription found for message id {int(m)}" for m in unknown[:5]]
    data_list = []
    for msg_id, (a_off, name, multi_id, dt) in subs.items():
        mine = (d_id == msg_id) & (d_off > a_off)
        if not mine.any():
            continue
        m_off, m_size = d_off[mine], d_size[mine] - 2
        ok = m_size == dt.itemsize            # pyulog skips any other size as corrupt
        if not ok.all():
            out.file_corruption = True
        rows = m_off[ok] + 5
        if rows.size == 0:
            continue
        # one gather of whole records through a strided view (no index array per byte)
        windows = np.lib.stride_tricks.sliding_window_view(arr, dt.itemsize)
        rec = np.ascontiguousarray(windows[rows]).view(dt).ravel()
        data_list.append(ULogTopic(name, multi_id, msg_id,
                                   {f: rec[f] for f in rec.dtype.names}))
    data_list.sort(key=lambda d: (d.name, d.multi_id))
    return data_list
