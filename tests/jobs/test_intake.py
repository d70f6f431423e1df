"""Intake reads and checks a submission once: the extension and the kind's checks run at submission
only; the worker re-reads the stored input by path and solves it without checking again; every
refusal names its field."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.errors import Unprocessable, UnsupportedMediaType
from plantsolve.jobs.lifecycle import SUCCEEDED
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService
from plantsolve.solvers.base import StoredInput
from plantsolve.store import Store
from tests.conftest import service_settings
from tests.jobs.test_runner import Recorder
from tests.support import kinds as test_kinds


class Counted:
    """The test-compute kind with its parse, load and check counted, and the sources it was given."""

    def __init__(self):
        self.calls = {"parse": 0, "load": 0, "check": 0}
        self.sources: list[StoredInput] = []
        base = test_kinds.SPECS[0]

        def parse(source, options):
            self.calls["parse"] += 1
            self.sources.append(source)
            return base.parse_upload(source, options)

        def load(request, source):
            self.calls["load"] += 1
            return request

        def check(job_input):
            self.calls["check"] += 1
            base.check_input(job_input)

        self.spec = dataclasses.replace(base, parse_upload=parse, load=load, check_input=check)


@pytest.fixture
def counted(tmp_path):
    settings = service_settings(tmp_path)
    kind = Counted()
    ctx = ServiceContext(settings=settings, store=Store.open(settings, migrate=True), kinds={kind.spec.kind: kind.spec})
    yield kind, ctx
    ctx.close()


def test_an_upload_is_checked_once_and_re_read_by_path_in_the_worker(counted):
    kind, ctx = counted
    dispatcher = Recorder()
    service = JobService(ctx, dispatcher)
    job = service.submit_upload("test-compute", "values.txt", b"1\n2\n3\n", '{"seconds": 0}', None).job
    assert kind.calls == {"parse": 1, "load": 1, "check": 1}
    assert kind.sources[0].path is not None and kind.sources[0].read() == b"1\n2\n3\n"  # read from its stored file

    assert run_job(ctx, dispatcher.enqueued[0], worker="test", requeue=lambda *a: None) == SUCCEEDED
    assert kind.calls == {"parse": 2, "load": 2, "check": 1}  # re-read, not checked again
    stored = kind.sources[1]
    assert stored.name == "values.txt" and isinstance(stored.path, Path) and stored.path.is_file()
    assert stored.read() == b"1\n2\n3\n"
    assert service.get(job.id).result["total"] == 6.0


def test_a_json_request_is_checked_once(counted):
    kind, ctx = counted
    dispatcher = Recorder()
    JobService(ctx, dispatcher).submit_json("test-compute", b'{"values": [1.5, 2.5]}', None)
    assert kind.calls == {"parse": 0, "load": 1, "check": 1}
    assert run_job(ctx, dispatcher.enqueued[0], worker="test", requeue=lambda *a: None) == SUCCEEDED
    assert kind.calls == {"parse": 0, "load": 2, "check": 1}


def test_refusals_name_the_field(counted):
    kind, ctx = counted
    service = JobService(ctx, Recorder())
    with pytest.raises(UnsupportedMediaType, match=r"'\.csv' is not accepted"):
        service.submit_upload("test-compute", "values.csv", b"1", None, None)
    with pytest.raises(Unprocessable) as empty:
        service.submit_upload("test-compute", "values.txt", b"", None, None)
    assert empty.value.errors[0]["loc"] == ["file"]
    with pytest.raises(Unprocessable) as options:
        service.submit_upload("test-compute", "values.txt", b"1", "[1, 2]", None)
    assert options.value.errors[0]["loc"] == ["options"]
    with pytest.raises(Unprocessable) as rule:
        service.submit_json("test-compute", b'{"values": [1, 666]}', None)
    assert rule.value.errors[0]["loc"] == ["values", 1]
    assert kind.calls["parse"] == 0  # the extension, the empty file and the options are refused before parsing


def test_stored_input_from_bytes_or_path(tmp_path):
    in_memory = StoredInput.from_bytes("Scan.PLY", b"ply")
    assert (in_memory.extension, in_memory.size, in_memory.read()) == (".ply", 3, b"ply")
    with in_memory.as_file() as path:
        assert path.read_bytes() == b"ply" and path.suffix == ".PLY"
    assert not path.exists()  # the temporary copy is gone
    on_disk = tmp_path / "model.ifc"
    on_disk.write_bytes(b"ISO")
    stored = StoredInput.from_path(on_disk)
    with stored.as_file() as path:
        assert path == on_disk  # no copy
    assert (stored.name, stored.size) == ("model.ifc", 3)
    with pytest.raises(ValueError):
        StoredInput("x.txt")


@pytest.mark.parametrize("value, accepted", [(3.0, 3), (0.0, 0), (3.5, None), (True, None), ("3", None),
                                             (2.0 ** 60, None)])
def test_an_integer_written_with_a_zero_fraction_is_an_integer(value, accepted):
    # the OpenAPI document's JSON Schema counts 3.0 as an integer; strict JSON still refuses a fraction, a boolean,
    # a string, and a float past 2**53 (not an exact integer)
    import json

    from plantsolve.jobs import intake
    from plantsolve.solvers.kinds import KINDS

    units = {"basis": "format", "factor": 1.0, "file_unit": "", "request_unit": "mm"}
    body = {"points": [[float(i), 0.0, 0.0] for i in range(100)],
            "source": {"format": "xyz", "points": value, "units": units}}
    if accepted is None:
        with pytest.raises(Unprocessable) as refused:
            intake.read_json(KINDS["tube"], json.dumps(body).encode())
        (error,) = refused.value.errors
        assert error["loc"] == ["source", "points"] and error["type"] == "int_type"
        return
    raw, _ = intake.read_json(KINDS["tube"], json.dumps(body).encode())
    assert raw["source"]["points"] == accepted and type(raw["source"]["points"]) is int
