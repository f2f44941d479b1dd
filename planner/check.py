"""Pre-flight endurance check: power profile → charge drawn → reserves → GO / NO-GO.

:class:`MissionChain` composes the models (as pvlib's ``ModelChain``): leg
kinematics and power (:mod:`planner.profile`), the integral capacity model
(:mod:`planner.battery.integral`), a loaded-voltage estimate from the pack's
resistance and a LiPo open-circuit-voltage curve, and the two reserves:

* **landing reserve** — the charge left on landing must be at least
  ``reserve`` × nominal capacity (default 20 %);
* **return-to-home reserve** — at every point of the mission the aircraft must
  be able to fly straight home at its cruise speed, at its current altitude,
  descend and land with that same reserve. The first point where it cannot is
  the *point of no return*.

Charge is drawn from the usable charge (nominal × ``usable_fraction``). With
the integral model the charge of a profile is not additive but its *stress*
:math:`S = \\int dt/(\\delta P^\\varepsilon)` is, so the return-home charge from a
point is :math:`(S_{point} + S_{return})^{1/\\beta}`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from planner import profile as prof
from planner.battery import integral
from planner.battery.ocv import lipo_ocv
from planner.definitions import Aircraft, BatteryPack, load_aircraft_and_battery
from planner.errors import InputError, ModelError
from planner.mission.legs import Environment, Mission
from planner.units import AS_PER_MAH

RTL_POINTS_PER_LEG = prof.RTL_POINTS_PER_LEG


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
    legs : pandas.DataFrame
        One row per leg (see :meth:`to_dict` for the columns and units).
    point_of_no_return : dict or None
        First point where a return home would not land with the reserve.
    rtl_min_margin_mah : float
        Smallest return-home margin along the mission. [mAh]
    peak_current_a, min_voltage_v : float
        [A], [V]
    battery_model : str
        Which integral-model parameters were used.
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
    legs: pd.DataFrame
    point_of_no_return: dict | None
    rtl_min_margin_mah: float
    peak_current_a: float
    min_voltage_v: float
    battery_model: str
    series: dict[str, np.ndarray] = field(repr=False, default_factory=dict)
    aircraft_type: str = "multirotor"
    circuit: dict | None = None
    best_speeds: dict | None = None

    @property
    def go(self) -> bool:
        return self.verdict == "GO"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (units in the key names)."""
        legs = [{k: _py(v) for k, v in row.items()} for row in self.legs.to_dict("records")]
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
            "circuit": self.circuit,
            "best_speeds": self.best_speeds,
            "legs": legs,
        }


def _py(value):
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return round(v, 6) if np.isfinite(v) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


def loaded_current(power_w, open_circuit_v, resistance_ohm):
    r"""
    Pack current that delivers ``power_w`` through a series resistance.

    .. math:: I = \frac{V_{oc} - \sqrt{V_{oc}^2 - 4 R P}}{2 R}

    from :math:`P = (V_{oc} - I R) I`; NaN where :math:`P > V_{oc}^2/(4R)`, the
    most the pack can deliver. [A]
    """
    p = np.asarray(power_w, dtype=float)
    v = np.asarray(open_circuit_v, dtype=float)
    r = float(resistance_ohm)
    if r <= 0:
        return p / v
    disc = v**2 - 4.0 * r * p
    with np.errstate(invalid="ignore"):
        return np.where(disc >= 0, (v - np.sqrt(np.where(disc >= 0, disc, 0.0))) / (2 * r),
                        np.nan)


