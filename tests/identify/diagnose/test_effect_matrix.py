"""The effect matrix of ``diagnose`` on real data, a seeded small sample.

The full matrix is ``python benchmarks/bench_effect_matrix.py`` (every effect × every real
source that can carry it × record richness × timing × size; figures in
docs/results.md). Here a few of its cells run on the real data of ``../shared/data``
with a fixed seed and few runs, and each must meet the issue's criterion for its kind
(:func:`testkit.matrix.verdict`): clean cells silent, cells the detection limit calls
identifiable named first, the others said to be not identifiable with no false cause.
The injections are physical laws of :mod:`testkit.injections`, which imports nothing of
the planner (checked below), so diagnose is examined on data its own models did not make.
"""

import ast
import math
from pathlib import Path

import pytest

from testkit import matrix as M

REPO = Path(__file__).resolve().parents[3]

#: (cell, runs): real Molicel P42A and A123 discharges, 16 real DJI M100 flights, real logs.
SAMPLE = [
    (M.Cell("p42a", "fade", "everything", None, "realistic"), 4),
    (M.Cell("p42a", "cold_cells", "everything", None, "realistic"), 4),
    (M.Cell("p42a", "cold_cells", "plain", None, "realistic"), 3),
    (M.Cell("p42a", "offset", "minimal", None, "realistic"), 3),
    (M.Cell("a123", "real_cold", "everything", None, "realistic"), 1),
    (M.Cell("m100", "clean", "plain", None, "realistic"), 2),
    # route R1 with the payload classes mixed in one draw, each flight given its own
    (M.Cell("m100_mixed", "payload", "plain", "mid", "realistic"), 2),
    # route R1 with a release injected by the M100's own measured power per kilogram
    (M.Cell("m100_measured", "payload", "plain", "random", "realistic"), 2),
    # log 171's plain record carries a real power step (testkit.matrix, "The record's own
    # findings"); with every channel a current offset against the power channel
    (M.Cell("log171", "clean", "plain", None, "realistic"), 2),
    (M.Cell("log171", "offset", "everything", None, "realistic"), 2),
    # another day of the McGill hexarotor, its rests between three hovers; a short damaged
    # ULog of another quadrotor
    (M.Cell("mcgill_hovers", "offset", "plain", None, "realistic"), 2),
    (M.Cell("px4_quad_v6xrt", "load", "plain", None, "realistic"), 2),
]


@pytest.fixture(scope="module")
def draws(shared_data):
    if not M.available():
        pytest.skip(f"the M100 flights and logs are not at {M.DATA}")
    return {}


@pytest.mark.parametrize("cell, runs", SAMPLE, ids=[c.name for c, _ in SAMPLE])
def test_a_seeded_cell_of_the_effect_matrix_meets_the_criterion(cell, runs, draws):
    st = M.run_cell(cell, runs, seed=0, draws=draws)
    assert not st["errors"], dict(st["errors"])
    kind, met = M.verdict(st)
    assert met, (kind, {k: st[k] for k in ("named_first", "named_any", "false_runs",
                                            "identifiable", "said_not_identifiable",
                                            "within_2se", "checked_2se", "limits",
                                            "sizes")})
    if kind == "not identifiable":
        # a miss is never silent: the output says the effect cannot be seen in these data
        assert st["said_not_identifiable"] == st["runs"] - st["named_any"]
        assert st["named_or_said_not_identifiable"] == st["runs"] - st["identifiable"]
    if kind == "identifiable":
        assert st["named_first_identifiable"] >= 0.8 * st["identifiable"]
    assert max(st["cpu_s"]) < 5.0
    if cell.injection != "clean":
        # each run is kept, and adds up to the cell's tallies
        runs_kept = st["per_run"]
        assert len(runs_kept) == st["runs"]
        assert sum(r["named_first"] for r in runs_kept) == st["named_first"]
        assert sum(r["named_any"] for r in runs_kept) == st["named_any"]
        assert [r["limit"] for r in runs_kept] == st["limits"]
    if cell.source == "log171" and cell.richness == "plain":
        # the real step is still reported, in every run, and only as the record's own
        assert st["own"] == {"payload_change": st["runs"]} and not st["false"]


def test_a_late_release_on_real_m100_flights_is_named_only_where_the_descents_leave_it_clear(
        draws):
    """A payload released at 75–90 % of each flight's airborne time on 16 real DJI M100
    route-R1 flights (Rodrigues et al. 2021, CC BY 4.0) with every channel. Every R1
    flight ends with a slow vertical descent drawn some 20–25 W below the rotor model
    (docs/results.md), where such a release falls: the step takes that misfit up and is
    found 15–30 % large. The placebo steps cannot see it (the step has taken it out of
    the residual they are fitted to); fitted once more with a power level of the
    descents' own, the step moves by 0.1–0.27 kg, and that shift is part of its error.
    Where the step then stands less than 2 standard errors from none it is withheld and
    the output says why (not "none found"); where it is named, the truth lies within 2 SE
    of it; the cell meets the criterion (seed 0: none of 5 named, each said not
    identifiable)."""
    cell = M.Cell("m100", "payload", "everything", "late", "realistic")
    st = M.run_cell(cell, 5, seed=0, draws=draws)
    kind, met = M.verdict(st)
    assert met, (kind, st)
    assert st["within_2se"] == st["checked_2se"] == st["named_first"]
    assert st["said_not_identifiable"] == st["runs"] - st["named_any"]


def _late_release(source, richness, run, draws, drop=(), kind="payload"):
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose

    cell = M.Cell(source, kind, richness, "late", "realistic")
    key = (source, run, 0)
    if key not in draws:
        draws[key] = M.sources()[source].draw(np.random.default_rng(M._seed(cell, run, 0)))
    d = draws[key]
    injd = M.inject(kind, d, np.random.default_rng(M._detail_seed(cell, run, 0)),
                    M.SIZES["realistic"], "late")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(M.reduce(injd.record, richness).drop(columns=list(drop)), d.pack,
                       M.diagnosed_aircraft(d, richness), payload_kg=injd.payload_kg,
                       site_altitude_m=d.site_altitude_m)
    return res, M._truth(kind, injd, None, res)[0]


