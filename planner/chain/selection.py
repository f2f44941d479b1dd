r"""Battery pack selection: every pack of a catalog on one mission, mass loop closed.

The pre-flight check answers "does *this* pack fly *this* mission with the reserve?".
Pack selection asks it of a whole catalog at once, and each pack changes the answer
through its own mass: take-off mass = aircraft empty mass + pack mass × ``count`` +
payload, so a bigger pack also needs more power. The physics is the mission chain's
(:class:`planner.chain.mission_chain.MissionChain` with the catalog as its pack axis), the same code
``check`` runs for one pack, with the same constraints
(:data:`planner.chain.steps.CHECK_CONSTRAINTS`, among them the aircraft's allowed cell
counts and, for multirotors with a known ``multirotor.max_thrust_n``, a minimum
thrust-to-weight ratio: :func:`planner.chain.steps.aircraft_limits`): a pack ``select``
rejects is NO-GO in ``check`` for the same reason.

:func:`select_pack` ranks the packs (objective ``mass``, ``margin`` or ``price``) and
names the binding constraint of every rejected pack.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from planner.chain.mission_chain import ChainResult, MissionChain
from planner.chain.steps import CHECK_CONSTRAINTS, DEFAULT_MIN_THRUST_TO_WEIGHT
from planner.errors import InputError
from planner.physics.mission import Environment, Mission
from planner.parameters import Aircraft, BatteryPack

__all__ = ["CONSTRAINTS", "DEFAULT_MIN_THRUST_TO_WEIGHT", "OBJECTIVES", "PackEvaluation",
           "Selection", "evaluate_packs", "rank_packs", "select_pack"]

#: Ranking objectives: lightest pack, largest landing margin (as extra hover or loiter
#: time), cheapest pack.
OBJECTIVES = ("mass", "margin", "price")

#: Constraint codes, in the order in which the first violated one is reported as the
#: *binding* constraint of a rejected pack: the check's own.
CONSTRAINTS = CHECK_CONSTRAINTS


# --------------------------------------------------------------------------- evaluation

@dataclass
class PackEvaluation:
    """Every pack of a catalog on one mission: the chain's result and verdicts (arrays: one element per pack; see
    :class:`planner.chain.mission_chain.ChainResult` for the figures and their units).

    Attributes
    ----------
    result : ChainResult
        The mission flown with every pack.
    min_thrust_to_weight : float
    thrust_to_weight : ndarray
        Maximum static thrust over take-off weight (NaN: not known). [unitless]
    violated : ndarray of bool, shape (packs, len(CONSTRAINTS))
    notes : list of str
        What the user should know about the evaluation as a whole.
    """

    result: ChainResult
    min_thrust_to_weight: float
    thrust_to_weight: np.ndarray
    violated: np.ndarray
    notes: list[str] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.result)

    def __getattr__(self, name):
        # the chain's per-pack figures (charge_used_mah, margin_mah, …) as attributes
        if name in ("result", "__setstate__"):
            raise AttributeError(name)
        return getattr(self.result, name)

    @property
    def aircraft_name(self) -> str:
        """The aircraft's name from its file."""
        return self.result.aircraft.name

    @property
    def aircraft_type(self) -> str:
        """``multirotor`` or ``fixed_wing``."""
        return self.result.aircraft.type

    @property
    def mission_name(self) -> str:
        """The mission's name from its file."""
        return self.result.mission.name

    @property
    def max_takeoff_mass_kg(self) -> float | None:
        """The aircraft's maximum take-off mass [kg] (None: not given)."""
        return self.result.aircraft.max_takeoff_mass_kg

    @property
    def cells_allowed(self) -> tuple[int, ...] | None:
        """The cell counts in series the aircraft flies (None: any)."""
        return self.result.aircraft.cells_series_allowed

    @property
    def method(self) -> str:
        """How the power was computed (the chain's power method, e.g. ``momentum``)."""
        return self.result.power_method

    @property
    def feasible(self) -> np.ndarray:
        """Packs that satisfy every constraint. [bool]"""
        return ~self.violated.any(axis=1)

    @property
    def check_go(self) -> np.ndarray:
        """The verdict ``check`` gives each pack: the same constraints. [bool]"""
        return self.result.go

    def constraints(self, i: int) -> list[str]:
        """Codes of the constraints pack ``i`` violates, binding first."""
        return [c for c, v in zip(CONSTRAINTS, self.violated[i]) if v]

    def binding(self, i: int) -> str | None:
        """The binding (first violated) constraint of pack ``i``; None when feasible."""
        codes = self.constraints(i)
        return codes[0] if codes else None

    def reasons(self, i: int) -> list[str]:
        """Why pack ``i`` is rejected, one message per violated constraint (``check``'s
        own words for the check's constraints)."""
        return [text for code in self.constraints(i)
                for text in self.result.reason(i, code)]

    def pack_dict(self, i: int) -> dict[str, Any]:
        """JSON-ready summary of pack ``i`` (units in the key names)."""
        p = self.packs[i]
        r = self.result
        return {
            "name": p.name + (f" x{p.count}" if p.count > 1 else ""),
            "feasible": bool(self.feasible[i]),
            "mass_kg": _num(r.pack_mass_kg[i]),
            "margin_mah": _num(r.margin_mah[i]),
            "reasons": self.reasons(i),
            "binding": self.binding(i),
            "constraints": self.constraints(i),
            "check_verdict": "GO" if self.check_go[i] else "NO-GO",
            "count": p.count, "cells_series": p.cells_series,
            "chemistry": p.chemistry,
            "capacity_mah": _num(r.capacity_mah[i]),
            "usable_mah": _num(r.usable_mah[i]),
            "takeoff_mass_kg": _num(r.takeoff_mass_kg[i]),
            "charge_used_mah": _num(r.charge_used_mah[i]),
            "remaining_fraction": _num(r.remaining_fraction[i]),
            "margin_time_s": _num(r.margin_time_s[i]),
            "rtl_min_margin_mah": _num(r.rtl_min_margin_mah[i]),
            "point_of_no_return": r.point_of_no_return(i),
            "energy_wh": _num(r.energy_wh[i]),
            "peak_current_a": _num(r.peak_current_a[i]),
            "max_current_a": _num(r.max_current_a[i]),
            "thrust_to_weight": _num(self.thrust_to_weight[i]),
            "price": None if p.price is None else float(p.price),
            "battery_model": "literature" if p.model.literature else "from the pack file",
            "battery_model_run": r.battery_models[i],
            "model_source": None if p.model.literature else p.model.source,
            "source": p.source,
        }

    def to_frame(self) -> pd.DataFrame:
        """One row per pack, catalog order."""
        r = self.result
        return pd.DataFrame({
            "name": [p.name + (f" x{p.count}" if p.count > 1 else "") for p in self.packs],
            "cells_series": [p.cells_series for p in self.packs],
            "capacity_mah": r.capacity_mah, "pack_mass_kg": r.pack_mass_kg,
            "takeoff_mass_kg": r.takeoff_mass_kg, "charge_used_mah": r.charge_used_mah,
            "margin_mah": r.margin_mah, "margin_time_s": r.margin_time_s,
            "rtl_min_margin_mah": r.rtl_min_margin_mah,
            "peak_current_a": r.peak_current_a, "max_current_a": r.max_current_a,
            "thrust_to_weight": self.thrust_to_weight, "feasible": self.feasible,
            "binding": [self.binding(i) for i in range(len(self))],
        })


