"""Physical bounds of aircraft and battery files and of ``--wind`` (bad input → InputError).

Every case here used to load and then overflow, end in NaN/inf, or stop with an error
that named neither the file nor the key. Now the loader (or the option parser) refuses
it in one line naming the file, the key path and what was expected.
"""

import copy
import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from planner.cli.main import main
from planner.cli.commands.common import parse_wind
from planner.errors import InputError
from planner.parameters import aircraft as D
from planner.parameters import load_aircraft, load_battery

REPO = Path(__file__).resolve().parents[2]
SOLO = REPO / "aircraft/solo_survey.yaml"
X8 = REPO / "aircraft/x8_mapper.yaml"
SOLO_PACK = REPO / "aircraft/batteries/solo_5200_4s.yaml"
ROUTE = str(REPO / "missions/survey_route.yaml")
MAPPING = str(REPO / "missions/mapping_plane.yaml")


def shipped(path: Path) -> dict:
    data = yaml.safe_load(path.read_text())
    if "battery" in data:
        data["battery"] = str((path.parent / data["battery"]).resolve())
    return data


def write(tmp_path, data: dict, name="x.yaml") -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data, allow_unicode=True))
    return p


def changed(path: Path, block: str | None = None, **values) -> dict:
    """A shipped file with some keys changed (``None`` removes a key)."""
    data = copy.deepcopy(shipped(path))
    target = data[block] if block else data
    for key, value in values.items():
        if value is None:
            target.pop(key, None)
        else:
            target[key] = value
    return data


def load_error(loader, tmp_path, data: dict) -> str:
    p = write(tmp_path, data)
    with pytest.raises(InputError) as info:
        loader(p)
    msg = str(info.value)
    assert msg.startswith(f"{p}: ") and "\n" not in msg
    return msg


def run(*args):
    return subprocess.run([sys.executable, "-m", "planner", *map(str, args)],
                          capture_output=True, text=True, cwd=REPO, timeout=120, check=False)


# --------------------------------------------------------------------------- --wind

@pytest.mark.parametrize("text", ["1e308@0", "101@0", "100.5@90", "inf@0", "-1@0", "nan@0"])
def test_wind_speed_must_be_within_100_ms(text):
    with pytest.raises(InputError, match=r"--wind: speed must be in \[0, 100\] m/s"):
        parse_wind(text)


@pytest.mark.parametrize("text", ["6@400", "6@-90", "6@360.5", "6@nan", "6@1e308"])
def test_wind_direction_must_be_a_bearing(text):
    with pytest.raises(InputError, match=r"--wind: direction must be a bearing in \[0, 360\]"):
        parse_wind(text)


@pytest.mark.parametrize("text, expected", [
    ("6@360", (6.0, 0.0)),          # north as METAR writes it
    ("6@0", (6.0, 0.0)),
    ("100@359.5", (100.0, 359.5)),
    ("0@270", (0.0, 270.0)),
])
def test_wind_within_bounds_is_accepted(text, expected):
    assert parse_wind(text) == expected


@pytest.mark.parametrize("wind", ["1e308@0", "6@400"])
def test_cli_refuses_out_of_range_wind_with_one_line(wind):
    p = run("check", ROUTE, "--aircraft", SOLO, "--wind", wind)
    assert p.returncode == 2, p.stderr
    assert "--wind" in p.stderr and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


# --------------------------------------------------------------------------- upper bounds

