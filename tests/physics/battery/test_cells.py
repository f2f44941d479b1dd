"""Cells in series from the pack voltage (planner.physics.battery.cells)."""

import numpy as np
import pytest

from planner.io.flightdata import load_flight_data
from planner.physics.battery.cells import CELL_MAX_V, series_cells

#: The real 8S and 6S logs of ../shared/data/logs (PROVENANCE.md, files 5 and 6).
EIGHT_S = "px4_quad_fmuv6c_indoor_quadrotor_local.ulg"
SIX_S = "px4_quad_fmuv3_esc_status_log.ulg"


@pytest.mark.parametrize("log, cells", [(EIGHT_S, 8), (SIX_S, 6)])
def test_the_real_8s_and_6s_logs_give_8_and_6_cells(shared_data, log, cells):
    """PROVENANCE.md: the 8S pack peaks at 30.96 V (3.87 V a cell), the 6S at 22.58 V
    (3.76 V a cell): neither is full, and V/4.2 V rounded gives 7 and 5; the logs' own
    cell-count parameter says 8 and 6."""
    df, metas = load_flight_data([shared_data / "logs" / log])
    assert series_cells(df["voltage_v"]) == cells
    assert metas[0]["battery_cells"] == cells
    assert round(float(np.nanmax(df["voltage_v"])) / 4.2) == cells - 1   # the old rule


def test_peak_voltages_of_the_real_logs_give_their_cell_counts():
    """Highest voltages of the real logs (PROVENANCE.md) give their packs' cell counts."""
    for vmax, cells in [(16.54, 4), (24.31, 6), (30.96, 8), (11.62, 3), (49.91, 12),
                        (22.58, 6), (15.19, 4)]:
        assert series_cells([vmax * 0.95, vmax]) == cells


def test_a_full_pack_and_the_limits_of_a_partly_charged_one():
    """A pack of N cells charged to 4.25 V each is N; below 4.25 (N − 1)/N V a cell it
    cannot be told from N − 1 cells."""
    for n in range(1, 15):
        assert series_cells([n * CELL_MAX_V]) == n
        assert series_cells([n * 4.20]) == n
        assert series_cells([(n - 1) * CELL_MAX_V + 0.01]) == n
    assert series_cells([np.nan, 0.0, -3.0]) is None
    assert series_cells([]) is None
    assert series_cells([np.nan, 12.4]) == 3
