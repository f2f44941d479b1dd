"""One flight → one row of the fleet table: read, replay through the chain, calibrate.

:func:`summarise_log` is what a Dask worker runs for each log. It never raises: a log that
cannot be used gives a row with ``status = "failed"`` and the one-line reason, so that one
damaged file does not stop a fleet.

Per flight it records what the operator reads off a logbook (duration, energy, charge) and
what the planner predicted for it:

* **charge** — the chain's battery model driven by the measured power
  (:func:`planner.identify.replay.battery_replay`, [UAV23] eq. 14) against the logger's consumed
  charge at the end of the flight;
* **energy** — the chain's power model driven by the measured flight state
  (:func:`planner.identify.replay.power_replay`) against the measured electric energy over the
  airborne samples;
* **δ scale** — the least-squares factor :math:`s` in :math:`C(t) = s\\,\\hat C(t)`
  between the measured charge and the model's charge along the flight, with its standard
  error (AR(1)-inflated, :func:`planner.identify.stats.covariance`). For the integral model
  :math:`\\hat C^\\beta = \\int dt / (\\delta P^\\varepsilon)` a factor :math:`s` on the
  charge is :math:`\\delta \\to \\delta s^{-\\beta}`; a pack that draws more charge for the
  same energy as it ages has :math:`s` rising with its cycles (the ``fade_per_cycle`` of
  the pack file, :meth:`planner.parameters.IntegralModel.charge_scale`);
* **internal resistance** — the amended-VDA estimate :math:`R = -\\Delta V / \\Delta I`
  ([UAV23] eq. 11) at every current step between two consecutive samples (a step of at least
  :data:`STEP_MIN_A` and :data:`STEP_MIN_FRACTION` of the flight's median current); the
  median over the steps, its standard error :math:`1.2533\\,s/\\sqrt n` (the median of a
  normal sample).
"""

from __future__ import annotations

import hashlib
import math
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from planner.io import record
from planner.identify import stats
from planner.chain.mission_chain import MissionChain
from planner.errors import PlannerError
from planner.parameters import Aircraft, BatteryPack
from planner.identify.replay import battery_replay, flown_pack, power_replay
from planner.physics.battery.cells import series_cells

#: Smallest current step used for the resistance. [A]
STEP_MIN_A = 2.0
#: Smallest current step relative to the flight's median current. [unitless]
STEP_MIN_FRACTION = 0.2
#: Longest time between the two samples of a step: beyond it the cells relax. [s]
STEP_MAX_DT_S = 1.0
#: Fewest steps for a resistance estimate.
STEP_MIN_COUNT = 3
#: Resistances outside (0, this] are not a pack's (sensor lag, a voltage spike). [Ω]
STEP_MAX_OHM = 1.0
#: Bytes read at a time for the content hash.
_HASH_BLOCK = 1 << 20
#: Most samples of one flight kept for the fleet's aircraft calibration (every k-th sample
#: of the record): 300 samples of 1 000 000 flights are 3·10⁸ rows, a few GB of Parquet.
CALIBRATION_SAMPLES = 300
#: Record columns kept for the calibration (those :func:`planner.chain.flightstate.from_record`
#: and :func:`planner.identify.aircraft_fit.fit_aircraft` read).
CALIBRATION_COLUMNS = ("time_s", "power_w", "altitude_m", "climb_rate_ms", "groundspeed_ms",
                       "airspeed_ms", "course_deg", "pressure_pa", "ambient_temperature_c",
                       "wind_n_ms", "wind_e_ms", "specific_force_ms2", "throttle", "mode",
                       "payload_kg")

#: Lowest voltage of a lithium cell in use (Battery University BU-501 "Basics about
#: Discharging": cut-off 3.0 V a cell): a pack whose highest voltage is below N × this
#: is not N cells in series. [V]
CELL_EMPTY_V = 3.0
#: A log's hover mass (the mass at which the aircraft's own power model draws the log's
#: hover power) beyond this factor of the aircraft's heaviest take-off, or below its empty
#: mass with the pack over this factor, is another class of aircraft. [unitless]
MASS_CLASS_FACTOR = 2.0
#: Hover samples: airborne, airspeed and climb rate below these. [m/s]
HOVER_SPEED_MS = 1.0
HOVER_CLIMB_MS = 0.3
#: Fewest hover samples for the mass check.
HOVER_MIN_SAMPLES = 10

