r"""Cells in series of a lithium pack, from its voltage.

A lithium-ion (LiPo) cell is charged to 4.20 V, within ±50 mV (Battery University,
BU-409 "Charging Lithium-ion": "most cells charge to 4.20V/cell with a tolerance of
+/-50mV/cell"). A pack of N cells in series therefore never reads more than
N × :data:`CELL_MAX_V` = N × 4.25 V, and the smallest N its highest voltage allows is

.. math:: N = \lceil V_{max} / 4.25\,\mathrm{V} \rceil .

This holds for a pack that is not full when the log starts, as long as its cells are
above 4.25 (N − 1)/N V (3.54 V for 6S, 3.72 V for 8S): the 6S log of
``px4_quad_fmuv3_esc_status_log.ulg`` peaks at 22.58 V (3.76 V a cell) and gives 6,
where rounding V/4.2 V gives 5.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["CELL_MAX_V", "series_cells"]

#: Highest voltage of a charged LiPo cell: 4.20 V plus the chargers' 50 mV tolerance. [V]
CELL_MAX_V = 4.25


def series_cells(voltage_v) -> int | None:
    """Cells in series of a pack from the voltages it showed: ⌈V_max / 4.25 V⌉ (module
    notes), at least 1; None where no voltage is finite and positive.

    Parameters
    ----------
    voltage_v : array_like
        Pack terminal voltages, e.g. a log's battery channel (NaN and 0 are ignored). [V]

    Returns
    -------
    int or None
        Cells in series. [unitless]
    """
    v = np.asarray(voltage_v, float).ravel()
    v = v[np.isfinite(v) & (v > 0)]
    if v.size == 0:
        return None
    return max(1, int(math.ceil(float(np.max(v)) / CELL_MAX_V)))
