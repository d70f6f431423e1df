"""A gbXML ShellGeometry states its own unit (``unit``, a gbXML length unit): a space read from its shell took the
file's lengthUnit whatever the shell said, its volume off by the cube of the ratio and nothing said. Now the shell is
read in its own unit and a shell unit that is not the file's is named; one gbXML does not have skips that shell."""

from __future__ import annotations

import pytest

from tests.conftest import REPO
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

OFFICES = (REPO / "examples" / "polyhedra" / "offices.xml").read_bytes()  # the store is a 3 x 2 x 2.5 m shell


def _solved(content: bytes):
    request = parse_upload(StoredInput.from_bytes("offices.xml", content), None)
    return request, solve(request).result


def _volumes(result) -> dict:
    return {z.id: z.volume for z in result.zones}


def test_a_shell_in_metres_in_a_millimetre_file_is_read_in_metres_and_named():
    """The store's shell says Meters; the file's surfaces are written in millimetres, as lengthUnit says."""
    text = OFFICES.decode("utf-8-sig").replace('lengthUnit="Meters"', 'lengthUnit="Millimeters"')
    request, result = _solved(text.encode())
    assert _volumes(result)["Space_S"] == pytest.approx(15.0)
    (warning,) = [w for w in result.report.warnings if w.code == "shell_unit_differs"]
    assert warning.details == {"line": 24, "unit": "Meters", "lengthUnit": "Millimeters"}
    assert text.splitlines()[23].strip().startswith('<ShellGeometry id="sgSpace_S" unit="Meters">')


def test_a_shell_in_the_files_unit_says_nothing_more():
    _, result = _solved(OFFICES)
    assert _volumes(result)["Space_S"] == pytest.approx(15.0)
    assert "shell_unit_differs" not in [w.code for w in result.report.warnings]


def test_a_shell_in_feet_in_a_metre_file_is_read_in_feet():
    _, result = _solved(OFFICES.replace(b'unit="Meters"', b'unit="Feet"'))
    assert _volumes(result)["Space_S"] == pytest.approx(15.0 * 0.3048 ** 3)
    assert "shell_unit_differs" in [w.code for w in result.report.warnings]


def test_a_shell_unit_gbxml_does_not_have_skips_the_shell_naming_its_line():
    request, result = _solved(OFFICES.replace(b'unit="Meters"', b'unit="Metres"'))
    assert "Space_S" not in _volumes(result)
    (entry,) = [s for s in request.source["skipped"] if s["object"] == "Space 'Space_S' ShellGeometry"]
    assert entry["line"] == 24 and "'Metres' is not a gbXML length unit" in entry["reason"]