#: Columns of the fleet table, in order, with their pandas/Arrow types.
COLUMNS: dict[str, str] = {
    "sha256": "string", "log": "string", "status": "string", "error": "string",
    "format": "string", "vehicle": "string", "aircraft": "string",
    "pack_id": "string", "pack_id_source": "string", "cycle": "float64",
    "start_time_utc": "datetime64[ns, UTC]", "duration_s": "float64", "samples": "int64",
    "cells": "float64", "log_capacity_mah": "float64", "battery_model": "string",
    "energy_wh": "float64", "charge_mah": "float64",
    "predicted_charge_mah": "float64", "charge_error_pct": "float64",
    "airborne_energy_wh": "float64", "predicted_energy_wh": "float64",
    "energy_error_pct": "float64", "power_rmse_w": "float64",
    "delta_scale": "float64", "delta_scale_se": "float64",
    "resistance_ohm": "float64", "resistance_se_ohm": "float64", "resistance_steps": "int64",
    "warnings": "string",
}


def safe_stem(text: str, fallback: str) -> str:
    """``text`` as a file name without folders or odd characters (``fallback`` when
    nothing is left): the stem of a pack or aircraft file in the output folder."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or fallback


def content_hash(path: str | Path) -> str:
    """SHA-256 of the file's bytes (hex): the key of a flight in the table."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(_HASH_BLOCK), b""):
            h.update(block)
    return h.hexdigest()


def step_resistance(time_s, voltage_v, current_a) -> tuple[float, float, int]:
    """Pack resistance from current steps (module notes): (R [Ω], standard error [Ω], n)."""
    t = np.asarray(time_s, float)
    v = np.asarray(voltage_v, float)
    i = np.asarray(current_a, float)
    nan = float("nan")
    ok = np.isfinite(i) & np.isfinite(v)
    if ok.sum() < 2:
        return nan, nan, 0
    d_i, d_v, d_t = np.diff(i), np.diff(v), np.diff(t)
    level = max(STEP_MIN_A, STEP_MIN_FRACTION * float(np.nanmedian(np.abs(i[ok]))))
    with np.errstate(invalid="ignore", divide="ignore"):
        step = (np.abs(d_i) >= level) & (d_t <= STEP_MAX_DT_S) & np.isfinite(d_v)
        r = -d_v[step] / d_i[step]
    r = r[(r > 0) & (r <= STEP_MAX_OHM)]
    if r.size < STEP_MIN_COUNT:
        return nan, nan, int(r.size)
    se = 1.2533 * float(np.std(r, ddof=1)) / math.sqrt(r.size)
    return float(np.median(r)), se, int(r.size)


def delta_scale(measured_mah, predicted_mah) -> tuple[float, float]:
    """Least-squares :math:`s` in ``measured = s · predicted`` along a flight and its
    standard error (module notes); NaN where the flight draws no charge."""
    m = np.asarray(measured_mah, float)
    p = np.asarray(predicted_mah, float)
    ok = np.isfinite(m) & np.isfinite(p)
    m, p = m[ok], p[ok]
    if m.size < 3 or not np.any(p > 0):
        return float("nan"), float("nan")
    s = float(np.dot(m, p) / np.dot(p, p))
    cov = stats.covariance(p[:, None], m - s * p)
    return s, float(cov.stderr[0])


def _start_time(meta: dict) -> pd.Timestamp:
    value = meta.get("start_time_unix")
    if value is None or not np.isfinite(value):
        return pd.NaT
    return pd.Timestamp(float(value), unit="s", tz="UTC")


