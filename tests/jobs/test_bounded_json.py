"""A large JSON body (above INLINE_INPUT_BYTES) is read and checked in a bounded process, as an upload is: the API
process holds its bytes, never the objects made of them (a flowmeter field file of two million rows cost the API
2 CPU s and 400 MB). What it answers is what the in-process read answers: the same 422 fields, the same request hash."""

from __future__ import annotations

import json
import os

import pytest

from plantsolve.jobs import intake
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.errors import Unprocessable
from plantsolve.jobs.service import JobService
from plantsolve.solvers.base import StoredInput
from tests.conftest import service_settings
from tests.support.dispatch import Recorder

PLUGINS = ["tests.support.kinds", "tests.jobs.pid_kind"]


@pytest.fixture
def service(tmp_path):
    ctx = ServiceContext.create(service_settings(tmp_path, plugins=PLUGINS, inline_input_bytes=1000), migrate=True)
    yield JobService(ctx, Recorder())
    ctx.close()


def _body(tmp_path, values, spaced: bool = False, **extra) -> bytes:
    document = {"values": values, "pid_file": str(tmp_path / "pid"), **extra}
    return json.dumps(document, indent=1 if spaced else None).encode()


def test_a_large_body_is_checked_in_another_process_and_a_small_one_here(service, tmp_path):
    large = _body(tmp_path, [float(i) for i in range(2000)])
    submitted = service.submit_json("test-pid", large, None)
    assert int((tmp_path / "pid").read_text()) != os.getpid()
    job = submitted.job
    assert job.input_kind == "json_file"
    assert service.ctx.files.get(job.input_file) == large  # stored as it came
    assert job.body_hash == intake.body_hash("test-pid", json.loads(large))
    small = _body(tmp_path, [1.0])
    assert service.submit_json("test-pid", small, None).job.input_kind == "json"
    assert int((tmp_path / "pid").read_text()) == os.getpid()


def test_the_same_large_request_spelled_otherwise_is_the_same_request(service, tmp_path):
    values = [i + 0.25 for i in range(2000)]
    first = service.submit_json("test-pid", _body(tmp_path, values), "key-1")
    again = service.submit_json("test-pid", _body(tmp_path, values, spaced=True), "key-1")
    assert first.created and not again.created and again.job.id == first.job.id
    with pytest.raises(Unprocessable, match="different request"):
        service.submit_json("test-pid", _body(tmp_path, values[:-1]), "key-1")


@pytest.mark.parametrize("values, extra, loc", [
    ([-1.0] + [1.0] * 2000, {}, ["values", 0]),  # the kind's check
    ([1.0] * 2000 + ["x"], {}, ["values", 2000]),  # the schema
    ([1.0] * 2000, {"count": 3.0}, None),  # an integral number where an integer goes: taken, as in this process
    ([1.0] * 2000, {"count": 3.5}, ["count"]),
])
def test_a_large_body_is_answered_as_a_small_one_would_be(service, tmp_path, values, extra, loc):
    body = _body(tmp_path, values, **extra)
    spec = service.spec("test-pid")
    if loc is None:
        assert service.submit_json("test-pid", body, None).created
        raw, _ = intake.read_json(spec, body)
        assert raw["count"] == 3 and isinstance(raw["count"], int)
        return
    with pytest.raises(Unprocessable) as here:
        intake.check(spec, intake.read_json(spec, body)[1])
    with pytest.raises(Unprocessable) as there:
        service.submit_json("test-pid", body, None)
    assert there.value.errors == here.value.errors and there.value.errors[0]["loc"] == loc
    assert there.value.detail == here.value.detail
    assert not list((service.ctx.files.root).glob("*/input/*"))  # a refused body is not kept


def test_a_body_that_needs_more_memory_than_allowed_is_a_422_naming_the_body(tmp_path):
    body = json.dumps({"values": [float(i) for i in range(150_000)], "pid_file": str(tmp_path / "pid")}).encode()
    path = tmp_path / "request.json"
    path.write_bytes(body)
    with pytest.raises(Unprocessable) as refused:
        intake.read_json_bounded(intake.load_kinds(PLUGINS)["test-pid"], StoredInput.from_path(path), PLUGINS,
                                 memory_bytes=4 * 2**20)
    error = refused.value.errors[0]
    assert error["loc"] == [] and error["type"] == "too_large" and "4 MiB a JSON body may take" in error["msg"]
    assert not (tmp_path / "pid").exists()  # the check never ran: the read stopped first

