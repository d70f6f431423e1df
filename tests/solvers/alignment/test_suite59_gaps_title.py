"""The gaps plot's title stands on its axes' top edge without matplotlib measuring the y tick labels at every save:
the same picture as with matplotlib's automatic placement."""

from __future__ import annotations

from matplotlib.axis import YAxis

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.artifacts import gaps_figure
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.kinds import KINDS
from plantsolve.solvers.plots import figure_bytes


def test_the_title_is_placed_where_the_automatic_placement_puts_it_without_measuring_tick_labels(monkeypatch):
    request = AlignmentRequest.model_validate(KINDS["alignment"].example())
    result = solve(request).result
    measured = []
    tightbbox = YAxis.get_tightbbox
    monkeypatch.setattr(YAxis, "get_tightbbox", lambda self, *a, **k: measured.append(self) or tightbbox(self, *a, **k))
    placed = figure_bytes(gaps_figure(request, result), dpi=100)
    assert not measured
    automatic = gaps_figure(request, result)
    automatic.axes[0]._autotitlepos = True  # matplotlib's own placement (what set_title without y= gives)
    assert figure_bytes(automatic, dpi=100) == placed and measured
