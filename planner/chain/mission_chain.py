r"""The mission chain: one orchestrator for every command that flies a mission.

:class:`MissionChain` composes the models as pvlib's ``ModelChain`` does: flight states
of the mission's legs (:func:`planner.chain.kinematics.leg_table`) → one power call for every
state and take-off mass (:class:`planner.chain.powertable.PowerTable`) → one battery model call
(the integral capacity model of [UAV23] eq. 14, and, for packs that use it, the
equivalent circuit and lumped thermal model of [HESS] eq. 1–5, 10–11 through
:func:`planner.physics.battery.circuit.simulate_packs`) → the reserves → the verdict.

It is vectorised over a **pack axis**: ``MissionChain(aircraft, packs)`` flies the mission
with every pack at once, each with its own take-off mass. ``check`` is the one-pack case
(:meth:`MissionChain.check`); ``select``, ``sweep``, ``hybrid`` and the sortie planner rank
or vary what the chain returns and never recompute physics themselves, so ``select`` and
``check`` cannot disagree about a pack.

Two entry points run the same models from measured data:

* :meth:`MissionChain.battery_from_power` — *from measured power*: the battery model alone
  (``replay``, ``fit-battery``, ``diagnose`` at the capacity level);
* :meth:`MissionChain.power_from_state` — *from measured flight state*
  (:class:`planner.chain.flightstate.FlightState`): the power model, then the battery
  (``replay``, ``fit-aircraft``, ``diagnose`` at the power level).

The battery model is chosen by name, as pvlib chooses its models: ``"integral"``,
``"circuit"`` or ``"infer"`` (the circuit for packs whose file has a ``circuit:`` or
``thermal:`` block, else the integral model).

The reserves
------------
* **landing reserve** — the charge left on landing must be at least ``reserve`` × nominal
  capacity (default 20 %);
* **return-to-home reserve** — at :data:`RTL_POINTS_PER_LEG` points of every leg the
  aircraft must be able to fly straight home at its cruise speed, at its altitude, descend
  and land with that same reserve. The first point where it cannot is the *point of no
  return*.

Charge is drawn from the usable charge (nominal × ``usable_fraction``); with the circuit
model the usable charge is also capped by the charge drawn when the loaded cell voltage
reaches ``cell_voltage_empty_v`` (the mission's profile, continued at the hold power).
With the integral model the charge of a profile is not additive but its *stress*
:math:`S = \int dt/(\delta P^\varepsilon)` is, so the return-home charge from a point is
:math:`(S_{point} + S_{return})^{1/\beta}`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numba
import numpy as np
import pandas as pd

from planner.chain import kinematics as prof
from planner.physics.battery import integral
from planner.physics.battery.circuit import loaded_current, simulate_packs
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.battery.thermal import T_RANGE_C
from planner.errors import InputError
from planner.physics.mission import Environment, Mission
from planner.parameters import Aircraft, BatteryPack, IntegralModel, load_aircraft_and_battery
from planner.chain.powertable import PowerTable
from planner.physics.units import AS_PER_MAH

__all__ = ["BATTERY_MODELS", "CHECK_CONSTRAINTS", "BatteryTrace", "ChainResult",
           "MissionChain", "RTL_POINTS_PER_LEG"]

#: Battery models the chain can run: by name, or inferred from the pack file.
BATTERY_MODELS = ("infer", "integral", "circuit")

#: Points per leg at which the return-home reserve is checked.
RTL_POINTS_PER_LEG = prof.RTL_POINTS_PER_LEG

#: The pre-flight check's constraints, in the order their reasons are given.
CHECK_CONSTRAINTS = ("mission", "power", "c_rating", "takeoff_mass", "temperature",
                     "voltage", "runs_out", "landing_reserve", "return_home")

#: The circuit model's time step through the mission, and after it (the run on to the
#: cut-off at the hold power that finds the usable charge), and how long that runs. [s]
CIRCUIT_STEP_S = 1.0
CIRCUIT_EXTEND_STEP_S = 5.0
CIRCUIT_EXTEND_S = 7200.0

#: Air (and starting pack) temperature of the circuit model when none is given. [°C]
DEFAULT_PACK_TEMPERATURE_C = 25.0

#: Legs the aircraft cannot fly that a reason names one by one; the rest are counted.
MAX_LISTED_PROBLEMS = 3

#: Figures of the circuit model per pack (see :class:`ChainResult`).
CIRCUIT_FIGURES = ("min_voltage_v", "voltage_margin_v", "worst_leg", "cutoff_time_s",
                   "charge_to_cutoff_mah", "charge_used_mah", "max_temperature_c",
                   "pack_temperature_c", "cutoff_leg", "collapse_time_s", "collapse_leg",
                   "hot_time_s", "hot_temperature_c", "collapse_power_w")


def _leg_name(table, i: int) -> str:
    """How messages name leg ``i`` (0-based): its origin in the mission file, else its
    number counted from 1 like the check's table."""
    return table.origin[i] or f"leg {i + 1}"


def _ranges(numbers) -> str:
    """``[3, 4, 5, 9]`` → ``"3–5, 9"``."""
    out, start = [], None
    for k, n in enumerate(numbers):
        if start is None:
            start = n
        if k + 1 == len(numbers) or numbers[k + 1] != n + 1:
            out.append(f"{start}" if start == n else f"{start}–{n}")
            start = None
    return ", ".join(out)


def _leg_at(table, time_s) -> np.ndarray:
    """Index of the leg flown at each time (the last leg after the end; NaN → 0)."""
    with np.errstate(invalid="ignore"):
        return np.clip(np.searchsorted(table.end_time_s, np.nan_to_num(time_s, nan=0.0)),
                       0, len(table) - 1)


# --------------------------------------------------------------------------- results

