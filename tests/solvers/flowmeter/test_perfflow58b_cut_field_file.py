"""A field file without a final line ending is told cut only when its last value is shorter than its column's by the
file readers' one rule (decimals; significant digits between exponent-notation cells; some 20 cells compared): no
false alarm on fixed-decimal exports whose last value is small, nor on tiny files; and its end is looked at without
splitting the whole file."""

from __future__ import annotations

import tracemalloc

import pytest

from plantsolve.solvers.flowmeter.field_file import cut_last_value, read_field_file

HEADER = "x [mm],y [mm],z [mm],Bx [T],By [T]\n"


def _fixed_decimals(rows: int, last_by: str) -> str:
    """A ``%.6f`` export whose By grows along the rows and whose last row's By is ``last_by``."""
    lines = [f"{k:.6f},0.000000,0.000000,0.000000,{0.5 - k * 1e-3:.6f}" for k in range(rows)]
    return HEADER + "\n".join(lines + [f"{rows:.6f},0.000000,0.000000,0.000000,{last_by}"])


def test_a_fixed_decimal_export_ending_on_its_smallest_value_is_whole():
    assert read_field_file(_fixed_decimals(40, "0.000916"), "mm").cut is None  # 3 significant digits, 6 decimals


def test_a_fixed_decimal_export_cut_inside_its_last_value_is_told():
    cut = read_field_file(_fixed_decimals(40, "0.0009"), "mm").cut
    assert cut is not None and "'0.0009' has 4 decimal(s) where the column's other values have 6" in cut


@pytest.mark.parametrize("last", ["0.1", "1e-3", "7"])
def test_a_three_row_file_says_nothing_of_a_cut(last):
    text = HEADER + "0,0,0,0,0.123456\n1,0,0,0,0.234567\n2,0,0,0," + last
    assert read_field_file(text, "mm").cut is None


def test_exponent_cells_are_held_against_exponent_cells_only():
    rows = [f"{k},0,0,0,{(k + 1) * 1.234567891e-4:.9E}" for k in range(30)]
    plain = [f"{k},0,0,0,0.25" for k in range(30, 60)]  # two decimals: no measure of the exponent cells' digits
    whole = read_field_file(HEADER + "\n".join(plain + rows), "mm")
    assert whole.cut is None
    cut = read_field_file(HEADER + "\n".join(plain + rows[:-1] + ["30,0,0,0,3.7E-3"]), "mm").cut
    assert cut is not None and "2 significant digit(s) where the column's other values have 10" in cut


def test_the_end_of_a_large_file_is_looked_at_without_splitting_it_whole():
    text = HEADER + "\n".join(f"{k}.5,1.25,2.5,0.000123,0.0{k:07d}" for k in range(200_000)) + "\n9,9,9,9,0.001"
    tracemalloc.start()
    try:
        told = cut_last_value(text, ",", 4)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4_000_000  # the file is 7 MB; its 200,000 lines split whole held some 16 MB
    assert told is not None and "'0.001' has 3 decimal(s)" in told
