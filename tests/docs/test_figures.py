"""Every figure the README and docs print is reproduced by its documented command.

``tools/figures.py`` reruns each ``$ endurance`` transcript of README.md and docs/*.md and
compares the printed lines; ``tools/reference.py`` checks that the generated key and
column tables of docs/formats.md and docs/record.md match the schemas the loaders use.
Transcripts that read ``../shared/data`` are skipped where it is absent.
"""

import pytest

from tools import figures, reference

TRANSCRIPTS = figures.transcripts()


def test_the_documents_hold_transcripts():
    docs = {t.doc.name for t in TRANSCRIPTS}
    assert {"README.md", "commands.md"} <= docs and len(TRANSCRIPTS) >= 6


@pytest.mark.parametrize("t", TRANSCRIPTS, ids=[f"{t.doc.name}:{t.line}" for t in TRANSCRIPTS])
def test_documented_output_reproduces(t):
    status, problems = figures.run(t)
    if status.startswith("skipped"):
        pytest.skip(status)
    assert status == "ok", "\n".join(problems)


def test_a_drifted_figure_is_caught():
    expected = ["GO: lands with 71.2 % (reserve 20 %)", "...", "Total 9.0 min"]
    assert figures.compare(expected, "Total   9.0 min\nGO: lands with 71.2 % (reserve 20 %)\n")
    assert not figures.compare(expected, "GO: lands with 71.2 %  (reserve 20 %)\nx\nTotal 9.0 min")
    assert figures.compare(["margin +2298 mAh"], "margin +2297 mAh")


def test_generated_reference_tables_are_current():
    assert reference.main(["--check"]) == 0
