"""Live MAVLink telemetry, or a log replayed as if live, → telemetry events.

One connection string chooses the source, as pymavlink takes it
(:func:`parse_connection`):

==============================  ============================================================
``udpin:HOST:PORT``             listen for UDP datagrams on that address only (the ground
                                station's usual ``udpin:127.0.0.1:14550``; ``udp:`` is the same)
``udpout:HOST:PORT``            send to, and receive from, that address
``tcp:HOST:PORT``               connect to a TCP server (SITL, a telemetry router)
``DEVICE:BAUD``, ``DEVICE``     a serial port (``/dev/ttyUSB0:57600``, ``COM3,115200``); the
                                baud rate may also be given on its own
``FILE.tlog``                   a MAVLink telemetry log, replayed at its recorded timing ×
                                ``rate`` (0: as fast as it can be read)
``FILE.bin``/``.ulg``/``.csv``  any log the planner reads (:func:`planner.io.logs.read_log`),
                                replayed row by row from its flight record (a *record player*)
==============================  ============================================================

Nothing is bound or connected but the address given; nothing received is forwarded.

Events
------
Every source yields :class:`Event` tuples ``(kind, time_s, data)``. ``time_s`` is the
stream's own clock, seconds since the vehicle booted (:class:`StreamClock`); ``data`` per
kind:

===================  ==================================================================
``battery``          (voltage [V], current [A], consumed [mAh], remaining [0..1]);
                     NaN where the message says "not measured"
``position``         (latitude [deg], longitude [deg], altitude above home [m],
                     altitude AMSL [m], v north, v east, v down [m/s])
``local``            (east [m], north [m], altitude above home [m], v north, v east,
                     v down [m/s]) — a record's dead-reckoned track, home at (0, 0)
``hud``              (airspeed [m/s], ground speed [m/s], climb rate [m/s], throttle [0..1])
``wind``             (wind towards north, towards east [m/s], variance [m²/s²]; NaN: none
                     given)
``state``            (armed [bool], mode [str], vehicle type [str], autopilot [int])
``landed``           (landed [bool],) from ``EXTENDED_SYS_STATE``
``home``             (latitude [deg], longitude [deg], altitude AMSL [m])
``mission_current``  (sequence number, item count or 0)
``mission``          (:class:`MissionItems`,) a mission downloaded or captured
``text``             (severity, text)
``param``            (name, value) — battery parameters (``BAT*``, ``BATT*``) only
``air``              (pressure [Pa], temperature [°C]) from ``SCALED_PRESSURE``
``reboot``           () the vehicle's boot clock went backwards (a reboot)
``flight``           (name,) a new flight of a record begins (another pack)
===================  ==================================================================

Robustness
----------
Frames that fail the CRC, truncated frames and stray bytes are dropped by pymavlink's
parser (counted in :attr:`MavlinkDecoder.stats`); messages from other systems than the
vehicle (a second vehicle, the ground station) are ignored; pymavlink's per-parameter
table is bounded (:data:`MAX_PARAMS`), so no stream of messages makes memory grow.
"""

from __future__ import annotations

import math
import os
import stat
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from planner.errors import InputError
from planner.io.mission.route import MavItem

__all__ = ["BATTERY_PARAM_PREFIXES", "ConnectionSpec", "Event", "LiveLink", "MavlinkDecoder",
           "MissionCapture", "MissionItems", "RecordSource", "StreamClock", "TlogSource",
           "open_source", "parse_connection", "statustext_chunks"]

#: The address the watcher listens on unless told otherwise (the ground station's port on
#: this machine only).
DEFAULT_CONNECTION = "udpin:127.0.0.1:14550"
#: Our own MAVLink identity when we send anything (a read request of the mission protocol,
#: an opt-in STATUSTEXT): a system id other than the ground station's 255.
SOURCE_SYSTEM = 254
SOURCE_COMPONENT = 190      # MAV_COMP_ID_MISSIONPLANNER
#: Parameters passed on as ``param`` events (the battery's).
BATTERY_PARAM_PREFIXES = ("BAT_", "BAT1_", "BATT_", "BATT1_")
#: Most parameters pymavlink may keep per system: a stream of ever new parameter names
#: would otherwise grow its table without bound.
MAX_PARAMS = 4096
#: The boot clock going back by more than this is a reboot (small steps back are messages
#: that arrived out of order). [s]
REBOOT_STEP_S = 2.0
#: A boot time older than this (receive clock) is not trusted for the next events: they
#: wait for a fresh one (the vehicle may have rebooted while the link was silent). [s]
RESYNC_GAP_S = 10.0
#: Events received before the first boot time wait this long for it (then the receive
#: clock is used), and at most this many of them. [s]
BOOT_WAIT_S = 2.0
MAX_PENDING = 5000
#: Characters of one STATUSTEXT (MAVLink); a longer text is sent in chunks.
STATUSTEXT_LEN = 50

_GCS_TYPES = {6, 5, 18, 26, 27, 30}      # GCS, antenna tracker, onboard controller, …
_MAV_TYPE_CLASS = {1: "fixed_wing", 2: "multirotor", 3: "multirotor", 4: "helicopter",
                   13: "multirotor", 14: "multirotor", 15: "multirotor", 16: "fixed_wing",
                   19: "vtol", 20: "vtol", 21: "vtol", 22: "vtol", 23: "vtol", 24: "vtol",
                   25: "vtol", 29: "multirotor"}
