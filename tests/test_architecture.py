"""The layers of docs/architecture.md, held by the code itself.

A folder of ``planner/`` is a layer; each may import only its own modules and the layers
below it (:data:`LAYERS`, lowest first), and :mod:`planner.errors`:

* physics imports numpy, scipy, numba, pandas (for its types) and itself only — no YAML,
  no file I/O, no plotting, no command-line words, no parameter files;
* definition files are read through :func:`planner.io.files.load_yaml` by the readers of
  definitions only;
* no flag name (``--…``) and no matplotlib outside ``planner/cli``;
* no private name (``_x``) is imported from, or reached into, another module;
* the runtime never imports the test tooling (``testkit``) and the tests never import
  the benchmarks;
* docstrings carry no control characters (a backslash in a non-raw docstring).
"""

import ast
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PLANNER = REPO / "planner"

#: The layers, lowest first: a module may import its own layer and those before it.
LAYERS = ("physics", "io", "parameters", "chain", "identify", "fleet", "cli")
#: Modules at the top of the package, importable from every layer.
SHARED = {"planner", "planner.errors"}
SOURCES = sorted(p for p in PLANNER.rglob("*.py") if "__pycache__" not in p.parts)
PHYSICS = [p for p in SOURCES if p.relative_to(PLANNER).parts[0] == "physics"]
THIRD_PARTY_OK = {"numpy", "scipy", "numba", "pandas"}
STDLIB_OK = {"__future__", "math", "dataclasses", "typing", "collections", "functools",
             "itertools", "warnings", "enum", "types"}
#: Calls that read or write files, parse YAML or draw.
IO_CALLS = {"open", "read_csv", "to_csv", "read_text", "write_text", "read_bytes",
            "write_bytes", "safe_load", "load_yaml", "savefig", "to_parquet", "read_parquet"}


def module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p) for p in SOURCES}


def layer_of(module: str) -> int | None:
    """Index of the layer of ``planner.<layer>…`` (None: a shared top-level module)."""
    parts = module.split(".")
    if len(parts) < 2 or parts[1] not in LAYERS:
        return None
    return LAYERS.index(parts[1])


