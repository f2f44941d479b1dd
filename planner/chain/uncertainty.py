r"""A probabilistic verdict: Monte Carlo of the mission through the one chain.

Every input of the pre-flight check is uncertain. :func:`monte_carlo` draws the inputs,
flies every draw through :class:`~planner.chain.mission_chain.MissionChain` — the chain's
pack axis is the sample axis, each sample a variant of the pack (``pack_samples``) with its
own payload and power error — and reports the probability of landing with the reserve,
percentiles of the charge left on landing and of the smallest return-home margin, the
conditional value at risk of the landing charge and which input drives the spread.

Sources and how each is drawn
-----------------------------
* **the power model's own error**: the battery power of every sample is multiplied by a
  log-normal factor :math:`e^{\sigma z}`, σ the aircraft file's ``energy_error_sd`` (the
  RMS per-flight energy error of the fitted model on the flights ``fit-aircraft`` trained
  on), else :data:`DEFAULT_MODEL_ERROR_SD`, said so. Drawn by default: a band without it
  claims the model is exact.
* **integral model** δ, ε, β: multivariate normal with the pack file's
  ``model.covariance`` (written by ``fit-battery``); absent → not drawn, and said so.
  That is the uncertainty of the model's mean; a discharge also scatters about the mean
  model (its start, its temperature, the cells' state), which the **integral model's
  own charge error** draws: the charge of every sample is multiplied by a log-normal
  factor :math:`e^{\sigma_C z}` (δ by :math:`e^{-\beta\sigma_C z}`, [UAV23] eq. 14),
  :math:`\sigma_C` the pack file's ``model.charge_error_sd`` (the RMS final charge error
  of ``fit-battery``'s fit on its training discharges); absent → not drawn, said so.
* **aircraft parameters**: the aircraft file stores no parameter covariance
  (``fit-aircraft`` prints standard errors only): not drawn, and said so; their effect on
  the whole-flight energy is in the power error above.
* **wind**: speed normal (``wind_sd_ms``, truncated at 0) and direction normal
  (``wind_direction_sd_deg``) about the forecast; a **gust factor** F (peak gust over mean
  wind, as a METAR ``G`` group gives it) makes the effective steady wind of each draw
  uniform between the drawn mean and F × mean.
* **air temperature**: normal (``temperature_sd_c``) about the forecast (ISA at the site
  when none is given); it sets the air density and the pack's starting temperature.
* **state of health**: the charge the pack can give (nominal × usable fraction, and the
  circuit model's charge to the cut-off) × SoH, SoH normal (``soh`` ± ``soh_sd``, capped
  at 1 / usable fraction so no sample gives more than the nominal charge).
* **payload**: normal (``payload_sd_kg``) about the mission's, truncated at 0.

A forecast is never exact: a wind or temperature spread left unset (None) is the default
forecast spread (:data:`DEFAULT_FORECAST_SPREADS`, each with its source, named in the
result); 0 is "not drawn". A run in which nothing is drawn is refused: its band would be
the forecast's one number, its probability 0 or 1.

The weather changes every leg's kinematics, so the weather is drawn at ``weather_draws``
points of a Latin hypercube (McKay, Beckman and Conover 1979) — by default one per
:data:`SAMPLES_PER_WEATHER_DRAW` samples, at most :data:`MAX_DEFAULT_WEATHER_DRAWS` — and the chain runs once per weather draw with
that draw's share of the samples on its pack axis; the pack inputs are drawn per sample.
The power model and the circuit model cost one evaluation per distinct take-off mass and
power error, so the samples of a weather draw share a few levels of the payload and of
the power error (:data:`PAYLOAD_LEVELS`, or more where the weather draws are few), one
drawn in each stratum of equal probability (stratified sampling). The probability's resolution is one over the number of independent
draws of the most coarsely drawn input (the weather draws, as a rule). The return-home
reserve of every sample is checked at the points where the nominal run is tightest plus a
regular thinning of the rest (``rtl_points``), not at every point of every leg.

Outputs
-------
* :math:`P(\text{land with the reserve})` — the share of samples that fly the mission within
  every limit of the check (return home aside) and land with at least the reserve;
  GO when it is at least ``confidence``; and its resolution.
* P5 / P50 / P95 of the charge left on landing (usable − drawn) and of the smallest
  return-home margin along the mission.
* :math:`\mathrm{CVaR}_{5\%}` of the landing charge: the mean of the worst 5 % of samples,
  the risk measure Choudhry et al. propose for energy-aware planning [1]_.
* The variance split: the landing charge regressed on the independently drawn inputs,
  each with a linear and a quadratic term (standardised regression [2]_, extended by the
  square so that the U-shaped power of a multirotor against wind speed is caught); the
  :math:`R^2` of that additive model is shared among the inputs by the Shapley value
  (the LMG decomposition [3]_): an input's share is its mean gain of :math:`R^2` over
  every order of adding the inputs. Each share lies between 0 and :math:`R^2` and the
  shares sum to :math:`R^2`; an input that is not drawn has none.

References
----------
.. [1] A. Choudhry, B. Moon, J. Patrikar, C. Samaras and S. Scherer, "CVaR-based Flight
   Energy Risk Assessment for Multirotor UAVs using a Deep Energy Model," in Proc. IEEE
   ICRA 2021, pp. 262–268, doi:10.1109/ICRA48506.2021.9561658.
.. [2] A. Saltelli et al., *Global Sensitivity Analysis: The Primer*. Chichester, U.K.:
   Wiley, 2008, §1.2.5 (standardised regression coefficients).
.. [3] U. Grömping, "Estimators of relative importance in linear regression based on
   variance decomposition," *The American Statistician* 61(2), pp. 139–147, 2007.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from itertools import combinations

import numpy as np
from scipy.special import ndtri

from planner.chain.mission_chain import ChainResult, MissionChain
from planner.chain.steps import CHECK_CONSTRAINTS
from planner.errors import InputError
from planner.physics import atmosphere
from planner.physics.battery import integral
from planner.physics.mission import Environment, Mission
from planner.physics.units import J_PER_WH, ZERO_CELSIUS_K

__all__ = ["DEFAULT_FORECAST_SPREADS", "DEFAULT_MODEL_ERROR_SD", "Spreads",
           "UncertaintyResult", "covariance_problem", "cvar", "monte_carlo", "shapley_r2"]

#: Standard deviations within which a drawn value must stay physical (a capacity, δ, a
#: payload): a spread that reaches zero inside this many is refused as bad input.
PHYSICAL_SIGMAS = 4.0
#: Least levels of the payload and of the power error per weather draw (stratified; the
#: power and circuit models run once per distinct take-off mass and power error); more
#: where the weather draws are few, so that the levels over all weather draws are at least
#: one per :data:`SAMPLES_PER_WEATHER_DRAW` samples.
PAYLOAD_LEVELS = 8
#: Samples per weather draw by default: 2000 samples draw the weather 400 times (the
#: probability's resolution 0.25 %), one chain run per weather draw. [samples]
SAMPLES_PER_WEATHER_DRAW = 5
#: Most weather draws by default: a resolution of 0.25 %, a twentieth of the 5 % a GO at
#: 95 % leaves to failures; more samples refine the pack inputs and the tails (each weather
#: draw costs a run of the chain; ``weather_draws`` asks for more).
MAX_DEFAULT_WEATHER_DRAWS = 400
#: Constraints a landing sample must meet (all but the return-home reserve).
LANDING_CONSTRAINTS = tuple(c for c in CHECK_CONSTRAINTS if c != "return_home")

#: Where the default forecast spreads come from: the ECMWF high-resolution forecast
#: (IFS-HRES, 9 km) against station observations, two 30-day verifications
#: (2026-03-21…04-20 and 2026-05-23…06-22, meteo.matrunich.com/benchmark).
FORECAST_SPREAD_SOURCE = ("ECMWF IFS-HRES 9 km against station observations, 30-day "
                          "verifications 2026-03/04 and 2026-05/06, "
                          "meteo.matrunich.com/benchmark")
#: Default forecast spreads (one standard deviation) and why: 10 m wind speed RMSE
#: 2.00 and 2.21 m/s; wind direction mean absolute error 39.2° and 43.8°, 44° × √(π/2)
#: = 55° as a normal's standard deviation; 2 m temperature mean absolute error 2.23 and
#: 2.27 °C, × √(π/2) = 2.8 °C (:data:`FORECAST_SPREAD_SOURCE`). [m/s], [deg], [°C]
DEFAULT_FORECAST_SPREADS = {
    "wind_sd_ms": (2.2, "10 m wind speed RMSE 2.0–2.2 m/s"),
    "wind_direction_sd_deg": (55.0, "wind direction mean absolute error 39–44°, × √(π/2)"),
    "temperature_sd_c": (2.8, "2 m temperature mean absolute error 2.2–2.3 °C, × √(π/2)"),
}
#: Default spread of the power model's whole-flight energy error, for an aircraft file
#: without ``energy_error_sd``: the RMS per-flight energy error of the DJI M100
#: ``rotor_losses`` fit on its 187 training flights fitted at one mass of 2.605 kg, their
#: payloads not given, 8.2 % (``fit-aircraft`` on ../shared/data/energy, the command in
#: aircraft/dji_m100_rotor_losses.yaml's source with ``--mass 2.605``; docs/commands.md).
#: A file never fitted to flights likely errs more. [unitless]
DEFAULT_MODEL_ERROR_SD = 0.08


@dataclass(frozen=True)
class Spreads:
    """The input spreads of a Monte Carlo run (standard deviations; 0 = not drawn; None =
    the default: :data:`DEFAULT_FORECAST_SPREADS` for the weather, the aircraft file's
    ``energy_error_sd`` or :data:`DEFAULT_MODEL_ERROR_SD` for the power error).

    Attributes
    ----------
    wind_sd_ms, wind_direction_sd_deg : float or None
        [m/s], [deg]
    gust_factor : float
        Peak gust over mean wind, ≥ 1 (1 = no gusts). [unitless]
    temperature_sd_c : float or None
        [°C]
    soh, soh_sd : float
        Mean state of health (share of the usable charge the pack still gives) and its
        spread. [unitless]
    payload_sd_kg : float
        [kg]
    model_covariance : bool
        Draw δ, ε, β from the pack file's ``model.covariance`` where it has one.
    model_error_sd : float or None
        Spread of the power model's own error, a fraction of the power. [unitless]
    charge_error_sd : float or None
        Spread of the integral model's own charge error from one discharge to the next,
        a fraction of the charge (None: the pack file's ``model.charge_error_sd``, not
        drawn where it has none). [unitless]
    """

    wind_sd_ms: float | None = None
    wind_direction_sd_deg: float | None = None
    gust_factor: float = 1.0
    temperature_sd_c: float | None = None
    soh: float = 1.0
    soh_sd: float = 0.0
    payload_sd_kg: float = 0.0
    model_covariance: bool = True
    model_error_sd: float | None = None
    charge_error_sd: float | None = None

    @classmethod
    def only(cls, **given) -> Spreads:
        """Spreads with no default: every spread not ``given`` is 0 (not drawn)."""
        zeros = {f.name: 0.0 for f in fields(cls) if f.default is None}
        return cls(**{**zeros, **given})


@dataclass
class UncertaintyResult:
    """What a Monte Carlo run of a mission says (see the module notes).

    Attributes
    ----------
    samples, weather_draws, seed : int
    confidence : float
    p_landing : float
        P(land with the reserve). [unitless]
    p_all_reserves : float
        P(land with the reserve and every return home with it too). [unitless]
    p_resolution : float
        The step of the probability: one over the independent draws of the most coarsely
        drawn input. [unitless]
    independent_draws : int
        Those draws.
    landing_mah, rtl_margin_mah : dict
        ``p5``, ``p50``, ``p95`` of the charge left on landing and of the smallest
        return-home margin. [mAh]
    cvar5_landing_mah : float
        Mean charge left on landing of the worst 5 % of samples. [mAh]
    reserve_mah : float
    sources : list of dict
        Each input: ``name``, ``spread`` (text; "not drawn"), ``origin`` (where the spread
        comes from: a setting, a file, or ``default …`` with its source), ``share`` (of
        the variance, its Shapley share of R²; None when not drawn).
    r2 : float
        Share of the variance the additive split explains; the sum of the shares.
        [unitless]
    driver : str or None
        The input with the largest share.
    landing_samples_mah, rtl_samples_mah : ndarray
        Per sample. [mAh]
    rtl_charge_p95_mah : ndarray
        95th percentile of the return's charge at every return-home point of the
        nominal run (NaN where not sampled). [mAh]
    nominal : ChainResult
        The forecast's own run (full return-home points, per-leg detail).
    energy_samples_wh, charge_samples_mah : ndarray
        Per sample: the mission's battery energy [Wh] and the charge drawn [mAh].
    """

    samples: int
    weather_draws: int
    seed: int
    confidence: float
    p_landing: float
    p_all_reserves: float
    p_resolution: float
    independent_draws: int
    landing_mah: dict
    rtl_margin_mah: dict
    cvar5_landing_mah: float
    reserve_mah: float
    sources: list[dict]
    r2: float
    driver: str | None
    landing_samples_mah: np.ndarray = field(repr=False)
    rtl_samples_mah: np.ndarray = field(repr=False)
    rtl_charge_p95_mah: np.ndarray = field(repr=False)
    nominal: ChainResult = field(repr=False)
    energy_samples_wh: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    charge_samples_mah: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    @property
    def go(self) -> bool:
        """True when the probability of landing with the reserve is at least the confidence
        asked."""
        return self.p_landing >= self.confidence

    @property
    def verdict(self) -> str:
        """``GO`` or ``NO-GO`` at the confidence asked."""
        return "GO" if self.go else "NO-GO"

    @property
    def coarse(self) -> bool:
        """The probability's step is more than a tenth of what a NO-GO allows (1 −
        confidence): a verdict resting on a handful of draws."""
        return self.p_resolution > 0.1 * (1.0 - self.confidence)

    def to_dict(self) -> dict:
        """JSON-ready: the verdict and its settings (confidence, samples, seed), the
        probabilities of landing with the reserve, the reserve, landing charge and
        return-home margin [mAh], and the split of the landing charge's variance among the
        drawn inputs (units in the key names)."""
        return {"verdict": self.verdict, "confidence": self.confidence,
                "samples": self.samples, "weather_draws": self.weather_draws,
                "seed": self.seed, "p_landing_with_reserve": self.p_landing,
                "p_all_reserves": self.p_all_reserves,
                "p_resolution": self.p_resolution,
                "independent_draws": self.independent_draws, "reserve_mah": self.reserve_mah,
                "landing_charge_mah": self.landing_mah,
                "cvar5_landing_charge_mah": self.cvar5_landing_mah,
                "return_home_margin_mah": self.rtl_margin_mah,
                "variance_split": {"method": "Shapley (LMG) shares of the R² of an additive "
                                             "quadratic regression on the independently "
                                             "drawn inputs; the shares sum to R²",
                                   "r2": self.r2, "driver": self.driver,
                                   "sources": self.sources}}


def cvar(values, alpha: float = 0.05) -> float:
    r"""Conditional value at risk of the low tail: the mean of the smallest
    :math:`\lceil \alpha n \rceil` values ([1]_ of the module notes). [same unit]"""
    v = np.sort(np.asarray(values, float))
    if not v.size:
        return float("nan")
    return float(np.mean(v[:max(1, math.ceil(alpha * v.size))]))


def _percentiles(values) -> dict:
    p5, p50, p95 = np.percentile(values, [5, 50, 95])
    return {"p5": float(p5), "p50": float(p50), "p95": float(p95)}


def _lhs(rng, n: int, dims: int) -> np.ndarray:
    """A Latin hypercube of ``n`` points in ``dims`` dimensions, open unit interval."""
    u = (np.argsort(rng.random((dims, n)), axis=1) + rng.random((dims, n))) / n
    return np.clip(u.T, 1e-9, 1 - 1e-9)


def _rtl_subset(nominal: ChainResult, points: int) -> np.ndarray:
    """Return-home points to check in every sample: the ``points`` tightest of the nominal
    run and about as many more spread evenly along the mission, with its end."""
    margin = nominal.detail["rtl_point_margin_mah"][0]
    n = margin.size
    tight = np.argsort(np.where(np.isfinite(margin), margin, -np.inf))[:points]
    even = np.linspace(0, n - 1, min(n, points)).astype(int)
    return np.union1d(np.union1d(tight, even), [n - 1])


# --------------------------------------------------------------------------- 1. inputs

def resolve_spreads(spreads: Spreads, aircraft, pack) -> tuple[Spreads, dict[str, str]]:
    """The spreads with every default filled in (:class:`Spreads`), and where each spread
    comes from: the setting's name, the aircraft or pack file, or ``default …`` with its
    source.

    Raises
    ------
    InputError
        A spread that is not a finite number ≥ 0, a gust factor outside [1, 5], a state
        of health outside (0, 1.5] or one whose spread allows a capacity ≤ 0.
    """
    values, origin = {}, {}
    for name, (value, why) in DEFAULT_FORECAST_SPREADS.items():
        given = getattr(spreads, name)
        values[name] = value if given is None else given
        origin[name] = (f"default forecast spread: {why} ({FORECAST_SPREAD_SOURCE})"
                        if given is None else name)
    where = str(getattr(aircraft, "path", None) or aircraft.name)
    if spreads.model_error_sd is not None:
        values["model_error_sd"], origin["model_error_sd"] = spreads.model_error_sd, \
            "model_error_sd"
    elif getattr(aircraft, "energy_error_sd", None) is not None:
        values["model_error_sd"] = aircraft.energy_error_sd
        origin["model_error_sd"] = (f"{where}: energy_error_sd (fit-aircraft: RMS per-flight "
                                    "energy error on its training flights)")
    else:
        values["model_error_sd"] = DEFAULT_MODEL_ERROR_SD
        origin["model_error_sd"] = (f"default: {where} has no energy_error_sd; the DJI M100 "
                                    "rotor_losses fit's RMS per-flight energy error on its "
                                    "187 training flights fitted at one mass, 8.2 % "
                                    "(fit-aircraft writes the aircraft's own)")
    own = pack.model.charge_error_sd
    pack_where = str(pack.path or pack.name)
    if spreads.charge_error_sd is not None:
        values["charge_error_sd"], origin["charge_error_sd"] = spreads.charge_error_sd, \
            "charge_error_sd"
    elif own is not None:
        values["charge_error_sd"] = own
        origin["charge_error_sd"] = (f"{pack_where}: model.charge_error_sd (fit-battery: RMS "
                                     "final charge error on its training discharges)")
    else:
        values["charge_error_sd"] = 0.0
        origin["charge_error_sd"] = (f"absent: {pack_where} stores no model.charge_error_sd "
                                     "(fit-battery writes one)")
    s = replace(spreads, **values)
    for name in ("wind_sd_ms", "wind_direction_sd_deg", "temperature_sd_c", "soh_sd",
                 "payload_sd_kg", "model_error_sd", "charge_error_sd"):
        value = getattr(s, name)
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
            raise InputError(f"{name} must be a finite spread ≥ 0, got {value}")
    for name, of in (("charge_error_sd", "the charge"), ("model_error_sd", "the power")):
        if getattr(s, name) > 1.0:
            raise InputError(f"{name} must be a fraction of {of} ≤ 1 (0.05 = 5 %), "
                             f"got {getattr(s, name):g}")
    if not (math.isfinite(s.gust_factor) and 1.0 <= s.gust_factor <= 5.0):
        raise InputError(f"gust_factor must be in [1, 5] (peak gust over mean wind), got "
                         f"{s.gust_factor}")
    if not (0.0 < s.soh <= 1.5):
        raise InputError(f"soh must be in (0, 1.5], got {s.soh}")
    if s.soh - PHYSICAL_SIGMAS * s.soh_sd <= 0:
        raise InputError(f"soh {s.soh:g}±{s.soh_sd:g} allows a capacity ≤ 0 within "
                         f"{PHYSICAL_SIGMAS:g} standard deviations")
    return s, origin


def covariance_problem(delta: float, beta: float, covariance) -> str | None:
    """Why (δ, ε, β) cannot be drawn from ``covariance`` (rows δ, ε, β): a standard error
    of δ or β that allows a value ≤ 0 within :data:`PHYSICAL_SIGMAS`; None when they
    can."""
    sd3 = np.sqrt(np.clip(np.diag(np.array(covariance, float)), 0, None))
    for name, m, sd in (("delta", delta, sd3[0]), ("beta", beta, sd3[2])):
        if m - PHYSICAL_SIGMAS * sd <= 0:
            return (f"the standard error of {name} ({sd:.3g}) allows {name} ≤ 0 (a capacity "
                    f"without bound) within {PHYSICAL_SIGMAS:g} standard errors of {m:.4g}")
    return None


def _pack_model(pack, s: Spreads):
    """The integral model's mean (δ, ε, β) and the covariance drawn (None: not drawn)."""
    where = str(pack.path or pack.name)
    cov = np.array(pack.model.covariance, float) if (
        s.model_covariance and pack.model.covariance is not None) else None
    mean3 = np.array([pack.model.delta, pack.model.epsilon, pack.model.beta])
    if cov is not None:
        problem = covariance_problem(mean3[0], mean3[2], cov)
        if problem:
            raise InputError(f"{where}: model.covariance: {problem}")
    return mean3, cov


