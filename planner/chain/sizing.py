r"""Mission sizing: endurance against battery mass, range against payload, and sorties.

Three questions a UAV operator asks before buying packs or planning a long job:

* **How much battery?** :func:`endurance_sweep` — hover (multirotor) or loiter
  (fixed-wing) time to the landing reserve against battery mass, for a chemistry's
  pack-level specific energy (capacity = mass × specific energy / nominal voltage),
  with the mass loop closed. A heavier pack stores more charge but needs more power
  to lift, so the endurance has an interior maximum; the optimum battery mass
  fraction is reported.
* **How far with this payload?** :func:`range_sweep` — still-air range of level
  flight from full to the reserve (at the cruise speed and at the best-range speed)
  against payload, for a given pack.
* **How many sorties?** :func:`plan_sorties` — when no single pack flies the mission,
  split the leg list into sorties that each fly home → start point → legs → home
  and pass :meth:`planner.chain.mission_chain.MissionChain.run` with the reserves.

All three use the same models as ``check``: the aircraft's battery power
(:meth:`planner.parameters.Aircraft.battery_power`, :func:`planner.chain.kinematics.hold_power`)
and the integral capacity model (:func:`planner.physics.battery.integral.time_to_charge`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar

from planner.chain import kinematics as prof
from planner.physics.battery import integral
from planner.chain.mission_chain import MissionChain
from planner.chain.result import MissionResult
from planner.errors import InputError
from planner.physics.atmosphere import G
from planner.physics.mission import Environment, Leg, Mission
from planner.parameters import Aircraft, BatteryPack, IntegralModel
from planner.physics.units import AS_PER_MAH

__all__ = ["CHEMISTRIES", "EnduranceSweep", "RangeSweep", "Sortie", "SortiePlan", "SplitPoint",
           "endurance_sweep", "plan_long_mission", "plan_sorties", "range_sweep",
           "sortie_mission"]

#: Pack-level defaults per chemistry: specific energy [Wh/kg] and nominal cell voltage
#: [V]. Typical values (assumed, not from one datasheet): LiPo hobby/UAV packs
#: 140–180 Wh/kg at 3.7 V; 21700 Li-ion packs 200–250 Wh/kg at 3.6 V.
CHEMISTRIES = {"lipo": {"specific_energy_wh_per_kg": 150.0, "cell_voltage_v": 3.7},
               "liion": {"specific_energy_wh_per_kg": 220.0, "cell_voltage_v": 3.6}}



# --------------------------------------------------------------------------- sweeps

def _site_density(aircraft, environment, altitude_m, temperature_c):
    env = environment or Environment()
    temp = temperature_c if temperature_c is not None else env.temperature_c
    rho = float(prof.air_density_at(env.site_altitude_m + altitude_m, env, temp))
    return env, temp, rho


def _constraints(aircraft: Aircraft, mass, min_thrust_to_weight):
    """(feasible, thrust-to-weight, reasons) for take-off masses."""
    mass = np.asarray(mass, float)
    ok = np.ones(mass.shape, bool)
    tw = np.full(mass.shape, np.nan)
    if aircraft.max_takeoff_mass_kg is not None:
        ok &= mass <= aircraft.max_takeoff_mass_kg
    if aircraft.is_multirotor and aircraft.multirotor.max_thrust_n is not None:
        tw = aircraft.multirotor.max_thrust_n / (mass * G)
        ok &= tw >= min_thrust_to_weight
    return ok, tw


@dataclass
class EnduranceSweep:
    """Hold endurance against battery mass (one array element per battery mass).

    Attributes
    ----------
    battery_mass_kg, takeoff_mass_kg : ndarray
        [kg]
    capacity_mah : ndarray
        From the specific energy. [mAh]
    hold_power_w : ndarray
        Hover (multirotor) or loiter (fixed-wing) battery power. [W]
    endurance_s : ndarray
        Hold time from full to the landing reserve. [s]
    feasible : ndarray of bool
        Within the maximum take-off mass and the minimum thrust-to-weight.
    optimum : dict
        ``battery_mass_kg``, ``mass_fraction`` (battery over take-off mass),
        ``endurance_s`` of the unconstrained maximum, and ``constrained_*`` of the best
        feasible battery mass (None when none is feasible).
    """

    aircraft: str
    hold: str
    specific_energy_wh_per_kg: float
    cells_series: int
    cell_voltage_v: float
    payload_kg: float
    reserve_fraction: float
    model: IntegralModel | None
    battery_mass_kg: np.ndarray
    takeoff_mass_kg: np.ndarray
    capacity_mah: np.ndarray
    hold_power_w: np.ndarray
    endurance_s: np.ndarray
    feasible: np.ndarray
    thrust_to_weight: np.ndarray
    optimum: dict[str, Any]
    notes: list[str] = field(default_factory=list)

    def to_frame(self) -> pd.DataFrame:
        """One row per swept battery mass: masses [kg], mass fraction, capacity [mAh], hold
        power [W], endurance [s, min] and whether the row is within the aircraft's limits."""
        return pd.DataFrame({
            "battery_mass_kg": self.battery_mass_kg, "takeoff_mass_kg": self.takeoff_mass_kg,
            "mass_fraction": self.battery_mass_kg / self.takeoff_mass_kg,
            "capacity_mah": self.capacity_mah, "hold_power_w": self.hold_power_w,
            "endurance_s": self.endurance_s, "endurance_min": self.endurance_s / 60.0,
            "thrust_to_weight": self.thrust_to_weight, "feasible": self.feasible})