def imported(path: Path) -> list[tuple[str, str, int]]:
    """(module, name or "", line) of every import of ``path`` (names of ``from`` imports)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, "", node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            out += [(node.module, a.name, node.lineno) for a in node.names]
    return out


def imports(path: Path) -> set[str]:
    out = set()
    for module, name, _ in imported(path):
        out.add(module)
        if name:
            out.add(f"{module}.{name}")
    return out


def calls(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            names.add(f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", ""))
    return names


def crossings(path: Path) -> list[str]:
    """Imports of ``path`` that reach a layer above its own."""
    own = layer_of(module_name(path))
    bad = []
    for module, name, line in imported(path):
        if not module.startswith("planner"):
            continue
        target = f"{module}.{name}" if f"{module}.{name}" in MODULES else module
        theirs = layer_of(target)
        if own is not None and theirs is not None and theirs > own:
            bad.append(f"{path.relative_to(REPO)}:{line} imports {target} "
                       f"({LAYERS[theirs]} is above {LAYERS[own]})")
        if own is None and module_name(path) not in ("planner.__main__",) and \
                theirs is not None:
            bad.append(f"{path.relative_to(REPO)}:{line}: a shared module imports {target}")
    return bad


def test_the_package_top_holds_the_layers_and_few_else():
    top = sorted(p.name for p in PLANNER.iterdir() if p.name != "__pycache__")
    assert len(top) <= 10, top
    assert set(LAYERS) <= set(top)


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(REPO)))
def test_no_module_imports_a_layer_above_its_own(path):
    assert not crossings(path)


def test_the_layer_test_catches_a_crossing(tmp_path):
    bad = PLANNER / "physics" / "_crossing_probe.py"
    try:
        bad.write_text("from planner.chain.mission_chain import MissionChain\n")
        assert crossings(bad) and "chain is above physics" in crossings(bad)[0]
    finally:
        bad.unlink()


@pytest.mark.parametrize("path", PHYSICS, ids=lambda p: str(p.relative_to(REPO)))
def test_physics_imports_only_numerics_and_physics(path):
    bad = []
    for name in imports(path):
        top = name.split(".")[0]
        if top == "planner":
            if layer_of(name) not in (0, None) or (layer_of(name) is None and
                                                    name not in SHARED | {"planner.errors"}):
                if not name.startswith("planner.errors"):
                    bad.append(name)
        elif top not in THIRD_PARTY_OK | STDLIB_OK:
            bad.append(name)
    assert not bad, f"{path.name} imports {sorted(bad)}"


@pytest.mark.parametrize("path", PHYSICS, ids=lambda p: str(p.relative_to(REPO)))
def test_physics_reads_and_writes_no_files(path):
    assert not calls(path) & IO_CALLS, f"{path.name} calls {sorted(calls(path) & IO_CALLS)}"


def test_the_layering_test_would_catch_a_physics_module_reading_yaml(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import yaml\nfrom planner.io import schema\n"
                   "def f(p):\n    return yaml.safe_load(open(p))\n")
    assert {"yaml", "planner.io.schema"} <= imports(bad)
    assert {"open", "safe_load"} <= calls(bad)


def test_definition_files_are_read_by_the_readers_of_definitions_only():
    """YAML is read by the parameters package (aircraft, pack, catalog), the column maps
    and the YAML mission reader, through planner.io.files.load_yaml only."""
    readers = set()
    for path in SOURCES:
        if "load_yaml" in calls(path) or "safe_load" in calls(path):
            readers.add(str(path.relative_to(PLANNER)))
    allowed = {"parameters/pack.py", "parameters/aircraft.py", "parameters/catalog.py",
               "parameters/__init__.py", "io/logs/columnmap.py", "io/schema.py",
               "io/mission/yaml_mission.py"}
    assert readers <= allowed, readers - allowed
    for path in SOURCES:
        assert "safe_load" not in calls(path), path   # only the bounded loader of io.files


FLAG = re.compile(r"""(?<![\w-])--[a-z][a-z0-9-]+""")


def flag_literals(path: Path) -> list[str]:
    """String constants of ``path`` (docstrings aside) that hold a flag name."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docs = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef, ast.AsyncFunctionDef)):
            body = getattr(node, "body", [])
            if body and isinstance(body[0], ast.Expr) and isinstance(
                    getattr(body[0], "value", None), ast.Constant):
                docs.add(id(body[0].value))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and \
                id(node) not in docs and FLAG.search(node.value):
            out.append(f"{path.relative_to(REPO)}:{node.lineno}: {FLAG.search(node.value)[0]}")
    return out


def test_only_the_command_line_knows_flag_names():
    found = [f for p in SOURCES if p.relative_to(PLANNER).parts[0] != "cli"
             for f in flag_literals(p)]
    assert not found, "\n".join(found)


def test_the_flag_test_catches_a_flag_in_a_library_message(tmp_path):
    bad = tmp_path / "m.py"
    bad.write_text('"""Reads --csv files."""\n'
                   'def f():\n    raise ValueError("give --aircraft A.yaml")\n')
    assert [x.split(": ")[1] for x in flag_literals_at(bad)] == ["--aircraft"]


def flag_literals_at(path: Path) -> list[str]:
    text = path.read_text()
    tree = ast.parse(text)
    doc = ast.get_docstring(tree, clean=False)
    return [f"{path.name}:{n.lineno}: {FLAG.search(n.value)[0]}" for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str)
            and n.value != doc and FLAG.search(n.value)]


def test_no_matplotlib_outside_the_command_line():
    found = [str(p.relative_to(REPO)) for p in SOURCES
             if p.relative_to(PLANNER).parts[0] != "cli"
             and any(n.split(".")[0] == "matplotlib" for n in imports(p))]
    assert not found, found


def private_crossings(path: Path) -> list[str]:
    """``from planner.x import _y`` of another module, and ``mod._y`` on an imported
    planner module."""
    me = module_name(path)
    tree = ast.parse(path.read_text(encoding="utf-8"))
    aliases = {}
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and \
                (node.module or "").startswith("planner"):
            for a in node.names:
                full = f"{node.module}.{a.name}"
                if full in MODULES:
                    aliases[a.asname or a.name] = full
                elif a.name.startswith("_") and not a.name.startswith("__") and \
                        node.module != me:
                    bad.append(f"{path.relative_to(REPO)}:{node.lineno}: from {node.module} "
                               f"import {a.name}")
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("planner") and a.asname:
                    aliases[a.asname] = a.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and \
                node.value.id in aliases and node.attr.startswith("_") and \
                not node.attr.startswith("__"):
            bad.append(f"{path.relative_to(REPO)}:{node.lineno}: "
                       f"{aliases[node.value.id]}.{node.attr}")
    return bad


