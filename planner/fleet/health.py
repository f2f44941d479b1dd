r"""Pack health over a fleet's flights: charge per energy, resistance, usable capacity, fade.

For each pack (the ``pack_id`` of the fleet table) the flights are put in cycle order:
the pack's cycle count from ``--packs`` where given, else the order of the flights' start
times, else of the log names (the flight number is then the cycle).

Fade
----
Each flight's δ scale :math:`s_i` (measured over predicted charge along the flight,
:mod:`planner.fleet.summary`) is fitted as

.. math:: s(n) = a\,(1 + \varphi\,n)

by weighted least squares (``scipy.optimize.curve_fit``, weights the flights' standard
errors, covariance scaled by the scatter between flights): :math:`a` is the new pack
against the model, :math:`\varphi` the rise of the charge drawn for the same energy per
cycle — the ``fade_per_cycle`` of the pack file
(:meth:`planner.parameters.IntegralModel.charge_scale`, ``1 + fade_per_cycle · cycle``).
The pack's state of health is the share of its new-pack energy its charge still delivers,
:math:`\mathrm{SoH}(n) = 1/(1 + \varphi n)`; it crosses the retirement threshold
:math:`h` (default 0.8) at :math:`n_h = (1/h - 1)/\varphi`, with a standard error from the
delta method.

Resistance
----------
The per-flight step resistances (where the log has steps) against the cycle: a straight
line (``numpy.polyfit`` with its covariance), its value at the last flight.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import OptimizeWarning, curve_fit

#: Default retirement threshold: state of health (share of the new pack's energy). [unitless]
RETIRE_DEFAULT = 0.8
#: Fewest flights for a fade fit.
MIN_FLIGHTS = 3


@dataclass(frozen=True)
class PackHealth:
    """One pack's health (module notes). Fractions are unitless; NaN = not determined.

    Attributes
    ----------
    pack_id : str
    flights : int
    last_cycle : float
        Cycle of the last flight in the table. [cycles]
    scale_new, scale_new_se : float
        :math:`a`: charge drawn by the new pack over the model's. [unitless]
    fade_per_cycle, fade_per_cycle_se : float
        :math:`\\varphi`. [1/cycle]
    soh, soh_se : float
        State of health at the last flight, :math:`1/(1 + \\varphi n)`. [unitless]
    retire_cycle, retire_cycle_se : float
        Cycle at which the SoH reaches the threshold (inf when the pack does not fade).
    flights_to_retire : float
        ``retire_cycle − last_cycle`` (≤ 0: already past). [flights]
    resistance_ohm, resistance_se_ohm : float
        Resistance at the last flight from the trend over the flights with steps. [Ω]
    resistance_slope_ohm_per_cycle, resistance_slope_se : float
        [Ω/cycle]
    capacity_mah : float
        Nominal capacity × SoH at the last flight (NaN without a nominal). [mAh]
    aircraft : str
        The aircraft that flew most of its flights ("" when not known).
    """

    pack_id: str
    flights: int
    last_cycle: float
    scale_new: float
    scale_new_se: float
    fade_per_cycle: float
    fade_per_cycle_se: float
    soh: float
    soh_se: float
    retire_cycle: float
    retire_cycle_se: float
    flights_to_retire: float
    resistance_ohm: float
    resistance_se_ohm: float
    resistance_slope_ohm_per_cycle: float
    resistance_slope_se: float
    capacity_mah: float
    aircraft: str = ""

    def retires_within(self, flights: float) -> bool:
        """True when the SoH is below the threshold now or reaches it within ``flights``."""
        return bool(np.isfinite(self.flights_to_retire) and self.flights_to_retire <= flights)


def cycle_order(flights: pd.DataFrame) -> np.ndarray:
    """The cycle of each of one pack's flights (module notes)."""
    if "cycle" in flights and flights["cycle"].notna().all():
        return flights["cycle"].to_numpy(float)
    keys = pd.DataFrame({"t": flights["start_time_utc"] if "start_time_utc" in flights
                         else pd.NaT, "log": flights["log"].astype(str)})
    order = keys.sort_values(["t", "log"], na_position="last", kind="stable").index
    rank = pd.Series(np.arange(len(order), dtype=float), index=order)
    return rank.reindex(flights.index).to_numpy(float)


def _model(n, a, phi):
    return a * (1.0 + phi * n)


