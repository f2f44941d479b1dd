"""Replay a real flight: drive the models with what was flown, compare with the battery.

Two levels, per experiment (flight or discharge):

* **battery** — the integral model driven by the *measured* power predicts the
  charge drawn; it is compared with the logger's own consumed-charge counter and
  with the trapezoid integral of the measured current (RMSE in mAh, final
  normalized error in %, [UAV23] eq. 29–30). Without a pack file the literature
  model δ₀(N), ε₀(N), β = 0.9648 is used for the cell count N from the log
  (``BATT_*``/``BAT1_N_CELLS``) or, failing that, N = ⌈V_max / 4.25 V⌉
  (:func:`planner.physics.battery.cells.series_cells`; :func:`literature_pack`). A
  pack that carries diagnose's extensions (``temperature_coefficient_per_c``,
  ``fade_per_cycle``) has them applied: each increment of charge is scaled by
  the logged pack temperature of that moment
  (:meth:`planner.parameters.IntegralModel.extend_charge`).
* **power** (with an aircraft) — the physics model driven by the measured
  airspeed (else ground speed corrected with the logged wind, else ground
  speed), climb rate, air density (measured pressure and temperature, else
  ISA) and mass predicts the electric power; compared with the measured power
  overall and per flight phase.

Flight phases are found from the data: *ground* where the power is below 30 %
of the flight's 90th-percentile power; among airborne samples *climb*
(vz > 0.5 m/s), *descent* (vz < −0.5 m/s), *cruise* (ground speed > 2 m/s) and
*hover* (the rest); *takeoff* is the first 10 s after the first airborne sample.

The pilot's view: at every sample, the time to reach the landing reserve at the
mean power of the last 60 s, from the integral model; and, checkable on any
log, the time at which the charge drawn would reach its final measured value,
predicted at 25 %, 50 % and 75 % of the flight, against the real end.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from planner.chain import flightstate
from planner.io import record
from planner.physics.battery import integral
from planner.physics.battery.cells import series_cells
from planner.chain.mission_chain import MissionChain
from planner.parameters import Aircraft, BatteryPack, IntegralModel
from planner.physics.units import AS_PER_MAH


@dataclass
class BatteryReplay:
    """Integral model against the measured charge of one experiment.

    Attributes
    ----------
    model : str
        Which parameters were used (``fitted``, ``literature 4S (from log)``, …).
    rmse_mah : float
        RMSE of predicted vs logged charge drawn. [mAh]
    final_error_pct : float
        (measured − predicted) / measured at the end, [UAV23] eq. 30. [%]
    rmse_vs_integrated_mah, final_error_vs_integrated_pct : float
        The same against the integral of the measured current. [mAh], [%]
    measured_final_mah, predicted_final_mah : float
        [mAh]
    time_error_s : dict
        Predicted minus real time to reach the final charge, from the
        prediction made at 25/50/75 % of the flight. [s]
    time_error_power_w : dict
        The power each of those predictions assumes for the rest of the flight: the
        mean of the 60 s before the point. [W]
    mean_power_w : float
        Mean power of the whole log, against which those powers read. [W]
    reserve_reached_s, reserve_predicted_s : float or None
        When the landing reserve was reached in the log and when the model
        (at the 50 % point) said it would be. [s]
    """

    model: str
    rmse_mah: float
    final_error_pct: float
    rmse_vs_integrated_mah: float
    final_error_vs_integrated_pct: float
    measured_final_mah: float
    predicted_final_mah: float
    time_error_s: dict[str, float]
    reserve_reached_s: float | None
    reserve_predicted_s: float | None
    time_error_power_w: dict[str, float] = field(default_factory=dict)
    mean_power_w: float = float("nan")


@dataclass
class PowerReplay:
    """Physics model against the measured electric power (airborne samples).

    Attributes
    ----------
    rmse_w : float
        [W]
    bias_w : float
        Mean predicted − measured. [W]
    energy_error_pct : float
        (predicted − measured) / measured energy over the airborne samples. [%]
    measured_energy_wh, predicted_energy_wh : float
        [Wh]
    phases : dict
        Per phase: duration [s], measured and predicted mean power [W], error [%].
    airspeed_source : str
        Which channel drove the model.
    """

    rmse_w: float
    bias_w: float
    energy_error_pct: float
    measured_energy_wh: float
    predicted_energy_wh: float
    phases: dict[str, dict[str, float]]
    airspeed_source: str
    density_source: str


@dataclass
class ExperimentReplay:
    """One experiment replayed: its id, duration [s] and samples, the battery and power
    levels (None where not replayed), notes, and the per-sample series of the replay
    (``series``: ``time_s`` [s], ``measured_w``/``predicted_w`` [W], charges [mAh],
    ``time_to_reserve_s`` [s], ``phase``).
    """
    experiment: str
    duration_s: float
    samples: int
    battery: BatteryReplay | None
    power: PowerReplay | None
    notes: list[str]
    series: dict[str, np.ndarray] = field(repr=False, default_factory=dict)


@dataclass
class ReplayResult:
    """Every experiment replayed and the overall figures (mean final error [%], RMSE
    [mAh], power RMSE [W], energy error [%]).
    """
    experiments: list[ExperimentReplay]
    overall: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form: the overall figures and each experiment without its series."""
        def conv(obj):
            if obj is None:
                return None
            d = {k: v for k, v in obj.__dict__.items() if k != "series"}
            return d
        return {"overall": self.overall,
                "experiments": [{"experiment": e.experiment, "duration_s": e.duration_s,
                                 "samples": e.samples, "battery": conv(e.battery),
                                 "power": conv(e.power), "notes": e.notes}
                                for e in self.experiments]}


