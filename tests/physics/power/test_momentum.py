"""Tests of planner.physics.power.momentum (actuator-disk momentum theory).

Reference: J. G. Leishman, Principles of Helicopter Aerodynamics, 2nd ed., 2006, ch. 2
(hover, axial climb and descent, §2.14 vortex-ring state) and ch. 5 (forward flight).
The aircraft is the seed paper's 7-inch quadcopter (0.6 kg, 4 × 0.1778 m rotors).
"""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from planner.physics.atmosphere import G
from planner.errors import ModelError
from planner.physics.power import momentum as mt
from planner.physics.power.multirotor import propeller_battery_power

QUAD = {"mass": 0.6, "air_density": 1.204, "rotors": 4, "diameter": 0.1778, "efficiency": 0.65}
AREA = 4 * np.pi * 0.1778**2 / 4
WEIGHT = 0.6 * G
IDEAL = {"induced_factor": 1.0, "profile_power_ratio": 0.0, "min_rotor_speed_ratio": 0.0}


def test_ideal_hover_power_closed_form():
    """Leishman ch. 2, ideal hover power P = T^1.5 / sqrt(2 ρ A) (κ = 1, no profile)."""
    expected = WEIGHT**1.5 / np.sqrt(2 * 1.204 * AREA)
    assert_allclose(mt.ideal_hover_power(WEIGHT, 1.204, AREA), expected)
    assert_allclose(WEIGHT * mt.hover_induced_velocity(WEIGHT, 1.204, AREA), expected)
    c = mt.momentum_power_components(**QUAD, **IDEAL)
    assert_allclose(c.shaft, expected)
    assert_allclose(c.battery, expected / 0.65)


def test_pure_climb_matches_closed_form():
    vh = mt.hover_induced_velocity(WEIGHT, 1.204, AREA)
    vc = np.linspace(0.0, 12.0, 25)
    expected = -vc / 2 + np.sqrt((vc / 2) ** 2 + vh**2)
    assert_allclose(mt.induced_velocity(WEIGHT, 1.204, AREA, climb_rate=vc), expected,
                    rtol=1e-10)
    c = mt.momentum_power_components(**QUAD, **IDEAL, climb_rate=vc)
    assert_allclose(c.shaft, WEIGHT * (vc + expected), rtol=1e-10)


def test_forward_flight_satisfies_glauert():
    vh = mt.hover_induced_velocity(WEIGHT, 1.204, AREA)
    v = np.array([5.0, 10.0, 20.0])
    alpha = np.array([0.05, 0.1, 0.3])
    vi = mt.induced_velocity(WEIGHT, 1.204, AREA, airspeed=v, disk_tilt=alpha)
    rhs = vh**2 / np.sqrt((v * np.cos(alpha)) ** 2 + (v * np.sin(alpha) + vi) ** 2)
    assert_allclose(vi, rhs, rtol=1e-10)


def test_axial_descent_regions():
    """Leishman §2.14: empirical curve in -2 <= Vc/vh <= 0 (normalised to join hover),
    windmill brake vi = -Vc/2 - sqrt((Vc/2)² - vh²) beyond Vc/vh = -2.5."""
    vh = mt.hover_induced_velocity(WEIGHT, 1.204, AREA)
    x = np.array([-1.0, -3.0, -5.0])
    vi = mt.induced_velocity(WEIGHT, 1.204, AREA, climb_rate=x * vh) / vh
    def poly(z):
        return 1.15 - 1.125 * z - 1.372 * z**2 - 1.718 * z**3 - 0.655 * z**4

    # Leishman's curve divided by κ = 1.15, plus the linear term that joins x = -2
    assert_allclose(vi[0], poly(-1.0) / 1.15 - 0.5 * (poly(-2.0) / 1.15 - 1), rtol=1e-12)
    assert_allclose(vi[1:], -x[1:] / 2 - np.sqrt(x[1:] ** 2 / 4 - 1))


