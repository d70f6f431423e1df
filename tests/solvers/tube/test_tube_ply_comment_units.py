"""A PLY header comment that states the coordinates' unit (``comment units m``, as some scanners and converters
write): the reader took every PLY in the request's unit, so a scan in metres was read 1000 times too small without
a word, and an options.file_units contradicting the comment went unremarked. The comment is the file's stated unit
now, like a text file's column header."""

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.upload import parse_upload

SCAN = (Path(__file__).parents[3] / "examples" / "tube" / "scan.ply").read_bytes()
FIRST_LINE = b"ply\nformat binary_little_endian 1.0\n"


def _with_comments(*comments: str, scale: float = 1.0) -> bytes:
    assert SCAN.startswith(FIRST_LINE)
    header_end = SCAN.index(b"end_header\n") + len(b"end_header\n")
    body = (np.frombuffer(SCAN[header_end:], dtype="<f4") * np.float32(scale)).astype("<f4").tobytes()
    extra = "".join(f"{c}\n" for c in comments).encode()
    return FIRST_LINE + extra + SCAN[len(FIRST_LINE):header_end] + body


def _points(data: bytes, options=None):
    req = parse_upload(StoredInput.from_bytes("scan.ply", data), options)
    return req, TubeScan(req).points


def test_a_scan_in_metres_whose_comment_says_so_is_read_in_millimetres():
    _, plain = _points(SCAN)
    req, points = _points(_with_comments("comment units m", scale=1e-3))
    assert np.allclose(points, plain, rtol=1e-6, atol=1e-3)
    u = req.source.units
    assert (u.basis, u.file_unit, u.factor) == ("header", "m", 1000.0) and "line 3" in u.evidence


@pytest.mark.parametrize("comment", ["comment units mm", "comment Unit: millimeters", "obj_info length_unit = mm"])
def test_the_usual_spellings_are_read(comment):
    req, points = _points(_with_comments(comment))
    assert req.source.units.basis == "header" and req.source.units.factor == 1.0
    assert np.array_equal(points, _points(SCAN)[1])


def test_file_units_contradicting_the_comment_is_warned_naming_both():
    req, _ = _points(_with_comments("comment units m", scale=1e-3), {"file_units": "mm"})
    (warning,) = [w for w in req.source.warnings if w.code == "file_unit_overridden"]
    assert warning.details["file_unit"] == "m" and warning.details["file_units"] == "mm"
    assert warning.details["ratio"] == pytest.approx(1e-3)


def test_comments_stating_two_units_are_refused_naming_their_lines():
    with pytest.raises(InputRejected) as refused:
        _points(_with_comments("comment units mm", "comment units m"))
    assert refused.value.errors[0].loc == ("file",)
    assert "line 3" in refused.value.errors[0].msg and "line 4" in refused.value.errors[0].msg
    assert _points(_with_comments("comment units mm", "comment units m"), {"file_units": "mm"})[0].units == "mm"


def test_a_comment_that_names_no_unit_is_no_statement():
    req, _ = _points(_with_comments("comment units of the scanner: see manual", "comment TextureFile scan.png"))
    assert req.source.units.basis == "request"
