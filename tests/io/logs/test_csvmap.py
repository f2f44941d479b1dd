"""CSV through a column map: the DJI Matrice 100 data set (Rodrigues et al. 2021)."""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from planner.errors import InputError
from planner.io.logs import read_log
from planner.io.logs.csvmap import FIELD_MAP, MAPS_DIR, load_map, read_csv_log
from planner.io.record import validate_record

M100_MAP = MAPS_DIR / "dji_m100.yaml"
CRUISE = ["1", "3", "4", "12", "14"]          # first cruise flight of each speed class
HOVER = "221"
GROUND = {"211": -4.0, "214": 10.0, "217": 36.0}   # PROVENANCE: A1 / A2 / A3 ground tests


@pytest.fixture(scope="module")
def energy(shared_data):
    return shared_data / "energy"


@pytest.fixture(scope="module")
def m100(energy):
    return read_csv_log(energy / "m100_flights_sample.csv", map=M100_MAP)


def test_sample_has_nine_experiments(m100):
    df, meta = m100
    validate_record(df, "m100")
    assert df["experiment"].unique().tolist() == CRUISE + ["211", "214", "217", HOVER]
    assert meta["experiments"] == 9 and meta["samples"] == 8699
    assert meta["vehicle_type"] == "multirotor" and meta["battery_capacity_mah"] == 4500
    for _, g in df.groupby("experiment"):
        assert g["time_s"].iloc[0] == 0.0 and g["time_s"].is_monotonic_increasing


def test_power_is_positive_where_the_aircraft_flies(m100):
    df, _ = m100
    p = df.groupby("experiment")["power_w"]
    for f in CRUISE:
        flight = df[df.experiment == f]
        airborne = flight[flight["altitude_m"] > 2.0]
        assert len(airborne) > 0.5 * len(flight)
        assert (airborne["power_w"] > 100).all(), f
        assert 300 < flight["power_w"].mean() < 560, f
    assert (p.get_group(HOVER) > 0).all()
    for f, watts in GROUND.items():
        assert p.get_group(f).median() == pytest.approx(watts, abs=1.5), f
    # 211 reads about -4 W: the current sensor offset of about -0.15 A (PROVENANCE)
    assert df.loc[df.experiment == "211", "current_a"].median() == pytest.approx(-0.17, abs=0.05)
    # hover flight 221 while airborne (P > 150 W): 461 W (PROVENANCE, per flight)
    hover = p.get_group(HOVER)
    assert hover[hover > 150].median() == pytest.approx(461, abs=2)


def test_matches_the_derived_summary(m100, energy):
    """energy_Wh, charge_Ah and duration of m100_flight_summary_derived.csv, per flight;
    its hspeed_p95 is |(velocity_x, velocity_y)|, in the body frame: the map's rotated
    ground speed is checked against the GNSS track below."""
    df, _ = m100
    summary = pd.read_csv(energy / "m100_flight_summary_derived.csv").set_index("flight")
    for f, g in df.groupby("experiment"):
        row = summary.loc[int(f)]
        t = g["time_s"].to_numpy()
        assert np.trapezoid(g["power_w"], t) / 3600 == pytest.approx(row.energy_Wh, abs=0.002)
        assert g["consumed_mah"].iloc[-1] / 1000 == pytest.approx(row.charge_Ah, abs=0.0002)
        assert g["time_s"].iloc[-1] == pytest.approx(row.duration_s, abs=0.01)


def _gnss_velocity(raw):
    """East, north and up speed of the GNSS track (longitude, latitude, altitude
    differenced over 1 s): the reference the rotated velocities must follow. [m/s]"""
    t = raw["time"].to_numpy()
    tt = np.arange(t[0], t[-1], 1.0)
    lat0 = np.radians(raw["position_y"].mean())
    e = np.interp(tt, t, np.radians(raw["position_x"])) * 6371000.0 * np.cos(lat0)
    n = np.interp(tt, t, np.radians(raw["position_y"])) * 6371000.0
    u = np.interp(tt, t, raw["position_z"])
    return tt, np.gradient(e, tt), np.gradient(n, tt), np.gradient(u, tt)


