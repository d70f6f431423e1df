"""A sheet whose header cells without a unit are merged down over the units row (Excel users merge 'theta' over
two rows when only the measured columns have units under them): the merged word was repeated into the units row,
which then read as no units row; the flow's kg/s and the pressure's bar were dropped without a word about units,
the row skipped as 'theta is not a number'."""

from __future__ import annotations

import io

import openpyxl
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.conftest import DATA

ROWS = [[float(v) for v in line.split(",")] for line in (DATA / "n3_fan_map.csv").read_text().splitlines()[1:]]


def _book(merges: list[str]) -> bytes:
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["theta", "phi", "flow", "pressure", "efficiency"])
    ws.append([None, None, "kg/s", "bar", "-"])
    for row in ROWS:
        ws.append(row)
    for cells in merges:
        ws.merge_cells(cells)
    return _saved(wb)


def _saved(wb) -> bytes:
    out = io.BytesIO()
    wb.save(out)
    return out.getvalue()


def _load(content: bytes, options=None):
    source = StoredInput.from_bytes("rig.xlsx", content)
    return load(parse_upload(source, {"map": False, **(options or {})}), source)


@pytest.mark.parametrize("merges", [["A1:A2", "B1:B2"], ["A1:A2"], []])
def test_header_cells_merged_over_the_units_row_keep_the_units_of_the_others(merges):
    loaded = _load(_book(merges), {"result_units": {"pressure": "kPa"}})
    assert (loaded.units.flow, loaded.units.pressure) == ("kg/s", "kPa")
    assert loaded.internal.positions[0].pressure[0] == pytest.approx(107.6, rel=1e-12)  # 1.076 bar
    codes = {w.code for w in loaded.request.upload_warnings}
    assert "upload_units_row" in codes and "upload_rows_skipped" not in codes


def test_a_value_merged_down_its_speed_line_is_still_every_rows_value():
    wb = openpyxl.Workbook()
    ws = wb.active
    ws.append(["theta", "phi", "flow [kg/s]", "pressure [bar]", "efficiency"])
    first = {}
    for n, row in enumerate(ROWS, start=2):
        key = (row[0], row[1])
        shown = [f"{row[0]:g} deg" if key not in first else None, *row[1:]]
        first.setdefault(key, n)
        ws.append(shown)
    for key, start in first.items():
        end = start + sum(1 for row in ROWS if (row[0], row[1]) == key) - 1
        if end > start:
            ws.merge_cells(start_row=start, start_column=1, end_row=end, end_column=1)
    loaded = _load(_saved(wb))
    assert [p.setting for p in loaded.internal.positions] == [
        p.setting for p in _load(_book([])).internal.positions]