def endurance_sweep(aircraft: Aircraft, battery_mass_kg, *, specific_energy_wh_per_kg: float,
                    cells_series: int, cell_voltage_v: float = 3.7,
                    model: IntegralModel | None = None, usable_fraction: float = 1.0,
                    payload_kg: float = 0.0, reserve: float = 0.2,
                    environment: Environment | None = None, altitude_m: float = 0.0,
                    temperature_c: float | None = None,
                    min_thrust_to_weight: float = 1.5) -> EnduranceSweep:
    r"""
    Hover or loiter endurance against battery mass, mass loop closed.

    Parameters
    ----------
    aircraft : Aircraft
    battery_mass_kg : array_like
        Battery masses to evaluate, > 0. [kg]
    specific_energy_wh_per_kg : float
        Pack-level specific energy of the chemistry. [Wh/kg]
    cells_series : int
        Cells in series (sets the voltage and the literature model). [unitless]
    cell_voltage_v : float, default 3.7
        Nominal cell voltage. [V]
    model : IntegralModel, optional
        Integral capacity model; None = the literature start values δ₀(N), ε₀(N),
        β = 0.9648 with δ rescaled to each capacity, as a pack file without a fitted
        model gets (:meth:`planner.parameters.IntegralModel.from_literature`).
    usable_fraction : float, default 1
    payload_kg : float, default 0
    reserve : float, default 0.2
        Landing reserve as a fraction of nominal capacity. [unitless]
    environment : Environment, optional
        Site and weather (wind: hover in wind costs forward-flight power).
    altitude_m : float, default 0
        Hold altitude above the site. [m]
    temperature_c : float, optional
        [°C]
    min_thrust_to_weight : float, default 1.5

    Returns
    -------
    EnduranceSweep

    Notes
    -----
    .. math::

        C = \frac{m_b\, e}{N V_{cell}}, \quad
        m = m_0 + m_b, \quad
        t = \delta\, P_{hold}(m)^{\varepsilon}\,
            \left(\frac{(f_u - r)\, C}{s}\right)^{\beta}

    with :math:`m_0` the empty mass plus payload, :math:`e` the specific energy,
    :math:`f_u` the usable fraction, :math:`r` the reserve and :math:`s` the model's
    charge scale (:func:`planner.physics.battery.integral.time_to_charge` from zero stress).
    The maximum is refined by bounded Brent minimisation between the grid neighbours.
    """
    m_b = np.asarray(battery_mass_kg, float)
    if m_b.ndim != 1 or m_b.size < 3 or np.any(~(m_b > 0)):
        raise InputError("battery masses must be at least 3 values > 0 kg")
    if not specific_energy_wh_per_kg > 0 or not cell_voltage_v > 0:
        raise InputError("specific energy and cell voltage must be > 0")
    if not 0.0 <= reserve < usable_fraction:
        raise InputError(f"reserve must be in [0, usable fraction {usable_fraction:g}), "
                         f"got {reserve}")
    env = environment or Environment()
    notes = []
    if model is None:
        notes.append(f"battery model: literature δ₀({cells_series}), ε₀({cells_series}), "
                     f"β = {integral.LITERATURE_BETA}, δ rescaled to each capacity as for a "
                     "pack file without a fitted model")
    m0 = aircraft.empty_mass_kg + payload_kg
    volts = cells_series * cell_voltage_v
    # a hold of zero length: the chain's margin as hold time is then the endurance from
    # full to the reserve, at the hold power of each take-off mass
    hold = Mission("hold", [Leg("hover", (0.0, 0.0), (0.0, 0.0), altitude_m, altitude_m,
                                duration_s=0.0, origin="hold")], env, payload_kg=payload_kg)

    def evaluate(mb):
        mb = np.atleast_1d(np.asarray(mb, float))
        cap_mah = mb * specific_energy_wh_per_kg / volts * 1000.0
        packs = [BatteryPack(name=f"{m:.4g} kg", cells_series=int(cells_series),
                             capacity_mah=float(c), mass_kg=float(m),
                             usable_fraction=float(usable_fraction), model=model)
                 for m, c in zip(mb, cap_mah)]
        r = MissionChain(aircraft, packs, battery_model="integral", reserve=reserve,
                         temperature_c=temperature_c).run(hold, env, detail=False)
        return cap_mah * AS_PER_MAH, r.takeoff_mass_kg, r.hold_power_w, r.margin_time_s

    cap_as, mass, p, t = evaluate(m_b)
    ok, tw = _constraints(aircraft, mass, min_thrust_to_weight)

    def best(mask):
        if not mask.any():
            return None
        tt = np.where(mask, t, -np.inf)
        i = int(np.argmax(tt))
        lo = m_b[max(i - 1, 0)]
        hi = m_b[min(i + 1, m_b.size - 1)]
        x, tx = float(m_b[i]), float(t[i])
        if hi > lo:
            res = minimize_scalar(lambda v: -float(evaluate(v)[3][0]), bounds=(lo, hi),
                                  method="bounded", options={"xatol": 1e-7 * hi})
            feasible_here = bool(_constraints(aircraft, m0 + res.x, min_thrust_to_weight)[0])
            if res.success and -res.fun >= tx and (feasible_here or mask.all()):
                x, tx = float(res.x), float(-res.fun)
        return {"battery_mass_kg": x, "mass_fraction": x / (m0 + x), "endurance_s": tx,
                "at_grid_edge": i in (0, m_b.size - 1)}

    free = best(np.ones(m_b.shape, bool))
    held = best(ok)
    optimum = dict(free)
    optimum.update({f"constrained_{k}": (None if held is None else v)
                    for k, v in (held or free).items()})
    if free["at_grid_edge"]:
        notes.append("the endurance maximum lies at the edge of the swept masses: "
                     "widen the range")
    if aircraft.is_multirotor and aircraft.multirotor.max_thrust_n is None:
        notes.append("thrust-to-weight not checked: the aircraft file gives no "
                     "multirotor.max_thrust_n")
    return EnduranceSweep(
        aircraft=aircraft.name, hold="hover" if aircraft.is_multirotor else "loiter",
        specific_energy_wh_per_kg=float(specific_energy_wh_per_kg),
        cells_series=int(cells_series), cell_voltage_v=float(cell_voltage_v),
        payload_kg=float(payload_kg), reserve_fraction=float(reserve), model=model,
        battery_mass_kg=m_b, takeoff_mass_kg=mass, capacity_mah=cap_as / AS_PER_MAH,
        hold_power_w=p, endurance_s=t, feasible=ok, thrust_to_weight=tw, optimum=optimum,
        notes=notes)


