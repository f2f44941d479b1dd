r"""The steps of the mission chain, each a function you can call and test alone.

:meth:`planner.chain.mission_chain.MissionChain.run` is this sequence, as pvlib's
``ModelChain.run_model`` is a sequence of model steps:

1. :func:`chain_inputs` — the weather flown, the payload, the packs' parameters as arrays
   (with a Monte Carlo run's samples) and each pack's take-off mass;
2. :func:`flight_states` — the legs' kinematics, the return-home points and the hold
   (:mod:`planner.chain.kinematics`);
3. :func:`power_step` — one battery-power model call for every state and take-off mass
   (:class:`planner.chain.powertable.PowerTable`);
4. the battery models, chosen per pack by name: :func:`circuit_model` (the equivalent
   circuit and lumped thermal model, [HESS] eq. 1–5, 10–11, for the packs that use it;
   its cut-off may lower the usable charge, :func:`charge_budget`), then, in blocks of
   packs, :func:`leg_figures` (the integral capacity model, [UAV23] eq. 14, and the
   loaded current of every leg);
5. :func:`return_home` — the return-home reserve at every point;
6. :func:`constraints` — which of :data:`CHECK_CONSTRAINTS` each pack breaks.

With the integral model the charge of a profile is not additive but its *stress*
:math:`S = \int dt/(\delta P^\varepsilon)` is, so the return-home charge from a point is
:math:`(S_{point} + S_{return})^{1/\beta}`
(:func:`planner.physics.battery.integral.charge_from_stress`). Charges are in A s inside,
mAh where the result reports them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from planner.chain import kinematics
from planner.chain.powertable import PowerTable
from planner.errors import InputError
from planner.parameters import Aircraft, BatteryPack
from planner.physics.atmosphere import G
from planner.physics.battery import chemistry, integral
from planner.physics.battery.circuit import simulate_packs
from planner.physics.battery.elements import (
    loaded_current,
    loaded_current_jit,
    power_limit_jit,
)
from planner.physics.battery.integral import charge_from_stress_jit
from planner.physics.battery.ocv import lipo_ocv, lipo_ocv_jit
from planner.physics.battery.thermal import T_RANGE_C
from planner.physics.kernel import kernel
from planner.physics.mission import Environment, Mission
from planner.physics.units import AS_PER_MAH, J_PER_WH

__all__ = ["CHECK_CONSTRAINTS", "CIRCUIT_FIGURES", "DEFAULT_MIN_THRUST_TO_WEIGHT",
           "AircraftLimits", "ChainInputs", "ChainPower",
           "ChargeBudget", "CircuitRun", "FlightStates", "LegFigures", "PackFigures",
           "ReturnHome", "aircraft_limits", "chain_inputs", "charge_budget", "circuit_model", "circuit_packs",
           "constraints", "flight_states", "leg_at", "leg_end_voltage", "leg_figures",
           "leg_kernel", "margin_time", "pack_arrays", "pack_blocks", "power_step",
           "return_home"]

#: The constraints of every verdict (``check``, ``select``, the sortie planner), in the
#: order their reasons are given; the first violated one is a rejected pack's *binding*
#: constraint. ``cells`` and ``thrust`` are the aircraft's own limits
#: (:func:`aircraft_limits`).
CHECK_CONSTRAINTS = ("mission", "cells", "thrust", "power", "c_rating", "takeoff_mass",
                     "temperature", "voltage", "runs_out", "landing_reserve", "return_home")

#: Minimum thrust-to-weight ratio of a multirotor (controllability margin for gusts and
#: manoeuvres) when the aircraft gives ``multirotor.max_thrust_n``. [unitless]
DEFAULT_MIN_THRUST_TO_WEIGHT = 1.5

#: The circuit model's time step through the mission, and after it (the run on to the
#: cut-off at the hold power that finds the usable charge), and how long that runs. [s]
CIRCUIT_STEP_S = 1.0
CIRCUIT_EXTEND_STEP_S = 5.0
CIRCUIT_EXTEND_S = 7200.0

#: Air (and starting pack) temperature of the circuit model when none is given. [°C]
DEFAULT_PACK_TEMPERATURE_C = 25.0

#: Figures of the circuit model per pack (see
#: :class:`planner.chain.mission_chain.ChainResult`).
CIRCUIT_FIGURES = ("min_voltage_v", "voltage_margin_v", "worst_leg", "cutoff_time_s",
                   "charge_to_cutoff_mah", "charge_used_mah", "max_temperature_c",
                   "pack_temperature_c", "cutoff_leg", "collapse_time_s", "collapse_leg",
                   "hot_time_s", "hot_temperature_c", "collapse_power_w")

#: States of charge over which :func:`cold_factor` averages the loaded current.
COLD_SOC_POINTS = 101

#: Packs that keep their per-leg detail by default (a catalog keeps none).
DETAIL_MAX_PACKS = 16


# --------------------------------------------------------------------------- 1. inputs

@dataclass
class ChainInputs:
    """What every step reads (step 1, :func:`chain_inputs`).

    Attributes
    ----------
    aircraft : Aircraft
    packs : list of BatteryPack
    models : list of str
        ``"integral"`` or ``"circuit"``, per pack.
    mission : Mission
    environment : Environment
        The weather flown: the override, else the mission's.
    temperature_c : float or None
        Air temperature used: the chain's, else the weather's; None = ISA. [°C]
    payload_kg : float or ndarray
        One value, or one per pack. [kg]
    keep : bool
        Keep the per-leg detail (packs × legs).
    pack : dict of ndarray
        The packs' parameters, one element per pack (:func:`pack_arrays`; SI units).
    soh : ndarray
        State of health per pack (1 unless sampled). [unitless]
    mass : ndarray
        Take-off mass per pack. [kg]
    reserve : float
        Landing reserve over nominal capacity. [unitless]
    min_thrust_to_weight : float
        Least maximum thrust over take-off weight of a multirotor. [unitless]
    notes : list of str
        What the chain changed in the mission to judge it (the return home it added,
        :func:`planner.chain.kinematics.closed_mission`).
    """

    aircraft: Aircraft
    packs: list[BatteryPack]
    models: list[str]
    mission: Mission
    environment: Environment
    temperature_c: float | None
    payload_kg: Any
    keep: bool
    pack: dict[str, np.ndarray]
    soh: np.ndarray
    mass: np.ndarray
    reserve: float
    min_thrust_to_weight: float = DEFAULT_MIN_THRUST_TO_WEIGHT
    notes: list = None

    @property
    def flown_environment(self) -> Environment:
        """The weather flown, with the air temperature used."""
        return replace(self.environment, temperature_c=self.temperature_c)


def chain_inputs(aircraft: Aircraft, packs: list[BatteryPack], models: list[str],
                 mission: Mission, environment: Environment | None, *,
                 temperature_c: float | None = None, reserve: float = 0.2,
                 payload_kg=None, detail: bool | None = None,
                 pack_samples: dict | None = None,
                 min_thrust_to_weight: float = DEFAULT_MIN_THRUST_TO_WEIGHT) -> ChainInputs:
    """Step 1: the inputs of a run, checked (:class:`ChainInputs`).

    ``environment`` overrides the mission's weather, ``temperature_c`` [°C] its air
    temperature, ``payload_kg`` its payload (one value or one per pack) [kg];
    ``pack_samples`` replaces per pack the integral model's ``delta``, ``epsilon``,
    ``beta``, gives a state of health ``soh`` that scales the usable charge and a
    ``power_scale`` that multiplies the battery power (a Monte Carlo draw of the power
    model's own error).

    Raises
    ------
    InputError
        No pack, no leg, or a pack (or a sample) whose δ or β is not positive.
    ValueError
        An unknown key of ``pack_samples``.
    """
    env = environment or mission.environment
    temp = temperature_c if temperature_c is not None else env.temperature_c
    payload = (mission.payload_kg if payload_kg is None else float(payload_kg)
               if np.ndim(payload_kg) == 0 else np.asarray(payload_kg, float))
    if not packs:
        raise InputError("the chain needs at least one pack to fly a mission")
    if not mission.legs:
        raise InputError(f"{mission.source or mission.name}: the mission has no legs")
    bad = [f"{p.path or p.name}: integral model delta = {p.model.delta:.4g}"
           + (f" (literature δ₀({p.cells_series}) is only valid for few-cell packs; give "
              "a fitted 'model:')" if p.model.literature else "")
           for p in packs if not (p.model.delta > 0 and p.model.beta > 0)]
    if bad:
        raise InputError("; ".join(bad) + " — delta must be > 0")
    mission, bounded = kinematics.flyable_legs(mission, aircraft)
    mission, note = kinematics.closed_mission(mission)
    pa = pack_arrays(packs, temp)
    t_pack = DEFAULT_PACK_TEMPERATURE_C if temp is None else float(temp)
    if t_pack < chemistry.REFERENCE_TEMPERATURE_C:
        # the integral model's packs sag through R0(T) of their chemistry in the cold
        # (the circuit model carries its own law): cold_factor
        for i, (p, m) in enumerate(zip(packs, models)):
            if m == "integral":
                pa["r"][i] *= float(chemistry.resistance_factor(p.chemistry, t_pack))
    soh = _apply_samples(pa, pack_samples or {}, len(packs))
    return ChainInputs(
        aircraft=aircraft, packs=list(packs), models=list(models), mission=mission,
        environment=env, temperature_c=temp, payload_kg=payload,
        keep=(len(packs) <= DETAIL_MAX_PACKS) if detail is None else bool(detail),
        pack=pa, soh=soh, mass=aircraft.empty_mass_kg + pa["mass"] + payload,
        reserve=float(reserve), min_thrust_to_weight=float(min_thrust_to_weight),
        notes=[n for n in (bounded, note) if n is not None])


def pack_arrays(packs, temperature_c) -> dict[str, np.ndarray]:
    """Per-pack parameters as arrays (one Python pass over the packs).

    Keys: ``mass`` [kg], ``cap`` nominal and ``usable`` charge [A s], ``r`` installed
    resistance (0 when unknown) [Ω], ``imax`` C-rating current (NaN: no rating) [A],
    ``cells``, the integral model's ``delta``, ``eps``, ``beta`` and ``scale`` (its
    extensions' charge factor at ``temperature_c`` [°C]). The totals are those of
    :class:`~planner.parameters.BatteryPack` (``count`` packs in parallel: mass and
    capacity × count, resistance ÷ count).
    """
    nan = float("nan")
    rows = [(p.mass_kg, p.count, p.capacity_mah, p.usable_fraction,
             nan if p.internal_resistance_ohm is None else p.internal_resistance_ohm,
             nan if p.max_discharge_c is None else p.max_discharge_c, p.cells_series,
             p.model.delta, p.model.epsilon, p.model.beta,
             p.model.charge_scale(temperature_c)
             if (p.model.fade_per_cycle or p.model.temperature_coefficient_per_c) else 1.0)
            for p in packs]
    (m, count, cap_mah, frac, r, c_rate, cells, delta, eps, beta,
     scale) = np.array(rows, dtype=float).T
    total_mah = cap_mah * count
    return {"mass": m * count, "cap": total_mah * AS_PER_MAH,
            "usable": total_mah * AS_PER_MAH * frac,
            "r": np.nan_to_num(r, nan=0.0) / count, "imax": c_rate * total_mah / 1000.0,
            "cells": cells, "delta": delta, "eps": eps, "beta": beta, "scale": scale,
            "log_power_scale": np.zeros(len(packs))}


def _apply_samples(pa: dict, samples: dict, k: int) -> np.ndarray:
    """Replace the sampled parameters of ``pa`` in place; the state of health per pack."""
    soh = np.ones(k)
    for key, values in samples.items():
        v = np.broadcast_to(np.asarray(values, float), (k,)).copy()
        if key == "soh":
            soh = v
            pa["usable"] = pa["usable"] * v
        elif key in ("delta", "epsilon", "beta"):
            pa["eps" if key == "epsilon" else key] = v
        elif key == "power_scale":
            if not np.all(v > 0):
                raise InputError(f"pack sample {int(np.argmax(~(v > 0)))}: power_scale "
                                 "must be > 0")
            pa["log_power_scale"] = np.log(v)
        else:
            raise ValueError(f"pack_samples: unknown key {key!r}")
    bad_sample = ~((pa["delta"] > 0) & (pa["beta"] > 0))
    if samples and bad_sample.any():
        raise InputError(f"pack sample {int(np.argmax(bad_sample))}: delta and beta must "
                         "be > 0")
    return soh


# --------------------------------------------------------------------------- 2. states

@dataclass
class FlightStates:
    """The flight states of a mission (step 2, :func:`flight_states`).

    Attributes
    ----------
    table : LegTable
        Leg kinematics (:func:`planner.chain.kinematics.leg_table`).
    rtl : dict
        The return-home points (:func:`planner.chain.kinematics.return_home_points`),
        cut to ``subset`` when one is given.
    subset : ndarray of int or None
        The indices of the points kept (all when None).
    hold : tuple
        Airspeed [m/s], climb rate [m/s], air density [kg m⁻³] and load factor of
        holding position at home.
    """

    table: Any
    rtl: dict
    subset: np.ndarray | None
    hold: tuple

    @property
    def legs(self) -> int:
        """Legs of the mission."""
        return len(self.table)

    @property
    def points(self) -> int:
        """Return-home points (those of the subset, when one is given)."""
        return len(self.rtl["leg"])


def flight_states(inputs: ChainInputs, rtl_subset=None) -> FlightStates:
    """Step 2: legs, return-home points (all, or those of ``rtl_subset``) and the hold.

    Raises
    ------
    ValueError
        ``rtl_subset`` not increasing, not ending with the mission's end, or asked
        together with the per-leg detail.
    """
    ac, env, temp = inputs.aircraft, inputs.environment, inputs.temperature_c
    table = kinematics.leg_table(inputs.mission, ac, env, temperature_c=temp)
    table.notes[:0] = inputs.notes or []
    rtl = kinematics.return_home_points(table, ac, env, temp)
    npts_all = len(rtl["leg"])
    sub = None
    if rtl_subset is not None:
        sub = np.asarray(rtl_subset, int)
        if (sub.ndim != 1 or not sub.size or sub[-1] != npts_all - 1
                or np.any(np.diff(sub) <= 0) or sub[0] < 0):
            raise ValueError("rtl_subset must be increasing point indices ending with the "
                             f"mission's end ({npts_all - 1})")
        if inputs.keep:
            raise ValueError("rtl_subset runs keep no per-leg detail (detail=False)")

        def cut(v):
            return v[sub] if np.ndim(v) and np.shape(v)[0] == npts_all else v

        rtl = {key: (tuple(cut(x) for x in v) if isinstance(v, tuple) else cut(v))
               for key, v in rtl.items()}
    hold = kinematics.hold_state(ac, float(table.air_density[-1]), env.wind_speed_ms)
    return FlightStates(table=table, rtl=rtl, subset=sub, hold=hold)


# --------------------------------------------------------------------------- 3. power

@dataclass
class ChainPower:
    """The battery power of every flight state at every take-off mass (step 3).

    ``table`` is the :class:`~planner.chain.powertable.PowerTable`; ``leg``, ``back``,
    ``down`` (per return-home point) and ``hold`` index its states.
    """

    table: PowerTable
    leg: np.ndarray
    back: np.ndarray
    down: np.ndarray
    hold: int


def power_step(inputs: ChainInputs, states: FlightStates, method: str = "auto") -> ChainPower:
    """Step 3: one power table over the legs, the return home (straight back, descent)
    and the hold, for every take-off mass (``method`` as in
    :class:`~planner.chain.powertable.PowerTable`)."""
    t, n, npts = states.table, states.legs, states.points
    groups = [(t.airspeed_ms, t.climb_rate_ms, t.air_density, t.load_factor),
              states.rtl["back"], states.rtl["down"], states.hold]
    sizes = [n, npts, npts, 1]
    cols = [np.concatenate([np.broadcast_to(np.asarray(g[c], float), (s,))
                            for g, s in zip(groups, sizes)]) for c in range(4)]
    table = PowerTable(inputs.aircraft, *cols, masses=inputs.mass, method=method)
    inv = table.inverse
    return ChainPower(table=table, leg=inv[:n], back=inv[n:n + npts],
                      down=inv[n + npts:n + 2 * npts], hold=int(inv[-1]))


# --------------------------------------------------------------------------- 4. battery

@dataclass
class CircuitRun:
    """The equivalent-circuit model of the packs that use it (step 4a).

    Attributes
    ----------
    figures : dict of ndarray
        :data:`CIRCUIT_FIGURES`, one element per pack of the chain (NaN for the packs on
        the integral model).
    which : list of int
        The packs on the circuit model.
    usable_as : ndarray
        Their charge to the cut-off (one per ``which``). [A s]
    leg_voltage_v : ndarray
        Their loaded voltage at the end of every leg (``which`` × legs). [V]
    temperature_bad : ndarray of bool
        Per pack of the chain: the temperature left the model's range in the mission.
    """

    figures: dict[str, np.ndarray]
    which: list[int]
    usable_as: np.ndarray
    leg_voltage_v: np.ndarray
    temperature_bad: np.ndarray


def circuit_model(inputs: ChainInputs, states: FlightStates, power: ChainPower) -> CircuitRun:
    """Step 4a: the circuit (and thermal) model of the packs whose model is ``"circuit"``.

    The distinct (pack, take-off mass, power scale) triples are run once
    (:func:`circuit_packs`) and spread back: the samples of a Monte Carlo run share one
    pack file and differ in the circuit model only by their mass and power scale.
    """
    k = len(inputs.packs)
    figures = {name: np.full(k, np.nan) for name in CIRCUIT_FIGURES}
    which = [i for i, m in enumerate(inputs.models) if m == "circuit"]
    t_pack = pack_temperature_c(inputs)
    figures["pack_temperature_c"][:] = t_pack
    # the cold laws of the integral model's packs (cold_factor) are those of the circuit
    # model: outside its range neither can vouch for the pack
    bad = np.full(k, not T_RANGE_C[0] <= t_pack <= T_RANGE_C[1])
    bad[which] = False
    if not which:
        return CircuitRun(figures, which, np.zeros(0), np.zeros((0, states.legs)), bad)
    keys = [(id(inputs.packs[i]), float(inputs.mass[i]),
             float(inputs.pack["log_power_scale"][i])) for i in which]
    first: dict = {}
    inv = np.array([first.setdefault(key, len(first)) for key in keys])
    reps = np.zeros(len(first), int)
    reps[inv[::-1]] = np.arange(len(which))[::-1]    # first row of each pair
    run = circuit_packs(inputs, states, power, [which[j] for j in reps])
    for name, values in run["figures"].items():
        figures[name][which] = values[inv]
    bad[which] = run["temperature_bad"][inv]
    return CircuitRun(figures, which, run["usable_as"][inv], run["leg_voltage_v"][inv], bad)


def circuit_packs(inputs: ChainInputs, states: FlightStates, power: ChainPower,
                  which: list[int]) -> dict:
    """The circuit (and thermal) model of the packs ``which`` along the mission.

    The mission's power profile is run at :data:`CIRCUIT_STEP_S` through the coupled
    circuit and thermal model from a full pack at the air temperature
    (:data:`DEFAULT_PACK_TEMPERATURE_C` where none is given), then continued at the
    hold power until the loaded cell voltage reaches ``cell_voltage_empty_v``: the
    charge drawn by then is the charge the pack can really give at this load and
    temperature. Only what happens during the mission grounds the flight (the run
    after it only finds the usable charge). Air outside the model's temperature range
    is run at the range's edge and grounds the flight (the model cannot vouch for it).

    Returns the figures (:data:`CIRCUIT_FIGURES`), ``usable_as`` [A s],
    ``leg_voltage_v`` [V] and ``temperature_bad``, one row per pack of ``which``.
    """
    table, temp = states.table, inputs.temperature_c
    packs = [inputs.packs[i] for i in which]
    t_pack = DEFAULT_PACK_TEMPERATURE_C if temp is None else float(temp)
    t_model = min(max(t_pack, T_RANGE_C[0]), T_RANGE_C[1])
    params = [p.circuit_parameters() for p in packs]
    thermal = [None if p.thermal is None else p.thermal_parameters().with_air(t_model)
               for p in packs]
    t, step_col, leg, window, total = _circuit_times(table)
    log_p = pack_log_power(inputs, power, which)
    load = np.exp(np.concatenate([log_p[:, power.leg], log_p[:, [power.hold]]], axis=1))
    probes = np.clip(np.searchsorted(t, table.end_time_s, side="left") - 1, 0, len(t) - 1)
    cells = np.array([p.cells_series for p in packs], float)
    v_empty = np.array([p.cell_voltage_empty_v for p in packs])
    m, n = len(which), len(table)
    fig = {name: np.full(m, np.nan) for name in CIRCUIT_FIGURES}
    usable = np.empty(m)
    leg_v = np.empty((m, n))
    hot = np.zeros(m, bool)
    # packs differ in the cut-off event only through cell_voltage_empty_v: group them
    for v_cut in np.unique(v_empty):
        rows = np.flatnonzero(v_empty == v_cut)
        r = simulate_packs([params[j] for j in rows], t, load[rows], step_col=step_col,
                           temperature_c=t_model, thermal=[thermal[j] for j in rows],
                           v_cutoff_cell=float(v_cut), window=window, probes=probes,
                           stop_when_all_cut=True)
        fig["min_voltage_v"][rows] = r.window_min_voltage_v
        fig["voltage_margin_v"][rows] = r.window_min_voltage_v - cells[rows] * v_cut
        fig["worst_leg"][rows] = leg[r.window_min_step]
        fig["cutoff_time_s"][rows] = r.cutoff_time_s
        fig["max_temperature_c"][rows] = r.window_max_temperature_c
        fig["charge_used_mah"][rows] = r.window_end_charge_as / AS_PER_MAH
        fig["cutoff_leg"][rows] = leg_at(table, r.cutoff_time_s)
        with np.errstate(invalid="ignore"):
            inside = r.undeliverable_time_s <= total
        fig["collapse_time_s"][rows] = np.where(inside, r.undeliverable_time_s, np.nan)
        fig["collapse_leg"][rows] = leg_at(table, r.undeliverable_time_s)
        fig["collapse_power_w"][rows] = load[rows, leg_at(table, r.undeliverable_time_s)]
        fig["hot_time_s"][rows] = np.where(r.out_of_range_in_window,
                                           r.out_of_range_time_s, np.nan)
        fig["hot_temperature_c"][rows] = np.where(r.out_of_range_in_window,
                                                  r.out_of_range_temperature_c, np.nan)
        hot[rows] = r.out_of_range_in_window
        leg_v[rows] = r.probe_voltage_v
        # no cut-off within the run: the charge drawn by its end
        usable[rows] = np.where(np.isfinite(r.cutoff_charge_as), r.cutoff_charge_as,
                                r.end_charge_as)
    fig["pack_temperature_c"][:] = t_pack
    fig["charge_to_cutoff_mah"] = usable / AS_PER_MAH
    return {"figures": fig, "usable_as": usable, "leg_voltage_v": leg_v,
            "temperature_bad": hot | (t_pack != t_model)}


def _circuit_times(table):
    """Sample times of the circuit run [s] (the mission at :data:`CIRCUIT_STEP_S`, every
    leg start, then the run on at the hold power), each sample's power column (a leg,
    or the hold), its leg, the samples within the mission and the mission's end [s]."""
    total = float(table.end_time_s[-1]) if len(table) else 0.0
    t_m = np.union1d(np.arange(0.0, total, CIRCUIT_STEP_S), table.start_time_s)
    t_x = total + np.arange(0.0, CIRCUIT_EXTEND_S, CIRCUIT_EXTEND_STEP_S)
    t = np.concatenate((t_m, t_x))
    n = len(table)
    leg = np.clip(np.searchsorted(table.end_time_s, t, side="right"), 0, n - 1)
    return t, np.where(t < total, leg, n), leg, int(np.sum(t < total)), total