@pytest.mark.parametrize("airspeed", [0.0, 2.0, 5.0])
def test_power_continuous_across_vortex_ring_boundaries(airspeed):
    """Small steps in the descent rate give small changes in power (no jumps)."""
    vh = mt.hover_induced_velocity(WEIGHT, 1.204, AREA)
    vc = np.linspace(-3.5 * vh, 0.5 * vh, 4001)  # step 0.001 vh
    for kwargs in (IDEAL, {}):
        c = mt.momentum_power_components(**QUAD, **kwargs, airspeed=airspeed, climb_rate=vc,
                                         drag_area=0.01)
        hover = mt.momentum_power_components(**QUAD, **kwargs).shaft
        assert np.all(np.isfinite(c.shaft))
        assert np.max(np.abs(np.diff(c.shaft))) < 0.02 * hover
        assert np.max(np.abs(np.diff(c.battery))) < 0.02 * hover / 0.65


def test_induced_velocity_continuous_everywhere():
    vh = mt.hover_induced_velocity(WEIGHT, 1.204, AREA)
    v = np.linspace(0.0, 3.0 * vh, 301)[:, None]
    vc = np.linspace(-6.0 * vh, 2.0 * vh, 1601)[None, :]
    vi = mt.induced_velocity(WEIGHT, 1.204, AREA, airspeed=v, climb_rate=vc)
    assert np.all(np.isfinite(vi)) and np.all(vi > 0)
    assert np.max(np.abs(np.diff(vi, axis=0))) < 0.02 * vh
    assert np.max(np.abs(np.diff(vi, axis=1))) < 0.03 * vh


def test_descent_power_positive_and_finite_over_sweep():
    v = np.linspace(0.0, 40.0, 81)[:, None]
    vc = -np.linspace(0.0, 15.0, 151)[None, :]
    p = mt.momentum_battery_power(**QUAD, airspeed=v, climb_rate=vc, drag_area=0.01)
    hover = mt.momentum_battery_power(**QUAD)
    assert p.shape == (81, 151)
    assert np.all(np.isfinite(p)) and np.all(p > 0)
    assert np.all(p >= hover / 8 - 1e-9)  # the idle floor
    # fast vertical descent: windmill brake, at the floor
    assert_allclose(p[0, -1], hover / 8)


def test_forward_flight_power_bucket():
    v = np.linspace(0.0, 25.0, 251)
    p = mt.momentum_battery_power(**QUAD, airspeed=v, drag_area=0.01)
    i = np.argmin(p)
    assert 0 < i < len(v) - 1
    assert p[i] < 0.9 * p[0] and p[-1] > p[0]
    assert np.all(np.diff(p[: i + 1]) <= 1e-12) and np.all(np.diff(p[i:]) >= -1e-12)


def test_induced_power_scales_as_inverse_sqrt_density():
    rho = np.array([0.9, 1.0, 1.225])
    c = mt.momentum_power_components(0.6, rho, 4, 0.1778, 0.65)
    assert_allclose(c.induced * np.sqrt(rho), c.induced[0] * np.sqrt(rho[0]))
    assert np.all(np.diff(c.induced) < 0)
    assert_allclose(mt.ideal_hover_power(5.0, rho, 0.1) * np.sqrt(rho),
                    5.0**1.5 / np.sqrt(0.2))


def test_figure_of_merit_defines_hover_power():
    for fm in (0.5, 0.6, 0.8):
        p = mt.momentum_power_components(**QUAD, figure_of_merit=fm).shaft
        assert_allclose(p, mt.ideal_hover_power(WEIGHT, 1.204, AREA) / fm)


def test_hover_consistent_with_propeller_model():
    """With FM 0.6 the hover power is within 5 % of the seed's propeller-coefficient
    model (75.1 W): a consistency check between the two models, not a published number."""
    p_mt = mt.momentum_battery_power(**QUAD)
    p_pr = propeller_battery_power(0.6, 1.204, 4, 0.1778, 0.0823, 0.0315, 0.65)
    assert_allclose(p_mt, p_pr, rtol=0.05)


