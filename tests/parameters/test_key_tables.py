"""Each key of a definition file is declared once: the key tables of planner.parameters.

The table of a block (``AIRCRAFT_KEYS``, ``BATTERY_KEYS``, ``CIRCUIT_KEYS`` …) validates the
file, gives the object it builds its defaults and prints the tables of docs/formats.md.
These tests fail when a default or a bound is written a second time and drifts: an object
whose default differs from its key's, an object that enforces another bound than the
table, a bound that is not one of the limits (each with its reason) of
planner.physics.limits, a key without a meaning.
"""

import dataclasses
import math

import numpy as np
import pytest

from planner.errors import InputError
from planner.io import schema as S
from planner.parameters import aircraft, blocks, catalog, pack
from planner.physics import limits
from planner.physics.battery.circuit import CircuitParameters
from planner.physics.battery.supercap import SupercapParameters
from planner.physics.battery.thermal import T_RANGE_C, ThermalParameters

TABLES = {
    "aircraft": aircraft.AIRCRAFT_KEYS, "fixed_wing": aircraft.FIXED_WING_KEYS,
    "multirotor": aircraft.MULTIROTOR_KEYS, "navigation": aircraft.NAVIGATION_KEYS,
    "pack": pack.BATTERY_KEYS,
    "model": pack.MODEL_KEYS, "circuit": blocks.CIRCUIT_KEYS,
    "thermal": blocks.THERMAL_KEYS, "supercap": blocks.SUPERCAP_KEYS,
    "catalog": catalog.CATALOG_KEYS, "catalog reference": catalog.REFERENCE_KEYS,
}

#: (object, its table, fields whose default is deliberately not the key's: why)
OBJECTS = [
    (aircraft.Aircraft, aircraft.AIRCRAFT_KEYS,
     {"climb_rate_ms", "descent_rate_ms"}),      # the type's DEFAULT_VERTICAL_SPEEDS
    (aircraft.FixedWing, aircraft.FIXED_WING_KEYS, set()),
    (aircraft.Multirotor, aircraft.MULTIROTOR_KEYS,
     set(aircraft.ROTOR_LOSSES_KEYS)),            # None unless power_model rotor_losses
    (pack.BatteryPack, pack.BATTERY_KEYS, set()),
    (pack.IntegralModel, pack.MODEL_KEYS, set()),
    # hysteresis_gamma: required with M > 0; the layout: absent from a block, the pack's
    (CircuitParameters, blocks.CIRCUIT_KEYS, {"hysteresis_gamma", "cells_series",
                                              "cells_parallel"}),
    (ThermalParameters, blocks.THERMAL_KEYS, set()),
    (SupercapParameters, blocks.SUPERCAP_KEYS, set()),
]

#: Bounds that are part of a quantity's definition, not a limit of what flies.
DEFINITIONAL = {0.0, 1.0}


@pytest.mark.parametrize("cls, keys, differ", OBJECTS, ids=lambda x: getattr(x, "__name__", ""))
def test_an_object_takes_its_defaults_from_its_key_table(cls, keys, differ):
    checked = 0
    for f in dataclasses.fields(cls):
        if f.name not in keys or f.name in differ or keys[f.name].required:
            continue
        if f.default is dataclasses.MISSING:
            continue
        assert f.default == keys[f.name].default, (cls.__name__, f.name)
        checked += 1
    assert checked


def test_a_block_without_keys_is_the_physics_object_with_its_defaults():
    """``CircuitBlock()`` completed by a pack is ``CircuitParameters`` with its own
    defaults: the table takes the physics object's defaults, not a copy of them."""
    made = blocks.CircuitBlock().parameters(capacity_ah=2.0, r0_ohm=0.01, cells_series=3,
                                            cells_parallel=2)
    plain = CircuitParameters(capacity_ah=2.0, r0_ohm=0.01, cells_series=3, cells_parallel=2)
    for f in dataclasses.fields(CircuitParameters):
        assert getattr(made, f.name) == getattr(plain, f.name), f.name


def _beyond(k: S.Key, side: str) -> float:
    """A value just outside the bound of ``k`` on ``side``."""
    if side == "low":
        return k.low if k.low_open else k.low - max(abs(k.low) * 1e-6, 1e-9)
    return k.high + max(abs(k.high) * 1e-6, 1e-9)


def _valid_cell(**changes):
    base = {"capacity_ah": 2.0, "r0_ohm": 0.01, "r1_ohm": 0.01, "c1_f": 2000.0,
            "hysteresis_v": 0.01, "hysteresis_gamma": 10.0}
    return {**base, **changes}


