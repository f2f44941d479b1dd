"""The rest of a mission from the present position: items and legs."""

import math

import pytest

from planner.io.mavlink_mission import (
    HERE,
    here_en,
    items_from_file,
    remaining_from_items,
    remaining_from_legs,
    return_home,
)
from planner.io.mission import load_mission
from planner.physics.geo import aeqd_to_latlon

WPL = "missions/survey_route.waypoints"


def _legs_key(legs):
    return [(leg.kind, round(leg.distance_m, 3), round(leg.end_alt_m, 3)) for leg in legs]


def test_from_home_on_the_ground_the_rest_is_the_whole_mission():
    items = items_from_file(WPL)
    whole = load_mission(WPL, vehicle_type="multirotor")
    rest = remaining_from_items(items, 1, items.home[:2], 0.0, items.home,
                                vehicle_type="multirotor")
    assert _legs_key(rest.legs) == _legs_key(whole.legs)
    assert all(leg.origin != HERE for leg in rest.legs)


def test_items_keep_the_vehicle_numbering_after_home():
    items = items_from_file(WPL)
    assert [it.seq for it in items.items][:3] == [1, 2, 3]
    assert items.items[0].origin == "item 1" and items.count == len(items.items) + 1
    assert items.home == (48.0468, 10.4452, 598.0)


def test_the_rest_starts_where_the_aircraft_is_and_flies_the_items_still_to_come():
    items = items_from_file(WPL)
    home = items.home
    # halfway along the leg to item 5, at 50 m
    lat, lon = aeqd_to_latlon(0.0, 0.0, home[0], home[1])
    wp4 = next(it for it in items.items if it.seq == 4).params[4:6]
    wp5 = next(it for it in items.items if it.seq == 5).params[4:6]
    here = ((wp4[0] + wp5[0]) / 2, (wp4[1] + wp5[1]) / 2)
    rest = remaining_from_items(items, 5, here, 50.0, home, vehicle_type="multirotor")
    e, n = here_en(here, home)
    first = rest.legs[0]
    assert first.kind == "cruise"
    assert first.start_en_m == pytest.approx((e, n), abs=0.01)
    assert first.start_alt_m == pytest.approx(50.0)
    # the whole mission from item 5 on: the half leg, then the same legs as from item 5
    whole = remaining_from_items(items, 1, home[:2], 0.0, home, vehicle_type="multirotor")
    origins = [leg.origin for leg in whole.legs]
    from_5 = whole.legs[origins.index("item 5"):]
    assert _legs_key(rest.legs[1:]) == _legs_key(from_5[1:])
    assert rest.legs[-1].kind == "descend" and rest.legs[-1].end_alt_m == 0.0


def test_a_jump_back_before_the_present_item_is_taken_as_done():
    items = items_from_file(WPL)
    home = items.home
    # item 2 is DO_CHANGE_SPEED; add a jump from the end back to item 3, three times
    from dataclasses import replace
    jump = replace(items.items[-2], seq=99, command=177, params=(3.0, 3.0, 0, 0, 0, 0, 0),
                   origin="item 99")
    with_jump = replace(items, items=items.items[:-1] + (jump, items.items[-1]))
    at_end = remaining_from_items(with_jump, 13, home[:2], 50.0, home,
                                  vehicle_type="multirotor")
    total = sum(leg.distance_m for leg in at_end.legs)
    assert total < 2000          # the lawnmower is not flown again three times


def test_past_the_last_item_no_mission_remains():
    items = items_from_file(WPL)
    assert remaining_from_items(items, 40, items.home[:2], 0.0, items.home) is None


def test_a_legs_mission_is_followed_by_position_forward_only():
    m = load_mission("missions/survey_quad.yaml", vehicle_type="multirotor")
    leg = m.legs[3]          # the third cruise
    mid = ((leg.start_en_m[0] + leg.end_en_m[0]) / 2, (leg.start_en_m[1] + leg.end_en_m[1]) / 2)
    rest, j = remaining_from_legs(m, mid, leg.start_alt_m, 0)
    assert j == 3 and len(rest.legs) == len(m.legs) - 3
    assert rest.legs[0].distance_m == pytest.approx(leg.distance_m / 2, rel=1e-6)
    # the same point again but progress already past it: forward only
    rest2, j2 = remaining_from_legs(m, mid, leg.start_alt_m, 10)
    assert j2 >= 10


def test_the_way_home_is_straight_at_the_present_altitude_then_down():
    m = return_home((300.0, 400.0), 42.0)
    assert [leg.kind for leg in m.legs] == ["cruise", "descend"]
    assert m.legs[0].distance_m == pytest.approx(500.0)
    assert m.legs[0].end_en_m == (0.0, 0.0) and m.legs[0].end_alt_m == 42.0
    assert m.legs[1].start_alt_m == 42.0 and m.legs[1].end_alt_m == 0.0
    at_home = return_home((0.1, 0.0), 0.0)
    assert len(at_home.legs) == 1 and at_home.legs[0].kind == "descend"


def test_position_without_home_has_no_frame():
    assert all(math.isnan(x) for x in here_en((47.0, 8.0), None))
