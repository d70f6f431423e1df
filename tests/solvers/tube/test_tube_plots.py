"""Tube plots: the overview's 3-D axes and histogram carry units and the LRA table has a panel of its own;
an inspection gets a plot of the deviation along the tube, whose curve is the distance its report sums up."""

from __future__ import annotations

import numpy as np
import pytest

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


def test_inspection_plot_shows_the_deviation_along_the_tube(inspected):
    scan, solved = inspected
    res = solved.result
    figs = figures(scan, res)
    assert set(figs) == {"overview", "inspection", "inspection_overlay"}
    fig = figs["inspection"]
    check_figure(fig)
    top, bars = fig.axes[0], fig.axes[1]
    assert top.get_ylabel() == "distance from nominal centreline [mm]"
    arc, d = top.get_lines()[0].get_data()
    assert arc[0] == 0 and np.all(np.diff(arc) >= 0)
    # the curve's maximum is the sheath deviation of the report (the same samples' worst point)
    assert np.max(d) == pytest.approx(res.inspection.sheath_deviation, rel=0.05, abs=0.02)
    assert len(bars.patches) == 2 * len(res.inspection.bends)
    assert [p.get_height() for p in bars.patches[:2]] == pytest.approx([b.angle for b in res.inspection.bends])
    assert "inspection.png" in [a.name for a in render_artifacts(scan, solved)]


def test_no_inspection_no_inspection_plot(tk_module):
    tk = tk_module
    _, pts = tk.scan(tk.SHAPES["s_bend"], n=1500, seed=3, noise=0.02)
    scan = TubeScan(tk.request(pts))
    assert set(figures(scan, solve(scan).result)) == {"overview"}