@pytest.mark.parametrize("path, block, key, value, expected", [
    (X8, "fixed_wing", "cruise_airspeed_ms", 1e308, "fixed_wing.cruise_airspeed_ms must be <= 150"),
    (X8, "fixed_wing", "max_airspeed_ms", 1e308, "fixed_wing.max_airspeed_ms must be <= 150"),
    (X8, "fixed_wing", "stall_speed_ms", 1e308, "fixed_wing.stall_speed_ms must be <= 150"),
    (X8, "fixed_wing", "loiter_airspeed_ms", 1e308,
     "fixed_wing.loiter_airspeed_ms must be <= 150"),
    (X8, "fixed_wing", "loiter_radius_m", 1e308, "fixed_wing.loiter_radius_m must be <= 10000"),
    (X8, "fixed_wing", "wing_area_m2", 1e308, "fixed_wing.wing_area_m2 must be <= 500"),
    (X8, "fixed_wing", "wing_area_m2", 1e-300, "fixed_wing.wing_area_m2 must be >= 0.005"),
    (X8, "fixed_wing", "cruise_airspeed_ms", 0.5, "fixed_wing.cruise_airspeed_ms must be >= 1"),
    (X8, None, "empty_mass_kg", 1e308, "empty_mass_kg must be <= 1000"),
    (X8, None, "system_power_w", 1e308, "system_power_w must be <= 1e\\+06"),
    (SOLO, None, "empty_mass_kg", 1e308, "empty_mass_kg must be <= 1000"),
    (SOLO, None, "max_takeoff_mass_kg", 1e308, "max_takeoff_mass_kg must be <= 1000"),
    (SOLO, None, "system_power_w", 1e308, "system_power_w must be <= 1e\\+06"),
    (SOLO, None, "climb_rate_ms", 1e308, "climb_rate_ms must be <= 50"),
    (SOLO, None, "descent_rate_ms", 1e308, "descent_rate_ms must be <= 50"),
    (SOLO, None, "efficiency", 1e-300, "efficiency must be >= 0.05"),
    (SOLO, "multirotor", "rotor_diameter_m", 1e-300, "multirotor.rotor_diameter_m must be >= 0.02"),
    (SOLO, "multirotor", "cruise_speed_ms", 1e308, "multirotor.cruise_speed_ms must be <= 150"),
    (SOLO, "multirotor", "cruise_speed_ms", 1e-300, "multirotor.cruise_speed_ms must be >= 0.1"),
    (SOLO, "multirotor", "max_airspeed_ms", 1e308, "multirotor.max_airspeed_ms must be <= 150"),
    (SOLO, "multirotor", "tip_speed_ms", 1e-300, "multirotor.tip_speed_ms must be >= 10"),
    (SOLO, "multirotor", "tip_speed_ms", 1e308, "multirotor.tip_speed_ms must be <= 340"),
    (SOLO, "multirotor", "max_thrust_n", 1e308, "multirotor.max_thrust_n must be <= 100000"),
    (SOLO, None, "energy_error_sd", 8.2, "energy_error_sd must be <= 1"),   # per cent for a fraction
    (SOLO, None, "energy_error_sd", -0.1, "energy_error_sd must be >= 0"),
])
def test_aircraft_numbers_are_bounded(tmp_path, path, block, key, value, expected):
    assert expected.replace("\\", "") in load_error(load_aircraft, tmp_path,
                                                    changed(path, block, **{key: value}))


def test_efficiency_curve_reference_power_is_bounded(tmp_path):
    for value, expected in ((1e308, "must be <= 1e+06"), (1e-300, "must be >= 1")):
        data = changed(SOLO, efficiency_slope=0.1, efficiency_reference_power_w=value)
        assert f"efficiency_reference_power_w {expected}" in load_error(load_aircraft, tmp_path,
                                                                        data)


def test_propeller_coefficients_are_bounded_below(tmp_path):
    quad = REPO / "aircraft/quad_7in.yaml"
    assert "multirotor.ct must be >= 0.005" in load_error(
        load_aircraft, tmp_path, changed(quad, "multirotor", ct=1e-300))
    assert "multirotor.cp must be >= 0.002" in load_error(
        load_aircraft, tmp_path, changed(quad, "multirotor", cp=1e-300))


@pytest.mark.parametrize("key, value, expected", [
    ("mass_kg", 1e308, "mass_kg must be <= 1000"),
    ("capacity_mah", 1e308, "capacity_mah must be <= 1e+06"),
    ("capacity_mah", 1e-300, "capacity_mah must be >= 1"),
    ("max_discharge_c", 1e308, "max_discharge_c must be <= 1000"),
    ("price", 1e308, "price must be <= 1e+09"),
    ("model", {"delta": 1e308, "epsilon": -1.0}, "model.delta must be <= 1e+20"),
    ("model", {"delta": 1e-300, "epsilon": -1.0}, "model.delta must be >= 1e-20"),
    ("model", {"delta": 20.0, "epsilon": -1.0, "cycle": 1e308}, "model.cycle must be <= 100000"),
])
def test_battery_numbers_are_bounded(tmp_path, key, value, expected):
    assert expected in load_error(load_battery, tmp_path, changed(SOLO_PACK, **{key: value}))


