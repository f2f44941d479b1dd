"""The flight record (DESIGN §4): schema, validation errors, CSV edge, derived columns,
time-base helpers."""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy.integrate import cumulative_trapezoid as scipy_cumtrapz

from planner.errors import InputError
from planner.io.record import (
    COLUMNS,
    add_consumed,
    add_power,
    complete_record,
    cumulative_trapezoid,
    interpolate_onto,
    has_power,
    read_record,
    resample_record,
    validate_record,
    voltage_only,
    write_record,
)


def record(n=5, **extra):
    df = pd.DataFrame({"time_s": np.arange(n, dtype=float),
                       "voltage_v": np.linspace(16.8, 16.0, n),
                       "current_a": np.full(n, 10.0)})
    for k, v in extra.items():
        df[k] = v
    return df


# ----------------------------------------------------------------------------- schema

def test_columns_units_match_design_table():
    # DESIGN §4 table
    expected = {"experiment": "text", "time_s": "s", "voltage_v": "V", "current_a": "A",
                "power_w": "W", "consumed_mah": "mAh", "temperature_c": "°C",
                "ambient_temperature_c": "°C", "pressure_pa": "Pa", "cycle": "integer",
                # the payload of each experiment (a mass per flight)
                "payload_kg": "kg",
                "altitude_m": "m", "climb_rate_ms": "m/s", "groundspeed_ms": "m/s",
                "course_deg": "deg", "airspeed_ms": "m/s", "wind_n_ms": "m/s",
                "wind_e_ms": "m/s", "throttle": "0..1", "mode": "text",
                # the accelerometer's specific force: thrust over mass (rotor_losses model)
                "specific_force_ms2": "m/s²",
                # the velocity through a multirotor's tilted rotor disk (FlightState)
                "axial_speed_ms": "m/s"}
    assert {k: c.unit for k, c in COLUMNS.items()} == expected
    assert list(COLUMNS)[:2] == ["experiment", "time_s"]


# ----------------------------------------------------------------------------- validation

def test_missing_time_column_names_file_and_column():
    df = record().drop(columns="time_s")
    with pytest.raises(InputError, match=r"flights\.csv: missing required column 'time_s'"):
        validate_record(df, "flights.csv")


def test_power_or_voltage_required():
    with pytest.raises(InputError, match="missing required column 'voltage_v'"):
        validate_record(record().drop(columns=["current_a", "voltage_v", "power_w"],
                                      errors="ignore"), "x.csv")
    # a vehicle without a current sensor: read, exported, said not replayable downstream
    only_voltage = validate_record(record().drop(columns=["current_a", "power_w"],
                                                 errors="ignore"), "x.csv")
    assert voltage_only(only_voltage) and not has_power(only_voltage)
    only_power = pd.DataFrame({"time_s": [0.0, 1.0], "power_w": [100.0, 110.0]})
    assert validate_record(only_power, "x.csv")["power_w"].dtype == np.float64
    kinematic = pd.DataFrame({"time_s": [0.0, 1.0], "altitude_m": [0.0, 1.0]})
    validate_record(kinematic, "x", require_power=False)


def test_non_numeric_value_names_column_and_first_bad_row():
    df = record()
    df["current_a"] = ["10", "10.5", "ten", "x", "11"]
    with pytest.raises(InputError) as exc:
        validate_record(df, "log.csv")
    msg = str(exc.value)
    assert "log.csv" in msg and "'current_a'" in msg and "row 3 (line 4)" in msg and "'ten'" in msg


def test_dataframe_rows_named_by_index_label():
    df = record()
    df.index = [10, 11, 12, 13, 14]
    df["voltage_v"] = df["voltage_v"].astype(object)
    df.loc[13, "voltage_v"] = "bad"
    with pytest.raises(InputError, match=r"'voltage_v' row 13: expected a number, got 'bad'"):
        validate_record(df)


def test_blank_and_nan_text_are_missing_samples_not_errors():
    df = record()
    df["temperature_c"] = ["20.5", "", "nan", None, "21"]
    out = validate_record(df, "x.csv")
    assert np.isnan(out["temperature_c"].iloc[1:4]).all()
    assert out["temperature_c"].iloc[4] == 21.0