def _empty_row(path: str, sha: str) -> dict[str, Any]:
    row: dict[str, Any] = {c: None for c in COLUMNS}
    row.update(sha256=sha, log=path, samples=0, resistance_steps=0)
    return row


def choose_aircraft(models: dict, key: str | None, meta: dict, path: str
                    ) -> tuple[str | None, Aircraft | None, BatteryPack | None]:
    """The aircraft that flew a log: ``key`` (from ``--packs``), else the only one of
    ``models`` (key → (Aircraft, pack)), else the one whose type (multirotor, fixed wing)
    is the log's vehicle type; without any aircraft, the key is moot. Raises PlannerError
    when several could have flown it or ``key`` is none of them."""
    if key is not None and key in models:
        return (key, *models[key])
    if key is not None and any(a is not None for a, _ in models.values()):
        raise PlannerError(f"{path}: the packs CSV names aircraft {key!r}, none of the "
                           f"aircraft given ({', '.join(models)})")
    if len(models) <= 1:
        return next(((k, *v) for k, v in models.items()), (None, None, None))
    kind = meta.get("vehicle_type")
    fits = [k for k, (a, _) in models.items() if a is not None and a.type == kind]
    if len(fits) == 1:
        return (fits[0], *models[fits[0]])
    raise PlannerError(f"{path}: which aircraft flew this {kind or 'unknown'} log? "
                       f"{'several' if fits else 'none'} of the aircraft given "
                       f"({', '.join(fits or list(models))}) could have: name it in the "
                       "packs CSV (column aircraft)")


class RowReason(PlannerError):
    """A log that is read but left out of the fleet's accuracy and calibration: the row's
    ``status`` (:attr:`status`) and its one-line reason; the row keeps what was measured."""

    status = "not used"


class NotReplayable(RowReason):
    """A log that is read but cannot be replayed (no current sensor): the row's reason."""

    status = "not replayable"


class Mismatch(RowReason):
    """A log whose vehicle type, cell count or mass class is not the aircraft's or the
    pack's it is flown with (:func:`check_match`): the row's reason."""

    status = "mismatch"


class NotAirborne(RowReason):
    """A log with no airborne sample (a ground test, a hop of a few seconds): its battery
    is replayed, but it is left out of the accuracy and the aircraft calibration."""

    status = "not airborne"


def summarise_log(path: str, pack_id: str | None = None, pack_id_source: str = "unknown",
                  cycle: float | None = None, *, aircraft: Aircraft | None = None,
                  pack: BatteryPack | None = None, payload_kg: float | None = None,
                  models: dict | None = None, aircraft_key: str | None = None,
                  samples: bool = False) -> dict[str, Any]:
    """Read, replay and calibrate one log: a row of :data:`COLUMNS` (module notes).

    Parameters
    ----------
    path : str
        The log file (any format :func:`planner.io.logs.read_log` takes).
    aircraft : Aircraft, optional
        Enables the energy (power-level) comparison.
    pack : BatteryPack, optional
        The new pack's model; default the literature model of the log's cell count.
    pack_id, pack_id_source : str, optional
        The pack flown, from ``--packs``; the log's own battery serial wins.
    cycle : float, optional
        The pack's charge-cycle count at this flight, from ``--packs``.
    payload_kg : float, optional
        Payload carried [kg]; default the log's own ``payload_kg`` (a flight record
        that carries one), else 0.
    models : dict, optional
        Aircraft key → (Aircraft, pack or None) of a fleet of several aircraft, instead of
        ``aircraft`` and ``pack``; the log's aircraft is :func:`choose_aircraft`'s.
    aircraft_key : str, optional
        The key of ``models`` that flew the log (from ``--packs``).
    samples : bool
        Also return the flight's record, every k-th sample (at most
        :data:`CALIBRATION_SAMPLES`, columns :data:`CALIBRATION_COLUMNS`), as
        ``row["_samples"]``: the fleet's aircraft calibration fits on them.

    Returns
    -------
    dict
        ``status`` is ``ok`` or ``failed`` (with ``error``, one line).
    """
    if models is None:
        models = {aircraft.name if aircraft is not None else "": (aircraft, pack)}
    try:
        sha = content_hash(path)
    except OSError as exc:
        row = _empty_row(path, "")
        row.update(status="failed", error=f"{path}: cannot read ({exc.strerror or exc})")
        return row
    row = _empty_row(path, sha)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            _fill(row, path, models, aircraft_key, pack_id, pack_id_source, cycle, payload_kg,
                  samples)
        notes = list(dict.fromkeys(str(w.message).replace("\n", " ") for w in caught))
        row["warnings"] = "; ".join(filter(None, [row.get("warnings") or ""] + notes)) or None
        row["status"] = "ok"
    except RowReason as exc:
        row.update(status=exc.status, error=str(exc))
    except PlannerError as exc:
        row.update(status="failed", error=str(exc).splitlines()[0] if str(exc) else
                   type(exc).__name__)
    except Exception as exc:  # noqa: BLE001 - one bad log must not stop a fleet
        row.update(status="failed",
                   error=f"{path}: internal error ({type(exc).__name__}: {exc})".splitlines()[0])
    return row


