"""The MAVLink stream reader: connection strings, the boot clock, decoding into events,
the mission protocol, robustness to damaged frames and other systems."""

import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav

from planner.errors import InputError
from planner.io.mavlink_stream import (
    MavlinkDecoder,
    MissionCapture,
    MissionClient,
    StreamClock,
    TlogSource,
    parse_connection,
    split_home,
    statustext_chunks,
)

SIM_TLOG = "logs/sim_solo_crosswind.tlog"


def _link(sysid=1, comp=1):
    return mav.MAVLink(None, srcSystem=sysid, srcComponent=comp)


def _decoded(msg, link):
    """A message as the receiver sees it: packed, then parsed (src system set)."""
    buf = msg.pack(link)
    return mav.MAVLink(None).decode(bytearray(buf))


def _heartbeat(link, armed=True, autopilot=3, mtype=2, custom_mode=3):
    return _decoded(mav.MAVLink_heartbeat_message(mtype, autopilot, 128 if armed else 0,
                                                  custom_mode, 4, 3), link)


# --------------------------------------------------------------------------- connections

@pytest.mark.parametrize("text, kind, address", [
    ("udpin:127.0.0.1:14550", "udpin", "127.0.0.1:14550"),
    ("udp:0.0.0.0:14551", "udpin", "0.0.0.0:14551"),
    ("udpout:10.0.0.2:14550", "udpout", "10.0.0.2:14550"),
    ("tcp:localhost:5760", "tcp", "localhost:5760"),
])
def test_network_connections_parse_to_their_kind_and_address(text, kind, address):
    spec = parse_connection(text)
    assert (spec.kind, spec.address) == (kind, address)


@pytest.mark.parametrize("text", ["udpin:127.0.0.1", "udpin:127.0.0.1:0", "tcp::5760",
                                  "udpout:host:99999", "udpbcast:1.2.3.4:14550",
                                  "nonsense", "/no/such/device:57600"])
def test_bad_connections_are_refused_with_one_line(text):
    with pytest.raises(InputError) as err:
        parse_connection(text)
    assert "\n" not in str(err.value) and "connection" in str(err.value)


def test_log_files_are_replay_sources(tmp_path):
    assert parse_connection(SIM_TLOG).kind == "tlog"
    assert parse_connection("logs/sim_solo_calm.bin").kind == "log"
    with pytest.raises(InputError, match="file not found"):
        parse_connection(str(tmp_path / "none.tlog"))


# --------------------------------------------------------------------------- clock

def test_the_clock_follows_the_boot_time_between_readings():
    c = StreamClock()
    assert c.update(100.0, 5000.0) is False
    assert c.now(5000.5) == pytest.approx(100.5)
    assert c.update(101.0, 5001.0) is False
    assert c.now(5001.25) == pytest.approx(101.25)


def test_a_boot_clock_going_back_twice_is_a_reboot_and_small_steps_back_are_not():
    c = StreamClock()
    c.update(300.0, 0.0)
    assert c.update(299.5, 0.1) is False          # out of order by half a second
    assert c.update(3.0, 1.0) is False            # one message: not yet
    assert c.now(1.0) == pytest.approx(301.0)
    assert c.update(3.2, 1.2) is True             # confirmed: rebooted
    assert c.now(2.2) == pytest.approx(4.2)


def test_one_stale_message_from_before_a_reboot_does_not_restart_the_clock():
    c = StreamClock()
    c.update(300.0, 0.0)
    assert c.update(5.0, 0.5) is False
    assert c.update(301.0, 1.0) is False          # the old clock goes on
    assert c.now(1.0) == pytest.approx(301.0)


def test_a_boot_clock_running_faster_than_the_receive_clock_is_followed():
    c = StreamClock()
    c.update(10.0, 0.0)
    assert c.update(50.0, 1.0) is False           # a log replayed 40 times faster
    assert c.now(1.0) == pytest.approx(50.0)


# --------------------------------------------------------------------------- decoding

