"""OCV tables: the ``soc [1], ocv [V]`` CSV files a ``circuit:`` block names.

A table is read once, when the pack file that names it is loaded, into a
:class:`planner.physics.battery.ocv.OcvTable`; ``fit-battery --circuit-rates`` writes one beside
the pack it fits.
"""

from __future__ import annotations

import re
from pathlib import Path

from planner.io import files
from planner.physics.battery.ocv import OcvTable, ocv_table
from planner.errors import InputError

__all__ = ["read_ocv_csv", "write_ocv_csv"]

_SOC_UNITS = {"1": 1.0, "-": 1.0, "": 1.0, "%": 0.01}
_OCV_UNITS = {"v": 1.0, "mv": 1e-3}


def _parse_header_field(field: str) -> tuple[str, str | None]:
    m = re.fullmatch(r"\s*([A-Za-z_ ]+?)\s*(?:\[\s*([^\]]*?)\s*\])?\s*", field)
    if m is None:
        return field.strip().lower(), None
    return m.group(1).strip().lower(), (None if m.group(2) is None else m.group(2))


def read_ocv_csv(path) -> OcvTable:
    """
    Read an OCV curve from a CSV file with units in the header.

    The first non-empty line is the header (a leading ``#`` is allowed, as in
    PyBaMM's ``ecm_example_ocv.csv``): a ``soc`` column in ``[1]`` (also
    ``[-]``, ``[%]`` or no unit) and an ``ocv`` column in ``[V]`` or ``[mV]``,
    e.g. ``soc [1], ocv [V]``. Extra columns are ignored; lines starting with
    ``#`` after the header are comments.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    OcvTable

    Raises
    ------
    planner.errors.InputError
        Unreadable file, missing column or unit, non-numeric value (naming
        the row), or a table that is not monotonic.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: OCV file not found")
    lines = files.read_text(path, "definition", "OCV table").splitlines()
    rows = [(n + 1, line) for n, line in enumerate(lines) if line.strip()]
    if not rows:
        raise InputError(f"{path}: the OCV file is empty, expected a header 'soc [1], ocv [V]'")
    header_line = rows[0][1].lstrip().lstrip("#")
    fields = [_parse_header_field(f) for f in header_line.split(",")]
    names = [f[0] for f in fields]
    if "soc" not in names or "ocv" not in names:
        raise InputError(f"{path}: header must name the columns 'soc [1]' and 'ocv [V]', "
                         f"got '{rows[0][1].strip()}'")
    i_soc, i_ocv = names.index("soc"), names.index("ocv")
    soc_unit = (fields[i_soc][1] or "").lower()
    ocv_unit = fields[i_ocv][1]
    if soc_unit not in _SOC_UNITS:
        raise InputError(f"{path}: column 'soc' must be in [1] or [%], got [{fields[i_soc][1]}]")
    if ocv_unit is None or ocv_unit.lower() not in _OCV_UNITS:
        got = "no unit" if ocv_unit is None else f"[{ocv_unit}]"
        raise InputError(f"{path}: column 'ocv' needs its unit in the header, [V] or [mV], "
                         f"got {got}")
    k_soc, k_ocv = _SOC_UNITS[soc_unit], _OCV_UNITS[ocv_unit.lower()]
    soc, ocv = [], []
    for lineno, line in rows[1:]:
        if line.lstrip().startswith("#"):
            continue
        cells = line.split(",")
        if len(cells) <= max(i_soc, i_ocv):
            raise InputError(f"{path}, line {lineno}: expected {len(fields)} columns, "
                             f"got {len(cells)}")
        for col, store, k in ((i_soc, soc, k_soc), (i_ocv, ocv, k_ocv)):
            text = cells[col].strip()
            try:
                store.append(float(text) * k)
            except ValueError:
                raise InputError(f"{path}, line {lineno}: column '{names[col]}' must be a "
                                 f"number, got '{text}'") from None
    return ocv_table(soc, ocv, where=str(path))


def write_ocv_csv(path, table: OcvTable) -> None:
    """Write an :class:`OcvTable` as CSV with the header ``soc [1],ocv [V]``."""
    files.write_text(path, "soc [1],ocv [V]\n" + "".join(
        f"{s:.6g},{v:.6f}\n" for s, v in zip(table.soc, table.ocv_v)), "OCV table")
