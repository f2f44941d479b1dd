"""``endurance watch`` as a user runs it: a log replayed, a live link over loopback (only
127.0.0.1, every run bounded in time), the faults it must survive, Ctrl-C, the opt-in
warning, bad input."""

import json
import math
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from testkit.mavlink_vehicle import Faults, FakeVehicle, waypoint_items
from tools.play_tlog import free_port, play

REPO = Path(__file__).resolve().parents[3]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
SIM_TLOG = REPO / "logs/sim_solo_crosswind.tlog"
HOME = (48.0468, 10.4452, 598.0)       # the simulated flights' home
REQUIRED = ("time_s", "time_to_reserve_s", "time_to_reserve_p5_s", "time_to_reserve_p95_s",
            "charge_above_reserve_mah", "mission_remaining_mah", "return_home_mah",
            "landing_margin_mah", "point_of_no_return_in_s", "link_age_s", "mission_item")


def run(*args, timeout=300):
    return subprocess.run([sys.executable, "-m", "planner", "watch", *args],
                          capture_output=True, text=True, cwd=REPO, timeout=timeout)


def run_here(capsys, monkeypatch, *args):
    """The command in this process: (exit status, stdout, stderr)."""
    from planner.cli.main import main

    monkeypatch.chdir(REPO)
    code = main(["watch", *args])
    out = capsys.readouterr()
    return code, out.out, out.err


def finish(w, vehicle, settle=2.0):
    """Ctrl-C the watcher once the vehicle is done: (stdout, stderr)."""
    vehicle.join(60)
    time.sleep(settle)
    w.send_signal(signal.SIGINT)
    return w.communicate(timeout=60)


def start_watch(port, jsonl, *extra, duration=40):
    """The watcher in its own process, listening on 127.0.0.1:port; returns once bound."""
    p = subprocess.Popen([sys.executable, "-m", "planner", "watch", f"udpin:127.0.0.1:{port}",
                          "--aircraft", SOLO, "--payload", "0.35", "--jsonl", str(jsonl),
                          "--duration", str(duration), "--silent-after", "2", *extra],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO)
    return wait_bound(p, port)


