"""Every plot of the commands, drawn on a shipped example: no legend covers a data line
or point (the legend's box against the drawn data, in display coordinates), and every axis
that has a label has tick labels."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PathCollection

from planner.cli.main import main
from planner.io import files

REPO = Path(__file__).resolve().parents[3]
SOLO = str(REPO / "aircraft/solo_survey.yaml")
QUAD7 = str(REPO / "aircraft/quad_7in.yaml")
SURVEY = str(REPO / "missions/survey_quad.yaml")
CATALOG = str(REPO / "aircraft/packs/catalog.yaml")


@pytest.fixture
def drawn(monkeypatch):
    """The figures the commands save, kept instead of written."""
    figs = []
    monkeypatch.setattr(files, "save_figure", lambda fig, path, *a, **k: figs.append(fig))
    return figs


def _display_points(artist, ax):
    """The drawn data of a line, line collection or scatter, in display coordinates
    (straight segments sampled densely), cut to the axes' box."""
    pts = []
    if isinstance(artist, LineCollection):
        for seg in artist.get_segments():
            pts.append(_densify(artist.get_transform().transform(seg), True))
    elif isinstance(artist, PathCollection):
        pts.append(artist.get_offset_transform().transform(artist.get_offsets()))
    else:
        xy = np.asarray(artist.get_xydata(), float)
        xy = xy[np.isfinite(xy).all(axis=1)]
        if len(xy):
            joined = artist.get_linestyle() not in ("None", "none", "", " ")
            pts.append(_densify(artist.get_transform().transform(xy), joined))
    if not pts:
        return np.empty((0, 2))
    p = np.concatenate(pts)
    box = ax.get_window_extent()
    inside = ((p[:, 0] >= box.x0) & (p[:, 0] <= box.x1) & (p[:, 1] >= box.y0)
              & (p[:, 1] <= box.y1))
    return p[inside]


def _densify(p, joined, n=40):
    if not joined or len(p) < 2:
        return p
    f = np.linspace(0.0, 1.0, n)[None, :, None]
    return (p[:-1, None, :] + f * (p[1:] - p[:-1])[:, None, :]).reshape(-1, 2)


def assert_legible(fig, what):
    FigureCanvasAgg(fig)
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    axes = [ax for ax in fig.axes if ax.get_visible() and ax.axison]
    for ax in axes:
        for axis, label in ((ax.xaxis, ax.get_xlabel()), (ax.yaxis, ax.get_ylabel())):
            if label and axis.get_label().get_visible():
                ticks = [t for t in axis.get_ticklabels() if t.get_visible() and t.get_text()]
                assert ticks, f"{what}: the axis '{label}' has no tick labels"
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    legends += list(fig.legends)
    for leg in legends:
        box = leg.get_window_extent(r).shrunk(0.98, 0.96)
        for ax in axes:
            artists = list(ax.lines) + [c for c in ax.collections
                                        if isinstance(c, (LineCollection, PathCollection))]
            for a in artists:
                if not a.get_visible():
                    continue
                p = _display_points(a, ax)
                hit = ((p[:, 0] > box.x0) & (p[:, 0] < box.x1) & (p[:, 1] > box.y0)
                       & (p[:, 1] < box.y1))
                assert not hit.any(), (f"{what}: the legend covers "
                                       f"'{a.get_label()}' of '{ax.get_title()}'")


COMMANDS = {
    "check GO": ["check", SURVEY, "--aircraft", SOLO, "--plot", "x.png", "--map", "m.png"],
    "check NO-GO": ["check", SURVEY, "--aircraft", QUAD7, "--plot", "x.png", "--map",
                    "m.png"],
    "check uncertainty": ["check", SURVEY, "--aircraft", SOLO, "--uncertainty",
                          "--samples", "60", "--plot", "x.png"],
    "select": ["select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--plot", "x.png",
               "--map", "m.png"],
    "sweep payload": ["sweep", "payload", "--aircraft", SOLO, "--plot", "x.png"],
    "sweep battery-mass": ["sweep", "battery-mass", "--aircraft", SOLO, "--plot", "x.png"],
    "replay": ["replay", str(REPO / "logs/sim_solo_calm.bin"),
               str(REPO / "logs/sim_solo_windy.ulg"), "--aircraft", SOLO, "--payload",
               "0.35", "--plot", "x.png"],
}


