"""``endurance fleet`` on a generated fleet with known pack fade, on a 2-worker Dask cluster.

The fleet (:mod:`testkit.fleet`): 216 flights of three aircraft (3DR Solo, 7-inch quad,
Skywalker X8; each flown as a *true* airframe that differs from its file) on twelve packs
that age at known rates, written in turn as ``.bin``, ``.tlog`` and ``.ulg`` under shuffled
file names. The simulation is the planner's own models: these tests check that ``fleet``
recovers what was put in, not that the models are right.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from planner.io import files
from planner.cli.main import main
from planner.errors import InputError
from planner.parameters import load_aircraft, load_aircraft_and_battery, load_battery

REPO = Path(__file__).resolve().parents[2]
AIRCRAFT = REPO / "aircraft/solo_survey.yaml"
FLIGHTS_PER_PACK = 18

dask_distributed = pytest.importorskip("dask.distributed",
                                       reason="dask[distributed] is a dependency of fleet")
pytest.importorskip("pyarrow", reason="pyarrow is a dependency of fleet")


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """The generated fleet: logs, the --packs CSV and the truth."""
    from testkit.fleet import generate_fleet

    return generate_fleet(tmp_path_factory.mktemp("fleet"), flights_per_pack=FLIGHTS_PER_PACK)


@pytest.fixture(scope="module")
def fleet_dir(fleet):
    return fleet.logs.parent


@pytest.fixture(scope="module")
def client():
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def _models():
    from testkit.fleet import aircraft_files

    craft, packs = {}, {}
    for key, path in aircraft_files().items():
        craft[key], packs[key] = load_aircraft_and_battery(path)
    return craft, packs


def _run(paths, out, client, **kw):
    from planner.fleet import read_pack_map, run_fleet

    files.reset({"--out": str(out)}, folders=("--out",))
    craft, packs = _models()
    from planner.cli.plots.fleet import write_figures

    kw.setdefault("progress", False)
    kw.setdefault("figures", write_figures)
    return run_fleet(paths, out_dir=out, aircraft=craft, pack=packs,
                     pack_map=read_pack_map(kw.pop("packs"), craft) if "packs" in kw else None,
                     client=client, **kw)


@pytest.fixture(scope="module")
def damaged(fleet_dir):
    """Two damaged logs beside the good ones: bytes that are no log, a truncated ULog."""
    bad = fleet_dir / "bad"
    bad.mkdir()
    (bad / "noise.ulg").write_bytes(np.random.default_rng(1).bytes(5000))
    good = sorted((fleet_dir / "logs").glob("*.ulg"))[0].read_bytes()
    (bad / "cut.ulg").write_bytes(good[:200])
    return bad


@pytest.fixture(scope="module")
def first(fleet_dir, damaged, client, tmp_path_factory):
    out = tmp_path_factory.mktemp("out") / "fleet"
    return out, _run([fleet_dir / "logs", damaged], out, client,
                     packs=fleet_dir / "packs.csv")


def _truth(fleet, table):
    """The table's ok rows joined with the generator's truth by file name."""
    ok = table[table["status"] == "ok"].copy()
    ok["file"] = ok["log"].map(lambda p: Path(p).name)
    return ok.merge(fleet.truth, left_on="file", right_on="log", suffixes=("", "_true"))


def test_the_fleet_is_at_least_200_flights_of_3_aircraft_and_12_packs(fleet):
    t = fleet.truth
    assert len(t) >= 200
    assert t["aircraft"].nunique() == 3 and t["pack"].nunique() == 12
    assert set(t["format"]) == {"bin", "tlog", "ulg"}


def test_fitted_fade_within_two_standard_errors_of_the_injected(first, fleet):
    """Each pack's fitted fade against the injected one, in its own standard errors.

    A two-standard-error interval covers the truth with a probability of about 95 % (the
    coverage itself is checked on 400 synthetic packs in
    ``test_fade_fit_recovers_a_known_rate_with_an_honest_error``): of twelve packs, one or
    two outside it is what honest errors give (P = 12 % for two or more). So: every pack
    within three standard errors, and at least ten of the twelve within two.
    """
    from testkit.fleet import PACKS

    _, res = first
    health = {h.pack_id: h for h in res.health}
    assert set(health) == {p.name for p in PACKS}
    z = []
    for p in PACKS:
        h = health[p.name]
        assert h.flights == FLIGHTS_PER_PACK
        assert h.aircraft == p.aircraft
        assert 0 < h.fade_per_cycle_se < 0.002, (p, h)
        z.append(abs(h.fade_per_cycle - p.fade_per_cycle) / h.fade_per_cycle_se)
        assert z[-1] <= 3, (p, h)
        if p.cycles_in_csv or p.serial is not None:
            assert h.last_cycle == p.first_cycle + FLIGHTS_PER_PACK - 1
        else:                                   # ordered by start time: cycles 0, 1, …
            assert h.last_cycle == FLIGHTS_PER_PACK - 1
        # the packs that reach 80 % within 50 flights, and only those, are flagged
        assert h.retires_within(50) == p.retires_within(50, FLIGHTS_PER_PACK), (p, h)
        last = p.first_cycle + FLIGHTS_PER_PACK - 1
        assert h.soh == pytest.approx(1 / (1 + p.fade_per_cycle * last),
                                      abs=3 * h.soh_se + 1e-3)
    assert sum(h.retires_within(50) for h in res.health) == 4
    assert sum(v <= 2 for v in z) >= 10, z


def test_damaged_logs_are_rows_with_their_reason_and_the_rest_is_kept(first):
    _, res = first
    t = res.table
    failed = t[t["status"] == "failed"]
    assert sorted(Path(p).name for p in failed["log"]) == ["cut.ulg", "noise.ulg"]
    assert failed["error"].str.contains(r"\.ulg").all()
    assert failed["error"].map(lambda e: "\n" not in e).all()
    assert (t["status"] == "ok").sum() == 12 * FLIGHTS_PER_PACK
    assert len(res.failed) == 2


def test_parquet_schema_and_rows(first, fleet):
    import pyarrow.parquet as pq

    from planner.fleet.summary import COLUMNS

    out, res = first
    schema = pq.read_schema(out / "flights.parquet")
    assert schema.names == list(COLUMNS)
    for name in ("duration_s", "energy_wh", "charge_mah", "delta_scale", "delta_scale_se"):
        assert str(schema.field(name).type) == "double", name
    assert str(schema.field("start_time_utc").type).startswith("timestamp")
    t = pd.read_parquet(out / "flights.parquet")
    ok = _truth(fleet, t)
    assert len(ok) == len(fleet.truth)
    assert ok["sha256"].str.fullmatch(r"[0-9a-f]{64}").all()
    assert ok["sha256"].is_unique
    assert (ok["format"].map({"dataflash": "bin", "tlog": "tlog", "ulog": "ulg"})
            == ok["format_true"]).all()
    # each flight's aircraft: the --packs CSV for the two multirotors, the log's vehicle
    # type (fixed wing) for the X8's flights, which the CSV leaves out
    assert (ok["aircraft"] == ok["aircraft_true"]).all()
    # the logged charge is the simulated charge: the measured charge over the prediction
    # of the new pack is the injected factor times the new pack's own ratio (one per
    # aircraft's pack type: the integral model against the simulated circuit)
    ratio = ok["delta_scale"] / ok["scale"]
    per_type = ratio / ratio.groupby(ok["aircraft_true"]).transform("median")
    assert per_type.sub(1).abs().max() < 0.03
    assert ratio.groupby(ok["aircraft_true"]).median().between(0.95, 1.10).all()
    smart = ok[ok["pack"] == "4242"]
    assert (smart["pack_id"] == "4242").all()
    assert (smart["pack_id_source"] == "log battery serial").all()
    assert (ok.loc[ok["pack"] != "4242", "pack_id"] == ok.loc[ok["pack"] != "4242", "pack"]).all()
    assert (ok.loc[ok["pack"] != "4242", "pack_id_source"] == "packs CSV").all()
    # a smart battery's ULog carries its cycle count
    ulg = smart[smart["format"] == "ulog"]
    assert len(ulg) and (ulg["cycle"] == ulg["cycle_true"]).all()
    # all three are 4S packs: energy / charge is the pack's voltage
    v = 1000 * ok["energy_wh"] / ok["charge_mah"]
    assert v.between(12.0, 17.0).all()
    assert ok["resistance_steps"].ge(0).all()
    # start times in every format: the tlog's receive time, the DataFlash GPS week and
    # time, the ULog's vehicle_gps_position.time_utc_usec
    start = pd.to_datetime(ok["start_unix"], unit="s", utc=True)
    assert (ok["start_time_utc"] - start).abs().max() < pd.Timedelta(seconds=1)


def test_pack_files_are_read_by_check_and_carry_the_fade(first):
    out, res = first
    d = load_battery(out / "packs" / "S4.yaml")
    h = {x.pack_id: x for x in res.health}["S4"]
    assert d.model.fade_per_cycle == pytest.approx(h.fade_per_cycle)
    assert d.model.cycle == h.last_cycle + 1
    # the pack draws (1 + φ n) × the charge of a new one: a shorter endurance for check
    assert d.model.charge_scale() == pytest.approx(1 + h.fade_per_cycle * (h.last_cycle + 1))
    # each pack file is its own aircraft's pack type
    x3 = load_battery(out / "packs" / "X3.yaml")
    assert x3.capacity_mah == load_aircraft_and_battery(REPO / "aircraft/x8_mapper.yaml")[
        1].capacity_mah
    code = main(["check", str(REPO / "missions/survey_quad.yaml"), "--aircraft",
                 str(AIRCRAFT), "--battery", str(out / "packs" / "S4.yaml")])
    assert code in (0, 1)


def test_report_has_bias_p95_drift_and_figures(first, fleet):
    out, res = first
    text = (out / "report.md").read_text()
    assert "bias" in text and "P95" in text and "drift per flight" in text
    assert "| S4 |" in text and "RETIRE" in text
    # the worst flights (largest charge error: the oldest pack at its last cycles) are
    # diagnosed, each on its own, with the aircraft that flew it
    assert len(res.diagnoses) == 5
    worst = fleet.truth.set_index("log").loc[[Path(p).name for p in res.diagnoses]]
    assert (worst["pack"] == "S4").all()
    assert all(t and not t.startswith("not diagnosed") for t in res.diagnoses.values())
    assert "`diagnose` (docs/commands.md)" in text
    assert "## Aircraft calibrated on the fleet" in text
    for png in ("accuracy.png", "drift.png", "packs.png"):
        assert (out / png).stat().st_size > 5000


def test_fleet_calibration_recovers_each_true_aircraft_on_held_out_flights(first, fleet):
    """Each aircraft is flown as a true airframe that differs from its file
    (testkit.fleet.TRUTH); the calibration on about four fifths of its flights finds the
    true values within three standard errors (a test over every parameter of three
    aircraft: two would fail one in twenty of them by chance) and cuts the held-out
    flights' energy error."""
    from planner.identify.aircraft_fit import get_param
    from planner.fleet.calibrate import held_out
    from testkit.fleet import TRUTH, true_aircraft

    out, res = first
    cals = {c.key: c for c in res.calibrations}
    assert set(cals) == set(TRUTH)
    table = res.table[res.table["status"] == "ok"]
    for key, cal in cals.items():
        truth, _ = true_aircraft(key)
        flights = table[table["aircraft"] == key]
        assert cal.train_flights + cal.validation_flights == len(flights)
        assert cal.validation_flights == sum(held_out(h) for h in flights["sha256"]) > 0
        for name in TRUTH[key]:
            value, se = cal.parameters[name], cal.stderr[name]
            assert abs(value - get_param(truth, name)) <= 3 * se, (key, name, value, se)
        before, after = cal.flight_error_pct["before"], cal.flight_error_pct["after"]
        assert after < 1.0 < before, (key, before, after)
        fitted = load_aircraft(out / "aircraft" / f"{key}.yaml")
        for name, value in cal.parameters.items():
            assert get_param(fitted, name) == pytest.approx(value, rel=1e-6)
        assert "held-out" in fitted.source
    samples = pd.read_parquet(out / "samples.parquet")
    assert set(samples["sha256"]) == set(table.loc[table["energy_error_pct"].notna(), "sha256"])
    assert samples.groupby("sha256").size().max() <= 300


