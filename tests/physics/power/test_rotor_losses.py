"""The rotor_losses multirotor power model: physics, file, fit on real DJI M100 flights,
``replay --csv``."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

from planner.cli.main import main
from planner.errors import ModelError
from planner.parameters import aircraft_from_mapping, load_aircraft
from planner.physics.power import momentum
from planner.physics.power.rotor_losses import REFERENCE_DENSITY, rotor_losses_components
from planner.identify.stats import cluster_covariance, covariance

REPO = Path(__file__).resolve().parents[3]
M100 = REPO / "aircraft/dji_m100.yaml"
G = 9.80665


def m100_mapping(model="rotor_losses", **multirotor):
    m = yaml.safe_load(M100.read_text())
    m["battery"] = str(REPO / "aircraft/batteries/dji_tb47d.yaml")
    m["multirotor"]["power_model"] = model
    m["multirotor"].update(multirotor)
    return m


def write(tmp_path, mapping, name="a.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(mapping))
    return path


# ---------------------------------------------------------------------------- physics
def test_zero_losses_equal_the_momentum_model_exactly():
    rng = np.random.default_rng(3)
    n = 3000
    v, vc = rng.uniform(0, 20, n), rng.uniform(-12, 6, n)   # includes windmill-brake descents
    m, rho = rng.uniform(0.8, 4.0, n), rng.uniform(0.9, 1.3, n)
    common = dict(airspeed=v, climb_rate=vc, drag_area=0.04, figure_of_merit=0.55)
    ref = momentum.momentum_battery_power(m, rho, 4, 0.33, 0.62, system_power=12.0, **common)
    new = rotor_losses_components(m, rho, 4, 0.33, 0.62, stopped_power=12.0,
                                  min_rotor_speed_ratio=0.5, **common).battery
    np.testing.assert_array_equal(new, ref)
    # the same through the aircraft file: a momentum file and its rotor_losses twin
    mom = aircraft_from_mapping(m100_mapping("momentum"), "m")
    twin = aircraft_from_mapping(m100_mapping(drive_efficiency=mom.efficiency), "t")
    v2, vc2 = np.linspace(0, 15, 40), np.linspace(-1, 4, 40)   # shaft power above the floor
    np.testing.assert_array_equal(twin.battery_power(v2, vc2, 1.19, 2.6),
                                  mom.battery_power(v2, vc2, 1.19, 2.6))


def test_shaft_power_is_floored_at_zero_and_losses_remain():
    c = rotor_losses_components(2.6, 1.19, 4, 0.33, 0.9, climb_rate=np.array([-14.0, -12.0]),
                                airspeed=1.0, stopped_power=5.0, no_load_power=40.0,
                                copper_loss_power=100.0, reference_mass=2.6)
    assert np.all(c.shaft < 0)          # a fast descent: the rotors windmill
    np.testing.assert_allclose(c.battery, 5.0 + (c.no_load + c.copper) / 0.9, rtol=1e-12)
    stopped = rotor_losses_components(2.6, 1.19, 4, 0.33, 0.9, stopped_power=5.0,
                                      no_load_power=40.0, copper_loss_power=100.0,
                                      rotors_turning=False)
    assert stopped.battery == 5.0


def test_motor_losses_scale_with_rotor_speed_and_torque():
    """Drela 2007: no-load loss ∝ Ω, copper loss ∝ Q²; fixed pitch in a hover: Ω ∝ √(T/ρ),
    Q ∝ T."""
    kw = dict(no_load_power=40.0, copper_loss_power=100.0, reference_mass=2.0,
              figure_of_merit=0.6)
    hover = rotor_losses_components(2.0, REFERENCE_DENSITY, 4, 0.33, 0.95, **kw)
    assert hover.no_load == pytest.approx(40.0) and hover.copper == pytest.approx(100.0)
    thin = rotor_losses_components(2.0, REFERENCE_DENSITY / 4, 4, 0.33, 0.95, **kw)
    assert thin.no_load == pytest.approx(80.0) and thin.copper == pytest.approx(100.0)
    heavy = rotor_losses_components(4.0, REFERENCE_DENSITY, 4, 0.33, 0.95, **kw)
    assert heavy.no_load == pytest.approx(40.0 * np.sqrt(2)) and heavy.copper == \
        pytest.approx(400.0)
    # a measured thrust replaces the trim thrust in every thrust-driven term
    pulled = rotor_losses_components(2.0, REFERENCE_DENSITY, 4, 0.33, 0.95,
                                     thrust=2.0 * 2 * G, **kw)
    assert pulled.copper == pytest.approx(400.0)
    assert pulled.induced == pytest.approx(hover.induced * 2**1.5, rel=1e-9)
    with pytest.raises(ModelError, match="no_load_power"):
        rotor_losses_components(2.0, 1.2, 4, 0.33, 0.95, no_load_power=-1.0)


def test_the_copper_loss_follows_the_torque_the_shaft_power_needs_off_the_hover():
    """Drela 2007: Q = P_shaft/Ω. At the thrust of the hover, a slow descent lowers the
    shaft power and with it the torque and the copper loss, and a climb raises them; a
    cruise near the power bucket lowers them though its thrust is higher. The unit evaluation the fit reuses gives the same battery power."""
    from planner.physics.power.rotor_losses import battery_power_from_unit_terms
    kw = {"no_load_power": 40.0, "copper_loss_power": 100.0, "reference_mass": 2.6,
          "figure_of_merit": 0.6, "drag_area": 0.03}
    vc = np.array([-1.5, 0.0, 2.0, 0.0])
    v = np.array([0.0, 0.0, 0.0, 15.0])
    c = rotor_losses_components(2.6, REFERENCE_DENSITY, 4, 0.33, 0.9, airspeed=v,
                                climb_rate=vc, **kw)
    np.testing.assert_allclose(c.torque_ratio * c.rotor_speed_ratio
                               * (c.reference_induced + c.reference_profile),
                               np.maximum(c.shaft, 0.0), rtol=1e-12)
    descent, hover, climb, cruise = c.copper
    assert hover == pytest.approx(100.0)
    assert descent < 0.97 * hover and climb > 1.2 * hover
    # the thrust-only form T/T_ref would give the descent and climb the hover's loss, and
    # the cruise more than the hover's (its thrust also carries the drag), where the
    # cruise needs less shaft power than the hover (the power bucket)
    assert c.thrust[0] == pytest.approx(c.thrust[1]) == pytest.approx(c.thrust[2])
    assert c.thrust[3] > c.thrust[1] and c.shaft[3] < c.shaft[1] and cruise < hover
    unit = rotor_losses_components(2.6, REFERENCE_DENSITY, 4, 0.33, 1.0, airspeed=v,
                                   climb_rate=vc, profile_power_ratio=1.0,
                                   no_load_power=1.0, copper_loss_power=1.0,
                                   reference_mass=2.6, drag_area=0.03)
    r0 = 1.0 / 0.6 - 1.15
    np.testing.assert_allclose(
        battery_power_from_unit_terms(unit, r0, 40.0, 100.0, 0.9, 7.0),
        rotor_losses_components(2.6, REFERENCE_DENSITY, 4, 0.33, 0.9, airspeed=v,
                                climb_rate=vc, stopped_power=7.0, **kw).battery, rtol=1e-12)


def test_cluster_covariance_counts_flights_not_samples():
    """Residuals shared within a flight (a payload, a wind) carry one sample per flight."""
    rng = np.random.default_rng(0)
    groups = np.repeat(np.arange(20), 200)
    x = rng.normal(size=groups.size)
    jac = np.column_stack([np.ones_like(x), x])
    resid = rng.normal(size=20)[groups] + 0.1 * rng.normal(size=groups.size)
    robust = cluster_covariance(jac, resid, groups).stderr[0]
    iid = covariance(jac, resid, autocorrelated=False).stderr[0]
    # the intercept's error is that of a mean of 20 flight effects of sd 1: about 0.22
    assert robust == pytest.approx(1 / np.sqrt(20), rel=0.5)
    assert robust > 5 * iid


# ---------------------------------------------------------------------------- the file
@pytest.mark.parametrize("change, named", [
    ({"drive_efficiency": 0.2}, "multirotor.drive_efficiency must be >= 0.3"),
    ({"no_load_power_w": -5}, "multirotor.no_load_power_w must be >= 0"),
    ({"copper_loss_power_w": "lots"}, "multirotor.copper_loss_power_w must be a number"),
    ({"power_lead_s": 2.0}, "multirotor.power_lead_s must be <= 1"),
    ({"reference_mass_kg": 0}, "multirotor.reference_mass_kg must be > 0"),
    ({"power_model": "momentum", "no_load_power_w": 30},
     "multirotor.no_load_power_w is read only by power_model rotor_losses"),
])
def test_bad_rotor_losses_keys_exit_2_naming_the_key(tmp_path, capsys, change, named):
    path = write(tmp_path, m100_mapping(**change))
    code = main(["check", str(REPO / "missions/survey_route.yaml"), "--aircraft", str(path),
                 "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert named in err and str(path) in err and "Traceback" not in err


def test_efficiency_slope_is_refused_with_rotor_losses(tmp_path, capsys):
    m = m100_mapping()
    m.update(efficiency_slope=0.2, efficiency_reference_power_w=300.0)
    code = main(["check", str(REPO / "missions/survey_route.yaml"), "--aircraft",
                 str(write(tmp_path, m)), "--quiet"])
    assert code == 2 and "efficiency_slope is not used" in capsys.readouterr().err


def test_old_files_keep_their_model_and_outputs():
    ac = load_aircraft(M100)
    assert ac.multirotor.power_model == "momentum"
    assert ac.multirotor.no_load_power_w is None
    assert "no_load_power_w" not in ac.to_mapping()["multirotor"]


# ---------------------------------------------------------------------------- real data
TEST_FLIGHTS = ["268", "269", "270", "271", "272", "276", "277", "278", "279"]


@pytest.fixture(scope="module")
def m100_split(shared_data):
    """Choudhry et al. (ICRA 2021) split of the DJI M100 flights (Rodrigues et al. 2021,
    CC BY 4.0): test flights 268–279 (273 absent), training on every eighth other
    flight to keep the test short."""
    from planner.io.flightdata import load_flight_data
    part2 = shared_data / "energy/m100_flights_part2_flights150-279.csv.gz"
    data, _ = load_flight_data([part2], column_map="dji_m100")
    ids = list(dict.fromkeys(data["experiment"]))
    train = [i for i in ids if i not in TEST_FLIGHTS and not 211 <= int(i) <= 224][::4]
    keep = data["experiment"].isin(train + TEST_FLIGHTS)
    return data[keep].reset_index(drop=True), train


def _mape(aircraft, data):
    """Mean over the test flights of the power MAPE of airborne samples (> 7 m above
    the first sample), Choudhry et al. 2021's metric. [%]"""
    from planner.chain import flightstate
    from planner.chain.mission_chain import MissionChain
    chain, out = MissionChain(aircraft, None), []
    for exp_id in TEST_FLIGHTS:
        exp = data[data["experiment"] == exp_id].reset_index(drop=True)
        state = flightstate.from_record(exp, 300.0)
        pred = chain.power_from_state(state, 2.605)
        h = exp["altitude_m"].to_numpy(float)
        air = (h - h[0] > 7.0) & (state.measured_power_w > 0)
        meas = state.measured_power_w[air]
        out.append(100.0 * np.mean(np.abs(pred[air] - meas) / meas))
    return float(np.mean(out))


