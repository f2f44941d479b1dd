"""``fit-aircraft`` on a fixed wing: the energy-rate fit's report lines and its figure."""

from __future__ import annotations

import math

import numpy as np

from planner.cli.commands.common import fmt

_UNITS = {"system_power_w": "W"}


def render(r: dict, mass: float) -> str:
    """The text report of :func:`planner.identify.fixed_wing_fit.fit_fixed_wing`."""
    lines = [f"Fixed-wing fit by the energy rate on {len(r['train_experiments'])} flight(s), "
             f"{r['samples']['train']} airborne samples, mass {mass:.3f} kg; validation: "
             f"{r['split']} ({r['samples']['validation']} samples)",
             f"  {r['method']}",
             f"  signals smoothed over {r['smoothing_s']:g} s (Gaussian sigma), "
             f"{r['trim_s']:g} s left out at each end of the airborne part"]
    for exp, src in r["sources"].items():
        w = src["window"]
        lines.append(f"  {exp}: airborne {w[0]:.1f}-{w[1]:.1f} s; {src['airspeed']}; "
                     f"density from {src['air density']}; climb rate: {src['climb rate']}")
    lines += ["", f"{'parameter':<19} {'start':>10} {'fitted':>10} {'± stderr':>10}"]
    for k, v in r["parameters"].items():
        flag = ""
        if k in r["at_bound"]:
            flag = "  ON ITS BOUND: misfit"
        elif k in r["poorly_determined"]:
            flag = "  poorly determined"
        lines.append(f"{k:<19} {fmt(r['start'][k], 4, 10)} {fmt(v, 4, 10)} "
                     f"{fmt(r['stderr'][k], 4, 10)} {_UNITS.get(k, ''):<2}{flag}")
    if r.get("oswald_efficiency") is not None:
        lines.append(f"{'oswald_efficiency':<19} {'':>10} "
                     f"{fmt(r['oswald_efficiency'], 3, 10)} "
                     f"{fmt(r['oswald_efficiency_stderr'], 3, 10)}    (aspect ratio "
                     f"{r['aspect_ratio']:.2f})")
    sp = r["system_power"]
    lines.append(f"system_power_w {sp['value_w']:.1f} W: {sp['source']}")
    lines.append(f"standard errors: {r['stderr_note']}; energy-rate residual RMS "
                 f"{r['energy_rate_rmse_w']:.1f} W (thrust power)")
    lines += ["", "plausibility against real airframes:"]
    for name, p in r["plausibility"].items():
        lo, hi = p["range"]
        lines.append(f"  {name} {p['value']:.3g}: {p['verdict']} the range {lo:g}-{hi:g} "
                     f"({p['source']})")
    for exp, g in r["glides"].items():
        if "drag_coefficient" not in g:
            lines.append(f"glides in {exp}: {g['samples']} motor-off sample(s), "
                         f"{g.get('core_samples', 0)} clear of the powered flight: too few to "
                         "read the polar from")
            continue
        lines.append(f"glides in {exp}: {g['duration_s']:.0f} s motor-off at "
                     f"{g['power_w']:.1f} W; from the energy rate alone "
                     f"({g['core_duration_s']:.0f} s at least {r['smoothing_s']:g} s inside "
                     f"the glides, {g['airspeed_ms']:.1f} m/s) C_L "
                     f"{g['lift_coefficient']:.2f}, C_D {g['drag_coefficient']:.4f} (L/D "
                     f"{g['lift_to_drag']:.1f}): {g['drag_vs_fitted_pct']:+.0f} % against the "
                     "fitted polar (a stopped or windmilling propeller's drag is in the "
                     "glides')")
    sh = r.get("shifted_polar")
    if sh and math.isfinite(sh["cl_min"]):
        lines.append(f"diagnostic, the least drag left free (C_D0 + K1 C_L + K C_L^2, not a "
                     f"planner polar): C_D,min {sh['cd_min']:.4f} at C_L {sh['cl_min']:.2f}, "
                     f"K {sh['k']:.4f}, eta {sh['efficiency']:.3f}, residual RMS "
                     f"{sh['energy_rate_rmse_w']:.1f} W")
    lines.append("")
    for split in ("train", "validation"):
        if split not in r:
            continue
        b, a, e = r[split]["before"], r[split]["after"], r[split]["after_energy_rate"]
        lines.append(f"{split:<10} battery power RMSE {b['rmse_w']:6.1f} -> {a['rmse_w']:6.1f} "
                     f"W, energy error {b['energy_error_pct']:+6.1f} -> "
                     f"{a['energy_error_pct']:+6.1f} % (steady model, as replay and check); "
                     f"with dV/dt {e['rmse_w']:.1f} W, {e['energy_error_pct']:+.1f} %")
    per = r.get("per_experiment_energy_error_pct", {}).get("after", {})
    for exp, v in per.items():
        if math.isfinite(v):
            lines.append(f"held-out {exp}: energy error after the fit {v:+.1f} %")
    lines.append("")
    if r["misfit"]:
        for m in r["misfit"]:
            extra = (f" = Oswald factor {m['oswald_unconstrained']:.2f}"
                     if "oswald_unconstrained" in m else "")
            lines.append(f"MISFIT: {m['parameter']} ended on its {m['bound']} bound "
                         f"{m['value']:.4g}; the data alone give {m['unconstrained']:.4g}"
                         f"{extra}. Likely cause: {m['cause']}")
    else:
        lines.append("fit_status: ok")
    return "\n".join(lines)


def curves(r: dict, mass: float, label: str, air_density: float | None = None) -> dict:
    """The fitted power curve (level, steady; at ``air_density``, default the flights'
    median) and polar, for :func:`planner.cli.plots.fixed_wing.save_fixed_wing_plot`."""
    from planner.identify.fixed_wing_fit import polar_curve, power_curve

    ac = r["aircraft"]
    t = r["samples_table"]
    rho = float(np.median(t["air_density"])) if air_density is None else air_density
    v = np.linspace(max(ac.min_airspeed_ms, 0.8 * float(t["airspeed_ms"].min())),
                    float(t["airspeed_ms"].max()), 80)
    cl = np.linspace(0.2, 1.8, 80)
    return {"label": label, "airspeed_ms": v, "power_w": power_curve(v, ac, mass, rho),
            "cl": cl, "cd": polar_curve(cl, ac.fixed_wing.cd0, ac.fixed_wing.k)}


def save_plot(r: dict, mass: float, path) -> None:
    """``fit-aircraft --plot``: the fitted curves over the corrected samples."""
    from planner.cli.plots.fixed_wing import save_fixed_wing_plot

    rho = float(np.median(r["samples_table"]["air_density"]))
    save_fixed_wing_plot(r["samples_table"], [curves(r, mass, "fitted (C_D0 + K C_L^2)")],
                         path, title=f"fit-aircraft: {', '.join(r['train_experiments'])} "
                                     + ("(misfit: " + ", ".join(r["at_bound"])
                                        + " on its bound)" if r["misfit"] else "(fit ok)"),
                         density_note=f"true airspeed, density {rho:.3f} kg/m³")
