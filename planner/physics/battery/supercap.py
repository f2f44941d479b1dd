r"""Two-branch supercapacitor (electric double-layer capacitor) model.

The cell is two RC branches and a leakage resistance in parallel at its
terminals ([HESS] eq. 6–9; the
two-branch form of Faranda, Gallina and Son [2]_, a reduction of Zubieta and
Bonert's three-branch model [1]_):

* the *fast* branch: series resistance ``R_f`` (the ESR) and a capacitance
  that grows with its voltage, :math:`C_f(v) = C_0 + C_v v`, so its charge is
  :math:`q_f(v) = C_0 v + C_v v^2 / 2`;
* the *slow* branch: ``R_s`` in series with ``C_s`` (charge redistribution
  over minutes);
* the leakage resistance ``R_leak`` (self-discharge).

With terminal voltage ``V`` and terminal current ``I`` (discharge positive):

.. math::

    I = \frac{v_f - V}{R_f} + \frac{v_s - V}{R_s} - \frac{V}{R_{leak}}, \quad
    \frac{dq_f(v_f)}{dt} = -\frac{v_f - V}{R_f}, \quad
    C_s \frac{dv_s}{dt} = -\frac{v_s - V}{R_s}

The terminal node is algebraic, so for a held terminal current the branch
states obey a linear ODE once ``C_f`` is frozen at its value at the start of
the step. :func:`simulate_supercap` (and the hybrid pack in
:mod:`planner.physics.battery.hybrid`) step it with the exact matrix exponential of
that linear system; the fast-branch voltage is then recomputed from the
exact charge balance ``q_f(v_new) = q_f(v_old) − ∫ i_f dt`` with the
nonlinear ``q_f``, so charge is conserved exactly and only the small change of
``C_f`` within one step is approximated.

A bank is ``cells_series × cells_parallel`` identical cells (balanced).

YAML ``supercap:`` block (per cell): ``c0_f`` [F], ``cv_f_per_v`` [F/V,
default 0], ``r_fast_ohm`` [Ω], ``r_slow_ohm`` [Ω] and ``c_slow_f`` [F]
(both or neither; default no slow branch), ``r_leak_ohm`` [Ω, default no
leakage], ``v_rated_v`` [V, default 2.7], ``r_th_k_per_w`` [K/W],
``c_th_j_per_k`` [J/K], ``mass_kg`` [kg], ``cells_series``,
``cells_parallel`` [default 1], ``name``, ``source``.

References
----------
.. [1] L. Zubieta and R. Bonert, "Characterization of double-layer capacitors
   for power electronics applications," IEEE Trans. Ind. Appl., vol. 36,
   no. 1, pp. 199–205, 2000, doi:10.1109/28.821816.
.. [2] R. Faranda, M. Gallina and D. T. Son, "A new simplified model of
   double-layer capacitors," in Proc. Int. Conf. Clean Electrical Power
   (ICCEP), 2007, pp. 706–710, doi:10.1109/ICCEP.2007.384288.
.. [3] Maxwell Technologies, "K2 series ultracapacitors" datasheet, document
   1015370 (BCAP0650–BCAP3000, 2.7 V).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import expm

from planner.errors import InputError, ModelError
from planner.physics.battery.elements import pack_capacitance, pack_resistance

#: Surge voltage of a supercap cell relative to its rated voltage (Maxwell K2: 2.85/2.7 V,
#: datasheet [3]). [unitless]
SURGE_RATIO = 2.85 / 2.7


@dataclass(frozen=True)
class SupercapParameters:
    """Per-cell parameters of the two-branch supercapacitor, and the bank layout.

    Attributes
    ----------
    c0_f : float
        Constant part of the fast-branch capacitance. [F]
    r_fast_ohm : float
        Fast-branch series resistance (ESR). [Ω]
    cv_f_per_v : float
        Voltage-dependent part of the fast-branch capacitance. [F/V]
    r_slow_ohm, c_slow_f : float or None
        Slow branch; ``None`` = no slow branch. [Ω], [F]
    r_leak_ohm : float or None
        Leakage (self-discharge) resistance; ``None`` = none. [Ω]
    v_rated_v : float
        Rated cell voltage. [V]
    r_th_k_per_w, c_th_j_per_k : float or None
        Lumped thermal resistance (case to air) and heat capacity of a cell. [K/W], [J/K]
    mass_kg : float or None
        Mass of a cell. [kg]
    cells_series, cells_parallel : int
        Bank layout.
    name, source : str
    """

    c0_f: float
    r_fast_ohm: float
    cv_f_per_v: float = 0.0
    r_slow_ohm: float | None = None
    c_slow_f: float | None = None
    r_leak_ohm: float | None = None
    v_rated_v: float = 2.7
    r_th_k_per_w: float | None = None
    c_th_j_per_k: float | None = None
    mass_kg: float | None = None
    cells_series: int = 1
    cells_parallel: int = 1
    name: str = ""
    source: str | None = None

    def __post_init__(self):
        problems = []
        for key, none_ok in (("c0_f", False), ("r_fast_ohm", False), ("r_slow_ohm", True),
                             ("c_slow_f", True), ("r_leak_ohm", True), ("v_rated_v", False),
                             ("r_th_k_per_w", True), ("c_th_j_per_k", True),
                             ("mass_kg", True)):
            value = getattr(self, key)
            if value is None and none_ok:
                continue
            if not (isinstance(value, (int, float)) and not isinstance(value, bool)
                    and math.isfinite(value) and value > 0):
                problems.append(f"{key} must be a number > 0, got {value!r}")
        if not (isinstance(self.cv_f_per_v, (int, float)) and math.isfinite(self.cv_f_per_v)
                and self.cv_f_per_v >= 0):
            problems.append(f"cv_f_per_v must be >= 0, got {self.cv_f_per_v!r}")
        if (self.r_slow_ohm is None) != (self.c_slow_f is None):
            problems.append("r_slow_ohm and c_slow_f come together (both or neither)")
        for key in ("cells_series", "cells_parallel"):
            value = getattr(self, key)
            if not (isinstance(value, (int, np.integer)) and not isinstance(value, bool)
                    and value >= 1):
                problems.append(f"{key} must be a whole number >= 1, got {value!r}")
        if problems:
            raise InputError("supercap: " + "; ".join(problems))

    # ------------------------------------------------------------ cell relations
    def fast_charge(self, v):
        """Charge of the fast branch of one cell at voltage ``v``, ``C0 v + Cv v²/2``. [C]"""
        v = np.asarray(v, dtype=float)
        q = self.c0_f * v + 0.5 * self.cv_f_per_v * v * v
        return float(q) if q.ndim == 0 else q

    def fast_voltage(self, q):
        """Inverse of :meth:`fast_charge` (the root with ``C0 + Cv v > 0``), from a cell's
        fast-branch charge ``q`` [C]. [V]"""
        q = np.asarray(q, dtype=float)
        if self.cv_f_per_v == 0:
            v = q / self.c0_f
        else:
            disc = np.maximum(self.c0_f ** 2 + 2.0 * self.cv_f_per_v * q, 0.0)
            v = (np.sqrt(disc) - self.c0_f) / self.cv_f_per_v
        return float(v) if v.ndim == 0 else v

    def fast_voltage_after(self, v_fast, charge_out):
        """Fast-branch cell voltage after the charge ``charge_out`` [C] left the branch:
        the exact charge balance ``q_f(v_new) = q_f(v_old) − Δq`` with the nonlinear
        ``q_f`` (module notes). [V]"""
        return self.fast_voltage(self.fast_charge(v_fast) - charge_out)

    def bank_fast_capacitance_f(self, v_fast) -> float:
        """Capacitance of the bank's fast branch at the cell voltage ``v_fast`` [V],
        :math:`C_f(v) = C_0 + C_v v` scaled to the bank. [F]"""
        return pack_capacitance(self.c0_f + self.cv_f_per_v * v_fast, self.cells_series,
                                self.cells_parallel)

    def equivalent_capacitance_f(self, v_high=None, v_low=None) -> float:
        """Constant-current capacitance of one cell between two voltages, ΔQ/ΔV. [F]

        Default: from the rated voltage to half of it, as in Maxwell's test
        procedure; fast branch only (the slow branch has minutes to follow).
        """
        v_high = self.v_rated_v if v_high is None else v_high
        v_low = v_high / 2 if v_low is None else v_low
        return (self.fast_charge(v_high) - self.fast_charge(v_low)) / (v_high - v_low)

    def stored_energy_j(self, v_fast, v_slow=None) -> float:
        """Energy stored in one cell's branches (fast ``∫ v dq``, slow ``C v²/2``). [J]"""
        e = self.c0_f * v_fast ** 2 / 2 + self.cv_f_per_v * v_fast ** 3 / 3
        if self.c_slow_f is not None and v_slow is not None:
            e = e + self.c_slow_f * v_slow ** 2 / 2
        return e

    # ------------------------------------------------------------ bank
    @property
    def n_cells(self) -> int:
        """Cells in the bank, series × parallel."""
        return self.cells_series * self.cells_parallel

    @property
    def bank_rated_v(self) -> float:
        """Rated voltage of the bank. [V]"""
        return self.v_rated_v * self.cells_series

    @property
    def bank_esr_ohm(self) -> float:
        """Bank series resistance of the fast branch. [Ω]"""
        return pack_resistance(self.r_fast_ohm, self.cells_series, self.cells_parallel)

    @property
    def bank_mass_kg(self) -> float | None:
        """Mass of the bank (None when the cell's is unknown). [kg]"""
        return None if self.mass_kg is None else self.mass_kg * self.n_cells

    def bank(self, cells_series: int, cells_parallel: int = 1) -> SupercapParameters:
        """The same cell in another bank layout."""
        return replace(self, cells_series=int(cells_series), cells_parallel=int(cells_parallel))