# --------------------------------------------------------------------------- 2. draws

@dataclass
class Draws:
    """The drawn inputs: the weather per weather draw, the rest per sample.

    ``group`` is each sample's weather draw; ``wind_mean`` [m/s] the drawn mean wind,
    ``gust`` the uniform deviate of the gusts, ``wind`` [m/s] the effective wind,
    ``direction_dev`` [deg] the direction's departure from the forecast and ``direction``
    [deg] the direction flown, ``temp`` [°C] the air; per sample ``theta`` (δ, ε, β),
    ``soh``, ``payload`` [kg], ``power_scale`` and ``charge_scale`` (the integral model's
    own charge error, a factor on the charge); ``levels`` the distinct (payload, power
    error) draws over all weather draws.
    """

    group: np.ndarray
    wind_mean: np.ndarray
    gust: np.ndarray
    wind: np.ndarray
    direction_dev: np.ndarray
    direction: np.ndarray
    temp: np.ndarray
    theta: np.ndarray
    soh: np.ndarray
    payload: np.ndarray
    power_scale: np.ndarray
    charge_scale: np.ndarray
    levels: int

    @property
    def weather_draws(self) -> int:
        """Number of distinct weather draws (wind and temperature) among the samples."""
        return len(self.wind)


def _stratified(rng, group: np.ndarray, levels: int):
    """Two independent standard normals shared in levels: the samples of each group take
    at most ``levels`` levels (as many as the group has samples, up to that), each level
    drawn in its own stratum of equal probability, the levels evenly shared. Returns the
    two normals per sample and the level of each sample (unique over the groups)."""
    g = int(group.max()) + 1
    counts = np.bincount(group, minlength=g)
    per = np.minimum(levels, np.maximum(counts, 1))
    pos = np.arange(group.size) - np.repeat(np.cumsum(counts) - counts, counts)
    level = pos % per[group]
    out = []
    for _ in range(2):
        key = np.where(np.arange(levels) < per[:, None], rng.random((g, levels)), np.inf)
        stratum = np.argsort(np.argsort(key, axis=1), axis=1)   # a permutation per group
        z = ndtri((stratum + rng.random((g, levels))) / per[:, None])
        out.append(z[group, level])
    return out[0], out[1], group * levels + level


