"""Propeller shaft power in axial flight (planner.physics.power.propeller) and the fixed-wing
propulsive-efficiency curve it gives, checked on the UIUC propeller database."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner.errors import ModelError
from planner.physics.power import propeller


def test_ideal_efficiency_is_froude_mccormick_eq_6_13():
    """κ = 1 and no profile power: η = 2 / (1 + √(1 + T/(½ρV²A))) (McCormick 1995,
    eq. 6.13), from the axial induced velocity alone."""
    t, v, rho, d = 30.0, np.array([5.0, 12.0, 20.0, 35.0]), 1.2, 0.33
    area = math.pi * d * d / 4
    eta = propeller.propulsive_efficiency(t, v, rho, d)
    froude = 2.0 / (1.0 + np.sqrt(1.0 + t / (0.5 * rho * v * v * area)))
    np.testing.assert_allclose(eta, froude, rtol=1e-12)
    assert np.all(np.diff(eta) > 0)           # faster flight, lighter disc loading


def test_static_thrust_needs_the_hover_induced_power_leishman_eq_2_124():
    """V = 0: v_i = √(T/(2ρA)), P = κ T v_i + P0 (Leishman 2006 eq. 2.124 at zero climb)."""
    t, rho, d, kappa, p0 = 20.0, 1.1, 0.3, 1.2, 7.0
    area = 2 * math.pi * d * d / 4
    p = propeller.shaft_power(t, 0.0, rho, d, count=2, induced_factor=kappa, profile_power=p0)
    assert p == pytest.approx(kappa * t * math.sqrt(t / (2 * rho * area)) + p0)


def test_coefficient_form_equals_the_si_form():
    """C_P = C_T J + κ C_T λ_i + C_P0 is the SI shaft power over ρ n³ D⁵."""
    rho, d, n = 1.2, 0.3, 80.0
    j = np.array([0.1, 0.4, 0.7])
    ct = np.array([0.10, 0.07, 0.03])
    kappa, cp0 = 1.3, 0.006
    t = ct * rho * n**2 * d**4
    v = j * n * d
    p = propeller.shaft_power(t, v, rho, d, 1, kappa, cp0 * rho * n**3 * d**5)
    np.testing.assert_allclose(p / (rho * n**3 * d**5),
                               propeller.power_coefficient(j, ct, kappa, cp0), rtol=1e-12)


def test_no_thrust_no_power_and_bad_parameters_are_named():
    assert propeller.shaft_power(-5.0, 15.0, 1.2, 0.3, profile_power=5.0) == 0.0
    assert math.isnan(propeller.propulsive_efficiency(0.0, 15.0, 1.2, 0.3))
    with pytest.raises(ModelError, match="propeller_induced_factor"):
        propeller.shaft_power(10.0, 15.0, 1.2, 0.3, induced_factor=0.9)
    with pytest.raises(ModelError, match="propeller_diameter_m"):
        propeller.shaft_power(10.0, 15.0, 1.2, 0.0)


def _x8(**prop):
    from dataclasses import replace
    from pathlib import Path

    from planner.parameters import load_aircraft

    a = load_aircraft(Path(__file__).resolve().parents[3] / "aircraft/x8_mapper.yaml")
    return replace(a, fixed_wing=replace(a.fixed_wing, **prop))


def test_fixed_wing_with_a_propeller_adds_its_losses_to_the_polar():
    """The X8 with a 13-inch propeller: battery power = (T V + κ T v_i + P0)/η + P_S with
    T = P_R / V; an enormous ideal propeller gives back the plain polar."""
    from planner.physics.power import fixed_wing

    plain = _x8()
    with_prop = _x8(propeller_diameter_m=0.33, propeller_induced_factor=1.2,
                    propeller_profile_power_w=15.0)
    v = np.array([14.0, 18.0, 24.0])
    mass, rho = 3.364, 1.2
    f = plain.fixed_wing
    pr = fixed_wing.required_power(v, rho, mass, f.wing_area_m2, f.cd0, f.k)
    thrust = pr / v
    expect = (propeller.shaft_power(thrust, v, rho, 0.33, 1, 1.2, 15.0) / plain.efficiency
              + plain.system_power_w)
    got = with_prop.battery_power(v, 0.0, rho, mass)
    np.testing.assert_allclose(got, expect, rtol=1e-12)
    assert np.all(got > plain.battery_power(v, 0.0, rho, mass))
    ideal = _x8(propeller_diameter_m=5.0, propeller_induced_factor=1.0)
    np.testing.assert_allclose(ideal.battery_power(v, 0.0, rho, mass),
                               plain.battery_power(v, 0.0, rho, mass), rtol=0.01)
    # a glide steeper than the polar's: no thrust, the motor is off
    assert with_prop.battery_power(18.0, -6.0, rho, mass) == pytest.approx(
        plain.system_power_w)


def test_propeller_keys_round_trip_and_are_left_out_without_a_propeller(tmp_path):
    import yaml

    from planner.parameters import aircraft_from_mapping

    m = _x8().to_mapping()
    assert not any(k.startswith("propeller") for k in m["fixed_wing"])
    m["fixed_wing"]["propeller_diameter_m"] = 0.33
    m["fixed_wing"]["propeller_profile_power_w"] = 12.0
    a = aircraft_from_mapping(yaml.safe_load(yaml.safe_dump(m)), "x8.yaml")
    assert a.fixed_wing.propeller_diameter_m == 0.33
    assert a.fixed_wing.propellers == 1 and a.fixed_wing.propeller_induced_factor == 1.15
    assert a.to_mapping()["fixed_wing"]["propeller_profile_power_w"] == 12.0


@pytest.fixture(scope="module")
def uiuc_fits():
    from testkit.uiuc import UIUC, fit_sweep, sweeps

    if not UIUC.is_dir():
        pytest.skip(f"UIUC propeller data not found at {UIUC} (../shared/data/props/uiuc)")
    return [f for f in map(fit_sweep, sweeps()) if f is not None]


def test_momentum_and_profile_form_fits_real_propellers_uiuc_database(uiuc_fits):
    """Every advance-ratio sweep of the UIUC propeller database subset (Brandt, Deters,
    Ananda, Dantsker and Selig, UIUC Propeller Database Vols 1–4): the form
    C_P = C_T J + κ C_T λ_i + C_P0 gives the measured efficiency to a median RMS error
    below 0.02 and beats a constant propulsive efficiency on at least 95 % of them."""
    assert len(uiuc_fits) >= 300
    model = np.array([f.eta_rmse for f in uiuc_fits])
    const = np.array([f.eta_rmse_constant for f in uiuc_fits])
    assert np.median(model) < 0.02
    assert np.mean(model < const) >= 0.95
    assert np.median(const) > 3 * np.median(model)
    kappa = np.array([f.induced_factor for f in uiuc_fits])
    assert 1.0 <= np.median(kappa) < 1.5
    assert np.all(np.array([f.profile_cp for f in uiuc_fits]) >= 0)