_ARMED = 128                              # MAV_MODE_FLAG_SAFETY_ARMED
_UINT16_MAX = 65535
_LOG_SUFFIXES = (".bin", ".px4log", ".ulg", ".csv", ".csv.gz", ".txt")
_NAN = float("nan")


class Event(NamedTuple):
    """One telemetry event: its kind, the stream clock [s] and its values (module notes)."""

    kind: str
    time_s: float
    data: tuple


# --------------------------------------------------------------------------- connections

@dataclass(frozen=True)
class ConnectionSpec:
    """A parsed connection string.

    Attributes
    ----------
    kind : {"udpin", "udpout", "tcp", "serial", "tlog", "log"}
    address : str
        ``HOST:PORT``, the serial device, or the file.
    baud : int or None
        Serial baud rate.
    text : str
        As given.
    """

    kind: str
    address: str
    baud: int | None = None
    text: str = ""

    @property
    def is_file(self) -> bool:
        """True when the connection is a log replayed as a stream, not a live link."""
        return self.kind in ("tlog", "log")


def _host_port(rest: str, text: str) -> str:
    host, sep, port = rest.rpartition(":")
    if not sep or not host or not port.isdigit() or not 1 <= int(port) <= 65535:
        raise InputError(f"connection {text!r}: expected HOST:PORT after the scheme, with a "
                         "port in 1..65535 (e.g. udpin:127.0.0.1:14550)")
    return f"{host}:{int(port)}"


def parse_connection(text: str, baud: int | None = None) -> ConnectionSpec:
    """A connection string → :class:`ConnectionSpec` (module notes for the forms).

    Raises
    ------
    InputError
        An unknown scheme, a bad address or port, a file that is no log, a serial device
        that is not one.
    """
    t = str(text).strip()
    low = t.lower()
    for scheme, kind in (("udpin:", "udpin"), ("udp:", "udpin"), ("udpout:", "udpout"),
                         ("tcp:", "tcp")):
        if low.startswith(scheme):
            return ConnectionSpec(kind, _host_port(t[len(scheme):], t), None, t)
    if low.startswith(("udpbcast:", "mcast:", "tcpin:", "wsserver:", "ws:")):
        raise InputError(f"connection {t!r}: not supported here (expected udpin:HOST:PORT, "
                         "udpout:HOST:PORT, tcp:HOST:PORT, a serial DEVICE:BAUD or a log file)")
    path = Path(t)
    if path.suffix.lower() == ".tlog" or low.endswith(_LOG_SUFFIXES):
        if not path.exists():
            raise InputError(f"{t}: file not found")
        return ConnectionSpec("tlog" if path.suffix.lower() == ".tlog" else "log", t, None, t)
    device, rate = t, baud
    for sep in (",", ":"):
        head, s, tail = t.rpartition(sep)
        if s and tail.isdigit() and head:
            device, rate = head, int(tail)
            break
    try:
        st = os.stat(device)
    except OSError:
        st = None
    if st is not None and stat.S_ISCHR(st.st_mode) or device.upper().startswith("COM"):
        if rate is None or not 50 <= rate <= 20_000_000:
            raise InputError(f"connection {t!r}: a serial port needs a baud rate in "
                             "50..20000000 (DEVICE:BAUD, e.g. /dev/ttyUSB0:57600)")
        return ConnectionSpec("serial", device, rate, t)
    if st is not None and stat.S_ISREG(st.st_mode):
        return ConnectionSpec("log", t, None, t)
    raise InputError(f"connection {t!r}: expected udpin:HOST:PORT, udpout:HOST:PORT, "
                     "tcp:HOST:PORT, a serial DEVICE:BAUD, or a .tlog/.bin/.ulg/.csv log file")


# --------------------------------------------------------------------------- clock

class StreamClock:
    """The vehicle's boot clock, kept from the messages that carry ``time_boot_ms``.

    A message without one is placed after the last that had one by the receive clock
    (the tlog's receive time, or this machine's monotonic clock on a live link). Before
    the first ``time_boot_ms`` the clock counts from the first message. A boot clock that
    steps back by more than :data:`REBOOT_STEP_S`, twice in a row, is a reboot:
    :meth:`update` then returns True and the clock follows the new boot.
    """

    __slots__ = ("_boot", "_recv_at_boot", "_first_recv", "_candidate")

    def __init__(self):
        self._candidate = None
        self._boot = None
        self._recv_at_boot = 0.0
        self._first_recv = None

    def update(self, time_boot_s: float, recv_s: float) -> bool:
        """Take a boot-clock reading received at ``recv_s``; True when it is a reboot.

        A step back is a reboot only when the next reading confirms it (a second reading
        on the same new clock): one stale or damaged message does not restart the clock.
        A step forward is taken as it comes (a link back after a gap, a log replayed
        faster than real time).
        """
        if self._first_recv is None:
            self._first_recv = recv_s
        if self._boot is None:
            self._boot, self._recv_at_boot = time_boot_s, recv_s
            return False
        if time_boot_s < self.now(recv_s) - REBOOT_STEP_S:
            cand = self._candidate
            if cand is not None and abs(time_boot_s - (cand[0] + recv_s - cand[1])) \
                    <= REBOOT_STEP_S + abs(time_boot_s - cand[0]):
                self._candidate = None
                self._boot, self._recv_at_boot = time_boot_s, recv_s
                return True
            self._candidate = (time_boot_s, recv_s)
            return False
        self._candidate = None
        if time_boot_s >= self._boot:
            self._boot, self._recv_at_boot = time_boot_s, recv_s
        return False

    @property
    def unconfirmed(self) -> bool:
        """A step back of the boot clock waits for its confirmation."""
        return self._candidate is not None

    def since_reading(self, recv_s: float) -> float:
        """Receive time since the last boot reading (inf: none yet). [s]"""
        return math.inf if self._boot is None else recv_s - self._recv_at_boot

    @property
    def booted(self) -> bool:
        """Whether a boot time has been read."""
        return self._boot is not None

    def now(self, recv_s: float) -> float:
        """The stream clock at receive time ``recv_s``. [s]"""
        if self._first_recv is None:
            self._first_recv = recv_s
        if self._boot is None:
            return recv_s - self._first_recv
        return self._boot + max(recv_s - self._recv_at_boot, 0.0)


