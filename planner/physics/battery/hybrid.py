r"""Passive battery ∥ supercapacitor hybrid pack ([HESS] eq. 12–14).

The battery (equivalent circuit of :mod:`planner.physics.battery.circuit`) and a
supercapacitor bank (:mod:`planner.physics.battery.supercap`) are wired directly in
parallel to the load; the circuit alone decides how the load current splits:

.. math::

    I_L = I_b + I_{sc}, \qquad
    V = E_b - v_{RC} - R_0 I_b
      = \text{(supercap terminal voltage at } I_{sc}\text{)}

with ``E_b = n_s (OCV(z) + h)``. The node is algebraic; with the load
current, ``E_b`` and the fast capacitance held over a step, the states
``[v_RC, v_f, v_s]`` follow a linear ODE that is stepped exactly with its
matrix exponential (zero-order hold), and the integrals of the battery
current and of its square over the step come from the same exponentials
(Van Loan's method). ``E_b`` is taken at the state of charge predicted for
the middle of the step, which makes the remaining (nonlinear OCV) error
second order in the step. State of charge, hysteresis and the fast-branch
voltage are then updated from those exact step integrals. With a power load
the load current of each step is solved in closed form from the node's
Thevenin equivalent, as in :func:`planner.physics.battery.circuit.simulate`.
The battery is isothermal here (a constant cell temperature).

Figures of merit
----------------
The same load is also run on the battery alone. Then

.. math::

    J_1 = \frac{\int |I_{b,hyb}|\,dt}{\int |I_{b,alone}|\,dt}, \qquad
    J_2 = \frac{\int I_{b,hyb}^2 R_0\,dt}{\int I_{b,alone}^2 R_0\,dt}

``J1`` is the battery's charge throughput with the hybrid over that without
(the charge throughput ratio of [HESS] Table 3), ``J2`` the ratio of the battery's ohmic
(Joule) losses — the energy the battery dissipates, which drives its heating
and ageing. Why ``J2 < J1``: over a periodic cycle the supercap returns what
it takes, so the battery still delivers the net charge and ``J1`` can only
fall where the battery current would change sign (the supercap bridges
short reversals). But the supercap cuts the *peaks* of the battery current,
and a square weighs a peak more: by the Cauchy–Schwarz inequality a
smoother current of the same mean has a smaller ``∫I²``, so the loss ratio
falls further than the throughput ratio. [HESS] Table 3 reports
``J1 = 0.78, J2 = 0.54`` for its lead-acid battery with the supercap bank in
the Start&Stop scenario of its FTP driving-cycle simulation (0.79 and 0.51 in
the conventional one); our LiPo example gives other numbers with the same
ordering.

Also reported: the peak battery current (largest magnitude) with and
without the supercap, and the voltage-sag margin: the lowest loaded pack
voltage minus the pack cut-off ``n_s·v_cutoff_cell``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from planner.errors import InputError, ModelError
from planner.physics.battery.circuit import (
    SOC_GRID_POINTS,
    CircuitParameters,
    CircuitResult,
    on_soc_grid,
    series_input,
    simulate,
    soc_grid,
)
from planner.physics.battery.elements import (
    delivered_current,
    hysteresis_step,
    pack_capacitance,
    pack_resistance,
)
from planner.physics.battery.supercap import (
    BCAP1500,
    SURGE_RATIO,
    LinearNode,
    SupercapParameters,
    matched_series_count,
)
from planner.physics.battery.thermal import check_temperature
from planner.physics.units import AS_PER_AH

#: Illustrative 4S2P LiPo pack of 10 Ah cells for the examples: R0 per cell from the
#: Multistar 10 Ah 4S pack of [UAV23] Table 2 (20.68 mΩ / 4 cells,
#: ``aircraft/batteries/multistar_10ah_4s.yaml``); R1, C1 (τ = 30 s) and the
#: hysteresis are typical orders of magnitude for LiPo cells, not a fit.
EXAMPLE_LIPO_PACK = CircuitParameters(
    capacity_ah=10.0, r0_ohm=0.00517, r1_ohm=0.0025, c1_f=12_000.0, hysteresis_v=0.01,
    hysteresis_gamma=30.0, cells_series=4, cells_parallel=2,
    source="illustrative; R0 from the Multistar 10 Ah 4S of [UAV23] Table 2 (20.68 mΩ "
           "pack)")


@dataclass
class HybridSummary:
    """Figures of merit of a hybrid run (see module notes).

    Attributes
    ----------
    j1 : float
        Battery charge-throughput ratio, hybrid over battery alone. [unitless]
    j2 : float
        Battery ohmic-loss ratio, hybrid over battery alone. [unitless]
    peak_battery_current_a, peak_battery_current_alone_a : float
        Largest battery current magnitude with and without the supercap. [A]
    min_voltage_v, min_voltage_alone_v : float
        Lowest loaded pack voltage with and without. [V]
    sag_margin_v, sag_margin_alone_v : float
        Lowest loaded voltage minus the pack cut-off, with and without. [V]
    supercap_cells : int
        Supercap cells in the bank.
    supercap_mass_kg : float or None
        Mass of the bank. [kg]
    """

    j1: float
    j2: float
    peak_battery_current_a: float
    peak_battery_current_alone_a: float
    min_voltage_v: float
    min_voltage_alone_v: float
    sag_margin_v: float
    sag_margin_alone_v: float
    supercap_cells: int
    supercap_mass_kg: float | None


@dataclass
class HybridResult:
    """Time series of :func:`simulate_hybrid` and its figures of merit.

    Sample ``k`` is the instant ``time_s[k]`` with the step's load applied.

    Attributes
    ----------
    time_s : ndarray [s]
    load_current_a : ndarray
        Load current, discharge positive. [A]
    power_w : ndarray
        Power delivered to the load. [W]
    voltage_v : ndarray
        Common (node) voltage. [V]
    battery_current_a, supercap_current_a : ndarray
        Branch currents, discharge positive. [A]
    soc : ndarray
        Battery state of charge. [unitless]
    supercap_voltage_v, supercap_slow_voltage_v : ndarray
        Bank voltages of the fast and slow branch capacitors. [V]
    battery_throughput_as : float
        ``∫|I_b| dt`` with the hybrid. [A s]
    battery_loss_j : float
        ``∫ I_b² R0 dt`` with the hybrid. [J]
    alone : CircuitResult or None
        The battery alone on the same load.
    j1, j2 : float
        Figures of merit (module notes); 1 when the battery alone carries nothing.
    max_supercap_cell_v : float
        Highest fast-branch cell voltage reached. [V]
    undeliverable_time_s : float or None
        First time the asked power exceeded what the node can deliver. [s]
    v_cutoff_cell : float
        Cell cut-off for the sag margin. [V]
    cells_series : int
        Battery cells in series.
    supercap : SupercapParameters
    """

    time_s: np.ndarray
    load_current_a: np.ndarray
    power_w: np.ndarray
    voltage_v: np.ndarray
    battery_current_a: np.ndarray
    supercap_current_a: np.ndarray
    soc: np.ndarray
    supercap_voltage_v: np.ndarray
    supercap_slow_voltage_v: np.ndarray
    battery_throughput_as: float
    battery_loss_j: float
    alone: CircuitResult | None
    j1: float
    j2: float
    max_supercap_cell_v: float
    undeliverable_time_s: float | None
    v_cutoff_cell: float
    cells_series: int
    supercap: SupercapParameters

    @property
    def peak_battery_current_a(self) -> float:
        """Largest battery current magnitude with the supercap. [A]"""
        return float(np.max(np.abs(self.battery_current_a)))

    @property
    def sag_margin_v(self) -> float:
        """Lowest loaded pack voltage less the pack cut-off ``n_s·v_cutoff_cell``. [V]"""
        return float(np.min(self.voltage_v) - self.cells_series * self.v_cutoff_cell)

    def summary(self) -> HybridSummary:
        """The figures of merit with and without the supercap."""
        alone = self.alone
        if alone is None:
            raise InputError("summary needs the battery-alone run (compare=True)")
        return HybridSummary(
            j1=self.j1, j2=self.j2, peak_battery_current_a=self.peak_battery_current_a,
            peak_battery_current_alone_a=float(np.max(np.abs(alone.current_a))),
            min_voltage_v=float(np.min(self.voltage_v)),
            min_voltage_alone_v=float(np.min(alone.voltage_v)),
            sag_margin_v=self.sag_margin_v,
            sag_margin_alone_v=float(np.min(alone.voltage_v)
                                     - self.cells_series * self.v_cutoff_cell),
            supercap_cells=self.supercap.n_cells, supercap_mass_kg=self.supercap.bank_mass_kg)


def matched_bank(supercap: SupercapParameters, battery: CircuitParameters,
                 cells_parallel: int = 1) -> SupercapParameters:
    """The supercap bank matched to a battery: fewest cells in series whose rated
    voltage covers the battery's full open-circuit voltage ``n_s·OCV(1)``."""
    v_full = float(battery.ocv_pack_v(1.0))
    return supercap.bank(matched_series_count(v_full, supercap.v_rated_v), cells_parallel)