def test_m100_rotor_losses_beat_todays_model_below_10_percent(m100_split):
    """Choudhry et al. 2021 split: Liu's analytic model 14.05 %, b-TCN 10.38 % mean
    per-flight MAPE. The rotor-loss model with measured thrust must stay below 10 % and
    beat today's momentum model (fitted on the same samples) by at least 1 point; the
    power drawn with the rotors stopped is measured (2–10 W on the M100's ground), not
    the 130–170 W constant load today's fit absorbs."""
    from planner.identify.aircraft_fit import fit_aircraft
    data, train = m100_split
    kw = dict(mass_kg=2.605, train=train, validate=TEST_FLIGHTS, site_altitude_m=300.0,
              airborne_height_m=7.0)
    with pytest.warns(UserWarning):
        today = fit_aircraft(data, aircraft_from_mapping(m100_mapping("momentum"), "m"), **kw)
        new = fit_aircraft(data, aircraft_from_mapping(m100_mapping(), "r"), **kw)
    mape_today, mape_new = _mape(today["aircraft"], data), _mape(new["aircraft"], data)
    assert mape_new < 10.0
    assert mape_new <= mape_today - 1.0
    assert 0.0 <= new["stopped_power"]["value_w"] < 15.0
    # today's model puts the rotors' losses into a constant load above anything drawn on
    # the ground: a misfit, and the fit written holds the file's load instead
    assert today["free_fit"]["parameters"]["system_power_w"] > 50.0
    assert "system_power_w" in today["fit_status"]
    assert new["lead_s"] in (0.0, 0.15, 0.3)
    # the fit's recombined terms and the aircraft's own power call agree
    assert new["train"]["after"]["rmse_w"] == pytest.approx(
        new["lead_train_rmse_w"][f"{new['lead_s']:g}"], rel=1e-9)
    se = new["stderr"]
    assert all(np.isfinite(se[k]) and se[k] > 0 for k in se)


