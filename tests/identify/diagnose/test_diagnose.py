"""diagnose: hidden effects are found and named first, clean data gives no findings.

The data come from :mod:`tests.helpers.diagnose_generators`, an independent statement of the
physics (the equivalent-circuit pack model; rotor momentum theory restated): nothing
there uses the extensions of :mod:`planner.identify.diagnose.effects`. Each generator keeps the
drivers of the other effects present but inactive (the pack temperature varies, the
pressure and temperature of the day vary, the cycle count rises) and starts the
planner from miscalibrated parameters (the pack's δ, ε, β from [UAV23]; the
aircraft file's η and drag area wrong by 15–50 %), so that plain miscalibration would
show up as an effect if the baseline were not calibrated first.
"""

import json
import math
from pathlib import Path

import numpy as np

import pytest
from diagnose_generators import (
    PACK_6S,
    aircraft_file,
    battery,
    capacity_dataset,
    power_dataset,
)

from planner.identify.diagnose import EFFECTS, diagnose
from planner.identify.diagnose import search as S
from planner.identify.diagnose.effects import make_effects
from planner.errors import InputError

#: The aircraft file the planner is given: η 0.60 (truth 0.72), drag area 0.06 m² (0.04).
WRONG = {"efficiency": 0.6, "drag_area_m2": 0.06}
#: Power-level test flights: four 10-minute flights at 2 Hz.
FLIGHTS = {"duration_s": 600.0, "rate_hz": 2.0}


def _power(effect, magnitude, seed, **kw):
    df, truth = power_dataset(effect, magnitude, seed=seed, **FLIGHTS, **kw)
    return diagnose(df, battery(PACK_6S), aircraft_file(**WRONG),
                    payload_kg=truth["payload_kg"]), truth


def _names(result):
    return [f["effect"] for f in result.findings]


def _tied(result, effect) -> bool:
    """Whether ``effect`` and a rival were withheld as a tie the data cannot break (and
    then: no power-level finding, the effect's detection entry not identifiable)."""
    tie = [w for w in result.withheld if w["effect"] == effect and w["kind"] == "confounded"
           and "cannot tell them apart" in w["why"]]
    if not tie:
        return False
    rivals = set(tie[0]["candidates"]) - {effect}
    assert rivals and all(w["effect"] in tie[0]["candidates"] for w in result.withheld
                          if "cannot tell them apart" in w["why"]), result.summary()
    assert not [f for f in result.findings if f["level"] == "power"], result.summary()
    entry = next(d for d in result.detection if d["effect"] == effect
                 and d["level"] == "power")
    assert not entry["identifiable"] and "cannot tell them apart" in entry["why"]
    return True


# ----------------------------------------------------------------------------- capacity

@pytest.mark.parametrize("effect, magnitude, profile, seed", [
    ("temperature", 0.006, "flights", 1),
    ("temperature", 0.004, "aprbs", 2),
    ("temperature", 0.008, "steps", 3),
    ("capacity_fade", 5e-4, "aprbs", 0),
    ("capacity_fade", 8e-4, "flights", 1),
    ("capacity_fade", 1e-3, "steps", 2),
    ("current_offset", 0.15, "aprbs", 0),
    ("current_offset", 0.3, "flights", 1),
    ("current_offset", -0.2, "aprbs", 2),
])
def test_hidden_capacity_effect_is_named_first(effect, magnitude, profile, seed):
    df, _ = capacity_dataset(effect, magnitude, profile=profile, seed=seed)
    res = diagnose(df, battery())
    assert _names(res)[:1] == [effect], res.summary()
    first = res.findings[0]
    h = first["heldout"]
    assert h["gain_pct"] >= S.MIN_GAIN_PCT and h["rmse_after"] < h["rmse_before"]
    assert first["evidence"]["paired_p_value"] < S.ALPHA_HELDOUT
    p = first["parameters"]
    if effect == "current_offset":       # the bias itself is recovered
        assert p["current_offset_a"] == pytest.approx(magnitude, abs=0.05 + 3 *
                                                      p["current_offset_a_stderr"])
    elif effect == "temperature":        # the cold pack draws more charge
        assert p["temperature_coefficient_per_c"] > 2 * p["temperature_coefficient_per_c_stderr"]
    else:                                # the ageing pack draws more charge
        assert p["fade_per_cycle"] > 2 * p["fade_per_cycle_stderr"]


