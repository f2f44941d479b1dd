"""``endurance watch``: in flight, the time to the reserve along the rest of the mission.

Reads a live MAVLink link (or a log replayed as one) and predicts, at most once a second,
the charge and time left above the reserve, the charge the rest of the mission and the
way home need, the landing margin and the point of no return, each with a P5–P95 band
(:mod:`planner.identify.inflight`). Advisory only: the watcher never sends a command or
changes a mode; it sends the read requests of the mission protocol to download the
mission (not with ``--passive``) and, with ``--send-warnings``, one STATUSTEXT when the
return becomes due.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
import time
from pathlib import Path

from planner.cli.commands.common import (
    add_options, flags_for, parse_float, parse_fraction, parse_int, parse_payload,
    parse_temperature, parse_wind_option)
from planner.errors import InputError
from planner.io import files
from planner.io.mavlink_stream import (
    DEFAULT_CONNECTION,
    open_source,
    parse_connection,
    statustext_chunks,
)

#: STATUSTEXT severity of the return warning (MAV_SEVERITY_WARNING).
WARNING_SEVERITY = 4
#: A return warning is sent again only after the return has not been due this long. [s]
WARNING_REARM_S = 60.0


def register(sub) -> None:
    """Add the ``watch`` command with its options to the subcommand parsers ``sub``."""
    p = sub.add_parser(
        "watch", help="in flight: time to the reserve along the rest of the mission, live "
                      "from MAVLink",
        description="Read a live MAVLink link (or replay a log as one) and predict, at "
                    "least once a second, the charge and time left above the reserve, the "
                    "charge to fly the rest of the mission and to return home, the landing "
                    "margin and the point of no return, with P5-P95 bands, learning the "
                    "power and battery models in flight. Advisory only: it never sends a "
                    "command or changes a mode. Ctrl-C ends it with the last estimate.")
    p.add_argument("connection", nargs="?", default=DEFAULT_CONNECTION,
                   help="udpin:HOST:PORT (default udpin:127.0.0.1:14550), udpout:HOST:PORT, "
                        "tcp:HOST:PORT, a serial DEVICE:BAUD, or a log file (.tlog, .bin, "
                        ".ulg, .csv) replayed as a stream")
    add_options(p, aircraft=True, battery=True)
    p.add_argument("--mission", help="mission file (.waypoints, .plan or .yaml); default: "
                                     "downloaded from the vehicle")
    p.add_argument("--reserve", default="0.2",
                   help="landing reserve: a fraction of the pack's capacity (0.2, 20%%), an "
                        "open-circuit cell voltage (3.6V), or the firmware's own level "
                        "(px4-low, px4-critical, px4-emergency) (default 0.2)")
    p.add_argument("--capacity", metavar="MAH|unknown",
                   help="the pack's capacity [mAh], or 'unknown': learnt from the voltage "
                        "(default: the pack file's, as a label)")
    add_options(p, payload="payload mass [kg] (default: the mission's, else 0)",
                wind="forecast wind SPEED@FROM_DEG until the vehicle reports its own estimate",
                temperature="outside air temperature [°C] (default ISA)")
    p.add_argument("--jsonl", metavar="F", help="write one JSON object per update to F "
                                                "('-': standard output)")
    p.add_argument("--send-warnings", action="store_true",
                   help="send a MAVLink STATUSTEXT to the ground station when the return "
                        "becomes due (nothing else is ever sent but mission read requests)")
    p.add_argument("--passive", action="store_true",
                   help="send nothing at all: no mission download (use --mission, or a "
                        "mission another ground station downloads on the same link)")
    p.add_argument("--system-id", help="the vehicle's MAVLink system id (default: the first "
                                       "vehicle heard)")
    p.add_argument("--baud", help="serial baud rate (or DEVICE:BAUD)")
    p.add_argument("--rate", default="1",
                   help="replay speed of a log file: 1 = its recorded timing, 20 = 20 times "
                        "faster, 0 = as fast as it can be read (default 1)")
    add_options(p, map="column map of a CSV flight record (e.g. dji_m100)")
    p.add_argument("--flight", help="replay only this flight (experiment) of a record")
    p.add_argument("--every", default="1", help="seconds of flight between predictions "
                                                "(default 1, at least 1)")
    p.add_argument("--print-every", default="10",
                   help="seconds of flight between printed lines when the output is not a "
                        "terminal (default 10)")
    p.add_argument("--silent-after", default="5",
                   help="a link silent for longer [s] is shown as lost (default 5)")
    p.add_argument("--duration", help="stop after this many seconds of wall time")
    p.add_argument("--samples", default="200", help="samples of the P5-P95 bands "
                                                    "(default 200)")
    p.add_argument("--seed", default="0", help="random seed of the bands (default 0)")
    p.set_defaults(func=run)


def parse_reserve(text: str) -> tuple[float, float | None, str | None]:
    """``0.2``, ``20%`` → (0.2, None, None); ``3.6V`` → (0, 3.6, None) (an open-circuit
    cell voltage); ``px4-critical`` → (0, None, "px4-critical") (the firmware's level)."""
    from planner.identify.inflight import FIRMWARE_LEVELS

    t = text.strip()
    if t.lower() in FIRMWARE_LEVELS:
        return 0.0, None, t.lower()
    if t.lower().endswith("v"):
        v = parse_float(t[:-1], "--reserve", 2.0, 4.5)
        return 0.0, v, None
    try:
        return parse_fraction(t, "--reserve"), None, None
    except InputError:
        raise InputError(f"--reserve: expected a fraction of the capacity (0.2, 20%), an "
                         f"open-circuit cell voltage (3.6V) or one of "
                         f"{', '.join(FIRMWARE_LEVELS)}, got {text!r}") from None


def load_inputs(args):
    """Aircraft, pack (with ``--capacity``), mission, settings and environment."""
    from planner.identify.inflight import WatchSettings
    from planner.io import mavlink_mission
    from planner.io.mission import load_mission
    from planner.parameters import IntegralModel, load_aircraft_and_battery
    from planner.physics.mission import Environment

    aircraft, pack = load_aircraft_and_battery(args.aircraft, args.battery)
    known = True
    if args.capacity is not None:
        if args.capacity.strip().lower() == "unknown":
            known = False
        else:
            cap = parse_float(args.capacity, "--capacity", 10.0, 1.0e6)
            model = (IntegralModel.from_literature(pack.cells_series, cap * pack.count * 3.6)
                     if pack.model.literature else pack.model)
            pack = dataclasses.replace(pack, capacity_mah=cap, model=model)
    reserve, reserve_v, reserve_fw = parse_reserve(args.reserve)
    temperature = parse_temperature(args)
    payload = parse_payload(args, aircraft)
    mission = items = None
    env = Environment()
    if args.mission:
        mission = load_mission(args.mission, vehicle_type=aircraft.type)
        env = mission.environment
        items = mavlink_mission.items_from_file(args.mission)
        if items is not None:
            mission = None       # followed by item number (MISSION_CURRENT)
    wind = parse_wind_option(args, aircraft)
    if wind is not None:
        env = dataclasses.replace(env, wind_speed_ms=wind[0], wind_from_deg=wind[1])
    settings = WatchSettings(
        reserve=reserve, reserve_cell_v=reserve_v, reserve_firmware=reserve_fw,
        capacity_known=known, samples=parse_int(args.samples, "--samples", 20, 100_000),
        seed=parse_int(args.seed, "--seed", 0, 2**63 - 1), temperature_c=temperature,
        payload_kg=payload,
        silent_after_s=parse_float(args.silent_after, "--silent-after", 0.5, 3600.0))
    return aircraft, pack, mission, items, settings, env


# --------------------------------------------------------------------------- display

def _num(x, digits=0, unit="", sign=False):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "–"
    return f"{x:{'+' if sign else ''}.{digits}f}{unit}"


def _dur(s):
    if s is None or (isinstance(s, float) and not math.isfinite(s)):
        return "–"
    return f"{s / 60:.1f} min" if abs(s) >= 120 else f"{s:.0f} s"


def _band(p, key, fmt_one):
    lo = p.get(key[:-2] + "_p5_s") if key.endswith("_s") else p.get(key + "_p5")
    hi = p.get(key[:-2] + "_p95_s") if key.endswith("_s") else p.get(key + "_p95")
    return f"{fmt_one(p.get(key))} (P5 {fmt_one(lo)}, P95 {fmt_one(hi)})"


def render_block(p: dict, source: str) -> list[str]:
    """The terminal display of one prediction: a few lines, every number with its unit."""
    mah = (lambda x: _num(x, 0, " mAh"))
    smah = (lambda x: _num(x, 0, " mAh", sign=True))
    link = ("LINK SILENT " + _dur(p.get("link_age_s")) if p.get("stale")
            else f"link {_num(p.get('link_age_s'), 1, ' s')} ago")
    state = ("airborne" if p.get("airborne") else "armed" if p.get("armed")
             else "disarmed")
    if p.get("mission_source") is None:
        mission = "no mission"
    elif p.get("mission_source") == "legs":
        mission = f"leg {p.get('mission_leg')} of {p.get('mission_items')} (legs file)"
    else:
        item = p.get("mission_item")
        mission = (f"item {'-' if item is None else item} of {p.get('mission_items') or '?'} "
                   f"({p.get('mission_source')})")
    lines = [
        f"t {_num(p.get('time_s'), 0, ' s')}  {p.get('mode') or '-'} {state}  {mission}  "
        f"wind {_num(p.get('wind_speed_ms'), 1, ' m/s')} from "
        f"{_num(p.get('wind_from_deg'), 0, '°')}  {link}  [{source}]",
        f"battery  {_num(p.get('voltage_v'), 2, ' V')}  {_num(p.get('current_a'), 1, ' A')}  "
        f"{_num(p.get('consumed_mah'), 0, ' mAh')} drawn  SoC {_num(_pc(p.get('soc')), 0, ' %')}"
        f"  capacity {_band(p, 'capacity_mah', mah)}  R "
        f"{_num(_milli(p.get('resistance_ohm')), 0, ' mΩ')}",
        f"above reserve     {_band(p, 'charge_above_reserve_mah', mah)}",
        f"time to reserve   {_band(p, 'time_to_reserve_s', _dur)} at "
        f"{_num(p.get('power_w'), 0, ' W')} (power model × {_num(p.get('power_scale'), 2)})",
        f"rest of mission   {_band(p, 'mission_remaining_mah', mah)}",
        f"return home       {_band(p, 'return_home_mah', mah)}",
        f"landing margin    {_band(p, 'landing_margin_mah', smah)}",
        f"point of no return in {_band(p, 'point_of_no_return_in_s', _dur)}",
        f"baselines         PX4 estimator {_dur(p.get('px4_time_to_reserve_s'))}, "
        f"consumption-rate extrapolation {_dur(p.get('rate_time_to_reserve_s'))}",
    ]
    if p.get("return_due"):
        lines.append("RETURN NOW: " + return_text(p))
    return lines


def _pc(x):
    return None if x is None else 100.0 * x


def _milli(x):
    return None if x is None else 1000.0 * x


def render_line(p: dict) -> str:
    """One plain line of a prediction (output that is not a terminal)."""
    return (f"t {_num(p.get('time_s'), 0, ' s')}: to reserve "
            f"{_num(p.get('time_to_reserve_s'), 0, ' s')} "
            f"(P5 {_num(p.get('time_to_reserve_p5_s'), 0, ' s')}, "
            f"P95 {_num(p.get('time_to_reserve_p95_s'), 0, ' s')}), above reserve "
            f"{_num(p.get('charge_above_reserve_mah'), 0, ' mAh')}, mission "
            f"{_num(p.get('mission_remaining_mah'), 0, ' mAh')}, home "
            f"{_num(p.get('return_home_mah'), 0, ' mAh')}, landing margin "
            f"{_num(p.get('landing_margin_mah'), 0, ' mAh', sign=True)}, no return in "
            f"{_num(p.get('point_of_no_return_in_s'), 0, ' s')}, {_where(p)}, link "
            f"{_num(p.get('link_age_s'), 1, ' s')}" + (" SILENT" if p.get("stale") else "")
            + ("  RETURN NOW" if p.get("return_due") else ""))


def _where(p: dict) -> str:
    """Where in the mission: ``item 5``, ``leg 3/18``, or ``no mission``."""
    if p.get("mission_source") == "legs":
        return f"leg {p.get('mission_leg')}/{p.get('mission_items')}"
    if p.get("mission_source") is None:
        return "no mission"
    item = p.get("mission_item")
    return f"item {'-' if item is None else item}"


def return_text(p: dict) -> str:
    """The warning: "Return now: home needs 1840 mAh, 1900 mAh left above reserve"."""
    return (f"Return now: home needs {_num(p.get('return_home_mah'), 0, ' mAh')}, "
            f"{_num(p.get('charge_above_reserve_mah'), 0, ' mAh')} left above reserve")


class Display:
    """A terminal block refreshed in place, or plain lines (not a terminal)."""

    def __init__(self, stream, source: str, print_every_s: float):
        self.stream, self.source = stream, source
        self.tty = bool(getattr(stream, "isatty", lambda: False)())
        self.lines = 0
        self.every = print_every_s
        self.last_t = -math.inf
        self.last_flags = None

    def show(self, p: dict) -> None:
        """Show the prediction ``p``: redraw the block in place on a terminal, else print one
        line every ``print_every`` seconds of flight and whenever the link's state, the
        return's being due or the mission item changes."""
        if self.tty:
            block = render_block(p, self.source)
            up = f"\x1b[{self.lines}F\x1b[J" if self.lines else ""
            self.stream.write(up + "\n".join(block) + "\n")
            self.lines = len(block)
        else:
            if p.get("link_age_s") is None:
                return                     # no battery sample yet: nothing to say
            flags = (bool(p.get("stale")), bool(p.get("return_due")), p.get("mission_item"),
                     p.get("mission_items"))
            t = p.get("time_s") or 0.0
            if t - self.last_t >= self.every or flags != self.last_flags:
                self.stream.write(render_line(p) + "\n")
                self.last_t, self.last_flags = t, flags
        self.stream.flush()

    def final(self, p: dict | None) -> None:
        """The last estimate when the watch ends (``no telemetry received`` when there was
        none)."""
        if p is None:
            self.stream.write("no telemetry received\n")
        else:
            if self.tty and self.lines:
                self.stream.write(f"\x1b[{self.lines}F\x1b[J")
                self.lines = 0
            self.stream.write("last estimate:\n" + "\n".join(render_block(p, self.source))
                              + "\n")
        self.stream.flush()


def _clean(obj):
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    return obj


class JsonLines:
    """One JSON object per update to a file (written as it goes) or standard output."""

    def __init__(self, path: str | None, stdout):
        self.fh = None
        if path == "-":
            self.fh, self.own = stdout, False
        elif path is not None:
            files.check_output(path, "--jsonl")
            try:
                self.fh, self.own = open(path, "w", encoding="utf-8"), True  # noqa: SIM115
            except OSError as exc:
                raise InputError(f"--jsonl {path}: cannot write ({exc.strerror or exc})") \
                    from None

    def write(self, p: dict) -> None:
        """Append the prediction ``p`` as one JSON line (non-finite numbers as null) and flush."""
        if self.fh is not None:
            self.fh.write(json.dumps(_clean(p), separators=(",", ":")) + "\n")
            self.fh.flush()

    def close(self) -> None:
        """Close the file (standard output is left open)."""
        if self.fh is not None and self.own:
            self.fh.close()


# --------------------------------------------------------------------------- the loop

def run(args) -> int:
    """``endurance watch``: follow the link or replayed log and print the predictions until it
    ends or Ctrl-C; returns 0."""
    from planner.identify.inflight import InflightEstimator
    from planner.physics.kernel import compile_from_start

    compile_from_start()            # a long run: each update fast, not the start-up
    jsonl = args.jsonl
    if jsonl not in (None, "-"):
        parent = Path(jsonl).resolve().parent
        if not parent.is_dir():
            raise InputError(f"--jsonl {jsonl}: folder {parent} does not exist")
    baud = parse_int(args.baud, "--baud", 50, 20_000_000) if args.baud else None
    spec = parse_connection(args.connection, baud)
    if args.send_warnings and spec.is_file:
        raise InputError(f"--send-warnings: {args.connection} is a log replayed, there is no "
                         "ground station to warn (expected a live link)")
    if args.send_warnings and args.passive:
        raise InputError("--send-warnings and --passive: a passive watcher sends nothing "
                         "(expected one of them)")
    rate = parse_float(args.rate, "--rate", 0.0, 1.0e6)
    every = parse_float(args.every, "--every", 1.0, 3600.0)
    print_every = parse_float(args.print_every, "--print-every", 0.0, 86400.0)
    duration = (parse_float(args.duration, "--duration", 0.0, 1.0e7)
                if args.duration is not None else None)
    system_id = parse_int(args.system_id, "--system-id", 1, 255) if args.system_id else None
    if args.map is not None and spec.kind != "log":
        raise InputError(f"--map applies to a CSV flight record, not to {args.connection}")
    with flags_for(reserve="--reserve", samples="--samples"):
        aircraft, pack, mission, items, settings, env = load_inputs(args)
        est = InflightEstimator(aircraft, pack, mission=mission, mission_items=items,
                                settings=settings, environment=env)
    stdout = files.STDOUT or sys.stdout
    text_out = sys.stderr if jsonl == "-" else stdout
    # every input is opened (and so registered) before the output: it can never be one
    source = open_source(spec, rate=rate, system_id=system_id,
                         download=not args.passive and args.mission is None,
                         column_map=args.map, experiment=args.flight)
    if spec.is_file:
        files.input_path(spec.address, "log", "log file")
    try:
        out = JsonLines(jsonl, stdout)
    except InputError:
        if source.link is not None:
            source.link.close()
        raise
    display = Display(text_out, spec.text, print_every)
    warner = Warner(source.link if args.send_warnings else None)
    last = None
    try:
        last = _loop(source, est, display, out, warner, every, duration)
    except KeyboardInterrupt:
        last = est.predict() if est.t is not None else None
    finally:
        if source.link is not None:
            source.link.close()
        out.close()
    if est.t is not None:
        last = est.predict(_now(source, est))
    display.final(last)
    return 0


def _now(source, est) -> float:
    """The stream clock now: a live link's keeps running while the link is silent."""
    if source.decoder is not None and source.link is not None and est.t is not None:
        return max(source.decoder.clock.now(time.monotonic()), est.t)
    return est.t


class Warner:
    """Sends the return warning once when it becomes due (advisory STATUSTEXT)."""

    def __init__(self, link):
        self.link = link
        self.sent_at = None
        self.clear_since = None
        self.count = 0

    def update(self, p: dict, t: float) -> None:
        """Send the return-home warning (STATUSTEXT) once when the prediction ``p`` says the
        return is due at flight time ``t`` [s], and re-arm it after the return has not been
        due for :data:`WARNING_REARM_S`."""
        if self.link is None:
            return
        if p.get("return_due"):
            self.clear_since = None
            if self.sent_at is None:
                for msg in statustext_chunks(return_text(p), WARNING_SEVERITY,
                                             chunk_id=(self.count % 255) + 1):
                    self.link.send(msg)
                self.sent_at, self.count = t, self.count + 1
        elif self.sent_at is not None:
            if self.clear_since is None:
                self.clear_since = t
            elif t - self.clear_since >= WARNING_REARM_S:
                self.sent_at = None


def _emit(est, display, out, warner, now, decoder=None):
    p = est.predict(now)
    if decoder is not None:
        st = decoder.stats
        p.update(messages=st.messages, bad_frames=st.bad, other_systems=st.other_systems)
    display.show(p)
    out.write(p)
    warner.update(p, now)
    return p


def _loop(source, est, display, out, warner, every, duration):
    start = time.monotonic()
    last_pred = None
    p = None
    if source.record is not None or source.tlog is not None:
        events = (source.record.events() if source.record is not None else
                  (ev for m in source.tlog.messages()
                   for ev in source.decoder.decode(m, m._recv)))
        for ev in events:
            est.feed(ev)
            if ev.kind == "flight":
                last_pred = None
            if est.t is not None and (last_pred is None or est.t - last_pred >= every):
                last_pred = est.t
                p = _emit(est, display, out, warner, est.t, source.decoder)
            if duration is not None and time.monotonic() - start > duration:
                break
        return p
    link, dec = source.link, source.decoder
    wall_last = -math.inf
    while duration is None or time.monotonic() - start <= duration:
        for msg in link.receive(0.2):
            for ev in dec.decode(msg, msg._recv):
                est.feed(ev)
        now_wall = time.monotonic()
        dec.poll(now_wall)
        if est.t is not None and now_wall - wall_last >= every:
            wall_last = now_wall
            p = _emit(est, display, out, warner, _now(source, est), dec)
    return p
