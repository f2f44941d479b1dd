"""OCV tables: the ``soc [1], ocv [V]`` CSV files a ``circuit:`` block names.

A table is read once, when the pack file that names it is loaded, into a
:class:`planner.physics.battery.ocv.OcvTable` (through the one table reader,
:func:`planner.io.tables.read_table`); ``fit-battery`` writes one beside the pack it fits
(:func:`planner.io.tables.write_ocv_csv`).
"""

from __future__ import annotations

from pathlib import Path

from planner.errors import InputError
from planner.io import tables
from planner.physics.battery.ocv import OcvTable, ocv_table

__all__ = ["read_ocv_csv"]


def read_ocv_csv(path) -> OcvTable:
    """
    Read an OCV curve from a CSV file with units in the header.

    The header (a leading ``#`` is allowed, as in PyBaMM's ``ecm_example_ocv.csv``) names
    a ``soc`` column in ``[1]`` (also ``[-]``, ``[%]`` or no unit) and an ``ocv`` column
    in ``[V]`` or ``[mV]``, e.g. ``soc [1], ocv [V]``. Extra columns are ignored; lines
    starting with ``#`` after the header are comments
    (:data:`planner.io.tables.OCV_COLUMNS`).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    OcvTable
        State of charge [1] and open-circuit voltage [V] per cell.

    Raises
    ------
    planner.errors.InputError
        Unreadable file, missing column or unit, non-numeric value (naming the column,
        row and line), or a table that is not monotonic.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: OCV file not found")
    table = tables.read_table(path, tables.OCV_COLUMNS, "OCV table", kind="definition")
    return ocv_table(table["soc"], table["ocv"], where=str(path))
