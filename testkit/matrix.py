r"""The effect matrix of ``diagnose`` on real data (``benchmarks/bench_effect_matrix.py``).

Every effect of diagnose's vocabulary × every real source that can carry it × the
richness of the record × when the effect happens × its size, each cell run on fresh
draws of the real data with the effect injected by a physical law of
:mod:`testkit.injections` (never the planner's own models).

Sources (``../shared/data``, PROVENANCE.md in each folder)
---------------------------------------------------------
``m100``
    16 cruise flights of the DJI Matrice 100 delivery data set (Rodrigues et al., Sci.
    Data 8, 155, 2021, CC BY 4.0; route R1, flights 8–277), all of one payload class
    (0, 250 or 500 g, from ``m100_parameters.csv``, drawn at random), so that the mass
    given to diagnose is the flights' own; ``aircraft/dji_m100.yaml`` (with
    :data:`CALIBRATE_DESCENT`, its slow-descent inflow weight calibrated on the route's
    flights not drawn: :func:`calibrated_aircraft`), site 300 m.
``m100_routes``
    16 of the 22 M100 flights without payload on every other route (A1–A3, H, R2–R7):
    what the ``m100`` draws hold fixed (one route flown in one order) varies here.
``m100_mixed``
    16 route-R1 flights of any payload class, mixed in one draw, each flight's own
    payload given to diagnose as the record's ``payload_kg`` column (:func:`given`) and
    each flown by the injection laws at its own mass: what the ``m100`` draws hold
    fixed — one mass for every flight — varies here.
``m100_measured``
    The ``m100`` draws, run by run the same flights, sizes and times, with a payload
    injected by the M100's own measured change of battery power per kilogram
    (:func:`measured_w_per_kg`: across route R1's flights at 0, 250 and 500 g, about
    200 W/kg in level cruise at every speed, in the climb and in the descent alike) in
    place of momentum theory, which gives 190–395 W/kg by regime on the same flights:
    what every other multirotor source holds fixed, the mass law, varies here.
``log171``
    ArduCopter log 171 (a 3DR-Solo-like quad; CC BY-SA 3.0), ``aircraft/solo_survey.yaml``.
``ac313_2004``, ``ac313_2044``
    The two ArduCopter 3.1.3 flights (no licence: validation only); no aircraft file is
    known for them, so diagnose's power level cannot run.
``mcgill_hover``
    The McGill hexarotor's 44-minute hover to a critical battery (no licence: validation
    only), no aircraft file.
``mcgill_hovers``
    The same hexarotor's three hovers of 2022-06-02 (no licence: validation only), the
    rotors stopped between them: rests within one record.
``px4_octo``, ``px4_quad_v3``, ``px4_quad_v6c``, ``px4_quad_v6xrt``
    Four short PX4 flights of other vehicles, 39–95 s each (an sdlog2 octocopter, a
    quadrotor whose log starts in the air, an indoor quadrotor, and a quadrotor whose
    ULog is damaged; no licence: validation only), no aircraft file: a few percent of
    the pack, so that most effects must be said not identifiable.
``solar_surfer``
    Flight 3 of MIT's Solar Surfer (Sharpe & Hansman 2024, MIT licence), a PX4 topic
    export, ``aircraft/solar_surfer.yaml``.
``p42a``, ``q30``
    Molicel P42A and Samsung 30Q cell discharges (:mod:`testkit.cells`).
``a123``
    The A123 LiFePO4 cell discharged at C/30 to 2.0 V at eight chamber temperatures,
    −25…45 °C (Plett 2015, CC BY-NC-SA 4.0): a real cold effect, nothing injected.

Richness
--------
``everything`` — every channel the source (and the injection) has; ``plain`` — time,
voltage, current, power, altitude, climb rate, ground speed, course; ``minimal`` — time,
voltage, current. A richness may name a telemetry rate, ``plain@1Hz``: the record as a
stream at that rate carries it (:func:`decimate`; ``bench_effect_matrix.py --rate``), the
same injection as at the source's own rate.

Timing (the payload change only, released or picked up; the other effects last the whole
record)
------------------------------------------------------------------------------------------
The change falls at a fraction of each flight's span in the air (a multirotor's: where
its rotors carry its weight, :func:`testkit.injections.lifting`): ``early`` 0.10–0.25,
``mid`` 0.40–0.60, ``late`` 0.75–0.90, ``random`` 0.10–0.90 drawn per flight.

Sizes
-----
``realistic`` as below, ``2x`` twice it; ``half`` and ``quarter`` probe the detection
limits from beneath (every range below scaled by the factor; not judged by the
criterion). Payload 0.2–0.4 kg (M100; 0.1–0.2 kg on the 1.5-kg Solo, 0.5–1.0 kg on
the 9.4-kg Solar Surfer), carried from take-off and released
(the real flight is the state after the release, so the masses stay physical); on the
M100 flights, log 171 and the Solar Surfer also the same mass picked up (``pickup``: the
record after the change flown heavier by the same law). Steady
wind 3–6 m/s from a random direction. Air density 75–85 % of the site's in half the
flights (2×: 50–70 %). A constant load of 3.3–9 % of the median airborne power (15–40 W
on the M100). A copper loss R·I² of 3–8 % of the power at the median current. A current
sensor reading 0.3–0.8 A too high (cells: 0.05–0.15 A), the power channel logged
independently of it where the record has one. A pack at −5…30 °C per flight (resistance
by Arrhenius, 19 kJ/mol; 2×: 38 kJ/mol), its temperature logged. Capacity fade of
0.04 %/cycle with DC resistance +0.06 %/cycle over 0–500 cycles per discharge (P42A,
30Q), the cycle count logged. Cold cells: half the discharges at 0 °C (10 % less capacity,
resistance by Arrhenius; :func:`testkit.cells.chill`).

The record's own findings
-------------------------
Some real records carry an effect of diagnose's vocabulary themselves. Each source
declares them (:class:`RealEffect`, ``Source.real``) with the evidence beside it:

* ``log171``: the log switches LOITER → ACRO at 206 s (from its first sample), and
  from 228 s the aircraft sits at 1.2 m drawing 333 W, against 225 W in the hover
  before. On the ``plain`` record (no
  ``mode`` channel) diagnose reports it, as the project requires, as a +103 W step of the
  power at 228 s consistent with a 0.43 ± 0.03 kg mass increase or anything else that
  raises the power (``payload_change``, with its alternatives); with the ``mode`` channel
  it withholds the step as one at a mode change and names nothing.
* ``a123``: the discharges run at eight chamber temperatures, a real cold effect.

They are declared, not taken from what diagnose names on each draw's clean record: that
would make every clean cell silent by construction and hide any false cause diagnose
names on clean data. A finding of a declared effect is the record's own where each
change it locates (``change_time_s[<flight>]``) lies within 15 s of the record's; it is
never a false cause, and silence and "named first" are judged on the other findings
(:func:`classify`). Where the injection is the same effect (a payload released on log
171), the injected change must be found at its own time: within 15 s of it and nearer to
it than to the record's step; a change located anywhere else counts as a false cause.
Where diagnose locates the record's own change instead, the flight holds it: diagnose
locates one change a flight, and the injected one's detection limit is then the one its
output gives for a second change in that flight (``second_change``: the located step's
size), not the one for a flight without a change.

What is scored (per run)
------------------------
The findings named (first, anywhere), causes named other than the injected one (false),
the record's own findings named (``own``), the detection limit diagnose gives for the
injected effect (``detection`` in its JSON) against the injected size, and whether the
fitted parameter lies within two of its standard errors of the injected one (where the
effect is named first). The truth of an injected wind, load or copper loss adds what the
clean record carries of it (:func:`clean_parameters`), except a wind on M100 flights: it
adds the wind the flights flew in as their on-board anemometer measured it
(:func:`anemometer_wind_of`), a measurement, not diagnose's own fit of the clean record.
A wind's size, set against its detection limit, is the speed of that sum: the wind the
record holds. A current offset's truth is the
injected one alone: the clean log's current sensor error is in its power channel too
(the power logged is V·I of that sensor, and the injection keeps it as the true power),
so the current against the power channel differs by the injected offset only.

On M100 flights a wind named where none is injected is set against the wind the flights
themselves flew in, measured by the on-board anemometer that diagnose never sees
(:func:`anemometer_wind_of`, :func:`wind_against`; ``winds`` in the tallies). The
flights did fly in a wind (the mean over a draw's flights, of several days: 0.2–1.3 m/s
on route R1, 1.0–1.5 m/s on the other routes, seeds 0–2), so a wind named within :data:`WIND_AGREES_Z` combined standard errors of the
measured one (the 95 % radius of the difference of two two-dimensional estimates) is the
flights' own weather, like the declared effects above: never a false cause, and silence
and "named first" are judged on the other findings. One farther from it is a false
cause whatever the weather was.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import time
import warnings
import zlib
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from testkit import cells, injections as inj

REPO = Path(__file__).resolve().parents[1]
DATA = REPO.parent / "shared" / "data"
ENERGY = DATA / "energy"
LOGS = DATA / "logs"

PLAIN = ("experiment", "time_s", "voltage_v", "current_a", "power_w", "altitude_m",
         "climb_rate_ms", "groundspeed_ms", "course_deg")
MINIMAL = ("experiment", "time_s", "voltage_v", "current_a")
RICHNESS = ("everything", "plain", "minimal")
TIMINGS = {"early": (0.10, 0.25), "mid": (0.40, 0.60), "late": (0.75, 0.90),
           "random": (0.10, 0.90)}
SIZES = {"realistic": 1.0, "2x": 2.0, "half": 0.5, "quarter": 0.25}

#: injection → the effect diagnose should name.
EXPECT = {"clean": None, "payload": "payload_change", "pickup": "payload_change", "wind": "wind",
          "density": "air_density", "load": "system_power", "copper": "efficiency_curve",
          "offset": "current_offset", "cold_pack": "temperature", "fade": "capacity_fade",
          "cold_cells": "temperature", "real_cold": "temperature"}


def available() -> bool:
    """True when the real data lie beside the repository."""
    return (ENERGY / "m100_parameters.csv").is_file() and LOGS.is_dir()


def reduce(df: pd.DataFrame, richness: str) -> pd.DataFrame:
    """The record as a user with ``richness`` would have it (module notes), at the
    telemetry rate it names (``plain@1Hz``)."""
    base, rate = split_richness(richness)
    out = df if base == "everything" else \
        df[[c for c in (PLAIN if base == "plain" else MINIMAL) if c in df]].copy()
    return out if rate is None else decimate(out, rate)


def split_richness(richness: str) -> tuple[str, float | None]:
    """``"plain@0.5Hz"`` → ``("plain", 0.5)``; ``"plain"`` → ``("plain", None)``. [Hz]"""
    base, _, rate = richness.partition("@")
    return base, (float(rate.removesuffix("Hz")) if rate else None)


def decimate(df: pd.DataFrame, rate_hz: float) -> pd.DataFrame:
    """The record as a telemetry stream at ``rate_hz`` carries it: in each experiment the
    first sample of every 1/``rate_hz``-s interval from its start, an instantaneous value
    as a telemetry message holds (not a mean); a counter such as the charge drawn keeps
    the autopilot's own integration. [Hz]"""
    t = df["time_s"].to_numpy(float)
    exp = df["experiment"].astype(str).to_numpy() if "experiment" in df else \
        np.zeros(len(df), str)
    start = pd.Series(t).groupby(exp).transform("min").to_numpy()
    slot = np.floor((t - start) * rate_hz + 1e-9)       # a clock's rounding is no new slot
    keep = np.r_[True, (slot[1:] != slot[:-1]) | (exp[1:] != exp[:-1])]
    return df[keep].reset_index(drop=True)


