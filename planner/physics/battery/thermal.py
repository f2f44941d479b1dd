r"""Lumped thermal model of a battery pack (or a supercapacitor cell).

One heat capacity exchanging heat with the air through one thermal resistance
([HESS] eq. 11):

.. math:: C_{th} \frac{dT}{dt} + \frac{T - T_{air}}{R_{th}} = Q_{gen}

For heat held constant over each time step (zero-order hold) the solution is
exact:

.. math:: T_{k+1} = T_{air} + R_{th} Q_k + (T_k - T_{air} - R_{th} Q_k)\, e^{-\Delta t_k/\tau},
          \qquad \tau = R_{th} C_{th}

Coupling with the equivalent circuit (:mod:`planner.physics.battery.circuit`) goes
both ways: the circuit's heat ``Q_gen = I² R0(T) + v_RC² / R1`` (Joule heat in
the ohmic resistance plus the heat in the resistor of the RC branch, whose
current is ``v_RC / R1``) drives this model, and the temperature sets R0
(Arrhenius) and the available capacity. Reversible (entropic) heat and the
heat of hysteresis are neglected.

YAML ``thermal:`` block of a battery pack (pack values, not per cell):

====================  ========  ========  =========================================
key                   unit      default   meaning
====================  ========  ========  =========================================
``r_th_k_per_w``      K/W       required  pack-to-air thermal resistance
``c_th_j_per_k``      J/K       required  pack heat capacity (≈ mass × ~1000 J/(kg K))
``t_air_c``           °C        25        air temperature (a mission's air
                                          temperature overrides it)
``t0_c``              °C        t_air_c   pack temperature at the start
``source``            text      —         where the numbers come from
====================  ========  ========  =========================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba
import numpy as np
import pandas as pd
from scipy.signal import lfilter

from planner.errors import InputError, ModelError
from planner.physics.battery.elements import joule_heat

#: Temperature range of the battery models (cell temperature). [°C]
T_RANGE_C = (-20.0, 60.0)

@dataclass(frozen=True)
class ThermalParameters:
    """Lumped thermal parameters of a pack.

    Attributes
    ----------
    r_th_k_per_w : float
        Thermal resistance to the air. [K/W]
    c_th_j_per_k : float
        Heat capacity. [J/K]
    t_air_c : float
        Air temperature. [°C]
    t0_c : float or None
        Initial temperature; ``None`` = ``t_air_c``. [°C]
    source : str or None
    """

    r_th_k_per_w: float
    c_th_j_per_k: float
    t_air_c: float = 25.0
    t0_c: float | None = None
    source: str | None = None

    def __post_init__(self):
        for key in ("r_th_k_per_w", "c_th_j_per_k"):
            value = getattr(self, key)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise InputError(f"thermal: {key} must be a number > 0, got {value!r}")
        for key in ("t_air_c", "t0_c"):
            value = getattr(self, key)
            if value is not None:
                check_temperature(value, what=f"thermal: {key}")

    @property
    def tau_s(self) -> float:
        """Thermal time constant R_th·C_th. [s]"""
        return self.r_th_k_per_w * self.c_th_j_per_k

    @property
    def initial_c(self) -> float:
        """Initial temperature (``t0_c``, else ``t_air_c``). [°C]"""
        return self.t_air_c if self.t0_c is None else self.t0_c

    def with_air(self, t_air_c: float, t0_c: float | None = None) -> ThermalParameters:
        """A copy at another air temperature (e.g. the mission's)."""
        return replace(self, t_air_c=float(t_air_c), t0_c=t0_c)


def check_temperature(temperature_c, what: str = "temperature") -> None:
    """Raise :class:`ModelError` when a temperature lies outside :data:`T_RANGE_C`.

    NaN values are let through (a missing sample propagates).
    """
    t = np.asarray(temperature_c, dtype=float)
    bad = (t < T_RANGE_C[0]) | (t > T_RANGE_C[1])
    if np.any(bad):
        value = float(t.ravel()[np.flatnonzero(bad.ravel())[0]])
        raise ModelError(f"{what} {value:.1f} °C is outside the battery model's range "
                         f"[{T_RANGE_C[0]:g} °C, {T_RANGE_C[1]:g} °C]")


@numba.njit(cache=True)
def lumped_step(temperature_c, t_air_c, heat_w, r_th, a):
    r"""
    One step of the lumped thermal model ([HESS] eq. 11) with the heat held over it.

    .. math:: T_{k+1} = T_{air} + R_{th} Q_k + (T_k - T_{air} - R_{th} Q_k)\, a,
              \qquad a = e^{-\Delta t_k/(R_{th} C_{th})}

    The exact solution of :math:`C_{th}\dot T + (T - T_{air})/R_{th} = Q` for a constant
    :math:`Q`; the one thermal step of the planner, used by :func:`lumped_temperature` and
    by the circuit model's time loop (:func:`planner.physics.battery.circuit.simulate`).

    Parameters
    ----------
    temperature_c, t_air_c : float
        Body and air temperature at the start of the step. [°C]
    heat_w : float
        Heat generated over the step. [W]
    r_th : float
        Thermal resistance to the air. [K/W]
    a : float
        :math:`e^{-\Delta t/\tau}`, the step's decay factor. [unitless]

    Returns
    -------
    temperature : float
        At the end of the step. [°C]
    """
    target = t_air_c + r_th * heat_w
    return target + (temperature_c - target) * a


def heat_generation(current_a, r0_ohm, rc_voltage_v=0.0, r1_ohm=None):
    r"""
    Joule heat of the equivalent circuit.

    Parameters
    ----------
    current_a : numeric
        Current through R0 (discharge positive). [A]
    r0_ohm : numeric
        Ohmic resistance. [Ω]
    rc_voltage_v : numeric, default 0
        Voltage across the RC branch. [V]
    r1_ohm : numeric or None
        Resistance of the RC branch; ``None`` or 0 = no RC branch. [Ω]

    Returns
    -------
    heat : numeric
        Generated heat. [W]

    Notes
    -----
    :func:`planner.physics.battery.elements.joule_heat` ([HESS] eq. 10):
    :math:`Q_{gen} = I^2 R_0 + v_{RC}^2 / R_1`; in steady state (``v_RC = I R1``) this is
    ``I² (R0 + R1)``.
    """
    r1 = np.inf if r1_ohm is None else np.where(np.asarray(r1_ohm) > 0, r1_ohm, np.inf)
    return joule_heat(current_a, r0_ohm, rc_voltage_v, r1)


def steady_state_temperature(heat_w, t_air_c, r_th):
    """Temperature reached under constant heat: ``T_air + R_th·Q``. [°C]"""
    return t_air_c + r_th * heat_w


def lumped_temperature(time_s, heat_w, t_air_c, r_th, c_th, t0_c=None):
    r"""
    Temperature of a lumped body heated piecewise-constantly.

    Parameters
    ----------
    time_s : array_like
        Sample times, increasing. [s]
    heat_w : numeric
        Generated heat, held from each sample to the next (zero-order hold);
        the last value is not used. [W]
    t_air_c : numeric
        Air temperature, scalar or one value per sample (held like the heat). [°C]
    r_th : float
        Thermal resistance to the air. [K/W]
    c_th : float
        Heat capacity. [J/K]
    t0_c : float, optional
        Temperature at ``time_s[0]``; default the first air temperature. [°C]

    Returns
    -------
    temperature : ndarray or Series
        Temperature at each sample (Series when ``heat_w`` is one). [°C]

    Notes
    -----
    Exact solution of :math:`C_{th} \dot T + (T - T_{air})/R_{th} = Q` ([HESS]
    eq. 11) for heat and air temperature constant over each step:

    .. math:: T_{k+1} = a_k T_k + (1 - a_k)(T_{air,k} + R_{th} Q_k), \quad
              a_k = e^{-\Delta t_k / (R_{th} C_{th})}

    A uniform time grid is filtered in one call (``scipy.signal.lfilter``).
    """
    if not (np.isfinite(r_th) and r_th > 0):
        raise InputError(f"r_th must be > 0 K/W, got {r_th!r}")
    if not (np.isfinite(c_th) and c_th > 0):
        raise InputError(f"c_th must be > 0 J/K, got {c_th!r}")
    t = np.asarray(time_s, dtype=float).ravel()
    n = t.size
    q = np.broadcast_to(np.asarray(heat_w, dtype=float), (n,)) if n else np.zeros(0)
    air = np.broadcast_to(np.asarray(t_air_c, dtype=float), (n,)) if n else np.zeros(0)
    if n == 0:
        return np.zeros(0)
    dt = np.diff(t)
    if np.any(dt < 0):
        raise InputError("time_s must not decrease")
    t0 = float(air[0]) if t0_c is None else float(t0_c)
    tau = r_th * c_th
    target = air[:-1] + r_th * q[:-1]
    out = np.empty(n)
    out[0] = t0
    if n > 1:
        if np.allclose(dt, dt[0], rtol=1e-9, atol=0.0):
            a = math.exp(-dt[0] / tau)
            # w[j] = a w[j-1] + (1 - a) target[j], w[-1] = t0, out[j + 1] = w[j]
            out[1:], _ = lfilter([1.0 - a], [1.0, -a], target, zi=[a * t0])
        else:
            a = np.exp(-dt / tau)
            temp = t0
            for k in range(n - 1):
                temp = lumped_step(temp, air[k], q[k], r_th, a[k])
                out[k + 1] = temp
    if isinstance(heat_w, pd.Series):
        return pd.Series(out, index=heat_w.index)
    return out
