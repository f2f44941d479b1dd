"""PX4 topic exports (pyulog ``ulog2csv``): the same flight record as the ``.ulg`` reader,
the propulsion battery instance, and bad input.

The exports are made here by pyulog's own ``convert_ulog2csv`` from ``.ulg`` files (the
repository's simulated ``logs/sim_*.ulg`` and the real logs of ``../shared/data/logs``);
the Solar Surfer flights are the real exports of ``../shared/data/fixed_wing``.
"""

import contextlib
import io
import shutil
import warnings
import zipfile

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from pyulog.ulog2csv import convert_ulog2csv

from planner.cli.main import main
from planner.errors import InputError
from planner.io.logs import LogWarning, detect_format, read_log
from planner.io.logs.ulog2csv import battery_charge_as, read_ulog2csv, topic_files

SOLAR = ("fixed_wing", "solar_surfer")


def export(ulg, folder):
    """pyulog's ulog2csv of ``ulg`` into ``folder`` (all topics)."""
    folder.mkdir(parents=True, exist_ok=True)
    with contextlib.redirect_stdout(io.StringIO()):
        convert_ulog2csv(str(ulg), None, str(folder), ",", None, None)
    return folder


def quiet(fn, *args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        return fn(*args, **kw)


def assert_same_record(a, b):
    """Same columns and rows; values equal to float32 precision of the channel's scale
    (ulog2csv prints each float32 value in its shortest form; a counter's difference to
    its first value keeps the counter's absolute error)."""
    assert list(a.columns) == list(b.columns)
    assert len(a) == len(b)
    for c in a.columns:
        if a[c].dtype.kind in "fi":
            x, y = a[c].to_numpy(float), b[c].to_numpy(float)
            assert_array_equal(np.isnan(x), np.isnan(y), err_msg=c)
            scale = np.nanmax(np.abs(x)) if np.isfinite(x).any() else 0.0
            # consumed_mah: a float32 counter of up to 5e4 mAh minus its first value
            extra = 0.01 if c == "consumed_mah" else 1e-9
            assert_allclose(x, y, rtol=0, atol=2e-6 * scale + extra, equal_nan=True,
                            err_msg=c)
        else:
            assert a[c].astype(str).tolist() == b[c].astype(str).tolist(), c


@pytest.fixture(scope="module")
def sim_export(repo, tmp_path_factory):
    folder = tmp_path_factory.mktemp("sim") / "export"
    return repo / "logs" / "sim_x8_mapping.ulg", export(repo / "logs" / "sim_x8_mapping.ulg",
                                                          folder)


def test_simulated_fixed_wing_export_gives_the_ulog_record(sim_export):
    ulg, folder = sim_export
    a, ma = quiet(read_log, ulg)
    b, mb = quiet(read_log, folder)
    assert detect_format(folder) == "ulog2csv" and mb["format"] == "ulog2csv"
    assert_same_record(a, b)
    assert b["experiment"].iloc[0] == ulg.stem          # the prefix is the .ulg stem
    for key in ("time_base_start_s", "start_time_unix", "vehicle_type", "time_base"):
        assert mb[key] == ma[key], key
    assert mb["channels"] == ma["channels"]


def test_zip_of_the_export_reads_as_the_folder(sim_export, tmp_path):
    _, folder = sim_export
    z = tmp_path / "export.zip"
    with zipfile.ZipFile(z, "w") as zf:
        for f in folder.iterdir():
            zf.write(f, f"some/dir/{f.name}")
    assert detect_format(z) == "ulog2csv"
    assert_same_record(quiet(read_log, folder)[0], quiet(read_log, z)[0])


@pytest.mark.parametrize("name", ["px4_quad_fmuv6c_indoor_quadrotor_local.ulg",
                                  "px4_quad_fmuv3_esc_status_log.ulg",
                                  "px4_quad_fmuv6xrt_corrupt_unregistered_msg_id.ulg",
                                  "px4_vtol_cubeorange_sample_log_small.ulg",
                                  "px4_pyulog_sample_px4_events_no_current.ulg"])
def test_real_ulg_exports_give_the_ulog_record(shared_data, tmp_path, name):
    ulg = shared_data / "logs" / name
    folder = export(ulg, tmp_path / "e")
    a, ma = quiet(read_log, ulg)
    # the .ulg reader keeps instance 0 when it measures current; ask for the same one
    b, mb = quiet(read_log, folder, battery_instance=ma.get("battery_instance"))
    assert_same_record(a, b)
    for key in ("time_base_start_s", "start_time_unix", "vehicle_type"):
        assert mb.get(key) == ma.get(key), key


def test_vtol_log_keeps_the_instance_that_carries_the_current(shared_data, tmp_path):
    folder = export(shared_data / "logs" / "px4_vtol_cubeorange_sample_log_small.ulg",
                    tmp_path / "e")
    with pytest.warns(LogWarning, match="kept instance 1 .the one that carries the current"):
        _, meta = read_log(folder)
    q = meta["battery_charge_mah"]
    assert meta["battery_instances"] == [0, 1] and q[1] > q[0] > 0


@pytest.mark.parametrize("flight, samples, charge_mah", [("flight3", 4872, 853.4),
                                                         ("flight1", 2170, 1401.9)])
def test_solar_surfer_propulsion_pack_is_instance_1(shared_data, flight, samples,
                                                     charge_mah):
    """PROVENANCE.md of the Solar Surfer data: ``battery_status_1`` is the 4S propulsion pack
    (flight 3: 852.8 mAh on its counter, 853.4 mAh integrated; flight 1: 1399.0 and 1401.9),
    ``battery_status_0`` the solar converter (≤ 0.19 A in flight 3, ≤ 1.04 A in flight 1)."""
    folder = shared_data.joinpath(*SOLAR, flight)
    df, meta = quiet(read_log, folder)
    assert meta["battery_instance"] == 1 and len(df) == samples
    assert meta["battery_charge_mah"][1] == pytest.approx(charge_mah, abs=0.1)
    assert meta["battery_charge_mah"][0] < 5.0
    assert df["experiment"].iloc[0] == flight
    assert df["consumed_mah"].iloc[-1] == pytest.approx(
        {"flight3": 852.77, "flight1": 1399.01}[flight], abs=0.01)
    assert meta["vehicle_type"] == ("fixed_wing" if flight == "flight3" else None)
    chosen, _ = quiet(read_log, folder, battery_instance=0)
    assert chosen["current_a"].max() < 1.1                 # the solar channel


def test_solar_surfer_flight3_time_base_and_energy(shared_data):
    """Flight 3's battery starts 539.3735 s after boot; its UTC is 13:00:53.7 (GPS:
    UTC − boot = 1 683 118 314.30 s); 8.58 Wh in 587–830 s after the authors' t0 =
    539 330 432 µs (PROVENANCE.md)."""
    df, meta = quiet(read_log, shared_data.joinpath(*SOLAR, "flight3"))
    assert meta["time_base_start_s"] == pytest.approx(539.373509, abs=1e-6)
    assert meta["start_time_unix"] == pytest.approx(1_683_118_314.30 + 539.3735, abs=0.05)
    t = df["time_s"].to_numpy() + meta["time_base_start_s"] - 539.330432
    w = (t >= 587) & (t <= 830)
    p = df["power_w"].to_numpy()[w]
    wh = np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t[w])) / 3600
    assert wh == pytest.approx(8.58, abs=0.01)


