"""Diagnose: show what the simulation gets wrong, name the cause, extend the model,
measure the gain (``endurance diagnose``, docs/commands.md).

>>> result = diagnose(record, pack, aircraft)          # doctest: +SKIP
>>> print(result.summary())                            # doctest: +SKIP
>>> result.to_dict()["findings"]                       # doctest: +SKIP

Three levels are examined, each where the data allows:

* **cut-off** (``cutoff``) — the energy each discharge delivered to its cut-off
  voltage, where six or more run from a full pack to one cut-off: the direct evidence
  of a capacity, where ``capacity_fade`` and ``temperature`` are tested
  (:mod:`planner.identify.diagnose.cutoff`); elsewhere the output says a capacity loss cannot
  be seen;
* **capacity** — the measured charge drawn against the integral model driven by
  the measured power (needs power and current or consumed charge);
* **power** — the measured electric power against the aircraft's physics model
  driven by the measured flight state (needs ``aircraft`` and a flight state:
  climb rate, ground speed or airspeed; a multirotor flies its rotor disks' axial
  speed where the record has ``axial_speed_ms``).

On each level the baseline's own parameters are calibrated first (δ, ε, β;
η and drag), every effect of :mod:`planner.identify.diagnose.effects` is fitted on
training splits and scored on held-out splits, and only effects whose held-out
gain is statistically and practically significant are reported, ranked by that
gain. The splits and statistics are documented in :mod:`planner.identify.diagnose.search`.

Direct evidence comes first wherever the record has it
(:mod:`planner.identify.diagnose.evidence`): a power channel logged independently of the
current measures a current sensor's offset sample by sample (level ``sensors``), and the
pack temperature against the voltage's sag measures a cold pack's resistance (level
``resistance``). Every effect asked for then gets a detection limit
(:mod:`planner.identify.diagnose.limits`): the smallest size these data could reveal, or
why it is not identifiable with them and what would make it so.
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from planner.io import record as rec
from planner.identify import stats
from planner.physics.battery import integral
from planner.identify.diagnose import cutoff as CO
from planner.identify.diagnose import evidence as EV
from planner.identify.diagnose import limits as LIM
from planner.identify.diagnose import search as S
from planner.identify.diagnose.effects import EFFECTS, make_effects
from planner.errors import FitError, InputError, ModelError
from planner.parameters import Aircraft, BatteryPack, IntegralModel
from planner.physics.units import AS_PER_MAH

__all__ = ["EFFECTS", "DiagnoseResult", "diagnose"]



@dataclass
class LevelReport:
    """One level's baseline, search result and final fits (for output and plots)."""

    name: str
    result: S.LevelResult
    base_values: dict[str, float]
    base_stderr: dict[str, float]
    final_values: dict[str, float]
    final_stderr: dict[str, float]
    rmse_as_given: float
    final_error_as_given: float
    findings: list[dict[str, Any]]