def _num(v):
    v = float(v)
    return round(v, 6) if np.isfinite(v) else None


def evaluate_packs(mission: Mission, aircraft: Aircraft, packs: list[BatteryPack],
                   environment: Environment | None = None, *, reserve: float = 0.2,
                   temperature_c: float | None = None, payload_kg: float | None = None,
                   min_thrust_to_weight: float = DEFAULT_MIN_THRUST_TO_WEIGHT,
                   battery_model: str = "infer", method: str = "auto",
                   block_elements: int = 2_000_000) -> PackEvaluation:
    """Fly ``mission`` with every pack of a catalog through the mission chain, with the
    constraints ``check`` applies.

    Parameters
    ----------
    mission : Mission
    aircraft : Aircraft
    packs : list of BatteryPack
    environment : Environment, optional
        Overrides the mission's weather (``--wind``).
    reserve : float, default 0.2
        Landing reserve as a fraction of nominal capacity. [unitless]
    temperature_c : float, optional
        Outside air temperature; None = the mission's, else ISA. [°C]
    payload_kg : float, optional
        Overrides the mission's payload. [kg]
    min_thrust_to_weight : float, default 1.5
        Multirotors with ``multirotor.max_thrust_n``: least maximum thrust over
        take-off weight. [unitless]
    battery_model : {"infer", "integral", "circuit"}
        The chain's battery model (:data:`planner.chain.mission_chain.BATTERY_MODELS`).
    method : {"auto", "exact", "table"}
        How the power is evaluated over many masses, see
        :class:`planner.chain.powertable.PowerTable`.
    block_elements : int
        Packs are processed in blocks of about this many (pack × point) elements,
        which bounds the memory.

    Returns
    -------
    PackEvaluation
    """
    if not packs:
        raise InputError("the pack catalog is empty")
    chain = MissionChain(aircraft, packs, battery_model=battery_model, reserve=reserve,
                         temperature_c=temperature_c,
                         min_thrust_to_weight=min_thrust_to_weight)
    r = chain.run(mission, environment, payload_kg=payload_kg, power_method=method,
                  block_elements=block_elements)
    k = len(packs)
    notes: list[str] = list(r.table.notes) + list(r.limit_notes)
    no_rating = int(np.sum(~np.isfinite(r.max_current_a)))
    if no_rating:
        notes.append(f"C rating not checked for {no_rating} pack(s) without "
                     "max_discharge_c")
    n_circuit = sum(m == "circuit" for m in r.battery_models)
    if n_circuit:
        notes.append(f"{n_circuit} pack(s) flown through the equivalent-circuit"
                     + (" and thermal" if any(p.thermal for p in packs) else "")
                     + " model of their pack file, as check does")
    literature = sorted({p.cells_series for p in packs if p.model.literature})
    n_lit = sum(p.model.literature for p in packs)
    if n_lit:
        from planner.physics.battery.integral import LITERATURE_BETA
        notes.append(f"battery model: {n_lit} of {k} pack(s) have no fitted δ, ε and use "
                     f"the literature start values δ₀(N), ε₀(N), β = {LITERATURE_BETA} "
                     "for N = " + ", ".join(f"{c}S" for c in literature))
    return PackEvaluation(result=r, min_thrust_to_weight=float(min_thrust_to_weight),
                          thrust_to_weight=r.thrust_to_weight, violated=r.violated,
                          notes=notes)


