"""The one validator of YAML input: definition files, column maps and missions.

A file's keys are declared once, in a table of :class:`Key` (its type, unit, bound,
default and meaning); :func:`check_mapping` validates a mapping against that table and
returns the values with the defaults filled in, and the readers build their objects from
those values. ``docs/formats.md`` prints the same tables (``tools/reference.py``).

Every problem of a file is collected (:class:`Problems`) and reported at once, in one
line naming the file and the key path: ``aircraft/x.yaml: capacity_mah must be > 0, got
-5; unknown key 'mas_kg' (did you mean 'mass_kg'?)``. The messages are written here only:

* an unknown key: ``unknown key 'fixed_wing.cd_0' (did you mean 'fixed_wing.cd0'?)``;
* a missing key: ``missing required key 'name' (text)``;
* a wrong type: ``mass_kg must be a number, got 'heavy'``;
* a number outside its bound: ``mass_kg must be <= 1000, got 5000``; a share given as
  a percentage says so: ``usable_fraction must be <= 1, got 80 (looks like a
  percentage: 80 % is 0.8)``.

Readers with rules of their own (one key of several, checks across keys) add their
problems to the same :class:`Problems`, so that the file is still reported in one line.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from planner.errors import InputError, WrongFileError

NUMBER = "number"
INTEGER = "integer"
TEXT = "text"
BOOL = "boolean"
MAPPING = "mapping"
LIST = "list"
ANY = "any"

#: A key absent from its mapping (``None`` is a value YAML gives to ``key:``).
MISSING = object()


@dataclass(frozen=True)
class Key:
    """One key of a definition file: what it holds, in what unit, within what bound.

    Attributes
    ----------
    kind : str
        ``number``, ``integer``, ``text``, ``boolean``, ``mapping``, ``list`` or ``any``.
    required : bool
        The file must give it.
    default : Any
        Value used when the key is absent (and not required); None: none.
    low, high : float or None
        Bounds of a number (the constants of :mod:`planner.physics.limits`, each with its
        reason); ``low_open``/``high_open`` make them strict.
    choices : tuple or None
        The values a text key may take.
    unit : str
        Unit of a number (``kg``, ``m/s``, ``1/°C``), for the reference tables; "" for
        none.
    meaning : str
        What the key is, in a few words, for the reference tables.
    why : str
        The bound's reason in a few words, said in the message of a value beyond it
        (``mission.duration_s must be <= 86400 (24 h), got 1e+05``).
    why_low, why_high : str or None
        The reason of one bound where the two differ (None: ``why``).
    share : bool
        A dimensionless share of a whole (an efficiency, a usable part, a relative spread):
        a value above its bound whose hundredth lies within it is said to look like a
        percentage (``usable_fraction must be <= 1, got 80 (looks like a percentage: 80 %
        is 0.8)``).
    """

    kind: str
    required: bool = False
    default: Any = None
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    choices: tuple | None = None
    unit: str = ""
    meaning: str = ""
    why: str = ""
    why_low: str | None = None
    why_high: str | None = None
    share: bool = False


def share(low, high, required=False, default=None, low_open=False, **kw) -> Key:
    """A dimensionless share of a whole in [``low``, ``high``] (``high`` <= 1): a value
    given as a percentage is told so."""
    return Key(NUMBER, required, default, low=low, high=high, low_open=low_open, share=True,
               **kw)


def positive(required=False, default=None, high=None, **kw) -> Key:
    """A number > 0, at most ``high``."""
    return Key(NUMBER, required, default, low=0.0, low_open=True, high=high, **kw)


def between(low, high, required=False, default=None, **kw) -> Key:
    """A number in the closed range [``low``, ``high``]."""
    return Key(NUMBER, required, default, low=low, high=high, **kw)


def non_negative(required=False, default=None, high=None, **kw) -> Key:
    """A number >= 0, at most ``high``."""
    return Key(NUMBER, required, default, low=0.0, high=high, **kw)


def count(high, required=False, default=None, low=1, **kw) -> Key:
    """A whole number in [``low``, ``high``] (cells, rotors, packs)."""
    return Key(INTEGER, required, default, low=low, high=high, **kw)


def text(meaning: str, required=False, default=None, choices=None) -> Key:
    """A text key."""
    return Key(TEXT, required, default, choices=choices, meaning=meaning)


def block(meaning: str, required=False) -> Key:
    """A nested mapping, validated by a table of its own."""
    return Key(MAPPING, required, meaning=meaning)


def defaults(spec: dict[str, Key]) -> dict[str, Any]:
    """Each key of ``spec`` → its default (None where it has none)."""
    return {name: k.default for name, k in spec.items()}


def field_defaults(cls) -> dict[str, Any]:
    """Each field of the dataclass ``cls`` that has a default → that default: a table whose
    object lives in a lower layer takes the object's defaults from here."""
    return {f.name: f.default for f in dataclasses.fields(cls)
            if f.default is not dataclasses.MISSING}


