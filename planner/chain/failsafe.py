r"""Battery failsafe parameters of ArduPilot and PX4, derived from the mission.

The autopilot's battery failsafe fires on a fixed threshold and then flies a fixed action.
The right threshold is the charge that action needs, from the worst point of *this*
mission in *this* wind, to land with the landing reserve. :func:`failsafe_parameters`
reads it from a :class:`~planner.chain.mission_chain.ChainResult` (one pack, run with its
per-leg detail), which holds the return home from
:data:`~planner.chain.mission_chain.RTL_POINTS_PER_LEG` points of every leg.

What each action costs
----------------------
Every action is charged from every return-home point (``docs/failsafe.md`` tabulates which
action each firmware and vehicle type flies, and the source file each follows):

* **return** — straight home at the cruise speed, at the point's altitude, in the mission's
  wind, then the descent over home (:func:`planner.chain.kinematics.return_home_points`). Its
  charge is the larger of the integral capacity model's ([UAV23] eq. 14),
  :math:`C(S_p + S_r) - C(S_p)`, and the loaded current of each segment through the pack's
  resistance at the state of charge of a landing with exactly the reserve,
  :math:`Q = \sum_k I_k t_k` with :math:`P_k = (V_{oc} - I_k R) I_k` ([HESS] eq. 2,
  :func:`planner.physics.battery.elements.loaded_current`);
* **land here** — the descent from the point's altitude where it is (a multirotor straight
  down, a fixed-wing aircraft in a descending circle), at that loaded current;
* **landing sequence** (fixed-wing) — to the start of the mission's landing sequence (its
  closing loiter and descent legs, where ArduPlane's ``DO_LAND_START`` stands) at the
  cruise airspeed in the wind, then the sequence's own legs; from a point inside the
  sequence, the rest of it (a landing under way is not interrupted). The mission's legs do
  not say whether the uploaded mission holds a ``DO_LAND_START``, so an action that flies
  the sequence where there is one and returns home where there is none is charged the
  larger of the two;
* **hold** (PX4) — the hover or loiter that PX4 flies for ``COM_FAIL_ACT_T`` (v1.14 on;
  ``COM_BAT_ACT_T`` in v1.13) before it acts, at the larger of the hold's power and the
  power of the leg flown at the point.

:math:`V_{oc}` comes from the pack's own OCV curve where its file has one (``circuit.
ocv_csv``, as ``fit-battery`` writes it), else from its chemistry's
(:mod:`planner.physics.battery.chemistry`).

Thresholds
----------
The autopilot counts the charge drawn against its capacity parameter; a threshold on the
*remaining* charge is :math:`Q_{reserve} + Q_{unusable} + \max_p Q_{action}(p)`, with
``Q_unusable`` = nominal − usable (``usable_fraction``, the circuit model's cut-off). Each
firmware tests its most severe level first (ArduPilot ``AP_BattMonitor_Backend::
update_failsafes``: critical voltage, critical mAh, low voltage, low mAh; PX4
``battery.cpp``: emergency, critical, low): two levels at the same value fire the severe
action only, so every level is kept apart from the next by at least one step the firmware
can tell apart. Firmware names, units, ranges and action values are those of ArduPilot
``libraries/AP_BattMonitor/AP_BattMonitor_Params.cpp``, ``ArduCopter/events.cpp``,
``ArduPlane/events.cpp`` and PX4 ``src/lib/battery/module.yaml`` (``battery_params.c`` and
``battery_params_common.c`` before PR 23419), ``src/modules/commander/commander_params.c``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from planner.errors import InputError
from planner.physics.battery.chemistry import chemistry
from planner.physics.battery.elements import loaded_current
from planner.physics.units import AS_PER_MAH
from planner.physics.wind import wind_triangle, wind_vector

__all__ = ["ACTIONS", "FIRMWARES", "PX4_RELEASES", "PX4_STABLE_VERSION", "Action",
           "FailsafeParameter", "FailsafePlan", "Px4Release", "failsafe_parameters",
           "landing_sequence_start", "pack_ocv", "pack_resistance_ohm",
           "parse_firmware_version", "px4_release"]

#: Firmware whose parameters :func:`failsafe_parameters` writes.
FIRMWARES = ("ardupilot", "px4")

#: How long the PX4 low-battery warning comes before the return: the pilot's notice. [s]
PX4_WARNING_NOTICE_S = 60.0
#: PX4 BAT1_R_INTERNAL range, per cell (module.yaml). [Ω]
PX4_R_MAX_OHM = 0.2
#: MAV_PARAM_TYPE of a QGroundControl parameter file: REAL32, INT32.
MAV_PARAM_TYPE = {"float": 9, "int": 6}
#: ArduPilot BATT_LOW_TIMER default: the voltage must stay under a threshold this long
#: (AP_BattMonitor_Params.cpp; it applies to the low and the critical voltage). [s]
BATT_LOW_TIMER_S = 10.0
#: Noise of the pack voltage the autopilot reads, peak (assumed: a hobby analog power
#: module after the firmware's averaging). [V]
VOLTAGE_NOISE_V = 0.1


# --------------------------------------------------------------------------- PX4 releases

@dataclass(frozen=True)
class Px4Release:
    """What the battery failsafe of a range of PX4 releases accepts and does.

    Attributes
    ----------
    first, last : tuple of int
        First and last (major, minor) release of the row (``last`` None: to the newest).
    ranges : dict of str to (float, float)
        ``BAT_LOW_THR``, ``BAT_CRIT_THR``, ``BAT_EMERGEN_THR`` [min, max]. [unitless]
    hold_param : str or None
        The hold before a battery failsafe acts (None: it acts at once).
    hold_s : float
        Its default. [s]
    source : str
        The files (and pull requests) the row follows.
    """

    first: tuple[int, int]
    last: tuple[int, int] | None
    ranges: dict
    hold_param: str | None
    hold_s: float
    source: str

    def label(self) -> str:
        """The releases this row covers in words, e.g. ``v1.14–v1.15`` or ``v1.16 and later``."""
        a = f"v{self.first[0]}.{self.first[1]}"
        if self.last is None:
            return f"{a} and later"
        return a if self.last == self.first else f"{a}–v{self.last[0]}.{self.last[1]}"


_OLD = {"BAT_LOW_THR": (0.12, 0.40), "BAT_CRIT_THR": (0.05, 0.10),
        "BAT_EMERGEN_THR": (0.03, 0.07)}
_PR15035 = {"BAT_LOW_THR": (0.12, 0.50), "BAT_CRIT_THR": (0.05, 0.25),
            "BAT_EMERGEN_THR": (0.03, 0.10)}
_PR23419 = {"BAT_LOW_THR": (0.12, 0.50), "BAT_CRIT_THR": (0.05, 0.50),
            "BAT_EMERGEN_THR": (0.03, 0.50)}

#: The PX4 battery-failsafe rows, oldest first.
PX4_RELEASES = (
    Px4Release((1, 0), (1, 10), _OLD, None, 0.0,
               "src/lib/battery/battery_params.c before PR 15035; no hold before the action"),
    Px4Release((1, 11), (1, 12), _PR15035, None, 0.0,
               "src/lib/battery/battery_params_common.c after PR 15035 (maxima relaxed, as "
               "in the v1.11.3 parameters.xml)"),
    Px4Release((1, 13), (1, 13), _PR15035, "COM_BAT_ACT_T", 10.0,
               "battery_params_common.c; commander_params.c COM_BAT_ACT_T, 10 s hold "
               "(PR 19033, merged for v1.13)"),
    Px4Release((1, 14), (1, 15), _PR15035, "COM_FAIL_ACT_T", 5.0,
               "battery_params_common.c; commander_params.c COM_FAIL_ACT_T, 5 s hold "
               "(failsafe framework, PR 20172)"),
    Px4Release((1, 16), None, _PR23419, "COM_FAIL_ACT_T", 5.0,
               "src/lib/battery/module.yaml after PR 23419 (every maximum 0.5; merged July "
               "2024, after the v1.15 branch: v1.16 inferred as the first release); "
               "commander_params.c COM_FAIL_ACT_T, 5 s"),
)
#: The PX4 release used without ``firmware_version``: the newest stable release found
#: (v1.17.0, May 2026); its ranges are those of main after PR 23419, not read from its tag.
PX4_STABLE_VERSION = (1, 17, 0)
#: Newest release whose ranges the table was checked against.
PX4_NEWEST_CHECKED = (1, 17)


def parse_firmware_version(text: str) -> tuple[int, int, int]:
    """``"v1.17.0"``, ``"1.16"``, ``"1.14.3-rc1"`` → (major, minor, patch).

    Raises
    ------
    InputError
        Not a version of the form MAJOR.MINOR[.PATCH].
    """
    m = re.fullmatch(r"\s*v?(\d+)\.(\d+)(?:\.(\d+))?(?:[-+][0-9A-Za-z.]*)?\s*", str(text))
    if m is None:
        raise InputError(f"expected a release such as v1.17.0 or 1.16, got {text!r}")
    return int(m.group(1)), int(m.group(2)), int(m.group(3) or 0)


def px4_release(version) -> Px4Release:
    """The :data:`PX4_RELEASES` row of a PX4 version (a tuple or a version text).

    Raises
    ------
    InputError
        A version outside PX4 v1 (the table starts at v1.0).
    """
    v = parse_firmware_version(version) if isinstance(version, str) else tuple(version)
    if v[0] != 1:
        raise InputError(f"PX4 v{'.'.join(map(str, v))}: the battery-failsafe table covers "
                         "PX4 v1.x")
    for row in PX4_RELEASES:
        if row.first <= v[:2] and (row.last is None or v[:2] <= row.last):
            return row
    raise InputError(f"PX4 v{'.'.join(map(str, v))} is not covered")  # pragma: no cover


# --------------------------------------------------------------------------- actions

@dataclass(frozen=True)
class Action:
    """A failsafe action as one firmware flies it on one vehicle type.

    ``charge`` names the per-point charge it needs (``return``, ``land_here``,
    ``return_or_sequence``); ``does`` says what the firmware does, with its source file.
    """

    value: int
    name: str
    charge: str
    does: str


#: Per firmware and vehicle type: the action at each level (ArduPilot ``low``,
#: ``critical``; PX4 ``critical``, ``emergency`` under ``COM_LOW_BAT_ACT`` = 3).
ACTIONS = {
    ("ardupilot", "multirotor"): {
        "low": Action(2, "RTL", "return",
                      "ArduCopter flies home and lands (ArduCopter/events.cpp "
                      "do_failsafe_action → set_mode_RTL_or_land_with_pause)"),
        "critical": Action(1, "Land", "land_here",
                           "ArduCopter descends where it is (set_mode_land_with_pause)")},
    ("ardupilot", "fixed_wing"): {
        "low": Action(1, "RTL", "return",
                      "ArduPlane flies home and circles over it until the critical "
                      "level lands it (ArduPlane/events.cpp Plane::handle_battery_failsafe)"),
        "critical": Action(2, "Land", "return_or_sequence",
                           "ArduPlane jumps to the mission's landing sequence "
                           "(DO_LAND_START) and flies it, or returns (RTL) where there is "
                           "none (Plane::handle_battery_failsafe)")},
    ("px4", "multirotor"): {
        "critical": Action(3, "Return", "return",
                           "PX4 flies home and lands (COM_LOW_BAT_ACT 3, "
                           "commander/failsafe/failsafe.cpp)"),
        "emergency": Action(3, "Land", "land_here", "PX4 descends where it is")},
    ("px4", "fixed_wing"): {
        "critical": Action(3, "Return", "return_or_sequence",
                           "PX4 flies home, or to the mission's landing where the "
                           "return type flies it (COM_LOW_BAT_ACT 3)"),
        "emergency": Action(3, "Land", "land_here",
                            "PX4 circles down where it is")},
}


# --------------------------------------------------------------------------- results

@dataclass(frozen=True)
class FailsafeParameter:
    """One firmware parameter with its value and how it was derived."""

    name: str
    value: float
    unit: str
    kind: str          # "float" or "int"
    derivation: str

    def text_value(self) -> str:
        """The value as the firmware's parameter file writes it: an integer for integer
        parameters, else the shortest decimal form (in the parameter's own unit)."""
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
        Remaining charge (capacity − drawn) at which the first and the second action
        fire. [mAh]
    levels : list of dict
        Per level: name, action, charge needed and the point that needs it most.
    firmware_version : str or None
        PX4: the release whose ranges were applied (and how it was chosen).
    go : bool
        False when no parameter set of this firmware lands with the reserve; ``reasons``
        says why, and no parameter file is written.
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
    levels: list[dict] = field(default_factory=list)
    firmware_version: str | None = None
    go: bool = True
    reasons: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def value(self, name: str) -> float:
        """The value of parameter ``name`` (in the firmware's unit for it)."""
        return next(p.value for p in self.parameters if p.name == name)

    def parameter(self, name: str) -> FailsafeParameter:
        """The parameter ``name`` of the plan (StopIteration when the plan has none)."""
        return next(p for p in self.parameters if p.name == name)

    def to_dict(self) -> dict:
        """JSON-ready: the firmware and version, verdict and reasons, the worst return point,
        its charges [mAh], every parameter with its value, unit and derivation, and the
        warnings."""
        return {"firmware": self.firmware, "firmware_version": self.firmware_version,
                "go": self.go, "reasons": list(self.reasons),
                "worst_point": self.worst_point,
                "return_charge_mah": self.return_charge_mah,
                "descent_charge_mah": self.descent_charge_mah,
                "low_remaining_mah": self.low_remaining_mah,
                "critical_remaining_mah": self.critical_remaining_mah,
                "return_source": self.return_source, "levels": self.levels,
                "parameters": [{"name": p.name, "value": p.value, "unit": p.unit,
                                "derivation": p.derivation} for p in self.parameters],
                "warnings": list(self.warnings)}

    def param_file(self, header: str = "") -> str:
        """The parameters as a file a ground station loads.

        ArduPilot: Mission Planner / MAVProxy ``.param`` (``NAME,VALUE`` lines, ``#``
        comments). PX4: QGroundControl parameter file (tab-separated ``vehicle-id
        component-id name value type``, type 9 = REAL32, 6 = INT32).

        Raises
        ------
        ValueError
            The plan is NO-GO: it has no values the firmware accepts that land with the
            reserve.
        """
        if not self.go:
            raise ValueError("a NO-GO failsafe plan has no parameter file: "
                             + "; ".join(self.reasons))
        lines = [f"# {line}" for line in header.splitlines() if line.strip()]
        if self.firmware == "ardupilot":
            lines += [f"{p.name},{p.text_value()}" for p in self.parameters]
        else:
            lines += ["#", "# Vehicle-Id Component-Id Name Value Type"]
            lines += [f"1\t1\t{p.name}\t"
                      + (str(int(p.value)) if p.kind == "int" else f"{p.value:.6f}")
                      + f"\t{MAV_PARAM_TYPE[p.kind]}" for p in self.parameters]
        return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------- the pack

def pack_resistance_ohm(pack) -> float | None:
    """Installed pack resistance where the pack file gives it (``internal_resistance_ohm``
    or a number for ``circuit.r0_ohm`` per cell), else None. [Ω]"""
    if pack.internal_resistance_ohm is not None:
        return pack.resistance_ohm
    r0 = getattr(pack.circuit, "r0_ohm", None) if pack.circuit is not None else None
    if isinstance(r0, (int, float)):
        return float(r0) * pack.cells_series / (pack.cells_parallel * pack.count)
    return None


def pack_polarisation_ohm(pack) -> float | None:
    """Installed resistance of the ``circuit:`` block's RC branch (``r1_ohm`` per cell), or
    None where the block gives none. [Ω]"""
    r1 = getattr(pack.circuit, "r1_ohm", 0.0) if pack.circuit is not None else 0.0
    if not r1:
        return None
    return float(r1) * pack.cells_series / (pack.cells_parallel * pack.count)


def pack_ocv(pack) -> tuple[Callable, str]:
    """The cell OCV curve of a pack, and where it comes from: the pack's own fitted curve
    (``circuit.ocv_csv``) where it has one, else its chemistry's."""
    circuit = pack.circuit
    if circuit is not None and circuit.ocv_csv:
        return circuit.ocv, f"the pack's own OCV curve ({circuit.ocv_csv})"
    chem = chemistry(pack.chemistry)
    return chem.ocv, f"the {chem.name} OCV curve ({chem.ocv_source})"


def _up(x: float, step: float) -> float:
    return round(math.ceil(x / step - 1e-9) * step, 10)


def _down(x: float, step: float) -> float:
    return round(math.floor(x / step + 1e-9) * step, 10)


# --------------------------------------------------------------------------- charges

def landing_sequence_start(table) -> int | None:
    """First leg of the mission's landing sequence: the closing run of ``loiter``,
    ``hover`` and ``descend`` legs of a mission that ends on the ground (None: the mission
    does not end in such a run)."""
    n = len(table)
    if n == 0 or float(table.end_alt_m[-1]) > 1.0 or table.kind[-1] != "descend":
        return None
    k = n - 1
    while k > 0 and table.kind[k - 1] in ("loiter", "hover", "descend"):
        k -= 1
    return k


@dataclass
class _Inputs:
    """What every derivation reads: the pack's charges and the per-point action charges."""

    result: object
    i: int
    pack: object
    vehicle: str
    cap: float
    usable: float
    reserve: float
    unusable: float
    ocv: Callable
    ocv_source: str
    r_pack: float | None
    v_land: float
    charges: dict
    hold_current_a: np.ndarray
    point_current_a: np.ndarray
    sequence_text: str
    source: str
    warnings: list

    @property
    def base(self) -> float:
        return self.reserve + self.unusable

    def charge(self, what: str) -> np.ndarray:
        """Per-point charge of an action: ``return``, ``land_here`` or
        ``return_or_sequence``. [mAh]"""
        if what == "return_or_sequence":
            seq = self.charges.get("sequence")
            return self.charges["return"] if seq is None else np.maximum(
                self.charges["return"], seq)
        return self.charges[what]


def _sequence_charge(result, i, k, current) -> np.ndarray:
    """Charge from every return-home point to the landing sequence starting at leg ``k``
    and through it, at the loaded currents ``current(power)``. [mAh]"""
    t, d, pts = result.table, result.detail, result.rtl_points
    legs = np.arange(k, len(t))
    q_leg = current(d["power_w"][i, legs]) * t.duration_s[legs] / AS_PER_MAH
    after = np.concatenate([np.cumsum(q_leg[::-1])[::-1][1:], [0.0]])   # legs after each
    leg = pts["leg"]
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.clip((pts["time_s"] - t.start_time_s[leg])
                       / np.where(t.duration_s[leg] > 0, t.duration_s[leg], 1.0), 0.0, 1.0)
    inside = leg >= k
    j = np.clip(leg - k, 0, len(legs) - 1)
    q_inside = (1.0 - frac) * q_leg[j] + after[j]
    # outside: fly to the start of the sequence at the cruise airspeed, level
    de = t.start_en_m[k, 0] - pts["east_m"]
    dn = t.start_en_m[k, 1] - pts["north_m"]
    dist = np.hypot(de, dn)
    course = np.degrees(np.arctan2(de, dn)) % 360.0
    ac, env = result.aircraft, result.environment
    w_e, w_n = wind_vector(env.wind_speed_ms, env.wind_from_deg)
    _, gs = wind_triangle(course, w_e, w_n, airspeed=np.full(dist.shape, ac.cruise_speed_ms))
    with np.errstate(invalid="ignore", divide="ignore"):
        t_to = np.where(dist < 1.0, 0.0, dist / gs)
    q_out = current(d["rtl_back_power_w"][i]) * t_to / AS_PER_MAH + q_leg.sum()
    out = np.where(inside, q_inside, q_out)
    return np.where(np.isfinite(out), out, np.inf)


def _inputs(result, i, return_charge_mah) -> _Inputs:
    """The pack's charges, its OCV and the charge of every action from every point."""
    d, pts, pack = result.detail, result.rtl_points, result.packs[i]
    cap, usable = float(result.capacity_mah[i]), float(result.usable_mah[i])
    reserve = float(result.reserve_mah[i])
    unusable = max(cap - usable, 0.0)
    ocv, ocv_source = pack_ocv(pack)
    r_pack = pack_resistance_ohm(pack)
    r = 0.0 if r_pack is None else r_pack
    soc_land = min(max((reserve + unusable) / cap, 0.0), 1.0)
    v_land = pack.cells_series * float(ocv(soc_land))
    warnings: list[str] = []

    def current(power):
        with np.errstate(invalid="ignore"):
            return loaded_current(power, v_land, r)

    with np.errstate(invalid="ignore"):
        q_down = np.where(pts["t_down"] > 0, current(d["rtl_down_power_w"][i]) * pts["t_down"],
                          0.0) / AS_PER_MAH
        q_volt = np.where(pts["t_back"] > 0, current(d["rtl_back_power_w"][i]) * pts["t_back"],
                          0.0) / AS_PER_MAH + q_down
    q_ret = np.maximum(d["rtl_point_charge_mah"][i], np.where(np.isfinite(q_volt), q_volt,
                                                                np.inf))
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
    charges = {"return": np.where(impossible, -np.inf, q_ret),
               "land_here": np.where(np.isfinite(q_down), q_down, 0.0), "sequence": None}
    vehicle = "multirotor" if result.aircraft.is_multirotor else "fixed_wing"
    k_seq = landing_sequence_start(result.table) if vehicle == "fixed_wing" else None
    seq_text = "the mission has no landing sequence (it does not end in a loiter or descent)"
    if k_seq is not None:
        seq = _sequence_charge(result, i, k_seq, current)
        blocked = ~np.isfinite(seq)
        if (blocked & ~impossible).any():
            k = int(np.argmax(blocked & ~impossible))
            warnings.append(f"the landing sequence cannot be reached from t = "
                            f"{pts['time_s'][k]:.0f} s (the wind or the pack's power limit "
                            "forbids it); the thresholds cover the other points only")
        charges["sequence"] = np.where(impossible | blocked, -np.inf, seq)
        seq_text = (f"landing sequence from {result.table.origin[k_seq] or f'leg {k_seq + 1}'}"
                    f" ({len(result.table) - k_seq} legs)")
    leg_power = d["power_w"][i, pts["leg"]]
    return _Inputs(result, i, pack, vehicle, cap, usable, reserve, unusable, ocv, ocv_source,
                   r_pack, v_land, charges,
                   current(np.maximum(leg_power, result.hold_power_w[i])),
                   current(leg_power), seq_text, source, warnings)


def _where(inp: _Inputs, j: int) -> dict:
    """The return-home point ``j`` as the plan reports it."""
    pts, table = inp.result.rtl_points, inp.result.table
    leg = int(pts["leg"][j])
    return {"time_s": float(pts["time_s"][j]), "leg": leg + 1,
            "leg_origin": table.origin[leg] or f"leg {leg + 1}",
            "east_m": float(pts["east_m"][j]), "north_m": float(pts["north_m"][j]),
            "altitude_m": float(pts["altitude_m"][j]),
            "distance_home_m": float(pts["distance_m"][j])}


def _worst(inp: _Inputs, q: np.ndarray) -> tuple[float, int, str]:
    """(charge, point, text) of the point where ``q`` is largest. [mAh]"""
    j = int(np.argmax(q))
    w = _where(inp, j)
    env = inp.result.environment
    text = (f"{w['distance_home_m']:.0f} m from home at {w['altitude_m']:.0f} m, t = "
            f"{w['time_s']:.0f} s, {w['leg_origin']}; wind {env.wind_speed_ms:.1f} m/s from "
            f"{env.wind_from_deg:.0f}°")
    return float(max(q[j], 0.0)), j, text


def _level(inp: _Inputs, name: str, action: Action, extra=None) -> dict:
    """One failsafe level: its action's largest charge over the points (plus ``extra`` per
    point), the point and the text of the derivation."""
    q = inp.charge(action.charge)
    if extra is not None:
        q = q + extra
    charge, j, where = _worst(inp, q)
    what = {"return": "the return home", "land_here": "the descent where it is",
            "return_or_sequence": ("the return home (" + inp.sequence_text + ")"
                                   if inp.charges.get("sequence") is None else
                                   "the larger of the return home and the "
                                   + inp.sequence_text)}[action.charge]
    text = f"{what}, {charge:.0f} mAh from the worst point ({where})"
    return {"name": name, "action": action.name, "value": action.value, "does": action.does,
            "charge_mah": charge, "point": j, "text": text, "where": _where(inp, j)}


# --------------------------------------------------------------------------- ArduPilot

def _ardupilot_voltages(inp: _Inputs, low_mah: float, crit_mah: float, levels) -> list:
    """BATT_FS_VOLTSRC, BATT_LOW_TIMER, BATT_LOW_VOLT, BATT_CRT_VOLT: the OCV at the state
    of charge of each level, drawn ``BATT_LOW_TIMER`` earlier, or 0 (off) where the two
    levels lie closer than the firmware can tell apart."""
    cells, cap = inp.pack.cells_series, inp.cap
    volts = []
    for level_mah, lv in ((low_mah, levels[0]), (crit_mah, levels[1])):
        i_pt = float(inp.point_current_a[lv["point"]])
        q_timer = i_pt * BATT_LOW_TIMER_S / AS_PER_MAH
        soc = min(max((level_mah + q_timer) / cap, 0.0), 1.0)
        volts.append((cells * float(inp.ocv(soc)), soc, q_timer, i_pt))
    out = [FailsafeParameter("BATT_FS_VOLTSRC", 1, "", "int",
                             "1 = sag compensated: the firmware adds current × its own "
                             "resistance estimate, so the thresholds below are resting "
                             "voltages"),
           FailsafeParameter("BATT_LOW_TIMER", BATT_LOW_TIMER_S, "s", "int",
                             "the firmware's default: a voltage level counts after this "
                             "long below it; the charge drawn meanwhile is added below")]
    v_low, v_crit = _up(volts[0][0], 0.1), _up(volts[1][0], 0.1)
    i_max = max(volts[0][3], volts[1][3])
    r_unseen = pack_polarisation_ohm(inp.pack) or inp.r_pack
    reason = None
    if inp.r_pack is None:
        reason = ("the pack file gives no resistance, so the sag the firmware must tell "
                  "apart from the charge is unknown")
    else:
        margin = 2 * VOLTAGE_NOISE_V + i_max * r_unseen
        if v_low - v_crit < margin:
            reason = (f"the two levels lie {v_low - v_crit:.2f} V apart on {inp.ocv_source}, "
                      f"less than the {margin:.2f} V the firmware can tell apart (twice "
                      f"{VOLTAGE_NOISE_V:g} V of sensor noise + {i_max:.1f} A × "
                      f"{r_unseen * 1000:.0f} mΩ of sag its short-term resistance estimate "
                      "does not remove); with equal readings it tests the critical level "
                      "first and lands instead of returning")
    for name, (v, soc, q_t, _), rounded, what in (
            ("BATT_LOW_VOLT", volts[0], v_low, "BATT_LOW_MAH"),
            ("BATT_CRT_VOLT", volts[1], v_crit, "BATT_CRT_MAH")):
        if reason is not None:
            out.append(FailsafeParameter(name, 0.0, "V", "float",
                                         f"0 = voltage failsafe off: {reason}; the mAh "
                                         "levels above hold" if name == "BATT_LOW_VOLT" else
                                         "0 = off, with BATT_LOW_VOLT"))
            continue
        out.append(FailsafeParameter(
            name, rounded, "V", "float",
            f"{inp.pack.cells_series} × {v / inp.pack.cells_series:.3f} V, the resting cell "
            f"voltage at {100 * soc:.1f} % charge ({what} + {q_t:.0f} mAh drawn over "
            f"BATT_LOW_TIMER) on {inp.ocv_source}, rounded up to 0.1 V"))
    return out


def _ardupilot_parameters(inp: _Inputs, version) -> FailsafePlan:
    """ArduPilot (Copter, Plane): capacity and voltage levels of the low and critical
    actions of :data:`ACTIONS` (``AP_BattMonitor_Backend::update_failsafes``)."""
    if version is not None:
        raise InputError("the ArduPilot derivation follows AP_BattMonitor and the vehicles' "
                         "events.cpp as read; a firmware version selects PX4 releases only")
    acts = ACTIONS[("ardupilot", inp.vehicle)]
    low, crit = _level(inp, "low", acts["low"]), _level(inp, "critical", acts["critical"])
    base = f"reserve {inp.reserve:.0f} + unusable {inp.unusable:.0f}"
    low_need, crit_need = inp.base + low["charge_mah"], inp.base + crit["charge_mah"]
    crit_mah = _up(crit_need, 50)
    low_mah = _up(low_need, 50)
    low_text = f"{base} + {low['text']} = {low_need:.0f} mAh, rounded up to 50 mAh"
    if low_mah <= crit_mah:
        low_mah = crit_mah + 50
        low_text += ("; raised to BATT_CRT_MAH + 50 mAh: the firmware tests the critical "
                     "level first and refuses to arm with critical above low "
                     "(AP_BattMonitor_Backend::arming_checks), so the return must come "
                     "one step before the critical action")
    pack, cap = inp.pack, inp.cap
    params = [
        FailsafeParameter("BATT_CAPACITY", round(cap), "mAh", "int",
                          f"nominal capacity of the pack{'s' if pack.count > 1 else ''} "
                          f"({pack.count} × {pack.capacity_mah:g} mAh)"),
        FailsafeParameter("BATT_LOW_MAH", low_mah, "mAh", "int", low_text),
        FailsafeParameter("BATT_CRT_MAH", crit_mah, "mAh", "int",
                          f"{base} + {crit['text']} = {crit_need:.0f} mAh, rounded up to "
                          "50 mAh")]
    params += _ardupilot_voltages(inp, low_mah, crit_mah, (low, crit))
    params += [FailsafeParameter("BATT_FS_LOW_ACT", low["value"], "", "int",
                                 f"{low['value']} = {low['action']}: {low['does']}"),
               FailsafeParameter("BATT_FS_CRT_ACT", crit["value"], "", "int",
                                 f"{crit['value']} = {crit['action']}: {crit['does']}")]
    return _plan(inp, "ardupilot", params, low, crit, cap - low_mah, cap - crit_mah)


# --------------------------------------------------------------------------- PX4

def _px4_fraction(name, need_mah, cap_fw, release, text, version_label, reasons):
    """A PX4 threshold as a fraction of BAT1_CAPACITY, checked against the release's
    range: above it NO-GO (``reasons``), below it raised to the minimum (earlier)."""
    lo, hi = release.ranges[name]
    f = _up(need_mah / cap_fw, 0.01)
    rng = f"PX4's [{lo:g}, {hi:g}] ({version_label})"
    derivation = f"{text} / BAT1_CAPACITY {cap_fw:.0f} mAh = {f:.2f}"
    if f > hi:
        reasons.append(f"{name}: the mission needs {f:.2f} of BAT1_CAPACITY ({need_mah:.0f} "
                       f"of {cap_fw:.0f} mAh) but {rng} allows at most {hi:g} "
                       f"({release.source}): no value of it lands with the reserve; "
                       "shorten the farthest leg, carry a larger pack or fly a newer release")
        return f, derivation + f"; {f:.2f} is above {_allowed(name, lo, hi, version_label)}: NO-GO"
    if f < lo:
        return lo, derivation + (f"; {f:.2f} is below {_allowed(name, lo, hi, version_label)}:"
                                 f" set to {lo:g} (earlier, the safe side)")
    return f, derivation + f"; {f:.2f} is within {_allowed(name, lo, hi, version_label)}"


def _allowed(name, lo, hi, version_label) -> str:
    """The range a PX4 release allows a threshold, named so that it reads apart from the
    figures of the derivation before it."""
    return f"the {lo:g}–{hi:g} PX4 {version_label} allows {name}"


def _px4_parameters(inp: _Inputs, version) -> FailsafePlan:
    """PX4: BAT1_* from the pack and its OCV curve; BAT_CRIT_THR and BAT_EMERGEN_THR from
    the Return and Land of :data:`ACTIONS` after the release's hold; BAT_LOW_THR a minute
    of hold above the return (``battery.cpp``, ``commander_params.c``)."""
    v = PX4_STABLE_VERSION if version is None else (
        parse_firmware_version(version) if isinstance(version, str) else tuple(version))
    release = px4_release(v)
    label = f"v{v[0]}.{v[1]}"
    cap_fw = _down(inp.usable - inp.reserve, 50)
    reasons: list[str] = []
    if cap_fw <= 0:
        raise InputError(f"{inp.pack.path or inp.pack.name}: the landing reserve "
                         f"{inp.reserve:.0f} mAh leaves no charge above it (usable "
                         f"{inp.usable:.0f} mAh): no PX4 thresholds can be derived")
    hold = inp.hold_current_a * release.hold_s / AS_PER_MAH
    acts = ACTIONS[("px4", inp.vehicle)]
    crit = _level(inp, "critical", acts["critical"], hold)
    emerg = _level(inp, "emergency", acts["emergency"], hold)
    hold_text = (f" (including {release.hold_s:g} s of {release.hold_param} hold)"
                 if release.hold_param else "")
    f_e, t_e = _px4_fraction("BAT_EMERGEN_THR", emerg["charge_mah"], cap_fw, release,
                             emerg["text"] + hold_text, label, reasons)
    f_c, t_c = _px4_fraction("BAT_CRIT_THR", crit["charge_mah"], cap_fw, release,
                             crit["text"] + hold_text, label, reasons)
    if f_c <= f_e:
        f_c = _up(f_e + 0.01, 0.01)
        t_c += (f"; raised above BAT_EMERGEN_THR to {f_c:.2f}: PX4 tests the emergency level "
                "first (battery.cpp), so at equal levels it would land instead of returning")
        if f_c > release.ranges["BAT_CRIT_THR"][1]:
            reasons.append(f"BAT_CRIT_THR must lie above BAT_EMERGEN_THR {f_e:.2f} but "
                           f"{label} allows at most {release.ranges['BAT_CRIT_THR'][1]:g}")
    low_p = _px4_low(inp, release, label, cap_fw, f_c, crit["point"], reasons)
    params = _px4_pack_parameters(inp, cap_fw) + [
        low_p, FailsafeParameter("BAT_CRIT_THR", f_c, "norm", "float", t_c),
        FailsafeParameter("BAT_EMERGEN_THR", f_e, "norm", "float", t_e),
        FailsafeParameter("COM_LOW_BAT_ACT", 3, "", "int",
                          f"3 = {crit['action']} at the critical level ({crit['does']}), "
                          f"{emerg['action']} at the emergency level ({emerg['does']})")]
    if release.hold_param:
        params.append(FailsafeParameter(
            release.hold_param, release.hold_s, "s", "float",
            f"the {label} default (commander_params.c), written so that the hold the "
            "thresholds count is the one flown; a longer hold needs larger thresholds"))
    plan = _plan(inp, "px4", params, crit, emerg, cap_fw * (1.0 - f_c), cap_fw * (1.0 - f_e))
    chosen = "the current stable release" if version is None else "as given"
    plan.firmware_version = f"{label} ({chosen}; the ranges of {release.label()})"
    if v[:2] > PX4_NEWEST_CHECKED:
        plan.warnings.append(f"PX4 {label} is newer than the releases this table was checked "
                             f"against (to v{PX4_NEWEST_CHECKED[0]}.{PX4_NEWEST_CHECKED[1]}): "
                             f"the ranges of {release.label()} are assumed")
    plan.reasons += reasons
    plan.go = plan.go and not reasons
    return plan


def _px4_low(inp, release, label, cap_fw, f_c, point, reasons) -> FailsafeParameter:
    """BAT_LOW_THR: a warning :data:`PX4_WARNING_NOTICE_S` of flight at the power of the
    return's worst point before the return."""
    lo, hi = release.ranges["BAT_LOW_THR"]
    q_notice = float(inp.hold_current_a[point]) * PX4_WARNING_NOTICE_S / AS_PER_MAH
    f = max(_up(f_c + q_notice / cap_fw, 0.01), _up(f_c + 0.01, 0.01))
    text = (f"BAT_CRIT_THR {f_c:g} + {PX4_WARNING_NOTICE_S:.0f} s at the worst point's power "
            f"({q_notice:.0f} mAh) / {cap_fw:.0f} mAh = {f:.2f}")
    rng = f"PX4's [{lo:g}, {hi:g}] ({label})"
    if f < lo:
        return FailsafeParameter("BAT_LOW_THR", lo, "norm", "float",
                                 f"{text}; {f:.2f} is below "
                                 f"{_allowed('BAT_LOW_THR', lo, hi, label)}: set to {lo:g} "
                                 "(an earlier warning)")
    if f <= hi:
        return FailsafeParameter("BAT_LOW_THR", f, "norm", "float",
                                 f"{text}; {f:.2f} is within "
                                 f"{_allowed('BAT_LOW_THR', lo, hi, label)}")
    if hi > f_c:
        return FailsafeParameter("BAT_LOW_THR", hi, "norm", "float",
                                 f"{text}; {f:.2f} is above "
                                 f"{_allowed('BAT_LOW_THR', lo, hi, label)}: set to its "
                                 f"maximum {hi:g}, so the warning comes less than a minute "
                                 "before the return")
    reasons.append(f"BAT_LOW_THR must lie above BAT_CRIT_THR {f_c:.2f} but {rng} allows at "
                   f"most {hi:g}")
    return FailsafeParameter("BAT_LOW_THR", f, "norm", "float",
                             f"{text}; {f:.2f} is above "
                             f"{_allowed('BAT_LOW_THR', lo, hi, label)}: NO-GO")


def _px4_pack_parameters(inp: _Inputs, cap_fw: float) -> list[FailsafeParameter]:
    """BAT1_CAPACITY, BAT1_N_CELLS, BAT1_V_EMPTY, BAT1_V_CHARGED, BAT1_R_INTERNAL."""
    pack, cells = inp.pack, inp.pack.cells_series
    soc_empty = min(max(inp.base / inp.cap, 0.0), 1.0)
    out = [FailsafeParameter("BAT1_CAPACITY", cap_fw, "mAh", "float",
                             f"usable {inp.usable:.0f} − reserve {inp.reserve:.0f} mAh, "
                             "rounded down to 50 mAh: PX4's 0 % is the landing reserve, and "
                             "its thresholds count the charge above it"),
           FailsafeParameter("BAT1_N_CELLS", cells, "", "int",
                             f"{cells} cells in series (pack file)"),
           FailsafeParameter("BAT1_V_EMPTY", _up(float(inp.ocv(soc_empty)), 0.01), "V",
                             "float", f"resting cell voltage at the landing reserve "
                                      f"({100 * soc_empty:.1f} % of nominal charge left) on "
                                      f"{inp.ocv_source}, rounded up to 0.01 V"),
           FailsafeParameter("BAT1_V_CHARGED", _down(float(inp.ocv(1.0)), 0.01), "V",
                             "float", f"resting voltage of a full cell on {inp.ocv_source}, "
                                      "rounded down to 0.01 V")]
    if inp.r_pack is None:
        out.append(FailsafeParameter("BAT1_R_INTERNAL", -1.0, "Ω", "float",
                                     "-1: the pack file gives no resistance (PX4 then "
                                     "estimates it in flight)"))
        return out
    r_cell = inp.r_pack * pack.cells_parallel * pack.count / cells
    if r_cell > PX4_R_MAX_OHM:
        inp.warnings.append(f"cell resistance {r_cell:.3f} Ω is above PX4's "
                            f"{PX4_R_MAX_OHM} Ω limit: BAT1_R_INTERNAL set to the limit")
    out.append(FailsafeParameter("BAT1_R_INTERNAL", round(min(r_cell, PX4_R_MAX_OHM), 4),
                                 "Ω", "float",
                                 f"pack {inp.r_pack * 1000:.1f} mΩ × "
                                 f"{pack.cells_parallel * pack.count} parallel / {cells} "
                                 "series, per cell"))
    return out


# --------------------------------------------------------------------------- assembly

def _plan(inp: _Inputs, firmware, params, first, second, trigger_drawn, second_drawn
          ) -> FailsafePlan:
    """The plan of two levels; warns where the mission itself crosses the first one."""
    ret = inp.charges["return"]
    q_return, j, _ = _worst(inp, ret)
    land = inp.charges["land_here"]
    levels = [{key: lv[key] for key in ("name", "action", "value", "charge_mah", "where")}
              for lv in (first, second)]
    plan = FailsafePlan(firmware=firmware, parameters=params, worst_point=_where(inp, j),
                        return_charge_mah=q_return,
                        descent_charge_mah=float(np.max(land)) if land.size else 0.0,
                        low_remaining_mah=inp.cap - trigger_drawn,
                        critical_remaining_mah=inp.cap - second_drawn,
                        return_source=inp.source, levels=levels,
                        warnings=list(inp.warnings))
    if plan.low_remaining_mah > inp.usable:
        plan.go = False
        plan.reasons.append(f"the first level needs {plan.low_remaining_mah:.0f} mAh left, "
                            f"more than the {inp.usable:.0f} mAh the pack can give: the "
                            "failsafe would fire at take-off")
    drawn = inp.result.detail["charge_end_mah"][inp.i]
    crossed = np.flatnonzero(drawn > trigger_drawn)
    if plan.go and crossed.size and crossed[0] < len(drawn) - 1:
        k = int(crossed[0])
        origin = inp.result.table.origin[k] or f"leg {k + 1}"
        plan.warnings.append(f"the first failsafe level ({trigger_drawn:.0f} mAh drawn) is "
                             f"reached by the end of {origin} (t = "
                             f"{inp.result.table.end_time_s[k]:.0f} s), before the mission "
                             "ends: the failsafe will bring the aircraft home early")
    return plan


#: The derivation of each firmware (:data:`ACTIONS` gives the vehicle type's actions).
DERIVATIONS = {"ardupilot": _ardupilot_parameters, "px4": _px4_parameters}


def failsafe_parameters(result, firmware: str, i: int = 0, *, return_charge_mah=None,
                        firmware_version=None) -> FailsafePlan:
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
    firmware_version : str or tuple, optional
        PX4 release whose ranges and hold apply (default :data:`PX4_STABLE_VERSION`).

    Returns
    -------
    FailsafePlan
        ``go`` False (with ``reasons``) where no value the firmware accepts lands with the
        reserve.
    """
    if firmware not in FIRMWARES:
        raise InputError(f"firmware must be one of {', '.join(FIRMWARES)}, got {firmware!r}")
    if result.detail is None or "rtl_point_charge_mah" not in result.detail:
        raise ValueError("failsafe_parameters needs a chain result run with detail=True")
    inp = _inputs(result, i, return_charge_mah)
    return DERIVATIONS[firmware](inp, firmware_version)
