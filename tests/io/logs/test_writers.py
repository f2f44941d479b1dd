"""Log writers: flight record → .bin / .tlog / .ulg → our readers, pymavlink and pyulog."""

import math
import struct
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from planner.errors import InputError
from planner.io.logs import read_log
from planner.io.mission import load_mission
from planner.physics.mission import Environment
from planner.parameters import load_aircraft_and_battery
from testkit.flight import simulate_flight
from testkit.writers import (
    DATAFLASH_FORMATS,
    SIMULATED_TEXT,
    ULOG_TOPICS,
    write_dataflash,
    write_log,
    write_tlog,
    write_ulog,
)

FORMATS = (".bin", ".tlog", ".ulg")

#: Largest difference read-back − written per column and format: the format's
#: quantisation (DataFlash/ULog float32; DataFlash 'c' fields 0.01; MAVLink mV,
#: cA, whole mAh, mm, c°C, float32 hPa). ``rel`` = relative to the value.
TOLERANCE = {
    ".bin": {"voltage_v": ("rel", 1e-6), "current_a": ("rel", 1e-6),
             "consumed_mah": ("abs", 1e-3), "temperature_c": ("abs", 0.005),
             "ambient_temperature_c": ("abs", 0.005), "pressure_pa": ("abs", 0.01),
             "altitude_m": ("abs", 1e-4), "climb_rate_ms": ("abs", 1e-6),
             "groundspeed_ms": ("abs", 1e-5), "course_deg": ("abs", 1e-4),
             "airspeed_ms": ("abs", 1e-5), "wind_n_ms": ("abs", 0.005),
             "wind_e_ms": ("abs", 0.005), "throttle": ("abs", 1e-6)},
    ".tlog": {"voltage_v": ("abs", 0.0005), "current_a": ("abs", 0.005),
              "consumed_mah": ("abs", 0.5), "temperature_c": ("abs", 0.005),
              "ambient_temperature_c": ("abs", 0.005), "pressure_pa": ("abs", 0.01),
              "altitude_m": ("abs", 0.0005), "climb_rate_ms": ("abs", 1e-5),
              "groundspeed_ms": ("abs", 1e-5), "course_deg": ("abs", 0.2),
              "airspeed_ms": ("abs", 1e-5), "wind_n_ms": ("abs", 1e-5),
              "wind_e_ms": ("abs", 1e-5), "throttle": ("abs", 0.005)},
    ".ulg": {"voltage_v": ("rel", 1e-6), "current_a": ("rel", 1e-6),
             "consumed_mah": ("abs", 1e-3), "temperature_c": ("abs", 1e-5),
             "ambient_temperature_c": ("abs", 1e-5), "pressure_pa": ("abs", 0.01),
             "altitude_m": ("abs", 1e-4), "climb_rate_ms": ("abs", 1e-6),
             "groundspeed_ms": ("abs", 1e-5), "course_deg": ("abs", 1e-3),
             "airspeed_ms": ("abs", 1e-5), "wind_n_ms": ("abs", 1e-6),
             "wind_e_ms": ("abs", 1e-6)},
}
#: What each format does not carry (by design of the writer or the format).
NOT_CARRIED = {
    (".bin", "multirotor"): {"airspeed_ms"},          # no airspeed sensor on a copter
    (".ulg", "multirotor"): {"airspeed_ms", "throttle"},
    (".ulg", "fixed_wing"): {"throttle"},
    (".tlog", "multirotor"): set(), (".tlog", "fixed_wing"): set(),
    (".bin", "fixed_wing"): set(),
}


