r"""A virtual battery test bench: constant-power discharges of a simulated LiPo pack.

The bench stands in for the laboratory set-up of [UAV23] (an electronic
load in constant-power mode, voltage and current sensors logged at 1 Hz) for
tests and demonstrations. It is deliberately **not** the integral capacity
model it is used to identify (:mod:`planner.physics.battery.integral`): the pack is
the equivalent circuit of :mod:`planner.physics.battery.circuit` — OCV(SoC) of a LiPo
cell, ohmic resistance R0(SoC, T) with the Arrhenius law, one polarisation RC
branch, the dynamic hysteresis state, the available capacity against
temperature — plus one state that the circuit lacks, a *diffusion* (surface
state-of-charge) state that gives the pack a rate-dependent capacity beyond
the IR drop. The empirical model is then fitted to something richer than
itself, as in the paper.

Pack equations (per cell; discharge current positive)
-----------------------------------------------------
The equations of :func:`planner.physics.battery.circuit.simulate`, with the OCV and R0
evaluated at the *surface* state of charge :math:`z_s = z - x`:

.. math::

    \dot z &= -i / Q(T) \\
    \dot x &= \frac{1 - c}{c}\,\frac{i}{Q(T)} - \frac{x}{\tau_d} \\
    \dot v_1 &= -v_1/(R_1 C_1) + i / C_1 \\
    v &= \mathrm{OCV}(z - x) + h - v_1 - R_0(z - x, T)\, i

(the hysteresis ``h`` as in :mod:`planner.physics.battery.circuit`). ``x`` is the
depletion of the electrode surface against the bulk: the kinetic battery model
(KiBaM) of Manwell and McGowan [1]_ written in state-of-charge terms. KiBaM
splits the charge into an *available* well (fraction ``c``) that feeds the
current and a *bound* well that refills it through a valve; the height
difference of the two wells relaxes with :math:`\tau_d = c(1-c)/k'`. The
terminal sees the available well: its level is the bulk SoC minus ``x``.
Jongerden and Haverkort [2]_ discuss KiBaM as a first-order approximation of
the diffusion model of Rakhmatov and Vrudhula: while a current flows the
lithium concentration at the electrode surface falls below the mean, and it
catches up at rest.

Two effects follow that an integral model of charge against power cannot
show:

* **rate-dependent capacity.** Under a steady current ``I`` the surface
  deficit settles at :math:`x_\infty = \frac{1-c}{c} \tau_d I / Q`, so the
  loaded voltage reaches the cut-off while the charge :math:`Q x` is still
  bound: the charge delivered at cut-off falls by

  .. math:: \Delta C = Q\,x(t_{cut}) \approx \frac{1-c}{c}\,\tau_d\, I

  on top of the IR-drop loss (R0, R1) that the circuit already has. With the
  defaults (``c`` = 5/6, ``τ_d`` = 600 s) this is 120 s × I: 1.1 % of
  10 Ah at 50 W, 2.9 % at 125 W (currents near the cut-off).
* **recovery.** At rest (or at lower power) ``x`` relaxes with ``τ_d`` and
  the withheld charge becomes available again.

The simulation is :func:`planner.physics.battery.circuit.simulate` with its
``diffusion`` state (exact zero-order-hold update
:math:`x_{k+1} = a x_k + (1-a)\,\frac{1-c}{c}\tau_d\, i_k/Q`,
:math:`a = e^{-\Delta t/\tau_d}`); with ``c = 1`` the state stays 0. The cell
temperature is held constant (isothermal bench, a climate chamber).

Constant-power control and logging
----------------------------------
The load draws the scheduled power exactly (the current of each step is the
smaller root of :math:`P = (E - R I) I`, as in ``simulate``). Each sample is
logged at 1 Hz by default with white Gaussian measurement noise on voltage
and current (seeded, reproducible); ``power_w`` is the product of the two
measured values while the load is on and 0 when it is off; ``consumed_mah``
is the logger's running sum of measured current × sample interval (left
rectangle, the zero-order hold of the load). The run stops at the first
sample whose loaded cell voltage is at or below the cut-off (that sample is
the last of the record: the load trips there) or at the end of the schedule.

Default pack
------------
:func:`seed_pack`: the Multistar 10.0 Ah 4S1P of [UAV23] as in
``aircraft/batteries/multistar_10ah_4s.yaml``: R0 = 20.68 mΩ per pack ([UAV23]
Table 2), one RC branch of 3 mΩ / 10 kF per cell (τ = 30 s, assumed), the
LiPo OCV of Chen and Rincón-Mora (:func:`planner.physics.battery.ocv.lipo_ocv`),
3.5 V per cell loaded cut-off, 25 °C. The diffusion parameters ``c`` = 5/6
and ``τ_d`` = 600 s are assumed: ``τ_d`` is of the order of the slow
(diffusion) branch of two-RC fits to lithium cells (minutes to tens of
minutes, e.g. Hu, Li and Peng [3]_), and ``c`` is chosen so that the withheld
charge at 1 C is 3.3 % of the capacity (a modest rate effect; assumed, not
measured). Measurement noise: 10 mV and 50 mA (1 σ), assumed.


References
----------
.. [1] J. F. Manwell and J. G. McGowan, "Lead acid battery storage model for
   hybrid energy systems," Solar Energy, vol. 50, no. 5, pp. 399–405, 1993,
   doi: 10.1016/0038-092X(93)90060-2.
.. [2] M. R. Jongerden and B. R. Haverkort, "Which battery model to use?"
   IET Software, vol. 3, no. 6, pp. 445–457, 2009.
.. [3] X. Hu, S. Li and H. Peng, "A comparative study of equivalent circuit
   models for Li-ion batteries," J. Power Sources, vol. 198, pp. 359–367,
   2012, doi: 10.1016/j.jpowsour.2011.10.013.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from planner.physics.battery import circuit
from planner.identify import protocols as design
from planner.physics.battery.circuit import CircuitParameters
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.battery.thermal import check_temperature
from planner.errors import InputError
from planner.physics.units import AS_PER_MAH

__all__ = [
    "DEFAULT_NOISE",
    "NO_NOISE",
    "RECORD_COLUMNS",
    "BenchNoise",
    "BenchPack",
    "BenchResult",
    "aprbs_discharge",
    "constant_power_discharge",
    "run_schedule",
    "seed_pack",
    "simulate_bench",
    "to_record",
    "two_step_discharge",
]

#: Columns of the flight records the bench writes (docs/record.md), in order.
RECORD_COLUMNS = ("experiment", "time_s", "voltage_v", "current_a", "power_w", "consumed_mah")

#: The seed pack (``aircraft/batteries/multistar_10ah_4s.yaml``): cells in series.
SEED_CELLS_SERIES = 4
#: ... nominal capacity. [mAh]
SEED_CAPACITY_MAH = 10_000.0
#: ... pack internal resistance, [UAV23] Table 2. [Ω]
SEED_R_PACK_OHM = 0.02068
#: ... RC branch per cell (assumed, τ = 30 s). [Ω], [F]
SEED_R1_OHM, SEED_C1_F = 0.003, 10_000.0
#: ... loaded cut-off per cell. [V]
SEED_CUTOFF_CELL_V = 3.5
#: ... integral model m_const, [UAV23] Table 5 (used to design two-step tests).
SEED_MODEL = {"delta": 23.6482, "epsilon": -1.0209, "beta": 0.9648}


#: Default KiBaM available-charge fraction c (assumed, see the module notes). [unitless]
DEFAULT_AVAILABLE_FRACTION = 5.0 / 6.0
#: Default diffusion (well-equalisation) time constant τ_d (assumed). [s]
DEFAULT_DIFFUSION_TAU_S = 600.0


# --------------------------------------------------------------------------- parameters

@dataclass(frozen=True, eq=False)
class BenchPack:
    """A simulated pack on the bench: the equivalent circuit plus the diffusion state.

    Attributes
    ----------
    circuit : CircuitParameters
        Equivalent circuit per cell and pack layout (:mod:`planner.physics.battery.circuit`).
    available_fraction : float, default 5/6
        KiBaM share ``c`` of the charge in the available well, (0, 1]; 1 = no
        diffusion limitation (the bench is then ``circuit.simulate``). [unitless]
    diffusion_tau_s : float, default 600
        Relaxation time τ_d of the surface deficit. [s]
    v_cutoff_cell : float, default 3.5
        Loaded cut-off per cell where the load trips. [V]
    name : str
        Pack name for reports.
    model : dict
        Integral model ``delta``, ``epsilon``, ``beta`` used to *design* tests
        (two-step durations); not used by the simulation.
    """

    circuit: CircuitParameters
    available_fraction: float = DEFAULT_AVAILABLE_FRACTION
    diffusion_tau_s: float = DEFAULT_DIFFUSION_TAU_S
    v_cutoff_cell: float = SEED_CUTOFF_CELL_V
    name: str = "bench pack"
    model: dict = field(default_factory=lambda: dict(SEED_MODEL))

    def __post_init__(self):
        problems = []
        c = self.available_fraction
        if not (isinstance(c, (int, float)) and math.isfinite(c) and 0.0 < c <= 1.0):
            problems.append(f"available_fraction must be in (0, 1], got {c!r}")
        tau = self.diffusion_tau_s
        if not (isinstance(tau, (int, float)) and math.isfinite(tau) and tau > 0.0):
            problems.append(f"diffusion_tau_s must be > 0 s, got {tau!r}")
        v = self.v_cutoff_cell
        if not (isinstance(v, (int, float)) and math.isfinite(v) and 0.0 < v < 10.0):
            problems.append(f"v_cutoff_cell must be a cell voltage in (0, 10) V, got {v!r}")
        if not isinstance(self.circuit, CircuitParameters):
            problems.append("circuit must be a CircuitParameters")
        if problems:
            raise ValueError("BenchPack: " + "; ".join(problems))

    @property
    def capacity_as(self) -> float:
        """Pack capacity at the reference temperature. [A s]"""
        return self.circuit.pack_capacity_ah * 3600.0

    @property
    def withheld_s_per_a(self) -> float:
        r"""Charge withheld at cut-off per ampere of steady current, :math:`\frac{1-c}{c}\tau_d`.

        [A s / A] = [s]; see the module notes (rate-dependent capacity).
        """
        c = self.available_fraction
        return (1.0 - c) / c * self.diffusion_tau_s

    @property
    def r_pack_ohm(self) -> float:
        """Pack ohmic resistance at full charge and the reference temperature. [Ω]"""
        return float(self.circuit.r0_pack_ohm(1.0))

    def with_changes(self, **changes) -> BenchPack:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    @classmethod
    def from_battery(cls, pack, **overrides) -> BenchPack:
        """A bench pack from a :class:`planner.parameters.BatteryPack`.

        The circuit comes from :meth:`planner.parameters.BatteryPack.circuit_parameters` (the pack's
        ``circuit:`` block, R0 from ``internal_resistance_ohm``), the cut-off
        from ``cell_voltage_empty_v`` (3.5 V when absent) and the design model
        from ``model``. ``overrides`` set other fields (``available_fraction``,
        ``diffusion_tau_s``, ...).
        """
        circuit = pack.circuit_parameters()
        cut = getattr(pack, "cell_voltage_empty_v", None) or SEED_CUTOFF_CELL_V
        m = pack.model
        kw = {"circuit": circuit, "v_cutoff_cell": float(cut), "name": str(pack.name),
              "model": {"delta": float(m.delta), "epsilon": float(m.epsilon),
                        "beta": float(m.beta)}}
        kw.update(overrides)
        return cls(**kw)


def seed_pack(**overrides) -> BenchPack:
    """The default bench pack: the Multistar 10.0 Ah 4S1P of [UAV23] (see the module notes).

    The numbers are those of ``aircraft/batteries/multistar_10ah_4s.yaml``
    (a test checks that they agree); ``overrides`` change fields of the
    :class:`BenchPack`.
    """
    circuit = CircuitParameters(
        capacity_ah=SEED_CAPACITY_MAH / 1000.0, r0_ohm=SEED_R_PACK_OHM / SEED_CELLS_SERIES,
        r1_ohm=SEED_R1_OHM, c1_f=SEED_C1_F, ocv=lipo_ocv, cells_series=SEED_CELLS_SERIES,
        source="[UAV23] Table 2 (R0); RC branch assumed (tau 30 s); LiPo OCV of Chen and "
               "Rincón-Mora 2006")
    kw = {"circuit": circuit, "name": "Multistar 10.0 Ah 4S1P (virtual bench)"}
    kw.update(overrides)
    return BenchPack(**kw)


@dataclass(frozen=True)
class BenchNoise:
    """White Gaussian measurement noise of the bench's sensors (1 σ).

    Attributes
    ----------
    voltage_v : float, default 0.01
        [V]
    current_a : float, default 0.05
        [A]
    """

    voltage_v: float = 0.01
    current_a: float = 0.05

    def __post_init__(self):
        for key in ("voltage_v", "current_a"):
            value = getattr(self, key)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"BenchNoise: {key} must be >= 0, got {value!r}")


#: The bench's default sensors: 10 mV and 50 mA (1 σ).
DEFAULT_NOISE = BenchNoise()
#: No measurement noise.
NO_NOISE = BenchNoise(0.0, 0.0)


# --------------------------------------------------------------------------- simulation

@dataclass
class BenchResult:
    """True (noise-free) time series of a bench run, up to where the load tripped.

    Sample ``k`` is the instant ``time_s[k]`` with the load of step ``k`` on.

    Attributes
    ----------
    time_s : ndarray
        [s]
    power_w : ndarray
        Power drawn, ``V·I`` (the asked power unless undeliverable). [W]
    current_a : ndarray
        Pack current. [A]
    voltage_v : ndarray
        Loaded terminal voltage. [V]
    soc : ndarray
        Bulk state of charge ``z`` (against the capacity at the temperature). [unitless]
    surface_deficit : ndarray
        Diffusion state ``x``; the surface SoC is ``soc − surface_deficit``. [unitless]
    charge_as : ndarray
        Charge drawn before ``time_s[k]``. [A s]
    cells_series : int
    capacity_as : float
        Capacity at the run's temperature, ``Q(T)``. [A s]
    v_cutoff_cell : float
        [V]
    cutoff_time_s, cutoff_charge_as : float or None
        When the loaded cell voltage first reached the cut-off (interpolated
        between samples, as ``circuit.simulate`` does) and the charge drawn by
        then; None when the schedule ended first. [s], [A s]
    undeliverable_time_s : float or None
        First time the asked power exceeded what the pack can deliver. [s]
    """

    time_s: np.ndarray
    power_w: np.ndarray
    current_a: np.ndarray
    voltage_v: np.ndarray
    soc: np.ndarray
    surface_deficit: np.ndarray
    charge_as: np.ndarray
    cells_series: int
    capacity_as: float
    v_cutoff_cell: float
    cutoff_time_s: float | None = None
    cutoff_charge_as: float | None = None
    undeliverable_time_s: float | None = None

    @property
    def tripped(self) -> bool:
        """True when the run ended at the cut-off (not at the end of the schedule)."""
        return self.cutoff_time_s is not None

    @property
    def withheld_charge_as(self) -> float:
        """Charge still bound by diffusion at the last sample, ``Q(T)·x``. [A s]"""
        return float(self.capacity_as * self.surface_deficit[-1])


def simulate_bench(pack: BenchPack, time_s, power_w, *, temperature_c: float = 25.0,
                   soc0: float = 1.0, stop_at_cutoff: bool = True) -> BenchResult:
    r"""
    Run the bench pack through a power profile (noise-free truth).

    Parameters
    ----------
    pack : BenchPack
    time_s : array_like
        Sample times, increasing. [s]
    power_w : numeric
        Power drawn, held from each sample to the next; 0 = load off. [W]
    temperature_c : float, default 25
        Cell temperature, constant (isothermal bench). [°C]
    soc0 : float, default 1
        Initial (bulk) state of charge; the surface starts in equilibrium. [unitless]
    stop_at_cutoff : bool, default True
        End the run at the first sample whose loaded cell voltage is at or
        below ``pack.v_cutoff_cell`` (that sample is kept). Otherwise run to
        the end (the cut-off event is still recorded).

    Returns
    -------
    BenchResult

    Raises
    ------
    InputError
        Times not increasing, lengths, negative or non-finite power, ``soc0``.
    ModelError
        A temperature outside the battery model's range.

    Notes
    -----
    Per step, in this order: the state at the start of the step gives the
    surface SoC, OCV and R0; the current is solved from the power; the sample
    (and the cut-off test) is recorded; the states advance over the step with
    the current held (exact updates of ``z``, ``x``, ``v1``, ``h``): this is
    :func:`planner.physics.battery.circuit.simulate` at a constant temperature with
    ``diffusion=(available_fraction, diffusion_tau_s)`` and ``end_at_cutoff``.
    """
    t = np.asarray(time_s, dtype=float).ravel()
    n = t.size
    if n == 0:
        raise InputError("time_s is empty")
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise InputError("time_s must be finite and increasing")
    p_arr = circuit.series_input(power_w, n, "power_w")
    if np.any(p_arr < 0):
        raise InputError("power_w must be >= 0 (the bench discharges only)")
    if not 0.0 <= float(soc0) <= 1.0:
        raise InputError(f"soc0 must lie in [0, 1], got {soc0!r}")
    temp = float(temperature_c)
    check_temperature(temp, "cell temperature")

    p = pack.circuit
    fq = 1.0 - p.capacity_temp_coeff_per_c * max(0.0, p.reference_temperature_c - temp)
    r = circuit.simulate(p, t, power_w=p_arr, soc0=soc0, temperature_c=temp,
                         v_cutoff_cell=pack.v_cutoff_cell, end_at_cutoff=stop_at_cutoff,
                         diffusion=(pack.available_fraction, pack.diffusion_tau_s))
    return BenchResult(
        time_s=r.time_s, power_w=r.power_w, current_a=r.current_a, voltage_v=r.voltage_v,
        soc=r.soc, surface_deficit=r.surface_deficit, charge_as=r.charge_as,
        cells_series=r.cells_series, capacity_as=pack.capacity_as * fq,
        v_cutoff_cell=float(pack.v_cutoff_cell), cutoff_time_s=r.cutoff_time_s,
        cutoff_charge_as=r.cutoff_charge_as, undeliverable_time_s=r.undeliverable_time_s)


# --------------------------------------------------------------------------- records

def _rng(seed) -> np.random.Generator:
    return seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)


def to_record(result: BenchResult, experiment: str, noise: BenchNoise = DEFAULT_NOISE,
              seed=None) -> pd.DataFrame:
    """The flight record a logger on the bench writes (docs/record.md), with measurement noise.

    Parameters
    ----------
    result : BenchResult
    experiment : str
        Experiment id.
    noise : BenchNoise
    seed : int, numpy.random.Generator or None
        Random source of the noise; the same seed gives the same record.

    Returns
    -------
    DataFrame
        Columns :data:`RECORD_COLUMNS`: ``voltage_v`` and ``current_a`` are
        the true values plus noise; ``power_w`` their product while the load
        is on (0 when off); ``consumed_mah`` the running sum of measured
        current × interval before each sample.
    """
    rng = _rng(seed)
    n = result.time_s.size
    v = result.voltage_v + rng.normal(0.0, noise.voltage_v, n) if noise.voltage_v else \
        result.voltage_v.copy()
    i = result.current_a + rng.normal(0.0, noise.current_a, n) if noise.current_a else \
        result.current_a.copy()
    on = result.current_a > 0
    power = np.where(on, v * i, 0.0)
    dt = np.diff(result.time_s)
    consumed_as = np.concatenate(([0.0], np.cumsum(i[:-1] * dt)))
    return pd.DataFrame({"experiment": experiment, "time_s": result.time_s, "voltage_v": v,
                         "current_a": i, "power_w": power,
                         "consumed_mah": consumed_as / AS_PER_MAH},
                        columns=list(RECORD_COLUMNS))


def _grid_until(end_s: float, dt: float) -> np.ndarray:
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"dt_s must be > 0, got {dt!r}")
    if not (math.isfinite(end_s) and end_s > dt):
        raise ValueError(f"the run must last longer than one sample, got {end_s!r} s")
    return np.arange(0.0, end_s - dt / 2, dt)


def run_schedule(pack: BenchPack, schedule: pd.DataFrame, experiment: str, *,
                 dt_s: float = 1.0, noise: BenchNoise = DEFAULT_NOISE, seed=None,
                 temperature_c: float = 25.0,
                 return_truth: bool = False) -> pd.DataFrame | tuple[pd.DataFrame, BenchResult]:
    """Run a power schedule (:mod:`planner.identify.protocols`) on the bench and log it.

    The load follows the schedule (sampled every ``dt_s``) until its end or
    until the loaded voltage reaches the cut-off, whichever comes first.

    Parameters
    ----------
    pack : BenchPack
    schedule : DataFrame
        ``start_s``, ``duration_s``, ``power_w`` rows (powers >= 0). [s], [s], [W]
    experiment : str
        Experiment id of the record.
    dt_s : float, default 1
        Sample interval. [s]
    noise : BenchNoise
    seed : int or numpy.random.Generator, optional
        Random source of the measurement noise.
    temperature_c : float, default 25
        [°C]
    return_truth : bool, default False
        Also return the noise-free :class:`BenchResult`.

    Returns
    -------
    DataFrame, or (DataFrame, BenchResult)
    """
    end = float(schedule["start_s"].iloc[-1] + schedule["duration_s"].iloc[-1])
    t = _grid_until(end, float(dt_s))
    result = simulate_bench(pack, t, design.sample_schedule(schedule, t),
                            temperature_c=temperature_c)
    record = to_record(result, experiment, noise, seed)
    return (record, result) if return_truth else record


def constant_power_discharge(pack: BenchPack, power_w: float, experiment: str | None = None,
                             *, max_duration_s: float = 12 * 3600.0, **kwargs):
    """A constant-power discharge to the loaded cut-off.

    Parameters
    ----------
    power_w : float
        > 0. [W]
    experiment : str, optional
        Default ``const_{P:03.0f}W``.
    max_duration_s : float, default 12 h
        The run ends here if the cut-off is not reached. [s]
    **kwargs
        Passed to :func:`run_schedule` (``dt_s``, ``noise``, ``seed``, ...).
    """
    if not (math.isfinite(power_w) and power_w > 0):
        raise ValueError(f"power_w must be > 0, got {power_w!r}")
    schedule = pd.DataFrame({"start_s": [0.0], "duration_s": [float(max_duration_s)],
                             "power_w": [float(power_w)]})
    return run_schedule(pack, schedule, experiment or f"const_{power_w:03.0f}W", **kwargs)


def two_step_discharge(pack: BenchPack, p1_w: float, p2_w: float, k: float,
                       capacity_mah: float, experiment: str | None = None, **kwargs):
    """A two-step test designed with :func:`planner.identify.protocols.two_step` and run on the bench.

    The durations are those that draw ``capacity_mah`` under the pack's design
    model (``pack.model``, [UAV23]'s m_const by default, [UAV23] eq. 25–28); the
    bench runs them until the end or the cut-off.

    Parameters
    ----------
    p1_w, p2_w : float
        Powers of the two steps. [W]
    k : float
        ``t2 / t1``. [unitless]
    capacity_mah : float
        Charge ``C0`` the design draws. [mAh]
    experiment : str, optional
        Default ``two_step_{P1}_{P2}_k{k}``.
    **kwargs
        Passed to :func:`run_schedule`.
    """
    test = design.two_step(p1_w, p2_w, k, capacity_mah * AS_PER_MAH, **pack.model)
    name = experiment or f"two_step_{p1_w:03.0f}_{p2_w:03.0f}_k{k:g}"
    return run_schedule(pack, test.schedule(), name, **kwargs)


def aprbs_discharge(pack: BenchPack, schedule_seed, experiment: str | None = None, *,
                    levels_w: Sequence[float] = (50.0, 75.0, 100.0, 125.0),
                    hold_s: tuple[float, float] = (30.0, 300.0),
                    min_duration_s: float = 3500.0, **kwargs):
    """An APRBS test (:func:`planner.identify.protocols.aprbs`) run on the bench.

    Parameters
    ----------
    schedule_seed : int or numpy.random.Generator
        Random source of the schedule (levels and hold times).
    experiment : str, optional
        Default ``aprbs_{schedule_seed}``.
    levels_w, hold_s, min_duration_s
        As :func:`planner.identify.protocols.aprbs` (seed: 50/75/100/125 W,
        U[30, 300] s, >= 3500 s).
    **kwargs
        Passed to :func:`run_schedule` (its ``seed`` is the noise's).
    """
    schedule = design.aprbs(levels_w, hold_s, min_duration_s, schedule_seed)
    return run_schedule(pack, schedule, experiment or f"aprbs_{schedule_seed}", **kwargs)
