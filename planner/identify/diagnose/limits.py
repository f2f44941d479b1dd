r"""Detection limits of ``diagnose``: the smallest size of each effect the data could reveal.

For every effect of the vocabulary asked for, on every level where it can be tested, a
power analysis (:func:`planner.identify.stats.detectable_size`) gives the size that the
search's tests (:mod:`planner.identify.diagnose.search`) find with 80 % power. An effect
that was not found is then said to be smaller than that ("a payload change smaller than
0.18 kg cannot be seen in these 16 flights"); an effect that cannot be tested at all (a
channel missing, a level that cannot run, a record that does not vary the effect's
driver) is *not identifiable with these data*, with what would make it identifiable.

What enters (per level, on the calibrated baseline fitted on all the data)
---------------------------------------------------------------------------
* The effect's **signature**: the change of the fitted quantity per unit of the
  effect's parameter at no effect (the levels' ``signature`` methods): per bin of power
  [W], per window increment of charge, per discharge's ln energy to the cut-off.
* What it must be told apart from (**nuisance**): the baseline's own parameters (the
  levels' ``jacobian``) and the signatures of the other effects that can be tested on
  the same level — the candidates the search weighs it against. A constant load and an
  efficiency curve on flights whose power barely varies, or a payload dropped at the
  turnaround of an out-and-back route and a steady wind, leave little of their
  signature visible: their limit is large, and the output says the data cannot tell
  them.
* The **noise**: the residual of the final fit (the effects found included), its
  long-run variance (AR(1), within experiments) raised by the scatter between flights
  where there are four or more (:func:`planner.identify.stats.design_effect`: flights on
  different routes and days scatter about their calibrated model by a level of their
  own, which no within-flight noise model sees and which is the noise of an effect
  carried by whole flights, such as the air density of a day), for the χ² test at 5 %
  with 80 % power,
  and the held-out mean squared error for the practical gain of
  :data:`planner.identify.diagnose.search.MIN_GAIN_PCT`.
* The effect's own **floor** where the search has one (a payload change of at least
  :data:`planner.identify.diagnose.effects.MIN_MASS_STEP` of the all-up mass).

The limit is the size that the search's own decision rule names with
:data:`POWER` (80 %) probability, so every gate of the rule enters, not only the
simplest test:

* the training likelihood-ratio test and the paired test, with the long-run variance of
  the autocorrelated residuals (the effective sample size of the search's
  :math:`n(1-\rho)/(1+\rho)`);
* the paired sign-flip test on the held-out **units** (:func:`unit_paired_size`): it
  refers the units' gains to their own spread, so a signature concentrated in a few
  units is harder to confirm than its noise alone says;
* the held-out gain of :data:`planner.identify.diagnose.search.MIN_GAIN_PCT`;
* the **gates that withhold** a fitted effect whatever its size: a wind whose change of
  the airspeed is one step per flight on this route, from most directions
  (:func:`_wind_gate`: the limit is then given at the power that leaves 80 % overall
  for a wind of unknown direction, or is infinite when no size reaches it), and a
  payload change at a position where its step follows the flight regime or — where a
  wind would change what the model sees — the course
  (:meth:`planner.identify.diagnose.effects.PayloadChange.step_gate`: infinite there).

A payload change needs more: it is located flight by flight, where its step must beat
a threshold of 2 ln n long-run variances (module notes of ``search``), so its limit is
the larger of the pooled one (net of each flight's own constant mass, the climb and
descent regimes and the other candidates) and the size at which the median flight
locates it with 80 % power. The search locates a change net of the climbs' and
descents' power levels pooled over the flights; the flight's own location is here taken
net of them within the flight (a change inside a climb or a descent is told from the
regime's level only by the bins of the regime on its other side), and its noise is the
long-run variance robust to a step (:func:`planner.identify.stats.step_robust_long_run_variance`),
so that a change present but not fitted does not raise its own limit. Both depend on
where in the flights it happens, and the limit is given by position (``by_position``:
fraction of each flight's airborne span).
The limit falls as 1/√(number of flights) for the pooled tests.

Not settled
-----------
"None found: a payload change smaller than 0.18 kg cannot be seen" is a power statement:
a change of the limit's size would be named four times in five. Where the search's own
candidate says more, the data are asked the question an equivalence test asks
(Schuirmann, *J. Pharmacokinet. Biopharm.* 15, 657, 1987; "absence of evidence is not
evidence of absence", Altman & Bland, *BMJ* 311, 485, 1995): can they exclude a change
as large as the limit? The payload candidate fitted on the training folds and not
confirmed on the held-out flights (:func:`unsettled`) is taken where its training test
passed (p below the search's :data:`~planner.identify.diagnose.search.ALPHA_TRAIN`),
with the step its folds read on the flights whose change is located, as a named step is
read (:class:`~planner.identify.diagnose.effects.StepEstimate`; the fitted step, which
flights without a located change pull small, where the read cannot be made), where its
flights locate it, and the step's standard error there (the power analysis's own, by
position, as for the limit). Where the one-sided bound
:math:`|\hat\delta| + z_{0.95}\,SE` reaches the limit at those positions, they cannot:
the entry says *not settled* (``identifiable`` false, the candidate in ``unsettled``),
with the step seen, where, the tests it passed and failed, and what would settle it. A
held-out flight that places the change at a step of its own loses the held-out tests for
a change the training flights see plainly (module notes of ``search``, "Change
points"); this says so instead of a silent miss. Measured on the
DJI M100 flights of routes other than R1 (Rodrigues et al. 2021; ``docs/results.md``,
"Not settled"): on 100 runs of four cells near their limits, the runs the limit calls
identifiable were named first in 47 of 62 (76 %); 13 of those missed are now not
settled, and the rest are named first in 47 of 49 (96 %). On 100 clean draws (route R1
and the others, plain record and every channel) 7 say not settled; none names a change.

A second change in a flight
---------------------------
The search locates one change a flight (module notes of ``search``): in a flight where
a change is located, a second one (a pick-up and a later drop, or a step of the record's
own beside a payload's) is seen only where it explains more than the located one, and
then in its place. Where a payload change is found, its entry says so
(``second_change``: the located step's size as the limit below which a second change in
those flights is not identifiable).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import numpy as np

from planner.identify import stats
from planner.physics.units import AS_PER_MAH

__all__ = ["HELP", "POSITIONS", "beyond_physics", "entry", "in_unit", "largest_physical",
           "level_limits", "not_identifiable", "unsettled"]

#: A detection limit more than this many times the largest physical size is said in words,
#: not as a figure. [unitless]
BEYOND_WORDS = 1000.0
#: Fractions of each flight's airborne span at which a payload change's limit is given.
POSITIONS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9)

#: What would make each effect identifiable, in words.
HELP = {
    "payload_change": "more flights (the limit falls as 1/√ of their number), a change away "
                      "from the start, the end and the turnaround of the flights, and the "
                      "climb rate and ground speed logged",
    "wind": "flights in more directions (a course that turns), the course over ground "
            "logged, and no airspeed sensor standing in for it",
    "air_density": "the static pressure and the air temperature logged, on flights at "
                   "different densities (days, sites)",
    "system_power": "flights over a wider range of power (climbs, fast and slow legs), or "
                    "the load measured with the rotors stopped on the ground",
    "efficiency_curve": "flights over a wider range of power (climbs, fast and slow legs)",
    "current_offset": "the power logged independently of the current (a power module; rests "
                      "with the load off then show the drift alone), or the sensor's zero read "
                      "with the load off and the avionics unplugged (where the power is the "
                      "logged V·I, a rest reads the avionics' draw plus the offset, and the "
                      "model drawn by that power draws the offset too)",
    "temperature": "the pack temperature logged, flights or discharges at different "
                   "temperatures, current steps (the voltage sag then measures the "
                   "resistance) and discharges to the cut-off",
    "capacity_fade": "the cycle count logged, and discharges from full to the cut-off at "
                     "several ages of the pack",
}

#: What each effect is called in the sentences.
NOUN = {"payload_change": "a payload change", "wind": "a steady wind",
        "air_density": "a dependence of the power on the measured air density",
        "system_power": "a constant load", "efficiency_curve": "an efficiency that changes "
        "with load", "current_offset": "a current-sensor offset",
        "temperature": "a cold-pack effect", "capacity_fade": "capacity fade"}

#: The parameter each level's limit is given in: (key, unit, scale to the unit, digits).
PARAMETER = {
    ("power", "payload_change"): ("mass_step_kg", "kg", 1.0, 2),
    ("power", "wind"): ("wind_speed_ms", "m/s", 1.0, 1),
    ("power", "air_density"): ("density_exponent", "(exponent; momentum theory: 1)", 1.0, 2),
    ("power", "system_power"): ("system_power_w", "W", 1.0, 0),
    ("power", "efficiency_curve"): ("efficiency_slope", "(η per relative change of the "
                                    "mechanical power)", 1.0, 3),
    ("capacity", "temperature"): ("temperature_coefficient_per_c", "%/°C", 100.0, 3),
    ("capacity", "capacity_fade"): ("fade_per_cycle", "%/cycle", 100.0, 4),
    ("capacity", "current_offset"): ("current_offset_a", "A", 1.0, 3),
    ("cutoff", "temperature"): ("temperature_coefficient_per_c", "%/°C", 100.0, 3),
    ("cutoff", "capacity_fade"): ("fade_per_cycle", "%/cycle", 100.0, 4),
    ("sensors", "current_offset"): ("current_offset_a", "A", 1.0, 3),
    ("resistance", "temperature"): ("activation_energy_j_per_mol", "kJ/mol", 1e-3, 1),
}


def in_unit(level: str, effect: str, x: float) -> str:
    """``x``, in the unit of :data:`PARAMETER`'s parameter of ``effect`` at ``level``."""
    _, unit, scale, digits = PARAMETER[(level, effect)]
    return f"{scale * x:.{digits}f} {unit}" if math.isfinite(x) else "∞"


