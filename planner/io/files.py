"""Every file a command reads or writes passes through here.

Inputs
------
:func:`input_path` (and :func:`read_text`, :func:`read_bytes`, :func:`load_yaml` on top of
it) is the one door for reading: it refuses what is not a regular file (a directory, a
FIFO, ``/dev/zero``, a socket) and a file larger than the bound of its kind
(:data:`SIZE_LIMITS`), each with an :class:`~planner.errors.InputError` naming the file,
and it records the file's identity — device and inode, and the resolved path — in the
registry of the running command. Files read *through* other files (the pack an aircraft
names, the OCV table of a ``circuit:`` block, the pack files of a catalog, a column map)
are recorded the same way.

Outputs
-------
Every output is checked against that registry before it is written: the same file,
whatever the spelling (``..``, a symbolic link, a hard link: same device and inode), is
refused with exit 2 naming both paths — input files are never overwritten. The outputs a
command is given are declared at its start (:func:`reset`) and checked there, before any
work: a read-only file (its owner may not write it) is refused, never replaced, and so is
a folder given for a file, a file given for a folder, and a folder that does not exist;
an input read later that is one of them is refused as it is read. Outputs are written to
a temporary file in the target folder and renamed into place (:func:`os.replace`), so an
interrupted run never leaves a half-written file where a good one was; a device or a pipe
(``/dev/null``) is written in place. An output given as ``-`` goes to standard output.

YAML
----
:func:`load_yaml` reads YAML 1.1 with PyYAML's safe loader, bounded: at most
:data:`YAML_MAX_ALIASES` aliases (a "billion laughs" document expands exponentially
through them), nesting at most :data:`YAML_MAX_DEPTH` deep and at most
:data:`YAML_MAX_NODES` values with every alias expanded (an alias bomb of few aliases is
refused as it is composed, before anything is built from it), no alias inside the node it
names. Events are parsed by libyaml where PyYAML has it (about 4 × faster than the pure
Python parser), composed and constructed by PyYAML's own safe loader classes, so values
are exactly what ``yaml.safe_load`` gives.
"""

from __future__ import annotations

import contextlib
import os
import stat
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import yaml

from planner.errors import InputError

__all__ = ["SIZE_LIMITS", "check_output", "check_outputs", "check_target", "finish",
           "input_path",
           "inputs", "output_file", "own_output_path", "read_only",
           "load_yaml", "read_bytes", "read_text", "reset", "save_figure", "write_bytes",
           "write_text"]

#: Largest file of each kind. [bytes] Definition files (aircraft, pack, catalog, column
#: map, OCV table) hold a few kB; missions of 20 000 waypoints fit in a few MB; logs of
#: long flights reach hundreds of MB.
SIZE_LIMITS = {"definition": 10 * 2**20, "mission": 50 * 2**20, "table": 2 * 2**30,
               "log": 4 * 2**30}
#: Most aliases in a YAML document (definition files need none).
YAML_MAX_ALIASES = 100
#: Deepest nesting of a YAML document.
YAML_MAX_DEPTH = 50
#: Most values in a YAML document, every alias expanded.
YAML_MAX_NODES = 200_000

#: Identity (device, inode) → the path as the command named it, for the running command.
_INPUTS: dict[tuple[int, int], str] = {}
#: Resolved path → the path as named (for files that vanish, and for spelling checks).
_INPUT_PATHS: dict[str, str] = {}
#: The running command's outputs (option → path), all checked at the first write.
_DECLARED: dict[str, Any] = {}
#: Identity (device, inode) and resolved path of each declared output that exists → (option,
#: path as named): an input read later that is one of them is refused as it is read.
_OUTPUT_IDS: dict[Any, tuple[str, str]] = {}
#: Where an output named ``-`` goes: the standard output the command started with (the
#: CLI sends the command's own text to standard error then, so that standard output holds
#: that output and nothing else).
STDOUT = None


def reset(outputs: dict[str, Any] | None = None, folders: tuple[str, ...] = ()) -> None:
    """Forget the previous command's files and declare this one's outputs (the CLI calls
    it at the start, with ``{option: path}``; ``folders``: the options that name a folder).
    Each output is checked at once (:func:`check_target`: not read-only, a file or a folder
    as it should be, its folder existing), and again against the inputs at the command's
    first write and as each input is read, so that nothing is written when any output
    names an input and no work is done for an output that cannot be written."""
    _INPUTS.clear()
    _INPUT_PATHS.clear()
    _DECLARED.clear()
    _OUTPUT_IDS.clear()
    declared = {k: v for k, v in (outputs or {}).items() if v is not None}
    for option, path in declared.items():
        check_target(path, option, folder=option in folders)
    _DECLARED.update({k: v for k, v in declared.items() if k not in folders})
    for option, path in _DECLARED.items():
        if str(path) == "-":
            continue
        _OUTPUT_IDS[os.path.realpath(path)] = (option, str(path))
        try:
            st = os.stat(path)
        except OSError:
            continue
        _OUTPUT_IDS[(st.st_dev, st.st_ino)] = (option, str(path))