# ---------------------------------------------------------------------- pieces
def _rolling_mean(t, y, window_s):
    """Mean of ``y`` over the trailing ``window_s`` seconds (trapezoid, vectorised)."""
    cum = record.cumulative_trapezoid(y, t)
    start = np.searchsorted(t, t - window_s, side="left")
    span = t - t[start]
    with np.errstate(invalid="ignore", divide="ignore"):
        m = (cum - cum[start]) / span
    return np.where(span > 0, m, y)


#: Capacity of a literature pack whose log gives none: far above any charge drawn, so
#: that nothing (diagnose's β fit, a reserve) takes it for a measured one. [mAh]
UNKNOWN_CAPACITY_MAH = 1e7


def literature_pack(cells: int | None = None, capacity_mah: float | None = None,
                    voltage_v=None) -> tuple[BatteryPack | None, str]:
    """The pack a log flew when no pack file is given: the literature integral model
    δ₀(N), ε₀(N) of its cell count N ([UAV23] eq. 16–17,
    :meth:`planner.parameters.IntegralModel.from_literature`), and a label saying so.

    Parameters
    ----------
    cells : int, optional
        Cells in series from the log's parameters (``battery_cells``); else found from
        the pack voltage (:func:`planner.physics.battery.cells.series_cells`).
    capacity_mah : float, optional
        The log's pack capacity (``battery_capacity_mah``): β = 0.9648 with δ scaled to
        it; unknown, β = 1 (Peukert's form) and the pack's capacity is
        :data:`UNKNOWN_CAPACITY_MAH`. [mAh]
    voltage_v : array_like, optional
        The log's pack voltage, for the cell count. [V]

    Returns
    -------
    (BatteryPack or None, str)
        The pack (mass 0 kg: unknown, so a take-off mass built from it leaves the pack
        out) and its label; ``(None, why)`` when the cell count cannot be found.
    """
    how = "log parameter"
    if not cells:
        cells, how = (series_cells(voltage_v) if voltage_v is not None else None,
                      "detected from voltage")
    if not cells:
        return None, "no voltage to find the cell count"
    cells = int(cells)
    cap = float(capacity_mah) if capacity_mah else None
    model = IntegralModel.from_literature(cells, cap * AS_PER_MAH if cap else None)
    size = f", {cap:.0f} mAh from the log" if cap else ", capacity unknown: β = 1"
    label = f"literature {cells}S ({how}{size})"
    return BatteryPack(name=label, cells_series=cells, capacity_mah=cap or UNKNOWN_CAPACITY_MAH,
                       mass_kg=0.0, model=model), label


def flown_pack(pack: BatteryPack | None, meta: dict, voltage) -> tuple[BatteryPack | None,
                                                                        str]:
    """The pack the replay flies: the pack file, else :func:`literature_pack` of the log."""
    if pack is not None:
        what = "literature" if pack.model.literature else "fitted"
        return pack, f"{what} ({pack.name})"
    return literature_pack(meta.get("battery_cells"), meta.get("battery_capacity_mah"),
                           voltage)