@dataclass
class RangeSweep:
    """Still-air range and endurance against payload for one pack.

    Attributes
    ----------
    payload_kg, takeoff_mass_kg : ndarray
        [kg]
    cruise_speed_ms : float
        The aircraft's cruise speed (air = ground in still air). [m/s]
    cruise_power_w, range_m, cruise_endurance_s : ndarray
        Level flight at the cruise speed from full to the reserve. [W], [m], [s]
    best_range_speed_ms, best_range_m : ndarray
        The same at the airspeed of minimum energy per distance. [m/s], [m]
    hold_endurance_s : ndarray
        Hover or loiter time to the reserve. [s]
    feasible : ndarray of bool
        Within the maximum take-off mass and the minimum thrust-to-weight.
    """

    aircraft: str
    pack: str
    reserve_fraction: float
    cruise_speed_ms: float
    payload_kg: np.ndarray
    takeoff_mass_kg: np.ndarray
    cruise_power_w: np.ndarray
    cruise_endurance_s: np.ndarray
    range_m: np.ndarray
    best_range_speed_ms: np.ndarray
    best_range_m: np.ndarray
    hold_endurance_s: np.ndarray
    feasible: np.ndarray
    notes: list[str] = field(default_factory=list)

    def to_frame(self) -> pd.DataFrame:
        """One row per swept payload: masses [kg], cruise power [W] and endurance [s], range
        [km], best-range speed [m/s] and range [km], hold endurance [s] and whether the row
        is within the aircraft's limits."""
        return pd.DataFrame({
            "payload_kg": self.payload_kg, "takeoff_mass_kg": self.takeoff_mass_kg,
            "cruise_power_w": self.cruise_power_w, "cruise_endurance_s": self.cruise_endurance_s,
            "range_km": self.range_m / 1000.0, "best_range_speed_ms": self.best_range_speed_ms,
            "best_range_km": self.best_range_m / 1000.0,
            "radius_of_action_km": self.best_range_m / 2000.0,
            "hold_endurance_s": self.hold_endurance_s, "feasible": self.feasible})


