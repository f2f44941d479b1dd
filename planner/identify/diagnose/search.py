r"""The search of ``diagnose``: baseline calibration, time-respecting splits,
selection statistics and the greedy combination of effects.

Splits (the rule, documented once here)
---------------------------------------
Never random samples. With **several experiments** whole experiments are held
out: they are dealt in the order they appear into K = min(4, n) folds
(experiment *i* to fold *i* mod K) and each fold is held out in turn (K-fold
cross-validation over whole experiments). With **one experiment** its record
is cut into 12 contiguous blocks of equal duration, dealt into 4 folds the
same way (blocks *k*, *k* + 4, *k* + 8 held out together), so that every
held-out block has training data before and after it. Every model — the
baseline and each extension — is fitted on the training folds and scored on
the held-out fold; the held-out predictions of all folds are pooled.

Units of the tests: the held-out blocks; with fewer than 24 experiments each
experiment is cut into ⌈24/n⌉ contiguous blocks, so that there are at least 24.

What is fitted
--------------
Capacity level: the window *increments* of the measured charge,
:math:`\Delta C_w = C(t_{w,1}) - C(t_{w,0})` over contiguous windows of about
:data:`TARGET_WINDOWS` per data set (5–120 s), weighted by
:math:`1/\sqrt{\Delta t_w}`. The measured charge is integrated current, so its
error is a random walk whose increments are nearly independent; fitting the
increments keeps the least-squares statistics honest (fitting the cumulative
charge would make neighbouring residuals almost perfectly correlated). The
baseline's free parameters are δ, ε and β (β only when some experiment draws at
least :data:`FIT_BETA_MIN_DEPTH` of the nominal charge, else held at the pack's
value). Held-out error: the cumulative residual :math:`C - \hat C` from the
start of each held-out segment (experiment or block) [mAh].

Power level: the airborne samples (phases of :func:`planner.chain.flightstate.flight_phases`
other than ground, take-off and landing) averaged over bins of B seconds (at least 1 s;
longer when there are more than :data:`MAX_BINS` bins, or
:data:`MIN_BINS_PER_EXPERIMENT` a flight if that is more; at most 10 s), within
the test units. The baseline's free parameters are the efficiency η and the
shape parameters (multirotor drag area; fixed-wing C_D0, K); the system load
stays at the aircraft file's value (fitting it is the ``system_power`` effect).
Held-out error: RMSE of the bin means [W].

Selection statistics and thresholds
-----------------------------------
An effect (added to the current model) is reported only when all hold:

1. **Training likelihood-ratio test.** In each fold,
   :math:`LR = n_{eff} \ln(RSS_0/RSS_1)` on the training rows, with the
   effective sample size :math:`n_{eff} = n (1-\rho)/(1+\rho)` from the lag-1
   autocorrelation ρ of the extended model's training residuals; compared with
   :math:`\chi^2` of the added degrees of freedom (a payload change also counts
   each located change time). The median p-value over the folds must be below
   :data:`ALPHA_TRAIN` (0.05). For a payload change, which explains only variation
   *within* a flight (it is located net of the flight's own constant mass), RSS and ρ
   are those of the training residuals net of each flight's mean: a flight flown with an
   unrecorded payload is a level shift of that flight, which neither model is asked to
   explain and which would otherwise swamp the test (on real M100 flights, whose payload
   per flight is not in the data, it did: ``benchmarks/bench_diagnose_real.py``).
2. **Practical held-out gain.** The pooled held-out RMSE falls by at least
   :data:`MIN_GAIN_PCT` (5 %).
3. **Paired held-out test.** One-sided paired randomisation (sign-flip) test on
   the per-unit differences of held-out squared error, baseline minus extended
   (capacity level: the cumulative residual restarted at each unit's start),
   p below :data:`ALPHA_HELDOUT` (0.05); exact up to 16 units, else 20 000
   seeded sign patterns.
4. **The effect's own physical floor**, where it has one: a payload change of
   at least 3 % of the all-up mass; an efficiency curve must fall with load (one
   that rises is a constant loss, i.e. ``system_power``).
5. **Consistency on all the data.** After the search, the selected model is
   fitted on all the data; an effect whose key parameter is less than 2
   standard errors from "no effect" there (on the power level, where its
   flight-clustered error rests on fewer than four flights in effect, Student's t
   critical value instead: below) is dropped (and a note says so).

Greedy combination: all testable effects are scored against the calibrated
baseline; the one with the largest held-out gain among those that pass joins
the model; the remaining ones are scored again against the extended model, and
so on until none passes. When none passes alone, the pairs of promising ones
(gain and training test passed) are tried together, for two effects that mask
each other; a pair joins when it passes and each member passes on top of the
other. Capacity- and power-level effects are searched separately (they explain
different residuals). Reported parameters and their standard errors come from
the final fit on all the data, with the covariance :math:`s^2 (J^TJ)^{-1}`
inflated by :math:`(1+\rho)/(1-\rho)` for the autocorrelation of the residuals. On the
power level with :data:`planner.identify.stats.MIN_CLUSTERS` or more flights each standard
error is the larger of that and the flight-clustered sandwich's (Liang & Zeger 1986): an
effect carried by whole flights (the air density of a day, a wind shared by flights on
different courses) is estimated against the scatter between flights, which a
within-flight noise model does not see; the detection limits count the same scatter
(:func:`planner.identify.stats.design_effect`). A sandwich rests on as many scores as
there are flights that carry the estimate, not flights in the data: a wind fitted on
sixteen flights of which three cruise along a course rests on about three. That number,
the effective number of flights :math:`G^*` along the effect's key parameter
(:func:`planner.identify.stats.effective_clusters`; Carter, Schnepel & Steigerwald
2017), is kept with each fit (``effective_flights[<effect>]`` of
:meth:`PowerLevel.physical`). Where the flight-clustered error is the one in use
(``clustered_error[<effect>]``) and :math:`G^*` is below
:data:`planner.identify.stats.MIN_CLUSTERS`, the consistency test of rule 5 judges the
effect's z against Student's t with :math:`G^* - 1` degrees of freedom instead of 2
(Cameron & Miller 2015, sec. VI.C), and says so where that withholds it; where the
AR(1) error is the larger, the test stands on the model's own noise. The detection
limits do not count it: a limit is given for an
effect not yet fitted, whose direction (a wind's) is not known.

Rival effects
-------------
When several effects pass in one round, the one with the largest held-out gain is not
simply taken: two effects of different physics may explain the same misfit (a payload
dropped late in flights along a closed route and a steady wind; a constant load and an
efficiency curve). The leading one is held against each of the next
:data:`MAX_RIVALS` that pass (:func:`_rival_step`): first by the paired sign-flip test
of their held-out unit losses against each other (Vuong's test for non-nested models),
then, where that does not decide, by fitting both and testing each on top of the other
(the encompassing principle); a rival that fails only the paired test is held against
it too. The one that adds to its rival while the rival adds
nothing to it is taken; where neither adds to the other the data cannot tell them apart,
neither is named, and both are withheld as confounded (``LevelResult.confused``). The
one taken keeps the test each rival lost (``LevelResult.held_against``), which its
finding quotes as evidence (``held_against`` of its ``evidence``): the rival's held-out
gain, the paired test's p, and the gains and p on top of each other where that decided.

An effect skipped because these data cannot name it but can fit it — a wind on a route
flown in one order, where it changes the airspeed as one step per flight — is still the
rival of what it would be mistaken for (``Effect.rival_of``: a payload step): it is
fitted in each round where that effect passes and held against it the same way. It is
never named; where it ties with the step or is preferred to it, neither is named. Without
it, a 5.2 m/s wind on sixteen M100 route-R1 flights was named as a −0.18 kg step
(docs/results.md, "A wind on route R1 is held against the step it makes").

Change points (``payload_change``)
----------------------------------
The change time of an experiment is located on the data of it the fit may see:
the training blocks of a time-block split; an experiment held out whole is
located on its own record with the mass step learned on the training
experiments (a drop is an event of the flight; only its size is learned), one
interleaved half of its bins locating the change applied to the other half.
The flights of a data set need not weigh what was given (an unrecorded payload
per flight): a change is located against a mass that differs for the whole
flight, i.e. the step's column :math:`s\,1\{t \ge t_c\}` and the residual are
both taken net of the flight's constant-mass column :math:`s` (the power's
sensitivity to the mass), so that a step near the start or end of a flight —
which is a flight flown heavier or lighter — is not a change. A change is
placed only where it lowers that squared error by more than :math:`k \ln(n)`
long-run residual variances (a BIC-like threshold, :math:`\ln n` per fitted
parameter: :math:`k = 2` for the time and the size, :math:`k = 1` on a held-out
flight, whose step size was learned on the other flights), else the flight has
none. One change is located a flight, the one that lowers the error most: a second in
the same flight is not (the detection limit says so,
:mod:`planner.identify.diagnose.limits`, "A second change in a flight"). The variance
is taken from differences at a lag, so that the change itself does not count as noise
(:func:`planner.identify.stats.step_robust_long_run_variance`).

The residual is first taken net of a power level of the climbs' and of the descents'
own (climb rate beyond ±:data:`~planner.chain.flightstate.CLIMB_THRESHOLD_MS`), pooled
over the flights. The power model misses these regimes by tens of watts (on 32 clean
route-R1 flights of the DJI M100 data, Rodrigues et al. 2021, the residual of the model
without a step is +15 to +21 W in level cruise, −21 to −28 W in the final descents and
−13 W in the climb): located on the raw residual, the change from cruise to descent
looks like a drop, so a release is found late or at the descent and a pick-up not at
all. The levels are fitted beside each flight's own constant mass and the step, and the
steps located again on the residual net of them, for up to :data:`LOCATE_ROUNDS` rounds
(until the located changes no longer move). Before any change is located, the step's
column is its expectation under a change time uniform over each flight (the share of
the flight elapsed, × :math:`s`): else the levels take up a change that happens in every
flight, and none is located. A held-out flight is
located net of the levels learned on the training flights where the held-out flights are
numerous enough for the same regimes to have levels of their own, else on the residual
as it is (with one or two held-out flights the learned levels let a step pass on clean
flights: 3 of 5 flights of the M100 sample with the plain climb rate).

A flight whose change is not located (too small against its noise, or where a regime
change hides it) still has one: the effect is a change in every flight. It is fitted
with the change's expectation given its own record — its mass raised by the step × the
posterior probability that the change has happened by each bin
(:meth:`PowerLevel._change_posterior`): a prior uniform over the flight's bins, times
the likelihood :math:`\exp(\Delta_j / 2\sigma^2)` of a change at bin :math:`j`, where
:math:`\Delta_j` is the drop of the squared error the step makes there (the scan's, net
of the flight's constant mass) and :math:`\sigma^2` the long-run variance of the
threshold (the posterior of a single change point under a uniform prior: Smith,
*Biometrika* 62, 407, 1975; Fearnhead, *Statistics and Computing* 16, 203, 2006). Where
the record says nothing this is the share of the flight elapsed (the uniform prior);
where it points to one time without beating the threshold it is a softened step there.
The rounds above take unlocated flights so too, and a held-out flight not located on its
half takes the posterior of that half. Fitted at its given mass all flight, such a
flight carried its change in the efficiency the flights share, and every located step
came out small (on the M100's other routes, five draws of 16 flights with a pick-up at
random points, plain record: 0.08–0.20 kg against 0.21–0.28 kg); fitted with the share
elapsed, a change early in every flight — the flight heavier for most of its span — was
a ramp it did not follow, and the step again came out small (a pick-up at 10–25 % of the
span: 0.02–0.07 kg against 0.20–0.28 kg).

The step's standard error is the larger of the fit's (AR(1)-inflated, within flights)
and the spread of **placebo steps**: the same step fitted on the final model's residual
at other times of the same flights, where nothing was located
(:meth:`PowerLevel.placebo_steps`, at 17 fractions of each flight's airborne span), the
root mean square of their sizes. A residual that drifts within the flights, or a regime
the power model misses (the slow vertical descents that end the DJI M100 flights),
makes steps of its own at any time; the fit's standard error treats the residual as
noise about a correct model and cannot see them, the placebos do. This is inference
from placebo event dates (Chetty, Looney & Kroft, *American Economic Review* 99, 1145,
2009; Abadie, Diamond & Hainmueller, *JASA* 105, 493, 2010).

What the placebos cannot see is a misfit where the step itself lies: the step takes it
up, and the residual they are fitted to no longer holds it. On a multirotor the regime
the rotor model is least sure of is the slow vertical descent (the vortex-ring state,
an empirical curve: :meth:`PowerLevel.descent_misfit`), which ends most flights, so a
late step falls on it. And a flight whose change is not located carries it by its
expectation, whose shape is the record's best guess, not the change. So the step named
is read where nothing but its own flights and its own size carry it
(:meth:`PowerLevel.step_read`): one Gauss-Newton step from the final fit on the
training bins of the flights whose change is located, with a power level of the
vertical descents' own beside the parameters (where three or more of those flights
descend vertically). The fit on every flight is the efficient estimate were the model
right in the descents and each unlocated flight's change where its expectation puts it;
the read is consistent whether or not they hold (Hausman, *Econometrica* 46, 1251,
1978), and its error is that fit's (the larger of the AR(1) and the flight-clustered
one), or the placebos' spread where larger. On 16 DJI M100 flights of the routes other
than R1 (Rodrigues et al. 2021) with a pick-up late in every flight, the change located
in 6 of them, the fit on every flight finds 0.21 kg of a 0.31 kg step, five of its
standard errors away; the read finds 0.29 ± 0.02 kg. The fit on every flight is kept
(``mass_step_kg_pooled``, ``mass_step_kg_pooled_stderr``; the read's flights and
whether the descents had a level: ``mass_step_kg_read_flights``,
``mass_step_kg_read_descent_level``).

Where fewer than three flights have a located change, or the descents have a level of
their own over every flight but not over the located ones, the step is the fit on every
flight and the descents' part of its error is measured instead: it is fitted once more
with a power level of the vertical descents' own beside it, over every flight
(:meth:`PowerLevel.descent_shift`). How far the step moves, less what noise alone would
move it (the same Hausman contrast), is the bias the descents' misfit puts into it, and
the standard error becomes the root sum of squares of the above and that bias: the root
mean square error of the estimate (the detection limit takes the descents as a nuisance
regime too, :mod:`planner.identify.diagnose.limits`). Where the model flies the descents
right the shift is of the size of that noise and the bias nil
(``mass_step_kg_descent_shift``, ``mass_step_kg_descent_bias``).

Wind
----
A multirotor holds its ground velocity, so a steady wind is read in two ways: where it
moves, the power changes with the direction of travel (the airspeed rises upwind and
falls downwind); where it hovers or moves only vertically, the wind is the whole
airspeed, and the power falls by the model's translational lift, whatever the wind's
direction. The second reading rests on the model's power at low airspeed, where momentum
theory's induced power is least sure (on DJI M100 flights of the routes other than R1,
Rodrigues et al. 2021, the calibrated rotor model's power falls from the hover to
3 m/s 1.3–6 times as much as the measured power does, in three draws). As for the
descents and a payload step, the wind is fitted once more with a power level of the
hover bins' own (:meth:`PowerLevel.hovering`: the ground velocity known and below
:data:`MOVING_MS`), and how far its speed moves, less what noise alone would move it
(:meth:`PowerLevel.hover_shift`, the same Hausman contrast), is added in quadrature to
the speed's standard error, each component taking its part
(``wind_speed_ms_hover_shift``, ``wind_speed_ms_hover_bias``); the detection limit
takes the hover as a nuisance regime too. On flights the model flies right the bias is
of the size of the fit's error.

Both readings rest on the model's change of power with airspeed, and a model whose power
changes twice as much as the aircraft's reads a wind of about half its speed. Where the
flights move at several speeds they show their own: the wind is fitted once more with a
free scale :math:`k` on that change, :math:`P = P_0 + k\,(P(V) - P_0)`, :math:`P_0` the
model's power at the same state with no airspeed
(:class:`~planner.identify.diagnose.effects.SpeedResponse`, a linear column;
:meth:`PowerLevel.speed_read`). On the DJI M100's routes other than R1 (Rodrigues et al.
2021) :math:`k` is about 0.5–0.8, two or more standard errors below 1. Across R1's 176
flights at 4–12 m/s the level cruise power by commanded speed (net of payload and
altitude; docs/results.md, "The M100's change of power with speed") falls 9 W from 4 to
8 m/s and rises 48 ± 7 W from 10 to 12 m/s, where the rotor model calibrated on 16 of
them falls 21–32 W and rises 76–90 W (three draws). Where :math:`k` lies more than
:data:`~planner.identify.diagnose.effects.SPEED_RESPONSE_Z` standard errors and
:data:`~planner.identify.diagnose.effects.SPEED_RESPONSE_FLOOR` from 1
(:func:`~planner.identify.diagnose.effects.speed_scale`), the wind named is the one
fitted with it free (the model's own reading is kept, ``wind_speed_ms_model``), and the
detection limit is the model's divided by :math:`k`; where it is not clearly above 0, a
wind's speed cannot be read, and none is named.

Climb rate
----------
Where the record has an altitude, the logged climb rate is checked against the
altitude's rate of change over :data:`CLIMB_WINDOW_S` windows; when they differ
by more than :data:`MAX_CLIMB_DISAGREEMENT_MS` RMS (the DJI M100 data's
``velocity_z`` is not a vertical speed in forward flight: it reads 1–3 m/s at
constant altitude), the power model is driven by the altitude's rate of change
(direct evidence first) and a note says so.
"""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2

