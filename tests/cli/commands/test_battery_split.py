"""fit-battery's split: a typo in --train is named as such with every experiment of the
data, and a stress test too short to fit is left out of a default split with a note,
not an abort."""

import numpy as np
import pandas as pd
import pytest

from battery_generators import constant
from planner.cli.main import main


@pytest.fixture
def bench_with_a_stub(tmp_path):
    rng = np.random.default_rng(5)
    runs = [constant(f"p{int(p):03d}", p, 2.0e5 / p, rng=rng) for p in (50, 90, 125)]
    stub = constant("stress_40A", 400.0, 4.0, rng=rng)      # a few samples only
    path = tmp_path / "bench.csv"
    pd.concat(runs + [stub]).to_csv(path, index=False)
    return path


def fit(path, tmp_path, *extra):
    return main(["fit-battery", str(path), "--out", str(tmp_path / "p.yaml"), "--name", "x",
                 "--cells", "4", "--mass-kg", "0.8", *extra])


def test_default_split_leaves_a_too_short_experiment_out_with_a_note(bench_with_a_stub,
                                                                      tmp_path, capsys):
    assert fit(bench_with_a_stub, tmp_path) == 0
    out = capsys.readouterr().out
    assert "note: left out of the fit:" in out and "stress_40A" in out and "too short" in out
    assert "train: p050, p125" in (tmp_path / "p.yaml").read_text()


def test_a_typo_in_train_is_named_with_every_experiment(bench_with_a_stub, tmp_path, capsys):
    assert fit(bench_with_a_stub, tmp_path, "--train", "p050,p12") == 2
    err = capsys.readouterr().err
    assert "--train: no experiment named 'p12'" in err
    assert all(name in err for name in ("p050", "p090", "p125", "stress_40A"))
    assert "too short" not in err and len(err.strip().splitlines()) == 1


def test_a_too_short_experiment_chosen_for_training_is_still_an_error(bench_with_a_stub,
                                                                       tmp_path, capsys):
    assert fit(bench_with_a_stub, tmp_path, "--train", "p050,stress_40A") == 2
    assert "stress_40A" in capsys.readouterr().err