def draw(rng, env: Environment, t_base: float, s: Spreads, samples: int, g: int,
         mean3, cov, payload: float, usable_fraction: float) -> Draws:
    """Step 2: the weather at ``g`` points of a Latin hypercube, the pack per sample, the
    payload and the power error in stratified levels per weather draw (module notes)."""
    u = _lhs(rng, g, 4)
    wind_mean = np.maximum(env.wind_speed_ms + s.wind_sd_ms * ndtri(u[:, 0]), 0.0)
    direction_dev = s.wind_direction_sd_deg * ndtri(u[:, 1])
    temp = t_base + s.temperature_sd_c * ndtri(u[:, 2])
    gust = u[:, 3]
    if g == 1:
        wind_mean, direction_dev, temp, gust = (np.array([env.wind_speed_ms]), np.zeros(1),
                                                np.array([t_base]), np.zeros(1))
    wind = wind_mean * (1.0 + (s.gust_factor - 1.0) * gust)
    group = np.repeat(np.arange(g), np.diff(np.linspace(0, samples, g + 1).round().astype(int)))
    if cov is not None:
        w, v = np.linalg.eigh(cov)
        theta = mean3 + rng.standard_normal((samples, 3)) @ (v * np.sqrt(np.clip(w, 0, None))).T
    else:
        theta = np.tile(mean3, (samples, 1))
    soh = np.minimum(s.soh + s.soh_sd * rng.standard_normal(samples), 1.0 / usable_fraction)
    # at least one level per SAMPLES_PER_WEATHER_DRAW samples over all weather draws
    levels = max(PAYLOAD_LEVELS, math.ceil(samples / (g * SAMPLES_PER_WEATHER_DRAW)))
    z_pay, z_power, level = _stratified(rng, group, levels)
    # drawn last, and only when drawn: the other draws stay those of a run without it
    charge_scale = (np.exp(s.charge_error_sd * rng.standard_normal(samples))
                    if s.charge_error_sd > 0 else np.ones(samples))
    return Draws(group=group, wind_mean=wind_mean, gust=gust, wind=wind,
                 direction_dev=direction_dev,
                 direction=(env.wind_from_deg + direction_dev) % 360.0, temp=temp,
                 theta=theta, soh=soh, payload=np.maximum(payload + s.payload_sd_kg * z_pay, 0.0),
                 power_scale=np.exp(s.model_error_sd * z_power),
                 levels=int(np.unique(level).size), charge_scale=charge_scale)


