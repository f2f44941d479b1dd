"""Equivalent-circuit pack model (planner.physics.battery.circuit) and OCV tables (planner.physics.battery.ocv)."""

import math

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from planner.physics.battery.circuit import CircuitParameters, simulate
from planner.physics.battery.ocv import OcvTable, lipo_ocv
from planner.physics.battery.thermal import ThermalParameters
from planner.errors import InputError, ModelError
from planner.parameters import BatteryPack
from planner.parameters.blocks import (
    circuit_block,
    circuit_from_mapping,
    circuit_to_mapping,
    thermal_from_mapping,
)
from planner.io.tables import write_ocv_csv
from planner.parameters.ocv import read_ocv_csv


def cell(**kw):
    base = {"capacity_ah": 2.0, "r0_ohm": 0.02, "r1_ohm": 0.01, "c1_f": 2000.0}
    base.update(kw)
    return CircuitParameters(**base)


# --------------------------------------------------------------------------- analytic

def test_rc_step_response_is_exact():
    # v_RC(t) = R1 I (1 - exp(-t / (R1 C1))) for a current step from rest
    p = cell(r1_ohm=0.005, c1_f=4000.0)
    t = np.linspace(0.0, 100.0, 101)
    i = 3.0
    res = simulate(p, t, current_a=i, soc0=0.8)
    expected = 0.005 * i * (1.0 - np.exp(-t / (0.005 * 4000.0)))
    assert_allclose(res.rc_voltage_v, expected, rtol=1e-12, atol=1e-15)
    # terminal voltage = OCV - v_RC - R0 I (no hysteresis)
    assert_allclose(res.voltage_v, res.ocv_v - res.rc_voltage_v - 0.02 * i, rtol=1e-12)


def test_rc_step_response_exact_on_a_non_uniform_grid():
    p = cell(r1_ohm=0.005, c1_f=4000.0)
    t = np.r_[0.0, np.cumsum(np.random.default_rng(3).uniform(0.1, 7.0, 40))]
    res = simulate(p, t, current_a=2.0)
    assert_allclose(res.rc_voltage_v, 0.01 * (1 - np.exp(-t / 20.0)), rtol=1e-12, atol=1e-15)


def test_hysteresis_converges_to_m_exponentially_in_charge():
    # |h| = M (1 - exp(-gamma q / Q)) from h0 = 0 under steady discharge
    m, gamma, q_ah = 0.015, 40.0, 2.0
    p = cell(hysteresis_v=m, hysteresis_gamma=gamma, capacity_ah=q_ah)
    t = np.arange(0.0, 1801.0, 5.0)
    res = simulate(p, t, current_a=1.0, soc0=0.9)
    q = res.charge_as
    expected = -m * (1.0 - np.exp(-gamma * q / (q_ah * 3600.0)))
    assert_allclose(res.hysteresis_v, expected, rtol=1e-10, atol=1e-15)
    assert res.hysteresis_v[-1] == pytest.approx(-m, rel=1e-4)
    # a charge reverses it towards +M
    res2 = simulate(p, t, current_a=-1.0, soc0=0.1, hysteresis0_v=-m)
    assert res2.hysteresis_v[-1] == pytest.approx(m, rel=1e-4)
    assert np.all(np.diff(res2.hysteresis_v) >= 0)


def test_charge_at_cutoff_is_the_capacity_at_low_rate():
    # C/20 discharge to 3.0 V per cell draws all but the steep knee of the LiPo curve
    p = cell(capacity_ah=2.0, cells_series=3)
    t = np.arange(0.0, 22 * 3600.0, 10.0)
    res = simulate(p, t, current_a=0.1, v_cutoff_cell=3.0)
    assert res.cutoff_time_s is not None
    assert res.cutoff_charge_as == pytest.approx(2.0 * 3600.0, rel=0.02)
    assert res.cutoff_charge_as == pytest.approx(0.1 * res.cutoff_time_s, rel=1e-9)
    # the interpolated crossing lies between the two samples around it
    k = int(np.searchsorted(t, res.cutoff_time_s))
    assert res.cell_voltage_v[k - 1] > 3.0 >= res.cell_voltage_v[k]
    assert res.empty_time_s == pytest.approx(2.0 * 3600.0 / 0.1, rel=1e-9)