# ============================================================================ sources

@dataclass
class Draw:
    """One run's clean data and what diagnose and the injections need to know."""

    record: pd.DataFrame
    pack: object
    aircraft: object | None
    #: the payload given to diagnose and the all-up mass, one for every flight or, where
    #: the flights differ, a mapping from each flight's id to its own [kg]
    payload_kg: float | dict = 0.0
    mass_kg: float | dict = 0.0
    site_altitude_m: float = 0.0
    rho: float = 1.225
    pack_resistance_ohm: float = 0.0
    rotors: inj.Rotors | None = None
    wing: inj.Wing | None = None
    cells_kind: str | None = None
    #: a multirotor's measured change of battery power per kilogram of payload, the mass
    #: law of its injections in place of momentum theory (None: momentum theory) [W/kg]
    w_per_kg: float | None = None
    extra: dict = field(default_factory=dict)

    @property
    def flights(self) -> list:
        return [k for k, _ in inj.experiments(self.record)]


def _definitions(aircraft_yaml: str | None, battery_yaml: str | None = None):
    from planner.parameters import default_battery_path, load_aircraft, load_battery

    ac = load_aircraft(REPO / aircraft_yaml) if aircraft_yaml else None
    path = battery_yaml and REPO / battery_yaml or (default_battery_path(ac) if ac else None)
    return (load_battery(path) if path else None), ac


@functools.lru_cache(maxsize=2)
def m100_flights(route_r1: bool = True) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The M100 route-R1 cruise flights (``route_r1``; else the flights of every other
    route) with a course (the map's ground velocity's direction, op ``enu_course``) and
    the per-flight parameters table."""
    import yaml

    from planner.io.flightdata import load_flight_data

    spec = yaml.safe_load((REPO / "planner/io/logs/maps/dji_m100.yaml").read_text())
    spec["derived"]["course_deg"] = {"op": "enu_course",
                                     "of": spec["derived"]["groundspeed_ms"]["of"]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        df, _ = load_flight_data(sorted(ENERGY.glob("m100_flights_part*.csv.gz")),
                                 column_map=spec)
    par = pd.read_csv(ENERGY / "m100_parameters.csv")
    on_r1 = par["route"] == "R1"
    r1 = par[(on_r1 if route_r1 else ~on_r1) & par["payload"].isin([0.0, 250.0, 500.0])]
    df = df[df["experiment"].astype(int).isin(r1["flight"])].reset_index(drop=True)
    return df, r1


def _height(flight: pd.DataFrame):
    """An M100 flight's height over the lowest of its first 50 altitude samples, or None
    where they are all unknown. [m]"""
    alt = flight["altitude_m"].to_numpy(float)
    first = alt[:50][np.isfinite(alt[:50])]
    return alt - first.min() if first.size else None


def level_cruise(flight: pd.DataFrame, speed_ms: float, altitude_m: float):
    """The samples of an M100 flight in level cruise at its commanded speed ``speed_ms``
    and altitude ``altitude_m``: climbing slower than 0.3 m/s, ground speed within 15 % of
    the commanded, above 80 % of the commanded altitude (:func:`_height`); None where the
    altitude is unknown. [bool array]"""
    height = _height(flight)
    if not np.isfinite(altitude_m) or height is None:
        return None
    gs = np.abs(flight["groundspeed_ms"].to_numpy(float))
    with np.errstate(invalid="ignore"):
        return ((np.abs(flight["climb_rate_ms"].to_numpy(float)) < 0.3)
                & (np.abs(gs - speed_ms) < 0.15 * speed_ms)
                & (height > 0.8 * altitude_m))


def _hc1(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least squares of ``y`` on ``X`` with heteroskedasticity-robust (HC1) standard
    errors: (coefficients, standard errors)."""
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ coef
    bread = np.linalg.inv(X.T @ X)
    cov = bread @ ((X * r[:, None]).T @ (X * r[:, None])) @ bread * len(y) / (
        len(y) - X.shape[1])
    return coef, np.sqrt(np.diag(cov))


def cruise_power_by_speed(route_r1: bool = True) -> dict:
    """How the M100's level cruise power changes with its commanded speed across flights:
    each flight's median battery power over its level cruise samples (|climb| < 0.3 m/s,
    ground speed within 15 % of the commanded speed, above 80 % of the commanded
    altitude), regressed on the commanded speed (one level per speed), the payload and the
    altitude of the per-flight parameters table, with heteroskedasticity-robust (HC1)
    standard errors. Across flights on many days the wind's effect averages out, which
    no single flight's speeds do. Returns ``{speed: (power − power at 10 m/s, stderr)}``
    [m/s]: ([W], [W]), with ``"payload_w_per_kg"`` and ``"flights"``."""
    df, par = m100_flights(route_r1)
    par = par.assign(altitude=pd.to_numeric(par["altitude"], errors="coerce")).set_index("flight")
    rows = []
    for f, g in df.groupby(df["experiment"].astype(int)):
        p = par.loc[f]
        pw = g["power_w"].to_numpy(float)
        ok = level_cruise(g, p["speed"], p["altitude"])
        if ok is None:
            continue
        ok &= np.isfinite(pw)
        if ok.sum() >= 50:
            rows.append((p["speed"], p["payload"] / 1000.0, p["altitude"], np.median(pw[ok])))
    t = np.array(rows)
    speeds = sorted(set(t[:, 0]) - {10.0})
    X = np.column_stack([np.ones(len(t))] + [(t[:, 0] == v).astype(float) for v in speeds]
                        + [t[:, 1], t[:, 2]])
    coef, se = _hc1(X, t[:, 3])
    out = {float(v): (float(coef[1 + i]), float(se[1 + i])) for i, v in enumerate(speeds)}
    out[10.0] = (0.0, 0.0)
    out["payload_w_per_kg"] = float(coef[1 + len(speeds)])
    out["flights"] = len(t)
    return out


#: Vertical flight of an M100 flight: ground speed below this, above 5 m of height. [m/s]
VERTICAL_GROUNDSPEED_MS = 1.0


