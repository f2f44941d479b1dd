"""``fit-battery --cells S×P``: the data are one cell's discharges; the pack file written is
the pack of S cells in series × P in parallel, its δ scaled from the cell's
(:func:`planner.physics.battery.integral.scale_to_pack`), its charge P × the cell's."""

from __future__ import annotations

import math
import re

import numpy as np

from planner.errors import InputError
from planner.physics.battery import integral

_SXP = re.compile(r"^\s*(\d+)\s*[sS]?\s*[x×X*]\s*(\d+)\s*[pP]?\s*$")


def parse_cells(text: str | None) -> tuple[int | None, int | None]:
    """``--cells``: ``N`` (cells in series of the pack the data were measured on) → (N,
    None); ``S×P`` (also ``SxP``, ``4S2P``) → (S, P): the data are of one cell."""
    if text is None:
        return None, None
    m = _SXP.match(text) or re.match(r"^\s*(\d+)\s*[sS]\s*(\d+)\s*[pP]\s*$", text)
    if m:
        s, p = int(m.group(1)), int(m.group(2))
        if not (1 <= s <= 40 and 1 <= p <= 100):
            raise InputError(f"--cells {text}: expected 1..40 cells in series × 1..100 in "
                             "parallel")
        return s, p
    try:
        n = int(text)
    except ValueError:
        raise InputError(f"--cells: expected a number of cells in series (4) or, for a "
                         f"one-cell fit scaled to a pack, S×P (4x2), got {text!r}") from None
    if not 1 <= n <= 40:
        raise InputError(f"--cells: expected 1..40, got {text!r}")
    return n, None


def scale_model(model_mapping: dict, series: int, parallel: int) -> dict:
    """The ``model:`` mapping of a one-cell fit, for the pack: δ scaled, ε, β kept, the
    covariance carried through the scaling (δ_pack = δ (S P)^−ε P^−β: its derivatives by
    δ, ε, β)."""
    d, e, b = (float(model_mapping[k]) for k in ("delta", "epsilon", "beta"))
    dp = integral.scale_to_pack(d, e, b, series, parallel)
    out = dict(model_mapping)
    out["delta"] = dp
    cov = model_mapping.get("covariance")
    if cov is not None:
        jac = np.array([[dp / d, -dp * math.log(series * parallel), -dp * math.log(parallel)],
                        [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        c = jac @ np.asarray(cov, float) @ jac.T
        out["covariance"] = [[float(x) for x in row] for row in 0.5 * (c + c.T)]
    return out


def describe(series: int, parallel: int, cell_delta: float, pack_delta: float,
             cell_mah: float) -> str:
    """How a one-cell fit was scaled to the pack, in words: δ of the cell and of the
    ``series``S``parallel``P pack, and the capacity [mAh]."""
    return (f"scaled from one cell to {series}S{parallel}P: δ {cell_delta:.4g} → "
            f"{pack_delta:.4g} (δ·(S·P)^−ε·P^−β, identical cells), ε and β kept; capacity "
            f"{cell_mah:.0f} mAh × {parallel} = {cell_mah * parallel:.0f} mAh")