def fields_from(cls, values: dict[str, Any], **changes) -> dict[str, Any]:
    """The keyword arguments of the dataclass ``cls`` from checked ``values`` (the keys
    that are fields of ``cls``), with ``changes`` on top."""
    names = {f.name for f in dataclasses.fields(cls)}
    return {**{k: v for k, v in values.items() if k in names}, **changes}


#: Keys that only one kind of definition or mission file has: what a file given in the
#: wrong place is.
KIND_MARKERS: dict[str, tuple[str, ...]] = {
    "battery pack": ("cells_series", "capacity_mah"),
    "aircraft": ("empty_mass_kg", "multirotor", "fixed_wing"),
    "pack catalog": ("packs",),
    "mission": ("legs", "waypoints"),
}


def refuse_other_kind(data: Any, expected: str, where: str) -> None:
    """Raise :class:`~planner.errors.WrongFileError` when ``data`` has the keys of another
    kind of file (:data:`KIND_MARKERS`) and none of ``expected``'s: ``pack.yaml: this is a
    battery pack file (it has cells_series, capacity_mah), not an aircraft file``."""
    if not isinstance(data, dict):
        return
    if any(k in data for k in KIND_MARKERS[expected]):
        return
    for kind, keys in KIND_MARKERS.items():
        has = [k for k in keys if k in data]
        if kind != expected and has:
            raise WrongFileError(f"{where}: this is {_article(kind)} {kind} file (it has "
                                 f"{', '.join(has)}), not {_article(expected)} {expected} "
                                 "file", kind)


def _article(noun: str) -> str:
    return "an" if noun[0] in "aeiou" else "a"


class Problems:
    """The problems of one file, collected to be reported at once.

    ``where`` names the file (and entry); :meth:`done` raises one
    :class:`~planner.errors.InputError` ``"{where}: p1; p2; …"`` when there is any.
    """

    def __init__(self, where: str):
        self.where = where
        self.items: list[str] = []

    def add(self, message: str) -> None:
        """Record one problem (a message naming the key path)."""
        self.items.append(message)

    def __len__(self) -> int:
        return len(self.items)

    def done(self) -> None:
        """Raise the problems recorded so far, if any, as one :class:`InputError`."""
        if self.items:
            raise InputError(f"{self.where}: " + "; ".join(self.items))


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


def shown(value: Any) -> str:
    """A value for a message; a whole number of many digits as ``1e+300`` (or its length)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**15:
        try:
            return f"{float(value):g}"
        except OverflowError:
            return f"a number of {len(str(abs(value)))} digits"
    return repr(value)


def expected(kind: str) -> str:
    """What a key of ``kind`` holds, in words (``a number``, ``a mapping of keys``)."""
    return {NUMBER: "a number", INTEGER: "a whole number", TEXT: "text",
            BOOL: "true or false", MAPPING: "a mapping of keys", LIST: "a list",
            ANY: "a value"}[kind]


def unknown_keys(data: dict, allowed: Iterable[str], problems: Problems | list[str],
                 prefix: str = "") -> list[str]:
    """Record every key of ``data`` that is not in ``allowed`` (with the likely intended
    one, or the list of allowed keys); return the unknown keys."""
    allowed = list(allowed)
    bad = [key for key in data if key not in allowed]
    for key in bad:
        close = difflib.get_close_matches(str(key), allowed, n=1)
        hint = f" (did you mean '{prefix}{close[0]}'?)" if close else (
            f" (expected one of: {', '.join(allowed)})")
        _add(problems, f"unknown key '{prefix}{key}'{hint}")
    return bad


def _add(problems: Problems | list[str], message: str) -> None:
    if isinstance(problems, Problems):
        problems.add(message)
    else:
        problems.append(message)


def check_mapping(data: Any, spec: dict[str, Key], where: str, prefix: str = "",
                  problems: Problems | list[str] | None = None,
                  rejected: set[str] | None = None, *,
                  empty_ok: bool = False) -> dict[str, Any]:
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
    problems : Problems or list of str, optional
        Collect problems here instead of raising (for nested blocks).
    rejected : set of str, optional
        Add here the keys that are present but invalid, so that checks across keys can
        leave them out instead of reporting the same value twice.
    empty_ok : bool
        ``data`` None (a block written ``key:`` with nothing under it) is an empty
        mapping.

    Raises
    ------
    InputError
        With every problem found, when ``problems`` is not given.
    """
    own = problems is None
    problems = Problems(where) if own else problems
    out: dict[str, Any] = {}
    if data is None and empty_ok:
        data = {}
    if not isinstance(data, dict):
        _add(problems, f"{prefix.rstrip('.') or 'the file'} must be a mapping of keys, "
                       f"got {type(data).__name__}")
        data = {}
    unknown_keys(data, spec, problems, prefix)
    for key, k in spec.items():
        before = len(problems)
        out[key] = check_value(data.get(key, MISSING), k, f"{prefix}{key}", problems)
        if rejected is not None and len(problems) > before:
            rejected.add(key)
    if own:
        problems.done()
    return out


