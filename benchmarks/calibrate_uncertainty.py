r"""Calibration of the predicted energy band on real flights (DJI Matrice 100).

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
   Each flight's all-up mass is the aircraft's empty mass, the 0.6 kg TB47D pack and the
   flight's own payload (0–0.75 kg), which the data set's per-flight table
   ``m100_parameters.csv`` gives (read through the column map).
2. For each held-out flight the energy of its airborne samples is predicted from its
   measured flight state and its own mass through the chain's power model
   (:meth:`planner.chain.mission_chain.MissionChain.power_at`), drawing the fitted
   parameters from normals with their standard errors (``DRAWS`` sets).
3. Coverage = share of held-out flights whose measured energy lies within P5–P95.

A second band adds the power model's own error as ``check --uncertainty`` draws it
(:mod:`planner.chain.uncertainty`): each flight's energy times :math:`e^{\sigma z}`, σ the
``energy_error_sd`` that ``fit-aircraft`` writes (the RMS per-flight energy error on its
training flights), which the parameters' standard errors do not contain. A third band
draws, in place of each flight's own payload, the payload of a training flight taken at
random: the band of a user who does not know what the flight carried.

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
from planner.identify.aircraft_fit import (  # noqa: E402
    airborne_samples,
    fit_aircraft,
    sample_masses,
    with_params,
)
from planner.io.flightdata import load_flight_data  # noqa: E402
from planner.io.record import experiment_payloads  # noqa: E402
from planner.parameters import load_aircraft_and_battery  # noqa: E402

ENERGY = REPO.parent / "shared" / "data" / "energy"
DRAWS = 40                             # parameter sets
SITE_ALTITUDE_M = 300.0                # Pittsburgh test site, about 300 m AMSL


def _flight_index(samples):
    """The flights of ``samples`` in their order and each sample's flight number."""
    flights = list(dict.fromkeys(samples.experiment))
    number = {f: i for i, f in enumerate(flights)}
    return flights, np.array([number[f] for f in samples.experiment])


def predictive_energy(aircraft, samples, fit, mass_of, rng, discrepancy_sd=0.0,
                      payloads=None, bare_kg=0.0):
    """Predicted airborne energy of every flight of ``samples``: (flights, draws) [Wh].

    ``mass_of``: all-up mass [kg] of each flight (experiment id → kg). With ``payloads``,
    each draw gives every flight a payload [kg] drawn from those, on ``bare_kg`` (the
    empty aircraft and the pack), in place of its own."""
    flights, flight_of = _flight_index(samples)
    names = list(fit["parameters"])
    mean = np.array([fit["parameters"][k] for k in names])
    sd = np.array([fit["stderr"][k] for k in names])
    sd = np.where(np.isfinite(sd), sd, 0.0)
    own = sample_masses(samples, mass_of)
    out = []
    for _ in range(DRAWS):
        theta = mean + sd * rng.standard_normal(len(names))
        chain = MissionChain(with_params(aircraft, dict(zip(names, theta))), None)
        mass = own if payloads is None else (
            bare_kg + rng.choice(payloads, len(flights))[flight_of])
        p = chain.power_at(samples.airspeed, samples.climb_rate, samples.air_density, mass,
                           disk_frame=samples.disk_frame)
        e = np.bincount(flight_of, weights=p * samples.dt, minlength=len(flights))
        out.append(e / 3600.0)
    e = np.array(out).T                                  # flights × draws
    if discrepancy_sd > 0:      # as check --uncertainty draws it (planner.chain.uncertainty)
        e = e * np.exp(discrepancy_sd * rng.standard_normal(e.shape))
    return flights, e


def measured_energy(samples):
    flights, flight_of = _flight_index(samples)
    return np.bincount(flight_of, weights=samples.measured_w * samples.dt,
                       minlength=len(flights)) / 3600.0


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
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/dji_m100.yaml")
    bare = aircraft.empty_mass_kg + pack.total_mass_kg
    payload = experiment_payloads(data)
    mass_of = {f: bare + payload[f] for f in payload}
    flights = list(dict.fromkeys(data.experiment.astype(str)))
    train, held = flights[0::2], flights[1::2]
    fit = fit_aircraft(data, aircraft, mass_kg=mass_of, train=train, validate=held,
                       site_altitude_m=SITE_ALTITUDE_M)
    fitted = fit["aircraft"]
    s_all = airborne_samples(data, SITE_ALTITUDE_M)
    s_held = s_all.subset(np.isin(s_all.experiment, held))
    rng = np.random.default_rng(0)

    # the model error check --uncertainty draws: fit-aircraft's energy_error_sd
    disc = fit["energy_error_sd"]

    fitted_text = ", ".join(f"{k} {v:.4g} ± {fit['stderr'][k]:.2g}"
                            for k, v in fit["parameters"].items())
    print(f"{len(flights)} cruise flights, payload 0–0.75 kg each from the data set's "
          f"per-flight table: {len(train)} train fit-aircraft, {len(held)} held out; "
          f"fitted {fitted_text}")
    e_meas = measured_energy(s_held)
    carried = np.array([payload[f] for f in train])
    for label, d, alt in (
            ("parameters (fit standard errors), each flight's own payload", 0.0, None),
            ((f"… + the model error check --uncertainty draws (fit-aircraft's "
              f"energy_error_sd {100 * disc:.1f} %, RMS per-flight error on the training "
              "flights)"), disc, None),
            (("… with each flight's payload unknown (drawn from the training flights' "
              f"{', '.join(f'{m:g}' for m in np.unique(carried))} kg)"), disc, carried)):
        _, e = predictive_energy(fitted, s_held, fit, mass_of, rng, d, alt, bare)
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
