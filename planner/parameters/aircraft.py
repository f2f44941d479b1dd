"""Aircraft definitions: parameters of the power models and their file (docs/formats.md).

:func:`load_aircraft` is the one reader of aircraft files; :func:`load_aircraft_and_battery`
also reads the pack the aircraft names. Every file is validated when it is loaded and
every problem is reported at once in one line naming the file and the key. The tables
``AIRCRAFT_KEYS``, ``FIXED_WING_KEYS`` and ``MULTIROTOR_KEYS`` declare each key once (type,
unit, bound from :mod:`planner.physics.limits`, default, meaning): they validate the file,
give the dataclasses their defaults and print the tables of ``docs/formats.md``.
``POWER_MODEL_KEYS`` lists the keys each multirotor power model needs. :class:`Aircraft`
methods stay thin: they pass the stored parameters to the pure power models of
:mod:`planner.physics.power`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from planner.errors import InputError
from planner.io import files
from planner.io import schema as S
from planner.parameters.pack import BatteryPack, load_battery
from planner.physics import limits as L
from planner.physics.atmosphere import G as G0
from planner.physics.power.efficiency import load_dependent_battery_power
from planner.physics.power.fixed_wing import min_loiter_radius
from planner.physics.power.momentum import DEFAULT_FIGURE_OF_MERIT

__all__ = ["AIRCRAFT_KEYS", "FIXED_WING_KEYS", "MULTIROTOR_KEYS", "NAVIGATION_DEFAULTS",
           "NAVIGATION_KEYS", "Aircraft", "FixedWing", "Multirotor", "Navigation", "aircraft_from_mapping", "default_battery_path", "load_aircraft",
           "load_aircraft_and_battery"]

AIRCRAFT_TYPES = ("fixed_wing", "multirotor")

#: Default vertical speeds when the aircraft file gives none. [m/s]
#: Multirotor: ArduCopter WPNAV_SPEED_UP 2.5 m/s and WPNAV_SPEED_DN 1.5 m/s;
#: fixed-wing: a gentle 2 m/s spiral climb and descent.
DEFAULT_VERTICAL_SPEEDS = {"multirotor": (2.5, 1.5), "fixed_wing": (2.0, 2.0)}

_CLIMB = ", ".join(f"{kind.replace('_', '-')} {up:g}" for kind, (up, _) in
                   DEFAULT_VERTICAL_SPEEDS.items())
_DESCENT = ", ".join(f"{kind.replace('_', '-')} {down:g}" for kind, (_, down) in
                     DEFAULT_VERTICAL_SPEEDS.items())

AIRCRAFT_KEYS = {
    "name": S.text("name shown in the reports", required=True),
    "type": S.text("`fixed_wing` or `multirotor`: which block below holds the power model",
                   required=True, choices=AIRCRAFT_TYPES),
    "empty_mass_kg": S.positive(required=True, high=L.MASS_MAX_KG, unit="kg",
                                meaning="everything but battery and payload"),
    "battery": S.text("default pack file, relative to the aircraft file"),
    "efficiency": S.share(L.EFFICIENCY_MIN, 1.0, required=True, meaning=(
        "η, battery power to useful mechanical power (motors, ESCs and propellers; with "
        "`fixed_wing.propeller_diameter_m` motors and ESCs only; not read by "
        "`power_model: rotor_losses`)")),
    "system_power_w": S.non_negative(default=0.0, high=L.POWER_MAX_W, unit="W", meaning=(
        "avionics and payload load P_S; for `rotor_losses` the power with the rotors "
        "stopped")),
    "climb_rate_ms": S.positive(high=L.VERTICAL_SPEED_MAX_MS, unit="m/s", meaning=(
        f"default climb speed (absent: {_CLIMB} m/s)")),
    "descent_rate_ms": S.positive(high=L.VERTICAL_SPEED_MAX_MS, unit="m/s", meaning=(
        f"default descent speed (absent: {_DESCENT} m/s)")),
    "max_takeoff_mass_kg": S.positive(high=L.MASS_MAX_KG, unit="kg",
                                      meaning="heaviest take-off the aircraft is rated for"),
    "efficiency_slope": S.between(-L.EFFICIENCY_SLOPE_MAX, L.EFFICIENCY_SLOPE_MAX, default=0.0,
                                  meaning=(
        "η1, change of η per relative change of the mechanical power at the reference "
        "(fitted by `endurance diagnose`; 0: constant η)")),
    "efficiency_reference_power_w": S.between(L.REFERENCE_POWER_MIN_W, L.POWER_MAX_W, unit="W",
                                              meaning=(
        "M_ref, mechanical power at which η = `efficiency` (with `efficiency_slope`)")),
    "cells_series_allowed": S.Key(S.LIST, meaning=(
        "cell counts the aircraft's ESCs take (a list of whole numbers, for `select`)")),
    "fixed_wing": S.block("the fixed-wing parameters (table below)"),
    "multirotor": S.block("the multirotor parameters (table below)"),
    "navigation": S.block("how the autopilot flies the plan: take-off, acceleration and "
                          "stops at waypoints, landing (table below; absent: legs at "
                          "constant speed)"),
    "source": S.text("where the numbers come from"),
    "fit_status": S.text("what `fit-aircraft` said of its fit: `ok`, or `misfit: <parameter> …` "
                         "(read, not used)"),
    "energy_error_sd": S.share(0.0, L.ENERGY_ERROR_SD_MAX, meaning=(
        "spread of the model's whole-flight energy error, a fraction (0.05 = 5 %): the root "
        "mean square of (predicted − measured) / measured energy over the flights "
        "`fit-aircraft` trained on; the uncertainty of `endurance check` draws a power "
        "error with it (absent: a documented default)")),
}

FIXED_WING_KEYS = {
    "wing_area_m2": S.between(L.WING_AREA_MIN_M2, L.WING_AREA_MAX_M2, required=True, unit="m²",
                              meaning="wing reference area S"),
    "cd0": S.positive(required=True, high=L.CD0_MAX,
                      meaning="zero-lift drag coefficient C_D0 of the polar"),
    "k": S.positive(high=L.INDUCED_DRAG_FACTOR_MAX,
                    meaning="induced-drag factor K of the polar"),
    "aspect_ratio": S.between(L.ASPECT_RATIO_MIN, L.ASPECT_RATIO_MAX,
                              meaning="aspect ratio AR, for K = 1/(π e AR) without `k`"),
    "oswald_efficiency": S.share(L.OSWALD_EFFICIENCY_MIN, 1.0,
                                 meaning="Oswald efficiency e, with `aspect_ratio`"),
    "cruise_airspeed_ms": S.between(L.AIRSPEED_MIN_MS, L.SPEED_MAX_MS, required=True, unit="m/s",
                                    meaning="default true airspeed; above the stall speed"),
    "stall_speed_ms": S.between(L.AIRSPEED_MIN_MS, L.SPEED_MAX_MS, unit="m/s", meaning=(
        "least airspeed of level flight (absent: half the cruise airspeed)")),
    "max_airspeed_ms": S.between(L.AIRSPEED_MIN_MS, L.SPEED_MAX_MS, unit="m/s", meaning=(
        "highest airspeed flown (absent: 1.5 × cruise)")),
    # at least min_loiter_radius() of the loiter airspeed and stall speed (_fixed_wing);
    # the default is widened to it when the aircraft is too fast to turn that tight
    "loiter_radius_m": S.positive(default=60.0, high=L.LOITER_RADIUS_MAX_M, unit="m", meaning=(
        f"loiter circle; at least a level turn at {L.LOITER_BANK_MAX_DEG:g}° of bank (the "
        "default is widened to it)")),
    "loiter_airspeed_ms": S.between(L.AIRSPEED_MIN_MS, L.SPEED_MAX_MS, unit="m/s",
                                    meaning="airspeed of a loiter (absent: cruise)"),
    # the propulsive-efficiency curve (planner.physics.power.propeller): with a propeller
    # diameter the shaft power is T V + κ T v_i + P0 and ``efficiency`` is the motor and ESC's
    "propeller_diameter_m": S.between(L.ROTOR_DIAMETER_MIN_M, L.ROTOR_DIAMETER_MAX_M, unit="m",
                                      meaning=(
        "propeller diameter: turns on the propulsive-efficiency curve (shaft power "
        "T V + κ T v_i + P0)")),
    "propellers": S.count(L.PROPELLERS_MAX, default=1, meaning="number of propellers"),
    "propeller_induced_factor": S.between(1.0, L.PROPELLER_INDUCED_FACTOR_MAX, default=1.15,
                                          meaning="κ of the propellers' induced power"),
    "propeller_profile_power_w": S.non_negative(default=0.0, high=L.POWER_MAX_W, unit="W",
                                                meaning="P0, profile power of the propellers"),
}

MULTIROTOR_KEYS = {
    "rotors": S.count(L.ROTORS_MAX, required=True, meaning="number of rotors"),
    "rotor_diameter_m": S.between(L.ROTOR_DIAMETER_MIN_M, L.ROTOR_DIAMETER_MAX_M, required=True,
                                  unit="m", meaning="rotor (propeller) diameter"),
    "ct": S.between(L.CT_MIN, L.CT_MAX, meaning=(
        "static thrust coefficient C_T = T/(ρ n² D⁴), n in rev/s (`propeller` model)")),
    "cp": S.between(L.CP_MIN, L.CP_MAX, meaning=(
        "static power coefficient C_P = P/(ρ n³ D⁵) (`propeller` model)")),
    "drag_area_m2": S.non_negative(default=0.0, high=L.DRAG_AREA_MAX_M2, unit="m²",
                                   meaning="body drag area f = C_D A"),
    "tilt_drag_area_m2": S.non_negative(high=L.DRAG_AREA_MAX_M2, unit="m²", meaning=(
        "drag area f_t the rotor disks' forward tilt balances in steady flight "
        "(T sin α = ½ρV²f_t), read by `fit-aircraft` from flights with the axial speed "
        "(`momentum`, `rotor_losses`): where given, a flight state without a measured axial "
        "speed is flown at the disks' velocities this tilt gives, as a record with one is, "
        "and `drag_area_m2` is the drag the tilt does not show")),
    "power_model": S.text("`propeller` (needs `ct`, `cp`), `momentum` or `rotor_losses`; "
                          "absent: `propeller` when `ct` and `cp` are given, else `momentum`",
                          choices=("propeller", "momentum", "rotor_losses")),
    "cruise_speed_ms": S.between(L.GROUNDSPEED_MIN_MS, L.SPEED_MAX_MS, default=5.0, unit="m/s",
                                 meaning="default ground speed"),
    "max_airspeed_ms": S.between(L.AIRSPEED_MIN_MS, L.SPEED_MAX_MS, default=15.0, unit="m/s",
                                 meaning="highest airspeed flown"),
    "induced_factor": S.between(1.0, L.ROTOR_INDUCED_FACTOR_MAX, default=1.15,
                                meaning="κ, induced power over the ideal of momentum theory"),
    "figure_of_merit": S.share(L.FIGURE_OF_MERIT_MIN, 1.0, meaning=(
        "hover figure of merit FM, ideal over actual rotor power: profile power "
        f"P0/P_ideal = 1/FM − κ (absent: {DEFAULT_FIGURE_OF_MERIT:g}, small fixed-pitch "
        "propellers)")),
    "descent_inflow_weight": S.between(
        L.DESCENT_INFLOW_WEIGHT_MIN, L.DESCENT_INFLOW_WEIGHT_MAX, default=0.0, meaning=(
        "w, weight of momentum theory's inflow against Leishman's vortex-ring curve in slow "
        "axial descent (`momentum`, `rotor_losses`): 0 Leishman's curve (the power stays "
        "near hover's), 1 momentum theory (it falls by half of W·|V_c|), 2 nearly the whole "
        "W·|V_c|, −1 it rises; fitted by `fit-aircraft` on flights with vertical "
        "descents")),
    "tip_speed_ms": S.between(L.TIP_SPEED_MIN_MS, L.TIP_SPEED_MAX_MS, unit="m/s", meaning=(
        "hover tip speed, for the profile power's growth with speed (absent: from the "
        "thrust)")),
    "max_thrust_n": S.positive(high=L.THRUST_MAX_N, unit="N", meaning=(
        "total static thrust at full throttle (thrust-to-weight checks)")),
    # power_model rotor_losses (planner.physics.power.rotor_losses): motor losses at the
    # reference hover, the drive efficiency between pack and motors, and the log's power lead
    "no_load_power_w": S.non_negative(default=0.0, high=L.POWER_MAX_W, unit="W", meaning=(
        "motors' no-load loss at the reference hover (`rotor_losses`)")),
    "copper_loss_power_w": S.non_negative(default=0.0, high=L.POWER_MAX_W, unit="W", meaning=(
        "motors' copper loss I²R at the reference hover (`rotor_losses`)")),
    "drive_efficiency": S.share(L.DRIVE_EFFICIENCY_MIN, 1.0, default=0.95, meaning=(
        "ESCs and wiring, battery to motor terminals (`rotor_losses`)")),
    "reference_mass_kg": S.positive(high=L.MASS_MAX_KG, unit="kg", meaning=(
        "mass of the reference hover of the losses (`rotor_losses`; absent: the flown "
        "mass)")),
    "power_lead_s": S.between(0.0, L.POWER_LEAD_MAX_S, default=0.0, unit="s", meaning=(
        "delay of a log's power channel behind its flight state (`rotor_losses` fits)")),
}

#: The autopilots whose navigation defaults :meth:`Navigation.defaults` knows.
AUTOPILOTS = ("arducopter-4.1", "px4", "dji")

NAVIGATION_KEYS = {
    "defaults": S.text("start from an autopilot's defaults (`arducopter-4.1`, `px4`, `dji`); "
                       "the keys given override them", choices=AUTOPILOTS),
    "takeoff_spinup_s": S.between(0.0, L.NAV_WAIT_MAX_S, unit="s", meaning=(
        "motors turning on the ground before lift-off")),
    "climb_rate_ms": S.positive(high=L.VERTICAL_SPEED_MAX_MS, unit="m/s", meaning=(
        "climb speed of take-offs and climbs (a leg's own rate overrides it)")),
    "descent_rate_ms": S.positive(high=L.VERTICAL_SPEED_MAX_MS, unit="m/s", meaning=(
        "descent speed, down to `landing_slow_height_m` when landing")),
    "landing_slow_height_m": S.between(0.0, L.LANDING_SLOW_HEIGHT_MAX_M, unit="m", meaning=(
        "height above the ground below which a landing slows down")),
    "landing_descent_rate_ms": S.positive(high=L.VERTICAL_SPEED_MAX_MS, unit="m/s", meaning=(
        "descent speed of the landing's last `landing_slow_height_m`")),
    "horizontal_accel_ms2": S.positive(high=L.NAV_ACCEL_MAX_MS2, unit="m/s²", meaning=(
        "acceleration limit A of straight legs")),
    "horizontal_jerk_ms3": S.positive(high=L.NAV_JERK_MAX_MS3, unit="m/s³", meaning=(
        "jerk limit J of straight legs")),
    "horizontal_brake_accel_ms2": S.positive(high=L.NAV_ACCEL_MAX_MS2, unit="m/s²", meaning=(
        "deceleration limit of straight legs where it differs from the acceleration's "
        "(absent: `horizontal_accel_ms2`)")),
    "horizontal_brake_jerk_ms3": S.positive(high=L.NAV_JERK_MAX_MS3, unit="m/s³", meaning=(
        "jerk limit of the slowing down where it differs (absent: `horizontal_jerk_ms3`)")),
    "vertical_accel_ms2": S.positive(high=L.NAV_ACCEL_MAX_MS2, unit="m/s²", meaning=(
        "vertical acceleration limit of climbs")),
    "stop_at_waypoints": S.Key(S.BOOL, meaning=(
        "`true`: the vehicle stops at every waypoint (rest-to-rest legs); `false`: it "
        "flies through them at speed")),
    "waypoint_dwell_s": S.between(0.0, L.NAV_WAIT_MAX_S, unit="s", meaning=(
        "hover at each waypoint stop")),
    "source": S.text("where the values come from"),
}

#: Navigation defaults per autopilot, SI, each value with where it comes from.
NAVIGATION_DEFAULTS: dict[str, dict[str, tuple[Any, str]]] = {
    "arducopter-4.1": {
        "takeoff_spinup_s": (0.5, "MOT_SPOOL_TIME 0.5 s (libraries/AP_Motors/"
                                  "AP_MotorsMulticopter.h AP_MOTORS_SPOOL_UP_TIME_DEFAULT)"),
        "climb_rate_ms": (2.5, "WPNAV_SPEED_UP 250 cm/s (libraries/AC_WPNav/AC_WPNav.h)"),
        "descent_rate_ms": (1.5, "LAND_SPEED_HIGH 0 → WPNAV_SPEED_DN 150 cm/s "
                                 "(ArduCopter/Parameters.cpp, AC_WPNav.h)"),
        "landing_slow_height_m": (10.0, "LAND_ALT_LOW 1000 cm (ArduCopter/Parameters.cpp)"),
        "landing_descent_rate_ms": (0.5, "LAND_SPEED 50 cm/s (ArduCopter/config.h)"),
        "horizontal_accel_ms2": (2.5, "WPNAV_ACCEL 250 cm/s² (AC_WPNav.h, 4.1 and later)"),
        "horizontal_jerk_ms3": (1.0, "WPNAV_JERK 1 m/s³ (AC_WPNav.cpp)"),
        "vertical_accel_ms2": (1.0, "WPNAV_ACCEL_Z 100 cm/s² (AC_WPNav.h)"),
        "stop_at_waypoints": (False, "waypoints without a delay are fast waypoints: the "
                                     "S-curves blend through them (ArduCopter/mode_auto.cpp "
                                     "set_next_wp, libraries/AP_Math/SCurve.cpp)"),
        "waypoint_dwell_s": (0.0, "NAV_WAYPOINT delay (param 1) 0"),
    },
    "px4": {
        "takeoff_spinup_s": (1.0, "COM_SPOOLUP_TIME 1 s (src/modules/commander)"),
        "climb_rate_ms": (3.0, "MPC_Z_V_AUTO_UP 3 m/s (src/modules/mc_pos_control/"
                               "multicopter_autonomous_params.c)"),
        "descent_rate_ms": (1.5, "MPC_Z_V_AUTO_DN 1.5 m/s (multicopter_autonomous_params.c)"),
        "landing_slow_height_m": (5.0, "MPC_LAND_ALT2 5 m (multicopter_takeoff_land_params.c; "
                                       "FlightTaskAuto.cpp ramps from MPC_LAND_ALT1 10 m)"),
        "landing_descent_rate_ms": (0.7, "MPC_LAND_SPEED 0.7 m/s "
                                         "(multicopter_takeoff_land_params.c)"),
        "horizontal_accel_ms2": (3.0, "MPC_ACC_HOR 3 m/s² (multicopter_autonomous_params.c)"),
        "horizontal_jerk_ms3": (4.0, "MPC_JERK_AUTO 4 m/s³ (multicopter_autonomous_params.c)"),
        "vertical_accel_ms2": (4.0, "MPC_ACC_UP_MAX 4 m/s² (mc_pos_control params)"),
        "stop_at_waypoints": (False, "corners flown at √(MPC_XY_TRAJ_P·MPC_ACC_HOR·"
                                     "NAV_ACC_RAD·tan(α/2)) (src/lib/motion_planning/"
                                     "TrajectoryConstraints.hpp): not a stop"),
        "waypoint_dwell_s": (0.0, "mission item hold time 0"),
    },
    "dji": {
        # measured: planner.identify.navigation_fit.fit_navigation on the 182 route-R1
        # flights of the DJI Matrice 100 of Rodrigues et al. (Sci. Data 8, 155, 2021,
        # doi:10.1184/R1/12683453; ../shared/data/energy, column map dji_m100): medians,
        # counts of flights or events in each text. DJI publishes no waypoint
        # acceleration or jerk limit.
        "takeoff_spinup_s": (4.0, "measured, M100: 170 flights (power above 20 % of "
                                  "airborne, to the 1 m lift-off, less the rise)"),
        "climb_rate_ms": (2.98, "measured, M100: 182 flights"),
        "descent_rate_ms": (2.80, "measured, M100: 138 flights descending from above the "
                                  "slow height"),
        "landing_slow_height_m": (24.0, "measured, M100: 138 flights"),
        "landing_descent_rate_ms": (1.03, "measured, M100: 180 flights"),
        "horizontal_accel_ms2": (2.03, "measured, M100: 523 starts from rest"),
        "horizontal_jerk_ms3": (1.65, "measured, M100: 523 starts from rest"),
        "horizontal_brake_accel_ms2": (3.78, "measured, M100: 523 stops"),
        "horizontal_brake_jerk_ms3": (2.95, "measured, M100: 523 stops"),
        "vertical_accel_ms2": (0.94, "measured, M100: 182 climbs"),
        "stop_at_waypoints": (True, "measured: the M100 stops at every route vertex (the "
                                    "OSDK waypoint traceMode 0, point to point: "
                                    "dji-sdk/Onboard-SDK dji_mission_type.hpp)"),
        "waypoint_dwell_s": (0.34, "measured, M100: 341 rests between moves"),
    },
}

_NAV_FIELDS = tuple(k for k in NAVIGATION_KEYS if k not in ("defaults", "source"))
#: Navigation keys a block may leave out (None: :attr:`Navigation.brake_limits` falls back
#: to the acceleration's).
_NAV_OPTIONAL = ("horizontal_brake_accel_ms2", "horizontal_brake_jerk_ms3")


@dataclass(frozen=True)
class Navigation:
    """How the autopilot flies a plan (the ``navigation:`` block): each field is the key
    of :data:`NAVIGATION_KEYS` of that name (SI; unit and meaning there). The chain
    (:func:`planner.chain.kinematics.leg_table`) flies a multirotor's legs with it
    (:mod:`planner.physics.motion`)."""

    takeoff_spinup_s: float
    climb_rate_ms: float
    descent_rate_ms: float
    landing_slow_height_m: float
    landing_descent_rate_ms: float
    horizontal_accel_ms2: float
    horizontal_jerk_ms3: float
    vertical_accel_ms2: float
    stop_at_waypoints: bool
    waypoint_dwell_s: float
    source: str | None = None
    horizontal_brake_accel_ms2: float | None = None
    horizontal_brake_jerk_ms3: float | None = None

    @property
    def brake_limits(self) -> tuple[float, float]:
        """Deceleration [m/s²] and jerk [m/s³] limits of the slowing down of straight legs
        (the acceleration's where the block gives none)."""
        return (self.horizontal_brake_accel_ms2 or self.horizontal_accel_ms2,
                self.horizontal_brake_jerk_ms3 or self.horizontal_jerk_ms3)

    @classmethod
    def defaults(cls, autopilot: str) -> Navigation:
        """The defaults of ``autopilot`` (:data:`AUTOPILOTS`), their sources in ``source``
        (DJI's are measured on the M100 flights: DJI publishes none)."""
        if autopilot not in NAVIGATION_DEFAULTS:
            raise ValueError(f"unknown autopilot {autopilot!r}; expected one of "
                             + ", ".join(AUTOPILOTS))
        table = NAVIGATION_DEFAULTS[autopilot]
        cited = "; ".join(f"{k}: {why}" for k, (_, why) in table.items())
        return cls(**{k: v for k, (v, _) in table.items()},
                   source=f"{autopilot} defaults ({cited})")

    def to_mapping(self) -> dict[str, Any]:
        """The block as a YAML-ready mapping (the keys of :data:`NAVIGATION_KEYS`)."""
        out: dict[str, Any] = {k: (bool(v) if isinstance(v, (bool, np.bool_)) else float(v))
                               for k in _NAV_FIELDS for v in [getattr(self, k)]
                               if v is not None}
        if self.source:
            out["source"] = self.source
        return out


#: Keys of MULTIROTOR_KEYS only the rotor_losses power model reads.
ROTOR_LOSSES_KEYS = ("no_load_power_w", "copper_loss_power_w", "drive_efficiency",
                     "reference_mass_kg", "power_lead_s")

#: Keys of MULTIROTOR_KEYS only some power models read, and which: a file giving one to
#: another model is refused, and the object holds None there (written back without it).
MODEL_ONLY_KEYS = {**{key: ("rotor_losses",) for key in ROTOR_LOSSES_KEYS},
                   "descent_inflow_weight": ("momentum", "rotor_losses"),
                   "tilt_drag_area_m2": ("momentum", "rotor_losses")}

#: Keys each multirotor power model needs (besides rotors and diameter).
POWER_MODEL_KEYS = {"propeller": ("ct", "cp"), "momentum": (), "rotor_losses": ()}

_FW = S.defaults(FIXED_WING_KEYS)
_MR = S.defaults(MULTIROTOR_KEYS)
_AC = S.defaults(AIRCRAFT_KEYS)


@dataclass(frozen=True)
class FixedWing:
    """Fixed-wing parameters: drag polar ``C_D = C_D0 + K C_L²`` and the propulsion.

    Each field is the key of :data:`FIXED_WING_KEYS` of that name (unit and meaning
    there; defaults from there); ``k`` is computed from ``aspect_ratio`` and
    ``oswald_efficiency`` where the file gives those instead.
    """

    wing_area_m2: float
    cd0: float
    k: float
    cruise_airspeed_ms: float
    stall_speed_ms: float | None = None
    max_airspeed_ms: float | None = None
    loiter_radius_m: float = _FW["loiter_radius_m"]
    loiter_airspeed_ms: float | None = None
    propeller_diameter_m: float | None = None
    propellers: int = _FW["propellers"]
    propeller_induced_factor: float = _FW["propeller_induced_factor"]
    propeller_profile_power_w: float = _FW["propeller_profile_power_w"]

    @property
    def top_airspeed_ms(self) -> float:
        """Highest airspeed the aircraft flies (default 1.5 × cruise). [m/s]"""
        return self.max_airspeed_ms or 1.5 * self.cruise_airspeed_ms


@dataclass(frozen=True)
class Multirotor:
    """Multirotor parameters (propeller-coefficient, momentum and rotor-loss models).

    Each field is the key of :data:`MULTIROTOR_KEYS` of that name (unit and meaning
    there; defaults from there). ``power_model`` is always set (inferred when the file
    leaves it out); the keys of :data:`MODEL_ONLY_KEYS` are None unless it is one of the
    models that read them.
    """

    rotors: int
    rotor_diameter_m: float
    power_model: str
    ct: float | None = None
    cp: float | None = None
    drag_area_m2: float = _MR["drag_area_m2"]
    tilt_drag_area_m2: float | None = None
    cruise_speed_ms: float = _MR["cruise_speed_ms"]
    max_airspeed_ms: float = _MR["max_airspeed_ms"]
    induced_factor: float = _MR["induced_factor"]
    figure_of_merit: float | None = None
    tip_speed_ms: float | None = None
    descent_inflow_weight: float | None = _MR["descent_inflow_weight"]
    max_thrust_n: float | None = None
    no_load_power_w: float | None = None
    copper_loss_power_w: float | None = None
    drive_efficiency: float | None = None
    reference_mass_kg: float | None = None
    power_lead_s: float | None = None


@dataclass(frozen=True)
class Aircraft:
    """An aircraft (``docs/formats.md``) without its battery and payload.

    Each field but ``battery_path`` (the key ``battery``) and ``path`` (the file it was
    read from) is the key of :data:`AIRCRAFT_KEYS` of that name: unit and meaning there,
    defaults from there. The climb and descent rates default to a multirotor's
    (:data:`DEFAULT_VERTICAL_SPEEDS`); a file without them gets its type's.
    """

    name: str
    type: str
    empty_mass_kg: float
    efficiency: float
    system_power_w: float = _AC["system_power_w"]
    climb_rate_ms: float = DEFAULT_VERTICAL_SPEEDS["multirotor"][0]
    descent_rate_ms: float = DEFAULT_VERTICAL_SPEEDS["multirotor"][1]
    battery_path: str | None = None
    max_takeoff_mass_kg: float | None = None
    efficiency_slope: float = _AC["efficiency_slope"]
    efficiency_reference_power_w: float | None = None
    cells_series_allowed: tuple[int, ...] | None = None
    fixed_wing: FixedWing | None = None
    multirotor: Multirotor | None = None
    source: str | None = None
    energy_error_sd: float | None = None
    path: str | None = None
    navigation: Navigation | None = None

    @property
    def is_multirotor(self) -> bool:
        """Whether the aircraft is a multirotor (else fixed-wing)."""
        return self.type == "multirotor"

    @property
    def cruise_speed_ms(self) -> float:
        """Default horizontal speed (multirotor: ground speed; fixed-wing: airspeed). [m/s]"""
        return (self.multirotor.cruise_speed_ms if self.is_multirotor
                else self.fixed_wing.cruise_airspeed_ms)

    @property
    def max_airspeed_ms(self) -> float:
        """Highest airspeed the aircraft flies. [m/s]"""
        return (self.multirotor.max_airspeed_ms if self.is_multirotor
                else self.fixed_wing.top_airspeed_ms)

    def heaviest_takeoff(self) -> tuple[float, str]:
        """The heaviest take-off this aircraft could make and what bounds it (kg, text):
        its maximum take-off mass, else the mass its rotor disks or its wing could lift at
        the highest loading of its class (:func:`heaviest_takeoff_kg`). A mass a user gives
        beyond it is in another unit."""
        block = self.multirotor if self.is_multirotor else self.fixed_wing
        return heaviest_takeoff_kg(self.type, block, self.max_takeoff_mass_kg)

    @property
    def has_rotor_losses(self) -> bool:
        """A multirotor flown by the ``rotor_losses`` power model
        (:mod:`planner.physics.power.rotor_losses`): its motor losses replace ``efficiency``
        and ``efficiency_slope``."""
        return self.is_multirotor and self.multirotor.power_model == "rotor_losses"

    @property
    def efficiency_key(self) -> str:
        """The parameter by which the power model divides everything the propulsion
        draws: ``drive_efficiency`` for the ``rotor_losses`` model (which does not read
        ``efficiency``), else ``efficiency``. A recalibration that scales the power model
        sets this one."""
        if self.has_rotor_losses:
            return "drive_efficiency"
        return "efficiency"

    @property
    def power_efficiency(self) -> float:
        """The value of :attr:`efficiency_key`. [unitless]"""
        if self.efficiency_key == "drive_efficiency":
            return self.multirotor.drive_efficiency
        return self.efficiency

    @property
    def min_airspeed_ms(self) -> float:
        """Least airspeed of steady flight. [m/s]

        Fixed-wing: the stall speed, else half the cruise airspeed. Multirotor:
        :data:`planner.physics.limits.MULTIROTOR_MIN_AIRSPEED_MS` (it hovers; the bound
        keeps the best-speed searches away from zero).
        """
        if self.is_multirotor:
            return L.MULTIROTOR_MIN_AIRSPEED_MS
        fw = self.fixed_wing
        return fw.stall_speed_ms or 0.5 * fw.cruise_airspeed_ms

    def battery_power(self, airspeed, climb_rate, air_density, mass, load_factor=1.0,
                      thrust=None, disk_frame=False):
        """Electric power drawn from the pack in steady flight.

        Thin wrapper: passes the stored parameters to the pure power models
        (:mod:`planner.physics.power.fixed_wing`, :mod:`planner.physics.power.multirotor`,
        :mod:`planner.physics.power.momentum`). All arguments broadcast.

        Parameters
        ----------
        airspeed : numeric
            True airspeed (multirotor hovering in wind: the wind speed). [m/s]
        climb_rate : numeric
            Vertical speed, up positive. [m/s]
        air_density : numeric
            [kg m⁻³]
        mass : numeric
            All-up mass. [kg]
        load_factor : numeric
            Lift over weight (turns). [unitless]
        thrust : numeric, optional
            Measured total thrust (mass × accelerometer specific force), read by the
            ``rotor_losses`` model only; default the trim thrust. [N]
        disk_frame : bool or array of bool
            Where true, ``airspeed`` and ``climb_rate`` are already the rotor disks'
            in-plane and axial speed (a record's measured axial speed,
            :meth:`planner.chain.flightstate.FlightState.rotor_velocities`). Elsewhere a
            multirotor with ``tilt_drag_area_m2`` flies the disks' velocities its tilt gives
            (:func:`planner.physics.power.momentum.tilted_disk_velocities`). [unitless]

        Returns
        -------
        power : numeric
            Battery power. [W]
        """
        airspeed, climb_rate = self.disk_velocities(airspeed, climb_rate, air_density, mass,
                                                    load_factor, disk_frame)
        if self.has_rotor_losses:
            return self.rotor_losses_power(airspeed, climb_rate, air_density, mass,
                                           load_factor, thrust=thrust)
        power = self._constant_efficiency_power(airspeed, climb_rate, air_density, mass,
                                                load_factor)
        if not self.efficiency_slope or not self.efficiency_reference_power_w:
            return power
        return load_dependent_battery_power(power, self.efficiency, self.system_power_w,
                                            self.efficiency_slope,
                                            self.efficiency_reference_power_w)

    def disk_velocities(self, airspeed, climb_rate, air_density, mass, load_factor=1.0,
                        disk_frame=False):
        """The speeds the power model flies (:meth:`battery_power`): the rotor disks'
        in-plane and axial speed from the tilt ``tilt_drag_area_m2`` where it is given
        and ``disk_frame`` is false; ``airspeed`` and ``climb_rate`` as they are
        elsewhere (and for a fixed wing). [m/s]"""
        tilt = self.multirotor.tilt_drag_area_m2 if self.is_multirotor else None
        if tilt is None or np.all(disk_frame):
            return airspeed, climb_rate
        from planner.physics.numeric import like_inputs
        from planner.physics.power.momentum import tilted_disk_velocities
        inplane, axial = tilted_disk_velocities(airspeed, climb_rate, air_density, mass,
                                                tilt, load_factor)
        keep = np.asarray(disk_frame, bool)
        return (like_inputs(np.where(keep, airspeed, inplane), airspeed, climb_rate),
                like_inputs(np.where(keep, climb_rate, axial), airspeed, climb_rate))

    def rotor_losses_power(self, airspeed, climb_rate, air_density, mass, load_factor=1.0,
                           thrust=None, rotors_turning=True):
        """Battery power of the ``rotor_losses`` multirotor model
        (:func:`planner.physics.power.rotor_losses.rotor_losses_battery_power`): ``system_power_w``
        is the power with the rotors stopped, ``drive_efficiency`` replaces ``efficiency``.
        The reference hover is at ``reference_mass_kg`` (default: ``mass``). [W]"""
        from planner.physics.power import rotor_losses
        m = self.multirotor
        return rotor_losses.rotor_losses_battery_power(
            mass, air_density, m.rotors, m.rotor_diameter_m, m.drive_efficiency,
            airspeed=airspeed, climb_rate=climb_rate, drag_area=m.drag_area_m2,
            induced_factor=m.induced_factor, figure_of_merit=m.figure_of_merit,
            tip_speed=m.tip_speed_ms, stopped_power=self.system_power_w,
            no_load_power=m.no_load_power_w, copper_loss_power=m.copper_loss_power_w,
            reference_mass=m.reference_mass_kg, thrust=thrust, load_factor=load_factor,
            rotors_turning=rotors_turning, descent_inflow_weight=m.descent_inflow_weight)

    def _constant_efficiency_power(self, airspeed, climb_rate, air_density, mass,
                                   load_factor=1.0):
        if self.is_multirotor:
            m = self.multirotor
            if m.power_model == "propeller":
                from planner.physics.power import multirotor
                return multirotor.propeller_battery_power(
                    mass * load_factor, air_density, m.rotors, m.rotor_diameter_m, m.ct, m.cp,
                    self.efficiency, climb_rate=climb_rate, airspeed=airspeed,
                    drag_area=m.drag_area_m2, system_power=self.system_power_w)
            from planner.physics.power import momentum
            return momentum.momentum_battery_power(
                mass, air_density, m.rotors, m.rotor_diameter_m, self.efficiency,
                airspeed=airspeed, climb_rate=climb_rate, drag_area=m.drag_area_m2,
                induced_factor=m.induced_factor, figure_of_merit=m.figure_of_merit,
                tip_speed=m.tip_speed_ms, system_power=self.system_power_w,
                load_factor=load_factor, descent_inflow_weight=m.descent_inflow_weight)
        from planner.physics.power import fixed_wing
        f = self.fixed_wing
        required = fixed_wing.required_power(airspeed, air_density, mass, f.wing_area_m2, f.cd0,
                                             f.k, climb_rate=climb_rate,
                                             load_factor=load_factor)
        if f.propeller_diameter_m:
            # the propulsive-efficiency curve: thrust T = P_R / V through the propeller
            # model (planner.physics.power.propeller); ``efficiency`` is then the motor and ESC's
            from planner.physics.power import propeller
            v = np.asarray(airspeed, float)
            with np.errstate(invalid="ignore", divide="ignore"):
                thrust = np.where(v > 0.0, np.asarray(required, float) / v, np.nan)
            required = propeller.shaft_power(
                thrust, v, air_density, f.propeller_diameter_m, f.propellers,
                f.propeller_induced_factor, f.propeller_profile_power_w)
        return fixed_wing.battery_power(required, self.efficiency, self.system_power_w)

    def to_mapping(self, folder: str | Path | None = None) -> dict[str, Any]:
        """The aircraft as a YAML-ready mapping (the keys of :data:`AIRCRAFT_KEYS`).

        ``folder``: where the mapping will be written; the ``battery`` path, relative to
        this aircraft's own file, is rewritten relative to it so that the pack is found
        from the new file.
        """
        out: dict[str, Any] = {"name": self.name, "type": self.type,
                               "empty_mass_kg": float(self.empty_mass_kg)}
        if self.battery_path:
            out["battery"] = self.battery_path
            if folder is not None and not Path(self.battery_path).is_absolute():
                pack = default_battery_path(self).resolve()
                out["battery"] = os.path.relpath(pack, Path(folder).resolve())
        out["efficiency"] = float(self.efficiency)
        out["system_power_w"] = float(self.system_power_w)
        out["climb_rate_ms"] = float(self.climb_rate_ms)
        out["descent_rate_ms"] = float(self.descent_rate_ms)
        if self.max_takeoff_mass_kg is not None:
            out["max_takeoff_mass_kg"] = float(self.max_takeoff_mass_kg)
        if self.efficiency_slope and self.efficiency_reference_power_w:
            out["efficiency_slope"] = float(self.efficiency_slope)
            out["efficiency_reference_power_w"] = float(self.efficiency_reference_power_w)
        if self.cells_series_allowed:
            out["cells_series_allowed"] = list(self.cells_series_allowed)
        block = self.multirotor if self.is_multirotor else self.fixed_wing
        out[self.type] = {k: (float(v) if isinstance(v, float) else v)
                          for k, v in block.__dict__.items() if v is not None}
        if not self.is_multirotor and self.fixed_wing.propeller_diameter_m is None:
            for k in ("propellers", "propeller_induced_factor", "propeller_profile_power_w"):
                out[self.type].pop(k, None)
        if self.navigation is not None:
            out["navigation"] = self.navigation.to_mapping()
        if self.source:
            out["source"] = self.source
        if self.energy_error_sd is not None:
            out["energy_error_sd"] = float(self.energy_error_sd)
        return out


def heaviest_takeoff_kg(kind: str, block, max_takeoff_mass_kg: float | None
                        ) -> tuple[float, str]:
    """The heaviest take-off of an aircraft and what bounds it (kg, text): the maximum
    take-off mass where given, else the mass its rotor disks lift at
    :data:`planner.physics.limits.DISK_LOADING_MAX_N_M2` (multirotor) or its wing at
    :data:`planner.physics.limits.WING_LOADING_MAX_N_M2` (fixed wing). [kg]"""
    if max_takeoff_mass_kg is not None:
        return float(max_takeoff_mass_kg), "the aircraft's maximum take-off mass"
    if block is None:
        return L.MASS_MAX_KG, "the heaviest electric UAV"
    if kind == "multirotor":
        disk = block.rotors * math.pi * block.rotor_diameter_m ** 2 / 4.0
        return (L.DISK_LOADING_MAX_N_M2 * disk / G0,
                f"the most its {block.rotors} rotors of {block.rotor_diameter_m:g} m lift")
    return (L.WING_LOADING_MAX_N_M2 * block.wing_area_m2 / G0,
            f"the most its wing of {block.wing_area_m2:g} m² lifts")


def in_grams(value_kg: float, bound_kg: float) -> str:
    """``": grams? (350 g = 0.35 kg)"`` when a mass beyond ``bound_kg`` written in grams
    would be within it, else ``""``."""
    if value_kg / 1000.0 <= bound_kg:
        return f": grams? ({value_kg:g} g = {value_kg / 1000.0:g} kg)"
    return ""


def aircraft_from_mapping(data: Any, where: str) -> Aircraft:
    """Validate an aircraft mapping (:data:`AIRCRAFT_KEYS`, then the block of its type)
    and build the aircraft.

    Raises
    ------
    InputError
        Every problem of the mapping at once, in one line naming ``where`` and each key.
    """
    d, problems = S.check_definition(data, "aircraft", AIRCRAFT_KEYS, where)
    kind = d["type"]
    blocks: dict[str, Any] = {"fixed_wing": None, "multirotor": None}
    if kind in AIRCRAFT_TYPES:
        blocks[kind] = _type_block(d, kind, where, problems)
    allowed = _cells_series_allowed(d["cells_series_allowed"], problems)
    _check_masses(d, kind, blocks.get(kind), problems)
    mr = blocks["multirotor"]
    if (mr is not None and mr.power_model == "rotor_losses" and d["efficiency_slope"]
            and data.get("efficiency_slope") is not None):
        problems.add("efficiency_slope is not used with multirotor.power_model "
                     "rotor_losses (its no-load and copper losses are how the efficiency "
                     "changes with load): remove it")
    nav = (None if d["navigation"] is None
           else _navigation(d["navigation"], where, problems))
    problems.done()
    climb, descent = DEFAULT_VERTICAL_SPEEDS[kind]
    return Aircraft(**S.fields_from(
        Aircraft, d, climb_rate_ms=d["climb_rate_ms"] or climb,
        descent_rate_ms=d["descent_rate_ms"] or descent, battery_path=d["battery"],
        cells_series_allowed=allowed, **blocks, path=where, navigation=nav))


def _navigation(data: Any, where: str, problems: S.Problems) -> Navigation | None:
    """The ``navigation:`` block: an autopilot's defaults (``defaults:``) with the keys
    given on top, else every key."""
    n = len(problems)
    d = S.check_mapping(data, NAVIGATION_KEYS, where, "navigation.", problems)
    if len(problems) > n:
        return None
    base = (Navigation.defaults(d["defaults"]).__dict__ if d["defaults"] else {})
    values = {k: (d[k] if d[k] is not None else base.get(k)) for k in _NAV_FIELDS}
    missing = [k for k, v in values.items() if v is None and k not in _NAV_OPTIONAL]
    if missing:
        problems.add("navigation needs " + ", ".join(f"'navigation.{k}'" for k in missing)
                     + " (or 'navigation.defaults': " + ", ".join(AUTOPILOTS) + ")")
        return None
    source = d["source"] or (base.get("source") if d["defaults"] else None)
    return Navigation(**values, source=source)


def _check_masses(d: dict, kind: str, block, problems: S.Problems) -> None:
    """The empty mass within the heaviest take-off (:func:`heaviest_takeoff_kg`): beyond it
    the mass was written in another unit (grams)."""
    empty, top = d["empty_mass_kg"], d["max_takeoff_mass_kg"]
    if not isinstance(empty, (int, float)) or isinstance(empty, bool) or not empty > 0:
        return
    if not (isinstance(top, (int, float)) and not isinstance(top, bool) and top > 0):
        top = None
    if top is None and block is None:
        return
    bound, what = heaviest_takeoff_kg(kind, block, top)
    if empty > bound:
        key = "max_takeoff_mass_kg" if top is not None else None
        problems.add(f"empty_mass_kg {empty:g} kg is more than {what}"
                     + (f" ({key} {bound:g} kg)" if key else f", {bound:.3g} kg")
                     + (in_grams(empty, bound) or "; expected kg"))


def _type_block(d: dict, kind: str, where: str, problems: S.Problems):
    """The block of the aircraft's type, built (None with its problems recorded)."""
    other = "multirotor" if kind == "fixed_wing" else "fixed_wing"
    if d[other] is not None:
        problems.add(f"'{other}' block given for an aircraft of type '{kind}'")
    if d[kind] is None:
        problems.add(f"missing required key '{kind}' (a mapping of the "
                     f"{kind.replace('_', '-')} parameters)")
        return None
    build = _fixed_wing if kind == "fixed_wing" else _multirotor
    return build(d[kind], where, problems)


def _cells_series_allowed(cells, problems: S.Problems) -> tuple[int, ...] | None:
    """``cells_series_allowed`` as a tuple (None where absent or bad)."""
    if cells is None:
        return None
    if not cells or not all(isinstance(c, int) and not isinstance(c, bool) and c > 0
                            for c in cells):
        problems.add(f"cells_series_allowed must be a list of whole numbers > 0, "
                     f"got {cells!r}")
        return None
    return tuple(cells)


def _fixed_wing(data: Any, where: str, problems: S.Problems) -> FixedWing | None:
    """The ``fixed_wing:`` block, with its checks across keys (speeds, loiter radius)."""
    n = len(problems)
    bad: set[str] = set()
    d = S.check_mapping(data, FIXED_WING_KEYS, where, "fixed_wing.", problems, bad)

    def given(key):  # present and valid on its own: usable in checks across keys
        return d[key] is not None and key not in bad

    k = d["k"]
    if k is None:
        if d["aspect_ratio"] is None or d["oswald_efficiency"] is None:
            problems.add("fixed_wing needs 'k' or both 'aspect_ratio' and "
                         "'oswald_efficiency' (K = 1/(π e AR))")
        elif given("aspect_ratio") and given("oswald_efficiency"):
            from planner.physics.power import fixed_wing
            k = float(fixed_wing.induced_drag_factor(d["aspect_ratio"], d["oswald_efficiency"]))
    elif d["aspect_ratio"] is not None:
        problems.add("fixed_wing: give either 'k' or 'aspect_ratio'/'oswald_efficiency', "
                     "not both")
    stall = d["stall_speed_ms"] if given("stall_speed_ms") else None
    cruise = d["cruise_airspeed_ms"] if given("cruise_airspeed_ms") else None
    top = d["max_airspeed_ms"] if given("max_airspeed_ms") else None
    loiter = d["loiter_airspeed_ms"] if given("loiter_airspeed_ms") else None
    if stall is not None and cruise is not None and cruise <= stall:
        problems.add(f"fixed_wing.cruise_airspeed_ms ({cruise}) must be above "
                     f"stall_speed_ms ({stall})")
    if top is not None and stall is not None and top <= stall:
        problems.add(f"fixed_wing.max_airspeed_ms must be above the stall speed "
                     f"(fixed_wing.stall_speed_ms {stall:g} m/s), got {top!r}")
    elif top is not None and cruise is not None and top < cruise:
        problems.add(f"fixed_wing.max_airspeed_ms must be at least the cruise airspeed "
                     f"(fixed_wing.cruise_airspeed_ms {cruise:g} m/s), got {top!r}")
    if loiter is not None and stall is not None and loiter <= stall:
        problems.add(f"fixed_wing.loiter_airspeed_ms must be above the stall speed "
                     f"(fixed_wing.stall_speed_ms {stall:g} m/s), got {loiter!r}")
    elif loiter is not None and top is not None and loiter > top:
        problems.add(f"fixed_wing.loiter_airspeed_ms must be at most the maximum airspeed "
                     f"(fixed_wing.max_airspeed_ms {top:g} m/s), got {loiter!r}")
    if len(problems) > n:
        return None
    v_loiter = loiter or cruise
    radius = d["loiter_radius_m"]
    r_min = min_loiter_radius(v_loiter, stall)
    if data.get("loiter_radius_m") is None:  # the default circle, widened for a fast aircraft
        radius = max(radius, float(np.ceil(r_min * 10.0)) / 10.0)
    elif radius < r_min:
        above = f", above the stall speed {stall:g} m/s" if stall is not None else ""
        problems.add(f"fixed_wing.loiter_radius_m must be at least {r_min:.1f} m (a level "
                     f"turn at the loiter airspeed {v_loiter:g} m/s with at most "
                     f"{L.LOITER_BANK_MAX_DEG:g}° of bank{above}), got {radius!r}")
        return None
    return FixedWing(**S.fields_from(
        FixedWing, d, k=k, cruise_airspeed_ms=cruise, stall_speed_ms=stall,
        max_airspeed_ms=top, loiter_radius_m=radius, loiter_airspeed_ms=loiter))


def _multirotor(data: Any, where: str, problems: S.Problems) -> Multirotor | None:
    """The ``multirotor:`` block, with its power model inferred and checked."""
    n = len(problems)
    bad: set[str] = set()
    d = S.check_mapping(data, MULTIROTOR_KEYS, where, "multirotor.", problems, bad)
    model = d["power_model"]
    if model is None:  # "infer", as ModelChain.infer_dc_model
        model = "propeller" if d["ct"] is not None and d["cp"] is not None else "momentum"
    missing = [key for key in POWER_MODEL_KEYS.get(model, ()) if d[key] is None]
    if missing:
        problems.add(f"multirotor.power_model '{model}' needs "
                     + " and ".join(f"'multirotor.{m}'" for m in missing))
    if (d["ct"] is None) != (d["cp"] is None):
        problems.add("multirotor: give both 'ct' and 'cp' or neither")
    cruise, top = d["cruise_speed_ms"], d["max_airspeed_ms"]
    if not bad & {"cruise_speed_ms", "max_airspeed_ms"} and cruise > top:
        problems.add(f"multirotor.cruise_speed_ms must be at most the maximum airspeed "
                     f"(multirotor.max_airspeed_ms {top:g} m/s), got {cruise!r}")
    if model in ("momentum", "rotor_losses") and not bad & {"figure_of_merit",
                                                            "induced_factor"}:
        # momentum theory: profile power P0/P_ideal = 1/FM − κ must not be negative
        fm, kappa = d["figure_of_merit"], d["induced_factor"]
        if fm is None and kappa * DEFAULT_FIGURE_OF_MERIT > 1.0:
            problems.add(f"multirotor.induced_factor must be at most "
                         f"{1.0 / DEFAULT_FIGURE_OF_MERIT:.3g} with the default "
                         f"figure of merit {DEFAULT_FIGURE_OF_MERIT:g} (profile power "
                         f">= 0), got {kappa!r}")
        elif fm is not None and kappa * fm > 1.0:
            problems.add(f"multirotor.figure_of_merit must be at most 1/induced_factor "
                         f"= {1.0 / kappa:.3g} (profile power >= 0), got {fm!r}")
    for readers in dict.fromkeys(MODEL_ONLY_KEYS.values()):
        given = [key for key, r in MODEL_ONLY_KEYS.items() if r == readers and model not in r
                 and isinstance(data, dict) and data.get(key) is not None]
        if given:
            problems.add(", ".join(f"multirotor.{k}" for k in given)
                         + f" {'is' if len(given) == 1 else 'are'} read only by power_model "
                         f"{' and '.join(readers)} (this file's power_model is '{model}')")
    unread = {key: (d[key] if model in r else None) for key, r in MODEL_ONLY_KEYS.items()}
    if len(problems) > n:
        return None
    return Multirotor(**S.fields_from(Multirotor, d, power_model=model, **unread))


def load_aircraft(path: str | Path) -> Aircraft:
    """Load and validate an aircraft YAML file (:func:`aircraft_from_mapping`)."""
    return aircraft_from_mapping(files.load_yaml(path, empty_ok=False), str(path))


def aspect_ratio_of(path: str | Path) -> float | None:
    """The ``fixed_wing.aspect_ratio`` an aircraft file gives, if any (the loaded
    :class:`Aircraft` keeps only K): the fixed-wing fit's Oswald factor needs it."""
    data = files.load_yaml(path, empty_ok=False)
    block = data.get("fixed_wing") if isinstance(data, dict) else None
    ar = block.get("aspect_ratio") if isinstance(block, dict) else None
    return float(ar) if isinstance(ar, (int, float)) and not isinstance(ar, bool) else None


def default_battery_path(aircraft: Aircraft) -> Path | None:
    """The aircraft's default pack file, resolved against the aircraft file's folder."""
    if not aircraft.battery_path:
        return None
    base = Path(aircraft.path).parent if aircraft.path else Path(".")
    return base / aircraft.battery_path


def load_aircraft_and_battery(aircraft_path, battery_path=None) -> tuple[Aircraft, BatteryPack]:
    """Load an aircraft and its pack (``battery_path`` or the aircraft's default).

    A pack the aircraft file names that cannot be found is reported with where its path
    came from: ``A.yaml: battery: batteries/x.yaml (resolved to /…/batteries/x.yaml):
    file not found``.
    """
    aircraft = load_aircraft(aircraft_path)
    if battery_path is not None:
        return aircraft, load_battery(battery_path)
    path = default_battery_path(aircraft)
    if path is None:
        raise InputError(f"{aircraft_path}: no 'battery' key and no battery pack given "
                         "(expected a battery-pack YAML)")
    if not path.exists():
        raise InputError(f"{aircraft_path}: battery: {aircraft.battery_path} (resolved to "
                         f"{path.resolve()}, relative to the aircraft file): file not found")
    return aircraft, load_battery(path)
