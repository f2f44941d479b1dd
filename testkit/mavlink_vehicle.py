"""A simulated vehicle on loopback, for the tests of ``endurance watch``.

:class:`FakeVehicle` replays the vehicle messages of a (simulated) ``.tlog`` re-encoded as
its own MAVLink system, sends ``MISSION_CURRENT``, answers the mission protocol from its
own items, records what the watcher sends it, and injects the faults the watcher must
survive: frames with a bad CRC, truncated frames, a flood of messages, a reboot (the boot
clock and the charge counter start again), a mission changed in flight, a second vehicle
on the link, a silent spell. It sends to 127.0.0.1 only and stops by itself (at the end of
the log, or after ``max_seconds``); with ``linger_s`` it goes on answering the mission
protocol after the log, as a landed vehicle does, until the watcher has acknowledged the
mission it holds and a mission change still due has been made (or ``linger_s`` has
passed).
"""

from __future__ import annotations

import math
import socket
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mav

HOST = "127.0.0.1"
#: Message types replayed from the log.
REPLAYED = {"HEARTBEAT", "SYS_STATUS", "BATTERY_STATUS", "GLOBAL_POSITION_INT", "VFR_HUD",
            "WIND", "SCALED_PRESSURE", "PARAM_VALUE", "STATUSTEXT"}


@dataclass
class Faults:
    """Faults to inject (0 / None: none).

    Attributes
    ----------
    bad_crc_every, truncate_every : int
        Every n-th frame with a flipped payload byte / cut in half.
    flood_per_s : int
        Extra ``ATTITUDE`` messages per second of wall time (a flood).
    flood_seconds : float
        How long the flood lasts from its start. [s of wall time]
    reboot_at_s : float or None
        Log time at which the vehicle reboots. [s]
    mission_change_at_s : float or None
        Log time at which the mission is replaced by ``new_mission``, or, where the
        watcher has not yet held the mission of then for :attr:`mission_hold_s`, the
        first message after it has: a mission changed in flight replaces one the ground
        station holds and has shown (the log plays many times faster than it was flown,
        and on a busy machine the first download through the faults may take longer
        than the log leaves it). [s]
    mission_hold_s : float
        Wall time the watcher holds a mission (from its acknowledgement) before the
        vehicle may change it: longer than the watcher's interval between updates. [s]
    second_vehicle : bool
        Send every battery and position message again as system ``system_id + 1``, with
        other values.
    silent : (float, float) or None
        Log times between which nothing is sent. [s]
    """

    bad_crc_every: int = 0
    truncate_every: int = 0
    flood_per_s: int = 0
    flood_seconds: float = 1.0
    reboot_at_s: float | None = None
    mission_change_at_s: float | None = None
    mission_hold_s: float = 3.0
    second_vehicle: bool = False
    silent: tuple | None = None


def waypoint_items(home, points, alt_m=30.0, autopilot=3):
    """Mission items for ``points`` [(lat, lon), …]: a take-off, waypoints, RTL; with
    ArduPilot's home as item 0. Each item (command, frame, params[7])."""
    items = []
    if autopilot == 3:
        items.append((16, 0, (0, 0, 0, 0, home[0], home[1], home[2])))
    items.append((22, 3, (0, 0, 0, 0, 0, 0, alt_m)))
    for lat, lon in points:
        items.append((16, 3, (0, 0, 0, 0, lat, lon, alt_m)))
    items.append((20, 3, (0, 0, 0, 0, 0, 0, 0)))
    return items