@pytest.mark.parametrize("loader, path, block, key, value, expected", [
    (load_aircraft, SOLO, None, "efficiency", 60, "efficiency must be <= 1, got 60 "
     "(looks like a percentage: 60 % is 0.6)"),
    (load_aircraft, SOLO, None, "energy_error_sd", 8.2, "energy_error_sd must be <= 1, got 8.2 "
     "(looks like a percentage: 8.2 % is 0.082)"),
    (load_aircraft, SOLO, "multirotor", "figure_of_merit", 65, "multirotor.figure_of_merit must "
     "be <= 1, got 65 (looks like a percentage: 65 % is 0.65)"),
    (load_aircraft, X8, "fixed_wing", "oswald_efficiency", 80, "fixed_wing.oswald_efficiency "
     "must be <= 1, got 80 (looks like a percentage: 80 % is 0.8)"),
    (load_battery, SOLO_PACK, None, "usable_fraction", 95, "usable_fraction must be <= 1, got 95 "
     "(looks like a percentage: 95 % is 0.95)"),
    (load_battery, SOLO_PACK, "model", "charge_error_sd", 4, "model.charge_error_sd must be "
     "<= 0.5, got 4 (looks like a percentage: 4 % is 0.04)"),
    (load_battery, SOLO_PACK, "circuit", "coulombic_efficiency", 99, "circuit.coulombic_efficiency"
     " must be <= 1, got 99 (looks like a percentage: 99 % is 0.99)"),
])
def test_a_share_given_as_a_percentage_says_it_looks_like_one(tmp_path, loader, path, block, key,
                                                              value, expected):
    data = copy.deepcopy(shipped(path))
    if block == "model":
        data["model"] = {"delta": 20.0, "epsilon": -1.0}
    (data.setdefault(block, {}) if block else data)[key] = value
    assert expected in load_error(loader, tmp_path, data)


@pytest.mark.parametrize("loader, path, block, key, value", [
    (load_aircraft, X8, "fixed_wing", "oswald_efficiency", 2),   # 2 % is below its bound
    (load_battery, SOLO_PACK, None, "usable_fraction", 150),      # above 100 %
    (load_aircraft, X8, "fixed_wing", "cd0", 3),                  # a coefficient, not a share
])
def test_a_value_that_is_no_plausible_percentage_gets_no_percentage_hint(tmp_path, loader, path,
                                                                         block, key, value):
    message = load_error(loader, tmp_path, changed(path, block, **{key: value}))
    assert f"got {value}" in message and "percentage" not in message


def test_huge_yaml_integer_is_an_input_error_not_an_overflow(tmp_path):
    p = tmp_path / "p.yaml"
    p.write_text("name: p\ncells_series: 4\ncapacity_mah: 1" + "0" * 400 + "\nmass_kg: 0.2\n")
    with pytest.raises(InputError, match="capacity_mah must be finite, got a number of 401 digits"):
        load_battery(p)
    p.write_text("name: p\ncells_series: 4\ncapacity_mah: 1" + "0" * 300 + "\nmass_kg: 0.2\n")
    with pytest.raises(InputError, match=r"capacity_mah must be <= 1e\+06, got 1e\+300$"):
        load_battery(p)


def test_exponent_without_decimal_point_gets_a_hint(tmp_path):
    """YAML 1.1 (PyYAML) reads ``1e3`` as text; the message says how to write it."""
    p = tmp_path / "p.yaml"
    p.write_text("name: p\ncells_series: 4\ncapacity_mah: 5e3\nmass_kg: 0.2\n")
    with pytest.raises(InputError, match=r"capacity_mah must be a number, got '5e3' "
                                         r"\(YAML reads .* write e\.g\. 1\.0e\+3\)"):
        load_battery(p)


