"""diagnose names a cause only when the data can tell it (docs/diagnose_real_flights.md, honesty rules).

* plausibility — a fit with impossible parameters or the wrong sign is not a cause;
* confounds — a driver the data cannot tell from time or depth of discharge is not named;
* one currency — findings of both levels are ranked by the held-out error of the charge or
  energy at the end of the held-out segments;
* no leakage — a held-out flight's change time is not found on its scoring samples;
* direct evidence first — the logged current at rest decides about a sensor bias.

The data come from the independent generators of ``tests/helpers/diagnose_generators.py``.
"""

import numpy as np
import pytest
from diagnose_generators import PACK_6S, aircraft_file, battery, capacity_dataset, power_dataset

from planner.identify.diagnose import diagnose
from planner.identify.diagnose import effects as E


def names(result):
    return [f["effect"] for f in result.findings]


def withheld(result):
    return {w["effect"]: w for w in result.withheld}


# ----------------------------------------------------------------------------- plausibility

@pytest.mark.parametrize("effect, params, needle", [
    (E.Temperature, {"temperature_coefficient_per_c": -0.004}, "never more"),
    (E.Temperature, {"temperature_coefficient_per_c": 0.08}, "beyond any lithium cell"),
    (E.AirDensity, {"density_exponent": -0.7}, "outside"),
    (E.EfficiencyCurve, {"efficiency_at_low": 1.3, "efficiency_at_reference": 0.8,
                         "efficiency_at_high": 0.6}, "outside (0, 1]"),
])
def test_impossible_parameters_are_named_as_such(effect, params, needle):
    assert needle in effect().implausible(params, None)


def test_a_cold_effect_with_the_wrong_sign_is_withheld_not_named():
    """The pack temperature column reversed (a sensor mounted on the heater, say): the
    true cold effect then fits as "colder draws less", which is never a cause. (Mirrored
    and shifted so that every reading stays below the 25 °C reference of the hinge.)"""
    df, _ = capacity_dataset("temperature", 0.006, profile="flights", seed=1)
    t = df["temperature_c"]
    df["temperature_c"] = t.min() + t.max() - t - 15.0
    assert df["temperature_c"].max() < 25.0
    res = diagnose(df, battery())
    assert "temperature" not in names(res)
    w = withheld(res).get("temperature")
    assert w is not None and w["kind"] == "implausible" and "never more" in w["why"]
    assert "temperature" in res.unexplained()


def test_a_constant_load_above_the_ground_power_is_not_a_cause():
    """A load that exists only while the rotors turn (propulsion loss) looks like a
    constant load in the air; the ground samples (rotors stopped: the avionics' 8–12 W)
    show it is not one, also where the rotors idle on the ground for part of the record
    (a constant load is drawn at every moment: the ground's low percentile bounds it)."""
    pw = E.SystemPower()

    class Level:
        measured = np.array([300.0, 320.0, 350.0])
        ground_power_w = (8.0, 12.0)
        file_system_power_w = 12.0

    p = {"system_power_w": 80.0, "system_power_w_stderr": 5.0}
    assert "on the ground" in pw.implausible(p, Level())
    p = {"system_power_w": 15.0, "system_power_w_stderr": 5.0}
    assert pw.implausible(p, Level()) is None

    class Idle(Level):
        # on the ground 8 W with the rotors stopped, 60 W with them idle: a constant load
        # is drawn at every moment, so the rotors-stopped samples bound it
        ground_power_w = (8.0, 60.0)

    p = {"system_power_w": 50.0, "system_power_w_stderr": 5.0}
    assert "on the ground" in pw.implausible(p, Idle())

    class Mixed(Level):
        # 16 M100 flights of mixed payloads (Rodrigues et al. 2021, route R1; seed 1 of
        # the effect matrix's m100_mixed): a load of 137 ± 61 W fitted in the air, where
        # the ground reads -2 to 42 W. It stands 2.2 SE above the ground's bound: no
        # constant load, though 3 SE would have let it pass
        measured = np.array([380.0, 450.0, 520.0])
        ground_power_w = (-2.0, 42.0)
        file_system_power_w = 10.0

    p = {"system_power_w": 137.0, "system_power_w_stderr": 61.0}
    assert "on the ground" in pw.implausible(p, Mixed())
    p = {"system_power_w": 110.0, "system_power_w_stderr": 61.0}
    assert pw.implausible(p, Mixed()) is None