def _things(level_name: str, n: int) -> str:
    if level_name == "power":
        return "this flight" if n == 1 else f"these {n} flights"
    if level_name == "cutoff":
        return f"these {n} discharges to the cut-off"
    return "this experiment" if n == 1 else f"these {n} experiments"


def entry(effect: str, level: str, *, found: bool, identifiable: bool,
          limit: float | None = None, why: str = "", n: int = 0, by_position=None,
          stderr: float | None = None, per: str | None = None,
          confused_with: list[str] | None = None,
          design_effect: float = 1.0, help_text: str | None = None,
          unsettled: dict | None = None) -> dict[str, Any]:
    """One detection entry (fields: docs/commands.md, Diagnose): ``effect``, ``level``,
    ``parameter``, ``unit``, ``found``, ``identifiable``, ``limit`` (in the parameter's
    unit; None when not identifiable), ``by_position``, ``why``, ``help`` (``help_text``,
    default the effect's :data:`HELP`) and ``text``."""
    key, unit, scale, _ = PARAMETER.get((level, effect), (None, "", 1.0, 3))
    noun = NOUN[effect]
    remedy = help_text or HELP[effect]
    if found and confused_with:
        text = (f"{noun[0].upper() + noun[1:]}: found at the {level} level, but these data "
                f"cannot tell it from {' or '.join(confused_with)}: against them none "
                f"smaller than {in_unit(level, effect, limit)} could be seen; read the finding "
                f"as either. Telling them apart needs {remedy}")
        identifiable = True
    elif not identifiable and found:
        text = (f"{noun[0].upper() + noun[1:]}: found at the {level} level, but one of "
                f"another size or direction would not be identifiable with these data: "
                f"{why}. It would be with {remedy}")
    elif not identifiable and unsettled is not None:
        text = (f"{noun[0].upper() + noun[1:]}: not settled: {why}. It would be settled "
                f"with {remedy}")
    elif not identifiable:
        text = f"{noun[0].upper() + noun[1:]}: not identifiable with these data: {why}. " \
               f"It would be with {remedy}"
    elif found:
        text = (f"{noun[0].upper() + noun[1:]}: found at the {level} level (these data show "
                f"one down to {in_unit(level, effect, limit)})")
    else:
        where = ""
        if by_position:
            lo = min(by_position.values())
            edge = max(by_position[0.1], by_position[0.9])
            where = (f" where it falls best in the flights ({in_unit(level, effect, edge)} "
                     "in their first or last tenth)") if math.isfinite(edge) and edge > lo \
                else ""
        text = (f"None found: {noun} smaller than {in_unit(level, effect, limit)}{where} cannot "
                f"be seen in {_things(level, n)} (below it, it is not identifiable with these "
                f"data). A smaller one needs {remedy}")
    if per == "experiment order":
        unit = "%/experiment"
        text = text.replace("%/cycle", "%/experiment")
    out = {"effect": effect, "level": level, "parameter": key, "unit": unit.strip("()"),
           "scale_to_unit": scale, "found": bool(found), "identifiable": bool(identifiable),
           "limit": (float(limit) if identifiable and limit is not None
                     and math.isfinite(limit) else None),
           "why": why, "help": remedy, "text": text}
    if stderr is not None:
        out["stderr"] = float(stderr)
    if by_position:
        out["by_position"] = {f"{k:g}": (float(v) if math.isfinite(v) else None)
                              for k, v in by_position.items()}
    if per is not None:
        out["per"] = per
    if confused_with:
        out["confused_with"] = list(confused_with)
    if design_effect > 1.0:
        out["design_effect"] = float(design_effect)
    if unsettled is not None:
        out["unsettled"] = dict(unsettled)
    return out


