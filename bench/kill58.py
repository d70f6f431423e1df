"""Killed processes the kill scenarios of ``bench/kill_scenarios.py`` leave out, on a real ``plantsolve serve``
(embedded default, SQLite, a private data dir; its ``Service``: LEASE_SECONDS 8, sweep 1 s, two job processes):

- ``warm-idle-long``: the service idle for ``--idle`` seconds, then kill -9 of its warm parent and two jobs submitted at
  once: do they run, and what does ``/readyz`` say meanwhile;
- ``warm-and-job``: kill -9 of the warm parent and of one of two running job processes at the same moment: each job
  solved once, and what the lost attempt's history says about how its process ended;
- ``warm-crash-loop``: a warm parent that dies at every start (the out-of-memory killer at each start, a library that
  crashes at import: a ``sitecustomize`` on the service's path kills each new interpreter started with ``-c``, which
  only the warm parent is, ``--die-after`` seconds after its start, while a flag file exists) for ``--loop`` seconds
  with two jobs submitted and clients' requests going on, then the flag removed: how many warm parents were started,
  the CPU seconds the API process and the warm parents it reaped spent, what ``/readyz``, HTTP and the log said, and
  whether the jobs run once it can start again;
- ``job-crash-loop``: every job process killed as soon as it appears, for ``--loop`` seconds, one job submitted: how
  many processes were started for it (a loop that spins starts hundreds), how its attempts ended;
- ``api-handover``: twelve submissions at once and kill -9 of the API in the middle of them (some rows committed and
  not handed over), then ``serve`` again: every job answered 202, and every row, ends solved exactly once;
- ``job-cpu``: what the warm parent holds for a job: three jobs of each of two real kinds (``examples/rigidity``'s
  four-bar linkage, ``examples/perfmap``'s fan map), one at a time; CPU seconds each job's process spent (the warm
  parent's reaped children's, over the jobs): a warm parent without the kind's solver makes each job import it;
- ``disk-full``: the data dir (SQLite file, artifacts) on a 48 MiB tmpfs filled up while two jobs run (their result
  writes meet ENOSPC), space freed after 8 s: final statuses, what the reports say, ``/readyz`` meanwhile, and a job
  submitted after.

Each row: statuses, solves per job (marker files, off the data dir), attempts and their outcomes, ``/readyz`` answers in
order, what HTTP answered meanwhile, seconds until the jobs ended, and a note. ``--before DIR`` runs the same on another
checkout (its source, this checkout's .venv and bench folder) first.

    python bench/kill58.py [--before /tmp/base] [--only warm-idle-long,...] [--idle 30] [--loop 30]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from kill_scenarios import HERE, Service, _forkservers  # noqa: E402

SCENARIOS = "warm-idle-long,warm-and-job,warm-crash-loop,job-crash-loop,api-handover,job-cpu,disk-full"
EXAMPLES = (("rigidity", "examples/rigidity/four_bar_and_door.json"), ("perfmap", "examples/perfmap/n3_fan_map.json"))
TICKS = os.sysconf("SC_CLK_TCK")
WARM_LOG = "plantsolve.processes: the job processes' warm parent"
# see warm-crash-loop: every interpreter of the service imports it; only a warm parent's command line is ``-c``
# (``--die-after`` seconds after its start: in its imports, or soon after it came up, as the out-of-memory killer would)
WARM_DIES = """import os, signal, sys, threading
if sys.argv[:1] == ["-c"] and os.path.exists(os.environ.get("KILL58_WARM_DIES", "/nonexistent")):
    threading.Timer(float(os.environ["KILL58_DIE_AFTER"]), os.kill, (os.getpid(), signal.SIGKILL)).start()
"""


def _cpu(pid: int) -> float:
    """CPU seconds of ``pid`` and of its children it has reaped (the warm parents that died)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return sum(int(f) for f in fields[11:15]) / TICKS


