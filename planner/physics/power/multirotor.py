r"""Multirotor power from static propeller coefficients ([UAV23] eq. 9–10, 22–24).

Layer 1: pure, vectorised functions in SI units. **Rotor speed is in revolutions per
second** (rev/s, not rad/s), as in [UAV23] and in propeller data sheets
(:math:`T = C_T \rho n^2 D^4`, :math:`P = C_P \rho n^3 D^5`). Every function takes floats,
ndarrays or pandas Series (broadcasting) and returns the same kind; NaN samples propagate;
physically impossible parameters raise :class:`planner.errors.ModelError`.

[UAV23] gives the propeller thrust and power (eq. 9–10), the multirotor battery power in
hover, climb and descent (eq. 22–24) and a worked example of a 7-inch quadcopter.

References
----------
.. [1] J. B. Brandt and M. S. Selig, "Propeller performance data at low Reynolds
   numbers," in Proc. 49th AIAA Aerospace Sciences Meeting, Orlando, FL, USA, 2011,
   AIAA 2011-1255, doi:10.2514/6.2011-1255 (static :math:`C_T`, :math:`C_P` of small
   propellers).
"""

from __future__ import annotations

import numpy as np

from planner.physics.atmosphere import G
from planner.physics.numeric import like_inputs, require
from planner.errors import ModelError

MIN_ROTOR_SPEED_RATIO = 0.5
r"""Default idle rotor speed as a fraction of the hover rotor speed [unitless].

A typical ArduPilot set-up spins at ``MOT_SPIN_MIN`` ≈ 0.15 of the throttle range with a
hover throttle ``MOT_THST_HOVER`` ≈ 0.3–0.4, i.e. roughly 0.4–0.5 of the hover rotor speed;
0.5 (12.5 % of the hover rotor power, since :math:`P \propto n^3`) is the conservative end.
"""


def rotor_speed(thrust, air_density, diameter, ct):
    r"""
    Rotor speed that produces a given static thrust.

    Parameters
    ----------
    thrust : numeric
        Thrust of one rotor, ≥ 0. [N]
    air_density : numeric
        Air density. [kg m⁻³]
    diameter : numeric
        Propeller diameter. [m]
    ct : numeric
        Static thrust coefficient (propeller convention, per rev/s). [unitless]

    Returns
    -------
    rotor_speed : numeric
        Rotor speed :math:`n`. [rev s⁻¹]

    Notes
    -----
    .. math:: T = C_T \rho n^2 D^4 \quad\Rightarrow\quad n = \sqrt{\frac{T}{C_T \rho D^4}}

    [UAV23] eq. 9; coefficient convention as in [1]_.
    """
    t = require(thrust, "thrust", ge=0.0, unit="N")
    rho, d, c = _rotor_inputs(air_density, diameter, ct, "ct")
    return like_inputs(_speed_for_thrust(t, rho, d, c), thrust, air_density, diameter, ct)


def rotor_power(rotor_speed, air_density, diameter, cp):
    r"""
    Shaft power of one rotor from its static power coefficient.

    Parameters
    ----------
    rotor_speed : numeric
        Rotor speed :math:`n`, ≥ 0. [rev s⁻¹]
    air_density, diameter : numeric
        As in :func:`rotor_speed`. [kg m⁻³], [m]
    cp : numeric
        Static power coefficient (propeller convention, per rev/s). [unitless]

    Returns
    -------
    power : numeric
        Shaft power of one rotor. [W]

    Notes
    -----
    .. math:: P = C_P \rho n^3 D^5

    [UAV23] eq. 10; coefficient convention as in [1]_.
    """
    n = require(rotor_speed, "rotor_speed", ge=0.0, unit="rev/s")
    rho, d, c = _rotor_inputs(air_density, diameter, cp, "cp")
    return like_inputs(_power_at_speed(n, rho, d, c), rotor_speed, air_density, diameter, cp)


def _rotor_inputs(air_density, diameter, coefficient, name):
    """Air density [kg m⁻³], diameter [m] and a propeller coefficient, checked."""
    return (require(air_density, "air_density", gt=0.0, unit="kg/m³"),
            require(diameter, "diameter", gt=0.0, unit="m"), require(coefficient, name, gt=0.0))


def _speed_for_thrust(thrust, air_density, diameter, ct):
    """:math:`n = \\sqrt{T/(C_T \\rho D^4)}` ([UAV23] eq. 9), ndarrays. [rev s⁻¹]"""
    return np.sqrt(thrust / (ct * air_density * diameter**4))


def _power_at_speed(speed, air_density, diameter, cp):
    """:math:`P = C_P \\rho n^3 D^5` ([UAV23] eq. 10), ndarrays. [W]"""
    return cp * air_density * speed**3 * diameter**5


