r"""Latitude/longitude <-> local east/north metres about a home point.

Two frames, both east/north of home in metres:

- **Legs** (:func:`latlon_to_aeqd`, :func:`aeqd_to_latlon`): the frame of a
  mission's legs (:mod:`planner.io.mission.route`), an azimuthal equidistant
  projection about home scaled to the WGS-84 radii of curvature at home, in
  which distances and bearings from home are great-circle ones at any range.
- **Tangent plane** (:func:`latlon_to_en`, :func:`en_to_latlon`): the
  orthographic projection onto the ellipsoid's tangent plane at home, for
  local work (writing simulated logs). Within 50 km of home the two frames
  agree to 1e-4 (0.01 %) in distance and a few metres in position; beyond
  some hundreds of kilometres the tangent plane shrinks distances from home by
  ``cos(d / R)`` and folds the far hemisphere onto the near one.

Leg frame
---------
A point at great-circle angle :math:`\sigma` from home, seen from home at
initial bearing :math:`\alpha` (spherical trigonometry on the geodetic
latitude and longitude), is placed at

.. math:: e = N_0 \, \sigma \sin\alpha, \qquad n = M_0 \, \sigma \cos\alpha

with :math:`M_0` the meridional and :math:`N_0` the prime-vertical radius of
curvature at home (:func:`meridian_radius`, :func:`normal_radius`); [1]_,
ch. 25, on a sphere.

- Distance and bearing *from home* are great-circle ones at any range, across
  a pole or up to the antipode: a leg that starts or ends at home, or runs
  straight through it, has its great-circle length, and a leg from home its
  initial bearing.
- Near home the frame is the ellipsoid's tangent plane to first order (it has
  the ellipsoid's metric :math:`M_0^2 d\varphi^2 + N_0^2 \cos^2\varphi\,
  d\lambda^2` at home). The radii change with latitude by about
  :math:`3 e^2 \sin\varphi \cos\varphi\,\Delta\varphi`, 8e-5 (0.008 %) over
  50 km; the home altitude is ignored (points are taken on the ellipsoid),
  which scales distances by ``1 / (1 + h / R)``: 1e-4 (0.01 %) at h = 600 m
  AMSL. Both are far below the 0.1 % the planner needs.
- A straight line in the frame between two points away from home is longer
  than their great circle by up to :math:`\sigma / \sin\sigma - 1 \approx
  \sigma^2 / 6` (across the line of sight from home): 1e-5 at 50 km from home,
  0.1 % at 490 km (:data:`FRAME_ERROR_KM`). :func:`frame_error` gives the
  error of one leg, for the route to reject legs the frame cannot represent.
- Far from home the scaled sphere differs from the WGS-84 geodesic by up to
  about 0.5 % (the radii at home are used for the whole leg): 48° N 10° E to
  0° N 10° E is 5 337 km here, 5 318 km on the ellipsoid.

Tangent-plane frame
-------------------
A point on the ellipsoid is mapped by orthographic projection onto the
tangent plane at home (east-north-up, the up axis dropped); the inverse
intersects the plane's normal line through ``(east, north)`` with the
ellipsoid, in closed form. The projection shrinks radial distances from home
by the factor ``cos(d / R)``, i.e. 3e-5 (0.003 %) at d = 50 km, and leaves
azimuths from home unchanged.

All functions are vectorised: they take floats or array-likes and return
floats for scalar input, ndarrays otherwise. NaN inputs give NaN outputs.

References
----------
.. [1] J. P. Snyder, Map Projections: A Working Manual, U.S. Geological Survey
   Professional Paper 1395. Washington, D.C.: USGPO, 1987,
   doi: 10.3133/pp1395.
"""

from __future__ import annotations

import numpy as np

from planner.physics.numeric import as_float_or_array

#: WGS-84 semi-major axis. [m]
WGS84_A = 6378137.0
#: WGS-84 flattening. [unitless]
WGS84_F = 1.0 / 298.257223563
#: WGS-84 first eccentricity squared. [unitless]
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)
_B2_OVER_A2 = 1.0 - WGS84_E2
#: Mean Earth radius (IUGG, R1 = (2a + b) / 3), for messages and estimates. [m]
EARTH_RADIUS_M = 6371008.8
#: Distance from home within which every straight leg of the frame is within
#: 0.1 % of its great-circle length (sigma^2 / 6 = 1e-3). [km]
FRAME_ERROR_KM = 490.0




