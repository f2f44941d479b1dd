"""The cut-off level of diagnose (planner/identify/diagnose/cutoff.py): which discharges count, and
capacity loss found on the energy to the cut-off.

The discharges here come from a generator that is not the planner's: a constant-current
cell with a tabulated open-circuit voltage against state of charge and an ohmic drop,
V = OCV(1 − q/Q) − I R, run until V reaches 2.5 V.
"""

import warnings

import numpy as np
import pandas as pd

from planner.identify.diagnose import cutoff as CO
from planner.identify.diagnose import diagnose
from planner.parameters import BatteryPack

#: Open-circuit voltage of a generic NMC cell against state of charge. [V]
SOC = np.array([-0.05, 0.0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9, 1.0])
OCV = np.array([1.5, 2.9, 3.3, 3.45, 3.55, 3.62, 3.72, 3.9, 4.08, 4.18])


def discharge(name, current_a, capacity_ah, r_ohm, cycle=None, temperature_c=None,
              dt=5.0, cutoff_v=2.5, start_soc=1.0):
    t = np.arange(0.0, 3600.0 * capacity_ah / current_a * 1.04, dt)
    q = current_a * t / 3600.0
    soc = start_soc - q / capacity_ah
    v = np.interp(soc, SOC, OCV, left=1.5) - current_a * r_ohm
    end = int(np.argmax(v <= cutoff_v)) if (v <= cutoff_v).any() else len(v) - 1
    n = end + 1
    d = {"experiment": name, "time_s": t[:n], "voltage_v": v[:n],
         "current_a": np.full(n, current_a), "power_w": v[:n] * current_a}
    if cycle is not None:
        d["cycle"] = float(cycle)
    if temperature_c is not None:
        d["temperature_c"] = temperature_c
    return pd.DataFrame(d)


def pack():
    return BatteryPack(name="cell", cells_series=1, capacity_mah=3000.0, mass_kg=0.05)


def run(df):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return diagnose(df, pack())


def _spread(n, seed=0):
    """Cell-to-cell capacity spread of ±0.4 % (1 σ)."""
    return 1.0 + 0.004 * np.random.default_rng(seed).standard_normal(n)


def test_only_full_discharges_to_one_cutoff_are_selected():
    exps = []
    for name, df in [("full", discharge("a", 3.0, 3.0, 0.03)),
                     ("partial", discharge("b", 3.0, 3.0, 0.03, cutoff_v=3.7)),
                     ("half-charged", discharge("c", 3.0, 3.0, 0.03, start_soc=0.5)),
                     ("other cut-off", discharge("d", 3.0, 3.0, 0.03, cutoff_v=3.0))]:
        exps.append({"name": name, "t": df["time_s"].to_numpy(),
                     "voltage": df["voltage_v"].to_numpy(), "p": df["power_w"].to_numpy(),
                     "c": df["current_a"].to_numpy() * df["time_s"].to_numpy()})
    exps.append(dict(exps[0], name="full 2"))
    chosen, what = CO.select(exps, pack())
    assert [e["name"] for e in chosen] == ["full", "full 2"]
    assert "1 more end at another cut-off" in what
    assert CO.select([dict(e, voltage=None) for e in exps], pack())[0] == []