def test_components_add_up():
    c = mt.momentum_power_components(**QUAD, airspeed=12.0, climb_rate=1.0, drag_area=0.01,
                                     system_power=2.0, tip_speed=70.0)
    assert_allclose(c.shaft, c.induced + c.profile + c.parasite + c.climb)
    assert_allclose(c.parasite, 0.5 * 1.204 * 144 * 0.01 * 12.0)
    assert_allclose(c.climb, WEIGHT)
    assert_allclose(c.battery, max(c.shaft, c.floor) / 0.65 + 2.0)
    assert_allclose(c.thrust, np.hypot(WEIGHT, 0.5 * 1.204 * 144 * 0.01))


def test_load_factor_raises_thrust():
    c = mt.momentum_power_components(**QUAD, load_factor=np.sqrt(2), **IDEAL)
    assert_allclose(c.thrust, np.sqrt(2) * WEIGHT)
    assert_allclose(c.shaft, mt.ideal_hover_power(np.sqrt(2) * WEIGHT, 1.204, AREA))


def test_input_kinds_and_nan():
    assert isinstance(mt.momentum_battery_power(**QUAD), float)
    assert isinstance(mt.induced_velocity(5.0, 1.2, 0.1), float)
    vc = np.array([0.0, np.nan, -3.0])
    p = mt.momentum_battery_power(**QUAD, climb_rate=vc)
    assert np.isnan(p[1]) and np.isfinite(p[[0, 2]]).all()
    s = mt.momentum_battery_power(**QUAD, airspeed=pd.Series([0.0, 5.0], index=[7, 8]))
    assert isinstance(s, pd.Series) and list(s.index) == [7, 8]
    assert mt.induced_velocity(0.0, 1.2, 0.1) == 0.0


@pytest.mark.parametrize(
    "kwargs, name",
    [({"mass": -1.0}, "mass"), ({"diameter": 0.0}, "diameter"),
     ({"efficiency": 1.1}, "efficiency"), ({"induced_factor": 0.9}, "induced_factor"),
     ({"figure_of_merit": 0.95}, "figure_of_merit"), ({"tip_speed": 0.0}, "tip_speed"),
     ({"figure_of_merit": 0.6, "profile_power_ratio": 0.5}, "figure_of_merit"),
     ({"airspeed": -1.0}, "airspeed"), ({"load_factor": 0.5}, "load_factor")],
)
def test_impossible_parameters_raise(kwargs, name):
    args = dict(QUAD)
    args.update(kwargs)
    with pytest.raises(ModelError, match=name):
        mt.momentum_battery_power(**args)


def test_slow_descent_with_momentum_weight_one_gives_back_half_the_weight_rate():
    """Liu, Sengupta & Kurzhanskiy, ICUAS 2017: vertical descent power from momentum
    theory's normal working state, κT(−V_d/2 + √(V_d²/4 + v_h²)). With the descent inflow
    weight 1 the curve is that near hover (the induced power falls by W·V_d/2), with 0
    Leishman's (§2.14: the power stays within 6 % of W·V_d of hover's), with 2 it falls by
    nearly the whole W·V_d (95 %)."""
    vh = mt.hover_induced_velocity(WEIGHT, 1.204, AREA)
    vd = 0.01 * vh                                  # x = -0.01
    ideal = {**IDEAL, "climb_rate": -vd}
    hover = mt.momentum_power_components(**QUAD, **IDEAL).shaft
    drop = {w: hover - mt.momentum_power_components(**QUAD, **ideal,
                                                    descent_inflow_weight=w).shaft
            for w in (-1.0, 0.0, 1.0, 2.0)}
    assert drop[1.0] == pytest.approx(0.5 * WEIGHT * vd, rel=0.02)
    liu = WEIGHT * (-vd / 2 + np.sqrt(vd**2 / 4 + vh**2))
    assert hover - drop[1.0] == pytest.approx(liu, rel=1e-4)
    assert abs(drop[0.0]) < 0.06 * WEIGHT * vd
    assert drop[2.0] == pytest.approx(WEIGHT * vd, rel=0.07)
    assert drop[-1.0] < 0.0                         # the power rises as the descent begins


