"""Validation of definition files (YAML) against a table of keys.

Every problem in a mapping is collected and reported at once, in one line:
``aircraft/x.yaml: capacity_mah must be > 0, got -5; unknown key 'mas_kg' (did
you mean 'mass_kg'?)``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from planner.errors import InputError

NUMBER = "number"
INTEGER = "integer"
TEXT = "text"
BOOL = "boolean"
MAPPING = "mapping"
LIST = "list"
ANY = "any"

_MISSING = object()


@dataclass(frozen=True)
class Key:
    """One key of a definition file.

    Attributes
    ----------
    kind : str
        ``number``, ``integer``, ``text``, ``boolean``, ``mapping``, ``list`` or ``any``.
    required : bool
    default : Any
        Value used when the key is absent (and not required).
    low, high : float or None
        Bounds for numbers; ``low_open``/``high_open`` make them strict.
    choices : tuple or None
        Allowed values for text keys.
    """

    kind: str
    required: bool = False
    default: Any = None
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple | None = None


def positive(required=False, default=None, high=None):
    return Key(NUMBER, required, default, low=0.0, low_open=True, high=high)


def non_negative(required=False, default=None, high=None):
    return Key(NUMBER, required, default, low=0.0, high=high)


def _type_ok(kind: str, value: Any) -> bool:
    if kind == ANY:
        return True
    if kind == NUMBER:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == INTEGER:
        return isinstance(value, int) and not isinstance(value, bool) or (
            isinstance(value, float) and value.is_integer())
    if kind == TEXT:
        return isinstance(value, str)
    if kind == BOOL:
        return isinstance(value, bool)
    if kind == MAPPING:
        return isinstance(value, dict)
    if kind == LIST:
        return isinstance(value, list)
    raise AssertionError(kind)


def _expected(kind: str) -> str:
    return {NUMBER: "a number", INTEGER: "a whole number", TEXT: "text",
            BOOL: "true or false", MAPPING: "a mapping of keys", LIST: "a list",
            ANY: "a value"}[kind]


def check_mapping(data: Any, spec: dict[str, Key], where: str, prefix: str = "",
                  problems: list[str] | None = None) -> dict[str, Any]:
    """Validate ``data`` against ``spec``; return a dict with defaults filled in.

    Parameters
    ----------
    data : mapping
        The parsed YAML mapping.
    spec : dict of str to Key
    where : str
        The file, for messages.
    prefix : str
        Key path of ``data`` inside the file (``"fixed_wing."``), for messages.
    problems : list of str, optional
        Collect problems here instead of raising (for nested blocks).

    Raises
    ------
    InputError
        With every problem found, when ``problems`` is not given.
    """
    own = problems is None
    problems = [] if own else problems
    out: dict[str, Any] = {}
    if not isinstance(data, dict):
        problems.append(f"{prefix.rstrip('.') or 'the file'} must be a mapping of keys, "
                        f"got {type(data).__name__}")
        data = {}
    for key in data:
        if key not in spec:
            close = difflib.get_close_matches(str(key), list(spec), n=1)
            hint = f" (did you mean '{prefix}{close[0]}'?)" if close else (
                f" (expected one of: {', '.join(spec)})")
            problems.append(f"unknown key '{prefix}{key}'{hint}")
    for key, k in spec.items():
        value = data.get(key, _MISSING)
        name = f"{prefix}{key}"
        if value is _MISSING or value is None:
            if k.required:
                problems.append(f"missing required key '{name}' ({_expected(k.kind)})")
            out[key] = k.default
            continue
        if not _type_ok(k.kind, value):
            problems.append(f"{name} must be {_expected(k.kind)}, got {value!r}")
            out[key] = k.default
            continue
        if k.kind == INTEGER:
            value = int(value)
        if k.kind in (NUMBER, INTEGER):
            value_f = float(value)
            if not math.isfinite(value_f):
                problems.append(f"{name} must be finite, got {value!r}")
            if k.low is not None and (value_f < k.low or (k.low_open and value_f <= k.low)):
                problems.append(f"{name} must be {'>' if k.low_open else '>='} {k.low:g}, "
                                f"got {value!r}")
            if k.high is not None and (value_f > k.high or (k.high_open and value_f >= k.high)):
                problems.append(f"{name} must be {'<' if k.high_open else '<='} {k.high:g}, "
                                f"got {value!r}")
        if k.choices is not None and value not in k.choices:
            problems.append(f"{name} must be one of {', '.join(map(str, k.choices))}, "
                            f"got {value!r}")
        out[key] = value
    if own and problems:
        raise InputError(f"{where}: " + "; ".join(problems))
    return out


def load_yaml(path: str | Path) -> Any:
    """Read a YAML file with the safe loader; bad files raise :class:`InputError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a directory, expected a YAML file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: cannot read ({exc})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f"line {mark.line + 1}" if mark is not None else "somewhere"
        problem = getattr(exc, "problem", None) or "invalid YAML"
        raise InputError(f"{path}: not valid YAML at {at}: {problem}") from None
    if data is None:
        raise InputError(f"{path}: the file is empty, expected a mapping of keys")
    return data


def require(condition: bool, where: str, message: str, problems: list[str]) -> None:
    if not condition:
        problems.append(message)


Validator = Callable[[dict, str], dict]