@dataclass
class ChainResult:
    """A mission flown with every pack of the chain (arrays: one element per pack).

    Attributes
    ----------
    packs : list of BatteryPack
    battery_models : list of str
        ``"integral"`` or ``"circuit"``, per pack.
    aircraft : Aircraft
    mission : Mission
    environment : Environment
        The weather flown, with the air temperature actually used (``temperature_c``
        overrides the mission's).
    table : LegTable
        Leg kinematics (the same for every pack).
    reserve_fraction : float
    payload_kg : float or ndarray
        Payload flown, one value or one per pack (a Monte Carlo sample). [kg]
    takeoff_mass_kg, pack_mass_kg : ndarray
        [kg]
    capacity_mah, usable_mah, reserve_mah : ndarray
        Nominal (× count), usable (the cut-off may lower it) and reserve charge. [mAh]
    charge_used_mah, margin_mah, remaining_fraction : ndarray
        Charge drawn by the integral model; usable − reserve − used; charge left on
        landing over nominal. [mAh], [mAh], [unitless]
    margin_time_s, hold_power_w : ndarray
        The margin as extra hover (multirotor) or loiter (fixed-wing) time at the hold
        power; −inf when the reserve exceeds the usable charge. [s], [W]
    energy_wh : ndarray
        ∫P dt over the mission. [Wh]
    rtl_min_margin_mah : ndarray
        Smallest return-home margin along the mission. [mAh]
    pnr_index : ndarray of int
        Return-home point of the point of no return (−1: none).
    peak_current_a, peak_leg : ndarray
        Highest loaded leg current (open-circuit curve and pack resistance) and its leg.
        [A]
    undeliverable_leg : ndarray of int
        First leg whose power the pack cannot deliver through its resistance (−1: none).
    max_current_a : ndarray
        C-rating limit (NaN: no rating). [A]
    circuit : dict of ndarray
        Circuit-model figures of the packs that use it (NaN for the others):
        ``min_voltage_v``, ``voltage_margin_v``, ``worst_leg``, ``cutoff_time_s``,
        ``charge_to_cutoff_mah``, ``charge_used_mah``, ``max_temperature_c``,
        ``pack_temperature_c``, ``cutoff_leg``, ``collapse_time_s``, ``collapse_leg``,
        ``hot_time_s``, ``hot_temperature_c``.
    violated : ndarray of bool, shape (packs, len(CHECK_CONSTRAINTS))
    detail : dict of ndarray or None
        Per-leg arrays (packs × legs) when the run kept them: ``power_w``,
        ``current_a``, ``voltage_v``, ``charge_mah``, ``charge_end_mah``,
        ``rtl_margin_mah``, ``stress_end`` (the integral model's stress at the end of
        each leg, without the extensions' scale), per return-home point (packs × points
        of ``rtl_points``) ``rtl_point_margin_mah``, ``rtl_point_charge_mah`` (the
        return's own charge: home at cruise speed, then the descent) and the return's
        ``rtl_back_power_w`` and ``rtl_down_power_w``, and plot series.
    rtl_points : dict of ndarray
        The return-home points: ``leg``, ``time_s``, ``east_m``, ``north_m``,
        ``altitude_m``, ``distance_m`` (home), and the return's ``t_back`` (straight
        home) and ``t_down`` (descent over home) durations. [s], [m]
    """

    packs: list[BatteryPack]
    battery_models: list[str]
    aircraft: Aircraft
    mission: Mission
    environment: Environment
    table: Any
    reserve_fraction: float
    payload_kg: float | np.ndarray
    takeoff_mass_kg: np.ndarray
    pack_mass_kg: np.ndarray
    capacity_mah: np.ndarray
    usable_mah: np.ndarray
    reserve_mah: np.ndarray
    charge_used_mah: np.ndarray
    margin_mah: np.ndarray
    remaining_fraction: np.ndarray
    margin_time_s: np.ndarray
    hold_power_w: np.ndarray
    energy_wh: np.ndarray
    rtl_min_margin_mah: np.ndarray
    pnr_index: np.ndarray
    peak_current_a: np.ndarray
    peak_leg: np.ndarray
    undeliverable_leg: np.ndarray
    max_current_a: np.ndarray
    circuit: dict[str, np.ndarray]
    violated: np.ndarray
    undeliverable_power_w: np.ndarray
    deliverable_max_w: np.ndarray
    rtl_points: dict[str, np.ndarray] = field(repr=False, default_factory=dict)
    power_method: str = "exact"
    detail: dict[str, np.ndarray] | None = field(repr=False, default=None)

    def __len__(self) -> int:
        return len(self.packs)

    @property
    def duration_s(self) -> float:
        """Mission duration (the same for every pack). [s]"""
        return float(np.sum(self.table.duration_s))

    @property
    def go(self) -> np.ndarray:
        """GO of the pre-flight check, per pack. [bool]"""
        return ~self.violated.any(axis=1)

    def constraints(self, i: int) -> list[str]:
        """Codes of the check constraints pack ``i`` violates, in reporting order."""
        return [c for c, v in zip(CHECK_CONSTRAINTS, self.violated[i]) if v]

    def point_of_no_return(self, i: int) -> dict | None:
        """Where pack ``i`` can no longer return home with the reserve."""
        j = int(self.pnr_index[i])
        if j < 0:
            return None
        r = self.rtl_points
        leg = int(r["leg"][j])
        out = {"time_s": float(r["time_s"][j]), "leg": leg + 1,
               "leg_origin": _leg_name(self.table, leg),
               "east_m": float(r["east_m"][j]), "north_m": float(r["north_m"][j]),
               "altitude_m": float(r["altitude_m"][j]),
               "distance_home_m": float(r["distance_m"][j])}
        if self.detail is not None and "rtl_point_margin_mah" in self.detail:
            m = float(self.detail["rtl_point_margin_mah"][i, j])
            out["rtl_margin_mah"] = m if np.isfinite(m) else None
        return out

    def reasons(self, i: int) -> list[str]:
        """Why pack ``i`` is grounded, one message per violated constraint.

        When the aircraft cannot fly the mission as planned (``mission``), only that is
        said: every later figure assumes legs it cannot fly.
        """
        codes = self.constraints(i)
        if "mission" in codes:
            codes = ["mission"]
        return [text for code in codes for text in self.reason(i, code)]

    def reason(self, i: int, code: str) -> list[str]:
        """The message(s) of check constraint ``code`` for pack ``i``."""
        p, table = self.packs[i], self.table
        c = {k: v[i] for k, v in self.circuit.items()}
        out: list[str] = []
        if code == "mission":
            listed = sorted(table.problems)
            problems = [f"{_leg_name(table, j)}: {why}" for j, why in listed]
            if len(problems) > MAX_LISTED_PROBLEMS:
                rest = sorted({j + 1 for j, _ in listed[MAX_LISTED_PROBLEMS - 1:]})
                problems = problems[:MAX_LISTED_PROBLEMS - 1] + [
                    f"and {len(rest)} more legs the aircraft cannot fly: legs "
                    f"{_ranges(rest)}"]
            out.extend(problems)
        elif code == "power":
            j = int(self.undeliverable_leg[i])
            out.append(f"{_leg_name(table, j)}: the pack cannot deliver "
                       f"{self.undeliverable_power_w[i]:.0f} W (at most "
                       f"{self.deliverable_max_w[i]:.0f} W through "
                       f"{p.resistance_ohm * 1000:.1f} mΩ)")
        elif code == "c_rating":
            j = int(self.peak_leg[i])
            out.append(f"{_leg_name(table, j)}: current {self.peak_current_a[i]:.1f} A "
                       f"exceeds the pack's {p.max_discharge_c:g} C rating "
                       f"({self.max_current_a[i]:.1f} A)")
        elif code == "takeoff_mass":
            out.append(f"take-off mass {self.takeoff_mass_kg[i]:.2f} kg exceeds the "
                       f"aircraft's maximum {self.aircraft.max_takeoff_mass_kg:.2f} kg")
        elif code == "temperature":
            out.append(f"the pack reaches {c['hot_temperature_c']:.0f} °C at t = "
                       f"{c['hot_time_s']:.0f} s, outside the battery model's range "
                       f"[{T_RANGE_C[0]:g} °C, {T_RANGE_C[1]:g} °C]"
                       if np.isfinite(c["hot_time_s"]) else
                       f"the pack starts at {c['pack_temperature_c']:.0f} °C, outside "
                       f"the battery model's range [{T_RANGE_C[0]:g} °C, "
                       f"{T_RANGE_C[1]:g} °C]: no prediction can be trusted")
        elif code == "voltage":
            if np.isfinite(c["cutoff_time_s"]) and c["cutoff_time_s"] <= self.duration_s:
                j = int(c["cutoff_leg"])
                v_cut = p.cells_series * p.cell_voltage_empty_v
                out.append(f"{_leg_name(table, j)}: loaded voltage reaches the cut-off "
                           f"{p.cell_voltage_empty_v:g} V/cell ({v_cut:.1f} V) at "
                           f"t = {c['cutoff_time_s']:.0f} s (pack at "
                           f"{c['pack_temperature_c']:.0f} °C)")
            if np.isfinite(c["collapse_time_s"]):
                j = int(c["collapse_leg"])
                out.append(f"{_leg_name(table, j)}: the pack cannot deliver "
                           f"{c['collapse_power_w']:.0f} W at "
                           f"{c['pack_temperature_c']:.0f} °C (voltage collapses)")
        elif code == "runs_out":
            out.append(f"needs {self.charge_used_mah[i]:.0f} mAh, more than the "
                       f"{self.usable_mah[i]:.0f} mAh the pack can give: it runs out "
                       "before landing")
        elif code == "landing_reserve":
            if self.cutoff_limited(i):
                out.append(f"the loaded cell voltage reaches the "
                           f"{p.cell_voltage_empty_v:g} V cut-off after "
                           f"{self.usable_mah[i]:.0f} mAh with the pack at "
                           f"{c['pack_temperature_c']:.0f} °C (of "
                           f"{p.usable_as / AS_PER_MAH:.0f} mAh usable when warm): the "
                           f"mission ends {-self.margin_mah[i]:.0f} mAh short of the "
                           "reserve")
            else:
                out.append(f"lands with {100 * self.remaining_fraction[i]:.1f} % of "
                           f"nominal charge, below the {100 * self.reserve_fraction:.0f} "
                           f"% reserve (short by {-self.margin_mah[i]:.0f} mAh)")
        elif code == "return_home":
            pnr = self.point_of_no_return(i)
            out.append(f"cannot return home with the reserve from t = "
                       f"{pnr['time_s']:.0f} s ({pnr['leg_origin']}, "
                       f"{pnr['distance_home_m']:.0f} m from home): point of no return "
                       "passed")
        return out

    def cutoff_limited(self, i: int) -> bool:
        """Whether the circuit model's cut-off, not the nominal charge, limits pack ``i``."""
        return self.usable_mah[i] * AS_PER_MAH < self.packs[i].usable_as

    def warnings(self, i: int) -> list[str]:
        """What the pilot should know about pack ``i`` that does not ground the flight."""
        p, out = self.packs[i], list(self.table.notes)
        if self.battery_models[i] == "integral" and self.detail is not None \
                and "voltage_v" in self.detail:
            v_end = self.detail["voltage_v"][i]
            v_min = p.cells_series * p.cell_voltage_empty_v
            low = np.flatnonzero(v_end < v_min)
            if low.size:
                j = int(low[0])
                out.append(f"loaded voltage {v_end[j]:.2f} V falls below {v_min:.2f} V "
                           f"({p.cell_voltage_empty_v:g} V/cell) by the end of "
                           f"{_leg_name(self.table, j)} (t = {self.table.end_time_s[j]:.0f} s): "
                           "expect a low-voltage failsafe")
        if p.model.literature:
            out.append(f"battery model: literature δ₀({p.cells_series}), ε₀({p.cells_series}) "
                       f"scaled to the pack's {p.capacity_mah:.0f} mAh, β = {p.model.beta} "
                       "(the pack file has no fitted model)")
        return out

    def mission_result(self, i: int = 0):
        """The pre-flight check of pack ``i`` (:class:`planner.chain.result.MissionResult`).

        Needs the per-leg detail: a result computed without it is run again for this
        one pack by the same chain.
        """
        from planner.chain.result import MissionResult

        if self.detail is None or "power_w" not in self.detail:
            chain = MissionChain(self.aircraft, [self.packs[i]],
                                 battery_model=self.battery_models[i],
                                 reserve=self.reserve_fraction,
                                 temperature_c=self.environment.temperature_c)
            return chain.run(self.mission, self.environment, payload_kg=self.payload_kg,
                             detail=True).mission_result(0)
        d, table, p = self.detail, self.table, self.packs[i]
        cap = self.capacity_mah[i]
        legs = pd.DataFrame({
            "kind": table.kind, "origin": table.origin, "start_time_s": table.start_time_s,
            "duration_s": table.duration_s, "distance_m": table.distance_m,
            "course_deg": table.course_deg, "airspeed_ms": table.airspeed_ms,
            "groundspeed_ms": table.groundspeed_ms, "climb_rate_ms": table.climb_rate_ms,
            "altitude_m": table.end_alt_m, "power_w": d["power_w"][i],
            "current_a": d["current_a"][i], "voltage_v": d["voltage_v"][i],
            "charge_mah": d["charge_mah"][i],
            "remaining_fraction": 1.0 - d["charge_end_mah"][i] / cap,
            "rtl_margin_mah": d["rtl_margin_mah"][i]})
        circuit = None
        if self.battery_models[i] == "circuit":
            c = {k: v[i] for k, v in self.circuit.items()}
            worst = int(c["worst_leg"])
            circuit = {
                "model": "equivalent circuit" + (" + thermal" if p.thermal else ""),
                "pack_temperature_c": float(c["pack_temperature_c"]),
                "min_voltage_v": float(c["min_voltage_v"]),
                "voltage_margin_v": float(c["voltage_margin_v"]),
                "worst_leg": worst + 1, "worst_leg_origin": _leg_name(table, worst),
                "cutoff_time_s": (float(c["cutoff_time_s"]) if np.isfinite(c["cutoff_time_s"])
                                  else None),
                "charge_to_cutoff_mah": float(c["charge_to_cutoff_mah"]),
                "charge_used_mah": float(c["charge_used_mah"]),
                "max_temperature_c": float(c["max_temperature_c"]),
                "reasons": [r for r in self.reasons(i) if _is_circuit_reason(r)]}
        v = d["voltage_v"][i]
        cur = d["current_a"][i]
        best = self.aircraft_best_speeds(i)
        return MissionResult(
            verdict="GO" if self.go[i] else "NO-GO", reasons=self.reasons(i),
            warnings=self.warnings(i), aircraft=self.aircraft.name,
            battery=p.name + (f" ×{p.count}" if p.count > 1 else ""),
            takeoff_mass_kg=float(self.takeoff_mass_kg[i]), duration_s=self.duration_s,
            energy_wh=float(self.energy_wh[i]), charge_used_mah=float(self.charge_used_mah[i]),
            capacity_mah=float(cap), usable_mah=float(self.usable_mah[i]),
            reserve_mah=float(self.reserve_mah[i]),
            remaining_fraction=float(self.remaining_fraction[i]),
            reserve_fraction=self.reserve_fraction, margin_mah=float(self.margin_mah[i]),
            margin_time_s=float(self.margin_time_s[i]),
            hold_power_w=float(self.hold_power_w[i]), legs=legs,
            point_of_no_return=self.point_of_no_return(i),
            rtl_min_margin_mah=float(self.rtl_min_margin_mah[i]),
            peak_current_a=(float(np.nanmax(cur)) if np.any(np.isfinite(cur))
                            else float("nan")),
            min_voltage_v=float(np.nanmin(v)) if np.any(np.isfinite(v)) else float("nan"),
            battery_model="literature" if p.model.literature else "fitted",
            series={k: d["series_" + k][i] for k in ("time_s", "power_w",
                                                      "remaining_fraction", "leg")},
            aircraft_type=self.aircraft.type, circuit=circuit, best_speeds=best,
            environment=self.environment, binding=self.binding(i),
            cutoff_limited=self.cutoff_limited(i),
            unflyable_legs=[j + 1 for j, _ in self.table.problems])

    def binding(self, i: int) -> str | None:
        """The first violated check constraint of pack ``i`` (None: GO)."""
        codes = self.constraints(i)
        return codes[0] if codes else None

    def aircraft_best_speeds(self, i: int) -> dict:
        """Airspeeds of maximum endurance (least power) and maximum range (least energy
        per distance) in level flight, still air, at pack ``i``'s take-off mass. [m/s]"""
        from planner.physics.power.speeds import best_speeds

        ac = self.aircraft
        mass = float(self.takeoff_mass_kg[i])
        rho0 = float(self.table.air_density[-1]) if len(self.table) else 1.225

        def power(v):
            return ac.battery_power(v, 0.0, rho0, mass)

        b = best_speeds(power, ac.min_airspeed_ms, ac.max_airspeed_ms)
        return {"max_endurance_airspeed_ms": float(b.max_endurance),
                "max_endurance_power_w": float(power(b.max_endurance)),
                "max_range_airspeed_ms": float(b.max_range),
                "max_range_power_w": float(power(b.max_range))}


