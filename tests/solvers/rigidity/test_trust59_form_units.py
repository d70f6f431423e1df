"""The upload form's ``units`` beside an LDraw file, which states its own unit (LDU): the positions, the result's
lengths and ``contact_tolerance`` stay LDU, and the unit the user meant is said not to be used (it was taken without
a word, a tolerance meant as 0.5 mm read as 0.5 LDU, 0.2 mm)."""

from __future__ import annotations

from pathlib import Path

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

WALL = (Path(__file__).resolve().parents[3] / "examples/rigidity/hinged_wall.ldr").read_bytes()


def solved(options: dict | None):
    return solve(parse_upload(StoredInput.from_bytes("wall.ldr", WALL), options)).result


def test_form_units_beside_an_ldraw_file_are_said_not_used_with_the_tolerance_in_ldu():
    plain = solved(None)
    said = solved({"units": "mm", "contact_tolerance": 0.5})
    (warning,) = [w for w in said.report.warnings if w.code == "units_not_used"]
    assert warning.details["units"] == "mm" and warning.details["contact_tolerance_ldu"] == 0.5
    assert "0.2 mm" in warning.message and "LDU" in warning.message
    # the answer is the file's, in LDU, whatever the form said
    assert said.length_unit == plain.length_unit == "ldu" and said.dof == plain.dof
    assert "units_not_used" not in {w.code for w in plain.report.warnings}


def test_form_units_nested_or_without_a_tolerance_are_said_too():
    (warning,) = [w for w in solved({"units": "in"}).report.warnings if w.code == "units_not_used"]
    assert warning.details["contact_tolerance_ldu"] is None and "'in'" in warning.message
    nested = solved({"units": "cm", "options": {"contact_tolerance": 1}})
    (warning,) = [w for w in nested.report.warnings if w.code == "units_not_used"]
    assert warning.details["contact_tolerance_ldu"] == 1
