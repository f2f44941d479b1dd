r"""Empirical integral capacity model of [UAV23] (:mod:`planner.physics.references`).

.. math:: \hat C(t)^\beta = \int_0^t \frac{dt}{\delta\, P(t)^\varepsilon}

with charge :math:`\hat C` in A·s, time in s and electric power :math:`P` in W
([UAV23] eq. 14; :func:`stress_rate`, :func:`charge`, :func:`charge_from_stress`). For a
constant power it reduces to :math:`t = \delta P^\varepsilon C^\beta` ([UAV23] eq. 15,
:func:`discharge_time`; Peukert's law written for power), with the literature start
values of eq. 16–17 (:func:`literature_delta`, :func:`literature_epsilon`). A power of
zero or less is a rest: the load is off and the model draws no charge.

The running integral :math:`S(t) = \int_0^t dt / (\delta P^\varepsilon)` is
called the *discharge stress* here; it is additive, while the charge
:math:`\hat C = S^{1/\beta}` is not (for :math:`\beta \ne 1`).
"""

from __future__ import annotations

import numpy as np

from planner.errors import ModelError
from planner.physics.battery.elements import compiled, quiet

#: β of [UAV23] (held fixed in its fits, Table 5). [unitless]
LITERATURE_BETA = 0.9648



def literature_delta(cells_series):
    r"""
    Literature start value :math:`\delta_0(N)` for N cells in series.

    .. math:: \delta_0(N) = -0.1067 N^3 + 0.8960 N^2 + 2.488 N + 0.6299

    [UAV23] eq. 16, the start value of the integral model's δ.

    Parameters
    ----------
    cells_series : numeric
        Number of cells in series. [unitless]
    """
    n = np.asarray(cells_series, dtype=float)
    out = -0.1067 * n**3 + 0.8960 * n**2 + 2.488 * n + 0.6299
    return out if out.ndim else float(out)


def literature_epsilon(cells_series):
    r"""
    Literature start value :math:`\varepsilon_0(N)` for N cells in series.

    .. math:: \varepsilon_0(N) = 2.917\cdot10^{-4} N^3 - 1.375\cdot10^{-3} N^2
              + 3.083\cdot10^{-3} N - 1.041

    [UAV23] eq. 17.
    """
    n = np.asarray(cells_series, dtype=float)
    out = 2.917e-4 * n**3 - 1.375e-3 * n**2 + 3.083e-3 * n - 1.041
    return out if out.ndim else float(out)


def scale_to_pack(delta, epsilon, beta, cells_series, cells_parallel=1):
    r"""δ of a pack of ``cells_series`` × ``cells_parallel`` identical cells, from the
    integral model of one cell (ε and β are the cell's).

    Every cell of the pack carries :math:`P_c = P / (S P_n)` and gives
    :math:`C_c = C / P_n` of the pack's charge, so the cell's law
    :math:`t = \delta_c P_c^\varepsilon C_c^\beta` ([UAV23] eq. 15) is, for the pack,

    .. math:: t = \delta_c (S P_n)^{-\varepsilon} P_n^{-\beta}\; P^\varepsilon C^\beta,
              \qquad \delta = \delta_c (S P_n)^{-\varepsilon} P_n^{-\beta}

    and the same holds for the integral form (eq. 14) at any power profile. Cell-to-cell
    spread and the wiring's losses are neglected. With ε ≈ −1.04 this makes δ grow
    about as :math:`S^{1.04}`, as the literature start values of eq. 16 do
    (δ₀(4)/δ₀(2) = 2.17 against 2^1.04 = 2.06): δ depends on the number of cells, which
    editing ``cells_series`` of a pack file does not change.

    Parameters
    ----------
    delta, epsilon, beta : float
        The cell's model. [s W^-ε (A s)^-β], [unitless], [unitless]
    cells_series, cells_parallel : int
        The pack's arrangement (S, P_n ≥ 1).
    """
    if cells_series < 1 or cells_parallel < 1:
        raise ModelError(f"a pack needs at least one cell in series and in parallel, got "
                         f"{cells_series}S{cells_parallel}P")
    return float(delta * (cells_series * cells_parallel) ** (-epsilon)
                 * cells_parallel ** (-beta))


def _check(delta, beta):
    if np.any(np.asarray(delta) <= 0):
        raise ModelError(f"integral model: delta must be > 0, got {delta}")
    if np.any(np.asarray(beta) <= 0):
        raise ModelError(f"integral model: beta must be > 0, got {beta}")