def wait_bound(p, port):
    """``p`` once the watcher holds its UDP port (it is listening)."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            probe.bind(("127.0.0.1", port))
        except OSError:
            return p                       # the watcher holds the port: it is listening
        finally:
            probe.close()
        if p.poll() is not None:
            raise AssertionError(p.stderr.read())
        time.sleep(0.1)
    p.kill()
    raise AssertionError("the watcher did not bind its port")


def rows(path):
    return [json.loads(line) for line in Path(path).read_text().splitlines()]


def mission():
    pts = [(HOME[0] + 0.001, HOME[1]), (HOME[0] + 0.001, HOME[1] + 0.0015),
           (HOME[0], HOME[1] + 0.0015)]
    return waypoint_items(HOME, pts, 30.0)


# --------------------------------------------------------------------------- a log replayed

@pytest.fixture(scope="module")
def replayed(tmp_path_factory):
    out = tmp_path_factory.mktemp("watch") / "w.jsonl"
    p = run(str(SIM_TLOG), "--aircraft", SOLO, "--payload", "0.35", "--rate", "0",
            "--every", "5", "--mission", "missions/survey_quad.yaml", "--jsonl", str(out))
    return p, rows(out)


def test_a_replayed_log_gives_one_json_object_per_update(replayed):
    p, data = replayed
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr and "last estimate:" in p.stdout
    assert len(data) > 50
    for row in data:
        assert all(key in row for key in REQUIRED)
    times = [r["time_s"] for r in data]
    assert times == sorted(times) and times[-1] - times[0] > 300
    flying = [r for r in data if r["airborne"]]
    assert flying and all(r["time_to_reserve_p5_s"] <= r["time_to_reserve_s"]
                          <= r["time_to_reserve_p95_s"] for r in flying)
    assert all(r["mission_remaining_mah"] is not None for r in flying[:-5])
    # the rest of the mission shrinks as it is flown
    assert flying[-10]["mission_remaining_mah"] < flying[5]["mission_remaining_mah"]


def test_the_plain_output_prints_lines_with_units(replayed):
    p, _ = replayed
    lines = [x for x in p.stdout.splitlines() if x.startswith("t ") and ": to reserve" in x]
    assert lines and "to reserve" in lines[-1] and " mAh" in lines[-1] and "\x1b[" not in p.stdout


def test_jsonl_to_standard_output_moves_the_display_to_standard_error(capsys, monkeypatch):
    code, out, err = run_here(capsys, monkeypatch, str(SIM_TLOG), "--aircraft", SOLO,
                              "--rate", "0", "--every", "60", "--jsonl", "-")
    assert code == 0, err
    data = [json.loads(x) for x in out.splitlines()]
    assert data and all("time_to_reserve_s" in d for d in data)
    assert "last estimate:" in err


def test_a_record_is_played_by_the_record_player(capsys, monkeypatch):
    code, out, err = run_here(capsys, monkeypatch, "logs/sim_solo_calm.bin", "--aircraft",
                              SOLO, "--payload", "0.35", "--rate", "0", "--every", "30",
                              "--print-every", "60")
    assert code == 0, err
    assert "time to reserve" in out and "min" in out


@pytest.mark.parametrize("args, says", [
    (["udpin:127.0.0.1", "--aircraft", SOLO], "HOST:PORT"),
    ([str(SIM_TLOG), "--aircraft", SOLO, "--send-warnings"], "--send-warnings"),
    ([str(SIM_TLOG), "--aircraft", SOLO, "--reserve", "150%"], "--reserve"),
    ([str(SIM_TLOG), "--aircraft", SOLO, "--reserve", "px4-nonsense"], "px4-critical"),
    ([str(SIM_TLOG), "--aircraft", SOLO, "--reserve", "9V"], "--reserve"),
    ([str(SIM_TLOG), "--aircraft", SOLO, "--capacity", "-5"], "--capacity"),
    ([str(SIM_TLOG), "--aircraft", SOLO, "--jsonl", "/no/such/folder/x.jsonl"], "--jsonl"),
    ([str(SIM_TLOG), "--aircraft", SOLO, "--map", "dji_m100"], "--map"),
    # the payload and wind rules of check and select: a value in grams or km/h says so
    ([str(SIM_TLOG), "--aircraft", SOLO, "--payload", "350"], "grams?"),
    ([str(SIM_TLOG), "--aircraft", SOLO, "--wind", "60@270"], "km/h?"),
])
def test_bad_input_exits_2_with_one_line(args, says, capsys, monkeypatch):
    code, out, err = run_here(capsys, monkeypatch, *args)
    assert code == 2, out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and says in lines[0] and "Traceback" not in err


def test_the_output_is_never_an_input(tmp_path, capsys, monkeypatch):
    log = tmp_path / "flight.tlog"
    log.write_bytes(SIM_TLOG.read_bytes())
    link = tmp_path / "same.jsonl"
    link.symlink_to(log)
    for target in (log, link):
        code, out, err = run_here(capsys, monkeypatch, str(log), "--aircraft", SOLO,
                                  "--jsonl", str(target))
        assert code == 2 and "input file" in err
    assert log.read_bytes() == SIM_TLOG.read_bytes()


def test_the_default_connection_listens_on_this_machine_only():
    from planner.cli.main import build_parser

    args = build_parser().parse_args(["watch", "--aircraft", SOLO])
    assert args.connection == "udpin:127.0.0.1:14550"


# --------------------------------------------------------------------------- live links

def test_a_log_played_over_loopback_predicts_as_the_file_replay_does(tmp_path, replayed):
    port = free_port()
    out = tmp_path / "live.jsonl"
    w = start_watch(port, out, "--mission", "missions/survey_quad.yaml", duration=60)
    sent = play(SIM_TLOG, port, speed=40.0, max_seconds=25)
    time.sleep(1.5)
    w.send_signal(signal.SIGINT)
    stdout, stderr = w.communicate(timeout=60)
    assert w.returncode == 0, stderr
    assert sent > 8000 and "last estimate:" in stdout
    # after the first minutes (the present power is a 30-s average: its start differs)
    live = [r for r in rows(out) if r["airborne"] and not r["stale"] and r["time_s"] > 150]
    ref = {round(r["time_s"] / 5): r for r in replayed[1] if r["airborne"]}
    compared = 0
    for r in live:
        f = ref.get(round(r["time_s"] / 5))
        if f and f["time_to_reserve_s"]:
            assert r["time_to_reserve_s"] == pytest.approx(f["time_to_reserve_s"], rel=0.1)
            compared += 1
    assert compared >= 4


def test_faults_on_the_link_neither_crash_the_watcher_nor_corrupt_its_estimate(tmp_path):
    """Bad CRCs, truncated frames, a flood of 10 000 messages a second, a reboot, a
    mission changed in flight and a second vehicle on the same link, all in one flight."""
    port = free_port()
    out = tmp_path / "faults.jsonl"
    w = start_watch(port, out, "--system-id", "1", duration=60)
    items = mission()
    faults = Faults(bad_crc_every=7, truncate_every=11, flood_per_s=10_000, flood_seconds=1.0,
                    reboot_at_s=150.0, mission_change_at_s=220.0, second_vehicle=True)
    # the faults lose about one frame in four: the vehicle answers the mission protocol
    # after its log until the new mission is acknowledged, as a landed vehicle would
    v = FakeVehicle(port, SIM_TLOG, mission=items, new_mission=items[:3], speed=25.0,
                    max_seconds=30, faults=faults, linger_s=20.0).start()
    stdout, stderr = finish(w, v)
    assert w.returncode == 0, stderr
    assert "Traceback" not in stderr
    data = rows(out)
    assert data and all(key in data[-1] for key in REQUIRED)
    assert data[-1]["reboots"] == 1
    # the mission was downloaded, then again when it changed: 5 items, then 2
    counts = [r["mission_items"] for r in data if r["mission_items"] is not None]
    assert 5 in counts and counts[-1] == 2, ([m.get_type() for m in v.received], v.served_counts, counts)
    assert v.served_counts[0] == 6 and v.served_counts[-1] == 3
    # the estimate is the vehicle's own, not the second vehicle's (3 × the current)
    last = [r for r in data if r["voltage_v"]][-1]
    assert 14.0 < last["voltage_v"] < 17.0 and last["current_a"] < 30
    assert math.isfinite(last["time_to_reserve_s"]) and last["time_to_reserve_s"] > 0
    # the charge counted before the reboot is kept: about the whole flight's 1682 mAh
    assert last["consumed_mah"] > 1300
    # it sends nothing but read requests of the mission protocol
    assert {m.get_type() for m in v.received} <= {
        "MISSION_REQUEST_LIST", "MISSION_REQUEST_INT", "MISSION_ACK"}


def test_a_silent_link_is_shown_and_ctrl_c_ends_with_the_last_estimate(tmp_path):
    port = free_port()
    out = tmp_path / "silent.jsonl"
    w = start_watch(port, out, "--passive", duration=60)
    v = FakeVehicle(port, SIM_TLOG, speed=25.0, max_seconds=8,
                    faults=Faults(silent=(100.0, 250.0))).start()
    stdout, stderr = finish(w, v, settle=4.0)       # the vehicle has stopped: silence
    assert w.returncode == 0, stderr
    assert "last estimate:" in stdout and "LINK SILENT" in stdout
    data = rows(out)
    stale = [r for r in data if r["stale"]]
    assert stale and all(r["link_age_s"] > 2.0 for r in stale)
    ages = [r["link_age_s"] for r in stale]
    assert ages[-1] > ages[0]                                # the estimate ages
    ttr = [r["time_to_reserve_s"] for r in stale[-4:]]
    assert ttr == sorted(ttr, reverse=True) and ttr[0] > ttr[-1]
    assert v.received == []                                  # passive: nothing sent


def test_the_return_warning_is_one_statustext_and_nothing_else(tmp_path):
    port = free_port()
    out = tmp_path / "warn.jsonl"
    # a pack believed to hold 900 mAh: the return is due a few minutes into the flight
    w = start_watch(port, out, "--send-warnings", "--capacity", "900", duration=60)
    v = FakeVehicle(port, SIM_TLOG, mission=mission(), speed=25.0, max_seconds=20).start()
    stdout, stderr = finish(w, v)
    assert w.returncode == 0, stderr
    texts = [m for m in v.received if m.get_type() == "STATUSTEXT"]
    assert texts, stdout
    first = texts[0].text
    first = first.decode() if isinstance(first, bytes) else first
    assert first.startswith("Return now: home needs") and texts[0].severity == 4
    assert len({m.id for m in texts}) == 1                   # one warning (in chunks)
    assert {m.get_type() for m in v.received} <= {
        "STATUSTEXT", "MISSION_REQUEST_LIST", "MISSION_REQUEST_INT", "MISSION_ACK"}
    assert any(r["return_due"] for r in rows(out))


# --------------------------------------------------------------------------- real data

def test_the_m100_record_player_runs_on_a_real_flight(shared_data, capsys, monkeypatch):
    code, out, err = run_here(capsys, monkeypatch,
                              str(shared_data / "energy/m100_flights_sample.csv"), "--map",
                              "dji_m100", "--flight", "1", "--aircraft",
                              "aircraft/dji_m100.yaml", "--rate", "0", "--every", "10",
                              "--print-every", "30")
    assert code == 0, err
    assert "time to reserve" in out


def test_a_real_px4_log_streams_over_loopback(shared_data, tmp_path):
    """The McGill hover's first minutes, played at 60×: the watcher learns the hover."""
    tlog = shared_data / "logs/px4_hexa_mcgill_2022-05-24_hover_to_critical.tlog"
    port = free_port()
    out = tmp_path / "px4.jsonl"
    w = subprocess.Popen([sys.executable, "-m", "planner", "watch", f"udpin:127.0.0.1:{port}",
                          "--aircraft", "aircraft/dji_m100.yaml", "--capacity", "unknown",
                          "--reserve", "3.642V", "--jsonl", str(out), "--duration", "60",
                          "--passive"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, cwd=REPO)
    wait_bound(w, port)
    play(tlog, port, speed=60.0, max_seconds=12)
    time.sleep(1.5)
    w.send_signal(signal.SIGINT)
    stdout, stderr = w.communicate(timeout=60)
    assert w.returncode == 0, stderr
    data = [r for r in rows(out) if r["airborne"]]
    assert data
    assert 140 < data[-1]["power_w"] < 180                   # the measured hover
    assert data[-1]["time_to_reserve_s"] > 0
