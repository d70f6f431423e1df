"""Nominal tables as shops hand them over after a spreadsheet has been at them: rows sorted by another column (their
row numbers kept), a units line under the header, an XYZ-CLR cut after a bend or an LRA read as points. Each is read
right or refused naming its line, never read as another part."""

import numpy as np
import pytest

from plantsolve.schemas.tube import TubeOptions
from plantsolve.solvers.tube.nominal_files import NominalError, nominal_errors, read_nominal_csv

LRA = "row,length,rotation,angle,clr\n1,80,0,90,18\n2,45,90,45,18\n3,30,-45,30,18\n4,70,0,0,0\n"
XYZ = ("point,x,y,z,clr\n0,0,0,0,\n1,98,0,0,18\n2,98,70.4558,0,18\n3,98,100.3516,29.8957,18\n"
       "4,71.546,127.4654,94.4211,\n")
PART = [[80, 0, 90, 18], [45, 90, 45, 18], [30, -45, 30, 18], [70, 0, 0, 0]]


def _lra(nominal):
    return np.array([[r.length, r.rotation, r.angle, r.bend_radius] for r in nominal.rows])


def _lines(text, order):
    lines = text.splitlines()
    return "\n".join([lines[0]] + [lines[k] for k in order]) + "\n"


@pytest.mark.parametrize("text, order", [(LRA, [2, 1, 3, 4]), (LRA, [4, 3, 2, 1]), (XYZ, [1, 2, 4, 3, 5])])
def test_rows_sorted_by_another_column_are_read_in_the_order_of_their_row_numbers(text, order):
    got = read_nominal_csv(_lines(text, order))
    np.testing.assert_allclose(_lra(got), PART, atol=2e-3)
    (warning,) = [w for w in got.warnings if w.code == "nominal_rows_reordered"]
    assert warning.details["lines_in_order"] == [order.index(k) + 2 for k in sorted(order)]


def test_a_row_number_given_twice_is_refused_naming_both_lines():
    with pytest.raises(NominalError, match="lines 2 and 3") as error:
        read_nominal_csv(_lines(LRA, [1, 1, 2, 3, 4]))
    assert error.value.where == 3


def test_rows_in_order_say_nothing():
    assert read_nominal_csv(LRA).warnings == []


@pytest.mark.parametrize("units, factor", [("mm,deg,deg,mm", 1.0), ("in,deg,deg,in", 25.4), ("[m],,,[m]", 1000.0)])
def test_a_units_line_under_the_header_gives_the_columns_units(units, factor):
    text = "length,rotation,angle,clr\n" + units + "\n" + "".join(
        ",".join(line.split(",")[1:]) + "\n" for line in LRA.splitlines()[1:])
    got = read_nominal_csv(text, units="mm")
    expected = np.array(PART, float)
    expected[:, [0, 3]] *= factor
    np.testing.assert_allclose(_lra(got), expected)
    assert got.warnings == []


def test_a_units_line_contradicting_the_header_is_refused_naming_it():
    with pytest.raises(NominalError, match="'length_mm'.*'mm'.*'in'") as error:
        read_nominal_csv("length_mm,rotation,angle,clr\nin,deg,deg,in\n80,0,90,18\n70,0,0,0\n")
    assert error.value.where == 2


@pytest.mark.parametrize("kept", [3, 4, 5])
def test_an_xyz_clr_cut_after_a_bend_is_refused_naming_its_last_line(kept):
    text = "\n".join(XYZ.splitlines()[:kept]) + "\n"
    with pytest.raises(NominalError, match="last point carries a CLR.*cut") as error:
        read_nominal_csv(text)
    assert error.value.where == kept


def test_an_lra_table_read_as_xyz_clr_is_refused_naming_its_first_line():
    rows = "".join(",".join(line.split(",")[1:]) + "\n" for line in LRA.splitlines()[1:])
    with pytest.raises(NominalError, match="first point carries a CLR.*nominal_format to lra") as error:
        read_nominal_csv(rows, "xyz_clr")
    assert error.value.where == 1
    np.testing.assert_allclose(_lra(read_nominal_csv(rows)), PART)  # read as what it is without the wrong option


def test_an_xyz_clr_giving_every_point_the_dies_clr_is_read():
    filled = XYZ.replace("0,0,0,0,\n", "0,0,0,0,18\n").replace("94.4211,\n", "94.4211,18\n")
    np.testing.assert_allclose(_lra(read_nominal_csv(filled)), PART, atol=2e-3)


def test_an_xyz_clr_list_ending_at_a_bend_is_refused_naming_the_point():
    points = [{"x": 0, "y": 0, "z": 0}, {"x": 98, "y": 0, "z": 0, "clr": 18},
              {"x": 98, "y": 70.4558, "z": 0, "clr": 18}]
    (error,) = nominal_errors(TubeOptions(nominal_xyz_clr=points))
    assert error.loc == ("options", "nominal_xyz_clr", 2, "clr") and "end point is missing" in error.msg


def _fixed_decimals(text: str) -> str:
    return text.replace("\n0,0,0,0,", "\n0,0.0000,0.0000,0.0000,").replace(
        "1,98,0,0,18", "1,98.0000,0.0000,0.0000,18").replace("2,98,70.4558,0,18", "2,98.0000,70.4558,0.0000,18")


def test_a_table_cut_inside_its_last_number_is_refused_naming_the_line():
    text = XYZ.replace("94.4211,\n", "94.4211,")[:-(1 + 3)]  # '94.4' of '94.4211,'
    with pytest.raises(NominalError, match="ends inside line 6 .*fewer decimals") as error:
        read_nominal_csv(_fixed_decimals(text))
    assert error.value.where == 6


def test_a_last_number_cut_before_its_decimal_mark_is_warned_and_a_round_end_value_is_read():
    cut = read_nominal_csv(_fixed_decimals(XYZ.replace("94.4211,\n", "94.4211,")[:-(1 + 5)]))  # '94' of '94.4211,'
    (warning,) = [w for w in cut.warnings if w.code == "nominal_last_row_short"]
    assert warning.details == {"line": 6, "value": "94", "decimals_above": 4}
    # a spreadsheet's export without a final line ending: the end row's CLR 0 and a round length are no cut
    table = "L,R,A,CLR\n100.5,0,90,50.8\n200.5,90,45,50.8\n150.5,0,30,50.8\n80.5,0,0,0"
    got = read_nominal_csv(table)
    assert not got.warnings and read_nominal_csv(table + "\n").rows == got.rows


def test_a_whole_table_without_a_final_line_ending_is_read():
    np.testing.assert_allclose(_lra(read_nominal_csv(XYZ.rstrip("\n"))), PART, atol=2e-3)


def test_a_table_ending_inside_a_short_last_row_says_it_may_be_cut():
    got = read_nominal_csv(LRA.rstrip("\n")[:-len("0,0,0,0")])  # '4,7' of '4,70,0,0,0'
    (warning,) = [w for w in got.warnings if w.code == "nominal_last_row_short"]
    assert warning.details == {"line": 5, "values": 2, "values_above": 5} and "'7'" in warning.message
    assert not read_nominal_csv(LRA.rstrip("\n")).warnings  # whole, without its final line ending
    assert not read_nominal_csv(LRA.replace("4,70,0,0,0", "4,70")).warnings  # short, but not at a cut end
