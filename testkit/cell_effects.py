"""Real single-cell discharges with one physically injected effect (ageing, cold, a
current-sensor bias), for diagnose's benchmark (``benchmarks/bench_diagnose_cells.py``,
whose docstring states each law and its size) and its tests.

Data: ``../shared/data/battery`` (PROVENANCE.md there), read by :mod:`testkit.cells`.
"""

from __future__ import annotations

import time
import warnings
from collections import Counter

import numpy as np
import pandas as pd

from planner.identify.diagnose import diagnose
from planner.parameters import BatteryPack
from testkit import cells

#: Capacity fade of the realistic ageing case (80 % after 500 cycles). [1/cycle]
FADE_PER_CYCLE = 0.0004


#: DC-resistance growth of the realistic ageing case (+30 % after 500 cycles). [1/cycle]
R_GROWTH_PER_CYCLE = 0.0006


#: Cycles between two logged discharges of the aged pack. [cycles]
FADE_SPACING = 50


#: Ambient temperature of the cold discharges. [°C]
COLD_AMBIENT_C = 0.0


#: Lab temperature of the P42A logs (no temperature channel). [°C]
P42A_LAB_C = 22.0


#: Activation energy of the cell's DC resistance (R doubles from 25 to 0 °C). [J/mol]
EA_J_PER_MOL = 19_000.0


#: Loss of usable capacity at 0 °C against 25 °C. [unitless]
COLD_CAPACITY_LOSS = 0.10


#: Zero error of the current sensor. [A]
BIAS_A = 0.1


#: DC resistance at 25 °C. [ohm]
R25 = {"p42a": 7.87e-3, "q30": 30e-3, "q30amb": 30e-3}


#: The packs' empty voltage (the planner's default ``cell_voltage_empty_v``). [V]
EMPTY_CELL_V = 3.5


#: Nominal capacity of the pack (one cell). [mAh]
CAPACITY_MAH = {"p42a": 4200.0, "q30": 3000.0, "q30amb": 3000.0, "pouch": 2280.0}


def load_sources():
    q30 = cells.q30()
    data = {"p42a": cells.p42a(("cycle", "storage")).drop(columns="consumed_mah"),
            "q30": q30, "q30amb": q30}
    if cells.ENERTECH.is_dir():
        data["pouch"] = cells.enertech()
    return data


def _experiments(df):
    return {k: g.reset_index(drop=True) for k, g in df.groupby("experiment", sort=False)}


def _draw(source, exps, rng, kind):
    names = list(exps)
    if source == "p42a":
        cyc = [n for n in names if "cycle" in n]
        sto = [n for n in names if "storage" in n]
        pick = list(rng.choice(cyc, 8, replace=False))
        if kind != "fade":
            pick += list(rng.choice(sto, 7, replace=False))
        return pick
    if source in ("q30", "q30amb"):
        return list(rng.choice(names, 10, replace=False))
    return names


