"""The chain's measured-data entry points are the one code path of replay and the fits.

``replay`` predicts the battery from the measured power
(:meth:`MissionChain.battery_from_power`) and the power from the measured flight state
(:meth:`MissionChain.power_from_state` on :func:`planner.chain.flightstate.from_record`); these
tests hold replay's per-sample predictions to the entry points' own results.
"""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from planner.chain import flightstate
from planner.io import record
from planner.chain.mission_chain import MissionChain
from planner.io.flightdata import load_flight_data
from planner.identify.aircraft_fit import _predict, airborne_samples
from planner.parameters import load_aircraft_and_battery
from planner.identify.replay import replay
from planner.physics.units import AS_PER_MAH

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def flight():
    data, metas = load_flight_data([REPO / "logs/sim_solo_windy.ulg"])
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/solo_survey.yaml")
    return data, metas, aircraft, pack


def test_replay_predictions_are_the_chain_entry_points(flight):
    data, metas, aircraft, pack = flight
    result = replay(data, metas, pack=pack, aircraft=aircraft, payload_kg=0.35)
    chain = MissionChain(aircraft, pack)
    (exp_id, exp), = record.experiments(data)
    exp = exp.reset_index(drop=True)
    series = result.experiments[0].series
    state = flightstate.from_record(exp)
    mass = aircraft.empty_mass_kg + pack.total_mass_kg + 0.35
    np.testing.assert_array_equal(series["predicted_w"], chain.power_from_state(state, mass))
    trace = chain.battery_from_power(exp["time_s"], exp["power_w"],
                                     temperature_c=exp["temperature_c"])
    np.testing.assert_allclose(series["predicted_mah"], trace.charge_as / AS_PER_MAH,
                               rtol=0, atol=1e-12)
    # and they are not trivial: they follow the flight (the simulated log was flown with
    # other "true" parameters than the shipped aircraft file's, logs/README.md)
    air = state.airborne
    assert np.corrcoef(series["predicted_w"][air], state.measured_power_w[air])[0, 1] > 0.7
    assert series["predicted_mah"][-1] == pytest.approx(series["measured_mah"][-1], rel=0.15)


def test_fit_aircraft_predicts_with_the_chain(flight):
    data, _, aircraft, pack = flight
    s = airborne_samples(data)
    mass = np.full(len(s.time_s), 1.85)
    want = MissionChain(aircraft, None).power_at(s.airspeed, s.climb_rate, s.air_density,
                                                 mass)
    np.testing.assert_array_equal(_predict(aircraft, s, mass), want)


def test_power_from_state_draws_only_the_system_load_on_the_ground(flight):
    _, _, aircraft, _ = flight
    n = 6
    state = flightstate.FlightState(
        time_s=np.arange(n, dtype=float), airspeed_ms=np.full(n, 5.0),
        climb_rate_ms=np.zeros(n), air_density=np.full(n, 1.2),
        phase=np.array(["ground"] * 3 + ["cruise"] * 3, dtype=object),
        measured_power_w=np.full(n, np.nan), airspeed_source="", density_source="")
    p = MissionChain(aircraft, None).power_from_state(state, 1.85)
    assert np.all(p[:3] == aircraft.system_power_w)
    assert np.all(p[3:] > 10 * aircraft.system_power_w)


def test_flight_state_takes_the_airspeed_from_the_logged_wind():
    """Ground velocity 10 m/s north in a 4 m/s wind towards the north: 6 m/s through the
    air (the wind triangle of planner.physics.wind)."""
    exp = pd.DataFrame({"time_s": np.arange(20.0), "power_w": 200.0,
                        "groundspeed_ms": 10.0, "course_deg": 0.0, "climb_rate_ms": 0.0,
                        "wind_n_ms": 4.0, "wind_e_ms": 0.0})
    state = flightstate.from_record(exp)
    assert "wind" in state.airspeed_source
    np.testing.assert_allclose(state.airspeed_ms, 6.0)
    exp["pressure_pa"], exp["ambient_temperature_c"] = 90000.0, 5.0
    rho = flightstate.from_record(exp).air_density
    np.testing.assert_allclose(rho, 90000.0 / (287.05287 * 278.15), rtol=1e-9)


def test_a_logged_pressure_outside_the_atmosphere_is_read_as_missing():
    """Found by the fuzz campaign: a damaged ULog logged -9.3e18 Pa and replay stopped with
    "pressure_pa must be > 0" naming no file. Out-of-model pressures and temperatures are
    missing values; the density comes from the others."""
    import numpy as np
    import pandas as pd

    from planner.chain import flightstate

    n = 50
    df = pd.DataFrame({"experiment": "x", "time_s": np.arange(n, dtype=float),
                       "power_w": np.full(n, 200.0), "groundspeed_ms": np.full(n, 5.0),
                       "climb_rate_ms": np.zeros(n), "pressure_pa": np.full(n, 95000.0),
                       "ambient_temperature_c": np.full(n, 15.0)})
    df.loc[10, "pressure_pa"] = -9.3e18
    df.loc[20, "ambient_temperature_c"] = -500.0
    state = flightstate.from_record(df)
    assert np.all(np.isfinite(state.air_density))
    assert np.allclose(state.air_density, state.air_density[0], rtol=1e-9)


def test_a_multirotor_flies_its_rotor_disks_axial_speed_where_the_record_has_it(flight):
    """With ``axial_speed_ms`` (the velocity along the thrust axis, a tilted disk's climb),
    a multirotor's power is the model's at the disk's in-plane and axial speed, the speed
    being the same in both frames; fit-aircraft's samples carry the same; without the
    channel nothing changes. (Momentum theory of a tilted disk: Leishman 2006 ch. 2.)"""
    data, _, aircraft, pack = flight
    (_, exp), = record.experiments(data)
    exp = exp.reset_index(drop=True)
    plain = flightstate.from_record(exp)
    assert plain.axial_speed_ms is None
    v, climb = plain.rotor_velocities()
    assert v is plain.airspeed_ms and climb is plain.climb_rate_ms

    # a disk tilted 10° forward into the flight path: V sin(10°) through it
    tilted = exp.assign(axial_speed_ms=np.sin(np.radians(10.0)) * plain.airspeed_ms
                        + plain.climb_rate_ms)
    state = flightstate.from_record(tilted)
    inplane, axial = state.rotor_velocities()
    assert_speed = np.hypot(plain.airspeed_ms, plain.climb_rate_ms)
    np.testing.assert_allclose(np.hypot(inplane, axial), assert_speed, atol=1e-9)
    chain = MissionChain(aircraft, pack)
    mass = aircraft.empty_mass_kg + pack.total_mass_kg
    airborne = state.phase != "ground"
    got = chain.power_from_state(state, mass)
    want = chain.power_at(inplane, axial, state.air_density, mass,
                          on_ground=state.phase == "ground")
    np.testing.assert_allclose(got, want)
    before = chain.power_from_state(plain, mass)
    assert np.mean(got[airborne]) > np.mean(before[airborne]) + 1.0   # the drag power
    s = airborne_samples(tilted)
    s0 = airborne_samples(exp)
    assert len(s.climb_rate) == len(s0.climb_rate)
    assert not np.allclose(s.climb_rate, s0.climb_rate)