# --------------------------------------------------------------------------- missions

@dataclass(frozen=True)
class MissionItems:
    """A vehicle's mission as MAVLink items.

    Attributes
    ----------
    items : tuple of MavItem
        The items after home, in sequence order (``origin`` ``"item N"``).
    home : (lat_deg, lon_deg, alt_amsl_m) or None
        ArduPilot's item 0, where it is home.
    source : str
        ``download``, ``capture`` (another ground station's download seen on the link) or
        the file it was read from.
    count : int
        Items as the vehicle counts them (ArduPilot: home included).
    """

    items: tuple
    home: tuple | None
    source: str
    count: int


def mav_item(msg) -> MavItem:
    """``MISSION_ITEM_INT`` or ``MISSION_ITEM`` → :class:`MavItem` (latitude, longitude in
    degrees, whatever the message's scaling)."""
    is_int = msg.get_type() == "MISSION_ITEM_INT"
    x, y = (msg.x * 1e-7, msg.y * 1e-7) if is_int else (float(msg.x), float(msg.y))
    params = (float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4),
              x, y, float(msg.z))
    return MavItem(seq=int(msg.seq), command=int(msg.command), frame=int(msg.frame),
                   params=params, origin=f"item {int(msg.seq)}")


def split_home(items: list[MavItem], autopilot: int | None):
    """ArduPilot keeps home as item 0: (home, the other items); else (None, items)."""
    if autopilot == 3 and items and items[0].seq == 0:
        h = items[0]
        lat, lon, alt = h.params[4], h.params[5], h.params[6]
        home = (lat, lon, alt) if (lat or lon) and all(map(math.isfinite, (lat, lon, alt))) \
            else None
        return home, items[1:]
    return None, items


class MissionCapture:
    """Assemble a mission from the mission protocol's messages seen on the link.

    Fed the vehicle's ``MISSION_COUNT`` and ``MISSION_ITEM(_INT)`` messages, whoever asked
    for them (our own download or another ground station's, which a shared link or a
    recorded tlog shows): when items 0 … count−1 have all been seen, :meth:`feed` returns
    the items. Bounded: at most :data:`planner.physics.mission.MAX_ITEMS` items are kept.
    """

    def __init__(self, max_items: int = 10_000):
        self.count: int | None = None
        self.items: dict[int, MavItem] = {}
        self.max_items = max_items

    def reset(self) -> None:
        """Forget a partly captured mission."""
        self.count, self.items = None, {}

    def feed(self, msg) -> list[MavItem] | None:
        """Take one MAVLink message of the mission protocol; the mission's items once all have
        been seen, else None."""
        mtype = msg.get_type()
        if getattr(msg, "mission_type", 0) not in (0, None):
            return None
        if mtype == "MISSION_COUNT":
            n = int(msg.count)
            if n != self.count:
                self.items = {}
            self.count = min(max(n, 0), self.max_items)
            return [] if self.count == 0 else None
        if mtype in ("MISSION_ITEM_INT", "MISSION_ITEM") and self.count is not None:
            seq = int(msg.seq)
            if 0 <= seq < self.count:
                try:
                    self.items[seq] = mav_item(msg)
                except (TypeError, ValueError, OverflowError):
                    return None
                if len(self.items) == self.count:
                    out = [self.items[k] for k in range(self.count)]
                    self.reset()
                    return out
        return None


