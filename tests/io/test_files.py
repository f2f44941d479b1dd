"""No output ever overwrites a file the command read (planner.io.files).

For every command and every output option it has, the output is pointed at each file the
command reads — given on the command line, named inside another file (aircraft → pack,
pack → OCV table, catalog → pack file), spelled through ``..``, a symbolic link or a hard
link — and the command must exit 2 with one line naming both paths, leaving every input
byte-for-byte unchanged. All files are copies in a temporary folder.
"""

import hashlib
import itertools
import os
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from planner.io import files
from planner.physics.battery import integral
from planner.physics.battery.ocv import lipo_ocv
from planner.cli.main import main

REPO = Path(__file__).resolve().parents[2]
SPELLINGS = ("plain", "dotdot", "symlink", "hardlink")


@pytest.fixture
def world(tmp_path):
    """Copies of an aircraft, its pack (with an OCV table), a mission, a catalog, a log
    and discharge data; returns name → path."""
    (tmp_path / "aircraft/batteries").mkdir(parents=True)
    (tmp_path / "sub").mkdir()
    shutil.copy(REPO / "aircraft/solo_survey.yaml", tmp_path / "aircraft/solo.yaml")
    pack = (REPO / "aircraft/batteries/solo_5200_4s.yaml").read_text()
    pack = pack.replace("circuit:                          # per cell",
                        "circuit:\n  ocv_csv: cell_ocv.csv         # per cell")
    (tmp_path / "aircraft/batteries/solo_5200_4s.yaml").write_text(pack)
    soc = np.linspace(0, 1, 21)
    (tmp_path / "aircraft/batteries/cell_ocv.csv").write_text(
        "soc [1],ocv [V]\n" + "".join(f"{s:.3f},{v:.4f}\n" for s, v in zip(soc, lipo_ocv(soc))))
    shutil.copy(REPO / "missions/survey_quad.yaml", tmp_path / "mission.yaml")
    (tmp_path / "aircraft/catalog.yaml").write_text(
        "packs:\n  - file: batteries/solo_5200_4s.yaml\n")
    shutil.copy(REPO / "logs/sim_solo_calm.bin", tmp_path / "flight.bin")
    rows = []
    for name, p in (("cp60", 60.0), ("cp90", 90.0), ("cp120", 120.0)):
        t = np.arange(0.0, 2400.0, 2.0)
        c = integral.charge(t, np.full(t.size, p), 23.6, -1.02, 0.9648) / 3.6
        rows.append(pd.DataFrame({"experiment": name, "time_s": t, "power_w": p,
                                  "consumed_mah": c, "voltage_v": 15.5,
                                  "current_a": p / 15.5}))
    pd.concat(rows).to_csv(tmp_path / "discharges.csv", index=False)
    return {"root": tmp_path, "aircraft": tmp_path / "aircraft/solo.yaml",
            "pack": tmp_path / "aircraft/batteries/solo_5200_4s.yaml",
            "ocv": tmp_path / "aircraft/batteries/cell_ocv.csv",
            "mission": tmp_path / "mission.yaml", "catalog": tmp_path / "aircraft/catalog.yaml",
            "log": tmp_path / "flight.bin", "data": tmp_path / "discharges.csv"}


def spelled(world, target: Path, spelling: str, suffix: str) -> str:
    """An output path that names ``target`` another way."""
    root = world["root"]
    if spelling == "plain":
        return str(target)
    if spelling == "dotdot":
        return str(root / "sub" / ".." / target.relative_to(root))
    link = root / f"link_{spelling}_{target.stem}{suffix}"
    if spelling == "symlink":
        link.symlink_to(target)
    else:
        os.link(target, link)
    return str(link)


def commands(w):
    """command → (argv, {output option: file suffix}, [inputs it reads])."""
    a, pk, m = str(w["aircraft"]), str(w["pack"]), str(w["mission"])
    return {
        "check": (["check", m, "--aircraft", a], {"--json": ".json", "--plot": ".png"},
                  ["mission", "aircraft", "pack", "ocv"]),
        "select": (["select", m, "--aircraft", a, "--packs", str(w["catalog"])],
                   {"--json": ".json", "--plot": ".png"},
                   ["mission", "aircraft", "catalog", "pack", "ocv"]),
        "sweep": (["sweep", "payload", "--aircraft", a], {"--csv": ".csv", "--plot": ".png"},
                  ["aircraft", "pack", "ocv"]),
        "hybrid": (["hybrid", m, "--aircraft", a], {"--json": ".json"},
                   ["mission", "aircraft", "pack", "ocv"]),
        "replay": (["replay", str(w["log"]), "--aircraft", a, "--battery", pk],
                   {"--json": ".json", "--plot": ".png"}, ["log", "aircraft", "pack"]),
        "export": (["export", str(w["log"])], {"--csv": ".csv"}, ["log"]),
        "fit-aircraft": (["fit-aircraft", str(w["log"]), "--aircraft", a],
                         {"--out": ".yaml", "--json": ".json"}, ["log", "aircraft", "pack"]),
        "diagnose": (["diagnose", str(w["data"]), "--battery", pk],
                     {"--json": ".json", "--out": ".yaml"}, ["data", "pack", "ocv"]),
        "fit-battery": (["fit-battery", str(w["data"]), "--battery", pk],
                        {"--out": ".yaml", "--json": ".json", "--plot": ".png"},
                        ["data", "pack"]),
        "design": (["design", "two-step", "--p1", "60", "--p2", "90", "--k", "1",
                    "--capacity-mah", "5200", "--battery", pk], {"--out": ".csv"}, ["pack"]),
    }


