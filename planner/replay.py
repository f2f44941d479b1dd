"""Replay a real flight: drive the models with what was flown, compare with the battery.

Two levels, per experiment (flight or discharge):

* **battery** — the integral model driven by the *measured* power predicts the
  charge drawn; it is compared with the logger's own consumed-charge counter and
  with the trapezoid integral of the measured current (RMSE in mAh, final
  normalized error in %, seed eq. 29–30). Without a pack file the literature
  model δ₀(N), ε₀(N), β = 0.9648 is used for the cell count N from the log
  (``BATT_*``/``BAT1_N_CELLS``) or, failing that, N = ⌈V_max / 4.25 V⌉. A
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

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from planner import atmosphere, record
from planner.battery import integral
from planner.chain import filled_temperature
from planner.parameters import Aircraft, BatteryPack, IntegralModel
from planner.units import AS_PER_MAH

R_AIR = 287.05287
PHASES = ("ground", "takeoff", "climb", "cruise", "hover", "descent")


def detect_cells(voltage_v) -> int | None:
    """Series cell count from the highest pack voltage: ⌈V_max / 4.25 V⌉."""
    v = np.asarray(voltage_v, float)
    v = v[np.isfinite(v) & (v > 0)]
    if v.size == 0:
        return None
    return max(1, int(math.ceil(float(np.max(v)) / 4.25)))


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
        (measured − predicted) / measured at the end, seed eq. 30. [%]
    rmse_vs_integrated_mah, final_error_vs_integrated_pct : float
        The same against the integral of the measured current. [mAh], [%]
    measured_final_mah, predicted_final_mah : float
        [mAh]
    time_error_s : dict
        Predicted minus real time to reach the final charge, from the
        prediction made at 25/50/75 % of the flight. [s]
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
    experiment: str
    duration_s: float
    samples: int
    battery: BatteryReplay | None
    power: PowerReplay | None
    notes: list[str]
    series: dict[str, np.ndarray] = field(repr=False, default_factory=dict)


@dataclass
class ReplayResult:
    experiments: list[ExperimentReplay]
    overall: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
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
def flight_phases(power_w, climb_rate_ms=None, groundspeed_ms=None, time_s=None,
                  altitude_m=None):
    """Label every sample with a flight phase (see the module docstring).

    A record whose altitude never changes by 1 m (or is not known) and whose
    ground speed never exceeds 1 m/s is a ground test: every sample is ``ground``.
    """
    p = np.asarray(power_w, float)
    n = p.size
    if n == 0:
        return np.array([], dtype=object)
    finite = p[np.isfinite(p)]
    p90 = np.percentile(finite, 90) if finite.size else np.nan
    airborne = p > 0.3 * p90
    if altitude_m is not None and groundspeed_ms is not None:
        alt = np.asarray(altitude_m, float)
        gsp = np.asarray(groundspeed_ms, float)
        still_alt = not np.isfinite(alt).any() or np.nanmax(alt) - np.nanmin(alt) < 1.0
        if still_alt and np.isfinite(gsp).any() and np.nanmax(gsp) < 1.0:
            return np.full(n, "ground", dtype=object)
    vz = np.zeros(n) if climb_rate_ms is None else np.nan_to_num(np.asarray(climb_rate_ms,
                                                                            float))
    gs = np.zeros(n) if groundspeed_ms is None else np.nan_to_num(np.asarray(groundspeed_ms,
                                                                             float))
    phase = np.where(vz > 0.5, "climb", np.where(vz < -0.5, "descent",
                                                 np.where(gs > 2.0, "cruise", "hover")))
    phase = np.where(airborne, phase, "ground").astype(object)
    if time_s is not None and airborne.any():
        t = np.asarray(time_s, float)
        t0 = t[np.argmax(airborne)]
        phase[airborne & (t >= t0) & (t < t0 + 10.0)] = "takeoff"
    return phase


def _rolling_mean(t, y, window_s):
    """Mean of ``y`` over the trailing ``window_s`` seconds (trapezoid, vectorised)."""
    cum = record.cumulative_trapezoid(y, t)
    start = np.searchsorted(t, t - window_s, side="left")
    span = t - t[start]
    with np.errstate(invalid="ignore", divide="ignore"):
        m = (cum - cum[start]) / span
    return np.where(span > 0, m, y)


def _pack_model(pack: BatteryPack | None, meta: dict, voltage) -> tuple[IntegralModel, str]:
    if pack is not None:
        what = "literature" if pack.model.literature else "fitted"
        return pack.model, f"{what} ({pack.name})"
    cells, how = meta.get("battery_cells"), "log parameter"
    if not cells:
        cells, how = detect_cells(voltage), "detected from voltage"
    if not cells:
        return None, "no voltage to find the cell count"
    cap = meta.get("battery_capacity_mah")
    model = IntegralModel.from_literature(cells, cap * AS_PER_MAH if cap else None)
    size = f", {cap:.0f} mAh from the log" if cap else ", capacity unknown: β = 1"
    return model, f"literature {cells}S ({how}{size})"


def battery_replay(exp: pd.DataFrame, model: IntegralModel, label: str,
                   capacity_mah: float | None, reserve: float = 0.2
                   ) -> tuple[BatteryReplay, dict[str, np.ndarray]]:
    """Integral model driven by the measured power of one experiment."""
    t = exp["time_s"].to_numpy(float)
    p = exp["power_w"].to_numpy(float)
    temp = (filled_temperature(exp["temperature_c"].to_numpy(float))
            if "temperature_c" in exp and model.temperature_coefficient_per_c else None)
    base = integral.charge(t, np.nan_to_num(p), model.delta, model.epsilon, model.beta)
    # the model's charge, with the pack's temperature and fade extensions sample by sample
    predicted = model.extend_charge(base, temp) / AS_PER_MAH
    # forward predictions hold the present extension factor: C = C_now + s·(C_0 − C_0,now)
    scale = model.charge_scale(temp) * np.ones_like(t)
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
    stress = integral.stress_from_charge(base, model.beta)

    def base_target(k, charge_as):
        return base[k] + (charge_as - predicted[k] * AS_PER_MAH) / scale[k]

    p_avg = _rolling_mean(t, np.nan_to_num(p), 60.0)
    c_final = measured[np.isfinite(measured)][-1] if np.isfinite(measured).any() else np.nan
    time_errors = {}
    for frac in (0.25, 0.5, 0.75):
        k = int(np.searchsorted(t, t[0] + frac * (t[-1] - t[0])))
        k = min(k, len(t) - 1)
        if p_avg[k] > 0 and np.isfinite(c_final):
            dt = integral.time_to_charge(stress[k], p_avg[k], base_target(k, c_final * AS_PER_MAH),
                                         model.delta, model.epsilon, model.beta)
            time_errors[f"{int(frac * 100)}pct"] = float(t[k] + dt - t[-1])
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
                           reserve_predicted_s=predicted_at)
    series = {"measured_mah": measured, "predicted_mah": predicted,
              "integrated_mah": integrated, "time_to_reserve_s": to_reserve}
    return result, series


def flight_state(exp: pd.DataFrame, site_altitude_m: float = 0.0):
    """Airspeed, climb rate and air density the power model needs, from the record.

    Returns ``(airspeed, climb_rate, density, airspeed_source, density_source)``.
    """
    n = len(exp)
    col = (lambda name: exp[name].to_numpy(float) if name in exp.columns
           else np.full(n, np.nan))
    airspeed, gs = col("airspeed_ms"), col("groundspeed_ms")
    course = col("course_deg")
    wn, we = col("wind_n_ms"), col("wind_e_ms")
    have_wind = np.isfinite(wn) & np.isfinite(we) & ((np.abs(wn) + np.abs(we)) > 0)
    # hovering, the track is undefined (and often not logged): any course will do
    course = np.where(np.isfinite(course) | ~(np.nan_to_num(gs, nan=1.0) < 0.2), course, 0.0)
    a = np.radians(course)
    from_wind = np.hypot(gs * np.sin(a) - we, gs * np.cos(a) - wn)
    if np.isfinite(airspeed).mean() > 0.5:
        source = "measured airspeed"
        v = np.where(np.isfinite(airspeed), airspeed, gs)
    elif have_wind.mean() > 0.5:
        source = "ground speed corrected with the logged wind"
        v = np.where(have_wind & np.isfinite(course), from_wind, gs)
    else:
        source = "ground speed (no airspeed or wind in the log: still air assumed)"
        v = gs
    v = np.abs(np.nan_to_num(v))
    climb = np.nan_to_num(col("climb_rate_ms"))
    p, temp = col("pressure_pa"), col("ambient_temperature_c")
    if np.isfinite(p).mean() > 0.5 and np.isfinite(temp).mean() > 0.5:
        p = pd.Series(p).interpolate(limit_direction="both").to_numpy()
        temp = pd.Series(temp).interpolate(limit_direction="both").to_numpy()
        rho = p / (R_AIR * (temp + 273.15))
        dsource = "measured pressure and temperature"
    else:
        rho = np.full(n, float(atmosphere.density(site_altitude_m)))
        dsource = f"ISA at {site_altitude_m:.0f} m"
    return v, climb, rho, source, dsource


def power_replay(exp: pd.DataFrame, aircraft: Aircraft, mass_kg: float,
                 site_altitude_m: float = 0.0) -> tuple[PowerReplay, dict[str, np.ndarray]]:
    """Physics model driven by the measured flight state of one experiment."""
    t = exp["time_s"].to_numpy(float)
    measured = exp["power_w"].to_numpy(float)
    v, climb, rho, vsource, dsource = flight_state(exp, site_altitude_m)
    if not aircraft.is_multirotor:
        fw = aircraft.fixed_wing
        v = np.maximum(v, fw.stall_speed_ms or 0.5 * fw.cruise_airspeed_ms)
    predicted = np.asarray(aircraft.battery_power(v, climb, rho, mass_kg), float)
    phase = flight_phases(measured, exp.get("climb_rate_ms"), exp.get("groundspeed_ms"), t,
                          exp.get("altitude_m"))
    # on the ground the motors are idle or off: only the system load remains
    predicted = np.where(phase == "ground", aircraft.system_power_w, predicted)
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
    for name in PHASES:
        m = phase == name
        if m.sum() >= 2:
            pm, pp = float(np.nanmean(measured[m])), float(np.nanmean(predicted[m]))
            phases[name] = {"duration_s": float(np.sum(dt[m])), "measured_w": pm,
                            "predicted_w": pp,
                            "error_pct": 100.0 * (pp - pm) / pm if pm > 0 else float("nan")}
    result = PowerReplay(rmse_w=float(np.sqrt(np.mean(r**2))), bias_w=float(np.mean(r)),
                         energy_error_pct=100.0 * (e_pred - e_meas) / e_meas,
                         measured_energy_wh=e_meas, predicted_energy_wh=e_pred,
                         phases=phases, airspeed_source=vsource, density_source=dsource)
    return result, {"predicted_w": predicted, "phase": phase}


# ---------------------------------------------------------------------- driver
def replay(data: pd.DataFrame, metas: list[dict] | None = None, *,
           pack: BatteryPack | None = None, aircraft: Aircraft | None = None,
           payload_kg: float = 0.0, reserve: float = 0.2,
           site_altitude_m: float = 0.0) -> ReplayResult:
    """Replay every experiment of a flight record (see the module docstring)."""
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
        model, label = _pack_model(pack, meta, exp.get("voltage_v", pd.Series(dtype=float)))
        if pack is not None and "voltage_v" in exp:
            cells = meta.get("battery_cells") or detect_cells(exp["voltage_v"])
            if cells and cells != pack.cells_series:
                notes.append(f"the log's pack has {cells} cells in series, the pack file "
                             f"{pack.cells_series}: is it the pack that flew?")
        capacity = (pack.total_capacity_mah if pack is not None
                    else meta.get("battery_capacity_mah"))
        series = {"time_s": t, "measured_w": exp["power_w"].to_numpy(float)}
        bat = None
        if model is not None and "power_w" in exp:
            bat, s = battery_replay(exp, model, label, capacity, reserve)
            series.update(s)
            if model.literature:
                notes.append(f"battery model: {label}")
        pw = None
        if aircraft is not None:
            mass = aircraft.empty_mass_kg + payload_kg + (
                pack.total_mass_kg if pack is not None else 0.0)
            if pack is None:
                notes.append("no --battery: take-off mass excludes the pack")
            if not {"climb_rate_ms", "groundspeed_ms"} & set(exp.columns):
                notes.append("no flight state (speed, climb) in the data: power level skipped")
            else:
                pw, s = power_replay(exp, aircraft, mass, site_altitude_m)
                series.update(s)
        out.append(ExperimentReplay(str(exp_id), float(t[-1] - t[0]) if len(t) else 0.0,
                                    len(exp), bat, pw, notes, series))
    return ReplayResult(out, _overall(out))


def _meta_for(exp_id, metas):
    for meta in metas:
        src = str(meta.get("source", ""))
        if src and str(exp_id) in src:
            return meta
    return metas[0] if len(metas) == 1 else {}


def _overall(exps: list[ExperimentReplay]) -> dict[str, Any]:
    bats = [e.battery for e in exps if e.battery is not None]
    pows = [e.power for e in exps if e.power is not None and np.isfinite(e.power.rmse_w)]
    overall: dict[str, Any] = {"experiments": len(exps)}
    if bats:
        overall["battery"] = {
            "final_error_pct": float(np.nanmean([b.final_error_pct for b in bats])),
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
