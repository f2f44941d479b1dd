"""The probabilistic verdict (``check --uncertainty``): Monte Carlo through the chain."""

import json
import math
import re
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
from planner.chain.uncertainty import (
    DEFAULT_MODEL_ERROR_SD,
    Spreads,
    cvar,
    monte_carlo,
    shapley_r2,
)

REPO = Path(__file__).resolve().parents[2]
SURVEY = REPO / "missions/survey_quad.yaml"
SOLO = REPO / "aircraft/solo_survey.yaml"
PACK = REPO / "aircraft/batteries/solo_5200_4s.yaml"


def solo(integral_only=True):
    aircraft, pack = load_aircraft_and_battery(SOLO)
    if integral_only:
        pack = replace(pack, circuit=None, thermal=None)
    mission = load_mission(SURVEY, vehicle_type=aircraft.type)
    # flown at 25 °C, the reference of the pack's cold laws: the survey's 14 °C takes the
    # integral-model pack below its reserve
    return aircraft, pack, replace(mission, environment=replace(mission.environment,
                                                                temperature_c=25.0))


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


def test_with_a_vanishing_spread_every_sample_is_the_deterministic_check():
    """The machinery adds nothing of its own: with a power error of 10⁻⁹ and nothing else
    drawn, every sample is the pre-flight check."""
    ac, pack, mission = solo(integral_only=False)   # circuit + thermal pack
    chain = MissionChain(ac, pack)
    check = chain.check(mission)
    u = monte_carlo(chain, mission, spreads=Spreads.only(model_error_sd=1e-9), samples=40,
                    seed=0)
    assert u.weather_draws == 1
    np.testing.assert_allclose(u.landing_samples_mah, check.landing_charge_mah, rtol=1e-6)
    np.testing.assert_allclose(u.rtl_samples_mah, check.rtl_min_margin_mah, rtol=1e-6)
    assert u.p_landing == (1.0 if check.margin_mah >= 0 else 0.0)
    drawn = [s["name"] for s in u.sources if s["share"] is not None]
    assert drawn == ["power model error"]


def test_nothing_drawn_is_refused_not_a_band_of_one_number(capsys):
    ac, pack, mission = solo()
    with pytest.raises(InputError, match="nothing is drawn"):
        monte_carlo(MissionChain(ac, pack), mission, spreads=Spreads.only(), samples=40)
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty",
                   "--wind-sd", "0@0", "--temperature-sd", "0", "--model-error-sd", "0"])
    err = capsys.readouterr().err
    assert status == 2 and "nothing is drawn" in err and "Traceback" not in err
    # gusts of a calm forecast move nothing either
    calm = replace(mission.environment, wind_speed_ms=0.0)
    with pytest.raises(InputError, match="nothing is drawn.*calm"):
        monte_carlo(MissionChain(ac, pack), mission, calm, samples=40,
                    spreads=Spreads.only(gust_factor=1.5))


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
    u = monte_carlo(chain, mission, spreads=Spreads.only(soh=mu, soh_sd=sd), samples=6000,
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
                        spreads=Spreads.only(soh=0.99, soh_sd=0.002, payload_sd_kg=0.08))
    assert heavy.driver == "payload"
    weak = monte_carlo(chain, mission, samples=1500, seed=1,
                       spreads=Spreads.only(soh=0.95, soh_sd=0.04, payload_sd_kg=0.005))
    assert weak.driver == "state of health"
    windy = monte_carlo(chain, mission, samples=1500, seed=1,
                        spreads=Spreads.only(wind_sd_ms=3.0, soh=0.99, soh_sd=0.001))
    assert windy.driver == "wind speed" and windy.weather_draws > 1
    assert windy.r2 > 0.5


def test_more_spread_lowers_the_probability_and_widens_the_band():
    ac, pack, mission = solo()
    chain = MissionChain(ac, pack)
    narrow = monte_carlo(chain, mission, samples=1500, seed=2,
                         spreads=Spreads.only(soh=0.99, soh_sd=0.01))
    wide = monte_carlo(chain, mission, samples=1500, seed=2,
                       spreads=Spreads.only(soh=0.99, soh_sd=0.06))
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
                    spreads=Spreads.only(soh=1.0, soh_sd=0.001))
    src = next(s for s in u.sources if s["name"].startswith("integral model"))
    assert "model.covariance" in src["origin"] and src["share"] > 0.5
    off = monte_carlo(MissionChain(ac, pack), mission, samples=800, seed=0,
                      spreads=Spreads.only(soh=1.0, soh_sd=0.001, model_covariance=False))
    assert np.std(off.landing_samples_mah) < 0.5 * np.std(u.landing_samples_mah)


