"""Excel rig tables (.xlsx) as exporters and people leave them, written here with openpyxl: each layout is
accepted with the same numbers as the CSV of the same table, or refused with a reason naming the row."""

from __future__ import annotations

import io

import openpyxl
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.solve import solve
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.synthetic import speed_lines

LINES = speed_lines(4, 8, steep=6.0)["positions"]
HEADER = ["Speed [rpm]", "Flow [kg/s]", "Pressure ratio", "Efficiency [%]"]


def data_rows(as_text: bool = False, comma: bool = False):
    for p in LINES:
        for f, pr, e in zip(p["flow"], p["pressure"], p["efficiency"]):
            row = [p["setting"][0] * 1000, f, pr, 100 * e]
            if as_text:
                row = [repr(v).replace(".", ",") if comma else repr(v) for v in row]
            yield row


def workbook(fill, sheets=("Data",)) -> bytes:
    wb = openpyxl.Workbook()
    wb.active.title = sheets[0]
    for name in sheets[1:]:
        wb.create_sheet(name)
    fill(wb)
    buf = io.BytesIO()
    wb.save(buf)
    return buf.getvalue()


def plain(ws, header=HEADER, start=1, **kw):
    ws.append(header) if start == 1 else ws.cell(row=start, column=1)
    if start != 1:
        for j, h in enumerate(header, start=1):
            ws.cell(row=start, column=j, value=h)
    for row in data_rows(**kw):
        ws.append(row)


def check_same_as_lines(req):
    assert len(req.positions) == 4
    for got, want in zip(req.positions, LINES):
        assert got.setting == pytest.approx([want["setting"][0] * 1000])
        assert got.flow == pytest.approx(want["flow"]) and got.pressure == pytest.approx(want["pressure"])
        assert got.efficiency == pytest.approx(want["efficiency"])
    assert req.units.flow == "kg/s" and req.units.pressure == "1" and req.setting_units == ["rpm"]


def test_a_plain_sheet_is_read_like_the_csv():
    req = parse_upload(StoredInput.from_bytes("rig.xlsx", workbook(lambda wb: plain(wb.active))), {"grid": [16, 16]})
    check_same_as_lines(req)
    res = solve(req).result
    assert res.units.flow == "kg/s" and all(s.pressure_excess <= 0.01 for s in res.settings)


def test_title_rows_merged_banner_and_blank_rows_above_the_header():
    def fill(wb):
        ws = wb.active
        ws["A1"] = "Compressor rig 7 — acceptance test"
        ws.merge_cells("A1:D1")
        ws["A2"] = "Inlet: 288.15 K, 101.325 kPa"
        plain(ws, start=5)  # rows 3 and 4 blank
    req = parse_upload(StoredInput.from_bytes("rig.xlsx", workbook(fill)), None)
    check_same_as_lines(req)
    skipped = {w.code: w for w in req.upload_warnings}["upload_rows_above_header"]
    assert skipped.details["rows"] == [1, 2]


def test_numbers_stored_as_text_with_decimal_commas():
    req = parse_upload(StoredInput.from_bytes("rig.xlsx", workbook(lambda wb: plain(wb.active, as_text=True, comma=True))), None)
    check_same_as_lines(req)


def test_a_units_row_under_the_header():
    def fill(wb):
        ws = wb.active
        ws.append(["Speed", "Flow", "Pressure ratio", "Efficiency"])
        ws.append(["[rpm]", "[kg/s]", "[-]", "[%]"])
        for row in data_rows():
            ws.append(row)
    req = parse_upload(StoredInput.from_bytes("rig.xlsx", workbook(fill)), None)
    check_same_as_lines(req)
    assert {w.code: w for w in req.upload_warnings}["upload_units_row"].details["row"] == 2


