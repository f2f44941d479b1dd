r"""Propeller shaft power in axial flight: actuator-disc momentum theory with profile loss.

The power a propeller absorbs to give thrust :math:`T` at airspeed :math:`V` is split, as
for a rotor in axial climb ([2]_ §2.7, §3.3), into the useful power, the induced power
and the profile power of the blades:

.. math::

    P_{shaft} = T\,V + \kappa\,T\,v_i + P_0, \qquad
    v_i = -\frac{V}{2} + \sqrt{\frac{V^2}{4} + \frac{T}{2\rho A}}

with :math:`A` the disc area of the propellers (thrust shared equally), :math:`v_i` the
induced velocity of the actuator disc in axial flow ([1]_ §6.3, [2]_ eq. 2.124), the
induced-power factor :math:`\kappa \ge 1` (non-uniform inflow, swirl, tip losses) and the
profile power :math:`P_0` (held constant: it scales with the cube of the rotational speed,
which changes little between the cruise, climb and loiter of one aircraft). The
propulsive efficiency is :math:`\eta_p = T V / P_{shaft}`; with :math:`\kappa = 1`,
:math:`P_0 = 0` it is the ideal (Froude) efficiency
:math:`2 / (1 + \sqrt{1 + T / (\tfrac12 \rho V^2 A)})` ([1]_ eq. 6.13).

In propeller coefficients (:math:`J = V/(nD)`, :math:`C_T = T/(\rho n^2 D^4)`,
:math:`C_P = P/(\rho n^3 D^5)`, :math:`n` in rev/s) the same model is

.. math::

    C_P = C_T J + \kappa\,C_T \lambda_i + C_{P0}, \qquad
    \lambda_i = \frac{v_i}{nD} = -\frac{J}{2} + \sqrt{\frac{J^2}{4} + \frac{2 C_T}{\pi}}

(:func:`power_coefficient`), linear in :math:`\kappa` and :math:`C_{P0}`: what
``benchmarks/bench_propeller_uiuc.py`` fits to the UIUC propeller database's wind-tunnel
sweeps to check the form on real propellers.

Layer 1: pure, vectorised, SI units. A non-positive thrust (a glide, the motor off) needs
no shaft power: 0 W.

References
----------
.. [1] B. W. McCormick, Aerodynamics, Aeronautics, and Flight Mechanics, 2nd ed. New
   York, NY, USA: Wiley, 1995, ch. 6 (momentum theory of the propeller, ideal efficiency).
.. [2] J. G. Leishman, Principles of Helicopter Aerodynamics, 2nd ed. Cambridge, U.K.:
   Cambridge Univ. Press, 2006, §2.7 (axial climb), §3.3 (power coefficient: induced
   and profile parts).
"""

from __future__ import annotations

import numpy as np

from planner.physics.numeric import like_inputs, require


def induced_velocity(thrust, airspeed, air_density, disc_area):
    r"""
    Induced velocity of an actuator disc in axial flow.

    Parameters
    ----------
    thrust : numeric
        Thrust of the disc(s) of total area ``disc_area``; values ≤ 0 give 0. [N]
    airspeed : numeric
        Axial inflow (true airspeed). [m/s]
    air_density : numeric
        [kg m⁻³]
    disc_area : numeric
        Total disc area. [m²]

    Returns
    -------
    v_i : numeric
        [m/s]

    Notes
    -----
    .. math:: v_i = -\frac{V}{2} + \sqrt{\frac{V^2}{4} + \frac{T}{2\rho A}}

    [1]_ §6.3, [2]_ eq. 2.124; at :math:`V = 0` the hover value :math:`\sqrt{T/(2\rho A)}`.
    """
    rho = require(air_density, "air_density", gt=0.0)
    area = require(disc_area, "disc_area", gt=0.0)
    t = np.maximum(np.asarray(thrust, float), 0.0)
    v = np.asarray(airspeed, float)
    out = -0.5 * v + np.sqrt(0.25 * v * v + t / (2.0 * rho * area))
    return like_inputs(out, thrust, airspeed, air_density, disc_area)


def shaft_power(thrust, airspeed, air_density, diameter, count=1, induced_factor=1.0,
                profile_power=0.0):
    r"""
    Shaft power of the propellers giving ``thrust`` at ``airspeed`` (module notes).

    Parameters
    ----------
    thrust : numeric
        Total thrust; ≤ 0 needs no power. [N]
    airspeed : numeric
        True airspeed. [m/s]
    air_density : numeric
        [kg m⁻³]
    diameter : float
        Propeller diameter. [m]
    count : int
        Propellers sharing the thrust.
    induced_factor : float
        :math:`\kappa \ge 1`. [unitless]
    profile_power : float
        :math:`P_0`, all propellers together. [W]

    Returns
    -------
    power : numeric
        [W]
    """
    d = require(diameter, "propeller_diameter_m", gt=0.0)
    n = require(count, "propellers", ge=1)
    kappa = require(induced_factor, "propeller_induced_factor", ge=1.0)
    p0 = require(profile_power, "propeller_profile_power_w", ge=0.0)
    area = n * np.pi * d * d / 4.0
    t = np.asarray(thrust, float)
    v = np.asarray(airspeed, float)
    vi = induced_velocity(t, v, air_density, area)
    out = np.where(t > 0.0, t * v + kappa * t * vi + p0, 0.0)
    return like_inputs(out, thrust, airspeed, air_density)


def propulsive_efficiency(thrust, airspeed, air_density, diameter, count=1,
                          induced_factor=1.0, profile_power=0.0):
    r"""
    :math:`\eta_p = T V / P_{shaft}` (module notes); NaN where no thrust. [unitless]
    """
    p = np.asarray(shaft_power(thrust, airspeed, air_density, diameter, count,
                               induced_factor, profile_power), float)
    t = np.asarray(thrust, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where((t > 0.0) & (p > 0.0), t * np.asarray(airspeed, float) / p, np.nan)
    return like_inputs(out, thrust, airspeed, air_density)


def inflow_ratio(advance_ratio, thrust_coefficient):
    r"""
    :math:`\lambda_i = v_i/(nD) = -J/2 + \sqrt{J^2/4 + 2 C_T/\pi}` (module notes); a
    non-positive :math:`C_T` gives 0. [unitless]
    """
    j = np.asarray(advance_ratio, float)
    ct = np.maximum(np.asarray(thrust_coefficient, float), 0.0)
    return like_inputs(-0.5 * j + np.sqrt(0.25 * j * j + 2.0 * ct / np.pi), advance_ratio,
                    thrust_coefficient)


def power_coefficient(advance_ratio, thrust_coefficient, induced_factor=1.0,
                      profile_cp=0.0):
    r"""
    :math:`C_P = C_T J + \kappa C_T \lambda_i + C_{P0}` (module notes). [unitless]
    """
    j = np.asarray(advance_ratio, float)
    ct = np.asarray(thrust_coefficient, float)
    out = ct * j + induced_factor * ct * inflow_ratio(j, ct) + profile_cp
    return like_inputs(out, advance_ratio, thrust_coefficient)