def power_per_payload_by_regime() -> dict:
    """How the M100's battery power changes with its payload in each regime it flies, across
    route R1's flights (0, 250 and 500 g on many days): each flight's median power in level
    cruise at its commanded speed (:func:`level_cruise`), in its vertical climb (climb
    above 1.5 m/s) and in its vertical descent (below −1 m/s; ground speed under
    :data:`VERTICAL_GROUNDSPEED_MS`, more than 5 m up, 20 samples or more), regressed on
    the payload: cruise with a level and a payload slope per commanded speed and the
    altitude, climb and descent with the flight's median vertical speed; HC1 errors.
    Returns ``{regime: (W per kg, stderr, flights)}``, regimes ``"cruise 4 m/s"`` … and
    ``"climb"``, ``"descent"``, each with its median vertical speed under
    ``"<regime> rate"`` [m/s]."""
    df, par = m100_flights(True)
    par = par.assign(altitude=pd.to_numeric(par["altitude"], errors="coerce")
                     ).set_index("flight")
    cruise, vertical = [], {"climb": [], "descent": []}
    for f, g in df.groupby(df["experiment"].astype(int)):
        p = par.loc[f]
        pw = g["power_w"].to_numpy(float)
        ok = level_cruise(g, p["speed"], p["altitude"])
        if ok is not None and (ok & np.isfinite(pw)).sum() >= 50:
            cruise.append((p["speed"], p["payload"] / 1000.0, p["altitude"],
                           np.median(pw[ok & np.isfinite(pw)])))
        climb = g["climb_rate_ms"].to_numpy(float)
        height = _height(g)
        if height is None:
            continue
        with np.errstate(invalid="ignore"):
            still = ((np.abs(g["groundspeed_ms"].to_numpy(float)) < VERTICAL_GROUNDSPEED_MS)
                     & (height > 5.0) & np.isfinite(pw))
            for name, m in (("climb", still & (climb > 1.5)), ("descent", still & (climb < -1.0))):
                if m.sum() >= 20:
                    vertical[name].append((p["payload"] / 1000.0, np.median(np.abs(climb[m])),
                                           np.median(pw[m])))
    out = {}
    t = np.array(cruise)
    speeds = sorted(set(t[:, 0]))
    X = np.column_stack([(t[:, 0] == v).astype(float) for v in speeds]
                        + [(t[:, 0] == v) * t[:, 1] for v in speeds] + [t[:, 2]])
    coef, se = _hc1(X, t[:, 3])
    for i, v in enumerate(speeds):
        n = len(speeds) + i
        out[f"cruise {v:g} m/s"] = (float(coef[n]), float(se[n]), int((t[:, 0] == v).sum()))
    for name, rows in vertical.items():
        t = np.array(rows)
        coef, se = _hc1(np.column_stack([np.ones(len(t)), t[:, 0], t[:, 1]]), t[:, 2])
        out[name] = (float(coef[1]), float(se[1]), len(t))
        out[f"{name} rate"] = float(np.median(t[:, 1]))
    return out


#: Diagnose the M100 draws with the slow-descent inflow weight calibrated on the flights
#: not drawn (:func:`calibrated_aircraft`) instead of the aircraft file's (Leishman's
#: curve); ``bench_effect_matrix.py --descent calibrated``.
CALIBRATE_DESCENT = False

#: Flights an M100 draw holds (``bench_effect_matrix.py --flights``): 16, the issue's.
FLIGHTS = 16

#: Most flights ``fit-aircraft`` calibrates a draw's descent weight on
#: (:func:`calibrated_aircraft`), evenly spaced among those not drawn.
CALIBRATION_FLIGHTS = 48

_CALIBRATED: dict = {}


def calibrated_aircraft(d: Draw, richness: str):
    """The draw's aircraft with its slow-descent inflow weight
    (``multirotor.descent_inflow_weight``,
    :func:`planner.physics.power.momentum.induced_velocity`) as ``fit-aircraft``
    calibrates it, with the efficiency and the drag area, each flight at its own mass, on
    up to :data:`CALIBRATION_FLIGHTS` flights of the same data that are not in the draw
    (``d.extra["calibration"]``), reduced to the ``richness`` of the record diagnosed (the
    weight found depends on whether the model flies the disks' axial speed). Diagnose
    holds it: it comes from flights diagnose never sees, as an operator's aircraft file
    comes from earlier flights. The draw's aircraft as it is without calibration flights
    or flight state (``minimal``)."""
    from planner.errors import PlannerError
    from planner.identify.aircraft_fit import fit_aircraft, with_params

    cal = d.extra.get("calibration")
    if cal is None or d.aircraft is None or split_richness(richness)[0] == "minimal":
        return d.aircraft
    key = (cal["key"], richness)
    if key not in _CALIBRATED:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                record = cal["data"][cal["data"]["experiment"].astype(str).isin(
                    cal["flights"])].reset_index(drop=True)
                r = fit_aircraft(reduce(record, richness), d.aircraft,
                                 mass_kg=cal["mass_kg"], site_altitude_m=d.site_altitude_m,
                                 parameters=["efficiency", "drag_area_m2",
                                             "descent_inflow_weight"])
            w = r["parameters"]["descent_inflow_weight"]
        except PlannerError:
            w = d.aircraft.multirotor.descent_inflow_weight
        _CALIBRATED[key] = with_params(d.aircraft, {"descent_inflow_weight": w})
    return _CALIBRATED[key]


def diagnosed_aircraft(d: Draw, richness: str):
    """The aircraft diagnose is given for a draw: the draw's, or with
    :data:`CALIBRATE_DESCENT` its :func:`calibrated_aircraft`."""
    return calibrated_aircraft(d, richness) if CALIBRATE_DESCENT else d.aircraft


@dataclass(frozen=True)
class RealEffect:
    """An effect a source's real data carry themselves (module notes, "The record's own
    findings"), declared with the evidence for it beside the source: diagnose naming it
    is never a false cause of an injection. ``change_time_s``: for a change at a time (a
    step of the power), when it happens, in seconds from the flight's first sample (the
    time base of diagnose's ``change_time_s[<flight>]``); a finding is this one when each
    change it locates lies within ``within_s`` of it. [s]"""

    effect: str
    change_time_s: float | None = None
    within_s: float = 15.0


class Source:
    """A real data source: its name, what it can carry and how a run draws from it."""

    name = ""
    kind = "flights"          # or "cells"
    carries: tuple[str, ...] = ()
    #: Effects the real data carry themselves (never a false cause here).
    real: tuple[RealEffect, ...] = ()
    runs_scale = 1.0          # share of the runs asked for (deterministic sources: fewer)

    def draw(self, rng) -> Draw:
        raise NotImplementedError


#: The injections a source of flights carries (M100 flights, logs, the Solar Surfer).
FLIGHT_INJECTIONS = ("clean", "payload", "pickup", "wind", "density", "load", "copper",
                     "offset", "cold_pack")


class M100(Source):
    name = "m100"
    carries = FLIGHT_INJECTIONS

    def draw(self, rng) -> Draw:
        df, par = m100_flights()
        cls = float(rng.choice([0.0, 250.0, 500.0]))
        return self._sixteen(rng, df, par, cls)

    def _sixteen(self, rng, df, par, payload_g: float | None) -> Draw:
        """:data:`FLIGHTS` flights of ``df`` (at most as many as there are) that carried
        ``payload_g`` [g] (None: any payload, each flight's own given to diagnose), drawn
        with ``rng``, with the M100's definitions; the flights not drawn, each with its
        mass, to calibrate on (:func:`calibrated_aircraft`, which takes their record from
        ``df`` only when it calibrates)."""
        have = set(df["experiment"].astype(int).unique())
        carried = par["payload"] == payload_g if payload_g is not None else \
            par["payload"].notna()
        ids = [f for f in par.loc[carried, "flight"] if f in have]
        pick = [str(x) for x in rng.choice(ids, size=min(FLIGHTS, len(ids)), replace=False)]
        rec = df[df["experiment"].astype(str).isin(pick)].reset_index(drop=True)
        pack, ac = _definitions("aircraft/dji_m100.yaml")
        rest = sorted(have - {int(x) for x in pick})
        rest = [str(rest[i]) for i in np.unique(np.linspace(
            0, len(rest) - 1, min(CALIBRATION_FLIGHTS, len(rest))).round().astype(int))]
        payload_of = dict(zip(par["flight"].astype(str), par["payload"] / 1000.0))
        calibration = {
            "key": (self.name, tuple(sorted(pick))),
            "flights": rest, "data": df,
            "mass_kg": {f: ac.empty_mass_kg + pack.total_mass_kg + payload_of[f]
                        for f in rest}}
        base = ac.empty_mass_kg + pack.total_mass_kg
        if payload_g is None:
            payload = {f: payload_of[f] for f in pick}
            mass = {f: base + m for f, m in payload.items()}
        else:
            payload = payload_g / 1000.0
            mass = base + payload
        return Draw(rec, pack, ac, payload, mass,
                    site_altitude_m=300.0, rho=_isa(300.0), pack_resistance_ohm=0.05,
                    rotors=inj.Rotors(4, ac.multirotor.rotor_diameter_m),
                    extra={"calibration": calibration})


class M100Routes(M100):
    """The M100 flights of every route but R1 (A1–A3, H, R2–R7: other shapes, headings
    and altitudes), 16 of the 22 without payload a run: what the R1 draws hold fixed —
    one route flown in one order — varies here."""

    name = "m100_routes"

    def draw(self, rng) -> Draw:
        return self._sixteen(rng, *m100_flights(route_r1=False), 0.0)


class M100Mixed(M100):
    """16 route-R1 flights of any payload class (0, 250 and 500 g mixed in one draw),
    each flight's own payload given to diagnose (a ``payload_kg`` column, as a record
    that names each flight's payload carries it): what the ``m100`` draws hold fixed —
    one mass for every flight — varies here."""

    name = "m100_mixed"

    def draw(self, rng) -> Draw:
        df, par = m100_flights()
        return self._sixteen(rng, df, par, None)


class M100Measured(M100):
    """The ``m100`` draws (route R1, one payload class a draw) with a payload injected by
    the M100's own measured change of power per kilogram (:func:`measured_w_per_kg`) in
    place of momentum theory: what every other M100 source holds fixed, the mass law,
    varies here."""

    name = "m100_measured"
    carries = ("clean", "payload", "pickup")

    def draw(self, rng) -> Draw:
        return dataclasses.replace(super().draw(rng), w_per_kg=measured_w_per_kg()[0])


