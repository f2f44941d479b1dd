"""The fixed-wing fit's figure: power required against airspeed and the polar C_D(C_L),
with the energy-rate corrected samples, the fitted curves and optional reference curves
(e.g. a published reconstruction of the same flight)."""

from __future__ import annotations

import numpy as np

from planner.cli.plots.common import figure, figure_legend
from planner.io import files


def save_fixed_wing_plot(samples, curves, path, *, references=(), title=None,
                         density_note=None) -> None:
    """Two panels, written to ``path``.

    Parameters
    ----------
    samples : DataFrame
        :func:`planner.identify.fixed_wing_fit.corrected_samples` (``airspeed_ms``,
        ``level_power_w``, ``lift_coefficient``, ``drag_coefficient``, ``glide``); drawn as
        points, glides marked. May be None.
    curves : list of dict
        Each ``{"label", "airspeed_ms", "power_w", "cl", "cd"}``: a fitted model's power
        curve and polar, drawn as lines.
    references : list of dict
        The same keys, drawn dashed (a published or re-run reconstruction).
    density_note : str, optional
        Says at which density the power curves are drawn (axis label).
    """
    fig, (ax_p, ax_d) = figure(1, 2, figsize=(11.0, 4.4))
    fig.set_layout_engine("constrained")
    if samples is not None and len(samples):
        g = np.asarray(samples["glide"], bool)
        for mask, label, colour in ((~g, "samples, energy-rate corrected", "#9ab"),
                                    (g, "glide samples (motor off)", "#d62")):
            if mask.any():
                ax_p.plot(samples["airspeed_ms"][mask], samples["level_power_w"][mask], ".",
                          ms=2.5, color=colour, label=label, alpha=0.6)
                ax_d.plot(samples["lift_coefficient"][mask],
                          samples["drag_coefficient"][mask], ".", ms=2.5, color=colour,
                          alpha=0.6, label=label)
    for c in curves:
        ax_p.plot(c["airspeed_ms"], c["power_w"], "-", lw=2, label=c["label"])
        ax_d.plot(c["cl"], c["cd"], "-", lw=2, label=c["label"])
    for c in references:
        ax_p.plot(c["airspeed_ms"], c["power_w"], "--", lw=2, color="k", label=c["label"])
        ax_d.plot(c["cl"], c["cd"], "--", lw=2, color="k", label=c["label"])
    ax_p.set_xlabel("airspeed [m/s]" + (f" ({density_note})" if density_note else ""))
    ax_p.set_ylabel("battery power, level steady flight [W]")
    ax_p.set_ylim(0, None)
    ax_d.set_xlabel("lift coefficient C_L [-]")
    ax_d.set_ylabel("drag coefficient C_D [-]")
    ax_d.set_ylim(0, 0.2)
    ax_d.set_xlim(0, 2.0)
    for ax in (ax_p, ax_d):
        ax.grid(alpha=0.3)
    figure_legend(fig, (ax_p, ax_d), ncol=3)
    if title:
        fig.suptitle(title, fontsize=10)
    files.save_figure(fig, path, dpi=120)