def test_time_going_backwards_names_row():
    df = record()
    df.loc[3, "time_s"] = 1.5
    with pytest.raises(InputError, match=r"'time_s' row 4 \(line 5\): time goes backwards "
                                         r"\(2 s then 1.5 s\)"):
        validate_record(df, "a.csv")


def test_time_restarts_per_experiment_but_not_within_one():
    a = record(3, experiment="A")
    b = record(3, experiment="B")
    validate_record(pd.concat([a, b], ignore_index=True), "two.csv")   # 0,1,2,0,1,2 fine
    bad = pd.concat([a, b], ignore_index=True)
    bad.loc[5, "time_s"] = 0.5
    with pytest.raises(InputError, match="within experiment 'B'"):
        validate_record(bad, "two.csv")
    # an experiment that comes back later must continue in time
    resumed = pd.concat([a, b, a.assign(time_s=[1.0, 5.0, 6.0])], ignore_index=True)
    with pytest.raises(InputError, match=r"row 7 \(line 8\)"):
        validate_record(resumed, "two.csv")


def test_missing_or_infinite_time_is_an_error():
    df = record()
    df.loc[2, "time_s"] = np.nan
    with pytest.raises(InputError, match=r"'time_s' row 2: expected a finite time"):
        validate_record(df)


def test_booleans_are_not_numbers():
    df = record()
    df["throttle"] = [True, False, True, True, False]
    with pytest.raises(InputError, match="'throttle'"):
        validate_record(df, "x.csv")


def test_unknown_columns_kept_and_types_normalised():
    df = record(experiment=[1, 1, 1, 1, 1], note=["a"] * 5, cycle=[3] * 5,
                mode=["LOITER", None, "RTL", "RTL", "RTL"])
    out = validate_record(df, "x")
    assert list(out.columns) == list(df.columns)
    assert out["note"].tolist() == ["a"] * 5
    assert out["experiment"].iloc[0] == "1"
    assert out["cycle"].dtype == np.float64
    assert out["mode"].iloc[0] == "LOITER" and pd.isna(out["mode"].iloc[1])
    assert df["experiment"].iloc[0] == 1          # input untouched


# ----------------------------------------------------------------------------- CSV edge

def test_write_then_read_round_trip_is_exact(tmp_path):
    rng = np.random.default_rng(0)
    df = record(50)
    df["current_a"] = rng.uniform(0, 40, 50)
    df.insert(0, "experiment", ["f1"] * 25 + ["f2"] * 25)
    df["time_s"] = np.r_[np.arange(25) * 0.1, np.arange(25) * 0.1]
    df["mode"] = ["AUTO"] * 10 + [None] * 40
    df["altitude_m"] = np.where(np.arange(50) % 7 == 0, np.nan, rng.normal(30, 5, 50))
    df["my_extra"] = np.arange(50)
    path = write_record(df, tmp_path / "rec.csv")
    back = read_record(path, derive=False)
    assert list(back.columns[:2]) == ["experiment", "time_s"]
    for col in ("time_s", "current_a", "voltage_v", "altitude_m"):
        assert_array_equal(back[col].to_numpy(), df[col].to_numpy())   # bit-exact
    assert back["mode"].iloc[0] == "AUTO" and pd.isna(back["mode"].iloc[20])
    assert back["my_extra"].tolist() == list(range(50))


def test_read_record_derives_power_and_consumed(tmp_path):
    p = tmp_path / "r.csv"
    p.write_text("time_s,voltage_v,current_a\n0,10,3.6\n1000,10,3.6\n")
    df = read_record(p)
    assert_allclose(df["power_w"], [36.0, 36.0])
    assert_allclose(df["consumed_mah"], [0.0, 1000.0])      # 3.6 A for 1000 s = 1 Ah


