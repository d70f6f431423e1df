"""The accuracy verdict: a sensitivity whose estimated error is above options.tolerance said 'ok' beside it (the
finite-element mesh stops at its finest size; the first-order iterate has an accuracy of its own)."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import no_progress
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.synthetic import meter


def run(**kwargs):
    return solve(FlowmeterRequest.model_validate(meter(**kwargs)), no_progress).result


def test_first_order_above_the_target_tolerance_is_a_warning_naming_the_sensitivity():
    result = run(half_length=25.0, method="first_order", tolerance=1e-3)
    assert result.sensitivity == pytest.approx(np.sin(np.radians(22.5)) / np.radians(22.5), abs=2e-4)
    assert result.error_estimate > 1e-2  # was status 'ok' beside it
    assert result.report.status == "warning" and "ABOVE the target tolerance" in result.report.message
    (missed,) = [w for w in result.report.warnings if w.code == "tolerance_not_reached"]
    assert missed.details["quantity"] == "sensitivity" and missed.details["tolerance"] == 1e-3
    assert missed.details["error_estimate"] == result.error_estimate
