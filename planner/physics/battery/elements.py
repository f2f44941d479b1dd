r"""The element functions the battery models are composed of, each written once.

The equivalent circuit (:mod:`planner.physics.battery.circuit`), the passive hybrid
(:mod:`planner.physics.battery.hybrid`) and the mission chain's compiled kernels
(:mod:`planner.chain.steps`) are assembled from the same small functions, as PyBaMM's
equivalent-circuit model is assembled from its element submodels:

=====================================  ==================================================
element                                equation
=====================================  ==================================================
open-circuit voltage                   :func:`planner.physics.battery.ocv.lipo_ocv`
                                       (compiled: ``lipo_ocv_jit``)
R0 against temperature                 :func:`arrhenius_factor` (Arrhenius)
capacity against temperature           :func:`capacity_factor`
hysteresis step                        :func:`hysteresis_step` ([HESS] eq. 4)
RC step                                :func:`rc_step` ([HESS] eq. 5)
loaded current                         :func:`loaded_current` ([HESS] eq. 2)
power limit                            :func:`power_limit`
Joule heat                             :func:`joule_heat` ([HESS] eq. 10)
lumped thermal step                    :func:`planner.physics.battery.thermal.lumped_step`
                                       ([HESS] eq. 11, compiled)
current the pack gives at a load       :func:`delivered_current` (compiled only)
pack scaling                           :func:`pack_resistance`, :func:`cell_resistance`,
                                       :func:`pack_capacitance`
integral model's charge                :func:`planner.physics.battery.integral.charge_from_stress`
=====================================  ==================================================

Each element is a plain function of numbers written with numpy operations that work on
arrays and on scalars alike: called from Python it works on whole arrays (NaN and ±inf
are its answers, so no floating-point warning is raised), and its compiled twin
(``<name>_jit``, numba, the same source) is what the time loops call per step; numba
inlines a small compiled function into the kernel that calls it. SI units throughout;
charge in A s.
"""

from __future__ import annotations

import functools

import numba
import numpy as np
import pandas as pd

from planner.physics.units import ZERO_CELSIUS_K

__all__ = ["R_GAS", "arrhenius_factor", "capacity_factor", "cell_resistance", "compiled",
           "delivered_current", "hysteresis_step", "joule_heat", "loaded_current",
           "pack_capacitance", "pack_resistance", "power_limit", "quiet", "rc_step"]

#: Universal gas constant. [J/(mol K)]
R_GAS = 8.314462618


def compiled(formula):
    """The compiled twin of an element: ``formula`` compiled by numba for the kernels
    (lazily, at its first call; cached on disk), with numpy's floating-point rules
    (a division by zero gives ±inf or NaN, as on arrays)."""
    return numba.njit(cache=True, error_model="numpy")(formula)


def quiet(formula):
    """An element called from Python: ``formula`` on floats or arrays without
    floating-point warnings (NaN and ±inf are answers of the element, not errors), a
    float for scalar inputs."""
    @functools.wraps(formula)
    def element(*args):
        args = [a if isinstance(a, (np.ndarray, np.generic, pd.Series))
                else np.asarray(a, dtype=float) for a in args]
        with np.errstate(all="ignore"):
            out = formula(*args)
        return float(out) if np.ndim(out) == 0 else out
    return element


# --------------------------------------------------------------------------- temperature

def _arrhenius_factor(temperature_c, activation_j_mol, reference_c):
    return np.exp(activation_j_mol / R_GAS * (1.0 / (temperature_c + ZERO_CELSIUS_K)
                                              - 1.0 / (reference_c + ZERO_CELSIUS_K)))


@quiet
def arrhenius_factor(temperature_c, activation_j_mol, reference_c):
    r"""R0(T)/R0(T_ref) from the Arrhenius law.

    .. math:: \frac{R_0(T)}{R_0(T_{ref})} = \exp\left(\frac{E_a}{R}
              \left(\frac{1}{T} - \frac{1}{T_{ref}}\right)\right)

    with the temperatures in kelvin and :math:`R` = 8.314462618 J/(mol K) (a resistance
    that falls as the cell warms; the activation energy is discussed in the module
    notes of :mod:`planner.physics.battery.circuit`).

    Parameters
    ----------
    temperature_c : numeric
        Cell temperature. [°C]
    activation_j_mol : numeric
        Activation energy :math:`E_a`. [J/mol]
    reference_c : numeric
        Temperature of the reference resistance. [°C]

    Returns
    -------
    factor : numeric
        [unitless]
    """
    return _arrhenius_factor(temperature_c, activation_j_mol, reference_c)


arrhenius_factor_jit = compiled(_arrhenius_factor)