@pytest.mark.parametrize("profile, seed", [("aprbs", 10), ("flights", 11), ("steps", 12)])
def test_clean_capacity_data_gives_no_findings(profile, seed):
    df, _ = capacity_dataset(None, profile=profile, seed=seed)
    res = diagnose(df, battery())
    assert res.findings == [], res.summary()
    d = res.to_dict()
    assert d["findings"] == [] and d["baseline"]["level"] == "capacity"
    # the calibration alone explains most of what the pack file's model gets wrong
    assert d["baseline"]["rmse"] < d["baseline"]["rmse_as_given"]


def test_false_positive_rate_on_clean_capacity_data():
    """Smaller-count version of the benchmark's 100-data-set measurement (≤ 5 %)."""
    hits = sum(bool(diagnose(capacity_dataset(None, profile=p, seed=100 + i,
                                              n_experiments=8, duration_s=2400)[0],
                             battery()).findings)
               for i, p in enumerate(["aprbs", "flights", "steps"] * 4))
    assert hits <= 1


def test_capacity_without_temperature_does_not_claim_temperature():
    df, _ = capacity_dataset("temperature", 0.008, profile="flights", seed=1, temperature=False)
    res = diagnose(df, battery())
    assert "temperature" not in _names(res)
    skipped = {s["effect"]: s["reason"] for s in res.to_dict()["skipped"]}
    assert "temperature_c" in skipped["temperature"]


def test_two_capacity_effects_are_both_found():
    df, _ = capacity_dataset({"temperature": 0.006, "current_offset": 0.2}, profile="flights",
                             seed=1)
    res = diagnose(df, battery())
    assert set(_names(res)) == {"temperature", "current_offset"}, res.summary()


def test_offset_without_rests_is_skipped_not_guessed():
    """Constant-power steps without rests, the power the logged V·I: a sensor bias cannot
    be told from δ, and the detection entry says it is not identifiable."""
    df, _ = capacity_dataset("current_offset", 0.3, profile="steps", seed=0)
    df["power_w"] = df["voltage_v"] * df["current_a"]
    res = diagnose(df, battery())
    assert "current_offset" not in _names(res)
    assert any(s["effect"] == "current_offset" and "rests" in s["reason"]
               for s in res.skipped)
    entries = [d for d in res.detection if d["effect"] == "current_offset"]
    assert entries and not any(d["identifiable"] for d in entries)
    assert all("not identifiable" in d["text"] for d in entries)


def test_offset_without_rests_is_found_on_an_independent_power_channel():
    """The same steps with the load's own power logged: the current minus power/voltage
    is the bias, sample by sample (direct evidence), with no rest needed."""
    df, _ = capacity_dataset("current_offset", 0.3, profile="steps", seed=0)
    res = diagnose(df, battery())
    first = res.findings[0]
    assert first["effect"] == "current_offset" and first["level"] == "sensors"
    p = first["parameters"]
    assert p["current_offset_a"] == pytest.approx(0.3, abs=3 * p["current_offset_a_stderr"]
                                                  + 0.01)
    assert any("separate load" in a for a in first["alternatives"])


def test_fade_from_experiment_order_says_so():
    """Without a cycle count the fade is read off the experiments' order, and the finding
    lists what else lowers the later discharges' charge: colder cells (a P42A matrix run
    with its cold discharges last named a fade so), a change of charger or cut-off, files
    out of order. With the cycle count logged it lists none of them."""
    df, _ = capacity_dataset("capacity_fade", 1e-3, profile="aprbs", seed=2)
    res = diagnose(df.drop(columns="cycle"), battery())
    fade = next(f for f in res.findings if f["effect"] == "capacity_fade")
    assert fade["parameters"]["cycle_from_experiment_order"] == 1.0
    assert "order" in fade["cause"]
    alternatives = " ".join(fade["alternatives"])
    assert "colder" in alternatives and "charger" in alternatives and "order" in alternatives
    assert "or: later discharges colder" in res.summary()
    logged = diagnose(df, battery())
    fade = next(f for f in logged.findings if f["effect"] == "capacity_fade")
    assert fade["parameters"]["cycle_from_experiment_order"] == 0.0
    assert fade["alternatives"] == []


