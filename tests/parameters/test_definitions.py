"""Aircraft and battery YAML: loading, defaults and validation (DESIGN §8)."""

from pathlib import Path

import numpy as np
import pytest

from planner.errors import InputError
from planner.parameters import load_aircraft, load_aircraft_and_battery, load_battery

REPO = Path(__file__).resolve().parents[2]


def write(tmp_path, text, name="x.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("path", sorted((REPO / "aircraft").glob("*.yaml")))
def test_every_shipped_aircraft_loads_with_its_pack(path):
    aircraft, pack = load_aircraft_and_battery(path)
    assert aircraft.empty_mass_kg > 0 and pack.mass_kg > 0
    assert aircraft.source, "every shipped aircraft states its sources"
    assert pack.source


@pytest.mark.parametrize("path", sorted((REPO / "aircraft" / "batteries").glob("*.yaml")))
def test_every_shipped_pack_loads(path):
    pack = load_battery(path)
    assert pack.capacity_as == pytest.approx(pack.capacity_mah * 3.6 * pack.count)


def test_seed_pack_keeps_table5_model_and_table2_resistance():
    pack = load_battery(REPO / "aircraft/batteries/multistar_10ah_4s.yaml")
    assert (pack.model.delta, pack.model.epsilon, pack.model.beta) == (23.6482, -1.0209, 0.9648)
    assert not pack.model.literature
    assert pack.internal_resistance_ohm == pytest.approx(0.02068)


def test_pack_without_model_uses_literature_values_scaled_to_the_pack():
    """δ₀(4) = 18.089 in the Peukert form (β = 1); with β = 0.9648, δ = δ₀ C_n^(1−β), so
    that a full constant-power discharge takes the same time in both forms."""
    pack = load_battery(REPO / "aircraft/batteries/lipo_4s_1500.yaml")
    m = pack.model
    assert m.literature and m.beta == 0.9648
    c_n = 1500 * 3.6
    assert m.delta == pytest.approx(18.0891 * c_n ** (1 - 0.9648))
    from planner.physics.battery import integral
    t_beta = integral.discharge_time(100.0, c_n, m.delta, m.epsilon, m.beta)
    t_peukert = integral.discharge_time(100.0, c_n, 18.0891, m.epsilon, 1.0)
    assert t_beta == pytest.approx(t_peukert)
    # physically: a 4S pack's effective voltage, energy / charge, is about 15 V
    assert 14.0 < 100.0 * t_beta / c_n < 17.0


def test_seed_quad_takeoff_mass_is_0_6_kg():
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft/quad_7in.yaml")
    assert aircraft.empty_mass_kg + pack.mass_kg == pytest.approx(0.6)
    assert aircraft.multirotor.power_model == "propeller"


def test_power_model_inferred_from_coefficients(tmp_path):
    base = ("name: q\ntype: multirotor\nempty_mass_kg: 1\nefficiency: 0.7\n"
            "multirotor: {rotors: 4, rotor_diameter_m: 0.25%s}\n")
    assert load_aircraft(write(tmp_path, base % "")).multirotor.power_model == "momentum"
    ac = load_aircraft(write(tmp_path, base % ", ct: 0.1, cp: 0.04", "y.yaml"))
    assert ac.multirotor.power_model == "propeller"


def test_the_descent_inflow_weight_is_read_by_the_rotor_models_only(tmp_path):
    """The slow-descent inflow weight changes the momentum model's power in a vertical
    descent; the propeller-coefficient model has no inflow, so a file giving it there is
    refused, as is a weight outside −1 … 2."""
    base = ("name: q\ntype: multirotor\nempty_mass_kg: 1\nefficiency: 0.7\n"
            "multirotor: {rotors: 4, rotor_diameter_m: 0.25%s}\n")
    plain = load_aircraft(write(tmp_path, base % ""))
    ac = load_aircraft(write(tmp_path, base % ", descent_inflow_weight: 1.0", "w.yaml"))
    assert plain.multirotor.descent_inflow_weight == 0.0
    assert ac.multirotor.descent_inflow_weight == 1.0
    descent = {"airspeed": 0.0, "climb_rate": -1.5, "air_density": 1.2, "mass": 1.6}
    assert ac.battery_power(**descent) < plain.battery_power(**descent) - 1.0
    climb = {**descent, "climb_rate": 1.5}
    assert ac.battery_power(**climb) == pytest.approx(plain.battery_power(**climb))
    prop = load_aircraft(write(tmp_path, base % ", ct: 0.1, cp: 0.04", "q.yaml"))
    assert "descent_inflow_weight" not in prop.to_mapping()["multirotor"]   # written back
    assert ac.to_mapping()["multirotor"]["descent_inflow_weight"] == 1.0
    with pytest.raises(InputError, match="descent_inflow_weight.*propeller"):
        load_aircraft(write(tmp_path, base % ", ct: 0.1, cp: 0.04, descent_inflow_weight: 1",
                            "p.yaml"))
    with pytest.raises(InputError, match="descent_inflow_weight"):
        load_aircraft(write(tmp_path, base % ", descent_inflow_weight: 3", "b.yaml"))


def test_a_file_with_the_disks_tilt_flies_it_wherever_no_axial_speed_is_measured(tmp_path):
    """``tilt_drag_area_m2``: a flight state given as airspeed and climb is flown at the
    rotor disks' velocities the tilt gives (planner.physics.power.momentum
    .tilted_disk_velocities), exactly as the same velocities given as measured
    (``disk_frame``); those are never tilted again. The tilt raises the power with speed
    and leaves hover alone; a propeller-coefficient model (no inflow) refuses the key; it
    is written back."""
    from planner.physics.power.momentum import tilted_disk_velocities

    base = ("name: q\ntype: multirotor\nempty_mass_kg: 2\nefficiency: 0.5\n"
            "multirotor: {rotors: 4, rotor_diameter_m: 0.33, drag_area_m2: 0.02%s}\n")
    plain = load_aircraft(write(tmp_path, base % ""))
    ac = load_aircraft(write(tmp_path, base % ", tilt_drag_area_m2: 0.086", "t.yaml"))
    v, rho, m = np.array([0.0, 5.0, 10.0, 14.0]), 1.19, 2.6
    inplane, axial = tilted_disk_velocities(v, 0.0, rho, m, 0.086)
    tilted = ac.battery_power(v, 0.0, rho, m)
    np.testing.assert_allclose(tilted, plain.battery_power(inplane, axial, rho, m),
                               rtol=1e-12)
    np.testing.assert_allclose(ac.battery_power(inplane, axial, rho, m, disk_frame=True),
                               tilted, rtol=1e-12)
    np.testing.assert_allclose(ac.battery_power(v, 0.0, rho, m, disk_frame=True),
                               plain.battery_power(v, 0.0, rho, m), rtol=1e-12)
    assert tilted[0] == pytest.approx(plain.battery_power(0.0, 0.0, rho, m))
    assert tilted[-1] > plain.battery_power(14.0, 0.0, rho, m) + 20.0
    assert ac.to_mapping()["multirotor"]["tilt_drag_area_m2"] == 0.086
    assert "tilt_drag_area_m2" not in plain.to_mapping()["multirotor"]
    with pytest.raises(InputError, match="tilt_drag_area_m2.*propeller"):
        load_aircraft(write(tmp_path, base % ", ct: 0.1, cp: 0.04, tilt_drag_area_m2: 0.1",
                            "p.yaml"))


def test_k_from_aspect_ratio_and_oswald(tmp_path):
    ac = load_aircraft(REPO / "aircraft/x8_mapper.yaml")
    import math
    assert ac.fixed_wing.k == pytest.approx(1 / (math.pi * 0.8 * 5.88))


@pytest.mark.parametrize("text, match", [
    ("name: p\ncells_series: 4\ncapacity_mah: -5\nmass_kg: 0.2\n",
     "capacity_mah must be >= 1, got -5"),
    ("name: p\ncells_series: 4\ncapacity_mah: 1000\nmas_kg: 0.2\n",
     "unknown key 'mas_kg' \\(did you mean 'mass_kg'\\?\\)"),
    ("name: p\ncells_series: four\ncapacity_mah: 1000\nmass_kg: 0.2\n",
     "cells_series must be a whole number"),
    ("name: p\ncapacity_mah: 1000\nmass_kg: 0.2\n", "missing required key 'cells_series'"),
    ("name: p\ncells_series: 4\ncapacity_mah: 1000\nmass_kg: 0.2\nmodel: {delta: 20}\n",
     "missing required key 'model.epsilon'"),
    ("name: p\ncells_series: 4\ncapacity_mah: 1000\nmass_kg: 0.2\nusable_fraction: 1.5\n",
     "usable_fraction must be <= 1"),
    ("- a\n- b\n", "must be a mapping"),
    ("name: [unclosed\n", "not valid YAML at line"),
])
def test_bad_battery_files_name_file_and_key(tmp_path, text, match):
    p = write(tmp_path, text)
    with pytest.raises(InputError, match=match) as info:
        load_battery(p)
    assert str(p) in str(info.value)
    assert "\n" not in str(info.value)


def test_all_problems_reported_at_once(tmp_path):
    p = write(tmp_path, "name: p\ncells_series: 0\ncapacity_mah: 0\nmass_kg: -1\n")
    with pytest.raises(InputError) as info:
        load_battery(p)
    msg = str(info.value)
    assert "cells_series" in msg and "capacity_mah" in msg and "mass_kg" in msg


@pytest.mark.parametrize("text, match", [
    ("name: a\ntype: helicopter\nempty_mass_kg: 1\nefficiency: 0.5\n", "type must be one of"),
    ("name: a\ntype: fixed_wing\nempty_mass_kg: 1\nefficiency: 1.5\n"
     "fixed_wing: {wing_area_m2: 0.3, cd0: 0.02, k: 0.05, cruise_airspeed_ms: 15}\n",
     "efficiency must be <= 1"),
    ("name: a\ntype: fixed_wing\nempty_mass_kg: 1\nefficiency: 0.5\n"
     "fixed_wing: {wing_area_m2: 0.3, cd0: 0.02, cruise_airspeed_ms: 15}\n", "needs 'k'"),
    ("name: a\ntype: multirotor\nempty_mass_kg: 1\nefficiency: 0.5\n", "missing required key "
     "'multirotor'"),
    ("name: a\ntype: multirotor\nempty_mass_kg: 1\nefficiency: 0.5\n"
     "multirotor: {rotors: 4, rotor_diameter_m: 0.2, power_model: propeller}\n",
     "power_model 'propeller' needs 'multirotor.ct'"),
    ("name: a\ntype: fixed_wing\nempty_mass_kg: 1\nefficiency: 0.5\n"
     "fixed_wing: {wing_area_m2: 0.3, cd0: 0.02, k: 0.05, cruise_airspeed_ms: 8, "
     "stall_speed_ms: 10}\n", "must be above stall_speed_ms"),
])
def test_bad_aircraft_files(tmp_path, text, match):
    with pytest.raises(InputError, match=match):
        load_aircraft(write(tmp_path, text))


def test_missing_file_is_input_error(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        load_aircraft(tmp_path / "nope.yaml")


def test_aircraft_without_pack_and_no_battery_option(tmp_path):
    p = write(tmp_path, "name: a\ntype: multirotor\nempty_mass_kg: 1\nefficiency: 0.5\n"
                        "multirotor: {rotors: 4, rotor_diameter_m: 0.2}\n")
    with pytest.raises(InputError, match="no 'battery' key"):
        load_aircraft_and_battery(p)


def test_round_trip_to_mapping(tmp_path):
    import yaml
    pack = load_battery(REPO / "aircraft/batteries/multistar_10ah_4s.yaml")
    p = write(tmp_path, yaml.safe_dump(pack.to_mapping(), allow_unicode=True))
    again = load_battery(p)
    assert again.model == pack.model and again.capacity_mah == pack.capacity_mah


def test_literature_model_for_large_packs_scales_with_voltage():
    """The start-value polynomials turn over above 6 cells; δ keeps growing as N^(−ε)."""
    from planner.parameters import IntegralModel
    deltas = [IntegralModel.from_literature(n).delta for n in range(3, 15)]
    assert all(b > a for a, b in zip(deltas, deltas[1:]))
    assert IntegralModel.from_literature(12).delta == pytest.approx(
        2 * IntegralModel.from_literature(6).delta, rel=0.02)


def test_efficiency_curve_from_diagnose_changes_battery_power(tmp_path):
    """``efficiency_slope`` (diagnose's efficiency_curve): 1/η(M) = 1/η0 − η1/η0² (M/M_ref − 1),
    so a falling efficiency costs more power above the reference and less below it."""
    from dataclasses import replace

    import yaml
    ac = load_aircraft(REPO / "aircraft/solo_survey.yaml")
    curved = replace(ac, efficiency_slope=-0.1, efficiency_reference_power_w=150.0)
    rho, m = 1.2, 1.5
    for v in (0.0, 15.0):
        p0 = float(ac.battery_power(v, 0.0, rho, m))
        mech = (p0 - ac.system_power_w) * ac.efficiency
        expected = mech * (1 / ac.efficiency + 0.1 / ac.efficiency**2
                           * (mech / 150.0 - 1)) + ac.system_power_w
        assert float(curved.battery_power(v, 0.0, rho, m)) == pytest.approx(expected)
    p = tmp_path / "a.yaml"
    mapping = curved.to_mapping()
    mapping["battery"] = str(REPO / "aircraft/batteries/solo_5200_4s.yaml")
    p.write_text(yaml.safe_dump(mapping, allow_unicode=True))
    again = load_aircraft(p)
    assert again.efficiency_slope == -0.1 and again.efficiency_reference_power_w == 150.0