def meridian_radius(lat_deg):
    """Meridional radius of curvature of the WGS-84 ellipsoid.

    Parameters
    ----------
    lat_deg : numeric
        Geodetic latitude. [deg]

    Returns
    -------
    radius : numeric
        ``M = a (1 - e²) / (1 - e² sin² φ)^{3/2}``. [m]
    """
    s = np.sin(np.radians(np.asarray(lat_deg, dtype=float)))
    return as_float_or_array(WGS84_A * (1.0 - WGS84_E2) / (1.0 - WGS84_E2 * s * s) ** 1.5)


def normal_radius(lat_deg):
    """Prime-vertical radius of curvature of the WGS-84 ellipsoid,
    ``N = a / sqrt(1 - e² sin² φ)`` [m], at the geodetic latitude ``lat_deg`` [deg]
    (numeric; the kind of the result as in :func:`meridian_radius`)."""
    return as_float_or_array(_prime_vertical(np.sin(np.radians(np.asarray(lat_deg,
                                                                         dtype=float)))))


def _prime_vertical(sin_lat):
    """``N = a / sqrt(1 - e² sin² φ)`` from ``sin φ`` (ndarray). [m]"""
    return WGS84_A / np.sqrt(1.0 - WGS84_E2 * sin_lat * sin_lat)


def _unit(lat_rad, lon_rad):
    """Unit vector (x, y, z) of points on the sphere."""
    c = np.cos(lat_rad)
    return c * np.cos(lon_rad), c * np.sin(lon_rad), np.sin(lat_rad)


def _axes(lat0, lon0):
    """Up, east and north unit vectors (ECEF components) at a point. [rad in]

    The same geodetic latitude gives the ellipsoid's normal and the sphere's
    radial direction, so the tangent-plane and the leg frame share them.
    """
    sp, cp, sl, cl = np.sin(lat0), np.cos(lat0), np.sin(lon0), np.cos(lon0)
    up = (cp * cl, cp * sl, sp)
    east = (-sl, cl, 0.0 * sp)
    north = (-sp * cl, -sp * sl, cp)
    return up, east, north


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _polar(lat_deg, lon_deg, lat0_deg, lon0_deg):
    """Great-circle angle [rad] and initial bearing [rad] of points from a point 0.

    Computed from unit vectors: ``sigma = atan2(|v x u0|, v . u0)`` and the
    bearing from the east and north components of ``v``; accurate at any range
    (no cancellation near 0 or near the antipode).
    """
    lat0, lon0 = np.radians(lat0_deg), np.radians(lon0_deg)
    v = _unit(np.radians(np.asarray(lat_deg, dtype=float)),
              np.radians(np.asarray(lon_deg, dtype=float)))
    up, east, north = _axes(lat0, lon0)
    ve, vn = _dot(v, east), _dot(v, north)
    sigma = np.arctan2(np.hypot(ve, vn), _dot(v, up))
    return sigma, np.arctan2(ve, vn)


def great_circle(lat1_deg, lon1_deg, lat2_deg, lon2_deg):
    r"""Great-circle angle and initial bearing from points 1 to points 2.

    Parameters
    ----------
    lat1_deg, lon1_deg : numeric
        Start points. [deg]
    lat2_deg, lon2_deg : numeric
        End points. [deg]

    Returns
    -------
    angle_rad : numeric
        Central angle between the points on the sphere, in [0, π]. [rad]
    bearing_deg : numeric
        Initial bearing at the start point, 0 = north, clockwise, in [0, 360).
        [deg]

    Notes
    -----
    The same values as the haversine formula
    :math:`\sigma = 2 \arcsin \sqrt{\sin^2(\Delta\varphi/2) + \cos\varphi_1
    \cos\varphi_2 \sin^2(\Delta\lambda/2)}` ([1]_, eq. 5-3a), computed from unit
    vectors, which keeps full precision at every range.
    """
    sigma, alpha = _polar(lat2_deg, lon2_deg, lat1_deg, lon1_deg)
    return as_float_or_array(sigma), as_float_or_array(np.degrees(alpha) % 360.0)


