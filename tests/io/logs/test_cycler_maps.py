"""Cycle-test files as labs write them: the shipped column maps of a cycler's export and
of the shared cell data, a file without a header row or with a byte-order mark, and
``--map auto`` naming the map that matched."""

import numpy as np
import pandas as pd
import pytest

from planner.cli.main import main
from planner.errors import InputError
from planner.io.logs.csvmap import read_csv_log


def arbin_csv(path, cycles=2):
    """An Arbin-style export: current negative in discharge, the capacity counted per
    cycle."""
    rows = []
    for c in range(1, cycles + 1):
        t = np.arange(0.0, 1800.0, 10.0) + (c - 1) * 4000.0
        cap = (t - t[0]) * 2.0 / 3600.0
        rows.append(pd.DataFrame({"Data_Point": 0, "Test_Time(s)": t, "Step_Index": 2,
                                  "Cycle_Index": c, "Current(A)": -2.0,
                                  "Voltage(V)": 4.1 - 0.5 * (t - t[0]) / 1800.0,
                                  "Charge_Capacity(Ah)": 0.0,
                                  "Discharge_Capacity(Ah)": cap}))
    pd.concat(rows).to_csv(path, index=False)


def test_arbin_export_is_matched_and_read_discharge_positive(tmp_path):
    path = tmp_path / "channel.csv"
    arbin_csv(path)
    df, meta = read_csv_log(path, map="auto")
    assert meta["column_map"] == "arbin"
    assert sorted(df["experiment"].unique()) == ["1", "2"]
    assert (df["current_a"] > 0).all()
    assert df["power_w"].to_numpy() == pytest.approx((df["voltage_v"] * 2.0).to_numpy())
    # the per-cycle counter: 2 A over the 1790 s of each cycle, 994 mAh
    last = df.groupby("experiment")["consumed_mah"].max()
    assert last.to_numpy() == pytest.approx([2.0 * 1790 / 3.6] * 2, abs=0.5)


def test_a_file_no_map_reads_is_one_line_naming_the_maps(tmp_path, capsys):
    path = tmp_path / "odd.csv"
    pd.DataFrame({"when": [0, 1], "amps": [1, 1], "volts": [4, 4]}).to_csv(path, index=False)
    with pytest.raises(InputError, match="no shipped column map reads") as exc:
        read_csv_log(path, map="auto")
    assert "arbin" in str(exc.value) and "samsung_30q_rate" in str(exc.value)
    assert main(["export", str(path), "--map", "auto", "--csv", str(tmp_path / "r.csv")]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_samsung_30q_rate_file_without_header_and_with_bom(shared_data, tmp_path, capsys):
    """The ARTS-Lab 30Q 1C file of cell S002: no header, a byte-order mark and the
    logger's overflow 3.4e38 in the first current: matched, read, and fitted without
    hand preprocessing."""
    src = shared_data / "battery/samsung_30q_artslab/raw/S002/Q30_S002_1C.csv"
    rec = tmp_path / "q30.csv"
    assert main(["export", str(src), "--map", "auto", "--csv", str(rec)]) == 0
    out = capsys.readouterr().out
    assert "column map samsung_30q_rate (matched: no header row, 7 numeric columns)" in out
    df = pd.read_csv(rec)
    assert np.isnan(df["current_a"].iloc[0])                 # the overflow, as missing
    assert df["current_a"].iloc[1:].median() == pytest.approx(3.0, abs=0.05)  # 1C, discharge +
    assert df["voltage_v"].iloc[-1] < 2.6
    # one 1C discharge excites no power dependence: fitted and written, the exponent a misfit
    # (exit 1), never refused for the file's form
    capsys.readouterr()
    assert main(["fit-battery", str(rec), "--out", str(tmp_path / "q30.yaml"), "--name",
                 "30Q", "--cells", "1", "--mass-kg", "0.048", "--fix-beta", "0.9648"]) == 1
    out = capsys.readouterr().out
    assert "fit_status: misfit: epsilon" in out and "too little excitation" in out
    assert (tmp_path / "q30.yaml").is_file()


def test_the_p42a_segments_match_their_own_map(shared_data):
    src = shared_data / "battery/molicel_p42a/p42a_discharge_segments_derived.csv"
    _, meta = read_csv_log(src, map="auto")
    assert meta["column_map"] == "molicel_p42a"
