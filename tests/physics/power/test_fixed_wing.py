"""Tests of planner.physics.power.fixed_wing (seed eq. 2–6) and planner.physics.power.speeds."""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from planner.physics.atmosphere import G
from planner.errors import ModelError
from planner.physics.power import fixed_wing as fw
from planner.physics.power.speeds import best_speeds

# Volantex Phoenix S of the seed paper ("Battery Testing and Discharge Model Validation
# for Electric UAV"): 0.98 kg, wing area 0.295 m², span 1.6 m.
PHOENIX = {"mass": 0.98, "wing_area": 0.295, "cd0": 0.0182, "k": 0.046}
RHO = 1.204


def test_induced_drag_factor():
    assert_allclose(fw.induced_drag_factor(8.0, 0.8), 1.0 / (np.pi * 0.8 * 8.0))


def test_phoenix_cruise_power_seed():
    """Seed paper, Volantex Phoenix S cruising at 60 km/h: ≈16.4 W mechanical.

    K = 1/(π·0.8·AR) with AR = 1.6²/0.295 = 8.68 gives K = 0.0459 ≈ 0.046; C_D0 = 0.0182
    is what solves P_R = A V³ + B/V = 16.4 W for that K at ρ = 1.204 kg/m³, g = 9.81
    (the paper quotes the cruise figure, not C_D0). Within 1 %.
    """
    k = fw.induced_drag_factor(1.6**2 / 0.295, 0.8)
    assert_allclose(k, 0.046, rtol=0.01)
    p = fw.required_power(60 / 3.6, RHO, **PHOENIX, gravity=9.81)
    assert_allclose(p, 16.4, rtol=0.01)


def test_min_power_speed_is_argmin_of_required_power():
    v = np.linspace(5.0, 30.0, 200001)
    p = fw.required_power(v, RHO, **PHOENIX)
    v_mp = fw.min_power_speed(RHO, **PHOENIX)
    assert_allclose(v_mp, v[np.argmin(p)], rtol=1e-4)
    a, b = fw.polar_coefficients(RHO, 0.295, 0.0182, 0.046, 0.98 * G)
    assert_allclose(v_mp, (b / (3 * a)) ** 0.25)


def test_max_range_speed_is_argmin_of_power_per_speed():
    v = np.linspace(5.0, 30.0, 200001)
    p = fw.required_power(v, RHO, **PHOENIX)
    assert_allclose(fw.max_range_speed(RHO, **PHOENIX), v[np.argmin(p / v)], rtol=1e-4)
    assert_allclose(fw.max_range_speed(RHO, **PHOENIX) / fw.min_power_speed(RHO, **PHOENIX),
                    3**0.25)


def test_climb_power_difference_at_battery():
    eta, climb = 0.5, 2.0
    level = fw.battery_power(fw.required_power(16.0, RHO, **PHOENIX), eta, 1.5)
    up = fw.battery_power(fw.required_power(16.0, RHO, **PHOENIX, climb_rate=climb), eta, 1.5)
    assert_allclose(up - level, 0.98 * G * climb / eta)


def test_zero_airspeed_needs_infinite_power():
    p = fw.required_power(np.array([0.0, 10.0]), RHO, **PHOENIX)
    assert np.isposinf(p[0]) and np.isfinite(p[1])
    assert np.isposinf(fw.battery_power(p, 0.5)[0])


def test_steep_descent_required_power_negative_battery_power_floor():
    p_r = fw.required_power(16.0, RHO, **PHOENIX, climb_rate=-5.0)
    assert p_r < 0  # physics: gravity supplies more than the drag takes
    assert fw.battery_power(p_r, 0.5, system_power=2.0) == 2.0


def test_load_factor_45_degree_bank():
    v = 20.0
    r = v**2 / G  # tan(phi) = V²/(g r) = 1
    assert_allclose(fw.bank_load_factor(v, r), np.sqrt(2.0))
    assert_allclose(fw.bank_angle(v, r), np.pi / 4)


