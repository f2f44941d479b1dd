"""``fit-battery --cells S×P``: a fit of one cell written as the pack of S × P such cells
(δ scaled, [UAV23] eq. 14–15 with identical cells), on the real Molicel P42A cell logs."""

from pathlib import Path

import numpy as np
import pytest

from planner.cli.commands.pack_scale import parse_cells
from planner.cli.main import main
from planner.errors import InputError
from planner.io.record import read_record
from planner.parameters import load_battery
from planner.physics.battery import integral

REPO = Path(__file__).resolve().parents[3]
TRAIN = [f"raw/set1/{c}_cell_{kind}.txt" for c in (1, 2, 3, 4) for kind in ("cycle", "storage")]
VALIDATE = [f"raw/set1/{c}_cell_{kind}.txt" for c in (5, 6) for kind in ("cycle", "storage")]


def test_p42a_cell_fit_scaled_to_4s2p_predicts_the_pack_of_its_cells(tmp_path, shared_data,
                                                                      capsys):
    """The 4S2P file drawn from the cells' fit gives, on any power profile, twice the charge
    the cell model gives at an eighth of the power: checked on a real validation discharge
    (cell 5 at 1C), its power × 8. Capacity is twice the cell's; ε and β are the cell's."""
    src = shared_data / "battery" / "molicel_p42a" / "p42a_discharge_segments_derived.csv"
    record = tmp_path / "p42a.csv"
    assert main(["export", str(src), "--map", str(REPO / "planner/io/logs/maps/molicel_p42a.yaml"),
                 "--csv", str(record)]) == 0
    common = ["--fix-beta", "0.9648", "--train", ",".join(TRAIN),
              "--validate", ",".join(VALIDATE)]
    cell_yaml, pack_yaml = tmp_path / "cell.yaml", tmp_path / "pack.yaml"
    assert main(["fit-battery", str(record), "--out", str(cell_yaml), "--name", "P42A cell",
                 "--mass-kg", "0.07", "--cells", "1", "--capacity-mah", "4200",
                 "--chemistry", "liion", *common]) == 0
    out = capsys.readouterr().out
    # the datasheet's nominal is written; what was measured, and to which cut-off, is said
    assert "4200 mAh nominal (given)" in out and "to the cut-off 2.50 V/cell" in out
    assert main(["fit-battery", str(record), "--out", str(pack_yaml), "--name", "P42A 4S2P",
                 "--mass-kg", "0.62", "--cells", "4x2", *common]) == 0
    out = capsys.readouterr().out
    assert "scaled from one cell to 4S2P" in out
    assert "written as the capacity (give --capacity-mah for the nominal)" in out
    cell, pack = load_battery(cell_yaml), load_battery(pack_yaml)
    assert cell.capacity_mah == 4200 and cell.chemistry == "liion"
    assert cell.cell_voltage_empty_v == pytest.approx(2.5, abs=0.02)
    cell = load_battery(cell_yaml)
    assert (pack.cells_series, pack.cells_parallel) == (4, 2)
    # the pack's charge: twice the most a cell drew (3.9–4.0 Ah at 1C, PROVENANCE.md)
    assert 2 * 3900 < pack.capacity_mah < 2 * 4050
    assert (pack.model.epsilon, pack.model.beta) == (cell.model.epsilon, cell.model.beta)
    # δ (S·P)^−ε P^−β: about 8^0.98 / 2^0.96 ≈ 4 times the cell's
    assert 3.5 < pack.model.delta / cell.model.delta < 4.5
    # the real cell-5 discharge, flown by the pack at 8 × the power
    data = read_record(record)
    exp = data[data["experiment"] == VALIDATE[0]]
    t = exp["time_s"].to_numpy(float)
    p_cell = exp["power_w"].to_numpy(float)
    m_c, m_p = cell.model, pack.model
    c_cell = integral.charge(t, p_cell, m_c.delta, m_c.epsilon, m_c.beta)
    c_pack = integral.charge(t, 8 * p_cell, m_p.delta, m_p.epsilon, m_p.beta)
    assert c_cell[-1] > 0
    assert np.allclose(c_pack, 2 * c_cell, rtol=1e-9, atol=1e-9)


def test_scaling_grows_delta_with_the_cells_as_the_literature_start_values_do():
    """[UAV23] eq. 16–17: δ₀(4)/δ₀(2) = 2.17; the scaling with ε₀(3) gives 2.05 (the
    polynomials are fits over many packs, the scaling assumes identical cells)."""
    eps = integral.literature_epsilon(3)
    ratio = (integral.scale_to_pack(1.0, eps, 1.0, 4) / integral.scale_to_pack(1.0, eps, 1.0, 2))
    assert ratio == pytest.approx(integral.literature_delta(4) / integral.literature_delta(2),
                                  rel=0.07)


@pytest.mark.parametrize("text, want", [("4", (4, None)), ("4x2", (4, 2)), ("4×2", (4, 2)),
                                        ("4S2P", (4, 2)), ("6 x 1", (6, 1))])
def test_cells_option_reads_a_count_or_an_arrangement(text, want):
    assert parse_cells(text) == want


@pytest.mark.parametrize("text", ["four", "4x", "0x2", "41", "4x0"])
def test_cells_option_refuses_anything_else_with_one_line(text):
    with pytest.raises(InputError, match="--cells"):
        parse_cells(text)