def _fill(row, path, models, key, pack_id, pack_id_source, cycle, payload_kg, samples
          ) -> None:
    """One log's row of the fleet table, ``row`` updated in place: the log's own figures,
    the battery level's replay, the power level's, the pack resistance and the notes.
    Raises :class:`NotReplayable` (no current), :class:`NotAirborne` (no airborne sample)
    or a :class:`PlannerError` naming the log."""
    from planner.io.logs import read_log

    df, meta = read_log(path)
    key, aircraft, pack = choose_aircraft(models, key, meta, path)
    df, t = _replayable(df, path)
    cells = _log_figures(row, df, meta, t, key if aircraft is not None else None,
                         pack_id, pack_id_source, cycle)
    state = None
    if aircraft is not None and {"climb_rate_ms", "groundspeed_ms"} & set(df.columns):
        from planner.chain import flightstate

        state = flightstate.from_record(df)
    check_match(df, meta, aircraft, pack, path, state)
    notes = _battery_level(row, df, meta, aircraft, pack, cells)
    if aircraft is not None:
        notes += _power_level(row, df, aircraft, pack, payload_kg, samples)
    if {"voltage_v", "current_a"} <= set(df.columns):
        r, r_se, n = step_resistance(t, df["voltage_v"], df["current_a"])
        row.update(resistance_ohm=r, resistance_se_ohm=r_se, resistance_steps=n)
    for w in meta.get("warnings") or []:
        notes.append(str(w))
    row["warnings"] = "; ".join(dict.fromkeys(notes)) or None
    if row["charge_mah"] is not None and row["charge_mah"] <= 0:
        row["warnings"] = "; ".join(filter(None, [row["warnings"],
                                                  "the logged charge does not rise"]))
    if state is not None:
        from planner.identify.aircraft_fit import airborne_mask

        if not airborne_mask(df, state, None).any():
            row.pop("_samples", None)
            raise NotAirborne(f"not airborne: no airborne sample in {row['duration_s']:.1f} s "
                              "(flight phases ground, take-off and landing only); left out "
                              "of the accuracy and the aircraft calibration")


def _replayable(df: pd.DataFrame, path) -> tuple[pd.DataFrame, np.ndarray]:
    """The log's flight record completed (one experiment, named after the file) and its
    times [s]; :class:`NotReplayable` without a current, a :class:`PlannerError` with
    fewer than two samples over time."""
    if not record.has_power(df):
        raise NotReplayable(f"{path}: {record.NO_CURRENT} (the log has "
                            + ("battery voltage only)" if "voltage_v" in df else
                               "no battery data)"))
    df = record.complete_record(df.assign(experiment=Path(path).name))
    df = df.reset_index(drop=True)
    t = df["time_s"].to_numpy(float)
    if len(t) < 2 or not t[-1] > t[0]:
        raise PlannerError(f"{path}: fewer than 2 battery samples over time; expected a flight")
    return df, t