# --------------------------------------------------------------------------- ranking

def rank_packs(evaluation: PackEvaluation, objective: str = "mass") -> np.ndarray:
    """Pack indices in ranked order: feasible packs first, each group by the objective.

    ``mass``: lightest pack (× count) first, ties by larger margin; ``margin``: largest
    landing margin expressed as extra hover/loiter time first (charge margins in mAh
    are not comparable between cell counts), ties by lighter pack; ``price``: cheapest
    first (packs without a price last), ties by lighter pack. Rejected packs follow in
    the same order.
    """
    if objective not in OBJECTIVES:
        raise InputError(f"objective must be one of {', '.join(OBJECTIVES)}, "
                         f"got {objective!r}")
    e = evaluation
    mt = np.where(np.isfinite(e.margin_time_s), e.margin_time_s,
                  np.where(e.margin_time_s > 0, 1e300, -1e300))
    mass = e.pack_mass_kg
    if objective == "mass":
        keys = (-mt, mass)
    elif objective == "margin":
        keys = (mass, -mt)
    else:
        price = np.array([np.inf if p.price is None else p.price for p in e.packs])
        keys = (mass, price)
    return np.lexsort(keys + (~e.feasible,))


@dataclass
class Selection:
    """A ranked catalog.

    Attributes
    ----------
    evaluation : PackEvaluation
    objective : str
    order : ndarray of int
        Pack indices, best first.
    """

    evaluation: PackEvaluation
    objective: str
    order: np.ndarray

    @property
    def best(self) -> int | None:
        """Index of the chosen pack; None when no pack is feasible."""
        if len(self.order) and self.evaluation.feasible[self.order[0]]:
            return int(self.order[0])
        return None

    @property
    def best_pack(self) -> BatteryPack | None:
        """The pack ranked first among those that fly the mission (None: none does)."""
        return None if self.best is None else self.evaluation.packs[self.best]

    def to_dict(self, top: int | None = None) -> dict[str, Any]:
        """JSON-ready: ``packs`` in ranked order (each with ``rank``)."""
        e = self.evaluation
        order = self.order if top is None else self.order[:top]
        packs = []
        for r, i in enumerate(order, 1):
            d = {"rank": r}
            d.update(e.pack_dict(int(i)))
            packs.append(d)
        return {"aircraft": e.aircraft_name, "mission": e.mission_name,
                "objective": self.objective, "reserve_fraction": e.reserve_fraction,
                "payload_kg": e.payload_kg, "duration_s": _num(e.duration_s),
                "feasible_count": int(e.feasible.sum()), "pack_count": len(e),
                "best": None if self.best is None else packs[0]["name"],
                "notes": list(e.notes), "packs": packs}


def select_pack(mission: Mission, aircraft: Aircraft, packs: list[BatteryPack],
                environment: Environment | None = None, *, objective: str = "mass",
                **kwargs) -> Selection:
    """Evaluate a catalog on a mission and rank it (see :func:`evaluate_packs`)."""
    if objective not in OBJECTIVES:
        raise InputError(f"objective must be one of {', '.join(OBJECTIVES)}, "
                         f"got {objective!r}")
    if objective == "price" and all(p.price is None for p in packs):
        raise InputError("objective price: no pack of the catalog has a price (give "
                         "'price:' in the pack entries, or rank by mass or margin)")
    evaluation = evaluate_packs(mission, aircraft, packs, environment, **kwargs)
    if objective == "price":
        unpriced = sum(p.price is None for p in packs)
        if unpriced:
            evaluation.notes.append(f"{unpriced} pack(s) without a price are ranked after "
                                    "the priced ones")
    return Selection(evaluation, objective, rank_packs(evaluation, objective))

