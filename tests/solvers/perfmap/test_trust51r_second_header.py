"""Two tables in one file or sheet, each under its own header (trust51r probe): the second header was skipped as an
unreadable line and its rows read under the first header's columns and units: flows in kg/s under a first header's
lb/s, 2.2 times too small, with only a note that one line was skipped. A second header that moves a column or states
another unit (or a row of units under it that does) is refused naming its line; a header repeated as it is, and a
title row between the tables, are skipped as before and the rows read."""

from __future__ import annotations

import io

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.conftest import DATA

LINES = (DATA / "n3_fan_map.csv").read_text().splitlines()
ROWS = [line.split(",")[1:] for line in LINES[1:] if line.startswith("0.0,")]  # one speed setting: phi, flow, PR, eff
FIRST, SECOND = ROWS[:30], ROWS[30:]
HEADER = "phi,flow,PR,efficiency"


def _csv(*blocks: tuple[str, list[list[str]]]) -> str:
    return "\n".join(header + "\n" + "\n".join(",".join(r) for r in rows) for header, rows in blocks) + "\n"


def _read(text: str):
    return parse_upload(StoredInput.from_bytes("rig.csv", text.encode()), {"map": False})


def _kg_s(rows):
    return [[r[0], f"{float(r[1]) * 0.45359237:.6f}", r[2], r[3]] for r in rows]


@pytest.mark.parametrize("second, rows, needle", [
    ("phi,flow [kg/s],PR,efficiency", _kg_s(SECOND), "'flow [kg/s]' (above: 'flow [lb/s]')"),
    ("flow [lb/s],phi,PR,efficiency", [[r[1], r[0], r[2], r[3]] for r in SECOND], "flow in column 1 (above: 2)"),
])
def test_a_second_header_reading_its_columns_otherwise_is_refused_naming_its_line(second, rows, needle):
    with pytest.raises(InputRejected) as refused:
        _read(_csv(("phi,flow [lb/s],PR,efficiency", FIRST), (second, rows)))
    (error,) = refused.value.errors
    assert error.loc == ("file", "row", len(FIRST) + 2) and "second header" in error.msg and needle in error.msg


def test_a_second_headers_units_row_stating_other_units_is_refused():
    text = _csv((HEADER, FIRST)) + "phi,flow,PR,efficiency\n-,kg/s,-,-\n" + "\n".join(",".join(r) for r in _kg_s(SECOND))
    with pytest.raises(InputRejected) as refused:
        _read(text + "\n")
    (error,) = refused.value.errors
    assert error.loc == ("file", "row", len(FIRST) + 3) and "'flow' in 'kg/s'" in error.msg


def test_a_header_repeated_as_it_is_and_a_title_between_are_skipped_and_every_row_read():
    whole = _read(_csv((HEADER, ROWS)))
    text = _csv((HEADER, FIRST)) + "Run 2\n" + _csv((HEADER, SECOND))
    split = _read(text)
    assert [p.flow for p in split.positions] == [p.flow for p in whole.positions]
    assert {w.code for w in split.upload_warnings} >= {"upload_rows_skipped"}


def test_a_workbook_with_a_second_table_in_percent_is_refused_naming_its_row():
    openpyxl = pytest.importorskip("openpyxl")
    book = openpyxl.Workbook()
    sheet = book.active
    for header, rows in ((HEADER, FIRST), ("phi,flow,PR,efficiency [%]", [r[:3] + [f"{float(r[3]) * 100:.2f}"]
                                                                          for r in SECOND])):
        sheet.append(header.split(","))
        for row in rows:
            sheet.append([float(v) for v in row])
        sheet.append([])
    content = io.BytesIO()
    book.save(content)
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("rig.xlsx", content.getvalue()), {"map": False})
    (error,) = refused.value.errors
    assert error.loc == ("file", "row", len(FIRST) + 3) and "'efficiency [%]' (above: 'efficiency')" in error.msg
