"""The operator's view of ``check``: what is printed agrees with itself and with the inputs.

Each test names the point of the operator's-view issue it holds (temperature flown, the
binding limit in the verdict, heating after the mission, cold beyond the model, flooding
reasons, closed pipes).
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from planner.cli.main import main

REPO = Path(__file__).resolve().parents[2]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
SURVEY = str(REPO / "missions/survey_quad.yaml")


def check_json(tmp_path, *extra):
    out = tmp_path / "r.json"
    code = main(["check", SURVEY, "--aircraft", SOLO, "--json", str(out), *extra])
    return code, json.loads(out.read_text())


def test_the_temperature_flown_is_reported(tmp_path, capsys):
    code, data = check_json(tmp_path, "--temperature", "0")
    assert data["environment"]["temperature_c"] == 0.0        # the mission file says 14 °C
    assert "air 0 °C" in capsys.readouterr().out


def test_a_no_go_line_names_the_binding_limit_and_agrees_with_the_margins(tmp_path, capsys):
    """Cold Solo pack: the voltage cut-off, not the nominal charge, grounds the flight. The
    verdict says so with the numbers of the JSON, not "lands with 36.7 % (reserve 20 %)"."""
    code, data = check_json(tmp_path, "--temperature", "0")
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert code == 1 and data["verdict"] == "NO-GO"
    assert data["binding"] == "landing_reserve" and data["cutoff_limited"]
    assert "cut-off" in line and "lands with" not in line
    assert f"short by {-data['margin_mah']:.0f} mAh" in line
    assert f"gives {data['usable_mah']:.0f} mAh" in line
    assert data["summary"] == line
    # and the margin is the usable charge less the reserve and what was drawn
    assert data["margin_mah"] == pytest.approx(
        data["usable_mah"] - data["reserve_mah"] - data["charge_used_mah"], abs=0.01)


def test_a_go_line_states_the_margin_it_prints(tmp_path, capsys):
    code, data = check_json(tmp_path, "--temperature", "25")
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert code == 0 and line.startswith("GO:") and f"{data['margin_mah']:+.0f} mAh" in line


@pytest.mark.parametrize("air", ["37", "40"])
def test_heating_after_the_mission_does_not_ground_it(tmp_path, air):
    """The circuit model runs on past the mission to find the cut-off; a pack that would
    heat to 60 °C only then is not a reason (the mission ends at about 880 s)."""
    code, data = check_json(tmp_path, "--temperature", air)
    assert not any("°C at t =" in r for r in data["reasons"]), data["reasons"]
    assert data["circuit"]["max_temperature_c"] < 60.0


def test_cold_beyond_the_model_is_a_no_go_not_a_refusal(tmp_path):
    code, data = check_json(tmp_path, "--temperature", "-25")
    assert code == 1
    assert "outside the battery model's range" in data["reasons"][0]
    assert data["binding"] == "temperature"


def test_a_storm_gives_a_few_reasons_and_no_figures_for_unflyable_legs(capsys):
    """35 m/s: beyond the Solo's 20 m/s top airspeed, yet under twice it (a wind typed in
    km/h is refused instead)."""
    code = main(["check", SURVEY, "--aircraft", SOLO, "--wind", "35@270"])
    out = capsys.readouterr().out
    nogo = [line for line in out.splitlines() if line.startswith("NO-GO     ")]
    assert code == 1 and 1 <= len(nogo) <= 3
    assert "more legs the aircraft cannot fly" in nogo[-1]
    assert "cannot be flown" in out and "5409" not in out


def long_survey(path, n=1500):
    """A lawnmower of ``n`` waypoints: a table of some 200 kB, more than a pipe holds."""
    lat0, lon0 = 47.3977, 8.5456
    lines = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{lat0}\t{lon0}\t488\t1",
             "1\t0\t3\t22\t0\t0\t0\t0\t0\t0\t40\t1"]
    for i in range(n):
        row, col = divmod(i, 20)
        lon = lon0 + 0.0003 * (col if row % 2 == 0 else 19 - col)
        lines.append(f"{i + 2}\t0\t3\t16\t0\t0\t0\t0\t{lat0 + 0.0002 * row:.7f}\t"
                     f"{lon:.7f}\t40\t1")
    lines.append(f"{n + 2}\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1")
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_a_closed_pipe_ends_quietly(tmp_path):
    """``endurance check … | head -1`` on a table larger than the pipe: no "internal
    error", no traceback."""
    mission = long_survey(tmp_path / "long.waypoints")
    p = subprocess.Popen([sys.executable, "-m", "planner", "check", mission, "--aircraft",
                          SOLO], stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=REPO)
    p.stdout.readline()
    p.stdout.close()
    p.wait(timeout=60)
    err = p.stderr.read().decode()
    assert "internal error" not in err and "Traceback" not in err
    assert p.returncode == 141


def test_the_plot_draws_the_limit_that_grounded_the_flight():
    """Cold Solo pack: the dashed landing limit is the reserve above the cut-off (about
    41 % of nominal), and the charge curve ends below it."""
    from planner.cli.plots import common as plots
    from planner.chain.mission_chain import MissionChain
    from planner.io.mission import load_mission

    chain = MissionChain.from_yaml(SOLO, temperature_c=0.0)
    r = chain.check(load_mission(SURVEY))
    ax = plots.plot_remaining(r)
    levels = {round(line.get_ydata()[0], 3) for line in ax.get_lines()
              if len(set(line.get_ydata())) == 1}
    limit = 100 * (1 - r.usable_mah / r.capacity_mah + r.reserve_fraction)
    assert round(limit, 3) in levels and 35 < limit < 45
    assert 100 * r.remaining_fraction < limit


