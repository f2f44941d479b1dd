"""``endurance diagnose`` as a user runs it: JSON, plot, extended YAML that ``check`` uses,
bad input."""

import json
from pathlib import Path

import pytest
import yaml
from diagnose_generators import PACK_6S, PACK_10AH, aircraft_file, capacity_dataset, power_dataset

from planner.cli.main import main
from planner.parameters import load_aircraft, load_battery

REPO = Path(__file__).resolve().parents[3]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
ROUTE = str(REPO / "missions/survey_route.yaml")


@pytest.fixture(scope="module")
def cold(tmp_path_factory):
    """Ten discharges of a pack that draws more charge in the cold (circuit model)."""
    d = tmp_path_factory.mktemp("cold")
    df, _ = capacity_dataset("temperature", 0.008, profile="flights", seed=1)
    df.to_csv(d / "cold.csv", index=False)
    (d / "pack.yaml").write_text(yaml.safe_dump(dict(PACK_10AH)))
    return d


def test_cli_writes_json_plot_and_an_extended_pack_that_check_uses(cold, tmp_path, capsys):
    out, png, ext = tmp_path / "d.json", tmp_path / "d.png", tmp_path / "ext.yaml"
    rc = main(["diagnose", str(cold / "cold.csv"), "--battery", str(cold / "pack.yaml"),
               "--json", str(out), "--plot", str(png), "--out", str(ext)])
    text = capsys.readouterr().out
    assert rc == 0
    assert "Cold pack: charge drawn per Wh rises" in text and "held-out error" in text
    data = json.loads(out.read_text())
    assert data["findings"][0]["effect"] == "temperature"
    assert data["baseline"]["unit"] == "mAh"
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 20_000
    pack = load_battery(ext)                      # loads back through the schema
    k = data["findings"][0]["parameters"]["temperature_coefficient_per_c"]
    assert pack.model.temperature_coefficient_per_c == pytest.approx(k)
    assert pack.model.charge_scale(-5.0) > 1.0 + 20 * k
    # `check --temperature` now draws more charge in the cold than the plain pack does
    used = {}
    for name, battery in (("plain", str(cold / "pack.yaml")), ("extended", str(ext))):
        for temp in ("-5", "40"):
            js = tmp_path / f"{name}{temp}.json"
            main(["check", ROUTE, "--aircraft", SOLO, "--battery", battery, "--temperature",
                  temp, "--json", str(js), "--quiet"])
            used[name, temp] = json.loads(js.read_text())["charge_used_mah"]
    capsys.readouterr()
    plain = used["plain", "-5"] / used["plain", "40"]
    extended = used["extended", "-5"] / used["extended", "40"]
    assert extended / plain == pytest.approx(pack.model.charge_scale(-5.0), rel=0.02)


def test_cli_power_level_writes_the_calibrated_aircraft(tmp_path, capsys):
    df, _ = power_dataset("system_power", 60.0, seed=1, duration_s=600, rate_hz=2)
    df.to_csv(tmp_path / "f.csv", index=False)
    (tmp_path / "pack.yaml").write_text(yaml.safe_dump(dict(PACK_6S)))
    (tmp_path / "ac.yaml").write_text(yaml.safe_dump(
        aircraft_file(efficiency=0.6, drag_area_m2=0.06).to_mapping()))
    out, ext = tmp_path / "d.json", tmp_path / "ac_ext.yaml"
    rc = main(["diagnose", str(tmp_path / "f.csv"), "--battery", str(tmp_path / "pack.yaml"),
               "--aircraft", str(tmp_path / "ac.yaml"), "--json", str(out), "--out", str(ext),
               "--effects", "system_power,efficiency_curve,current_offset"])
    capsys.readouterr()
    assert rc == 0
    names = [f["effect"] for f in json.loads(out.read_text())["findings"]]
    assert names == ["system_power"]
    ac = load_aircraft(ext)
    assert ac.system_power_w == pytest.approx(72.0, abs=20.0)     # 12 W file + 60 W hidden
    assert ac.efficiency == pytest.approx(0.72, abs=0.05)


def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys):
    rc = main(["diagnose", str(tmp_path / "missing.csv"), "--json", str(tmp_path / "o.json")])
    err = capsys.readouterr().err
    assert rc == 2 and "missing.csv" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    df, _ = capacity_dataset(None, n_experiments=2, duration_s=600, seed=0)
    df.to_csv(tmp_path / "d.csv", index=False)
    rc = main(["diagnose", str(tmp_path / "d.csv"), "--json", str(tmp_path / "o.json"),
               "--effects", "temperature,moon_phase"])
    err = capsys.readouterr().err
    assert rc == 2 and "moon_phase" in err
    # without --json the findings are printed (the JSON is optional)
    assert main(["diagnose", str(tmp_path / "d.csv")]) == 0
    assert "Baseline, capacity level" in capsys.readouterr().out