def range_sweep(aircraft: Aircraft, pack: BatteryPack, payload_kg, *, reserve: float = 0.2,
                environment: Environment | None = None, altitude_m: float = 50.0,
                temperature_c: float | None = None,
                min_thrust_to_weight: float = 1.5) -> RangeSweep:
    r"""
    Still-air range of level flight against payload, mass loop closed.

    Parameters
    ----------
    aircraft : Aircraft
    pack : BatteryPack
    payload_kg : array_like
        Payloads, ≥ 0. [kg]
    reserve : float, default 0.2
    environment : Environment, optional
        Site (altitude, temperature, pressure); its wind is ignored: the range is
        for still air.
    altitude_m : float, default 50
        Cruise altitude above the site. [m]
    temperature_c : float, optional
    min_thrust_to_weight : float, default 1.5

    Returns
    -------
    RangeSweep

    Notes
    -----
    :math:`R = V\, t(P(V))` with :math:`t` the time at constant power from full to
    the reserve (:func:`planner.physics.battery.integral.time_to_charge`), at the cruise speed
    and at the best-range airspeed :math:`\arg\min_V P(V)/V`
    (:func:`planner.physics.power.speeds.best_speeds`). Climb and descent are not included;
    the radius of action (out and back) is half the range.
    """
    from planner.physics.power.speeds import best_speeds

    pl = np.asarray(payload_kg, float)
    if pl.ndim != 1 or pl.size < 2 or np.any(~(pl >= 0)):
        raise InputError("payloads must be at least 2 values >= 0 kg")
    if not 0.0 <= reserve < pack.usable_fraction:
        raise InputError(f"reserve must be in [0, {pack.usable_fraction:g}), got {reserve}")
    env = replace(environment or Environment(), wind_speed_ms=0.0)
    env, temp, rho = _site_density(aircraft, env, altitude_m, temperature_c)
    model = pack.model
    scale = model.charge_scale(temp)
    limit = (pack.usable_as - reserve * pack.capacity_as) / scale
    mass = aircraft.empty_mass_kg + pack.total_mass_kg + pl
    v = aircraft.cruise_speed_ms

    def t_at(power):
        return np.asarray(integral.time_to_charge(0.0, power, limit, model.delta,
                                                  model.epsilon, model.beta), float)

    p_cruise = np.asarray(aircraft.battery_power(v, 0.0, rho, mass), float)
    t_cruise = t_at(p_cruise)
    if aircraft.is_multirotor:
        v_lo = 1.0
    else:
        fw = aircraft.fixed_wing
        v_lo = fw.stall_speed_ms or 0.5 * fw.cruise_airspeed_ms
    v_hi = aircraft.max_airspeed_ms
    v_best = np.array([best_speeds(lambda s, m=m: aircraft.battery_power(s, 0.0, rho, m),
                                   v_lo, v_hi).max_range for m in mass])
    p_best = np.asarray(aircraft.battery_power(v_best, 0.0, rho, mass), float)
    p_hold = np.asarray(prof.hold_power(aircraft, mass, rho, 0.0), float)
    ok, _ = _constraints(aircraft, mass, min_thrust_to_weight)
    notes = [("range in still air, level flight only (no climb or descent); radius of "
              "action = half the range")]
    if model.literature:
        notes.append(f"battery model: literature δ₀({pack.cells_series}), "
                     f"ε₀({pack.cells_series}), β = {model.beta} (the pack has no fitted "
                     "model)")
    return RangeSweep(
        aircraft=aircraft.name, pack=pack.name, reserve_fraction=float(reserve),
        cruise_speed_ms=float(v), payload_kg=pl, takeoff_mass_kg=mass,
        cruise_power_w=p_cruise, cruise_endurance_s=t_cruise, range_m=v * t_cruise,
        best_range_speed_ms=v_best, best_range_m=v_best * t_at(p_best),
        hold_endurance_s=t_at(p_hold), feasible=ok, notes=notes)


# --------------------------------------------------------------------------- sorties

#: Horizontal distance below which a transit leg is left out. [m]
MIN_TRANSIT_M = 0.5
#: Altitude below which a climb or descent at home is left out. [m]
MIN_ALTITUDE_M = 0.01
#: Bisection steps when a sortie ends inside a leg (leg fraction to 2⁻²⁰, under a
#: metre on a 1 km leg).
BISECTION_STEPS = 20
#: Least charge a sortie keeps above its landing and return-home reserves whatever the
#: margin policy (:func:`sortie_margin`): the split is found by bisection to the limit,
#: and the sortie's mission file (positions rounded to the file's precision, e.g. 1e-8°
#: in a .waypoints file) must still pass the check. [mAh]
SPLIT_MARGIN_MAH = 1.0
#: One-sided confidence of the sortie margin policy (:func:`sortie_margin`). [unitless]
SORTIE_CONFIDENCE = 0.95
#: Sortie margin policy of a pack without a fitted model covariance: this share of the
#: sortie's charge drawn. A policy value, not a measured spread: the literature integral
#: model's final error on the real logs (+2.8 … +11.2 %, docs/results.md, "Battery level
#: on real logs") lies on the safe side, and 5 % is half its largest size. [unitless]
SORTIE_MARGIN_FRACTION = 0.05