# ----------------------------------------------------------------------------- confounds

def test_self_heating_at_one_ambient_temperature_is_confounded_not_named():
    """A misfit that fades with depth of discharge (more charge per Wh early in every
    discharge), and a pack that starts at the same 15 °C every time and heats itself by
    8 °C: its temperature follows time and depth exactly, so a "cold pack" effect would
    fit — but the data cannot tell it from anything else that changes with depth, and it
    is not named."""
    import pandas as pd

    df, _ = capacity_dataset(None, profile="flights", seed=3)
    parts = []
    for _, g in df.groupby("experiment", sort=False):
        t = g.time_s.to_numpy()
        mid = 0.5 * (t[1:] + t[:-1]) / t[-1]
        inc = np.diff(g.consumed_mah.to_numpy()) * (1 + 0.15 * (1 - mid) ** 2)
        g = g.assign(consumed_mah=np.r_[0.0, np.cumsum(inc)],
                     temperature_c=15.0 + 8.0 * t / t[-1])
        parts.append(g)
    res = diagnose(pd.concat(parts), battery())
    assert "temperature" not in names(res)
    w = withheld(res).get("temperature")
    assert w is not None and w["kind"] == "confounded", res.summary()
    assert "the time since the start" in w["candidates"]
    assert "cannot tell temperature" in res.unexplained()


def test_a_cold_effect_across_ambient_temperatures_is_still_named():
    """The same self-heating, but the days differ by tens of degrees: the temperature has
    variation of its own and the cold effect is named."""
    df, _ = capacity_dataset("temperature", 0.006, profile="flights", seed=1)
    res = diagnose(df, battery())
    assert names(res)[:1] == ["temperature"]


# ----------------------------------------------------------------------------- direct evidence

def test_a_drift_the_rest_current_does_not_show_is_not_a_sensor_bias():
    """The logger's charge counter drifts (+0.2 A of phantom current) while its current
    channel reads zero at rest: the direct evidence (the rest current) says the sensor's
    zero is right, so current_offset — which the drift alone would pass — is not named."""
    import pandas as pd

    df, _ = capacity_dataset(None, profile="aprbs", seed=4)
    parts = []
    for _, g in df.groupby("experiment", sort=False):
        g = g.copy()
        n = len(g)
        # the load off for 5 % of each experiment
        g.iloc[int(0.4 * n):int(0.45 * n), g.columns.get_indexer(["power_w", "current_a"])] = 0
        t, i = g.time_s.to_numpy(), g.current_a.to_numpy()
        drawn = np.r_[0.0, np.cumsum(0.5 * (i[1:] + i[:-1]) * np.diff(t))]
        g["consumed_mah"] = (drawn + 0.2 * (t - t[0])) / 3.6
        parts.append(g)
    res = diagnose(pd.concat(parts), battery())
    assert "current_offset" not in names(res)
    w = withheld(res)["current_offset"]
    assert w["kind"] == "implausible" and "at rest" in w["why"]


def test_a_drift_the_power_channel_does_not_show_is_not_a_sensor_bias():
    """Where the power is logged independently of the current, the logged current against
    the power / voltage measures the sensor's offset sample by sample (0.35 ± 0.002 A
    here); a capacity-level drift 7 standard errors above it (0.44 ± 0.012 A, what the
    integral model's misfit adds to it) is not a sensor bias. Within 3 standard errors
    it is, and without the power channel the rule does not apply."""
    off = E.CurrentOffset()

    class Level:
        median_current_a = 14.0
        rest_current = None
        power_channel_offset = (0.352, 0.002)

    p = {"current_offset_a": 0.436, "current_offset_a_stderr": 0.012}
    assert "misfit of the integral model" in off.implausible(p, Level())
    assert off.implausible(dict(p, current_offset_a=0.36), Level()) is None
    Level.power_channel_offset = None
    assert off.implausible(p, Level()) is None


# ----------------------------------------------------------------------------- one currency