# ----------------------------------------------------------------------------- power

@pytest.mark.parametrize("effect, magnitude, seed, profile", [
    ("wind", (4.0, 250.0), 0, "survey"),
    ("wind", (7.0, 30.0), 1, "lawnmower"),
    ("air_density", 0.08, 0, "survey"),
    ("air_density", 0.15, 2, "lawnmower"),
    ("payload_change", -0.5, 0, "survey"),
    ("payload_change", 0.8, 1, "lawnmower"),
    ("system_power", 40.0, 0, "survey"),
    ("system_power", 60.0, 1, "survey"),
    ("efficiency_curve", 1.5e-3, 0, "survey"),
    ("efficiency_curve", 2.5e-3, 2, "survey"),
])
def test_hidden_power_effect_is_named_first(effect, magnitude, seed, profile):
    """The hidden effect is named first with its parameter — or, where a rival of other
    physics explains the same misfit and the held-out data prefer neither (a constant load
    and an efficiency curve on flights whose power varies little: search, "Rival
    effects"), neither is named, both are withheld as confounded and the hidden one is
    said not identifiable; never the rival alone."""
    res, truth = _power(effect, magnitude, seed, profile=profile)
    if _tied(res, effect):
        return
    assert _names(res)[:1] == [effect], res.summary()
    first = res.findings[0]
    assert first["level"] == "power" and first["unit"] == "W"
    assert first["heldout"]["gain_pct"] >= S.MIN_GAIN_PCT
    p = first["parameters"]
    if effect == "wind":
        speed, frm = magnitude
        assert p["wind_speed_ms"] == pytest.approx(speed, rel=0.15)
        assert abs((p["wind_from_deg"] - frm + 180) % 360 - 180) < 15
    elif effect == "air_density":
        assert p["density_exponent"] == pytest.approx(1.0, abs=0.2)
    elif effect == "payload_change":
        assert p["mass_step_kg"] == pytest.approx(magnitude, rel=0.15)
        for flight, tc in truth["change_time_s"].items():
            found = p.get(f"change_time_s[{flight}]")
            assert found is None or abs(found - tc) < 30
        # a step of the power, named with its evidence and what else makes one
        assert first["headline"].startswith("Power step")
        assert "or anything else that" in first["cause"]
        assert any("flight mode" in a for a in first["alternatives"])
        assert any("load of" in a for a in first["alternatives"])
    elif effect == "system_power":
        assert p["missing_w"] == pytest.approx(magnitude, rel=0.35)
    else:
        assert p["efficiency_slope"] < 0 and p["efficiency_at_high"] < p["efficiency_at_low"]


def test_a_finding_quotes_the_test_its_rival_lost():
    """A 60 W constant load: an efficiency curve explains much of the same misfit and
    passes alone, and is held against it (search, "Rival effects"); the load is named,
    and its evidence quotes the rival and the paired test of their held-out losses that
    the rival lost, in the JSON and in the summary."""
    res, _ = _power("system_power", 60.0, 1, profile="survey")
    assert _names(res)[:1] == ["system_power"], res.summary()
    first = res.findings[0]
    cands = res.levels["power"].result.candidates
    (held,) = [h for h in first["evidence"]["held_against"] if h["rival"] == "efficiency_curve"]
    assert held["rival_gain_pct"] == pytest.approx(cands["efficiency_curve"].gain_pct)
    assert held["gain_pct"] == pytest.approx(cands["system_power"].gain_pct)
    assert held["rival_gain_pct"] >= S.MIN_GAIN_PCT > 0
    assert held["paired_p"] < 0.5 * S.ALPHA_HELDOUT
    assert f"held against efficiency_curve: {held['text']}" in res.summary()


@pytest.mark.parametrize("seed, profile", [(20, "survey"), (21, "lawnmower")])
def test_clean_power_data_gives_no_findings(seed, profile):
    res, _ = _power(None, None, seed, profile=profile)
    assert res.findings == [], res.summary()
    base = res.levels["power"].base_values
    assert base["efficiency"] == pytest.approx(0.72, abs=0.03)   # calibrated from 0.60


