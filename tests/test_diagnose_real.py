"""diagnose on the real third-party data (../shared/data): it runs on every log with battery
data and on the DJI Matrice 100 flights, and reports what it can and cannot test."""

import json
from pathlib import Path

import pytest

from planner.cli import main

REPO = Path(__file__).resolve().parents[1]
LOGS = ("ardupilot_copter_quad_ac33dev_dronekit_log171.bin",
        "ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin",
        "ardupilot_copter_ac313_pixhawk_2014-10-18_20-44.bin",
        "px4_octo_legacy_sdlog2_01_07_59.px4log",
        "px4_quad_fmuv6c_indoor_quadrotor_local.ulg",
        "px4_quad_fmuv3_esc_status_log.ulg",
        "px4_quad_fmuv6xrt_corrupt_unregistered_msg_id.ulg",
        "px4_vtol_cubeorange_sample_log_small.ulg",
        "ardupilot_copter_ac34dev_fs-batt_ground.tlog")


@pytest.mark.parametrize("name", LOGS)
def test_diagnose_runs_on_every_real_log_with_battery_data(shared_data, name, tmp_path, capsys):
    out = tmp_path / "d.json"
    rc = main(["diagnose", str(shared_data / "logs" / name), "--json", str(out)])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    data = json.loads(out.read_text())
    assert isinstance(data["findings"], list)
    # a level either ran (and says how well the calibrated model does) or a note says why not
    assert data["baseline"] is not None or data["notes"]


def test_diagnose_log_without_battery_data_is_bad_input(shared_data, tmp_path, capsys):
    rc = main(["diagnose", str(shared_data / "logs" / "ardupilot_quadplane_sitl_vtol.tlog"),
               "--json", str(tmp_path / "d.json")])
    err = capsys.readouterr().err
    assert rc == 2 and "no battery" in err


def test_diagnose_on_m100_flights(shared_data, tmp_path, capsys):
    out = tmp_path / "m100.json"
    rc = main(["diagnose", str(shared_data / "energy" / "m100_flights_sample.csv"),
               "--map", "dji_m100", "--aircraft", str(REPO / "aircraft/dji_m100.yaml"),
               "--json", str(out)])
    capsys.readouterr()
    assert rc == 0
    data = json.loads(out.read_text())
    levels = {b["level"] for b in data["baselines"]}
    assert levels == {"capacity", "power"}
    skipped = {s["effect"]: s["reason"] for s in data["skipped"]}
    # the M100 data have neither a course nor a static pressure nor a pack temperature
    assert "course_deg" in skipped["wind"] and "pressure_pa" in skipped["air_density"]
    assert "temperature_c" in skipped["temperature"]
    power = next(b for b in data["baselines"] if b["level"] == "power")
    assert power["rmse"] < power["rmse_as_given"]        # calibration helps on real flights
