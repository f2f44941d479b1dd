"""``check --map/--kml`` and ``select --map``: the route drawn and written as KML, on every
shipped mission and on a real survey plan."""

import json
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from planner.chain.mission_chain import MissionChain
from planner.cli.main import main
from planner.cli.plots import route_map
from planner.io.mission import NavDefaults, load_mission
from planner.parameters import load_aircraft_and_battery
from planner.physics.geo import latlon_to_aeqd

REPO = Path(__file__).resolve().parents[3]
SOLO = REPO / "aircraft/solo_survey.yaml"
X8 = REPO / "aircraft/x8_mapper.yaml"
QUAD7 = REPO / "aircraft/quad_7in.yaml"
KML = "{http://www.opengis.net/kml/2.2}"
MISSIONS = sorted(p.name for p in (REPO / "missions").iterdir()
                  if p.suffix in (".yaml", ".plan", ".waypoints"))


def aircraft_for(name):
    return X8 if "plane" in name else SOLO


def check_outputs(mission, aircraft, tmp_path):
    png, kml, js = tmp_path / "route.png", tmp_path / "route.kml", tmp_path / "r.json"
    status = main(["check", str(mission), "--aircraft", str(aircraft), "--quiet",
                   "--map", str(png), "--kml", str(kml), "--json", str(js)])
    assert status in (0, 1)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    return json.loads(js.read_text()), ET.parse(kml).getroot()


def assert_kml_matches(data, root):
    """One LineString per leg, from the leg's start to its end, at the JSON's latitude,
    longitude and altitude; home and the landing as points."""
    lines = root.findall(f".//{KML}LineString/{KML}coordinates")
    assert len(lines) == len(data["legs"])
    for leg, c in zip(data["legs"], lines):
        (lon0, lat0, a0), (lon1, lat1, a1) = (map(float, p.split(","))
                                              for p in c.text.split())
        assert (lat0, lon0) == pytest.approx((leg["start_lat_deg"], leg["start_lon_deg"]),
                                             abs=1e-6)
        assert (lat1, lon1) == pytest.approx((leg["end_lat_deg"], leg["end_lon_deg"]),
                                             abs=1e-6)
        assert a1 == pytest.approx(leg["end_alt_amsl_m"], abs=0.06)
    names = [n.text for n in root.iter(f"{KML}name")]
    assert "home" in names and "landing" in names


@pytest.mark.parametrize("name", MISSIONS)
def test_map_and_kml_render_on_every_shipped_mission(name, tmp_path):
    data, root = check_outputs(REPO / "missions" / name, aircraft_for(name), tmp_path)
    assert_kml_matches(data, root)
    legs = data["legs"]
    # the legs join up: each starts where the one before ended, the first at home
    assert (legs[0]["start_east_m"], legs[0]["start_north_m"]) == pytest.approx((0, 0),
                                                                                 abs=1e-6)
    for a, b in zip(legs, legs[1:]):
        assert (b["start_east_m"], b["start_north_m"], b["start_alt_m"]) == pytest.approx(
            (a["end_east_m"], a["end_north_m"], a["end_alt_m"]), abs=1e-3)


def test_leg_latitude_longitude_are_the_waypoints_of_the_file(tmp_path):
    """The per-leg latitudes and longitudes land on the .waypoints file's own waypoints
    (MAV_CMD_NAV_WAYPOINT = 16, columns 9 and 10 of QGC WPL 110)."""
    path = REPO / "missions/survey_route.waypoints"
    rows = [line.split("\t") for line in path.read_text().splitlines()[2:]]
    wps = np.array([(float(r[8]), float(r[9])) for r in rows if r[3] == "16"])
    data, _ = check_outputs(path, SOLO, tmp_path)
    ends = np.array([(leg["end_lat_deg"], leg["end_lon_deg"]) for leg in data["legs"]
                     if leg["kind"] == "cruise"])
    for lat, lon in wps:
        assert np.min(np.hypot(ends[:, 0] - lat, ends[:, 1] - lon)) < 2e-6
    # and back to the legs' frame: the same metres east and north of home
    home = [float(x) for x in path.read_text().splitlines()[1].split("\t")[8:10]]
    e, n = latlon_to_aeqd(np.array([leg["end_lat_deg"] for leg in data["legs"]]),
                          np.array([leg["end_lon_deg"] for leg in data["legs"]]), *home)
    assert np.allclose(e, [leg["end_east_m"] for leg in data["legs"]], atol=0.1)
    assert np.allclose(n, [leg["end_north_m"] for leg in data["legs"]], atol=0.1)