def test_the_integral_model_s_own_charge_error_scales_each_sample_s_charge(tmp_path):
    """With ``charge_error_sd`` σ alone drawn, each sample draws the check's charge times
    e^(σz): δ is scaled by e^(−βσz), and C = (t / (δ P^ε))^(1/β) ([UAV23] eq. 14). The
    log of the charge ratio then has the spread σ and median 0; the pack file's
    ``model.charge_error_sd`` is drawn by default and named, and a pack without one says
    it is absent."""
    ac, pack, mission = solo()
    nominal = MissionChain(ac, pack).check(mission)
    u = monte_carlo(MissionChain(ac, pack), mission, samples=3000, seed=1,
                    spreads=Spreads.only(charge_error_sd=0.05))
    ratio = np.log(u.charge_samples_mah / nominal.charge_used_mah)
    assert np.std(ratio) == pytest.approx(0.05, rel=0.06)
    assert np.median(ratio) == pytest.approx(0.0, abs=0.004)
    np.testing.assert_allclose(u.energy_samples_wh, nominal.energy_wh, rtol=1e-9)
    assert u.driver == "integral model's charge error"
    raw = yaml.safe_load(PACK.read_text())
    raw.setdefault("model", {"delta": pack.model.delta, "epsilon": pack.model.epsilon,
                             "beta": pack.model.beta})["charge_error_sd"] = 0.04
    path = tmp_path / "pack.yaml"
    path.write_text(yaml.safe_dump(raw))
    own = replace(load_battery(path), circuit=None, thermal=None)
    assert own.model.charge_error_sd == 0.04
    u = monte_carlo(MissionChain(ac, own), mission, samples=400, seed=0,
                    spreads=Spreads(soh=0.99, soh_sd=0.01))
    src = next(s for s in u.sources if s["name"] == "integral model's charge error")
    assert src["spread"] == "±4 %" and "model.charge_error_sd" in src["origin"]
    u = monte_carlo(MissionChain(ac, pack), mission, samples=40, seed=0,
                    spreads=Spreads(soh=0.99, soh_sd=0.01))
    src = next(s for s in u.sources if s["name"] == "integral model's charge error")
    assert src["spread"] == "not drawn" and "absent" in src["origin"]


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


# ------------------------------------------------------- a probability that means what it says

def test_weather_draws_scale_with_the_samples_and_the_resolution_is_stated():
    """The weather is drawn once per 5 samples up to 400 draws (not 16 times whatever the
    samples), and the probability's step is one over those draws."""
    ac, pack, mission = solo()
    chain = MissionChain(ac, pack)
    for n in (400, 1000):
        u = monte_carlo(chain, mission, spreads=Spreads.only(wind_sd_ms=2.0), samples=n,
                        seed=1)
        assert u.weather_draws == n // 5
        assert u.independent_draws == n // 5 and u.p_resolution == pytest.approx(5 / n)
        assert np.unique(u.landing_samples_mah).size >= n // 5
        assert u.to_dict()["p_resolution"] == pytest.approx(5 / n)
    many = monte_carlo(chain, mission, spreads=Spreads.only(wind_sd_ms=2.0), samples=2500,
                       seed=1)
    assert many.weather_draws == 400 and many.p_resolution == pytest.approx(1 / 400)
    own = monte_carlo(chain, mission, spreads=Spreads.only(wind_sd_ms=2.0), samples=400,
                      weather_draws=50, seed=1)
    assert own.weather_draws == 50 and own.p_resolution == pytest.approx(1 / 50)
    # pack inputs alone: one weather run, every sample its own draw
    pack_only = monte_carlo(chain, mission, spreads=Spreads.only(soh=0.97, soh_sd=0.02),
                            samples=300, seed=1)
    assert pack_only.weather_draws == 1 and pack_only.p_resolution == pytest.approx(1 / 300)


def test_the_probability_moves_in_steps_finer_than_a_sixteenth():
    """A reserve at the 30th percentile of a pilot run's landing charge: P near 0.7 (not
    a multiple of 1/16, as 1/2 would be), and with 400 weather draws it takes values a
    16-draw Monte Carlo cannot (k/16)."""
    ac, pack, mission = solo()
    check = MissionChain(ac, pack).check(mission)
    pilot = monte_carlo(MissionChain(ac, pack), mission,
                        spreads=Spreads.only(wind_sd_ms=2.0), samples=2000, seed=99)
    reserve = float(np.percentile(pilot.landing_samples_mah, 30)) / check.capacity_mah
    chain = MissionChain(ac, pack, reserve=reserve)
    values = [monte_carlo(chain, mission, spreads=Spreads.only(wind_sd_ms=2.0), samples=2000,
                          seed=seed).p_landing for seed in range(3)]
    assert all(0.05 < p < 0.95 for p in values)
    assert any(abs(p * 16 - round(p * 16)) > 0.05 for p in values)


