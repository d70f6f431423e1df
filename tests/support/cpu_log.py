"""What each test costs, to find what makes the suite slow: with ``PLANTSOLVE_TEST_CPU_LOG=<file>`` set, every
test appends one JSON line to that file — its set-up, call and teardown together: the CPU seconds of the pytest
process (all its threads) and of the children it reaped meanwhile (subprocesses, job processes, Celery workers),
and the wall seconds. Under pytest-xdist each worker appends its own lines, named by ``worker``. Unset, nothing is
measured. ``python -m tests.support.cpu_log <file>`` ranks the lines.

CPU, not wall, is what stays comparable on a machine others load; a module- or session-scoped fixture's set-up and
teardown are charged to the test that ran them (its first and its last)."""

from __future__ import annotations

import argparse
import json
import os
import resource
import time
from collections import defaultdict

import pytest

ENV = "PLANTSOLVE_TEST_CPU_LOG"


def _cpu_seconds() -> tuple[float, float]:
    """(this process's CPU, its reaped children's user + system CPU), in seconds."""
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.process_time(), children.ru_utime + children.ru_stime


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item, nextitem):
    path = os.environ.get(ENV)
    if not path or getattr(item, "_cpu_logged", False):  # hooked twice (the conftest's and a -p of it): one line
        return (yield)
    item._cpu_logged = True
    wall, (own, children) = time.perf_counter(), _cpu_seconds()
    try:
        return (yield)
    finally:
        wall_after, (own_after, children_after) = time.perf_counter(), _cpu_seconds()
        line = {"nodeid": item.nodeid, "worker": os.environ.get("PYTEST_XDIST_WORKER", "main"),
                "own_cpu": round(own_after - own, 4), "children_cpu": round(children_after - children, 4),
                "cpu": round(own_after - own + children_after - children, 4), "wall": round(wall_after - wall, 4)}
        with open(path, "a", encoding="utf-8") as log:  # one short write in append mode: workers' lines stay whole
            log.write(json.dumps(line) + "\n")


def read(path: str) -> list[dict]:
    with open(path, encoding="utf-8") as log:
        return [json.loads(line) for line in log if line.strip()]


def rank(rows: list[dict], top: int = 20) -> str:
    """The totals per worker, then the ``top`` tests by CPU and by wall, then the ``top`` files by CPU."""
    out = [f"{len(rows)} tests, {sum(r['cpu'] for r in rows):.1f} CPU s, {sum(r['wall'] for r in rows):.1f} wall s"]
    workers: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
    files: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
    for row in rows:
        for total in (workers[row["worker"]], files[row["nodeid"].split("::")[0]]):
            total[0] += row["cpu"]
            total[1] += row["wall"]
            total[2] += 1
    out += [f"  {name}: {n} tests, {cpu:.1f} CPU s, {wall:.1f} wall s" for name, (cpu, wall, n) in sorted(workers.items())]
    for key in ("cpu", "wall"):
        out += ["", f"top {top} by {key}:", f"{'CPU s':>8} {'own':>8} {'children':>8} {'wall s':>8}  test"]
        out += [f"{r['cpu']:8.2f} {r['own_cpu']:8.2f} {r['children_cpu']:8.2f} {r['wall']:8.2f}  {r['nodeid']}"
                for r in sorted(rows, key=lambda r: -r[key])[:top]]
    out += ["", f"top {top} files by CPU:", f"{'CPU s':>8} {'wall s':>8} {'tests':>6}  file"]
    out += [f"{cpu:8.2f} {wall:8.2f} {n:6d}  {name}"
            for name, (cpu, wall, n) in sorted(files.items(), key=lambda item: -item[1][0])[:top]]
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description="rank the tests of a PLANTSOLVE_TEST_CPU_LOG file")
    parser.add_argument("log")
    parser.add_argument("--top", type=int, default=20)
    args = parser.parse_args()
    print(rank(read(args.log), args.top))


if __name__ == "__main__":
    main()
