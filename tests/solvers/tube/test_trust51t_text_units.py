"""Units a text scan states where the reader did not look: a blank-separated header ``x [m] y [m] z [m]`` (split at
every blank, its units were columns of their own and the header no column header) and a comment before the rows
(``# units: in``). Both were ignored and the file read in the request's unit: a scan in inches of a 20 mm tube gave
a tube of 0.79 mm, plausible, without a word. Both are the file's unit now; a comment naming a unit not read here,
or another than the header's, is refused naming its line unless options.file_units says the unit."""

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

PTS = surface_samples(make_model([(400, 0, 90, 100), (300, 0, 0, 0)], 20.0), 300, np.random.default_rng(0))
INCH = 25.4


def _text(head: str, pts) -> bytes:
    return (head + "\n".join(f"{x:.6f} {y:.6f} {z:.6f}" for x, y, z in pts) + "\n").encode()


def _read(data: bytes, options=None):
    req = parse_upload(StoredInput.from_bytes("scan.xyz", data), options)
    return req, TubeScan(req).points


@pytest.mark.parametrize("head", ["x [in] y [in] z [in]\n", "X (in) Y (in) Z (in)\n", "# units: in\n",
                                  "# Unit = inches\n# exported by a scanner\nx y z\n", "// length_units inch\n"])
def test_a_unit_stated_in_a_blank_separated_header_or_a_comment_is_read(head):
    req, points = _read(_text(head, PTS / INCH))
    assert np.allclose(points, PTS, atol=1e-4)
    assert (req.source.units.basis, req.source.units.file_unit) == ("header", "in")


def test_the_comment_is_named_as_the_evidence():
    req, _ = _read(_text("# written by the line scanner\n# units: in\n", PTS / INCH))
    assert "line 2" in req.source.units.evidence


@pytest.mark.parametrize(("head", "line"), [("# units: furlong\n", "line 1"),
                                            ("# units: in\nx [mm] y [mm] z [mm]\n", "line 1")])
def test_a_comment_unit_not_read_or_contradicting_the_header_is_refused(head, line):
    with pytest.raises(InputRejected) as refused:
        _read(_text(head, PTS / INCH))
    assert refused.value.errors[0].loc == ("file",) and line in refused.value.errors[0].msg
    _, points = _read(_text(head, PTS / INCH), {"file_units": "in"})
    assert np.allclose(points, PTS, atol=1e-4)


@pytest.mark.parametrize("head", ["# units: unknown\n", "# units of measure follow the scanner's setting\n"])
def test_a_comment_stating_no_unit_is_no_statement(head):
    req, points = _read(_text(head, PTS))
    assert req.source.units.basis == "request" and np.allclose(points, PTS, atol=1e-5)
