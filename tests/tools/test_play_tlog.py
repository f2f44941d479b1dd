"""The loopback player: every frame as recorded, to 127.0.0.1 only, bounded."""

import socket
import time
from pathlib import Path

import pytest

from planner.io.mavlink_stream import TlogSource
from tools.play_tlog import HOST, frames, main, play

REPO = Path(__file__).resolve().parents[2]
SIM_TLOG = REPO / "logs/sim_solo_crosswind.tlog"


def _receiver():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)
    s.settimeout(0.5)
    return s, s.getsockname()[1]


def _drain(s):
    got = []
    while True:
        try:
            got.append(s.recv(65535))
        except TimeoutError:
            return got


def test_every_frame_of_the_log_is_found_with_its_receive_time():
    data = SIM_TLOG.read_bytes()
    found = list(frames(data))
    decoded = sum(1 for _ in TlogSource(SIM_TLOG, rate=0).messages())
    assert len(found) == decoded
    times = [t for t, _ in found]
    assert times == sorted(times) and 300 < times[-1] - times[0] < 500


def test_the_player_sends_the_recorded_bytes_to_this_machine_and_stops_at_its_bound():
    assert HOST == "127.0.0.1"
    s, port = _receiver()
    try:
        sent = play(SIM_TLOG, port, speed=1e6, max_messages=300)
        got = _drain(s)
    finally:
        s.close()
    assert sent == 300 and len(got) == 300
    first = [f for _, f in frames(SIM_TLOG.read_bytes())][:300]
    assert got == first


def test_the_player_keeps_the_recorded_timing_sped_up():
    s, port = _receiver()
    start = time.monotonic()
    try:
        n = play(SIM_TLOG, port, speed=100.0, max_seconds=1.0)
    finally:
        s.close()
    took = time.monotonic() - start
    assert 0.9 < took < 3.0
    # about 100 s of the flight in 1 s of wall time: ~2200 of its 8136 frames
    assert 1000 < n < 4000


@pytest.mark.parametrize("kwargs", [{"speed": 0.0}, {"max_seconds": -1.0}])
def test_bad_settings_are_refused(kwargs):
    with pytest.raises(ValueError):
        play(SIM_TLOG, 14550, **kwargs)
    with pytest.raises(ValueError):
        play(SIM_TLOG, 0)


def test_the_command_line_says_what_it_sent(capsys, tmp_path):
    s, port = _receiver()
    try:
        assert main([str(SIM_TLOG), "--port", str(port), "--speed", "1e6",
                     "--max-messages", "50"]) == 0
    finally:
        s.close()
    assert f"sent 50 messages to 127.0.0.1:{port}" in capsys.readouterr().out
    assert main([str(tmp_path / "missing.tlog")]) == 2