def simulate_hybrid(battery: CircuitParameters, supercap: SupercapParameters, time_s, *,
                    power_w=None, current_a=None, soc0: float = 1.0,
                    temperature_c: float = 25.0, v_cutoff_cell: float = 3.5,
                    supercap_v0_v: float | None = None, compare: bool = True,
                    rtol: float = 1e-3) -> HybridResult:
    """
    Run the passive battery ∥ supercapacitor pack through a load profile.

    Parameters
    ----------
    battery : CircuitParameters
        The battery pack (its R0 must be > 0).
    supercap : SupercapParameters
        The supercap bank (``cells_series``/``cells_parallel`` set; see
        :func:`matched_bank`).
    time_s : array_like
        Sample times, non-decreasing. [s]
    power_w, current_a : numeric
        The load, power or current (give one), held over each step. [W], [A]
    soc0 : float, default 1
        Initial battery state of charge. [unitless]
    temperature_c : float, default 25
        Battery cell temperature (isothermal). [°C]
    v_cutoff_cell : float, default 3.5
        Battery cell cut-off for the sag margin (the default ``cell_voltage_empty_v`` of a
        pack file, ``docs/formats.md``). [V]
    supercap_v0_v : float, optional
        Initial supercap bank voltage; default the battery's open-circuit
        voltage at ``soc0`` (a bank kept connected to the battery). [V]
    compare : bool, default True
        Also run the battery alone and compute J1 and J2.
    rtol : float, default 1e-3
        Relative change of R0 or of the fast capacitance after which the step
        matrices are recomputed.

    Returns
    -------
    HybridResult

    Raises
    ------
    InputError
        Bad arguments.
    ModelError
        Temperature outside [−20 °C, 60 °C]; a supercap cell voltage above its
        surge voltage at the start (too few cells in series).
    """
    load = _load(time_s, power_w, current_a, soc0, temperature_c)
    pack = _HybridBattery.of(battery, float(temperature_c))
    node = LinearNode(supercap, r1p=pack.r1p, c1p=pack.c1p, quadratic=True, rtol=rtol)
    v0 = _bank_voltage(pack, supercap, float(soc0), supercap_v0_v)
    run = _run(load, pack, supercap, node, float(soc0), v0)
    alone, j1, j2 = (_battery_alone(battery, load, float(soc0), v_cutoff_cell, run)
                     if compare else (None, 1.0, 1.0))
    return HybridResult(
        time_s=load.t, load_current_a=run["il"], power_w=run["p"], voltage_v=run["v"],
        battery_current_a=run["ib"], supercap_current_a=run["il"] - run["ib"],
        soc=run["z"], supercap_voltage_v=run["vf"], supercap_slow_voltage_v=run["vs"],
        battery_throughput_as=run["throughput"], battery_loss_j=run["loss"], alone=alone,
        j1=j1, j2=j2, max_supercap_cell_v=run["vf_max"],
        undeliverable_time_s=run["undeliverable"], v_cutoff_cell=float(v_cutoff_cell),
        cells_series=battery.cells_series, supercap=supercap)