def stress_rate(power_w, delta, epsilon):
    r"""
    Integrand :math:`1/(\delta P^\varepsilon)` of [UAV23] eq. 14; zero where the load is off.

    Parameters
    ----------
    power_w : numeric
        Electric power drawn from the pack; ``<= 0`` is a rest. [W]
    delta, epsilon : numeric
        Model parameters (δ in s·W^-ε·(A s)^-β). [unitless]

    Returns
    -------
    rate : numeric
        d S / d t; NaN where the power is NaN. [(A s)^β / s]
    """
    p = np.asarray(power_w, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        lp = np.where(p > 0, np.log(np.where(p > 0, p, 1.0)), np.where(np.isnan(p), np.nan,
                                                                      -np.inf))
    rate = stress_rate_from_log_power(lp, delta, epsilon)
    return rate if rate.ndim else float(rate)


def stress_rate_from_log_power(log_power, delta, epsilon):
    r""":func:`stress_rate` from :math:`\ln P`: :math:`e^{-\varepsilon \ln P}/\delta`.

    ``log_power`` of −inf is a rest (rate 0); NaN propagates. The form the mission chain
    uses, whose power table holds :math:`\ln P`. [(A s)^β / s]
    """
    lp = np.asarray(log_power, float)
    with np.errstate(over="ignore", invalid="ignore"):
        rate = np.asarray(np.multiply(-np.asarray(epsilon, float), lp))
        if rate.ndim:
            np.exp(rate, out=rate)
        rate = np.asarray(np.exp(rate) if not rate.ndim else rate) / np.asarray(delta, float)
    off = ~np.isfinite(lp)
    if off.any():
        rate = np.where(off, np.where(np.isnan(lp), np.nan, 0.0), rate)
    return rate


def stress_piecewise(duration_s, power_w, delta, epsilon):
    """Cumulative stress at the end of piecewise-constant segments (exact).

    Parameters
    ----------
    duration_s : array_like
        Segment durations, last axis = segments. [s]
    power_w : array_like
        Constant power in each segment (broadcast against ``duration_s``). [W]

    Returns
    -------
    stress : ndarray
        :math:`S` at the end of each segment. [(A s)^β]
    """
    return np.cumsum(np.asarray(duration_s, float) * stress_rate(power_w, delta, epsilon),
                     axis=-1)


def _charge_from_stress(stress, beta):
    return np.exp(np.log(np.maximum(stress, 0.0)) / beta)


@quiet
def charge_from_stress(stress, beta):
    r"""Charge drawn from the discharge stress, :math:`\hat C = S^{1/\beta}`.

    [UAV23] eq. 14 solved for the charge; the one home of this rule (the mission chain's
    compiled kernels call its twin ``charge_from_stress_jit``).

    Parameters
    ----------
    stress : numeric
        Discharge stress :math:`S`; S ≤ 0 (nothing drawn) gives 0, NaN stays NaN.
        [(A s)^β]
    beta : numeric
        Integral model exponent β, > 0. [unitless]

    Returns
    -------
    charge : numeric
        [A s]
    """
    return _charge_from_stress(stress, beta)


charge_from_stress_jit = compiled(_charge_from_stress)


def stress_from_charge(charge_as, beta):
    """Inverse of :func:`charge_from_stress`: :math:`S = C^\\beta`. [(A s)^β]"""
    c = np.clip(np.asarray(charge_as, dtype=float), 0.0, None)
    out = c**beta
    return out if out.ndim else float(out)


def charge(time_s, power_w, delta, epsilon, beta=LITERATURE_BETA):
    r"""
    Charge drawn along a sampled power profile, :math:`\hat C(t)`.

    Parameters
    ----------
    time_s : array_like
        Sample times, increasing. [s]
    power_w : array_like
        Electric power at those times; ``<= 0`` is a rest. [W]
    delta, epsilon, beta : float
        Integral model parameters.

    Returns
    -------
    charge : ndarray
        Charge drawn since ``time_s[0]``. [A s]

    Notes
    -----
    [UAV23] eq. 14 by trapezoidal cumulative integration of :math:`1/(\delta P^\varepsilon)`
    (vectorised, no per-sample loop), then :math:`\hat C = S^{1/\beta}`.
    """
    _check(delta, beta)
    t = np.asarray(time_s, dtype=float)
    rate = np.asarray(stress_rate(power_w, delta, epsilon), dtype=float)
    if t.size == 0:
        return np.zeros(0)
    from scipy.integrate import cumulative_trapezoid   # imported where used: start-up time

    stress = cumulative_trapezoid(rate, t, initial=0.0)
    return charge_from_stress(stress, beta)


def discharge_time(power_w, charge_as, delta, epsilon, beta=LITERATURE_BETA):
    r"""
    Time to draw ``charge_as`` at constant power: :math:`t = \delta P^\varepsilon C^\beta`
    ([UAV23] eq. 15).

    Parameters
    ----------
    power_w : numeric
        Constant electric power, > 0. [W]
    charge_as : numeric
        Charge to draw. [A s]

    Returns
    -------
    time : numeric
        [s]
    """
    _check(delta, beta)
    p = np.asarray(power_w, dtype=float)
    out = delta * p**epsilon * np.asarray(charge_as, dtype=float) ** beta
    return out if out.ndim else float(out)


def time_to_charge(stress_now, power_w, charge_limit_as, delta, epsilon, beta):
    """Time at constant power until the drawn charge reaches ``charge_limit_as``.

    Negative when the limit is already passed. [s]
    """
    _check(delta, beta)
    limit = stress_from_charge(charge_limit_as, beta)
    p = np.asarray(power_w, dtype=float)
    out = (limit - np.asarray(stress_now, float)) * delta * p**epsilon
    return out if out.ndim else float(out)
