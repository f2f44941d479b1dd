"""A log with battery voltage and no current sensor (issue: a real voltage-only log crashed
the suite): it is read and exported as it is, said once to be not replayable, and
``replay`` and ``fleet`` report it without failing the other logs.

Real log: ``../shared/data/logs/px4_pyulog_sample_px4_events_no_current.ulg`` (PX4 v1.15
SITL sample of pyulog, BSD-3; ``battery_status.current_a`` = −1, "not measured").
"""

import warnings

import numpy as np
import pandas as pd
import pytest

from planner.cli.main import main
from planner.io.logs import LogWarning, read_log
from planner.io.record import NO_CURRENT, read_record

NAME = "px4_pyulog_sample_px4_events_no_current.ulg"


@pytest.fixture(scope="module")
def nocur(shared_data):
    path = shared_data / "logs" / NAME
    if not path.exists():
        pytest.skip(f"{path} absent (the shared real data)")
    return path


def test_reader_keeps_voltage_and_drops_the_dead_charge_counter(nocur):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df, meta = read_log(nocur)
    assert "voltage_v" in df and np.isfinite(df["voltage_v"]).all()
    # the counter of a vehicle without a current sensor stays at 0: not a measurement
    assert "current_a" not in df and "power_w" not in df and "consumed_mah" not in df
    said = [w for w in caught if NO_CURRENT in str(w.message)]
    assert len(said) == 1 and issubclass(said[0].category, LogWarning)
    assert any(NO_CURRENT in w for w in meta["warnings"])


def test_export_writes_what_the_log_has_and_says_so_once(nocur, tmp_path, capsys):
    out = tmp_path / "nocur.csv"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["export", str(nocur), "--csv", str(out)]) == 0
    io = capsys.readouterr()
    assert sum(NO_CURRENT in str(w.message) for w in caught) == 1
    assert str(out) in io.out and "voltage_v" in io.out
    back = read_record(out, derive=False)
    assert len(back) == 157 and back["voltage_v"].between(15.0, 17.0).all()
    # the exported record is itself a valid input: exported again unchanged
    again = tmp_path / "again.csv"
    assert main(["export", str(out), "--csv", str(again)]) == 0
    assert again.read_text() == out.read_text()


def test_replay_reports_the_log_and_replays_the_others(nocur, repo, tmp_path, capsys):
    other = repo / "logs" / "sim_solo_calm.bin"
    warnings.simplefilter("ignore", LogWarning)
    code = main(["replay", str(nocur), str(other), "--aircraft",
                 str(repo / "aircraft/solo_survey.yaml"), "--json", str(tmp_path / "r.json"),
                 "--csv", str(tmp_path / "r.csv"), "--plot", str(tmp_path / "r.png")])
    assert code == 0
    out = capsys.readouterr().out
    row = next(line for line in out.splitlines() if line.startswith(nocur.stem))
    assert NO_CURRENT in row
    calm = next(line for line in out.splitlines() if line.startswith("sim_solo_calm "))
    assert calm.split()[2] != "-"       # the other log's measured charge is there
    import json
    exps = json.loads((tmp_path / "r.json").read_text())["experiments"]
    by = {e["experiment"]: e for e in exps}
    assert by[nocur.stem]["battery"] is None and by[nocur.stem]["power"] is None
    assert by["sim_solo_calm"]["battery"]["measured_final_mah"] > 1000


def test_fleet_row_is_not_replayable_not_failed(nocur, repo, tmp_path, capsys):
    code = main(["fleet", str(nocur), str(repo / "logs" / "sim_solo_calm.bin"),
                 "--aircraft", str(repo / "aircraft/solo_survey.yaml"),
                 "--out", str(tmp_path / "fl"), "--workers", "1", "--no-calibration"])
    assert code == 0
    io = capsys.readouterr()
    assert "(0 failed, 1 not replayable)" in io.out
    table = pd.read_parquet(tmp_path / "fl" / "flights.parquet")
    row = table[table["log"].str.endswith(NAME)].iloc[0]
    assert row["status"] == "not replayable" and NO_CURRENT in row["error"]
    assert (table["status"] == "ok").sum() == 1
    assert "internal error" not in io.err


def test_voltage_only_record_without_shared_data(tmp_path, repo, capsys):
    """The same rules on a flight-record CSV with voltage only (no shared data needed)."""
    t = np.arange(0.0, 120.0, 0.5)
    rec = pd.DataFrame({"time_s": t, "voltage_v": 16.4 - 0.004 * t,
                        "climb_rate_ms": np.zeros_like(t), "groundspeed_ms": np.full_like(t, 5)})
    path = tmp_path / "v.csv"
    rec.to_csv(path, index=False)
    assert main(["replay", str(path), "--aircraft", str(repo / "aircraft/solo_survey.yaml")]) == 0
    assert NO_CURRENT in capsys.readouterr().out
    assert main(["fit-aircraft", str(path), "--aircraft", str(repo / "aircraft/solo_survey.yaml"),
                 "--out", str(tmp_path / "a.yaml")]) == 2
    err = capsys.readouterr().err
    assert NO_CURRENT in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