def great_circle_distance(lat1_deg, lon1_deg, lat2_deg, lon2_deg):
    """Great-circle distance from points 1 to points 2, on the local sphere at point 1.

    Parameters
    ----------
    lat1_deg, lon1_deg, lat2_deg, lon2_deg : numeric
        Start and end points. [deg]

    Returns
    -------
    distance : numeric
        ``sigma * sqrt((M1 cos a)² + (N1 sin a)²)`` with ``a`` the initial
        bearing and ``M1``, ``N1`` the radii of curvature at point 1: the
        length of the leg in the leg frame (:func:`latlon_to_aeqd`) when point 1 is home.
        [m]
    """
    sigma, alpha = _polar(lat2_deg, lon2_deg, lat1_deg, lon1_deg)
    m, n = meridian_radius(lat1_deg), normal_radius(lat1_deg)
    return as_float_or_array(sigma * np.hypot(m * np.cos(alpha), n * np.sin(alpha)))


def latlon_to_aeqd(lat_deg, lon_deg, home_lat_deg, home_lon_deg):
    """East and north of home in the leg frame, in metres, of points given by latitude
    and longitude.

    Parameters
    ----------
    lat_deg, lon_deg : numeric
        Geodetic latitude and longitude of the points (WGS-84). [deg]
    home_lat_deg, home_lon_deg : float
        Home point, the origin of the local frame. [deg]

    Returns
    -------
    east_m, north_m : numeric
        Position in the leg frame (see the module notes). [m]
    """
    sigma, alpha = _polar(lat_deg, lon_deg, home_lat_deg, home_lon_deg)
    m0, n0 = meridian_radius(home_lat_deg), normal_radius(home_lat_deg)
    return (as_float_or_array(n0 * sigma * np.sin(alpha)),
            as_float_or_array(m0 * sigma * np.cos(alpha)))


def aeqd_to_latlon(east_m, north_m, home_lat_deg, home_lon_deg):
    """Latitude and longitude of points given east and north of home in the leg frame
    (inverse of :func:`latlon_to_aeqd`).

    Parameters
    ----------
    east_m, north_m : numeric
        Position in the leg frame. [m]
    home_lat_deg, home_lon_deg : float
        Home point. [deg]

    Returns
    -------
    lat_deg, lon_deg : numeric
        Geodetic latitude and longitude (WGS-84); longitude in [-180, 180].
        [deg]

    Notes
    -----
    With ``x = east / N0`` and ``y = north / M0``, the point is
    ``cos σ û + sin σ (cos α n̂ + sin α ê)`` with ``σ = hypot(x, y)`` and
    ``α = atan2(x, y)``, û, ê, n̂ the up, east and north unit vectors at home.
    """
    lat0, lon0 = np.radians(home_lat_deg), np.radians(home_lon_deg)
    x = np.asarray(east_m, dtype=float) / normal_radius(home_lat_deg)
    y = np.asarray(north_m, dtype=float) / meridian_radius(home_lat_deg)
    sigma = np.hypot(x, y)
    alpha = np.arctan2(x, y)
    up, east, north = _axes(lat0, lon0)
    c, s = np.cos(sigma), np.sin(sigma)
    ce, cn = s * np.sin(alpha), s * np.cos(alpha)
    px, py, pz = (c * up[k] + ce * east[k] + cn * north[k] for k in range(3))
    lat = np.degrees(np.arctan2(pz, np.hypot(px, py)))
    lon = np.degrees(np.arctan2(py, px))
    return as_float_or_array(lat), as_float_or_array(lon)


def frame_error(lat1_deg, lon1_deg, lat2_deg, lon2_deg, home_lat_deg, home_lon_deg):
    """Relative length error of a straight leg in the leg frame about home.

    Parameters
    ----------
    lat1_deg, lon1_deg, lat2_deg, lon2_deg : numeric
        Start and end of the leg. [deg]
    home_lat_deg, home_lon_deg : float
        Home point. [deg]

    Returns
    -------
    error : numeric
        ``|chord - sigma| / sigma``: the straight line between the two points in
        the frame (on the unit sphere, before the scaling by the radii at home)
        against their great-circle angle ``sigma``; 0 for a leg of zero length.
        0 for a leg through home, about ``r² / (6 R²)`` for a short leg at
        ``r`` from home, 1e-3 at :data:`FRAME_ERROR_KM`. [unitless]
    """
    s1, a1 = _polar(lat1_deg, lon1_deg, home_lat_deg, home_lon_deg)
    s2, a2 = _polar(lat2_deg, lon2_deg, home_lat_deg, home_lon_deg)
    chord = np.hypot(s2 * np.sin(a2) - s1 * np.sin(a1), s2 * np.cos(a2) - s1 * np.cos(a1))
    sigma, _ = _polar(lat2_deg, lon2_deg, lat1_deg, lon1_deg)
    with np.errstate(invalid="ignore", divide="ignore"):
        err = np.where(sigma > 0, np.abs(chord - sigma) / np.where(sigma > 0, sigma, 1.0), 0.0)
    return as_float_or_array(np.where(np.isnan(sigma), np.nan, err))