def inject(source, kind, parts, rng, size):
    """One run's record and two equivalents of the injection in the effect's parameter.

    ``parts`` are the clean discharges. Returns (record, endurance equivalent,
    charge-per-energy equivalent): the first is the rise of the factor on the charge drawn
    that makes the planner's pack run out when the injected cell reaches its cut-off
    (energy to cut-off clean / injected − 1), the second the rise of the charge drawn per
    unit energy over the discharge (what the capacity level's windows can show); both
    regressed through the origin on the cycle number or the temperature drop.
    """
    if kind == "clean":
        return pd.concat(parts, ignore_index=True), float("nan"), float("nan")
    if kind == "bias":
        out = [cells.bias(g, size * BIAS_A) for g in parts]
        return pd.concat(out, ignore_index=True), size * BIAS_A, size * BIAS_A
    out, xs, pairs, base = [], [], [], []
    if kind == "fade":
        for g, k in zip(parts, rng.permutation(len(parts))):
            n = FADE_SPACING * float(k)
            d = cells.age(g, n, size * FADE_PER_CYCLE, size * R_GROWTH_PER_CYCLE, R25[source])
            out.append(d)
            xs.append(n)
            base.append(0.0)
            pairs.append((g, d))
    else:  # cold
        cold = set(rng.choice(len(parts), len(parts) // 2, replace=False).tolist())
        for j, g in enumerate(parts):
            if "temperature_c" not in g:
                g = g.assign(temperature_c=P42A_LAB_C, ambient_temperature_c=P42A_LAB_C)
            if j not in cold:
                out.append(g)
                continue
            drop = float(g["ambient_temperature_c"].mean()) - COLD_AMBIENT_C
            d = cells.chill(g, drop, size * COLD_CAPACITY_LOSS, size * R25[source],
                            EA_J_PER_MOL)
            out.append(d)
            # the drop in the planner's driver: the charge-weighted mean of the hinge
            # max(25 °C − T, 0) of the temperature channel diagnose reads
            col = "ambient_temperature_c" if source == "q30amb" else "temperature_c"
            xs.append(cells.mean_hinge(d, col) - cells.mean_hinge(g, col))
            base.append(cells.mean_hinge(g, col))
            pairs.append((g, d))
    # the pack's endurance is set by the discharges to empty (the P42A "storage" tests stop
    # at 3.7 V, half-way)
    full = np.array([float(g["voltage_v"].iloc[-1]) <= EMPTY_CELL_V for g, _ in pairs])
    x = np.asarray(xs)[full]
    h0 = np.asarray(base)[full]
    pairs = [p for p, ok in zip(pairs, full) if ok]
    f = np.array([cells.energy_wh(g) / cells.energy_wh(d) - 1.0 for g, d in pairs])
    r = np.array([(cells.charge_ah(d) / cells.energy_wh(d))
                  / (cells.charge_ah(g) / cells.energy_wh(g)) - 1.0 for g, d in pairs])
    if not len(x):
        return pd.concat(out, ignore_index=True), float("nan"), float("nan")
    return (pd.concat(out, ignore_index=True), cells.charge_scale_equivalent(f, x, h0),
            cells.charge_scale_equivalent(r, x, h0))


#: case → (data source, injection, size × realistic, the effect that should be named).
CASES = {
    "clean_p42a": ("p42a", "clean", 0.0, None),
    "clean_30q": ("q30", "clean", 0.0, None),
    "clean_pouch": ("pouch", "clean", 0.0, None),
    "fade_p42a": ("p42a", "fade", 1.0, "capacity_fade"),
    "fade_p42a_x4": ("p42a", "fade", 4.0, "capacity_fade"),
    "cold_p42a": ("p42a", "cold", 1.0, "temperature"),
    "cold_p42a_x4": ("p42a", "cold", 4.0, "temperature"),
    "cold_30q": ("q30", "cold", 1.0, "temperature"),
    "cold_30q_x4": ("q30", "cold", 4.0, "temperature"),
    "clean_30q_amb": ("q30amb", "clean", 0.0, None),
    "cold_30q_amb": ("q30amb", "cold", 1.0, "temperature"),
    "cold_30q_amb_x4": ("q30amb", "cold", 4.0, "temperature"),
    "bias_p42a": ("p42a", "bias", 1.0, "current_offset"),
    "bias_30q": ("q30", "bias", 1.0, "current_offset"),
}


KEY = {"capacity_fade": "fade_per_cycle", "temperature": "temperature_coefficient_per_c",
       "current_offset": "current_offset_a"}


def run_case(name, data, runs, seed):
    source, kind, size, expect = CASES[name]
    exps = _experiments(data[source])
    rng = np.random.default_rng(seed)
    n_runs = 1 if source == "pouch" else runs
    stats = {"runs": n_runs, "first": 0, "any_cause": 0, "false": Counter(), "cpu": [],
             "fits": [], "skipped": 0, "withheld": Counter(), "equiv": [], "cpe": []}
    for _ in range(n_runs):
        pick = _draw(source, exps, rng, kind)
        record, equiv, cpe = inject(source, kind, [exps[n] for n in pick], rng, size)
        if source == "q30amb":      # the same injection, seen by a sensor in the air
            record["temperature_c"] = record["ambient_temperature_c"]
        pack = BatteryPack(name=source, cells_series=1, capacity_mah=CAPACITY_MAH[source],
                           mass_kg=0.0)
        t0 = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = diagnose(record, pack)
        stats["cpu"].append(time.process_time() - t0)
        named = [f["effect"] for f in res.findings]
        stats["any_cause"] += bool(named)
        for w in res.withheld:
            stats["withheld"][w["effect"]] += 1
        stats["false"].update(e for e in named if e != expect)
        tested = {c["effect"] for c in res.to_dict()["candidates"]}
        if expect and expect not in tested and \
                any(s["effect"] == expect for s in res.skipped):
            stats["skipped"] += 1
        stats["equiv"].append(equiv)
        stats["cpe"].append(cpe)
        if expect and named and named[0] == expect:
            stats["first"] += 1
            # the fitted coefficient of the model level's finding (a direct-evidence
            # finding of the same cause, e.g. the resistance against the pack
            # temperature, carries other parameters and may rank first)
            p = next((f["parameters"] for f in res.findings
                      if f["effect"] == expect and KEY[expect] in f["parameters"]), None)
            if p is not None:
                stats["fits"].append((p[KEY[expect]], p[KEY[expect] + "_stderr"], equiv,
                                      cpe))
    return stats