def test_stop_at_cutoff_disconnects_the_load():
    p = cell(capacity_ah=0.5)
    t = np.arange(0.0, 3 * 3600.0, 10.0)
    res = simulate(p, t, current_a=1.0, v_cutoff_cell=3.3, stop_at_cutoff=True)
    k_cut = int(np.searchsorted(res.time_s, res.cutoff_time_s))
    assert np.all(res.current_a[k_cut:] == 0.0)
    assert np.all(res.soc[k_cut:] == res.soc[k_cut])
    assert res.charge_as[-1] == res.charge_as[k_cut]
    # at the cut-off instant the R0 drop vanishes, then the RC branch relaxes
    assert res.cell_voltage_v[-1] > 3.3
    assert np.all(np.diff(res.cell_voltage_v[k_cut:]) >= 0)


# --------------------------------------------------------------------------- power load

def test_end_at_cutoff_keeps_the_loaded_sample_and_the_prefix_of_the_run():
    # a bench load trips at the cut-off: the run ends there, nothing before it changes
    p = cell(hysteresis_v=0.02, hysteresis_gamma=50.0)
    t = np.arange(0.0, 4000.0)
    full = simulate(p, t, power_w=25.0, v_cutoff_cell=3.5, diffusion=(0.8, 300.0))
    ended = simulate(p, t, power_w=25.0, v_cutoff_cell=3.5, end_at_cutoff=True,
                     diffusion=(0.8, 300.0))
    k = ended.time_s.size
    assert 100 < k < t.size
    assert ended.cell_voltage_v[-1] <= 3.5 < ended.cell_voltage_v[-2]
    assert ended.current_a[-1] > 0  # loaded, not rested
    for name in ("voltage_v", "current_a", "soc", "surface_deficit", "charge_as",
                 "hysteresis_v"):
        assert_allclose(getattr(ended, name), getattr(full, name)[:k], rtol=0, atol=0,
                        err_msg=name)
    assert ended.cutoff_time_s == full.cutoff_time_s
    with pytest.raises(InputError, match="end_at_cutoff needs v_cutoff_cell"):
        simulate(p, t, power_w=25.0, end_at_cutoff=True)


def test_diffusion_state_is_the_kibam_solution_and_sets_the_surface_soc():
    r"""KiBaM (Manwell and McGowan 1993) in SoC terms, ẋ = (1 − c)/c · i/Q − x/τ_d.

    A 20 A step for 1200 s then a rest: x follows x∞(1 − e^{−t/τ_d}) with
    x∞ = (1 − c)/c · τ_d · i/Q, then decays as e^{−t/τ_d} (recovery); the
    terminal voltage is OCV(z − x) − R0 i, the bulk SoC z is coulomb counting.
    """
    c, tau = 0.8, 600.0
    p = cell(capacity_ah=10.0, r0_ohm=0.01, r1_ohm=0.0)
    t = np.arange(0.0, 3000.0)
    i = np.where(t < 1200.0, 20.0, 0.0)
    r = simulate(p, t, current_a=i, diffusion=(c, tau))
    x_inf = (1.0 - c) / c * tau * 20.0 / 36000.0
    x = np.where(t <= 1200.0, x_inf * (1.0 - np.exp(-t / tau)),
                 x_inf * (1.0 - np.exp(-1200.0 / tau)) * np.exp(-(t - 1200.0) / tau))
    assert_allclose(r.surface_deficit, x, rtol=1e-10, atol=1e-14)
    z = 1.0 - np.minimum(t, 1200.0) * 20.0 / 36000.0
    assert_allclose(r.soc, z, rtol=1e-12)
    assert_allclose(r.voltage_v + 0.01 * i, lipo_ocv(z - x), atol=2e-6)
    # without diffusion the voltage sees the bulk SoC: the deficit costs voltage
    plain = simulate(p, t, current_a=i)
    assert plain.surface_deficit is None
    assert np.all(r.voltage_v[1:1200] < plain.voltage_v[1:1200])
    with pytest.raises(InputError, match="diffusion"):
        simulate(p, t, current_a=i, diffusion=(0.0, 600.0))


