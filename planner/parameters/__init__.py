"""Parameters: the one reader of definition files (layer 2 of the planner).

Aircraft, battery packs, pack catalogs, the ``circuit:``/``thermal:``/``supercap:``
blocks and OCV tables are read here into typed, frozen, validated objects; nothing else in
the planner opens a definition file. Each key is declared once, in the key table of its
module (type, unit, bound, default, meaning; ``docs/formats.md`` prints them). The physics
takes these objects or plain numbers; the mission chain composes them.
"""

from planner.io import files
from planner.parameters.aircraft import (
    Aircraft,
    FixedWing,
    Multirotor,
    Navigation,
    aircraft_from_mapping,
    default_battery_path,
    load_aircraft,
    load_aircraft_and_battery,
)
from planner.parameters.blocks import CircuitBlock
from planner.parameters.catalog import catalog_from_mapping, load_catalog
from planner.parameters.pack import BatteryPack, IntegralModel, battery_from_mapping, load_battery


def read_definition(path, to_folder=None):
    """A definition file's mapping as written (validated YAML syntax only), for a command
    that extends a file and writes it again (``endurance fit-battery`` of a pack file).

    ``to_folder``: where the mapping will be written; the paths it holds relative to its
    own file (an aircraft's ``battery``, a pack's ``circuit.ocv_csv``) are rewritten
    relative to that folder, so that the new file finds them.
    """
    import os
    from pathlib import Path

    data = files.load_yaml(path, empty_ok=False)
    if to_folder is None or not isinstance(data, dict):
        return data
    data = dict(data)
    here = Path(path).resolve().parent

    def moved(value):
        if not isinstance(value, str) or Path(value).is_absolute():
            return value
        return os.path.relpath(here / value, Path(to_folder).resolve())

    if "battery" in data:
        data["battery"] = moved(data["battery"])
    if isinstance(data.get("circuit"), dict) and "ocv_csv" in data["circuit"]:
        data["circuit"] = dict(data["circuit"], ocv_csv=moved(data["circuit"]["ocv_csv"]))
    return data


__all__ = ["read_definition", "Aircraft", "BatteryPack", "CircuitBlock", "FixedWing", "IntegralModel",
           "Multirotor", "Navigation", "aircraft_from_mapping", "battery_from_mapping",
           "catalog_from_mapping", "default_battery_path", "load_aircraft",
           "load_aircraft_and_battery", "load_battery", "load_catalog"]
