"""A scan whose header names x, y, z beside a column of text (a point's name: ``Point,X,Y,Z`` over ``P12,...``, a
surveyor's ``name x y z``, a label after z) is read from the named columns, the text column left out and said
(``text_column_skipped``). Its rows were taken for more header, and the valid file was refused as holding "no
readable 'x y z' rows"."""

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.upload import parse_upload

POINTS = np.loadtxt(Path(__file__).parents[3] / "examples" / "tube" / "scan.xyz")


def _read(name: str, text: str, options=None):
    request = parse_upload(StoredInput.from_bytes(name, text.encode()), options)
    return np.asarray(request.points), {w.code: w for w in request.source.warnings}


@pytest.mark.parametrize(("name", "header", "row", "left_out"), [
    ("scan.csv", "Point,X,Y,Z", "P{k},{x:.3f},{y:.3f},{z:.3f}", ["Point"]),
    ("scan.txt", "name x y z", "pt-{k} {x:.3f} {y:.3f} {z:.3f}", ["name"]),
    ("scan.csv", "x;y;z;label", "{x:.3f};{y:.3f};{z:.3f};weld{k}", ["label"]),
    ("scan.csv", "Point,Northing,Easting,Elevation,Code", "{k},{y:.3f},{x:.3f},{z:.3f},TUBE", ["Code"]),
])
def test_a_text_column_beside_named_x_y_z_is_left_out_and_said(name, header, row, left_out):
    text = header + "\n" + "".join(row.format(k=k, x=x, y=y, z=z) + "\n" for k, (x, y, z) in enumerate(POINTS))
    points, warned = _read(name, text)
    np.testing.assert_allclose(points, POINTS, atol=5e-4)
    said = warned["text_column_skipped"]
    assert said.details == {"columns": left_out, "header_line": 1} and repr(left_out[0]) in said.message


def test_the_unit_the_named_columns_state_is_read():
    text = "Point,X [m],Y [m],Z [m]\n" + "".join(f"P{k},{x / 1000:.6f},{y / 1000:.6f},{z / 1000:.6f}\n"
                                               for k, (x, y, z) in enumerate(POINTS))
    points, warned = _read("scan.csv", text, {"units": "mm"})
    np.testing.assert_allclose(points, POINTS, atol=5e-4)
    assert "text_column_skipped" in warned


def test_a_row_with_text_in_a_coordinate_column_is_left_out_and_named():
    rows = [f"P{k},{x:.3f},{y:.3f},{z:.3f}" for k, (x, y, z) in enumerate(POINTS)]
    rows[5] = "P5,n/a,1.0,2.0"
    points, warned = _read("scan.csv", "Point,X,Y,Z\n" + "\n".join(rows) + "\n")
    np.testing.assert_allclose(points, np.delete(POINTS, 5, axis=0), atol=5e-4)
    assert warned["records_skipped"].details["lines"] == [7]


def _comma(v: float) -> str:
    return f"{v:.3f}".replace(".", ",")


@pytest.mark.parametrize(("name", "head", "row"), [
    # a decimal comma (a spreadsheet's European export), between semicolons or tabs
    ("scan.csv", "Point;X;Y;Z\n", lambda k, x, y, z: f"P{k};{_comma(x)};{_comma(y)};{_comma(z)}"),
    ("scan.txt", "Point\tX\tY\tZ\n", lambda k, x, y, z: f"P{k}\t{_comma(x)}\t{_comma(y)}\t{_comma(z)}"),
    # a line of units between the header and the rows
    ("scan.csv", "Point,X,Y,Z\n,mm,mm,mm\n", lambda k, x, y, z: f"P{k},{x:.3f},{y:.3f},{z:.3f}"),
    ("scan.csv", "Point,X,Y,Z\n-,mm,mm,mm\n", lambda k, x, y, z: f"P{k},{x:.3f},{y:.3f},{z:.3f}"),
    # a header written as a comment, as a CloudCompare or a script writes it
    ("scan.txt", "# name x y z\n", lambda k, x, y, z: f"pt{k} {x:.3f} {y:.3f} {z:.3f}"),
    # quoted cells: numbers, and a name holding the delimiter
    ("scan.csv", "Point,X,Y,Z\n", lambda k, x, y, z: f'P{k},"{x:.3f}","{y:.3f}","{z:.3f}"'),
    ("scan.csv", "Point,X,Y,Z\n", lambda k, x, y, z: f'"P {k}, north",{x:.3f},{y:.3f},{z:.3f}'),
])
def test_a_text_column_is_left_out_in_a_spreadsheets_layouts(name, head, row):
    text = head + "".join(row(k, x, y, z) + "\n" for k, (x, y, z) in enumerate(POINTS))
    points, warned = _read(name, text)
    np.testing.assert_allclose(points, POINTS, atol=5e-4)
    assert warned["text_column_skipped"].details["columns"] in (["Point"], ["name"])


def test_the_units_line_under_a_header_with_a_text_column_is_read():
    text = "Point,X,Y,Z\n,m,m,m\n" + "".join(f"P{k},{x / 1000:.6f},{y / 1000:.6f},{z / 1000:.6f}\n"
                                            for k, (x, y, z) in enumerate(POINTS))
    points, _ = _read("scan.csv", text, {"units": "mm"})
    np.testing.assert_allclose(points, POINTS, atol=5e-4)


def test_a_trailing_delimiter_is_no_column_of_its_own():
    text = "Point,X,Y,Z,\n" + "".join(f"P{k},{x:.3f},{y:.3f},{z:.3f},\n" for k, (x, y, z) in enumerate(POINTS))
    points, warned = _read("scan.csv", text)
    np.testing.assert_allclose(points, POINTS, atol=5e-4)
    assert warned["text_column_skipped"].details["columns"] == ["Point"]


@pytest.mark.parametrize(("header", "row", "said"), [
    ("name x y z", "pt {k} {x:.3f} {y:.3f} {z:.3f}", "line 2 holds 5 cells ('pt 0 "),
    ("Point,X,Y,Z", "P{k},{x:.3f},{y:.3f},{z:.3f},extra", "line 2 holds 5 cells ('P0,"),
])
def test_rows_that_match_no_reading_of_the_header_are_refused_naming_both(header, row, said):
    text = header + "\n" + "".join(row.format(k=k, x=x, y=y, z=z) + "\n" for k, (x, y, z) in enumerate(POINTS))
    with pytest.raises(InputRejected) as refused:
        _read("scan.txt", text)
    message = refused.value.errors[0].msg
    assert "the header on line 1 names 4 columns" in message and said in message
