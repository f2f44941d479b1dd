r"""The identification experiment of [UAV23], reproduced on the virtual bench.

[UAV23] identifies its integral capacity model three ways and
cross-validates them (its Table 4 and Fig. 12–13):

* **m_const** — fitted on the constant-power discharges at the lowest and the
  highest power (50 W and 125 W);
* **m_2-step** — fitted on the two-step tests;
* **m_APRBS** — fitted on the APRBS tests;

and each is scored on every test: RMSE of the charge residual [mAh] (eq. 29)
and final normalised error [%] (eq. 30). This module runs that campaign on
:mod:`planner.identify.bench` and does the fits with
:func:`planner.identify.battery_fit.fit_integral` — nothing of the model or the metrics
is re-implemented here.

The campaign (:class:`SeedCampaign`, defaults)
----------------------------------------------
* constant power at 50, 75, 100 and 125 W, each to the loaded cut-off;
* two-step tests designed with :func:`planner.identify.protocols.two_step` from the
  pack's design model ([UAV23]'s m_const) to draw :math:`C_0` = 90 % of the
  nominal capacity (9000 mAh for the [UAV23] pack, so that they end before the
  cut-off): P1→P2 of 50→125 W
  and 125→50 W, each with k = 0.5 and k = 2 (four tests);
* three APRBS tests: levels 50/75/100/125 W, holds U[30, 300] s, at least
  3500 s each (:func:`planner.identify.protocols.aprbs`);
* 1 Hz sampling, the bench's default measurement noise, one seed for the
  whole campaign (each experiment's noise and each APRBS schedule are drawn
  from their own child of :class:`numpy.random.SeedSequence`).

β is fitted both ways: held at 0.9648 as in the paper (``"held"``) and free
(``"free"``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from planner.identify import bench, battery_fit as fit
from planner.physics.battery import integral
from planner.physics.units import AS_PER_MAH

__all__ = [
    "BETA_MODES",
    "CAMPAIGNS",
    "KINDS",
    "MODELS",
    "PAPER_FINAL_ERROR_PCT",
    "CampaignReport",
    "SeedCampaign",
    "cross_validate",
    "experiment_kind",
    "render_report",
    "report_to_dict",
    "run_campaign",
]

#: Kinds of test, in report order.
KINDS = ("constant", "two-step", "APRBS")
#: Models of [UAV23] Table 4 and the kind of test each is fitted on.
MODELS = {"m_const": "constant", "m_2step": "two-step", "m_APRBS": "APRBS"}
#: β held at the paper's value, or fitted.
BETA_MODES = {"held": integral.LITERATURE_BETA, "free": None}
#: Named campaigns (the kinds of test they run).
CAMPAIGNS = {"seed": KINDS, "constant": ("constant",), "two-step": ("two-step",),
             "aprbs": ("APRBS",)}
#: The paper's headline bound on the final normalised error. [%]
PAPER_FINAL_ERROR_PCT = 0.7


@dataclass(frozen=True)
class SeedCampaign:
    """The tests of the [UAV23] campaign (see the module notes for the defaults).

    Attributes
    ----------
    constant_w : tuple of float
        Constant-power discharges to the cut-off. [W]
    m_const_train_w : tuple of float
        The constant powers m_const is fitted on. [W]
    two_step : tuple of (P1, P2, k)
        Two-step tests. [W], [W], [unitless]
    two_step_capacity_fraction : float
        Charge C0 the two-step tests are designed to draw, as a share of the
        pack's nominal capacity. [unitless]
    aprbs_count : int
        Number of APRBS tests.
    aprbs_levels_w : tuple of float
        [W]
    aprbs_hold_s : (float, float)
        [s]
    aprbs_min_duration_s : float
        [s]
    """

    constant_w: tuple[float, ...] = (50.0, 75.0, 100.0, 125.0)
    m_const_train_w: tuple[float, ...] = (50.0, 125.0)
    two_step: tuple[tuple[float, float, float], ...] = (
        (50.0, 125.0, 0.5), (50.0, 125.0, 2.0), (125.0, 50.0, 0.5), (125.0, 50.0, 2.0))
    two_step_capacity_fraction: float = 0.9
    aprbs_count: int = 3
    aprbs_levels_w: tuple[float, ...] = (50.0, 75.0, 100.0, 125.0)
    aprbs_hold_s: tuple[float, float] = (30.0, 300.0)
    aprbs_min_duration_s: float = 3500.0

    def constant_name(self, power_w: float) -> str:
        """Experiment id of the constant-power discharge at ``power_w`` [W], e.g. ``const_050W``."""
        return f"const_{power_w:03.0f}W"

    def two_step_name(self, p1_w: float, p2_w: float, k: float) -> str:
        """Experiment id of a two-step test, P1 → P2 [W] with t2/t1 = ``k``, e.g.
        ``two_step_050_125_k0.5``.
        """
        return f"two_step_{p1_w:03.0f}_{p2_w:03.0f}_k{k:g}"

    def aprbs_name(self, index: int) -> str:
        """Experiment id of the APRBS test number ``index`` (from 0), e.g. ``aprbs_1``."""
        return f"aprbs_{index + 1}"

    @property
    def m_const_train(self) -> list[str]:
        """Experiment ids m_const is fitted on."""
        return [self.constant_name(p) for p in self.m_const_train_w]


def experiment_kind(name: str) -> str:
    """Kind of test of a campaign experiment id: ``constant``, ``two-step`` or ``APRBS``."""
    if name.startswith("const_"):
        return "constant"
    if name.startswith("two_step_"):
        return "two-step"
    if name.startswith("aprbs_"):
        return "APRBS"
    raise ValueError(f"not a campaign experiment id: {name!r}")


def run_campaign(pack: bench.BenchPack | None = None, *, campaign: str = "seed",
                 config: SeedCampaign = SeedCampaign(), seed: int = 0,
                 noise: bench.BenchNoise = bench.DEFAULT_NOISE, dt_s: float = 1.0,
                 temperature_c: float = 25.0,
                 return_info: bool = False) -> pd.DataFrame | tuple[pd.DataFrame, pd.DataFrame]:
    """Run a named campaign on the bench and return its flight records.

    Parameters
    ----------
    pack : BenchPack, optional
        Default :func:`planner.identify.bench.seed_pack`.
    campaign : str, default ``"seed"``
        One of :data:`CAMPAIGNS`: ``seed`` (every test), ``constant``,
        ``two-step``, ``aprbs``.
    config : SeedCampaign
    seed : int, default 0
        Seed of the measurement noise and of the APRBS schedules.
    noise : BenchNoise
    dt_s : float, default 1
        Sample interval. [s]
    temperature_c : float, default 25
        [°C]
    return_info : bool, default False
        Also return one row per experiment: ``experiment``, ``kind``,
        ``duration_s`` [s], ``charge_mah`` (true charge drawn) [mAh],
        ``tripped`` (ended at the cut-off rather than the schedule's end).

    Returns
    -------
    DataFrame, or (DataFrame, DataFrame)
        One flight record (docs/record.md) of all experiments, told apart by
        ``experiment``, in the order constant, two-step, APRBS (and the info).
    """
    if campaign not in CAMPAIGNS:
        raise ValueError(f"unknown campaign {campaign!r}; expected one of "
                         f"{', '.join(CAMPAIGNS)}")
    pack = pack if pack is not None else bench.seed_pack()
    kinds = CAMPAIGNS[campaign]
    # one child seed per experiment of the full campaign, so that a partial
    # campaign gives the same records as the same tests of the full one
    n_tests = len(config.constant_w) + len(config.two_step) + 2 * config.aprbs_count
    children = iter(np.random.SeedSequence(seed).spawn(n_tests))
    common = {"dt_s": dt_s, "noise": noise, "temperature_c": temperature_c,
              "return_truth": True}
    c0_mah = config.two_step_capacity_fraction * pack.capacity_as / AS_PER_MAH
    runs = []
    for p in config.constant_w:
        child = next(children)
        if "constant" in kinds:
            runs.append(bench.constant_power_discharge(
                pack, p, config.constant_name(p), seed=np.random.default_rng(child), **common))
    for p1, p2, k in config.two_step:
        child = next(children)
        if "two-step" in kinds:
            runs.append(bench.two_step_discharge(
                pack, p1, p2, k, c0_mah, config.two_step_name(p1, p2, k),
                seed=np.random.default_rng(child), **common))
    for i in range(config.aprbs_count):
        schedule_child, noise_child = next(children), next(children)
        if "APRBS" in kinds:
            runs.append(bench.aprbs_discharge(
                pack, np.random.default_rng(schedule_child), config.aprbs_name(i),
                levels_w=config.aprbs_levels_w, hold_s=config.aprbs_hold_s,
                min_duration_s=config.aprbs_min_duration_s,
                seed=np.random.default_rng(noise_child), **common))
    records = pd.concat([r for r, _ in runs], ignore_index=True)
    if not return_info:
        return records
    info = pd.DataFrame([{"experiment": r["experiment"].iloc[0],
                          "kind": experiment_kind(r["experiment"].iloc[0]),
                          "duration_s": float(truth.time_s[-1]),
                          "charge_mah": float(truth.charge_as[-1]) / AS_PER_MAH,
                          "tripped": truth.tripped} for r, truth in runs])
    return records, info


# --------------------------------------------------------------------------- cross-validation

@dataclass
class CampaignReport:
    """Fits and cross-validation of the three models of [UAV23] Table 4.

    Attributes
    ----------
    fits : dict
        ``fits[beta_mode][model]``: the
        :class:`planner.identify.battery_fit.IntegralFit` of
        :func:`planner.identify.battery_fit.fit_integral`.
    table : DataFrame
        One row per β mode × model × experiment: ``beta_mode``, ``model``,
        ``experiment``, ``kind``, ``split`` (``train``/``validate``),
        ``mean_power_w`` [W], ``final_charge_mah`` [mAh], ``rmse_mah`` [mAh],
        ``final_error_pct`` [%], ``time_error_s`` [s].
    warnings : list of str
        Warnings raised by the fits (e.g. a poorly determined parameter).
    experiments : list of str
        Experiment ids in campaign order.
    """

    fits: dict[str, dict[str, fit.IntegralFit]]
    table: pd.DataFrame
    warnings: list[str] = field(default_factory=list)
    experiments: list[str] = field(default_factory=list)

    def metric(self, beta_mode: str, model: str, experiment: str, column: str) -> float:
        """One cell of the table."""
        t = self.table
        row = t[(t.beta_mode == beta_mode) & (t.model == model) & (t.experiment == experiment)]
        if len(row) != 1:
            raise KeyError(f"no row for {beta_mode}, {model}, {experiment}")
        return float(row[column].iloc[0])

    def summary(self, beta_mode: str = "held") -> pd.DataFrame:
        """Per model and kind of test, over the experiments the model was *not* fitted on.

        Columns ``model``, ``kind``, ``n``, ``mean_rmse_mah``,
        ``max_abs_final_error_pct``; a row ``kind = "all"`` pools the kinds.
        """
        t = self.table[(self.table.beta_mode == beta_mode) & (self.table.split == "validate")]
        rows = []
        for model in MODELS:
            sub = t[t.model == model]
            for kind in (*KINDS, "all"):
                s = sub if kind == "all" else sub[sub.kind == kind]
                if s.empty:
                    continue
                rows.append({"model": model, "kind": kind, "n": len(s),
                             "mean_rmse_mah": float(s.rmse_mah.mean()),
                             "max_abs_final_error_pct": float(s.final_error_pct.abs().max())})
        return pd.DataFrame(rows)

    def best_model(self, beta_mode: str = "held") -> str:
        """The model with the lowest mean held-out RMSE over the kinds it was not fitted on.

        Kinds are weighted equally: the mean over kinds of each kind's mean
        held-out RMSE (a model's own kind counts only through its held-out
        experiments of that kind, e.g. m_const on 75 and 100 W).
        """
        s = self.summary(beta_mode)
        s = s[s.kind != "all"]
        return str(s.groupby("model")["mean_rmse_mah"].mean().idxmin())


def cross_validate(records: pd.DataFrame, *, config: SeedCampaign = SeedCampaign(),
                   beta_modes: Sequence[str] = ("held", "free")) -> CampaignReport:
    """Fit m_const, m_2step and m_APRBS and score each on every experiment.

    Parameters
    ----------
    records : DataFrame
        A campaign's flight records (:func:`run_campaign`), experiment ids as
        there; the models whose training tests are missing are skipped.
    config : SeedCampaign
        Gives the constant powers m_const is fitted on.
    beta_modes : sequence of str
        Keys of :data:`BETA_MODES`.

    Returns
    -------
    CampaignReport
    """
    experiments = fit.prepare_experiments(records)
    names = [e.name for e in experiments]
    kinds = {n: experiment_kind(n) for n in names}
    train_of = {"m_const": [n for n in config.m_const_train if n in names],
                "m_2step": [n for n in names if kinds[n] == "two-step"],
                "m_APRBS": [n for n in names if kinds[n] == "APRBS"]}
    fits: dict[str, dict[str, fit.IntegralFit]] = {}
    rows, messages = [], []
    for mode in beta_modes:
        if mode not in BETA_MODES:
            raise ValueError(f"unknown beta mode {mode!r}; expected one of "
                             f"{', '.join(BETA_MODES)}")
        fits[mode] = {}
        for model, train in train_of.items():
            if not train:
                continue
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                result = fit.fit_integral(experiments, beta=BETA_MODES[mode], train=train)
            messages += [f"{model} (β {mode}): {w.message}" for w in caught]
            fits[mode][model] = result
            for m in result.metrics:
                rows.append({"beta_mode": mode, "model": model, "experiment": m.experiment,
                             "kind": kinds[m.experiment], "split": m.split,
                             "mean_power_w": m.mean_power_w,
                             "final_charge_mah": m.final_charge_mah, "rmse_mah": m.rmse_mah,
                             "final_error_pct": m.final_error_pct,
                             "time_error_s": m.time_error_s})
    return CampaignReport(fits=fits, table=pd.DataFrame(rows), warnings=messages,
                          experiments=names)


# --------------------------------------------------------------------------- report

def _cell(value: float, digits: int, train: bool, width: int) -> str:
    text = "-" if not math.isfinite(value) else f"{value:.{digits}f}"
    return (text + ("*" if train else " ")).rjust(width)


def render_report(report: CampaignReport, *, beta_modes: Sequence[str] | None = None) -> str:
    """The table behind [UAV23] Fig. 12–13, as text.

    For each β mode: the fitted δ, ε, β of each model, then RMSE [mAh] and
    final normalised error [%] per validation experiment (rows) and model
    (columns); ``*`` marks an experiment the model was fitted on. Then the
    held-out summary per kind of test.
    """
    modes = list(beta_modes) if beta_modes is not None else list(report.fits)
    lines: list[str] = []
    width = 11
    for mode in modes:
        fits = report.fits[mode]
        models = list(fits)
        title = ("β held at 0.9648 (as in [UAV23])" if mode == "held"
                 else "β fitted (free)")
        lines += [title, "=" * len(title)]
        for model in models:
            r = fits[model]
            se = r.stderr
            beta_text = (f"β = {r.beta:.4f} (held)" if "beta" in r.fixed
                         else f"β = {r.beta:.4f} ± {se['beta']:.2g}")
            lines.append(f"{model:<8} δ = {r.delta:.4f} ± {se['delta']:.2g}, "
                         f"ε = {r.epsilon:.4f} ± {se['epsilon']:.2g}, {beta_text}; "
                         f"trained on {', '.join(r.train)}")
        t = report.table[report.table.beta_mode == mode]
        for column, label, digits in (("rmse_mah", "RMSE [mAh] ([UAV23] eq. 29)", 1),
                                      ("final_error_pct",
                                       "final normalised error [%] ([UAV23] eq. 30)", 3)):
            lines += ["", label]
            lines.append(f"{'experiment':<24}{'kind':<10}{'mean P [W]':>11}"
                         + "".join(m.rjust(width) for m in models))
            for name in report.experiments:
                rows = t[t.experiment == name].set_index("model")
                if rows.empty:
                    continue
                first = rows.iloc[0]
                cells = "".join(_cell(float(rows.loc[m, column]),
                                      digits, rows.loc[m, "split"] == "train", width)
                                if m in rows.index else "-".rjust(width) for m in models)
                lines.append(f"{name:<24}{first.kind:<10}{first.mean_power_w:>11.1f}{cells}")
        lines.append("(* = a training experiment of that model)")
        s = report.summary(mode)
        if not s.empty:
            lines += ["", "held-out experiments only: mean RMSE [mAh] / max |final error| [%]",
                      f"{'model':<10}" + "".join(k.rjust(18) for k in (*KINDS, "all"))]
            for model in models:
                cells = []
                for kind in (*KINDS, "all"):
                    row = s[(s.model == model) & (s.kind == kind)]
                    cells.append("-".rjust(18) if row.empty else
                                 f"{row.mean_rmse_mah.iloc[0]:.1f} / "
                                 f"{row.max_abs_final_error_pct.iloc[0]:.3f}".rjust(18))
                lines.append(f"{model:<10}" + "".join(cells))
            worst = float(t[t.split == "validate"].final_error_pct.abs().max())
            lines.append(f"lowest held-out RMSE (kinds weighted equally): "
                         f"{report.best_model(mode)}; largest held-out |final error| "
                         f"{worst:.3f} % (paper: below {PAPER_FINAL_ERROR_PCT} %)")
        lines.append("")
    if report.warnings:
        lines += ["fit warnings:"] + [f"  {w}" for w in report.warnings]
    return "\n".join(lines).rstrip() + "\n"


def report_to_dict(report: CampaignReport) -> dict[str, Any]:
    """JSON-ready form of a report (fits without their per-experiment metrics)."""
    fits = {mode: {model: r.to_dict()
                   for model, r in by_model.items()}
            for mode, by_model in report.fits.items()}
    return {"fits": fits, "table": report.table.to_dict(orient="records"),
            "summary": {mode: report.summary(mode).to_dict(orient="records")
                        for mode in report.fits},
            "best_model": {mode: report.best_model(mode) for mode in report.fits
                           if not report.summary(mode).empty},
            "warnings": list(report.warnings), "experiments": list(report.experiments)}
