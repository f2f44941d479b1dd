"""The effect matrix of ``diagnose`` on real data, a seeded small sample.

The full matrix is ``python benchmarks/bench_effect_matrix.py`` (every effect × every real
source that can carry it × record richness × timing × size; figures in
docs/results.md). Here a few of its cells run on the real data of ``../shared/data``
with a fixed seed and few runs, and each must meet the issue's criterion for its kind
(:func:`testkit.matrix.verdict`): clean cells silent, cells the detection limit calls
identifiable named first, the others said to be not identifiable with no false cause.
The injections are physical laws of :mod:`testkit.injections`, which imports nothing of
the planner (checked below), so diagnose is examined on data its own models did not make.
"""

import ast
from pathlib import Path

import pytest

from testkit import matrix as M

REPO = Path(__file__).resolve().parents[3]

#: (cell, runs): real Molicel P42A discharges and 16 real DJI M100 flights.
SAMPLE = [
    (M.Cell("p42a", "fade", "everything", None, "realistic"), 4),
    (M.Cell("p42a", "cold_cells", "everything", None, "realistic"), 4),
    (M.Cell("p42a", "cold_cells", "plain", None, "realistic"), 3),
    (M.Cell("p42a", "offset", "minimal", None, "realistic"), 3),
    (M.Cell("a123", "real_cold", "everything", None, "realistic"), 1),
    (M.Cell("m100", "clean", "plain", None, "realistic"), 2),
]


@pytest.fixture(scope="module")
def draws(shared_data):
    if not M.available():
        pytest.skip(f"the M100 flights and logs are not at {M.DATA}")
    return {}


@pytest.mark.parametrize("cell, runs", SAMPLE, ids=[c.name for c, _ in SAMPLE])
def test_a_seeded_cell_of_the_effect_matrix_meets_the_criterion(cell, runs, draws):
    st = M.run_cell(cell, runs, seed=0, draws=draws)
    assert not st["errors"], dict(st["errors"])
    kind, met = M.verdict(st)
    assert met, (kind, {k: st[k] for k in ("named_first", "named_any", "false_runs",
                                            "identifiable", "said_not_identifiable",
                                            "within_2se", "checked_2se", "limits",
                                            "sizes")})
    if kind == "not identifiable":
        # a miss is never silent: the output says the effect cannot be seen in these data
        assert st["said_not_identifiable"] == st["runs"] - st["named_any"]
    assert max(st["cpu_s"]) < 5.0


def test_the_injection_laws_import_nothing_of_the_planner():
    """The examiner's rule: the effects are injected by laws written in testkit, not by
    the planner's own power or battery models."""
    tree = ast.parse((REPO / "testkit" / "injections.py").read_text())
    imported = [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    imported += [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    assert imported and not [m for m in imported if m.split(".")[0] == "planner"]


def test_verdict_follows_the_issue_criterion():
    base = {"runs": 10, "errors": {}, "named_first": 0, "named_any": 0, "false_runs": 0,
            "identifiable": 0, "said_not_identifiable": 0, "within_2se": 0,
            "checked_2se": 0, "silent": 10, "expect": None}
    assert M.verdict(base) == ("clean", True)
    assert M.verdict(dict(base, silent=9)) == ("clean", False)          # 90 % < 95 %
    ident = dict(base, expect="wind", identifiable=10, named_first=8, named_any=8,
                 within_2se=5, checked_2se=8)
    assert M.verdict(ident) == ("identifiable", True)
    assert M.verdict(dict(ident, named_first=7)) == ("identifiable", False)
    assert M.verdict(dict(ident, within_2se=3)) == ("identifiable", False)
    hidden = dict(base, expect="wind", said_not_identifiable=10)
    assert M.verdict(hidden) == ("not identifiable", True)
    assert M.verdict(dict(hidden, said_not_identifiable=9)) == ("not identifiable", False)
    assert M.verdict(dict(hidden, false_runs=1)) == ("not identifiable", False)
