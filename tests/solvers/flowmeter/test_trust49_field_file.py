"""A blank-separated field file from a decimal-comma locale ('-60  -60  -160  0,00092  0,0021', COMSOL's spreadsheet
layout re-saved on a German system): its commas were taken for the column separator, and every row refused as
'4 values for the header's 6 columns', though a comma separates nothing between blanks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.flowmeter.field_file import FieldFileError, read_field_file

COMSOL = (Path(__file__).parents[3] / "examples" / "flowmeter" / "magnet_comsol.txt").read_text()
HEAD = [line for line in COMSOL.splitlines() if line.startswith("%")]
ROWS = [line for line in COMSOL.splitlines() if not line.startswith("%")]


def _file(rows: list[str]) -> str:
    return "\n".join(HEAD + rows) + "\n"


def test_blank_separated_rows_with_decimal_commas_read_as_their_points_do():
    read = read_field_file(_file([r.replace(".", ",") for r in ROWS]), "mm")
    expected = read_field_file(COMSOL, "mm")
    assert read.rows.shape == expected.rows.shape == (225, 6) and np.array_equal(read.rows, expected.rows)


def test_blank_separated_rows_mixing_decimal_commas_and_points_are_refused_naming_the_line():
    rows = [r.replace(".", ",") for r in ROWS]
    rows[3] = ROWS[3]  # one row with decimal points: the first row with commas is named
    with pytest.raises(FieldFileError, match=rf"^line {len(HEAD) + 1}: .*decimal commas among decimal points"):
        read_field_file(_file(rows), "mm")


@pytest.mark.parametrize("row", ["1, 2, 3, 4, 5, 6", "1,2,3,4,5,6"])
def test_comma_separated_rows_under_a_blank_separated_header_stay_comma_separated(row):
    """'1, 2, 3' writes its commas after its fields: a separator, not a decimal comma."""
    read = read_field_file("x y z Bx By Bz\n" + row + "\n", "mm")
    assert read.rows.tolist() == [[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]]