@pytest.mark.parametrize("weight", [-1.0, 1.0, 2.0])
def test_the_descent_weight_changes_only_the_axial_descent_and_stays_continuous(weight):
    """Climb, forward flight above one hover induced velocity and the windmill brake
    beyond x = -2 are the same for every weight; the curve is continuous at x = -2,
    where every weight joins Leishman's curve and the windmill branch."""
    vh = mt.hover_induced_velocity(WEIGHT, 1.204, AREA)
    same = {"climb_rate": np.array([0.0, 1.0, 5.0, -2.5 * vh, -4.0 * vh])}
    for kw in (same, {"airspeed": np.array([1.5 * vh, 3.0 * vh]), "climb_rate": -0.5 * vh}):
        assert_allclose(mt.induced_velocity(WEIGHT, 1.204, AREA, **kw,
                                            descent_inflow_weight=weight),
                        mt.induced_velocity(WEIGHT, 1.204, AREA, **kw), rtol=1e-12)
    x = np.array([-2.0 + 1e-7, -2.0 - 1e-7])
    vi = mt.induced_velocity(WEIGHT, 1.204, AREA, climb_rate=x * vh,
                             descent_inflow_weight=weight)
    assert abs(vi[0] - vi[1]) < 1e-5 * vh
    slow = mt.induced_velocity(WEIGHT, 1.204, AREA, climb_rate=-0.3 * vh,
                               descent_inflow_weight=weight)
    assert slow != pytest.approx(mt.induced_velocity(WEIGHT, 1.204, AREA, climb_rate=-0.3 * vh))


@pytest.mark.parametrize("weight", [-1.5, 2.5])
def test_a_descent_weight_outside_its_range_is_refused(weight):
    with pytest.raises(ModelError, match="descent_inflow_weight"):
        mt.momentum_power_components(**QUAD, climb_rate=-1.0, descent_inflow_weight=weight)


def test_the_tilted_disks_carry_the_drag_power_through_their_axial_inflow():
    """The disks tilted against a drag area f_t in steady level flight: the axial
    inflow V_z = V sin α with tan α = D/W, so T·V_z = D·V (Leishman 2006 ch. 5, the
    energy method) and V_xy² + V_z² = V²; in hover and in a vertical climb the axial
    speed is the climb rate; with no drag area the velocities are the flight's."""
    from planner.physics.power.momentum import tilted_disk_velocities

    rho, m, f, g = 1.19, 2.6, 0.086, 9.80665
    v = np.array([0.0, 4.0, 8.0, 12.0])
    inplane, axial = tilted_disk_velocities(v, 0.0, rho, m, f, gravity=g)
    drag = 0.5 * rho * v**2 * f
    thrust = np.hypot(m * g, drag)
    np.testing.assert_allclose(thrust * axial, drag * v, rtol=1e-12)
    np.testing.assert_allclose(inplane**2 + axial**2, v**2, rtol=1e-12, atol=1e-12)
    assert axial[-1] == pytest.approx(12.0 * np.sin(np.arctan(drag[-1] / (m * g))))
    _, up = tilted_disk_velocities(0.0, 2.5, rho, m, f)
    assert up == pytest.approx(2.5)
    flat = tilted_disk_velocities(v, 1.5, rho, m, 0.0)
    np.testing.assert_allclose(flat[0], v)
    np.testing.assert_allclose(flat[1], 1.5)