def largest_physical(effect: str, level) -> float:
    """The largest size of an effect that is still physical on this level's data (the
    bounds of :mod:`planner.identify.diagnose.effects`): a limit beyond it means no
    physical size of the effect can be seen. [unit of the parameter]"""
    from planner.identify.diagnose import effects as E
    from planner.physics import limits as L

    name = getattr(level, "name", "")
    if effect == "payload_change":
        return E.MAX_DROP_SHARE * level.mass0
    if effect == "wind":
        return E.MAX_WIND_SHARE * level.aircraft.max_airspeed_ms
    if effect == "air_density":
        return E.DENSITY_EXPONENT_RANGE[1]
    if effect == "system_power":
        return E.MAX_SYSTEM_SHARE * float(np.percentile(level.measured, 5))
    if effect == "efficiency_curve":
        return L.EFFICIENCY_SLOPE_MAX
    if effect == "temperature":
        return E.MAX_TEMPERATURE_COEFF
    if effect == "capacity_fade":
        span = float(np.ptp(level.cycles)) if name in ("capacity", "cutoff") else 0.0
        return E.MAX_FADE_SPAN / span if span > 0 else math.inf
    if effect == "current_offset":
        return E.MAX_OFFSET_SHARE * getattr(level, "median_current_a", math.inf)
    return math.inf


