"""Real single-cell bench discharges as flight records (DESIGN §4), for the diagnose tests
and benchmarks on real cells.

The data are third-party lab logs in ``../shared/data/battery`` (see PROVENANCE.md there),
never copied into the repository:

* Molicel INR-21700-P42A (Team-Peryton/21700-Li-ion-Cell-Testing @ 968133a, no licence,
  validation only): constant-current discharges, one sample per ~10 s, read with the
  shipped column map ``planner/io/logs/maps/molicel_p42a.yaml``;
* Samsung INR18650-30Q (ARTS-Lab, CC BY-SA 4.0): constant-current rate tests C/10…4C,
  1 Hz, with the cell surface temperature;
* Enertech LiCoO2 pouch (PyBaMM repository, BSD-3-Clause; Ai et al. 2020, J. Electrochem.
  Soc. 167, 013512): 0.1C…2C discharges, 1 Hz, voltage only; the current is the nominal
  C-rate × 2.28 A (the files hold no current).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
BATTERY = REPO.parent / "shared" / "data" / "battery"
P42A = BATTERY / "molicel_p42a" / "p42a_discharge_segments_derived.csv"
Q30 = BATTERY / "samsung_30q_artslab" / "raw"
ENERTECH = BATTERY / "enertech_lco_pouch" / "raw"
P42A_MAP = REPO / "planner" / "io" / "logs" / "maps" / "molicel_p42a.yaml"

#: Samsung 30Q rate tests: (cell, rate label) → file name. [-]
Q30_RATES = ("C10", "1C", "2C", "3C", "4C")
#: Nominal capacity of the Enertech pouch cell (PyBaMM ``Ai2020``). [A h]
ENERTECH_AH = 2.28
#: Largest plausible cell current; larger values are logger overflow codes. [A]
MAX_CELL_CURRENT_A = 100.0


def available() -> bool:
    """True when the battery data set is beside the repository."""
    return P42A.is_file() and Q30.is_dir()


def p42a(test: str | tuple[str, ...] = "cycle") -> pd.DataFrame:
    """P42A discharges of ``test`` ("cycle": 1C to 2.5 V; "storage": 10 A to 3.7 V;
    "stress": 30/40 A), one experiment per upstream file, in the data set's order.

    Columns: experiment, time_s, voltage_v, current_a, consumed_mah, power_w (= V·I).
    """
    from planner.io.flightdata import load_flight_data

    tests = (test,) if isinstance(test, str) else tuple(test)
    df, _ = load_flight_data(P42A, column_map=P42A_MAP)
    raw = pd.read_csv(P42A, usecols=["source_file", "test", "set", "cell"]).drop_duplicates()
    keep = raw[raw["test"].str.startswith(tests)]
    df = df[df["experiment"].isin(keep["source_file"])].reset_index(drop=True)
    return df


def q30(rates: tuple[str, ...] = Q30_RATES, cells: tuple[int, ...] = (1, 2, 3)) -> pd.DataFrame:
    """Samsung 30Q rate tests as one record, one experiment per file.

    Columns: experiment, time_s, voltage_v, current_a (discharge positive), power_w,
    temperature_c (the cell surface thermocouple: the cell's own self-heating, 11 K at 1C
    to 41 K at 4C), ambient_temperature_c. Rows with a current beyond
    :data:`MAX_CELL_CURRENT_A` (a logger overflow code) are dropped. S003's 2C test ran
    at 2.33C (file ``Q30_S003_2.33C.csv``).
    """
    parts = []
    for cell in cells:
        for rate in rates:
            name = f"Q30_S00{cell}_{rate}.csv"
            path = Q30 / f"S00{cell}" / name
            if not path.is_file() and rate == "2C":
                path = Q30 / f"S00{cell}" / f"Q30_S00{cell}_2.33C.csv"
            d = pd.read_csv(path, header=None, encoding="utf-8-sig")
            d = d[d[1].abs() < MAX_CELL_CURRENT_A]
            current = -d[1].to_numpy(float)
            voltage = d[2].to_numpy(float)
            parts.append(pd.DataFrame({
                "experiment": path.stem, "time_s": d[0].to_numpy(float) - float(d[0].iloc[0]),
                "voltage_v": voltage, "current_a": current, "power_w": voltage * current,
                "temperature_c": d[4].to_numpy(float),
                "ambient_temperature_c": d[6].to_numpy(float)}))
    return pd.concat(parts, ignore_index=True)


def enertech(rates: tuple[str, ...] = ("0.5C", "1C", "2C")) -> pd.DataFrame:
    """Enertech pouch discharges: voltage as measured, current assumed = C-rate × 2.28 A.

    Columns: experiment, time_s, voltage_v, current_a, power_w.
    """
    parts = []
    for rate in rates:
        d = np.loadtxt(ENERTECH / f"{rate}_discharge_U.txt")
        current = float(rate.rstrip("C")) * ENERTECH_AH
        parts.append(pd.DataFrame({
            "experiment": f"enertech_{rate}", "time_s": d[:, 0] - d[0, 0],
            "voltage_v": d[:, 1], "current_a": current, "power_w": d[:, 1] * current}))
    return pd.concat(parts, ignore_index=True)


# ============================================================================ injections
# Physical laws applied to a real discharge (one experiment of a record): the data stay
# measured, only the named effect is added (never data made by the planner's own models).

R_GAS = 8.314462618     # J/(mol K)
T0_K = 273.15           # K at 0 °C


def arrhenius(temp_c, ea_j_per_mol: float, ref_c: float = 25.0):
    r"""R(T)/R(T_ref) of a thermally activated resistance. [unitless]

    :math:`R(T) = R_{ref} \exp[E_a/R_g\,(1/T - 1/T_{ref})]` (Arrhenius law of the
    charge-transfer and electrolyte resistance of Li-ion cells; e.g. Jaguemont, Boulon and
    Dubé 2016, Applied Energy 164, 99–114).
    """
    return np.exp(ea_j_per_mol / R_GAS * (1.0 / (np.asarray(temp_c, float) + T0_K)
                                          - 1.0 / (ref_c + T0_K)))


def shrink(g: pd.DataFrame, scale: float, extra_drop_v, cutoff_v: float) -> pd.DataFrame:
    r"""The discharge of the same cell with ``scale`` × its capacity and an extra voltage drop.

    At constant current a cell with capacity :math:`sQ` runs through the same
    voltage-versus-state-of-charge curve :math:`1/s` times faster, so every logged channel
    is resampled as :math:`x_s(t) = x(t/s)` on the original time stamps up to :math:`sT`;
    then ``extra_drop_v`` (V, a number or a function of the resampled record giving one
    value per sample, e.g. :math:`I\,\Delta R`) is subtracted from the voltage, the record
    ends where the voltage first falls below ``cutoff_v`` (the test's cut-off; at least 10
    samples are kept), and ``power_w`` = V·I is formed again.
    """
    t = g["time_s"].to_numpy(float)
    tn = t[t <= scale * t[-1]]
    out = {"time_s": tn}
    for col in g.columns:
        if col == "time_s":
            continue
        if pd.api.types.is_numeric_dtype(g[col]):
            out[col] = np.interp(tn / scale, t, g[col].to_numpy(float))
        else:
            out[col] = g[col].iloc[0]
    d = pd.DataFrame(out)
    drop = extra_drop_v(d) if callable(extra_drop_v) else extra_drop_v
    d["voltage_v"] = d["voltage_v"] - np.asarray(drop, float)
    below = np.flatnonzero(d["voltage_v"].to_numpy() < cutoff_v)
    if below.size:
        d = d.iloc[:max(int(below[0]), 10)].copy()
    d["power_w"] = d["voltage_v"] * d["current_a"]
    return d.reset_index(drop=True)


def age(g: pd.DataFrame, cycle: float, fade_per_cycle: float, r_growth_per_cycle: float,
        r0_ohm: float) -> pd.DataFrame:
    r"""The discharge as the same cell would give it after ``cycle`` charge cycles.

    Capacity :math:`Q_n = Q_0(1 - a n)` (:func:`shrink`) and DC resistance
    :math:`R_n = R_0(1 + g n)`, i.e. an extra drop :math:`I R_0 g n`; the discharge ends at
    its own cut-off (its last voltage). Sets ``cycle`` = n.
    """
    dr = r0_ohm * r_growth_per_cycle * cycle
    cutoff = float(g["voltage_v"].iloc[-1]) - 1e-3
    d = shrink(g, 1.0 - fade_per_cycle * cycle, lambda d: d["current_a"] * dr, cutoff)
    d["cycle"] = float(cycle)
    return d


def chill(g: pd.DataFrame, drop_c: float, capacity_loss_at_0c: float, r25_ohm: float,
          ea_j_per_mol: float) -> pd.DataFrame:
    r"""The discharge of the same cell ``drop_c`` colder (ambient and cell).

    The cell temperature (``temperature_c``, which must be present) falls by ``drop_c``
    sample by sample (self-heating kept); the resistance follows :func:`arrhenius`, so the
    voltage falls by :math:`I\,R_{25}[r(T - \Delta T) - r(T)]`; the usable capacity falls
    by ``capacity_loss_at_0c`` × (25 °C − the new ambient)/25 K (linear, none at 25 °C;
    :func:`shrink`). Ends at the discharge's own cut-off.
    """
    amb = float(g["ambient_temperature_c"].mean()) if "ambient_temperature_c" in g else \
        float(g["temperature_c"].iloc[0])
    new_amb = amb - drop_c
    scale = 1.0 - capacity_loss_at_0c * float(np.clip((25.0 - new_amb) / 25.0, 0.0, None))
    cutoff = float(g["voltage_v"].iloc[-1]) - 1e-3

    def extra(d):
        temp = d["temperature_c"].to_numpy(float)
        ratio = arrhenius(temp - drop_c, ea_j_per_mol) - arrhenius(temp, ea_j_per_mol)
        return d["current_a"].to_numpy(float) * r25_ohm * ratio

    d = shrink(g, scale, extra, cutoff)
    d["temperature_c"] -= drop_c
    if "ambient_temperature_c" in d:
        d["ambient_temperature_c"] -= drop_c
    return d


def bias(g: pd.DataFrame, amps: float) -> pd.DataFrame:
    """The discharge as a current sensor reading ``amps`` too high logs it (and V·I)."""
    d = g.copy()
    d["current_a"] = d["current_a"] + amps
    d["power_w"] = d["voltage_v"] * d["current_a"]
    if "consumed_mah" in d:
        d = d.drop(columns="consumed_mah")
    return d


def energy_wh(g: pd.DataFrame) -> float:
    """∫P dt of one discharge. [W h]"""
    return float(np.trapezoid(g["power_w"].to_numpy(float), g["time_s"].to_numpy(float))) / 3600


def charge_ah(g: pd.DataFrame) -> float:
    """∫I dt of one discharge. [A h]"""
    return float(np.trapezoid(g["current_a"].to_numpy(float),
                              g["time_s"].to_numpy(float))) / 3600


# ============================================================================ equivalents

def mean_hinge(g: pd.DataFrame, column: str = "temperature_c", reference_c: float = 25.0
               ) -> float:
    """Charge-weighted mean of max(reference − T, 0) over one discharge: the driver of the
    planner's cold-pack charge scale (:meth:`planner.parameters.IntegralModel.extend_charge`).
    [°C]"""
    h = np.maximum(reference_c - g[column].to_numpy(float), 0.0)
    i = g["current_a"].to_numpy(float)
    return float(np.sum(h * i) / np.sum(i))


def charge_scale_equivalent(f, dz, z0) -> float:
    r"""An injection expressed as the planner's charge scale :math:`1 + k z`.

    ``f`` per pair of discharges: energy to the cut-off clean over injected − 1; ``dz`` the
    rise of the driver z (the cycle, or :func:`mean_hinge`) from clean to injected, ``z0``
    its clean value. Returns the k that minimises
    :math:`\sum [\ln(1 + f) - \ln((1 + k (z_0 + \Delta z)) / (1 + k z_0))]^2`, the loss the
    cut-off level of ``diagnose`` fits. [1/unit of z]
    """
    from scipy.optimize import minimize_scalar

    f, dz, z0 = (np.asarray(a, float) for a in (f, dz, z0))
    y = np.log1p(f)

    def loss(k):
        return float(np.sum((y - np.log((1 + k * (z0 + dz)) / (1 + k * z0))) ** 2))

    k0 = float(np.sum(dz * f) / np.sum(dz * dz))
    lo, hi = sorted((k0 / 4, 4 * k0))
    return float(minimize_scalar(loss, bounds=(lo - 1e-9, hi + 1e-9), method="bounded").x)
