"""Plots of ``diagnose``: held-out residuals against time and against each finding's driver,
before (calibrated baseline) and after (extended model).

Functions draw on given Axes and return them; :func:`save_diagnose_plot` writes the PNG.
The library never calls ``plt.show()``.
"""

from __future__ import annotations

import math

import numpy as np

from planner.cli.plots.common import figure, figure_legend, new_axes, save
from planner.physics.units import AS_PER_MAH

BEFORE = {"color": "0.55", "label": "before: calibrated baseline"}
AFTER = {"color": "C3", "label": "after: extended model"}


def _ordered(score):
    order = np.argsort(score.heldout_rows, kind="stable")
    return score.heldout_rows[order], score.heldout_row_resid[order]


def plot_residual_time(report, ax=None):
    """Held-out residual against time since the start of each experiment."""
    ax = ax or new_axes()
    res = report.result
    level = res.level
    changed = bool(res.selected)
    scores = [(res.baseline, BEFORE)] + ([(res.final, AFTER)] if changed else [])
    if level.name == "cutoff":
        for score, style in scores:
            rows, r = _ordered(score)
            ax.plot(level.duration[rows] / 60.0, level.row_driver_residual(r, rows), "o",
                    ms=4, color=style["color"], label=style["label"])
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_xlabel("duration of the discharge to the cut-off [min]")
        ax.set_ylabel("energy to the cut-off, measured / model − 1 [%]")
        ax.set_title("cut-off level: held-out error of the energy to the cut-off, one point "
                     "per discharge", fontsize=9)
        ax.grid(alpha=0.3)
        return ax
    for score, style in scores:
        if level.name == "capacity":
            idx = score.heldout_samples
            order = np.argsort(idx, kind="stable")
            idx, r = idx[order], score.heldout_sample_resid[order] / AS_PER_MAH
            t = level.t[idx] / 60.0
            seg = np.diff(level.exp_index[idx]) != 0
            breaks = np.flatnonzero((np.diff(idx) != 1) | seg) + 1
            for k, (a, b) in enumerate(zip(np.r_[0, breaks], np.r_[breaks, len(idx)])):
                ax.plot(t[a:b], r[a:b], color=style["color"], lw=0.9,
                        label=style["label"] if k == 0 else None)
            ax.set_ylabel("charge residual C − Ĉ [mAh]")
        else:
            rows, r = _ordered(score)
            ax.plot(level.time[rows] / 60.0, r, ".", ms=2, color=style["color"],
                    label=style["label"], alpha=0.6)
            ax.set_ylabel("power residual, measured − model [W]")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("time since the start of the experiment [min]")
    what = "restarted at each held-out segment" if level.name == "capacity" else \
        f"{level.bin_s:.1f}-s means"
    ax.set_title(f"{level.name} level: held-out residual against time ({what})", fontsize=9)
    ax.grid(alpha=0.3)
    return ax


def _driver(level, effect, state):
    if level.name == "cutoff":
        x = effect.cutoff_column(level)
        # the temperature's column is the mean hinge below the reference: plot the
        # temperature it stands for
        return effect.reference_c - x if effect.name == "temperature" else x
    if level.name == "capacity":
        return effect.window_driver(level)
    if effect.name in ("system_power", "efficiency_curve"):
        return level.measured
    return effect.bin_driver(level, state)


def plot_residual_driver(report, effect, ax=None, after=True):
    """Held-out residual against the driver of ``effect`` (binned means as lines)."""
    ax = ax or new_axes()
    res = report.result
    level = res.level
    state = res.final_fit.state if res.final_fit is not None else {}
    x_all = np.asarray(_driver(level, effect, state), float)
    label = effect.driver_label if not (
        level.name == "power" and effect.name in ("system_power", "efficiency_curve")) \
        else "measured battery power [W]"
    if label.startswith("time") and label.endswith("[s]"):   # every time axis in minutes
        x_all = x_all / 60.0
        label = label[:-3] + "[min]"
    scores = [(res.baseline, BEFORE)] + ([(res.final, AFTER)] if after else [])
    for score, style in scores:
        rows, r = _ordered(score)
        y = level.row_driver_residual(r, rows)
        x = x_all[rows]
        ok = np.isfinite(x) & np.isfinite(y)
        x, y = x[ok], y[ok]
        ax.plot(x, y, "o" if level.name == "cutoff" else ".", ms=4 if level.name == "cutoff"
                else 2, color=style["color"], alpha=0.8 if level.name == "cutoff" else 0.35,
                label=style["label"] if level.name == "cutoff" else None)
        if len(x) >= 10:
            edges = np.unique(np.quantile(x, np.linspace(0, 1, min(16, len(x) // 5) + 1)))
            if len(edges) > 2:
                k = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
                mx = np.bincount(k, x) / np.maximum(np.bincount(k), 1)
                my = np.bincount(k, y) / np.maximum(np.bincount(k), 1)
                ax.plot(mx, my, "-o", ms=3, lw=1.5, color=style["color"],
                        label=style["label"] + " (binned mean)")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel(label)
    ax.set_ylabel({"capacity": "excess current, measured − model [mA]",
                   "cutoff": "energy to the cut-off, measured / model − 1 [%]"}.get(
                       level.name, "power residual, measured − model [W]"))
    found = any(e.name == effect.name for e, _ in res.selected)
    ax.set_title(f"{effect.name} ({'found' if found else 'not significant'}): residual against "
                 "its driver", fontsize=9)
    ax.grid(alpha=0.3)
    return ax


def diagnose_figure(result):
    """Residual against time per level, then against the driver of each significant
    finding, before and after. Effects that were not significant get no panel (the text
    output and the JSON list what was tested)."""
    panels = []
    for report in result.levels.values():
        panels.append(("time", report, None, True))
        panels += [("driver", report, e, True) for e, _ in report.result.selected]
    if not panels:
        fig, ax = figure(figsize=(7, 3))
        ax.text(0.5, 0.5, "no level could run:\n" + "\n".join(result.notes[:6]),
                ha="center", va="center", fontsize=8, wrap=True)
        ax.set_axis_off()
        return fig
    ncol = 2 if len(panels) > 1 else 1
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = figure(nrow, ncol, figsize=(6.2 * ncol, 3.6 * nrow), squeeze=False)
    for ax, (kind, report, effect, after) in zip(axes.flat, panels):
        if kind == "time":
            plot_residual_time(report, ax)
        else:
            plot_residual_driver(report, effect, ax, after=after)
    for ax in list(axes.flat)[len(panels):]:
        ax.set_axis_off()
    names = ", ".join(f["effect"] for f in result.findings) or "no significant effect"
    fig.suptitle(f"diagnose: {names}", fontsize=11)
    figure_legend(fig, list(axes.flat)[:len(panels)])
    return fig


def save_diagnose_plot(result, path) -> None:
    """Write :func:`diagnose_figure` as a PNG."""
    save(diagnose_figure(result), path)