def battery_replay(exp: pd.DataFrame, chain: MissionChain, label: str,
                   capacity_mah: float | None, reserve: float = 0.2
                   ) -> tuple[BatteryReplay, dict[str, np.ndarray]]:
    """The chain's battery model driven by the measured power of one experiment
    (:meth:`planner.chain.mission_chain.MissionChain.battery_from_power`)."""
    t = exp["time_s"].to_numpy(float)
    p = exp["power_w"].to_numpy(float)
    trace = chain.battery_from_power(
        t, p, temperature_c=exp["temperature_c"].to_numpy(float)
        if "temperature_c" in exp else None)
    model, base = trace.model, trace.base_charge_as
    # the model's charge, with the pack's temperature and fade extensions sample by sample
    predicted = trace.charge_as / AS_PER_MAH
    # forward predictions hold the present extension factor: C = C_now + s·(C_0 − C_0,now)
    scale = trace.scale
    measured = exp["consumed_mah"].to_numpy(float)
    measured = measured - measured[np.isfinite(measured)][0] if np.isfinite(measured).any() \
        else measured
    current = exp["current_a"].to_numpy(float) if "current_a" in exp else np.full_like(t, np.nan)
    integrated = record.cumulative_trapezoid(current, t) / AS_PER_MAH

    def metrics(meas):
        ok = np.isfinite(meas) & np.isfinite(predicted)
        if ok.sum() < 2:
            return float("nan"), float("nan")
        r = meas[ok] - predicted[ok]
        final = meas[ok][-1]
        return (float(np.sqrt(np.mean(r**2))),
                float(100.0 * r[-1] / final) if final > 0 else float("nan"))

    rmse, final_err = metrics(measured)
    rmse_i, final_i = metrics(integrated)
    stress = trace.stress

    def base_target(k, charge_as):
        return base[k] + (charge_as - predicted[k] * AS_PER_MAH) / scale[k]

    p_avg = _rolling_mean(t, np.nan_to_num(p), 60.0)
    c_final = measured[np.isfinite(measured)][-1] if np.isfinite(measured).any() else np.nan
    time_errors, time_error_power = {}, {}
    for frac in (0.25, 0.5, 0.75):
        k = int(np.searchsorted(t, t[0] + frac * (t[-1] - t[0])))
        k = min(k, len(t) - 1)
        if p_avg[k] > 0 and np.isfinite(c_final):
            dt = integral.time_to_charge(stress[k], p_avg[k], base_target(k, c_final * AS_PER_MAH),
                                         model.delta, model.epsilon, model.beta)
            time_errors[f"{int(frac * 100)}pct"] = float(t[k] + dt - t[-1])
            time_error_power[f"{int(frac * 100)}pct"] = float(p_avg[k])
    reached = predicted_at = None
    to_reserve = np.full_like(t, np.nan)
    if capacity_mah:
        limit = capacity_mah * (1.0 - reserve)
        hit = np.flatnonzero(measured >= limit)
        reached = float(t[hit[0]]) if hit.size else None
        with np.errstate(invalid="ignore", divide="ignore"):
            to_reserve = np.where(p_avg > 0, integral.time_to_charge(
                stress, np.where(p_avg > 0, p_avg, 1.0), base_target(slice(None), limit * AS_PER_MAH),
                model.delta, model.epsilon, model.beta), np.nan)
        k = len(t) // 2
        predicted_at = float(t[k] + to_reserve[k]) if np.isfinite(to_reserve[k]) else None
    result = BatteryReplay(model=label, rmse_mah=rmse, final_error_pct=final_err,
                           rmse_vs_integrated_mah=rmse_i,
                           final_error_vs_integrated_pct=final_i,
                           measured_final_mah=float(c_final),
                           predicted_final_mah=float(predicted[-1]),
                           time_error_s=time_errors, reserve_reached_s=reached,
                           reserve_predicted_s=predicted_at,
                           time_error_power_w=time_error_power,
                           mean_power_w=_mean_power(t, p))
    series = {"measured_mah": measured, "predicted_mah": predicted,
              "integrated_mah": integrated, "time_to_reserve_s": to_reserve}
    return result, series


