"""Every number the README and docs print is reproducible by one command.

The documents show what commands print as transcripts: a fenced block whose first line is
``$ endurance …`` (continued over lines ending in ``\\``), followed by the output. This
script reruns every such command from the repository folder and compares: every line of
the documented output (whitespace aside) must appear in what the command prints now, in
the same order; a line ``...`` stands for lines left out. A command that reads
``../shared/data`` is skipped, with that reason, where the data is absent.

Run::

    python tools/figures.py [--check] [FILE.md ...]

Without ``--check`` it prints the report; with it, it exits 1 when any printed figure
drifted from the documents. The last line is the summary.
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared" / "data"
ELLIPSIS = {"...", "…"}
#: Options whose value is a file the command writes.
OUTPUT_OPTIONS = {"--out", "--json", "--plot", "--csv", "--params-out", "--sorties-out",
                  "--kml"}
#: ``--map`` writes a figure in check and select, and reads a column map elsewhere.
FIGURE_SUFFIXES = (".png", ".svg", ".pdf", ".jpg")
_RUN = "import sys; from planner.cli.main import main; sys.exit(main(sys.argv[1:]))"


@dataclass
class Transcript:
    """One documented command and its documented output."""

    doc: Path
    line: int
    command: str
    expected: list[str]


def documents() -> list[Path]:
    return [REPO / "README.md"] + sorted((REPO / "docs").glob("*.md"))


def transcripts(paths=None) -> list[Transcript]:
    """The ``$ endurance`` transcripts of the documents."""
    out = []
    for doc in paths or documents():
        lines = doc.read_text().splitlines()
        i = 0
        while i < len(lines):
            if lines[i].startswith("```") and i + 1 < len(lines) \
                    and lines[i + 1].startswith("$ endurance "):
                j = i + 1
                command = lines[j][2:]
                while command.endswith("\\"):
                    j += 1
                    command = command[:-1].rstrip() + " " + lines[j].strip()
                k = j + 1
                expected = []
                while k < len(lines) and not lines[k].startswith("```"):
                    expected.append(lines[k])
                    k += 1
                out.append(Transcript(doc, i + 2, command, expected))
                i = k
            i += 1
    return out


def _norm(line: str) -> str:
    return " ".join(line.split())


def compare(expected: list[str], actual: str) -> list[str]:
    """Documented lines missing from the output, in order (empty: it matches)."""
    got = [_norm(x) for x in actual.splitlines()]
    missing = []
    pos = 0
    for line in expected:
        want = _norm(line)
        if not want or want in ELLIPSIS:
            continue
        try:
            pos = got.index(want, pos) + 1
        except ValueError:
            near = [g for g in got if g[:12] == want[:12]]
            missing.append(f"documented: {line.strip()}\n      prints now: "
                           f"{near[0] if near else '(no such line)'}")
    return missing


def run(t: Transcript, timeout: float = 600.0) -> tuple[str, list[str]]:
    """Rerun a transcript: ("ok" | "skipped: why" | "drifted", problems)."""
    args = shlex.split(t.command)[1:]
    if any("../shared/data" in a for a in args) and not SHARED.is_dir():
        return "skipped: ../shared/data is absent", []
    env = dict(os.environ, COLUMNS="200")
    with tempfile.TemporaryDirectory(prefix="figures-") as tmp:
        # what the command writes goes to a scratch folder, never into the repository
        args = [str(Path(tmp) / Path(a).name) if prev in OUTPUT_OPTIONS or (
                    prev == "--map" and a.lower().endswith(FIGURE_SUFFIXES)) else a
                for prev, a in zip([""] + args[:-1], args)]
        p = subprocess.run([sys.executable, "-c", _RUN, *args], cwd=REPO,
                           capture_output=True, text=True, timeout=timeout, env=env,
                           check=False)
    problems = compare(t.expected, p.stdout)
    if p.returncode not in (0, 1):
        problems.insert(0, f"exit {p.returncode}: {p.stderr.strip()[-300:]}")
    return ("drifted" if problems else "ok"), problems


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="*", type=Path)
    ap.add_argument("--check", action="store_true",
                    help="exit 1 when a documented figure drifted")
    args = ap.parse_args(argv)
    items = transcripts([p.resolve() for p in args.files] or None)
    counts = {"ok": 0, "drifted": 0, "skipped": 0}
    for t in items:
        status, problems = run(t)
        where = f"{t.doc.relative_to(REPO)}:{t.line}"
        counts[status.split(":")[0]] += 1
        print(f"{status:<8} {where}  $ {t.command[:100]}")
        for problem in problems:
            print(f"    {problem}")
    print(f"figures: {len(items)} documented commands, {counts['ok']} reproduce, "
          f"{counts['drifted']} drifted, {counts['skipped']} skipped")
    return 1 if args.check and counts["drifted"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
