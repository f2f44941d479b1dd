"""Plots for pack selection and sizing. Functions draw on a given Axes (or make one) and
return it; the library never calls ``plt.show()``. Only the ``save_*`` helpers write files."""

from __future__ import annotations

import numpy as np

from planner.cli.plots.common import figure, legend_outside, new_axes, save

#: The binding constraint of a rejected pack, in the legend's words.
REJECT_WORDS = {
    "mission": "mission cannot be flown", "cells": "cell count not allowed",
    "thrust": "thrust-to-weight too low", "power": "power above the aircraft's maximum",
    "c_rating": "current above the pack's C rating",
    "takeoff_mass": "over the maximum take-off mass", "temperature": "pack overheats",
    "voltage": "loaded voltage below the cut-off", "runs_out": "runs out of charge",
    "landing_reserve": "lands below the reserve", "return_home": "cannot return home",
}


def plot_sorties(plan, ax=None):
    """The sortie plan (when no single pack flies the mission): remaining charge of each
    sortie against mission time, one after the other, each ending above its landing limit,
    with the swaps marked. Returns the Axes."""
    ax = ax or new_axes()
    offset = 0.0
    limit = None
    for s in plan.sorties:
        r = s.result
        t = np.asarray(r.series["time_s"], float)
        frac = 100 * np.asarray(r.series["remaining_fraction"], float)
        ax.plot((offset + t) / 60.0, frac, lw=1.6, color=f"C{(s.number - 1) % 10}",
                label=f"sortie {s.number}: {r.duration_s / 60:.1f} min, lands with "
                      f"{r.landing_charge_mah:.0f} mAh")
        unusable = 100 * (1 - r.usable_mah / r.capacity_mah)
        limit = unusable + 100 * r.reserve_fraction
        offset += t[-1] if t.size else 0.0
        if s.number < plan.count:
            ax.axvline(offset / 60.0, color="0.3", ls=":", lw=1.0,
                       label="land and swap the pack" if s.number == 1 else None)
    if limit is not None:
        ax.axhline(limit, color="k", ls="--", lw=1.2, label="landing limit (reserve)")
    ax.set_xlabel("flight time, sorties in sequence [min]")
    ax.set_ylabel("remaining charge [% of nominal]")
    ax.set_ylim(0, 105)
    ax.set_title(f"{plan.count} sorties with {plan.pack.name}"
                 + (" (provably the fewest)" if plan.minimal else ""))
    ax.grid(alpha=0.3)
    return ax


def pareto_front(mass, margin, feasible):
    """Indices of the feasible packs no other feasible pack beats on both mass and margin.

    A pack is on the front when every lighter (or equally heavy) feasible pack has a
    smaller margin. Returned in order of increasing mass.
    """
    mass, margin = np.asarray(mass, float), np.asarray(margin, float)
    idx = np.flatnonzero(np.asarray(feasible, bool) & np.isfinite(margin))
    idx = idx[np.lexsort((-margin[idx], mass[idx]))]
    front, best = [], -np.inf
    for i in idx:
        if margin[i] > best:
            front.append(int(i))
            best = margin[i]
    return np.array(front, dtype=int)


def plot_pareto(selection, ax=None):
    """Pack mass against landing margin (extra hover/loiter time), feasible and rejected.

    The Pareto front of the feasible packs (lightest pack for each margin) is joined
    by a line and the chosen pack is labelled. Returns the Axes.
    """
    ax = ax or new_axes()
    e = selection.evaluation
    what = "hover" if e.aircraft_type == "multirotor" else "loiter"
    mass = e.pack_mass_kg
    margin = np.where(np.isfinite(e.margin_time_s), e.margin_time_s, np.nan) / 60.0
    ok = e.feasible
    floor = np.nanmin(margin) if np.any(np.isfinite(margin)) else 0.0
    shown = np.where(np.isfinite(margin), margin, floor)
    # rejected packs, one marker per binding constraint, named in the legend
    binding = np.array([e.binding(i) or "" for i in range(len(mass))], dtype=object)
    markers = "xv^<>sPD1234"
    for k, code in enumerate(sorted({b for b in binding[~ok]},
                                    key=lambda c: REJECT_WORDS.get(c, c))):
        sel = ~ok & (binding == code)
        ax.scatter(mass[sel], shown[sel], marker=markers[k % len(markers)],
                   color=f"C{(k + 4) % 10}", s=30,
                   label=f"rejected: {REJECT_WORDS.get(code, code)} ({int(sel.sum())})")
    ax.scatter(mass[ok], shown[ok], marker="o", color="C0", s=30, edgecolor="k",
               linewidth=0.4, label=f"feasible ({int(ok.sum())})")
    front = pareto_front(mass, margin, ok)
    if front.size:
        ax.step(mass[front], margin[front], where="post", color="C2", lw=1.5,
                label="Pareto front (feasible)")
    if selection.best is not None:
        b = selection.best
        ax.scatter([mass[b]], [margin[b]], marker="*", s=220, color="C3", edgecolor="k",
                   zorder=5, label=f"chosen ({selection.objective}): "
                                   f"{e.packs[b].name}")
    ax.axhline(0.0, color="k", lw=0.8, ls="--", label="landing reserve reached")
    label_packs(ax, selection, mass, shown)
    ax.set_xlabel("pack mass (× count) [kg]")
    ax.set_ylabel(f"landing margin beyond the {100 * e.reserve_fraction:.0f} % reserve "
                  f"[min of {what}]")
    ax.grid(alpha=0.3)
    return ax


