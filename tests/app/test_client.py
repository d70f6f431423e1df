"""plantsolve.client against the app over real HTTP: submit (JSON and files), wait with progress over
Server-Sent Events or by polling, results, artifacts (SHA-256 checked), cancel, and every error as an
exception carrying its problem document."""

from __future__ import annotations

import asyncio
import json
import subprocess
import sys
import time

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from plantsolve.client import (
    AsyncClient,
    Client,
    Conflict,
    InvalidInput,
    Job,
    JobFailed,
    NotFound,
    Unauthorized,
    UnsupportedMediaType,
)
from tests.conftest import REPO, service_settings
from tests.support.live import live_server


def fast(tmp_path, **overrides):
    return service_settings(tmp_path, events_poll_seconds=0.05, **overrides)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with live_server(create_app(fast(tmp_path_factory.mktemp("client")))) as url:
        yield url


def test_submit_wait_with_progress_result_and_artifacts(server, tmp_path):
    seen: list[Job] = []
    with Client(server) as client:
        job = client.submit("test-compute", {"values": [3.0, 4.0], "seconds": 2.0}, idempotency_key="client-1")
        assert job.status in ("queued", "running") and job.kind == "test-compute"
        done = client.wait(job, progress=seen.append, timeout=60)
        assert done.status == "succeeded" and done.finished and done.fraction == 1.0
        fractions = [j.fraction for j in seen]
        assert fractions == sorted(fractions) and len(set(fractions)) >= 5  # live: 20 steps over 2 s, not two polls
        assert seen[-1].status == "succeeded"
        assert client.result(done)["norm"] == 5.0
        files = client.download_artifacts(done, tmp_path / "out")
        assert sorted(p.name for p in files) == ["summary.json", "values.txt"]
        assert (tmp_path / "out" / "values.txt").read_bytes() == b"3.0\n4.0"
        assert json.loads((tmp_path / "out" / "summary.json").read_text())["total"] == 7.0
        assert client.artifact(done, "values.txt") == b"3.0\n4.0"
        # the same key and body: the same job
        assert client.submit("test-compute", {"values": [3.0, 4.0], "seconds": 2.0}, idempotency_key="client-1").id == job.id


def test_file_upload_with_options(server):
    with Client(server) as client:
        job = client.submit("test-compute", file=("numbers.txt", b"1\n2\n2.5\n"), options={"seconds": 0})
        assert client.wait(job.id, timeout=60).status == "succeeded"
        assert client.result(job)["total"] == 5.5
        with pytest.raises(UnsupportedMediaType) as error:
            client.submit("test-compute", file=("numbers.csv", b"1\n"))
        assert ".txt" in error.value.detail


def test_errors_carry_the_problem_document(server):
    with Client(server) as client:
        with pytest.raises(InvalidInput) as invalid:
            client.submit("test-compute", {"values": [1.0, "x"]})
        assert invalid.value.status == 422 and invalid.value.errors[0]["loc"] == ["values", 1]
        assert invalid.value.problem["type"].endswith("/invalid-input")
        with pytest.raises(NotFound):
            client.job("00000000-0000-0000-0000-000000000000")
        with pytest.raises(NotFound):
            client.wait("00000000-0000-0000-0000-000000000000", timeout=10)
        failed = client.wait(client.submit("test-fail", {"message": "no fit"}), timeout=60)
        assert failed.status == "failed" and failed.report["stage"] == "fit"
        with pytest.raises(Conflict) as conflict:
            client.result(failed)
        assert conflict.value.extra["report"]["message"] == "no fit"
        with pytest.raises(JobFailed) as job_failed:
            client.wait(failed, raise_on_failure=True)
        assert job_failed.value.job.id == failed.id


def test_cancel_and_timeout(server):
    with Client(server) as client:
        job = client.submit("test-compute", {"values": [1.0], "seconds": 30})
        started = time.monotonic()
        with pytest.raises(TimeoutError):
            client.wait(job, timeout=0.5)
        assert time.monotonic() - started < 5
        assert client.cancel(job).status == "cancelled"
        assert client.wait(job, timeout=10).status == "cancelled"
        finished = client.wait(client.submit("test-compute", {"values": [1.0]}), timeout=60)
        with pytest.raises(Conflict) as conflict:
            client.cancel(finished)
        assert conflict.value.extra["status"] == "succeeded"


def test_jobs_iterates_every_page(server):
    with Client(server) as client:
        ids = {client.submit("test-compute", {"values": [float(i)]}).id for i in range(5)}
        listed = [job.id for job in client.jobs(kind="test-compute", page_size=2)]
        assert ids <= set(listed) and len(listed) == len(set(listed))


