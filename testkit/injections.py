r"""Physical effects injected into real flight records, by laws written here.

Every function takes a real flight record (one or more experiments, the columns of
docs/record.md) and returns a copy changed by one physical law. The laws are written in
this module from textbook physics and the data's own measurements; none calls the
planner's power or battery models, so that ``diagnose`` is examined on data it did not
make. The laws and their sources:

Pack (every injection that changes the electric power)
    The pack is a voltage source behind a resistance :math:`R_p`: an added electric power
    :math:`\Delta P` at the same source voltage raises the current from :math:`I` to the
    :math:`I'` that solves :math:`(V - R_p (I' - I))\,I' = V I + \Delta P`, and the
    terminal voltage falls to :math:`V - R_p (I' - I)` (:func:`add_power`). The logged
    charge is integrated again from the new current.
Mass (:func:`payload_step`, multirotor)
    Momentum theory with Glauert's forward-flight inflow (Leishman 2006, *Principles of
    Helicopter Aerodynamics*, 2nd ed., eq. 2.37 and sec. 2.14): the ideal induced power of
    thrust :math:`T = m g` at speed :math:`V` is :math:`T v_i` with
    :math:`v_i^2 = \tfrac12\big(\sqrt{V^4 + 4 v_h^4} - V^2\big)`,
    :math:`v_h = \sqrt{T / (2 \rho A)}`, plus the climb power :math:`T v_c`. The electric
    power per ideal induced power is the flight's own: the median ratio over its slowest
    level flying samples (hover, where nearly all the power is induced). A mass change
    changes only that part; profile and parasite power stay.
Mass, measured (:func:`payload_step` with ``w_per_kg``, multirotor)
    The battery power changes by a measured amount per kilogram, the same in every regime
    where the rotors carry the weight: what an aircraft's own flights at several payloads
    show where momentum theory's dependence on the regime does not hold (the DJI M100:
    about 200 W/kg in level cruise at 4–12 m/s, in the vertical climb and in the vertical
    descent alike, where the law above gives 190–395 W/kg by regime on the same flights).
Flying (:func:`lifting`, multirotor)
    Every multirotor law acts only where the aircraft flies, where it draws at least
    the ideal power above (no rotor carrying its weight undercuts it). Height above the
    first sample is no test: it keeps idle rotors after a landing whose barometric
    altitude has drifted a few metres and ground tests with no altitude, and it drops
    hovers whose record starts in the air.
Mass (:func:`payload_step`, fixed wing)
    Induced drag :math:`D_i = (m g)^2 / (\tfrac12 \rho V^2 \pi e b^2)` and climb power
    :math:`m g v_c`, divided by a propulsive efficiency (Anderson, *Aircraft Performance
    and Design*, 1999, eq. 2.45 and 5.9).
Airspeed (:func:`steady_wind`, :func:`air_density`)
    The source's own power–speed law, fitted by least squares on its clean level-flight
    samples: :math:`P(V) = a\,\pi_i(V) + b V^3 + c`, :math:`\pi_i` the ideal induced power
    above (rotor power), :math:`b V^3` the parasite power, :math:`c` the rest. A multirotor
    holds its ground velocity: in a steady wind :math:`\vec w` it flies the airspeed
    :math:`|\vec v_g - \vec w|`. A fixed wing holds its airspeed: the wind moves it over
    ground (ground speed and course change, the power does not).
Air density (:func:`air_density`)
    At constant thrust, momentum theory gives rotor power :math:`\propto \rho^{-1/2}`
    (induced power :math:`T^{3/2}/\sqrt{2\rho A}`; the profile power
    :math:`\propto \rho \Omega^3` with :math:`\Omega \propto \rho^{-1/2}` at constant
    thrust, the same) and parasite power :math:`\propto \rho` (Leishman 2006, ch. 2 and 5).
    The static pressure and the air temperature are logged for every flight
    (:math:`\rho = p/(R_d T)`, :math:`R_d` = 287.05 J/(kg K)).
Cold pack (:func:`cold_pack`)
    Arrhenius law of the cell's DC resistance, :math:`R(T) = R_{25}\exp[E_a/R_g (1/T -
    1/T_{25})]` (Jaguemont, Boulon and Dubé 2016, Applied Energy 164, 99–114), applied to
    the whole resistance of each experiment's pack as its record shows it (the voltage's
    step against the current's, :func:`dc_resistance`); the load draws the same power, so
    the current rises as the voltage sags.
Current sensor (:func:`current_offset`)
    The logged current reads :math:`b` too high; the logged charge integrates it. Where
    the record's power is logged independently (a power module that measures the power
    itself), that channel keeps the true power; otherwise it is the logged V·I.
Loads (:func:`constant_load`, :func:`copper_loss`)
    An added constant electric load :math:`L`, or a copper loss :math:`R_c I^2` (a
    resistive loss in the wiring, ESCs and windings).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

#: Standard gravity. [m/s²]
G = 9.80665
#: Universal gas constant. [J/(mol K)]
R_GAS = 8.314462618
#: Specific gas constant of dry air. [J/(kg K)]
R_AIR = 287.05
#: 0 °C. [K]
T0_K = 273.15
#: Height above the first sample above which a multirotor counts as airborne. [m]
AIRBORNE_HEIGHT_M = 2.0


@dataclass(frozen=True)
class Rotors:
    """A multirotor's rotor disks: ``count`` disks of ``diameter_m``. [-], [m]"""

    count: int
    diameter_m: float

    @property
    def area_m2(self) -> float:
        """Total disk area. [m²]"""
        return self.count * math.pi * (0.5 * self.diameter_m) ** 2