def sortie_margin(result: MissionResult, pack: BatteryPack) -> tuple[float, str]:
    r"""The charge a sortie must keep above its reserves, and the policy's name. [mAh]

    With the pack model's covariance :math:`\Sigma` of (δ, ε, β) (``fit-battery``): the
    one-sided :data:`SORTIE_CONFIDENCE` quantile of the charge drawn, :math:`z\,\sigma_C`,
    :math:`\sigma_C` by the delta method through the integral model ([UAV23] eq. 14):
    :math:`C = S^{1/\beta}`, :math:`S = \sum_j t_j/(\delta P_j^{\varepsilon})`, so

    .. math:: \frac{\partial \ln C}{\partial \delta} = -\frac{1}{\beta\delta},\quad
              \frac{\partial \ln C}{\partial \varepsilon} =
              -\frac{1}{\beta}\frac{\sum_j t_j P_j^{-\varepsilon}\ln P_j}
                                     {\sum_j t_j P_j^{-\varepsilon}},\quad
              \frac{\partial \ln C}{\partial \beta} = -\frac{\ln S}{\beta^2},

    :math:`\sigma_C = C\sqrt{g^T \Sigma g}`. Without a covariance:
    :data:`SORTIE_MARGIN_FRACTION` of the charge drawn. Never less than
    :data:`SPLIT_MARGIN_MAH`.
    """
    from scipy.special import ndtri

    used = float(result.charge_used_mah)
    m = pack.model
    z = float(ndtri(SORTIE_CONFIDENCE))
    if m.covariance is None:
        need = SORTIE_MARGIN_FRACTION * used
        policy = (f"{100 * SORTIE_MARGIN_FRACTION:g} % of the charge drawn (the pack file "
                  "has no model covariance: a policy value, not a measured spread)")
    else:
        legs = result.legs
        t = np.asarray(legs.duration_s, float)
        p = np.asarray(legs.power_w, float)
        ok = (t > 0) & np.isfinite(p) & (p > 0)
        t, p = t[ok], p[ok]
        w = t * p ** (-m.epsilon)
        stress = float(np.sum(w)) / m.delta
        g = np.array([-1.0 / (m.beta * m.delta),
                      -float(np.sum(w * np.log(p)) / np.sum(w)) / m.beta,
                      -math.log(stress) / m.beta ** 2])
        sd = used * math.sqrt(max(float(g @ np.asarray(m.covariance, float) @ g), 0.0))
        need = z * sd
        policy = (f"{z:.3f} σ of the charge drawn ({100 * SORTIE_CONFIDENCE:g} % one-sided), "
                  "σ from the pack model's covariance")
    return max(need, SPLIT_MARGIN_MAH), policy


@dataclass(frozen=True)
class SplitPoint:
    """Where one sortie ends and the next begins: a point of the original route.

    Attributes
    ----------
    position : float
        Leg index plus the fraction flown along it (0 = start of the first leg).
    leg : int
        0-based index of the leg in the original mission.
    fraction : float
        Share of that leg flown before the swap. [unitless]
    time_s : float
        Mission time of the point in the original (single-flight) timeline. [s]
    east_m, north_m, altitude_m : float
        [m]
    origin : str
        The leg's origin in the mission file.
    """

    position: float
    leg: int
    fraction: float
    time_s: float
    east_m: float
    north_m: float
    altitude_m: float
    origin: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the leg (1-based) and its origin, the fraction of the leg flown, the
        time [s] and the position east and north of home [m]."""
        return {"leg": self.leg + 1, "leg_origin": self.origin,
                "fraction": round(self.fraction, 6), "time_s": round(self.time_s, 3),
                "east_m": round(self.east_m, 3), "north_m": round(self.north_m, 3),
                "altitude_m": round(self.altitude_m, 3)}


@dataclass
class Sortie:
    """One flight of a split mission."""

    number: int
    start: float
    end: float
    mission: Mission
    result: MissionResult


@dataclass
class SortiePlan:
    r"""A long mission split into sorties for one pack.

    Attributes
    ----------
    pack : BatteryPack
    sorties : list of Sortie
        Each passes ``check`` (GO) on its own.
    splits : list of SplitPoint
        Where to land and swap packs (one fewer than the sorties).
    lower_bound : int
        :math:`\\lceil S_{mission} / S_{limit} \rceil`: no plan with fewer sorties can
        exist, whatever the splits (see :func:`sortie_lower_bound`).
    """

    pack: BatteryPack
    sorties: list[Sortie]
    splits: list[SplitPoint]
    lower_bound: int
    notes: list[str] = field(default_factory=list)

    @property
    def count(self) -> int:
        """Number of sorties."""
        return len(self.sorties)

    @property
    def minimal(self) -> bool:
        """True when the count equals the lower bound: provably the fewest sorties."""
        return self.count == self.lower_bound

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: the pack and its mass [kg], the count, its lower bound and whether it
        is the fewest, the split points, each sortie's legs, duration [s], charge drawn,
        margin and required margin [mAh], and the notes."""
        return {"pack": self.pack.name + (f" x{self.pack.count}" if self.pack.count > 1
                                          else ""),
                "pack_mass_kg": round(self.pack.total_mass_kg, 6),
                "sorties": self.count, "lower_bound": self.lower_bound,
                "minimal": self.minimal,
                "splits": [s.to_dict() for s in self.splits],
                "flights": [{"sortie": s.number, "legs": len(s.mission.legs),
                             "duration_s": round(s.result.duration_s, 3),
                             "charge_used_mah": round(s.result.charge_used_mah, 3),
                             "margin_mah": round(s.result.margin_mah, 3),
                             "margin_required_mah": round(
                                 sortie_margin(s.result, self.pack)[0], 3)}
                            for s in self.sorties],
                "notes": list(self.notes)}


