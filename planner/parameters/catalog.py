"""Pack catalogs for ``select``: a YAML file with a ``packs:`` list, or a folder of packs.

A catalog entry is either a whole pack (the keys of a pack file, docs/formats.md) or a
reference to a pack file, ``{file: ../batteries/x.yaml}`` (path relative to the catalog),
optionally with its own ``count`` and ``price``: a pack that has a file is described
there once, and ``select`` and ``check`` fly the same pack.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from planner.errors import InputError
from planner.io import files
from planner.io import schema as S
from planner.parameters.pack import (
    BATTERY_KEYS,
    BatteryPack,
    battery_from_mapping,
    load_battery,
)

__all__ = ["CATALOG_KEYS", "REFERENCE_KEYS", "catalog_from_mapping", "load_catalog"]

#: Keys of a catalog entry that references a pack file.
REFERENCE_KEYS = {
    "file": S.text("the pack file, relative to the catalog", required=True),
    # the pack file's own keys, given again to change them for this entry: same bounds
    "count": replace(BATTERY_KEYS["count"], default=None,
                     meaning=BATTERY_KEYS["count"].meaning + " (absent: the file's)"),
    "price": replace(BATTERY_KEYS["price"],
                     meaning=BATTERY_KEYS["price"].meaning + " (absent: the file's)"),
}

#: Top-level keys of a catalog file.
CATALOG_KEYS = {
    "packs": S.Key(S.LIST, required=True, meaning=(
        "the packs: each a pack mapping (the keys of a pack file) or a file reference")),
    "name": S.text("name of the catalog"),
    "source": S.text("where the numbers come from"),
}


def _referenced(item: dict, entry: str, base: Path) -> BatteryPack:
    """A catalog entry ``{file: PATH, count: N, price: X}``: the pack file, loaded."""
    d = S.check_mapping(item, REFERENCE_KEYS, entry)
    path = Path(d["file"])
    if not path.is_absolute():
        path = base / path
    try:
        pack = load_battery(path)
    except InputError as exc:
        raise InputError(f"{entry}: {exc}") from None
    changes = {key: d[key] for key in ("count", "price") if d[key] is not None}
    return replace(pack, **changes) if changes else pack


def catalog_from_mapping(data: Any, where: str, base_dir: str | Path | None = None
                         ) -> list[BatteryPack]:
    """Validate a catalog mapping (``packs:`` list of packs, :data:`CATALOG_KEYS`) and build
    the packs.

    Each pack is validated with :func:`planner.parameters.pack.battery_from_mapping`
    (or loaded from the file it references) under the name ``"{where}: packs[i]"``,
    counted from 1; every problem of every pack is reported at once in one line.
    Relative paths are read from ``base_dir`` (default: the folder of ``where``).

    Raises
    ------
    InputError
        A missing or empty ``packs`` list, an unknown top-level key, or any problem in
        any pack (``catalog.yaml: packs[3]: mass_kg must be > 0, got -1``).
    """
    S.refuse_other_kind(data, "pack catalog", where)
    d = S.check_mapping(data, CATALOG_KEYS, where)
    items = d["packs"]
    if not items:
        raise InputError(f"{where}: 'packs' is empty, expected a list of battery packs")
    base = Path(base_dir) if base_dir is not None else Path(where).parent
    packs, problems = [], []
    for i, item in enumerate(items):
        entry = f"{where}: packs[{i + 1}]"
        try:
            if isinstance(item, dict) and "file" in item:
                packs.append(_referenced(item, entry, base))
            else:
                packs.append(battery_from_mapping(item, entry, base))
        except InputError as exc:
            problems.append(str(exc))
    if problems:
        raise InputError("; ".join(problems))
    return packs


def load_catalog(path: str | Path) -> list[BatteryPack]:
    """Load a pack catalog: a YAML file with a ``packs:`` list, or a folder of pack files.

    Parameters
    ----------
    path : str or Path
        A catalog file (``packs:`` list of battery mappings, docs/formats.md, each with
        optional ``price`` and ``count``), a single pack file (a catalog of one), or a
        folder whose ``*.yaml``/``*.yml`` files are single packs or catalogs themselves
        (read in name order).

    Returns
    -------
    list of BatteryPack
    """
    path = Path(path)
    if path.is_dir():
        found = sorted(p for p in path.iterdir()
                       if p.suffix.lower() in (".yaml", ".yml") and p.is_file())
        if not found:
            raise InputError(f"{path}: folder holds no pack files (*.yaml)")
        packs, problems = [], []
        for f in found:
            try:
                data = files.load_yaml(f, empty_ok=False)
                if isinstance(data, dict) and "packs" in data:
                    packs.extend(catalog_from_mapping(data, str(f)))
                else:
                    packs.append(battery_from_mapping(data, str(f)))
            except InputError as exc:
                problems.append(str(exc))
        if problems:
            raise InputError("; ".join(problems))
        return packs
    data = files.load_yaml(path, empty_ok=False)
    if isinstance(data, dict) and "packs" not in data and any(
            k in data for k in S.KIND_MARKERS["battery pack"]):
        return [battery_from_mapping(data, str(path))]        # one pack: a catalog of one
    return catalog_from_mapping(data, str(path))