def test_a_speed_merged_down_its_speed_line():
    def fill(wb):
        ws = wb.active
        ws.append(HEADER)
        r = 2
        for p in LINES:
            first = r
            for f, pr, e in zip(p["flow"], p["pressure"], p["efficiency"]):
                ws.append([p["setting"][0] * 1000 if r == first else None, f, pr, 100 * e])
                r += 1
            ws.merge_cells(start_row=first, start_column=1, end_row=r - 1, end_column=1)
    check_same_as_lines(parse_upload(StoredInput.from_bytes("rig.xlsx", workbook(fill)), None))


def test_a_named_sheet_and_the_first_sheet_with_a_header():
    def fill(wb):
        wb["Notes"]["A1"] = "nothing here but notes"
        plain(wb["Rig"])
        plain(wb["Copy"], header=["Speed [rpm]", "Flow [lbm/s]", "Pressure ratio", "Efficiency [%]"])
    content = workbook(fill, sheets=("Notes", "Rig", "Copy"))
    req = parse_upload(StoredInput.from_bytes("rig.xlsx", content), None)
    check_same_as_lines(req)
    assert {w.code: w for w in req.upload_warnings}["upload_sheet"].details["sheet"] == "Rig"
    assert parse_upload(StoredInput.from_bytes("rig.xlsx", content), {"sheet": "Copy"}).units.flow == "lbm/s"
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.xlsx", content), {"sheet": "Summary"})
    assert e.value.errors[0].loc == ("options", "sheet") and "'Rig'" in e.value.errors[0].msg


# ---------------------------------------------------------------- a row skipped, or the file refused, with its reason


def _skipped(request) -> dict:
    (warning,) = [w for w in request.upload_warnings if w.code == "upload_rows_skipped"]
    return warning.details["skipped"][0]


def test_a_formula_never_calculated_skips_its_row_with_the_reason():
    def fill(wb):
        ws = wb.active
        plain(ws)
        ws["B3"] = "=B2*1.01"  # written by a script: no saved value
    skipped = _skipped(parse_upload(StoredInput.from_bytes("rig.xlsx", workbook(fill)), None))
    assert skipped["line"] == 3 and "sheet 'Data' row 3" in skipped["reason"] and "formula" in skipped["reason"]


def test_an_error_value_skips_its_row_with_the_reason():
    def fill(wb):
        plain(wb.active)
        wb.active["D5"] = "#DIV/0!"
    skipped = _skipped(parse_upload(StoredInput.from_bytes("rig.xlsx", workbook(fill)), None))
    assert skipped["line"] == 5 and "#DIV/0!" in skipped["reason"]


def test_an_incompatible_unit_in_a_sheet_names_the_column():
    content = workbook(lambda wb: plain(wb.active, header=["Speed [rpm]", "Flow [kg]", "Pressure ratio",
                                                           "Efficiency [%]"]))
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.xlsx", content), None)
    assert e.value.errors[0].loc == ("file", "header") and "'Flow [kg]'" in e.value.errors[0].msg


@pytest.mark.parametrize("content, needle", [
    (b"", "not a readable Excel"),
    (b"PK\x03\x04 not really a zip", "not a readable Excel"),
    (b"Speed,Flow,PR,Eff\n1,2,3,0.5\n", "not a readable Excel"),
])
def test_what_is_not_a_workbook_says_so(content, needle):
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.xlsx", content), None)
    assert needle in e.value.errors[0].msg and e.value.errors[0].loc == ("file",)


def test_an_empty_workbook():
    """(An old .xls workbook is refused by the intake, naming .xlsx: test_perfmap_service.py.)"""
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.xlsx", workbook(lambda wb: None)), None)
    assert "empty" in e.value.errors[0].msg


def test_a_workbook_cut_short_is_refused_saying_so():
    content = workbook(lambda wb: plain(wb.active))
    with pytest.raises(InputRejected) as e:
        parse_upload(StoredInput.from_bytes("rig.xlsx", content[:len(content) * 2 // 3]), None)
    (fe,) = e.value.errors
    assert fe.loc == ("file",) and "cut short" in fe.msg and f"{len(content) * 2 // 3:,} bytes" in fe.msg
