"""Local east/north projection about home (planner.physics.geo)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad

from planner.physics import geo


def _deg_lat_length(lat):
    """Length of one degree of latitude centred on ``lat`` [m]: the standard WGS-84
    series 111132.954 - 559.822 cos 2φ + 1.175 cos 4φ (e.g. NGA, "Length of a
    degree of latitude and longitude")."""
    p = np.radians(lat)
    return 111132.954 - 559.822 * np.cos(2 * p) + 1.175 * np.cos(4 * p)


def _deg_lon_length(lat):
    """Length of one degree of longitude at ``lat`` [m], same source:
    111412.84 cos φ - 93.5 cos 3φ + 0.118 cos 5φ."""
    p = np.radians(lat)
    return 111412.84 * np.cos(p) - 93.5 * np.cos(3 * p) + 0.118 * np.cos(5 * p)


def test_one_degree_of_latitude_at_45():
    _, north = geo.latlon_to_en([45.5, 44.5], [10.0, 10.0], 45.0, 10.0)
    span = north[0] - north[1]
    assert_allclose(span, _deg_lat_length(45.0), rtol=1e-4)   # 111 131.8 m
    assert_allclose(span, 111.2e3, rtol=1e-3)                  # "about 111.2 km"


def test_one_degree_of_longitude_at_45():
    east, _ = geo.latlon_to_en([45.0, 45.0], [10.5, 9.5], 45.0, 10.0)
    assert_allclose(east[0] - east[1], _deg_lon_length(45.0), rtol=1e-4)  # 78 846 m


def test_meridian_arc_over_50_km_within_0p1_percent():
    # reference: the meridian arc length, ∫ M(φ) dφ, integrated numerically
    lat0, lat1 = 48.0, 48.45
    arc, _ = quad(lambda p: geo.meridian_radius(np.degrees(p)), np.radians(lat0),
                  np.radians(lat1))
    assert arc == pytest.approx(50_000, rel=0.01)
    _, north = geo.latlon_to_en(lat1, 10.4, lat0, 10.4)
    assert north == pytest.approx(arc, rel=1e-3)


def test_radii_of_curvature_known_values():
    # WGS-84: M = b²/a at the equator, N = a at the equator, N = M = a²/b at the pole
    a, f = 6378137.0, 1 / 298.257223563
    b = a * (1 - f)
    assert geo.meridian_radius(0.0) == pytest.approx(b * b / a, rel=1e-12)
    assert geo.normal_radius(0.0) == pytest.approx(a, rel=1e-12)
    assert geo.meridian_radius(90.0) == pytest.approx(a * a / b, rel=1e-12)
    assert geo.normal_radius(90.0) == pytest.approx(a * a / b, rel=1e-12)


def test_round_trip_arrays_to_a_millimetre():
    rng = np.random.default_rng(1)
    east = rng.uniform(-50e3, 50e3, 200)
    north = rng.uniform(-50e3, 50e3, 200)
    for home in [(48.0468, 10.4452), (-33.9, 151.2), (64.1, -21.9), (0.0, 179.9)]:
        lat, lon = geo.en_to_latlon(east, north, *home)
        assert isinstance(lat, np.ndarray) and lat.shape == east.shape
        e2, n2 = geo.latlon_to_en(lat, lon, *home)
        assert_allclose(e2, east, atol=1e-3)
        assert_allclose(n2, north, atol=1e-3)


def test_scalar_in_scalar_out_and_home_is_origin():
    e, n = geo.latlon_to_en(48.0468, 10.4452, 48.0468, 10.4452)
    assert isinstance(e, float) and isinstance(n, float)
    assert (e, n) == (0.0, 0.0)
    lat, lon = geo.en_to_latlon(0.0, 0.0, 48.0468, 10.4452)
    assert lat == pytest.approx(48.0468, abs=1e-12)
    assert lon == pytest.approx(10.4452, abs=1e-12)


def test_axes_directions():
    # a point north of home has ~0 east; a point east of home (same latitude) has
    # positive east and only the curvature drop (a few mm at 100 m) in north
    e, n = geo.latlon_to_en(48.01, 10.0, 48.0, 10.0)
    assert abs(e) < 1e-6 and n > 1000
    e, n = geo.latlon_to_en(48.0, 10.001, 48.0, 10.0)
    assert e == pytest.approx(74.5, rel=1e-2) and abs(n) < 0.01


def test_nan_propagates():
    e, n = geo.latlon_to_en(np.array([np.nan, 48.0]), np.array([np.nan, 10.0]), 48.0, 10.0)
    assert np.isnan(e[0]) and np.isnan(n[0]) and e[1] == 0.0
