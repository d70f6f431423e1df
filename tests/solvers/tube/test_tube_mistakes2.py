"""A second round of mistakes users make with tube files and nominals, each answered by the right number, a
warning naming the quantity, or a refusal naming the field — never a confident wrong result."""

from __future__ import annotations

import json

import numpy as np
import pytest

from plantsolve.schemas.tube import InspectionTolerances, LraRow, TubeRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.inspection import nominal_mixups
from plantsolve.solvers.tube.read_log import ReadLog
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model
from plantsolve.solvers.tube.text_points import read_text_points
from plantsolve.solvers.tube.tolerances import implausible
from plantsolve.solvers.tube.upload import parse_upload
from tests.conftest import REPO

SCAN_XYZ = REPO / "examples" / "tube" / "scan.xyz"
POINTS = np.loadtxt(SCAN_XYZ)


def _points(name: str, content: bytes, options: dict | None = None) -> np.ndarray:
    request = parse_upload(StoredInput.from_bytes(name, content), options or {})
    return np.asarray(request.points, float)


def _decimal_comma(sep: str) -> str:
    return "\n".join(sep.join(f"{v:.3f}".replace(".", ",") for v in row) for row in POINTS) + "\n"


# --- numbers written as a European locale writes them -------------------------------------------------------


@pytest.mark.parametrize("name, sep", [("scan.csv", ";"), ("scan.xyz", " "), ("scan.txt", "\t")])
def test_a_scan_written_with_decimal_commas_gives_the_same_points(name, sep):
    # split at the commas, each row was six numbers and the first three a wrong point (a 999 mm straight tube)
    got = _points(name, _decimal_comma(sep).encode())
    np.testing.assert_allclose(got, POINTS, atol=5e-4)


def test_a_decimal_comma_scan_under_a_semicolon_header_keeps_the_headers_unit():
    got = _points("scan.csv", ("x [m];y [m];z [m]\n" + _decimal_comma(";")).encode())
    np.testing.assert_allclose(got, POINTS * 1000.0, atol=0.5)


@pytest.mark.parametrize("text, expected", [
    ("1,2,3\n4,5,6\n", [[1, 2, 3], [4, 5, 6]]),  # comma-separated integers stay three numbers a row
    ("1, 2, 3\n4, 5, 6\n", [[1, 2, 3], [4, 5, 6]]),
    ("1.5,2.5,3.5\n", [[1.5, 2.5, 3.5]]),
    ("1,5;2,5;3,5\n4;5;6\n", [[1.5, 2.5, 3.5], [4, 5, 6]]),
])
def test_comma_separated_and_decimal_comma_rows_are_told_apart(text, expected):
    got, _ = read_text_points(text.encode(), ReadLog("csv"))
    np.testing.assert_allclose(got, expected)


# --- a nominal that misses the scan the way a mix-up makes it miss ------------------------------------------

EXAMPLE = json.loads((REPO / "examples" / "tube" / "scan_request.json").read_text())
NOMINAL = EXAMPLE["options"]["nominal"]  # 90, 45 and 30 degree bends on an 18 mm CLR, a 6 mm tube
MEASURED = make_model([[r["length"], r["rotation"], r["angle"], r["bend_radius"]] for r in NOMINAL], 6.0)


def _rows(scale_length=1.0, angle=lambda a: a, clr=None) -> list[LraRow]:
    return [LraRow(length=r["length"] * scale_length, rotation=r["rotation"], angle=angle(r["angle"]),
                   bend_radius=(clr if clr is not None and r["bend_radius"] else r["bend_radius"] * scale_length))
            for r in NOMINAL]


def _codes(rows) -> dict:
    return {w.code: w for w in nominal_mixups(MEASURED, rows, "mm")}


def test_a_nominal_that_fits_raises_no_mixup():
    assert _codes(_rows()) == {}


def test_bend_angles_in_radians_in_a_degree_column_are_named():
    warning = _codes(_rows(angle=np.radians))["nominal_angles_in_radians"]
    np.testing.assert_allclose(warning.details["as_degrees"], [90, 45, 30])
    assert "as radians they would be 90.0, 45.0, 30.0°" in warning.message


