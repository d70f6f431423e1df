"""Numbers as a spreadsheet exports them (a decimal comma, digit grouping, quoted cells, a byte-order mark, trailing
empty columns) are read by one rule in the scan reader and the nominal reader: the same cells give the same numbers
in both, and a row of the other decimal mark is named, never read as another number."""

from __future__ import annotations

import json

import numpy as np
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.nominal_files import NominalError, read_nominal_csv
from plantsolve.solvers.tube.upload import parse_upload
from tests.conftest import REPO

POINTS = np.loadtxt(REPO / "examples" / "tube" / "scan.xyz") * 10.0  # every x beyond 1000: grouped digits
NOMINAL = json.loads((REPO / "examples" / "tube" / "scan_request.json").read_text())["options"]["nominal"]
LRA = np.array([[r["length"], r["rotation"], r["angle"], r["bend_radius"]] for r in NOMINAL]) * [100, 1, 1, 1]


def german(v: float) -> str:
    return f"{v:,.3f}".replace(",", "_").replace(".", ",").replace("_", ".")


# how Excel and LibreOffice write a number in four locales: (cell writer, separator between cells)
LOCALES = {
    "de": (german, ";"),
    "fr": (lambda v: f"{v:,.3f}".replace(",", "\u202f").replace(".", ","), ";"),
    "ch": (lambda v: f"{v:,.3f}".replace(",", "'"), ";"),
    "en_tab": (lambda v: f"{v:,.3f}", "\t"),
    "en_quoted": (lambda v: f'"{v:,.3f}"', ","),
    "de_blank": (lambda v: f"{v:.3f}".replace(".", ","), " "),
}


def _table(rows: np.ndarray, cell, sep: str, header: str | None = None) -> str:
    lines = ([header] if header else []) + [sep.join(cell(v) for v in row) for row in rows]
    return "\ufeff" + "\r\n".join(lines) + "\r\n"


def _scan(text: str) -> np.ndarray:
    return np.asarray(parse_upload(StoredInput.from_bytes("scan.csv", text.encode()), {}).points, float)


@pytest.mark.parametrize("locale", LOCALES)
def test_the_scan_reader_reads_every_locales_numbers(locale):
    # before: 2.515,123 was split at its comma (x 2.515, y 123), with no word; 2 515,123 and 2,515.123 were refused
    # as "samples on 2 parallel planes", a quoted "2,515.123" as "no readable x y z rows"
    cell, sep = LOCALES[locale]
    np.testing.assert_allclose(_scan(_table(POINTS, cell, sep)), POINTS, atol=5e-4)


@pytest.mark.parametrize("locale", LOCALES)
def test_the_nominal_reader_reads_every_locales_numbers_as_the_scan_reader_does(locale):
    # before: a decimal comma between blanks, grouped digits or a byte-order mark refused the nominal
    cell, sep = LOCALES[locale]
    header = sep.join(["length", "rotation", "angle", "clr"]) if sep != " " else "length rotation angle clr"
    nominal = read_nominal_csv(_table(LRA, cell, sep, header))
    got = [[r.length, r.rotation, r.angle, r.bend_radius] for r in nominal.rows]
    np.testing.assert_allclose(got, LRA, atol=5e-4)
    assert nominal.warnings == []


def test_one_rule_decides_the_mark_and_the_value_of_a_cell():
    from plantsolve.solvers.tube.number_cells import decimal_mark, number  # new: the rule both readers share

    assert decimal_mark([["251,5", "-112,4", "30"]], ";") == ","
    assert decimal_mark([["2,515.5", "1"]], "\t") == "."
    assert decimal_mark([["251,5"]], ",") == "."  # a comma-separated file writes a decimal point
    assert number("2.515,5", ",") == 2515.5 and number("2 515,5", ",", blank_is_delimiter=False) == 2515.5
    assert number("2,515.5", ".") == 2515.5 and number("+1,5e3", ",") == 1500.0
    for cell, mark in [("2.515", ","), ("1,234", "."), ("12.5", ",")]:  # grouped, or the other mark: cannot tell
        with pytest.raises(ValueError, match="writes a"):
            number(cell, mark)


def test_a_row_of_the_other_decimal_mark_is_named_not_read_as_another_number():
    rows = [";".join(f"{v:.3f}".replace(".", ",") for v in row) for row in POINTS]
    rows[30] = ";".join(f"{v:.3f}" for v in POINTS[30])
    request = parse_upload(StoredInput.from_bytes("scan.csv", ("\n".join(rows) + "\n").encode()), {})
    assert len(request.points) == len(POINTS) - 1
    assert request.source.skipped_lines == [31]
    assert "a number of the other decimal mark (the file writes decimal commas)" in request.source.warnings[0].message
    with pytest.raises(NominalError, match="line 3 cannot be read .'8.000' writes a decimal point in a file "
                                           "written with decimal commas"):
        read_nominal_csv("length;rotation;angle;clr\n80,5;0;90;18\n8.000;45;45,5;18\n30;0;0;0\n")
    with pytest.raises(NominalError, match="'8.000' writes a decimal point"):
        read_nominal_csv("length;rotation;angle;clr\n8.000;0;90,5;18,5\n")


def test_a_quoted_decimal_comma_in_a_comma_separated_file_is_refused_naming_the_line_not_a_500():
    # before the rule was shared this path gave no reason; "251,500" there is 251500 (Excel) or 251.5 (LibreOffice)
    text = "\n".join(",".join('"' + f"{v:.3f}".replace(".", ",") + '"' for v in row) for row in POINTS) + "\n"
    with pytest.raises(InputRejected) as refused:
        _scan(text)
    msg = refused.value.errors[0].msg
    assert "(lines 1, 2, 3," in msg
    assert "4000 a number of the other decimal mark (the file writes decimal points)" in msg


def test_a_row_grouped_by_blanks_among_plain_decimal_comma_rows_is_read_cell_by_cell():
    rows = [";".join(f"{v:.3f}".replace(".", ",") for v in row) for row in POINTS]
    rows[40] = ";".join(f"{v:,.3f}".replace(",", " ").replace(".", ",") for v in POINTS[40])  # 2 620,710
    np.testing.assert_allclose(_scan("\n".join(rows) + "\n"), POINTS, atol=5e-4)
