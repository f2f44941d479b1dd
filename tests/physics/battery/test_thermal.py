"""Lumped thermal model (planner.physics.battery.thermal) and its coupling with the circuit."""

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from planner.physics.battery.circuit import CircuitParameters, simulate
from planner.physics.battery.thermal import (
    ThermalParameters,
    check_temperature,
    heat_generation,
    lumped_temperature,
    steady_state_temperature,
)
from planner.errors import InputError, ModelError
from planner.parameters.blocks import thermal_from_mapping, thermal_to_mapping


def test_steady_state_is_air_plus_rth_q():
    t = np.arange(0.0, 20_000.0, 10.0)
    temp = lumped_temperature(t, 4.0, 15.0, r_th=2.5, c_th=200.0)
    assert temp[-1] == pytest.approx(15.0 + 2.5 * 4.0, rel=1e-9)
    assert steady_state_temperature(4.0, 15.0, 2.5) == 25.0


def test_time_constant_is_rth_cth():
    r_th, c_th, q, t_air = 2.0, 300.0, 5.0, 20.0
    tau = r_th * c_th
    t = np.linspace(0.0, 5 * tau, 501)
    temp = lumped_temperature(t, q, t_air, r_th, c_th)
    assert_allclose(temp, t_air + r_th * q * (1 - np.exp(-t / tau)), rtol=1e-12)
    k = int(np.searchsorted(t, tau))
    assert temp[k] - t_air == pytest.approx(r_th * q * (1 - np.exp(-1)), rel=1e-12)


def test_cooling_from_a_warm_start_and_non_uniform_grid():
    t = np.r_[0.0, np.cumsum(np.random.default_rng(0).uniform(1.0, 30.0, 200))]
    temp = lumped_temperature(t, 0.0, 10.0, 1.5, 400.0, t0_c=40.0)
    assert_allclose(temp, 10.0 + 30.0 * np.exp(-t / 600.0), rtol=1e-12)


def test_piecewise_constant_heat_is_exact():
    # heat on for 100 s then off: exact two-piece solution at every sample
    r_th, c_th = 1.0, 50.0
    t = np.arange(0.0, 300.0, 0.5)
    q = np.where(t < 100.0, 8.0, 0.0)
    temp = lumped_temperature(t, q, 0.0, r_th, c_th)
    t_on = 8.0 * (1 - np.exp(-100.0 / 50.0))
    expected = np.where(t <= 100.0, 8.0 * (1 - np.exp(-t / 50.0)),
                        t_on * np.exp(-(t - 100.0) / 50.0))
    assert_allclose(temp, expected, rtol=1e-10, atol=1e-12)


def test_series_in_series_out_and_air_profile():
    t = pd.Series(np.arange(0.0, 10.0))
    q = pd.Series(np.ones(10), index=list("abcdefghij"))
    out = lumped_temperature(t, q, np.linspace(10, 20, 10), 1.0, 10.0)
    assert isinstance(out, pd.Series) and list(out.index) == list("abcdefghij")


def test_bad_parameters():
    with pytest.raises(InputError, match="r_th"):
        lumped_temperature([0, 1], 1.0, 20.0, -1.0, 10.0)
    with pytest.raises(InputError, match="c_th"):
        lumped_temperature([0, 1], 1.0, 20.0, 1.0, 0.0)
    with pytest.raises(ModelError, match=r"outside the battery model's range \[-20 °C, 60 °C\]"):
        check_temperature([20.0, 70.0])


def test_heat_generation_steady_state_r0_plus_r1():
    assert heat_generation(10.0, 0.01, rc_voltage_v=10.0 * 0.005, r1_ohm=0.005) == \
        pytest.approx(100 * 0.015)


def test_thermal_block_validation():
    th = thermal_from_mapping({"r_th_k_per_w": 2.0, "c_th_j_per_k": 800.0,
                                         "t_air_c": 5.0}, "pack.yaml")
    assert th.tau_s == 1600.0 and th.initial_c == 5.0
    assert thermal_from_mapping(thermal_to_mapping(th), "x") == th
    with pytest.raises(InputError, match=r"pack.yaml: .*unknown key 'thermal.r_th_k_w' "
                                         r"\(did you mean 'thermal.r_th_k_per_w'\?\)"):
        thermal_from_mapping({"r_th_k_w": 2.0, "c_th_j_per_k": 800.0}, "pack.yaml")
    with pytest.raises(InputError, match="thermal.c_th_j_per_k must be > 0"):
        thermal_from_mapping({"r_th_k_per_w": 2.0, "c_th_j_per_k": -8.0}, "p.yaml")
    with pytest.raises(InputError, match="r_th_k_per_w must be a number > 0"):
        ThermalParameters(r_th_k_per_w=-1.0, c_th_j_per_k=1.0)


def test_coupled_circuit_reaches_air_plus_rth_i2_r0_plus_r1():
    # constant current, no Arrhenius: the pack settles at T_air + R_th I² (R0 + R1)
    p = CircuitParameters(capacity_ah=100.0, r0_ohm=0.01, r1_ohm=0.005, c1_f=2000.0,
                          r0_activation_energy_j_mol=0.0, cells_series=2, cells_parallel=1)
    th = ThermalParameters(r_th_k_per_w=4.0, c_th_j_per_k=100.0, t_air_c=20.0)
    t = np.arange(0.0, 8000.0, 1.0)
    res = simulate(p, t, current_a=10.0, temperature_c=th, soc0=1.0)
    q_ss = 10.0 ** 2 * 2 * (0.01 + 0.005)
    assert res.heat_w[-1] == pytest.approx(q_ss, rel=1e-9)
    assert res.temperature_c[-1] == pytest.approx(20.0 + 4.0 * q_ss, rel=1e-6)
    # and the temperature is the lumped model driven by the circuit's own heat
    assert_allclose(res.temperature_c, lumped_temperature(t, res.heat_w, 20.0, 4.0, 100.0),
                    rtol=1e-12)