def finish() -> None:
    """The command has ended (the CLI calls it): its outputs are no longer guarded against
    being read (a caller may read what it wrote); the inputs it read stay listed."""
    _DECLARED.clear()
    _OUTPUT_IDS.clear()


def read_only(path: str | os.PathLike) -> bool:
    """Whether an existing file is read-only: its owner may not write it (its mode has no
    owner write bit, which holds for every user, the superuser too), or this process may
    not."""
    try:
        st = os.stat(path)
    except OSError:
        return False
    return not st.st_mode & stat.S_IWUSR or not os.access(path, os.W_OK)


def check_target(path: str | os.PathLike | None, option: str = "output", *,
                 folder: bool = False) -> None:
    """Refuse an output that cannot or may not be written, before any work: a read-only
    file (never replaced), a folder given for a file, a file given for a folder, a file in
    a folder that does not exist. A folder output that does not exist yet is created by the
    command; a device or a pipe is written in place."""
    if path is None or str(path) == "-":
        return
    p = Path(path)
    real = Path(os.path.realpath(p))
    if folder:
        if real.exists() and not real.is_dir():
            raise InputError(f"{option} {path}: not a folder (expected a folder to write into)")
        if real.is_dir() and read_only(real):
            raise InputError(f"{option} {path}: read-only folder; nothing written into it (a "
                             "read-only folder is protected: make it writable or give another "
                             "folder)")
        if not real.parent.is_dir():
            raise InputError(f"{option} {path}: folder {real.parent} does not exist")
        return
    if real.is_dir():
        raise InputError(f"{option} {path}: is a folder, expected a file name")
    if not real.parent.is_dir():
        raise InputError(f"{option} {path}: folder {real.parent} does not exist")
    try:
        st = os.stat(real)
    except OSError:
        return
    if stat.S_ISREG(st.st_mode) and read_only(real):
        raise InputError(f"{option} {path}: read-only; not replaced (a read-only file is "
                         "protected: make it writable or give another path)")


def _first_write() -> None:
    if _DECLARED:
        declared = dict(_DECLARED)
        _DECLARED.clear()
        check_outputs(declared)


def inputs() -> list[str]:
    """The input files recorded so far, as named."""
    return list(dict.fromkeys(_INPUT_PATHS.values()))


def _kind_limit(kind: str) -> int:
    if kind not in SIZE_LIMITS:
        raise ValueError(f"kind must be one of {', '.join(SIZE_LIMITS)}, got {kind!r}")
    return SIZE_LIMITS[kind]


def input_path(path: str | os.PathLike, kind: str, what: str = "file") -> Path:
    """Check an input file and record it (module notes); return it as a Path.

    Raises
    ------
    InputError
        Missing, not a regular file, unreadable, or larger than the bound of ``kind``.
    """
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise InputError(f"{p}: file not found") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{p}: is a directory, expected a {what}")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{p}: not a regular file (a device, a pipe or a socket), expected "
                         f"a {what}")
    limit = _kind_limit(kind)
    if st.st_size > limit:
        raise InputError(f"{p}: {st.st_size / 2**20:.0f} MB is larger than a {what} can be "
                         f"(at most {limit / 2**20:.0f} MB)")
    real = os.path.realpath(p)
    taken = _OUTPUT_IDS.get((st.st_dev, st.st_ino)) or _OUTPUT_IDS.get(real)
    if taken is not None:
        option, named = taken
        raise InputError(f"{option} {named}: is the input file {path} of this command (the "
                         "same file by another name, a link or a copy of its path); input "
                         "files are never overwritten, expected another path")
    _INPUTS[(st.st_dev, st.st_ino)] = str(path)
    _INPUT_PATHS[real] = str(path)
    return p


def read_bytes(path: str | os.PathLike, kind: str, what: str = "file") -> bytes:
    """The bytes of an input file (:func:`input_path` first)."""
    p = input_path(path, kind, what)
    try:
        return p.read_bytes()
    except OSError as exc:
        raise InputError(f"{p}: cannot read ({exc.strerror or exc})") from None


def read_text(path: str | os.PathLike, kind: str, what: str = "file",
              encoding: str = "utf-8") -> str:
    """The text of an input file (:func:`input_path` first); not UTF-8 is bad input."""
    data = read_bytes(path, kind, what)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text (byte {exc.start}), expected a {what}") \
            from None


