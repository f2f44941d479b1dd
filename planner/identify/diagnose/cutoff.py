r"""The cut-off level of ``diagnose``: the energy each discharge delivered to its cut-off.

Why a third level
-----------------
The capacity level fits the charge drawn against the energy drawn along each record. A
loss of capacity (an ageing pack, a cold pack) hardly changes that ratio: at constant
current an aged cell runs through the same voltage curve, only faster, so it mostly
*ends sooner*. The direct evidence of a capacity is where a discharge reaches its
cut-off voltage: the energy delivered by then is the pack's usable energy at that load
and temperature. This level uses exactly that, one row per discharge that ends at the
cut-off, and it is what the planner's endurance needs: the planner's pack is empty when
the integral model's charge, scaled by
:meth:`planner.parameters.IntegralModel.charge_scale`, reaches the capacity, so a scale
:math:`s` leaves :math:`1/s` of the energy.

Which discharges count
----------------------
An experiment *ends at the cut-off* when the lowest voltage of its last
:data:`TAIL_SHARE` of samples (at least 3) is at most the pack's empty voltage
(``cell_voltage_empty_v`` × cells in series), and it *starts full* when the highest
voltage of its first :data:`TAIL_SHARE` of samples is at least the full open-circuit
voltage of the pack's chemistry (:mod:`planner.physics.battery.chemistry`) less
:data:`FULL_MARGIN_V` per cell (a charged cell under load: 3.8 V for a LiPo; a partly
charged pack reads less). Of those, the
ones whose end voltage lies within :data:`CUTOFF_SPREAD_V` per cell of their median share
one cut-off and are used; at least :data:`MIN_CUTOFF_EXPERIMENTS` are needed (the paired
held-out test needs six units).

Model
-----
.. math::

    \ln E_j = c_0 + a\,(\bar I_j / I_{ref} - 1) - \ln\Big(1 + \sum_e \theta_e\,z_{e,j}\Big)

:math:`E_j` the energy to the cut-off [J], :math:`\bar I_j = Q_j / T_j` the discharge's
mean current (charge over duration) and :math:`I_{ref}` their median. The rate term
(linear in the current: the ohmic loss :math:`I^2 R` per unit of charge grows with the
current; on the Samsung 30Q rate tests, C/10 to 4C, :math:`\ln E` is linear in the
current within 0.3 %) is fitted only where the mean currents differ by a factor
:data:`MIN_RATE_RATIO`; otherwise it cannot be told from :math:`c_0` (and no effect can
be confounded with it). The effects are the planner's charge scale:
``capacity_fade`` :math:`z = n` (the cycle), ``temperature`` :math:`z = \bar h`, the
charge-weighted mean of the hinge :math:`\max(T_{ref} - T, 0)` over the discharge
(:meth:`planner.parameters.IntegralModel.extend_charge` scales each increment of charge
by :math:`1 + k h`). :math:`c_0, a` are solved in closed form, :math:`\theta` by bounded
least squares.

Fade law
--------
The planner's charge scale :math:`1 + \varphi n` has the pack hold :math:`1/(1 + \varphi n)`
of its energy after n cycles; the other common law, a capacity that falls linearly with
the cycles, :math:`1 - a n` (the linear ageing regime: e.g. Ecker et al. 2014, Journal
of Power Sources 248, 839–851), is as plausible. The two agree while the fade is small;
over 20–25 % they bend differently, and the fresh pack's energy :math:`c_0` is not
known, so the fitted φ follows the curvature of the law fitted over the discharges'
cycles. The capacity fade is fitted once more with the linear law, expressed as the
charge scale that matches it from a fresh pack (both 1 at n = 0; least squares of
:math:`\ln(1 + \varphi n) + \ln(1 - a n)` over the discharges' cycles), and the
difference (``fade_per_cycle_law_shift``) is added in quadrature to φ's standard error,
as the bias a law of the wrong form would put into it.

Splits and statistics are those of :mod:`planner.identify.diagnose.search` with whole experiments
held out (experiment *i* to fold *i* mod min(4, n)); each held-out discharge is one test
unit. The held-out error is the error of the predicted energy at the cut-off in % (the
residual of :math:`\ln E`, × 100), the final error :math:`\sum|E - \hat E| / \sum E`:
the common currency of all levels. Standard errors are
:math:`s^2 (J^\mathsf{T}J)^{-1}` with :math:`s^2 = RSS/(n - p)`: the discharges' own
spread (cell to cell) is in :math:`s`.

Ageing gives no capacity back
-----------------------------
Without a cycle count the discharges' age is their order in the files, and without a
pack temperature a cold discharge is only a discharge that gave less. Where the cold
ones happen to lie late in the order (the Molicel P42A discharges of the effect matrix,
half of them chilled to 0 °C: on one draw 4 of 8, at positions 3, 5, 6 and 7), a fade
fits the trend, passes every test and was named as an ageing pack. The energies
themselves say otherwise: they fall in two levels, flat within each, where a pack
losing capacity declines from one discharge to the next. A fade found here is withheld
(:meth:`~planner.identify.diagnose.effects.CapacityFade.contradicted`,
:func:`~planner.identify.diagnose.effects.two_levels`) where two levels, split at the
best threshold, fit the energies better than a trend with age beyond what a trend's own
noise gives (a parametric bootstrap of the trend, the split chosen afresh in each draw:
Cox 1961, Williams 1970; p below the search's α). Where a discharge of the high level
comes after one of the low, ageing is contradicted (it gives no capacity back); where
the levels come one after the other, a step between two sets of discharges is a change
between the experiments, or, without a cycle count, ageing between two sets whose ages
the data do not give: the entry says these cannot be told apart.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from planner.identify import stats
from planner.identify.diagnose.search import N_FOLDS, Fit, Split, Unit, experiment_channels

#: Share of an experiment's samples at its end (start) searched for the cut-off (full
#: charge). [unitless]
TAIL_SHARE = 0.02
#: Largest drop below the chemistry's full open-circuit voltage per cell at the start of a
#: discharge from a full pack (a charged lithium cell at 4.1–4.2 V loses some 0.3 V at 4C;
#: for a LiPo, full at 4.10 V on its curve, a start at 3.8 V). [V]
FULL_MARGIN_V = 0.3
#: Largest spread of the end voltages per cell of discharges that share one cut-off. [V]
CUTOFF_SPREAD_V = 0.1
#: Least number of discharges to the cut-off for the level to run. [unitless]
MIN_CUTOFF_EXPERIMENTS = 6
#: Least ratio of the highest to the lowest mean current for the rate term. [unitless]
MIN_RATE_RATIO = 1.5


def _tail(n: int) -> int:
    return max(3, int(math.ceil(TAIL_SHARE * n)))


def select(exps: list[dict], pack) -> tuple[list[dict], str]:
    """The experiments that run from full to one common cut-off, and why others do not.

    Returns the selected experiments (dicts of :func:`planner.identify.diagnose._capacity_experiments`
    with a ``voltage`` entry) and a sentence on what was found.
    """
    from planner.physics.battery.chemistry import chemistry

    cells = max(int(pack.cells_series), 1)
    empty = float(pack.cell_voltage_empty_v)
    full = round(chemistry(pack.chemistry).full_v - FULL_MARGIN_V, 2)
    with_v = [e for e in exps if e.get("voltage") is not None]
    if not with_v:
        return [], "no pack voltage in the data: the cut-off cannot be seen"
    ends, keep = [], []
    for e in with_v:
        v = e["voltage"] / cells
        k = _tail(len(v))
        end = float(np.nanmin(v[-k:]))
        start = float(np.nanmax(v[:k]))
        if end <= empty and start >= full:
            keep.append(e)
            ends.append(end)
    if not keep:
        return [], (f"no experiment runs from a full pack (≥ {full:g} V per cell at the "
                    f"start) to the empty voltage ({empty:g} V per cell) at its end")
    ends = np.asarray(ends)
    mid = float(np.median(ends))
    same = np.abs(ends - mid) <= CUTOFF_SPREAD_V
    chosen = [e for e, s in zip(keep, same) if s]
    what = (f"{len(chosen)} of {len(exps)} experiments run from a full pack to a cut-off of "
            f"{mid:.2f} V per cell")
    if (~same).any():
        what += f" ({int((~same).sum())} more end at another cut-off, not used)"
    return chosen, what


class CutoffLevel:
    """Energy delivered to the cut-off, one row per discharge (module notes).

    Parameters
    ----------
    exps : list of dict
        From :func:`select`: ``name``, ``t`` [s], ``p`` [W], ``c`` [A s],
        ``temperature`` [°C] or None, ``cycle`` or None.
    pack : BatteryPack
    """

    name = "cutoff"
    unit = "%"

    def __init__(self, exps: list[dict], pack):
        self.pack = pack
        self.names = [e["name"] for e in exps]
        n = len(exps)
        self.n_experiments = self.n_rows = n
        self.energy = np.array([float(np.trapezoid(e["p"], e["t"])) for e in exps])
        self.duration = np.array([float(e["t"][-1] - e["t"][0]) for e in exps])
        self.charge = np.array([float(e["c"][-1] - e["c"][0]) for e in exps])
        self.mean_power = self.energy / np.maximum(self.duration, 1e-9)
        self.p_ref = float(np.median(self.mean_power))
        self.mean_current = self.charge / np.maximum(self.duration, 1e-9)
        self.i_ref = float(np.median(self.mean_current))
        ratio = float(self.mean_current.max() / max(self.mean_current.min(), 1e-12))
        self.rate = self.mean_current / self.i_ref - 1.0 if ratio >= MIN_RATE_RATIO else None
        self.e_ref = float(np.median(self.energy))
        self.y = np.log(self.energy / self.e_ref)
        # per-sample channels, for the effects' skip rules and charge-weighted means
        lengths = np.array([len(e["t"]) for e in exps])
        self.exp_index = np.repeat(np.arange(n), lengths)
        w = []
        for e in exps:
            dc = np.diff(e["c"])
            w.append(np.r_[0.0, dc] * 0.5 + np.r_[dc, 0.0] * 0.5)
        self.charge_weight = np.clip(np.concatenate(w), 0.0, None)
        (self.temperature, self.temperature_missing, self.cycles,
         self.cycle_source) = experiment_channels(exps)
        k = min(N_FOLDS, n)
        self.row_fold = np.arange(n) % k
        self.row_group = np.arange(n)
        units = [Unit(j, 0.0, float(self.duration[j]), int(self.row_fold[j])) for j in range(n)]
        self.split = Split(units, k, True,
                           f"whole discharges held out: {n} discharges to the cut-off dealt in "
                           f"order into {k} folds (discharge i to fold i mod {k}); one test "
                           "unit per discharge")

    # ---------------------------------------------------------------- helpers
    def charge_mean(self, x: np.ndarray) -> np.ndarray:
        """Charge-weighted mean of a per-sample channel over each discharge."""
        w = self.charge_weight
        num = np.bincount(self.exp_index, weights=w * x, minlength=self.n_rows)
        den = np.bincount(self.exp_index, weights=w, minlength=self.n_rows)
        return num / np.maximum(den, 1e-12)

    def _columns(self, effects) -> np.ndarray:
        for e in effects:
            e.prepare(self)
        if not effects:
            return np.zeros((self.n_rows, 0))
        return np.column_stack([np.asarray(e.cutoff_column(self), float) for e in effects])

    def _linear(self) -> tuple[list[str], np.ndarray]:
        cols = [np.ones(self.n_rows)]
        names = ["log_energy"]
        if self.rate is not None:
            cols.append(self.rate)
            names.append("rate_slope")
        return names, np.column_stack(cols)

    def _predict(self, theta, Z, X, coef) -> np.ndarray:
        return X @ coef - np.log(np.maximum(1.0 + Z @ theta, 1e-9))

    # ---------------------------------------------------------------- fit
    def fit(self, effects, train: np.ndarray, start: Fit | None = None) -> Fit:
        """Fit the energy-to-cut-off model with ``effects`` on the ``train`` rows (one per
        discharge), from ``start`` where given.
        """
        Z = self._columns(effects)
        lin_names, X = self._linear()
        rows = np.flatnonzero(train)
        y = self.y[rows]
        Xr, Zr = X[rows], Z[rows]
        cache: dict = {}

        def resid(theta):
            target = y + np.log(np.maximum(1.0 + Zr @ theta, 1e-9))
            coef, *_ = np.linalg.lstsq(Xr, target, rcond=None)
            cache["coef"] = coef
            return target - Xr @ coef

        m = Z.shape[1]
        nl_names = [e.coefficient for e in effects]
        if m:
            zmax = np.maximum(np.abs(Z).max(axis=0), 1e-12)
            lo, hi = -0.9 / zmax, 10.0 / zmax
            x0 = np.zeros(m)
            if start is not None:
                v = start.values()
                x0 = np.array([v.get(k, 0.0) for k in nl_names])
            res = least_squares(resid, np.clip(x0, lo + 1e-12, hi - 1e-12), bounds=(lo, hi),
                                xtol=1e-12, ftol=1e-12, max_nfev=200)
            theta = res.x
        else:
            theta = np.zeros(0)
        r = resid(theta)
        return Fit(tuple(e.name for e in effects), nl_names, theta, lin_names,
                   cache["coef"], train, r, state={})

    def prepare_heldout(self, fit: Fit, effects, heldout: np.ndarray) -> None:
        """Nothing to locate on a discharge."""

    def predict(self, fit: Fit, effects) -> np.ndarray:
        """Predicted ln(E/E_ref) of every discharge."""
        Z = self._columns(effects)
        _, X = self._linear()
        return self._predict(fit.nl, Z, X, fit.coef)

    def heldout(self, fit: Fit, effects, fold: int) -> dict[str, Any]:
        """Held-out residuals of one fold: the ln error of each held-out discharge's
        energy to the cut-off, in % for the samples, and the final errors ``(|E − Ê|, E)``
        [W h].
        """
        rows = np.flatnonzero(self.row_fold == fold)
        r = self.y[rows] - self.predict(fit, effects)[rows]
        e_hat = self.energy[rows] * np.exp(-r)
        finals = [(abs(a - b), a) for a, b in zip(self.energy[rows], e_hat)]
        return {"rows": rows, "row_resid": r, "samples": rows, "sample_resid": 100.0 * r,
                "finals": finals, "loss_units": rows, "loss": r**2}

    # ---------------------------------------------------------------- reporting
    def covariance(self, fit: Fit, effects) -> tuple[np.ndarray, np.ndarray]:
        """Covariance of [θ…, c0, a] of an all-data fit, s²(JᵀJ)⁻¹ with one independent
        residual per discharge (:func:`planner.identify.stats.scaled_covariance`; infinite
        where the discharges cannot tell the parameters apart)."""
        rows = np.flatnonzero(fit.train)
        Z = self._columns(effects)[rows]
        _, X = self._linear()
        X = X[rows]
        q = 1.0 + Z @ fit.nl
        J = np.column_stack([-Z / q[:, None], X]) if Z.shape[1] else X
        r = self.y[rows] - self._predict(fit.nl, Z, X, fit.coef)
        cov = stats.scaled_covariance(J, float(r @ r)).matrix
        return cov, np.r_[fit.nl, fit.coef]

    def jacobian(self, fit: Fit, effects) -> np.ndarray:
        """Change of the predicted ln E of every discharge per unit of each fitted
        parameter [θ…, c₀, a]. [per unit]"""
        Z = self._columns(effects)
        _, X = self._linear()
        q = 1.0 + Z @ fit.nl
        return np.column_stack([-Z / q[:, None], X]) if Z.shape[1] else X

    def signature(self, fit: Fit, effects, effect) -> np.ndarray:
        """Change of the predicted ln E of every discharge per unit of ``effect``'s
        coefficient, at no effect: −z. [per unit]"""
        return -self._columns([effect])

    def physical(self, fit: Fit, effects) -> tuple[dict[str, float], dict[str, float]]:
        """Each effect's coefficient, the energy to the cut-off at the median discharge
        [W h], the median mean power [W] and current [A], and the rate slope [% per A],
        with standard errors."""
        cov, x = self.covariance(fit, effects)
        se = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        m = len(fit.nl)
        values = {e.coefficient: float(x[i]) for i, e in enumerate(effects)}
        stderr = {e.coefficient: float(se[i]) for i, e in enumerate(effects)}
        c0, sc0 = float(x[m]), float(se[m])
        values["energy_at_cutoff_wh"] = self.e_ref * math.exp(c0) / 3600.0
        stderr["energy_at_cutoff_wh"] = values["energy_at_cutoff_wh"] * sc0
        values["reference_power_w"], stderr["reference_power_w"] = self.p_ref, 0.0
        values["reference_current_a"], stderr["reference_current_a"] = self.i_ref, 0.0
        if self.rate is not None:
            values["energy_per_a_pct"] = 100.0 * float(x[m + 1]) / self.i_ref
            stderr["energy_per_a_pct"] = 100.0 * float(se[m + 1]) / self.i_ref
        for i, e in enumerate(effects):
            if e.name == "capacity_fade":
                shift = self.fade_law_shift(fit, effects, i)
                if math.isfinite(shift):
                    values[f"{e.coefficient}_law_shift"] = shift
                    stderr[e.coefficient] = math.hypot(stderr[e.coefficient], shift)
        return values, stderr

    def fade_law_shift(self, fit: Fit, effects, i: int) -> float:
        r"""How far the fade moves under the other common law of capacity fade (module
        notes, "Fade law"): :math:`\varphi_{lin} - \varphi`, with :math:`\varphi_{lin}`
        the charge scale of the linear capacity law fitted on the same discharges. NaN
        where it cannot be fitted. [1/cycle]"""
        rows = np.flatnonzero(fit.train)
        Z = self._columns(effects)[rows]
        _, X = self._linear()
        X, y = X[rows], self.y[rows]
        n = Z[:, i]
        others = np.delete(Z, i, axis=1) @ np.delete(fit.nl, i) if Z.shape[1] > 1 else 0.0
        base = y + np.log(np.maximum(1.0 + others, 1e-9))
        top = float(np.max(np.abs(n)))
        if top <= 0 or len(rows) <= X.shape[1] + 1:
            return math.nan

        def resid(a):
            target = base - np.log(np.maximum(1.0 - a[0] * n, 1e-9))
            coef, *_ = np.linalg.lstsq(X, target, rcond=None)
            return target - X @ coef

        phi = float(fit.nl[i])
        a0 = phi / (1.0 + phi * top) if phi > -1.0 / top else 0.0
        lin = least_squares(resid, [a0], bounds=([-10.0 / top], [0.99 / top]),
                            xtol=1e-12, ftol=1e-12, max_nfev=200)
        a = float(lin.x[0])
        # the linear law as the planner's charge scale 1 + φ n, both 1 at n = 0
        eq = least_squares(lambda f: np.log1p(np.maximum(f[0] * n, -0.99))
                           + np.log1p(-a * n), [phi], xtol=1e-12, ftol=1e-12, max_nfev=200)
        return float(eq.x[0]) - phi

    def confounders(self) -> list[tuple[str, np.ndarray]]:
        """What an effect's driver must not follow: the discharge rate (mean current),
        where the rates differ enough for the rate term (else there is none to follow)."""
        if self.rate is None:
            return []
        return [("the discharge rate (mean current)", self.mean_current)]

    def row_driver_residual(self, resid: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Held-out residual of the energy at the cut-off, measured over model − 1. [%]"""
        return 100.0 * np.expm1(resid)

    def as_given(self) -> tuple[float, float]:
        r"""Held-out-free error of the pack file as given: its energy to empty at each
        discharge's mean power, :math:`E = \delta \bar P^{1+\varepsilon} (u C)^\beta / s`
        (the integral model at constant power with the usable charge :math:`uC` and the
        file's charge scale :math:`s`): RMS of the ln error [%] and the final error [%]."""
        m = self.pack.model
        q = self.pack.capacity_as * self.pack.usable_fraction
        e_hat = m.delta * self.mean_power ** (1.0 + m.epsilon) * q ** m.beta / \
            float(np.asarray(m.charge_scale()))
        r = np.log(self.energy / e_hat)
        return float(100.0 * np.sqrt(np.mean(r**2))), \
            float(100.0 * np.sum(np.abs(self.energy - e_hat)) / np.sum(self.energy))

