"""Bounded intake: hostile submissions, scaled down to the same shape,
answer a 422 naming the field quickly, counted before anything is built; uploads are read in a bounded
process, so a reader that runs away costs that process, never the API. The full sizes run in
bench/hostile.py."""

from __future__ import annotations

import io
import json
import resource
import time
import zipfile

import numpy as np
import pytest

from plantsolve.jobs import intake
from plantsolve.jobs.errors import Unprocessable
from plantsolve.solvers.kinds import load_kinds
from plantsolve.solvers.base import StoredInput
from tests.conftest import wait_for


def cpu_seconds() -> float:
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time() + children.ru_utime + children.ru_stime


def timed(call):
    """The call's response and the CPU seconds it cost this process and the readers it forked and reaped: a
    refusal's cost, which a loaded machine's wall clock would multiply."""
    start = cpu_seconds()
    response = call()
    return response, cpu_seconds() - start


def test_a_body_past_the_value_budget_is_refused_naming_the_array_before_it_is_parsed(client):
    connections = ",".join('{"from":["C%d",0],"to":["C%d",1]}' % (i, i + 1) for i in range(200_000))
    body = '{"components":[{"id":"C0","kind":"fitting","ports":[{"position":[0,0,0],"direction":[1,0,0]}]}],' \
           '"connections":[' + connections + "]}"
    response, seconds = timed(lambda: client.post("/v1/alignment/jobs", content=body,
                                                  headers={"Content-Type": "application/json"}))
    assert response.status_code == 422
    error = response.json()["errors"][0]
    assert error["loc"] == ["connections"] and error["type"] == "json_too_large"
    assert seconds < 5


def test_an_array_past_its_declared_bound_is_refused_as_counted(client):
    body = '{"joints":[' + ",".join(["1"] * 1_200_000) + "]}"  # past the budget: the bound is met first
    response = client.post("/v1/rigidity/jobs", content=body, headers={"Content-Type": "application/json"})
    assert response.status_code == 422
    error = response.json()["errors"][0]
    assert error["loc"] == ["joints"] and error["type"] == "too_long" and "before validation" in error["msg"]


def workbook(member: str, data: bytes) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("[Content_Types].xml", '<?xml version="1.0"?><Types/>')
        archive.writestr(member, data)
    return buffer.getvalue()


def test_an_xlsx_zip_bomb_is_refused_counting_inflated_bytes(client):
    bomb = workbook("xl/worksheets/sheet1.xml", b"<" + b"a" * (96 * 1024 * 1024))  # ~100 KB that inflate to 96 MB
    assert len(bomb) < 1_000_000
    response, seconds = timed(lambda: client.post("/v1/perfmap/jobs", files={"file": ("rig.xlsx", bomb)}))
    assert response.status_code == 422, response.text
    error = response.json()["errors"][0]
    assert error["loc"] == ["file"] and "inflates" in error["msg"]
    assert seconds < 10


def test_an_xlsx_declaring_a_dtd_is_a_422_not_a_500(client):
    xml = (b'<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;">]>'
           b'<workbook>&lol2;</workbook>')
    response = client.post("/v1/perfmap/jobs", files={"file": ("rig.xlsx", workbook("xl/workbook.xml", xml))})
    assert response.status_code == 422, response.text
    error = response.json()["errors"][0]
    assert error["loc"] == ["file"] and "DTD" in error["msg"]


def test_an_ldraw_fan_out_is_refused_as_it_expands(client):
    lines = []
    for level in range(8):
        lines.append(f"0 FILE m{level}.ldr")
        child = f"m{level + 1}.ldr" if level < 7 else "3001.dat"
        lines += [f"1 16 {i} 0 0 1 0 0 0 1 0 0 0 1 {child}" for i in range(10)]
    text = ("\n".join(lines) + "\n").encode()
    response, seconds = timed(lambda: client.post("/v1/rigidity/jobs", files={"file": ("fan.mpd", text)}))
    assert response.status_code == 422, response.text
    error = response.json()["errors"][0]
    assert error["loc"] == ["file"] and "expands to more than" in error["msg"]
    assert seconds < 10


def test_a_text_cloud_past_the_line_limit_is_refused_before_the_reader_runs(client):
    cloud = b"0 0 0\n" * (intake.MAX_TEXT_LINES + 1)
    response, seconds = timed(lambda: client.post("/v1/tube/jobs", files={"file": ("scan.xyz", cloud)}))
    assert response.status_code == 422
    error = response.json()["errors"][0]
    assert error["loc"] == ["file"] and error["type"] == "too_long"
    assert seconds < 5


def test_an_upload_that_needs_more_memory_than_allowed_is_a_422_and_costs_the_reader_only(tmp_path):
    path = tmp_path / "cloud.npy"
    np.save(path, np.random.default_rng(0).normal(size=(2_000_000, 3)))  # 48 MB read into arrays
    spec = load_kinds()["tube"]
    with pytest.raises(Unprocessable) as refused:
        intake.read_upload_bounded(spec, StoredInput.from_path(path), None, memory_bytes=16 * 1024 * 1024)
    assert refused.value.errors[0]["loc"] == ["file"] and refused.value.errors[0]["type"] == "too_large"
    small = tmp_path / "small.npy"
    np.save(small, np.random.default_rng(0).normal(size=(2_000, 3)))
    intake.read_upload_bounded(spec, StoredInput.from_path(small), None)  # within the bounds: accepted


def test_a_crash_report_names_no_exception_class(client):
    job = client.post("/v1/test-crash/jobs", json={"error": "ValueError", "message": "tuple index out of range"}).json()
    done = wait_for(client, job["id"])
    assert done["status"] == "failed"
    text = json.dumps(done["report"])
    assert "ValueError" not in text and "Error:" not in text



@pytest.mark.parametrize("options,accepted", [({"read_cpu_seconds": 30}, False), ({"read_wait_seconds": 2.5}, True)])
def test_the_read_budget_is_cpu_time_so_a_slow_wall_clock_is_no_refusal(tmp_path, options, accepted):
    plugins = ("tests.support.kinds",)
    spec = load_kinds(plugins)["test-compute"]
    path = tmp_path / "in.txt"
    path.write_text("1\n2\n")
    started = time.monotonic()
    if accepted:  # 2.5 s of waiting on a 1 s CPU budget: a loaded machine's reader, not a runaway one
        intake.read_upload_bounded(spec, StoredInput.from_path(path), options, plugins, seconds=1)
    else:
        with pytest.raises(Unprocessable) as refused:
            intake.read_upload_bounded(spec, StoredInput.from_path(path), options, plugins, seconds=1)
        error = refused.value.errors[0]
        assert error["type"] == "too_slow" and "1 CPU seconds" in error["msg"], error
    assert time.monotonic() - started < 1 * intake.UPLOAD_READ_WALL_FACTOR + 2 + 5
