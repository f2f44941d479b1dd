"""The one reader of small CSV tables (planner.io.tables) and its one error style.

Every message names the file, the column, the row and its line, and what was expected:
``FILE: column 'c' row r (line l): expected WHAT, got VALUE``.
"""

import re

import numpy as np
import pytest

from planner.errors import InputError
from planner.io import files
from planner.io.record import read_record
from planner.io.tables import (
    OCV_COLUMNS,
    Column,
    cell_error,
    read_table,
    row_label,
    write_ocv_csv,
    write_table,
)
from planner.physics.battery.ocv import ocv_table

SCHEDULE = (Column("time_s"), Column("power_w"))
PACK_MAP = (Column("log", kind="text"), Column("pack", kind="text", blank_ok=True),
            Column("cycle", required=False, blank_ok=True))

STYLE = re.compile(r"^\S+: column '\w+' row \d+ \(line \d+\): expected [^,]+, got .+$")


def table(tmp_path, text, columns, name="t.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path, read_table(path, columns, "test table")


def error(tmp_path, text, columns, name="t.csv") -> str:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError) as info:
        read_table(path, columns, "test table")
    message = str(info.value)
    assert message.startswith(f"{path}: ")
    return message[len(str(path)) + 2:]


def test_units_in_the_header_are_converted_to_the_columns_unit(tmp_path):
    _, t = table(tmp_path, "# soc [%], ocv [mV], note\n100,4200,full\n# a comment\n\n"
                           "0,3000,empty\n", OCV_COLUMNS)
    assert np.allclose(t["soc"], [1.0, 0.0]) and np.allclose(t["ocv"], [4.2, 3.0])
    assert list(t.lines) == [2, 5]


def test_comment_lines_before_the_header_are_skipped(tmp_path):
    """A power schedule: comments, then the header that names the columns."""
    _, t = table(tmp_path, "# power schedule\n# time_s [s]: start; power_w [W]: power\n"
                           "time_s,power_w\n0,100\n60,0\n", SCHEDULE)
    assert list(t["time_s"]) == [0.0, 60.0] and list(t["power_w"]) == [100.0, 0.0]
    assert list(t.lines) == [4, 5]


def test_text_columns_quotes_blanks_absent_optional_columns_and_a_bom(tmp_path):
    _, t = table(tmp_path, '\ufefflog , pack\n"a,1.bin",P1\nb.bin,\n', PACK_MAP)
    assert list(t["log"]) == ["a,1.bin", "b.bin"] and list(t["pack"]) == ["P1", ""]
    assert np.isnan(t["cycle"]).all()


@pytest.mark.parametrize("text, columns, expected", [
    ("soc [1],ocv [V]\n0,3.0\n1,abc\n", OCV_COLUMNS,
     "column 'ocv' row 2 (line 3): expected a number, got 'abc'"),
    ("time_s,power_w\n0,100\n\n# note\n60,\n", SCHEDULE,
     "column 'power_w' row 2 (line 5): expected a number, got ''"),
    ("log,pack\n,P1\n", PACK_MAP, "column 'log' row 1 (line 2): expected a value, got ''"),
])
def test_a_bad_cell_names_file_column_row_line_and_what_was_expected(tmp_path, text,
                                                                     columns, expected):
    message = error(tmp_path, text, columns)
    assert message == expected
    assert STYLE.match(f"f.csv: {message}")


@pytest.mark.parametrize("text, columns, expected", [
    ("soc [1],ocv\n0,3\n", OCV_COLUMNS,
     "column 'ocv' (header): expected its unit, [V] or [mV], got no unit"),
    ("soc [1],ocv [kV]\n0,3\n", OCV_COLUMNS,
     "column 'ocv' (header): expected its unit, [V] or [mV], got [kV]"),
    ("time_s [s],power_w\n0,1\n", SCHEDULE,
     "column 'time_s' (header): expected no unit (the name carries it), got [s]"),
    ("state,volts\n0,3\n", OCV_COLUMNS,
     "header: expected the columns 'soc [1]' and 'ocv [V]', got 'state,volts'"),
    ("# nothing but a comment\n", SCHEDULE,
     "the file is empty, expected a header naming the columns 'time_s' and 'power_w'"),
    ("time_s,power_w\n0\n", SCHEDULE, "row 1 (line 2): expected 2 fields, got 1"),
])
def test_a_bad_header_or_row_says_what_was_expected(tmp_path, text, columns, expected):
    assert error(tmp_path, text, columns) == expected


def test_the_flight_record_reader_speaks_in_the_same_style(tmp_path):
    """Large tables are read by pandas, with the same message for the same fault."""
    path = tmp_path / "rec.csv"
    path.write_text("time_s,power_w\n0,100\n1,abc\n", encoding="utf-8")
    with pytest.raises(InputError) as info:
        read_record(path)
    assert str(info.value) == str(cell_error(path, "power_w", row_label(1, 3), "a number", "abc"))


def test_ocv_tables_round_trip_and_never_overwrite_an_input(tmp_path):
    t = ocv_table([0.0, 0.5, 1.0], [3.0, 3.7, 4.2])
    out = tmp_path / "ocv.csv"
    write_ocv_csv(out, t)
    back = read_table(out, OCV_COLUMNS, "OCV table")
    assert np.allclose(back["soc"], t.soc) and np.allclose(back["ocv"], t.ocv_v)
    files.reset()
    read_table(out, OCV_COLUMNS, "OCV table")        # now an input of this command
    with pytest.raises(InputError, match="input file"):
        write_table(out, ["soc [1]", "ocv [V]"], [["0", "3"]])
    files.reset()