def test_power_beyond_deliverable_is_reported_not_nan():
    p = cell(cells_series=4, r0_ohm=0.05)
    t = np.arange(0.0, 60.0, 1.0)
    p_max = p.max_power_w(1.0)
    power = np.where(t < 20, 0.3 * p_max, 2.0 * p_max)
    res = simulate(p, t, power_w=power)
    assert res.undeliverable_time_s == 20.0
    assert not res.deliverable
    for arr in (res.current_a, res.voltage_v, res.power_w, res.soc, res.energy_j):
        assert np.all(np.isfinite(arr))
    # it delivers the maximum power instead, at half the source voltage
    k = 25
    e = res.ocv_v[k] + res.hysteresis_v[k] - res.rc_voltage_v[k]
    assert res.voltage_v[k] == pytest.approx(e / 2, rel=1e-12)
    assert res.power_w[k] == pytest.approx(e ** 2 / (4 * p.r0_pack_ohm(res.soc[k])), rel=1e-12)
    # before the overload the asked power is met exactly
    assert_allclose(res.power_w[:20], power[:20], rtol=1e-12)


def test_power_load_closed_form_current():
    p = cell(cells_series=3, cells_parallel=2, hysteresis_v=0.01, hysteresis_gamma=20)
    t = np.arange(0.0, 600.0, 1.0)
    res = simulate(p, t, power_w=150.0)
    assert_allclose(res.voltage_v * res.current_a, 150.0, rtol=1e-12)
    # pack current splits over 2 parallel strings: R_pack = 3 R0 / 2
    e = res.ocv_v + res.hysteresis_v - res.rc_voltage_v
    assert_allclose(res.voltage_v, e - res.current_a * 0.03, rtol=1e-12)


def test_soc_never_rises_while_discharging():
    rng = np.random.default_rng(7)
    p = cell(cells_series=4, hysteresis_v=0.01, hysteresis_gamma=50)
    t = np.arange(0.0, 3600.0, 1.0)
    power = rng.uniform(0.0, 60.0, t.size)
    res = simulate(p, t, power_w=power, soc0=0.95)
    assert np.all(np.diff(res.soc) <= 0.0)
    assert np.all(np.diff(res.charge_as) >= 0.0)


def test_energy_drawn_equals_integral_of_power():
    rng = np.random.default_rng(11)
    p = cell(cells_series=4, capacity_ah=5.0)
    t = np.r_[0.0, np.cumsum(rng.uniform(0.5, 2.0, 1500))]
    power = rng.uniform(0.0, 200.0, t.size)
    res = simulate(p, t, power_w=power)
    assert res.deliverable
    assert res.energy_j[-1] == pytest.approx(np.sum(power[:-1] * np.diff(t)), rel=1e-12)
    # and the charge is the integral of the current
    assert res.charge_as[-1] == pytest.approx(np.sum(res.current_a[:-1] * np.diff(t)),
                                              rel=1e-12)


def test_zero_length_mission_uses_no_energy():
    res = simulate(cell(), [0.0], power_w=100.0)
    assert res.energy_j[-1] == 0.0 and res.charge_as[-1] == 0.0


@pytest.mark.parametrize("kind", [list, np.asarray, pd.Series])
def test_input_types(kind):
    t = np.arange(0.0, 10.0)
    res = simulate(cell(), kind(list(t)), power_w=kind([5.0] * 10))
    assert res.voltage_v.shape == (10,)
    assert isinstance(res.to_frame(), pd.DataFrame)


