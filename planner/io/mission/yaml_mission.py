"""YAML mission files: a list of legs, or a waypoint route.

Legs form (positions dead-reckoned from home, course 0 = north, clockwise)::

    name: Field survey
    payload_kg: 0.3
    environment: {wind_speed_ms: 4, wind_from_deg: 270, temperature_c: 15}
    legs:
      - climb: {altitude_m: 60, rate_ms: 3}          # or height_m: 40 (relative)
      - cruise: {distance_m: 2000, course_deg: 90, airspeed_ms: 12}
                                                      # or groundspeed_ms; altitude_m optional
      - hover: {duration_s: 60}
      - loiter: {duration_s: 120, radius_m: 60, airspeed_ms: 14}
                                                      # or turns: 3 (needs radius_m and a speed)
      - descend: {altitude_m: 0, rate_ms: 2}          # or height_m; nothing = to 0

Waypoints form (flown by :mod:`planner.io.mission.route`, like ``.plan`` and
``.waypoints`` files)::

    home: {lat: 48.04, lon: 10.45, alt_m: 612}        # alt_m above mean sea level
    takeoff_alt_m: 50                                 # optional vertical take-off
    speed_ms: 6                                       # optional default speed; or
                                                      # groundspeed_ms / airspeed_ms
    waypoints:
      - {lat: 48.041, lon: 10.451, alt_m: 50}         # alt_m above home
      - {lat: 48.042, lon: 10.451, alt_m: 50, hold_s: 30, groundspeed_ms: 5}
    return_home: true                                 # default true: fly home
    land: true                                        # default true: descend to 0 at the end

A waypoint's speed applies from the flight *to* that waypoint on (as a
``DO_CHANGE_SPEED`` placed before it). ``speed_ms`` leaves the kind of speed
to the aircraft type; ``groundspeed_ms`` / ``airspeed_ms`` say which.

Common keys: ``name`` (default: the file name), ``payload_kg`` (default 0),
``environment`` (``wind_speed_ms``, ``wind_from_deg``, ``temperature_c``,
``pressure_pa``, ``site_altitude_m``; all optional, the site altitude defaults
to the home altitude), ``source``, and ``home`` (optional in the legs form).

The keys of each block are declared once (:data:`TOP_KEYS`, :data:`ENVIRONMENT_KEYS`,
:data:`HOME_KEYS`, :data:`WAYPOINT_KEYS`, :data:`LEG_KEYS`) and checked by the validator of
the definition files, :mod:`planner.io.schema`, in its words: every problem found is
reported at once, in one line naming the file and each key path
(``unknown key 'legs[2].cruise.distnce_m' (did you mean 'legs[2].cruise.distance_m'?)``).

Bounds (shared with the other formats, see :mod:`planner.io.mission.route`): a
hover, a loiter or a waypoint's ``hold_s`` lasts 0 to
:data:`~planner.mission.route.MAX_HOLD_S` (24 h), and so do all of them
together; a cruise is at most :data:`MAX_LEG_M` long; a loiter has at most
:data:`~planner.mission.route.MAX_LOITER_TURNS` turns; the home and site
altitudes and every altitude of the mission (site altitude + altitude above
home) lie in the atmosphere model's range,
:data:`planner.physics.atmosphere.ALTITUDE_RANGE_M`; numbers are finite.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any

import yaml

from planner.io import files
from planner.physics.atmosphere import ALTITUDE_RANGE_M, MAX_WIND_MS
from planner.errors import InputError
from planner.physics.geo import EARTH_RADIUS_M
from planner.physics.mission import (LEG_KINDS, Environment, Leg, Mission, NavDefaults,
                                     too_many)
from planner.io.mission.route import (
    MAX_HOLD_S,
    MAX_LOITER_TURNS,
    MAX_SPEED_MS,
    RouteStep,
    altitude_problem,
    hold_problem,
    route_to_legs,
    total_hold_problem,
)
from planner.io import schema
from planner.io.schema import (BOOL, EXPONENT_TEXT, LIST, NUMBER, Key, Problems, between,
                               block, non_negative, positive, refuse_other_kind)

#: Slowest mission speed: slower, a leg never ends in a flight's time. [m/s]
MIN_SPEED_MS = 0.1

#: Longest cruise leg of the legs form: half the Earth's circumference, the
#: longest great circle between two points. [m]
MAX_LEG_M = math.pi * EARTH_RADIUS_M
_ATMOSPHERE = "the atmosphere model's range, m above mean sea level"
_24H = "24 h"


def _speed_key(meaning: str) -> Key:
    return between(MIN_SPEED_MS, MAX_SPEED_MS, unit="m/s", meaning=meaning,
                   why_low="slower, the leg never ends", why_high="the aircraft files' bound")


#: The keys of a mission file (:mod:`planner.io.schema`: type, unit, bound, meaning),
#: one table per block; the legs and the waypoints forms take some of the top keys each.
COMMON_KEYS = {
    "name": schema.text("mission name (default: the file name)"),
    "source": schema.text("provenance note (validated, not stored)"),
    "payload_kg": non_negative(default=0.0, unit="kg", meaning="payload carried"),
    "environment": block("wind, temperature, pressure and site altitude"),
    "home": block("home point (required with waypoints)"),
}
LEGS_KEYS = {**COMMON_KEYS, "legs": Key(LIST, meaning="the legs, in order")}
WAYPOINTS_KEYS = {
    **COMMON_KEYS,
    "waypoints": Key(LIST, meaning="the waypoints, in order"),
    "takeoff_alt_m": positive(unit="m", meaning="vertical take-off to this altitude above "
                                                "home"),
    "speed_ms": _speed_key("default speed (kind from the aircraft type)"),
    "groundspeed_ms": _speed_key("default ground speed"),
    "airspeed_ms": _speed_key("default airspeed"),
    "return_home": Key(BOOL, default=True, meaning="fly home at the end"),
    "land": Key(BOOL, default=True, meaning="descend to 0 at the end"),
}
TOP_KEYS = {**LEGS_KEYS, **WAYPOINTS_KEYS}
ENVIRONMENT_KEYS = {
    "wind_speed_ms": between(0.0, MAX_WIND_MS, unit="m/s", meaning="wind speed",
                             why_high="above any sustained surface wind on record"),
    "wind_from_deg": Key(NUMBER, unit="deg", meaning="bearing the wind blows from "
                                                     "(taken modulo 360°)"),
    "temperature_c": between(-90.0, 60.0, unit="°C", meaning="air temperature",
                             why_low="the coldest air on record",
                             why_high="the hottest on record"),
    "pressure_pa": positive(unit="Pa", meaning="static pressure"),
    "site_altitude_m": between(*ALTITUDE_RANGE_M, unit="m", why=_ATMOSPHERE,
                               meaning="site altitude (default: the home altitude)"),
}
HOME_KEYS = {
    "lat": between(-90, 90, required=True, unit="deg", meaning="latitude"),
    "lon": between(-180, 180, required=True, unit="deg", meaning="longitude"),
    "alt_m": between(*ALTITUDE_RANGE_M, required=True, unit="m", why=_ATMOSPHERE,
                     meaning="altitude above mean sea level"),
}
WAYPOINT_KEYS = {
    "lat": between(-90, 90, required=True, unit="deg", meaning="latitude"),
    "lon": between(-180, 180, required=True, unit="deg", meaning="longitude"),
    "alt_m": Key(NUMBER, required=True, unit="m", meaning="altitude above home"),
    "speed_ms": _speed_key("speed from the flight to this waypoint on"),
    "groundspeed_ms": _speed_key("ground speed from the flight to this waypoint on"),
    "airspeed_ms": _speed_key("airspeed from the flight to this waypoint on"),
    "hold_s": between(0.0, MAX_HOLD_S, unit="s", why_high=_24H, meaning="hold at the waypoint"),
}
_ALTITUDE = Key(NUMBER, unit="m", meaning="altitude above home")
_RATE = positive(unit="m/s", meaning="vertical speed")
#: Parameters of each leg kind.
LEG_KEYS = {
    "climb": {"altitude_m": _ALTITUDE, "height_m": positive(unit="m", meaning="relative"),
              "rate_ms": _RATE},
    "descend": {"altitude_m": _ALTITUDE, "height_m": positive(unit="m", meaning="relative"),
                "rate_ms": _RATE},
    "cruise": {"distance_m": between(0.0, MAX_LEG_M, required=True, unit="m",
                                     why_high="half the Earth's circumference"),
               "course_deg": Key(NUMBER, required=True, unit="deg",
                                 meaning="0 = north, clockwise"),
               "airspeed_ms": _speed_key("airspeed"),
               "groundspeed_ms": _speed_key("ground speed"),
               "altitude_m": _ALTITUDE},
    "hover": {"duration_s": between(0.0, MAX_HOLD_S, required=True, unit="s", why_high=_24H)},
    "loiter": {"duration_s": between(0.0, MAX_HOLD_S, unit="s", why_high=_24H),
               "turns": positive(high=MAX_LOITER_TURNS, why="the most ArduPilot stores"),
               "radius_m": positive(unit="m"),
               "airspeed_ms": _speed_key("airspeed"),
               "groundspeed_ms": _speed_key("ground speed")},
}
SPEED_KEYS = {"speed_ms": None, "groundspeed_ms": False, "airspeed_ms": True}


def _join(path: str, key: str | int) -> str:
    if isinstance(key, int):
        return f"{path}[{key + 1}]"
    return f"{path}.{key}" if path else key


def _add(chk: Problems, path: str, message: str) -> None:
    """Record a problem of the rules across keys, naming its key path."""
    chk.add(f"{path} {message}" if path else message)


def _describe(value: Any) -> str:
    if isinstance(value, (dict, list)):
        return f"a {'mapping' if isinstance(value, dict) else 'list'}"
    return schema.shown(value)


def _block(chk: Problems, value: Any, spec: dict[str, Key], path: str, *,
           empty_ok: bool = True) -> dict | None:
    """The values of one mapping of the file checked against its table (:mod:`planner.io.
    schema`): a value with a problem is None (the problem recorded); None when ``value``
    is not a mapping. A number written ``1e3`` (YAML 1.1 reads it as text) is the number."""
    if value is None and empty_ok:
        value = {}
    if not isinstance(value, dict):
        _add(chk, path, f"must be {schema.expected(schema.MAPPING)} "
                        f"({', '.join(spec)}), got {_describe(value)}")
        return None
    value = {k: (float(v) if isinstance(v, str) and k in spec and spec[k].kind == NUMBER
                 and EXPONENT_TEXT.fullmatch(v.strip()) else v) for k, v in value.items()}
    rejected: set[str] = set()
    prefix = f"{path}." if path else ""
    out = schema.check_mapping(value, spec, chk.where, prefix, chk, rejected)
    return {k: (None if k in rejected else v) for k, v in out.items()}


def _altitude(chk: Problems, path: str, written: float, alt_m: float, site: float) -> bool:
    """Record a problem if ``alt_m`` above home is outside the atmosphere model.

    ``written`` is the value in the file (``alt_m`` itself, or a ``height_m``).
    Returns True when the altitude is accepted.
    """
    problem = altitude_problem(alt_m, site)
    if problem is None:
        return True
    to = "" if written == alt_m else f" (to {alt_m:g} m above home)"
    _add(chk, path, f"{written:g} m{to} {problem}")
    return False


def _one_of(chk: Problems, given: dict, keys: tuple[str, ...], path: str) -> str | None:
    """The one of ``keys`` given (more than one is a problem)."""
    return schema.one_of(given, keys, chk, f"{path}." if path else "")


def _speed(chk: Problems, v: dict, given: dict, path: str,
           keys=("airspeed_ms", "groundspeed_ms")) -> tuple[float | None, bool | None]:
    """The speed given (one of ``keys``) and its kind (:data:`SPEED_KEYS`)."""
    key = _one_of(chk, given, keys, path)
    if key is None:
        return None, None
    return v[key], SPEED_KEYS[key]


# --------------------------------------------------------------------------


def _environment(chk: Problems, data: dict, site_default: float) -> Environment:
    env = _block(chk, data.get("environment"), ENVIRONMENT_KEYS, "environment")
    if not env:
        return Environment(site_altitude_m=site_default)
    site = env["site_altitude_m"]
    return Environment(wind_speed_ms=env["wind_speed_ms"] or 0.0,
                       wind_from_deg=(env["wind_from_deg"] or 0.0) % 360.0,
                       temperature_c=env["temperature_c"], pressure_pa=env["pressure_pa"],
                       site_altitude_m=site_default if site is None else site)


def _home(chk: Problems, data: dict, required: bool) -> tuple[float, float, float] | None:
    if "home" not in data:
        if required:
            chk.add("missing required key 'home' (a mapping lat, lon, alt_m: the waypoints "
                    "form needs it)")
        return None
    home = _block(chk, data["home"], HOME_KEYS, "home", empty_ok=False)
    if home is None or None in home.values():
        return None
    return home["lat"], home["lon"], home["alt_m"]


def _vertical_leg(chk: Problems, kind: str, v: dict, given: dict, path: str, origin: str,
                  pos: tuple[float, float], alt: float, site: float) -> Leg | None:
    """A ``climb`` or ``descend`` leg: to ``altitude_m`` above home or by ``height_m``
    (a descent with neither goes to 0), at ``rate_ms``."""
    key = _one_of(chk, given, ("altitude_m", "height_m"), path)
    if key is None and kind == "climb":
        _add(chk, path, "needs altitude_m (above home) or height_m (relative)")
        return None
    if key == "height_m":
        h = v["height_m"]
        target = alt + (h if kind == "climb" else -h)
    else:
        target = 0.0 if key is None else v["altitude_m"]
    written = target if key != "height_m" else v["height_m"]
    if not _altitude(chk, _join(path, key or "altitude_m"), float(written), target, site):
        return None
    if (kind == "climb") != (target > alt):
        _add(chk, path, f"goes from {alt:g} m to {target:g} m (expected a "
                        f"{'higher' if kind == 'climb' else 'lower'} altitude; use "
                        f"{'descend' if kind == 'climb' else 'climb'})")
        return None
    return Leg(kind, start_en_m=pos, end_en_m=pos, start_alt_m=alt, end_alt_m=target,
               climb_rate_ms=v["rate_ms"], origin=origin)


def _cruise_leg(chk: Problems, kind: str, v: dict, given: dict, path: str, origin: str,
                pos: tuple[float, float], alt: float, site: float) -> Leg | None:
    """A ``cruise``: ``distance_m`` along ``course_deg`` (0 = north, clockwise), to an
    optional ``altitude_m``, at an optional air- or ground speed."""
    speed, is_air = _speed(chk, v, given, path)
    new_alt = v["altitude_m"]
    if new_alt is not None and not _altitude(chk, _join(path, "altitude_m"), new_alt,
                                             new_alt, site):
        return None
    c = math.radians(v["course_deg"])
    dist = v["distance_m"]
    end = (pos[0] + dist * math.sin(c), pos[1] + dist * math.cos(c))
    end_alt = alt if new_alt is None else new_alt
    return Leg("cruise", start_en_m=pos, end_en_m=end, start_alt_m=alt, end_alt_m=end_alt,
               speed_ms=speed, speed_is_airspeed=is_air, origin=origin)


def _hover_leg(chk: Problems, kind: str, v: dict, given: dict, path: str, origin: str,
               pos: tuple[float, float], alt: float, site: float) -> Leg | None:
    """A ``hover`` of ``duration_s`` where the aircraft is."""
    return Leg("hover", start_en_m=pos, end_en_m=pos, start_alt_m=alt, end_alt_m=alt,
               duration_s=v["duration_s"], origin=origin)


def _loiter_leg(chk: Problems, kind: str, v: dict, given: dict, path: str, origin: str,
                pos: tuple[float, float], alt: float, site: float) -> Leg | None:
    """A ``loiter`` of ``duration_s``, or of ``turns`` (duration turns × 2π radius /
    speed, so ``radius_m`` and a speed are needed)."""
    key = _one_of(chk, given, ("duration_s", "turns"), path)
    radius = v["radius_m"]
    speed, is_air = _speed(chk, v, given, path)
    if key is None:
        _add(chk, path, "needs duration_s, or turns with radius_m and airspeed_ms")
        return None
    dur = v["duration_s"]
    if key == "turns":
        turns = v["turns"]
        if radius is None or speed is None:
            _add(chk, path, "turns needs radius_m and airspeed_ms (or groundspeed_ms): "
                            "the duration is turns x 2 pi radius / speed")
            return None
        dur = turns * 2.0 * math.pi * radius / speed
        if hold_problem(dur):
            _add(chk, path, f"{turns:g} turns of {radius:g} m at {speed:g} m/s: "
                            f"{hold_problem(dur, 'loiter time')}")
            return None
    return Leg("loiter", start_en_m=pos, end_en_m=pos, start_alt_m=alt, end_alt_m=alt,
               speed_ms=speed, speed_is_airspeed=is_air, duration_s=dur,
               loiter_radius_m=radius, origin=origin)


#: Leg kind → the reader of its checked parameters (``v``: the values of
#: :data:`LEG_KEYS`, ``given``: the mapping as written); each returns the leg, or None
#: after recording its problem.
_LEG_READERS = {"climb": _vertical_leg, "descend": _vertical_leg, "cruise": _cruise_leg,
                "hover": _hover_leg, "loiter": _loiter_leg}


def _leg_item(chk: Problems, item: Any, path: str) -> tuple[str, Any] | None:
    """``(kind, parameters)`` of one item of ``legs`` (a one-key mapping of a known
    kind), or None after recording the problem."""
    if not isinstance(item, dict) or len(item) != 1:
        _add(chk, path, "must be a one-key mapping {kind: {parameters}} with kind one of "
                        f"{', '.join(LEG_KINDS)}, got {_describe(item)}")
        return None
    (kind, params), = item.items()
    if kind not in LEG_KINDS:
        hint = difflib.get_close_matches(str(kind), LEG_KINDS, n=1)
        tip = f"did you mean {hint[0]!r}? " if hint else ""
        _add(chk, path, f"has unknown leg kind {kind!r} ({tip}expected one of "
                        f"{', '.join(LEG_KINDS)})")
        return None
    return kind, params


def _legs_form(chk: Problems, raw: Any, site: float) -> list[Leg]:
    """The legs of the legs form, dead-reckoned from home (each kind read by
    :data:`_LEG_READERS`); every problem recorded."""
    if not isinstance(raw, list):
        _add(chk, "legs", f"must be a list of legs, got {_describe(raw)}")
        return []
    if not raw:
        _add(chk, "legs", f"is empty (expected at least one leg: {', '.join(LEG_KINDS)})")
        return []
    if (msg := too_many(chk.where, "legs", len(raw))) is not None:
        raise InputError(msg)
    legs: list[Leg] = []
    pos = (0.0, 0.0)
    alt = 0.0
    for i, item in enumerate(raw):
        origin = f"legs[{i + 1}]"
        kind_params = _leg_item(chk, item, origin)
        if kind_params is None:
            continue
        kind, params = kind_params
        path = f"{origin}.{kind}"
        before = len(chk)
        v = _block(chk, params, LEG_KEYS[kind], path)
        if v is None or len(chk) > before:     # a leg with a problem is not flown
            continue
        leg = _LEG_READERS[kind](chk, kind, v, params or {}, path, origin, pos, alt, site)
        if leg is not None:
            legs.append(leg)
            pos, alt = leg.end_en_m, leg.end_alt_m
    too_long = total_hold_problem(legs)
    if too_long:
        _add(chk, too_long[0], too_long[1])
    return legs


def _waypoints_form(chk: Problems, data: dict, top: dict,
                    home: tuple[float, float, float] | None, site: float,
                    defaults: NavDefaults | None = None) -> list[Leg]:
    """The route of the waypoints form (``top``: the checked top-level values), flown
    from home by :func:`planner.io.mission.route.route_to_legs`."""
    raw = data["waypoints"]
    if not isinstance(raw, list):
        _add(chk, "waypoints", f"must be a list of waypoints, got {_describe(raw)}")
        return []
    if not raw:
        _add(chk, "waypoints", "is empty (expected at least one {lat, lon, alt_m})")
        return []
    if (msg := too_many(chk.where, "waypoints", len(raw))) is not None:
        raise InputError(msg)
    steps: list[RouteStep] = []
    takeoff = top["takeoff_alt_m"]
    if takeoff is not None and not _altitude(chk, "takeoff_alt_m", takeoff, takeoff, site):
        takeoff = None
    if takeoff is not None:
        steps.append(RouteStep("takeoff", alt_m=takeoff, origin="takeoff_alt_m"))
    speed, is_air = _speed(chk, top, data, "", keys=tuple(SPEED_KEYS))
    for i, item in enumerate(raw):
        path = f"waypoints[{i + 1}]"
        wp = _block(chk, item, WAYPOINT_KEYS, path, empty_ok=False)
        if wp is None:
            continue
        alt = wp["alt_m"]
        if alt is not None and not _altitude(chk, _join(path, "alt_m"), alt, alt, site):
            alt = None
        wp_speed, wp_air = _speed(chk, wp, item, path, keys=tuple(SPEED_KEYS))
        if wp_speed is not None:
            steps.append(RouteStep("speed", speed_ms=wp_speed, speed_is_airspeed=wp_air,
                                   origin=path))
        if wp["lat"] is not None and wp["lon"] is not None and alt is not None:
            steps.append(RouteStep("waypoint", wp["lat"], wp["lon"], alt,
                                   hold_s=wp["hold_s"], origin=path))
    if len(chk) or home is None:
        return []
    go_home, land = top["return_home"], top["land"]
    if go_home and land:
        steps.append(RouteStep("rtl", origin="return_home"))
    elif go_home:
        steps.append(RouteStep("waypoint", home[0], home[1], None, origin="return_home"))
    elif land:
        steps.append(RouteStep("land", origin="land"))
    return route_to_legs(steps, home[0], home[1], where=chk.where, speed_ms=speed,
                         speed_is_airspeed=is_air, defaults=defaults)


def load_yaml_mission(path: str | Path, *, vehicle_type: str | None = None,
                      defaults: NavDefaults | None = None) -> Mission:
    """Load a YAML mission (legs form or waypoints form).

    Parameters
    ----------
    path : str or Path
    vehicle_type : {"multirotor", "fixed_wing"} or None
        Not needed by this format (kept for a uniform loader signature).
    defaults : NavDefaults or None
        The aircraft's speeds and rates: the waypoints form's climbs are bounded by them
        as a waypoint file's are (:func:`planner.io.mission.route.route_to_legs`); the
        legs form is flown as written.

    Returns
    -------
    Mission
        The legs flown from home, the environment, the payload.

    Raises
    ------
    InputError
        Unreadable YAML, an unknown key (with the closest valid one), a wrong
        type, an impossible value, an empty mission or an unknown leg kind;
        every problem in the file, in one line.
    """
    path = Path(path)
    where = str(path)
    try:
        data = files.load_yaml(path, "mission", "mission file")
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1} column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or "syntax error"
        raise InputError(f"{where}: not valid YAML{at}: {problem}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{where}: cannot read the file ({exc})") from None
    if data is None:
        raise InputError(f"{where}: empty file (expected a mission with legs: or waypoints:)")
    if not isinstance(data, dict):
        raise InputError(f"{where}: expected a mapping with legs: or waypoints:, got "
                         f"{_describe(data)}")
    refuse_other_kind(data, "mission", where)
    chk = Problems(where)
    has_legs, has_wps = "legs" in data, "waypoints" in data
    if has_legs and has_wps:
        chk.add("give either legs: or waypoints:, not both")
    elif not (has_legs or has_wps):
        chk.add("no legs: or waypoints: (expected one of them: the mission is empty)")
    spec = WAYPOINTS_KEYS if has_wps else LEGS_KEYS if has_legs else TOP_KEYS
    other = [k for k in data if k in TOP_KEYS and k not in spec]
    for key in other:
        chk.add(f"unknown key '{key}' (only used with waypoints:, not with legs:)")
    top = _block(chk, {k: v for k, v in data.items() if k not in other}, spec, "")
    name = top["name"] if top["name"] is not None else path.stem
    home = _home(chk, data, required=has_wps)
    env = _environment(chk, data, home[2] if home else 0.0)
    legs: list[Leg] = []
    if has_legs and not has_wps:
        legs = _legs_form(chk, data["legs"], env.site_altitude_m)
    elif has_wps and not has_legs:
        legs = _waypoints_form(chk, data, top, home, env.site_altitude_m, defaults)
    chk.done()
    return Mission(name=str(name), legs=legs, environment=env,
                   payload_kg=top["payload_kg"] or 0.0, home=home, source=where)
