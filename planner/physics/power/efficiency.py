r"""Propulsion efficiency that changes with load: the reciprocal efficiency linear in power.

A constant efficiency η turns the mechanical power M into the battery power
:math:`P = M/\eta + P_S`. Motors and their controllers lose more at high load: the copper
loss :math:`R I^2` grows with the square of the current, so at a near-constant voltage
(:math:`I \approx P/V`) the loss over the mechanical power grows linearly with the power,
and the reciprocal efficiency is, to first order about a reference power
:math:`M_{ref}`,

.. math:: \frac{1}{\eta(M)} = \frac{1}{\eta_0} - \frac{\eta_1}{\eta_0^2}
          \left(\frac{M}{M_{ref}} - 1\right)

(Drela's first-order DC motor [1]_: input power :math:`I V` with :math:`V = I R + \ldots`
holds the term :math:`I^2 R`). :math:`\eta_0` is the efficiency at :math:`M_{ref}`,
:math:`\eta_1` the slope :math:`d\eta/d(M/M_{ref})` there, negative when the efficiency
falls with load. ``endurance diagnose`` fits :math:`\eta_1` and :math:`M_{ref}` (its
``efficiency_curve`` effect); an aircraft file stores them as ``efficiency_slope`` and
``efficiency_reference_power_w``.

References
----------
.. [1] M. Drela, "First-order DC electric motor model," MIT Aero & Astro, Feb. 2007.
"""

from __future__ import annotations

import numpy as np

__all__ = ["load_dependent_battery_power"]


def load_dependent_battery_power(constant_power_w, efficiency, system_power_w, slope,
                                 reference_power_w):
    r"""Battery power with the efficiency against load instead of a constant efficiency.

    The mechanical power is recovered from the battery power of the constant-efficiency
    model, :math:`M = (P_c - P_S)\,\eta_0`, and drawn again through :math:`1/\eta(M)` of
    the module notes, held at 1 or more (the efficiency never exceeds 1):
    :math:`P = M \max(1/\eta(M), 1) + P_S`. All arguments broadcast.

    Parameters
    ----------
    constant_power_w : numeric
        Battery power of the constant-efficiency model, :math:`M/\eta_0 + P_S`. [W]
    efficiency : float
        :math:`\eta_0`, the efficiency at the reference power. [unitless]
    system_power_w : float
        Avionics and payload load :math:`P_S`. [W]
    slope : float
        :math:`\eta_1`, the change of the efficiency per relative change of the
        mechanical power at the reference. [unitless]
    reference_power_w : float
        :math:`M_{ref}`, the reference mechanical power. [W]

    Returns
    -------
    power : numeric
        Battery power. [W]
    """
    mech = (np.asarray(constant_power_w, float) - system_power_w) * efficiency
    inverse = 1.0 / efficiency - slope / efficiency**2 * (mech / reference_power_w - 1.0)
    return mech * np.maximum(inverse, 1.0) + system_power_w