def _bcap1500() -> SupercapParameters:
    # Datasheet [3]: 1500 F rated (constant-current, V_R -> V_R/2), 0.47 mΩ DC ESR,
    # 2.7 V, 3.0 mA max leakage at 25 °C after 72 h, Rca 4.5 °C/W, Cth 320 J/°C, 0.28 kg.
    # Branch split (not on the datasheet): the shape of the six-parameter example set that
    # accompanies an open implementation of Faranda et al.'s model (R0 10.0 mΩ,
    # C0 89.03 F, Kv 29.11 F/V, R2 17.50 Ω, C2 13.72 F, R_EPR 5 kΩ): Kv·2.7 V / C0 = 0.883,
    # C2/C0 = 0.154, R2·C2 = 240 s; scaled so that ΔQ/ΔV from 2.7 V to 1.35 V is 1500 F.
    k_shape = 29.1062 * 2.7 / 89.03
    c0 = 1500.0 / (1.0 + 0.75 * k_shape)
    cv = k_shape * c0 / 2.7
    c2 = c0 * 13.7162 / 89.03
    r2 = 17.4976 * 13.7162 / c2
    return SupercapParameters(
        c0_f=c0, cv_f_per_v=cv, r_fast_ohm=0.47e-3, r_slow_ohm=r2, c_slow_f=c2,
        r_leak_ohm=2.7 / 3.0e-3, v_rated_v=2.7, r_th_k_per_w=4.5, c_th_j_per_k=320.0,
        mass_kg=0.28, name="Maxwell BCAP1500 P270 (K2)",
        source="Maxwell K2 series datasheet doc. 1015370 (1500 F, 0.47 mΩ, 2.7 V, "
               "3.0 mA, 4.5 °C/W, 320 J/°C, 280 g); branch split scaled from the Faranda "
               "et al. (2007) two-branch example set")