@dataclass(frozen=True)
class Wing:
    """A fixed wing: span [m], Oswald factor e, propulsive efficiency (battery to thrust
    power). [m], [-], [-]"""

    span_m: float
    oswald: float
    propulsive_efficiency: float


# ============================================================================ helpers

def experiments(df: pd.DataFrame):
    """(id, row index) of each experiment, in order of first appearance."""
    if "experiment" not in df:
        return [(None, df.index)]
    return list(df.groupby("experiment", sort=False).groups.items())


def mass_of(mass_kg, g: pd.DataFrame) -> float:
    """The all-up mass of the experiment ``g``: ``mass_kg`` itself, or where the flights
    differ (a mapping from each experiment's id, as a string, to its mass) the one of
    ``g``'s experiment. [kg]"""
    if not isinstance(mass_kg, Mapping):
        return float(mass_kg)
    return float(mass_kg[str(g["experiment"].iloc[0])])


def integrate_mah(t: np.ndarray, i: np.ndarray) -> np.ndarray:
    """Trapezoid integral of a current from the first sample. [mAh]"""
    q = np.concatenate(([0.0], np.cumsum(0.5 * (i[1:] + i[:-1]) * np.diff(t))))
    return q / 3.6


def airborne(g: pd.DataFrame) -> np.ndarray:
    """Airborne samples of one experiment: more than :data:`AIRBORNE_HEIGHT_M` above its
    first valid altitude, else a measured airspeed above 5 m/s, else every sample."""
    if "altitude_m" in g and np.isfinite(g["altitude_m"]).sum() > 10:
        alt = g["altitude_m"].to_numpy(float)
        base = alt[np.isfinite(alt)][0]
        with np.errstate(invalid="ignore"):
            return np.nan_to_num(alt - base, nan=0.0) > AIRBORNE_HEIGHT_M
    if "airspeed_ms" in g and np.isfinite(g["airspeed_ms"]).sum() > 10:
        return np.nan_to_num(g["airspeed_ms"].to_numpy(float)) > 5.0
    return np.ones(len(g), bool)


#: Samples over which the power must stay above the lifting floor (a running median):
#: a single spike of a motor test on the ground is not a flight.
LIFT_MEDIAN_SAMPLES = 5


def lifting(g: pd.DataFrame, mass_kg, rho: float, area_m2: float) -> np.ndarray:
    """Samples of one experiment at which a multirotor of ``mass_kg`` (:func:`mass_of`) is
    flying: its electric power (a running median of :data:`LIFT_MEDIAN_SAMPLES`) at least
    the ideal induced and climb power of its weight at its speed
    (:func:`ideal_rotor_power`), which no rotor carrying that weight can undercut (its
    efficiency is below 1), and the sample's own power as well. The height above the
    first sample (:func:`airborne`) misses what this catches: idle rotors
    after a landing whose barometric altitude has drifted above the take-off's, ground
    tests with no altitude, and records that start in the air (a hover whose altitude
    then reads below its first sample)."""
    p = _col(g, "power_w", np.nan)
    steady = pd.Series(p).rolling(LIFT_MEDIAN_SAMPLES, center=True,
                                  min_periods=1).median().to_numpy()
    floor = ideal_rotor_power(mass_of(mass_kg, g), rho, area_m2, speed_of(g),
                              _col(g, "climb_rate_ms"))
    with np.errstate(invalid="ignore"):
        return np.isfinite(p) & (p >= floor) & (steady >= floor)


