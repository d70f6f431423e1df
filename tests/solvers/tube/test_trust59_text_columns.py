"""A scan whose header names x, y, z beside a column of text (a point's name: ``Point,X,Y,Z`` over ``P12,...``, a
surveyor's ``name x y z``, a label after z) is read from the named columns, the text column left out and said
(``text_column_skipped``). Its rows were taken for more header, and the valid file was refused as holding "no
readable 'x y z' rows"."""

from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
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
