r"""The candidate effects of ``diagnose`` (docs/commands.md, Diagnose): one class per effect.

Each effect is an *extension* of a baseline model with physically meaningful
parameters; at zero extension the baseline is recovered exactly (the models are
nested, which the selection statistics need). An effect declares the channels of
the flight record (docs/record.md) it needs, says why it is skipped when they are
absent (or when they do not vary, so that the effect cannot be told from the
baseline's own calibration), and names its cause in plain words.

Capacity level
--------------
The baseline is the integral model of :mod:`planner.physics.battery.integral` driven by
the measured power: :math:`\hat C(t) = A\,G(t)` with
:math:`G = S_1^{1/\beta}`, :math:`S_1 = \int (P/P_{ref})^{-\varepsilon} dt` and
:math:`A = (\delta P_{ref}^\varepsilon)^{-1/\beta}`. Every capacity effect adds one
column that is linear in its parameter (the search solves the linear
coefficients in closed form, ``A`` included):

``temperature``
    :math:`\hat C = A \int (1 + k\,h(T))\, dG`, :math:`h = \max(T_{ref} - T, 0)`:
    each increment of charge drawn is scaled by the pack temperature at that
    moment; for a constant temperature this is
    :meth:`planner.parameters.IntegralModel.charge_scale`. :math:`k` [1/°C];
    :math:`T_{ref}` = :data:`REFERENCE_TEMPERATURE_C` (25 °C, the rating temperature of
    cell data sheets): the extension models the cold only, so a cell's self-heating above
    it is not a driver (a reference at the hottest sample made self-heated cells "cold"
    and the driver follow the C-rate).
``capacity_fade``
    :math:`\hat C = A\,(1 + \varphi\, n)\, G` with :math:`n` the experiment's
    ``cycle`` (else its position in the data, 0, 1, 2, …: then :math:`\varphi`
    is per experiment, and the output says so). :math:`\varphi` [1/cycle];
    δ then belongs to cycle 0, as ``charge_scale`` expects.
At the cut-off level (:mod:`planner.identify.diagnose.cutoff`) the same two effects scale the
energy a discharge delivers to its cut-off by :math:`1/(1 + k\bar h)` and
:math:`1/(1 + \varphi n)`, :math:`\bar h` the charge-weighted mean hinge of the discharge:
the direct evidence of a capacity (where discharges reach the cut-off, they are tested
there and not on the charge per unit energy).
``current_offset``
    measured charge :math:`= \hat C + b\,t`: a current sensor that reads
    :math:`b` too high drifts linearly in time, also while the load is off. [A]

Combined capacity effects add their columns; the products of two extensions
(second order, e.g. :math:`k\varphi`) are neglected.

Power level
-----------
The baseline is the aircraft's physics model
(:meth:`planner.parameters.Aircraft.battery_power`) driven by the measured
flight state, written as :math:`P = M(\theta)/\eta + P_S` with :math:`M` the
mechanical (shaft or required) power; :math:`1/\eta` is solved in closed form
and the shape parameters θ (multirotor drag area; fixed-wing C_D0 and K) by
least squares. The effects change the model's inputs or add a linear column:

``wind``
    airspeed :math:`|\vec v_g - \vec w|` from the ground velocity (``groundspeed_ms``,
    ``course_deg``) and a steady wind :math:`\vec w = (w_N, w_E)` [m/s]: the
    power then depends on the direction of travel. Needs the course and no
    measured airspeed (a measured airspeed already contains the wind).
``air_density``
    :math:`\rho = \rho_{std}\,(\rho_{meas}/\rho_{std})^a` with
    :math:`\rho_{meas} = p/(R T)` from ``pressure_pa`` and
    ``ambient_temperature_c`` (the ISA temperature at the pressure altitude when
    no temperature is logged) and :math:`\rho_{std}` the ISA density at the site
    altitude. :math:`a` = 1 is momentum theory; 0 is the baseline.
``payload_change``
    mass :math:`m_0 + \Delta m` from a change time on [kg, s]. One mass step
    shared by the flights; its time is located in each flight.
``system_power``
    :math:`P_S` fitted (the baseline holds the aircraft file's value). [W]
``efficiency_curve``
    :math:`1/\eta(M) = c_0 + c_1 (M/M_{ref} - 1)`, reported as
    :math:`\eta(M) \approx \eta_0 + \eta_1 (M/M_{ref} - 1)` with
    :math:`\eta_0 = 1/c_0`, :math:`\eta_1 = -c_1/c_0^2`; :math:`M_{ref}` is the
    median mechanical power of the training data. A copper loss
    :math:`R I^2` gives exactly this form with :math:`\eta_1 < 0`.
"""

from __future__ import annotations

import functools
import math
from typing import Any, ClassVar

import numpy as np

from planner.identify import stats
from planner.chain.flightstate import CLIMB_THRESHOLD_MS, inplane_speed
from planner.physics.wind import course_deg

__all__ = [
    "CAPACITY_EFFECTS",
    "EFFECTS",
    "POWER_EFFECTS",
    "AirDensity",
    "CapacityFade",
    "CurrentOffset",
    "Effect",
    "EfficiencyCurve",
    "PayloadChange",
    "SystemPower",
    "Temperature",
    "Wind",
    "make_effects",
]

#: Reference of the cold-pack hinge max(T_ref − T, 0): the data-sheet rating temperature.
REFERENCE_TEMPERATURE_C = 25.0
#: Below this spread of the hinge max(T_ref − T, 0) a temperature effect cannot be told
#: from δ. [°C]
MIN_TEMPERATURE_SPREAD_C = 3.0
#: Below this spread of ln(ρ_meas/ρ_std) a density effect cannot be told from η. [unitless]
MIN_LOG_DENSITY_SPREAD = 0.01
#: Below this coefficient of variation of the mechanical power a constant load or an
#: efficiency curve cannot be told from η. [unitless]
MIN_LOAD_VARIATION = 0.05
#: Power below this share of the median on-load power counts as rest or idle. [unitless]
LOW_LOAD = 0.1
#: Least share of the time at rest or idle for a current offset to be told from δ. [unitless]
MIN_LOW_LOAD_SHARE = 0.02
#: Smallest payload change that counts, as a share of the all-up mass. [unitless]
MIN_MASS_STEP = 0.03
#: Mean resultant length of the course above which the flight went one way only. [unitless]
MAX_COURSE_CONCENTRATION = 0.8
#: Shortest share of the airborne bins that must be moving (≥ 2 m/s) to see the wind.
MIN_MOVING_SHARE = 0.2

# Physical bounds of the effects' parameters: a fit beyond them is an unexplained misfit of
# the model's form, never a cause (see :meth:`Effect.implausible`).
#: Largest rise of the charge drawn per °C of cold: lithium cells lose some 0.5–1 % of
#: capacity per °C below room temperature (Zhang, Xu and Jow 2003: about 35 % of the
#: energy at −20 °C); 3 %/°C leaves room for the added resistance. [1/°C]
MAX_TEMPERATURE_COEFF = 0.03
#: Largest fade over the data: a pack past 30 % more charge per Wh is retired (the usual
#: end of life is 80 % of the capacity, i.e. 25 % more charge). [unitless]
MAX_FADE_SPAN = 0.3
#: Largest current-sensor zero error, as a share of the median current. [unitless]
MAX_OFFSET_SHARE = 0.1
#: Largest steady wind, as a share of the maximum airspeed (it must still make way). [unitless]
MAX_WIND_SHARE = 0.8
#: Standard errors by which the flights' scale on the model's change of power with
#: airspeed must differ from 1, and stand above 0, for a wind to be read through it
#: (:func:`speed_scale`). [unitless]
SPEED_RESPONSE_Z = 2.0
#: Share by which that scale must differ from 1 as well: on flights made by the tests'
#: own rotor model, which the diagnosed model flies with bins and a noisy ground speed,
#: it comes out 0.93–0.98 (± 0.01–0.014); within this share the model's change of power
#: with airspeed is taken as the aircraft's. [unitless]
SPEED_RESPONSE_FLOOR = 0.1
#: Directions of a wind at which a route is checked for winds that are one step per
#: flight (:meth:`Wind.passing_share`). [unitless]
ROUTE_DIRECTIONS = 24
#: Range of the density exponent of the power (momentum theory: induced power ∝ ρ^-1/2 at
#: constant thrust; profile power ∝ ρ). [unitless]
DENSITY_EXPONENT_RANGE = (0.0, 2.0)
#: Largest payload drop as a share of the all-up mass. [unitless]
MAX_DROP_SHARE = 0.5
#: Largest constant load as a share of the lowest airborne power (the rotors need the
#: rest). [unitless]
MAX_SYSTEM_SHARE = 0.5
#: Allowance above the ground power for a constant load (sensor noise, heaters). [W]
GROUND_POWER_MARGIN_W = 5.0
#: Standard errors a constant load may stand above the ground power's bound before it is
#: no constant load: the two a finding must stand from none. [unitless]
GROUND_BOUND_Z = 2.0