def test_with_the_torque_copper_loss_every_m100_parameter_is_determined(m100_split):
    """DJI M100 flights (Rodrigues et al. 2021), each at its own payload: with the copper
    loss following the torque P_shaft/Ω the fit of P_nl, P_cu, FM, f and the
    slow-descent inflow weight ends inside every bound, FM a real rotor's (0.5–0.85).
    With the copper loss ∝ T² the same fit put FM on 1/κ and the weight on 2, a misfit,
    at a held-out power RMSE of 56.8 W on the Choudhry et al. 2021 test flights."""
    from planner.identify.aircraft_fit import fit_aircraft
    from planner.io.record import experiment_payloads
    data, train = m100_split
    payload = experiment_payloads(data)
    mass = {e: 2.355 + (p if np.isfinite(p) else 0.0) for e, p in payload.items()}
    assert len(set(mass.values())) >= 3        # the flights carry 0–0.75 kg
    fit = fit_aircraft(data, aircraft_from_mapping(m100_mapping(), "r"), mass_kg=mass,
                       train=train, validate=TEST_FLIGHTS, site_altitude_m=300.0,
                       airborne_height_m=7.0)
    assert fit["fit_status"] == "ok" and fit["at_bound"] == [] and fit["held"] == {}
    p = fit["parameters"]
    assert 0.5 < p["figure_of_merit"] < 0.85
    assert 0.3 < p["descent_inflow_weight"] < 1.9
    assert p["no_load_power_w"] > 3 * fit["stderr"]["no_load_power_w"]
    assert p["copper_loss_power_w"] > 3 * fit["stderr"]["copper_loss_power_w"]
    assert fit["validation"]["after"]["rmse_w"] < 56.0


