"""The project's ULog decoder against pyulog, field by field, and on damaged files.

Every ULog at hand (the real logs of ../shared/data/logs and the shipped examples) is
decoded by both; every topic, instance and field must be the same array with the same
dtype, and the parameters, the info messages and the corruption flag must agree. The
damaged logs of ../shared/fuzz-examples must give data or a one-line bad-input error
within seconds, never an internal error.
"""

import contextlib
import io
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from planner.io.logs._ulog_decode import ULogError, decode
from planner.io.logs.ulog import _TOPICS

REPO = Path(__file__).resolve().parents[3]
SHARED = REPO.parent / "shared"


def ulogs():
    real = sorted((SHARED / "data/logs").glob("*.ulg")) if (SHARED / "data/logs").is_dir() \
        else []
    return real + sorted((REPO / "logs").glob("*.ulg"))


@pytest.mark.parametrize("path", ulogs(), ids=lambda p: p.name)
def test_every_field_equals_pyulog(path):
    from pyulog import ULog

    with contextlib.redirect_stdout(io.StringIO()):
        ref = ULog(str(path), _TOPICS)
    ours = decode(path.read_bytes(), _TOPICS)
    a = {(d.name, d.multi_id): d.data for d in ref.data_list}
    b = {(d.name, d.multi_id): d.data for d in ours.data_list}
    assert a.keys() == b.keys() and a
    for key in a:
        assert list(a[key]) == list(b[key]), key
        for name in a[key]:
            assert a[key][name].dtype == b[key][name].dtype, (key, name)
            np.testing.assert_array_equal(a[key][name], b[key][name], err_msg=f"{key} {name}")
    assert ours.initial_parameters == ref.initial_parameters
    assert ours.msg_info_dict == ref.msg_info_dict
    assert ours.file_corruption == ref.file_corruption


def test_a_format_that_contains_itself_is_refused_not_followed():
    """A nested type that refers to itself (pyulog recurses until RecursionError) and a
    huge array of it (pyulog: gigabytes) are refused at the subscription."""
    import struct

    def msg(t, payload):
        return struct.pack("<HB", len(payload), ord(t)) + payload

    head = b"ULog\x01\x12\x35\x01" + b"\x00" * 8
    body = (msg("F", b"loop:uint64_t timestamp;loop[65535] again;")
            + msg("F", b"battery_status:uint64_t timestamp;float voltage_v;")
            + msg("A", struct.pack("<BH", 0, 1) + b"loop")
            + msg("A", struct.pack("<BH", 0, 2) + b"battery_status")
            + msg("D", struct.pack("<HQf", 2, 1000, 15.5))
            + msg("D", struct.pack("<HQ", 1, 5) + b"\x00" * 100))
    t0 = time.perf_counter()
    out = decode(head + body, ["loop", "battery_status"])
    assert time.perf_counter() - t0 < 2.0
    assert [d.name for d in out.data_list] == ["battery_status"]
    assert out.data_list[0].data["voltage_v"][0] == np.float32(15.5)
    assert out.file_corruption and any("contains itself" in p for p in out.problems)
    with pytest.raises(ULogError):
        decode(b"not a ulog file at all", _TOPICS)


FUZZ = sorted((SHARED / "fuzz-examples").glob("*.*")) if (SHARED / "fuzz-examples").is_dir() \
    else []


@pytest.mark.parametrize("path", [p for p in FUZZ if p.suffix != ".md"], ids=lambda p: p.name)
def test_damaged_logs_give_data_or_one_line_quickly(path, tmp_path):
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "planner", "export", str(path), "--csv",
                        str(tmp_path / "x.csv")], capture_output=True, text=True, timeout=60,
                       cwd=tmp_path)
    assert time.perf_counter() - t0 < 30.0
    assert p.returncode in (0, 2), p.stderr[-2000:]
    assert "Traceback" not in p.stderr and "internal error" not in p.stderr
    if p.returncode == 2:
        errors = [line for line in p.stderr.splitlines() if line.startswith("error:")]
        assert len(errors) == 1 and path.name in errors[0]


def test_a_parameter_with_a_garbled_type_is_ignored_with_a_warning(tmp_path):
    """Found by the fuzz campaign: a bit flip in the type of MAV_TYPE made its value raw
    bytes, and int() of them raised ValueError (exit 3); now the parameter is ignored and
    the rest of the log read."""
    from planner.cli.main import main

    data = bytearray((REPO / "logs/sim_solo_windy.ulg").read_bytes())
    i = data.find(b"int32_t MAV_TYPE")
    assert i > 0
    data[i:i + 7] = b"intXX_t"
    path = tmp_path / "garbled.ulg"
    path.write_bytes(bytes(data))
    with pytest.warns(UserWarning, match="parameter.*unreadable type ignored .*MAV_TYPE"):
        assert main(["export", str(path), "--csv", str(tmp_path / "out.csv")]) == 0
    assert (tmp_path / "out.csv").stat().st_size > 1000