def _compass(deg: float) -> str:
    names = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")
    return names[int(((deg % 360) + 22.5) // 45) % 8]


def _pm(value: float, se: float, digits: int) -> str:
    if se is None or not math.isfinite(se):
        return f"{value:.{digits}f}"
    return f"{value:.{digits}f} ± {se:.{digits}f}"


class Effect:
    """One candidate effect: what it needs, how it extends the model, its cause.

    Attributes
    ----------
    name : str
        The stable vocabulary of ``findings[].effect`` (docs/commands.md, Diagnose).
    level : str
        ``"capacity"`` or ``"power"``.
    needs : tuple of str
        Flight-record channels it uses (beyond what the level itself needs).
    driver_label : str
        What the residual is plotted against, with its unit.
    """

    name: ClassVar[str] = ""
    level: ClassVar[str] = ""
    needs: ClassVar[tuple[str, ...]] = ()
    driver_label: ClassVar[str] = "time [s]"
    #: Nonlinear parameters (power level).
    nonlinear: ClassVar[tuple[str, ...]] = ()

    def extra_dof(self, state: dict) -> int:
        """Parameters the training test counts beyond the fitted ones."""
        return 0

    def skip_reason(self, level) -> str | None:
        """Why the effect cannot be tested on this level's data (None = testable)."""
        return None

    #: Effects that an effect skipped as not identifiable (:meth:`rival_reason`) still
    #: explains as well on these data: it is fitted in their place wherever one of them
    #: passes, as their rival (:func:`planner.identify.diagnose.search.search`).
    rival_of: ClassVar[tuple[str, ...]] = ()

    def rival_reason(self, level) -> str | None:
        """Why the effect, skipped, cannot be named on these data although it can be
        fitted to them (None = it is not a rival only): it is then held against the
        effects of :attr:`rival_of` and never named itself."""
        return None

    def practical(self, fits, level) -> str | None:
        """Why the fitted extension is too small to matter physically (None = it is not)."""
        return None

    def estimate(self, fits, level, effects) -> Any:
        """What a candidate's fits on the training folds (of the model ``effects``) read of
        the effect, for the detection limit to weigh when the effect is not named
        (:func:`planner.identify.diagnose.limits.unsettled`); None where the effect gives
        none."""
        return None

    #: The effect's driver is time itself (a drift, a step in time): it is not tested for
    #: confounding with time (its form — a linear drift through rests, a step — is what
    #: tells it apart).
    driver_is_time: ClassVar[bool] = False

    def implausible(self, p: dict[str, float], level) -> str | None:
        """Why the fitted parameters (of :meth:`parameters`) are physically impossible or
        have the wrong sign; None when they are plausible. An implausible fit is never
        reported as a cause (module notes of :mod:`planner.identify.diagnose`)."""
        return None

    def contradicted(self, p: dict[str, float], level) -> str | None:
        """Why the data contradict the form of the effect fitted (of :meth:`parameters`)
        though its parameters are possible, e.g. a fade whose discharges' energies fall in
        two levels rather than along the age (:func:`two_levels`); None where they do not.
        Such a fit is withheld, never reported as a cause."""
        return None

    #: The parameter (of :meth:`parameters`) that is 0 (or ``null_key``) without the effect.
    key: ClassVar[str] = ""

    def z_score(self, p: dict[str, float]) -> float:
        """Distance of the key parameter from "no effect", in standard errors."""
        se = p.get(self.key + "_stderr", float("nan"))
        null = p.get("file_system_power_w", 0.0) if self.name == "system_power" else 0.0
        if not se or not math.isfinite(se):
            return float("nan")
        return abs(p[self.key] - null) / se

    def parameters(self, values: dict[str, float], stderr: dict[str, float], level,
                   state: dict) -> dict[str, float]:
        """Reported parameters (physical units) with ``<name>_stderr`` entries."""
        raise NotImplementedError

    def cause(self, p: dict[str, float], level) -> str:
        """The cause in plain words, with the fitted numbers."""
        raise NotImplementedError

    def headline(self, p: dict[str, float], level) -> str:
        """A short pilot's line (no held-out numbers; the caller adds them)."""
        return self.cause(p, level)

    def __repr__(self) -> str:
        return f"<effect {self.name}>"


# ============================================================================ capacity

class CapacityEffect(Effect):
    """An effect at the capacity (and cut-off) level: one column of the charge drawn, linear in
    its coefficient (module notes, "Capacity level")."""
    level = "capacity"
    @property
    def coefficient(self) -> str:
        """Name of the linear coefficient this effect adds (its column's coefficient): the
        effect's parameter key."""
        return self.key
    #: The coefficient is relative to the charge scale A (a factor on the charge drawn).
    relative: ClassVar[bool] = True

    def prepare(self, cap) -> None:
        """Fix data-dependent constants (reference temperature, cycles)."""

    def cumulative(self, cap, G: np.ndarray, dG: np.ndarray) -> np.ndarray:
        """The effect's column, cumulative per sample like ``G`` (0 at each start)."""
        raise NotImplementedError

    def window_driver(self, cap) -> np.ndarray:
        """Driver value of each window (for plots and evidence)."""
        return cap.window_time


class Temperature(CapacityEffect):
    r"""``temperature``: a cold pack draws more charge per energy, each increment scaled by
    :math:`1 + k\max(T_{ref} - T, 0)`; :math:`k` [1/°C], :math:`T_{ref}` 25 °C (module notes)."""
    key = "temperature_coefficient_per_c"
    name = "temperature"
    needs = ("temperature_c",)
    driver_label = "pack temperature [°C]"

    def prepare(self, cap) -> None:
        """The reference temperature [°C] and each sample's hinge max(T_ref − T, 0) [°C]."""
        temp = cap.temperature
        self.reference_c = REFERENCE_TEMPERATURE_C
        self.hinge = None if temp is None else np.maximum(self.reference_c - temp, 0.0)

    def cutoff_column(self, level) -> np.ndarray:
        """Charge-weighted mean hinge of each discharge (cut-off level). [°C]"""
        return level.charge_mean(self.hinge)

    def skip_reason(self, cap) -> str | None:
        """No pack temperature for some experiment, or a hinge that varies by less than
        :data:`MIN_TEMPERATURE_SPREAD_C`."""
        if cap.temperature is None:
            missing = cap.temperature_missing
            return ("no pack temperature (temperature_c) in the data" if not missing else
                    "no pack temperature (temperature_c) for experiment(s) "
                    + ", ".join(missing[:5]) + (" …" if len(missing) > 5 else ""))
        self.prepare(cap)
        h = self.cutoff_column(cap) if cap.name == "cutoff" else self.hinge
        spread = float(np.nanmax(h) - np.nanmin(h))
        if spread < MIN_TEMPERATURE_SPREAD_C:
            what = ("the discharges' mean temperature" if cap.name == "cutoff"
                    else "the pack temperature")
            return (f"{what} varies by only {spread:.1f} °C below "
                    f"{self.reference_c:.0f} °C (needs {MIN_TEMPERATURE_SPREAD_C:g} °C): its "
                    "effect cannot be told from the calibration")
        return None

    def cumulative(self, cap, G, dG):
        r"""The hinge-weighted charge shape, :math:`\int h\,dG` from each start. [s^(1/β) °C]"""
        h = self.hinge
        mid = 0.5 * (h[1:] + h[:-1])
        return cap.cumulate(mid * dG)

    def window_driver(self, cap):
        """Mean pack temperature of each window. [°C]"""
        return cap.window_mean(cap.temperature)

    def parameters(self, values, stderr, cap, state):
        """The coefficient k [1/°C], also in % per °C, with standard errors, and the
        reference temperature [°C]."""
        k = values[self.coefficient]
        return {"temperature_coefficient_per_c": k,
                "temperature_coefficient_per_c_stderr": stderr[self.coefficient],
                "reference_temperature_c": self.reference_c,
                "percent_per_c": 100.0 * k,
                "percent_per_c_stderr": 100.0 * stderr[self.coefficient]}

    def implausible(self, p, cap):
        """A cold pack drawing less charge per Wh (k ≤ 0), or k above
        :data:`MAX_TEMPERATURE_COEFF`."""
        k = p["temperature_coefficient_per_c"]
        if k <= 0:
            return (f"the fit has a cold pack drawing less charge per Wh ({100 * k:+.2f} %/°C "
                    "below the reference): cold lithium cells give less charge for the same "
                    "energy, never more")
        if k > MAX_TEMPERATURE_COEFF:
            return (f"{100 * k:.1f} %/°C is beyond any lithium cell "
                    f"(at most {100 * MAX_TEMPERATURE_COEFF:g} %/°C)")
        return None

    def cause(self, p, cap):
        """A cold pack, in words, with k [%/°C] and the reference [°C]."""
        k = p["percent_per_c"]
        t_lo = float(np.nanmin(cap.temperature))
        ref = p["reference_temperature_c"]
        if cap.name == "cutoff":
            cold = float(np.nanmax(self.cutoff_column(cap)))
            loss = 100.0 * (1.0 - 1.0 / (1.0 + p["temperature_coefficient_per_c"] * cold))
            return (f"Cold pack: the energy delivered to the cut-off falls as the pack is "
                    f"colder; the charge scale rises {k:.2f} %/°C (±"
                    f"{p['percent_per_c_stderr']:.2f}) below {ref:.0f} °C, so the coldest "
                    f"discharges (mean {ref - cold:.0f} °C) delivered {loss:.1f} % less energy "
                    "before the cut-off (less usable capacity and more resistance in the "
                    "cold)")
        if k >= 0:
            return (f"Cold pack: the charge drawn per Wh rises {abs(k):.2f} %/°C below "
                    f"{ref:.0f} °C (±{p['percent_per_c_stderr']:.2f}); at {t_lo:.0f} °C the "
                    f"pack draws {k * max(ref - t_lo, 0):.1f} % more charge for the same "
                    "energy (less usable capacity and more resistance in the cold)")
        return (f"Cold pack draws less: the charge drawn per Wh falls {abs(k):.2f} %/°C "
                f"below {ref:.0f} °C (±{p['percent_per_c_stderr']:.2f}); unusual for a "
                "LiPo, check the temperature sensor")

    def headline(self, p, cap):
        """``Cold pack: …`` in one line."""
        k = p["percent_per_c"]
        word = "rises" if k >= 0 else "falls"
        if cap.name == "cutoff":
            return (f"Cold pack: {abs(k):.2f} % less energy to the cut-off per °C below "
                    f"{p['reference_temperature_c']:.0f} °C")
        return (f"Cold pack: charge drawn per Wh {word} {abs(k):.2f} %/°C below "
                f"{p['reference_temperature_c']:.0f} °C")


#: Parametric bootstrap draws of :func:`two_levels`' test (seeded: the same data give the
#: same answer).
TWO_LEVEL_DRAWS = 999


def _split_statistic(y: np.ndarray, base: np.ndarray, trend: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""For each row of ``y`` (draws × discharges): :math:`\ln(RSS_{trend}/RSS_{levels})`
    and the trend's residual sum of squares; and the first row's lowest level (a mask).
    The trend is ``y`` on ``base`` and the age (``trend``: that design, the projection's
    complement); the levels are ``y`` on ``base`` and the indicator of the k lowest
    residuals of ``y`` on ``base``, k the best of 1 … n − 1: adding a column d to
    ``base`` lowers the residual sum of squares by
    :math:`(d^\mathsf{T} r)^2 / \lVert M_0 d\rVert^2`, with r the residual on ``base``
    and :math:`M_0` its projection's complement, both read from the cumulative sums over
    the sorted residuals."""
    n = y.shape[1]
    g = np.linalg.pinv(base.T @ base)
    r = y - (y @ base) @ g @ base.T
    rss_trend = np.einsum("ij,ij->i", y @ trend, y)
    order = np.argsort(r, axis=1)
    rs = np.take_along_axis(r, order, axis=1)
    cr = np.cumsum(rs, axis=1)[:, :-1]                         # d'r for k = 1 … n − 1
    cb = np.cumsum(base[order], axis=1)[:, :-1, :]             # B'd
    q = np.arange(1, n)[None, :] - np.einsum("skp,pq,skq->sk", cb, g, cb)
    with np.errstate(divide="ignore", invalid="ignore"):
        drop = np.where(q > 1e-9, cr**2 / q, -np.inf)
    k = np.argmax(drop, axis=1)
    rss_levels = np.einsum("ij,ij->i", r, r) - drop[np.arange(len(k)), k]
    low = np.zeros(n, bool)                                    # the first row's
    low[order[0, :k[0] + 1]] = True
    with np.errstate(divide="ignore", invalid="ignore"):
        stat = np.log(rss_trend / np.maximum(rss_levels, 1e-300))
    return stat, rss_trend, low


def _declines_within(y, base, low, age, alpha: float) -> bool:
    """Whether ``y`` declines with ``age`` beside ``base`` and the two levels (``low``):
    the age's slope below zero by a one-sided Student t test at ``alpha``."""
    from scipy.stats import t as student_t

    x = np.column_stack([base, low.astype(float), age])
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    dof = y.size - x.shape[1]
    res = y - x @ coef
    if dof <= 0 or not float(res @ res) > 0:
        return False
    se = float(stats.scaled_covariance(x, float(res @ res)).stderr[-1])
    return bool(student_t.cdf(coef[-1] / max(se, 1e-150), dof) < alpha)


def two_levels(y, cycles, rate, e_ref: float, order: str) -> str | None:
    r"""Why a fade fitted at the cut-off level is not the ageing it stands for, or None:
    the discharges' energies fall in two levels, not along a trend with their age.

    ``y`` is each discharge's :math:`\ln(E/E_{ref})` (``e_ref`` [J]), with the rate term
    beside it where there is one (``rate``), ``cycles`` its age (``order`` names where the
    age comes from). Two models of ``y`` are set against each other: a trend with the age
    (the fade's signature) and two levels, the discharges split between them at the best
    threshold (a condition that differs between discharges). They are not nested, and
    the split is chosen on the data, so the statistic
    :math:`\ln(RSS_{trend}/RSS_{levels})` is referred to its distribution under the
    trend by a parametric bootstrap (Cox, *Proc. 4th Berkeley Symp.* 1, 105, 1961;
    Williams, *JRSS B* 32, 350, 1970): the fitted trend plus Gaussian noise of its own
    residual variance, :data:`TWO_LEVEL_DRAWS` draws, the split chosen afresh in each. At
    p below the search's α the trend does not describe the energies. Then:

    * a discharge of the high level after one of the low contradicts the fade as fitted:
      a pack that delivers that much more after it delivered less has not lost capacity
      between the two (capacity fade is monotone in the cycles; Birkl et al., *J. Power
      Sources* 341, 373, 2017), so the fitted size is the levels', whatever ageing there
      is besides;
    * the levels in order (all high, then all low) are a step between two sets of
      discharges. Where the energy declines with age within them too (a one-sided t
      test at the same α, :func:`_declines_within`), the fade stands: ageing within
      each of two sets far apart in age (a gap in the cycles the files' order does not
      show). Where it does not, each set is flat where a pack ageing declines from one
      discharge to the next: a change between the experiments (temperature, charger,
      charge voltage, cut-off), or ageing between two sets whose ages the data do not
      give, which these data cannot tell apart.
    """
    from planner.identify.diagnose.search import ALPHA_TRAIN

    y = np.asarray(y, float)
    n = y.size
    if n < 4:
        return None
    base = np.column_stack([np.ones(n)] + ([np.asarray(rate, float)] if rate is not None
                                           else []))
    age = np.asarray(cycles, float)
    x1 = np.column_stack([base, age])
    trend = np.eye(n) - x1 @ np.linalg.pinv(x1)
    stat, rss_trend, low = _split_statistic(y[None, :], base, trend)
    if not (np.isfinite(stat[0]) and rss_trend[0] > 0):
        return None
    sigma = math.sqrt(rss_trend[0] / max(n - x1.shape[1], 1))
    fitted = y - trend @ y
    rng = np.random.default_rng(20260)
    sims = fitted[None, :] + sigma * rng.standard_normal((TWO_LEVEL_DRAWS, n))
    null, _, _ = _split_statistic(sims, base, trend)
    p = (1 + int(np.sum(null >= stat[0]))) / (TWO_LEVEL_DRAWS + 1)
    if p >= ALPHA_TRAIN:
        return None
    by_age = np.argsort(age, kind="stable")
    first_low = int(np.argmax(low[by_age]))
    m = int((~low[by_age][first_low:]).sum())
    if not m and _declines_within(y, base, low, age, ALPHA_TRAIN):
        return None
    e = e_ref * np.exp(y) / 3600.0
    levels = (f"the energies to the cut-off fall in two levels ({np.mean(e[low]):.3g} and "
              f"{np.mean(e[~low]):.3g} W h, {int(low.sum())} and {int((~low).sum())} "
              f"discharges; a trend with age leaves {math.exp(stat[0] / 2):.2g} times "
              f"their residual, p = {p:.2g} under the trend)")
    if m:
        return (f"{levels} that alternate in the {order}: {m} of the high level "
                f"{'comes' if m == 1 else 'come'} after one of the low, which an ageing "
                "pack cannot do (it gives no capacity back); a condition that differs "
                "between the discharges (temperature, charger, charge voltage or cut-off) "
                "fits them")
    step = (f"{levels}, one after the other in the {order}: a step between two sets of "
            "discharges, where an ageing pack declines from one to the next")
    if order == "cycle":
        return (f"{step} with its cycles: a change between the experiments (temperature, "
                "charger, charge voltage or cut-off) fits them")
    return (f"{step}; a change between the experiments (temperature, charger, charge "
            "voltage or cut-off), or ageing between two sets whose ages the data do not "
            "give (no cycle count), cannot be told apart on these data")


class CapacityFade(CapacityEffect):
    r"""``capacity_fade``: the charge drawn per energy grows by :math:`\varphi` per cycle,
    :math:`\hat C = A (1 + \varphi n) G` (module notes); :math:`\varphi` [1/cycle]."""
    key = "fade_per_cycle"
    name = "capacity_fade"
    needs = ("cycle",)
    driver_label = "charge cycle (or experiment order) [cycles]"

    def prepare(self, cap) -> None:
        """Each experiment's cycle [cycles] and where it came from."""
        self.cycles = cap.cycles
        self.source = cap.cycle_source

    def skip_reason(self, cap) -> str | None:
        """Fewer than 3 experiments, or fewer than 3 different cycles."""
        if cap.n_experiments < 3:
            return (f"needs at least 3 experiments of one pack to see it age, got "
                    f"{cap.n_experiments}")
        self.prepare(cap)
        if len(np.unique(self.cycles)) < 3:
            return "the cycle count takes fewer than 3 different values"
        return None

    def cumulative(self, cap, G, dG):
        r"""The charge shape scaled by the experiment's cycle, :math:`n\,G`. [s^(1/β) cycles]"""
        return self.cycles[cap.exp_index] * G

    def cutoff_column(self, level) -> np.ndarray:
        """The cycle of each discharge (cut-off level). [cycles]"""
        return self.cycles

    def window_driver(self, cap):
        """The cycle of each window's experiment. [cycles]"""
        return self.cycles[cap.window_exp].astype(float)

    def parameters(self, values, stderr, cap, state):
        """The fade φ [1/cycle] with its standard error, the last cycle, whether the
        cycles are the experiments' order, and at the cut-off level the shift to the
        linear capacity law (:meth:`planner.identify.diagnose.cutoff.CutoffLevel.fade_law_shift`,
        in the error)."""
        f = values[self.coefficient]
        out = {"fade_per_cycle": f, "fade_per_cycle_stderr": stderr[self.coefficient],
               "cycle": float(np.max(self.cycles)),
               "cycle_from_experiment_order": float(self.source != "cycle")}
        shift = values.get(f"{self.coefficient}_law_shift")
        if shift is not None:
            out["fade_per_cycle_law_shift"] = shift
        return out

    def implausible(self, p, cap):
        """A pack that draws less charge as it ages (φ ≤ 0), or more than
        :data:`MAX_FADE_SPAN` more over the data."""
        f = p["fade_per_cycle"]
        if f <= 0:
            return (f"the fit has the pack drawing less charge as it ages ({100 * f:+.3f} % per "
                    "cycle): an ageing pack gives less charge for the same energy, never more")
        span = f * (float(np.max(self.cycles)) - float(np.min(self.cycles)))
        if span > MAX_FADE_SPAN:
            return (f"{100 * span:.0f} % more charge over the data is beyond a pack still in "
                    f"use (at most {100 * MAX_FADE_SPAN:g} %)")
        return None

    def contradicted(self, p, cap):
        """At the cut-off level, where the discharges' energies fall in two levels rather
        than along the age (:func:`two_levels`): why; else None."""
        if cap.name != "cutoff":
            return None
        return two_levels(cap.y, self.cycles, cap.rate, cap.e_ref,
                          "cycle" if self.source == "cycle" else "experiments' order")

    def alternatives(self, p, cap) -> list[str]:
        """Where the cycles are only the experiments' order (no cycle count), what else
        makes the pack give less as the experiments go on; none where the cycle count is
        logged."""
        if self.source == "cycle":
            return []
        cold = "later discharges colder than the first (a cold cell gives less"
        cold += (", and the data have no pack temperature to tell)"
                 if cap.temperature is None else ")")
        return [cold,
                "a change of charger, charge voltage or cut-off between the experiments",
                "experiments not in the order the pack was used (the files' order), or of "
                "more than one pack"]

    def cause(self, p, cap):
        """An ageing pack, in words, with φ [% per cycle or per experiment]."""
        f = 100 * p["fade_per_cycle"]
        se = 100 * p["fade_per_cycle_stderr"]
        lo, hi = float(np.min(self.cycles)), float(np.max(self.cycles))
        per = "charge cycle" if self.source == "cycle" else (
            "experiment (no cycle count in the data: experiments taken in the order they "
            "appear, one cycle each)")
        word = "rises" if f >= 0 else "falls"
        if cap.name == "cutoff":
            loss = 100.0 * (1.0 - 1.0 / (1.0 + p["fade_per_cycle"] * (hi - lo)))
            return (f"Ageing pack: the energy delivered to the cut-off falls as the pack "
                    f"ages; the charge scale rises {f:.3f} % (±{se:.3f}) per {per}, so at "
                    f"cycle {hi:.0f} the pack delivers {loss:.1f} % less energy than at cycle "
                    f"{lo:.0f} (capacity loss and resistance growth)")
        return (f"Ageing pack: the charge drawn for the same energy {word} {abs(f):.3f} % "
                f"(±{se:.3f}) per {per}; {100 * p['fade_per_cycle'] * (hi - lo):+.1f} % "
                f"from cycle {lo:.0f} to {hi:.0f}")

    def headline(self, p, cap):
        """``Pack ageing: …`` in one line."""
        f = 100 * p["fade_per_cycle"]
        unit = "cycle" if self.source == "cycle" else "experiment"
        if cap.name == "cutoff":
            return f"Ageing pack: {f:.3f} % less energy to the cut-off per {unit}"
        return f"Ageing pack: charge drawn per Wh {'rises' if f >= 0 else 'falls'} " \
               f"{abs(f):.3f} % per {unit}"


class CurrentOffset(CapacityEffect):
    r"""``current_offset``: a current sensor that reads :math:`b` too high, so the logged
    charge drifts :math:`b\,t`, also at rest (module notes); :math:`b` [A]."""
    key = "current_offset_a"
    name = "current_offset"
    needs = ()
    relative = False
    driver_label = "time since start [s]"
    driver_is_time = True

    def implausible(self, p, cap):
        """A bias beyond :data:`MAX_OFFSET_SHARE` of the median current, or one the direct
        evidence contradicts (more than 3 standard errors apart): the logged current at
        rest, or the logged current against an independently logged power
        (``cap.power_channel_offset``, :func:`planner.identify.diagnose.evidence.power_channel`),
        which measures the same offset sample by sample where the integral model's drift
        also takes up the model's own misfit."""
        b, se = p["current_offset_a"], p["current_offset_a_stderr"]
        if abs(b) > MAX_OFFSET_SHARE * cap.median_current_a:
            return (f"a bias of {b:+.2f} A is {100 * abs(b) / cap.median_current_a:.0f} % of the "
                    f"median current ({cap.median_current_a:.1f} A): beyond a sensor's zero "
                    f"error (at most {100 * MAX_OFFSET_SHARE:g} %)")
        rest = cap.rest_current
        if rest is not None:
            # direct evidence first: the logged current while the load is off
            mean, sem = rest
            z = abs(b - mean) / math.hypot(se if math.isfinite(se) else 0.0, sem)
            if z > 3.0:
                return (f"the logged current at rest is {mean:+.3f} ± {sem:.3f} A, not the "
                        f"fitted bias {b:+.3f} A: the drift is not a sensor zero error")
        direct = getattr(cap, "power_channel_offset", None)
        if direct is not None:
            # direct evidence of the same two channels: the logged current against the
            # independently logged power / voltage, sample by sample, without a model
            mean, sem = direct
            z = abs(b - mean) / math.hypot(se if math.isfinite(se) else 0.0, sem)
            if z > 3.0:
                return (f"the logged current against the logged power / voltage reads "
                        f"{mean:+.3f} ± {sem:.3f} A too high, not the fitted bias {b:+.3f} A: "
                        "the drift beyond that is a misfit of the integral model (its "
                        "charge per unit of energy), not a sensor zero error")
        return None

    def skip_reason(self, cap) -> str | None:
        """A load that is never (nearly) off: less than :data:`MIN_LOW_LOAD_SHARE` of the
        time below :data:`LOW_LOAD` of the median power."""
        reasons = []
        if getattr(cap, "power_from_current", False):
            reasons.append("the power is the logged voltage × the logged current: an offset "
                           "of the current sensor is in the power too, and the integral model "
                           "driven by that power draws the offset's charge itself")
        share = cap.low_load_fraction
        if share < MIN_LOW_LOAD_SHARE:
            reasons.append(f"the load is never (nearly) off: only {100 * share:.1f} % of the "
                           f"time below {100 * LOW_LOAD:.0f} % of the median power (needs "
                           f"{100 * MIN_LOW_LOAD_SHARE:g} %): a sensor bias cannot be told "
                           "from the calibration without rests or idle periods")
        return "; and ".join(reasons) or None

    def cumulative(self, cap, G, dG):
        r"""Time since each experiment's start: the drift :math:`b\,t` per unit b. [s]"""
        return cap.time_since_start

    def parameters(self, values, stderr, cap, state):
        """The bias b [A] and the drift it gives [mAh/h], with standard errors."""
        b = values[self.coefficient]
        return {"current_offset_a": b, "current_offset_a_stderr": stderr[self.coefficient],
                "drift_mah_per_hour": b * 1000.0,
                "drift_mah_per_hour_stderr": stderr[self.coefficient] * 1000.0}

    def cause(self, p, cap):
        """A sensor bias, in words, with b [A] and the drift [mAh/h]."""
        b = p["current_offset_a"]
        rest = cap.rest_fraction
        extra = (f" (the record rests {100 * rest:.0f} % of the time, where the drift shows "
                 "alone)" if rest > 0.01 else "")
        return (f"Current sensor bias: the logged current reads {abs(b):.3f} A "
                f"(±{p['current_offset_a_stderr']:.3f}) too {'high' if b > 0 else 'low'}, "
                f"so the logged charge drifts {abs(b) * 1000:.0f} mAh per hour, also while the "
                f"load is off{extra}; calibrate the sensor's zero")

    def headline(self, p, cap):
        """``Current sensor bias: …`` in one line."""
        b = p["current_offset_a"]
        return (f"Current sensor bias: logged current {abs(1000 * b):.0f} mA too "
                f"{'high' if b > 0 else 'low'}, charge drifts {abs(b) * 1000:.0f} mAh/h")


# ============================================================================ power

class PowerEffect(Effect):
    """An effect at the power level: it changes the model's inputs (:meth:`transform`), adds
    nonlinear parameters (:attr:`bounds`) or linear columns (:meth:`columns`) (module
    notes, "Power level")."""
    level = "power"
    #: (start, low, high, scale) of each nonlinear parameter.
    bounds: ClassVar[dict[str, tuple[float, float, float, float]]] = {}
    #: Linear column names this effect adds.
    linear: ClassVar[tuple[str, ...]] = ()

    def start(self, pw) -> dict[str, tuple[float, float, float, float]]:
        """(start, low, high, scale) of each nonlinear parameter on this level's data."""
        return dict(self.bounds)

    def transform(self, inputs: dict, values: dict, pw, state: dict) -> dict:
        """Return the model inputs (airspeed, density, mass per bin) with the effect."""
        return inputs

    def columns(self, M: np.ndarray, pw, state: dict) -> list[np.ndarray]:
        """The linear columns the effect adds, per bin, given the mechanical power ``M`` [W]."""
        return []

    def bin_driver(self, pw, state: dict) -> np.ndarray:
        """What each bin's residual is plotted against (default: time [s])."""
        return pw.time


#: Sample interval from which a wind's alternatives include a step the sampling cannot
#: locate: on the M100 flights decimated to 0.5 and 0.25 Hz a release was no longer
#: located and a wind took it up, at 1 Hz it was (docs/results.md, "At a telemetry
#: rate"). [s]
SPARSE_SAMPLE_S = 2.0


class Wind(PowerEffect):
    r"""``wind``: a steady wind :math:`(w_N, w_E)` [m/s] turns the ground velocity into the
    airspeed :math:`|\vec v_g - \vec w|` (module notes)."""
    key = "wind_speed_ms"
    name = "wind"
    needs = ("groundspeed_ms", "course_deg")
    nonlinear = ("wind_n_ms", "wind_e_ms")
    bounds: ClassVar[dict] = {"wind_n_ms": (0.0, -25.0, 25.0, 1.0),
                              "wind_e_ms": (0.0, -25.0, 25.0, 1.0)}
    driver_label = "course over ground [deg]"

    def skip_reason(self, pw) -> str | None:
        """What in the data stops a wind from being seen (:meth:`data_reason`), or a route
        on which a wind from more than 1 − :data:`planner.identify.diagnose.limits.POWER` of
        the directions is one step per flight (:meth:`route_reason`, :meth:`regime_confound`):
        a wind is then not named from any direction, so it is not tested."""
        return self.data_reason(pw) or self.route_reason(pw)

    def data_reason(self, pw) -> str | None:
        """A measured airspeed, no course, too little moving flight (:data:`MIN_MOVING_SHARE`)
        or one direction of travel only (:data:`MAX_COURSE_CONCENTRATION`): a wind does not
        change what the power model sees, or cannot be told from the calibration."""
        if pw.airspeed_measured:
            return ("airspeed is measured: the power model already sees the air the "
                    "aircraft flies in, whatever the wind")
        if not pw.has_course:
            return ("no direction of travel (course_deg) in the data: a wind cannot be told "
                    "from how power depends on it")
        moving = pw.moving
        if moving.mean() < MIN_MOVING_SHARE:
            return (f"the aircraft moves (≥ 2 m/s) in only {100 * moving.mean():.0f} % of "
                    "the airborne time: too little to see a wind")
        a = np.radians(pw.course[moving])
        r = float(np.hypot(np.mean(np.cos(a)), np.mean(np.sin(a))))
        if r > MAX_COURSE_CONCENTRATION:
            return ("the aircraft flew in one direction only (course concentration "
                    f"{r:.2f}): a wind cannot be told from the calibration")
        return None

    #: On a route where a wind is one step per flight, a payload step is its rival.
    rival_of: ClassVar[tuple[str, ...]] = ("payload_change",)

    def rival_reason(self, pw) -> str | None:
        """A wind that the data could show but the route turns into one step per flight
        (:meth:`route_reason`) is not named, but a payload step it explains as well is
        not either (:func:`planner.identify.diagnose.search.search`)."""
        return None if self.data_reason(pw) else self.route_reason(pw)

    def route_reason(self, pw) -> str | None:
        """Why this route cannot tell a wind from a change in time within the flights
        (:meth:`skip_reason`); None when it can."""
        moving = pw.moving

        # the route's own test (:meth:`regime_confound`), for a light wind (linear regime:
        # the airspeed changes by −v̂·w, whatever the wind's speed)
        light = 1e-3 * float(np.median(np.hypot(pw.vn, pw.ve)[moving]))
        q, words = self.one_step_route(pw, light)
        if words:
            return (f"{words} (the legs are flown in one order): a wind cannot be told from a "
                    "payload dropped or picked up there, or anything else that changes in "
                    "time within the flights")
        return None

    def transform(self, inputs, values, pw, state):
        """The inputs with the airspeed through the wind triangle where the ground velocity is
        known (in the rotor disks' plane where the level flies it). [m/s]"""
        wn = pw.logged_wind_n + values["wind_n_ms"]
        we = pw.logged_wind_e + values["wind_e_ms"]
        v = np.hypot(pw.vn - wn, pw.ve - we)
        if getattr(pw, "rotor_axial", False):     # the speed in the rotor disks' plane
            v = inplane_speed(v, pw.climb, inputs["climb"])
        out = dict(inputs)
        out["airspeed"] = np.where(pw.course_known, v, inputs["airspeed"])
        return out

    def bin_driver(self, pw, state):
        """Course over ground of each bin. [deg]"""
        return pw.course

    @staticmethod
    def step_share(pw, wind_n_ms: float, wind_e_ms: float) -> float:
        r"""Share of the within-flight variance of the airspeed change :math:`\Delta v` that
        a wind :math:`(w_N, w_E)` [m/s] makes over the moving bins which one step per flight
        (at its best place) explains (:meth:`regime_confound`); NaN without variation.
        [unitless]"""
        wn0, we0 = pw.logged_wind_n, pw.logged_wind_e
        dv = (np.hypot(pw.vn - wn0 - wind_n_ms, pw.ve - we0 - wind_e_ms)
              - np.hypot(pw.vn - wn0, pw.ve - we0))
        m = pw.moving
        sse = sst = 0.0
        for e in np.unique(pw.exp[m]):
            x = dv[m & (pw.exp == e)]
            if x.size < 6:
                continue
            x = x - x.mean()
            sst += float(np.dot(x, x))
            # best single step: the split that leaves the least squared error
            n = x.size
            k = np.arange(1, n)
            cs = np.cumsum(x)[:-1]
            gain = cs**2 / k + cs**2 / (n - k)     # between-segment sum of squares
            sse += float(np.dot(x, x) - gain.max())
        return 1.0 - sse / sst if sst > 0 else math.nan

    @classmethod
    def passing_share(cls, pw, speed_ms: float) -> float:
        """Share of :data:`ROUTE_DIRECTIONS` directions from which a wind of ``speed_ms``
        [m/s] is *not* one step per flight on this route (:meth:`step_share` below
        :data:`planner.identify.diagnose.CONFOUND_R`²). [unitless]"""
        from planner.identify.diagnose import CONFOUND_R

        a = np.radians(np.arange(ROUTE_DIRECTIONS) * 360.0 / ROUTE_DIRECTIONS)
        share = np.array([cls.step_share(pw, speed_ms * math.cos(x), speed_ms * math.sin(x))
                          for x in a])
        return float(np.mean(~(share >= CONFOUND_R**2)))

    @classmethod
    def one_step_route(cls, pw, speed_ms: float) -> tuple[float, str | None]:
        """The route's test for a wind of ``speed_ms`` [m/s]: the share ``q`` of directions
        from which it is not one step per flight (:meth:`passing_share`) and, where ``q``
        is below :data:`planner.identify.diagnose.limits.POWER` (a wind of unknown direction
        could not be named in that share of cases at any size), the reason's opening words;
        else None."""
        from planner.identify.diagnose.limits import POWER

        q = cls.passing_share(pw, speed_ms)
        if q >= POWER:
            return q, None
        return q, (f"on this route a steady wind from {100 * (1 - q):.0f} % of the directions "
                   "changes the airspeed within each flight as one step")

    def regime_confound(self, pw, state) -> tuple[str, list[str]] | None:
        r"""Why the fitted wind cannot be told from a mass change in flight, and the
        candidates; None when it can.

        A steady wind changes the airspeed by :math:`\Delta v = |\vec v_g - \vec w| - |\vec
        v_g - \vec w_0|` (:math:`\vec w_0` the logged wind, or calm). On an out-and-back
        route it is one sign on the way out and the other on the way back: a step at the
        turnaround, which a payload dropped (or picked up) there fits as well. The test is
        the one of the other confounds (:data:`planner.identify.diagnose.CONFOUND_R`): the share of
        the within-flight variance of :math:`\Delta v` over the moving bins that one step
        per flight (its best place) explains.

        The route itself is checked too: where winds from more than 1 −
        :data:`planner.identify.diagnose.limits.POWER` of the directions (of the fitted speed)
        are one step per flight (:meth:`passing_share`), a fitted wind is withheld from
        whichever direction it comes. A mass change, or anything else that changes in time
        within flights flown in one order, pulls the fitted direction to the one that
        mimics it, which may sit just short of the step test (on the DJI M100 triangle
        route, ``benchmarks/bench_effect_matrix.py --sources m100 --injections payload``, the
        winds fitted on records with a payload drop came from 294–304°, one step for
        71–82 % of their airspeed change); and this is the route on which the detection
        limit says a wind is not identifiable (:func:`planner.identify.diagnose.limits._wind_gate`),
        so the decision and the limit agree.
        """
        from planner.identify.diagnose import CONFOUND_R

        values = state.get("values", {})
        if "wind_n_ms" not in values:
            return None
        r2 = self.step_share(pw, values["wind_n_ms"], values["wind_e_ms"])
        if not math.isfinite(r2) or r2 < CONFOUND_R**2:
            _, words = self.one_step_route(pw, math.hypot(values["wind_n_ms"],
                                                          values["wind_e_ms"]))
            if words is None:
                return None
            return (f"{words}, which a mass change "
                    "fits as well; a wind fitted on such a route takes the direction that "
                    "mimics whatever changed in time within the flights, so the data cannot "
                    "tell a wind from a payload dropped or picked up, from whichever "
                    "direction it is fitted", [self.name, "payload_change"])
        return (f"{100 * r2:.0f} % of the wind's change of the airspeed within each flight is "
                "one step (out and back): a mass change in flight at that point fits the same "
                "power pattern, so the data cannot tell the wind from a payload dropped or "
                "picked up there", [self.name, "payload_change"])

    def parameters(self, values, stderr, pw, state):
        """Wind components, speed [m/s] and the direction it blows from [deg], with standard
        errors; whether it adds to the autopilot's logged wind. On a multirotor the
        speed's error adds in quadrature the bias the model's power in the hover can put
        into it (:meth:`planner.identify.diagnose.search.PowerLevel.hover_shift`; the shift
        and the bias are kept), and each component its share of it. Where the flights'
        power changes with airspeed otherwise than the model's (:func:`speed_scale`), the
        wind is the one fitted with that change's scale free
        (:meth:`planner.identify.diagnose.search.PowerLevel.speed_read`); the scale
        (``speed_response``) and the model's own reading (``wind_speed_ms_model``) are
        kept."""
        wn, we = values["wind_n_ms"], values["wind_e_ms"]
        sn, se = stderr["wind_n_ms"], stderr["wind_e_ms"]
        speed = math.hypot(wn, we)
        frm = float(course_deg(-we, -wn))
        s_speed = math.sqrt((wn * sn) ** 2 + (we * se) ** 2) / speed if speed > 0 else \
            math.hypot(sn, se)
        s_dir = math.degrees(math.sqrt((we * sn) ** 2 + (wn * se) ** 2) / speed**2) \
            if speed > 0 else 180.0
        out = {}
        bias = values.get("wind_speed_ms_hover_bias")
        if bias is not None and speed > 0:
            # the bias lies along the wind: the speed takes it whole, each component its part
            s_speed = math.hypot(s_speed, bias)
            sn, se = math.hypot(sn, bias * wn / speed), math.hypot(se, bias * we / speed)
            out = {"wind_speed_ms_hover_shift": values["wind_speed_ms_hover_shift"],
                   "wind_speed_ms_hover_bias": bias}
        for k in ("speed_response", "speed_response_stderr", "wind_speed_ms_model"):
            if k in values:
                out[k] = values[k]
        return {"wind_n_ms": wn, "wind_n_ms_stderr": sn, "wind_e_ms": we,
                "wind_e_ms_stderr": se, "wind_speed_ms": speed, "wind_speed_ms_stderr": s_speed,
                "wind_from_deg": frm, "wind_from_deg_stderr": min(s_dir, 180.0),
                "logged_wind_added": float(pw.has_logged_wind), **out}

    def implausible(self, p, pw):
        """A wind above :data:`MAX_WIND_SHARE` of the maximum airspeed, or one whose speed
        cannot be read (:func:`speed_scale`: the flights do not show their power changing
        with airspeed)."""
        k, sk = p.get("speed_response", 1.0), p.get("speed_response_stderr", 0.0)
        if math.isnan(speed_scale(k, sk)):
            return (f"these flights' power changes with airspeed {k:.2f} ± {sk:.2f} times as "
                    "much as the calibrated model's, not clearly at all: the speed of a wind "
                    "read through that change cannot be told")
        vmax = pw.aircraft.max_airspeed_ms
        if p["wind_speed_ms"] > MAX_WIND_SHARE * vmax:
            return (f"a steady wind of {p['wind_speed_ms']:.1f} m/s is more than "
                    f"{100 * MAX_WIND_SHARE:g} % of the aircraft's maximum airspeed "
                    f"({vmax:.0f} m/s): it could not have flown the record")
        return None

    def cause(self, p, pw):
        """A steady wind, in words, with its speed [m/s] and direction [deg]."""
        extra = " beyond the autopilot's own wind estimate" if pw.has_logged_wind else ""
        text = (f"Steady wind{extra}: {_pm(p['wind_speed_ms'], p['wind_speed_ms_stderr'], 1)} "
                f"m/s from {p['wind_from_deg']:.0f}° ({_compass(p['wind_from_deg'])}); airspeed "
                "differs from groundspeed, so the power depends on the direction of travel "
                f"(check missions in it: {p['wind_speed_ms']:.1f} m/s from "
                f"{p['wind_from_deg']:.0f}°)")
        k = p.get("speed_response", 1.0)
        if speed_scale(k, p.get("speed_response_stderr", 0.0)) != 1.0:
            text += (f". These flights' power changes with airspeed "
                     f"{_pm(k, p['speed_response_stderr'], 2)} times as much as the calibrated "
                     f"model's; read through the model's own change it is "
                     f"{p['wind_speed_ms_model']:.1f} m/s")
        return text

    def alternatives(self, p, pw) -> list[str]:
        """What else makes the power follow the course: a step of the mass or of a load
        where the flights turn onto another leg, and, where the record is sampled too
        sparsely (:data:`SPARSE_SAMPLE_S` or more between samples) to locate a step within
        a flight, any such step."""
        out = ["a change of mass or of an electrical load partway through the flights, where "
               "they turn onto another leg (on a route flown in one order, a step in time "
               "and a change of course look alike)"]
        dt = pw.sample_interval_s
        if dt >= SPARSE_SAMPLE_S:
            out.append(f"with one sample every {dt:.1f} s a step of the power within a flight "
                       "cannot be located, and a wind may take it up: set the named wind "
                       "against the flights' own weather (an anemometer, a forecast)")
        return out

    def headline(self, p, pw):
        """``Wind: …`` in one line."""
        return (f"Wind: {p['wind_speed_ms']:.1f} m/s from {p['wind_from_deg']:.0f}° "
                f"({_compass(p['wind_from_deg'])}), power depends on the direction of travel")


def speed_scale(k: float, k_stderr: float) -> float:
    r"""What the flights' scale ``k`` ± ``k_stderr`` on the model's change of power with
    airspeed (:class:`SpeedResponse`) makes of a wind read through it: 1 where :math:`k`
    lies within :data:`SPEED_RESPONSE_Z` standard errors or :data:`SPEED_RESPONSE_FLOOR`
    of 1 (the model's change is taken as the aircraft's); :math:`k` where it lies farther
    and :data:`SPEED_RESPONSE_Z` standard errors above 0 (the wind is read with the
    scale free, :meth:`Wind.parameters`); NaN where it lies farther and not clearly above
    0 (the flights do not show their power changing with airspeed: a wind's speed cannot
    be read). [unitless]"""
    if not (math.isfinite(k) and math.isfinite(k_stderr)):
        return 1.0
    if abs(k - 1.0) <= max(SPEED_RESPONSE_Z * k_stderr, SPEED_RESPONSE_FLOOR):
        return 1.0
    return k if k - SPEED_RESPONSE_Z * k_stderr > 0.0 else math.nan


class SpeedResponse(PowerEffect):
    r"""``speed_response``: a free scale :math:`k` on the model's change of power with
    airspeed, :math:`P = P_0 + k\,(P(V) - P_0)` with :math:`P_0` the model's power at the
    same state with no airspeed; a linear column :math:`M - M_0` beside the mechanical
    power :math:`M`, whose coefficient :math:`c` gives :math:`k = 1 + c\,\eta`. Not a
    cause (it is not in the vocabulary): the wind is read with it (module notes of
    :mod:`planner.identify.diagnose.search`, "Wind"). [unitless]"""
    key = "speed_response"
    name = "speed_response"
    needs = ()
    linear = ("speed_response_coefficient",)

    def columns(self, M, pw, state):
        """The mechanical power less its value with no airspeed (the same state
        otherwise, :meth:`planner.identify.diagnose.search.PowerLevel._evaluate`). [W per W]"""
        return [M - state["still_mechanical_w"]]


class AirDensity(PowerEffect):
    r"""``air_density``: the power follows the measured density,
    :math:`\rho = \rho_{std} (\rho_{meas}/\rho_{std})^a`; :math:`a` unitless (module notes)."""
    key = "density_exponent"
    name = "air_density"
    needs = ("pressure_pa",)
    nonlinear = ("density_exponent",)
    bounds: ClassVar[dict] = {"density_exponent": (0.0, -2.0, 4.0, 0.1)}
    driver_label = "measured air density [kg/m³]"

    def skip_reason(self, pw) -> str | None:
        """No measured pressure, or a density that varies by less than
        :data:`MIN_LOG_DENSITY_SPREAD`."""
        if not pw.has_pressure:
            return ("no static pressure (pressure_pa) in the data: the air density cannot be "
                    "measured")
        spread = float(np.std(np.log(pw.rho_meas / pw.rho_std)))
        if spread < MIN_LOG_DENSITY_SPREAD:
            mean = float(np.mean(pw.rho_meas))
            return (f"the measured air density varies by only {100 * spread:.1f} % (mean "
                    f"{mean:.3f} kg/m³): a constant density is absorbed by the efficiency")
        return None

    def transform(self, inputs, values, pw, state):
        r"""The inputs with the density :math:`\rho_{std} (\rho_{meas}/\rho_{std})^a`. [kg/m³]"""
        out = dict(inputs)
        out["air_density"] = pw.rho_std * np.exp(values["density_exponent"] * pw.log_rho_ratio)
        return out

    def bin_driver(self, pw, state):
        """Measured air density of each bin. [kg/m³]"""
        return pw.rho_meas

    def parameters(self, values, stderr, pw, state):
        """The exponent a with its standard error, the measured density range and the
        standard density [kg/m³], and whether the temperature was logged."""
        return {"density_exponent": values["density_exponent"],
                "density_exponent_stderr": stderr["density_exponent"],
                "density_min_kg_m3": float(np.min(pw.rho_meas)),
                "density_max_kg_m3": float(np.max(pw.rho_meas)),
                "standard_density_kg_m3": float(np.mean(pw.rho_std)),
                "temperature_logged": float(pw.has_air_temperature)}

    def implausible(self, p, pw):
        """An exponent outside :data:`DENSITY_EXPONENT_RANGE`."""
        a = p["density_exponent"]
        if not DENSITY_EXPONENT_RANGE[0] <= a <= DENSITY_EXPONENT_RANGE[1]:
            return (f"the power follows the density with exponent {a:.2f}, outside "
                    f"[{DENSITY_EXPONENT_RANGE[0]:g}, {DENSITY_EXPONENT_RANGE[1]:g}] (momentum "
                    "theory: rotor power falls as the density rises, exponent near 0.5–1)")
        return None

    def cause(self, p, pw):
        """A non-standard density, in words, with its range [kg/m³] and the exponent."""
        how = "pressure and temperature" if pw.has_air_temperature else \
            "pressure (ISA temperature)"
        return (f"Air density differs from standard: {p['density_min_kg_m3']:.3f}–"
                f"{p['density_max_kg_m3']:.3f} kg/m³ from the measured {how}, against "
                f"{p['standard_density_kg_m3']:.3f} assumed; the power follows it with "
                f"exponent {_pm(p['density_exponent'], p['density_exponent_stderr'], 2)} "
                "(1 = as momentum theory predicts)")

    def headline(self, p, pw):
        """``Air density …`` in one line."""
        return (f"Air density {p['density_min_kg_m3']:.2f}–{p['density_max_kg_m3']:.2f} kg/m³, "
                "not standard: power follows the measured density")


class StepEstimate:
    """A payload candidate's step as its training folds read it, computed when asked
    (the detection limit asks only of a candidate not named: ``limits.unsettled``).

    ``mass_step_kg``: the median over the folds of the step read on the flights whose
    change is located (:meth:`planner.identify.diagnose.search.PowerLevel.read_step`:
    the fitted step moved as the named step's read moves it, with the vertical descents
    at a power level of their own; the fitted step where the read cannot be made) [kg];
    ``change_time_s``: each flight's located change time, the median over the folds it
    trains in (flights located in none left out) [s]."""

    def __init__(self, fits, level, effects):
        self.fits, self.level, self.effects = fits, level, effects

    @functools.cached_property
    def mass_step_kg(self) -> float:
        """The median over the folds of the step read on their located flights. [kg]"""
        return float(np.median([self.level.read_step(f, self.effects) for f in self.fits]))

    @property
    def change_time_s(self) -> dict[str, float]:
        """Each located flight's change time, the median over the folds it trains in. [s]"""
        times: dict[str, list[float]] = {}
        for f in self.fits:
            for k, v in f.located_changes().items():
                times.setdefault(k, []).append(v)
        return {k: float(np.median(v)) for k, v in times.items()}


class PayloadChange(PowerEffect):
    r"""``payload_change``: the mass steps by :math:`\Delta m` [kg] at a time located in each
    flight (module notes of :mod:`planner.identify.diagnose.search`)."""
    key = "mass_step_kg"
    name = "payload_change"
    #: A change within a flight explains only variation within it (the flight's own
    #: constant mass is projected out where the change is located): its training test
    #: compares the residuals net of each flight's mean (:func:`planner.diagnose.search.compare`).
    within_experiment = True
    needs = ()
    nonlinear = ("mass_step_kg",)
    bounds: ClassVar[dict] = {"mass_step_kg": (0.0, -10.0, 10.0, 0.05)}
    driver_label = "time since start [s]"
    driver_is_time = True

    def estimate(self, fits, pw, effects) -> StepEstimate | None:
        """The step the training folds read and each flight's located change time
        (:class:`StepEstimate`); None where no fold fits a step."""
        fits = [f for f in fits if "mass_step_kg" in f.nl_names]
        return StepEstimate(fits, pw, tuple(effects)) if fits else None

    def implausible(self, p, pw):
        """No flight with a change, a drop beyond :data:`MAX_DROP_SHARE` of the mass, or a
        pick-up past the maximum take-off mass."""
        if p.get("flights_with_change", 0) < 1:
            return "no flight has a change time: the step is never applied"
        dm = p["mass_step_kg"]
        if dm < 0 and -dm > MAX_DROP_SHARE * pw.mass0:
            return (f"a drop of {-dm:.2f} kg is more than {100 * MAX_DROP_SHARE:g} % of the "
                    f"all-up mass ({pw.mass0:.2f} kg)")
        mtow = pw.aircraft.max_takeoff_mass_kg
        if dm > 0 and mtow is not None and pw.mass0 + dm > mtow:
            return (f"a pick-up of {dm:.2f} kg takes the aircraft to "
                    f"{pw.mass0 + dm:.2f} kg, above its maximum take-off mass {mtow:.2f} kg")
        return None

    def regime_confound(self, pw, state) -> tuple[str, list[str]] | None:
        """Why the located steps cannot be told from a change of flight regime, and the
        candidates; None when they can.

        A mass step switches the model's mass on at the change time of each flight. When
        the change times sit where the flight changes regime — at the end of the climb or
        the start of the descent — the step's indicator is (almost) the indicator of the
        regime: a power model whose climb or descent power is wrong fits the same step. The
        test is the one of the other confounds (:data:`planner.identify.diagnose.CONFOUND_R`): the
        share of the variance of the step indicator, over the airborne bins of the flights
        with a change, that a linear fit on the regime indicators (climbing, descending:
        the altitude-checked climb rate beyond ±:data:`planner.chain.flightstate.CLIMB_THRESHOLD_MS`)
        explains. Ground speed is deliberately not a regime here: with a wind it varies
        with the direction of travel, which a wind effect explains.

        Where the record logs the flight mode, a step that falls at a change of mode in
        every flight with one (:data:`MODE_BEFORE_S` before it to :data:`MODE_AFTER_S`
        after) cannot be told from a change of how the aircraft is flown either (a mode
        changes the controllers, the thrust, a landing detector).
        """
        mask = state.get("step_mask")
        times = state.get("change_time_s", {})
        located = [pw.names.index(k) for k, v in times.items() if v is not None]
        if mask is None or not located:
            return None
        modes = _modes_at_steps(pw, {k: v for k, v in times.items() if v is not None})
        if modes is not None:
            return (f"every located step falls at a change of flight mode ({modes}): a step "
                    "at a mode change cannot be told from a change of how the aircraft is "
                    "flown", [self.name, f"the change of flight mode ({modes})"])
        gate = self.step_gate(pw, mask, located)
        if gate is None:
            return None
        kind, r2 = gate
        if kind == "regime":
            return (f"{100 * r2:.0f} % of the variation of its step (on after the change time "
                    f"in {len(located)} flight(s)) follows the flight regime (climbing, level, "
                    "descending): the data cannot tell a mass change from a power model whose "
                    "climb or descent power is wrong",
                    [self.name, "the power model's climb or descent power"])
        return (f"{100 * r2:.0f} % of the variation of its step within the flights follows the "
                "direction of travel (out and back): a steady wind fits the same power pattern, "
                "so the data cannot tell a mass change from a wind",
                [self.name, "wind"])

    @classmethod
    def step_gate(cls, pw, mask, located) -> tuple[str, float] | None:
        r"""The gate that withholds a step with indicator ``mask`` (1 after each flight's
        change) in the flights ``located``, whatever its size, with its share of the step's
        variation: ``("regime", r²)`` where the climb and descent regimes explain at least
        :data:`planner.identify.diagnose.CONFOUND_R`² of it (:meth:`regime_share`), else
        ``("course", r²)`` where a wind would change what the power model sees (a course
        and no measured airspeed, :meth:`Wind.data_reason`) and the cosine and sine of the
        course explain that much of its within-flight variation (:meth:`course_share`: a
        wind :math:`\vec w` changes the airspeed by about :math:`-\hat v_g \cdot \vec w`);
        None when neither does (:meth:`regime_confound`, and the detection limit's
        positions)."""
        from planner.identify.diagnose import CONFOUND_R

        mask = np.asarray(mask, float)
        r2 = cls.regime_share(pw, mask, located)
        if r2 >= CONFOUND_R**2:
            return "regime", r2
        if not getattr(pw, "has_course", False) or Wind().data_reason(pw) is not None:
            return None
        r2 = cls.course_share(pw, mask, located)
        return ("course", r2) if r2 >= CONFOUND_R**2 else None

    @staticmethod
    def regime_share(pw, mask, located) -> float:
        """Share of the variance of a step indicator ``mask`` over the airborne bins of the
        flights ``located`` that the regime indicators (climbing, descending) explain
        (:meth:`regime_confound`); NaN without variation. [unitless]"""
        from planner.chain.flightstate import climb_regimes

        rows = np.isin(pw.exp, located)
        y = np.asarray(mask, float)[rows]
        if np.var(y) <= 0:
            return math.nan
        X = np.column_stack([np.ones(y.size)]
                            + list(climb_regimes(pw.climb[rows]).values())).astype(float)
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        return float(1.0 - np.var(y - X @ coef) / np.var(y))

    @staticmethod
    def course_share(pw, mask, located) -> float:
        r"""Share of the within-flight variance of a step indicator ``mask`` (1 after each
        flight's change) over the moving bins of the flights ``located`` that the cosine
        and sine of the course explain (:meth:`step_gate`); NaN where it cannot be
        computed. [unitless]"""
        rows = pw.moving & np.isin(pw.exp, located)
        if rows.sum() < 10:
            return math.nan
        c = np.radians(pw.course[rows])
        exp = pw.exp[rows]
        y, xc, xs = (stats.within_groups(v, exp) for v in (mask[rows], np.cos(c), np.sin(c)))
        sst = float(np.dot(y, y))
        if sst <= 0:
            return math.nan
        X = np.column_stack([xc, xs])
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        return float(1.0 - np.sum((y - X @ coef) ** 2) / sst)

    def start(self, pw):
        """The mass step's start, bounds and scale from the median all-up mass. [kg]"""
        m0 = float(np.median(pw.mass))
        return {"mass_step_kg": (0.0, -0.9 * m0, 2.0 * m0, 0.05 * m0)}

    def extra_dof(self, state):
        """One more degree of freedom per located change time."""
        return sum(1 for v in state.get("change_time_s", {}).values() if v is not None)

    def practical(self, fits, pw) -> str | None:
        """A step below :data:`MIN_MASS_STEP` of the all-up mass is not a payload."""
        steps = [abs(f.values()["mass_step_kg"]) for f in fits]
        step = float(np.median(steps))
        if step < MIN_MASS_STEP * pw.mass0:
            return (f"mass step {step:.3f} kg is below {100 * MIN_MASS_STEP:g} % of the "
                    f"all-up mass ({pw.mass0:.2f} kg): not a payload")
        return None

    def transform(self, inputs, values, pw, state):
        """The inputs with the mass stepped after each flight's change time, and raised
        by the step × the posterior probability that the change has happened in a flight
        whose change was not located (the change's expectation given its record:
        :meth:`planner.identify.diagnose.search.PowerLevel._change_posterior`). [kg]"""
        step = state.get("step_mask")
        if step is None:
            return inputs
        out = dict(inputs)
        expected = state.get("unlocated_expectation")
        if expected is not None:
            step = step + expected
        out["mass"] = inputs["mass"] + values["mass_step_kg"] * step
        return out

    def bin_driver(self, pw, state):
        """Time of each bin since its flight's start. [s]"""
        return pw.time

    def parameters(self, values, stderr, pw, state):
        """The step [kg] with its standard error, as the located flights show it net of the
        vertical descents' own level
        (:meth:`planner.identify.diagnose.search.PowerLevel.step_read`; the fit on every
        flight's kept as ``mass_step_kg_pooled``), else as fitted on every flight with the
        bias the vertical descents can put into it added in quadrature
        (:meth:`planner.identify.diagnose.search.PowerLevel.descent_shift`); the error the
        larger of the fit's and the spread of the placebo steps
        (:meth:`planner.identify.diagnose.search.PowerLevel.placebo_steps`; all kept), the
        flights with a change, their change times [s] and how many fall at the end of a
        climb."""
        out = {"mass_step_kg": values["mass_step_kg"],
               "mass_step_kg_stderr": stderr["mass_step_kg"]}
        for k in ("mass_step_kg_fit_stderr", "mass_step_kg_placebo_sd", "placebo_positions",
                  "mass_step_kg_pooled", "mass_step_kg_pooled_stderr",
                  "mass_step_kg_read_flights", "mass_step_kg_read_descent_level",
                  "mass_step_kg_descent_shift", "mass_step_kg_descent_bias"):
            if k in values:
                out[k] = values[k]
        times = state.get("change_time_s", {})
        located = {k: v for k, v in times.items() if v is not None}
        out["flights_with_change"] = float(len(located))
        if located:
            out["change_time_min_s"] = float(min(located.values()))
            out["change_time_max_s"] = float(max(located.values()))
        out["changes_at_end_of_climb"] = float(sum(
            _end_of_climb(pw, pw.names.index(k), v) for k, v in located.items()))
        out["changes_at_start_of_descent"] = float(sum(
            _start_of_descent(pw, pw.names.index(k), v) for k, v in located.items()))
        out["power_step_w"] = _power_step(pw, values, state)
        for k, v in list(located.items())[:20]:
            out[f"change_time_s[{k}]"] = float(v)
        return out

    def cause(self, p, pw, state=None):
        """A power step in flight, in words, with its size [W], the mass change it is
        consistent with [kg], its times [s], a change of flight mode near it (the
        ``mode`` channel), and a caution where most of its changes fall at the end of a
        climb or the start of a descent: the evidence and the alternatives, not a payload
        as fact."""
        dm = p["mass_step_kg"]
        dp = p.get("power_step_w", math.nan)
        n = int(p.get("flights_with_change", 0))
        when = "" if not n else (f"at {p['change_time_min_s']:.0f} s" if n == 1 else
                                 f"in {n} flights ({p['change_time_min_s']:.0f}–"
                                 f"{p['change_time_max_s']:.0f} s after their start)")
        step = f"a {dp:+.0f} W step" if math.isfinite(dp) else "a step"
        text = (f"{step[0].upper() + step[1:]} of the power {when} that the flight state does "
                f"not explain, consistent with a {_pm(abs(dm), p['mass_step_kg_stderr'], 2)} kg "
                f"mass {'decrease' if dm < 0 else 'increase'} (a payload "
                f"{'dropped' if dm < 0 else 'picked up'}) or anything else that "
                f"{'lowers' if dm < 0 else 'raises'} the power")
        if "mass_step_kg_pooled" in p:
            # the step as read on its located flights (search.PowerLevel.step_read)
            k = int(p["mass_step_kg_read_flights"])
            level = (", the vertical descents at a power level of their own"
                     if p.get("mass_step_kg_read_descent_level") else "")
            text += (f" (sized on the {k} flight{'s' if k != 1 else ''} whose change is "
                     f"located{level}; fitted on every flight: "
                     f"{abs(p['mass_step_kg_pooled']):.2f} kg)")
        modes = mode_changes_near(pw, p)
        if modes:
            text += "; " + "; ".join(modes)
        for key, where, what in (("changes_at_end_of_climb", "the end of a climb", "climb"),
                                 ("changes_at_start_of_descent", "the start of a descent",
                                  "descent")):
            n_at = int(p.get(key, 0))
            if n_at and n_at >= 0.5 * p["flights_with_change"]:
                text += (f". Caution: {n_at} of {int(p['flights_with_change'])} change "
                         f"time(s) fall at {where}: the power model's {what} may be wrong "
                         "instead")
        return text

    def alternatives(self, p, pw) -> list[str]:
        """What else makes a step of the power within a flight."""
        dm = p["mass_step_kg"]
        dp = p.get("power_step_w", math.nan)
        size = f"{abs(dp):.0f} W " if math.isfinite(dp) else ""
        on = "switched off" if dm < 0 else "switched on"
        out = ["a change of how the aircraft is flown there (flight mode, height above "
               "ground, speed) that the power model does not follow",
               f"a load of {size}{on} (lights, a gimbal, a heater)"]
        # a wind not tested because the route turns it into one step per flight fits
        # the same step (Wind.rival_reason)
        if Wind().rival_reason(pw) is not None:
            out.append("a steady wind: on this route it changes the airspeed within each "
                       "flight as one step (the legs are flown in one order)")
        return out

    def headline(self, p, pw):
        """``Power step … (a … kg payload drop or pick-up, or …)`` in one line."""
        dm = p["mass_step_kg"]
        dp = p.get("power_step_w", math.nan)
        n = int(p.get("flights_with_change", 0))
        where = f" at {p['change_time_min_s']:.0f} s" if n == 1 else ""
        size = f"{dp:+.0f} W " if math.isfinite(dp) else ""
        return (f"Power step {size}in flight{where}: a {abs(dm):.2f} kg payload "
                f"{'drop' if dm < 0 else 'pick-up'}, or anything else that "
                f"{'lowers' if dm < 0 else 'raises'} the power")


#: A change of flight mode this long before a located power step (or up to
#: :data:`MODE_AFTER_S` after it) is named beside it. [s]
MODE_BEFORE_S = 30.0
MODE_AFTER_S = 5.0


def _modes_at_steps(pw, times: dict) -> str | None:
    """The mode changes near every located step, in words; None unless every located step
    has one (:meth:`PayloadChange.regime_confound`)."""
    changes = getattr(pw, "mode_changes", {})
    found = []
    for name, tc in times.items():
        near = [(t, old, new) for t, old, new in changes.get(name, ())
                if tc - MODE_BEFORE_S <= t <= tc + MODE_AFTER_S]
        if not near:
            return None
        t, old, new = near[-1]
        found.append(f"{old} to {new} at {t:.0f} s, the step at {tc:.0f} s" if len(times) == 1
                     else f"flight {name}: {old} to {new} at {t:.0f} s")
    return "; ".join(found[:5]) + (" …" if len(found) > 5 else "")


def mode_changes_near(pw, p) -> list[str]:
    """The changes of flight mode (the record's ``mode`` channel) near each located change
    time of a payload step, in words."""
    out = []
    changes = getattr(pw, "mode_changes", {})
    for key, tc in p.items():
        if not key.startswith("change_time_s["):
            continue
        name = key[len("change_time_s["):-1]
        for t, old, new in changes.get(name, ()):
            if tc - MODE_BEFORE_S <= t <= tc + MODE_AFTER_S:
                where = "" if p.get("flights_with_change", 0) <= 1 else f" of flight {name}"
                out.append(f"the mode changed from {old} to {new} at {t:.0f} s{where}")
    return out


def _power_per_kg(pw, values) -> float:
    """The calibrated model's median rise of the battery power per kg of mass over the
    bins. [W/kg]"""
    if "efficiency" not in values:
        return float("nan")
    shape = {k: values[k] for k in pw.shape}
    rows = np.arange(pw.n_rows)
    dm = 0.05 * pw.mass0
    bumped = dict(pw.base_inputs)
    bumped["mass"] = pw.base_inputs["mass"] + dm
    m1 = pw.mechanical(shape, bumped, rows, table=False)
    m0 = pw.mechanical(shape, pw.base_inputs, rows, table=False)
    return float(np.median(m1 - m0) / dm / values["efficiency"])


def _power_step(pw, values, state) -> float:
    """The median power step of the located mass step over the bins after it: the change
    of the model's power with the mass, × the step. [W]"""
    mask = np.asarray(state.get("step_mask", np.zeros(pw.n_rows)), float) > 0
    if not mask.any() or "efficiency" not in values:
        return float("nan")
    rows = np.flatnonzero(mask)
    shape = {k: values[k] for k in pw.shape}
    dm = float(values["mass_step_kg"])
    bumped = dict(pw.base_inputs)
    bumped["mass"] = pw.base_inputs["mass"] + dm
    m1 = pw.mechanical(shape, bumped, rows, table=False)
    m0 = pw.mechanical(shape, pw.base_inputs, rows, table=False)
    return float(np.median(m1 - m0) / values["efficiency"])


#: Span before and after a change time over which its flight's mean climb rate says
#: whether it follows a climb or precedes a descent. [s]
REGIME_WINDOW_S = 30.0
#: Mean climb rate over :data:`REGIME_WINDOW_S` beyond which the span is a climb (or,
#: negative, a descent); within ±:data:`planner.chain.flightstate.CLIMB_THRESHOLD_MS` it
#: is level flight. [m/s]
REGIME_RATE_MS = 1.0


def _climb_around(pw, exp: int, tc: float) -> tuple[float, float] | None:
    """Mean climb rate of flight ``exp`` over :data:`REGIME_WINDOW_S` before and after
    ``tc`` (None where either span has no bin). [m/s]"""
    m = pw.exp == exp
    before = m & (pw.time < tc) & (pw.time >= tc - REGIME_WINDOW_S)
    after = m & (pw.time >= tc) & (pw.time < tc + REGIME_WINDOW_S)
    if not before.any() or not after.any():
        return None
    return float(np.mean(pw.climb[before])), float(np.mean(pw.climb[after]))


def _end_of_climb(pw, exp: int, tc: float) -> bool:
    """Whether a change at ``tc`` follows a climb (> :data:`REGIME_RATE_MS`) and precedes
    level flight."""
    around = _climb_around(pw, exp, tc)
    return around is not None and around[0] > REGIME_RATE_MS and \
        abs(around[1]) < CLIMB_THRESHOLD_MS


def _start_of_descent(pw, exp: int, tc: float) -> bool:
    """Whether a change at ``tc`` follows level flight and precedes a descent (below
    −:data:`REGIME_RATE_MS`): the approach to a landing, where a model's descent misfit
    makes a step (:func:`_end_of_climb`'s mirror)."""
    around = _climb_around(pw, exp, tc)
    return around is not None and abs(around[0]) < CLIMB_THRESHOLD_MS and \
        around[1] < -REGIME_RATE_MS


def _steady_load(pw, what: str) -> str | None:
    """Why an effect that needs the load to vary cannot be tested: the mechanical power
    varies by less than :data:`MIN_LOAD_VARIATION` (then ``what`` follows); None when it
    varies enough."""
    if pw.load_variation < MIN_LOAD_VARIATION:
        return f"the mechanical power varies by only {100 * pw.load_variation:.1f} %: {what}"
    return None


class SystemPower(PowerEffect):
    """``system_power``: the constant electrical load :math:`P_S` fitted instead of the
    aircraft file's (module notes); [W]."""
    key = "system_power_w"
    name = "system_power"
    needs = ()
    linear = ("system_power_w",)
    driver_label = "modelled battery power [W]"

    def skip_reason(self, pw) -> str | None:
        """A mechanical power too steady (:data:`MIN_LOAD_VARIATION`) to tell a constant load
        from the efficiency."""
        return _steady_load(pw, "a constant load cannot be told from the efficiency")

    def columns(self, M, pw, state):
        """A column of ones: the constant load. [W per W]"""
        return [np.ones_like(M)]

    def bin_driver(self, pw, state):
        """The modelled battery power of each bin. [W]"""
        return state.get("modelled_w", pw.measured)

    def parameters(self, values, stderr, pw, state):
        """The fitted load and the file's [W], with the standard error and what is missing."""
        ps = values["system_power_w"]
        return {"system_power_w": ps, "system_power_w_stderr": stderr["system_power_w"],
                "file_system_power_w": pw.file_system_power_w,
                "missing_w": ps - pw.file_system_power_w,
                "power_per_kg_w": _power_per_kg(pw, values)}

    def implausible(self, p, pw):
        """A negative load, one above :data:`MAX_SYSTEM_SHARE` of the lowest airborne power,
        or one above what the aircraft draws on the ground."""
        ps, se = p["system_power_w"], p["system_power_w_stderr"]
        if ps < 0:
            return f"a constant load of {ps:.1f} W is negative"
        air = float(np.percentile(pw.measured, 5))
        if ps > MAX_SYSTEM_SHARE * air:
            return (f"a constant load of {ps:.0f} W would be {100 * ps / air:.0f} % of the "
                    f"lowest airborne power ({air:.0f} W, 5th percentile): the rotors' own "
                    "power cannot be that small")
        ground = pw.ground_power_w
        if ground is not None:
            # a constant load is drawn at every moment, the rotors stopped or idle: every
            # ground sample bounds it, the low percentile the most tightly
            high = ground[0] + GROUND_BOUND_Z * (se if math.isfinite(se) else 0.0) \
                + GROUND_POWER_MARGIN_W
            if ps > high:
                return (f"a constant load of {ps:.0f} W where the aircraft draws "
                        f"{ground[0]:.0f}–{ground[1]:.0f} W on the ground (rotors stopped or "
                        "idle): what is missing is drawn only while the rotors turn, not a "
                        "constant load")
        return None

    def cause(self, p, pw):
        """A constant load, in words, against the file's. [W]"""
        miss = p["missing_w"]
        return (f"A constant electrical load of {_pm(p['system_power_w'], p['system_power_w_stderr'], 1)}"
                f" W (avionics, payload, heater) where the aircraft file has "
                f"{p['file_system_power_w']:.1f} W: {abs(miss):.1f} W "
                f"{'missing from' if miss > 0 else 'too much in'} the model")

    def headline(self, p, pw):
        """``Constant load …`` in one line."""
        return (f"Constant load {p['system_power_w']:.0f} W (file {p['file_system_power_w']:.0f} W)"
                " missing from the model")

    def alternatives(self, p, pw) -> list[str]:
        """What else the missing power could be: a payload not given (the mass that draws
        it, from the model's power per kg at the flown state) [kg]."""
        miss = p["missing_w"]
        per_kg = p.get("power_per_kg_w", math.nan)
        if not (math.isfinite(per_kg) and per_kg > 0) or miss <= 0:
            return []
        return [f"a payload of {miss / per_kg:.2f} kg not given (the model's power rises "
                f"{per_kg:.0f} W per kg of mass on these flights)"]


class EfficiencyCurve(PowerEffect):
    r"""``efficiency_curve``: :math:`1/\eta(M) = c_0 + c_1 (M/M_{ref} - 1)`, an efficiency
    that changes with the mechanical power :math:`M` [W] (module notes)."""
    key = "efficiency_slope"
    name = "efficiency_curve"
    needs = ()
    linear = ("efficiency_slope_coefficient",)
    driver_label = "modelled mechanical power [W]"

    def skip_reason(self, pw) -> str | None:
        """A ``rotor_losses`` aircraft, whose no-load and copper losses are how its
        efficiency changes with load (its file refuses ``efficiency_slope``: a curve on
        top could not be written into the calibrated aircraft; a wrong one is a misfit of
        those losses, which ``fit-aircraft`` refits), or a mechanical power too steady
        (:data:`MIN_LOAD_VARIATION`) to tell a curve from a constant efficiency."""
        if pw.aircraft is not None and pw.aircraft.has_rotor_losses:
            return ("the rotor_losses power model's no-load and copper losses are how its "
                    "efficiency changes with load: refit them with fit-aircraft instead")
        return _steady_load(pw, "an efficiency curve cannot be told from a constant "
                                "efficiency")

    def columns(self, M, pw, state):
        """The column :math:`M (M/M_{ref} - 1)` of the slope. [W]"""
        ref = state["reference_mechanical_w"]
        return [M * (M / ref - 1.0)]

    def practical(self, fits, pw) -> str | None:
        """An efficiency that rises with load is a constant load (``system_power``), not a
        curve."""
        # 1/η = c0 + c1 (M/M_ref − 1): c1 < 0 is an efficiency that rises with load, which
        # is what a constant loss looks like (that is the system_power effect)
        c1 = float(np.median([f.values()["efficiency_slope_coefficient"] for f in fits]))
        if c1 < 0:
            return ("the efficiency rises with load, which is what a constant electrical load "
                    "looks like: see system_power")
        return None

    def bin_driver(self, pw, state):
        """The modelled mechanical power of each bin. [W]"""
        return state.get("mechanical_w", pw.measured)

    def parameters(self, values, stderr, pw, state):
        """η at the reference and its slope, with standard errors, and η at the low and high
        end of the flown mechanical power [W]."""
        # values carry eta0/eta1 already converted by the search (delta method)
        p_lo, p_hi = state.get("mechanical_range_w", (np.nan, np.nan))
        ref = state["reference_mechanical_w"]
        e0, e1 = values["efficiency_at_reference"], values["efficiency_slope"]
        def eta(m):
            return 1.0 / (1.0 / e0 - e1 / e0**2 * (m / ref - 1.0))
        return {"efficiency_at_reference": e0,
                "efficiency_at_reference_stderr": stderr["efficiency_at_reference"],
                "efficiency_slope": e1, "efficiency_slope_stderr": stderr["efficiency_slope"],
                "reference_mechanical_power_w": ref,
                "mechanical_power_low_w": p_lo, "mechanical_power_high_w": p_hi,
                "efficiency_at_low": eta(p_lo), "efficiency_at_high": eta(p_hi)}

    def implausible(self, p, pw):
        """An efficiency outside (0, 1] anywhere over the flown range."""
        for k in ("efficiency_at_low", "efficiency_at_reference", "efficiency_at_high"):
            e = p[k]
            if not (math.isfinite(e) and 0.0 < e <= 1.0):
                return (f"the efficiency curve reaches {e:.2f} over the flown range, outside "
                        "(0, 1]")
        return None

    def cause(self, p, pw):
        """An efficiency that changes with load, in words, with η [%] at three powers [W]."""
        word = "falls" if p["efficiency_slope"] < 0 else "rises"
        return (f"Propulsion efficiency {word} with load instead of being constant: "
                f"{100 * p['efficiency_at_low']:.0f} % at {p['mechanical_power_low_w']:.0f} W, "
                f"{100 * p['efficiency_at_reference']:.0f} % at "
                f"{p['reference_mechanical_power_w']:.0f} W and "
                f"{100 * p['efficiency_at_high']:.0f} % at {p['mechanical_power_high_w']:.0f} W "
                f"of mechanical power (slope {_pm(p['efficiency_slope'], p['efficiency_slope_stderr'], 3)}"
                " per unit of P/P_ref)")

    def headline(self, p, pw):
        """``Efficiency falls …`` or ``rises with load`` in one line."""
        word = "falls" if p["efficiency_slope"] < 0 else "rises"
        return (f"Efficiency {word} with load: {100 * p['efficiency_at_low']:.0f} % → "
                f"{100 * p['efficiency_at_high']:.0f} % from {p['mechanical_power_low_w']:.0f} to "
                f"{p['mechanical_power_high_w']:.0f} W")


CAPACITY_EFFECTS = (Temperature, CapacityFade, CurrentOffset)
POWER_EFFECTS = (Wind, AirDensity, PayloadChange, SystemPower, EfficiencyCurve)
#: The vocabulary, in the order docs/commands.md (Diagnose) lists it.
EFFECTS = {cls.name: cls for cls in (Temperature, CapacityFade, CurrentOffset, Wind, AirDensity,
                                     PayloadChange, SystemPower, EfficiencyCurve)}


def make_effects(names=None) -> list[Effect]:
    """Fresh effect objects for ``names`` (default: the whole vocabulary)."""
    from planner.errors import InputError

    names = list(EFFECTS) if names is None else list(names)
    unknown = [n for n in names if n not in EFFECTS]
    if unknown:
        raise InputError(f"unknown effect(s) {', '.join(unknown)}; expected some of "
                         f"{', '.join(EFFECTS)}")
    return [EFFECTS[n]() for n in names]

