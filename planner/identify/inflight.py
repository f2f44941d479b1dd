r"""In flight: the charge and time left above the reserve, learnt as the flight goes.

:class:`InflightEstimator` is fed telemetry events (:mod:`planner.io.mavlink_stream`) one by
one — cheaply: each message only updates running sums, a scalar or a 2-state Kalman
filter — and predicts on request (:meth:`InflightEstimator.predict`, at most once a
second) through the same :class:`~planner.chain.mission_chain.MissionChain` as the
pre-flight check, vectorised over a sample axis for the P5–P95 bands.

What it learns (each from the pre-flight value as prior)
--------------------------------------------------------
* **State of charge and capacity** — a Kalman filter on :math:`\theta = (s_0, 1/C)` with
  the measurement :math:`s = s_0 - Q/C`: :math:`Q` the charge counted since boot (the
  autopilot's counter, else the integral of the current) and :math:`s` the state of charge
  read from the voltage on the chemistry's open-circuit curve (the pack's ``circuit.ocv``
  or :func:`planner.physics.battery.ocv.lipo_ocv`), sag-compensated with the pack's
  resistance, :math:`V_{oc} = V + I R` (per cell), averaged over :data:`BIN_S` bins of
  steady current. The curve is not the pack's own: its error is taken as a random walk of
  :math:`s_0` along the state of charge (:data:`CURVE_WALK_PER_SOC`), so that a long
  flight tightens the capacity only as far as the curve allows. A rested voltage above the
  curve's top reads as a full pack. The prior of :math:`1/C` is the pack file's nominal
  capacity with :data:`CAPACITY_SD_KNOWN` (a label) or :data:`CAPACITY_SD_UNKNOWN` (the
  capacity is not known: the voltage must tell it).
* **Pack resistance** :math:`R` — a scalar filter on :math:`-\Delta V / \Delta I` over
  consecutive samples across current steps (take-off, manoeuvres).
* **Charge scale** :math:`c` — the measured charge over the integral model's
  ([UAV23] eq. 14) along the *measured* power, per :data:`CHARGE_WINDOW_S` window: the
  model's δ becomes :math:`\delta c^{-\beta}`.
* **Power scale** :math:`k` — measured power over the aircraft's power model at the
  measured flight state (air-relative speed from the ground velocity and the wind
  estimate, climb rate, density), airborne only: a random-walk Kalman filter on
  :math:`\ln k` (:data:`POWER_WALK_PER_S`), so a changed payload is followed. A power
  scale is exactly a δ of the integral model, :math:`\delta k^{\varepsilon}`.

What it predicts
----------------
From the present state, per sample (the filters' posteriors, the wind estimate's spread
over :attr:`WatchSettings.weather_draws` weather draws, the present power's spread):

* ``charge_above_reserve_mah`` :math:`(s - r)\,C`, the reserve :math:`r` a fraction of the
  capacity (or the state of charge of an open-circuit cell voltage);
* ``time_to_reserve_s``: at the present condition (the measured power, 30-s average;
  before take-off the hold power), the time for the integral model to draw that charge:
  :math:`t = \delta' P^{\varepsilon}\,(S_{lim} - S_{now})`, with the stress
  :math:`S = (D/\mathrm{scale})^{\beta}` of the charge :math:`D` drawn since full;
* ``mission_remaining_mah``, ``return_home_mah``, ``landing_margin_mah``,
  ``point_of_no_return_in_s``: the chain flies the rest of the mission from the present
  position (:mod:`planner.io.mavlink_mission`) and, at every return-home point of it, the
  way straight home at cruise speed and down, in the estimated wind. The chain's charges
  are those of a fresh pack; they are carried to the present one through the additive
  stress: a fresh charge :math:`C_f` is a stress :math:`\Delta S = (C_f/\mathrm{scale})^\beta`,
  which costs :math:`\mathrm{scale}\,[(S_{now} + \Delta S)^{1/\beta} - S_{now}^{1/\beta}]` now.
  Without a mission the return home is from here and the point of no return is when,
  at the present condition, the charge above the reserve falls to the return's.

A silent link ages the estimate: the time since the last battery sample is flown at the
present power before predicting. The baselines it carries for comparison: PX4's estimator
(remaining charge ÷ a first-order 50-s filtered current started at ``BAT_AVRG_CURRENT``,
updated while armed; PX4-Autopilot ``src/lib/battery/battery.cpp``,
``computeRemainingTime``) and a consumption-rate extrapolation (the same remaining charge
over the mean current since take-off), both with the firmware's own remaining percentage
times the pack's nominal capacity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.special import ndtri

from planner.chain.kinematics import hold_power
from planner.chain.kinematics import RTL_POINTS_PER_LEG
from planner.chain.mission_chain import MissionChain
from planner.chain.steps import CHECK_CONSTRAINTS
from planner.errors import InputError
from planner.io import mavlink_mission as mm
from planner.io.mavlink_stream import Event, MissionItems
from planner.parameters import Aircraft, BatteryPack
from planner.physics import atmosphere
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.mission import Environment, Mission
from planner.physics.units import AS_PER_MAH
from planner.physics.wind import course_deg

__all__ = ["InflightEstimator", "OcvCurve", "WatchSettings", "px4_filter_alpha"]

#: Battery samples are averaged over bins of this length before the state-of-charge
#: filter sees them. [s]
BIN_S = 10.0
#: A bin is used only when its current spread is below this share of its mean (or 1 A),
#: and not within :data:`SETTLE_S` of a current step (the pack's polarisation settles).
STEADY_SPREAD = 0.25
SETTLE_S = 30.0
#: Rested: a bin whose mean current is below this (or C/50). [A]
REST_CURRENT_A = 0.5
#: Cell-voltage error of a bin read on the curve: white part, and at rest. [V]
CELL_V_SD = 0.015
CELL_V_SD_REST = 0.010
#: Random walk of the curve's error along the state of charge: SD 0.02 per 0.1 of
#: state of charge traversed. [1/SoC]
CURVE_WALK_PER_SOC = 0.02**2 / 0.1
#: Above the voltage of this state of charge the curve is not used: the top of the
#: curve is where cells charged to different voltages differ most (the lithium-polymer
#: curve's cell was charged to 4.1 V, a LiPo pack to 4.2 V); a rested voltage above it
#: reads as a full pack.
TRUST_TOP_SOC = 0.8
#: Prior SD of a voltage-less start (no rested voltage seen before take-off). [unitless]
S0_PRIOR_SD = 0.15
#: Relative prior SD of the capacity: a label, or unknown.
CAPACITY_SD_KNOWN = 0.10
CAPACITY_SD_UNKNOWN = 0.50
#: Resistance prior where the pack file gives none: per series cell [Ω], and the prior's
#: relative SD then and with the file's resistance; its random walk per SoC traversed.
R_CELL_DEFAULT_OHM = 0.006
R_SD_UNKNOWN = 3.0
R_SD_KNOWN = 0.5
R_WALK_PER_SOC = 0.2
#: Prior SD of ln(power scale) and ln(charge scale).
POWER_SCALE_SD = 0.30
CHARGE_SCALE_SD = 0.10
#: Random walks of ln(power scale) and ln(charge scale). [1/s]
POWER_WALK_PER_S = 0.05**2 / 600.0
CHARGE_WALK_PER_S = 0.01**2 / 600.0
#: Power-scale updates use means over this window; the charge scale this one. [s]
POWER_WINDOW_S = 5.0
CHARGE_WINDOW_S = 60.0
#: Smallest SD of one power-scale measurement, ln units (the model's scatter is learnt
#: above it).
POWER_Y_SD_MIN = 0.03
#: Seconds of flight kept to measure how well the present condition forecast the power
#: (one row a second), and the least needed. [s]
HISTORY_S = 1800
HISTORY_MIN_S = 60
#: Largest error of one window of that history, ln units (a factor 2).
FORECAST_ERR_CLIP = math.log(2.0)
#: Time constant of the present power (the present condition) and of the wind. [s]
POWER_TAU_S = 30.0
#: The present condition priced by the power model: its state averaged over this time
#: constant, once the power scale's SD is below this. [s], [unitless]
PRESENT_MODEL_TAU_S = 10.0
PRESENT_SCALE_SD = 0.10
WIND_TAU_S = 60.0
#: Wind SD added to the estimate's own (the wind changes), and without any wind source.
#: [m/s]
WIND_SD_MIN_MS = 1.0
WIND_SD_NONE_MS = 3.0
#: PX4's BAT_AVRG_CURRENT default and its filter time constant (battery.cpp). [A], [s]
PX4_AVRG_CURRENT_A = 15.0
PX4_FILTER_TAU_S = 50.0
#: Airborne (without EXTENDED_SYS_STATE): above this altitude, or drawing more than this
#: share of the modelled hold power. [m], [unitless]
AIRBORNE_ALT_M = 1.0
AIRBORNE_POWER_SHARE = 0.4
#: PX4's battery parameters (v1.11 defaults, ``battery_params*.c``), used where the
#: vehicle has not sent its own.
PX4_DEFAULTS = {"V_EMPTY": 3.5, "V_CHARGED": 4.05, "V_LOAD_DROP": 0.3, "R_INTERNAL": -1.0,
                "LOW_THR": 0.15, "CRIT_THR": 0.07, "EMERGEN_THR": 0.05}
#: The firmware levels a reserve may be.
FIRMWARE_LEVELS = ("px4-low", "px4-critical", "px4-emergency")
#: A first reading of the autopilot's charge counter up to this share of the capacity is
#: taken as counted from a full pack at boot; beyond it, from the first reading.
COUNTER_FROM_BOOT_SHARE = 1.5
#: A battery voltage that moves by more than this share within 5 s is a damaged sample.
VOLTAGE_JUMP = 0.25
#: Physical ranges of the events' values (NaN is "not measured" and passes).
PLAUSIBLE = {
    "battery": ((0.0, 1000.0), (-500.0, 2000.0), (-1e7, 1e7), (0.0, 1.0)),
    "position": ((-90.0, 90.0), (-180.0, 180.0), (-1e4, 3e4), (-1e3, 3e4), (-300.0, 300.0),
                 (-300.0, 300.0), (-300.0, 300.0)),
    "local": ((-1e6, 1e6), (-1e6, 1e6), (-1e4, 3e4), (-300.0, 300.0), (-300.0, 300.0),
              (-300.0, 300.0)),
    "hud": ((-50.0, 300.0), (0.0, 300.0), (-300.0, 300.0), (0.0, 1.0)),
    "wind": ((-100.0, 100.0), (-100.0, 100.0), (0.0, 1e4)),
    "home": ((-90.0, 90.0), (-180.0, 180.0), (-1e3, 3e4)),
    "air": ((1e3, 2e5), (-100.0, 100.0)),
}
#: A point of no return never reached stands for this in the percentiles. [s]
NEVER_S = 1.0e12
_NAN = float("nan")


def _plausible(kind: str, data) -> bool:
    """Whether an event's numbers lie in their physical ranges (:data:`PLAUSIBLE`)."""
    ranges = PLAUSIBLE.get(kind)
    if ranges is None:
        return True
    try:
        for (lo, hi), x in zip(ranges, data):
            if x == x and not lo <= x <= hi:      # NaN passes
                return False
    except TypeError:
        return False
    return True


