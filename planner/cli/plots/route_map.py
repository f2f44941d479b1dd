"""The route, drawn: a map of the mission in local east/north metres around home (no map
tiles: it draws offline), each leg coloured by the charge left, the point of no return and
the worst return-home point marked, the wind arrow, a scale bar, home and landing.

:func:`save_route_map` draws one pre-flight check; :func:`save_sorties_map` draws the
sorties of a plan, each in its own colour. Positions come from the check's per-leg table
(``start_east_m`` … ``end_north_m``, :func:`planner.chain.mission_chain.route_columns`):
the legs' frame, east and north of home.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib import colormaps
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

from planner.cli.plots.common import save

#: Colour map of the charge left (% of nominal): red empty, green full.
CHARGE_CMAP = "RdYlGn"


def route_points(result) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """East, north [m] and charge left [% of nominal] along the route, at the samples of
    the check's series (each sample placed on its leg by the share of the leg's time
    flown)."""
    legs, s = result.legs, result.series
    t = np.asarray(s["time_s"], float)
    k = np.clip(np.asarray(s["leg"], int), 0, len(legs) - 1)
    t0 = legs["start_time_s"].to_numpy(float)[k]
    dur = legs["duration_s"].to_numpy(float)[k]
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.clip(np.where(dur > 0, (t - t0) / np.where(dur > 0, dur, 1.0), 1.0), 0, 1)
    e0, n0 = legs["start_east_m"].to_numpy(float)[k], legs["start_north_m"].to_numpy(float)[k]
    e1, n1 = legs["end_east_m"].to_numpy(float)[k], legs["end_north_m"].to_numpy(float)[k]
    left = 100.0 * np.asarray(s["remaining_fraction"], float)
    return e0 + f * (e1 - e0), n0 + f * (n1 - n0), left


def _segments(east, north):
    pts = np.column_stack([east, north])
    return np.stack([pts[:-1], pts[1:]], axis=1)


def nice_length(span_m: float) -> float:
    """A round length (1, 2 or 5 × 10^k m) of about a fifth of ``span_m``, for the scale
    bar. [m]"""
    target = max(span_m / 5.0, 1.0)
    base = 10.0 ** math.floor(math.log10(target))
    for m in (5, 2, 1):
        if m * base <= target:
            return m * base
    return base


def _length_text(m: float) -> str:
    return f"{m / 1000:g} km" if m >= 1000 else f"{m:g} m"


def draw_route(ax, result, *, colour=None, label=None, marks=True, cmap=CHARGE_CMAP):
    """One route on ``ax``: coloured by the charge left (``colour`` None) or drawn in one
    colour (a sortie); with ``marks``, the point of no return, the worst return-home point,
    hovers/loiters and the landing. Returns the LineCollection (or Line2D) drawn."""
    east, north, left = route_points(result)
    if colour is None:
        lc = LineCollection(_segments(east, north), cmap=colormaps[cmap],
                            norm=Normalize(0.0, 100.0), linewidths=2.6, zorder=3)
        lc.set_array(np.clip(0.5 * (left[:-1] + left[1:]), 0.0, 100.0))
        ax.add_collection(lc)
        artist = lc
    else:
        (artist,) = ax.plot(east, north, color=colour, lw=2.0, zorder=3, label=label)
    legs = result.legs
    if marks:
        hold = legs["kind"].isin(["hover", "loiter"]).to_numpy()
        if hold.any():
            ax.plot(legs["start_east_m"][hold], legs["start_north_m"][hold], "o", ms=9,
                    mfc="none", mec="0.25", mew=1.4, ls="none", zorder=4,
                    label="hover / loiter")
        ax.plot(legs["end_east_m"].iloc[-1], legs["end_north_m"].iloc[-1], "s", ms=8,
                color="0.15", mfc="white", mew=1.6, ls="none", zorder=5, label="landing")
        unusable = 100.0 * (1.0 - result.usable_mah / result.capacity_mah)
        empty = np.flatnonzero(left <= unusable)
        if empty.size:
            j = int(empty[0])
            t = float(result.series["time_s"][j])
            ax.plot(east[j], north[j], "*", ms=15, color="k", mfc="C3", ls="none", zorder=6,
                    label=f"usable charge runs out (t = {t:.0f} s)")
        p = result.point_of_no_return
        if p:
            ax.plot(p["east_m"], p["north_m"], "X", ms=11, color="C3", mec="k", ls="none",
                    zorder=6, label=f"point of no return (t = {p['time_s']:.0f} s)")
        w = result.worst_return
        if w:
            margin = ("home out of reach" if w.get("rtl_margin_mah") is None
                      else f"margin {w['rtl_margin_mah']:+.0f} mAh")
            ax.plot(w["east_m"], w["north_m"], "D", ms=8, color="C1", mec="k", ls="none",
                    zorder=6, label=f"worst return home ({margin}, t = {w['time_s']:.0f} s)")
    return artist


def draw_home(ax):
    """Mark home (the take-off point, the map's origin at 0 m east, 0 m north) on ``ax``."""
    ax.plot(0.0, 0.0, "^", ms=11, color="k", ls="none", zorder=7, label="home (take-off)")


def draw_wind(ax, environment):
    """The wind on its own small axes beside the map: an arrow pointing where the wind
    blows to (north up), its speed and the direction it blows from."""
    ax.set_xlim(-1, 1)
    ax.set_ylim(-1.9, 1.1)
    ax.set_aspect("equal")
    ax.axis("off")
    if environment is None:
        return
    speed, frm = environment.wind_speed_ms, environment.wind_from_deg
    ax.text(0, 1.05, "N ↑", ha="center", va="bottom", fontsize=7, color="0.4")
    if speed > 0:
        to = math.radians(frm + 180.0)
        d = 0.8 * np.array([math.sin(to), math.cos(to)])
        ax.annotate("", xy=(d[0], d[1]), xytext=(-d[0], -d[1]),
                    arrowprops=dict(arrowstyle="-|>", color="C0", lw=2.2, mutation_scale=16))
        text = f"wind\n{speed:.1f} m/s\nfrom {frm:.0f}°"
    else:
        text = "no wind"
    ax.text(0, -1.0, text, ha="center", va="top", fontsize=8, color="C0")


def _frame(ax, east, north):
    """Equal scale, a margin round the route, the scale bar, axis labels and the grid."""
    e_lo, e_hi = float(np.nanmin(east)), float(np.nanmax(east))
    n_lo, n_hi = float(np.nanmin(north)), float(np.nanmax(north))
    span = max(e_hi - e_lo, n_hi - n_lo, 50.0)
    half = 0.62 * span
    ce, cn = 0.5 * (e_lo + e_hi), 0.5 * (n_lo + n_hi)
    ax.set_xlim(ce - half, ce + half)
    ax.set_ylim(cn - half, cn + half)
    ax.set_aspect("equal", adjustable="box")
    bar = nice_length(span)
    ax.add_artist(AnchoredSizeBar(ax.transData, bar, _length_text(bar), "lower right",
                                  pad=0.5, sep=4, frameon=True, size_vertical=0,
                                  fontproperties={"size": 8}))
    ax.set_xlabel("east of home [m]")
    ax.set_ylabel("north of home [m]")
    ax.grid(alpha=0.3)


def _legend(ax):
    """The legend below the map, clear of the route."""
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=2, fontsize=8,
              frameon=False)


