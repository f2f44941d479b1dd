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
* :func:`random_walk_covariance` — the sandwich for a residual that is a random walk
  within each experiment (a measured charge, the integral of a noisy current): the
  integral model's fit (:mod:`planner.identify.battery_fit`, whose notes derive it).
* :func:`poorly_determined` — the one rule that names a parameter the data do not
  determine: a standard error that is not finite or exceeds a share of the value. The
  share is the fit's (10 % for the integral model, 50 % for an aircraft's power
  parameters; each module says why).

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

import math
import warnings
from dataclasses import dataclass

import numpy as np

__all__ = ["RHO_MAX", "Covariance", "ar1_inflation", "cluster_covariance", "covariance",
           "delta_method", "jacobian_covariance", "lag1_autocorrelation",
           "poorly_determined", "random_walk_covariance", "scaled_covariance",
           "within_groups"]

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
        """Standard errors, the square roots of the diagonal. [units of the parameters]"""
        return np.sqrt(np.clip(np.diag(self.matrix), 0.0, None))

    def warn_if_singular(self, what: str, category=UserWarning, stacklevel: int = 1) -> None:
        """Warn (``curve_fit``'s practice) that the covariance of ``what`` is indeterminate
        when the Jacobian is singular; ``stacklevel`` as :func:`warnings.warn`'s, counted
        from the caller (1: the line that calls this)."""
        if self.singular:
            warnings.warn(f"covariance of {what} is indeterminate (singular Jacobian)",
                          category, stacklevel=stacklevel + 1)


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
    """``x`` net of the mean of its group (e.g. each experiment's own level). [unit of x]"""
    x = np.asarray(x, float)
    _, inv = np.unique(groups, return_inverse=True)
    return x - (np.bincount(inv, weights=x) / np.bincount(inv))[inv]


def ar1_inflation(rho: float) -> float:
    """Variance inflation :math:`(1 + \\rho)/(1 - \\rho)` of an AR(1) residual. [unitless]"""
    rho = min(max(float(rho), 0.0), RHO_MAX)
    return (1.0 + rho) / (1.0 - rho)


def scaled_covariance(jac, rss: float) -> Covariance:
    r"""The least-squares covariance for independent residuals,
    :math:`s^2 (J^\mathsf{T} J)^{-1}` with :math:`s^2 = \mathrm{RSS}/(n - p)` for the
    ``n`` rows and ``p`` columns of ``jac`` (``curve_fit``'s ``pcov``); infinite where the
    Jacobian is singular. [units of the parameters²]"""
    base = jacobian_covariance(jac)
    n, p = np.shape(jac)
    return Covariance(base.matrix * (float(rss) / max(n - p, 1)), base.condition,
                      base.singular)


def covariance(jac, resid, groups=None, *, autocorrelated: bool = True) -> Covariance:
    r"""Parameter covariance of a least-squares fit.

    :math:`s^2 (J^\mathsf{T} J)^{-1}` with :math:`s^2 = \mathrm{RSS}/(n - p)`
    (:func:`scaled_covariance`), inflated by :func:`ar1_inflation` of the residuals'
    lag-1 autocorrelation (within ``groups``) when ``autocorrelated``. [units of the
    parameters²]
    """
    resid = np.asarray(resid, float)
    base = scaled_covariance(jac, float(np.dot(resid, resid)))
    k = ar1_inflation(lag1_autocorrelation(resid, groups)) if autocorrelated else 1.0
    return Covariance(base.matrix * k, base.condition, base.singular)


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


def random_walk_covariance(jac, resid, time_s, starts, lengths, *, lag_fraction: float
                           ) -> tuple[Covariance, Covariance, float]:
    r"""Covariance of a least-squares fit whose residual is a random walk within each
    experiment (module notes of :mod:`planner.identify.battery_fit`).

    With :math:`r_i = \sum_{k \le i} e_k` and independent increments of variance
    :math:`\sigma_j^2 \Delta t_k` in experiment *j*,

    .. math:: \Sigma = (J^T J)^{-1} \Big[\sum_j \sigma_j^2 \sum_k \Delta t_k\,
              T_k T_k^T\Big] (J^T J)^{-1}, \qquad T_k = \sum_{i \ge k} J_i ,

    :math:`\sigma_j^2` the mean of :math:`(r_{i+m} - r_i)^2/(t_{i+m} - t_i)` at the lag
    :math:`m` = ``lag_fraction`` of the experiment's samples (at least 1).

    Parameters
    ----------
    jac, resid : ndarray
        Jacobian (n × p) and residuals (n) of the fit, experiments stacked.
    time_s : ndarray
        Time of each row, from each experiment's start. [s]
    starts, lengths : sequence of int
        First row and number of rows of each experiment.
    lag_fraction : float
        Lag of the differences, as a fraction of an experiment's samples. [unitless]

    Returns
    -------
    (Covariance, Covariance, float)
        The random-walk sandwich; the i.i.d. :math:`s^2 (J^T J)^{-1}` (infinite with no
        degree of freedom left), for comparison; the lag-1 autocorrelation of the
        residuals about each experiment's mean, pooled. Both covariances are infinite
        where the Jacobian is singular.
    """
    jac = np.asarray(jac, float)
    r = np.asarray(resid, float)
    n, p = jac.shape
    base = jacobian_covariance(jac)
    bread, cond, singular = base.matrix, base.condition, base.singular
    rss = float(np.dot(r, r))
    meat = np.zeros((p, p))
    num = den = 0.0
    for a, m in zip(starts, lengths):
        rj, jj, tj = r[a:a + m], jac[a:a + m], time_s[a:a + m]
        lag = max(1, round(lag_fraction * m))
        span = tj[lag:] - tj[:-lag]
        ok = span > 0
        s2 = float(np.mean((rj[lag:] - rj[:-lag])[ok] ** 2 / span[ok])) if ok.any() else 0.0
        tails = np.cumsum(jj[::-1], axis=0)[::-1][1:]
        meat += s2 * (tails * np.diff(tj)[:, None]).T @ tails
        seg = rj - rj.mean()
        num += float(np.dot(seg[1:], seg[:-1]))
        den += float(np.dot(seg, seg))
    rho = num / den if den > 0 else 0.0
    if singular:
        return base, base, rho
    iid = bread * (rss / (n - p) if n > p else np.inf)
    return Covariance(bread @ meat @ bread, cond, False), Covariance(iid, cond, False), rho


def poorly_determined(values: dict[str, float], stderr: dict[str, float],
                      limit: float) -> list[str]:
    """The parameters the data do not determine: those whose standard error is not
    finite or exceeds ``limit`` × |value| (the value taken as at least 1e-12), in the
    order of ``values``.

    Parameters
    ----------
    values, stderr : dict of str to float
        Fitted values and their standard errors, by name (``stderr`` holds every name of
        ``values``). [units of each parameter]
    limit : float
        Largest relative standard error of a determined parameter. [unitless]

    Returns
    -------
    list of str
    """
    return [k for k, v in values.items()
            if not math.isfinite(stderr[k]) or stderr[k] > limit * max(abs(v), 1e-12)]


def delta_method(func, x, cov) -> tuple[np.ndarray, np.ndarray]:
    """Values and standard errors of ``func(x)`` (a vector) for ``x`` with covariance
    ``cov``, by forward differences (first-order error propagation). [units of func]"""
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
