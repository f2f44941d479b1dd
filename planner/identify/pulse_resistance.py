r"""Internal resistance from a current-pulse test (amended VDA method, [UAV23] eq. 11).

[UAV23] measures the pack's DC resistance with an amended version of the VDA
current-step method. Per pulse current, the block of its Table 1
(:func:`planner.identify.protocols.pulse_block`): relaxation 100 s, discharge pulse,
relaxation 200 s, charge pulse, relaxation 100 s. At the instant the current is
switched off the voltage jumps by the ohmic drop only (the polarisation voltage of the
electrodes is continuous and decays slowly afterwards), so

.. math:: R = \frac{\Delta V}{\Delta I}
          = \frac{V_{after} - V_{before}}{I_{before} - I_{after}}

with the samples just before and just after the switch-off. This holds for a
discharge pulse (the voltage jumps up) and a charge pulse (it drops) alike.
[UAV23] Table 2 lists R at 2, 4, 6 and 8 A (20.48, 21.24, 20.46 and
20.51 mΩ) and reports their mean, 20.68 mΩ, with the 95 % confidence interval
20.07–21.29 mΩ.

:func:`current_off_instants` finds the switch-off samples,
:func:`pulse_resistance` evaluates a test, and :func:`pulse_profile` generates
the Table 1 test at several currents with the voltage response of a simple pack (for
tests and for planning a bench run).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import signal, stats

from planner.errors import InputError
from planner.identify.protocols import PULSE_REST_S, pulse_block

__all__ = [
    "LEVEL_TOLERANCE",
    "ON_THRESHOLD_A",
    "Pulse",
    "PulseResistance",
    "current_off_instants",
    "pulse_profile",
    "pulse_resistance",
]

#: A sample with ``|current| >=`` this is "current on". [A]
ON_THRESHOLD_A = 0.1
#: Pulses whose currents, in increasing order, step up by less than this fraction from
#: one to the next share a level: a bench's set points wander by some per cent from pulse
#: to pulse (0.27, 0.30, 0.33 A is one 0.3 A level), while the levels of a pulse test are
#: far apart (2, 4, 6, 8 A). [unitless]
LEVEL_TOLERANCE = 0.2


@dataclass(frozen=True)
class Pulse:
    """One current switch-off and the resistance it shows."""

    time_s: float
    """Time of the first sample with the current off. [s]"""
    current_a: float
    """Current just before the switch-off (discharge positive, charge negative). [A]"""
    delta_v: float
    """:math:`V_{after} - V_{before}`. [V]"""
    delta_i: float
    """:math:`I_{before} - I_{after}`. [A]"""
    resistance_ohm: float
    """:math:`\\Delta V / \\Delta I`. [Ω]"""

    @property
    def kind(self) -> str:
        """``"discharge"`` (current positive before the switch-off) or ``"charge"``."""
        return "discharge" if self.current_a > 0 else "charge"


@dataclass(frozen=True)
class PulseResistance:
    """Result of a pulse test: R per pulse and per current level, with statistics."""

    pulses: list[Pulse]
    """Every switch-off found, in time order."""
    levels_a: np.ndarray
    """Pulse current magnitude of each level (mean of its pulses). [A]"""
    level_resistance_ohm: np.ndarray
    """R of each level: mean over its pulses (discharge and charge). [Ω]"""
    mean_ohm: float
    """Mean of the values the statistics are taken over (levels or pulses). [Ω]"""
    ci_low_ohm: float
    """Lower end of the confidence interval of the mean (Student t). [Ω]"""
    ci_high_ohm: float
    """Upper end of the confidence interval. [Ω]"""
    rmse_ohm: float
    """Root-mean-square deviation of those values from their mean. [Ω]"""
    std_ohm: float
    """Sample standard deviation (n − 1) of those values. [Ω]"""
    n: int
    """Number of values the statistics are taken over. [unitless]"""
    confidence: float = 0.95
    """Confidence level of the interval. [unitless]"""
    by: str = "level"
    """``"level"`` (one value per pulse current) or ``"pulse"``."""
    values_ohm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The values the statistics are taken over. [Ω]"""

    def to_dict(self) -> dict:
        """JSON-ready form: every pulse, the levels [A] and their resistances [Ω], the
        statistics [Ω] and how they were taken.
        """
        return {
            "pulses": [{"time_s": p.time_s, "current_a": p.current_a, "kind": p.kind,
                        "delta_v": p.delta_v, "delta_i": p.delta_i,
                        "resistance_ohm": p.resistance_ohm} for p in self.pulses],
            "levels_a": self.levels_a.tolist(),
            "level_resistance_ohm": self.level_resistance_ohm.tolist(),
            "mean_ohm": self.mean_ohm, "ci_low_ohm": self.ci_low_ohm,
            "ci_high_ohm": self.ci_high_ohm, "rmse_ohm": self.rmse_ohm,
            "std_ohm": self.std_ohm, "n": self.n, "confidence": self.confidence,
            "by": self.by,
        }