def test_cli_states_the_resolution_and_takes_weather_samples(capsys):
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty",
                   "--samples", "400", "--seed", "1"])
    out = capsys.readouterr().out
    assert status in (0, 1) and "P resolution 1/80 = 1.25 %" in out
    assert "Warning   P moves in steps of 1.25 %, more than a tenth of the 5 %" in out
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty",
                   "--samples", "400", "--weather-samples", "100", "--seed", "1"])
    out = capsys.readouterr().out
    assert "100 weather draws" in out and "P resolution 1/100 = 1 %" in out
    # 40 samples: 8 weather draws, a verdict resting on a handful of draws is flagged
    main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty", "--samples", "40"])
    out = capsys.readouterr().out
    assert "P resolution 1/8 = 12.5 %" in out and "Warning   P moves in steps of 12.5 %" in out
    for bad in ("1", "401", "many"):
        status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty",
                       "--samples", "400", "--weather-samples", bad])
        err = capsys.readouterr().err
        assert status == 2 and "--weather-samples" in err and "Traceback" not in err


def test_shapley_shares_decompose_r2_of_independent_inputs():
    """y = 3 x₁ + x₂ + noise, x independent with unit variance: R² = 10/11, shared 9/11 and
    1/11 (for independent inputs the Shapley share is each input's own explained variance)."""
    rng = np.random.default_rng(0)
    x1, x2, e = rng.standard_normal((3, 200_000))
    shares, r2 = shapley_r2([x1, x2], 3 * x1 + x2 + e)
    assert r2 == pytest.approx(10 / 11, abs=0.005)
    assert shares == pytest.approx([9 / 11, 1 / 11], abs=0.005)
    assert shares.sum() == pytest.approx(r2, rel=1e-12)


def test_shapley_shares_stay_between_0_and_r2_for_collinear_inputs():
    """Two nearly equal inputs of opposite effect: a regression's own-term variances blow
    up (the 14633867 % of a gust factor with no wind spread); Shapley shares do not."""
    rng = np.random.default_rng(1)
    x1 = rng.random(5000)
    x2 = x1 * (1 + 1e-7 * rng.standard_normal(5000))
    x3 = rng.standard_normal(5000)
    y = 1e6 * (x1 - x2) + 0.5 * x3 + 0.1 * x1 + 0.05 * rng.standard_normal(5000)
    shares, r2 = shapley_r2([x1, x2, x3], y)
    assert np.all(shares >= 0) and np.all(shares <= r2 + 1e-12)
    assert shares.sum() == pytest.approx(r2, rel=1e-9)
    assert 0 < r2 <= 1


def _printed_shares(text):
    block = text[text.index("spread of the landing charge"):text.index("drives the spread")]
    rows = [re.match(r"    \S.*?\s{2,}(-?\d+\.\d) %  ", line)
            for line in block.splitlines()[1:]]
    shares = [float(m.group(1)) for m in rows if m]
    r2 = float(re.search(r"R² = (\d+\.\d) %", block).group(1))
    return shares, r2


def test_gusts_without_a_wind_spread_get_a_share_between_0_and_100_percent(capsys):
    """Survey in a 5 m/s forecast wind, gust factor 1.5: the gusts are the only thing that
    moves the wind. The mean wind is not drawn (no share), the shares are a decomposition."""
    ac, pack, mission = solo()
    u = monte_carlo(MissionChain(ac, pack), mission, samples=1000, seed=0,
                    spreads=Spreads.only(gust_factor=1.5, soh=0.99, soh_sd=0.01))
    by = {s["name"]: s for s in u.sources}
    assert by["wind speed"]["share"] is None and by["wind speed"]["spread"] == "not drawn"
    assert 0 < by["gusts"]["share"] <= u.r2 <= 1
    shares = [s["share"] for s in u.sources if s["share"] is not None]
    assert all(0 <= x <= 1 for x in shares) and sum(shares) == pytest.approx(u.r2, rel=1e-9)
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty", "--gust",
                   "1.5", "--samples", "500"])
    shares, r2 = _printed_shares(capsys.readouterr().out)
    assert status in (0, 1) and shares and all(0 <= x <= 100 for x in shares)
    assert sum(shares) == pytest.approx(r2, abs=0.05 * len(shares) + 0.05)


