"""A file header's 'Mm' names no one unit: the megametre (M is mega in SI) or millimetres with a slipped shift
key. A JSON body's ``units`` refuses it naming both readings; the file readers read it as millimetres without a
word. One rule now (schemas.common.AMBIGUOUS_UNITS): every reader refuses it, naming both readings."""

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.flowmeter.field_file import FieldFileError, read_field_file
from plantsolve.solvers.length_units import unit_named
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.upload import parse_upload

SCAN = (Path(__file__).parents[3] / "examples" / "tube" / "scan.ply").read_bytes()
FIRST_LINE = b"ply\nformat binary_little_endian 1.0\n"


def _names_both_readings(message: str) -> None:
    assert "'Mm'" in message and "megametre" in message and "millimetres" in message


def test_the_lookup_names_no_unit_for_mm_and_the_others_as_before():
    assert unit_named("Mm") is None
    assert [unit_named(w) for w in ("mm", "MM", "mM", " mm ", "Millimetres")] == ["mm"] * 5


def test_a_field_files_coordinate_header_in_mm_is_refused_naming_both_readings():
    rows = "".join(f"{x} {y} {z} 0 0.1 0\n" for x in (-30, 30) for y in (-30, 30) for z in (-80, 80))
    assert read_field_file("x[mm] y[mm] z[mm] Bx[T] By[T] Bz[T]\n" + rows, "mm").length_unit == "mm"  # the spelling we read
    with pytest.raises(FieldFileError) as refused:
        read_field_file("x[Mm] y[Mm] z[Mm] Bx[T] By[T] Bz[T]\n" + rows, "mm")
    _names_both_readings(str(refused.value))
    with pytest.raises(FieldFileError) as refused:
        read_field_file("% Length unit: Mm\nx y z Bx By Bz\n" + rows, "mm")
    _names_both_readings(str(refused.value))


@pytest.mark.parametrize("header", ["x [Mm],y [Mm],z [Mm]\n", "x,y,z\nMm,Mm,Mm\n"])
def test_a_point_lists_column_header_in_mm_is_refused_naming_both_readings(header):
    rows = "".join(f"{t:.3f},{2 * t:.3f},{0.5 * t:.3f}\n" for t in np.linspace(0, 500, 200))
    with pytest.raises(InputRejected) as refused:
        _ = TubeScan(parse_upload(StoredInput.from_bytes("scan.csv", (header + rows).encode()), None)).points
    _names_both_readings(str(refused.value))


def test_a_ply_comment_stating_mm_is_refused_naming_both_readings():
    header_end = SCAN.index(b"end_header\n") + len(b"end_header\n")
    data = FIRST_LINE + b"comment units Mm\n" + SCAN[len(FIRST_LINE):]
    assert SCAN.startswith(FIRST_LINE) and header_end < len(SCAN)
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("scan.ply", data), None)
    _names_both_readings(str(refused.value))
