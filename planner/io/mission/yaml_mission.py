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

Every problem found is reported at once, in one line naming the file and each
key path (``legs[2].cruise.distance_m``).

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
from planner.io.schema import EXPONENT_TEXT, refuse_other_kind

#: Slowest mission speed: slower, a leg never ends in a flight's time. [m/s]
MIN_SPEED_MS = 0.1

COMMON_KEYS = ("name", "source", "payload_kg", "environment", "home")
LEGS_KEYS = COMMON_KEYS + ("legs",)
WAYPOINTS_KEYS = COMMON_KEYS + ("waypoints", "takeoff_alt_m", "speed_ms", "groundspeed_ms",
                                "airspeed_ms", "return_home", "land")
TOP_KEYS = tuple(dict.fromkeys(LEGS_KEYS + WAYPOINTS_KEYS))
ENVIRONMENT_KEYS = ("wind_speed_ms", "wind_from_deg", "temperature_c", "pressure_pa",
                    "site_altitude_m")
HOME_KEYS = ("lat", "lon", "alt_m")
WAYPOINT_KEYS = ("lat", "lon", "alt_m", "speed_ms", "groundspeed_ms", "airspeed_ms", "hold_s")
#: Parameters of each leg kind.
LEG_KEYS = {
    "climb": ("altitude_m", "height_m", "rate_ms"),
    "descend": ("altitude_m", "height_m", "rate_ms"),
    "cruise": ("distance_m", "course_deg", "airspeed_ms", "groundspeed_ms", "altitude_m"),
    "hover": ("duration_s",),
    "loiter": ("duration_s", "turns", "radius_m", "airspeed_ms", "groundspeed_ms"),
}
SPEED_KEYS = {"speed_ms": None, "groundspeed_ms": False, "airspeed_ms": True}

#: Longest cruise leg of the legs form: half the Earth's circumference, the
#: longest great circle between two points. [m]
MAX_LEG_M = math.pi * EARTH_RADIUS_M
_ATMOSPHERE = "the atmosphere model's range, m above mean sea level"
_MISSING = object()


def _join(path: str, key: str | int) -> str:
    if isinstance(key, int):
        return f"{path}[{key + 1}]"
    return f"{path}.{key}" if path else key


class _Checker:
    """Collects the problems of one file, to report them all at once."""

    def __init__(self, where: str):
        self.where = where
        self.problems: list[str] = []

    def add(self, path: str, message: str) -> None:
        self.problems.append(f"{path} {message}" if path else message)

    def done(self) -> None:
        if self.problems:
            raise InputError(f"{self.where}: " + "; ".join(self.problems))

    def mapping(self, value: Any, path: str, *, allowed: tuple[str, ...],
                empty_ok: bool = True) -> dict | None:
        if value is None and empty_ok:
            return {}
        if not isinstance(value, dict):
            self.add(path, f"must be a mapping (keys {', '.join(allowed)}), "
                     f"got {_describe(value)}")
            return None
        for key in value:
            if key not in allowed:
                hint = difflib.get_close_matches(str(key), allowed, n=1)
                tip = f"did you mean {hint[0]!r}?" if hint else f"expected one of {', '.join(allowed)}"
                self.add(_join(path, str(key)), f"is not a known key ({tip})")
        return value

    def number(self, mapping: dict, key: str, path: str, *, required: bool = False,
               minimum: float | None = None, positive: bool = False,
               maximum: float | None = None, why_max: str = "",
               why_min: str = "") -> float | None:
        """A finite number (``None`` where absent or bad, the problem recorded).

        ``why_max`` and ``why_min`` explain the bounds in the message, e.g. ``"24 h"``.
        """
        full = _join(path, key)
        value = mapping.get(key, _MISSING)
        if value is _MISSING or value is None:
            if required:
                self.add(full, "is required (a number)")
            return None
        if isinstance(value, str) and EXPONENT_TEXT.fullmatch(value.strip()):
            value = float(value)  # YAML 1.1 reads 1e3 (no dot) as a string
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.add(full, f"must be a number, got {_describe(value)}")
            return None
        try:
            value = float(value)
        except OverflowError:                 # an integer too large for a float
            self.add(full, f"must be a finite number, got an integer of "
                           f"{len(str(abs(value)))} digits")
            return None
        if not math.isfinite(value):
            self.add(full, f"must be a finite number, got {value}")
            return None
        if positive and value <= 0:
            self.add(full, f"must be > 0, got {value:g}")
            return None
        if minimum is not None and value < minimum:
            why = f" ({why_min})" if why_min else ""
            self.add(full, f"must be >= {minimum:g}{why}, got {value:g}")
            return None
        if maximum is not None and value > maximum:
            why = f" ({why_max})" if why_max else ""
            self.add(full, f"must be <= {maximum:g}{why}, got {value:g}")
            return None
        return value

    def boolean(self, mapping: dict, key: str, path: str, default: bool) -> bool:
        value = mapping.get(key, default)
        if not isinstance(value, bool):
            self.add(_join(path, key), f"must be true or false, got {_describe(value)}")
            return default
        return value

    def text(self, mapping: dict, key: str, path: str, default: str) -> str:
        value = mapping.get(key, default)
        if value is None:
            return default
        if not isinstance(value, (str, int, float)) or isinstance(value, bool):
            self.add(_join(path, key), f"must be text, got {_describe(value)}")
            return default
        return str(value)

    def one_of(self, mapping: dict, keys: tuple[str, ...], path: str) -> str | None:
        """The one of ``keys`` present (at most one allowed)."""
        present = [k for k in keys if k in mapping]
        if len(present) > 1:
            self.add(path, f"give only one of {' or '.join(present)}")
        return present[0] if present else None


