r"""Fixed-wing power required from the parabolic drag polar ([UAV23] eq. 2–6).

Layer 1: pure, vectorised functions in SI units (m, s, kg, N, W, kg m⁻³, angles in
radians). Every function takes floats, ndarrays or pandas Series (broadcasting) and returns
the same kind; NaN samples propagate; physically impossible parameters raise
:class:`planner.errors.ModelError` naming the parameter.

The power model is that of [UAV23] eq. 2–6: :math:`P_{tot} = P_S + P_R/\eta`,
:math:`P_R = A V^3 + B/V + W\dot h`.

References
----------
.. [1] J. D. Anderson, Aircraft Performance and Design. Boston, MA, USA: McGraw-Hill,
   1999: ch. 2 (parabolic drag polar), ch. 5 (power required, minimum-power and
   maximum-range speeds), ch. 6 (level coordinated turn).
"""

from __future__ import annotations

import numpy as np

from planner.physics.atmosphere import G
from planner.physics.numeric import like_inputs, require


def induced_drag_factor(aspect_ratio, oswald_efficiency):
    r"""
    Induced-drag factor of the parabolic polar.

    Parameters
    ----------
    aspect_ratio : numeric
        Wing aspect ratio :math:`AR = b^2 / S`. [unitless]
    oswald_efficiency : numeric
        Oswald span efficiency, in (0, 1]. [unitless]

    Returns
    -------
    k : numeric
        Induced-drag factor :math:`K` in :math:`C_D = C_{D0} + K C_L^2`. [unitless]

    Notes
    -----
    .. math:: K = \frac{1}{\pi e AR}

    Parabolic drag polar, [1]_ ch. 2; [UAV23] eq. 3–4 use the same polar.
    """
    ar = require(aspect_ratio, "aspect_ratio", gt=0.0)
    e = require(oswald_efficiency, "oswald_efficiency", gt=0.0, le=1.0)
    return like_inputs(1.0 / (np.pi * e * ar), aspect_ratio, oswald_efficiency)


def polar_coefficients(air_density, wing_area, cd0, k, weight, load_factor=1.0):
    r"""
    Coefficients A and B of the power-required curve :math:`A V^3 + B / V`.

    Parameters
    ----------
    air_density : numeric
        Air density, see :func:`planner.physics.atmosphere.density`. [kg m⁻³]
    wing_area : numeric
        Wing reference area. [m²]
    cd0 : numeric
        Zero-lift (parasite) drag coefficient. [unitless]
    k : numeric
        Induced-drag factor, see :func:`induced_drag_factor`. [unitless]
    weight : numeric
        Aircraft weight :math:`W = m g`. [N]
    load_factor : numeric, default 1
        Lift over weight, :math:`n \ge 1` (1 in level flight, see
        :func:`bank_load_factor` for a turn). [unitless]

    Returns
    -------
    a : numeric
        Parasite coefficient :math:`A`. [kg m⁻¹] (W per (m/s)³)
    b : numeric
        Induced coefficient :math:`B`. [kg m³ s⁻⁴] (W·m/s)

    Notes
    -----
    .. math::

        A = \tfrac12 \rho S C_{D0}, \qquad B = \frac{2 K (n W)^2}{\rho S}

    [UAV23] eq. 3–4, extended with the load factor :math:`n` (lift = :math:`nW`).
    """
    rho = require(air_density, "air_density", gt=0.0, unit="kg/m³")
    s = require(wing_area, "wing_area", gt=0.0, unit="m²")
    c = require(cd0, "cd0", ge=0.0)
    kk = require(k, "k", ge=0.0)
    w = require(weight, "weight", gt=0.0, unit="N")
    n = require(load_factor, "load_factor", ge=1.0)
    a = 0.5 * rho * s * c
    b = 2.0 * kk * (n * w) ** 2 / (rho * s)
    args = (air_density, wing_area, cd0, k, weight, load_factor)
    return like_inputs(a, *args), like_inputs(b, *args)


