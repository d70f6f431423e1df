"""What keeping a solve's output before its commit costs a job that is not killed: this checkout beside ``--before``
(default ``main``, in a temporary worktree) in the same run, the checkouts taken in turn.

Each case runs one job through the runner (``run_job``, in process, the job's input stored first and not measured),
in a fresh process per run with the checkout's source: the embedded store (SQLite, blobs in a local folder) and, with
``--scaled``, the scaled one (a PostgreSQL database of its own, blobs in its table). Per case and checkout: CPU s of
the run (least of ``--repeat``), bytes put into the blob store during the run, bytes the process passed to write()
(``/proc/self/io`` wchar: blob files, SQLite's file and WAL; a PostgreSQL server's own writes are not in it), and the
bytes the blob store holds afterwards.

Cases: rigidity's ``four_bar_and_door.json`` (a small result), perfmap's ``n3_fan_map.csv`` (a 0.5 MB result, 2 MB of
artifacts) and dedup's ``tunnel_3rings.ifc`` (a payload, the optimized model, that is also an artifact).

    python bench/kept_result.py [--before main|DIR] [--repeat 3] [--scaled]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import uuid
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
ADMIN = "postgresql://postgres@127.0.0.1:5432/postgres"
CASES = (("rigidity", "four_bar_and_door.json"), ("perfmap", "n3_fan_map.csv"), ("dedup", "tunnel_3rings.ifc"))

# run in a fresh process with the checkout's source first on the path: one job, measured
CHILD = r'''
import json, os, sys, time, uuid
from pathlib import Path
from plantsolve.app.settings import AppSettings
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.runner import run_job
from plantsolve.jobs.service import JobService, NewJob

kind, path, data, database = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3]), sys.argv[4]
values = dict(data_dir=data, embedded_mode="thread", min_free_disk_bytes=0)
if database:
    values["database_url"] = database
ctx = ServiceContext.create(AppSettings(_env_file=None, **values), migrate=True)


class Quiet:
    def enqueue(self, job_id, kind=""): ...


service = JobService(ctx, Quiet())
if path.suffix == ".json":
    job_id = service.submit_json(kind, path.read_bytes(), None).job.id
else:  # stored as the intake stores an upload; its reading at submission is not what is measured
    job_id = uuid.uuid4()
    blob = ctx.files.put(f"{job_id}/input/{path.name}", path.read_bytes())
    service.store(NewJob(ctx.spec(kind), job_id, uuid.uuid4().hex, None, {"input_kind": "upload",
                  "input_file": blob.key, "input_filename": path.name, "input_options": None}))
ctx.spec(kind).preload()
put_bytes = []
real_put = ctx.files.put
ctx.files.put = lambda key, data: put_bytes.append(len(data)) or real_put(key, data)


def wchar():
    return int(next(line for line in open("/proc/self/io") if line.startswith("wchar")).split()[1])


written, cpu = wchar(), time.process_time()
outcome = run_job(ctx, job_id, worker="bench", requeue=lambda *a: None)
cpu, written = time.process_time() - cpu, wchar() - written
held = sum(a.size for a in ctx.repo.artifacts(job_id))
root = data / "artifacts"
left = sum(p.stat().st_size for p in root.rglob("*") if p.is_file() and "/input/" not in str(p)) if not database \
    else None
print(json.dumps({"outcome": outcome, "cpu": cpu, "put": sum(put_bytes), "puts": len(put_bytes), "wchar": written,
                  "artifacts": held, "left": left, "result": len(json.dumps(ctx.repo.get(job_id).result))}))
ctx.close()
'''


def run(code: Path, kind: str, name: str, database: str) -> dict:
    with tempfile.TemporaryDirectory(prefix="kept-") as data:
        env = {**os.environ, "PYTHONPATH": str(code), "OPENBLAS_NUM_THREADS": "1", "LOG_LEVEL": "warning"}
        done = subprocess.run([sys.executable, "-c", CHILD, kind, str(REPO / "examples" / kind / name), data,
                               database], env=env, capture_output=True, text=True, cwd=code)
        if done.returncode:
            raise SystemExit(done.stderr[-3000:])
        return json.loads(done.stdout.strip().splitlines()[-1])


def _database() -> tuple[str, str]:
    import psycopg

    name = f"plantsolve_kept_{uuid.uuid4().hex[:8]}"
    with psycopg.connect(ADMIN, autocommit=True) as admin:
        admin.execute(f'CREATE DATABASE "{name}"')
    return name, f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}"


def _drop(name: str) -> None:
    import psycopg

    with psycopg.connect(ADMIN, autocommit=True) as admin:
        admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", default="main", help="the checkout beside this one (a folder or a revision)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--scaled", action="store_true", help="also the scaled store (local PostgreSQL)")
    args = parser.parse_args()
    remove = None
    if Path(args.before).is_dir():
        before = Path(args.before)
    else:
        before = remove = Path(tempfile.mkdtemp(prefix="kept-before-")) / "before"
        subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(before), args.before], check=True,
                       capture_output=True)
    sides = (("before", before), ("this", REPO))
    stores = ("embedded", "scaled") if args.scaled else ("embedded",)
    print("| store | case | checkout | CPU s | blob bytes put (puts) | bytes written (wchar) | blob bytes held after |"
          " result JSON |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    try:
        for store in stores:
            for kind, name in CASES:
                runs: dict[str, list[dict]] = {label: [] for label, _ in sides}
                for _ in range(args.repeat):
                    for label, code in sides:
                        database, url = _database() if store == "scaled" else ("", "")
                        try:
                            runs[label].append(run(code, kind, name, url))
                        finally:
                            if database:
                                _drop(database)
                for label, _ in sides:
                    best = min(runs[label], key=lambda r: r["cpu"])
                    assert all(r["outcome"] == "succeeded" for r in runs[label]), runs[label]
                    left = "–" if best["left"] is None else f"{best['left']:,}"
                    print(f"| {store} | {kind} `{name}` | {label} | {best['cpu']:.3f} | {best['put']:,} ({best['puts']}) "
                          f"| {best['wchar']:,} | {left} | {best['result']:,} |", flush=True)
    finally:
        if remove is not None:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(remove)], check=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
