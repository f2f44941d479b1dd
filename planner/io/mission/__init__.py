"""Missions: files in three formats -> :class:`~planner.physics.mission.Mission` of legs.

================================  ==========================================
extension                         format
================================  ==========================================
``.yaml``, ``.yml``               planner YAML (legs or waypoints form),
                                  :mod:`planner.io.mission.yaml_mission`
``.plan``                         QGroundControl plan (JSON),
                                  :mod:`planner.io.mission.qgc_plan`
``.waypoints``, ``.txt``          Mission Planner ``QGC WPL 110``,
                                  :mod:`planner.io.mission.wpl`
================================  ==========================================
"""

from __future__ import annotations

import warnings
from pathlib import Path

from planner.errors import InputError
from planner.physics.mission import (LEG_KINDS, MAX_ITEMS, Environment, Leg, Mission,
                                     NavDefaults)
from planner.io.mission.qgc_plan import load_plan
from planner.io.mission.wpl import load_wpl
from planner.io.mission.yaml_mission import load_yaml_mission

__all__ = ["LEG_KINDS", "VEHICLE_TYPES", "Environment", "Leg", "Mission", "NavDefaults",
           "load_mission", "load_plan", "load_wpl", "load_yaml_mission"]

#: Legs a mission item may become (a waypoint: a climb and a cruise; a jump repeats some).
LEGS_PER_ITEM = 3

#: Values of the ``vehicle_type`` argument (the aircraft ``type:`` key).
VEHICLE_TYPES = ("multirotor", "fixed_wing")

_LOADERS = {".yaml": load_yaml_mission, ".yml": load_yaml_mission, ".plan": load_plan,
            ".waypoints": load_wpl, ".txt": load_wpl}


def load_mission(path: str | Path, *, vehicle_type: str | None = None,
                 defaults: NavDefaults | None = None) -> Mission:
    """Load a mission file, choosing the format from its extension.

    Parameters
    ----------
    path : str or Path
        ``.yaml``/``.yml``, ``.plan``, or ``.waypoints``/``.txt`` (which must
        start with the ``QGC WPL 110`` header).
    vehicle_type : {"multirotor", "fixed_wing"} or None
        The aircraft type where known (else ``defaults.vehicle_type``, else a ``.plan``
        file's ``vehicleType``): how loiters, arcs and ``DO_CHANGE_SPEED`` are flown.
    defaults : NavDefaults or None
        The aircraft's own speeds and rates, which the firmware flies where the file
        does not say: give a loiter in turns its speed, bound the climb of a leg
        (:mod:`planner.io.mission.route`). The command line always gives them; without
        them a loiter in turns needs a ``DO_CHANGE_SPEED`` before it and a leg's climb
        is not bounded.

    Returns
    -------
    Mission

    Raises
    ------
    InputError
        A missing file, an unknown extension, or any problem in the file: one
        line naming the file, the key or line, and what was expected.
    """
    path = Path(path)
    if vehicle_type is not None and vehicle_type not in VEHICLE_TYPES:
        raise InputError(f"vehicle type {vehicle_type!r} not known (expected one of "
                         f"{', '.join(VEHICLE_TYPES)})")
    loader = _LOADERS.get(path.suffix.lower())
    if loader is None:
        raise InputError(f"{path}: unknown mission file type {path.suffix!r} (expected "
                         f"{', '.join(_LOADERS)})")
    if not path.is_file():
        raise InputError(f"{path}: file not found")
    if defaults is not None:
        vehicle_type = vehicle_type or defaults.vehicle_type
    # a file that is refused gives one line: its warnings are said only once it is read
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        mission = loader(path, vehicle_type=vehicle_type, defaults=defaults)
    for w in said:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    if len(mission.legs) > LEGS_PER_ITEM * MAX_ITEMS:
        raise InputError(f"{path}: {len(mission.legs)} legs once its jumps and waypoints are "
                         f"flown, more than the planner flies (at most "
                         f"{LEGS_PER_ITEM * MAX_ITEMS})")
    return mission
