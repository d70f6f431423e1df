"""API benchmark: submissions per second and status-read latency, embedded vs scaled.

Starts ``plantsolve serve`` as a real server on a loopback port, for each mode:
- embedded: SQLite (WAL) + in-process pool (the jobs run while submissions arrive);
- scaled:   PostgreSQL + Redis (the API only enqueues; no worker is started, so the
            numbers are the API's own).
Submits N small jobs from C concurrent connections, then reads GET /v1/jobs/{id} for
random jobs from 8 concurrent connections. Prints a table. Targets (issue 2):
>= 300 submissions/s, p99 status read < 20 ms.

    python bench/api.py [--quick] [--jobs N] [--concurrency C] [--modes embedded,scaled]
"""

from __future__ import annotations

import argparse
import asyncio
import os
import random
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import httpx
import numpy as np

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
PG_ADMIN = os.environ.get("BENCH_PG_ADMIN_URL", "postgresql://postgres@127.0.0.1:5432/postgres")
REDIS = os.environ.get("BENCH_REDIS_URL", "redis://127.0.0.1:6379/8")


def start_server(env: dict[str, str], port: int) -> subprocess.Popen:
    process = subprocess.Popen(
        [str(BIN / "plantsolve"), "serve", "--port", str(port), "--log-level", "warning"],
        cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
    )
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"http://127.0.0.1:{port}/readyz", timeout=1).status_code == 200:
                return process
        except httpx.HTTPError:
            pass
        if process.poll() is not None:
            raise SystemExit(f"server exited: {process.stderr.read().decode()[-2000:]}")
        time.sleep(0.2)
    raise SystemExit("server did not become ready")


async def submit_all(base: str, jobs: int, concurrency: int) -> tuple[float, list[float], list[str]]:
    latencies: list[float] = []
    ids: list[str] = []
    counter = iter(range(jobs))
    limits = httpx.Limits(max_connections=concurrency, max_keepalive_connections=concurrency)
    async with httpx.AsyncClient(base_url=base, limits=limits, timeout=30) as client:
        async def worker() -> None:
            for i in counter:
                started = time.perf_counter()
                response = await client.post("/v1/test-compute/jobs", json={"values": [float(i), 1.5]})
                latencies.append(time.perf_counter() - started)
                if response.status_code != 202:
                    raise SystemExit(f"submission failed: {response.status_code} {response.text[:300]}")
                ids.append(response.json()["id"])

        started = time.perf_counter()
        await asyncio.gather(*(worker() for _ in range(concurrency)))
        return time.perf_counter() - started, latencies, ids


async def read_all(base: str, ids: list[str], reads: int, concurrency: int) -> list[float]:
    latencies: list[float] = []
    rng = random.Random(7)
    picks = iter([rng.choice(ids) for _ in range(reads)])
    async with httpx.AsyncClient(base_url=base, timeout=30) as client:
        async def worker() -> None:
            for job_id in picks:
                started = time.perf_counter()
                response = await client.get(f"/v1/jobs/{job_id}")
                latencies.append(time.perf_counter() - started)
                assert response.status_code == 200

        await asyncio.gather(*(worker() for _ in range(concurrency)))
    return latencies


def run_mode(mode: str, jobs: int, concurrency: int, reads: int, port: int) -> dict:
    data_dir = Path(tempfile.mkdtemp(prefix=f"bench-{mode}-"))
    env = dict(os.environ, DATA_DIR=str(data_dir), PLUGINS="tests.support.kinds", PYTHONPATH=str(REPO))
    cleanup = None
    if mode == "scaled":
        import psycopg
        import redis

        name = f"plantsolve_bench_{uuid.uuid4().hex[:8]}"
        admin = psycopg.connect(PG_ADMIN, autocommit=True)
        admin.execute(f'CREATE DATABASE "{name}"')
        redis.Redis.from_url(REDIS).flushdb()
        env.update(DATABASE_URL=PG_ADMIN.rsplit("/", 1)[0].replace("postgresql://", "postgresql+psycopg://") + "/" + name, BROKER_URL=REDIS)

        def cleanup() -> None:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
            redis.Redis.from_url(REDIS).flushdb()

    server = start_server(env, port)
    try:
        base = f"http://127.0.0.1:{port}"
        elapsed, submit_latency, ids = asyncio.run(submit_all(base, jobs, concurrency))
        read_latency = asyncio.run(read_all(base, ids, reads, 1))
        started = time.perf_counter()
        loaded_latency = asyncio.run(read_all(base, ids, reads, 8))
        read_rate = reads / (time.perf_counter() - started)
    finally:
        server.terminate()
        server.wait(timeout=20)
        if cleanup:
            cleanup()
    ms = lambda values, q: 1000 * float(np.percentile(values, q))  # noqa: E731
    return {
        "mode": mode,
        "jobs": jobs,
        "rate": jobs / elapsed,
        "submit_p50": ms(submit_latency, 50),
        "submit_p99": ms(submit_latency, 99),
        "read_p50": ms(read_latency, 50),
        "read_p99": ms(read_latency, 99),
        "loaded_p50": ms(loaded_latency, 50),
        "loaded_p99": ms(loaded_latency, 99),
        "read_rate": read_rate,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer jobs (500) and reads (1000)")
    parser.add_argument("--jobs", type=int)
    parser.add_argument("--reads", type=int)
    parser.add_argument("--concurrency", type=int, default=16)
    parser.add_argument("--modes", default="embedded,scaled")
    parser.add_argument("--port", type=int, default=18765)
    args = parser.parse_args()
    jobs = args.jobs or (500 if args.quick else 2000)
    reads = args.reads or (1000 if args.quick else 3000)
    rows = [run_mode(mode, jobs, args.concurrency, reads, args.port + i) for i, mode in enumerate(args.modes.split(","))]
    print(
        f"\nAPI benchmark, {os.cpu_count()} cores, client and server on the same machine: {jobs} submissions from "
        f"{args.concurrency} connections; {reads} status reads from 1 connection (latency) and from 8 (throughput)"
    )
    header = (
        f"{'mode':<10} {'submits/s':>10} {'submit p50/p99 ms':>18} {'status p50/p99 ms':>18} "
        f"{'8-conn reads/s':>15} {'8-conn p50/p99 ms':>18}  target >=300/s, p99<20 ms"
    )
    print(header)
    print("-" * len(header))
    for row in rows:
        verdict = "met" if row["rate"] >= 300 and row["read_p99"] < 20 else "MISSED"
        print(
            f"{row['mode']:<10} {row['rate']:>10.0f} {row['submit_p50']:>8.1f}/{row['submit_p99']:<9.1f} "
            f"{row['read_p50']:>8.1f}/{row['read_p99']:<9.1f} {row['read_rate']:>15.0f} "
            f"{row['loaded_p50']:>8.1f}/{row['loaded_p99']:<9.1f}  {verdict}"
        )


if __name__ == "__main__":
    main()