def test_no_private_name_crosses_a_module():
    found = [b for p in SOURCES for b in private_crossings(p)]
    assert not found, "\n".join(found)


def test_the_runtime_never_imports_the_test_tooling():
    for path in SOURCES:
        assert not any(n.split(".")[0] == "testkit" for n in imports(path)), path


def test_the_tests_never_import_the_benchmarks():
    tests = [p for p in (REPO / "tests").rglob("*.py") if "__pycache__" not in p.parts]
    found = [str(p.relative_to(REPO)) for p in tests
             if any(n.split(".")[0] == "benchmarks" for n in imports(p))
             or "benchmarks" in {c for c in calls(p)}]
    assert not found, found


def test_the_tests_mirror_the_package():
    """A module's tests are found by its path: ``tests/<layer>/…``."""
    loose = [p.name for p in (REPO / "tests").glob("test_*.py")
             if p.name != "test_architecture.py"]
    assert not loose, loose
    for sub in (REPO / "tests").iterdir():
        if sub.is_dir() and sub.name not in ("__pycache__", "helpers"):
            assert sub.name in LAYERS or sub.name in ("tools", "docs"), sub.name


def test_no_library_module_selects_a_matplotlib_backend():
    for path in SOURCES:
        assert "use" not in {c for c in calls(path)} or "matplotlib" not in imports(path), path
        assert "matplotlib.pyplot" not in imports(path), path


def test_docstrings_have_no_control_characters():
    """A backslash sequence like \\f or \\t in a non-raw docstring corrupts its equation."""
    for path in SOURCES:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.Module, ast.FunctionDef, ast.ClassDef,
                                 ast.AsyncFunctionDef)):
                doc = ast.get_docstring(node, clean=False) or ""
                bad = [c for c in doc if ord(c) < 32 and c not in "\n"]
                assert not bad, (path.relative_to(REPO), getattr(node, "name", "module"),
                                 [hex(ord(c)) for c in bad])


def _public_without_docstring(tree) -> list[str]:
    """Public functions, classes and methods of a module without a docstring."""
    out = []

    def walk(node, prefix):
        for n in ast.iter_child_nodes(node):
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                if n.name.startswith("_"):
                    continue
                if not ast.get_docstring(n):
                    out.append(f"{prefix}{n.name} (line {n.lineno})")
                if isinstance(n, ast.ClassDef):
                    walk(n, f"{prefix}{n.name}.")
    walk(tree, "")
    return out


def test_every_public_definition_has_a_docstring():
    """Every public function, class and method of the package says what it does."""
    missing = {str(path.relative_to(REPO)): names for path in SOURCES
               if (names := _public_without_docstring(ast.parse(path.read_text("utf-8"))))}
    assert not missing, missing


def test_the_docstring_test_catches_a_bare_method():
    tree = ast.parse("class A:\n    \"\"\"A.\"\"\"\n    def f(self):\n        return 1\n"
                     "    def _g(self):\n        return 2\n")
    assert _public_without_docstring(tree) == ["A.f (line 3)"]


def test_every_citation_key_resolves():
    """``[UAV23] eq. 14``, ``[HESS] eq. 11``: each key used in the package is one of
    planner.physics.references, so no citation is ambiguous between the two seed papers."""
    from planner.physics.references import REFERENCES

    used = set()
    for path in SOURCES:
        used |= set(re.findall(r"\[([A-Z][A-Z0-9]+)\] (?:eq|Table|Fig)\.?", path.read_text()))
    assert used and used <= set(REFERENCES), used - set(REFERENCES)
    assert {"UAV23", "HESS"} <= used


def test_no_reference_to_a_file_outside_the_repository():
    """The code cites equations by key and section of its own docs, never a file that is
    not in the repository (``DESIGN §n``)."""
    found = [f"{p.relative_to(REPO)}" for p in SOURCES if "DESIGN §" in p.read_text()]
    assert not found, found
