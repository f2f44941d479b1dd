"""The fleet's accuracy report: ``DIR/report.md`` and its figures.

* predicted vs measured charge (battery level, from the measured power) and airborne energy
  (power level, from the measured flight state) over every flight, with the bias (mean
  error) and the P95 of the absolute error, in per cent of the measured value;
* drift: the error against the flight's order (start time, else log name), with a
  least-squares slope and its standard error — a model that was right for the new fleet
  and drifts as it ages shows here;
* the worst flights by charge error, with their data-quality warnings;
* per pack: flights, state of health, fade per cycle, flights to retirement, resistance;
* the logs left out (a mismatch with the aircraft or pack, no airborne sample) and why;
* per aircraft: the model calibrated on the whole fleet (:mod:`planner.fleet.calibrate`),
  its parameters with standard errors, and its error on held-out flights against the
  aircraft file as given.

The figures it shows are drawn by the command line (``figures`` of :func:`write_report`:
:func:`planner.cli.plots.fleet.write_figures`); without them the report is text only.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from planner.io import files
from planner.fleet.health import cycle_order

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


def _pm(x, se, digits=1, unit="", why="–"):
    """``x ± se unit``; ``x unit`` without a finite standard error; ``why`` (a dash, or
    the reason) without a value: never ``– ± –``."""
    if not _finite(x):
        return why
    if not _finite(se):
        return f"{x:.{digits}f}{unit}"
    return f"{x:.{digits}f} ± {se:.{digits}f}{unit}"


def _finite(x) -> bool:
    return x is not None and x is not pd.NA and math.isfinite(float(x))


def _to_retire(h) -> str:
    """Flights to retirement: ``past`` when the pack is already below the threshold, ``no
    fade`` when it does not fade, else the count."""
    n = h.flights_to_retire
    if _finite(n) and n <= 0:
        return "past it now"
    if not _finite(n):
        return "no fade seen" if (h.fade_per_cycle is not None and _finite(h.fade_per_cycle)
                                  and h.fade_per_cycle <= 0) else "–"
    return f"{n:.0f}"


def _cell(text, width: int = 160) -> str:
    """Text for a Markdown table cell: one line, no column bars, shortened."""
    if text is None or text is pd.NA or (isinstance(text, float) and math.isnan(text)):
        return ""
    one = " ".join(str(text).replace("|", "/").split())
    return one if len(one) <= width else one[:width - 1] + "…"


def _row(*cells) -> str:
    """A Markdown table row of the cells' text."""
    return "| " + " | ".join(str(c) for c in cells) + " |"


def render(result, *, retire: float, within: float, with_figures: bool = True) -> str:
    """The Markdown report (module notes): the flights counted, predicted against
    measured, the worst flights, pack health, the aircraft calibrated on the fleet, the
    failed and unreplayable logs and the notes; ``retire`` (the state of health at
    retirement, unitless) and ``within`` (flights ahead flagged) as
    :meth:`planner.fleet.health.PackHealth.retires_within` takes them."""
    table = result.table
    ok = table[table["status"] == "ok"].reset_index(drop=True)
    lines = _counts(result, table, ok) + _accuracy(ok, with_figures)
    if len(ok):
        lines += _worst_flights(ok, getattr(result, "diagnoses", {}) or {})
    if result.health:
        lines += _pack_health(result, retire, within, with_figures)
    cals = getattr(result, "calibrations", []) or []
    if cals:
        lines += _calibrations(cals)
    if result.failed:
        lines += ["## Failed logs (this run)", ""]
        lines += [f"- {_cell(err, 400)}" for _, err in result.failed]
        lines.append("")
    if result.not_replayable:
        lines += ["## Logs read but not replayable (this run)", ""]
        lines += [f"- {_cell(err, 400)}" for _, err in result.not_replayable]
        lines.append("")
    left_out = getattr(result, "left_out", []) or []
    if left_out:
        lines += ["## Logs left out (this run)", "",
                  ("Read, but not counted in the accuracy or the calibration: the log is not "
                   "of the aircraft or pack it was flown with (mismatch, with the evidence), "
                   "or it has no airborne sample."), ""]
        lines += [f"- {_cell(Path(log).name, 120)}: {_cell(reason, 400)}"
                  for log, _, reason in left_out]
        lines.append("")
    if result.notes:
        lines += ["## Notes", ""] + [f"- {n}" for n in result.notes] + [""]
    return "\n".join(lines) + "\n"


def _counts(result, table: pd.DataFrame, ok: pd.DataFrame) -> list[str]:
    """Title and the flights in the table, failed and not replayable."""
    bad = table[table["status"] == "failed"]
    others = [f"{n} {status}" for status in ("not replayable", "mismatch", "not airborne")
              if (n := int((table["status"] == status).sum()))]
    return ["# Fleet report", "",
            f"{len(ok)} flights in the table ({len(bad)} failed logs"
            + "".join(f", {o}" for o in others)
            + "); this run summarised "
            f"{result.processed} logs ({len(result.failed)} failed) and found "
            f"{result.skipped} already in the table.", ""]


