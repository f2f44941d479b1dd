"""Parameters: the one reader of definition files (layer 2 of the planner).

Aircraft, battery packs, pack catalogs, the ``circuit:``/``thermal:``/``supercap:``
blocks, OCV tables and power schedules are read here into typed, frozen, validated
objects; nothing else in the planner opens a definition file. The physics (layer 1) takes
these objects or plain numbers; the mission chain (layer 3) composes them.
"""

from planner import schema as _schema
from planner.parameters.aircraft import (
    Aircraft,
    FixedWing,
    Multirotor,
    aircraft_from_mapping,
    default_battery_path,
    load_aircraft,
    load_aircraft_and_battery,
)
from planner.parameters.blocks import CircuitBlock
from planner.parameters.catalog import catalog_from_mapping, load_catalog
from planner.parameters.pack import BatteryPack, IntegralModel, battery_from_mapping, load_battery



def read_definition(path):
    """A definition file's mapping as written (validated YAML syntax only), for a command
    that extends a file and writes it again (``fit-battery --battery``)."""
    return _schema.load_yaml(path)


__all__ = ["read_definition", "Aircraft", "BatteryPack", "CircuitBlock", "FixedWing", "IntegralModel",
           "Multirotor", "aircraft_from_mapping", "battery_from_mapping",
           "catalog_from_mapping", "default_battery_path", "load_aircraft",
           "load_aircraft_and_battery", "load_battery", "load_catalog"]