class MissionClient:
    """Download the vehicle's mission with the MAVLink mission protocol (read only).

    ``MISSION_REQUEST_LIST`` → ``MISSION_COUNT``; ``MISSION_REQUEST_INT`` for each item →
    ``MISSION_ITEM_INT``; then ``MISSION_ACK``. None of these changes anything on the
    vehicle. A request unanswered within :attr:`timeout_s` is sent again, at most
    :attr:`retries` times; then the download is abandoned and tried again after
    :attr:`backoff_s`. The items arrive through the decoder's :class:`MissionCapture`.

    A vehicle refuses a request for an item its mission no longer holds (it changed during
    the download) with a ``MISSION_ACK`` carrying an error: ArduPilot's
    ``MissionItemProtocol_Waypoints::get_item`` sends the new ``MISSION_COUNT`` and
    ``MAV_MISSION_ERROR``, PX4's ``MavlinkMissionManager::handle_mission_request_both``
    ``MAV_MISSION_ERROR`` and ends the transfer. The download then starts again from the
    list at once, at most :attr:`retries` times in a row before the back-off.
    """

    def __init__(self, send, timeout_s: float = 1.5, retries: int = 6, backoff_s: float = 10.0):
        self.send = send
        self.timeout_s, self.retries, self.backoff_s = timeout_s, retries, backoff_s
        self.target: tuple[int, int] | None = None
        self.state = "idle"            # idle, count, items, done, failed
        self.count = 0
        self.next_seq = 0
        self.sent_at = -math.inf
        self.tries = 0
        self.failed_at = -math.inf
        self.requests = 0
        self.refusals = 0              # error acknowledgements in a row

    def start(self, target: tuple[int, int], now: float) -> None:
        """Begin (or restart) a download from ``target`` = (system, component)."""
        self.target = target
        self.state, self.tries = "count", 0
        self._request(now)

    def _request(self, now: float) -> None:
        from pymavlink.dialects.v20 import ardupilotmega as mav

        sysid, comp = self.target
        if self.state == "count":
            msg = mav.MAVLink_mission_request_list_message(sysid, comp, 0)
        else:
            msg = mav.MAVLink_mission_request_int_message(sysid, comp, self.next_seq, 0)
        self.send(msg)
        self.requests += 1
        self.sent_at = now
        self.tries += 1

    def on_message(self, msg, now: float) -> None:
        """Follow the vehicle's answers to us (messages of the vehicle only)."""
        mtype = msg.get_type()
        if getattr(msg, "mission_type", 0) not in (0, None) \
                or getattr(msg, "target_system", 0) not in (SOURCE_SYSTEM, 0):
            return
        if mtype == "MISSION_COUNT" and self.state == "count":
            self.count = max(int(msg.count), 0)
            self.next_seq, self.tries = 0, 0
            if self.count == 0:
                self._finish()
            else:
                self.state = "items"
                self._request(now)
        elif mtype in ("MISSION_ITEM_INT", "MISSION_ITEM") and self.state == "items":
            if int(msg.seq) == self.next_seq:
                self.next_seq += 1
                self.tries = 0
                if self.next_seq >= self.count:
                    self._finish()
                else:
                    self._request(now)
        elif mtype == "MISSION_ACK" and self.state in ("count", "items") \
                and getattr(msg, "type", 0) != 0:
            # the vehicle refused our request: its mission changed under the download, or
            # another ground station is uploading (ArduPilot: MAV_MISSION_DENIED)
            self.refusals += 1
            if self.refusals > self.retries:
                self.state, self.failed_at = "failed", now
            else:
                self.start(self.target, now)

    def _finish(self) -> None:
        from pymavlink.dialects.v20 import ardupilotmega as mav

        sysid, comp = self.target
        self.send(mav.MAVLink_mission_ack_message(sysid, comp, 0, 0))
        self.state, self.refusals = "done", 0

    def poll(self, now: float) -> None:
        """Time-outs: send again, or give up and retry after the back-off."""
        if self.state in ("count", "items") and now - self.sent_at > self.timeout_s:
            if self.tries > self.retries:
                self.state, self.failed_at = "failed", now
            else:
                self._request(now)
        elif self.state == "failed" and now - self.failed_at > self.backoff_s \
                and self.target is not None:
            self.start(self.target, now)


# --------------------------------------------------------------------------- decoder

@dataclass
class DecoderStats:
    """What the decoder saw. Counts."""

    messages: int = 0
    bad: int = 0
    other_systems: int = 0
    reboots: int = 0
    missions: int = 0