@functools.lru_cache(maxsize=1)
def measured_w_per_kg() -> tuple[float, float]:
    """The DJI M100's change of battery power per kilogram of payload, one for every
    regime: the inverse-variance mean of :func:`power_per_payload_by_regime`'s slopes
    (level cruise at each commanded speed, the vertical climb and descent; each lies within
    two standard errors of it), and its standard error. [W/kg]"""
    real = power_per_payload_by_regime()
    slopes = np.array([v[0] for k, v in real.items() if not k.endswith("rate")])
    se = np.array([v[1] for k, v in real.items() if not k.endswith("rate")])
    w = se**-2
    return float(np.sum(w * slopes) / np.sum(w)), float(np.sum(w) ** -0.5)


def _isa(h: float) -> float:
    from planner.physics import atmosphere

    return float(atmosphere.density(h))


@functools.lru_cache(maxsize=1)
def _anemometer_winds() -> dict:
    """Each M100 flight's steady wind (east, north) [m/s] from its on-board anemometer
    (:func:`testkit.m100.anemometer_wind`), over both files of the data set."""
    from testkit.m100 import anemometer_wind

    out = {}
    for path in sorted(ENERGY.glob("m100_flights_part*.csv.gz")):
        out.update(anemometer_wind(path))
    return out


def anemometer_wind_of(d: Draw) -> dict | None:
    """The flights' own steady wind in a draw of M100 flights, measured by the on-board
    anemometer, which diagnose never sees: the mean of the flights' winds weighted by
    their samples (diagnose fits one wind to them all), with the standard error of each
    component from the spread between flights; None with fewer than two flights that
    have one. [m/s]"""
    winds = _anemometer_winds()
    rows = d.record.groupby(d.record["experiment"].astype(str)).size()
    have = [f for f in rows.index if f in winds]
    if len(have) < 2:
        return None
    w = np.array([winds[f] for f in have])
    n = rows[have].to_numpy(float)
    east, north = (w * n[:, None]).sum(axis=0) / n.sum()
    se = w.std(axis=0, ddof=1) / math.sqrt(len(have))
    return {"wind_e_ms": float(east), "wind_n_ms": float(north), "wind_e_ms_stderr":
            float(se[0]), "wind_n_ms_stderr": float(se[1]), "flights": len(have)}


#: Largest distance, in combined standard errors, of a named wind from the anemometer's
#: for it to be the flights' own weather: the 95 % radius of a two-dimensional normal,
#: √χ²₂(0.95). [unitless]
WIND_AGREES_Z = 2.448


def weather_kind(against: dict) -> str:
    """Whose a wind named where none was injected is (:func:`classify`'s kinds), from
    :func:`wind_against`: ``"own"`` (the flights' own weather) within
    :data:`WIND_AGREES_Z` combined standard errors of the measured wind, else ``"other"``
    (a false cause)."""
    return "own" if against["z"] <= WIND_AGREES_Z else "other"


def wind_against(named: dict, measured: dict) -> dict:
    """A wind diagnose named (its ``parameters``) against one measured otherwise
    (:func:`anemometer_wind_of`): both as speed [m/s] and direction it blows from [deg],
    and the distance between the two vectors in combined standard errors (the root of
    the sum of the two components' squared z). [m/s, deg, unitless]"""
    from planner.physics.wind import course_deg

    z = math.hypot(
        (named["wind_n_ms"] - measured["wind_n_ms"])
        / math.hypot(named["wind_n_ms_stderr"], measured["wind_n_ms_stderr"]),
        (named["wind_e_ms"] - measured["wind_e_ms"])
        / math.hypot(named["wind_e_ms_stderr"], measured["wind_e_ms_stderr"]))
    east, north = measured["wind_e_ms"], measured["wind_n_ms"]
    return {"named_ms": named["wind_speed_ms"], "named_from_deg": named["wind_from_deg"],
            "measured_ms": math.hypot(east, north),
            "measured_from_deg": float(course_deg(-east, -north)),   # blows from
            "flights": measured["flights"], "z": z}


@functools.lru_cache(maxsize=8)
def _log(name: str, battery_instance: int | None = None) -> pd.DataFrame:
    from planner.io.flightdata import load_flight_data

    # the reader's own warnings (a damaged log) are shown by its filter "default":
    # recorded here, as the matrix reads each log once for every cell
    with warnings.catch_warnings(record=True):
        warnings.simplefilter("ignore")
        df, _ = load_flight_data([LOGS / name if not name.startswith("/") else name],
                                 battery_instance=battery_instance)
    return df


class Log(Source):
    """One real autopilot log, with its aircraft file where one is known."""

    kind = "flights"
    runs_scale = 0.5

    def __init__(self, name, file, aircraft=None, battery=None, rotors=None, payload=0.0,
                 resistance=0.03, carries=None, real=()):
        self.name, self.file, self.aircraft_yaml = name, file, aircraft
        self.real = tuple(real)
        self.battery_yaml, self.rotors, self.payload = battery, rotors, payload
        self.resistance = resistance
        self.carries = carries or FLIGHT_INJECTIONS

    def draw(self, rng) -> Draw:
        rec = _log(self.file).copy()
        pack, ac = _definitions(self.aircraft_yaml, self.battery_yaml)
        if pack is None:
            from planner.identify.replay import literature_pack

            pack, _ = literature_pack(None, None, rec["voltage_v"])
        mass = (ac.empty_mass_kg if ac else 1.5) + pack.total_mass_kg + self.payload
        return Draw(rec, pack, ac, self.payload, mass, rho=1.2,
                    pack_resistance_ohm=self.resistance, rotors=self.rotors)


class SolarSurfer(Source):
    name = "solar_surfer"
    carries = FLIGHT_INJECTIONS
    runs_scale = 0.5

    def draw(self, rng) -> Draw:
        rec = _log(str(DATA / "fixed_wing/solar_surfer/flight3"), 1).copy()
        pack, ac = _definitions("aircraft/solar_surfer.yaml")
        mass = ac.empty_mass_kg + pack.total_mass_kg
        return Draw(rec, pack, ac, 0.0, mass, rho=1.11, pack_resistance_ohm=0.06,
                    wing=inj.Wing(4.267, 0.9, 0.5))


class Cells(Source):
    """Single-cell discharges (:mod:`testkit.cells`)."""

    kind = "cells"

    def __init__(self, name):
        self.name = name
        self.carries = {"p42a": ("clean", "offset", "fade", "cold_cells"),
                        "q30": ("clean", "offset", "fade", "cold_cells"),
                        "a123": ("real_cold", "offset")}[name]
        self.runs_scale = 0.5 if name == "a123" else 1.0
        # the A123 discharges were run at eight chamber temperatures: a real cold effect
        self.real = (RealEffect("temperature"),) if name == "a123" else ()

    def draw(self, rng) -> Draw:
        from planner.parameters import BatteryPack

        data = _cells(self.name)
        exps = {k: g.reset_index(drop=True) for k, g in data.groupby("experiment", sort=False)}
        names = list(exps)
        if self.name == "p42a":
            cyc = [n for n in names if "cycle" in n]
            sto = [n for n in names if "storage" in n]
            pick = list(rng.choice(cyc, 8, replace=False)) + list(rng.choice(sto, 7,
                                                                             replace=False))
        elif self.name == "q30":
            pick = list(rng.choice(names, 10, replace=False))
        else:
            pick = names
        rec = pd.concat([exps[n] for n in pick], ignore_index=True)
        cap = {"p42a": 4200.0, "q30": 3000.0, "a123": 2060.0}[self.name]
        chem = "lifepo4" if self.name == "a123" else "lipo"
        empty = 2.5 if self.name == "a123" else 3.5
        pack = BatteryPack(name=self.name, cells_series=1, capacity_mah=cap, mass_kg=0.07,
                           chemistry=chem, cell_voltage_empty_v=empty)
        return Draw(rec, pack, None, cells_kind=self.name,
                    pack_resistance_ohm={"p42a": 7.87e-3, "q30": 30e-3, "a123": 10e-3}[self.name])


@functools.lru_cache(maxsize=4)
def _cells(name: str) -> pd.DataFrame:
    if name == "p42a":
        return cells.p42a(("cycle", "storage")).drop(columns="consumed_mah")
    if name == "q30":
        return cells.q30()
    return a123_discharges()


#: The A123 files' chamber temperature from their name. [°C]
A123_TEMPS = {"N25": -25.0, "N15": -15.0, "N05": -5.0, "P05": 5.0, "P15": 15.0,
              "P25": 25.0, "P35": 35.0, "P45": 45.0}


def a123_discharges() -> pd.DataFrame:
    """The A123 C/30 discharges to 2.0 V (step 2 of each OCV file), one experiment per
    chamber temperature, with that temperature as the pack's (``temperature_c``): the
    cell soaked at it before the test and C/30 barely heats it."""
    parts = []
    for tag, temp in A123_TEMPS.items():
        d = pd.read_csv(DATA / "battery/a123_temperature" / f"A123_OCV_{tag}_S1.csv")
        d = d[d["Step_Index"] == 2]
        t = d["Step_Time(s)"].to_numpy(float)
        i = -d["Current(A)"].to_numpy(float)
        v = d["Voltage(V)"].to_numpy(float)
        parts.append(pd.DataFrame({"experiment": f"a123_{tag}", "time_s": t - t[0],
                                   "voltage_v": v, "current_a": i, "power_w": v * i,
                                   "temperature_c": temp}))
    return pd.concat(parts, ignore_index=True)


