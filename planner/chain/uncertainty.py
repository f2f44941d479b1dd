r"""A probabilistic verdict: Monte Carlo of the mission through the one chain.

Every input of the pre-flight check is uncertain. :func:`monte_carlo` draws the inputs,
flies every draw through :class:`~planner.chain.mission_chain.MissionChain` — the chain's
pack axis is the sample axis, each sample a variant of the pack (``pack_samples``) with its own payload
— and reports the probability of landing with the reserve, percentiles of the charge left
on landing and of the smallest return-home margin, the conditional value at risk of the
landing charge and which input drives the spread.

Sources and how each is drawn
-----------------------------
* **integral model** δ, ε, β: multivariate normal with the pack file's
  ``model.covariance`` (written by ``fit-battery``); absent → not drawn, and said so.
* **aircraft parameters**: the aircraft file stores no parameter covariance
  (``fit-aircraft`` prints standard errors only): not drawn, and said so.
* **wind**: speed normal (``wind_sd_ms``, truncated at 0) and direction normal
  (``wind_direction_sd_deg``) about the forecast; a **gust factor** F (peak gust over mean
  wind, as a METAR ``G`` group gives it) makes the effective steady wind of each draw
  uniform between the drawn mean and F × mean.
* **air temperature**: normal (``temperature_sd_c``) about the forecast (ISA at the site
  when none is given); it sets the air density and the pack's starting temperature.
* **state of health**: the charge the pack can give (nominal × usable fraction, and the
  circuit model's charge to the cut-off) × SoH, SoH normal (``soh`` ± ``soh_sd``, capped
  at 1 / usable fraction so no sample gives more than the nominal charge).
* **payload**: normal (``payload_sd_kg``) about the mission's, truncated at 0. The power
  model and the circuit model cost one evaluation per distinct take-off mass, so the
  samples of each weather draw share :data:`PAYLOAD_LEVELS` levels of that normal, one
  drawn in each stratum of equal probability (stratified sampling).

The weather changes every leg's kinematics, so the weather is drawn at ``weather_draws``
points of a Latin hypercube (McKay, Beckman and Conover 1979) and the chain runs once per
weather draw with that draw's share of the samples on its pack axis; the pack and payload
inputs are drawn independently per sample. The return-home reserve of every sample is
checked at the points where the nominal run is tightest plus a regular thinning of the
rest (``rtl_points``), not at every point of every leg.

Outputs
-------
* :math:`P(\text{land with the reserve})` — the share of samples that fly the mission within
  every limit of the check (return home aside) and land with at least the reserve;
  GO when it is at least ``confidence``.
* P5 / P50 / P95 of the charge left on landing (usable − drawn) and of the smallest
  return-home margin along the mission.
* :math:`\mathrm{CVaR}_{5\%}` of the landing charge: the mean of the worst 5 % of samples,
  the risk measure Choudhry et al. propose for energy-aware planning [1]_.
* The variance split: the landing charge regressed on every input, each with a linear
  and a quadratic term and no interactions (standardised regression [2]_, extended by the
  square so that the U-shaped power of a multirotor against wind speed is caught); an
  input's share is the variance of its own terms over the variance of the landing charge,
  and the :math:`R^2` says how much of the spread this additive model explains.

References
----------
.. [1] A. Choudhry, B. Moon, J. Patrikar, C. Samaras and S. Scherer, "CVaR-based Flight
   Energy Risk Assessment for Multirotor UAVs using a Deep Energy Model," in Proc. IEEE
   ICRA 2021, pp. 262–268, doi:10.1109/ICRA48506.2021.9561658.
.. [2] A. Saltelli et al., *Global Sensitivity Analysis: The Primer*. Chichester, U.K.:
   Wiley, 2008, §1.2.5 (standardised regression coefficients).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.special import ndtri

from planner.chain.mission_chain import ChainResult, MissionChain
from planner.chain.steps import CHECK_CONSTRAINTS
from planner.errors import InputError
from planner.physics import atmosphere
from planner.physics.battery import integral
from planner.physics.mission import Environment, Mission
from planner.physics.units import J_PER_WH, ZERO_CELSIUS_K

__all__ = ["Spreads", "UncertaintyResult", "monte_carlo", "cvar"]

#: Standard deviations within which a drawn value must stay physical (a capacity, δ, a
#: payload): a spread that reaches zero inside this many is refused as bad input.
PHYSICAL_SIGMAS = 4.0
#: Payload levels per weather draw (stratified; the power and circuit models run once per
#: distinct take-off mass).
PAYLOAD_LEVELS = 8
#: Constraints a landing sample must meet (all but the return-home reserve).
LANDING_CONSTRAINTS = tuple(c for c in CHECK_CONSTRAINTS if c != "return_home")


@dataclass(frozen=True)
class Spreads:
    """The input spreads of a Monte Carlo run (standard deviations; 0 = not drawn).

    Attributes
    ----------
    wind_sd_ms, wind_direction_sd_deg : float
        [m/s], [deg]
    gust_factor : float
        Peak gust over mean wind, ≥ 1 (1 = no gusts). [unitless]
    temperature_sd_c : float
        [°C]
    soh, soh_sd : float
        Mean state of health (share of the usable charge the pack still gives) and its
        spread. [unitless]
    payload_sd_kg : float
        [kg]
    model_covariance : bool
        Draw δ, ε, β from the pack file's ``model.covariance`` where it has one.
    """

    wind_sd_ms: float = 0.0
    wind_direction_sd_deg: float = 0.0
    gust_factor: float = 1.0
    temperature_sd_c: float = 0.0
    soh: float = 1.0
    soh_sd: float = 0.0
    payload_sd_kg: float = 0.0
    model_covariance: bool = True


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
    landing_mah, rtl_margin_mah : dict
        ``p5``, ``p50``, ``p95`` of the charge left on landing and of the smallest
        return-home margin. [mAh]
    cvar5_landing_mah : float
        Mean charge left on landing of the worst 5 % of samples. [mAh]
    reserve_mah : float
    sources : list of dict
        Each input: ``name``, ``spread`` (text), ``origin`` (where the spread comes from),
        ``share`` (of the variance; None when not drawn).
    r2 : float
        Share of the variance the linear split explains. [unitless]
    driver : str or None
        The input with the largest share.
    landing_samples_mah, rtl_samples_mah : ndarray
        Per sample. [mAh]
    rtl_charge_p95_mah : ndarray
        95th percentile of the return's charge at every return-home point of the
        nominal run (NaN where not sampled). [mAh]
    nominal : ChainResult
        The forecast's own run (full return-home points, per-leg detail).
    """

    samples: int
    weather_draws: int
    seed: int
    confidence: float
    p_landing: float
    p_all_reserves: float
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

    @property
    def go(self) -> bool:
        return self.p_landing >= self.confidence

    @property
    def verdict(self) -> str:
        return "GO" if self.go else "NO-GO"

    def to_dict(self) -> dict:
        return {"verdict": self.verdict, "confidence": self.confidence,
                "samples": self.samples, "weather_draws": self.weather_draws,
                "seed": self.seed, "p_landing_with_reserve": self.p_landing,
                "p_all_reserves": self.p_all_reserves, "reserve_mah": self.reserve_mah,
                "landing_charge_mah": self.landing_mah,
                "cvar5_landing_charge_mah": self.cvar5_landing_mah,
                "return_home_margin_mah": self.rtl_margin_mah,
                "variance_split": {"method": "additive quadratic regression on the "
                                             "standardised inputs: variance of each input's "
                                             "own terms",
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


def monte_carlo(chain: MissionChain, mission: Mission, environment: Environment | None = None,
                spreads: Spreads = Spreads(), *, samples: int = 2000, seed: int = 0,
                confidence: float = 0.95, weather_draws: int | None = None,
                rtl_points: int = 48, payload_kg: float | None = None) -> UncertaintyResult:
    """Monte Carlo of a one-pack chain's mission (module notes).

    Parameters
    ----------
    chain : MissionChain
        One pack; its battery model, reserve and temperature are used.
    mission : Mission
    environment : Environment, optional
        The forecast (default the mission's).
    spreads : Spreads
    samples : int
    seed : int
        Seed of the random generator: the same seed gives the same result.
    confidence : float
        GO when P(land with the reserve) is at least this. [unitless]
    weather_draws : int, optional
        Weather points of the Latin hypercube (default 16, fewer with fewer samples; 1
        when no weather input is spread).
    rtl_points : int
        Tightest return-home points of the nominal run checked in every sample.
    payload_kg : float, optional
        Overrides the mission's payload. [kg]

    Returns
    -------
    UncertaintyResult
    """
    if len(chain.packs) != 1:
        raise InputError("the Monte Carlo flies one pack")
    if not 0.0 < confidence < 1.0:
        raise InputError(f"confidence must be in (0, 1), got {confidence}")
    if samples < 20:
        raise InputError(f"samples must be at least 20, got {samples}")
    s = spreads
    pack, ac = chain.pack, chain.aircraft
    where = str(pack.path or pack.name)
    env = environment or mission.environment
    payload = mission.payload_kg if payload_kg is None else float(payload_kg)
    t_forecast = chain.temperature_c if chain.temperature_c is not None else env.temperature_c
    t_base = (t_forecast if t_forecast is not None
              else atmosphere.temperature(env.site_altitude_m) - ZERO_CELSIUS_K)

    # -- bad spreads: a drawn value must stay physical
    for name, value in (("wind_sd_ms", s.wind_sd_ms),
                        ("wind_direction_sd_deg", s.wind_direction_sd_deg),
                        ("temperature_sd_c", s.temperature_sd_c), ("soh_sd", s.soh_sd),
                        ("payload_sd_kg", s.payload_sd_kg)):
        if not (math.isfinite(value) and value >= 0):
            raise InputError(f"{name} must be a finite spread ≥ 0, got {value}")
    if not (math.isfinite(s.gust_factor) and 1.0 <= s.gust_factor <= 5.0):
        raise InputError(f"gust_factor must be in [1, 5] (peak gust over mean wind), got "
                         f"{s.gust_factor}")
    if not (0.0 < s.soh <= 1.5):
        raise InputError(f"soh must be in (0, 1.5], got {s.soh}")
    if s.soh - PHYSICAL_SIGMAS * s.soh_sd <= 0:
        raise InputError(f"soh {s.soh:g}±{s.soh_sd:g} allows a capacity ≤ 0 within "
                         f"{PHYSICAL_SIGMAS:g} standard deviations")
    cov = np.array(pack.model.covariance, float) if (
        s.model_covariance and pack.model.covariance is not None) else None
    mean3 = np.array([pack.model.delta, pack.model.epsilon, pack.model.beta])
    if cov is not None:
        sd3 = np.sqrt(np.clip(np.diag(cov), 0, None))
        for name, m, sd in (("delta", mean3[0], sd3[0]), ("beta", mean3[2], sd3[2])):
            if m - PHYSICAL_SIGMAS * sd <= 0:
                raise InputError(f"{where}: model.covariance: the standard error of {name} "
                                 f"({sd:.3g}) allows {name} ≤ 0 (a capacity without bound) "
                                 f"within {PHYSICAL_SIGMAS:g} standard errors of {m:.4g}")

    # -- the forecast's own run: full return-home points and detail
    nominal = chain.run(mission, env, payload_kg=payload, detail=True)
    sub = _rtl_subset(nominal, rtl_points)

    weather_spread = (s.wind_sd_ms > 0 or s.wind_direction_sd_deg > 0
                      or s.gust_factor > 1.0 or s.temperature_sd_c > 0)
    g = 1 if not weather_spread else int(weather_draws or min(16, max(2, samples // 50)))
    g = max(1, min(g, samples))
    rng = np.random.default_rng(seed)
    u = _lhs(rng, g, 4)
    wind = np.maximum(env.wind_speed_ms + s.wind_sd_ms * ndtri(u[:, 0]), 0.0)
    wind = wind * (1.0 + (s.gust_factor - 1.0) * u[:, 3])
    direction = (env.wind_from_deg + s.wind_direction_sd_deg * ndtri(u[:, 1])) % 360.0
    temp = t_base + s.temperature_sd_c * ndtri(u[:, 2])
    if not weather_spread:
        wind, direction, temp = (np.array([env.wind_speed_ms]), np.array([env.wind_from_deg]),
                                 np.array([t_base]))
    group = np.repeat(np.arange(g), np.diff(np.linspace(0, samples, g + 1).round().astype(int)))

    # -- per-sample pack and payload draws
    if cov is not None:
        w, v = np.linalg.eigh(cov)
        root = v * np.sqrt(np.clip(w, 0, None))
        theta = mean3 + rng.standard_normal((samples, 3)) @ root.T
    else:
        theta = np.tile(mean3, (samples, 1))
    soh = s.soh + s.soh_sd * rng.standard_normal(samples)
    soh_eff = np.minimum(soh, 1.0 / pack.usable_fraction)
    # the power model and the circuit model run once per distinct take-off mass: the
    # payload of each weather draw's samples takes PAYLOAD_LEVELS levels, one drawn in
    # each stratum of equal probability, evenly shared
    z = ndtri((np.arange(PAYLOAD_LEVELS) + rng.random((g, PAYLOAD_LEVELS))) / PAYLOAD_LEVELS)
    level = np.concatenate([rng.permutation(np.arange(np.sum(group == j)) % PAYLOAD_LEVELS)
                            for j in range(g)])
    pay = np.maximum(payload + s.payload_sd_kg * z[group, level], 0.0)

    landing = np.empty(samples)
    rtl_min = np.empty(samples)
    ok_land = np.empty(samples, bool)
    ok_all = np.empty(samples, bool)
    rtl_charge = np.empty((samples, sub.size))
    land_cols = [CHECK_CONSTRAINTS.index(c) for c in LANDING_CONSTRAINTS]
    for j in range(g):
        rows = np.flatnonzero(group == j)
        if not rows.size:
            continue
        env_j = replace(env, wind_speed_ms=float(wind[j]), wind_from_deg=float(direction[j]),
                        temperature_c=float(temp[j]) if weather_spread else env.temperature_c)
        chain_j = MissionChain(ac, [pack] * rows.size, battery_model=chain.battery_model,
                               reserve=chain.reserve,
                               temperature_c=float(temp[j]) if weather_spread
                               else chain.temperature_c)
        r = chain_j.run(mission, env_j, payload_kg=pay[rows], detail=False, rtl_subset=sub,
                        pack_samples={"delta": theta[rows, 0], "epsilon": theta[rows, 1],
                                      "beta": theta[rows, 2], "soh": soh_eff[rows]})
        landing[rows] = r.usable_mah - r.charge_used_mah
        rtl_min[rows] = r.rtl_min_margin_mah
        ok_land[rows] = ~r.violated[:, land_cols].any(axis=1)
        ok_all[rows] = r.go
        rtl_charge[rows] = r.detail["rtl_point_charge_mah"]
    reserve = float(nominal.reserve_mah[0])
    landing_ok = ok_land & (landing >= reserve - 1e-9)

    # -- variance split: standardised regression coefficients
    p_mean, t_mission = (float(nominal.energy_wh[0]) * J_PER_WH / max(nominal.duration_s, 1e-9),
                         nominal.duration_s)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        model_charge = integral.charge_from_stress(
            t_mission * integral.stress_rate(p_mean, theta[:, 0], theta[:, 1]), theta[:, 2])
    cov_origin = (f"{where}: model.covariance (fit-battery)" if cov is not None else
                  f"absent: {where} stores no model.covariance (fit-battery writes one)"
                  if pack.model.covariance is None else "not drawn")
    columns = [
        ("integral model δ, ε, β", model_charge, "covariance of the fit" if cov is not None
         else "—", cov_origin),
        ("wind speed", wind[group], f"±{s.wind_sd_ms:g} m/s", "wind_sd_ms"),
        ("wind direction", direction[group], f"±{s.wind_direction_sd_deg:g}°", "wind_direction_sd_deg"),
        ("gusts", (1.0 + (s.gust_factor - 1.0) * u[:, 3])[group] if weather_spread
         else np.ones(samples), f"factor {s.gust_factor:g}",
         "gust_factor: effective wind uniform between the mean and factor × mean"),
        ("air temperature", temp[group], f"±{s.temperature_sd_c:g} °C", "temperature_sd_c"),
        ("state of health", soh_eff, f"{s.soh:g}±{s.soh_sd:g}",
         "soh: usable charge × SoH"),
        ("payload", pay, f"±{s.payload_sd_kg:g} kg", "payload_sd_kg"),
    ]
    sources, xs, names = [], [], []
    for name, x, spread, origin in columns:
        x = np.asarray(x, float)
        drawn = bool(np.nanstd(x) > 1e-9 * max(float(np.nanmax(np.abs(x))), 1e-300))
        sources.append({"name": name, "spread": spread if drawn else "not drawn",
                        "origin": origin, "share": None})
        if drawn:
            xs.append(x)
            names.append(name)
    sources.append({"name": "aircraft parameters", "spread": "not drawn",
                    "origin": "absent: the aircraft file stores no parameter covariance "
                              "(fit-aircraft reports standard errors only)", "share": None})
    r2, driver = float("nan"), None
    y = landing
    if xs and np.std(y) > 0:
        x = np.column_stack(xs)
        z = (x - x.mean(axis=0)) / x.std(axis=0)
        q = z**2 - np.mean(z**2, axis=0)
        a = np.column_stack([np.ones(samples), z, q])
        try:   # normal equations: the columns are standardised, the system small
            coef = np.linalg.solve(a.T @ a, a.T @ y)
        except np.linalg.LinAlgError:
            coef = np.linalg.lstsq(a, y, rcond=None)[0]
        m = len(xs)
        own = z * coef[1:m + 1] + q * coef[m + 1:]      # each input's own terms
        r2 = float(1.0 - np.var(y - a @ coef) / np.var(y))
        shares = np.var(own, axis=0) / np.var(y)
        for name, share in zip(names, shares):
            next(d for d in sources if d["name"] == name)["share"] = float(share)
        driver = names[int(np.argmax(shares))]

    p95 = np.full(nominal.detail["rtl_point_charge_mah"].shape[1], np.nan)
    with np.errstate(invalid="ignore"):
        p95[sub] = np.percentile(rtl_charge, 95, axis=0)
    return UncertaintyResult(
        samples=samples, weather_draws=g, seed=seed, confidence=confidence,
        p_landing=float(landing_ok.mean()), p_all_reserves=float((landing_ok & ok_all).mean()),
        landing_mah=_percentiles(landing), rtl_margin_mah=_percentiles(rtl_min),
        cvar5_landing_mah=cvar(landing), reserve_mah=reserve, sources=sources, r2=r2,
        driver=driver, landing_samples_mah=landing, rtl_samples_mah=rtl_min,
        rtl_charge_p95_mah=p95, nominal=nominal)