# --------------------------------------------------------------------------- 3. flights

def _charge_scaled_delta(d: Draws, rows: np.ndarray) -> np.ndarray:
    """δ of the samples ``rows`` with the integral model's own charge error: the charge
    C = (t / (δ P^ε))^(1/β) ([UAV23] eq. 14) times ``charge_scale`` is δ times
    ``charge_scale``^−β."""
    return d.theta[rows, 0] * d.charge_scale[rows] ** (-d.theta[rows, 2])


def fly(chain: MissionChain, mission: Mission, env: Environment, d: Draws, sub: np.ndarray,
        weather_spread: bool) -> dict[str, np.ndarray]:
    """Step 3: the chain once per weather draw with that draw's samples on its pack axis:
    per sample ``landing`` (charge left, [mAh]), ``rtl_min`` (smallest return-home margin
    [mAh]), ``ok_land`` (every limit but the return home met), ``ok_all`` (every limit)
    ``rtl_charge`` (charge of the return at the points ``sub``, [mAh]), ``energy``
    (battery energy of the mission [Wh]) and ``charge`` (charge drawn [mAh])."""
    n = d.group.size
    out = {"landing": np.empty(n), "rtl_min": np.empty(n), "ok_land": np.empty(n, bool),
           "ok_all": np.empty(n, bool), "rtl_charge": np.empty((n, sub.size)),
           "energy": np.empty(n), "charge": np.empty(n)}
    land_cols = [CHECK_CONSTRAINTS.index(c) for c in LANDING_CONSTRAINTS]
    for j in range(d.weather_draws):
        rows = np.flatnonzero(d.group == j)
        if not rows.size:
            continue
        temp = float(d.temp[j]) if weather_spread else None
        env_j = replace(env, wind_speed_ms=float(d.wind[j]), wind_from_deg=float(d.direction[j]),
                        temperature_c=temp if weather_spread else env.temperature_c)
        chain_j = MissionChain(chain.aircraft, [chain.pack] * rows.size,
                               battery_model=chain.battery_model, reserve=chain.reserve,
                               temperature_c=temp if weather_spread else chain.temperature_c,
                               min_thrust_to_weight=chain.min_thrust_to_weight)
        r = chain_j.run(mission, env_j, payload_kg=d.payload[rows], detail=False,
                        rtl_subset=sub,
                        pack_samples={"delta": _charge_scaled_delta(d, rows),
                                      "epsilon": d.theta[rows, 1],
                                      "beta": d.theta[rows, 2], "soh": d.soh[rows],
                                      "power_scale": d.power_scale[rows]})
        out["landing"][rows] = r.usable_mah - r.charge_used_mah
        out["energy"][rows] = r.energy_wh
        out["charge"][rows] = r.charge_used_mah
        out["rtl_min"][rows] = r.rtl_min_margin_mah
        out["ok_land"][rows] = ~r.violated[:, land_cols].any(axis=1)
        out["ok_all"][rows] = r.go
        out["rtl_charge"][rows] = r.detail["rtl_point_charge_mah"]
    return out


