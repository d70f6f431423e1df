"""Killed and stopped processes that ``bench/kill_scenarios.py`` and ``bench/kill58.py`` leave out, on a real
``plantsolve serve`` (embedded default, SQLite, a private data dir; their ``Service``: LEASE_SECONDS 8, sweep 1 s,
two job processes; jobs of the test kind ``test-compute``, whose marker files count the solves):

- ``api-stop``: SIGSTOP of the API process for 12 s (longer than a lease) with two jobs running and two queued, then
  SIGCONT: every job solved once, and what ``/readyz`` and HTTP say after;
- ``warm-stop-busy``: SIGSTOP of the warm parent while two jobs run (its children) and two wait;
- ``two-apis-first``: a second ``serve`` on the same data dir, jobs submitted to the first, the first killed with -9
  while its jobs run: the second must take them over (their processes are gone) and run each once;
- ``api-kill-twice``: kill -9 of the API while jobs run, ``serve`` again, and kill -9 again as soon as it is ready,
  then ``serve`` a third time;
- ``api-term``: SIGTERM of the API (``docker stop``) with two jobs running and two queued, then ``serve`` again;
- ``warm-uploads``: uploads (which are read in processes forked from the warm parent) sent one after another while
  the warm parent is killed again and again: each must be answered 202 or 503, never a 500, and each 202 run once;
- ``sqlite-deleted``: the SQLite file (and its WAL and shared-memory files) deleted under two running jobs: what
  HTTP and ``/readyz`` answer (a 500 is a fault; a 503 naming ``database`` the honest answer), and whether the
  service leaves an empty database file behind.

Each row as ``bench/kill_scenarios.py``'s. ``--before DIR`` runs the same on another checkout first.

    python bench/kill59.py [--before /tmp/base] [--only api-stop,...]
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from kill_scenarios import HERE, JOB_SECONDS, Service, _forkservers, _stray, _what

SCENARIOS = "api-stop,warm-stop-busy,two-apis-first,api-kill-twice,api-term,warm-uploads,sqlite-deleted"


def _kill_api(service: Service) -> None:
    service.process.kill()
    service.process.wait()
    until = time.monotonic() + 10
    while _stray(service.data) and time.monotonic() < until:
        time.sleep(0.1)
    for pid in _stray(service.data):
        os.kill(pid, signal.SIGKILL)


def scenario(name: str, tree: Path) -> dict:
    data = Path(tempfile.mkdtemp(prefix=f"kill59-{name}-"))
    markers = data / "markers"
    service = Service(tree, data)
    note, jobs, seconds, ids = "", [], float("nan"), []
    try:
        service.start()
        if name == "api-stop":
            ids = service.submit(4, markers)
            service.wait_claimed(ids, 2)
            time.sleep(0.5)
            service.process.send_signal(signal.SIGSTOP)
            time.sleep(12)
            service.process.send_signal(signal.SIGCONT)
            service.probe_for(3, ids[0])
        elif name == "warm-stop-busy":
            ids = service.submit(4, markers)
            service.wait_claimed(ids, 2)
            time.sleep(0.3)
            os.kill(_forkservers(service.process.pid)[0], signal.SIGSTOP)
            service.probe_for(4, ids[0])
        elif name == "two-apis-first":
            other = Service(tree, data)
            other.start()
            ids = service.submit(4, markers)
            service.wait_claimed(ids, 2)
            time.sleep(0.5)
            service.process.kill()  # not _kill_api: the survivor's processes name the same data dir
            service.process.wait()
            service.process = other.process  # the survivor answers from here on
            service.client = other.client
            other.probe_for(3, ids[0])
            service.answers, service.ready_seen = other.answers, service.ready_seen + other.ready_seen
            service.extra += other.extra
        elif name == "api-kill-twice":
            ids = service.submit(4, markers)
            service.wait_claimed(ids, 2)
            time.sleep(0.5)
            _kill_api(service)
            service.start()
            _kill_api(service)
            service.start()
        elif name == "api-term":
            ids = service.submit(4, markers)
            service.wait_claimed(ids, 2)
            time.sleep(0.5)
            began = time.monotonic()
            service.process.send_signal(signal.SIGTERM)
            service.process.wait(60)
            ended = time.monotonic()
            left = {pid: _what(pid) for pid in _stray(data)}
            while _stray(data) and time.monotonic() - ended < 10:
                time.sleep(0.1)
            note = (f"SIGTERM: exited {service.process.returncode} after {ended - began:.1f} s; left then: "
                    f"{sorted(left.values())}, gone {time.monotonic() - ended:.1f} s later")
            service.start()
        elif name == "warm-uploads":
            kills, until, n = 0, time.monotonic() + 15, 0
            while time.monotonic() < until:
                if n % 3 == 0:
                    for pid in _forkservers(service.process.pid):
                        os.kill(pid, signal.SIGKILL)
                        kills += 1
                body = f"{n + 0.5}\n{n + 1.5}\n".encode()
                try:
                    response = service.client.post("/v1/test-compute/jobs", files={"file": ("v.txt", body)})
                    key = f"POST upload {response.status_code}"
                    if response.status_code == 202:
                        service.extra.append(response.json()["id"])
                    elif response.status_code >= 500 and response.status_code != 503:
                        key += f" {response.text[:120]}"
                except Exception as error:  # noqa: BLE001 - tallied
                    key = f"POST upload {type(error).__name__}"
                service.answers[key] = service.answers.get(key, 0) + 1
                n += 1
                time.sleep(0.1)
            note = f"{kills} kills of the warm parent over {n} uploads"
        elif name == "sqlite-deleted":
            ids = service.submit(2, markers)
            service.wait_claimed(ids, 2)
            for suffix in ("", "-wal", "-shm"):
                (data / f"plantsolve.db{suffix}").unlink(missing_ok=True)
            service.probe_for(6, ids[0])
            time.sleep(JOB_SECONDS)
            note = f"after 6 s: db file {'re-created' if (data / 'plantsolve.db').exists() else 'absent'}"
            try:
                jobs = service.jobs(ids)
            except Exception as error:  # noqa: BLE001 - the bench reports what happened
                note += f"; job views: {type(error).__name__}"
        else:
            raise ValueError(name)
        if name != "sqlite-deleted":
            ids = ids + service.extra
            jobs, seconds = service.wait_finished(ids, 120)
            service.wait_ready(30)
            service.ready()
    finally:
        service.stop()
    n = len(ids) - len(service.extra) if name != "sqlite-deleted" else len(ids)
    accepted = jobs[n:]
    jobs = jobs[:n]
    solves = [len(list((markers / str(i)).glob("*"))) if (markers / str(i)).exists() else 0 for i in range(n)]
    statuses = [j.get("status", j.get("title", "?")) for j in jobs]
    once = bool(jobs) and all((s == "succeeded" and k == 1) or (s in ("failed", "cancelled") and k <= 1)
                              for s, k in zip(statuses, solves))
    return {"scenario": name, "statuses": statuses, "solves": solves, "attempts": [j.get("attempt") for j in jobs],
            "outcomes": [[a["outcome"] for a in j.get("attempts") or []] for j in jobs],
            "exactly_once": once, "readyz": service.ready_seen, "seconds": round(seconds, 1), "note": note,
            "answers": service.answers,
            "accepted_meanwhile": f"{sum(j.get('status') == 'succeeded' for j in accepted)} of {len(accepted)} succeeded"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path)
    parser.add_argument("--only", default=SCENARIOS)
    args = parser.parse_args()
    for tree in ([args.before] if args.before else []) + [HERE]:
        for name in args.only.split(","):
            print(json.dumps({"tree": str(tree), **scenario(name, tree)}), flush=True)


if __name__ == "__main__":
    main()
