"""The planner's fuzzer: damaged and hostile input through every command.

Seeded mutators make damaged copies of the shipped and real logs (bit flips, overwritten
ranges, truncation, duplicated and deleted chunks, huge length fields, garbage behind a
valid magic, empty files, and structure-aware damage: ULog format and subscription
messages, DataFlash FMT records, MAVLink frame lengths and ids, CSV rows) and hostile
copies of the definition and mission files (wrong types, extremes, NaN/inf, huge
numbers, YAML alias bombs, deep nesting, non-UTF-8 bytes, empty files, special files,
oversized files, thousands of legs and waypoints, waypoints at the pole or across the
antimeridian, ``.plan`` items with extreme parameters, hostile option values). Every case
runs one command (``export``, ``replay``, ``diagnose``, ``check``, ``select``,
``sweep``, ``hybrid``) in a forked worker with a CPU-time limit (and a wall-time limit
for runs blocked without working) and an address-space limit, and the fuzzer records the
exit status, any traceback, the CPU time, the peak memory
above the worker's start, whether any input changed, and whether a file was written
that the command was not asked to write.

A case **fails** when: the exit status is 3 (an internal error) or the worker died; it
ran past the time limit; its peak memory exceeded 3 × the input's size + 300 MB; an
input changed; a stray file appeared; an exit 2 did not print exactly one line naming
the file (or the option) it blames; or input that is invalid by construction was given
a verdict (exit 0 or 1).

Run::

    python tools/fuzz.py [--cases N] [--seed S] [--jobs J] [--full] [--only logs|defs]

``--full`` runs the full campaign (10 000 log cases and 5 000 definition cases). The last
line printed is the summary.
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
    kind: str                       # "logs" or "defs"
    argv: list[str]
    inputs: list[str]
    outputs: list[str] = field(default_factory=list)
    invalid: bool = False           # invalid by construction: no verdict allowed
    blame: tuple[str, ...] = ()     # what an exit-2 line must name (any of)


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
            before = _digest(case.inputs)
            listing = _listing(Path(case.inputs[0]).parent) if case.inputs else set()
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
        rss_p = Path(str(err_p) + ".rss")
        try:
            base_rss = int(rss_p.read_text())
        except (OSError, ValueError):
            pass                                # killed before it wrote: the parent's
        rss_p.unlink(missing_ok=True)
        for p in (out_p, err_p):
            p.unlink(missing_ok=True)
        failures = _judge(case, code, seconds, peak - base_rss, stderr, before, listing)
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


def _judge(case: Case, code: int, seconds: float, peak_above: int, stderr: str,
           before: dict, listing: set) -> list[str]:
    out = []
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
    if case.inputs:
        stray = _listing(Path(case.inputs[0]).parent) - listing - set(case.outputs)
        stray = {s for s in stray if not Path(s).name.startswith(".")}
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
    worst_t = max((r.seconds for r in results), default=0.0)
    worst_m = max((r.peak_bytes for r in results), default=0) / 2**20
    return (f"fuzz: {n} cases, {len(bad)} failing ({internal} internal errors, {hangs} over "
            f"{TIME_LIMIT_S:g} s, {memory} over the memory bound, {changed} inputs changed); "
            f"exit codes {dict(sorted(codes.items()))}; slowest {worst_t:.1f} s of CPU; largest "
            f"peak {worst_m:.0f} MB above start")


#: Cases made and run at a time by :func:`campaign`.
BATCH = 500


def campaign(n_logs: int, n_defs: int, seed: int = 0, jobs: int = 2,
             progress: bool = False) -> list[Outcome]:
    """Run ``n_logs`` + ``n_defs`` cases in batches of :data:`BATCH` (each batch's files
    are made, run and deleted in turn, so the disk holds one batch)."""
    rng = random.Random(seed)
    results: list[Outcome] = []
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


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=600, help="cases in all (default 600)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--full", action="store_true",
                    help="the full campaign: 10 000 log cases and 5 000 definition cases")
    ap.add_argument("--only", choices=("logs", "defs"))
    ap.add_argument("--show", type=int, default=20, help="failing cases to list")
    args = ap.parse_args(argv)
    n_logs, n_defs = (10_000, 5_000) if args.full else (args.cases * 2 // 3,
                                                         args.cases - args.cases * 2 // 3)
    if args.only == "logs":
        n_defs = 0
    elif args.only == "defs":
        n_logs = 0
    t0 = time.perf_counter()
    results = campaign(n_logs, n_defs, args.seed, args.jobs, progress=True)
    for r in [r for r in results if r.failures][:args.show]:
        print(f"FAIL {r.case.name}: {'; '.join(r.failures)} :: {' '.join(r.case.argv)[:200]}")
    print(f"({time.perf_counter() - t0:.0f} s, seed {args.seed})")
    print(summary(results))
    return 0 if not any(r.failures for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
