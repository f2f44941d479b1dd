"""PX4 ULog reader, against pyulog's own numbers and PROVENANCE.md."""

import contextlib
import io
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from pyulog import ULog

from planner.io.logs import LogWarning, detect_format, read_log
from planner.io.logs.ulog import FIELD_MAP, NAV_STATE_NAMES, read_ulog
from planner.io.record import validate_record

ULGS = ["px4_quad_fmuv6c_indoor_quadrotor_local.ulg",
        "px4_quad_fmuv3_esc_status_log.ulg",
        "px4_quad_fmuv6xrt_corrupt_unregistered_msg_id.ulg",
        "px4_vtol_cubeorange_sample_log_small.ulg"]


@pytest.fixture(scope="module")
def logs_dir(shared_data):
    return shared_data / "logs"


def read_quiet(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        return read_log(path, **kw)


def pyulog_battery(path, instance=0):
    with contextlib.redirect_stdout(io.StringIO()):
        u = ULog(str(path), ["battery_status"])
    return u.get_dataset("battery_status", instance).data


@pytest.mark.parametrize("name", ULGS)
def test_battery_channels_equal_pyulog(logs_dir, name):
    path = logs_dir / name
    df, meta = read_quiet(path)
    validate_record(df, path)
    b = pyulog_battery(path)
    t = b["timestamp"] * 1e-6
    assert len(df) == len(t)
    assert_allclose(df["time_s"], t - t[0], rtol=0, atol=1e-9)
    assert_array_equal(df["voltage_v"], b["voltage_v"].astype(float))
    assert_array_equal(df["current_a"], b["current_a"].astype(float))
    assert_allclose(df["consumed_mah"], b["discharged_mah"] - b["discharged_mah"][0], atol=1e-9)
    assert meta["time_base"] == "battery_status" and meta["format"] == "ulog"


# PROVENANCE.md: samples, V range, mean / max I, discharged at start and end, integrated
PROVENANCE = {
    "px4_quad_fmuv6c_indoor_quadrotor_local.ulg":
        (464, 28.54, 30.96, 16.50, 22.35, 14.1, 438.8, 425.2),
    "px4_quad_fmuv3_esc_status_log.ulg":
        (73, 21.75, 22.58, 55.34, 73.90, 49921.4, 50537.2, 608.6),
    "px4_quad_fmuv6xrt_corrupt_unregistered_msg_id.ulg":
        (475, 13.97, 15.19, 12.18, 22.06, 307.0, 629.9, 322.9),
    "px4_vtol_cubeorange_sample_log_small.ulg": (21, 23.34, 23.46, 0.29, 1.00, 1.59, 1.98, None),
}


@pytest.mark.parametrize("name", ULGS)
def test_provenance_numbers(logs_dir, name):
    n, vmin, vmax, imean, imax, d0, d1, integ = PROVENANCE[name]
    df, _ = read_quiet(logs_dir / name)
    assert len(df) == n
    assert df["voltage_v"].min() == pytest.approx(vmin, abs=0.006)
    assert df["voltage_v"].max() == pytest.approx(vmax, abs=0.006)
    assert df["current_a"].mean() == pytest.approx(imean, abs=0.006)
    assert df["current_a"].max() == pytest.approx(imax, abs=0.006)
    assert df["consumed_mah"].iloc[-1] == pytest.approx(d1 - d0, abs=0.1)
    if integ is not None:   # PROVENANCE "integrated": trapezoid of the logged current
        integrated = np.trapezoid(df["current_a"], df["time_s"]) / 3.6
        assert integrated == pytest.approx(integ, abs=0.1)


def test_corrupt_ulog_is_read_with_a_warning(logs_dir):
    path = logs_dir / "px4_quad_fmuv6xrt_corrupt_unregistered_msg_id.ulg"
    with pytest.warns(LogWarning, match=r"damaged ULog.*message id 32812"):
        df, meta = read_log(path)
    assert len(df) == 475 and meta["warnings"]
    # the only file with a battery temperature sensor (PROVENANCE: 20.26–20.96 °C)
    assert df["temperature_c"].min() == pytest.approx(20.26, abs=0.01)
    assert df["temperature_c"].max() == pytest.approx(20.96, abs=0.01)
    # local z -15.9 .. 10.8 m (NED) -> altitude up; at the 5 Hz battery times the
    # 10 Hz extremes are slightly cut
    assert df["altitude_m"].min() == pytest.approx(-10.8, abs=1.0)
    assert df["altitude_m"].max() == pytest.approx(15.9, abs=0.3)
    assert df["altitude_m"].dropna().between(-10.8, 15.9).all()


def test_multi_battery_keeps_instance_0_and_says_so(logs_dir):
    path = logs_dir / "px4_vtol_cubeorange_sample_log_small.ulg"
    with pytest.warns(LogWarning, match=r"2 battery_status instances; kept instance 0"):
        df, meta = read_log(path)
    assert meta["battery_instances"] == [0, 1] and meta["battery_instance"] == 0
    assert df["voltage_v"].max() < 24          # instance 0 is the 6S pack, instance 1 is 12S
    assert meta["battery_capacity_mah"] == 30000.0 and meta["battery_cells"] == 6
    assert meta["vehicle_type"] == "vtol"
    assert "temperature_c" not in df           # NaN = no sensor
    assert df["airspeed_ms"].notna().any()     # airspeed_validated present
    assert (df["wind_n_ms"].dropna() == 0).all()


def test_metadata_and_field_name_fallbacks(logs_dir):
    df, m = read_quiet(logs_dir / "px4_quad_fmuv3_esc_status_log.ulg")
    assert m["firmware"].startswith("PX4 v1.9.0-beta") and m["hardware"] == "PX4_FMU_V3"
    assert m["battery_capacity_mah"] is None and m["battery_cells"] == 6   # BAT_CAPACITY -1
    assert m["channels"]["ambient_temperature_c"] == "vehicle_air_data.baro_temp_celcius"
    assert m["channels"]["wind_n_ms"] == "wind_estimate.windspeed_north"
    assert m["channels"]["throttle"] == "actuator_controls_0.control[3]"
    assert "temperature_c" not in df                                     # 0.0 = no sensor
    # PROVENANCE: wind north -0.66..-0.01, east -1.94..-0.71
    assert df["wind_n_ms"].dropna().between(-0.67, 0.0).all()
    assert df["wind_e_ms"].dropna().between(-1.95, -0.70).all()
    assert df["mode"].dropna().unique().tolist() == ["AUTO_MISSION", "AUTO_RTL"]
    df, m = read_quiet(logs_dir / "px4_quad_fmuv6c_indoor_quadrotor_local.ulg")
    assert m["channels"]["ambient_temperature_c"] == "vehicle_air_data.ambient_temperature"
    assert m["channels"]["throttle"] == "vehicle_thrust_setpoint.xyz[2]"
    assert m["battery_cells"] == 8 and m["firmware"].startswith("PX4 v1.16.1-rc")
    assert set(df["mode"]) == {"STAB"}                                   # nav_state 15
    assert df["throttle"].dropna().between(0, 1).all() and df["throttle"].max() > 0.5
    assert "groundspeed_ms" not in df       # no GPS: v_xy_valid false, unaided vx ignored


def test_nav_state_names():
    assert NAV_STATE_NAMES[3] == "AUTO_MISSION" and NAV_STATE_NAMES[15] == "STAB"
    assert NAV_STATE_NAMES[18] == "AUTO_LAND"


def test_field_map_has_version_fallbacks():
    srcs = {c: [f.describe() for f in fs] for c, fs in FIELD_MAP.items()}
    assert srcs["voltage_v"] == ["battery_status.voltage_v", "battery_status.voltage_filtered_v"]
    assert "wind.windspeed_north" in srcs["wind_n_ms"]
    assert "wind_estimate.windspeed_north" in srcs["wind_n_ms"]


def test_detect_format(logs_dir):
    for name in ULGS:
        assert detect_format(logs_dir / name) == "ulog"
    assert read_ulog  # the reader is importable on its own


@pytest.mark.parametrize("name", ["px4_quad_fmuv3_esc_status_log.ulg",
                                  "px4_vtol_cubeorange_sample_log_small.ulg",
                                  "px4_quad_fmuv6xrt_corrupt_unregistered_msg_id.ulg"])
def test_start_time_from_the_gps_utc_equals_pyulogs_reading(logs_dir, name):
    """UTC of the first battery sample: the GPS receiver's ``time_utc_usec`` less its
    offset from the boot clock, read here independently with pyulog (the median offset
    over the fixes, moved to the first kept battery sample)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df, meta = read_log(logs_dir / name)
        with contextlib.redirect_stdout(io.StringIO()):
            ulog = ULog(str(logs_dir / name), ["vehicle_gps_position"])
    gps = ulog.data_list[0].data
    fix = gps["time_utc_usec"] > 946_684_800 * 1_000_000          # after 2000-01-01
    offset = np.median(gps["time_utc_usec"][fix] * 1e-6 - gps["timestamp"][fix] * 1e-6)
    expected = meta["time_base_start_s"] + offset
    assert meta["start_time_unix"] == pytest.approx(expected, abs=1e-3)


def test_no_start_time_without_a_gps_fix(logs_dir):
    """The indoor flight's receiver never had a fix (time_utc_usec 0): no start time."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, meta = read_log(logs_dir / "px4_quad_fmuv6c_indoor_quadrotor_local.ulg")
    assert meta.get("start_time_unix") is None