def _describe(value: Any) -> str:
    if isinstance(value, (dict, list)):
        return f"a {'mapping' if isinstance(value, dict) else 'list'}"
    return f"{value!r} ({type(value).__name__})"


def _altitude(chk: _Checker, path: str, written: float, alt_m: float, site: float) -> bool:
    """Record a problem if ``alt_m`` above home is outside the atmosphere model.

    ``written`` is the value in the file (``alt_m`` itself, or a ``height_m``).
    Returns True when the altitude is accepted.
    """
    problem = altitude_problem(alt_m, site)
    if problem is None:
        return True
    to = "" if written == alt_m else f" (to {alt_m:g} m above home)"
    chk.add(path, f"{written:g} m{to} {problem}")
    return False


def _speed(chk: _Checker, mapping: dict, path: str, keys=("airspeed_ms", "groundspeed_ms")
           ) -> tuple[float | None, bool | None]:
    key = chk.one_of(mapping, keys, path)
    if key is None:
        return None, None
    speed = chk.number(mapping, key, path, positive=True, maximum=MAX_SPEED_MS,
                       why_max="the aircraft files' bound")
    if speed is not None and speed < MIN_SPEED_MS:
        chk.add(_join(path, key), f"must be >= {MIN_SPEED_MS:g} m/s (slower, the leg never "
                                  f"ends), got {speed:g}")
        speed = None
    return speed, SPEED_KEYS[key]


# --------------------------------------------------------------------------


def _environment(chk: _Checker, data: dict, site_default: float) -> Environment:
    env = chk.mapping(data.get("environment"), "environment", allowed=ENVIRONMENT_KEYS)
    if not env:
        return Environment(site_altitude_m=site_default)
    p = "environment"
    wind = chk.number(env, "wind_speed_ms", p, minimum=0.0, maximum=MAX_WIND_MS,
                      why_max="above any sustained surface wind on record")
    wind_from = chk.number(env, "wind_from_deg", p)  # a bearing: taken modulo 360°
    temp = chk.number(env, "temperature_c", p, minimum=-90.0, maximum=60.0,
                      why_min="the coldest air on record", why_max="the hottest on record")
    pressure = chk.number(env, "pressure_pa", p, positive=True)
    site = chk.number(env, "site_altitude_m", p, minimum=ALTITUDE_RANGE_M[0],
                      maximum=ALTITUDE_RANGE_M[1], why_max=_ATMOSPHERE,
                      why_min=_ATMOSPHERE)
    return Environment(wind_speed_ms=wind or 0.0,
                       wind_from_deg=(wind_from or 0.0) % 360.0,
                       temperature_c=temp, pressure_pa=pressure,
                       site_altitude_m=site_default if site is None else site)


def _home(chk: _Checker, data: dict, required: bool) -> tuple[float, float, float] | None:
    if "home" not in data:
        if required:
            chk.add("home", "is required with waypoints: (a mapping lat, lon, alt_m)")
        return None
    home = chk.mapping(data["home"], "home", allowed=HOME_KEYS, empty_ok=False)
    if home is None:
        return None
    lat = chk.number(home, "lat", "home", required=True, minimum=-90, maximum=90)
    lon = chk.number(home, "lon", "home", required=True, minimum=-180, maximum=180)
    alt = chk.number(home, "alt_m", "home", required=True, minimum=ALTITUDE_RANGE_M[0],
                     maximum=ALTITUDE_RANGE_M[1], why_max=_ATMOSPHERE,
                     why_min=_ATMOSPHERE)
    if lat is None or lon is None or alt is None:
        return None
    return lat, lon, alt


