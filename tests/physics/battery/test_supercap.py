"""Two-branch supercapacitor (planner.physics.battery.supercap) and the passive hybrid (hybrid)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import solve_ivp

from planner.physics.battery.circuit import CircuitParameters
from planner.physics.battery.hybrid import (
    EXAMPLE_LIPO_PACK,
    matched_bank,
    simulate_hybrid,
    start_stop_cycle,
    start_stop_example,
    takeoff_example,
)
from planner.physics.battery.ocv import lipo_ocv
from planner.physics.battery.supercap import (
    BCAP1500,
    SupercapParameters,
    matched_series_count,
    simulate_supercap,
)
from planner.errors import InputError, ModelError
from planner.parameters.blocks import supercap_from_mapping, supercap_to_mapping

# --------------------------------------------------------------------------- supercap


def test_bcap1500_datasheet_values():
    # Maxwell K2 datasheet, doc. 1015370: 1500 F, 0.47 mΩ, 2.7 V, 4.5 °C/W, 320 J/°C, 280 g
    assert BCAP1500.equivalent_capacitance_f() == pytest.approx(1500.0, rel=1e-12)
    assert BCAP1500.r_fast_ohm == 0.47e-3
    assert BCAP1500.v_rated_v == 2.7
    assert BCAP1500.r_th_k_per_w == 4.5 and BCAP1500.c_th_j_per_k == 320.0
    assert BCAP1500.mass_kg == 0.28
    assert BCAP1500.r_leak_ohm == pytest.approx(900.0)      # 3.0 mA at 2.7 V
    assert "1015370" in BCAP1500.source
    bank = BCAP1500.bank(7)
    assert bank.bank_rated_v == pytest.approx(18.9)
    assert bank.bank_esr_ohm == pytest.approx(7 * 0.47e-3)


def test_constant_current_discharge_of_an_ideal_capacitor():
    # fast branch only, constant C: V = V0 - I t / C - I R
    p = SupercapParameters(c0_f=100.0, r_fast_ohm=0.01)
    t = np.linspace(0.0, 20.0, 41)
    res = simulate_supercap(p, t, 5.0, v0_v=2.5)
    assert_allclose(res.voltage_v, 2.5 - 5.0 * t / 100.0 - 5.0 * 0.01, rtol=1e-12)


def test_voltage_dependent_capacitance_conserves_charge():
    # q(v) = C0 v + Cv v²/2 falls by exactly I t
    p = SupercapParameters(c0_f=100.0, cv_f_per_v=40.0, r_fast_ohm=0.01)
    t = np.linspace(0.0, 30.0, 16)
    res = simulate_supercap(p, t, 4.0, v0_v=2.7)
    assert_allclose(p.fast_charge(res.fast_voltage_v), p.fast_charge(2.7) - 4.0 * t,
                    rtol=1e-12)
    assert p.fast_voltage(p.fast_charge(1.3)) == pytest.approx(1.3, rel=1e-12)


def test_series_parallel_bank_scales():
    cell = SupercapParameters(c0_f=100.0, r_fast_ohm=0.01)
    bank = cell.bank(3, 2)       # 3 in series, 2 strings: C = 200/3 F, R = 15 mΩ
    t = np.linspace(0.0, 10.0, 11)
    res = simulate_supercap(bank, t, 6.0, v0_v=7.5)
    assert_allclose(res.voltage_v, 7.5 - 6.0 * t / (200.0 / 3.0) - 6.0 * 0.015, rtol=1e-12)


def test_self_discharge_through_leakage():
    p = SupercapParameters(c0_f=50.0, r_fast_ohm=0.01, r_leak_ohm=200.0)
    t = np.linspace(0.0, 20_000.0, 201)
    res = simulate_supercap(p, t, 0.0, v0_v=2.7)
    tau = (200.0 + 0.01) * 50.0
    assert_allclose(res.fast_voltage_v, 2.7 * np.exp(-t / tau), rtol=1e-9)


def test_slow_branch_redistribution_conserves_charge():
    p = SupercapParameters(c0_f=100.0, r_fast_ohm=0.01, r_slow_ohm=2.0, c_slow_f=25.0)
    t = np.arange(0.0, 1000.0, 0.5)
    i = np.where(t < 10.0, 20.0, 0.0)
    res = simulate_supercap(p, t, i, v0_v=2.5)
    # after the pulse the branches equalise at (Q0 - I t) / (C_f + C_s)
    v_final = (2.5 * 125.0 - 200.0) / 125.0
    assert res.fast_voltage_v[-1] == pytest.approx(v_final, rel=1e-6)
    assert res.slow_voltage_v[-1] == pytest.approx(v_final, rel=1e-6)
    # the terminal voltage recovers after the pulse (charge flows back from the slow branch)
    assert res.voltage_v[-1] > res.voltage_v[21]
    q = 100.0 * res.fast_voltage_v + 25.0 * res.slow_voltage_v
    assert_allclose(q[t >= 10.0], 2.5 * 125.0 - 200.0, rtol=1e-9)


def test_supercap_mapping_and_errors():
    p = supercap_from_mapping(supercap_to_mapping(BCAP1500), "hess.yaml")
    assert p == BCAP1500
    with pytest.raises(InputError, match=r"hess.yaml: .*unknown key 'supercap.esr_ohm'"):
        supercap_from_mapping({"c0_f": 1.0, "r_fast_ohm": 1.0, "esr_ohm": 1},
                                        "hess.yaml")
    with pytest.raises(InputError, match="supercap.c0_f must be > 0"):
        supercap_from_mapping({"c0_f": -1.0, "r_fast_ohm": 1.0}, "hess.yaml")
    with pytest.raises(InputError, match="come together"):
        supercap_from_mapping({"c0_f": 1.0, "r_fast_ohm": 1.0, "r_slow_ohm": 1.0},
                                        "hess.yaml")
    with pytest.raises(InputError, match="r_fast_ohm must be a number > 0"):
        SupercapParameters(c0_f=1.0, r_fast_ohm=-0.1)
    with pytest.raises(ModelError, match="rated 2.7 V"):
        simulate_supercap(BCAP1500, [0, 1], 0.0, v0_v=3.5)


def test_matched_series_count():
    assert matched_series_count(16.8) == 7
    assert matched_series_count(5.4) == 2
    bank = matched_bank(BCAP1500, EXAMPLE_LIPO_PACK)
    assert bank.cells_series == 7    # 7 x 2.7 V = 18.9 V covers 4 x 4.10 V


# --------------------------------------------------------------------------- hybrid

def _reference_hybrid(b, sc, t, i_load, soc0):
    """Brute-force ODE of the passive hybrid (no hysteresis), tight tolerances."""
    ns, npb = b.cells_series, b.cells_parallel
    r0p, r1p, c1p = b.r0_ohm * ns / npb, b.r1_ohm * ns / npb, b.c1_f * npb / ns
    q_as = b.capacity_ah * 3600.0
    nss, nps = sc.cells_series, sc.cells_parallel
    g0, gf = 1 / r0p, nps / (nss * sc.r_fast_ohm)
    gs, cs = nps / (nss * sc.r_slow_ohm), sc.c_slow_f * nps / nss
    gl = nps / (nss * sc.r_leak_ohm)

    def node(y, il):
        z, vrc, vf, vs = y
        e = ns * lipo_ocv(z)
        v = (g0 * (e - vrc) + gf * vf + gs * vs - il) / (g0 + gf + gs + gl)
        return v, g0 * (e - vrc - v), gf * (vf - v), gs * (vs - v)

    def rhs(_, y, il):
        _, ib, i_f, i_s = node(y, il)
        cf = (sc.c0_f + sc.cv_f_per_v * y[2] / nss) * nps / nss
        return [-ib / (npb * q_as), ib / c1p - y[1] / (r1p * c1p), -i_f / cf, -i_s / cs]

    e0 = ns * lipo_ocv(soc0)
    y = np.array([soc0, 0.0, e0, e0])
    volts, ibs = [], []
    for k in range(t.size):
        v, ib, _, _ = node(y, i_load[k])
        volts.append(v)
        ibs.append(ib)
        if k < t.size - 1:
            sol = solve_ivp(rhs, (t[k], t[k + 1]), y, args=(i_load[k],), method="Radau",
                            rtol=1e-10, atol=1e-12)
            y = sol.y[:, -1]
    return np.array(volts), np.array(ibs)


def test_hybrid_matches_a_brute_force_ode_solution():
    b = CircuitParameters(capacity_ah=10.0, r0_ohm=0.005, r1_ohm=0.003, c1_f=10_000.0,
                          cells_series=4, cells_parallel=2)
    sc = matched_bank(BCAP1500, b)
    t = np.arange(0.0, 120.0, 1.0)
    i_load = np.where(t < 30, 40.0, np.where(t < 35, 120.0, np.where(t < 80, -30.0, 0.0)))
    res = simulate_hybrid(b, sc, t, current_a=i_load, soc0=0.8, compare=False)
    v_ref, ib_ref = _reference_hybrid(b, sc, t, i_load, 0.8)
    assert_allclose(res.voltage_v, v_ref, atol=5e-4)   # 0.003 % of 15 V
    assert_allclose(res.battery_current_a, ib_ref, atol=0.05)
    # Kirchhoff at the node
    assert_allclose(res.battery_current_a + res.supercap_current_a, i_load, atol=1e-9)


def test_hybrid_step_size_independent():
    t1, i1 = start_stop_cycle(dt_s=1.0, repetitions=3)
    t2, i2 = start_stop_cycle(dt_s=0.25, repetitions=3)
    sc = matched_bank(BCAP1500, EXAMPLE_LIPO_PACK)
    r1 = simulate_hybrid(EXAMPLE_LIPO_PACK, sc, t1, current_a=i1, soc0=0.8)
    r2 = simulate_hybrid(EXAMPLE_LIPO_PACK, sc, t2, current_a=i2, soc0=0.8)
    assert r1.j1 == pytest.approx(r2.j1, rel=2e-3)
    assert r1.j2 == pytest.approx(r2.j2, rel=2e-3)
    assert_allclose(r1.voltage_v, r2.voltage_v[::4], atol=2e-3)


def test_start_stop_cycle_profile():
    t, i = start_stop_cycle(dt_s=0.5, repetitions=30)
    assert t[-1] == 30 * 122.0
    period = (t >= 122.0) & (t < 244.0)
    assert np.sum(i[period] == 45.0) * 0.5 == 59.0
    assert np.sum(i[period] == 100.0) * 0.5 == 3.0
    assert np.sum(i[period] * 0.5) == pytest.approx(0.0, abs=1e-9)   # charge-neutral


def test_start_stop_supercap_lowers_throughput_losses_and_peak():
    # seed paper Table 3 (lead-acid, its parameters): J1 = 0.79, J2 = 0.51;
    # here 4S2P LiPo + 7 x BCAP1500: same ordering J2 < J1 < 1
    res = start_stop_example()
    s = res.summary()
    assert s.supercap_cells == 7
    assert 0.0 < s.j1 < 1.0
    assert s.j2 < s.j1
    assert s.peak_battery_current_a < s.peak_battery_current_alone_a == pytest.approx(100.0)
    assert s.sag_margin_v > s.sag_margin_alone_v
    assert res.max_supercap_cell_v < 2.7
    for arr in (res.voltage_v, res.battery_current_a, res.soc):
        assert np.all(np.isfinite(arr))


def test_takeoff_example_reports_the_figures():
    s = takeoff_example()
    assert s.peak_battery_current_a < s.peak_battery_current_alone_a
    assert s.j2 < s.j1 < 1.0
    assert s.sag_margin_v > s.sag_margin_alone_v
    assert s.supercap_mass_kg == pytest.approx(7 * 0.28)


def test_negligible_supercap_changes_nothing():
    tiny = SupercapParameters(c0_f=1e-3, r_fast_ohm=100.0).bank(7)
    t = np.arange(0.0, 200.0, 0.5)
    i = np.where(t < 100.0, 30.0, 60.0)
    res = simulate_hybrid(EXAMPLE_LIPO_PACK, tiny, t, current_a=i, soc0=0.9)
    assert res.j1 == pytest.approx(1.0, abs=1e-3)
    assert res.j2 == pytest.approx(1.0, abs=2e-3)
    assert_allclose(res.voltage_v, res.alone.voltage_v, atol=5e-3)


def test_hybrid_power_overload_is_reported_not_nan():
    sc = matched_bank(BCAP1500, EXAMPLE_LIPO_PACK)
    t = np.arange(0.0, 20.0, 0.5)
    res = simulate_hybrid(EXAMPLE_LIPO_PACK, sc, t, power_w=np.where(t < 5, 100.0, 1e6))
    assert res.undeliverable_time_s == 5.0
    assert np.all(np.isfinite(res.voltage_v)) and np.all(np.isfinite(res.power_w))


def test_hybrid_rejects_an_overvolted_bank():
    with pytest.raises(ModelError, match="use at least 7 cells in series"):
        simulate_hybrid(EXAMPLE_LIPO_PACK, BCAP1500.bank(5), [0.0, 1.0], current_a=1.0)
    with pytest.raises(ModelError, match=r"range \[-20 °C, 60 °C\]"):
        simulate_hybrid(EXAMPLE_LIPO_PACK, BCAP1500.bank(7), [0.0, 1.0], current_a=1.0,
                        temperature_c=-40.0)
