"""The layers of docs/architecture.md, held by the code itself.

* physics modules import numpy, scipy, numba, pandas (for its types) and each other only —
  no YAML, no file I/O, no plotting, no command-line words, no parameter files;
* definition files are read by :mod:`planner.parameters` only;
* the runtime never imports the test tooling (``testkit``);
* no library module selects a matplotlib backend;
* docstrings carry no control characters (a backslash in a non-raw docstring).
"""

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PLANNER = REPO / "planner"

#: The physics layer (docs/architecture.md).
PHYSICS = sorted(
    [PLANNER / "atmosphere.py", PLANNER / "units.py", PLANNER / "wind.py",
     PLANNER / "stats.py", PLANNER / "mission/geo.py", PLANNER / "mission/legs.py"]
    + list((PLANNER / "power").glob("*.py"))
    + [PLANNER / "battery" / f"{m}.py" for m in
       ("integral", "circuit", "thermal", "ocv", "supercap", "hybrid", "design", "vda")])
PHYSICS_MODULES = {".".join(p.relative_to(REPO).with_suffix("").parts) for p in PHYSICS}
THIRD_PARTY_OK = {"numpy", "scipy", "numba", "pandas"}
STDLIB_OK = {"__future__", "math", "dataclasses", "typing", "collections", "functools",
             "itertools", "warnings", "enum"}
#: Calls that read or write files, parse YAML or draw.
IO_CALLS = {"open", "read_csv", "to_csv", "read_text", "write_text", "read_bytes",
            "write_bytes", "safe_load", "load_yaml", "savefig", "to_parquet", "read_parquet"}


def imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            out.add(node.module)
            out.update(f"{node.module}.{a.name}" for a in node.names)
    return out


def calls(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            names.add(f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", ""))
    return names


@pytest.mark.parametrize("path", PHYSICS, ids=lambda p: str(p.relative_to(REPO)))
def test_physics_imports_only_numerics_and_physics(path):
    bad = []
    for name in imports(path):
        top = name.split(".")[0]
        if top == "planner":
            module = name if name in PHYSICS_MODULES else name.rsplit(".", 1)[0]
            if module not in PHYSICS_MODULES | {"planner.errors", "planner", "planner.power",
                                                "planner.battery", "planner.mission"}:
                bad.append(name)
        elif top not in THIRD_PARTY_OK | STDLIB_OK:
            bad.append(name)
    assert not bad, f"{path.name} imports {sorted(bad)}"


@pytest.mark.parametrize("path", PHYSICS, ids=lambda p: str(p.relative_to(REPO)))
def test_physics_reads_and_writes_no_files(path):
    assert not calls(path) & IO_CALLS, f"{path.name} calls {sorted(calls(path) & IO_CALLS)}"


def test_the_layering_test_would_catch_a_physics_module_reading_yaml(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import yaml\nfrom planner import schema\n"
                   "def f(p):\n    return yaml.safe_load(open(p))\n")
    assert {"yaml", "planner.schema"} <= imports(bad)
    assert {"open", "safe_load"} <= calls(bad)


def test_definition_files_are_read_by_the_parameters_package_only():
    """YAML is read by the parameters package (definition files: aircraft, pack, catalog,
    column map) and the YAML mission reader, through planner.files only."""
    readers = set()
    for path in PLANNER.rglob("*.py"):
        if "load_yaml" in calls(path) or "safe_load" in calls(path):
            readers.add(str(path.relative_to(PLANNER)))
    allowed = {"parameters/pack.py", "parameters/aircraft.py", "parameters/catalog.py",
               "parameters/__init__.py", "parameters/columnmap.py", "schema.py",
               "mission/yaml_mission.py"}
    assert readers <= allowed, readers - allowed
    for path in PLANNER.rglob("*.py"):
        assert "safe_load" not in calls(path), path   # only the bounded loader of files.py


def test_the_runtime_never_imports_the_test_tooling():
    for path in PLANNER.rglob("*.py"):
        assert not any(n.split(".")[0] == "testkit" for n in imports(path)), path


def test_no_library_module_selects_a_matplotlib_backend():
    for path in PLANNER.rglob("*.py"):
        assert "use" not in {c for c in calls(path)} or "matplotlib" not in imports(path), path
        assert "matplotlib.pyplot" not in imports(path), path


def test_docstrings_have_no_control_characters():
    """A backslash sequence like \\f or \\t in a non-raw docstring corrupts its equation."""
    for path in PLANNER.rglob("*.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef,
                                 ast.AsyncFunctionDef)):
                doc = ast.get_docstring(node, clean=False) or ""
                bad = [c for c in doc if ord(c) < 32 and c not in "\n"]
                assert not bad, (path.relative_to(REPO), getattr(node, "name", "module"),
                                 [hex(ord(c)) for c in bad])


def test_every_citation_key_resolves():
    """``[UAV23] eq. 14``, ``[HESS] eq. 11``: each key used in the package is one of
    planner.references, so no citation is ambiguous between the two seed papers."""
    import re

    from planner.references import REFERENCES

    used = set()
    for path in PLANNER.rglob("*.py"):
        used |= set(re.findall(r"\[([A-Z][A-Z0-9]+)\] (?:eq|Table|Fig)\.?", path.read_text()))
    assert used and used <= set(REFERENCES), used - set(REFERENCES)
    assert {"UAV23", "HESS"} <= used
