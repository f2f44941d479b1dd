r"""Multirotor battery power with the motors' own losses: momentum theory plus Drela's motor.

Layer 1: pure, vectorised functions in SI units (floats, ndarrays or pandas Series,
broadcasting; NaN samples propagate; physically impossible parameters raise
:class:`planner.errors.ModelError` naming the parameter).

The model separates what is drawn with the rotors stopped from what the propulsion
draws while it turns:

.. math::

    P_{batt} = P_{stop} + s\,\frac{\max(P_{shaft}, P_{floor})
               + P_{nl}\,\hat\Omega + P_{cu}\,\hat Q^2}{\eta_d}

* :math:`P_{stop}` — avionics and payload electronics, the power seen on the ground with
  the rotors stopped (``system_power_w`` of the aircraft file); :math:`s = 1` while the
  rotors turn (every airborne sample), 0 with the rotors stopped.
* :math:`P_{shaft} = \kappa T v_i + P_0 + \tfrac12\rho V^3 f + W\dot h` — the rotors'
  aerodynamic power, term by term as in :mod:`planner.physics.power.momentum` (Glauert inflow,
  Leishman's vortex-ring curve, profile power :math:`r_0 T v_h (1 + 4.65\mu^2)`, body
  parasite power, climb power) [1]_, [2]_. ESCs do not regenerate: it is floored, at zero
  by default (:math:`P_{floor} = 0`), or at the idle-speed floor of the momentum model.
* :math:`P_{nl}\hat\Omega` — the motors' no-load loss (iron and friction losses,
  :math:`I_0 V`), proportional to rotor speed. For a fixed-pitch propeller
  :math:`T = C_T\rho\Omega^2D^4`, so :math:`\Omega \propto \sqrt{T/\rho}` and
  :math:`\hat\Omega = \sqrt{(T/\rho)/(T_{ref}/\rho_{ref})}`, normalised at the reference
  hover (:math:`T_{ref} = m_{ref}g`, :math:`\rho_{ref}` = 1.225 kg/m³) [3]_, [4]_.
* :math:`P_{cu}\hat Q^2` — the copper loss :math:`I^2R`: the motor current is
  proportional to its torque, and the torque is the rotor's shaft power over its speed,
  :math:`Q = P_{shaft}/\Omega` [3]_. Normalised at the reference hover,
  :math:`\hat Q = \max(P_{shaft}, P_{floor}) / (\hat\Omega\,P_{ref})` with
  :math:`P_{ref} = (\kappa + r_0)\,T_{ref}\,v_h(T_{ref}, \rho_{ref})` the shaft power of
  that hover. In a hover at any mass and density this is :math:`\hat Q = T/T_{ref}` (a
  fixed-pitch propeller's :math:`Q = C_Q\rho\Omega^2D^5 \propto T`); in forward flight,
  climb and descent the torque follows the shaft power the rotors deliver there, which
  the thrust alone does not give (a descent lowers both).
* :math:`\eta_d` — what is left between battery and motors (ESC switching, wiring).

With :math:`P_{nl} = P_{cu} = 0`, :math:`\eta_d = \eta`, :math:`P_{stop} = P_S` and the
idle-speed floor it is exactly :func:`planner.physics.power.momentum.momentum_battery_power`.

References
----------
.. [1] J. G. Leishman, Principles of Helicopter Aerodynamics, 2nd ed. Cambridge, U.K.:
   Cambridge Univ. Press, 2006: ch. 2 (momentum theory, vortex-ring curve, §2.14) and
   ch. 5 (Glauert's inflow, profile power :math:`1 + 4.65\mu^2`).
.. [2] H. Glauert, "A general theory of the autogyro," Aeronautical Research Committee,
   R&M 1111, 1926.
.. [3] M. Drela, "First-order DC electric motor model," MIT Aero & Astro, Feb. 2007:
   :math:`P_{elec} = P_{shaft} + I_0 V + I^2 R`, :math:`Q = (I - I_0)/K_v`.
.. [4] O. Gur and A. Rosen, "Optimizing electric propulsion systems for unmanned aerial
   vehicles," Journal of Aircraft 46(4), 1340–1353, 2009, doi:10.2514/1.41027 (motor
   losses of a UAV propulsion system: no-load and copper losses against rotor speed and
   torque).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from planner.physics.atmosphere import RHO0, G
from planner.physics.numeric import require
from planner.physics.power.momentum import (
    RotorPowerTerms,
    ideal_hover_power,
    rotor_shaft_terms,
    terms_like_inputs,
)

__all__ = ["REFERENCE_DENSITY", "RotorLossesPower", "battery_power_from_unit_terms",
           "rotor_losses_battery_power", "rotor_losses_components"]

REFERENCE_DENSITY = RHO0
"""Air density of the reference hover at which :math:`\\hat\\Omega = \\hat Q = 1`:
ISA sea level. [kg m⁻³]"""


@dataclass(frozen=True)
class RotorLossesPower(RotorPowerTerms):
    """Power budget of :func:`rotor_losses_components`: the aerodynamic terms of
    :class:`~planner.physics.power.momentum.RotorPowerTerms` (shaft power before the
    floor), the battery power of the module notes, and the motor losses:
    """

    no_load: Any
    """Motor no-load loss :math:`P_{nl}\\hat\\Omega`. [W]"""
    copper: Any
    """Motor copper loss :math:`P_{cu}\\hat Q^2`. [W]"""
    rotor_speed_ratio: Any
    """:math:`\\hat\\Omega`, rotor speed over that of the reference hover. [unitless]"""
    torque_ratio: Any
    """:math:`\\hat Q`, rotor torque over that of the reference hover. [unitless]"""
    reference_induced: Any
    """Induced power :math:`\\kappa T_{ref} v_h(T_{ref}, \\rho_{ref})` of the reference
    hover. [W]"""
    reference_profile: Any
    """Profile power :math:`r_0 T_{ref} v_h(T_{ref}, \\rho_{ref})` of the reference
    hover. [W]"""


def rotor_losses_components(mass, air_density, rotors, diameter, drive_efficiency=0.95,
                            airspeed=0.0, climb_rate=0.0, drag_area=0.0, induced_factor=1.15,
                            figure_of_merit=None, profile_power_ratio=None, tip_speed=None,
                            stopped_power=0.0, no_load_power=0.0, copper_loss_power=0.0,
                            reference_mass=None, reference_density=REFERENCE_DENSITY,
                            thrust=None, load_factor=1.0, rotors_turning=True,
                            min_rotor_speed_ratio=0.0, gravity=G, descent_inflow_weight=0.0):
    r"""
    Multirotor battery power with motor no-load and copper losses, term by term.

    Parameters
    ----------
    mass, air_density, rotors, diameter, airspeed, climb_rate, drag_area, \
