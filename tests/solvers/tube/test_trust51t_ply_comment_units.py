"""A PLY header comment stating a unit the reader could not convert (``comment units yd``, ``dm``, ``um``,
``furlong``) was no statement: the file was read in the request's unit without a word, a scan in decimetres 100
times too small, one in micrometres 1000 times too large. Micrometres are read now; any other unit is refused
naming the line unless options.file_units says the unit; a comment saying no unit is stated is still none."""

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

PTS = surface_samples(make_model([(120, 0, 90, 30), (100, 0, 0, 0)], 6.0), 400, np.random.default_rng(0))


def _ply(pts, comment: str) -> bytes:
    head = f"ply\nformat ascii 1.0\n{comment}\nelement vertex {len(pts)}\nproperty double x\nproperty double y\n" \
           "property double z\nend_header\n"
    return (head + "\n".join(f"{x:.17g} {y:.17g} {z:.17g}" for x, y, z in pts) + "\n").encode()


def _read(data: bytes, options=None):
    req = parse_upload(StoredInput.from_bytes("scan.ply", data), options)
    return req, TubeScan(req).points


def test_micrometres_stated_in_a_comment_are_read():
    req, points = _read(_ply(PTS * 1000, "comment units um"))
    assert np.allclose(points, PTS, rtol=0, atol=1e-9)
    assert (req.source.units.basis, req.source.units.file_unit) == ("header", "um")


@pytest.mark.parametrize("word", ["yd", "dm", "furlong", "Yards"])
def test_a_unit_not_read_here_is_refused_naming_its_line(word):
    with pytest.raises(InputRejected) as refused:
        _read(_ply(PTS / 100, f"comment units {word}"))
    (error,) = refused.value.errors
    assert error.loc == ("file",) and "line 3" in error.msg and repr(word) in error.msg and "file_units" in error.msg


def test_file_units_reads_a_file_whose_comment_states_another_unit():
    req, points = _read(_ply(PTS / 10, "comment units dm"), {"file_units": "cm"})
    assert np.allclose(points, PTS, atol=1e-9) and req.source.units.basis == "options.file_units"


@pytest.mark.parametrize("comment", ["comment units unknown", "comment Units: none", "comment units of the scanner"])
def test_a_comment_stating_no_unit_is_no_statement(comment):
    req, points = _read(_ply(PTS, comment))
    assert req.source.units.basis == "request" and np.allclose(points, PTS)