def test_waiting_falls_back_to_polling_without_the_event_stream(tmp_path):
    app = create_app(fast(tmp_path))
    app.router.routes[:] = [r for r in app.router.routes if not getattr(r, "path", "").endswith("/events")]  # an older server
    seen: list[Job] = []
    with live_server(app) as url, Client(url) as client:
        job = client.submit("test-compute", {"values": [2.0], "seconds": 1.0})
        done = client.wait(job, progress=seen.append, poll_seconds=0.1, timeout=60)
        assert done.status == "succeeded" and client.result(done)["total"] == 2.0
        fractions = [j.fraction for j in seen]
        assert fractions == sorted(fractions) and len(set(fractions)) >= 3 and seen[-1].status == "succeeded"


def test_async_client(server, tmp_path):
    async def scenario() -> None:
        fractions: list[float] = []

        async def progress(job: Job) -> None:  # a coroutine callback is awaited
            fractions.append(job.fraction)

        async with AsyncClient(server) as client:
            job = await client.submit("test-compute", {"values": [6.0, 8.0], "seconds": 0.5})
            done = await client.wait(job, progress=progress, timeout=60)
            assert done.status == "succeeded" and fractions == sorted(fractions) and fractions[-1] == 1.0
            assert (await client.result(done))["norm"] == 10.0
            files = await client.download_artifacts(done, tmp_path / "async")
            assert (tmp_path / "async" / "values.txt").read_bytes() == b"6.0\n8.0" and len(files) == 2
            assert [j.id async for j in client.jobs(kind="test-compute", page_size=50) if j.id == job.id] == [job.id]
            with pytest.raises(InvalidInput):
                await client.submit("test-compute", {"values": []})
            polled = await client.wait(await client.submit("test-compute", {"values": [1.0]}), events=False,
                                       poll_seconds=0.05, timeout=60)
            assert polled.status == "succeeded"

    asyncio.run(scenario())


def test_api_keys_and_an_in_process_transport(tmp_path):
    with TestClient(create_app(fast(tmp_path, api_keys=["alice:key-a"]))) as http:
        with pytest.raises(Unauthorized):
            Client(http=http).submit("test-compute", {"values": [1.0]})
        client = Client(api_key="key-a", http=http)
        job = client.wait(client.submit("test-compute", {"values": [1.0, 2.0]}), timeout=60)
        assert client.result(job)["total"] == 3.0


def test_the_example_script_submits_waits_and_downloads(server, tmp_path):
    numbers = tmp_path / "numbers.txt"
    numbers.write_text("3\n4\n")
    run = subprocess.run(
        [sys.executable, str(REPO / "examples" / "client" / "submit_and_wait.py"), "--url", server, "test-compute",
         str(numbers), "--options", '{"seconds": 0.5}', "--artifacts", str(tmp_path / "artifacts"),
         "-o", str(tmp_path / "result.json")],
        capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    assert json.loads((tmp_path / "result.json").read_text())["norm"] == 5.0
    assert (tmp_path / "artifacts" / "values.txt").read_text() == "3.0\n4.0"
    assert "succeeded" in run.stderr and "100%" in run.stderr
    bad = subprocess.run([sys.executable, str(REPO / "examples" / "client" / "submit_and_wait.py"), "--url", server,
                          "test-compute", str(numbers), "--options", '{"seconds": -1}'],
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "seconds" in bad.stderr


def _view(status: str, *codes: str) -> dict:
    return {"id": "j", "kind": "tube", "status": status, "progress": {"fraction": 1.0, "message": ""}, "summary": "",
            "report": {"status": "warning", "warnings": [{"code": c, "message": f"{c} said"} for c in codes]}}


def test_a_job_says_whether_its_result_passes_beside_its_status():
    """'succeeded' means the job ran to its end; ``verdict`` is the first warning saying its answer is no (a failed
    inspection), which a script would otherwise have to know every kind's codes to find."""
    job = Job.from_view(_view("succeeded", "scan_gap", "inspection_failed", "not_converged"))
    assert job.verdict == {"code": "inspection_failed", "message": "inspection_failed said"}
    assert Job.from_view(_view("succeeded", "scan_gap")).verdict is None
    assert Job.from_view(_view("failed", "not_converged")).verdict is None  # a failure says so with its status


def test_the_clients_verdict_codes_are_the_services():
    from plantsolve.schemas.common import VERDICT_CODES as VERDICTS
    from plantsolve.client import VERDICT_CODES

    assert VERDICT_CODES == set(VERDICTS)
