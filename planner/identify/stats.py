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
* :func:`effective_clusters` and :func:`few_clusters_critical` — how many clusters carry
  an estimate (G* [5]_), and the t critical value to judge it by where they are fewer
  than :data:`MIN_CLUSTERS`.
* :func:`random_walk_covariance` — the sandwich for a residual that is a random walk
  within each experiment (a measured charge, the integral of a noisy current): the
  integral model's fit (:mod:`planner.identify.battery_fit`, whose notes derive it).
* :func:`poorly_determined` — the one rule that names a parameter the data do not
  determine: a standard error that is not finite or exceeds a share of the value. The
  share is the fit's (10 % for the integral model, 50 % for an aircraft's power
  parameters; each module says why).
* :func:`detectable_size` and :func:`noncentrality_for_power` — the power analysis of
  ``diagnose``'s detection limits: the smallest size of an effect, given its signature
  (the change it makes to the fitted quantity per unit of its parameter), the nuisance
  columns it must be told apart from (the baseline's own parameters and the other
  candidates), and the noise of the residuals, that a test at level α finds with the
  given power [3]_, and that lowers the held-out error by the practical share.

References
----------
.. [1] G. E. P. Box, G. M. Jenkins, G. C. Reinsel and G. M. Ljung, *Time Series
   Analysis: Forecasting and Control*, 5th ed. Hoboken, NJ, USA: Wiley, 2015, sec. 2.1
   (variance of the mean of an autocorrelated series).
.. [2] A. C. Cameron and D. L. Miller, "A practitioner's guide to cluster-robust
   inference," Journal of Human Resources 50(2), 317–372, 2015 (eq. 11 and the
   small-sample factor :math:`\frac{G}{G-1}\frac{n-1}{n-p}`).
.. [3] J. Cohen, *Statistical Power Analysis for the Behavioral Sciences*, 2nd ed.
   Hillsdale, NJ, USA: Erlbaum, 1988, ch. 9 (power of the F and χ² tests through the
   noncentrality parameter λ); the χ² form with λ = θᵀ(XᵀX)θ/σ² for a linear
   regression's added columns, e.g. S. D. Silvey, *Statistical Inference*, Chapman &
   Hall, 1975, sec. 7.
.. [4] L. Kish, *Survey Sampling*, New York: Wiley, 1965, sec. 5.4 (the design effect:
   the variance of an estimate under the clustered design over its variance under the
   simple one).
.. [5] A. V. Carter, K. T. Schnepel and D. G. Steigerwald, "Asymptotic behavior of a
   t-test robust to cluster heterogeneity," Review of Economics and Statistics 99(4),
   698–709, 2017 (the effective number of clusters G*).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

__all__ = ["RHO_MAX", "Covariance", "DetectionLimit", "ar1_inflation", "cluster_covariance",
           "covariance", "delta_method", "design_effect", "detectable_size", "jacobian_covariance",
           "lag1_autocorrelation", "long_run_variance", "noncentrality_for_power",
           "paired_test_factor",
           "poorly_determined", "practical_size", "project_out", "random_walk_covariance",
           "scaled_covariance", "within_groups"]

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



# ============================================================================ power analysis

def noncentrality_for_power(df: int, alpha: float = 0.05, power: float = 0.8,
                            critical: float | None = None) -> float:
    r"""The noncentrality λ at which a χ² test with ``df`` degrees of freedom at level
    ``alpha`` rejects with probability ``power`` [3]_: :math:`P(\chi^2_{df}(\lambda) >
    \chi^2_{df,1-\alpha}) = power`. For one degree of freedom √λ ≈ z₁₋α/₂ + z_power
    (2.80 at 5 % and 80 %). ``critical``: a threshold of the statistic of its own instead
    of the χ² quantile (e.g. a BIC-like 2 ln n). [unitless]"""
    from scipy.optimize import brentq
    from scipy.stats import chi2, ncx2

    crit = float(chi2.ppf(1.0 - alpha, df)) if critical is None else float(critical)
    return float(brentq(lambda lam: float(ncx2.sf(crit, df, lam)) - power, 1e-9, 1e4))


