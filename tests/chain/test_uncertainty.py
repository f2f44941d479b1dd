"""The probabilistic verdict (``check --uncertainty``): Monte Carlo through the chain."""

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.stats import norm

from planner.chain.mission_chain import MissionChain
from planner.cli.main import main
from planner.errors import InputError
from planner.chain.failsafe import failsafe_parameters
from planner.io.mission import load_mission
from planner.parameters import load_aircraft_and_battery, load_battery
from planner.chain.uncertainty import Spreads, cvar, monte_carlo

REPO = Path(__file__).resolve().parents[2]
SURVEY = REPO / "missions/survey_quad.yaml"
SOLO = REPO / "aircraft/solo_survey.yaml"
PACK = REPO / "aircraft/batteries/solo_5200_4s.yaml"


def solo(integral_only=True):
    aircraft, pack = load_aircraft_and_battery(SOLO)
    if integral_only:
        pack = replace(pack, circuit=None, thermal=None)
    return aircraft, pack, load_mission(SURVEY, vehicle_type=aircraft.type)


def test_same_seed_same_answer_other_seed_other_draws():
    ac, pack, mission = solo()
    sp = Spreads(wind_sd_ms=2.0, wind_direction_sd_deg=20.0, soh=0.97, soh_sd=0.03,
                 payload_sd_kg=0.05)
    a = monte_carlo(MissionChain(ac, pack), mission, spreads=sp, samples=300, seed=7)
    b = monte_carlo(MissionChain(ac, pack), mission, spreads=sp, samples=300, seed=7)
    c = monte_carlo(MissionChain(ac, pack), mission, spreads=sp, samples=300, seed=8)
    np.testing.assert_array_equal(a.landing_samples_mah, b.landing_samples_mah)
    assert a.to_dict() == b.to_dict()
    assert not np.array_equal(a.landing_samples_mah, c.landing_samples_mah)


def test_without_spread_every_sample_is_the_deterministic_check():
    ac, pack, mission = solo(integral_only=False)   # circuit + thermal pack
    chain = MissionChain(ac, pack)
    check = chain.check(mission)
    u = monte_carlo(chain, mission, spreads=Spreads(), samples=40, seed=0)
    assert u.weather_draws == 1
    np.testing.assert_allclose(u.landing_samples_mah, check.landing_charge_mah, rtol=1e-9)
    np.testing.assert_allclose(u.rtl_samples_mah, check.rtl_min_margin_mah, rtol=1e-9)
    assert u.p_landing == (1.0 if check.margin_mah >= 0 else 0.0)
    assert all(s["share"] is None for s in u.sources)


def test_state_of_health_alone_gives_the_normal_distribution_of_the_landing_charge():
    """With the integral model the SoH only scales the usable charge U, so the landing
    charge is U·SoH − used: normal with mean U·μ − used and standard deviation U·σ. The
    Monte Carlo must reproduce P(≥ reserve) = Φ((U μ − used − reserve)/(U σ)), the 5th
    percentile μ_L − 1.645 σ_L and the CVaR of a normal tail, μ_L − σ_L φ(1.645)/0.05
    (= μ_L − 2.063 σ_L)."""
    ac, pack, mission = solo()
    chain = MissionChain(ac, pack)
    nominal = chain.check(mission)
    mu, sd = 0.97, 0.04
    u = monte_carlo(chain, mission, spreads=Spreads(soh=mu, soh_sd=sd), samples=6000,
                    seed=3)
    usable, used, reserve = nominal.usable_mah, nominal.charge_used_mah, nominal.reserve_mah
    m_l, s_l = usable * mu - used, usable * sd
    p = norm.cdf((m_l - reserve) / s_l)
    assert abs(u.p_landing - p) < 4 * math.sqrt(p * (1 - p) / 6000) + 0.005
    assert u.landing_mah["p5"] == pytest.approx(m_l - 1.6449 * s_l, abs=0.06 * s_l)
    assert u.landing_mah["p50"] == pytest.approx(m_l, abs=0.05 * s_l)
    assert u.cvar5_landing_mah == pytest.approx(m_l - s_l * norm.pdf(1.6449) / 0.05,
                                                abs=0.08 * s_l)
    assert u.driver == "state of health"
    assert next(s for s in u.sources if s["name"] == "state of health")["share"] > 0.99


def test_cvar_is_the_mean_of_the_worst_five_percent():
    values = np.arange(100.0)
    assert cvar(values) == pytest.approx(np.mean(values[:5]))
    assert cvar(values, 0.1) == pytest.approx(4.5)


