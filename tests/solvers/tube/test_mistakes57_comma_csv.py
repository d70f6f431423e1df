"""A scan saved as a comma-separated file in a decimal-comma locale (``251,000,-112,446,30,572``): each number is two
cells, and read cell by cell every point was wrong (x 251, y 0, z -112) without a word. It is refused naming the
first row; a file that only looks alike (integers and colours, a ';'-separated decimal-comma file) reads as before."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.upload import parse_upload

SCAN = (Path(__file__).resolve().parents[3] / "examples" / "tube" / "scan.xyz").read_text()
POINTS = np.loadtxt(SCAN.splitlines())


def _points(text: str, name: str = "scan.csv") -> np.ndarray:
    return np.asarray(parse_upload(StoredInput.from_bytes(name, text.encode()), None).points, dtype=float)


def _refused(text: str, name: str = "scan.csv"):
    with pytest.raises(InputRejected) as caught:
        parse_upload(StoredInput.from_bytes(name, text.encode()), None)
    (error,) = caught.value.errors
    return error


def _comma_rows() -> list[str]:
    return [line.replace(".", ",").replace(" ", ",") for line in SCAN.splitlines()]


@pytest.mark.parametrize("header, name", [("x,y,z", "scan.csv"), (None, "scan.csv"), ("X,Y,Z", "scan.txt")])
def test_decimal_commas_between_comma_separated_cells_are_refused_naming_the_first_row(header, name):
    error = _refused("\n".join(([header] if header else []) + _comma_rows()) + "\n", name)
    first = 2 if header else 1
    assert error.loc == ("file", "line", first)
    assert f"line {first}: 6 comma-separated cells" in error.msg and "decimal commas" in error.msg
    assert ("under the 3 columns of line 1" in error.msg) == bool(header)


def test_the_same_numbers_between_semicolons_or_with_points_read_to_the_scan():
    semicolons = "\n".join(line.replace(".", ",").replace(" ", ";") for line in SCAN.splitlines())
    for text in ("x;y;z\n" + semicolons, "x,y,z\n" + SCAN.replace(" ", ",")):
        assert np.allclose(_points(text), POINTS)


def test_integer_coordinates_with_colour_columns_are_no_decimal_commas():
    rows = np.abs(POINTS).round().astype(int)
    text = "\n".join(",".join(map(str, [*p, 255, 128, 7])) for p in rows) + "\n"
    assert np.array_equal(_points(text), rows)