def _leg_part(leg: Leg, f0: float, f1: float, origin: str | None = None) -> Leg:
    """The part of ``leg`` between fractions ``f0`` and ``f1`` of it."""
    s, e = np.asarray(leg.start_en_m, float), np.asarray(leg.end_en_m, float)
    a0 = leg.start_alt_m + f0 * (leg.end_alt_m - leg.start_alt_m)
    a1 = leg.start_alt_m + f1 * (leg.end_alt_m - leg.start_alt_m)
    p0, p1 = s + f0 * (e - s), s + f1 * (e - s)
    changes = {"start_en_m": tuple(map(float, p0)), "end_en_m": tuple(map(float, p1)),
               "start_alt_m": float(a0), "end_alt_m": float(a1)}
    if leg.kind in ("hover", "loiter") and leg.duration_s is not None:
        changes["duration_s"] = float(leg.duration_s) * (f1 - f0)
    if origin is not None:
        changes["origin"] = origin
    return leg.with_(**changes)


def _point(legs: list[Leg], position: float):
    """(east, north, altitude) of a route position (leg index + fraction)."""
    n = len(legs)
    i = min(math.floor(position), n - 1)
    f = position - i
    leg = legs[i]
    s, e = np.asarray(leg.start_en_m, float), np.asarray(leg.end_en_m, float)
    p = s + f * (e - s)
    return float(p[0]), float(p[1]), float(leg.start_alt_m + f * (leg.end_alt_m
                                                                   - leg.start_alt_m))


def sortie_mission(mission: Mission, start: float, end: float, number: int = 1) -> Mission:
    """The sortie that flies the route from position ``start`` to ``end``.

    Positions are leg index + fraction along the leg (0 ≤ start < end ≤ n legs). A
    sortie that does not begin where the mission does climbs at home to the altitude
    of its start point and flies there straight (new transit legs, the aircraft's
    default speeds); one that does not end where the mission does flies straight home
    at the altitude of its end point and descends. The route's own legs in between
    are flown as planned; a leg cut at an interior point is flown in part (a hold
    for its share of the time).
    """
    legs = mission.legs
    n = len(legs)
    if not 0.0 <= start < end <= n:
        raise ValueError(f"sortie must satisfy 0 <= start < end <= {n}, got {start}, {end}")
    tag = f"sortie {number}"
    out: list[Leg] = []
    if start > 0:
        e, nn, h = _point(legs, start)
        if h > MIN_ALTITUDE_M:
            out.append(Leg("climb", (0.0, 0.0), (0.0, 0.0), 0.0, h,
                           origin=f"{tag}: climb at home"))
        if math.hypot(e, nn) > MIN_TRANSIT_M:
            out.append(Leg("cruise", (0.0, 0.0), (e, nn), h, h, origin=f"{tag}: transit out"))
    i0, i1 = math.floor(start), math.ceil(end) - 1
    for i in range(i0, i1 + 1):
        f0 = start - i if i == i0 else 0.0
        f1 = end - i if i == i1 else 1.0
        f0, f1 = max(f0, 0.0), min(f1, 1.0)
        if f1 <= f0:
            continue
        leg = legs[i]
        name = leg.origin or f"leg {i + 1}"
        out.append(leg if (f0, f1) == (0.0, 1.0) else _leg_part(
            leg, f0, f1, origin=f"{name} ({100 * f0:.0f}–{100 * f1:.0f} %)"))
    if end < n:
        e, nn, h = _point(legs, end)
        if math.hypot(e, nn) > MIN_TRANSIT_M:
            out.append(Leg("cruise", (e, nn), (0.0, 0.0), h, h, origin=f"{tag}: transit home"))
        if h > MIN_ALTITUDE_M:
            out.append(Leg("descend", (0.0, 0.0), (0.0, 0.0), h, 0.0, origin=f"{tag}: land"))
    return replace(mission, name=f"{mission.name} — {tag}", legs=out)


def sortie_lower_bound(charge_used_mah: float, limit_mah: float, beta: float) -> int:
    r"""
    Fewest sorties any split can need: :math:`\lceil (C_{used}/C_{limit})^\beta \rceil`.

    The integral model's stress :math:`S = \hat C^\beta` is additive over legs (and
    over the parts of a cut leg, flown at the same power), so the sorties' route
    stresses add up to the whole mission's; every sortie adds transit, and must keep
    its total stress at or below :math:`(C_{limit}/s)^\beta`. Hence
    :math:`n \ge S_{mission}/S_{limit} = (C_{used}/C_{limit})^\beta` (the charge
    scale :math:`s` cancels). :math:`C_{limit}` is the usable charge less the reserve, as
    the mission chain gives it (lowered by the circuit model's cut-off where the pack
    has one). [mAh]
    """
    if limit_mah <= 0:
        return 10**9
    return max(1, math.ceil((charge_used_mah / limit_mah) ** beta - 1e-12))


