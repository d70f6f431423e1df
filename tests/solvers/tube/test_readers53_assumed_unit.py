"""A 20 mm tube scanned in inches, uploaded with no unit anywhere, fits as a 0.79 mm tube: every length 25.4 times
too small and within every physical bound, so it was answered without a word. The unit was assumed (the default,
mm), and a radius that small is a capillary's: warned naming the pipe radius and what it is in inches or
centimetres. Stating the unit (millimetres for a capillary) says which and silences it. A given pipe radius 25.4
times the scan's is refused naming the option and the unit the scan is likely in."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload
from plantsolve.solvers.tube.validation import assumed_unit_small_radius, check_input

INCH = 25.4
TUBE = surface_samples(make_model([(120, 0, 90, 30), (100, 0, 0, 0)], 20.0), 2000, np.random.default_rng(0),
                       noise=0.05)


def _request(pts, options=None, head=""):
    text = head + "".join(" ".join(f"{v:.5f}" for v in p) + "\n" for p in pts)
    return parse_upload(StoredInput.from_bytes("scan.xyz", text.encode()), options)


def test_a_tube_in_inches_read_in_the_assumed_mm_is_warned_naming_its_radius_in_inches():
    result = solve(TubeScan(_request(TUBE / INCH))).result
    (warning,) = [w for w in result.report.warnings if w.code == "file_units_assumed"]
    assert result.pipe_radius == pytest.approx(20.0 / INCH, rel=0.02)
    assert "pipe radius" in warning.message and "inches" in warning.message
    assert warning.details["pipe_radius_mm_if"]["in"] == pytest.approx(20.0, rel=0.02)


@pytest.mark.parametrize(("options", "head"), [({"units": "mm"}, ""), ({"file_units": "mm"}, ""),
                                               (None, "# units: mm\n"), ({"units": "in"}, "")])
def test_a_stated_unit_says_nothing(options, head):
    assert assumed_unit_small_radius(0.79, _request(TUBE / INCH, options, head)) is None


@pytest.mark.parametrize(("radius", "warned"), [(0.3, False), (0.79, True), (1.4, True), (1.6, False), (20.0, False)])
def test_only_a_capillary_radius_in_the_assumed_unit_is_warned(radius, warned):
    assert (assumed_unit_small_radius(radius, _request(TUBE / INCH)) is not None) is warned


def test_a_given_radius_in_mm_over_a_scan_in_inches_is_refused_naming_inches():
    longer = surface_samples(make_model([(500, 0, 90, 60), (400, 0, 0, 0)], 20.0), 2000, np.random.default_rng(0),
                             noise=0.05)  # longer than the radius even in inches (25.4 times too small)
    with pytest.raises(InputRejected) as refused:
        check_input(TubeScan(_request(longer / INCH, {"pipe_radius": 20.0})))
    (error,) = refused.value.errors
    assert error.loc == ("options", "pipe_radius") and "options.file_units to 'in'" in error.msg and "another unit" in error.msg