@pytest.mark.parametrize("factor, pair", [(25.4, "inches and mm"), (1000.0, "m and mm"), (1 / 25.4, "inches and mm")])
def test_nominal_lengths_in_another_unit_are_named_with_the_ratio(factor, pair):
    warning = _codes(_rows(scale_length=factor))["nominal_unit_mismatch"]
    assert warning.details["ratio"] == pytest.approx(factor, rel=1e-9)
    assert pair in warning.message


def test_a_clr_below_the_tubes_radius_is_named_by_row():
    warning = _codes(_rows(clr=3.0))["implausible_nominal_clr"]
    assert warning.details["rows"] == [1, 2, 3] and "below the tube's radius (6 mm)" in warning.message


def test_a_radian_nominal_fails_its_inspection_and_the_report_says_why():
    # before: "inspection FAIL" on every row and the end points, with no word on the radians
    nominal = [{**r, "angle": float(np.radians(r["angle"]))} for r in NOMINAL]
    result = solve(TubeScan(TubeRequest.model_validate({**EXAMPLE, "options": {"nominal": nominal}}))).result
    codes = [w.code for w in result.report.warnings]
    assert result.inspection.verdict == "fail" and "nominal_angles_in_radians" in codes


# --- a PLY header that declares fewer records than the file holds ------------------------------------------


def _ascii_ply(points: np.ndarray, declared: int) -> bytes:
    head = (f"ply\nformat ascii 1.0\nelement vertex {declared}\nproperty double x\nproperty double y\n"
            "property double z\nend_header\n")
    return (head + "\n".join(" ".join(f"{v:.3f}" for v in row) for row in points) + "\n").encode()


def _warning(name: str, content: bytes, code: str):
    request = parse_upload(StoredInput.from_bytes(name, content), {})
    return next((w for w in request.source.warnings if w.code == code), None), np.asarray(request.points)


def test_an_ascii_ply_holding_more_vertices_than_its_header_declares_says_so():
    # before: the last 500 samples were dropped without a word
    warning, points = _warning("scan.ply", _ascii_ply(POINTS, len(POINTS) - 500), "records_beyond_header")
    assert len(points) == len(POINTS) - 500
    assert warning is not None and "500 more line(s) from line 3508 on" in warning.message
    assert warning.details["declared"] == {"vertex": len(POINTS) - 500}
    assert _warning("scan.ply", _ascii_ply(POINTS, len(POINTS)), "records_beyond_header")[0] is None


def test_a_binary_ply_with_bytes_past_its_declared_vertices_says_so_and_a_final_newline_does_not():
    content = (REPO / "examples" / "tube" / "scan.ply").read_bytes()
    warning, _ = _warning("scan.ply", content + np.zeros((2, 3), "<f4").tobytes(), "records_beyond_header")
    assert warning is not None and "24 more bytes" in warning.message
    assert _warning("scan.ply", content + b"\n", "records_beyond_header")[0] is None


# --- a column header whose units disagree -------------------------------------------------------------------


@pytest.mark.parametrize("header", ["x [mm],y [m],z [mm]", "x [m],y,z"])
def test_coordinate_columns_stating_different_units_are_refused_unless_file_units_says(header):
    body = (header + "\n" + "\n".join(",".join(f"{v:.3f}" for v in row) for row in POINTS) + "\n").encode()
    # before: read in the request's unit, y (or x) 1000 times off its header, without a word
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("scan.csv", body), {})
    (error,) = refused.value.errors
    assert f"columns {header.replace(',', ', ')} state different units" in error.msg
    assert "options.file_units" in error.msg
    np.testing.assert_allclose(_points("scan.csv", body, {"file_units": "mm"}), POINTS, atol=5e-4)


# --- inspection tolerances that pass anything ---------------------------------------------------------------


def test_a_millimetre_tolerance_given_to_a_metre_request_is_named():
    nominal_m = [LraRow(length=r.length / 1000, rotation=r.rotation, angle=r.angle, bend_radius=r.bend_radius / 1000)
                 for r in _rows()]
    # before: "length": 1 in a metre request passed every straight within a metre, without a word
    (warning,) = implausible(InspectionTolerances(length=1.0), 0.006, nominal_m, "m")
    assert warning.details["field"] == "length" and "meant in mm (1 mm = 0.001 m)?" in warning.message
    assert warning.details["plausible_up_to"] == pytest.approx(0.024)  # 4 tube radii, over 5 % of the part's 0.28 m
    assert implausible(InspectionTolerances(length=0.001, end_point=0.002), 0.006, nominal_m, "m") == []
    (angle,) = implausible(InspectionTolerances(angle=90.0), 6.0, _rows(), "mm")
    assert angle.details["field"] == "angle" and "90° is more than 10°" in angle.message