def power_replay(exp: pd.DataFrame, chain: MissionChain, mass_kg: float,
                 site_altitude_m: float = 0.0) -> tuple[PowerReplay, dict[str, np.ndarray]]:
    """The chain's power model driven by the measured flight state of one experiment
    (:meth:`planner.chain.mission_chain.MissionChain.power_from_state`)."""
    state = flightstate.from_record(exp, site_altitude_m)
    t, measured, phase = state.time_s, state.measured_power_w, state.phase
    vsource, dsource = state.airspeed_source, state.density_source
    predicted = chain.power_from_state(state, mass_kg)
    air = (phase != "ground") & np.isfinite(measured) & np.isfinite(predicted)
    dt = np.gradient(t) if len(t) > 1 else np.ones_like(t)
    if air.sum() < 2:
        nan = float("nan")
        return PowerReplay(nan, nan, nan, nan, nan, {}, vsource, dsource), {
            "predicted_w": predicted, "phase": phase}
    r = predicted[air] - measured[air]
    e_meas = float(np.sum(measured[air] * dt[air])) / 3600.0
    e_pred = float(np.sum(predicted[air] * dt[air])) / 3600.0
    phases = {}
    for name in flightstate.PHASES:
        m = phase == name
        if m.sum() >= 2:
            pm, pp = float(np.nanmean(measured[m])), float(np.nanmean(predicted[m]))
            phases[name] = {"duration_s": float(np.sum(dt[m])), "measured_w": pm,
                            "predicted_w": pp,
                            "error_pct": 100.0 * (pp - pm) / pm if pm > 0 else float("nan")}
    result = PowerReplay(rmse_w=float(np.sqrt(np.mean(r**2))), bias_w=float(np.mean(r)),
                         energy_error_pct=100.0 * (e_pred - e_meas) / e_meas if e_meas > 0
                         else float("nan"),
                         measured_energy_wh=e_meas, predicted_energy_wh=e_pred,
                         phases=phases, airspeed_source=vsource, density_source=dsource)
    return result, {"predicted_w": predicted, "phase": phase}


# ---------------------------------------------------------------------- driver
def replay(data: pd.DataFrame, metas: list[dict] | None = None, *,
           pack: BatteryPack | None = None, aircraft: Aircraft | None = None,
           payload_kg: float | dict | None = None, reserve: float = 0.2,
           site_altitude_m: float = 0.0) -> ReplayResult:
    """Replay every experiment of a flight record (see the module docstring).

    ``payload_kg``: one payload for every experiment, or a mapping experiment id →
    payload [kg]; None: the record's own ``payload_kg`` per experiment where it has one,
    else 0."""
    if payload_kg is None:
        payload_kg = record.experiment_payloads(data) or 0.0
    metas = metas or [{}]
    meta_of = {}
    for meta in metas:
        meta_of[str(meta.get("source", ""))] = meta
    out: list[ExperimentReplay] = []
    for exp_id, exp in record.experiments(data):
        exp = exp.reset_index(drop=True)
        meta = _meta_for(exp_id, metas)
        notes: list[str] = []
        t = exp["time_s"].to_numpy(float)
        if not record.has_power(exp):
            # a log without a current sensor: nothing of the battery to compare with
            notes.append(record.NO_CURRENT + (" (the log has battery voltage only)"
                                              if "voltage_v" in exp else " (no battery data)"))
            out.append(ExperimentReplay(str(exp_id), float(t[-1] - t[0]) if len(t) else 0.0,
                                        len(exp), None, None, notes, {"time_s": t}))
            continue
        flown, label = flown_pack(pack, meta, exp.get("voltage_v", pd.Series(dtype=float)))
        if pack is not None and "voltage_v" in exp:
            cells = meta.get("battery_cells") or series_cells(exp["voltage_v"])
            if cells and cells != pack.cells_series:
                notes.append(f"the log's pack has {cells} cells in series, the pack file "
                             f"{pack.cells_series}: is it the pack that flew?")
        capacity = (pack.total_capacity_mah if pack is not None
                    else meta.get("battery_capacity_mah"))
        series = {"time_s": t, "measured_w": exp["power_w"].to_numpy(float)}
        chain = MissionChain(aircraft, flown) if flown is not None else None
        bat = None
        if chain is not None and "power_w" in exp:
            bat, s = battery_replay(exp, chain, label, capacity, reserve)
            series.update(s)
            if flown.model.literature:
                notes.append(f"battery model: {label}")
        pw = None
        if aircraft is not None:
            payload = (payload_kg.get(str(exp_id), float("nan"))
                       if isinstance(payload_kg, dict) else payload_kg)
            if not np.isfinite(payload):
                notes.append("no payload known for this flight: 0 kg assumed")
                payload = 0.0
            mass = aircraft.empty_mass_kg + payload + (
                pack.total_mass_kg if pack is not None else 0.0)
            if pack is None:
                notes.append("no battery-pack file: take-off mass excludes the pack")
            if not {"climb_rate_ms", "groundspeed_ms"} & set(exp.columns):
                notes.append("no flight state (speed, climb) in the data: power level skipped")
            else:
                pw, s = power_replay(exp, chain or MissionChain(aircraft, None), mass,
                                     site_altitude_m)
                series.update(s)
                if chain is not None:
                    # the whole chain: measured state → power model → battery model
                    trace = chain.battery_from_power(
                        t, s["predicted_w"], temperature_c=exp["temperature_c"].to_numpy(float)
                        if "temperature_c" in exp else None)
                    series["predicted_power_mah"] = trace.charge_as / AS_PER_MAH
        out.append(ExperimentReplay(str(exp_id), float(t[-1] - t[0]) if len(t) else 0.0,
                                    len(exp), bat, pw, notes, series))
    return ReplayResult(out, _overall(out))


