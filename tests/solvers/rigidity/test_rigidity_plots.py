"""graph.png of real models: every label readable, none over another label, a node, the title or the legend."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.artifacts import graph_figure
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload
from tests.support.plots import figure_problems

HERE = Path(__file__).parent


@pytest.mark.parametrize("name", ["official_parts.ldr", "omr/30023-1-Lighthouse.ldr", "omr/30054-1-AT-ST-Mini.mpd",
                                  "omr/6965-1-TIEIntercep_4h4MXk5.mpd"])
def test_graph_labels_overlap_nothing_and_those_left_out_are_counted(name):
    path = HERE / name
    request = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), None)
    result = solve(request).result
    fig = graph_figure(request, result)
    assert figure_problems(fig, 100) == []
    ax = fig.axes[0]
    labels = [t for t in ax.texts if t.get_visible()]
    title = ax.get_title()
    left_out = int(title.split("; ")[1].split()[0]) if "left out" in title else 0
    assert len(labels) + left_out == len({b for c in result.clusters for b in c})
    assert len(labels) >= 0.6 * (len(labels) + left_out)  # most nodes keep their label
