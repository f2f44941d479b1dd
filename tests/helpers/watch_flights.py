"""Simulated flights as telemetry events, for the tests of the in-flight estimator.

The flights are made by the project's own models (:func:`testkit.flight.simulate_flight`):
they check that the estimator recovers what the simulation put in, never validate a model.
"""

from __future__ import annotations

from dataclasses import replace

from planner.io.mavlink_stream import RecordSource
from planner.io.record import write_record
from planner.parameters import load_aircraft_and_battery
from planner.physics.mission import Environment, Leg, Mission
from testkit.flight import simulate_flight


def hover_mission(hover_s: float, alt_m: float = 20.0, payload_kg: float = 0.0) -> Mission:
    """Climb to ``alt_m``, hover ``hover_s``, descend: at home."""
    legs = [Leg("climb", start_alt_m=0.0, end_alt_m=alt_m, origin="climb"),
            Leg("hover", start_alt_m=alt_m, end_alt_m=alt_m, duration_s=hover_s,
                origin="hover"),
            Leg("descend", start_alt_m=alt_m, end_alt_m=0.0, origin="land")]
    return Mission("hover", legs, Environment(), payload_kg=payload_kg)


def solo(capacity_mah: float | None = None):
    """The Solo aircraft and its pack (optionally with another true capacity)."""
    aircraft, pack = load_aircraft_and_battery("aircraft/solo_survey.yaml")
    if capacity_mah is not None:
        pack = replace(pack, capacity_mah=capacity_mah, model=None)
    return aircraft, pack


def flight_events(tmp_path, mission, aircraft, pack, *, rate_hz=2.0, seed=0,
                  name="flight.csv", **kwargs):
    """(record, events): the simulated flight and its record played as telemetry."""
    rec = simulate_flight(mission, aircraft, pack, rate_hz=rate_hz, seed=seed, **kwargs)
    path = write_record(rec, tmp_path / name)
    return rec, list(RecordSource(path, rate=0).events())