def _legs_form(chk: _Checker, raw: Any, site: float) -> list[Leg]:
    if not isinstance(raw, list):
        chk.add("legs", f"must be a list of legs, got {_describe(raw)}")
        return []
    if not raw:
        chk.add("legs", "is empty (expected at least one leg: "
                f"{', '.join(LEG_KINDS)})")
        return []
    if (msg := too_many(chk.where, "legs", len(raw))) is not None:
        raise InputError(msg)
    legs: list[Leg] = []
    pos = (0.0, 0.0)
    alt = 0.0
    for i, item in enumerate(raw):
        path = f"legs[{i + 1}]"
        if not isinstance(item, dict) or len(item) != 1:
            chk.add(path, "must be a one-key mapping {kind: {parameters}} with kind one of "
                    f"{', '.join(LEG_KINDS)}, got {_describe(item)}")
            continue
        (kind, params), = item.items()
        if kind not in LEG_KINDS:
            hint = difflib.get_close_matches(str(kind), LEG_KINDS, n=1)
            tip = f"did you mean {hint[0]!r}? " if hint else ""
            chk.add(path, f"has unknown leg kind {kind!r} ({tip}expected one of "
                    f"{', '.join(LEG_KINDS)})")
            continue
        path = f"{path}.{kind}"
        before = len(chk.problems)
        p = chk.mapping(params, path, allowed=LEG_KEYS[kind])
        if p is None:
            continue
        origin = f"legs[{i + 1}]"
        if kind in ("climb", "descend"):
            key = chk.one_of(p, ("altitude_m", "height_m"), path)
            rate = chk.number(p, "rate_ms", path, positive=True)
            if key is None and kind == "climb":
                chk.add(path, "needs altitude_m (above home) or height_m (relative)")
                continue
            if key == "height_m":
                h = chk.number(p, "height_m", path, positive=True)
                target = None if h is None else alt + (h if kind == "climb" else -h)
            else:
                target = 0.0 if key is None else chk.number(p, "altitude_m", path)
            if target is None or len(chk.problems) > before:
                continue
            written = target if key != "height_m" else p["height_m"]
            if not _altitude(chk, _join(path, key or "altitude_m"), float(written), target, site):
                continue
            if (kind == "climb") != (target > alt):
                chk.add(path, f"goes from {alt:g} m to {target:g} m (expected a "
                        f"{'higher' if kind == 'climb' else 'lower'} altitude; use "
                        f"{'descend' if kind == 'climb' else 'climb'})")
                continue
            legs.append(Leg(kind, start_en_m=pos, end_en_m=pos, start_alt_m=alt,
                            end_alt_m=target, climb_rate_ms=rate, origin=origin))
            alt = target
        elif kind == "cruise":
            dist = chk.number(p, "distance_m", path, required=True, minimum=0.0,
                              maximum=MAX_LEG_M, why_max="half the Earth's circumference")
            course = chk.number(p, "course_deg", path, required=True)
            speed, is_air = _speed(chk, p, path)
            new_alt = chk.number(p, "altitude_m", path)
            if dist is None or course is None or len(chk.problems) > before:
                continue
            if new_alt is not None and not _altitude(chk, _join(path, "altitude_m"), new_alt,
                                                     new_alt, site):
                continue
            c = math.radians(course)
            end = (pos[0] + dist * math.sin(c), pos[1] + dist * math.cos(c))
            end_alt = alt if new_alt is None else new_alt
            legs.append(Leg("cruise", start_en_m=pos, end_en_m=end, start_alt_m=alt,
                            end_alt_m=end_alt, speed_ms=speed, speed_is_airspeed=is_air,
                            origin=origin))
            pos, alt = end, end_alt
        elif kind == "hover":
            dur = chk.number(p, "duration_s", path, required=True, minimum=0.0,
                             maximum=MAX_HOLD_S, why_max="24 h")
            if dur is None:
                continue
            legs.append(Leg("hover", start_en_m=pos, end_en_m=pos, start_alt_m=alt,
                            end_alt_m=alt, duration_s=dur, origin=origin))
        else:  # loiter
            key = chk.one_of(p, ("duration_s", "turns"), path)
            radius = chk.number(p, "radius_m", path, positive=True)
            speed, is_air = _speed(chk, p, path)
            if key is None:
                chk.add(path, "needs duration_s, or turns with radius_m and airspeed_ms")
                continue
            if key == "duration_s":
                dur = chk.number(p, "duration_s", path, minimum=0.0, maximum=MAX_HOLD_S,
                                 why_max="24 h")
            else:
                turns = chk.number(p, "turns", path, positive=True, maximum=MAX_LOITER_TURNS,
                                   why_max="the most ArduPilot stores")
                if "radius_m" not in p or not ("airspeed_ms" in p or "groundspeed_ms" in p):
                    chk.add(path, "turns needs radius_m and airspeed_ms (or groundspeed_ms): "
                            "the duration is turns x 2 pi radius / speed")
                    continue
                dur = (None if turns is None or radius is None or speed is None
                       else turns * 2.0 * math.pi * radius / speed)
                if dur is not None and hold_problem(dur):
                    chk.add(path, f"{turns:g} turns of {radius:g} m at {speed:g} m/s: "
                            f"{hold_problem(dur, 'loiter time')}")
                    continue
            if dur is None or len(chk.problems) > before:
                continue
            legs.append(Leg("loiter", start_en_m=pos, end_en_m=pos, start_alt_m=alt,
                            end_alt_m=alt, speed_ms=speed, speed_is_airspeed=is_air,
                            duration_s=dur, loiter_radius_m=radius, origin=origin))
    too_long = total_hold_problem(legs)
    if too_long:
        chk.add(too_long[0], too_long[1])
    return legs


