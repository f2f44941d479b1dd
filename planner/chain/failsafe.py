r"""Battery failsafe parameters of ArduPilot and PX4, derived from the mission.

The autopilot's battery failsafe fires on a fixed threshold; the right threshold is the
charge the aircraft needs, from the worst point of *this* mission in *this* wind, to fly
home and land with the landing reserve. :func:`failsafe_parameters` reads it from a
:class:`~planner.chain.mission_chain.ChainResult` (one pack, run with its per-leg
detail), which holds the return-home reserve at
:data:`~planner.chain.kinematics.RTL_POINTS_PER_LEG` points of every leg.

The return from a point
-----------------------
From every return-home point the chain flies straight home at the cruise speed, at the
point's altitude, in the mission's wind, then descends over home (:func:`planner.chain.kinematics.
return_home_points`). The charge of that return is taken as the larger of

* the integral capacity model's ([UAV23] eq. 14): :math:`C(S_p + S_r) - C(S_p)`, with
  :math:`S_p` the stress drawn by the point and :math:`S_r` the return's stress;
* the charge at the power of each return segment through the pack's resistance at the
  state of charge of a landing with exactly the reserve (the lowest voltage the return can
  see): :math:`Q = \sum_k I_k t_k`, :math:`I_k` from :math:`P_k = (V_{oc} - I_k R) I_k`
  ([HESS] eq. 2, :func:`planner.physics.battery.elements.loaded_current`), :math:`V_{oc}` from the
  open-circuit curve (:func:`planner.physics.battery.ocv.lipo_ocv`).

The second is what a current sensor integrates when the voltage sags late in the flight;
taking the larger keeps the threshold on the safe side of either model. The worst point
is the one whose return needs the most charge.

Thresholds
----------
The autopilot counts the charge drawn against its capacity parameter, so a threshold on
the *remaining* charge (capacity − drawn) that lands with the reserve is

.. math:: Q_{low} = Q_{reserve} + Q_{unusable} + \max_p Q_{return}(p)

(RTL at this level), and the critical level (land where it is) holds the descent from the
highest point of the mission instead of the return. ``Q_unusable`` = nominal − usable
(the pack's ``usable_fraction`` and the circuit model's cut-off).

Names, units, ranges and action values are those the firmware documents:
ArduPilot ``libraries/AP_BattMonitor/AP_BattMonitor_Params.cpp`` (``BATT_CAPACITY``,
``BATT_LOW_MAH``, ``BATT_CRT_MAH`` in mAh with increment 50; ``BATT_LOW_VOLT``,
``BATT_CRT_VOLT`` in V with increment 0.1; ``BATT_FS_VOLTSRC`` 0 raw, 1 sag compensated;
``BATT_FS_LOW_ACT``/``BATT_FS_CRT_ACT`` Copter 1 Land, 2 RTL, Plane 1 RTL, 2 Land), PX4
``src/lib/battery/module.yaml`` and ``battery_params_common.c`` (``BAT1_CAPACITY`` mAh
[-1, 100000]; ``BAT1_N_CELLS``; ``BAT1_V_EMPTY``, ``BAT1_V_CHARGED`` per cell V;
``BAT1_R_INTERNAL`` per cell Ω [-1, 0.2]; ``BAT_LOW_THR`` [0.12, 0.4], ``BAT_CRIT_THR``
[0.05, 0.1], ``BAT_EMERGEN_THR`` [0.03, 0.07], fractions of the capacity) and
``src/modules/commander/commander_params.c`` (``COM_LOW_BAT_ACT`` 0 warning, 2 land,
3 return at critical, land at emergency).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from planner.physics.battery.elements import loaded_current, pack_resistance
from planner.physics.battery.ocv import lipo_ocv
from planner.errors import InputError
from planner.physics.units import AS_PER_MAH

__all__ = ["FIRMWARES", "FailsafeParameter", "FailsafePlan", "failsafe_parameters",
           "pack_resistance_ohm"]

#: Firmware whose parameters :func:`failsafe_parameters` writes.
FIRMWARES = ("ardupilot", "px4")

#: How long the PX4 low-battery warning comes before the return: the pilot's notice. [s]
PX4_WARNING_NOTICE_S = 60.0

#: PX4 threshold ranges (battery_params_common.c). [unitless]
PX4_RANGES = {"BAT_LOW_THR": (0.12, 0.4), "BAT_CRIT_THR": (0.05, 0.1),
              "BAT_EMERGEN_THR": (0.03, 0.07)}
#: PX4 BAT1_R_INTERNAL range, per cell (module.yaml). [Ω]
PX4_R_MAX_OHM = 0.2
#: MAV_PARAM_TYPE of a QGroundControl parameter file: REAL32, INT32.
MAV_PARAM_TYPE = {"float": 9, "int": 6}


@dataclass(frozen=True)
class FailsafeParameter:
    """One firmware parameter with its value and how it was derived."""

    name: str
    value: float
    unit: str
    kind: str          # "float" or "int"
    derivation: str

    def text_value(self) -> str:
        return str(int(self.value)) if self.kind == "int" else f"{self.value:g}"


@dataclass
class FailsafePlan:
    """Battery failsafe parameters of one firmware for one mission and pack.

    Attributes
    ----------
    firmware : str
        ``"ardupilot"`` or ``"px4"``.
    parameters : list of FailsafeParameter
    worst_point : dict
        The return-home point whose return needs the most charge (time, leg, position,
        altitude, distance home). [s], [m]
    return_charge_mah : float
        Charge of the return from the worst point (see the module notes). [mAh]
    descent_charge_mah : float
        Charge of the descent from the highest point. [mAh]
    low_remaining_mah, critical_remaining_mah : float
        Remaining charge (capacity − drawn) at which to return and to land. [mAh]
    warnings : list of str
    """

    firmware: str
    parameters: list[FailsafeParameter]
    worst_point: dict
    return_charge_mah: float
    descent_charge_mah: float
    low_remaining_mah: float
    critical_remaining_mah: float
    return_source: str = "forecast wind"
    warnings: list[str] = field(default_factory=list)

    def value(self, name: str) -> float:
        return next(p.value for p in self.parameters if p.name == name)

    def to_dict(self) -> dict:
        return {"firmware": self.firmware, "worst_point": self.worst_point,
                "return_charge_mah": self.return_charge_mah,
                "descent_charge_mah": self.descent_charge_mah,
                "low_remaining_mah": self.low_remaining_mah,
                "critical_remaining_mah": self.critical_remaining_mah,
                "return_source": self.return_source,
                "parameters": [{"name": p.name, "value": p.value, "unit": p.unit,
                                "derivation": p.derivation} for p in self.parameters],
                "warnings": list(self.warnings)}

    def param_file(self, header: str = "") -> str:
        """The parameters as a file a ground station loads.

        ArduPilot: Mission Planner / MAVProxy ``.param`` (``NAME,VALUE`` lines, ``#``
        comments). PX4: QGroundControl parameter file (tab-separated ``vehicle-id
        component-id name value type``, type 9 = REAL32, 6 = INT32).
        """
        lines = [f"# {line}" for line in header.splitlines() if line.strip()]
        if self.firmware == "ardupilot":
            lines += [f"{p.name},{p.text_value()}" for p in self.parameters]
        else:
            lines += ["#", "# Vehicle-Id Component-Id Name Value Type"]
            lines += [f"1\t1\t{p.name}\t"
                      + (str(int(p.value)) if p.kind == "int" else f"{p.value:.6f}")
                      + f"\t{MAV_PARAM_TYPE[p.kind]}" for p in self.parameters]
        return "\n".join(lines) + "\n"


def pack_resistance_ohm(pack) -> float | None:
    """Installed pack resistance where the pack file gives it (``internal_resistance_ohm``
    or a number for ``circuit.r0_ohm`` per cell), else None. [Ω]"""
    if pack.internal_resistance_ohm is not None:
        return pack.resistance_ohm
    r0 = getattr(pack.circuit, "r0_ohm", None) if pack.circuit is not None else None
    if isinstance(r0, (int, float)):
        return pack_resistance(float(r0), pack.cells_series, pack.cells_parallel * pack.count)
    return None


def _up(x: float, step: float) -> float:
    return round(math.ceil(x / step - 1e-9) * step, 10)


def _down(x: float, step: float) -> float:
    return round(math.floor(x / step + 1e-9) * step, 10)


def failsafe_parameters(result, firmware: str, i: int = 0, *,
                        return_charge_mah=None) -> FailsafePlan:
    """The battery failsafe parameters of ``firmware`` for pack ``i`` of a chain result.

    Parameters
    ----------
    result : ChainResult
        Run with ``detail=True``.
    firmware : {"ardupilot", "px4"}
    i : int
        Which pack.
    return_charge_mah : array_like, optional
        Charge of the return from every return-home point (e.g. the 95th percentile of a
        Monte Carlo run; NaN where not sampled): where it is larger than the forecast's,
        it is used instead. [mAh]

    Returns
    -------
    FailsafePlan
    """
    if firmware not in FIRMWARES:
        raise InputError(f"firmware must be one of {', '.join(FIRMWARES)}, got {firmware!r}")
    if result.detail is None or "rtl_point_charge_mah" not in result.detail:
        raise ValueError("failsafe_parameters needs a chain result run with detail=True")
    d, pts, pack = result.detail, result.rtl_points, result.packs[i]
    cap = float(result.capacity_mah[i])
    usable = float(result.usable_mah[i])
    reserve = float(result.reserve_mah[i])
    unusable = max(cap - usable, 0.0)
    cells = pack.cells_series
    r_pack = pack_resistance_ohm(pack)
    r = 0.0 if r_pack is None else r_pack
    warnings: list[str] = []

    # the return's charge at the voltage of a landing with exactly the reserve
    soc_land = min(max((reserve + unusable) / cap, 0.0), 1.0)
    v_oc = cells * lipo_ocv(soc_land)
    i_back = loaded_current(d["rtl_back_power_w"][i], v_oc, r)
    i_down = loaded_current(d["rtl_down_power_w"][i], v_oc, r)
    with np.errstate(invalid="ignore"):
        q_down = np.where(pts["t_down"] > 0, i_down * pts["t_down"], 0.0) / AS_PER_MAH
        q_volt = np.where(pts["t_back"] > 0, i_back * pts["t_back"], 0.0) / AS_PER_MAH + q_down
    q_volt = np.where(np.isfinite(q_volt), q_volt, np.inf)
    q_ret = np.maximum(d["rtl_point_charge_mah"][i], q_volt)
    source = "forecast wind"
    if return_charge_mah is not None:
        given = np.asarray(return_charge_mah, float)
        q_ret = np.where(np.isnan(given), q_ret, np.maximum(q_ret, given))
        source = "forecast wind and the Monte Carlo P95"
    q_ret = np.where(np.isnan(q_ret), np.inf, q_ret)
    impossible = ~np.isfinite(q_ret)
    if impossible.any():
        k = int(np.argmax(impossible))
        warnings.append(f"no return home is possible from t = {pts['time_s'][k]:.0f} s "
                        f"({pts['distance_m'][k]:.0f} m from home): the wind or the pack's "
                        "power limit forbids it; the thresholds cover the other points only")
        q_ret = np.where(impossible, -np.inf, q_ret)
    j = int(np.argmax(q_ret))
    q_return = float(max(q_ret[j], 0.0))
    q_land = float(np.nanmax(np.where(np.isfinite(q_down), q_down, 0.0)))
    h = int(np.argmax(pts["altitude_m"]))
    leg = int(pts["leg"][j])
    worst = {"time_s": float(pts["time_s"][j]), "leg": leg + 1,
             "leg_origin": result.table.origin[leg] or f"leg {leg + 1}",
             "east_m": float(pts["east_m"][j]), "north_m": float(pts["north_m"][j]),
             "altitude_m": float(pts["altitude_m"][j]),
             "distance_home_m": float(pts["distance_m"][j])}
    env = result.environment
    where = (f"{worst['distance_home_m']:.0f} m from home at {worst['altitude_m']:.0f} m, "
             f"t = {worst['time_s']:.0f} s, {worst['leg_origin']}; wind "
             f"{env.wind_speed_ms:.1f} m/s from {env.wind_from_deg:.0f}°")
    low = reserve + unusable + q_return
    crit = reserve + unusable + q_land
    base = f"reserve {reserve:.0f} + unusable {unusable:.0f}"
    ret_text = (f"return {q_return:.0f} mAh from the worst point ({where}; larger of "
                "integral model and loaded current"
                + ("" if return_charge_mah is None else " and the Monte Carlo P95") + ")")
    land_text = (f"descent {q_land:.0f} mAh from the highest point "
                 f"({pts['altitude_m'][h]:.0f} m)")

    if low > usable:
        warnings.append(f"the return needs {low:.0f} mAh left, more than the "
                        f"{usable:.0f} mAh the pack can give: the failsafe fires at take-off")

    multirotor = result.aircraft.is_multirotor
    params: list[FailsafeParameter] = []
    add = params.append
    if firmware == "ardupilot":
        low_mah, crit_mah = _up(low, 50), _up(crit, 50)
        add(FailsafeParameter("BATT_CAPACITY", round(cap), "mAh", "int",
                              f"nominal capacity of the pack{'s' if pack.count > 1 else ''} "
                              f"({pack.count} × {pack.capacity_mah:g} mAh)"))
        add(FailsafeParameter("BATT_LOW_MAH", low_mah, "mAh", "int",
                              f"{base} + {ret_text} = {low:.0f} mAh, rounded up to 50 mAh"))
        add(FailsafeParameter("BATT_CRT_MAH", crit_mah, "mAh", "int",
                              f"{base} + {land_text} = {crit:.0f} mAh, rounded up to 50 mAh"))
        sag = r_pack is not None
        add(FailsafeParameter("BATT_FS_VOLTSRC", 1 if sag else 0, "", "int",
                              f"1 = sag compensated: the pack's resistance "
                              f"{r * 1000:.1f} mΩ is known, the voltages below are resting "
                              "(open-circuit) voltages" if sag else
                              "0 = raw: the pack file gives no resistance; the voltages "
                              "below are open-circuit voltages, which the loaded voltage "
                              "reaches earlier (a conservative trigger)"))
        for name, q, what in (("BATT_LOW_VOLT", low_mah, "BATT_LOW_MAH"),
                              ("BATT_CRT_VOLT", crit_mah, "BATT_CRT_MAH")):
            soc = min(max(q / cap, 0.0), 1.0)
            v = cells * float(lipo_ocv(soc))
            add(FailsafeParameter(name, _up(v, 0.1), "V", "float",
                                  f"{cells} × open-circuit cell voltage {v / cells:.3f} V at "
                                  f"{100 * soc:.1f} % charge ({what} left), rounded up to "
                                  "0.1 V"))
        add(FailsafeParameter("BATT_FS_LOW_ACT", 2 if multirotor else 1, "", "int",
                              "RTL (Copter 2, Plane 1) at the low level"))
        add(FailsafeParameter("BATT_FS_CRT_ACT", 1 if multirotor else 2, "", "int",
                              "Land (Copter 1, Plane 2) at the critical level"))
    else:
        cap_fw = _down(usable - reserve, 50)
        if cap_fw <= 0:
            raise InputError(f"{pack.path or pack.name}: the landing reserve {reserve:.0f} "
                             f"mAh leaves no charge above it (usable {usable:.0f} mAh): no "
                             "PX4 thresholds can be derived")
        soc_empty = min(max((reserve + unusable) / cap, 0.0), 1.0)
        v_empty = float(lipo_ocv(soc_empty))
        add(FailsafeParameter("BAT1_CAPACITY", cap_fw, "mAh", "float",
                              f"usable {usable:.0f} − reserve {reserve:.0f} mAh, rounded down "
                              "to 50 mAh: PX4's 0 % is the landing reserve, and its "
                              "thresholds (the return's at most 10 %) count the charge "
                              "above it"))
        add(FailsafeParameter("BAT1_N_CELLS", cells, "", "int",
                              f"{cells} cells in series (pack file)"))
        add(FailsafeParameter("BAT1_V_EMPTY", _up(v_empty, 0.01), "V", "float",
                              f"open-circuit cell voltage at the landing reserve "
                              f"({100 * soc_empty:.1f} % of nominal charge left), rounded up "
                              "to 0.01 V"))
        add(FailsafeParameter("BAT1_V_CHARGED", _down(float(lipo_ocv(1.0)), 0.01), "V",
                              "float", "open-circuit cell voltage of a full cell, rounded "
                                       "down to 0.01 V"))
        if r_pack is None:
            add(FailsafeParameter("BAT1_R_INTERNAL", -1.0, "Ω", "float",
                                  "-1: the pack file gives no resistance (PX4 then uses "
                                  "BAT1_V_LOAD_DROP)"))
        else:
            r_cell = r_pack * pack.cells_parallel * pack.count / cells
            if r_cell > PX4_R_MAX_OHM:
                warnings.append(f"cell resistance {r_cell:.3f} Ω is above PX4's "
                                f"{PX4_R_MAX_OHM} Ω limit: BAT1_R_INTERNAL set to the limit")
            add(FailsafeParameter("BAT1_R_INTERNAL", round(min(r_cell, PX4_R_MAX_OHM), 4),
                                  "Ω", "float",
                                  f"pack {r_pack * 1000:.1f} mΩ × {pack.cells_parallel * pack.count}"
                                  f" parallel / {cells} series, per cell"))

        def fraction(name, q, text):
            lo, hi = PX4_RANGES[name]
            f = _up(q / cap_fw, 0.01)
            value = min(max(f, lo), hi)
            note = ""
            if f > hi:
                note = f"; above PX4's maximum {hi:g}: set to it"
                warnings.append(f"{name}: the mission needs {f:.2f} of BAT1_CAPACITY but "
                                f"PX4 allows at most {hi:g}: the failsafe comes too late "
                                "from the worst point; shorten the mission's farthest leg "
                                "or carry a larger pack")
            elif f < lo:
                note = f"; below PX4's minimum {lo:g}: set to it (earlier, safe)"
            return FailsafeParameter(name, value, "norm", "float",
                                     f"{text} / BAT1_CAPACITY {cap_fw:.0f} mAh = {f:.2f}"
                                     + note)

        crit_p = fraction("BAT_CRIT_THR", q_return, ret_text)
        emerg_p = fraction("BAT_EMERGEN_THR", q_land, land_text)
        with np.errstate(invalid="ignore"):
            i_hold = loaded_current(result.hold_power_w[i], cells * lipo_ocv(soc_land), r)
        q_notice = float(i_hold) * PX4_WARNING_NOTICE_S / AS_PER_MAH
        lo, hi = PX4_RANGES["BAT_LOW_THR"]
        f_low = _up(crit_p.value + q_notice / cap_fw, 0.01)
        low_p = FailsafeParameter(
            "BAT_LOW_THR", min(max(f_low, lo), hi), "norm", "float",
            f"BAT_CRIT_THR {crit_p.value:g} + {PX4_WARNING_NOTICE_S:.0f} s of hold "
            f"({q_notice:.0f} mAh) / {cap_fw:.0f} mAh = {f_low:.2f}, within PX4's "
            f"[{lo:g}, {hi:g}]: a warning a minute before the return")
        params += [low_p, crit_p, emerg_p]
        add(FailsafeParameter("COM_LOW_BAT_ACT", 3, "", "int",
                              "3 = return at the critical level, land at the emergency "
                              "level"))
    # when does the mission itself cross the return threshold?
    trigger = (cap - params[1].value if firmware == "ardupilot"
               else cap_fw * (1.0 - crit_p.value))
    drawn = d["charge_end_mah"][i]
    crossed = np.flatnonzero(drawn > trigger)
    if crossed.size and crossed[0] < len(drawn) - 1:
        k = int(crossed[0])
        warnings.append(f"the return threshold ({trigger:.0f} mAh drawn) is reached by the "
                        f"end of {result.table.origin[k] or f'leg {k + 1}'} (t = "
                        f"{result.table.end_time_s[k]:.0f} s), before the mission ends: the "
                        "failsafe will bring the aircraft home early")
    return FailsafePlan(firmware=firmware, parameters=params, worst_point=worst,
                        return_charge_mah=q_return, descent_charge_mah=q_land,
                        low_remaining_mah=low, critical_remaining_mah=crit,
                        return_source=source, warnings=warnings)