def test_vertical_descents_flown_by_the_model_itself_are_not_called_a_misfit():
    """Four flights made by the planner's own rotor model descend vertically at 1 m/s at
    their end: the descents' misfit is measured there and is nil (within 2 % of their
    power), and no note calls it one. Real flights differ: the DJI M100 draws some 5 %
    less (tests/identify/diagnose/test_effect_matrix.py)."""
    res, _ = _power(None, None, 20, profile="survey")
    r = res.levels["power"].result
    m = r.level.descent_misfit(r.final_fit, [])
    assert m["flights"] == 4 and m["rate_ms"] == pytest.approx(1.0, abs=0.2)
    assert abs(m["misfit_w"]) < 0.02 * m["power_w"]
    assert not [n for n in res.notes if "vertical descents" in n]


def test_two_power_effects_are_both_found():
    res, _ = _power({"wind": (5.0, 120.0), "payload_change": -0.5}, None, 3)
    assert set(_names(res)) == {"wind", "payload_change"}, res.summary()


def test_wind_needs_the_course():
    df, _ = power_dataset("wind", (6.0, 90.0), seed=0, **FLIGHTS)
    res = diagnose(df.drop(columns="course_deg"), battery(PACK_6S), aircraft_file(**WRONG),
                   effects=["wind", "system_power"])
    assert "wind" not in _names(res)
    assert any(s["effect"] == "wind" and "course_deg" in s["reason"] for s in res.skipped)


def test_fixed_wing_flights_with_measured_airspeed():
    """Fixed-wing flights flown by testkit.flight in three winds: the polar and η are
    calibrated; a wind cannot matter when the airspeed is measured, and diagnose says so."""
    import pandas as pd

    from planner.io.mission import load_mission
    from planner.physics.mission import Environment
    from planner.parameters import load_aircraft_and_battery
    from testkit.flight import simulate_flight

    repo = Path(__file__).resolve().parents[3]
    ac, pack = load_aircraft_and_battery(repo / "aircraft/phoenix_s.yaml")
    mission = load_mission(repo / "missions/mapping_plane.yaml", vehicle_type="fixed_wing")
    df = pd.concat([simulate_flight(mission, ac, pack, environment=Environment(w, d, 15.0, None,
                                                                               100.0),
                                    seed=i, experiment=f"fw{i}", rate_hz=2.0)
                    for i, (w, d) in enumerate([(0.0, 0.0), (3.0, 90.0), (5.0, 200.0)])],
                   ignore_index=True)
    res = diagnose(df, pack, ac)
    assert res.findings == [], res.summary()
    assert set(res.levels) == {"capacity", "power"}
    assert set(res.levels["power"].base_values) >= {"cd0", "k", "efficiency"}
    why = {s["effect"]: s["reason"] for s in res.skipped}
    assert "airspeed is measured" in why["wind"]


# ----------------------------------------------------------------------------- output

def test_json_has_the_design_fields(tmp_path):
    df, _ = capacity_dataset("temperature", 0.008, profile="flights", seed=1)
    res = diagnose(df, battery())
    d = json.loads(json.dumps(res.to_dict(), default=float))
    assert set(d["baseline"]) >= {"level", "rmse", "unit", "final_error_pct"}
    assert d["baseline"]["unit"] == "mAh"
    f = d["findings"][0]
    assert set(f) >= {"effect", "cause", "parameters", "evidence", "heldout"}
    assert set(f["heldout"]) >= {"rmse_before", "rmse_after", "gain_pct"}
    assert f["effect"] in EFFECTS and isinstance(f["cause"], str) and f["cause"]
    assert all(isinstance(v, float) for v in f["parameters"].values())
    assert f["heldout"]["gain_pct"] == pytest.approx(
        100 * (1 - f["heldout"]["rmse_after"] / f["heldout"]["rmse_before"]))
    assert "unexplained" in d
    # the skipped effects say why (no aircraft: the power level did not run)
    assert {s["effect"] for s in d["skipped"]} >= {"wind", "payload_change"}
    assert "Cold pack" in res.summary() and "→" in res.summary()


