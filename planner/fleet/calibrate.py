"""The aircraft model calibrated on a whole fleet, scored on flights the fit never saw.

Each worker returns, beside its flight's row, the flight record thinned to at most
:data:`planner.fleet.summary.CALIBRATION_SAMPLES` samples; the fleet keeps them in
``DIR/samples.parquet`` (keyed by the log's content hash, so a rerun adds only the new
flights). For each aircraft of the run:

* **flights** — the aircraft's ``ok`` flights with airborne samples
  (:func:`planner.identify.aircraft_fit.airborne_samples`) among their calibration samples;
  a flight without (a ground test, a hop of a few seconds: the fleet's ``not airborne``
  rows, or a flight whose thinned samples miss its few airborne ones) is left out before
  the split, so that it is never a held-out flight the fit cannot score;
* **split** — a flight is held out when the first 32 bits of its content hash are
  divisible by :data:`HOLDOUT_EVERY` (about one flight in five, the same flights on every
  rerun and whatever order the logs come in); with no such flight, the flight of the
  smallest hash is held out;
* **fit** — :func:`planner.identify.aircraft_fit.fit_aircraft` on the other flights (its
  parameters: η, drag area and constant load of a multirotor; C_D0, K, η and the constant
  load of a fixed wing; the ``rotor_losses`` terms for that model), at the aircraft's
  all-up mass with its pack;
* **score** — the power RMSE and the energy error of the aircraft file as given and of
  the calibrated aircraft on the held-out flights' airborne samples, and the mean
  absolute per-flight energy error of the held-out flights before and after.

The calibrated aircraft is written as ``DIR/aircraft/<key>.yaml``, its source naming the
flights and the held-out score.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from planner.io import files
from planner.io import record
from planner.errors import PlannerError
from planner.identify.aircraft_fit import airborne_samples, fit_aircraft
from planner.fleet.summary import safe_stem

#: One flight in about this many is held out (by content hash).
HOLDOUT_EVERY = 5
#: Fewest flights (training and held out) to calibrate an aircraft.
MIN_FLIGHTS = 3


def held_out(sha256: str) -> bool:
    """A flight held out of the calibration (module notes)."""
    return int(sha256[:8], 16) % HOLDOUT_EVERY == 0


@dataclass
class AircraftCalibration:
    """One aircraft calibrated on the fleet.

    Attributes
    ----------
    key : str
        The aircraft (the table's ``aircraft``).
    train_flights, validation_flights : int
    parameters, stderr, start : dict
        Fitted values, their standard errors, the file's values (units of the aircraft
        file's keys).
    poorly_determined, at_bound : list of str
    validation : dict
        ``before`` / ``after``: ``rmse_w``, ``bias_w``, ``energy_error_pct`` of the held-out
        airborne samples.
    flight_error_pct : dict
        ``before`` / ``after``: mean absolute energy error of the held-out flights. [%]
    aircraft : Aircraft or None
    file : Path or None
        ``DIR/aircraft/<key>.yaml``.
    note : str
        Why there is no calibration (empty when there is one).
    """

    key: str
    train_flights: int = 0
    validation_flights: int = 0
    parameters: dict = field(default_factory=dict)
    stderr: dict = field(default_factory=dict)
    start: dict = field(default_factory=dict)
    poorly_determined: list = field(default_factory=list)
    at_bound: list = field(default_factory=list)
    validation: dict = field(default_factory=dict)
    flight_error_pct: dict = field(default_factory=dict)
    aircraft: object = None
    file: Path | None = None
    note: str = ""


def calibrate_aircraft(key: str, samples: pd.DataFrame, table: pd.DataFrame, aircraft,
                       pack) -> AircraftCalibration:
    """Calibrate ``aircraft`` (key ``key``) on its flights' samples (module notes)."""
    out = AircraftCalibration(key)
    ok = table[(table["status"] == "ok") & (table["aircraft"] == key)]
    shas = sorted(set(ok["sha256"]) & set(samples["sha256"]))
    data = samples[samples["sha256"].isin(shas)].rename(columns={"sha256": "experiment"})
    data = data.sort_values(["experiment", "time_s"], kind="stable").reset_index(drop=True)
    for c in data.columns:
        if data[c].dtype == np.float32:
            data[c] = data[c].astype(float)
    flying = _airborne_flights(data)
    grounded = len(shas) - len(flying)
    shas = [h for h in shas if h in flying]
    if len(shas) < MIN_FLIGHTS:
        out.note = (f"{len(shas)} flight(s) with airborne flight state: too few to calibrate "
                    f"(expected at least {MIN_FLIGHTS})"
                    + (f"; {grounded} without airborne samples left out" if grounded else ""))
        return out
    val = [h for h in shas if held_out(h)] or shas[:1]
    trn = [h for h in shas if h not in set(val)]
    data = data[data["experiment"].isin(shas)].reset_index(drop=True)
    mass = aircraft.empty_mass_kg + (pack.total_mass_kg if pack is not None else 0.0)
    own = record.experiment_payloads(data)      # each flight's payload where logged
    if own is not None:
        mass = {k: mass + (v if np.isfinite(v) else 0.0) for k, v in own.items()}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = fit_aircraft(data, aircraft, mass_kg=mass, train=trn, validate=val)
    except PlannerError as exc:
        out.note = f"calibration failed: {str(exc).splitlines()[0]}"
        return out
    out.train_flights, out.validation_flights = len(trn), len(val)
    out.parameters, out.stderr = res["parameters"], res["stderr"]
    # the fit starts a parameter at 0 a hair inside its bound: the file says 0
    out.start = {k: 0.0 if abs(v) < 1e-6 else v for k, v in res.get("start", {}).items()}
    out.poorly_determined = list(res.get("poorly_determined", []))
    out.at_bound = list(res.get("at_bound", []))
    out.validation = res.get("validation", {})
    per = res.get("per_experiment_energy_error_pct", {})
    out.flight_error_pct = {k: float(np.mean(np.abs(list(v.values())))) if v else math.nan
                            for k, v in per.items()}
    out.aircraft = res["aircraft"]
    if grounded:
        out.note = f"{grounded} flight(s) without airborne samples left out"
    return out


def _airborne_flights(data: pd.DataFrame) -> set[str]:
    """The flights (``experiment``) of ``data`` with at least one airborne sample."""
    if data.empty:
        return set()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = airborne_samples(data)
    except PlannerError:
        return set()
    return set(map(str, s.experiment))


def write_aircraft_file(cal: AircraftCalibration, folder: Path) -> Path | None:
    """``folder/<key>.yaml``: the calibrated aircraft, its source naming the fleet fit."""
    import yaml

    if cal.aircraft is None:
        return None
    folder.mkdir(exist_ok=True)
    path = folder / f"{safe_stem(cal.key, 'aircraft')}.yaml"
    mapping = cal.aircraft.to_mapping(folder=folder)
    fitted = ", ".join(f"{k} {v:.4g} ± {cal.stderr.get(k, math.nan):.2g}"
                       for k, v in cal.parameters.items())
    before = cal.validation.get("before", {}).get("energy_error_pct", math.nan)
    after = cal.validation.get("after", {}).get("energy_error_pct", math.nan)
    mapping["source"] = (f"endurance fleet: calibrated on {cal.train_flights} flights "
                         f"({fitted}); energy error on {cal.validation_flights} held-out "
                         f"flights {before:+.1f} % as given, {after:+.1f} % calibrated")
    files.write_text(path, yaml.safe_dump(mapping, sort_keys=False, allow_unicode=True),
                     "fleet output")
    cal.file = path
    return path
