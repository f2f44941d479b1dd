"""The check's result (planner.chain.result): the per-leg table as columns, rows and a
DataFrame, all three the same figures."""

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from planner.chain.mission_chain import MissionChain
from planner.io.mission import load_mission
from planner.parameters import load_aircraft_and_battery

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def result():
    aircraft, pack = load_aircraft_and_battery(REPO / "aircraft" / "solo_survey.yaml")
    mission = load_mission(REPO / "missions" / "survey_route.yaml")
    return MissionChain(aircraft, pack).check(mission)


def test_legs_is_a_dataframe_of_the_leg_columns(result):
    legs = result.legs
    assert isinstance(legs, pd.DataFrame)
    assert list(legs.columns) == list(result.leg_columns)
    assert len(legs) == len(result.leg_columns["kind"]) > 1
    for name, values in result.leg_columns.items():
        assert legs[name].tolist() == pytest.approx(list(values), nan_ok=True) \
            if np.asarray(values).dtype.kind == "f" else legs[name].tolist() == list(values)
    assert result.legs is legs                       # built once


def test_leg_rows_and_json_carry_the_same_figures(result):
    rows = result.leg_rows()
    assert [r.kind for r in rows] == result.legs["kind"].tolist()
    assert [r.power_w for r in rows] == pytest.approx(result.legs["power_w"].tolist())
    assert sum(r.charge_mah for r in rows) == pytest.approx(result.charge_used_mah)
    legs_json = result.to_dict()["legs"]
    assert [leg["charge_mah"] for leg in legs_json] == pytest.approx(
        result.legs["charge_mah"].round(6).tolist())
    assert legs_json[0].keys() == set(result.leg_columns)
