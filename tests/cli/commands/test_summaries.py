"""Summaries that explain themselves: the rejection reasons of select printed whole, the
sweeps naming the limit a row exceeds, the check's return-home column named as the margin
it is."""

import json

import pytest
from pathlib import Path

from planner.cli.main import main
from planner.parameters import load_aircraft

REPO = Path(__file__).resolve().parents[3]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
SURVEY = str(REPO / "missions/survey_quad.yaml")
CATALOG = str(REPO / "aircraft/packs/catalog.yaml")


def test_select_prints_every_rejection_reason_whole(tmp_path, capsys):
    js = tmp_path / "s.json"
    main(["select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--json", str(js)])
    out = capsys.readouterr().out
    packs = json.loads(js.read_text())["packs"]
    rejected = [p for p in packs if not p["feasible"] and p["reasons"]]
    assert rejected and any(len(p["reasons"][0]) > 70 for p in rejected)
    for p in rejected:
        assert f"{p['binding']}: {p['reasons'][0]}" in out
    assert not any(line.rstrip().endswith("...") for line in out.splitlines())


def test_sweeps_name_the_limit_a_row_exceeds(capsys):
    mtow = load_aircraft(SOLO).max_takeoff_mass_kg
    main(["sweep", "payload", "--aircraft", SOLO, "--range", "0:1", "--points", "5"])
    out = capsys.readouterr().out
    assert "exceeded" not in out
    over = [line for line in out.splitlines() if "take-off mass over" in line]
    assert over and all(f"the {mtow:.2f} kg maximum" in line for line in over)
    # exactly the rows whose take-off mass is above the maximum
    for line in out.splitlines():
        parts = line.split()
        if len(parts) > 2 and parts[0].replace(".", "").isdigit():
            assert (float(parts[1]) > mtow) == ("take-off mass over" in line)


def test_check_names_the_return_home_column_as_a_margin(capsys):
    main(["check", SURVEY, "--aircraft", SOLO])
    out = capsys.readouterr().out
    assert "RTL margin mAh" in out and "RTL mAh" not in out


# --------------------------------------------------------------------------- replay

def _battery(measured, predicted, **kw):
    from planner.identify.replay import BatteryReplay

    base = dict(model="fitted", rmse_mah=1.0,
                final_error_pct=100.0 * (measured - predicted) / measured if measured else
                float("nan"), rmse_vs_integrated_mah=1.0, final_error_vs_integrated_pct=0.0,
                measured_final_mah=measured, predicted_final_mah=predicted, time_error_s={},
                reserve_reached_s=None, reserve_predicted_s=None)
    base.update(kw)
    return BatteryReplay(**base)


def _experiment(name, duration, battery):
    from planner.identify.replay import ExperimentReplay

    return ExperimentReplay(experiment=name, duration_s=duration, samples=10,
                            battery=battery, power=None, notes=[])


def test_overall_final_error_is_weighted_by_the_charge_drawn():
    """Two short logs with large relative errors and one whole flight: the overall figure
    is sum(measured − predicted) / sum(measured), not the mean of the three percentages;
    a log whose counter ran below zero carries no weight."""
    from planner.identify.replay import _overall

    exps = [_experiment("short", 6, _battery(10.0, 6.0)),        # +40 %
            _experiment("shortish", 20, _battery(40.0, 30.0)),   # +25 %
            _experiment("flight", 900, _battery(4000.0, 3960.0)),  # +1 %
            _experiment("negative", 200, _battery(-6.0, 50.0))]
    o = _overall(exps)["battery"]
    assert o["final_error_pct"] == pytest.approx(100 * (4 + 10 + 40) / 4050)
    assert o["logs_weighted"] == 3
    assert o["unweighted_final_error_pct"] > 10 * o["final_error_pct"]


def test_replay_explains_a_time_error_longer_than_the_flight_and_a_negative_charge():
    from planner.cli.commands.replay import render
    from planner.identify.replay import ReplayResult, _overall

    b = _battery(1000.0, 950.0, time_error_s={"25pct": 5132.0, "50pct": 12.0},
                 time_error_power_w={"25pct": 9.0, "50pct": 310.0}, mean_power_w=305.0)
    exps = [_experiment("log171", 243, b),
            _experiment("m100_211", 120, _battery(-6.0, 40.0))]
    text = render(ReplayResult(exps, _overall(exps)))
    assert "from 25 % +5132 s" in text
    assert "from 25 % the power assumed was 9 W against 305 W" in text
    assert "from 50 % the power assumed" not in text       # 12 s is within the flight
    assert "ends at -6 mAh, below zero" in text
    assert "measured − predicted throughout" in text


# --------------------------------------------------------------------------- fleet

def _health(**kw):
    from types import SimpleNamespace

    base = dict(pack_id="A", flights=12, last_cycle=40.0, soh=0.78, soh_se=0.01,
                fade_per_cycle=0.007, fade_per_cycle_se=0.001, flights_to_retire=-8.0,
                resistance_ohm=float("nan"), resistance_se_ohm=float("nan"))
    base.update(kw)
    h = SimpleNamespace(**base)
    h.retires_within = lambda n: h.flights_to_retire <= n
    return h


def test_pack_health_table_has_no_negative_flights_and_no_empty_plus_minus():
    from types import SimpleNamespace

    from planner.fleet.report import _pack_health

    packs = [_health(),
             _health(pack_id="B", fade_per_cycle=-0.001, flights_to_retire=float("inf"),
                     soh=float("nan"), soh_se=float("nan"), resistance_ohm=0.021,
                     resistance_se_ohm=float("nan")),
             _health(pack_id="C", flights_to_retire=37.4, resistance_ohm=0.02,
                     resistance_se_ohm=0.001)]
    text = "\n".join(_pack_health(SimpleNamespace(health=packs, pack_files={}), 0.8, 10,
                                  False))
    rows = {line.split("|")[1].strip(): line for line in text.splitlines()
            if line.startswith("| ") and line.split("|")[1].strip() in "ABC"}
    assert "– ± –" not in text and "± –" not in text and "-8" not in text
    assert "past it now" in rows["A"] and "RETIRE" in rows["A"]
    assert "too few flights with current steps" in rows["A"]
    assert "no fade seen" in rows["B"] and "21.0" in rows["B"]
    assert "| 37 |" in rows["C"] and "20.0 ± 1.0" in rows["C"]