def _log_lines(data: Path, *needles: str) -> int:
    try:
        text = (data / "serve.log").read_text(errors="replace")
    except OSError:
        return 0
    return sum(text.count(needle) for needle in needles)


def _histories(jobs: list[dict]) -> list[list[str]]:
    return [[f"{a['outcome']}: {a.get('error') or ''}"[:110] for a in j.get("attempts") or []] for j in jobs]


def scenario(name: str, tree: Path, idle: float, loop: float, die_after: float) -> dict:
    data = Path(tempfile.mkdtemp(prefix=f"kill58-{name}-"))
    markers = Path(tempfile.mkdtemp(prefix=f"kill58-{name}-markers-"))
    service = Service(tree, data)
    (markers / "site").mkdir()
    (markers / "site" / "sitecustomize.py").write_text(WARM_DIES)
    service.env["PYTHONPATH"] = f"{markers / 'site'}{os.pathsep}{service.env['PYTHONPATH']}"
    service.env["KILL58_WARM_DIES"] = str(markers / "warm-dies")
    service.env["KILL58_DIE_AFTER"] = str(die_after)
    mounted = False
    note = ""
    ids: list[str] = []
    try:
        if name == "disk-full":
            subprocess.run(["mount", "-t", "tmpfs", "-o", "size=48m", "tmpfs", str(data)], check=True)
            mounted = True
            service.env["MIN_FREE_DISK_BYTES"] = str(4 << 20)
        service.start()
        if name == "warm-idle-long":
            time.sleep(idle)
            os.kill(_forkservers(service.process.pid)[0], signal.SIGKILL)
            killed = time.monotonic()
            ids = service.submit(2, markers)
            service.wait_ready(120)
            note = f"/readyz 200 again {time.monotonic() - killed:.1f} s after the kill"
        elif name == "warm-and-job":
            ids = service.submit(2, markers)
            pids = service.wait_claimed(ids, 2)
            time.sleep(0.5)
            os.kill(_forkservers(service.process.pid)[0], signal.SIGKILL)
            os.kill(pids[0], signal.SIGKILL)
        elif name == "warm-crash-loop":
            flag = Path(service.env["KILL58_WARM_DIES"])
            flag.write_text("1")
            before = _cpu(service.process.pid)
            os.kill(_forkservers(service.process.pid)[0], signal.SIGKILL)
            ids = service.submit(2, markers)
            warm_seen: set[int] = set()
            until = time.monotonic() + loop
            while time.monotonic() < until:
                warm_seen.update(_forkservers(service.process.pid))
                service.ready()
                service.probe(ids[0])
                time.sleep(0.3)
            cpu = _cpu(service.process.pid) - before
            flag.unlink()
            healed = time.monotonic()
            service.wait_ready(240)
            note = (f"{len(warm_seen)} warm parents seen in {loop:.0f} s, {cpu:.1f} CPU s; log lines: "
                    f"{_log_lines(data, WARM_LOG)} about the warm parent's end or failed start; /readyz 200 "
                    f"{time.monotonic() - healed:.1f} s after the flag went")
        elif name == "job-crash-loop":
            ids = service.submit(1, markers)
            killed: set[int] = set()
            until = time.monotonic() + loop
            while time.monotonic() < until:
                for pid in service.job_processes():
                    if pid not in killed:
                        try:
                            os.kill(pid, signal.SIGKILL)
                        except ProcessLookupError:
                            pass
                        killed.add(pid)
                time.sleep(0.005)
            job = service.jobs(ids)[0]
            note = (f"{len(killed)} job processes killed in {loop:.0f} s; then: {job['status']}, "
                    f"attempt {job['attempt']}")
        elif name == "api-handover":
            answers: list[tuple[int, str | None]] = []
            lock = threading.Lock()

            def submit(i: int) -> None:
                body = {"values": [i + 0.5], "seconds": 0.5, "marker_dir": str(markers / str(i))}
                try:
                    response = service.client.post("/v1/test-compute/jobs", json=body, timeout=10)
                    said = (response.status_code, response.json().get("id"))
                except Exception as error:  # the API died under it
                    said = (0, type(error).__name__)
                with lock:
                    answers.append(said)

            threads = [threading.Thread(target=submit, args=(i,)) for i in range(12)]
            for thread in threads:
                thread.start()
            time.sleep(random.uniform(0.02, 0.12))
            service.process.kill()
            service.process.wait()
            for thread in threads:
                thread.join()
            service.start()
            rows = service.client.get("/v1/jobs", params={"limit": 200}).json()["items"]
            ids = [row["id"] for row in rows]
            accepted = [job_id for code, job_id in answers if code == 202]
            note = (f"{len(accepted)} answered 202, {sum(code == 0 for code, _ in answers)} got no answer, "
                    f"{len(ids)} rows; every 202 a row: {set(accepted) <= set(ids)}")
        elif name == "job-cpu":
            (warm,) = _forkservers(service.process.pid)
            per_job = {}
            for kind, example in EXAMPLES:
                body = (HERE / example).read_bytes()
                before = _cpu(warm)
                for _ in range(3):
                    job_id = service.client.post(f"/v1/{kind}/jobs", content=body,
                                                 headers={"Content-Type": "application/json"}).json()["id"]
                    ids.append(job_id)
                    service.wait_finished([job_id], 120)
                per_job[kind] = round((_cpu(warm) - before) / 3, 2)
            note = f"CPU s per job process: {per_job}"
        elif name == "disk-full":
            ids = service.submit(2, markers)
            service.wait_claimed(ids, 2)
            filler = data / "filler"
            subprocess.run(["dd", "if=/dev/zero", f"of={filler}", "bs=1M"], capture_output=True)
            service.probe_for(8, ids[0])
            during = [j["status"] for j in service.jobs(ids)]
            filler.unlink()
            later = service.submit(1, markers / "later")
            ids += later
            note = f"statuses when space came back: {during}"
        else:
            raise ValueError(name)
        ids = ids + service.extra
        jobs, seconds = service.wait_finished(ids, 240)
        service.wait_ready(60)
    finally:
        service.stop()
        if mounted:
            subprocess.run(["umount", "-l", str(data)], check=False)
    folders = sorted(p for p in markers.rglob("*") if p.is_dir() and p.name.isdigit() and any(p.iterdir()))
    if name == "api-handover":  # one marker folder per submission: the solves of the rows that ran
        solves = sorted(len(list(folder.iterdir())) for folder in folders)
    elif name == "job-cpu":  # real kinds: no marker files
        solves = []
    else:
        solves = [len(list((markers / str(i)).glob("done-*"))) if (markers / str(i)).exists() else 0
                  for i in range(min(len(ids), 2 if name != "job-crash-loop" else 1))]
    return {"scenario": name, "statuses": [j["status"] for j in jobs], "solves": solves,
            "attempts": [j["attempt"] for j in jobs], "histories": _histories(jobs),
            "reports": [((j.get("report") or {}).get("message") or "")[:140] for j in jobs if j["status"] == "failed"],
            "readyz": service.ready_seen, "answers": service.answers, "seconds": round(seconds, 1), "note": note}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path)
    parser.add_argument("--only", default=SCENARIOS)
    parser.add_argument("--idle", type=float, default=30.0)
    parser.add_argument("--loop", type=float, default=30.0)
    parser.add_argument("--die-after", type=float, default=3.0)
    args = parser.parse_args()
    for name in args.only.split(","):
        for tree in ([args.before] if args.before else []) + [HERE]:
            row = scenario(name, tree, args.idle, args.loop, args.die_after)
            print(json.dumps({"tree": str(tree), **row}), flush=True)


if __name__ == "__main__":
    main()
