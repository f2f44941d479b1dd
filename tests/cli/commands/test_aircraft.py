"""``endurance fit-aircraft`` (multirotor) end to end: a fit never writes the impossible.

A parameter that ends on its bound or outside its physical range is a misfit: the
written file says so (``fit_status``), the command exits 1 and names the parameter and
the likely cause (planner.identify.aircraft_fit, module notes "Fit status"). On the
real logs (log 171, the two ArduCopter 3.1.3 flights) the free fit puts
η on 1.0, the drag area on 0 and a constant load of 90–204 W that the aircraft never
draws with its rotors stopped.
"""

from pathlib import Path

import pytest
import yaml
from diagnose_generators import QUAD, power_dataset

from planner.cli.main import main
from planner.parameters import load_aircraft

REPO = Path(__file__).resolve().parents[3]
SOLO = REPO / "aircraft" / "solo_survey.yaml"
LOG171 = "ardupilot_copter_quad_ac33dev_dronekit_log171.bin"
AC313 = ("ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin",
         "ardupilot_copter_ac313_pixhawk_2014-10-18_20-44.bin")


def _quad_file(folder: Path, efficiency: float) -> Path:
    """The test quad of diagnose_generators as an aircraft YAML (η as given)."""
    path = folder / "quad.yaml"
    path.write_text(yaml.safe_dump({
        "name": "test quad", "type": "multirotor", "empty_mass_kg": QUAD["empty_mass_kg"],
        "efficiency": efficiency, "system_power_w": QUAD["system_power_w"],
        "multirotor": {"rotors": QUAD["rotors"], "rotor_diameter_m": QUAD["rotor_diameter_m"],
                       "power_model": "momentum", "figure_of_merit": QUAD["figure_of_merit"],
                       "induced_factor": QUAD["induced_factor"],
                       "drag_area_m2": QUAD["drag_area_m2"]}}))
    return path


def _flights(folder: Path, power_scale: float = 1.0) -> Path:
    df, _ = power_dataset(None, seed=3, n_flights=3, duration_s=600, rate_hz=2)
    for col in ("power_w", "current_a"):
        df[col] = df[col] * power_scale
    path = folder / "flights.csv"
    df.to_csv(path, index=False)
    return path


def _fit_quad(tmp_path, capsys, data, *extra) -> tuple[int, str, Path]:
    """``fit-aircraft`` of the test quad (η 0.6 in its file) on ``data`` at 2.8 kg: its
    exit code, standard output and the file it writes."""
    out = tmp_path / "fitted.yaml"
    rc = main(["fit-aircraft", str(data), "--aircraft", str(_quad_file(tmp_path, 0.6)),
               "--mass", "2.8", "--out", str(out), *extra])
    return rc, capsys.readouterr().out, out


def test_a_good_fit_is_written_with_status_ok(tmp_path, capsys):
    rc, text, out = _fit_quad(tmp_path, capsys, _flights(tmp_path), "--parameters",
                              "efficiency,drag_area_m2")
    assert rc == 0, text
    assert "fit_status: ok" in text
    written = yaml.safe_load(out.read_text())
    assert written["fit_status"] == "ok"
    # η found near the flights' true 0.72 from the file's 0.6 (the flights' physics has
    # a profile power that grows with speed, which the planner's model does not)
    assert load_aircraft(out).efficiency == pytest.approx(QUAD["efficiency"], abs=0.08)


def test_a_constant_load_on_its_bound_is_refit_held_as_diagnose_does(tmp_path, capsys):
    """The same flights with the constant load free: the flights' power wants a negative
    one, the fit ends on 0 W; it is done again with the file's 12 W held, and the status
    names the free fit it replaces (exit 1)."""
    rc, text, out = _fit_quad(tmp_path, capsys, _flights(tmp_path))
    assert rc == 1
    status = yaml.safe_load(out.read_text())["fit_status"]
    assert "the free fit: system_power_w ended on its low bound" in status
    assert load_aircraft(out).system_power_w == pytest.approx(QUAD["system_power_w"])
    assert "free fit, not written" in text


def test_an_efficiency_on_its_bound_is_a_misfit_exit_1_named_in_the_file(tmp_path, capsys):
    """Power logged at half the truth: only an η above 1 would fit; the fit ends on its
    bound and says so instead of writing 1.0 as a value."""
    rc, text, out = _fit_quad(tmp_path, capsys, _flights(tmp_path, power_scale=0.5))
    assert rc == 1
    status = yaml.safe_load(out.read_text())["fit_status"]
    assert status.startswith("misfit:") and "efficiency" in status
    assert "bound" in status or "above any electric motor" in status
    assert f"fit_status: {status}" in text


def test_log171_fit_is_a_misfit_naming_parameters_and_cause(shared_data, tmp_path, capsys):
    """Before: log 171 gave η 1.0000 ± 0.78 and a drag area of 0.0000 with exit 0."""
    out = tmp_path / "solo.yaml"
    rc = main(["fit-aircraft", str(shared_data / "logs" / LOG171), "--aircraft", str(SOLO),
               "--out", str(out)])
    text = capsys.readouterr().out
    assert rc == 1
    status = yaml.safe_load(out.read_text())["fit_status"]
    assert status.startswith("misfit:")
    for name in ("efficiency", "drag_area_m2", "system_power_w"):
        assert name in status
    assert any(c in status for c in ("too little excitation", "one regime only",
                                     "the model's form does not fit"))
    fitted = load_aircraft(out)
    # what is written is not on a bound: η below 0.95, a drag area above zero
    assert 0.2 < fitted.efficiency < 0.95
    assert fitted.multirotor.drag_area_m2 > 1e-3
    assert "free fit, not written" in text


def test_two_logs_are_counted_and_their_constant_load_refused(shared_data, tmp_path, capsys):
    """Before: the two AC 3.1.3 logs gave a 204 W system load and "Fit on 1
    experiment(s)" for two logs."""
    out = tmp_path / "ac313.yaml"
    rc = main(["fit-aircraft", *(str(shared_data / "logs" / n) for n in AC313),
               "--aircraft", str(SOLO), "--out", str(out)])
    text = capsys.readouterr().out
    assert rc == 1
    assert "Fit on 1 of 2 experiment(s)" in text
    status = yaml.safe_load(out.read_text())["fit_status"]
    assert "system_power_w" in status and "lowest airborne power" in status
    assert load_aircraft(out).system_power_w == pytest.approx(
        load_aircraft(SOLO).system_power_w)


def test_data_without_airborne_samples_are_refused_naming_the_files(tmp_path, capsys):
    """Flights that never rise above the airborne height (ground runs, or a record whose
    altitude or time is in the wrong unit) leave nothing to fit: the refusal names the
    data file(s), as every bad-input line does."""
    data = _flights(tmp_path)
    rc = main(["fit-aircraft", str(data), "--aircraft", str(_quad_file(tmp_path, 0.6)),
               "--mass", "2.8", "--out", str(tmp_path / "fitted.yaml"),
               "--airborne-height", "900"])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and err == f"error: {data}: no airborne samples in the data (ground tests only?)"
    assert not (tmp_path / "fitted.yaml").exists()
