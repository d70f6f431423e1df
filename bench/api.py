"""API benchmark: submissions per second and status-read latency, embedded vs scaled.

Starts ``plantsolve serve`` as a real server on a loopback port, for each mode:
- embedded: SQLite (WAL) + the supervised pool of job processes (the jobs run while submissions arrive);
- scaled:   PostgreSQL + Redis (the API only enqueues; no worker is started, so the
            numbers are the API's own).
Load comes from ``wrk`` when it is installed (Debian package ``wrk``: a C client that leaves
the CPU to the server) and otherwise from a Python httpx client, which on this 2-core machine
takes about half the CPU itself and so understates the server. The table says which was used.
Submissions run for a fixed time from 1 connection, then from C connections (each makes a new job;
in embedded mode the pool runs them meanwhile), then GET /v1/jobs/{id} is read from 1 connection
(latency of a polling client) and from 8 (throughput), while the backlog of jobs is still running.
The trivial app (bench/baseline_app.py: FastAPI + SQLite, same uvicorn settings) runs first in the
same run, then each mode with the code of ``main`` (a temporary git worktree, or ``--before DIR``; ``--before none``
leaves it out) and with this checkout's code. Targets: submit p99 < 20 ms at 16 connections while jobs run, status p99 < 20 ms at 8
connections, single-connection submits >= 0.5x the trivial app's.

Beside the rates (which a loaded machine lowers), the table gives the CPU milliseconds the server's own process
spends per single-connection submit, read from /proc: the measure that holds where other work shares the cores.
``--smoke`` (CI runs it) makes each phase about a second long, embedded mode only: it proves the bench runs to its
table, not that the targets hold. The in-process table runs each row ``--rounds`` times in turn and gives the least and
the median (``--no-server``: that table alone).

    python bench/api.py [--quick | --smoke] [--seconds S] [--concurrency C] [--modes embedded,scaled]
                        [--client wrk|python] [--before main|DIR|none] [--in-process N] [--rounds R] [--no-server]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import re
import shutil
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


def launch(command: list[str], env: dict[str, str], data_dir: str | Path) -> subprocess.Popen:
    """A server whose output goes to ``server.log`` in its data dir: a pipe nobody reads fills up and stalls
    the server mid-run."""
    log_path = Path(data_dir) / "server.log"
    with log_path.open("wb") as log:
        process = subprocess.Popen(command, cwd=REPO, env=env, stdout=subprocess.DEVNULL, stderr=log)
    process.log_path = log_path
    return process


def start_server(env: dict[str, str], port: int) -> subprocess.Popen:
    # ``-m plantsolve.cli``: the package is imported from PYTHONPATH first (this checkout, or the code compared with)
    process = launch([sys.executable, "-m", "plantsolve.cli", "serve", "--port", str(port), "--log-level", "warning"], env,
                     env["DATA_DIR"])
    return wait_ready(process, f"http://127.0.0.1:{port}/readyz", ready=lambda status: status == 200)


async def submit_all(base: str, submit_path: str, jobs: int, concurrency: int) -> tuple[float, list[float], list[str]]:
    latencies: list[float] = []
    ids: list[str] = []
    counter = iter(range(jobs))
    limits = httpx.Limits(max_connections=concurrency, max_keepalive_connections=concurrency)
    async with httpx.AsyncClient(base_url=base, limits=limits, timeout=30) as client:
        async def worker() -> None:
            for i in counter:
                started = time.perf_counter()
                # never a value the test kind refuses (666: its check's test rule), so any number of jobs is accepted
                response = await client.post(submit_path, json={"values": [i + 0.5, 1.5]})
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


def process_cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of one process so far (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _requests_made(out: str) -> int:
    return int(re.search(r"(\d+) requests in", out).group(1))


def _wrk(args: list[str]) -> tuple[float, float, float, int]:
    """Run wrk; returns (requests/s, p50 ms, p99 ms, non-2xx responses)."""
    out = subprocess.run(["wrk", "--latency", *args], capture_output=True, text=True, check=True).stdout
    scale = {"us": 1e-3, "ms": 1.0, "s": 1e3}

    def percentile(name: str) -> float:
        value, unit = re.search(rf"^\s*{name}\s+([\d.]+)(us|ms|s)\s*$", out, re.M).groups()
        return float(value) * scale[unit]

    rate = float(re.search(r"Requests/sec:\s+([\d.]+)", out).group(1))
    bad = re.search(r"Non-2xx or 3xx responses:\s+(\d+)", out)
    _wrk.last_count = _requests_made(out)
    return rate, percentile("50%"), percentile("99%"), int(bad.group(1)) if bad else 0


def run_with_wrk(base: str, submit_path: str, seconds: float, concurrency: int, read_seconds: float,
                 server_pid: int) -> dict:
    """Single-connection submits, then submits from ``concurrency`` connections, then status reads
    of the newest job from 1 and 8 connections while the submitted backlog is still being run."""
    script = Path(tempfile.mkdtemp()) / "post.lua"
    script.write_text(
        'wrk.method = "POST"\nwrk.body = \'{"values": [1.5, 2.5]}\'\nwrk.headers["Content-Type"] = "application/json"\n'
    )
    url = f"{base}{submit_path}"
    cpu_before = process_cpu_seconds(server_pid)
    single_rate, _, _, bad_single = _wrk(["-t", "1", "-c", "1", "-d", f"{seconds}s", "-s", str(script), url])
    cpu_per_submit = (process_cpu_seconds(server_pid) - cpu_before) / max(_wrk.last_count, 1)
    threads = str(min(2, concurrency))
    rate, p50, p99, bad = _wrk(["-t", threads, "-c", str(concurrency), "-d", f"{seconds}s", "-s", str(script), url])
    if bad or bad_single:
        raise SystemExit(f"{bad + bad_single} submissions were not accepted")
    job_id = httpx.post(url, json={"values": [1.5, 2.5]}).json()["id"]
    read_url = f"{base}/v1/jobs/{job_id}"
    _, read_p50, read_p99, _ = _wrk(["-t", "1", "-c", "1", "-d", f"{read_seconds}s", read_url])
    read_rate, loaded_p50, loaded_p99, _ = _wrk(["-t", "2", "-c", "8", "-d", f"{read_seconds}s", read_url])
    return {
        "jobs": int(rate * seconds + single_rate * seconds), "single_rate": single_rate, "rate": rate,
        "submit_p50": p50, "submit_p99": p99, "read_p50": read_p50, "read_p99": read_p99,
        "loaded_p50": loaded_p50, "loaded_p99": loaded_p99, "read_rate": read_rate, "cpu_per_submit": cpu_per_submit,
    }


def run_with_python(base: str, submit_path: str, jobs: int, concurrency: int, reads: int, server_pid: int) -> dict:
    # enough single submits that the kernel's 10 ms CPU clock tick is a small part of their CPU time
    single = max(jobs // 2, 100)
    started, cpu_before = time.perf_counter(), process_cpu_seconds(server_pid)
    asyncio.run(submit_all(base, submit_path, single, 1))
    single_rate = single / (time.perf_counter() - started)
    cpu_per_submit = (process_cpu_seconds(server_pid) - cpu_before) / single
    elapsed, submit_latency, ids = asyncio.run(submit_all(base, submit_path, jobs, concurrency))
    read_latency = asyncio.run(read_all(base, ids, reads, 1))
    started = time.perf_counter()
    loaded_latency = asyncio.run(read_all(base, ids, reads, 8))
    read_rate = reads / (time.perf_counter() - started)
    ms = lambda values, q: 1000 * float(np.percentile(values, q))  # noqa: E731
    return {
        "jobs": jobs, "single_rate": single_rate, "rate": jobs / elapsed, "submit_p50": ms(submit_latency, 50),
        "submit_p99": ms(submit_latency, 99), "read_p50": ms(read_latency, 50), "read_p99": ms(read_latency, 99),
        "loaded_p50": ms(loaded_latency, 50), "loaded_p99": ms(loaded_latency, 99), "read_rate": read_rate,
        "cpu_per_submit": cpu_per_submit,
    }


# How long a server may take to answer ready (the service: its warm job parent imports every kind, tens of CPU
# seconds on a loaded machine); past it the bench stops with the server's log instead of waiting forever.
START_SECONDS = 180.0
# How long the in-process measure may run (its app's start-up included)
IN_PROCESS_SECONDS = 900.0


def wait_ready(process: subprocess.Popen, url: str, ready=lambda status: status < 500) -> subprocess.Popen:
    deadline = time.monotonic() + START_SECONDS
    while time.monotonic() < deadline:
        try:
            if ready(httpx.get(url, timeout=1).status_code):
                return process
        except httpx.HTTPError:
            pass
        if process.poll() is not None:
            raise SystemExit(f"server exited: {process.log_path.read_text(errors='replace')[-2000:]}")
        time.sleep(0.2)
    process.kill()
    raise SystemExit(f"server not ready within {START_SECONDS:g} s: "
                     f"{process.log_path.read_text(errors='replace')[-2000:]}")


def run_mode(mode: str, args, port: int, code: Path = REPO, label: str | None = None) -> dict:
    """One server (the trivial app, or plantsolve in ``mode`` with the code in ``code``) under the load phases."""
    data_dir = Path(tempfile.mkdtemp(prefix=f"bench-{mode}-"))
    env = dict(os.environ, DATA_DIR=str(data_dir), PLUGINS="tests.support.kinds", PYTHONPATH=str(code))
    cleanup = None
    submit_path = "/v1/test-compute/jobs"
    if mode == "baseline":
        submit_path = "/v1/jobs"
        server = wait_ready(launch(
            [sys.executable, str(REPO / "bench" / "baseline_app.py"), "--port", str(port), "--db", str(data_dir / "b.db")],
            env, data_dir), f"http://127.0.0.1:{port}/v1/jobs/none")
    else:
        if mode == "scaled":
            services, cleanup = scaled_services()
            env.update(services)
        server = start_server(env, port)
    try:
        base = f"http://127.0.0.1:{port}"
        if args.client == "wrk":
            row = run_with_wrk(base, submit_path, args.seconds, args.concurrency, args.read_seconds, server.pid)
        else:
            row = run_with_python(base, submit_path, args.jobs, args.concurrency, args.reads, server.pid)
    finally:
        server.terminate()
        server.wait(timeout=30)
        if cleanup:
            cleanup()
    return {"mode": label or mode, **row}


# The app called in process (ASGI, no network, no client): the CPU seconds of the app's own code per request,
# which other work on the machine does not inflate the way it does rates and latencies. Jobs run meanwhile
# (the embedded pool). Prints one JSON line: CPU ms per submit, per submit with an Idempotency-Key and per status read.
IN_PROCESS = r"""
import asyncio, importlib.util, json, os, sys, time
N, APP = int(sys.argv[1]), sys.argv[2]
if APP == "baseline":
    spec = importlib.util.spec_from_file_location("baseline_app", sys.argv[3])
    module = importlib.util.module_from_spec(spec); spec.loader.exec_module(module)
    app, submit_path = module.create_app(os.path.join(os.environ["DATA_DIR"], "b.db")), "/v1/jobs"