CIRCUIT_BOUNDED = [(name, side) for name, k in blocks.CIRCUIT_KEYS.items()
                   if k.kind == S.NUMBER for side in ("low", "high")
                   if getattr(k, side) is not None]


@pytest.mark.parametrize("name, side", CIRCUIT_BOUNDED)
def test_the_circuit_object_enforces_the_bound_its_file_key_declares(tmp_path, name, side):
    """A bound of ``CIRCUIT_KEYS`` is the bound of ``CircuitParameters``: a fit or a program
    cannot build a circuit that a pack file could not hold, and the other way round."""
    k = blocks.CIRCUIT_KEYS[name]
    bad = _beyond(k, side)
    with pytest.raises(InputError, match=name):
        CircuitParameters(**_valid_cell(**{name: bad}))
    with pytest.raises(InputError, match=f"circuit.{name} must be"):
        blocks.circuit_block(_valid_cell(**{name: bad}), "p.yaml")
    edge = getattr(k, side)
    if not getattr(k, f"{side}_open"):
        CircuitParameters(**_valid_cell(**{name: edge}))         # the bound itself is in
        blocks.circuit_block(_valid_cell(**{name: edge}), "p.yaml")


def test_the_thermal_object_and_its_key_table_agree_on_the_temperature_range():
    for name in ("t_air_c", "t0_c"):
        k = blocks.THERMAL_KEYS[name]
        assert (k.low, k.high) == T_RANGE_C
        with pytest.raises(Exception, match=name):
            ThermalParameters(2.0, 800.0, **{"t_air_c": 25.0, name: k.high + 1.0})


def _limit_values() -> set[float]:
    values = set()
    for name in dir(limits):
        value = getattr(limits, name)
        if name.isupper() and isinstance(value, (int, float)):
            values |= {float(value), -float(value)}
    return values | set(map(float, T_RANGE_C))


@pytest.mark.parametrize("table", TABLES, ids=str)
def test_every_bound_is_a_limit_with_its_reason(table):
    """A bound other than 0 or 1 (part of the quantity's definition: an efficiency,
    a share) is a constant of planner.physics.limits, where its reason is written."""
    known = _limit_values()
    for name, k in TABLES[table].items():
        for bound in (k.low, k.high):
            if bound is None or float(bound) in DEFINITIONAL:
                continue
            assert float(bound) in known, f"{table}.{name}: bound {bound} is not in limits"


def test_every_limit_says_why_and_in_what_unit():
    """Each limit of planner.physics.limits has a comment above it: its reason and unit."""
    lines = open(limits.__file__, encoding="utf-8").read().splitlines()
    for i, line in enumerate(lines):
        if line and line[0].isupper() and "=" in line:
            assert lines[i - 1].startswith("#:") or lines[i - 1].startswith("#: ") or \
                lines[i - 1].startswith("#"), line
            block = []
            j = i - 1
            while j >= 0 and lines[j].startswith("#"):
                block.append(lines[j])
                j -= 1
            assert "[" in " ".join(block), f"no unit for {line}"


@pytest.mark.parametrize("table", TABLES, ids=str)
def test_every_key_has_a_meaning_and_numbers_a_unit_or_none(table):
    for name, k in TABLES[table].items():
        assert k.meaning.strip(), f"{table}.{name} has no meaning"
        if k.unit:
            assert k.kind in (S.NUMBER, S.ANY), f"{table}.{name}: a unit on a {k.kind}"


def test_the_reference_tables_print_the_meaning():
    from tools import reference

    text = reference.key_table(blocks.CIRCUIT_KEYS, "circuit.")
    row = next(line for line in text.splitlines() if "`circuit.capacity_ah`" in line)
    assert "A h" in row and blocks.CIRCUIT_KEYS["capacity_ah"].meaning in row
    assert "(0 … 2000]" in row


def test_a_catalog_reference_has_the_bounds_of_the_pack_keys_it_changes():
    for name in ("count", "price"):
        ref, own = catalog.REFERENCE_KEYS[name], pack.BATTERY_KEYS[name]
        assert (ref.low, ref.high, ref.kind) == (own.low, own.high, own.kind)


@pytest.mark.parametrize("value, ok", [(0.0, True), (math.inf, False), (-1e-9, False),
                                       (np.float64(0.02), True)])
def test_parse_r0_takes_a_number_as_a_pack_file_writes_it(value, ok):
    problems = S.Problems("p.yaml")
    out = blocks.parse_r0(value, "circuit.r0_ohm", problems)
    assert (out is not None) == ok and (len(problems) == 0) == ok