def test_battery_messages_become_volts_amps_and_milliamp_hours():
    link = _link()
    dec = MavlinkDecoder()
    dec.decode(_heartbeat(link), 0.0)
    pos = _decoded(mav.MAVLink_global_position_int_message(60_000, 0, 0, 0, 0, 0, 0, 0, 0),
                   link)
    dec.decode(pos, 0.0)
    sys_status = _decoded(mav.MAVLink_sys_status_message(0, 0, 0, 0, 15_321, 1_234, 57,
                                                         0, 0, 0, 0, 0, 0), link)
    (ev,) = dec.decode(sys_status, 0.5)
    assert ev.kind == "battery" and ev.time_s == pytest.approx(60.5)
    v, i, consumed, remaining = ev.data
    assert (v, i, remaining) == (pytest.approx(15.321), pytest.approx(12.34), pytest.approx(0.57))
    assert math.isnan(consumed)
    bs = _decoded(mav.MAVLink_battery_status_message(
        0, 1, 1, 32767, [4100, 4101, 4099, 4100] + [65535] * 6, 1500, 812, -1, 40), link)
    (ev,) = dec.decode(bs, 0.6)
    assert ev.data[0] == pytest.approx(16.4) and ev.data[1] == pytest.approx(15.0)
    assert ev.data[2] == 812 and ev.data[3] == pytest.approx(0.40)


def test_unmeasured_battery_values_are_nan():
    link = _link()
    dec = MavlinkDecoder()
    dec.decode(_heartbeat(link), 0.0)
    msg = _decoded(mav.MAVLink_sys_status_message(0, 0, 0, 0, 65535, -1, -1, 0, 0, 0, 0, 0,
                                                  0), link)
    events = dec.decode(msg, 3.0)                  # after the boot-clock wait
    (ev,) = [e for e in events if e.kind == "battery"]
    assert all(math.isnan(x) for x in ev.data)


def test_ardupilot_wind_comes_from_its_direction_and_px4_wind_is_the_air_velocity():
    link = _link()
    dec = MavlinkDecoder()
    dec.decode(_heartbeat(link), 0.0)
    dec.decode(_decoded(mav.MAVLink_global_position_int_message(1000, 0, 0, 0, 0, 0, 0, 0, 0),
                        link), 0.0)
    (ev,) = dec.decode(_decoded(mav.MAVLink_wind_message(270.0, 6.0, 0.0), link), 0.1)
    wn, we, _ = ev.data       # from the west: the air moves east
    assert wn == pytest.approx(0.0, abs=1e-9) and we == pytest.approx(6.0)
    (ev,) = dec.decode(_decoded(mav.MAVLink_wind_cov_message(0, -3.0, 1.0, 0, 0.25, 0, 0, 0,
                                                             0), link), 0.2)
    assert ev.data == (pytest.approx(-3.0), pytest.approx(1.0), pytest.approx(0.25))


def test_px4_integer_parameters_sent_as_float_bytes_are_read_as_integers():
    import struct
    link = _link(1, 1)
    dec = MavlinkDecoder()
    dec.decode(_heartbeat(link, autopilot=12), 0.0)
    dec.decode(_decoded(mav.MAVLink_global_position_int_message(1000, 0, 0, 0, 0, 0, 0, 0, 0),
                        link), 0.0)
    raw = struct.unpack("<f", struct.pack("<i", 6))[0]
    (ev,) = dec.decode(_decoded(mav.MAVLink_param_value_message(b"BAT1_N_CELLS", raw, 6, 900,
                                                                3), link), 0.1)
    assert ev.data == ("BAT1_N_CELLS", 6.0)
    (ev,) = dec.decode(_decoded(mav.MAVLink_param_value_message(b"BAT1_V_EMPTY", 3.6, 9, 900,
                                                                4), link), 0.1)
    assert ev.data[1] == pytest.approx(3.6)
    assert dec.decode(_decoded(mav.MAVLink_param_value_message(b"MPC_XY_VEL", 5.0, 9, 900,
                                                               5), link), 0.1) == []