def _figure():
    """The map's axes, and beside it the wind's and the colour bar's."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9.0, 8.5), layout="constrained")
    axes = fig.subplot_mosaic([["map", "wind"], ["map", "bar"]], width_ratios=[1, 0.1],
                              height_ratios=[0.22, 0.78])
    return fig, axes


def save_route_map(result, path, title=None, option: str = "--map"):
    """Write :func:`route_map` to ``path``."""
    save(route_map(result, title), path, option)


def route_map(result, title=None):
    """The map of one pre-flight check (:class:`planner.chain.result.MissionResult`):
    the figure, its axes ``"map"``, ``"wind"`` and ``"bar"``."""
    fig, axes = _figure()
    ax = axes["map"]
    lc = draw_route(ax, result)
    draw_home(ax)
    east, north, _ = route_points(result)
    _frame(ax, np.append(east, 0.0), np.append(north, 0.0))
    draw_wind(axes["wind"], result.environment)
    bar = fig.colorbar(lc, cax=axes["bar"])
    bar.set_label("charge left [% of nominal]")
    unusable = 100 * (1 - result.usable_mah / result.capacity_mah)
    limit = unusable + 100 * result.reserve_fraction
    bar.ax.axhline(limit, color="k", ls="--", lw=1.5)
    bar.ax.text(1.05, limit, " landing\n limit", transform=bar.ax.get_yaxis_transform(),
                va="center", fontsize=7)
    ax.set_title(title or f"{result.aircraft}, {result.battery}: {result.verdict}",
                 fontsize=10)
    _legend(ax)
    return fig


def save_sorties_map(plan, path, title=None, option: str = "--map"):
    """Write :func:`sorties_map` to ``path``."""
    save(sorties_map(plan, title), path, option)


def sorties_map(plan, title=None):
    """The sorties of a plan (:class:`planner.chain.sizing.SortiePlan`), each in its own
    colour, the swap points marked."""
    fig, axes = _figure()
    ax = axes["map"]
    axes["bar"].set_visible(False)
    es, ns = [0.0], [0.0]
    colours = colormaps["tab10"].colors
    for k, s in enumerate(plan.sorties):
        r = s.result
        draw_route(ax, r, colour=colours[k % len(colours)], marks=False,
                   label=f"flight {s.number}: {r.duration_s / 60:.1f} min, margin "
                         f"{r.margin_mah:+.0f} mAh ({r.verdict})")
        e, n, _ = route_points(r)
        es.extend(e)
        ns.extend(n)
    for k, sp in enumerate(plan.splits, 1):
        ax.plot(sp.east_m, sp.north_m, "P", ms=11, color="k", mfc="white", mew=1.6,
                ls="none", zorder=6, label="pack swap" if k == 1 else None)
    draw_home(ax)
    _frame(ax, np.asarray(es), np.asarray(ns))
    if plan.sorties:
        draw_wind(axes["wind"], plan.sorties[0].result.environment)
    ax.set_title(title or f"{plan.count} sorties with {plan.pack.name}", fontsize=10)
    _legend(ax)
    return fig