def _arrays(time_s, voltage_v, current_a, where: str):
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(voltage_v, dtype=float)
    i = np.asarray(current_a, dtype=float)
    if not (t.shape == v.shape == i.shape) or t.ndim != 1:
        raise InputError(f"{where}: time, voltage and current must be 1-D arrays of one "
                         f"length, got shapes {t.shape}, {v.shape}, {i.shape}")
    for name, a in (("time_s", t), ("voltage_v", v), ("current_a", i)):
        bad = ~np.isfinite(a)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputError(f"{where}: column '{name}' sample {k + 1}: expected a finite "
                             f"number, got {float(a[k]):g}")
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise InputError(f"{where}: column 'time_s' sample {k + 1}: time must increase")
    return t, v, i


def current_off_instants(time_s, current_a, threshold_a: float = ON_THRESHOLD_A,
                         min_on_samples: int = 2) -> np.ndarray:
    """Indices of the first sample with the current off after each pulse.

    Parameters
    ----------
    time_s, current_a : array_like
        Sample times [s] and pack current [A] (sign free: discharge or charge).
    threshold_a : float, default :data:`ON_THRESHOLD_A`
        ``|current| >= threshold_a`` is "on". [A]
    min_on_samples : int, default 2
        Shorter "on" runs are spikes, not pulses.

    Returns
    -------
    ndarray of int
    """
    i = np.abs(np.asarray(current_a, dtype=float))
    on = i >= threshold_a
    off_after_on = np.flatnonzero(on[:-1] & ~on[1:]) + 1
    if not len(off_after_on):
        return off_after_on
    # length of the "on" run ending just before each switch-off
    starts = np.flatnonzero(on & ~np.r_[False, on[:-1]])
    run_start = starts[np.searchsorted(starts, off_after_on - 1, side="right") - 1]
    return off_after_on[(off_after_on - run_start) >= min_on_samples]


def _levels(currents: np.ndarray, tolerance: float) -> np.ndarray:
    """Group pulse currents (magnitudes) into levels (single linkage on the sorted
    magnitudes: a new level where one steps up from the one before by more than
    ``tolerance``); returns a level index per pulse."""
    mags = np.abs(np.asarray(currents, float))
    order = np.argsort(mags, kind="stable")
    m = mags[order]
    step = np.r_[False, m[1:] > m[:-1] * (1 + tolerance)]
    label = np.empty(len(mags), dtype=int)
    label[order] = np.cumsum(step)
    return label