def test_capacity_fade_is_named_on_the_energy_to_the_cutoff_with_its_size():
    """Eight discharges every 50 cycles of a cell losing 0.04 %/cycle of capacity (and
    0.06 %/cycle more resistance): capacity_fade at the cut-off level, its charge scale
    within 2 SE of the one the energies imply."""
    spread = _spread(8)
    parts, clean = [], []
    for k in range(8):
        n = 50 * k
        parts.append(discharge(f"d{k}", 3.0, 3.0 * spread[k] * (1 - 4e-4 * n),
                               0.03 * (1 + 6e-4 * n), cycle=n))
        clean.append(discharge(f"c{k}", 3.0, 3.0 * spread[k], 0.03, cycle=0))
    res = run(pd.concat(parts, ignore_index=True))
    assert [(f["effect"], f["level"]) for f in res.findings] == [("capacity_fade", "cutoff")]
    p = res.findings[0]["parameters"]
    e = lambda d: np.trapezoid(d["power_w"], d["time_s"])  # noqa: E731
    scale = np.array([e(c) / e(d) for c, d in zip(clean, parts)])
    n = 50.0 * np.arange(8)
    expected = np.polyfit(n, scale, 1)[0]          # the scale rises linearly with the cycle
    assert abs(p["fade_per_cycle"] - expected) < 2 * p["fade_per_cycle_stderr"] + 2e-5
    assert 5e-4 > p["fade_per_cycle"] > 3e-4


def test_clean_discharges_at_several_rates_name_no_cause():
    """A fresh cell at C/5 … 2C, some in a 5 °C room: the rate costs energy (the ohmic drop)
    and is the baseline's own term; without a cold effect in the generator no cause."""
    spread = _spread(10, seed=3)
    rates = [0.6, 1.5, 3.0, 4.5, 6.0] * 2
    temps = [24.0] * 5 + [5.0] * 5
    parts = [discharge(f"d{k}", i, 3.0 * spread[k], 0.03, temperature_c=tc)
             for k, (i, tc) in enumerate(zip(rates, temps))]
    res = run(pd.concat(parts, ignore_index=True))
    assert "cutoff" in res.levels
    assert res.levels["cutoff"].result.level.rate is not None
    assert res.findings == []


def test_cold_discharges_are_named_and_rate_is_not_mistaken_for_cold():
    """Half the discharges in a 0 °C room lose 10 % of their capacity and have twice the
    resistance: temperature is named at the cut-off level."""
    spread = _spread(10, seed=5)
    rates = [0.6, 1.5, 3.0, 4.5, 6.0] * 2
    cold = [False, True, False, True, False, True, False, True, False, True]
    parts = [discharge(f"d{k}", i, 3.0 * spread[k] * (0.9 if c else 1.0),
                       0.03 * (2.0 if c else 1.0), temperature_c=0.0 if c else 24.0)
             for k, (i, c) in enumerate(zip(rates, cold))]
    res = run(pd.concat(parts, ignore_index=True))
    assert [(f["effect"], f["level"]) for f in res.findings] == [("temperature", "cutoff")]
    k = res.findings[0]["parameters"]["temperature_coefficient_per_c"]
    assert 0.002 < k < 0.01          # 10 % capacity and the doubled ohmic loss over 24 K


def test_too_few_discharges_to_the_cutoff_say_a_capacity_loss_is_not_identifiable():
    parts = [discharge(f"d{k}", 3.0, 3.0 * (1 - 0.02 * k), 0.03, cycle=100 * k)
             for k in range(4)]
    res = run(pd.concat(parts, ignore_index=True))
    assert "cutoff" not in res.levels
    skip = [s for s in res.skipped if s["level"] == "cutoff"]
    assert {s["effect"] for s in skip} == {"capacity_fade", "temperature"}
    assert all("only 4 experiment(s)" in s["reason"] for s in skip)
    blind = [x for x in res.to_dict()["not_identifiable"] if x["level"] == "cutoff"]
    assert blind and "only 4 experiment(s)" in blind[0]["why"]
    assert "Not identifiable on these data: capacity_fade or temperature" in res.summary()


def test_the_json_and_the_plot_carry_the_cutoff_level(tmp_path):
    from planner.cli.plots.diagnose import save_diagnose_plot

    parts = [discharge(f"d{k}", 3.0, 3.0 * (1 - 4e-4 * 60 * k), 0.03, cycle=60 * k)
             for k in range(7)]
    res = run(pd.concat(parts, ignore_index=True))
    d = res.to_dict()
    base = next(b for b in d["baselines"] if b["level"] == "cutoff")
    assert base["unit"] == "%" and base["experiments"] == 7
    assert d["findings"][0]["level"] == "cutoff"
    save_diagnose_plot(res, tmp_path / "d.png")
    assert (tmp_path / "d.png").stat().st_size > 10_000


