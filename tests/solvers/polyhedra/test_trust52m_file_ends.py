"""An IDF whose last ';' has no line ending (a hand edit) lost nothing: no `truncated_file` warning, which
said "(the file was cut?)" and taught users to ignore it; text after the last ';' without a line ending still
warns. IFC spaces skipped without a line number are named in the `skipped_lines` message."""

from __future__ import annotations

from pathlib import Path

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

DATA = Path(__file__).parent / "data"
IDF = (DATA / "openstudio_two_offices.idf").read_text()


def warnings_of(text: str) -> dict:
    request = parse_upload(StoredInput.from_bytes("model.idf", text.encode()), None)
    return {w["code"]: w for w in request.source.get("warnings", [])}, request


def test_an_idf_ending_on_its_last_semicolon_without_a_line_ending_is_not_called_cut():
    whole, request = warnings_of(IDF.rstrip())
    assert IDF.rstrip().endswith(";") and "truncated_file" not in whole
    assert len(request.faces) == len(warnings_of(IDF)[1].faces)


def test_text_after_the_last_semicolon_without_a_line_ending_still_warns():
    cut, _ = warnings_of(IDF.rstrip() + "\n\n! Zone 3 follows: Zone, Office")
    assert "(the file was cut?)" in cut["truncated_file"]["message"]
    trailing_comment, _ = warnings_of(IDF.rstrip() + "  ! end;")
    assert "truncated_file" in trailing_comment


def test_an_ifc_space_without_a_representation_is_named_in_the_message():
    request = parse_upload(StoredInput.from_path(DATA / "ifcopenshell_spaces.ifc"), None)
    (warning,) = [w for w in solve(request).result.report.warnings if w.code == "skipped_lines"]
    assert "first: #" in warning.message and "IfcSpace '104': no representation" in warning.message