@dataclass
class DiagnoseResult:
    """What ``diagnose`` found.

    Attributes
    ----------
    levels : dict of str to LevelReport
        ``"capacity"`` and/or ``"power"``, the levels that ran.
    findings : list of dict
        The significant effects, ranked by held-out gain (fields: :meth:`DiagnoseResult.to_dict`).
    skipped : list of dict
        Effects not tested, with the reason (``effect``, ``level``, ``reason``).
    notes : list of str
        Levels not run, experiments not used, and why.
    pack, aircraft : BatteryPack, Aircraft or None
        The definitions given (start values).
    sources : list of str
        The data files, where known.
    withheld : list of dict
        Effects that passed the held-out tests but are not causes: physically impossible
        parameters (``kind`` ``implausible``), a form the data contradict
        (``contradicted``: a fade whose discharges' energies fall in two levels), a driver
        the data cannot tell from time, depth of discharge or another effect
        (``confounded``), or an impossible baseline (``baseline``); each with ``why`` and
        ``where`` the misfit shows.
    not_identifiable : list of dict
        Effects these data cannot tell apart whatever the fit says (``effects``, the
        candidates; ``level``; ``why``), e.g. a current-sensor offset and a constant load
        when the power is the logged voltage times the logged current.
    detection : list of dict
        Per effect asked for and level (or direct evidence) where it can be looked for:
        the smallest size these data could reveal, or why it is not identifiable with
        them and what would make it so (:func:`planner.identify.diagnose.limits.entry`).
    """

    levels: dict[str, LevelReport]
    findings: list[dict[str, Any]]
    skipped: list[dict[str, str]]
    notes: list[str]
    pack: BatteryPack | None
    aircraft: Aircraft | None
    sources: list[str] = field(default_factory=list)
    withheld: list[dict[str, Any]] = field(default_factory=list)
    not_identifiable: list[dict[str, Any]] = field(default_factory=list)
    detection: list[dict[str, Any]] = field(default_factory=list)

    # ------------------------------------------------------------------ JSON
    def baseline(self, name: str) -> dict[str, Any]:
        """The calibrated baseline of level ``name`` (``cutoff``, ``capacity`` or ``power``):
        its held-out error (``rmse`` in the level's unit, mAh, W or % of energy;
        ``final_error_pct`` [%]), the error of the definition file as given, its parameters
        with standard errors, the experiments and the split, and how the error is measured.
        """
        lv = self.levels[name]
        base = lv.result.baseline
        level = lv.result.level
        out = {"level": name, "rmse": base.rmse, "unit": level.unit,
               "final_error_pct": base.final_error_pct,
               "rmse_as_given": lv.rmse_as_given,
               "final_error_pct_as_given": lv.final_error_as_given,
               "parameters": _with_stderr(lv.base_values, lv.base_stderr),
               "experiments": level.n_experiments, "split": level.split.to_dict()}
        if name == "cutoff":
            out["rmse_note"] = ("held-out error of the energy delivered to the cut-off, "
                                "ln(E/Ê) × 100, one unit per held-out discharge; final error: "
                                "Σ|E − Ê| / Σ E")
        elif name == "capacity":
            out["window_s"] = level.window_s
            out["beta_fitted"] = bool(level.fit_beta)
            out["rmse_note"] = ("held-out cumulative C − Ĉ from the start of each held-out "
                                "segment; final error: Σ|r_final| / Σ C over those segments")
        else:
            out["bin_s"] = level.bin_s
            out["rmse_note"] = (f"held-out RMSE of {level.bin_s:.1f}-s means of the airborne "
                                "power; final error: Σ|energy error| / Σ energy over held-out "
                                "segments")
            alt = calibration_alternatives(lv, self.aircraft)
            if alt:
                out["alternatives"] = alt
        return out

    @property
    def primary_level(self) -> str | None:
        """The level whose baseline the JSON leads with: capacity, else power, else the
        cut-off; None when no level ran.
        """
        for name in ("capacity", "power", "cutoff"):
            if name in self.levels:
                return name
        return None

    def unexplained(self) -> str | None:
        """What the tested effects leave unexplained, in words: held-out residuals with slow
        structure (lag-1 autocorrelation above 0.5) and the effects withheld as misfits or
        confounded; None when nothing is left.
        """
        parts = []
        for name, lv in self.levels.items():
            final = lv.result.final
            level = lv.result.level
            if name == "cutoff":        # one row per discharge: no series to be slow in
                continue
            rows = final.heldout_rows
            resid = final.heldout_row_resid
            order = np.argsort(rows, kind="stable")
            rho = stats.lag1_autocorrelation(resid[order], level.row_group[rows[order]])
            if rho > 0.5:
                what = (f"{level.window_s:.0f}-s windows" if name == "capacity"
                        else f"{level.bin_s:.1f}-s bins")
                worst = _worst_experiment(level, rows, resid)
                parts.append(f"{_title(name)} level: held-out error {final.rmse:.3g} {level.unit} "
                             f"remains with slow structure (lag-1 autocorrelation {rho:.2f} "
                             f"between {what}), largest in experiment {worst}; none of the "
                             "tested effects explains it")
        for w in self.withheld:
            if w["kind"] == "confounded":
                seen = f"{w['evidence']}; " if w.get("evidence") else ""
                parts.append(f"{_title(w['level'])} level: {seen}a misfit that {w['effect']} "
                             f"would absorb, not named: {w['why']} (candidates: "
                             f"{', '.join(w['candidates'])})")
            else:
                parts.append(f"{_title(w['level'])} level: a misfit of the model's form "
                             f"against {w['where']}, not a cause: {w['effect']} would need "
                             f"parameters that are physically impossible ({w['why']})"
                             if w["kind"] == "implausible" else
                             f"{_title(w['level'])} level: {w['effect']} not named: {w['why']}")
        return "; ".join(parts) if parts else None

    def extended(self) -> dict[str, Any]:
        """Per level that ran: the effects added, the held-out error before and after (the
        level's unit) with the gain [%], the final error before and after [%] and the final
        parameters with standard errors.
        """
        out: dict[str, Any] = {}
        for name, lv in self.levels.items():
            r = lv.result
            b, f = r.baseline, r.final
            out[name] = {"effects": [e.name for e, _ in r.selected], "rmse_before": b.rmse,
                         "rmse_after": f.rmse,
                         "gain_pct": 100 * (1 - f.rmse / b.rmse) if b.rmse > 0 else 0.0,
                         "final_error_pct_before": b.final_error_pct,
                         "final_error_pct_after": f.final_error_pct,
                         "unit": r.level.unit,
                         "parameters": _with_stderr(lv.final_values, lv.final_stderr)}
        return out

    def to_dict(self) -> dict[str, Any]:
        """The JSON ``endurance diagnose`` writes: ``baseline``, ``findings``,
        ``unexplained``, ``withheld``, ``not_identifiable`` and ``detection_limits``, plus
        ``baselines``, ``extended``, ``candidates``, ``skipped``, ``selection``, ``notes``
        and ``data``."""
        primary = self.primary_level
        candidates = []
        for name, lv in self.levels.items():
            for key, cmp in lv.result.candidates.items():
                candidates.append({"effect": cmp.effect, "level": name,
                                   "against": ["baseline", *cmp.against],
                                   "significant": cmp.significant,
                                   "heldout": _heldout(cmp), "evidence": cmp.evidence(),
                                   "why_not": cmp.reasons})
            for key, why in lv.result.failed.items():
                candidates.append({"effect": key, "level": name, "significant": False,
                                   "error": why})
        return {
            "baseline": self.baseline(primary) if primary else None,
            "findings": self.findings,
            "unexplained": self.unexplained(),
            "withheld": [{k: v for k, v in w.items()} for w in self.withheld],
            "not_identifiable": [dict(x) for x in self.not_identifiable],
            "detection_limits": [dict(x) for x in self.detection],
            "baselines": [self.baseline(n) for n in self.levels],
            "extended": self.extended(),
            "candidates": candidates,
            "skipped": self.skipped,
            "selection": {
                "splits": {n: lv.result.level.split.rule for n, lv in self.levels.items()},
                "training_test": "likelihood ratio n_eff ln(RSS0/RSS1) ~ chi2(added "
                                 "parameters), n_eff = n(1-rho)/(1+rho); median p over folds",
                "alpha_train": S.ALPHA_TRAIN,
                "heldout_test": "one-sided Wilcoxon signed-rank on per-unit held-out squared "
                                "error, baseline minus extended",
                "alpha_heldout": S.ALPHA_HELDOUT,
                "min_gain_pct": S.MIN_GAIN_PCT,
                "combination": "greedy: best passing effect joins, the rest are scored again",
            },
            "notes": self.notes,
            "data": self.sources,
        }

    # ------------------------------------------------------------------ text
    def summary(self) -> str:
        """The result as text: each level's baseline, the findings ranked by held-out gain,
        the extended models, what was not tested or cannot be told apart, and the notes.
        """
        lines = []
        for name, lv in self.levels.items():
            b = lv.result.baseline
            unit = lv.result.level.unit
            if name == "cutoff":
                v = lv.base_values
                rate = (f", {v['energy_per_a_pct']:+.3g} %/A" if "energy_per_a_pct" in v
                        else "")
                what = (f"energy to the cut-off {v['energy_at_cutoff_wh']:.4g} W h at "
                        f"{v['reference_current_a']:.3g} A mean current{rate}, "
                        f"{lv.result.level.n_rows} discharges")
            elif name == "capacity":
                v = lv.base_values
                what = (f"integral model recalibrated (δ {v['delta']:.4g}, ε {v['epsilon']:.4g}, "
                        f"β {v['beta']:.4g}{'' if lv.result.level.fit_beta else ' held'})")
            else:
                v = lv.base_values
                shape = ", ".join(f"{k} {v[k]:.3g}" for k in lv.result.level.shape)
                what = f"power model recalibrated (η {v['efficiency']:.3g}, {shape})"
            lines.append(f"Baseline, {_title(name)} level: {what}: held-out error "
                         f"{_num(b.rmse)} {unit}, "
                         f"final error {_num(b.final_error_pct, 2)} % "
                         f"(as given: {_num(lv.rmse_as_given)} {unit})")
            alt = calibration_alternatives(lv, self.aircraft) if name == "power" else None
            if alt:
                lines.append(f"  {alt['text']}")
        if not self.levels:
            lines.append("No level could run: " + "; ".join(self.notes))
        if self.findings:
            lines.append("Findings (held-out; ranked by the gain in the error of the charge or "
                         "energy at the end of the held-out segments):")
            for i, f in enumerate(self.findings, 1):
                h = f["heldout"]
                if h is None:
                    how = "direct evidence"
                elif "rmse_before" not in h:
                    how = f"direct evidence, {h['gain_pct']:.0f} % better held out"
                else:
                    how = (f"held-out error {_num(h['rmse_before'])} → {_num(h['rmse_after'])} "
                           f"{f['unit']} ({h['gain_pct']:.0f} % better)")
                lines.append(f"  {i}. {f['headline']}; {how}")
                lines.append(f"     {f['cause']}")
                for alt in f.get("alternatives", ()):
                    lines.append(f"     or: {alt}")
                for h in f.get("evidence", {}).get("held_against", ()):
                    lines.append(f"     held against {h['rival']}: {h['text']}")
        elif self.levels:
            lines.append("No significant effect: the calibrated model explains the data as well "
                         "as any tested extension.")
        for name, ext in self.extended().items():
            if ext["effects"]:
                title = _title(name)
                lines.append(f"Extended {title} model ({' + '.join(ext['effects'])}): held-out "
                             f"error {_num(ext['rmse_before'])} → {_num(ext['rmse_after'])} "
                             f"{ext['unit']}, final error {_num(ext['final_error_pct_before'], 2)}"
                             f" → {_num(ext['final_error_pct_after'], 2)} %")
        for s in self.skipped:
            lines.append(f"  not tested at the {_title(s['level'])} level: {s['effect']}: "
                         f"{s['reason']}")
        for x in self.not_identifiable:
            lines.append(f"Not identifiable on these data: {' or '.join(x['effects'])}: "
                         f"{x['why']}")
        if self.detection:
            lines.append("Detection limits (the smallest effect these data could reveal):")
            for d in self.detection:
                lines.append(f"  {d['effect']} ({d['level']}): {d['text']}")
        un = self.unexplained()
        if un:
            lines.append(f"Unexplained: {un}")
        for note in self.notes:
            lines.append(f"note: {note}")
        return "\n".join(lines)

    # ------------------------------------------------------------------ extended definitions
    def extended_pack(self) -> BatteryPack | None:
        """The pack with the calibrated and extended integral model (None without the level)."""
        lv = self.levels.get("capacity")
        if lv is None or self.pack is None:
            return None
        v = dict(lv.final_values)
        effects = {e.name: e for e, _ in lv.result.selected}
        cut = self.levels.get("cutoff")
        if cut is not None:      # the capacity effects found on the energy to the cut-off
            effects |= {e.name: e for e, _ in cut.result.selected}
            v |= {k: x for k, x in cut.final_values.items()
                  if k in ("temperature_coefficient_per_c", "fade_per_cycle")}
        kw = {}
        if "temperature" in effects:
            kw["temperature_coefficient_per_c"] = float(np.clip(
                v["temperature_coefficient_per_c"], -0.2, 0.2))
            kw["reference_temperature_c"] = float(effects["temperature"].reference_c)
        if "capacity_fade" in effects:
            kw["fade_per_cycle"] = float(np.clip(v["fade_per_cycle"], -0.01, 0.05))
            kw["cycle"] = float(np.max(effects["capacity_fade"].cycles))
        names = ", ".join(effects) or "no effect found"
        model = IntegralModel(v["delta"], v["epsilon"], v["beta"], literature=False,
                              source=f"endurance diagnose ({names}) on "
                                     f"{', '.join(self.sources) or 'the given data'}", **kw)
        return replace(self.pack, model=model)

    def extended_aircraft(self) -> Aircraft | None:
        """The aircraft with the calibrated and extended power parameters."""
        from planner.identify.aircraft_fit import with_params

        lv = self.levels.get("power")
        if lv is None or self.aircraft is None:
            return None
        v = lv.final_values
        values = {k: float(v[k]) for k in lv.result.level.shape}
        values[self.aircraft.efficiency_key] = float(np.clip(v["efficiency"], 1e-3, 1.0))
        if "system_power_w" in v:
            values["system_power_w"] = float(max(v["system_power_w"], 0.0))
        ac = with_params(self.aircraft, values)
        for f in self.findings:
            if f.get("effect") == "efficiency_curve":
                p = f["parameters"]
                ac = replace(ac, efficiency=float(p["efficiency_at_reference"]),
                             efficiency_slope=float(p["efficiency_slope"]),
                             efficiency_reference_power_w=float(
                                 p["reference_mechanical_power_w"]))
        names = ", ".join(e.name for e, _ in lv.result.selected) or "no effect found"
        return replace(ac, source=f"endurance diagnose ({names}) on "
                                  f"{', '.join(self.sources) or 'the given data'}; start values "
                                  f"from {self.aircraft.path or self.aircraft.name}")


