"""A pyCycle map file cut after its tables (an interrupted copy): its tables read whole, but the statements after
them, where pyCycle states the flow's unit (``units['WcMap'] = 'lbm/s'``), were lost without a word; the map came
out with a flow of no unit and a clean report."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.conftest import DATA

NCP01 = (DATA / "pycycle" / "ncp01.py").read_text()
UNITS_LINE = NCP01[:NCP01.index("NCP01.units['WcMap']")].count("\n") + 1


def _read(text: str):
    return parse_upload(StoredInput.from_bytes("ncp01.py", text.encode()), None)


def _codes(request) -> dict:
    return {w.code: w for w in request.upload_warnings}


@pytest.mark.parametrize("cut_after, line, unit", [
    ("NCP01.units['WcMap'] ", UNITS_LINE, None),  # a statement that does nothing: its value is cut off
    ("NCP01.units['WcMap'] = 'lb", UNITS_LINE, None),  # a string never closed
    ("NCP01.output_data.append({'name': 'WcMap', 'values': NCP01.WcMap,\n", None, "lbm/s"),  # a call never closed
])
def test_a_map_cut_after_its_tables_warns_naming_the_line_and_the_unit_it_lost(cut_after, line, unit):
    cut = NCP01[:NCP01.index(cut_after) + len(cut_after)]
    request = _read(cut)
    warning = _codes(request)["truncated_file"]
    expected_line = line or cut.count("\n")
    assert warning.details["line"] == expected_line and f"line {expected_line}" in warning.message
    assert request.units.flow == unit
    assert (f"({unit})" in warning.message) if unit else ("no unit of the flow" in warning.message)
    assert len(request.positions) == len(_read(NCP01).positions)  # the tables are whole


@pytest.mark.parametrize("text", [NCP01, NCP01.rstrip("\n"), NCP01 + "\n# end of map\n"])
def test_a_whole_map_with_or_without_its_last_line_end_says_nothing_of_a_cut(text):
    request = _read(text)
    assert "truncated_file" not in _codes(request) and request.units.flow == "lbm/s"