def plan_sorties(mission: Mission, aircraft: Aircraft, pack: BatteryPack,
                 environment: Environment | None = None, *, reserve: float = 0.2,
                 temperature_c: float | None = None, payload_kg: float | None = None,
                 max_sorties: int = 50) -> SortiePlan:
    """Split ``mission`` into the fewest sorties ``pack`` can fly, greedily.

    Each sortie is made as long as possible: every leg end after its start is tried
    (until the route alone would exceed the pack's charge budget), the furthest one
    whose sortie passes :meth:`planner.chain.mission_chain.MissionChain.run` is kept, and
    the sortie is then extended into the next leg by bisection on the fraction flown (a
    long cruise leg is cut at an interior point; :class:`_SortieSearch`). Greedy
    furthest-reach splitting gives the minimum number of sorties when a shorter piece of
    the route is never harder to fly than a longer piece containing it;
    :attr:`SortiePlan.lower_bound` gives a bound no split can beat, and
    :attr:`SortiePlan.minimal` says when it is reached.

    Raises
    ------
    InputError
        When the pack cannot fly even the start of some part of the route (its
        transit alone exceeds the reserve), or more than ``max_sorties`` are needed.
    """
    env = environment or mission.environment
    if payload_kg is not None:
        mission = replace(mission, payload_kg=float(payload_kg))
    n = len(mission.legs)
    if n == 0:
        raise InputError(f"{mission.source or mission.name}: the mission has no legs")
    # the legs as the chain flies them (bounded climbs, the return of a mission that
    # never comes home), so that route positions index the legs the chain judges
    mission, _ = prof.flyable_legs(mission, aircraft)
    mission, _ = prof.closed_mission(mission)
    n = len(mission.legs)
    search = _SortieSearch(mission, MissionChain(aircraft, pack, reserve=reserve,
                                                 temperature_c=temperature_c), env)
    sorties: list[Sortie] = []
    a = 0.0
    while a < n:
        k = len(sorties) + 1
        if k > max_sorties:
            raise InputError(f"more than {max_sorties} sorties needed with {pack.name}")
        b, result = search.longest(a, k)
        sorties.append(Sortie(k, a, b, sortie_mission(mission, a, b, k), result))
        a = b
    lb = sortie_lower_bound(search.whole.charge_used_mah, search.limit_mah, pack.model.beta)
    notes = ["margin policy: every sortie keeps above its landing and return-home "
             "reserves " + sortie_margin(sorties[0].result, pack)[1]
             + f", at least {SPLIT_MARGIN_MAH:g} mAh"]
    if len(sorties) > lb:
        notes.append(f"{len(sorties)} sorties; the charge bound allows {lb}: transit to "
                     "and from the split points costs the difference")
    return SortiePlan(pack=pack, sorties=sorties,
                      splits=[_split_point(mission, search.leg_times, s.end)
                              for s in sorties[:-1]], lower_bound=lb, notes=notes)


class _SortieSearch:
    """The furthest point of the route each sortie can reach (:func:`plan_sorties`).

    The whole mission is flown once by the chain: its integral-model stress per leg is
    additive, so the stress of a piece of the route is a sum, and a piece whose stress
    alone exceeds the pack's budget :math:`(C_{limit}/s)^\\beta` needs no check.
    """

    def __init__(self, mission: Mission, chain: MissionChain, env: Environment):
        self.mission, self.chain, self.env = mission, chain, env
        self.n = len(mission.legs)
        pack = chain.pack
        flown = chain.run(mission, env, detail=True)
        self.whole = flown.mission_result(0)
        # a mission leg is several rows of the table with a navigation model: the stress
        # and times at the end of each mission leg's last row
        leg_of = np.asarray(flown.table.leg_index)
        last = np.flatnonzero(np.append(leg_of[1:] != leg_of[:-1], True))
        self.cum = np.concatenate([[0.0], flown.detail["stress_end"][0][last]])
        end = np.asarray(flown.table.end_time_s)[last]
        self.leg_times = (np.concatenate([[0.0], end[:-1]]), np.diff(end, prepend=0.0))
        self.leg_stress = np.diff(self.cum)
        scale = float(np.asarray(pack.model.charge_scale(flown.environment.temperature_c)))
        self.limit_mah = self.whole.usable_mah - self.whole.reserve_mah
        self.s_lim = integral.stress_from_charge(
            max(self.limit_mah, 0.0) * AS_PER_MAH / scale, pack.model.beta)

    def route_stress(self, a: float, b: float) -> float:
        """Stress of the route between positions a and b (legs at constant power).
        [(A s)^β]"""
        def at(p):
            i = min(math.floor(p), self.n - 1)
            return self.cum[i] + (p - i) * self.leg_stress[i]
        return at(b) - at(a)

    def check(self, a: float, b: float, k: int) -> MissionResult:
        """The pre-flight check of sortie ``k`` from position ``a`` to ``b``."""
        return self.chain.check(sortie_mission(self.mission, a, b, k), self.env)

    def flies(self, r: MissionResult) -> bool:
        """GO with the margin of the policy (:func:`sortie_margin`) to spare on the
        landing and every return home."""
        need, _ = sortie_margin(r, self.chain.pack)
        return r.go and r.margin_mah >= need and r.rtl_min_margin_mah >= need

    def longest(self, a: float, k: int) -> tuple[float, MissionResult]:
        """The furthest end of sortie ``k`` from position ``a`` and its check: the last
        leg end that flies, then into the next leg by :data:`BISECTION_STEPS` bisection
        steps. Raises :class:`InputError` when no part of the route from ``a`` flies."""
        n = self.n
        best_b, best_r = None, None
        for j in range(math.floor(a) + 1, n + 1):
            if self.route_stress(a, j) > self.s_lim:
                break                      # the route alone already exceeds the budget
            r = self.check(a, j, k)
            if self.flies(r):
                best_b, best_r = float(j), r
        lo = best_b if best_b is not None else a
        if lo < n:
            hi = float(min(math.floor(lo), n - 1) + 1)
            for _ in range(BISECTION_STEPS):
                mid = 0.5 * (lo + hi)
                if mid <= a:
                    break
                r = self.check(a, mid, k)
                if self.flies(r):
                    lo, best_b, best_r = mid, mid, r
                else:
                    hi = mid
        if best_b is None or best_b <= a:
            e, nn, h = _point(self.mission.legs, a)
            raise InputError(f"{self.chain.pack.name} cannot fly any part of the route from "
                             f"{self.mission.legs[min(int(a), n - 1)].origin or 'leg'} "
                             f"({math.hypot(e, nn):.0f} m from home, {h:.0f} m up) and "
                             "back with the reserve")
        return best_b, best_r


