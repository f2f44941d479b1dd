"""The figures of the fleet report (``DIR/accuracy.png``, ``drift.png``, ``packs.png``):
predicted against measured per flight, the error over the fleet's flights, and each pack's
state of health (:mod:`planner.fleet.report` writes the text that shows them)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from planner.cli.plots.common import figure, legend_outside, save
from planner.fleet.health import cycle_order

def plot_accuracy(ok: pd.DataFrame):
    """Predicted vs measured charge and energy, one point per flight, with the 1:1 line."""
    fig, (a1, a2) = figure(1, 2, figsize=(10, 4.4))
    for ax, meas, pred, what, unit in (
            (a1, "charge_mah", "predicted_charge_mah", "charge drawn", "mAh"),
            (a2, "airborne_energy_wh", "predicted_energy_wh", "airborne energy", "Wh")):
        m = pd.to_numeric(ok[meas], errors="coerce").to_numpy(float)
        p = pd.to_numeric(ok[pred], errors="coerce").to_numpy(float)
        good = np.isfinite(m) & np.isfinite(p)
        ax.plot(m[good], p[good], "o", ms=3.5, alpha=0.7, color="C0",
                label=f"flights ({good.sum()})")
        if good.any():
            lim = [0.0, 1.05 * float(max(m[good].max(), p[good].max()))]
            ax.plot(lim, lim, "k--", lw=1, label="predicted = measured")
        ax.set_xlabel(f"measured {what} [{unit}]")
        ax.set_ylabel(f"predicted {what} [{unit}]")
        ax.set_title(f"{what}: planner vs log")
        ax.grid(alpha=0.3)
        legend_outside(ax)
    return fig


def outlier_limits(values: np.ndarray, spread: float = 4.0) -> tuple[float, float]:
    """The error range drawn in full: the quartiles widened by ``spread`` interquartile
    ranges (at least ±10 % round the median); points beyond are drawn at the edge and
    labelled with their value, so that one bad log does not squash the others."""
    v = values[np.isfinite(values)]
    if v.size == 0:
        return -10.0, 10.0
    q1, med, q3 = np.percentile(v, [25, 50, 75])
    iqr = max(q3 - q1, 5.0)
    lo, hi = min(q1 - spread * iqr, med - 10.0), max(q3 + spread * iqr, med + 10.0)
    return float(min(lo, 0.0)), float(max(hi, 0.0))


def plot_drift(ok: pd.DataFrame, order: np.ndarray):
    """Charge and energy error against the flight order; outliers clipped to the edge
    and annotated with their value."""
    fig, ax = figure(figsize=(11, 4.2))
    series = []
    # one sign for both: measured − predicted (the table's energy error is predicted −
    # measured, so it is turned round here)
    for col, sign, label, colour in (
            ("charge_error_pct", 1.0, "charge (measured − predicted)", "C0"),
            ("energy_error_pct", -1.0, "energy (measured − predicted)", "C3")):
        y = sign * pd.to_numeric(ok[col], errors="coerce").to_numpy(float)
        series.append((y, label, colour))
    lo, hi = outlier_limits(np.concatenate([y for y, _, _ in series]) if series
                            else np.array([]))
    clipped = 0
    for y, label, colour in series:
        good = np.isfinite(y)
        inside = good & (y >= lo) & (y <= hi)
        if good.any():
            ax.plot(order[inside], y[inside], "o", ms=3, alpha=0.7, color=colour,
                    label=label)
        for j in np.flatnonzero(good & ~inside):
            edge = hi if y[j] > hi else lo
            ax.plot(order[j], edge, "^" if y[j] > hi else "v", ms=7, color=colour,
                    mec="k", label="outside the range shown (value written)"
                    if clipped == 0 else None)
            ax.annotate(f"{y[j]:+.0f} %", (order[j], edge), xytext=(4, -10 if y[j] > hi
                                                                    else 4),
                        textcoords="offset points", fontsize=7, color=colour)
            clipped += 1
    span = hi - lo
    ax.set_ylim(lo - 0.04 * span, hi + 0.04 * span)
    ax.axhline(0.0, color="k", lw=0.7)
    ax.set_xlabel("flight (in order of start time, else log name)")
    ax.set_ylabel("error [% of measured]")
    ax.set_title("prediction error over the fleet's flights")
    ax.grid(alpha=0.3)
    legend_outside(ax)
    return fig


def plot_packs(ok: pd.DataFrame, health, retire: float):
    """Each pack's per-flight state of health :math:`a/s_i` against its cycle, the fitted
    fade and the retirement threshold."""
    fig, ax = figure(figsize=(11, 4.6))
    colours = pack_colours(len(health))
    for k, h in enumerate(health):
        flights = ok[ok["pack_id"] == h.pack_id]
        n = cycle_order(flights)
        s = flights["delta_scale"].to_numpy(float)
        colour = colours[k]
        if math.isfinite(h.scale_new):
            ax.plot(n, h.scale_new / s, "o", ms=3, color=colour, alpha=0.7,
                    label=f"pack {h.pack_id}")
            if math.isfinite(h.fade_per_cycle):
                grid = np.linspace(0.0, max(float(np.nanmax(n)), 1.0), 50)
                ax.plot(grid, 1.0 / (1.0 + h.fade_per_cycle * grid), "-", color=colour, lw=1)
    ax.axhline(retire, color="k", ls="--", lw=1, label=f"retirement at {100 * retire:.0f} %")
    ax.set_xlabel("cycle [flights]")
    ax.set_ylabel("state of health [share of the new pack's energy]")
    ax.set_title("pack health: charge per energy relative to new, and the fitted fade")
    ax.grid(alpha=0.3)
    if health:
        legend_outside(ax, fontsize=7, ncol=1 if len(health) <= 16 else 2)
    return fig


def pack_colours(n: int) -> list:
    """``n`` colours no two packs share: the 20 of ``tab20`` (dark and light of ten
    hues, the dark ones first), beyond that hues spread round the colour wheel."""
    from matplotlib import colormaps

    if n <= 10:
        return [colormaps["tab10"](k) for k in range(n)]
    if n <= 20:
        tab = colormaps["tab20"]
        return [tab(2 * k if k < 10 else 2 * (k - 10) + 1) for k in range(n)]
    hsv = colormaps["hsv"]
    return [hsv(k / n) for k in range(n)]


def write_figures(result, out: Path, *, retire: float, option: str = "--out") -> list[Path]:
    """Draw the report's figures of a fleet run into ``out``; return the paths written."""
    ok = result.table[result.table["status"] == "ok"].reset_index(drop=True)
    figs = [("accuracy.png", plot_accuracy(ok)),
            ("drift.png", plot_drift(ok, cycle_order(ok) if len(ok) else np.array([])))]
    if result.health:
        figs.append(("packs.png", plot_packs(ok, result.health, retire)))
    written = []
    for name, fig in figs:
        save(fig, out / name, option)
        written.append(out / name)
    return written