@pytest.mark.parametrize("flight", CRUISE)
def test_body_velocity_rotated_follows_the_gnss_track(m100, energy, flight):
    """velocity_x/y/z are body-frame: rotated by the attitude quaternion (the map's enu_*
    ops) they follow the GNSS track's speed, course and climb; velocity_z alone (the
    map's axial_speed_ms, the velocity along the thrust axis) does not."""
    from planner.io.logs.csvmap import _enu

    raw = pd.read_csv(energy / "m100_flights_sample.csv")
    raw = raw[raw["flight"] == int(flight)]
    tt, ve, vn, vu = _gnss_velocity(raw)
    v = raw[["velocity_x", "velocity_y", "velocity_z"]].to_numpy(float)
    q = raw[["orientation_x", "orientation_y", "orientation_z", "orientation_w"]].to_numpy(float)
    t = raw["time"].to_numpy()
    g = m100[0][m100[0]["experiment"] == flight]
    assert_allclose(g["axial_speed_ms"], raw["velocity_z"])
    gs = np.interp(tt, t, g["groundspeed_ms"])
    climb = np.interp(tt, t, g["climb_rate_ms"])
    assert np.sqrt(np.mean((gs - np.hypot(ve, vn)) ** 2)) < 0.5
    assert np.corrcoef(climb, vu)[0, 1] > 0.9
    assert np.sqrt(np.mean((climb - vu) ** 2)) < 0.4
    raw_vz = np.interp(tt, t, raw["velocity_z"])
    worse = 2.0 if flight in ("12", "14") else 1.2    # the faster, the more the body pitches
    assert np.sqrt(np.mean((raw_vz - vu) ** 2)) > worse * np.sqrt(np.mean((climb - vu) ** 2))
    course = _enu("enu_course", v, q)
    course = np.interp(tt, t, np.unwrap(np.radians(pd.Series(course).ffill().bfill())))
    moving = np.hypot(ve, vn) > 3.0
    diff = np.angle(np.exp(1j * (course - np.arctan2(ve, vn))))[moving]
    assert np.median(np.abs(np.degrees(diff))) < 10.0


def test_sensible_groundspeed_altitude_and_climb(m100):
    df, _ = m100
    g = df.groupby("experiment")
    for f, speed in zip(CRUISE, [4, 6, 8, 10, 12]):
        gs = g.get_group(f)["groundspeed_ms"]
        assert gs.min() >= 0 and gs.quantile(0.95) == pytest.approx(speed, abs=0.9)
        alt = g.get_group(f)["altitude_m"]
        assert alt.iloc[0] == 0.0 and 22 < alt.max() < 28      # ~25 m altitude class
    for f in GROUND:                                           # no GNSS: position_z is 0
        assert g.get_group(f)["altitude_m"].isna().all()
    # climb rate is up-positive: it follows the altitude over 5-s windows
    one = g.get_group("1")
    t, alt, vz = one["time_s"].to_numpy(), one["altitude_m"].to_numpy(), \
        one["climb_rate_ms"].to_numpy()
    edges = np.arange(0, t[-1], 5.0)
    rise = np.diff(np.interp(edges, t, alt))
    climbed = np.diff(np.interp(edges, t, np.r_[0, np.cumsum(np.diff(t) * (vz[1:] + vz[:-1]) / 2)]))
    assert np.corrcoef(rise, climbed)[0, 1] > 0.8


def test_extra_columns_and_no_course(m100):
    df, meta = m100
    assert "anemometer_speed_ms" in df and "airspeed_ms" not in df
    assert "course_deg" not in df                 # see the map's notes
    assert meta["channels"]["groundspeed_ms"].startswith("enu_horizontal(velocity_x, ")
    assert meta["channels"]["climb_rate_ms"].startswith("enu_up(velocity_x, ")
    assert meta["channels"]["axial_speed_ms"] == "velocity_z"


def test_enu_ops_rotate_by_the_quaternion(tmp_path):
    """A body moving forward (+x) at 10 m/s and climbing 1 m/s along its own z, yawed 90°
    left of east (facing north in ENU) and pitched: east/north/up from the quaternion."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_euler("zy", [90.0, -10.0], degrees=True).as_quat()   # x, y, z, w
    v = Rotation.from_quat(q).inv().apply([0.0, 10.0, 1.0])   # world (E, N, U) in the body
    rows = "\n".join(f"{k},{k * 0.1:.1f},{v[0]},{v[1]},{v[2]},{q[0]},{q[1]},{q[2]},{q[3]},"
                     "22.0,10.0" for k in range(20))
    csv = write(tmp_path, "b.csv", "f,t,vx,vy,vz,qx,qy,qz,qw,u,i\n" + rows + "\n")
    of = "[vx, vy, vz, qx, qy, qz, qw]"
    m = write(tmp_path, "m.yaml", f"""time: t