def _title(level: str) -> str:
    """A level's name in text (the JSON keeps the key: ``cutoff``)."""
    return "cut-off" if level == "cutoff" else level


def _num(x, digits=None) -> str:
    if x is None or not math.isfinite(x):
        return "-"
    if digits is None:
        digits = 1 if abs(x) >= 10 else (2 if abs(x) >= 1 else 3)
    return f"{x:.{digits}f}"


def _with_stderr(values: dict[str, float], stderr: dict[str, float]) -> dict[str, float]:
    out = {}
    for k, v in values.items():
        out[k] = v
        if k in stderr:
            out[f"{k}_stderr"] = stderr[k]
    return out


def _heldout(cmp: S.Comparison) -> dict[str, float]:
    return {"rmse_before": cmp.rmse_before, "rmse_after": cmp.rmse_after,
            "gain_pct": cmp.gain_pct, "final_error_pct_before": cmp.final_error_pct_before,
            "final_error_pct_after": cmp.final_error_pct_after,
            "final_gain_pp": cmp.final_error_pct_before - cmp.final_error_pct_after}


def _worst_experiment(level, rows, resid) -> str:
    e = level.row_group[rows]
    ss = np.bincount(e, weights=resid**2, minlength=level.n_experiments)
    nn = np.bincount(e, minlength=level.n_experiments)
    with np.errstate(invalid="ignore", divide="ignore"):
        ms = ss / nn
    return str(level.names[int(np.nanargmax(ms))])


# ============================================================================ data

def _load(data, column_map, battery_instance=None) -> tuple[pd.DataFrame, list[dict], list[str]]:
    from planner.io.flightdata import load_flight_data

    if isinstance(data, pd.DataFrame):
        df = rec.complete_record(rec.validate_record(data))
        if "experiment" not in df.columns:
            df = df.assign(experiment="1")
        return df, [{}], []
    if isinstance(data, (str, os.PathLike)):
        data = [data]
    paths = list(data)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        df, metas = load_flight_data(paths, column_map=column_map,
                                     battery_instance=battery_instance)
    for w in caught:  # what the readers skipped or read as missing; not library noise
        if w.category is UserWarning:
            warnings.warn(str(w.message), stacklevel=2)
    return df, metas, [str(p) for p in paths]


def _capacity_experiments(df: pd.DataFrame, notes: list[str]) -> list[dict]:
    out = []
    for key, sub in rec.experiments(df):
        name = str(key)
        t = sub["time_s"].to_numpy(float)
        if len(t) < 10 or t[-1] - t[0] < S.MIN_EXPERIMENT_S:
            notes.append(f"experiment {name}: too short for the capacity level ({len(t)} "
                         f"samples, {t[-1] - t[0] if len(t) else 0:.0f} s; needs 10 samples and "
                         f"{S.MIN_EXPERIMENT_S:g} s)")
            continue
        t = t - t[0]
        p = S.interp_nan(t, sub["power_w"].to_numpy(float)) if "power_w" in sub else None
        if p is None or not np.isfinite(p).all():
            notes.append(f"experiment {name}: no power, not used at the capacity level")
            continue
        if "consumed_mah" in sub and np.isfinite(sub["consumed_mah"].to_numpy(float)).any():
            c = S.interp_nan(t, sub["consumed_mah"].to_numpy(float))
            c = (c - c[0]) * AS_PER_MAH
        elif "current_a" in sub and np.isfinite(sub["current_a"].to_numpy(float)).any():
            c = rec.cumulative_trapezoid(sub["current_a"].to_numpy(float), t)
        else:
            notes.append(f"experiment {name}: no current or consumed charge, not used at the "
                         "capacity level")
            continue
        p = np.clip(p, 0.0, None)
        if not np.any(p > 0) or not c[-1] > 0:
            notes.append(f"experiment {name}: no discharge (power or charge drawn is zero), "
                         "not used at the capacity level")
            continue
        temp = None
        if "temperature_c" in sub:
            tc = sub["temperature_c"].to_numpy(float)
            if np.isfinite(tc).mean() > 0.5:
                temp = S.interp_nan(t, tc)
        cycle = None
        if "cycle" in sub:
            cy = sub["cycle"].to_numpy(float)
            if np.isfinite(cy).any():
                cycle = float(cy[np.isfinite(cy)][0])
        current = None
        if "current_a" in sub and np.isfinite(sub["current_a"].to_numpy(float)).mean() > 0.5:
            current = S.interp_nan(t, sub["current_a"].to_numpy(float))
        voltage = None
        if "voltage_v" in sub and np.isfinite(sub["voltage_v"].to_numpy(float)).mean() > 0.5:
            voltage = S.interp_nan(t, sub["voltage_v"].to_numpy(float))
        out.append({"name": name, "t": t, "p": p, "c": c, "temperature": temp, "cycle": cycle,
                    "current": current, "voltage": voltage})
    return out


def _literature_pack(df: pd.DataFrame, metas: list[dict], notes: list[str]) -> BatteryPack:
    """The pack flown without a pack file: :func:`planner.identify.replay.literature_pack`
    of the logs' cell count and capacity (the first log that gives each), noted."""
    from planner.identify.replay import literature_pack

    cells = next((m.get("battery_cells") for m in metas if m.get("battery_cells")), None)
    cap = next((m.get("battery_capacity_mah") for m in metas if m.get("battery_capacity_mah")),
               None)
    pack, _ = literature_pack(cells, cap, df["voltage_v"] if "voltage_v" in df else None)
    if pack is None:
        where = ", ".join(dict.fromkeys(str(m["source"]) for m in metas if m.get("source")))
        raise InputError(f"{where + ': ' if where else ''}no battery given and no pack "
                         "voltage (voltage_v) to find the cell count from: give the "
                         "battery-pack file flown")
    n = pack.cells_series
    if cap:
        notes.append(f"no battery file: literature start values δ₀({n}), ε₀({n}) and "
                     f"the log's {cap:.0f} mAh")
    else:
        # capacity unknown: a nominal charge far above what was drawn keeps β held
        notes.append(f"no battery file and no capacity in the log: literature start values "
                     f"δ₀({n}), ε₀({n}), β held")
    return pack


