"""Open-circuit voltage of lithium cells against state of charge."""

from __future__ import annotations

import numpy as np


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
    4.10 V full, 3.70 V at half charge, steep knee below 10 %.

    References
    ----------
    .. [1] M. Chen and G. A. Rincón-Mora, "Accurate electrical battery model
       capable of predicting runtime and I–V performance," IEEE Trans. Energy
       Convers., vol. 21, no. 2, pp. 504–511, 2006, doi:10.1109/TEC.2006.874229.
    """
    s = np.clip(soc, 0.0, 1.0)
    return -1.031 * np.exp(-35.0 * s) + 3.685 + 0.2156 * s - 0.1178 * s**2 + 0.3201 * s**3