from planner.physics import atmosphere
from planner.physics.battery import integral
from planner.identify import stats
from planner.errors import FitError, ModelError
from planner.identify.aircraft_fit import MIN_DESCENT_FLIGHTS, with_params
from planner.identify.diagnose.evidence import mode_changes
from planner.chain.flightstate import (
    CLIMB_THRESHOLD_MS,
    STILL_MS,
    climb_regimes,
    flown,
    from_record,
    inplane_speed,
    vertical_descent,
)
from planner.physics.units import AS_PER_MAH

#: Folds of the cross-validation. [unitless]
N_FOLDS = 4
#: Blocks a single experiment is cut into. [unitless]
N_BLOCKS_SINGLE = 12
#: Least number of test units (held-out blocks). [unitless]
MIN_UNITS = 24
#: Least held-out RMSE gain for an effect to be reported. [%]
MIN_GAIN_PCT = 5.0
#: Level of the one-sided paired test on held-out units. [unitless]
ALPHA_HELDOUT = 0.05
#: Level of the training likelihood-ratio test. [unitless]
ALPHA_TRAIN = 0.05
#: Least number of units with a non-zero difference for the paired test. [unitless]
MIN_TEST_UNITS = 6
#: Target number of capacity windows over the data set. [unitless]
TARGET_WINDOWS = 500
#: Most power bins before the bin width grows (up to 10 s). [unitless]
MAX_BINS = 1000
#: Bins an experiment keeps on average however many there are (the bins are then
#: allowed beyond :data:`MAX_BINS`): a change point is located flight by flight, and
#: wider bins leave each flight fewer to place it with (module notes, "Change points").
#: [unitless]
MIN_BINS_PER_EXPERIMENT = 60
#: β is fitted only when some experiment draws this share of the nominal charge. [unitless]
FIT_BETA_MIN_DEPTH = 0.1
#: Shortest experiment used. [s]
MIN_EXPERIMENT_S = 30.0
#: Least number of windows (capacity) or bins (power) for a level to run. [unitless]
MIN_ROWS = 24
#: Ground speed above which the aircraft counts as moving. [m/s]
MOVING_MS = 2.0
#: Least number of samples at rest for the rest current to count as direct evidence.
MIN_REST_SAMPLES = 30
#: Least number of ground samples for the ground power to bound a constant load.
MIN_GROUND_SAMPLES = 10
#: Window over which the logged climb rate is checked against the altitude. [s]
CLIMB_WINDOW_S = 5.0
#: Largest RMS difference between the logged climb rate and the altitude's rate of change
#: (both over :data:`CLIMB_WINDOW_S` windows) for the power model to be driven by the
#: logged climb rate: the speed :func:`planner.chain.flightstate.flight_phases` calls a climb.
#: Autopilot logs agree within 0.07–0.17 m/s; beyond 0.5 m/s the climb power alone
#: (m g v_c / η) is misstated by some 8 % of the hover power of a 3.6-kg quadrotor. [m/s]
MAX_CLIMB_DISAGREEMENT_MS = CLIMB_THRESHOLD_MS
#: Share of the vertical descents' mean power from which their misfit is reported (it is
#: measured on as many flights with vertical descents as fit-aircraft needs to free the
#: descent inflow weight, :data:`~planner.identify.aircraft_fit.MIN_DESCENT_FLIGHTS`).
#: [unitless]
DESCENT_MISFIT_SHARE = 0.03
#: Fractions of each located flight's airborne span at which a placebo step is placed
#: (:meth:`PowerLevel.placebo_steps`). [unitless]
PLACEBO_POSITIONS = tuple(round(0.10 + 0.05 * i, 2) for i in range(17))
#: A placebo this close to a flight's own change time (a share of its airborne span) is
#: not placed in that flight. [unitless]
PLACEBO_EXCLUSION = 0.1
#: Fewer placebo positions than this give no placebo spread. [count]
MIN_PLACEBOS = 5
#: Rounds in which the climbs' and descents' power levels and the change times are
#: located in turn (:meth:`PowerLevel._locate`). [count]
LOCATE_ROUNDS = 3


# ============================================================================ split

@dataclass(frozen=True)
class Unit:
    """A contiguous block of one experiment, the unit of the held-out tests."""

    exp: int
    t0: float
    t1: float
    fold: int


