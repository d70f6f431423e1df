"""A comment's unit needs a separator after ``unit(s)``: without one, ``# units``, ``# unitless``, ``# Unity`` and
the PLY comments ``comment units`` and ``obj_info units`` were read as stating the units 's', 'less' and 'y' and the
file refused; both readers share one reading of such a comment (``length_units.comment_unit``). A scan whose rows
are numbered keeps the unit its comment states (it was read in the request's unit: 25.4 times too small)."""

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.length_units import SIZES, comment_unit
from plantsolve.solvers.tube.ply_points import stated_unit
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

PTS = surface_samples(make_model([(400, 0, 90, 100), (300, 0, 0, 0)], 20.0), 300, np.random.default_rng(0))
INCH = 25.4


def _text(head: str, pts, numbered: bool = False) -> bytes:
    return (head + "".join((f"{i + 1} " if numbered else "") + " ".join(f"{v:.6f}" for v in p) + "\n"
                           for i, p in enumerate(pts))).encode()


def _read(data: bytes, options=None):
    req = parse_upload(StoredInput.from_bytes("scan.xyz", data), options)
    return req, TubeScan(req).points


def _ply_header(comment: str) -> bytes:
    return f"ply\nformat ascii 1.0\n{comment}\nelement vertex 0\nproperty float x\nend_header\n".encode()


@pytest.mark.parametrize("head", ["# units\n", "# unitless\n", "# Unity\n", "# Unity export\n", "// units\n"])
def test_a_comment_starting_with_unit_but_stating_none_reads_the_request_unit(head):
    req, points = _read(_text(head, PTS))
    assert req.source.units.basis == "request" and np.allclose(points, PTS, atol=1e-5)


@pytest.mark.parametrize("comment", ["comment units", "comment unitless", "comment Unity", "obj_info units",
                                     "obj_info Unity 2022 export"])
def test_a_ply_comment_starting_with_unit_but_stating_none_is_no_statement(comment):
    assert stated_unit(_ply_header(comment)) is None


@pytest.mark.parametrize(("comment", "unit"), [("comment units mm", "mm"), ("comment Unit: meter", "m"),
                                               ("obj_info length_unit = millimetres", "mm"),
                                               ("comment units um", "um")])
def test_a_ply_comment_stating_a_unit_is_still_read(comment, unit):
    assert stated_unit(_ply_header(comment))[0] == unit


@pytest.mark.parametrize(("text", "stated"), [("units: in", ("in", "in")), ("unit=mm", ("mm", "mm")),
                                              ("Units microns", ("microns", "um")), ("units", None),
                                              ("unitless", None), ("Unity", None), ("units: none", None),
                                              ("units: furlong", ("furlong", None))])
def test_one_reading_of_a_unit_comment(text, stated):
    assert comment_unit(text, SIZES) == stated


@pytest.mark.parametrize("head", ["# units: in\n", "// Unit = inches\n"])
def test_numbered_rows_keep_the_unit_a_comment_states(head):
    req, points = _read(_text(head, PTS / INCH, numbered=True))
    assert (req.source.units.basis, req.source.units.file_unit) == ("header", "in")
    assert np.allclose(points, PTS, atol=1e-4)


def test_numbered_rows_under_a_comment_naming_no_unit_read_here_are_refused():
    with pytest.raises(InputRejected) as refused:
        _read(_text("# units: furlong\n", PTS, numbered=True))
    assert "line 1" in refused.value.errors[0].msg and "'furlong'" in refused.value.errors[0].msg
