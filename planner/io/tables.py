"""Small CSV tables: the one reader of the tables a definition file or a command names.

OCV tables (``soc [1], ocv [V]``), power schedules and pack maps are small CSV files: a
header line naming the columns (a unit in brackets where the name does not carry it), one
row per line, ``#`` comment lines. :func:`read_table` reads one against the columns it
expects (:class:`Column`) and returns a :class:`Table`; :func:`write_table` writes one.
The flight record and CSV logs, which can be large, are read by pandas
(:mod:`planner.io.record`, :mod:`planner.io.logs.csvmap`) with the same messages.

Every problem is an :class:`~planner.errors.InputError` in one style, naming the file, the
column, the row (and its line) and what was expected (:func:`cell_error`)::

    cells.csv: column 'ocv' row 2 (line 3): expected a number, got 'abc'
    cells.csv: column 'ocv' (header): expected its unit, [V] or [mV], got no unit
    cells.csv: header: expected the columns 'soc [1]' and 'ocv [V]', got 'state,volts'
"""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from planner.errors import InputError
from planner.io import files

__all__ = ["Column", "Table", "cell_error", "read_table", "row_label", "write_ocv_csv",
           "write_table"]

NUMBER = "number"
TEXT = "text"


@dataclass(frozen=True)
class Column:
    """One column a table is read for.

    Attributes
    ----------
    name : str
        The name in the header (compared without case and surrounding blanks).
    units : dict of str to float, optional
        The units the header may give in brackets (``ocv [mV]``), lower case, each with
        its factor to the column's own unit; the key ``""`` allows a header without one.
        None: the name carries the unit (``time_s``) and the header gives none.
    kind : str
        ``number`` (read as float, times the unit's factor) or ``text``.
    required : bool
        The header must name it; else an absent column reads as blanks.
    blank_ok : bool
        An empty cell is allowed (NaN for a number, "" for text).
    """

    name: str
    units: dict[str, float] | None = None
    kind: str = NUMBER
    required: bool = True
    blank_ok: bool = False

    @property
    def shown(self) -> str:
        """The column as a header should name it: ``'ocv [V]'``."""
        unit = next((u for u in (self.units or {}) if u), None)
        return f"'{self.name} [{_unit_text(unit)}]'" if unit else f"'{self.name}'"


def _unit_text(unit: str) -> str:
    return {"v": "V", "mv": "mV"}.get(unit, unit)


@dataclass
class Table:
    """A table as read: one array per column, and the file line of each row.

    Attributes
    ----------
    path : Path
        The file, for messages.
    columns : dict of str to ndarray
        Each column asked for: float64 for numbers (in the column's own unit), object
        (str) for text.
    lines : ndarray
        The file line (from 1) of each row.
    """

    path: Path
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    lines: np.ndarray = field(default_factory=lambda: np.zeros(0, int))

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __len__(self) -> int:
        return len(self.lines)

    def error(self, column: str | None, row: int, expected: str, got) -> InputError:
        """The error for row ``row`` (from 0) of ``column``, in the one style."""
        return cell_error(self.path, column, row_label(row, int(self.lines[row])), expected,
                          got)


def row_label(row: int, line: int | None = None) -> str:
    """``row 3 (line 4)``: a data row counted from 1, and its line in the file."""
    return f"row {row + 1}" + (f" (line {line})" if line is not None else "")


def cell_error(path, column: str | None, row: str, expected: str, got) -> InputError:
    """The one message of a bad table cell: ``FILE: column 'c' row r (line l): expected
    WHAT, got VALUE``. ``row`` is the row's label (:func:`row_label`, or a table's index
    label); ``column`` None: the row as a whole."""
    where = f"column '{column}' " if column is not None else ""
    return InputError(f"{path}: {where}{row}: expected {expected}, got {got!r}")


_FIELD = re.compile(r"\s*([^\[\]]*?)\s*(?:\[\s*([^\]]*?)\s*\])?\s*")


def _header_field(text: str) -> tuple[str, str | None]:
    """``'ocv [mV]'`` → ``('ocv', 'mV')``; no brackets → unit None."""
    m = _FIELD.fullmatch(text)
    if m is None:
        return text.strip().lower(), None
    return m.group(1).strip().lower(), m.group(2)


def _split(line: str) -> list[str]:
    return next(csv.reader(io.StringIO(line)), [])


def _find_header(lines: list[str], columns: Sequence[Column]):
    """(index, names, units) of the header: the first line that is not a comment, or a
    comment (``# soc [1], ocv [V]``, as PyBaMM writes) that names every required column."""
    required = {c.name for c in columns if c.required}
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        comment = line.lstrip().startswith("#")
        fields = [_header_field(f) for f in _split(line.lstrip().lstrip("#"))]
        names = [f[0] for f in fields]
        if not comment or required <= set(names):
            return i, names, [f[1] for f in fields]
    return None