#: Most packs named beside their point on the Pareto plot (the best-ranked first).
MAX_LABELS = 12


def label_packs(ax, selection, mass, shown):
    """Name the packs beside their points: the feasible ones in ranking order, then the
    rejected ones, at most :data:`MAX_LABELS`."""
    e = selection.evaluation
    order = [int(i) for i in selection.order]
    ranked = [i for i in order if e.feasible[i]] + [i for i in order if not e.feasible[i]]
    for i in ranked[:MAX_LABELS]:
        p = e.packs[i]
        name = p.name + (f" ×{p.count}" if p.count > 1 else "")
        ax.annotate(name if len(name) <= 28 else name[:27] + "…", (mass[i], shown[i]),
                    xytext=(4, 3), textcoords="offset points", fontsize=6.5,
                    color="0.2" if e.feasible[i] else "0.5")


def save_pareto_plot(selection, path, title=None, plan=None):
    """The Pareto plot; beside it the sortie plan when there is one (no pack suffices)."""
    if plan is None:
        fig, ax = figure(figsize=(11, 6))
    else:
        fig, (ax, ax2) = figure(1, 2, figsize=(18, 6))
        plot_sorties(plan, ax2)
        legend_outside(ax2)
    plot_pareto(selection, ax)
    e = selection.evaluation
    ax.set_title(title or f"{e.mission_name}: {e.aircraft_name}, {len(e)} packs",
                 fontsize=10, wrap=True)
    legend_outside(ax)
    save(fig, path)


def plot_endurance_sweep(sweep, ax=None):
    """Endurance against battery mass with the optimum marked. Returns the Axes."""
    ax = ax or new_axes()
    m, t = sweep.battery_mass_kg, sweep.endurance_s / 60.0
    ax.plot(m, t, color="C0", lw=1.8, label=f"{sweep.hold} time to the "
                                            f"{100 * sweep.reserve_fraction:.0f} % reserve")
    if not sweep.feasible.all():
        ax.plot(m[~sweep.feasible], t[~sweep.feasible], ".", color="C3", ms=3,
                label="beyond max take-off mass or thrust")
    o = sweep.optimum
    ax.plot([o["battery_mass_kg"]], [o["endurance_s"] / 60.0], "*", ms=14, color="C3",
            mec="k", label=f"optimum {o['battery_mass_kg']:.2f} kg "
                           f"(mass fraction {o['mass_fraction']:.2f})")
    if o.get("constrained_battery_mass_kg") is not None and (
            abs(o["constrained_battery_mass_kg"] - o["battery_mass_kg"]) > 1e-9):
        ax.plot([o["constrained_battery_mass_kg"]], [o["constrained_endurance_s"] / 60.0],
                "D", ms=8, color="C2", mec="k", label="best within the limits")
    ax.set_xlabel("battery mass [kg]")
    ax.set_ylabel(f"{sweep.hold} endurance [min]")
    ax.grid(alpha=0.3)
    return ax


def save_endurance_plot(sweep, path, title=None):
    """Write the endurance–battery-mass sweep ``sweep`` as a PNG to ``path`` (title: the
    aircraft, specific energy [Wh/kg], cells and payload [kg], unless ``title``)."""
    fig, ax = figure(figsize=(11, 5.5))
    plot_endurance_sweep(sweep, ax)
    ax.set_title(title or f"{sweep.aircraft}:\n{sweep.specific_energy_wh_per_kg:.0f} Wh/kg, "
                          f"{sweep.cells_series}S, payload {sweep.payload_kg:g} kg",
                 fontsize=10)
    legend_outside(ax)
    save(fig, path)


def plot_range_sweep(sweep, ax=None):
    """Range against payload (cruise and best-range speed). Returns the Axes."""
    ax = ax or new_axes()
    p = sweep.payload_kg
    ax.plot(p, sweep.range_m / 1000.0, color="C0", lw=1.8,
            label=f"at cruise speed {sweep.cruise_speed_ms:.1f} m/s")
    ax.plot(p, sweep.best_range_m / 1000.0, color="C1", lw=1.5, ls="--",
            label="at the best-range airspeed")
    if not sweep.feasible.all():
        ax.axvspan(p[~sweep.feasible].min(), p.max(), color="C3", alpha=0.12,
                   label="beyond max take-off mass or thrust")
    ax.set_xlabel("payload [kg]")
    ax.set_ylabel("still-air range to the reserve [km]")
    ax.grid(alpha=0.3)
    return ax


def save_range_plot(sweep, path, title=None):
    """Write the range–payload sweep ``sweep`` as a PNG to ``path`` (title: the aircraft and
    pack, unless ``title``)."""
    fig, ax = figure(figsize=(11, 5.5))
    plot_range_sweep(sweep, ax)
    ax.set_title(title or f"{sweep.aircraft} with {sweep.pack}:\nrange against payload",
                 fontsize=10)
    legend_outside(ax)
    save(fig, path)