def beyond_physics(effect: str, level_name: str, limit: float, top: float) -> str:
    """Why an effect is not identifiable at any physical size: the largest physical one,
    ``top``, is below the detection limit ``limit`` (both in the effect's unit at
    ``level_name``), in words."""
    if not limit <= BEYOND_WORDS * top:
        # a limit many orders above any physical size is not a figure worth printing
        return (f"even the largest physical one ({in_unit(level_name, effect, top)}) is more "
                f"than {BEYOND_WORDS:g} times below the smallest these data could reveal: its "
                "signature is all but absorbed by the calibration and the other candidates")
    return (f"even the largest physical one ({in_unit(level_name, effect, top)}) is below the "
            f"smallest these data could reveal ({in_unit(level_name, effect, limit)})")


def not_identifiable(effect: str, level: str, why: str) -> dict[str, Any]:
    """The entry of an effect that cannot be tested at ``level``: ``why``."""
    return entry(effect, level, found=False, identifiable=False, why=why)


# ============================================================================ per level

def level_limits(report, effects, found: set[str]) -> list[dict[str, Any]]:
    """The detection entries of one level that ran (a :class:`LevelReport`): every effect
    of ``effects`` (those asked for at this level) — skipped ones as not identifiable."""
    res = report.result
    level = res.level
    skipped = dict(res.skipped)
    tested = [e for e in effects if e.name not in skipped and e.name not in res.failed]
    out = []
    for e in effects:
        if e.name in skipped:
            out.append(not_identifiable(e.name, report.name, skipped[e.name]))
        elif e.name in res.failed:
            out.append(not_identifiable(e.name, report.name,
                                        f"the fit failed ({res.failed[e.name]})"))
    if not tested:
        return out
    base = res.base_fit
    final = res.final_fit or base
    try:
        J = level.jacobian(base, [])
        sigs = {e.name: np.asarray(level.signature(base, [], e), float) for e in tested}
    except Exception:       # a level whose model cannot be linearised here: say so
        return out + [not_identifiable(e.name, report.name, "its signature could not be "
                                       "computed on these data") for e in tested]
    resid = np.asarray(final.train_resid, float)
    groups = level.row_group
    clusters = getattr(level, "exp", None)      # flights (a cut-off level has none)
    ho = np.asarray(res.final.heldout_row_resid, float)
    mse_rows = float(np.mean(ho**2)) if ho.size else None
    withheld = {w["effect"]: w for w in res.withheld}
    for e in tested:
        others = [sigs[o.name] for o in tested if o.name != e.name
                  and o.name != "payload_change"]
        if e.name == "payload_change":
            out.append(_payload(report, level, base, J, sigs, tested, resid, mse_rows,
                                e.name in found))
            continue
        if e.name == "wind" and "payload_change" in sigs:
            others.append(_steps(level, sigs["payload_change"][:, 0], 0.5)[:, None])
        if e.name == "wind" and level.aircraft.is_multirotor:
            # the hover's own power level, as the wind's error counts it (module notes)
            others.append(_hover_level(level))
        nuisance = np.column_stack([J] + others) if others else J
        sig = sigs[e.name]
        if report.name == "capacity":
            lim = _capacity_limit(level, res, base, e, [o for o in tested if o is not e],
                                  sig, nuisance, resid, groups)
        else:
            lim = stats.detectable_size(sig, nuisance, resid, groups, dof=J.shape[1],
                                        heldout_mse=mse_rows, paired=True,
                                        clusters=clusters)
            lim = _with_units(lim, sig, nuisance, level, resid, J.shape[1])
        gate_why = ""
        if e.name == "wind" and math.isfinite(lim.limit):
            lim, gate_why = _wind_gate(level, sig, nuisance, resid, groups, clusters,
                                       J.shape[1], mse_rows, lim)
        if e.name == "wind" and math.isfinite(lim.limit):
            lim, gate_why = _speed_scaled(level, res, base, lim)
        limit = lim.limit
        if e.name == "efficiency_curve":         # c1 → the slope η1 = −c1/c0²
            c0 = float(base.coef[0])
            limit = limit / c0**2
        why = ""
        ident = math.isfinite(limit)
        top = largest_physical(e.name, level)
        confused = None
        if not ident:
            why = gate_why or ("its signature is absorbed entirely by the calibration and "
                               "the other candidates")
        elif limit > top:
            ident, why = False, beyond_physics(e.name, report.name, limit, top)
        if e.name in found and not (ident and limit <= top) and not gate_why:
            confused = _confused_with(e, tested, sigs, J, resid, groups, top, clusters)
        remedy = None
        if e.name in withheld and e.name not in found:
            w = withheld[e.name]
            ident = False
            why = f"the fit that explains the misfit is withheld: {w['why']}"
            remedy = w.get("help")
        per = getattr(level, "cycle_source", None) if e.name == "capacity_fade" else None
        out.append(entry(e.name, report.name, found=e.name in found, identifiable=ident,
                         limit=limit, why=why, n=level.n_experiments, stderr=lim.stderr,
                         per=per, confused_with=confused, design_effect=lim.design_effect,
                         help_text=remedy))
    return out


