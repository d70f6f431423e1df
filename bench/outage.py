"""A database outage under a running job, measured against the real server on PostgreSQL.

Starts ``plantsolve serve`` (embedded pool, ``DATABASE_URL`` on the local PostgreSQL, a lease shorter than
the outage), submits a job that computes for a while, stops PostgreSQL for ``--outage`` seconds while it
runs, and starts it again. Prints what the API answered during the outage (every answer should be a 503
with Retry-After and X-Request-ID, never a 500), how long after PostgreSQL is back ``/readyz`` says ok, and
how the job ended: succeeded on attempt 1 and solved once (its marker files counted), its lease not lapsed.

Needs root (it stops and starts the cluster with ``pg_ctlcluster``); never run it while tests use the
database.

``--black-hole``: the link dies without a word instead (PostgreSQL reached through a proxy that, at a moment,
passes nothing on and closes nothing: tests/support/black_hole.py), for this checkout and the one ``--before``
names (default ``main``, in a temporary worktree) in the same run: how long a submit and ``/readyz`` take to
answer, and what, once the connections pooled before are dead; how soon the service answers again once the link
does. The shipped DATABASE_WAIT_SECONDS and DATABASE_STATEMENT_SECONDS, the API process's job threads
(EMBEDDED_MODE=thread: the bounds are the API process's); a request gets ``--patience`` seconds before the
bench gives up on it. This mode stops nothing and may run beside the tests.

``--scaled``: the scaled path under killed processes and outages, for this checkout and the one ``--before`` names, in
the same run (each scenario on a database of its own on the local PostgreSQL, a Redis server of its own on a free
port, ``plantsolve serve`` and ``plantsolve worker`` processes): ``worker-kill`` (kill -9 of a Celery worker mid-job,
another started), ``worker-stop`` (SIGSTOP of one mid-job, another started), ``redis-queued`` (Redis restarted, empty,
with jobs queued and no worker; a worker started after), ``redis-running`` (Redis restarted under a busy worker),
``pg-kill`` (``pg_terminate_backend`` of every connection to the scenario's database, again and again, as the jobs
store their results), ``pg-restart`` (a PostgreSQL cluster of the bench's own, stopped with four jobs running and
queued for 8 s of HTTP probes, then started again), ``store-kill`` (kill -9 of the worker busy with two jobs once the
first is solved and before its result's commit: ``bench/kill_kinds.py``'s ``test-slow-render``, whose artifacts take
2 s to render; another worker started), ``cancel`` (a running job cancelled). Each row: final statuses, solves per
job (marker files), attempts and each attempt's outcome, what HTTP answered meanwhile,
the ``/readyz`` answers in order, and ``/readyz`` at the end. Stops nothing shared: the PostgreSQL cluster and the
shared Redis are left alone.

    python bench/outage.py [--outage 20] [--lease 8]
    python bench/outage.py --black-hole [--before main|DIR|none] [--patience 60]
    python bench/outage.py --scaled [--before main|DIR|none] [--only worker-kill,redis-running,store-kill,...]
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import random
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import httpx
import psycopg

REPO = Path(__file__).resolve().parents[1]
ADMIN = "postgresql://postgres@127.0.0.1:5432/postgres"
sys.path.insert(0, str(REPO))
from tests.support.black_hole import BlackHoleProxy  # noqa: E402  (the tests' proxy: one black hole, not two)


def cluster(action: str) -> None:
    version = sorted(os.listdir("/etc/postgresql"))[0]
    subprocess.run(["pg_ctlcluster", "--skip-systemctl-redirect", version, "main", action], check=True,
                   capture_output=True)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _timed(call) -> tuple[str, float]:
    """(the answer's status, or the error's name; seconds it took)."""
    started = time.monotonic()
    try:
        answer = str(call().status_code)
    except httpx.HTTPError as error:
        answer = f"no answer ({type(error).__name__})"
    return answer, time.monotonic() - started


def black_hole_side(code: Path, patience: float) -> list[tuple[str, str]]:
    """One checkout's server through a proxy that turns into a black hole: what each request answered, and when."""
    name = f"plantsolve_blackhole_{uuid.uuid4().hex[:8]}"
    with psycopg.connect(ADMIN, autocommit=True) as admin:
        admin.execute(f'CREATE DATABASE "{name}"')
    proxy = BlackHoleProxy(("127.0.0.1", 5432))
    work = Path(tempfile.mkdtemp(prefix="black-hole-"))
    port = free_port()
    env = {**os.environ, "DATA_DIR": str(work / "var"), "PYTHONPATH": f"{code}{os.pathsep}{REPO}",
           "PLUGINS": "tests.support.kinds", "BLOB_STORE": "local", "EMBEDDED_MODE": "thread", "LOG_FORMAT": "text",
           "DATABASE_URL": f"postgresql+psycopg://postgres@127.0.0.1:{proxy.port}/{name}"}
    log = (work / "server.log").open("w")
    server = subprocess.Popen([sys.executable, "-m", "plantsolve.cli", "serve", "--port", str(port)], env=env,
                              stdout=log, stderr=subprocess.STDOUT, cwd=work)
    base = f"http://127.0.0.1:{port}"
    submit = lambda: httpx.post(f"{base}/v1/test-compute/jobs", json={"values": [1.5, 2.5]}, timeout=patience)  # noqa: E731
    ready = lambda: httpx.get(f"{base}/readyz", timeout=patience)  # noqa: E731
    rows = []
    try:
        deadline = time.monotonic() + 120
        while _timed(ready)[0] != "200":
            if time.monotonic() > deadline or server.poll() is not None:
                raise SystemExit(f"the server did not start: {(work / 'server.log').read_text()[-2000:]}")
            time.sleep(0.3)
        with concurrent.futures.ThreadPoolExecutor(8) as pool:  # connections pooled while the link works
            list(pool.map(lambda _: submit(), range(32)))
        time.sleep(1.0)  # idle in the pool, as between requests
        proxy.swallow()
        for label, call in (("submit", submit), ("/readyz", ready), ("submit again", submit),
                            ("/readyz again", ready)):
            answer, took = _timed(call)
            rows.append((f"{label} through the black hole", f"{answer} after {took:.1f} s"))
        proxy.forward()
        back = time.monotonic()
        while _timed(ready)[0] != "200" and time.monotonic() - back < 2 * patience:
            time.sleep(0.2)
        answer, took = _timed(submit)
        rows.append(("/readyz 200 after the link is back", f"{time.monotonic() - back - took:.1f} s"))
        rows.append(("submit after", f"{answer} after {took:.2f} s"))
    finally:
        proxy.close()
        server.terminate()
        try:
            server.wait(timeout=30)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()
        log.close()
        with psycopg.connect(ADMIN, autocommit=True) as admin:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
    return rows