def required_power(airspeed, air_density, mass, wing_area, cd0, k, climb_rate=0.0,
                   load_factor=1.0, gravity=G):
    r"""
    Mechanical (propeller output) power required by a fixed-wing aircraft.

    Parameters
    ----------
    airspeed : numeric
        True airspeed, ≥ 0 (0 gives an infinite power: a wing cannot fly at zero
        airspeed). [m s⁻¹]
    air_density : numeric
        Air density. [kg m⁻³]
    mass : numeric
        All-up mass. [kg]
    wing_area : numeric
        Wing reference area. [m²]
    cd0 : numeric
        Zero-lift drag coefficient. [unitless]
    k : numeric
        Induced-drag factor. [unitless]
    climb_rate : numeric, default 0
        Rate of climb :math:`\dot h`, up positive. [m s⁻¹]
    load_factor : numeric, default 1
        Lift over weight (turn), ≥ 1. [unitless]
    gravity : float, default 9.80665
        Acceleration of gravity. [m s⁻²]

    Returns
    -------
    power : numeric
        Power required :math:`P_R`. [W] Negative in a descent steeper than the glide at
        that airspeed: gravity then supplies more than the drag takes (that is physics;
        :func:`battery_power` applies the motor-off floor).

    Raises
    ------
    ModelError
        If an airspeed is negative or a parameter is physically impossible.

    Notes
    -----
    .. math:: P_R = A V^3 + \frac{B}{V} + W \dot h

    [UAV23] eq. 2, with :math:`A`, :math:`B` from :func:`polar_coefficients`.
    Small flight-path angles: lift is taken as :math:`nW`, not :math:`nW\cos\gamma`.
    """
    v = require(airspeed, "airspeed", ge=0.0, unit="m/s")
    m = require(mass, "mass", gt=0.0, unit="kg")
    weight = m * gravity
    a, b = polar_coefficients(np.asarray(air_density, dtype=float), wing_area, cd0, k,
                              weight, load_factor)
    hdot = np.asarray(climb_rate, dtype=float)
    with np.errstate(divide="ignore"):
        induced = b / v  # +inf at V = 0 (b > 0); 0/0 only for K = 0 at V = 0
    induced = np.where((v == 0.0) & (b == 0.0), 0.0, induced)
    p = a * v**3 + induced + weight * hdot
    return like_inputs(p, airspeed, air_density, mass, wing_area, cd0, k, climb_rate,
                    load_factor)


def bank_angle(airspeed, turn_radius, gravity=G):
    r"""
    Bank angle of a level coordinated turn.

    Parameters
    ----------
    airspeed : numeric
        True airspeed. [m s⁻¹]
    turn_radius : numeric
        Turn radius, > 0. [m]
    gravity : float, default 9.80665
        Acceleration of gravity. [m s⁻²]

    Returns
    -------
    bank : numeric
        Bank angle :math:`\phi`. [rad]

    Notes
    -----
    .. math:: \tan\phi = \frac{V^2}{g r}

    [1]_, ch. 6 (level turn: :math:`L\cos\phi = W`, :math:`L\sin\phi = m V^2 / r`).
    """
    return like_inputs(np.arctan(_turn_ratio(airspeed, turn_radius, gravity)), airspeed,
                       turn_radius)


def _turn_ratio(airspeed, turn_radius, gravity):
    """:math:`\\tan\\phi = V^2/(g r)` of a level coordinated turn, ndarray. [unitless]"""
    v = np.asarray(airspeed, dtype=float)
    r = require(turn_radius, "turn_radius", gt=0.0, unit="m")
    return v**2 / (gravity * r)


def bank_load_factor(airspeed, turn_radius, gravity=G):
    r"""
    Load factor of a level coordinated turn.

    Parameters
    ----------
    airspeed, turn_radius, gravity
        As in :func:`bank_angle`. [m s⁻¹], [m], [m s⁻²]

    Returns
    -------
    load_factor : numeric
        :math:`n = L / W = 1/\cos\phi`. [unitless]

    Notes
    -----
    .. math:: n = \sqrt{1 + \left(\frac{V^2}{g r}\right)^2}

    [1]_, ch. 6. A 45° bank (:math:`V^2 = g r`) gives :math:`n = \sqrt2`.
    """
    return like_inputs(np.sqrt(1.0 + _turn_ratio(airspeed, turn_radius, gravity) ** 2),
                       airspeed, turn_radius)


def battery_power(required_power, efficiency, system_power=0.0):
    r"""
    Electrical power drawn from the battery.

    Parameters
    ----------
    required_power : numeric
        Mechanical power required :math:`P_R`, see :func:`required_power`. [W]
    efficiency : numeric
        Total propulsion efficiency :math:`\eta` (battery to useful thrust power), in
        (0, 1]. [unitless]
    system_power : numeric, default 0
        Constant electrical load of avionics and payload :math:`P_S`, ≥ 0. [W]

    Returns
    -------
    power : numeric
        Battery (discharge) power, ≥ :math:`P_S`. [W]

    Notes
    -----
    .. math:: P = \frac{\max(P_R, 0)}{\eta} + P_S

    [UAV23] eq. 2–6, :math:`P_{tot} = P_S + P_R / \eta`, with a floor: the propeller does not
    regenerate. When :math:`P_R < 0` (a descent steeper than the glide at that airspeed)
    the motor is off, the aircraft glides and the extra potential energy goes into drag
    (speed brakes, a steeper path), so only :math:`P_S` is drawn.
    """
    p = np.asarray(required_power, dtype=float)
    eta = require(efficiency, "efficiency", gt=0.0, le=1.0)
    ps = require(system_power, "system_power", ge=0.0, unit="W")
    out = np.maximum(p, 0.0) / eta + ps
    return like_inputs(out, required_power, efficiency, system_power)