def _is_circuit_reason(text: str) -> bool:
    return ("cut-off" in text or "voltage collapses" in text
            or "battery model's range" in text)


@dataclass
class BatteryTrace:
    """The battery model driven by a measured (or given) power profile.

    Attributes
    ----------
    time_s, power_w : ndarray
        [s], [W]
    charge_as : ndarray
        Charge drawn since the first sample: the integral model ([UAV23] eq. 14) with the
        pack's diagnose extensions applied sample by sample. [A s]
    base_charge_as : ndarray
        The integral model's charge without the extensions. [A s]
    stress : ndarray
        :math:`S(t) = \\int dt/(\\delta P^\\varepsilon)` of the base charge. [(A s)^β]
    scale : ndarray
        The extensions' factor at each sample (1: none). [unitless]
    model : IntegralModel
    """

    time_s: np.ndarray
    power_w: np.ndarray
    charge_as: np.ndarray
    base_charge_as: np.ndarray
    stress: np.ndarray
    scale: np.ndarray
    model: IntegralModel


# --------------------------------------------------------------------------- the chain

class MissionChain:
    """Aircraft, packs and models composed into one chain (module notes).

    Parameters
    ----------
    aircraft : Aircraft
    packs : BatteryPack or sequence of BatteryPack or None
        One pack (the pre-flight check) or many (a catalog; the pack axis); None for a
        chain that only runs the power model from measured flight states.
    battery_model : {"infer", "integral", "circuit"}
        ``"infer"``: the circuit model for packs whose file has a ``circuit:`` or
        ``thermal:`` block, else the integral model.
    reserve : float, default 0.2
        Landing reserve as a fraction of nominal capacity. [unitless]
    temperature_c : float, optional
        Outside air (and starting pack) temperature; None = the mission's, else ISA.
        [°C]

    Examples
    --------
    >>> chain = MissionChain.from_yaml("aircraft/solo_survey.yaml")     # doctest: +SKIP
    >>> result = chain.check(load_mission("missions/survey_quad.yaml"))  # doctest: +SKIP
    >>> result.verdict, result.margin_mah                               # doctest: +SKIP
    """

    def __init__(self, aircraft: Aircraft, packs: BatteryPack | Sequence[BatteryPack], *,
                 battery_model: str = "infer", reserve: float = 0.2,
                 temperature_c: float | None = None):
        if battery_model not in BATTERY_MODELS:
            raise InputError(f"battery_model must be one of {', '.join(BATTERY_MODELS)}, "
                             f"got {battery_model!r}")
        if not 0.0 <= reserve < 1.0:
            raise InputError(f"reserve must be in [0, 1), got {reserve}")
        self.aircraft = aircraft
        self.packs = ([] if packs is None else [packs] if isinstance(packs, BatteryPack)
                      else list(packs))
        self.battery_model = battery_model
        self.reserve = float(reserve)
        self.temperature_c = temperature_c
        self.models = [self._model_of(p) for p in self.packs]

    @classmethod
    def from_yaml(cls, aircraft_path, battery_path=None, **kwargs) -> MissionChain:
        """The chain of an aircraft file and its pack (``battery_path`` or its default)."""
        aircraft, pack = load_aircraft_and_battery(aircraft_path, battery_path)
        return cls(aircraft, pack, **kwargs)

    def _model_of(self, pack: BatteryPack) -> str:
        if self.battery_model == "integral":
            return "integral"
        if self.battery_model == "circuit":
            if pack.internal_resistance_ohm is None and not (
                    pack.circuit and "r0_ohm" in pack.circuit):
                raise InputError(f"{pack.path or pack.name}: the circuit model needs the "
                                 "pack's internal_resistance_ohm (or circuit.r0_ohm)")
            return "circuit"
        return "circuit" if (pack.circuit is not None or pack.thermal is not None) \
            else "integral"

    @property
    def pack(self) -> BatteryPack:
        """The pack of a one-pack chain."""
        return self.packs[0]

    # ------------------------------------------------------------------ missions
    def check(self, mission: Mission, environment: Environment | None = None, *,
              payload_kg: float | None = None):
        """The pre-flight check of a one-pack chain (:class:`planner.chain.result.MissionResult`)."""
        if len(self.packs) != 1:
            raise InputError("check flies one pack; use run() for a catalog")
        return self.run(mission, environment, payload_kg=payload_kg,
                        detail=True).mission_result(0)

    def run(self, mission: Mission, environment: Environment | None = None, *,
            payload_kg=None, detail: bool | None = None,
            power_method: str = "auto", block_elements: int = 2_000_000,
            rtl_subset=None, pack_samples: dict | None = None) -> ChainResult:
        """Fly ``mission`` with every pack.

        Parameters
        ----------
        mission : Mission
        environment : Environment, optional
            Overrides the mission's weather (``--wind``).
        payload_kg : float or array_like, optional
            Overrides the mission's payload: one value, or one per pack (the pack axis as
            a sample axis). [kg]
        detail : bool, optional
            Keep the per-leg arrays (packs × legs) for tables and plots; default when
            there are at most 16 packs.
        power_method : {"auto", "exact", "table"}
            How the power is evaluated over many masses, see :class:`PowerTable`.
        block_elements : int
            Packs are processed in blocks of about this many (pack × point) elements,
            which bounds the memory.
        rtl_subset : array_like of int, optional
            Check the return-home reserve only at these of the
            :func:`~planner.chain.kinematics.return_home_points` (indices, increasing, the last
            point — the mission's end — included): a Monte Carlo run checks the points
            where the nominal run is tightest instead of every point. The result's
            ``rtl_points`` are then the subset's, ``pnr_index`` indexes it, and
            ``rtl_point_margin_mah`` and ``rtl_point_charge_mah`` (packs × subset) are kept
            without ``detail``.
        pack_samples : dict of array_like, optional
            Per-pack values that replace the packs' own, one per pack (the pack axis as a
            Monte Carlo sample axis): ``delta``, ``epsilon``, ``beta`` of the integral
            model and ``soh``, the state of health, which scales the charge the pack can
            give (nominal × usable fraction, and the circuit model's charge to the
            cut-off).

        Returns
        -------
        ChainResult
        """
        env = environment or mission.environment
        temp = self.temperature_c if self.temperature_c is not None else env.temperature_c
        flown_env = replace(env, temperature_c=temp)
        payload = (mission.payload_kg if payload_kg is None else float(payload_kg)
                   if np.ndim(payload_kg) == 0 else np.asarray(payload_kg, float))
        if not self.packs:
            raise InputError("the chain needs at least one pack to fly a mission")
        if not mission.legs:
            raise InputError(f"{mission.source or mission.name}: the mission has no legs")
        packs, ac = self.packs, self.aircraft
        bad = [f"{p.path or p.name}: integral model delta = {p.model.delta:.4g}"
               + (f" (literature δ₀({p.cells_series}) is only valid for few-cell packs; give "
                  "a fitted 'model:')" if p.model.literature else "")
               for p in packs if not (p.model.delta > 0 and p.model.beta > 0)]
        if bad:
            raise InputError("; ".join(bad) + " — delta must be > 0")
        k = len(packs)
        keep = (k <= 16) if detail is None else bool(detail)
        table = prof.leg_table(mission, ac, env, temperature_c=temp)
        n = len(table)
        pa = _pack_arrays(packs, temp)
        soh = np.ones(k)
        for key, values in (pack_samples or {}).items():
            v = np.broadcast_to(np.asarray(values, float), (k,)).copy()
            if key == "soh":
                soh = v
                pa["usable"] = pa["usable"] * v
            elif key in ("delta", "epsilon", "beta"):
                pa["eps" if key == "epsilon" else key] = v
            else:
                raise ValueError(f"pack_samples: unknown key {key!r}")
        bad_sample = ~((pa["delta"] > 0) & (pa["beta"] > 0))
        if pack_samples and bad_sample.any():
            raise InputError(f"pack sample {int(np.argmax(bad_sample))}: delta and beta must "
                             "be > 0")
        mass = ac.empty_mass_kg + pa["mass"] + payload
        cap, usable, scale = pa["cap"], pa["usable"].copy(), pa["scale"]
        limit = usable - self.reserve * cap

        # flight states: legs, return-home (back, down), hold; one power table for all
        rtl = prof.return_home_points(table, ac, env, temp)
        npts_all = len(rtl["leg"])
        sub = None
        if rtl_subset is not None:
            sub = np.asarray(rtl_subset, int)
            if (sub.ndim != 1 or not sub.size or sub[-1] != npts_all - 1
                    or np.any(np.diff(sub) <= 0) or sub[0] < 0):
                raise ValueError("rtl_subset must be increasing point indices ending with the "
                                 f"mission's end ({npts_all - 1})")
            if keep:
                raise ValueError("rtl_subset runs keep no per-leg detail (detail=False)")

            def cut(v):
                return v[sub] if np.ndim(v) and np.shape(v)[0] == npts_all else v

            rtl = {key: (tuple(cut(x) for x in v) if isinstance(v, tuple) else cut(v))
                   for key, v in rtl.items()}
        npts = len(rtl["leg"])
        rho0 = float(table.air_density[-1])
        hold = prof.hold_state(ac, rho0, env.wind_speed_ms)
        groups = [(table.airspeed_ms, table.climb_rate_ms, table.air_density,
                   table.load_factor), rtl["back"], rtl["down"], hold]
        sizes = [n, npts, npts, 1]
        cols = [np.concatenate([np.broadcast_to(np.asarray(g[c], float), (s,))
                                for g, s in zip(groups, sizes)]) for c in range(4)]
        ptable = PowerTable(ac, *cols, masses=mass, method=power_method)
        inv = ptable.inverse
        i_leg, i_back = inv[:n], inv[n:n + npts]
        i_down, i_hold = inv[n + npts:n + 2 * npts], inv[-1]
        dur = table.duration_s
        t_back, t_down = rtl["t_back"], rtl["t_down"]
        f_points = np.linspace(0.0, 1.0, RTL_POINTS_PER_LEG)

        # the equivalent-circuit (and thermal) model of the packs that use it: its cut-off
        # may lower the usable charge, which the reserves below are judged against
        circuit = {name: np.full(k, np.nan) for name in CIRCUIT_FIGURES}
        temp_bad = np.zeros(k, bool)
        which = [i for i, m in enumerate(self.models) if m == "circuit"]
        run = None
        if which:
            run = self._circuit(table, which, ptable, i_leg, i_hold, mass, temp)
            for name, values in run["figures"].items():
                circuit[name][which] = values
            cut_usable = run["usable_as"] * soh[which]
            lower = cut_usable < usable[which]
            idx = np.asarray(which)[lower]
            usable[idx] = cut_usable[lower]
            limit[idx] = usable[idx] - self.reserve * cap[idx]
            temp_bad[which] = run["temperature_bad"]

        out = {name: np.empty(k) for name in ("used", "energy", "peak", "rtl_min", "s_final",
                                              "p_hold", "p_undeliverable", "p_max")}
        pnr_index = np.full(k, -1, dtype=int)
        peak_leg = np.zeros(k, dtype=int)
        undeliverable = np.full(k, -1, dtype=int)
        det = {name: np.empty((k, n)) for name in (
            "power_w", "current_a", "voltage_v", "charge_mah", "charge_end_mah",
            "rtl_margin_mah", "stress_end")} if keep else None
        if keep:
            for name in ("rtl_point_margin_mah", "rtl_point_charge_mah", "rtl_back_power_w",
                         "rtl_down_power_w"):
                det[name] = np.empty((k, npts))
        if sub is not None:
            det = {name: np.empty((k, npts)) for name in ("rtl_point_margin_mah",
                                                          "rtl_point_charge_mah")}
        block = max(1, int(block_elements // max(npts, len(ptable.states), 1)))
        for b0 in range(0, k, block):
            sl = slice(b0, min(k, b0 + block))
            delta, eps, beta = (pa[x][sl, None] for x in ("delta", "eps", "beta"))
            sc, cp, rr, cells = (pa[x][sl, None] for x in ("scale", "cap", "r", "cells"))
            lp_u = ptable.log_power(mass[sl])
            r_u = integral.stress_rate_from_log_power(lp_u, delta, eps)
            out["p_hold"][sl] = np.exp(lp_u[:, i_hold])
            if not keep:
                # one compiled pass over the legs of every pack (same figures as below)
                s_end, inc = np.empty((sl.stop - sl.start, n)), np.empty((sl.stop - sl.start, n))
                (out["used"][sl], out["energy"][sl], out["peak"][sl], peak_leg[sl],
                 undeliverable[sl], out["p_undeliverable"][sl], out["p_max"][sl]) = \
                    _legs_kernel(np.ascontiguousarray(lp_u[:, i_leg]), r_u[:, i_leg].copy(),
                                 np.asarray(dur, float), pa["beta"][sl], pa["scale"][sl],
                                 pa["cap"][sl], pa["r"][sl], pa["cells"][sl], s_end, inc)
                out["s_final"][sl] = s_end[:, -1]
                s_start = s_end - inc
            else:
                power = np.exp(lp_u[:, i_leg])
                inc = dur * r_u[:, i_leg]
                s_end = np.cumsum(inc, axis=1)
                s_start = s_end - inc
                c_end = sc * integral.charge_from_stress(s_end, beta)
                c_start = np.concatenate([np.zeros((c_end.shape[0], 1)), c_end[:, :-1]],
                                         axis=1)
                out["used"][sl] = c_end[:, -1]
                out["s_final"][sl] = s_end[:, -1]
                out["energy"][sl] = power @ dur / 3600.0

                # loaded current and voltage (open-circuit curve + pack resistance)
                soc_mid = 1.0 - 0.5 * (c_start + c_end) / cp
                current = loaded_current(power, cells * lipo_ocv(soc_mid), rr)
                finite = np.isfinite(current)
                cur = np.where(finite, current, -np.inf)
                peak_leg[sl] = np.argmax(cur, axis=1)
                peak = cur.max(axis=1)
                out["peak"][sl] = np.where(np.isfinite(peak), peak, np.nan)
                bad_i = ~finite & np.isfinite(power)
                first = np.where(bad_i.any(axis=1), np.argmax(bad_i, axis=1), -1)
                undeliverable[sl] = first
                rows_b = np.arange(power.shape[0])
                j = np.maximum(first, 0)
                out["p_undeliverable"][sl] = power[rows_b, j]
                v_oc = cells[:, 0] * lipo_ocv(soc_mid[rows_b, j])
                with np.errstate(divide="ignore"):
                    out["p_max"][sl] = v_oc**2 / (4.0 * rr[:, 0])

            # return-home reserve, on stresses: S_point + S_return <= (limit/scale)^beta
            total = r_u[:, i_back] * t_back
            total += r_u[:, i_down] * t_down
            if sub is None:
                s_point = (s_start[:, :, None] + inc[:, :, None] * f_points).reshape(
                    total.shape)
            else:
                s_point = s_start[:, rtl["leg"]] + inc[:, rtl["leg"]] * rtl["frac"]
            s_point[:, -1] = s_end[:, -1]
            total += s_point
            total[:, -1] = s_end[:, -1]   # the mission's own end: the landing reserve
            total[np.isnan(total)] = np.inf
            lim = limit[sl]
            s_lim = np.where(lim >= 0, integral.stress_from_charge(
                np.maximum(lim, 0.0) / pa["scale"][sl], pa["beta"][sl]), -np.inf)
            bad = total[:, :-1] > s_lim[:, None]
            pnr_index[sl] = np.where(bad.any(axis=1), np.argmax(bad, axis=1), -1)
            t_max = total.max(axis=1)
            rows = np.flatnonzero(~np.isfinite(t_max))
            if rows.size:  # largest finite total where some return is impossible
                t_max[rows] = np.where(np.isfinite(total[rows]), total[rows],
                                       -np.inf).max(axis=1)
            with np.errstate(invalid="ignore"):
                rtl_min = lim - pa["scale"][sl] * integral.charge_from_stress(
                    t_max, pa["beta"][sl])
            out["rtl_min"][sl] = np.where(np.isfinite(t_max), rtl_min, -np.inf)
            if sub is not None:
                with np.errstate(invalid="ignore"):
                    c_total = sc * integral.charge_from_stress(total, beta)
                    det["rtl_point_margin_mah"][sl] = np.where(
                        np.isfinite(total), lim[:, None] - c_total, -np.inf) / AS_PER_MAH
                    det["rtl_point_charge_mah"][sl] = np.where(
                        np.isfinite(total), c_total - sc * integral.charge_from_stress(
                            s_point, beta), np.inf) / AS_PER_MAH
            if keep:
                soc_end = 1.0 - c_end / cp
                cur_end = loaded_current(power, cells * lipo_ocv(soc_end), rr)
                v_end = cells * lipo_ocv(soc_end) - cur_end * rr
                det["power_w"][sl] = power
                det["current_a"][sl] = current
                det["voltage_v"][sl] = np.where(np.isnan(cur_end), np.nan, v_end)
                det["charge_mah"][sl] = (c_end - c_start) / AS_PER_MAH
                det["charge_end_mah"][sl] = c_end / AS_PER_MAH
                det["stress_end"][sl] = s_end
                with np.errstate(invalid="ignore"):
                    point = lim[:, None] - sc * integral.charge_from_stress(total, beta)
                point = np.where(np.isfinite(total), point, -np.inf)
                det["rtl_point_margin_mah"][sl] = point / AS_PER_MAH
                # the return's own charge: from the stress at the point to its end
                with np.errstate(invalid="ignore"):
                    back_charge = sc * (integral.charge_from_stress(total, beta)
                                        - integral.charge_from_stress(s_point, beta))
                det["rtl_point_charge_mah"][sl] = np.where(
                    np.isfinite(total), back_charge, np.inf) / AS_PER_MAH
                det["rtl_back_power_w"][sl] = np.exp(lp_u[:, i_back])
                det["rtl_down_power_w"][sl] = np.exp(lp_u[:, i_down])
                det["rtl_margin_mah"][sl] = point.reshape(-1, n, RTL_POINTS_PER_LEG).min(
                    axis=2) / AS_PER_MAH
                _series_into(det, sl, table, power, s_start, s_end, sc, beta, cp)

        used = out["used"]
        margin = limit - used
        if keep and run is not None:
            det["voltage_v"][which] = run["leg_voltage_v"]
        with np.errstate(invalid="ignore", divide="ignore"):
            margin_time = integral.time_to_charge(out["s_final"], out["p_hold"],
                                                  np.maximum(limit, 0.0) / scale,
                                                  pa["delta"], pa["eps"], pa["beta"])
        margin_time = np.where(limit <= 0, -np.inf, margin_time)

        violated = np.zeros((k, len(CHECK_CONSTRAINTS)), dtype=bool)

        def mark(code, mask):
            violated[:, CHECK_CONSTRAINTS.index(code)] = mask

        mark("mission", np.full(k, bool(table.problems)))
        mark("power", undeliverable >= 0)
        imax = pa["imax"]
        with np.errstate(invalid="ignore"):
            mark("c_rating", np.isfinite(imax) & np.isfinite(out["peak"])
                 & (out["peak"] > imax))
        mtow = ac.max_takeoff_mass_kg
        mark("takeoff_mass", np.full(k, False) if mtow is None else mass > mtow)
        mark("temperature", temp_bad)
        total_s = float(np.sum(dur))
        with np.errstate(invalid="ignore"):
            cut_in = np.isfinite(circuit["cutoff_time_s"]) & (circuit["cutoff_time_s"]
                                                              <= total_s)
        collapse = np.isfinite(circuit["collapse_time_s"])
        mark("voltage", cut_in | collapse)
        usable_now = usable
        runs_out = (used > usable_now) & (usable_now >= pa["usable"])
        mark("runs_out", runs_out)
        mark("landing_reserve", ~runs_out & (margin < 0))
        mark("return_home", pnr_index >= 0)

        return ChainResult(
            packs=list(packs), battery_models=list(self.models), aircraft=ac,
            mission=mission, environment=flown_env, table=table,
            reserve_fraction=self.reserve, payload_kg=payload, takeoff_mass_kg=mass,
            pack_mass_kg=pa["mass"], capacity_mah=cap / AS_PER_MAH,
            usable_mah=usable / AS_PER_MAH, reserve_mah=self.reserve * cap / AS_PER_MAH,
            charge_used_mah=used / AS_PER_MAH, margin_mah=margin / AS_PER_MAH,
            remaining_fraction=1.0 - used / cap, margin_time_s=margin_time,
            hold_power_w=out["p_hold"], energy_wh=out["energy"],
            rtl_min_margin_mah=out["rtl_min"] / AS_PER_MAH, pnr_index=pnr_index,
            peak_current_a=out["peak"], peak_leg=peak_leg, undeliverable_leg=undeliverable,
            max_current_a=imax, circuit=circuit, violated=violated,
            undeliverable_power_w=out["p_undeliverable"], deliverable_max_w=out["p_max"],
            rtl_points={key: rtl[key] for key in ("leg", "time_s", "east_m", "north_m",
                                                  "altitude_m", "distance_m", "t_back",
                                                  "t_down")},
            power_method=ptable.method, detail=det)

    def _circuit(self, table, which, ptable, i_leg, i_hold, mass, temp) -> dict:
        """:meth:`_circuit_unique` of the distinct (pack, take-off mass) pairs of ``which``,
        spread back over ``which``: the samples of a Monte Carlo run share one pack file
        and differ in the circuit model only by their mass."""
        keys = [(id(self.packs[i]), float(mass[i])) for i in which]
        first: dict = {}
        inv = np.array([first.setdefault(key, len(first)) for key in keys])
        if len(first) == len(which):
            return self._circuit_unique(table, which, ptable, i_leg, i_hold, mass, temp)
        reps = np.zeros(len(first), int)
        reps[inv[::-1]] = np.arange(len(which))[::-1]    # first row of each pair
        run = self._circuit_unique(table, [which[j] for j in reps], ptable, i_leg, i_hold,
                                   mass, temp)
        return {"figures": {k: v[inv] for k, v in run["figures"].items()},
                "usable_as": run["usable_as"][inv], "leg_voltage_v": run["leg_voltage_v"][inv],
                "temperature_bad": run["temperature_bad"][inv]}

    def _circuit_unique(self, table, which, ptable, i_leg, i_hold, mass, temp) -> dict:
        """The circuit (and thermal) model of the packs ``which`` along the mission.

        The mission's power profile is run at :data:`CIRCUIT_STEP_S` through the coupled
        circuit and thermal model from a full pack at the air temperature
        (:data:`DEFAULT_PACK_TEMPERATURE_C` where none is given), then continued at the
        hold power until the loaded cell voltage reaches ``cell_voltage_empty_v``: the
        charge drawn by then is the charge the pack can really give at this load and
        temperature. Only what happens during the mission grounds the flight (the run
        after it only finds the usable charge). Air outside the model's temperature range
        is run at the range's edge and grounds the flight (the model cannot vouch for it).
        """
        packs = [self.packs[i] for i in which]
        t_pack = DEFAULT_PACK_TEMPERATURE_C if temp is None else float(temp)
        t_model = min(max(t_pack, T_RANGE_C[0]), T_RANGE_C[1])
        params = [p.circuit_parameters() for p in packs]
        thermal = [None if p.thermal is None else p.thermal_parameters().with_air(t_model)
                   for p in packs]
        total = float(table.end_time_s[-1]) if len(table) else 0.0
        t_m = np.union1d(np.arange(0.0, total, CIRCUIT_STEP_S), table.start_time_s)
        t_x = total + np.arange(0.0, CIRCUIT_EXTEND_S, CIRCUIT_EXTEND_STEP_S)
        t = np.concatenate((t_m, t_x))
        n = len(table)
        leg = np.clip(np.searchsorted(table.end_time_s, t, side="right"), 0, n - 1)
        step_col = np.where(t < total, leg, n)
        log_p = ptable.log_power(mass[which])
        load = np.exp(np.concatenate([log_p[:, i_leg], log_p[:, [i_hold]]], axis=1))
        probes = np.clip(np.searchsorted(t, table.end_time_s, side="left") - 1, 0, len(t) - 1)
        window = int(np.sum(t < total))
        cells = np.array([p.cells_series for p in packs], float)
        v_empty = np.array([p.cell_voltage_empty_v for p in packs])
        m = len(which)
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
            fig["cutoff_leg"][rows] = _leg_at(table, r.cutoff_time_s)
            with np.errstate(invalid="ignore"):
                inside = r.undeliverable_time_s <= total
            fig["collapse_time_s"][rows] = np.where(inside, r.undeliverable_time_s, np.nan)
            fig["collapse_leg"][rows] = _leg_at(table, r.undeliverable_time_s)
            fig["collapse_power_w"][rows] = load[rows, _leg_at(table, r.undeliverable_time_s)]
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

    # ------------------------------------------------------------------ measured data
    def battery_from_power(self, time_s, power_w, *, temperature_c=None,
                           pack_index: int = 0) -> BatteryTrace:
        """*From measured power*: the pack's battery model along a power profile.

        Parameters
        ----------
        time_s : array_like
            Sample times, increasing. [s]
        power_w : array_like
            Electric power drawn; NaN samples count as rests. [W]
        temperature_c : array_like, optional
            Pack temperature per sample (gaps filled from neighbours), for a pack whose
            model carries a temperature extension. [°C]
        pack_index : int
            Which of the chain's packs.

        Returns
        -------
        BatteryTrace
        """
        model = self.packs[pack_index].model
        t = np.asarray(time_s, float)
        p = np.nan_to_num(np.asarray(power_w, float))
        temp = (filled_temperature(temperature_c)
                if temperature_c is not None and model.temperature_coefficient_per_c
                else None)
        base = integral.charge(t, p, model.delta, model.epsilon, model.beta)
        charge = model.extend_charge(base, temp)
        scale = model.charge_scale(temp) * np.ones_like(t)
        return BatteryTrace(time_s=t, power_w=p, charge_as=charge, base_charge_as=base,
                            stress=integral.stress_from_charge(base, model.beta),
                            scale=scale, model=model)

    def power_from_state(self, state, mass_kg) -> np.ndarray:
        """*From measured flight state*: the aircraft's electric power along a flight.

        Parameters
        ----------
        state : FlightState
            Airspeed, climb rate, air density and phase per sample
            (:func:`planner.chain.flightstate.from_record`).
        mass_kg : numeric
            All-up mass, a number or one value per sample. [kg]

        Returns
        -------
        power : ndarray
            Battery power. On the ground (phase ``ground``) the rotors or propeller are
            idle: only the system load ``system_power_w`` is drawn. [W]

        Notes
        -----
        A multirotor with ``power_model: rotor_losses`` reads the flight state
        ``power_lead_s`` after each power sample (the log's power channel leads its
        state channels; linear interpolation, held at the ends) and, where the state has
        a specific force, flies the measured thrust ``mass × specific_force_ms2``
        instead of the trim thrust.
        """
        ac = self.aircraft
        on_ground = state.phase == "ground"
        # a multirotor flies its rotor disks' in-plane and axial speed (FlightState notes)
        v, climb = (state.rotor_velocities() if ac.is_multirotor
                    else (state.airspeed_ms, state.climb_rate_ms))
        if not (ac.is_multirotor and ac.multirotor.power_model == "rotor_losses"):
            return self.power_at(v, climb, state.air_density, mass_kg, on_ground=on_ground)
        lead = float(ac.multirotor.power_lead_s or 0.0)
        t = np.asarray(state.time_s, float)

        def later(x):
            x = np.asarray(x, float)
            return x if lead == 0.0 or t.size < 2 else np.interp(t + lead, t, x)

        mass = np.asarray(mass_kg, float)
        force = state.specific_force_ms2
        thrust = None if force is None else mass * later(force)
        return self.power_at(later(v), later(climb), later(state.air_density), mass,
                             on_ground=on_ground, thrust=thrust)

    def power_at(self, airspeed_ms, climb_rate_ms, air_density, mass_kg, *,
                 on_ground=False, thrust=None) -> np.ndarray:
        """The aircraft's battery power at measured flight states (all broadcast).

        A fixed-wing aircraft's airspeed is held at its minimum airspeed
        (:attr:`planner.parameters.Aircraft.min_airspeed_ms`): below it the polar's
        induced term has no meaning. On the ground only ``system_power_w`` is drawn.
        ``thrust`` (measured, N) is read by the ``rotor_losses`` model only. [W]
        """
        ac = self.aircraft
        v = (np.asarray(airspeed_ms, float) if ac.is_multirotor
             else np.maximum(airspeed_ms, ac.min_airspeed_ms))
        extra = {} if thrust is None else {"thrust": thrust}
        power = np.asarray(ac.battery_power(v, climb_rate_ms, air_density, mass_kg, **extra),
                           float)
        return np.where(on_ground, ac.system_power_w, power)


# --------------------------------------------------------------------------- helpers

def filled_temperature(temperature_c) -> np.ndarray | None:
    """Temperatures with missing samples filled from the nearest valid ones; ``None``
    when there are none. [°C]"""
    if temperature_c is None:
        return None
    temp = np.asarray(temperature_c, dtype=float).ravel()
    ok = np.isfinite(temp)
    if not ok.any():
        return None
    if not ok.all():
        idx = np.arange(temp.size)
        temp = np.interp(idx, idx[ok], temp[ok])
    return temp


@numba.njit(cache=True, error_model="numpy")
def _ocv_cell(soc):
    """:func:`planner.physics.battery.ocv.lipo_ocv` for one value (compiled). [V]"""
    s = min(max(soc, 0.0), 1.0)
    return -1.031 * np.exp(-35.0 * s) + 3.685 + s * (0.2156 + s * (-0.1178 + 0.3201 * s))


@numba.njit(cache=True, error_model="numpy")
def _current(p, v, r):
    """:func:`planner.physics.battery.circuit.loaded_current` for one value (compiled). [A]"""
    if not r > 0:
        return p / v
    disc = v * v - 4.0 * r * p
    if disc >= 0:
        return (v - np.sqrt(disc)) / (2.0 * r)
    return np.nan


@numba.njit(cache=True, error_model="numpy")
def _legs_kernel(lp_leg, rate_leg, dur, beta, scale, cap, r, cells, s_end, inc):
    r"""The per-leg figures of :meth:`MissionChain.run` for every pack in one pass.

    The same equations as the array code of ``run`` (which keeps the per-leg detail):
    stress increments and their sum, the charge :math:`C = S^{1/\beta}` ([UAV23] eq. 14)
    × the extensions' scale, the energy, and the loaded current at the mid-leg state of
    charge through the pack resistance (its peak, and the first leg whose power the pack
    cannot deliver). Fills ``s_end`` and ``inc`` (packs × legs) and returns per pack:
    charge used [A s], energy [Wh], peak current [A] (NaN: none), its leg, the first
    undeliverable leg (−1: none), that leg's power [W] and the most the pack delivers
    there [W].
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
            if s > 0:
                c = scale[i] * np.exp(np.log(s) / beta[i])
            elif np.isnan(s):
                c = np.nan
            else:
                c = 0.0
            p = np.exp(lp_leg[i, j])
            e += p * dur[j]
            soc = 1.0 - 0.5 * (c_prev + c) / cap[i]
            if j == 0:
                soc_first = soc
            cur = _current(p, cells[i] * _ocv_cell(soc), r[i])
            if np.isfinite(cur):
                if cur > best:
                    best = cur
                    best_j = j
            elif np.isfinite(p) and first[i] < 0:
                first[i] = j
                p_bad[i] = p
                v_oc = cells[i] * _ocv_cell(soc)
                p_max[i] = v_oc * v_oc / (4.0 * r[i])
            c_prev = c
        used[i] = c_prev
        energy[i] = e / 3600.0
        peak[i] = best if np.isfinite(best) else np.nan
        peak_leg[i] = best_j
        if first[i] < 0:
            p_bad[i] = np.exp(lp_leg[i, 0])
            v_oc = cells[i] * _ocv_cell(soc_first)
            p_max[i] = v_oc * v_oc / (4.0 * r[i])
    return used, energy, peak, peak_leg, first, p_bad, p_max


def _pack_arrays(packs, temperature_c):
    """Per-pack parameters as arrays (one Python pass over the packs).

    The totals are those of :class:`~planner.parameters.BatteryPack` (``count`` packs
    in parallel: mass and capacity × count, resistance ÷ count).
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
            "cells": cells, "delta": delta, "eps": eps, "beta": beta, "scale": scale}


def _series_into(det, sl, table, power, s_start, s_end, scale, beta, cap, points=12):
    """Power and remaining charge sampled inside every leg (for plots)."""
    f = np.linspace(0.0, 1.0, points)
    t = (table.start_time_s[:, None] + f * table.duration_s[:, None]).ravel()
    s = (s_start[:, :, None] + f * (s_end - s_start)[:, :, None]).reshape(s_start.shape[0], -1)
    rows = range(sl.start, sl.stop)
    for j, i in enumerate(rows):
        det.setdefault("series_time_s", {})[i] = t
        det.setdefault("series_power_w", {})[i] = np.repeat(power[j], points)
        det.setdefault("series_remaining_fraction", {})[i] = (
            1.0 - scale[j] * integral.charge_from_stress(s[j], beta[j]) / cap[j])
        det.setdefault("series_leg", {})[i] = np.repeat(np.arange(len(table)), points)