@dataclass
class _Load:
    """The load of a hybrid run: times [s], steps [s], power [W] or current [A]."""

    t: np.ndarray
    dt: np.ndarray
    values: np.ndarray
    by_power: bool
    temperature_c: float


def _load(time_s, power_w, current_a, soc0, temperature_c) -> _Load:
    """The run's times and load, checked (:class:`InputError` on bad arguments)."""
    if (power_w is None) == (current_a is None):
        raise InputError("give exactly one of power_w and current_a")
    t = np.asarray(time_s, dtype=float).ravel()
    n = t.size
    if n == 0 or not np.all(np.isfinite(t)):
        raise InputError("time_s must be a non-empty list of finite times")
    dt = np.diff(t)
    if np.any(dt < 0):
        raise InputError("time_s must not decrease")
    by_power = power_w is not None
    values = series_input(power_w if by_power else current_a, n,
                          "power_w" if by_power else "current_a")
    if not (0.0 <= soc0 <= 1.0):
        raise InputError(f"soc0 must lie in [0, 1], got {soc0!r}")
    if np.ndim(temperature_c) != 0:
        raise InputError("the hybrid model is isothermal: temperature_c must be one number")
    check_temperature(float(temperature_c), "cell temperature")
    return _Load(t, dt, values, by_power, float(temperature_c))