def test_the_variance_split_names_the_input_that_drives_the_spread():
    ac, pack, mission = solo()
    chain = MissionChain(ac, pack)
    heavy = monte_carlo(chain, mission, samples=1500, seed=1,
                        spreads=Spreads(soh=0.99, soh_sd=0.002, payload_sd_kg=0.08))
    assert heavy.driver == "payload"
    weak = monte_carlo(chain, mission, samples=1500, seed=1,
                       spreads=Spreads(soh=0.95, soh_sd=0.04, payload_sd_kg=0.005))
    assert weak.driver == "state of health"
    windy = monte_carlo(chain, mission, samples=1500, seed=1,
                        spreads=Spreads(wind_sd_ms=3.0, soh=0.99, soh_sd=0.001))
    assert windy.driver == "wind speed" and windy.weather_draws > 1
    assert windy.r2 > 0.5


def test_more_spread_lowers_the_probability_and_widens_the_band():
    ac, pack, mission = solo()
    chain = MissionChain(ac, pack)
    narrow = monte_carlo(chain, mission, samples=1500, seed=2,
                         spreads=Spreads(soh=0.99, soh_sd=0.01))
    wide = monte_carlo(chain, mission, samples=1500, seed=2,
                       spreads=Spreads(soh=0.99, soh_sd=0.06))
    assert (wide.landing_mah["p95"] - wide.landing_mah["p5"]
            > 3 * (narrow.landing_mah["p95"] - narrow.landing_mah["p5"]))
    assert wide.p_landing < narrow.p_landing


def test_return_home_points_of_the_subset_agree_with_every_point():
    """The Monte Carlo checks the return home at the nominal run's tightest points: for
    packs around the nominal the smallest margin over the subset equals the one over
    every point."""
    ac, pack, mission = solo()
    packs = [replace(pack, usable_fraction=f) for f in (0.85, 0.9, 0.95, 1.0)]
    chain = MissionChain(ac, packs)
    full = chain.run(mission, detail=True)
    margin = full.detail["rtl_point_margin_mah"][2]
    n = margin.size
    sub = np.union1d(np.argsort(margin)[:48], [n - 1])
    part = chain.run(mission, detail=False, rtl_subset=sub)
    np.testing.assert_allclose(part.rtl_min_margin_mah, full.rtl_min_margin_mah, rtol=1e-9)
    np.testing.assert_allclose(part.detail["rtl_point_charge_mah"],
                               full.detail["rtl_point_charge_mah"][:, sub], rtol=1e-9)
    with pytest.raises(ValueError, match="rtl_subset"):
        chain.run(mission, detail=False, rtl_subset=sub[:-1])


def test_failsafe_from_the_monte_carlo_is_at_least_the_forecast_one():
    ac, pack, mission = solo()
    chain = MissionChain(ac, pack)
    u = monte_carlo(chain, mission, samples=600, seed=0,
                    spreads=Spreads(wind_sd_ms=3.0, wind_direction_sd_deg=30.0))
    forecast = failsafe_parameters(u.nominal, "ardupilot")
    p95 = failsafe_parameters(u.nominal, "ardupilot", return_charge_mah=u.rtl_charge_p95_mah)
    assert p95.return_charge_mah > forecast.return_charge_mah
    assert p95.value("BATT_LOW_MAH") >= forecast.value("BATT_LOW_MAH")


def _pack_with_covariance(tmp_path, cov):
    data = yaml.safe_load(PACK.read_text())
    data.pop("circuit"), data.pop("thermal")
    data["model"] = {"delta": 20.0, "epsilon": -1.02, "beta": 0.9648, "covariance": cov}
    path = tmp_path / "pack.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_model_covariance_is_drawn_and_drives_the_spread(tmp_path):
    cov = [[0.25, 0.0, 0.0], [0.0, 1e-4, 0.0], [0.0, 0.0, 1e-6]]
    pack = load_battery(_pack_with_covariance(tmp_path, cov))
    ac, _, mission = solo()
    u = monte_carlo(MissionChain(ac, pack), mission, samples=800, seed=0,
                    spreads=Spreads(soh=1.0, soh_sd=0.001))
    src = next(s for s in u.sources if s["name"].startswith("integral model"))
    assert "model.covariance" in src["origin"] and src["share"] > 0.5
    off = monte_carlo(MissionChain(ac, pack), mission, samples=800, seed=0,
                      spreads=Spreads(soh=1.0, soh_sd=0.001, model_covariance=False))
    assert np.std(off.landing_samples_mah) < 0.5 * np.std(u.landing_samples_mah)


