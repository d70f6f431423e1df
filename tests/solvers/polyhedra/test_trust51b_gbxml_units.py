"""A gbXML ShellGeometry states its own unit (``unit``): one that is not the file's lengthUnit was neither read nor
said, the space's volume taken in lengthUnit whatever the shell said. The file contradicts itself; the shell is still
read in lengthUnit, as the surfaces are (one building in one unit, so that a lengthUnit of Feet over metres is still
named by the plausibility checks), and the contradiction is named with its line and what the other reading gives."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from tests.conftest import REPO

OFFICES = (REPO / "examples" / "polyhedra" / "offices.xml").read_bytes()  # the store is a 3 x 2 x 2.5 m shell


def _solved(content: bytes):
    return solve(parse_upload(StoredInput.from_bytes("offices.xml", content), None)).result


def test_a_shell_unit_that_is_not_the_files_is_named_with_its_line():
    result = _solved(OFFICES.replace(b'unit="Meters"', b'unit="Feet"'))
    assert {z.id: z.volume for z in result.zones}["Space_S"] == pytest.approx(15.0)
    (warning,) = [w for w in result.report.warnings if w.code == "shell_unit_differs"]
    assert warning.details == {"line": 24, "unit": "Feet", "lengthUnit": "Meters"}
    assert OFFICES.decode("utf-8-sig").splitlines()[23].strip().startswith('<ShellGeometry id="sgSpace_S"')
    assert f"would be {0.3048 ** 3:.4g} times as large" in warning.message


def test_a_shell_in_the_files_unit_says_nothing_more():
    result = _solved(OFFICES)
    assert "shell_unit_differs" not in [w.code for w in result.report.warnings]


def test_a_feet_length_unit_over_metres_is_still_named_as_a_building_too_low():
    result = _solved(OFFICES.replace(b'lengthUnit="Meters"', b'lengthUnit="Feet"'))
    codes = [w.code for w in result.report.warnings]
    assert "shell_unit_differs" in codes and "implausible_building_height" in codes