experiment: f
columns:
  voltage_v: u
  current_a: i
derived:
  climb_rate_ms: {{op: enu_up, of: {of}}}
  groundspeed_ms: {{op: enu_horizontal, of: {of}}}
  course_deg: {{op: enu_course, of: {of}}}
""")
    df, _ = read_csv_log(csv, map=m)
    assert_allclose(df["climb_rate_ms"], 1.0, atol=1e-9)
    assert_allclose(df["groundspeed_ms"], 10.0, atol=1e-9)
    assert_allclose(df["course_deg"], 0.0, atol=1e-6)
    bad = write(tmp_path, "bad.yaml", "time: t\ncolumns: {voltage_v: u}\n"
                "derived: {climb_rate_ms: {op: enu_up, of: [vx, vy, vz]}}\n")
    with pytest.raises(InputError, match="seven CSV columns"):
        load_map(bad)


def test_read_log_dispatch_and_shipped_map_name(energy):
    df, meta = read_log(energy / "m100_flights_sample.csv", map="dji_m100")
    assert meta["format"] == "csv" and df["experiment"].nunique() == 9
    with pytest.raises(InputError, match="column map applies to CSV files only"):
        read_log(energy.parent / "logs" / "ardupilot_copter_ac34dev_fs-batt_ground.tlog",
                 map="dji_m100")


# ----------------------------------------------------------------------------- map errors

def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_map_validation_names_file_and_key(tmp_path):
    p = write(tmp_path, "m.yaml", "time: t\ncolums:\n  voltage_v: v\n")
    with pytest.raises(InputError, match=r"m\.yaml: unknown key 'colums' \(did you mean "
                                         r"'columns'\?\)"):
        load_map(p)
    p = write(tmp_path, "m.yaml", "time: t\ncolumns:\n  voltage: {column: v}\n")
    with pytest.raises(InputError, match=r"unknown key 'columns.voltage' \(did you mean "
                                         r"'columns.voltage_v'\?\)"):
        load_map(p)
    p = write(tmp_path, "m.yaml", "time: t\ncolumns:\n  voltage_v: {column: v, scale: big}\n")
    with pytest.raises(InputError, match=r"columns\.voltage_v\.scale must be a number"):
        load_map(p)
    p = write(tmp_path, "m.yaml", "columns:\n  voltage_v: v\n")
    with pytest.raises(InputError, match="missing required key 'time'"):
        load_map(p)
    with pytest.raises(InputError, match="column map not found"):
        load_map(tmp_path / "none.yaml")
    p = write(tmp_path, "m.yaml", "time: t\ncolumns:\n  voltage_v: {column: v, scale: .nan}\n")
    with pytest.raises(InputError, match=r"columns\.voltage_v\.scale must be finite, got nan"):
        load_map(p)
    p = write(tmp_path, "m.yaml", "time: t\ncolumns:\n  voltage_v: v\nmeta: {battery_cells: -6}\n")
    with pytest.raises(InputError, match=r"meta\.battery_cells must be >= 1, got -6"):
        load_map(p)


def test_csv_errors_name_column_and_row(tmp_path):
    m = {"time": {"column": "t", "scale": 0.001}, "columns": {"voltage_v": "v",
                                                              "current_a": {"column": "i"}}}
    p = write(tmp_path, "d.csv", "t,v,i\n0,12,1\n1000,12,x\n")
    with pytest.raises(InputError, match=r"d\.csv: column 'i' row 2 \(line 3\): expected a "
                                         r"number, got 'x'"):
        read_csv_log(p, map=m)
    p = write(tmp_path, "d.csv", "t,v,amps\n0,12,1\n")
    with pytest.raises(InputError, match=r"column 'i' named in <column map> \(current_a\) is not "
                                         r"in the file"):
        read_csv_log(p, map=m)
    p = write(tmp_path, "d.csv", "t,v,i\n0,12,1\n2000,12,1\n1000,12,1\n")
    with pytest.raises(InputError, match=r"'time_s' row 3 \(line 4\): time goes backwards"):
        read_csv_log(p, map=m)


def test_scale_offset_relative_and_identity_map(tmp_path):
    m = {"time": {"column": "t", "scale": 0.001},
         "columns": {"voltage_v": {"column": "mv", "scale": 0.001},
                     "current_a": {"column": "i", "offset": -0.5},
                     "altitude_m": {"column": "z", "relative": True}}}
    p = write(tmp_path, "d.csv", "t,mv,i,z\n5000,12000,2.5,300\n6000,11900,3.5,310\n")
    df, _ = read_csv_log(p, map=m)
    assert_allclose(df["time_s"], [0.0, 1.0])
    assert_allclose(df["voltage_v"], [12.0, 11.9])
    assert_allclose(df["current_a"], [2.0, 3.0])
    assert_allclose(df["altitude_m"], [0.0, 10.0])
    assert_allclose(df["consumed_mah"], [0.0, 2.5 / 3.6])
    # without a map the file must already be a flight record
    p = write(tmp_path, "r.csv", "time_s,voltage_v,current_a,cycle\n0,12,1,3\n1,12,1,3\n")
    df, meta = read_log(p)
    assert_allclose(df["power_w"], [12.0, 12.0]) and meta["format"] == "csv"
    assert set(FIELD_MAP) >= {"voltage_v", "current_a", "mode"}


# --------------------------------------------------------------- a per-flight table joined
def test_m100_map_joins_each_flights_payload_speed_and_altitude(m100):
    """The data set's own parameters.csv (Rodrigues et al. 2021, PROVENANCE.md): flight 14
    carried 250 g at 12 m/s, flights 1/3/4/12 none at 4/6/8/10 m/s; all at 25 m."""
    df, meta = m100
    per = df.groupby("experiment")[["payload_kg", "commanded_speed_ms"]].agg(["min", "max"])
    assert (per.xs("min", axis=1, level=1) == per.xs("max", axis=1, level=1)).all().all()
    first = df.groupby("experiment").first()
    assert first.loc["14", "payload_kg"] == pytest.approx(0.250)
    assert first.loc[["1", "3", "4", "12"], "payload_kg"].tolist() == [0.0] * 4
    assert first.loc[CRUISE, "commanded_speed_ms"].tolist() == [4.0, 6.0, 8.0, 10.0, 12.0]
    assert set(first.loc[CRUISE, "commanded_altitude"]) == {"25"}
    assert meta["channels"]["payload_kg"] == "m100_parameters.csv:payload"


def _joined_csv(tmp_path, table: str):
    (tmp_path / "log.csv").write_text("flight,t,v,i\n" + "".join(
        f"{f},{k},{16 - 0.01 * k},{10 + f}\n" for f in (1, 2) for k in range(5)))
    (tmp_path / "per_flight.csv").write_text(table)
    return {"experiment": "flight", "time": "t",
            "columns": {"voltage_v": "v", "current_a": "i"},
            "flights": {"file": "per_flight.csv", "key": "flight",
                        "columns": {"payload_kg": {"column": "payload", "scale": 0.001}},
                        "extra": {"route": {"column": "route"}}}}


def test_a_flight_the_table_lacks_keeps_its_samples_without_a_payload(tmp_path):
    cmap = _joined_csv(tmp_path, "flight,payload,route\n1,500,R1\n9,250,R2\n")
    with pytest.warns(UserWarning, match=r"no row for experiment\(s\) 2"):
        df, _ = read_csv_log(tmp_path / "log.csv", map=cmap)
    one, two = df[df.experiment == "1"], df[df.experiment == "2"]
    assert_allclose(one["payload_kg"], 0.5)
    assert two["payload_kg"].isna().all() and len(two) == 5
    assert set(one["route"]) == {"R1"}


def test_a_flight_named_twice_or_a_payload_that_is_text_is_refused(tmp_path):
    cmap = _joined_csv(tmp_path, "flight,payload,route\n1,500,R1\n1,250,R2\n2,0,R1\n")
    with pytest.raises(InputError, match=r"per_flight.csv: column 'flight' .*3.*named twice"):
        read_csv_log(tmp_path / "log.csv", map=cmap)
    cmap = _joined_csv(tmp_path, "flight,payload,route\n1,heavy,R1\n2,0,R1\n")
    with pytest.raises(InputError, match=r"per_flight.csv.*payload.*heavy"):
        read_csv_log(tmp_path / "log.csv", map=cmap)


def test_a_missing_per_flight_table_is_said_and_the_log_still_read(tmp_path):
    cmap = _joined_csv(tmp_path, "flight,payload,route\n1,500,R1\n2,0,R1\n")
    (tmp_path / "per_flight.csv").unlink()
    with pytest.warns(UserWarning, match="per_flight.csv .* is not next to the data"):
        df, _ = read_csv_log(tmp_path / "log.csv", map=cmap)
    assert "payload_kg" not in df and len(df) == 10
