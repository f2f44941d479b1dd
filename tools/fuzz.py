"""The planner's fuzzer: damaged and hostile input through every command.

Seeded mutators make damaged copies of the shipped and real logs (bit flips, overwritten
ranges, truncation, duplicated and deleted chunks, huge length fields, garbage behind a
valid magic, empty files, and structure-aware damage: ULog format and subscription
messages, DataFlash FMT records, MAVLink frame lengths and ids, CSV rows) and hostile
copies of the definition and mission files (wrong types, extremes, NaN/inf, huge
numbers, YAML alias bombs, deep nesting, non-UTF-8 bytes, empty files, special files,
oversized files, thousands of legs and waypoints, waypoints at the pole or across the
antimeridian, ``.plan`` items with extreme parameters, hostile option values); damaged
flight-record CSVs (``records``: duplicated columns with different values, renamed and
dropped columns, units off by 10³ and 10⁶ or 10⁻³, time in microseconds, time jumps,
no-data sentinels such as −3.4e38, all-NaN columns, 1e308 and denormal magnitudes, rows
with extra or missing fields, shuffled rows, text in numeric cells, a header alone,
``.csv.gz`` whole, cut short, bit-flipped, with trailing bytes or two members) through
``replay``, ``fit-aircraft``, ``fit-battery`` and ``diagnose``; every command's output
options pointed at a read-only file or folder, a folder, ``/dev/null``, ``/dev/full``, a
link (to a writable or a read-only file, or dangling), a path in a missing folder, or
one of its inputs (``outputs``); numeric options typed in a wrong unit — grams for kg,
km/h for m/s, per cent for a fraction, °F for °C, feet for m, Ah for mAh — and the same
options in the right unit (``options``). Every case
runs one command (``export``, ``replay``, ``diagnose``, ``check``, ``select``,
``sweep``, ``hybrid``, ``fit-aircraft``, ``fit-battery``, ``bench``) in a forked worker with a CPU-time limit (and a wall-time limit
for runs blocked without working) and an address-space limit, and the fuzzer records the
exit status, any traceback, the CPU time, the peak memory
above the worker's start, whether any input changed, and whether a file was written
that the command was not asked to write.

A case **fails** when: the exit status is 3 (an internal error) or the worker died; it
ran past the time limit; its peak memory exceeded 3 × the input's size + 300 MB; an
input changed; a stray file appeared; an exit 2 did not print exactly one line naming
the file (or the option) it blames; input that is invalid by construction was given
a verdict (exit 0 or 1); input that is valid by construction was refused (exit 2); a
protected path (a read-only target, a link) was replaced or changed; or a verdict was
printed with ``nan`` or ``inf`` in it.

Run::

    python tools/fuzz.py [--cases N] [--seed S] [--jobs J] [--full]
                         [--only logs|defs|records|outputs|options ...]

``--full`` runs the full campaign (:data:`FULL`: 10 000 log cases, 5 000 definition
cases, 2 000 records, 600 output targets, 300 option values); ``--only`` (repeatable)
keeps the kinds named. A table of cases, failures and exit codes per kind and class, and
the slowest case and the one of largest memory with their commands, precede the summary,
the last line printed.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import resource
import shutil
import signal
import stat
import struct
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

#: CPU-time limit of one case (its own work, counted from the fork). [s]
TIME_LIMIT_S = 10.0
#: Wall-time limit of one case, which catches a run that waits without working (a
#: blocked read); the 10 s limit counts the CPU time of the case, so that a machine
#: shared with other work does not turn slow-but-finite runs into "hangs". [s]
WALL_LIMIT_S = 60.0
#: Memory allowance above the worker's start: 3 × input size + this. [bytes]
MEMORY_ALLOWANCE = 300 * 2**20
#: Hard address-space limit of a worker (protects the machine). [bytes]
ADDRESS_SPACE_LIMIT = 6 * 2**30


@dataclass
class Case:
    """One run: the command line, its input files, what it may write."""

    name: str
    kind: str                       # "logs", "defs", "records", "outputs" or "options"
    argv: list[str]
    inputs: list[str]
    outputs: list[str] = field(default_factory=list)
    invalid: bool = False           # invalid by construction: no verdict allowed
    blame: tuple[str, ...] = ()     # what an exit-2 line must name (any of)
    valid: bool = False             # valid by construction: exit 2 is a failure
    protected: list[str] = field(default_factory=list)  # must stay as they are (not replaced)
    folder: str | None = None       # where a stray file is looked for (default: the input's)


@dataclass
class Outcome:
    case: Case
    status: int
    seconds: float
    peak_bytes: int
    stderr: str
    failures: list[str]


# =========================================================================== mutators

def _bitflips(data: bytes, rng: random.Random) -> bytes:
    b = bytearray(data)
    for _ in range(rng.randint(1, 16)):
        i = rng.randrange(len(b))
        b[i] ^= 1 << rng.randrange(8)
    return bytes(b)


def _overwrite(data: bytes, rng: random.Random) -> bytes:
    b = bytearray(data)
    i = rng.randrange(len(b))
    n = rng.randint(1, 512)
    b[i:i + n] = rng.randbytes(min(n, len(b) - i))
    return bytes(b)


def _truncate(data: bytes, rng: random.Random) -> bytes:
    return data[:rng.randrange(len(data))]


def _duplicate(data: bytes, rng: random.Random) -> bytes:
    i = rng.randrange(len(data))
    n = rng.randint(1, 4096)
    return data[:i] + data[i:i + n] + data[i:]


def _delete(data: bytes, rng: random.Random) -> bytes:
    i = rng.randrange(len(data))
    return data[:i] + data[i + rng.randint(1, 4096):]


def _garbage_after_magic(data: bytes, rng: random.Random) -> bytes:
    keep = rng.choice([3, 8, 16, 64])
    return data[:keep] + rng.randbytes(rng.randint(0, 20000))


def _empty(data: bytes, rng: random.Random) -> bytes:
    return b""


def _ulog_structure(data: bytes, rng: random.Random) -> bytes:
    """Damage a ULog format ('F') or subscription ('A') message, or a size field."""
    b = bytearray(data)
    o, found = 16, []
    while o + 3 <= len(b) and len(found) < 5000:
        size, typ = struct.unpack_from("<HB", b, o)
        found.append((o, size, typ))
        o += 3 + size
    if not found:
        return _bitflips(data, rng)
    pick = rng.choice([m for m in found if m[2] in b"FA"] or found)
    o, size, typ = pick
    action = rng.randrange(4)
    if typ == ord("F") and action == 0:           # an array of itself, or huge
        text = bytes(b[o + 3:o + 3 + size]).split(b":")[0]
        extra = rng.choice([b"%s[65535] loop;" % text, b"uint8_t[999999] x;",
                            b"nosuchtype[3] y;", b"float[-5] z;"])
        b[o + 3:o + 3 + size] = bytes(b[o + 3:o + 3 + size]) + extra
        struct.pack_into("<H", b, o, min(0xFFFF, size + len(extra)))
    elif typ == ord("A") and action == 1 and size >= 3:
        struct.pack_into("<H", b, o + 4, rng.randrange(0x10000))     # another msg_id
    elif action == 2:
        struct.pack_into("<H", b, o, rng.choice([0, 1, 0xFFFF, rng.randrange(0x10000)]))
    else:
        b[o + 2] = rng.randrange(256)                                   # another type
    return bytes(b)


def _dataflash_structure(data: bytes, rng: random.Random) -> bytes:
    """Damage a DataFlash FMT record (type, length, format characters)."""
    b = bytearray(data)
    fmts = [i for i in range(len(b) - 89) if b[i] == 0xA3 and b[i + 1] == 0x95
            and b[i + 2] == 0x80][:2000]
    if not fmts:
        return _bitflips(data, rng)
    i = rng.choice(fmts)
    field_ = rng.randrange(3)
    if field_ == 0:
        b[i + 4] = rng.choice([0, 1, 2, 255, rng.randrange(256)])       # length
    elif field_ == 1:
        b[i + 9:i + 25] = rng.randbytes(16)                              # format chars
    else:
        b[i + 3] = rng.randrange(256)                                    # type id
    return bytes(b)


def _mavlink_structure(data: bytes, rng: random.Random) -> bytes:
    """Damage a MAVLink frame's length byte or message id (tlog)."""
    b = bytearray(data)
    starts = [i for i in range(8, len(b) - 12) if b[i] in (0xFE, 0xFD)][:5000]
    if not starts:
        return _bitflips(data, rng)
    i = rng.choice(starts)
    if rng.random() < 0.5:
        b[i + 1] = rng.randrange(256)
    else:
        j = i + (5 if b[i] == 0xFE else 7)
        b[j] = rng.randrange(256)
    return bytes(b)


