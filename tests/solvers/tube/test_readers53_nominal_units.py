"""A nominal table's header reads a length unit by any spelling of the one table (``length_units``): ``(inches)``
and ``[millimetres]`` were refused as unknown units, and ``[µm]`` took the column for no length column at all."""

import pytest

from plantsolve.solvers.tube.nominal_files import read_nominal_csv

ROWS = "\n3.15,,90,0.7\n1.77,90,45,0.7\n1.18,-45,30,0.7\n2.76\n"


@pytest.mark.parametrize(("unit", "mm"), [("in", 25.4), ("inches", 25.4), ("Inch", 25.4), ("millimetres", 1.0),
                                          ("µm", 1e-3), ("cm", 10.0)])
def test_a_nominal_header_unit_is_read_by_any_spelling(unit, mm):
    nominal = read_nominal_csv(f"length ({unit}),rotation,angle,clr ({unit})" + ROWS)
    assert [r.length for r in nominal.rows] == pytest.approx([3.15 * mm, 1.77 * mm, 1.18 * mm, 2.76 * mm])
    assert nominal.rows[0].bend_radius == pytest.approx(0.7 * mm)