def test_replay_csv_has_predicted_power_and_charge(tmp_path, shared_data):
    sample = shared_data / "energy/m100_flights_sample.csv"
    m = m100_mapping(no_load_power_w=100.0, copper_loss_power_w=200.0, figure_of_merit=0.7,
                     reference_mass_kg=2.6, power_lead_s=0.15)
    m["system_power_w"] = 3.0
    aircraft = write(tmp_path, m)
    out = tmp_path / "replay.csv"
    code = main(["replay", str(sample), "--map", "dji_m100", "--aircraft", str(aircraft),
                 "--csv", str(out)])
    assert code == 0
    table = pd.read_csv(out)
    raw = pd.read_csv(sample)
    assert len(table) == len(raw)
    for col in ("time_s", "power_w", "specific_force_ms2", "predicted_power_w",
                "predicted_charge_mah", "battery_model_charge_mah", "measured_charge_mah",
                "flight_phase"):
        assert col in table
    from planner.parameters import load_battery
    model = load_battery(REPO / "aircraft/batteries/dji_tb47d.yaml").model
    delta, eps, beta = model.delta, model.epsilon, model.beta
    for exp_id, exp in table.groupby("experiment"):
        t, p = exp["time_s"].to_numpy(), exp["predicted_power_w"].to_numpy()
        ground = exp["flight_phase"].to_numpy() == "ground"
        assert np.allclose(p[ground], 3.0)          # rotors stopped: P_stop only
        rate = np.where(p > 0, 1.0 / (delta * np.where(p > 0, p, 1.0) ** eps), 0.0)
        stress = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t))])
        expected_mah = stress ** (1.0 / beta) / 3.6
        got = exp["predicted_charge_mah"].to_numpy()
        np.testing.assert_allclose(got, expected_mah, rtol=1e-6, atol=1e-6)
        # the measured power drives the other column: they differ where the model errs
        assert not np.allclose(got, exp["battery_model_charge_mah"].to_numpy(), rtol=1e-3)


