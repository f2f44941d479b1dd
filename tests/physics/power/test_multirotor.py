"""Tests of planner.physics.power.multirotor (propeller-coefficient model, seed eq. 9–10, 22–24).

Published numbers: the 7-inch quadcopter example of the seed paper, "Battery Testing and
Discharge Model Validation for Electric UAV": m = 0.6 kg, D = 7 in = 0.1778 m,
C_T = 0.0823, C_P = 0.0315, η = 0.65, P_S = 0, ρ = 1.204 kg/m³. The paper's numbers are
reproduced with g = 9.81 m/s² (the seed's value; 9.80665 differs by < 0.05 %).
"""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from planner.errors import ModelError
from planner.physics.power import multirotor as mr

QUAD = {"mass": 0.6, "air_density": 1.204, "rotors": 4, "diameter": 0.1778,
        "ct": 0.0823, "cp": 0.0315, "efficiency": 0.65, "gravity": 9.81}
RTOL = 0.015


def _battery(**kwargs):
    return mr.propeller_battery_power(**QUAD, **kwargs)


def test_seed_7inch_quad_hover_rotor_speed_and_rotor_power():
    """Seed paper, 7-inch quad: hover rotor speed 122 rev/s, 12.2 W per rotor."""
    n = mr.rotor_speed(0.6 * 9.81 / 4, 1.204, 0.1778, 0.0823)
    assert_allclose(n, 122.0, rtol=RTOL)
    assert_allclose(mr.rotor_power(n, 1.204, 0.1778, 0.0315), 12.2, rtol=RTOL)


@pytest.mark.parametrize(
    "climb_rate, expected",
    [(0.0, 75.2), (3.0, 102.4), (6.0, 129.5), (-3.0, 48.0)],
)
def test_seed_7inch_quad_battery_power_vertical_flight(climb_rate, expected):
    """Seed paper, 7-inch quad battery power: hover 75.2 W, climb 3 m/s 102.4 W,
    climb 6 m/s 129.5 W, descent 3 m/s 48.0 W (within 1.5 %)."""
    assert_allclose(_battery(climb_rate=climb_rate), expected, rtol=RTOL)


def test_vertical_flight_is_linear_in_climb_rate():
    vc = np.array([-2.0, 0.0, 2.0, 4.0])
    p = _battery(climb_rate=vc)
    assert_allclose(np.diff(p), 0.6 * 9.81 * 2.0 / 0.65)


def test_fast_descent_floor_is_idle_rotor_power():
    hover = _battery()
    p = _battery(climb_rate=np.array([-10.0, -20.0]), system_power=3.0)
    # idle at half the hover rotor speed: (1/2)³ of the hover rotor power
    assert_allclose(p, hover / 8 + 3.0)
    assert_allclose(_battery(climb_rate=-20.0, min_rotor_speed_ratio=0.0), 0.0, atol=1e-12)


def test_forward_flight_extension():
    v = np.array([0.0, 5.0, 10.0, 15.0])
    f = 0.01
    p = _battery(airspeed=v, drag_area=f)
    drag = 0.5 * 1.204 * v**2 * f
    weight = 0.6 * 9.81
    n = mr.rotor_speed(np.sqrt(weight**2 + drag**2) / 4, 1.204, 0.1778, 0.0823)
    expected = (4 * mr.rotor_power(n, 1.204, 0.1778, 0.0315) + drag * v) / 0.65
    assert_allclose(p, expected)
    assert np.all(np.diff(p) > 0)  # no translational-lift credit: monotone in speed
    assert_allclose(_battery(airspeed=10.0), _battery())  # no drag area: hover power


def test_system_power_adds():
    assert_allclose(_battery(system_power=5.0) - _battery(), 5.0)


def test_input_kinds_and_nan():
    assert isinstance(_battery(), float)
    vc = np.array([0.0, np.nan, 3.0])
    p = _battery(climb_rate=vc)
    assert isinstance(p, np.ndarray) and np.isnan(p[1]) and np.isfinite(p[[0, 2]]).all()
    s = _battery(climb_rate=pd.Series([0.0, 3.0], index=["a", "b"]))
    assert isinstance(s, pd.Series) and list(s.index) == ["a", "b"]
    grid = _battery(climb_rate=np.array([0.0, 3.0])[:, None], airspeed=np.array([0.0, 5.0]),
                    drag_area=0.01)
    assert grid.shape == (2, 2)


@pytest.mark.parametrize(
    "name, value",
    [("mass", -0.6), ("diameter", 0.0), ("efficiency", 1.5), ("efficiency", 0.0),
     ("ct", 0.0), ("cp", -0.1), ("rotors", 0), ("rotors", 2.5), ("drag_area", -0.1),
     ("air_density", -1.0), ("system_power", -1.0)],
)
def test_impossible_parameters_raise(name, value):
    args = dict(QUAD)
    args[name] = value
    with pytest.raises(ModelError, match=name):
        mr.propeller_battery_power(**args)


def test_negative_thrust_raises():
    with pytest.raises(ModelError, match="thrust"):
        mr.rotor_speed(-1.0, 1.2, 0.2, 0.08)