induced_factor, figure_of_merit, profile_power_ratio, tip_speed, load_factor
        As in :func:`planner.physics.power.momentum.momentum_power_components`. [kg],
        [kg m⁻³], [unitless], [m], [m s⁻¹], [m s⁻¹], [m²], [unitless], [unitless],
        [unitless], [m s⁻¹], [unitless]
    drive_efficiency : numeric, default 0.95
        Battery-to-motor efficiency :math:`\eta_d` (ESC, wiring), in (0, 1]. [unitless]
    stopped_power : numeric, default 0
        :math:`P_{stop}`, drawn with the rotors stopped, ≥ 0. [W]
    no_load_power : numeric, default 0
        :math:`P_{nl}`, motor no-load loss at the reference hover, ≥ 0. [W]
    copper_loss_power : numeric, default 0
        :math:`P_{cu}`, motor copper loss at the reference hover, ≥ 0. [W]
    reference_mass : numeric, optional
        Mass of the reference hover (default: ``mass``). [kg]
    reference_density : numeric, default 1.225
        Air density of the reference hover. [kg m⁻³]
    thrust : numeric, optional
        Measured total thrust (e.g. mass × accelerometer specific force); default the
        trim thrust :math:`\sqrt{(nW)^2 + D^2}`. [N]
    rotors_turning : bool or array of bool, default True
        :math:`s`: False where the rotors are stopped (only :math:`P_{stop}` drawn).
    min_rotor_speed_ratio : float, default 0
        Idle rotor speed over hover rotor speed setting the shaft-power floor
        :math:`r^3 W v_h(W)(\kappa + r_0)`; 0 floors the shaft power at zero. [unitless]
    gravity : float, default 9.80665
        [m s⁻²]
    descent_inflow_weight : float, default 0
        As in :func:`planner.physics.power.momentum.momentum_power_components`. [unitless]

    Returns
    -------
    components : RotorLossesPower

    Notes
    -----
    .. math::

        P_{batt} = P_{stop} + s\,\frac{\max(P_{shaft}, P_{floor})
                   + P_{nl}\hat\Omega + P_{cu}\hat Q^2}{\eta_d},
        \qquad \hat\Omega = \sqrt{\frac{T/\rho}{T_{ref}/\rho_{ref}}},
        \qquad \hat Q = \frac{\max(P_{shaft}, P_{floor})}{\hat\Omega\,(\kappa + r_0)
                              T_{ref}\,v_h(T_{ref}, \rho_{ref})}

    :math:`P_{shaft} = \kappa T v_i + r_0 T v_h (1 + 4.65\mu^2) + \tfrac12\rho V^3 f +
    W\dot h` ([1]_ ch. 2 and 5; :math:`v_i` from
    :func:`planner.physics.power.momentum.induced_velocity`'s Glauert / vortex-ring solution with
    the axial inflow :math:`V_z = (DV + W\dot h)/T`); the motor terms follow Drela's
    first-order motor model [3]_ (:math:`I_0V \propto \Omega`, :math:`I^2R \propto Q^2`,
    :math:`Q = P_{shaft}/\Omega`) with :math:`\Omega \propto \sqrt{T/\rho}` of a
    fixed-pitch propeller, as Gur & Rosen [4]_ model UAV motor losses; in a hover
    :math:`\hat Q = T/T_{ref}`.
    """
    terms = rotor_shaft_terms(mass, air_density, rotors, diameter, airspeed, climb_rate,
                              drag_area, induced_factor, figure_of_merit, profile_power_ratio,
                              tip_speed, load_factor, min_rotor_speed_ratio, gravity,
                              thrust=thrust, descent_inflow_weight=descent_inflow_weight)
    eta = require(drive_efficiency, "drive_efficiency", gt=0.0, le=1.0)
    p_stop = require(stopped_power, "stopped_power", ge=0.0, unit="W")
    p_nl = require(no_load_power, "no_load_power", ge=0.0, unit="W")
    p_cu = require(copper_loss_power, "copper_loss_power", ge=0.0, unit="W")
    m_ref = (np.asarray(mass, dtype=float) if reference_mass is None
             else require(reference_mass, "reference_mass", gt=0.0, unit="kg"))
    rho_ref = require(reference_density, "reference_density", gt=0.0, unit="kg/m³")
    t, rho = terms["thrust"], np.asarray(air_density, dtype=float)
    t_ref = m_ref * gravity
    speed = np.sqrt((t / rho) / (t_ref / rho_ref))
    ideal_ref = ideal_hover_power(t_ref, rho_ref, rotors * 0.25 * np.pi * diameter**2)
    ref_induced = np.asarray(induced_factor, dtype=float) * ideal_ref
    ref_profile = terms["profile_power_ratio"] * ideal_ref
    torque = _torque_ratio(np.maximum(terms["shaft"], terms["floor"]), speed,
                           ref_induced + ref_profile)
    no_load = p_nl * speed
    copper = p_cu * torque**2
    battery = _battery(terms["shaft"], terms["floor"], no_load, copper, eta, p_stop,
                       rotors_turning)
    inputs = (mass, air_density, rotors, diameter, drive_efficiency, airspeed, climb_rate,
              drag_area, induced_factor, stopped_power, no_load_power, copper_loss_power,
              load_factor) + (() if thrust is None else (thrust,))
    out = terms_like_inputs({k: terms[k] for k in (
        "induced", "profile", "parasite", "climb", "shaft", "thrust")} | {
        "no_load": no_load, "copper": copper, "battery": battery,
        "rotor_speed_ratio": speed, "torque_ratio": torque,
        "reference_induced": ref_induced, "reference_profile": ref_profile}, battery, inputs)
    return RotorLossesPower(**out)


def _torque_ratio(shaft, speed, reference_shaft):
    """Q̂ = P_shaft/(Ω̂ P_ref): the torque over the reference hover's (module notes); 0
    where the rotors do not turn (Ω̂ = 0)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(speed > 0.0, shaft / (np.where(speed > 0.0, speed, 1.0)
                                              * reference_shaft), 0.0)


