r"""The energy-rate balance of a fixed-wing aircraft in unsteady flight.

Thrust power goes into drag and into the aircraft's kinetic and potential energy:

.. math::

    \eta\,(P - P_S) = D V + m g \dot h + m V \dot V, \qquad
    D V = \tfrac12 \rho V^3 S\, C_{D0} + \frac{2 K (n m g)^2}{\rho S V}

with :math:`P` the battery power, :math:`\eta` the propulsive efficiency (battery to
thrust power), :math:`P_S` the system load, :math:`V` the true airspeed, :math:`\dot V`
its rate of change, :math:`\dot h` the climb rate and the parabolic polar
:math:`C_D = C_{D0} + K C_L^2`. This is [UAV23] eq. 2 with the acceleration term kept: the
seed drops :math:`m V \dot V` for planning (steady flight), identification from unsteady
flight (throttle pulses, glides, speed changes) cannot ([1]_ eq. "total power"). In a
glide (no thrust) the left side is zero and the drag follows from the energy rate alone,
without :math:`\eta` (:func:`glide_drag_coefficient`). Lift is taken as :math:`n m g`
(small flight-path angles, as [UAV23] eq. 2).

The balance is linear in :math:`\eta`, :math:`C_{D0}` and :math:`K` once :math:`P_S` is
known: :func:`polar_power_terms` gives the two drag regressors.

Layer 1: pure, vectorised functions in SI units; NaN samples propagate.

References
----------
.. [1] P. Sharpe and R. J. Hansman, "Physics-Informed Regression and Uncertainty
   Quantification of Aircraft Performance from Minimal Flight Data," AIAA SciTech Forum,
   2024: the total-power balance
   :math:`m U \dot U + m g \dot h + U D - V i\,\eta_{propulsive} + P_{avionics} = 0`.
"""

from __future__ import annotations

import math

import numpy as np

from planner.errors import ModelError
from planner.physics.atmosphere import G

__all__ = ["energy_rate", "glide_drag_coefficient", "lift_coefficient", "lift_power",
           "polar_power_terms", "shifted_polar", "thrust_power"]


def _positive(value, name: str) -> np.ndarray:
    arr = np.asarray(value, float)
    if np.any(arr <= 0):
        raise ModelError(f"{name} must be > 0, got {arr[arr <= 0].flat[0]:g} (physically "
                         "impossible)")
    return arr


def energy_rate(mass, airspeed, acceleration, climb_rate, gravity=G):
    r"""
    Rate of change of the aircraft's kinetic and potential energy.

    Parameters
    ----------
    mass : numeric
        All-up mass, > 0. [kg]
    airspeed : numeric
        True airspeed :math:`V`. [m/s]
    acceleration : numeric
        Its rate of change :math:`\dot V`. [m/s²]
    climb_rate : numeric
        :math:`\dot h`, up positive. [m/s]
    gravity : float
        [m/s²]

    Returns
    -------
    power : ndarray
        :math:`m V \dot V + m g \dot h`. [W]

    Notes
    -----
    The last two terms of [UAV23] eq. 2 with the acceleration kept ([1]_).
    """
    m = _positive(mass, "mass")
    return m * np.asarray(airspeed, float) * np.asarray(acceleration, float) \
        + m * gravity * np.asarray(climb_rate, float)


def polar_power_terms(airspeed, air_density, mass, wing_area, load_factor=1.0, gravity=G):
    r"""
    The drag power's regressors: :math:`D V = a\,C_{D0} + b\,K`.

    Parameters
    ----------
    airspeed : numeric
        True airspeed, > 0. [m/s]
    air_density : numeric
        > 0. [kg/m³]
    mass : numeric
        All-up mass, > 0. [kg]
    wing_area : float
        > 0. [m²]
    load_factor : numeric
        Lift over weight. [unitless]
    gravity : float
        [m/s²]

    Returns
    -------
    a, b : ndarray
        :math:`a = \tfrac12 \rho V^3 S` [W], :math:`b = 2 (n m g)^2 / (\rho S V)` [W].

    Notes
    -----
    [UAV23] eq. 3–4: :math:`A V^3 = a C_{D0}`, :math:`B / V = b K`.
    """
    v = _positive(airspeed, "airspeed")
    rho = _positive(air_density, "air_density")
    s = _positive(wing_area, "wing_area")
    w = _positive(mass, "mass") * gravity * np.asarray(load_factor, float)
    return 0.5 * rho * v**3 * s, 2.0 * w * w / (rho * s * v)