def pulse_resistance(time_s, voltage_v, current_a, *, threshold_a: float = ON_THRESHOLD_A,
                     by: str = "level", confidence: float = 0.95,
                     level_tolerance: float = LEVEL_TOLERANCE,
                     source: str | None = None) -> PulseResistance:
    r"""
    Internal resistance from a pulse test (amended VDA, [UAV23] eq. 11, Table 2).

    Parameters
    ----------
    time_s, voltage_v, current_a : array_like
        The test record: time [s], pack terminal voltage [V], pack current
        (discharge positive) [A].
    threshold_a : float, default :data:`ON_THRESHOLD_A`
        Current magnitude that counts as "on". [A]
    by : {"level", "pulse"}, default "level"
        Statistics over one value per pulse current (the mean of its discharge
        and charge pulses), as the [UAV23] Table 2 lists them, or over every
        pulse.
    confidence : float, default 0.95
        Level of the Student-t confidence interval of the mean.
    level_tolerance : float, default :data:`LEVEL_TOLERANCE`
        Pulses whose currents differ by less than this fraction share a level.
    source : str, optional
        File name for messages.

    Returns
    -------
    PulseResistance

    Raises
    ------
    InputError
        Non-finite samples, time not increasing, no pulse found, or a
        switch-off whose current step is too small to divide by.

    Notes
    -----
    At each switch-off :math:`R = (V_{after} - V_{before})/(I_{before} - I_{after})`.
    Over the *n* values :math:`R_j`: mean :math:`\bar R`, interval
    :math:`\bar R \pm t_{(1+c)/2,\,n-1}\, s/\sqrt{n}` with the sample standard
    deviation *s*, and :math:`RMSE = \sqrt{\sum (R_j - \bar R)^2 / n}`. With a
    single value the interval is undefined (NaN).
    """
    where = source or "pulse test"
    if by not in ("level", "pulse"):
        raise ValueError(f"by must be 'level' or 'pulse', got {by!r}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    t, v, i = _arrays(time_s, voltage_v, current_a, where)
    offs = current_off_instants(t, i, threshold_a)
    if not len(offs):
        raise InputError(f"{where}: no current pulse found (no switch-off from "
                         f"|current| >= {threshold_a:g} A to below it); expected the "
                         "pulse profile of rest, discharge pulse, rest, charge pulse, rest")
    pulses = []
    for k in offs:
        dv = v[k] - v[k - 1]
        di = i[k - 1] - i[k]
        if abs(di) < threshold_a:
            raise InputError(f"{where}: switch-off at {t[k]:g} s: current step {di:g} A is "
                             "too small to divide by")
        pulses.append(Pulse(time_s=float(t[k]), current_a=float(i[k - 1]), delta_v=float(dv),
                            delta_i=float(di), resistance_ohm=float(dv / di)))
    currents = np.array([p.current_a for p in pulses])
    r_pulse = np.array([p.resistance_ohm for p in pulses])
    label = _levels(currents, level_tolerance)
    n_levels = label.max() + 1
    levels = np.array([np.mean(np.abs(currents[label == j])) for j in range(n_levels)])
    r_level = np.array([np.mean(r_pulse[label == j]) for j in range(n_levels)])
    values = r_level if by == "level" else r_pulse
    n = len(values)
    mean = float(np.mean(values))
    rmse = float(np.sqrt(np.mean((values - mean) ** 2)))
    if n > 1:
        sd = float(np.std(values, ddof=1))
        half = float(stats.t.ppf(0.5 + confidence / 2, n - 1)) * sd / np.sqrt(n)
    else:
        sd = half = np.nan
    return PulseResistance(pulses=pulses, levels_a=levels, level_resistance_ohm=r_level,
                           mean_ohm=mean, ci_low_ohm=mean - half, ci_high_ohm=mean + half,
                           rmse_ohm=rmse, std_ohm=sd, n=n, confidence=confidence, by=by,
                           values_ohm=values)


def pulse_profile(currents_a=(2.0, 4.0, 6.0, 8.0), resistance_ohm=0.02068, *,
                  ocv_v: float = 16.0, pulse_s: float = 10.0,
                  rest_s: tuple[float, float, float] = PULSE_REST_S,
                  dt_s: float = 0.1, polarisation_ohm: float = 0.0, tau_s: float = 30.0,
                  noise_v: float = 0.0, noise_a: float = 0.0, rng=None) -> pd.DataFrame:
    r"""
    The [UAV23] Table 1 pulse profile and the voltage response of a simple pack.

    Per pulse current: relaxation ``rest_s[0]``, discharge pulse of
    ``pulse_s``, relaxation ``rest_s[1]``, charge pulse of ``pulse_s``,
    relaxation ``rest_s[2]`` (Table 1: 100 s, pulse, 200 s, pulse, 100 s).

    Parameters
    ----------
    currents_a : sequence of float, default (2, 4, 6, 8)
        Pulse current magnitudes, in order ([UAV23] Table 2). [A]
    resistance_ohm : float or sequence of float, default 0.02068
        Ohmic resistance R0 of the pack, one for all or one per current. [Ω]
    ocv_v : float, default 16.0
        Open-circuit voltage, held constant. [V]
    pulse_s : float, default 10.0
        Length of each pulse (a parameter: the bench's choice). [s]
    rest_s : (float, float, float)
        The three relaxations. [s]
    dt_s : float, default 0.1
        Sample interval. [s]
    polarisation_ohm, tau_s : float
        Optional RC branch (R1 [Ω], time constant [s]) for a realistic slow
        relaxation after the jump; 0 = none.
    noise_v, noise_a : float
        Standard deviation of white measurement noise. [V], [A]
    rng : numpy.random.Generator or int, optional

    Returns
    -------
    DataFrame
        ``time_s`` [s], ``voltage_v`` [V], ``current_a`` [A] (discharge
        positive): :math:`V = OCV - R_0 I - V_{RC}`.
    """
    currents = np.asarray(currents_a, dtype=float).ravel()
    r0 = np.broadcast_to(np.asarray(resistance_ohm, dtype=float), currents.shape)
    blocks_i, blocks_r = [], []
    for amps, ohms in zip(currents, r0):
        for duration, value in pulse_block(amps, pulse_s, rest_s):
            n = round(duration / dt_s)
            blocks_i.append(np.full(n, value))
            blocks_r.append(np.full(n, ohms))
    current = np.concatenate(blocks_i + [np.zeros(1)])
    r_ohm = np.concatenate(blocks_r + [r0[-1:]])
    t = np.arange(current.size) * dt_s
    if polarisation_ohm > 0:
        a = np.exp(-dt_s / tau_s)
        # V_rc[k] from the current of the previous samples (exact for steps)
        v_rc = signal.lfilter([0.0, polarisation_ohm * (1 - a)], [1.0, -a], current)
    else:
        v_rc = np.zeros_like(current)
    voltage = ocv_v - r_ohm * current - v_rc
    if noise_v or noise_a:
        g = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        voltage = voltage + g.normal(0.0, noise_v, voltage.size) if noise_v else voltage
        current = current + g.normal(0.0, noise_a, current.size) if noise_a else current
    return pd.DataFrame({"time_s": t, "voltage_v": voltage, "current_a": current})


def resistance_by_charge(result: PulseResistance, time_s, current_a, *,
                         capacity_mah: float | None = None,
                         block_fraction: float = 0.05) -> list[dict]:
    """R against the charge drawn before the pulses (and the state of charge, with the
    capacity): a pulse test run at several states of charge ([UAV23] Table 1 blocks
    between discharges) gives one R per block.

    The charge drawn is the trapezoid integral of the current from the first sample
    (discharge positive); pulses whose charge drawn lies within ``block_fraction`` of the
    total drawn of the one before share a block.

    Returns
    -------
    list of dict
        Per block: ``drawn_mah`` (mean over its pulses) [mAh], ``soc`` [unitless] (None
        without ``capacity_mah``), ``resistance_ohm`` (mean) [Ω], ``pulses``.
    """
    t = np.asarray(time_s, float)
    i = np.asarray(current_a, float)
    q = np.concatenate(([0.0], np.cumsum(0.5 * (i[1:] + i[:-1]) * np.diff(t)))) / 3.6
    at = np.interp([p.time_s for p in result.pulses], t, q)
    r = np.array([p.resistance_ohm for p in result.pulses])
    if at.size == 0:
        return []
    span = max(float(np.nanmax(q) - np.nanmin(q)), 1e-9)
    order = np.argsort(at, kind="stable")
    new = np.r_[True, np.diff(at[order]) > block_fraction * span]
    block = np.empty(at.size, int)
    block[order] = np.cumsum(new) - 1
    out = []
    for b in range(block.max() + 1):
        sel = block == b
        drawn = float(at[sel].mean())
        out.append({"drawn_mah": drawn,
                    "soc": None if not capacity_mah else 1.0 - drawn / capacity_mah,
                    "resistance_ohm": float(r[sel].mean()), "pulses": int(sel.sum())})
    return out