def test_split_rule_respects_time():
    one = S.make_split([(0.0, 1200.0)])
    assert not one.whole_experiments and len(one.units) == S.N_BLOCKS_SINGLE
    assert [u.fold for u in one.units[:5]] == [0, 1, 2, 3, 0]
    assert all(u.t1 == pytest.approx(v.t0) for u, v in zip(one.units, one.units[1:]))
    many = S.make_split([(0.0, 100.0)] * 6)
    assert many.whole_experiments
    folds = {}
    for u in many.units:                 # every experiment lies in one fold, whole
        folds.setdefault(u.exp, set()).add(u.fold)
    assert all(len(f) == 1 for f in folds.values()) and len(many.units) >= S.MIN_UNITS


def test_sign_flip_test():
    assert S.sign_flip_test(np.ones(8)) == pytest.approx(2 / 257)   # exact enumeration
    assert S.sign_flip_test(np.r_[np.ones(8), -np.ones(8)]) > 0.4
    assert S.sign_flip_test(np.r_[100.0, np.full(9, -1.0)]) > 0.05  # one unit is no proof


def test_unknown_effect_name_is_bad_input():
    with pytest.raises(InputError, match="unknown effect"):
        make_effects(["temperature", "moon_phase"])


def test_too_short_data_runs_and_says_why():
    df, _ = capacity_dataset(None, n_experiments=1, duration_s=20.0, seed=0)
    res = diagnose(df, battery())
    assert res.findings == [] and not res.levels
    assert any("too short" in n for n in res.notes)
    assert res.to_dict()["baseline"] is None


def test_false_positive_rate_on_100_clean_data_sets():
    """Issue 'Diagnose': the false-positive rate over many clean data sets is ≤ 5 %."""
    hits = 0
    for i in range(100):
        df, _ = capacity_dataset(None, profile=["aprbs", "flights", "steps"][i % 3],
                                 seed=1000 + i)
        hits += bool(diagnose(df, battery()).findings)
    assert hits <= 5


def test_diagnose_plot_gives_panels_only_to_significant_findings():
    """Operator's-view point 10: effects that were not significant get no panel; every
    time axis is in minutes."""
    from planner.cli.plots.diagnose import diagnose_figure

    df, _ = capacity_dataset(None, profile="aprbs", seed=10)
    clean = diagnose(df, battery())
    assert clean.findings == []
    shown = [ax for ax in diagnose_figure(clean).axes if ax.get_visible() and ax.axison]
    assert len(shown) == len(clean.levels)           # the residual against time, per level
    df, _ = capacity_dataset("capacity_fade", 1e-3, profile="steps", seed=2)
    found = diagnose(df, battery())
    shown = [ax for ax in diagnose_figure(found).axes if ax.get_visible() and ax.axison]
    assert len(shown) == len(found.levels) + len(found.findings)
    for ax in shown:
        if "time" in ax.get_xlabel():
            assert "[min]" in ax.get_xlabel()


# ----------------------------------------------------------------------------- direct evidence

def test_pack_temperature_against_the_voltage_sag_measures_the_activation_energy():
    """The generator's pack resistance follows Arrhenius at 25 kJ/mol: the voltage's step
    against the current's step, per discharge, against the logged pack temperature gives
    it back (direct evidence, carried by the capacity level's temperature finding)."""
    df, _ = capacity_dataset("temperature", 0.006, profile="flights", seed=1)
    res = diagnose(df, battery())
    first = res.findings[0]
    assert first["effect"] == "temperature" and first["level"] == "capacity"
    ev = first["direct_evidence"]
    assert ev["level"] == "resistance"
    p = ev["parameters"]
    assert p["activation_energy_j_per_mol"] == pytest.approx(
        25_000.0, abs=3 * p["activation_energy_j_per_mol_stderr"] + 500.0)
    assert "voltage sag" in first["cause"]
    entry = next(d for d in res.detection if d["level"] == "resistance")
    assert entry["found"] and entry["limit"] < 25_000.0


def test_clean_pack_temperature_gives_a_limit_not_a_finding():
    df, _ = capacity_dataset(None, profile="flights", seed=5)
    res = diagnose(df, battery())
    assert res.findings == []
    entry = next(d for d in res.detection if d["effect"] == "temperature"
                 and d["level"] == "resistance")
    assert entry["identifiable"] and not entry["found"]
    assert entry["text"].startswith("None found: a cold-pack effect smaller than")
    assert entry["limit"] > 0


