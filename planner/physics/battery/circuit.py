r"""First-order equivalent-circuit (Thevenin/Randles) model of a LiPo cell and pack.

The cell is an open-circuit voltage source OCV(SoC) with a one-state dynamic
hysteresis voltage ``h``, an ohmic resistance R0(SoC, T) and one RC branch
(R1 ∥ C1), as in [HESS] (its first-order Randles circuit: state of charge eq. 1,
terminal voltage eq. 2, dynamic hysteresis state eq. 4, RC branch eq. 5, heat eq. 10) and
in Plett's "enhanced self-correcting" cell model [1]_ (ch. 2). Discharge
current is positive.

.. math::

    \dot z &= -\eta\, i / Q(T) \\
    \dot v_1 &= -v_1/(R_1 C_1) + i / C_1 \\
    \dot h &= -\frac{\gamma\,|\eta\, i|}{Q(T)}\,\bigl(h + M\,\mathrm{sgn}(i)\bigr) \\
    v &= \mathrm{OCV}(z) + h - v_1 - R_0(z, T)\, i

``z`` is the state of charge, ``v1`` the RC-branch voltage, ``h`` the
hysteresis voltage (bounded by ±M), ``η`` the coulombic efficiency (1 on
discharge). The hysteresis equation is Plett's one-state model ([1]_, ch. 2)
written for the hysteresis *voltage* ``h = M·h_Plett`` (``M`` constant here,
where [HESS] eq. 4 allows ``M(SoC, sgn i)``): under a steady
discharge ``h → −M`` (the loaded curve lies below the OCV), under charge
``h → +M``, and the approach is exponential in the *charge* passed, with the
charge constant ``Q/γ``. For a current held over a step the exact solution is

.. math:: h_{k+1} = e^{-\gamma |\Delta q| / Q} h_k
          - \bigl(1 - e^{-\gamma |\Delta q| / Q}\bigr) M\,\mathrm{sgn}(i_k),
          \quad \Delta q = \eta\, i_k \Delta t_k

and the RC branch is discretised exactly for a zero-order-hold current:
``v1[k+1] = a v1[k] + R1 (1 − a) i[k]`` with ``a = exp(−Δt/(R1 C1))``.
These are the two exact updates the simulation uses; the state of charge is
integrated exactly (coulomb counting) for the held current. The nonlinear
coupling (OCV and R0 depend on z and T) is resolved step by step: the
parameters are evaluated at the start of each step.

Diffusion (optional)
--------------------
``simulate(..., diffusion=(c, tau_d))`` adds one state that the circuit
lacks: the depletion ``x`` of the electrode surface against the bulk, the
kinetic battery model (KiBaM) of Manwell and McGowan [5]_ written in
state-of-charge terms. The OCV and R0 are then evaluated at the *surface*
state of charge ``z − x``:

.. math:: \dot x = \frac{1 - c}{c}\,\frac{\eta\, i}{Q(T)} - \frac{x}{\tau_d}

KiBaM splits the charge into an *available* well (fraction ``c``) that feeds
the current and a *bound* well that refills it; the height difference of the
wells relaxes with :math:`\tau_d`. Under a steady current ``x`` settles at
:math:`\frac{1-c}{c}\tau_d\, i/Q`, so the cut-off comes while the charge
``Q x`` is still bound (a rate-dependent capacity beyond the IR drop), and it
returns at rest (recovery). The update for the held current is exact:
:math:`x_{k+1} = a x_k + (1-a)\frac{1-c}{c}\tau_d\,\eta i_k/Q`,
:math:`a = e^{-\Delta t/\tau_d}`. The virtual bench
(:mod:`planner.identify.bench`) uses it.

Temperature
-----------
* R0 follows Arrhenius, ``R0(T) = R0_ref·exp(E_a/R·(1/T − 1/T_ref))``. The
  default ``E_a = 25 kJ/mol`` lies between the activation energy of the
  electrolyte conductivity, 17 kJ/mol (the Nyman et al. electrolyte of
  PyBaMM's ``Chen2020`` parameter set [2]_), and those of the electrode
  reactions, 30 kJ/mol for the graphite exchange current of Kim et al. [4]_
  (27–53 kJ/mol in PyBaMM's BPX example set): the pulse resistance R0 mixes
  ohmic and charge-transfer parts. It gives R0(−20 °C) ≈ 6·R0(25 °C). R1 and
  C1 are held at their reference values.
* The available capacity falls linearly below the reference temperature:
  ``Q(T) = Q_ref·(1 − k·max(0, T_ref − T))`` with ``k = 0.006 /°C`` by
  default, i.e. 73 % at −20 °C, which is consistent with the roughly 65 % of
  room-temperature *energy* Zhang, Xu and Jow [3]_ report for commercial
  Li-ion cells at −20 °C (energy falls faster than charge because the voltage
  sags too). The state of charge counts against the capacity available at the
  present temperature. Above ``T_ref`` the capacity is ``Q_ref``.
* The model is valid for cell temperatures in [−20 °C, 60 °C]
  (:data:`planner.physics.battery.thermal.T_RANGE_C`); outside it raises
  :class:`planner.errors.ModelError`.

Pack files
----------
A pack file's ``circuit:`` block gives these parameters per cell (the pack supplies the
capacity, R0 and layout it leaves out); its keys, units, bounds and defaults are declared
in :data:`planner.parameters.blocks.CIRCUIT_KEYS` and printed in ``docs/formats.md``.

References
----------
.. [1] G. L. Plett, Battery Management Systems, Volume I: Battery Modeling.
   Norwood, MA, USA: Artech House, 2015.
.. [2] C.-H. Chen et al., "Development of experimental techniques for
   parameterization of multi-scale lithium-ion battery models," J.
   Electrochem. Soc., vol. 167, 080534, 2020, doi:10.1149/1945-7111/ab9050;
   electrolyte after A. Nyman et al., Electrochim. Acta, vol. 53,
   pp. 6356–6365, 2008, doi:10.1016/j.electacta.2008.04.023.
.. [3] S. S. Zhang, K. Xu and T. R. Jow, "The low temperature performance of
   Li-ion batteries," J. Power Sources, vol. 115, pp. 137–140, 2003,
   doi:10.1016/S0378-7753(02)00618-3.
.. [4] G.-H. Kim, K. Smith, K.-J. Lee, S. Santhanagopalan and A. Pesaran,
   "Multi-domain modeling of lithium-ion batteries encompassing multi-physics
   in varied length scales," J. Electrochem. Soc., vol. 158, no. 8,
   pp. A955–A969, 2011, doi:10.1149/1.3597614.
.. [5] J. F. Manwell and J. G. McGowan, "Lead acid battery storage model for
   hybrid energy systems," Solar Energy, vol. 50, no. 5, pp. 399–405, 1993,
   doi: 10.1016/0038-092X(93)90060-2.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from planner.errors import InputError, ModelError
from planner.physics.battery import elements as el
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.battery.thermal import (
    T_RANGE_C,
    ThermalParameters,
    check_temperature,
    lumped_step,
)
from planner.physics.kernel import kernel
from planner.physics.limits import (
    ACTIVATION_ENERGY_MAX_J_MOL,
    CAPACITY_TEMP_COEFF_MAX_PER_C,
    CELL_CAPACITY_MAX_AH,
    CELL_RESISTANCE_MAX_OHM,
    HYSTERESIS_GAMMA_MAX,
    HYSTERESIS_MAX_V,
)
from planner.physics.units import AS_PER_AH

if TYPE_CHECKING:
    import pandas as pd

#: Default Arrhenius activation energy of R0 (see module notes). [J/mol]
DEFAULT_R0_ACTIVATION_J_MOL = 25_000.0
#: Default capacity loss per °C below the reference temperature (see module notes). [1/°C]
DEFAULT_CAPACITY_TEMP_COEFF = 0.006
#: Points of the uniform SoC grid on which OCV and R0(SoC) are tabulated for the time loops
#: (here and in :mod:`planner.physics.battery.hybrid`).
SOC_GRID_POINTS = 4001

# --------------------------------------------------------------------------- parameters

def r0_table(soc, ohm, name: str = "r0_ohm") -> tuple[np.ndarray, np.ndarray]:
    """An R0(SoC) table, checked and sorted by state of charge.

    Parameters
    ----------
    soc, ohm : array_like
        States of charge in [0, 1] and the resistances there, of equal length >= 2, no
        state of charge twice. [unitless], [Ω]
    name : str
        What the table is called in messages (``name.soc``, ``name.ohm``).

    Returns
    -------
    (ndarray, ndarray)
        The table sorted by state of charge.

    Raises
    ------
    InputError
        A table that breaks one of those rules, naming it.
    """
    try:
        soc = np.asarray(soc, dtype=float).ravel()
        ohm = np.asarray(ohm, dtype=float).ravel()
    except (TypeError, ValueError):
        raise InputError(f"{name}.soc and {name}.ohm must be lists of numbers") from None
    if soc.size != ohm.size or soc.size < 2:
        raise InputError(f"{name}.soc and {name}.ohm must be lists of equal length >= 2, "
                         f"got {soc.size} and {ohm.size}")
    if not (np.all(np.isfinite(soc)) and np.all(np.isfinite(ohm))):
        raise InputError(f"{name} has a value that is not a finite number")
    if soc.min() < 0 or soc.max() > 1:
        raise InputError(f"{name}.soc must lie in [0, 1], got {soc.min():g}..{soc.max():g}")
    if np.any(ohm < 0):
        raise InputError(f"{name}.ohm must be >= 0 (a resistance), got {ohm.min():g}")
    order = np.argsort(soc)
    soc, ohm = soc[order], ohm[order]
    if np.any(np.diff(soc) == 0):
        raise InputError(f"{name}.soc has a repeated value")
    return soc, ohm


def _r0(value, problems: list[str]):
    """``r0_ohm`` of :class:`CircuitParameters`: a resistance >= 0 or an R0(SoC) table
    (:func:`r0_table`); None with the problem recorded."""
    if isinstance(value, (tuple, list)) and len(value) == 2:
        try:
            return r0_table(value[0], value[1])
        except InputError as exc:
            problems.append(str(exc))
            return None
    if isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool):
        if math.isfinite(value) and value >= 0:
            return float(value)
        problems.append(f"r0_ohm must be >= 0 (a resistance), got {value!r}")
        return None
    problems.append(f"r0_ohm must be a number or a table (soc, ohm), got {value!r}")
    return None


@dataclass(frozen=True, eq=False)
class CircuitParameters:
    """Per-cell parameters of the equivalent circuit, and the pack layout.

    Attributes
    ----------
    capacity_ah : float
        Cell capacity at the reference temperature. [A h]
    r0_ohm : float or (ndarray, ndarray)
        Ohmic resistance at the reference temperature: a number, or a table
        ``(soc, ohm)`` interpolated linearly (held at the ends). [Ω]
    r1_ohm : float
        Resistance of the RC branch; 0 = no RC branch. [Ω]
    c1_f : float or None
        Capacitance of the RC branch (required when ``r1_ohm > 0``). [F]
    hysteresis_v : float
        Maximum hysteresis voltage M. [V]
    hysteresis_gamma : float
        Hysteresis rate γ; the hysteresis settles within about ``3 Q/γ`` of charge. [unitless]
    ocv : callable
        ``ocv(soc) -> V`` per cell; default :func:`planner.physics.battery.ocv.lipo_ocv`.
    ocv_csv : str or None
        The CSV file ``ocv`` was read from (kept for :meth:`to_mapping`).
    r0_activation_energy_j_mol : float
        Arrhenius activation energy of R0. [J/mol]
    capacity_temp_coeff_per_c : float
        Relative capacity loss per °C below the reference temperature. [1/°C]
    reference_temperature_c : float
        Temperature of ``capacity_ah`` and ``r0_ohm``. [°C]
    coulombic_efficiency : float
        Share of the charging charge that is stored, (0, 1]. [unitless]
    cells_series, cells_parallel : int
        Pack layout.
    source : str or None
        Where the numbers come from.
    """

    capacity_ah: float
    r0_ohm: Any
    r1_ohm: float = 0.0
    c1_f: float | None = None
    hysteresis_v: float = 0.0
    hysteresis_gamma: float = 0.0
    ocv: Callable = field(default=lipo_ocv)
    ocv_csv: str | None = None
    r0_activation_energy_j_mol: float = DEFAULT_R0_ACTIVATION_J_MOL
    capacity_temp_coeff_per_c: float = DEFAULT_CAPACITY_TEMP_COEFF
    reference_temperature_c: float = 25.0
    coulombic_efficiency: float = 1.0
    cells_series: int = 1
    cells_parallel: int = 1
    source: str | None = None

    def __post_init__(self):
        problems: list[str] = []
        r0 = _r0(self.r0_ohm, problems)
        if r0 is not None:
            object.__setattr__(self, "r0_ohm", r0)

        def num(key, low=0.0, strict=False, high=None, none_ok=False):
            value = getattr(self, key)
            if value is None and none_ok:
                return
            ok = (isinstance(value, (int, float, np.floating, np.integer))
                  and not isinstance(value, bool) and math.isfinite(value)
                  and (value > low if strict else value >= low)
                  and (high is None or value <= high))
            if not ok:
                rel = ">" if strict else ">="
                rng = f" and <= {high:g}" if high is not None else ""
                problems.append(f"{key} must be {rel} {low:g}{rng}, got {value!r}")

        # the bounds of the pack files' circuit: block (planner.physics.limits)
        num("capacity_ah", strict=True, high=CELL_CAPACITY_MAX_AH)
        num("r1_ohm", high=CELL_RESISTANCE_MAX_OHM)
        num("c1_f", strict=True, none_ok=True)
        num("hysteresis_v", high=HYSTERESIS_MAX_V)
        num("hysteresis_gamma", high=HYSTERESIS_GAMMA_MAX)
        num("r0_activation_energy_j_mol", high=ACTIVATION_ENERGY_MAX_J_MOL)
        num("capacity_temp_coeff_per_c", high=CAPACITY_TEMP_COEFF_MAX_PER_C)
        num("coulombic_efficiency", strict=True, high=1.0)
        num("reference_temperature_c", low=T_RANGE_C[0], high=T_RANGE_C[1])
        for key in ("cells_series", "cells_parallel"):  # the installed packs: no bound
            value = getattr(self, key)
            if not (isinstance(value, (int, np.integer)) and not isinstance(value, bool)
                    and value >= 1):
                problems.append(f"{key} must be a whole number >= 1, got {value!r}")
        if not callable(self.ocv):
            problems.append(f"ocv must be a callable soc -> V, got {self.ocv!r}")
        if not problems:
            if self.r1_ohm > 0 and self.c1_f is None:
                problems.append("c1_f is required when r1_ohm > 0")
            if self.hysteresis_v > 0 and self.hysteresis_gamma is None:
                problems.append("hysteresis_gamma is required when hysteresis_v > 0")
        if problems:
            raise InputError("circuit: " + "; ".join(problems))

    # ---------------------------------------------------------------- evaluation
    @property
    def r0_is_table(self) -> bool:
        """Whether R0 is a table against the state of charge (else one number)."""
        return isinstance(self.r0_ohm, tuple)

    @property
    def tau1_s(self) -> float:
        """Time constant R1·C1 of the RC branch (0 without one). [s]"""
        return self.r1_ohm * self.c1_f if self.r1_ohm > 0 else 0.0

    @property
    def pack_capacity_ah(self) -> float:
        """Pack capacity at the reference temperature. [A h]"""
        return self.capacity_ah * self.cells_parallel

    def arrhenius_factor(self, temperature_c):
        """R0(T)/R0(T_ref) of these cells at ``temperature_c`` [°C]
        (:func:`planner.physics.battery.elements.arrhenius_factor`). [unitless]"""
        return el.arrhenius_factor(np.asarray(temperature_c, dtype=float),
                                   self.r0_activation_energy_j_mol,
                                   self.reference_temperature_c)

    def capacity_factor(self, temperature_c):
        """Q(T)/Q_ref of these cells at ``temperature_c`` [°C]
        (:func:`planner.physics.battery.elements.capacity_factor`). [unitless]"""
        return el.capacity_factor(np.asarray(temperature_c, dtype=float),
                                  self.capacity_temp_coeff_per_c, self.reference_temperature_c)

    def r0_cell_ohm(self, soc, temperature_c=None):
        """Cell ohmic resistance at ``soc`` and ``temperature_c`` (default T_ref). [Ω]"""
        if self.r0_is_table:
            r = np.interp(np.asarray(soc, dtype=float), self.r0_ohm[0], self.r0_ohm[1])
        else:
            r = np.full(np.shape(soc), self.r0_ohm, dtype=float)
        if temperature_c is not None:
            r = r * self.arrhenius_factor(temperature_c)
        return float(r) if np.ndim(r) == 0 else r

    def r0_pack_ohm(self, soc, temperature_c=None):
        """Pack ohmic resistance. [Ω]"""
        return el.pack_resistance(self.r0_cell_ohm(soc, temperature_c), self.cells_series,
                                  self.cells_parallel)

    def ocv_pack_v(self, soc):
        """Pack open-circuit voltage (without hysteresis). [V]"""
        return self.ocv(soc) * self.cells_series

    def max_power_w(self, soc, temperature_c=None):
        """Largest power the rested pack can deliver, ``OCV²/(4 R0)``
        (:func:`planner.physics.battery.elements.power_limit`); infinite when R0 is 0. [W]
        """
        return el.power_limit(np.asarray(self.ocv_pack_v(soc), dtype=float),
                              np.asarray(self.r0_pack_ohm(soc, temperature_c), dtype=float))

# --------------------------------------------------------------------------- simulation

@dataclass
class CircuitResult:
    """Time series and events of :func:`simulate` (pack quantities unless stated).

    Sample ``k`` describes the instant ``time_s[k]`` with the load of step
    ``k`` applied (held until ``time_s[k+1]``): ``voltage_v[k]`` is the loaded
    terminal voltage, ``charge_as[k]`` the charge drawn before ``time_s[k]``.

    Attributes
    ----------
    time_s : ndarray
        [s]
    current_a : ndarray
        Pack current, discharge positive. [A]
    power_w : ndarray
        Power delivered at the terminals, ``V·I`` (less than asked where the
        power cannot be delivered). [W]
    voltage_v : ndarray
        Loaded terminal voltage. [V]
    ocv_v : ndarray
        Open-circuit voltage OCV(SoC) (without hysteresis; at the surface
        SoC ``z − x`` with ``diffusion``). [V]
    soc : ndarray
        State of charge against the capacity available at the present
        temperature; may go below 0 when the run continues past empty. [unitless]
    rc_voltage_v : ndarray
        Voltage across the RC branches. [V]
    hysteresis_v : ndarray
        Hysteresis voltage. [V]
    temperature_c : ndarray
        Cell temperature. [°C]
    heat_w : ndarray
        Heat generated, ``I² R0 + v_RC²/R1`` over the pack. [W]
    charge_as : ndarray
        Charge drawn since the start. [A s]
    energy_j : ndarray
        Energy drawn at the terminals since the start. [J]
    cells_series : int
    v_cutoff_cell : float or None
        Cut-off used for the event. [V]
    cutoff_time_s, cutoff_charge_as : float or None
        When the loaded cell voltage first reached the cut-off (interpolated
        between samples) and the charge drawn by then. [s], [A s]
    undeliverable_time_s : float or None
        First sample time at which the asked power exceeded ``E²/(4 R0)``; the
        pack then delivers that maximum power instead. [s]
    empty_time_s : float or None
        When the state of charge first reached 0 (interpolated). [s]
    surface_deficit : ndarray or None
        Diffusion state ``x`` (surface SoC below the bulk SoC) when
        :func:`simulate` ran with ``diffusion``; ``None`` otherwise. [unitless]
    """

    time_s: np.ndarray
    current_a: np.ndarray
    power_w: np.ndarray
    voltage_v: np.ndarray
    ocv_v: np.ndarray
    soc: np.ndarray
    rc_voltage_v: np.ndarray
    hysteresis_v: np.ndarray
    temperature_c: np.ndarray
    heat_w: np.ndarray
    charge_as: np.ndarray
    energy_j: np.ndarray
    cells_series: int = 1
    v_cutoff_cell: float | None = None
    cutoff_time_s: float | None = None
    cutoff_charge_as: float | None = None
    undeliverable_time_s: float | None = None
    empty_time_s: float | None = None
    surface_deficit: np.ndarray | None = None

    @property
    def cell_voltage_v(self) -> np.ndarray:
        """Loaded voltage per series cell. [V]"""
        return self.voltage_v / self.cells_series

    @property
    def deliverable(self) -> bool:
        """``True`` when every asked power could be delivered."""
        return self.undeliverable_time_s is None

    def to_frame(self) -> pd.DataFrame:
        """The time series as a DataFrame with unit-suffixed columns."""
        import pandas as pd                   # imported where used: start-up time

        return pd.DataFrame({
            "time_s": self.time_s, "current_a": self.current_a, "power_w": self.power_w,
            "voltage_v": self.voltage_v, "ocv_v": self.ocv_v, "soc": self.soc,
            "rc_voltage_v": self.rc_voltage_v, "hysteresis_v": self.hysteresis_v,
            "temperature_c": self.temperature_c, "heat_w": self.heat_w,
            "charge_as": self.charge_as, "energy_j": self.energy_j})


def series_input(value, n: int, name: str) -> np.ndarray:
    """A load or temperature given for a run of ``n`` samples: a constant, or one finite
    value per sample, as a float ndarray of length ``n`` (units unchanged).

    Raises
    ------
    InputError
        Another length, or a value that is not finite (naming ``name`` and the sample).
    """
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    arr = arr.ravel()
    if arr.size != n:
        raise InputError(f"{name} has {arr.size} values, time_s has {n}")
    if not np.all(np.isfinite(arr)):
        k = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise InputError(f"{name} has a non-finite value at sample {k}")
    return arr


def soc_grid(func, n: int = SOC_GRID_POINTS) -> np.ndarray:
    """``func`` (an OCV curve, soc → V) tabulated on ``n`` uniform states of charge from 0
    to 1, for :func:`on_soc_grid`. [V]

    Raises
    ------
    InputError
        The function does not return one finite voltage per state of charge.
    """
    z = np.linspace(0.0, 1.0, n)
    values = np.asarray(func(z), dtype=float)
    if values.shape != z.shape or not np.all(np.isfinite(values)):
        raise InputError("the OCV function must return finite voltages for soc in [0, 1]")
    return values


@el.compiled
def on_soc_grid(table, row, soc):
    """Row ``row`` of a table on the uniform grid of :func:`soc_grid` at ``soc``, linearly
    interpolated and held at the ends (units of the table; compiled, for the time loops)."""
    last = table.shape[1] - 1
    x = soc * last
    if x <= 0.0:
        return table[row, 0]
    if x >= last:
        return table[row, last]
    j = int(x)
    return table[row, j] + (x - j) * (table[row, j + 1] - table[row, j])


# --------------------------------------------------------------------------- the step kernel
#
# One time loop for every use of the circuit: a single pack with every sample recorded
# (:func:`simulate`) and many packs at once with only the events and a few reductions
# kept (:func:`simulate_packs`, the mission chain's pack axis). The loop runs over time;
# each step updates every pack. It is compiled with numba: the state of step k+1 depends
# on step k, so the time axis cannot be vectorised, and a Python loop over time costs
# microseconds per step where the compiled loop costs nanoseconds per pack.

_NAN = float("nan")


@kernel
def _kernel(t, load_table, step_col, by_power, soc0, h0, v10,
            ns, npar, cap_as, eta_c, m_h, gamma, r1, r1_pack, tau1, ea, t_ref, kq,
            ocv_tab, ocv_idx, r0_tab, r0_idx, r0_scale, diff_gain, tau_d,
            thermal, r_th, tau_th, t_air, t0, temps, t_lo, t_hi,
            cut, stop_at_cutoff, end_at_cutoff, n_window, probe_slot, n_probes,
            record, stop_when_all_cut):
    """Run the circuit of every pack through the load (see :func:`simulate_packs`)."""
    n = t.size
    k = ns.size
    rec_n = n if record else 1
    out = np.full((12, k if record else 1, rec_n), _NAN)
    ev = np.full((12, k), _NAN)   # events and reductions, rows documented in simulate_packs
    probe = np.full((k, max(n_probes, 1)), _NAN)
    z = np.full(k, soc0)
    xd = np.zeros(k)
    h = np.full(k, h0)
    v1 = np.full(k, v10)
    temp = np.empty(k)
    for i in range(k):
        temp[i] = t0[i] if thermal[i] else temps[0]
    q = np.zeros(k)
    e = np.zeros(k)
    disconnected = np.zeros(k, np.bool_)
    prev_v = np.full(k, _NAN)
    prev_q = np.zeros(k)
    prev_t = np.zeros(k)
    a_rc = np.ones(k)
    a_th = np.ones(k)
    a_d = np.ones(k)
    last_dt = -1.0
    vmin = np.full(k, np.inf)
    tmax = np.full(k, -np.inf)
    steps = 0
    for j in range(n):
        steps = j + 1
        d = t[j + 1] - t[j] if j < n - 1 else 0.0
        if d != last_dt and d > 0.0:
            for i in range(k):
                a_rc[i] = np.exp(-d / tau1[i]) if tau1[i] > 0.0 else 0.0
                a_th[i] = np.exp(-d / tau_th[i]) if thermal[i] else 1.0
                a_d[i] = np.exp(-d / tau_d[i]) if diff_gain[i] > 0.0 else 1.0
            last_dt = d
        col = step_col[j]
        in_window = j < n_window
        slot = probe_slot[j]
        ending = False
        all_cut = True
        for i in range(k):
            if thermal[i]:
                tc = temp[i]
                if (tc < t_lo or tc > t_hi) and np.isnan(ev[6, i]):
                    ev[6, i] = t[j]
                    ev[7, i] = tc
                    ev[10, i] = 1.0 if in_window else 0.0
                tc = min(max(tc, t_lo), t_hi)
            else:
                tc = temps[j]
                temp[i] = tc
            fa = el.arrhenius_factor_jit(tc, ea[i], t_ref[i])
            fq = el.capacity_factor_jit(tc, kq[i], t_ref[i])
            # tabulated OCV and R0 at the surface state of charge z − x (held at the ends)
            ocv = on_soc_grid(ocv_tab, ocv_idx[i], z[i] - xd[i])
            r0c = on_soc_grid(r0_tab, r0_idx[i], z[i] - xd[i]) * r0_scale[i] * fa
            e_p = ns[i] * (ocv + h[i] - v1[i])
            r_p = el.pack_resistance_jit(r0c, ns[i], npar[i])
            ld = load_table[i, col]
            if disconnected[i]:
                cur = 0.0
            elif not by_power:
                cur = ld
            elif ld == 0.0:
                cur = 0.0
            else:
                cur, delivered = el.delivered_current(ld, e_p, r_p)
                if not delivered and np.isnan(ev[2, i]):
                    ev[2, i] = t[j]
            volt = e_p - r_p * cur
            # the cut-off event compares the loaded cell voltage
            if cut > 0.0 and np.isnan(ev[0, i]):
                vcell = volt / ns[i]
                if vcell <= cut:
                    pv = prev_v[i]
                    if np.isnan(pv) or pv == vcell:
                        ev[0, i] = t[j]
                        ev[1, i] = q[i]
                    else:
                        w = (pv - cut) / (pv - vcell)
                        ev[0, i] = prev_t[i] + w * (t[j] - prev_t[i])
                        ev[1, i] = prev_q[i] + w * (q[i] - prev_q[i])
                    if end_at_cutoff:
                        ending = True
                    elif stop_at_cutoff:
                        disconnected[i] = True
                        cur = 0.0
                        volt = e_p
                prev_v[i] = vcell
                prev_q[i] = q[i]
                prev_t[i] = t[j]
            if np.isnan(ev[0, i]):
                all_cut = False
            heat = el.joule_heat_jit(cur, r_p, ns[i] * v1[i], r1_pack[i])
            if record:
                out[0, i, j] = cur
                out[1, i, j] = volt * cur
                out[2, i, j] = volt
                out[3, i, j] = ns[i] * ocv
                out[4, i, j] = z[i]
                out[5, i, j] = ns[i] * v1[i]
                out[6, i, j] = ns[i] * h[i]
                out[7, i, j] = temp[i]
                out[8, i, j] = heat
                out[9, i, j] = q[i]
                out[10, i, j] = e[i]
                out[11, i, j] = xd[i]
            if in_window or j == 0:
                if volt < vmin[i]:
                    vmin[i] = volt
                    ev[4, i] = j
                if temp[i] > tmax[i]:
                    tmax[i] = temp[i]
                ev[8, i] = q[i]
            if slot >= 0:
                probe[i, slot] = volt
            ev[11, i] = q[i]
            if d == 0.0 or ending:
                continue
            # state update over the step, exact for the held current
            icell = cur / npar[i]
            dq = icell * d if icell >= 0.0 else eta_c[i] * icell * d
            qcap = cap_as[i] * fq
            z_new = z[i] - dq / qcap
            if np.isnan(ev[3, i]) and z[i] > 0.0 >= z_new:
                ev[3, i] = t[j] + d * z[i] / (z[i] - z_new)
            z[i] = z_new
            if diff_gain[i] > 0.0:
                xd[i] = a_d[i] * xd[i] + (1.0 - a_d[i]) * diff_gain[i] * (dq / d) / qcap
            if gamma[i] > 0.0 and dq != 0.0:
                h[i] = el.hysteresis_step_jit(h[i], dq, qcap, gamma[i], m_h[i])
            if tau1[i] > 0.0:
                v1[i] = el.rc_step_jit(v1[i], icell, r1[i], a_rc[i])
            if thermal[i]:
                temp[i] = lumped_step(temp[i], t_air[i], heat, r_th[i], a_th[i])
            q[i] += cur * d
            e[i] += volt * cur * d
        if ending:
            break
        if stop_when_all_cut and all_cut and j >= n_window:
            break
    for i in range(k):
        ev[5, i] = vmin[i]
        ev[9, i] = tmax[i]
    return out, ev, probe, steps


def _tables(params_list):
    """Unique OCV and R0(SoC) grids of the packs, and each pack's row in them."""
    ocv_rows, ocv_key, ocv_idx = [], {}, []
    r0_rows, r0_key, r0_idx, r0_scale = [np.ones(SOC_GRID_POINTS)], {}, [], []
    z = np.linspace(0.0, 1.0, SOC_GRID_POINTS)
    for p in params_list:
        key = id(p.ocv)
        if key not in ocv_key:
            ocv_key[key] = len(ocv_rows)
            ocv_rows.append(soc_grid(p.ocv))
        ocv_idx.append(ocv_key[key])
        if p.r0_is_table:
            key = (tuple(p.r0_ohm[0]), tuple(p.r0_ohm[1]))
            if key not in r0_key:
                r0_key[key] = len(r0_rows)
                r0_rows.append(np.interp(z, p.r0_ohm[0], p.r0_ohm[1]))
            r0_idx.append(r0_key[key])
            r0_scale.append(1.0)
        else:
            r0_idx.append(0)
            r0_scale.append(float(p.r0_ohm))
    return (np.array(ocv_rows), np.array(ocv_idx, np.int64), np.array(r0_rows),
            np.array(r0_idx, np.int64), np.array(r0_scale))


