"""A second round of mistakes users make with tube files and nominals, each answered by the right number, a
warning naming the quantity, or a refusal naming the field — never a confident wrong result."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.upload import parse_upload
from tests.conftest import REPO

SCAN_XYZ = REPO / "examples" / "tube" / "scan.xyz"
POINTS = np.loadtxt(SCAN_XYZ)


def _points(name: str, content: bytes, options: dict | None = None) -> np.ndarray:
    request = parse_upload(StoredInput.from_bytes(name, content), options or {})
    return np.asarray(request.points, float)


def _decimal_comma(sep: str) -> str:
    return "\n".join(sep.join(f"{v:.3f}".replace(".", ",") for v in row) for row in POINTS) + "\n"


# --- numbers written as a European locale writes them -------------------------------------------------------


@pytest.mark.parametrize("name, sep", [("scan.csv", ";"), ("scan.xyz", " "), ("scan.txt", "\t")])
def test_a_scan_written_with_decimal_commas_gives_the_same_points(name, sep):
    # split at the commas, each row was six numbers and the first three a wrong point (a 999 mm straight tube)
    got = _points(name, _decimal_comma(sep).encode())
    np.testing.assert_allclose(got, POINTS, atol=5e-4)


def test_a_decimal_comma_scan_under_a_semicolon_header_keeps_the_headers_unit():
    got = _points("scan.csv", ("x [m];y [m];z [m]\n" + _decimal_comma(";")).encode())
    np.testing.assert_allclose(got, POINTS * 1000.0, atol=0.5)


@pytest.mark.parametrize("text, expected", [
    ("1,2,3\n4,5,6\n", [[1, 2, 3], [4, 5, 6]]),  # comma-separated integers stay three numbers a row
    ("1, 2, 3\n4, 5, 6\n", [[1, 2, 3], [4, 5, 6]]),
    ("1.5,2.5,3.5\n", [[1.5, 2.5, 3.5]]),
    ("1,5;2,5;3,5\n4;5;6\n", [[1.5, 2.5, 3.5], [4, 5, 6]]),
])
def test_comma_separated_and_decimal_comma_rows_are_told_apart(text, expected):
    from plantsolve.solvers.tube.read_log import ReadLog
    from plantsolve.solvers.tube.text_points import read_text_points

    got, _ = read_text_points(text.encode(), ReadLog("csv"))
    np.testing.assert_allclose(got, expected)
