"""Mission Planner / ArduPilot ``.waypoints`` files (``QGC WPL 110``).

Format (https://mavlink.io/en/file_formats/): a header line ``QGC WPL 110``,
then one mission item per line, tab-separated::

    index  current  frame  command  p1  p2  p3  p4  lat  lon  alt  autocontinue

The item with index 0 is home, its altitude above mean sea level. Any run of
whitespace is accepted as the separator. Blank lines and lines starting with ``#``
are skipped, as pymavlink's ``MAVWPLoader`` skips them (``mavwp.py``
``_read_waypoints_v110``; MAVProxy writes such comments, QGroundControl refuses them).
The index column is not used for the sequence: items are numbered by their position,
as ``MAVWPLoader.add`` renumbers them and the vehicle receives them, so a ``DO_JUMP``
target is a position. Commands and frames are interpreted by
:func:`planner.io.mission.route.mav_items_to_steps`.

Row 0 is taken as home, as QGroundControl and ArduPilot take it (ArduPilot overwrites
it with the vehicle's home at upload). A file whose row 0 is another command (a
take-off, as MAVSDK writes it) has no home: its relative altitudes are read against
that row's position with a warning; absolute (AMSL) altitudes cannot be, and are
refused.

Latitude, longitude and altitude must be finite numbers (``nan`` or ``inf``
is refused; 0, 0 is "the current position"); param1..param4 may be ``nan``
(unset, as MAVLink allows) but not infinite.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

from planner.io import files
from planner.physics.atmosphere import ALTITUDE_RANGE_M
from planner.errors import InputError
from planner.physics.mission import Environment, Mission, NavDefaults, too_many
from planner.io.mission.route import POSITIONED_CMDS, MavItem, cmd_name, fly_mav_items

HEADER = "QGC WPL 110"
FIELDS = ("index", "current", "frame", "command", "param1", "param2", "param3", "param4",
          "latitude", "longitude", "altitude", "autocontinue")
_INT_FIELDS = {"index", "current", "frame", "command", "autocontinue"}


def _read_text(path: Path) -> str:
    return files.read_text(path, "mission", "mission file", encoding="utf-8-sig")


def _parse_line(text: str, lineno: int, where: Path, position: int) -> tuple[int, MavItem]:
    """The line's index field and its item, numbered by its ``position`` in the file."""
    fields = text.rstrip("\r\n").split("\t")
    if len(fields) != len(FIELDS):
        fields = text.split()
    if len(fields) != len(FIELDS):
        raise InputError(f"{where}: line {lineno}: expected {len(FIELDS)} tab-separated fields "
                         "(index, current, frame, command, param1..param4, lat, lon, alt, "
                         f"autocontinue), got {len(fields)}")
    values = {}
    for name, raw in zip(FIELDS, fields):
        raw = raw.strip()
        try:
            values[name] = int(raw) if name in _INT_FIELDS else float(raw)
        except ValueError:
            kind = "an integer" if name in _INT_FIELDS else "a number"
            raise InputError(f"{where}: line {lineno}: {name} is {raw!r} (expected {kind})"
                             ) from None
        value = values[name]
        if name not in _INT_FIELDS and not math.isfinite(value) and (
                math.isinf(value) or name in ("latitude", "longitude", "altitude")):
            raise InputError(f"{where}: line {lineno} (item {values['index']}): {name} is "
                             f"{raw!r} (expected a finite number)")
    params = tuple(values[k] for k in FIELDS[4:11])
    return values["index"], MavItem(seq=position, command=values["command"],
                                    frame=values["frame"], params=params,
                                    origin=f"line {lineno}",
                                    autocontinue=values["autocontinue"])


