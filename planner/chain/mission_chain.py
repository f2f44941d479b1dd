r"""The mission chain: one orchestrator for every command that flies a mission.

:class:`MissionChain` composes the models as pvlib's ``ModelChain`` does:
:meth:`MissionChain.run` is a short sequence of named steps (:mod:`planner.chain.steps`):
the inputs → the flight states of the mission's legs, of the return home and of the hold
(:mod:`planner.chain.kinematics`) → one power call for every state and take-off mass
(:class:`planner.chain.powertable.PowerTable`) → the battery models (the equivalent
circuit and lumped thermal model of [HESS] eq. 1–5, 10–11 for the packs that use it, the
integral capacity model of [UAV23] eq. 14 along the legs) → the return-home reserve → the
constraints of the verdict.

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
* **return-to-home reserve** — at
  :data:`~planner.chain.kinematics.RTL_POINTS_PER_LEG` points of every leg the aircraft
  must be able to fly straight home at its cruise speed, at its altitude, descend and land
  with that same reserve. The first point where it cannot is the *point of no return*.

Charge is drawn from the usable charge (nominal × ``usable_fraction``); with the circuit
model the usable charge is also capped by the charge drawn when the loaded cell voltage
reaches ``cell_voltage_empty_v`` (the mission's profile, continued at the hold power).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

from typing import Any

import numpy as np

from planner.chain import steps
from planner.chain.flightstate import fill_gaps
from planner.chain.result import MissionResult
from planner.chain.steps import CHECK_CONSTRAINTS, DEFAULT_MIN_THRUST_TO_WEIGHT
from planner.errors import InputError
from planner.parameters import Aircraft, BatteryPack, IntegralModel, load_aircraft_and_battery
from planner.physics.atmosphere import RHO0
from planner.physics.battery import integral
from planner.physics.battery.thermal import T_RANGE_C
from planner.physics.geo import aeqd_to_latlon
from planner.physics.mission import Environment, Mission
from planner.physics.units import AS_PER_MAH

__all__ = ["BATTERY_MODELS", "BatteryTrace", "ChainResult", "MissionChain"]

#: Battery models the chain can run: by name, or inferred from the pack file.
BATTERY_MODELS = ("infer", "integral", "circuit")

#: Legs the aircraft cannot fly that a reason names one by one; the rest are counted.
MAX_LISTED_PROBLEMS = 3


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
    thrust_to_weight : ndarray
        Maximum static thrust over take-off weight (NaN: not known). [unitless]
    min_thrust_to_weight : float
        The least thrust-to-weight the verdict asks of a multirotor. [unitless]
    limit_notes : list of str
        The aircraft's limits that could not be checked, and why.
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
    thrust_to_weight: np.ndarray | None = None
    min_thrust_to_weight: float = DEFAULT_MIN_THRUST_TO_WEIGHT
    limit_notes: list[str] = field(default_factory=list)

    @classmethod
    def of_run(cls, inputs, states, power, circuit, budget, flown, violated) -> ChainResult:
        """The result of the steps of :meth:`MissionChain.run` (:mod:`planner.chain.steps`)."""
        pa, rtl, cap = inputs.pack, states.rtl, budget.cap
        used = flown.used_as
        limits = steps.aircraft_limits(inputs.aircraft, inputs.packs, inputs.mass,
                                       inputs.min_thrust_to_weight)
        return cls(
            packs=list(inputs.packs), battery_models=list(inputs.models),
            aircraft=inputs.aircraft, mission=inputs.mission,
            environment=inputs.flown_environment, table=states.table,
            reserve_fraction=inputs.reserve, payload_kg=inputs.payload_kg,
            takeoff_mass_kg=inputs.mass, pack_mass_kg=pa["mass"],
            capacity_mah=cap / AS_PER_MAH, usable_mah=budget.usable / AS_PER_MAH,
            reserve_mah=inputs.reserve * cap / AS_PER_MAH, charge_used_mah=used / AS_PER_MAH,
            margin_mah=(budget.limit - used) / AS_PER_MAH, remaining_fraction=1.0 - used / cap,
            margin_time_s=steps.margin_time(inputs, budget, flown.stress_final,
                                            flown.hold_power_w),
            hold_power_w=flown.hold_power_w, energy_wh=flown.energy_wh,
            rtl_min_margin_mah=flown.rtl_min_margin_as / AS_PER_MAH,
            pnr_index=flown.pnr_index, peak_current_a=flown.peak_current_a,
            peak_leg=flown.peak_leg, undeliverable_leg=flown.undeliverable_leg,
            max_current_a=pa["imax"], circuit=circuit.figures, violated=violated,
            undeliverable_power_w=flown.p_undeliverable_w, deliverable_max_w=flown.p_max_w,
            rtl_points={key: rtl[key] for key in ("leg", "time_s", "east_m", "north_m",
                                                  "altitude_m", "distance_m", "t_back",
                                                  "t_down")},
            power_method=power.table.method, detail=flown.detail,
            thrust_to_weight=limits.thrust_to_weight,
            min_thrust_to_weight=inputs.min_thrust_to_weight, limit_notes=limits.notes)

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

    def worst_return(self, i: int) -> dict | None:
        """The return-home point of pack ``i`` with the smallest margin (the charge left
        over the reserve after flying home from there), as :meth:`point_of_no_return`
        reports a point; None when the run kept no per-point margins."""
        if self.detail is None or "rtl_point_margin_mah" not in self.detail:
            return None
        m = np.asarray(self.detail["rtl_point_margin_mah"][i], float)
        if m.size == 0 or np.isnan(m).all():
            return None
        j = int(np.argmin(np.where(np.isnan(m), np.inf, m)))  # -inf: home out of reach
        r = self.rtl_points
        leg = int(r["leg"][j])
        return {"time_s": float(r["time_s"][j]), "leg": leg + 1,
                "leg_origin": _leg_name(self.table, leg),
                "east_m": float(r["east_m"][j]), "north_m": float(r["north_m"][j]),
                "altitude_m": float(r["altitude_m"][j]),
                "distance_home_m": float(r["distance_m"][j]),
                "rtl_margin_mah": float(m[j]) if np.isfinite(m[j]) else None}

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
        """The message(s) of check constraint ``code`` for pack ``i``: the method
        ``_reason_<code>`` of that constraint."""
        return getattr(self, f"_reason_{code}")(i)

    def _circuit_row(self, i: int) -> dict:
        """The circuit model's figures of pack ``i`` (:data:`CIRCUIT_FIGURES`)."""
        return {k: v[i] for k, v in self.circuit.items()}

    def _reason_mission(self, i: int) -> list[str]:
        listed = sorted(self.table.problems)
        problems = [f"{_leg_name(self.table, j)}: {why}" for j, why in listed]
        if len(problems) <= MAX_LISTED_PROBLEMS:
            return problems
        rest = sorted({j + 1 for j, _ in listed[MAX_LISTED_PROBLEMS - 1:]})
        return problems[:MAX_LISTED_PROBLEMS - 1] + [
            f"and {len(rest)} more legs the aircraft cannot fly: legs {_ranges(rest)}"]

    def _reason_cells(self, i: int) -> list[str]:
        allowed = ", ".join(f"{c}S" for c in self.aircraft.cells_series_allowed)
        return [f"{self.packs[i].cells_series}S pack, the aircraft allows {allowed}"]

    def _reason_thrust(self, i: int) -> list[str]:
        return [f"thrust-to-weight {self.thrust_to_weight[i]:.2f} at the take-off mass "
                f"{self.takeoff_mass_kg[i]:.2f} kg is below the minimum "
                f"{self.min_thrust_to_weight:g}"]

    def _reason_power(self, i: int) -> list[str]:
        leg = _leg_name(self.table, int(self.undeliverable_leg[i]))
        ohm = self.packs[i].resistance_ohm
        return [f"{leg}: the pack cannot deliver {self.undeliverable_power_w[i]:.0f} W (at "
                f"most {self.deliverable_max_w[i]:.0f} W through {ohm * 1000:.1f} mΩ)"]

    def _reason_c_rating(self, i: int) -> list[str]:
        leg = _leg_name(self.table, int(self.peak_leg[i]))
        return [f"{leg}: current {self.peak_current_a[i]:.1f} A exceeds the pack's "
                f"{self.packs[i].max_discharge_c:g} C rating ({self.max_current_a[i]:.1f} A)"]

    def _reason_takeoff_mass(self, i: int) -> list[str]:
        return [f"take-off mass {self.takeoff_mass_kg[i]:.2f} kg exceeds the aircraft's "
                f"maximum {self.aircraft.max_takeoff_mass_kg:.2f} kg"]

    def _reason_temperature(self, i: int) -> list[str]:
        c = self._circuit_row(i)
        span = f"[{T_RANGE_C[0]:g} °C, {T_RANGE_C[1]:g} °C]"
        if np.isfinite(c["hot_time_s"]):
            return [f"the pack reaches {c['hot_temperature_c']:.0f} °C at t = "
                    f"{c['hot_time_s']:.0f} s, outside the battery model's range {span}"]
        return [f"the pack starts at {c['pack_temperature_c']:.0f} °C, outside the battery "
                f"model's range {span}: no prediction can be trusted"]

    def _reason_voltage(self, i: int) -> list[str]:
        return self._voltage_reasons(i, self._circuit_row(i))

    def _reason_runs_out(self, i: int) -> list[str]:
        return [f"needs {self.charge_used_mah[i]:.0f} mAh, more than the "
                f"{self.usable_mah[i]:.0f} mAh the pack can give: it runs out before landing"]

    def _reason_landing_reserve(self, i: int) -> list[str]:
        return [self._landing_reason(i, self._circuit_row(i))]

    def _reason_return_home(self, i: int) -> list[str]:
        pnr = self.point_of_no_return(i)
        return [f"cannot return home with the reserve from t = {pnr['time_s']:.0f} s "
                f"({pnr['leg_origin']}, {pnr['distance_home_m']:.0f} m from home): point of "
                "no return passed"]

    def _voltage_reasons(self, i: int, c: dict) -> list[str]:
        """The circuit model's cut-off and voltage collapse, in words, for pack ``i``."""
        p, table, out = self.packs[i], self.table, []
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
        return out

    def _landing_reason(self, i: int, c: dict) -> str:
        """Why pack ``i`` lands below the reserve: the cold, the cut-off or the charge."""
        p = self.packs[i]
        if self.cutoff_limited(i) and self.battery_models[i] == "integral":
            return (f"with the pack at {c['pack_temperature_c']:.0f} °C it gives "
                    f"{self.usable_mah[i]:.0f} mAh of the "
                    f"{p.usable_as / AS_PER_MAH:.0f} mAh usable at 25 °C (the "
                    f"{p.chemistry} cold laws): the mission ends "
                    f"{-self.margin_mah[i]:.0f} mAh short of the reserve")
        if self.cutoff_limited(i):
            return (f"the loaded cell voltage reaches the "
                    f"{p.cell_voltage_empty_v:g} V cut-off after "
                    f"{self.usable_mah[i]:.0f} mAh with the pack at "
                    f"{c['pack_temperature_c']:.0f} °C (of "
                    f"{p.usable_as / AS_PER_MAH:.0f} mAh usable when warm): the "
                    f"mission ends {-self.margin_mah[i]:.0f} mAh short of the "
                    "reserve")
        return (f"lands with {100 * self.remaining_fraction[i]:.1f} % of "
                f"nominal charge, below the {100 * self.reserve_fraction:.0f} "
                f"% reserve (short by {-self.margin_mah[i]:.0f} mAh)")

    def cutoff_limited(self, i: int) -> bool:
        """Whether the circuit model's cut-off, not the nominal charge, limits pack ``i``."""
        return self.usable_mah[i] * AS_PER_MAH < self.packs[i].usable_as

    def warnings(self, i: int) -> list[str]:
        """What the pilot should know about pack ``i`` that does not ground the flight."""
        p, out = self.packs[i], list(self.table.notes) + list(self.limit_notes)
        if self.battery_models[i] == "integral" and self.detail is not None \
                and "voltage_v" in self.detail:
            v_end = self.detail["voltage_v"][i]
            v_min = p.cells_series * p.cell_voltage_empty_v
            low = np.flatnonzero(v_end < v_min)
            if low.size:
                j = int(low[0])
                out.append(f"loaded voltage {v_end[j]:.2f} V falls below {v_min:.2f} V "
                           f"({p.cell_voltage_empty_v:g} V/cell) by the end of "
                           f"{_leg_name(self.table, j)} "
                           f"(t = {self.table.end_time_s[j]:.0f} s): "
                           "expect a low-voltage failsafe")
        if self.battery_models[i] == "integral" and self.cutoff_limited(i):
            t = float(self.circuit["pack_temperature_c"][i])
            out.append(f"cold: with the pack at {t:.0f} °C it gives "
                       f"{self.usable_mah[i]:.0f} of its {p.usable_as / AS_PER_MAH:.0f} mAh "
                       f"usable at 25 °C (the {p.chemistry} capacity and resistance laws; "
                       "the pack file has no circuit: or thermal: block)")
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
        if self.detail is None or "power_w" not in self.detail:
            chain = MissionChain(self.aircraft, [self.packs[i]],
                                 battery_model=self.battery_models[i],
                                 reserve=self.reserve_fraction,
                                 temperature_c=self.environment.temperature_c,
                                 min_thrust_to_weight=self.min_thrust_to_weight)
            return chain.run(self.mission, self.environment, payload_kg=self.payload_kg,
                             detail=True).mission_result(0)
        d, table, p = self.detail, self.table, self.packs[i]
        cap = self.capacity_mah[i]
        legs = {
            "kind": table.kind, "origin": table.origin, "start_time_s": table.start_time_s,
            "duration_s": table.duration_s, "distance_m": table.distance_m,
            "course_deg": table.course_deg, "airspeed_ms": table.airspeed_ms,
            "groundspeed_ms": table.groundspeed_ms, "climb_rate_ms": table.climb_rate_ms,
            "altitude_m": table.end_alt_m, "power_w": d["power_w"][i],
            "current_a": d["current_a"][i], "voltage_v": d["voltage_v"][i],
            "charge_mah": d["charge_mah"][i],
            "remaining_fraction": 1.0 - d["charge_end_mah"][i] / cap,
            "rtl_margin_mah": d["rtl_margin_mah"][i]}
        for col, values in route_columns(table, self.mission.home).items():
            legs[col] = values
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
            hold_power_w=float(self.hold_power_w[i]), leg_columns=legs,
            point_of_no_return=self.point_of_no_return(i), worst_return=self.worst_return(i),
            endurance=self.endurance(i),
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
        rho0 = float(self.table.air_density[-1]) if len(self.table) else RHO0

        def power(v):
            return ac.battery_power(v, 0.0, rho0, mass)

        b = best_speeds(power, ac.min_airspeed_ms, ac.max_airspeed_ms)
        return {"max_endurance_airspeed_ms": float(b.max_endurance),
                "max_endurance_power_w": float(power(b.max_endurance)),
                "max_range_airspeed_ms": float(b.max_range),
                "max_range_power_w": float(power(b.max_range))}


    def endurance(self, i: int) -> dict:
        """Hold and least-power endurance of pack ``i`` at its take-off mass, from a full
        pack to the landing limit (usable charge less the reserve), in still air:
        ``hold_s`` at the mission's hover (multirotor) or loiter (fixed-wing) power
        ``hold_power_w``, and ``least_power_s`` in level flight at the airspeed of least
        power ``least_power_airspeed_ms`` (``least_power_w``). The integral model at
        constant power, [UAV23] eq. 15 (:func:`integral.time_to_charge`). [s], [W], [m/s]"""
        pa = steps.pack_arrays([self.packs[i]], self.environment.temperature_c)
        limit = max(float(self.usable_mah[i] - self.reserve_mah[i]), 0.0) * AS_PER_MAH

        def hold(power_w):
            return float(integral.time_to_charge(0.0, power_w, limit / pa["scale"][0],
                                                 pa["delta"][0], pa["eps"][0],
                                                 pa["beta"][0]))

        best = self.aircraft_best_speeds(i)
        p_hold, p_least = float(self.hold_power_w[i]), best["max_endurance_power_w"]
        return {"hold_power_w": p_hold, "hold_s": hold(p_hold),
                "least_power_airspeed_ms": best["max_endurance_airspeed_ms"],
                "least_power_w": p_least, "least_power_s": hold(p_least),
                "takeoff_mass_kg": float(self.takeoff_mass_kg[i]),
                "reserve_mah": float(self.reserve_mah[i])}