#: Maxwell BCAP1500 P270 (K2 series) cell, datasheet values plus a scaled branch split
#: (see :func:`_bcap1500`): C_eff 1500 F, ESR 0.47 mΩ, 2.7 V, R_leak 900 Ω,
#: R_th 4.5 °C/W, C_th 320 J/°C, 0.28 kg.
BCAP1500 = _bcap1500()


def matched_series_count(v_max_v: float, cell_rated_v: float = 2.7) -> int:
    """Fewest cells in series whose rated voltage covers ``v_max_v``: ``ceil(V/V_rated)``."""
    if not (v_max_v > 0 and cell_rated_v > 0):
        raise InputError(f"voltages must be > 0, got {v_max_v!r} and {cell_rated_v!r}")
    return math.ceil(v_max_v / cell_rated_v - 1e-12)


# --------------------------------------------------------------------------- linear node

class LinearNode:
    """Battery Thevenin source (optional) and a supercap bank sharing one node.

    States ``x = [v_rc, v_f, v_s]`` (pack/bank volts), inputs ``u = [E, I_L]``
    (battery source voltage, load current). Over a step with ``u`` and the
    fast capacitance held, ``x`` follows a linear ODE; its zero-order-hold
    solution, the integral of ``[x; u]`` and the integral of the squared
    battery current come from matrix exponentials (C. F. Van Loan, "Computing
    integrals involving the matrix exponential," IEEE Trans. Autom. Control 23(3),
    1978), cached while the coefficients stay within ``rtol``.

    Parameters
    ----------
    bank : SupercapParameters
        The bank (its branch conductances and slow capacitance follow from it).
    r1p, c1p : float
        The battery's RC branch at pack level (0 and 1: none). [Ω], [F]
    quadratic : bool
        Also compute the matrix of ∫ i_b² dt (:attr:`w_quad`).
    rtol : float
        Relative change of the conductance or capacitance that recomputes the matrices.
    """

    def __init__(self, bank: SupercapParameters, *, r1p=0.0, c1p=1.0, quadratic=False,
                 rtol=1e-3):
        ns, npar = bank.cells_series, bank.cells_parallel
        self.r1p, self.c1p = r1p, c1p
        self.gf = 1.0 / pack_resistance(bank.r_fast_ohm, ns, npar)
        has_slow = bank.r_slow_ohm is not None
        self.gs = 1.0 / pack_resistance(bank.r_slow_ohm, ns, npar) if has_slow else 0.0
        self.cs = pack_capacitance(bank.c_slow_f, ns, npar) if has_slow else 1.0
        self.gl = (1.0 / pack_resistance(bank.r_leak_ohm, ns, npar)
                   if bank.r_leak_ohm is not None else 0.0)
        self.quadratic = quadratic
        self.rtol = rtol
        self._key = None

    def rows(self, g0):
        """The node's algebraic rows at the battery conductance ``g0`` [S]: node voltage
        and branch currents as linear functions of the states and inputs."""
        gf, gs, gl = self.gf, self.gs, self.gl
        gt = g0 + gf + gs + gl
        a_node = np.array([-g0, gf, gs]) / gt
        b_node = np.array([g0, -1.0]) / gt
        c_b = g0 * (np.array([-1.0, 0.0, 0.0]) - a_node)
        d_b = g0 * (np.array([1.0, 0.0]) - b_node)
        c_f = gf * (np.array([0.0, 1.0, 0.0]) - a_node)
        d_f = -gf * b_node
        c_s = gs * (np.array([0.0, 0.0, 1.0]) - a_node)
        d_s = -gs * b_node
        return a_node, b_node, c_b, d_b, c_f, d_f, c_s, d_s

    def prepare(self, g0: float, cf: float, dt: float) -> None:
        """Step matrices for the battery conductance ``g0`` [S], the fast capacitance
        ``cf`` [F] and the step ``dt`` [s] (kept while within ``rtol``)."""
        key = (g0, cf, dt)
        if self._key is not None:
            g_old, c_old, dt_old = self._key
            if (dt == dt_old and abs(cf - c_old) <= self.rtol * c_old
                    and abs(g0 - g_old) <= self.rtol * max(g_old, 1e-300)):
                return
        self._key = key
        a_node, b_node, c_b, d_b, c_f, d_f, c_s, d_s = self.rows(g0)
        self.a_node, self.b_node = a_node, b_node
        self.w_b = np.r_[c_b, d_b]
        self.w_f = np.r_[c_f, d_f]
        self.w_s = np.r_[c_s, d_s]
        a = np.zeros((3, 3))
        b = np.zeros((3, 2))
        if self.r1p > 0 and g0 > 0:
            a[0] = c_b / self.c1p
            a[0, 0] -= 1.0 / (self.r1p * self.c1p)
            b[0] = d_b / self.c1p
        a[1] = -c_f / cf
        b[1] = -d_f / cf
        if self.gs > 0:
            a[2] = -c_s / self.cs
            b[2] = -d_s / self.cs
        f = np.zeros((5, 5))
        f[:3, :3] = a
        f[:3, 3:] = b
        big = np.zeros((10, 10))
        big[:5, :5] = f * dt
        big[:5, 5:] = np.eye(5) * dt
        e = expm(big)
        self.phi = e[:5, :5]          # y(t+dt) = phi y(t), y = [x; u]
        self.integral = e[:5, 5:]     # ∫ y dt = integral y(t)
        if self.quadratic:
            vl = np.zeros((10, 10))
            vl[:5, :5] = -f.T * dt
            vl[:5, 5:] = np.outer(self.w_b, self.w_b) * dt
            vl[5:, 5:] = f * dt
            ev = expm(vl)
            self.w_quad = ev[5:, 5:].T @ ev[:5, 5:]   # ∫ i_b² dt = y' W y
            self.w_quad = 0.5 * (self.w_quad + self.w_quad.T)


