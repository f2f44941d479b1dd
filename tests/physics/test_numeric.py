"""The numeric conventions of the physics functions (planner.physics.numeric)."""

import numpy as np
import pandas as pd
import pytest

from planner.errors import ModelError
from planner.physics.numeric import as_float_or_array, like_inputs, require


def test_require_names_the_parameter_the_rule_and_the_first_bad_value():
    with pytest.raises(ModelError, match=r"air_density must be > 0 kg/m³, got -1"):
        require([1.2, -1.0, -2.0], "air_density", gt=0.0, unit="kg/m³")
    with pytest.raises(ModelError, match=r"efficiency must be > 0 and <= 1, got 1.5"):
        require(1.5, "efficiency", gt=0.0, le=1.0)
    out = require([0.5, np.nan], "x", ge=0.0, lt=1.0)       # NaN passes, to propagate
    assert out.dtype == float and np.isnan(out[1])


def test_like_inputs_keeps_a_series_index_and_name_and_gives_floats_for_scalars():
    s = pd.Series([1.0, 2.0], index=[5, 9], name="v")
    out = like_inputs(np.array([3.0, 4.0]), 2.0, s)
    assert isinstance(out, pd.Series) and list(out.index) == [5, 9] and out.name == "v"
    assert isinstance(like_inputs(np.float64(3.0), 1.0, 2), float)
    assert isinstance(like_inputs([3.0, 4.0], [1.0, 2.0]), np.ndarray)
    assert isinstance(as_float_or_array(np.array(2.5)), float)
    assert as_float_or_array([1, 2]).dtype == float
