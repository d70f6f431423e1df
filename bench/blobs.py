"""Artifact download throughput per blob store back-end, through the API (HTTP, streamed), in one run.

For each back-end — the local directory (the baseline: what ARTIFACT_DIR always did), PostgreSQL (a fresh
database on the test server, skipped with the reason when it is unreachable) and S3 (moto's S3 server in
this process) — a job of the bench kind below renders one artifact of SIZE MiB of random bytes; the API
(uvicorn on 127.0.0.1, in a thread of this process) serves it, and an httpx client downloads it RUNS times,
checking its SHA-256 against X-Content-SHA256. Printed: MiB/s (best and median of the runs), time to the
first byte, and each back-end's throughput relative to the local directory's.

    python bench/blobs.py            # 64 MiB, 5 runs
    python bench/blobs.py --quick    # 16 MiB, 3 runs

moto is an in-process Python server, so the S3 row measures the client path (boto3 streaming through the
API), not a production object store; PostgreSQL is the local server over TCP.
"""

from __future__ import annotations

import argparse
import hashlib
import logging
import os
import socket
import statistics
import sys
import tempfile
import threading
import time
import uuid
from contextlib import ExitStack, contextmanager
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pydantic import BaseModel, Field  # noqa: E402

from plantsolve.schemas.common import Report, StrictModel  # noqa: E402
from plantsolve.solvers.base import Artifact, Solved, SolverSpec  # noqa: E402

MIB = 1024 * 1024
PG_ADMIN_URL = os.environ.get("TEST_PG_ADMIN_URL", "postgresql://postgres@127.0.0.1:5432/postgres")


class PayloadRequest(StrictModel):
    mebibytes: int = Field(ge=1, le=1024, description="Size of the artifact (MiB).")


class PayloadResult(BaseModel):
    size: int
    report: Report


def _solve(request: PayloadRequest, progress) -> Solved:
    return Solved(PayloadResult(size=request.mebibytes * MIB, report=Report(status="ok", message="made")))


def _render(request: PayloadRequest, solved: Solved) -> list[Artifact]:
    import numpy as np

    data = np.random.default_rng(request.mebibytes).bytes(request.mebibytes * MIB)  # incompressible
    return [Artifact("payload.bin", "application/octet-stream", data)]


# a bench-only kind (PLUGINS=bench.blobs): one artifact of the requested size
SPECS = [SolverSpec(kind="bench-payload", request_model=PayloadRequest, result_model=PayloadResult, solve=_solve,
                    version="1", render_artifacts=_render)]


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@contextmanager
def _serving(settings):
    """The app on 127.0.0.1 (uvicorn in a thread); yields (base URL, the app's service context)."""
    import uvicorn

    from plantsolve.app.main import create_app

    app = create_app(settings, run_jobs=False)
    for name in ("plantsolve", "werkzeug"):  # the job's log lines and moto's access log would bury the table
        logging.getLogger(name).setLevel(logging.WARNING)
    port = _free_port()
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning", access_log=False))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        if time.monotonic() > deadline:
            raise RuntimeError("uvicorn did not start")
        time.sleep(0.05)
    try:
        yield f"http://127.0.0.1:{port}", app.state.ctx
    finally:
        server.should_exit = True
        thread.join(timeout=10)


@contextmanager
def _postgres():
    import psycopg

    admin = psycopg.connect(PG_ADMIN_URL, autocommit=True, connect_timeout=3)
    name = f"plantsolve_bench_{uuid.uuid4().hex[:8]}"
    admin.execute(f'CREATE DATABASE "{name}"')
    try:
        yield PG_ADMIN_URL.rsplit("/", 1)[0].replace("postgresql://", "postgresql+psycopg://") + f"/{name}"
    finally:
        admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        admin.close()


def _measure(base: str, ctx, mebibytes: int, runs: int) -> dict:
    import httpx

    from plantsolve.jobs.runner import run_job

    with httpx.Client(base_url=base, timeout=120) as client:
        job_id = client.post("/v1/bench-payload/jobs", json={"mebibytes": mebibytes}).json()["id"]
        assert run_job(ctx, uuid.UUID(job_id), worker="bench", requeue=lambda *_: None) == "succeeded"
        rates, first_bytes = [], []
        for _ in range(runs):
            digest = hashlib.sha256()
            received = 0
            start = time.perf_counter()
            first = None
            with client.stream("GET", f"/v1/jobs/{job_id}/artifacts/payload.bin") as response:
                response.raise_for_status()
                expected = response.headers["x-content-sha256"]
                for chunk in response.iter_raw(MIB):
                    if first is None:
                        first = time.perf_counter() - start
                    digest.update(chunk)
                    received += len(chunk)
            elapsed = time.perf_counter() - start
            if received != mebibytes * MIB or digest.hexdigest() != expected:
                raise AssertionError(f"download corrupted: {received} bytes, sha256 {digest.hexdigest()} != {expected}")
            rates.append(received / MIB / elapsed)
            first_bytes.append(first)
    return {"best": max(rates), "median": statistics.median(rates), "first_byte_ms": 1000 * statistics.median(first_bytes)}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="16 MiB, 3 runs")
    parser.add_argument("--size", type=int, help="artifact size (MiB)")
    parser.add_argument("--runs", type=int, help="downloads per back-end")
    args = parser.parse_args()
    mebibytes = args.size or (16 if args.quick else 64)
    runs = args.runs or (3 if args.quick else 5)

    from plantsolve.app.settings import AppSettings

    print(f"artifact download through the API: {mebibytes} MiB, {runs} runs per back-end (MiB/s; higher is better)")
    print(f"{'back-end':<10} {'best MiB/s':>11} {'median MiB/s':>13} {'first byte':>11} {'vs local':>9}")
    rows: dict[str, dict] = {}
    for back_end in ("local", "postgres", "s3"):
        with ExitStack() as stack, tempfile.TemporaryDirectory(prefix="plantsolve-bench-blobs-") as folder:
            values: dict = dict(data_dir=Path(folder), plugins=["bench.blobs"], embedded_mode="thread",
                                inline_input_bytes=1024 * 1024, log_format="text")
            try:
                if back_end == "postgres":
                    values.update(database_url=stack.enter_context(_postgres()), blob_store="postgres")
                elif back_end == "s3":
                    from tests.store.s3_server import moto_s3

                    env = stack.enter_context(moto_s3())
                    values.update(blob_store="s3", s3_bucket=env["S3_BUCKET"], s3_endpoint_url=env["S3_ENDPOINT_URL"])
            except BaseException as error:  # pytest's skip included: the back-end is not here
                print(f"{back_end:<10} skipped: {type(error).__name__}: {error}")
                continue
            settings = AppSettings(_env_file=None, **values)
            base, ctx = stack.enter_context(_serving(settings))
            rows[back_end] = row = _measure(base, ctx, mebibytes, runs)
            baseline = rows.get("local")
            relative = f"{row['median'] / baseline['median']:.2f}x" if baseline else "-"
            print(f"{back_end:<10} {row['best']:>11.0f} {row['median']:>13.0f} {row['first_byte_ms']:>9.1f}ms {relative:>9}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
