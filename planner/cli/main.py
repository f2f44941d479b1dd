"""Command line: ``endurance <command> ...`` (also ``python -m planner``).

Argparse only; every command calls importable library functions. Exit status
(docs/commands.md): 0 success (``check``: GO), 1 ``check`` says NO-GO, 2 bad input
(one line on stderr naming the file, the field and what was expected),
3 unexpected internal error.

Each command lives in a module of :mod:`planner.cli.commands` with a
``register(subparsers)`` function that adds its parser and sets ``func`` to a
callable ``func(args) -> int``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
import traceback
import warnings

from planner import __version__
from planner.io import files
from planner.errors import InputError, ModelError, PlannerError, WrongFileError

#: Modules that each register one or more sub-commands, in help order, with the names of
#: their sub-commands: a command imports its own module only (start-up time).
COMMAND_MODULES = {
    "planner.cli.commands.check": ("check",),
    "planner.cli.commands.select": ("select", "sweep"),
    "planner.cli.commands.logs": ("export",),
    "planner.cli.commands.replay": ("replay",),
    "planner.cli.commands.battery": ("fit-battery", "design", "pulse-resistance", "bench"),
    "planner.cli.commands.hybrid": ("hybrid",),
    "planner.cli.commands.aircraft": ("fit-aircraft",),
    "planner.cli.commands.diagnose": ("diagnose",),
    "planner.cli.commands.fleet": ("fleet",),
    "planner.cli.commands.watch": ("watch",),
    "planner.cli.commands.backtest": ("backtest",),
}

EXIT_OK, EXIT_NOGO, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3
#: Exit status when standard output is closed under us: 128 + SIGPIPE, as the shell
#: reports a process the signal ended.
EXIT_BROKEN_PIPE = 141


class _Parser(argparse.ArgumentParser):
    """Argparse parser whose usage errors exit 2 with a one-line message."""

    def error(self, message):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The command line's parser: with ``argv`` naming a sub-command first, that command's
    module only (the others are not imported); else every command (help, a wrong name)."""
    parser = _Parser(
        prog="endurance",
        description="UAV mission endurance planner: pre-flight check, pack selection, "
        "log replay and model diagnosis.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    modules = list(COMMAND_MODULES)
    if argv and not argv[0].startswith("-"):
        modules = [m for m, names in COMMAND_MODULES.items() if argv[0] in names] or modules
    for name in modules:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            if exc.name == name:  # command not built yet
                continue
            raise
        module.register(sub)
    return parser


#: Options (``dest``) that name outputs: all checked before the command starts (read-only
#: files are not replaced) and against every file the command reads
#: (:mod:`planner.io.files`). A command whose output option names a folder sets
#: ``output_folders`` (the flags) in its parser's defaults.
OUTPUT_ARGS = ("out", "json", "plot", "csv", "params_out", "sorties_out", "route_map", "kml")
#: Output options whose flag is not their ``dest`` spelled with dashes (``--map`` of
#: check and select is ``route_map``: elsewhere ``--map`` reads a column map).
OUTPUT_FLAGS = {"route_map": "--map"}


#: Where each kind of file is given, by the option (``dest``) that takes it: the first of
#: the command's options.
KIND_OPTIONS = {"battery pack": ("battery", "packs"), "aircraft": ("aircraft",),
                "pack catalog": ("packs",), "mission": ("mission",)}


def where_to_give(kind: str, args) -> str:
    """``": give it as --battery"``: the option of this command that takes a file of
    ``kind`` (a mission is the command's first argument); "" when it has none."""
    for dest in KIND_OPTIONS.get(kind, ()):
        if dest in vars(args):
            return (": give it as the mission (the first argument)" if dest == "mission"
                    else f": give it as --{dest}")
    return ""


def _format_warning(message, category, filename, lineno, line=None):
    return f"warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    """Run the CLI; return the exit status."""
    warnings.formatwarning = _format_warning
    parser = build_parser(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    outputs = {OUTPUT_FLAGS.get(name, f"--{name.replace('_', '-')}"): getattr(args, name, None)
               for name in OUTPUT_ARGS}
    to_stdout = "-" in outputs.values()
    saved = sys.stdout
    try:
        files.reset(outputs, folders=tuple(getattr(args, "output_folders", ())))
        if to_stdout:
            # standard output carries that output alone; the command's text goes to stderr
            files.STDOUT, sys.stdout = saved, sys.stderr
        return int(args.func(args))
    except WrongFileError as exc:
        print(f"error: {exc}{where_to_give(exc.kind, args)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (InputError, ModelError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except PlannerError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        # the reader of the output went away (``endurance … | head``): end quietly, as a
        # process killed by SIGPIPE would, without a second error while flushing stdout
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except Exception:  # pragma: no cover - the last line of defence
        traceback.print_exc()
        print("error: internal error (a bug): please report it with the input files",
              file=sys.stderr)
        return EXIT_INTERNAL
    finally:
        files.finish()
        if to_stdout:
            sys.stdout, files.STDOUT = saved, None


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
