"""ArduPilot DataFlash .bin and PX4 sdlog2 .px4log reader.

Real logs: ../shared/data/logs (skipped where absent). The reference is pymavlink's
own reader (``DFReader_binary``): every decoded field must be bit-for-bit what it
returns, and the flight record's battery channels must be its numbers. The figures
quoted from ../shared/data/logs/PROVENANCE.md are an independent cross-check.
"""

import struct
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from pymavlink import DFReader
from pymavlink.DFReader import FORMAT_TO_STRUCT

from planner.errors import InputError
from planner.io.logs import LogWarning, detect_format, read_log
from planner.io.logs.dataflash import FIELD_MAP, DataFlashLog, read_dataflash
from planner.io.record import validate_record

BINS = ["ardupilot_copter_quad_ac33dev_dronekit_log171.bin",
        "ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin",
        "ardupilot_copter_ac313_pixhawk_2014-10-18_20-44.bin",
        "px4_octo_legacy_sdlog2_01_07_59.px4log"]


@pytest.fixture(scope="module")
def logs_dir(shared_data):
    return shared_data / "logs"


_REF_CACHE: dict = {}


def pymavlink_messages(path):
    """Every message of the file through pymavlink: {type: {field: [values], '_ts': [...]}}."""
    key = str(path)
    if key not in _REF_CACHE:
        r = DFReader.DFReader_binary(str(path), zero_time_base=False)
        out = {}
        while True:
            m = r.recv_msg()
            if m is None:
                break
            t = m.get_type()
            if t == "FMT":
                continue
            d = out.get(t)
            if d is None:
                d = out[t] = {c: [] for c in m._fieldnames}
                d["_ts"] = []
            d["_ts"].append(m._timestamp)
            for c in m._fieldnames:
                d[c].append(getattr(m, c))
        r.close()
        _REF_CACHE[key] = out
    return _REF_CACHE[key]