def _log_figures(row, df, meta, t, aircraft_key, pack_id, pack_id_source, cycle):
    """The log's own figures into ``row`` (format, vehicle, aircraft, pack id and cycle —
    the log's battery serial and cycle count first —, start, duration [s], samples, cells,
    capacity [mAh], energy [Wh], charge drawn [mAh]); returns the cells in series (None:
    unknown)."""
    serial = meta.get("battery_serial")
    if serial not in (None, "", 0):
        pack_id, pack_id_source = str(serial), "log battery serial"
        if cycle is None and meta.get("battery_cycle_count") is not None:
            cycle = float(meta["battery_cycle_count"])
    power = df["power_w"].to_numpy(float)
    consumed = df["consumed_mah"].to_numpy(float)
    ok_c = np.isfinite(consumed)
    cells = meta.get("battery_cells") or (series_cells(df["voltage_v"]) if "voltage_v" in df
                                          else None)
    row.update(format=meta.get("format"), vehicle=meta.get("vehicle"),
               aircraft=aircraft_key,
               pack_id=pack_id or "unknown",
               pack_id_source=pack_id_source if pack_id else "unknown",
               cycle=float(cycle) if cycle is not None else None,
               start_time_utc=_start_time(meta), duration_s=float(t[-1] - t[0]),
               samples=len(t), cells=float(cells) if cells else None,
               log_capacity_mah=meta.get("battery_capacity_mah"),
               energy_wh=float(record.cumulative_trapezoid(np.nan_to_num(power), t)[-1]) / 3600.0,
               charge_mah=float(consumed[ok_c][-1] - consumed[ok_c][0]) if ok_c.any()
               else None)
    return cells


def _battery_level(row, df, meta, aircraft, pack, cells) -> list[str]:
    """The battery level's replay into ``row`` (model, predicted charge [mAh], error [%],
    the δ scale and its standard error); returns its notes."""
    flown, label = flown_pack(pack, meta, df.get("voltage_v", pd.Series(dtype=float)))
    if flown is None:
        return [f"battery level skipped: {label}"]
    notes = []
    if pack is not None and cells and int(cells) != pack.cells_series:
        notes.append(f"the log's pack has {int(cells)} cells in series, the pack file "
                     f"{pack.cells_series}")
    chain = MissionChain(aircraft, flown)
    capacity = pack.total_capacity_mah if pack is not None else \
        meta.get("battery_capacity_mah")
    bat, series = battery_replay(df, chain, label, capacity)
    s, s_se = delta_scale(series["measured_mah"], series["predicted_mah"])
    row.update(battery_model=label, predicted_charge_mah=bat.predicted_final_mah,
               charge_error_pct=bat.final_error_pct, delta_scale=s, delta_scale_se=s_se)
    return notes


def _power_level(row, df, aircraft, pack, payload_kg, samples) -> list[str]:
    """The power level's replay into ``row`` (airborne energy measured and predicted [Wh],
    its error [%], the power RMSE [W]; the calibration samples when ``samples``); returns
    its notes."""
    if not {"climb_rate_ms", "groundspeed_ms"} & set(df.columns):
        return ["no flight state (speed, climb) in the log: energy not predicted"]
    if payload_kg is None:
        own = record.experiment_payloads(df)
        payload_kg = next(iter(own.values())) if own else 0.0
        payload_kg = payload_kg if np.isfinite(payload_kg) else 0.0
    mass = aircraft.empty_mass_kg + payload_kg + (
        pack.total_mass_kg if pack is not None else 0.0)
    pw, _ = power_replay(df, MissionChain(aircraft, pack), mass)
    row.update(airborne_energy_wh=pw.measured_energy_wh,
               predicted_energy_wh=pw.predicted_energy_wh,
               energy_error_pct=pw.energy_error_pct, power_rmse_w=pw.rmse_w)
    if samples:
        row["_samples"] = calibration_samples(df)
    return []