# --------------------------------------------------------------------------- 4. the split

def _terms(x: np.ndarray) -> np.ndarray:
    """An input's standardised linear and centred quadratic terms (samples × 2)."""
    z = (x - x.mean()) / x.std()
    q = z**2 - np.mean(z**2)
    return np.column_stack([z, q])


def shapley_r2(inputs: list[np.ndarray], y) -> tuple[np.ndarray, float]:
    """Shapley (LMG) shares of the :math:`R^2` of ``y`` regressed on every input's linear
    and quadratic terms ([3]_ of the module notes): an input's share is the weighted mean
    of the gain of :math:`R^2` when it joins each subset of the others, weights
    :math:`|S|!\\,(p-|S|-1)!/p!`. :math:`R^2` never falls when terms are added, so each
    share is ≥ 0, and the shares sum to the full :math:`R^2`. Returns (shares, R²)."""
    y = np.asarray(y, float)
    p = len(inputs)
    var_y = float(np.var(y))
    if p == 0 or var_y <= 0:
        return np.zeros(p), float("nan")
    x = np.column_stack([_terms(np.asarray(v, float)) for v in inputs])
    x = x - x.mean(axis=0)
    gram, cross = x.T @ x / y.size, x.T @ (y - y.mean()) / y.size
    r2 = {0: 0.0}
    for k in range(1, p + 1):
        for subset in combinations(range(p), k):
            cols = [2 * i + t for i in subset for t in (0, 1)]
            beta = np.linalg.lstsq(gram[np.ix_(cols, cols)], cross[cols], rcond=None)[0]
            r2[sum(1 << i for i in subset)] = float(np.clip(cross[cols] @ beta / var_y, 0, 1))
    shares = np.zeros(p)
    for mask, value in r2.items():
        size = bin(mask).count("1")
        for i in range(p):
            if not mask >> i & 1:
                weight = math.factorial(size) * math.factorial(p - size - 1) / math.factorial(p)
                shares[i] += weight * max(r2[mask | 1 << i] - value, 0.0)
    return shares, r2[(1 << p) - 1]