def leg_at(table, time_s) -> np.ndarray:
    """Index of the leg flown at each time (the last leg after the end; NaN → 0)."""
    with np.errstate(invalid="ignore"):
        return np.clip(np.searchsorted(table.end_time_s, np.nan_to_num(time_s, nan=0.0)),
                       0, len(table) - 1)


@dataclass
class ChargeBudget:
    """Charges each pack is judged against (step 4b, :func:`charge_budget`), [A s].

    ``cap`` nominal (× count); ``usable`` nominal × usable fraction × state of health,
    lowered by the circuit model's cut-off where it gives less; ``limit`` usable less the
    landing reserve; ``scale`` the integral model's extensions' factor. [unitless]
    """

    cap: np.ndarray
    usable: np.ndarray
    limit: np.ndarray
    scale: np.ndarray


def pack_temperature_c(inputs: ChainInputs) -> float:
    """The packs' starting temperature: the air's, :data:`DEFAULT_PACK_TEMPERATURE_C`
    where none is given. [°C]"""
    temp = inputs.temperature_c
    return DEFAULT_PACK_TEMPERATURE_C if temp is None else float(temp)


def cold_factor(inputs: ChainInputs, power: ChainPower) -> np.ndarray:
    r"""Share of its usable charge a pack on the integral model keeps in the cold
    (1 for the packs on the circuit model, which carries its own cold laws). [unitless]

    A pack file without a ``circuit:`` or ``thermal:`` block states its usable charge at
    the reference temperature of its chemistry's cold laws (25 °C,
    :mod:`planner.physics.battery.chemistry`). Below it the pack gives less through both
    laws of the equivalent-circuit model, with the pack taken to stay at the air
    temperature (no self-heating without a ``thermal:`` block):

    * the capacity law :math:`Q(T)/Q_{ref} = 1 - k\,\max(0, T_{ref} - T)`
      (:func:`~planner.physics.battery.chemistry.capacity_factor`), unless the pack's
      integral model carries a fitted temperature coefficient (then that measured law
      applies, through the charge drawn);
    * the resistance law :math:`R_0(T) = R_0 \exp[E_a/R\,(1/T - 1/T_{ref})]`
      (:func:`~planner.physics.battery.chemistry.resistance_factor`): at the hold power
      :math:`P` the pack delivers :math:`I = P/V` at a lower terminal voltage
      (:func:`~planner.physics.battery.elements.loaded_current`, [HESS] eq. 2), so each
      unit of charge carries less energy. The charge that carries the energy of the
      usable charge at the reference is the mean of :math:`I_{ref}/I_T` over the usable
      states of charge (on the chemistry's OCV curve; 0 where the pack cannot deliver
      :math:`P`).

    Neither factor is above 1 below the reference, so the cold never adds charge; above
    it the factor is 1 (no warm bonus either).
    """
    k = len(inputs.packs)
    out = np.ones(k)
    t = pack_temperature_c(inputs)
    if t >= chemistry.REFERENCE_TEMPERATURE_C:
        return out
    which = [i for i, m in enumerate(inputs.models) if m == "integral"]
    if not which:
        return out
    hold_w = np.exp(power.table.log_power(inputs.mass)[:, power.hold])
    for i in which:
        p = inputs.packs[i]
        c = chemistry.chemistry(p.chemistry)
        q = 1.0 if p.model.temperature_coefficient_per_c else float(c.capacity_factor(t))
        r_ref = p.resistance_ohm
        if r_ref > 0:
            soc = np.linspace(1.0 - min(p.usable_fraction, 1.0), 1.0, COLD_SOC_POINTS)
            v_oc = p.cells_series * np.asarray(c.ocv(soc), float)
            i_ref = loaded_current(hold_w[i], v_oc, r_ref)
            i_cold = loaded_current(hold_w[i], v_oc, r_ref * float(c.resistance_factor(t)))
            with np.errstate(invalid="ignore"):
                ratio = np.where(np.isfinite(i_cold) & np.isfinite(i_ref),
                                 i_ref / i_cold, 0.0)
            q *= float(np.mean(ratio))
        out[i] = min(q, 1.0)
    return out


