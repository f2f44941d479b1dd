r"""Statistics of the fits: parameter covariance and autocorrelated residuals, in one place.

Every least-squares fit of the planner (the integral capacity model, the equivalent
circuit, the aircraft's power parameters, diagnose's extensions) reports standard errors
from here.

* :func:`jacobian_covariance` — :math:`(J^\mathsf{T} J)^{-1}` through the SVD of the
  column-normalised Jacobian, as ``scipy.optimize.curve_fit`` does. **A singular or
  indeterminate Jacobian** (a zero or non-finite column, or a singular value below
  :math:`\epsilon\,\max(n, p)\,s_{max}`) **gives an infinite covariance**, never a
  pseudo-inverse: the data cannot tell the parameters apart, and a finite standard error
  would claim they can. Callers warn (``curve_fit``'s ``OptimizeWarning``) and report the
  parameters as poorly determined.
* :func:`lag1_autocorrelation` and :func:`ar1_inflation` — residuals of a time series
  are autocorrelated, so they carry fewer independent samples than rows. With the lag-1
  autocorrelation :math:`\rho` of an AR(1) process the effective sample size is
  :math:`n (1 - \rho)/(1 + \rho)` [1]_, and the i.i.d. covariance is inflated by
  :math:`(1 + \rho)/(1 - \rho)`. :math:`\rho` is clipped to :data:`RHO_MAX`.
* :func:`cluster_covariance` — the cluster-robust (sandwich) covariance with one
  cluster per flight [2]_: residuals may be correlated in any way within a flight (a
  payload, a wind, a pack of that flight), only flights are taken as independent.

References
----------
.. [1] G. E. P. Box, G. M. Jenkins, G. C. Reinsel and G. M. Ljung, *Time Series
   Analysis: Forecasting and Control*, 5th ed. Hoboken, NJ, USA: Wiley, 2015, sec. 2.1
   (variance of the mean of an autocorrelated series).
.. [2] A. C. Cameron and D. L. Miller, "A practitioner's guide to cluster-robust
   inference," Journal of Human Resources 50(2), 317–372, 2015 (eq. 11 and the
   small-sample factor :math:`\frac{G}{G-1}\frac{n-1}{n-p}`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["RHO_MAX", "Covariance", "ar1_inflation", "cluster_covariance", "covariance",
           "delta_method",
           "jacobian_covariance", "lag1_autocorrelation"]

#: Largest lag-1 autocorrelation taken: beyond it the AR(1) inflation (39× at 0.95)
#: stops describing the residuals (a drift, not a correlated noise). [unitless]
RHO_MAX = 0.95


@dataclass(frozen=True)
class Covariance:
    """A parameter covariance and how well the data determine it.

    Attributes
    ----------
    matrix : ndarray, shape (p, p)
        Infinite where the Jacobian is singular.
    condition : float
        Condition number of the column-normalised Jacobian (inf when singular).
    singular : bool
    """

    matrix: np.ndarray
    condition: float
    singular: bool

    @property
    def stderr(self) -> np.ndarray:
        """Standard errors, the square roots of the diagonal."""
        return np.sqrt(np.clip(np.diag(self.matrix), 0.0, None))


def jacobian_covariance(jac) -> Covariance:
    """:math:`(J^\\mathsf{T} J)^{-1}` of a Jacobian (module notes), unscaled."""
    jac = np.asarray(jac, float)
    p = jac.shape[1]
    norms = np.linalg.norm(jac, axis=0)
    if jac.shape[0] == 0 or np.any(norms == 0) or not np.all(np.isfinite(jac)):
        return Covariance(np.full((p, p), np.inf), np.inf, True)
    jn = jac / norms
    _, s, vt = np.linalg.svd(jn, full_matrices=False)
    threshold = np.finfo(float).eps * max(jn.shape) * s[0]
    if np.sum(s > threshold) < p:
        return Covariance(np.full((p, p), np.inf), np.inf, True)
    cov_n = (vt.T / s**2) @ vt
    return Covariance(cov_n / np.outer(norms, norms), float(s[0] / s[-1]), False)


def lag1_autocorrelation(resid, groups=None) -> float:
    """Lag-1 autocorrelation of residuals, within groups of consecutive rows (experiments),
    clipped to [0, :data:`RHO_MAX`]."""
    r = np.asarray(resid, float)
    if r.size < 4:
        return 0.0
    r = r - r.mean()
    den = float(np.dot(r, r))
    if den <= 0:
        return 0.0
    same = (np.ones(r.size - 1, bool) if groups is None
            else np.asarray(groups)[1:] == np.asarray(groups)[:-1])
    rho = float(np.dot(r[1:][same], r[:-1][same]) / den)
    return min(max(rho, 0.0), RHO_MAX)


def within_groups(x, groups) -> np.ndarray:
    """``x`` net of the mean of its group (e.g. each experiment's own level)."""
    x = np.asarray(x, float)
    _, inv = np.unique(groups, return_inverse=True)
    return x - (np.bincount(inv, weights=x) / np.bincount(inv))[inv]


def ar1_inflation(rho: float) -> float:
    """Variance inflation :math:`(1 + \\rho)/(1 - \\rho)` of an AR(1) residual. [unitless]"""
    rho = min(max(float(rho), 0.0), RHO_MAX)
    return (1.0 + rho) / (1.0 - rho)


def covariance(jac, resid, groups=None, *, autocorrelated: bool = True) -> Covariance:
    r"""Parameter covariance of a least-squares fit.

    :math:`s^2 (J^\mathsf{T} J)^{-1}` with :math:`s^2 = \mathrm{RSS}/(n - p)`, inflated by
    :func:`ar1_inflation` of the residuals' lag-1 autocorrelation (within ``groups``)
    when ``autocorrelated``.
    """
    resid = np.asarray(resid, float)
    base = jacobian_covariance(jac)
    n, p = np.shape(jac)
    s2 = float(np.dot(resid, resid)) / max(n - p, 1)
    k = ar1_inflation(lag1_autocorrelation(resid, groups)) if autocorrelated else 1.0
    return Covariance(base.matrix * s2 * k, base.condition, base.singular)


def cluster_covariance(jac, resid, groups) -> Covariance:
    r"""Cluster-robust covariance of a least-squares fit, one cluster per group [2]_.

    .. math::

        V = \frac{G}{G-1}\frac{n-1}{n-p}\,(J^\mathsf{T}J)^{-1}
            \Big(\sum_g J_g^\mathsf{T} r_g\, r_g^\mathsf{T} J_g\Big)(J^\mathsf{T}J)^{-1}

    with :math:`G` groups (flights). Fewer than two groups cannot estimate it: the AR(1)
    covariance of :func:`covariance` is returned instead.
    """
    jac = np.asarray(jac, float)
    resid = np.asarray(resid, float)
    groups = np.asarray(groups)
    labels, index = np.unique(groups, return_inverse=True)
    if labels.size < 2:
        return covariance(jac, resid, groups)
    base = jacobian_covariance(jac)
    if base.singular:
        return base
    n, p = jac.shape
    scores = np.zeros((labels.size, p))
    np.add.at(scores, index, jac * resid[:, None])
    meat = scores.T @ scores
    g = labels.size
    factor = g / (g - 1.0) * (n - 1.0) / max(n - p, 1)
    return Covariance(factor * base.matrix @ meat @ base.matrix, base.condition, False)


def delta_method(func, x, cov) -> tuple[np.ndarray, np.ndarray]:
    """Values and standard errors of ``func(x)`` (a vector) for ``x`` with covariance
    ``cov``, by forward differences."""
    x = np.asarray(x, float)
    f0 = np.asarray(func(x), float)
    grad = np.zeros((f0.size, x.size))
    for j in range(x.size):
        h = 1e-6 * max(abs(x[j]), 1e-3)
        xp = x.copy()
        xp[j] += h
        grad[:, j] = (np.asarray(func(xp), float) - f0) / h
    with np.errstate(invalid="ignore"):
        var = np.einsum("ij,jk,ik->i", grad, cov, grad)
    return f0, np.sqrt(np.clip(var, 0.0, None))
