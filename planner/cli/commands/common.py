"""Argument parsing and output helpers shared by the sub-commands."""

from __future__ import annotations

import json
import math
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from planner.io import files
from planner.physics.atmosphere import MAX_WIND_MS
from planner.errors import InputError


@contextmanager
def flags_for(**flags: str):
    """Name the command-line flags in the library's errors.

    The library's errors name its own parameters (``reserve must be in [0, 1)``); inside
    this context an :class:`InputError` that starts with one of the given parameter names
    is raised again with the flag instead (``--reserve must be in [0, 1)``).
    """
    try:
        yield
    except InputError as exc:
        text = str(exc)
        for name, flag in flags.items():
            if text.startswith(f"{name} "):
                raise InputError(flag + text[len(name):]) from None
        raise


def parse_wind(text: str, max_speed_ms: float = MAX_WIND_MS) -> tuple[float, float]:
    """``SPEED@FROM_DEG`` (m/s, degrees the wind blows from) → (speed, direction).

    The speed must be in [0, ``max_speed_ms``] m/s; the default
    :data:`planner.physics.atmosphere.MAX_WIND_MS` (100 m/s) is several times what a small UAV
    can fly in. The direction must be a compass bearing in [0, 360] degrees;
    360 (north, as METAR and aviation reports write it) is returned as 0. Other values
    are rejected rather than wrapped: ``-90`` or ``400`` is more likely a typo than a
    bearing.
    """
    try:
        speed_s, direction_s = text.split("@")
        speed, direction = float(speed_s), float(direction_s)
    except ValueError:
        raise InputError(f"--wind: expected SPEED@FROM_DEG, e.g. 6@270 (m/s from the west), "
                         f"got {text!r}") from None
    if not (math.isfinite(speed) and 0.0 <= speed <= max_speed_ms):
        raise InputError(f"--wind: speed must be in [0, {max_speed_ms:g}] m/s, got {text!r}")
    if not (math.isfinite(direction) and 0.0 <= direction <= 360.0):
        raise InputError(f"--wind: direction must be a bearing in [0, 360] degrees (the "
                         f"direction the wind blows from, 0 or 360 = north), got {text!r}")
    return speed, direction % 360.0


#: A bare number in this range given for a fraction is ambiguous: ``--reserve 1.5`` may be
#: 1.5 % (as a number above 1 is read) or a slip for 0.15; such a small share is written
#: with its ``%``.
AMBIGUOUS_PERCENT = (1.0, 5.0)


def parse_fraction(text: str, option: str) -> float:
    """``0.2``, ``20%`` or ``20`` → 0.2: a number above 1 is read as per cent. A bare
    number between 1 and 5 (:data:`AMBIGUOUS_PERCENT`) is refused: 1.5 % is written
    ``1.5%``, 15 % ``0.15`` or ``15``."""
    t = text.strip()
    try:
        value = float(t[:-1]) / 100.0 if t.endswith("%") else float(t)
    except ValueError:
        raise InputError(f"{option}: expected a fraction such as 0.2 or a percentage such as "
                         f"20 or 20%, got {text!r}") from None
    low, high = AMBIGUOUS_PERCENT
    if not t.endswith("%") and low < value < high:
        raise InputError(f"{option} {text}: ambiguous: {value:g} % (a number above 1 is read "
                         f"as per cent) or a mistyped fraction? Write {value:g}% for "
                         f"{value:g} %, or the fraction below 1 (0.2 for 20 %)")
    if not t.endswith("%") and 1.0 < value < 100.0:
        value /= 100.0
    if not 0.0 <= value < 1.0:
        raise InputError(f"{option}: must be a fraction in [0, 1) or a percentage below 100, "
                         f"got {text!r}")
    return value


def parse_mass(text: str, option: str, aircraft, what: str = "payload",
               low: float = 0.0, factor: float = 1.0) -> float:
    """A mass [kg] a user typed (payload, all-up mass, battery mass) for ``aircraft``: a
    number ≥ ``low`` and at most ``factor`` × the heaviest take-off of its class
    (:meth:`~planner.parameters.Aircraft.heaviest_takeoff`; an overloaded flight's all-up
    mass may pass its rating, not by half again); beyond it the mass was typed in another
    unit, and the message says which (``350 kg is more than the aircraft's maximum take-off
    mass 2 kg: grams?``)."""
    from planner.parameters.aircraft import in_grams

    value = parse_float(text, option, low, None, "kg")
    bound, why = aircraft.heaviest_takeoff()
    if factor != 1.0:
        bound, why = factor * bound, f"{factor:g} × {why}"
    if value > bound:
        raise InputError(f"{option} {text}: {value:g} kg of {what} is more than {why} "
                         f"{bound:.3g} kg{in_grams(value, bound) or '; expected kg'}")
    return value


