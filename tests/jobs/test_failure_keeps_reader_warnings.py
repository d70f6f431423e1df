"""A job whose upload was read with warnings and whose solve then fails keeps the reader's warnings in its failure
report, for every kind whose reader leaves any and every way a solve can fail: a failed job is no cleaner than a
succeeded one."""

from __future__ import annotations

import dataclasses
import time

import pytest

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.reader_notes import reader_warnings
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService
from plantsolve.solvers.base import SolverError, StoredInput
from tests.conftest import REPO, service_settings
from tests.support.dispatch import Recorder, stored_upload

EXAMPLES = REPO / "examples"


def _tube() -> bytes:
    return (EXAMPLES / "tube" / "scan.xyz").read_bytes() + b"12.0 abc 4\n"


def _perfmap() -> bytes:
    text = (EXAMPLES / "perfmap" / "n3_fan_map.csv").read_text()
    lines = text.splitlines()
    return "\n".join([lines[0] + ",comment", *(line + ",x" for line in lines[1:])]).encode() + b"\n"


def _rigidity() -> bytes:
    return (EXAMPLES / "rigidity" / "hinged_wall.ldr").read_bytes() + b"1 4 0 0"


def _idf() -> bytes:
    return (EXAMPLES / "polyhedra" / "two_offices.idf").read_bytes().rstrip()


def _gbxml() -> bytes:
    return (EXAMPLES / "polyhedra" / "offices.xml").read_bytes().replace(
        b"<Campus", "<!-- caf\xe9 -->\n<Campus".encode("cp1252"), 1)


# (kind, file name, bytes, a reader's warning code the report must keep, the line or quantity it names)
CASES = [
    ("tube", "scan.xyz", _tube, "records_skipped", "line 4001"),
    ("perfmap", "map.csv", _perfmap, "upload_columns_ignored", "comment"),
    ("rigidity", "wall.ldr", _rigidity, "truncated_file", "line 23"),
    ("polyhedra", "two.idf", _idf, "truncated_file", "line 263"),
    ("polyhedra", "offices.xml", _gbxml, "encoding_assumed", "line 3"),
]


@pytest.fixture
def ctx(tmp_path):
    context = ServiceContext.create(service_settings(tmp_path, soft_time_limits={"tube": 0.2}), migrate=True)
    yield context
    context.close()


def _failing(ctx: ServiceContext, kind: str, solve) -> None:
    ctx.kinds = {**ctx.kinds, kind: dataclasses.replace(ctx.spec(kind), solve=solve, render_artifacts=None)}


def _codes(report: dict) -> list[str]:
    return [w["code"] for w in report.get("warnings") or []]


@pytest.mark.parametrize("kind, name, content, code, names", CASES, ids=[f"{c[0]}-{c[1]}" for c in CASES])
def test_a_failed_solve_keeps_the_readers_warnings(ctx, kind, name, content, code, names):
    data = content()
    job_id = stored_upload(ctx, kind, name, data)

    def fails(job_input, progress):
        raise SolverError("fit", "no bend could be fitted", {"stage_detail": 1})

    _failing(ctx, kind, fails)
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "failed"
    report = ctx.repo.get(job_id).report
    assert (report["status"], report["stage"], report["message"]) == ("failed", "fit", "no bend could be fitted")
    assert report["details"] == {"stage_detail": 1}
    kept = [w for w in report["warnings"] if w["code"] == code]
    assert len(kept) == 1 and names in kept[0]["message"], report["warnings"]
    # the same words a successful report of this file starts with (the kind's solve puts them first there)
    spec = ctx.kinds[kind]
    request = spec.parse_upload(StoredInput.from_bytes(name, data), None)
    assert report["warnings"] == reader_warnings(request)


def test_every_way_a_solve_fails_keeps_them(ctx):
    """A crash (fails at once), running out of memory, the soft time limit, and a machine's error on every attempt
    (re-queued, then failed): each report keeps the reader's word that line 4001 was left out."""

    def crash(job_input, progress):
        raise ZeroDivisionError("float division by zero")

    def memory(job_input, progress):
        raise MemoryError()

    def slow(job_input, progress):
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            progress(0.5, "fitting")
            time.sleep(0.02)
        raise AssertionError("the soft time limit did not stop the solve")

    def disk(job_input, progress):
        raise OSError(5, "Input/output error")

    queue = Recorder()
    for solve, stage in ((crash, "solver"), (memory, "solver"), (slow, "time_limit"), (disk, "infrastructure")):
        job_id = stored_upload(ctx, "tube", "scan.xyz", _tube())
        _failing(ctx, "tube", solve)
        while (outcome := run_job(ctx, job_id, worker="w", requeue=queue.enqueue)) == "requeued":
            assert _codes(ctx.repo.get(job_id).report) == ["records_skipped"]  # the re-queued job's report too
        assert outcome == "failed"
        report = ctx.repo.get(job_id).report
        assert report["stage"] == stage and _codes(report) == ["records_skipped"], (solve.__name__, report)


def test_a_json_request_has_no_reader_warnings(ctx):
    body = (EXAMPLES / "perfmap" / "n3_fan_map.json").read_bytes()
    job_id = JobService(ctx, Recorder()).submit_json("perfmap", body, None).job.id

    def fails(job_input, progress):
        raise SolverError("triangulation", "no non-degenerate triangle of settings")

    _failing(ctx, "perfmap", fails)
    assert run_job(ctx, job_id, worker="w", requeue=Recorder().enqueue) == "failed"
    assert ctx.repo.get(job_id).report["warnings"] == []

