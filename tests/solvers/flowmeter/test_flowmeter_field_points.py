"""A magnetic field given as its tools write it: points with their values in any order, COMSOL's spreadsheet
export, a CSV with a header. The known answer is the same field as a flat grid in C order: the same S, to the
last bit for any row order; refusals name the row (or the file's line)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.base import InputRejected, StoredInput, no_progress, validated
from plantsolve.solvers.flowmeter.field_points import PointsNotAGrid, place_on_grid
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.upload import parse_upload
from plantsolve.solvers.flowmeter.validation import check_input

RADIUS, LINER = 50.0, 300.0
SHAPE = (7, 9, 11)  # unequal axes: each wrong order of a flat list is another field


def field(shape=SHAPE):
    x, y, z = (np.linspace(-r, r, n) for r, n in zip((60.0, 55.0, 160.0), shape))
    gx, gy, gz = np.meshgrid(x, y, z, indexing="ij")
    bx = 0.002 * gx * gy / RADIUS**2
    by = 0.01 * (1 + 0.2 * gx / RADIUS + 0.1 * gy / RADIUS) * np.exp(-(gz / 150) ** 2)
    return (x, y, z), np.column_stack([gx.ravel(), gy.ravel(), gz.ravel(), bx.ravel(), by.ravel()])


def request(magnetic_field=None, units="mm", scale=1.0, **options) -> FlowmeterRequest:
    body = {"units": units, "pipe": {"radius": RADIUS * scale, "liner_length": LINER * scale},
            "electrodes": {"shape": "patch", "half_angle": 22.5, "half_length": None},
            "velocity": {"type": "uniform", "mean": 1.0}, "options": options}
    if magnetic_field is not None:
        body["magnetic_field"] = magnetic_field
    req = validated(FlowmeterRequest, body)
    check_input(req)
    return req


def sensitivity(req: FlowmeterRequest) -> float:
    return solve(req, no_progress).result.sensitivity


def grid_form():
    (x, y, z), rows = field()
    return {"type": "grid", "x": x.tolist(), "y": y.tolist(), "z": z.tolist(), "bx": rows[:, 3].tolist(),
            "by": rows[:, 4].tolist()}


@pytest.fixture(scope="module")
def grid_sensitivity() -> float:
    return sensitivity(request(grid_form()))


def test_points_in_any_order_give_the_grid_s_to_the_last_bit(grid_sensitivity):
    _, rows = field()
    fortran = np.column_stack([c.reshape(SHAPE).ravel(order="F") for c in rows.T])  # x fastest, as COMSOL writes
    for ordered in (rows, fortran, rows[np.random.default_rng(3).permutation(len(rows))]):
        assert sensitivity(request({"type": "points", "points": ordered.tolist()})) == grid_sensitivity
    # the same values as a flat list in x-fastest order are another field: the order matters there, not here
    flat_f = {**grid_form(), "bx": fortran[:, 3].tolist(), "by": fortran[:, 4].tolist()}
    assert abs(sensitivity(request(flat_f)) - grid_sensitivity) > 0.01


@settings(max_examples=25, deadline=None)
@given(st.randoms(use_true_random=False))
def test_placing_shuffled_rows_gives_the_same_grid_bit_for_bit(random):
    (x, _, z), rows = field((4, 3, 5))
    order = list(range(len(rows)))
    random.shuffle(order)
    placed = place_on_grid(rows[order])
    assert np.array_equal(placed.x, x) and np.array_equal(placed.z, z)
    assert np.array_equal(placed.by, rows[:, 4].reshape(4, 3, 5)) and np.array_equal(placed.bx, rows[:, 3].reshape(4, 3, 5))


def test_rounding_of_a_coordinate_is_one_grid_line_and_a_repeated_row_is_kept_once():
    (x, _, _), rows = field((4, 3, 5))
    rows = np.vstack([rows, rows[:2]])  # given twice, same values
    rows[5, 0] += 1e-12 * 320  # written with another rounding
    placed = place_on_grid(rows)
    assert placed.bx.shape == (4, 3, 5) and np.array_equal(placed.x, x)


@pytest.mark.parametrize("mistake, row, words", [
    ("drop", None, "has no row"),
    ("duplicate", 60, "is also row 7, with another value"),
    ("off_line", 9, "lies off the grid line"),
])
def test_points_that_make_no_grid_are_refused_naming_the_row(mistake, row, words):
    _, rows = field((4, 3, 5))
    if mistake == "drop":
        rows = rows[1:]
    elif mistake == "duplicate":
        edited = rows[7:8].copy()
        edited[0, 4] *= 1.01
        rows = np.vstack([rows, edited])
    else:
        rows[9, 0] += 0.5
    with pytest.raises(PointsNotAGrid, match=words) as caught:
        place_on_grid(rows)
    assert caught.value.row == row
    with pytest.raises(InputRejected) as refused:
        request({"type": "points", "points": rows.tolist()})
    loc = refused.value.errors[0].loc
    assert loc == (("magnetic_field", "points") if row is None else ("magnetic_field", "points", row))


@pytest.mark.parametrize("value", [6000.0, 1e12, -1e12])
def test_a_mistyped_coordinate_far_beyond_the_grid_is_named_with_its_row(value):
    """One x typed 1e12 (or 6000: metres' digits in mm) among x = -60..60: the line tolerance, taken of the whole
    extent, merged every other x line into one ("every point has x = ..."); now the row is named."""
    _, rows = field((4, 3, 5))
    rows[9, 0] = value
    with pytest.raises(PointsNotAGrid, match="a mistyped coordinate") as caught:
        place_on_grid(rows)
    assert caught.value.row == 9
    with pytest.raises(InputRejected) as refused:
        request({"type": "points", "points": rows.tolist()})
    assert refused.value.errors[0].loc == ("magnetic_field", "points", 9)


def comsol_export(rows: np.ndarray, length_unit: str, field_unit: str) -> str:
    """A COMSOL spreadsheet export (Results > Export > Data) reproduced from its documented layout: '%' header
    lines, the columns' line with each expression's unit, then rows blank separated in the model's length unit,
    x fastest (mesh or grid order)."""
    head = ["% Model:              magnet.mph", "% Version:            COMSOL 6.1.0.252",
            "% Date:               Nov 29 2026, 10:12", "% Dimension:          3",
            f"% Nodes:              {len(rows)}", "% Expressions:        3",
            ("% Description:        Magnetic flux density, x-component, Magnetic flux density, y-component, "
             "Magnetic flux density, z-component"),
            f"% Length unit:        {length_unit}",
            (f"% x                       y                        z                        mf.Bx ({field_unit})"
             f"                mf.By ({field_unit})                mf.Bz ({field_unit})")]
    body = ["  ".join(f"{v:.17g}" for v in (*row, 0.0)) for row in rows]
    return "\n".join(head + body) + "\n"


def fortran_rows(length: float, tesla: float) -> np.ndarray:
    _, rows = field()
    out = np.column_stack([c.reshape(SHAPE).ravel(order="F") for c in rows.T])
    out[:, :3] *= length
    out[:, 3:] *= tesla
    return out


def test_a_comsol_export_in_mm_or_in_m_and_mt_gives_the_grid_s(grid_sensitivity):
    in_mm = solve(request(magnetic_field_file=comsol_export(fortran_rows(1.0, 1.0), "mm", "T")), no_progress).result
    in_m = solve(request(magnetic_field_file=comsol_export(fortran_rows(1e-3, 1e3), "m", "mT")), no_progress).result
    assert in_mm.sensitivity == grid_sensitivity
    assert in_m.sensitivity == pytest.approx(grid_sensitivity, abs=1e-12)
    conversions = {c["quantity"]: c for c in in_m.report.details["source"]["conversions"]}
    assert conversions["magnetic field file: x, y, z"]["factor"] == 1000.0
    assert conversions["magnetic field file: B"]["from_unit"] == "mT"
    assert "COMSOL" in in_m.report.details["source"]["magnetic_field"]


def test_a_csv_with_units_in_its_header_and_columns_in_any_order(grid_sensitivity):
    rows = fortran_rows(1e-1, 1e4)[np.random.default_rng(5).permutation(693)]  # cm and gauss
    text = "By [G];x [cm];y [cm];z [cm];Bx [G]\n" + "\n".join(
        ";".join(f"{v:.15g}".replace(".", ",") for v in row[[4, 0, 1, 2, 3]]) for row in rows)
    assert sensitivity(request(magnetic_field_file=text)) == pytest.approx(grid_sensitivity, abs=1e-12)


def test_a_header_without_units_reads_request_units_and_tesla_and_warns_on_mt():
    rows = fortran_rows(1.0, 1e3)  # mT written under a header that names no unit
    text = "x,y,z,Bx,By\n" + "\n".join(",".join(f"{v:.15g}" for v in row) for row in rows)
    warnings = {w.code: w for w in solve(request(magnetic_field_file=text), no_progress).result.report.warnings}
    assert "no unit for B" in warnings["implausible_magnetic_field"].message


@pytest.mark.parametrize("edit, words", [
    (lambda lines: lines[:9] + ["-60  -55  -160  NaN  NaN  NaN"] + lines[10:], "line 10: a value is NaN"),
    (lambda lines: lines[:-1] + [lines[-1][:20]], r"line 702: \d values for the header's 6 columns \(line 9\); a cut file\?"),
    (lambda lines: lines[:8] + ["% Grid"] + lines[9:], "line 9: '% Grid' is COMSOL's grid or sectionwise format"),
    (lambda lines: lines[:8] + [lines[8].replace("mf.By (T)", "mf.Hy (A/m)")] + lines[9:], "names no column by"),
    (lambda lines: lines + [lines[100].rsplit(" ", 1)[0] + " 1"], "line 703: the point .* is also line 101"),
    (lambda lines: [line for k, line in enumerate(lines) if k != 300], "the grid point .* has no row"),
    (lambda lines: lines[9:], "no header naming its columns"),
])
def test_a_field_file_that_cannot_be_read_is_refused_naming_the_line(edit, words):
    lines = comsol_export(fortran_rows(1.0, 1.0), "mm", "T").splitlines()
    with pytest.raises(InputRejected, match=words) as refused:
        request(magnetic_field_file="\n".join(edit(lines)))
    assert refused.value.errors[0].loc == ("options", "magnetic_field_file")


def test_a_file_and_a_magnetic_field_together_are_refused():
    with pytest.raises(InputRejected, match="given twice"):
        request({"type": "uniform", "magnitude": 0.01}, magnetic_field_file=comsol_export(fortran_rows(1.0, 1.0), "mm", "T"))


def test_an_uploaded_request_takes_the_field_file_from_the_forms_options(grid_sensitivity, tmp_path):
    body = {"units": "mm", "pipe": {"radius": RADIUS, "liner_length": LINER},
            "electrodes": {"shape": "patch", "half_angle": 22.5, "half_length": None},
            "velocity": {"type": "uniform", "mean": 1.0}}
    path = tmp_path / "meter.json"
    path.write_text(json.dumps(body))
    req = parse_upload(StoredInput(name="meter.json", path=path),
                       {"magnetic_field_file": comsol_export(fortran_rows(1e-3, 1.0), "m", "T")})
    check_input(req)
    assert sensitivity(req) == pytest.approx(grid_sensitivity, abs=1e-12)


def test_a_correctly_ordered_flat_grid_varying_along_x_draws_no_warning():
    """The reviewer's grid: B_y linear in x over 5 x 5 x 101 points, in C order. A roughness comparison of axis
    orders called it 20 times rougher than another order; a correct field must draw no warning."""
    from plantsolve.solvers.flowmeter.plausibility import request_warnings

    x, y, z = np.linspace(-60, 60, 5), np.linspace(-60, 60, 5), np.linspace(-300, 300, 101)
    gx = np.meshgrid(x, y, z, indexing="ij")[0]
    req = request({"type": "grid", "x": x.tolist(), "y": y.tolist(), "z": z.tolist(),
                   "bx": np.zeros(gx.size).tolist(), "by": (0.01 * (1 + 0.3 * gx / 50)).ravel().tolist()})
    assert [w.code for w in request_warnings(req, 0.01)] == []


def test_many_thin_grid_lines_are_refused_from_their_counts_at_once():
    """x-lines of 2 rows alternating with x-lines of 1 row: each thin line once cost a pass over all lines (30k
    lines took seconds, 80k 17 s CPU). Were the check quadratic again, this test would turn visibly slow."""
    m = 30_000
    x = np.arange(2 * m - 1, dtype=float)
    per_line = np.where(np.arange(2 * m - 1) % 2 == 0, 2, 1)
    xs = np.repeat(x, per_line)
    rows = np.column_stack([xs, np.arange(len(xs)) % 2, np.arange(len(xs)) % 3 // 2, 0 * xs, 0.01 + 0 * xs])
    with pytest.raises(PointsNotAGrid, match=f"the points lie on {2 * m - 1} distinct x values"):
        place_on_grid(rows)


def plain_csv(rows: np.ndarray, header: str = "x [mm],y [mm],z [mm],Bx [T],By [T]", end: str = "") -> str:
    return header + end + "\n" + "\n".join(",".join(f"{v:.17g}" for v in row[:5]) + end for row in rows) + "\n"


@pytest.mark.parametrize("text", [
    plain_csv(fortran_rows(1.0, 1.0), '"x [mm]","y [mm]","z [mm]","Bx [T]","By [T]"'),  # R's write.csv, pandas
    plain_csv(fortran_rows(1.0, 1.0), end=","),  # a delimiter ending every line
    plain_csv(fortran_rows(1.0, 1e4), "x [MM],y [MM],z [MM],Bx [Gauss],By [Gauss]"),
    plain_csv(fortran_rows(1.0, 1.0), "x [mm],y [mm],z [mm],Bx [tesla],By [tesla]"),
    plain_csv(fortran_rows(1.0, 1e3), "x [mm],y [mm],z [mm],Bx [millitesla],By [millitesla]"),
])
def test_quoted_headers_trailing_delimiters_and_unit_spellings_read_as_the_plain_file(text):
    from plantsolve.solvers.flowmeter.field_file import read_field_file

    plain = read_field_file(plain_csv(fortran_rows(1.0, 1.0)), "mm")
    table = read_field_file(text, "mm")
    np.testing.assert_allclose(table.rows, plain.rows, rtol=1e-15, atol=0)
    assert (table.lines == plain.lines).all() and table.length_unit == "mm"


def test_a_unit_whose_case_decides_it_is_not_read_in_another_case():
    with pytest.raises(InputRejected, match="field unit 'MT' is not known"):  # megatesla, not mT
        request(magnetic_field_file=plain_csv(fortran_rows(1.0, 1e3), "x [mm],y [mm],z [mm],Bx [MT],By [MT]"))


def test_a_contradicting_length_unit_is_refused_and_agreeing_spellings_are_one():
    from plantsolve.solvers.flowmeter.field_file import read_field_file

    comsol = comsol_export(fortran_rows(1.0, 1.0), "m", "T").replace("% x  ", "% x (mm)  ", 1)
    with pytest.raises(InputRejected, match="coordinates are given in m and mm"):
        request(magnetic_field_file=comsol)
    assert read_field_file(comsol_export(fortran_rows(1.0, 1.0), "MM", "T"), "mm").length_unit == "mm"


def test_a_header_stating_mm_over_coordinates_in_metres_is_not_said_to_state_no_unit():
    text = plain_csv(fortran_rows(1e-3, 1.0), "x [mm],y [mm],z [mm],Bx,By")
    with pytest.raises(InputRejected) as refused:
        request(magnetic_field_file=text)
    message = refused.value.errors[0].msg
    assert "does not cover the pipe" in message and "header states its coordinates in mm" in message
    assert "no length unit" not in message


# Header lines that once made the header's patterns backtrack over the whole line for each place in it: seconds
# for tens of kB. The answer is asserted; were a pattern quadratic again, these would turn visibly slow (minutes).
def test_a_long_header_line_of_blanks_reads_in_linear_time():
    from plantsolve.solvers.flowmeter.field_file import read_field_file

    text = "% a" + " " * 100_000 + "b\n% x y z mf.Bx (T) mf.By (T)\n1 2 3 4 5\n"
    assert read_field_file(text, "mm").rows.tolist() == [[1.0, 2.0, 3.0, 4.0, 5.0]]


@pytest.mark.parametrize("text", ["% " + "a(" * 100_000 + "\n1 2 3 4 5\n",
                                  "x,y,z,Bx,By " + "[a" * 100_000 + "\n1,2,3,4,5\n"])
def test_a_long_header_line_of_unclosed_brackets_is_refused_in_linear_time(text):
    from plantsolve.solvers.flowmeter.field_file import FieldFileError, read_field_file

    with pytest.raises(FieldFileError, match=r"line 1: the header names no column .*and \d+ more|names no column by"):
        read_field_file(text, "mm")


def test_a_file_of_more_rows_than_a_grid_has_points_is_refused(monkeypatch):
    from plantsolve.solvers.flowmeter import field as field_module

    monkeypatch.setattr(field_module, "GRID_POINTS_MAX", 692)  # the file's 693 rows, one too many
    with pytest.raises(InputRejected, match="the file holds 693 rows; a field has at most 692 points"):
        request(magnetic_field_file=plain_csv(fortran_rows(1.0, 1.0)))