@dataclass
class PackRuns:
    """Events and reductions of :func:`simulate_packs` (one element per pack).

    Attributes
    ----------
    cutoff_time_s, cutoff_charge_as : ndarray
        When the loaded cell voltage first reached the cut-off, and the charge drawn by
        then (interpolated between samples); NaN: not reached. [s], [A s]
    undeliverable_time_s : ndarray
        First time the asked power exceeded what the pack can deliver (NaN: never). [s]
    empty_time_s : ndarray
        When the state of charge first reached 0 (NaN: never). [s]
    window_min_voltage_v : ndarray
        Lowest loaded voltage over the window (the first ``n_window`` samples). [V]
    window_min_step : ndarray of int
        Sample of that lowest voltage.
    window_max_temperature_c : ndarray
        Highest cell temperature over the window. [°C]
    window_end_charge_as : ndarray
        Charge drawn before the last sample of the window. [A s]
    end_charge_as : ndarray
        Charge drawn before the last sample run. [A s]
    out_of_range_time_s, out_of_range_temperature_c : ndarray
        First time a coupled pack temperature left the model's range, and that
        temperature; from then on the model's parameters use the temperature held at the
        range's edge (NaN: never). [s], [°C]
    out_of_range_in_window : ndarray of bool
        Whether that happened within the window.
    probe_voltage_v : ndarray, shape (packs, probes)
        Loaded voltage at the probe samples. [V]
    steps : int
        Samples run (the run ends early once every pack is past the cut-off and the
        window, with ``stop_when_all_cut``).
    """

    cutoff_time_s: np.ndarray
    cutoff_charge_as: np.ndarray
    undeliverable_time_s: np.ndarray
    empty_time_s: np.ndarray
    window_min_voltage_v: np.ndarray
    window_min_step: np.ndarray
    window_max_temperature_c: np.ndarray
    window_end_charge_as: np.ndarray
    end_charge_as: np.ndarray
    out_of_range_time_s: np.ndarray
    out_of_range_temperature_c: np.ndarray
    out_of_range_in_window: np.ndarray
    probe_voltage_v: np.ndarray
    steps: int