def check_definition(data: Any, kind: str, spec: dict[str, Key],
                     where: str) -> tuple[dict[str, Any], Problems]:
    """The start of reading a definition file of ``kind`` (:data:`KIND_MARKERS`): a file
    of another kind refused, the mapping checked against ``spec``; returns the values and
    the :class:`Problems` the reader's own rules add to (it calls ``done()``)."""
    refuse_other_kind(data, kind, where)
    problems = Problems(where)
    return check_mapping(data, spec, where, problems=problems), problems


def check_value(value: Any, k: Key, name: str, problems: Problems | list[str]) -> Any:
    """Check one value against its key; return it, or the default when absent or unusable.

    ``value`` is :data:`MISSING` (or None) when the key is absent; ``name`` is its key
    path, for the message.
    """
    if value is MISSING or value is None:
        if k.required:
            _add(problems, f"missing required key '{name}' ({expected(k.kind)})")
        return k.default
    if not _type_ok(k.kind, value):
        _add(problems, f"{name} must be {expected(k.kind)}, got {value!r}"
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
            _add(problems, f"{name} must be finite, got {shown(value)}")
            return k.default
        if k.low is not None and (value_f < k.low or (k.low_open and value_f <= k.low)):
            why = _why(k.why if k.why_low is None else k.why_low)
            _add(problems, f"{name} must be {'>' if k.low_open else '>='} {k.low:g}{why}, "
                           f"got {shown(value)}")
        if k.high is not None and (value_f > k.high or (k.high_open and value_f >= k.high)):
            why = _why(k.why if k.why_high is None else k.why_high)
            _add(problems, f"{name} must be {'<' if k.high_open else '<='} {k.high:g}{why}, "
                           f"got {shown(value)}{_percent_hint(k, value_f)}")
    if k.choices is not None and value not in k.choices:
        _add(problems, f"{name} must be one of {', '.join(map(str, k.choices))}, "
                       f"got {value!r}")
    return value


def _percent_hint(k: Key, value: float) -> str:
    """`` (looks like a percentage: 80 % is 0.8)`` where ``k`` is a share and a hundredth
    of ``value`` lies within its bounds; "" otherwise."""
    if not k.share or not 1.0 < value <= 100.0 or not within(k, value / 100.0):
        return ""
    return f" (looks like a percentage: {value:g} % is {value / 100.0:g})"


def _why(reason: str) -> str:
    return f" ({reason})" if reason else ""


def within(k: Key, value: float) -> bool:
    """Whether a number lies within the bounds of ``k``."""
    if k.low is not None and (value < k.low or (k.low_open and value <= k.low)):
        return False
    return not (k.high is not None and (value > k.high or (k.high_open and value >= k.high)))


def one_of(data: dict, keys: Iterable[str], problems: Problems | list[str],
           prefix: str = "") -> str | None:
    """The one of ``keys`` that ``data`` gives (None: none of them); more than one is a
    problem (``give only one of 'legs' or 'waypoints'``)."""
    present = [k for k in keys if k in data]
    if len(present) > 1:
        _add(problems, "give only one of " + " or ".join(f"'{prefix}{k}'" for k in present))
    return present[0] if present else None