def add_power(df: pd.DataFrame, dp: np.ndarray, pack_resistance_ohm: float,
              power_logged: bool = False) -> pd.DataFrame:
    r"""The record with an added electric power ``dp`` [W] per row (module notes, "Pack"):
    new current and voltage, ``power_w`` = V'·I' (unless ``power_logged``: the logged power
    channel then gets the true added power too, V·I + ΔP), ``consumed_mah`` integrated
    again per experiment."""
    out = df.copy()
    v = df["voltage_v"].to_numpy(float)
    i = df["current_a"].to_numpy(float)
    dp = np.asarray(dp, float)
    r = float(pack_resistance_ohm)
    if r > 0:
        b = v + r * i
        disc = np.maximum(b * b - 4.0 * r * (v * i + dp), 0.0)
        i_new = (b - np.sqrt(disc)) / (2.0 * r)
    else:
        i_new = i + dp / v
    v_new = v - r * (i_new - i)
    out["current_a"] = i_new
    out["voltage_v"] = v_new
    if power_logged and "power_w" in df:
        out["power_w"] = df["power_w"].to_numpy(float) + dp
    else:
        out["power_w"] = v_new * i_new
    return recount(out)


def recount(df: pd.DataFrame) -> pd.DataFrame:
    """``consumed_mah`` integrated again from ``current_a`` per experiment (a logger's
    charge counter integrates its own current sensor)."""
    if "consumed_mah" not in df:
        return df
    q = np.empty(len(df))
    t_all = df["time_s"].to_numpy(float)
    i_all = df["current_a"].to_numpy(float)
    for _, idx in experiments(df):
        pos = df.index.get_indexer(idx)
        q[pos] = integrate_mah(t_all[pos], i_all[pos])
    df = df.copy()
    df["consumed_mah"] = q
    return df


def induced_velocity(thrust_n, rho, area_m2, speed_ms) -> np.ndarray:
    """Glauert's induced velocity of a rotor in level flight (module notes). [m/s]"""
    vh2 = np.asarray(thrust_n, float) / (2.0 * rho * area_m2)
    v2 = np.asarray(speed_ms, float) ** 2
    return np.sqrt(0.5 * (np.sqrt(v2 * v2 + 4.0 * vh2 * vh2) - v2))


def ideal_rotor_power(mass_kg, rho, area_m2, speed_ms, climb_ms=0.0) -> np.ndarray:
    """Ideal induced plus climb power of a multirotor of ``mass_kg`` (module notes). [W]"""
    t = np.asarray(mass_kg, float) * G
    vi = induced_velocity(t, rho, area_m2, speed_ms)
    return t * np.maximum(vi + np.asarray(climb_ms, float), 0.1 * vi)


def _col(g: pd.DataFrame, name: str, default=0.0) -> np.ndarray:
    if name in g:
        x = g[name].to_numpy(float)
        return np.where(np.isfinite(x), x, default)
    return np.full(len(g), float(default))


def speed_of(g: pd.DataFrame) -> np.ndarray:
    """The speed the injection laws fly: the logged airspeed, else the ground speed. [m/s]"""
    if "airspeed_ms" in g and np.isfinite(g["airspeed_ms"]).mean() > 0.5:
        return _col(g, "airspeed_ms")
    return np.abs(_col(g, "groundspeed_ms"))


# ============================================================================ mass