def test_absent_covariances_are_stated():
    ac, pack, mission = solo()
    u = monte_carlo(MissionChain(ac, pack), mission, samples=40, seed=0,
                    spreads=Spreads(soh=0.99, soh_sd=0.01))
    origins = {s["name"]: s["origin"] for s in u.sources}
    assert "absent" in origins["integral model δ, ε, β"]
    assert "absent" in origins["aircraft parameters"]


def test_non_psd_covariance_is_refused_naming_file_and_key(tmp_path, capsys):
    path = _pack_with_covariance(tmp_path, [[1.0, 2.0, 0.0], [2.0, 1.0, 0.0],
                                            [0.0, 0.0, 1e-6]])
    with pytest.raises(InputError, match=r"pack\.yaml.*model\.covariance.*positive "
                                         r"semi-definite"):
        load_battery(path)
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--battery", str(path),
                   "--uncertainty"])
    err = capsys.readouterr().err
    assert status == 2 and "model.covariance" in err and "Traceback" not in err


def test_a_spread_that_allows_a_negative_capacity_is_refused(tmp_path, capsys):
    path = _pack_with_covariance(tmp_path, [[36.0, 0.0, 0.0], [0.0, 1e-4, 0.0],
                                            [0.0, 0.0, 1e-6]])   # δ = 20 ± 6: ≤ 0 at 3.3 σ
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--battery", str(path),
                   "--uncertainty"])
    err = capsys.readouterr().err
    assert status == 2 and "pack.yaml: model.covariance" in err and "delta" in err
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty",
                   "--soh", "0.5±0.2"])
    err = capsys.readouterr().err
    assert status == 2 and "--soh" in err and "capacity" in err


@pytest.mark.parametrize("flag, value, message", [
    ("--wind-sd", "2", "--wind-sd: expected SPEED@DEG"),
    ("--gust", "0.5", "--gust"),
    ("--soh", "high", "--soh: expected F±SD"),
    ("--samples", "5", "--samples"),
    ("--confidence", "100", "--confidence"),
])
def test_bad_uncertainty_flags_exit_2(flag, value, message, capsys):
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty", flag,
                   value])
    err = capsys.readouterr().err
    assert status == 2 and message in err and "Traceback" not in err


def test_cli_uncertainty_text_json_and_exit_status(tmp_path, capsys):
    js = tmp_path / "u.json"
    png = tmp_path / "band.png"
    argv = ["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty", "--samples",
            "400", "--seed", "4", "--soh", "0.99+-0.01", "--wind-sd", "1@10",
            "--plot", str(png), "--json", str(js)]
    status = main(argv)
    text = capsys.readouterr().out
    data = json.loads(js.read_text())["uncertainty"]
    assert status == (0 if data["verdict"] == "GO" else 1)
    assert data["p_landing_with_reserve"] >= 0.95 if status == 0 else \
        data["p_landing_with_reserve"] < 0.95
    for key in ("p5", "p50", "p95"):
        assert key in data["landing_charge_mah"] and key in data["return_home_margin_mah"]
    assert data["variance_split"]["driver"]
    assert "P(landing with the reserve)" in text and "CVaR5" in text
    assert png.stat().st_size > 10_000
    # a lower confidence can only turn NO-GO into GO
    status_low = main(argv[:-2] + ["--confidence", "0.01"])
    capsys.readouterr()
    assert status_low == 0 or data["p_landing_with_reserve"] < 0.01


def test_the_circuit_model_runs_once_per_mass_and_gives_each_sample_its_own():
    """Samples sharing the pack file and the take-off mass share one circuit simulation;
    every sample's figures equal those of its own one-pack run."""
    ac, pack, mission = solo(integral_only=False)
    payloads = np.array([0.2, 0.5, 0.2, 0.5, 0.35])
    soh = np.array([1.0, 1.0, 0.9, 0.95, 1.0])
    many = MissionChain(ac, [pack] * 5).run(mission, payload_kg=payloads, detail=False,
                                            pack_samples={"soh": soh})
    for i in range(5):
        one = MissionChain(ac, pack).run(mission, payload_kg=payloads[i], detail=False,
                                         pack_samples={"soh": soh[i]})
        for name in ("usable_mah", "charge_used_mah", "margin_mah", "rtl_min_margin_mah"):
            assert getattr(many, name)[i] == pytest.approx(getattr(one, name)[0], rel=1e-9)
        for name in ("min_voltage_v", "cutoff_time_s", "max_temperature_c"):
            assert many.circuit[name][i] == pytest.approx(one.circuit[name][0], rel=1e-9,
                                                          nan_ok=True)
    # the state of health scales the charge to the cut-off too
    assert many.usable_mah[2] == pytest.approx(0.9 * many.usable_mah[0], rel=1e-9)
