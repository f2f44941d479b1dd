"""MAVLink telemetry log reader: real tlogs (against pymavlink) and a synthetic one."""

import struct
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from pymavlink import mavutil

from planner.errors import InputError
from planner.io.logs import LogWarning, detect_format, read_log
from planner.io.logs.tlog import FIELD_MAP, read_tlog
from planner.io.record import validate_record

GROUND = "ardupilot_copter_ac34dev_fs-batt_ground.tlog"
SITL = "ardupilot_quadplane_sitl_vtol.tlog"


@pytest.fixture(scope="module")
def logs_dir(shared_data):
    return shared_data / "logs"


def pymavlink_rows(path, mtype):
    c = mavutil.mavlink_connection(str(path))
    rows = []
    while True:
        m = c.recv_match(type=mtype)
        if m is None:
            break
        rows.append((m._timestamp, m.to_dict()))
    c.close()
    return rows


def test_ground_tlog_battery_equals_pymavlink(logs_dir):
    path = logs_dir / GROUND
    df, meta = read_log(path)
    validate_record(df, path)
    ref = pymavlink_rows(path, "SYS_STATUS")
    t = np.array([r[0] for r in ref])
    assert len(df) == len(ref) == 26                              # PROVENANCE
    assert_allclose(df["time_s"], t - t[0], atol=1e-9)
    assert_allclose(df["voltage_v"], [r[1]["voltage_battery"] / 1000 for r in ref], rtol=1e-12)
    assert_allclose(df["current_a"], [r[1]["current_battery"] / 100 for r in ref], rtol=1e-12)
    # PROVENANCE: 11.57–11.62 V; 0.25 / 0.43 A; 20.2 s
    assert df["voltage_v"].min() == pytest.approx(11.57, abs=0.006)
    assert df["voltage_v"].max() == pytest.approx(11.62, abs=0.006)
    assert df["current_a"].mean() == pytest.approx(0.25, abs=0.006)
    assert df["current_a"].max() == pytest.approx(0.43, abs=0.006)
    assert df["time_s"].iloc[-1] == pytest.approx(20.2, abs=0.3)
    # no BATTERY_STATUS: consumed charge is the integral of the current
    assert meta["channels"]["consumed_mah"] == "trapezoid integral of current_a"
    assert df["consumed_mah"].iloc[-1] == pytest.approx(
        np.trapezoid(df["current_a"], df["time_s"]) / 3.6)
    assert meta["channels"]["voltage_v"] == "SYS_STATUS.voltage_battery"
    assert 95_700 < df["pressure_pa"].mean() < 95_800                # 957.5 hPa
    assert df["ambient_temperature_c"].dropna().between(32.3, 33.5).all()
    assert meta["firmware"] == "APM:Copter V3.4-dev (a3c91424)"
    assert meta["vehicle_type"] == "multirotor" and meta["system_id"] == 1
    assert meta["battery_capacity_mah"] == 2650.0                    # PARAM_VALUE


def test_sitl_tlog_without_battery(logs_dir):
    path = logs_dir / SITL
    with pytest.raises(InputError, match=r"ardupilot_quadplane_sitl_vtol\.tlog: no battery "
                                         r"voltage/current in this log"):
        read_log(path)
    with pytest.warns(LogWarning, match="no battery voltage/current; time base is the VFR_HUD"):
        df, meta = read_log(path, require_battery=False)
    assert "voltage_v" not in df and "current_a" not in df
    hud = pymavlink_rows(path, "VFR_HUD")
    assert len(df) == len(hud) == 878
    assert_allclose(df["airspeed_ms"], [r[1]["airspeed"] for r in hud], rtol=1e-12)
    # PROVENANCE: airspeed 0.02–28.0, groundspeed 0–27.8, throttle 0–55 %, rel. alt -2.7..63.4
    assert df["airspeed_ms"].max() == pytest.approx(28.0, abs=0.05)
    assert df["groundspeed_ms"].max() == pytest.approx(27.8, abs=0.05)
    assert df["throttle"].max() == pytest.approx(0.55)
    assert df["altitude_m"].min() >= -2.7 and df["altitude_m"].max() <= 63.4
    assert df["altitude_m"].max() > 60
    assert {"QLOITER", "QLAND"} <= set(df["mode"].dropna())
    assert (df["wind_n_ms"].dropna() == 0).all()
    assert meta["vehicle_type"] == "fixed_wing"
    assert meta["firmware"] == "ArduPlane V3.10.0-dev (f2b4e06a)"


def test_field_map_coverage():
    assert {f.message for fs in FIELD_MAP.values() for f in fs} >= {
        "BATTERY_STATUS", "SYS_STATUS", "VFR_HUD", "GLOBAL_POSITION_INT", "WIND",
        "SCALED_PRESSURE", "HEARTBEAT"}


def test_detect_format(logs_dir):
    assert detect_format(logs_dir / GROUND) == "tlog"
    assert detect_format(logs_dir / SITL) == "tlog"