def charge_budget(inputs: ChainInputs, circuit: CircuitRun,
                  power: ChainPower | None = None) -> ChargeBudget:
    """Step 4b: the usable charge and the limit of every pack (:class:`ChargeBudget`);
    with ``power``, the packs on the integral model keep in the cold only
    :func:`cold_factor` of their usable charge."""
    pa = inputs.pack
    usable = pa["usable"].copy()
    if power is not None:
        usable *= cold_factor(inputs, power)
    if circuit.which:
        which = np.asarray(circuit.which)
        cut = circuit.usable_as * inputs.soh[which]
        usable[which] = np.where(cut < usable[which], cut, usable[which])
    return ChargeBudget(cap=pa["cap"], usable=usable, limit=usable - inputs.reserve * pa["cap"],
                        scale=pa["scale"])


def pack_blocks(k: int, power: ChainPower, states: FlightStates,
                block_elements: int = 2_000_000):
    """Slices of about ``block_elements`` (pack × state) elements over ``k`` packs, which
    bound the memory of the steps that run per block."""
    block = max(1, int(block_elements // max(states.points, len(power.table.states), 1)))
    return [slice(b0, min(k, b0 + block)) for b0 in range(0, k, block)]


@dataclass
class LegFigures:
    """The integral model along the legs for a block of packs (step 4c, arrays packs ×
    legs unless said).

    Attributes
    ----------
    log_power : ndarray, packs × states
        :math:`\\ln P` of every state (:attr:`ChainPower.table`).
    rate : ndarray, packs × states
        :math:`dS/dt = 1/(\\delta P^\\varepsilon)` of every state. [(A s)^β/s]
    log_power_leg : ndarray
        :math:`\\ln P` of every leg (:attr:`power_w` is its exponential). [ln W]
    increment, stress_end : ndarray
        Stress of each leg and at its end. [(A s)^β]
    charge_end_as : ndarray
        Charge drawn by the end of each leg (× the extensions' scale). [A s]
    current_a : ndarray
        Loaded current at the leg's mid state of charge; NaN where the pack cannot deliver
        the leg's power. [A]
    used_as, energy_wh, peak_current_a, p_undeliverable_w, p_max_w : ndarray, packs
        Charge used [A s], energy [Wh], peak current [A] (NaN: none), the power of the
        first undeliverable leg (else of the first leg) and the most the pack delivers
        there [W].
    peak_leg, undeliverable_leg : ndarray of int, packs
        Leg of the peak current; first undeliverable leg (−1: none).
    """

    log_power: np.ndarray
    rate: np.ndarray
    log_power_leg: np.ndarray
    increment: np.ndarray
    stress_end: np.ndarray
    charge_end_as: np.ndarray
    current_a: np.ndarray
    used_as: np.ndarray
    energy_wh: np.ndarray
    peak_current_a: np.ndarray
    peak_leg: np.ndarray
    undeliverable_leg: np.ndarray
    p_undeliverable_w: np.ndarray
    p_max_w: np.ndarray

    @property
    def power_w(self) -> np.ndarray:
        """Battery power of every leg. [W]"""
        return np.exp(self.log_power_leg)

    @property
    def stress_start(self) -> np.ndarray:
        """Stress at the start of each leg. [(A s)^β]"""
        return self.stress_end - self.increment


def pack_log_power(inputs: ChainInputs, power: ChainPower, rows) -> np.ndarray:
    """:math:`\\ln P` of the packs ``rows`` at every state of the power table: the table at
    their take-off masses times their ``power_scale`` (packs × states)."""
    return (power.table.log_power(inputs.mass[rows])
            + inputs.pack["log_power_scale"][rows, None])


def leg_figures(inputs: ChainInputs, states: FlightStates, power: ChainPower,
                rows: slice) -> LegFigures:
    """Step 4c: the integral model ([UAV23] eq. 14) and the loaded current along the legs
    of the packs ``rows`` (one compiled pass, :func:`leg_kernel`)."""
    pa = inputs.pack
    lp = pack_log_power(inputs, power, rows)
    rate = integral.stress_rate_from_log_power(lp, pa["delta"][rows, None],
                                               pa["eps"][rows, None])
    lp_leg = np.ascontiguousarray(lp[:, power.leg])
    k, n = lp_leg.shape
    arrays = [np.empty((k, n)) for _ in range(4)]
    inc, s_end, c_end, current = arrays
    (used, energy, peak, peak_leg, first, p_bad, p_max) = leg_kernel(
        lp_leg, rate[:, power.leg].copy(), np.asarray(states.table.duration_s, float),
        pa["beta"][rows], pa["scale"][rows], pa["cap"][rows], pa["r"][rows],
        pa["cells"][rows], inc, s_end, c_end, current)
    return LegFigures(
        log_power=lp, rate=rate, log_power_leg=lp_leg, increment=inc, stress_end=s_end,
        charge_end_as=c_end, current_a=current, used_as=used, energy_wh=energy,
        peak_current_a=peak, peak_leg=peak_leg, undeliverable_leg=first,
        p_undeliverable_w=p_bad, p_max_w=p_max)


@kernel(error_model="numpy")
def leg_kernel(lp_leg, rate_leg, dur, beta, scale, cap, r, cells, inc, s_end, c_end,
               current):
    r"""The per-leg figures of every pack in one compiled pass (packs × legs in).

    Per leg: the stress increment and its running sum, the charge
    :math:`C = s\,S^{1/\beta}` ([UAV23] eq. 14, :func:`~planner.physics.battery.integral.
    charge_from_stress`, × the extensions' scale :math:`s`), and the loaded current at the
    mid-leg state of charge through the pack resistance
    (:func:`~planner.physics.battery.elements.loaded_current` from the open-circuit curve
    :func:`~planner.physics.battery.ocv.lipo_ocv`; NaN where the pack cannot deliver the
    leg's power, :func:`~planner.physics.battery.elements.power_limit`). Fills ``inc``,
    ``s_end``, ``c_end`` [A s] and ``current`` [A] and returns per pack: charge used
    [A s], energy [Wh], peak current [A] (NaN: none), its leg, the first undeliverable
    leg (−1: none), that leg's power [W] (else the first leg's) and the most the pack
    delivers there [W].
    """
    k, n = lp_leg.shape
    used = np.empty(k)
    energy = np.empty(k)
    peak = np.empty(k)
    peak_leg = np.zeros(k, np.int64)
    first = np.full(k, -1, np.int64)
    p_bad = np.empty(k)
    p_max = np.empty(k)
    for i in range(k):
        s = 0.0
        c_prev = 0.0
        e = 0.0
        best = -np.inf
        best_j = 0
        soc_first = 0.0
        for j in range(n):
            d = dur[j] * rate_leg[i, j]
            inc[i, j] = d
            s += d
            s_end[i, j] = s
            c = scale[i] * charge_from_stress_jit(s, beta[i])
            c_end[i, j] = c
            p = np.exp(lp_leg[i, j])
            e += p * dur[j]
            soc = 1.0 - 0.5 * (c_prev + c) / cap[i]
            if j == 0:
                soc_first = soc
            cur = loaded_current_jit(p, cells[i] * lipo_ocv_jit(soc), r[i])
            current[i, j] = cur
            if np.isfinite(cur):
                if cur > best:
                    best = cur
                    best_j = j
            elif np.isfinite(p) and first[i] < 0:
                first[i] = j
                p_bad[i] = p
                p_max[i] = power_limit_jit(cells[i] * lipo_ocv_jit(soc), r[i])
            c_prev = c
        used[i] = c_prev
        energy[i] = e / J_PER_WH
        peak[i] = best if np.isfinite(best) else np.nan
        peak_leg[i] = best_j
        if first[i] < 0:
            p_bad[i] = np.exp(lp_leg[i, 0])
            p_max[i] = power_limit_jit(cells[i] * lipo_ocv_jit(soc_first), r[i])
    return used, energy, peak, peak_leg, first, p_bad, p_max


def leg_end_voltage(inputs: ChainInputs, legs: LegFigures, rows: slice,
                    power_w=None) -> np.ndarray:
    """Loaded voltage at the end of every leg (open-circuit curve at the leg's end state of
    charge, less the drop through the pack resistance); NaN where the pack cannot deliver
    the leg's power (``power_w``, default the legs'). [V]"""
    pa = inputs.pack
    cells, r = pa["cells"][rows, None], pa["r"][rows, None]
    v_oc = cells * lipo_ocv(1.0 - legs.charge_end_as / pa["cap"][rows, None])
    current = loaded_current(legs.power_w if power_w is None else power_w, v_oc, r)
    return np.where(np.isnan(current), np.nan, v_oc - current * r)


# --------------------------------------------------------------------------- 5. return home

@dataclass
class ReturnHome:
    """The return-home reserve of a block of packs (step 5, :func:`return_home`).

    Attributes
    ----------
    total : ndarray, packs × points
        Stress on reaching home (and down) from each point; the last point is the
        mission's own end (the landing reserve); +inf where the return is impossible.
        [(A s)^β]
    point_stress : ndarray, packs × points
        Stress at each point. [(A s)^β]
    min_margin_as : ndarray, packs
        The smallest return-home margin over the mission (−inf: a return is impossible).
        [A s]
    pnr_index : ndarray of int, packs
        The first point whose return breaks the reserve (the point of no return; −1:
        none).
    limit_as, scale, beta : ndarray, packs
        The limit [A s], the extensions' factor and β the margins are taken with.
    """

    total: np.ndarray
    point_stress: np.ndarray
    min_margin_as: np.ndarray
    pnr_index: np.ndarray
    limit_as: np.ndarray
    scale: np.ndarray
    beta: np.ndarray

    def point_margin_as(self) -> np.ndarray:
        """The limit less the charge drawn on reaching home from each point (packs ×
        points); −inf where the return is impossible. [A s]"""
        with np.errstate(invalid="ignore"):
            margin = self.limit_as[:, None] - self._charge(self.total)
        return np.where(np.isfinite(self.total), margin, -np.inf)

    def return_charge_as(self) -> np.ndarray:
        """The return's own charge from each point (home at cruise speed, then down),
        packs × points; +inf where impossible. [A s]"""
        with np.errstate(invalid="ignore"):
            charge = self._charge(self.total) - self._charge(self.point_stress)
        return np.where(np.isfinite(self.total), charge, np.inf)

    def _charge(self, stress):
        return self.scale[:, None] * integral.charge_from_stress(stress, self.beta[:, None])


def return_home(inputs: ChainInputs, states: FlightStates, power: ChainPower,
                budget: ChargeBudget, legs: LegFigures, rows: slice) -> ReturnHome:
    """Step 5: from every return-home point, straight home at cruise speed and down, on
    stresses: :math:`S_{point} + S_{return} \\le (C_{limit}/s)^\\beta`; the mission's
    own end is the landing reserve."""
    rtl = states.rtl
    beta, sc = inputs.pack["beta"][rows], budget.scale[rows]
    total = legs.rate[:, power.back] * rtl["t_back"]
    total += legs.rate[:, power.down] * rtl["t_down"]
    s_start, inc, s_end = legs.stress_start, legs.increment, legs.stress_end
    if states.subset is None:
        f = np.linspace(0.0, 1.0, kinematics.RTL_POINTS_PER_LEG)
        s_point = (s_start[:, :, None] + inc[:, :, None] * f).reshape(total.shape)
    else:
        s_point = s_start[:, rtl["leg"]] + inc[:, rtl["leg"]] * rtl["frac"]
    s_point[:, -1] = s_end[:, -1]
    total += s_point
    total[:, -1] = s_end[:, -1]   # the mission's own end: the landing reserve
    total[np.isnan(total)] = np.inf
    lim = budget.limit[rows]
    s_lim = np.where(lim >= 0, integral.stress_from_charge(np.maximum(lim, 0.0) / sc, beta),
                     -np.inf)
    bad = total[:, :-1] > s_lim[:, None]
    pnr = np.where(bad.any(axis=1), np.argmax(bad, axis=1), -1)
    t_max = total.max(axis=1)
    impossible = np.flatnonzero(~np.isfinite(t_max))
    if impossible.size:  # largest finite total where some return is impossible
        t_max[impossible] = np.where(np.isfinite(total[impossible]), total[impossible],
                                     -np.inf).max(axis=1)
    with np.errstate(invalid="ignore"):
        min_margin = lim - sc * integral.charge_from_stress(t_max, beta)
    return ReturnHome(total=total, point_stress=s_point,
                      min_margin_as=np.where(np.isfinite(t_max), min_margin, -np.inf),
                      pnr_index=pnr, limit_as=lim, scale=sc, beta=beta)


# --------------------------------------------------------------------------- the figures

class PackFigures:
    """The per-pack figures of a run, filled block by block (steps 4c and 5).

    Attributes (one element per pack): ``used_as`` charge used [A s], ``energy_wh`` [Wh],
    ``peak_current_a`` [A], ``peak_leg``, ``undeliverable_leg``,
    ``p_undeliverable_w`` and ``p_max_w`` [W], ``stress_final`` [(A s)^β],
    ``hold_power_w`` [W], ``rtl_min_margin_as`` [A s], ``pnr_index``; ``detail``: the
    per-leg and per-point arrays of :class:`planner.chain.mission_chain.ChainResult`
    (None unless kept, or a subset run's two per-point arrays).
    """

    def __init__(self, inputs: ChainInputs, states: FlightStates):
        k, n, npts = len(inputs.packs), states.legs, states.points
        for name in ("used_as", "energy_wh", "peak_current_a", "p_undeliverable_w",
                     "p_max_w", "stress_final", "hold_power_w", "rtl_min_margin_as"):
            setattr(self, name, np.empty(k))
        self.peak_leg = np.zeros(k, dtype=int)
        self.undeliverable_leg = np.full(k, -1, dtype=int)
        self.pnr_index = np.full(k, -1, dtype=int)
        self.detail = None
        if inputs.keep:
            self.detail = {name: np.empty((k, n)) for name in (
                "power_w", "current_a", "voltage_v", "charge_mah", "charge_end_mah",
                "rtl_margin_mah", "stress_end")}
            self.detail.update({name: np.empty((k, npts)) for name in (
                "rtl_point_margin_mah", "rtl_point_charge_mah", "rtl_back_power_w",
                "rtl_down_power_w")})
        elif states.subset is not None:
            self.detail = {name: np.empty((k, npts)) for name in ("rtl_point_margin_mah",
                                                                  "rtl_point_charge_mah")}

    def store(self, rows: slice, inputs: ChainInputs, states: FlightStates,
              power: ChainPower, legs: LegFigures, home: ReturnHome) -> None:
        """Keep the figures of the packs ``rows``."""
        self.used_as[rows], self.energy_wh[rows] = legs.used_as, legs.energy_wh
        self.peak_current_a[rows], self.peak_leg[rows] = legs.peak_current_a, legs.peak_leg
        self.undeliverable_leg[rows] = legs.undeliverable_leg
        self.p_undeliverable_w[rows], self.p_max_w[rows] = legs.p_undeliverable_w, legs.p_max_w
        self.stress_final[rows] = legs.stress_end[:, -1]
        self.hold_power_w[rows] = np.exp(legs.log_power[:, power.hold])
        self.rtl_min_margin_as[rows], self.pnr_index[rows] = home.min_margin_as, home.pnr_index
        if self.detail is None:
            return
        d = self.detail
        margin = home.point_margin_as()
        d["rtl_point_margin_mah"][rows] = margin / AS_PER_MAH
        d["rtl_point_charge_mah"][rows] = home.return_charge_as() / AS_PER_MAH
        if not inputs.keep:
            return
        c_end = legs.charge_end_as
        c_start = np.concatenate([np.zeros((c_end.shape[0], 1)), c_end[:, :-1]], axis=1)
        leg_power = legs.power_w
        d["power_w"][rows] = leg_power
        d["current_a"][rows] = legs.current_a
        d["voltage_v"][rows] = leg_end_voltage(inputs, legs, rows, leg_power)
        d["charge_mah"][rows] = (c_end - c_start) / AS_PER_MAH
        d["charge_end_mah"][rows] = c_end / AS_PER_MAH
        d["stress_end"][rows] = legs.stress_end
        d["rtl_back_power_w"][rows] = np.exp(legs.log_power[:, power.back])
        d["rtl_down_power_w"][rows] = np.exp(legs.log_power[:, power.down])
        d["rtl_margin_mah"][rows] = margin.reshape(
            -1, states.legs, kinematics.RTL_POINTS_PER_LEG).min(axis=2) / AS_PER_MAH
        self._series(rows, inputs, states, legs, leg_power)

    def circuit_voltages(self, circuit: CircuitRun) -> None:
        """The circuit model's loaded voltage at every leg's end for its packs (detail)."""
        if self.detail is not None and "voltage_v" in self.detail and circuit.which:
            self.detail["voltage_v"][circuit.which] = circuit.leg_voltage_v

    def _series(self, rows, inputs, states, legs, power, points=12):
        """Power [W] and remaining charge [unitless] sampled inside every leg (plots)."""
        table, pa = states.table, inputs.pack
        f = np.linspace(0.0, 1.0, points)
        t = (table.start_time_s[:, None] + f * table.duration_s[:, None]).ravel()
        s_start, s_end = legs.stress_start, legs.stress_end
        s = (s_start[:, :, None] + f * (s_end - s_start)[:, :, None]).reshape(
            s_start.shape[0], -1)
        d = self.detail
        for j, i in enumerate(range(rows.start, rows.stop)):
            d.setdefault("series_time_s", {})[i] = t
            d.setdefault("series_power_w", {})[i] = np.repeat(power[j], points)
            d.setdefault("series_remaining_fraction", {})[i] = (
                1.0 - pa["scale"][i] * integral.charge_from_stress(s[j], pa["beta"][i])
                / pa["cap"][i])
            d.setdefault("series_leg", {})[i] = np.repeat(np.arange(len(table)), points)


# --------------------------------------------------------------------------- 6. constraints

@dataclass
class AircraftLimits:
    """The aircraft's own limits on a pack (:func:`aircraft_limits`), one element per pack.

    Attributes
    ----------
    cells_bad, thrust_bad : ndarray of bool
        The pack's cell count is not one the aircraft allows; the thrust-to-weight ratio is
        below the minimum.
    thrust_to_weight : ndarray
        Maximum static thrust over take-off weight (NaN: not known). [unitless]
    notes : list of str
        Limits that could not be checked, and why.
    """

    cells_bad: np.ndarray
    thrust_bad: np.ndarray
    thrust_to_weight: np.ndarray
    notes: list


def aircraft_limits(aircraft: Aircraft, packs: list[BatteryPack], mass_kg,
                    min_thrust_to_weight: float = DEFAULT_MIN_THRUST_TO_WEIGHT
                    ) -> AircraftLimits:
    """The aircraft's limits on each pack: the cell counts it allows
    (``cells_series_allowed``) and, for a multirotor with a known
    ``multirotor.max_thrust_n``, the least thrust-to-weight ratio
    :math:`T_{max}/(m g)` at the take-off mass ``mass_kg`` [kg] (one per pack).

    ``check``, ``select`` and the sortie planner all judge these through
    :func:`constraints`, so they cannot disagree about a pack.
    """
    k = len(packs)
    mass = np.broadcast_to(np.asarray(mass_kg, float), (k,))
    allowed = aircraft.cells_series_allowed
    cells = np.array([p.cells_series for p in packs])
    cells_bad = ~np.isin(cells, allowed) if allowed else np.zeros(k, bool)
    tw = np.full(k, np.nan)
    thrust_bad = np.zeros(k, bool)
    notes: list[str] = []
    if aircraft.is_multirotor:
        thrust = aircraft.multirotor.max_thrust_n
        if thrust is not None:
            tw = thrust / (mass * G)
            thrust_bad = tw < min_thrust_to_weight
        else:
            notes.append("thrust-to-weight not checked: the aircraft file gives no "
                         "multirotor.max_thrust_n")
    return AircraftLimits(cells_bad=cells_bad, thrust_bad=thrust_bad, thrust_to_weight=tw,
                          notes=notes)


def constraints(inputs: ChainInputs, states: FlightStates, circuit: CircuitRun,
                budget: ChargeBudget, flown: PackFigures) -> np.ndarray:
    """Step 6: which of :data:`CHECK_CONSTRAINTS` each pack breaks (packs × constraints,
    bool), from the figures of the steps before."""
    used_as, peak_current_a = flown.used_as, flown.peak_current_a
    k = len(inputs.packs)
    violated = np.zeros((k, len(CHECK_CONSTRAINTS)), dtype=bool)

    def mark(code, mask):
        violated[:, CHECK_CONSTRAINTS.index(code)] = mask

    table, c = states.table, circuit.figures
    mark("mission", np.full(k, bool(table.problems)))
    limits = aircraft_limits(inputs.aircraft, inputs.packs, inputs.mass,
                             inputs.min_thrust_to_weight)
    mark("cells", limits.cells_bad)
    mark("thrust", limits.thrust_bad)
    mark("power", flown.undeliverable_leg >= 0)
    imax = inputs.pack["imax"]
    with np.errstate(invalid="ignore"):
        mark("c_rating", np.isfinite(imax) & np.isfinite(peak_current_a)
             & (peak_current_a > imax))
        mtow = inputs.aircraft.max_takeoff_mass_kg
        mark("takeoff_mass", np.full(k, False) if mtow is None else inputs.mass > mtow)
        mark("temperature", circuit.temperature_bad)
        cut_in = np.isfinite(c["cutoff_time_s"]) & (c["cutoff_time_s"]
                                                    <= float(np.sum(table.duration_s)))
    mark("voltage", cut_in | np.isfinite(c["collapse_time_s"]))
    runs_out = (used_as > budget.usable) & (budget.usable >= inputs.pack["usable"])
    mark("runs_out", runs_out)
    mark("landing_reserve", ~runs_out & (budget.limit - used_as < 0))
    mark("return_home", flown.pnr_index >= 0)
    return violated


def margin_time(inputs: ChainInputs, budget: ChargeBudget, stress_final, hold_power_w):
    """The margin as extra hold time at the hold power, from the stress at the mission's
    end ([UAV23] eq. 15, :func:`~planner.physics.battery.integral.time_to_charge`);
    −inf where the reserve exceeds the usable charge. [s]"""
    pa = inputs.pack
    with np.errstate(invalid="ignore", divide="ignore"):
        t = integral.time_to_charge(stress_final, hold_power_w,
                                    np.maximum(budget.limit, 0.0) / budget.scale,
                                    pa["delta"], pa["eps"], pa["beta"])
    return np.where(budget.limit <= 0, -np.inf, t)