# --------------------------------------------------------------------------- simulation

@dataclass
class SupercapResult:
    """Time series of :func:`simulate_supercap` (bank quantities).

    Attributes
    ----------
    time_s : ndarray [s]
    current_a : ndarray
        Terminal current, discharge positive. [A]
    voltage_v : ndarray
        Terminal voltage with the step's current applied. [V]
    fast_voltage_v, slow_voltage_v : ndarray
        Branch capacitor voltages. [V]
    energy_j : ndarray
        Energy stored in the branches. [J]
    heat_w : ndarray
        Joule heat in the branch resistors and the leakage, at each sample. [W]
    """

    time_s: np.ndarray
    current_a: np.ndarray
    voltage_v: np.ndarray
    fast_voltage_v: np.ndarray
    slow_voltage_v: np.ndarray
    energy_j: np.ndarray
    heat_w: np.ndarray


def simulate_supercap(params: SupercapParameters, time_s, current_a, *, v0_v=None,
                      slow_v0_v=None) -> SupercapResult:
    """
    Run a supercapacitor bank through a current profile.

    Parameters
    ----------
    params : SupercapParameters
    time_s : array_like
        Sample times, non-decreasing. [s]
    current_a : numeric
        Terminal current held from each sample to the next, discharge positive. [A]
    v0_v : float, optional
        Initial bank voltage of the fast branch; default the rated bank voltage. [V]
    slow_v0_v : float, optional
        Initial bank voltage of the slow branch; default ``v0_v`` (rested). [V]

    Returns
    -------
    SupercapResult

    Raises
    ------
    ModelError
        An initial cell voltage above the rated voltage or below 0.
    """
    t = np.asarray(time_s, dtype=float).ravel()
    n = t.size
    if n == 0:
        raise InputError("time_s is empty")
    dt = np.diff(t)
    if np.any(dt < 0) or not np.all(np.isfinite(t)):
        raise InputError("time_s must be finite and not decrease")
    cur = np.broadcast_to(np.asarray(current_a, dtype=float), (n,)).astype(float)
    if not np.all(np.isfinite(cur)):
        raise InputError("current_a has a non-finite value")
    p = params
    ns, npar = p.cells_series, p.cells_parallel
    v0 = p.bank_rated_v if v0_v is None else float(v0_v)
    vs0 = v0 if slow_v0_v is None else float(slow_v0_v)
    for name, v in (("v0_v", v0), ("slow_v0_v", vs0)):
        if not (0.0 <= v / ns <= p.v_rated_v * SURGE_RATIO):
            raise ModelError(f"supercap: {name} gives {v / ns:.3f} V per cell, outside "
                             f"[0 V, {p.v_rated_v * SURGE_RATIO:.2f} V] (rated {p.v_rated_v} V "
                             "plus surge)")
    has_slow = p.r_slow_ohm is not None
    node = LinearNode(p)
    vf_cell = v0 / ns
    vs = vs0
    out_v = np.empty(n)
    out_vf = np.empty(n)
    out_vs = np.empty(n)
    out_e = np.empty(n)
    out_q = np.empty(n)
    d_prev = float(dt[dt > 0][0]) if np.any(dt > 0) else 1.0
    for k in range(n):
        cf = p.bank_fast_capacitance_f(vf_cell)
        d = dt[k] if k < n - 1 else 0.0
        if d > 0:
            d_prev = d
        node.prepare(0.0, cf, d_prev)
        y = np.array([0.0, vf_cell * ns, vs, 0.0, cur[k]])
        v_node = node.a_node @ y[:3] + node.b_node @ y[3:]
        i_f = node.w_f @ y
        i_s = node.w_s @ y
        out_v[k] = v_node
        out_vf[k] = vf_cell * ns
        out_vs[k] = vs
        out_e[k] = p.n_cells * p.stored_energy_j(vf_cell, vs / ns if has_slow else None)
        out_q[k] = (i_f ** 2 / node.gf + (i_s ** 2 / node.gs if has_slow else 0.0)
                    + (v_node ** 2 * node.gl))
        if k == n - 1 or d == 0.0:
            continue
        y1 = node.phi @ y
        iy = node.integral @ y
        q_out_cell = (node.w_f @ iy) / npar
        vf_cell = p.fast_voltage_after(vf_cell, q_out_cell)
        vs = y1[2]
    return SupercapResult(t, cur, out_v, out_vf, out_vs, out_e, out_q)