@dataclass
class _HybridBattery:
    """The battery of a hybrid run at its (constant) temperature, at pack level: layout,
    capacity available [A s], R0(T) factor, hysteresis, RC branch [Ω], [F] and the OCV
    and R0 tables on the SoC grid (:func:`~planner.physics.battery.circuit.soc_grid`)."""

    params: CircuitParameters
    ns: int
    npar: int
    r0_factor: float
    cap_as: float
    r1p: float
    c1p: float
    tables: np.ndarray

    @classmethod
    def of(cls, b: CircuitParameters, temperature_c: float) -> _HybridBattery:
        ns, npar = b.cells_series, b.cells_parallel
        r0 = (np.interp(np.linspace(0.0, 1.0, SOC_GRID_POINTS), b.r0_ohm[0], b.r0_ohm[1])
              if b.r0_is_table else np.full(SOC_GRID_POINTS, float(b.r0_ohm)))
        if r0.min() <= 0:
            raise InputError("the hybrid model needs the battery's r0_ohm > 0")
        return cls(b, ns, npar, b.arrhenius_factor(temperature_c),
                   b.capacity_ah * AS_PER_AH * b.capacity_factor(temperature_c),
                   pack_resistance(b.r1_ohm, ns, npar),
                   pack_capacitance(b.c1_f, ns, npar) if b.r1_ohm > 0 else 1.0,
                   np.vstack([soc_grid(b.ocv), r0]))

    def source_v(self, z: float, h: float) -> float:
        """``E_b = n_s (OCV(z) + h)`` at the state of charge ``z``. [V]"""
        return self.ns * (on_soc_grid(self.tables, 0, z) + h)

    def r0_pack_ohm(self, z: float) -> float:
        """Pack R0 at the state of charge ``z`` and the run's temperature. [Ω]"""
        return pack_resistance(on_soc_grid(self.tables, 1, z) * self.r0_factor, self.ns,
                               self.npar)


def _bank_voltage(pack: _HybridBattery, sc: SupercapParameters, soc0, v0_v) -> float:
    """The bank's starting voltage [V]: given, or the battery's at ``soc0``; a cell above
    its surge voltage raises :class:`ModelError` naming the series count it needs."""
    v0 = pack.source_v(soc0, 0.0) if v0_v is None else float(v0_v)
    nss = sc.cells_series
    if not (0.0 <= v0 / nss <= sc.v_rated_v * SURGE_RATIO):
        need = matched_series_count(v0, sc.v_rated_v)
        raise ModelError(f"supercap: {v0:.2f} V on {nss} cells in series is {v0 / nss:.2f} V "
                         f"per cell, outside [0 V, {sc.v_rated_v * SURGE_RATIO:.2f} V] (rated "
                         f"{sc.v_rated_v} V, surge {sc.v_rated_v * SURGE_RATIO:.2f} V); use at "
                         f"least {need} cells in series")
    return v0


