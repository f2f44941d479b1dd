"""The battery model's element functions (planner.physics.battery.elements), each against
an independent statement of its equation or a published number, and each compiled twin
against its numpy form."""

import math

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from planner.physics.battery import elements as el
from planner.physics.battery import integral
from planner.physics.battery.ocv import lipo_ocv, lipo_ocv_jit
from planner.physics.battery.supercap import BCAP1500

RNG = np.random.default_rng(7)


# --------------------------------------------------------------------------- temperature

def test_arrhenius_log_factor_is_linear_in_inverse_temperature_with_slope_ea_over_r():
    """ln(R0(T)/R0(T_ref)) = (E_a/R)(1/T − 1/T_ref): a straight line in 1/T (kelvin) whose
    slope is E_a over the gas constant (CODATA 2018, 8.314462618 J/(mol K))."""
    t_c = np.linspace(-20.0, 60.0, 17)
    f = el.arrhenius_factor(t_c, 25_000.0, 25.0)
    slope, intercept = np.polyfit(1.0 / (t_c + 273.15), np.log(f), 1)
    assert slope == pytest.approx(25_000.0 / 8.314462618, rel=1e-9)
    assert intercept == pytest.approx(-slope / 298.15, rel=1e-9)
    assert el.arrhenius_factor(25.0, 25_000.0, 25.0) == 1.0


def test_arrhenius_cold_rise_of_the_multistar_pack_file():
    """25 kJ/mol: R0 at 0 °C is 2.5 × its 25 °C value (the comment of
    aircraft/batteries/multistar_10ah_4s.yaml), about 6 × at −20 °C (circuit notes)."""
    assert el.arrhenius_factor(0.0, 25_000.0, 25.0) == pytest.approx(2.52, abs=0.01)
    assert el.arrhenius_factor(-20.0, 25_000.0, 25.0) == pytest.approx(6.0, abs=0.05)


def test_capacity_factor_is_73_percent_at_minus_20_c_and_whole_when_warm():
    """k = 0.006 /°C below 25 °C: 1 − 0.006 × 45 = 0.73 at −20 °C (circuit notes); 1 at and
    above the reference."""
    f = el.capacity_factor(np.array([-20.0, 0.0, 25.0, 40.0]), 0.006, 25.0)
    assert_allclose(f, [0.73, 0.85, 1.0, 1.0], rtol=1e-12)


# --------------------------------------------------------------------------- state steps

def _hysteresis_ode(h0, current, seconds, q, gamma, m):
    """dh/dt = −γ|i|/Q (h + M sgn i), integrated numerically."""
    sol = solve_ivp(lambda t, h: -gamma * abs(current) / q * (h + m * np.sign(current)),
                    (0.0, seconds), [h0], rtol=1e-11, atol=1e-14)
    return sol.y[0, -1]


@pytest.mark.parametrize("current", [12.0, -8.0])
def test_hysteresis_step_is_the_exact_solution_of_the_hess_eq_4_ode(current):
    """[HESS] eq. 4 (written for the voltage): the one-step update equals the ODE solved
    numerically over the step, on discharge (towards −M) and on charge (towards +M)."""
    q, gamma, m, dt = 3600.0 * 2.0, 30.0, 0.02, 60.0
    exact = _hysteresis_ode(0.005, current, dt, q, gamma, m)
    step = el.hysteresis_step(0.005, current * dt, q, gamma, m)
    assert step == pytest.approx(exact, rel=1e-8)
    assert np.sign(step - 0.005) == -np.sign(current)


def test_hysteresis_settles_at_minus_m_under_a_long_discharge_and_holds_at_rest():
    assert el.hysteresis_step(0.0, 1e6, 3600.0, 30.0, 0.02) == pytest.approx(-0.02)
    assert el.hysteresis_step(0.013, 0.0, 3600.0, 30.0, 0.02) == 0.013


def test_rc_step_follows_the_step_response_of_an_rc_branch():
    """v(t) = R1 I (1 − e^{−t/(R1 C1)}) from rest under a held current (HESS eq. 5), step
    by step on a grid of unequal steps."""
    r1, c1, i = 0.004, 5000.0, 20.0
    t = np.cumsum(np.r_[0.0, RNG.uniform(0.5, 8.0, 40)])
    v = 0.0
    for k in range(1, t.size):
        v = el.rc_step(v, i, r1, math.exp(-(t[k] - t[k - 1]) / (r1 * c1)))
    assert v == pytest.approx(r1 * i * (1.0 - math.exp(-t[-1] / (r1 * c1))), rel=1e-12)


# --------------------------------------------------------------------------- load

def test_loaded_current_is_the_smaller_root_of_p_equals_v_minus_ri_times_i():
    """P = (V − R I) I: the current is the smaller root of R I² − V I + P = 0
    (numpy.roots), on the source's side of the power maximum (I < V/2R)."""
    for p, v, r in [(100.0, 16.0, 0.05), (900.0, 25.2, 0.02), (1e-3, 3.7, 0.3)]:
        roots = np.sort(np.roots([r, -v, p]).real)
        i = el.loaded_current(p, v, r)
        assert i == pytest.approx(roots[0], rel=1e-12)
        assert (v - r * i) * i == pytest.approx(p, rel=1e-12)
        assert i < v / (2 * r)


def test_loaded_current_without_resistance_is_p_over_v_and_nan_past_the_limit():
    assert el.loaded_current(100.0, 16.0, 0.0) == pytest.approx(6.25, rel=1e-15)
    over = el.power_limit(16.0, 0.05) * 1.001
    assert np.isnan(el.loaded_current(over, 16.0, 0.05))
    out = el.loaded_current(np.array([[50.0], [over]]), 16.0, np.array([0.05, 0.0]))
    assert out.shape == (2, 2) and np.isnan(out[1, 0]) and np.isfinite(out[1, 1])