def black_hole(args: argparse.Namespace) -> int:
    sides, remove = _sides(args.before)
    try:
        measured = [(label, black_hole_side(code, args.patience)) for label, code in sides]
    finally:
        if remove is not None:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(remove)], check=False)
    print(f"PostgreSQL through a black hole (DATABASE_WAIT_SECONDS 3, DATABASE_STATEMENT_SECONDS 10: the shipped "
          f"defaults; a request given {args.patience:g} s)\n")
    print("| measure | " + " | ".join(label for label, _ in measured) + " |")
    print("| --- |" + " --- |" * len(measured))
    for i, (measure, _) in enumerate(measured[0][1]):
        print(f"| {measure} | " + " | ".join(rows[i][1] for _, rows in measured) + " |")
    return 0


SCALED = ("worker-kill", "worker-stop", "redis-queued", "redis-running", "pg-kill", "store-kill", "cancel",
          "pg-restart")


class PrivateCluster:
    """A PostgreSQL cluster of the bench's own (``initdb`` in a temporary folder, a free port, run as the ``postgres``
    user): stopped and started at will while the shared one serves the tests."""

    def __init__(self):
        self.folder = Path(tempfile.mkdtemp(prefix="pg-private-"))
        shutil.chown(self.folder, "postgres")
        self.port = free_port()
        self.admin = f"postgresql://postgres@127.0.0.1:{self.port}/postgres"
        try:
            self._as_postgres(["initdb", "-D", str(self.folder / "data"), "-A", "trust", "-U", "postgres"])
            self.start()
        except BaseException:
            self.remove()
            raise

    def _as_postgres(self, argv: list[str]) -> None:
        subprocess.run(["su", "postgres", "-c", " ".join(shlex.quote(arg) for arg in argv)], check=True,
                       capture_output=True)

    def start(self) -> None:
        self._as_postgres(["pg_ctl", "-D", str(self.folder / "data"), "-l", str(self.folder / "log"), "-w", "-o",
                           f"-p {self.port} -k {self.folder} -c listen_addresses=127.0.0.1", "start"])

    def stop(self, mode: str = "fast") -> None:
        self._as_postgres(["pg_ctl", "-D", str(self.folder / "data"), "-m", mode, "-w", "stop"])

    def remove(self) -> None:
        try:
            self.stop("immediate")
        except subprocess.CalledProcessError:
            pass
        shutil.rmtree(self.folder, ignore_errors=True)