def fit_fade(cycle, scale, scale_se=None) -> tuple[np.ndarray, np.ndarray]:
    """:math:`(a, \\varphi)` and their covariance from one pack's flights (module notes)."""
    n = np.asarray(cycle, float)
    s = np.asarray(scale, float)
    se = None if scale_se is None else np.asarray(scale_se, float)
    ok = np.isfinite(n) & np.isfinite(s) & (s > 0)
    if se is not None:
        ok &= np.isfinite(se) & (se > 0)
    nan2 = np.full(2, np.nan)
    if ok.sum() < MIN_FLIGHTS or np.ptp(n[ok]) <= 0:
        return nan2, np.full((2, 2), np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", OptimizeWarning)
        p, cov = curve_fit(_model, n[ok], s[ok], p0=(float(np.median(s[ok])), 0.0),
                           sigma=None if se is None else se[ok], absolute_sigma=False)
    return p, cov


def pack_health(table: pd.DataFrame, *, retire: float = RETIRE_DEFAULT,
                nominal_mah: float | dict | None = None,
                aircraft: dict | None = None) -> list[PackHealth]:
    """Health of every identified pack of the fleet table (``status == "ok"``).
    ``nominal_mah``: the new pack's capacity, or pack id → it; ``aircraft``: pack id → the
    aircraft that flew it."""
    out = []
    ok = table[(table["status"] == "ok") & table["pack_id"].notna()
               & (table["pack_id"] != "unknown")]
    for pack_id, flights in ok.groupby("pack_id", sort=True):
        n = cycle_order(flights)
        nominal = (nominal_mah.get(str(pack_id)) if isinstance(nominal_mah, dict)
                   else nominal_mah)
        (a, phi), cov = fit_fade(n, flights["delta_scale"], flights["delta_scale_se"])
        last = float(np.nanmax(n)) if len(n) else math.nan
        a_se, phi_se = (np.sqrt(np.diag(cov)) if np.all(np.isfinite(cov))
                        else (math.nan, math.nan))
        soh = 1.0 / (1.0 + phi * last) if np.isfinite(phi) else math.nan
        soh_se = abs(last / (1.0 + phi * last) ** 2) * phi_se if np.isfinite(phi) else math.nan
        if np.isfinite(phi) and phi > 0:
            n_ret = (1.0 / retire - 1.0) / phi
            n_ret_se = n_ret * phi_se / phi
        else:
            n_ret, n_ret_se = math.inf, math.nan
        r_now = r_se = slope = slope_se = math.nan
        res = flights["resistance_ohm"].to_numpy(float)
        rk = np.isfinite(res)
        if rk.sum() >= MIN_FLIGHTS and np.ptp(n[rk]) > 0:
            coef, rcov = np.polyfit(n[rk], res[rk], 1, cov=True) if rk.sum() > 3 else (
                np.polyfit(n[rk], res[rk], 1), np.full((2, 2), np.nan))
            slope, r_now = float(coef[0]), float(coef[0] * last + coef[1])
            slope_se = float(math.sqrt(rcov[0, 0])) if np.isfinite(rcov[0, 0]) else math.nan
            var = rcov[0, 0] * last**2 + 2 * last * rcov[0, 1] + rcov[1, 1]
            r_se = float(math.sqrt(var)) if np.isfinite(var) and var >= 0 else math.nan
        elif rk.any():
            r_now = float(np.median(res[rk]))
            if rk.sum() > 1:
                r_se = 1.2533 * float(np.std(res[rk], ddof=1)) / math.sqrt(rk.sum())
        out.append(PackHealth(
            pack_id=str(pack_id), flights=len(flights), last_cycle=last,
            scale_new=float(a), scale_new_se=float(a_se), fade_per_cycle=float(phi),
            fade_per_cycle_se=float(phi_se), soh=float(soh), soh_se=float(soh_se),
            retire_cycle=float(n_ret), retire_cycle_se=float(n_ret_se),
            flights_to_retire=float(n_ret - last), resistance_ohm=r_now,
            resistance_se_ohm=r_se, resistance_slope_ohm_per_cycle=slope,
            resistance_slope_se=slope_se,
            capacity_mah=float(nominal * soh) if nominal else math.nan,
            aircraft=str((aircraft or {}).get(str(pack_id), ""))))
    return out


def health_frame(health: list[PackHealth]) -> pd.DataFrame:
    """The health of the packs as a table, one row per pack."""
    return pd.DataFrame([h.__dict__ for h in health])
