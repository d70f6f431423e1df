"""A database outage under a running job, measured against the real server on PostgreSQL.

Starts ``plantsolve serve`` (embedded pool, ``DATABASE_URL`` on the local PostgreSQL, a lease shorter than
the outage), submits a job that computes for a while, stops PostgreSQL for ``--outage`` seconds while it
runs, and starts it again. Prints what the API answered during the outage (every answer should be a 503
with Retry-After and X-Request-ID, never a 500), how long after PostgreSQL is back ``/readyz`` says ok, and
how the job ended: succeeded on attempt 1 and solved once (its marker files counted), its lease not lapsed.

Needs root (it stops and starts the cluster with ``pg_ctlcluster``); never run it while tests use the
database.

    python bench/outage.py [--outage 20] [--lease 8]
"""

from __future__ import annotations

import argparse
import os
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


def cluster(action: str) -> None:
    version = sorted(os.listdir("/etc/postgresql"))[0]
    subprocess.run(["pg_ctlcluster", "--skip-systemctl-redirect", version, "main", action], check=True,
                   capture_output=True)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--outage", type=float, default=20.0, help="seconds PostgreSQL is down (default 20)")
    parser.add_argument("--lease", type=float, default=8.0, help="LEASE_SECONDS of the server (default 8)")
    args = parser.parse_args()
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