def _split_point(mission: Mission, leg_times, pos: float) -> SplitPoint:
    """The point of the route at position ``pos`` (leg index + fraction), timed on the
    single-flight timeline of ``leg_times`` (each mission leg's start and duration in the
    check, [s])."""
    n = len(mission.legs)
    i = min(math.floor(pos), n - 1)
    f = pos - i
    e, nn, h = _point(mission.legs, pos)
    return SplitPoint(position=pos, leg=i, fraction=f,
                      time_s=float(leg_times[0][i] + f * leg_times[1][i]),
                      east_m=e, north_m=nn, altitude_m=h,
                      origin=mission.legs[i].origin or f"leg {i + 1}")


def plan_long_mission(mission: Mission, aircraft: Aircraft, packs: list[BatteryPack],
                      evaluation=None, environment: Environment | None = None, *,
                      reserve: float = 0.2, temperature_c: float | None = None,
                      payload_kg: float | None = None, candidates: int = 6) -> SortiePlan:
    """The fewest sorties over a catalog (ties: the lighter pack), with the split points.

    Packs that break a pack-level constraint (cell count, take-off mass,
    thrust-to-weight, deliverable power, C rating) are left out. The rest are ordered
    by their sortie lower bound, then mass, and split greedily
    (:func:`plan_sorties`) until no remaining pack's lower bound can beat the best
    plan found (at most ``candidates`` splits are run).

    Parameters
    ----------
    evaluation : PackEvaluation, optional
        :func:`planner.chain.selection.evaluate_packs` of the same mission, catalog and
        options (computed when not given).
    """
    from planner.chain.selection import CONSTRAINTS, evaluate_packs

    if evaluation is None:
        evaluation = evaluate_packs(mission, aircraft, packs, environment, reserve=reserve,
                                    temperature_c=temperature_c, payload_kg=payload_kg)
    e = evaluation
    blocking = [CONSTRAINTS.index(c) for c in ("mission", "cells", "takeoff_mass", "thrust",
                                               "power", "c_rating")]
    usable = ~e.violated[:, blocking].any(axis=1)
    if not usable.any():
        raise InputError("no pack of the catalog meets the pack constraints (cells, "
                         "take-off mass, thrust, power, C rating): splitting cannot help")
    idx = np.flatnonzero(usable)
    bounds = np.array([sortie_lower_bound(e.charge_used_mah[i],
                                          e.usable_mah[i] - e.reserve_mah[i],
                                          e.packs[i].model.beta) for i in idx])
    order = idx[np.lexsort((e.pack_mass_kg[idx], bounds))]
    bound_of = dict(zip(idx.tolist(), bounds.tolist()))
    best: SortiePlan | None = None
    errors = []
    for tried, i in enumerate(order):
        if tried >= candidates or (best is not None and bound_of[int(i)] > best.count):
            break
        try:
            plan = plan_sorties(mission, aircraft, e.packs[i], environment, reserve=reserve,
                                temperature_c=temperature_c, payload_kg=payload_kg)
        except InputError as exc:
            errors.append(str(exc))
            continue
        if best is None or plan.count < best.count or (
                plan.count == best.count
                and plan.pack.total_mass_kg < best.pack.total_mass_kg):
            best = plan
    if best is None:
        raise InputError("no pack can fly the mission even in sorties: " + "; ".join(errors))
    return best
