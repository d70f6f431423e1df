"""Every kind end to end through the command line: ``plantsolve solve`` on the shipped examples, as a user runs it,
this checkout beside another (``--before``, default: the ``main`` branch) in the same run.

For each kind and example file, a fresh ``plantsolve solve KIND FILE -o result.json --artifacts DIR`` process per
checkout: the CPU seconds (user + system) of the whole process tree (the command, its upload reader's forkserver
and the readers: this script is their subreaper, so processes orphaned at the command's exit are waited for and
counted), the command's peak resident memory, the wall time, and the sizes of what it wrote. The floor in the same
run: ``plantsolve solve --help`` and ``python -c pass``. Then the API process's start-up (``plantsolve serve``
until ``/healthz`` answers: its CPU seconds and resident memory then); the service's warm start (until ``/readyz``
says 200, then how soon a job submitted at once runs, and the memory of each of its processes while it does: RSS,
PSS and private, from ``smaps_rollup``); and with ``--importtime`` the libraries that ``solve --help`` spends its
imports on. Numbers are best of ``--repeat``, the two checkouts interleaved (CPU seconds
hold on a loaded machine; wall time does not).

    python bench/cli.py [--repeat N] [--kinds tube,perfmap] [--before main|DIR|''] [--no-bytecode-side] [--no-api]
                        [--no-serve] [--importtime]
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request
from collections import defaultdict
from pathlib import Path

from hostile import descendants  # this folder is on the path of a script run from it

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
PR_SET_CHILD_SUBREAPER = 36
# how long a service may take to answer ready, and its first job to start
START_SECONDS = 300.0

# (kind, example file, options JSON or None): each kind's shipped inputs, JSON and the files other tools write
CASES = [
    ("alignment", "alignment/ladder.json", None),
    ("alignment", "alignment/ladder.pcf", None),
    ("tube", "tube/scan_request.json", None),
    ("tube", "tube/scan.xyz", None),
    ("tube", "tube/scan.ply", None),
    ("perfmap", "perfmap/n3_fan_map.json", None),
    ("perfmap", "perfmap/n3_fan_map.csv", None),
    ("dedup", "dedup/tunnel_3rings.ifc", None),
    ("dedup", "dedup/zoo_ifc2x3.ifc", None),
    ("rigidity", "rigidity/four_bar_and_door.json", None),
    ("rigidity", "rigidity/hinged_wall.ldr", None),
    ("flowmeter", "flowmeter/meter.json", None),
    ("flowmeter", "flowmeter/button.json", None),
    ("polyhedra", "polyhedra/gable_house.json", None),
    ("polyhedra", "polyhedra/two_offices.idf", None),
]


class Checkout:
    """A source tree whose ``plantsolve`` runs with this interpreter (its directory first on PYTHONPATH). With
    ``no_bytecode`` (a folder) its processes find no compiled module and write none (PYTHONPYCACHEPREFIX names that
    empty folder, PYTHONDONTWRITEBYTECODE is set): every module is compiled from source as it is imported, as in an
    install that was not compiled to bytecode where no process may write ``__pycache__`` (the image's)."""

    def __init__(self, name: str, root: Path, no_bytecode: Path | None = None) -> None:
        self.name, self.root = name, root
        self.env = {**os.environ, "PYTHONPATH": str(root)}
        if no_bytecode is not None:
            no_bytecode.mkdir(parents=True, exist_ok=True)
            self.env.update(PYTHONPYCACHEPREFIX=str(no_bytecode), PYTHONDONTWRITEBYTECODE="1")

    def command(self, *args: str) -> list[str]:
        return [sys.executable, "-m", "plantsolve.cli", *args]


def become_subreaper() -> None:
    """Orphans of the measured commands (a forkserver outliving its parent by a moment) become this process's
    children, so their CPU time is waited for and counted."""
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_CHILD_SUBREAPER)")