class ScaledService:
    """One scenario's scaled service: a database and a Redis server of its own, the API, Celery workers."""

    def __init__(self, code: Path, work: Path, cluster: PrivateCluster | None = None):
        self.work, self.code, self.cluster = work, code, cluster
        self.admin = cluster.admin if cluster is not None else ADMIN
        self.redis_port, self.port = free_port(), free_port()
        self.redis = self._redis()
        self.database = f"plantsolve_scaled_{uuid.uuid4().hex[:8]}"
        with psycopg.connect(self.admin, autocommit=True) as admin:
            admin.execute(f'CREATE DATABASE "{self.database}"')
        database_port = cluster.port if cluster is not None else 5432
        self.env = {**os.environ, "PYTHONPATH": f"{code}{os.pathsep}{REPO}{os.pathsep}{REPO / 'bench'}",
                    "PLUGINS": "tests.support.kinds,kill_kinds",
                    "DATA_DIR": str(work / "var"),
                    "DATABASE_URL": f"postgresql+psycopg://postgres@127.0.0.1:{database_port}/{self.database}",
                    "BROKER_URL": f"redis://127.0.0.1:{self.redis_port}/0", "LEASE_SECONDS": "4",
                    "HEARTBEAT_SECONDS": "0.5", "SWEEP_SECONDS": "1", "WORKER_BEAT_SECONDS": "0.5",
                    "WORKER_ALIVE_SECONDS": "3", "REQUEUE_QUEUED_AFTER": "10", "PROGRESS_WRITE_SECONDS": "0",
                    "LOG_FORMAT": "text", "MIN_FREE_DISK_BYTES": "0"}
        self.bin = Path(sys.executable).parent
        subprocess.run([str(self.bin / "plantsolve"), "migrate"], env=self.env, check=True, capture_output=True)
        self.api = subprocess.Popen([str(self.bin / "plantsolve"), "serve", "--port", str(self.port)], env=self.env,
                                    cwd=work, stdout=(work / "api.log").open("ab"), stderr=subprocess.STDOUT)
        self.client = httpx.Client(base_url=f"http://127.0.0.1:{self.port}", timeout=30)
        self.workers: list[subprocess.Popen] = []
        self.ready_seen: list[str] = []
        self.answers: dict[str, int] = {}
        self.extra: list[str] = []
        until = time.monotonic() + 120
        while self.ready() not in ("200", "503 workers"):
            if time.monotonic() > until or self.api.poll() is not None:
                raise SystemExit(f"the API did not start: {(work / 'api.log').read_text()[-2000:]}")
            time.sleep(0.3)

    def _redis(self) -> subprocess.Popen:
        return subprocess.Popen(["redis-server", "--port", str(self.redis_port), "--bind", "127.0.0.1", "--save", "",
                                 "--appendonly", "no"], stdout=(self.work / "redis.log").open("ab"),
                                stderr=subprocess.STDOUT)

    def restart_redis(self, away: float) -> None:
        """Redis killed, ``away`` seconds of HTTP probes, then started again empty (no persistence)."""
        self.redis.kill()
        self.redis.wait()
        self.probe_for(away)
        self.redis = self._redis()

    def worker(self, name: str) -> subprocess.Popen:
        log = self.work / f"worker-{name}.log"
        process = subprocess.Popen([str(self.bin / "plantsolve"), "worker", "--concurrency", "1", "--hostname",
                                    f"{name}@%h", "--log-level", "info"], env=self.env, cwd=self.work,
                                   stdout=log.open("ab"), stderr=subprocess.STDOUT, start_new_session=True)
        until = time.monotonic() + 120
        while b" ready.\n" not in log.read_bytes():
            if process.poll() is not None or time.monotonic() > until:
                raise SystemExit(f"worker {name} did not start: {log.read_text()[-2000:]}")
            time.sleep(0.2)
        self.workers.append(process)
        return process

    def ready(self) -> str:
        try:
            response = self.client.get("/readyz", timeout=10)
            said = "200" if response.status_code == 200 else \
                f"{response.status_code} {','.join(k for k, v in response.json()['checks'].items() if v != 'ok')}"
        except httpx.HTTPError as error:
            said = f"no answer ({type(error).__name__})"
        if not self.ready_seen or self.ready_seen[-1] != said:
            self.ready_seen.append(said)
        return said

    def submit(self, i: int, seconds: float) -> str:
        body = {"values": [1.0 + i], "seconds": seconds, "marker_dir": str(self.work / "markers" / str(i))}
        return self.client.post("/v1/test-compute/jobs", json=body).json()["id"]

    def jobs(self, ids: list[str]) -> list[dict]:
        return [self.client.get(f"/v1/jobs/{i}").json() for i in ids]

    def wait_running(self, job_id: str) -> None:
        until = time.monotonic() + 60
        while self.jobs([job_id])[0]["status"] != "running":
            if time.monotonic() > until:
                raise SystemExit("the job did not start")
            time.sleep(0.1)

    def probe(self, job_id: str) -> None:
        """One round of what clients ask meanwhile; the answers are tallied by route and status."""
        for method, path, extra in (("get", f"/v1/jobs/{job_id}", {}), ("get", "/v1/jobs", {}),
                                    ("post", "/v1/test-compute/jobs", {"json": {"values": [3.0]}})):
            route = "GET /v1/jobs/{id}" if path.startswith("/v1/jobs/") else f"{method.upper()} {path}"
            try:
                response = getattr(self.client, method)(path, timeout=20, **extra)
                key = f"{route} {response.status_code}"
                if response.status_code == 202:
                    self.extra.append(response.json()["id"])
            except httpx.HTTPError as error:
                key = f"{route} {type(error).__name__}"
            self.answers[key] = self.answers.get(key, 0) + 1

    def probe_for(self, seconds: float, job_id: str | None = None) -> None:
        until = time.monotonic() + seconds
        while time.monotonic() < until:
            self.ready()
            if job_id:
                self.probe(job_id)
            time.sleep(0.3)

    def finish(self, ids: list[str], seconds: float = 120) -> list[dict]:
        until = time.monotonic() + seconds
        while time.monotonic() < until:
            jobs = self.jobs(ids)
            self.ready()
            if all(j["status"] in ("succeeded", "failed", "cancelled") for j in jobs):
                return jobs
            time.sleep(0.3)
        return self.jobs(ids)

    def close(self) -> None:
        for process in self.workers:
            try:
                os.killpg(process.pid, signal.SIGCONT)
                os.killpg(process.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        for process in self.workers:
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
        self.api.terminate()
        try:
            self.api.wait(30)
        except subprocess.TimeoutExpired:
            self.api.kill()
        self.redis.kill()
        if self.cluster is not None:
            self.cluster.remove()
            return
        with psycopg.connect(ADMIN, autocommit=True) as admin:
            admin.execute(f'DROP DATABASE IF EXISTS "{self.database}" WITH (FORCE)')


def scaled_scenario(name: str, code: Path) -> dict:
    work = Path(tempfile.mkdtemp(prefix=f"scaled-{name}-"))
    cluster = PrivateCluster() if name == "pg-restart" else None
    try:
        service = ScaledService(code, work, cluster)
    except BaseException:  # (its close() removes the cluster, once there is a service to close)
        if cluster is not None:
            cluster.remove()
        raise
    note = ""
    try:
        if name in ("worker-kill", "worker-stop"):
            first = service.worker("a")
            ids = [service.submit(i, 2.0) for i in range(2)]
            service.wait_running(ids[0])
            time.sleep(0.5)
            if name == "worker-kill":
                os.killpg(first.pid, signal.SIGKILL)
                first.wait()
            else:
                os.killpg(first.pid, signal.SIGSTOP)
            service.probe_for(4, ids[0])
            service.worker("b")
        elif name == "redis-queued":
            ids = [service.submit(i, 0.5) for i in range(4)]
            service.restart_redis(5)
            service.probe_for(3, ids[0])
            service.worker("a")
        elif name == "redis-running":
            service.worker("a")
            ids = [service.submit(i, 3.0) for i in range(4)]
            service.wait_running(ids[0])
            service.restart_redis(5)
        elif name == "pg-kill":
            service.worker("a")
            ids = [service.submit(i, 1.0) for i in range(6)]
            until = time.monotonic() + 30
            with psycopg.connect(ADMIN, autocommit=True) as admin:
                while time.monotonic() < until:
                    jobs = service.jobs(ids)
                    if all(j["status"] in ("succeeded", "failed") for j in jobs):
                        break
                    if any(j["status"] == "running" and j["progress"]["fraction"] >= 0.9 for j in jobs):
                        time.sleep(random.uniform(0, 0.08))
                        admin.execute("SELECT pg_terminate_backend(pid) FROM pg_stat_activity WHERE datname = %s",
                                      (service.database,))
                        service.probe(ids[0])
                    time.sleep(0.02)
        elif name == "store-kill":
            first = service.worker("a")
            ids = [service.client.post("/v1/test-slow-render/jobs", json={
                "values": [1.0 + i], "seconds": 1.0, "render_seconds": 2.0,
                "marker_dir": str(work / "markers" / str(i))}).json()["id"] for i in range(2)]
            until = time.monotonic() + 60
            while not (work / "markers" / "0").exists() and time.monotonic() < until:
                time.sleep(0.01)
            time.sleep(random.uniform(0.05, 1.5))  # solved, and rendering for 2 s before it stores anything
            os.killpg(first.pid, signal.SIGKILL)
            first.wait()
            service.probe_for(2, ids[0])
            service.worker("b")
        elif name == "pg-restart":
            service.worker("a")
            ids = [service.submit(i, 2.0) for i in range(4)]
            service.wait_running(ids[0])
            time.sleep(0.5)
            cluster.stop()
            service.probe_for(8, ids[0])
            cluster.start()
            back = time.monotonic()
            while service.ready() != "200" and time.monotonic() - back < 60:
                time.sleep(0.1)
            note = f"/readyz 200 {time.monotonic() - back:.1f} s after PostgreSQL was back"
        elif name == "cancel":
            service.worker("a")
            ids = [service.submit(0, 20.0)]
            service.wait_running(ids[0])
            time.sleep(0.5)
            service.answers["POST /v1/jobs/{id}/cancel " + str(service.client.post(f"/v1/jobs/{ids[0]}/cancel")
                                                               .status_code)] = 1
        else:
            raise ValueError(name)
        jobs = service.finish(ids + service.extra)
        time.sleep(2)  # the workers' next beats
        final = service.ready()
    finally:
        service.close()
    marked = [len(list((work / "markers" / str(i)).glob("*"))) for i in range(len(ids))]
    mine = jobs[:len(ids)]
    return {"scenario": name, "statuses": [j["status"] for j in mine], "solves": marked,
            "attempts": [j["attempt"] for j in mine], "outcomes": [[a["outcome"] for a in j["attempts"]] for j in mine],
            "submitted_meanwhile": f"{sum(j['status'] == 'succeeded' for j in jobs[len(ids):])} of "
                                   f"{len(jobs) - len(ids)} succeeded",
            "answers": service.answers, "readyz": service.ready_seen, "readyz_at_end": final, "note": note}


def scaled(args: argparse.Namespace) -> int:
    sides, remove = _sides(args.before)
    try:
        for label, code in sides:
            for name in args.only.split(","):
                print(json.dumps({"tree": label, **scaled_scenario(name, code)}), flush=True)
    finally:
        if remove is not None:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(remove)], check=False)
    return 0


