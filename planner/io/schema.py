"""Validation of definition files (YAML) against a table of keys.

Every problem in a mapping is collected and reported at once, in one line:
``aircraft/x.yaml: capacity_mah must be > 0, got -5; unknown key 'mas_kg' (did
you mean 'mass_kg'?)``.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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


def between(low, high, required=False, default=None):
    """A number in the closed range [``low``, ``high``]."""
    return Key(NUMBER, required, default, low=low, high=high)


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


#: A number in exponent notation that YAML 1.1 (PyYAML) reads as text: ``1e3``, ``5E-2``.
EXPONENT_TEXT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+")


def _type_hint(kind: str, value: Any) -> str:
    """Why a number written as ``1e3`` arrived as text: YAML 1.1 wants ``1.0e+3``."""
    if kind in (NUMBER, INTEGER) and isinstance(value, str) and EXPONENT_TEXT.fullmatch(
            value.strip()):
        return " (YAML reads exponent notation without a decimal point as text: write " \
               "e.g. 1.0e+3)"
    return ""


def _shown(value: Any) -> str:
    """A value for a message; a whole number of many digits as ``1e+300`` (or its length)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**15:
        try:
            return f"{float(value):g}"
        except OverflowError:
            return f"a number of {len(str(abs(value)))} digits"
    return repr(value)


def _expected(kind: str) -> str:
    return {NUMBER: "a number", INTEGER: "a whole number", TEXT: "text",
            BOOL: "true or false", MAPPING: "a mapping of keys", LIST: "a list",
            ANY: "a value"}[kind]


def check_mapping(data: Any, spec: dict[str, Key], where: str, prefix: str = "",
                  problems: list[str] | None = None,
                  rejected: set[str] | None = None) -> dict[str, Any]:
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
    rejected : set of str, optional
        Add here the keys that are present but invalid, so that checks across keys can
        leave them out instead of reporting the same value twice.

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
        before = len(problems)
        out[key] = _check_value(data.get(key, _MISSING), k, f"{prefix}{key}", problems)
        if rejected is not None and len(problems) > before:
            rejected.add(key)
    if own and problems:
        raise InputError(f"{where}: " + "; ".join(problems))
    return out


def _check_value(value: Any, k: Key, name: str, problems: list[str]) -> Any:
    """Check one value against its key; return it, or the default when absent or unusable."""
    if value is _MISSING or value is None:
        if k.required:
            problems.append(f"missing required key '{name}' ({_expected(k.kind)})")
        return k.default
    if not _type_ok(k.kind, value):
        problems.append(f"{name} must be {_expected(k.kind)}, got {value!r}"
                        f"{_type_hint(k.kind, value)}")
        return k.default
    if k.kind == INTEGER:
        value = int(value)
    if k.kind in (NUMBER, INTEGER):
        try:
            value_f = float(value)
        except OverflowError:  # a YAML integer of hundreds of digits
            value_f = math.inf if value > 0 else -math.inf
        if not math.isfinite(value_f):
            problems.append(f"{name} must be finite, got {_shown(value)}")
            return k.default
        if k.low is not None and (value_f < k.low or (k.low_open and value_f <= k.low)):
            problems.append(f"{name} must be {'>' if k.low_open else '>='} {k.low:g}, "
                            f"got {_shown(value)}")
        if k.high is not None and (value_f > k.high or (k.high_open and value_f >= k.high)):
            problems.append(f"{name} must be {'<' if k.high_open else '<='} {k.high:g}, "
                            f"got {_shown(value)}")
    if k.choices is not None and value not in k.choices:
        problems.append(f"{name} must be one of {', '.join(map(str, k.choices))}, "
                        f"got {value!r}")
    return value


def load_yaml(path: str | Path) -> Any:
    """Read a YAML file with the safe loader; bad files raise :class:`InputError`."""
    from planner.io import files

    path = Path(path)
    data = files.load_yaml(path, "definition")
    if data is None:
        raise InputError(f"{path}: the file is empty, expected a mapping of keys")
    return data


def require(condition: bool, where: str, message: str, problems: list[str]) -> None:
    if not condition:
        problems.append(message)


Validator = Callable[[dict, str], dict]
