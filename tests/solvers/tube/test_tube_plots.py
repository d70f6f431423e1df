"""Tube plots: the overview's 3-D axes and histogram carry units and the LRA table has a panel of its own;
an inspection gets a plot of the deviation along the tube, whose curve is the distance its report sums up."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import to_rgba

from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.artifacts import figures, render_artifacts
from tests.support.plots import check_figure

NOMINAL = [[40, 0, 61, 12], [20, 180, 61.5, 12], [30, 0, 0, 0]]


@pytest.fixture(scope="module")
def inspected(tk_module):
    tk = tk_module
    _, pts = tk.scan(tk.SHAPES["s_bend"], n=3000, seed=8, view=[0.2, 0.1, -1.0], noise=0.04)
    scan = TubeScan(tk.request(pts, nominal=[dict(length=a, rotation=b, angle=c, bend_radius=d) for a, b, c, d in NOMINAL]))
    return scan, solve(scan)


def test_overview_axes_have_units_and_the_table_its_own_panel(inspected):
    scan, solved = inspected
    res = solved.result
    fig = figures(scan, res)["overview"]
    check_figure(fig)
    ax3d = fig.axes[0]
    assert [ax3d.get_xlabel(), ax3d.get_ylabel(), ax3d.get_zlabel()] == ["x [mm]", "y [mm]", "z [mm]"]
    hist = next(a for a in fig.axes if a.get_xlabel().startswith("signed distance"))
    assert not hist.texts  # the LRA no longer sits over the bars
    table_ax = next(a for a in fig.axes if a.tables)
    assert len(table_ax.tables[0].get_celld()) == 5 * (len(res.lra) + 1)


def _y_span(ax, patch) -> tuple[float, float]:
    """The data-coordinate y extent of a patch (an axhspan band: x in axes, y in data coordinates)."""
    corners = patch.get_transform().transform(patch.get_path().vertices)
    y = ax.transData.inverted().transform(corners)[:, 1]
    return float(y.min()), float(y.max())


def test_inspection_plot_shows_the_deviation_along_the_tube(inspected):
    scan, solved = inspected
    res = solved.result
    figs = figures(scan, res)
    assert set(figs) == {"overview", "inspection", "inspection_overlay"}
    fig = figs["inspection"]
    check_figure(fig)
    top = fig.axes[0]
    assert top.get_ylabel() == "distance from nominal centreline [mm]"
    arc, d = top.get_lines()[0].get_data()
    assert arc[0] == 0 and np.all(np.diff(arc) >= 0)
    # the curve's maximum is the sheath deviation of the report (the same samples' worst point)
    assert np.max(d) == pytest.approx(res.inspection.sheath_deviation, rel=0.05, abs=0.02)
    assert "inspection.png" in [a.name for a in render_artifacts(scan, solved)]


def test_inspection_plot_draws_each_fields_tolerance_band_and_deviations(inspected):
    scan, solved = inspected
    ins = solved.result.inspection
    fig = figures(scan, solved.result)["inspection"]
    panels = fig.axes[1:5]
    assert [a.get_ylabel() for a in panels] == ["length deviation [mm]", "rotation deviation [deg]",
                                                "bend angle deviation [deg]", "CLR deviation [mm]"]
    for ax, name in zip(panels, ("length", "rotation", "angle", "bend_radius")):
        tol = getattr(ins.tolerances, name)
        bands = [p for p in ax.patches if p.get_label() == "tolerance band"]
        assert len(bands) == 1 and _y_span(ax, bands[0]) == pytest.approx((-tol, tol))
        checks = [getattr(r, name) for r in ins.rows if getattr(r, name) is not None]
        bars = [p for p in ax.patches if p.get_label() != "tolerance band"]
        assert [b.get_height() for b in bars] == pytest.approx([c.deviation for c in checks])
        # the band and every bar with its whiskers lie inside the panel
        lo, hi = ax.get_ylim()
        assert lo <= -tol and hi >= tol and all(lo <= b.get_height() <= hi for b in bars)
    # the made tube's bends are 0.5-1° off in angle against ±0.5°: red bars, the others blue
    angle_bars = [p for p in panels[2].patches if p.get_label() != "tolerance band"]
    angle_checks = [r.angle for r in ins.rows if r.angle is not None]
    colours = {"C3": to_rgba("C3"), "C0": to_rgba("C0")}
    for bar, check in zip(angle_bars, angle_checks):
        assert bar.get_facecolor() == pytest.approx(colours["C0" if check.ok else "C3"])


def test_the_overview_z_label_keeps_clear_of_the_colour_bar(inspected):
    scan, solved = inspected
    fig = figures(scan, solved.result)["overview"]
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    z_label = fig.axes[0].zaxis.label.get_window_extent(renderer)
    bar = next(a for a in fig.axes if a.get_label() == "<colorbar>").get_window_extent(renderer)
    assert bar.x0 - z_label.x1 >= 8  # pixels between the label's right edge and the bar


def test_no_inspection_no_inspection_plot(tk_module):
    tk = tk_module
    _, pts = tk.scan(tk.SHAPES["s_bend"], n=1500, seed=3, noise=0.02)
    scan = TubeScan(tk.request(pts))
    assert set(figures(scan, solve(scan).result)) == {"overview"}
