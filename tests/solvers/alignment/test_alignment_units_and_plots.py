"""The alignment result and its summary state the length unit; the gaps plot shows gaps and angle errors
with units, integer connection ticks and a legend off the data."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.artifacts import figures
from plantsolve.solvers.alignment.synthetic import example
from tests.support.plots import check_figure


def _request(units: str) -> AlignmentRequest:
    return AlignmentRequest.model_validate({**example(), "units": units})


def test_result_and_summary_state_the_length_unit():
    for units in ("mm", "in"):
        res = solve(_request(units)).result
        assert res.units == units and res.angle_unit == "deg"
        assert f"largest gap {res.max_position_error:.3g} {units}," in res.report.message
        assert res.model_dump(mode="json")["units"] == units


def test_gaps_plot_has_units_integer_ticks_and_angle_errors():
    req = _request("mm")
    res = solve(req).result
    fig = figures(req, res)["gaps"]
    check_figure(fig)
    gap_ax, ang_ax = fig.axes[:2]
    assert gap_ax.get_ylabel() == "gap [mm]" and ang_ax.get_ylabel() == "angle error [deg]"
    ticks = ang_ax.get_xticks()
    shown = ticks[(ticks >= -0.5) & (ticks <= len(req.connections) - 0.5)]
    assert len(shown) >= 2 and np.allclose(shown, np.round(shown))
    # the angle panel's "before" points are the submitted angle errors (degrees)
    before = ang_ax.get_lines()[0].get_ydata()
    assert len(before) == len(req.connections) and np.all(before > 0)