def propeller_battery_power(mass, air_density, rotors, diameter, ct, cp, efficiency,
                            climb_rate=0.0, airspeed=0.0, drag_area=0.0, system_power=0.0,
                            min_rotor_speed_ratio=MIN_ROTOR_SPEED_RATIO, gravity=G):
    r"""
    Battery power of a multirotor from static propeller coefficients.

    Parameters
    ----------
    mass, air_density, rotors, efficiency, climb_rate, airspeed, drag_area
        As in :func:`planner.physics.power.momentum.momentum_power_components` (the
        climb rate :math:`\dot h`). [kg], [kg m⁻³], [unitless], [unitless], [m s⁻¹],
        [m s⁻¹], [m²]
    diameter : numeric
        Propeller diameter :math:`D`. [m]
    ct, cp : numeric
        Static thrust and power coefficients (per rev/s). [unitless]
    system_power : numeric, default 0
        Constant electrical load :math:`P_S`, ≥ 0. [W]
    min_rotor_speed_ratio : float, default 0.5
        Idle rotor speed as a fraction of the hover rotor speed, in [0, 1]; sets the
        power floor. [unitless]
    gravity : float, default 9.80665
        Acceleration of gravity. [m s⁻²]

    Returns
    -------
    power : numeric
        Battery (discharge) power. [W]

    Notes
    -----
    Vertical flight, exactly [UAV23] eq. 22–24: each rotor carries
    :math:`T = W/N`, turns at :math:`n` from :func:`rotor_speed` and needs
    :func:`rotor_power`; the climb adds :math:`W\dot h`:

    .. math:: P = \frac{N C_P \rho n^3 D^5 + W \dot h}{\eta} + P_S

    **Forward flight (extension, not in [UAV23]).** The thrust is tilted forward so that
    it balances the weight and the body drag :math:`D = \tfrac12 \rho V^2 f`; each rotor
    carries :math:`T = \sqrt{W^2 + D^2}/N` and its power is taken from the *static*
    coefficients at that thrust. The static coefficients price only the power to make
    thrust in still air (the hover-like induced and profile power); they do not contain
    the work done by the thrust vector on the moving vehicle. That work is
    :math:`\vec T\cdot\vec u = W\dot h + D V` (the thrust's vertical part times the climb
    rate plus its forward part times the airspeed). [UAV23] keeps the first term, so
    the second, the parasite power :math:`D V`, is added as well:

    .. math:: P_R = N C_P \rho n^3 D^5 + W \dot h + D V

    This is conservative: no translational-lift credit is taken (in reality the induced
    power falls with forward speed, see :mod:`planner.physics.power.momentum`), and the body drag
    is computed from the horizontal airspeed only (vertical drag neglected, as in
    [UAV23]).

    **Floor (no regeneration).** In a fast descent :math:`W\dot h` would drive
    :math:`P_R` below zero. The motors keep spinning (attitude control needs thrust
    authority) and ESCs do not regenerate, so the electrical power never drops below
    :math:`P_S` plus the rotors' power at an idle rotor speed
    :math:`n_{min} = r\, n_{hover}`:

    .. math::

        P = \frac{\max\left(P_R,\; N C_P \rho (r\,n_{hover})^3 D^5\right)}{\eta} + P_S
        = \frac{\max(P_R,\; r^3 P_{R,hover})}{\eta} + P_S

    with :math:`r` = ``min_rotor_speed_ratio`` (default 0.5, i.e. 12.5 % of the hover
    rotor power). The descent example of [UAV23] (3 m/s, 48.0 W for a 75.2 W hover) lies well
    above this floor.
    """
    m = require(mass, "mass", gt=0.0, unit="kg")
    n_rot = require(rotors, "rotors", ge=1.0)
    rho, d, c_t = _rotor_inputs(air_density, diameter, ct, "ct")
    c_p = require(cp, "cp", gt=0.0)
    eta = require(efficiency, "efficiency", gt=0.0, le=1.0)
    hdot = np.asarray(climb_rate, dtype=float)
    v = require(airspeed, "airspeed", ge=0.0, unit="m/s")
    f = require(drag_area, "drag_area", ge=0.0, unit="m²")
    ps = require(system_power, "system_power", ge=0.0, unit="W")
    r = require(min_rotor_speed_ratio, "min_rotor_speed_ratio", ge=0.0, le=1.0)
    if np.any(np.asarray(rotors) != np.round(np.asarray(rotors, dtype=float))):
        raise ModelError(f"rotors must be a whole number >= 1, got {rotors}")

    weight = m * gravity
    drag = 0.5 * rho * v**2 * f
    thrust_rotor = np.sqrt(weight**2 + drag**2) / n_rot
    speed = _speed_for_thrust(thrust_rotor, rho, d, c_t)
    p_rotors = n_rot * _power_at_speed(speed, rho, d, c_p)
    p_required = p_rotors + weight * hdot + drag * v

    speed_hover = _speed_for_thrust(weight / n_rot, rho, d, c_t)
    p_floor = n_rot * _power_at_speed(r * speed_hover, rho, d, c_p)
    p = np.maximum(p_required, p_floor) / eta + ps
    return like_inputs(p, mass, air_density, rotors, diameter, ct, cp, efficiency, climb_rate,
                    airspeed, drag_area, system_power)