#: Power at which a limit is given: the size named in this share of the runs. [unitless]
POWER = 0.8
def unit_paired_size(signature, nuisance, units, s2: float, alpha: float = 0.05,
                     power: float = POWER) -> float:
    r"""The size at which the search's paired sign-flip test on held-out *units* rejects
    with probability ``power`` (:func:`planner.identify.diagnose.search.sign_flip_test`).
    [unit of the parameter]

    An effect of size θ lowers unit u's held-out loss by :math:`d_u = \theta^2 a_u +
    \varepsilon_u`, with :math:`a_u` the unit's share of the visible signature
    :math:`\lVert s_{\perp,u}\rVert^2` (least visible direction) and
    :math:`\operatorname{var}\varepsilon_u = 4\theta^2\sigma^2_{LR} a_u` (σ²_LR the
    residual's long-run variance, ``s2``: autocorrelated residuals within a unit). The
    sign-flip test refers :math:`\sum d_u` to its randomisation distribution, of variance
    :math:`\sum d_u^2` — not to the noise alone: a signature concentrated in few units
    makes the test weak whatever its size, for :math:`\sum d_u / \sqrt{\sum d_u^2}` is at
    most the square root of the effective number of units
    :math:`(\sum a_u)^2/\sum a_u^2`. With A = Σ a_u, Q = Σ a_u², the normal
    approximation of the randomisation test (Fisher 1935; Lehmann & Romano, *Testing
    Statistical Hypotheses*, 3rd ed., 2005, §15.2: the sign-flip statistic is
    asymptotically normal with the variance above) rejects with the given power when
    :math:`\theta A - z_{1-\alpha}\sqrt{\theta^2 Q + 4\sigma^2 A} \ge
    2 z_{power}\,\sigma\sqrt{A}`, a quadratic in θ; for Q → 0 it is the
    :math:`2(z_{1-\alpha}+z_{power})\,SE` of :func:`planner.identify.stats.detectable_size`.
    Infinite where the units are too few to reject at any size.
    """
    from scipy.stats import norm

    s = np.asarray(signature, float).reshape(len(units), -1)
    sp = stats.project_out(s, nuisance)
    if sp.shape[1] > 1:
        w, v = np.linalg.eigh(sp.T @ sp)
        sp = sp @ v[:, :1]
    a = np.bincount(np.asarray(units, int), weights=sp[:, 0] ** 2)
    A, Q = float(a.sum()), float(np.dot(a, a))
    za, zb = float(norm.ppf(1.0 - alpha)), float(norm.ppf(power))
    den = A * A - za * za * Q
    if not (A > 0 and s2 > 0 and den > 0):
        return math.inf
    c = 2.0 * zb * math.sqrt(s2 * A)
    disc = (A * c) ** 2 - den * (c * c - 4.0 * za * za * s2 * A)
    return (A * c + math.sqrt(max(disc, 0.0))) / den


def _with_units(lim, sig, nuisance, level, resid, dof, power: float = POWER):
    """``lim`` with its statistical limit raised to the paired test on the held-out units
    where that is the stricter (:func:`unit_paired_size`)."""
    from planner.identify.diagnose.search import ALPHA_HELDOUT

    units = getattr(level, "row_unit", None)
    if units is None or not math.isfinite(lim.limit):
        return lim
    s2 = stats.long_run_variance(resid, level.row_group, dof) * lim.design_effect
    paired = unit_paired_size(sig, nuisance, units, s2, ALPHA_HELDOUT, power)
    stat = max(lim.statistical, paired)
    return stats.DetectionLimit(max(stat, lim.practical), stat, lim.practical, lim.stderr,
                                lim.visible_share, lim.design_effect)


def _wind_gate(level, sig, nuisance, resid, groups, clusters, dof, mse, lim):
    r"""The wind's limit through the route's own gate, and why it is infinite if it is.

    The search withholds a fitted wind whose change of the airspeed within each flight is
    one step (:meth:`planner.identify.diagnose.effects.Wind.regime_confound`: at least
    :data:`planner.identify.diagnose.CONFOUND_R`² of its variation), for a mass change at
    that point fits it as well. Whether a wind is withheld depends on where it blows
    from against the route: on a closed route flown in one order (the M100's triangle,
    an out-and-back) the winds along its main axis are. A wind of unknown direction
    (uniform) is named with probability :math:`q\,P(\theta)`, q the share of the
    :data:`planner.identify.diagnose.effects.ROUTE_DIRECTIONS` directions whose wind of the limit's size passes the gate and P
    the tests' power; so the limit is the size of power :data:`POWER`/q, and there is
    none when q < :data:`POWER` (named in fewer than that share at any size; the search
    then withholds a fitted wind from any direction,
    :meth:`planner.identify.diagnose.effects.Wind.regime_confound`)."""
    from planner.identify.diagnose import CONFOUND_R
    from planner.identify.diagnose.effects import Wind

    q, words = Wind.one_step_route(level, lim.limit)
    if q >= 1.0:
        return lim, ""
    if words:
        why = (f"{words} (at least "
               f"{100 * CONFOUND_R**2:.0f} % of its variation), which a mass change at that "
               f"point fits as well, so at no size would a wind of unknown direction be "
               f"named in {100 * POWER:.0f} % of cases")
        return _none(lim), why
    p = POWER / q
    out = stats.detectable_size(sig, nuisance, resid, groups, dof=dof, heldout_mse=mse,
                                paired=True, power=p, clusters=clusters)
    return _with_units(out, sig, nuisance, level, resid, dof, power=p), ""


