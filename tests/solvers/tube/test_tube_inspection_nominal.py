"""The nominal of an inspection as shops give it: XYZ-CLR ↔ LRA on hand-computable tubes, CSV tables in the
forms benders and CAD write (and this service's own lra.csv / xyz_clr.csv), and clear 422s naming line or
point."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from plantsolve.schemas.tube import TubeOptions
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.tube.nominal_files import (
    NominalError,
    read_nominal_csv,
    resolve_nominal,
    rows_from_xyz_clr,
    xyz_clr_from_rows,
)
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.validation import check_input

# a corner of a box: +x 100, +y 100, then +z 100 (or -z), CLR 20 at both corners
CORNER = [[0, 0, 0], [100, 0, 0], [100, 100, 0], [100, 100, 100]]


def lra(rows):
    return np.array([[r.length, r.rotation, r.angle, r.bend_radius] for r in rows])


def test_xyz_clr_to_lra_on_a_box_corner():
    # L = leg − CLR·tan(A/2) at each bend end: 100 − 20 = 80, 100 − 2·20 = 60, 80; A = 90° twice. After the
    # first bend the in-plane normal points along −x; the second bend turns toward +z: −x → +z about the
    # tangent +y is +90° by the right-hand rule (and −90° toward −z).
    np.testing.assert_allclose(lra(rows_from_xyz_clr(CORNER, [20, 20])),
                               [[80, 0, 90, 20], [60, 90, 90, 20], [80, 0, 0, 0]], atol=1e-9)
    down = [p[:2] + [-p[2]] for p in CORNER]
    assert rows_from_xyz_clr(down, [20, 20])[1].rotation == pytest.approx(-90.0, abs=1e-9)


def test_xyz_clr_to_lra_of_a_60_degree_bend():
    s = np.sqrt(3) / 2
    rows = rows_from_xyz_clr([[0, 0, 0], [100, 0, 0], [150, 100 * s, 0]], [10])
    t = 10 * np.tan(np.radians(30))  # tangent length CLR·tan(A/2)
    np.testing.assert_allclose(lra(rows), [[100 - t, 0, 60, 10], [100 - t, 0, 0, 0]], atol=1e-9)


def test_lra_to_xyz_clr_is_the_inverse():
    pts, clr = xyz_clr_from_rows(rows_from_xyz_clr(CORNER, [20, 20]))
    np.testing.assert_allclose(pts, CORNER, atol=1e-9)
    np.testing.assert_allclose(clr, [20, 20])


@pytest.mark.parametrize("points, clr, where, text", [
    ([[0, 0, 0], [100, 0, 0], [200, 0, 0]], [10], 1, "collinear"),
    ([[0, 0, 0], [100, 0, 0], [100, 0, 0], [0, 50, 0]], [10, 10], 2, "coincides"),
    ([[0, 0, 0], [10, 0, 0], [10, 10, 0], [20, 10, 0]], [20, 20], 1, "overlap"),
    ([[0, 0, 0], [100, 0, 0], [100, 100, 0]], [0], 1, "CLR"),
])
def test_impossible_xyz_clr_names_the_point(points, clr, where, text):
    with pytest.raises(NominalError) as exc:
        rows_from_xyz_clr(points, clr)
    assert exc.value.where == where and text in exc.value.msg


def test_own_lra_and_xyz_clr_csv_are_read():
    # the headers this service writes (artifacts.lra_csv / xyz_clr_csv)
    own_lra = ("row,length_mm,rotation_deg,angle_deg,bend_radius_mm\n1,80.000000,0.000000,90.000000,20.000000\n"
               "2,60.000000,90.000000,90.000000,20.000000\n3,80.000000,0.000000,0.000000,0.000000\n")
    own_xyz = ("point,x_mm,y_mm,z_mm,clr_mm\n0,0.000000,0.000000,0.000000,\n1,100.000000,0.000000,0.000000,20.000000\n"
               "2,100.000000,100.000000,0.000000,20.000000\n3,100.000000,100.000000,100.000000,\n")
    want = [[80, 0, 90, 20], [60, 90, 90, 20], [80, 0, 0, 0]]
    a, b = read_nominal_csv(own_lra), read_nominal_csv(own_xyz)
    np.testing.assert_allclose(lra(a.rows), want, atol=1e-9)
    np.testing.assert_allclose(lra(b.rows), want, atol=1e-9)
    assert "LRA" in a.source and "XYZ-CLR" in b.source and not a.warnings and not b.warnings


@pytest.mark.parametrize("text", [
    "80 0 90 20\n60 90 90 20\n80\n",                                    # blank separated, last row length only
    "Bend;Y [mm];B [deg];C [deg];CLR [mm]\n1;80;0;90;20\n2;60;90;90;20\n3;80;0;0;0\n",  # YBC with units
    "L;R;A;CLR\n80,0;0;90;20\n60,0;90;90;20\n80,0;0;0;0\n",             # decimal commas
    "# bender export\nlength\trotation\tangle\tclr\n80\t0\t90\t20\n60\t90\t90\t20\n80\t0\t0\t0\n",
    "X,Y,Z,CLR\n0,0,0\n100,0,0,20\n100,100,0,20\n100,100,100\n",        # ends without CLR field
    "0 0 0\n100 0 0 20\n100 100 0 20\n100 100 100\n",                   # headerless XYZ: first point has no CLR
    "L[in],R,A,CLR[in]\n3.1496062992,0,90,0.7874015748\n2.3622047244,90,90,0.7874015748\n3.1496062992,0,0,0\n",
    "L,R,A_rad,CLR\n80,0,1.5707963267948966,20\n60,90,1.5707963267948966,20\n80,0,0,0\n",
])
def test_csv_forms_give_the_same_nominal(text):
    np.testing.assert_allclose(lra(read_nominal_csv(text, units="mm").rows),
                               [[80, 0, 90, 20], [60, 90, 90, 20], [80, 0, 0, 0]], atol=1e-6)


def test_an_unreadable_row_of_numbers_is_refused_naming_its_line():
    # skipped, the table would be a part with a bend fewer, which the inspection judges the scan against
    with pytest.raises(NominalError, match="line 3 cannot be read .*another part") as error:
        read_nominal_csv("L,R,A,CLR\n80,0,90,20\n60,ninety,90,20\n60,90,90,20\n80,0,0,0\n")
    assert error.value.where == 3
    with pytest.raises(NominalError, match="line 5 cannot be read"):  # the end straight, cut
        read_nominal_csv("L,R,A,CLR\n80,0,90,20\n60,90,90,20\n80,0,0,0\n8O,0,0,0\n")


def test_a_title_line_holding_numbers_above_the_header_is_still_only_skipped():
    got = read_nominal_csv("Part,4711,Rev,3\nL,R,A,CLR\n80,0,90,20\n60,90,90,20\n80,0,0,0\n")
    assert len(got.rows) == 3 and [w.details["line"] for w in got.warnings] == [1]


def test_unreadable_lines_before_or_after_the_rows_are_skipped_with_a_warning_naming_them():
    got = read_nominal_csv("L,R,A,CLR\nas drawn,,,\n80,0,90,20\n60,90,90,20\n80,0,0,0\nchecked: J. Doe,,,\n")
    assert len(got.rows) == 3
    assert [w.details["line"] for w in got.warnings] == [2, 6]
    assert "line 2" in got.warnings[0].message and "line 6" in got.warnings[1].message


def test_first_rotation_is_read_as_zero_with_a_warning():
    got = read_nominal_csv("80 15 90 20\n60 90 90 20\n80 0 0 0\n")
    assert got.rows[0].rotation == 0 and got.warnings[0].code == "nominal_first_rotation"


def test_nominal_in_the_options_takes_any_form():
    a = resolve_nominal(TubeOptions(nominal_xyz_clr=[{"x": p[0], "y": p[1], "z": p[2], "clr": c}
                                                     for p, c in zip(CORNER, [None, 20, 20, None])]))
    np.testing.assert_allclose(lra(a.rows)[1], [60, 90, 90, 20], atol=1e-9)
    with pytest.raises(ValidationError, match="give the nominal once"):
        TubeOptions(nominal=[{"length": 10}], nominal_csv="10\n")


@pytest.fixture(scope="module")
def cloud(tk_module):
    return tk_module.scan(tk_module.SHAPES["bend90"], n=500)[1]


def _rejected(cloud, tk_module, **opts):
    with pytest.raises(InputRejected) as exc:
        check_input(TubeScan(tk_module.request(cloud, **opts)))
    return exc.value.errors


@pytest.mark.parametrize("text, loc, words", [
    ("x,y,z,clr\n0,0,0,\n1,0,0,5\n2,0,0,5\n3,0,0,\n", ("options", "nominal_csv"), ["line 3", "collinear"]),
    ("foo,bar\nx,y\n", ("options", "nominal_csv"), ["no column"]),
    ("L,R,A,CLR\none,two,three,four\n", ("options", "nominal_csv"), ["no row", "line 2"]),
    ("L,R,A,CLR\n80,0,90,20\n60,0,45,20\n", ("options", "nominal_csv"), ["line 3", "final straight"]),
    ("1 2 3\n4 5 6\n", ("options", "nominal_csv"), ["3 columns"]),
])
def test_unusable_csv_is_a_422_naming_the_line(cloud, tk_module, text, loc, words):
    errors = _rejected(cloud, tk_module, nominal_csv=text)
    assert errors[0].loc == loc and all(w in errors[0].msg for w in words), errors[0].msg


def test_unusable_xyz_clr_is_a_422_naming_the_point(cloud, tk_module):
    pts = [{"x": 0, "y": 0, "z": 0}, {"x": 100, "y": 0, "z": 0}, {"x": 100, "y": 100, "z": 0}]
    errors = _rejected(cloud, tk_module, nominal_xyz_clr=pts)
    assert errors[0].loc == ("options", "nominal_xyz_clr", 1, "clr")


def test_example_nominal_files_are_the_example_requests_nominal():
    import json

    from tests.conftest import REPO

    ex = REPO / "examples" / "tube"
    want = lra([TubeOptions(**json.loads((ex / "scan_request.json").read_text())["options"]).nominal][0])
    for name in ("nominal_lra.csv", "nominal_xyz_clr.csv"):
        got = read_nominal_csv((ex / name).read_text())
        np.testing.assert_allclose(lra(got.rows), want, atol=1e-3)  # the XYZ file holds 4 decimals
        assert not got.warnings


def test_title_lines_above_the_header_are_skipped_with_a_warning():
    got = read_nominal_csv("Part 4711 rev B\nCustomer: ACME\nL;R;A;CLR\n80;0;90;20\n60;90;90;20\n80;0;0;0\n")
    np.testing.assert_allclose(lra(got.rows), [[80, 0, 90, 20], [60, 90, 90, 20], [80, 0, 0, 0]])
    assert [w.details["line"] for w in got.warnings] == [1, 2]
