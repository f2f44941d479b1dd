r"""Cell chemistries: open-circuit voltage, voltage window and cold behaviour.

A pack file names its chemistry (``chemistry:``); every name of :data:`CHEMISTRY_NAMES` has
here an open-circuit-voltage curve OCV(SoC) per cell, its charge and cut-off voltages, a
cold-capacity law Q(T) and a resistance law R0(T), each with its source. A pack that has
its own fitted curve (``circuit.ocv_csv``, as ``fit-battery`` writes it) is better served by
that curve; these are the defaults where it has none.

Open-circuit voltage
--------------------
=============  ===========================================================================
``lipo``       Fit of Chen and Rincón-Mora [CR06]_ to a Li-ion polymer (LiCoO2) cell,
               :func:`planner.physics.battery.ocv.lipo_ocv`: 2.65 V empty, 4.10 V full.
``lihv``       *Derived, no measured curve found*: the LiPo fit scaled by the ratio of the
               rated charge voltages, 4.35 V / 4.20 V (every voltage 3.6 % higher; 4.25 V
               full, 3.94 V at half charge). Marked as such wherever it is used.
``liion_nmc``  Pseudo-OCV of a Molicel INR21700-P42A cell (NMC/graphite), measured at C/32
               and room temperature, as the optimised lookup-table breakpoints of Sunil,
               Pattipati and Balasingam [SPB25]_ (repository soorajsunil/Piecewise-Battery-OCV,
               README.md @0002eb5), linear between breakpoints. ``liion`` is an alias.
``liion_nca``  *Derived from a paper's electrode model*: the full-cell OCV of the
               graphite/NCA cell of Kim et al. [KIM11]_, U_p(y) − U_n(x), from the two
               electrode open-circuit potentials and the electrode balance of that paper's
               parameter set (as tabulated in PyBaMM, ``NCA_Kim2011.py``): the lithium
               inventory of the initial concentrations, 100 % at 4.2 V and 0 % at 2.7 V
               (the set's cut-offs), :func:`nca_kim2011_ocv`. No measured NCA cell curve
               was found.
``lifepo4``    Pseudo-OCV of a Lithium Werks APR18650M1B cell (LiFePO4/graphite), C/32,
               room temperature, breakpoints of [SPB25]_.
=============  ===========================================================================

Cold: capacity and resistance
-----------------------------
The capacity left at a temperature below the reference (25 °C) falls linearly,
:math:`Q(T)/Q_{ref} = 1 - k\,\max(0, T_{ref} - T)`, and the ohmic resistance follows
Arrhenius, :math:`R_0(T)/R_0(T_{ref}) = \exp[E_a/R\,(1/T - 1/T_{ref})]` — the laws of the
equivalent-circuit model (:mod:`planner.physics.battery.circuit`), with per-chemistry values:

* ``k`` = 0.006 /°C for the LiCoO2, NMC and NCA cells (LiPo, LiHV, Li-ion): the circuit
  model's default, consistent with the roughly 65 % of room-temperature energy that Zhang,
  Xu and Jow [ZXJ03]_ report for commercial Li-ion cells at −20 °C. For LiFePO4
  ``k`` = 0.0005 /°C, from measurement: the A123 LiFePO4 cell of Plett's ESC toolbox data
  [PL15]_ gives at C/30 98.2 % of its 25 °C charge at −25 °C (2.023 against 2.060 A h) and
  99.05 % at 5 °C, the steepest loss per degree; 0.0005 /°C keeps the law at or under every
  measured temperature. At that rate the loss is thermodynamic only — the rate-dependent
  part comes from R0(T).
* :math:`E_a`: for LiPo and LiHV the graphite exchange-current activation energy of the
  LiCoO2/graphite Kokam pouch cell of PyBaMM's ``Marquis2019`` set (Dualfoil), 37.48 kJ/mol
  (LiHV: *assumed* equal to LiPo); for NMC that of the LG M50 graphite electrode of Chen et
  al. [CHEN20]_, 35 kJ/mol; for NCA that of Kim et al. [KIM11]_, 30 kJ/mol (both
  electrodes); for LiFePO4 31.7 kJ/mol, fitted here on the 1-s step resistance of Plett's
  A123 cell at −25, −15, −5, 5, 15 and 25 °C (median ΔV/ΔI over current steps above 0.5 A
  in the dynamic tests: 126, 58.6, 29.2, 17.6, 12.5, 9.9 mΩ). The measured LiFePO4 value,
  which sees the ohmic and the charge-transfer parts a one-second pulse sees, lies in the
  range of the electrode values, which is why the electrode values are used for the others.

The two laws together make a cold pack give less and sag more: neither can add margin below
the reference temperature (:func:`capacity_factor` ≤ 1, :func:`resistance_factor` ≥ 1).

References
----------
.. [CR06] M. Chen and G. A. Rincón-Mora, "Accurate electrical battery model capable of
   predicting runtime and I–V performance," IEEE Trans. Energy Convers., vol. 21, no. 2,
   pp. 504–511, 2006.
.. [SPB25] S. Sunil, K. R. Pattipati and B. Balasingam, "Piecewise linear approximation of
   battery open-circuit voltage characteristics using dynamic programming," IEEE Trans.
   Instrum. Meas., 2025.
.. [KIM11] G.-H. Kim, K. Smith, K.-J. Lee, S. Santhanagopalan and A. Pesaran, "Multi-domain
   modeling of lithium-ion batteries encompassing multi-physics in varied length scales,"
   J. Electrochem. Soc., vol. 158, no. 8, pp. A955–A969, 2011.
.. [CHEN20] C.-H. Chen et al., "Development of experimental techniques for parameterization
   of multi-scale lithium-ion battery models," J. Electrochem. Soc., vol. 167, 080534, 2020.
.. [ZXJ03] S. S. Zhang, K. Xu and T. R. Jow, "The low temperature performance of Li-ion
   batteries," J. Power Sources, vol. 115, pp. 137–140, 2003.
.. [PL15] G. L. Plett, Battery Management Systems, Vol. I: Battery Modeling, Artech House,
   2015; its ESC toolbox data (A123 OCV and dynamic tests, −25 to 45 °C).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from planner.physics.battery.ocv import OcvTable, lipo_ocv, ocv_table

__all__ = ["ALIASES", "CHEMISTRIES", "CHEMISTRY_NAMES", "Chemistry", "capacity_factor",
           "chemistry", "lihv_ocv", "nca_kim2011_ocv", "nca_kim2011_table",
           "resistance_factor"]

#: Universal gas constant. [J/(mol K)]
R_GAS = 8.314462618
#: Reference temperature of the cold laws. [°C]
REFERENCE_TEMPERATURE_C = 25.0
#: Rated charge voltages whose ratio scales the LiPo curve into the LiHV one. [V]
LIPO_CHARGE_V, LIHV_CHARGE_V = 4.20, 4.35

#: Molicel INR21700-P42A pseudo-OCV at C/32 ([SPB25]_ breakpoints). [unitless], [V]
P42A_SOC = (0.0, 0.0151, 0.0452, 0.0955, 0.1508, 0.2915, 0.4573, 0.8342, 0.9497, 1.0)
P42A_OCV_V = (2.5061, 2.8981, 3.1461, 3.3231, 3.4218, 3.5737, 3.7017, 4.0637, 4.1009, 4.1932)
#: Lithium Werks APR18650M1B (LiFePO4) pseudo-OCV at C/32 ([SPB25]_ breakpoints).
APR18650M1B_SOC = (0.0, 0.0033, 0.0117, 0.0267, 0.0534, 0.0885, 0.2972, 0.9833, 0.995, 1.0)
APR18650M1B_OCV_V = (2.0102, 2.4177, 2.7405, 2.9299, 3.0872, 3.1942, 3.2772, 3.3511, 3.418,
                     3.5981)


def lihv_ocv(soc):
    """LiHV cell OCV: the LiPo fit scaled by 4.35/4.20 (derived, see the module notes). [V]"""
    return lipo_ocv(soc) * (LIHV_CHARGE_V / LIPO_CHARGE_V)


# --------------------------------------------------------------------------- NCA (Kim 2011)

def _graphite_ocp_kim2011(x):
    """Graphite OCP of [KIM11]_ against the stoichiometry x (PyBaMM NCA_Kim2011.py). [V]"""
    return (0.124 + 1.5 * np.exp(-70 * x) - 0.0351 * np.tanh((x - 0.286) / 0.083)
            - 0.0045 * np.tanh((x - 0.9) / 0.119) - 0.035 * np.tanh((x - 0.99) / 0.05)
            - 0.0147 * np.tanh((x - 0.5) / 0.034) - 0.102 * np.tanh((x - 0.194) / 0.142)
            - 0.022 * np.tanh((x - 0.98) / 0.0164) - 0.011 * np.tanh((x - 0.124) / 0.0226)
            + 0.0155 * np.tanh((x - 0.105) / 0.029))


def _nca_ocp_kim2011(y):
    """NCA OCP of [KIM11]_ against the stoichiometry y (PyBaMM NCA_Kim2011.py). [V]"""
    y = np.asarray(y, float)
    with np.errstate(over="ignore"):
        tail = 0.61386 * np.exp(5.8201 * np.minimum(y, 1.0) ** 136.4)
    return (1.638 * y**10 - 2.222 * y**9 + 15.056 * y**8 - 23.488 * y**7 + 81.246 * y**6
            - 344.566 * y**5 + 621.3475 * y**4 - 554.774 * y**3 + 264.427 * y**2
            - 66.3691 * y + 11.8058 - tail)


#: Electrode balance of the Kim 2011 "nominal design" cell (PyBaMM NCA_Kim2011.py):
#: active volume fraction × thickness × maximum concentration per electrode, and the
#: initial concentrations, which fix the cell's lithium inventory. [1], [m], [mol m⁻³]
KIM2011_NEGATIVE = (0.51, 7e-5, 28700.0, 18081.0)
KIM2011_POSITIVE = (0.41, 5e-5, 49000.0, 20090.0)
#: Voltage window of the Kim 2011 set (its lower and upper cut-offs). [V]
KIM2011_WINDOW_V = (2.7, 4.2)


@functools.lru_cache(maxsize=1)
def nca_kim2011_table(points: int = 101) -> OcvTable:
    r"""The graphite/NCA full-cell OCV of [KIM11]_ as a table over the state of charge.

    With :math:`Q_n, Q_p` the electrode capacities (volume fraction × thickness × maximum
    concentration, per unit area) and :math:`Q_{Li}` the cyclable lithium of the initial
    concentrations, the stoichiometries at 100 % solve
    :math:`U_p(y_{100}) - U_n(x_{100}) = 4.2` V with :math:`x Q_n + y Q_p = Q_{Li}`; the
    cell's charge :math:`Q` is where :math:`U_p(y_{100} + Q/Q_p) - U_n(x_{100} - Q/Q_n)`
    reaches 2.7 V; between, :math:`x = x_{100} - (1-s) Q/Q_n`, :math:`y = y_{100} + (1-s)
    Q/Q_p` at state of charge ``s`` (the electrode balance of PyBaMM's ``ElectrodeSOH``).
    """
    (en, ln, cn, cn0), (ep, lp, cp, cp0) = KIM2011_NEGATIVE, KIM2011_POSITIVE
    q_n, q_p = en * ln * cn, ep * lp * cp                   # [mol m⁻²]
    q_li = en * ln * cn0 + ep * lp * cp0
    v_lo, v_hi = KIM2011_WINDOW_V

    def at_full(x):
        return _nca_ocp_kim2011((q_li - x * q_n) / q_p) - _graphite_ocp_kim2011(x) - v_hi

    x100 = brentq(at_full, 0.3, 0.99)
    y100 = (q_li - x100 * q_n) / q_p

    def voltage(q):
        return _nca_ocp_kim2011(y100 + q / q_p) - _graphite_ocp_kim2011(x100 - q / q_n)

    q_cell = brentq(lambda q: voltage(q) - v_lo, 1e-9,
                    min(x100 * q_n, (1.0 - y100) * q_p) * (1 - 1e-9))
    soc = np.linspace(0.0, 1.0, points)
    return ocv_table(soc, voltage((1.0 - soc) * q_cell), where="Kim et al. 2011 (NCA)")


def nca_kim2011_ocv(soc):
    """NCA cell OCV of [KIM11]_'s electrode model (:func:`nca_kim2011_table`). [V]"""
    return nca_kim2011_table()(soc)


# --------------------------------------------------------------------------- the table

@dataclass(frozen=True)
class Chemistry:
    """One cell chemistry (see the module notes for every number's source).

    Attributes
    ----------
    name : str
    ocv : callable
        ``ocv(soc) -> V`` per cell, SoC in [0, 1] (clipped).
    ocv_source : str
        Where the curve comes from, and whether it is measured, fitted or derived.
    charge_v, cutoff_v : float
        Charge (full) and discharge cut-off cell voltages of the curve's source. [V]
    capacity_temp_coeff_per_c : float
        ``k`` of Q(T) = Q_ref (1 − k max(0, T_ref − T)). [1/°C]
    r0_activation_energy_j_mol : float
        Arrhenius activation energy of R0. [J/mol]
    cold_source : str
        Where ``k`` and the activation energy come from.
    derived : bool
        True where the OCV curve is derived rather than measured or fitted to a cell.
    """

    name: str
    ocv: Callable
    ocv_source: str
    charge_v: float
    cutoff_v: float
    capacity_temp_coeff_per_c: float
    r0_activation_energy_j_mol: float
    cold_source: str
    derived: bool = False

    @property
    def full_v(self) -> float:
        """OCV of a full cell on this chemistry's curve. [V]"""
        return float(self.ocv(1.0))

    @property
    def empty_v(self) -> float:
        """OCV of an empty cell on this chemistry's curve. [V]"""
        return float(self.ocv(0.0))

    def capacity_factor(self, temperature_c):
        """Q(T)/Q(25 °C): 1 at and above 25 °C, linear below, never below 0. [unitless]"""
        t = np.asarray(temperature_c, float)
        f = np.clip(1.0 - self.capacity_temp_coeff_per_c
                    * np.maximum(REFERENCE_TEMPERATURE_C - t, 0.0), 0.0, 1.0)
        return float(f) if f.ndim == 0 else f

    def resistance_factor(self, temperature_c):
        """R0(T)/R0(25 °C) from Arrhenius (> 1 below 25 °C). [unitless]"""
        t_k = np.asarray(temperature_c, float) + 273.15
        t_ref = REFERENCE_TEMPERATURE_C + 273.15
        f = np.exp(self.r0_activation_energy_j_mol / R_GAS * (1.0 / t_k - 1.0 / t_ref))
        return float(f) if f.ndim == 0 else f


_LIION_COLD = ("k from the circuit model's default (Zhang, Xu and Jow 2003: about 65 % of "
               "room-temperature energy at −20 °C); ")

CHEMISTRIES: dict[str, Chemistry] = {
    "lipo": Chemistry(
        "lipo", lipo_ocv,
        "fit of Chen and Rincón-Mora 2006 to a Li-ion polymer (LiCoO2) cell",
        4.20, 3.00, 0.006, 37_480.0,
        _LIION_COLD + "Ea: graphite exchange current of the LiCoO2/graphite Kokam pouch "
                      "cell, PyBaMM Marquis2019 (Dualfoil)"),
    "lihv": Chemistry(
        "lihv", lihv_ocv,
        "derived, no measured LiHV curve found: the LiPo fit (Chen and Rincón-Mora 2006) "
        "scaled by 4.35 V / 4.20 V",
        4.35, 3.00, 0.006, 37_480.0,
        _LIION_COLD + "Ea assumed equal to LiPo's", derived=True),
    "liion_nmc": Chemistry(
        "liion_nmc", OcvTable(np.array(P42A_SOC), np.array(P42A_OCV_V),
                              source="Molicel P42A, Sunil et al. 2025"),
        "pseudo-OCV of a Molicel INR21700-P42A cell at C/32 (NMC/graphite), breakpoints of "
        "Sunil, Pattipati and Balasingam 2025",
        4.20, 2.50, 0.006, 35_000.0,
        _LIION_COLD + "Ea: LG M50 graphite exchange current, Chen et al. 2020"),
    "liion_nca": Chemistry(
        "liion_nca", nca_kim2011_ocv,
        "derived from the electrode model of Kim et al. 2011 (graphite/NCA open-circuit "
        "potentials and electrode balance, PyBaMM NCA_Kim2011); no measured NCA cell curve "
        "found",
        4.20, 2.70, 0.006, 30_000.0,
        _LIION_COLD + "Ea: exchange currents of Kim et al. 2011", derived=True),
    "lifepo4": Chemistry(
        "lifepo4", OcvTable(np.array(APR18650M1B_SOC), np.array(APR18650M1B_OCV_V),
                            source="Lithium Werks APR18650M1B, Sunil et al. 2025"),
        "pseudo-OCV of a Lithium Werks APR18650M1B cell at C/32 (LiFePO4/graphite), "
        "breakpoints of Sunil, Pattipati and Balasingam 2025",
        3.60, 2.00, 0.0005, 31_700.0,
        "k and Ea measured on the A123 LiFePO4 cell of Plett's ESC toolbox data (C/30 "
        "capacity and 1-s step resistance, −25 to 25 °C)"),
}

#: Other names accepted in pack files, and the chemistry each means.
ALIASES = {"liion": "liion_nmc"}
#: Every value ``chemistry:`` may take in a pack file.
CHEMISTRY_NAMES = tuple(CHEMISTRIES) + tuple(ALIASES)


def chemistry(name: str) -> Chemistry:
    """The :class:`Chemistry` of a name of :data:`CHEMISTRY_NAMES` (aliases resolved).

    Raises
    ------
    KeyError
        An unknown name (pack files are checked against the vocabulary when loaded).
    """
    return CHEMISTRIES[ALIASES.get(name, name)]


def capacity_factor(name: str, temperature_c):
    """Q(T)/Q(25 °C) of chemistry ``name`` (:meth:`Chemistry.capacity_factor`). [unitless]"""
    return chemistry(name).capacity_factor(temperature_c)


def resistance_factor(name: str, temperature_c):
    """R0(T)/R0(25 °C) of chemistry ``name`` (:meth:`Chemistry.resistance_factor`). [unitless]"""
    return chemistry(name).resistance_factor(temperature_c)
