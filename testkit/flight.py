"""Simulated flights: a mission flown by our own models, as a flight record.

Used for the example logs the repository ships (``logs/``, all marked
simulated), for tests with known true parameters, and for demonstrations.
The aircraft's power model gives the electric power of every leg; a seeded
turbulence term (an AR(1) process, 3 % by default) makes it look measured;
the equivalent-circuit pack model (:mod:`planner.physics.battery.circuit`) turns the
power into terminal voltage and current; the logger's consumed charge is the
integral of that current. Sensor noise is added to voltage and current.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.signal import lfilter

from planner.chain import kinematics as prof
from planner.physics.battery.circuit import simulate
from planner.physics.mission import Environment, Mission
from planner.parameters import Aircraft, BatteryPack
from planner.physics.wind import wind_vector


def simulate_flight(mission: Mission, aircraft: Aircraft, pack: BatteryPack, *,
                    environment: Environment | None = None, rate_hz: float = 10.0,
                    turbulence: float = 0.03, voltage_noise_v: float = 0.02,
                    current_noise_a: float = 0.05, temperature_c: float = 25.0,
                    seed: int = 0, experiment: str = "simulated") -> pd.DataFrame:
    """Fly ``mission`` with the models and return a flight record (DESIGN §4).

    Parameters
    ----------
    rate_hz : float
        Sample rate. [Hz]
    turbulence : float
        Standard deviation of the relative power fluctuation (AR(1), 2 s
        correlation time). [unitless]
    voltage_noise_v, current_noise_a : float
        White sensor noise. [V], [A]
    temperature_c : float
        Pack and air temperature. [°C]

    Returns
    -------
    DataFrame
        Columns ``experiment, time_s, voltage_v, current_a, power_w,
        consumed_mah, temperature_c, ambient_temperature_c, pressure_pa,
        altitude_m, climb_rate_ms, groundspeed_ms, course_deg, airspeed_ms,
        wind_n_ms, wind_e_ms, mode``.
    """
    env = environment or mission.environment
    rng = np.random.default_rng(seed)
    table = prof.leg_table(mission, aircraft, env, temperature_c=temperature_c)
    mass = aircraft.empty_mass_kg + pack.total_mass_kg + mission.payload_kg
    power_leg = np.asarray(prof.leg_power(table, aircraft, mass), float)
    total = float(table.end_time_s[-1]) if len(table) else 0.0
    t = np.arange(0.0, total, 1.0 / rate_hz)
    leg = np.clip(np.searchsorted(table.end_time_s, t, side="right"), 0, len(table) - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(table.duration_s[leg] > 0,
                        (t - table.start_time_s[leg]) / table.duration_s[leg], 0.0)
    frac = np.clip(frac, 0.0, 1.0)
    pos = table.start_en_m[leg] + frac[:, None] * (table.end_en_m[leg] - table.start_en_m[leg])
    alt = table.start_alt_m[leg] + frac * (table.end_alt_m[leg] - table.start_alt_m[leg])

    # turbulence: AR(1) with a 2 s correlation time, unit variance
    a = np.exp(-1.0 / (2.0 * rate_hz))
    gust = lfilter([np.sqrt(1 - a * a)], [1.0, -a], rng.standard_normal(t.size))
    power = power_leg[leg] * (1.0 + turbulence * gust)

    params = pack.circuit_parameters()
    battery = simulate(params, t, power_w=power, temperature_c=temperature_c)
    current = battery.current_a + current_noise_a * rng.standard_normal(t.size)
    voltage = battery.voltage_v + voltage_noise_v * rng.standard_normal(t.size)
    amsl = env.site_altitude_m + alt
    w_e, w_n = wind_vector(env.wind_speed_ms, env.wind_from_deg)
    from planner.physics import atmosphere
    pressure = atmosphere.pressure(amsl) if env.pressure_pa is None else (
        env.pressure_pa * atmosphere.pressure(amsl) / atmosphere.pressure(env.site_altitude_m))
    return pd.DataFrame({
        "experiment": experiment, "time_s": t, "voltage_v": voltage, "current_a": current,
        "power_w": voltage * current, "consumed_mah": battery.charge_as / 3.6,
        "temperature_c": battery.temperature_c,
        "ambient_temperature_c": temperature_c - atmosphere.LAPSE_RATE * alt,
        "pressure_pa": pressure, "altitude_m": alt,
        "climb_rate_ms": table.climb_rate_ms[leg], "groundspeed_ms": table.groundspeed_ms[leg],
        "course_deg": table.course_deg[leg], "airspeed_ms": table.airspeed_ms[leg],
        "wind_n_ms": np.full(t.size, w_n), "wind_e_ms": np.full(t.size, w_e),
        "east_m": pos[:, 0], "north_m": pos[:, 1], "mode": "AUTO",
    })