#: A selected effect whose key parameter lies closer than this many standard errors to
#: "no effect" in the all-data fit is dropped (its held-out gain came from elsewhere).
MIN_Z = 2.0
#: Multiple correlation of an effect's driver with time and depth of discharge (or with
#: another effect's driver) at or above which the data cannot tell them apart: the driver
#: then has less than 1 − 0.9² = 19 % of its variation of its own. [unitless]
CONFOUND_R = 0.9
#: Range of a calibrated propulsion efficiency (battery to useful power). [unitless]
EFFICIENCY_RANGE = (0.05, 1.0)


def _explained(x: np.ndarray, columns: list[np.ndarray]) -> float:
    """Share of the variance of ``x`` that a linear fit on ``columns`` explains (R²)."""
    x = np.asarray(x, float)
    ok = np.isfinite(x)
    for c in columns:
        ok &= np.isfinite(c)
    if ok.sum() < len(columns) + 3:
        return 0.0
    X = np.column_stack([np.ones(ok.sum())] + [np.asarray(c, float)[ok] for c in columns])
    xo = x[ok]
    var = float(np.var(xo))
    if var <= 0:
        return 1.0
    coef, *_ = np.linalg.lstsq(X, xo, rcond=None)
    return float(1.0 - np.var(xo - X @ coef) / var)


def _driver(level, effect, state) -> np.ndarray | None:
    if effect.driver_is_time:
        return None
    if level.name == "cutoff":
        return np.asarray(effect.cutoff_column(level), float)
    if level.name == "capacity":
        return np.asarray(effect.window_driver(level), float)
    return np.asarray(effect.bin_driver(level, state), float)


def _confound(level, effect, state, others) -> tuple[str, list[str]] | None:
    """Why ``effect`` cannot be told apart from time, depth of discharge or another
    selected effect in these data (module notes), and the candidates; None if it can."""
    regime = getattr(effect, "regime_confound", None)
    if regime is not None:
        found = regime(level, state)
        if found:
            return found
    x = _driver(level, effect, state)
    if x is None:
        return None
    confounders = level.confounders()
    r2 = _explained(x, [y for _, y in confounders])
    if r2 >= CONFOUND_R**2:
        labels = " and ".join(label for label, _ in confounders)
        return (f"{100 * r2:.0f} % of the variation of its driver ({effect.driver_label}) "
                f"follows {labels}: the data cannot tell {effect.name} from a misfit that "
                f"grows with them", [effect.name] + [label for label, _ in confounders])
    for other in others:
        y = _driver(level, other, state)
        if y is None or other.name == effect.name:
            continue
        r2 = _explained(x, [y])
        if r2 >= CONFOUND_R**2:
            return (f"{100 * r2:.0f} % of the variation of its driver follows the driver of "
                    f"{other.name}: the data cannot tell the two apart",
                    [effect.name, other.name])
    return None


def _run_level(level, effects, notes) -> S.LevelResult | None:
    """Search, then hold the selected effects to the honesty rules on all the data.

    After the search, the selected model is fitted on all the data and an effect is
    withheld (never named as a cause) when its key parameter is within :data:`MIN_Z`
    standard errors of no effect, when its parameters are physically impossible
    (:meth:`planner.diagnose.effects.Effect.implausible`), when the data contradict its
    form (:meth:`~planner.identify.diagnose.effects.Effect.contradicted`), or when its
    driver cannot be
    told apart from time, depth of discharge or another selected effect's driver
    (:data:`CONFOUND_R`); the model is refitted without it until what remains holds.
    Rival effects the search could not tell apart (``LevelResult.confused``) are withheld
    as confounded from the start.
    """
    try:
        res = S.search(level, effects)
        by_name = {e.name: e for e in effects}
        res.withheld = [{"effect": name, "level": level.name, "kind": "confounded",
                         "why": tie["why"], "candidates": list(tie["candidates"]),
                         "where": by_name[name].driver_label}
                        for tie in res.confused for name in tie["candidates"]]
        all_rows = np.ones(level.n_rows, bool)
        res.base_fit = level.fit([], all_rows)
        while True:
            chosen = [e for e, _ in res.selected]
            res.final_fit = level.fit(chosen, all_rows, start=res.base_fit) if chosen else \
                res.base_fit
            if not chosen:
                break
            values, stderr = level.physical(res.final_fit, chosen)
            drop = {}
            for e in chosen:
                params = e.parameters(values, stderr, level, res.final_fit.state)
                z = e.z_score(params)
                few = _few_flights(values, e.name)
                crit = max(MIN_Z, few[1]) if few else MIN_Z
                if math.isfinite(z) and z < crit:
                    # withheld, so that its detection entry says why it is not named
                    # rather than that none was found
                    drop[e.name] = {"effect": e.name, "level": level.name, "kind": "weak",
                                    "why": _weak_why(e, params, z, level.name, few),
                                    "where": e.driver_label, "parameters": params,
                                    "help": _regime_help(e, params)}
                    continue
                for kind, check in (("implausible", e.implausible),
                                    ("contradicted", e.contradicted)):
                    why = check(params, level)
                    if why:
                        drop[e.name] = {"effect": e.name, "level": level.name,
                                        "kind": kind, "why": why, "where": e.driver_label,
                                        "parameters": params}
                        break
                if e.name in drop:
                    continue
                state = res.final_fit.state | {"values": res.final_fit.values()}
                conf = _confound(level, e, state,
                                 [o for o in chosen if o.name != e.name])
                if conf:
                    drop[e.name] = {"effect": e.name, "level": level.name,
                                    "kind": "confounded", "why": conf[0],
                                    "candidates": conf[1], "where": e.driver_label,
                                    "parameters": params, "evidence": e.cause(params, level)}
            if not drop:
                res.final_physical = (res.final_fit, values, stderr)
                break
            res.withheld += list(drop.values())
            res.selected = [(e, c) for e, c in res.selected if e.name not in drop]
        return res
    except (FitError, ModelError, np.linalg.LinAlgError) as exc:
        notes.append(f"{_title(level.name)} level: could not be calibrated ({exc})")
        return None


def _few_flights(values: dict, name: str) -> tuple[float, float] | None:
    """``(G*, critical value)`` where the estimate of effect ``name`` among a level's
    ``values`` (:meth:`planner.identify.diagnose.search.PowerLevel.physical`) has the
    flight-clustered error (so the level has
    :data:`planner.identify.stats.MIN_CLUSTERS` flights or more) and rests on fewer
    flights in effect than that (G*, :func:`planner.identify.stats.effective_clusters`):
    its z is then judged against Student's t with G* − 1 degrees of freedom
    (:func:`planner.identify.stats.few_clusters_critical`); else None."""
    g_star = values.get(f"effective_flights[{name}]")
    if g_star is None or not values.get(f"clustered_error[{name}]"):
        return None
    crit = stats.few_clusters_critical(g_star)
    return None if crit is None else (float(g_star), crit)