#: What a log without an aircraft file can carry: diagnose's power level cannot run on it.
CAPACITY_ONLY = ("clean", "offset", "load", "cold_pack")


def sources() -> dict[str, Source]:
    """Every source of the matrix (module notes), by name."""
    from planner.parameters import load_aircraft

    solo = load_aircraft(REPO / "aircraft/solo_survey.yaml")
    return {
        "m100": M100(),
        "m100_routes": M100Routes(),
        "m100_mixed": M100Mixed(),
        "m100_measured": M100Measured(),
        # The log switches LOITER → ACRO at 206 s (from its first sample), comes down from
        # 8.6 m to 1.2 m by 228 s and sits there drawing 333 W against 225 W in the hover
        # before (the means of 230–243 s and 100–200 s): without the ``mode`` channel
        # diagnose reports it as a +103 W step of the power at 228 s (a 0.43 ± 0.03 kg
        # mass increase or anything else that raises the power), with the mode channel it
        # withholds it as a step at a mode change.
        "log171": Log("log171", "ardupilot_copter_quad_ac33dev_dronekit_log171.bin",
                      "aircraft/solo_survey.yaml",
                      rotors=inj.Rotors(4, solo.multirotor.rotor_diameter_m),
                      real=(RealEffect("payload_change", change_time_s=228.0),)),
        # no aircraft file: the injection laws assume four 12-inch rotors (a 6-Ah 4S quad)
        "ac313_2004": Log("ac313_2004", "ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin",
                          rotors=inj.Rotors(4, 0.305), carries=("clean", "payload", "offset",
                                                                 "load")),
        "ac313_2044": Log("ac313_2044", "ardupilot_copter_ac313_pixhawk_2014-10-18_20-44.bin",
                          rotors=inj.Rotors(4, 0.305), carries=("clean", "payload", "offset",
                                                                 "load")),
        "mcgill_hover": Log("mcgill_hover", "px4_hexa_mcgill_2022-05-24_hover_to_critical.tlog",
                            carries=CAPACITY_ONLY),
        # the same hexarotor on another day: three hovers with the rotors stopped between
        # them (rests), its pack at 25.5 V full and never near empty
        "mcgill_hovers": Log("mcgill_hovers", "px4_hexa_mcgill_2022-06-02_three_hovers.tlog",
                             carries=CAPACITY_ONLY),
        # four short PX4 flights of other vehicles (39-95 s, a few percent of their
        # packs): whatever is injected, the data can tell little, and must say so
        "px4_octo": Log("px4_octo", "px4_octo_legacy_sdlog2_01_07_59.px4log",
                        carries=CAPACITY_ONLY),
        "px4_quad_v3": Log("px4_quad_v3", "px4_quad_fmuv3_esc_status_log.ulg",
                           carries=CAPACITY_ONLY),
        "px4_quad_v6c": Log("px4_quad_v6c", "px4_quad_fmuv6c_indoor_quadrotor_local.ulg",
                            carries=CAPACITY_ONLY),
        "px4_quad_v6xrt": Log("px4_quad_v6xrt",
                              "px4_quad_fmuv6xrt_corrupt_unregistered_msg_id.ulg",
                              carries=CAPACITY_ONLY),
        "solar_surfer": SolarSurfer(),
        "p42a": Cells("p42a"),
        "q30": Cells("q30"),
        "a123": Cells("a123"),
    }


# ============================================================================ injection

@dataclass
class Injected:
    """A run's record and the truth of what was injected."""

    record: pd.DataFrame
    payload_kg: float | dict
    truth: dict            # parameter name → injected value (diagnose's units)
    size: float            # the injected size in the detection limit's unit
    fraction: float | None = None     # where in the flights a change falls (median)
    #: each flight's change time, s from its first sample (a payload change)
    change_times: dict | None = None
    cycle_spacing: float = 1.0        # mean cycles between consecutive discharges (fade)


def _uniform(rng, lo, hi, scale=1.0):
    return float(rng.uniform(lo, hi)) * scale