def test_findings_of_both_levels_are_ranked_by_one_measure():
    """A hidden power effect and a hidden capacity effect: the two levels' findings are
    ordered by the common held-out measure (percentage points of the final error)."""
    df, truth = power_dataset("wind", (4.0, 250.0), seed=2, duration_s=600.0, rate_hz=2.0)
    res = diagnose(df, battery(PACK_6S), aircraft_file(efficiency=0.6, drag_area_m2=0.06),
                   payload_kg=truth["payload_kg"])
    gains = [f["heldout"]["final_gain_pp"] for f in res.findings]
    by_level = {}
    for f in res.findings:
        by_level.setdefault(f["level"], []).append(f["heldout"]["final_gain_pp"])
    firsts = [v[0] for v in by_level.values()]
    assert res.findings and firsts == sorted(firsts, reverse=True)
    assert all(np.isfinite(gains))


# ----------------------------------------------------------------------------- payload step

class _Flights:
    """The few attributes of a power level that the payload step's checks read."""

    def __init__(self, climb, exp, time, names):
        self.climb, self.exp, self.time, self.names = climb, exp, time, names


def test_a_step_at_the_end_of_the_climb_is_confounded_with_the_regime():
    """A mass step switched on exactly where every flight levels off has the indicator of
    'not climbing': a power model with a wrong climb power fits it as well, so it is
    withheld with both candidates; the same step in the middle of level flight is not."""
    t = np.arange(200.0)
    climb = np.where(t < 40, 2.5, np.where(t > 170, -1.5, 0.0))
    pw = _Flights(np.r_[climb, climb], np.repeat([0, 1], 200), np.r_[t, t], ["a", "b"])
    at_climb_end = {"step_mask": (pw.time >= 40).astype(float),
                    "change_time_s": {"a": 40.0, "b": 40.0}}
    found = E.PayloadChange().regime_confound(pw, at_climb_end)
    assert found is not None and "the power model's climb or descent power" in found[1]
    mid = {"step_mask": (pw.time >= 100).astype(float),
           "change_time_s": {"a": 100.0, "b": 100.0}}
    assert E.PayloadChange().regime_confound(pw, mid) is None


class _Route(_Flights):
    """Flights that move at 10 m/s along ``courses`` (deg from north, one per bin), no
    logged wind: what the wind's and the payload step's confound checks read."""

    def __init__(self, courses, n_flights=2):
        c = np.radians(np.tile(courses, n_flights))
        n = len(courses)
        t = np.tile(np.arange(n, dtype=float), n_flights)
        super().__init__(np.zeros(t.size), np.repeat(np.arange(n_flights), n), t,
                         [f"f{k}" for k in range(n_flights)])
        self.vn, self.ve = 10.0 * np.cos(c), 10.0 * np.sin(c)
        self.course = np.degrees(c) % 360.0
        self.moving = np.ones(t.size, bool)
        self.course_known = self.moving
        self.has_course, self.airspeed_measured = True, False
        self.logged_wind_n = self.logged_wind_e = 0.0


OUT_AND_BACK = np.r_[np.full(100, 30.0), np.full(100, 210.0)]
SURVEY = np.tile(np.r_[np.full(25, 0.0), np.full(25, 90.0), np.full(25, 180.0),
                       np.full(25, 90.0)], 2)


def test_a_wind_on_an_out_and_back_route_is_confounded_with_a_mass_change():
    """Out and back, a steady wind changes the airspeed one way out and the other way back:
    a step at the turnaround, which a payload drop there fits as well. On a survey route
    (legs N, E, S, E) it is not one step, and the wind can be named."""
    wind = {"values": {"wind_n_ms": 3.0, "wind_e_ms": 1.0}}
    found = E.Wind().regime_confound(_Route(OUT_AND_BACK), wind)
    assert found is not None and found[1] == ["wind", "payload_change"]
    assert E.Wind().regime_confound(_Route(SURVEY), wind) is None