def _weak_why(effect, params: dict, z: float, level_name: str,
              few: tuple[float, float] | None = None) -> str:
    """Why an effect that passed the held-out tests is withheld: its key parameter is
    within :data:`MIN_Z` standard errors of no effect (with what makes most of the error,
    where the vertical descents or the hovers do: :data:`_REGIME_BIAS`), or, where it
    rests on few flights in effect (``few``: :func:`_few_flights`), within the t
    distribution's critical value; in the unit its detection limit is given in."""
    from planner.identify.diagnose.limits import PARAMETER, in_unit

    if PARAMETER.get((level_name, effect.name), ("",))[0] == effect.key:
        def show(x):
            return in_unit(level_name, effect.name, x)
    else:
        def show(x):
            return f"{x:.3g}"
    se = params.get(effect.key + "_stderr", math.nan)
    why = (f"it passed the held-out tests, but its {effect.key} ({show(params[effect.key])} ± "
           f"{show(se)}) is only {z:.1f} standard errors from no effect in the fit on all the "
           "data")
    if few is not None and z >= MIN_Z:
        why += (f", and its evidence comes from {few[0]:.1f} flights in effect: too few to "
                "tell one shared effect from each flight's own, it needs "
                f"{few[1]:.1f} (Student's t with {max(few[0] - 1, 1):.1f} degrees of freedom)")
    for regime, whose, moves, reason, _ in _REGIME_BIAS:
        bias = params.get(f"{effect.key}_{regime}_bias")
        if bias is not None and bias > 0.5 * se:
            why += (f"; most of that error is {whose}: {moves} by "
                    f"{show(abs(params[f'{effect.key}_{regime}_shift']))} when they get a "
                    f"power level of their own ({reason})")
    return why


#: The regimes whose own power level shows a bias in a parameter (``<key>_<regime>_shift``
#: and ``_bias``: PowerLevel.descent_shift, PowerLevel.hover_shift), in the words of
#: :func:`_weak_why`: the regime, whose error, what moves, why the model is unsure there,
#: and what would make the effect identifiable where that bias is most of its error
#: (:func:`_regime_help`; None: the effect's usual help).
_REGIME_BIAS = (
    ("descent", "the vertical descents'", "the step moves",
     "the rotor model's power in slow descent is an empirical curve",
     "the slow vertical descents modelled on flights like these (fit-aircraft frees the "
     "aircraft's descent_inflow_weight where flights descend vertically), or a change away "
     "from the final descents; more flights do not shrink the part of its error that the "
     "descents' misfit makes"),
    ("hover", "the hovers'", "the wind's speed moves",
     "there the wind is the whole airspeed, and its effect the rotor model's fall of power "
     "from the hover", None),
)


def _regime_help(effect, params: dict) -> str | None:
    """What would make a withheld effect identifiable where the bias a regime puts into
    its key parameter is more than half of its error variance (:data:`_REGIME_BIAS`): then
    more flights, which shrink only the rest, are not the remedy; else None."""
    se = params.get(effect.key + "_stderr", math.nan)
    for regime, _, _, _, remedy in _REGIME_BIAS:
        bias = params.get(f"{effect.key}_{regime}_bias")
        if remedy and bias is not None and math.isfinite(se) and bias**2 > 0.5 * se**2:
            return remedy
    return None


def _as_given_capacity(level, pack) -> tuple[float, float]:
    m = pack.model
    r = np.empty_like(level.t)          # the file's model, restarted at each experiment
    for a, b in zip(level.exp_start, level.exp_end):
        r[a:b + 1] = level.c[a:b + 1] - integral.charge(level.t[a:b + 1], level.p[a:b + 1],
                                                        m.delta, m.epsilon, m.beta)
    samples = np.arange(len(level.t))
    seg = np.empty_like(samples)
    for k in range(level.split.n_folds):
        idx = np.flatnonzero(level.sample_fold == k)
        seg[idx] = level._segment_start(idx)
    rs = r - r[seg]
    finals = []
    for s in np.unique(seg):
        idx = samples[seg == s]
        dc = level.c[idx[-1]] - level.c[s]
        if dc > 0:
            finals.append((abs(rs[idx[-1]]), dc))
    return float(np.sqrt(np.mean(rs**2))) / AS_PER_MAH, S.weighted_final(finals)


def _as_given_power(level, aircraft) -> tuple[float, float]:
    rows = np.arange(level.n_rows)
    pred = np.asarray(aircraft.battery_power(
        np.maximum(level.base_inputs["airspeed"], getattr(level, "v_min", 0.0)),
        level.base_inputs["climb"], level.rho_std, level.mass,
        disk_frame=getattr(level, "rotor_axial", False)), float)
    r = level.measured - pred
    finals = []
    for e in range(level.n_experiments):
        m = level.exp[rows] == e
        em = float(np.sum(level.measured[m] * level.dt_bin[m]))
        if em > 0:
            finals.append((abs(em - float(np.sum(pred[m] * level.dt_bin[m]))), em))
    return float(np.sqrt(np.mean(r**2))), S.weighted_final(finals)


def _findings(name: str, lv_result: S.LevelResult, level, values, stderr) -> list[dict]:
    out = []
    state = lv_result.final_fit.state if lv_result.final_fit else {}
    for e, step in lv_result.selected:
        params = e.parameters(values, stderr, level, state)
        alone = lv_result.candidates.get(e.name, step)
        # the rivals fitted in its place and the tests they lost: evidence of the finding
        held = lv_result.held_against.get(e.name, [])
        out.append({
            "effect": e.name,
            "level": name,
            "cause": e.cause(params, level),
            "parameters": params,
            "evidence": step.evidence() | {"gain_alone_pct": alone.gain_pct}
            | ({"held_against": [dict(h) for h in held]} if held else {}),
            "added_after": list(step.against),
            "heldout": _heldout(step),
            "unit": level.unit,
            "headline": e.headline(params, level),
            "driver": e.driver_label,
            "alternatives": (e.alternatives(params, level)
                             if hasattr(e, "alternatives") else []),
        })
    return out


def diagnose(data, pack: BatteryPack | None = None, aircraft: Aircraft | None = None,
             **opts) -> DiagnoseResult:
    """Find what the models get wrong on measured data, name the cause, measure the gain.

    Parameters
    ----------
    data : DataFrame, path or list of paths
        Flight record(s) (docs/record.md) or logs any reader takes.
    pack : BatteryPack, optional
        The pack flown: start values of the integral model. Default: the
        literature model for the cell count of the log (as ``replay``).
    aircraft : Aircraft, optional
        Enables the power level (with a flight state in the data).
    **opts
        ``payload_kg`` [kg] (default: each flight's ``payload_kg`` in the record, else
        0), ``mass_kg`` (all-up mass; default aircraft + pack + payload) [kg], ``site_altitude_m`` (0, for the standard density) [m],
        ``effects`` (names to test; default all), ``column_map`` (for CSV data
        that is not a flight record), ``battery_instance`` (of PX4 topic exports).

    Returns
    -------
    DiagnoseResult
    """
    allowed = {"payload_kg", "mass_kg", "site_altitude_m", "effects", "column_map",
               "battery_instance"}
    unknown = set(opts) - allowed
    if unknown:
        raise TypeError(f"diagnose() got unexpected option(s) {sorted(unknown)}; expected "
                        f"{sorted(allowed)}")
    df, metas, sources = _load(data, opts.get("column_map"), opts.get("battery_instance"))
    run = _Run()
    if pack is None:
        pack = _literature_pack(df, metas, run.notes)
    wanted = make_effects(opts.get("effects"))
    names = {e.name for e in wanted}
    power_ev = EV.power_channel(df)
    run.power_from_current = not power_ev["independent"]
    if power_ev["independent"]:
        run.power_channel_offset = (power_ev["current_offset_a"],
                                    power_ev["current_offset_a_stderr"])
    exps = _capacity_experiments(df, run.notes)
    run.experiments = exps
    cap_effects = [e for e in wanted if e.level == "capacity"]
    cut = _cutoff_step(exps, pack, cap_effects, run)
    _capacity_step(df, exps, pack, [e for e in cap_effects if e.name not in cut.tested],
                   run)
    _power_step(df, pack, aircraft, opts, [e for e in wanted if e.level == "power"], run)
    resist_ev = EV.resistance_temperature(exps) if "temperature" in names else None
    direct = _direct_findings(power_ev if "current_offset" in names else None, resist_ev,
                              exps, run)
    found = direct + _ranked_findings(run.levels)
    findings = _merge_direct(direct, found[len(direct):])
    withheld = [w for lv in run.levels.values() for w in lv.result.withheld]
    blind = [_offset_or_load(df, run.levels, findings)]
    if cut.effects and "cutoff" not in run.levels and "capacity" in run.levels:
        blind.append({
            "effects": sorted(e.name for e in cut.effects), "level": "cutoff",
            "why": (f"a loss of usable capacity (an ageing or a cold pack) shows where a "
                    f"discharge reaches its cut-off voltage; here {cut.what}. The charge "
                    "drawn per unit of energy, which the capacity level tests instead, "
                    "barely changes when the capacity shrinks: no finding there measures a "
                    "capacity loss")})
    detection = _detection(run, wanted, power_ev if "current_offset" in names else None,
                           resist_ev, found)
    return DiagnoseResult(run.levels, findings, run.skipped, run.notes, pack, aircraft,
                          sources, withheld, [b for b in blind if b], detection)


