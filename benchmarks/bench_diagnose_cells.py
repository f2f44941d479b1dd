r"""diagnose on real single-cell discharges, clean and with one physically injected effect.

Data (``../shared/data/battery``, PROVENANCE.md there; read by :mod:`testkit.cells`):

* **P42A** — Molicel INR-21700-P42A: 10 discharges at 1C (4.25 A) to 2.5 V on 9 cells
  ("cycle") and 9 at 10 A to 3.7 V ("storage"), PowerLab 8 logs, one sample per 10 s;
  no temperature channel. Pack: 1 cell, 4200 mAh (data-sheet nominal).
* **30Q** — Samsung INR18650-30Q, 3 cells × C/10, 1C, 2C (2.33C), 3C, 4C to 2.5 V, 1 Hz,
  with the cell surface temperature (the cell's own self-heating: +11 K at 1C, +41 K at
  4C) at 22–23 °C ambient. Pack: 1 cell, 3000 mAh.
* **pouch** — Enertech LiCoO2 pouch, 0.5C/1C/2C to 3.0 V (current = C-rate × 2.28 A:
  the files hold none); three discharges, so only the clean case (one run, nothing to
  resample).

The logged charge is always the trapezoid integral of the (possibly injected) current
(``consumed_mah`` is dropped), so clean and injected runs are scored the same way.

Each run draws a subset of the discharges at random (seeded: P42A 8 of 10 "cycle" and 7
of 9 "storage" discharges; 30Q 10 of 15 rate tests) and runs the full search
(``planner.diagnose.diagnose(record, pack)``; capacity level only, no aircraft). Cases:

``clean``
    The real discharges as recorded (target: no cause named in ≥ 95 % of runs). The 30Q
    cells' self-heating is real and is *not* an effect: naming ``temperature`` there is a
    false cause.
``fade`` (P42A "cycle" discharges)
    The drawn discharges become one pack logged every :data:`FADE_SPACING` cycles
    (cycle 0, 50, 100, …; random order of the cells), ``cycle`` set accordingly. Ageing
    law at cycle n: capacity :math:`Q_n = Q_0(1 - a n)` — the cell runs through the same
    voltage-versus-state-of-charge curve :math:`(1 - a n)` times faster, so the real
    voltage is resampled as :math:`V_n(t) = V(t/(1 - a n))` — and the DC resistance grows
    :math:`R_n = R_0(1 + g n)`, so :math:`V_n` falls further by :math:`I R_0 g n`; the
    discharge ends where :math:`V_n` first falls below the test's own cut-off.
    Realistic size: :data:`FADE_PER_CYCLE` = 0.04 %/cycle (80 % of the capacity after
    500 cycles, the usual data-sheet end-of-life rating of 18650/21700 power cells) and
    :data:`R_GROWTH_PER_CYCLE` = 0.06 %/cycle (+30 % DC resistance at that point;
    resistance rise of the order of the capacity loss, e.g. Schuster et al. 2015,
    J. Energy Storage 1, 44–53); :math:`R_0` = 7.87 mΩ, the P42A's identified
    resistance (docs/results.md).
``cold`` (P42A, 30Q)
    Half of the drawn discharges (at random) run at :data:`COLD_AMBIENT_C` = 0 °C
    instead of the lab's 22–23 °C. The cell temperature falls by the same amount (the
    30Q's measured self-heating is kept on top; the P42A, which logs no temperature, is
    given a constant 22 °C warm and 0 °C cold channel, as a pack sensor would read
    before self-heating). Law: the DC resistance follows Arrhenius,
    :math:`R(T) = R_{25}\exp[E_a/R_g\,(1/T - 1/T_{25})]` with :data:`EA_J_PER_MOL`
    = 19 kJ/mol (R doubles from 25 to 0 °C, the usual factor for Li-ion cells, e.g.
    Jaguemont, Boulon and Dubé 2016, Applied Energy 164, 99–114), applied sample by
    sample at the cell temperature, :math:`V_{cold} = V - I\,[R(T_{cold}) - R(T)]`; and
    the usable capacity falls :data:`COLD_CAPACITY_LOSS` = 10 % at 0 °C (linear in the
    temperature below 25 °C; typical of 18650 data-sheet temperature curves at 0.2–1C),
    by the same resampling as for fade. :math:`R_{25}`: 7.87 mΩ (P42A), 30 mΩ (30Q: the
    1-s voltage step at the start of its 1C–4C tests, (V_rest − V_loaded)/I).
``*_30q_amb``
    The same 30Q cases with the ambient (chamber) channel as ``temperature_c`` instead of
    the cell surface: a pack sensor that reads the air, without the self-heating. It
    shows how much of the cold cells' miss is owed to the self-heating in the
    temperature channel.
``bias`` (P42A, 30Q)
    The logged current reads :data:`BIAS_A` = +0.1 A too high (and so does V·I): the
    zero error of a Hall-effect hobby current sensor (Allegro ACS712/ACS758 class: tens
    of mV of offset and noise at 40–185 mV/A). These discharges never rest, so diagnose
    should say that a bias cannot be told from the calibration (``current_offset``
    skipped) and name no other cause.

``×4`` cases inject four times the realistic size (the size at which capacity fade and
cold cells were reported to become visible).

What "the injected value" is in diagnose's terms. ``capacity_fade`` and ``temperature``
are factors on the charge drawn (:meth:`planner.parameters.IntegralModel.charge_scale`,
:math:`1 + \varphi n` and :math:`1 + k\,\bar h` with :math:`\bar h` the charge-weighted
mean of max(25 °C − T, 0) over a discharge): the planner's pack runs out when the scaled
charge reaches its capacity, so a scale s leaves 1/s of the energy. Where the discharges
reach their cut-off, diagnose fits them on the energy delivered to it (the cut-off level,
:mod:`planner.diagnose.cutoff`). The **endurance equivalent** of an injection is measured
on the data: for each pair of a clean discharge to the empty voltage and the same
discharge injected, f = energy to the cut-off clean / injected − 1; the equivalent is the
k (or φ) of the scale whose ratio :math:`(1 + k z_{inj})/(1 + k z_{clean})` fits the
pairs' 1 + f best in the log (:func:`testkit.cells.charge_scale_equivalent`, z the cycle
or :math:`\bar h` of the channel diagnose reads). The **charge per energy equivalent** (the
same with (charge/energy) injected over clean) is printed beside it: what the capacity
level's windows could show. Printed per case: runs, the rate at which the expected effect
is named first, the fitted parameter ± its standard error (medians over the runs where it
was named) against both equivalents and the share of those runs within 2 SE of the
endurance equivalent, the false causes named, and the CPU time per run. Run::

    python benchmarks/bench_diagnose_cells.py [--runs 20] [--seed 1] [--cases clean_p42a,...]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from planner.diagnose import diagnose  # noqa: E402
from planner.parameters import BatteryPack  # noqa: E402
from testkit import cells  # noqa: E402

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


# ============================================================================ data

def _load():
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


# ============================================================================ injection

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



# ============================================================================ cases

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
            p = res.findings[0]["parameters"]
            stats["fits"].append((p[KEY[expect]], p[KEY[expect] + "_stderr"], equiv, cpe))
    return stats


def _fmt(x):
    return f"{x:.3g}" if np.isfinite(x) else "-"


def report(name, s):
    source, kind, size, expect = CASES[name]
    line = [f"{name:14s} runs {s['runs']:3d}"]
    if expect is None:
        clean = s["runs"] - s["any_cause"]
        line.append(f"no cause named {clean}/{s['runs']} ({100 * clean / s['runs']:.0f} %, "
                    f"target ≥ 95 %)")
    else:
        line.append(f"{expect} named first {s['first']}/{s['runs']} "
                    f"({100 * s['first'] / s['runs']:.0f} %, target ≥ 80 %)")
        if s["skipped"]:
            line.append(f"not testable (skipped with a reason) {s['skipped']}/{s['runs']}")
        unit = {"capacity_fade": "1/cycle", "temperature": "1/°C", "current_offset": "A"}[expect]
        eq = float(np.nanmedian(s["equiv"]))
        cpe = float(np.nanmedian(s["cpe"]))
        injected = (f"injected {_fmt(eq)} {unit} (endurance equivalent; charge per energy "
                    f"{_fmt(cpe)})" if expect != "current_offset" else
                    f"injected {_fmt(eq)} {unit}")
        if s["fits"]:
            f = np.array(s["fits"])
            within = np.mean(np.abs(f[:, 0] - f[:, 2]) <= 2 * f[:, 1])
            within_cpe = np.mean(np.abs(f[:, 0] - f[:, 3]) <= 2 * f[:, 1])
            line.append(f"fitted {_fmt(np.median(f[:, 0]))} ± {_fmt(np.median(f[:, 1]))} {unit} "
                        f"vs {injected}; within 2 SE of the endurance equivalent in "
                        f"{100 * within:.0f} % of hits, of the charge per energy in "
                        f"{100 * within_cpe:.0f} %")
        else:
            line.append(injected)
    false = ", ".join(f"{k} {v}" for k, v in s["false"].most_common()) or "none"
    line.append(f"false causes named: {false}")
    if s["withheld"]:
        line.append("withheld: " + ", ".join(f"{k} {v}" for k, v in s["withheld"].items()))
    line.append(f"CPU {np.mean(s['cpu']):.2f} s/run")
    return "; ".join(line)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cases", default=",".join(CASES))
    args = ap.parse_args(argv)
    if not cells.available():
        print(f"battery data not found at {cells.BATTERY}: nothing to measure")
        return 0
    data = _load()
    for name in args.cases.split(","):
        if CASES[name][0] not in data:
            print(f"{name}: data not found, skipped")
            continue
        print(report(name, run_case(name, data, args.runs, args.seed)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