def min_power_speed(air_density, mass, wing_area, cd0, k, load_factor=1.0, gravity=G):
    r"""
    Airspeed of minimum power required (maximum endurance) in still air.

    Parameters
    ----------
    air_density, mass, wing_area, k, load_factor, gravity
        As in :func:`required_power`. [kg m⁻³], [kg], [m²], [unitless], [unitless],
        [m s⁻²]
    cd0 : numeric
        Zero-lift drag coefficient, > 0. [unitless]

    Returns
    -------
    speed : numeric
        :math:`V_{mp}`. [m s⁻¹]

    Notes
    -----
    .. math:: V_{mp} = \left(\frac{B}{3A}\right)^{1/4}

    From :math:`dP_R/dV = 3AV^2 - B/V^2 = 0` with the polar of [UAV23] eq. 2;
    [1]_, ch. 5. Equivalent to :math:`C_L = \sqrt{3 C_{D0}/K}`.
    """
    a, b = _speed_polar(air_density, mass, wing_area, cd0, k, load_factor, gravity)
    return like_inputs((b / (3.0 * a)) ** 0.25, air_density, mass, wing_area, cd0, k,
                    load_factor)


def max_range_speed(air_density, mass, wing_area, cd0, k, load_factor=1.0, gravity=G):
    r"""
    Airspeed of maximum range (minimum drag, minimum :math:`P_R/V`) in still air.

    Parameters
    ----------
    air_density, mass, wing_area, cd0, k, load_factor, gravity
        As in :func:`min_power_speed`. [kg m⁻³], [kg], [m²], [unitless], [unitless],
        [unitless], [m s⁻²]

    Returns
    -------
    speed : numeric
        :math:`V_{mr}`, a factor :math:`3^{1/4} \approx 1.316` above
        :func:`min_power_speed`. [m s⁻¹]

    Notes
    -----
    .. math:: V_{mr} = \left(\frac{B}{A}\right)^{1/4}

    From :math:`d(P_R/V)/dV = 2AV - 2B/V^3 = 0` with [UAV23] eq. 2; [1]_, ch. 5. With a
    constant efficiency and :math:`P_S = 0` this also maximises range per battery energy;
    for wind or a system load use :func:`planner.physics.power.speeds.best_speeds`.
    """
    a, b = _speed_polar(air_density, mass, wing_area, cd0, k, load_factor, gravity)
    return like_inputs((b / a) ** 0.25, air_density, mass, wing_area, cd0, k, load_factor)


def _speed_polar(air_density, mass, wing_area, cd0, k, load_factor, gravity):
    """A and B of :func:`polar_coefficients` for the best-speed formulas (C_D0 > 0)."""
    m = require(mass, "mass", gt=0.0, unit="kg")
    require(cd0, "cd0", gt=0.0)
    return polar_coefficients(np.asarray(air_density, dtype=float), wing_area, cd0, k,
                              m * gravity, load_factor)


def min_loiter_radius(loiter_airspeed_ms: float, stall_speed_ms: float | None = None,
                      bank_max_deg: float = 60.0) -> float:
    r"""
    Tightest level loiter circle a fixed-wing can fly at its loiter airspeed. [m]

    Parameters
    ----------
    loiter_airspeed_ms : float
        Airspeed of the loiter. [m/s]
    stall_speed_ms : float, optional
        Wings-level stall speed; the stall speed in a turn rises as :math:`\sqrt n`. [m/s]
    bank_max_deg : float, default 60
        Steepest bank allowed. [deg]

    Returns
    -------
    radius : float
        ``inf`` when the loiter airspeed is not above the stall speed. [m]

    Notes
    -----
    .. math:: r_{min} = \frac{V^2}{g \tan\phi_{max}}, \qquad
              \cos\phi_{max} = \max\left(\cos\phi_{bank}, (V_s/V)^2\right)

    Level coordinated turn (Anderson, *Aircraft Performance and Design*, ch. 6): the
    load factor is :math:`n = 1/\cos\phi` and must stay below :math:`(V/V_s)^2` so that
    the wing does not stall in the turn.
    """
    cos_max = np.cos(np.radians(bank_max_deg))
    if stall_speed_ms is not None:
        cos_max = max(cos_max, (stall_speed_ms / loiter_airspeed_ms) ** 2)
    if cos_max >= 1.0:
        return float("inf")
    tan_max = np.sqrt(1.0 - cos_max**2) / cos_max
    return float(loiter_airspeed_ms**2 / (G * tan_max))
