"""Test protocols: two-step tests ([UAV23] eq. 25–28), APRBS power schedules, pulse tests."""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from planner.identify import protocols as design
from planner.physics.battery import integral
from planner.identify.schedule import read_schedule, write_schedule

M_CONST = {"delta": 23.6482, "epsilon": -1.0209, "beta": 0.9648}  # [UAV23] Table 5

# --------------------------------------------------------------------------- [UAV23] Table 3

#: The model Table 3 implies (from the lead's reading of the table): ε and the
#: full-discharge time at 100 W, K = δ 100^ε C0^β.
TABLE_3_EPSILON = -1.0107
TABLE_3_K_S = 2986.0


def _table_3_model(c0_as=10_000 * 3.6, beta=integral.LITERATURE_BETA):
    """δ such that δ 100^ε C0^β = K for the chosen C0 and β (any choice gives the same t1)."""
    delta = TABLE_3_K_S / (100.0**TABLE_3_EPSILON * c0_as**beta)
    return {"delta": delta, "epsilon": TABLE_3_EPSILON, "beta": beta}, c0_as


def test_table_3_model_depends_only_on_k_and_epsilon():
    r"""The model [UAV23] Table 3 implies: ε = −1.0107 and K = δ·100^ε·C0^β = 2986 s.

    Eq. 25–28 give :math:`t_1 = \delta P_2^\varepsilon C_0^\beta / (k + (P_2/P_1)^\varepsilon)`;
    with :math:`K = \delta\,100^\varepsilon C_0^\beta` (the single-step time at 100 W),
    :math:`t_1 = K (P_2/100)^\varepsilon / (k + (P_2/P_1)^\varepsilon)`, so δ, C0 and β
    enter only through K: other C0, β with the same K give the same design.
    """
    a_model, a_c0 = _table_3_model(10_000 * 3.6, 0.9648)
    b_model, b_c0 = _table_3_model(5_000 * 3.6, 1.0)
    a = design.two_step(50, 125, 0.5, a_c0, **a_model)
    b = design.two_step(50, 125, 0.5, b_c0, **b_model)
    assert a.t1_s == pytest.approx(b.t1_s, rel=1e-12)
    # and at P1 = P2 = 100 W the total is K itself, whatever k
    single = design.two_step(100, 100, 3.0, a_c0, **a_model)
    assert single.total_s == pytest.approx(TABLE_3_K_S, rel=1e-12)


#: [UAV23] Table 3 (../shared/SEED_TABLES.md): nr, k, P1 [W], P2 [W], t1 [s], t2 [s],
#: t_test [s], as published.
UAV23_TABLE_3 = [
    (1, 1.0, 75, 100, 1708.5, 1708.5, 3417.0),
    (2, 1.0, 100, 75, 1708.5, 1708.5, 3417.0),
    (3, 2.0, 75, 100, 1086.7, 2173.5, 3260.2),
    (4, 2.0, 100, 75, 1196.5, 2393.1, 3589.6),
    (5, 0.5, 75, 100, 2393.1, 1196.5, 3589.6),
    (6, 0.5, 100, 75, 2173.5, 1086.8, 3260.3),
]


def _model_from_rows(rows):
    """ε and K of the integral model from two published rows with P2 = 100 W.

    For P2 = 100 W, eq. 25–28 give :math:`t_1 (k + (100/P_1)^\varepsilon) = K`; two rows
    with different k fix ε (a root in (−2, 0)) and then K.
    """
    from scipy.optimize import brentq

    (_, ka, p1a, _, t1a, _, _), (_, kb, p1b, _, t1b, _, _) = rows

    def mismatch(eps):
        return t1a * (ka + (100 / p1a) ** eps) - t1b * (kb + (100 / p1b) ** eps)

    eps = brentq(mismatch, -2.0, -0.5)
    return eps, t1a * (ka + (100 / p1a) ** eps)