try:  # libyaml's event parser (C) under PyYAML's own composer, resolver and constructor
    from yaml._yaml import CParser as _Parser
except ImportError:  # pragma: no cover - PyYAML built without libyaml
    from yaml.parser import Parser as _Parser
    from yaml.reader import Reader as _Reader
    from yaml.scanner import Scanner as _Scanner

    class _Parser(_Reader, _Scanner, _Parser):  # type: ignore[no-redef]
        def __init__(self, stream):
            _Reader.__init__(self, stream)
            _Scanner.__init__(self)
            _Parser.__init__(self)


class _BoundedLoader(yaml.composer.Composer, yaml.constructor.SafeConstructor,
                     yaml.resolver.Resolver, _Parser):
    """PyYAML's safe loader with bounds on aliases, nesting and size (module notes).

    Every node's *expanded* size (itself and everything under it, an alias counting as
    the whole node it repeats) is summed as the document is composed, so an alias bomb is
    refused at the first alias that takes the expanded document past
    :data:`YAML_MAX_NODES`, long before anything is built from it; an alias inside the
    node it names (a recursive document) is refused too.
    """

    def __init__(self, stream):
        _Parser.__init__(self, stream)
        yaml.constructor.SafeConstructor.__init__(self)
        yaml.resolver.Resolver.__init__(self)
        yaml.composer.Composer.__init__(self)
        self._aliases = 0
        self._depth = 0
        self._size: dict[int, int] = {}
        self._expanded = 0

    def compose_node(self, parent, index):
        """PyYAML's node composition, counting aliases, depth and expanded size."""
        if self.check_event(yaml.AliasEvent):
            self._aliases += 1
            if self._aliases > YAML_MAX_ALIASES:
                raise _YamlBound(f"more than {YAML_MAX_ALIASES} aliases (a YAML alias bomb?)")
            event = self.peek_event()
            node = self.anchors.get(event.anchor)
            if node is not None and id(node) not in self._size:
                raise _YamlBound(f"the alias *{event.anchor} is inside the node it names "
                                 "(a recursive document)")
            if node is not None:
                self._count(self._size[id(node)])
            return super().compose_node(parent, index)
        self._depth += 1
        if self._depth > YAML_MAX_DEPTH:
            raise _YamlBound(f"nested more than {YAML_MAX_DEPTH} levels deep")
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        if isinstance(node, yaml.SequenceNode):
            size = 1 + sum(self._size.get(id(c), 1) for c in node.value)
        elif isinstance(node, yaml.MappingNode):
            size = 1 + sum(self._size.get(id(k), 1) + self._size.get(id(v), 1)
                           for k, v in node.value)
        else:
            size = 1
            self._count(1)
        self._size[id(node)] = size
        return node

    def _count(self, n: int) -> None:
        self._expanded += n
        if self._expanded > YAML_MAX_NODES:
            raise _YamlBound(f"more than {YAML_MAX_NODES} values once its aliases are "
                             "expanded (a YAML alias bomb?)")


class _YamlBound(Exception):
    pass