def _prepare(params_list, thermal_list, t, temperature_c):
    k = len(params_list)
    ocv_tab, ocv_idx, r0_tab, r0_idx, r0_scale = _tables(params_list)
    arr = lambda f: np.array([float(f(p)) for p in params_list])  # noqa: E731
    thermal = np.array([th is not None for th in thermal_list], np.bool_)
    th_or = lambda f, d: np.array([f(th) if th is not None else d  # noqa: E731
                                   for th in thermal_list], float)
    temps = series_input(temperature_c, t.size, "temperature_c")
    return dict(
        ns=arr(lambda p: p.cells_series), npar=arr(lambda p: p.cells_parallel),
        cap_as=arr(lambda p: p.capacity_ah * AS_PER_AH),
        eta_c=arr(lambda p: p.coulombic_efficiency),
        m_h=arr(lambda p: p.hysteresis_v),
        gamma=arr(lambda p: p.hysteresis_gamma if p.hysteresis_v > 0 else 0.0),
        r1=arr(lambda p: p.r1_ohm), tau1=arr(lambda p: p.tau1_s),
        r1_pack=arr(lambda p: el.pack_resistance(p.r1_ohm, p.cells_series, p.cells_parallel)
                    if p.r1_ohm > 0 else np.inf),
        ea=arr(lambda p: p.r0_activation_energy_j_mol),
        t_ref=arr(lambda p: p.reference_temperature_c),
        kq=arr(lambda p: p.capacity_temp_coeff_per_c),
        ocv_tab=ocv_tab, ocv_idx=ocv_idx, r0_tab=r0_tab, r0_idx=r0_idx, r0_scale=r0_scale,
        thermal=thermal, r_th=th_or(lambda th: th.r_th_k_per_w, 0.0),
        tau_th=th_or(lambda th: th.tau_s, 1.0), t_air=th_or(lambda th: th.t_air_c, 0.0),
        t0=th_or(lambda th: th.initial_c, 0.0), temps=temps, k=k)


