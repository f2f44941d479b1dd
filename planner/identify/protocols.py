r"""Test protocols for identifying a pack: discharge schedules and current-pulse tests.

Three kinds of test signal from [UAV23]:

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

* **Current pulses** ([UAV23] Table 1, the amended VDA current-step test): per pulse
  current a rest, a discharge pulse, a rest, a charge pulse and a rest
  (:func:`pulse_block`, defined here once). :mod:`planner.identify.pulse_resistance`
  runs it at several currents ([UAV23] Table 2); :func:`pulse_test_profile` at several
  states of charge, for the equivalent circuit (:mod:`planner.identify.circuit_fit`).

The discharge tests are returned as a *power schedule*: a table of steps (``start_s``,
``duration_s``, ``power_w``) that :func:`planner.identify.schedule.write_schedule` exports as a CSV a
programmable electronic load in constant-power mode can run, and
:func:`sample_schedule` puts on a time grid for simulation.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from planner.errors import InputError
from planner.physics.battery import integral
from planner.physics.units import AS_PER_MAH

__all__ = [
    "PULSE_REST_S",
    "SCHEDULE_COLUMNS",
    "PulseProfile",
    "TwoStepTest",
    "aprbs",
    "pulse_block",
    "pulse_test_profile",
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
    [UAV23] eq. 25–28: the stress of the two steps adds up to :math:`C_0^\beta`,

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
        Power levels, at least two, each > 0 ([UAV23]: 50, 75, 100, 125 W). [W]
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


# --------------------------------------------------------------------------- current pulses

_AS_PER_AH = 1000.0 * AS_PER_MAH     # [A s / A h]

#: The three rests of a [UAV23] Table 1 pulse block: before the discharge pulse, between
#: the two pulses, after the charge pulse. [s]
PULSE_REST_S = (100.0, 200.0, 100.0)


def pulse_block(current_a: float, pulse_s: float,
                rest_s=PULSE_REST_S) -> list[tuple[float, float]]:
    """One block of the current-pulse test ([UAV23] Table 1): a rest, a discharge pulse
    of ``current_a``, a rest, a charge pulse of ``−current_a`` and a rest.

    Parameters
    ----------
    current_a : float
        Pulse current magnitude (discharge positive). [A]
    pulse_s : float
        Length of each pulse. [s]
    rest_s : float or (float, float, float)
        The three rests, or one length for all three. [s]

    Returns
    -------
    list of (float, float)
        The five segments in order, each ``(duration [s], current [A])``.
    """
    r0, r1, r2 = (rest_s,) * 3 if np.ndim(rest_s) == 0 else rest_s
    amps = float(current_a)
    return [(r0, 0.0), (pulse_s, amps), (r1, 0.0), (pulse_s, -amps), (r2, 0.0)]


@dataclass
class PulseProfile:
    """A pulse-test current profile.

    Attributes
    ----------
    time_s : ndarray [s]
    current_a : ndarray
        Current held from each sample to the next, discharge positive. [A]
    blocks : list of dict
        One per state of charge: ``soc`` (nominal), ``start_s``, ``end_s`` of
        the rest–discharge–rest–charge–rest block.
    """

    time_s: np.ndarray
    current_a: np.ndarray
    blocks: list[dict]


def pulse_test_profile(capacity_ah: float, *, soc_levels=(0.9, 0.7, 0.5, 0.3, 0.1),
                       pulse_current_a: float | None = None, pulse_s: float = 20.0,
                       rest_s: float = 60.0, move_current_a: float | None = None,
                       settle_s: float = 600.0, soc0: float = 1.0,
                       dt_s: float = 0.1) -> PulseProfile:
    """
    The [UAV23] Table 1 pulse block (:func:`pulse_block`) at several states of charge.

    At each level: a constant-current discharge from the previous level
    (``move_current_a``), ``settle_s`` of rest, then the block: ``rest_s``
    rest, ``pulse_s`` discharge pulse, ``rest_s`` rest, ``pulse_s`` charge
    pulse, ``rest_s`` rest (60 s, 20 s, 60 s, 20 s, 60 s by default).

    Parameters
    ----------
    capacity_ah : float
        Capacity of the cell or pack under test. [A h]
    soc_levels : sequence of float
        Decreasing states of charge at which to pulse. [unitless]
    pulse_current_a : float, optional
        Pulse magnitude; default 1 C. [A]
    move_current_a : float, optional
        Current of the discharges between levels; default C/2. [A]
    soc0 : float
        State of charge at the start. [unitless]
    dt_s : float
        Sample interval; durations are rounded to it. [s]

    Returns
    -------
    PulseProfile
    """
    if not capacity_ah > 0:
        raise InputError(f"capacity_ah must be > 0, got {capacity_ah!r}")
    if not dt_s > 0:
        raise InputError(f"dt_s must be > 0, got {dt_s!r}")
    i_pulse = capacity_ah if pulse_current_a is None else float(pulse_current_a)
    i_move = capacity_ah / 2 if move_current_a is None else float(move_current_a)
    if i_pulse <= 0 or i_move <= 0:
        raise InputError("pulse_current_a and move_current_a must be > 0")
    levels = [float(s) for s in soc_levels]
    if any(not 0 < s <= 1 for s in levels) or any(b >= a for a, b in itertools.pairwise(levels)):
        raise InputError("soc_levels must decrease within (0, 1]")

    def steps(duration):
        return max(round(duration / dt_s), 0)

    segments: list[tuple[int, float]] = []
    blocks = []
    soc = float(soc0)
    k = 0
    for level in levels:
        if level < soc:
            n_move = steps((soc - level) * capacity_ah * _AS_PER_AH / i_move)
            segments.append((n_move, i_move))
            k += n_move
            soc -= n_move * dt_s * i_move / (capacity_ah * _AS_PER_AH)
        segments.append((steps(settle_s), 0.0))
        k += steps(settle_s)
        start = k
        for duration, cur in pulse_block(i_pulse, pulse_s, rest_s):
            segments.append((steps(duration), cur))
            k += steps(duration)
        blocks.append({"soc": soc, "start_s": start * dt_s, "end_s": k * dt_s})
    current = np.concatenate([np.full(n_seg, cur) for n_seg, cur in segments] + [[0.0]])
    time = np.arange(current.size) * dt_s
    return PulseProfile(time, current, blocks)