def test_fit_aircraft_writes_a_rotor_losses_file_check_accepts(tmp_path, shared_data, capsys):
    sample = shared_data / "energy/m100_flights_sample.csv"
    start = write(tmp_path, m100_mapping(), "start.yaml")
    out = tmp_path / "fitted.yaml"
    code = main(["fit-aircraft", str(sample), "--map", "dji_m100", "--aircraft", str(start),
                 "--mass", "2.605", "--site-altitude", "300", "--airborne-height", "7",
                 "--train", "1,3,12,14", "--validate", "4", "--out", str(out)])
    text = capsys.readouterr().out
    # the copper loss follows the torque P_shaft/Ω, the profile power T·v_h: over the
    # speeds of four flights they differ enough to leave the figure of merit off its
    # bound (with a copper loss ∝ T² it ended on 1/κ, profile power 0)
    assert code == 0, text
    assert "rotors stopped" in text and "cluster-robust" in text
    assert "fit_status: ok" in text
    fitted = load_aircraft(out)
    assert yaml.safe_load(out.read_text())["fit_status"] == "ok"
    m = fitted.multirotor
    assert 0.45 < m.figure_of_merit < 0.8
    assert m.power_model == "rotor_losses" and m.reference_mass_kg == pytest.approx(2.605)
    assert m.power_lead_s in (0.0, 0.15, 0.3)
    assert 0.0 <= fitted.system_power_w < 15.0
    code = main(["check", str(REPO / "missions/survey_route.yaml"), "--aircraft", str(out),
                 "--quiet"])
    assert code in (0, 1)