def _speed_scaled(level, res, base, lim):
    r"""The wind's limit on the flights' own change of power with airspeed, and why it is
    infinite if it is.

    A wind is read through the model's change of power with airspeed: a model whose
    power changes twice as much as the aircraft's names a wind of half its speed, and
    sees one of half the size it could. The scale :math:`k` on that change which the
    flights choose (:meth:`planner.identify.diagnose.search.PowerLevel.speed_read`) is
    read on the level's final fit with a steady wind in it (the one found, else one
    fitted here beside the effects found): without it the airspeed is the ground speed,
    whose spread a real wind blurs, and the scale comes out too small. Where it differs
    from the model's (:func:`planner.identify.diagnose.effects.speed_scale`) the limit is
    the model's divided by :math:`k` (the wind's power pattern is :math:`k` times the
    model's, to first order), and there is none where :math:`k` is not clearly above 0."""
    from planner.identify.diagnose.effects import speed_scale

    read = speed_response_of(level, res, base)
    if read is None:
        return lim, ""
    k, se, _ = read
    scale = speed_scale(k, se)
    if scale == 1.0:
        return lim, ""
    if math.isnan(scale):
        why = (f"these flights' power changes with airspeed {k:.2f} ± {se:.2f} times as much as "
               "the calibrated model's, not clearly at all: a wind cannot be read from the "
               "power's change with the direction of travel")
        return _none(lim), why
    return dataclasses.replace(lim, limit=lim.limit / k, statistical=lim.statistical / k,
                               practical=lim.practical / k, stderr=lim.stderr / k), ""


def _none(lim):
    """``lim`` with no size at which the effect is named (a gate that withholds it at any
    size)."""
    return dataclasses.replace(lim, limit=math.inf, statistical=math.inf)


def speed_response_of(level, res, base=None) -> tuple[float, float, bool] | None:
    """The flights' scale on the model's change of power with airspeed, its standard
    error (:meth:`planner.identify.diagnose.search.PowerLevel.speed_read`) and whether a
    steady wind was in the fit it was read on (:func:`_with_wind`), once per level result
    (kept in its ``speed_response``); None where it cannot be read."""
    if res.speed_response is False:
        fit, effects = _with_wind(level, res, base or res.base_fit)
        read = level.speed_read(fit, effects) if fit is not None else None
        res.speed_response = None if read is None else (
            read[0], read[1], any(e.name == "wind" for e in effects))
    return res.speed_response


def _with_wind(level, res, base):
    """The level's final fit with its effects where a wind is among them; else, where the
    record can show a wind (:meth:`planner.identify.diagnose.effects.Wind.data_reason`:
    a course, no measured airspeed), a steady wind fitted on every bin beside the effects
    found (started from the final fit, or ``base``); else the final fit as it is. (None,
    []) where a fit fails."""
    from planner.errors import PlannerError
    from planner.identify.diagnose.effects import Wind

    chosen = [e for e, _ in res.selected]
    final = res.final_fit or base
    if any(e.name == "wind" for e in chosen) or Wind().data_reason(level) is not None:
        return final, chosen
    effects = chosen + [Wind()]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return level.fit(effects, np.ones(level.n_rows, bool), start=final), effects
    except (PlannerError, np.linalg.LinAlgError, ValueError):
        return None, []         # a fit that fails here leaves the model's limit


def _confused_with(effect, tested, sigs, J, resid, groups, top, clusters) -> list[str]:
    """The other candidates that, each alone beside the calibration, take a found
    effect's limit beyond its physical range (those the data cannot tell it from)."""
    out = []
    for o in tested:
        if o.name in (effect.name, "payload_change"):
            continue
        lim = stats.detectable_size(sigs[effect.name], np.column_stack([J, sigs[o.name]]),
                                    resid, groups, dof=J.shape[1], clusters=clusters).limit
        if not lim <= top:
            out.append(o.name)
    return out or ["the other candidates together"]


def _capacity_limit(level, res, base, effect, others, sig, nuisance, resid, groups):
    """The statistical limit on the window increments and the practical one on the
    held-out cumulative charge (what the search scores)."""
    stat = stats.detectable_size(sig, nuisance, resid, groups, dof=nuisance.shape[1],
                                 paired=True)
    J_cum, S_cum = level.cumulative_columns(base, [], [effect] + others)
    visible = stats.project_out(S_cum[:, :1], np.column_stack([J_cum, S_cum[:, 1:]]))
    mse = (float(res.final.rmse) * AS_PER_MAH) ** 2
    prac = stats.practical_size(float(np.mean(visible**2)), mse)
    return stats.DetectionLimit(max(stat.statistical, prac), stat.statistical, prac,
                                stat.stderr, stat.visible_share)


