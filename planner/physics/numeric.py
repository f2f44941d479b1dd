"""How every physics function takes its numbers and gives them back.

Layer 1 of the planner. The physics functions take a float, a list, an ndarray or a pandas
Series (broadcasting) and return the same kind; a value outside its physical range raises
:class:`planner.errors.ModelError` naming the parameter, while NaN samples pass through
(a missing sample propagates instead of stopping the model). The two rules are written
here once: :func:`require` checks a range, :func:`like_inputs` gives a result the kind of
the inputs (:func:`as_float_or_array` where no Series is to be kept).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from planner.errors import ModelError

__all__ = ["as_float_or_array", "like_inputs", "require"]


def as_float_or_array(result):
    """``result`` as a float when it holds one value (0-d), else as a float ndarray; the
    values and their unit are not changed."""
    result = np.asarray(result, dtype=float)
    return float(result) if result.ndim == 0 else result


def like_inputs(result, *inputs):
    """Return ``result`` as the kind of the inputs: Series, float or ndarray.

    A pandas Series among ``inputs`` (first one wins) gives a Series with its index and
    name when the shapes agree; all-scalar inputs give a float; anything else an ndarray.
    The values are not changed (units are those of ``result``).
    """
    result = np.asarray(result, dtype=float)
    for value in inputs:
        if isinstance(value, pd.Series) and result.shape == (len(value),):
            return pd.Series(result, index=value.index, name=value.name)
    if all(np.ndim(value) == 0 for value in inputs):
        return float(result)
    return result


def require(value, name, *, gt=None, ge=None, lt=None, le=None, unit=""):
    """``value`` as a float ndarray; :class:`ModelError` naming ``name`` when a non-NaN
    value breaks a bound.

    The bounds ``gt``, ``ge``, ``lt``, ``le`` are exclusive/inclusive limits in the unit of
    ``value`` (``unit`` names it in the message); NaN values pass (they propagate through
    the model instead).
    """
    arr = np.asarray(value, dtype=float)
    bad = np.zeros(arr.shape, dtype=bool)
    rule = []
    if gt is not None:
        bad |= arr <= gt
        rule.append(f"> {gt:g}")
    if ge is not None:
        bad |= arr < ge
        rule.append(f">= {ge:g}")
    if lt is not None:
        bad |= arr >= lt
        rule.append(f"< {lt:g}")
    if le is not None:
        bad |= arr > le
        rule.append(f"<= {le:g}")
    if np.any(bad):
        first = arr[bad].flat[0] if arr.ndim else float(arr)
        unit_text = f" {unit}" if unit else ""
        raise ModelError(
            f"{name} must be {' and '.join(rule)}{unit_text}, got {first:g}"
            " (physically impossible or outside the model's validity range)"
        )
    return arr
