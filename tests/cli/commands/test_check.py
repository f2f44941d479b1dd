"""``endurance check`` as a user runs it: exit codes, output files, bad input."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from planner.cli.main import main

REPO = Path(__file__).resolve().parents[3]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
ROUTE = str(REPO / "missions/survey_route.yaml")


def run(*args):
    return subprocess.run([sys.executable, "-m", "planner", *args], capture_output=True,
                          text=True, cwd=REPO, timeout=120)


def test_go_mission_exits_0_and_writes_json_and_plot(tmp_path):
    out, png = tmp_path / "r.json", tmp_path / "r.png"
    p = run("check", ROUTE, "--aircraft", SOLO, "--json", str(out), "--plot", str(png))
    assert p.returncode == 0, p.stderr
    assert "GO" in p.stdout and "Traceback" not in p.stderr
    data = json.loads(out.read_text())
    for key in ("verdict", "reasons", "takeoff_mass_kg", "duration_s", "energy_wh",
                "charge_used_mah", "remaining_fraction", "reserve_fraction", "margin_mah",
                "legs"):
        assert key in data
    assert data["verdict"] == "GO" and data["reasons"] == []
    for key in ("kind", "duration_s", "distance_m", "airspeed_ms", "groundspeed_ms",
                "climb_rate_ms", "power_w", "current_a", "charge_mah", "remaining_fraction"):
        assert key in data["legs"][0]
    assert sum(leg["charge_mah"] for leg in data["legs"]) == pytest.approx(
        data["charge_used_mah"], rel=1e-6)
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


def test_nogo_mission_exits_1_with_reason(tmp_path):
    out = tmp_path / "r.json"
    code = main(["check", str(REPO / "missions/survey_quad.yaml"), "--aircraft",
                 str(REPO / "aircraft/quad_7in.yaml"), "--json", str(out), "--quiet"])
    assert code == 1
    data = json.loads(out.read_text())
    assert data["verdict"] == "NO-GO" and data["reasons"]


def test_wind_option_overrides_mission_and_can_ground_the_flight():
    calm = main(["check", ROUTE, "--aircraft", SOLO, "--quiet", "--wind", "0@0"])
    gale = main(["check", ROUTE, "--aircraft", SOLO, "--quiet", "--wind", "25@270"])
    assert calm == 0 and gale == 1


def test_reserve_option():
    assert main(["check", ROUTE, "--aircraft", SOLO, "--quiet", "--reserve", "90%"]) == 1


@pytest.mark.parametrize("text", ["0.3", "30%", "30"])
def test_reserve_as_fraction_or_percentage(text, capsys):
    """``--reserve 30`` is 30 % (a fraction cannot exceed 1), as 0.3 and 30% are."""
    main(["check", ROUTE, "--aircraft", SOLO, "--quiet", "--reserve", text])
    assert "(30 %)" in capsys.readouterr().out


@pytest.mark.parametrize("args, needle", [
    (["check", "missing.yaml", "--aircraft", SOLO], "missing.yaml"),
    (["check", ROUTE, "--aircraft", "nope.yaml"], "nope.yaml"),
    (["check", ROUTE, "--aircraft", SOLO, "--wind", "fast"], "--wind"),
    (["check", ROUTE, "--aircraft", SOLO, "--reserve", "100"], "--reserve"),
    (["check", ROUTE, "--aircraft", SOLO, "--reserve", "-5"], "--reserve"),
    (["check", ROUTE, "--aircraft", SOLO, "--temperature", "hot"], "--temperature"),
    (["check", ROUTE, "--aircraft", SOLO, "--json", "/no/such/dir/r.json"], "--json"),
    (["check", ROUTE], "--aircraft"),
    (["check", ROUTE, "--aircraft", SOLO, "--plot", "r.txt"], "expected a figure file"),
    (["select", ROUTE, "--aircraft", SOLO, "--packs", "aircraft/packs/catalog.yaml",
      "--plot", "p.xyz"], "expected a figure file"),
])
def test_bad_input_exits_2_with_one_line(args, needle):
    p = run(*args)
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) <= 2 and needle in p.stderr   # argparse adds a usage line
    assert "Traceback" not in p.stderr


@pytest.mark.parametrize("content, needle", [
    ("legs: []\n", "legs"),
    ("legs:\n  - teleport: {distance_m: 5}\n", "teleport"),
    ("legs:\n  - cruise: {distance_m: -5, course_deg: 0}\n", "distance_m"),
    ("name: x\nlegs:\n  - hover: {duration_s: ten}\n", "duration_s"),
])
def test_bad_mission_files_exit_2_naming_the_key(tmp_path, content, needle):
    m = tmp_path / "m.yaml"
    m.write_text(content)
    p = run("check", str(m), "--aircraft", SOLO)
    assert p.returncode == 2, p.stdout
    assert needle in p.stderr and str(m) in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


def test_bad_aircraft_file_exits_2(tmp_path):
    a = tmp_path / "a.yaml"
    a.write_text("name: a\ntype: multirotor\nempty_mass_kg: -1\nefficiency: 0.5\n"
                 "multirotor: {rotors: 4, rotor_diameter_m: 0.2}\nbattery: x.yaml\n")
    p = run("check", ROUTE, "--aircraft", str(a))
    assert p.returncode == 2 and "empty_mass_kg" in p.stderr


def test_input_files_are_not_modified(tmp_path):
    before = {p: p.read_bytes() for p in [Path(ROUTE), Path(SOLO)]}
    main(["check", ROUTE, "--aircraft", SOLO, "--quiet", "--json", str(tmp_path / "o.json")])
    assert all(p.read_bytes() == b for p, b in before.items())


def test_an_output_path_that_names_an_input_is_refused(tmp_path):
    """Input files are never modified, whatever output option names them."""
    import shutil
    mission = tmp_path / "route.yaml"
    shutil.copy(REPO / "missions" / "survey_route.yaml", mission)
    log = tmp_path / "calm.bin"
    shutil.copy(REPO / "logs" / "sim_solo_calm.bin", log)
    before = {p: p.read_bytes() for p in (mission, log)}
    for args in (["check", mission, "--aircraft", SOLO, "--json", mission],
                 ["check", mission, "--aircraft", SOLO, "--plot", tmp_path / "x.png",
                  "--json", tmp_path / ".." / tmp_path.name / "route.yaml"],
                 ["export", log, "--csv", log]):
        p = run(*map(str, args))
        assert p.returncode == 2, p.stderr
        assert "input files are never overwritten" in p.stderr
        assert len(p.stderr.strip().splitlines()) == 1
    assert {p: p.read_bytes() for p in (mission, log)} == before


def test_payload_spread_in_grams_is_refused_with_the_unit(capsys):
    """``--payload-sd 50`` meant 50 g: a 50 kg spread for a 2 kg aircraft is refused,
    saying grams; 0.05 (kg) runs."""
    quad = str(REPO / "missions/survey_quad.yaml")
    base = ["check", quad, "--aircraft", SOLO, "--uncertainty", "--samples", "50"]
    assert main(base + ["--payload-sd", "50"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == ("error: --payload-sd 50: 50 kg of payload spread is more than the "
                   "aircraft's maximum take-off mass 2 kg: grams? (50 g = 0.05 kg)")
    assert main(base + ["--payload-sd", "0.05"]) in (0, 1)


@pytest.mark.parametrize("flag, value", [("--payload-sd", "0.05"), ("--gust", "1.4"),
                                         ("--soh", "0.9±0.05"), ("--wind-sd", "2@30")])
def test_a_spread_without_uncertainty_is_refused_not_ignored(capsys, flag, value):
    """A spread is drawn only by the --uncertainty run: given without it, it was silently
    ignored (and never checked); it is refused naming the flag."""
    quad = str(REPO / "missions/survey_quad.yaml")
    assert main(["check", quad, "--aircraft", SOLO, flag, value]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {flag}: a spread of the --uncertainty run")
