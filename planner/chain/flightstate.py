r"""Flight state from a flight record: what the power model needs, in one module.

The mission chain's *from measured flight state* entry point
(:meth:`planner.chain.mission_chain.MissionChain.power_from_state`) takes a
:class:`FlightState`; every
command that drives the power model with a log (``replay``, ``fit-aircraft``,
``diagnose``, ``fleet``) builds it here, from one experiment of the flight record
(``docs/record.md``):

* **airspeed** — the measured true airspeed where the log has it; else the ground
  velocity corrected with the autopilot's wind estimate (the wind triangle of
  :func:`planner.physics.wind.airspeed_from_ground`); else the ground speed (still air assumed);
* **air density** — from the measured static pressure and outside air temperature
  (:func:`planner.physics.atmosphere.density`); from the pressure alone with the ISA temperature
  at the pressure altitude; else the ISA density at the site altitude;
* **specific force** — the magnitude of the accelerometer's specific force
  (``specific_force_ms2``) where the record has it: the measured thrust over mass;
* **flight phases** (:func:`flight_phases`) — *ground* where the power is below 30 % of
  the flight's 90th-percentile power; among airborne samples *climb* (vz > 0.5 m/s),
  *descent* (vz < −0.5 m/s), *cruise* (ground speed > 2 m/s) and *hover* (the rest);
  *takeoff* is the first 10 s after the first airborne sample, *landing* the last 3 s
  before the last one where the record goes on to the ground (:data:`LANDING_S`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from planner.physics import atmosphere
from planner.physics.wind import airspeed_from_ground

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["NOT_FLOWN", "PHASES", "FlightState", "air_density_from_log", "fill_gaps",
           "flight_phases", "flown", "from_record", "vertical_descent"]

#: Flight phases, in the order reports list them.
PHASES = ("ground", "takeoff", "climb", "cruise", "hover", "descent", "landing")
#: Share of the 90th-percentile power below which a sample is on the ground. [unitless]
GROUND_POWER_FRACTION = 0.3
#: Vertical speed beyond which an airborne sample climbs or descends. [m/s]
CLIMB_THRESHOLD_MS = 0.5
#: Ground (or in-plane) speed below which an airborne sample is still over ground: its
#: ground velocity is known whatever the course says, and a multirotor descending there
#: descends vertically (:func:`vertical_descent`). [m/s]
STILL_MS = 0.5
#: Ground speed above which an airborne sample cruises. [m/s]
CRUISE_THRESHOLD_MS = 2.0
#: Duration of the take-off phase after the first airborne sample. [s]
TAKEOFF_S = 10.0
#: Duration of the landing phase before the last airborne sample, where the record goes on
#: to the ground: the last rotor diameter of the descent at a landing's final sink of
#: 0.5–1 m/s, in ground effect (the induced power at a given thrust falls by the factor
#: :math:`1-(R/4z)^2`: Cheeseman & Bennett, "The effect of the ground on a helicopter rotor
#: in forward flight", ARC R&M 3021, 1955; Leishman, *Principles of Helicopter
#: Aerodynamics*, 2006, on the ground effect), then the gear taking the weight while the
#: motors spin down. Neither is flight the power model describes: the fits leave it out as
#: they leave out the take-off (on four draws of 16 M100 flights of the other routes,
#: Rodrigues et al. 2021, the last 2 s read 53 W below the calibrated model, the rest of
#: the final descent 5–25 W). [s]
LANDING_S = 3.0
#: Phases whose power no flight model describes (on the ground, the take-off, the
#: landing): the fits and the diagnosis leave them out (:func:`flown`).
NOT_FLOWN = ("ground", "takeoff", "landing")
#: Share of finite samples a channel needs to be used. [unitless]
CHANNEL_COVERAGE = 0.5


def flown(phase) -> np.ndarray:
    """Samples of :func:`flight_phases`' ``phase`` in flight the power model describes:
    none of :data:`NOT_FLOWN`. [bool]"""
    return ~np.isin(np.asarray(phase, dtype=object), NOT_FLOWN)


def vertical_descent(speed, climb_rate) -> np.ndarray:
    """Where a multirotor descends vertically: still over ground (``speed`` below
    :data:`STILL_MS`) and sinking faster than :data:`CLIMB_THRESHOLD_MS`, as the flight
    phases count a descent. [m/s] in, bool out."""
    return (np.asarray(speed, float) < STILL_MS) & \
        (np.asarray(climb_rate, float) < -CLIMB_THRESHOLD_MS)


def climb_regimes(climb_rate) -> dict[str, np.ndarray]:
    """Where a sample climbs and where it descends, whatever its ground speed: the
    vertical speed beyond ±:data:`CLIMB_THRESHOLD_MS`, as the flight phases count a climb
    and a descent. [m/s] in, bool out (``{"climb": …, "descent": …}``)."""
    climb = np.asarray(climb_rate, float)
    return {"climb": climb > CLIMB_THRESHOLD_MS, "descent": climb < -CLIMB_THRESHOLD_MS}


def flight_phases(power_w, climb_rate_ms=None, groundspeed_ms=None, time_s=None,
                  altitude_m=None) -> np.ndarray:
    """Label every sample with a flight phase (see the module notes).

    A record whose altitude never changes by 1 m (or is not known) and whose ground speed
    never exceeds 1 m/s is a ground test: every sample is ``ground``.

    Returns
    -------
    phase : ndarray of str
    """
    p = np.asarray(power_w, float)
    n = p.size
    if n == 0:
        return np.array([], dtype=object)
    finite = p[np.isfinite(p)]
    p90 = np.percentile(finite, 90) if finite.size else np.nan
    airborne = p > GROUND_POWER_FRACTION * p90
    if altitude_m is not None and groundspeed_ms is not None:
        alt = np.asarray(altitude_m, float)
        gsp = np.asarray(groundspeed_ms, float)
        still_alt = not np.isfinite(alt).any() or np.nanmax(alt) - np.nanmin(alt) < 1.0
        if still_alt and np.isfinite(gsp).any() and np.nanmax(gsp) < 1.0:
            return np.full(n, "ground", dtype=object)
    vz = np.zeros(n) if climb_rate_ms is None else np.nan_to_num(
        np.asarray(climb_rate_ms, float))
    gs = np.zeros(n) if groundspeed_ms is None else np.nan_to_num(
        np.asarray(groundspeed_ms, float))
    phase = np.where(vz > CLIMB_THRESHOLD_MS, "climb",
                     np.where(vz < -CLIMB_THRESHOLD_MS, "descent",
                              np.where(gs > CRUISE_THRESHOLD_MS, "cruise", "hover")))
    phase = np.where(airborne, phase, "ground").astype(object)
    if time_s is not None and airborne.any():
        t = np.asarray(time_s, float)
        t0 = t[np.argmax(airborne)]
        phase[airborne & (t >= t0) & (t < t0 + TAKEOFF_S)] = "takeoff"
        last = n - 1 - int(np.argmax(airborne[::-1]))
        if np.isfinite(p[last + 1:]).any():      # the record goes on to the ground
            t1 = t[last]
            phase[airborne & (phase != "takeoff") & (t > t1 - LANDING_S) & (t <= t1)] = \
                "landing"
    return phase


@dataclass
class FlightState:
    """The flight state of one experiment, sample by sample.

    Attributes
    ----------
    time_s : ndarray
        [s]
    airspeed_ms : ndarray
        True airspeed (never NaN: 0 where nothing is known). [m/s]
    climb_rate_ms : ndarray
        Vertical speed, up positive (0 where not logged). [m/s]
    air_density : ndarray
        [kg m⁻³]
    phase : ndarray of str
        :data:`PHASES`.
    measured_power_w : ndarray
        The record's electric power (NaN where missing). [W]
    airspeed_source, density_source : str
        Which channels gave the airspeed and the density, in words.
    specific_force_ms2 : ndarray or None
        Magnitude of the accelerometer's specific force where the record has it (gaps
        filled from neighbours), else None; thrust = mass × specific force. [m/s²]
    axial_speed_ms : ndarray or None
        Velocity along the thrust axis where the record has it (gaps filled), else None:
        see :meth:`rotor_velocities`. [m/s]
    """

    time_s: np.ndarray
    airspeed_ms: np.ndarray
    climb_rate_ms: np.ndarray
    air_density: np.ndarray
    phase: np.ndarray
    measured_power_w: np.ndarray
    airspeed_source: str
    density_source: str
    specific_force_ms2: np.ndarray | None = None
    axial_speed_ms: np.ndarray | None = None

    def rotor_velocities(self) -> tuple[np.ndarray, np.ndarray]:
        r"""Speed in the plane of a multirotor's rotor disks and along their axis. [m/s]

        Momentum theory of a rotor in forward flight (Glauert; Leishman 2006 ch. 2) works
        in the disk's frame: the flow through the disk is the velocity component along
        its axis, :math:`V \sin\alpha` for a disk tilted by α into a flight speed V,
        and the power :math:`T (v_i + V \sin\alpha)` holds the power to overcome the
        body's drag (in steady flight the tilt balances it). Where the record has the
        velocity along the thrust axis (``axial_speed_ms``), the disk's climb is that and
        its in-plane speed :math:`\sqrt{V^2 + \dot h^2 - v_{ax}^2}` (the speed is the
        same in both frames); otherwise they are the airspeed and the climb rate.
        """
        if not self.disk_frame:
            return self.airspeed_ms, self.climb_rate_ms
        ax = self.axial_speed_ms
        return inplane_speed(self.airspeed_ms, self.climb_rate_ms, ax), ax

    @property
    def disk_frame(self) -> bool:
        """True where :meth:`rotor_velocities` gives the disks' measured in-plane and
        axial speed (the record has the axial speed), false where it gives the airspeed
        and the climb rate (the power model then flies the tilt of the aircraft file's
        ``tilt_drag_area_m2`` where it has one). [unitless]"""
        return self.axial_speed_ms is not None

    def __len__(self) -> int:
        return len(self.time_s)

    @property
    def airborne(self) -> np.ndarray:
        """Samples in the air. [bool]"""
        return self.phase != "ground"


def inplane_speed(horizontal, climb, axial):
    r"""Speed in the plane of a rotor disk, :math:`\sqrt{V^2 + \dot h^2 - v_{ax}^2}`, from
    the horizontal speed, the climb rate and the speed along the disk's axis (the speed is
    the same in the ground's and the disk's frame; :meth:`FlightState.rotor_velocities`).
    [m/s]"""
    speed2 = np.asarray(horizontal, float) ** 2 + np.asarray(climb, float) ** 2
    return np.sqrt(np.maximum(speed2 - np.asarray(axial, float) ** 2, 0.0))


def _plausible(x: np.ndarray, column: str) -> np.ndarray:
    """``x`` with the values outside the record column's physical range
    (:data:`planner.io.record.PLAUSIBLE`) as NaN."""
    from planner.io.record import PLAUSIBLE   # the record module imports pandas: start-up

    low, high = PLAUSIBLE[column]
    with np.errstate(invalid="ignore"):
        return np.where((x >= low) & (x <= high), x, np.nan)


def fill_gaps(values) -> np.ndarray | None:
    """A logged series with its missing samples filled from the nearest valid ones
    (linear between them, held at the ends), as a float ndarray in the unit of
    ``values``; ``None`` when no sample is valid."""
    if values is None:
        return None
    x = np.asarray(values, dtype=float).ravel()
    ok = np.isfinite(x)
    if not ok.any():
        return None
    if not ok.all():
        idx = np.arange(x.size)
        x = np.interp(idx, idx[ok], x[ok])
    return x


def air_density_from_log(pressure_pa, temperature_c, site_altitude_m: float = 0.0, *,
                         coverage: float = CHANNEL_COVERAGE) -> tuple[np.ndarray, str]:
    """Air density along a log, and where it came from (the module notes' rule).

    From the measured static pressure and outside air temperature where both channels
    hold more than ``coverage`` of their samples; from the pressure alone with the ISA
    temperature at the pressure altitude; else the ISA density at the site
    (:func:`planner.physics.atmosphere.density`). Gaps are filled (:func:`fill_gaps`).

    Parameters
    ----------
    pressure_pa, temperature_c : array_like
        Logged static pressure [Pa] and outside air temperature [°C], NaN where missing.
    site_altitude_m : float
        Site altitude for the ISA density. [m]
    coverage : float
        Share of valid samples a channel needs to be used. [unitless]

    Returns
    -------
    density : ndarray
        [kg m⁻³]
    source : str
        How it was found, for reports.
    """
    p, temp = np.asarray(pressure_pa, float), np.asarray(temperature_c, float)
    have_p = np.isfinite(p).mean() > coverage
    if have_p and np.isfinite(temp).mean() > coverage:
        return (np.asarray(atmosphere.density(temperature_c=fill_gaps(temp),
                                              pressure_pa=fill_gaps(p)), float),
                "measured pressure and temperature")
    if have_p:
        p = fill_gaps(p)
        return (np.asarray(atmosphere.density(atmosphere.pressure_altitude(p),
                                              pressure_pa=p), float),
                "measured pressure, ISA temperature at the pressure altitude")
    return (np.full(p.size, float(atmosphere.density(site_altitude_m))),
            f"ISA at {site_altitude_m:.0f} m")


def from_record(exp: pd.DataFrame, site_altitude_m: float = 0.0) -> FlightState:
    """The flight state of one experiment of a flight record (see the module notes).

    Parameters
    ----------
    exp : DataFrame
        One experiment, flight-record columns (``docs/record.md``).
    site_altitude_m : float
        Site altitude for the ISA density when the log has no pressure. [m]

    Returns
    -------
    FlightState
    """
    n = len(exp)

    def col(name):
        return exp[name].to_numpy(float) if name in exp.columns else np.full(n, np.nan)

    airspeed, gs, course = col("airspeed_ms"), col("groundspeed_ms"), col("course_deg")
    wn, we = col("wind_n_ms"), col("wind_e_ms")
    have_wind = np.isfinite(wn) & np.isfinite(we) & ((np.abs(wn) + np.abs(we)) > 0)
    # hovering, the track is undefined (and often not logged): any course will do
    course = np.where(np.isfinite(course) | ~(np.nan_to_num(gs, nan=1.0) < 0.2), course, 0.0)
    if np.isfinite(airspeed).mean() > CHANNEL_COVERAGE:
        source = "measured airspeed"
        v = np.where(np.isfinite(airspeed), airspeed, gs)
    elif have_wind.mean() > CHANNEL_COVERAGE:
        source = "ground speed corrected with the logged wind"
        v = np.where(have_wind & np.isfinite(course),
                     airspeed_from_ground(gs, course, we, wn), gs)
    else:
        source = "ground speed (no airspeed or wind in the log: still air assumed)"
        v = gs
    v = np.abs(np.nan_to_num(v))
    climb = np.nan_to_num(col("climb_rate_ms"))
    p, temp = col("pressure_pa"), col("ambient_temperature_c")
    # a logged value outside its physical range (damage, a sensor fault) is missing, as
    # when a record file is read (planner.io.record.PLAUSIBLE)
    rho, dsource = air_density_from_log(_plausible(p, "pressure_pa"),
                                        _plausible(temp, "ambient_temperature_c"),
                                        site_altitude_m)
    t = exp["time_s"].to_numpy(float)
    power = col("power_w")
    phase = flight_phases(power, exp.get("climb_rate_ms"), exp.get("groundspeed_ms"), t,
                          exp.get("altitude_m"))
    force = col("specific_force_ms2")
    force = fill_gaps(force) if np.isfinite(force).mean() > CHANNEL_COVERAGE else None
    axial = col("axial_speed_ms")
    axial = fill_gaps(axial) if np.isfinite(axial).mean() > CHANNEL_COVERAGE else None
    return FlightState(time_s=t, airspeed_ms=v, climb_rate_ms=climb,
                       air_density=np.asarray(rho, float), phase=phase,
                       measured_power_w=power, airspeed_source=source,
                       density_source=dsource, specific_force_ms2=force,
                       axial_speed_ms=axial)