class MavlinkDecoder:
    """MAVLink messages of one vehicle → :class:`Event` tuples.

    Parameters
    ----------
    system_id : int, optional
        The vehicle's system id; default the first system that sends a vehicle
        ``HEARTBEAT`` (not a ground station, tracker or companion computer).
    send : callable, optional
        Sends a MAVLink message to the vehicle: with it the decoder downloads the mission
        (read requests of the mission protocol only); without it (a log, or a passive
        watcher) a mission is only captured when another ground station downloads it.
    """

    def __init__(self, system_id: int | None = None, send=None):
        self.system_id = system_id
        self.component: int | None = None
        self.autopilot: int | None = None
        self.vehicle_type: str | None = None
        self.clock = StreamClock()
        self.stats = DecoderStats()
        self.capture = MissionCapture()
        self.client = MissionClient(send) if send is not None else None
        self.mission_total: int | None = None
        self.mission_count: int | None = None
        self.last_recv: float | None = None
        self.receive_clock = False
        self._resync: float | None = None
        self._first_recv: float | None = None
        self._pending: list[Event] = []
        self._prelock: list = []
        self._handlers = {
            "HEARTBEAT": self._heartbeat, "SYS_STATUS": self._sys_status,
            "BATTERY_STATUS": self._battery_status, "GLOBAL_POSITION_INT": self._position,
            "VFR_HUD": self._hud, "WIND": self._wind, "WIND_COV": self._wind_cov,
            "MISSION_CURRENT": self._mission_current, "HOME_POSITION": self._home,
            "EXTENDED_SYS_STATE": self._landed, "STATUSTEXT": self._text,
            "PARAM_VALUE": self._param, "SCALED_PRESSURE": self._air,
            "MISSION_COUNT": self._mission_msg, "MISSION_ITEM_INT": self._mission_msg,
            "MISSION_ITEM": self._mission_msg, "MISSION_ACK": self._mission_ack,
        }

    # -- entry
    def decode(self, msg, recv_s: float) -> list[Event]:
        """The events of one message received at ``recv_s`` (receive clock, s)."""
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            self.stats.bad += 1
            return []
        src = msg.get_srcSystem()
        if self.system_id is None:
            if mtype == "HEARTBEAT" and self._is_vehicle(msg):
                # the vehicle is known: its messages that came before its heartbeat first
                self.system_id = src
                early = [(m, r) for m, r in self._prelock if m.get_srcSystem() == src]
                self._prelock.clear()
                out = [ev for m, r in early for ev in self.decode(m, r)]
                return out + self.decode(msg, recv_s)
            if len(self._prelock) < MAX_PENDING:
                self._prelock.append((msg, recv_s))
            return []
        if src != self.system_id:
            # the mission protocol's answers to another ground station come from the vehicle;
            # everything from other systems is someone else's
            self.stats.other_systems += 1
            return []
        self.stats.messages += 1
        self.last_recv = recv_s
        if self._first_recv is None:
            self._first_recv = recv_s
        out: list[Event] = []
        boot_ms = getattr(msg, "time_boot_ms", None)
        if boot_ms is not None and not self.receive_clock:
            try:
                if self.clock.update(float(boot_ms) * 1e-3, recv_s):
                    self.stats.reboots += 1
                    out.append(Event("reboot", self.clock.now(recv_s), ()))
            except (TypeError, ValueError):
                pass
        holding = self.clock.booted is False and not self.receive_clock
        if holding and recv_s - self._first_recv >= BOOT_WAIT_S:
            # no boot clock in the stream: the receive clock it is, for good
            self.receive_clock, holding = True, False
        if not holding and boot_ms is None and self.clock.booted and not self.receive_clock:
            # after a long silence (the vehicle may have rebooted) events wait for a fresh
            # boot time, at most BOOT_WAIT_S
            since = self.clock.since_reading(recv_s)
            if since > RESYNC_GAP_S and (self._resync is None or recv_s - self._resync
                                         < BOOT_WAIT_S):
                if self._resync is None:
                    self._resync = recv_s
                holding = True
        if boot_ms is not None:
            self._resync = None
        if self.clock.unconfirmed and len(self._pending) < MAX_PENDING:
            holding = True           # a step back not yet confirmed: which clock is it?
        handler = self._handlers.get(mtype)
        if handler is not None:
            try:
                handler(msg, recv_s if holding else self.clock.now(recv_s), out, recv_s)
            except (TypeError, ValueError, OverflowError, AttributeError):
                self.stats.bad += 1
        if holding:
            # until the first boot time, events wait (bounded) to be put on the boot clock
            if len(self._pending) < MAX_PENDING:
                self._pending.extend(out)
            return []
        if self._pending:
            held = [Event(k, self.clock.now(r), d) for k, r, d in self._pending]
            self._pending.clear()
            first = 1 if out and out[0].kind == "reboot" else 0
            out = out[:first] + held + out[first:]
        return out

    def poll(self, recv_s: float) -> None:
        """Time-outs of the mission download."""
        if self.client is not None:
            self.client.poll(recv_s)

    # -- helpers
    @staticmethod
    def _is_vehicle(msg) -> bool:
        return msg.type not in _GCS_TYPES and msg.autopilot != 8     # MAV_AUTOPILOT_INVALID

    def _start_download(self, recv_s: float) -> None:
        if self.client is not None and self.component is not None:
            self.client.start((self.system_id, self.component), recv_s)

    # -- handlers: (msg, stream time, out list, receive time)
    def _heartbeat(self, msg, t, out, recv_s):
        if not self._is_vehicle(msg):
            return
        if self.component is None:
            self.component = msg.get_srcComponent()
            self.autopilot = int(msg.autopilot)
            self.vehicle_type = _MAV_TYPE_CLASS.get(int(msg.type), "other")
            if self.client is not None and self.client.state == "idle":
                self._start_download(recv_s)
        elif msg.get_srcComponent() != self.component:
            return
        from pymavlink import mavutil

        try:
            mode = mavutil.mode_string_v10(msg)
        except Exception:          # noqa: BLE001 - pymavlink's tables raise several kinds
            mode = f"mode {msg.custom_mode}"
        out.append(Event("state", t, (bool(msg.base_mode & _ARMED), str(mode),
                                      self.vehicle_type, self.autopilot)))

    def _sys_status(self, msg, t, out, recv_s):
        v = msg.voltage_battery
        i = msg.current_battery
        rem = msg.battery_remaining
        out.append(Event("battery", t, (
            _NAN if v in (0, _UINT16_MAX) else v * 1e-3,
            _NAN if i == -1 else i * 1e-2, _NAN,
            _NAN if rem < 0 else rem * 1e-2)))

    def _battery_status(self, msg, t, out, recv_s):
        if msg.id != 0:
            return
        cells = [c for c in msg.voltages if c != _UINT16_MAX]
        v = sum(cells) * 1e-3 if cells and sum(cells) > 0 else _NAN
        i = _NAN if msg.current_battery == -1 else msg.current_battery * 1e-2
        if not math.isfinite(i):
            v = _NAN        # a voltage without its current: SYS_STATUS gives both
        out.append(Event("battery", t, (
            v, i, _NAN if msg.current_consumed < 0 else float(msg.current_consumed),
            _NAN if msg.battery_remaining < 0 else msg.battery_remaining * 1e-2)))

    def _position(self, msg, t, out, recv_s):
        lat, lon = msg.lat * 1e-7, msg.lon * 1e-7
        if lat == 0 and lon == 0:
            lat = lon = _NAN
        out.append(Event("position", t, (lat, lon, msg.relative_alt * 1e-3, msg.alt * 1e-3,
                                         msg.vx * 1e-2, msg.vy * 1e-2, msg.vz * 1e-2)))

    def _hud(self, msg, t, out, recv_s):
        out.append(Event("hud", t, (float(msg.airspeed), float(msg.groundspeed),
                                    float(msg.climb), min(max(msg.throttle, 0), 100) * 1e-2)))

    def _wind(self, msg, t, out, recv_s):
        # ArduPilot WIND: direction the wind comes FROM [deg], speed [m/s]
        frm = math.radians(float(msg.direction))
        s = float(msg.speed)
        out.append(Event("wind", t, (-s * math.cos(frm), -s * math.sin(frm), _NAN)))

    def _wind_cov(self, msg, t, out, recv_s):
        # PX4 WIND_COV: wind_x north, wind_y east, the air's velocity (NED)
        var = float(msg.var_horiz)
        out.append(Event("wind", t, (float(msg.wind_x), float(msg.wind_y),
                                     var if math.isfinite(var) and var >= 0 else _NAN)))

    def _mission_current(self, msg, t, out, recv_s):
        total = int(getattr(msg, "total", 0) or 0)
        if total and self.mission_total is not None and total != self.mission_total:
            self._changed(recv_s)
        if total:
            self.mission_total = total
        seq = int(msg.seq)
        if self.mission_count is not None and seq >= max(self.mission_count, 1) \
                and self.client is not None and self.client.state == "done":
            self._changed(recv_s)
        out.append(Event("mission_current", t, (seq, total)))

    def _changed(self, recv_s):
        """The vehicle's mission changed: download it again (a download under way fetches
        the old mission's items: it starts again too)."""
        if self.client is not None:
            self.capture.reset()
            self._start_download(recv_s)

    def _home(self, msg, t, out, recv_s):
        lat, lon = msg.latitude * 1e-7, msg.longitude * 1e-7
        if lat or lon:
            out.append(Event("home", t, (lat, lon, msg.altitude * 1e-3)))

    def _landed(self, msg, t, out, recv_s):
        if msg.landed_state:       # 0: undefined
            out.append(Event("landed", t, (msg.landed_state == 1,)))

    def _text(self, msg, t, out, recv_s):
        text = msg.text
        if isinstance(text, bytes):
            text = text.decode(errors="replace")
        out.append(Event("text", t, (int(msg.severity), str(text).rstrip("\x00"))))

    def _param(self, msg, t, out, recv_s):
        pid = msg.param_id
        pid = pid.decode(errors="replace") if isinstance(pid, bytes) else str(pid)
        pid = pid.rstrip("\x00")
        if pid.startswith(BATTERY_PARAM_PREFIXES):
            value = float(msg.param_value)
            if msg.param_type in (1, 2, 3, 4, 5, 6) and not value.is_integer():
                # an integer parameter sent as its bytes in a float (PX4): reinterpret
                import struct
                value = float(struct.unpack("<i", struct.pack("<f", value))[0])
            out.append(Event("param", t, (pid, value)))

    def _air(self, msg, t, out, recv_s):
        out.append(Event("air", t, (msg.press_abs * 100.0, msg.temperature * 1e-2)))

    def _mission_msg(self, msg, t, out, recv_s):
        if msg.get_type() == "MISSION_COUNT" and getattr(msg, "mission_type", 0) in (0, None):
            if self.mission_count is not None and int(msg.count) != self.mission_count \
                    and (self.client is None or self.client.state == "done"):
                self._changed(recv_s)
        if self.client is not None:
            self.client.on_message(msg, recv_s)
        items = self.capture.feed(msg)
        if items is None:
            return
        home, rest = split_home(items, self.autopilot)
        self.mission_count = len(items)
        self.stats.missions += 1
        source = ("download" if self.client is not None and self.client.state == "done"
                  else "capture")
        out.append(Event("mission", t, (MissionItems(tuple(rest), home, source, len(items)),)))

    def _mission_ack(self, msg, t, out, recv_s):
        if getattr(msg, "mission_type", 0) not in (0, None):
            return
        if msg.target_system not in (SOURCE_SYSTEM, 0):
            # the vehicle accepted an upload from another ground station: the mission changed
            if msg.type == 0:
                self._changed(recv_s)
        elif self.client is not None:
            self.client.on_message(msg, recv_s)      # a refusal of our own request


