"""The fleet's accuracy report: ``DIR/report.md`` and its figures.

* predicted vs measured charge (battery level, from the measured power) and airborne energy
  (power level, from the measured flight state) over every flight, with the bias (mean
  error) and the P95 of the absolute error, in per cent of the measured value;
* drift: the error against the flight's order (start time, else log name), with a
  least-squares slope and its standard error — a model that was right for the new fleet
  and drifts as it ages shows here;
* the worst flights by charge error, with their data-quality warnings;
* per pack: flights, state of health, fade per cycle, flights to retirement, resistance;
* per aircraft: the model calibrated on the whole fleet (:mod:`planner.fleet.calibrate`),
  its parameters with standard errors, and its error on held-out flights against the
  aircraft file as given.

Figures are :class:`matplotlib.figure.Figure` objects (:func:`planner.plots.figure`),
written through :func:`planner.plots.save`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from planner import files
from planner.fleet.health import cycle_order
from planner.plots import figure, save

#: Flights listed as the worst.
WORST = 10


def error_summary(error_pct) -> dict[str, float]:
    """Bias (mean), P95 of the absolute value and count of finite errors. [%]"""
    e = np.asarray(error_pct, float)
    e = e[np.isfinite(e)]
    if e.size == 0:
        return {"n": 0, "bias_pct": math.nan, "p95_abs_pct": math.nan}
    return {"n": int(e.size), "bias_pct": float(np.mean(e)),
            "p95_abs_pct": float(np.percentile(np.abs(e), 95))}


def drift(order, error_pct) -> tuple[float, float]:
    """Least-squares slope of the error against the flight order and its standard error.
    [%/flight]"""
    x = np.asarray(order, float)
    y = np.asarray(error_pct, float)
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 4 or np.ptp(x[ok]) <= 0:
        return math.nan, math.nan
    coef, cov = np.polyfit(x[ok], y[ok], 1, cov=True)
    return float(coef[0]), float(math.sqrt(cov[0, 0]))


def _fmt(x, digits=1, unit=""):
    if x is None or (isinstance(x, float) and not math.isfinite(x)) or x is pd.NA:
        return "–"
    return f"{x:.{digits}f}{unit}"


def _cell(text, width: int = 160) -> str:
    """Text for a Markdown table cell: one line, no column bars, shortened."""
    if text is None or text is pd.NA or (isinstance(text, float) and math.isnan(text)):
        return ""
    one = " ".join(str(text).replace("|", "/").split())
    return one if len(one) <= width else one[:width - 1] + "…"


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


def render(result, *, retire: float, within: float) -> str:
    """The Markdown report (module notes)."""
    table = result.table
    ok = table[table["status"] == "ok"].reset_index(drop=True)
    bad = table[table["status"] == "failed"]
    unusable = table[table["status"] == "not replayable"]
    lines = ["# Fleet report", "",
             f"{len(ok)} flights in the table ({len(bad)} failed logs"
             + (f", {len(unusable)} not replayable" if len(unusable) else "")
             + "); this run summarised "
             f"{result.processed} logs ({len(result.failed)} failed) and found "
             f"{result.skipped} already in the table.", ""]
    ch = error_summary(ok["charge_error_pct"])
    en = error_summary(ok["energy_error_pct"])
    order = cycle_order(ok) if len(ok) else np.array([])
    d_ch, d_ch_se = drift(order, ok["charge_error_pct"])
    d_en, d_en_se = drift(order, ok["energy_error_pct"])
    lines += ["## Predicted vs measured", "",
              "| level | flights | bias | P95 of the absolute error | drift per flight |",
              "|---|---:|---:|---:|---:|",
              f"| charge (battery model on measured power; measured − predicted) | {ch['n']} | "
              f"{_fmt(ch['bias_pct'], 2, ' %')} | {_fmt(ch['p95_abs_pct'], 2, ' %')} | "
              f"{_fmt(d_ch, 3, ' %')} ± {_fmt(d_ch_se, 3, ' %')} |",
              f"| airborne energy (power model on measured flight state; predicted − measured)"
              f" | {en['n']} | {_fmt(en['bias_pct'], 2, ' %')} | "
              f"{_fmt(en['p95_abs_pct'], 2, ' %')} | {_fmt(d_en, 3, ' %')} ± "
              f"{_fmt(d_en_se, 3, ' %')} |", "",
              "Errors are in per cent of the measured value. Drift is the least-squares slope "
              "of the error against the flight's order, with its standard error.", "",
              "![predicted vs measured](accuracy.png)", "", "![drift](drift.png)", ""]
    if len(ok):
        worst = ok.assign(_abs=ok["charge_error_pct"].abs()).sort_values(
            "_abs", ascending=False, na_position="last").head(WORST)
        diag = getattr(result, "diagnoses", {}) or {}
        lines += ["## Worst flights (charge error)", "",
                  "| log | pack | duration s | charge mAh | predicted mAh | error % | energy "
                  "error % | warnings |", "|---|---|---:|---:|---:|---:|---:|---|"]
        for _, r in worst.iterrows():
            lines.append(f"| {Path(str(r['log'])).name} | {r['pack_id']} | "
                         f"{_fmt(r['duration_s'], 0)} | {_fmt(r['charge_mah'], 0)} | "
                         f"{_fmt(r['predicted_charge_mah'], 0)} | "
                         f"{_fmt(r['charge_error_pct'], 2)} | "
                         f"{_fmt(r['energy_error_pct'], 1)} | "
                         f"{_cell(r['warnings'])} |")
        lines.append("")
        if diag:
            lines += ["`diagnose` (DESIGN §6) on each of the worst flights alone:", ""]
            lines += [f"- {Path(log).name}: {_cell(text, 600)}" for log, text in diag.items()]
            lines.append("")
    if result.health:
        lines += ["## Pack health", "",
                  f"State of health: the share of the new pack's energy its charge still "
                  f"delivers, 1/(1 + fade × cycle). Retirement at {100 * retire:.0f} %; "
                  f"flagged: within the next {within:g} flights.", "",
                  "| pack | flights | last cycle | SoH % | fade per cycle | flights to "
                  "retirement | resistance mΩ | pack file | flag |",
                  "|---|---:|---:|---:|---:|---:|---:|---|---|"]
        for h in result.health:
            f = result.pack_files.get(h.pack_id)
            flag = "RETIRE" if h.retires_within(within) else ""
            lines.append(
                f"| {h.pack_id} | {h.flights} | {_fmt(h.last_cycle, 0)} | "
                f"{_fmt(100 * h.soh, 1)} ± {_fmt(100 * h.soh_se, 1)} | "
                f"{_fmt(h.fade_per_cycle * 1e3, 3)} ± {_fmt(h.fade_per_cycle_se * 1e3, 3)} "
                f"‰ | {_fmt(h.flights_to_retire, 0)} | "
                f"{_fmt(h.resistance_ohm * 1e3, 1)} ± {_fmt(h.resistance_se_ohm * 1e3, 1)} | "
                f"{'packs/' + f.name if f else '–'} | {flag} |")
        lines += ["", "![pack health](packs.png)", ""]
    cals = getattr(result, "calibrations", []) or []
    if cals:
        lines += ["## Aircraft calibrated on the fleet", "",
                  "Fitted on the flights of each aircraft but about one in five, held out by "
                  "content hash; scored on the held-out flights' airborne samples (energy "
                  "error: predicted − measured, in per cent of the measured).", "",
                  "| aircraft | flights fitted / held out | parameter: file → calibrated ± SE "
                  "| held-out power RMSE, file → calibrated | held-out energy error | mean "
                  "absolute per-flight energy error | file |",
                  "|---|---:|---|---:|---:|---:|---|"]
        for c in cals:
            if c.aircraft is None:
                lines.append(f"| {c.key} | – | not calibrated: {_cell(c.note, 200)} | | | | |")
                continue
            params = "; ".join(
                f"{k} {c.start.get(k, math.nan):.4g} → {v:.4g} ± {c.stderr.get(k, math.nan):.2g}"
                + (" (poorly determined)" if k in c.poorly_determined else "")
                + (" (at a bound)" if k in c.at_bound else "")
                for k, v in c.parameters.items())
            b, a = c.validation.get("before", {}), c.validation.get("after", {})
            fb, fa = c.flight_error_pct.get("before"), c.flight_error_pct.get("after")
            lines.append(
                f"| {c.key} | {c.train_flights} / {c.validation_flights} | {params} | "
                f"{_fmt(b.get('rmse_w'), 1, ' W')} → {_fmt(a.get('rmse_w'), 1, ' W')} | "
                f"{_fmt(b.get('energy_error_pct'), 2, ' %')} → "
                f"{_fmt(a.get('energy_error_pct'), 2, ' %')} | {_fmt(fb, 2, ' %')} → "
                f"{_fmt(fa, 2, ' %')} | {'aircraft/' + c.file.name if c.file else '–'} |")
        lines.append("")
    if result.failed:
        lines += ["## Failed logs (this run)", ""]
        lines += [f"- {_cell(err, 400)}" for _, err in result.failed]
        lines.append("")
    if result.not_replayable:
        lines += ["## Logs read but not replayable (this run)", ""]
        lines += [f"- {_cell(err, 400)}" for _, err in result.not_replayable]
        lines.append("")
    if result.notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in result.notes] + [""]
    return "\n".join(lines) + "\n"


def write_report(result, out: Path, *, retire: float, within: float) -> list[Path]:
    """Write ``report.md`` and its PNG figures into ``out``; return the paths."""
    ok = result.table[result.table["status"] == "ok"].reset_index(drop=True)
    written = []
    figs = [("accuracy.png", plot_accuracy(ok)),
            ("drift.png", plot_drift(ok, cycle_order(ok) if len(ok) else np.array([])))]
    if result.health:
        figs.append(("packs.png", plot_packs(ok, result.health, retire)))
    for name, fig in figs:
        save(fig, out / name, "--out")
        written.append(out / name)
    files.write_text(out / "report.md", render(result, retire=retire, within=within), "--out")
    written.append(out / "report.md")
    return written
