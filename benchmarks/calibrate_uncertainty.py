"""Calibration of the predicted energy band on real flights (DJI Matrice 100).

The question: does the P5–P95 band the planner gives for a flight's energy contain what
was measured in 80–95 % of flights it has not seen? Too narrow (over-confident) and too
wide (useless) are both failures.

Data: the CMU package-delivery flights of a DJI Matrice 100 (Rodrigues et al., Scientific
Data 8, 155 (2021), DOI 10.1184/R1/12683453, CC BY 4.0), ``../shared/data/energy`` beside
the repository, read through ``planner/io/logs/maps/dji_m100.yaml``; the cruise flights
(route R of ``m100_flight_summary_derived.csv``).

Procedure:

1. Every other cruise flight trains ``fit_aircraft`` (efficiency, drag area, system power,
   with standard errors), the others are held out.
2. For each held-out flight the energy of its airborne samples is predicted from its
   measured flight state through the chain's power model
   (:meth:`planner.chain.mission_chain.MissionChain.power_at`), drawing
   * the fitted parameters from normals with their standard errors (``DRAWS`` sets), and
   * the payload from the data set's design, 0, 0.25 or 0.5 kg with equal weight (the
     payload of each flight is not in this copy of the data).
3. Coverage = share of held-out flights whose measured energy lies within P5–P95.

A second band adds a per-flight model discrepancy: the spread of the per-flight energy
errors of the fitted model on the *training* flights (normal, relative), which the
parameters' standard errors do not contain.

Run: ``python benchmarks/calibrate_uncertainty.py``
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from planner.chain.mission_chain import MissionChain  # noqa: E402
from planner.io.flightdata import load_flight_data  # noqa: E402
from planner.identify.aircraft_fit import airborne_samples, fit_aircraft, with_params  # noqa: E402
from planner.parameters import load_aircraft_and_battery  # noqa: E402

ENERGY = REPO.parent / "shared" / "data" / "energy"
PAYLOADS_KG = (0.0, 0.25, 0.5)      # the data set's design (Rodrigues et al. 2021)
DRAWS = 40                          # parameter sets
SITE_ALTITUDE_M = 300.0             # Pittsburgh test site, about 300 m AMSL


def predictive_energy(aircraft, samples, fit, rng, discrepancy_sd=0.0):
    """Predicted airborne energy of every flight of ``samples``: (flights, draws) [Wh]."""
    flights = list(dict.fromkeys(samples.experiment))
    index = np.searchsorted(np.array(flights, dtype=object), samples.experiment,
                            sorter=np.argsort(np.array(flights, dtype=object)))
    order = np.argsort(np.array(flights, dtype=object))
    flight_of = order[index]
    names = list(fit["parameters"])
    mean = np.array([fit["parameters"][k] for k in names])
    sd = np.array([fit["stderr"][k] for k in names])
    sd = np.where(np.isfinite(sd), sd, 0.0)
    mass0 = aircraft.empty_mass_kg + 0.6
    out = []
    for _ in range(DRAWS):
        theta = mean + sd * rng.standard_normal(len(names))
        ac = with_params(aircraft, dict(zip(names, theta)))
        chain = MissionChain(ac, None)
        for payload in PAYLOADS_KG:
            p = chain.power_at(samples.airspeed, samples.climb_rate, samples.air_density,
                               mass0 + payload)
            e = np.bincount(flight_of, weights=p * samples.dt, minlength=len(flights))
            out.append(e / 3600.0)
    e = np.array(out).T                                  # flights × draws
    if discrepancy_sd > 0:
        e = e * (1.0 + discrepancy_sd * rng.standard_normal(e.shape))
    return flights, e


def measured_energy(samples):
    flights = list(dict.fromkeys(samples.experiment))
    return np.array([np.sum((samples.measured_w * samples.dt)[samples.experiment == f])
                     for f in flights]) / 3600.0


def _subset(samples, mask):
    """The samples where ``mask`` is true (an optional channel that is None stays None)."""
    return type(samples)(*(None if (v := getattr(samples, f)) is None else v[mask]
                           for f in samples.__dataclass_fields__))


def main() -> None:
    if not ENERGY.is_dir():
        print(f"no data at {ENERGY}: the calibration needs ../shared/data/energy")
        return
    t0 = time.perf_counter()
    summary = pd.read_csv(ENERGY / "m100_flight_summary_derived.csv")
    cruise = [str(f) for f in summary.loc[summary.route_inferred == "R", "flight"]]
    data, _ = load_flight_data(sorted(ENERGY.glob("m100_flights_part*.csv.gz")),
                               column_map="dji_m100")
    data = data[data.experiment.astype(str).isin(cruise)].copy()
    aircraft, _ = load_aircraft_and_battery(REPO / "aircraft/dji_m100.yaml")
    flights = list(dict.fromkeys(data.experiment.astype(str)))
    train, held = flights[0::2], flights[1::2]
    fit = fit_aircraft(data, aircraft, mass_kg=aircraft.empty_mass_kg + 0.6 + 0.25,
                       train=train, validate=held, site_altitude_m=SITE_ALTITUDE_M)
    fitted = fit["aircraft"]
    s_all = airborne_samples(data, SITE_ALTITUDE_M)
    s_held, s_train = (_subset(s_all, np.isin(s_all.experiment, ids)) for ids in (held, train))
    rng = np.random.default_rng(0)

    # per-flight discrepancy of the fitted model on the training flights (mid payload)
    p_tr = MissionChain(fitted, None).power_at(s_train.airspeed, s_train.climb_rate,
                                               s_train.air_density,
                                               fitted.empty_mass_kg + 0.6 + 0.25)
    e_tr = np.array([np.sum((p_tr * s_train.dt)[s_train.experiment == f])
                     for f in dict.fromkeys(s_train.experiment)]) / 3600.0
    rel = e_tr / measured_energy(s_train) - 1.0
    disc = float(np.std(rel))

    fitted_text = ", ".join(f"{k} {v:.4g} ± {fit['stderr'][k]:.2g}"
                            for k, v in fit["parameters"].items())
    print(f"{len(flights)} cruise flights: {len(train)} train fit-aircraft, {len(held)} "
          f"held out; fitted {fitted_text}")
    e_meas = measured_energy(s_held)
    for label, d in (("parameters (fit standard errors) + payload 0/0.25/0.5 kg", 0.0),
                     (f"… + per-flight discrepancy ±{100 * disc:.1f} % (training flights)",
                      disc)):
        names, e = predictive_energy(fitted, s_held, fit, rng, d)
        p5, p50, p95 = np.percentile(e, [5, 50, 95], axis=1)
        inside = (e_meas >= p5) & (e_meas <= p95)
        width = np.median((p95 - p5) / p50)
        verdict = ("calibrated" if 0.80 <= inside.mean() <= 0.95 else
                   "too narrow" if inside.mean() < 0.80 else "too wide")
        print(f"{label}:\n  P5–P95 contains the measured energy in {inside.sum()}/{len(inside)}"
              f" held-out flights = {100 * inside.mean():.1f} % (target 80–95 %: {verdict}); "
              f"median band width {100 * width:.1f} % of P50; median error of P50 "
              f"{100 * np.median(p50 / e_meas - 1):+.1f} %")
    print(f"({time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
