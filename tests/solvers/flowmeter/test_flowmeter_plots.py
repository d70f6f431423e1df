"""The flow meter's plots for finite patch electrodes (the integral equation: W over the section, the current
density across and over the electrode, linearity) pass the plot checker as saved; the example (full-length
electrodes) is covered by tests/solvers/test_plots.py."""

from __future__ import annotations

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import no_progress
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.artifacts import figures
from plantsolve.solvers.flowmeter.synthetic import meter
from plantsolve.solvers.plots import DPI
from tests.support.plots import check_figure


def test_finite_electrode_plots_pass_the_checker():
    request = FlowmeterRequest.model_validate(meter(radius=50.0, half_angle=22.5, half_length=15.7,
                                                    reynolds=[1000.0, 100000.0]))
    result = solve(request, no_progress).result
    figs = figures(request, result)
    assert set(figs) == {"weight_function", "electrode_current", "linearity"}
    assert len(figs["electrode_current"].axes) == 3  # across, the map over the electrode and its colour bar
    for fig in figs.values():
        check_figure(fig, DPI)