#: Relative change of η by the calibration beyond which its alternatives are listed.
#: [unitless]
CALIBRATION_ALTERNATIVE_SHARE = 0.1


def calibration_alternatives(lv: LevelReport, aircraft: Aircraft | None) -> dict | None:
    r"""What else the power level's recalibration of η could stand for.

    The calibration scales the whole modelled power by the file's η
    (:attr:`~planner.parameters.Aircraft.power_efficiency`: the drive efficiency for
    ``rotor_losses``) over the fitted one;
    anything that raises (or lowers) the power nearly in proportion is absorbed there. Two
    alternatives are sized on the flights (mean over the airborne bins): an all-up mass
    heavier by :math:`\Delta m` at the file's η — :math:`\overline{M}\,(\eta_f/\hat\eta -
    1) = \Delta m\,\overline{\partial M/\partial m}`, the mechanical power's change per
    kg from the level's own model at the flown states (linearised: a first-order size) —
    and a constant load :math:`P_S' = P_S + \overline{M}\,(1/\hat\eta - 1/\eta_f)`.
    ``None`` when η moved by less than :data:`CALIBRATION_ALTERNATIVE_SHARE`.
    Returns ``efficiency_file``, ``efficiency_fitted``, ``mass_kg`` (Δm), ``load_w``
    (P_S'), ``load_file_w`` and ``text``.
    """
    if aircraft is None or lv.name != "power" or "efficiency" not in lv.base_values:
        return None
    eta_file, eta = float(aircraft.power_efficiency), float(lv.base_values["efficiency"])
    if not (eta > 0 and abs(eta / eta_file - 1.0) >= CALIBRATION_ALTERNATIVE_SHARE):
        return None
    level, base = lv.result.level, lv.result.base_fit
    ps = float(aircraft.system_power_w)
    mean_m = eta * (float(np.mean(level.measured)) - ps)      # mean mechanical power [W]
    try:
        per_kg = float(np.mean(level.signature(base, [], EFFECTS["payload_change"]())[:, 0]))             * eta
    except Exception:       # a level whose model cannot be linearised: no mass figure
        per_kg = math.nan
    dm = (eta_file / eta - 1.0) * mean_m / per_kg if per_kg > 0 else math.nan
    load = ps + mean_m * (1.0 / eta - 1.0 / eta_file)
    parts = []
    if math.isfinite(dm):
        parts.append(f"an all-up mass {abs(dm):.2f} kg {'heavier' if dm > 0 else 'lighter'} "
                     f"than the {level.mass0:.2f} kg given at the file's η "
                     f"({'a payload not given' if dm > 0 else 'less payload than given'})")
    if load >= 0:
        parts.append(f"a constant load of {load:.0f} W (file {ps:g} W) at the file's η")
    if not parts:
        return None
    text = (f"η recalibrated from the file's {eta_file:.3g} to {eta:.3g}: the flights' power "
            f"is {'higher' if eta < eta_file else 'lower'} than the file's model by "
            f"{100 * abs(eta_file / eta - 1):.0f} %: read as a "
            f"{'less' if eta < eta_file else 'more'} efficient drive, but equally "
            "consistent with " + " or with ".join(parts) + ", or a mix; the calibration "
            "cannot tell them apart (the payload flown, given, pins the mass)")
    return {"efficiency_file": eta_file, "efficiency_fitted": eta, "mass_kg": dm,
            "load_w": load, "load_file_w": ps, "text": text}


def _merge_direct(direct: list[dict], ranked: list[dict]) -> list[dict]:
    """One finding per cause: a direct finding whose effect a model level also names is
    carried by that level's finding (``direct_evidence``: the direct finding's level,
    cause, parameters and evidence; its cause appended), which keeps its rank and the
    held-out figures; the other direct findings lead."""
    out = [dict(f) for f in ranked]
    lead = []
    for d in direct:
        same = next((f for f in out if f["effect"] == d["effect"]), None)
        if same is None:
            lead.append(d)
            continue
        same["direct_evidence"] = {k: d[k] for k in ("level", "cause", "parameters",
                                                      "evidence", "headline")}
        same["cause"] = f"{same['cause']}. Direct evidence as well: {d['cause']}"
        same["alternatives"] = list(same.get("alternatives", [])) + [
            a for a in d.get("alternatives", []) if a not in same.get("alternatives", [])]
    return lead + out


def _direct_findings(power_ev: dict | None, resist_ev: dict | None, exps: list[dict],
                     run: "_Run") -> list[dict]:
    """The findings of the direct evidence (:mod:`planner.identify.diagnose.evidence`):
    a current sensor against an independent power channel, the pack's resistance against
    its temperature; noted where the evidence is there but implausible."""
    out = []
    if power_ev is not None and power_ev.get("significant"):
        out.append(EV.power_channel_finding(power_ev))
    if resist_ev is not None and resist_ev.get("testable"):
        if resist_ev["significant"]:
            out.append(EV.resistance_finding(resist_ev, exps))
        elif resist_ev["implausible"] and resist_ev["paired_p_value"] < S.ALPHA_HELDOUT:
            run.notes.append("resistance: the pack's resistance follows its temperature, but "
                             f"not as a cold pack: {resist_ev['implausible']}")
    return out


def _detection(run: "_Run", wanted, power_ev: dict | None, resist_ev: dict | None,
               findings: list[dict]) -> list[dict]:
    """The detection entries (:mod:`planner.identify.diagnose.limits`) of every effect
    asked for: per level that ran, per level that could not run (not identifiable, with
    why), and per direct evidence."""
    found = {(f["level"], f["effect"]) for f in findings}
    out, covered = [], set()
    for name, lv in run.levels.items():
        effects = run.level_effects.get(name, [])
        out += LIM.level_limits(lv, effects, {e for lvl, e in found if lvl == name})
        covered |= {(name, e.name) for e in effects}
    asked = {e.name for e in wanted}
    for s in run.skipped:
        key = (s["level"], s["effect"])
        if key in covered or s["effect"] not in asked or \
                s["reason"].startswith("tested at the cut-off level instead"):
            continue
        covered.add(key)
        out.append(LIM.not_identifiable(s["effect"], s["level"], s["reason"]))
    if power_ev is not None:
        top = EV.MAX_SENSOR_OFFSET_SHARE * power_ev.get("median_current_a", math.inf)
        if power_ev["independent"] and power_ev["limit_a"] > top:
            out.append(LIM.not_identifiable("current_offset", "sensors", LIM.beyond_physics(
                "current_offset", "sensors", power_ev["limit_a"], top)))
        elif power_ev["independent"]:
            out.append(LIM.entry("current_offset", "sensors",
                                 found=("sensors", "current_offset") in found,
                                 identifiable=True, limit=power_ev["limit_a"],
                                 n=len({e["name"] for e in run.experiments}) or 1,
                                 stderr=power_ev["current_offset_a_stderr"]))
        else:
            out.append(LIM.not_identifiable("current_offset", "sensors", power_ev["why"]))
    if resist_ev is not None:
        if resist_ev.get("testable"):
            # an implausible slope that is not significant is noise around none
            ok = (resist_ev["implausible"] is None or ("resistance", "temperature") in found
                  or resist_ev["z"] < EV.MIN_Z)
            why = "" if ok else resist_ev["implausible"]
            top = EV.ACTIVATION_RANGE_J_PER_MOL[1]
            if ok and resist_ev["limit_j_per_mol"] > top:
                ok, why = False, LIM.beyond_physics("temperature", "resistance",
                                                    resist_ev["limit_j_per_mol"], top)
            out.append(LIM.entry("temperature", "resistance",
                                 found=("resistance", "temperature") in found,
                                 identifiable=ok, limit=resist_ev["limit_j_per_mol"],
                                 n=len(resist_ev["experiments"]), why=why,
                                 stderr=resist_ev["activation_energy_j_per_mol_stderr"]))
        else:
            out.append(LIM.not_identifiable("temperature", "resistance", resist_ev["why"]))
    order = {e.name: i for i, e in enumerate(wanted)}
    return sorted(out, key=lambda d: order.get(d["effect"], 99))


