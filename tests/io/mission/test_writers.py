"""Sortie mission files (``select --sorties-out``) and the mission writers behind them."""

from pathlib import Path

import numpy as np
import pytest

from planner.chain.mission_chain import MissionChain
from planner.cli.main import main
from testkit.missions import write_waypoints
from planner.io.mission import load_mission, writers
from planner.parameters import load_aircraft, load_catalog

REPO = Path(__file__).resolve().parents[3]
SOLO = REPO / "aircraft/solo_survey.yaml"
CATALOG = REPO / "aircraft/packs/catalog.yaml"


def same_legs(a, b, tol_m=0.02):
    assert [leg.kind for leg in a.legs] == [leg.kind for leg in b.legs]
    for la, lb in zip(a.legs, b.legs):
        assert np.allclose(la.end_en_m, lb.end_en_m, atol=tol_m)
        assert la.end_alt_m == pytest.approx(lb.end_alt_m, abs=1e-3)
        assert (la.duration_s or 0.0) == pytest.approx(lb.duration_s or 0.0, abs=1e-3)
        assert la.speed_ms == lb.speed_ms


@pytest.mark.parametrize("name", ["survey_route.waypoints", "survey_route.plan",
                                  "survey_route.yaml", "survey_quad.yaml"])
@pytest.mark.parametrize("fmt", ["waypoints", "plan", "yaml"])
def test_written_missions_read_back_into_the_same_legs(name, fmt, tmp_path):
    mission = load_mission(REPO / "missions" / name, vehicle_type="multirotor")
    if fmt != "yaml" and mission.home is None:
        with pytest.raises(Exception, match="no home position"):
            writers.to_waypoints(mission)
        return
    text = {"waypoints": writers.to_waypoints, "plan": writers.to_plan,
            "yaml": writers.to_yaml}[fmt](mission)
    path = tmp_path / f"m.{fmt}"
    path.write_text(text)
    same_legs(mission, load_mission(path, vehicle_type="multirotor"))


@pytest.fixture(scope="module")
def long_survey(tmp_path_factory):
    """A 400-waypoint survey no single pack of the catalog flies: two sorties."""
    folder = tmp_path_factory.mktemp("long")
    wp = folder / "survey.waypoints"
    write_waypoints(wp, n=400)
    mission = load_mission(wp, vehicle_type="multirotor")
    (folder / "survey.plan").write_text(writers.to_plan(mission))
    (folder / "survey.yaml").write_text(writers.to_yaml(mission))
    # one pack that needs two sorties (a catalog of one keeps the sortie search short)
    (folder / "solo.yaml").write_text(
        f"name: Solo pack\npacks:\n  - file: {REPO / 'aircraft/batteries/solo_5200_4s.yaml'}\n")
    return folder


@pytest.mark.parametrize("suffix", [".waypoints", ".plan", ".yaml"])
def test_each_sortie_file_is_in_the_input_format_and_passes_check(long_survey, suffix,
                                                                   tmp_path, capsys):
    src = long_survey / f"survey{suffix}"
    out = tmp_path / "sorties"          # created by the command
    status = main(["select", str(src), "--aircraft", str(SOLO), "--packs",
                   str(long_survey / "solo.yaml"), "--sorties-out", str(out)])
    text = capsys.readouterr().out
    assert status == 1 and "Swap 1" in text
    written = sorted(out.iterdir())
    assert [p.name for p in written] == [f"survey_sortie{k}{suffix}"
                                         for k in range(1, len(written) + 1)]
    assert len(written) >= 2
    # the plan's pack flies each file on its own (the sorties are planned with it)
    aircraft = load_aircraft(SOLO)
    plan_pack = text.split("Sorties   fewest: ")[1].split(" flight(s) with ")[1].split(" (")[0]
    pack = next(p for p in load_catalog(long_survey / "solo.yaml") if p.name == plan_pack)
    swap = text.split("Swap 1")[1].split("\n")[0]
    east = float(swap.split(" m E ")[0].split(", ")[-1])
    for k, path in enumerate(written, 1):
        mission = load_mission(path, vehicle_type=aircraft.type)
        result = MissionChain(aircraft, pack).check(mission)
        assert result.verdict == "GO", (path.name, result.reasons)
        first_cruise = next(leg for leg in mission.legs if leg.kind == "cruise")
        if k == 2:   # starts with a transit from home to where the first one stopped
            assert first_cruise.start_en_m == pytest.approx((0.0, 0.0), abs=1e-6)
            assert first_cruise.end_en_m[0] == pytest.approx(east, abs=1.0)
        assert mission.legs[-1].kind == "descend" and mission.legs[-1].end_alt_m == 0