@pytest.mark.parametrize("name", list(COMMANDS))
def test_plots_of_the_commands_are_legible(name, drawn, tmp_path, capsys):
    argv = [str(tmp_path / a) if a.endswith(".png") else a for a in COMMANDS[name]]
    assert main(argv) in (0, 1), capsys.readouterr().err
    assert drawn, f"{name}: no figure drawn"
    for k, fig in enumerate(drawn):
        assert_legible(fig, f"{name} figure {k + 1}")


def test_check_plot_stops_at_empty_and_marks_where_the_charge_runs_out(drawn, tmp_path):
    """NO-GO on the small pack: the charge line never goes below empty, the run-out point
    is marked, and the upper (power) panel keeps its time tick labels."""
    main(["check", SURVEY, "--aircraft", QUAD7, "--plot", str(tmp_path / "x.png")])
    (fig,) = drawn
    ax1, ax2 = fig.axes[:2]
    (charge,) = [line for line in ax2.lines if line.get_label().startswith("remaining")]
    y = np.asarray(charge.get_ydata(), float)
    assert np.nanmin(y) >= 0 and np.isnan(y).any()
    assert any(line.get_label().startswith("usable charge runs out") for line in ax2.lines)
    assert ax2.get_ylim()[0] > -5
    assert_legible(fig, "check NO-GO")


def test_fit_battery_plot_is_legible_and_names_its_pages(drawn, tmp_path, capsys):
    from battery_generators import constant

    rng = np.random.default_rng(3)
    data = pd.concat([constant(f"run{k:02d}", p, 2.0e5 / p, rng=rng)
                      for k, p in enumerate(np.linspace(40, 130, 10))])
    path = tmp_path / "many.csv"
    data.to_csv(path, index=False)
    png = tmp_path / "fit.png"
    assert main(["fit-battery", str(path), "--out", str(tmp_path / "p.yaml"), "--name", "x",
                 "--cells", "4", "--mass-kg", "0.8", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert len(drawn) == 2 and str(tmp_path / "fit_page2.png") in out
    for k, fig in enumerate(drawn):
        assert_legible(fig, f"fit-battery page {k + 1}")


def fleet_table(n=40, outlier=1205.0):
    rng = np.random.default_rng(0)
    m = rng.uniform(2000, 4000, n)
    t = pd.DataFrame({"charge_mah": m, "predicted_charge_mah": m * rng.normal(1, 0.03, n),
                      "airborne_energy_wh": m / 70, "predicted_energy_wh": m / 70 * 1.02,
                      "charge_error_pct": rng.normal(0, 3, n),
                      "energy_error_pct": rng.normal(1, 3, n),
                      "pack_id": [f"P{k % 12:02d}" for k in range(n)],
                      "delta_scale": rng.uniform(1.0, 1.2, n), "log": [f"l{k}" for k in
                                                                       range(n)]})
    t.loc[7, "charge_error_pct"] = outlier
    return t


def test_fleet_plots_are_legible_clip_outliers_and_give_each_pack_its_colour():
    from planner.cli.plots import fleet

    ok = fleet_table()
    drift = fleet.plot_drift(ok, np.arange(len(ok), dtype=float))
    assert_legible(drift, "fleet drift")
    ax = drift.axes[0]
    assert ax.get_ylim()[1] < 100          # one 1205 % flight does not set the scale
    assert any("+1205 %" in t.get_text() for t in ax.texts)
    assert_legible(fleet.plot_accuracy(ok), "fleet accuracy")
    health = [SimpleNamespace(pack_id=f"P{k:02d}", scale_new=1.1, fade_per_cycle=0.002)
              for k in range(12)]
    packs = fleet.plot_packs(ok, health, 0.8)
    assert_legible(packs, "fleet packs")
    colours = {tuple(np.round(line.get_color(), 3)) for line in packs.axes[0].lines
               if line.get_label().startswith("pack ")}
    assert len(colours) == 12


def test_pareto_points_carry_the_pack_names(drawn, tmp_path):
    main(["select", SURVEY, "--aircraft", SOLO, "--packs", CATALOG, "--plot",
          str(tmp_path / "x.png")])
    (fig,) = drawn
    names = {t.get_text() for t in fig.axes[0].texts}
    assert any(n.startswith("3DR Solo Smart Battery") for n in names)
    assert len(names) >= 3