def test_a_log_two_aircraft_could_have_flown_fails_with_the_reason(fleet):
    from planner.fleet.summary import summarise_log

    craft, packs = _models()
    models = {k: (craft[k], packs[k]) for k in ("solo_survey", "quad_7in")}
    log = next(p for p in sorted(fleet.logs.iterdir())
               if fleet.truth.set_index("log").loc[p.name, "aircraft"] == "quad_7in")
    row = summarise_log(str(log), models=models)
    assert row["status"] == "failed"
    assert "which aircraft flew this multirotor log" in row["error"]
    assert "column aircraft" in row["error"]
    row = summarise_log(str(log), models=models, aircraft_key="quad_7in")
    assert row["status"] == "ok" and row["aircraft"] == "quad_7in"


def test_cli_runs_a_mixed_fleet_and_names_an_unknown_aircraft(fleet_dir, tmp_path, capsys):
    bad = tmp_path / "packs.csv"
    bad.write_text("log,pack,aircraft\nx.bin,P1,solo_survey\ny.bin,P2,hexa\n")
    code = main(["fleet", str(fleet_dir / "logs"), "--aircraft", str(AIRCRAFT),
                 str(REPO / "aircraft/quad_7in.yaml"), "--out", str(tmp_path / "o"),
                 "--packs", str(bad), "--workers", "1"])
    err = capsys.readouterr().err
    assert code == 2
    assert "packs.csv: row 3: aircraft 'hexa' is none of the aircraft given" in err
    assert not (tmp_path / "o").exists()


