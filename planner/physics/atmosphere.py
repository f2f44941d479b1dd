r"""International Standard Atmosphere (troposphere): temperature, pressure, density.

Layer 1 of the planner: pure, vectorised functions in SI units. Every function takes a
float, a list, an ndarray or a pandas Series (broadcasting) and returns the same kind
(float for scalars, ndarray, or a Series carrying the input's index). NaN samples
propagate; physically impossible parameters and inputs outside the model's validity range
raise :class:`planner.errors.ModelError` naming the parameter and the valid range.

The module also holds the gravity constant :data:`G` used by every power model.

References
----------
.. [1] U.S. Standard Atmosphere, 1976. NOAA, NASA and USAF, Washington, D.C.,
   Oct. 1976, NOAA-S/T 76-1562.
.. [2] ISO 2533:1975, Standard Atmosphere. Geneva: International Organization for
   Standardization, 1975.
"""

from __future__ import annotations

import numpy as np

from planner.errors import ModelError
from planner.physics.numeric import like_inputs, require
from planner.physics.units import ZERO_CELSIUS_K

G = 9.80665
"""Standard acceleration of gravity [m s⁻²] ([1]_, Table 2)."""

T0 = 288.15
"""ISA sea-level temperature [K]."""
P0 = 101325.0
"""ISA sea-level pressure [Pa]."""
RHO0 = 1.225
"""ISA sea-level density [kg m⁻³]."""
LAPSE_RATE = 0.0065
"""ISA tropospheric temperature lapse rate, temperature falls with height [K m⁻¹]."""
R_AIR = 287.05287
"""Specific gas constant of dry air [J kg⁻¹ K⁻¹]."""
ALTITUDE_RANGE_M = (-500.0, 11000.0)
"""Validity range of the tropospheric model (geopotential altitude) [m]."""
MAX_WIND_MS = 100.0
"""Strongest wind the planner takes [m s⁻¹]: above any sustained surface wind on record
(the strongest tropical cyclones reach some 85–90 m/s); larger values only overflow."""

_EXPONENT = G / (R_AIR * LAPSE_RATE)  # 5.25588, barometric exponent [unitless]


def _check_altitude(altitude_m):
    lo, hi = ALTITUDE_RANGE_M
    arr = np.asarray(altitude_m, dtype=float)
    bad = (arr < lo) | (arr > hi)
    if np.any(bad):
        first = arr[bad].flat[0] if arr.ndim else float(arr)
        raise ModelError(
            f"altitude_m must be in range [{lo:g} m, {hi:g} m] (ISA troposphere), "
            f"got {first:g}"
        )
    return arr


def _isa_temperature(h):
    """:math:`T = T_0 - L h` (ndarray in m, out in K)."""
    return T0 - LAPSE_RATE * h


def _isa_pressure(h):
    """:math:`p = p_0 (T/T_0)^{g_0/(R L)}` (ndarray in m, out in Pa)."""
    return P0 * (_isa_temperature(h) / T0) ** _EXPONENT


# --------------------------------------------------------------------------------------
# Public functions
# --------------------------------------------------------------------------------------
def temperature(altitude_m):
    r"""
    ISA air temperature in the troposphere.

    Parameters
    ----------
    altitude_m : numeric
        Geopotential altitude above mean sea level, in [-500, 11000]. [m]

    Returns
    -------
    temperature : numeric
        Air temperature. [K]

    Raises
    ------
    ModelError
        If an altitude lies outside [-500 m, 11000 m].

    Notes
    -----
    .. math:: T = T_0 - L h, \quad T_0 = 288.15\ \mathrm{K},\ L = 0.0065\ \mathrm{K\,m^{-1}}

    Linear lapse of the first layer of [1]_ (Table 4) and [2]_.
    """
    return like_inputs(_isa_temperature(_check_altitude(altitude_m)), altitude_m)


def pressure(altitude_m):
    r"""
    ISA static pressure in the troposphere.

    Parameters
    ----------
    altitude_m : numeric
        As in :func:`temperature` (which raises the same error). [m]

    Returns
    -------
    pressure : numeric
        Static pressure. [Pa]

    Notes
    -----
    .. math:: p = p_0 \left(\frac{T_0 - L h}{T_0}\right)^{g_0 / (R L)}

    Hydrostatic equation integrated over a layer of constant lapse rate, [1]_ eq. (33a),
    with :math:`p_0` = 101325 Pa, :math:`g_0` = 9.80665 m s⁻², :math:`R` = 287.05287
    J kg⁻¹ K⁻¹ (exponent 5.25588).
    """
    return like_inputs(_isa_pressure(_check_altitude(altitude_m)), altitude_m)