def test_read_record_errors_name_file_and_line(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("time_s,voltage_v,current_a\n0,10,1\n1,10,oops\n")
    with pytest.raises(InputError, match=r"bad\.csv: column 'current_a' row 2 \(line 3\)"):
        read_record(p)
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    with pytest.raises(InputError, match="empty file"):
        read_record(empty)
    with pytest.raises(InputError, match="file not found"):
        read_record(tmp_path / "nope.csv")


# ----------------------------------------------------------------------------- derived

def test_add_power_keeps_measured_power_and_fills_gaps():
    df = record(3)
    df["power_w"] = [1.0, np.nan, 3.0]
    out = add_power(df)
    assert out["power_w"].tolist()[0] == 1.0 and out["power_w"].tolist()[2] == 3.0
    assert out["power_w"].iloc[1] == pytest.approx(df.voltage_v[1] * df.current_a[1])
    assert "power_w" not in df.columns or df["power_w"].isna().sum() == 1


def test_add_consumed_per_experiment_matches_scipy():
    rng = np.random.default_rng(2)
    t = np.cumsum(rng.uniform(0.05, 0.3, 400))
    i = rng.uniform(5, 30, 400)
    df = pd.DataFrame({"experiment": ["a"] * 200 + ["b"] * 200,
                       "time_s": np.r_[t[:200] - t[0], t[200:] - t[200]],
                       "voltage_v": 22.0, "current_a": i})
    out = add_consumed(df)
    for exp, rows in (("a", slice(0, 200)), ("b", slice(200, 400))):
        ref = scipy_cumtrapz(i[rows], df["time_s"].to_numpy()[rows], initial=0) / 3.6
        assert_allclose(out["consumed_mah"].to_numpy()[rows], ref, rtol=1e-12)
    # logger's own count is kept
    df["consumed_mah"] = 7.0
    assert (add_consumed(df)["consumed_mah"] == 7.0).all()


def test_cumulative_trapezoid_bridges_nan():
    x = np.arange(5.0)
    y = np.array([1.0, 1.0, np.nan, 1.0, 1.0])
    assert_allclose(cumulative_trapezoid(y, x), [0, 1, 2, 3, 4])
    y2 = np.array([np.nan, 2.0, 2.0, np.nan, np.nan])
    assert_allclose(cumulative_trapezoid(y2, x), [0, 0, 2, 2, 2])


def test_complete_record_invariant_energy_equals_integral_of_power():
    t = np.linspace(0, 600, 601)
    df = pd.DataFrame({"time_s": t, "voltage_v": 22.2 - t / 600, "current_a": 20 + 5 * np.sin(t / 30)})
    out = complete_record(df)
    energy_j = np.trapezoid(out["power_w"], t)
    assert energy_j == pytest.approx(np.trapezoid(df.voltage_v * df.current_a, t))
    assert out["consumed_mah"].iloc[-1] == pytest.approx(np.trapezoid(df.current_a, t) / 3.6)
    assert np.all(np.diff(out["consumed_mah"]) >= 0)        # discharging: never decreases


# ----------------------------------------------------------------------------- time base

def test_interpolate_linear_never_extrapolates():
    t = np.array([1.0, 2.0, 3.0])
    y = np.array([10.0, 20.0, 40.0])
    out = interpolate_onto([0.5, 1.0, 1.5, 3.0, 3.5], t, y)
    assert np.isnan(out[0]) and np.isnan(out[-1])
    assert_allclose(out[1:4], [10.0, 15.0, 40.0])


def test_interpolate_linear_leaves_long_gaps_empty_and_sorts():
    t = np.array([0.0, 1.0, 10.0, 11.0])[::-1]
    y = np.array([0.0, 1.0, 10.0, 11.0])[::-1]
    out = interpolate_onto([0.5, 5.0, 10.5], t, y, max_gap_s=2.0)
    assert out[0] == 0.5 and np.isnan(out[1]) and out[2] == 10.5


def test_interpolate_previous_for_states():
    t = np.array([1.0, 5.0])
    modes = np.array(["LOITER", "RTL"], dtype=object)
    out = interpolate_onto([0.0, 1.0, 4.9, 5.0, 9.0], t, modes, "previous", hold_last=True)
    assert out.tolist() == [None, "LOITER", "LOITER", "RTL", "RTL"]
    out = interpolate_onto([9.0], t, modes, "previous")
    assert out.tolist() == [None]
    with pytest.raises(ValueError, match="method"):
        interpolate_onto([1.0], t, [1.0, 2.0], "cubic")


def test_resample_record_per_experiment():
    df = pd.DataFrame({"experiment": ["a"] * 3 + ["b"] * 2,
                       "time_s": [0.0, 1.0, 2.0, 0.0, 3.0],
                       "power_w": [0.0, 10.0, 20.0, 5.0, 35.0],
                       "mode": ["X", "Y", "Y", "Z", "Z"]})
    out = resample_record(df, 0.5)
    a = out[out.experiment == "a"]
    assert_allclose(a.time_s, [0, 0.5, 1, 1.5, 2])
    assert_allclose(a.power_w, [0, 5, 10, 15, 20])
    assert a["mode"].tolist() == ["X", "X", "Y", "Y", "Y"]
    b = out[out.experiment == "b"]
    assert_allclose(b.power_w, 5 + 10 * b.time_s)
    with pytest.raises(ValueError, match="period_s"):
        resample_record(df, 0)


def test_implausible_values_are_read_as_missing_with_a_warning():
    """A 1e308 ground speed or a −300 °C air temperature is corrupt data: the sample's
    value becomes missing (the rest of the log stays usable) and the warning names the
    column, the count and the first row."""
    df = pd.DataFrame({"time_s": [0.0, 1.0, 2.0], "power_w": [100.0, 110.0, 120.0],
                       "groundspeed_ms": [5.0, 1e308, 6.0],
                       "ambient_temperature_c": [-300.0, 15.0, 15.0]})
    with pytest.warns(UserWarning) as caught:
        out = validate_record(df, "f.csv")
    text = " ".join(str(w.message) for w in caught)
    assert "column 'groundspeed_ms': 1 value(s) outside [0, 300] m/s, first row 2" in text
    assert "column 'ambient_temperature_c'" in text and "row 1 (line 2)" in text
    assert np.isnan(out["groundspeed_ms"][1]) and out["groundspeed_ms"][2] == 6.0
    assert np.isnan(out["ambient_temperature_c"][0])


def test_a_truncated_last_line_is_skipped_with_a_warning(tmp_path):
    path = tmp_path / "cut.csv"
    path.write_text("time_s,power_w,voltage_v\n0,100,15\n1,101,15\n2,1")  # cut mid-row
    with pytest.warns(UserWarning, match="the last line is incomplete"):
        df = read_record(path)
    assert list(df["time_s"]) == [0.0, 1.0]
    whole = tmp_path / "whole.csv"
    whole.write_text("time_s,power_w,voltage_v\n0,100,15\n1,101,15\n2,102,15")  # no newline
    assert len(read_record(whole)) == 3


def test_experiments_without_duration_are_skipped_or_refused(tmp_path):
    from planner.io.flightdata import load_flight_data
    path = tmp_path / "r.csv"
    pd.DataFrame({"experiment": ["a", "a", "b"], "time_s": [0.0, 1.0, 5.0],
                  "power_w": [100.0, 100.0, 100.0]}).to_csv(path, index=False)
    with pytest.warns(UserWarning, match=r"skipped experiment\(s\) b"):
        df, _ = load_flight_data(path)
    assert set(df["experiment"]) == {"a"}
    same = tmp_path / "same.csv"
    pd.DataFrame({"time_s": [5.0, 5.0], "power_w": [1.0, 2.0]}).to_csv(same, index=False)
    with pytest.raises(InputError, match="no experiment spans more than one instant"):
        load_flight_data(same)


@pytest.mark.parametrize("compressed", [False, True])
def test_a_record_of_a_header_and_no_rows_is_refused_naming_the_file(tmp_path, compressed):
    """A header line and nothing after it (or a .csv.gz cut short before its first row)
    has no sample to use: one error naming the file, not an index error in the
    plausibility check of an empty column."""
    import gzip

    header = b"experiment,time_s,voltage_v,current_a,power_w\n"
    path = tmp_path / ("header.csv.gz" if compressed else "header.csv")
    path.write_bytes(gzip.compress(header) if compressed else header)
    with pytest.raises(InputError, match=r"header\.csv(\.gz)?: no data rows"):
        read_record(path)


def test_strict_plausibility_check_of_an_empty_table_does_not_fail():
    """The strict check (a column of no plausible value is a unit mistake) needs a value
    to call implausible: an empty table has none, and is returned empty."""
    empty = pd.DataFrame({"time_s": [], "voltage_v": [], "current_a": [], "power_w": []})
    assert len(validate_record(empty, "empty.csv", require_power=False, strict=True)) == 0