def test_price_ranking_needs_prices(tmp_path, capsys):
    code = main(["select", SURVEY, "--aircraft", SOLO, "--packs",
                 str(REPO / "aircraft/packs/catalog.yaml"), "--objective", "price"])
    err = capsys.readouterr().err
    assert code == 2 and "no pack of the catalog has a price" in err


def test_a_4s_aircraft_does_not_rank_a_6s_pack(tmp_path):
    out = tmp_path / "s.json"
    main(["select", SURVEY, "--aircraft", SOLO, "--packs",
          str(REPO / "aircraft/packs/catalog.yaml"), "--json", str(out)])
    packs = json.loads(out.read_text())["packs"]
    for p in packs:
        if p["cells_series"] != 4:
            assert not p["feasible"] and p["binding"] == "cells"
    assert all(p["cells_series"] == 4 for p in packs if p["feasible"])


def test_the_sweep_headlines_an_optimum_within_the_take_off_mass(capsys):
    """7.7 kg of battery on a 4.2 kg X8 is not an answer: the headline optimum is the best
    battery mass within the limits; the unlimited one is named as beyond them."""
    from planner.parameters import load_aircraft

    x8 = str(REPO / "aircraft/x8_mapper.yaml")
    main(["sweep", "battery-mass", "--aircraft", x8])
    out = capsys.readouterr().out
    optimum = next(line for line in out.splitlines() if line.startswith("Optimum"))
    mb = float(optimum.split()[1])
    ac = load_aircraft(x8)
    assert mb + ac.empty_mass_kg <= ac.max_takeoff_mass_kg
    assert "Unlimited" in out and "beyond the aircraft's limits" in out


def test_hybrid_says_when_the_bank_is_over_the_take_off_mass(tmp_path, capsys):
    out = tmp_path / "h.json"
    main(["hybrid", SURVEY, "--aircraft", SOLO, "--json", str(out)])
    text = capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["over_max_takeoff_mass"] and data["takeoff_mass_with_bank_kg"] > 2.0
    assert "over its maximum take-off mass" in text


def test_fit_aircraft_out_elsewhere_still_finds_its_pack(tmp_path):
    """``fit-aircraft --out elsewhere/A.yaml`` writes the pack path relative to the new
    file, so ``check --aircraft elsewhere/A.yaml`` works."""
    out = tmp_path / "elsewhere" / "A.yaml"
    out.parent.mkdir()
    assert main(["fit-aircraft", str(REPO / "logs/sim_solo_calm.bin"), "--aircraft", SOLO,
                 "--payload", "0.35", "--out", str(out)]) == 0
    assert main(["check", SURVEY, "--aircraft", str(out), "--quiet"]) in (0, 1)


def test_a_missing_pack_file_says_where_its_path_came_from(tmp_path, capsys):
    bad = tmp_path / "A.yaml"
    bad.write_text((REPO / "aircraft/solo_survey.yaml").read_text())
    assert main(["check", SURVEY, "--aircraft", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "battery: batteries/solo_5200_4s.yaml" in err and "relative to the aircraft" in err


def test_a_replay_batch_names_each_bad_file_and_replays_the_rest(tmp_path, capsys):
    """Operator's-view point 8: one unreadable log no longer aborts a whole replay batch."""
    bad = tmp_path / "damaged.bin"
    bad.write_bytes(b"\xa3\x95" + bytes(200))
    code = main(["replay", str(REPO / "logs/sim_solo_calm.bin"), str(bad),
                 str(REPO / "logs/sim_solo_windy.ulg"), "--aircraft", SOLO])
    out, err = capsys.readouterr()
    assert code == 2
    assert "sim_solo_calm" in out and "sim_solo_windy" in out
    assert str(bad) in err and "1 of 3 files could not be read" in err


def test_replay_shows_long_log_names_whole(tmp_path, capsys):
    """Two logs whose names differ only after the 34th character are told apart."""
    stem = "survey_block_north_field_2026-11-25_flight"
    a, b = tmp_path / f"{stem}_0001.bin", tmp_path / f"{stem}_0002.bin"
    for p in (a, b):
        p.write_bytes((REPO / "logs/sim_solo_calm.bin").read_bytes())
    assert main(["replay", str(a), str(b)]) == 0
    out = capsys.readouterr().out
    assert f"{stem}_0001 " in out and f"{stem}_0002 " in out


def test_replay_plot_of_nine_logs_is_a_paged_grid(tmp_path, capsys):
    """Operator's-view point 10: a 9-log replay was one 5940 × 770 px row."""
    from PIL import Image

    logs = []
    for k in range(9):
        p = tmp_path / f"flight{k}.bin"
        p.write_bytes((REPO / "logs/sim_solo_calm.bin").read_bytes())
        logs.append(str(p))
    png = tmp_path / "replay.png"
    assert main(["replay", *logs, "--aircraft", SOLO, "--plot", str(png)]) == 0
    second = tmp_path / "replay_page2.png"
    assert png.exists() and second.exists()
    w, h = Image.open(png).size
    assert w <= 2000 and h <= 2200 and h > 0.5 * w, (w, h)     # 3 columns × 3 rows of logs