def test_a_second_system_and_the_ground_station_are_ignored():
    vehicle, other, gcs = _link(1), _link(2), _link(255, 190)
    dec = MavlinkDecoder(system_id=2)
    for link in (vehicle, gcs):
        dec.decode(_heartbeat(link, mtype=6 if link is gcs else 2), 0.0)
    status = mav.MAVLink_sys_status_message(0, 0, 0, 0, 15000, 1000, 50, 0, 0, 0, 0, 0, 0)
    assert dec.decode(_decoded(status, vehicle), 3.0) == []
    assert dec.stats.other_systems >= 2
    dec.decode(_heartbeat(other), 3.1)
    events = dec.decode(_decoded(status, other), 5.2)     # no boot clock: after the wait
    assert [e.kind for e in events] == ["state", "battery"]
    assert dec.receive_clock


def test_without_a_system_id_the_first_vehicle_heartbeat_is_locked_and_a_gcs_is_not():
    dec = MavlinkDecoder()
    dec.decode(_heartbeat(_link(255, 190), mtype=6, autopilot=8), 0.0)
    assert dec.system_id is None
    dec.decode(_heartbeat(_link(7)), 0.0)
    assert dec.system_id == 7


def test_events_before_the_first_boot_time_are_put_on_the_boot_clock():
    link = _link()
    dec = MavlinkDecoder()
    dec.decode(_heartbeat(link), 10.0)
    status = mav.MAVLink_sys_status_message(0, 0, 0, 0, 15000, 1000, 50, 0, 0, 0, 0, 0, 0)
    assert dec.decode(_decoded(status, link), 10.5) == []          # waits for a boot time
    pos = mav.MAVLink_global_position_int_message(200_000, 0, 0, 0, 0, 0, 0, 0, 0)
    events = dec.decode(_decoded(pos, link), 11.0)
    times = {e.kind: e.time_s for e in events}
    assert times["battery"] == pytest.approx(200.0) and times["position"] == pytest.approx(200.0)
    assert times["state"] == pytest.approx(200.0)


def test_a_reboot_is_an_event():
    link = _link()
    dec = MavlinkDecoder()
    dec.decode(_heartbeat(link), 0.0)
    dec.decode(_decoded(mav.MAVLink_global_position_int_message(500_000, 0, 0, 0, 0, 0, 0, 0,
                                                                0), link), 0.0)
    first = dec.decode(_decoded(mav.MAVLink_global_position_int_message(
        2_000, 0, 0, 0, 0, 0, 0, 0, 0), link), 1.0)
    assert first == [] and dec.stats.reboots == 0      # held: which clock is it?
    events = dec.decode(_decoded(mav.MAVLink_global_position_int_message(
        2_200, 0, 0, 0, 0, 0, 0, 0, 0), link), 1.2)
    assert [e.kind for e in events] == ["reboot", "position", "position"]
    assert dec.stats.reboots == 1
    times = [e.time_s for e in events[1:]]
    assert times == sorted(times) and 2.0 <= times[0] and times[-1] == pytest.approx(2.2)


def test_after_a_long_silence_and_a_reboot_events_are_on_the_new_boot_clock():
    link = _link()
    dec = MavlinkDecoder()
    dec.decode(_heartbeat(link), 0.0)
    dec.decode(_decoded(mav.MAVLink_global_position_int_message(500_000, 0, 0, 0, 0, 0, 0, 0,
                                                                0), link), 0.0)
    # 100 s of silence: the vehicle was power-cycled; its heartbeat comes first
    assert dec.decode(_heartbeat(link), 100.0) == []
    assert dec.decode(_decoded(mav.MAVLink_global_position_int_message(
        3_000, 0, 0, 0, 0, 0, 0, 0, 0), link), 100.3) == []
    events = dec.decode(_decoded(mav.MAVLink_global_position_int_message(
        3_500, 0, 0, 0, 0, 0, 0, 0, 0), link), 100.8)
    assert [e.kind for e in events][0] == "reboot"
    assert max(e.time_s for e in events) < 10.0          # none on the old clock (600 s)


def test_a_damaged_log_replays_its_intact_messages(tmp_path):
    data = bytearray(open(SIM_TLOG, "rb").read())
    intact = sum(1 for _ in TlogSource(SIM_TLOG, rate=0).messages())
    for k in range(1000, len(data) - 200, 5000):        # flip a byte every 5 kB
        data[k] ^= 0xFF
    data = data[:-37]                                    # and cut the last frame
    bad = tmp_path / "damaged.tlog"
    bad.write_bytes(bytes(data))
    src = TlogSource(bad, rate=0)
    got = sum(1 for _ in src.messages())
    assert intact * 0.95 < got < intact and src.bad > 0