def px4_filter_alpha(dt_s: float, tau_s: float = PX4_FILTER_TAU_S) -> float:
    """The weight of a new sample in PX4's ``AlphaFilter``: dt / (dt + τ)
    (PX4-Autopilot ``src/lib/mathlib/math/filter/AlphaFilter.hpp``, ``setParameters``)."""
    return dt_s / (dt_s + tau_s) if dt_s > 0 else 0.0


class OcvCurve:
    """A cell's open-circuit curve as a table, and its inverse. [V], [unitless]"""

    def __init__(self, ocv_fn=lipo_ocv, points: int = 2001):
        self.s = np.linspace(0.0, 1.0, points)
        v = np.asarray(ocv_fn(self.s), float)
        v = np.maximum.accumulate(v + np.arange(points) * 1e-9)
        self.v = v
        self.dv_ds = np.gradient(v, self.s)
        self.top, self.bottom = float(v[-1]), float(v[0])

    def soc(self, cell_v):
        """State of charge [0..1] at the open-circuit cell voltage ``cell_v`` [V], linear
        between the curve's points and held at its ends."""
        return np.interp(cell_v, self.v, self.s)

    def slope(self, soc):
        """dV/dsoc of the curve at ``soc`` [V per unit state of charge]."""
        return np.interp(soc, self.s, self.dv_ds)


@dataclass(frozen=True)
class WatchSettings:
    """How the in-flight estimator predicts.

    Attributes
    ----------
    reserve : float
        Landing reserve, a fraction of the pack's capacity. [unitless]
    reserve_cell_v : float or None
        Or the reserve as an open-circuit cell voltage: the state of charge where the
        curve reaches it. [V]
    reserve_firmware : str or None
        Or the firmware's own level: ``px4-low``, ``px4-critical``, ``px4-emergency``
        (:meth:`InflightEstimator.firmware_level_soc`).
    capacity_known : bool
        The pack file's capacity is the pack's (a label); False: not known.
    samples : int
        Samples of the bands.
    weather_draws : int
        Wind draws (the chain runs once per draw).
    seed : int
    temperature_c : float or None
        Outside air temperature; None: ISA. [°C]
    payload_kg : float or None
        Payload; None: the mission's (0 without one). [kg]
    silent_after_s : float
        A link silent for longer is reported stale. [s]
    """

    reserve: float = 0.2
    reserve_cell_v: float | None = None
    reserve_firmware: str | None = None
    capacity_known: bool = True
    samples: int = 200
    weather_draws: int = 4
    seed: int = 0
    temperature_c: float | None = None
    payload_kg: float | None = None
    silent_after_s: float = 5.0


class _Scalar:
    """A scalar Kalman filter with a random walk: x, variance p, walk q per s."""

    __slots__ = ("x", "p", "q", "t")

    def __init__(self, x, sd, q=0.0):
        self.x, self.p, self.q, self.t = float(x), float(sd) ** 2, float(q), None

    def update(self, y, sd, t):
        if self.t is not None and t > self.t:
            self.p += self.q * (t - self.t)
        self.t = t
        r = sd * sd
        k = self.p / (self.p + r)
        innov = y - self.x
        self.x += k * innov
        self.p *= 1.0 - k
        return innov

    @property
    def sd(self):
        return math.sqrt(max(self.p, 0.0))


def _pct(x, q=(5, 50, 95)):
    x = np.asarray(x, float)
    ok = x[~np.isnan(x)]
    if not ok.size:
        return [None] * len(q)
    return [float(v) for v in np.percentile(ok, q)]


