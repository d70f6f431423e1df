"""Mistakes of the 49th probe with field files: a tab-separated export from a decimal-comma locale (Excel's 'Text
(tab delimited)' on a German system: '0,5<TAB>1,25') was refused as 'not a row of numbers', though a comma can
separate nothing in a tab-separated file."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.flowmeter.field_file import FieldFileError, read_field_file

HEADER = "x [mm]\ty [mm]\tz [mm]\tBx [mT]\tBy [mT]"
GRID = [(x, y, z) for x in (-60.0, 0.0, 60.0) for y in (-60.0, 0.0, 60.0) for z in (-200.0, 0.0, 200.0)]


def _rows(fmt) -> list[str]:
    return [fmt(x, y, z, 0.25 * x / 60, 10.0 - 0.5 * z / 200) for x, y, z in GRID]


def test_a_tab_separated_file_with_decimal_commas_reads_as_its_points_do():
    commas = "\n".join([HEADER, *_rows(lambda *v: "\t".join(f"{c:.2f}".replace(".", ",") for c in v))]) + "\n"
    points = "\n".join([HEADER, *_rows(lambda *v: "\t".join(f"{c:.2f}" for c in v))]) + "\n"
    read, expected = read_field_file(commas, "mm"), read_field_file(points, "mm")
    assert np.array_equal(read.rows, expected.rows) and read.rows.shape == (27, 5)
    assert read.rows[1].tolist() == pytest.approx([-60.0, -60.0, 0.0, -0.25e-3, 10.0e-3])  # mT read as tesla


def test_a_tab_separated_file_mixing_decimal_commas_and_points_is_refused_naming_the_line():
    rows = _rows(lambda *v: "\t".join(f"{c:.2f}" for c in v))
    rows[4] = rows[4].replace(".", ",")
    with pytest.raises(FieldFileError, match=r"^line 6: .*decimal commas among decimal points"):
        read_field_file("\n".join([HEADER, *rows]) + "\n", "mm")