def electric_per_ideal(g: pd.DataFrame, mass_kg: float, rho: float, rotors: Rotors,
                       up: np.ndarray | None = None) -> float:
    """The flight's electric power per ideal induced power, over its slowest tenth of the
    level airborne samples (below 1.5 m/s where there are 20 or more); ``up``: the
    flight's :func:`lifting` samples where the caller has them. [unitless]"""
    if up is None:
        up = lifting(g, mass_kg, rho, rotors.area_m2)
    climb = _col(g, "climb_rate_ms")
    v = speed_of(g)
    p = _col(g, "power_w", np.nan)
    level = up & (np.abs(climb) < 0.5) & np.isfinite(p)
    if level.sum() < 10:
        level = up & np.isfinite(p)
    slow = level & (v < 1.5)
    if slow.sum() < 20:
        cut = np.percentile(v[level], 10) if level.any() else np.inf
        slow = level & (v <= cut)
    ideal = ideal_rotor_power(mass_kg, rho, rotors.area_m2, v[slow])
    return float(np.median(p[slow] / ideal)) if slow.any() else 1.0


def change_times(df: pd.DataFrame, fractions, flying=airborne) -> dict:
    """Each experiment's time [s] at ``fractions`` (one per experiment) of its span in
    the air, the samples ``flying(g)`` marks (default :func:`airborne`)."""
    out = {}
    for (key, idx), u in zip(experiments(df), fractions):
        g = df.loc[idx]
        up = np.flatnonzero(flying(g))
        if up.size < 10:
            continue
        t = g["time_s"].to_numpy(float)
        out[key] = float(t[up[0]] + u * (t[up[-1]] - t[up[0]]))
    return out


def payload_step(df: pd.DataFrame, dm_kg: float, times: dict, mass_kg, *,
                 rho: float, pack_resistance_ohm: float, rotors: Rotors | None = None,
                 wing: Wing | None = None, power_logged: bool = False,
                 w_per_kg: float | None = None) -> pd.DataFrame:
    """The record with the mass changed by ``dm_kg`` (negative: a drop) at each
    experiment's time in ``times`` while airborne (module notes, "Mass"). ``mass_kg``:
    the all-up mass before the change (:func:`mass_of`). ``w_per_kg``: a multirotor's
    measured change of battery power per kilogram, the same wherever its rotors carry it
    (module notes, "Mass, measured"), in place of momentum theory. [kg], [s], [W/kg]"""
    dp = np.zeros(len(df))
    for key, idx in experiments(df):
        if key not in times:
            continue
        g = df.loc[idx]
        m = mass_of(mass_kg, g)
        pos = df.index.get_indexer(idx)
        up = lifting(g, m, rho, rotors.area_m2) if rotors is not None else airborne(g)
        after = up & (g["time_s"].to_numpy(float) >= times[key])
        v = speed_of(g)
        climb = _col(g, "climb_rate_ms")
        if rotors is not None and w_per_kg is not None:
            gain = np.full(len(g), w_per_kg * dm_kg)
        elif rotors is not None:
            k = electric_per_ideal(g, m, rho, rotors, up)
            gain = k * (ideal_rotor_power(m + dm_kg, rho, rotors.area_m2, v, climb)
                        - ideal_rotor_power(m, rho, rotors.area_m2, v, climb))
        else:
            vv = np.maximum(v, 1.0)
            q = 0.5 * rho * vv**2
            di = ((G * (m + dm_kg)) ** 2 - (G * m) ** 2) / (
                q * math.pi * wing.oswald * wing.span_m**2)
            gain = (di * vv + dm_kg * G * climb) / wing.propulsive_efficiency
        dp[pos] = np.where(after, gain, 0.0)
    return add_power(df, dp, pack_resistance_ohm, power_logged)


# ============================================================================ airspeed

@dataclass(frozen=True)
class SpeedLaw:
    r""":math:`P(V) = a\,\pi_i(V) + b V^3 + c` [W] of a source's level flight (module notes),
    with :math:`\pi_i` the ideal induced power [W] at ``mass_kg`` and ``rho``; where the
    flights' masses differ (``mass_kg`` a mapping, :func:`mass_of`), :meth:`of` gives
    each flight's law."""

    a: float
    b: float
    c: float
    mass_kg: float | Mapping
    rho: float
    area_m2: float

    def of(self, g: pd.DataFrame) -> "SpeedLaw":
        """The law of the experiment ``g``, at its own mass."""
        return dataclasses.replace(self, mass_kg=mass_of(self.mass_kg, g))

    def rotor(self, v) -> np.ndarray:
        """The rotor (induced and profile) part :math:`a\\,\\pi_i(V)`. [W]"""
        return self.a * ideal_rotor_power(self.mass_kg, self.rho, self.area_m2, v)

    def parasite(self, v) -> np.ndarray:
        """The parasite part :math:`b V^3`. [W]"""
        return self.b * np.asarray(v, float) ** 3

    def __call__(self, v) -> np.ndarray:
        return self.rotor(v) + self.parasite(v) + self.c

    def flying(self, g: pd.DataFrame) -> np.ndarray:
        """:func:`lifting` at the law's mass, density and disk area."""
        return lifting(g, self.mass_kg, self.rho, self.area_m2)