# --------------------------------------------------------------------------
# Tangent-plane frame

def _ecef(lat_rad, lon_rad):
    """Earth-centred Earth-fixed coordinates of points on the ellipsoid. [m]"""
    s = np.sin(lat_rad)
    n = _prime_vertical(s)
    c = np.cos(lat_rad)
    return n * c * np.cos(lon_rad), n * c * np.sin(lon_rad), n * _B2_OVER_A2 * s


def latlon_to_en(lat_deg, lon_deg, home_lat_deg, home_lon_deg):
    """East and north of home, in metres, of points given by latitude and longitude.

    Parameters
    ----------
    lat_deg, lon_deg, home_lat_deg, home_lon_deg
        As in :func:`latlon_to_aeqd`. [deg]

    Returns
    -------
    east_m, north_m : numeric
        Position in the local tangent plane at home. [m]
    """
    lat0, lon0 = np.radians(home_lat_deg), np.radians(home_lon_deg)
    x0, y0, z0 = _ecef(lat0, lon0)
    x, y, z = _ecef(np.radians(np.asarray(lat_deg, dtype=float)),
                    np.radians(np.asarray(lon_deg, dtype=float)))
    dx, dy, dz = x - x0, y - y0, z - z0
    _, (ex, ey, _), (nx, ny, nz) = _axes(lat0, lon0)
    return as_float_or_array(ex * dx + ey * dy), as_float_or_array(nx * dx + ny * dy + nz * dz)


def en_to_latlon(east_m, north_m, home_lat_deg, home_lon_deg):
    """Latitude and longitude of points given east and north of home (inverse of
    :func:`latlon_to_en`).

    Parameters
    ----------
    east_m, north_m : numeric
        Position in the local tangent plane at home. [m]
    home_lat_deg, home_lon_deg : float
        Home point. [deg]

    Returns
    -------
    lat_deg, lon_deg : numeric
        Geodetic latitude and longitude (WGS-84). [deg]

    Notes
    -----
    The point ``Q = P0 + east·ê + north·n̂`` is moved along the local up
    vector ``û`` to the ellipsoid: ``A t² + B t + C = 0`` with the ellipsoid
    written as ``(x² + y²)/a² + z²/b² = 1``; the root nearest zero is taken in
    the cancellation-free form ``t = -2C / (B + sqrt(B² - 4AC))``. On the
    ellipsoid the geodetic latitude is exactly ``atan2(z, (1 - e²) p)``.
    """
    lat0, lon0 = np.radians(home_lat_deg), np.radians(home_lon_deg)
    x0, y0, z0 = _ecef(lat0, lon0)
    (ux, uy, uz), (ex, ey, _), (nx, ny, nz) = _axes(lat0, lon0)
    e = np.asarray(east_m, dtype=float)
    n = np.asarray(north_m, dtype=float)
    qx = x0 + ex * e + nx * n
    qy = y0 + ey * e + ny * n
    qz = z0 + nz * n
    a2, b2 = WGS84_A**2, WGS84_A**2 * _B2_OVER_A2
    qa = (ux * ux + uy * uy) / a2 + uz * uz / b2
    qb = 2.0 * ((qx * ux + qy * uy) / a2 + qz * uz / b2)
    qc = (qx * qx + qy * qy) / a2 + qz * qz / b2 - 1.0
    t = -2.0 * qc / (qb + np.sqrt(qb * qb - 4.0 * qa * qc))
    x, y, z = qx + t * ux, qy + t * uy, qz + t * uz
    lat = np.degrees(np.arctan2(z, _B2_OVER_A2 * np.hypot(x, y)))
    lon = np.degrees(np.arctan2(y, x))
    return as_float_or_array(lat), as_float_or_array(lon)