def variance_split(columns: list[tuple], y) -> tuple[list[dict], float, str | None]:
    """Step 4: the sources with their Shapley shares of the landing charge's variance
    (:func:`shapley_r2`). ``columns``: (name, values per sample, spread text, origin); an
    input whose values do not vary is "not drawn" and has no share. Returns the sources,
    R² and the driver."""
    sources, drawn = [], []
    for name, x, spread, origin in columns:
        x = np.asarray(x, float)
        varies = bool(np.nanstd(x) > 1e-9 * max(float(np.nanmax(np.abs(x))), 1e-300))
        sources.append({"name": name, "spread": spread if varies else "not drawn",
                        "origin": origin, "share": None})
        if varies:
            drawn.append((len(sources) - 1, x))
    shares, r2 = shapley_r2([x for _, x in drawn], y)
    if not math.isfinite(r2):
        return sources, r2, None
    for (k, _), share in zip(drawn, shares):
        sources[k]["share"] = float(share)
    driver = sources[drawn[int(np.argmax(shares))][0]]["name"] if drawn else None
    return sources, r2, driver


def _columns(chain: MissionChain, nominal: ChainResult, d: Draws, s: Spreads,
             origin: dict, cov) -> list[tuple]:
    """The independently drawn inputs of the split: (name, values per sample, spread,
    origin). The integral model enters as the charge its (δ, ε, β) give at the mission's
    mean power, the weather by its own deviates (the wind's mean, the gusts' uniform
    deviate — which changes the wind only where the mean wind is not 0 —, the direction's
    departure, unwrapped)."""
    pack, where = chain.pack, str(chain.pack.path or chain.pack.name)
    p_mean = float(nominal.energy_wh[0]) * J_PER_WH / max(nominal.duration_s, 1e-9)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        model_charge = integral.charge_from_stress(
            nominal.duration_s * integral.stress_rate(p_mean, d.theta[:, 0], d.theta[:, 1]),
            d.theta[:, 2])
    cov_origin = (f"{where}: model.covariance (fit-battery)" if cov is not None else
                  f"absent: {where} stores no model.covariance (fit-battery writes one)"
                  if pack.model.covariance is None else "not drawn")
    g = d.group
    gusty = d.gust[g] if np.ptp(d.wind_mean * (s.gust_factor - 1.0) * d.gust) > 0 \
        else np.zeros(g.size)
    return [
        ("power model error", np.log(d.power_scale), f"±{100 * s.model_error_sd:.3g} %",
         origin["model_error_sd"]),
        ("integral model δ, ε, β", model_charge,
         "covariance of the fit" if cov is not None else "—", cov_origin),
        ("integral model's charge error", np.log(d.charge_scale),
         f"±{100 * s.charge_error_sd:.3g} %", origin["charge_error_sd"]),
        ("wind speed", d.wind_mean[g], f"±{s.wind_sd_ms:g} m/s", origin["wind_sd_ms"]),
        ("wind direction", d.direction_dev[g], f"±{s.wind_direction_sd_deg:g}°",
         origin["wind_direction_sd_deg"]),
        ("gusts", gusty, f"factor {s.gust_factor:g}",
         "gust_factor: effective wind uniform between the mean and factor × mean"),
        ("air temperature", d.temp[g], f"±{s.temperature_sd_c:g} °C",
         origin["temperature_sd_c"]),
        ("state of health", d.soh, f"{s.soh:g}±{s.soh_sd:g}", "soh: usable charge × SoH"),
        ("payload", d.payload, f"±{s.payload_sd_kg:g} kg", "payload_sd_kg"),
    ]