def lift_power(airspeed, mass, load_factor=1.0, gravity=G):
    r"""
    The drag power's regressor of a term linear in the lift coefficient: for
    :math:`C_D = C_{D0} + K_1 C_L + K C_L^2`, :math:`D V = a C_{D0} + (n m g V) K_1 + b K`
    (:func:`polar_power_terms` for :math:`a`, :math:`b`), since
    :math:`\tfrac12 \rho V^2 S\, C_L = n m g`. [W]
    """
    return np.asarray(load_factor, float) * _positive(mass, "mass") * gravity * \
        np.asarray(airspeed, float)


def shifted_polar(cd0, k1, k):
    r"""
    The polar :math:`C_{D0} + K_1 C_L + K C_L^2` written as
    :math:`C_{D,min} + K (C_L - C_{L,min})^2`: the least drag and where it is.

    Returns
    -------
    cd_min, cl_min : float
        :math:`C_{D,min} = C_{D0} - K_1^2 / (4K)`, :math:`C_{L,min} = -K_1 / (2K)`; NaN
        when :math:`K \le 0` (no least drag). [unitless]

    Notes
    -----
    The quadratic part of the polar Sharpe & Hansman's solver fits
    (``figures/results_solver.py``: ``CD0 + CD2 |C_L - CLCD0|^2 + ...``, [1]_): a cambered
    wing at low Reynolds number has its least drag at a positive lift.
    """
    if not k > 0:
        return math.nan, math.nan
    return cd0 - k1 * k1 / (4.0 * k), -k1 / (2.0 * k)


def thrust_power(battery_power, efficiency, system_power=0.0):
    r"""
    Thrust power from the battery power: :math:`\eta (P - P_S)`. [W]

    Parameters
    ----------
    battery_power : numeric
        [W]
    efficiency : float
        Propulsive efficiency, battery to thrust power, in (0, 1]. [unitless]
    system_power : float
        Avionics and payload load, ≥ 0. [W]

    Notes
    -----
    The propulsion term of [1]_'s balance, as their solver writes it (efficiency times the
    battery power less the avionics power).
    """
    eta = float(efficiency)
    if not 0.0 < eta <= 1.0:
        raise ModelError(f"efficiency must be in (0, 1], got {eta:g}")
    return eta * (np.asarray(battery_power, float) - float(system_power))


def lift_coefficient(airspeed, air_density, mass, wing_area, load_factor=1.0, gravity=G):
    r"""
    :math:`C_L = n m g / (\tfrac12 \rho V^2 S)`. [unitless]
    """
    v = _positive(airspeed, "airspeed")
    q = 0.5 * _positive(air_density, "air_density") * v * v
    return np.asarray(load_factor, float) * _positive(mass, "mass") * gravity / (
        q * _positive(wing_area, "wing_area"))


def glide_drag_coefficient(airspeed, acceleration, climb_rate, air_density, mass,
                           wing_area, gravity=G):
    r"""
    Drag coefficient of a glide (no thrust) from the energy rate alone.

    Returns
    -------
    cd : ndarray
        :math:`C_D = -(m V \dot V + m g \dot h) / (\tfrac12 \rho V^3 S)`. [unitless]

    Notes
    -----
    With no thrust, :math:`D V = -(m V \dot V + m g \dot h)` ([UAV23] eq. 2 with the
    acceleration kept, [1]_): the polar measured without the propulsive efficiency.
    """
    a, _ = polar_power_terms(airspeed, air_density, mass, wing_area, gravity=gravity)
    return -energy_rate(mass, airspeed, acceleration, climb_rate, gravity) / a