def cases():
    out = []
    spell = itertools.cycle(SPELLINGS)
    for cmd, (_, options, inputs) in commands({k: Path(k) for k in
                                               ("aircraft", "pack", "mission", "catalog",
                                                "log", "data", "ocv")}).items():
        for option, suffix in options.items():
            for target in inputs:
                spellings = SPELLINGS if cmd == "check" else (next(spell),)
                for s in spellings:
                    if suffix == ".png" and s in ("plain", "dotdot"):
                        s = "symlink"      # a figure needs a figure's name to get that far
                    out.append((cmd, option, target, s))
    return sorted(set(out))


def digest(paths):
    return {p: hashlib.sha256(Path(p).read_bytes()).hexdigest() for p in paths}


@pytest.mark.parametrize("cmd, option, target, spelling", cases())
def test_an_output_naming_an_input_exits_2_and_leaves_it_unchanged(world, cmd, option,
                                                                   target, spelling, capsys):
    argv, options, _ = commands(world)[cmd]
    if cmd in ("fit-aircraft", "fit-battery") and option != "--out":
        argv = argv + ["--out", str(world["root"] / "new.yaml")]      # a required output
    keys = ("aircraft", "pack", "ocv", "mission", "catalog", "log", "data")
    before = digest(world[k] for k in keys)
    out = spelled(world, world[target], spelling, options[option])
    rc = main(argv + [option, out])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2, (cmd, option, target, spelling, err)
    assert len(err) == 1 and "never overwritten" in err[0], err
    assert digest(world[k] for k in keys) == before


def test_the_guard_knows_files_read_through_other_files(world):
    """check reads the aircraft, the pack it names and the OCV table the pack names."""
    files.reset()
    main(["check", str(world["mission"]), "--aircraft", str(world["aircraft"]), "--quiet"])
    read = {Path(p).resolve() for p in files.inputs()}
    assert {world[k].resolve() for k in ("mission", "aircraft", "pack", "ocv")} <= read


def test_outputs_are_written_whole_or_not_at_all(tmp_path, monkeypatch):
    """A write that fails midway leaves the file that was there."""
    target = tmp_path / "result.json"
    target.write_text("good")

    class Boom(Exception):
        pass

    def fail(*args, **kwargs):
        raise Boom

    files.reset()
    with pytest.raises(Boom):
        with files._atomic(target, "w") as fh:
            fh.write("half")
            fail()
    assert target.read_text() == "good"
    assert [p.name for p in tmp_path.iterdir()] == ["result.json"]   # no temporary left
    files.write_text(target, "new")
    assert target.read_text() == "new"


def test_json_to_standard_output(world, capsys):
    rc = main(["check", str(world["mission"]), "--aircraft", str(world["aircraft"]),
               "--quiet", "--json", "-"])
    out = capsys.readouterr().out
    import json

    assert rc in (0, 1)
    data = json.loads(out[out.index("{"):])
    assert data["verdict"] in ("GO", "NO-GO")
    assert not (Path.cwd() / "-").exists()


def test_outputs_get_normal_permissions_and_links_and_devices_survive(tmp_path):
    """A new output gets 0666 less the umask (not mkstemp's 0600), a replaced file keeps
    its own mode, a symbolic link given as the output stays a link to the updated file,
    and /dev/null is written to, never replaced."""
    import os
    import stat as st

    from planner.io import files

    umask = os.umask(0o022)
    try:
        new = tmp_path / "new.json"
        files.write_text(new, "{}")
        assert st.S_IMODE(new.stat().st_mode) == 0o644
        kept = tmp_path / "kept.json"
        kept.write_text("old")
        kept.chmod(0o600)
        files.write_text(kept, "{}")
        assert st.S_IMODE(kept.stat().st_mode) == 0o600 and kept.read_text() == "{}"
        target = tmp_path / "target.json"
        target.write_text("old")
        link = tmp_path / "link.json"
        link.symlink_to(target)
        files.write_text(link, "new")
        assert link.is_symlink() and target.read_text() == "new"
        files.write_text("/dev/null", "nothing")
        assert st.S_ISCHR(os.stat("/dev/null").st_mode)
    finally:
        os.umask(umask)


def test_read_only_outputs_are_refused_before_any_work(tmp_path):
    """A read-only file given as an output is not replaced (a rename over it would
    succeed where a write would not, even for the superuser), and nothing is written into
    a read-only folder given as an output folder, directly or through a symbolic link:
    each is refused when the outputs are declared, naming the option and the path."""
    import stat as st

    locked = tmp_path / "locked.json"
    locked.write_text("keep")
    locked.chmod(0o444)
    folder = tmp_path / "locked_dir"
    folder.mkdir()
    folder.chmod(0o555)
    link = tmp_path / "link_dir"
    link.symlink_to(folder)
    try:
        with pytest.raises(files.InputError, match=r"--json .*locked\.json: read-only; not "
                                                    r"replaced"):
            files.reset({"--json": str(locked)})
        for given in (folder, link):
            with pytest.raises(files.InputError, match=rf"--sorties-out {given}: read-only "
                                                        r"folder; nothing written into it"):
                files.reset({"--sorties-out": str(given)}, folders=("--sorties-out",))
        files.reset({"--sorties-out": str(tmp_path / "new_dir")}, folders=("--sorties-out",))
        assert locked.read_text() == "keep" and not st.S_IMODE(locked.stat().st_mode) & 0o222
    finally:
        files.reset()
        folder.chmod(0o755)
        locked.chmod(0o644)