# --------------------------------------------------------------------------- fixed-wing keys

@pytest.mark.parametrize("key, value, expected", [
    ("aspect_ratio", 0, "fixed_wing.aspect_ratio must be >= 1, got 0"),
    ("oswald_efficiency", 0, "fixed_wing.oswald_efficiency must be >= 0.3, got 0"),
    ("oswald_efficiency", 2, "fixed_wing.oswald_efficiency must be <= 1, got 2"),
])
def test_polar_keys_name_file_and_key(tmp_path, key, value, expected):
    """These used to reach induced_drag_factor and fail there without file or key."""
    assert expected in load_error(load_aircraft, tmp_path, changed(X8, "fixed_wing",
                                                                   **{key: value}))


@pytest.mark.parametrize("values, expected", [
    ({"max_airspeed_ms": 5}, ("fixed_wing.max_airspeed_ms must be above the stall speed "
                             "(fixed_wing.stall_speed_ms 11 m/s), got 5")),
    ({"max_airspeed_ms": 15}, ("fixed_wing.max_airspeed_ms must be at least the cruise airspeed "
                              "(fixed_wing.cruise_airspeed_ms 18 m/s), got 15")),
    ({"loiter_airspeed_ms": 10}, ("fixed_wing.loiter_airspeed_ms must be above the stall speed "
                                 "(fixed_wing.stall_speed_ms 11 m/s), got 10")),
    ({"loiter_airspeed_ms": 30}, ("fixed_wing.loiter_airspeed_ms must be at most the maximum "
                                 "airspeed (fixed_wing.max_airspeed_ms 28 m/s), got 30")),
])
def test_fixed_wing_speeds_are_consistent(tmp_path, values, expected):
    assert expected in load_error(load_aircraft, tmp_path, changed(X8, "fixed_wing", **values))


def test_a_bad_speed_is_reported_once(tmp_path):
    """A value out of its own range is not compared with the other speeds as well."""
    msg = load_error(load_aircraft, tmp_path, changed(X8, "fixed_wing", stall_speed_ms=1e308))
    assert msg.count("stall_speed_ms") == 1 and "must be above" not in msg


def test_loiter_radius_bounded_by_bank_and_stall(tmp_path):
    msg = load_error(load_aircraft, tmp_path, changed(X8, "fixed_wing", loiter_radius_m=1))
    assert ("fixed_wing.loiter_radius_m must be at least 19.1 m (a level turn at the loiter "
            "airspeed 18 m/s with at most 60° of bank, above the stall speed 11 m/s), "
            "got 1") in msg
    # just above the bound loads
    ac = load_aircraft(write(tmp_path, changed(X8, "fixed_wing", loiter_radius_m=19.2), "y.yaml"))
    assert ac.fixed_wing.loiter_radius_m == 19.2


def test_min_loiter_radius_is_the_bank_or_the_stall_limit():
    """Level coordinated turn: tan φ = V²/(g r), n = 1/cos φ; at the least radius the bank is
    60° (n = 2) or, when that would stall, the stall speed in the turn V_s √n equals V."""
    from planner.physics.power import fixed_wing as fw
    r = D.min_loiter_radius(18.0)
    assert r == pytest.approx(18.0**2 / (9.80665 * math.tan(math.radians(60.0))))
    assert math.degrees(fw.bank_angle(18.0, r)) == pytest.approx(60.0)
    r = D.min_loiter_radius(18.0, stall_speed_ms=15.0)
    assert 15.0 * np.sqrt(fw.bank_load_factor(18.0, r)) == pytest.approx(18.0)
    assert D.min_loiter_radius(18.0, stall_speed_ms=18.0) == math.inf


def test_fixed_wing_without_stall_speed_uses_the_bank_limit_only(tmp_path):
    data = changed(X8, "fixed_wing", stall_speed_ms=None, loiter_radius_m=10)
    msg = load_error(load_aircraft, tmp_path, data)
    assert "must be at least 19.1 m" in msg and "stall speed" not in msg


