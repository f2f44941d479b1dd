"""The one validator of YAML input (planner.io.schema): one message per kind of problem,
every problem of a file at once, in one line naming the file and the key path."""

import pytest

from planner.errors import InputError
from planner.io import schema as S

SPEC = {
    "name": S.text("a name", required=True),
    "mass_kg": S.positive(required=True, high=1000.0, unit="kg", meaning="mass"),
    "cells": S.count(40, default=1, meaning="cells"),
    "hold_s": S.non_negative(high=86_400.0, why="24 h", meaning="hold"),
    "mode": S.text("mode", choices=("a", "b")),
    "block": S.block("a block"),
}


def problems_of(data, **kw) -> list[str]:
    problems = S.Problems("f.yaml")
    S.check_mapping(data, SPEC, "f.yaml", problems=problems, **kw)
    return problems.items


def test_every_problem_at_once_in_one_line_naming_the_file():
    with pytest.raises(InputError) as info:
        S.check_mapping({"mass_kg": -1, "cells": 2.5, "mas": 1, "mode": "c"}, SPEC, "f.yaml")
    assert str(info.value) == (
        "f.yaml: unknown key 'mas' (did you mean 'mass_kg'?); "
        "missing required key 'name' (text); mass_kg must be > 0, got -1; "
        "cells must be a whole number, got 2.5; mode must be one of a, b, got 'c'")


def test_defaults_fill_absent_keys_and_a_valid_file_passes():
    d = S.check_mapping({"name": "x", "mass_kg": 2}, SPEC, "f.yaml")
    assert d == {"name": "x", "mass_kg": 2, "cells": 1, "hold_s": None, "mode": None,
                 "block": None}


@pytest.mark.parametrize("value, expected", [
    (True, "mass_kg must be a number, got True"),
    ("5e3", "mass_kg must be a number, got '5e3' (YAML reads exponent notation without a "
            "decimal point as text: write e.g. 1.0e+3)"),
    (float("nan"), "mass_kg must be finite, got nan"),
    (10**400, "mass_kg must be finite, got a number of 401 digits"),
    (2000, "mass_kg must be <= 1000, got 2000"),
])
def test_a_bad_number_says_what_was_expected(value, expected):
    assert problems_of({"name": "x", "mass_kg": value}) == [expected]


def test_a_bound_with_its_reason_says_it():
    assert problems_of({"name": "x", "mass_kg": 1, "hold_s": 1e5}) == [
        "hold_s must be <= 86400 (24 h), got 100000.0"]


def test_nested_blocks_are_named_by_their_key_path_and_may_be_empty():
    problems = S.Problems("f.yaml")
    S.check_mapping({"mass": 1}, SPEC, "f.yaml", "legs[2].cruise.", problems)
    assert problems.items[0] == "unknown key 'legs[2].cruise.mass' (did you mean " \
                                "'legs[2].cruise.mass_kg'?)"
    assert "missing required key 'legs[2].cruise.name' (text)" in problems.items
    assert problems_of(None)[0] == "the file must be a mapping of keys, got NoneType"
    empty = S.Problems("f.yaml")
    S.check_mapping(None, {"x": S.text("x")}, "f.yaml", "block.", empty, empty_ok=True)
    assert not empty.items


def test_one_of_several_keys():
    problems = S.Problems("m.yaml")
    assert S.one_of({"legs": [], "waypoints": []}, ("legs", "waypoints"), problems) == "legs"
    assert problems.items == ["give only one of 'legs' or 'waypoints'"]
    assert S.one_of({}, ("legs", "waypoints"), problems) is None


def test_rejected_keys_are_left_out_of_checks_across_keys():
    rejected: set[str] = set()
    S.check_mapping({"name": "x", "mass_kg": -1, "cells": 3}, SPEC, "f.yaml",
                    problems=[], rejected=rejected)
    assert rejected == {"mass_kg"}


def test_objects_are_built_from_the_checked_values():
    import dataclasses

    @dataclasses.dataclass
    class Thing:
        name: str
        mass_kg: float
        cells: int = S.defaults(SPEC)["cells"]

    d = S.check_mapping({"name": "x", "mass_kg": 2}, SPEC, "f.yaml")
    assert Thing(**S.fields_from(Thing, d, cells=4)) == Thing("x", 2, 4)
    assert S.field_defaults(Thing) == {"cells": 1}


@pytest.mark.parametrize("data, expected, message", [
    ({"name": "p", "cells_series": 4, "capacity_mah": 5200, "mass_kg": 0.5}, "aircraft",
     "pack.yaml: this is a battery pack file (it has cells_series, capacity_mah), not an "
     "aircraft file"),
    ({"name": "a", "empty_mass_kg": 1.0, "multirotor": {}}, "battery pack",
     "pack.yaml: this is an aircraft file (it has empty_mass_kg, multirotor), not a battery "
     "pack file"),
])
def test_a_file_of_another_kind_is_named_with_its_keys(data, expected, message):
    """A pack given as the aircraft (or the reverse) is named as what it is, with the keys
    that say so, in one short line, not as a list of every unknown key."""
    from planner.errors import WrongFileError

    with pytest.raises(WrongFileError) as info:
        S.refuse_other_kind(data, expected, "pack.yaml")
    assert str(info.value) == message


def test_a_file_with_its_own_kind_keys_is_not_refused():
    S.refuse_other_kind({"empty_mass_kg": 1.0, "cells_series": 4}, "aircraft", "a.yaml")
