"""A text upload means the same whatever a Windows tool saved it as: UTF-16 with its mark ("Unicode text"), UTF-8
behind a mark, CRLF or CR line ends. Each kind's example and public files, read through the intake as uploaded, give
the same request as the UTF-8 original (before: UTF-16 JSON was 'invalid JSON', a UTF-16 PCF had 'no PCF
components', UTF-16 XYZ/CSV points were 'not UTF-8', an IFC behind a mark had 'No schema loaded')."""

from __future__ import annotations

import codecs
from pathlib import Path

import pytest

from plantsolve.jobs.intake import check, read_upload
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.kinds import KINDS

ROOT = Path(__file__).parents[2]
FILES = [
    ("alignment", "examples/alignment/ladder.json"),
    ("alignment", "examples/alignment/ladder.pcf"),
    ("alignment", "tests/solvers/alignment/data/revit_caps_materials.pcf"),
    ("flowmeter", "examples/flowmeter/meter.json"),
    ("perfmap", "examples/perfmap/n3_fan_map.json"),
    ("perfmap", "examples/perfmap/n3_fan_map.csv"),
    ("polyhedra", "examples/polyhedra/gable_house.json"),
    ("polyhedra", "tests/solvers/polyhedra/data/1ZoneUncontrolled.idf"),  # EnergyPlus (BSD-3-like, data/README.md)
    ("polyhedra", "tests/solvers/polyhedra/data/ifcopenshell_spaces.ifc"),
    ("rigidity", "examples/rigidity/four_bar_and_door.json"),
    ("rigidity", "tests/solvers/rigidity/omr/889-1-RadarTruck.mpd"),  # OMR, CC BY 2.0 (omr/README.md)
    ("tube", "examples/tube/scan.xyz"),
    ("tube", "examples/tube/scan_request.json"),
]
SAVED_AS = {
    "utf-16-le with mark": lambda text: text.encode("utf-16"),
    "utf-16-be with mark": lambda text: codecs.BOM_UTF16_BE + text.encode("utf-16-be"),
    "utf-16-le without mark": lambda text: text.encode("utf-16-le"),
    "utf-16-be without mark": lambda text: text.encode("utf-16-be"),
    "utf-8 with mark": lambda text: codecs.BOM_UTF8 + text.encode(),
    "crlf": lambda text: text.replace("\n", "\r\n").encode(),
}
OPTIONS = {"scan.xyz": {"pipe_radius": 6.0}}


def _read(kind: str, name: str, content: bytes):
    spec = KINDS[kind]
    job_input = read_upload(spec, StoredInput.from_bytes(name, content), OPTIONS.get(name))
    check(spec, job_input)
    request = getattr(job_input, "request", job_input)
    return request.model_dump(exclude={"source_encoding", "source_pcf"})


@pytest.mark.parametrize("saved_as", SAVED_AS)
@pytest.mark.parametrize("kind, path", FILES, ids=[Path(p).name for _, p in FILES])
def test_a_text_upload_reads_the_same_whatever_encoding_and_line_ends_it_was_saved_with(kind, path, saved_as):
    text = (ROOT / path).read_bytes().decode("utf-8-sig").replace("\r\n", "\n")
    name = Path(path).name
    assert _read(kind, name, SAVED_AS[saved_as](text)) == _read(kind, name, text.encode())


def test_an_aligned_pcf_is_written_back_in_the_utf16_it_came_in():
    from plantsolve.solvers.alignment.artifacts import render_artifacts
    from plantsolve.solvers.alignment.solve import solve

    text = (ROOT / "examples/alignment/ladder.pcf").read_text()
    spec = KINDS["alignment"]
    request = read_upload(spec, StoredInput.from_bytes("ladder.pcf", text.encode("utf-16")), None)
    assert request.source_encoding == "utf-16"
    aligned = next(a for a in render_artifacts(request, solve(request)) if a.name == "aligned.pcf")
    assert aligned.data[:2] == codecs.BOM_UTF16_LE and "charset=utf-16" in aligned.media_type
    assert aligned.data.decode("utf-16").splitlines()[:3] == text.splitlines()[:3]