def _run(load: _Load, pack: _HybridBattery, sc: SupercapParameters, node: LinearNode,
         soc0: float, v0: float) -> dict:
    """The time loop (module notes): per step the node's load current, the branch
    currents, then the exact step of the states and of the battery's throughput and
    Joule loss. Returns the series and totals of :class:`HybridResult`."""
    b, t, dt, n = pack.params, load.t, load.dt, load.t.size
    nss, nps = sc.cells_series, sc.cells_parallel
    gamma = b.hysteresis_gamma if b.hysteresis_v > 0 else 0.0
    z, h, v_rc, vf_cell, vs = soc0, 0.0, 0.0, v0 / nss, v0
    d_prev = float(dt[dt > 0][0]) if np.any(dt > 0) else 1.0
    out = {key: np.empty(n) for key in ("il", "p", "v", "ib", "z", "vf", "vs")}
    throughput = loss = 0.0
    undeliverable = None
    vf_max = vf_cell
    for k in range(n):
        r0p = pack.r0_pack_ohm(z)
        e_b = pack.source_v(z, h)
        d = dt[k] if k < n - 1 else 0.0
        if d > 0:
            d_prev = d
        node.prepare(1.0 / r0p, sc.bank_fast_capacitance_f(vf_cell), d_prev)
        x = np.array([v_rc, vf_cell * nss, vs])
        v_oc = node.a_node @ x + node.b_node[0] * e_b
        r_node = -node.b_node[1]
        i_l, delivered = _load_current(load, k, v_oc, r_node)
        if not delivered and undeliverable is None:
            undeliverable = float(t[k])
        y = np.array([x[0], x[1], x[2], e_b, i_l])
        v_node = v_oc - r_node * i_l
        i_b = node.w_b @ y
        for key, value in (("il", i_l), ("p", v_node * i_l), ("v", v_node), ("ib", i_b),
                           ("z", z), ("vf", vf_cell * nss), ("vs", vs)):
            out[key][k] = value
        if d <= 0.0:
            continue
        # OCV at the predicted mid-step state of charge (second-order in the step)
        y[3] = pack.source_v(z - 0.5 * (i_b * d / pack.npar) / pack.cap_as, h)
        y1 = node.phi @ y
        iy = node.integral @ y
        qb = float(node.w_b @ iy)
        throughput += abs(qb)
        loss += float(y @ node.w_quad @ y) * r0p
        dq = qb / pack.npar
        if dq < 0:
            dq *= b.coulombic_efficiency
        z -= dq / pack.cap_as
        if gamma > 0.0 and dq != 0.0:
            h = hysteresis_step(h, dq, pack.cap_as, gamma, b.hysteresis_v)
        v_rc = float(y1[0]) if b.r1_ohm > 0 else 0.0
        vs = float(y1[2]) if sc.r_slow_ohm is not None else vs
        vf_cell = sc.fast_voltage_after(vf_cell, float(node.w_f @ iy) / nps)
        vf_max = max(vf_max, vf_cell)
    return out | {"throughput": throughput, "loss": loss, "undeliverable": undeliverable,
                  "vf_max": vf_max}


def _load_current(load: _Load, k: int, v_oc: float, r_node: float) -> tuple[float, bool]:
    """Load current of step ``k`` [A] from the node's Thevenin equivalent (open-circuit
    voltage [V], resistance [Ω]), and whether the asked power was delivered."""
    if not load.by_power:
        return float(load.values[k]), True
    if load.values[k] == 0.0:
        return 0.0, True
    current, delivered = delivered_current(float(load.values[k]), float(v_oc), float(r_node))
    return float(current), bool(delivered)


def _battery_alone(b: CircuitParameters, load: _Load, soc0: float, v_cutoff_cell: float,
                   run: dict):
    """The battery alone on the same load (:func:`simulate`) and the figures of merit
    J1, J2 of the module notes (1 where the battery alone carries nothing)."""
    kw = {"power_w": load.values} if load.by_power else {"current_a": load.values}
    alone = simulate(b, load.t, soc0=soc0, temperature_c=load.temperature_c,
                     v_cutoff_cell=v_cutoff_cell, **kw)
    steps = np.r_[load.dt, 0.0]
    thr_alone = float(np.sum(np.abs(alone.current_a) * steps))
    loss_alone = float(np.sum(alone.current_a ** 2 * steps
                              * b.r0_pack_ohm(alone.soc.clip(0, 1), load.temperature_c)))
    j1 = run["throughput"] / thr_alone if thr_alone > 0 else 1.0
    j2 = run["loss"] / loss_alone if loss_alone > 0 else 1.0
    return alone, j1, j2


# --------------------------------------------------------------------------- examples

def start_stop_cycle(dt_s: float = 0.5, repetitions: int = 30, *, load_a: float = 45.0,
                     load_s: float = 59.0, crank_a: float = 100.0, crank_s: float = 3.0,
                     charge_s: float = 60.0, charge_a: float | None = None):
    """
    The Start&Stop validation profile of [HESS].

    Engine off: ``load_a`` for ``load_s``; crank: ``crank_a`` for
    ``crank_s``; engine running: charge for ``charge_s``; repeated.

    Parameters
    ----------
    dt_s : float
        Sample interval; the phase durations should be multiples of it. [s]
    repetitions : int
    charge_a : float, optional
        Charging current (negative); default the charge-neutral value
        ``−(load_a·load_s + crank_a·crank_s)/charge_s`` (−49.25 A): [HESS]'s
        alternator phase is modelled as a constant current that returns the
        charge drawn. [A]

    Returns
    -------
    time_s, current_a : ndarray
        Samples ``0, dt, …, T`` (the last sample ends the profile). [s], [A]
    """
    if charge_a is None:
        charge_a = -(load_a * load_s + crank_a * crank_s) / charge_s
    period = load_s + crank_s + charge_s
    t = np.arange(0.0, repetitions * period + dt_s / 2, dt_s)
    return t, _phases(np.mod(t, period), (load_s, load_s + crank_s),
                      (load_a, crank_a, charge_a))