def _sides(before: str) -> tuple[list[tuple[str, Path]], Path | None]:
    """(label, checkout) to measure, ``before`` first; and the temporary worktree made for it, to remove after."""
    sides = [("this", REPO)]
    if before == "none":
        return sides, None
    if Path(before).is_dir():
        return [(Path(before).name, Path(before)), *sides], None
    folder = Path(tempfile.mkdtemp(prefix="outage-before-")) / "before"
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(folder), before], check=True,
                   capture_output=True)
    return [(before, folder), *sides], folder


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--outage", type=float, default=20.0, help="seconds PostgreSQL is down (default 20)")
    parser.add_argument("--lease", type=float, default=8.0, help="LEASE_SECONDS of the server (default 8)")
    parser.add_argument("--black-hole", action="store_true", help="a link that dies without a word (see above)")
    parser.add_argument("--scaled", action="store_true", help="the scaled path's killed processes and outages")
    parser.add_argument("--only", default=",".join(SCALED), help="--scaled: the scenarios to run")
    parser.add_argument("--before", default="main",
                        help="--black-hole, --scaled: the checkout beside this one ('none': none)")
    parser.add_argument("--patience", type=float, default=60.0, help="--black-hole: seconds a request is given")
    args = parser.parse_args()
    if args.black_hole:
        return black_hole(args)
    if args.scaled:
        return scaled(args)
    name = f"plantsolve_outage_{uuid.uuid4().hex[:8]}"
    with psycopg.connect(ADMIN, autocommit=True) as admin:
        admin.execute(f'CREATE DATABASE "{name}"')
    work = Path(tempfile.mkdtemp(prefix="outage-"))
    port = free_port()
    env = {**os.environ, "DATA_DIR": str(work / "var"), "PYTHONPATH": str(REPO), "PLUGINS": "tests.support.kinds",
           "DATABASE_URL": f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}", "BLOB_STORE": "local",
           "LEASE_SECONDS": str(args.lease), "HEARTBEAT_SECONDS": "1", "SWEEP_SECONDS": "1", "EMBEDDED_WORKERS": "1",
           "LOG_FORMAT": "text"}
    log = (work / "server.log").open("w")
    server = subprocess.Popen([str(Path(sys.executable).parent / "plantsolve"), "serve", "--port", str(port)],
                              env=env, stdout=log, stderr=subprocess.STDOUT)
    base = f"http://127.0.0.1:{port}"
    markers = work / "runs"
    rows: list[tuple[str, str]] = []
    try:
        deadline = time.monotonic() + 90
        while True:
            try:
                if httpx.get(f"{base}/readyz", timeout=2).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            if time.monotonic() > deadline:
                raise SystemExit("the server did not start")
            time.sleep(0.3)
        solve_seconds = args.outage + 3 * args.lease
        job = httpx.post(f"{base}/v1/test-compute/jobs", timeout=10,
                         json={"values": [1.0, 2.0], "seconds": solve_seconds, "marker_dir": str(markers)}).json()
        while httpx.get(f"{base}/v1/jobs/{job['id']}", timeout=5).json()["status"] != "running":
            time.sleep(0.2)
        cluster("stop")
        down = time.monotonic()
        answers: dict[str, int] = {}
        missing_headers = 0
        while time.monotonic() - down < args.outage:
            for path in (f"/v1/jobs/{job['id']}", "/v1/jobs", "/dashboard", "/readyz"):
                try:
                    response = httpx.get(base + path, timeout=10)
                except httpx.HTTPError as error:
                    answers[f"{path} {type(error).__name__}"] = answers.get(f"{path} {type(error).__name__}", 0) + 1
                    continue
                key = f"{path.split('/')[1] or path} {response.status_code}"
                answers[key] = answers.get(key, 0) + 1
                if response.status_code == 503 and path != "/readyz" and not (
                        response.headers.get("retry-after") and response.headers.get("x-request-id")):
                    missing_headers += 1
            time.sleep(0.5)
        cluster("start")
        back = time.monotonic()
        while True:
            try:
                if httpx.get(f"{base}/readyz", timeout=5).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            time.sleep(0.1)
        ready_after = time.monotonic() - back
        while True:
            view = httpx.get(f"{base}/v1/jobs/{job['id']}", timeout=10).json()
            if view["status"] in ("succeeded", "failed", "cancelled"):
                break
            time.sleep(0.5)
        solved = len(list(markers.iterdir())) if markers.exists() else 0
        rows += [(f"answers during the {args.outage:g} s outage", ", ".join(f"{k}: {v}" for k, v in sorted(answers.items()))),
                 ("503s without Retry-After or X-Request-ID", str(missing_headers)),
                 ("/readyz ok after PostgreSQL is back", f"{ready_after:.2f} s"),
                 ("job", f"{view['status']}, attempt {view['attempt']} of {view['max_attempts']}, "
                         f"outcomes {[a['outcome'] for a in view['attempts']]}"),
                 ("times solved (marker files)", str(solved)),
                 (f"lease {args.lease:g} s, outage {args.outage:g} s, job {solve_seconds:g} s", "")]
    finally:
        try:
            cluster("start")
        except subprocess.CalledProcessError:
            pass
        server.terminate()
        server.wait(timeout=30)
        log.close()
        for _ in range(30):
            try:
                with psycopg.connect(ADMIN, autocommit=True, connect_timeout=3) as admin:
                    admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
                break
            except psycopg.OperationalError:
                time.sleep(1)
    width = max(len(a) for a, _ in rows)
    print("| measure | value |\n| --- | --- |")
    for a, b in rows:
        print(f"| {a.ljust(width)} | {b} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