def read_wpl(path: str | Path) -> tuple[MavItem, list[MavItem]]:
    """Read a ``.waypoints`` file into its home item and its mission items.

    Raises
    ------
    InputError
        Missing header, a malformed line, a coordinate that is not finite, no
        home item or a home out of range, a duplicate index.
    """
    path = Path(path)
    lines = _read_text(path).splitlines()
    numbered = [(n, line) for n, line in enumerate(lines, start=1)
                if line.strip() and not line.startswith("#")]
    if not numbered:
        raise InputError(f"{path}: empty file (expected the header {HEADER!r})")
    if (msg := too_many(str(path), "mission items", len(numbered) - 2)) is not None:
        raise InputError(msg)
    n0, first = numbered[0]
    if first.split() != HEADER.split():
        raise InputError(f"{path}: line {n0}: expected the header {HEADER!r}, "
                         f"got {first.strip()[:40]!r}")
    # the vehicle numbers the items by position (pymavlink MAVWPLoader.add: w.seq = count)
    parsed = [_parse_line(line, n, path, k) for k, (n, line) in enumerate(numbered[1:])]
    if not parsed:
        raise InputError(f"{path}: no mission items (expected home at index 0, then the "
                         "mission items)")
    home, rest = parsed[0][1], [item for _, item in parsed[1:]]
    if parsed[0][0] != 0:
        raise InputError(f"{path}: {home.origin}: first item has index {parsed[0][0]} "
                         "(expected 0, the home position)")
    if not all(math.isfinite(v) for v in home.params[4:7]):
        raise InputError(f"{path}: {home.origin}: home latitude, longitude and altitude must "
                         "be numbers")
    lat, lon, alt = home.params[4:7]
    if lat == 0 and lon == 0:
        raise InputError(f"{path}: {home.origin}: home position is 0, 0 (expected the "
                         "home latitude and longitude)")
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise InputError(f"{path}: {home.origin} (item 0): home latitude/longitude {lat:g}, "
                         f"{lon:g} out of range (expected -90..90, -180..180 degrees)")
    lo, hi = ALTITUDE_RANGE_M
    if not lo <= alt <= hi:
        raise InputError(f"{path}: {home.origin} (item 0): home altitude {alt:g} m above mean "
                         f"sea level is outside the atmosphere model (expected {lo:g} to "
                         f"{hi:g} m)")
    seen = {0: home.origin}
    for index, item in parsed[1:]:
        if index in seen:
            raise InputError(f"{path}: {item.origin}: index {index} already used at "
                             f"{seen[index]} (expected unique indices)")
        seen[index] = item.origin
    if home.command not in (0, 16):
        amsl = next((item for item in rest if item.frame in (0, 5)
                     and item.command in POSITIONED_CMDS), None)
        if amsl is not None:
            raise InputError(
                f"{path}: {home.origin}: item 0 is {cmd_name(home.command)}, not the home "
                "position, and the file has no other: QGroundControl and ArduPilot take "
                "item 0 as home (ArduPilot overwrites it with the vehicle's home), so it is "
                f"never flown, and the absolute altitudes of {amsl.origin} (frame "
                f"{amsl.frame}, above mean sea level) have no take-off point to be read "
                "against (expected item 0 a NAV_WAYPOINT (16) at the home position, "
                "altitude above mean sea level, as Mission Planner writes it)")
        warnings.warn(f"{path}: {home.origin}: item 0 is {cmd_name(home.command)}, taken as "
                      "the home position as QGroundControl and ArduPilot take it (not "
                      "flown)", stacklevel=2)
    return home, rest


def load_wpl(path: str | Path, *, vehicle_type: str | None = None,
             defaults: NavDefaults | None = None) -> Mission:
    """Load a Mission Planner ``.waypoints`` file.

    Parameters
    ----------
    path : str or Path
    vehicle_type : {"multirotor", "fixed_wing"} or None
        See :func:`planner.io.mission.route.mav_items_to_steps`.
    defaults : NavDefaults or None
        The aircraft's speeds and rates (:func:`planner.io.mission.route.route_to_legs`).

    Returns
    -------
    Mission
        Named after the file; home from index 0; the environment's site
        altitude is the home altitude. The file carries no default speed, so
        legs before the first ``DO_CHANGE_SPEED`` use the aircraft's. Items are
        flown by ArduPilot's rules (the format's firmware). ``Mission.file`` keeps
        the items to write sorties back.
    """
    path = Path(path)
    home, items = read_wpl(path)
    lat, lon, alt = home.params[4], home.params[5], home.params[6]
    legs, file = fly_mav_items(items, home, where=str(path), fmt="waypoints",
                               vehicle_type=vehicle_type, firmware=None, defaults=defaults)
    return Mission(name=path.stem, legs=legs, environment=Environment(site_altitude_m=alt),
                   home=(lat, lon, alt), source=str(path), file=file)