def test_nan_load_is_bad_input():
    with pytest.raises(InputError, match="power_w has a non-finite value at sample 2"):
        simulate(cell(), [0, 1, 2, 3], power_w=[1.0, 1.0, np.nan, 1.0])
    with pytest.raises(InputError, match="exactly one"):
        simulate(cell(), [0, 1], power_w=1.0, current_a=1.0)


# --------------------------------------------------------------------------- temperature

def test_arrhenius_r0_and_capacity_below_reference():
    p = cell(r0_activation_energy_j_mol=25_000.0, capacity_temp_coeff_per_c=0.006)
    f = math.exp(25_000.0 / 8.314462618 * (1 / 273.15 - 1 / 298.15))
    assert p.r0_cell_ohm(0.5, 0.0) == pytest.approx(0.02 * f, rel=1e-12)
    assert p.capacity_factor(0.0) == pytest.approx(1 - 0.006 * 25)
    assert p.capacity_factor(40.0) == 1.0
    # the simulation uses both
    t = np.arange(0.0, 101.0, 1.0)
    cold = simulate(p, t, current_a=1.0, temperature_c=0.0, soc0=0.8)
    warm = simulate(p, t, current_a=1.0, temperature_c=25.0, soc0=0.8)
    assert cold.voltage_v[0] == pytest.approx(warm.ocv_v[0] - 0.02 * f, rel=1e-12)
    drop_cold, drop_warm = 0.8 - cold.soc[-1], 0.8 - warm.soc[-1]
    assert drop_cold == pytest.approx(drop_warm / (1 - 0.006 * 25), rel=1e-12)


@pytest.mark.parametrize("temp", [-30.0, 75.0])
def test_temperature_outside_range_is_a_model_error(temp):
    with pytest.raises(ModelError, match=r"\[-20 °C, 60 °C\]"):
        simulate(cell(), [0, 1, 2], current_a=1.0, temperature_c=temp)


def test_coupled_thermal_model_warms_and_lowers_resistance():
    p = cell(cells_series=4, capacity_ah=5.0, r0_activation_energy_j_mol=25_000.0)
    th = ThermalParameters(r_th_k_per_w=3.0, c_th_j_per_k=300.0, t_air_c=10.0)
    t = np.arange(0.0, 1800.0, 1.0)
    res = simulate(p, t, current_a=10.0, temperature_c=th, soc0=0.9)
    assert res.temperature_c[0] == 10.0
    assert np.all(np.diff(res.temperature_c) >= -1e-12)
    assert res.temperature_c[-1] > 15.0
    # R0 at the reached temperature (the voltage step of the current is R0(T) I)
    iso = simulate(p, t, current_a=10.0, temperature_c=res.temperature_c, soc0=0.9)
    assert_allclose(iso.voltage_v, res.voltage_v, rtol=1e-12)


def test_coupled_thermal_runaway_beyond_range_is_a_model_error():
    p = cell(cells_series=4, capacity_ah=50.0, r0_ohm=0.2, r0_activation_energy_j_mol=0.0)
    th = ThermalParameters(r_th_k_per_w=20.0, c_th_j_per_k=50.0, t_air_c=25.0)
    with pytest.raises(ModelError, match="reached .* at t = "):
        simulate(p, np.arange(0.0, 600.0), current_a=20.0, temperature_c=th)


# --------------------------------------------------------------------------- YAML block