def test_sorties_out_bad_input_exits_2(long_survey, tmp_path, capsys):
    src = long_survey / "survey.waypoints"
    status = main(["select", str(src), "--aircraft", str(SOLO), "--packs", str(CATALOG),
                   "--sorties-out", str(tmp_path / "missing" / "sorties")])
    err = capsys.readouterr().err
    assert status == 2 and "--sorties-out" in err and "does not exist" in err
    assert not (tmp_path / "missing").exists()
    a_file = tmp_path / "a_file"
    a_file.write_text("")
    status = main(["select", str(src), "--aircraft", str(SOLO), "--packs", str(CATALOG),
                   "--sorties-out", str(a_file)])
    assert status == 2 and "not a folder" in capsys.readouterr().err
    other = tmp_path / "m.mission"
    other.write_text((long_survey / "survey.waypoints").read_text())
    status = main(["select", str(other), "--aircraft", str(SOLO), "--packs", str(CATALOG),
                   "--sorties-out", str(tmp_path)])
    err = capsys.readouterr().err
    assert status == 2 and "cannot write missions in the format" in err


# ------------------------------------------------------------ sorties keep the input's

import json  # noqa: E402
import math  # noqa: E402
import warnings  # noqa: E402

from pymavlink import mavwp  # noqa: E402
from qgc_plan_rules import qgc_problems  # noqa: E402

from planner.chain.sizing import sortie_mission  # noqa: E402
from planner.io.mission import NavDefaults  # noqa: E402
from planner.io.mission.route import MIN_CRUISE_M  # noqa: E402
from tools import missions_real  # noqa: E402

X8 = REPO / "aircraft/x8_mapper.yaml"


def quiet_load(path, defaults):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_mission(path, defaults=defaults)


def flies_as_planned(planned, written, defaults):
    """The legs read back from a written file are the legs planned: same kinds, ends,
    altitudes, hold times, loiter radii and speeds (a leg without a speed flies the
    aircraft's own). A cruise shorter than the readers' MIN_CRUISE_M (a leg cut within
    half a metre of its end) is a waypoint the aircraft has already reached."""
    legs = [leg for leg in planned.legs
            if not (leg.kind == "cruise" and leg.distance_m < MIN_CRUISE_M)]
    assert [leg.kind for leg in written.legs] == [leg.kind for leg in legs]
    for a, b in zip(legs, written.legs):
        assert math.dist(a.end_en_m, b.end_en_m) < 1e-3, (a, b)
        assert b.end_alt_m == pytest.approx(a.end_alt_m, abs=1e-6), (a, b)
        assert (b.duration_s or 0.0) == pytest.approx(a.duration_s or 0.0, abs=1e-6), (a, b)
        assert a.loiter_radius_m == b.loiter_radius_m, (a, b)
        if a.kind == "cruise":
            va = a.speed_ms if a.speed_ms is not None else defaults.cruise_speed_ms
            vb = b.speed_ms if b.speed_ms is not None else defaults.cruise_speed_ms
            assert vb == pytest.approx(va, rel=1e-12), (a, b)
        if a.kind in ("climb", "descend"):
            own = defaults.climb_rate_ms if a.kind == "climb" else defaults.descent_rate_ms
            assert (b.climb_rate_ms or own) == pytest.approx(a.climb_rate_ms or own), (a, b)