def _accuracy(ok: pd.DataFrame, with_figures: bool) -> list[str]:
    """Bias, P95 of the absolute error and drift of the charge and energy errors. [%]"""
    ch = error_summary(ok["charge_error_pct"])
    en = error_summary(ok["energy_error_pct"])
    order = cycle_order(ok) if len(ok) else np.array([])
    d_ch, d_ch_se = drift(order, ok["charge_error_pct"])
    d_en, d_en_se = drift(order, ok["energy_error_pct"])
    lines = ["## Predicted vs measured", "",
             "| level | flights | bias | P95 of the absolute error | drift per flight |",
             "|---|---:|---:|---:|---:|",
             _row("charge (battery model on measured power; measured − predicted)", ch["n"],
                  _fmt(ch["bias_pct"], 2, " %"), _fmt(ch["p95_abs_pct"], 2, " %"),
                  _pm(d_ch, d_ch_se, 3, " %", why="too few flights")),
             _row("airborne energy (power model on measured flight state; predicted − "
                  "measured)", en["n"], _fmt(en["bias_pct"], 2, " %"),
                  _fmt(en["p95_abs_pct"], 2, " %"),
                  _pm(d_en, d_en_se, 3, " %", why="too few flights")), "",
             "Errors are in per cent of the measured value. Drift is the least-squares slope "
             "of the error against the flight's order, with its standard error.", ""]
    if with_figures:
        lines += ["![predicted vs measured](accuracy.png)", "", "![drift](drift.png)", ""]
    return lines


def _worst_flights(ok: pd.DataFrame, diag: dict[str, str]) -> list[str]:
    """The :data:`WORST` flights by absolute charge error, and ``diagnose`` on them."""
    worst = ok.assign(_abs=ok["charge_error_pct"].abs()).sort_values(
        "_abs", ascending=False, na_position="last").head(WORST)
    lines = ["## Worst flights (charge error)", "",
             "| log | pack | duration s | charge mAh | predicted mAh | error % | energy "
             "error % | warnings |", "|---|---|---:|---:|---:|---:|---:|---|"]
    for _, r in worst.iterrows():
        lines.append(_row(Path(str(r["log"])).name, r["pack_id"], _fmt(r["duration_s"], 0),
                          _fmt(r["charge_mah"], 0), _fmt(r["predicted_charge_mah"], 0),
                          _fmt(r["charge_error_pct"], 2), _fmt(r["energy_error_pct"], 1),
                          _cell(r["warnings"])))
    lines.append("")
    if diag:
        lines += ["`diagnose` (docs/commands.md) on each of the worst flights alone:", ""]
        lines += [f"- {Path(log).name}: {_cell(text, 600)}" for log, text in diag.items()]
        lines.append("")
    return lines


def _pack_health(result, retire: float, within: float, with_figures: bool) -> list[str]:
    """Each pack's flights, state of health [%], fade per cycle [‰], flights to
    retirement and resistance [mΩ], with its pack file and the retirement flag."""
    lines = ["## Pack health", "",
             f"State of health: the share of the new pack's energy its charge still "
             f"delivers, 1/(1 + fade × cycle). Retirement at {100 * retire:.0f} %; "
             f"flagged: within the next {within:g} flights.", "",
             "| pack | flights | last cycle | SoH % | fade per cycle | flights to "
             "retirement | resistance mΩ | pack file | flag |",
             "|---|---:|---:|---:|---:|---:|---:|---|---|"]
    for h in result.health:
        f = result.pack_files.get(h.pack_id)
        lines.append(_row(
            h.pack_id, h.flights, _fmt(h.last_cycle, 0),
            _pm(100 * h.soh, 100 * h.soh_se, 1),
            _pm(h.fade_per_cycle * 1e3, h.fade_per_cycle_se * 1e3, 3, " ‰"),
            _to_retire(h),
            _pm(h.resistance_ohm * 1e3, h.resistance_se_ohm * 1e3, 1,
                why="too few flights with current steps"),
            "packs/" + f.name if f else "–", "RETIRE" if h.retires_within(within) else ""))
    lines.append("")
    if with_figures:
        lines += ["![pack health](packs.png)", ""]
    return lines


def _calibrations(cals) -> list[str]:
    """Each aircraft calibrated on the fleet: its parameters, file → calibrated ± SE,
    and its held-out error before and after."""
    lines = ["## Aircraft calibrated on the fleet", "",
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
        lines.append(_row(
            c.key, f"{c.train_flights} / {c.validation_flights}", params,
            f"{_fmt(b.get('rmse_w'), 1, ' W')} → {_fmt(a.get('rmse_w'), 1, ' W')}",
            f"{_fmt(b.get('energy_error_pct'), 2, ' %')} → "
            f"{_fmt(a.get('energy_error_pct'), 2, ' %')}",
            f"{_fmt(fb, 2, ' %')} → {_fmt(fa, 2, ' %')}",
            "aircraft/" + c.file.name if c.file else "–"))
    lines.append("")
    return lines


def write_report(result, out: Path, *, retire: float, within: float, figures=None,
                 option: str = "output folder") -> list[Path]:
    """Write ``report.md`` into ``out`` and, with ``figures`` (a callable
    ``figures(result, out, retire=…)`` that draws and returns the PNG files), its figures;
    return the paths written. ``option`` names the output in messages."""
    written = list(figures(result, out, retire=retire)) if figures is not None else []
    text = render(result, retire=retire, within=within, with_figures=bool(written))
    files.write_text(out / "report.md", text, option)
    written.append(out / "report.md")
    return written
