"""Scaled mode for real: PostgreSQL + Redis + Celery worker subprocesses started with the
``plantsolve worker`` command. Skipped with a printed reason when the services are down,
except under CI=true where they must run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from plantsolve.app.main import create_app
from tests.conftest import REPO, service_settings, wait_for

pytestmark = pytest.mark.integration

BIN = Path(sys.executable).parent
ALIVE = 2.0  # WORKER_ALIVE_SECONDS of these tests' API and workers (the workers beat every 0.3 s)


def _env(pg_url: str, redis_url: str, data_dir: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.update(
        DATABASE_URL=pg_url,
        BROKER_URL=redis_url,
        DATA_DIR=str(data_dir),
        PLUGINS="tests.support.kinds",
        MIN_FREE_DISK_BYTES="0",  # a CI machine short of disk: these tests are about the queue and the workers
        HEARTBEAT_SECONDS="0.3",
        LEASE_SECONDS="2",
        SWEEP_SECONDS="0.5",
        PROGRESS_WRITE_SECONDS="0",
        WORKER_BEAT_SECONDS="0.3",
        WORKER_ALIVE_SECONDS=str(ALIVE),
        PYTHONPATH=str(REPO),
    )
    return env


class Worker:
    def __init__(self, env: dict[str, str], name: str, log: Path, *, wait: bool = True):
        self.log = log
        self.process = subprocess.Popen(
            [str(BIN / "plantsolve"), "worker", "--concurrency", "1", "--hostname", f"{name}@%h", "--log-level", "info"],
            cwd=REPO,
            env=env,
            stdout=log.open("ab"),
            stderr=subprocess.STDOUT,
            start_new_session=True,  # its own process group: kill takes the pool children too
        )
        if wait:
            self.wait_ready()

    def wait_ready(self) -> Worker:
        deadline = time.monotonic() + 60
        # Celery's "<node> ready." line (a bare b"ready" also matched a path in an earlier warning: ".../ready48f/...")
        while b" ready.\n" not in self.log.read_bytes():
            if self.process.poll() is not None or time.monotonic() > deadline:
                raise AssertionError(f"worker did not start:\n{self.log.read_text()[-3000:]}")
            time.sleep(0.1)
        return self

    @classmethod
    def several(cls, starts: list[tuple[dict[str, str], str, Path]]) -> list[Worker]:
        """Workers (env, name, log) started side by side, a start-up being seconds of imports: all ready on return."""
        workers = [cls(env, name, log, wait=False) for env, name, log in starts]
        try:
            return [worker.wait_ready() for worker in workers]
        except BaseException:
            for worker in workers:
                worker.stop()
            raise

    def kill(self) -> None:
        os.killpg(self.process.pid, signal.SIGKILL)
        self.process.wait(timeout=10)

    def stop(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            try:
                self.process.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.kill()


_main_workers: list = []


@pytest.fixture
def scaled_workers_stopped():
    """Stop the module's shared worker so only the test's own workers consume jobs."""
    for worker in _main_workers:
        worker.stop()


@pytest.fixture(scope="module")
def scaled(pg_url, redis_url, tmp_path_factory):
    data_dir = tmp_path_factory.mktemp("scaled")
    env = _env(pg_url, redis_url, data_dir)
    settings = service_settings(
        data_dir, database_url=pg_url, broker_url=redis_url, heartbeat_seconds=0.3, lease_seconds=2.0, sweep_seconds=0.5,
        worker_beat_seconds=0.3, worker_alive_seconds=ALIVE,
    )
    with TestClient(create_app(settings)) as client:  # migrates the fresh database
        worker = Worker(env, "main", data_dir / "worker-main.log")
        _main_workers.append(worker)
        try:
            yield client, env, data_dir
        finally:
            worker.stop()


def test_job_runs_end_to_end_on_postgres_and_celery(scaled):
    client, _, _ = scaled
    response = client.post("/v1/test-compute/jobs", json={"values": [3.0, 4.0]})
    assert response.status_code == 202
    done = wait_for(client, response.json()["id"], timeout=60)
    assert done["status"] == "succeeded", done
    assert done["attempt"] == 1
    assert client.get(f"/v1/jobs/{done['id']}/result").json()["norm"] == 5.0
    artifact = client.get(f"/v1/jobs/{done['id']}/artifacts/values.txt")
    assert artifact.status_code == 200 and artifact.content == b"3.0\n4.0"
    assert client.get("/readyz").json()["checks"] == {"database": "ok", "files": "ok", "disk": "ok", "jobs": "ok", "workers": "ok"}


def test_embedded_and_celery_give_identical_results(scaled, tmp_path):
    client, _, _ = scaled
    body = {"values": [0.1, 0.2, -0.3, 1e-9, 12345.678]}
    scaled_job = wait_for(client, client.post("/v1/test-compute/jobs", json=body).json()["id"], timeout=60)
    with TestClient(create_app(service_settings(tmp_path))) as embedded:
        embedded_job = wait_for(embedded, embedded.post("/v1/test-compute/jobs", json=body).json()["id"])
        embedded_result = embedded.get(f"/v1/jobs/{embedded_job['id']}/result").json()
    scaled_result = client.get(f"/v1/jobs/{scaled_job['id']}/result").json()
    assert scaled_result == embedded_result
    assert scaled_result["report"]["warnings"][0]["code"] == "negative"


def test_real_solver_gives_identical_results_embedded_and_celery(scaled, tmp_path):
    from plantsolve.solvers.kinds import KINDS

    client, _, _ = scaled
    # the kind's own example: a real least-squares map fit and its twelve artifacts, at a third of the CPU the
    # N3 fan map costs (twice here); whether the two transports agree does not depend on the map's size
    body = KINDS["perfmap"].example()
    scaled_job = wait_for(client, client.post("/v1/perfmap/jobs", json=body).json()["id"], timeout=180)
    assert scaled_job["status"] == "succeeded", scaled_job
    with TestClient(create_app(service_settings(tmp_path))) as embedded:
        embedded_job = wait_for(embedded, embedded.post("/v1/perfmap/jobs", json=body).json()["id"], timeout=180)
        embedded_result = embedded.get(f"/v1/jobs/{embedded_job['id']}/result").json()
        embedded_artifacts = {a["name"]: a["sha256"] for a in embedded_job["artifacts"]}
    assert _same(client.get(f"/v1/jobs/{scaled_job['id']}/result").json(), embedded_result)
    assert {a["name"] for a in scaled_job["artifacts"]} == set(embedded_artifacts)


def _same(a, b) -> bool:
    """Equal, numbers to 1e-6 of an efficiency: numpy's vectorised sums round by how their arrays lie in memory, which
    differs between processes, and the error table of a least-squares family near its own round-off follows (once:
    a parabola_log's largest relative error 1.97e-6 in one process, 2.59e-6 in the other)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        return a == pytest.approx(b, rel=1e-9, abs=1e-6)
    return a == b


def test_crash_is_retried_then_failed_with_report(scaled):
    client, _, _ = scaled
    done = wait_for(client, client.post("/v1/test-crash/jobs", json={"message": "kaputt"}).json()["id"], timeout=60)
    assert done["status"] == "failed" and done["attempt"] == 2
    assert [(a["attempt"], a["outcome"]) for a in done["attempts"]] == [(1, "requeued"), (2, "failed")]
    assert "kaputt" in done["report"]["message"] and "attempts" not in done["report"]["details"]


def test_hanging_solver_hits_celery_time_limit(scaled):
    client, _, _ = scaled
    done = wait_for(client, client.post("/v1/test-hang/jobs", json={}).json()["id"], timeout=60)
    assert done["status"] == "failed" and done["report"]["stage"] == "time_limit"


def test_solver_deaf_to_the_soft_limit_is_killed_at_the_hard_limit(scaled):
    client, _, _ = scaled
    done = wait_for(client, client.post("/v1/test-stubborn/jobs", json={}).json()["id"], timeout=60)
    assert done["status"] == "failed" and done["attempt"] == 1
    assert done["report"]["stage"] == "time_limit" and done["report"]["details"]["killed"] is True
    # The pool replaced the killed process: the next job runs.
    follow = wait_for(client, client.post("/v1/test-compute/jobs", json={"values": [1.0]}).json()["id"], timeout=60)
    assert follow["status"] == "succeeded"


def test_cancel_running_job_on_celery(scaled):
    client, _, _ = scaled
    job = client.post("/v1/test-compute/jobs", json={"values": [1.0], "seconds": 30}).json()
    wait_for(client, job["id"], statuses=("running",), timeout=60)
    assert client.post(f"/v1/jobs/{job['id']}/cancel").json()["status"] == "cancelled"
    follow = wait_for(client, client.post("/v1/test-compute/jobs", json={"values": [2.0]}).json()["id"], timeout=60)
    assert follow["status"] == "succeeded"  # the worker gave up the cancelled job promptly
    assert client.get(f"/v1/jobs/{job['id']}").json()["status"] == "cancelled"


def test_events_stream_progress_written_by_a_celery_worker(scaled):
    """The API process runs no job here: the progress it streams can only come from the database rows a
    worker process writes."""
    import json

    from tests.support.sse import events

    client, _, _ = scaled
    assert client.app.state.settings.embedded_mode and client.app.state.settings.broker_url  # Celery mode
    job = client.post("/v1/test-compute/jobs", json={"values": [1.0, 2.0], "seconds": 3.0}).json()
    received = []
    with client.stream("GET", f"/v1/jobs/{job['id']}/events") as response:
        for name, data in events(response.iter_lines(), deadline=time.monotonic() + 60):
            received.append((name, data))
    views = [data for name, data in received if name == "job"]
    fractions = [view["progress"]["fraction"] for view in views]
    assert fractions == sorted(fractions) and len({f for f in fractions if 0 < f < 1}) >= 3
    assert {view["status"] for view in views} >= {"running", "succeeded"}
    worker = views[-1]["attempts"][0]["worker"]  # "celery@<host>:<pid>": run by the worker subprocess
    assert worker.startswith("celery@") and not worker.endswith(f":{os.getpid()}")
    assert received[-1] == ("end", {"status": "succeeded"})
    assert json.loads(json.dumps(views[-1])) == client.get(f"/v1/jobs/{job['id']}").json()


def test_the_compose_worker_healthcheck_pings_a_live_worker(scaled, redis_url):
    """docker-compose.yml's worker check, run here against the module's worker (node main@<host>)."""
    import socket

    import yaml

    client, env, _ = scaled
    compose = yaml.safe_load((REPO / "docker-compose.yml").read_text())
    command = compose["services"]["worker"]["healthcheck"]["test"][1].replace("$$", "$")
    node = f"main@{socket.gethostname()}"
    shell_env = {**env, "PATH": f"{BIN}:{os.environ.get('PATH', '')}", "BROKER_URL": redis_url,
                 "HOSTNAME": "ignored"}
    alive = subprocess.run(["sh", "-c", command.replace("celery@$HOSTNAME", node)], env=shell_env,
                           capture_output=True, text=True, timeout=60)
    assert alive.returncode == 0 and "pong" in alive.stdout, alive.stdout + alive.stderr
    nobody = subprocess.run(["sh", "-c", command], env={**shell_env, "HOSTNAME": "no-such-node"},
                            capture_output=True, text=True, timeout=60)
    assert nobody.returncode != 0  # a worker that does not answer is reported unhealthy


# The tests below stop the module's shared worker: tests that need it go above this line.
@pytest.fixture
def unstaffed(pg_url, redis_url, tmp_path):
    """The scaled API with no worker running yet (the test starts and kills its own)."""
    env = _env(pg_url, redis_url, tmp_path)
    settings = service_settings(
        tmp_path, database_url=pg_url, broker_url=redis_url, heartbeat_seconds=0.3, lease_seconds=2.0, sweep_seconds=0.5,
        worker_beat_seconds=0.3, worker_alive_seconds=ALIVE,
    )
    with TestClient(create_app(settings)) as client:
        yield client, env, tmp_path


def _readiness(client) -> tuple[int, str]:
    response = client.get("/readyz")
    return response.status_code, response.json()["checks"].get("workers")


def test_killed_worker_job_reruns_on_another_attempt(unstaffed, scaled_workers_stopped, redis_url):
    """Also readiness with no worker there: the module's worker, stopped cleanly, took itself off the roll at once;
    a SIGKILLed one drops out within WORKER_ALIVE_SECONDS; one started is counted as soon as it is ready."""
    import redis

    client, env, data_dir = unstaffed
    roll = [member.decode() for member in redis.Redis.from_url(redis_url).zrange("plantsolve:workers", 0, -1)]
    assert not [member for member in roll for worker in _main_workers if member.endswith(f":{worker.process.pid}")]
    assert _readiness(client) == (503, "unavailable")
    markers = data_dir / "markers"
    victim = Worker(env, "victim", data_dir / "worker-victim.log")
    rescuer = None
    try:
        assert _readiness(client) == (200, "ok")
        job = client.post("/v1/test-compute/jobs", json={"values": [5.0], "seconds": 4, "marker_dir": str(markers)}).json()
        wait_for(client, job["id"], statuses=("running",), timeout=60)
        victim.kill()  # SIGKILL to the whole worker: no clean shutdown, no ack, no result
        killed_at = time.monotonic()
        assert client.get(f"/v1/jobs/{job['id']}").json()["status"] == "running"
        while _readiness(client) != (503, "unavailable"):
            assert time.monotonic() - killed_at < ALIVE + 1.0, "a SIGKILLed worker still counted after the window"
            time.sleep(0.1)
        rescuer = Worker(env, "rescuer", data_dir / "worker-rescuer.log")
        assert _readiness(client) == (200, "ok")
        done = wait_for(client, job["id"], timeout=90)
        assert done["status"] == "succeeded", done
        assert done["attempt"] == 2
        assert client.get(f"/v1/jobs/{job['id']}/result").json()["total"] == 5.0
        assert len(list(markers.iterdir())) == 1  # the killed attempt never completed
    finally:
        victim.stop()
        if rescuer is not None:
            rescuer.stop()


def test_queued_jobs_whose_messages_the_broker_lost_are_sent_again(pg_url, redis_url, tmp_path, scaled_workers_stopped):
    """A Redis restarted without persistence forgets its queue: the sweeper notices the broker holds fewer
    messages than there are queued jobs and sends them again, within a sweep period after REQUEUE_QUEUED_AFTER."""
    import redis

    env = {**_env(pg_url, redis_url, tmp_path), "REQUEUE_QUEUED_AFTER": "1.5"}
    settings = service_settings(tmp_path, database_url=pg_url, broker_url=redis_url, heartbeat_seconds=0.3,
                                lease_seconds=2.0, sweep_seconds=0.5, requeue_queued_after=1.5)
    with TestClient(create_app(settings)) as client:
        ids = [client.post("/v1/test-compute/jobs", json={"values": [float(i)]}).json()["id"] for i in range(5)]
        redis.Redis.from_url(redis_url).flushdb()  # the restart: every queued message is gone
        lost_at = time.monotonic()
        worker = Worker(env, "after-restart", tmp_path / "worker-after-restart.log")
        try:
            for job_id in ids:
                assert wait_for(client, job_id, timeout=60)["status"] == "succeeded"
            assert time.monotonic() - lost_at < 30
        finally:
            worker.stop()


def test_a_job_whose_enqueue_failed_is_sent_by_the_next_sweep(pg_url, tmp_path):
    """The broker is down while a job is submitted: the job is stored, not marked as sent, and the sweeper
    sends it once the broker is back."""
    settings = service_settings(tmp_path, database_url=pg_url, broker_url="redis://127.0.0.1:9/0",
                                sweep_seconds=0.3, requeue_queued_after=60.0)
    with TestClient(create_app(settings)) as client:
        job = client.post("/v1/test-compute/jobs", json={"values": [1.0]})
        assert job.status_code == 202
        stored = client.app.state.ctx.repo.get(__import__("uuid").UUID(job.json()["id"]))
        assert stored.status == "queued" and stored.enqueued_at is None


def test_a_message_delivered_twice_runs_the_solver_once(unstaffed, scaled_workers_stopped):
    """At-least-once delivery: the broker hands the same job id to two workers; the claim lets one run it."""
    client, env, data_dir = unstaffed
    markers = data_dir / "markers-twice"
    workers = Worker.several([(env, f"twin{i}", data_dir / f"worker-twin{i}.log") for i in range(2)])
    try:
        job = client.post("/v1/test-compute/jobs", json={"values": [2.0], "seconds": 2, "marker_dir": str(markers)}).json()
        client.app.state.dispatcher.enqueue(__import__("uuid").UUID(job["id"]), "test-compute")  # the duplicate
        done = wait_for(client, job["id"], timeout=60)
        assert done["status"] == "succeeded" and done["attempt"] == 1
        time.sleep(1.0)  # the duplicate has been consumed by now
        assert len(list(markers.iterdir())) == 1
        assert [a["outcome"] for a in client.get(f"/v1/jobs/{job['id']}").json()["attempts"]] == ["succeeded"]
    finally:
        for worker in workers:
            worker.stop()


def test_a_database_outage_during_the_final_write_loses_no_result(pg_url, redis_url, tmp_path, scaled_workers_stopped):
    """PostgreSQL refuses every connection (and drops the open ones) while the solver finishes: the worker keeps
    the computed result and retries the write; once the database is back the job succeeds on its first attempt
    and the solver ran once."""
    import psycopg

    from tests.conftest import PG_ADMIN_URL

    name = pg_url.rsplit("/", 1)[1]
    env = {**_env(pg_url, redis_url, tmp_path), "LEASE_SECONDS": "30", "RESULT_WRITE_SECONDS": "60"}
    settings = service_settings(tmp_path, database_url=pg_url, broker_url=redis_url, heartbeat_seconds=0.3,
                                lease_seconds=30.0, sweep_seconds=0.5)
    markers = tmp_path / "markers"
    admin = psycopg.connect(PG_ADMIN_URL, autocommit=True)
    with TestClient(create_app(settings)) as client:
        worker = Worker(env, "outage", tmp_path / "worker-outage.log")
        try:
            job = client.post("/v1/test-compute/jobs",
                              json={"values": [7.0], "seconds": 1.5, "marker_dir": str(markers)}).json()
            wait_for(client, job["id"], statuses=("running",), timeout=60)
            admin.execute(f'ALTER DATABASE "{name}" ALLOW_CONNECTIONS false')
            admin.execute("SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE datname = %s", (name,))
            deadline = time.monotonic() + 30
            while not markers.exists() or not any(markers.iterdir()):  # the solver finished during the outage
                assert time.monotonic() < deadline
                time.sleep(0.1)
            time.sleep(2.0)  # the result write is failing and being retried meanwhile
            admin.execute(f'ALTER DATABASE "{name}" ALLOW_CONNECTIONS true')
            done = wait_for(client, job["id"], timeout=90)
            assert done["status"] == "succeeded" and done["attempt"] == 1, done
            assert client.get(f"/v1/jobs/{job['id']}/result").json()["total"] == 7.0
            assert len(list(markers.iterdir())) == 1
        finally:
            admin.execute(f'ALTER DATABASE "{name}" ALLOW_CONNECTIONS true')
            admin.close()
            worker.stop()

