"""``endurance select`` and ``endurance sweep`` as a user runs them."""

import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from planner.cli.main import main

REPO = Path(__file__).resolve().parents[3]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
X8 = str(REPO / "aircraft/x8_mapper.yaml")
SURVEY = str(REPO / "missions/survey_quad.yaml")
CATALOG = str(REPO / "aircraft/packs/catalog.yaml")


def run(*args):
    return subprocess.run([sys.executable, "-m", "planner", *args], capture_output=True,
                          text=True, cwd=REPO, timeout=300, check=False)


def test_select_feasible_exits_0_with_ranked_json_and_pareto_plot(tmp_path):
    out, png = tmp_path / "s.json", tmp_path / "s.png"
    p = run("select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--json", str(out),
            "--plot", str(png), "--top", "5")
    assert p.returncode == 0, p.stderr
    assert "Best" in p.stdout and "Traceback" not in p.stderr
    assert "literature" in p.stdout                 # packs without fitted δ, ε are named
    data = json.loads(out.read_text())
    packs = data["packs"]
    assert len(packs) == data["pack_count"] >= 15   # JSON holds every pack, not --top
    for pack in packs:
        for key in ("name", "feasible", "mass_kg", "margin_mah", "reasons", "binding",
                    "takeoff_mass_kg", "battery_model"):
            assert key in pack
        assert pack["feasible"] == (pack["reasons"] == []) == (pack["binding"] is None)
    feasible = [p for p in packs if p["feasible"]]
    assert packs[:len(feasible)] == feasible        # ranked: feasible first ...
    masses = [p["mass_kg"] for p in feasible]
    assert masses == sorted(masses)                 # ... lightest first
    assert data["best"] == packs[0]["name"] and data["objective"] == "mass"
    assert [p["rank"] for p in packs] == list(range(1, len(packs) + 1))
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"


def test_select_margin_objective(tmp_path):
    out = tmp_path / "s.json"
    code = main(["select", str(REPO / "missions/mapping_plane.yaml"), "--aircraft", X8,
                 "--packs", CATALOG, "--objective", "margin", "--json", str(out)])
    assert code == 0
    packs = [p for p in json.loads(out.read_text())["packs"] if p["feasible"]]
    times = [p["margin_time_s"] for p in packs]
    assert times == sorted(times, reverse=True)


def test_select_none_feasible_exits_1_and_plans_sorties(tmp_path):
    out = tmp_path / "s.json"
    mission = tmp_path / "long.yaml"
    lines = ["name: long survey", "payload_kg: 0.35", "legs:",
             "  - climb: {altitude_m: 40, rate_ms: 3}"]
    for k in range(14):
        lines.append(f"  - cruise: {{distance_m: 1500, course_deg: {0 if k % 2 == 0 else 180}}}")
        lines.append("  - cruise: {distance_m: 60, course_deg: 90}")
    lines += ["  - cruise: {distance_m: 840, course_deg: 270}",
              "  - descend: {altitude_m: 0, rate_ms: 1.5}"]
    mission.write_text("\n".join(lines) + "\n")
    p = run("select", str(mission), "--aircraft", SOLO, "--packs", CATALOG, "--json", str(out))
    assert p.returncode == 1, p.stderr
    assert "NO-GO" in p.stdout and "Sorties" in p.stdout and "Swap 1" in p.stdout
    data = json.loads(out.read_text())
    assert data["best"] is None and not any(pk["feasible"] for pk in data["packs"])
    plan = data["sorties"]
    assert plan["sorties"] >= 2 and len(plan["splits"]) == plan["sorties"] - 1
    assert plan["sorties"] >= plan["lower_bound"]
    for split in plan["splits"]:
        assert {"leg", "fraction", "time_s", "east_m", "north_m"} <= set(split)


