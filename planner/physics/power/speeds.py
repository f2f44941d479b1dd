r"""Best airspeeds (maximum endurance, maximum range) of any power-against-airspeed curve.

Layer 1: works on a vectorised callable ``P(V)``, so the same search serves the
fixed-wing polar, the propeller-coefficient and the momentum-theory multirotor models,
with the system power and efficiency already inside ``P``.

References
----------
.. [1] J. D. Anderson, Aircraft Performance and Design. Boston, MA, USA: McGraw-Hill,
   1999, ch. 5 (endurance and range; tangent construction for the range speed).
.. [2] R. P. Brent, Algorithms for Minimization without Derivatives. Englewood Cliffs,
   NJ, USA: Prentice-Hall, 1973, ch. 5 (bounded scalar minimisation, as in
   :func:`scipy.optimize.minimize_scalar`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.optimize import minimize_scalar

from planner.physics.numeric import like_inputs
from planner.errors import ModelError

GRID_POINTS = 401
"""Number of airspeeds of the coarse grid before refinement [unitless]."""


class BestSpeeds(NamedTuple):
    """Speeds of maximum endurance and maximum range (unpacks as a 2-tuple)."""

    max_endurance: float | np.ndarray
    """Airspeed of minimum battery power (does not depend on the wind). [m s⁻¹]"""
    max_range: float | np.ndarray
    """Airspeed of minimum energy per ground distance, :math:`P/(V - V_{hw})`; NaN where
    the headwind is at least ``v_max`` (no progress possible). [m s⁻¹]"""


def _refine(objective, grid, values, lo_bound, hi_bound):
    """Bounded Brent refinement around the grid minimum of ``values``."""
    if not np.any(np.isfinite(values)):
        return np.nan
    i = int(np.nanargmin(np.where(np.isfinite(values), values, np.nan)))
    lo = grid[max(i - 1, 0)]
    hi = grid[min(i + 1, len(grid) - 1)]
    lo, hi = max(lo, lo_bound), min(hi, hi_bound)
    if not hi > lo:
        return float(grid[i])
    res = minimize_scalar(objective, bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-6 * max(hi, 1.0)})
    best = float(res.x) if res.success and np.isfinite(res.fun) else float(grid[i])
    # keep the grid point if Brent ended on a worse value (flat or noisy curve)
    return best if objective(best) <= values[i] else float(grid[i])


def best_speeds(power_fn, v_min, v_max, headwind=0.0):
    r"""
    Airspeeds of maximum endurance and maximum range for a power curve.

    Parameters
    ----------
    power_fn : callable
        Vectorised ``P(V)``: battery power [W] against airspeed [m s⁻¹]; called with a
        1-D ndarray of airspeeds and with scalars.
    v_min : float
        Lowest admissible airspeed (stall speed, or 0 for a multirotor), ≥ 0. [m s⁻¹]
    v_max : float
        Highest admissible airspeed, > ``v_min``. [m s⁻¹]
    headwind : numeric, default 0
        Headwind component along the track (negative for a tailwind). An array gives
        one range speed per value. [m s⁻¹]

    Returns
    -------
    speeds : BestSpeeds
        ``(max_endurance, max_range)`` airspeeds [m s⁻¹]; ``max_range`` has the kind of
        ``headwind``.

    Raises
    ------
    ModelError
        If ``v_min`` < 0 or ``v_max`` ≤ ``v_min``.

    Notes
    -----
    Maximum endurance minimises the battery power, maximum range the energy per ground
    distance ([1]_ ch. 5):

    .. math::

        V_E = \arg\min_V P(V), \qquad
        V_R = \arg\min_V \frac{P(V)}{V - V_{hw}}, \quad V - V_{hw} > 0

    A headwind shifts the tangent from the origin to :math:`(V_{hw}, 0)` and so raises
    :math:`V_R`. Each minimum is found on a grid of 401 airspeeds (one vectorised call
    of ``power_fn``), then refined by bounded Brent minimisation ([2]_,
    :func:`scipy.optimize.minimize_scalar`) between the grid neighbours. A minimum at a
    bound returns that bound. For an array of headwinds one scalar refinement runs per
    distinct value. For the fixed-wing polar with :math:`P = P_R/\eta` in still air
    these are :math:`(B/3A)^{1/4}` and :math:`(B/A)^{1/4}`.
    """
    v_min = float(v_min)
    v_max = float(v_max)
    if not v_min >= 0.0:
        raise ModelError(f"v_min must be >= 0 m/s, got {v_min:g}")
    if not v_max > v_min:
        raise ModelError(f"v_max must be > v_min ({v_min:g} m/s), got {v_max:g}")

    grid = np.linspace(v_min, v_max, GRID_POINTS)
    with np.errstate(divide="ignore", invalid="ignore"):
        power = np.asarray(power_fn(grid), dtype=float) * np.ones_like(grid)

    def power_at(v):
        return float(np.asarray(power_fn(v), dtype=float))

    v_endurance = _refine(power_at, grid, power, v_min, v_max)

    hw = np.asarray(headwind, dtype=float)
    unique, inverse = np.unique(hw.ravel(), return_inverse=True)
    v_range_unique = np.full(unique.shape, np.nan)
    for k, h in enumerate(unique):  # one refinement per distinct wind, not per sample
        if not np.isfinite(h):
            continue
        ground = grid - h
        with np.errstate(divide="ignore", invalid="ignore"):
            per_metre = np.where(ground > 0.0, power / ground, np.inf)

        def energy_per_metre(v, h=h):
            g = v - h
            return power_at(v) / g if g > 0.0 else np.inf

        if np.isfinite(per_metre).any():
            v_range_unique[k] = _refine(energy_per_metre, grid, per_metre,
                                        max(v_min, h), v_max)
    v_range = v_range_unique[inverse].reshape(hw.shape)
    return BestSpeeds(v_endurance, like_inputs(v_range, headwind))
