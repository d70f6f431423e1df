"""The zones plot: every 3-D panel with its axes in the request's units, one legend below the panels."""

from __future__ import annotations

from pathlib import Path

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.artifacts import figures
from tests.support.plots import check_figure

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "polyhedra"


def test_zone_panels_have_units_and_the_legend_sits_outside():
    req = parse_upload(StoredInput.from_path(EXAMPLES / "two_offices.idf"), None)
    res = solve(req).result
    fig = figures(req, res)["zones"]
    check_figure(fig)
    panels = [a for a in fig.axes if a.name == "3d"]
    assert len(panels) == len(res.zones)
    for ax in panels:
        assert [ax.get_xlabel(), ax.get_ylabel(), ax.get_zlabel()] == [f"{c} [{req.units}]" for c in "xyz"]
        assert ax.get_legend() is None
    assert fig.legends and "faces" in [t.get_text() for t in fig.legends[0].get_texts()]
