"""Mistakes of the fourth probe: options.file_units contradicting the unit a file states was followed with no word
when the request was in the option's unit (a gbXML in feet read as metres: 2,000 m³ for 56.6 m³)."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

DATA = Path(__file__).parent / "data"


def _result(name: str, options=None):
    return solve(parse_upload(StoredInput.from_path(DATA / name), options)).result


def test_file_units_contradicting_a_gbxml_length_unit_is_warned_naming_both():
    stated = _result("revit_room_feet.xml")
    assert stated.total_volume == pytest.approx(2000 * 0.3048 ** 3)
    overridden = _result("revit_room_feet.xml", {"file_units": "m"})
    assert overridden.total_volume == pytest.approx(2000.0)  # as asked, but no longer silently
    (warning,) = [w for w in overridden.report.warnings if w.code == "file_unit_overridden"]
    assert warning.details["file_unit"] == "ft" and warning.details["option"] == "m"
    assert warning.details["basis"] == "lengthUnit" and "states ft" in warning.message


def test_file_units_on_an_idf_is_warned_energyplus_lengths_being_metres():
    result = _result("openstudio_two_offices.idf", {"file_units": "ft", "units": "ft"})
    (warning,) = [w for w in result.report.warnings if w.code == "file_unit_overridden"]
    assert warning.details == {"file_unit": "m", "option": "ft", "basis": "format", "factor": 0.3048}
    assert result.total_volume == pytest.approx(120.0)  # the file's 120 m³ read as 120 ft³: said now
    assert "always metres" in warning.message


def test_file_units_agreeing_with_the_file_says_nothing_more():
    result = _result("revit_room_feet.xml", {"file_units": "ft"})
    assert not [w for w in result.report.warnings if w.code == "file_unit_overridden"]


def test_file_units_on_an_ifc_that_assigns_no_length_unit_state_what_it_left_open():
    """IFC reads a project without a length unit in metres; an option naming the unit contradicts nothing there
    (before: warned that the file 'states m')."""
    text = (DATA / "ifcopenshell_spaces.ifc").read_text().replace("IFCUNITASSIGNMENT((#2,#3,#4))",
                                                                   "IFCUNITASSIGNMENT((#3,#4))")
    stated = _result("ifcopenshell_spaces.ifc")
    left_open = solve(parse_upload(StoredInput.from_bytes("spaces.ifc", text.encode()), {"file_units": "mm"})).result
    assert left_open.total_volume == pytest.approx(stated.total_volume, rel=1e-12)
    assert not [w for w in left_open.report.warnings if w.code == "file_unit_overridden"]
