"""The worked example of docs/api.md runs as written (its Python blocks, in order)."""

import os
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_the_api_page_runs_as_written(capsys):
    text = (REPO / "docs/api.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert len(blocks) >= 4
    cwd = os.getcwd()
    os.chdir(REPO)
    try:
        namespace: dict = {}
        for block in blocks:
            exec(compile(block, "docs/api.md", "exec"), namespace)  # noqa: S102
    finally:
        os.chdir(cwd)
    out = capsys.readouterr().out
    assert "GO" in out and "margin" in out and "predicted mean power" in out