def inject(kind: str, d: Draw, rng, size: float, timing: str | None = None) -> Injected:
    """The draw's record with injection ``kind`` at ``size`` × realistic (module notes)."""
    rec, r = d.record, d.pack_resistance_ohm
    if kind == "clean":
        return Injected(rec, d.payload_kg, {}, 0.0)
    if kind == "payload":
        dm, times, fraction, since_start = _mass_change(d, rng, size, timing)
        # carried from take-off, released at the change: the record before the change is
        # flown dm heavier (the real flight is the state after the release)
        out = _carry_until(rec, dm, times, d)
        carried = {k: m + dm for k, m in d.payload_kg.items()} \
            if isinstance(d.payload_kg, dict) else d.payload_kg + dm
        return Injected(out, carried, {"mass_step_kg": -dm}, dm, fraction,
                        change_times=since_start)
    if kind == "pickup":
        # the same mass, picked up in flight: the record after the change is flown dm
        # heavier, the take-off payload the flights' own
        dm, times, fraction, since_start = _mass_change(d, rng, size, timing)
        out = inj.payload_step(rec, dm, times, d.mass_kg, rho=d.rho, pack_resistance_ohm=r,
                               rotors=d.rotors, wing=d.wing, w_per_kg=d.w_per_kg)
        return Injected(out, d.payload_kg, {"mass_step_kg": dm}, dm, fraction,
                        change_times=since_start)
    if kind == "wind":
        w = _uniform(rng, 3.0, 6.0, size)
        frm = _uniform(rng, 0.0, 360.0)
        law = _speed_law(d) if d.rotors is not None else None
        out = inj.steady_wind(rec, w, frm, law=law, pack_resistance_ohm=r, power_logged=False)
        return Injected(out, d.payload_kg, {"wind_speed_ms": w, "wind_from_deg": frm}, w)
    if kind == "density":
        ids = d.flights
        half = set(rng.choice(len(ids), max(1, len(ids) // 2), replace=False).tolist())
        deficit = (0.15 * size, 0.25 * size)
        ratios = {k: (1.0 - _uniform(rng, *deficit) if j in half else 1.0)
                  for j, k in enumerate(ids)}
        law = _speed_law(d) if d.rotors is not None else None
        site_t = 15.0 - 0.0065 * d.site_altitude_m
        site_p = d.rho * inj.R_AIR * (site_t + inj.T0_K)
        out = inj.air_density(rec, ratios, site_pressure_pa=site_p, site_temperature_c=site_t,
                              law=law, rng=rng, pack_resistance_ohm=r,
                              avionics_w=d.aircraft.system_power_w if d.aircraft else 0.0,
                              wing_split=None if law is not None else _wing_split(d))
        return Injected(out, d.payload_kg, {"density_exponent": 1.0}, 1.0)
    if kind == "load":
        p_med = _median_flying_power(rec, d)
        watts = _uniform(rng, 0.033, 0.09, size) * p_med
        out = inj.constant_load(rec, watts, pack_resistance_ohm=r)
        return Injected(out, d.payload_kg, {"missing_w": watts}, watts)
    if kind == "copper":
        p_med = _median_flying_power(rec, d)
        i_med = float(np.nanmedian(rec["current_a"]))
        share = _uniform(rng, 0.03, 0.08, size)
        ohm = share * p_med / i_med**2
        out = inj.copper_loss(rec, ohm, pack_resistance_ohm=r)
        v_med = float(np.nanmedian(rec["voltage_v"]))
        return Injected(out, d.payload_kg, {"copper_share": share,
                                            "copper_x": ohm * p_med / v_med**2}, share)
    if kind == "offset":
        lo, hi = (0.05, 0.15) if d.cells_kind else (0.3, 0.8)
        b = _uniform(rng, lo, hi, size)
        out = inj.current_offset(rec, b, power_logged=d.cells_kind is None, rng=rng)
        return Injected(out, d.payload_kg, {"current_offset_a": b}, b)
    if kind == "cold_pack":
        temps = {k: _uniform(rng, -5.0, 30.0) for k in d.flights}
        ea = 19_000.0 * size
        out = inj.cold_pack(rec, temps, ea_j_per_mol=ea, pack_resistance_ohm=r,
                            rng=rng)
        return Injected(out, d.payload_kg, {"activation_energy_j_per_mol": ea}, ea)
    if kind in ("fade", "cold_cells", "real_cold"):
        return _cell_injection(kind, d, rng, size)
    raise ValueError(kind)


def _mass_change(d: Draw, rng, size: float, timing: str):
    """A payload change's draw (module notes, "Sizes" and "Timing"): its mass [kg]
    (0.2–0.4 kg × ``size`` on the M100 with its mid payload, in proportion to the
    aircraft's mass elsewhere), each flight's change time [s of the record's time], the
    median fraction of the airborne span it falls at, and each change time from its
    flight's first sample [s]."""
    dm = _uniform(rng, 0.2, 0.4, size * _mean(d.mass_kg) / 2.955)
    lo, hi = TIMINGS[timing]
    fr = rng.uniform(lo, hi, len(d.flights)) if timing == "random" else \
        np.full(len(d.flights), rng.uniform(lo, hi))
    times = inj.change_times(d.record, fr, flying=_flying(d))
    t0 = {str(k): float(d.record.loc[idx, "time_s"].iloc[0])
          for k, idx in inj.experiments(d.record)}
    return dm, times, float(np.median(fr)), {str(k): t - t0[str(k)] for k, t in times.items()}


def _mean(x) -> float:
    """A mass, or the mean of a draw's per-flight masses. [kg]"""
    return float(np.mean(list(x.values()))) if isinstance(x, dict) else float(x)


def given(record: pd.DataFrame, payload_kg) -> tuple[pd.DataFrame, dict]:
    """The record and diagnose's payload option for ``payload_kg``: one value for every
    flight, or each flight's own (a mapping) as the record's ``payload_kg`` column, which
    diagnose reads per flight when no payload is given."""
    if not isinstance(payload_kg, dict):
        return record, {"payload_kg": payload_kg}
    out = record.copy()
    out["payload_kg"] = out["experiment"].astype(str).map(payload_kg).astype(float)
    return out, {"payload_kg": None}


def _carry_until(rec, dm, times, d: Draw) -> pd.DataFrame:
    """The record flown ``dm`` heavier before each flight's change time (the payload
    carried from take-off and released then): :func:`testkit.injections.payload_step` of
    +dm applied before the change, i.e. the step of −dm at the change on a flight that
    was dm heavier all along."""
    heavy_from_start = {k: -np.inf for k in times}
    heavy = inj.payload_step(rec, dm, heavy_from_start, d.mass_kg, rho=d.rho,
                             pack_resistance_ohm=0.0, rotors=d.rotors, wing=d.wing,
                             w_per_kg=d.w_per_kg)
    dp_all = heavy["power_w"].to_numpy(float) - rec["power_w"].to_numpy(float)
    t = rec["time_s"].to_numpy(float)
    before = np.zeros(len(rec), bool)
    for key, idx in inj.experiments(rec):
        if key in times:
            pos = rec.index.get_indexer(idx)
            before[pos] = t[pos] < times[key]
    return inj.add_power(rec, np.where(before, dp_all, 0.0), d.pack_resistance_ohm)


def _speed_law(d: Draw) -> inj.SpeedLaw:
    return inj.fit_speed_law(d.record, d.mass_kg, d.rho, d.rotors)


def _wing_split(d: Draw):
    """Parasite and induced power of each sample of a fixed wing at its logged airspeed
    (the aircraft's C_D0 and span, the law's propulsive efficiency). [W]"""
    fw = d.aircraft.fixed_wing

    def split(g):
        v = np.maximum(inj.speed_of(g), 5.0)
        q = 0.5 * d.rho * v**2
        par = q * fw.wing_area_m2 * fw.cd0 * v / d.wing.propulsive_efficiency
        ind = (d.mass_kg * inj.G) ** 2 / (q * math.pi * d.wing.oswald * d.wing.span_m**2) \
            * v / d.wing.propulsive_efficiency
        return par, ind

    return split


def _flying(d: Draw):
    """The samples of an experiment at which the draw's aircraft flies: a multirotor's
    :func:`testkit.injections.lifting`, else :func:`testkit.injections.airborne`."""
    if d.rotors is None:
        return inj.airborne
    return lambda g: inj.lifting(g, d.mass_kg, d.rho, d.rotors.area_m2)


def _median_flying_power(rec, d: Draw) -> float:
    p = []
    flying = _flying(d)
    for _, idx in inj.experiments(rec):
        g = rec.loc[idx]
        p.append(g["power_w"].to_numpy(float)[flying(g)])
    p = np.concatenate(p)
    return float(np.nanmedian(p)) if p.size else float(np.nanmedian(rec["power_w"]))


#: Realistic cell ageing: capacity fade and DC-resistance growth. [1/cycle]
FADE_PER_CYCLE, R_GROWTH_PER_CYCLE = 0.0004, 0.0006


def _cell_injection(kind, d: Draw, rng, size) -> Injected:
    parts = [g.reset_index(drop=True) for _, g in d.record.groupby("experiment", sort=False)]
    if kind == "real_cold":
        # the truth: the energy each discharge gave against the 25 °C one, as the charge
        # scale 1 + k h of the cut-off level (testkit.cells.charge_scale_equivalent)
        ref = next(g for g in parts if g["temperature_c"].iloc[0] == 25.0)
        pairs = [g for g in parts if g["temperature_c"].iloc[0] < 25.0]
        f = np.array([cells.energy_wh(ref) / cells.energy_wh(g) - 1.0 for g in pairs])
        dz = np.array([cells.mean_hinge(g) for g in pairs])
        k = cells.charge_scale_equivalent(f, dz, np.zeros_like(dz))
        return Injected(d.record, 0.0, {"temperature_coefficient_per_c": k}, k)
    out, xs, z0, pairs = [], [], [], []
    if kind == "fade":
        for g in parts:
            n = float(rng.uniform(0.0, 500.0))
            a = cells.age(g, n, size * FADE_PER_CYCLE, size * R_GROWTH_PER_CYCLE,
                          d.pack_resistance_ohm)
            out.append(a)
            xs.append(n)
            z0.append(0.0)
            pairs.append((g, a))
        order = np.argsort(xs)                # logs listed by date: experiment order = cycles
        out = [out[j] for j in order]
        spacing = float(np.ptp(xs)) / max(len(xs) - 1, 1)
        key = "fade_per_cycle"
    else:
        cold = set(rng.choice(len(parts), len(parts) // 2, replace=False).tolist())
        for j, g in enumerate(parts):
            if "temperature_c" not in g:
                g = g.assign(temperature_c=22.0, ambient_temperature_c=22.0)
            if j not in cold:
                out.append(g)
                continue
            drop = float(g["ambient_temperature_c"].mean())
            c = cells.chill(g, drop, size * 0.10, size * d.pack_resistance_ohm, 19_000.0)
            out.append(c)
            xs.append(cells.mean_hinge(c) - cells.mean_hinge(g))
            z0.append(cells.mean_hinge(g))
            pairs.append((g, c))
        key = "temperature_coefficient_per_c"
    if kind != "fade":
        spacing = 1.0
    full = np.array([float(g["voltage_v"].iloc[-1]) <= 3.5 for g, _ in pairs])
    truth = float("nan")
    if full.any():
        f = np.array([cells.energy_wh(g) / cells.energy_wh(c) - 1.0
                      for (g, c), ok in zip(pairs, full) if ok])
        truth = cells.charge_scale_equivalent(f, np.asarray(xs)[full], np.asarray(z0)[full])
    return Injected(pd.concat(out, ignore_index=True), 0.0, {key: truth}, truth,
                    cycle_spacing=spacing)


# ============================================================================ cells of the matrix

@dataclass(frozen=True)
class Cell:
    source: str
    injection: str
    richness: str
    timing: str | None
    size: str

    @property
    def name(self) -> str:
        t = f"/{self.timing}" if self.timing else ""
        return f"{self.source}/{self.injection}{t}/{self.richness}/{self.size}"

    @property
    def expect(self) -> str | None:
        return EXPECT[self.injection]


def all_cells(source_names=None, sizes=("realistic", "2x")) -> list[Cell]:
    """Every cell of the matrix (module notes) for the named sources."""
    out = []
    for name, src in sources().items():
        if source_names and name not in source_names:
            continue
        for kind in src.carries:
            timings = list(TIMINGS) if kind in ("payload", "pickup") else [None]
            for rich in RICHNESS:
                for timing in timings:
                    for size in (("realistic",) if kind in ("clean", "real_cold") else sizes):
                        out.append(Cell(name, kind, rich, timing, size))
    return out


#: Sources that draw the same flights and inject the same sizes at the same times as
#: another, by another law: their runs pair with that source's run by run.
SAME_DRAWS = {"m100_measured": "m100"}


def _seed(cell: Cell, run: int, seed: int) -> int:
    return zlib.crc32(f"{SAME_DRAWS.get(cell.source, cell.source)}|{run}|{seed}".encode())


def _detail_seed(cell: Cell, run: int, seed: int) -> int:
    # a telemetry rate reduces the same injection: the seed of the richness without it
    base = dataclasses.replace(cell, richness=split_richness(cell.richness)[0],
                               source=SAME_DRAWS.get(cell.source, cell.source))
    return zlib.crc32(f"{base.name}|{run}|{seed}".encode())


#: The parameter (diagnose's detection entries) each injection's size is given in.
SIZE_KEY = {"payload": "mass_step_kg", "pickup": "mass_step_kg", "wind": "wind_speed_ms",
            "density": "density_exponent",
            "load": "system_power_w", "copper": "efficiency_slope",
            "offset": "current_offset_a", "cold_pack": "activation_energy_j_per_mol",
            "fade": "fade_per_cycle", "cold_cells": "temperature_coefficient_per_c",
            "real_cold": "temperature_coefficient_per_c"}


def detection_of(res, effect: str, key: str | None) -> list[dict]:
    """diagnose's detection entries for ``effect`` whose limit is in the parameter
    ``key`` (any parameter when None)."""
    return [d for d in getattr(res, "detection", []) or []
            if d["effect"] == effect and (key is None or d.get("parameter") == key)]


def limit_at(entry: dict | None, fraction: float | None) -> float:
    """The detection limit of an entry (the one for the position ``fraction`` of a change
    within the flights where the entry gives limits by position); inf when not
    identifiable at any size."""
    if entry is None or not entry.get("identifiable"):
        return math.inf
    by = entry.get("by_position")
    if by and fraction is not None:
        keys = np.array([float(k) for k in by])
        vals = np.array([math.inf if by[k] is None else by[k] for k in by], float)
        if not np.isfinite(vals).any():
            return math.inf
        return float(np.interp(fraction, keys, vals))
    lim = entry.get("limit")
    return math.inf if lim is None else float(lim)


def within_2se(effect: str, params: dict, truth: dict) -> bool | None:
    """Whether the finding's parameter lies within two standard errors of the injected
    value (None where the injection has no value in diagnose's units)."""
    key = {"payload_change": "mass_step_kg", "wind": "wind_speed_ms",
           "air_density": "density_exponent", "system_power": "missing_w",
           "current_offset": "current_offset_a", "capacity_fade": "fade_per_cycle",
           "efficiency_curve": "efficiency_slope"}.get(effect)
    if effect == "temperature":
        for k in ("activation_energy_j_per_mol", "temperature_coefficient_per_c"):
            if k in truth and k in params and math.isfinite(truth[k]):
                return abs(params[k] - truth[k]) <= 2 * params.get(k + "_stderr", math.inf)
        return None
    if key is None or key not in truth or key not in params or not math.isfinite(truth[key]):
        return None
    if params.get("cycle_from_experiment_order"):      # per experiment, not per cycle
        return None
    se = params.get(key + "_stderr", params.get("system_power_w_stderr", math.inf))
    return abs(params[key] - truth[key]) <= 2 * se


def clean_parameters(d: Draw, richness: str, effect: str) -> dict | None:
    """The parameters of ``effect`` fitted (named or not) on the draw's clean record at
    ``richness``: what the real flights carry of it already (their own wind, load,
    efficiency curve), added to the injected value for the truth."""
    from planner.identify.diagnose import diagnose
    from planner.identify.diagnose.effects import make_effects

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            record, payload = given(reduce(d.record, richness), d.payload_kg)
            res = diagnose(record, d.pack, diagnosed_aircraft(d, richness),
                           site_altitude_m=d.site_altitude_m, effects=[effect], **payload)
            lv = res.levels["power"].result.level
            e = make_effects([effect])[0]
            if e.skip_reason(lv):
                return None
            fit = lv.fit([e], np.ones(lv.n_rows, bool))
            values, stderr = lv.physical(fit, [e])
            return e.parameters(values, stderr, lv, fit.state)
        except Exception:
            return None


def located_changes(params: dict) -> dict[str, float]:
    """The change times a finding locates, per flight (``change_time_s[<flight>]`` of its
    parameters; its ``change_time_min_s`` where it names no flight). [s]"""
    out = {k[len("change_time_s["):-1]: float(v) for k, v in params.items()
           if k.startswith("change_time_s[")}
    if not out and "change_time_min_s" in params:
        out[""] = float(params["change_time_min_s"])
    return out


def classify(finding: dict, real: tuple[RealEffect, ...], expect: str | None,
             change_times: dict | None = None) -> str:
    """Whose a finding is: ``"own"`` (an effect the record carries itself, :class:`RealEffect`),
    ``"injected"`` (the injected effect) or ``"other"`` (a false cause).

    A finding of an effect the record carries at a time is the record's own where each
    change it locates lies within ``within_s`` of the record's; where the injection is the
    same effect, it is the injected one only where each change lies within ``within_s`` of
    the injected change of its flight (``change_times``) and nearer to it than to the
    record's own, and any other time is neither. A real effect without a time is the
    record's own unless it is the injected effect."""
    effect = finding["effect"]
    for r in real:
        if r.effect != effect:
            continue
        located = located_changes(finding.get("parameters", {}))
        if r.change_time_s is None or not located:
            return "injected" if effect == expect else "own"
        to_own = {k: abs(t - r.change_time_s) for k, t in located.items()}
        if effect == expect and change_times:
            to_inj = {k: min(abs(t - c) for c in ([change_times[k]] if k in change_times
                                                   else change_times.values()))
                      for k, t in located.items()}
            if all(to_inj[k] <= r.within_s and to_inj[k] < to_own[k] for k in located):
                return "injected"
        if all(d <= r.within_s for d in to_own.values()):
            return "own"
        return "other"
    return "injected" if effect == expect else "other"


def _truth(kind: str, injd: Injected, clean: dict | None, res) -> tuple[dict, float]:
    """The truth in diagnose's units and the size in the detection entries' parameter,
    with what the clean record carries already (``clean``: :func:`clean_parameters`, or a
    wind measured otherwise, :func:`anemometer_wind_of`; module notes)."""
    truth, size = dict(injd.truth), injd.size
    if kind == "wind" and clean:
        from planner.physics.wind import course_deg

        to = math.radians(truth["wind_from_deg"] + 180.0)
        wn = clean["wind_n_ms"] + truth["wind_speed_ms"] * math.cos(to)
        we = clean["wind_e_ms"] + truth["wind_speed_ms"] * math.sin(to)
        truth["wind_speed_ms"] = size = math.hypot(wn, we)
        truth["wind_from_deg"] = float(course_deg(-we, -wn))     # blows from
    if kind == "load" and clean:
        truth["missing_w"] += clean["missing_w"]
    if kind == "copper":
        base = res.levels.get("power")
        eta = base.base_values["efficiency"] if base else 0.5
        x = truth["copper_x"]
        slope = -eta * x / (1.0 + x)
        size = abs(slope)
        truth["efficiency_slope"] = slope + (clean["efficiency_slope"] if clean else 0.0)
    return truth, size


def run_cell(cell: Cell, runs: int, seed: int = 0, draws: dict | None = None) -> dict:
    """Run one cell ``runs`` times; the tallies of the module notes."""
    from planner.identify.diagnose import diagnose

    src = sources()[cell.source]
    n = max(1, round(runs * src.runs_scale))
    st = {"cell": cell.name, "source": cell.source, "injection": cell.injection,
          "richness": cell.richness, "timing": cell.timing, "size": cell.size,
          "expect": cell.expect, "runs": n, "named_first": 0, "named_any": 0,
          "false_runs": 0, "false": Counter(), "silent": 0, "identifiable": 0,
          "said_not_identifiable": 0, "within_2se": 0, "checked_2se": 0, "limits": [],
          "named_first_identifiable": 0, "named_or_said_not_identifiable": 0,
          "sizes": [], "cpu_s": [], "errors": Counter(), "own": Counter(), "winds": [],
          "per_run": [], "not_settled": 0}
    draws = {} if draws is None else draws
    for run in range(n):
        key = (cell.source, run, seed)
        if key not in draws:
            draws[key] = src.draw(np.random.default_rng(_seed(cell, run, seed)))
        d = draws[key]
        rng = np.random.default_rng(_detail_seed(cell, run, seed))
        try:
            injd = inject(cell.injection, d, rng, SIZES[cell.size], cell.timing)
        except Exception as exc:            # a source that cannot carry this injection
            st["errors"][f"inject: {type(exc).__name__}: {exc}"[:160]] += 1
            continue
        record, payload = given(reduce(injd.record, cell.richness), injd.payload_kg)
        opts = {**payload, "site_altitude_m": d.site_altitude_m}
        t0 = time.process_time()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = diagnose(record, d.pack, diagnosed_aircraft(d, cell.richness),
                               **opts)
        except Exception as exc:
            st["errors"][f"diagnose: {type(exc).__name__}: {exc}"[:160]] += 1
            continue
        st["cpu_s"].append(time.process_time() - t0)
        expect = cell.expect
        kinds = [classify(f, src.real, expect, injd.change_times) for f in res.findings]
        if isinstance(src, M100) and cell.injection != "wind" and \
                any(f["effect"] == "wind" for f in res.findings):
            # a wind named on M100 flights against the one their anemometer measured: the
            # flights' own weather where the two agree (module notes)
            measured = anemometer_wind_of(d)
            for j, f in enumerate(res.findings):
                if f["effect"] != "wind" or measured is None:
                    continue
                against = wind_against(f["parameters"], measured)
                st["winds"].append(against)
                kinds[j] = weather_kind(against)
        st["own"].update(f["effect"] for f, k in zip(res.findings, kinds) if k == "own")
        # the record's own findings aside: silence, false causes and "named first" are
        # judged on the rest
        rest = [(f, k) for f, k in zip(res.findings, kinds) if k != "own"]
        st["silent"] += not rest
        # a payload change the data neither name nor exclude (limits.unsettled)
        st["not_settled"] += any("unsettled" in e for e in getattr(res, "detection", []) or [])
        false = [f["effect"] for f, k in rest if k == "other"]
        st["false_runs"] += bool(false)
        st["false"].update(false)
        if expect is None:
            continue
        clean = None
        if cell.injection == "wind" and isinstance(src, M100):
            clean = anemometer_wind_of(d)       # measured, not diagnose's own (notes)
        if cell.injection in ("wind", "load", "copper") and d.aircraft is not None \
                and clean is None:
            ck = (key, cell.richness, expect)
            if ck not in draws:
                draws[ck] = clean_parameters(d, cell.richness, expect)
            clean = draws[ck]
        truth, size = _truth(cell.injection, injd, clean, res)
        entries = detection_of(res, expect, SIZE_KEY.get(cell.injection))
        if cell.injection == "fade" and any(e.get("per") == "experiment order"
                                            for e in entries):
            # without a cycle count the fade is per experiment (logs in date order)
            size *= injd.cycle_spacing
        limit = min([limit_at(e, injd.fraction) for e in entries], default=math.inf)
        if any(f["effect"] == expect and k == "own" for f, k in zip(res.findings, kinds)):
            # the record's own change holds the flight: a second one there is seen only
            # where larger than it (the entry's ``second_change``)
            limit = max([limit] + [e["second_change"]["limit"] for e in entries
                                   if e.get("second_change")])
        st["limits"].append(limit)
        st["sizes"].append(size)
        ident = math.isfinite(limit) and abs(size) >= limit
        st["identifiable"] += ident
        first = bool(rest) and rest[0][1] == "injected"
        if first:
            st["named_first"] += 1
            ok = within_2se(expect, rest[0][0]["parameters"], truth)
            if ok is not None:
                st["checked_2se"] += 1
                st["within_2se"] += bool(ok)
        st["named_first_identifiable"] += ident and first
        named_any = any(k == "injected" for _, k in rest)
        if named_any:
            st["named_any"] += 1
            st["named_or_said_not_identifiable"] += not ident
        elif not ident:
            st["said_not_identifiable"] += bool(entries)
            st["named_or_said_not_identifiable"] += bool(entries)
        st["per_run"].append({"size": float(size), "limit": float(limit),
                              "named_first": first, "named_any": named_any,
                              "not_settled": any("unsettled" in e for e in entries)})
    return st


def run_by_run(stats: list[dict]) -> dict:
    """The criterion read run by run over realistic-size cells with an injection
    (``stats``: :func:`run_cell`'s tallies; older tallies without the run-by-run counts
    are left out): the runs whose detection limit calls the injected size identifiable
    and those named first among them; the other runs and those in which the effect was
    named anyway or said not identifiable."""
    out = {"identifiable": 0, "named_first": 0, "not_identifiable": 0, "named_or_said": 0,
           "cells": 0}
    for st in stats:
        if st.get("size") != "realistic" or st.get("expect") is None or \
                "named_first_identifiable" not in st:
            continue
        n = max(st["runs"] - sum(dict(st["errors"]).values()), 0)
        out["cells"] += 1
        out["identifiable"] += st["identifiable"]
        out["named_first"] += st["named_first_identifiable"]
        out["not_identifiable"] += n - st["identifiable"]
        out["named_or_said"] += st["named_or_said_not_identifiable"]
    return out


#: Bins of the injected size over its detection limit in :func:`limit_calibration`.
RATIO_BINS = (0.0, 0.5, 1.0, 1.5, 2.0, math.inf)


def limit_calibration(stats: list[dict]) -> dict[str, list[list[int]]]:
    """How often an effect is named first against its size over the detection limit the
    same run gave (``per_run`` of :func:`run_cell`'s tallies, every size; runs whose limit
    is infinite, said not identifiable at any size, are left out): per injection and
    over all (``"all"``), [runs, named first] in each bin of :data:`RATIO_BINS`. The limit
    is the size named with :data:`planner.identify.diagnose.limits.POWER` (80 %)
    probability, so at 1–1.5 times it at least that share should be named, and below it
    fewer."""
    out: dict[str, list[list[int]]] = {}
    edges = np.array(RATIO_BINS)
    for st in stats:
        for r in st.get("per_run", []):
            lim = r["limit"]
            if not (math.isfinite(lim) and lim > 0) or st.get("expect") is None:
                continue
            k = int(np.searchsorted(edges, abs(r["size"]) / lim, side="right")) - 1
            for key in (st["injection"], "all"):
                row = out.setdefault(key, [[0, 0] for _ in range(len(edges) - 1)])
                row[k][0] += 1
                row[k][1] += bool(r["named_first"])
    return out


def limit_calibration_text(cal: dict[str, list[list[int]]]) -> list[str]:
    """:func:`limit_calibration` as a Markdown table: named first of runs, per bin."""
    heads = [f"{a:g}–{b:g}×" if math.isfinite(b) else f"≥ {a:g}×"
             for a, b in zip(RATIO_BINS[:-1], RATIO_BINS[1:])]
    lines = ["| injection (size / limit) | " + " | ".join(heads) + " |",
             "|---|" + "---|" * len(heads)]
    for key in sorted(cal, key=lambda k: (k == "all", k)):
        cells = [f"{f} of {n} ({100 * f / n:.0f} %)" if n else "–" for n, f in cal[key]]
        lines.append(f"| {key} | " + " | ".join(cells) + " |")
    return lines


def run_by_run_text(r: dict) -> str:
    """:func:`run_by_run` in one line."""
    def pct(a, b):
        return f"{100 * a / b:.0f} %" if b else "–"
    return (f"run by run ({r['cells']} realistic cells with an injection): the limit calls "
            f"the injected size identifiable in {r['identifiable']} runs, named first in "
            f"{r['named_first']} ({pct(r['named_first'], r['identifiable'])}); in the other "
            f"{r['not_identifiable']} runs the effect is named or said not identifiable in "
            f"{r['named_or_said']} ({pct(r['named_or_said'], r['not_identifiable'])})")


def verdict(st: dict) -> tuple[str, bool | None]:
    """The issue's criterion for one realistic-size cell: (kind, met). Kinds: ``clean``
    (silent in ≥ 95 %, the record's own findings aside), ``identifiable`` (the detection
    limit calls it so in most runs, more than half: named first in ≥ 80 %, within 2 SE in
    most: more than half of those checked), ``not identifiable`` (said so where not found,
    false causes in ≤ 5 %)."""
    n = max(st["runs"] - sum(st["errors"].values()), 1)
    if st["expect"] is None:
        return "clean", st["silent"] / n >= 0.95
    false_ok = st["false_runs"] / n <= 0.05
    if st["identifiable"] / n > 0.5:        # most runs: a cell split evenly is not
        two = st["within_2se"] > 0.5 * st["checked_2se"] if st["checked_2se"] else True
        return "identifiable", st["named_first"] / n >= 0.8 and two
    missed = n - st["named_any"]
    said = st["said_not_identifiable"] >= missed
    return "not identifiable", said and false_ok


def promised_power(ratio: float) -> float:
    r"""The probability of naming an effect that the detection limit promises at ``ratio``
    times the limit: the power curve of the one-sided normal test the limit is built on
    (:func:`planner.identify.stats.detectable_size`), :math:`\Phi((z_{1-\alpha} +
    z_{P})\,r - z_{1-\alpha})`, with the held-out test's α and the limit's power P
    (80 % at r = 1). [unitless]"""
    from scipy.stats import norm

    from planner.identify.diagnose.limits import POWER
    from planner.identify.diagnose.search import ALPHA_HELDOUT

    za, zp = float(norm.ppf(1.0 - ALPHA_HELDOUT)), float(norm.ppf(POWER))
    return float(norm.cdf((za + zp) * ratio - za))


def expected_to_meet(st: dict) -> float | None:
    """The probability that a realistic-size cell meets :func:`verdict`'s criterion if
    each run named its effect exactly as often as its own detection limit promises
    (:func:`promised_power` of its size over its limit; a run whose limit is infinite,
    said not identifiable at any size, never). It asks whether the criterion, read cell
    by cell, asks more than the limit promises: a cell whose limit calls 3 of 5 runs
    identifiable is judged as identifiable and needs 4 named, so at least one below its
    limit. Cells of the kind ``identifiable``: the chance that at least 80 % of the runs
    are named first (the runs independent: a Poisson binomial); ``not identifiable``:
    that every run the limit calls identifiable is named. The check of the size within
    2 SE is taken as met. None for a clean cell (no power statement) or a tally without
    its runs."""
    runs = st.get("per_run")
    if st.get("expect") is None or not runs:
        return None
    p = np.array([promised_power(abs(r["size"]) / r["limit"])
                  if math.isfinite(r["limit"]) and r["limit"] > 0 else 0.0 for r in runs])
    kind, _ = verdict(st)
    if kind == "not identifiable":
        ident = np.array([math.isfinite(r["limit"]) and abs(r["size"]) >= r["limit"]
                          for r in runs])
        return float(np.prod(p[ident]))
    dist = np.zeros(len(p) + 1)
    dist[0] = 1.0
    for q in p:                   # the distribution of the number named, run by run
        dist[1:] = dist[1:] * (1.0 - q) + dist[:-1] * q
        dist[0] *= 1.0 - q
    return float(dist[math.ceil(0.8 * len(p) - 1e-9):].sum())


def expected_text(stats: list[dict]) -> str:
    """:func:`expected_to_meet` over the realistic-size cells with an injection, in one
    line: the cells that meet the criterion against those expected to, and the cells no
    run could let meet it (expected under 1 %)."""
    rows = [(st, expected_to_meet(st)) for st in stats if st.get("size") == "realistic"]
    rows = [(st, e) for st, e in rows if e is not None]
    if not rows:
        return "expected: no realistic cell with an injection and its runs"
    met = sum(bool(verdict(st)[1]) for st, _ in rows)
    exp = sum(e for _, e in rows)
    none = [st for st, e in rows if e < 0.01]
    return (f"the limit's promise (each run named as often as its own limit promises: 80 % "
            f"at 1×): {exp:.1f} of {len(rows)} cells with an injection expected to meet "
            f"the criterion, {met} meet it; {len(none)} {'cell' if len(none) == 1 else 'cells'} "
            f"cannot meet it as read cell by cell "
            f"({sum(bool(verdict(st)[1]) for st in none)} of them do)")