@dataclass
class _Run:
    """What the levels of one :func:`diagnose` run add up: their reports, the effects
    not tested (``effect``, ``level``, ``reason``) and the notes."""

    levels: dict[str, LevelReport] = field(default_factory=dict)
    skipped: list[dict[str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: The effects asked for at each level that ran.
    level_effects: dict[str, list] = field(default_factory=dict)
    #: The capacity experiments (dicts of :func:`_capacity_experiments`).
    experiments: list[dict] = field(default_factory=list)
    #: The record's power is the logged voltage × the logged current.
    power_from_current: bool = True
    #: The current sensor's offset against an independently logged power, with its
    #: standard error (:func:`planner.identify.diagnose.evidence.power_channel`). [A]
    power_channel_offset: tuple[float, float] | None = None

    def skip(self, effects, level: str, reason: str) -> None:
        """Note ``effects`` (Effect objects or names) as not tested at ``level``."""
        self.skipped += [{"effect": getattr(e, "name", e), "level": level, "reason": reason}
                         for e in effects]

    def add(self, name: str, level, res: S.LevelResult, as_given, base=None,
            effects=()) -> None:
        """The report of a level that ran: baseline and final parameters, the file's
        error as given (``as_given()``, after them), the findings; the effects the
        search skipped. ``base``: the baseline parameters, where already computed;
        ``effects``: those asked for at this level."""
        self.level_effects[name] = list(effects)
        bv, bs = base if base is not None else level.physical(res.base_fit, [])
        done = res.final_physical
        if res.final_fit is res.base_fit:
            fv, fs = bv, bs
        elif done is not None and done[0] is res.final_fit:
            fv, fs = done[1], done[2]
        else:
            fv, fs = level.physical(res.final_fit, [e for e, _ in res.selected])
        rg, fg = as_given()
        rep = LevelReport(name, res, bv, bs, fv, fs, rg, fg, [])
        rep.findings = _findings(name, res, level, fv, fs)
        self.levels[name] = rep
        self.skipped += [{"effect": k, "level": name, "reason": v}
                         for k, v in res.skipped.items()]


@dataclass(frozen=True)
class _Cutoff:
    """The cut-off level's effects, those it tested and why it did not run (if so)."""

    effects: list
    tested: set
    what: str


def _cutoff_step(exps: list[dict], pack: BatteryPack, cap_effects, run: _Run) -> _Cutoff:
    """The cut-off level, where enough discharges run from a full pack to one cut-off
    (:mod:`planner.identify.diagnose.cutoff`): the capacity effects it tests are not
    tested again at the capacity level."""
    cut_effects = [e for e in make_effects([e.name for e in cap_effects])
                   if hasattr(e, "cutoff_column")]
    cut_names = {e.name for e in cut_effects}
    cut_exps, cut_what = CO.select(exps, pack) if exps else ([], "no experiment")
    if cut_effects and len(cut_exps) >= CO.MIN_CUTOFF_EXPERIMENTS:
        cut_level = CO.CutoffLevel(cut_exps, pack)
        run.notes.append(f"cut-off level: {cut_what}")
        res = _run_level(cut_level, cut_effects, run.notes)
        if res is not None:
            run.add("cutoff", cut_level, res, cut_level.as_given, effects=cut_effects)
            # direct evidence first: the capacity effects are tested on the energy to the
            # cut-off, not again on the charge per unit energy
            run.skip([e for e in cap_effects if e.name in cut_names], "capacity",
                     "tested at the cut-off level instead, on the energy each discharge "
                     "delivered to its cut-off (the direct evidence of the capacity)")
            return _Cutoff(cut_effects, cut_names, cut_what)
    elif cut_effects and exps:
        cut_what = (f"only {len(cut_exps)} experiment(s) run from a full pack to a common "
                    f"cut-off (needs {CO.MIN_CUTOFF_EXPERIMENTS})" if cut_exps else cut_what)
        run.skip(cut_effects, "cutoff", cut_what)
    return _Cutoff(cut_effects, set(), cut_what)


def _capacity_step(df: pd.DataFrame, exps: list[dict], pack: BatteryPack, effects,
                   run: _Run) -> None:
    """The capacity level: the measured charge against the integral model driven by the
    measured power (:class:`planner.identify.diagnose.search.CapacityLevel`)."""
    level = None
    if not exps:
        run.notes.append("capacity level not run: no experiment with power and charge drawn"
                         + (f" ({rec.NO_CURRENT}: battery voltage only)"
                            if rec.voltage_only(df) else ""))
    else:
        try:
            level = S.CapacityLevel(exps, pack)
            level.power_from_current = run.power_from_current
            level.power_channel_offset = run.power_channel_offset
        except (FitError, ModelError, ValueError) as exc:
            run.notes.append(f"capacity level not run: {exc}")
        if level is not None and level.n_rows < S.MIN_ROWS:
            run.notes.append(f"capacity level not run: only {level.n_rows} windows of "
                             f"{level.window_s:.0f} s (needs {S.MIN_ROWS})")
            level = None
    res = _run_level(level, effects, run.notes) if level is not None else None
    if res is not None:
        run.add("capacity", level, res, lambda: _as_given_capacity(level, pack),
                effects=effects)
    if level is None:
        run.skip(effects, "capacity", "capacity level not run")


def _power_step(df: pd.DataFrame, pack: BatteryPack, aircraft: Aircraft | None, opts: dict,
                effects, run: _Run) -> None:
    """The power level: the measured power against the aircraft's physics driven by the
    measured flight state (:class:`planner.identify.diagnose.search.PowerLevel`); no
    cause is named on a baseline whose efficiency is impossible."""
    level, why = _power_level(df, pack, aircraft, opts, effects, run.notes)
    if level is None:
        run.skip(effects, "power", why)
        return
    res = _run_level(level, effects, run.notes)
    if res is None:
        return
    base = level.physical(res.base_fit, [])
    _withhold_on_impossible_baseline(res, base[0], run.notes)
    _note_descent_misfit(level, res, run.notes)
    _note_speed_response(level, res, run.notes)
    run.add("power", level, res, lambda: _as_given_power(level, aircraft), base,
            effects=effects)


def _power_level(df, pack, aircraft, opts, effects, notes):
    """The power level of the data, or None and why it cannot run."""
    if aircraft is None:
        why = "no aircraft definition given: the power level cannot run"
        if effects:
            notes.append(why)
        return None, why
    if not {"climb_rate_ms", "groundspeed_ms", "airspeed_ms"} & set(df.columns) or \
            "power_w" not in df:
        why = "no flight state (climb rate, ground speed or airspeed) or power in the data"
        notes.append(f"power level not run: {why}")
        return None, why
    mass = opts.get("mass_kg")
    if mass is None:
        base = aircraft.empty_mass_kg + pack.total_mass_kg
        own = rec.experiment_payloads(df) if opts.get("payload_kg") is None else None
        if own is not None:        # each flight at its own payload (the record's payload_kg)
            mass = {k: base + (v if np.isfinite(v) else 0.0) for k, v in own.items()}
            notes.append("payload per flight from the data: "
                         + ", ".join(f"{v:g}" for v in sorted(set(own.values()))) + " kg")
        else:
            mass = base + float(opts.get("payload_kg") or 0.0)
    exps = [(str(k), sub) for k, sub in rec.experiments(df)]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            level = S.PowerLevel(exps, aircraft, mass if isinstance(mass, dict) else float(mass),
                                 float(opts.get("site_altitude_m", 0.0)))
        notes += level.notes
        if level.n_rows < S.MIN_ROWS:
            notes.append(f"power level not run: only {level.n_rows} airborne bins "
                         f"(needs {S.MIN_ROWS})")
            level = None
    except (FitError, ModelError) as exc:
        notes.append(f"power level not run: {exc}")
        level = None
    return level, "power level not run"


def _note_descent_misfit(level: S.PowerLevel, res: S.LevelResult, notes: list[str]) -> None:
    """A note where the final power model misses a multirotor's vertical descents by more
    than two standard errors and :data:`planner.identify.diagnose.search.DESCENT_MISFIT_SHARE`
    of their power (:meth:`planner.identify.diagnose.search.PowerLevel.descent_misfit`)."""
    d = level.descent_misfit(res.final_fit, [e for e, _ in res.selected])
    if d is None or not (abs(d["misfit_w"]) > 2.0 * d["stderr_w"] and
                         abs(d["misfit_w"]) > S.DESCENT_MISFIT_SHARE * d["power_w"]):
        return
    notes.append(
        f"power level: the vertical descents ({d['flights']} flights, {d['bins']} bins at "
        f"{d['rate_ms']:.1f} m/s) draw {abs(d['misfit_w']):.0f} ± {d['stderr_w']:.0f} W "
        f"({100 * abs(d['misfit_w']) / d['power_w']:.0f} %) "
        f"{'less' if d['misfit_w'] < 0 else 'more'} than the model, whose power in slow "
        "descent (the vortex-ring state, an empirical curve) is uncertain; an effect "
        "whose change falls where these descents begin would take part of this up")


def _note_speed_response(level: S.PowerLevel, res: S.LevelResult, notes: list[str]) -> None:
    """A note where the flights' power changes with airspeed otherwise than the calibrated
    model's (:func:`planner.identify.diagnose.limits.speed_response_of`,
    :func:`planner.identify.diagnose.effects.speed_scale`): a model-form misfit that the
    wind is read through and that a mission at other speeds is predicted with."""
    from planner.identify.diagnose.effects import speed_scale

    read = LIM.speed_response_of(level, res)
    if read is None or speed_scale(read[0], read[1]) == 1.0:
        return
    k, se, wind = read
    notes.append(
        f"power level: these flights' power changes with airspeed {k:.2f} ± {se:.2f} times as "
        "much as the calibrated model's (a free scale on the model's change of power with "
        f"airspeed{', fitted with a steady wind' if wind else ''}): a mission flown at speeds "
        "other than these flights' is predicted with that error"
        + (", and a wind is read through the flights' own change" if wind else ""))


def _withhold_on_impossible_baseline(res: S.LevelResult, base_values: dict,
                                     notes: list[str]) -> None:
    """A calibrated efficiency outside :data:`EFFICIENCY_RANGE` is a misfit of the power
    model's form: what the effects would absorb is withheld, not named as a cause."""
    eta = base_values.get("efficiency", float("nan"))
    if EFFICIENCY_RANGE[0] < eta <= EFFICIENCY_RANGE[1]:
        return
    res.withheld += [{"effect": e.name, "level": "power", "kind": "baseline",
                      "why": "the calibrated power model is physically impossible",
                      "where": e.driver_label, "parameters": {}}
                     for e, _ in res.selected]
    res.selected = []
    res.final_fit = res.base_fit
    notes.append(f"power level: the calibrated baseline needs an efficiency of "
                 f"{eta:.2f}, outside ({EFFICIENCY_RANGE[0]:g}, "
                 f"{EFFICIENCY_RANGE[1]:g}]: the power model's form does not fit "
                 "these flights; no cause is named at this level")


def _ranked_findings(levels: dict[str, LevelReport]) -> list[dict]:
    """The findings of every level in one currency: the held-out error of the charge
    (capacity) or energy (power) at the end of each held-out segment, in % of what was
    drawn. Within a level the order the greedy search added them is kept (each one's
    gain is over the model before it); the levels are merged by that common gain."""
    findings = sorted((f for lv in levels.values() for f in lv.findings),
                      key=lambda f: -f["heldout"]["final_gain_pp"])
    for lv in levels.values():
        order = [f["effect"] for f in lv.findings]
        pos = [i for i, f in enumerate(findings) if f["level"] == lv.name]
        for i, eff in zip(pos, order):
            findings[i] = next(f for f in lv.findings if f["effect"] == eff)
    return findings


#: Largest median relative difference between the logged power and voltage × current
#: for the power to count as computed from the logged current. [unitless]
POWER_FROM_CURRENT_TOL = 1e-3


def _offset_or_load(df: pd.DataFrame, levels: dict, findings: list[dict]) -> dict | None:
    """A current-sensor offset and a constant load, when the data cannot tell them apart.

    When the logged power is the logged voltage times the logged current (the readers
    and column maps compute it so where no power is logged), an offset b of the current
    sensor enters the charge drawn *and* the power: the integral model, driven by that
    power, predicts the extra charge b·t itself, so the capacity level cannot see it;
    the power level sees b·V, which — with V within some ±10 % over a flight — is a
    constant load. And the current at rest is the avionics' draw plus b. Unless a
    current offset was named (a charge counter that drifts apart from the current it
    counts, which the power does not carry), the output says so, naming both.
    """
    if any(f["effect"] == "current_offset" for f in findings):
        return None
    if not {"power_w", "voltage_v", "current_a"} <= set(df.columns):
        return None
    p = df["power_w"].to_numpy(float)
    vi = df["voltage_v"].to_numpy(float) * df["current_a"].to_numpy(float)
    ok = np.isfinite(p) & np.isfinite(vi) & (np.abs(vi) > 1.0)
    if ok.sum() < 10 or np.median(np.abs(p[ok] - vi[ok]) / np.abs(vi[ok])) > \
            POWER_FROM_CURRENT_TOL:
        return None
    effects = ["current_offset", "system_power"]
    tested = [name for name in ("capacity", "power") if name in levels]
    if not tested:
        return None
    why = ("the power is the logged voltage × the logged current, so an offset b of the "
           "current sensor is in the power too: the capacity level predicts the extra charge "
           "b·t from that power itself, and at the power level b·V is a constant load "
           "(the voltage varies little); the current at rest is the avionics' draw plus b. "
           "A constant load found (or missing) at the power level may be a current-sensor "
           "offset of load / voltage, and the other way round: calibrate the sensor's zero "
           "with the load off and the avionics unplugged to tell them apart")
    out = {"effects": effects, "level": " and ".join(tested), "why": why}
    cap = levels.get("capacity")
    rest = getattr(cap.result.level, "rest_current", None) if cap else None
    if rest is not None:
        out["rest_current_a"], out["rest_current_a_stderr"] = rest
    return out


def load_definitions(battery: str | Path | None, aircraft: str | Path | None):
    """Load the pack and aircraft files (the aircraft's default pack when no battery)."""
    from planner.parameters import default_battery_path, load_aircraft, load_battery

    ac = load_aircraft(aircraft) if aircraft else None
    if battery is None and ac is not None and ac.battery_path:
        battery = default_battery_path(ac)
    return (load_battery(battery) if battery else None), ac
