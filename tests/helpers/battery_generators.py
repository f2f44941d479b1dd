"""Synthetic bench discharges from the integral model with known parameters ([UAV23]
eq. 14), for the battery-fit tests: the fit must find the parameters they were made with."""

import numpy as np
import pandas as pd

from planner.identify import protocols as design
from planner.physics.battery import integral

# The seed paper's constant-power model m_const (Table 5, as in test_integral.py).
TRUE = {"delta": 23.6482, "epsilon": -1.0209, "beta": 0.9648}


def synthetic_discharge(name, time_s, power_w, model=TRUE, noise_a=0.05, rng=None,
                        rest_voltage_v=15.6):
    """A bench discharge that follows the integral model exactly, plus current noise.

    The true current is dĈ/dt = (1/β) S^(1/β − 1) dS/dt with S = Ĉ^β (the charge
    of :func:`integral.charge`); white noise of ``noise_a`` is added to the
    measured current. ``voltage_v`` = P / I_true (so V·I is the power), and
    ``power_w`` is given as well. At t = 0 the model's current is 0 (β < 1);
    the first sample takes the second one's value, as a real load would.
    """
    rng = rng if rng is not None else np.random.default_rng(0)
    t = np.asarray(time_s, float)
    p = np.asarray(power_w, float)
    c = integral.charge(t, p, **model)
    s = np.asarray(integral.stress_from_charge(c, model["beta"]))
    rate = np.asarray(integral.stress_rate(p, model["delta"], model["epsilon"]))
    b = model["beta"]
    current = (1 / b) * np.power(np.maximum(s, 1e-12), 1 / b - 1) * rate
    current[0] = current[1] if p[0] > 0 else 0.0
    voltage = np.where(current > 0, p / np.where(current > 0, current, 1.0), rest_voltage_v)
    return pd.DataFrame({"experiment": name, "time_s": t, "voltage_v": voltage,
                         "current_a": current + rng.normal(0.0, noise_a, t.size),
                         "power_w": p})


def constant(name, power_w, duration_s, dt=1.0, **kw):
    t = np.arange(0.0, duration_s + dt / 2, dt)
    return synthetic_discharge(name, t, np.full_like(t, power_w), **kw)


def scheduled(name, schedule, dt=1.0, **kw):
    end = float(schedule["start_s"].iloc[-1] + schedule["duration_s"].iloc[-1])
    t = np.arange(0.0, end - dt / 2, dt)
    return synthetic_discharge(name, t, design.sample_schedule(schedule, t), **kw)


def bench_set(seed, noise_a=0.05):
    """Four constant-power discharges (≈8 Ah each) and two variable ones."""
    rng = np.random.default_rng(seed)
    two = design.two_step(50, 125, 1.0, 8000 * 3.6, **TRUE).schedule()
    frames = [constant("p050", 50, 8000, rng=rng, noise_a=noise_a),
              constant("p075", 75, 5400, rng=rng, noise_a=noise_a),
              constant("p100", 100, 4000, rng=rng, noise_a=noise_a),
              constant("p125", 125, 3200, rng=rng, noise_a=noise_a),
              scheduled("aprbs", design.aprbs([50, 75, 100, 125], (30, 300), 4000, seed),
                        rng=rng, noise_a=noise_a),
              scheduled("two_step", two, rng=rng, noise_a=noise_a)]
    return pd.concat(frames, ignore_index=True)
