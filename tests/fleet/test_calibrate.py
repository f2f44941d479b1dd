"""The fleet's aircraft calibration: flights without airborne samples stay out of the split.

A 20 s ground test or a 6 s hop has calibration samples but no airborne one; held out by
its hash, it once broke the fit ("unknown experiment(s)"). Generated Solo flights (the
planner's own models) and the real ground tlog.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pandas as pd

from planner.parameters import load_aircraft_and_battery

REPO = Path(__file__).resolve().parents[2]
SOLO = REPO / "aircraft/solo_survey.yaml"


def _samples(rec: pd.DataFrame, sha: str) -> pd.DataFrame:
    from planner.fleet.summary import calibration_samples

    return calibration_samples(rec).assign(sha256=sha)


def test_a_held_out_flight_without_airborne_samples_is_left_out_before_the_split(
        shared_data):
    from planner.fleet.calibrate import calibrate_aircraft, held_out
    from planner.fleet.summary import to_frame
    from planner.io import record
    from planner.io.logs import read_log
    from testkit.fleet import mission
    from testkit.flight import simulate_flight

    craft, pack = load_aircraft_and_battery(SOLO)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ground, _ = read_log(shared_data / "logs/ardupilot_copter_ac34dev_fs-batt_ground.tlog")
    ground = record.complete_record(ground.assign(experiment="g")).reset_index(drop=True)
    # hashes: the ground log's is held out (its first 32 bits divisible by 5), one flight's
    shas = ["0" * 64] + [f"{k:08x}" + "a" * 56 for k in (1, 2, 3, 5)]
    assert held_out(shas[0]) and held_out(shas[4])
    assert not any(held_out(h) for h in shas[1:4])
    parts = [_samples(ground, shas[0])]
    for k, sha in enumerate(shas[1:]):
        rec = simulate_flight(mission(craft), craft, pack, rate_hz=2.0, seed=k,
                              experiment="f")
        parts.append(_samples(rec, sha))
    samples = pd.concat(parts, ignore_index=True)
    table = to_frame([{"sha256": h, "log": f"{h[:8]}.bin", "status": "ok",
                       "aircraft": "solo", "samples": 1, "resistance_steps": 0}
                      for h in shas])
    cal = calibrate_aircraft("solo", samples, table, craft, pack)
    assert cal.aircraft is not None, cal.note
    assert (cal.train_flights, cal.validation_flights) == (3, 1)
    assert cal.note == "1 flight(s) without airborne samples left out"
    # too few flying flights: the note says why, and counts the grounded one
    few = calibrate_aircraft("solo", samples[samples["sha256"].isin(shas[:3])],
                             table, craft, pack)
    assert few.aircraft is None
    assert few.note == ("2 flight(s) with airborne flight state: too few to calibrate "
                        "(expected at least 3); 1 without airborne samples left out")


def test_the_real_folder_is_checked_and_calibrated_on_the_flights_that_match(
        shared_data, tmp_path, capsys):
    """``fleet ../shared/data/logs --aircraft aircraft/solo_survey.yaml``: the 3S, 6S and 8S
    logs and the VTOL are mismatch rows (counted in the summary), and the Solo is
    calibrated on the 4S quadcopter logs instead of failing its split."""
    from planner.cli.main import main

    out = tmp_path / "fleet"
    code = main(["fleet", str(shared_data / "logs"), "--aircraft", str(SOLO), "--out",
                 str(out), "--workers", "1"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    assert "7 mismatch" in cap.out.splitlines()[0]
    assert "calibration failed" not in cap.out
    assert "aircraft solo_survey: calibrated on 3 flights" in cap.out
    assert ("px4_quad_fmuv6c_indoor_quadrotor_local.ulg: mismatch: 8S pack, the aircraft "
            "allows 4S") in cap.err
    assert ("px4_vtol_cubeorange_sample_log_small.ulg: mismatch: a vtol log, the aircraft "
            "is a multirotor") in cap.err
    table = pd.read_parquet(out / "flights.parquet")
    assert (table["status"] == "mismatch").sum() == 7
    assert table.loc[table["status"] == "mismatch", "charge_error_pct"].isna().all()
    samples = pd.read_parquet(out / "samples.parquet")
    assert set(samples["sha256"]) == set(table.loc[table["status"] == "ok", "sha256"])
    report = (out / "report.md").read_text()
    assert "## Logs left out (this run)" in report
    assert "mismatch: 8S pack" in report
