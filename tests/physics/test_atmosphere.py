"""Tests of planner.physics.atmosphere (ISA troposphere)."""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from planner.physics import atmosphere
from planner.errors import ModelError


@pytest.mark.parametrize(
    "altitude_m, rho",
    [(0.0, 1.2250), (1000.0, 1.1117), (5000.0, 0.7364)],
)
def test_density_us_standard_atmosphere_1976(altitude_m, rho):
    """U.S. Standard Atmosphere 1976 (NOAA-S/T 76-1562), tabulated density at 0, 1000
    and 5000 m (1.2250, 1.1117, 0.73643 kg/m³), within 1e-3 relative."""
    assert_allclose(atmosphere.density(altitude_m), rho, rtol=1e-3)


def test_temperature_and_pressure_us_standard_atmosphere_1976():
    """U.S. Standard Atmosphere 1976: 288.15 K / 101325 Pa at 0 m, 281.65 K /
    89874.6 Pa at 1000 m (geopotential), 216.65 K / 22632 Pa at 11000 m."""
    assert_allclose(atmosphere.temperature([0.0, 1000.0, 11000.0]),
                    [288.15, 281.65, 216.65])
    assert_allclose(atmosphere.pressure([0.0, 1000.0, 11000.0]),
                    [101325.0, 89874.6, 22632.1], rtol=1e-4)


def test_density_warm_day_sea_level():
    """20 °C at sea level (ISA pressure): 101325 / (287.05287 · 293.15) = 1.204 kg/m³."""
    assert_allclose(atmosphere.density(0.0, temperature_c=20.0), 1.204, rtol=1e-3)


def test_density_measured_pressure_and_temperature_is_ideal_gas():
    p = np.array([95000.0, 101325.0, 80000.0])
    t_c = np.array([-10.0, 15.0, 35.0])
    expected = p / (287.05287 * (t_c + 273.15))
    # altitude is ignored when both are measured, even outside the ISA range
    assert_allclose(atmosphere.density(20000.0, temperature_c=t_c, pressure_pa=p), expected)


def test_density_pressure_only_uses_isa_temperature():
    rho = atmosphere.density(1000.0, pressure_pa=90000.0)
    assert_allclose(rho, 90000.0 / (287.05287 * 281.65))


def test_density_temperature_override_uses_isa_pressure():
    rho = atmosphere.density(1000.0, temperature_c=30.0)
    assert_allclose(rho, atmosphere.pressure(1000.0) / (287.05287 * 303.15))


def test_scalar_in_float_out():
    assert isinstance(atmosphere.density(100.0), float)
    assert isinstance(atmosphere.temperature(100.0), float)
    assert isinstance(atmosphere.pressure(100.0), float)


def test_ndarray_and_list_in_ndarray_out():
    h = np.array([[0.0, 500.0], [1000.0, 2000.0]])
    rho = atmosphere.density(h)
    assert isinstance(rho, np.ndarray) and rho.shape == (2, 2)
    assert_allclose(atmosphere.density([0.0, 1000.0]), rho.ravel()[[0, 2]])
    assert np.all(np.diff(atmosphere.density(np.linspace(0, 11000, 50))) < 0)


def test_series_in_series_out():
    h = pd.Series([0.0, 1000.0], index=[10, 20])
    rho = atmosphere.density(h)
    assert isinstance(rho, pd.Series)
    assert list(rho.index) == [10, 20]


def test_nan_propagates():
    rho = atmosphere.density(np.array([0.0, np.nan, 1000.0]))
    assert np.isnan(rho[1]) and np.isfinite(rho[[0, 2]]).all()
    assert np.isnan(atmosphere.density(0.0, temperature_c=np.nan))
    assert np.isnan(atmosphere.density(0.0, temperature_c=10.0, pressure_pa=np.nan))


@pytest.mark.parametrize("altitude_m", [-600.0, 11001.0, [0.0, 12000.0]])
def test_altitude_out_of_range_raises_with_range(altitude_m):
    with pytest.raises(ModelError, match=r"altitude_m.*\[-500 m, 11000 m\]"):
        atmosphere.density(altitude_m)


def test_impossible_temperature_and_pressure_raise():
    with pytest.raises(ModelError, match="temperature_c"):
        atmosphere.density(0.0, temperature_c=-300.0)
    with pytest.raises(ModelError, match="pressure_pa"):
        atmosphere.density(0.0, pressure_pa=-1.0)


def test_gravity_constant():
    assert atmosphere.G == 9.80665