def reap_orphans(deadline_seconds: float = 60.0) -> float:
    """Wait for every remaining child (orphaned descendants); their CPU seconds."""
    cpu, deadline = 0.0, time.monotonic() + deadline_seconds
    while time.monotonic() < deadline:
        try:
            pid, _, usage = os.wait4(-1, os.WNOHANG)
        except ChildProcessError:
            return cpu
        if pid == 0:
            time.sleep(0.02)
            continue
        cpu += usage.ru_utime + usage.ru_stime
    raise SystemExit("orphaned processes of a measured command did not end within a minute")


def run_measured(command: list[str], cwd: Path, env: dict) -> tuple[float, float, float]:
    """Run ``command``; (CPU seconds of its process tree, its peak RSS in MiB, wall seconds)."""
    started = time.perf_counter()
    process = subprocess.Popen(command, cwd=cwd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    stderr = process.stderr.read().decode(errors="replace")
    _, status, usage = os.wait4(process.pid, 0)
    process.returncode = os.waitstatus_to_exitcode(status)
    process.stderr.close()
    orphans = reap_orphans()
    wall = time.perf_counter() - started
    if process.returncode not in (0, 3):  # 3: the job ran and its result carries a verdict against it
        raise SystemExit(f"{' '.join(command)} exited {process.returncode}:\n{stderr[-2000:]}")
    return usage.ru_utime + usage.ru_stime + orphans, usage.ru_maxrss / 1024, wall


def size_of(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) if path.exists() else 0


def best(measures: list[tuple[float, float, float]]) -> tuple[float, float, float]:
    return tuple(min(m[i] for m in measures) for i in range(3))


def stop(process: subprocess.Popen) -> None:
    """The service stopped as an operator stops it (SIGTERM, then SIGKILL after 30 s), its orphans reaped."""
    process.send_signal(signal.SIGTERM)
    try:
        process.wait(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
    reap_orphans()


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def proc_status(pid: int) -> dict[str, int]:
    """VmRSS and VmHWM in kB, and the CPU seconds so far, of a live process."""
    fields = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        name, _, value = line.partition(":")
        if name in ("VmRSS", "VmHWM"):
            fields[name] = int(value.split()[0])
    stat = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    fields["cpu"] = (int(stat[11]) + int(stat[12])) / os.sysconf("SC_CLK_TCK")
    return fields


def api_start(checkout: Checkout, scratch: Path) -> tuple[float, float, float, float]:
    """``plantsolve serve`` until /healthz answers: (its CPU seconds, RSS MiB and peak RSS MiB then, wall seconds)."""
    port, data = free_port(), Path(tempfile.mkdtemp(prefix="api-", dir=scratch))
    env = {**checkout.env, "DATA_DIR": str(data)}
    for name in ("DATABASE_URL", "BROKER_URL", "ARTIFACT_DIR", "BLOB_STORE"):
        env.pop(name, None)
    started = time.perf_counter()
    process = subprocess.Popen(checkout.command("serve", "--port", str(port), "--log-level", "warning"), cwd=data,
                               env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        while True:
            if process.poll() is not None:
                raise SystemExit(f"plantsolve serve ({checkout.name}) exited {process.returncode}")
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=2) as answer:
                    if answer.status == 200:
                        break
            except OSError:
                time.sleep(0.05)
        wall = time.perf_counter() - started
        status = proc_status(process.pid)
    finally:
        stop(process)
    return status["cpu"], status["VmRSS"] / 1024, status["VmHWM"] / 1024, wall


def memory(pid: int) -> tuple[float, float, float]:
    """(RSS, PSS, private) MiB of a live process (smaps_rollup): private is what it holds alone, PSS its fair share of
    what it shares (a fork's inherited pages count once across the family)."""
    fields = {}
    for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines()[1:]:
        name, _, value = line.partition(":")
        fields[name] = int(value.split()[0])
    private = fields.get("Private_Clean", 0) + fields.get("Private_Dirty", 0)
    return fields.get("Rss", 0) / 1024, fields.get("Pss", 0) / 1024, private / 1024


def role(pid: int) -> str:
    try:
        line = Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return "gone"
    for word, name in (("forkserver", "warm parent / forkserver"), ("resource_tracker", "resource tracker"),
                       ("spawn_main", "pool worker (spawned)")):
        if word in line:
            return name
    return "process"


def warm_start(checkout: Checkout, scratch: Path) -> dict:
    """``plantsolve serve`` (embedded default, 2 job processes) from its start: wall seconds until /readyz answers 200,
    then one job submitted at once (a 3 s test job): seconds from its submission until it runs; meanwhile the private
    memory and PSS of the API process, of the process running the job and of every other process of the service."""
    port, data = free_port(), Path(tempfile.mkdtemp(prefix="warm-", dir=scratch))
    env = {**checkout.env, "DATA_DIR": str(data), "PLUGINS": "tests.support.kinds", "EMBEDDED_WORKERS": "2",
           "PYTHONPATH": f"{checkout.env['PYTHONPATH']}:{REPO}"}
    for name in ("DATABASE_URL", "BROKER_URL", "ARTIFACT_DIR", "BLOB_STORE"):
        env.pop(name, None)
    base = f"http://127.0.0.1:{port}"
    started = time.perf_counter()
    process = subprocess.Popen(checkout.command("serve", "--port", str(port), "--log-level", "warning"), cwd=data,
                               env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def call(method: str, path: str, body: bytes | None = None) -> tuple[int, dict]:
        request = urllib.request.Request(base + path, data=body, method=method,
                                         headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=5) as answer:
                return answer.status, json.loads(answer.read() or b"{}")
        except urllib.error.HTTPError as error:
            return error.code, {}

    try:
        deadline = started + START_SECONDS
        while True:
            if process.poll() is not None or time.perf_counter() > deadline:
                raise SystemExit(f"plantsolve serve ({checkout.name}) did not get ready")
            try:
                if call("GET", "/readyz")[0] == 200:
                    break
            except OSError:
                pass
            time.sleep(0.05)
        ready = time.perf_counter() - started
        submitted = time.perf_counter()
        job_id = call("POST", "/v1/test-compute/jobs", b'{"values": [3, 4], "seconds": 3}')[1]["id"]
        while call("GET", f"/v1/jobs/{job_id}")[1]["status"] == "queued":
            if time.perf_counter() - submitted > START_SECONDS:
                raise SystemExit(f"({checkout.name}) the first job did not start")
            time.sleep(0.01)
        first_job = time.perf_counter() - submitted
        time.sleep(0.5)  # the job runs: its process holds what a job costs
        sampled = {}
        for pid in [process.pid, *descendants(process.pid)]:
            try:
                sampled[pid] = (role(pid), *memory(pid))
            except OSError:
                continue
        while call("GET", f"/v1/jobs/{job_id}")[1]["status"] not in ("succeeded", "failed"):
            time.sleep(0.1)
        worker = int(call("GET", f"/v1/jobs/{job_id}")[1]["attempts"][-1]["worker"].rsplit(":", 1)[1])
    finally:
        stop(process)
    rows = {"API process": sampled.pop(process.pid)[1:]}
    if worker in sampled:
        rows["the job's process"] = sampled.pop(worker)[1:]
    for pid, (name, *numbers) in sorted(sampled.items()):
        rows[f"{name} {pid}" if name.startswith("process") else name + ("" if name not in rows else f" {pid}")] = numbers
    return {"ready": ready, "first_job": first_job, "memory": rows,
            "pss": sum(numbers[1] for numbers in rows.values())}


# the small job whose imports --importtime lists (with `solve --help`'s)
IMPORTTIME_CASE = ("rigidity", "rigidity/four_bar_and_door.json")


def import_offenders(checkout: Checkout, scratch: Path, top: int, *args: str) -> list[tuple[str, float]]:
    """The top-level packages ``plantsolve ARGS`` spends its import time on (own time of their modules, ms)."""
    result = subprocess.run([sys.executable, "-X", "importtime", "-m", "plantsolve.cli", *args],
                            cwd=scratch, env=checkout.env, capture_output=True, text=True, check=True)
    own: dict[str, float] = defaultdict(float)
    for line in result.stderr.splitlines():
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        self_us, _, name = line.removeprefix("import time:").split("|")
        name = name.strip()
        package = ".".join(name.split(".")[:3]) if name.startswith("plantsolve.") else name.split(".")[0]
        own[package] += int(self_us) / 1000
    return sorted(own.items(), key=lambda item: -item[1])[:top]


def before_checkout(spec: str, scratch: Path) -> tuple[Checkout | None, Path | None]:
    """``--before``: a directory as it is, a git revision checked out into a temporary worktree (and compiled), ''
    for none."""
    if not spec:
        return None, None
    if Path(spec).is_dir():
        return Checkout(Path(spec).name, Path(spec).resolve()), None
    folder = scratch / "before"
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(folder), spec], check=True,
                   capture_output=True)
    # compiled as `make install` compiles this checkout: both sides start from bytecode
    subprocess.run([sys.executable, "-m", "compileall", "-q", str(folder / "plantsolve")], check=True)
    return Checkout(spec, folder), folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--kinds", default="", help="comma-separated kinds (default: all)")
    parser.add_argument("--before", default="main",
                        help="the checkout to compare with: a directory, or a git revision (checked out for the run); "
                        "'' for this checkout alone")
    parser.add_argument("--no-api", action="store_true", help="leave out the API start-up")
    parser.add_argument("--no-serve", action="store_true", help="leave out the warm start of the service")
    parser.add_argument("--importtime", action="store_true",
                        help="the libraries `solve --help` and a small job import, by time")
    parser.add_argument("--no-bytecode-side", action="store_true",
                        help="also the --before checkout with no compiled module (as an install that was not compiled "
                        "to bytecode runs where no process writes __pycache__)")
    args = parser.parse_args()
    kinds = {k for k in args.kinds.split(",") if k}
    become_subreaper()
    scratch = Path(tempfile.mkdtemp(prefix="bench-cli-"))
    before, worktree = before_checkout(args.before, scratch)
    cold = None
    if before is not None and args.no_bytecode_side:
        cold = Checkout(f"{before.name}-no-pyc", before.root, no_bytecode=scratch / "no-bytecode")
    sides = [side for side in (cold, before, Checkout("this", REPO)) if side is not None]
    try:
        run(args, kinds, sides, scratch)
    finally:
        if worktree is not None:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(worktree)], check=False)
        shutil.rmtree(scratch, ignore_errors=True)