def test_uav23_table_3_all_six_rows_within_0_2_percent():
    """[UAV23] Table 3: the two-step design of eq. 25–28 reproduces t1, t2 and t_test of all
    six published rows within 0.2 %, with the model the table implies.

    The model (ε and the single-step time K = δ 100^ε C0^β) is derived from rows 1 and 3
    alone (the rows with P2 = 100 W and k = 1, 2); the other four rows, and rows 1 and 3
    through t2 and t_test, are then predictions.
    """
    eps, k_s = _model_from_rows([UAV23_TABLE_3[0], UAV23_TABLE_3[2]])
    assert eps == pytest.approx(-1.0107, abs=0.002)          # the reading
    assert k_s == pytest.approx(2986.0, rel=0.001)
    c0 = 0.55 * 10_000 * 3.6          # designed for C0 ≈ 55 % of the 10 Ah pack
    beta = integral.LITERATURE_BETA
    delta = k_s / (100.0**eps * c0**beta)
    for nr, k, p1, p2, t1, t2, total in UAV23_TABLE_3:
        test = design.two_step(p1, p2, k, c0, delta, eps, beta)
        assert test.t1_s == pytest.approx(t1, rel=0.002), nr
        assert test.t2_s == pytest.approx(t2, rel=0.002), nr
        assert test.total_s == pytest.approx(total, rel=0.002), nr


# --------------------------------------------------------------------------- two-step

@pytest.mark.parametrize("p1,p2,k", [(50, 125, 1.0), (125, 50, 1.0), (75, 100, 0.5),
                                     (100, 50, 2.0), (50, 75, 3.0)])
def test_two_step_test_draws_exactly_c0(p1, p2, k):
    """[UAV23] eq. 25–28: the designed steps draw C0 under the model (exact piecewise sum)."""
    c0 = 10_000 * 3.6
    test = design.two_step(p1, p2, k, c0, **M_CONST)
    assert test.t2_s == pytest.approx(k * test.t1_s, rel=1e-12)
    stress = integral.stress_piecewise([test.t1_s, test.t2_s], [p1, p2], M_CONST["delta"],
                                       M_CONST["epsilon"])
    assert integral.charge_from_stress(stress[-1], M_CONST["beta"]) == pytest.approx(c0,
                                                                                    rel=1e-12)
    # and sampled through integral.charge on a 0.5 s grid
    t = np.arange(0.0, test.total_s, 0.5)
    c = integral.charge(t, design.sample_schedule(test.schedule(), t), **M_CONST)
    assert c[-1] == pytest.approx(c0, rel=1e-3)


def test_equal_powers_give_the_single_step_time():
    t = integral.discharge_time(80.0, 36000.0, **M_CONST)
    for k in (0.25, 1.0, 4.0):
        test = design.two_step(80, 80, k, 36000.0, **M_CONST)
        assert test.total_s == pytest.approx(t, rel=1e-12)
        assert test.t1_s == pytest.approx(t / (1 + k), rel=1e-12)


def test_two_step_is_vectorised():
    p2 = np.array([75.0, 100.0, 125.0])
    k = np.array([[0.5], [1.0]])
    t1, t2, total = design.two_step(50.0, p2, k, 36000.0, **M_CONST)
    assert t1.shape == (2, 3)
    for i in range(2):
        for j in range(3):
            one = design.two_step(50.0, p2[j], k[i, 0], 36000.0, **M_CONST)
            assert t1[i, j] == pytest.approx(one.t1_s, rel=1e-12)
            assert total[i, j] == pytest.approx(one.total_s, rel=1e-12)
    assert_allclose(t2, k * t1)


@pytest.mark.parametrize("kw", [{"p1_w": 0.0}, {"p2_w": -5.0}, {"k": 0.0},
                                {"capacity_as": np.nan}])
def test_two_step_rejects_impossible_inputs(kw):
    args = {"p1_w": 50.0, "p2_w": 125.0, "k": 1.0, "capacity_as": 36000.0} | kw
    with pytest.raises(ValueError, match=next(iter(kw))):
        design.two_step(**args, **M_CONST)


def test_two_step_schedule_table():
    test = design.two_step(50, 125, 2.0, 36000.0, **M_CONST)
    s = test.schedule()
    assert list(s.columns) == ["start_s", "duration_s", "power_w"]
    assert_allclose(s["start_s"], [0.0, test.t1_s])
    assert_allclose(s["duration_s"], [test.t1_s, test.t2_s])
    assert_allclose(s["power_w"], [50.0, 125.0])


# --------------------------------------------------------------------------- APRBS