def _steps(level, s: np.ndarray, u: float) -> np.ndarray:
    """The mass step's signature at fraction ``u`` of each flight's span: ``s`` (power per
    kg all flight long) after the change, 0 before. [W per kg]"""
    out = np.zeros_like(s)
    for f in np.unique(level.exp):
        m = level.exp == f
        t = level.time[m]
        tc = t.min() + u * (t.max() - t.min())
        out[m] = np.where(t >= tc, s[m], 0.0)
    return out


def _hover_level(level) -> np.ndarray:
    """The indicator column of a multirotor's hover bins
    (:meth:`planner.identify.diagnose.search.PowerLevel.hovering`) where, as for the wind's
    error (:meth:`~planner.identify.diagnose.search.PowerLevel.hover_shift`), they can
    have a power level of their own (``has_own_level``); else an empty column set."""
    still = level.hovering()
    if not level.has_own_level(still):
        return np.zeros((level.n_rows, 0))
    return still.astype(float)[:, None]


def _payload(report, level, base, J, sigs, tested, resid, mse_rows, found) -> dict:
    """The payload change's limit by position (module notes)."""
    from planner.chain.flightstate import climb_regimes
    from planner.identify.diagnose.effects import MIN_MASS_STEP, PayloadChange

    s = sigs["payload_change"][:, 0]
    exp = level.exp
    flights = np.unique(exp)
    per_flight = np.column_stack([np.where(exp == f, s, 0.0) for f in flights] +
                                 [(exp == f).astype(float) for f in flights])
    regime = np.column_stack([r.astype(float) for r in climb_regimes(level.climb).values()])
    others = [sigs[o.name] for o in tested if o.name != "payload_change"]
    nuisance = np.column_stack([J, per_flight, regime] + others)
    within = stats.within_groups(resid, exp)
    floor = MIN_MASS_STEP * level.mass0
    # per flight: the long-run variance (robust to a step not yet fitted, as the search's)
    # and the noncentrality at which its change point beats the 2 ln n threshold of the
    # search with 80 % power; the search locates net of the climbs' and descents' levels,
    # which a flight's step is here taken net of within the flight (module notes)
    s2 = {f: stats.step_robust_long_run_variance(within[exp == f]) for f in flights}
    lam = {f: stats.noncentrality_for_power(1, critical=2.0 * math.log(max((exp == f).sum(), 3)))
           for f in flights}
    by, se_by = {}, {}
    se_mid, deff_mid = math.nan, 1.0
    dof = J.shape[1] + len(flights)
    ones = np.ones_like(s)
    for u in POSITIONS:
        g = _steps(level, s, u)
        if PayloadChange.step_gate(level, _steps(level, ones, u), list(flights)) is not None:
            # withheld by the search's own gates whatever its size
            by[u] = se_by[u] = math.inf
            continue
        pooled = stats.detectable_size(g, nuisance, within, exp, dof=dof,
                                       heldout_mse=mse_rows, paired=True, clusters=exp)
        pooled = _with_units(pooled, g, nuisance, level, within, dof)
        if u == 0.5:
            se_mid, deff_mid = pooled.stderr, pooled.design_effect
        se_by[u] = pooled.stderr
        located = []
        for f in flights:
            m = exp == f
            gf = stats.project_out(g[m][:, None], np.column_stack([s[m], regime[m]]))[:, 0]
            ss = float(np.dot(gf, gf))
            if ss <= 0:
                located.append(math.inf)
                continue
            located.append(math.sqrt(lam[f] * s2[f] / ss))
        by[u] = max(pooled.limit, float(np.median(located)), floor)
    best = min(by.values())
    ident = math.isfinite(best)
    why = "" if ident else ("a step in the power is absorbed entirely by each flight's own "
                            "mass, the climb and descent and the other candidates, or falls "
                            "where the flights change regime or course at every position")
    top = largest_physical("payload_change", level)
    if ident and best > top:
        ident, why = False, beyond_physics("payload_change", "power", best, top)
    withheld = {w["effect"]: w for w in report.result.withheld}
    remedy = None
    if "payload_change" in withheld and not found:
        ident, why = False, ("the fit that explains the misfit is withheld: "
                             + withheld["payload_change"]["why"])
        remedy = withheld["payload_change"].get("help")
    unset = unsettled(report.result, level, by, se_by) if ident and not found else None
    if unset is not None:
        ident, why = False, unset.pop("why")
    out = entry("payload_change", "power", found=found, identifiable=ident, limit=best,
                why=why, n=level.n_experiments, by_position=by, stderr=se_mid,
                design_effect=deff_mid, help_text=remedy, unsettled=unset)
    second = _second_change(report) if found else None
    if second is not None:
        out["second_change"] = second
        out["text"] = out["text"].rstrip(".") + ". " + second["text"]
    return out