# ----------------------------------------------------------------------------- detection limits

def test_clean_flights_give_each_power_effect_a_detection_limit():
    """Nothing found is never silent: every power effect asked for has the smallest size
    these flights could reveal (or why none is identifiable), printed and in the JSON."""
    res, _ = _power(None, None, 20)
    assert res.findings == []
    d = json.loads(json.dumps(res.to_dict(), default=float))
    entries = {e["effect"]: e for e in d["detection_limits"] if e["level"] == "power"}
    assert set(entries) >= {"wind", "payload_change", "system_power", "efficiency_curve"}
    pay = entries["payload_change"]
    assert pay["identifiable"] and not pay["found"] and pay["unit"] == "kg"
    assert 0.0 < pay["limit"] < 0.9 * 2.8          # below 90 % of the all-up mass
    assert pay["text"].startswith("None found: a payload change smaller than")
    assert "these 4 flights" in pay["text"]
    # the limit depends on where in the flights the change falls
    by = {float(k): v for k, v in pay["by_position"].items() if v is not None}
    assert min(by.values()) == pytest.approx(pay["limit"], rel=1e-6)
    assert max(by[0.1], by[0.9]) > pay["limit"]    # harder at the start or the end
    for e in entries.values():
        assert e["identifiable"] == (e["limit"] is not None)
        assert e["text"] and e["help"]
    assert "Detection limits" in res.summary()


@pytest.mark.parametrize("magnitude, seed, profile", [(-0.5, 0, "survey"),
                                                      (0.8, 1, "lawnmower")])
def test_on_flights_the_model_fits_the_placebo_steps_are_as_small_as_the_fits_error(
        magnitude, seed, profile):
    """Placebo steps (the step fitted on the final residual at other times of the same
    flights: search, "Change points") measure what the residual makes of a step by
    itself. Where the power follows the model but for noise and turbulence, they are of
    the size of the fit's own standard error; the step's standard error is the larger
    of the two, and the truth lies within two of it. These flights end with vertical
    descents that the model flies right (the flights are the model's own): read on the
    located flights with a power level of the descents' own (search, "Change points"),
    the step moves from the fit on every flight by less than that fit's error."""
    res, _ = _power("payload_change", magnitude, seed, profile=profile)
    p = next(f for f in res.findings if f["effect"] == "payload_change")["parameters"]
    assert p["placebo_positions"] >= S.MIN_PLACEBOS
    ratio = p["mass_step_kg_placebo_sd"] / p["mass_step_kg_fit_stderr"]
    assert 0.3 < ratio < 2.5
    assert p["mass_step_kg_read_descent_level"] == 1.0
    assert p["mass_step_kg_read_flights"] == p["flights_with_change"] >= S.MIN_DESCENT_FLIGHTS
    assert abs(p["mass_step_kg"] - p["mass_step_kg_pooled"]) < p["mass_step_kg_pooled_stderr"]
    assert p["mass_step_kg_stderr"] == max(p["mass_step_kg_fit_stderr"],
                                           p["mass_step_kg_placebo_sd"])
    assert abs(p["mass_step_kg"] - magnitude) < 2 * p["mass_step_kg_stderr"]


@pytest.mark.parametrize("speed, frm, seed, profile", [(4.0, 250.0, 0, "survey"),
                                                       (7.0, 30.0, 1, "lawnmower")])
