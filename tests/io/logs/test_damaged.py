"""Damaged input: truncated logs, overwritten bytes, empty files, not-a-log files.

Every damaged file is built under tmp_path from a real log. A reader must return
the valid part with a warning saying what it skipped, or raise InputError naming
the file and the problem: never hang, never a traceback.
"""

import time
import warnings

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from planner.errors import InputError
from planner.io.logs import LogWarning, read_log

BIN = "ardupilot_copter_quad_ac33dev_dronekit_log171.bin"
PX4LOG = "px4_octo_legacy_sdlog2_01_07_59.px4log"
ULG = "px4_quad_fmuv6c_indoor_quadrotor_local.ulg"
TLOG = "ardupilot_copter_ac34dev_fs-batt_ground.tlog"
BATTERY = ["voltage_v", "current_a", "consumed_mah"]


@pytest.fixture(scope="module")
def logs_dir(shared_data):
    return shared_data / "logs"


def damaged(tmp_path, logs_dir, name, how, seed=0):
    data = bytearray((logs_dir / name).read_bytes())
    rng = np.random.default_rng(seed)
    if how == "truncate":
        data = data[:len(data) // 2 + 7]
    elif how == "overwrite":                         # 1000 random bytes at 40 %
        i = len(data) * 2 // 5
        data[i:i + 1000] = rng.integers(0, 256, 1000, dtype=np.uint8).tobytes()
    elif how == "sprinkle":                          # 20 bursts of 16 random bytes
        for _ in range(20):
            i = int(rng.integers(1000, len(data) - 64))
            data[i:i + 16] = rng.integers(0, 256, 16, dtype=np.uint8).tobytes()
    elif how == "zeros":                             # a 5 kB hole of zeros at 1/3
        i = len(data) // 3
        data[i:i + 5000] = bytes(5000)
    path = tmp_path / f"{how}_{name}"
    path.write_bytes(bytes(data))
    return path


def read_timed(path, **kw):
    t = time.perf_counter()
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        df, meta = read_log(path, **kw)
    assert time.perf_counter() - t < 10.0              # never hang
    logw = [str(w.message) for w in rec if issubclass(w.category, LogWarning)]
    assert logw == meta["warnings"]
    return df, meta, logw


def clean(logs_dir, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        return read_log(logs_dir / name)[0]


@pytest.mark.parametrize("name", [BIN, PX4LOG])
def test_truncated_dataflash_keeps_the_valid_part(tmp_path, logs_dir, name):
    full = clean(logs_dir, name)
    df, _, logw = read_timed(damaged(tmp_path, logs_dir, name, "truncate"))
    assert any("is truncated: skipped" in w for w in logw)
    assert 0.45 * len(full) < len(df) < 0.55 * len(full)
    n = len(df) - 1
    for col in BATTERY:
        assert_array_equal(df[col].to_numpy()[:n], full[col].to_numpy()[:n])


@pytest.mark.parametrize("name", [BIN, PX4LOG])
@pytest.mark.parametrize("how", ["overwrite", "sprinkle", "zeros"])
def test_overwritten_dataflash_resyncs(tmp_path, logs_dir, name, how):
    full = clean(logs_dir, name)
    df, meta, logw = read_timed(damaged(tmp_path, logs_dir, name, how))
    assert any("byte(s) of damaged data" in w for w in logw), logw
    assert meta["skipped_bytes"] > 0
    assert len(df) >= len(full) - 30                  # only the damaged messages are lost
    # every battery sample that survived is one of the clean file's, at its time
    merged = df.merge(full, on="time_s", suffixes=("", "_clean"))
    assert len(merged) >= len(df) - 5
    for col in BATTERY[:2]:
        same = merged[col].to_numpy() == merged[col + "_clean"].to_numpy()
        assert same.mean() > 0.99


def test_ulog_truncated_and_overwritten(tmp_path, logs_dir):
    full = clean(logs_dir, ULG)
    df, _, logw = read_timed(damaged(tmp_path, logs_dir, ULG, "truncate"))
    assert any("truncated ULog" in w for w in logw)
    assert 0.4 * len(full) < len(df) < 0.6 * len(full)
    assert_array_equal(df["voltage_v"].to_numpy(), full["voltage_v"].to_numpy()[:len(df)])
    for how in ("overwrite", "sprinkle", "zeros"):
        df, _, logw = read_timed(damaged(tmp_path, logs_dir, ULG, how))
        assert any("damaged ULog" in w for w in logw), how
        assert len(df) > 0.9 * len(full)


@pytest.mark.parametrize("cut", [5, 1000, 40_000, 99_999])
def test_truncated_ulog_without_sync_messages(tmp_path, logs_dir, cut):
    """PX4 v1.9 logs have no sync messages: the end is judged from the last 4 kB."""
    name = "px4_quad_fmuv3_esc_status_log.ulg"
    data = (logs_dir / name).read_bytes()
    p = tmp_path / f"cut_{name}"
    p.write_bytes(data[: len(data) - cut])
    _, _, logw = read_timed(p)
    assert any("truncated ULog: the file ends inside a message" in w for w in logw)
    p.write_bytes(data)
    assert read_timed(p)[2] == []          # the intact file: no warning


def test_tlog_truncated_and_overwritten(tmp_path, logs_dir):
    for how in ("truncate", "overwrite", "sprinkle", "zeros"):
        df, _, logw = read_timed(damaged(tmp_path, logs_dir, TLOG, how))
        assert any("damaged telemetry log" in w for w in logw), how
        assert len(df) > 0


@pytest.mark.parametrize("ext", [".bin", ".px4log", ".ulg", ".tlog", ".csv", ".dat"])
def test_empty_file(tmp_path, ext):
    p = tmp_path / f"empty{ext}"
    p.write_bytes(b"")
    with pytest.raises(InputError, match=rf"empty{ext}: empty file"):
        read_log(p)


@pytest.mark.parametrize("ext", [".bin", ".ulg", ".tlog", ".px4log", ".dat"])
def test_random_bytes_are_not_a_log(tmp_path, ext):
    p = tmp_path / f"noise{ext}"
    p.write_bytes(np.random.default_rng(3).integers(0, 256, 50_000, dtype=np.uint8).tobytes())
    t = time.perf_counter()
    with pytest.raises(InputError, match=rf"noise{ext}: (not a|no MAVLink messages)"):
        read_log(p)
    assert time.perf_counter() - t < 10


def test_text_and_other_non_logs(tmp_path, logs_dir):
    p = tmp_path / "notes.bin"
    p.write_text("hello, world\n" * 50)
    with pytest.raises(InputError, match=r"notes\.bin: not a dataflash log"):
        read_log(p)
    p = tmp_path / "notes.md"
    p.write_text("a, b\n" * 50)
    with pytest.raises(InputError, match="a text file, not a recognised log"):
        read_log(p)
    # a folder is read as a PX4 topic export: one without topic files is bad input
    with pytest.raises(InputError, match="no CSV files; expected a PX4 topic export"):
        read_log(tmp_path)
    with pytest.raises(InputError, match="file not found"):
        read_log(tmp_path / "missing.ulg")
    # only the header of a real log: nothing to read
    for name in (ULG, BIN, TLOG):
        head = tmp_path / f"head_{name}"
        head.write_bytes((logs_dir / name).read_bytes()[:100])
        with pytest.raises(InputError, match=rf"head_{name}"), warnings.catch_warnings():
            warnings.simplefilter("ignore", LogWarning)   # "truncated" comes first
            read_log(head)


@pytest.mark.parametrize("name", [BIN, PX4LOG, ULG, TLOG])
def test_fuzzed_logs_give_a_record_or_input_error(tmp_path, logs_dir, name):
    """Random damage anywhere (FMT/definitions included): a result or InputError, quickly."""
    data = (logs_dir / name).read_bytes()
    for seed in range(12):
        rng = np.random.default_rng(seed)
        b = bytearray(data)
        region = len(b) if seed % 2 else min(len(b), 20_000)      # odd: anywhere; even: head
        for i in rng.integers(0, region, int(rng.integers(1, 400))):
            b[int(i)] = int(rng.integers(0, 256))
        if seed % 3 == 0:
            b = b[: int(rng.integers(len(b) // 4, len(b)))]
        p = tmp_path / f"fuzz{seed}_{name}"
        p.write_bytes(bytes(b))
        t = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                df, _ = read_log(p)
            assert df["time_s"].is_monotonic_increasing
        except InputError as exc:
            assert p.name in str(exc)
        assert time.perf_counter() - t < 10