class MissionChain:
    """Composes aircraft, pack and models into a pre-flight check.

    Parameters
    ----------
    aircraft : Aircraft
    pack : BatteryPack
    reserve : float, default 0.2
        Landing reserve as a fraction of nominal capacity. [unitless]
    temperature_c : float, optional
        Outside air (and pack) temperature; ``None`` = the mission's, else ISA. [°C]

    Examples
    --------
    >>> chain = MissionChain.from_yaml("aircraft/quad_7in.yaml")    # doctest: +SKIP
    >>> result = chain.run(load_mission("missions/survey_quad.yaml"))  # doctest: +SKIP
    >>> result.verdict, result.margin_mah                             # doctest: +SKIP
    """

    def __init__(self, aircraft: Aircraft, pack: BatteryPack, *, reserve: float = 0.2,
                 temperature_c: float | None = None):
        if not 0.0 <= reserve < 1.0:
            raise InputError(f"--reserve must be in [0, 1), got {reserve}")
        self.aircraft = aircraft
        self.pack = pack
        self.reserve = float(reserve)
        self.temperature_c = temperature_c

    @classmethod
    def from_yaml(cls, aircraft_path, battery_path=None, **kwargs) -> MissionChain:
        aircraft, pack = load_aircraft_and_battery(aircraft_path, battery_path)
        return cls(aircraft, pack, **kwargs)

    # ------------------------------------------------------------------ run
    def run(self, mission: Mission, environment: Environment | None = None) -> MissionResult:
        """Check one mission. ``environment`` overrides the mission's weather."""
        env = environment or mission.environment
        ac, pack = self.aircraft, self.pack
        temp = self.temperature_c if self.temperature_c is not None else env.temperature_c
        table = prof.leg_table(mission, ac, env, temperature_c=temp)
        mass = ac.empty_mass_kg + pack.total_mass_kg + mission.payload_kg
        power = np.asarray(prof.leg_power(table, ac, mass), dtype=float)
        reasons = [f"{table.origin[i] or f'leg {i + 1}'}: {why}" for i, why in table.problems]
        warnings = list(table.notes)

        model = pack.model
        scale = model.charge_scale(temp)
        dur = table.duration_s
        rate = np.asarray(integral.stress_rate(power, model.delta, model.epsilon), float)
        s_end = np.cumsum(dur * rate)
        s_start = s_end - dur * rate
        c_end = scale * integral.charge_from_stress(s_end, model.beta)
        c_start = scale * integral.charge_from_stress(s_start, model.beta)
        cap = pack.capacity_as
        limit = pack.usable_as - self.reserve * cap
        used = float(c_end[-1]) if len(c_end) else 0.0

        # loaded current and voltage from the open-circuit curve and the resistance
        cells = pack.cells_series
        soc_mid = 1.0 - 0.5 * (c_start + c_end) / cap
        soc_end = 1.0 - c_end / cap
        r = pack.resistance_ohm
        current = loaded_current(power, cells * lipo_ocv(soc_mid), r)
        current_end = loaded_current(power, cells * lipo_ocv(soc_end), r)
        v_end = cells * lipo_ocv(soc_end) - current_end * r
        v_end = np.where(np.isnan(current_end), np.nan, v_end)
        peak = float(np.nanmax(current)) if np.any(np.isfinite(current)) else float("nan")
        for i in np.flatnonzero(np.isnan(current) & np.isfinite(power)):
            vmax = cells * lipo_ocv(soc_mid[i])
            reasons.append(f"{table.origin[i] or f'leg {i + 1}'}: the pack cannot deliver "
                           f"{power[i]:.0f} W (at most {vmax**2 / (4 * r):.0f} W through "
                           f"{r * 1000:.1f} mΩ)")
            break
        if pack.max_current_a is not None and np.isfinite(peak) and peak > pack.max_current_a:
            i = int(np.nanargmax(current))
            reasons.append(f"{table.origin[i] or f'leg {i + 1}'}: current {peak:.1f} A exceeds "
                           f"the pack's {pack.max_discharge_c:g} C rating "
                           f"({pack.max_current_a:.1f} A)")
        with_circuit = pack.circuit is not None or pack.thermal is not None
        v_min_allowed = cells * pack.cell_voltage_empty_v
        low = np.flatnonzero(v_end < v_min_allowed)
        if low.size and not with_circuit:  # the circuit model judges the voltage itself
            i = int(low[0])
            warnings.append(f"loaded voltage {v_end[i]:.2f} V falls below "
                            f"{v_min_allowed:.2f} V ({pack.cell_voltage_empty_v:g} V/cell) "
                            f"by the end of {table.origin[i] or f'leg {i + 1}'} "
                            f"(t = {table.end_time_s[i]:.0f} s): expect a low-voltage failsafe")
        if ac.max_takeoff_mass_kg is not None and mass > ac.max_takeoff_mass_kg:
            reasons.append(f"take-off mass {mass:.2f} kg exceeds the aircraft's maximum "
                           f"{ac.max_takeoff_mass_kg:.2f} kg")
        if model.literature:
            warnings.append(f"battery model: literature δ₀({cells}), ε₀({cells}) scaled to "
                            f"the pack's {pack.capacity_mah:.0f} mAh, β = {model.beta} "
                            "(the pack file has no fitted model)")

        rho0 = float(table.air_density[-1]) if len(table) else 1.225
        p_hold = float(prof.hold_power(ac, mass, rho0, env.wind_speed_ms))
        circuit = None
        if with_circuit:
            circuit = self._circuit(table, power, temp, p_hold)
            usable_v = circuit.pop("_usable_as")
            if usable_v < pack.usable_as:
                limit = usable_v - self.reserve * cap
            v_end = circuit.pop("_leg_voltage_v")
            reasons += circuit["reasons"]

        # landing reserve
        margin = limit - used
        usable_now = limit + self.reserve * cap
        if circuit is not None and usable_now < pack.usable_as and margin < 0:
            reasons.append(f"the loaded cell voltage reaches the {pack.cell_voltage_empty_v:g} V "
                           f"cut-off after {usable_now / AS_PER_MAH:.0f} mAh with the pack at "
                           f"{circuit['pack_temperature_c']:.0f} °C (of "
                           f"{pack.usable_as / AS_PER_MAH:.0f} mAh usable when warm): the mission "
                           f"ends {-margin / AS_PER_MAH:.0f} mAh short of the reserve")
        elif used > usable_now:
            reasons.append(f"needs {used / AS_PER_MAH:.0f} mAh, more than the "
                           f"{usable_now / AS_PER_MAH:.0f} mAh the pack can give: it runs out "
                           f"before landing")
        elif margin < 0:
            reasons.append(f"lands with {100 * (1 - used / cap):.1f} % of nominal charge, "
                           f"below the {100 * self.reserve:.0f} % reserve "
                           f"(short by {-margin / AS_PER_MAH:.0f} mAh)")
        s_final = float(s_end[-1]) if len(s_end) else 0.0
        margin_time = float(integral.time_to_charge(s_final, p_hold, max(limit, 0.0) / scale,
                                                    model.delta, model.epsilon, model.beta))
        if limit <= 0:
            margin_time = float("-inf")

        speeds = self._best_speeds(mass, rho0)

        # return-to-home reserve
        rtl_margin_leg, pnr, rtl_min = self._return_home(table, power, s_start, s_end, mass,
                                                         env, temp, limit, scale)
        if pnr is not None:
            reasons.append(f"cannot return home with the reserve from t = {pnr['time_s']:.0f} s "
                           f"({pnr['leg_origin']}, {pnr['distance_home_m']:.0f} m from home): "
                           "point of no return passed")

        legs = pd.DataFrame({
            "kind": table.kind, "origin": table.origin, "start_time_s": table.start_time_s,
            "duration_s": dur, "distance_m": table.distance_m, "course_deg": table.course_deg,
            "airspeed_ms": table.airspeed_ms, "groundspeed_ms": table.groundspeed_ms,
            "climb_rate_ms": table.climb_rate_ms, "altitude_m": table.end_alt_m,
            "power_w": power, "current_a": current, "voltage_v": v_end,
            "charge_mah": (c_end - c_start) / AS_PER_MAH, "remaining_fraction": 1.0 - c_end / cap,
            "rtl_margin_mah": rtl_margin_leg / AS_PER_MAH,
        })
        series = _series(table, power, s_start, s_end, model, scale, cap)
        energy = float(np.sum(power * dur)) / 3600.0
        return MissionResult(
            verdict="NO-GO" if reasons else "GO", reasons=reasons, warnings=warnings,
            aircraft=ac.name, battery=pack.name + (f" ×{pack.count}" if pack.count > 1 else ""),
            takeoff_mass_kg=mass, duration_s=float(np.sum(dur)), energy_wh=energy,
            charge_used_mah=used / AS_PER_MAH, capacity_mah=cap / AS_PER_MAH,
            usable_mah=(limit + self.reserve * cap) / AS_PER_MAH,
            reserve_mah=self.reserve * cap / AS_PER_MAH,
            remaining_fraction=1.0 - used / cap, reserve_fraction=self.reserve,
            margin_mah=margin / AS_PER_MAH, margin_time_s=margin_time, hold_power_w=p_hold,
            legs=legs, point_of_no_return=pnr, rtl_min_margin_mah=rtl_min / AS_PER_MAH,
            peak_current_a=peak,
            min_voltage_v=float(np.nanmin(v_end)) if np.any(np.isfinite(v_end)) else float("nan"),
            battery_model=("literature" if model.literature else "fitted"), series=series,
            aircraft_type=ac.type, circuit=circuit, best_speeds=speeds)

    def _best_speeds(self, mass: float, air_density: float) -> dict:
        """Airspeeds of maximum endurance (least power) and maximum range (least
        energy per distance) in level flight, still air, at take-off mass. [m/s]"""
        from planner.power.speeds import best_speeds

        ac = self.aircraft
        if ac.is_multirotor:
            v_min = 0.5
        else:
            fw = ac.fixed_wing
            v_min = fw.stall_speed_ms or 0.5 * fw.cruise_airspeed_ms
        v_max = ac.max_airspeed_ms

        def power(v):
            return ac.battery_power(v, 0.0, air_density, mass)

        b = best_speeds(power, v_min, v_max)
        return {"max_endurance_airspeed_ms": float(b.max_endurance),
                "max_endurance_power_w": float(power(b.max_endurance)),
                "max_range_airspeed_ms": float(b.max_range),
                "max_range_power_w": float(power(b.max_range))}

    def _circuit(self, table, power, temp, p_hold: float, step_s: float = 1.0,
                 extend_s: float = 7200.0) -> dict:
        """Equivalent-circuit (and thermal) pack model along the mission.

        The mission's power profile is run at ``step_s`` through the coupled
        circuit and thermal model from a full pack at the air temperature
        (25 °C where none is given), then continued at the hold power until
        the loaded cell voltage reaches ``cell_voltage_empty_v``: the charge
        drawn by then is the charge the pack can really give at this load and
        temperature.
        """
        from planner.battery.circuit import CircuitParameters, simulate
        from planner.battery.thermal import ThermalParameters

        pack = self.pack
        params = CircuitParameters.from_pack(pack)
        t_pack = 25.0 if temp is None else float(temp)
        where = pack.path or pack.name
        thermal = (ThermalParameters.from_mapping(pack.thermal, where).with_air(t_pack)
                   if pack.thermal is not None else t_pack)
        total = float(table.end_time_s[-1]) if len(table) else 0.0
        t_m = np.union1d(np.arange(0.0, total, step_s), table.start_time_s)
        t_x = total + np.arange(0.0, extend_s, 5.0 * step_s)
        t = np.concatenate((t_m, t_x))
        leg = np.clip(np.searchsorted(table.end_time_s, t, side="right"), 0, len(table) - 1)
        p = np.where(t < total, power[leg], p_hold)
        reasons = []
        try:
            res = simulate(params, t, power_w=p, temperature_c=thermal,
                           v_cutoff_cell=pack.cell_voltage_empty_v)
        except ModelError as exc:  # the coupled thermal model left its range
            reasons.append(f"pack temperature out of range: {exc}")
            res = simulate(params, t, power_w=p, temperature_c=np.clip(t_pack, -20.0, 60.0),
                           v_cutoff_cell=pack.cell_voltage_empty_v)
        cells = pack.cells_series
        in_mission = t < total
        if not in_mission.any():
            in_mission[0] = True
        v_cut = cells * pack.cell_voltage_empty_v
        sag = res.voltage_v[in_mission] - v_cut
        k = int(np.argmin(sag))
        worst_leg = int(leg[in_mission][k])
        origin = table.origin
        if res.cutoff_time_s is not None and res.cutoff_time_s <= total:
            i = int(np.clip(np.searchsorted(table.end_time_s, res.cutoff_time_s), 0,
                            len(table) - 1))
            reasons.append(f"{origin[i] or f'leg {i + 1}'}: loaded voltage reaches the cut-off "
                           f"{pack.cell_voltage_empty_v:g} V/cell ({v_cut:.1f} V) at "
                           f"t = {res.cutoff_time_s:.0f} s (pack at {t_pack:.0f} °C)")
        if res.undeliverable_time_s is not None and res.undeliverable_time_s <= total:
            i = int(np.clip(np.searchsorted(table.end_time_s, res.undeliverable_time_s), 0,
                            len(table) - 1))
            reasons.append(f"{origin[i] or f'leg {i + 1}'}: the pack cannot deliver "
                           f"{power[i]:.0f} W at {t_pack:.0f} °C (voltage collapses)")
        usable = (res.cutoff_charge_as if res.cutoff_charge_as is not None
                  else float(res.charge_as[-1]))
        # loaded voltage at the end of every leg
        idx = np.clip(np.searchsorted(t, table.end_time_s, side="left") - 1, 0, len(t) - 1)
        leg_v = res.voltage_v[idx]
        return {
            "model": "equivalent circuit" + (" + thermal" if pack.thermal else ""),
            "pack_temperature_c": t_pack,
            "min_voltage_v": float(res.voltage_v[in_mission].min()),
            "voltage_margin_v": float(sag[k]),
            "worst_leg": worst_leg + 1,
            "worst_leg_origin": origin[worst_leg] or f"leg {worst_leg + 1}",
            "cutoff_time_s": res.cutoff_time_s,
            "charge_to_cutoff_mah": usable / AS_PER_MAH,
            "charge_used_mah": float(res.charge_as[in_mission][-1]) / AS_PER_MAH,
            "max_temperature_c": float(res.temperature_c[in_mission].max()),
            "reasons": reasons, "_usable_as": usable, "_leg_voltage_v": leg_v,
        }

    def _return_home(self, table, power, s_start, s_end, mass, env, temp, limit, scale):
        """Return-home margin at points along every leg; the point of no return."""
        n = len(table)
        if n == 0:
            return np.zeros(0), None, float(limit)
        ac, model = self.aircraft, self.pack.model
        pts = prof.return_home_points(table, ac, env, temp)
        leg_of, time, dist = pts["leg"], pts["time_s"], pts["distance_m"]
        stress = s_start[leg_of] + pts["frac"] * (s_end - s_start)[leg_of]
        p_back = ac.battery_power(*pts["back"][:3], mass, load_factor=pts["back"][3])
        p_down = ac.battery_power(*pts["down"][:3], mass, load_factor=pts["down"][3])
        t_back, t_down = pts["t_back"], pts["t_down"]
        s_rtl = (t_back * integral.stress_rate(p_back, model.delta, model.epsilon)
                 + t_down * integral.stress_rate(p_down, model.delta, model.epsilon))
        charge = scale * integral.charge_from_stress(stress + s_rtl, model.beta)
        margin = np.where(np.isfinite(charge), limit - charge, -np.inf)
        # the mission's own end is judged by the landing reserve, not by a return from it
        margin[-1] = limit - scale * integral.charge_from_stress(stress[-1], model.beta)
        per_leg = margin.reshape(n, prof.RTL_POINTS_PER_LEG).min(axis=1)
        bad = np.flatnonzero(margin[:-1] < 0)
        pnr = None
        if bad.size:
            j = int(bad[0])
            i = int(leg_of[j])
            pnr = {"time_s": float(time[j]), "leg": i + 1,
                   "leg_origin": table.origin[i] or f"leg {i + 1}",
                   "east_m": float(pts["east_m"][j]), "north_m": float(pts["north_m"][j]),
                   "altitude_m": float(pts["altitude_m"][j]),
                   "distance_home_m": float(dist[j]),
                   "rtl_margin_mah": (float(margin[j]) / AS_PER_MAH if np.isfinite(margin[j])
                                      else None)}
        finite = margin[np.isfinite(margin)]
        rtl_min = float(finite.min()) if finite.size else float("-inf")
        return per_leg, pnr, rtl_min


def _series(table, power, s_start, s_end, model, scale, cap, points=12):
    """Power and remaining charge sampled inside every leg (for plots)."""
    f = np.linspace(0.0, 1.0, points)
    t = (table.start_time_s[:, None] + f * table.duration_s[:, None]).ravel()
    s = (s_start[:, None] + f * (s_end - s_start)[:, None]).ravel()
    p = np.repeat(power, points)
    remaining = 1.0 - scale * integral.charge_from_stress(s, model.beta) / cap
    return {"time_s": t, "power_w": p, "remaining_fraction": remaining,
            "leg": np.repeat(np.arange(len(table)), points)}