def fit_speed_law(df: pd.DataFrame, mass_kg, rho: float, rotors: Rotors) -> SpeedLaw:
    """:class:`SpeedLaw` by least squares on the level flying samples of ``df`` (|climb|
    < 0.5 m/s, :func:`lifting`); the coefficients are kept non-negative (a and b by
    NNLS)."""
    from scipy.optimize import nnls

    xs, ys = [], []
    for _, idx in experiments(df):
        g = df.loc[idx]
        level = np.abs(_col(g, "climb_rate_ms")) < 0.5
        ok = lifting(g, mass_kg, rho, rotors.area_m2) & level
        v = speed_of(g)[ok]
        xs.append(np.column_stack([ideal_rotor_power(mass_of(mass_kg, g), rho, rotors.area_m2,
                                                     v), v**3,
                                   np.ones(v.size)]))
        ys.append(_col(g, "power_w")[ok])
    X, y = np.vstack(xs), np.concatenate(ys)
    coef, _ = nnls(X, y)
    return SpeedLaw(float(coef[0]), float(coef[1]), float(coef[2]), mass_kg, rho,
                    rotors.area_m2)


def ground_velocity(g: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """North and east ground velocity from ground speed and course (0 where the course is
    unknown). [m/s]"""
    gs = np.abs(_col(g, "groundspeed_ms"))
    c = g["course_deg"].to_numpy(float) if "course_deg" in g else np.full(len(g), np.nan)
    a = np.radians(np.where(np.isfinite(c), c, 0.0))
    known = np.isfinite(c)
    return np.where(known, gs * np.cos(a), 0.0), np.where(known, gs * np.sin(a), 0.0)


def steady_wind(df: pd.DataFrame, speed_ms: float, from_deg: float, *, law: SpeedLaw | None,
                pack_resistance_ohm: float, power_logged: bool = False) -> pd.DataFrame:
    """The record flown in a steady wind of ``speed_ms`` from ``from_deg`` (module notes,
    "Airspeed"): a multirotor (``law`` given) holds its ground velocity and its power
    follows the airspeed; a fixed wing (``law`` None) holds its airspeed and is carried
    over ground. The autopilot's own wind estimate (``wind_n_ms``, ``wind_e_ms``) did not
    see this wind and is dropped. [m/s], [deg]"""
    to = math.radians(from_deg + 180.0)
    wn, we = speed_ms * math.cos(to), speed_ms * math.sin(to)
    out = df.drop(columns=[c for c in ("wind_n_ms", "wind_e_ms") if c in df])
    if law is None:
        vn, ve = ground_velocity(out)
        up = np.concatenate([airborne(out.loc[idx]) for _, idx in experiments(out)])
        vn, ve = vn + np.where(up, wn, 0.0), ve + np.where(up, we, 0.0)
        out = out.copy()
        out["groundspeed_ms"] = np.hypot(vn, ve)
        out["course_deg"] = np.degrees(np.arctan2(ve, vn)) % 360.0
        return out
    dp = np.zeros(len(out))
    for _, idx in experiments(out):
        g = out.loc[idx]
        pos = out.index.get_indexer(idx)
        vn, ve = ground_velocity(g)
        before = np.hypot(vn, ve)
        after = np.hypot(vn - wn, ve - we)
        own = law.of(g)
        dp[pos] = np.where(own.flying(g), own(after) - own(before), 0.0)
    return add_power(out, dp, pack_resistance_ohm, power_logged)


def air_density(df: pd.DataFrame, ratios: dict, *, site_pressure_pa: float,
                site_temperature_c: float, law: SpeedLaw | None, rng, pack_resistance_ohm: float,
                wing_split=None, avionics_w: float = 0.0, power_logged: bool = False
                ) -> pd.DataFrame:
    """The record with each experiment flown at ``ratios[id]`` × the site's density
    (module notes, "Air density"), and ``pressure_pa`` and ``ambient_temperature_c``
    logged for every experiment: the site's (``site_*``) where the ratio is 1, else a
    warmer day (10–25 K) at the pressure that gives the ratio; each with a sensor's noise
    (30 Pa, 0.3 K). A multirotor's measured power less the law's parasite power and the
    avionics' ``avionics_w`` is rotor power (∝ ρ^-1/2); the parasite power ∝ ρ.
    ``wing_split(g)``: for a fixed wing, the parasite and induced power of each sample [W],
    which scale as ρ and 1/ρ at the same airspeed."""
    out = df.copy()
    rho0 = site_pressure_pa / (R_AIR * (site_temperature_c + T0_K))
    dp = np.zeros(len(out))
    pres = np.zeros(len(out))
    temp = np.zeros(len(out))
    for key, idx in experiments(out):
        g = out.loc[idx]
        pos = out.index.get_indexer(idx)
        s = float(ratios.get(key, 1.0))
        t_c = site_temperature_c if s == 1.0 else site_temperature_c + rng.uniform(10.0, 25.0)
        p = s * rho0 * R_AIR * (t_c + T0_K)
        pres[pos] = p + rng.normal(0.0, 30.0, len(g))
        temp[pos] = t_c + rng.normal(0.0, 0.3, len(g))
        if s == 1.0:
            continue
        up = law.flying(g) if law is not None else airborne(g)
        if law is not None:
            v = speed_of(g)
            par = law.parasite(v)
            rotor = np.maximum(_col(g, "power_w") - par - avionics_w, 0.0)
            gain = rotor * (s**-0.5 - 1.0) + par * (s - 1.0)
        else:
            par, ind = wing_split(g)
            gain = par * (s - 1.0) + ind * (1.0 / s - 1.0)
        dp[pos] = np.where(up, gain, 0.0)
    out = add_power(out, dp, pack_resistance_ohm, power_logged)
    out["pressure_pa"] = pres
    out["ambient_temperature_c"] = temp
    return out


# ============================================================================ loads

def constant_load(df: pd.DataFrame, watts: float, *, pack_resistance_ohm: float,
                  power_logged: bool = False) -> pd.DataFrame:
    """The record with a constant electric load of ``watts`` added throughout. [W]"""
    return add_power(df, np.full(len(df), float(watts)), pack_resistance_ohm, power_logged)


def copper_loss(df: pd.DataFrame, ohm: float, *, pack_resistance_ohm: float,
                power_logged: bool = False) -> pd.DataFrame:
    """The record with a resistive loss ``ohm`` × I² added (I the logged current). [Ω]"""
    i = df["current_a"].to_numpy(float)
    return add_power(df, ohm * i * i, pack_resistance_ohm, power_logged)


def current_offset(df: pd.DataFrame, amps: float, *, power_logged: bool, rng=None,
                   power_gain_sd: float = 0.01, power_noise: float = 0.003) -> pd.DataFrame:
    """The record as a current sensor reading ``amps`` too high logs it (module notes,
    "Current sensor"): the logged current and charge carry it; ``power_w`` is V·I of the
    logged current unless ``power_logged`` (an independent power channel, which measures
    the true power with a calibration error of its own, a gain off by N(0,
    ``power_gain_sd``), and a noise of ``power_noise`` of the reading). [A]"""
    out = df.copy()
    v = df["voltage_v"].to_numpy(float)
    i = df["current_a"].to_numpy(float)
    true_p = df["power_w"].to_numpy(float) if "power_w" in df else v * i
    out["current_a"] = i + amps
    if power_logged:
        rng = rng or np.random.default_rng(0)
        gain = 1.0 + rng.normal(0.0, power_gain_sd)
        out["power_w"] = true_p * gain * (1.0 + rng.normal(0.0, power_noise, len(df)))
    else:
        out["power_w"] = v * (i + amps)
    if "consumed_mah" not in out:
        out["consumed_mah"] = 0.0
    return recount(out)


# ============================================================================ pack temperature

def arrhenius(temp_c, ea_j_per_mol: float, ref_c: float = 25.0) -> np.ndarray:
    """R(T)/R(T_ref) of a thermally activated resistance (module notes). [unitless]"""
    return np.exp(ea_j_per_mol / R_GAS * (1.0 / (np.asarray(temp_c, float) + T0_K)
                                          - 1.0 / (ref_c + T0_K)))


def dc_resistance(df: pd.DataFrame, step_share: float = 0.1) -> dict:
    r"""Each experiment's DC resistance as the record shows it [Ω]: the least-squares slope
    of the voltage's first differences on the current's, :math:`R = -\sum \Delta V \Delta I /
    \sum \Delta I^2`, over the samples whose current steps by more than ``step_share`` of the
    experiment's median current (the voltage's response to a current step: the pulse
    resistance of Plett, *Battery Management Systems* vol. 1, 2015, §2.10). None for an
    experiment with fewer than ten such steps or a slope that is not positive."""
    out = {}
    for key, idx in experiments(df):
        i = df.loc[idx, "current_a"].to_numpy(float)
        v = df.loc[idx, "voltage_v"].to_numpy(float)
        ok = np.isfinite(i) & np.isfinite(v)
        di, dv = np.diff(i[ok]), np.diff(v[ok])
        level = float(np.median(np.abs(i[ok]))) if ok.any() else 0.0
        step = np.abs(di) > step_share * max(level, 1e-6)
        r = -float(np.dot(dv[step], di[step])) / float(np.dot(di[step], di[step])) \
            if step.sum() >= 10 else math.nan
        out[key] = r if r > 0 else None
    return out


def cold_pack(df: pd.DataFrame, temps_c: dict, *, ea_j_per_mol: float,
              pack_resistance_ohm: float, flown_c: float = 25.0, self_heating_k: float = 3.0,
              rng=None) -> pd.DataFrame:
    r"""The record with each experiment's pack at ``temps_c[id]`` (module notes, "Cold
    pack"): the pack warms by ``self_heating_k`` over the charge drawn; its whole DC
    resistance follows Arrhenius from the one it had as flown (the real flight's pack at
    ``flown_c``), :math:`R(T) = R_{own}\,r(T)/r(T_{flown})`, with :math:`R_{own}` the
    experiment's resistance as its record shows it (:func:`dc_resistance`; where that
    cannot be measured, ``pack_resistance_ohm``). The ratio of the resistance at two
    temperatures is then Arrhenius's whatever each pack's own resistance, as the law says;
    one increment of resistance added to every pack would not be. The load keeps its
    power, so the current solves :math:`(V - R_{own} (I' - I) - \Delta R\,I')\,I' = V I`,
    with :math:`\Delta R = R(T) - R_{own}`. ``temperature_c`` is logged with a sensor's
    0.5 K noise. [°C], [Ω], [J/mol]"""
    out = df.copy()
    v = df["voltage_v"].to_numpy(float)
    i = df["current_a"].to_numpy(float)
    temp = np.full(len(df), np.nan)
    dr = np.zeros(len(df))
    rp = np.full(len(df), float(pack_resistance_ohm))
    own = dc_resistance(df)
    t_all = df["time_s"].to_numpy(float)
    for key, idx in experiments(df):
        pos = df.index.get_indexer(idx)
        q = integrate_mah(t_all[pos], np.maximum(i[pos], 0.0))
        frac = q / q[-1] if q[-1] > 0 else np.zeros_like(q)
        tc = float(temps_c[key]) + self_heating_k * frac
        temp[pos] = tc
        r_own = own.get(key) or float(pack_resistance_ohm)
        rp[pos] = r_own
        dr[pos] = r_own * (arrhenius(tc, ea_j_per_mol, ref_c=flown_c) - 1.0)
    # (V + R_p I) - (R_p + ΔR) I' ... quadratic in I': (R_p + ΔR) I'^2 - (V + R_p I) I' + V I = 0
    a = rp + dr
    b = v + rp * i
    disc = np.maximum(b * b - 4.0 * a * v * i, 0.0)
    i_new = np.where(a > 0, (b - np.sqrt(disc)) / np.where(a > 0, 2.0 * a, 1.0), i)
    v_new = v - rp * (i_new - i) - dr * i_new
    out["current_a"] = i_new
    out["voltage_v"] = v_new
    out["power_w"] = v_new * i_new
    noise = rng.normal(0.0, 0.5, len(df)) if rng is not None else 0.0
    out["temperature_c"] = temp + noise
    return recount(out)
