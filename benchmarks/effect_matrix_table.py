"""The effect matrix's JSON (``bench_effect_matrix.py --json F``) as the Markdown table of
``docs/results.md``, with the count of cells meeting the criterion by kind.

Columns: the cell (source/injection[/timing]/richness[/2x]); runs; % named first and
anywhere; % of runs with a false cause (which, how often; "own": the record's own
findings named, never a false cause); % of runs whose detection limit
calls the injected size identifiable; of the runs that missed the effect, those whose
output said it is not identifiable; runs with the named parameter within 2 SE of the truth
(of those checked); median injected size / median detection limit in the detection
entry's unit; median CPU seconds of diagnose per run; the verdict at realistic size
(:func:`testkit.matrix.verdict` on the cell's tallies);
then the count of cells meeting the criterion, the criterion read run by run
(:func:`testkit.matrix.run_by_run`) and how often an effect is named first against its
size over the run's own detection limit (:func:`testkit.matrix.limit_calibration`; JSON
files written since the tallies keep each run).

Run: ``python benchmarks/effect_matrix_table.py matrix.json [more.json …]`` (several files
are joined; a cell in a later file replaces the same cell of an earlier one).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from testkit import matrix as M  # noqa: E402

HEAD = ("| cell (source/injection[/timing]/richness) | runs | named first | named anywhere "
        "| false cause | limit calls it identifiable | said not identifiable (of misses) "
        "| within 2 SE | median size / limit | CPU s/run | verdict |")


def _pct(a: int, n: int) -> str:
    return f"{100 * a / n:.0f} %" if n else "–"


def _median(values) -> float:
    return float(np.median(values)) if values else math.nan


def markdown_row(st: dict) -> str:
    """One cell of the JSON as a row of the table."""
    n = max(st["runs"] - sum(st["errors"].values()), 0)
    name = st["cell"].removesuffix("/realistic")
    clean = st["expect"] is None
    which = [", ".join(f"{k} {v}" for k, v in sorted(st[key].items(), key=lambda kv: -kv[1]))
             for key in ("false", "own") if st.get(key)]
    if st.get("own"):
        which[-1] = "own: " + which[-1]
    false = _pct(st["false_runs"], n) + (f" ({'; '.join(which)})" if which else "")
    misses = n - st["named_any"]
    said = "–" if clean or misses == 0 else f"{st['said_not_identifiable']} of {misses}"
    se = "–" if not st["checked_2se"] else f"{st['within_2se']} of {st['checked_2se']}"
    size = "–" if clean else f"{_median(st['sizes']):.3g} / {_median(st['limits']):.3g}"
    cpu = _median(st["cpu_s"])
    if st.get("verdict") is None:
        verdict = "–"
    else:
        verdict = f"{st['verdict']}: " + ("met" if st["met"] else "**not met**")
    cells = [name, str(n), "–" if clean else _pct(st["named_first"], n),
             "–" if clean else _pct(st["named_any"], n), false,
             "–" if clean else _pct(st["identifiable"], n), said, se, size,
             f"{cpu:.2f}", verdict]
    return "| " + " | ".join(cells) + " |"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("json", nargs="+", help="JSON files written by bench_effect_matrix.py")
    args = ap.parse_args(argv)
    cells: dict[str, dict] = {}
    for path in args.json:
        for st in json.loads(Path(path).read_text()):
            if st.get("verdict") is not None:
                # the criterion as the code reads it now, not as when the JSON was written
                st["verdict"], st["met"] = M.verdict(st)
            cells[st["cell"]] = st
    print(HEAD)
    print("|" + "---|" * 11)
    for st in cells.values():
        print(markdown_row(st))
    real = [s for s in cells.values() if s.get("verdict") is not None]
    met = sum(1 for s in real if s["met"])
    kinds = ", ".join(f"{kind} {sum(1 for s in ks if s['met'])} of {len(ks)}"
                      for kind in ("clean", "identifiable", "not identifiable")
                      if (ks := [s for s in real if s["verdict"] == kind]))
    runs = sum(s["runs"] for s in cells.values())
    print(f"\n{met} of {len(real)} cells at realistic size meet the criterion ({kinds}); "
          f"{len(cells)} cells, {runs} runs.")
    by_run = M.run_by_run(list(cells.values()))
    if by_run["cells"]:
        print(M.run_by_run_text(by_run) + ".")
    cal = M.limit_calibration(list(cells.values()))
    if cal:
        print("\nNamed first against the injected size over the run's own detection limit "
              "(every size; runs with an infinite limit left out):\n")
        print("\n".join(M.limit_calibration_text(cal)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