def simulate_packs(params_list, time_s, power_w, *, step_col=None, temperature_c=25.0,
                   thermal=None, v_cutoff_cell: float | None = None, window: int | None = None,
                   probes=None, stop_when_all_cut: bool = False) -> PackRuns:
    r"""
    Run the equivalent-circuit model of many packs through their load profiles at once.

    The same equations and the same time loop as :func:`simulate`, over a pack axis:
    the load of pack ``i`` at sample ``j`` is ``power_w[i, step_col[j]]``, so a mission
    of L legs needs only an (packs × L) table of leg powers, not (packs × samples).
    Only events and reductions are kept (:class:`PackRuns`).

    Parameters
    ----------
    params_list : sequence of CircuitParameters
        One per pack.
    time_s : array_like
        Sample times, non-decreasing. [s]
    power_w : array_like, shape (packs, columns)
        Power drawn from each pack, held from each sample to the next. [W]
    step_col : array_like of int, optional
        Column of ``power_w`` for each sample; default ``arange(samples)``.
    temperature_c : float or array_like
        Cell temperature of the packs without a thermal model (constant or per sample).
        [°C]
    thermal : sequence of ThermalParameters or None, optional
        Per pack: the lumped thermal model coupled to the circuit (air and initial
        temperature from it), or None for the prescribed ``temperature_c``.
    v_cutoff_cell : float, optional
        Cut-off per cell for the cut-off event. [V]
    window : int, optional
        The samples over which the minimum voltage, the maximum temperature and the
        charge at the end are taken (default all).
    probes : array_like of int, optional
        Samples at which the loaded voltage of every pack is kept.
    stop_when_all_cut : bool
        End the run once every pack has reached the cut-off, past the window.

    Returns
    -------
    PackRuns
    """
    t = np.asarray(time_s, float).ravel()
    n = t.size
    if n == 0:
        raise InputError("time_s is empty")
    if np.any(np.diff(t) < 0):
        raise InputError("time_s must not decrease")
    load = np.ascontiguousarray(np.asarray(power_w, float))
    if load.ndim != 2 or load.shape[0] != len(params_list):
        raise InputError("power_w must have one row per pack")
    step_col = (np.arange(n, dtype=np.int64) if step_col is None
                else np.asarray(step_col, np.int64))
    thermal = [None] * len(params_list) if thermal is None else list(thermal)
    k = _prepare(params_list, thermal, t, temperature_c)
    count = k.pop("k")
    n_window = n if window is None else max(int(window), 1)
    probes = np.zeros(0, np.int64) if probes is None else np.asarray(probes, np.int64)
    uniq, inverse = np.unique(probes, return_inverse=True)
    slot = np.full(n, -1, np.int64)
    slot[uniq] = np.arange(uniq.size)
    _, ev, probe, steps = _kernel(
        t, load, step_col, True, 1.0, 0.0, 0.0, **k, diff_gain=np.zeros(count),
        tau_d=np.ones(count), t_lo=T_RANGE_C[0], t_hi=T_RANGE_C[1],
        cut=float(v_cutoff_cell or 0.0), stop_at_cutoff=False, end_at_cutoff=False,
        n_window=n_window, probe_slot=slot, n_probes=int(uniq.size), record=False,
        stop_when_all_cut=bool(stop_when_all_cut))
    return PackRuns(
        cutoff_time_s=ev[0], cutoff_charge_as=ev[1], undeliverable_time_s=ev[2],
        empty_time_s=ev[3], window_min_voltage_v=ev[5],
        window_min_step=ev[4].astype(np.int64), window_max_temperature_c=ev[9],
        window_end_charge_as=ev[8], end_charge_as=ev[11], out_of_range_time_s=ev[6],
        out_of_range_temperature_c=ev[7], out_of_range_in_window=ev[10] == 1.0,
        probe_voltage_v=probe[:, inverse] if uniq.size else probe[:, :0], steps=int(steps))


