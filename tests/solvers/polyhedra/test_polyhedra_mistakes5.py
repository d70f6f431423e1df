"""Plausible mistakes in EnergyPlus files that read with a wrong number and no word before: field notes in feet, a zone
defined twice, a Space's declared floor area."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

OFFICES = (Path(__file__).parents[3] / "examples" / "polyhedra" / "two_offices.idf").read_text()


def _solved(text: str, options: dict | None = None):
    request = parse_upload(StoredInput.from_bytes("offices.idf", text.encode()), options)
    check_input(request)
    return solve(request).result


def test_field_notes_in_feet_are_named_and_file_units_reads_the_numbers_as_feet():
    """An IDF written in feet with '{ft}' notes (an IP export) read as metres gave 60 m³ offices, no word; EnergyPlus
    reads metres too, so the numbers stand, but the notes are named with the option that reads them as feet."""
    feet = OFFICES.replace("{m}", "{ft}")
    result = _solved(feet)
    (warning,) = [w for w in result.report.warnings if w.code == "idf_notes_other_units"]
    first = next(k for k, line in enumerate(feet.splitlines(), 1) if "{ft}" in line and "Origin" in line)
    assert warning.details["units"] == ["ft"] and warning.details["lines"][0] == first and "file_units" in warning.message
    assert [z.volume for z in result.zones] == pytest.approx([60.0, 60.0])
    as_feet = _solved(feet, {"file_units": "ft"})
    assert [z.volume for z in as_feet.zones] == pytest.approx([60.0 * 0.3048 ** 3] * 2)
    plain = _solved(OFFICES)  # metre notes, and notes of other fields ({deg}): nothing said
    assert not [w for w in plain.report.warnings if w.code == "idf_notes_other_units"]