def _diagnosed(cell, run, seed):
    """The run ``run`` of ``cell`` on ``seed`` as the matrix runs it
    (:func:`testkit.matrix.run_cell`): its draw, its injection and what diagnose returns
    on the reduced record."""
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose

    d = M.sources()[cell.source].draw(np.random.default_rng(M._seed(cell, run, seed)))
    injd = M.inject(cell.injection, d, np.random.default_rng(M._detail_seed(cell, run, seed)),
                    M.SIZES[cell.size], cell.timing)
    rec, pay = M.given(M.reduce(injd.record, cell.richness), injd.payload_kg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(rec, d.pack, M.diagnosed_aircraft(d, cell.richness),
                       site_altitude_m=d.site_altitude_m, **pay)
    return d, injd, res


def test_a_late_release_on_other_m100_routes_is_read_on_its_located_flights(draws):
    """A payload released late (75–90 %) on 16 real DJI M100 flights of the routes other
    than R1 (Rodrigues et al. 2021, CC BY 4.0), plain record, seed 0's first draw. Fitted
    on every flight the step is found 20 % large (−0.37 against −0.31 kg): it takes up
    part of the vertical descents' misfit. Read on the flights whose change is located,
    with a power level of the descents' own (search, "Change points"), it is nearer the
    truth, which lies within 2 SE of it."""
    res, truth = _late_release("m100_routes", "plain", 0, draws)
    first = res.findings[0]
    assert first["effect"] == "payload_change"
    p = first["parameters"]
    assert p["mass_step_kg_read_descent_level"] == 1.0
    assert p["mass_step_kg_read_flights"] == p["flights_with_change"]
    assert abs(p["mass_step_kg"] - truth["mass_step_kg"]) < \
        abs(p["mass_step_kg_pooled"] - truth["mass_step_kg"])
    assert p["mass_step_kg_stderr"] == max(p["mass_step_kg_fit_stderr"],
                                           p["mass_step_kg_placebo_sd"])
    assert M.within_2se("payload_change", p, truth)


def test_a_late_pick_up_on_other_m100_routes_is_read_on_its_located_flights(draws):
    """A payload picked up late (75–90 %) on 16 real DJI M100 flights of the routes other
    than R1 (Rodrigues et al. 2021, CC BY 4.0), plain record, seed 0's first draw. The
    change is located in 6 flights of 16. Fitted on every flight, the unlocated ones by
    the expectation of their change and the final descents (which the model over-predicts
    by 20–28 W on clean flights of these routes) by the model, the step comes out a
    third small: 0.21 against 0.31 kg, five of its standard errors away. Read on the
    located flights with a power level of the descents' own (search, "Change points") it
    is 0.29 kg, and the truth lies within 2 SE."""
    res, truth = _late_release("m100_routes", "plain", 0, draws, kind="pickup")
    first = res.findings[0]
    assert first["effect"] == "payload_change"
    p = first["parameters"]
    assert p["mass_step_kg_read_flights"] == p["flights_with_change"] < 16
    assert abs(p["mass_step_kg_pooled"] - truth["mass_step_kg"]) > \
        2 * p["mass_step_kg_pooled_stderr"]
    assert M.within_2se("payload_change", p, truth)
    # the finding says how it was sized, and what the fit on every flight found
    k = int(p["flights_with_change"])
    assert f"sized on the {k} flights whose change is located, the vertical descents" \
        in first["cause"]
    assert f"fitted on every flight: {p['mass_step_kg_pooled']:.2f} kg" in first["cause"]


def test_late_pick_ups_on_other_m100_routes_are_sized_within_2_se(draws):
    """The late pick-up cell of the routes other than R1 (DJI M100, Rodrigues et al. 2021,
    CC BY 4.0), plain record, five draws (seed 0): each run that names the pick-up sizes
    it within 2 SE (0 of 3 when the step was the fit on every flight, its error widened
    by the descents' bias), and the others say it is not identifiable."""
    cell = M.Cell("m100_routes", "pickup", "plain", "late", "realistic")
    st = M.run_cell(cell, 5, seed=0, draws=draws)
    assert st["named_first"] >= 3, st
    assert st["within_2se"] == st["checked_2se"] == st["named_first"], st
    assert st["said_not_identifiable"] == st["runs"] - st["named_any"], st
    assert st["false_runs"] == 0, st


def test_a_pick_up_on_other_m100_routes_is_sized_with_its_unlocated_flights_expectation(
        draws):
    """A payload picked up mid-flight in 16 real DJI M100 flights of the routes other than
    R1 (Rodrigues et al. 2021, CC BY 4.0), plain record, five draws (seed 0). Some
    flights' changes are not located; fitted at their given mass all flight they carried
    the change in the efficiency the flights share, and the step came out small: named in
    3 of 5 (0.12 against 0.19 kg in one draw). Fitted with the change's expectation under
    a time uniform over each such flight (search, "Change points"), the pick-up is named
    in at least 4 of 5 and sized within 2 SE in at least 4."""
    cell = M.Cell("m100_routes", "pickup", "plain", "mid", "realistic")
    st = M.run_cell(cell, 5, seed=0, draws=draws)
    kind, met = M.verdict(st)
    assert met and kind == "identifiable", (kind, st)
    assert st["named_first"] >= 4 and st["within_2se"] >= 4, st


def test_an_early_pick_up_on_other_m100_routes_is_sized_with_each_flights_posterior(draws):
    """A payload picked up at 10–25 % of each flight's span in 16 real DJI M100 flights of
    the routes other than R1 (Rodrigues et al. 2021, CC BY 4.0), every channel, five draws
    (seed 0): each flight is heavier for most of its span. The flights whose change was
    not located were fitted with the share of the flight elapsed (a change uniform over
    the flight), a ramp an early change does not follow; the step came out 0.02–0.07 kg
    and the pick-up was named in 1 of 5. Fitted with each such flight's posterior of its
    change time (search, "Change points"), it is named in at least 4 of 5 and sized within
    2 SE in at least 3."""
    cell = M.Cell("m100_routes", "pickup", "everything", "early", "realistic")
    st = M.run_cell(cell, 5, seed=0, draws=draws)
    kind, met = M.verdict(st)
    assert met and kind == "identifiable", (kind, st)
    assert st["named_first"] >= 4 and st["within_2se"] >= 3, st


def _located(kind, size, runs, draws):
    """(flights, flights located within 10 s of the injected change) over ``runs`` draws
    of 16 route-R1 M100 flights, plain record, the change mid-flight (seed 0): the change
    times of the payload change fitted on all the bins, from the calibrated baseline."""
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose
    from planner.identify.diagnose.effects import make_effects

    flights = near = 0
    for run in range(runs):
        cell = M.Cell("m100", kind, "plain", "mid", size)
        key = ("m100", kind, run, size)
        if key not in draws:
            draws[key] = M.sources()["m100"].draw(
                np.random.default_rng(M._seed(cell, run, 0)))
        d = draws[key]
        injd = M.inject(kind, d, np.random.default_rng(M._detail_seed(cell, run, 0)),
                        M.SIZES[size], "mid")
        rec, pay = M.given(M.reduce(injd.record, "plain"), injd.payload_kg)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = diagnose(rec, d.pack, d.aircraft, site_altitude_m=d.site_altitude_m, **pay)
            power = res.levels["power"].result
            level = power.level
            fit = level.fit(make_effects(["payload_change"]), np.ones(level.n_rows, bool),
                            start=power.base_fit)
        for name, t in fit.state["change_time_s"].items():
            flights += 1
            near += t is not None and abs(t - injd.change_times[name]) <= 10.0
    return flights, near


def test_a_pick_up_is_located_as_a_release_is_net_of_the_climbs_and_descents_misfit(draws):
    """The change time of each flight is located on the residual of the model without
    the step, which on real DJI M100 route-R1 flights (Rodrigues et al. 2021, CC BY 4.0)
    carries the rotor model's misfit of the regimes: some +20 W in level cruise, −25 W in
    the final descents. Located on it as it is, the change from cruise to descent looks
    like a drop: a release is found late and a pick-up seldom (three draws of 16 flights,
    plain record, mid-flight: releases of realistic size within 10 s of the truth in 25
    of 48 flights, pick-ups of twice that size in 25 of 48, the landing then counted as
    flight). Located net of the climbs' and descents' own levels, pooled over the flights
    and fitted with the step (search, "Change points"), 30 and 36 of 48 (36 and 37 with
    the landing in: its touchdown, well below the model in every flight, helped a release
    and hid a pick-up)."""
    flights, near = _located("payload", "realistic", 3, draws)
    assert flights == 48 and near >= 28, near
    flights, near = _located("pickup", "2x", 3, draws)
    assert flights == 48 and near >= 34, near


def test_a_step_the_descents_leave_within_2_se_of_none_is_withheld_and_said_why(draws):
    """Seed 0's second late release on route R1 (DJI M100, plain record without the
    course): the step passes the held-out tests, but counted with the shift of the
    vertical descents it is within 2 SE of none. It is not named, and neither the
    detection entry nor the unexplained misfit says "none found": both say why, naming
    the descents. With the course logged, a steady wind (one step per flight on this
    route) fits the held-out data as well, and the step is withheld beside it instead."""
    with_course, _ = _late_release("m100", "plain", 1, draws)
    rival = [w for w in with_course.withheld if w["effect"] == "payload_change"]
    assert len(rival) == 1 and rival[0]["kind"] == "confounded", rival
    assert "wind" in rival[0]["candidates"]
    res, _ = _late_release("m100", "plain", 1, draws, drop=("course_deg",))
    assert not [f for f in res.findings if f["effect"] == "payload_change"]
    weak = [w for w in res.withheld if w["effect"] == "payload_change"]
    assert len(weak) == 1 and weak[0]["kind"] == "weak"
    p = weak[0]["parameters"]
    assert abs(p["mass_step_kg"]) < 2 * p["mass_step_kg_stderr"]
    assert p["mass_step_kg_descent_bias"] > 0.5 * p["mass_step_kg_stderr"]
    entry = next(e for e in res.detection if e["effect"] == "payload_change")
    assert not entry["identifiable"] and "vertical descents" in entry["text"]
    assert "payload_change not named" in res.unexplained()
    # the descents' bias is most of the step's error variance: more flights, which shrink
    # only the rest, are not what the entry asks for, a model of the descents is
    assert p["mass_step_kg_descent_bias"] ** 2 > 0.5 * p["mass_step_kg_stderr"] ** 2
    assert "descent_inflow_weight" in entry["help"]
    assert "more flights do not shrink" in entry["text"]
    assert "limit falls as 1/√" not in entry["text"]


def test_the_air_density_of_other_days_is_sized_within_the_flight_clustered_error(draws):
    """Air density 75–85 % of the site's in half of 16 real DJI M100 flights on routes
    other than R1, flown on several days, pressure and temperature logged (Rodrigues et
    al. 2021, CC BY 4.0): the exponent is carried by whole flights, and these flights
    scatter about the model by a level of their own from day to day. The AR(1) error
    sees only the noise within flights and covered the injected exponent in 2 of 5 runs
    (seed 0); each power-level error is now the larger of it and the flight-clustered
    sandwich's, which covers it in most runs, as the criterion asks."""
    cell = M.Cell("m100_routes", "density", "everything", None, "realistic")
    st = M.run_cell(cell, 5, seed=0, draws=draws)
    kind, met = M.verdict(st)
    assert st["named_first"] == 5 and st["false_runs"] == 0
    assert st["within_2se"] >= 4 and met, (kind, st["within_2se"])


STEP = M.RealEffect("payload_change", change_time_s=228.0)
FLIGHT = "log171"


def _step_at(t):
    return {"effect": "payload_change",
            "parameters": {"mass_step_kg": 0.43, f"change_time_s[{FLIGHT}]": t}}


@pytest.mark.parametrize("t_found, expect, injected, kind", [
    (228.3, None, None, "own"),                  # log 171's own step on its clean record
    (228.3, "wind", None, "own"),                # ... is never a false cause of a wind
    (190.0, None, None, "other"),                # a step where the record has none
    (152.0, "payload_change", 150.0, "injected"),    # the injected release, at its time
    (228.3, "payload_change", 150.0, "own"),     # the real step is not the injected one
    (190.0, "payload_change", 150.0, "other"),   # nor is a step at neither time
    (224.0, "payload_change", 221.0, "injected"),    # a late release nearer its own time
    (227.0, "payload_change", 221.0, "own"),     # ... but nearer the real step: the record's
])
def test_the_records_own_step_is_told_from_an_injected_one_by_its_time(
        t_found, expect, injected, kind):
    times = None if injected is None else {FLIGHT: injected}
    assert M.classify(_step_at(t_found), (STEP,), expect, times) == kind


def test_an_effect_without_a_time_is_the_records_own_unless_injected():
    cold = (M.RealEffect("temperature"),)
    f = {"effect": "temperature", "parameters": {"temperature_coefficient_per_c": 0.002}}
    assert M.classify(f, cold, "current_offset") == "own"
    assert M.classify(f, cold, "temperature") == "injected"
    assert M.classify(f, (), "current_offset") == "other"
    assert M.classify(f, (), "temperature") == "injected"


def test_a_step_with_no_flight_named_is_located_by_its_earliest_change():
    f = {"effect": "payload_change", "parameters": {"change_time_min_s": 229.0,
                                                     "change_time_max_s": 229.0}}
    assert M.located_changes(f["parameters"]) == {"": 229.0}
    assert M.classify(f, (STEP,), None) == "own"


def test_the_injection_laws_import_nothing_of_the_planner():
    """The examiner's rule: the effects are injected by laws written in testkit, not by
    the planner's own power or battery models."""
    tree = ast.parse((REPO / "testkit" / "injections.py").read_text())
    imported = [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    imported += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    assert imported and not [m for m in imported if m.split(".")[0] == "planner"]


def test_the_multirotor_laws_act_only_where_the_m100_flies(draws):
    """On the M100 flights of every route but R1 (Rodrigues et al. 2021, CC BY 4.0) the
    ground tests have no altitude and their motors never run, several flights end with
    the barometric altitude a few metres above the take-off's with the motors idle, and
    two hovers start in the air.
    The injection laws must not count those samples as flight: the speed law fitted on
    the level flying samples has a rotor (induced) part and predicts the measured hover
    power, and a payload is never carried on the ground."""
    import dataclasses

    import numpy as np

    from testkit import injections as inj

    df, _ = M.m100_flights(route_r1=False)          # all 22 flights, not a draw of 16
    d = dataclasses.replace(M.M100Routes().draw(np.random.default_rng(0)), record=df)
    law = M._speed_law(d)
    hover = []
    for key, idx in inj.experiments(df):
        g = df.loc[idx]
        fly = law.flying(g)
        p = g["power_w"].to_numpy(float)
        if not np.isfinite(g["altitude_m"]).any():        # a ground test
            assert not fly.any(), key
        # idle rotors on the ground draw 0-100 W (the ideal hover power is 123 W)
        assert not (fly & (p < 100.0)).any(), key
        # the hovers 221 and 222 start in the air: every sample is flight until 222 lands
        assert fly.mean() > 0.95 or key not in ("221", "222"), key
        slow = fly & (inj.speed_of(g) < 0.5) & (np.abs(inj._col(g, "climb_rate_ms")) < 0.5)
        hover.append(p[slow])
    hover = np.concatenate(hover)
    assert hover.size > 200 and law.a > 0
    assert abs(law(0.0) - np.median(hover)) < 0.05 * np.median(hover)
    times = inj.change_times(df, np.full(len(d.flights), 0.5), flying=law.flying)
    out = inj.payload_step(df, 0.3, times, d.mass_kg, rho=d.rho, pack_resistance_ohm=0.0,
                           rotors=d.rotors)
    dp = out["power_w"].to_numpy(float) - df["power_w"].to_numpy(float)
    idle = df["power_w"].to_numpy(float) < 100.0
    assert np.nanmax(np.abs(dp[idle])) == 0.0 and np.nanmax(dp) > 20.0


def test_verdict_follows_the_issue_criterion():
    base = {"runs": 10, "errors": {}, "named_first": 0, "named_any": 0, "false_runs": 0,
            "identifiable": 0, "said_not_identifiable": 0, "within_2se": 0,
            "checked_2se": 0, "silent": 10, "expect": None}
    assert M.verdict(base) == ("clean", True)
    assert M.verdict(dict(base, silent=9)) == ("clean", False)          # 90 % < 95 %
    ident = dict(base, expect="wind", identifiable=10, named_first=8, named_any=8,
                 within_2se=5, checked_2se=8)
    assert M.verdict(ident) == ("identifiable", True)
    assert M.verdict(dict(ident, named_first=7)) == ("identifiable", False)
    assert M.verdict(dict(ident, within_2se=3)) == ("identifiable", False)
    assert M.verdict(dict(ident, within_2se=4)) == ("identifiable", False)   # half is not most
    # a cell whose limit calls half its runs identifiable is not called identifiable (one
    # of two runs of a single log): its misses must be said not identifiable
    split = dict(base, expect="current_offset", runs=2, silent=0, identifiable=1,
                 named_first=1, named_any=1, within_2se=1, checked_2se=1,
                 said_not_identifiable=1)
    assert M.verdict(split) == ("not identifiable", True)
    assert M.verdict(dict(split, said_not_identifiable=0)) == ("not identifiable", False)
    hidden = dict(base, expect="wind", said_not_identifiable=10)
    assert M.verdict(hidden) == ("not identifiable", True)
    assert M.verdict(dict(hidden, said_not_identifiable=9)) == ("not identifiable", False)
    assert M.verdict(dict(hidden, false_runs=1)) == ("not identifiable", False)


def test_a_named_wind_is_set_against_the_flights_anemometer_wind(monkeypatch):
    """The flights' own wind (testkit.matrix.anemometer_wind_of) is the samples-weighted
    mean of the flights' anemometer winds with the spread between flights as its
    standard error, and a named wind is that many combined standard errors from it: the
    flights' own weather within the 95 % radius of a 2-D normal (2.45), a false cause
    beyond."""

    import numpy as np
    import pandas as pd

    winds = {"1": np.array([1.0, -2.0]), "2": np.array([3.0, 0.0]), "9": np.array([9.0, 9.0])}
    monkeypatch.setattr(M, "_anemometer_winds", lambda: winds)
    record = pd.DataFrame({"experiment": ["1"] * 30 + ["2"] * 10 + ["7"] * 50})
    d = M.Draw(record, pack=None, aircraft=None)
    got = M.anemometer_wind_of(d)
    assert got["flights"] == 2                      # flight 7 has no anemometer wind
    assert math.isclose(got["wind_e_ms"], (30 * 1.0 + 10 * 3.0) / 40)
    assert math.isclose(got["wind_n_ms"], (30 * -2.0 + 10 * 0.0) / 40)
    assert math.isclose(got["wind_e_ms_stderr"], np.std([1.0, 3.0], ddof=1) / math.sqrt(2))
    named = {"wind_e_ms": got["wind_e_ms"], "wind_e_ms_stderr": 0.0,
             "wind_n_ms": got["wind_n_ms"] + 2.0 * math.hypot(0.3, got["wind_n_ms_stderr"]),
             "wind_n_ms_stderr": 0.3, "wind_speed_ms": 1.0, "wind_from_deg": 0.0}
    cmp = M.wind_against(named, got)
    assert math.isclose(cmp["z"], 2.0)
    # 2 combined standard errors away: the flights' own weather; 3: a false cause
    assert M.weather_kind(cmp) == "own"
    far = dict(named, wind_n_ms=got["wind_n_ms"] + 3.0 * math.hypot(0.3, got["wind_n_ms_stderr"]))
    assert M.weather_kind(M.wind_against(far, got)) == "other"
    assert math.isclose(cmp["measured_from_deg"],
                        math.degrees(math.atan2(-got["wind_e_ms"], -got["wind_n_ms"])) % 360)
    assert M.anemometer_wind_of(M.Draw(record[record["experiment"] != "2"], None, None)) \
        is None                                     # one flight: no spread, no answer


@pytest.mark.parametrize("source", ["m100", "m100_routes"])
def test_the_m100s_slow_vertical_descents_draw_less_than_the_rotor_model(source, draws):
    """The DJI M100 flights (Rodrigues et al. 2021, CC BY 4.0) descend vertically at
    0.9–1.7 m/s: at the end of every flight of route R1, and on the other routes flown on
    other days. The rotor model puts that power near the hover's (Leishman's empirical
    induced velocity in the vortex-ring state, Principles of Helicopter Aerodynamics,
    2nd ed., §2.14); the aircraft draws some 17–26 W (4–6 %) less, on R1 and on the other
    routes alike. Diagnose measures it over the flights and says so in a note."""
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose

    cell = M.Cell(source, "clean", "plain", None, "realistic")
    d = M.sources()[source].draw(np.random.default_rng(M._seed(cell, 0, 0)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(M.reduce(d.record, "plain"), d.pack, d.aircraft,
                       site_altitude_m=d.site_altitude_m)
    r = res.levels["power"].result
    m = r.level.descent_misfit(r.final_fit, [e for e, _ in r.selected])
    assert m["flights"] >= 5 and 0.5 < m["rate_ms"] < 2.5
    assert -40.0 < m["misfit_w"] < -10.0 and m["misfit_w"] < -2.0 * m["stderr_w"]
    note = [n for n in res.notes if "vertical descents" in n]
    assert len(note) == 1 and f"{abs(m['misfit_w']):.0f} ±" in note[0] and "less" in note[0]


def test_the_descent_weight_calibrated_on_flights_not_drawn_takes_up_most_of_the_misfit(
        draws):
    """The same R1 draw (DJI M100, Rodrigues et al. 2021, CC BY 4.0) diagnosed with the
    slow-descent inflow weight fit-aircraft calibrates on 48 R1 flights not in the draw
    (testkit.matrix.calibrated_aircraft): the vertical descents' misfit shrinks by more
    than half (from about 25 W to about 6 W)."""
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose

    cell = M.Cell("m100", "clean", "plain", None, "realistic")
    d = M.sources()["m100"].draw(np.random.default_rng(M._seed(cell, 0, 0)))
    misfit = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for ac in (d.aircraft, M.calibrated_aircraft(d, "plain")):
            res = diagnose(M.reduce(d.record, "plain"), d.pack, ac,
                           site_altitude_m=d.site_altitude_m)
            r = res.levels["power"].result
            misfit[ac.multirotor.descent_inflow_weight] = r.level.descent_misfit(
                r.final_fit, [e for e, _ in r.selected])["misfit_w"]
    (w0, before), (w, after) = sorted(misfit.items())
    assert w0 == 0.0 and 0.5 < w <= 2.0
    assert before < -10.0 and abs(after) < 0.5 * abs(before)


def test_an_injected_winds_truth_and_size_are_the_wind_the_record_holds():
    """An injected wind adds to the one the flights flew in (on the M100, their
    anemometer's): the truth is the vector sum, and the size set against the detection
    limit is its speed, not the injected speed alone. A 4 m/s wind from the north
    injected into flights in a 3 m/s wind from the south leaves 1 m/s from the north."""

    injd = M.Injected(record=None, payload_kg=0.0,
                      truth={"wind_speed_ms": 4.0, "wind_from_deg": 0.0}, size=4.0)
    measured = {"wind_n_ms": 3.0, "wind_e_ms": 0.0}     # blowing north: from the south
    truth, size = M._truth("wind", injd, measured, None)
    assert math.isclose(truth["wind_speed_ms"], 1.0, abs_tol=1e-12)
    assert math.isclose(size, 1.0, abs_tol=1e-12)
    assert abs((truth["wind_from_deg"] + 180.0) % 360.0 - 180.0) < 1e-9
    truth, _ = M._truth("wind", injd, {"wind_n_ms": 0.0, "wind_e_ms": 4.0}, None)
    assert math.isclose(truth["wind_from_deg"], 315.0)   # from the north and the west
    assert math.isclose(truth["wind_speed_ms"], math.hypot(4.0, 4.0))
    assert injd.truth["wind_speed_ms"] == 4.0       # the injection's own record is kept
    truth, size = M._truth("wind", injd, None, None)
    assert (truth["wind_speed_ms"], size) == (4.0, 4.0)


def test_a_wind_on_other_m100_routes_is_sized_within_the_error_its_hovers_add(draws):
    """Seed 0's run 1 of a 3–6 m/s wind injected into 16 real DJI M100 flights of the
    routes other than R1 (Rodrigues et al. 2021, CC BY 4.0), plain record. The wind is
    found from its direction but slow (4.0 against 6.0 m/s): the rotor model's power falls
    faster from the hover than these flights' does, and the hovers hold part of the
    evidence. The fit's error alone puts the truth (the injected wind plus the flights'
    anemometer wind) more than 2 SE away; with the bias the hovers' own power level shows
    (the speed moves by 2.4 m/s), within 2 SE — and then the wind stands less than 2 SE
    from none: it is withheld, and the output says most of its error is the hovers'."""
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose

    cell = M.Cell("m100_routes", "wind", "plain", None, "realistic")
    src = M.sources()[cell.source]
    d = src.draw(np.random.default_rng(M._seed(cell, 1, 0)))
    injd = M.inject("wind", d, np.random.default_rng(M._detail_seed(cell, 1, 0)),
                    M.SIZES["realistic"], None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(M.reduce(injd.record, "plain"), d.pack,
                       M.diagnosed_aircraft(d, "plain"), payload_kg=injd.payload_kg,
                       site_altitude_m=d.site_altitude_m)
    truth, _ = M._truth("wind", injd, M.anemometer_wind_of(d), res)
    assert not [f for f in res.findings if f["effect"] == "wind"]
    weak = [w for w in res.withheld if w["effect"] == "wind"]
    assert len(weak) == 1 and weak[0]["kind"] == "weak" and "the hovers'" in weak[0]["why"]
    p = weak[0]["parameters"]
    bias = p["wind_speed_ms_hover_bias"]
    fit_only = math.sqrt(p["wind_speed_ms_stderr"]**2 - bias**2)
    miss = truth["wind_speed_ms"] - p["wind_speed_ms"]
    assert miss > 2 * fit_only                      # slow, beyond the fit's own error
    assert abs((p["wind_from_deg"] - truth["wind_from_deg"] + 180) % 360 - 180) < 30
    assert miss < 2 * p["wind_speed_ms_stderr"]
    assert M.within_2se("wind", p, truth)
    assert p["wind_speed_ms"] < 2 * p["wind_speed_ms_stderr"]
    entry = next(e for e in res.detection if e["effect"] == "wind")
    assert not entry["identifiable"] and "the hovers'" in entry["text"]


def test_a_wind_that_three_flights_carry_is_not_named_as_the_flights_shared_wind(draws):
    """Seed 0's draw 4 of 16 real DJI M100 flights of the routes other than R1
    (Rodrigues et al. 2021, CC BY 4.0), every channel, nothing injected: a wind of
    1.8 m/s from 151° passes the held-out tests 2.9 standard errors from none, where the
    three cruise flights' anemometer measured 1.2 m/s from 203°. Its estimate rests on
    about three flights (the others hover or fly no course): judged on Student's t with
    two degrees of freedom it is withheld, and said why, never named."""
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose

    cell = M.Cell("m100_routes", "clean", "everything", None, "realistic")
    d = M.sources()[cell.source].draw(np.random.default_rng(M._seed(cell, 4, 0)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(M.reduce(d.record, "everything"), d.pack,
                       M.diagnosed_aircraft(d, "everything"), payload_kg=d.payload_kg,
                       site_altitude_m=d.site_altitude_m)
    assert not [f for f in res.findings if f["effect"] == "wind"], res.summary()
    weak = [w for w in res.levels["power"].result.withheld if w["effect"] == "wind"]
    assert len(weak) == 1 and weak[0]["kind"] == "weak"
    p = weak[0]["parameters"]
    assert p["wind_speed_ms"] / p["wind_speed_ms_stderr"] > 2.0     # past the old rule
    assert "flights in effect" in weak[0]["why"]
    entry = next(e for e in res.detection if e["effect"] == "wind" and e["level"] == "power")
    assert not entry["identifiable"] and "withheld" in entry["why"]


def test_the_criterion_read_run_by_run_counts_each_run_against_its_own_limit():
    """A cell whose limit calls 3 of 5 runs identifiable, named first in exactly those,
    and says not identifiable in the 2 others, misses the cell criterion (60 % named)
    but meets it run by run: 3 of 3 named, 2 of 2 said. Clean cells, 2× cells and
    tallies without the run-by-run counts are left out."""
    from collections import Counter

    def tally(**kw):
        st = {"size": "realistic", "expect": "payload_change", "runs": 5,
              "errors": Counter(), "identifiable": 3, "named_first": 3, "named_any": 3,
              "false_runs": 0, "said_not_identifiable": 2, "within_2se": 3,
              "checked_2se": 3, "named_first_identifiable": 3,
              "named_or_said_not_identifiable": 2}
        return st | kw

    mixed = tally()
    assert M.verdict(mixed) == ("identifiable", False)
    rest = [tally(expect=None), tally(size="2x"),
            {k: v for k, v in tally().items() if k != "named_first_identifiable"}]
    r = M.run_by_run([mixed, *rest])
    assert r == {"identifiable": 3, "named_first": 3, "not_identifiable": 2,
                 "named_or_said": 2, "cells": 1}
    r = M.run_by_run([mixed, tally(errors=Counter({"inject: x": 1}), identifiable=1,
                                   named_first_identifiable=0,
                                   named_or_said_not_identifiable=2)])
    assert (r["identifiable"], r["named_first"], r["not_identifiable"]) == (4, 3, 5)
    assert "named first in 3 (75 %)" in M.run_by_run_text(r)


def test_the_limits_promise_gives_each_cell_its_chance_of_meeting_the_criterion():
    """The promised power is 80 % at the limit and rises with the size over it; a cell
    whose limit calls 3 of 5 runs identifiable and the other 2 not identifiable at any
    size is judged as identifiable and needs 4 named: it cannot meet the criterion if its
    runs are named as the limit promises. A cell of the kind "not identifiable" needs its
    one identifiable run named: the promise at that run's size. Clean cells and tallies
    without their runs have no promise."""
    from collections import Counter

    assert M.promised_power(1.0) == pytest.approx(0.8)
    assert M.promised_power(0.5) < 0.5 < 0.8 < M.promised_power(1.5) < M.promised_power(2.0)

    def tally(sizes, limits, **kw):
        runs = [{"size": s, "limit": lim, "named_first": False, "named_any": False}
                for s, lim in zip(sizes, limits)]
        ident = sum(math.isfinite(lim) and abs(s) >= lim for s, lim in zip(sizes, limits))
        st = {"size": "realistic", "expect": "payload_change", "runs": len(runs),
              "errors": Counter(), "identifiable": ident, "named_first": 0, "named_any": 0,
              "false_runs": 0, "said_not_identifiable": 0, "within_2se": 0,
              "checked_2se": 0, "silent": len(runs), "per_run": runs}
        return st | kw

    far = tally([0.3] * 5, [0.1] * 5)
    assert M.expected_to_meet(far) == pytest.approx(1.0, abs=1e-3)
    at = tally([0.2] * 5, [0.2] * 5)          # 4 or 5 of 5 at 80 % each
    assert M.expected_to_meet(at) == pytest.approx(0.8**5 + 5 * 0.8**4 * 0.2)
    split = tally([-0.3] * 5, [0.1, 0.1, 0.1, math.inf, math.inf])
    assert M.verdict(split)[0] == "identifiable"
    assert M.expected_to_meet(split) == 0.0
    one = tally([0.25, 0.1, 0.1, 0.1, 0.1], [0.25, 0.2, 0.2, math.inf, 0.2])
    assert M.verdict(one)[0] == "not identifiable"
    assert M.expected_to_meet(one) == pytest.approx(0.8)
    assert M.expected_to_meet(tally([0.3], [0.1], expect=None)) is None
    assert M.expected_to_meet({k: v for k, v in far.items() if k != "per_run"}) is None
    line = M.expected_text([far, split, one, tally([0.3], [0.1], size="2x")])
    assert "1.8 of 3 cells" in line and "1 cell cannot meet it" in line


def test_the_limits_calibration_bins_each_run_by_its_size_over_its_own_limit():
    """A run at exactly its limit is in the 1–1.5× bin (named with 80 % probability
    there), one at 0.9× below it; a run whose limit is infinite (not identifiable at any
    size) and clean cells are left out; a negative size (a payload picked up) counts by
    its magnitude; each injection has its row and "all" sums them."""
    def st(injection, runs, expect="x"):
        return {"injection": injection, "expect": expect,
                "per_run": [{"size": s, "limit": lim, "named_first": f, "named_any": f}
                            for s, lim, f in runs]}

    cal = M.limit_calibration([
        st("payload", [(0.2, 0.2, True), (0.18, 0.2, False), (-0.5, 0.2, True),
                       (0.3, math.inf, False)]),
        st("wind", [(3.0, 2.0, False), (1.0, 4.0, False)]),
        st("clean", [(0.0, 1.0, True)], expect=None)])
    assert set(cal) == {"payload", "wind", "all"}
    assert cal["payload"] == [[0, 0], [1, 0], [1, 1], [0, 0], [1, 1]]
    assert cal["wind"] == [[1, 0], [0, 0], [0, 0], [1, 0], [0, 0]]
    assert cal["all"] == [[1, 0], [1, 0], [1, 1], [1, 0], [1, 1]]
    table = M.limit_calibration_text(cal)
    assert table[0].startswith("| injection") and "1–1.5×" in table[0]
    assert table[-1].startswith("| all |") and "1 of 1 (100 %)" in table[-1]


def test_a_cold_pack_scales_each_packs_own_resistance_by_arrhenius():
    """Jaguemont, Boulon and Dubé 2016: a pack's whole DC resistance follows Arrhenius.
    Two packs of 30 and 80 mΩ at −5 °C with 19 kJ/mol must both read
    R(−5 °C)/R(25 °C) = exp(E_a/R_g (1/268.15 − 1/298.15)) ≈ 2.36: one increment of
    resistance for every pack (the injection's law before) gives 3.2 and 1.8."""
    import numpy as np
    import pandas as pd

    from testkit import injections as inj

    rng = np.random.default_rng(3)
    t = np.arange(0.0, 300.0, 0.2)
    rows = []
    for name, r in (("a", 0.030), ("b", 0.080)):
        i = 20.0 + 8.0 * (rng.random(t.size) > 0.5)          # current steps, 20–28 A
        v = 24.0 - 0.002 * t - r * i
        rows.append(pd.DataFrame({"experiment": name, "time_s": t, "current_a": i,
                                  "voltage_v": v, "power_w": v * i}))
    df = pd.concat(rows, ignore_index=True)
    own = inj.dc_resistance(df)
    assert own["a"] == pytest.approx(0.030, rel=1e-4) and own["b"] == pytest.approx(0.080,
                                                                                      rel=1e-4)
    out = inj.cold_pack(df, {"a": -5.0, "b": -5.0}, ea_j_per_mol=19_000.0,
                        pack_resistance_ohm=0.05, self_heating_k=0.0)
    after = inj.dc_resistance(out)
    want = float(inj.arrhenius(-5.0, 19_000.0))
    assert want == pytest.approx(2.36, abs=0.01)
    for name, r in (("a", 0.030), ("b", 0.080)):
        assert after[name] / r == pytest.approx(want, rel=0.02)
    # the load keeps its power
    assert np.allclose(out["voltage_v"] * out["current_a"], df["voltage_v"] * df["current_a"],
                       rtol=1e-9)


def test_a_linear_capacity_fade_is_sized_within_the_error_its_law_adds(draws):
    """Real Molicel P42A discharges aged by a capacity that falls linearly with the cycles
    (20 % at 500) and a resistance that grows: the cut-off level's charge scale 1 + φn
    bends the other way, and with the fresh cell's energy unknown it fits φ 5–13 % above
    the truth; the shift to the linear law (``fade_per_cycle_law_shift``) in its error
    keeps the truth within 2 SE (2 of 5 runs without it, seed 2)."""
    import numpy as np

    from planner.identify.diagnose import diagnose

    cell = M.Cell("p42a", "fade", "everything", None, "realistic")
    within, shifts = 0, []
    for run in range(5):
        d = M.sources()["p42a"].draw(np.random.default_rng(M._seed(cell, run, 2)))
        injd = M.inject("fade", d, np.random.default_rng(M._detail_seed(cell, run, 2)),
                        M.SIZES["realistic"], None)
        res = diagnose(injd.record, d.pack, None)
        first = res.findings[0]
        assert first["effect"] == "capacity_fade" and first["level"] == "cutoff"
        p = first["parameters"]
        shifts.append(p["fade_per_cycle_law_shift"])
        within += bool(M.within_2se("capacity_fade", p, injd.truth))
    assert within >= 4
    # the linear law fits a smaller fade: the charge scale overshoots it
    assert all(s < 0 for s in shifts)


@pytest.mark.parametrize("size", ["quarter", "half", "realistic", "2x"])
def test_every_injection_scales_with_the_size_named(size, draws):
    """The sizes below realistic probe the detection limits from beneath: each injection's
    range (module notes of testkit.matrix, "Sizes") scales by the size's factor, the air
    density's deficit too (log 171, CC BY-SA 3.0: one flight, always the changed one)."""
    import numpy as np

    from testkit import injections as inj

    k = M.SIZES[size]
    d = M.sources()["log171"].draw(np.random.default_rng(0))
    for run in range(3):
        rng = np.random.default_rng(run)
        off = M.inject("offset", d, rng, k)
        assert 0.3 * k <= off.truth["current_offset_a"] <= 0.8 * k
        cold = M.inject("cold_pack", d, rng, k)
        assert cold.truth["activation_energy_j_per_mol"] == pytest.approx(19_000.0 * k)
        dens = M.inject("density", d, rng, k).record
        rho = dens["pressure_pa"] / (inj.R_AIR * (dens["ambient_temperature_c"] + inj.T0_K))
        # the site's density is the draw's (the sensors' noise: 30 Pa, 0.3 K)
        deficit = 1.0 - float(np.median(rho)) / d.rho
        assert 0.15 * k - 0.005 <= deficit <= 0.25 * k + 0.005, (size, deficit)


def test_the_benchmark_names_an_unknown_size_or_source_and_what_it_expects():
    import subprocess
    import sys

    for opt, bad in (("--sizes", "huge"), ("--sources", "m100,nowhere")):
        run = subprocess.run([sys.executable, str(REPO / "benchmarks/bench_effect_matrix.py"),
                              opt, bad], capture_output=True, text=True, cwd=REPO)
        assert run.returncode == 2, run.stdout
        line = run.stderr.strip().splitlines()[-1]
        assert f"{opt}: unknown {bad.split(',')[-1]}; expected some of" in line
        assert ("quarter" if opt == "--sizes" else "mcgill_hovers") in line


def test_a_telemetry_rate_decimates_each_flight_from_its_own_start():
    """``plain@0.5Hz``: the first sample of every 2-s interval of each experiment, counted
    from that experiment's start; instantaneous values, never means."""
    import numpy as np
    import pandas as pd

    t = np.r_[np.arange(0.0, 10.0, 0.1), np.arange(100.05, 105.0, 0.1)]
    exp = ["a"] * 100 + ["b"] * 50
    df = pd.DataFrame({"experiment": exp, "time_s": t, "voltage_v": t, "current_a": 1.0,
                       "temperature_c": 20.0})
    assert M.split_richness("plain@0.5Hz") == ("plain", 0.5)
    assert M.split_richness("everything") == ("everything", None)
    out = M.reduce(df, "minimal@0.5Hz")
    assert list(out.columns) == ["experiment", "time_s", "voltage_v", "current_a"]
    a = out[out["experiment"] == "a"]["time_s"].to_numpy()
    b = out[out["experiment"] == "b"]["time_s"].to_numpy()
    np.testing.assert_allclose(a, [0.0, 2.0, 4.0, 6.0, 8.0], atol=1e-9)
    np.testing.assert_allclose(b, [100.05, 102.05, 104.05], atol=1e-9)
    # values are the samples' own (the voltage column here is the time)
    np.testing.assert_array_equal(out["voltage_v"].to_numpy(), out["time_s"].to_numpy())
    assert len(M.reduce(df, "everything")) == len(df)


def test_a_cell_at_a_telemetry_rate_reduces_the_same_injection(draws):
    """A cell at ``plain@1Hz`` draws the same record and injection as at ``plain``, so the
    rate alone differs between them (log 171, CC BY-SA 3.0)."""
    at_rate = M.run_cell(M.Cell("log171", "offset", "plain@1Hz", None, "realistic"), 2, 0,
                         draws)
    native = M.run_cell(M.Cell("log171", "offset", "plain", None, "realistic"), 2, 0, draws)
    assert at_rate["sizes"] == native["sizes"] and not at_rate["errors"]
    assert at_rate["named_first"] == at_rate["runs"] == 1


def test_a_wind_on_other_m100_routes_is_read_through_the_flights_change_of_power_with_speed(
        draws, monkeypatch):
    """Seed 0's run 2 of a 3–6 m/s wind injected into 16 real DJI M100 flights of the
    routes other than R1 (Rodrigues et al. 2021, CC BY 4.0), plain record; the injection
    law is the flights' own power against their speed. These flights' power changes with
    airspeed well under the calibrated rotor model's (the scale about 0.5–0.8, 2 SE below
    1): read through the model the wind comes out slow, read with the scale free nearer
    the truth (the injected wind plus the flights' anemometer wind: 3.3 → 3.6 against
    4.6 m/s; still more than 2 SE slow, and the hovers show no bias here); and the
    detection limit is the model's divided by the scale."""
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose, limits

    cell = M.Cell("m100_routes", "wind", "plain", None, "realistic")
    d = M.sources()[cell.source].draw(np.random.default_rng(M._seed(cell, 2, 0)))
    injd = M.inject("wind", d, np.random.default_rng(M._detail_seed(cell, 2, 0)),
                    M.SIZES["realistic"], None)

    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return diagnose(M.reduce(injd.record, "plain"), d.pack,
                            M.diagnosed_aircraft(d, "plain"), payload_kg=injd.payload_kg,
                            site_altitude_m=d.site_altitude_m)

    res = run()
    truth, _ = M._truth("wind", injd, M.anemometer_wind_of(d), res)
    p = next(f for f in res.findings if f["effect"] == "wind")["parameters"]
    k, sk = p["speed_response"], p["speed_response_stderr"]
    assert k + 2 * sk < 1.0 and k > 0.3
    assert p["wind_speed_ms_model"] < p["wind_speed_ms"] < truth["wind_speed_ms"]
    limit = next(e for e in res.detection if e["effect"] == "wind")["limit"]
    monkeypatch.setattr(limits, "_speed_scaled", lambda level, r, base, lim: (lim, ""))
    model = next(e for e in run().detection if e["effect"] == "wind")["limit"]
    assert limit == pytest.approx(model / k, rel=1e-6)


def test_the_m100s_cruise_power_changes_with_speed_less_than_the_calibrated_models(draws):
    """Across the 176 route-R1 flights of the DJI M100 (Rodrigues et al. 2021, CC BY 4.0),
    flown at 4–12 m/s with 0–0.5 kg on many days, the level cruise power by commanded
    speed (net of payload and altitude, testkit.matrix.cruise_power_by_speed) is nearly
    flat from 4 to 10 m/s and 48 ± 7 W higher at 12 m/s; the rotor model diagnose
    calibrates on 16 of them (seed 0's first clean draw) rises from 10 to 12 m/s by more
    than 1.5 times that, and falls from 4 to 8 m/s by more than twice the flights' fall:
    the reason a wind read through the model comes out slow (search, "Wind"). diagnose
    reads the same on those flights (a scale on the model's change well under 1) and
    says so in a note."""
    import warnings

    import numpy as np

    from planner.identify.diagnose import diagnose

    data = M.cruise_power_by_speed(True)
    assert data["flights"] > 150
    assert abs(data[4.0][0] - data[8.0][0]) < 20.0
    rise, se = data[12.0]
    assert 30.0 < rise < 65.0 and se < 10.0
    assert 150.0 < data["payload_w_per_kg"] < 250.0
    cell = M.Cell("m100", "clean", "plain", None, "realistic")
    d = M.sources()["m100"].draw(np.random.default_rng(M._seed(cell, 0, 0)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = diagnose(M.reduce(d.record, "plain"), d.pack, d.aircraft,
                       payload_kg=d.payload_kg, site_altitude_m=d.site_altitude_m)
    report = res.levels["power"]
    level, values = report.result.level, report.base_values
    v = np.array([4.0, 8.0, 10.0, 12.0])
    inputs = {"airspeed": v, "climb": np.zeros(4),
              "air_density": np.full(4, float(np.median(level.base_inputs["air_density"]))),
              "mass": np.full(4, level.mass0)}
    model = level.mechanical({k: values[k] for k in level.shape}, inputs, np.arange(4),
                             table=False) / values["efficiency"]
    assert model[3] - model[2] > 1.5 * rise
    assert model[0] - model[1] > 2.0 * (data[4.0][0] - data[8.0][0])
    # diagnose reads it on the same 16 flights: a free scale on the model's change of
    # power with airspeed, fitted with a steady wind, well under 1, and a note says so
    k, se, wind = report.result.speed_response
    assert wind and 0.0 < k < 0.8 and k + 2 * se < 1.0
    assert any("changes with airspeed" in n for n in res.notes)


def test_a_draw_of_mixed_payloads_flies_each_flight_at_its_own_mass(draws):
    """The ``m100_mixed`` draws (route R1, Rodrigues et al. 2021, CC BY 4.0) mix the
    data set's payload classes in one draw: each flight's own payload (its
    ``m100_parameters.csv`` entry) goes to diagnose as the record's ``payload_kg``
    column, and the injection laws fly each flight at its own mass, as they fly a draw
    of one class."""
    import numpy as np
    import pandas as pd

    from testkit import injections as inj

    d = M.M100Mixed().draw(np.random.default_rng(0))
    par = pd.read_csv(M.ENERGY / "m100_parameters.csv").set_index("flight")
    assert len(d.flights) == 16 and len(set(d.payload_kg.values())) > 1
    for f in d.flights:
        assert d.payload_kg[str(f)] == par.loc[int(f), "payload"] / 1000.0
        assert d.mass_kg[str(f)] - d.payload_kg[str(f)] == pytest.approx(
            d.aircraft.empty_mass_kg + d.pack.total_mass_kg)
    record, opts = M.given(M.reduce(d.record, "plain"), d.payload_kg)
    assert opts == {"payload_kg": None}
    for f, g in record.groupby("experiment"):
        assert (g["payload_kg"] == d.payload_kg[str(f)]).all()
    # the law fitted per flight's mass, and a mass step at each flight's own mass
    flying = M._flying(d)
    times = inj.change_times(d.record, np.full(16, 0.5), flying=flying)
    out = inj.payload_step(d.record, -0.3, times, d.mass_kg, rho=d.rho,
                           pack_resistance_ohm=0.0, rotors=d.rotors)
    for key, idx in inj.experiments(d.record):
        g = d.record.loc[idx]
        alone = inj.payload_step(g, -0.3, {key: times[key]}, d.mass_kg[str(key)], rho=d.rho,
                                 pack_resistance_ohm=0.0, rotors=d.rotors)
        np.testing.assert_allclose(out.loc[idx, "power_w"], alone["power_w"])
    heavy = max(d.flights, key=lambda f: d.mass_kg[str(f)])
    light = min(d.flights, key=lambda f: d.mass_kg[str(f)])
    law = M._speed_law(d)
    g_h, g_l = (d.record[d.record["experiment"] == f] for f in (heavy, light))
    # a heavier multirotor needs less extra induced power per m/s of airspeed at cruise
    # but more in hover: its law differs from the light flight's
    assert law.of(g_h)(0.0) > law.of(g_l)(0.0)
    injd = M.inject("payload", d, np.random.default_rng(1), 1.0, "mid")
    dm = -injd.truth["mass_step_kg"]
    assert {k: v - dm for k, v in injd.payload_kg.items()} == pytest.approx(d.payload_kg)


def test_the_m100s_power_rises_with_its_payload_alike_in_every_regime_unlike_the_models(
        draws):
    """Across route R1's flights of the DJI M100 (Rodrigues et al. 2021, CC BY 4.0; 0,
    250 and 500 g on many days) the battery power rises with the payload by about 200 W
    per kg in level cruise at every commanded speed from 4 to 12 m/s, in the vertical
    climb at 3 m/s and in the vertical descent at 1.8 m/s alike
    (testkit.matrix.power_per_payload_by_regime). Both shipped M100 power models change
    by far more in the climb than in fast cruise: what a payload step fitted on the
    model's signature across regimes, or a mission planned at another payload, rests on."""
    import numpy as np

    from planner.parameters import load_aircraft

    real = M.power_per_payload_by_regime()
    regimes = [k for k in real if not k.endswith("rate")]
    assert len(regimes) == 7 and all(real[k][2] >= 30 for k in regimes)
    slopes = np.array([real[k][0] for k in regimes])
    errs = np.array([real[k][1] for k in regimes])
    mean = float(np.average(slopes, weights=errs**-2))
    assert 180.0 < mean < 220.0
    # the same in every regime: each within 2 SE of the common slope
    assert np.all(np.abs(slopes - mean) < 2.0 * errs), dict(zip(regimes, slopes))
    rho = M._isa(300.0)
    for name in ("aircraft/dji_m100.yaml", "aircraft/dji_m100_rotor_losses.yaml"):
        ac = load_aircraft(M.REPO / name)

        def per_kg(v, climb):
            return 10.0 * float(ac.battery_power(v, climb, rho, 2.705)
                                - ac.battery_power(v, climb, rho, 2.605))

        climb = per_kg(0.0, real["climb rate"])
        fast = per_kg(10.0, 0.0)
        assert climb > 1.35 * fast, (name, climb, fast)
        # the flights' climb and fast cruise differ by less than a tenth
        assert abs(real["climb"][0] - real["cruise 10 m/s"][0]) < 0.1 * mean


def test_a_payload_picked_up_is_the_release_flown_the_other_way(draws):
    """The ``pickup`` injection (DJI M100 route R1, Rodrigues et al. 2021, CC BY 4.0): the
    same mass law as a release, the record after the change flown heavier where a release
    flies the record before it heavier; diagnose is given the flights' own take-off
    payload and the truth is a positive step."""
    import numpy as np

    from testkit import injections as inj

    d = M.sources()["m100"].draw(np.random.default_rng(3))
    up = M.inject("pickup", d, np.random.default_rng(4), 1.0, "mid")
    down = M.inject("payload", d, np.random.default_rng(4), 1.0, "mid")
    dm = up.truth["mass_step_kg"]
    assert dm > 0 and down.truth["mass_step_kg"] == pytest.approx(-dm)
    assert up.payload_kg == d.payload_kg and down.payload_kg == pytest.approx(d.payload_kg + dm)
    assert up.change_times == pytest.approx(down.change_times)
    p0 = d.record["power_w"].to_numpy(float)
    t = d.record["time_s"].to_numpy(float)
    for key, idx in inj.experiments(d.record):
        pos = d.record.index.get_indexer(idx)
        after = t[pos] - t[pos][0] >= up.change_times[str(key)]
        gain_up = up.record["power_w"].to_numpy(float)[pos] - p0[pos]
        gain_down = down.record["power_w"].to_numpy(float)[pos] - p0[pos]
        # heavier after the pick-up, heavier before the release, by the same law
        assert np.all(np.abs(gain_up[~after]) < 1e-6) and np.all(np.abs(gain_down[after]) < 1e-6)
        assert gain_up[after].max() > 20.0 and gain_down[~after].max() > 20.0
        assert np.median(gain_up[after & (gain_up > 1.0)]) == pytest.approx(
            np.median(gain_down[~after & (gain_down > 1.0)]), rel=0.3)


@pytest.mark.parametrize("size, run, seed", [("2x", 2, 0), ("realistic", 3, 2)])
def test_a_wind_the_route_turns_into_one_step_is_held_against_the_step_it_makes(
        size, run, seed, draws):
    """A steady wind on 16 real DJI M100 route-R1 flights (Rodrigues et al. 2021, CC BY
    4.0), plain record: on this route it changes the airspeed within each flight as one
    step (the legs are flown in one order), so it is not named. It is fitted as the rival
    of the power step it makes, and the two are withheld as confounded: neither is named.
    Before, a step was named in its place (seed 0's third draw at twice the realistic
    speed, 6.8 m/s; seed 2's fourth at realistic, 5.2 m/s: −0.18 ± 0.08 kg)."""
    _, _, res = _diagnosed(M.Cell("m100", "wind", "plain", None, size), run, seed)
    assert any("as one step" in s["reason"] for s in res.skipped if s["effect"] == "wind")
    assert not any(f["effect"] in ("payload_change", "wind") for f in res.findings), \
        res.findings
    step = next(w for w in res.withheld if w["effect"] == "payload_change")
    assert step["kind"] == "confounded" and "wind" in step["candidates"], step


def test_a_release_on_route_r1_that_its_rival_wind_fits_worse_is_named_beside_it(draws):
    """A 0.32 kg payload released at a random point of each of 16 real DJI M100 route-R1
    flights (Rodrigues et al. 2021, CC BY 4.0), plain record, seed 0's first draw: the
    wind the route turns into one step per flight is fitted as the step's rival, the
    held-out data prefer the step, and the step is named, with the wind among what else
    makes the same step and the test the wind lost among the step's evidence; the wind
    itself is not named."""
    _, _, res = _diagnosed(M.Cell("m100", "payload", "plain", "random", "realistic"), 0, 0)
    assert "wind" in res.levels["power"].result.candidates      # fitted as the rival
    assert not any(f["effect"] == "wind" for f in res.findings)
    step = next(f for f in res.findings if f["effect"] == "payload_change")
    assert step["parameters"]["mass_step_kg"] < 0
    assert any(a.startswith("a steady wind") for a in step["alternatives"]), step
    # the rival contest is quoted: the wind fitted in the step's place, and the paired
    # test of their held-out losses that it lost
    from planner.identify.diagnose import search as S

    (held,) = step["evidence"]["held_against"]
    wind = res.levels["power"].result.candidates["wind"]
    assert held["rival"] == "wind" and held["rival_gain_pct"] == pytest.approx(wind.gain_pct)
    assert held["gain_pct"] > held["rival_gain_pct"]
    assert held["paired_p"] < 0.5 * S.ALPHA_HELDOUT
    assert f"paired p = {held['paired_p']:.2g}" in held["text"]
    assert f"held against wind: {held['text']}" in res.summary()


def test_a_pick_up_in_the_flight_that_holds_log_171s_own_step_is_said_not_identifiable(
        draws):
    """diagnose locates one change a flight. On log 171's plain record it locates the
    record's own +110 W step at 228 s; a 0.19 kg pick-up injected at 45 % of the flight
    (seed 1, run 0: its limit in a flight without a change is 0.19 kg) is then not located.
    The output says a second change in that flight is not identifiable below the located
    step, and the matrix takes that as the run's limit: the miss is said, not silent."""
    cell = M.Cell("log171", "pickup", "plain", "mid", "realistic")
    st = M.run_cell(cell, 1, seed=1, draws=draws)
    assert st["own"] == {"payload_change": 1} and not st["false"]
    assert st["named_any"] == 0
    (limit,), (size,) = st["limits"], st["sizes"]
    assert size < limit
    assert st["said_not_identifiable"] == 1 and st["named_or_said_not_identifiable"] == 1

    _, injd, res = _diagnosed(cell, 0, 1)
    (found,) = [f for f in res.findings if f["effect"] == "payload_change"]
    (entry,) = M.detection_of(res, "payload_change", "mass_step_kg")
    second = entry["second_change"]
    assert second["flights"] == 1
    assert second["limit"] == pytest.approx(abs(found["parameters"]["mass_step_kg"]))
    assert second["limit"] == pytest.approx(limit) and second["limit"] > injd.size
    # the limit for a flight without a change would have called the pick-up identifiable
    assert M.limit_at(entry, injd.fraction) <= injd.size
    assert "second change in the flight" in entry["text"]
    assert "not identifiable" in second["text"]


def test_the_measured_mass_law_adds_the_m100s_own_power_per_kg_in_every_regime(draws):
    """The ``m100_measured`` source (DJI M100 route R1, Rodrigues et al. 2021, CC BY 4.0)
    draws the ``m100`` source's flights, sizes and change times run by run, and injects a
    pick-up by the M100's own measured change of battery power per kilogram (the
    inverse-variance mean of its regimes' slopes across the 0, 250 and 500 g flights, about
    200 W/kg): the same in the climb, the cruise and the descent, where momentum theory's
    law on the same flights changes by regime, and nothing where the rotors do not carry
    the aircraft."""
    import numpy as np

    from testkit import injections as inj

    w, se = M.measured_w_per_kg()
    assert 180.0 < w < 220.0 and 0.0 < se < 10.0
    cell = M.Cell("m100_measured", "pickup", "plain", "mid", "realistic")
    twin = M.Cell("m100", "pickup", "plain", "mid", "realistic")
    assert M._seed(cell, 0, 0) == M._seed(twin, 0, 0)
    assert M._detail_seed(cell, 0, 0) == M._detail_seed(twin, 0, 0)
    d = M.sources()["m100_measured"].draw(np.random.default_rng(M._seed(cell, 0, 0)))
    d0 = M.sources()["m100"].draw(np.random.default_rng(M._seed(twin, 0, 0)))
    assert d.flights == d0.flights and d.w_per_kg == w and d0.w_per_kg is None
    got = M.inject("pickup", d, np.random.default_rng(M._detail_seed(cell, 0, 0)), 1.0, "mid")
    ref = M.inject("pickup", d0, np.random.default_rng(M._detail_seed(twin, 0, 0)), 1.0, "mid")
    assert got.truth == ref.truth and got.change_times == pytest.approx(ref.change_times)
    dm = got.truth["mass_step_kg"]
    # the law itself, at the terminals (no pack resistance): w × dm after the change
    # wherever the rotors carry the weight
    rec = d.record
    step = inj.payload_step(rec, dm, {k: -np.inf for k in d.flights}, d.mass_kg, rho=d.rho,
                            pack_resistance_ohm=0.0, rotors=d.rotors, w_per_kg=w)
    momentum = inj.payload_step(rec, dm, {k: -np.inf for k in d.flights}, d.mass_kg,
                                rho=d.rho, pack_resistance_ohm=0.0, rotors=d.rotors)
    gain = step["power_w"].to_numpy(float) - rec["power_w"].to_numpy(float)
    gain_m = momentum["power_w"].to_numpy(float) - rec["power_w"].to_numpy(float)
    lifted = np.abs(gain) > 1e-9
    assert np.allclose(gain[lifted], w * dm)
    assert lifted.mean() > 0.5 and np.array_equal(lifted, np.abs(gain_m) > 1e-9)
    climb = rec["climb_rate_ms"].to_numpy(float)
    speed = rec["groundspeed_ms"].to_numpy(float)
    per_kg = {name: np.median(gain_m[lifted & m]) / dm for name, m in (
        ("climb", (climb > 1.5) & (speed < 1.0)), ("descent", (climb < -1.0) & (speed < 1.0)),
        ("fast cruise", (np.abs(climb) < 0.3) & (speed > 9.0)))}
    # momentum theory's law is not the M100's: it changes by regime, by far more than w
    assert per_kg["climb"] > 1.5 * per_kg["fast cruise"] and per_kg["climb"] > w + 100.0


def test_a_step_at_the_start_of_the_final_descents_says_the_descent_model_may_be_wrong(
        draws, monkeypatch):
    """Eight clean route-R1 flights of the DJI M100 (Rodrigues et al. 2021, CC BY 4.0;
    seed 0's fourth draw of eight, plain record) show a −56 W step where four of them end
    their cruise and start the final descent, and the held-out data confirm it (paired
    p = 0.017). No payload was dropped there: the finding says so as a caution beside the
    alternatives, as it does for changes at the end of a climb."""
    monkeypatch.setattr(M, "FLIGHTS", 8)
    _, _, res = _diagnosed(M.Cell("m100", "clean", "plain", None, "realistic"), 3, 0)
    step = [f for f in res.findings if f["effect"] == "payload_change"]
    assert len(step) == 1, [f["effect"] for f in res.findings]
    p = step[0]["parameters"]
    assert p["changes_at_start_of_descent"] >= 0.5 * p["flights_with_change"]
    assert "fall at the start of a descent: the power model's descent may be wrong" in \
        step[0]["cause"]


@pytest.mark.parametrize("run", [22, 3])
def test_a_release_the_held_out_flights_do_not_confirm_is_said_not_settled(run, draws):
    """DJI M100 flights of routes other than R1 (Rodrigues et al. 2021, CC BY 4.0; seed 0,
    runs 22 and 3 of the early release, plain record): 0.18 kg released at 12 % of eight
    flights and 0.31 kg at 12 % of ten, each about 1.0–1.1 times the limit there. The
    training flights see it (p ≈ 1e-12, 1e-14), the held-out flights place it at steps of
    their own and do not confirm it, and nothing is named. "None found … cannot be seen"
    would deny a change that is there: the step the folds read on their located flights
    does not exclude one as large as the limit, so the entry says not settled, with the
    drop seen (within 2 SE of the release), where, and its bound. (Fitted on every flight
    run 3's folds find 0.21 kg, pulled small by the flights without a located change,
    whose bound stays below the limit.)"""
    cell = M.Cell("m100_routes", "payload", "plain", "early", "realistic")
    _, injd, res = _diagnosed(cell, run, 0)
    assert not [f for f in res.findings if f["effect"] == "payload_change"]
    (entry,) = M.detection_of(res, "payload_change", "mass_step_kg")
    assert not entry["identifiable"] and M.limit_at(entry, injd.fraction) == math.inf
    u = entry["unsettled"]
    assert u["mass_step_kg"] < 0 and u["bound_kg"] >= u["limit_there_kg"]
    assert abs(u["mass_step_kg"] + injd.size) <= 2 * u["mass_step_kg_stderr"]
    assert u["located_flights"] >= 4 and u["lr_p_value"] < 0.05
    assert entry["text"].startswith("A payload change: not settled: the training flights "
                                    "show a drop of")


def test_cold_cells_late_in_the_files_order_are_not_named_as_an_ageing_pack(draws):
    """Real Molicel P42A discharges, half chilled to 0 °C, the plain record (no pack
    temperature, no cycle count): on seed 3 the fifth draw's cold discharges lie at
    positions 3, 5, 6 and 7 of the eight that reach the cut-off, and a fade of 2.2 % per
    experiment fitted their trend and was named as an ageing pack, a false cause. The
    energies fall in two levels and a warm one comes after a cold one: the fade is
    withheld with that reason, and no run of the cell names a false cause."""
    cell = M.Cell("p42a", "cold_cells", "plain", None, "realistic")
    st = M.run_cell(cell, 5, seed=3, draws=draws)
    assert not st["errors"], dict(st["errors"])
    assert st["false_runs"] == 0, dict(st["false"])
    assert M.verdict(st) == ("not identifiable", True)