def test_a_winds_error_counts_the_bias_a_misfit_of_the_hover_puts_into_it(
        speed, frm, seed, profile):
    """A multirotor's wind is read partly in its hover (search, "Wind"): there the wind
    sets the airspeed, and the model's power at low airspeed its effect. On flights made
    by the model the hover's own power level moves the wind by no more than noise would
    (the bias is of the size of the fit's error); with the hover drawing 30 W more than
    the model says, the wind comes out slow and the bias that the hover's level shows
    keeps the truth within two standard errors, where the fit's error alone would put it
    many errors away. Eight flights: on four, a wind whose error is the flights' scatter
    rests on fewer than four flights in effect and is judged on Student's t
    (search, "Selection statistics"), which is not what is tested here."""
    df, truth = power_dataset("wind", (speed, frm), seed=seed, profile=profile,
                              n_flights=8, **FLIGHTS)

    def wind(record):
        res = diagnose(record, battery(PACK_6S), aircraft_file(**WRONG),
                       payload_kg=truth["payload_kg"])
        return next(f for f in res.findings if f["effect"] == "wind")["parameters"]

    p = wind(df)
    assert p["wind_speed_ms_hover_bias"] <= abs(p["wind_speed_ms_hover_shift"])
    assert p["wind_speed_ms_hover_bias"] < 3 * p["wind_speed_ms_stderr"] < 0.1 * speed
    assert abs(p["wind_speed_ms"] - speed) < 2 * p["wind_speed_ms_stderr"]

    hover = (df["groundspeed_ms"].abs() < 2.0) & (df["altitude_m"] > 1.0)
    assert 0.1 < hover.mean() < 0.5
    off = df.copy()
    off.loc[hover, "power_w"] += 30.0
    off.loc[hover, "current_a"] += 30.0 / off.loc[hover, "voltage_v"]
    q = wind(off)
    bias = q["wind_speed_ms_hover_bias"]
    assert q["wind_speed_ms"] < speed - 0.1 * speed          # slow: the hover's misfit
    fit_only = math.sqrt(max(q["wind_speed_ms_stderr"]**2 - bias**2, 0.0))
    assert abs(q["wind_speed_ms"] - speed) > 3 * fit_only
    assert q["wind_speed_ms_stderr"] == pytest.approx(math.hypot(fit_only, bias))
    assert abs(q["wind_speed_ms"] - speed) < 2 * q["wind_speed_ms_stderr"]


def test_a_payload_change_above_its_limit_is_found_and_the_limit_says_so():
    res, truth = _power("payload_change", -0.5, 0)
    entry = next(e for e in res.detection if e["effect"] == "payload_change"
                 and e["level"] == "power")
    assert entry["found"] and entry["identifiable"]
    assert entry["limit"] < 0.5


def test_no_pack_and_no_voltage_names_the_data_file(tmp_path):
    """Without a pack file the cell count comes from the voltage: a record without
    voltage_v (a renamed column) is refused naming the file it came from."""
    df, _ = capacity_dataset(None, n_experiments=2, duration_s=600, seed=0)
    path = tmp_path / "no_voltage.csv"
    df.drop(columns=[c for c in df.columns if c == "voltage_v"]).to_csv(path, index=False)
    with pytest.raises(InputError, match=r"no_voltage\.csv: no battery given and no pack "
                                         r"voltage \(voltage_v\)"):
        diagnose([path])


def test_an_offset_behind_a_vi_power_is_not_said_to_need_rests_the_record_has():
    """Flights with rests between them, the power the logged V·I (as the McGill
    hexarotor's three hovers log it): the rests cannot show a current-sensor offset, for
    a rest reads the avionics' draw plus the offset and the model driven by V·I draws the
    offset too. The entry says what would: a power channel of its own, or the sensor's
    zero read with the avionics unplugged, not rests alone."""
    df, _ = capacity_dataset("current_offset", 0.3, profile="flights", seed=0)
    df["power_w"] = df["voltage_v"] * df["current_a"]
    assert (df["current_a"] < 0.05 * df["current_a"].median()).mean() > 0.01   # rests
    res = diagnose(df, battery())
    assert "current_offset" not in _names(res)
    entries = [d for d in res.detection if d["effect"] == "current_offset"]
    assert entries and not any(d["identifiable"] for d in entries)
    for d in entries:
        assert "avionics unplugged" in d["help"] and "power module" in d["help"]
        assert "or rests with the load off" not in d["text"]