#: Columns ``replay --csv`` adds to the flight record, with their meaning.
TABLE_COLUMNS = {
    "predicted_power_w": "power model at the measured flight state [W]",
    "predicted_charge_mah": "charge drawn since the start, battery model driven by "
                            "predicted_power_w [mAh]",
    "battery_model_charge_mah": "charge drawn since the start, battery model driven by "
                                "the measured power_w [mAh]",
    "measured_charge_mah": "charge drawn since the start, from the logger's counter "
                           "(else the integral of current_a) [mAh]",
    "flight_phase": "flight phase of the power comparison (planner.chain.flightstate)",
}


def replay_table(data: pd.DataFrame, result: ReplayResult) -> pd.DataFrame:
    """The flight record with the replay's per-sample values beside the measured ones
    (:data:`TABLE_COLUMNS`; NaN where a level was not replayed), experiment by
    experiment in the order of :func:`replay`."""
    frames = []
    by_id = {e.experiment: e for e in result.experiments}
    for exp_id, exp in record.experiments(data):
        exp = exp.reset_index(drop=True).copy()
        series = by_id[str(exp_id)].series
        n = len(exp)
        nan = np.full(n, np.nan)
        exp["predicted_power_w"] = series.get("predicted_w", nan)
        exp["predicted_charge_mah"] = series.get("predicted_power_mah", nan)
        exp["battery_model_charge_mah"] = series.get("predicted_mah", nan)
        exp["measured_charge_mah"] = series.get("measured_mah", nan)
        exp["flight_phase"] = series.get("phase", np.full(n, "", dtype=object))
        frames.append(exp)
    return pd.concat(frames, ignore_index=True)


def _meta_for(exp_id, metas):
    for meta in metas:
        src = str(meta.get("source", ""))
        if src and str(exp_id) in src:
            return meta
    return metas[0] if len(metas) == 1 else {}


def _mean_power(t, p) -> float:
    """Time-weighted mean of the finite power samples (trapezoids). [W]"""
    ok = np.isfinite(p)
    if ok.sum() < 2 or t[ok][-1] <= t[ok][0]:
        return float("nan")
    tt, pp = t[ok], p[ok]
    return float(np.sum(0.5 * (pp[1:] + pp[:-1]) * np.diff(tt)) / (tt[-1] - tt[0]))


def _overall(exps: list[ExperimentReplay]) -> dict[str, Any]:
    bats = [e.battery for e in exps if e.battery is not None]
    pows = [e.power for e in exps if e.power is not None and np.isfinite(e.power.rmse_w)]
    overall: dict[str, Any] = {"experiments": len(exps)}
    if bats:
        # weighted by the charge each log drew: sum(measured - predicted) / sum(measured),
        # so that a log of a few seconds cannot outweigh whole flights; logs whose counter
        # drew no charge (or ran below zero) carry no weight
        m = np.array([b.measured_final_mah for b in bats], float)
        pr = np.array([b.predicted_final_mah for b in bats], float)
        use = np.isfinite(m) & np.isfinite(pr) & (m > 0)
        weighted = (float(100.0 * np.sum(m[use] - pr[use]) / np.sum(m[use])) if use.any()
                    else float("nan"))
        overall["battery"] = {
            "final_error_pct": weighted,
            "final_error_weighting": "charge drawn",
            "logs_weighted": int(use.sum()),
            "unweighted_final_error_pct": float(np.nanmean([b.final_error_pct
                                                            for b in bats])),
            "abs_final_error_pct": float(np.nanmean([abs(b.final_error_pct) for b in bats])),
            "rmse_mah": float(np.sqrt(np.nanmean([b.rmse_mah**2 for b in bats]))),
        }
    if pows:
        e_m = sum(p.measured_energy_wh for p in pows)
        e_p = sum(p.predicted_energy_wh for p in pows)
        overall["power"] = {
            "rmse_w": float(np.sqrt(np.mean([p.rmse_w**2 for p in pows]))),
            "energy_error_pct": 100.0 * (e_p - e_m) / e_m if e_m > 0 else float("nan"),
        }
    return overall