def route_columns(table, home) -> dict[str, np.ndarray]:
    """Where each leg starts and ends: east/north of home and altitude above home [m],
    and, when the mission's home is known, latitude, longitude [deg] (WGS-84, the legs'
    frame: :func:`planner.physics.geo.aeqd_to_latlon`) and altitude above mean sea level
    [m]."""
    out = {}
    for end in ("start", "end"):
        en = np.asarray(getattr(table, f"{end}_en_m"), float).reshape(-1, 2)
        alt = np.asarray(getattr(table, f"{end}_alt_m"), float)
        out[f"{end}_east_m"], out[f"{end}_north_m"] = en[:, 0], en[:, 1]
        out[f"{end}_alt_m"] = alt
        if home is not None:
            lat, lon = aeqd_to_latlon(en[:, 0], en[:, 1], home[0], home[1])
            out[f"{end}_lat_deg"] = np.atleast_1d(lat)
            out[f"{end}_lon_deg"] = np.atleast_1d(lon)
            if len(home) > 2 and home[2] is not None:
                out[f"{end}_alt_amsl_m"] = alt + float(home[2])
    return out


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
    min_thrust_to_weight : float, default 1.5
        Multirotors with ``multirotor.max_thrust_n``: least maximum thrust over take-off
        weight (:func:`planner.chain.steps.aircraft_limits`). [unitless]

    Examples
    --------
    >>> chain = MissionChain.from_yaml("aircraft/solo_survey.yaml")     # doctest: +SKIP
    >>> result = chain.check(load_mission("missions/survey_quad.yaml"))  # doctest: +SKIP
    >>> result.verdict, result.margin_mah                               # doctest: +SKIP
    """

    def __init__(self, aircraft: Aircraft, packs: BatteryPack | Sequence[BatteryPack], *,
                 battery_model: str = "infer", reserve: float = 0.2,
                 temperature_c: float | None = None,
                 min_thrust_to_weight: float = DEFAULT_MIN_THRUST_TO_WEIGHT):
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
        self.min_thrust_to_weight = float(min_thrust_to_weight)
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
        """The pre-flight check of a one-pack chain
        (:class:`planner.chain.result.MissionResult`)."""
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
            How the power is evaluated over many masses, see
            :class:`~planner.chain.powertable.PowerTable`.
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
            model, ``soh``, the state of health, which scales the charge the pack can
            give (nominal × usable fraction, and the circuit model's charge to the
            cut-off), and ``power_scale``, which multiplies the battery power (the power
            model's own error).

        Returns
        -------
        ChainResult
        """
        inputs = steps.chain_inputs(
            self.aircraft, self.packs, self.models, mission, environment,
            temperature_c=self.temperature_c, reserve=self.reserve, payload_kg=payload_kg,
            detail=detail, pack_samples=pack_samples,
            min_thrust_to_weight=self.min_thrust_to_weight)
        states = steps.flight_states(inputs, rtl_subset)
        power = steps.power_step(inputs, states, power_method)
        circuit = steps.circuit_model(inputs, states, power)
        budget = steps.charge_budget(inputs, circuit, power)
        flown = steps.PackFigures(inputs, states)
        for rows in steps.pack_blocks(len(self.packs), power, states, block_elements):
            legs = steps.leg_figures(inputs, states, power, rows)
            home = steps.return_home(inputs, states, power, budget, legs, rows)
            flown.store(rows, inputs, states, power, legs, home)
        flown.circuit_voltages(circuit)
        violated = steps.constraints(inputs, states, circuit, budget, flown)
        return ChainResult.of_run(inputs, states, power, circuit, budget, flown, violated)

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
        temp = (fill_gaps(temperature_c)
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
        disk = ac.is_multirotor and state.disk_frame
        if not ac.has_rotor_losses:
            return self.power_at(v, climb, state.air_density, mass_kg, on_ground=on_ground,
                                 disk_frame=disk)
        lead = float(ac.multirotor.power_lead_s or 0.0)
        t = np.asarray(state.time_s, float)

        def later(x):
            x = np.asarray(x, float)
            return x if lead == 0.0 or t.size < 2 else np.interp(t + lead, t, x)

        mass = np.asarray(mass_kg, float)
        force = state.specific_force_ms2
        thrust = None if force is None else mass * later(force)
        return self.power_at(later(v), later(climb), later(state.air_density), mass,
                             on_ground=on_ground, thrust=thrust, disk_frame=disk)

    def power_at(self, airspeed_ms, climb_rate_ms, air_density, mass_kg, *,
                 on_ground=False, thrust=None, disk_frame=False) -> np.ndarray:
        """The aircraft's battery power at measured flight states (all broadcast).

        A fixed-wing aircraft's airspeed is held at its minimum airspeed
        (:attr:`planner.parameters.Aircraft.min_airspeed_ms`): below it the polar's
        induced term has no meaning. On the ground only ``system_power_w`` is drawn.
        ``thrust`` (measured, N) is read by the ``rotor_losses`` model only; where
        ``disk_frame`` is true the speeds are the rotor disks' in-plane and axial speed
        (:meth:`planner.parameters.Aircraft.battery_power`). [W]
        """
        ac = self.aircraft
        v = (np.asarray(airspeed_ms, float) if ac.is_multirotor
             else np.maximum(airspeed_ms, ac.min_airspeed_ms))
        extra = {} if thrust is None else {"thrust": thrust}
        power = np.asarray(ac.battery_power(v, climb_rate_ms, air_density, mass_kg,
                                            disk_frame=disk_frame, **extra), float)
        return np.where(on_ground, ac.system_power_w, power)
