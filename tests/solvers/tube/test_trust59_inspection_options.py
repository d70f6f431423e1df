"""Inspection options sent without a nominal (``inspection_tolerances``, a ``damping`` or ``springback_model`` other
than the default) were ignored without a word: the tube was reconstructed with status ok, and nothing told that no
part had been inspected. They are named in a warning (``inspection_options_ignored``)."""

import pytest

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.tube.synthetic import example
from plantsolve.solvers.tube.solve import solve

NOMINAL = [{"length": 30.0, "angle": 90.0, "bend_radius": 12.0}, {"length": 30.0}]


def _solved(options: dict):
    return solve(TubeRequest.model_validate({**example(), "options": options})).result


def test_tolerances_without_a_nominal_are_named():
    result = _solved({"inspection_tolerances": {"angle": 0.2, "length": 0.5}, "damping": 0.8})
    (said,) = [w for w in result.report.warnings if w.code == "inspection_options_ignored"]
    assert said.details == {"options": ["inspection_tolerances", "damping"]}
    assert "inspection_tolerances (length, angle)" in said.message and result.report.status == "warning"
    assert result.inspection is None


@pytest.mark.parametrize("options", [
    {"inspection_tolerances": {}, "damping": 1.0, "springback_model": "per_bend"},  # the defaults, sent
    {"inspection_tolerances": {"angle": 0.2}, "nominal": NOMINAL},
])
def test_defaults_or_a_nominal_are_no_warning(options):
    result = _solved(options)
    assert "inspection_options_ignored" not in {w.code for w in result.report.warnings}
    assert (result.inspection is not None) == ("nominal" in options)


@pytest.mark.parametrize("options", [
    {"nominal_format": "lra", "nominal": NOMINAL},
    {"nominal_format": "xyz_clr", "nominal": NOMINAL},
])
def test_a_nominal_format_beside_a_nominal_that_is_no_csv_is_named(options):
    result = _solved(options)
    (said,) = [w for w in result.report.warnings if w.code == "inspection_options_ignored"]
    assert said.details == {"options": ["nominal_format"]} and "given as options.nominal:" in said.message
    assert result.inspection is not None