def test_load_factor_raises_induced_power_and_speeds():
    a1, b1 = fw.polar_coefficients(RHO, 0.295, 0.0182, 0.046, 9.6, load_factor=1.0)
    a2, b2 = fw.polar_coefficients(RHO, 0.295, 0.0182, 0.046, 9.6, load_factor=np.sqrt(2))
    assert_allclose(a1, a2)
    assert_allclose(b2, 2 * b1)
    assert_allclose(fw.min_power_speed(RHO, **PHOENIX, load_factor=np.sqrt(2)),
                    2**0.25 * fw.min_power_speed(RHO, **PHOENIX))


def test_input_kinds_and_nan():
    assert isinstance(fw.required_power(16.0, RHO, **PHOENIX), float)
    v = np.array([10.0, np.nan, 20.0])
    p = fw.required_power(v, RHO, **PHOENIX)
    assert isinstance(p, np.ndarray) and np.isnan(p[1]) and np.isfinite(p[[0, 2]]).all()
    s = fw.required_power(pd.Series([10.0, 20.0], index=[3, 4]), RHO, **PHOENIX)
    assert isinstance(s, pd.Series) and list(s.index) == [3, 4]
    assert_allclose(s.to_numpy(), p[[0, 2]])
    grid = fw.required_power(np.array([10.0, 20.0])[:, None], np.array([1.0, 1.2]),
                             **PHOENIX)
    assert grid.shape == (2, 2)
    assert np.isnan(fw.battery_power(np.nan, 0.5))


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"mass": -1.0}, "mass"),
        ({"wing_area": 0.0}, "wing_area"),
        ({"cd0": -0.01}, "cd0"),
        ({"air_density": 0.0}, "air_density"),
        ({"airspeed": -1.0}, "airspeed"),
        ({"load_factor": 0.5}, "load_factor"),
    ],
)
def test_impossible_parameters_raise(kwargs, name):
    args = dict(airspeed=15.0, air_density=RHO, **PHOENIX)
    args.update(kwargs)
    with pytest.raises(ModelError, match=name):
        fw.required_power(**args)


def test_impossible_efficiency_and_oswald_raise():
    for eta in (0.0, 1.2):
        with pytest.raises(ModelError, match="efficiency"):
            fw.battery_power(10.0, eta)
    with pytest.raises(ModelError, match="oswald_efficiency"):
        fw.induced_drag_factor(8.0, 1.5)
    with pytest.raises(ModelError, match="turn_radius"):
        fw.bank_load_factor(15.0, 0.0)


# ---- planner.physics.power.speeds ---------------------------------------------------------
def _phoenix_battery_power(v):
    return fw.battery_power(fw.required_power(v, RHO, **PHOENIX), 0.5)


def test_best_speeds_match_analytic_polar():
    v_e, v_r = best_speeds(_phoenix_battery_power, 5.0, 35.0)
    assert_allclose(v_e, fw.min_power_speed(RHO, **PHOENIX), rtol=5e-3)
    assert_allclose(v_r, fw.max_range_speed(RHO, **PHOENIX), rtol=5e-3)


def test_headwind_raises_max_range_speed():
    still = best_speeds(_phoenix_battery_power, 5.0, 35.0)
    winds = best_speeds(_phoenix_battery_power, 5.0, 35.0, headwind=np.array([-3.0, 0, 5.0]))
    assert winds.max_endurance == pytest.approx(still.max_endurance)
    assert_allclose(winds.max_range[1], still.max_range)
    assert winds.max_range[0] < still.max_range < winds.max_range[2]


def test_best_speeds_bounds_and_no_progress():
    # minimum outside the interval -> the bound
    v_e, _v_r = best_speeds(_phoenix_battery_power, 13.0, 35.0)
    assert v_e == pytest.approx(13.0)
    # headwind above v_max: no progress possible
    assert np.isnan(best_speeds(_phoenix_battery_power, 5.0, 20.0, headwind=25.0).max_range)
    with pytest.raises(ModelError, match="v_max"):
        best_speeds(_phoenix_battery_power, 10.0, 5.0)