def _cell_evidence(meta: dict, voltage) -> tuple[int | None, str]:
    """The log's cells in series and where they come from."""
    logged = meta.get("battery_cells")
    if logged:
        return int(logged), "battery_cells in the log's metadata"
    cells = series_cells(voltage) if voltage is not None else None
    if cells is None:
        return None, ""
    vmax = float(np.nanmax(np.asarray(voltage, float)))
    return cells, f"from its highest voltage {vmax:.2f} V, series_cells"


def check_match(df: pd.DataFrame, meta: dict, aircraft: Aircraft | None,
                pack: BatteryPack | None, path: str, state=None) -> list[str]:
    """Check a log against the aircraft and pack it is flown with: the log's vehicle type
    (its metadata), its cells in series (the metadata's ``battery_cells``, else
    :func:`planner.physics.battery.cells.series_cells` of its voltage: the fewest cells
    that voltage allows, so a pack of more cells is accepted as long as its highest
    voltage is above :data:`CELL_EMPTY_V` a cell) against the aircraft's
    ``cells_series_allowed`` and the pack file's ``cells_series``, and its mass class
    (a multirotor's hover power against the aircraft's own power model). Raises
    :class:`Mismatch` naming the first mismatch and its evidence; returns the checks that
    passed (the evidence used)."""
    used: list[str] = []
    if aircraft is None:
        return used
    kind = meta.get("vehicle_type")
    if kind:
        what = f"vehicle type {kind} from the log's metadata" + (
            f": {meta['vehicle']}" if meta.get("vehicle") else "")
        if kind != aircraft.type:
            raise Mismatch(f"mismatch: a {kind} log, the aircraft is a {aircraft.type} "
                           f"({what})")
        used.append(what)
    voltage = df["voltage_v"].to_numpy(float) if "voltage_v" in df else None
    cells, source = _cell_evidence(meta, voltage)
    if cells is not None:
        vmax = (float(np.nanmax(voltage)) if voltage is not None
                and np.isfinite(voltage).any() else math.nan)
        logged = bool(meta.get("battery_cells"))
        sets = []
        if aircraft.cells_series_allowed:
            sets.append((tuple(aircraft.cells_series_allowed), "the aircraft allows"))
        if pack is not None:
            sets.append(((pack.cells_series,), "the pack file is"))
        for allowed, whose in sets:
            if cells in allowed:
                continue
            # series_cells is the fewest cells the voltage allows: a pack of more cells
            # that starts the log part-discharged reads fewer, down to its empty voltage
            fuller = [n for n in allowed if n > cells and vmax >= n * CELL_EMPTY_V]
            if fuller and not logged:
                source += "" if "not charged" in source else (f"; {fuller[0]}S at {vmax / fuller[0]:.2f} V a cell at most, "
                           "not charged when the log starts")
                continue
            names = ", ".join(f"{n}S" for n in allowed)
            lower = [n for n in allowed if n > cells]
            why = (f"; {lower[0]}S would be {vmax / lower[0]:.2f} V a cell at most, below "
                   f"{CELL_EMPTY_V:.1f} V" if lower and not logged and np.isfinite(vmax)
                   else "")
            raise Mismatch(f"mismatch: {cells}S pack, {whose} {names} ({source}{why})")
        used.append(f"{cells}S ({source})")
    used += _check_mass(df, aircraft, pack, state)
    return used