def _phases(t, ends, values):
    """``values[i]`` where ``t`` lies before ``ends[i]`` (and after the ends before it),
    the last value after the last end: a profile of constant phases (units of
    ``values``; ``t`` and ``ends`` in s, compared to 1e-9 s)."""
    out = np.full(np.shape(t), values[-1], dtype=float)
    for end, value in reversed(list(zip(ends, values[:-1]))):
        out = np.where(t < end - 1e-9, value, out)
    return out


def start_stop_example(battery: CircuitParameters | None = None,
                       supercap: SupercapParameters | None = None, *, dt_s: float = 0.5,
                       repetitions: int = 30, soc0: float = 0.8,
                       temperature_c: float = 25.0) -> HybridResult:
    """The Start&Stop cycle on a battery with and without a supercap bank.

    Defaults: :data:`EXAMPLE_LIPO_PACK` (4S2P, 20 Ah) and BCAP1500 cells,
    7 in series (:func:`matched_bank`: 7 × 2.7 V = 18.9 V covers the full
    4S open-circuit voltage, 16.4 V; 2.34 V per cell at full charge).
    """
    battery, supercap = _example_pack(battery, supercap)
    t, cur = start_stop_cycle(dt_s, repetitions)
    return simulate_hybrid(battery, supercap, t, current_a=cur, soc0=soc0,
                           temperature_c=temperature_c)


def _example_pack(battery, supercap):
    """The examples' battery (default :data:`EXAMPLE_LIPO_PACK`) and its bank of
    ``supercap`` cells (default BCAP1500), matched by :func:`matched_bank`."""
    battery = EXAMPLE_LIPO_PACK if battery is None else battery
    return battery, matched_bank(BCAP1500 if supercap is None else supercap, battery)


def takeoff_profile(*, idle_w: float = 50.0, idle_s: float = 10.0, takeoff_w: float = 1800.0,
                    takeoff_s: float = 20.0, hover_w: float = 900.0, hover_s: float = 120.0,
                    dt_s: float = 0.1):
    """Electric power of a heavy multirotor: idle, take-off/climb peak, hover. [s], [W]"""
    total = idle_s + takeoff_s + hover_s
    t = np.arange(0.0, total + dt_s / 2, dt_s)
    return t, _phases(t, (idle_s, idle_s + takeoff_s), (idle_w, takeoff_w, hover_w))


def takeoff_example(battery: CircuitParameters | None = None,
                    supercap: SupercapParameters | None = None, *, soc0: float = 1.0,
                    temperature_c: float = 25.0, v_cutoff_cell: float = 3.5,
                    **profile) -> HybridSummary:
    """
    UAV take-off/climb power peak with and without a supercap bank.

    Parameters
    ----------
    battery : CircuitParameters, optional
        Default :data:`EXAMPLE_LIPO_PACK`.
    supercap : SupercapParameters, optional
        Cell type; the bank is matched to the battery (:func:`matched_bank`).
        Default BCAP1500.
    soc0, temperature_c, v_cutoff_cell :
        As in :func:`simulate_hybrid`.
    **profile :
        Passed to :func:`takeoff_profile` (``takeoff_w``, ``hover_w``, …).

    Returns
    -------
    HybridSummary
        Peak battery current, J1, J2 and the sag margin with and without.
    """
    battery, supercap = _example_pack(battery, supercap)
    t, p = takeoff_profile(**profile)
    res = simulate_hybrid(battery, supercap, t, power_w=p, soc0=soc0,
                          temperature_c=temperature_c, v_cutoff_cell=v_cutoff_cell)
    return res.summary()


__all__ = ["BCAP1500", "EXAMPLE_LIPO_PACK", "HybridResult", "HybridSummary", "matched_bank",
           "simulate_hybrid", "start_stop_cycle", "start_stop_example", "takeoff_example",
           "takeoff_profile"]
