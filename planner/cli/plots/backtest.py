"""The backtest's figure (``DIR/predicted_vs_measured.png``): each scored flight's
predicted against measured energy and flight time, with the 1:1 line and the ±10 % lines,
coloured by the commanded speed."""

from __future__ import annotations

import numpy as np
import pandas as pd

from planner.cli.plots.common import figure, figure_legend, save


def save_backtest_plot(table: pd.DataFrame, path, option: str = "--out") -> None:
    """Predicted against measured energy [Wh] and flight time [s], one point per scored
    flight."""
    ok = table[table["status"] == "scored"]
    fig, axes = figure(1, 2, figsize=(10.5, 4.6))
    speed = pd.to_numeric(ok["speed_ms"], errors="coerce").to_numpy(float)
    for ax, what, unit, meas, pred in (
            (axes[0], "energy", "Wh", "measured_energy_wh", "predicted_energy_wh"),
            (axes[1], "flight time", "s", "measured_time_s", "predicted_time_s")):
        m = pd.to_numeric(ok[meas], errors="coerce").to_numpy(float)
        p = pd.to_numeric(ok[pred], errors="coerce").to_numpy(float)
        good = np.isfinite(m) & np.isfinite(p)
        if good.any():
            sc = ax.scatter(m[good], p[good], c=speed[good], s=14, cmap="viridis",
                            label=f"flights ({int(good.sum())})")
            top = 1.1 * float(max(m[good].max(), p[good].max()))
            line = np.array([0.0, top])
            ax.plot(line, line, "k-", lw=1, label="predicted = measured")
            ax.plot(line, 1.1 * line, "k:", lw=0.8, label="±10 %")
            ax.plot(line, 0.9 * line, "k:", lw=0.8)
            ax.set_xlim(0, top)
            ax.set_ylim(0, top)
            if what == "flight time":
                fig.colorbar(sc, ax=ax, label="commanded speed [m/s]")
        ax.set_xlabel(f"measured {what} [{unit}]")
        ax.set_ylabel(f"predicted before take-off [{unit}]")
        ax.set_title(f"{what}: pre-flight prediction vs the log")
        ax.grid(alpha=0.3)
    figure_legend(fig, axes, ncol=3)
    save(fig, path, option)
