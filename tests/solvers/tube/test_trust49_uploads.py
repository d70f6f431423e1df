"""Tube uploads as users get them wrong: a unit in the form or a JSON file by any of its spellings ('MM',
'Millimetres', 'IN') is read, 'Mm' refused naming both of its readings (SI's megametre, millimetres with a slipped
shift key); before, each was refused as an unknown unit (one table of spellings: ``solvers.length_units``). A text
file of x, y, z as three rows is read transposed, with a warning."""

from __future__ import annotations

import json

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.upload import parse_upload
from tests.conftest import REPO

SCAN_XYZ = (REPO / "examples" / "tube" / "scan.xyz").read_bytes()
POINTS = np.loadtxt(REPO / "examples" / "tube" / "scan.xyz")


@pytest.mark.parametrize("word, unit", [("MM", "mm"), ("Millimetres", "mm"), ("millimeters", "mm"), ("CM", "cm"),
                                        ("M", "m"), ("Metres", "m"), ("IN", "in"), ("Inches", "in"), ("FT", "ft")])
def test_a_file_unit_in_any_spelling_converts_the_points(word, unit):
    request = parse_upload(StoredInput.from_bytes("scan.xyz", SCAN_XYZ), {"file_units": word})
    factor = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8}[unit]
    assert request.options.file_units == unit and request.units == "mm"
    np.testing.assert_allclose(np.asarray(TubeScan(request).points), POINTS * factor, rtol=1e-12)


@pytest.mark.parametrize("word, unit", [("MM", "mm"), ("Inches", "in")])
def test_a_request_unit_in_any_spelling_is_the_results_unit(word, unit):
    form = parse_upload(StoredInput.from_bytes("scan.xyz", SCAN_XYZ), {"units": word, "file_units": "mm"})
    body = {"points": POINTS.tolist(), "units": word}
    in_file = parse_upload(StoredInput.from_bytes("scan.json", json.dumps(body).encode()), {})
    assert form.units == in_file.units == unit


def _refusal(call) -> tuple[tuple, str]:
    with pytest.raises(InputRejected) as caught:
        call()
    (error,) = caught.value.errors
    return error.loc, error.msg


@pytest.mark.parametrize("options, loc", [({"file_units": "Mm"}, ("options", "file_units")),
                                          ({"units": "Mm"}, ("options", "units"))])
def test_mm_with_a_capital_m_is_refused_naming_both_readings(options, loc):
    got, msg = _refusal(lambda: parse_upload(StoredInput.from_bytes("scan.xyz", SCAN_XYZ), options))
    assert got == loc and "megametre" in msg and "millimetres" in msg


def test_an_unknown_unit_is_still_refused_naming_the_units():
    loc, msg = _refusal(lambda: parse_upload(StoredInput.from_bytes("scan.xyz", SCAN_XYZ), {"file_units": "yd"}))
    assert loc == ("options", "file_units") and msg.startswith("unknown unit 'yd'; one of mm, cm, m, in, ft")


@pytest.mark.parametrize("separator", [" ", ",", "\t"])
def test_a_text_file_of_three_rows_of_coordinates_is_read_transposed_and_says_so(separator):
    text = "\n".join(separator.join(repr(v) for v in row) for row in POINTS.T.tolist()) + "\n"
    request = parse_upload(StoredInput.from_bytes("scan.csv", text.encode()), {})
    # before: three points of the first three numbers of each row, refused as 'at least 100 points are needed'
    (warning,) = request.source.warnings
    assert warning.code == "text_transposed" and warning.details == {"rows": 3, "columns": 4000}
    np.testing.assert_array_equal(np.asarray(TubeScan(request).points), POINTS)


def _pts_lines(points: np.ndarray, other: np.ndarray, decimals: int) -> list[str]:
    return [" ".join(f"{v:.{decimals}f}" for v in p) + " " + " ".join(map(str, o)) for p, o in zip(points, other)]


@pytest.mark.parametrize("decimals", [0, 3])
def test_half_a_pts_file_pasted_again_shuffled_is_read_once_where_its_intensities_tell(decimals):
    rng = np.random.default_rng(0)
    other = np.column_stack([rng.integers(-2048, 2048, len(POINTS)), rng.integers(0, 256, (len(POINTS), 3))])
    lines = _pts_lines(POINTS, other, decimals)
    once = parse_upload(StoredInput.from_bytes("scan.txt", "\n".join(lines).encode()), {})
    pasted = lines + [lines[k] for k in rng.permutation(len(lines))[:2000]]
    twice = parse_upload(StoredInput.from_bytes("scan.txt", "\n".join(pasted).encode()), {})
    # before, printed to 1 mm: 6,000 samples, no warning (the positions alone hold no more coincidences than a
    # denser scan's); the samples of the file given once, in its order, make the same request
    assert once.source.warnings == []
    (warning,) = twice.source.warnings
    assert warning.code == "duplicate_points" and warning.details == {"repeated": 2000, "samples": 6000, "kept": 4000}
    assert twice.model_dump(exclude={"source"}) == once.model_dump(exclude={"source"})


def test_coincident_positions_of_different_intensities_are_all_kept():
    rng = np.random.default_rng(1)
    other = np.column_stack([rng.integers(-2048, 2048, len(POINTS)), rng.integers(0, 256, (len(POINTS), 3))])
    lines = _pts_lines(POINTS, other, 0)  # printed to 1 mm: 1,138 samples share a position with an earlier one
    request = parse_upload(StoredInput.from_bytes("scan.txt", "\n".join(lines).encode()), {})
    assert request.source.warnings == [] and request.source.points == len(POINTS)