def unsettled(result, level, by: dict[float, float], se_by: dict[float, float]
              ) -> dict[str, Any] | None:
    r"""Whether a payload change not named is *not settled* by these data (module notes,
    "Not settled"): its candidate's training test passed (p below the search's
    :data:`~planner.identify.diagnose.search.ALPHA_TRAIN`), the held-out tests did not
    confirm it, and the step its folds read (``StepEstimate``, as a named step is read)
    does not exclude one as large as the detection limit where its flights locate it:
    :math:`|\hat\delta| + z_{1-\alpha}\,SE \ge L` (the one-sided bound of an
    equivalence test at the same α), with ``by`` the limit and
    ``se_by`` the step's standard error by position (each the median over the located
    flights; the smallest limit and its error where none is located). Returns the step,
    where it is, the bound, the tests and the sentence (``why``); None where the absence
    of a finding stands."""
    from scipy.stats import norm

    from planner.identify.diagnose.search import ALPHA_TRAIN

    # the last round's candidate fitted alone (a pair's comparisons carry no estimate)
    scored = [c for c in result.candidates.values()
              if c.effect == "payload_change" and c.estimate is not None]
    if not scored or scored[-1].significant or not scored[-1].lr_p_value < ALPHA_TRAIN:
        return None
    cmp = scored[-1]
    step = cmp.estimate.mass_step_kg
    if not math.isfinite(step):
        return None
    keys = np.array(sorted(by), float)

    def at(table: dict[float, float], u: float) -> float:
        # the table between the positions either side of u (inf where either is gated)
        vals = np.array([table[k] for k in sorted(table)], float)
        j = int(np.searchsorted(keys, u))
        near = vals[max(j - 1, 0):j + 1]
        return float(np.interp(u, keys, vals)) if np.isfinite(near).all() else math.inf

    fractions = []
    for name, tc in cmp.estimate.change_time_s.items():
        if name not in level.names:
            continue
        t = level.time[level.exp == level.names.index(name)]
        if t.size >= 2 and t.max() > t.min():
            fractions.append(float((tc - t.min()) / (t.max() - t.min())))
    if fractions:
        here = float(np.median([at(by, u) for u in fractions]))
        se = float(np.median([at(se_by, u) for u in fractions]))
    else:
        u = min(by, key=by.get)
        here, se = by[u], se_by[u]
    bound = abs(step) + float(norm.ppf(1.0 - ALPHA_TRAIN)) * se
    if not (math.isfinite(here) and math.isfinite(bound) and bound >= here):
        return None
    where = ""
    if fractions:
        lo, hi = 100 * min(fractions), 100 * max(fractions)
        span = f"{lo:.0f} %" if round(lo) == round(hi) else f"{lo:.0f}–{hi:.0f} %"
        where = (f": {len(fractions)} of {level.n_experiments}, at {span} of their "
                 f"airborne span, median {100 * np.median(fractions):.0f} %")
    kind = "drop" if step < 0 else "pick-up"
    why = (f"the training flights show a {kind} of {abs(step):.2f} ± {se:.2f} kg (the "
           f"median of the folds, read on the flights whose change is located{where}; "
           f"training likelihood-ratio p = {cmp.lr_p_value:.2g}) that the held-out flights "
           f"do not confirm (held-out gain {cmp.gain_pct:.1f} %, paired p = "
           f"{cmp.paired_p_value:.2g}), and its "
           f"{100 * (1 - ALPHA_TRAIN):g} % bound, {bound:.2f} kg, reaches the {here:.2f} kg "
           f"these data could reveal there: a {kind} of that size, or anything else that "
           f"{'lowers' if step < 0 else 'raises'} the power there as much, may or may not be "
           "there, and these data cannot settle it")
    return {"mass_step_kg": float(step), "mass_step_kg_stderr": se, "bound_kg": bound,
            "limit_there_kg": here, "located_flights": len(fractions),
            "positions": [float(u) for u in sorted(fractions)],
            "lr_p_value": float(cmp.lr_p_value), "heldout_gain_pct": float(cmp.gain_pct),
            "paired_p_value": float(cmp.paired_p_value), "why": why}


def _second_change(report) -> dict[str, Any] | None:
    """What a flight with a located change shows of a second one (module notes, "A second
    change in a flight"): ``limit`` [kg], the located step's size, below which a second
    change there is not located; ``flights``, those with a change located; ``text``. None
    where no change is located."""
    fit = report.result.final_fit
    if fit is None:
        return None
    times = fit.located_changes()
    # the step as named (search.PowerLevel.step_read), else as fitted
    phys = report.result.final_physical
    values = phys[1] if phys is not None and phys[0] is fit else fit.values()
    dm = values.get("mass_step_kg", math.nan)
    if not times or not math.isfinite(dm):
        return None
    n = len(times)
    where = "the flight" if n == 1 else f"the {n} flights"
    return {"limit": abs(float(dm)), "flights": n,
            "text": (f"One change a flight is located: a second change in {where} with one "
                     f"located (a pick-up and a drop in one flight) is not identifiable with "
                     f"these data below the located step ({abs(dm):.2f} kg); a larger one "
                     "would be located in its place")}