# --------------------------------------------------------------------------- multirotor keys

def test_multirotor_cruise_above_max_airspeed_is_refused(tmp_path):
    msg = load_error(load_aircraft, tmp_path, changed(SOLO, "multirotor", cruise_speed_ms=25))
    assert ("multirotor.cruise_speed_ms must be at most the maximum airspeed "
            "(multirotor.max_airspeed_ms 20 m/s), got 25") in msg


@pytest.mark.parametrize("values, expected", [
    ({"figure_of_merit": 0.9, "induced_factor": 1.2},
     "multirotor.figure_of_merit must be at most 1/induced_factor = 0.833"),
    ({"figure_of_merit": None, "induced_factor": 1.8},
     "multirotor.induced_factor must be at most 1.67 with the default figure of merit 0.6"),
])
def test_momentum_figure_of_merit_and_induced_factor_leave_profile_power(tmp_path, values,
                                                                           expected):
    """Profile power P0 = (1/FM − κ) P_ideal cannot be negative (it used to fail at run time,
    naming neither file nor key)."""
    assert expected in load_error(load_aircraft, tmp_path, changed(SOLO, "multirotor", **values))


# --------------------------------------------------------------------------- end to end

def test_cli_out_of_range_aircraft_exits_2_naming_file_and_key(tmp_path):
    a = write(tmp_path, changed(X8, "fixed_wing", cruise_airspeed_ms=1e308, max_airspeed_ms=None))
    p = run("check", MAPPING, "--aircraft", a)
    assert p.returncode == 2, p.stderr
    assert p.stderr.strip() == (f"error: {a}: fixed_wing.cruise_airspeed_ms must be <= 150, "
                                f"got 1e+308")


@pytest.mark.parametrize("aircraft, mission, block, values", [
    (SOLO, ROUTE, "multirotor", {"rotor_diameter_m": 0.02, "cruise_speed_ms": 150.0,
                                 "max_airspeed_ms": 150.0, "drag_area_m2": 10.0}),
    (X8, MAPPING, "fixed_wing", {"cruise_airspeed_ms": 150.0, "max_airspeed_ms": 150.0,
                                 "wing_area_m2": 0.005, "loiter_radius_m": 1400.0}),
])
def test_aircraft_at_its_bounds_gives_a_finite_verdict(tmp_path, aircraft, mission, block,
                                                       values):
    """The bounds are tight enough: the heaviest, fastest aircraft in the strongest wind
    gives finite numbers (a NO-GO), not an overflow."""
    data = changed(aircraft, block, **values)
    data.update(empty_mass_kg=1000.0, max_takeoff_mass_kg=1000.0, system_power_w=1.0e6,
                climb_rate_ms=50.0)
    out = tmp_path / "r.json"
    code = main(["check", mission, "--aircraft", str(write(tmp_path, data)), "--quiet",
                 "--wind", "100@90", "--json", str(out)])
    result = json.loads(out.read_text())
    assert code == 1 and result["verdict"] == "NO-GO"
    assert all(math.isfinite(leg["power_w"]) for leg in result["legs"])


def test_default_loiter_radius_widens_for_a_fast_aircraft(tmp_path):
    """Without ``loiter_radius_m`` the default 60 m circle is kept when it can be flown and
    widened to the tightest allowed circle when it cannot (not refused: the user wrote no
    radius)."""
    slow = load_aircraft(write(tmp_path, changed(X8, "fixed_wing", loiter_radius_m=None)))
    assert slow.fixed_wing.loiter_radius_m == 60.0
    data = changed(X8, "fixed_wing", loiter_radius_m=None, cruise_airspeed_ms=40.0,
                   max_airspeed_ms=45.0)
    fast = load_aircraft(write(tmp_path, data, "fast.yaml"))
    r_min = D.min_loiter_radius(40.0, 11.0)
    assert r_min > 60.0 and fast.fixed_wing.loiter_radius_m == pytest.approx(r_min, abs=0.1)
    assert fast.fixed_wing.loiter_radius_m >= r_min