def test_a_mass_change_at_the_turnaround_is_confounded_with_a_wind():
    """The other way round: a drop at the turnaround of out-and-back flights follows the
    direction of travel, which a wind fits; the same drop on a survey route does not."""
    for route, confounded in ((OUT_AND_BACK, True), (SURVEY, False)):
        pw = _Route(route)
        step = {"step_mask": (pw.time >= 100).astype(float),
                "change_time_s": {"f0": 100.0, "f1": 100.0}}
        found = E.PayloadChange().regime_confound(pw, step)
        assert (found is not None and found[1] == ["payload_change", "wind"]) == confounded


def test_a_flight_flown_heavier_throughout_has_no_change_point():
    """A flight whose power is higher all along by what 0.3 kg more would draw (an
    unrecorded payload) is not a mass change in flight; a true mid-flight drop is."""
    from planner.identify.diagnose.search import PowerLevel

    rng = np.random.default_rng(7)
    n = 400
    t = np.arange(n, dtype=float)
    s = 60.0 * (1 + 0.1 * np.sin(t / 30))        # W per kg, as the mass sensitivity
    noise = 5.0 * rng.standard_normal(n)
    fake = _Flights(np.zeros(n), np.zeros(n, int), t, ["f"])
    rows, groups = np.arange(n), np.zeros(n, int)
    heavier = 0.3 * s + noise
    out = PowerLevel._scan(fake, rows, heavier, s, groups, fixed_step=None)
    assert out["f"] is None
    drop = np.where(t >= 250, -0.3 * s, 0.0) + noise
    out = PowerLevel._scan(fake, rows, drop, s, groups, fixed_step=None)
    assert out["f"] is not None and abs(out["f"] - 250) <= 5


def test_a_change_too_small_to_locate_is_expected_where_its_record_points():
    """A 0.02 kg drop at 20 % of a flight beats no threshold on its own (5 W noise, 20
    draws): the flight has no change point. Its expected mass step is the posterior
    probability that the change has happened (Smith, Biometrika 62, 407, 1975): on average
    0.6–0.8 from a third to three fifths of the flight, where a change uniform over the
    flight (the share elapsed) is 0.33–0.6; with the record silent (no step) the posterior
    is that uniform share."""
    from planner.identify.diagnose.search import PowerLevel

    class Level(_Flights):
        _change_posterior = staticmethod(PowerLevel._change_posterior)
        _expected_mask = PowerLevel._expected_mask

    n = 400
    t = np.arange(n, dtype=float)
    s = 60.0 * (1 + 0.1 * np.sin(t / 30))        # W per kg, as the mass sensitivity
    level = Level(np.zeros(n), np.zeros(n, int), t, ["f"])
    rows, groups = np.arange(n), np.zeros(n, int)
    share = (t + 1) / n
    expected = []
    for seed in range(20):
        r = np.where(t >= 80, -0.02 * s, 0.0) + 5.0 * np.random.default_rng(seed).standard_normal(n)
        post: dict = {}
        out = PowerLevel._scan(level, rows, r, s, groups, fixed_step=-0.02, posterior=post)
        assert out["f"] is None
        e = level._expected_mask(post, rows)
        assert np.all(np.diff(e) >= 0) and 0.0 <= e.min() and e.max() <= 1.0 + 1e-12
        expected.append(e)
    mean = np.mean(expected, axis=0)
    after = (t >= 130) & (t < 240)
    assert np.all(mean[after] - share[after] > 0.15), (mean[after] - share[after]).min()
    assert mean[t < 40].max() < 0.15
    post = {}
    PowerLevel._scan(level, rows, np.zeros(n), s, groups, fixed_step=-0.02, posterior=post)
    assert np.allclose(level._expected_mask(post, rows), share)


def test_no_offset_or_load_entry_where_the_power_is_measured_on_its_own():
    """The 'current offset or constant load' entry holds only where the power is V·I."""
    import pandas as pd

    from planner.identify.diagnose import _offset_or_load

    df = pd.DataFrame({"voltage_v": np.full(50, 22.0), "current_a": np.full(50, 20.0)})
    df["power_w"] = df["voltage_v"] * df["current_a"]
    assert _offset_or_load(df, {"power": None}, [])["effects"] == ["current_offset",
                                                                   "system_power"]
    assert _offset_or_load(df, {"power": None}, [{"effect": "current_offset"}]) is None
    df["power_w"] = df["power_w"] * 1.05
    assert _offset_or_load(df, {"power": None}, []) is None