def _capacity_factor(temperature_c, coeff_per_c, reference_c):
    return 1.0 - coeff_per_c * np.maximum(0.0, reference_c - temperature_c)


@quiet
def capacity_factor(temperature_c, coeff_per_c, reference_c):
    r"""Q(T)/Q_ref: the available capacity falls linearly below the reference temperature.

    .. math:: \frac{Q(T)}{Q_{ref}} = 1 - k \max(0, T_{ref} - T)

    (1 at and above :math:`T_{ref}`; the coefficient is discussed in the module notes of
    :mod:`planner.physics.battery.circuit`, after Zhang, Xu and Jow, J. Power Sources
    115, 2003).

    Parameters
    ----------
    temperature_c, reference_c : numeric
        Cell temperature and that of the reference capacity. [°C]
    coeff_per_c : numeric
        Relative capacity loss per degree below the reference, :math:`k`. [1/°C]

    Returns
    -------
    factor : numeric
        [unitless]
    """
    return _capacity_factor(temperature_c, coeff_per_c, reference_c)


capacity_factor_jit = compiled(_capacity_factor)


# --------------------------------------------------------------------------- state steps

def _hysteresis_step(h, charge_as, capacity_as, gamma, m_v):
    decay = np.exp(-gamma * np.abs(charge_as) / capacity_as)
    return decay * h - (1.0 - decay) * m_v * np.sign(charge_as)


@quiet
def hysteresis_step(h, charge_as, capacity_as, gamma, m_v):
    r"""The hysteresis voltage after a step that passed the charge ``charge_as``.

    .. math:: h_{k+1} = e^{-\gamma |\Delta q| / Q} h_k
              - \bigl(1 - e^{-\gamma |\Delta q| / Q}\bigr) M\,\mathrm{sgn}(\Delta q)

    The exact solution over the step of the one-state hysteresis
    :math:`\dot h = -\frac{\gamma |\eta i|}{Q}(h + M \mathrm{sgn}\, i)` ([HESS] eq. 4,
    written for the hysteresis voltage as in Plett, *Battery Management Systems* I,
    ch. 2): on discharge (:math:`\Delta q > 0`) it falls towards :math:`-M`, on charge it
    rises towards :math:`+M`; no charge passed, no change.

    Parameters
    ----------
    h : numeric
        Hysteresis voltage at the start of the step. [V]
    charge_as : numeric
        Charge passed over the step, :math:`\eta\, i\, \Delta t`, discharge positive. [A s]
    capacity_as : numeric
        Capacity :math:`Q` the state of charge counts against. [A s]
    gamma : numeric
        Hysteresis rate :math:`\gamma`. [unitless]
    m_v : numeric
        Maximum hysteresis voltage :math:`M`. [V]

    Returns
    -------
    h : numeric
        At the end of the step. [V]
    """
    return _hysteresis_step(h, charge_as, capacity_as, gamma, m_v)


hysteresis_step_jit = compiled(_hysteresis_step)


def _rc_step(v_rc, current_a, r1_ohm, decay):
    return decay * v_rc + r1_ohm * (1.0 - decay) * current_a


@quiet
def rc_step(v_rc, current_a, r1_ohm, decay):
    r"""The RC-branch voltage after a step with the current held over it.

    .. math:: v_{k+1} = a\, v_k + R_1 (1 - a)\, i_k, \qquad a = e^{-\Delta t/(R_1 C_1)}

    The exact zero-order-hold solution of :math:`\dot v = -v/(R_1 C_1) + i/C_1`
    ([HESS] eq. 5).

    Parameters
    ----------
    v_rc : numeric
        Branch voltage at the start of the step. [V]
    current_a : numeric
        Current through the branch, discharge positive. [A]
    r1_ohm : numeric
        Branch resistance :math:`R_1`. [Ω]
    decay : numeric
        :math:`a = e^{-\Delta t/(R_1 C_1)}`, the step's decay factor. [unitless]

    Returns
    -------
    v_rc : numeric
        At the end of the step. [V]
    """
    return _rc_step(v_rc, current_a, r1_ohm, decay)


rc_step_jit = compiled(_rc_step)


def _joule_heat(current_a, r0_ohm, v_rc, r1_ohm):
    return current_a * current_a * r0_ohm + v_rc * v_rc / r1_ohm