@dataclass
class FakeVehicle:
    """See the module notes. Use :meth:`start`, then :meth:`join` or :meth:`stop`."""

    port: int
    tlog: Path
    system_id: int = 1
    autopilot: int = 3
    mission: list = field(default_factory=list)
    new_mission: list = field(default_factory=list)
    speed: float = 20.0
    max_seconds: float = 60.0
    faults: Faults = field(default_factory=Faults)
    received: list = field(default_factory=list)
    sent: int = 0
    served_counts: list = field(default_factory=list)
    linger_s: float = 0.0

    def __post_init__(self):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((HOST, 0))
        self.sock.setblocking(False)
        self.link = mav.MAVLink(None, srcSystem=self.system_id, srcComponent=1)
        self.other = mav.MAVLink(None, srcSystem=self.system_id + 1, srcComponent=1)
        self.parser = mav.MAVLink(None)
        self.parser.robust_parsing = True
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self.items = list(self.mission)
        self.frame_count = 0
        self.acked = False          # the watcher acknowledged the items held now
        self.acked_at = math.inf    # when it did [s of time.monotonic()]
        self.changed = False        # the mission was changed in flight

    # -- control
    def start(self) -> FakeVehicle:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=10)
        self.sock.close()

    def join(self, timeout: float | None = None) -> None:
        self._thread.join(timeout)

    @property
    def done(self) -> bool:
        return not self._thread.is_alive()

    # -- sending
    def _send_bytes(self, data: bytes) -> None:
        self.frame_count += 1
        f = self.faults
        if f.bad_crc_every and self.frame_count % f.bad_crc_every == 0 and len(data) > 12:
            b = bytearray(data)
            b[11] ^= 0x5A
            data = bytes(b)
        elif f.truncate_every and self.frame_count % f.truncate_every == 0:
            data = data[: max(1, len(data) // 2)]
        try:
            self.sock.sendto(data, (HOST, self.port))
            self.sent += 1
        except OSError:
            pass

    def _send(self, msg, link=None) -> None:
        self._send_bytes(msg.pack(link or self.link))

    # -- the mission protocol (answers to the watcher)
    def _serve(self, t_log: float) -> None:
        while True:
            try:
                data, _ = self.sock.recvfrom(65535)
            except (BlockingIOError, OSError):
                return
            try:
                msgs = self.parser.parse_buffer(data) or []
            except Exception:   # noqa: BLE001
                continue
            for m in msgs:
                if m.get_type() == "BAD_DATA":
                    continue
                self.received.append(m)
                mtype = m.get_type()
                if mtype == "MISSION_ACK" and not self.acked:
                    self.acked, self.acked_at = True, time.monotonic()
                if mtype == "MISSION_REQUEST_LIST":
                    self.served_counts.append(len(self.items))
                    self._send(mav.MAVLink_mission_count_message(
                        m.get_srcSystem(), m.get_srcComponent(), len(self.items), 0))
                elif mtype in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
                    if m.seq >= len(self.items) and (m.seq != 0 or self.autopilot != 3):
                        # an item the mission no longer holds: as ArduPilot's
                        # MissionItemProtocol_Waypoints::get_item, the count, then an error
                        self._send(mav.MAVLink_mission_count_message(
                            m.get_srcSystem(), m.get_srcComponent(), len(self.items), 0))
                        self._send(mav.MAVLink_mission_ack_message(
                            m.get_srcSystem(), m.get_srcComponent(), 1, 0))   # MAV_MISSION_ERROR
                    elif 0 <= m.seq < len(self.items):
                        cmd, frame, p = self.items[m.seq]
                        self._send(mav.MAVLink_mission_item_int_message(
                            m.get_srcSystem(), m.get_srcComponent(), m.seq, frame, cmd,
                            0, 1, p[0], p[1], p[2], p[3], int(round(p[4] * 1e7)),
                            int(round(p[5] * 1e7)), float(p[6]), 0))

    def _change_mission(self, t_log: float) -> None:
        """Replace the mission by ``new_mission`` once its time has come and the watcher
        has held the mission of now for ``mission_hold_s`` (or there is none)."""
        f = self.faults
        if f.mission_change_at_s is None or self.changed or t_log < f.mission_change_at_s:
            return
        if self.items and not (self.acked
                               and time.monotonic() - self.acked_at >= f.mission_hold_s):
            return
        self.changed = True
        self.items = list(self.new_mission)
        self.acked, self.acked_at = False, math.inf

    # -- the replay
    def _run(self) -> None:
        from planner.io.mavlink_stream import TlogSource

        f = self.faults
        src = TlogSource(self.tlog, rate=0)
        wall0 = time.monotonic()
        t0 = None
        boot_shift = 0.0
        consumed_shift = 0
        rebooted = False
        heartbeat = None
        last_current = -math.inf
        flood_start = None
        for msg in src.messages():
            if self._stop.is_set() or time.monotonic() - wall0 > self.max_seconds:
                break
            mtype = msg.get_type()
            if mtype not in REPLAYED or msg.get_srcSystem() == 255:
                continue
            t = msg._recv
            if t0 is None:
                t0 = t
            tl = t - t0
            wait = wall0 + tl / self.speed - time.monotonic()
            if wait > 0:
                self._serve(tl)
                time.sleep(min(wait, 0.05))
                wait = wall0 + tl / self.speed - time.monotonic()
                while wait > 0 and not self._stop.is_set():
                    self._serve(tl)
                    time.sleep(min(wait, 0.05))
                    wait = wall0 + tl / self.speed - time.monotonic()
            self._serve(tl)
            if f.silent and f.silent[0] <= tl < f.silent[1]:
                continue
            if f.reboot_at_s is not None and not rebooted and tl >= f.reboot_at_s:
                rebooted = True
                boot_shift = -(tl - 3.0)          # the boot clock starts again at 3 s
            if hasattr(msg, "time_boot_ms"):
                msg.time_boot_ms = max(int(msg.time_boot_ms + boot_shift * 1000), 0)
            if mtype == "BATTERY_STATUS":
                if rebooted and consumed_shift == 0:
                    consumed_shift = msg.current_consumed
                if msg.current_consumed >= 0:
                    msg.current_consumed = max(msg.current_consumed - consumed_shift, 0)
            self._change_mission(tl)
            self._send(msg)
            if mtype == "HEARTBEAT":
                heartbeat = msg
            if f.second_vehicle and mtype in ("HEARTBEAT", "SYS_STATUS", "BATTERY_STATUS",
                                              "GLOBAL_POSITION_INT"):
                if mtype == "SYS_STATUS":
                    msg.voltage_battery = int(msg.voltage_battery * 0.8)
                    msg.current_battery = int(msg.current_battery * 3)
                if mtype == "BATTERY_STATUS":
                    msg.current_battery = int(msg.current_battery * 3)
                self._send(msg, self.other)
            if self.items and tl - last_current >= 1.0:
                last_current = tl
                n = len(self.items)
                start = 1 if self.autopilot == 3 else 0
                seq = min(start + int(tl // 30), n - 1)
                self._send(mav.MAVLink_mission_current_message(seq, n, 0, 0))
            if f.flood_per_s and tl > 5.0 and flood_start is None:
                # a burst: flood_per_s messages a second for flood_seconds, nothing else
                flood_start = time.monotonic()
                vib = mav.MAVLink_vibration_message(0, 0.1, 0.2, 0.3, 0, 0, 0)
                burst = vib.pack(self.link)
                while time.monotonic() - flood_start < f.flood_seconds:
                    tick = time.monotonic()
                    for _ in range(max(1, f.flood_per_s // 100)):
                        self._send_bytes(burst)
                    self._serve(tl)
                    rest = 0.01 - (time.monotonic() - tick)
                    if rest > 0:
                        time.sleep(rest)
                wall0 += time.monotonic() - flood_start      # the log resumes where it was
        self._serve(0.0)
        # the log is over; the vehicle is still there for the mission protocol
        end = time.monotonic() + self.linger_s
        beat = -math.inf
        pending = f.mission_change_at_s is not None
        while self.items and (not self.acked or (pending and not self.changed)) \
                and not self._stop.is_set() and time.monotonic() < end:
            self._change_mission(math.inf)
            if time.monotonic() - beat >= 1.0:
                beat = time.monotonic()
                if heartbeat is not None:
                    self._send(heartbeat)
                n = len(self.items)
                self._send(mav.MAVLink_mission_current_message(n - 1, n, 0, 0))
            self._serve(0.0)
            time.sleep(0.02)
