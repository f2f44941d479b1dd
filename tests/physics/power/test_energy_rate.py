"""The energy-rate balance of a fixed wing ([UAV23] eq. 2 with dV/dt kept)."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from planner.errors import ModelError
from planner.physics.atmosphere import G
from planner.physics.power import energy_rate as er
from planner.physics.power import fixed_wing as fw


def test_drag_regressors_are_the_seed_polar_coefficients():
    """[UAV23] eq. 3-4: A V³ = a·C_D0 and B/V = b·K for any speed and density."""
    v = np.array([8.0, 12.0, 20.0])
    rho = np.array([1.1, 1.2, 1.25])
    a, b = er.polar_power_terms(v, rho, 9.4, 1.5)
    big_a, big_b = fw.polar_coefficients(rho, 1.5, 0.04, 0.03, 9.4 * G)
    assert_allclose(a * 0.04, big_a * v**3, rtol=1e-12)
    assert_allclose(b * 0.03, big_b / v, rtol=1e-12)
    # level and steady, the balance is the seed's power required
    req = fw.required_power(v, rho, 9.4, 1.5, 0.04, 0.03)
    assert_allclose(a * 0.04 + b * 0.03 + er.energy_rate(9.4, v, 0.0, 0.0), req, rtol=1e-12)


def test_energy_rate_counts_height_and_speed_changes():
    assert er.energy_rate(2.0, 10.0, 0.0, 1.0) == pytest.approx(2.0 * G)
    assert er.energy_rate(2.0, 10.0, 0.5, 0.0) == pytest.approx(10.0)      # m V dV/dt
    with pytest.raises(ModelError, match="mass"):
        er.energy_rate(0.0, 10.0, 0.0, 0.0)


def test_a_steady_glide_gives_its_own_lift_to_drag():
    """Motor off, steady: the sink rate is V/(L/D), so the energy rate gives C_D = C_L/(L/D)."""
    v, ld = 11.0, 15.0
    cl = er.lift_coefficient(v, 1.2, 9.4, 1.5)
    cd = er.glide_drag_coefficient(v, 0.0, -v / ld, 1.2, 9.4, 1.5)
    assert cd == pytest.approx(cl / ld, rel=1e-12)


def test_lift_power_regressor_and_shifted_polar():
    """C_D0 + K1 C_L + K C_L² = C_Dmin + K (C_L − C_Lmin)², and its drag power."""
    cd_min, cl_min, k = 0.04, 0.55, 0.073
    k1, cd0 = -2 * k * cl_min, cd_min + k * cl_min**2
    assert er.shifted_polar(cd0, k1, k) == pytest.approx((cd_min, cl_min))
    assert all(math.isnan(x) for x in er.shifted_polar(0.04, 0.01, 0.0))
    v, rho = 10.0, 1.2
    a, b = er.polar_power_terms(v, rho, 9.4, 1.5)
    cl = er.lift_coefficient(v, rho, 9.4, 1.5)
    direct = (cd0 + k1 * cl + k * cl**2) * 0.5 * rho * v**3 * 1.5
    assert a * cd0 + er.lift_power(v, 9.4) * k1 + b * k == pytest.approx(direct, rel=1e-12)


def test_thrust_power():
    assert er.thrust_power(108.0, 0.5, 8.0) == pytest.approx(50.0)
    with pytest.raises(ModelError, match="efficiency"):
        er.thrust_power(100.0, 1.2)