# --------------------------------------------------------------------------- sources

class LiveLink:
    """A live MAVLink link through pymavlink (UDP, TCP or serial).

    Only the address given is bound or connected. :meth:`send` sends our own messages
    (mission read requests, an opt-in STATUSTEXT) to the vehicle; nothing received is
    forwarded anywhere.
    """

    def __init__(self, spec: ConnectionSpec, *, source_system: int = SOURCE_SYSTEM,
                 source_component: int = SOURCE_COMPONENT):
        from pymavlink import mavutil

        device = {"udpin": f"udpin:{spec.address}", "udpout": f"udpout:{spec.address}",
                  "tcp": f"tcp:{spec.address}", "serial": spec.address}[spec.kind]
        try:
            self.conn = mavutil.mavlink_connection(
                device, baud=spec.baud or 57600, source_system=source_system,
                source_component=source_component, input=spec.kind != "udpout",
                dialect="ardupilotmega", autoreconnect=spec.kind == "tcp",
                robust_parsing=True)
        except (OSError, ValueError) as exc:
            raise InputError(f"connection {spec.text}: cannot open "
                             f"({getattr(exc, 'strerror', None) or exc})") from None
        except Exception as exc:      # noqa: BLE001 - pyserial and socket errors vary
            raise InputError(f"connection {spec.text}: cannot open ({exc})") from None
        self.spec = spec
        self.sent = 0

    def receive(self, timeout_s: float, max_messages: int = 2000) -> list:
        """Messages waiting (at most ``max_messages``), after waiting up to ``timeout_s``
        for the first. Each message carries ``_recv`` (monotonic receive time, s)."""
        out = []
        conn = self.conn
        for attempt in range(2):
            while len(out) < max_messages:
                try:
                    msg = conn.recv_msg()
                except (OSError, ValueError, IndexError, TypeError):
                    msg = None
                except Exception:      # noqa: BLE001 - a damaged frame must not end the watch
                    msg = None
                if msg is None:
                    break
                msg._recv = time.monotonic()
                out.append(msg)
            if out or attempt:
                break
            try:
                conn.select(timeout_s)
            except (OSError, ValueError):
                time.sleep(timeout_s)
        self._bound()
        return out

    def _bound(self) -> None:
        """Keep pymavlink's own tables bounded (module notes)."""
        states = getattr(self.conn, "param_state", None)
        if states:
            for st in states.values():
                if len(st.params) > MAX_PARAMS:
                    st.params.clear()
            if len(states) > 256:
                states.clear()

    def send(self, msg) -> None:
        """Send ``msg`` on the link; dropped silently while there is no peer or the link is
        down."""
        try:
            self.conn.mav.send(msg)
            self.sent += 1
        except (OSError, ValueError, TypeError, AttributeError):
            pass                        # no peer yet (udpin before any datagram), link down

    def close(self) -> None:
        """Close the link (errors on closing ignored)."""
        try:
            self.conn.close()
        except Exception:   # noqa: BLE001
            pass