@dataclass
class Split:
    """Folds and test units (see the module notes for the rule)."""

    units: list[Unit]
    n_folds: int
    whole_experiments: bool
    rule: str

    def assign(self, exp: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Unit index of each sample (experiment index ``exp``, time ``t``)."""
        out = np.full(len(t), -1, dtype=int)
        by_exp: dict[int, list[int]] = {}
        for i, u in enumerate(self.units):
            by_exp.setdefault(u.exp, []).append(i)
        for e, idx in by_exp.items():
            m = exp == e
            edges = np.array([self.units[i].t0 for i in idx[1:]])
            pos = np.searchsorted(edges, t[m], side="right")
            out[m] = np.asarray(idx)[pos]
        return out

    def to_dict(self) -> dict[str, Any]:
        """The rule in words, the folds, the number of test units and whether whole
        experiments are held out."""
        return {"rule": self.rule, "folds": self.n_folds, "units": len(self.units),
                "whole_experiments": self.whole_experiments}


def make_split(spans: list[tuple[float, float]]) -> Split:
    """Folds and units for experiments spanning ``spans`` = [(t_first, t_last), …]."""
    n = len(spans)
    units: list[Unit] = []
    if n >= 2:
        k = min(N_FOLDS, n)
        m = max(1, math.ceil(MIN_UNITS / n))
        for j, (a, b) in enumerate(spans):
            for i in range(m):
                units.append(Unit(j, a + (b - a) * i / m, a + (b - a) * (i + 1) / m, j % k))
        rule = (f"whole experiments held out: {n} experiments dealt in order into {k} folds "
                f"(experiment i to fold i mod {k}), each fold held out in turn; "
                f"test units: {m} contiguous block(s) per experiment")
        return Split(units, k, True, rule)
    a, b = spans[0]
    m = N_BLOCKS_SINGLE
    for i in range(m):
        units.append(Unit(0, a + (b - a) * i / m, a + (b - a) * (i + 1) / m, i % N_FOLDS))
    rule = (f"one experiment: {m} contiguous time blocks of {(b - a) / m:.0f} s dealt into "
            f"{N_FOLDS} folds (block i to fold i mod {N_FOLDS}), each fold held out in turn; "
            "never random samples")
    return Split(units, N_FOLDS, False, rule)


# ============================================================================ helpers

def _lstsq(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return coef


@dataclass
class Fit:
    """One fitted model (one fold, or all the data)."""

    effects: tuple[str, ...]
    nl_names: list[str]
    nl: np.ndarray
    lin_names: list[str]
    coef: np.ndarray
    train: np.ndarray                 # bool over rows
    train_resid: np.ndarray           # weighted training residuals (rows order)
    state: dict = field(default_factory=dict)

    @property
    def rss(self) -> float:
        """Sum of the squared weighted training residuals. [level's unit²]"""
        return float(np.dot(self.train_resid, self.train_resid))

    def values(self) -> dict[str, float]:
        """Every fitted value by name, the nonlinear ones first (raw coordinates of the
        level, not the physical parameters of :meth:`CapacityLevel.physical`)."""
        return dict(zip(self.nl_names + self.lin_names,
                        map(float, np.r_[self.nl, self.coef])))

    def located_changes(self) -> dict[str, float]:
        """Each flight's located change time [s] by flight name (a payload change's
        ``change_time_s``), the flights whose change is not located left out."""
        return {k: v for k, v in self.state.get("change_time_s", {}).items() if v is not None}


# ============================================================================ capacity

def experiment_channels(exps: list[dict]):
    """The capacity effects' channels of a set of experiments: the pack temperature of
    every sample (None unless every experiment has one), the names of the experiments
    without, each experiment's cycle and where it came from (``"cycle"``, else
    ``"experiment order"``: 0, 1, 2, …)."""
    temps = [e.get("temperature") for e in exps]
    missing = [e["name"] for e, tc in zip(exps, temps) if tc is None]
    temperature = None if missing else np.concatenate(temps)
    cyc = [e.get("cycle") for e in exps]
    if all(c is not None for c in cyc):
        return temperature, missing, np.asarray(cyc, float), "cycle"
    return temperature, missing, np.arange(len(exps), dtype=float), "experiment order"


class CapacityLevel:
    """Measured charge against the integral model driven by the measured power.

    Parameters
    ----------
    exps : list of dict
        One per experiment: ``name``, ``t`` [s from 0], ``p`` [W, ≤ 0 = rest],
        ``c`` [A s, measured charge from 0], ``temperature`` [°C] or None,
        ``cycle`` or None.
    pack : BatteryPack
        Start values (δ, ε, β) and the nominal capacity.
    """

    name = "capacity"
    unit = "mAh"

    def __init__(self, exps: list[dict], pack):
        self.pack = pack
        self.names = [e["name"] for e in exps]
        self.n_experiments = len(exps)
        lengths = np.array([len(e["t"]) for e in exps])
        self.exp_start = np.r_[0, np.cumsum(lengths)[:-1]]
        self.exp_end = self.exp_start + lengths - 1
        self.exp_index = np.repeat(np.arange(len(exps)), lengths)
        self.start_of = self.exp_start[self.exp_index]
        self.t = np.concatenate([e["t"] for e in exps])
        self.p = np.concatenate([e["p"] for e in exps])
        self.c = np.concatenate([e["c"] for e in exps])
        n = len(self.t)
        dt = np.diff(self.t)
        self.cross = np.zeros(n - 1, bool)
        self.cross[self.exp_start[1:] - 1] = True
        dt[self.cross] = 0.0
        self.half_dt = 0.5 * dt
        on = self.p > 0
        self.on = on.astype(float)
        logp = np.log(np.where(on, self.p, 1.0))
        w = np.r_[self.half_dt, 0] + np.r_[0, self.half_dt]
        self.p_ref = float(np.exp(np.sum(logp * w * on) / max(np.sum(w * on), 1e-9)))
        self.logp = np.where(on, logp - math.log(self.p_ref), 0.0)
        self.time_since_start = self.t.copy()
        total = float(np.sum(dt))
        self.rest_fraction = float(np.sum(dt * (self.p[:-1] <= 0))) / total if total else 0.0
        med_on = float(np.median(self.p[on])) if on.any() else 0.0
        low = self.p[:-1] <= 0.1 * med_on
        self.low_load_fraction = float(np.sum(dt * low)) / total if total else 0.0

        # direct evidence of the current sensor's zero: the logged current at rest
        currents = [e.get("current") for e in exps]
        if all(i is not None for i in currents):
            i_all = np.concatenate(currents)
            rest = (self.p <= 0) & np.isfinite(i_all)
            self.median_current_a = float(np.nanmedian(i_all[on])) if on.any() else 0.0
            self.rest_current = None
            if rest.sum() >= MIN_REST_SAMPLES:
                r = i_all[rest]
                n_eff = r.size / stats.ar1_inflation(stats.lag1_autocorrelation(r))
                self.rest_current = (float(r.mean()), float(r.std(ddof=1) / math.sqrt(n_eff)))
        else:
            rate = np.diff(self.c) / np.where(dt > 0, dt, np.inf)
            self.median_current_a = float(np.median(rate[self.p[:-1] > 0])) if on.any() else 0.0
            self.rest_current = None
        (self.temperature, self.temperature_missing, self.cycles,
         self.cycle_source) = experiment_channels(exps)

        self.final_charge_as = np.array([e["c"][-1] for e in exps])
        depth = float(np.max(self.final_charge_as)) / max(pack.capacity_as, 1e-9)
        self.fit_beta = depth >= FIT_BETA_MIN_DEPTH
        self.split = make_split([(float(e["t"][0]), float(e["t"][-1])) for e in exps])
        self.sample_unit = self.split.assign(self.exp_index, self.t)
        self.sample_fold = np.array([u.fold for u in self.split.units])[self.sample_unit]
        self._windows()

    # ---------------------------------------------------------------- layout
    def _windows(self) -> None:
        total = float(np.sum(2 * self.half_dt))
        med_dt = float(np.median(np.diff(self.t)[~self.cross])) if len(self.t) > 1 else 1.0
        width = min(max(total / TARGET_WINDOWS, 3 * med_dt, 5.0), 120.0)
        self.window_s = width
        w0, w1 = [], []
        for e in range(self.n_experiments):
            a, b = self.exp_start[e], self.exp_end[e]
            t = self.t[a:b + 1]
            units = self.sample_unit[a:b + 1]
            bounds = {0, len(t) - 1}
            bounds.update((np.flatnonzero(np.diff(units) != 0) + 1).tolist())
            ub = sorted(bounds)
            for s0, s1 in itertools.pairwise(ub):
                k = max(1, round((t[s1] - t[s0]) / width))
                edges = np.searchsorted(t, np.linspace(t[s0], t[s1], k + 1))
                bounds.update(int(min(max(x, s0), s1)) for x in edges)
            ub = np.array(sorted(bounds))
            ub = ub[np.r_[True, np.diff(ub) > 0]]
            w0.append(a + ub[:-1])
            w1.append(a + ub[1:])
        self.w0 = np.concatenate(w0)
        self.w1 = np.concatenate(w1)
        self.window_exp = self.exp_index[self.w0]
        self.window_unit = self.sample_unit[self.w0]
        self.window_fold = np.array([self.split.units[u].fold for u in self.window_unit])
        self.window_dt = self.t[self.w1] - self.t[self.w0]
        self.window_time = 0.5 * (self.t[self.w1] + self.t[self.w0])
        self.weights = 1.0 / np.sqrt(np.maximum(self.window_dt, 1e-6))
        self.y = self.c[self.w1] - self.c[self.w0]
        self.n_rows = len(self.w0)
        self.row_group = self.window_exp
        self.row_unit = self.window_unit
        self.row_fold = self.window_fold

    def cumulate(self, interval_values: np.ndarray) -> np.ndarray:
        """Cumulative sum per experiment of per-interval values (n − 1) → per sample."""
        x = np.where(self.cross, 0.0, interval_values)
        cs = np.r_[0.0, np.cumsum(x)]
        return cs - cs[self.start_of]

    def window_mean(self, x: np.ndarray) -> np.ndarray:
        """Mean of a per-sample series over each window's samples. [unit of x]"""
        cs = np.r_[0.0, np.cumsum(x)]
        return (cs[self.w1 + 1] - cs[self.w0]) / (self.w1 - self.w0 + 1)

    # ---------------------------------------------------------------- model
    def _nl_start(self, start: Fit | None) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
        m = self.pack.model
        names = ["epsilon"] + (["beta"] if self.fit_beta else [])
        x0 = np.array([m.epsilon] + ([m.beta] if self.fit_beta else []), float)
        if start is not None:
            x0 = np.array([start.values()[k] for k in names])
        lo = np.array([-3.0] + ([0.5] if self.fit_beta else []))
        hi = np.array([0.5] + ([1.5] if self.fit_beta else []))
        return names, np.clip(x0, lo + 1e-6, hi - 1e-6), lo, hi

    def _beta(self, x: np.ndarray) -> float:
        return float(x[1]) if self.fit_beta else float(self.pack.model.beta)

    def G(self, x: np.ndarray) -> np.ndarray:
        r"""The model's charge shape per sample, :math:`S^{1/\beta}` with the stress
        :math:`S = \int (P/P_{ref})^{-\varepsilon} dt` from each experiment's start
        ([UAV23] eq. 14 up to the scale δ, fitted linearly). [s^(1/β)]"""
        rate = np.exp(-x[0] * self.logp) * self.on
        S = self.cumulate(self.half_dt * (rate[1:] + rate[:-1]))
        return integral.charge_from_stress(S, self._beta(x))

    def design(self, x: np.ndarray, effects) -> np.ndarray:
        """Per-sample cumulative columns: G, then one per effect."""
        G = self.G(x)
        dG = np.diff(G)
        dG[self.cross] = 0.0
        return np.column_stack([G] + [e.cumulative(self, G, dG) for e in effects])

    def fit(self, effects, train: np.ndarray, start: Fit | None = None) -> Fit:
        """Fit the integral model with ``effects`` to the window increments of the
        ``train`` rows: ε (and β) by least squares, the scale and the effects'
        coefficients linearly at each step (variable projection)."""
        names, x0, lo, hi = self._nl_start(start)
        for e in effects:
            e.prepare(self)
        rows = np.flatnonzero(train)
        wt = self.weights[rows]
        y = self.y[rows] * wt
        i0, i1 = self.w0[rows], self.w1[rows]
        cache: dict = {}

        def solve(x):
            X = self.design(x, effects)
            Xw = (X[i1] - X[i0]) * wt[:, None]
            coef = _lstsq(Xw, y)
            cache["coef"] = coef
            return y - Xw @ coef

        res = least_squares(solve, x0, bounds=(lo, hi), x_scale=np.full(len(x0), 0.01),
                            diff_step=1e-4, xtol=1e-8, ftol=1e-10, max_nfev=200)
        resid = solve(res.x)
        coef = cache["coef"]
        if not coef[0] > 0:
            raise FitError("capacity baseline: the fitted charge scale is not positive: the "
                           "measured charge does not follow the measured power")
        lin = ["scale"] + [e.coefficient + "__raw" for e in effects]
        return Fit(tuple(e.name for e in effects), names, res.x, lin, coef, train, resid)

    def predict_samples(self, fit: Fit, effects) -> np.ndarray:
        """Predicted cumulative charge at every sample. [A s]"""
        return self.design(fit.nl, effects) @ fit.coef

    def row_residuals(self, fit: Fit, effects, rows: np.ndarray,
                      X: np.ndarray | None = None) -> np.ndarray:
        """Weighted residuals of the window increments of ``rows``. [A s / √s]"""
        X = self.design(fit.nl, effects) if X is None else X
        Xw = X[self.w1[rows]] - X[self.w0[rows]]
        return (self.y[rows] - Xw @ fit.coef) * self.weights[rows]

    def prepare_heldout(self, fit: Fit, effects, heldout: np.ndarray) -> None:
        """Nothing to locate at the capacity level."""

    def heldout(self, fit: Fit, effects, fold: int) -> dict[str, Any]:
        """Held-out residuals of one fold: rows, samples (reset per segment), final errors."""
        X = self.design(fit.nl, effects)
        rows = np.flatnonzero(self.row_fold == fold)
        row_r = self.row_residuals(fit, effects, rows, X)
        samples = np.flatnonzero(self.sample_fold == fold)
        r = self.c - X @ fit.coef
        seg = self._segment_start(samples)
        rs = r[samples] - r[seg]
        # test-unit loss: cumulative residual restarted at each unit's first sample
        ufirst = self._unit_first(samples)
        loss = (r[samples] - r[ufirst]) ** 2
        finals = []
        for s in np.unique(seg):
            idx = samples[seg == s]
            last = idx[-1]
            # include the shared boundary sample of the next block where it exists
            dc = self.c[last] - self.c[s]
            if dc > 0:
                finals.append((abs(r[last] - r[s]), dc))
        return {"rows": rows, "row_resid": row_r, "samples": samples, "sample_resid": rs,
                "finals": finals, "loss_units": self.sample_unit[samples], "loss": loss}

    def _unit_first(self, samples: np.ndarray) -> np.ndarray:
        units = self.sample_unit[samples]
        change = np.r_[True, units[1:] != units[:-1]]
        starts = samples[change]
        return starts[np.cumsum(change) - 1]

    def _segment_start(self, samples: np.ndarray) -> np.ndarray:
        if self.split.whole_experiments:
            return self.start_of[samples]
        return self._unit_first(samples)

    # ---------------------------------------------------------------- reporting
    def covariance(self, fit: Fit, effects) -> tuple[np.ndarray, np.ndarray]:
        """Covariance of [nl…, coef…] of an all-data fit (the Jacobian of
        :meth:`jacobian` on its training rows)."""
        rows = np.flatnonzero(fit.train)
        X0 = self.design(fit.nl, effects)
        r0 = (self.y[rows] - (X0[self.w1[rows]] - X0[self.w0[rows]]) @ fit.coef) \
            * self.weights[rows]
        J = self.jacobian(fit, effects)[rows]
        return stats.covariance(J, r0, self.row_group[rows]).matrix, np.r_[fit.nl, fit.coef]

    def jacobian(self, fit: Fit, effects) -> np.ndarray:
        """Change of the weighted window increments (all rows) per unit of each fitted
        parameter [nonlinear…, linear…] of ``fit``. [A s / √s per unit]"""
        X0 = self.design(fit.nl, effects)
        wt = self.weights
        cols = [(X0[self.w1, j] - X0[self.w0, j]) * wt for j in range(X0.shape[1])]
        base = (X0[self.w1] - X0[self.w0]) @ fit.coef * wt
        jnl = []
        for j in range(len(fit.nl)):
            h = 1e-5
            x = fit.nl.copy()
            x[j] += h
            X = self.design(x, effects)
            jnl.append(((X[self.w1] - X[self.w0]) @ fit.coef * wt - base) / h)
        return np.column_stack(jnl + cols)

    def signature(self, fit: Fit, effects, effect) -> np.ndarray:
        """Change of the weighted window increments per unit of ``effect``'s coefficient
        (relative ones: per unit of the factor on the charge drawn), at ``fit``.
        [A s / √s per unit]"""
        effect.prepare(self)
        G = self.G(fit.nl)
        dG = np.diff(G)
        dG[self.cross] = 0.0
        col = effect.cumulative(self, G, dG)
        scale = float(fit.coef[0]) if effect.relative else 1.0
        return (col[self.w1] - col[self.w0]) * self.weights * scale

    def cumulative_columns(self, fit: Fit, effects, extra=()) -> tuple[np.ndarray, np.ndarray]:
        """Per sample, restarted at each test unit's first sample: the change of the
        predicted cumulative charge per unit of each fitted parameter, and per unit of
        each ``extra`` effect's coefficient (as :meth:`signature`). [A s per unit]"""
        first = self._unit_first(np.arange(len(self.t)))
        X0 = self.design(fit.nl, effects)
        base = X0 @ fit.coef
        cols = []
        for j in range(len(fit.nl)):
            x = fit.nl.copy()
            x[j] += 1e-5
            cols.append((self.design(x, effects) @ fit.coef - base) / 1e-5)
        cols += [X0[:, j] for j in range(X0.shape[1])]
        J = np.column_stack(cols)
        J = J - J[first]
        G = self.G(fit.nl)
        dG = np.diff(G)
        dG[self.cross] = 0.0
        sig = []
        for e in extra:
            e.prepare(self)
            c = e.cumulative(self, G, dG) * (float(fit.coef[0]) if e.relative else 1.0)
            sig.append(c - c[first])
        return J, (np.column_stack(sig) if sig else np.zeros((len(self.t), 0)))

    def physical(self, fit: Fit, effects) -> tuple[dict[str, float], dict[str, float]]:
        """δ, ε, β and each effect's coefficient, with standard errors."""
        cov, x = self.covariance(fit, effects)
        k = len(fit.nl)
        names = ["delta", "epsilon", "beta"] + [e.coefficient for e in effects]

        def conv(v):
            eps = v[0]
            beta = v[1] if self.fit_beta else self.pack.model.beta
            A = v[k]
            delta = A ** (-beta) * self.p_ref ** (-eps)
            return [delta, eps, beta] + [v[k + 1 + i] / (A if e.relative else 1.0)
                                         for i, e in enumerate(effects)]

        vals, se = stats.delta_method(conv, x, cov)
        if not self.fit_beta:
            se[2] = 0.0
        return dict(zip(names, map(float, vals))), dict(zip(names, map(float, se)))

    def confounders(self) -> list[tuple[str, np.ndarray]]:
        """What an effect's driver must not follow (per window): time since the start and
        the depth of discharge (charge drawn so far)."""
        depth = 0.5 * (self.c[self.w0] + self.c[self.w1])
        return [("the time since the start", self.window_time),
                ("the depth of discharge", depth)]

    def row_driver_residual(self, resid: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Held-out window residual as an excess current [mA]."""
        return resid / self.weights[rows] / np.maximum(self.window_dt[rows], 1e-9) * 1000.0


# ============================================================================ power

def _finite_col(sub, name: str, n: int) -> np.ndarray:
    if name in sub.columns:
        return sub[name].to_numpy(float)
    return np.full(n, np.nan)


class _Bins:
    """Bins of B seconds within the test units of the power level (module notes): B at
    least 1 s and the median sample interval, longer when there would be more than
    :data:`MAX_BINS` (or :data:`MIN_BINS_PER_EXPERIMENT` a flight, if that is more), at
    most 10 s; bins with fewer than half the median count of samples are dropped
    (:attr:`keep`)."""

    def __init__(self, s: dict, split: Split, spans):
        self.unit = split.assign(s["exp"], s["t"])
        total = sum(b - a for a, b in spans)
        dts = np.diff(s["t"])
        self.med_dt = float(np.median(dts[dts > 0])) if np.any(dts > 0) else 1.0
        most = max(MAX_BINS, MIN_BINS_PER_EXPERIMENT * np.unique(s["exp"]).size)
        self.width = min(max(1.0, self.med_dt, total / most), 10.0)
        u0 = np.array([split.units[u].t0 for u in self.unit])
        key = self.unit.astype(np.int64) * 10**7 + \
            np.floor((s["t"] - u0) / self.width).astype(np.int64)
        _, self.inv, self.count = np.unique(key, return_inverse=True, return_counts=True)
        self.nb = len(self.count)
        self.keep = self.count >= 0.5 * np.median(self.count)
        self.n = int(self.keep.sum())

    def mean(self, x, valid=None):
        """Mean of the valid (default: finite) samples of ``x`` in every bin, and their
        count. [unit of x], [samples]"""
        valid = np.isfinite(x) if valid is None else valid
        num = np.bincount(self.inv, weights=np.where(valid, x, 0.0), minlength=self.nb)
        den = np.bincount(self.inv, weights=valid.astype(float), minlength=self.nb)
        with np.errstate(invalid="ignore", divide="ignore"):
            return num / den, den

    def take(self, x):
        """The kept bins of a per-bin array."""
        return x[self.keep]


class PowerLevel:
    """Measured electric power against the aircraft's physics model.

    Parameters
    ----------
    exps : list of (name, DataFrame)
        The experiments (flight record columns, docs/record.md).
    aircraft : Aircraft
    mass_kg : float or dict
        All-up mass at the start of every flight, or of each (experiment → mass). [kg]
    site_altitude_m : float
        Site altitude for the standard (ISA) density. [m]

    Notes
    -----
    Each experiment's flight phases, power and climb rate are those of
    :func:`planner.chain.flightstate.from_record` (on the experiment's own clock, from 0).
    Its airspeed and air density are not, for reasons of this level:

    * the level works on bin means, and averages each bin's ground-velocity *vector*
      (known where the course is logged or the ground speed is below 0.5 m/s) before
      the wind triangle, where ``from_record`` applies it sample by sample; and it keeps
      the ground velocity, which the ``wind`` effect fits a wind to;
    * the baseline flies the ISA density at the site altitude: the measured density is
      the driver of the ``air_density`` effect, tested against it. A driver must be
      measured, not filled in: the pressure (and the temperature) must cover 90 % of the
      bins, where ``from_record``, whose density is the model's input, takes any channel
      that covers half the samples (a measured density beats ISA as an input).
    """

    name = "power"
    unit = "W"

    def __init__(self, exps, aircraft, mass_kg, site_altitude_m: float = 0.0):
        self.aircraft = aircraft
        self.file_system_power_w = float(aircraft.system_power_w)
        per_flight = mass_kg if isinstance(mass_kg, dict) else None
        self.mass0 = (float(np.mean(list(per_flight.values()))) if per_flight
                      else float(mass_kg))
        self.notes: list[str] = []
        s, spans = self._airborne_samples(exps, site_altitude_m)
        self._choose_climb(s)
        self.n_experiments = len(self.names)
        self.split = make_split(spans)
        bins = _Bins(s, self.split, spans)
        self.bin_s = bins.width
        #: Median interval between the record's samples. [s]
        self.sample_interval_s = bins.med_dt
        self._bin_flight_state(s, bins)
        self._bin_air_density(s, bins, site_altitude_m)
        self.mass = np.full(bins.n, self.mass0)
        if per_flight:      # each flight at its own take-off mass
            of = np.array([float(per_flight.get(str(n), self.mass0)) for n in self.names])
            self.mass = of[self.exp]
            self.mass0 = float(np.mean(self.mass))
        self.n_rows = bins.n
        self._set_base_inputs(s, bins)
        self._set_shape()

    # ---------------------------------------------------------------- construction
    def _airborne_samples(self, exps, site_altitude_m: float):
        """The airborne samples of every experiment with 10 or more (other than ground,
        take-off and landing), stacked as columns; each experiment's airborne span; the ground
        power's 5th–95th percentiles (:attr:`ground_power_w`)."""
        self.names = []
        cols = {k: [] for k in ("exp", "t", "p", "gs", "course", "climb", "air", "wn", "we",
                                "pres", "temp", "alt_rate", "climb_smooth", "axial")}
        spans = []
        ground = []
        #: Each experiment's changes of flight mode, (time [s], old, new) (``mode``).
        self.mode_changes: dict[str, list] = {}
        for name, sub in exps:
            sub = sub.reset_index(drop=True)
            self.mode_changes[name] = mode_changes(sub)
            n = len(sub)
            t = sub["time_s"].to_numpy(float)
            t = t - t[0]
            state = from_record(sub.assign(time_s=t), site_altitude_m)
            p, phase, climb = state.measured_power_w, state.phase, state.climb_rate_ms
            ok = flown(phase) & np.isfinite(p)
            ground.append(p[(phase == "ground") & np.isfinite(p)])
            if ok.sum() < 10:
                self.notes.append(f"experiment {name}: no airborne samples, not used at the power "
                                  "level")
                continue
            e = len(self.names)
            self.names.append(name)
            spans.append((float(t[ok][0]), float(t[ok][-1])))
            rate, smooth = _altitude_rate(t, _finite_col(sub, "altitude_m", n), climb)
            for key, x in (("exp", np.full(ok.sum(), e)), ("t", t), ("p", p),
                           ("gs", np.abs(np.nan_to_num(_finite_col(sub, "groundspeed_ms", n)))),
                           ("course", _finite_col(sub, "course_deg", n)), ("climb", climb),
                           ("alt_rate", rate), ("climb_smooth", smooth),
                           ("air", _finite_col(sub, "airspeed_ms", n)),
                           ("axial", _finite_col(sub, "axial_speed_ms", n)),
                           ("wn", _finite_col(sub, "wind_n_ms", n)),
                           ("we", _finite_col(sub, "wind_e_ms", n)),
                           ("pres", interp_nan(t, _finite_col(sub, "pressure_pa", n))),
                           ("temp", interp_nan(t, _finite_col(sub, "ambient_temperature_c", n)))):
                cols[key].append(x if key == "exp" else x[ok])
        if not self.names:
            raise FitError("no airborne samples in the data")
        ground = np.concatenate(ground) if ground else np.zeros(0)
        #: Measured power on the ground (5th, 95th percentile), what is drawn with the
        #: rotors stopped or idle; None without enough ground samples. [W]
        self.ground_power_w = ((float(np.percentile(ground, 5)),
                                float(np.percentile(ground, 95)))
                               if ground.size >= MIN_GROUND_SAMPLES else None)
        return {k: np.concatenate(v) for k, v in cols.items()}, spans

    def _choose_climb(self, s: dict) -> None:
        """The logged climb rate, or the altitude's rate of change where the two disagree
        by more than :data:`MAX_CLIMB_DISAGREEMENT_MS` (module notes, "Climb rate")."""
        self.climb_source = "logged climb rate"
        #: RMS difference of the logged climb rate and the altitude's rate of change. [m/s]
        self.climb_disagreement_ms = _climb_disagreement(s["climb_smooth"], s["alt_rate"])
        if self.climb_disagreement_ms is not None and \
                self.climb_disagreement_ms > MAX_CLIMB_DISAGREEMENT_MS:
            has = np.isfinite(s["alt_rate"])
            s["climb"] = np.where(has, s["alt_rate"], s["climb"])
            self.climb_source = "rate of change of the logged altitude"
            self.notes.append(
                "power level: the logged climb rate (climb_rate_ms) disagrees with the rate of "
                f"change of the logged altitude by {self.climb_disagreement_ms:.2f} m/s RMS over "
                f"{CLIMB_WINDOW_S:g}-s windows (more than the "
                f"{MAX_CLIMB_DISAGREEMENT_MS:g} m/s that counts as a climb): the altitude is the "
                "direct measure of climbing, so the power model is driven by its rate of "
                "change instead")

    def _bin_flight_state(self, s: dict, bins: _Bins) -> None:
        """Bin means of the time, power, ground velocity, climb rate, airspeed and logged
        wind, and each bin's experiment, test unit and fold."""
        count, take, mean = bins.count, bins.take, bins.mean
        course = s["course"]
        # the ground velocity is known where the course is, and where the aircraft is
        # (nearly) still over ground whatever the course says
        known = np.isfinite(course) | (s["gs"] < STILL_MS)
        a = np.radians(np.where(np.isfinite(course), course, 0.0))
        vn, kn = mean(s["gs"] * np.cos(a), known)
        ve, _ = mean(s["gs"] * np.sin(a), known)
        self.count = count[bins.keep].astype(float)
        self.dt_bin = self.count * bins.med_dt
        self.exp = take(np.bincount(bins.inv, weights=s["exp"], minlength=bins.nb)
                        / count).round().astype(int)
        self.row_group = self.exp
        self.row_unit = take(np.bincount(bins.inv, weights=bins.unit, minlength=bins.nb)
                             / count).round().astype(int)
        self.row_fold = np.array([self.split.units[u].fold for u in self.row_unit])
        self.time = take(mean(s["t"])[0])
        self.measured = take(mean(s["p"])[0])
        self.gs = take(mean(s["gs"])[0])
        self.climb = take(mean(s["climb"])[0])
        self.course_known = take(kn) >= 0.5 * take(count.astype(float))
        self.vn = np.where(self.course_known, take(np.nan_to_num(vn)), 0.0)
        self.ve = np.where(self.course_known, take(np.nan_to_num(ve)), 0.0)
        self.course = np.degrees(np.arctan2(self.ve, self.vn)) % 360.0
        moving_samples = s["gs"] >= MOVING_MS
        self.has_course = bool(moving_samples.any() and
                               np.isfinite(course[moving_samples]).mean() > 0.5)
        self.moving = (self.gs >= MOVING_MS) & self.course_known
        air, na = mean(s["air"])
        self.airspeed_measured = bool(np.isfinite(s["air"]).mean() > 0.5)
        self.airspeed = take(np.where(na > 0, air, np.nan))
        wn, _ = mean(s["wn"])
        we, _ = mean(s["we"])
        self.has_logged_wind = bool(np.isfinite(s["wn"]).mean() > 0.5 and (
            np.nanmax(np.abs(s["wn"])) + np.nanmax(np.abs(s["we"])) > 0))
        self.logged_wind_n = take(np.nan_to_num(wn)) if self.has_logged_wind else 0.0
        self.logged_wind_e = take(np.nan_to_num(we)) if self.has_logged_wind else 0.0

    def _bin_air_density(self, s: dict, bins: _Bins, site_altitude_m: float) -> None:
        """The ISA density at the site (the baseline's) and the measured one of each bin
        (class notes): from pressure and temperature, else from the pressure at the ISA
        temperature of the pressure altitude; the ISA density without a pressure."""
        self.rho_std = np.full(bins.n, float(atmosphere.density(site_altitude_m)))
        pres, _ = bins.mean(s["pres"])
        temp, _ = bins.mean(s["temp"])
        pres, temp = bins.take(pres), bins.take(temp)
        self.has_pressure = bool(np.isfinite(pres).mean() > 0.9 and np.nanmin(pres) > 1000)
        self.has_air_temperature = bool(np.isfinite(temp).mean() > 0.9)
        if self.has_pressure:
            pres = _fill(pres)
            if self.has_air_temperature:
                rho = atmosphere.density(temperature_c=_fill(temp), pressure_pa=pres)
            else:
                h = atmosphere.pressure_altitude(pres)
                rho = atmosphere.density(h, pressure_pa=pres)
            self.rho_meas = np.asarray(rho, float)
        else:
            self.rho_meas = self.rho_std.copy()
        self.log_rho_ratio = np.log(self.rho_meas / self.rho_std)

    def _set_base_inputs(self, s: dict, bins: _Bins) -> None:
        """The baseline's inputs per bin: the airspeed (measured, else the ground velocity
        less the logged wind, else the ground speed), the climb rate, the ISA density and
        the mass; a multirotor flies its disks' axial and in-plane speed where the record
        has the velocity along the thrust axis (FlightState.rotor_velocities)."""
        if self.airspeed_measured:
            v = np.where(np.isfinite(self.airspeed), self.airspeed, self.gs)
        else:
            v = np.where(self.course_known, np.hypot(self.vn - self.logged_wind_n,
                                                     self.ve - self.logged_wind_e), self.gs)
        self.base_inputs = {"airspeed": np.abs(v), "climb": self.climb,
                            "air_density": self.rho_std, "mass": self.mass}
        axial, n_axial = bins.mean(s["axial"])
        self.rotor_axial = bool(self.aircraft.is_multirotor
                                and np.isfinite(s["axial"]).mean() > 0.5)
        if self.rotor_axial:
            ax = _fill(bins.take(np.where(n_axial > 0, axial, np.nan)))
            self.base_inputs["airspeed"] = inplane_speed(v, self.climb, ax)
            self.base_inputs["climb"] = ax
            self.notes.append("power level: the rotor model flies the disks' axial speed "
                              "(axial_speed_ms) and their in-plane speed")

    def _set_shape(self) -> None:
        """The baseline's shape parameters (start, low, high, scale: multirotor drag area
        [m²]; fixed-wing C_D0 and K) and how much the mechanical power varies over the
        bins (:attr:`load_variation`, unitless)."""
        aircraft = self.aircraft
        self._table = None
        self._warm: dict = {}
        self._shape_name = "drag_area_m2"
        if aircraft.is_multirotor:
            self.shape = {"drag_area_m2": (aircraft.multirotor.drag_area_m2, 0.0, 2.0, 0.01)}
        else:
            fw = aircraft.fixed_wing
            self.shape = {"cd0": (fw.cd0, 0.002, 0.3, 0.005), "k": (fw.k, 0.005, 0.5, 0.01)}
            self.v_min = fw.stall_speed_ms or 0.5 * fw.cruise_airspeed_ms
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            M0 = self.mechanical({k: v[0] for k, v in self.shape.items()}, self.base_inputs,
                                 np.arange(self.n_rows))
        self.load_variation = float(np.std(M0) / np.mean(M0)) if np.mean(M0) > 0 else 0.0

    # ---------------------------------------------------------------- model
    def _drag_table(self):
        """Cubic spline of the mechanical power against the drag area at the base inputs.

        The baseline and the effects that only add linear columns evaluate the rotor
        model at the measured inputs; only the drag area changes between evaluations, and
        the power is smooth in it: a spline through 9 drag areas replaces the model there
        (its error is checked against the model at a tenth point).
        """
        from scipy.interpolate import CubicSpline

        f0 = self.aircraft.multirotor.drag_area_m2
        top = max(0.3, 4.0 * f0)
        grid = np.linspace(0.0, top, 9)
        rows = np.arange(self.n_rows)
        M = np.array([self._model(self._shape_name, f, self.base_inputs, rows) for f in grid])
        spline = CubicSpline(grid, M, axis=0)
        check = 0.37 * top
        err = np.max(np.abs(spline(check) - self._model(self._shape_name, check,
                                                         self.base_inputs, rows)))
        return (spline, top) if err < 1e-3 * max(float(np.max(np.abs(M))), 1.0) else None

    def _model(self, name, value, inputs, rows):
        return self.mechanical({name: value}, inputs, rows, table=False)

    def mechanical(self, shape: dict[str, float], inputs: dict, rows: np.ndarray,
                   table: bool = True) -> np.ndarray:
        """Mechanical (shaft) power of the aircraft model at unit efficiency
        (:attr:`~planner.parameters.Aircraft.efficiency_key`: with ``rotor_losses`` the
        shaft power plus the motor losses) and no system load, with the ``shape``
        parameters, at the ``inputs`` of ``rows``; from
        the drag-area spline (:meth:`_drag_table`) where it holds. [W]"""
        if table and self.aircraft.is_multirotor and inputs is self.base_inputs:
            if self._table is None:
                self._table = self._drag_table() or False
            if self._table:
                spline, top = self._table
                f = shape[self._shape_name]
                if 0.0 <= f <= top:
                    return spline(f)[rows]
        ac = with_params(self.aircraft, {**shape, self.aircraft.efficiency_key: 1.0,
                                         "system_power_w": 0.0})
        v = inputs["airspeed"][rows]
        if not self.aircraft.is_multirotor:
            v = np.maximum(v, self.v_min)
        return np.asarray(ac.battery_power(v, inputs["climb"][rows],
                                           inputs["air_density"][rows], inputs["mass"][rows],
                                           disk_frame=getattr(self, "rotor_axial", False)),
                          float)

    def _inputs(self, effects, values, state) -> dict:
        inputs = self.base_inputs
        for e in effects:
            inputs = e.transform(inputs, values, self, state)
        return inputs

    def _spec(self, effects):
        spec = dict(self.shape)
        for e in effects:
            spec.update(e.start(self))
        lin = ["inverse_efficiency"] + [n for e in effects for n in e.linear]
        return spec, lin

    def _y(self, effects) -> np.ndarray:
        fixed = 0.0 if any(e.name == "system_power" for e in effects) else self.file_system_power_w
        return self.measured - fixed

    def _columns(self, M, effects, state):
        return np.column_stack([M] + [c for e in effects for c in e.columns(M, self, state)])

    def _evaluate(self, x, names, effects, state, rows):
        values = dict(zip(names, x))
        inputs = self._inputs(effects, values, state)
        shape = {k: values[k] for k in self.shape}
        if any(e.name == "speed_response" for e in effects):
            # the same state with no airspeed, for the speed response's column
            still = dict(inputs)
            still["airspeed"] = np.zeros_like(inputs["airspeed"])
            state["still_mechanical_w"] = self.mechanical(shape, still, rows, table=False)
        return self.mechanical(shape, inputs, rows)

    def fit(self, effects, train: np.ndarray, start: Fit | None = None) -> Fit:
        """Fit the power model with ``effects`` to the ``train`` bins: the shape and the
        effects' nonlinear parameters by least squares, 1/η and the linear coefficients
        at each step; a payload change is located first (module notes), a wind started
        from a grid of directions."""
        spec, lin = self._spec(effects)
        names = list(spec)
        x0 = np.array([spec[k][0] for k in names], float)
        lo = np.array([spec[k][1] for k in names], float)
        hi = np.array([spec[k][2] for k in names], float)
        scale = np.array([spec[k][3] for k in names], float)
        state: dict = {}
        reuse_steps = False
        tkey = hash(train.tobytes())
        warm = {k: self._warm[(tkey, k)] for k in names if (tkey, k) in self._warm}
        if start is not None:
            sv = start.values()
            x0 = np.array([sv.get(k, warm.get(k, x0[i])) for i, k in enumerate(names)])
            keep = ("reference_mechanical_w", "change_time_s", "step_mask", "regime_levels_w",
                    "unlocated_expectation")
            state.update({k: v for k, v in start.state.items() if k in keep})
            reuse_steps = "change_time_s" in start.state
        x0 = np.clip(x0, lo + 1e-9 * scale, hi - 1e-9 * scale)
        rows = np.flatnonzero(train)
        y_all = self._y(effects)
        y = y_all[rows]
        groups = self.exp[rows]
        if any(e.name == "efficiency_curve" for e in effects) and \
                "reference_mechanical_w" not in state:
            M = self._evaluate(x0, names, [e for e in effects if e.name != "payload_change"],
                               state, rows)
            state["reference_mechanical_w"] = float(np.median(M))
        cache: dict = {}

        def solve(x, st=state, thin=1):
            r_, y_ = (rows, y) if thin == 1 else (rows[::thin], y[::thin])
            M = self._evaluate(x, names, effects, st, r_)
            X = self._columns(M, effects, st)
            coef = _lstsq(X, y_)
            if thin == 1:
                cache["coef"], cache["M"] = coef, M
            return X @ coef - y_

        payload = next((e for e in effects if e.name == "payload_change"), None)
        if payload is not None and not reuse_steps:
            self._locate(payload, effects, names, x0, state, rows, y, groups, fixed_step=None)
            k = names.index("mass_step_kg")
            x0[k] = np.clip(state.pop("initial_step", 0.0), lo[k] + 1e-6, hi[k] - 1e-6)
        wind = any(e.name == "wind" for e in effects)
        starts = [x0]
        if wind and (start is None or "wind_n_ms" not in start.nl_names) and \
                "wind_n_ms" not in warm:
            starts = self._wind_grid(x0, names, solve)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            res = None
            for xs in starts:
                trial = least_squares(solve, np.clip(xs, lo, hi), bounds=(lo, hi),
                                      x_scale=scale, diff_step=1e-4, xtol=1e-5, ftol=1e-6,
                                      max_nfev=100)
                if res is None or trial.cost < res.cost:
                    res = trial
            x = res.x
            if payload is not None and not reuse_steps:  # locate again with the fit, refit
                k = names.index("mass_step_kg")
                solve(x)
                self._locate(payload, effects, names, x, state, rows, y, groups,
                             fixed_step=float(x[k]), coef=cache["coef"])
                res = least_squares(solve, x, bounds=(lo, hi), x_scale=scale, diff_step=1e-4,
                                    xtol=1e-5, ftol=1e-6, max_nfev=60)
                x = res.x
            r = solve(x)
        coef = cache["coef"]
        M = cache["M"]
        state["mechanical_range_w"] = (float(np.percentile(M, 5)), float(np.percentile(M, 95)))
        # later fits on the same training rows start effects' parameters from here
        self._warm.update({(tkey, k): float(v) for k, v in zip(names, x)
                           if k not in self.shape})
        return Fit(tuple(e.name for e in effects), names, x, lin, coef, train, r, state)

    def _wind_grid(self, x0, names, solve) -> list[np.ndarray]:
        """Start points for the wind: the best two of a grid of 8 directions × 3 speeds
        (and calm) that lie in different directions."""
        kn, ke = names.index("wind_n_ms"), names.index("wind_e_ms")
        trials = []
        for speed in (0.0, 3.0, 6.0, 10.0):
            for ang in (range(0, 360, 45) if speed > 0 else [0]):
                x = x0.copy()
                x[kn] = speed * math.cos(math.radians(ang))
                x[ke] = speed * math.sin(math.radians(ang))
                trials.append((float(np.sum(solve(x, thin=3) ** 2)), ang, x))
        trials.sort(key=lambda v: v[0])
        starts = [trials[0][2]]
        for rss, ang, x in trials[1:]:
            if abs((ang - trials[0][1] + 180) % 360 - 180) >= 45:
                starts.append(x)
                break
        return starts

    def _locate(self, payload, effects, names, x, state, rows, y, groups, fixed_step,
                coef=None, step_known=False):
        """Locate the change time in each experiment with training rows (see the module
        notes): on the residual of the model without the step, net of the climbs' and
        descents' own power levels, pooled over the flights and fitted with the step
        (:meth:`_regime_columns`); a held-out flight (``step_known``) takes the levels
        learned on the training flights."""
        base = [e for e in effects if e.name != "payload_change"]
        bnames = [k for k in names if k != "mass_step_kg"]
        xb = np.array([x[names.index(k)] for k in bnames])
        values = dict(zip(bnames, xb))
        st = {k: v for k, v in state.items() if k != "step_mask"}
        inputs = self._inputs(base, values, st)
        shape = {k: values[k] for k in self.shape}
        M = self.mechanical(shape, inputs, rows)
        X = self._columns(M, base, st)
        # residual of the model without the step: refitted at the start, else with the
        # coefficients of the full model (the payload effect adds no linear column)
        coef = _lstsq(X, y) if coef is None else coef
        r = y - X @ coef
        dm = 0.05 * self.mass0
        bumped = dict(inputs)
        bumped["mass"] = inputs["mass"] + dm
        s = (self.mechanical(shape, bumped, rows) - M) / dm * coef[0]
        names = tuple(k for k, regime in climb_regimes(self.climb).items()
                      if self.has_own_level(regime, rows))
        if step_known:
            # the training flights' levels, where the held-out flights are numerous enough
            # for the same regimes to have levels of their own; else the residual as it is
            learned = state.get("regime_levels_w", {})
            net = r
            if names and names == tuple(learned):
                net = r - self._regime_columns(rows, names) @ np.array(
                    [learned[k] for k in names], float)
            posterior: dict = {}
            change = self._scan(rows, net, s, groups, fixed_step, step_known, posterior)
        else:
            Z = self._regime_columns(rows, names)
            # the levels fitted beside each flight's own mass and, before any change is
            # located, the step's expected column under a change time uniform over the
            # flight (the airborne share of the flight elapsed × s): else the levels take
            # up the steps and no change is located (module notes, "Change points")
            own_mass = np.column_stack([np.where(groups == e, s, 0.0)
                                        for e in np.unique(groups)])
            ramp = self._elapsed_share(rows)
            step = ramp * s
            change: dict = {}
            for _ in range(LOCATE_ROUNDS):
                if not Z.shape[1]:
                    levels = np.zeros(0)
                    break
                levels = _lstsq(np.column_stack([Z, own_mass, step]), r)[:Z.shape[1]]
                posterior = {}
                found = self._scan(rows, r - Z @ levels, s, groups, fixed_step, step_known,
                                   posterior)
                if found == change:
                    break
                change = found
                located = np.isin(groups, [self.names.index(k) for k, v in change.items()
                                           if v is not None])
                step = np.where(located, self._step_mask_rows(change, rows),
                                self._expected_mask(posterior, rows)) * s
            net = r - Z @ levels
            posterior = {}
            change = self._scan(rows, net, s, groups, fixed_step, step_known, posterior)
            state["regime_levels_w"] = {k: float(v) for k, v in zip(names, levels)}
        times = dict(state.get("change_time_s", {}))
        times.update(change)
        state["change_time_s"] = times
        state["step_mask"] = self._step_mask(times)
        # a flight whose change is not located carries the change's expectation given its
        # record: the posterior probability that the change has happened (module notes)
        unlocated = {k: v for k, v in posterior.items() if change.get(k) is None}
        if step_known:
            state["change_posterior"] = unlocated
        else:
            state["unlocated_expectation"] = self._expected_mask(unlocated,
                                                                 np.arange(self.n_rows))
        if fixed_step is None:
            m = self._step_mask_rows(change, rows) > 0
            den = float(np.dot(s[m], s[m]))
            state["initial_step"] = float(np.dot(s[m], net[m])) / den if den > 0 else 0.0

    def _regime_columns(self, rows: np.ndarray, names) -> np.ndarray:
        """The indicator columns of the regimes ``names``
        (:func:`planner.chain.flightstate.climb_regimes`: the regimes a change is located
        net of, on the training flights each where it can have a power level of its own,
        :meth:`has_own_level`, as the detection limit takes them) among ``rows``."""
        regimes = climb_regimes(self.climb)
        cols = [regimes[k][rows].astype(float) for k in names]
        return np.column_stack(cols) if cols else np.zeros((rows.size, 0))

    def _elapsed_share(self, rows: np.ndarray) -> np.ndarray:
        """Share of its flight's span among ``rows`` elapsed at each of ``rows``: the
        expected indicator of a change whose time is uniform over the flight. [unitless]"""
        out = np.zeros(rows.size)
        for e in np.unique(self.exp[rows]):
            m = self.exp[rows] == e
            t = self.time[rows][m]
            out[m] = (t - t.min()) / max(float(t.max() - t.min()), 1e-9)
        return out

    def _step_mask_rows(self, change: dict, rows: np.ndarray) -> np.ndarray:
        """1 on the ``rows`` at or after their flight's located change time, else 0."""
        out = np.zeros(rows.size)
        for name, tc in change.items():
            if tc is not None:
                m = (self.exp[rows] == self.names.index(name)) & (self.time[rows] >= tc)
                out[m] = 1.0
        return out

    def _scan(self, rows, r, s, groups, fixed_step, step_known=False, posterior=None
              ) -> dict[str, float | None]:
        """Each flight's change time among ``rows`` (None where none beats the threshold,
        module notes); where ``posterior`` is a dict, each flight's posterior distribution
        of its change time is put there too (:meth:`_change_posterior`)."""
        out: dict[str, float | None] = {}
        per: dict[int, tuple] = {}
        variance: dict[int, float] = {}       # each flight's long-run residual variance
        for e in np.unique(groups):
            m = np.flatnonzero(groups == e)
            n = len(m)
            lo = max(3, int(0.05 * n))
            hi = n - max(3, int(0.05 * n))
            if hi <= lo:
                out[self.names[e]] = None
                continue
            # against a mass that differs for the whole flight: the step's column
            # s·1{t ≥ t_c} and the residual are both taken net of the flight's own
            # constant-mass column s (projection), so that a step explains only a change
            # within the flight, never a flight flown heavier or lighter than the given
            # mass (module notes)
            sm, rm = s[m], r[m]
            ss = float(np.dot(sm, sm))
            if ss <= 0:
                out[self.names[e]] = None
                continue
            rp = rm - sm * (float(np.dot(sm, rm)) / ss)
            num = np.cumsum((sm * rp)[::-1])[::-1]
            den_raw = np.cumsum((sm**2)[::-1])[::-1]
            den = den_raw - den_raw**2 / ss
            # a change point must beat a BIC-like threshold: 2 ln(n) times the residual
            # variance inflated for autocorrelation (else noise always "finds" one)
            # (per fitted parameter ln(n): the time and the size; only the time when the
            # size was learned on other flights, step_known)
            variance[e] = stats.step_robust_long_run_variance(rp)
            penalty = (1.0 if step_known else 2.0) * math.log(n) * variance[e]
            per[e] = (m, num, den, lo, hi, penalty)
        step = fixed_step
        for it in range(3 if fixed_step is None else 1):
            if step is None:
                chosen = {}
                for e, (m, num, den, lo, hi, _) in per.items():
                    red = num[lo:hi] ** 2 / np.maximum(den[lo:hi], 1e-12)
                    chosen[e] = lo + int(np.argmax(red))
                tot_n = sum(per[e][1][j] for e, j in chosen.items())
                tot_d = sum(per[e][2][j] for e, j in chosen.items())
                step = tot_n / tot_d if tot_d > 0 else 0.0
            for e, (m, num, den, lo, hi, penalty) in per.items():
                red = 2 * step * num[lo:hi] - step**2 * den[lo:hi]
                j = int(np.argmax(red))
                out[self.names[e]] = float(self.time[rows[m[lo + j]]]) if red[j] > penalty \
                    else None
            if fixed_step is None and it < 2:
                tot_n = tot_d = 0.0
                for e, (m, num, den, lo, hi, _) in per.items():
                    tc = out[self.names[e]]
                    if tc is not None:
                        j = int(np.searchsorted(self.time[rows[m]], tc))
                        tot_n += num[j]
                        tot_d += den[j]
                step = tot_n / tot_d if tot_d > 0 else step
        if posterior is not None:
            for e in np.unique(groups):
                if e in per:
                    m, num, den = per[e][:3]
                    posterior[self.names[e]] = self._change_posterior(
                        self.time[rows[m]], 2 * step * num - step**2 * den, variance[e])
                else:                           # too short to say: the uniform prior
                    m = np.flatnonzero(groups == e)
                    posterior[self.names[e]] = self._change_posterior(
                        self.time[rows[m]], np.zeros(m.size), 1.0)
        return out

    @staticmethod
    def _change_posterior(times: np.ndarray, reduction: np.ndarray, variance: float
                          ) -> tuple[np.ndarray, np.ndarray]:
        """A flight's change time given its record: the candidate times (its bins) and
        the probability that the change has happened by each (module notes, "Change
        points"). Uniform prior over the bins; the likelihood of a change at bin j is
        :math:`\\exp(\\Delta_j / 2\\sigma^2)`, with :math:`\\Delta_j` the drop of the squared
        error the step makes there (net of the flight's constant mass) and
        :math:`\\sigma^2` the residual's long-run variance. [s], [unitless]"""
        if not (variance > 0 and np.isfinite(variance)):
            w = np.ones(reduction.size)
        else:
            z = reduction / (2.0 * variance)
            w = np.exp(z - np.max(z))
        return times, np.cumsum(w) / np.sum(w)

    def _expected_mask(self, posterior: dict, rows: np.ndarray) -> np.ndarray:
        """The probability that each of ``rows`` lies after its flight's change, from the
        flights' posteriors (:meth:`_change_posterior`; 0 in flights without one)."""
        out = np.zeros(rows.size)
        for name, (tj, cdf) in posterior.items():
            m = self.exp[rows] == self.names.index(name)
            if not m.any():
                continue
            j = np.searchsorted(tj, self.time[rows][m], side="right") - 1
            out[m] = np.where(j >= 0, cdf[np.clip(j, 0, None)], 0.0)
        return out

    def _step_mask(self, times: dict) -> np.ndarray:
        """1 on every bin at or after its flight's change time in ``times``, else 0."""
        return self._step_mask_rows(times, np.arange(self.n_rows))

    def predict(self, fit: Fit, effects, rows: np.ndarray) -> np.ndarray:
        """Predicted electric power of the bins ``rows``. [W]"""
        M = self._evaluate(fit.nl, fit.nl_names, effects, fit.state, rows)
        X = self._columns(M, effects, fit.state)
        fixed = 0.0 if any(e.name == "system_power" for e in effects) else \
            self.file_system_power_w
        return X @ fit.coef + fixed

    def prepare_heldout(self, fit: Fit, effects, heldout: np.ndarray) -> None:
        """Locate the change time of held-out whole flights by cross-fitting.

        A held-out flight's change time is a per-flight parameter: it must not be found on
        the samples that score it. Its bins are split into two interleaved halves; the
        change time located on one half (with the mass step learned on the training
        flights) sets the mass of the other half, and the other way round.
        """
        payload = next((e for e in effects if e.name == "payload_change"), None)
        if payload is None:
            return
        rows = np.flatnonzero(heldout)
        new = [e for e in np.unique(self.exp[rows]) if self.names[e] not in
               fit.state.get("change_time_s", {})]
        if not new:
            return
        rows = rows[np.isin(self.exp[rows], new)]
        k = fit.nl_names.index("mass_step_kg")
        y_all = self._y(effects)
        # position of each bin within its flight: even and odd bins are the two halves
        position = np.zeros(rows.size, int)
        for e in new:
            m = self.exp[rows] == e
            position[m] = np.arange(m.sum())
        mask = np.array(fit.state.get("step_mask", np.zeros(self.n_rows)), float)
        for half in (0, 1):
            locate, apply = rows[position % 2 == half], rows[position % 2 != half]
            st = {key: v for key, v in fit.state.items() if key != "step_mask"}
            st["change_time_s"] = {}
            self._locate(payload, effects, fit.nl_names, fit.nl, st, locate, y_all[locate],
                         self.exp[locate], fixed_step=float(fit.nl[k]), coef=fit.coef,
                         step_known=True)
            times = st["change_time_s"]
            expected = self._expected_mask(st.get("change_posterior", {}), apply)
            for e in new:
                tc = times.get(self.names[e])
                on = self.exp[apply] == e
                m = apply[on]
                # not located: the change's expectation given the half it was looked for
                # on, as for a training flight
                mask[m] = expected[on] if tc is None else (self.time[m] >= tc).astype(float)
        fit.state["step_mask"] = mask

    def heldout(self, fit: Fit, effects, fold: int) -> dict[str, Any]:
        """Held-out residuals of one fold [W] and the final (energy) errors of its
        segments ``(|E − Ê|, E)`` [W s]."""
        rows = np.flatnonzero(self.row_fold == fold)
        pred = self.predict(fit, effects, rows)
        r = self.measured[rows] - pred
        finals = []
        for key in np.unique(self.row_unit[rows] if not self.split.whole_experiments
                             else self.exp[rows]):
            m = (self.row_unit[rows] == key) if not self.split.whole_experiments else \
                (self.exp[rows] == key)
            e_meas = float(np.sum(self.measured[rows][m] * self.dt_bin[rows][m]))
            e_pred = float(np.sum(pred[m] * self.dt_bin[rows][m]))
            if e_meas > 0:
                finals.append((abs(e_meas - e_pred), e_meas))
        return {"rows": rows, "row_resid": r, "samples": rows, "sample_resid": r,
                "finals": finals, "predicted": pred, "loss_units": self.row_unit[rows],
                "loss": r**2}

    def _jacobian(self, fit: Fit, effects, rows: np.ndarray):
        """Change of the predicted power of ``rows`` per unit of each parameter
        [nonlinear…, linear…], and the residual (model − measured) there. [W per unit], [W]"""
        y = self._y(effects)[rows]
        M = self._evaluate(fit.nl, fit.nl_names, effects, fit.state, rows)
        X = self._columns(M, effects, fit.state)
        r0 = X @ fit.coef - y
        cols = []
        for j in range(len(fit.nl)):
            hi = self._spec(effects)[0][fit.nl_names[j]][2]
            h = 1e-4 * max(abs(fit.nl[j]), 0.01)
            x = fit.nl.copy()
            x[j] = x[j] + h if x[j] + h <= hi else x[j] - h
            step = x[j] - fit.nl[j]
            Mj = self._evaluate(x, fit.nl_names, effects, fit.state, rows)
            cols.append((self._columns(Mj, effects, fit.state) @ fit.coef - y - r0) / step)
        return np.column_stack(cols + [X[:, j] for j in range(X.shape[1])]), r0

    def jacobian(self, fit: Fit, effects) -> np.ndarray:
        """Change of the predicted power of every bin per unit of each fitted parameter
        [nonlinear…, linear…] of ``fit``. [W per unit]"""
        return self._jacobian(fit, effects, np.arange(self.n_rows))[0]

    def signature(self, fit: Fit, effects, effect) -> np.ndarray:
        """Change of the predicted power of every bin per unit of ``effect``'s parameters
        (at no effect), on the model ``fit`` of ``effects``: a column per parameter (wind:
        north and east [W per m/s]; air density: per unit of the exponent; system power:
        per W; efficiency curve: per unit of the slope coefficient c₁; payload change: per
        kg of mass all flight long — the step is cut from it by the caller)."""
        rows = np.arange(self.n_rows)
        values = dict(zip(fit.nl_names, fit.nl))
        state = dict(fit.state)
        inputs = self._inputs(effects, values, state)
        shape = {k: values[k] for k in self.shape}
        M = self.mechanical(shape, inputs, rows, table=False)
        inv_eta = float(fit.coef[0])
        name = effect.name
        if name == "system_power":
            return np.ones((self.n_rows, 1))
        if name == "efficiency_curve":
            return (M * (M / float(np.median(M)) - 1.0))[:, None]
        if name == "payload_change":
            dm = 0.01 * self.mass0
            bumped = dict(inputs)
            bumped["mass"] = inputs["mass"] + dm
            return ((self.mechanical(shape, bumped, rows, table=False) - M) / dm
                    * inv_eta)[:, None]
        cols = []
        for key, h in (("wind_n_ms", 0.5), ("wind_e_ms", 0.5)) if name == "wind" else \
                (("density_exponent", 0.05),):
            trial = dict(values)
            trial.update({"wind_n_ms": 0.0, "wind_e_ms": 0.0, "density_exponent": 0.0})
            lo = effect.transform(inputs, trial, self, state)
            trial[key] = h
            hi = effect.transform(inputs, trial, self, state)
            m_lo = self.mechanical(shape, lo, rows, table=False)
            m_hi = self.mechanical(shape, hi, rows, table=False)
            cols.append((m_hi - m_lo) / h * inv_eta)
        return np.column_stack(cols)

    def descent_misfit(self, fit: Fit, effects) -> dict[str, float] | None:
        r"""How far the model ``fit`` of ``effects`` misses a multirotor's vertical descents
        (bins of :func:`planner.chain.flightstate.vertical_descent`: still over ground and
        descending as the flight phases count it),
        or None (not a multirotor, or fewer than :data:`MIN_DESCENT_FLIGHTS` flights with
        such bins).

        In slow axial descent, :math:`-2 \le v_c/v_h < 0`, momentum theory does not hold
        (vortex-ring and turbulent-wake states); the rotor model takes Leishman's empirical
        induced velocity there, a fit through widely scattered measurements (Leishman,
        *Principles of Helicopter Aerodynamics*, 2nd ed., 2006, §2.14), which puts the
        power of a 1 m/s descent near the hover's. Each flight's mean residual over its
        vertical descent bins is one value; returned: their mean ``misfit_w`` (measured −
        model) and its standard error over the flights ``stderr_w`` [W], the descents'
        mean measured power ``power_w`` [W] and rate ``rate_ms`` [m/s], ``flights`` and
        ``bins``. On route R1 of the DJI M100 data (Rodrigues et al. 2021) every flight
        ends with such a descent at 1–2 m/s, drawn some 20–25 W (4–5 %) below the
        calibrated model: an effect that lowers the power from there on (a payload
        released late) takes it up.
        """
        if not self.aircraft.is_multirotor:
            return None
        vertical = vertical_descent(self.gs, self.climb)
        flights, e_of = np.unique(self.exp[vertical], return_inverse=True)
        if flights.size < MIN_DESCENT_FLIGHTS:
            return None
        rows = np.flatnonzero(vertical)
        resid = self.measured[rows] - self.predict(fit, effects, rows)
        per_flight = np.bincount(e_of, weights=resid) / np.bincount(e_of)
        return {"misfit_w": float(per_flight.mean()),
                "stderr_w": float(per_flight.std(ddof=1) / math.sqrt(flights.size)),
                "power_w": float(self.measured[rows].mean()),
                "rate_ms": float(-self.climb[rows].mean()),
                "flights": int(flights.size), "bins": int(rows.size)}

    def descent_shift(self, fit: Fit, jacobian, key: str = "mass_step_kg"
                      ) -> tuple[float, float] | None:
        r"""How far the parameter ``key`` of the all-data ``fit`` moves when the vertical
        descents (:func:`planner.chain.flightstate.vertical_descent`) get a power level of
        their own, and the bias that shift shows (module notes, "Change points";
        :meth:`regime_shift`); None where fewer than :data:`MIN_DESCENT_FLIGHTS` flights
        descend vertically (or not a multirotor). ``jacobian``: the fit's (Jacobian,
        residual) on its training rows (:meth:`_jacobian`). [unit of the parameter]"""
        if not self.aircraft.is_multirotor or key not in fit.nl_names:
            return None
        direction = np.zeros(len(fit.nl))
        direction[list(fit.nl_names).index(key)] = 1.0
        return self.regime_shift(fit, jacobian, vertical_descent(self.gs, self.climb),
                                 direction)

    def step_read(self, fit: Fit, jacobian) -> tuple[float, float, int, bool] | None:
        r"""The mass step of the all-data ``fit`` read where nothing but the step's own
        flights and its own size carry it (module notes, "Change points"): one
        Gauss-Newton step from the fit on the training bins of the flights whose change is
        located, with a power level of the vertical descents' own beside the parameters
        (:func:`planner.chain.flightstate.vertical_descent`, on a multirotor whose located
        flights have such a level: :meth:`has_own_level`). Returned: how far the step
        moves [kg], its variance there (the larger of the AR(1) one and the
        flight-clustered sandwich's, as in :meth:`physical`) [kg²], the flights it is read
        on, and whether the descents have their level. None where fewer than
        :data:`MIN_DESCENT_FLIGHTS` flights have a located change, where the descents have
        a level of their own over all the flights but not over the located ones (the
        step is then read as fitted, with the descents' bias in its error:
        :meth:`descent_shift`), or where every flight is located and none descends.

        The fit on every flight is the efficient estimate were the model right in the
        descents and each unlocated flight's change where its expectation puts it; this one
        is consistent whether or not they hold (Hausman, *Econometrica* 46, 1251, 1978)."""
        if "mass_step_kg" not in fit.nl_names:
            return None
        rows = np.flatnonzero(fit.train)
        J, r0 = jacobian
        groups = self.exp[rows]
        located = np.isin(groups, [self.names.index(k) for k in fit.located_changes()])
        flights = int(np.unique(groups[located]).size)
        if flights < MIN_DESCENT_FLIGHTS:
            return None
        X, descents = J, False
        if self.aircraft.is_multirotor:
            regime = vertical_descent(self.gs, self.climb)
            if self.has_own_level(regime, rows):
                if not self.has_own_level(regime, rows[located]):
                    return None
                X, descents = np.column_stack([J, regime[rows].astype(float)]), True
        if located.all() and not descents:
            return None
        u = np.zeros(X.shape[1])
        u[list(fit.nl_names).index("mass_step_kg")] = 1.0
        step, v = _gauss_newton_along(X[located], r0[located], groups[located], u)
        return step, v, flights, descents

    def read_step(self, fit: Fit, effects) -> float:
        """The step of ``fit`` (a model of ``effects`` with a payload change) as a named
        step is read (:meth:`step_read`, on its located flights): the fitted step plus the
        read's move, or the fitted step where the read cannot be made. [kg]"""
        step = float(fit.values()["mass_step_kg"])
        read = self.step_read(fit, self._jacobian(fit, effects, np.flatnonzero(fit.train)))
        return step if read is None else step + float(read[0])

    def hover_shift(self, fit: Fit, jacobian) -> tuple[float, float] | None:
        r"""How far the speed of the fitted wind moves when the bins in which the aircraft
        hovers or moves only vertically (ground speed below :data:`MOVING_MS`, the ground
        velocity known) get a power level of their own, and the bias that shift shows
        (module notes, "Wind"; :meth:`regime_shift`); None without a fitted wind, on a
        fixed wing, or where fewer than :data:`MIN_DESCENT_FLIGHTS` flights hover.
        ``jacobian``: as :meth:`descent_shift`. [m/s]"""
        direction = _wind_direction(fit, len(fit.nl))
        if not self.aircraft.is_multirotor or direction is None:
            return None
        return self.regime_shift(fit, jacobian, self.hovering(), direction)

    def has_own_level(self, regime: np.ndarray, rows: np.ndarray | None = None) -> bool:
        """Whether the bins of ``regime`` (a boolean per bin) among ``rows`` (default: all)
        can get a power level of their own (:meth:`regime_shift`, and the detection
        limits' nuisance regimes): :data:`MIN_DESCENT_FLIGHTS` flights or more have such
        bins, and not every bin is one."""
        rows = np.arange(self.n_rows) if rows is None else rows
        inside = regime[rows]
        return bool(not inside.all()
                    and np.unique(self.exp[rows][inside]).size >= MIN_DESCENT_FLIGHTS)

    def hovering(self) -> np.ndarray:
        """The bins in which the aircraft hovers or moves only vertically: its ground
        velocity known and below :data:`MOVING_MS` (a wind sets the airspeed there, the
        model's power at low airspeed its effect: module notes, "Wind")."""
        return self.course_known & (self.gs < MOVING_MS)

    def regime_shift(self, fit: Fit, jacobian, regime: np.ndarray, direction: np.ndarray
                     ) -> tuple[float, float] | None:
        r"""How far the combination ``direction`` · (nonlinear parameters) of the all-data
        ``fit`` moves when the bins of ``regime`` (a boolean per bin) get a power level of
        their own, and the bias that shift shows; None where fewer than
        :data:`MIN_DESCENT_FLIGHTS` training flights have such bins, or all bins are in it.

        The shift :math:`\Delta` is one Gauss-Newton step from the fit with and without the
        regime's indicator column beside the parameters. Were the model's power in that
        regime right, :math:`\Delta` would be noise only, of variance
        :math:`V_1 - V_0` (the variances of the combination with and without the column:
        the efficient estimate against a consistent one, Hausman 1978); the bias is
        estimated as :math:`\sqrt{\max(\Delta^2 - (V_1 - V_0), 0)}`. Each variance is the
        larger of the AR(1) one and the flight-clustered sandwich's, as in
        :meth:`physical`.
        """
        rows = np.flatnonzero(fit.train)
        inside = regime[rows]
        if not self.has_own_level(regime, rows):
            return None
        J, r0 = jacobian
        groups = self.exp[rows]
        u = np.r_[np.asarray(direction, float), np.zeros(J.shape[1] - len(direction))]

        step0, v0 = _gauss_newton_along(J, r0, groups, u)
        step1, v1 = _gauss_newton_along(np.column_stack([J, inside.astype(float)]), r0,
                                        groups, u)
        shift = step1 - step0
        return shift, math.sqrt(max(shift**2 - max(v1 - v0, 0.0), 0.0))

    def speed_read(self, fit: Fit, effects) -> tuple[float, float, dict, dict] | None:
        r"""The model ``fit`` of ``effects`` fitted once more with a free scale :math:`k` on
        its change of power with airspeed (:class:`~planner.identify.diagnose.effects.SpeedResponse`,
        module notes, "Wind"), started from it on its training bins: :math:`k`
        [unitless], its standard error, and that fit's physical values and errors
        (:meth:`physical`). None on a fixed wing, where fewer than
        :data:`MIN_DESCENT_FLIGHTS` training flights move (ground speed at least
        :data:`MOVING_MS`), or where the fit fails. Read once per fit and effects (kept in
        the fit's state): the wind's parameters and the level's note both ask for it."""
        key = ("speed_read", tuple(e.name for e in effects))
        if key not in fit.state:
            fit.state[key] = self._speed_read(fit, effects)
        return fit.state[key]

    def _speed_read(self, fit: Fit, effects) -> tuple[float, float, dict, dict] | None:
        from planner.identify.diagnose.effects import SpeedResponse

        if not self.aircraft.is_multirotor:
            return None
        rows = np.flatnonzero(fit.train)
        moving = self.gs[rows] >= MOVING_MS
        if np.unique(self.exp[rows][moving]).size < MIN_DESCENT_FLIGHTS:
            return None
        free = list(effects) + [SpeedResponse()]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                joint = self.fit(free, fit.train, start=fit)
                jv, js = self.physical(joint, free)
        except (FitError, ModelError, np.linalg.LinAlgError, ValueError):
            return None
        k, sk = jv.get("speed_response", math.nan), js.get("speed_response", math.nan)
        if not (math.isfinite(k) and math.isfinite(sk)):
            return None
        return k, sk, jv, js

    def covariances(self, fit: Fit, jacobian):
        """Covariances of [nonlinear…, linear…] of an all-data fit, with those values:
        AR(1)-inflated within each flight and the flight-clustered sandwich, None with
        fewer than :data:`planner.identify.stats.MIN_CLUSTERS` flights
        (:func:`_covariance_pair`). ``jacobian``: the fit's (Jacobian, residual) on its
        training rows (:meth:`_jacobian`)."""
        J, r0 = jacobian
        ar1, clustered = _covariance_pair(J, r0, self.exp[np.flatnonzero(fit.train)])
        return ar1, np.r_[fit.nl, fit.coef], clustered

    def placebo_steps(self, fit: Fit, effects) -> np.ndarray:
        r"""Mass steps [kg] that the residual of the model ``fit`` of ``effects`` (a payload
        change among them, located) makes by itself at other times of the same flights:
        the placebo estimates of the step's size (module notes, "Change points").

        At each fraction :data:`PLACEBO_POSITIONS` of every located flight's airborne span
        (bins within :data:`PLACEBO_EXCLUSION` of the span from the flight's own change
        time take no placebo), the residual net of each flight's mean is regressed on the
        placebo step's column :math:`s\,1\{t \ge t_p\}` (:math:`s` the power's change
        per kg of mass) beside the located step's own, both net of each flight's mean;
        the placebo's coefficient is a mass step where none was located. Empty where there
        are fewer than :data:`MIN_PLACEBOS` positions."""
        times = fit.located_changes()
        mask = fit.state.get("step_mask")
        payload = next((e for e in effects if e.name == "payload_change"), None)
        if payload is None or mask is None or not times:
            return np.empty(0)
        located = np.array([self.names.index(k) for k in times])
        rows = np.flatnonzero(np.isin(self.exp, located))
        exp, t = self.exp[rows], self.time[rows]
        sens = self.signature(fit, effects, payload)[rows, 0]
        resid = self.measured[rows] - self.predict(fit, effects, rows)
        first = np.array([t[exp == e].min() for e in located])
        span = np.array([t[exp == e].max() for e in located]) - first
        change = np.array([times[self.names[e]] for e in located])
        pos = np.full(self.n_experiments, -1)
        pos[located] = np.arange(located.size)
        k = pos[exp]                            # each row's flight in ``located``
        y = stats.within_groups(resid, exp)
        step = stats.within_groups(sens * np.asarray(mask, float)[rows], exp)
        out = []
        for f in PLACEBO_POSITIONS:
            tp = first + f * span
            far = np.abs(tp - change) > PLACEBO_EXCLUSION * span
            col = stats.within_groups(sens * (t >= tp[k]) * far[k], exp)
            if not far.any() or float(np.dot(col, col)) <= 0:
                continue
            coef, *_ = np.linalg.lstsq(np.column_stack([step, col]), y, rcond=None)
            out.append(float(coef[1]))
        return np.array(out) if len(out) >= MIN_PLACEBOS else np.empty(0)

    def physical(self, fit: Fit, effects) -> tuple[dict[str, float], dict[str, float]]:
        """The shape parameters, the efficiency η (unitless) and each effect's
        parameters in physical units, with standard errors (delta method): each the
        larger of the AR(1) one and the flight-clustered sandwich's (module notes,
        "Selection statistics")."""
        jacobian = self._jacobian(fit, effects, np.flatnonzero(fit.train))
        cov, x, clustered = self.covariances(fit, jacobian)
        k = len(fit.nl)
        names = list(fit.nl_names) + ["efficiency"]
        extra = [n for e in effects for n in e.linear]
        eff_curve = "efficiency_slope_coefficient" in extra

        def conv(v):
            out = list(v[:k])
            a = v[k]
            out.append(1.0 / a)
            for i, n in enumerate(extra):
                c = v[k + 1 + i]
                if n == "efficiency_slope_coefficient":
                    out += [1.0 / a, -c / a**2]
                elif n == "speed_response_coefficient":
                    out.append(1.0 + c / a)         # the scale k (SpeedResponse)
                else:
                    out.append(c)
            return out

        for n in extra:
            names += (["efficiency_at_reference", "efficiency_slope"]
                      if n == "efficiency_slope_coefficient" else
                      ["speed_response"] if n == "speed_response_coefficient" else [n])
        vals, se = stats.delta_method(conv, x, cov)
        if clustered is not None:
            se = np.fmax(se, stats.delta_method(conv, x, clustered)[1])
        values = dict(zip(names, map(float, vals)))
        stderr = dict(zip(names, map(float, se)))
        if eff_curve:
            values.setdefault("efficiency", values["efficiency_at_reference"])
        placebo = self.placebo_steps(fit, effects) if "mass_step_kg" in values else ()
        if len(placebo):
            # the step's standard error is the larger of the fit's and the placebo steps'
            # spread (module notes, "Change points")
            values["mass_step_kg_fit_stderr"] = stderr["mass_step_kg"]
            values["mass_step_kg_placebo_sd"] = float(np.sqrt(np.mean(placebo**2)))
            values["placebo_positions"] = float(len(placebo))
            stderr["mass_step_kg"] = max(stderr["mass_step_kg"],
                                         values["mass_step_kg_placebo_sd"])
        read = self.step_read(fit, jacobian) if "mass_step_kg" in values else None
        descent = None
        if read is not None:
            # the step its located flights show, net of the descents' own level (module
            # notes, "Change points"); its error the larger of that fit's and the placebos'
            values["mass_step_kg_pooled"] = values["mass_step_kg"]
            values["mass_step_kg_pooled_stderr"] = stderr["mass_step_kg"]
            values["mass_step_kg"] += read[0]
            values["mass_step_kg_read_flights"] = float(read[2])
            values["mass_step_kg_read_descent_level"] = float(read[3])
            values["mass_step_kg_fit_stderr"] = math.sqrt(read[1])
            stderr["mass_step_kg"] = max(math.sqrt(read[1]),
                                         values.get("mass_step_kg_placebo_sd", 0.0))
        elif "mass_step_kg" in values:
            descent = self.descent_shift(fit, jacobian)
        if descent is not None:
            # ... and the bias the vertical descents' misfit can put into it (module notes)
            values["mass_step_kg_descent_shift"], values["mass_step_kg_descent_bias"] = descent
            stderr["mass_step_kg"] = math.hypot(stderr["mass_step_kg"], descent[1])
        hover = self.hover_shift(fit, jacobian) if "wind_n_ms" in values else None
        if hover is not None:
            # ... and the bias the model's power in the hover puts into a wind's speed
            # (module notes, "Wind"); the wind effect adds it to the speed's error
            values["wind_speed_ms_hover_shift"], values["wind_speed_ms_hover_bias"] = hover
        read = self.speed_read(fit, effects) if "wind_n_ms" in values and \
            not any(e.name == "speed_response" for e in effects) else None
        if read is not None:
            from planner.identify.diagnose.effects import speed_scale

            # the flights' own change of power with airspeed (module notes, "Wind"): where
            # it differs from the model's, the wind is the one fitted with it free
            k, sk, jv, js = read
            values["wind_speed_ms_model"] = math.hypot(values["wind_n_ms"], values["wind_e_ms"])
            scale = speed_scale(k, sk)
            if math.isfinite(scale) and scale != 1.0:
                for key in ("wind_n_ms", "wind_e_ms"):
                    values[key], stderr[key] = jv[key], js[key]
                for key in ("wind_speed_ms_hover_shift", "wind_speed_ms_hover_bias"):
                    values.pop(key, None)
                    if key in jv:
                        values[key] = jv[key]
            values["speed_response"], values["speed_response_stderr"] = k, sk
        groups = self.exp[np.flatnonzero(fit.train)]
        for e in effects:
            # how many flights carry each effect's estimate, and whether its error is the
            # flight-clustered one (module notes, "Selection statistics")
            a = self._key_direction(fit, effects, e, jacobian[0].shape[1])
            if a is None:
                continue
            values[f"effective_flights[{e.name}]"] = stats.effective_clusters(
                jacobian[0], a, groups)
            values[f"clustered_error[{e.name}]"] = float(
                clustered is not None
                and _variance_along(clustered, a) > _variance_along(cov, a))
        return values, stderr

    def _key_direction(self, fit: Fit, effects, effect, width: int) -> np.ndarray | None:
        """The direction of ``effect``'s key estimate among the fit's [nonlinear…,
        linear…] parameters: along the fitted wind for a wind, else its key parameter (or
        its first linear column); None where it has none."""
        names = list(fit.nl_names) + ["inverse_efficiency"] + \
            [n for e in effects for n in e.linear]
        if effect.name == "wind":
            return _wind_direction(fit, width)
        key = effect.key if effect.key in names else (effect.linear or (None,))[0]
        if key not in names:
            return None
        a = np.zeros(width)
        a[names.index(key)] = 1.0
        return a

    def confounders(self) -> list[tuple[str, np.ndarray]]:
        """What an effect's driver must not follow (per bin): the time since the start and
        the energy drawn so far in the flight."""
        energy = np.zeros(self.n_rows)
        for e in range(self.n_experiments):
            m = self.exp == e
            energy[m] = np.cumsum(self.measured[m] * self.dt_bin[m])
        return [("the time since the start", self.time), ("the energy drawn so far", energy)]

    def row_driver_residual(self, resid: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Held-out bin residual, as it is: an excess power. [W]"""
        return resid


def _wind_direction(fit: Fit, width: int) -> np.ndarray | None:
    """The unit vector along the fitted wind among the first ``width`` of the fit's
    [nonlinear…, linear…] parameters (the wind's north and east components); None
    without a wind or with a calm one."""
    names = list(fit.nl_names)
    if "wind_n_ms" not in names:
        return None
    kn, ke = names.index("wind_n_ms"), names.index("wind_e_ms")
    speed = math.hypot(fit.nl[kn], fit.nl[ke])
    if speed <= 0.0:
        return None
    a = np.zeros(width)
    a[kn], a[ke] = fit.nl[kn] / speed, fit.nl[ke] / speed
    return a


def _variance_along(cov: np.ndarray, a: np.ndarray) -> float:
    r"""The variance :math:`a^\mathsf{T} C a` of the combination ``a`` of parameters with
    covariance ``cov``, over the parameters ``a`` weighs only (an infinite variance of
    one it does not weigh stays out). [unit of the combination squared]"""
    on = np.flatnonzero(a)
    return float(a[on] @ cov[np.ix_(on, on)] @ a[on])


def _gauss_newton_along(X: np.ndarray, r: np.ndarray, groups: np.ndarray, u: np.ndarray
                        ) -> tuple[float, float]:
    """One Gauss-Newton step from a fit with Jacobian ``X`` and residual ``r`` (its rows in
    flights ``groups``), along the combination ``u`` of its first ``len(u)`` parameters:
    how far that combination moves, and its variance there (the larger of the AR(1) one
    and the flight-clustered sandwich's, as in :meth:`PowerLevel.physical`).
    [unit of the combination], [its square]"""
    d = np.linalg.lstsq(X, -r, rcond=None)[0]
    ar1, clustered = _covariance_pair(X, r + X @ d, groups)
    v = _variance_along(ar1, u)
    if clustered is not None:
        v = max(v, _variance_along(clustered, u))
    return float(u @ d[:u.size]), v


def _covariance_pair(J: np.ndarray, r: np.ndarray, groups: np.ndarray):
    """The covariance of a least-squares fit with Jacobian ``J`` and residual ``r``,
    AR(1)-inflated within each group (:func:`planner.identify.stats.covariance`), and the
    group-clustered sandwich (:func:`planner.identify.stats.cluster_covariance`), None with
    fewer than :data:`planner.identify.stats.MIN_CLUSTERS` groups."""
    clustered = (stats.cluster_covariance(J, r, groups).matrix
                 if np.unique(groups).size >= stats.MIN_CLUSTERS else None)
    return stats.covariance(J, r, groups).matrix, clustered


def _altitude_rate(t: np.ndarray, alt: np.ndarray, climb: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Rate of change of the altitude and the logged climb rate, both as means over
    centred windows of :data:`CLIMB_WINDOW_S` (NaN where the altitude is not known).

    The windowed altitude rate is (h(t + w/2) − h(t − w/2)) / w, the exact mean of the
    true vertical speed over the window; the logged climb rate is averaged over the same
    window (trapezoidal integral), so that the two are compared like for like.
    """
    n = len(t)
    nan = np.full(n, np.nan)
    ok = np.isfinite(alt)
    if ok.sum() < 10 or n < 10 or t[-1] - t[0] < 2 * CLIMB_WINDOW_S:
        return nan, nan
    h = np.interp(t, t[ok], alt[ok])
    half = 0.5 * CLIMB_WINDOW_S
    a = np.clip(t - half, t[0], t[-1])
    b = np.clip(t + half, t[0], t[-1])
    width = b - a
    good = width >= CLIMB_WINDOW_S - 1e-9
    rate = np.where(good, (np.interp(b, t, h) - np.interp(a, t, h)) / np.maximum(width, 1e-9),
                    np.nan)
    z = np.r_[0.0, np.cumsum(0.5 * (climb[1:] + climb[:-1]) * np.diff(t))]
    smooth = np.where(good, (np.interp(b, t, z) - np.interp(a, t, z)) / np.maximum(width, 1e-9),
                      np.nan)
    return rate, smooth


def _climb_disagreement(climb: np.ndarray, rate: np.ndarray) -> float | None:
    """RMS difference between the windowed logged climb rate and the windowed rate of
    change of the altitude [m/s]; None without enough samples with altitude."""
    ok = np.isfinite(climb) & np.isfinite(rate)
    if ok.sum() < MIN_ROWS:
        return None
    return float(np.sqrt(np.mean((climb[ok] - rate[ok]) ** 2)))


def interp_nan(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``y`` with its missing (non-finite) samples interpolated linearly in time ``t`` and
    held at the ends; unchanged where none or all are missing. [unit of y]"""
    ok = np.isfinite(y)
    if ok.sum() == 0 or ok.all():
        return y
    return np.interp(t, t[ok], y[ok])


def _fill(x: np.ndarray) -> np.ndarray:
    ok = np.isfinite(x)
    if ok.all():
        return x
    idx = np.arange(len(x))
    return np.interp(idx, idx[ok], x[ok])


# ============================================================================ scoring

def weighted_final(finals) -> float:
    """Final error of the held-out segments, Σ|error at the end| / Σ charge (energy)
    drawn, from ``(|error|, drawn)`` pairs, in % (a short segment that draws little does
    not dominate); NaN without segments. [%]"""
    if not finals:
        return float("nan")
    a = np.asarray(finals, float)
    return float(100.0 * a[:, 0].sum() / a[:, 1].sum())


@dataclass
class Score:
    """Cross-validated score of one model (a set of effects) on one level."""

    effects: tuple[str, ...]
    fits: list[Fit]
    rmse: float
    final_error_pct: float
    unit_loss: np.ndarray
    heldout_rows: np.ndarray
    heldout_row_resid: np.ndarray
    heldout_samples: np.ndarray
    heldout_sample_resid: np.ndarray
    train_rss: list[float]
    train_n: list[int]
    train_rho: list[float]
    dof: list[int]
    #: The same, of the training residuals net of each experiment's mean (the test of an
    #: effect that explains only variation within an experiment).
    train_rss_within: list[float] = field(default_factory=list)
    train_rho_within: list[float] = field(default_factory=list)


def cross_validate(level, effects, base: Score | None = None) -> Score:
    """Fit ``effects`` on each fold's training split, score on its held-out split."""
    n_units = len(level.split.units)
    unit_loss = np.zeros(n_units)
    has = np.zeros(n_units, bool)
    fits, rows_all, rr_all, samples_all, sr_all, finals = [], [], [], [], [], []
    rss, nn, rho, dof, rss_w, rho_w = [], [], [], [], [], []
    for k in range(level.split.n_folds):
        train = level.row_fold != k
        if not train.any() or not (~train).any():
            raise FitError(f"{level.name} level: fold {k} has no training or no held-out data")
        start = base.fits[k] if base is not None else None
        fit = level.fit(effects, train, start=start)
        n_params = len(fit.nl) + len(fit.coef)
        dof.append(n_params + sum(e.extra_dof(fit.state) for e in effects))
        level.prepare_heldout(fit, effects, ~train)
        h = level.heldout(fit, effects, k)
        fits.append(fit)
        rows_all.append(h["rows"])
        rr_all.append(h["row_resid"])
        samples_all.append(h["samples"])
        sr_all.append(h["sample_resid"])
        finals += h["finals"]
        np.add.at(unit_loss, h["loss_units"], h["loss"])
        has[h["loss_units"]] = True
        rss.append(fit.rss)
        nn.append(int(train.sum()))
        rho.append(stats.lag1_autocorrelation(fit.train_resid, level.row_group[train]))
        wr = stats.within_groups(fit.train_resid, level.row_group[train])
        rss_w.append(float(np.dot(wr, wr)))
        rho_w.append(stats.lag1_autocorrelation(wr, level.row_group[train]))
    sr = np.concatenate(sr_all)
    scale = AS_PER_MAH if level.name == "capacity" else 1.0
    unit_loss[~has] = np.nan
    return Score(tuple(e.name for e in effects), fits,
                 float(np.sqrt(np.mean(sr**2))) / scale,
                 weighted_final(finals),
                 unit_loss, np.concatenate(rows_all), np.concatenate(rr_all),
                 np.concatenate(samples_all), sr, rss, nn, rho, dof, rss_w, rho_w)


#: Random sign patterns of the paired test (exact enumeration up to 2**16 patterns).
SIGN_FLIPS = 20000


def sign_flip_test(d: np.ndarray) -> float:
    """One-sided paired randomisation test of ``sum(d) > 0`` (signs of d flipped at random).

    Under the null hypothesis (the extension does not predict the held-out units better)
    each unit's difference is as likely negative as positive; the p-value is the share of
    sign patterns whose sum reaches the observed one. Exact for up to 16 units, else
    :data:`SIGN_FLIPS` seeded random patterns.
    """
    d = np.asarray(d, float)
    n = len(d)
    if n == 0:
        return 1.0
    obs = float(d.sum())
    if n <= 16:
        signs = 1 - 2 * ((np.arange(2**n)[:, None] >> np.arange(n)) & 1)
    else:
        signs = np.random.default_rng(12345).choice([-1.0, 1.0], size=(SIGN_FLIPS, n))
    sums = signs @ d
    return float((np.sum(sums >= obs - 1e-12 * abs(obs)) + 1) / (len(sums) + 1))


@dataclass
class Comparison:
    """Evidence for one extension against the current model."""

    effect: str
    rmse_before: float
    rmse_after: float
    gain_pct: float
    final_error_pct_before: float
    final_error_pct_after: float
    lr_statistic: float
    lr_p_value: float
    effective_samples: float
    added_parameters: int
    paired_p_value: float
    units: int
    units_improved: int
    significant: bool
    reasons: list[str]
    against: tuple[str, ...] = ()
    #: What the candidate's training folds read of the effect (``Effect.estimate``; None
    #: where it gives none, or for a pair's comparison).
    estimate: Any = None

    def evidence(self) -> dict[str, float]:
        """The statistics behind the verdict: the training likelihood ratio and its p,
        the effective samples, the added parameters, the paired held-out p and the test
        units (all, and improved)."""
        return {"lr_statistic": self.lr_statistic, "lr_p_value": self.lr_p_value,
                "effective_samples": self.effective_samples,
                "added_parameters": float(self.added_parameters),
                "paired_p_value": self.paired_p_value, "test_units": float(self.units),
                "test_units_improved": float(self.units_improved)}


def compare(effect, before: Score, after: Score, level=None) -> Comparison:
    """The three selection criteria of the module notes (plus the effect's own practical
    floor, e.g. a payload change of at least 3 % of the mass)."""
    gain = 100.0 * (1.0 - after.rmse / before.rmse) if before.rmse > 0 else 0.0
    d = before.unit_loss - after.unit_loss
    d = d[np.isfinite(d)]
    nz = d[np.abs(d) > 1e-12 * max(float(np.nanmax(np.abs(before.unit_loss))), 1e-300)]
    p_pair = sign_flip_test(nz) if len(nz) >= MIN_TEST_UNITS else 1.0
    lrs, ps, neffs = [], [], []
    within = bool(getattr(effect, "within_experiment", False))
    for k in range(len(before.fits)):
        n = after.train_n[k]
        rho = (after.train_rho_within if within else after.train_rho)[k]
        neff = n * (1 - rho) / (1 + rho)
        r0, r1 = ((before.train_rss_within[k], after.train_rss_within[k]) if within else
                  (before.train_rss[k], after.train_rss[k]))
        lr = neff * math.log(r0 / r1) if r0 > 0 and r1 > 0 else 0.0
        df = max(after.dof[k] - before.dof[k], 1)
        lrs.append(lr)
        ps.append(float(chi2.sf(max(lr, 0.0), df)))
        neffs.append(neff)
    p_train = float(np.median(ps))
    reasons = []
    floor = effect.practical(after.fits, level) if hasattr(effect, "practical") else None
    if floor:
        reasons.append(floor)
    if gain < MIN_GAIN_PCT:
        reasons.append(f"held-out gain {gain:.1f} % < {MIN_GAIN_PCT:g} %")
    if p_pair >= ALPHA_HELDOUT:
        reasons.append(f"paired held-out test p = {p_pair:.3g} ≥ {ALPHA_HELDOUT:g}")
    if p_train >= ALPHA_TRAIN:
        reasons.append(f"training likelihood-ratio p = {p_train:.3g} ≥ {ALPHA_TRAIN:g}")
    name = effect if isinstance(effect, str) else effect.name
    return Comparison(name, before.rmse, after.rmse, gain, before.final_error_pct,
                      after.final_error_pct, float(np.median(lrs)), p_train,
                      float(np.median(neffs)), int(np.median(np.array(after.dof)
                                                             - np.array(before.dof))),
                      p_pair, len(d), int(np.sum(d > 0)), not reasons, reasons)


@dataclass
class LevelResult:
    """Everything the search found on one level."""

    level: Any
    baseline: Score
    final: Score
    selected: list[tuple[Any, Comparison]]
    candidates: dict[str, Comparison]
    skipped: dict[str, str]
    failed: dict[str, str]
    final_fit: Fit | None = None
    base_fit: Fit | None = None
    #: ``(fit, values, stderr)``: the level's ``physical`` of ``fit``, the final fit with
    #: the selected effects, as the honesty rules computed it last.
    final_physical: tuple | None = None
    #: Effects that passed the held-out tests but are not named as causes (implausible,
    #: confounded), each a dict with ``effect``, ``kind``, ``why`` and ``where``.
    withheld: list[dict] = field(default_factory=list)
    #: Rival effects that each passed alone but that the held-out data cannot tell apart
    #: (:func:`_rival_step`): one dict per tie, ``candidates``, ``why``.
    confused: list[dict] = field(default_factory=list)
    #: The rivals each named effect was held against and the test it won
    #: (:func:`_held_against`), by the effect's name.
    held_against: dict[str, list[dict]] = field(default_factory=dict)
    #: The flights' scale on the model's change of power with airspeed, its standard
    #: error and whether a steady wind was in the fit it was read on
    #: (:meth:`PowerLevel.speed_read`,
    #: :func:`planner.identify.diagnose.limits.speed_response_of`); False until read, None
    #: where it cannot be.
    speed_response: tuple[float, float, bool] | None | bool = False


def _promising(cmp: Comparison) -> bool:
    """An effect whose held-out gain and training test pass on its own (whatever its
    paired test): a member of a masking pair or a rival of the round's leader."""
    return cmp.gain_pct >= MIN_GAIN_PCT and cmp.lr_p_value < ALPHA_TRAIN


def _fit_together(level, chosen, current, first, second):
    """Two candidate effects, ``first`` and ``second`` ((effect, its score alone) each),
    cross-validated together on top of ``chosen``, and each compared on top of the other
    (:func:`compare`, ``against`` set): (the joint score, first on top of second, second
    on top of first); None when the joint fit fails."""
    (a, sa), (b, sb) = first, second
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            both = cross_validate(level, chosen + [a, b], base=current)
    except (FitError, ModelError, np.linalg.LinAlgError, ValueError):
        return None
    a_on_b, b_on_a = compare(a, sb, both, level), compare(b, sa, both, level)
    for c, other in ((a_on_b, b), (b_on_a, a)):
        c.against = tuple(x.name for x in chosen) + (other.name,)
    return both, a_on_b, b_on_a


def _pair_step(level, chosen, current, round_scores, candidates):
    """Two effects that mask each other: when no single effect passes, try the pairs of
    promising ones (held-out gain ≥ the minimum and training test passed on their own).
    A pair joins when the pair passes against the current model and each member passes
    against the model with the other."""
    promising = sorted((v for v in round_scores.values() if _promising(v[2])),
                       key=lambda v: -v[2].gain_pct)[:3]
    best = None
    for i in range(len(promising)):
        for j in range(i + 1, len(promising)):
            (a, sa, _), (b, sb, _) = promising[i], promising[j]
            fitted = _fit_together(level, chosen, current, (a, sa), (b, sb))
            if fitted is None:
                continue
            both, cmp_a, cmp_b = fitted
            joint = compare(a, current, both, level)
            for c in (cmp_b, cmp_a):
                candidates[f"{c.effect} (after {' + '.join(c.against)})"] = c
            if joint.significant and cmp_a.significant and cmp_b.significant:
                gain = 100.0 * (1.0 - both.rmse / current.rmse)
                if best is None or gain > best[2]:
                    first, second = (a, cmp_a), (b, cmp_b)
                    if cmp_b.gain_pct > cmp_a.gain_pct:
                        first, second = second, first
                    best = ([first, second], both, gain)
    return None if best is None else best[:2]


#: Most rivals the leading candidate of a round is held against (:func:`_rival_step`).
MAX_RIVALS = 2


def _rival_step(level, chosen, current, passing, candidates, promising=(), held=None):
    r"""The candidate of a round that the held-out data prefer among those that pass alone,
    and None; or None and the tie (``candidates``, ``why``) when the leading one and a
    rival cannot be told apart (module notes, "Rival effects").

    The held-out gain ranks the candidates, but two effects of different physics may
    explain the same misfit (a payload dropped late in out-and-back flights and a steady
    wind along the route; a constant load and an efficiency curve), and a gain of 11 %
    against one of 7 % on 24–64 held-out units is no evidence between them. They are
    non-nested models, compared as Vuong (1989) compares them — the paired differences of
    their held-out losses, here per test unit with the sign-flip test of the selection
    (:func:`sign_flip_test`), two-sided at :data:`ALPHA_HELDOUT` — and, where that does
    not decide, by the encompassing principle (Mizon & Richard 1986; Davidson & MacKinnon
    1981): both are fitted together and each is tested on top of the other with the
    selection's own criteria (:func:`compare`). The one that adds to its rival while the
    rival adds nothing to it explains the rival's misfit: it is the cause the data
    support. Both adding: both effects are there, the leading one joins first. Neither
    adding: the data cannot tell them apart and neither is named. A rival that passes
    the gain and the training test but not the paired test (``promising``, as for the
    pairs of :func:`_pair_step`) is held against the leading one the same way; it cannot
    lead, but where the leading one adds nothing on top of it the two tie.

    References: Q. H. Vuong, "Likelihood ratio tests for model selection and non-nested
    hypotheses", Econometrica 57 (1989) 307–333; G. E. Mizon and J.-F. Richard, "The
    encompassing principle and its application to testing non-nested hypotheses",
    Econometrica 54 (1986) 657–678; R. Davidson and J. G. MacKinnon, "Several tests for
    model specification in the presence of alternative hypotheses", Econometrica 49
    (1981) 781–793.

    ``held``, where given, receives the tests each candidate won against a rival, by the
    winner's name (:func:`_held_against`): the evidence its finding quotes.
    """
    held = {} if held is None else held
    ranked = sorted(passing, key=lambda v: -v[2].gain_pct)
    lead = ranked[0]
    near = sorted((v for v in promising if not v[2].significant),
                  key=lambda v: -v[2].gain_pct)
    for rival in (ranked[1:] + near)[:MAX_RIVALS]:
        (a, sa, ca), (b, sb, cb) = lead, rival
        passed = cb.significant
        d = sb.unit_loss - sa.unit_loss            # > 0 where a predicts the unit better
        d = d[np.isfinite(d)]
        d = d[np.abs(d) > 1e-12 * max(float(np.max(np.abs(d))) if d.size else 0.0, 1e-300)]
        if len(d) >= MIN_TEST_UNITS:
            p_a, p_b = sign_flip_test(d), sign_flip_test(-d)
        else:
            p_a = p_b = 1.0
        if p_b < 0.5 * ALPHA_HELDOUT and passed:
            held.setdefault(b.name, []).append(_held_against(a, cb, ca, p_b))
            lead = rival
            continue
        if p_a < 0.5 * ALPHA_HELDOUT:
            held.setdefault(a.name, []).append(_held_against(b, ca, cb, p_a))
            continue
        fitted = _fit_together(level, chosen, current, (a, sa), (b, sb))
        if fitted is None:
            continue
        _, a_on_b, b_on_a = fitted
        for c in (a_on_b, b_on_a):
            candidates[f"{c.effect} (after {' + '.join(c.against)})"] = c
        if a_on_b.significant:                       # a adds to b: a leads (b may follow)
            held.setdefault(a.name, []).append(
                _held_against(b, ca, cb, p_a, on_top=a_on_b, under=b_on_a))
            continue
        if b_on_a.significant and passed:            # b explains a's misfit, not reverse
            held.setdefault(b.name, []).append(
                _held_against(a, cb, ca, p_b, on_top=b_on_a, under=a_on_b))
            lead = rival
            continue
        alone = "each pass alone" if passed else \
            f"{a.name} passes alone, {b.name} all but the paired test"
        why = (f"{a.name} and {b.name} {alone} (held-out gain {ca.gain_pct:.1f} % "
               f"and {cb.gain_pct:.1f} %), but {a.name} does not predict the held-out data "
               f"better than {b.name} (paired p = {p_a:.2g}) and "
               f"{a.name} adds nothing to it (on top of it: {a_on_b.gain_pct:+.1f} %, "
               f"paired p = {a_on_b.paired_p_value:.2g}): these data cannot tell them apart")
        return None, {"candidates": [a.name, b.name], "why": why}
    return lead, None


def _held_against(rival, c_win: Comparison, c_rival: Comparison, paired_p: float,
                  on_top: Comparison | None = None, under: Comparison | None = None) -> dict:
    """The test by which the winner (``c_win``) was preferred to ``rival``
    (:func:`_rival_step`): their held-out gains alone [%], the paired test of their
    held-out losses (``paired_p``: that the winner predicts no better), and where that did
    not decide, the winner's gain on top of the rival and the rival's on top of the winner
    [%] with their paired p; ``text`` in words."""
    out = {"rival": rival.name, "gain_pct": c_win.gain_pct,
           "rival_gain_pct": c_rival.gain_pct, "paired_p": paired_p}
    if on_top is None:
        text = (f"fitted in its place, {rival.name} predicts the held-out data worse "
                f"(held-out gain {c_rival.gain_pct:.1f} % against {c_win.gain_pct:.1f} %, "
                f"paired p = {paired_p:.2g})")
    else:
        out.update(on_top_gain_pct=on_top.gain_pct, on_top_p=on_top.paired_p_value,
                   under_gain_pct=under.gain_pct, under_p=under.paired_p_value)
        text = (f"fitted with it, {rival.name} adds nothing on top of it "
                f"({under.gain_pct:+.1f} %, paired p = {under.paired_p_value:.2g}) while it "
                f"adds {on_top.gain_pct:+.1f} % on top of {rival.name} (paired p = "
                f"{on_top.paired_p_value:.2g})")
    out["text"] = text
    return out


def _score(level, chosen, current, e, candidates, failed):
    """``(e, score, comparison)`` of ``e`` added to ``chosen`` (entered in ``candidates``),
    or None where its fit fails (entered in ``failed``)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sc = cross_validate(level, chosen + [e], base=current)
    except (FitError, ModelError, np.linalg.LinAlgError, ValueError) as exc:
        failed[e.name] = str(exc)
        return None
    cmp = compare(e, current, sc, level)
    cmp.against = tuple(c.name for c in chosen)
    cmp.estimate = e.estimate(sc.fits, level, chosen + [e])
    key = e.name if not chosen else f"{e.name} (after {' + '.join(cmp.against)})"
    candidates[key] = cmp
    return e, sc, cmp


def _rivals_due(rivals, passing, round_scores, failed) -> list:
    """The rivals (:func:`search`) of an effect that passes this round, not yet scored."""
    names = {v[0].name for v in passing}
    return [r for r in rivals if names & set(r.rival_of)
            and r.name not in round_scores and r.name not in failed]


def _rival_lead(pick, passing, reason: str) -> dict:
    """The tie (``candidates``, ``why``) where a rival that cannot be named
    (:func:`search`), for ``reason``, predicts the held-out data better than the effects
    it rivals: none of them is named."""
    r, _, cr = pick
    beaten = [v for v in passing if v[0].name in r.rival_of]
    names = " or ".join(v[0].name for v in beaten)
    gains = " and ".join(f"{v[2].gain_pct:.1f} %" for v in beaten)
    why = (f"{r.name} predicts the held-out data at least as well as {names} (held-out "
           f"gain {cr.gain_pct:.1f} % against {gains}), and {r.name} cannot be named here "
           f"({reason}): these data cannot tell them apart")
    return {"candidates": [r.name] + [v[0].name for v in beaten], "why": why}


def search(level, effects: list) -> LevelResult:
    """Calibrate the baseline, then add effects greedily (see the module notes).

    An effect skipped because these data cannot name it, but which they can fit (a wind
    on a route that makes it one step per flight, ``Effect.rival_reason``), is fitted in
    each round where an effect it rivals (``Effect.rival_of``) passes, and held against
    it as any rival is (:func:`_rival_step`): where the held-out data cannot tell the two
    apart, or prefer the rival, neither is named."""
    skipped, testable, rivals = {}, [], []
    for e in effects:
        why = e.skip_reason(level)
        if why:
            skipped[e.name] = why
            if e.rival_of and e.rival_reason(level):    # its skip reason, as a rival
                rivals.append(e)
        else:
            testable.append(e)
    baseline = cross_validate(level, [])
    current, chosen = baseline, []
    candidates: dict[str, Comparison] = {}
    failed: dict[str, str] = {}
    selected: list[tuple[Any, Comparison]] = []
    confused: list[dict] = []
    held: dict[str, list[dict]] = {}
    remaining = list(testable)
    while remaining:
        round_scores = {}
        for e in remaining:
            scored = _score(level, chosen, current, e, candidates, failed)
            if scored is not None:
                round_scores[e.name] = scored
        passing = [v for v in round_scores.values() if v[2].significant]
        if not passing:
            pair = _pair_step(level, chosen, current, round_scores, candidates)
            if pair is None:
                break
            for e, cmp in pair[0]:
                selected.append((e, cmp))
                chosen.append(e)
            current = pair[1]
            remaining = [r for r in remaining if r not in chosen and r.name not in failed]
            continue
        for r in _rivals_due(rivals, passing, round_scores, failed):
            scored = _score(level, chosen, current, r, candidates, failed)
            if scored is not None:
                round_scores[r.name] = scored
                if scored[2].significant:
                    passing.append(scored)
        promising = [v for v in round_scores.values() if _promising(v[2])]
        won: dict[str, list[dict]] = {}
        pick, tied = _rival_step(level, chosen, current, passing, candidates, promising,
                                 won)
        if pick is not None and pick[0] in rivals:     # a rival that cannot be named leads
            tied = _rival_lead(pick, passing, skipped[pick[0].name])
            pick = None
        if pick is None:                # the leading ones cannot be told apart: name neither
            confused.append(tied)
            remaining = [r for r in remaining if r.name not in tied["candidates"]
                         and r.name not in failed]
            rivals = [r for r in rivals if r.name not in tied["candidates"]]
            continue
        e, sc, cmp = pick
        selected.append((e, cmp))
        chosen.append(e)
        current = sc
        if e.name in won:               # the tests it won in the round it was taken
            held[e.name] = won[e.name]
        remaining = [r for r in remaining if r is not e and r.name not in failed]
    return LevelResult(level, baseline, current, selected, candidates, skipped, failed,
                       confused=confused, held_against=held)
