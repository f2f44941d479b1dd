r"""Design of discharge tests for identifying the integral capacity model.

Two kinds of test signal from the seed paper [1]_:

* **Two-step tests** ([UAV23] eq. 25–28): constant power :math:`P_1` for
  :math:`t_1`, then :math:`P_2` for :math:`t_2 = k t_1`, sized so that the
  model draws exactly the charge :math:`C_0` by the end:

  .. math:: \frac{t_1}{\delta P_1^\varepsilon} + \frac{k t_1}{\delta P_2^\varepsilon}
            = C_0^\beta
            \quad\Rightarrow\quad
            t_1 = \frac{\delta P_2^\varepsilon C_0^\beta}{k + (P_2/P_1)^\varepsilon},
            \qquad t_2 = k t_1 .

* **APRBS** (amplitude-modulated pseudo-random binary sequence): the power
  jumps between a few levels (e.g. 50/75/100/125 W), each held for a time drawn
  uniformly from :math:`[t_{min}, t_{max}]`, until a minimum total duration.

Both are returned as a *power schedule*: a table of steps (``start_s``,
``duration_s``, ``power_w``) that :func:`planner.identify.schedule.write_schedule` exports as a CSV a
programmable electronic load in constant-power mode can run, and
:func:`sample_schedule` puts on a time grid for simulation.

References
----------
.. [1] "Battery Testing and Discharge Model Validation for Electric Unmanned
   Aerial Vehicles (UAV)," Sensors, vol. 23, no. 15, 6937, 2023,
   doi: 10.3390/s23156937.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from planner.physics.battery import integral

__all__ = [
    "SCHEDULE_COLUMNS",
    "TwoStepTest",
    "aprbs",
    "sample_schedule",
    "two_step",
    "two_step_schedule",
]

#: Columns of a power schedule table.
SCHEDULE_COLUMNS = ("start_s", "duration_s", "power_w")


@dataclass(frozen=True)
class TwoStepTest:
    """A two-step constant-power test ([UAV23] eq. 25–28)."""

    p1_w: float
    """Power of the first step. [W]"""
    p2_w: float
    """Power of the second step. [W]"""
    k: float
    """Ratio of the step durations, :math:`t_2 / t_1`. [unitless]"""
    capacity_as: float
    """Charge the test draws, :math:`C_0`. [A s]"""
    t1_s: float
    """Duration of the first step. [s]"""
    t2_s: float
    """Duration of the second step. [s]"""

    @property
    def total_s(self) -> float:
        """:math:`t_1 + t_2`. [s]"""
        return self.t1_s + self.t2_s

    def schedule(self) -> pd.DataFrame:
        """The test as a power schedule (see :func:`two_step_schedule`)."""
        return two_step_schedule(self)


def _positive(name: str, value) -> np.ndarray:
    v = np.asarray(value, dtype=float)
    if np.any(~np.isfinite(v)) or np.any(v <= 0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return v


def two_step(p1_w, p2_w, k, capacity_as, delta, epsilon, beta=integral.LITERATURE_BETA):
    r"""
    Step durations of a two-step test that draws the charge ``capacity_as``.

    Parameters
    ----------
    p1_w, p2_w : numeric
        Constant power of the first and the second step, > 0. [W]
    k : numeric
        Ratio :math:`t_2/t_1`, > 0. [unitless]
    capacity_as : numeric
        Charge :math:`C_0` the whole test draws, > 0 (e.g. the nominal
        capacity × 3.6 A s/mAh). [A s]
    delta, epsilon, beta : float
        Integral model parameters (:mod:`planner.physics.battery.integral`).

    Returns
    -------
    TwoStepTest or tuple of ndarray
        For scalar inputs a :class:`TwoStepTest`; for array inputs the tuple
        ``(t1_s, t2_s, total_s)`` broadcast over them. [s]

    Notes
    -----
    Seed eq. 25–28: the stress of the two steps adds up to :math:`C_0^\beta`,

    .. math:: t_1 = \frac{\delta P_2^\varepsilon C_0^\beta}{k + (P_2/P_1)^\varepsilon},
              \qquad t_2 = k\, t_1 .

    With :math:`k = 0` the test is a single step at :math:`P_1` lasting
    :math:`\delta P_1^\varepsilon C_0^\beta`; ``k`` must nevertheless be > 0
    here since a two-step test has two steps.
    """
    p1, p2, kk, c0 = (_positive(n, v) for n, v in (("p1_w", p1_w), ("p2_w", p2_w),
                                                    ("k", k), ("capacity_as", capacity_as)))
    full_at_p2 = np.asarray(integral.discharge_time(p2, c0, delta, epsilon, beta), float)
    t1 = full_at_p2 / (kk + (p2 / p1) ** epsilon)
    t2 = kk * t1
    if t1.ndim == 0:
        return TwoStepTest(float(p1), float(p2), float(kk), float(c0), float(t1), float(t2))
    return t1, t2, t1 + t2


def two_step_schedule(test: TwoStepTest) -> pd.DataFrame:
    """Power schedule of a two-step test: two rows (``start_s``, ``duration_s``, ``power_w``)."""
    return pd.DataFrame({"start_s": [0.0, test.t1_s], "duration_s": [test.t1_s, test.t2_s],
                         "power_w": [test.p1_w, test.p2_w]}, columns=list(SCHEDULE_COLUMNS))


def aprbs(levels_w, hold_s=(30.0, 300.0), min_duration_s=3500.0, rng=None, *,
          resolution_s: float = 1.0) -> pd.DataFrame:
    r"""
    An APRBS power schedule: random levels held for random times.

    Parameters
    ----------
    levels_w : sequence of float
        Power levels, at least two, each > 0 (seed: 50, 75, 100, 125 W). [W]
    hold_s : (float, float), default (30, 300)
        Hold times are drawn from :math:`U[t_{min}, t_{max}]`. [s]
    min_duration_s : float, default 3500
        Steps are added until the total reaches at least this. [s]
    rng : numpy.random.Generator or int, optional
        Random source (or a seed for :func:`numpy.random.default_rng`); give
        one for a reproducible schedule.
    resolution_s : float, default 1.0
        Hold times are rounded to a multiple of this (a load's time step),
        staying within ``hold_s``. [s]

    Returns
    -------
    DataFrame
        One row per step: ``start_s`` [s], ``duration_s`` [s], ``power_w`` [W].

    Notes
    -----
    Each level is drawn uniformly from ``levels_w`` but never equal to the
    previous one, so every switching instant is a real change of power and the
    hold-time distribution is the one asked for (two equal neighbours would
    merge into one longer hold).
    """
    levels = np.asarray(levels_w, dtype=float).ravel()
    if levels.size < 2 or np.unique(levels).size < 2:
        raise ValueError(f"levels_w needs at least two different levels, got {levels_w!r}")
    _positive("levels_w", levels)
    lo, hi = (float(h) for h in hold_s)
    if not (0 < lo <= hi and np.isfinite(hi)):
        raise ValueError(f"hold_s must be (min, max) with 0 < min <= max, got {hold_s!r}")
    if not (np.isfinite(min_duration_s) and min_duration_s > 0):
        raise ValueError(f"min_duration_s must be > 0, got {min_duration_s!r}")
    if not resolution_s > 0:
        raise ValueError(f"resolution_s must be > 0, got {resolution_s!r}")
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(rng)
    k_lo = max(1, int(np.ceil(lo / resolution_s - 1e-9)))  # a hold lasts at least one step
    k_hi = int(np.floor(hi / resolution_s + 1e-9))
    if k_hi < k_lo:
        raise ValueError(f"no multiple of resolution_s={resolution_s} lies in hold_s={hold_s}")
    powers, holds = [], []
    total, previous = 0.0, None
    while total < min_duration_s:
        choices = levels if previous is None else levels[levels != previous]
        level = float(choices[rng.integers(choices.size)])
        hold = np.clip(np.round(rng.uniform(lo, hi) / resolution_s), k_lo, k_hi) * resolution_s
        powers.append(level)
        holds.append(float(hold))
        total += hold
        previous = level
    holds_a = np.array(holds)
    starts = np.concatenate(([0.0], np.cumsum(holds_a)[:-1]))
    return pd.DataFrame({"start_s": starts, "duration_s": holds_a, "power_w": powers},
                        columns=list(SCHEDULE_COLUMNS))


def sample_schedule(schedule: pd.DataFrame, time_s) -> np.ndarray:
    """Power of a schedule at the given times (step held; 0 outside the schedule). [W]"""
    t = np.asarray(time_s, dtype=float)
    starts = schedule["start_s"].to_numpy(float)
    ends = starts + schedule["duration_s"].to_numpy(float)
    power = schedule["power_w"].to_numpy(float)
    i = np.searchsorted(starts, t, side="right") - 1
    inside = (i >= 0) & (t < ends[np.clip(i, 0, None)]) if len(starts) else np.zeros(t.shape, bool)
    return np.where(inside, power[np.clip(i, 0, max(len(power) - 1, 0))], 0.0)
