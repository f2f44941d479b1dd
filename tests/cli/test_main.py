"""The command line's entry (planner.cli.main): each command imports its own module only."""

import argparse
import importlib
import json
import subprocess
import sys
from pathlib import Path

from planner.cli.main import COMMAND_MODULES, build_parser

REPO = Path(__file__).resolve().parents[2]


def test_command_table_names_what_each_module_registers():
    for module, names in COMMAND_MODULES.items():
        sub = argparse.ArgumentParser().add_subparsers()
        importlib.import_module(module).register(sub)
        assert tuple(sub.choices) == names, module


def test_a_command_builds_its_own_parser_and_help_builds_all():
    def commands(parser):
        return set(next(a for a in parser._actions
                        if isinstance(a, argparse._SubParsersAction)).choices)
    assert commands(build_parser(["sweep", "--help"])) == {"select", "sweep"}
    every = {n for names in COMMAND_MODULES.values() for n in names}
    assert commands(build_parser(["--help"])) == every
    assert commands(build_parser(["chekc"])) == every      # a wrong name lists them all


def test_check_imports_no_table_signal_statistics_or_plot_library():
    """``endurance check`` of the shipped survey imports neither pandas nor scipy.signal,
    scipy.stats, scipy.integrate, Dask or matplotlib (start-up time)."""
    code = ("import sys, json\nfrom planner.cli.main import main\n"
            "code = main(['check', 'missions/survey_route.yaml', '--aircraft', "
            "'aircraft/solo_survey.yaml', '--quiet'])\n"
            "heavy = ('pandas', 'scipy.signal', 'scipy.stats', 'scipy.integrate', 'dask', "
            "'matplotlib')\n"
            "print(json.dumps([code, sorted(m for m in heavy if m in sys.modules)]))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True,
                         text=True, check=True).stdout
    code, loaded = json.loads(out.strip().splitlines()[-1])
    assert code == 0 and loaded == []


def test_swapped_aircraft_and_pack_files_say_where_to_give_each(capsys):
    """``--aircraft pack.yaml`` says it is a pack file and to give it as --battery; the
    reverse says to give the aircraft as --aircraft (one line each, exit 2)."""
    from planner.cli.main import main

    solo = str(REPO / "aircraft/solo_survey.yaml")
    pack = str(REPO / "aircraft/batteries/solo_5200_4s.yaml")
    mission = str(REPO / "missions/survey_quad.yaml")
    assert main(["check", mission, "--aircraft", pack]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"error: {pack}: this is a battery pack file (it has cells_series, "
                   "capacity_mah), not an aircraft file: give it as --battery")
    assert main(["check", mission, "--aircraft", solo, "--battery", solo]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"error: {solo}: this is an aircraft file (it has empty_mass_kg, "
                   "multirotor), not a battery pack file: give it as --aircraft")
