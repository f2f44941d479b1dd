"""The pre-flight check's answer for one pack: :class:`MissionResult`.

The check itself is the one-pack case of the mission chain
(:meth:`planner.chain.mission_chain.MissionChain.check`); this module holds the result a
pilot reads: verdict, reasons, margins, the per-leg table and the series for the plot.
"""

from __future__ import annotations

import functools
import math
from collections import namedtuple
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from planner.physics.mission import Environment

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["MissionResult"]


@dataclass
class MissionResult:
    """Outcome of a pre-flight check.

    Attributes
    ----------
    verdict : str
        ``"GO"`` or ``"NO-GO"``.
    reasons : list of str
        Why NO-GO (empty for GO).
    warnings : list of str
        Things that do not ground the flight but the pilot should know.
    takeoff_mass_kg : float
        Aircraft + pack(s) + payload. [kg]
    duration_s : float
        [s]
    energy_wh : float
        ∫P dt over the mission. [Wh]
    charge_used_mah : float
        Charge drawn by the integral model. [mAh]
    capacity_mah, usable_mah, reserve_mah : float
        Nominal, usable (nominal × usable fraction) and reserve charge. [mAh]
    remaining_fraction : float
        Charge left on landing over nominal. [unitless]
    reserve_fraction : float
        Required landing reserve over nominal. [unitless]
    margin_mah : float
        Usable − reserve − used; negative = short. [mAh]
    margin_time_s : float
        The margin as extra hover (multirotor) or loiter (fixed-wing) time. [s]
    hold_power_w : float
        Power of that hover or loiter. [W]
    leg_columns : dict of ndarray
        The per-leg table, one array per column (see :meth:`to_dict` for the columns and
        units); :attr:`legs` is the same table as a DataFrame, :meth:`leg_rows` its rows.
    point_of_no_return : dict or None
        First point where a return home would not land with the reserve.
    endurance : dict or None
        Hover (loiter) and least-power endurance with this pack at this mass to the
        reserve (:meth:`planner.chain.mission_chain.ChainResult.endurance`). [s], [W]
    worst_return : dict or None
        The return-home point with the smallest margin (``rtl_margin_mah``), where it is
        (``east_m``, ``north_m``, ``altitude_m``, ``time_s``, ``leg``).
    rtl_min_margin_mah : float
        Smallest return-home margin along the mission. [mAh]
    peak_current_a, min_voltage_v : float
        [A], [V]
    battery_model : str
        Which integral-model parameters were used.
    environment : Environment
        The weather flown, with the air temperature actually used. [m/s, deg, °C]
    binding : str or None
        The first violated check constraint (:data:`planner.chain.steps.CHECK_CONSTRAINTS`);
        None for GO.
    cutoff_limited : bool
        The circuit model's voltage cut-off, not the nominal charge, sets the usable
        charge.
    unflyable_legs : list of int
        Legs (counted from 1) the aircraft cannot fly; their figures mean nothing.
    series : dict of ndarray
        ``time_s``, ``power_w``, ``remaining_fraction`` sampled along the mission
        for plots.
    """

    verdict: str
    reasons: list[str]
    warnings: list[str]
    aircraft: str
    battery: str
    takeoff_mass_kg: float
    duration_s: float
    energy_wh: float
    charge_used_mah: float
    capacity_mah: float
    usable_mah: float
    reserve_mah: float
    remaining_fraction: float
    reserve_fraction: float
    margin_mah: float
    margin_time_s: float
    hold_power_w: float
    leg_columns: dict[str, np.ndarray]
    point_of_no_return: dict | None
    rtl_min_margin_mah: float
    peak_current_a: float
    min_voltage_v: float
    battery_model: str
    series: dict[str, np.ndarray] = field(repr=False, default_factory=dict)
    aircraft_type: str = "multirotor"
    circuit: dict | None = None
    best_speeds: dict | None = None
    environment: Environment | None = None
    binding: str | None = None
    cutoff_limited: bool = False
    unflyable_legs: list[int] = field(default_factory=list)
    worst_return: dict | None = None
    endurance: dict | None = None

    @functools.cached_property
    def legs(self) -> pd.DataFrame:
        """The per-leg table as a DataFrame (one row per leg; pandas is imported when a
        caller asks for it, not by the check itself)."""
        import pandas as pd

        return pd.DataFrame(self.leg_columns)

    def leg_rows(self) -> list:
        """The per-leg table's rows, as named tuples of its columns (without pandas)."""
        row = namedtuple("LegRow", list(self.leg_columns))
        return [row(*values) for values in zip(*self.leg_columns.values())]

    @property
    def go(self) -> bool:
        """True when the verdict is GO."""
        return self.verdict == "GO"

    @property
    def landing_charge_mah(self) -> float:
        """Charge still usable on landing: usable − drawn (the reserve is part of it). [mAh]"""
        return self.usable_mah - self.charge_used_mah

    def verdict_line(self) -> str:
        """One line: the verdict, the limit that binds, by how much (agreeing with the
        margins printed beside it)."""
        what = "hover" if self.aircraft_type == "multirotor" else "loiter"
        extra = (f" = {self.margin_time_s / 60:+.1f} min of {what} at "
                 f"{self.hold_power_w:.0f} W" if math.isfinite(self.margin_time_s) else "")
        reserve = f"reserve {self.reserve_mah:.0f} mAh ({100 * self.reserve_fraction:.0f} %)"
        if self.cutoff_limited:
            limit = (f"the pack gives {self.usable_mah:.0f} mAh before its loaded voltage "
                     f"reaches the cut-off, {reserve}")
        else:
            limit = f"lands with {100 * self.remaining_fraction:.1f} % ({reserve})"
        if self.go:
            return f"GO: {limit}, margin {self.margin_mah:+.0f} mAh{extra}"
        more = len(self.reasons) - 1
        tail = f" (+{more} more reason{'s' if more > 1 else ''} above)" if more > 0 else ""
        b = self.binding
        if b == "landing_reserve":
            return (f"NO-GO: {limit}: short by {-self.margin_mah:.0f} mAh{extra}{tail}")
        if b == "runs_out":
            return (f"NO-GO: needs {self.charge_used_mah:.0f} mAh, the pack gives "
                    f"{self.usable_mah:.0f} mAh: it runs out before landing, short by "
                    f"{-self.margin_mah:.0f} mAh of the {reserve}{tail}")
        if b == "return_home" and self.point_of_no_return:
            p = self.point_of_no_return
            return (f"NO-GO: point of no return at t = {p['time_s']:.0f} s "
                    f"({p['leg_origin']}, {p['distance_home_m']:.0f} m from home): from "
                    f"there home with the {reserve} is out of reach (smallest return "
                    f"margin {self.rtl_min_margin_mah:+.0f} mAh){tail}")
        return f"NO-GO: {self.reasons[0]}{tail}" if self.reasons else "NO-GO"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (units in the key names)."""
        legs = [{k: _py(v) for k, v in row._asdict().items()} for row in self.leg_rows()]
        return {
            "verdict": self.verdict, "reasons": list(self.reasons),
            "warnings": list(self.warnings), "aircraft": self.aircraft,
            "battery": self.battery, "battery_model": self.battery_model,
            "aircraft_type": self.aircraft_type,
            "takeoff_mass_kg": _py(self.takeoff_mass_kg), "duration_s": _py(self.duration_s),
            "energy_wh": _py(self.energy_wh), "charge_used_mah": _py(self.charge_used_mah),
            "capacity_mah": _py(self.capacity_mah), "usable_mah": _py(self.usable_mah),
            "reserve_mah": _py(self.reserve_mah),
            "remaining_fraction": _py(self.remaining_fraction),
            "reserve_fraction": _py(self.reserve_fraction), "margin_mah": _py(self.margin_mah),
            "margin_time_s": _py(self.margin_time_s), "hold_power_w": _py(self.hold_power_w),
            "peak_current_a": _py(self.peak_current_a), "min_voltage_v": _py(self.min_voltage_v),
            "rtl_min_margin_mah": _py(self.rtl_min_margin_mah),
            "point_of_no_return": self.point_of_no_return,
            "worst_return": self.worst_return,
            "endurance": self.endurance,
            "circuit": self.circuit,
            "best_speeds": self.best_speeds,
            "binding": self.binding,
            "cutoff_limited": self.cutoff_limited,
            "unflyable_legs": list(self.unflyable_legs),
            "summary": self.verdict_line(),
            "legs": legs,
        }


def _py(value):
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return round(v, 6) if np.isfinite(v) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