# ----------------------------------------------------------------------------- synthetic

def synthetic_tlog(path, n=40):
    """A PX4 vehicle (sysid 1) streaming BATTERY_STATUS, a GCS (255), another vehicle (2)."""
    vehicle = mavutil.mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    other = mavutil.mavlink.MAVLink(None, srcSystem=2, srcComponent=1)
    gcs = mavutil.mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    t0 = 1_700_000_000.0
    out = bytearray()

    def put(t, link, m):
        out.extend(struct.pack(">Q", int(t * 1e6)) + m.pack(link))

    mission = (4 << 16) | (4 << 24)        # PX4 AUTO.MISSION
    rtl = (4 << 16) | (5 << 24)            # PX4 AUTO.RTL
    for k in range(n):
        t = t0 + 0.5 * k
        put(t, gcs, gcs.heartbeat_encode(6, 8, 0, 0, 0))
        put(t + 0.01, vehicle, vehicle.heartbeat_encode(2, 12, 157, mission if k < 20 else rtl, 4))
        cells = [3950 - k] * 4 + [65535] * 6                              # mV per cell
        put(t + 0.02, vehicle, vehicle.battery_status_encode(
            0, 1, 1, 32767, cells, 2000 + 10 * k, 100 + 5 * k, -1, 80))
        put(t + 0.025, other, other.battery_status_encode(
            0, 1, 1, 2500, [22000] + [65535] * 9, 9990, 1, -1, 5))       # total in cell 0
        put(t + 0.03, vehicle, vehicle.sys_status_encode(0, 0, 0, 0, 1234, 5, 50, 0, 0, 0, 0, 0, 0))
        put(t + 0.04, vehicle, vehicle.wind_encode(90.0, 5.0, 0.0))       # from the east
        put(t + 0.05, vehicle, vehicle.global_position_int_encode(
            k * 500, 0, 0, 500_000, 1000 * k, 300, 400, -100, 0))         # cm/s N, E, D
        put(t + 0.06, vehicle, vehicle.vfr_hud_encode(12.0, 5.0, 53, 40, 500.0 + k, 1.0))
    path.write_bytes(bytes(out))
    return t0


def test_synthetic_tlog_battery_status_units_and_filters(tmp_path):
    path = tmp_path / "px4.tlog"
    synthetic_tlog(path)
    df, meta = read_tlog(path)
    assert len(df) == 40
    assert meta["channels"]["voltage_v"] == "BATTERY_STATUS.voltages"
    assert_allclose(df["voltage_v"], 4 * (3950 - np.arange(40)) / 1000)   # 4 cells, mV -> V
    assert_allclose(df["current_a"], (2000 + 10 * np.arange(40)) / 100)    # cA -> A
    assert_allclose(df["consumed_mah"], 5 * np.arange(40))                 # Δ from first
    assert "temperature_c" not in df                                       # INT16_MAX
    assert_allclose(df["time_s"], 0.5 * np.arange(40), atol=1e-6)
    assert_allclose(df["wind_e_ms"].dropna(), -5.0, atol=1e-9)  # from the east -> towards west
    assert_allclose(df["wind_n_ms"].dropna(), 0.0, atol=1e-9)
    assert_allclose(df["climb_rate_ms"].dropna(), 1.0)                     # VFR_HUD.climb
    assert_allclose(df["course_deg"].dropna(), np.degrees(np.arctan2(4, 3)))
    assert_allclose(df["groundspeed_ms"].dropna(), 5.0)
    assert_allclose(df["throttle"].dropna(), 0.40)
    assert df["mode"].iloc[5] == "MISSION" and df["mode"].iloc[-1] == "RTL"
    assert meta["system_id"] == 1 and meta["vehicle_type"] == "multirotor"


def test_sys_status_not_measured_is_nan(tmp_path):
    link = mavutil.mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    out = bytearray()
    for k in range(10):
        t = 1_700_000_000 + k
        out += struct.pack(">Q", int(t * 1e6)) + link.heartbeat_encode(
            2, 3, 81, 5, 4).pack(link)
        out += struct.pack(">Q", int(t * 1e6) + 1000) + link.sys_status_encode(
            0, 0, 0, 0, 12000 if k % 2 else 0, -1 if k < 5 else 150, 50, 0, 0, 0, 0, 0, 0
        ).pack(link)
    p = tmp_path / "s.tlog"
    p.write_bytes(bytes(out))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        df, _ = read_tlog(p)
    assert np.isnan(df["voltage_v"].to_numpy()[::2]).all()        # 0 mV = not measured
    assert_allclose(df["voltage_v"].to_numpy()[1::2], 12.0)
    assert np.isnan(df["current_a"].to_numpy()[:5]).all()         # -1 = not measured
    assert_allclose(df["current_a"].to_numpy()[5:], 1.5)
    assert set(df["mode"].dropna()) == {"LOITER"}                  # ArduCopter mode 5