def _csv_structure(data: bytes, rng: random.Random) -> bytes:
    """Damage rows of a CSV file: garbage values, NaN/inf, huge numbers, missing fields,
    a dropped header column, non-UTF-8 bytes."""
    lines = data.split(b"\n")
    if len(lines) < 3:
        return _bitflips(data, rng)
    for _ in range(rng.randint(1, 20)):
        k = rng.randrange(1, len(lines))
        cells = lines[k].split(b",")
        if not cells:
            continue
        j = rng.randrange(len(cells))
        cells[j] = rng.choice([b"nan", b"inf", b"-inf", b"1e308", b"-1e308", b"abc", b"",
                               b"\xff\xfe", b"9" * 400, b'"x,y"'])
        if rng.random() < 0.1:
            cells = cells[:-1]
        lines[k] = b",".join(cells)
    if rng.random() < 0.1:
        lines[0] = b",".join(lines[0].split(b",")[1:])
    return b"\n".join(lines)


LOG_MUTATORS = {
    "bitflip": _bitflips, "overwrite": _overwrite, "truncate": _truncate,
    "duplicate": _duplicate, "delete": _delete, "garbage_after_magic": _garbage_after_magic,
    "empty": _empty,
}
STRUCTURE = {".ulg": _ulog_structure, ".bin": _dataflash_structure,
             ".px4log": _dataflash_structure, ".tlog": _mavlink_structure,
             ".csv": _csv_structure}


# ----------------------------------------------------------------------- definitions

def _yaml_value(rng: random.Random) -> str:
    return rng.choice([".nan", ".inf", "-.inf", "1e308", "-1e308", "0", "-1", "1e-320",
                       "9" * 400, "'text'", "[]", "{}", "null", "true", "[1, 2, [3]]",
                       "0x7fffffffffffffff", "1_000", "12:30:00", "!!binary aGVsbG8="])


def _mutate_yaml_value(text: str, rng: random.Random) -> str:
    lines = text.splitlines()
    keyed = [i for i, line in enumerate(lines) if ":" in line and not
             line.lstrip().startswith("#") and not line.rstrip().endswith(":")]
    for _ in range(rng.randint(1, 3)):
        if not keyed:
            break
        i = rng.choice(keyed)
        key, _, _ = lines[i].partition(":")
        lines[i] = f"{key}: {_yaml_value(rng)}"
    return "\n".join(lines) + "\n"


