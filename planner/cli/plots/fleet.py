"""The figures of the fleet report (``DIR/accuracy.png``, ``drift.png``, ``packs.png``):
predicted against measured per flight, the error over the fleet's flights, and each pack's
state of health (:mod:`planner.fleet.report` writes the text that shows them)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from planner.cli.plots.common import figure, save
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
        ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return fig


def plot_drift(ok: pd.DataFrame, order: np.ndarray):
    """Charge and energy error against the flight order."""
    fig, ax = figure(figsize=(9, 4))
    for col, label, colour in (("charge_error_pct", "charge (measured − predicted)", "C0"),
                               ("energy_error_pct", "energy (predicted − measured)", "C3")):
        y = pd.to_numeric(ok[col], errors="coerce").to_numpy(float)
        good = np.isfinite(y)
        if good.any():
            ax.plot(order[good], y[good], "o", ms=3, alpha=0.7, color=colour, label=label)
    ax.axhline(0.0, color="k", lw=0.7)
    ax.set_xlabel("flight (in order of start time, else log name)")
    ax.set_ylabel("error [% of measured]")
    ax.set_title("prediction error over the fleet's flights")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return fig


def plot_packs(ok: pd.DataFrame, health, retire: float):
    """Each pack's per-flight state of health :math:`a/s_i` against its cycle, the fitted
    fade and the retirement threshold."""
    fig, ax = figure(figsize=(9, 4.6))
    for k, h in enumerate(health):
        flights = ok[ok["pack_id"] == h.pack_id]
        n = cycle_order(flights)
        s = flights["delta_scale"].to_numpy(float)
        colour = f"C{k % 10}"
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
        ax.legend(loc="lower left", fontsize=7, ncol=2)
    fig.tight_layout()
    return fig


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