@pytest.mark.parametrize("content, needles", [
    (("packs:\n  - {name: a, cells_series: 4, capacity_mah: 5000, mass_kg: 0.5}\n"
      "  - {name: b, cells_series: 4, capacity_mah: 5000, mass_kg: 0.5, colour: red}\n"),
     ["packs[2]", "colour"]),
    ("packs:\n  - {name: a, cells_series: 4, capacity_mah: 5000, mass_kg: -0.5}\n",
     ["packs[1]", "mass_kg"]),
    (("packs:\n  - {name: a, cells_series: 4, capacity_mah: 5000, mass_kg: 0.5, "
      "max_discharge_c: -3}\n"), ["packs[1]", "max_discharge_c"]),
])
def test_bad_catalog_exits_2_with_one_line_naming_file_and_key(tmp_path, content, needles):
    cat = tmp_path / "bad_catalog.yaml"
    cat.write_text(content)
    p = run("select", SURVEY, "--aircraft", SOLO, "--packs", str(cat))
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stderr
    assert "bad_catalog.yaml" in lines[0]
    for needle in needles:
        assert needle in lines[0]


@pytest.mark.parametrize("args, needle", [
    (["select", SURVEY, "--aircraft", SOLO, "--packs", "nope.yaml"], "nope.yaml"),
    (["select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--objective", "cost"],
     "--objective"),
    (["select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--top", "0"], "--top"),
    (["select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--reserve", "150"],
     "--reserve"),
    (["select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--json", "/no/dir/x.json"],
     "--json"),
    (["select", SURVEY, "--aircraft", SOLO], "--packs"),
    (["sweep", "battery-mass", "--aircraft", SOLO, "--range", "3:1"], "--range"),
    (["sweep", "battery-mass", "--aircraft", SOLO, "--cells", "many"], "--cells"),
])
def test_bad_input_exits_2(args, needle):
    p = run(*args)
    assert p.returncode == 2
    assert needle in p.stderr and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) <= 2     # argparse adds a usage line


def test_sweep_battery_mass_table_csv_and_plot(tmp_path):
    csv, png = tmp_path / "e.csv", tmp_path / "e.png"
    p = run("sweep", "battery-mass", "--aircraft", SOLO, "--chemistry", "liion",
            "--cells", "4", "--payload", "0.3", "--csv", str(csv), "--plot", str(png))
    assert p.returncode == 0, p.stderr
    assert "Optimum" in p.stdout and "mass fraction" in p.stdout
    table = pd.read_csv(csv)
    assert {"battery_mass_kg", "mass_fraction", "capacity_mah", "hold_power_w",
            "endurance_s", "feasible"} <= set(table.columns)
    assert len(table) == 200
    i = table.endurance_s.idxmax()
    assert 0 < i < len(table) - 1                   # interior maximum
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_sweep_payload_table_csv_and_plot(tmp_path):
    csv, png = tmp_path / "r.csv", tmp_path / "r.png"
    code = main(["sweep", "payload", "--aircraft", X8, "--range", "0:1.2", "--points", "13",
                 "--csv", str(csv), "--plot", str(png)])
    assert code == 0
    table = pd.read_csv(csv)
    assert len(table) == 13 and table.range_km.is_monotonic_decreasing
    assert {"payload_kg", "range_km", "best_range_km", "feasible"} <= set(table.columns)
    assert png.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize("kind, text, what", [("battery-mass", "200:1500", "battery"),
                                              ("payload", "100:900", "payload")])
def test_sweep_range_in_grams_is_refused_with_the_unit(capsys, kind, text, what):
    """``--range 200:1500`` meant grams: 1500 kg of battery is beyond the aircraft's
    maximum take-off mass, refused in one line saying grams; the range in kg runs."""
    assert main(["sweep", kind, "--aircraft", SOLO, "--range", text]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    hi = text.split(":")[1]
    assert f"--range {text}: {hi} kg of {what} is more than the aircraft's maximum take-off" \
           in err and f"grams? ({hi} g = {float(hi) / 1000:g} kg)" in err
    lo, hi = (float(v) / 1000 for v in text.split(":"))
    assert main(["sweep", kind, "--aircraft", SOLO, "--range", f"{lo:g}:{hi:g}",
                 "--points", "5"]) == 0


def test_select_takes_one_pack_file_as_a_catalog_of_one(capsys):
    """``--packs pack.yaml`` (a single pack, not a catalog) is flown as a catalog of one,
    and the report says so."""
    pack = str(REPO / "aircraft/batteries/solo_5200_4s.yaml")
    assert main(["select", SURVEY, "--aircraft", SOLO, "--packs", pack, "--no-sorties"]) == 0
    out = capsys.readouterr().out
    assert f"Catalog   {pack}: 1 pack (a catalog of one), 1 feasible" in out
    assert "3DR Solo Smart Battery 5200 mAh 4S" in out
