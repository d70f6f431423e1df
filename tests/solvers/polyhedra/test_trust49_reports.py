"""One name per concept in polyhedra's reports: the objects of a file its reader skipped were 'objects_skipped' in a
succeeded job's report and 'skipped_lines' in a failed one's (the runner's reader notes), so a client looking for the
one missed the other."""

from __future__ import annotations

from pathlib import Path

from plantsolve.jobs.reader_notes import reader_warnings
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

DATA = Path(__file__).parent / "data"


def test_skipped_objects_have_one_code_whether_the_job_succeeds_or_fails():
    content = (DATA / "sketchup_two_rooms.obj").read_bytes().rstrip()
    cut = content[:content.rfind(b" ")]  # the last face line cut after two of its vertices
    last = cut.count(b"\n") + 1
    request = parse_upload(StoredInput.from_bytes("cut.obj", cut), None)
    succeeded = {w.code: w for w in solve(request).result.report.warnings}
    failed = {w["code"]: w for w in reader_warnings(request)}  # what the runner puts in a failure report
    assert "skipped_lines" in succeeded and "skipped_lines" in failed and "objects_skipped" not in succeeded
    assert succeeded["skipped_lines"].details["lines"] == failed["skipped_lines"]["details"]["lines"] == [last]