def test_topic_names_with_underscores_and_digits(shared_data):
    files = {(tf.topic, tf.instance) for tf in topic_files(shared_data.joinpath(*SOLAR,
                                                                                 "flight3"))}
    assert ("actuator_controls_0", 0) in files and ("battery_status", 1) in files
    assert all(topic != "wind" for topic, _ in files)      # airspeed_wind is not wind


def test_battery_charge_ignores_not_measured_current():
    t = np.arange(5) * 1e6
    assert battery_charge_as({"timestamp": t, "current_a": np.full(5, -1.0)}) == -1.0
    assert battery_charge_as({"timestamp": t, "current_a": np.full(5, 2.0)}) == 8.0


# ------------------------------------------------------------------------ bad input
def _copy(folder, dest, skip=()):
    dest.mkdir()
    for f in folder.iterdir():
        if not any(s in f.name for s in skip):
            shutil.copy(f, dest / f.name)
    return dest


def test_no_battery_topic_is_bad_input_unless_allowed(sim_export, tmp_path):
    _, folder = sim_export
    nob = _copy(folder, tmp_path / "nob", skip=("battery_status",))
    with pytest.raises(InputError, match=r"nob: no usable battery_status file"):
        read_log(nob)
    df, meta = quiet(read_log, nob, require_battery=False)
    assert "voltage_v" not in df and "airspeed_ms" in df