def test_from_mapping_round_trip_and_defaults():
    block = {"capacity_ah": 5.0, "r0_ohm": {"soc": [0.0, 0.5, 1.0], "ohm": [0.01, 0.006, 0.007]},
             "r1_ohm": 0.003, "c1_f": 8000, "hysteresis_v": 0.01, "hysteresis_gamma": 30}
    p = circuit_from_mapping(block, "pack.yaml", cells_series=6)
    assert p.cells_series == 6 and p.cells_parallel == 1
    assert p.r0_cell_ohm(0.25) == pytest.approx(0.008)
    assert p.r0_activation_energy_j_mol == 25_000.0
    again = circuit_from_mapping(circuit_to_mapping(p), "x")
    assert circuit_to_mapping(again) == circuit_to_mapping(p)


def test_from_mapping_takes_capacity_and_r0_from_the_pack():
    p = circuit_from_mapping({}, "pack.yaml", capacity_ah=10.0, r0_ohm=0.005,
                                       cells_series=4, cells_parallel=2)
    assert (p.capacity_ah, p.r0_ohm, p.pack_capacity_ah) == (10.0, 0.005, 20.0)
    assert p.r0_pack_ohm(0.5) == pytest.approx(0.01)


@pytest.mark.parametrize("block, match", [
    ({"capacity_ah": 5, "r0_ohm": 0.01, "r1_ohms": 0.1},
     r"unknown key 'circuit.r1_ohms' \(did you mean 'circuit.r1_ohm'\?\)"),
    ({"capacity_ah": 5, "r0_ohm": -0.01}, r"circuit.r0_ohm must be >= 0"),
    ({"capacity_ah": -5, "r0_ohm": 0.01}, r"circuit.capacity_ah must be > 0"),
    ({"capacity_ah": 5, "r0_ohm": 0.01, "c1_f": "big"}, r"circuit.c1_f must be a number"),
    ({"capacity_ah": 5, "r0_ohm": 0.01, "r1_ohm": 0.01}, r"circuit.c1_f is required"),
    ({"capacity_ah": 5, "r0_ohm": 0.01, "hysteresis_v": 0.01}, r"hysteresis_gamma is required"),
    ({"capacity_ah": 5, "r0_ohm": {"soc": [0, 1], "ohm": [0.01]}}, r"equal length"),
    ({"capacity_ah": 5, "r0_ohm": {"soc": [0, 1], "ohm": [0.01, -1]}}, r"r0_ohm.ohm must be >= 0"),
    ({"r0_ohm": 0.01}, r"missing required key 'circuit.capacity_ah'"),
])
def test_from_mapping_errors_name_the_key(block, match):
    with pytest.raises(InputError, match=match) as err:
        circuit_from_mapping(block, "aircraft/batteries/x.yaml")
    assert str(err.value).startswith("aircraft/batteries/x.yaml: ")


def test_all_problems_reported_at_once():
    with pytest.raises(InputError) as err:
        circuit_from_mapping({"capacity_ah": -1, "r0_ohm": -1, "r1_ohm": -2}, "f.yaml")
    msg = str(err.value)
    assert "capacity_ah" in msg and "r0_ohm" in msg and "r1_ohm" in msg


def test_dataclass_rejects_impossible_values():
    with pytest.raises(InputError, match="c1_f must be > 0"):
        cell(c1_f=-1.0)
    with pytest.raises(InputError, match="cells_series"):
        cell(cells_series=0)


def test_validate_blocks_for_the_battery_loader():
    circuit_block({"r1_ohm": 0.002, "c1_f": 5000}, "x.yaml")   # capacity from pack
    with pytest.raises(InputError, match="x.yaml: unknown key 'circuit.r2_ohm'"):
        circuit_block({"r2_ohm": 1.0}, "x.yaml")
    thermal_from_mapping({"r_th_k_per_w": 2.0, "c_th_j_per_k": 800}, "x.yaml")
    with pytest.raises(InputError, match="thermal.c_th_j_per_k"):
        thermal_from_mapping({"r_th_k_per_w": 2.0}, "x.yaml")