else:
    from plantsolve.app.main import create_app
    from plantsolve.app.settings import AppSettings
    app, submit_path = create_app(AppSettings()), "/v1/test-compute/jobs"
BODY = b'{"values": [1.5, 2.5]}'

async def call(method, path, body=b"", extra=()):
    headers = [(b"host", b"127.0.0.1"), (b"content-type", b"application/json"), (b"content-length", b"%d" % len(body)),
               *extra]
    scope = {"type": "http", "asgi": {"version": "3.0"}, "http_version": "1.1", "method": method, "scheme": "http",
             "path": path, "raw_path": path.encode(), "query_string": b"", "root_path": "", "headers": headers,
             "client": ("127.0.0.1", 5555), "server": ("127.0.0.1", 8000)}
    messages = [{"type": "http.request", "body": body, "more_body": False}]
    answer = {}

    async def receive():
        return messages.pop() if messages else await asyncio.Event().wait()

    async def send(message):
        answer.setdefault("status", message.get("status"))
        answer["body"] = answer.get("body", b"") + message.get("body", b"")

    await app(scope, receive, send)
    return answer

async def measure():
    async with app.router.lifespan_context(app):
        job_id = json.loads((await call("POST", submit_path, BODY))["body"])["id"]
        for _ in range(200):  # warm up: statement caches, first-use imports
            await call("POST", submit_path, BODY); await call("GET", f"/v1/jobs/{job_id}")
        started = time.process_time()
        for _ in range(N):
            assert (await call("POST", submit_path, BODY))["status"] in (200, 202)
        submit = (time.process_time() - started) / N
        started = time.process_time()
        for i in range(N):  # each with a key of its own (the trivial app ignores the header)
            assert (await call("POST", submit_path, BODY, [(b"idempotency-key", b"bench-%d" % i)]))["status"] == 202
        keyed = (time.process_time() - started) / N
        started = time.process_time()
        for _ in range(N):
            assert (await call("GET", f"/v1/jobs/{job_id}"))["status"] == 200
        read = (time.process_time() - started) / N
    print(json.dumps({"submit_ms": 1000 * submit, "keyed_ms": 1000 * keyed, "read_ms": 1000 * read}))