# ---------------------------------------------------------------------------- the fit
def _synthetic_flights(truth, lead_s, n_flights=6, seed=7, negative_no_load_w=0.0):
    """Flights whose power is the rotor_losses model itself at ``truth`` (the state read
    ``lead_s`` after each power sample), 5 Hz, 20 s on the ground with the rotors stopped
    then 160 s airborne with varying speed, climb and specific force, 3 W noise; minus
    ``negative_no_load_w`` × Ω̂ in the air (a term of the wrong sign for the model)."""
    from planner.chain import flightstate
    from planner.chain.mission_chain import MissionChain
    rng = np.random.default_rng(seed)
    ac = aircraft_from_mapping(m100_mapping(**truth["multirotor"], power_lead_s=lead_s),
                               "truth")
    ac = ac.__class__(**{**ac.__dict__, "system_power_w": truth["system_power_w"]})
    frames = []
    for k in range(n_flights):
        t = np.arange(0, 180, 0.2)
        air = t >= 20
        smooth = lambda x: np.convolve(x, np.ones(25) / 25, mode="same")  # noqa: E731
        speed = np.where(air, np.clip(6 + 5 * smooth(rng.normal(0, 3, t.size)), 0, 13), 0)
        climb = np.where(air, smooth(rng.normal(0, 4, t.size)), 0)
        climb[air & (t < 30)] = 2.5
        alt = np.cumsum(climb) * 0.2
        force = np.where(air, 9.81 * (1 + 0.06 * smooth(rng.normal(0, 4, t.size))), 9.81)
        exp = pd.DataFrame({"experiment": f"f{k}", "time_s": t, "altitude_m": alt,
                            "climb_rate_ms": climb, "groundspeed_ms": speed,
                            "specific_force_ms2": force, "power_w": np.full(t.size, 300.0)})
        state = flightstate.from_record(exp, 300.0)
        state.phase = np.where(air, "cruise", "ground").astype(object)
        power = MissionChain(ac, None).power_from_state(state, 2.605)
        speed_ratio = np.sqrt(force / G * REFERENCE_DENSITY / state.air_density)
        power = power - np.where(air, negative_no_load_w * speed_ratio, 0.0)
        exp["power_w"] = power + rng.normal(0, 3.0, t.size)
        frames.append(exp)
    return pd.concat(frames, ignore_index=True)


def test_fit_recovers_the_parameters_the_lead_and_the_stopped_power():
    from planner.identify.aircraft_fit import fit_aircraft
    truth = {"system_power_w": 8.0,
             "multirotor": {"no_load_power_w": 60.0, "copper_loss_power_w": 140.0,
                            "figure_of_merit": 0.55, "drag_area_m2": 0.03,
                            "reference_mass_kg": 2.605}}
    data = _synthetic_flights(truth, lead_s=0.3)
    start = aircraft_from_mapping(m100_mapping(), "start")
    r = fit_aircraft(data, start, mass_kg=2.605, site_altitude_m=300.0,
                     airborne_height_m=3.0, validate=["f5"])
    assert r["lead_s"] == 0.3
    assert r["stopped_power"]["value_w"] == pytest.approx(8.0, abs=0.5)
    assert not r["at_bound"]
    for key, value in r["parameters"].items():
        assert abs(value - truth["multirotor"][key]) < 3 * r["stderr"][key] + 1e-3 * abs(
            truth["multirotor"][key]), key
    assert r["validation"]["after"]["rmse_w"] < 4.0


def test_a_loss_the_data_do_not_have_ends_on_its_bound_and_is_not_a_value(capsys, tmp_path):
    truth = {"system_power_w": 8.0,
             "multirotor": {"no_load_power_w": 0.0, "copper_loss_power_w": 140.0,
                            "figure_of_merit": 0.55, "drag_area_m2": 0.03,
                            "reference_mass_kg": 2.605}}
    csv = tmp_path / "flights.csv"
    _synthetic_flights(truth, lead_s=0.0, negative_no_load_w=40.0).to_csv(csv, index=False)
    start = write(tmp_path, m100_mapping(), "start.yaml")
    code = main(["fit-aircraft", str(csv), "--aircraft", str(start), "--mass", "2.605",
                 "--site-altitude", "300", "--airborne-height", "3", "--out",
                 str(tmp_path / "fitted.yaml")])
    out = capsys.readouterr().out
    assert code == 1            # a parameter on its bound: a misfit, exit 1
    line = next(x for x in out.splitlines() if x.startswith("no_load_power_w"))
    assert "ended on its bound" in line and "misfit of the model's form" in line
