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
(``planner.identify.diagnose.diagnose(record, pack)``; capacity level only, no aircraft). Cases:

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
:mod:`planner.identify.diagnose.cutoff`). The **endurance equivalent** of an injection is measured
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
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from testkit import cells  # noqa: E402
from testkit.cell_effects import CASES, load_sources, run_case  # noqa: E402


# ============================================================================ data


# ============================================================================ injection


# ============================================================================ cases


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
                        f"{100 * within:.0f} % of the {len(f)} hits that fit it, of the charge "
                        f"per energy in {100 * within_cpe:.0f} %")
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
    data = load_sources()
    for name in args.cases.split(","):
        if CASES[name][0] not in data:
            print(f"{name}: data not found, skipped")
            continue
        print(report(name, run_case(name, data, args.runs, args.seed)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
