"""Open-circuit voltage of lithium cells against state of charge."""

from __future__ import annotations

import numpy as np

from planner.errors import InputError
from planner.physics.battery.elements import compiled
from planner.physics.numeric import like_inputs


def lipo_ocv(soc):
    r"""
    Open-circuit voltage of one lithium-ion polymer cell.

    Parameters
    ----------
    soc : numeric
        State of charge, 1 = full, 0 = empty. Values outside [0, 1] are
        clipped. [unitless]

    Returns
    -------
    ocv : numeric
        Cell open-circuit voltage. [V]

    Notes
    -----
    .. math:: V_{oc} = -1.031 e^{-35 s} + 3.685 + 0.2156 s - 0.1178 s^2 + 0.3201 s^3

    The fit of [1]_, eq. (4), to a 850 mAh Li-ion polymer cell (TCL PL-383562):
    4.10 V full, 3.80 V at half charge, steep knee below 10 %. The one home of this curve:
    the circuit model tabulates it, the mission chain's compiled kernel calls
    :data:`lipo_ocv_jit`.

    References
    ----------
    .. [1] M. Chen and G. A. Rincón-Mora, "Accurate electrical battery model
       capable of predicting runtime and I–V performance," IEEE Trans. Energy
       Convers., vol. 21, no. 2, pp. 504–511, 2006, doi:10.1109/TEC.2006.874229.
    """
    s = np.minimum(np.maximum(soc, 0.0), 1.0)
    return -1.031 * np.exp(-35.0 * s) + 3.685 + s * (0.2156 + s * (-0.1178 + 0.3201 * s))


#: :func:`lipo_ocv` compiled for the time loops (one value per call; the same source).
lipo_ocv_jit = compiled(lipo_ocv)


# --------------------------------------------------------------------------- tables

class OcvTable:
    """An open-circuit-voltage curve given as a table, linearly interpolated.

    Call it like :func:`lipo_ocv`: ``table(soc) -> ocv``. Build it with
    :func:`ocv_table` (validates) or :func:`read_ocv_csv`.

    Attributes
    ----------
    soc : ndarray
        State of charge of the knots, strictly increasing in [0, 1]. [unitless]
    ocv_v : ndarray
        Open-circuit voltage at the knots, strictly increasing. [V]
    source : str
        Where the table came from (a file name), for messages.
    """

    def __init__(self, soc, ocv_v, source: str = ""):
        self.soc = np.asarray(soc, dtype=float)
        self.ocv_v = np.asarray(ocv_v, dtype=float)
        self.source = source

    def __call__(self, soc):
        return interpolate_ocv(soc, self.soc, self.ocv_v)

    def soc_from_ocv(self, ocv_v):
        """State of charge at which the curve reaches ``ocv_v`` [V] (clipped to the table).
        [unitless]"""
        return like_inputs(np.interp(np.asarray(ocv_v, dtype=float), self.ocv_v, self.soc), ocv_v)

    def __repr__(self) -> str:
        return (f"OcvTable({len(self.soc)} points, {self.ocv_v[0]:.3f}–{self.ocv_v[-1]:.3f} V"
                f"{', ' + self.source if self.source else ''})")


def interpolate_ocv(soc, soc_table, ocv_table):
    r"""
    Open-circuit voltage by linear interpolation in a table.

    Parameters
    ----------
    soc : numeric
        State of charge. Values outside the table are held at the end values
        (no extrapolation). NaN propagates. [unitless]
    soc_table : array_like
        Knots, increasing. [unitless]
    ocv_table : array_like
        Open-circuit voltage at the knots. [V]

    Returns
    -------
    ocv : numeric
        Same kind as ``soc`` (float, ndarray or Series). [V]
    """
    values = np.interp(np.asarray(soc, dtype=float), np.asarray(soc_table, dtype=float),
                       np.asarray(ocv_table, dtype=float))
    return like_inputs(values, soc)


def ocv_table(soc, ocv_v, where: str = "OCV table") -> OcvTable:
    """
    Validate an OCV table and build an :class:`OcvTable`.

    The rows may come in any order (they are sorted by state of charge); the
    state of charge must lie in [0, 1] without repeats and the voltage must
    rise strictly with the state of charge.

    Parameters
    ----------
    soc : array_like
        State of charge. [unitless]
    ocv_v : array_like
        Open-circuit voltage. [V]
    where : str
        Name of the source (file), for messages.

    Raises
    ------
    planner.errors.InputError
        Naming ``where`` and the first offending row.
    """
    s = np.asarray(soc, dtype=float).ravel()
    v = np.asarray(ocv_v, dtype=float).ravel()
    if s.size != v.size:
        raise InputError(f"{where}: soc and ocv have different lengths ({s.size} and {v.size})")
    if s.size < 2:
        raise InputError(f"{where}: an OCV table needs at least 2 rows, got {s.size}")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(v))):
        bad = int(np.flatnonzero(~(np.isfinite(s) & np.isfinite(v)))[0])
        raise InputError(f"{where}: row {bad + 1} is not a finite number")
    if s.min() < 0.0 or s.max() > 1.0:
        bad = int(np.flatnonzero((s < 0.0) | (s > 1.0))[0])
        raise InputError(f"{where}: soc must lie in [0, 1], got {s[bad]:g} in row {bad + 1}")
    if np.any(v <= 0.0):
        bad = int(np.flatnonzero(v <= 0.0)[0])
        raise InputError(f"{where}: ocv must be > 0 V, got {v[bad]:g} in row {bad + 1}")
    order = np.argsort(s, kind="stable")
    s, v = s[order], v[order]
    ds, dv = np.diff(s), np.diff(v)
    if np.any(ds == 0.0):
        j = int(np.flatnonzero(ds == 0.0)[0])
        raise InputError(f"{where}: soc {s[j]:g} appears twice; each state of charge once")
    if np.any(dv <= 0.0):
        j = int(np.flatnonzero(dv <= 0.0)[0])
        raise InputError(f"{where}: ocv must rise with soc (monotonic table), but it goes "
                         f"from {v[j]:.4f} V at soc {s[j]:g} to {v[j + 1]:.4f} V at soc "
                         f"{s[j + 1]:g}")
    return OcvTable(s, v, source=where)