def test_a_named_wind_lists_what_else_follows_the_course_and_a_sparse_records_caveat():
    """A wind's finding lists its alternatives: a step of mass or load where the flights
    turn onto another leg; and on a record sampled every 4 s (a telemetry log at 0.25 Hz,
    where on the M100's routes a release was no longer located and a wind took it up,
    docs/results.md) that a step within a flight cannot be located there."""
    from testkit.matrix import decimate

    df, _ = power_dataset("wind", (6.0, 90.0), seed=0, **FLIGHTS)
    for rate, sparse in ((None, False), (0.25, True)):
        data = df if rate is None else decimate(df, rate)
        res = diagnose(data, battery(PACK_6S), aircraft_file(),
                       effects=["wind", "system_power"])
        wind = next(f for f in res.findings if f["effect"] == "wind")
        alternatives = " ".join(wind["alternatives"])
        assert "turn onto another leg" in alternatives
        assert ("one sample every 4.0 s" in alternatives) == sparse, alternatives
        assert ("one sample every" in res.summary()) == sparse


def test_a_wind_is_read_through_the_flights_own_change_of_power_with_airspeed():
    """Eight flights in a 6 m/s wind whose aircraft draws half the rotor model's change of
    power with airspeed (the DJI M100's, docs/results.md): read through the model's own
    change the wind comes out slow, beyond its error; with the change's scale free
    (search, "Wind") the scale is found near a half, the wind within 2 SE of the truth
    and the finding says both readings. The detection limit rises with it: the wind's
    power is half what the model says. On flights with the model's own change of power
    with airspeed the wind is the model's reading."""
    def wind(response):
        df, truth = power_dataset("wind", (6.0, 90.0), seed=0, n_flights=8,
                                  speed_response=response, **FLIGHTS)
        res = diagnose(df, battery(PACK_6S), aircraft_file(**WRONG),
                       payload_kg=truth["payload_kg"])
        f = next(f for f in res.findings if f["effect"] == "wind")
        entry = next(e for e in res.detection if e["effect"] == "wind")
        note = any("changes with airspeed" in n for n in res.notes)
        return f, entry, note

    f, entry, note = wind(0.5)
    p = f["parameters"]
    assert 0.35 < p["speed_response"] < 0.6
    assert p["wind_speed_ms_model"] < 6.0 - 3 * p["wind_speed_ms_stderr"]
    assert abs(p["wind_speed_ms"] - 6.0) < 2 * p["wind_speed_ms_stderr"]
    assert "times as much as the calibrated model's" in f["cause"]
    assert note                       # a model-form misfit, said as such
    same, same_entry, same_note = wind(1.0)
    q = same["parameters"]
    assert q["wind_speed_ms"] == q["wind_speed_ms_model"]
    assert "times as much" not in same["cause"] and not same_note
    assert entry["limit"] > 1.8 * same_entry["limit"]


def test_a_wind_is_read_through_the_flights_scale_only_where_it_differs_from_the_models():
    """speed_scale: within 2 standard errors or a tenth of 1 the model's change of power
    with airspeed stands; farther, the flights' scale; not clearly above 0, none (a wind
    read through it is withheld as one whose speed cannot be told)."""
    from planner.identify.diagnose.effects import Wind, speed_scale

    assert speed_scale(0.93, 0.01) == 1.0            # the tests' own flights: the floor
    assert speed_scale(0.5, 0.3) == 1.0              # within 2 SE of 1
    assert speed_scale(0.55, 0.1) == 0.55
    assert speed_scale(1.4, 0.05) == 1.4
    assert math.isnan(speed_scale(0.1, 0.1))
    why = Wind().implausible({"speed_response": 0.1, "speed_response_stderr": 0.1,
                              "wind_speed_ms": 3.0}, None)
    assert "cannot be told" in why


def test_a_record_without_a_course_reads_the_speed_response_without_a_wind():
    """Eight flights without wind whose aircraft draws half the rotor model's change of
    power with airspeed, the course not logged: no wind can be fitted, and the note on
    the model's misfit says the scale without one (search, "Wind")."""
    df, truth = power_dataset(None, None, seed=1, n_flights=8, speed_response=0.5, **FLIGHTS)
    res = diagnose(df.drop(columns=["course_deg"]), battery(PACK_6S), aircraft_file(**WRONG),
                   payload_kg=truth["payload_kg"])
    k, se, wind = res.levels["power"].result.speed_response
    assert not wind and abs(k - 0.5) < 0.1 and se < 0.05
    note = next(n for n in res.notes if "changes with airspeed" in n)
    assert "steady wind" not in note