def test_power_limit_is_the_largest_p_of_a_source_behind_a_resistance():
    """max over I of (V − R I) I, found on a fine grid, is V²/(4R), at I = V/(2R)."""
    v, r = 22.2, 0.031
    i = np.linspace(0.0, v / r, 200_001)
    p = (v - r * i) * i
    assert el.power_limit(v, r) == pytest.approx(p.max(), rel=1e-9)
    assert i[np.argmax(p)] == pytest.approx(v / (2 * r), rel=1e-4)
    assert el.power_limit(v, 0.0) == math.inf


def test_delivered_current_gives_the_maximum_power_when_overloaded():
    i, ok = el.delivered_current(100.0, 16.0, 0.05)
    assert ok and i == pytest.approx(el.loaded_current(100.0, 16.0, 0.05), rel=1e-15)
    i, ok = el.delivered_current(2000.0, 16.0, 0.05)
    assert not ok and i == pytest.approx(16.0 / 0.1)
    assert (16.0 - 0.05 * i) * i == pytest.approx(el.power_limit(16.0, 0.05))
    assert el.delivered_current(10.0, -1.0, 0.05) == (0.0, False)


# --------------------------------------------------------------------------- pack

def test_pack_scaling_of_a_4s2p_pack_and_a_supercap_bank():
    """4S2P of 10 mΩ cells: 20 mΩ; one cell of a 20 mΩ 4S2P pack: 10 mΩ; 4S2P of 100 F
    cells: 50 F; the BCAP1500 bank ESR of the supercap model is the same rule."""
    assert el.pack_resistance(0.010, 4, 2) == pytest.approx(0.020)
    assert el.cell_resistance(0.020, 4, 2) == pytest.approx(0.010)
    assert el.pack_capacitance(100.0, 4, 2) == pytest.approx(50.0)
    bank = BCAP1500.bank(7, 2)
    assert bank.bank_esr_ohm == pytest.approx(BCAP1500.r_fast_ohm * 7 / 2)


# --------------------------------------------------------------------------- compiled twins

@pytest.mark.parametrize("name, args", [
    ("arrhenius_factor", lambda: (RNG.uniform(-20, 60), RNG.uniform(0, 6e4), 25.0)),
    ("capacity_factor", lambda: (RNG.uniform(-20, 60), 0.006, 25.0)),
    ("hysteresis_step", lambda: (RNG.uniform(-0.02, 0.02), RNG.normal(0, 50), 7200.0,
                                 RNG.uniform(0, 60), 0.02)),
    ("rc_step", lambda: (RNG.uniform(-0.1, 0.1), RNG.normal(0, 30), 0.003,
                         RNG.uniform(0, 1))),
    ("loaded_current", lambda: (RNG.uniform(0, 3000), RNG.uniform(10, 50),
                                RNG.uniform(0, 0.2))),
    ("power_limit", lambda: (RNG.uniform(10, 50), RNG.uniform(0.001, 0.2))),
])
def test_each_compiled_twin_equals_its_numpy_form(name, args):
    """The kernels call the compiled twin (same source): they must agree to rounding."""
    numpy_form, compiled_form = getattr(el, name), getattr(el, name + "_jit")
    for _ in range(50):
        a = args()
        assert compiled_form(*a) == pytest.approx(numpy_form(*a), rel=1e-13, nan_ok=True)


def test_the_ocv_curve_and_its_twin_give_chen_and_rincon_mora_eq_4():
    """Chen & Rincón-Mora (2006) eq. 4: 4.10 V full, 3.80 V at half charge; clipped to
    [0, 1]; the compiled twin gives the same."""
    assert lipo_ocv(1.0) == pytest.approx(4.1029, abs=1e-4)
    assert lipo_ocv(0.5) == pytest.approx(3.8034, abs=1e-4)
    assert lipo_ocv(1.5) == lipo_ocv(1.0) and lipo_ocv(-0.2) == lipo_ocv(0.0)
    for s in RNG.uniform(-0.1, 1.1, 50):
        assert lipo_ocv_jit(s) == pytest.approx(lipo_ocv(s), rel=1e-14)


def test_charge_from_stress_twin_and_the_uav23_table_3_design():
    """[UAV23] Table 3 designs its six two-step tests to draw the same charge (about 55 %
    of the 10 Ah pack): with the Table 5 m_const model the additive stress of each test,
    turned into charge by C = S^(1/β), is 5.46 Ah for all six (within 0.2 %)."""
    d, e, b = 23.6482, -1.0209, 0.9648
    tests = [(75, 100, 1708.5, 1708.5), (100, 75, 1708.5, 1708.5), (75, 100, 1086.7, 2173.5),
             (100, 75, 1196.5, 2393.1), (75, 100, 2393.1, 1196.5), (100, 75, 2173.5, 1086.8)]
    stress = np.array([t1 * integral.stress_rate(p1, d, e)
                       + t2 * integral.stress_rate(p2, d, e) for p1, p2, t1, t2 in tests])
    ah = integral.charge_from_stress(stress, b) / 3600.0
    assert_allclose(ah, 5.46, rtol=1e-3)
    assert ah.max() / ah.min() - 1 < 2e-3
    for s in stress:
        assert integral.charge_from_stress_jit(s, b) == pytest.approx(
            integral.charge_from_stress(s, b), rel=1e-14)
    assert integral.charge_from_stress(-1.0, b) == 0.0