def _check_mass(df, aircraft: Aircraft, pack, state) -> list[str]:
    """The mass class of a multirotor log: the mass at which the aircraft's power model
    (:meth:`planner.chain.mission_chain.MissionChain.power_at`, the momentum or
    rotor-losses model of the aircraft file) draws the log's median hover power, against
    the aircraft's heaviest take-off and its empty mass with the pack (module constants)."""
    if not aircraft.is_multirotor or state is None or "power_w" not in df:
        return []
    from planner.identify.aircraft_fit import airborne_mask

    v, climb = state.rotor_velocities()
    p = df["power_w"].to_numpy(float)
    with np.errstate(invalid="ignore"):
        hover = (airborne_mask(df, state, None) & np.isfinite(p) & (p > 0)
                 & (np.abs(v) < HOVER_SPEED_MS) & (np.abs(climb) < HOVER_CLIMB_MS))
    n = int(hover.sum())
    if n < HOVER_MIN_SAMPLES:
        return []
    p_hover = float(np.median(p[hover]))
    rho = float(np.nanmedian(state.air_density[hover]))
    top, _ = aircraft.heaviest_takeoff()
    light = aircraft.empty_mass_kg + (pack.total_mass_kg if pack is not None else 0.0)
    masses = np.geomspace(light / (2 * MASS_CLASS_FACTOR), top * 2 * MASS_CLASS_FACTOR, 200)
    chain = MissionChain(aircraft, None)
    curve = chain.power_at(np.zeros_like(masses), np.zeros_like(masses),
                           np.full_like(masses, rho), masses)
    if not np.all(np.diff(curve) > 0):
        return []
    mass = float(np.interp(p_hover, curve, masses, left=masses[0], right=masses[-1]))
    what = (f"hover power {p_hover:.0f} W, median of {n} samples below "
            f"{HOVER_SPEED_MS:g} m/s: {mass:.2f} kg under the aircraft's power model")
    if mass > MASS_CLASS_FACTOR * top:
        raise Mismatch(f"mismatch: a {mass:.1f} kg class aircraft, this one takes off at "
                       f"{top:.1f} kg at most ({what})")
    if mass < light / MASS_CLASS_FACTOR:
        raise Mismatch(f"mismatch: a {mass:.2f} kg class aircraft, this one weighs "
                       f"{light:.2f} kg with its pack ({what})")
    return [what]


def calibration_samples(df: pd.DataFrame) -> pd.DataFrame:
    """Every k-th sample of a flight record, at most :data:`CALIBRATION_SAMPLES`, with
    the columns of :data:`CALIBRATION_COLUMNS` it has (float32 but the time)."""
    step = max(1, math.ceil(len(df) / CALIBRATION_SAMPLES))
    cols = [c for c in CALIBRATION_COLUMNS if c in df.columns]
    out = df[cols].iloc[::step].reset_index(drop=True)
    for c in cols:
        if c != "time_s" and c != "mode":
            out[c] = out[c].astype("float32")
    if "mode" in out:
        out["mode"] = out["mode"].astype("string")
    return out


def diagnose_log(path: str, *, aircraft: Aircraft | None = None,
                 pack: BatteryPack | None = None) -> str:
    """One line of :func:`planner.identify.diagnose.diagnose` on one log: its findings'
    headlines, or that the calibrated model explains the flight, with what stays unexplained.
    Never raises: a log that cannot be diagnosed gives the reason."""
    from planner.identify.diagnose import diagnose
    from planner.io.logs import read_log

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            df, _ = read_log(path)
            df = record.complete_record(df.assign(experiment=Path(path).name))
            res = diagnose(df, pack, aircraft)
    except PlannerError as exc:
        return f"not diagnosed: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
    except Exception as exc:  # noqa: BLE001 - the report goes on without it
        return f"not diagnosed: internal error ({type(exc).__name__})"
    if res.findings:
        text = "; ".join(f["headline"] for f in res.findings)
    elif res.levels:
        text = "no significant effect beyond the recalibrated model"
    else:
        text = "no level could run: " + "; ".join(res.notes)
    unexplained = res.unexplained()
    return text + (f" (unexplained: {unexplained})" if unexplained else "")


def to_frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """Rows of :data:`COLUMNS` → the typed table."""
    df = pd.DataFrame(rows, columns=list(COLUMNS))
    for col, kind in COLUMNS.items():
        if kind.startswith("datetime"):
            df[col] = pd.to_datetime(df[col], utc=True)
        elif kind == "int64":
            df[col] = pd.to_numeric(df[col]).fillna(0).astype("int64")
        else:
            df[col] = df[col].astype(kind)
    return df