def test_ocv_csv_relative_to_the_yaml_file(tmp_path):
    (tmp_path / "cell_ocv.csv").write_text(
        "soc [1], ocv [V]\n0.0, 3.0\n0.5, 3.7\n1.0, 4.2\n", encoding="utf-8")
    p = circuit_from_mapping({"capacity_ah": 1, "r0_ohm": 0.01,
                                        "ocv_csv": "cell_ocv.csv"},
                                       str(tmp_path / "pack.yaml"))
    assert isinstance(p.ocv, OcvTable)
    assert p.ocv(0.25) == pytest.approx(3.35)
    assert circuit_to_mapping(p)["ocv_csv"] == "cell_ocv.csv"
    with pytest.raises(InputError, match="circuit.ocv_csv: .*missing.csv: OCV file not found"):
        circuit_from_mapping({"capacity_ah": 1, "r0_ohm": 0.01,
                                        "ocv_csv": "missing.csv"}, str(tmp_path / "pack.yaml"))


def test_pack_circuit_uses_pack_fields():
    pack = BatteryPack(name="p", cells_series=4, cells_parallel=2, capacity_mah=10000.0,
                       mass_kg=1.0, internal_resistance_ohm=0.02, count=2,
                       circuit=circuit_block({"r1_ohm": 0.002, "c1_f": 9000.0}, "p.yaml"))
    p = pack.circuit_parameters()
    assert p.capacity_ah == 5.0 and p.cells_parallel == 4 and p.r0_ohm == pytest.approx(0.01)
    assert p.r1_ohm == 0.002 and p.c1_f == 9000.0


# --------------------------------------------------------------------------- OCV tables

def test_ocv_csv_reading_units_and_order(tmp_path):
    path = tmp_path / "ocv.csv"
    path.write_text("# soc [%],ocv [mV]\n100,4200\n50,3700\n# comment\n0,3000\n",
                    encoding="utf-8")
    table = read_ocv_csv(path)
    assert_allclose(table.soc, [0.0, 0.5, 1.0])
    assert_allclose(table.ocv_v, [3.0, 3.7, 4.2])
    assert table(np.array([0.25, 2.0])) == pytest.approx([3.35, 4.2])
    assert isinstance(table(0.3), float)
    s = pd.Series([0.1, 0.9], index=["a", "b"])
    assert list(table(s).index) == ["a", "b"]
    assert np.isnan(table(np.nan))
    assert table.soc_from_ocv(3.35) == pytest.approx(0.25)
    out = tmp_path / "out.csv"
    write_ocv_csv(out, table)
    assert_allclose(read_ocv_csv(out).ocv_v, table.ocv_v)


@pytest.mark.parametrize("text, match", [
    ("soc [1],ocv [V]\n0,3.0\n0.5,3.8\n1,3.7\n", r"must rise with soc \(monotonic"),
    ("soc [1],ocv [V]\n0,3.0\n0,3.1\n", "appears twice"),
    ("soc [1],ocv\n0,3.0\n1,4.0\n",
     r"column 'ocv' \(header\): expected its unit, \[V\] or \[mV\], got no unit"),
    ("soc [1],ocv [V]\n0,3.0\n1,abc\n",
     r"column 'ocv' row 2 \(line 3\): expected a number, got 'abc'"),
    ("soc [1],ocv [V]\n0,3.0\n1.5,4.0\n", r"soc must lie in \[0, 1\]"),
    ("state,volts\n0,3\n1,4\n", r"header: expected the columns 'soc \[1\]' and 'ocv \[V\]'"),
    ("soc [1],ocv [V]\n0,3.0\n", "at least 2 rows"),
])
def test_ocv_csv_errors(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match=match) as err:
        read_ocv_csv(path)
    assert str(path) in str(err.value)


def test_lipo_ocv_default_is_used():
    p = cell()
    assert p.ocv is lipo_ocv
    res = simulate(p, [0.0, 1.0], current_a=0.0, soc0=0.5)
    assert res.ocv_v[0] == pytest.approx(lipo_ocv(0.5), abs=1e-6)
