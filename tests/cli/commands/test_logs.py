"""``endurance export LOG --csv F``: flight record CSV, one-line summary, exit status."""

import os
import subprocess
import sys
import warnings

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from planner.cli.main import main
from planner.io.logs import LogWarning, read_log
from planner.io.logs.csvmap import MAPS_DIR
from planner.io.record import read_record


@pytest.fixture(scope="module")
def logs_dir(shared_data):
    return shared_data / "logs"


def test_export_bin_round_trips(tmp_path, logs_dir, capsys):
    log = logs_dir / "ardupilot_copter_quad_ac33dev_dronekit_log171.bin"
    out = tmp_path / "rec.csv"
    assert main(["export", str(log), "--csv", str(out)]) == 0
    stdout = capsys.readouterr().out.strip().splitlines()
    assert len(stdout) == 1
    assert "2384 samples, 242.6 s, 14 channels (voltage_v, current_a, power_w" in stdout[0]
    back = read_record(out, derive=False)
    df, _ = read_log(log)
    assert list(back.columns) == list(df.columns)
    for col in df.columns:
        if col in ("experiment", "mode"):
            assert back[col].astype(str).tolist() == df[col].astype(str).tolist()
        else:
            assert_array_equal(back[col].to_numpy(), df[col].to_numpy())


def test_export_every_real_log(tmp_path, logs_dir, capsys):
    for log in sorted(logs_dir.iterdir()):
        if log.suffix not in (".bin", ".px4log", ".ulg", ".tlog"):
            continue
        args = ["export", str(log), "--csv", str(tmp_path / "o.csv")]
        if "sitl" in log.name:
            assert main(args) == 2
            assert "no battery voltage/current" in capsys.readouterr().err
            args.append("--allow-no-battery")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LogWarning)
            assert main(args) == 0, log.name
        assert " samples, " in capsys.readouterr().out


def test_export_csv_with_map(tmp_path, shared_data, capsys):
    out = tmp_path / "m100.csv"
    code = main(["export", str(shared_data / "energy" / "m100_flights_sample.csv"),
                 "--map", str(MAPS_DIR / "dji_m100.yaml"), "--csv", str(out)])
    assert code == 0
    assert "8699 samples, 1303.5 s in 9 experiments" in capsys.readouterr().out
    rec = read_record(out)
    assert rec["experiment"].nunique() == 9 and "anemometer_speed_ms" in rec


def test_bad_input_exits_2_with_one_line(tmp_path, capsys):
    p = tmp_path / "notes.txt.bin"
    p.write_bytes(b"not a log at all\n" * 20)
    assert main(["export", str(p), "--csv", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "notes.txt.bin" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    empty = tmp_path / "e.ulg"
    empty.write_bytes(b"")
    assert main(["export", str(empty), "--csv", str(tmp_path / "o.csv")]) == 2
    assert "empty file" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["export", str(p)])                          # --csv is required
    assert exc.value.code == 2


def test_damaged_log_exports_with_warning(tmp_path, logs_dir, repo):
    data = (logs_dir / "px4_octo_legacy_sdlog2_01_07_59.px4log").read_bytes()
    p = tmp_path / "cut.px4log"
    p.write_bytes(data[: len(data) // 3])
    # a real process: the warning must reach stderr as one "warning: ..." line
    env = dict(os.environ, PYTHONPATH=str(repo))
    run = subprocess.run([sys.executable, "-m", "planner", "export", str(p), "--csv",
                          str(tmp_path / "o.csv")], capture_output=True, text=True, env=env, check=False,
                         cwd=tmp_path, timeout=120)
    assert run.returncode == 0
    assert run.stderr.startswith("warning: ") and "is truncated: skipped" in run.stderr
    assert "Traceback" not in run.stderr
    assert "samples" in run.stdout
    assert np.isfinite(read_record(tmp_path / "o.csv")["voltage_v"]).all()