def _alias_bomb(text: str, rng: random.Random) -> str:
    bomb = ["a0: &a0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for k in range(1, 10):
        prev = f"*a{k - 1}"
        bomb.append(f"a{k}: &a{k} [{', '.join([prev] * 9)}]")
    return text + "\n" + "\n".join(bomb) + "\n"


def _deep(text: str, rng: random.Random) -> str:
    depth = rng.choice([100, 1000, 5000])
    return text + "\ndeep: " + "[" * depth + "]" * depth + "\n"


DEF_MUTATORS = {
    "value": ("maybe", lambda t, r: _mutate_yaml_value(t, r)),
    "alias_bomb": ("invalid", _alias_bomb),
    "deep_nesting": ("invalid", _deep),
    "non_utf8": ("invalid", lambda t, r: t + "\nname: \udcff\udcfe\n"),
    "empty": ("invalid", lambda t, r: ""),
    "huge_comment": ("invalid", lambda t, r: t + "\n#" + "x" * (11 * 2**20) + "\n"),
    "tabs_and_junk": ("maybe", lambda t, r: t.replace("  ", "\t", r.randint(1, 3))),
    "truncated": ("maybe", lambda t, r: t[:r.randrange(max(len(t), 1))]),
}


def _many_legs(rng: random.Random) -> str:
    n = rng.choice([10_000, 20_001, 100_000])
    legs = "\n".join(f"  - cruise: {{distance_m: 50, course_deg: {i % 360}}}"
                     for i in range(n))
    return f"name: many legs\nlegs:\n  - climb: {{altitude_m: 30}}\n{legs}\n"


def _waypoints(rng: random.Random) -> str:
    lat0, lon0 = rng.choice([(89.99, 0.0), (-89.99, 179.9), (0.0, 179.999), (47.0, -179.999)])
    n = rng.choice([20_000, 50, 3])
    lines = ["QGC WPL 110", f"0\t1\t0\t16\t0\t0\t0\t0\t{lat0}\t{lon0}\t100\t1"]
    for i in range(n):
        lat = max(-90, min(90, lat0 + rng.uniform(-1, 1)))
        lon = ((lon0 + rng.uniform(-5, 5) + 180) % 360) - 180
        p = rng.choice([0, 1e9, -1, 1e308, float("nan")])
        lines.append(f"{i + 1}\t0\t3\t{rng.choice([16, 17, 18, 19, 20, 21, 22, 178])}\t{p}\t"
                     f"{rng.choice([0, 1e6, -5])}\t0\t0\t{lat:.7f}\t{lon:.7f}\t"
                     f"{rng.choice([40, 1e6, -100, 1e308])}\t1")
    return "\n".join(lines) + "\n"


def _half_earth(rng: random.Random) -> str:
    return ("name: half the earth\nhome: {lat: 0.0, lon: 0.0, alt_m: 0}\n"
            "legs:\n  - climb: {altitude_m: 100}\n"
            f"  - cruise: {{distance_m: {rng.choice([2.0e7, 1e9, 4.0e7])}, course_deg: 90}}\n"
            "  - descend: {altitude_m: 0}\n")


def _plan_extreme(text: str, rng: random.Random) -> str:
    data = json.loads(text)
    items = data["mission"]["items"]
    for _ in range(rng.randint(1, 5)):
        it = rng.choice(items)
        if "params" in it:
            k = rng.randrange(len(it["params"]))
            it["params"][k] = rng.choice([1e308, -1e308, 1e9, -1, 0, None, "x", [1]])
        if rng.random() < 0.3:
            it["command"] = rng.choice([16, 17, 18, 19, 20, 21, 22, 178, 177, 9999, -1])
        if rng.random() < 0.2:
            it["Altitude"] = rng.choice([1e9, -1e9, None, "high"])
    return json.dumps(data)


# =========================================================================== cases

def _seed_logs() -> list[Path]:
    logs = sorted((REPO / "logs").glob("*.*"))
    real = SHARED / "data/logs"
    if real.is_dir():
        logs += sorted(p for p in real.glob("*.*") if p.suffix != ".md")
    return [p for p in logs if p.suffix in (".bin", ".tlog", ".ulg", ".px4log")]


def log_cases(n: int, rng: random.Random, work: Path) -> list[Case]:
    """Damaged logs through export (most), replay and diagnose."""
    seeds = _seed_logs()
    csv_seed = work / "seed_record.csv"
    if not csv_seed.exists():
        from planner.cli.main import main
        main(["export", str(REPO / "logs/sim_solo_calm.bin"), "--csv", str(csv_seed)])
    seeds.append(csv_seed)
    solo = str(REPO / "aircraft/solo_survey.yaml")
    cases = []
    for k in range(n):
        src = rng.choice(seeds)
        data = src.read_bytes()
        if rng.random() < 0.4 and src.suffix in STRUCTURE:
            name, out = "structure", STRUCTURE[src.suffix](data, rng)
        else:
            name = rng.choice(list(LOG_MUTATORS))
            out = LOG_MUTATORS[name](data, rng) if data else data
        case_dir = work / f"log{k:05d}"
        case_dir.mkdir()
        path = case_dir / f"{name}{src.suffix}"
        path.write_bytes(out)
        pick = rng.random()
        if pick < 0.8:
            csv = case_dir / "out.csv"
            argv, outputs = ["export", str(path), "--csv", str(csv)], [str(csv)]
        elif pick < 0.9:
            argv, outputs = ["replay", str(path), "--aircraft", solo], []
        else:
            argv, outputs = ["diagnose", str(path)], []
        cases.append(Case(f"{name}:{src.name}", "logs", argv, [str(path)], outputs,
                          invalid=(name == "empty"), blame=(path.name,)))
    return cases


def def_cases(n: int, rng: random.Random, work: Path) -> list[Case]:
    """Hostile definition and mission files, and option values, through check, select,
    sweep and hybrid."""
    solo_ac = (REPO / "aircraft/solo_survey.yaml").read_text()
    solo_pack = (REPO / "aircraft/batteries/solo_5200_4s.yaml").read_text()
    catalog = (REPO / "aircraft/packs/catalog.yaml").read_text()
    mission = (REPO / "missions/survey_quad.yaml").read_text()
    plan = (REPO / "missions/survey_route.plan").read_text()
    cases = []
    for k in range(n):
        case_dir = work / f"def{k:05d}"
        (case_dir / "batteries").mkdir(parents=True)
        (case_dir / "batteries/solo_5200_4s.yaml").write_text(solo_pack)
        (case_dir / "aircraft.yaml").write_text(solo_ac)
        (case_dir / "catalog.yaml").write_text(
            catalog.replace("../batteries/", str(REPO / "aircraft/batteries") + "/"))
        (case_dir / "mission.yaml").write_text(mission)
        target = rng.choice(["aircraft.yaml", "batteries/solo_5200_4s.yaml", "catalog.yaml",
                             "mission.yaml", "mission.plan", "mission.waypoints",
                             "special", "options", "big_mission"])
        invalid, blame, mission_path = False, (), case_dir / "mission.yaml"
        command_choices = ["check", "check", "select", "sweep", "hybrid"]
        extra: list[str] = []
        mutator = target
        if target in ("aircraft.yaml", "batteries/solo_5200_4s.yaml", "catalog.yaml",
                      "mission.yaml"):
            mutator = rng.choice(list(DEF_MUTATORS))
            kind, fn = DEF_MUTATORS[mutator]
            p = case_dir / target
            text = fn(p.read_text(), rng)
            if "\udcff" in text:
                p.write_bytes(text.encode("utf-8", "surrogateescape"))
            else:
                p.write_text(text)
            invalid, blame = kind == "invalid", (Path(target).name,)
            if mutator == "huge_comment" and target == "mission.yaml":
                invalid = False              # 11 MB is within a mission's size bound
            if kind == "invalid" and target == "catalog.yaml":
                invalid = True
        elif target == "mission.plan":
            mission_path = case_dir / "mission.plan"
            mission_path.write_text(_plan_extreme(plan, rng))
            blame = ("mission.plan",)
        elif target == "mission.waypoints":
            mission_path = case_dir / "mission.waypoints"
            mission_path.write_text(_waypoints(rng))
            blame = ("mission.waypoints",)
        elif target == "big_mission":
            mission_path.write_text(rng.choice([_many_legs, _half_earth])(rng))
            blame = ("mission.yaml",)
        elif target == "special":
            which = rng.choice(["fifo", "devzero", "dir"])
            p = case_dir / rng.choice(["mission.yaml", "aircraft.yaml"])
            p.unlink()
            if which == "fifo":
                os.mkfifo(p)
            elif which == "devzero":
                p.symlink_to("/dev/zero")
            else:
                p.mkdir()
            invalid, blame = True, (p.name,)
        else:
            opt, value = rng.choice([("--wind", "1e308@5"), ("--wind", "5@nan"),
                                     ("--wind", "-3@90"), ("--temperature", "nan"),
                                     ("--temperature", "-274"), ("--reserve", "inf"),
                                     ("--reserve", "-0.1"), ("--payload", "1e308"),
                                     ("--payload", "-1"), ("--temperature", "1e400")])
            extra = [opt, value]
            invalid, blame = True, (opt,)
            if opt in ("--reserve", "--payload"):
                command_choices = ["check", "check", "select", "sweep"]
        aircraft = str(case_dir / "aircraft.yaml")
        command = rng.choice(command_choices)
        if command == "check":
            argv = ["check", str(mission_path), "--aircraft", aircraft]
        elif command == "select":
            argv = ["select", str(mission_path), "--aircraft", aircraft, "--packs",
                    str(case_dir / "catalog.yaml"), "--no-sorties"]
        elif command == "sweep":
            argv = ["sweep", rng.choice(["battery-mass", "payload"]), "--aircraft", aircraft]
            if target in ("mission.yaml", "mission.plan", "mission.waypoints",
                          "big_mission", "catalog.yaml") or (
                    target == "special" and "mission" in blame[0]):
                invalid, blame = False, ()   # the sweep does not read the mission
        else:
            argv = ["hybrid", str(mission_path), "--aircraft", aircraft]
        if command == "select" and target == "batteries/solo_5200_4s.yaml":
            invalid, blame = False, ()       # select flies the catalog's packs
        if command != "select" and target == "catalog.yaml":
            invalid, blame = False, ()       # only select reads the catalog
        if command == "sweep" and extra and extra[0] == "--wind" and "battery-mass" not in argv:
            extra = []
            invalid = False
        inputs = [str(p) for p in case_dir.rglob("*") if p.is_file() and not p.is_symlink()]
        cases.append(Case(f"{target}:{mutator}:{command}", "defs", argv + extra, inputs, [],
                          invalid=invalid, blame=blame))
    return cases


# ------------------------------------------------------------------- flight records

#: Columns a record's battery model reads, and its time.
_BATTERY_COLS = ("voltage_v", "current_a", "power_w")
_CORE_COLS = ("time_s",) + _BATTERY_COLS


def _num(cell: str) -> float | None:
    try:
        return float(cell)
    except ValueError:
        return None


def _scale(cell: str, factor: float) -> str:
    v = _num(cell)
    return cell if v is None else repr(v * factor)


#: What the last record mutator picked (column, factor, value): part of the case's name.
_NOTE: list[str] = []


def _pick(header: list[str], rng: random.Random, among=_CORE_COLS) -> str:
    present = [c for c in among if c in header]
    name = rng.choice(present or header)
    _NOTE.append(name)
    return name


def _rec_dup_different(h, rows, rng):
    name = _pick(h, rng)
    j = h.index(name)
    h.append(name)
    differ = False
    for r in rows:
        v = _num(r[j]) if j < len(r) else None
        r.append(r[j] if v is None else repr(v * 1.25 + 0.5))
        differ = differ or (v is not None and v == v and r[-1] != r[j])
    return ("invalid", (name,)) if differ else ("maybe", ())   # NaN twice: the same


def _rec_dup_same(h, rows, rng):
    name = rng.choice(h)
    _NOTE.append(name)
    j = h.index(name)
    k = rng.randrange(len(h) + 1)             # where the copy goes, in the header and rows
    h.insert(k, name)
    for r in rows:
        r.insert(k, r[j] if j < len(r) else "")
    return "maybe", ()


def _rec_rename(h, rows, rng):
    name = _pick(h, rng, _CORE_COLS + ("altitude_m", "groundspeed_ms", "experiment"))
    j = h.index(name)
    h[j] = rng.choice([name.upper(), name.replace("_", " "), f" {name} ", f"{name} [SI]",
                       name.split("_")[0], name + "_2"])
    _NOTE.append(repr(h[j]))
    if h[j].strip() == name:                # surrounding blanks: the same name
        return "maybe", ()
    return ("invalid" if name == "time_s" or (name in _BATTERY_COLS and name != "power_w"
                                              and "power_w" not in h) else "maybe"), ()


def _rec_unit(h, rows, rng):
    name = _pick(h, rng, _CORE_COLS + ("altitude_m", "groundspeed_ms", "consumed_mah"))
    factor = rng.choice([1e3, 1e6, 1e-3])
    _NOTE.append(f"x{factor:g}")
    j = h.index(name)
    for r in rows:
        if j < len(r):
            r[j] = _scale(r[j], factor)
    # a column scaled up by 10³ or 10⁶ leaves its plausible range (or, for time, a flight's
    # length); scaled down it may stay inside it (15 mV, a 0.35 s flight): judged by the
    # other rules only
    invalid = name in _CORE_COLS and factor > 1
    return ("invalid" if invalid else "maybe"), ((name,) if invalid else ())


def _rec_microseconds(h, rows, rng):
    if "time_s" not in h:
        return "maybe", ()
    j = h.index("time_s")
    for r in rows:
        r[j] = _scale(r[j], 1e6)
    return "invalid", ("time_s",)


def _rec_sentinel(h, rows, rng):
    name = _pick(h, rng, _CORE_COLS + ("altitude_m", "temperature_c", "groundspeed_ms"))
    j = h.index(name)
    value = rng.choice(["-3.4e38", "3.4028235e38", "-9999", "65535", "-1.7976931348623157e308"])
    everywhere = rng.random() < 0.3
    _NOTE.append(value + ("_everywhere" if everywhere else ""))
    for r in rows:
        if j < len(r) and (everywhere or rng.random() < 0.05):
            r[j] = value
    # a float no-data value in every row leaves the column unusable; an integer one
    # (65535, -9999) may be a plausible reading
    invalid = everywhere and name in _CORE_COLS and abs(float(value)) > 1e30
    return ("invalid" if invalid else "maybe"), ((name,) if invalid else ())


def _rec_all_nan(h, rows, rng):
    group = rng.choice([["time_s"], list(_BATTERY_COLS), [_pick(h, rng, _BATTERY_COLS)],
                        ["voltage_v", "power_w"]])
    _NOTE[:] = list(group)
    cols = [h.index(c) for c in group if c in h]
    for r in rows:
        for j in cols:
            if j < len(r):
                r[j] = rng.choice(["nan", "", "NaN"])
    unusable = group == ["time_s"] or set(group) >= set(_BATTERY_COLS) or (
        set(group) == {"voltage_v", "power_w"})
    return ("invalid" if unusable else "maybe"), ()


def _rec_magnitude(h, rows, rng):
    name = _pick(h, rng, _CORE_COLS + ("altitude_m", "groundspeed_ms", "consumed_mah",
                                       "temperature_c", "wind_n_ms", "throttle"))
    value = rng.choice(["1e308", "-1e308", "1e-320", "5e-324", "1e30", "-0.0"])
    _NOTE.append(value)
    j = h.index(name)
    for r in rows:
        if j < len(r):
            r[j] = value
    # the time, or the power the replay is driven by, of no usable value; a voltage or
    # current of 1e-320 beside a measured power leaves the record usable
    invalid = name in ("time_s", "power_w") and value != "-0.0" or name in (
        "altitude_m", "groundspeed_ms", "temperature_c", "wind_n_ms", "voltage_v",
        "current_a") and value in ("1e308", "-1e308", "1e30")
    return ("invalid" if invalid else "maybe"), ()


def _rec_ragged(h, rows, rng):
    extra = rng.random() < 0.5
    for _ in range(rng.randint(1, 5)):
        r = rows[rng.randrange(len(rows))]
        if extra:
            r.extend(rng.choice([["1.0"], ["", ""], ["x", "2", "3"]]))
        elif len(r) > 1:
            del r[-rng.randint(1, min(3, len(r) - 1)):]
    return "invalid", ()


def _rec_time_jump(h, rows, rng):
    if "time_s" not in h:
        return "maybe", ()
    j = h.index("time_s")
    k = rng.randrange(1, len(rows))
    jump = rng.choice([1e12, 1e9, 3e4, -1e6, 1e5])
    for r in rows[k:] if rng.random() < 0.7 else rows[k:k + 1]:
        r[j] = _scale(r[j], 1.0) if _num(r[j]) is None else repr(float(r[j]) + jump)
    return "maybe", ()


def _rec_shuffle(h, rows, rng):
    for _ in range(rng.randint(1, 50)):
        a, b = rng.randrange(len(rows)), rng.randrange(len(rows))
        rows[a], rows[b] = rows[b], rows[a]
    return "maybe", ()


def _rec_drop_column(h, rows, rng):
    name = rng.choice(h)
    _NOTE.append(name)
    j = h.index(name)
    del h[j]
    for r in rows:
        if j < len(r):
            del r[j]
    return ("invalid" if name == "time_s" else "maybe"), ()


def _rec_header_only(h, rows, rng):
    rows.clear()
    return "invalid", ()


def _rec_text_cells(h, rows, rng):
    name = _pick(h, rng)
    j = h.index(name)
    for r in rows:
        if j < len(r) and rng.random() < 0.02:
            r[j] = rng.choice(["12.3V", "N/A", "1,5", "0x10", "--", "\u2212" + "3"])
    return "maybe", ()


RECORD_MUTATORS = {
    "dup_column_different": _rec_dup_different, "dup_column_same": _rec_dup_same,
    "renamed_column": _rec_rename, "unit_off": _rec_unit, "microseconds": _rec_microseconds,
    "sentinel": _rec_sentinel, "all_nan": _rec_all_nan, "magnitude": _rec_magnitude,
    "ragged_rows": _rec_ragged, "time_jump": _rec_time_jump, "shuffled_rows": _rec_shuffle,
    "dropped_column": _rec_drop_column, "header_only": _rec_header_only,
    "text_cells": _rec_text_cells,
}


def _gzip_damage(data: bytes, rng: random.Random) -> tuple[bytes, str, bool]:
    """``data`` gzip-compressed, whole or damaged: (bytes, how, unusable). A file cut
    short gives the rows before the cut and bytes after the compressed data are ignored,
    each with a warning (a log copied while it was written): usable; damaged compressed
    data (a flipped bit: its CRC fails) is not."""
    import gzip

    z = gzip.compress(data)
    how = rng.choice(["whole", "whole", "cut_short", "bitflip", "trailer", "concatenated"])
    if how == "cut_short":
        return z[:rng.randrange(1, len(z) - 1)], how, False
    if how == "bitflip":
        b = bytearray(z)
        i = rng.randrange(10, len(b) - 8)
        b[i] ^= 1 << rng.randrange(8)
        return bytes(b), how, True
    if how == "trailer":
        return z + rng.randbytes(rng.randint(1, 64)), how, False
    if how == "concatenated":
        return z + gzip.compress(data), how, False  # the rows twice: times go back
    return z, how, False


def record_seeds(work: Path) -> dict[str, Path]:
    """Undamaged flight records: a flight (``sim_solo_calm.bin`` exported) and two
    constant-power discharges of the virtual bench (every 5th sample)."""
    import contextlib
    import io

    from planner.cli.main import main

    flight, bench = work / "seed_flight.csv", work / "seed_bench.csv"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        if not flight.exists():
            main(["export", str(REPO / "logs/sim_solo_calm.bin"), "--csv", str(flight)])
        if not bench.exists():
            full = work / "bench_full.csv"
            main(["bench", "--campaign", "constant", "--out", str(full)])
            lines = full.read_text().splitlines()
            keep = [lines[0]] + [line for k, line in enumerate(lines[1:])
                                 if line.startswith(("const_100W", "const_125W")) and k % 5 == 0]
            bench.write_text("\n".join(keep) + "\n")
            full.unlink()
    return {"flight": flight, "bench": bench}


def record_cases(n: int, rng: random.Random, work: Path) -> list[Case]:
    """Damaged flight-record CSVs (and .csv.gz) through replay, fit-aircraft, fit-battery
    and diagnose."""
    seeds = record_seeds(work)
    texts = {k: p.read_text().splitlines() for k, p in seeds.items()}
    solo = str(REPO / "aircraft/solo_survey.yaml")
    packs = {"flight": str(REPO / "aircraft/batteries/solo_5200_4s.yaml"),
             "bench": str(REPO / "aircraft/batteries/multistar_10ah_4s.yaml")}
    cases = []
    for k in range(n):
        which = rng.choice(["flight", "flight", "bench"])
        lines = texts[which]
        header = lines[0].split(",")
        rows = [line.split(",") for line in lines[1:]]
        names = []
        verdict, blame, columns = "maybe", (), set()
        for _ in range(1 if rng.random() < 0.8 else 2):
            if not rows:
                break
            name = rng.choice(list(RECORD_MUTATORS))
            _NOTE.clear()
            kind, b = RECORD_MUTATORS[name](header, rows, rng)
            names.append("_".join([name] + _NOTE))
            touched = {c for c in _NOTE if c in header} | set(_NOTE) & set(_CORE_COLS)
            if touched & columns:
                # a second mutation of the same column decides alone (all NaN after a
                # unit mistake is all NaN)
                verdict, blame = "maybe", ()
            both = touched | columns
            if "power_w" in both and both & {"voltage_v", "current_a"} \
                    and not touched & columns:
                # power in another unit is told by V × I: with V or I damaged too, it
                # cannot be (a power of 100 kW beside 0 V is not refused by rule)
                verdict, blame, kind = "maybe", (), "maybe"
            if kind == "invalid":
                verdict, blame = kind, b
            columns |= touched
        text = "\n".join([",".join(header)] + [",".join(r) for r in rows]) + "\n"
        data = text.encode("utf-8", "surrogateescape")
        case_dir = work / f"rec{k:05d}"
        case_dir.mkdir()
        suffix = ".csv"
        if rng.random() < 0.25:
            data, how, unusable = _gzip_damage(data, rng)
            names.append(f"gzip_{how}")
            suffix = ".csv.gz"
            if unusable:
                verdict = "invalid"
            elif how == "cut_short" and any(n.startswith(("ragged_rows", "text_cells",
                                                          "sentinel")) for n in names):
                verdict = "maybe"                   # the damaged rows may be cut away
        path = case_dir / f"{'+'.join(names)}{suffix}".replace("/", "_")
        path.write_bytes(data)
        outputs: list[str] = []
        command = rng.choice(["replay", "fit-aircraft", "fit-battery", "diagnose"]
                             if which == "flight" else ["replay", "fit-battery", "diagnose"])
        if command == "replay":
            argv = ["replay", str(path)] + (["--aircraft", solo] if which == "flight"
                                            else ["--battery", packs[which]])
        elif command == "fit-aircraft":
            out = str(case_dir / "fitted.yaml")
            argv, outputs = ["fit-aircraft", str(path), "--aircraft", solo, "--out", out], [out]
        elif command == "fit-battery":
            out = str(case_dir / "pack.yaml")
            argv = ["fit-battery", str(path), "--battery", packs[which], "--out", out]
            outputs = [out]
        else:
            argv = ["diagnose", str(path)] + (["--aircraft", solo] if which == "flight"
                                              and rng.random() < 0.5 else [])
        cases.append(Case(f"{'+'.join(names)}:{which}:{command}", "records", argv,
                          [str(path)], outputs, invalid=verdict == "invalid",
                          blame=(path.name,) + tuple(blame)))
    return cases


# ------------------------------------------------------------------ output targets

def _output_commands(d: Path) -> list[tuple[list[str], dict]]:
    """Each command (reading copies in the case's folder ``d``) with its output options
    (flag → file suffix; ``/``: a folder)."""
    ac, mission, rec, bench = (str(d / n) for n in ("aircraft.yaml", "mission.yaml",
                                                     "flight.csv", "bench.csv"))
    pack = str(d / "batteries/solo_5200_4s.yaml")
    catalog = str(REPO / "aircraft/packs/catalog.yaml")
    multistar = str(REPO / "aircraft/batteries/multistar_10ah_4s.yaml")
    return [
        (["check", mission, "--aircraft", ac, "--failsafe", "ardupilot"],
         {"--json": ".json", "--plot": ".png", "--map": ".png", "--kml": ".kml",
          "--params-out": ".param"}),
        (["select", mission, "--aircraft", ac, "--packs", catalog],
         {"--json": ".json", "--plot": ".png", "--map": ".png", "--kml": ".kml",
          "--sorties-out": "/"}),
        (["sweep", "battery-mass", "--aircraft", ac, "--points", "8"],
         {"--csv": ".csv", "--plot": ".png"}),
        (["hybrid", mission, "--aircraft", ac], {"--json": ".json"}),
        (["export", str(REPO / "logs/sim_solo_calm.bin")], {"--csv": ".csv"}),
        (["replay", rec, "--aircraft", ac], {"--json": ".json", "--plot": ".png",
                                             "--csv": ".csv"}),
        (["fit-aircraft", rec, "--aircraft", ac],       # (--plot: a fixed wing's fit)
         {"--out": ".yaml", "--json": ".json"}),
        (["fit-battery", bench, "--battery", multistar],
         {"--out": ".yaml", "--json": ".json", "--plot": ".png"}),
        (["diagnose", rec, "--battery", pack], {"--json": ".json", "--plot": ".png",
                                                "--out": ".yaml"}),
        (["bench", "--campaign", "constant"], {"--out": ".csv"}),   # (--json: with --report)
    ]


#: Output options a command requires (added to fill them when another is tried).
_REQUIRED_OUTPUT = {"fit-aircraft": "--out", "fit-battery": "--out", "export": "--csv",
                    "bench": "--out"}

OUTPUT_TARGETS = ("read_only", "directory", "dev_null", "dev_full", "symlink",
                  "symlink_to_read_only", "dangling_symlink", "missing_folder", "an_input")


def _case_copies(case_dir: Path, seeds: dict[str, Path]) -> None:
    """The inputs of an output or option case, copied into its folder."""
    (case_dir / "batteries").mkdir(parents=True)
    shutil.copy(REPO / "aircraft/solo_survey.yaml", case_dir / "aircraft.yaml")
    shutil.copy(REPO / "aircraft/batteries/solo_5200_4s.yaml",
                case_dir / "batteries/solo_5200_4s.yaml")
    shutil.copy(REPO / "missions/survey_quad.yaml", case_dir / "mission.yaml")
    shutil.copy(seeds["flight"], case_dir / "flight.csv")
    shutil.copy(seeds["bench"], case_dir / "bench.csv")


def output_cases(n: int, rng: random.Random, work: Path) -> list[Case]:
    """Every command's output options pointed at read-only files, folders, devices,
    symbolic links, missing folders and inputs."""
    seeds = record_seeds(work)
    cases = []
    k = 0
    while len(cases) < n:
        case_dir = work / f"out{k:05d}"
        k += 1
        _case_copies(case_dir, seeds)
        argv, options = rng.choice(_output_commands(case_dir))
        argv = list(argv)
        flag, suffix = rng.choice(list(options.items()))
        target = rng.choice(OUTPUT_TARGETS)
        folder = suffix == "/"
        outputs: list[str] = []
        protected: list[str] = []
        invalid, valid, blame = False, False, ()
        name = "target" + ("" if folder else suffix)
        path = case_dir / name
        if target == "read_only":
            if folder:
                path.mkdir()
                os.chmod(path, 0o555)
            else:
                path.write_text("protected\n")
                os.chmod(path, 0o444)
            invalid, blame = True, (name,)
            protected = [str(path)]
        elif target == "directory":
            path.mkdir()
            if folder:
                outputs, valid = [str(path)], True
            else:
                invalid, blame = True, (name,)
        elif target in ("dev_null", "dev_full"):
            path = Path("/dev/null" if target == "dev_null" else "/dev/full")
            invalid, blame = target == "dev_full" or folder, (str(path),)
        elif target in ("symlink", "symlink_to_read_only"):
            real = case_dir / ("real" + ("" if folder else suffix))
            if folder:
                real.mkdir()
            else:
                real.write_text("old\n")
            if target == "symlink_to_read_only":
                os.chmod(real, 0o555 if folder else 0o444)
                protected = [str(real)]
                invalid, blame = True, (name,)
            else:
                outputs, valid = [str(real)], True
            path.symlink_to(real)
            protected.append(str(path))     # the link itself stays a link
        elif target == "dangling_symlink":
            path.symlink_to(case_dir / "nowhere" / "x")
            invalid, blame = True, (name,)
            protected = [str(path)]
        elif target == "missing_folder":
            path = case_dir / "no_such_folder" / name
            blame = ("no_such_folder",)
            if folder:
                outputs = [str(case_dir / "no_such_folder")]
            else:
                invalid = True
        else:
            read = [a for a in argv if a.startswith(str(case_dir))]
            if not read:
                continue
            path = Path(rng.choice(read))
            invalid, blame = True, (path.name,)
        if target == "dev_null" and flag in ("--plot", "--map"):
            invalid, blame = True, (flag,)      # no figure format in its name
        argv += [flag, str(path)]
        req = _REQUIRED_OUTPUT.get(argv[0])
        if req and req != flag:
            other = case_dir / ("required" + options[req])
            argv += [req, str(other)]
            outputs.append(str(other))
        inputs = [str(p) for p in sorted(case_dir.rglob("*")) if p.is_file()
                  and not p.is_symlink() and p.name not in ("target" + suffix, "real" + suffix)]
        cases.append(Case(f"{target}:{argv[0]}:{flag}", "outputs", argv, inputs, outputs,
                          invalid=invalid, blame=blame, valid=valid, protected=protected,
                          folder=str(case_dir)))
    return cases


# ------------------------------------------------------------- options in a wrong unit

def _option_table() -> list[tuple[list[str], str, str, bool]]:
    """(command, option, value, wrong): the value in a wrong unit (``wrong``: refused
    with exit 2 naming the option) or, for contrast, in the right one (never refused)."""
    solo = "{dir}/aircraft.yaml"
    quad = "{dir}/mission.yaml"
    catalog = str(REPO / "aircraft/packs/catalog.yaml")
    rec = "{flight}"
    bench = "{bench}"
    multistar = str(REPO / "aircraft/batteries/multistar_10ah_4s.yaml")
    check = ["check", quad, "--aircraft", solo]
    select = ["select", quad, "--aircraft", solo, "--packs", catalog, "--no-sorties"]
    sweep = ["sweep", "battery-mass", "--aircraft", solo, "--points", "8"]
    sweep_p = ["sweep", "payload", "--aircraft", solo, "--points", "8"]
    hybrid = ["hybrid", quad, "--aircraft", solo]
    replay = ["replay", rec, "--aircraft", solo]
    fit_a = ["fit-aircraft", rec, "--aircraft", solo, "--out", "{dir}/fit.yaml"]
    fit_b = ["fit-battery", bench, "--out", "{dir}/pack.yaml"]
    fit_bb = fit_b + ["--battery", multistar]
    diag = ["diagnose", rec, "--aircraft", solo]
    rows = []
    for cmd in (check, select):
        rows += [(cmd, "--payload", "350", True), (cmd, "--payload", "1200", True),
                 (cmd, "--payload", "0.35", False), (cmd, "--reserve", "1.5", True),
                 (cmd, "--reserve", "150", True), (cmd, "--reserve", "20", False),
                 (cmd, "--reserve", "0.2", False), (cmd, "--temperature", "95", True),
                 (cmd, "--temperature", "120", True), (cmd, "--temperature", "25", False),
                 (cmd, "--wind", "72@270", True), (cmd, "--wind", "5@270", False)]
    check_mc = check + ["--uncertainty", "--samples", "50"]
    rows += [(check_mc, "--payload-sd", "50", True), (check_mc, "--payload-sd", "0.05", False),
             (check, "--payload-sd", "0.05", True)]      # a spread without --uncertainty
    rows += [(sweep, "--range", "200:1500", True), (sweep, "--range", "0.2:1.5", False),
             (sweep, "--payload", "800", True), (sweep, "--cell-voltage", "3700", True),
             (sweep, "--cell-voltage", "3.7", False), (sweep, "--specific-energy", "680000", True),
             (sweep, "--altitude", "40000", True), (sweep, "--site-altitude", "30000", True),
             (sweep, "--temperature", "104", True), (sweep, "--reserve", "2", True),
             (sweep_p, "--range", "100:900", True), (sweep_p, "--range", "0:0.9", False),
             (hybrid, "--temperature", "90", True), (hybrid, "--step", "500", True),
             (hybrid, "--wind", "50@90", True)]
    for cmd in (replay, fit_a, diag):
        rows += [(cmd, "--payload", "350", True), (cmd, "--payload", "0.35", False),
                 (cmd, "--site-altitude", "30000", True), (cmd, "--site-altitude", "1000", False)]
    rows += [(replay, "--reserve", "1.5", True), (fit_a, "--mass", "1800", True),
             (fit_a, "--mass", "1.8", False), (diag, "--mass", "1800", True),
             (fit_a, "--airborne-height", "5000", True),
             (fit_b + ["--name", "x"], "--mass-kg", "800", True),
             (fit_b + ["--name", "x"], "--mass-kg", "0.8", False),
             (fit_b + ["--name", "x", "--mass-kg", "0.8"], "--capacity-mah", "10", True),
             (fit_b + ["--name", "x", "--mass-kg", "0.8"], "--capacity-mah", "10000", False),
             (fit_bb, "--cells", "400", True), (fit_bb, "--fix-beta", "96", True)]
    return rows


def option_cases(n: int, rng: random.Random, work: Path) -> list[Case]:
    """Numeric options typed in a wrong unit (grams for kg, km/h for m/s, per cent for a
    fraction, °F for °C, feet for m), and the same options in the right unit."""
    seeds = record_seeds(work)
    table = _option_table()
    cases = []
    for k in range(n):
        argv, option, value, wrong = table[k % len(table)] if n >= len(table) \
            else rng.choice(table)
        case_dir = work / f"opt{k:05d}"
        case_dir.mkdir()
        _case_copies(case_dir, seeds)
        subst = {"flight": str(case_dir / "flight.csv"), "bench": str(case_dir / "bench.csv"),
                 "dir": str(case_dir)}
        argv = [a.format(**subst) for a in argv] + [option, value]
        outputs = [a for a in argv if a.endswith((".yaml",)) and "/fit.yaml" in a
                   or a.endswith("/pack.yaml") and a.startswith(str(case_dir))]
        inputs = [str(p) for p in sorted(case_dir.rglob("*")) if p.is_file()]
        cases.append(Case(f"{option}={value}:{argv[0]}", "options", argv, inputs, outputs,
                          invalid=wrong, valid=not wrong, blame=(option,) if wrong else (),
                          folder=str(case_dir)))
    return cases


# =========================================================================== runner

def _digest(paths) -> dict[str, str]:
    out = {}
    for p in paths:
        try:
            st = os.lstat(p)
            if stat.S_ISREG(st.st_mode):
                out[p] = hashlib.sha256(Path(p).read_bytes()).hexdigest()
        except OSError:
            out[p] = "missing"
    return out


def _state(paths) -> dict[str, tuple]:
    """What a protected path is: a link (and where to), or a file's inode, mode and
    contents; a folder's inode and listing."""
    out = {}
    for p in paths:
        try:
            st = os.lstat(p)
        except OSError:
            out[p] = ("missing",)
            continue
        if stat.S_ISLNK(st.st_mode):
            out[p] = ("link", os.readlink(p))
        elif stat.S_ISDIR(st.st_mode):
            out[p] = ("folder", st.st_ino, st.st_mode, tuple(sorted(os.listdir(p))))
        else:
            out[p] = ("file", st.st_ino, st.st_mode, _digest([p]).get(p))
    return out


def _case_folder(case: Case) -> Path | None:
    if case.folder:
        return Path(case.folder)
    return Path(case.inputs[0]).parent if case.inputs else None


def _rss_now() -> int:
    """This process's resident set now (a forked worker starts from it). [bytes]"""
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def _listing(folder: Path) -> set[str]:
    return {str(p) for p in folder.rglob("*")}


def _child(case: Case, out_path: Path, err_path: Path) -> None:
    """Run one case in this (forked) process and exit with its status."""
    # the resident set this worker starts from: its peak above it is the case's memory
    Path(str(err_path) + ".rss").write_text(str(_rss_now()))
    try:
        resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_LIMIT, ADDRESS_SPACE_LIMIT))
        cpu = resource.getrusage(resource.RUSAGE_SELF)
        used = int(cpu.ru_utime + cpu.ru_stime)
        resource.setrlimit(resource.RLIMIT_CPU, (used + int(TIME_LIMIT_S) + 1,
                                                 used + int(TIME_LIMIT_S) + 2))
    except (ValueError, OSError):
        pass
    fd_out = os.open(out_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    fd_err = os.open(err_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(fd_out, 1)
    os.dup2(fd_err, 2)
    sys.stdout = os.fdopen(1, "w", closefd=False)
    sys.stderr = os.fdopen(2, "w", closefd=False)
    import warnings

    warnings.simplefilter("default")
    from planner.cli.main import main

    try:
        status = main(case.argv)
    except SystemExit as exc:
        status = exc.code if isinstance(exc.code, int) else 2
    except MemoryError:
        status = 97
    except BaseException:                                       # noqa: BLE001
        import traceback
        traceback.print_exc()
        status = 3
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(int(status) & 0xFF)


def run_cases(cases: list[Case], work: Path, jobs: int = 2,
              progress: bool = False) -> list[Outcome]:
    """Run the cases, ``jobs`` forked workers at a time."""
    import contextlib
    import io

    from planner.cli.main import main

    # import and compile what the commands use once, before forking the workers
    solo = str(REPO / "aircraft/solo_survey.yaml")
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        main(["check", str(REPO / "missions/survey_quad.yaml"), "--aircraft", solo])
        main(["replay", str(REPO / "logs/sim_solo_calm.bin"), "--aircraft", solo])
        main(["diagnose", str(REPO / "logs/sim_solo_calm.bin")])
    # give the warm-up's freed memory back, so a worker's growth is its own
    import ctypes
    import gc

    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass

    results: list[Outcome] = []
    running: dict[int, tuple] = {}
    queue = list(cases)
    done = 0
    while queue or running:
        while queue and len(running) < jobs:
            case = queue.pop(0)
            before = (_digest(case.inputs), _state(case.protected))
            folder = _case_folder(case)
            listing = _listing(folder) if folder else set()
            out_p = work / f".out_{case.name.replace('/', '_')}_{len(results) + len(running)}"
            err_p = work / f".err_{case.name.replace('/', '_')}_{len(results) + len(running)}"
            base_rss = _rss_now()
            pid = os.fork()
            if pid == 0:
                _child(case, out_p, err_p)
            running[pid] = (case, time.perf_counter(), before, listing, out_p, err_p,
                            base_rss)
        pid, status, usage = os.wait4(-1, os.WNOHANG)
        if pid == 0:
            now = time.perf_counter()
            for p, (case, t0, *_rest) in list(running.items()):
                if now - t0 > WALL_LIMIT_S:
                    os.kill(p, signal.SIGKILL)
            time.sleep(0.002)
            continue
        case, t0, before, listing, out_p, err_p, base_rss = running.pop(pid)
        wall = time.perf_counter() - t0
        seconds = usage.ru_utime + usage.ru_stime          # the case's own CPU time
        peak = usage.ru_maxrss * 1024
        code = os.waitstatus_to_exitcode(status)
        stderr = err_p.read_text(errors="replace") if err_p.exists() else ""
        stdout = out_p.read_text(errors="replace") if out_p.exists() else ""
        rss_p = Path(str(err_p) + ".rss")
        try:
            base_rss = int(rss_p.read_text())
        except (OSError, ValueError):
            pass                                # killed before it wrote: the parent's
        rss_p.unlink(missing_ok=True)
        for p in (out_p, err_p):
            p.unlink(missing_ok=True)
        failures = _judge(case, code, seconds, peak - base_rss, stderr, before, listing,
                          stdout)
        if wall > WALL_LIMIT_S:
            failures.insert(0, f"hang (killed after {WALL_LIMIT_S:g} s of wall time)")
        results.append(Outcome(case, code, seconds, max(peak - base_rss, 0), stderr,
                               failures))
        done += 1
        if results[-1].failures and progress:
            r = results[-1]
            print(f"  FAIL {r.case.name}: {'; '.join(r.failures)} :: "
                  f"{' '.join(r.case.argv)[:200]}", file=sys.stderr, flush=True)
    return results


#: A number printed as ``nan`` or ``inf`` in a verdict.
_NAN_WORD = __import__("re").compile(r"(?<![\w.])-?(nan|inf)(?![\w])", __import__("re").I)


def _judge(case: Case, code: int, seconds: float, peak_above: int, stderr: str,
           before, listing: set, stdout: str = "") -> list[str]:
    """The failures of one case (module notes). ``before``: the inputs' digests, or
    (digests, state of the protected paths)."""
    out = []
    protected_before = {}
    if isinstance(before, tuple):
        before, protected_before = before
    size = sum(os.path.getsize(p) for p in case.inputs if os.path.isfile(p)
               and not os.path.islink(p))
    if code in (-signal.SIGXCPU, -signal.SIGKILL) and seconds >= TIME_LIMIT_S:
        out.append(f"over {TIME_LIMIT_S:g} s of CPU time (killed)")
    elif code < 0:
        out.append(f"worker died (signal {-code})")
    elif code == 3:
        last = [line for line in stderr.splitlines() if line.strip()]
        exc = next((line for line in reversed(last) if "Error" in line or "Exception" in line),
                   last[-1] if last else "")
        out.append(f"internal error: {exc.strip()[:200]}")
    elif code == 97:
        out.append("MemoryError")
    elif code not in (0, 1, 2):
        out.append(f"exit status {code}")
    if seconds > TIME_LIMIT_S and code >= 0:
        out.append(f"took {seconds:.1f} s of CPU time (limit {TIME_LIMIT_S:g} s)")
    if peak_above > 3 * size + MEMORY_ALLOWANCE:
        out.append(f"peak memory {peak_above / 2**20:.0f} MB above start for "
                   f"{size / 2**20:.1f} MB of input")
    if _digest(case.inputs) != before:
        out.append("an input file changed")
    if protected_before and _state(case.protected) != protected_before:
        changed = [p for p, s in _state(case.protected).items() if protected_before.get(p) != s]
        out.append(f"protected path replaced or changed: {Path(changed[0]).name}")
    folder = _case_folder(case)
    if folder is not None:
        stray = _listing(folder) - listing - set(case.outputs)
        stray = {s for s in stray if not Path(s).name.startswith(".") and not any(
            s.startswith(o.rstrip("/") + "/") for o in case.outputs)}
        if stray:
            out.append(f"stray file(s) written: {sorted(stray)[:3]}")
    if code == 2:
        lines = [line for line in stderr.splitlines() if line.startswith("error:")
                 or line.startswith("endurance") and ": error:" in line]
        errors = lines + [line for line in stderr.splitlines() if line.startswith("usage:")]
        if "usage:" not in stderr and len(lines) != 1:
            out.append(f"exit 2 with {len(lines)} error lines")
        elif case.blame and not any(b in "\n".join(errors) for b in case.blame) \
                and "usage:" not in stderr:
            out.append(f"exit-2 line does not name {case.blame[0]}: {lines[0][:160]}")
    if case.invalid and code in (0, 1):
        out.append(f"invalid input given a verdict (exit {code})")
    if case.valid and code == 2:
        err = next((line for line in stderr.splitlines() if "error" in line), "")
        out.append(f"valid input refused: {err[:160]}")
    if code in (0, 1) and _NAN_WORD.search(stdout):
        line = next(line for line in stdout.splitlines() if _NAN_WORD.search(line))
        out.append(f"nan or inf printed: {line.strip()[:160]}")
    return out


# =========================================================================== report

def summary(results: list[Outcome]) -> str:
    n = len(results)
    bad = [r for r in results if r.failures]
    internal = sum(any(f.startswith("internal") for f in r.failures) for r in results)
    hangs = sum(any("hang" in f or "took" in f or "CPU" in f for f in r.failures)
                for r in results)
    memory = sum(any("memory" in f.lower() for f in r.failures) for r in results)
    changed = sum(any("input file changed" in f for f in r.failures) for r in results)
    codes = {}
    for r in results:
        codes[r.status] = codes.get(r.status, 0) + 1
    slow = max(results, key=lambda r: r.seconds, default=None)
    big = max(results, key=lambda r: r.peak_bytes, default=None)
    worst_t = slow.seconds if slow else 0.0
    worst_m = big.peak_bytes / 2**20 if big else 0.0
    return (f"fuzz: {n} cases, {len(bad)} failing ({internal} internal errors, {hangs} over "
            f"{TIME_LIMIT_S:g} s, {memory} over the memory bound, {changed} inputs changed); "
            f"exit codes {dict(sorted(codes.items()))}; slowest {worst_t:.1f} s of CPU; largest "
            f"peak {worst_m:.0f} MB above start")


def breakdown(results: list[Outcome]) -> str:
    """Per kind and class of case: cases, exit codes, failures; the slowest case and the
    one with the largest memory, with their commands."""
    rows: dict[tuple[str, str], list[Outcome]] = {}
    for r in results:
        cls = r.case.name.split(":")[0].split("+")[0] if r.case.kind != "options" \
            else r.case.name.split("=")[0]
        cls = max((k for k in RECORD_MUTATORS if cls.startswith(k)), key=len, default=cls)
        rows.setdefault((r.case.kind, cls), []).append(r)
    lines = [f"{'kind':8s} {'class':24s} {'cases':>5s} {'failing':>7s}  exit codes"]
    for (kind, cls), rs in sorted(rows.items()):
        codes: dict[int, int] = {}
        for r in rs:
            codes[r.status] = codes.get(r.status, 0) + 1
        lines.append(f"{kind:8s} {cls:24s} {len(rs):5d} {sum(bool(r.failures) for r in rs):7d}"
                     f"  {dict(sorted(codes.items()))}")
    if results:
        slow = max(results, key=lambda r: r.seconds)
        big = max(results, key=lambda r: r.peak_bytes)
        lines.append(f"slowest: {slow.seconds:.1f} s of CPU: endurance {' '.join(slow.case.argv)}")
        lines.append(f"largest: {big.peak_bytes / 2**20:.0f} MB above start: endurance "
                     f"{' '.join(big.case.argv)}")
    return "\n".join(lines)


#: Cases made and run at a time by :func:`campaign`.
BATCH = 500


def campaign(n_logs: int, n_defs: int, seed: int = 0, jobs: int = 2,
             progress: bool = False, n_records: int = 0, n_outputs: int = 0,
             n_options: int = 0) -> list[Outcome]:
    """Run ``n_logs`` + ``n_defs`` cases in batches of :data:`BATCH` (each batch's files
    are made, run and deleted in turn, so the disk holds one batch), then the record,
    output and option cases."""
    rng = random.Random(seed)
    results: list[Outcome] = []
    for n, make in ((n_records, record_cases), (n_outputs, output_cases),
                    (n_options, option_cases)):
        done = 0
        while done < n:
            with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
                k = min(BATCH, n - done)
                cases = make(k, rng, Path(tmp))
                rng.shuffle(cases)
                results += run_cases(cases, Path(tmp), jobs=jobs, progress=progress)
                _writable(Path(tmp))
            done += k
            if progress:
                print(f"  {len(results)}: {summary(results)}", file=sys.stderr, flush=True)
    total = n_logs + n_defs
    with tempfile.TemporaryDirectory(prefix="fuzz-") as tmp:
        root = Path(tmp)
        seed_csv = root / "seed_record.csv"
        done_logs = done_defs = 0
        batch = 0
        while done_logs < n_logs or done_defs < n_defs:
            work = root / f"batch{batch:03d}"
            work.mkdir()
            if seed_csv.exists():
                shutil.copy(seed_csv, work / "seed_record.csv")
            k_logs = min(BATCH * n_logs // max(total, 1) or 1, n_logs - done_logs)
            k_defs = min(BATCH * n_defs // max(total, 1) or 1, n_defs - done_defs)
            cases = log_cases(k_logs, rng, work) + def_cases(k_defs, rng, work)
            if not seed_csv.exists() and (work / "seed_record.csv").exists():
                shutil.copy(work / "seed_record.csv", seed_csv)
            rng.shuffle(cases)
            results += run_cases(cases, work, jobs=jobs, progress=progress)
            shutil.rmtree(work, ignore_errors=True)
            done_logs += k_logs
            done_defs += k_defs
            batch += 1
            if progress:
                print(f"  {len(results)}/{total}: {summary(results)}", file=sys.stderr,
                      flush=True)
    return results


def _writable(folder: Path) -> None:
    """Give back the owner's write permission under ``folder`` (read-only targets), so that
    it can be deleted."""
    for p in folder.rglob("*"):
        if not p.is_symlink():
            with __import__("contextlib").suppress(OSError):
                os.chmod(p, stat.S_IMODE(os.lstat(p).st_mode) | stat.S_IWUSR)


#: The full campaign: cases of each kind.
FULL = {"logs": 10_000, "defs": 5_000, "records": 2_000, "outputs": 600, "options": 300}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=600, help="cases in all (default 600)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--full", action="store_true",
                    help="the full campaign: " + ", ".join(f"{v:,} {k}".replace(",", " ")
                                                           for k, v in FULL.items()))
    ap.add_argument("--only", action="append", choices=tuple(FULL),
                    help="run only these kinds (repeatable)")
    ap.add_argument("--show", type=int, default=20, help="failing cases to list")
    args = ap.parse_args(argv)
    if args.full:
        n = dict(FULL)
    else:
        c = args.cases
        n = {"logs": c * 2 // 5, "defs": c // 5, "records": c // 5, "outputs": c // 10,
             "options": c - c * 2 // 5 - c // 5 - c // 5 - c // 10}
    if args.only:
        n = {k: (v if k in args.only else 0) for k, v in n.items()}
        if not args.full and len(args.only) == 1:
            n[args.only[0]] = args.cases
    t0 = time.perf_counter()
    results = campaign(n["logs"], n["defs"], args.seed, args.jobs, progress=True,
                       n_records=n["records"], n_outputs=n["outputs"], n_options=n["options"])
    for r in [r for r in results if r.failures][:args.show]:
        print(f"FAIL {r.case.name}: {'; '.join(r.failures)} :: {' '.join(r.case.argv)[:300]}")
    print(breakdown(results))
    print(f"({time.perf_counter() - t0:.0f} s, seed {args.seed})")
    print(summary(results))
    return 0 if not any(r.failures for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
