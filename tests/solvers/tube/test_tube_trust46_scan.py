"""Scan text files as instruments and spreadsheets export them: a line of units under the column names, a row
number before x, y, z in a file without a header. Read as the file means them, never as other coordinates."""

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.upload import parse_upload

PTS = np.round(np.random.default_rng(3).normal(size=(200, 3)) * [40.0, 7.0, 5.0] + [100.0, 0.0, 0.0], 3)


def _read(text: str, name: str = "scan.csv"):
    req = parse_upload(StoredInput.from_bytes(name, text.encode()), {})
    return np.array(req.points, dtype=float), req.source


def _rows(pts, sep=",", first=None):
    return "".join(sep.join(([str(first[k])] if first is not None else []) + [f"{v:.3f}" for v in p]) + "\n"
                   for k, p in enumerate(pts))


@pytest.mark.parametrize("header, units, factor", [
    ("x,y,z", "mm,mm,mm", 1.0),
    ("x,y,z", "m,m,m", 1000.0),
    ("X;Y;Z", "[in];[in];[in]", 25.4),
])
def test_a_units_line_under_the_column_names_gives_the_files_unit(header, units, factor):
    sep = ";" if ";" in header else ","
    pts, source = _read(f"{header}\n{units}\n" + _rows(PTS, sep))
    np.testing.assert_allclose(pts, PTS * factor)
    assert source.units.basis == "header" and source.units.factor == pytest.approx(factor)


def test_a_units_line_under_an_index_column_and_x_y_z():
    pts, source = _read("n,x,y,z\n,m,m,m\n" + _rows(PTS, first=range(1, len(PTS) + 1)))
    np.testing.assert_allclose(pts, PTS * 1000.0)
    assert source.units.file_unit == "m"


@pytest.mark.parametrize("start, sep", [(0, " "), (1, ","), (1, "\t")])
def test_a_row_number_before_x_y_z_without_a_header_is_skipped_and_said(start, sep):
    pts, source = _read(_rows(PTS, sep, first=range(start, start + len(PTS))), "scan.xyz")
    np.testing.assert_allclose(pts, PTS)
    (warning,) = [w for w in source.warnings if w.code == "row_numbers_skipped"]
    assert warning.details["x_y_z_columns"] == [2, 3, 4]


def test_a_fourth_column_after_x_y_z_is_not_taken_for_row_numbers():
    pts, source = _read(_rows(PTS, " ", first=None).replace("\n", " 17\n"), "scan.xyz")
    np.testing.assert_allclose(pts, PTS)
    assert not [w for w in source.warnings if w.code == "row_numbers_skipped"]


def test_x_sampled_a_unit_apart_before_y_z_and_a_constant_intensity_stays_x():
    x = np.arange(200.0)
    text = "".join(f"{int(v)},{12.5 * np.cos(v):.4f},{12.5 * np.sin(v):.4f},0.80\n" for v in x)
    pts, source = _read(text, "scan.xyz")
    np.testing.assert_allclose(pts[:, 0], x)
    assert not [w for w in source.warnings if w.code == "row_numbers_skipped"]


def test_a_units_line_contradicting_the_units_in_the_column_names_is_refused_naming_both():
    from plantsolve.solvers.base import InputRejected

    with pytest.raises(InputRejected, match=r"'x \[mm\]' states the unit 'mm' in its name and 'in'"):
        _read("x [mm],y [mm],z [mm]\nin,in,in\n" + _rows(PTS, ",", first=None), "scan.csv")
    pts, _ = _read("x [mm],y [mm],z [mm]\nmm,mm,mm\n" + _rows(PTS, ",", first=None), "scan.csv")  # agreeing: read
    np.testing.assert_allclose(pts, PTS)