def flight_payloads(data, payload_text: str | None, option: str, aircraft):
    """The payload of each flight [kg]: ``--payload`` when given (one value for every
    flight, said to override the data's own), else the record's ``payload_kg`` per
    experiment (a flight without one carries 0, said), else 0. Returns a float or a
    mapping experiment id → payload; prints what it used."""
    from planner.io.record import experiment_payloads

    own = experiment_payloads(data) if data is not None else None
    if payload_text is not None:
        value = (parse_mass(payload_text, option, aircraft) if aircraft is not None
                 else parse_float(payload_text, option, 0.0, 1000.0, "kg"))
        if own is not None:
            print(f"{option} {value:g} kg overrides the payload of each flight given by the "
                  "data")
        return value
    if own is None:
        return 0.0
    unknown = sorted(k for k, v in own.items() if not np.isfinite(v))
    if unknown:
        print(f"warning: no payload for experiment(s) {', '.join(unknown[:10])}"
              f"{' …' if len(unknown) > 10 else ''} in the data: 0 kg assumed")
    own = {k: (v if np.isfinite(v) else 0.0) for k, v in own.items()}
    values = sorted(set(own.values()))
    print(f"payload per flight from the data: {', '.join(f'{v:g}' for v in values)} kg "
          f"over {len(own)} flight(s)")
    return own


def mass_text(mass) -> str:
    """A mass or a mass per flight for a report line."""
    if isinstance(mass, dict):
        lo, hi = min(mass.values()), max(mass.values())
        return (f"{lo:.3f} kg" if lo == hi else f"{lo:.3f}–{hi:.3f} kg (one per flight)")
    return f"{mass:.3f} kg"


def check_speed(value: float, option: str, text: str, aircraft, what: str) -> None:
    """A speed [m/s] a user typed that no flight of ``aircraft`` reaches (more than twice
    its maximum airspeed) was typed in another unit: km/h or knots."""
    top = aircraft.max_airspeed_ms
    if value <= 2.0 * top:
        return
    for unit, factor in (("km/h", 1 / 3.6), ("knots", 0.514444)):
        if value * factor <= top:
            raise InputError(f"{option} {text}: {value:g} m/s of {what} is more than twice "
                             f"the aircraft's maximum airspeed {top:g} m/s: {unit}? "
                             f"({value:g} {unit} = {value * factor:.3g} m/s)")
    raise InputError(f"{option} {text}: {value:g} m/s of {what} is more than twice the "
                     f"aircraft's maximum airspeed {top:g} m/s; expected m/s")


#: Outside air temperatures the commands accept [°C]: the coldest and hottest air a small
#: electric aircraft is flown in, and the span of the battery models' temperature laws.
AIR_TEMPERATURE_C = (-60.0, 60.0)


def parse_temperature(args) -> float | None:
    """``--temperature``, the outside air temperature [°C] (None when not given)."""
    text = getattr(args, "temperature", None)
    return (None if text is None
            else parse_float(text, "--temperature", *AIR_TEMPERATURE_C, "°C"))


def parse_payload(args, aircraft) -> float | None:
    """``--payload`` [kg] for ``aircraft`` (:func:`parse_mass`; None when not given)."""
    text = getattr(args, "payload", None)
    return None if text is None else parse_mass(text, "--payload", aircraft)


def parse_wind_option(args, aircraft) -> tuple[float, float] | None:
    """``--wind`` SPEED@FROM_DEG: (speed [m/s], direction it blows from [deg]), a speed
    in another unit named (:func:`check_speed`); None when not given."""
    text = getattr(args, "wind", None)
    if text is None:
        return None
    wind = parse_wind(text)
    check_speed(wind[0], "--wind", text, aircraft, "wind")
    return wind


def parse_float(text: str, option: str, low: float | None = None,
                high: float | None = None, unit: str = "") -> float:
    """A number in [low, high] (``unit`` named in the message; ``°C`` and ``m`` also say
    when the value looks like °F or feet)."""
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{option}: expected a number, got {text!r}") from None
    if not math.isfinite(value) or (low is not None and value < low) or (
            high is not None and value > high):
        hint = ""
        if math.isfinite(value) and unit == "°C" and low <= (value - 32) / 1.8 <= high:
            hint = f": °F? ({value:g} °F = {(value - 32) / 1.8:.1f} °C)"
        elif math.isfinite(value) and unit == "m" and low <= value * 0.3048 <= high:
            hint = f": feet? ({value:g} ft = {value * 0.3048:.0f} m)"
        rng = (f"[{low:g}, {high:g}]" if low is not None and high is not None else
               f"≥ {low:g}" if low is not None else f"≤ {high:g}" if high is not None
               else "(finite)")
        raise InputError(f"{option}: expected a number in {rng}{' ' + unit if unit else ''}, "
                         f"got {text!r}{hint}")
    return value


