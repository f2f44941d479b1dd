"""The detection limits of diagnose follow its own decision rule
(planner/identify/diagnose/limits.py): the paired test on held-out units and the gates
that withhold a fitted effect whatever its size."""

import math

import numpy as np
import pytest
from scipy.stats import norm

from planner.identify import stats
from planner.identify.diagnose import limits as L


def test_unit_paired_size_is_the_paired_factor_when_the_signature_is_spread():
    """Spread evenly over many units, the sign-flip test's own spread is negligible: the
    size is 2 (z_{1-α} + z_power) standard errors (Q → 0 in the docstring)."""
    n, units = 20000, 2000
    s = np.ones(n)
    u = np.repeat(np.arange(units), n // units)
    size = L.unit_paired_size(s, None, u, 1.0, alpha=0.05, power=0.8)
    expected = 2 * (norm.ppf(0.95) + norm.ppf(0.8)) / math.sqrt(n)
    assert size == pytest.approx(expected, rel=0.05)
    assert stats.paired_test_factor(0.05, 0.8) / math.sqrt(n) == pytest.approx(expected)


def test_unit_paired_size_grows_as_the_signature_concentrates_in_few_units():
    """The same signature energy in fewer units needs a larger effect, and in two units
    (fewer than (z_{1-α})² ≈ 2.7 effective units) no size passes."""
    n = 4800
    u = np.repeat(np.arange(48), n // 48)
    sizes = []
    for k in (48, 12, 4):
        s = np.where(u < k, 1.0 / math.sqrt(k), 0.0)
        sizes.append(L.unit_paired_size(s, None, u, 1.0))
    assert sizes[0] < sizes[1] < sizes[2] < math.inf
    s = np.where(u < 2, 1.0, 0.0)
    assert L.unit_paired_size(s, None, u, 1.0) == math.inf


class _Route:
    """Four flights flown along ``course`` [deg per bin] at 10 m/s, with what the wind's
    limit reads of a power level."""

    def __init__(self, course):
        c = np.radians(np.tile(course, 4))
        n = c.size
        self.exp = np.repeat(np.arange(4), len(course))
        self.row_group = self.exp
        self.row_unit = np.repeat(np.arange(16), n // 16)
        self.vn, self.ve = 10.0 * np.cos(c), 10.0 * np.sin(c)
        self.moving = np.ones(n, bool)
        self.logged_wind_n = self.logged_wind_e = 0.0
        # a power that rises 8 W per m/s of airspeed: the wind's signature per m/s of
        # its north and east components is −8 (v̂_N, v̂_E)
        self.sig = -8.0 * np.column_stack([np.cos(c), np.sin(c)])
        self.resid = 5.0 * np.random.default_rng(0).standard_normal(n)


#: A closed triangle flown in one order (the legs of the M100 data set's route R1).
TRIANGLE = np.r_[np.full(60, 65.0), np.full(80, 206.0), np.full(60, 342.0)]
SURVEY = np.tile(np.r_[np.full(25, 0.0), np.full(25, 90.0), np.full(25, 180.0),
                       np.full(25, 90.0)], 2)


def _gate(route):
    nuis = np.ones((route.exp.size, 1))
    lim = stats.detectable_size(route.sig, nuis, route.resid, route.exp, dof=1,
                                paired=True)
    return lim, L._wind_gate(route, route.sig, nuis, route.resid, route.exp, route.exp, 1,
                                 None, lim)


def test_a_wind_on_a_triangle_flown_in_one_order_has_no_limit():
    """On a closed triangle flown in one order, a wind from about half the directions
    changes the airspeed as one step per flight (the legs before against the leg after),
    which the search withholds as a mass change: a wind of unknown direction is named in
    fewer than 80 % of cases at any size."""
    lim, (gated, why) = _gate(_Route(TRIANGLE))
    assert math.isfinite(lim.limit) and gated.limit == math.inf
    assert "one step" in why and "unknown direction" in why


def test_a_wind_on_a_survey_route_keeps_a_finite_limit_no_smaller_than_the_tests():
    """On a survey (legs N, E, S, E) the wind's airspeed change is not one step: the
    gate leaves the limit finite and never below the tests' own."""
    lim, (gated, why) = _gate(_Route(SURVEY))
    assert why == "" and lim.limit <= gated.limit < math.inf


def test_a_route_that_cannot_tell_a_wind_from_a_step_does_not_test_one():
    """The search skips a wind where the limit has none (the triangle flown in one order),
    so what it decides and what the limit says agree; on a survey it tests one."""
    from planner.identify.diagnose.effects import Wind

    why = Wind().route_reason(_Route(TRIANGLE))
    assert why is not None and "one step" in why
    assert Wind().route_reason(_Route(SURVEY)) is None


def _flights(n_flights=12, bins=100, between_w=0.0, seed=1):
    """Residuals [W] of ``n_flights`` flights: white noise of 5 W per bin plus a level of
    ``between_w`` RMS per flight; a signature carried by whole flights (1 in every other
    flight, as an effect of the air density of a day) and one that varies within them."""
    rng = np.random.default_rng(seed)
    exp = np.repeat(np.arange(n_flights), bins)
    resid = 5.0 * rng.standard_normal(exp.size) + between_w * rng.standard_normal(
        n_flights)[exp]
    per_flight = (exp % 2).astype(float)
    within = np.tile(np.sin(np.linspace(0.0, 6.0 * math.pi, bins)), n_flights)
    return exp, resid, per_flight, within


def test_design_effect_is_one_without_scatter_between_flights():
    """Kish's design effect: with white noise only, the cluster-robust variance is the
    residual's own (within sampling error), so the limit is unchanged."""
    exp, resid, per_flight, within = _flights(between_w=0.0)
    ones = np.ones((exp.size, 1))
    for s in (per_flight, within):
        sp = stats.project_out(s, ones)
        assert 1.0 <= stats.design_effect(sp, resid, exp, exp, 1) < 2.0


def test_scatter_between_flights_raises_the_limit_of_an_effect_carried_by_whole_flights():
    """A level of 20 W per flight (flights on different routes and days scatter so about
    their calibrated model) is the noise of an effect carried by whole flights: with 6
    flights on each side its estimate, a difference of means, has a standard error of
    20·√(1/6 + 1/6) = 11.5 W whatever the bins. The AR(1) variance (ρ clipped) sees a
    fraction of it; with the flights as clusters the standard error comes near the true
    one (median of 40 draws) and the limit rises by the square root of the design
    effect. An effect that varies within the flights keeps its limit."""
    true_se = 20.0 * math.sqrt(1 / 6 + 1 / 6)
    ratios = []
    for seed in range(40):
        exp, resid, per_flight, within = _flights(between_w=20.0, seed=seed)
        ones = np.ones((exp.size, 1))
        plain = stats.detectable_size(per_flight, ones, resid, exp, dof=1)
        clustered = stats.detectable_size(per_flight, ones, resid, exp, dof=1, clusters=exp)
        ratios.append((plain.stderr / true_se, clustered.stderr / true_se))
    plain_ratio, clustered_ratio = np.median(ratios, axis=0)
    assert plain_ratio < 0.7
    assert 0.8 < clustered_ratio < 1.25
    assert clustered.limit == pytest.approx(plain.limit * math.sqrt(clustered.design_effect),
                                            rel=1e-9)
    w_plain = stats.detectable_size(within, ones, resid, exp, dof=1)
    w_clustered = stats.detectable_size(within, ones, resid, exp, dof=1, clusters=exp)
    assert w_clustered.limit < 1.5 * w_plain.limit


def test_an_effect_present_in_the_residual_is_not_counted_as_scatter():
    """The sandwich's scores come from the residual with the effect fitted: a real
    per-flight effect of 30 W in the residual leaves the design effect near 1."""
    exp, resid, per_flight, _ = _flights(between_w=0.0)
    sp = stats.project_out(per_flight, np.ones((exp.size, 1)))
    assert stats.design_effect(sp, resid + 30.0 * sp[:, 0], exp, exp, 1) < 2.0


def test_too_few_flights_give_no_design_effect():
    """Fewer than MIN_CLUSTERS flights cannot estimate a between-flight variance: 1."""
    exp, resid, per_flight, _ = _flights(n_flights=stats.MIN_CLUSTERS - 1, between_w=20.0)
    sp = stats.project_out(per_flight, np.ones((exp.size, 1)))
    assert stats.design_effect(sp, resid, exp, exp, 1) == 1.0


def test_a_limit_far_beyond_any_physical_size_is_said_in_words_not_as_a_figure():
    """On log 171 flown by a 7-inch quad's file the wind's limit came out at 4·10¹³ m/s
    and was printed as such; a limit over a thousand times the largest physical size is
    said in words, a nearer one keeps its figure."""
    from planner.identify.diagnose.limits import BEYOND_WORDS, beyond_physics

    far = beyond_physics("wind", "power", 41971114035255.2, 16.0)
    assert "41971114035255" not in far and f"more than {BEYOND_WORDS:g} times" in far
    assert "16.0 m/s" in far
    near = beyond_physics("wind", "power", 48.2, 16.0)
    assert "(48.2 m/s)" in near and "16.0 m/s" in near
    assert beyond_physics("wind", "power", float("inf"), 16.0) == \
        beyond_physics("wind", "power", 1e300, 16.0)


def test_a_withheld_weak_effect_is_said_in_the_unit_of_its_detection_limit():
    """A cold-pack coefficient is a fraction per °C, its limit is given in %/°C: the reason
    an effect within 2 SE of none is withheld shows 0.24 %/°C, not 0.0024 labelled %/°C."""
    from planner.identify.diagnose import _weak_why
    from planner.identify.diagnose.effects import make_effects

    temperature = make_effects(["temperature"])[0]
    why = _weak_why(temperature, {"temperature_coefficient_per_c": 0.0024,
                                  "temperature_coefficient_per_c_stderr": 0.0015},
                    1.6, "capacity")
    assert "(0.240 %/°C ± 0.150 %/°C)" in why and "1.6 standard errors" in why
    assert "vertical descents" not in why


def test_a_weak_wind_says_when_most_of_its_error_is_the_hovers():
    """A multirotor's wind whose error is mostly the bias its hovers show (search,
    "Wind") is withheld with that reason, in m/s; a small bias is not named."""
    from planner.identify.diagnose import _weak_why
    from planner.identify.diagnose.effects import make_effects

    wind = make_effects(["wind"])[0]
    p = {"wind_speed_ms": 2.6, "wind_speed_ms_stderr": 1.5,
         "wind_speed_ms_hover_shift": -1.4, "wind_speed_ms_hover_bias": 1.3}
    why = _weak_why(wind, p, 1.7, "power")
    assert "most of that error is the hovers'" in why
    assert "the wind's speed moves by 1.4 m/s" in why
    assert "vertical descents" not in why
    small = _weak_why(wind, {**p, "wind_speed_ms_hover_bias": 0.3}, 1.7, "power")
    assert "hovers" not in small


def test_the_power_channels_offset_limit_is_named_in_80_percent_of_records():
    """The limit is the size the sensors' test names with 80 % probability: a record
    whose current reads that much too high against an independent power channel (a gain
    error and 1 % noise of its own) passes the test (|z| ≥ 3 and 0.5 % of the median
    current) in about 80 % of draws; at a limit set at the 2.80 standard errors of a test
    at 5 %, which the sensors' test does not use, about half are named."""
    import pandas as pd

    from planner.identify.diagnose import evidence as EV

    def record(rng, b):
        n = 60
        i = 20.0 + 4.0 * rng.standard_normal(n)
        v = 22.0 - 0.02 * i
        p = v * i * (1.0 + rng.normal(0.0, 0.002)) * (1.0 + rng.normal(0.0, 0.01, n))
        return pd.DataFrame({"time_s": np.arange(n, dtype=float), "voltage_v": v,
                             "current_a": i + b, "power_w": p})

    rng = np.random.default_rng(7)
    limit = np.median([EV.power_channel(record(rng, 0.0))["limit_a"] for _ in range(50)])
    named = [EV.power_channel(record(rng, limit))["significant"] for _ in range(400)]
    assert 0.72 <= np.mean(named) <= 0.88, (limit, np.mean(named))


class _Estimate:
    """What a payload candidate's folds read (``effects.StepEstimate``'s two fields)."""

    def __init__(self, step, times):
        self.mass_step_kg, self.change_time_s = step, times


class _Candidate:
    """A payload candidate as the search keeps it (``Comparison``): its tests and what
    its training folds read (``estimate``)."""

    def __init__(self, step, times, lr_p=1e-6, significant=False):
        self.effect = "payload_change"
        self.significant = significant
        self.lr_p_value = lr_p
        self.gain_pct = -2.0
        self.paired_p_value = 0.4
        self.estimate = _Estimate(step, times)


class _Result:
    def __init__(self, *cands):
        self.candidates = {f"payload_change ({k})": c for k, c in enumerate(cands)}


class _Ten:
    """Ten flights of 101 bins, 1 s apart (0–100 s): a change at t s is at t % of each."""
    names = [str(k) for k in range(10)]
    n_experiments = 10
    exp = np.repeat(np.arange(10), 101)
    time = np.tile(np.arange(101.0), 10)


#: A limit 0.20 kg at 0.1–0.3 of the flights and 0.10 kg from 0.4 on; its error 0.03 kg.
_BY = {u: (0.20 if u < 0.35 else 0.10) for u in L.POSITIONS}
_SE = {u: 0.03 for u in L.POSITIONS}


def test_a_step_the_training_flights_see_that_does_not_exclude_the_limit_is_not_settled():
    """Equivalence-test bound (Schuirmann 1987): |δ| + z₀.₉₅ SE against the limit where the
    flights locate the change (the median over them). A 0.16 kg drop at 10–30 %: bound
    0.16 + 1.645 × 0.03 = 0.209 ≥ 0.20: not settled, with the step, where and the bound."""
    times = {"0": 10.0, "1": 20.0, "2": 30.0}
    out = L.unsettled(_Result(_Candidate(-0.16, times)), _Ten(), _BY, _SE)
    assert out is not None
    assert out["bound_kg"] == pytest.approx(0.16 + norm.ppf(0.95) * 0.03)
    assert out["limit_there_kg"] == pytest.approx(0.20)
    assert out["positions"] == pytest.approx([0.1, 0.2, 0.3])
    assert out["located_flights"] == 3
    assert "drop of 0.16 ± 0.03 kg" in out["why"] and "lowers the power" in out["why"]


def test_a_step_whose_bound_stays_below_the_limit_leaves_the_absence_standing():
    """0.14 kg at the same positions: bound 0.189 < 0.20; and no located flight takes the
    smallest limit (0.10 kg), which a 0.14 kg step reaches."""
    times = {"0": 10.0, "1": 20.0, "2": 30.0}
    assert L.unsettled(_Result(_Candidate(-0.14, times)), _Ten(), _BY, _SE) is None
    out = L.unsettled(_Result(_Candidate(0.14, {})), _Ten(), _BY, _SE)
    assert out is not None and out["limit_there_kg"] == pytest.approx(0.10)
    assert "pick-up" in out["why"] and "raises the power" in out["why"]


def test_only_the_last_candidate_unconfirmed_with_its_training_test_passed_is_weighed():
    """A candidate confirmed (named or withheld elsewhere) or whose training test fails
    (p ≥ 0.05) says nothing; of several rounds the last one fitted alone counts (not a
    pair's comparison after it); a change located at a gated position (limit infinite)
    is not settled by it."""
    times = {"0": 10.0, "1": 20.0, "2": 30.0}
    level = _Ten()
    assert L.unsettled(_Result(_Candidate(-0.3, times, significant=True)), level, _BY,
                       _SE) is None
    assert L.unsettled(_Result(_Candidate(-0.3, times, lr_p=0.2)), level, _BY, _SE) is None
    assert L.unsettled(_Result(_Candidate(-0.3, times), _Candidate(-0.3, times, lr_p=0.2)),
                       level, _BY, _SE) is None
    pair = _Candidate(-0.3, times, lr_p=0.2)
    pair.estimate = None            # a pair's comparison (search._pair_step) reads none
    assert L.unsettled(_Result(_Candidate(-0.3, times), pair), level, _BY, _SE) is not None
    gated = {**_BY, 0.1: math.inf, 0.2: math.inf, 0.3: math.inf}
    assert L.unsettled(_Result(_Candidate(-0.3, times)), level, gated, _SE) is None
