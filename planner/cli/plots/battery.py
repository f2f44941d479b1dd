"""The figure of ``fit-battery --plot``: measured against predicted C^β and the residual
C − Ĉ per experiment ([UAV23] Fig. 8–11 kind), at most :data:`common.PER_PAGE`
experiments a page."""

from __future__ import annotations

from planner.cli.plots.common import figure_legend, item_grid, page_path, pages, save
from planner.physics.battery import integral
from planner.physics.units import AS_PER_MAH


def save_fit_plot(experiments, result, path) -> list[str]:
    """Write the pages of :func:`fit_figures`; returns the files written (the path, then
    ``<stem>_page2<ext>`` …)."""
    written = []
    for k, fig in enumerate(fit_figures(experiments, result)):
        written.append(page_path(path, k))
        save(fig, written[-1])
    return written


def fit_figures(experiments, result) -> list:
    """One figure per page; each experiment's RMSE and final error in its residual
    panel's title, one legend per page below the panels."""
    by_name = {m.experiment: m for m in result.metrics}
    params = result.parameters
    chunks = pages(len(experiments))
    figs = []
    for k, chunk in enumerate(chunks):
        fig, cells = item_grid(len(chunk), 2, stack="horizontal")
        _draw_fit_page([experiments[j] for j in chunk], cells, by_name, params)
        more = f" (page {k + 1} of {len(chunks)})" if len(chunks) > 1 else ""
        fig.suptitle(f"integral model δ = {params['delta']:.4g}, ε = {params['epsilon']:.4g}, "
                     f"β = {params['beta']:.4g}{more}")
        figure_legend(fig, [ax for row in cells for ax in row])
        figs.append(fig)
    return figs


def _draw_fit_page(experiments, cells, by_name, params) -> None:
    for row, e in zip(cells, experiments):
        m = by_name[e.name]
        c_hat = integral.charge(e.time_s, e.power_w, **params)
        t_min = e.time_s / 60.0
        b = params["beta"]
        row[0].plot(t_min, integral.stress_from_charge(e.charge_as, b), color="k", lw=1.6,
                    label="measured $C^\\beta$")
        row[0].plot(t_min, integral.stress_from_charge(c_hat, b), color="C3", lw=1.2, ls="--",
                    label="model $\\hat C^\\beta$")
        row[0].set_title(f"{e.name} ({m.split}, mean {m.mean_power_w:.0f} W)", fontsize=9)
        row[0].set_xlabel("time [min]")
        row[0].set_ylabel("$C^\\beta$ [(A·s)$^\\beta$]")
        row[0].grid(alpha=0.3)
        row[1].plot(t_min, (e.charge_as - c_hat) / AS_PER_MAH, color="C0", lw=1.2,
                    label="residual $r = C - \\hat C$")
        row[1].axhline(0.0, color="0.5", lw=0.8)
        row[1].set_title(f"{e.name}: residual, RMSE {m.rmse_mah:.1f} mAh, final "
                         f"{m.final_error_pct:+.2f} %", fontsize=9)
        row[1].set_xlabel("time [min]")
        row[1].set_ylabel("residual [mAh]")
        row[1].grid(alpha=0.3)