def test_map_and_kml_render_on_a_real_survey_plan(shared_data, tmp_path):
    """A QGroundControl survey (TransectStyleComplexItem) from the shared mission files."""
    plan = shared_data / "missions_real" / "mavsdk_qgroundcontrol_sample_with_survey.plan"
    data, root = check_outputs(plan, SOLO, tmp_path)
    assert len(data["legs"]) > 5
    assert_kml_matches(data, root)


def result_of(mission_path, aircraft_path):
    aircraft, pack = load_aircraft_and_battery(aircraft_path, None)
    mission = load_mission(mission_path, defaults=NavDefaults.of(aircraft))
    chain = MissionChain(aircraft, pack)
    return chain.run(mission, mission.environment, detail=True).mission_result(0)


def test_map_colours_the_route_by_the_charge_left_and_marks_the_points():
    """NO-GO survey on a small pack: the colours are the charge left (100 % at take-off,
    the landing's at the end), the point of no return and the worst return home are
    drawn where the check puts them, and the wind arrow points where the wind blows."""
    r = result_of(REPO / "missions/survey_quad.yaml", QUAD7)
    assert r.point_of_no_return is not None and r.worst_return is not None
    fig = route_map.route_map(r)
    ax = fig.axes[0]
    from matplotlib.collections import LineCollection
    (lc,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    values = lc.get_array()
    assert values[0] == pytest.approx(100.0, abs=1.0)
    assert values[-1] == pytest.approx(max(100 * r.remaining_fraction, 0.0), abs=1.0)
    marks = {line.get_label(): line.get_xydata()[0] for line in ax.get_lines()}
    pnr = next(v for k, v in marks.items() if k.startswith("point of no return"))
    assert pnr == pytest.approx([r.point_of_no_return["east_m"],
                                 r.point_of_no_return["north_m"]])
    worst = next(v for k, v in marks.items() if k.startswith("worst return home"))
    assert worst == pytest.approx([r.worst_return["east_m"], r.worst_return["north_m"]])
    assert "usable charge runs out" in " ".join(marks)
    # wind 5 m/s from 250°: the arrow points to 70° (east-north-east)
    wind_ax = fig.axes[1]
    (arrow,) = [t for t in wind_ax.texts if getattr(t, "arrow_patch", None) is not None]
    (x0, y0), (x1, y1) = arrow.xyann, arrow.xy
    assert np.degrees(np.arctan2(x1 - x0, y1 - y0)) % 360 == pytest.approx(70.0, abs=0.5)


def test_worst_return_is_the_smallest_return_home_margin():
    r = result_of(REPO / "missions/survey_quad.yaml", SOLO)
    assert r.worst_return["rtl_margin_mah"] == pytest.approx(r.rtl_min_margin_mah, abs=0.5)


@pytest.mark.parametrize("span, bar", [(680, 100), (90, 10), (2600, 500), (12000, 2000)])
def test_scale_bar_is_a_round_length_of_about_a_fifth(span, bar):
    assert route_map.nice_length(span) == bar


def test_kml_of_a_mission_without_home_is_refused_before_any_work(tmp_path, capsys):
    mission = tmp_path / "m.yaml"
    mission.write_text("name: no home\nlegs:\n  - climb: {altitude_m: 30, rate_ms: 2}\n"
                       "  - hover: {duration_s: 30}\n  - descend: {altitude_m: 0, rate_ms: 1}\n")
    status = main(["check", str(mission), "--aircraft", str(SOLO), "--kml",
                   str(tmp_path / "m.kml"), "--map", str(tmp_path / "m.png")])
    err = capsys.readouterr().err
    assert status == 2 and "--kml" in err and "home" in err
    assert not (tmp_path / "m.kml").exists() and not (tmp_path / "m.png").exists()
    # the map needs no home: it is drawn in metres around the take-off point
    assert main(["check", str(mission), "--aircraft", str(SOLO), "--quiet", "--map",
                 str(tmp_path / "m.png")]) == 0
    assert (tmp_path / "m.png").stat().st_size > 0