def _waypoints_form(chk: _Checker, data: dict,
                    home: tuple[float, float, float] | None, site: float,
                    defaults: NavDefaults | None = None) -> list[Leg]:
    raw = data["waypoints"]
    if not isinstance(raw, list):
        chk.add("waypoints", f"must be a list of waypoints, got {_describe(raw)}")
        return []
    if not raw:
        chk.add("waypoints", "is empty (expected at least one {lat, lon, alt_m})")
        return []
    if (msg := too_many(chk.where, "waypoints", len(raw))) is not None:
        raise InputError(msg)
    steps: list[RouteStep] = []
    takeoff = chk.number(data, "takeoff_alt_m", "", positive=True)
    if takeoff is not None and not _altitude(chk, "takeoff_alt_m", takeoff, takeoff, site):
        takeoff = None
    if takeoff is not None:
        steps.append(RouteStep("takeoff", alt_m=takeoff, origin="takeoff_alt_m"))
    speed, is_air = _speed(chk, data, "", keys=tuple(SPEED_KEYS))
    for i, item in enumerate(raw):
        path = f"waypoints[{i + 1}]"
        wp = chk.mapping(item, path, allowed=WAYPOINT_KEYS, empty_ok=False)
        if wp is None:
            continue
        lat = chk.number(wp, "lat", path, required=True, minimum=-90, maximum=90)
        lon = chk.number(wp, "lon", path, required=True, minimum=-180, maximum=180)
        alt = chk.number(wp, "alt_m", path, required=True)
        if alt is not None and not _altitude(chk, _join(path, "alt_m"), alt, alt, site):
            alt = None
        hold = chk.number(wp, "hold_s", path, minimum=0.0, maximum=MAX_HOLD_S, why_max="24 h")
        wp_speed, wp_air = _speed(chk, wp, path, keys=tuple(SPEED_KEYS))
        if wp_speed is not None:
            steps.append(RouteStep("speed", speed_ms=wp_speed, speed_is_airspeed=wp_air,
                                   origin=path))
        if lat is not None and lon is not None and alt is not None:
            steps.append(RouteStep("waypoint", lat, lon, alt, hold_s=hold, origin=path))
    go_home = chk.boolean(data, "return_home", "", True)
    land = chk.boolean(data, "land", "", True)
    if chk.problems or home is None:
        return []
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
    chk = _Checker(where)
    has_legs, has_wps = "legs" in data, "waypoints" in data
    if has_legs and has_wps:
        chk.add("", "give either legs: or waypoints:, not both")
    elif not (has_legs or has_wps):
        chk.add("", "no legs: or waypoints: (expected one of them: the mission is empty)")
    allowed = WAYPOINTS_KEYS if has_wps else LEGS_KEYS if has_legs else TOP_KEYS
    for key in data:
        if key in allowed:
            continue
        if key in TOP_KEYS:
            chk.add(str(key), "is only used with waypoints: (not with legs:)")
        else:
            hint = difflib.get_close_matches(str(key), allowed, n=1)
            tip = f"did you mean {hint[0]!r}?" if hint else f"expected one of {', '.join(allowed)}"
            chk.add(str(key), f"is not a known key ({tip})")
    name = chk.text(data, "name", "", path.stem)
    chk.text(data, "source", "", "")  # provenance note: validated, not stored
    payload = chk.number(data, "payload_kg", "", minimum=0.0)
    home = _home(chk, data, required=has_wps)
    env = _environment(chk, data, home[2] if home else 0.0)
    legs: list[Leg] = []
    if has_legs and not has_wps:
        legs = _legs_form(chk, data["legs"], env.site_altitude_m)
    elif has_wps and not has_legs:
        legs = _waypoints_form(chk, data, home, env.site_altitude_m, defaults)
    chk.done()
    return Mission(name=name, legs=legs, environment=env, payload_kg=payload or 0.0,
                   home=home, source=where)