def run(args: argparse.Namespace, kinds: set[str], sides: list[Checkout], scratch: Path) -> None:
    def measured(command_of, env_of=lambda side: side.env) -> list[tuple[float, float, float]]:
        runs: dict[str, list] = {side.name: [] for side in sides}
        for _ in range(args.repeat):  # interleaved: a change of the machine's load hits both sides alike
            for side in sides:
                runs[side.name].append(run_measured(command_of(side), scratch, env_of(side)))
        return [best(runs[side.name]) for side in sides]

    python = measured(lambda side: [sys.executable, "-c", "pass"])
    helps = measured(lambda side: side.command("solve", "--help"))
    rows = []
    for kind, example, options in CASES:
        if kinds and kind not in kinds:
            continue
        sizes: dict[str, tuple[Path, Path]] = {}

        def command(side: Checkout) -> list[str]:
            out = scratch / f"{side.name}-{kind}.json"
            artifacts = scratch / f"{side.name}-{kind}-artifacts"
            shutil.rmtree(artifacts, ignore_errors=True)
            sizes[side.name] = (out, artifacts)
            extra = ["--options", options] if options else []
            return side.command("solve", kind, str(EXAMPLES / example), "-o", str(out), "--artifacts", str(artifacts),
                                "--no-progress", *extra)

        results = measured(command)
        written = [(size_of(sizes[side.name][0]), size_of(sizes[side.name][1])) for side in sides]
        rows.append((kind, example.split("/", 1)[1], size_of(EXAMPLES / example), results, written))

    names = " → ".join(side.name for side in sides)
    print(f"\n`plantsolve solve` per kind on the shipped examples, {names}, best of {args.repeat}, {os.cpu_count()} "
          f"cores (CPU s of the process tree, peak RSS of the command)")
    header = (f"{'kind':<10} {'input':<22} {'input kB':>8}  {'CPU s':>13}  {'over --help':>13}  {'peak MiB':>11}  "
              f"{'wall s':>11}  {'result kB':>15}  {'artifacts kB':>15}")
    print(header)
    print("-" * len(header))

    def pair(values, fmt: str) -> str:
        return " → ".join(format(v, fmt) for v in values)

    for name, results in (("python -c pass", python), ("solve --help", helps)):
        print(f"{'(floor)':<10} {name:<22} {'':>8}  {pair([r[0] for r in results], '.2f'):>13}  {'':>13}  "
              f"{pair([r[1] for r in results], '.0f'):>11}  {pair([r[2] for r in results], '.2f'):>11}")
    totals = [0.0] * len(sides)
    for kind, name, input_size, results, written in rows:
        for i, r in enumerate(results):
            totals[i] += r[0]
        over = [r[0] - h[0] for r, h in zip(results, helps)]
        print(f"{kind:<10} {name:<22} {input_size / 1024:>8.1f}  {pair([r[0] for r in results], '.2f'):>13}  "
              f"{pair(over, '.2f'):>13}  {pair([r[1] for r in results], '.0f'):>11}  "
              f"{pair([r[2] for r in results], '.2f'):>11}  {pair([w[0] / 1024 for w in written], '.1f'):>15}  "
              f"{pair([w[1] / 1024 for w in written], '.1f'):>15}")
    print(f"{'(all)':<10} {'CPU s of every case':<22} {'':>8}  {pair(totals, '.1f'):>13}")
    print("over --help: CPU s beyond `plantsolve solve --help` of the same checkout")

    if not args.no_api:
        starts: dict[str, list] = {side.name: [] for side in sides}
        for _ in range(args.repeat):
            for side in sides:
                starts[side.name].append(api_start(side, scratch))
        print(f"\nAPI process start-up (`plantsolve serve` until /healthz answers; the API process alone, not its job "
              f"processes or upload readers), best of {args.repeat}")
        print(f"{'checkout':<10} {'CPU s':>7} {'RSS MiB':>8} {'peak MiB':>9} {'wall s':>7}")
        for side in sides:
            cpu, rss, peak, wall = (min(s[i] for s in starts[side.name]) for i in range(4))
            print(f"{side.name:<10} {cpu:>7.2f} {rss:>8.0f} {peak:>9.0f} {wall:>7.2f}")

    if not args.no_serve:
        print("\nWarm start (`plantsolve serve`, embedded default, 2 job processes): until /readyz says 200, then one job "
              "submitted at once; memory while it runs (MiB: RSS / PSS / private)")
        for side in sides:
            found = warm_start(side, scratch)
            print(f"{side.name}: ready after {found['ready']:.1f} s; first job running {found['first_job']:.2f} s after its "
                  f"submission; PSS of every process {found['pss']:.0f} MiB")
            for name, (rss, pss, private) in found["memory"].items():
                print(f"    {name:<32} {rss:>6.0f} / {pss:>6.0f} / {private:>6.0f}")

    if args.importtime:
        kind, example = IMPORTTIME_CASE
        out = str(scratch / "importtime.json")
        for title, command in (("solve --help", ["solve", "--help"]),
                               (f"solve {kind} {example.split('/')[-1]}",
                                ["solve", kind, str(EXAMPLES / example), "-o", out, "--no-progress"])):
            print(f"\n`plantsolve {title}`: import time by top-level package (own time of its modules, ms; "
                  "-X importtime inflates it)")
            for side in sides:
                offenders = import_offenders(side, scratch, 12, *command)
                print(f"{side.name:<14} " + ", ".join(f"{name} {ms:.0f}" for name, ms in offenders))


if __name__ == "__main__":
    main()