@quiet
def joule_heat(current_a, r0_ohm, v_rc, r1_ohm):
    r"""Heat generated in the equivalent circuit's resistors.

    .. math:: Q_{gen} = I^2 R_0 + v_{RC}^2 / R_1

    ([HESS] eq. 10): the Joule heat of the ohmic resistance and of the RC branch's
    resistor, whose current is :math:`v_{RC}/R_1`. In steady state (:math:`v_{RC} = I R_1`)
    it is :math:`I^2 (R_0 + R_1)`.

    Parameters
    ----------
    current_a : numeric
        Current through R0. [A]
    r0_ohm : numeric
        Ohmic resistance. [Ω]
    v_rc : numeric
        Voltage across the RC branch. [V]
    r1_ohm : numeric
        Resistance of the RC branch; +inf where there is none. [Ω]

    Returns
    -------
    heat : numeric
        [W]
    """
    return _joule_heat(current_a, r0_ohm, v_rc, r1_ohm)


joule_heat_jit = compiled(_joule_heat)


# --------------------------------------------------------------------------- load

def _loaded_current(power_w, source_v, resistance_ohm):
    return 2.0 * power_w / (source_v + np.sqrt(source_v * source_v
                                               - 4.0 * resistance_ohm * power_w))


@quiet
def loaded_current(power_w, source_v, resistance_ohm):
    r"""The current that delivers ``power_w`` from a source behind a series resistance.

    .. math:: I = \frac{V - \sqrt{V^2 - 4 R P}}{2 R} = \frac{2 P}{V + \sqrt{V^2 - 4 R P}}

    the smaller root of :math:`P = (V - R I) I`, the terminal voltage of [HESS] eq. 2
    times the current; computed in the second form, which has no cancellation and gives
    :math:`P/V` for :math:`R = 0`.

    Parameters
    ----------
    power_w : numeric
        Power drawn at the terminals, discharge positive. [W]
    source_v : numeric
        Source (open-circuit) voltage behind the resistance, > 0. [V]
    resistance_ohm : numeric
        Series resistance, ≥ 0. [Ω]

    Returns
    -------
    current : numeric
        [A]; NaN where :math:`P > V^2/(4R)` (:func:`power_limit`): the source cannot
        deliver the power.
    """
    return _loaded_current(power_w, source_v, resistance_ohm)


loaded_current_jit = compiled(_loaded_current)


def _power_limit(source_v, resistance_ohm):
    return source_v * source_v / (4.0 * resistance_ohm)


@quiet
def power_limit(source_v, resistance_ohm):
    r"""The most power a source behind a series resistance can deliver.

    .. math:: P_{max} = \frac{V^2}{4 R}

    reached at :math:`I = V/(2R)`, where the terminal voltage has fallen to :math:`V/2`
    (the maximum of :math:`P = (V - R I) I`, [HESS] eq. 2).

    Parameters
    ----------
    source_v : numeric
        Source (open-circuit) voltage. [V]
    resistance_ohm : numeric
        Series resistance; 0 gives +inf. [Ω]

    Returns
    -------
    power : numeric
        [W]
    """
    return _power_limit(source_v, resistance_ohm)


power_limit_jit = compiled(_power_limit)


@compiled
def delivered_current(power_w, source_v, resistance_ohm):
    r"""The current a source gives at a power load, and whether it delivers the load.

    :func:`loaded_current` where the source can deliver the power; beyond
    :func:`power_limit` it gives its maximum power, at :math:`I = V/(2R)` (no current
    without a positive source voltage). Compiled only: the step of the time loops.

    Parameters
    ----------
    power_w : float
        Power asked, discharge positive. [W]
    source_v : float
        Source voltage. [V]
    resistance_ohm : float
        Series resistance. [Ω]

    Returns
    -------
    current : float
        [A]
    delivered : bool
        False where the power asked could not be delivered.
    """
    current = loaded_current_jit(power_w, source_v, resistance_ohm)
    if source_v > 0.0 and np.isfinite(current):
        return current, True
    if source_v > 0.0 and resistance_ohm > 0.0:
        return source_v / (2.0 * resistance_ohm), False
    return 0.0, False


# --------------------------------------------------------------------------- pack

def pack_resistance(cell_ohm, cells_series, cells_parallel):
    """Resistance of ``cells_series × cells_parallel`` identical cells: ``R n_s / n_p``.
    [Ω]"""
    return cell_ohm * cells_series / cells_parallel


def cell_resistance(pack_ohm, cells_series, cells_parallel):
    """Resistance of one cell of a pack of ``cells_series × cells_parallel`` identical
    cells (the inverse of :func:`pack_resistance`): ``R n_p / n_s``. [Ω]"""
    return pack_ohm * cells_parallel / cells_series


def pack_capacitance(cell_f, cells_series, cells_parallel):
    """Capacitance of ``cells_series × cells_parallel`` identical cells: ``C n_p / n_s``.
    [F]"""
    return cell_f * cells_parallel / cells_series


pack_resistance_jit = compiled(pack_resistance)