def test_missing_battery_instance_is_bad_input(sim_export):
    _, folder = sim_export
    with pytest.raises(InputError, match=r"no battery_status instance 2 .*instance\(s\) 0"):
        read_log(folder, battery_instance=2)


def test_battery_instance_is_for_topic_exports_only(sim_export):
    ulg, _ = sim_export
    with pytest.raises(InputError, match="applies to a PX4 topic export"):
        read_log(ulg, battery_instance=0)


def test_topics_on_different_time_bases_are_bad_input(sim_export, tmp_path):
    _, folder = sim_export
    bad = _copy(folder, tmp_path / "bad")
    f = next(bad.glob("*_airspeed_validated_0.csv"))
    text = f.read_text().splitlines()
    rows = [line.split(",", 1) for line in text[1:]]
    # the airspeed written in seconds since its first sample instead of µs since boot
    t0 = int(rows[0][0])
    f.write_text("\n".join([text[0]] + [f"{(int(t) - t0) // 1000000},{rest}"
                                        for t, rest in rows]) + "\n")
    with pytest.raises(InputError, match=r"airspeed_validated_0.csv: timestamps .* do not "
                                         r"overlap the battery's .*different time bases"):
        read_log(bad)


def test_two_exports_in_one_folder_are_bad_input(sim_export, tmp_path):
    _, folder = sim_export
    both = _copy(folder, tmp_path / "both")
    f = next(both.glob("*_battery_status_0.csv"))
    shutil.copy(f, both / "other_battery_status_0.csv")
    with pytest.raises(InputError, match=r"files of 2 exports .*one prefix"):
        read_log(both)


def test_folder_without_topic_files_is_bad_input(tmp_path):
    (tmp_path / "notes.csv").write_text("a,b\n1,2\n")
    with pytest.raises(InputError, match=r"none of a known topic; expected a PX4 topic "
                                         r"export"):
        read_log(tmp_path)
    with pytest.raises(InputError, match="not a readable zip file"):
        (tmp_path / "x.zip").write_bytes(b"PK\x03\x04 not really")
        read_log(tmp_path / "x.zip")


def test_partial_export_reads_what_is_valid_with_a_warning(sim_export, tmp_path):
    _, folder = sim_export
    full, _ = quiet(read_log, folder)
    part = _copy(folder, tmp_path / "part")
    bat = next(part.glob("*_battery_status_0.csv"))
    raw = bat.read_bytes()
    bat.write_bytes(raw[: raw.rindex(b"\n", 0, len(raw) - 1) + 20])   # cut inside a row
    gps = next(part.glob("*_vehicle_local_position_0.csv"))
    gps.write_bytes(b"\x00\xff garbage \x00")
    with pytest.warns(LogWarning) as caught:
        df, meta = read_log(part)
    text = " | ".join(str(w.message) for w in caught)
    assert "ends inside a row" in text and "battery_status_0.csv" in text
    assert "vehicle_local_position_0.csv" in text and "skipped" in text
    assert len(df) == len(full) - 1
    assert_allclose(df["voltage_v"], full["voltage_v"].iloc[:-1], rtol=1e-6)
    # what only the damaged topic gave is missing; altitude falls back to the global position
    assert set(full.columns) - set(df.columns) == {"climb_rate_ms", "groundspeed_ms",
                                                   "course_deg"}
    assert "altitude_m" in df and "airspeed_ms" in df


def test_cli_exit_2_names_the_folder(sim_export, tmp_path, capsys):
    _, folder = sim_export
    code = main(["export", str(folder), "--csv", str(tmp_path / "o.csv"),
                 "--battery-instance", "4"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1
    assert str(folder) in err[0] and "no battery_status instance 4" in err[0]
    assert main(["export", str(folder), "--csv", str(tmp_path / "o.csv")]) == 0