def _battery(shaft, floor, no_load, copper, eta, p_stop, turning):
    """P_stop + s (max(P_shaft, P_floor) + no-load + copper loss)/η_d (module notes)."""
    drive = (np.maximum(shaft, floor) + no_load + copper) / eta
    return p_stop + np.where(np.asarray(turning, dtype=bool), drive, 0.0)


def battery_power_from_unit_terms(unit: RotorLossesPower, profile_power_ratio, no_load_power,
                                  copper_loss_power, drive_efficiency, stopped_power=0.0):
    r"""
    Battery power of rotors turning from the terms of a unit evaluation.

    The induced, parasite and climb power, thrust and rotor speed do not depend on
    :math:`r_0`, :math:`P_{nl}`, :math:`P_{cu}`, :math:`\eta_d` or :math:`P_{stop}`;
    the profile power (of the samples and of the reference hover) and the no-load loss
    are proportional to :math:`r_0` and :math:`P_{nl}`, and the torque ratio follows
    from them. A fit that varies only these reuses one evaluation of the aerodynamics.

    Parameters
    ----------
    unit : RotorLossesPower
        :func:`rotor_losses_components` with ``profile_power_ratio=1``,
        ``no_load_power=1``, ``copper_loss_power=1`` and the shaft floored at zero
        (``min_rotor_speed_ratio=0``), rotors turning.
    profile_power_ratio, no_load_power, copper_loss_power, drive_efficiency, \
stopped_power : numeric
        :math:`r_0` [unitless], :math:`P_{nl}` [W], :math:`P_{cu}` [W],
        :math:`\eta_d` [unitless], :math:`P_{stop}` [W].

    Returns
    -------
    power : ndarray
        The same as :func:`rotor_losses_battery_power` with these parameters. [W]
    """
    shaft = np.maximum(np.asarray(unit.induced) + profile_power_ratio * np.asarray(unit.profile)
                       + np.asarray(unit.parasite) + np.asarray(unit.climb), 0.0)
    speed = np.asarray(unit.rotor_speed_ratio)
    torque = _torque_ratio(shaft, speed, np.asarray(unit.reference_induced)
                           + profile_power_ratio * np.asarray(unit.reference_profile))
    return _battery(shaft, 0.0, no_load_power * speed, copper_loss_power * torque**2,
                    drive_efficiency, stopped_power, True)


def rotor_losses_battery_power(mass, air_density, rotors, diameter, drive_efficiency=0.95,
                               **kwargs):
    r"""
    Battery power of a multirotor with motor no-load and copper losses.

    Parameters
    ----------
    mass, air_density, rotors, diameter, drive_efficiency, **kwargs
        As in :func:`rotor_losses_components`.

    Returns
    -------
    power : numeric
        :math:`P_{batt}`, see :func:`rotor_losses_components` (module references
        [1]_–[4]_: Leishman, Glauert, Drela 2007, Gur & Rosen 2009). [W]
    """
    return rotor_losses_components(mass, air_density, rotors, diameter, drive_efficiency,
                                   **kwargs).battery