def read_quiet(path, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        return read_log(path, **kw)


# ----------------------------------------------------------------------------- bit-for-bit

@pytest.mark.parametrize("name", BINS)
def test_fast_path_equals_pymavlink_bit_for_bit(logs_dir, name):
    path = logs_dir / name
    ref = pymavlink_messages(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        log = DataFlashLog(path)
    assert log.message_counts().keys() - {"FMT"} == ref.keys()
    n_fields = 0
    for mtype, fields in ref.items():
        ours = log.decode(mtype)
        assert log.count(mtype) == len(fields["_ts"]), mtype
        for col, values in fields.items():
            if col == "_ts":
                continue
            a = ours[col]
            n_fields += 1
            if a.dtype == object:                                    # strings
                assert a.tolist() == values, (mtype, col)
            elif a.ndim == 2:                                        # 'a' int16[32]
                assert_array_equal(a, np.array([list(v) for v in values]))
            elif a.dtype.kind == "f":
                b = np.asarray(values, dtype=np.float64)
                assert a.shape == b.shape
                assert_array_equal(a.view(np.int64), b.view(np.int64), err_msg=f"{mtype}.{col}")
            else:
                assert all(type(v) is int for v in values[:5]), (mtype, col)
                assert_array_equal(a, np.asarray(values), err_msg=f"{mtype}.{col}")
    assert n_fields > 80


@pytest.mark.parametrize("name", BINS)
def test_message_times_follow_pymavlink_clock(logs_dir, name):
    """Our boot-based times differ from pymavlink's timestamps by one constant."""
    path = logs_dir / name
    ref = pymavlink_messages(path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        log = DataFlashLog(path)
    offsets = []
    for mtype, fields in ref.items():
        ours = log.times(log.decode(mtype)["_chain"])
        ts = np.asarray(fields["_ts"])
        ok = np.isfinite(ours)       # before the first timed message pymavlink has no clock
        offsets.append(ts[ok] - ours[ok])
    off = np.concatenate(offsets)
    assert np.ptp(off) < 1e-5


# ----------------------------------------------------------------------------- flight record

def battery_reference(path):
    """(time s, voltage V, current A, consumed mAh) straight from pymavlink."""
    ref = pymavlink_messages(path)
    if "BATT" in ref and "V" in ref["BATT"]:                          # sdlog2
        b = ref["BATT"]
        return (np.asarray(ref["BATT"]["_ts"]), np.asarray(b["V"]), np.asarray(b["C"]),
                np.asarray(b["Discharged"]))
    c = ref["CURR"]
    t = np.asarray(c["TimeMS"]) * 1e-3
    return t, np.asarray(c["Volt"]) / 100.0, np.asarray(c["Curr"]) / 100.0, \
        np.asarray(c["CurrTot"], float)


@pytest.mark.parametrize("name", BINS)
def test_battery_channels_match_pymavlink(logs_dir, name):
    path = logs_dir / name
    df, meta = read_quiet(path)
    validate_record(df, path)
    t, v, i, mah = battery_reference(path)
    assert len(df) == len(t)                                   # one row per battery message
    assert df["time_s"].iloc[0] == 0.0
    assert df["time_s"].iloc[-1] == pytest.approx(t[-1] - t[0], abs=1e-6)
    assert_allclose(df["voltage_v"], v, rtol=1e-12)
    assert_allclose(df["current_a"], i, rtol=1e-12)
    assert_allclose(df["consumed_mah"], mah - mah[0], rtol=1e-12, atol=1e-9)
    assert_allclose(df["power_w"], v * i, rtol=1e-12)
    assert meta["time_base"] in ("CURR", "BATT")
    assert df["experiment"].unique().tolist() == [path.stem]


# PROVENANCE.md table: samples, duration, V range, max I, mean I, consumed delta
PROVENANCE = {
    "ardupilot_copter_quad_ac33dev_dronekit_log171.bin":
        (2384, 242.6, 14.91, 16.54, 27.44, 10.92, 1196 - 421),
    "ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin":
        (332, 331.0, 14.38, 16.44, 39.45, 26.84, 2550.1 - 66.3),
    "ardupilot_copter_ac313_pixhawk_2014-10-18_20-44.bin":
        (301, 300.0, 14.55, 16.30, 35.81, 26.65, 2242.9 - 9.7),
    "px4_octo_legacy_sdlog2_01_07_59.px4log":
        (5648, 70.5, 18.33, 24.31, 50.78, 25.53, 2113.7 - 1614.4),
}


@pytest.mark.parametrize("name", BINS)
def test_provenance_numbers(logs_dir, name):
    n, dur, vmin, vmax, imax, imean, delta = PROVENANCE[name]
    df, _ = read_quiet(logs_dir / name)
    assert len(df) == n
    assert df["time_s"].iloc[-1] == pytest.approx(dur, abs=0.15)
    assert df["voltage_v"].min() == pytest.approx(vmin, abs=0.006)
    assert df["voltage_v"].max() == pytest.approx(vmax, abs=0.006)
    assert df["current_a"].max() == pytest.approx(imax, abs=0.006)
    assert df["current_a"].mean() == pytest.approx(imean, abs=0.006)
    assert df["consumed_mah"].iloc[-1] == pytest.approx(delta, abs=0.15)


def test_metadata(logs_dir):
    _, m = read_quiet(logs_dir / BINS[0])
    assert m["format"] == "dataflash" and m["vehicle_type"] == "multirotor"
    assert m["firmware"] == "APM:Copter V3.3-dev (ae3192b8)" and m["frame"] == "QUAD"
    assert m["battery_capacity_mah"] == 5200.0 and m["battery_cells"] is None
    assert m["rates_hz"]["voltage_v"] == pytest.approx(9.8, abs=0.1)     # CURR ~10 Hz
    assert m["rates_hz"]["groundspeed_ms"] == pytest.approx(5.0, abs=0.1)  # GPS 5 Hz
    _, m = read_quiet(logs_dir / BINS[1])
    assert m["battery_capacity_mah"] == 6000.0 and m["firmware"].startswith("ArduCopter V3.1.3")
    _, m = read_quiet(logs_dir / BINS[3])
    assert m["format"] == "px4log" and m["vehicle"] == "octorotor"
    assert m["vehicle_type"] == "multirotor"
    assert m["battery_capacity_mah"] is None          # BAT_CAPACITY -1 = unset
    assert m["battery_cells"] == 6
    assert "FwGit" not in m["firmware"] and "44d2c4a1" in m["firmware"]


def test_old_curr_is_int16_centi_units(logs_dir):
    log = DataFlashLog(logs_dir / BINS[1])
    assert log.formats[log.name_to_type["CURR"]].char("Volt") == "h"
    raw = log.decode("CURR")["Volt"]
    assert raw.dtype == np.int64 and raw.max() == 1644          # 16.44 V
    df, meta = read_quiet(logs_dir / BINS[1])
    assert df["voltage_v"].max() == pytest.approx(16.44)
    assert meta["channels"]["voltage_v"] == "CURR.Volt"


def test_modes_are_names_from_pymavlink_tables(logs_dir):
    df, _ = read_quiet(logs_dir / BINS[0])
    # PROVENANCE: ModeNum 5 = LOITER at 11.5 s (log start) and 74.6 s, 1 = ACRO at 217.2 s
    assert df["mode"].iloc[0] == "LOITER"
    t_acro = df.loc[df["mode"] == "ACRO", "time_s"].iloc[0]
    assert t_acro == pytest.approx(217.2 - 11.5, abs=0.15)
    df, _ = read_quiet(logs_dir / BINS[1])
    assert set(df["mode"].dropna()) <= {"STABILIZE", "LOITER", "CIRCLE", "RTL"}
    assert {"LOITER", "RTL"} <= set(df["mode"].dropna())
    df, _ = read_quiet(logs_dir / BINS[3])
    assert set(df["mode"]) == {"MANUAL", "AUTO_MISSION"}       # STAT.MainState 0, 3


def test_climb_rate_is_up_positive(logs_dir):
    """GPS VZ is down-positive in ArduPilot: the record's climb rate must follow altitude."""
    for name in BINS:
        df, _ = read_quiet(logs_dir / name)
        d = df[df["altitude_m"].notna() & df["climb_rate_ms"].notna()]
        t, alt, vz = (d[c].to_numpy() for c in ("time_s", "altitude_m", "climb_rate_ms"))
        # over 5-s windows: altitude change vs integral of the climb rate
        edges = np.arange(t[0], t[-1], 5.0)
        rise = np.diff(np.interp(edges, t, alt))
        climbed = np.diff(np.interp(edges, t, np.r_[0, np.cumsum(np.diff(t) * 0.5 *
                                                                  (vz[1:] + vz[:-1]))]))
        assert np.corrcoef(rise, climbed)[0, 1] > 0.7, name


def test_channels_and_units(logs_dir):
    df, meta = read_quiet(logs_dir / BINS[0])
    assert 94_000 < df["pressure_pa"].min() < df["pressure_pa"].max() < 96_000
    assert 26.0 < df["ambient_temperature_c"].min() < 32.0
    thr = df["throttle"].dropna()
    assert len(thr) == len(df) - 2            # CTUN starts after and ends before CURR
    assert thr.between(0, 1).all() and thr.max() == pytest.approx(0.619, abs=1e-3)
    assert (df["wind_n_ms"].dropna() == 0).all()      # EKF2 VWN/VWE all 0 in this log
    assert df["groundspeed_ms"].max() == pytest.approx(12.2, abs=0.1)
    assert df["course_deg"].dropna().between(0, 360).all()
    assert "airspeed_ms" not in df and "temperature_c" not in df   # none logged
    px4, meta = read_quiet(logs_dir / BINS[3])
    assert 98_000 < px4["pressure_pa"].mean() < 99_000             # SENS mbar -> Pa
    assert "airspeed_ms" not in px4                                # sdlog2 ARSP is a rate
    assert not any("ARSP" in s for s in meta["channels"].values())
    assert px4["throttle"].max() == pytest.approx(0.535, abs=1e-3)  # ATSP.ThrustSP


def test_field_map_covers_design_columns():
    assert set(FIELD_MAP) == {"voltage_v", "current_a", "consumed_mah", "temperature_c",
                              "pressure_pa", "ambient_temperature_c", "altitude_m",
                              "climb_rate_ms", "groundspeed_ms", "course_deg", "airspeed_ms",
                              "wind_n_ms", "wind_e_ms", "throttle", "mode"}
    assert not any(f.message == "ARSP" and f.fields == ("RollRateSP",)
                   for fs in FIELD_MAP.values() for f in fs)


def test_detect_format(logs_dir):
    for name in BINS:
        assert detect_format(logs_dir / name) == "dataflash"


# ----------------------------------------------------------------------------- synthetic log

def _struct(fmt):
    return "<" + "".join(FORMAT_TO_STRUCT[c][0] for c in fmt)


def fmt_msg(mtype, name, fmt, columns):
    length = struct.calcsize(_struct(fmt)) + 3
    return b"\xa3\x95\x80" + struct.pack("<BB4s16s64s", mtype, length, name.encode(),
                                         fmt.encode(), columns.encode())


def msg(mtype, fmt, *values):
    return b"\xa3\x95" + bytes([mtype]) + struct.pack(_struct(fmt), *values)


def modern_plane_log(n=50, bad_time_at=None):
    """A small modern ArduPlane log: BAT (two instances), GPS, ARSP, XKF2, CTUN, MODE, PARM."""
    fmts = {
        128: ("FMT", "BBnNZ", "Type,Length,Name,Format,Columns"),
        129: ("PARM", "QNff", "TimeUS,Name,Value,Default"),
        130: ("MSG", "QZ", "TimeUS,Message"),
        131: ("BAT", "QBfffffcf", "TimeUS,Inst,Volt,VoltR,Curr,CurrTot,EnrgTot,Temp,Res"),
        132: ("GPS", "QBBIHBCLLeffffB",
              "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U"),
        133: ("ARSP", "QBffcff", "TimeUS,I,Airspeed,DiffPress,Temp,RawPress,Offset"),
        134: ("XKF2", "QBff", "TimeUS,C,VWN,VWE"),
        135: ("CTUN", "Qff", "TimeUS,ThO,As"),
        136: ("MODE", "QMBB", "TimeUS,Mode,ModeNum,Rsn"),
        137: ("BARO", "QBfffc", "TimeUS,I,Alt,AltAMSL,Press,Temp"),
    }
    out = b"".join(fmt_msg(t, *v) for t, v in fmts.items())
    out += msg(130, "QZ", 1000, b"ArduPlane V4.5.7 (abcdef12)")
    out += msg(129, "QNff", 1000, b"BATT_CAPACITY", 5000.0, 3300.0)
    for k in range(n):
        us = 1_000_000 + 100_000 * k
        if bad_time_at == k:
            us = 9_000_000_000
        out += msg(131, "QBfffffcf", us, 0, 16.0 - 0.01 * k, 16.1, 20.0 + k % 3, 100.0 + 0.5 * k,
                   1.0, 2534, 0.02)
        out += msg(131, "QBfffffcf", us + 10, 1, 50.0, 50.0, 1.0, 7.0, 0.3, 0, 0.1)
        out += msg(137, "QBfffc", us + 20, 0, 0.5 * k, 300 + 0.5 * k, 97000.0 - 6 * k, 3012)
        if k % 2 == 0:
            out += msg(132, "QBBIHBCLLeffffB", us + 30, 0, 3 if k >= 10 else 1, 1000 * k, 2300,
                       12, 80, 473977000, 85456000, 48800 + 50 * k, 15.0, 90.0, -0.5, 0.0, 1)
            out += msg(133, "QBffcff", us + 40, 0, 17.5, 150.0, 2500, 150.0, 1.0)
            out += msg(134, "QBff", us + 50, 0, 3.0, -4.0)
            out += msg(134, "QBff", us + 50, 1, 9.0, 9.0)              # core 1: ignored
        out += msg(135, "Qff", us + 60, 55.0, 17.0)
        if k in (0, 30):
            out += msg(136, "QMBB", us + 70, 10 if k == 0 else 11, 10 if k == 0 else 11, 1)
    return out


def test_synthetic_modern_log_matches_pymavlink_and_maps_every_channel(tmp_path):
    path = tmp_path / "plane.bin"
    path.write_bytes(modern_plane_log())
    # the decoder and pymavlink agree on this hand-made file too
    ref = pymavlink_messages(path)
    log = DataFlashLog(path)
    for mtype in ("BAT", "GPS", "ARSP", "XKF2", "BARO"):
        for col, vals in ref[mtype].items():
            if col != "_ts":
                assert_array_equal(np.asarray(log.decode(mtype)[col], dtype=float),
                                   np.asarray(vals, dtype=float), err_msg=f"{mtype}.{col}")
    with pytest.warns(LogWarning, match=r"2 batteries logged in BAT; kept instance 0"):
        df, meta = read_log(path)
    assert len(df) == 50 and meta["battery_instances"] == [0, 1]
    assert_allclose(df["voltage_v"], 16.0 - 0.01 * np.arange(50), rtol=1e-6)   # instance 0 only
    assert_allclose(df["consumed_mah"], 0.5 * np.arange(50))
    assert_allclose(df["temperature_c"], 25.34)
    assert_allclose(df["time_s"], 0.1 * np.arange(50))
    # BARO is logged 20 µs after each BAT: linear interpolation, NaN before its first sample
    assert np.isnan(df["pressure_pa"].iloc[0])
    assert_allclose(df["pressure_pa"].iloc[1:], 97000 - 6 * np.arange(1, 50) + 6 * 20e-6 / 0.1,
                    atol=1e-6)
    assert_allclose(df["ambient_temperature_c"].dropna(), 30.12)
    assert_allclose(df["airspeed_ms"].dropna(), 17.5)
    assert_allclose(df["wind_n_ms"].dropna(), 3.0)            # XKF2 core 0
    assert_allclose(df["wind_e_ms"].dropna(), -4.0)
    assert_allclose(df["throttle"].dropna(), 0.55)            # plane CTUN.ThO is percent
    # GPS: no fix before k = 10 -> no climb/speed there; VZ -0.5 down-positive -> +0.5 up
    assert df["climb_rate_ms"].iloc[:10].isna().all()
    assert_allclose(df["climb_rate_ms"].iloc[11:48], 0.5)
    assert_allclose(df["groundspeed_ms"].iloc[11:48], 15.0)
    # MODE 10 (AUTO) 70 µs after the first BAT, 11 (RTL) after the 31st: sample-and-hold
    assert df["mode"].isna().tolist() == [True] + [False] * 49
    assert df["mode"].iloc[1:31].eq("AUTO").all() and df["mode"].iloc[31:].eq("RTL").all()
    assert meta["vehicle_type"] == "fixed_wing" and meta["battery_capacity_mah"] == 5000.0
    assert meta["channels"]["voltage_v"] == "BAT.Volt"


def test_damaged_timestamp_drops_only_that_sample(tmp_path):
    path = tmp_path / "badtime.bin"
    path.write_bytes(modern_plane_log(bad_time_at=20))
    with pytest.warns(LogWarning) as rec:
        df, meta = read_dataflash(path)
    assert any("out of order" in str(w.message) and "1 BAT" in str(w.message) for w in rec)
    assert len(meta["warnings"]) == len(rec) == 2       # also: 2 batteries
    assert len(df) == 49 and df["time_s"].is_monotonic_increasing
    assert df["time_s"].iloc[-1] == pytest.approx(4.9)


def test_not_a_dataflash_log(tmp_path):
    p = tmp_path / "x.bin"
    p.write_bytes(b"\xa3\x95" + bytes(range(256)) * 4)
    with pytest.raises(InputError, match=r"x\.bin: not a DataFlash/sdlog2 log"):
        read_dataflash(p)
