"""Play a MAVLink telemetry log as a live stream over loopback.

Sends every frame of a ``.tlog`` — the bytes as recorded, damaged frames included — to
``udpout:127.0.0.1:PORT`` at its recorded timing, sped up ``--speed`` times, so that
``endurance watch udpin:127.0.0.1:PORT`` sees the flight as if it were live. It only ever
sends to this machine (127.0.0.1), and it stops by itself: at the end of the log, after
``--max-messages`` frames or after ``--max-seconds`` of wall time, whichever comes first.
Nothing it receives is read or forwarded.

Run::

    python tools/play_tlog.py FLIGHT.tlog --port 14550 --speed 20
"""

from __future__ import annotations

import argparse
import socket
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:          # run as a script from anywhere
    sys.path.insert(0, str(REPO))

from planner.io.mavlink_stream import tlog_frame  # noqa: E402

#: The only address the player sends to.
HOST = "127.0.0.1"
#: Bounds of one run.
MAX_MESSAGES = 5_000_000
MAX_SECONDS = 3600.0


def frames(data: bytes):
    """(receive time [s], frame bytes) of every MAVLink frame of a tlog, in order
    (:func:`planner.io.mavlink_stream.tlog_frame`); bytes that start no frame are stepped
    over."""
    n, ofs = len(data), 0
    while ofs + 14 <= n:
        frame = tlog_frame(data, ofs)
        if frame is None:
            ofs += 1
            continue
        end, t_us = frame
        yield t_us * 1e-6, bytes(data[ofs + 8:end])
        ofs = end


def free_port() -> int:
    """A UDP port of 127.0.0.1 free at the time of the call."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind((HOST, 0))
    port = s.getsockname()[1]
    s.close()
    return port


def play(path: str | Path, port: int, *, speed: float = 1.0,
         max_messages: int = MAX_MESSAGES, max_seconds: float = MAX_SECONDS,
         start_s: float = 0.0, stop=None) -> int:
    """Send the log's frames to 127.0.0.1:``port`` (module notes); return how many.

    ``start_s``: skip the log's first seconds. ``stop``: an object with ``is_set()``
    (a :class:`threading.Event`) that ends the play early.
    """
    if not 1 <= int(port) <= 65535:
        raise ValueError(f"port must be in 1..65535, got {port}")
    if not (speed > 0 and max_messages >= 0 and max_seconds > 0):
        raise ValueError("speed and max_seconds must be > 0, max_messages >= 0")
    max_messages = min(int(max_messages), MAX_MESSAGES)
    max_seconds = min(float(max_seconds), MAX_SECONDS)
    data = Path(path).read_bytes()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sent = 0
    wall0 = time.monotonic()
    t0 = None
    try:
        for t, frame in frames(data):
            if t0 is None:
                t0 = t
            if t - t0 < start_s:
                continue
            if sent >= max_messages or (stop is not None and stop.is_set()):
                break
            wait = wall0 + (t - t0 - start_s) / speed - time.monotonic()
            if wait > 0:
                time.sleep(min(wait, 1.0))
            if time.monotonic() - wall0 > max_seconds:
                break
            try:
                sock.sendto(frame, (HOST, int(port)))
            except OSError:
                time.sleep(0.001)        # the receiver's buffer is full: a datagram lost
                continue
            sent += 1
    finally:
        sock.close()
    return sent


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("tlog", type=Path)
    ap.add_argument("--port", type=int, default=14550, help="UDP port on 127.0.0.1")
    ap.add_argument("--speed", type=float, default=1.0, help="times the recorded timing")
    ap.add_argument("--start", type=float, default=0.0, help="skip the first seconds")
    ap.add_argument("--max-messages", type=int, default=MAX_MESSAGES)
    ap.add_argument("--max-seconds", type=float, default=MAX_SECONDS)
    args = ap.parse_args(argv)
    if not args.tlog.is_file():
        print(f"error: {args.tlog}: file not found", file=sys.stderr)
        return 2
    try:
        n = play(args.tlog, args.port, speed=args.speed, max_messages=args.max_messages,
                 max_seconds=args.max_seconds, start_s=args.start)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    print(f"sent {n} messages to {HOST}:{args.port}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
