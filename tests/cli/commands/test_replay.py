"""``endurance replay``: what it prints when the data give nothing to compare with."""

import re
from pathlib import Path

import numpy as np
from battery_generators import constant

from planner.cli.main import main

REPO = Path(__file__).resolve().parents[3]
MULTISTAR = REPO / "aircraft" / "batteries" / "multistar_10ah_4s.yaml"


def test_no_measured_charge_prints_no_nan(tmp_path, capsys):
    """A consumed-charge column with nothing after its first sample (as a column in the
    wrong unit is read: its implausible values as missing) leaves no log with a measured
    charge: the overall line says so, instead of ``RMSE nan mAh, final error +nan %``."""
    rng = np.random.default_rng(5)
    df = constant("p100", 100.0, 3000, rng=rng).iloc[::5].copy()
    df["consumed_mah"] = np.nan
    df.iloc[0, df.columns.get_loc("consumed_mah")] = 0.0
    path = tmp_path / "consumed_missing.csv"
    df.to_csv(path, index=False)
    rc = main(["replay", str(path), "--battery", str(MULTISTAR)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "Overall battery: no log has a measured charge to compare with" in out
    assert not re.search(r"(?<![\w.])[+-]?nan(?!\w)", out, re.I), out


def test_a_phase_without_a_usable_measured_power_prints_no_nan(tmp_path, capsys):
    """A no-data value (-9999 W) in every power sample of the ground phase leaves that
    phase no measured energy to divide by: its error is shown as "–", not "+nan %"."""
    import pandas as pd

    record = tmp_path / "calm.csv"
    assert main(["export", str(REPO / "logs/sim_solo_calm.bin"), "--csv", str(record)]) == 0
    df = pd.read_csv(record)
    ground = df["time_s"] < 19.0
    df.loc[ground, "power_w"] = -9999.0
    df.to_csv(record, index=False)
    capsys.readouterr()
    rc = main(["replay", str(record), "--aircraft", str(REPO / "aircraft/solo_survey.yaml")])
    out = capsys.readouterr().out
    assert rc in (0, 1)
    assert not re.search(r"(?<![\w.])[+-]?nan(?!\w)", out, re.I), out