def three_sorties(mission):
    n = len(mission.legs)
    cuts = sorted({0.0, n // 3 + 0.37, (2 * n) // 3 + 0.61, float(n)})
    return [sortie_mission(mission, a, b, k)
            for k, (a, b) in enumerate(zip(cuts, cuts[1:]), 1) if b > a]


def test_every_real_mission_split_in_three_flies_as_planned(shared_data, tmp_path):
    """Every real file that is read, cut into three sorties at fractions of legs, written
    in its own format: QGroundControl's loader rules (.plan) and pymavlink's MAVWPLoader
    (.waypoints/.txt) accept each file, and it reads back into the sortie's legs."""
    defaults = {"multirotor": NavDefaults.of(load_aircraft(SOLO)),
                "fixed_wing": NavDefaults.of(load_aircraft(X8))}
    folder = shared_data / "missions_real"
    written = 0
    for o in missions_real.read_all(folder):
        if o.status != missions_real.READ:
            continue
        src = folder / o.name
        nd = defaults[o.vehicle]
        mission = quiet_load(src, nd)
        for sortie in three_sorties(mission):
            path = tmp_path / f"{src.stem}_{sortie.name[-1]}{src.suffix}"
            kind = writers.WRITERS[src.suffix]
            path.write_text(writers.WRITE[kind](sortie, defaults=nd))
            if kind == "plan":
                assert qgc_problems(path) == [], (path.name, qgc_problems(path))
            else:
                loader = mavwp.MAVWPLoader()
                assert loader.load(str(path)) == len(path.read_text().splitlines()) - 1
            flies_as_planned(sortie, quiet_load(path, nd), nd)
            written += 1
    assert written >= 60


def test_qgc_rules_accept_what_qgc_loads_and_refuse_what_it_refuses(shared_data):
    """The test's QGroundControl checker, on the real plans: the four QGroundControl
    refuses (wrong plan version, no mission, a survey of version 9 or without its items,
    JSON with a comment) and none of the others."""
    folder = shared_data / "missions_real"
    refused = {p.name for p in folder.glob("*.plan") if qgc_problems(p)}
    assert refused == {"mavsdk_qgroundcontrol_sample_wrong_overall_version.plan",
                       "mavsdk_qgroundcontrol_sample_without_mission.plan",
                       "mavsdk_qgroundcontrol_sample_with_survey_wrong_version.plan",
                       "mavsdk_qgroundcontrol_sample_with_survey_missing_items.plan",
                       "px4_fw_mission.plan"}


def fence_plan(tmp_path):
    """A PX4 VTOL survey with a geofence, rally points, camera triggering and a VTOL
    landing: the envelope and items a sortie must keep."""
    home = [47.3977, 8.5456, 488.0]
    step = 0.0009
    items = [{"AMSLAltAboveTerrain": None, "Altitude": 40, "AltitudeMode": 1,
              "autoContinue": True, "command": 84, "doJumpId": 1, "frame": 3,
              "params": [0, 90, 0, None, home[0] + 0.0005, home[1], 40], "type": "SimpleItem"},
             {"autoContinue": True, "command": 3000, "doJumpId": 2, "frame": 2,
              "params": [4, 0, 0, 0, 0, 0, 0], "type": "SimpleItem"},
             {"autoContinue": True, "command": 206, "doJumpId": 3, "frame": 2,
              "params": [25, 0, 1, 0, 0, 0, 0], "type": "SimpleItem"}]
    for k in range(12):
        lat = home[0] + step * (1 + k)
        lon = home[1] + (0.004 if k % 2 else 0.0)
        items.append({"AMSLAltAboveTerrain": None, "Altitude": 60, "AltitudeMode": 1,
                      "autoContinue": True, "command": 16, "doJumpId": 4 + k, "frame": 3,
                      "params": [0, 0, 0, None, lat, lon, 60], "type": "SimpleItem"})
    items += [{"autoContinue": True, "command": 206, "doJumpId": 16, "frame": 2,
               "params": [0, 0, 0, 0, 0, 0, 0], "type": "SimpleItem"},
              {"AMSLAltAboveTerrain": None, "Altitude": 0, "AltitudeMode": 1,
               "autoContinue": True, "command": 85, "doJumpId": 17, "frame": 3,
               "params": [0, 0, 30, None, home[0] + 0.0002, home[1], 0],
               "type": "SimpleItem"}]
    fence = {"circles": [{"circle": {"center": [home[0] + 0.005, home[1] + 0.002],
                                     "radius": 80}, "inclusion": False, "version": 1}],
             "polygons": [{"inclusion": True, "polygon": [[47.39, 8.54], [47.42, 8.54],
                                                          [47.42, 8.56], [47.39, 8.56]],
                           "version": 1}], "version": 2}
    rally = {"points": [[47.398, 8.546, 30]], "version": 2}
    plan = {"fileType": "Plan", "geoFence": fence, "groundStation": "QGroundControl",
            "mission": {"cruiseSpeed": 15, "firmwareType": 12, "globalPlanAltitudeMode": 1,
                        "hoverSpeed": 5, "items": items, "plannedHomePosition": home,
                        "vehicleType": 20, "version": 2},
            "rallyPoints": rally, "version": 1}
    path = tmp_path / "vtol_survey.plan"
    path.write_text(json.dumps(plan, indent=4))
    return path, plan


def test_sortie_plans_keep_fence_rally_vehicle_vtol_items_speeds_and_camera(tmp_path):
    """Each sortie .plan keeps the input's geofence and rally points (QGroundControl
    uploads mission, fence and rally in turn: an empty fence would clear the vehicle's),
    firmwareType 12 and vehicleType 20, cruiseSpeed/hoverSpeed as plan fields (no
    DO_CHANGE_SPEED type 1, ArduPlane's minimum ground speed), VTOL take-off and landing
    items as they were (not NAV_TAKEOFF and a LAND at 0, 0), and the camera state
    (the VTOL transition and trigger distance re-issued where a sortie starts, the
    trigger stopped before it turns home). All four used to be lost."""
    src, plan = fence_plan(tmp_path)
    x8 = NavDefaults.of(load_aircraft(X8))
    mission = quiet_load(src, x8)
    for k, sortie in enumerate(three_sorties(mission), 1):
        path = tmp_path / f"s{k}.plan"
        path.write_text(writers.to_plan(sortie, defaults=x8))
        out = json.loads(path.read_text())
        assert qgc_problems(path) == []
        assert out["geoFence"] == plan["geoFence"]
        assert out["rallyPoints"] == plan["rallyPoints"]
        for key in ("firmwareType", "vehicleType", "cruiseSpeed", "hoverSpeed",
                    "globalPlanAltitudeMode"):
            assert out["mission"][key] == plan["mission"][key]
        items = out["mission"]["items"]
        cmds = [it["command"] for it in items]
        assert cmds[0] == 84 and items[0]["params"][1] == 90       # the VTOL take-off
        assert cmds[-1] == 85 and items[-1]["params"][2] == 30     # the VTOL landing
        assert items[-1]["params"][4:6] != [0, 0]
        assert 22 not in cmds and 21 not in cmds
        assert all(it["params"][0] == 0 for it in items if it["command"] == 178)
        assert 3000 in cmds                                          # transition re-issued
        trig = [it["params"][0] for it in items if it["command"] == 206]
        assert trig[0] == 25 and trig[-1] == 0                       # camera on, then off
        first_wp = cmds.index(16) if k == 1 else cmds.index(206)
        assert cmds.index(3000) < first_wp + 2
        flies_as_planned(sortie, quiet_load(path, x8), x8)
    # the whole plan written back is the plan: the same items, fence and rally
    path = tmp_path / "whole.plan"
    path.write_text(writers.to_plan(mission, defaults=x8))
    out = json.loads(path.read_text())
    assert [it["command"] for it in out["mission"]["items"]] == [
        it["command"] for it in plan["mission"]["items"]]


def test_px4_vtol_round_trip_keeps_the_verdict(shared_data, tmp_path):
    """px4_vtol_mission.plan written back and checked with the X8: the same verdict and
    charge (the round trip used to turn GO into NO-GO)."""
    src = shared_data / "missions_real/px4_vtol_mission.plan"
    x8 = NavDefaults.of(load_aircraft(X8))
    mission = quiet_load(src, x8)
    path = tmp_path / "vtol.plan"
    path.write_text(writers.to_plan(mission, defaults=x8))
    from planner.parameters import load_aircraft_and_battery
    aircraft, pack = load_aircraft_and_battery(X8)
    before = MissionChain(aircraft, pack).check(mission)
    after = MissionChain(aircraft, pack).check(quiet_load(path, x8))
    assert after.verdict == before.verdict
    assert after.charge_used_mah == pytest.approx(before.charge_used_mah, rel=1e-9)
    out = json.loads(path.read_text())
    assert out == {**json.loads(src.read_text()), "mission": {
        **json.loads(src.read_text())["mission"], "items": out["mission"]["items"]}}
    assert [it["command"] for it in out["mission"]["items"]] == [84] + [16] * 7 + [85]


def test_select_go_sorties_are_go_in_check_with_a_mission_speed_not_the_aircrafts(
        tmp_path, capsys):
    """A survey flown at DO_CHANGE_SPEED 5 m/s by a Solo whose own speed is 8 m/s, read
    from a .txt file: select splits it, and each sortie file is GO in check (the transit
    home used to be written without its speed, flown at 5 m/s, short of charge)."""
    wp = tmp_path / "survey.txt"
    write_waypoints(wp, n=400)
    lines = wp.read_text().splitlines()
    lines.insert(3, "2\t0\t2\t178\t1\t5\t-1\t0\t0\t0\t0\t1")
    rows = [lines[0]] + [f"{k}\t" + line.split("\t", 1)[1] for k, line in enumerate(lines[1:])]
    wp.write_text("\n".join(rows) + "\n")
    (tmp_path / "one.yaml").write_text(
        f"name: Solo pack\npacks:\n  - file: {REPO / 'aircraft/batteries/solo_5200_4s.yaml'}\n")
    out = tmp_path / "sorties"
    out.mkdir()
    status = main(["select", str(wp), "--aircraft", str(SOLO), "--packs",
                   str(tmp_path / "one.yaml"), "--sorties-out", str(out)])
    text = capsys.readouterr().out
    assert status == 1 and "Swap 1" in text
    written = sorted(out.iterdir())
    assert len(written) >= 2 and all(p.suffix == ".txt" for p in written)
    for path in written:
        assert mavwp.MAVWPLoader().load(str(path)) >= 3
        status = main(["check", str(path), "--aircraft", str(SOLO)])
        report = capsys.readouterr().out
        assert status == 0 and "\nGO" in report, (path.name, report[-400:])
