"""``endurance backtest`` as a user runs it: the outputs on a real sample of the DJI
Matrice 100 flights (Rodrigues et al., Scientific Data 8, 155, 2021), and bad input."""

import json
import re
from pathlib import Path

import pandas as pd
import pytest
import yaml

from planner.cli.main import main

REPO = Path(__file__).resolve().parents[3]
M100 = str(REPO / "aircraft/dji_m100_rotor_losses.yaml")


@pytest.fixture(scope="module")
def sample(shared_data):
    return str(shared_data / "energy/m100_flights_sample.csv")


def test_backtest_writes_the_table_the_report_and_the_plot(sample, tmp_path, capsys):
    out = tmp_path / "bt"
    rc = main(["backtest", sample, "--map", "dji_m100", "--aircraft", M100, "--out", str(out),
               "--folds", "3", "--site-altitude", "300"])
    text = capsys.readouterr().out
    assert rc == 0
    assert "Backtest of 9 flight(s): 5 scored, 4 left out" in text
    assert "3  never airborne (a ground test?)" in text
    table = pd.read_parquet(out / "backtest.parquet")
    csv = pd.read_csv(out / "backtest.csv", dtype={"experiment": str})
    assert list(table["experiment"]) == list(csv["experiment"])
    assert (table["status"] == "scored").sum() == 5
    report = json.loads((out / "report.json").read_text())
    assert report["scored"] == 5 and report["calibration"] == "3-fold by flight"
    scored = table[table.status == "scored"]
    assert report["energy"]["bias_pct"] == pytest.approx(scored.energy_error_pct.mean())
    # leg by leg: the level legs at constant speed, against the flights' level cruise
    assert report["cruise_power"]["n"] == 5
    assert "cruise power bias" in text and "cruise power error by speed [m/s]:" in text
    assert scored.cruise_power_error_pct.notna().all()
    assert (out / "report.txt").read_text().startswith("Backtest of 9 flight(s)")
    assert (out / "predicted_vs_measured.png").read_bytes()[:4] == b"\x89PNG"


def test_a_payload_given_overrides_every_flight_s_and_says_so(sample, tmp_path, capsys):
    rc = main(["backtest", sample, "--map", "dji_m100", "--aircraft", M100, "--out",
               str(tmp_path / "bt"), "--held-out", "14,12", "--payload", "0.5"])
    text = capsys.readouterr().out
    assert rc == 0 and "--payload 0.5 kg overrides the payload of each flight" in text
    table = pd.read_parquet(tmp_path / "bt" / "backtest.parquet")
    assert list(table["experiment"]) == ["12", "14"]
    assert set(table["payload_kg"]) == {0.5}


def test_the_report_says_what_turned_the_power_into_charge(sample, tmp_path, capsys):
    """By default the pack's integral model is fitted on the training flights' charge, and
    the report says so; ``--battery-model file`` keeps the pack file's model: here a
    TB47D file without one (the literature start values), whose charge comes out short
    of the measured."""
    raw = yaml.safe_load((REPO / "aircraft/batteries/dji_tb47d.yaml").read_text())
    del raw["model"], raw["fit_status"]
    literature = tmp_path / "tb47d_literature.yaml"
    literature.write_text(yaml.safe_dump(raw))
    texts, tables = {}, {}
    for choice in ("fitted", "file"):
        out = tmp_path / choice
        rc = main(["backtest", sample, "--map", "dji_m100", "--aircraft", M100, "--out",
                   str(out), "--held-out", "1,12", "--battery-model", choice,
                   "--battery", str(literature)])
        texts[choice] = capsys.readouterr().out
        assert rc == 0
        tables[choice] = pd.read_parquet(out / "backtest.parquet")
    assert re.search(r"charge drawn by the pack's integral model fitted on \d+ training "
                     r"flights: δ [\d.]+, ε -[\d.]+, β 0.9648 \(held\)", texts["fitted"])
    assert "charge drawn by the pack file's integral model" in texts["file"]
    assert (tables["file"].charge_error_pct < -5.0).all()
    assert (tables["fitted"].charge_error_pct.abs()
            < tables["file"].charge_error_pct.abs()).all()


@pytest.mark.parametrize("table, message", [
    ("experiment,wind_speed_ms\n1,3\n", "no column wind_from_deg"),
    ("experiment,wind_speed_ms,wind_from_deg\n1,3,270\n3,calm,90\n",
     "column 'wind_speed_ms'.*3.*calm"),
    ("experiment,wind_speed_ms,wind_from_deg\n1,300,270\n", "wind_speed_ms.*300"),
])
def test_a_bad_weather_table_is_one_line_naming_the_file(sample, tmp_path, capsys, table,
                                                         message):
    weather = tmp_path / "weather.csv"
    weather.write_text(table)
    rc = main(["backtest", sample, "--map", "dji_m100", "--aircraft", M100, "--out",
               str(tmp_path / "bt"), "--weather", str(weather)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1
    assert "weather.csv" in err[0]
    assert re.search(message, err[0]), err[0]
    assert not (tmp_path / "bt" / "backtest.parquet").exists()


def test_flights_the_weather_table_lacks_are_left_out_with_the_reason(sample, tmp_path,
                                                                      capsys):
    weather = tmp_path / "weather.csv"
    weather.write_text("experiment,wind_speed_ms,wind_from_deg\n1,2,270\n3,1,90\n999,4,0\n")
    rc = main(["backtest", sample, "--map", "dji_m100", "--aircraft", M100, "--out",
               str(tmp_path / "bt"), "--folds", "2", "--weather", str(weather)])
    text = capsys.readouterr().out
    assert rc == 0 and "names 1 flight(s) the data lack (999)" in text
    table = pd.read_parquet(tmp_path / "bt" / "backtest.parquet").set_index("experiment")
    assert set(table.index[table.status == "scored"]) == {"1", "3"}
    assert table.loc["4", "reason"] == "no forecast for this flight in the weather table"
    assert table.loc["1", "forecast"] == "weather table"


def test_folds_by_day_without_dates_are_refused(tmp_path, capsys):
    rec = tmp_path / "rec.csv"
    rec.write_text("experiment,time_s,voltage_v,current_a\n"
                   + "".join(f"{e},{k},16,10\n" for e in "ab" for k in range(5)))
    rc = main(["backtest", str(rec), "--aircraft", M100, "--out", str(tmp_path / "bt"),
               "--folds", "2", "--by", "day"])
    err = capsys.readouterr().err
    assert rc == 2 and "no date per flight" in err