def test_without_spreads_the_default_forecast_spreads_are_drawn_and_named(tmp_path, capsys):
    js = tmp_path / "u.json"
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty",
                   "--samples", "400", "--json", str(js)])
    out = capsys.readouterr().out
    data = json.loads(js.read_text())["uncertainty"]
    assert status in (0, 1)
    lm = data["landing_charge_mah"]
    assert lm["p5"] < lm["p50"] < lm["p95"]
    by = {s["name"]: s for s in data["variance_split"]["sources"]}
    for name, value in (("wind speed", "±2.2 m/s"), ("wind direction", "±55°"),
                        ("air temperature", "±2.8 °C"), ("power model error", "±8 %")):
        assert by[name]["spread"] == value and by[name]["share"] is not None
        assert by[name]["origin"].startswith("default")
    assert "meteo.matrunich.com" in by["wind speed"]["origin"]
    assert "default forecast spread: 10 m wind speed RMSE" in out
    assert "has no energy_error_sd" in out
    # a spread given replaces its default; 0 is "not drawn"
    status = main(["check", str(SURVEY), "--aircraft", str(SOLO), "--uncertainty",
                   "--samples", "400", "--wind-sd", "0@0", "--json", str(js)])
    by = {s["name"]: s for s in json.loads(js.read_text())["uncertainty"]["variance_split"]
          ["sources"]}
    assert by["wind speed"]["spread"] == "not drawn" and by["wind speed"]["share"] is None


def test_power_scale_multiplies_the_power_of_its_sample():
    """The pack axis' power_scale multiplies the battery power: the energy scales with it
    exactly, and the circuit model runs each (mass, scale) apart."""
    ac, pack, mission = solo()
    r = MissionChain(ac, [pack] * 3).run(mission, detail=False,
                                         pack_samples={"power_scale": [1.0, 1.1, 0.9]})
    assert r.energy_wh[1] == pytest.approx(1.1 * r.energy_wh[0], rel=1e-12)
    assert r.energy_wh[2] == pytest.approx(0.9 * r.energy_wh[0], rel=1e-12)
    ac, cpack, _ = solo(integral_only=False)
    c = MissionChain(ac, [cpack] * 2).run(mission, detail=False,
                                          pack_samples={"power_scale": [1.0, 1.2]})
    assert c.circuit["min_voltage_v"][1] < c.circuit["min_voltage_v"][0]
    with pytest.raises(InputError, match="power_scale"):
        MissionChain(ac, [pack] * 2).run(mission, pack_samples={"power_scale": [1.0, 0.0]})


def test_the_power_error_spreads_the_landing_charge_by_its_own_sd():
    """Drawn alone, a power error of σ spreads the charge drawn by σ × d(charge)/d(ln P):
    the slope measured by two deterministic runs at P × e^{±0.01}."""
    ac, pack, mission = solo()
    chain = MissionChain(ac, pack)
    r = MissionChain(ac, [pack] * 2).run(mission, detail=False,
                                         pack_samples={"power_scale": np.exp([-0.01, 0.01])})
    slope = (r.charge_used_mah[1] - r.charge_used_mah[0]) / 0.02
    for sigma in (0.03, 0.06):
        u = monte_carlo(chain, mission, spreads=Spreads.only(model_error_sd=sigma),
                        samples=4000, seed=5)
        assert np.std(u.landing_samples_mah) == pytest.approx(slope * sigma, rel=0.06)
        assert u.driver == "power model error"
        # one weather run: the power error still takes a level per 5 samples, not 8 in all
        assert u.weather_draws == 1 and u.independent_draws == 800


def test_the_aircraft_files_energy_error_sd_is_drawn_and_named(tmp_path):
    data = yaml.safe_load(SOLO.read_text())
    data["battery"] = str(PACK)
    data["energy_error_sd"] = 0.03
    path = tmp_path / "fitted.yaml"
    path.write_text(yaml.safe_dump(data))
    ac, pack = load_aircraft_and_battery(path)
    assert ac.energy_error_sd == 0.03 and ac.to_mapping()["energy_error_sd"] == 0.03
    pack = replace(pack, circuit=None, thermal=None)
    mission = load_mission(SURVEY, vehicle_type=ac.type)
    u = monte_carlo(MissionChain(ac, pack), mission, samples=400, seed=0,
                    spreads=Spreads(wind_sd_ms=0, wind_direction_sd_deg=0, temperature_sd_c=0))
    src = next(s for s in u.sources if s["name"] == "power model error")
    assert src["spread"] == "±3 %" and "fitted.yaml: energy_error_sd" in src["origin"]
    assert src["share"] == pytest.approx(u.r2)
    default = monte_carlo(MissionChain(solo()[0], pack), mission, samples=400, seed=0,
                          spreads=Spreads(wind_sd_ms=0, wind_direction_sd_deg=0,
                                          temperature_sd_c=0))
    src = next(s for s in default.sources if s["name"] == "power model error")
    assert src["spread"] == f"±{100 * DEFAULT_MODEL_ERROR_SD:g} %"
    assert src["origin"].startswith("default")
    assert np.std(default.landing_samples_mah) == pytest.approx(
        np.std(u.landing_samples_mah) * DEFAULT_MODEL_ERROR_SD / 0.03, rel=0.15)
