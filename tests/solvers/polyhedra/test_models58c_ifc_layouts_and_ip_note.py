"""Polyhedra's notes on a file say what was read:

- an IFC model whose instances share lines (two a line, the DATA on one line) is no "schema misfit": models58 cut an
  instance from its line's start to the newline and named '#1=IFCPROJECT is written with 12 attribute value(s)'; a
  real misfit laid out so is still named, by its own line;
- an IDF asking for InchPound tables: the note says the lengths were read in options.file_units' unit when given (it
  said metres), and stays when the request is in inches (it was dropped, though the tables are in feet); only a
  request in feet answers it.
"""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from tests.conftest import REPO

IFC = (REPO / "tests" / "solvers" / "polyhedra" / "data" / "ifcopenshell_spaces.ifc").read_text()
IDF = (REPO / "examples" / "polyhedra" / "two_offices.idf").read_text()
INCH_POUND = IDF + "\n  OutputControl:Table:Style,\n    HTML,                    !- Column Separator\n    InchPound;\n"


def _read(name: str, text: str, options: dict | None = None):
    return parse_upload(StoredInput.from_bytes(name, text.encode()), options)


def _warnings(request) -> dict[str, dict]:
    return {w["code"]: w for w in request.source["warnings"]}


def _two_per_line(text: str) -> str:
    head, data = text.split("DATA;\n", 1)
    body, tail = data.split("ENDSEC;", 1)
    lines = body.splitlines()
    return head + "DATA;\n" + "\n".join("".join(lines[i:i + 2]) for i in range(0, len(lines), 2)) + "\nENDSEC;" + tail


@pytest.mark.parametrize("layout", [_two_per_line, lambda t: t.replace("\n", "")], ids=["two per line", "one line"])
def test_spaces_laid_out_several_a_line_read_as_written_without_a_misfit_note(layout):
    volumes = {z.id: z.volume for z in solve(_read("spaces.ifc", IFC)).result.zones}
    request = _read("spaces.ifc", layout(IFC))
    assert not {"ifc_schema_misfit", "ifc_lines_not_read"} & set(_warnings(request))  # before: a misfit on #1
    assert {z.id: z.volume for z in solve(request).result.zones} == pytest.approx(volumes)


def test_a_misfit_two_instances_a_line_is_named_by_its_own_line():
    text = _two_per_line(IFC.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC2X3'))"))
    note = _warnings(_read("spaces.ifc", text))["ifc_schema_misfit"]
    line = text[:text.index("#34=IFCQUANTITYAREA(")].count("\n") + 1
    assert note["details"] == {"line": line, "entity": "IfcQuantityArea", "written": 5, "expected": 4,
                               "schema": "IFC2X3", "fits": ["IFC4", "IFC4X3_ADD2"]}


def test_the_inch_pound_note_names_the_unit_the_lengths_were_read_in():
    note = _warnings(_read("zones.idf", INCH_POUND, {"file_units": "ft"}))["idf_tables_inch_pound"]
    assert note["details"]["file_unit"] == "ft"  # before: 'm', and "the IDF's lengths are metres"
    assert "read as ft, as options.file_units says" in note["message"] and "results are in m " in note["message"]
    plain = _warnings(_read("zones.idf", INCH_POUND))["idf_tables_inch_pound"]
    assert plain["details"]["file_unit"] == "m" and "lengths are metres" in plain["message"]


def test_the_inch_pound_note_stays_for_a_request_in_inches_and_goes_for_one_in_feet():
    note = _warnings(_read("zones.idf", INCH_POUND, {"units": "in"}))["idf_tables_inch_pound"]  # before: dropped
    assert "results are in in (volumes in in3, areas in in2)" in note["message"]
    assert "idf_tables_inch_pound" not in _warnings(_read("zones.idf", INCH_POUND, {"units": "ft"}))