def test_tolerances_that_pass_anything_are_warned_in_the_job_report():
    body = {**EXAMPLE, "options": {**EXAMPLE["options"], "inspection_tolerances": {"angle": 90.0}}}
    result = solve(TubeScan(TubeRequest.model_validate(body))).result
    assert result.inspection.verdict == "pass" and result.report.status == "warning"
    assert "implausible_inspection_tolerance" in [w.code for w in result.report.warnings]


def _binary_ply(declared: str, data: np.ndarray) -> bytes:
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(data)}\nproperty {declared} x\n"
            f"property {declared} y\nproperty {declared} z\nend_header\n")
    return head.encode() + data.tobytes()


def test_a_binary_ply_in_the_other_byte_order_is_refused_naming_the_format_line():
    # before: 1,110 of the byte-swapped vertices read as finite noise and were solved, the rest "skipped"
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("scan.ply", _binary_ply("float", POINTS.astype(">f4"))), {})
    msg = refused.value.errors[0].msg
    assert "2890 of 4000 vertices are not coordinates" in msg and "'format binary_little_endian' is wrong" in msg


def test_an_organized_scans_missing_returns_are_no_sign_of_a_wrong_header():
    grid = np.full((3 * len(POINTS), 3), np.nan, "<f4")  # two of three cells without a return, NaN in x, y and z
    grid[::3] = POINTS
    warning, points = _warning("scan.ply", _binary_ply("float", grid), "records_skipped")
    np.testing.assert_allclose(points, POINTS, atol=1e-3)
    assert warning.details["count"] == 2 * len(POINTS)


# --- a nominal that cannot be this tube's tooling does not move the measurement ------------------------------


def _solved(nominal: list[dict] | None):
    options = {"nominal": nominal} if nominal is not None else {}
    return solve(TubeScan(TubeRequest.model_validate({**EXAMPLE, "options": options}))).result


@pytest.mark.parametrize("case, nominal", [
    ("inches", [{**r, "length": r["length"] / 25.4, "bend_radius": r["bend_radius"] / 25.4} for r in NOMINAL]),
    ("CLR below the tube's radius", [{**r, "bend_radius": 3.0 if r["bend_radius"] else 0.0} for r in NOMINAL]),
    ("CLR 1.6 times", [{**r, "bend_radius": r["bend_radius"] * 1.6} for r in NOMINAL]),
])
def test_a_nominal_whose_clrs_cannot_be_the_dies_leaves_the_measured_lra_as_the_scan_alone_gives(case, nominal):
    """Before: the nominal's CLRs started the dies whatever they were, and a nominal in inches moved the measured
    bend radius 18.01 -> 16.98 mm and a straight 29.95 -> 30.24 mm."""
    alone = _solved(None)
    got = _solved(nominal)
    for a, b in zip(alone.lra, got.lra):
        assert (a.length, a.rotation, a.angle, a.bend_radius) == pytest.approx(
            (b.length, b.rotation, b.angle, b.bend_radius), abs=1e-6)
    assert "the nominal's CLRs not used as dies" in got.bend_radius_model.summary
    assert got.bend_radius_model.nominal_clrs is None and got.inspection.verdict == "fail"


def test_a_nominal_of_this_tube_still_starts_the_dies():
    got = _solved(NOMINAL)
    assert got.bend_radius_model.nominal_clrs == [18.0]
    assert "not used as dies" not in got.bend_radius_model.summary


def test_a_ratio_between_two_unit_ratios_names_one_mixup_the_nearest():
    # 11 lies within the slack of both 10 (cm and mm) and 12 (ft and inches): one warning, not two that disagree
    warned = nominal_mixups(MEASURED, _rows(scale_length=11.2), "mm")
    (warning,) = [w for w in warned if w.code == "nominal_unit_mismatch"]
    assert warning.details["unit_ratio"] == 12.0