def read_quiet(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")              # a written log reads without warnings
        return read_log(path, **kw)


def _short_flight(repo, aircraft, mission, legs, wind, seed):
    ac, pack = load_aircraft_and_battery(repo / aircraft)
    m = load_mission(repo / mission, vehicle_type=ac.type)
    m.legs = [m.legs[i] for i in legs]
    env = Environment(wind[0], wind[1], 15.0, m.environment.pressure_pa,
                      m.environment.site_altitude_m)
    df = simulate_flight(m, ac, pack, environment=env, rate_hz=5, temperature_c=15.0, seed=seed)
    df["throttle"] = np.linspace(0.3, 0.6, len(df))
    return df, ac, pack, m


@pytest.fixture(scope="module")
def flights(repo):
    """A short multirotor (climb, transit, lane) and fixed-wing (climb, transit) flight."""
    quad = _short_flight(repo, "aircraft/solo_survey.yaml", "missions/survey_quad.yaml",
                         (0, 1, 2), (6.0, 250.0), 1)
    plane = _short_flight(repo, "aircraft/x8_mapper.yaml", "missions/mapping_plane.yaml",
                          (0, 1), (5.0, 200.0), 2)
    return {"multirotor": quad, "fixed_wing": plane}


def _write(flights, vehicle, suffix, tmp_path):
    df, _ac, pack, m = flights[vehicle]
    path = tmp_path / f"{vehicle}{suffix}"
    opts = {"vehicle_type": vehicle, "capacity_mah": pack.capacity_mah, "home": m.home}
    if suffix == ".ulg":
        opts["cells"] = pack.cells_series
    write_log(df, path, **opts)
    return path, df


@pytest.mark.parametrize("vehicle", ["multirotor", "fixed_wing"])
@pytest.mark.parametrize("suffix", FORMATS)
def test_round_trip_gives_back_every_channel(flights, vehicle, suffix, tmp_path):
    path, df = _write(flights, vehicle, suffix, tmp_path)
    got, meta = read_quiet(path)
    assert len(got) == len(df)
    assert_allclose(got["time_s"], df["time_s"], atol=1e-6)
    assert meta["vehicle_type"] == vehicle
    assert meta["battery_capacity_mah"] == flights[vehicle][2].capacity_mah
    checked = set()
    for col, (kind, tol) in TOLERANCE[suffix].items():
        if col in NOT_CARRIED[(suffix, vehicle)]:
            assert col not in got, col
            continue
        assert col in got, f"{col} missing after the round trip"
        want, have = df[col].to_numpy(float), got[col].to_numpy(float)
        ok = np.isfinite(want)
        if col == "course_deg":       # undefined at rest: readers give NaN below 0.2 m/s
            ok &= df["groundspeed_ms"].to_numpy() > 1.0
            err = np.abs((have[ok] - want[ok] + 180.0) % 360.0 - 180.0)
        else:
            err = np.abs(have[ok] - want[ok])
        assert np.isfinite(have[ok]).all(), col
        limit = (tol * np.abs(want[ok]) if kind == "rel" else tol) * (1 + 1e-6) + 1e-12
        assert np.all(err <= limit), f"{col}: max error {err.max():.3g}"
        checked.add(col)
    assert {"voltage_v", "current_a", "consumed_mah", "altitude_m", "groundspeed_ms",
            "wind_n_ms", "wind_e_ms", "pressure_pa"} <= checked
    assert set(got["mode"]) == ({"AUTO_MISSION"} if suffix == ".ulg" else {"AUTO"})


def test_dataflash_matches_pymavlink_dfreader(flights, tmp_path):
    """pymavlink's DFReader parses every message; its BAT values are ours."""
    from pymavlink import DFReader
    path, df = _write(flights, "fixed_wing", ".bin", tmp_path)
    log = DFReader.DFReader_binary(str(path), zero_time_base=False)
    counts, bat, texts, arsp = {}, [], [], []
    while (m := log.recv_msg()) is not None:
        counts[m.get_type()] = counts.get(m.get_type(), 0) + 1
        if m.get_type() == "BAT":
            bat.append((m.TimeUS, m.Volt, m.Curr, m.CurrTot, m.Temp))
        elif m.get_type() == "MSG":
            texts.append(m.Message)
        elif m.get_type() == "ARSP":
            arsp.append(m.Airspeed)
    n = len(df)
    assert counts["BAT"] == counts["GPS"] == counts["BARO"] == counts["ARSP"] == n
    assert counts["FMT"] == len(DATAFLASH_FORMATS) + 1        # plus CTUN
    assert SIMULATED_TEXT in texts
    assert log.mav_type == 1                                  # "ArduPlane" banner → plane
    ours, _ = read_quiet(path)
    bat = np.array(bat)
    assert_allclose(bat[:, 1], ours["voltage_v"], rtol=0, atol=0)
    assert_allclose(bat[:, 2], ours["current_a"], rtol=0, atol=0)
    assert_allclose(bat[:, 3] - bat[0, 3], ours["consumed_mah"], atol=1e-9)
    assert_allclose(bat[:, 4], 15.0, atol=0.005)              # 'c' centi-degrees
    assert_allclose(np.diff(bat[:, 0]) * 1e-6, np.diff(df["time_s"]), atol=1e-6)
    assert_allclose(arsp, ours["airspeed_ms"], atol=0)


def test_dataflash_byte_layout(flights, tmp_path):
    """Each FMT length is the struct size + 3; every message starts A3 95 and chains."""
    from pymavlink.DFReader import FORMAT_TO_STRUCT
    path, _ = _write(flights, "multirotor", ".bin", tmp_path)
    data = path.read_bytes()
    lengths, ofs, seen = {}, 0, {}
    while ofs < len(data):
        assert data[ofs:ofs + 2] == b"\xa3\x95", f"no header at byte {ofs}"
        mtype = data[ofs + 2]
        if mtype == 0x80:
            t, length, name, fmt, cols = struct.unpack_from("<BB4s16s64s", data, ofs + 3)
            fmt = fmt.rstrip(b"\0").decode()
            size = struct.calcsize("<" + "".join(FORMAT_TO_STRUCT[c][0] for c in fmt))
            assert length == size + 3, name
            assert len(cols.rstrip(b"\0").decode().split(",")) == len(fmt)
            lengths[t] = length
            lengths.setdefault(0x80, 89)
        assert mtype in lengths, f"message type {mtype} before its FMT"
        seen[mtype] = seen.get(mtype, 0) + 1
        ofs += lengths[mtype]
    assert ofs == len(data)


def test_tlog_matches_pymavlink(flights, tmp_path):
    """mavutil reads every frame (CRC checked); BATTERY_STATUS values are ours."""
    from pymavlink import mavutil
    path, df = _write(flights, "multirotor", ".tlog", tmp_path)
    conn = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    rows, counts, texts = [], {}, []
    while (m := conn.recv_match()) is not None:
        counts[m.get_type()] = counts.get(m.get_type(), 0) + 1
        if m.get_type() == "BATTERY_STATUS":
            rows.append((m._timestamp, m.voltages[0], m.current_battery, m.current_consumed))
        elif m.get_type() == "STATUSTEXT":
            texts.append(m.text)
    conn.close()
    assert "BAD_DATA" not in counts
    assert counts["BATTERY_STATUS"] == counts["GLOBAL_POSITION_INT"] == len(df)
    assert counts["WIND"] >= df["time_s"].iloc[-1] and counts["HEARTBEAT"] >= 2
    assert SIMULATED_TEXT in texts
    assert conn.flightmode == "AUTO"
    ours, _ = read_quiet(path)
    rows = np.array(rows, float)
    assert_allclose(rows[:, 1] / 1000, ours["voltage_v"])
    assert_allclose(rows[:, 2] / 100, ours["current_a"])
    assert_allclose(rows[:, 3] - rows[0, 3], ours["consumed_mah"])
    assert_allclose(rows[:, 0] - rows[0, 0], ours["time_s"], atol=1e-6)


def test_ulog_matches_pyulog(flights, tmp_path):
    """pyulog reads the file cleanly; battery_status values are ours; info says simulated."""
    from pyulog import ULog
    path, _df = _write(flights, "fixed_wing", ".ulg", tmp_path)
    ulog = ULog(str(path))
    assert not ulog.file_corruption
    assert ulog.msg_info_dict["sys_name"] == "PX4"
    assert SIMULATED_TEXT in ulog.msg_info_dict["simulated"]
    assert [m.message for m in ulog.logged_messages] == [SIMULATED_TEXT]
    assert ulog.initial_parameters["MAV_TYPE"] == 1
    assert ulog.initial_parameters["BAT1_N_CELLS"] == 4
    topics = {d.name for d in ulog.data_list}
    assert topics == set(ULOG_TOPICS)
    for d in ulog.data_list:                          # field names as the reader expects
        assert [f.field_name for f in d.field_data] == [n for _, n in ULOG_TOPICS[d.name]]
    bat = ulog.get_dataset("battery_status").data
    ours, _ = read_quiet(path)
    assert_array_equal(bat["voltage_v"].astype(float), ours["voltage_v"])
    assert_array_equal(bat["current_a"].astype(float), ours["current_a"])
    assert_allclose(bat["discharged_mah"] - bat["discharged_mah"][0], ours["consumed_mah"])
    assert_allclose(bat["remaining"][0], 1.0, atol=1e-3)


@pytest.mark.parametrize("suffix", FORMATS)
def test_writing_is_deterministic(flights, suffix, tmp_path):
    paths = []
    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        paths.append(_write(flights, "multirotor", suffix, tmp_path / sub)[0])
    assert paths[0].read_bytes() == paths[1].read_bytes()
    assert SIMULATED_TEXT.encode() in paths[0].read_bytes()


@pytest.mark.parametrize("suffix", FORMATS)
def test_battery_only_record(suffix, tmp_path):
    """The smallest record (time, voltage, current): battery messages only."""
    t = np.arange(0, 60.0, 0.5)
    df = pd.DataFrame({"time_s": t, "voltage_v": 16.0 - 0.01 * t, "current_a": 10.0 + 0 * t})
    path = write_log(df, tmp_path / f"b{suffix}")
    got, _meta = read_quiet(path)
    assert len(got) == len(t)
    assert_allclose(got["voltage_v"], df["voltage_v"], atol=5e-4)
    # consumed: the trapezoid integral of the current, as the writer logs it
    assert_allclose(got["consumed_mah"], 10.0 * t / 3.6, atol=0.5 + 1e-9)
    for col in ("altitude_m", "groundspeed_ms", "pressure_pa", "wind_n_ms", "airspeed_ms",
                "temperature_c"):
        assert col not in got, col


def test_temperature_unknown_and_modes(tmp_path):
    """No temperature → 'no sensor' in every format; mode changes are logged."""
    t = np.arange(0, 20.0, 0.2)
    df = pd.DataFrame({"time_s": t, "voltage_v": 15.0, "current_a": 5.0, "altitude_m": t,
                       "mode": np.where(t < 10, "AUTO", "RTL")})
    for suffix, rtl in ((".bin", "RTL"), (".tlog", "RTL"), (".ulg", "AUTO_RTL")):
        got, _ = read_quiet(write_log(df, tmp_path / f"m{suffix}"))
        assert "temperature_c" not in got
        assert got["mode"].iloc[0] in ("AUTO", "AUTO_MISSION") and got["mode"].iloc[-1] == rtl
        assert (got["mode"] == rtl).sum() == pytest.approx((t >= 10).sum(), abs=5)


def test_bad_input(flights, tmp_path):
    df = flights["multirotor"][0]
    two = pd.concat([df.assign(experiment="a"), df.assign(experiment="b")])
    with pytest.raises(InputError, match="2 experiments"):
        write_dataflash(two, tmp_path / "x.bin")
    with pytest.raises(InputError, match="current_a"):
        write_tlog(df.drop(columns="current_a"), tmp_path / "x.tlog")
    with pytest.raises(InputError, match=r"\.csv log"):
        write_log(df, tmp_path / "x.csv")
    with pytest.raises(ValueError, match="vehicle_type"):
        write_ulog(df, tmp_path / "x.ulg", vehicle_type="helicopter")
    with pytest.raises(ValueError, match="mode 'WARP'"):
        write_dataflash(df.assign(mode="WARP"), tmp_path / "x.bin")
    back = df.copy()
    back.loc[5, "time_s"] = back.loc[4, "time_s"]
    with pytest.raises(InputError, match="strictly increasing"):
        write_ulog(back, tmp_path / "x.ulg")


def test_gps_time_and_position(flights, tmp_path):
    """GPS week/time-of-week of the start time; positions from east/north of home."""
    from pymavlink import DFReader
    path, df = _write(flights, "multirotor", ".bin", tmp_path)
    log = DFReader.DFReader_binary(str(path), zero_time_base=False)
    first = log.recv_match(type="GPS")
    # 2024-05-18 09:00:00 UTC = GPS week 2314, Saturday 09:00:18 (18 leap seconds)
    assert first.GWk == 2314
    assert first.GMS == (6 * 86400 + 9 * 3600 + 18) * 1000
    home = flights["multirotor"][3].home
    assert first.Lat == pytest.approx(home[0], abs=1e-7)
    assert first.Lng == pytest.approx(home[1], abs=1e-7)
    assert first.Alt == pytest.approx(home[2], abs=0.01)
    last = None
    while (m := log.recv_match(type="GPS")) is not None:
        last = m
    from planner.physics.geo import latlon_to_en
    e, n = latlon_to_en(last.Lat, last.Lng, home[0], home[1])
    assert e == pytest.approx(df["east_m"].iloc[-1], abs=0.02)
    assert n == pytest.approx(df["north_m"].iloc[-1], abs=0.02)
    assert math.isfinite(last.Spd)
