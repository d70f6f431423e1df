"""Two files that read to the right numbers but mislead their user without a word before:

- an IDF whose OutputControl:Table:Style asks EnergyPlus for InchPound tables: its user compares the zone volumes in
  ft3 there with these in m3; the report now says the results are metres and how to have feet (not when the request
  asks for feet already);
- an IFC4 model of spaces whose header says IFC2X3: IfcOpenShell read its quantities as IFC2X3's (a value dropped);
  the report now names the first line written in another schema's attribute count.
"""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from tests.conftest import REPO

IDF = (REPO / "examples" / "polyhedra" / "two_offices.idf").read_text()
IFC = (REPO / "tests" / "solvers" / "polyhedra" / "data" / "ifcopenshell_spaces.ifc").read_text()
INCH_POUND = "\n  OutputControl:Table:Style,\n    HTML,                    !- Column Separator\n    {};\n"


def _read(name: str, text: str, options: dict | None = None):
    return parse_upload(StoredInput.from_bytes(name, text.encode()), options)


def _codes(request) -> dict[str, dict]:
    return {w["code"]: w for w in request.source["warnings"]}


@pytest.mark.parametrize("conversion", ["InchPound", "InchPoundExceptElectricity"])
def test_an_idf_asking_for_inch_pound_tables_is_told_its_results_are_metres(conversion):
    text = IDF + INCH_POUND.format(conversion)
    request = _read("zones.idf", text)
    note = _codes(request)["idf_tables_inch_pound"]
    assert note["details"] == {"line": IDF.count("\n") + 2, "unit_conversion": conversion, "file_unit": "m"}
    assert "options.units = 'ft'" in note["message"]
    result = solve(request).result
    assert result.units == "m" and result.total_volume == pytest.approx(120.0)  # 5 x 4 x 3 m twice


def test_no_inch_pound_note_without_the_style_or_with_the_request_in_feet():
    assert "idf_tables_inch_pound" not in _codes(_read("zones.idf", IDF))
    assert "idf_tables_inch_pound" not in _codes(_read("zones.idf", IDF + INCH_POUND.format("JtoKWH")))
    in_feet = _read("zones.idf", IDF + INCH_POUND.format("InchPound"), {"units": "ft"})
    assert "idf_tables_inch_pound" not in _codes(in_feet)
    assert solve(in_feet).result.total_volume == pytest.approx(120.0 / 0.3048 ** 3)


def test_ifc4_spaces_under_an_ifc2x3_header_name_the_first_misfit_line():
    assert IFC.splitlines()[40].startswith("#34=IFCQUANTITYAREA(") and "FILE_SCHEMA(('IFC4'))" in IFC
    assert "ifc_schema_misfit" not in _codes(_read("spaces.ifc", IFC))
    request = _read("spaces.ifc", IFC.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC2X3'))"))
    note = _codes(request)["ifc_schema_misfit"]
    assert note["details"] == {"line": 41, "entity": "IfcQuantityArea", "written": 5, "expected": 4,
                               "schema": "IFC2X3", "fits": ["IFC4", "IFC4X3_ADD2"]}
    assert note["message"].startswith("line 41: #34=IFCQUANTITYAREA is written with 5 attribute value(s)")