class InflightEstimator:
    """The in-flight estimator (module notes).

    Parameters
    ----------
    aircraft : Aircraft
    pack : BatteryPack
        The pre-flight pack: its capacity (the prior, see ``capacity_known``), cells,
        resistance, open-circuit curve and integral model.
    mission : Mission, optional
        A mission given as legs (followed by position).
    mission_items : MissionItems, optional
        A mission as items (followed by ``MISSION_CURRENT``); one downloaded from the
        vehicle replaces it.
    settings : WatchSettings
    environment : Environment, optional
        The forecast: the wind's prior until the vehicle estimates its own, the site.
    """

    def __init__(self, aircraft: Aircraft, pack: BatteryPack, *, mission: Mission | None = None,
                 mission_items: MissionItems | None = None,
                 settings: WatchSettings = WatchSettings(),
                 environment: Environment | None = None):
        self.aircraft, self.pack, self.settings = aircraft, pack, settings
        if not 0.0 <= settings.reserve < 1.0:
            raise InputError(f"reserve must be in [0, 1), got {settings.reserve}")
        if settings.reserve_firmware not in (None, *FIRMWARE_LEVELS):
            raise InputError(f"reserve must be a fraction, a cell voltage or one of "
                             f"{', '.join(FIRMWARE_LEVELS)}, got {settings.reserve_firmware!r}")
        if settings.samples < 20:
            raise InputError(f"samples must be at least 20, got {settings.samples}")
        self.mission_legs = mission
        self.mission_items = mission_items
        self.file_items = mission_items is not None
        self.env0 = environment or (mission.environment if mission else Environment())
        self.payload = (settings.payload_kg if settings.payload_kg is not None
                        else mission.payload_kg if mission else 0.0)
        self.mass = aircraft.empty_mass_kg + pack.total_mass_kg + self.payload
        self.cells = pack.cells_series
        ocv = pack.circuit.ocv if pack.circuit is not None else lipo_ocv
        self.curve = OcvCurve(ocv)
        self.trust_top = float(np.interp(TRUST_TOP_SOC, self.curve.s, self.curve.v))
        self.reserve_soc = (float(self.curve.soc(settings.reserve_cell_v))
                            if settings.reserve_cell_v is not None else settings.reserve)
        self.floor_soc = max(self.reserve_soc, 1.0 - pack.usable_fraction)
        self.c0_mah = pack.total_capacity_mah
        model = pack.model
        self.delta, self.eps, self.beta = model.delta, model.epsilon, model.beta
        self.scale = (model.charge_scale(settings.temperature_c)
                      if (model.fade_per_cycle or model.temperature_coefficient_per_c)
                      else 1.0)
        if pack.internal_resistance_ohm is not None:
            self.r0, self.r0_sd = pack.resistance_ohm, R_SD_KNOWN * pack.resistance_ohm
        else:
            self.r0 = R_CELL_DEFAULT_OHM * pack.cells_series / pack.cells_parallel / pack.count
            self.r0_sd = R_SD_UNKNOWN * self.r0
        self._chains: dict[int, MissionChain] = {}
        self.reset_battery()
        self.k = _Scalar(0.0, POWER_SCALE_SD, POWER_WALK_PER_S)
        self.k_y_var = 0.1**2
        self._k_out = None
        self.c = _Scalar(0.0, CHARGE_SCALE_SD, CHARGE_WALK_PER_S)
        self._draw_common_numbers(settings)
        self._clear_vehicle(mission)

    # ------------------------------------------------------------------ state resets

    def _draw_common_numbers(self, settings: WatchSettings) -> None:
        """Common random numbers: the same draws every prediction (smooth, reproducible)."""
        rng = np.random.default_rng(settings.seed)
        k = settings.samples
        u = (np.argsort(rng.random((8, k)), axis=1) + rng.random((8, k))) / k
        # (8, K): s0, 1/C, R, charge scale, power scale, present power, its drift, the
        # curve's error at the reserve
        self.z = ndtri(np.clip(u, 1e-9, 1 - 1e-9))
        w = max(1, min(settings.weather_draws, k))
        uw = (np.argsort(rng.random((2, w)), axis=1) + rng.random((2, w))) / w
        self.zw = ndtri(np.clip(uw, 1e-9, 1 - 1e-9))        # (2, W)
        self.group = np.repeat(np.arange(w), np.diff(np.linspace(0, k, w + 1).round()
                                                     .astype(int)))

    def _clear_vehicle(self, mission: Mission | None) -> None:
        """The vehicle's state before any message: unknown, on the ground, no flight."""
        self.t = None                  # stream time of the last event
        self.t_battery = None
        self.armed = False
        self.mode = ""
        self.vehicle_type = None
        self.autopilot = None
        self.landed_state: bool | None = None
        self.airborne = False
        self.t_takeoff = None
        self.q_takeoff = None
        self.pos = None                # (lat, lon, rel_alt, alt_amsl, vn, ve, vd)
        self.local = None              # (east, north, alt, vn, ve, vd)
        self.hud = None                # (airspeed, groundspeed, climb, throttle)
        self.home = (self.mission_items.home if self.mission_items else None) or (
            mission.home if mission else None)
        self.home_source = "mission" if self.home else None
        self.seq = None
        self.leg_index = 0
        self.wind_n = self.wind_e = None
        self.wind_var = 0.0
        self.wind_t = None
        self.pressure_pa = None
        self.params: dict[str, float] = {}
        self.texts = 0
        self.rejected = 0
        self.dropped = 0
        self.reboots = 0
        self.flights = 0
        self.buf_p: list[float] = []
        self.buf_state: list[tuple] = []
        self.k_window_t = None
        self.t_tick = None

    def reset_battery(self) -> None:
        """A new pack: forget the battery's state (not the learnt scales)."""
        g0 = 1.0 / self.c0_mah
        sd_rel = CAPACITY_SD_KNOWN if self.settings.capacity_known else CAPACITY_SD_UNKNOWN
        self.theta = np.array([1.0, g0, self.r0])
        self.P = np.diag([S0_PRIOR_SD**2, (sd_rel * g0) ** 2, self.r0_sd**2])
        self.rest_seen = False
        self.q_counter0 = None         # the autopilot's counter at its first reading
        self.q_counter_last = None
        self.q_own = 0.0               # own integral since the last counter reading
        self.q_offset = 0.0            # carried over a reboot
        self.v = self.i = _NAN
        self.last_src: dict[int, tuple] = {}
        self.bin = None
        self.t_step = -math.inf
        self.t_load_end = -math.inf
        self.p_ewma = None
        self.pm_ewma = None
        self.pm_long = None
        self._hist = np.full((HISTORY_S, 3), np.nan)   # (t, measured, forecast) a second
        self._hist_n = 0
        self.i_ewma = None
        self.thr_ewma = None
        self.lnp_var = 0.0
        self.px4_i = PX4_AVRG_CURRENT_A
        self.px4_t = None
        self.fw_remaining = None
        self.s_meas = 0.0              # stress of the measured power (model units)
        self.cwin = None
        self.bins = 0

    # ------------------------------------------------------------------ feeding
    @property
    def q_now(self) -> float:
        """Charge drawn since boot (the counter, else the current's integral). [mAh]"""
        if self.q_counter_last is not None:
            return self.q_offset + self.q_counter_last - self.q_counter0 + self.q_own
        return self.q_offset + self.q_own

    def feed(self, ev: Event) -> None:
        """Take one telemetry event (cheap: no model runs here)."""
        kind, t, d = ev
        if not math.isfinite(t):
            return
        restart = kind in ("reboot", "flight")
        if self.t is not None and t < self.t - 1.0 and not restart:
            self.dropped += 1
            return                     # out of order by more than a second: dropped
        handler = getattr(self, "_on_" + kind, None)
        if handler is not None and not _plausible(kind, d):
            self.rejected += 1
            return
        self.t = t if self.t is None or restart else max(t, self.t)
        if handler is not None:
            try:
                handler(t, d)
            except (ValueError, OverflowError, ZeroDivisionError, FloatingPointError):
                self.rejected += 1
        if self.t_tick is None:
            self.t_tick = t
        elif t - self.t_tick >= 1.0:
            self._tick(t)
            self.t_tick = t

    def _on_reboot(self, t, d):
        # the pack stays: carry the charge counted so far, restart the counters
        self.reboots += 1
        self.q_offset = self.q_now
        self.q_counter0 = self.q_counter_last = None
        self.q_own = 0.0
        self.last_src.clear()
        self.bin = None
        self._restart_stream(t)
        self.px4_t = None
        self._p_t = None
        self.wind_t = t if self.wind_t is not None else None
        self.cwin = None
        if self.t_takeoff is not None:
            self.t_takeoff = t
            self.q_takeoff = self.q_now

    def _on_flight(self, t, d):
        # a record's next flight: another pack, the learnt scales stay
        self.flights += 1
        self.reset_battery()
        self._restart_stream(t)
        self.t_takeoff = self.q_takeoff = None
        self.airborne = False
        self.local = self.pos = self.hud = None
        self.leg_index = 0

    def _restart_stream(self, t):
        """The stream's clock and what is timed by it start again at ``t`` [s] (after a
        reboot of the autopilot, or at a record's next flight): the last event, battery
        sample and prediction times, the power and state buffers, the scale's window."""
        self.t = t
        self.t_battery = None
        self.t_tick = t
        self.k_window_t = None
        self.buf_p.clear()
        self.buf_state.clear()

    def _on_state(self, t, d):
        armed, mode, vtype, autopilot = d
        if armed and not self.armed:
            self.px4_t = None
        self.armed, self.mode = bool(armed), mode
        self.vehicle_type, self.autopilot = vtype, autopilot
        if not armed:
            self._set_airborne(False, t)

    def _on_landed(self, t, d):
        self.landed_state = bool(d[0])
        self._set_airborne(not d[0] and self.armed, t)

    def _set_airborne(self, flying: bool, t: float) -> None:
        if flying and not self.airborne:
            if self.t_takeoff is None:
                self.t_takeoff, self.q_takeoff = t, self.q_now
        if not flying and self.airborne:
            self.t_load_end = t
        self.airborne = flying

    def _on_param(self, t, d):
        name, value = d
        if len(self.params) < 256 or name in self.params:
            self.params[name] = value
        if name in ("BAT_AVRG_CURRENT", "BAT1_AVRG_CURRENT") and value > 0 \
                and self.px4_t is None:
            self.px4_i = value

    def _on_text(self, t, d):
        self.texts += 1

    def _on_home(self, t, d):
        self.home, self.home_source = tuple(d), "vehicle"

    def _on_air(self, t, d):
        p, _ = d
        if math.isfinite(p) and 1e3 < p < 2e5:
            self.pressure_pa = p

    def _on_mission(self, t, d):
        items: MissionItems = d[0]
        self.mission_items = items if items.items else None
        self.file_items = False
        if items.home is not None and self.home_source != "vehicle":
            self.home, self.home_source = items.home, "mission"

    def _on_mission_current(self, t, d):
        self.seq = int(d[0])

    def _on_position(self, t, d):
        self.pos = d
        if self.home is None and self.armed and all(map(math.isfinite, d[:2])) \
                and math.isfinite(d[3]):
            self.home, self.home_source = (d[0], d[1], d[3] - d[2]), "first armed position"
        self._kinematic(t)

    def _on_local(self, t, d):
        self.local = d
        self._kinematic(t)

    def _on_hud(self, t, d):
        self.hud = d

    def _on_wind(self, t, d):
        wn, we, var = d
        if not (math.isfinite(wn) and math.isfinite(we)) or abs(wn) > 100 or abs(we) > 100:
            return
        if self.wind_n is None:
            self.wind_n, self.wind_e, self.wind_var = wn, we, 0.0
        else:
            a = 1.0 - math.exp(-max(t - self.wind_t, 0.0) / WIND_TAU_S)
            dn, de = wn - self.wind_n, we - self.wind_e
            self.wind_n += a * dn
            self.wind_e += a * de
            self.wind_var = (1 - a) * (self.wind_var + a * 0.5 * (dn * dn + de * de))
        if math.isfinite(var):
            self.wind_var = max(self.wind_var, 0.5 * var)
        self.wind_t = t

    def _kinematic(self, t):
        """Buffer the flight state for the power-scale filter; decide airborne."""
        alt = self._alt()
        if self.landed_state is None and self.armed:
            p_share = (self.p_ewma or 0.0) / max(self._hold_power_model(), 1.0)
            flying = (math.isfinite(alt) and alt > AIRBORNE_ALT_M) or \
                p_share > AIRBORNE_POWER_SHARE
            self._set_airborne(flying, t)
        if self.airborne:
            v_air, climb = self._air_state()
            if math.isfinite(v_air) and math.isfinite(climb) and len(self.buf_state) < 1000:
                self.buf_state.append((v_air, climb))

    def _alt(self) -> float:
        if self.pos is not None:
            return self.pos[2]
        if self.local is not None:
            return self.local[2]
        return _NAN

    def _air_state(self) -> tuple[float, float]:
        """Air-relative horizontal speed and climb rate at the latest state. [m/s]"""
        src = self.pos[4:7] if self.pos is not None else (
            self.local[3:6] if self.local is not None else None)
        wn, we = (self.wind_n or 0.0), (self.wind_e or 0.0)
        if src is not None and all(map(math.isfinite, src)):
            vn, ve, vd = src
            v_air = math.hypot(vn - wn, ve - we)
            climb = -vd
            if self.hud is not None and math.isfinite(self.hud[2]):
                climb = self.hud[2]
            if self.pos is None and self.hud is not None and math.isfinite(self.hud[0]) \
                    and not (vn or ve):
                v_air = self.hud[0]     # a record without a course: its airspeed column
            return v_air, climb
        if self.hud is not None:
            return self.hud[0], self.hud[2]
        return _NAN, _NAN

    def _on_battery(self, t, d):
        v, i, consumed, remaining = d[:4]
        measured = math.isfinite(v) and math.isfinite(i) and v > 0
        if measured and self.t_battery is not None and t - self.t_battery < 5.0 and \
                abs(v - self.v) > VOLTAGE_JUMP * self.v:
            self.rejected += 1          # a pack does not jump so: a damaged sample
            return
        if math.isfinite(remaining):
            self.fw_remaining = (remaining, t)
        if measured and self.t_battery is not None and t > self.t_battery:
            dt = t - self.t_battery
            if dt < 30.0:
                self.q_own += 0.5 * (i + self.i) * dt / AS_PER_MAH
                p_mid = 0.5 * (v * i + self.v * self.i)
                if p_mid > 0:
                    self.s_meas += dt / (self.delta * p_mid ** self.eps)
            if self.armed:
                a = px4_filter_alpha(dt)
                self.px4_i += a * (max(i, 0.0) - self.px4_i)
        if math.isfinite(consumed):
            if self.q_counter0 is None:
                # the autopilot counts from its boot: joining in flight, the charge drawn
                # before counts too (a counter beyond the pack's capacity has another origin)
                self.q_counter0 = (0.0 if self.q_offset == 0 and 0 <= consumed
                                   <= COUNTER_FROM_BOOT_SHARE * self.c0_mah else consumed)
            elif consumed < (self.q_counter_last or 0.0) - 1.0:
                # the counter went back without a reboot seen: carry what was counted
                self.q_offset += self.q_counter_last - self.q_counter0
                self.q_counter0 = consumed
            self.q_counter_last = consumed
            self.q_own = 0.0            # the counter holds everything up to now
        if not measured:
            return
        if self.t_battery is not None and abs(i - self.i) > max(1.0, STEADY_SPREAD * abs(i)):
            self.t_step = t
        self.v, self.i, self.t_battery = v, i, t
        power = v * i
        if self.airborne and power > 0:
            self.buf_p.append(power)
            if self.p_ewma is None:
                self.p_ewma = power
            else:
                a = 1.0 - math.exp(-min(max(t - (self._p_t or t), 0.0), 60.0) / POWER_TAU_S)
                dl = min(max(math.log(power / self.p_ewma), -5.0), 5.0)
                self.p_ewma *= math.exp(a * dl)
                self.i_ewma = i if self.i_ewma is None else self.i_ewma + a * (i - self.i_ewma)
                thr = self.hud[3] if self.hud is not None else math.nan
                if math.isfinite(thr):
                    self.thr_ewma = (thr if self.thr_ewma is None
                                     else self.thr_ewma + a * (thr - self.thr_ewma))
                self.lnp_var = (1 - a) * (self.lnp_var + a * dl * dl)
            self._p_t = t
        elif not self.airborne and self.p_ewma is None:
            self._p_t = t
        self._bin(t, v, i)

    _p_t = None

    def _bin(self, t, v, i):
        b = self.bin
        if b is None:
            self.bin = [t, t, v, i, self.q_now, 1, i, i]
            return
        b[1] = t
        b[2] += v
        b[3] += i
        b[4] += self.q_now
        b[5] += 1
        b[6] = min(b[6], i)
        b[7] = max(b[7], i)
        if t - b[0] >= BIN_S:
            self.bin = None
            self._soc_update(b)

    def _soc_update(self, b):
        """One bin through the battery filter (module notes): an extended Kalman filter
        in voltage space on x = (s0, 1/C, R), z = V/N = OCV(s0 − Q/C) − I R / N."""
        n = b[5]
        v, i, q = b[2] / n, b[3] / n, b[4] / n
        t_mid = 0.5 * (b[0] + b[1])
        if b[7] - b[6] > max(1.0, STEADY_SPREAD * abs(i)):
            return
        rest_i = max(REST_CURRENT_A, self.c0_mah / 1000.0 / 50.0)
        rested = abs(i) < rest_i
        if rested and (t_mid - self.t_load_end < 60.0 or self.airborne):
            return                     # relaxing after a load
        if not rested and b[0] - self.t_step < SETTLE_S:
            return
        x, P = self.theta.copy(), self.P.copy()
        # the curve's error: a random walk of s0 along the state of charge traversed, and
        # of the resistance
        if self.bins:
            ds = abs(q - self._q_bin) * x[1]
            P[0, 0] += CURVE_WALK_PER_SOC * ds
            P[2, 2] += (R_WALK_PER_SOC * self.r0_sd) ** 2 * ds
        self._q_bin = q
        self.bins += 1
        z = v / self.cells
        comp = z + i * max(x[2], 0.0) / self.cells
        if comp >= self.trust_top:
            if not rested or self.rest_seen:
                self.P = P
                return                 # loaded above the curve's top: says only "near full"
            # rested at or above the curve's top: a full pack
            h = np.array([1.0, -q, 0.0])
            resid, var_z = 1.0 - float(h @ x), 0.03**2
        else:
            s_pred = float(x[0] - q * x[1])
            s_lin = min(max(s_pred, 0.0), 1.0)
            m = float(self.curve.slope(s_lin))
            h = np.array([m, -q * m, -i / self.cells])
            resid = z - (float(np.interp(s_lin, self.curve.s, self.curve.v))
                         + m * (s_pred - s_lin) - i * x[2] / self.cells)
            var_z = (CELL_V_SD_REST if rested else CELL_V_SD) ** 2
        ph = P @ h
        var = float(h @ ph) + var_z
        k = ph / var
        x = x + k * resid
        P = P - np.outer(k, ph)
        self.P = 0.5 * (P + P.T)
        g0 = 1.0 / self.c0_mah
        x[1] = min(max(x[1], 0.1 * g0), 10 * g0)
        x[2] = min(max(x[2], 0.0), 10 * self.r0 + 0.5)
        self.theta = x
        if rested:
            self.rest_seen = True

    _q_bin = 0.0

    # ------------------------------------------------------------------ learning tick
    def _tick(self, t: float) -> None:
        """Once a second of stream time: the power and charge scales (vectorised), and the
        history of the present condition's forecasts."""
        if self.buf_p and self.airborne:
            k = self._hist_n % HISTORY_S
            self._hist[k] = (t, float(np.mean(self.buf_p)), self.present_power()[0])
            self._hist_n += 1
        if self.buf_state and self.buf_p and self.airborne:
            if self.k_window_t is None:
                self.k_window_t = t
                self._kp, self._km = [], []
            p_meas = float(np.mean(self.buf_p))
            st = np.asarray(self.buf_state, float)
            try:
                p_model = float(np.mean(self.aircraft.battery_power(
                    np.clip(st[:, 0], 0.0, None), st[:, 1], self._rho(), self.mass)))
            except ValueError:            # a state outside the power model's range
                p_model = math.nan
            if p_model > 0 and math.isfinite(p_model):
                a = 1.0 - math.exp(-1.0 / PRESENT_MODEL_TAU_S)
                self.pm_ewma = (p_model if self.pm_ewma is None
                                else self.pm_ewma + a * (p_model - self.pm_ewma))
                a = 1.0 - math.exp(-1.0 / POWER_TAU_S)
                self.pm_long = (p_model if self.pm_long is None
                                else self.pm_long + a * (p_model - self.pm_long))
            if p_meas > 0 and p_model > 0 and math.isfinite(p_model):
                self._kp.append(p_meas)
                self._km.append(p_model)
            if t - self.k_window_t >= POWER_WINDOW_S and self._kp:
                y = math.log(float(np.mean(self._kp)) / float(np.mean(self._km)))
                sd = math.sqrt(max(self.k_y_var, POWER_Y_SD_MIN**2))
                # a window more than 3 SD from the learnt scale is a glitch and counts as
                # 3 SD away; two in a row on the same side are the model being off (a
                # prior far from the truth, a payload dropped): the scale's variance is
                # widened to the step so that it moves there at once
                spread = 3.0 * math.sqrt(self.k.p + sd * sd)
                step = y - self.k.x
                if abs(step) > spread:
                    if self._k_out is not None and self._k_out * step > 0:
                        self.k.p = max(self.k.p, step * step)
                    else:
                        step = math.copysign(spread, step)
                    self._k_out = step
                else:
                    self._k_out = None
                innov = self.k.update(self.k.x + step, sd, t)
                self.k_y_var = 0.95 * self.k_y_var + 0.05 * min(innov * innov, 0.25)
                self.k_window_t = t
                self._kp, self._km = [], []
        self.buf_p.clear()
        self.buf_state.clear()
        self._charge_window(t)

    def _charge_window(self, t: float) -> None:
        q = self.q_now
        if self.cwin is None:
            self.cwin = (t, q, self.s_meas)
            return
        t0, q0, s0 = self.cwin
        if t - t0 < CHARGE_WINDOW_S:
            return
        self.cwin = (t, q, self.s_meas)
        dq = (q - q0) * AS_PER_MAH
        ds = self.s_meas - s0
        if dq <= 0.5 * AS_PER_MAH * 10 or ds <= 0:
            return
        s_full, g = self.theta[:2]
        d0 = max((1.0 - s_full) / g + q0, 0.0) * AS_PER_MAH      # drawn since full [As]
        c = math.exp(self.c.x)
        st0 = (d0 / (self.scale * c)) ** self.beta               # model stress units
        dc_model = self.scale * c * ((st0 + ds) ** (1 / self.beta) - st0 ** (1 / self.beta))
        if dc_model > 0:
            self.c.update(self.c.x + math.log(dq / dc_model), 0.02, t)

    def _rho(self) -> float:
        try:
            if self.pressure_pa is not None:
                return float(atmosphere.density(0.0, self.settings.temperature_c,
                                                self.pressure_pa))
            alt = self.pos[3] if self.pos is not None and math.isfinite(self.pos[3]) else (
                self.env0.site_altitude_m + (self._alt() if math.isfinite(self._alt()) else 0))
            alt = min(max(alt, atmosphere.ALTITUDE_RANGE_M[0]), atmosphere.ALTITUDE_RANGE_M[1])
            return float(atmosphere.density(alt, self.settings.temperature_c))
        except (ValueError, InputError):
            return 1.225

    def _hold_power_model(self) -> float:
        try:
            return float(hold_power(self.aircraft, self.mass, self._rho(),
                                    math.hypot(self.wind_n or 0.0, self.wind_e or 0.0)))
        except (ValueError, ZeroDivisionError):
            return 100.0

    # ------------------------------------------------------------------ prediction
    def _wind(self) -> tuple[float, float, float]:
        """Mean wind (towards north, east) and its SD per component. [m/s]"""
        if self.wind_n is not None:
            sd = math.sqrt(self.wind_var + WIND_SD_MIN_MS**2)
            return self.wind_n, self.wind_e, sd
        frm = math.radians(self.env0.wind_from_deg)
        s = self.env0.wind_speed_ms
        return -s * math.cos(frm), -s * math.sin(frm), (
            WIND_SD_MIN_MS if s > 0 else WIND_SD_NONE_MS)

    def _here(self):
        """(east, north) of home and altitude, or None."""
        alt = self._alt()
        if self.pos is not None and self.home is not None and \
                all(map(math.isfinite, self.pos[:3])):
            e, n = mm.here_en(self.pos[:2], self.home)
            return (e, n), self.pos[2]
        if self.local is not None and all(map(math.isfinite, self.local[:3])):
            return (self.local[0], self.local[1]), self.local[2]
        if math.isfinite(alt):
            return (0.0, 0.0), alt
        return None

    def remaining_mission(self, env: Environment) -> Mission | None:
        """The rest of the mission from the present position (None: no mission)."""
        here = self._here()
        if here is None:
            return None
        en, alt = here
        if self.mission_items is not None and self.pos is not None and self.home is not None:
            if self.seq is None:
                return None
            off = -1 if (self.file_items and self.autopilot == 12) else 0
            return mm.remaining_from_items(
                self.mission_items, self.seq, self.pos[:2], alt, self.home,
                vehicle_type=self.aircraft.type, seq_offset=off, payload_kg=self.payload,
                environment=env)
        if self.mission_legs is not None:
            rest, self.leg_index = mm.remaining_from_legs(
                replace(self.mission_legs, environment=env, payload_kg=self.payload),
                en, alt, self.leg_index)
            return rest
        return None

    def _chain(self, n: int) -> MissionChain:
        ch = self._chains.get(n)
        if ch is None:
            ch = MissionChain(self.aircraft, [self.pack] * n, battery_model="integral",
                              reserve=0.0, temperature_c=self.settings.temperature_c)
            self._chains = {n: ch} if len(self._chains) > 8 else {**self._chains, n: ch}
        return ch

    def samples(self):
        """Per-sample battery and scale draws (common random numbers): s0, 1/C, R, the
        charge scale and the power scale."""
        z = self.z
        try:
            chol = np.linalg.cholesky(self.P + np.eye(3) * 1e-18)
        except np.linalg.LinAlgError:
            chol = np.diag(np.sqrt(np.clip(np.diag(self.P), 0, None)))
        th = self.theta[:, None] + chol @ z[:3]
        g0 = 1.0 / self.c0_mah
        s0 = th[0]
        g = np.clip(th[1], 0.1 * g0, 10 * g0)
        r = np.clip(th[2], 0.0, None)
        c = np.exp(self.c.x + self.c.sd * z[3])
        k = np.exp(self.k.x + self.k.sd * z[4])
        return s0, g, r, c, k

    def predict(self, now: float | None = None) -> dict:
        """The prediction at stream time ``now`` (default the last event's): see the
        module notes. Percentiles over the samples: ``…_p5``, median, ``…_p95``."""
        t_now = self.t if now is None else max(now, self.t or now)
        out = {"time_s": t_now, "link_age_s": None, "stale": False, "armed": self.armed,
               "airborne": self.airborne, "mode": self.mode, "mission_item": self.seq,
               "mission_source": (self.mission_items.source if self.mission_items else
                                  "legs" if self.mission_legs else None)}
        for key in ("time_to_reserve_s", "charge_above_reserve_mah",
                    "mission_remaining_mah", "return_home_mah", "landing_margin_mah",
                    "point_of_no_return_in_s"):
            self._put(out, key, [])
        out["return_due"] = False
        if self.t_battery is None or not math.isfinite(self.v):
            out.update(self._extras(t_now, None))
            return self._finish(out, t_now)
        age = max(t_now - self.t_battery, 0.0)
        out["link_age_s"] = age
        out["stale"] = age > self.settings.silent_after_s
        s0, g, r_pack, c, k = self.samples()
        beta, scale = self.beta, self.scale
        cap_mah = 1.0 / g
        q_now = self.q_now
        p_now, sd_lnp = self.present_power()
        delta_m = self.delta * c ** (-beta)                       # measured power
        d_now = np.maximum((1.0 - s0) / g + q_now, 0.0) * AS_PER_MAH
        s_now = (d_now / scale) ** beta                           # stress: C = scale S^(1/β)
        p_k = p_now * np.exp(sd_lnp * self.z[5])
        if age > 0:                     # a silent link: fly the gap at the present power
            s_now = s_now + age / (delta_m * p_k ** self.eps)
        d_now = scale * s_now ** (1.0 / beta)
        soc_now = 1.0 - d_now / AS_PER_MAH * g
        floor = self.floor(r_pack)
        # the curve's error between here and the reserve: its random walk over the way
        floor = floor + np.sqrt(CURVE_WALK_PER_SOC * np.abs(soc_now - floor)) * self.z[7]
        above = (soc_now - floor) / g                              # [mAh]
        d_lim = (1.0 - floor) / g * AS_PER_MAH
        s_lim = (np.maximum(d_lim, 0.0) / scale) ** beta
        ttr = delta_m * p_k ** self.eps * (s_lim - s_now)
        # horizon of the present power's drift
        sd_drift = self.forecast_spread(max(float(np.nanmedian(ttr)), 0.0))
        if sd_drift > 0:
            p_k2 = p_k * np.exp(sd_drift * self.z[6])
            ttr = delta_m * p_k2 ** self.eps * (s_lim - s_now)
        ttr = np.where(above > 0, ttr, 0.0)
        out["soc"] = _pct(soc_now)[1]
        out["reserve_soc"] = _pct(floor)[1]
        self._put(out, "capacity_mah", cap_mah)
        self._put(out, "time_to_reserve_s", ttr)
        self._put(out, "charge_above_reserve_mah", above)
        out["power_w"] = p_now
        mission_part = self._mission_part(s_now, above, k, c, p_k, delta_m)
        out.update(mission_part)
        out.update(self._extras(t_now, above))
        return self._finish(out, t_now)

    @staticmethod
    def _put(out, key, values):
        p5, p50, p95 = _pct(values) if len(values) else (None, None, None)
        out[key] = p50
        if key.endswith("_s"):
            out[key[:-2] + "_p5_s"], out[key[:-2] + "_p95_s"] = p5, p95
        else:
            out[key + "_p5"], out[key + "_p95"] = p5, p95

    def _mission_part(self, s_now, above, k, c, p_k, delta_m) -> dict:
        """Mission, return home, landing margin and point of no return (module notes)."""
        out: dict = {}
        beta, scale = self.beta, self.scale
        wn, we, wsd = self._wind()
        temp = self.settings.temperature_c
        site = (float(self.home[2]) if self.home is not None and math.isfinite(self.home[2])
                else self.env0.site_altitude_m)
        env_mean = Environment(wind_speed_ms=math.hypot(wn, we),
                               wind_from_deg=float(course_deg(-we, -wn)),
                               temperature_c=temp, site_altitude_m=site)
        out["wind_speed_ms"] = env_mean.wind_speed_ms
        out["wind_from_deg"] = env_mean.wind_from_deg
        here = self._here()
        if here is None:
            return out
        try:
            rest = self.remaining_mission(env_mean)
        except InputError:
            rest = None
        trip = rest if rest is not None else mm.return_home(
            here[0], here[1], environment=env_mean, payload_kg=self.payload, home=self.home)
        n_pts = RTL_POINTS_PER_LEG * len(trip.legs)
        kk = len(s_now)
        delta_s = self.delta * c ** (-beta) * k ** self.eps       # modelled power
        c_used = np.full(kk, np.nan)
        c_tot = np.full((kk, n_pts), np.nan)
        times = np.full((kk, n_pts), np.nan)
        ran = False
        for j in range(self.zw.shape[1]):
            rows = np.flatnonzero(self.group == j)
            if not rows.size:
                continue
            wn_j, we_j = wn + wsd * self.zw[0, j], we + wsd * self.zw[1, j]
            env_j = replace(env_mean, wind_speed_ms=min(math.hypot(wn_j, we_j),
                                                        atmosphere.MAX_WIND_MS),
                            wind_from_deg=float(course_deg(-we_j, -wn_j)))
            try:
                r = self._chain(rows.size).run(
                    trip, env_j, payload_kg=self.payload, detail=False,
                    rtl_subset=np.arange(n_pts), pack_samples={"delta": delta_s[rows]})
            except (InputError, ValueError, FloatingPointError):
                continue
            ran = True
            bad = r.violated[:, CHECK_CONSTRAINTS.index("mission")]  # legs it cannot fly
            used = np.where(bad, np.inf, r.charge_used_mah)
            c_used[rows] = used
            margin = r.detail["rtl_point_margin_mah"]
            c_tot[rows] = np.where(np.isfinite(margin), r.usable_mah[:, None] - margin, np.inf)
            times[rows] = r.rtl_points["time_s"]
        if not ran:
            return out

        def cost(c_fresh_mah):
            ds = (np.maximum(c_fresh_mah, 0.0) * AS_PER_MAH / scale) ** beta
            sn = s_now if np.ndim(ds) == 1 else s_now[:, None]
            with np.errstate(invalid="ignore", over="ignore"):
                return scale * ((sn + ds) ** (1 / beta) - sn ** (1 / beta)) / AS_PER_MAH

        home_cost = cost(c_tot[:, 0])
        self._put(out, "return_home_mah", home_cost)
        ret_margin = above - home_cost
        if rest is not None:
            mission = cost(c_used)
            self._put(out, "mission_remaining_mah", mission)
            landing = above - mission
            self._put(out, "landing_margin_mah", landing)
            point = cost(c_tot)
            over = point[:, :-1] > above[:, None]
            first = np.where(over.any(axis=1), np.argmax(over, axis=1), -1)
            pnr = np.where(first >= 0, times[np.arange(kk), np.maximum(first, 0)], np.inf)
            pnr = np.where(landing >= 0, np.inf, pnr)
            out["return_due"] = bool(_pct(landing)[0] is not None and _pct(landing)[0] < 0
                                     and _pct(ret_margin)[0] <= 0)
        else:
            self._put(out, "landing_margin_mah", ret_margin)
            # present condition until the charge above the reserve is the return's
            d_lim = (d_now_from(s_now, scale, beta) + np.maximum(ret_margin, 0) * AS_PER_MAH)
            s_lim = (d_lim / scale) ** beta
            pnr = np.where(ret_margin > 0, delta_m * p_k ** self.eps * (s_lim - s_now), 0.0)
            out["return_due"] = bool(_pct(ret_margin)[0] <= 0)
        # never (the mission lands with the reserve): infinite, reported as none
        self._put(out, "point_of_no_return_in_s", np.where(np.isfinite(pnr), pnr, NEVER_S))
        for key in ("point_of_no_return_in_s", "point_of_no_return_in_p5_s",
                    "point_of_no_return_in_p95_s"):
            if out[key] is not None and out[key] >= NEVER_S:
                out[key] = None
        out["return_home_p50_mah"] = _pct(home_cost)[1]
        out["return_margin_p5_mah"] = _pct(ret_margin)[0]
        return out

    def _extras(self, t_now, above) -> dict:
        """Learnt parameters and the baselines."""
        fw_r = self.firmware_reserve()
        px4 = rate = None
        if self.fw_remaining is not None:
            rem = self.fw_remaining[0]
            above_fw = max(rem - fw_r, 0.0) * self.c0_mah                    # [mAh]
            if self.px4_i > 0:
                px4 = above_fw / self.px4_i * AS_PER_MAH
            mean_i = self.mean_current()
            if mean_i and mean_i > 0:
                rate = above_fw / mean_i * AS_PER_MAH
        return {"power_scale": math.exp(self.k.x), "power_scale_sd": self.k.sd,
                "charge_scale": math.exp(self.c.x), "resistance_ohm": float(self.theta[2]),
                "consumed_mah": self.q_now, "voltage_v": self.v, "current_a": self.i,
                "px4_current_a": self.px4_i, "px4_time_to_reserve_s": px4,
                "rate_time_to_reserve_s": rate, "firmware_remaining": (
                    self.fw_remaining[0] if self.fw_remaining else None),
                "reboots": self.reboots}

    def _finish(self, out, t_now):
        if self.mission_items is not None:
            out["mission_items"] = len(self.mission_items.items)
        elif self.mission_legs is not None:
            out["mission_items"] = len(self.mission_legs.legs)
            out["mission_leg"] = self.leg_index + 1
        else:
            out["mission_items"] = None
        return out

    def mean_current(self) -> float | None:
        """Mean current since take-off (the consumption-rate baseline). [A]"""
        if self.t_takeoff is None or self.t is None or self.t - self.t_takeoff < 10.0:
            return None
        return (self.q_now - self.q_takeoff) * AS_PER_MAH / (self.t - self.t_takeoff)

    def floor(self, resistance=None):
        """The state of charge at the reserve (or where the pack's usable charge ends, if
        higher), per resistance sample. [unitless]"""
        r = self.reserve_soc
        if self.settings.reserve_firmware is not None:
            r = self.firmware_level_soc(self.settings.reserve_firmware, resistance)
        return np.maximum(r, 1.0 - self.pack.usable_fraction)

    def firmware_level_soc(self, level: str, resistance=None):
        """The state of charge at which the firmware will declare ``level``, on our curve.

        PX4 (``src/lib/battery/battery.cpp``, ``estimateRemaining`` of v1.11, the versions
        whose state of charge is read from the voltage alone): the cell voltage
        compensated by ``BAT_R_INTERNAL`` × current (when it is set, ≥ 0) or else by
        ``BAT_V_LOAD_DROP`` × throttle is placed linearly between ``BAT_V_EMPTY`` and
        ``BAT_V_CHARGED``, and the level is that fraction falling below ``BAT_LOW_THR``,
        ``BAT_CRIT_THR`` or ``BAT_EMERGEN_THR``. The loaded cell voltage there, plus our
        sag at the present current (:math:`I R / N`), is the open-circuit voltage of the
        level; the curve gives its state of charge. The parameters are the vehicle's
        (``PARAM_VALUE`` on the link), else PX4's defaults (:data:`PX4_DEFAULTS`).
        """
        p = dict(PX4_DEFAULTS)
        for name in p:
            for pre in ("BAT1_", "BAT_"):
                if pre + name in self.params:
                    p[name] = self.params[pre + name]
                    break
        frac = p[{"px4-low": "LOW_THR", "px4-critical": "CRIT_THR",
                  "px4-emergency": "EMERGEN_THR"}[level]]
        v_level = p["V_EMPTY"] + frac * (p["V_CHARGED"] - p["V_EMPTY"])
        i = self.i_ewma if self.i_ewma is not None else (self.i if math.isfinite(self.i)
                                                         else 0.0)
        thr = self.thr_ewma if self.thr_ewma is not None else (
            self.hud[3] if self.hud is not None and math.isfinite(self.hud[3]) else 0.0)
        comp = p["R_INTERNAL"] * i if p["R_INTERNAL"] >= 0 else thr * p["V_LOAD_DROP"]
        r = np.maximum(self.theta[2] if resistance is None else resistance, 0.0)
        ocv = v_level - comp + max(i, 0.0) * r / self.cells
        return self.curve.soc(ocv)

    def firmware_reserve(self) -> float:
        """The reserve on the firmware's remaining-percentage scale: a fraction as given;
        a cell voltage on PX4's linear scale between ``BAT_V_EMPTY`` and
        ``BAT_V_CHARGED`` where those parameters were seen, else on our curve."""
        if self.settings.reserve_firmware is not None:
            key = {"px4-low": "LOW_THR", "px4-critical": "CRIT_THR",
                   "px4-emergency": "EMERGEN_THR"}[self.settings.reserve_firmware]
            return next((self.params[pre + key] for pre in ("BAT1_", "BAT_")
                         if pre + key in self.params), PX4_DEFAULTS[key])
        v = self.settings.reserve_cell_v
        if v is None:
            return self.settings.reserve
        for pre in ("BAT1_", "BAT_"):
            ve, vc = self.params.get(pre + "V_EMPTY"), self.params.get(pre + "V_CHARGED")
            if ve and vc and vc > ve:
                return min(max((v - ve) / (vc - ve), 0.0), 1.0)
        return self.reserve_soc

    def present_power(self) -> tuple[float, float]:
        """The present condition's power and the SD of its log. [W], [unitless]

        Airborne, once the power scale is learnt (its SD below
        :data:`PRESENT_SCALE_SD`): the power model at the present flight state (a
        :data:`PRESENT_MODEL_TAU_S` average) times the learnt scale — the model knows that
        a climb has ended or a turn costs more; before that, the measured power (a
        :data:`POWER_TAU_S` average); on the ground, the hold power times the scale.
        """
        if self.airborne and self.pm_ewma and self.k.sd < PRESENT_SCALE_SD:
            sd = math.sqrt(self.k.p + max(self.k_y_var, POWER_Y_SD_MIN**2))
            return self.pm_ewma * math.exp(self.k.x), sd
        if self.airborne and self.p_ewma:
            return self.p_ewma, math.sqrt(max(self.lnp_var, 0.0) / 10.0 + 0.02**2)
        return self._hold_power_model() * math.exp(self.k.x), math.hypot(self.k.sd, 0.05)

    def forecast_spread(self, horizon_s: float) -> float:
        """SD of ln(mean power over the next ``horizon_s`` / the present condition's power),
        as this flight has shown it: over its last :data:`HISTORY_S` seconds, how far the
        mean measured power over every window of that length (at most half the history)
        fell from the present condition forecast at the window's start (RMS, bias
        included). With under :data:`HISTORY_MIN_S` of history: the random walk
        :data:`POWER_WALK_PER_S`. [unitless]"""
        walk = math.sqrt(POWER_WALK_PER_S * max(horizon_s, 0.0) / 3.0)
        n = min(self._hist_n, HISTORY_S)
        if n < HISTORY_MIN_S or horizon_s <= 0:
            return walk
        h = self._hist[:n] if self._hist_n <= HISTORY_S else np.roll(
            self._hist, -(self._hist_n % HISTORY_S), axis=0)
        t, p, f = h[:, 0], h[:, 1], h[:, 2]
        ok = np.isfinite(p) & np.isfinite(f) & (p > 0) & (f > 0)
        t, p, f = t[ok], p[ok], f[ok]
        if t.size < HISTORY_MIN_S:
            return walk
        span = t[-1] - t[0]
        w = min(horizon_s, 0.5 * span)
        j = np.searchsorted(t, t + w, side="right")          # windows (i, j): t_i … t_i + w
        c = np.concatenate(([0.0], np.cumsum(p)))
        valid = (j - np.arange(t.size) > 1) & (t + w <= t[-1])
        if valid.sum() < 10:
            return walk
        i = np.flatnonzero(valid)
        mean_p = (c[j[i]] - c[i + 1]) / (j[i] - i - 1)
        # a window with a landing or a glitch in it counts as a factor 2 at most
        err = np.clip(np.log(mean_p / f[i]), -FORECAST_ERR_CLIP, FORECAST_ERR_CLIP)
        return max(float(np.sqrt(np.mean(err * err))), walk)

    def _descent(self) -> tuple[float, float]:
        """Time and power of the descent to land from the present altitude: the power
        model at the aircraft's descent rate (hovering in the wind), times the scale.
        [s], [W]"""
        alt = self._alt()
        if not (math.isfinite(alt) and alt > 0):
            return 0.0, 0.0
        rate = self.aircraft.descent_rate_ms
        wind = math.hypot(self.wind_n or 0.0, self.wind_e or 0.0)
        try:
            p = float(self.aircraft.battery_power(wind, -rate, self._rho(), self.mass))
        except ValueError:
            return 0.0, 0.0
        return alt / rate, p * math.exp(self.k.x)

    def horizon_charge(self, horizon_s: float, land: bool = True) -> dict:
        """Charge drawn over the next ``horizon_s`` at the present condition, the last
        part of it descending to land (``land``): ours (P5, median, P95) and the
        baselines' (PX4's filtered current, the mean current since take-off), which
        know nothing of a landing. [mAh]"""
        s0, g, _, c, k = self.samples()
        beta, scale = self.beta, self.scale
        delta_m = self.delta * c ** (-beta)
        p_now, sd0 = self.present_power()
        sd = math.hypot(sd0, self.forecast_spread(horizon_s))
        p_k = p_now * np.exp(sd * self.z[5])
        t_down, p_down = self._descent() if land else (0.0, 0.0)
        t_down = min(t_down, horizon_s)
        d_now = np.maximum((1.0 - s0) / g + self.q_now, 0.0) * AS_PER_MAH
        s_now = (d_now / scale) ** beta
        s_end = s_now + (horizon_s - t_down) / (delta_m * p_k ** self.eps)
        if t_down > 0 and p_down > 0:
            s_end = s_end + t_down / (delta_m * (p_down * p_k / p_now) ** self.eps)
        drawn = scale * (s_end ** (1 / beta) - s_now ** (1 / beta)) / AS_PER_MAH
        p5, p50, p95 = _pct(drawn)
        mean_i = self.mean_current()
        return {"p5": p5, "p50": p50, "p95": p95,
                "px4": self.px4_i * horizon_s / AS_PER_MAH,
                "rate": None if mean_i is None else mean_i * horizon_s / AS_PER_MAH}


def d_now_from(s_now, scale, beta):
    """Charge drawn since full at a stress (per-sample δ units). [A s]"""
    return scale * np.asarray(s_now) ** (1.0 / beta)