def _resolution(d: Draws, sources: list[dict], samples: int) -> int:
    """Independent draws of the most coarsely drawn input: the weather draws when the
    weather is drawn, the payload and power-error levels when either is, else the
    samples."""
    drawn = {src["name"] for src in sources if src["share"] is not None
             or src["spread"] != "not drawn"}
    counts = [samples]
    if drawn & {"wind speed", "wind direction", "gusts", "air temperature"}:
        counts.append(d.weather_draws)
    if drawn & {"payload", "power model error"}:
        counts.append(d.levels)
    return int(min(counts))


def _summary(nominal: ChainResult, flown: dict, sub: np.ndarray) -> dict:
    """Step 5: probabilities, percentiles and CVaR of the flown samples."""
    reserve = float(nominal.reserve_mah[0])
    landing = flown["landing"]
    landing_ok = flown["ok_land"] & (landing >= reserve - 1e-9)
    p95 = np.full(nominal.detail["rtl_point_charge_mah"].shape[1], np.nan)
    with np.errstate(invalid="ignore"):
        p95[sub] = np.percentile(flown["rtl_charge"], 95, axis=0)
    return {"p_landing": float(landing_ok.mean()),
            "p_all_reserves": float((landing_ok & flown["ok_all"]).mean()),
            "landing_mah": _percentiles(landing),
            "rtl_margin_mah": _percentiles(flown["rtl_min"]),
            "cvar5_landing_mah": cvar(landing), "reserve_mah": reserve,
            "landing_samples_mah": landing, "rtl_samples_mah": flown["rtl_min"],
            "rtl_charge_p95_mah": p95, "energy_samples_wh": flown["energy"],
            "charge_samples_mah": flown["charge"]}


