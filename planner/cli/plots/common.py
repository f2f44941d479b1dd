"""Plots. Functions draw on a given Axes (or make one) and return it; the
library never calls ``plt.show()`` and never touches pyplot's global state or backend
(figures are :class:`matplotlib.figure.Figure` objects). Only the ``save_*`` helpers write
files."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from planner.io import files

_LEG_COLOURS = {"climb": "#fde0c5", "cruise": "#e5f0fa", "hover": "#e8f5e0",
                "loiter": "#e8f5e0", "descend": "#f2e6f7"}


def figure(nrows=1, ncols=1, *, figsize=None, **kwargs):
    """A new figure and its axes (``Figure.subplots``), outside pyplot: no global state,
    no backend to choose; :func:`save` writes it. Constrained layout keeps titles, tick
    labels and the legends placed outside the axes (:func:`legend_outside`) in the
    figure."""
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.subplots(nrows, ncols, **kwargs)


def legend_outside(ax, *, fontsize=8, **kwargs):
    """The legend of ``ax`` to the right of its data area, where it covers no data."""
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                     fontsize=fontsize, **kwargs)


def figure_legend(fig, axes, *, ncol=4, fontsize=8):
    """One legend for a grid of panels that show the same things (each label once, from
    whichever panel has it), below the panels, where it covers no data."""
    handles, labels = {}, []
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            if label not in handles:
                handles[label] = h
                labels.append(label)
    if labels:
        fig.legend([handles[k] for k in labels], labels, loc="outside lower center",
                   ncol=min(ncol, len(labels)), fontsize=fontsize)


#: Most logs or experiments drawn on one page; more go to further pages
#: (``replay.png``, ``replay_page2.png``, ...).
PER_PAGE = 8


def pages(n: int, per_page: int = PER_PAGE) -> list[range]:
    """The items of each page."""
    return [range(i, min(i + per_page, n)) for i in range(0, n, per_page)] or [range(0)]


def page_path(path, k: int):
    """The file of page ``k`` (0-based): the path itself, then ``<stem>_page<k+1><ext>``."""
    if k == 0:
        return path
    from pathlib import Path
    p = Path(path)
    return str(p.with_name(f"{p.stem}_page{k + 1}{p.suffix}"))


def item_grid(n_items: int, panels: int, *, stack: str = "vertical", items_per_row=None,
              panel_size=(5.2, 2.7)):
    """A figure laid out as a grid of items (a log, an experiment), each of ``panels``
    axes stacked ``"vertical"``ly or side by side (``"horizontal"``); unused cells are
    hidden. Constrained layout keeps the figure's title clear of the panels.

    Returns ``(fig, [axes of item 0, axes of item 1, ...])``."""
    import math
    per_row = items_per_row or min(n_items, 3 if stack == "vertical" else 2)
    per_row = max(per_row, 1)
    item_rows = max(math.ceil(n_items / per_row), 1)
    if stack == "vertical":
        nrows, ncols = item_rows * panels, per_row
    else:
        nrows, ncols = item_rows, per_row * panels
    fig = Figure(figsize=(panel_size[0] * ncols, panel_size[1] * nrows + 0.6),
                 layout="constrained")
    axes = np.atleast_2d(fig.subplots(nrows, ncols, squeeze=False))
    out = []
    for k in range(item_rows * per_row):
        r, c = divmod(k, per_row)
        if stack == "vertical":
            cell = list(axes[r * panels:(r + 1) * panels, c])
        else:
            cell = list(axes[r, c * panels:(c + 1) * panels])
        if k < n_items:
            out.append(cell)
        else:
            for ax in cell:
                ax.set_visible(False)
    return fig, out


def new_axes():
    """Axes on a new figure, for a ``plot_*`` function called without ``ax``."""
    return figure()[1]


def plot_power(result, ax=None):
    """Battery power against time, legs shaded by kind. Returns the Axes."""
    ax = ax or new_axes()
    s = result.series
    ax.plot(s["time_s"] / 60.0, s["power_w"], color="C3", lw=1.5, label="battery power")
    _shade_legs(ax, result)
    ax.set_ylabel("power [W]")
    ax.set_xlabel("time [min]")
    ax.grid(alpha=0.3)
    return ax


def plot_remaining(result, ax=None):
    """Remaining charge (% of nominal) against time, with the landing limit that decides
    the verdict (the reserve above the charge the pack cannot give) and the point of no
    return. The line stops where the pack is empty; where the usable charge runs out is
    marked."""
    ax = ax or new_axes()
    s = result.series
    t_min = np.asarray(s["time_s"], float) / 60.0
    left = 100 * np.asarray(s["remaining_fraction"], float)
    ax.plot(t_min, np.where(left >= 0, left, np.nan), color="C0", lw=1.8,
            label="remaining charge (integral model)")
    # the limit the landing is judged against: the reserve above the charge the pack
    # cannot give (its usable fraction, or the circuit model's voltage cut-off)
    unusable = 100 * (1 - result.usable_mah / result.capacity_mah)
    limit = unusable + 100 * result.reserve_fraction
    if result.cutoff_limited:
        ax.axhline(unusable, color="C1", ls=":", lw=1.2,
                   label=f"loaded-voltage cut-off ({result.usable_mah:.0f} mAh drawn)")
    elif unusable > 0:
        ax.axhline(unusable, color="0.5", ls=":", lw=1, label="unusable charge")
    ax.axhline(limit, color="k", ls="--", lw=1.2,
               label=f"landing limit: reserve {result.reserve_mah:.0f} mAh above that"
               if unusable > 0 else f"landing reserve {100 * result.reserve_fraction:.0f} %")
    out = np.flatnonzero(left <= unusable)
    if out.size:
        j = int(out[0])
        ax.plot(t_min[j], max(left[j], 0.0), "X", ms=10, color="C3", mec="k", ls="none",
                zorder=5, label=f"usable charge runs out at {t_min[j]:.1f} min")
    if result.point_of_no_return:
        t = result.point_of_no_return["time_s"] / 60.0
        ax.axvline(t, color="C3", ls="-.", lw=1.2, label="point of no return")
    _shade_legs(ax, result)
    ax.set_ylim(-3, 105)
    ax.set_ylabel("remaining charge [% of nominal]")
    ax.set_xlabel("time [min]")
    ax.grid(alpha=0.3)
    return ax


def _shade_legs(ax, result):
    seen = set()
    for row in result.legs.itertuples(index=False):
        t0 = row.start_time_s / 60.0
        t1 = (row.start_time_s + row.duration_s) / 60.0
        label = f"{row.kind} leg" if row.kind not in seen else None
        seen.add(row.kind)
        ax.axvspan(t0, t1, color=_LEG_COLOURS.get(row.kind, "#eeeeee"), alpha=0.6, lw=0,
                   label=label, zorder=0)


def plot_landing_band(result, uncertainty, ax):
    """The Monte Carlo band of the charge left on landing (P5–P95, P50 and the mean of the
    worst 5 %) at the end of the mission, as remaining charge in % of nominal."""
    unusable = result.capacity_mah - result.usable_mah
    lm = uncertainty.landing_mah

    def pct(mah):
        return 100.0 * (mah + unusable) / result.capacity_mah

    t = result.duration_s / 60.0
    lo, mid, hi = pct(lm["p5"]), pct(lm["p50"]), pct(lm["p95"])
    ax.errorbar([t], [mid], yerr=[[mid - lo], [hi - mid]], fmt="o", color="C2", capsize=6,
                lw=2, zorder=5, label=f"landing, {uncertainty.samples} samples: P5–P95 "
                                      f"(P50 ●), P(reserve) {100 * uncertainty.p_landing:.0f} %")
    ax.plot([t], [pct(uncertainty.cvar5_landing_mah)], marker="v", color="C3", ls="none",
            zorder=5, label="landing, mean of the worst 5 % (CVaR5)")
    return ax


def save_mission_plot(result, path, title=None, uncertainty=None):
    """Two panels: power and remaining charge against time; legs marked; with a Monte
    Carlo result, the band of the charge left on landing."""
    save(mission_figure(result, title, uncertainty), path)


def mission_figure(result, title=None, uncertainty=None):
    """The figure of :func:`save_mission_plot`: both panels keep their time tick labels;
    the legends sit beside the panels."""
    fig, (ax1, ax2) = figure(2, 1, figsize=(12, 7), sharex=True)
    plot_power(result, ax1)
    plot_remaining(result, ax2)
    if uncertainty is not None:
        plot_landing_band(result, uncertainty, ax2)
    ax1.tick_params(labelbottom=True)
    ax1.set_title(title or f"{result.aircraft}: {result.verdict}")
    legend_outside(ax1)
    legend_outside(ax2)
    return fig


def save(fig, path, option: str = "--plot"):
    """Write a figure (atomically, never over an input file: :mod:`planner.io.files`)."""
    files.save_figure(fig, path, option, dpi=110)


_PHASE_COLOURS = {"ground": "#eeeeee", "takeoff": "#fde0c5", "climb": "#fbe3d6",
                  "cruise": "#e5f0fa", "hover": "#e8f5e0", "descent": "#f2e6f7",
                  "landing": "#f6d5d5"}


def _shade_phases(ax, t, phase):
    if phase is None or len(phase) == 0:
        return
    change = np.flatnonzero(phase[1:] != phase[:-1]) + 1
    starts = np.concatenate(([0], change))
    ends = np.concatenate((change, [len(phase)]))
    seen = set()
    for a, b in zip(starts, ends):
        name = phase[a]
        label = f"{name}" if name not in seen else None
        seen.add(name)
        ax.axvspan(t[a], t[min(b, len(t) - 1)], color=_PHASE_COLOURS.get(name, "#eeeeee"),
                   alpha=0.7, lw=0, label=label, zorder=0)


def plot_replay_experiment(exp, axes):
    """Measured vs predicted power (top) and charge drawn (bottom) of one experiment."""
    s = exp.series
    t = s["time_s"]
    ax1, ax2 = axes
    if "measured_w" not in s:   # nothing of the battery to compare with (no current sensor)
        for ax, what in zip(axes, ("power", "charge")):
            ax.text(0.5, 0.5, "; ".join(exp.notes) or "not replayed", ha="center",
                    va="center", wrap=True, transform=ax.transAxes, fontsize=8)
            ax.set_title(f"{exp.experiment}: {what}")
        ax1.set_ylabel("power [W]")
        ax2.set_ylabel("charge drawn [mAh]")
        ax2.set_xlabel("time [s]")
        return
    ax1.plot(t, s["measured_w"], color="k", lw=0.8, label="measured power")
    if "predicted_w" in s:
        ax1.plot(t, s["predicted_w"], color="C3", lw=1.0, label="power model")
    _shade_phases(ax1, t, s.get("phase"))
    ax1.set_ylabel("power [W]")
    ax1.set_title(f"{exp.experiment}: power")
    if "predicted_mah" in s:
        ax2.plot(t, s["measured_mah"], color="k", lw=1.2, label="logged consumed charge")
        ax2.plot(t, s["integrated_mah"], color="0.5", ls=":", lw=1.2,
                 label="∫ measured current")
        ax2.plot(t, s["predicted_mah"], color="C0", lw=1.2, label="integral model")
    _shade_phases(ax2, t, s.get("phase"))
    ax2.set_ylabel("charge drawn [mAh]")
    ax2.set_xlabel("time [s]")
    ax2.set_title(f"{exp.experiment}: charge")
    for ax in axes:
        ax.grid(alpha=0.3)


def save_replay_plot(result, path) -> list[str]:
    """Measured vs predicted power and charge, one grid cell per log, at most
    :data:`PER_PAGE` logs a page. Returns the files written."""
    written = []
    for k, fig in enumerate(replay_figures(result)):
        written.append(page_path(path, k))
        save(fig, written[-1])
    return written


def replay_figures(result) -> list:
    """The pages of :func:`save_replay_plot`: one legend per page, below the panels."""
    exps = result.experiments
    chunks = pages(len(exps))
    figs = []
    for k, chunk in enumerate(chunks):
        fig, cells = item_grid(len(chunk), 2)
        for j, axes in zip(chunk, cells):
            plot_replay_experiment(exps[j], axes)
        more = f" (page {k + 1} of {len(chunks)})" if len(chunks) > 1 else ""
        fig.suptitle(f"Replay: measured vs predicted{more}")
        figure_legend(fig, [ax for cell in cells for ax in cell])
        figs.append(fig)
    return figs
