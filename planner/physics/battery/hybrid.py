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
(the seed's charge-throughput share), ``J2`` the ratio of the battery's ohmic
(Joule) losses — the energy the battery dissipates, which drives its heating
and ageing. Why ``J2 < J1``: over a periodic cycle the supercap returns what
it takes, so the battery still delivers the net charge and ``J1`` can only
fall where the battery current would change sign (the supercap bridges
short reversals). But the supercap cuts the *peaks* of the battery current,
and a square weighs a peak more: by the Cauchy–Schwarz inequality a
smoother current of the same mean has a smaller ``∫I²``, so the loss ratio
falls further than the throughput ratio. The seed paper reports
``J1 = 0.79, J2 = 0.51`` (its Table 3) for its lead-acid battery and
supercap bank on the Start&Stop cycle; our LiPo example gives other numbers
with the same ordering.

Also reported: the peak battery current (largest magnitude) with and
without the supercap, and the voltage-sag margin: the lowest loaded pack
voltage minus the pack cut-off ``n_s·v_cutoff_cell``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from planner.physics.battery import circuit as _circuit
from planner.physics.battery.circuit import CircuitParameters, CircuitResult, simulate
from planner.physics.battery.supercap import (
    BCAP1500,
    SupercapParameters,
    _LinearNode,
    matched_series_count,
)
from planner.physics.battery.thermal import check_temperature
from planner.errors import InputError, ModelError

#: Surge voltage of a supercap cell relative to its rated voltage (Maxwell K2: 2.85/2.7 V).
SURGE_RATIO = 2.85 / 2.7

#: Illustrative 4S2P LiPo pack of 10 Ah cells for the examples: R0 per cell from the
#: Multistar 10 Ah 4S pack of DESIGN §8 (20.68 mΩ / 4 cells); R1, C1 (τ = 30 s) and the
#: hysteresis are typical orders of magnitude for LiPo cells, not a fit.
EXAMPLE_LIPO_PACK = CircuitParameters(
    capacity_ah=10.0, r0_ohm=0.00517, r1_ohm=0.0025, c1_f=12_000.0, hysteresis_v=0.01,
    hysteresis_gamma=30.0, cells_series=4, cells_parallel=2,
    source="illustrative; R0 from DESIGN §8 Multistar 10 Ah 4S (20.68 mΩ pack)")


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
        return float(np.max(np.abs(self.battery_current_a)))

    @property
    def sag_margin_v(self) -> float:
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
        Battery cell cut-off for the sag margin (DESIGN §8 default). [V]
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
    load = _circuit._as_series_input(power_w if by_power else current_a, n,
                                     "power_w" if by_power else "current_a")
    if not (0.0 <= soc0 <= 1.0):
        raise InputError(f"soc0 must lie in [0, 1], got {soc0!r}")
    if np.ndim(temperature_c) != 0:
        raise InputError("the hybrid model is isothermal: temperature_c must be one number")
    temperature_c = float(temperature_c)
    check_temperature(temperature_c, "cell temperature")

    b, sc = battery, supercap
    ns, npb = b.cells_series, b.cells_parallel
    fa = b.arrhenius_factor(temperature_c)
    cap_as = b.capacity_ah * 3600.0 * b.capacity_factor(temperature_c)
    eta_c = b.coulombic_efficiency
    m_h = b.hysteresis_v
    gamma = b.hysteresis_gamma if m_h > 0 else 0.0
    r1p = b.r1_ohm * ns / npb
    c1p = (b.c1_f * npb / ns) if b.r1_ohm > 0 else 1.0
    ocv_g = _circuit._grid(b.ocv)
    gn = _circuit._GRID_N - 1
    zgrid = np.linspace(0.0, 1.0, _circuit._GRID_N)
    r0_g = (np.interp(zgrid, b.r0_ohm[0], b.r0_ohm[1]) if b.r0_is_table
            else np.full(_circuit._GRID_N, float(b.r0_ohm))).tolist()
    if min(r0_g) <= 0:
        raise InputError("the hybrid model needs the battery's r0_ohm > 0")

    nss, nps = sc.cells_series, sc.cells_parallel
    has_slow = sc.r_slow_ohm is not None
    node = _LinearNode(
        g0=0.0, r1p=r1p, c1p=c1p, gf=nps / (nss * sc.r_fast_ohm),
        gs=nps / (nss * sc.r_slow_ohm) if has_slow else 0.0,
        cs=sc.c_slow_f * nps / nss if has_slow else 1.0,
        gl=nps / (nss * sc.r_leak_ohm) if sc.r_leak_ohm is not None else 0.0,
        quadratic=True, rtol=rtol)

    def interp(grid, z):
        x = min(max(z, 0.0), 1.0) * gn
        j = min(int(x), gn - 1)
        return grid[j] + (x - j) * (grid[j + 1] - grid[j])

    z = float(soc0)
    h = 0.0
    v_rc = 0.0
    e0 = ns * (interp(ocv_g, z) + h)
    v0 = e0 if supercap_v0_v is None else float(supercap_v0_v)
    if not (0.0 <= v0 / nss <= sc.v_rated_v * SURGE_RATIO):
        need = matched_series_count(v0, sc.v_rated_v)
        raise ModelError(f"supercap: {v0:.2f} V on {nss} cells in series is {v0 / nss:.2f} V "
                         f"per cell, outside [0 V, {sc.v_rated_v * SURGE_RATIO:.2f} V] (rated "
                         f"{sc.v_rated_v} V, surge {sc.v_rated_v * SURGE_RATIO:.2f} V); use at "
                         f"least {need} cells in series")
    vf_cell = v0 / nss
    vs = v0
    d_prev = float(dt[dt > 0][0]) if np.any(dt > 0) else 1.0

    out_il = np.empty(n)
    out_p = np.empty(n)
    out_v = np.empty(n)
    out_ib = np.empty(n)
    out_z = np.empty(n)
    out_vf = np.empty(n)
    out_vs = np.empty(n)
    throughput = 0.0
    loss = 0.0
    undeliverable = None
    vf_max = vf_cell
    for k in range(n):
        r0p = ns * interp(r0_g, z) * fa / npb
        g0 = 1.0 / r0p
        e_b = ns * (interp(ocv_g, z) + h)
        cf = (sc.c0_f + sc.cv_f_per_v * vf_cell) * nps / nss
        d = dt[k] if k < n - 1 else 0.0
        if d > 0:
            d_prev = d
        node.prepare(g0, cf, d_prev)
        x = np.array([v_rc, vf_cell * nss, vs])
        v_oc = node.a_node @ x + node.b_node[0] * e_b
        r_node = -node.b_node[1]
        if by_power:
            pw = load[k]
            disc = v_oc * v_oc - 4.0 * r_node * pw
            if pw == 0.0:
                i_l = 0.0
            elif disc >= 0.0 and v_oc + math.sqrt(disc) > 0.0:
                i_l = 2.0 * pw / (v_oc + math.sqrt(disc))
            else:
                i_l = v_oc / (2.0 * r_node) if v_oc > 0 else 0.0
                if undeliverable is None:
                    undeliverable = float(t[k])
        else:
            i_l = load[k]
        y = np.array([x[0], x[1], x[2], e_b, i_l])
        v_node = v_oc - r_node * i_l
        i_b = node.w_b @ y
        out_il[k] = i_l
        out_p[k] = v_node * i_l
        out_v[k] = v_node
        out_ib[k] = i_b
        out_z[k] = z
        out_vf[k] = vf_cell * nss
        out_vs[k] = vs
        if d <= 0.0:
            continue
        # OCV at the predicted mid-step state of charge (second-order in the step)
        dq_pred = i_b * d / npb
        y[3] = ns * (interp(ocv_g, z - 0.5 * dq_pred / cap_as) + h)
        y1 = node.phi @ y
        iy = node.integral @ y
        qb = float(node.w_b @ iy)
        throughput += abs(qb)
        loss += float(y @ node.w_quad @ y) * r0p
        dq = qb / npb
        if dq < 0:
            dq *= eta_c
        z -= dq / cap_as
        if gamma > 0.0 and dq != 0.0:
            eh = math.exp(-gamma * abs(dq) / cap_as)
            h = eh * h + (1.0 - eh) * (-m_h if dq > 0 else m_h)
        v_rc = float(y1[0]) if b.r1_ohm > 0 else 0.0
        vs = float(y1[2]) if has_slow else vs
        q_out_cell = float(node.w_f @ iy) / nps
        vf_cell = sc.fast_voltage(sc.fast_charge(vf_cell) - q_out_cell)
        vf_max = max(vf_max, vf_cell)

    alone = None
    j1 = j2 = 1.0
    if compare:
        kw = {"power_w": load} if by_power else {"current_a": load}
        alone = simulate(b, t, soc0=soc0, temperature_c=temperature_c,
                         v_cutoff_cell=v_cutoff_cell, **kw)
        steps = np.r_[dt, 0.0]
        thr_alone = float(np.sum(np.abs(alone.current_a) * steps))
        loss_alone = float(np.sum(alone.current_a ** 2 * steps
                                  * b.r0_pack_ohm(alone.soc.clip(0, 1), temperature_c)))
        j1 = throughput / thr_alone if thr_alone > 0 else 1.0
        j2 = loss / loss_alone if loss_alone > 0 else 1.0
    return HybridResult(
        time_s=t, load_current_a=out_il, power_w=out_p, voltage_v=out_v,
        battery_current_a=out_ib, supercap_current_a=out_il - out_ib, soc=out_z,
        supercap_voltage_v=out_vf, supercap_slow_voltage_v=out_vs,
        battery_throughput_as=throughput, battery_loss_j=loss, alone=alone, j1=j1, j2=j2,
        max_supercap_cell_v=vf_max, undeliverable_time_s=undeliverable,
        v_cutoff_cell=float(v_cutoff_cell), cells_series=ns, supercap=sc)


# --------------------------------------------------------------------------- examples

def start_stop_cycle(dt_s: float = 0.5, repetitions: int = 30, *, load_a: float = 45.0,
                     load_s: float = 59.0, crank_a: float = 100.0, crank_s: float = 3.0,
                     charge_s: float = 60.0, charge_a: float | None = None):
    """
    The seed paper's Start&Stop current cycle.

    Engine off: ``load_a`` for ``load_s``; crank: ``crank_a`` for
    ``crank_s``; engine running: charge for ``charge_s``; repeated.

    Parameters
    ----------
    dt_s : float
        Sample interval; the phase durations should be multiples of it. [s]
    repetitions : int
    charge_a : float, optional
        Charging current (negative); default the charge-neutral value
        ``−(load_a·load_s + crank_a·crank_s)/charge_s`` (−49.25 A): the seed's
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
    phase = np.mod(t, period)
    cur = np.where(phase < load_s - 1e-9, load_a,
                   np.where(phase < load_s + crank_s - 1e-9, crank_a, charge_a))
    return t, cur


def start_stop_example(battery: CircuitParameters | None = None,
                       supercap: SupercapParameters | None = None, *, dt_s: float = 0.5,
                       repetitions: int = 30, soc0: float = 0.8,
                       temperature_c: float = 25.0) -> HybridResult:
    """The Start&Stop cycle on a battery with and without a supercap bank.

    Defaults: :data:`EXAMPLE_LIPO_PACK` (4S2P, 20 Ah) and BCAP1500 cells,
    7 in series (:func:`matched_bank`: 7 × 2.7 V = 18.9 V covers the full
    4S open-circuit voltage, 16.4 V; 2.34 V per cell at full charge).
    """
    battery = EXAMPLE_LIPO_PACK if battery is None else battery
    supercap = matched_bank(BCAP1500 if supercap is None else supercap, battery)
    t, cur = start_stop_cycle(dt_s, repetitions)
    return simulate_hybrid(battery, supercap, t, current_a=cur, soc0=soc0,
                           temperature_c=temperature_c)


def takeoff_profile(*, idle_w: float = 50.0, idle_s: float = 10.0, takeoff_w: float = 1800.0,
                    takeoff_s: float = 20.0, hover_w: float = 900.0, hover_s: float = 120.0,
                    dt_s: float = 0.1):
    """Electric power of a heavy multirotor: idle, take-off/climb peak, hover. [s], [W]"""
    total = idle_s + takeoff_s + hover_s
    t = np.arange(0.0, total + dt_s / 2, dt_s)
    p = np.where(t < idle_s - 1e-9, idle_w,
                 np.where(t < idle_s + takeoff_s - 1e-9, takeoff_w, hover_w))
    return t, p


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
    battery = EXAMPLE_LIPO_PACK if battery is None else battery
    supercap = matched_bank(BCAP1500 if supercap is None else supercap, battery)
    t, p = takeoff_profile(**profile)
    res = simulate_hybrid(battery, supercap, t, power_w=p, soc0=soc0,
                          temperature_c=temperature_c, v_cutoff_cell=v_cutoff_cell)
    return res.summary()


__all__ = ["BCAP1500", "EXAMPLE_LIPO_PACK", "HybridResult", "HybridSummary", "matched_bank",
           "simulate_hybrid", "start_stop_cycle", "start_stop_example", "takeoff_example",
           "takeoff_profile"]