def project_out(columns: np.ndarray, nuisance: np.ndarray | None) -> np.ndarray:
    """``columns`` (n × k) less their least-squares fit on ``nuisance`` (n × p): the part
    of an effect's signature the nuisance parameters cannot absorb. [unit of columns]"""
    cols = np.asarray(columns, float).reshape(len(columns), -1)
    if nuisance is None or np.size(nuisance) == 0:
        return cols
    X = np.asarray(nuisance, float).reshape(len(columns), -1)
    ok = np.all(np.isfinite(X), axis=0) & (np.linalg.norm(X, axis=0) > 0)
    if not ok.any():
        return cols
    X = X[:, ok]
    coef, *_ = np.linalg.lstsq(X / np.linalg.norm(X, axis=0), cols, rcond=None)
    return cols - (X / np.linalg.norm(X, axis=0)) @ coef


def step_robust_long_run_variance(r) -> float:
    """Long-run variance σ²(1+ρ)/(1−ρ) of a residual series, robust to a step in it: the
    noise a change point is located against (:meth:`planner.identify.diagnose.search.PowerLevel._scan`)
    and the detection limit of a change predicts it with
    (:func:`planner.identify.diagnose.limits._payload`), so that a change not yet fitted
    does not count as noise. [unit of r²]

    σ² from differences at a lag beyond the short-range correlation, ρ from the lag-1
    differences; a single step touches only a few of either.
    """
    r = np.asarray(r, float)
    n = len(r)
    lag = max(1, min(10, n // 4))
    s2 = float(np.mean((r[lag:] - r[:-lag]) ** 2)) / 2.0
    if s2 <= 0:
        return 0.0
    v1 = float(np.mean(np.diff(r) ** 2))
    rho = min(max(1.0 - v1 / (2.0 * s2), 0.0), 0.95)
    return s2 * (1 + rho) / (1 - rho)


def long_run_variance(resid, groups=None, dof: int = 0) -> float:
    r"""σ²(1 + ρ)/(1 − ρ) of a residual series: the variance per row that a sum over
    autocorrelated rows carries (AR(1), :func:`ar1_inflation`); σ² = RSS/(n − dof).
    [unit of resid²]"""
    r = np.asarray(resid, float)
    n = r.size
    if n <= dof + 1:
        return math.inf
    s2 = float(np.dot(r, r)) / (n - dof)
    return s2 * ar1_inflation(lag1_autocorrelation(r, groups))


@dataclass(frozen=True)
class DetectionLimit:
    """The smallest size of an effect that its tests find (:func:`detectable_size`).

    Attributes
    ----------
    limit : float
        The larger of ``statistical`` and ``practical`` (inf when the signature is
        absorbed entirely). [unit of the effect's parameter]
    statistical : float
        The size the χ² test at level α finds with the given power. [same]
    practical : float
        The size that lowers the held-out error by the practical share. [same]
    stderr : float
        Standard error of the parameter along its least visible direction. [same]
    visible_share : float
        Share of the signature's sum of squares left after the nuisance columns
        (0: absorbed entirely, 1: orthogonal to them). [unitless]
    design_effect : float
        Factor (≥ 1) by which the scatter between clusters (flights) raises the estimate's
        variance above the autocorrelated residual's (:func:`design_effect`); 1 without
        clusters. [unitless]
    """

    limit: float
    statistical: float
    practical: float
    stderr: float
    visible_share: float
    design_effect: float = 1.0


def paired_test_factor(alpha: float = 0.05, power: float = 0.8) -> float:
    r"""The size, in standard errors, at which a one-sided paired test on held-out losses
    rejects at level ``alpha`` with probability ``power``: :math:`2(z_{1-\alpha} +
    z_{power})`, 4.97 at 5 % and 80 % (:func:`detectable_size`). [unitless]"""
    from scipy.stats import norm

    return 2.0 * float(norm.ppf(1.0 - alpha) + norm.ppf(power))


def detectable_size(signature, nuisance, resid, groups=None, *, dof: int = 0,
                    alpha: float = 0.05, power: float = 0.8,
                    heldout_mse: float | None = None, min_gain: float = 0.05,
                    paired: bool = False, clusters=None) -> DetectionLimit:
    r"""Power analysis of one effect on one fitted quantity (module notes, [3]_).

    An effect of size θ adds :math:`\theta\,s` to the fitted quantity (``signature`` s,
    n × k for k parameters: the change per unit of the parameter, e.g. a column of ones
    for a constant load in watts). What the nuisance columns (the baseline's own
    parameters, the other candidates) can absorb is not visible: :math:`s_\perp` is s
    less its fit on them (:func:`project_out`). With the residual's long-run variance
    :math:`\sigma^2_{LR}` (:func:`long_run_variance`) the estimate's covariance is
    :math:`\sigma^2_{LR} (s_\perp^\mathsf{T} s_\perp)^{-1}`; along its least visible
    direction the standard error is SE. The χ² test of the k added parameters at level
    α rejects with probability ``power`` from :math:`\theta = \sqrt{\lambda}\,SE`
    (:func:`noncentrality_for_power`): the statistical limit. The held-out mean squared
    error ``heldout_mse`` falls by the share ``min_gain`` of the root mean square when
    :math:`\theta^2\,\overline{s_\perp^2} \ge ((1 - g)^{-2} - 1)\,MSE`: the practical
    limit. Both are in the unit of the parameter.

    With ``paired``, the effect must also pass a one-sided paired test on the held-out
    losses: for each held-out row the loss without the effect exceeds the one with it by
    :math:`\theta^2 s_i^2 + 2\theta s_i e_i` (e the noise), so their sum has mean
    :math:`\theta^2 \lVert s\rVert^2` and standard deviation
    :math:`2\theta\sigma_{LR}\lVert s\rVert`, and the test rejects with the given power
    from :math:`\theta = 2(z_{1-\alpha} + z_{power})\,SE`
    (:func:`paired_test_factor`) — the stricter of the two statistical tests.

    With ``clusters`` (the flight of each row), the residual's long-run variance is
    raised by the :func:`design_effect` of the scatter between flights along the
    signature: a flight-to-flight difference no within-flight noise model sees (a day's
    weather, a pack, a route the power model fits less well) makes an effect carried by
    whole flights harder to see than the bins' noise says.

    Parameters
    ----------
    signature : ndarray, shape (n,) or (n, k)
        Change of the fitted quantity per unit of each parameter. [fitted unit / unit]
    nuisance : ndarray, shape (n, p), or None
        Columns the effect must be told apart from.
    resid : ndarray, shape (n,)
        Residuals of the fit without the effect. [fitted unit]
    groups : array, optional
        Experiment of each row (the autocorrelation is taken within them).
    dof : int
        Parameters fitted to ``resid`` (for σ²).
    alpha, power : float
        Level and power of the test. [unitless]
    heldout_mse : float, optional
        Held-out mean squared error of the fit [fitted unit²]; None: no practical limit.
    min_gain : float
        Practical share of the held-out RMS error. [unitless]
    clusters : array, optional
        Cluster (flight) of each row, for :func:`design_effect`; None: none.
    """
    s = np.asarray(signature, float).reshape(len(resid), -1)
    total = float(np.sum(s * s))
    sp = project_out(s, nuisance)
    gram = sp.T @ sp
    visible = float(np.trace(gram)) / total if total > 0 else 0.0
    k = s.shape[1]
    eig = np.linalg.eigvalsh(gram) if k > 1 else np.array([float(gram[0, 0])])
    low = float(eig.min())
    if not (low > 1e-12 * max(total, 1e-300)):
        return DetectionLimit(math.inf, math.inf, math.inf, math.inf, visible)
    deff = 1.0 if clusters is None else design_effect(sp, resid, clusters, groups, dof)
    s2 = long_run_variance(resid, groups, dof) * deff
    se = math.sqrt(s2 / low)
    stat = math.sqrt(noncentrality_for_power(k, alpha, power)) * se
    if paired:
        stat = max(stat, paired_test_factor(alpha, power) * se)
    prac = 0.0
    if heldout_mse is not None and math.isfinite(heldout_mse):
        prac = practical_size(low / len(resid), heldout_mse, min_gain)
    return DetectionLimit(max(stat, prac), stat, prac, se, visible, deff)


#: Fewest clusters for :func:`design_effect` to be estimated. [unitless]
MIN_CLUSTERS = 4


def effective_clusters(jac, direction, groups) -> float:
    r"""Effective number of clusters :math:`G^*` behind the estimate of
    :math:`a^\mathsf{T}\theta` (``direction`` a) of a least-squares fit with Jacobian
    ``jac``, one cluster per group (Carter, Schnepel and Steigerwald [5]_, :math:`G^*(0)`):
    with :math:`\gamma_g = a^\mathsf{T} A J_g^\mathsf{T} J_g A\, a`, :math:`A =
    (J^\mathsf{T}J)^{-1}`, each cluster's share of the estimate's variance under
    independent errors, :math:`G^* = (\sum_g \gamma_g)^2 / \sum_g \gamma_g^2`. Equal
    shares give the number of clusters; an estimate that three of sixteen flights carry
    has about three. A cluster-robust variance rests on that many scores, and a test
    of it on a t distribution with :math:`G^* - 1` degrees of freedom
    (:func:`few_clusters_critical`). NaN for a singular fit. [unitless]"""
    jac = np.asarray(jac, float)
    a = np.asarray(direction, float)
    base = jacobian_covariance(jac)
    if base.singular:
        return math.nan
    w = base.matrix @ a                               # A a
    labels, index = np.unique(np.asarray(groups), return_inverse=True)
    proj = jac @ w                                    # J_g A a, stacked
    gamma = np.bincount(index, weights=proj**2, minlength=labels.size)
    total = float(gamma.sum())
    return total**2 / float(np.dot(gamma, gamma)) if total > 0 else math.nan


def few_clusters_critical(g_star: float, alpha: float = 0.05) -> float | None:
    r"""The two-sided critical value of a test whose cluster-robust variance rests on
    :math:`G^*` effective clusters (:func:`effective_clusters`), where :math:`G^*` is
    below :data:`MIN_CLUSTERS`: Student's t with :math:`G^* - 1` degrees of freedom
    (at least 1; Cameron and Miller [2]_, sec. VI.C; Carter, Schnepel and Steigerwald
    [5]_). None from :data:`MIN_CLUSTERS` on, where the normal reference stands.
    [unitless]"""
    from scipy.stats import t

    if not math.isfinite(g_star) or g_star >= MIN_CLUSTERS:
        return None
    return float(t.ppf(1.0 - alpha / 2.0, max(g_star - 1.0, 1.0)))


def design_effect(visible, resid, clusters, groups=None, dof: int = 0) -> float:
    r"""Design effect of clustered rows on an effect's estimate (Kish 1965 [4]_): the
    cluster-robust variance of the estimate (:func:`cluster_covariance`'s sandwich,
    one cluster per flight [2]_) over the variance the autocorrelated residual gives it
    (:func:`long_run_variance`), along the least visible direction of ``visible`` (the
    signature net of the nuisance columns, n × k), at least 1. [unitless]

    Both are taken from the residual with the effect fitted (``resid`` less its
    least-squares fit on ``visible``): a sandwich's scores are those of the model that
    holds the parameter, so an effect present in ``resid`` does not count as scatter.
    Fewer than :data:`MIN_CLUSTERS` clusters cannot estimate it: 1.
    """
    x = np.asarray(visible, float).reshape(len(resid), -1)
    if np.unique(np.asarray(clusters)).size < MIN_CLUSTERS:
        return 1.0
    r = np.asarray(resid, float)
    coef, *_ = np.linalg.lstsq(x, r, rcond=None)
    e = r - x @ coef
    k = x.shape[1]
    if k > 1:
        _, v = np.linalg.eigh(x.T @ x)
        x = x @ v[:, :1]
    within = long_run_variance(e, groups, dof + k) / float(np.dot(x[:, 0], x[:, 0]))
    between = float(cluster_covariance(x, e, clusters).matrix[0, 0])
    if not (within > 0 and math.isfinite(within)):
        return 1.0
    return max(1.0, between / within)


def practical_size(mean_square: float, heldout_mse: float, min_gain: float = 0.05) -> float:
    r"""The size θ of an effect whose visible signature has mean square ``mean_square``
    per unit θ² that lowers a held-out root-mean-square error of ``heldout_mse`` (its
    square) by the share ``min_gain``: :math:`\theta^2 m = ((1-g)^{-2} - 1)\,MSE`
    (:func:`detectable_size`). [unit of the parameter]"""
    if not mean_square > 0:
        return math.inf
    return math.sqrt(((1.0 - min_gain) ** -2 - 1.0) * heldout_mse / mean_square)