def _check_header(path: Path, columns: Sequence[Column], header, text_shown: str):
    """Each column's position in the header and its unit's factor."""
    expected = " and ".join(c.shown for c in columns if c.required)
    if header is None:
        raise InputError(f"{path}: the file is empty, expected a header naming the columns "
                         f"{expected}")
    _, names, units = header
    missing = [c for c in columns if c.required and c.name not in names]
    if missing:
        raise InputError(f"{path}: header: expected the columns {expected}, got "
                         f"'{text_shown}'")
    out = {}
    for c in columns:
        if c.name not in names:
            continue
        at = names.index(c.name)
        unit = units[at]
        if c.units is None:
            if unit is not None:
                raise InputError(f"{path}: column '{c.name}' (header): expected no unit (the "
                                 f"name carries it), got [{unit}]")
            out[c.name] = (at, 1.0)
            continue
        key = (unit or "").lower()
        if key not in c.units:
            allowed = " or ".join(f"[{_unit_text(u)}]" for u in c.units if u)
            got = "no unit" if unit is None else f"[{unit}]"
            raise InputError(f"{path}: column '{c.name}' (header): expected its unit, "
                             f"{allowed}, got {got}")
        out[c.name] = (at, c.units[key])
    return out


def read_table(path: str | os.PathLike, columns: Sequence[Column], what: str,
               kind: str = "table") -> Table:
    """Read a small CSV table (module notes) for ``columns``.

    The header is the first line that is not a ``#`` comment, or a comment line that names
    every required column. Other columns are ignored; blank lines and ``#`` lines after
    the header are skipped; fields may be quoted; a UTF-8 byte-order mark is dropped.

    Parameters
    ----------
    path : str or path
        The file.
    columns : sequence of Column
        The columns to read.
    what : str
        What the file is (``"OCV table"``), for messages.
    kind : str
        Its kind, which bounds its size (:data:`planner.io.files.SIZE_LIMITS`).

    Returns
    -------
    Table

    Raises
    ------
    InputError
        Unreadable file, a header without a required column or with a wrong unit, a row
        with too few fields, a cell that is not a number, a blank cell where a value is
        needed: naming the file, the column, the row and line, and what was expected.
    """
    path = Path(path)
    text = files.read_text(path, kind, what).removeprefix("\ufeff")
    lines = text.splitlines()
    header = _find_header(lines, columns)
    shown = lines[header[0]].strip() if header else ""
    where = _check_header(path, columns, header, shown)
    rows, numbers = [], []
    for i in range(header[0] + 1, len(lines)):
        if lines[i].strip() and not lines[i].lstrip().startswith("#"):
            rows.append(_split(lines[i]))
            numbers.append(i + 1)
    table = Table(path, {}, np.asarray(numbers, dtype=int))
    need = max(at for at, _ in where.values()) + 1
    for r, cells in enumerate(rows):
        if len(cells) < need:
            raise table.error(None, r, f"{len(header[1])} fields", len(cells))
    for c in columns:
        table.columns[c.name] = _column(table, rows, c, where.get(c.name))
    return table


def _column(table: Table, rows: list[list[str]], c: Column, at) -> np.ndarray:
    """One column's values, checked cell by cell."""
    if at is None:  # an optional column the file does not have
        return np.full(len(rows), np.nan if c.kind == NUMBER else "", dtype=float
                       if c.kind == NUMBER else object)
    index, factor = at
    cells = [row[index].strip() for row in rows]
    if c.kind == TEXT:
        for r, cell in enumerate(cells):
            if not cell and not c.blank_ok:
                raise table.error(c.name, r, "a value", cell)
        return np.asarray(cells, dtype=object)
    out = np.empty(len(cells))
    for r, cell in enumerate(cells):
        if not cell and c.blank_ok:
            out[r] = np.nan
            continue
        try:
            out[r] = float(cell) * factor
        except ValueError:
            raise table.error(c.name, r, "a number", cell) from None
    return out


def write_table(path: str | os.PathLike, header: Iterable[str],
                rows: Iterable[Iterable[str]], *, comments: Iterable[str] = (),
                option: str = "output") -> None:
    """Write a small CSV table that :func:`read_table` reads back: ``#`` comment lines,
    the header, one line per row (fields already formatted, with their unit's numbers).
    Atomic, and never over an input file (:func:`planner.io.files.write_text`)."""
    lines = [f"# {c}" for c in comments] + [",".join(header)]
    lines += [",".join(row) for row in rows]
    files.write_text(path, "\n".join(lines) + "\n", option)


#: The columns of an OCV table: state of charge in [1] (or [%], or no unit) and the open-
#: circuit voltage in [V] or [mV].
OCV_COLUMNS = (Column("soc", {"1": 1.0, "-": 1.0, "": 1.0, "%": 0.01}),
               Column("ocv", {"v": 1.0, "mv": 1e-3}))


def write_ocv_csv(path, table) -> None:
    """Write an OCV table (:class:`planner.physics.battery.ocv.OcvTable`: state of charge
    [1], open-circuit voltage [V]) as CSV with the header ``soc [1],ocv [V]``."""
    write_table(path, ["soc [1]", "ocv [V]"],
                ([f"{s:.6g}", f"{v:.6f}"] for s, v in zip(table.soc, table.ocv_v)),
                option="OCV table")
