"""Synthetic unsteady fixed-wing flights for the energy-rate fit's tests.

Test-only code. The physics is stated anew here, not taken from the planner: the
aircraft flies a prescribed airspeed history with a pulsed throttle (thrust power on or
off), and its height follows from the energy balance

    T V = D V + m g dh/dt + m V dV/dt,   D = ½ ρ V² S C_D(C_L),   C_L = m g / (½ ρ V² S)

integrated in time (so the motor-off glides sink as physics says). The battery gives
``T V / η + P_S``; the logger records voltage and current, the airspeed with noise, and
the static pressure of the height (ISA, 15 °C) with noise.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

G = 9.80665
R_AIR = 287.05287


def isa_pressure(h):
    return 101325.0 * (1.0 - 0.0065 * np.asarray(h, float) / 288.15) ** 5.25588


def unsteady_flight(*, cd0=0.035, k=0.03, cl_min=0.0, efficiency=0.55, system_power=8.0,
                    mass=9.4, wing_area=1.5, battery_fraction=1.0, seed=0, duration=300.0,
                    rate_hz=5.0, airspeed_noise=0.15, pressure_noise=1.0,
                    experiment="synthetic") -> pd.DataFrame:
    """One flight: 30 s on the water, the airborne part, 30 s on the water again.

    ``cl_min`` shifts the polar's least drag to a positive lift:
    C_D = cd0 + k (C_L − cl_min)². ``battery_fraction`` < 1 logs only that share of the
    electric power (a source the battery sensor does not see).
    """
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    t = np.arange(0.0, duration + 60.0, dt)
    air = (t >= 30.0) & (t <= 30.0 + duration)
    tau = t - 30.0
    # airspeed: cruise with slow speed changes and a fast pass, 2 m/s on the water
    v = 11.0 + 1.8 * np.sin(2 * np.pi * tau / 70.0) + 1.2 * np.sin(2 * np.pi * tau / 23.0)
    v += 5.0 * np.exp(-0.5 * ((tau - 180.0) / 12.0) ** 2)
    ramp = np.clip(np.minimum(tau, duration - tau) / 10.0, 0.0, 1.0)
    v = np.where(air, 2.0 + (v - 2.0) * ramp, 2.0)
    vdot = np.gradient(v, dt)
    # throttle: motor-off glides of 12-20 s every ~60 s, and a climbing pulse
    on = np.ones(t.size, bool)
    for start in (45.0, 105.0, 160.0, 230.0):
        on &= ~((tau >= start) & (tau < start + 12.0 + (start % 9)))
    rho = isa_pressure(0.0) / (R_AIR * 288.15)
    q = 0.5 * rho * v * v
    cl = mass * G / (q * wing_area)
    drag_power = (cd0 + k * (cl - cl_min) ** 2) * q * wing_area * v
    # motor on: thrust for drag, acceleration and a gentle height profile
    hdot_on = 0.9 * np.sin(2 * np.pi * tau / 50.0)
    thrust_power = np.where(on & air, np.maximum(drag_power + mass * v * vdot
                                                 + mass * G * hdot_on, 0.0), 0.0)
    hdot = np.where(air, (thrust_power - drag_power - mass * v * vdot) / (mass * G), 0.0)
    h = np.concatenate([[0.0], np.cumsum(0.5 * (hdot[1:] + hdot[:-1]) * dt)])
    h = h - h.min()
    power = (thrust_power / efficiency + system_power) * battery_fraction
    voltage = 15.5 - 0.06 * power / 15.5 + rng.normal(0, 0.01, t.size)
    current = power / voltage
    return pd.DataFrame({
        "experiment": experiment, "time_s": t, "voltage_v": voltage, "current_a": current,
        "pressure_pa": isa_pressure(h) + rng.normal(0, pressure_noise, t.size),
        "ambient_temperature_c": 15.0,
        "airspeed_ms": v + rng.normal(0, airspeed_noise, t.size),
        "altitude_m": h})
