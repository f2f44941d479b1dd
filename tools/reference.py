"""Write the generated parts of ``docs/formats.md`` and ``docs/record.md`` from the code.

The key tables of the definition files (every key, its type, whether it is required,
its default and its allowed range) and the flight record's columns are read from the
schemas the loaders validate with (:mod:`planner.parameters`, :mod:`planner.io.record`,
:mod:`planner.io.mission.yaml_mission`), so the reference cannot drift from what the
planner accepts. Text between ``<!-- generated: NAME -->`` and ``<!-- end -->`` is
replaced; the rest of each page is written by hand.

Run::

    python tools/reference.py [--check]

``--check`` exits 1 when a page is out of date (CI runs it through the tests).
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

_UNITS = [("_mah", "mAh"), ("_kg", "kg"), ("_ms", "m/s"), ("_m2", "m²"), ("_w", "W"),
          ("_ohm", "Ω"), ("_v", "V"), ("_c", "°C"), ("_deg", "deg"), ("_s", "s"),
          ("_m", "m"), ("_pa", "Pa"), ("_n", "N"), ("_f", "F"), ("_per_c", "1/°C"),
          ("_k_per_w", "K/W"), ("_j_per_k", "J/K")]


def _default_text(entry) -> str:
    """A navigation default as the table shows it: ``–`` where the autopilot has none (the
    key's fallback holds)."""
    if entry is None:
        return "–"
    value = entry[0]
    return f"{value!s}".lower() if isinstance(value, bool) else f"{value:g}"


def _unit(key: str) -> str:
    best = ""
    for suffix, unit in _UNITS:
        if key.endswith(suffix) and len(suffix) > len(best):
            best = suffix
    return dict(_UNITS).get(best, "") if best else ""


def _num(x) -> str:
    if isinstance(x, float) and (x != 0 and (abs(x) >= 1e5 or abs(x) < 1e-3)):
        return f"{x:.3g}"
    return f"{x:g}" if isinstance(x, float) else str(x)


def _range(k) -> str:
    if k.choices:
        return " \\| ".join(f"`{c}`" for c in k.choices)
    if k.low is None and k.high is None:
        return ""
    lo = "" if k.low is None else ("(" if k.low_open else "[") + _num(k.low)
    hi = "" if k.high is None else _num(k.high) + (")" if k.high_open else "]")
    if k.low is None:
        return f"≤ {hi[:-1]}" if not k.high_open else f"< {hi[:-1]}"
    if k.high is None:
        return f"> {_num(k.low)}" if k.low_open else f"≥ {_num(k.low)}"
    return f"{lo} … {hi}"


def key_table(keys: dict, prefix: str = "") -> str:
    """The reference table of a key table: each key's type, unit, default, bound and
    meaning, as the loader declares them (:class:`planner.io.schema.Key`)."""
    rows = ["| key | type | unit | required / default | allowed | meaning |",
            "|---|---|---|---|---|---|"]
    for name, k in keys.items():
        if k.required:
            need = "required"
        elif k.default is None:
            need = "optional"
        else:
            d = k.default
            need = f"default {_num(d) if isinstance(d, (int, float)) and not isinstance(d, bool) else d}"
            if isinstance(d, float) and math.isnan(d):
                need = "optional"
        rows.append(f"| `{prefix}{name}` | {k.kind} | {k.unit} | {need} | {_range(k)} "
                    f"| {k.meaning} |")
    return "\n".join(rows)


def list_table(keys, prefix: str = "") -> str:
    """A table of key names with the unit their name ends in (the mission keys)."""
    return "\n".join(["| key | unit |", "|---|---|"]
                     + [f"| `{prefix}{k}` | {_unit(k)} |" for k in keys])


def sections() -> dict[str, str]:
    from planner.io import record
    from planner.io.mission import yaml_mission as ym
    from planner.parameters import aircraft, blocks, catalog, pack
    from planner.io.logs import columnmap

    out = {
        "aircraft": key_table(aircraft.AIRCRAFT_KEYS),
        "fixed_wing": key_table(aircraft.FIXED_WING_KEYS, "fixed_wing."),
        "multirotor": key_table(aircraft.MULTIROTOR_KEYS, "multirotor."),
        "navigation": key_table(aircraft.NAVIGATION_KEYS, "navigation.") + "\n\n"
        + "\n".join(["| key | " + " | ".join(f"`{a}`" for a in aircraft.AUTOPILOTS) + " |",
                     "|---|" + "---|" * len(aircraft.AUTOPILOTS)]
                    + [f"| `{k}` | " + " | ".join(
                        _default_text(aircraft.NAVIGATION_DEFAULTS[a].get(k))
                        for a in aircraft.AUTOPILOTS) + " |"
                       for k in dict.fromkeys(k for a in aircraft.AUTOPILOTS
                                              for k in aircraft.NAVIGATION_DEFAULTS[a])]),
        "pack": key_table(pack.BATTERY_KEYS),
        "model": key_table(pack.MODEL_KEYS, "model."),
        "circuit": key_table(blocks.CIRCUIT_KEYS, "circuit."),
        "thermal": key_table(blocks.THERMAL_KEYS, "thermal."),
        "catalog": key_table(catalog.CATALOG_KEYS) + "\n\nA pack entry is a pack mapping "
        "(the keys above) or a reference to a pack file:\n\n"
        + key_table(catalog.REFERENCE_KEYS, "packs[i]."),
        "mission_top": list_table(ym.TOP_KEYS),
        "mission_environment": list_table(ym.ENVIRONMENT_KEYS, "environment."),
        "mission_home": list_table(ym.HOME_KEYS, "home."),
        "mission_waypoint": list_table(ym.WAYPOINT_KEYS, "waypoints[i]."),
        "mission_legs": "\n".join(["| leg kind | parameters |", "|---|---|"] + [
            f"| `{kind}` | " + ", ".join(f"`{p}`" + (f" [{_unit(p)}]" if _unit(p) else "")
                                          for p in params) + " |"
            for kind, params in ym.LEG_KEYS.items()]),
        "columnmap": "\n\n".join(
            [key_table(columnmap.TOP_KEYS)]
            + [f"{title}:\n\n" + key_table(keys, prefix) for title, keys, prefix in (
                ("`time` (as a mapping)", columnmap.TIME_KEYS, "time."),
                ("each `columns.<record column>` (as a mapping)", columnmap.COLUMN_KEYS,
                 "columns.<c>."),
                ("each `derived.<record column>`", columnmap.DERIVED_KEYS, "derived.<c>."),
                ("each `extra.<name>` (as a mapping)", columnmap.EXTRA_KEYS, "extra.<name>."),
                ("`meta`", columnmap.META_KEYS, "meta."),
                ("`flights` (a per-flight table joined by experiment id)",
                 columnmap.FLIGHTS_KEYS, "flights."))]),
        "record": "\n".join(["| column | unit | meaning |", "|---|---|---|"] + [
            f"| `{c.name}` | {c.unit} | {c.meaning} |" for c in record.COLUMNS.values()]),
    }
    return out


_BLOCK = re.compile(r"(<!-- generated: (\w+) -->\n)(.*?)(<!-- end -->)", re.S)


def render(text: str, parts: dict[str, str]) -> str:
    def fill(m):
        return m.group(1) + parts[m.group(2)] + "\n" + m.group(4)
    return _BLOCK.sub(fill, text)


PAGES = ("docs/formats.md", "docs/record.md")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if a page is out of date")
    args = ap.parse_args(argv)
    parts = sections()
    stale = []
    for page in PAGES:
        p = REPO / page
        text = p.read_text()
        new = render(text, parts)
        if new != text:
            stale.append(page)
            if not args.check:
                p.write_text(new)
    verb = "out of date" if args.check else "rewritten"
    print(f"reference: {len(PAGES)} pages, {len(stale)} {verb}"
          + (f": {', '.join(stale)}" if stale else ""))
    return 1 if args.check and stale else 0


if __name__ == "__main__":
    raise SystemExit(main())
