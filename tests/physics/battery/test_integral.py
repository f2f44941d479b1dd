"""Integral capacity model (seed paper "Battery Testing and Discharge Model
Validation for Electric UAV", DESIGN §5)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from planner.physics.battery import integral

M_CONST = {"delta": 23.6482, "epsilon": -1.0209, "beta": 0.9648}  # seed Table 5


def test_literature_start_values_4s_seed_equations():
    """δ₀(4) = 18.089 and ε₀(4) = −1.032 from the seed's start-value polynomials."""
    assert integral.literature_delta(4) == pytest.approx(18.089, abs=5e-4)
    assert integral.literature_epsilon(4) == pytest.approx(-1.032, abs=5e-4)


def test_literature_values_vectorised():
    n = np.array([3, 4, 6])
    assert_allclose(integral.literature_delta(n),
                    [integral.literature_delta(k) for k in n])


@pytest.mark.parametrize("power", [50.0, 75.0, 100.0, 125.0])
def test_constant_power_reduces_to_t_equals_delta_p_eps_c_beta(power):
    """At constant power the integral equals t = δ P^ε C^β (seed eq. 17)."""
    t_end = 3000.0
    t = np.linspace(0, t_end, 3001)
    c = integral.charge(t, np.full_like(t, power), **M_CONST)
    assert_allclose(integral.discharge_time(power, c[-1], **M_CONST), t_end, rtol=1e-9)


def test_piecewise_equals_sampled_for_steps():
    """Exact piecewise sums agree with trapezoid integration of a step profile."""
    durations = np.array([600.0, 300.0, 900.0])
    powers = np.array([80.0, 120.0, 60.0])
    s = integral.stress_piecewise(durations, powers, M_CONST["delta"], M_CONST["epsilon"])
    t = np.arange(0, 1800.0 + 0.25, 0.25)
    p = np.select([t < 600, t < 900], [80.0, 120.0], 60.0)
    c = integral.charge(t, p, **M_CONST)
    assert integral.charge_from_stress(s[-1], M_CONST["beta"]) == pytest.approx(c[-1],
                                                                               rel=2e-4)


def test_rest_draws_no_charge_and_charge_never_falls():
    t = np.arange(0, 100.0)
    p = np.where((t > 30) & (t < 60), 0.0, 90.0)
    c = integral.charge(t, p, **M_CONST)
    assert np.all(np.diff(c) >= 0)
    assert c[55] == pytest.approx(c[32], rel=0.02)  # flat during the rest


def test_multistar_100w_runtime_is_physical():
    """10 Ah 4S (≈148 Wh) at 100 W: about 1.5 h, as energy alone suggests."""
    t = integral.discharge_time(100.0, 10.0 * 3600, **M_CONST)
    assert 1.35 * 3600 < t < 1.6 * 3600


def test_time_to_charge_inverts_charge():
    s_now = integral.stress_from_charge(5000.0, M_CONST["beta"])
    dt = integral.time_to_charge(s_now, 100.0, 9000.0, **M_CONST)
    s_after = s_now + dt * integral.stress_rate(100.0, M_CONST["delta"], M_CONST["epsilon"])
    assert integral.charge_from_stress(s_after, M_CONST["beta"]) == pytest.approx(9000.0)


def test_nan_power_propagates():
    assert np.isnan(integral.stress_rate(np.nan, 20.0, -1.0))


def test_bad_parameters_raise():
    with pytest.raises(ValueError, match="delta"):
        integral.charge([0, 1], [10, 10], delta=-1.0, epsilon=-1.0)