def density(altitude_m=0.0, temperature_c=None, pressure_pa=None):
    r"""
    Air density from the ISA, optionally with measured temperature and pressure.

    Parameters
    ----------
    altitude_m : numeric, default 0
        Geopotential altitude above mean sea level, in [-500, 11000]. Not used when both
        ``temperature_c`` and ``pressure_pa`` are given. [m]
    temperature_c : numeric, optional
        Measured outside air temperature; None uses the ISA temperature at
        ``altitude_m``. [°C]
    pressure_pa : numeric, optional
        Measured static (barometric) pressure; None uses the ISA pressure at
        ``altitude_m``. [Pa]

    Returns
    -------
    density : numeric
        Air density. [kg m⁻³]

    Raises
    ------
    ModelError
        If an altitude that is used lies outside [-500 m, 11000 m], a temperature is at
        or below absolute zero, or a pressure is not positive.

    Notes
    -----
    Ideal gas law for dry air, [1]_ eq. (42):

    .. math:: \rho = \frac{p}{R T}

    with four cases:

    - neither given: ISA :math:`p(h)` and :math:`T(h)` (1.225 kg m⁻³ at sea level);
    - temperature only: ISA pressure at ``altitude_m`` and the given temperature (a hot
      or cold day at a known altitude);
    - pressure and temperature: both measured, altitude ignored;
    - pressure only: given pressure with the ISA temperature at ``altitude_m``.

    Humidity is neglected (moist air is up to about 1 % lighter at 30 °C).
    ``altitude_m`` is geopotential; the geometric altitude of the 1976 tables differs by
    less than 0.2 % in density below 11 km.

    Examples
    --------
    >>> round(density(0.0, temperature_c=20.0), 4)
    1.2041
    """
    if pressure_pa is not None:
        p = require(pressure_pa, "pressure_pa", gt=0.0, unit="Pa")
    if temperature_c is not None:
        t = require(temperature_c, "temperature_c", gt=-ZERO_CELSIUS_K, unit="°C") + ZERO_CELSIUS_K
    if pressure_pa is None or temperature_c is None:
        h = _check_altitude(altitude_m)
        if pressure_pa is None:
            p = _isa_pressure(h)
        if temperature_c is None:
            t = _isa_temperature(h)
        used = [altitude_m, temperature_c, pressure_pa]
    else:
        used = [temperature_c, pressure_pa]
    rho = p / (R_AIR * t)
    return like_inputs(rho, *[u for u in used if u is not None])


def site_density(altitude_amsl_m, site_altitude_m=0.0, site_temperature_c=None,
                 site_pressure_pa=None):
    r"""
    Air density at altitude above a site whose temperature and pressure may be known.

    Parameters
    ----------
    altitude_amsl_m : numeric
        Altitude above mean sea level. [m]
    site_altitude_m : float, default 0
        Altitude of the site (home). [m]
    site_temperature_c : float, optional
        Air temperature at the site; None = ISA. [°C]
    site_pressure_pa : float, optional
        Static pressure at the site; None = ISA. [Pa]

    Returns
    -------
    density : numeric
        [kg m⁻³]

    Notes
    -----
    A site temperature shifts the ISA profile (the lapse rate is kept):
    :math:`T(h) = T_{site} - L (h - h_{site})`. A site pressure is carried to altitude
    with the ISA pressure ratio, :math:`p(h) = p_{site}\, p_{ISA}(h)/p_{ISA}(h_{site})`.
    The density is then :func:`density` of that temperature and pressure.
    """
    h = np.asarray(altitude_amsl_m, dtype=float)
    t = None
    if site_temperature_c is not None:
        t = site_temperature_c - LAPSE_RATE * (h - site_altitude_m)
    p = None
    if site_pressure_pa is not None:
        p = site_pressure_pa * (pressure(h) / pressure(site_altitude_m))
        if t is None:
            t = temperature(h) - ZERO_CELSIUS_K
    return like_inputs(density(h, temperature_c=t, pressure_pa=p), altitude_amsl_m)


def pressure_altitude(pressure_pa):
    r"""
    ISA altitude of a static pressure (the inverse of :func:`pressure`), clipped to the
    model's range.

    .. math:: h = \frac{T_0}{L}\left(1 - (p/p_0)^{R L/g}\right)

    Parameters
    ----------
    pressure_pa : numeric
        Static pressure, > 0. [Pa]

    Returns
    -------
    altitude : numeric
        Geopotential altitude in [-500, 11000]. [m]
    """
    p = require(pressure_pa, "pressure_pa", gt=0.0, unit="Pa")
    h = T0 / LAPSE_RATE * (1.0 - (p / P0) ** (1.0 / _EXPONENT))
    return like_inputs(np.clip(h, ALTITUDE_RANGE_M[0], ALTITUDE_RANGE_M[1]), pressure_pa)