def test_rerun_skips_finished_logs_and_an_interrupted_run_completes_to_the_same_table(
        first, fleet_dir, damaged, client, tmp_path):
    _, full = first
    logs = sorted((fleet_dir / "logs").iterdir())
    out = tmp_path / "fleet"
    # "interrupted": only a third of the logs were done
    part = _run(logs[: len(logs) // 3], out, client, packs=fleet_dir / "packs.csv")
    assert part.processed == len(logs) // 3
    again = _run([fleet_dir / "logs", damaged], out, client, packs=fleet_dir / "packs.csv")
    assert again.skipped == len(logs) // 3
    assert again.processed == len(logs) - len(logs) // 3 + 2    # the damaged are retried

    def canon(t):
        return t.sort_values(["status", "sha256", "log"]).reset_index(drop=True)

    pd.testing.assert_frame_equal(canon(again.table), canon(full.table))
    # the calibration samples of the first part were kept, not read again
    full_out, _ = first

    def samples(folder):
        s = pd.read_parquet(folder / "samples.parquet")
        return s.sort_values(["sha256", "time_s"]).reset_index(drop=True)

    pd.testing.assert_frame_equal(samples(out), samples(full_out))
    third = _run([fleet_dir / "logs"], out, client, packs=fleet_dir / "packs.csv")
    assert third.processed == 0 and third.skipped == len(logs)


def test_an_interrupted_run_keeps_what_it_finished_and_its_rerun_reads_only_the_rest(
        first, fleet_dir, damaged, client, tmp_path):
    _, full = first
    out = tmp_path / "fleet"

    class Interrupt:
        """Ctrl-C once 20 logs are done."""

        def update(self, done, failed, skipped):
            if done >= 20:
                raise KeyboardInterrupt

    from planner.fleet import FleetInterrupted

    with pytest.raises(FleetInterrupted) as stop:
        _run([fleet_dir / "logs", damaged], out, client, packs=fleet_dir / "packs.csv",
             progress=Interrupt(), checkpoint_s=3600.0)
    kept = pd.read_parquet(out / "flights.parquet")
    finished = int((kept["status"] == "ok").sum())
    assert 20 <= finished < 12 * FLIGHTS_PER_PACK
    assert (stop.value.kept, stop.value.table) == (finished, out / "flights.parquet")
    again = _run([fleet_dir / "logs", damaged], out, client, packs=fleet_dir / "packs.csv")
    assert again.skipped == finished
    assert again.processed == 12 * FLIGHTS_PER_PACK - finished + 2

    def canon(t):
        return t.sort_values(["status", "sha256", "log"]).reset_index(drop=True)

    pd.testing.assert_frame_equal(canon(again.table), canon(full.table))


def test_output_folder_may_not_hold_an_input(fleet_dir, capsys):
    before = sorted(p.name for p in fleet_dir.rglob("*"))
    code = main(["fleet", str(fleet_dir / "logs"), "--aircraft", str(AIRCRAFT),
                 "--out", str(fleet_dir / "logs")])
    assert code == 2
    assert "contains the input file" in capsys.readouterr().err
    with pytest.raises(InputError, match="contains the input file"):
        _run([fleet_dir / "logs"], fleet_dir, None)     # the parent of the logs
    assert sorted(p.name for p in fleet_dir.rglob("*")) == before


def test_cli_on_an_existing_scheduler_and_all_failed_exits_2(damaged, client, tmp_path,
                                                            capsys):
    addr = client.scheduler.address
    code = main(["fleet", str(damaged), "--aircraft", str(AIRCRAFT), "--out",
                 str(tmp_path / "o"), "--scheduler", addr])
    err = capsys.readouterr().err
    assert code == 2
    assert "all 2 logs failed" in err and "noise.ulg" in err and "cut.ulg" in err
    assert "Traceback" not in err
    assert not (tmp_path / "o" / "flights.parquet").exists()


def test_cli_bad_packs_csv_names_the_row(fleet_dir, tmp_path, capsys):
    bad = tmp_path / "packs.csv"
    bad.write_text("log,pack,cycle\nB_000.bin,B,3\nB_001.tlog,B,three\n")
    code = main(["fleet", str(fleet_dir / "logs"), "--aircraft", str(AIRCRAFT), "--out",
                 str(tmp_path / "o"), "--packs", str(bad), "--workers", "1"])
    err = capsys.readouterr().err
    assert code == 2
    assert "packs.csv: row 3: cycle must be a whole number" in err


def test_pack_map_reads_excel_csv_and_pack_file_names_stay_apart(tmp_path):
    from planner.fleet import _pack_file_name, read_pack_map

    csv = tmp_path / "packs.csv"
    csv.write_bytes("\ufefflog,pack,cycle\r\nx.bin,A/1,4\r\ny.ulg,A_1,\r\n".encode())
    files.reset()
    assert read_pack_map(csv) == {"x.bin": ("A/1", 4.0, None), "y.ulg": ("A_1", None, None)}
    assert _pack_file_name("A/1") == _pack_file_name("A_1") == "A_1.yaml"


def test_two_packs_whose_names_clash_get_two_files(tmp_path):
    from planner.fleet import write_pack_files
    from planner.fleet.health import PackHealth

    nan = float("nan")
    health = [PackHealth(pid, 10, 9.0, 1.02, 0.01, 0.004 * k, 0.001, 0.97, 0.01, 60.0, 5.0,
                         51.0, nan, nan, nan, nan, nan) for k, pid in enumerate(("A/1", "A_1"))]
    files.reset()
    written, _ = write_pack_files(health, load_aircraft_and_battery(AIRCRAFT)[1], tmp_path)
    assert sorted(p.name for p in written.values()) == ["A_1-2.yaml", "A_1.yaml"]
    assert load_battery(written["A_1"]).model.fade_per_cycle == pytest.approx(0.004)


def test_step_resistance_recovers_a_known_resistance():
    from planner.fleet.summary import step_resistance

    rng = np.random.default_rng(3)
    t = np.arange(0.0, 300.0, 0.2)
    i = np.where((t // 20) % 2 == 0, 8.0, 20.0) + 0.05 * rng.standard_normal(t.size)
    v = 16.0 - 0.025 * i - 0.002 * t + 0.005 * rng.standard_normal(t.size)
    r, se, n = step_resistance(t, v, i)
    assert n == 14
    assert abs(r - 0.025) < 3 * se + 1e-4
    assert se < 0.002


def test_fade_fit_recovers_a_known_rate_with_an_honest_error():
    """Over many synthetic packs the fitted φ lies within 2 SE of the truth about 95 %
    of the time (a coverage check of the standard error)."""
    from planner.fleet.health import fit_fade

    rng = np.random.default_rng(5)
    n = np.arange(30.0)
    hits = 0
    for _ in range(400):
        s = 1.03 * (1 + 0.004 * n) * (1 + 0.01 * rng.standard_normal(n.size))
        (a, phi), cov = fit_fade(n, s, np.full(n.size, 0.001))
        hits += abs(phi - 0.004) <= 2 * math.sqrt(cov[1, 1])
    assert 0.90 <= hits / 400 <= 0.99


def test_collect_logs_skips_other_files(fleet_dir, tmp_path):
    from planner.fleet import collect_logs

    d = tmp_path / "mixed"
    d.mkdir()
    shutil.copy(sorted((fleet_dir / "logs").glob("*.bin"))[0], d / "x.BIN")
    (d / "notes.txt").write_text("not a log")
    files.reset()
    assert [p.name for p in collect_logs([d])] == ["x.BIN"]
    (d / "x.BIN").unlink()
    with pytest.raises(InputError, match="no log files"):
        collect_logs([d])


def test_start_time_of_a_real_dataflash_log_from_its_gps_week(shared_data):
    """ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin: the file is named by the local
    time of the flight in Texas (CDT, UTC−5): 2014-10-18 20:04 → 2014-10-19 01:04 UTC."""
    from planner.io.logs import read_log

    _, meta = read_log(shared_data / "logs/ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin")
    start = pd.Timestamp(meta["start_time_unix"], unit="s", tz="UTC")
    assert pd.Timestamp("2014-10-19 01:04", tz="UTC") <= start < pd.Timestamp(
        "2014-10-19 01:06", tz="UTC")


def test_serial_numbers_unset_on_real_logs_without_a_smart_battery(shared_data):
    """PX4 writes battery_status.serial_number 0 without a smart battery: no pack identity
    from such a log (it would merge every pack of the fleet into one)."""
    from planner.io.logs import read_log
    from planner.io.logs._common import serial_or_none

    _, meta = read_log(shared_data / "logs/px4_quad_fmuv6c_indoor_quadrotor_local.ulg")
    assert meta["battery_serial"] is None
    assert serial_or_none(np.array([0, 0, 1234, 1234, 0])) == "1234"
    assert serial_or_none(-1.0) is None and serial_or_none(None) is None


def test_a_fleet_without_aircraft_keeps_each_packs_nominal_capacity(client, tmp_path):
    """Library use without an aircraft: the pack given is every pack's reference, so the
    health carries its capacity and a pack file is written per pack; the CSV's aircraft
    column is moot."""
    from planner.fleet import read_pack_map, run_fleet
    from testkit.fleet import PACKS, generate_fleet

    g = generate_fleet(tmp_path / "small", flights_per_pack=4, packs=PACKS[1:3])
    _, pack = load_aircraft_and_battery(AIRCRAFT)
    files.reset({"--out": str(tmp_path / "o")}, folders=("--out",))
    res = run_fleet([g.logs], out_dir=tmp_path / "o", aircraft=None, pack=pack,
                    pack_map=read_pack_map(g.packs_csv), client=client, progress=False)
    assert (res.table["status"] == "ok").all()
    assert {h.pack_id for h in res.health} == {"S2", "S3"}
    for h in res.health:
        assert h.capacity_mah == pytest.approx(pack.capacity_mah * h.soh)
    assert sorted(p.name for p in res.pack_files.values()) == ["S2.yaml", "S3.yaml"]


def test_an_aircraft_the_run_does_not_have_is_a_failed_row_that_names_it(fleet):
    from planner.fleet.summary import summarise_log

    craft, packs = _models()
    log = sorted(fleet.logs.iterdir())[0]
    row = summarise_log(str(log), models={"solo_survey": (craft["solo_survey"],
                                                          packs["solo_survey"])},
                        aircraft_key="hexa")
    assert row["status"] == "failed"
    assert "names aircraft 'hexa', none of the aircraft given (solo_survey)" in row["error"]


def test_ctrl_c_says_how_many_flights_were_kept_and_how_to_resume(fleet_dir, tmp_path):
    """Ctrl-C from a terminal reaches the whole process group (the command and its Dask
    workers): one line saying what was kept and how to resume, no worker tracebacks, and
    the table it names holds that many flights.

    The command starts as from a terminal, with Ctrl-C's default handler: a test run in
    the background (``cmd &``, ``nohup``) passes SIGINT ignored to its children, and
    Python keeps an inherited SIGINT ignored, as a command started so should."""
    import os
    import signal
    import subprocess
    import sys

    out = tmp_path / "fleet"
    as_from_a_terminal = ("import runpy, signal, sys; "
                          "signal.signal(signal.SIGINT, signal.default_int_handler); "
                          "sys.argv[0] = 'endurance'; "
                          "runpy.run_module('planner.cli.main', run_name='__main__')")
    proc = subprocess.Popen(
        [sys.executable, "-c", as_from_a_terminal, "fleet", str(fleet_dir / "logs"),
         "--aircraft", str(AIRCRAFT), str(REPO / "aircraft/quad_7in.yaml"),
         str(REPO / "aircraft/x8_mapper.yaml"), "--packs", str(fleet_dir / "packs.csv"),
         "--out", str(out), "--workers", "1"],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True)
    try:
        first = proc.stderr.readline()          # the first progress line: some logs done
        assert first.startswith("fleet: "), first
        os.killpg(proc.pid, signal.SIGINT)
        rest, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    lines = [s for s in err.splitlines() if not s.startswith("fleet: ")]
    assert proc.returncode == 130
    assert "Traceback" not in err and rest == ""
    assert len(lines) == 1, lines
    kept = int((pd.read_parquet(out / "flights.parquet")["status"] == "ok").sum())
    assert kept >= 1
    flights = "flight" if kept == 1 else "flights"
    assert lines[0] == (f"interrupted: {kept} {flights} kept in {out / 'flights.parquet'}; "
                        "run the same command again to finish (the flights in the table are "
                        "not read again)")
