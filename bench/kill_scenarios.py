"""Killed processes on a real ``plantsolve serve`` (embedded default, SQLite, a private data dir): does every job end
solved exactly once or failed with a reason, and does ``/readyz`` tell the truth meanwhile?

Scenarios (each on a fresh service; jobs of the test kind ``test-compute``, which writes a marker file per finished
solve, so the markers count the solves):

- ``warm``: kill -9 of the idle warm parent; /readyz is polled until it is 200 again, then jobs are submitted;
- ``jobs``: kill -9 of every job process while two jobs run and two wait;
- ``stop``: SIGSTOP of one running job process (its lease lapses; the sweep takes the attempt back and kills it);
- ``api``: kill -9 of the API process with two jobs running and four queued, then ``serve`` again on the same data dir;
- ``warm-submit``: kill -9 of the idle warm parent and four jobs submitted at once, while it starts again (accepted
  jobs must run);
- ``warm-twice``: kill -9 of the idle warm parent, and of the new one as soon as it is there, then four jobs;
- ``warm-stop``: SIGSTOP of the idle warm parent, then four jobs (their start hangs until the watch kills it);
- ``jobs-twice``: kill -9 of both running job processes, then of the processes that run the same jobs again (two
  attempts lost per job, the third runs them);
- ``stop-kill``: SIGSTOP of one running job process, then kill -9 of the process that runs its job again;
- ``warm-fork``: kill -9 of the warm parent again and again while twelve short jobs start (kills that land mid-fork);
- ``store-kill``: kill -9 of each job process as soon as its solve is done and before its result's commit (jobs of
  ``bench/kill_kinds.py``'s ``test-slow-render``: the solve's marker names its process, whose artifacts then take 2 s
  to render): a job solved twice is a kill in that window that cost a second solve;
- ``cancel-kill``: two running jobs cancelled, one just after its process was killed, one just before;
- ``sqlite-lock``: another process holds the SQLite file's write lock (``BEGIN EXCLUSIVE``) for 8 s under two
  running jobs;
- ``two-apis``: a second ``serve`` on the same data dir, three jobs submitted to each, the second killed with -9;
- ``read-only``: the artifacts folder made read-only (a read-only bind mount: needs root) for 8 s under two running
  jobs;
- ``webhook-dead``: three jobs whose ``callback_url`` is a closed port;
- ``idempotency``: an ``Idempotency-Key`` reused with another body, another kind, an upload, and the same body.

Each row: the scenario, the jobs' final statuses, the solves and attempts per job, each job's attempt history
(outcomes), whether a failed job's report says
why, the /readyz answers seen (in order, repeats folded), what HTTP answered meanwhile (by route and status, where the
scenario probes), and the seconds until every job had ended. ``--before DIR``
runs the same on another checkout (its source, this checkout's .venv) first. LEASE_SECONDS is 8 and the sweep 1 s, so that a
stopped process is noticed in seconds.

    python bench/kill_scenarios.py [--before /tmp/base] [--only warm,jobs,stop,api,...]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx

HERE = Path(__file__).resolve().parent.parent
BIN = Path(sys.executable).parent
JOB_SECONDS = 3.0
START_SECONDS = 240  # the warm parent imports every kind: a minute and more on a machine shared with other work


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == pid and fields[0] not in ("Z", "X"):
                found.append(int(entry.name))
    return found


def _forkservers(api: int) -> list[int]:
    out = []
    for pid in _children(api):
        try:
            if b"multiprocessing.forkserver" in Path(f"/proc/{pid}/cmdline").read_bytes():
                out.append(pid)
        except OSError:
            pass
    return out


class Service:
    def __init__(self, tree: Path, data: Path):
        self.tree, self.data, self.port = tree, data, _free_port()
        self.env = {**os.environ, "PYTHONPATH": f"{tree}{os.pathsep}{HERE / 'bench'}",
                    "PLUGINS": "tests.support.kinds,kill_kinds", "DATA_DIR": str(data),
                    "LEASE_SECONDS": "8", "HEARTBEAT_SECONDS": "1", "SWEEP_SECONDS": "1", "EMBEDDED_WORKERS": "2",
                    "LOG_FORMAT": "text", "LOG_LEVEL": "warning",
                    # webhook-dead: signed callbacks to this host, retried quickly
                    "WEBHOOK_SECRETS": "whsec_QUJDREVGR0hJSktMTU5PUFFSU1RVVldYWVo=", "WEBHOOK_PRIVATE_TARGETS": "true",
                    "WEBHOOK_RETRY_SECONDS": "0.2"}
        self.process: subprocess.Popen | None = None
        self.client = httpx.Client(base_url=f"http://127.0.0.1:{self.port}", timeout=30)
        self.ready_seen: list[str] = []
        self.answers: dict[str, int] = {}
        self.extra: list[str] = []  # jobs accepted by the probes meanwhile (they must end too)

    def probe(self, job_id: str) -> None:
        """One round of what clients ask meanwhile (a job's view, the list, a JSON submission, an upload), tallied by
        route and status; a 5xx other than 503 is kept whole."""
        for method, path, extra in (("get", f"/v1/jobs/{job_id}", {}), ("get", "/v1/jobs", {}),
                                    ("post", "/v1/test-compute/jobs", {"json": {"values": [3.5]}}),
                                    ("post", "/v1/test-compute/jobs", {"files": {"file": ("v.txt", b"1.5\n2.5\n")}})):
            route = "GET /v1/jobs/{id}" if path.startswith("/v1/jobs/") else \
                f"{method.upper()} {path}{' upload' if 'files' in extra else ''}"
            try:
                response = getattr(self.client, method)(path, timeout=30, **extra)
                key = f"{route} {response.status_code}"
                if response.status_code == 202:
                    self.extra.append(response.json()["id"])
                elif response.status_code >= 500 and response.status_code != 503:
                    key += f" {response.text[:120]}"
            except httpx.HTTPError as error:
                key = f"{route} {type(error).__name__}"
            self.answers[key] = self.answers.get(key, 0) + 1

    def probe_for(self, seconds: float, job_id: str) -> None:
        until = time.monotonic() + seconds
        while time.monotonic() < until:
            self.ready()
            self.probe(job_id)
            time.sleep(0.3)

    def start(self) -> None:
        log = open(self.data / "serve.log", "ab")
        self.process = subprocess.Popen([str(BIN / "plantsolve"), "serve", "--port", str(self.port)], cwd=self.tree,
                                        env=self.env, stdout=log, stderr=subprocess.STDOUT)
        self.wait_ready(START_SECONDS)

    def ready(self) -> str:
        try:
            response = self.client.get("/readyz", timeout=10)
            said = "200" if response.status_code == 200 else \
                f"{response.status_code} {','.join(k for k, v in response.json()['checks'].items() if v != 'ok')}"
        except httpx.HTTPError:
            said = "no answer"
        if not self.ready_seen or self.ready_seen[-1] != said:
            self.ready_seen.append(said)
        return said

    def wait_ready(self, seconds: float) -> None:
        until = time.monotonic() + seconds
        while self.ready() != "200":
            if time.monotonic() > until:
                raise RuntimeError(f"not ready after {seconds} s: {self.ready_seen}")
            time.sleep(0.2)

    def submit(self, n: int, markers: Path) -> list[str]:
        ids = []
        for i in range(n):
            body = {"values": [float(i)], "seconds": JOB_SECONDS, "marker_dir": str(markers / str(i))}
            ids.append(self.client.post("/v1/test-compute/jobs", json=body).json()["id"])
        return ids

    def jobs(self, ids: list[str]) -> list[dict]:
        return [self.client.get(f"/v1/jobs/{i}").json() for i in ids]

    def job_processes(self) -> list[int]:
        return [pid for server in _forkservers(self.process.pid) for pid in _children(server)]

    def wait_claimed(self, ids: list[str], count: int, attempt: int = 1, seconds: float = 60) -> list[int]:
        """The job processes, once ``count`` of the jobs run their attempt ``attempt`` (claimed: a process killed
        before its claim loses no attempt, and the scenario would test nothing)."""
        until = time.monotonic() + seconds
        while time.monotonic() < until:
            running = [j for j in self.jobs(ids) if j["status"] == "running" and j["attempt"] == attempt]
            if len(running) >= count:
                return self.job_processes()
            self.ready()
            time.sleep(0.05)
        raise RuntimeError(f"{count} job(s) did not start attempt {attempt}")

    def wait_finished(self, ids: list[str], seconds: float) -> tuple[list[dict], float]:
        started = time.monotonic()
        while time.monotonic() - started < seconds:
            jobs = self.jobs(ids)
            if all(j["status"] in ("succeeded", "failed", "cancelled") for j in jobs):
                return jobs, time.monotonic() - started
            self.ready()
            time.sleep(0.3)
        return self.jobs(ids), float("nan")

    def stop(self) -> None:
        if self.process and self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(20)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        for pid in _stray(self.data):
            os.kill(pid, signal.SIGKILL)


def _stray(data: Path) -> list[int]:
    """Processes left of a killed service (none should be): their environment names its data dir."""
    out = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit() and int(entry.name) != os.getpid():
            try:
                if f"DATA_DIR={data}".encode() in (entry / "environ").read_bytes():
                    out.append(int(entry.name))
            except OSError:
                pass
    return out


def _what(pid: int) -> str:
    """A process's role, read from its command line: the warm parent (forkserver), a job process, or other."""
    try:
        argv = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return "gone"
    return "warm parent" if b"forkserver" in argv and b"main" in argv else \
        "job process" if b"multiprocessing" in argv or b"forkserver" in argv else argv.split(b"\0")[0].decode()[-40:]


def _new_warm_parent(service: Service, old: set[int], seconds: float = 60) -> int:
    until = time.monotonic() + seconds
    while time.monotonic() < until:
        new = [pid for pid in _forkservers(service.process.pid) if pid not in old]
        if new:
            return new[0]
        service.ready()
        time.sleep(0.02)
    raise RuntimeError("no new warm parent")


def scenario(name: str, tree: Path) -> dict:
    data = Path(tempfile.mkdtemp(prefix=f"kill-{name}-"))
    markers = data / "markers"
    service = Service(tree, data)
    note = ""
    try:
        service.start()
        if name == "warm":
            servers = _forkservers(service.process.pid)
            os.kill(servers[0], signal.SIGKILL)
            until = time.monotonic() + 60
            service.ready()
            while service.ready() != "200" and time.monotonic() < until:
                time.sleep(0.1)
            ids = service.submit(4, markers)
        elif name == "jobs":
            ids = service.submit(4, markers)
            pids = service.wait_claimed(ids, 2)
            time.sleep(0.5)
            for pid in pids:
                os.kill(pid, signal.SIGKILL)
        elif name == "stop":
            ids = service.submit(2, markers)
            pids = service.wait_claimed(ids, 2)
            time.sleep(0.5)
            os.kill(pids[0], signal.SIGSTOP)
            stopped = pids[0]
        elif name == "api":
            ids = service.submit(6, markers)
            service.wait_claimed(ids, 2)
            time.sleep(1.0)
            service.process.kill()
            service.process.wait()
            killed = time.monotonic()
            lingered: dict[int, str] = {}
            while (left := _stray(data)) and time.monotonic() - killed < 10:
                lingered.update({pid: _what(pid) for pid in left if pid not in lingered})
                time.sleep(0.1)
            note = (f"after the kill {len(lingered)} process(es) lingered ({', '.join(sorted(set(lingered.values())))})"
                    f" for {time.monotonic() - killed:.1f} s" if lingered else "no process outlived the kill")
            for pid in left:
                os.kill(pid, signal.SIGKILL)
            service.start()
        elif name == "warm-submit":
            os.kill(_forkservers(service.process.pid)[0], signal.SIGKILL)
            ids = service.submit(4, markers)
        elif name == "warm-twice":
            first = _forkservers(service.process.pid)[0]
            os.kill(first, signal.SIGKILL)
            os.kill(_new_warm_parent(service, {first}), signal.SIGKILL)
            ids = service.submit(4, markers)
        elif name == "warm-stop":
            os.kill(_forkservers(service.process.pid)[0], signal.SIGSTOP)
            time.sleep(0.5)
            note = f"/readyz 0.5 s after the stop: {service.ready()}"
            ids = service.submit(4, markers)
        elif name == "jobs-twice":
            ids = service.submit(2, markers)
            for attempt in (1, 2):
                pids = service.wait_claimed(ids, 2, attempt)
                time.sleep(0.5)
                for pid in pids:
                    os.kill(pid, signal.SIGKILL)
        elif name == "stop-kill":
            ids = service.submit(1, markers)
            (pid,) = service.wait_claimed(ids, 1)
            time.sleep(0.5)
            os.kill(pid, signal.SIGSTOP)
            stopped = pid
            service.wait_claimed(ids, 1, 2)
            time.sleep(0.5)
            for other in service.job_processes():
                if other != pid:
                    os.kill(other, signal.SIGKILL)
        elif name == "warm-fork":
            ids = []
            for i in range(12):
                body = {"values": [i + 0.5], "seconds": 0.2, "marker_dir": str(markers / str(i))}
                ids.append(service.client.post("/v1/test-compute/jobs", json=body).json()["id"])
            kills, until = 0, time.monotonic() + 20
            while time.monotonic() < until and not all(
                    j["status"] in ("succeeded", "failed") for j in service.jobs(ids)):
                for pid in _forkservers(service.process.pid):
                    time.sleep(random.uniform(0, 0.05))
                    try:
                        os.kill(pid, signal.SIGKILL)
                        kills += 1
                    except ProcessLookupError:
                        pass
                service.ready()
                time.sleep(random.uniform(0.05, 0.5))
            note = f"{kills} kills of the warm parent"
        elif name == "store-kill":
            ids = [service.client.post("/v1/test-slow-render/jobs", json={
                "values": [i + 0.5], "seconds": 1.0, "render_seconds": 2.0, "marker_dir": str(markers / str(i))}
            ).json()["id"] for i in range(4)]
            due: dict[int, tuple[float, int]] = {}  # job -> (when its solving process dies, its pid)
            killed: set[int] = set()
            until = time.monotonic() + 60
            while len(killed) < len(ids) and time.monotonic() < until:
                for i in set(range(len(ids))) - set(due):
                    done = list((markers / str(i)).glob("done-*")) if (markers / str(i)).exists() else []
                    if done:  # solved; it renders for 2 s before it stores anything: it dies at a moment of those
                        due[i] = (time.monotonic() + random.uniform(0.05, 1.5), int(done[0].name.split("-")[1]))
                for i, (when, pid) in due.items():
                    if i not in killed and time.monotonic() >= when:
                        try:
                            os.kill(pid, signal.SIGKILL)
                        except ProcessLookupError:
                            pass
                        killed.add(i)
                time.sleep(0.01)
            note = f"{len(killed)} job processes killed between their solve and their result's commit"
        elif name == "cancel-kill":
            ids = service.submit(2, markers)
            pids = service.wait_claimed(ids, 2)
            time.sleep(0.3)
            os.kill(pids[0], signal.SIGKILL)
            said = [service.client.post(f"/v1/jobs/{ids[0]}/cancel").status_code]
            said.append(service.client.post(f"/v1/jobs/{ids[1]}/cancel").status_code)
            os.kill(pids[1], signal.SIGKILL)
            time.sleep(2)
            note = f"cancel answered {said}; job processes left: {len(service.job_processes())}"
        elif name == "sqlite-lock":
            ids = service.submit(2, markers)
            service.wait_claimed(ids, 2)
            holder = sqlite3.connect(data / "plantsolve.db", timeout=5, isolation_level=None)
            holder.execute("BEGIN EXCLUSIVE")
            try:
                service.probe_for(8, ids[0])
            finally:
                holder.execute("ROLLBACK")
                holder.close()
        elif name == "two-apis":
            other = Service(tree, data)
            other.start()
            ids = service.submit(3, markers)
            for i in range(3, 6):
                body = {"values": [i + 0.5], "seconds": JOB_SECONDS, "marker_dir": str(markers / str(i))}
                ids.append(other.client.post("/v1/test-compute/jobs", json=body).json()["id"])
            service.wait_claimed(ids, 2)
            time.sleep(0.5)
            other.process.kill()
            other.process.wait()
            service.probe_for(3, ids[0])
            note = f"/readyz of the killed one before its kill: {other.ready_seen}"
        elif name == "read-only":
            ids = service.submit(2, markers)
            service.wait_claimed(ids, 2)
            folder = data / "artifacts"
            subprocess.run(["mount", "--bind", str(folder), str(folder)], check=True)
            try:
                subprocess.run(["mount", "-o", "remount,ro,bind", str(folder)], check=True)
                service.probe_for(8, ids[0])
                note = f"while read-only: {[j['status'] for j in service.jobs(ids)]}"
            finally:
                subprocess.run(["umount", str(folder)], check=True)
        elif name == "webhook-dead":
            dead = _free_port()
            ids = []
            for i in range(3):
                body = {"values": [i + 0.5], "seconds": 0.5, "marker_dir": str(markers / str(i))}
                ids.append(service.client.post(f"/v1/test-compute/jobs?callback_url=http://127.0.0.1:{dead}/hook",
                                               json=body).json()["id"])
            service.wait_finished(ids, 60)
            time.sleep(3)
            started = time.monotonic()
            service.ready()
            note = (f"callbacks {sorted({(j.get('callback') or {}).get('state') for j in service.jobs(ids)})}, "
                    f"/readyz then {time.monotonic() - started:.2f} s")
        elif name == "idempotency":
            def post(kind: str, key: str, **extra) -> str:
                return str(service.client.post(f"/v1/{kind}/jobs", headers={"Idempotency-Key": key}, **extra).status_code)
            body = {"values": [1.5], "seconds": 0.2, "marker_dir": str(markers / "0")}
            first = service.client.post("/v1/test-compute/jobs", headers={"Idempotency-Key": "k"}, json=body)
            ids = [first.json()["id"]]
            note = (f"first {first.status_code}; other body {post('test-compute', 'k', json={'values': [2.5]})}, "
                    f"other kind {post('test-crash', 'k', json={'message': 'x'})}, "
                    f"upload {post('test-compute', 'k', files={'file': ('v.txt', b'1.5')})}, "
                    f"same body {post('test-compute', 'k', json=body)}")
        else:
            raise ValueError(name)
        ids = ids + service.extra
        jobs, seconds = service.wait_finished(ids, 120)
        if name in ("stop", "stop-kill"):
            alive = Path(f"/proc/{stopped}").exists() and \
                Path(f"/proc/{stopped}/stat").read_text().rsplit(")", 1)[1].split()[0] not in ("Z", "X")
            note = "stopped process " + ("still alive" if alive else "killed")
        service.wait_ready(30)
        service.ready()
    finally:
        service.stop()
    accepted = jobs[len(ids) - len(service.extra):]  # the probes' jobs: they must end, solved (no markers)
    ids, jobs = ids[:len(ids) - len(service.extra)], jobs[:len(ids) - len(service.extra)]
    solves = [len(list((markers / str(i)).glob("*"))) if (markers / str(i)).exists() else 0 for i in range(len(ids))]
    statuses = [j["status"] for j in jobs]
    reasons = [bool((j.get("report") or {}).get("message")) for j in jobs if j["status"] == "failed"]
    once = all((s == "succeeded" and n == 1) or (s in ("failed", "cancelled") and n <= 1) for s, n in zip(statuses, solves))
    if name == "warm-stop":
        for pid in _stray(data):  # the stopped warm parent, if the service left it
            os.kill(pid, signal.SIGKILL)
    return {"scenario": name, "statuses": statuses, "solves": solves, "attempts": [j["attempt"] for j in jobs],
            "outcomes": [[a["outcome"] for a in j.get("attempts") or []] for j in jobs],
            "failed_say_why": all(reasons),
            "exactly_once": once, "readyz": service.ready_seen, "seconds": round(seconds, 1), "note": note,
            "answers": service.answers,
            "accepted_meanwhile": f"{sum(j['status'] == 'succeeded' for j in accepted)} of {len(accepted)} succeeded"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path)
    parser.add_argument("--only", default="warm,jobs,stop,api,warm-submit,warm-twice,warm-stop,jobs-twice,stop-kill,"
                        "warm-fork,store-kill,cancel-kill,sqlite-lock,two-apis,read-only,webhook-dead,idempotency")
    args = parser.parse_args()
    for tree in ([args.before] if args.before else []) + [HERE]:
        for name in args.only.split(","):
            row = scenario(name, tree)
            print(json.dumps({"tree": str(tree), **row}), flush=True)


if __name__ == "__main__":
    main()