def simulate(params: CircuitParameters, time_s, *, power_w=None, current_a=None,
             soc0: float = 1.0, temperature_c: float | Any | ThermalParameters = 25.0,
             v_cutoff_cell: float | None = None, stop_at_cutoff: bool = False,
             end_at_cutoff: bool = False, hysteresis0_v: float = 0.0, rc0_v: float = 0.0,
             diffusion: tuple[float, float] | None = None) -> CircuitResult:
    r"""
    Run the equivalent-circuit pack model through a load profile.

    Parameters
    ----------
    params : CircuitParameters
    time_s : array_like
        Sample times, non-decreasing. [s]
    power_w : numeric, optional
        Electric power drawn from the pack, held from each sample to the next
        (charging negative). Give this or ``current_a``. [W]
    current_a : numeric, optional
        Pack current, held from each sample to the next (discharge positive). [A]
    soc0 : float, default 1
        Initial state of charge. [unitless]
    temperature_c : float, array_like or ThermalParameters, default 25
        Cell temperature: a constant, one value per sample (prescribed), or a
        :class:`~planner.physics.battery.thermal.ThermalParameters` to couple the
        lumped thermal model (air temperature and initial temperature from
        it; the circuit's heat warms the pack). [°C]
    v_cutoff_cell : float, optional
        Cut-off per cell for the cut-off event. [V]
    stop_at_cutoff : bool, default False
        Disconnect the load (current 0) from the first sample at or below the
        cut-off on, as a low-voltage cut-off would (that sample then shows the
        rested voltage); otherwise the load goes on.
    end_at_cutoff : bool, default False
        End the run at the first sample at or below the cut-off, keeping that
        sample with its loaded values (a bench whose load trips there); the
        result is shorter than ``time_s``.
    hysteresis0_v, rc0_v : float, default 0
        Initial hysteresis and RC-branch voltage, per cell. [V]
    diffusion : (float, float), optional
        ``(c, tau_d_s)``: add the kinetic-battery-model diffusion state of the
        module notes (available-charge fraction ``c`` in (0, 1], relaxation
        time ``τ_d`` > 0 s). The surface deficit starts at 0 (equilibrium).

    Returns
    -------
    CircuitResult

    Raises
    ------
    InputError
        Bad arguments (both or neither load given, lengths, non-finite values).
    ModelError
        A temperature outside [−20 °C, 60 °C] (prescribed, or reached by the
        coupled thermal model — the message gives the time).

    Notes
    -----
    With a power load the current of each step is solved in closed form from
    :math:`P = (E - R I) I`, the smaller root
    :math:`I = 2P / (E + \sqrt{E^2 - 4RP})`, where ``E = n_s(OCV + h − v1)``
    and ``R = n_s R0 / n_p`` at the start of the step. When
    :math:`P > E^2/(4R)` the pack cannot deliver it: the event
    ``undeliverable_time_s`` records the first such time and the pack
    delivers its maximum power (``I = E/(2R)``) — no NaN. The energy drawn is
    then the delivered power, ``energy_j[-1] = Σ V_k I_k Δt_k``; otherwise it
    equals ``Σ P_k Δt_k``.

    The heat of every step, ``I² R0 + v_RC²/R1`` ([HESS] eq. 10), drives the lumped
    thermal step of :func:`planner.physics.battery.thermal.lumped_temperature` ([HESS] eq. 11).
    """
    if (power_w is None) == (current_a is None):
        raise InputError("give exactly one of power_w and current_a")
    t = np.asarray(time_s, dtype=float).ravel()
    n = t.size
    if n == 0:
        raise InputError("time_s is empty")
    if not np.all(np.isfinite(t)):
        raise InputError("time_s has a non-finite value")
    dt = np.diff(t)
    if np.any(dt < 0):
        k = int(np.flatnonzero(dt < 0)[0]) + 1
        raise InputError(f"time_s must not decrease (sample {k})")
    by_power = power_w is not None
    load = series_input(power_w if by_power else current_a, n,
                            "power_w" if by_power else "current_a")
    if not (0.0 <= float(soc0) <= 1.0):
        raise InputError(f"soc0 must lie in [0, 1], got {soc0!r}")
    if v_cutoff_cell is not None and not (0.0 < float(v_cutoff_cell) < 10.0):
        raise InputError(f"v_cutoff_cell must be a cell voltage in volts, got {v_cutoff_cell!r}")
    if end_at_cutoff and v_cutoff_cell is None:
        raise InputError("end_at_cutoff needs v_cutoff_cell")
    gain, tau_d = 0.0, 1.0
    if diffusion is not None:
        c_avail, tau_d = (float(v) for v in diffusion)
        if not (0.0 < c_avail <= 1.0 and math.isfinite(tau_d) and tau_d > 0.0):
            raise InputError(f"diffusion must be (c in (0, 1], tau_d > 0 s), got {diffusion!r}")
        # x settles at gain·i/Q under a steady current i (module notes)
        gain = (1.0 - c_avail) / c_avail * tau_d
    thermal = temperature_c if isinstance(temperature_c, ThermalParameters) else None
    if thermal is not None:
        check_temperature(thermal.t_air_c, "air temperature")
        check_temperature(thermal.initial_c, "initial pack temperature")
        temps = 25.0
    else:
        temps = series_input(temperature_c, n, "temperature_c")
        check_temperature(temps, "cell temperature")
    k = _prepare([params], [thermal], t, temps)
    k.pop("k")
    out, ev, _, steps = _kernel(
        t, load[None, :], np.arange(n, dtype=np.int64), by_power, float(soc0),
        float(hysteresis0_v), float(rc0_v), **k, diff_gain=np.array([gain]),
        tau_d=np.array([tau_d]), t_lo=T_RANGE_C[0], t_hi=T_RANGE_C[1],
        cut=float(v_cutoff_cell or 0.0), stop_at_cutoff=bool(stop_at_cutoff),
        end_at_cutoff=bool(end_at_cutoff), n_window=n, probe_slot=np.full(n, -1, np.int64),
        n_probes=0, record=True, stop_when_all_cut=False)
    if thermal is not None and np.isfinite(ev[6, 0]):
        raise ModelError(
            f"cell temperature reached {ev[7, 0]:.1f} °C at t = {ev[6, 0]:.0f} s (coupled "
            f"thermal model), outside the battery model's range "
            f"[{T_RANGE_C[0]:g} °C, {T_RANGE_C[1]:g} °C]")
    m = int(steps)
    o = out[:, 0, :m]
    opt = lambda v: None if not np.isfinite(v) else float(v)  # noqa: E731
    return CircuitResult(
        time_s=t[:m], current_a=o[0], power_w=o[1], voltage_v=o[2], ocv_v=o[3], soc=o[4],
        rc_voltage_v=o[5], hysteresis_v=o[6], temperature_c=o[7], heat_w=o[8],
        charge_as=o[9], energy_j=o[10], cells_series=params.cells_series,
        v_cutoff_cell=None if v_cutoff_cell is None else float(v_cutoff_cell),
        cutoff_time_s=opt(ev[0, 0]), cutoff_charge_as=opt(ev[1, 0]),
        undeliverable_time_s=opt(ev[2, 0]), empty_time_s=opt(ev[3, 0]),
        surface_deficit=o[11].copy() if diffusion is not None else None)


def with_changes(params: CircuitParameters, **changes) -> CircuitParameters:
    """A copy of ``params`` with some fields changed (validated again)."""
    return replace(params, **changes)