def test_cold_discharges_alternating_with_warm_ones_are_not_read_as_ageing():
    """No temperature logged, no cycle count: eight discharges of one cell, four of them
    cold (10 % less capacity), the cold ones mostly late in the files' order but one warm
    after them. A fade fits the trend, but the energies fall in two levels and a
    discharge of the high level comes after the low ones: ageing gives no capacity back,
    so the fade is withheld with that reason and no cause is named."""
    spread = _spread(8, seed=7)
    cold = [False, False, False, True, False, True, True, True]
    parts = [discharge(f"d{k}", 3.0, 3.0 * spread[k] * (0.9 if c else 1.0), 0.03)
             for k, c in enumerate(cold)]
    res = run(pd.concat(parts, ignore_index=True))
    assert res.findings == []
    why = {w["effect"]: w for w in res.withheld}
    assert why["capacity_fade"]["kind"] == "contradicted"
    assert "two levels" in why["capacity_fade"]["why"]
    assert "1 of the high level comes after one of the low" in why["capacity_fade"]["why"]


def test_two_levels_tell_a_trend_with_age_from_a_condition_that_alternates():
    """The plausibility test of a fade at the cut-off level: a linear trend with age and
    noise is ageing, and so are two sets of discharges at two ages where the cycle count
    gives them, or where each of two sets far apart in age declines too; two levels that
    alternate with age are not; two flat levels in order (a step: all high, then all low)
    are a change between the experiments, not told from ageing where the age is only the
    files' order; too few discharges say nothing."""
    from planner.identify.diagnose.effects import two_levels

    rng = np.random.default_rng(1)
    age = np.arange(8.0)
    trend = -0.01 * age + 0.002 * rng.standard_normal(8)
    assert two_levels(trend, age, None, 5e4, "cycle") is None
    alt = np.where(np.array([0, 0, 0, 1, 0, 1, 1, 1], bool), -0.1, 0.0) \
        + 0.002 * rng.standard_normal(8)
    why = two_levels(alt, age, None, 5e4, "cycle")
    assert why is not None and "4 and 4 discharges" in why
    step = np.where(age >= 4, -0.1, 0.0) + 0.002 * rng.standard_normal(8)
    assert "cannot be told apart" in two_levels(step, age, None, 5e4, "experiments' order")
    assert "a change between the experiments" in two_levels(step, age, None, 5e4, "cycle")
    # ageing measured at two ages (cycles 0-3 and 400-403): the trend with the cycles
    # fits as well as two levels, and the fade stands
    aged = np.r_[age[:4], 400 + age[:4]]
    assert two_levels(-1e-4 * aged + 0.002 * rng.standard_normal(8), aged, None, 5e4,
                      "cycle") is None
    assert two_levels(alt[:3], age[:3], None, 5e4, "cycle") is None
    # ageing within two sets far apart in age (cycles 0-60 and 400-460) with only the
    # files' order to go by: a step, but each set declines too, and the fade stands
    gap = np.r_[0.0, 20, 40, 60, 400, 420, 440, 460]
    within = -3e-4 * gap + 0.002 * rng.standard_normal(8)
    assert two_levels(within, age, None, 5e4, "experiments' order") is None
    # the rate term is taken out first: two levels of the current alone are not a condition
    rate = np.where(np.array([0, 1, 0, 1, 0, 1, 0, 1], bool), 0.5, -0.5)
    by_rate = -0.2 * rate - 0.01 * age + 0.002 * rng.standard_normal(8)
    assert two_levels(by_rate, age, rate, 5e4, "cycle") is None