def test_aprbs_follows_the_seed_recipe():
    """Levels 50/75/100/125 W, holds in [30, 300] s, total >= 3500 s ([UAV23] APRBS tests)."""
    s = design.aprbs([50, 75, 100, 125], (30, 300), 3500, rng=1)
    assert set(s["power_w"]) <= {50.0, 75.0, 100.0, 125.0}
    assert s["duration_s"].between(30, 300).all()
    assert_allclose(s["duration_s"] % 1.0, 0.0)  # whole seconds (default resolution)
    total = s["duration_s"].sum()
    assert total >= 3500 and total - s["duration_s"].iloc[-1] < 3500  # stops when reached
    assert (np.diff(s["power_w"]) != 0).all()  # every switch is a change
    assert_allclose(s["start_s"], np.r_[0.0, np.cumsum(s["duration_s"])[:-1]])


def test_aprbs_is_reproducible_with_a_seed_or_generator():
    a = design.aprbs([50, 75, 100, 125], rng=7)
    b = design.aprbs([50, 75, 100, 125], rng=np.random.default_rng(7))
    c = design.aprbs([50, 75, 100, 125], rng=8)
    pd.testing.assert_frame_equal(a, b)
    assert not a.equals(c)


def test_aprbs_hold_times_and_levels_are_uniform():
    """Long sequence: mean hold ≈ (30 + 300)/2 s, each level ≈ 1/4 of the steps."""
    s = design.aprbs([50, 75, 100, 125], (30, 300), 2_000_000, rng=3)
    holds = s["duration_s"].to_numpy()
    assert holds.mean() == pytest.approx(165.0, rel=0.01)
    assert holds.std() == pytest.approx(270 / np.sqrt(12), rel=0.02)
    shares = s["power_w"].value_counts(normalize=True)
    assert_allclose(shares.sort_index().to_numpy(), 0.25, atol=0.01)


@pytest.mark.parametrize("kw,match", [({"levels_w": [50, 50]}, "two different"),
                                      ({"hold_s": (300, 30)}, "hold_s"),
                                      ({"min_duration_s": 0}, "min_duration_s"),
                                      ({"levels_w": [50, -75]}, "levels_w")])
def test_aprbs_rejects_bad_parameters(kw, match):
    args = {"levels_w": [50, 75, 100, 125]} | kw
    with pytest.raises(ValueError, match=match):
        design.aprbs(**args)


def test_schedule_csv_round_trip_for_a_programmable_load(tmp_path):
    s = design.aprbs([50, 75, 100, 125], rng=2)
    path = write_schedule(s, tmp_path / "schedule.csv", comment="seed=2")
    lines = path.read_text().splitlines()
    assert lines[0].startswith("#") and "[s]" in lines[1] and "[W]" in lines[1]
    assert "# seed=2" in lines
    assert "time_s,power_w" in lines
    raw = pd.read_csv(path, comment="#")
    assert list(raw.columns) == ["time_s", "power_w"]
    assert raw["power_w"].iloc[-1] == 0.0  # load off at the end
    assert raw["time_s"].iloc[-1] == pytest.approx(s["duration_s"].sum())
    back = read_schedule(path)
    assert_allclose(back.to_numpy(), s.to_numpy())


def test_sample_schedule_holds_each_step():
    s = pd.DataFrame({"start_s": [0.0, 10.0], "duration_s": [10.0, 5.0],
                      "power_w": [50.0, 125.0]})
    p = design.sample_schedule(s, [-1.0, 0.0, 9.99, 10.0, 14.9, 15.0, 100.0])
    assert_allclose(p, [0.0, 50.0, 50.0, 125.0, 125.0, 0.0, 0.0])


def test_pulse_test_profile_repeats_the_uav23_block_at_each_state_of_charge():
    """[UAV23] Table 1 block (rest, discharge pulse, rest, charge pulse, rest) at 1 C."""
    prof = design.pulse_test_profile(2.0, soc_levels=(0.8, 0.5), dt_s=0.5, settle_s=120.0)
    assert len(prof.blocks) == 2
    b = prof.blocks[0]
    assert b["soc"] == pytest.approx(0.8)
    assert b["end_s"] - b["start_s"] == 60 + 20 + 60 + 20 + 60
    seg = (prof.time_s >= b["start_s"]) & (prof.time_s < b["end_s"])
    cur = prof.current_a[seg]
    assert np.sum(cur == 2.0) * 0.5 == 20.0          # 1 C discharge pulse
    assert np.sum(cur == -2.0) * 0.5 == 20.0         # 1 C charge pulse
    assert np.all(cur[:120] == 0.0)                  # 60 s rest first
    assert prof.blocks[1]["soc"] == pytest.approx(0.5)
    assert prof.current_a[-1] == 0.0
