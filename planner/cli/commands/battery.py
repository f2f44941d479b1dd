"""Battery identification commands: ``fit-battery``, ``design``, ``pulse-resistance``, ``bench``.

Argparse and printing only; the work is done by :mod:`planner.identify.battery_fit`,
:mod:`planner.identify.protocols`, :mod:`planner.identify.pulse_resistance`,
:mod:`planner.identify.bench` and :mod:`planner.identify.campaign`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import yaml

from planner.io import files
from planner.identify import protocols as design, battery_fit as fit, pulse_resistance as vda
from planner.physics.battery import integral
from planner.physics.battery.cells import series_cells
from planner.cli.commands.pack_scale import describe, parse_cells, scale_model
from planner.cli.commands.common import (add_options, fmt, name_width, output_path, outputs,
                                         parse_float, parse_int, write_json)
from planner.errors import InputError
from planner.parameters import IntegralModel, battery_from_mapping, load_battery, read_definition
from planner.identify.schedule import write_schedule
from planner.physics.units import AS_PER_MAH

def register(sub) -> None:
    """Add the battery commands (``fit-battery``, ``design``, ``pulse-resistance``,
    ``bench``) with their options to the subcommand parsers ``sub``."""
    _register_fit(sub)
    _register_design(sub)
    _register_pulse(sub)
    _register_bench(sub)


# --------------------------------------------------------------------------- fit-battery

#: What ``fit-battery`` does, for its help.
FIT_DESCRIPTION = (
    "Fit the integral capacity model t = δ P^ε C^β to measured discharges (flight-record "
    "CSV: time_s, power_w or voltage_v+current_a, and current_a or consumed_mah; several "
    "experiments told apart by 'experiment'). Default split ([UAV23]): the experiments with "
    "the lowest and the highest mean power train, the rest validate. Exit 1 when a "
    "parameter ends on its bound or outside its physical range (a misfit, written as "
    "fit_status).")


def _register_fit(sub) -> None:
    p = sub.add_parser("fit-battery", description=FIT_DESCRIPTION,
                       help="identify the integral model δ, ε, β from discharge data")
    p.add_argument("data", nargs="+", help="flight-record CSV file(s)")
    add_options(p, out={"required": True, "help": "battery-pack YAML to write"},
                battery="pack YAML whose other keys are kept (name, mass, ...)")
    p.add_argument("--name", help="pack name (required without --battery)")
    p.add_argument("--cells", help="cells in series (without --battery; default: detected "
                                   "as max voltage / 4.25 V, rounded up); S×P (e.g. 4x2): "
                                   "the data are one cell's, and the pack file written is "
                                   "that of S in series × P in parallel (δ and the charge "
                                   "scaled from the cell)")
    p.add_argument("--mass-kg", help="pack mass [kg] (required without --battery)")
    p.add_argument("--capacity-mah", help="nominal capacity to write [mAh] (the datasheet's; "
                                          "default: the charge measured to the cut-off at "
                                          "the lowest power, said so)")
    p.add_argument("--chemistry", help="cell chemistry to write (lipo, liion, …; default "
                                       "lipo)")
    p.add_argument("--fix-beta", help="hold β at this value (e.g. 0.9648) and fit δ, ε only")
    add_options(p, map=True)
    p.add_argument("--in-flight", action="store_true",
                   help="fit each experiment from spin-up to touch-down only, as backtest "
                        "scores a flight (flight logs: the ground before and after is no "
                        "part of the flight's discharge); experiments never airborne are "
                        "left out, said so")
    p.add_argument("--train", help="comma-separated experiment ids to fit on")
    p.add_argument("--validate", help="comma-separated experiment ids to score only")
    add_options(p, plot="PNG of measured vs predicted C^β and residuals",
                json="write the fit and the metrics as JSON to this file")
    p.add_argument("--circuit", metavar="PULSE_CSV",
                   help="also identify the equivalent circuit (R0(SoC) from pulse edges, R1 "
                        "and C1 from the relaxations, with the LiPo OCV) from a "
                        "pulse-test record (time_s, voltage_v, current_a) and write it as the "
                        "pack's 'circuit:' block")
    p.add_argument("--circuit-rates", action="store_true",
                   help="also identify the equivalent circuit (an OCV(SoC) table and the DC "
                        "resistance) from the training experiments — constant-current "
                        "discharges from full at two or more currents, as a charger logs "
                        "them — write the table beside --out as <name>_ocv.csv and the "
                        "'circuit:' block, and score the validation experiments' voltage")
    p.add_argument("--circuit-hysteresis", action="store_true",
                   help="also fit the hysteresis (γ, M) from the pulse test's current reversals")
    p.add_argument("--circuit-soc0", default="1.0",
                   help="state of charge at the start of the pulse test (default 1.0)")
    p.set_defaults(func=run_fit)


def _ids(text: str | None, option: str) -> list[str] | None:
    if text is None:
        return None
    ids = [s.strip() for s in text.split(",") if s.strip()]
    if not ids:
        raise InputError(f"{option}: expected comma-separated experiment ids, got {text!r}")
    return ids


def capacity_and_cutoff(args, experiments, result, cells: int):
    """The capacity the pack file carries and what it is: ``--capacity-mah`` (nominal,
    given) or the charge measured to the end of the lowest-power experiment (its
    cut-off); the cut-off per cell [V] the experiments end at (their lowest loaded cell
    voltage at the end), None without voltage. Returns (mAh, note, V)."""
    from planner.physics import limits as L

    by = {e.name: e for e in experiments}
    most = max(result.metrics, key=lambda m: m.final_charge_mah)
    measured = most.final_charge_mah
    e = by.get(most.experiment)
    cutoff = None
    if e is not None and e.voltage_v is not None:
        v = e.voltage_v[np.isfinite(e.voltage_v)] / cells
        # a cut-off only where the discharge ran down to it: the last voltage is the
        # lowest and well below the first
        if len(v) > 1 and v[-1] <= v.min() + 1e-9 and v[-1] < 0.85 * v[0] \
                and L.CELL_CUTOFF_MIN_V <= v[-1] <= L.CELL_CUTOFF_MAX_V:
            cutoff = round(float(v[-1]), 3)
    to = f"to the cut-off {cutoff:.2f} V/cell" if cutoff is not None else "to its end"
    found = (f"{measured:.0f} mAh measured {to}, the most any experiment drew "
             f"({most.experiment}, {most.mean_power_w:.1f} W)")
    if args.capacity_mah is not None:
        nominal = parse_float(args.capacity_mah, "--capacity-mah", 1.0, 1e7, "mAh")
        if measured > 2.0 * nominal:
            # a pack gives no more than its charge: twice the nominal drawn is another unit
            raise InputError(f"--capacity-mah {args.capacity_mah}: {nominal:g} mAh is less than "
                             f"half the {measured:.0f} mAh {most.experiment} drew: Ah? "
                             f"({nominal:g} Ah = {nominal * 1000:.0f} mAh)")
        return nominal, f"{nominal:.0f} mAh nominal (given); {found}", cutoff
    return measured, (f"{found}, written as the capacity (give --capacity-mah for the "
                      "nominal)"), cutoff


def check_split_names(records, train, validate) -> None:
    """``--train`` and ``--validate`` name experiments of the data: checked against every
    experiment of every file before any is prepared, so that a typo is named as such
    (not hidden behind another experiment's problem), with the full list."""
    ids = list(dict.fromkeys(str(x) for _, df in records for x in df["experiment"]))
    for option, names in (("--train", train), ("--validate", validate)):
        unknown = [n for n in (names or ()) if n not in ids]
        if unknown:
            shown = ", ".join(ids[:20]) + (f", … ({len(ids)} in all)" if len(ids) > 20 else "")
            raise InputError(f"{option}: no experiment named {', '.join(map(repr, unknown))} "
                             f"in {', '.join(src for src, _ in records)} (its experiments: "
                             f"{shown})")


def _cells_from_voltage(experiments) -> int:
    """Cells in series from the experiments' voltage
    (:func:`planner.physics.battery.cells.series_cells`)."""
    voltages = [e.voltage_v for e in experiments if e.voltage_v is not None]
    if not voltages:
        raise InputError("--cells is required: no voltage_v in the data to detect the cell "
                         "count from (max voltage / 4.25 V, rounded up)")
    cells = series_cells(np.concatenate(voltages))
    if cells is None:
        raise InputError("cannot detect the cell count: voltage_v is never above 0 V; "
                         "give --cells")
    return cells


def _fit_circuit(args, mapping: dict) -> dict:
    """The ``circuit:`` block from a pulse test (:func:`identify.fit_pulse_test`)."""
    from planner.io import record
    from planner.identify import circuit_fit as identify
    from planner.physics.battery.ocv import lipo_ocv

    df = record.read_record(args.circuit, derive=False)
    missing = [c for c in ("voltage_v", "current_a") if c not in df.columns]
    if missing:
        raise InputError(f"{args.circuit}: a pulse test needs the column(s) "
                         f"{', '.join(missing)}")
    soc0 = parse_float(args.circuit_soc0, "--circuit-soc0", 0.0, 1.0)
    cells_p = int(mapping.get("cells_parallel", 1))
    fitted = identify.fit_pulse_test(
        df["time_s"].to_numpy(float), df["voltage_v"].to_numpy(float),
        df["current_a"].to_numpy(float), capacity_ah=float(mapping["capacity_mah"]) / 1000.0,
        soc0=soc0, cells_series=int(mapping["cells_series"]), cells_parallel=cells_p,
        ocv=lipo_ocv, hysteresis=bool(args.circuit_hysteresis))
    block = {k: (v if not isinstance(v, (np.floating, float)) else float(v))
             for k, v in fitted.params.items()}
    block["source"] = (f"fit-battery --circuit on {args.circuit} (pulse edges and "
                       f"relaxations; LiPo OCV of Chen and Rincón-Mora 2006)")
    print("circuit (per cell): " + ", ".join(
        f"{k} {v:.4g} ± {fitted.stderr[k]:.2g}" for k, v in fitted.params.items()
        if isinstance(v, float) and k in fitted.stderr))
    return block


def _fit_circuit_rates(mapping: dict, experiments, result: fit.IntegralFit,
                       out: Path) -> tuple[dict, list[dict]]:
    """The ``circuit:`` block from constant-current discharges at several rates
    (:func:`identify.fit_rate_discharges`) and its score on the validation experiments."""
    from planner.identify import circuit_fit as identify
    from planner.physics.battery.circuit import CircuitParameters, simulate
    from planner.io.tables import write_ocv_csv

    ns, npar = int(mapping["cells_series"]), int(mapping.get("cells_parallel", 1))
    by_name = {e.name: e for e in experiments}

    def arrays(name):
        e = by_name[name]
        for col, values in (("voltage_v", e.voltage_v), ("current_a", e.current_a)):
            if values is None or not np.all(np.isfinite(values)):
                raise InputError(f"{e.source or 'data'}: experiment '{name}': --circuit-rates "
                                 f"needs column '{col}' with a value in every row")
        return e.time_s, e.voltage_v, e.current_a

    train = list(result.train)
    table, fitted = identify.fit_rate_discharges(
        [(t, v / ns, i / npar) for t, v, i in map(arrays, train)], names=train)
    r0, se = fitted.params["r0_ohm"], fitted.stderr["r0_ohm"]
    ocv_path = out.with_name(out.stem + "_ocv.csv")
    try:
        write_ocv_csv(ocv_path, table)
    except OSError as exc:
        raise InputError(f"{ocv_path}: cannot write ({exc.strerror})") from None
    block = {"capacity_ah": float(fitted.params["capacity_ah"]), "r0_ohm": float(r0),
             "ocv_csv": ocv_path.name,
             "source": (f"fit-battery --circuit-rates: OCV(SoC) and DC resistance "
                        f"({1000 * r0:.3g} ± {1000 * se:.2g} mΩ per cell) from the "
                        f"constant-current discharges {', '.join(train)}")}
    print(f"circuit (per cell): DC resistance {1000 * r0:.3f} ± {1000 * se:.2g} mΩ, capacity "
          f"{fitted.params['capacity_ah']:.4g} Ah, OCV {table.ocv_v[0]:.3f}–"
          f"{table.ocv_v[-1]:.3f} V over SoC {table.soc[0]:.2f}–{table.soc[-1]:.2f} "
          f"(wrote {ocv_path}); voltage RMSE on the training data "
          f"{1000 * fitted.rmse:.1f} mV")
    fitted_pack = CircuitParameters(capacity_ah=block["capacity_ah"], r0_ohm=r0, ocv=table,
                                    cells_series=ns, cells_parallel=npar)
    # baseline: what check assumes without the table, the LiPo OCV (with the same R)
    baseline = CircuitParameters(capacity_ah=block["capacity_ah"], r0_ohm=r0,
                                 cells_series=ns, cells_parallel=npar)
    scores = []
    for name in result.validate:
        t, v, i = arrays(name)
        row = {"experiment": name, "current_a": identify.current_level(i),
               "voltage_rmse_mv": 1000 * float(np.sqrt(np.mean(
                   (simulate(fitted_pack, t, current_a=i).voltage_v - v) ** 2)))}
        row["lipo_ocv_voltage_rmse_mv"] = 1000 * float(np.sqrt(np.mean(
            (simulate(baseline, t, current_a=i).voltage_v - v) ** 2)))
        scores.append(row)
    if scores:
        w = name_width([row["experiment"] for row in scores], "validation (circuit)")
        print(f"{'validation (circuit)':<{w}} {'current [A]':>11} {'voltage RMSE [mV]':>17} "
              f"{'with the LiPo OCV [mV]':>22}")
        for row in scores:
            print(f"{row['experiment']:<{w}} {row['current_a']:>11.3g} "
                  f"{row['voltage_rmse_mv']:>17.1f} {row['lipo_ocv_voltage_rmse_mv']:>22.1f}")
    return block, scores


def _records(args) -> list:
    """The data to fit: flight-record CSV files as they are; through ``--map`` (and any
    log format) with ``--map`` or ``--in-flight``, each experiment then cut to its span
    in the air with ``--in-flight``."""
    if not (args.map or args.in_flight):
        return fit.load_records(args.data)
    from planner.identify.backtest import in_flight
    from planner.io.flightdata import load_flight_data

    data, _ = load_flight_data(args.data, column_map=args.map)
    if args.in_flight:
        data, left = in_flight(data)
        for e in left:
            print(f"note: left out of the fit: experiment {e}: never airborne (no flight "
                  "between spin-up and touch-down)")
        if data.empty:
            raise InputError(f"{', '.join(map(str, args.data))}: no experiment was airborne "
                             "(--in-flight)")
    return [(", ".join(map(str, args.data)), data)]


def run_fit(args) -> int:
    """``endurance fit-battery``: fit the integral model (δ, ε, β) to the training discharges,
    validate it on the others and write the pack file; returns 0, or 1 when the fit is a
    misfit (``fit_status``)."""
    out, plot_out, json_out = outputs(args, "out", "plot", "json")
    beta = parse_float(args.fix_beta, "--fix-beta", 0.5, 1.5) if args.fix_beta else None
    mass_kg = (parse_float(args.mass_kg, "--mass-kg", 1e-3, 1000.0, "kg")
               if args.mass_kg is not None else None)
    train, validate = _ids(args.train, "--train"), _ids(args.validate, "--validate")
    base_raw = _base_pack(args, out)
    # with both lists given, the experiments in neither are left out unchecked
    chosen = set(train) | set(validate) if train and validate else None
    records = _records(args)
    check_split_names(records, train, validate)
    short: list[str] = []
    experiments = fit.prepare_experiments(records, only=chosen, short=short,
                                          named=set(train or ()) | set(validate or ()))
    for why in short:
        print(f"note: left out of the fit: {why}")
    result = fit.fit_integral(experiments, beta=beta, train=train, validate=validate)

    data_names = ", ".join(str(d) for d in args.data)
    source = (f"fit-battery on {data_names}; train: {', '.join(result.train)}; validate: "
              f"{', '.join(result.validate) or 'none'}"
              + (f"; beta held at {beta:g}" if beta is not None else ""))
    model = IntegralModel(result.delta, result.epsilon, result.beta,
                          covariance=result.covariance,
                          charge_error_sd=result.charge_error_sd)
    dropped, scale_note, capacity_note = [], None, None
    if base_raw is not None:
        mapping = base_raw
        old = mapping.get("model") or {}
        dropped = [k for k in old if k not in ("delta", "epsilon", "beta", "source")]
        mapping["model"] = model.to_mapping()
    else:
        mapping, capacity_note, scale_note = _new_pack(args, experiments, result, model,
                                                       mass_kg)
        source += "".join(f"; {n}" for n in (scale_note, capacity_note) if n)
    mapping["source"] = source
    mapping["fit_status"] = result.fit_status
    if args.circuit and args.circuit_rates:
        raise InputError("give --circuit (a pulse test) or --circuit-rates (discharges at "
                         "several currents), not both")
    circuit_scores = None
    if args.circuit:
        mapping["circuit"] = _fit_circuit(args, mapping)
    elif args.circuit_rates:
        mapping["circuit"], circuit_scores = _fit_circuit_rates(mapping, experiments, result,
                                                                Path(out))
    battery_from_mapping(mapping, str(out))  # what we write must load back
    header = (f"# written by endurance fit-battery: integral model fitted to {data_names}\n"
              f"# stderr: delta ±{result.stderr['delta']:.4g}, epsilon "
              f"±{result.stderr['epsilon']:.3g}, beta ±{result.stderr['beta']:.3g}\n")
    files.write_text(out, header + yaml.safe_dump(mapping, sort_keys=False, allow_unicode=True),
                     "--out")

    print(render_fit(result))
    for label, note in (("capacity ", capacity_note), ("pack     ", scale_note)):
        if note:
            print(f"{label} {note}")
    print(f"fit_status: {result.fit_status}")
    if dropped:
        print(f"note: model keys {', '.join(dropped)} of {args.battery} were dropped: they "
              "belong to the old δ, ε, β")
    print(f"wrote {out}")
    _fit_outputs(args, result, experiments, mapping, circuit_scores, json_out, plot_out)
    # a parameter on its bound or outside its physical range: written as such, exit 1
    return 0 if result.fit_status == "ok" else 1


def _base_pack(args, out) -> dict | None:
    """The pack file ``--battery`` the fitted model is written into a copy of (its
    mapping, paths relative to ``out``'s folder), after checking that none of the options
    it would silently override is given; None without ``--battery``, when ``--name`` and
    ``--mass-kg`` are required instead."""
    if not args.battery:
        missing = [o for o, v in (("--name", args.name), ("--mass-kg", args.mass_kg)) if v is None]
        if missing:
            raise InputError(f"{' and '.join(missing)} required without --battery "
                             "(the pack YAML needs name and mass_kg)")
        return None
    # the fitted model goes into a copy of the pack file, which keeps its own name,
    # cells, capacity, mass and chemistry: those options would be silently dropped
    given = [(o, v, k) for o, v, k in (
        ("--name", args.name, "name"), ("--cells", args.cells, "cells_series"),
        ("--mass-kg", args.mass_kg, "mass_kg"),
        ("--capacity-mah", args.capacity_mah, "capacity_mah"),
        ("--chemistry", args.chemistry, "chemistry")) if v is not None]
    if given:
        option, value, key = given[0]
        raise InputError(f"{option} {value}: not used with --battery {args.battery} (the "
                         "fitted model is written into a copy of that pack file, which "
                         f"keeps its own {key}): leave out {option} or --battery")
    load_battery(args.battery)  # validate first: bad base file -> one-line error
    return dict(read_definition(args.battery, to_folder=Path(out).parent))


def _new_pack(args, experiments, result, model, mass_kg):
    """The pack file written without ``--battery``: cells (given, else from the voltage),
    the capacity and cut-off, the model scaled from a cell to ``S×P`` when asked; and the
    notes on the capacity and the scaling."""
    cells, parallel = parse_cells(args.cells)
    cells = cells or _cells_from_voltage(experiments)
    capacity, capacity_note, cutoff = capacity_and_cutoff(args, experiments, result, cells)
    model_map, scale_note = model.to_mapping(), None
    if parallel is not None:
        scaled = scale_model(model_map, cells, parallel)
        scale_note = describe(cells, parallel, model.delta, scaled["delta"], capacity)
        model_map, capacity = scaled, capacity * parallel
    check_pack_mass(mass_kg, args.mass_kg, cells, capacity)
    mapping = {"name": args.name, "cells_series": cells,
               "capacity_mah": float(round(capacity)), "mass_kg": mass_kg,
               "model": model_map}
    if parallel is not None:
        mapping["cells_parallel"] = parallel
    if cutoff is not None:
        mapping["cell_voltage_empty_v"] = cutoff
    if args.chemistry is not None:
        mapping["chemistry"] = args.chemistry
    return mapping, capacity_note, scale_note


def _fit_outputs(args, result, experiments, mapping, circuit_scores, json_out, plot_out):
    """``--json`` (the fit, its metrics and the pack written) and ``--plot`` (its pages)."""
    if json_out:
        data = result.to_dict()
        data["metrics"] = [m.to_dict() for m in result.metrics]
        data["data"] = [str(d) for d in args.data]
        data["pack"] = mapping
        if circuit_scores is not None:
            data["circuit_validation"] = circuit_scores
        write_json(data, json_out)
    if plot_out:
        from planner.cli.plots.battery import save_fit_plot

        written = save_fit_plot(experiments, result, plot_out)
        if len(written) > 1:
            print(f"wrote     {', '.join(map(str, written))} ({len(written)} pages of at "
                  "most 8 experiments)")


#: Nominal cell voltage of the specific-energy check of ``--mass-kg`` (LiPo 3.7 V,
#: Li-ion 3.6 V: the check's range is far wider than their difference). [V]
CHECK_CELL_VOLTAGE_V = 3.7


#: Least share of the pack's charge a discharge of the training data is taken to have
#: drawn when ``--mass-kg`` is checked against it: the charge drawn is a lower bound of
#: the capacity (a short flight draws a tenth of it), so a low specific energy refuses the
#: mass only below this share of the range's floor. [unitless]
DRAWN_SHARE_FLOOR = 0.05


def check_pack_mass(mass_kg: float, text: str, cells: int, capacity_mah: float) -> None:
    """``--mass-kg`` against the pack's nominal energy (cells × 3.7 V × the charge its
    discharges drew): a specific energy above
    :data:`~planner.physics.limits.PACK_SPECIFIC_ENERGY_MAX_WH_KG`, or below
    :data:`DRAWN_SHARE_FLOOR` × :data:`~planner.physics.limits.PACK_SPECIFIC_ENERGY_MIN_WH_KG`
    (the charge drawn may be a small part of the capacity), is a mass in another unit."""
    from planner.physics import limits as L

    if not (capacity_mah > 0 and mass_kg):
        return
    energy_wh = cells * CHECK_CELL_VOLTAGE_V * capacity_mah / 1000.0
    spec = energy_wh / mass_kg
    low, high = L.PACK_SPECIFIC_ENERGY_MIN_WH_KG, L.PACK_SPECIFIC_ENERGY_MAX_WH_KG
    if DRAWN_SHARE_FLOOR * low <= spec <= high:
        return
    hint = "; expected kg"
    if spec < low and DRAWN_SHARE_FLOOR * low <= spec * 1000.0 <= high:
        hint = f": grams? ({mass_kg:g} g = {mass_kg / 1000:g} kg, {spec * 1000:.0f} Wh/kg)"
    elif spec > high and low <= spec / 1000.0 <= high:
        hint = f": tonnes? ({spec / 1000:.0f} Wh/kg in tonnes)"
    raise InputError(f"--mass-kg {text}: {mass_kg:g} kg for a {cells}S pack of "
                     f"{capacity_mah:.0f} mAh ({energy_wh:.0f} Wh) is {spec:.3g} Wh/kg, "
                     f"outside the [{low:g}, {high:g}] Wh/kg of battery packs{hint}")


def render_fit(result: fit.IntegralFit) -> str:
    """Per-experiment table and the parameters with their standard errors."""
    w = name_width([m.experiment for m in result.metrics], "experiment")
    lines = [(f"{'experiment':<{w}} {'split':<9} {'mean P [W]':>10} {'duration [s]':>12} "
             f"{'RMSE [mAh]':>10} {'final error [%]':>15} {'time error [s]':>14}")]
    for m in result.metrics:
        lines.append(f"{m.experiment:<{w}} {m.split:<9} {fmt(m.mean_power_w, 1, 10)} "
                     f"{fmt(m.duration_s, 0, 12)} {fmt(m.rmse_mah, 2, 10)} "
                     f"{fmt(m.final_error_pct, 3, 15)} {fmt(m.time_error_s, 1, 14)}")
    lines.append("")
    se = result.stderr
    for key, digits in (("delta", 4), ("epsilon", 5), ("beta", 5)):
        if key in result.fixed:
            lines.append(f"{key:<8}= {result.parameters[key]:.{digits}f} (held)")
        else:
            lines.append(f"{key:<8}= {result.parameters[key]:.{digits}f} ± {se[key]:.2g}")
    iid = result.stderr_iid
    ratio = max((se[k] / iid[k] for k in ("delta", "epsilon", "beta")
                 if k not in result.fixed and iid[k] > 0 and math.isfinite(se[k])),
                default=float("nan"))
    lines.append(f"standard errors: {result.stderr_method} for the autocorrelated samples "
                 f"(lag-1 ρ = {result.autocorrelation:.4f}; up to ×{ratio:.3g} the i.i.d. "
                 f"value; {result.samples} training samples)")
    if result.poorly_determined:
        lines.append(f"POORLY DETERMINED: {', '.join(result.poorly_determined)}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- design

def _register_design(sub) -> None:
    p = sub.add_parser("design", help="design discharge tests: two-step or APRBS",
                       description="Design discharge tests for identifying the integral "
                                   "model ([UAV23] eq. 25–28 two-step tests; APRBS signals).")
    kinds = p.add_subparsers(dest="design_kind", metavar="KIND", parser_class=type(p),
                             required=True)
    t = kinds.add_parser("two-step", help="durations of a two-step constant-power test",
                         description="t1 = δ P2^ε C0^β / (k + (P2/P1)^ε), t2 = k t1: the test "
                                     "that draws C0 under the integral model.")
    t.add_argument("--p1", required=True, help="power of the first step [W]")
    t.add_argument("--p2", required=True, help="power of the second step [W]")
    t.add_argument("--k", required=True, help="ratio t2/t1")
    t.add_argument("--capacity-mah", required=True, help="charge C0 the test draws [mAh]")
    t.add_argument("--battery", help="pack YAML whose model to use")
    t.add_argument("--cells", help="cells in series for the literature model "
                                   "(without --battery)")
    t.add_argument("--out", help="write the power schedule CSV (time_s,power_w)")
    t.set_defaults(func=run_two_step)

    a = kinds.add_parser("aprbs", help="APRBS power schedule for a programmable load",
                         description="Random power levels, each held U[min, max] s, until the "
                                     "minimum duration; written as time_s,power_w CSV.")
    a.add_argument("--levels", default="50,75,100,125", help="power levels [W] "
                                                             "(default 50,75,100,125)")
    a.add_argument("--hold", default="30,300", help="MIN,MAX hold time [s] (default 30,300)")
    a.add_argument("--min-duration", default="3500", help="minimum total duration [s] "
                                                          "(default 3500)")
    a.add_argument("--seed", help="random seed (integer) for a reproducible schedule")
    a.add_argument("--resolution", default="1", help="hold times in multiples of this [s]")
    a.add_argument("--out", required=True, help="schedule CSV to write")
    a.add_argument("--battery", help="pack YAML: also report the charge the model draws")
    a.set_defaults(func=run_aprbs)


def _floats(text: str, option: str, count: int | None = None, low: float = 0.0) -> list[float]:
    parts = [s for s in text.split(",") if s.strip()]
    values = [parse_float(s.strip(), option, low, 1e9) for s in parts]
    if not values or (count is not None and len(values) != count):
        want = f"{count} " if count else ""
        raise InputError(f"{option}: expected {want}comma-separated numbers, got {text!r}")
    return values


def _duration(seconds: float) -> str:
    h, rest = divmod(seconds, 3600.0)
    return f"{int(h)} h {rest / 60:.1f} min" if h else f"{seconds / 60:.1f} min"


def _model_for(args) -> tuple[IntegralModel, str]:
    if args.battery:
        pack = load_battery(args.battery)
        what = "literature δ₀(N), ε₀(N)" if pack.model.literature else "fitted"
        return pack.model, f"{args.battery} ({what})"
    if args.cells:
        cells = parse_int(args.cells, "--cells", 1, 40)
        return IntegralModel.from_literature(cells), f"literature values for {cells} cells"
    raise InputError("give --battery B.yaml (its model) or --cells N (literature model)")


def run_two_step(args) -> int:
    """``endurance design two-step``: the step durations t1, t2 [s] of a two-step
    constant-power test that draws the charge C0 [mAh] under the integral model
    ([UAV23] eq. 25–28), and its power schedule (time [s], power [W]) if asked; returns 0."""
    out = output_path(args.out, "--out")
    p1 = parse_float(args.p1, "--p1", 1e-3, 1e6)
    p2 = parse_float(args.p2, "--p2", 1e-3, 1e6)
    k = parse_float(args.k, "--k", 1e-6, 1e6)
    cap = parse_float(args.capacity_mah, "--capacity-mah", 1e-3, 1e8)
    model, what = _model_for(args)
    test = design.two_step(p1, p2, k, cap * AS_PER_MAH, model.delta, model.epsilon,
                           model.beta)
    print(f"two-step test drawing C0 = {cap:g} mAh (model: {what}; δ = {model.delta:.4g}, "
          f"ε = {model.epsilon:.4g}, β = {model.beta:.4g})")
    print(f"  step 1: {p1:g} W for t1 = {test.t1_s:.0f} s ({_duration(test.t1_s)})")
    print(f"  step 2: {p2:g} W for t2 = {test.t2_s:.0f} s ({_duration(test.t2_s)})")
    print(f"  total:  {test.total_s:.0f} s ({_duration(test.total_s)})")
    if out:
        write_schedule(test.schedule(), out,
                              comment=f"two-step test P1={p1:g} W, P2={p2:g} W, k={k:g}, "
                                      f"C0={cap:g} mAh; model {what}", option="--out")
        print(f"wrote {out}")
    return 0


#: Most steps an APRBS schedule may have (a programmable load's table is far shorter).
MAX_APRBS_STEPS = 100_000


def run_aprbs(args) -> int:
    """``endurance design aprbs``: an APRBS power schedule (random levels [W], each held a
    random time [s]) for a programmable load, written as CSV; returns 0."""
    out = output_path(args.out, "--out")
    levels = _floats(args.levels, "--levels")
    if len(set(levels)) < 2 or min(levels) <= 0:
        raise InputError(f"--levels: expected at least two different powers > 0 W, "
                         f"got {args.levels!r}")
    lo, hi = _floats(args.hold, "--hold", 2)
    if not 0 < lo <= hi:
        raise InputError(f"--hold: expected MIN,MAX with 0 < MIN <= MAX seconds, "
                         f"got {args.hold!r}")
    min_duration = parse_float(args.min_duration, "--min-duration", 1e-3, 1e7)
    resolution = parse_float(args.resolution, "--resolution", 1e-3, 1e4)
    if math.floor(hi / resolution + 1e-9) < max(1, math.ceil(lo / resolution - 1e-9)):
        raise InputError(f"--resolution {args.resolution}: no multiple of it (at least one) "
                         f"lies in --hold {args.hold}")
    if min_duration / max(lo, resolution) > MAX_APRBS_STEPS:
        raise InputError(f"--hold {args.hold}: holds this short make more than "
                         f"{MAX_APRBS_STEPS:,} steps in {min_duration:g} s; expected longer "
                         "holds ([UAV23] holds 30–300 s)")
    if args.seed is not None:
        seed = parse_int(args.seed, "--seed", 0, 2**32 - 1)
    else:
        seed = int(np.random.SeedSequence().entropy % 2**31)
    schedule = design.aprbs(levels, (lo, hi), min_duration, seed, resolution_s=resolution)
    total = float(schedule["duration_s"].sum())
    mean_p = float((schedule["duration_s"] * schedule["power_w"]).sum() / total)
    write_schedule(schedule, out, comment=(
        f"APRBS levels_w={','.join(f'{v:g}' for v in levels)} hold_s={lo:g}..{hi:g} "
        f"min_duration_s={min_duration:g} seed={seed}"), option="--out")
    print(f"APRBS schedule: {len(schedule)} steps, {total:.0f} s ({_duration(total)}), "
          f"mean power {mean_p:.1f} W, seed {seed}")
    for level in sorted(set(levels)):
        share = schedule.loc[schedule["power_w"] == level, "duration_s"].sum() / total
        print(f"  {level:g} W: {100 * share:.0f} % of the time")
    if args.battery:
        model, what = _model_for(args)
        t = np.arange(0.0, total + 0.5, 1.0)
        c = integral.charge(t, design.sample_schedule(schedule, t), model.delta,
                            model.epsilon, model.beta)
        print(f"  the model ({what}) draws {c[-1] / AS_PER_MAH:.0f} mAh over it")
    print(f"wrote {out}")
    return 0


# --------------------------------------------------------------------------- pulse-resistance

def _register_pulse(sub) -> None:
    p = sub.add_parser("pulse-resistance", help="internal resistance from a pulse test "
                                                "(amended VDA)",
                       description="R = ΔV/ΔI at each current switch-off of a pulse test "
                                   "(seed §3.1): per pulse, per pulse current, and their mean "
                                   "with a Student-t confidence interval.")
    p.add_argument("data", help="CSV with time_s, voltage_v, current_a")
    p.add_argument("--threshold", default=str(vda.ON_THRESHOLD_A),
                   help=f"|current| that counts as on [A] (default {vda.ON_THRESHOLD_A})")
    p.add_argument("--by", choices=("level", "pulse"), default="level",
                   help="statistics over pulse currents (default) or every pulse")
    add_options(p, battery="pack YAML to update with internal_resistance_ohm",
                out="write the updated pack YAML here (needs --battery)", json=True)
    p.add_argument("--experiment", metavar="ID",
                   help="the pulse test to read when the file holds several experiments")
    p.set_defaults(func=run_pulse)


def one_experiment(df, path, chosen: str | None):
    """The samples of one experiment: a pulse test is one time series. A file of several
    experiments needs ``--experiment``, and the message lists them."""
    if "experiment" not in df.columns:
        if chosen is not None:
            raise InputError(f"--experiment {chosen}: {path} has no 'experiment' column "
                             "(it holds one test)")
        return df
    ids = list(dict.fromkeys(df["experiment"].astype(str)))
    if chosen is None:
        if len(ids) == 1:
            return df
        shown = ", ".join(ids[:12]) + (f", … ({len(ids)} in all)" if len(ids) > 12 else "")
        raise InputError(f"{path}: {len(ids)} experiments: pulse-resistance reads one pulse "
                         f"test; give --experiment ID, one of {shown}")
    if chosen not in ids:
        raise InputError(f"--experiment {chosen}: not in {path} (its experiments: "
                         f"{', '.join(ids[:12])}{', …' if len(ids) > 12 else ''})")
    return df[df["experiment"].astype(str) == chosen].reset_index(drop=True)


def run_pulse(args) -> int:
    """``endurance pulse-resistance``: the internal resistance [Ω] of a pulse test, per pulse
    and state of charge; returns 0."""
    from planner.io import record as rec

    out = output_path(args.out, "--out")
    json_out = output_path(args.json, "--json")
    if out and not args.battery:
        raise InputError("--out needs --battery (the pack whose resistance to update)")
    threshold = parse_float(args.threshold, "--threshold", 1e-6, 1e4)
    df = one_experiment(rec.read_record(args.data, derive=False), args.data,
                        args.experiment)
    missing = [c for c in ("voltage_v", "current_a") if c not in df.columns]
    if missing:
        raise InputError(f"{args.data}: missing column '{missing[0]}' (a pulse test needs "
                         "time_s, voltage_v and current_a)")
    res = vda.pulse_resistance(df["time_s"], df["voltage_v"], df["current_a"],
                               threshold_a=threshold, by=args.by, source=str(args.data))
    print(f"{'time [s]':>10} {'kind':<9} {'I [A]':>8} {'ΔV [mV]':>9} {'R [mΩ]':>8}")
    for pulse in res.pulses:
        print(f"{pulse.time_s:10.1f} {pulse.kind:<9} {pulse.current_a:8.3f} "
              f"{1e3 * pulse.delta_v:9.2f} {1e3 * pulse.resistance_ohm:8.3f}")
    print()
    for amps, ohms in zip(res.levels_a, res.level_resistance_ohm):
        print(f"  {amps:6.2f} A: R = {1e3 * ohms:.2f} mΩ")
    unit = "pulse currents" if res.by == "level" else "pulses"
    ci = (f"{100 * res.confidence:.0f} % CI {1e3 * res.ci_low_ohm:.2f}–"
          f"{1e3 * res.ci_high_ohm:.2f} mΩ" if res.n > 1 else "no CI from one value")
    print(f"R = {1e3 * res.mean_ohm:.2f} mΩ ({ci}, n = {res.n} {unit}), "
          f"RMSE {1e3 * res.rmse_ohm:.2f} mΩ")
    capacity = load_battery(args.battery).capacity_mah if args.battery else None
    blocks = vda.resistance_by_charge(res, df["time_s"], df["current_a"],
                                      capacity_mah=capacity)
    if len(blocks) > 1:
        print("R against the charge drawn before the pulses"
              + (" and the state of charge:" if capacity else
                 " (--battery gives the state of charge):"))
        for b in blocks:
            soc = f"  SoC {100 * b['soc']:5.1f} %" if b["soc"] is not None else ""
            print(f"  {b['drawn_mah']:8.0f} mAh drawn{soc}: R = "
                  f"{1e3 * b['resistance_ohm']:.2f} mΩ ({b['pulses']} pulses)")
    if json_out:
        write_json(res.to_dict() | {"data": str(args.data)}, json_out)
    if out:
        load_battery(args.battery)
        mapping = dict(read_definition(args.battery, to_folder=Path(out).parent))
        mapping["internal_resistance_ohm"] = round(float(res.mean_ohm), 6)
        battery_from_mapping(mapping, str(out))
        files.write_text(out, f"# internal_resistance_ohm from endurance pulse-resistance on "
                              f"{args.data}\n"
                         + yaml.safe_dump(mapping, sort_keys=False, allow_unicode=True), "--out")
        print(f"wrote {out}")
    return 0


# --------------------------------------------------------------------------- bench

#: Decimals the bench's CSV keeps per column (below the sensors' noise).
_BENCH_DECIMALS = {"time_s": 3, "voltage_v": 4, "current_a": 4, "power_w": 4,
                   "consumed_mah": 4}


def _register_bench(sub) -> None:
    from planner.identify import campaign

    p = sub.add_parser(
        "bench", help="virtual test bench: run a named discharge campaign (and the seed "
                      "paper's cross-validation)",
        description="Run a named campaign of constant-power, two-step and APRBS discharges on "
                    "the virtual bench (equivalent-circuit LiPo pack with a diffusion-limited "
                    "capacity, constant-power load, 1 Hz logging with seeded measurement "
                    "noise, stop at the loaded cut-off) and write it as a flight-record CSV. "
                    "With --report, fit [UAV23]'s m_const, m_2step and m_APRBS (β held "
                    "at 0.9648 and free) and print their cross-validation table (seed "
                    "Fig. 12–13).")
    p.add_argument("--campaign", required=True, choices=list(campaign.CAMPAIGNS),
                   help="seed: every test (constant 50/75/100/125 W, four two-step, three "
                        "APRBS); or only constant, two-step or aprbs")
    p.add_argument("--out", help="flight-record CSV to write")
    p.add_argument("--report", action="store_true",
                   help="fit the models and print the cross-validation table")
    p.add_argument("--json", help="write the report as JSON to this file (with --report)")
    p.add_argument("--battery", help="pack YAML to put on the bench (default: the seed's "
                                     "Multistar 10 Ah 4S)")
    p.add_argument("--seed", default="0", help="seed of the noise and the APRBS schedules "
                                               "(integer, default 0)")
    p.add_argument("--noise-v", default="0.01", help="voltage noise, 1 σ [V] (default 0.01)")
    p.add_argument("--noise-a", default="0.05", help="current noise, 1 σ [A] (default 0.05)")
    p.add_argument("--temperature", default="25", help="cell temperature [°C] (default 25)")
    p.set_defaults(func=run_bench)


def run_bench(args) -> int:
    """``endurance bench``: run a named discharge campaign on the virtual bench and write it
    as a flight record (with ``--report``, the cross-validation of the integral models);
    returns 0."""
    from planner.io import record
    from planner.identify import bench, campaign
    from planner.physics.battery.thermal import T_RANGE_C

    out = output_path(args.out, "--out")
    json_out = output_path(args.json, "--json")
    if not out and not args.report:
        raise InputError("bench: give --out CSV and/or --report")
    if json_out and not args.report:
        raise InputError("--json needs --report")
    try:
        seed = int(args.seed)
    except ValueError:
        raise InputError(f"--seed: expected a non-negative integer, got {args.seed!r}") from None
    if seed < 0:
        raise InputError(f"--seed: expected a non-negative integer, got {args.seed!r}")
    noise = bench.BenchNoise(parse_float(args.noise_v, "--noise-v", 0.0, 10.0),
                             parse_float(args.noise_a, "--noise-a", 0.0, 100.0))
    temperature = parse_float(args.temperature, "--temperature", *T_RANGE_C)
    if args.battery:
        battery = load_battery(args.battery)
        try:
            pack = bench.BenchPack.from_battery(battery)
        except InputError:
            raise
        except ValueError as exc:
            raise InputError(f"{args.battery}: {exc}") from None
    else:
        pack = bench.seed_pack()
    try:
        records, info = campaign.run_campaign(pack, campaign=args.campaign, seed=seed,
                                              noise=noise, temperature_c=temperature,
                                              return_info=True)
    except ValueError as exc:  # a pack the campaign's powers cannot test
        raise InputError(f"{args.battery or 'seed pack'}: cannot run the '{args.campaign}' "
                         f"campaign on this pack ({exc}); expected a pack of the size the "
                         "campaign's powers are designed for") from None
    # what is written is what is fitted: fit-battery on the CSV gives the same numbers
    records = records.round(_BENCH_DECIMALS)
    print(f"virtual bench: {pack.name}, {pack.circuit.cells_series}S, "
          f"{pack.capacity_as / AS_PER_MAH:.0f} mAh, R0 {1e3 * pack.r_pack_ohm:.2f} mΩ, "
          f"cut-off {pack.v_cutoff_cell:g} V/cell, {temperature:g} °C; campaign "
          f"'{args.campaign}', seed {seed}")
    print(f"{'experiment':<24} {'kind':<9} {'duration [s]':>12} {'mean P [W]':>10} "
          f"{'drawn [mAh]':>11}  ended at")
    for row in info.itertuples():
        sub = records[records["experiment"] == row.experiment]
        t, p = sub["time_s"].to_numpy(), sub["power_w"].to_numpy()
        print(f"{row.experiment:<24} {row.kind:<9} {row.duration_s:12.0f} "
              f"{np.trapezoid(p, t) / t[-1]:10.1f} {row.charge_mah:11.0f}  "
              f"{'cut-off' if row.tripped else 'end of schedule'}")
    if out:
        record.write_record(records, out, option="--out")
        print(f"wrote {out} ({len(records)} samples)")
    if args.report:
        report = campaign.cross_validate(records)
        print()
        print(campaign.render_report(report), end="")
        if json_out:
            write_json(campaign.report_to_dict(report) | {
                "campaign": args.campaign, "seed": seed, "pack": pack.name,
                "noise": {"voltage_v": noise.voltage_v, "current_a": noise.current_a},
                "temperature_c": temperature}, json_out)
    return 0