def test_statustext_longer_than_fifty_characters_goes_in_chunks():
    text = "Return now: home needs 1840 mAh, 1900 mAh left above reserve"
    chunks = statustext_chunks(text, 4, chunk_id=3)
    assert len(chunks) == 2 and {c.id for c in chunks} == {3}
    joined = b"".join(c.text if isinstance(c.text, bytes) else c.text.encode()
                      for c in chunks)
    assert joined.rstrip(b"\x00").decode() == text
    (one,) = statustext_chunks("Return now", 4)
    assert one.id == 0


# --------------------------------------------------------------------------- missions

def _item(seq, cmd=16, frame=3, lat=47.0, lon=8.0, alt=30.0, link=None):
    msg = mav.MAVLink_mission_item_int_message(254, 190, seq, frame, cmd, 0, 1, 0, 0, 0, 0,
                                               int(lat * 1e7), int(lon * 1e7), alt, 0)
    return _decoded(msg, link or _link())


def test_a_mission_is_captured_from_the_protocol_seen_on_the_link_whoever_asked():
    cap = MissionCapture()
    link = _link()
    assert cap.feed(_decoded(mav.MAVLink_mission_count_message(255, 190, 3, 0), link)) is None
    assert cap.feed(_item(0, link=link)) is None
    assert cap.feed(_item(2, lat=47.001, link=link)) is None
    items = cap.feed(_item(1, link=link))
    assert [it.seq for it in items] == [0, 1, 2]
    assert items[2].params[4] == pytest.approx(47.001) and items[0].origin == "item 0"


def test_ardupilot_keeps_home_as_item_zero_px4_does_not():
    cap = MissionCapture()
    cap.feed(_decoded(mav.MAVLink_mission_count_message(255, 190, 2, 0), _link()))
    cap.feed(_item(0, frame=0, lat=47.5, lon=8.5, alt=410.0))
    items = cap.feed(_item(1))
    home, rest = split_home(items, autopilot=3)
    assert home == (pytest.approx(47.5), pytest.approx(8.5), pytest.approx(410.0))
    assert [it.seq for it in rest] == [1]
    assert split_home(items, autopilot=12) == (None, items)


def test_the_mission_client_asks_for_every_item_then_acknowledges():
    sent = []
    client = MissionClient(sent.append, timeout_s=1.0, retries=2)
    client.start((1, 1), now=0.0)
    assert sent[-1].get_type() == "MISSION_REQUEST_LIST"
    link = _link()
    count = _decoded(mav.MAVLink_mission_count_message(254, 190, 2, 0), link)
    client.on_message(count, 0.1)
    assert sent[-1].get_type() == "MISSION_REQUEST_INT" and sent[-1].seq == 0
    client.poll(0.5)
    assert len(sent) == 2                               # not timed out yet
    client.poll(1.2)
    assert sent[-1].seq == 0 and len(sent) == 3         # asked again
    client.on_message(_item(0), 1.3)
    client.on_message(_item(1), 1.4)
    assert sent[-1].get_type() == "MISSION_ACK" and client.state == "done"
    assert all(m.get_type().startswith("MISSION_") for m in sent)


def test_the_mission_client_gives_up_then_tries_again_after_the_back_off():
    sent = []
    client = MissionClient(sent.append, timeout_s=1.0, retries=2, backoff_s=10.0)
    client.start((1, 1), 0.0)
    for t in (1.5, 3.0, 4.5, 6.0):
        client.poll(t)
    assert client.state == "failed" and len(sent) == 3
    client.poll(12.0)
    assert client.state == "failed"
    client.poll(17.0)
    assert client.state == "count" and sent[-1].get_type() == "MISSION_REQUEST_LIST"


def test_answers_addressed_to_another_ground_station_do_not_drive_our_download():
    sent = []
    client = MissionClient(sent.append)
    client.start((1, 1), 0.0)
    other = _decoded(mav.MAVLink_mission_count_message(255, 190, 5, 0), _link())
    client.on_message(other, 0.1)
    assert client.state == "count"