def _weather_draws(s: Spreads, samples: int, weather_draws: int | None) -> int:
    """Weather draws: 1 when no weather input is spread, else ``weather_draws`` or one per
    :data:`SAMPLES_PER_WEATHER_DRAW` samples up to :data:`MAX_DEFAULT_WEATHER_DRAWS`, at
    most one per sample."""
    if not (s.wind_sd_ms > 0 or s.wind_direction_sd_deg > 0 or s.gust_factor > 1.0
            or s.temperature_sd_c > 0):
        return 1
    if weather_draws is not None and not 2 <= int(weather_draws) <= samples:
        raise InputError(f"weather_draws must be between 2 and the samples ({samples}), got "
                         f"{weather_draws}")
    return int(weather_draws or max(2, min(samples // SAMPLES_PER_WEATHER_DRAW,
                                            MAX_DEFAULT_WEATHER_DRAWS)))


def monte_carlo(chain: MissionChain, mission: Mission, environment: Environment | None = None,
                spreads: Spreads = Spreads(), *, samples: int = 2000, seed: int = 0,
                confidence: float = 0.95, weather_draws: int | None = None,
                rtl_points: int = 48, payload_kg: float | None = None) -> UncertaintyResult:
    """Monte Carlo of a one-pack chain's mission (module notes): inputs, draws, flights,
    the variance split, the summary.

    Parameters
    ----------
    chain : MissionChain
        One pack; its aircraft (``energy_error_sd``), battery model, reserve and
        temperature are used.
    mission : Mission
    environment : Environment, optional
        The forecast (default the mission's).
    spreads : Spreads
        None fields take their defaults (:class:`Spreads`).
    samples : int
    seed : int
        Seed of the random generator: the same seed gives the same result.
    confidence : float
        GO when P(land with the reserve) is at least this. [unitless]
    weather_draws : int, optional
        Weather points of the Latin hypercube (default one per
        :data:`SAMPLES_PER_WEATHER_DRAW` samples, at most :data:`MAX_DEFAULT_WEATHER_DRAWS`;
        1 when no weather input is spread).
    rtl_points : int
        Tightest return-home points of the nominal run checked in every sample.
    payload_kg : float, optional
        Overrides the mission's payload. [kg]

    Raises
    ------
    InputError
        Bad settings or spreads, or nothing drawn at all.
    """
    if len(chain.packs) != 1:
        raise InputError("the Monte Carlo flies one pack")
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be in (0, 1), got {confidence}")
    if samples < 20:
        raise InputError(f"samples must be at least 20, got {samples}")
    s, origin = resolve_spreads(spreads, chain.aircraft, chain.pack)
    mean3, cov = _pack_model(chain.pack, s)
    if cov is None and not any((s.wind_sd_ms, s.wind_direction_sd_deg, s.gust_factor > 1,
                                s.temperature_sd_c, s.soh_sd, s.payload_sd_kg,
                                s.model_error_sd, s.charge_error_sd)):
        raise InputError("nothing is drawn: every spread is 0 and the pack has no model "
                         "covariance, so every sample would be the forecast's run (a band "
                         "of one number, a probability of 0 or 1); give a spread")
    env = environment or mission.environment
    payload = mission.payload_kg if payload_kg is None else float(payload_kg)
    t_forecast = chain.temperature_c if chain.temperature_c is not None else env.temperature_c
    t_base = (t_forecast if t_forecast is not None
              else atmosphere.temperature(env.site_altitude_m) - ZERO_CELSIUS_K)
    nominal = chain.run(mission, env, payload_kg=payload, detail=True)
    sub = _rtl_subset(nominal, rtl_points)
    g = _weather_draws(s, samples, weather_draws)
    d = draw(np.random.default_rng(seed), env, t_base, s, samples, g, mean3, cov, payload,
             chain.pack.usable_fraction)
    flown = fly(chain, mission, env, d, sub, weather_spread=g > 1)
    sources, r2, driver = variance_split(_columns(chain, nominal, d, s, origin, cov),
                                         flown["landing"])
    if all(src["spread"] == "not drawn" for src in sources):
        raise InputError("nothing is drawn: the spreads given change no input (gusts of a "
                         "calm forecast?), so every sample would be the forecast's run; give "
                         "a spread")
    sources.append({"name": "aircraft parameters", "spread": "not drawn",
                    "origin": "absent: the aircraft file stores no parameter covariance "
                              "(their effect on the energy is in the power model error)",
                    "share": None})
    draws = _resolution(d, sources, samples)
    return UncertaintyResult(samples=samples, weather_draws=g, seed=seed,
                             confidence=confidence, p_resolution=1.0 / draws,
                             independent_draws=draws, sources=sources, r2=r2, driver=driver,
                             nominal=nominal, **_summary(nominal, flown, sub))
