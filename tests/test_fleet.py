"""``endurance fleet`` on a generated fleet with known pack fade, on a 2-worker Dask cluster.

The fleet: flights of the simulated 3DR Solo (testkit.flight, in winds that differ from
flight to flight) written as ``.bin``, ``.tlog`` and ``.ulg`` (testkit.writers), flown on
four packs that age at known rates. A pack ageing at ``φ`` per cycle draws
``(1 + φ n)`` times the new pack's charge for the same energy at cycle ``n``: the
simulated current is multiplied by that factor and the voltage divided by it (the power,
and so the flight, unchanged), with a flight-to-flight scatter of 0.5 % (temperature,
charge at take-off). (The step resistance of such a log reads R/s², an artefact of the
injection: the resistance is checked on its own, not on this fleet.)
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from planner import files
from planner.cli import main
from planner.errors import InputError
from planner.mission.legs import Environment, Leg, Mission
from planner.parameters import load_aircraft_and_battery, load_battery

REPO = Path(__file__).resolve().parents[1]
AIRCRAFT = REPO / "aircraft/solo_survey.yaml"
#: pack → (fade per cycle, first cycle, cycles given in the --packs CSV); pack 4242 is a
#: smart battery: its serial (and, in a ULog, its cycle count) is in the log, not in the CSV
PACKS = {"4242": (0.0, 0, False), "B": (0.002, 0, False), "C": (0.003, 5, True),
         "D": (0.008, 20, True)}
SERIAL = "4242"
FLIGHTS_PER_PACK = 12
SCATTER = 0.005
FORMATS = (".bin", ".tlog", ".ulg")

dask_distributed = pytest.importorskip("dask.distributed",
                                       reason="dask[distributed] is a dependency of fleet")
pytest.importorskip("pyarrow", reason="pyarrow is a dependency of fleet")


def _mission() -> Mission:
    return Mission("fleet test sortie", [
        Leg("climb", (0.0, 0.0), (0.0, 0.0), 0.0, 30.0, climb_rate_ms=2.5),
        Leg("cruise", (0.0, 0.0), (700.0, 0.0), 30.0, 30.0, speed_ms=9.0),
        Leg("hover", (700.0, 0.0), (700.0, 0.0), 30.0, 30.0, duration_s=40.0),
        Leg("cruise", (700.0, 0.0), (0.0, 0.0), 30.0, 30.0, speed_ms=9.0),
        Leg("descend", (0.0, 0.0), (0.0, 0.0), 30.0, 0.0, climb_rate_ms=1.5)])


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory):
    """The logs, the --packs CSV and the truth."""
    from testkit.flight import simulate_flight
    from testkit.writers import write_log

    root = tmp_path_factory.mktemp("fleet")
    logs = root / "logs"
    logs.mkdir()
    aircraft, pack = load_aircraft_and_battery(AIRCRAFT)
    mission = _mission()
    rng = np.random.default_rng(16)
    rows = []
    k = 0
    for name, (phi, first, cycles_given) in PACKS.items():
        for j in range(FLIGHTS_PER_PACK):
            cycle = first + j
            env = Environment(float(rng.uniform(0, 7)), float(rng.uniform(0, 360)), 15.0)
            rec = simulate_flight(mission, aircraft, pack, environment=env, rate_hz=2.0,
                                  seed=k, experiment="f")
            s = (1.0 + phi * cycle) * (1.0 + SCATTER * rng.standard_normal())
            rec["current_a"] *= s
            rec["voltage_v"] /= s
            rec["consumed_mah"] *= s
            ext = FORMATS[k % 3]
            file = logs / f"{name}_{j:03d}{ext}"
            opts = {"capacity_mah": pack.capacity_mah}
            if ext == ".ulg":
                opts["cells"] = pack.cells_series
            if name == SERIAL:
                if ext == ".ulg":
                    opts.update(battery_serial=int(SERIAL), battery_cycle=cycle)
                else:
                    opts["params"] = {"BATT_SERIAL_NUM": float(SERIAL)}
            write_log(rec, file, **opts)
            if name != SERIAL:
                rows.append({"log": file.name, "pack": name,
                             "cycle": str(cycle) if cycles_given else ""})
            k += 1
    pd.DataFrame(rows).to_csv(root / "packs.csv", index=False)
    return root


@pytest.fixture(scope="module")
def client():
    from dask.distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                           dashboard_address=None)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


def _run(paths, out, client, **kw):
    from planner.fleet import read_pack_map, run_fleet

    files.reset({"--out": str(out)})
    aircraft, pack = load_aircraft_and_battery(AIRCRAFT)
    kw.setdefault("progress", False)
    return run_fleet(paths, out_dir=out, aircraft=aircraft, pack=pack,
                     pack_map=read_pack_map(kw.pop("packs")) if "packs" in kw else None,
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


def test_fitted_fade_within_two_standard_errors_of_the_injected(first):
    _, res = first
    health = {h.pack_id: h for h in res.health}
    assert set(health) == set(PACKS)
    for name, (phi, first_cycle, _) in PACKS.items():
        h = health[name]
        assert h.flights == FLIGHTS_PER_PACK
        assert 0 < h.fade_per_cycle_se < 0.002, (name, h)
        assert abs(h.fade_per_cycle - phi) <= 2 * h.fade_per_cycle_se, (name, h)
        assert h.last_cycle == first_cycle + FLIGHTS_PER_PACK - 1
    # pack D is at 1/(1 + 0.008·31) = 80.1 %: it reaches 80 % within 50 flights, the
    # slowly ageing ones do not
    assert health["D"].retires_within(50)
    assert not any(health[p].retires_within(50) for p in (SERIAL, "B", "C"))
    assert health["D"].soh == pytest.approx(1 / (1 + 0.008 * 31), abs=3 * health["D"].soh_se)


def test_damaged_logs_are_rows_with_their_reason_and_the_rest_is_kept(first):
    _, res = first
    t = res.table
    failed = t[t["status"] == "failed"]
    assert sorted(Path(p).name for p in failed["log"]) == ["cut.ulg", "noise.ulg"]
    assert failed["error"].str.contains(r"\.ulg").all()
    assert failed["error"].map(lambda e: "\n" not in e).all()
    assert (t["status"] == "ok").sum() == len(PACKS) * FLIGHTS_PER_PACK
    assert len(res.failed) == 2


def test_parquet_schema_and_rows(first):
    import pyarrow.parquet as pq

    from planner.fleet.summary import COLUMNS

    out, res = first
    schema = pq.read_schema(out / "flights.parquet")
    assert schema.names == list(COLUMNS)
    for name in ("duration_s", "energy_wh", "charge_mah", "delta_scale", "delta_scale_se"):
        assert str(schema.field(name).type) == "double", name
    assert str(schema.field("start_time_utc").type).startswith("timestamp")
    t = pd.read_parquet(out / "flights.parquet")
    ok = t[t["status"] == "ok"]
    assert ok["sha256"].str.fullmatch(r"[0-9a-f]{64}").all()
    assert ok["sha256"].is_unique
    assert set(ok["format"]) == {"dataflash", "tlog", "ulog"}
    assert (ok["aircraft"] == load_aircraft_and_battery(AIRCRAFT)[0].name).all()
    # the measured charge and the prediction agree to a few per cent on the new pack
    new = ok[ok["log"].str.contains(f"/{SERIAL}_")]
    assert new["charge_error_pct"].abs().max() < 10
    assert (new["pack_id"] == SERIAL).all()
    assert (new["pack_id_source"] == "log battery serial").all()
    assert (ok.loc[ok["pack_id"] != SERIAL, "pack_id_source"] == "--packs").all()
    # a smart battery's ULog carries its cycle count
    ulg = new[new["format"] == "ulog"]
    assert len(ulg) and (ulg["cycle"] == ulg["log"].str.extract(r"_(\d+)\.ulg")[0]
                         .astype(float)).all()
    # the logged charge is the simulated charge: energy / charge is the pack's voltage
    v = 1000 * ok["energy_wh"] / ok["charge_mah"]
    assert v.between(12.0, 17.0).all()
    assert ok["resistance_steps"].ge(0).all()
    # start times: the tlog's receive time and the DataFlash GPS time of the writers' start
    from testkit.writers import START_TIME_UNIX

    start = pd.Timestamp(START_TIME_UNIX, unit="s", tz="UTC")
    clocked = ok[ok["format"] != "ulog"]
    assert (clocked["start_time_utc"] - start).abs().max() < pd.Timedelta(seconds=1)
    assert ok.loc[ok["format"] == "ulog", "start_time_utc"].isna().all()


def test_pack_files_are_read_by_check_and_carry_the_fade(first):
    out, res = first
    d = load_battery(out / "packs" / "D.yaml")
    h = {x.pack_id: x for x in res.health}["D"]
    assert d.model.fade_per_cycle == pytest.approx(h.fade_per_cycle)
    assert d.model.cycle == h.last_cycle + 1
    # the pack draws (1 + φ n) × the charge of a new one: a shorter endurance for check
    assert d.model.charge_scale() == pytest.approx(1 + h.fade_per_cycle * (h.last_cycle + 1))
    code = main(["check", str(REPO / "missions/survey_quad.yaml"), "--aircraft",
                 str(AIRCRAFT), "--battery", str(out / "packs" / "D.yaml")])
    assert code in (0, 1)


def test_report_has_bias_p95_drift_and_figures(first):
    out, res = first
    text = (out / "report.md").read_text()
    assert "bias" in text and "P95" in text and "drift per flight" in text
    assert "| D |" in text and "RETIRE" in text
    # the worst flights are diagnosed, each on its own
    assert len(res.diagnoses) == 5
    assert all(Path(log).name.startswith("D_") for log in res.diagnoses)
    assert all(t and not t.startswith("not diagnosed") for t in res.diagnoses.values())
    assert "`diagnose` (DESIGN §6)" in text
    for png in ("accuracy.png", "drift.png", "packs.png"):
        assert (out / png).stat().st_size > 5000


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

    with pytest.raises(KeyboardInterrupt):
        _run([fleet_dir / "logs", damaged], out, client, packs=fleet_dir / "packs.csv",
             progress=Interrupt(), checkpoint_s=3600.0)
    kept = pd.read_parquet(out / "flights.parquet")
    finished = int((kept["status"] == "ok").sum())
    assert 20 <= finished < len(PACKS) * FLIGHTS_PER_PACK
    again = _run([fleet_dir / "logs", damaged], out, client, packs=fleet_dir / "packs.csv")
    assert again.skipped == finished
    assert again.processed == len(PACKS) * FLIGHTS_PER_PACK - finished + 2

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
    assert read_pack_map(csv) == {"x.bin": ("A/1", 4.0), "y.ulg": ("A_1", None)}
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
    from planner.logs import read_log

    _, meta = read_log(shared_data / "logs/ardupilot_copter_ac313_pixhawk_2014-10-18_20-04.bin")
    start = pd.Timestamp(meta["start_time_unix"], unit="s", tz="UTC")
    assert pd.Timestamp("2014-10-19 01:04", tz="UTC") <= start < pd.Timestamp(
        "2014-10-19 01:06", tz="UTC")


def test_serial_numbers_unset_on_real_logs_without_a_smart_battery(shared_data):
    """PX4 writes battery_status.serial_number 0 without a smart battery: no pack identity
    from such a log (it would merge every pack of the fleet into one)."""
    from planner.logs import read_log
    from planner.logs._common import serial_or_none

    _, meta = read_log(shared_data / "logs/px4_quad_fmuv6c_indoor_quadrotor_local.ulg")
    assert meta["battery_serial"] is None
    assert serial_or_none(np.array([0, 0, 1234, 1234, 0])) == "1234"
    assert serial_or_none(-1.0) is None and serial_or_none(None) is None