import uvloop; uvloop.run(measure())
"""


def scaled_services() -> tuple[dict[str, str], callable]:
    """A new PostgreSQL database and the emptied Redis database: the settings of scaled mode on them, and the
    function that drops the database and empties Redis again."""
    import psycopg
    import redis

    name = f"plantsolve_bench_{uuid.uuid4().hex[:8]}"
    admin = psycopg.connect(PG_ADMIN, autocommit=True)
    admin.execute(f'CREATE DATABASE "{name}"')
    redis.Redis.from_url(REDIS).flushdb()
    env = {"DATABASE_URL": PG_ADMIN.rsplit("/", 1)[0].replace("postgresql://", "postgresql+psycopg://") + "/" + name,
           "BROKER_URL": REDIS}

    def cleanup() -> None:
        admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        admin.close()
        redis.Redis.from_url(REDIS).flushdb()

    return env, cleanup


def in_process(label: str, code: Path, requests: int, *, scaled: bool = False) -> dict:
    """CPU ms per submit and per status read of an app called in process (see IN_PROCESS); ``label`` 'baseline' is
    the trivial app; ``scaled``: on PostgreSQL and Redis (no worker: the messages wait in the queue)."""
    data_dir = tempfile.mkdtemp(prefix="bench-inprocess-")
    env = dict(os.environ, DATA_DIR=data_dir, PLUGINS="tests.support.kinds", PYTHONPATH=str(code), LOG_LEVEL="warning")
    cleanup = None
    if scaled:
        services, cleanup = scaled_services()
        env.update(services)
    args = [sys.executable, "-c", IN_PROCESS, str(requests), "baseline" if label == "baseline" else "plantsolve",
            str(REPO / "bench" / "baseline_app.py")]
    try:
        done = subprocess.run(args, cwd=data_dir, env=env, capture_output=True, text=True, timeout=IN_PROCESS_SECONDS)
        if done.returncode:
            raise SystemExit(f"the in-process run of {label!r} ({code}) failed:\n{done.stderr[-3000:]}")
        out = done.stdout
    finally:
        shutil.rmtree(data_dir, ignore_errors=True)
        if cleanup is not None:
            cleanup()
    return {"mode": label, **json.loads(out.strip().splitlines()[-1])}


def main_checkout() -> tuple[Path, callable]:
    """A temporary worktree of ``main`` (the code before this branch), and the function that removes it."""
    path = Path(tempfile.mkdtemp(prefix="bench-api-main-")) / "main"
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(path), "main"], check=True,
                   capture_output=True)
    return path, lambda: subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(path)],
                                        check=False, capture_output=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="shorter runs")
    parser.add_argument("--smoke", action="store_true", help="about a second per phase, embedded only (CI)")
    parser.add_argument("--client", choices=("wrk", "python"), default="wrk" if shutil.which("wrk") else "python")
    parser.add_argument("--seconds", type=float, help="wrk: submission phase length")
    parser.add_argument("--read-seconds", type=float, help="wrk: each read phase length")
    parser.add_argument("--jobs", type=int, help="python client: submissions")
    parser.add_argument("--reads", type=int, help="python client: status reads per phase")
    parser.add_argument("--concurrency", type=int, default=16)
    parser.add_argument("--modes", default="embedded,scaled")
    parser.add_argument("--port", type=int, default=18765)
    parser.add_argument("--in-process", type=int, default=None, metavar="N",
                        help="requests of each kind in the in-process CPU table (0: no table)")
    parser.add_argument("--rounds", type=int, default=3, help="runs of each row of the in-process table, in turn")
    parser.add_argument("--no-server", action="store_true", help="the in-process table alone (no server, no load)")
    parser.add_argument("--before", default="main",
                        help="the code to compare with in the same run: 'main' (a temporary worktree), a directory "
                             "holding the plantsolve package, or 'none'")
    args = parser.parse_args()
    if args.smoke:
        args.seconds, args.read_seconds, args.jobs, args.reads, args.modes = 1, 1, 60, 60, "embedded"
        args.before = "none"
    args.seconds = args.seconds or (4 if args.quick else 10)
    args.read_seconds = args.read_seconds or (3 if args.quick else 6)
    args.jobs = args.jobs or (500 if args.quick else 2000)
    args.reads = args.reads or (1000 if args.quick else 3000)
    modes = [mode for mode in args.modes.split(",") if mode != "baseline"]
    before, remove = (None, None) if args.before == "none" else main_checkout() if args.before == "main" else \
        (Path(args.before), None)
    before_label = "main" if args.before == "main" else Path(args.before).name
    try:
        requests = args.in_process if args.in_process is not None else (0 if args.smoke else 1000 if args.quick else 3000)
        cpu_rows = in_process_rows(modes, before, before_label, requests, args.rounds) if requests else []
        rows = [] if args.no_server else [run_mode("baseline", args, args.port)]
        for i, mode in enumerate(modes if rows else ()):
            if before is not None:
                rows.append(run_mode(mode, args, args.port + 1 + 2 * i, before, f"{mode} ({before_label})"[:20]))
            rows.append(run_mode(mode, args, args.port + 2 + 2 * i))
    finally:
        if remove is not None:
            remove()
    if rows:
        print_server_table(rows, args)
    if cpu_rows:
        print(f"\nIn process (the ASGI app called directly: no network, no client; embedded: SQLite, jobs running; scaled: "
              f"PostgreSQL and Redis, the messages queued): CPU ms per request of every thread of the process, least and "
              f"median of {args.rounds} runs taken in turn (the least is the run other work on the machine disturbed least)")
        print(f"{'mode':<20}" + "".join(f" {title:>12} {'median':>8} {'vs baseline':>11}" for title in
                                        ("submit", "keyed submit", "status read")))
        base = cpu_rows[0]
        for row in cpu_rows:
            print(f"{row['mode']:<20}" + "".join(f" {row[f'{name}_ms']:>12.3f} {row[f'{name}_median']:>8.3f} "
                                                 f"{row[f'{name}_ms'] / base[f'{name}_ms']:>10.2f}x" for name in MEASURES))
        print("keyed submit: each with an Idempotency-Key of its own (the trivial app ignores it)")

MEASURES = ("submit", "keyed", "read")


def in_process_rows(modes: list[str], before: Path | None, before_label: str, requests: int, rounds: int) -> list[dict]:
    """The in-process measure of the trivial app and of each mode (with the code compared with, then this checkout's),
    ``rounds`` times in turn, so that a spell of load elsewhere on the machine falls on every row alike: per row the
    least CPU ms per request and the median."""
    runs = [("baseline", REPO, False)]
    for mode in modes:
        if before is not None:
            runs.append((f"{mode} ({before_label})"[:20], before, mode == "scaled"))
        runs.append((mode, REPO, mode == "scaled"))
    samples: dict[str, list[dict]] = {label: [] for label, _, _ in runs}
    for _ in range(rounds):
        for label, code, scaled in runs:
            samples[label].append(in_process(label, code, requests, scaled=scaled))
    return [{"mode": label, **{f"{name}_ms": min(run[f"{name}_ms"] for run in taken) for name in MEASURES},
             **{f"{name}_median": float(np.median([run[f"{name}_ms"] for run in taken])) for name in MEASURES}}
            for label, taken in samples.items()]


def print_server_table(rows: list[dict], args) -> None:
    baseline = next(row for row in rows if row["mode"] == "baseline")
    load = f"wrk, {args.seconds:g} s per phase" if args.client == "wrk" else "python httpx"
    print(
        f"\nAPI benchmark ({load}), {os.cpu_count()} cores, client and server on one machine. Submits from 1 connection "
        f"and from {args.concurrency}; status reads from 1 and 8 connections while the submitted jobs run "
        "(baseline: bench/baseline_app.py, FastAPI + SQLite, no jobs)"
    )
    header = (
        f"{'mode':<20} {'jobs':>6} {'1-conn submits/s':>17} {'vs baseline':>11} {f'{args.concurrency}-conn submits/s':>18} "
        f"{'submit p50/p99 ms':>18} {'status p50/p99 ms':>18} {'8-conn reads/s':>15} {'8-conn p50/p99 ms':>18} "
        f"{'CPU ms/submit':>13} {'vs baseline':>11}  targets"
    )
    print(header)
    print("-" * len(header))
    for row in rows:
        ratio = row["single_rate"] / baseline["single_rate"]
        met = row["submit_p99"] < 20 and row["loaded_p99"] < 20 and ratio >= 0.5
        verdict = "-" if row is baseline else ("met" if met else "MISSED")
        print(
            f"{row['mode']:<20} {row['jobs']:>6} {row['single_rate']:>17.0f} {ratio:>10.2f}x {row['rate']:>18.0f} "
            f"{row['submit_p50']:>8.1f}/{row['submit_p99']:<9.1f} {row['read_p50']:>8.1f}/{row['read_p99']:<9.1f} "
            f"{row['read_rate']:>15.0f} {row['loaded_p50']:>8.1f}/{row['loaded_p99']:<9.1f} "
            f"{1000 * row['cpu_per_submit']:>13.2f} {row['cpu_per_submit'] / baseline['cpu_per_submit']:>10.2f}x  {verdict}"
        )
    print(f"targets: submit p99 < 20 ms at {args.concurrency} connections, 8-connection status p99 < 20 ms, "
          "1-connection submits >= 0.5x the baseline. CPU ms/submit: the server process alone (its job processes "
          "not counted), during the 1-connection phase")


if __name__ == "__main__":
    main()
