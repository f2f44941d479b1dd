"""planner.identify.stats: the one covariance and autocorrelation treatment of every fit."""

import numpy as np
import pytest
from scipy.optimize import curve_fit

from planner.identify import stats


def test_covariance_equals_curve_fit_on_independent_noise():
    rng = np.random.default_rng(0)
    x = np.linspace(0, 10, 200)
    y = 2.0 + 0.5 * x + rng.normal(0, 0.3, x.size)
    popt, pcov = curve_fit(lambda x, a, b: a + b * x, x, y)
    jac = np.column_stack([np.ones_like(x), x])
    resid = popt[0] + popt[1] * x - y
    cov = stats.covariance(jac, resid, autocorrelated=False)
    np.testing.assert_allclose(cov.matrix, pcov, rtol=1e-6)
    assert not cov.singular and np.isfinite(cov.condition)


def test_singular_jacobian_gives_infinite_covariance_not_a_pseudo_inverse():
    x = np.linspace(0, 1, 50)
    jac = np.column_stack([x, 2 * x])            # two parameters the data cannot separate
    cov = stats.covariance(jac, np.ones(50) * 0.1)
    assert cov.singular and np.all(np.isinf(cov.stderr))
    assert stats.jacobian_covariance(np.column_stack([x, np.zeros(50)])).singular


def test_ar1_inflation_matches_the_effective_sample_size_of_an_ar1_series():
    """Box et al. sec. 2.1: the mean of an AR(1) series has variance σ²/n (1+ρ)/(1−ρ);
    the inflation of an intercept fit reproduces it on simulated series."""
    rng = np.random.default_rng(1)
    rho, n, runs = 0.8, 400, 400
    e = rng.normal(size=(runs, n))
    series = np.empty_like(e)
    series[:, 0] = e[:, 0] / np.sqrt(1 - rho**2)
    for k in range(1, n):
        series[:, k] = rho * series[:, k - 1] + e[:, k]
    means = series.mean(axis=1)
    jac = np.ones((n, 1))
    se = np.array([stats.covariance(jac, s - s.mean()).stderr[0] for s in series])
    # the reported standard error of the mean matches the spread of the means (±15 %)
    assert np.median(se) == pytest.approx(means.std(), rel=0.15)
    assert np.median([stats.lag1_autocorrelation(s) for s in series]) == pytest.approx(
        rho, abs=0.05)


def test_autocorrelation_is_taken_within_groups_and_clipped():
    r = np.r_[np.ones(10), -np.ones(10)]
    assert stats.lag1_autocorrelation(r, groups=np.r_[np.zeros(10), np.ones(10)]) <= \
        stats.RHO_MAX
    assert stats.ar1_inflation(0.99) == stats.ar1_inflation(stats.RHO_MAX)
    assert stats.lag1_autocorrelation(np.array([1.0, -1.0] * 10)) == 0.0


def test_poorly_determined_is_a_relative_standard_error_above_the_limit():
    """The one rule every fit uses: a standard error that is not finite or above
    ``limit`` × |value| (a value of 0 counts as 1e-12), in the order of the values."""
    values = {"a": 2.0, "b": -4.0, "c": 1.0, "d": 0.0, "e": 3.0}
    stderr = {"a": 0.2, "b": 0.41, "c": np.inf, "d": 1e-3, "e": np.nan}
    assert stats.poorly_determined(values, stderr, 0.1) == ["b", "c", "d", "e"]
    assert stats.poorly_determined(values, stderr, 0.5) == ["c", "d", "e"]
    assert stats.poorly_determined({"a": 2.0}, {"a": 0.2}, 0.1) == []   # at the limit


def test_scaled_covariance_is_curve_fits_pcov_from_the_residual_sum_of_squares():
    rng = np.random.default_rng(3)
    x = np.linspace(0, 5, 80)
    y = 1.0 - 0.3 * x + rng.normal(0, 0.2, x.size)
    popt, pcov = curve_fit(lambda x, a, b: a + b * x, x, y)
    jac = np.column_stack([np.ones_like(x), x])
    r = popt[0] + popt[1] * x - y
    np.testing.assert_allclose(stats.scaled_covariance(jac, float(r @ r)).matrix, pcov,
                               rtol=1e-6)
    singular = stats.scaled_covariance(np.column_stack([x, 3 * x]), 1.0)
    assert singular.singular and np.all(np.isinf(singular.matrix))
    with pytest.warns(RuntimeWarning, match="covariance of the test fit is indeterminate"):
        singular.warn_if_singular("the test fit", RuntimeWarning)


def test_random_walk_covariance_is_infinite_for_a_singular_jacobian():
    t = np.arange(100.0)
    jac = np.column_stack([t, 2 * t])
    cov, iid, rho = stats.random_walk_covariance(jac, np.cumsum(np.ones(100)), t, [0],
                                                 [100], lag_fraction=0.01)
    assert cov.singular and iid.singular and np.all(np.isinf(cov.stderr))
    assert 0.9 < rho <= 1.0                      # a straight line about its mean


def test_effective_clusters_count_the_flights_that_carry_an_estimate():
    """Carter, Schnepel & Steigerwald (2017) G*(0): equal clusters give their number; a
    parameter that three of sixteen equal flights carry (its column is zero elsewhere)
    rests on three, and a test of it is judged on Student's t with two degrees of
    freedom (4.30 at 5 %, two-sided); from four effective clusters the normal stands."""
    rng = np.random.default_rng(0)
    groups = np.repeat(np.arange(16), 50)
    level = np.ones(groups.size)
    x = rng.normal(size=groups.size)
    J = np.column_stack([level, x])
    assert stats.effective_clusters(J, [0.0, 1.0], groups) == pytest.approx(16, rel=0.1)
    carried = np.where(groups < 3, x, 0.0)
    J3 = np.column_stack([level, carried])
    g = stats.effective_clusters(J3, [0.0, 1.0], groups)
    assert g == pytest.approx(3, rel=0.1)
    assert stats.few_clusters_critical(g) > stats.few_clusters_critical(3.9) > 1.96
    assert stats.few_clusters_critical(3.0) == pytest.approx(4.303, abs=1e-3)
    assert stats.few_clusters_critical(4.0) is None
    assert stats.few_clusters_critical(float("nan")) is None
    # unequal shares: one flight with most of the information counts little more than one
    weights = np.where(groups == 0, 10.0, 1.0)
    assert stats.effective_clusters(np.column_stack([level, x * weights]), [0, 1],
                                    groups) < 3


def test_a_step_not_yet_fitted_does_not_count_as_noise_in_the_step_robust_variance():
    """A change point is located against the noise, and its detection limit predicted
    with it: a step still in the residual must not raise that noise (else the larger a
    change, the higher its own limit). On white noise of unit variance with a step of
    4 in the middle, the RSS-based long-run variance counts the step (about 4 + the
    inflation its autocorrelation brings: 40 here); the step-robust one stays below 2 (the
    step touches a few of its differences at a lag), and near the RSS-based one where
    there is no step."""
    rng = np.random.default_rng(3)
    noise = rng.normal(0.0, 1.0, 400)
    stepped = noise + np.where(np.arange(400) >= 200, 4.0, 0.0)
    stepped -= stepped.mean()
    assert stats.long_run_variance(stepped) > 20.0
    assert 0.7 < stats.step_robust_long_run_variance(stepped) < 2.0
    assert stats.step_robust_long_run_variance(noise) == pytest.approx(
        stats.long_run_variance(noise), rel=0.3)