def statustext_chunks(text: str, severity: int, chunk_id: int = 1) -> list:
    """A STATUSTEXT message for ``text``, in chunks of :data:`STATUSTEXT_LEN` characters
    (MAVLink 2 ``id`` / ``chunk_seq``) when it is longer."""
    from pymavlink.dialects.v20 import ardupilotmega as mav

    raw = text.encode("ascii", errors="replace")
    if len(raw) <= STATUSTEXT_LEN:
        return [mav.MAVLink_statustext_message(severity, raw, 0, 0)]
    parts = [raw[i:i + STATUSTEXT_LEN] for i in range(0, len(raw), STATUSTEXT_LEN)]
    if len(parts[-1]) == STATUSTEXT_LEN:
        parts.append(b"")            # a last chunk shorter than 50 closes the text
    return [mav.MAVLink_statustext_message(severity, p, chunk_id, k)
            for k, p in enumerate(parts)]


#: Receive times a tlog frame may carry: 2000 … 2100 [µs since 1970].
TLOG_TIME_US = (int(946684800e6), int(4102444800e6))


def tlog_frame(data, ofs: int) -> tuple[int, int] | None:
    """The tlog frame starting at byte ``ofs`` of ``data``: (its end offset, its receive
    time [µs]), or None when no frame starts there. A frame is an 8-byte big-endian
    receive time then a MAVLink 1 (``FE``) or 2 (``FD``, signed when its flag says so)
    frame, the time within :data:`TLOG_TIME_US` and the frame whole."""
    n = len(data)
    if ofs + 14 > n:
        return None
    marker = data[ofs + 8]
    if marker == 0xFE:
        end = ofs + 16 + data[ofs + 9]
    elif marker == 0xFD and ofs + 18 <= n:
        end = ofs + 20 + data[ofs + 9] + (13 if data[ofs + 10] & 0x01 else 0)
    else:
        return None
    t_us = int.from_bytes(data[ofs:ofs + 8], "big")
    lo, hi = TLOG_TIME_US
    if not lo <= t_us <= hi or end > n:
        return None
    return end, t_us


class TlogSource:
    """A ``.tlog`` replayed: its frames decoded by pymavlink's parser (CRC checked), each
    with its recorded receive time, paced at ``rate`` × real time (0: no pacing).

    Damaged frames are stepped over one byte at a time (as
    :mod:`planner.io.logs.tlog` does), so a damaged log replays in time linear in its size.
    """

    def __init__(self, path: str | os.PathLike, rate: float = 1.0):
        from planner.io import files
        from pymavlink.dialects.v20 import ardupilotmega as mav

        self.path = files.input_path(path, "log", "telemetry log")
        self.data = memoryview(self.path.read_bytes())
        self.rate = float(rate)
        self.link = mav.MAVLink(None)
        self.link.robust_parsing = True
        self.bad = 0

    def messages(self) -> Iterator:
        """Yield every intact message with ``_recv`` = its recorded receive time [s]."""
        data, n, ofs = self.data, len(self.data), 0
        start_file = start_wall = None
        while ofs + 14 <= n:
            frame = tlog_frame(data, ofs)
            if frame is None:
                ofs += 1
                continue
            end, t_us = frame
            try:
                msg = self.link.decode(bytearray(data[ofs + 8:end]))
            except Exception:          # noqa: BLE001 - pymavlink raises several kinds
                self.bad += 1
                ofs += 1
                continue
            ofs = end
            t = t_us * 1e-6
            if self.rate > 0:
                if start_file is None:
                    start_file, start_wall = t, time.monotonic()
                wait = start_wall + (t - start_file) / self.rate - time.monotonic()
                if wait > 0:
                    time.sleep(min(wait, 5.0))
            msg._recv = t
            yield msg