def _downloading():
    """A decoder that has seen the vehicle (heartbeat, position) and asked for its mission:
    (decoder, what it sent, the vehicle's link)."""
    sent = []
    link = _link()
    dec = MavlinkDecoder(send=sent.append)
    dec.decode(_heartbeat(link), 0.0)
    dec.decode(_decoded(mav.MAVLink_global_position_int_message(1000, 0, 0, 0, 0, 0, 0, 0, 0),
                        link), 0.0)
    return dec, sent, link


def test_a_changed_mission_count_reported_by_the_vehicle_starts_a_new_download():
    dec, sent, link = _downloading()
    assert sent[-1].get_type() == "MISSION_REQUEST_LIST"
    dec.decode(_decoded(mav.MAVLink_mission_count_message(254, 190, 2, 0), link), 0.1)
    dec.decode(_item(0, link=link), 0.2)
    events = dec.decode(_item(1, link=link), 0.3)
    assert events[-1].kind == "mission" and dec.client.state == "done"
    n = len(sent)
    dec.decode(_decoded(mav.MAVLink_mission_current_message(1, 2, 0, 0), link), 1.0)
    assert len(sent) == n                                # same count: nothing asked
    dec.decode(_decoded(mav.MAVLink_mission_current_message(1, 5, 0, 0), link), 2.0)
    assert sent[-1].get_type() == "MISSION_REQUEST_LIST" and len(sent) == n + 1


def test_a_refused_item_request_starts_the_download_again_from_the_list():
    """The mission changed under the download: ArduPilot (MissionItemProtocol_Waypoints::
    get_item) and PX4 (MavlinkMissionManager::handle_mission_request_both) answer a request
    for an item it no longer holds with MISSION_ACK MAV_MISSION_ERROR; waiting for the
    time-outs and the back-off instead left the watcher on the old mission."""
    sent = []
    link = _link()
    client = MissionClient(sent.append, timeout_s=1.0, retries=2)
    client.start((1, 1), 0.0)
    client.on_message(_decoded(mav.MAVLink_mission_count_message(254, 190, 6, 0), link), 0.1)
    client.on_message(_item(0), 0.2)
    assert sent[-1].get_type() == "MISSION_REQUEST_INT" and sent[-1].seq == 1
    refused = _decoded(mav.MAVLink_mission_ack_message(254, 190, 1, 0), link)
    client.on_message(refused, 0.3)
    assert client.state == "count" and sent[-1].get_type() == "MISSION_REQUEST_LIST"
    # a refusal addressed to another ground station is not ours
    n = len(sent)
    client.on_message(_decoded(mav.MAVLink_mission_ack_message(255, 190, 1, 0), link), 0.4)
    assert len(sent) == n and client.state == "count"
    # refused again and again: the back-off, not a storm of requests
    for k in range(5):
        client.on_message(refused, 0.5 + 0.1 * k)
    assert client.state == "failed"


def test_a_mission_changed_during_the_download_is_downloaded_again_at_once():
    dec, sent, link = _downloading()
    dec.decode(_decoded(mav.MAVLink_mission_current_message(1, 5, 0, 0), link), 0.05)
    dec.decode(_decoded(mav.MAVLink_mission_count_message(254, 190, 6, 0), link), 0.1)
    dec.decode(_item(0, link=link), 0.2)
    assert dec.client.state == "items"
    # the vehicle now reports 2 items: the download under way fetches a stale mission
    dec.decode(_decoded(mav.MAVLink_mission_current_message(1, 2, 0, 0), link), 0.3)
    assert sent[-1].get_type() == "MISSION_REQUEST_LIST" and dec.client.state == "count"
    dec.decode(_decoded(mav.MAVLink_mission_count_message(254, 190, 3, 0), link), 0.4)
    dec.decode(_item(0, link=link), 0.5)
    dec.decode(_item(1, link=link), 0.6)
    events = dec.decode(_item(2, link=link), 0.7)
    assert events[-1].kind == "mission" and events[-1].data[0].count == 3