def test_a_nominal_written_from_the_other_end_raises_no_mixup():
    from plantsolve.solvers.tube.inspection import reversed_rows
    assert _codes(reversed_rows(_rows())) == {}


# --- a PLY header whose types or counts are not its body's --------------------------------------------------


@pytest.mark.parametrize("values", [POINTS, np.round(POINTS, 1)], ids=["3 decimals", "rounded"])
def test_a_ply_of_doubles_declared_float_is_refused_naming_the_header_line(values):
    # before: read as floats, the rounded scan's halves of doubles passed as 2,883 coordinates and were solved
    # (records_beyond_header only); the other was refused as "fewer than 100 distinct points"
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("scan.ply", _binary_ply("float", values.astype("<f8"))), {})
    msg = refused.value.errors[0].msg
    assert msg.startswith("PLY header line 4 ('property float x'): the body holds exactly the bytes of the declared "
                          "records (4000 vertex) with 8-byte doubles")
    got = _points("scan.ply", _binary_ply("double", values.astype("<f8")))
    np.testing.assert_allclose(got, values)  # a 0.1 mm print: 8 samples print alike and each is kept


def test_a_ply_of_floats_with_as_many_bytes_again_is_still_read_with_a_warning():
    twice = np.vstack([POINTS, POINTS[::-1]]).astype("<f4")  # 8,000 float vertices under a count of 4,000
    head = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(POINTS)}\nproperty float x\n"
            "property float y\nproperty float z\nend_header\n")
    warning, points = _warning("scan.ply", head.encode() + twice.tobytes(), "records_beyond_header")
    assert warning is not None and len(points) == len(POINTS)


def test_a_negative_ply_record_count_is_refused_naming_the_header_line():
    # before: numpy read a count of -5 as "all there are", and the whole body was solved
    content = _binary_ply("float", POINTS.astype("<f4")).replace(b"element vertex 4000", b"element vertex -5")
    with pytest.raises(InputRejected, match="PLY header line 3 not understood: 'element vertex -5'"):
        parse_upload(StoredInput.from_bytes("scan.ply", content), {})


# --- a binary STL whose triangle count is not its body's, text renamed .stl ------------------------------------


def _binary_stl(corners: np.ndarray, declared: int) -> bytes:
    records = np.zeros(len(corners), [("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    records["corners"] = corners
    return b"binary stl".ljust(80, b" ") + np.uint32(declared).tobytes() + records.tobytes()


@pytest.mark.parametrize("name", ["scan.xyz", "ladder.pcf"])
def test_text_renamed_stl_is_refused_not_read_as_triangles_of_its_characters(name):
    content = (SCAN_XYZ if name == "scan.xyz" else REPO / "examples" / "alignment" / "ladder.pcf").read_bytes()
    # before: its characters were a count of 808,464,685 triangles and 20,000 "points" up to 1e11 were read
    with pytest.raises(InputRejected, match="not an STL file: it is text"):
        parse_upload(StoredInput.from_bytes("scan.stl", content), {})


def test_a_binary_stl_holding_more_triangles_than_its_header_declares_says_so():
    corners = POINTS[: 3 * 1000].reshape(-1, 3, 3)
    warning, _ = _warning("scan.stl", _binary_stl(corners, 600), "records_beyond_header")
    # before: the last 400 triangles were dropped without a word
    assert warning is not None and warning.details == {"declared": {"triangle": 600}, "beyond": 400}
    assert _warning("scan.stl", _binary_stl(corners, 1000), "records_beyond_header")[0] is None


def test_an_angle_tolerance_in_radians_is_named():
    # before: 0.0087 (0.5° in radians) failed the example's bends on the scan's noise, with no word on the tolerance
    (warning,) = implausible(InspectionTolerances(angle=0.0087), 6.0, _rows(), "mm")
    assert warning.details == {"field": "angle", "tolerance": 0.0087, "units": "deg", "plausible_from": 0.1}
    assert "meant in radians (0.0087 rad = 0.498°)?" in warning.message
    assert implausible(InspectionTolerances(angle=0.5, rotation=0.1), 6.0, _rows(), "mm") == []