def load_yaml(path: str | os.PathLike, kind: str = "definition",
              what: str = "YAML file", *, empty_ok: bool = True) -> Any:
    """Read a YAML file with the bounded safe loader; bad files raise :class:`InputError`.

    The one reader of YAML (definition files, column maps, missions). ``kind`` bounds the
    file's size (:data:`SIZE_LIMITS`), ``what`` names it in messages; with
    ``empty_ok=False`` an empty document (None) is bad input too.
    """
    text = read_text(path, kind, what)
    try:
        data = yaml.load(text, Loader=_BoundedLoader)  # the safe constructor, bounded
    except _YamlBound as exc:
        raise InputError(f"{path}: refused: {exc}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f"line {mark.line + 1}" if mark is not None else "somewhere"
        problem = getattr(exc, "problem", None) or "invalid YAML"
        raise InputError(f"{path}: not valid YAML at {at}: {problem}") from None
    except RecursionError:
        raise InputError(f"{path}: refused: nested too deeply") from None
    except (ValueError, OverflowError, TypeError) as exc:
        # a value PyYAML's constructor cannot build: a 5000-digit integer, 2023-02-30, ...
        raise InputError(f"{path}: a value cannot be read: {str(exc).splitlines()[0][:120]}") \
            from None
    if data is None and not empty_ok:
        raise InputError(f"{path}: the file is empty, expected a mapping of keys")
    return data


# --------------------------------------------------------------------------- outputs

def check_output(path: str | os.PathLike | None, option: str = "output") -> None:
    """Refuse an output that is one of the command's input files (module notes)."""
    if path is None or str(path) == "-":
        return
    p = Path(path)
    real = os.path.realpath(p)
    same = _INPUT_PATHS.get(real)
    if same is None:
        try:
            st = os.stat(p)
            same = _INPUTS.get((st.st_dev, st.st_ino))
        except OSError:
            same = None
    if same is not None:
        raise InputError(f"{option} {path}: is the input file {same} of this command (the "
                         "same file by another name, a link or a copy of its path); input "
                         "files are never overwritten, expected another path")
    check_target(path, option)


def check_outputs(outputs: dict[str, Any]) -> None:
    """:func:`check_output` for every ``{option: path}`` at once, before anything is
    written."""
    for option, path in outputs.items():
        check_output(path, option)


def _target(path: Path) -> tuple[Path, int | None]:
    """Where an output really goes and the permissions it gets: a symbolic link's target
    (the link stays), the existing file's own mode, else the usual mode for a new file
    (0666 less the umask, not mkstemp's 0600). ``None``: not a regular file (a device
    such as /dev/null, a pipe), written in place, never replaced."""
    real = Path(os.path.realpath(path))
    try:
        st = os.stat(real)
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        return real, 0o666 & ~umask
    except OSError:
        return real, 0o666
    if not stat.S_ISREG(st.st_mode):
        return real, None
    return real, stat.S_IMODE(st.st_mode)


@contextlib.contextmanager
def _in_place_of(path: Path) -> Iterator[Path]:
    """The path to write in place of ``path``: a temporary file beside its real target
    (:func:`_target`), renamed onto it with its permissions when the block ends without
    an error and removed otherwise; a device or a pipe is written in place."""
    real, perm = _target(path)
    if perm is None:
        try:
            yield real
        except OSError as exc:
            raise InputError(f"{path}: cannot write ({exc.strerror or exc})") from None
        return
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{real.name}.", suffix=".tmp", dir=real.parent)
    except OSError as exc:
        raise InputError(f"{path}: cannot write ({exc.strerror or exc})") from None
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, perm)
        os.replace(tmp, real)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        if isinstance(exc, OSError):
            raise InputError(f"{path}: cannot write ({exc.strerror or exc})") from None
        raise


@contextlib.contextmanager
def _atomic(path: Path, mode: str) -> Iterator[Any]:
    with _in_place_of(path) as target, \
            open(target, mode, **({} if "b" in mode else {"encoding": "utf-8"})) as fh:
        yield fh


def write_text(path: str | os.PathLike, text: str, option: str = "output") -> None:
    """Write text atomically (``-``: standard output), after :func:`check_output`."""
    _first_write()
    if str(path) == "-":
        out = STDOUT or sys.stdout
        out.write(text)
        out.flush()
        return
    check_output(path, option)
    with _atomic(Path(path), "w") as fh:
        fh.write(text)


def write_bytes(path: str | os.PathLike, data: bytes, option: str = "output") -> None:
    """Write bytes atomically (``-``: standard output), after :func:`check_output`."""
    _first_write()
    if str(path) == "-":
        out = STDOUT or sys.stdout
        out.buffer.write(data)
        out.flush()
        return
    check_output(path, option)
    with _atomic(Path(path), "wb") as fh:
        fh.write(data)


def save_figure(fig, path: str | os.PathLike, option: str = "output", **kwargs) -> None:
    """Save a matplotlib figure atomically, in the format of the file's extension."""
    _first_write()
    p = Path(path)
    check_output(p, option)
    fmt = p.suffix.lstrip(".").lower() or "png"
    with _atomic(p, "wb") as fh:
        fig.savefig(fh, format=fmt, **kwargs)


@contextlib.contextmanager
def output_file(path: str | os.PathLike, option: str = "output") -> Iterator[Path]:
    """A temporary path in the target folder for a writer that wants a file name (pyarrow,
    pandas): renamed onto ``path`` when the block ends without an error, removed otherwise;
    :func:`check_output` first, as for every output."""
    _first_write()
    p = Path(path)
    check_output(p, option)
    with _in_place_of(p) as target:
        yield target


def own_output_path(path: str | os.PathLike, kind: str, what: str = "file") -> Path:
    """A file the command itself maintains and replaces (the table ``fleet`` updates on a
    rerun): checked like an input (a regular file within the bound of ``kind``) but not
    recorded as one, so that its updated version may be written in its place."""
    p = Path(path)
    try:
        st = os.stat(p)
    except OSError as exc:
        raise InputError(f"{p}: cannot read ({exc.strerror or exc})") from None
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{p}: not a regular file, expected a {what}")
    if st.st_size > _kind_limit(kind):
        raise InputError(f"{p}: {st.st_size / 2**20:.0f} MB is larger than a {what} can be")
    return p