def parse_int(text: str, option: str, low: int, high: int) -> int:
    """A whole number in [low, high] (``4`` or ``4.0``), else :class:`InputError`."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value.is_integer() and low <= value <= high):
        raise InputError(f"{option}: expected a whole number in [{low}, {high}], got {text!r}")
    return int(value)


def _default(obj: Any):
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def _clean(obj: Any):
    """Replace NaN/inf by None so that the JSON is standard."""
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, dict):
        return {k: _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    return obj


def write_json(data: dict, path: str | Path, option: str = "--json") -> None:
    """Write JSON (``-``: standard output), never over an input (:mod:`planner.io.files`)."""
    files.write_text(path, json.dumps(_clean(data), indent=2, default=_default) + "\n", option)


def output_path(path: str | None, option: str) -> str | None:
    """Check that an output file's folder exists before any work is done (``-`` is
    standard output)."""
    if path is None or path == "-":
        return path
    parent = Path(path).resolve().parent
    if not parent.is_dir():
        raise InputError(f"{option} {path}: folder {parent} does not exist")
    return path


def plot_path(path: str | None, option: str = "--plot") -> str | None:
    """:func:`output_path` for a figure: also check that matplotlib can write its format."""
    if path is None:
        return None
    from matplotlib.backend_bases import FigureCanvasBase

    formats = FigureCanvasBase.get_supported_filetypes()
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in formats:
        raise InputError(f"{option} {path}: expected a figure file ending in "
                         f"{', '.join('.' + f for f in sorted(formats))}")
    return output_path(path, option)


def outputs(args, *names: str) -> tuple[str | None, ...]:
    """The output options ``names`` (``dest`` names: ``out``, ``plot``, ``json``, …) of
    ``args``, each checked before the work (:func:`output_path`; a plot by
    :func:`plot_path`), in the order named."""
    return tuple(plot_path(getattr(args, n), "--plot") if n == "plot"
                 else output_path(getattr(args, n), "--" + n.replace("_", "-"))
                 for n in names)


def fmt(value: float, digits: int = 1, width: int = 0) -> str:
    """``value`` with ``digits`` decimals right-aligned in ``width`` characters; ``-`` for a
    missing or non-finite value (units are the caller's)."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-".rjust(width)
    return f"{value:{width}.{digits}f}"


def name_width(names, header: str = "", minimum: int = 10) -> int:
    """Width of a table's name column: every name shown whole (two logs whose names
    differ only at the end must not look the same)."""
    return max([minimum, len(header)] + [len(str(n)) for n in names])


#: Help of the option that picks a PX4 topic export's battery instance.
BATTERY_INSTANCE_HELP = ("battery_status instance of a PX4 topic export (a folder or zip of "
                         "ulog2csv CSV files); default: the one that carries the current")


def add_battery_instance(parser) -> None:
    """The ``--battery-instance N`` option of the commands that read logs."""
    parser.add_argument("--battery-instance", metavar="N", help=BATTERY_INSTANCE_HELP)


def battery_instance(args) -> int | None:
    """The parsed ``--battery-instance`` (None when not given)."""
    text = getattr(args, "battery_instance", None)
    return None if text is None else parse_int(text, "--battery-instance", 0, 255)


#: The options several commands share, with their argparse settings (flag: ``--`` and the
#: name with ``-`` for ``_``; ``mission`` is the first argument). A command gives each its
#: own help where it means more there (:func:`add_options`).
SHARED_OPTIONS: dict[str, dict[str, Any]] = {
    "mission": {"help": "mission file: .yaml, QGroundControl .plan or Mission Planner "
                        ".waypoints"},
    "aircraft": {"required": True, "help": "aircraft YAML"},
    "battery": {"help": "battery-pack YAML (default: the aircraft's)"},
    "map": {"help": "column map for CSV data that is not a flight record (e.g. dji_m100)"},
    "wind": {"help": "SPEED@FROM_DEG, e.g. 6@270 (overrides the mission's)"},
    "temperature": {"help": "outside air temperature [°C]"},
    "reserve": {"default": "0.2", "help": "landing reserve fraction (default 0.2)"},
    "payload": {"help": "payload mass [kg] (overrides the mission's)"},
    "mass": {"help": "all-up mass [kg] (overrides aircraft + pack + payload)"},
    "site_altitude": {"default": "0", "help": "site altitude AMSL [m] (default 0)"},
    "out": {"help": "file to write"},
    "json": {"help": "write the result as JSON to this file"},
    "plot": {"help": "write a PNG"},
    "csv": {"help": "write the table as CSV"},
}


def add_options(parser, **options: bool | str | dict[str, Any]) -> None:
    """Add shared options (:data:`SHARED_OPTIONS`) to ``parser``, in the order given:
    ``name=True`` with the shared settings, ``name="…"`` with this help, ``name={…}``
    with these settings over the shared ones (``{"default": "0", "help": …}``)."""
    for name, given in options.items():
        settings = dict(SHARED_OPTIONS[name])
        if isinstance(given, str):
            settings["help"] = given
        elif isinstance(given, dict):
            settings.update(given)
        flag = name if name == "mission" else "--" + name.replace("_", "-")
        parser.add_argument(flag, **settings)
