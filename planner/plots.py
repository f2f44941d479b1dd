"""Plots. Functions draw on a given Axes (or make one) and return it; the
library never calls ``plt.show()``. Only the ``save_*`` helpers write files."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from planner.errors import InputError  # noqa: E402

_LEG_COLOURS = {"climb": "#fde0c5", "cruise": "#e5f0fa", "hover": "#e8f5e0",
                "loiter": "#e8f5e0", "descend": "#f2e6f7"}


def plot_power(result, ax=None):
    """Battery power against time, legs shaded by kind. Returns the Axes."""
    ax = ax or plt.gca()
    s = result.series
    ax.plot(s["time_s"] / 60.0, s["power_w"], color="C3", lw=1.5, label="battery power")
    _shade_legs(ax, result)
    ax.set_ylabel("power [W]")
    ax.set_xlabel("time [min]")
    ax.grid(alpha=0.3)
    return ax


def plot_remaining(result, ax=None):
    """Remaining charge (% of nominal) against time, with the reserve line."""
    ax = ax or plt.gca()
    s = result.series
    ax.plot(s["time_s"] / 60.0, 100 * s["remaining_fraction"], color="C0", lw=1.8,
            label="remaining charge (integral model)")
    ax.axhline(100 * result.reserve_fraction, color="k", ls="--", lw=1,
               label=f"landing reserve {100 * result.reserve_fraction:.0f} %")
    usable = 100 * (1 - result.usable_mah / result.capacity_mah)
    if usable > 0:
        ax.axhline(usable, color="0.5", ls=":", lw=1, label="unusable charge")
    if result.point_of_no_return:
        t = result.point_of_no_return["time_s"] / 60.0
        ax.axvline(t, color="C3", ls="-.", lw=1.2, label="point of no return")
    _shade_legs(ax, result)
    ax.set_ylim(min(0, 100 * np.nanmin(s["remaining_fraction"]) - 5), 105)
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


def save_mission_plot(result, path, title=None):
    """Two panels: power and remaining charge against time; legs marked."""
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    plot_power(result, ax1)
    plot_remaining(result, ax2)
    ax1.set_title(title or f"{result.aircraft}: {result.verdict}")
    ax1.legend(loc="upper right", fontsize=8, ncol=3)
    ax2.legend(loc="lower left", fontsize=8)
    fig.tight_layout()
    save(fig, path)


def save(fig, path):
    try:
        fig.savefig(path, dpi=110)
    except OSError as exc:
        raise InputError(f"{path}: cannot write the plot ({exc.strerror})") from None
    finally:
        plt.close(fig)