class RecordSource:
    """A flight record replayed as telemetry (the *record player*).

    Any log the planner reads (``read_log``: DataFlash, ULog, tlog, CSV with a column map)
    becomes, row by row: ``battery`` (voltage, current, consumed; remaining unknown),
    ``hud`` (airspeed — the ground speed where the record has none —, ground speed, climb
    rate, throttle), ``local`` (the track dead-reckoned from ground speed and course, home at
    the first row; no course: no horizontal motion), ``wind`` where the record has it, a
    ``state`` (armed) at the start and ``flight`` at each new experiment. Paced at ``rate``
    × real time (0: no pacing).
    """

    def __init__(self, path: str | os.PathLike, rate: float = 1.0, column_map=None,
                 experiment: str | None = None):
        from planner.io.logs import read_log

        opts = {"map": column_map} if column_map is not None else {}
        df, meta = read_log(path, **opts)
        if experiment is not None:
            if "experiment" not in df.columns or not (df["experiment"].astype(str)
                                                      == str(experiment)).any():
                have = (sorted(map(str, df["experiment"].unique()))[:10]
                        if "experiment" in df.columns else [])
                raise InputError(f"{path}: no flight {experiment!r} in the record (flights: "
                                 f"{', '.join(have) or 'one, unnamed'})")
            df = df[df["experiment"].astype(str) == str(experiment)]
        self.record, self.meta, self.rate = df.reset_index(drop=True), meta, float(rate)
        self.path = str(path)

    def events(self) -> Iterator[Event]:
        """The record's samples as stream events, in time order (paced by the replay rate)."""
        df = self.record

        def col(name):
            return (df[name].to_numpy(float) if name in df.columns
                    else np.full(len(df), np.nan))

        t = col("time_s")
        volt, cur, cons = col("voltage_v"), col("current_a"), col("consumed_mah")
        alt, climb, gs = col("altitude_m"), col("climb_rate_ms"), col("groundspeed_ms")
        course, aspd, thr = col("course_deg"), col("airspeed_ms"), col("throttle")
        wn, we = col("wind_n_ms"), col("wind_e_ms")
        exp = (df["experiment"].astype(str).to_numpy() if "experiment" in df.columns
               else np.full(len(df), ""))
        # dead-reckoned track per experiment (vectorised); NaN speeds count as none
        rad = np.radians(np.nan_to_num(course))
        has_course = np.isfinite(course) & np.isfinite(gs)
        vn = np.where(has_course, gs * np.cos(rad), 0.0)
        ve = np.where(has_course, gs * np.sin(rad), 0.0)
        new = np.r_[True, exp[1:] != exp[:-1]]
        dt = np.r_[0.0, np.diff(t)]
        dt[new | ~np.isfinite(dt) | (dt < 0)] = 0.0
        group = np.cumsum(new) - 1
        east = np.cumsum(ve * dt)
        north = np.cumsum(vn * dt)
        first = np.flatnonzero(new)
        east -= east[first][group]
        north -= north[first][group]
        air = np.where(np.isfinite(aspd), aspd, gs)
        vtype = self.meta.get("vehicle_type") or "multirotor"
        start_file = start_wall = None
        for k in range(len(df)):
            tk = float(t[k])
            if self.rate > 0 and math.isfinite(tk):
                if start_file is None or new[k]:
                    start_file, start_wall = tk, time.monotonic()
                wait = start_wall + (tk - start_file) / self.rate - time.monotonic()
                if wait > 0:
                    time.sleep(min(wait, 5.0))
            if new[k]:
                yield Event("flight", tk, (exp[k],))
                yield Event("state", tk, (True, "record", vtype, 0))
            yield Event("battery", tk, (volt[k], cur[k], cons[k], _NAN))
            yield Event("hud", tk, (air[k], gs[k], climb[k], thr[k]))
            yield Event("local", tk, (east[k], north[k], alt[k], vn[k], ve[k],
                                      -climb[k] if math.isfinite(climb[k]) else 0.0))
            if math.isfinite(wn[k]) and math.isfinite(we[k]):
                yield Event("wind", tk, (wn[k], we[k], _NAN))


@dataclass
class Source:
    """An open source: its events, and what it can send (``send`` None: it cannot)."""

    spec: ConnectionSpec
    link: LiveLink | None = None
    tlog: TlogSource | None = None
    record: RecordSource | None = None
    decoder: MavlinkDecoder | None = None
    extra: dict = field(default_factory=dict)


def open_source(spec: ConnectionSpec, *, rate: float = 1.0, system_id: int | None = None,
                download: bool = True, column_map=None, experiment: str | None = None
                ) -> Source:
    """Open the source of a connection (module notes).

    ``download``: on a live link, download the vehicle's mission (read requests only);
    False sends nothing unless asked (:meth:`LiveLink.send`).
    """
    if spec.kind == "log":
        return Source(spec, record=RecordSource(spec.address, rate, column_map, experiment))
    if spec.kind == "tlog":
        return Source(spec, tlog=TlogSource(spec.address, rate),
                      decoder=MavlinkDecoder(system_id))
    link = LiveLink(spec)
    return Source(spec, link=link,
                  decoder=MavlinkDecoder(system_id, link.send if download else None))
