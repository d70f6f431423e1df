"""Every kind end to end through the command line: ``plantsolve solve`` on the shipped examples, as a user runs it,
this checkout beside another (``--before``, default: the ``main`` branch) in the same run.

For each kind and example file, a fresh ``plantsolve solve KIND FILE -o result.json --artifacts DIR`` process per
checkout: the CPU seconds (user + system) of the whole process tree (the command, its upload reader's forkserver
and the readers: this script is their subreaper, so processes orphaned at the command's exit are waited for and
counted), the command's peak resident memory, the wall time, and the sizes of what it wrote. The floor in the same
run: ``plantsolve solve --help`` and ``python -c pass``. Then the API process's start-up (``plantsolve serve``
until ``/healthz`` answers: its CPU seconds and resident memory then), and with ``--importtime`` the libraries that
``solve --help`` spends its imports on. Numbers are best of ``--repeat``, the two checkouts interleaved (CPU seconds
hold on a loaded machine; wall time does not).

    python bench/cli.py [--repeat N] [--kinds tube,perfmap] [--before main|DIR|''] [--importtime]
"""

from __future__ import annotations

import argparse
import ctypes
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
PR_SET_CHILD_SUBREAPER = 36

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
    """A source tree whose ``plantsolve`` runs with this interpreter (its directory first on PYTHONPATH)."""

    def __init__(self, name: str, root: Path) -> None:
        self.name, self.root = name, root
        self.env = {**os.environ, "PYTHONPATH": str(root)}

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
    if process.returncode != 0:
        raise SystemExit(f"{' '.join(command)} exited {process.returncode}:\n{stderr[-2000:]}")
    return usage.ru_utime + usage.ru_stime + orphans, usage.ru_maxrss / 1024, wall


def size_of(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) if path.exists() else 0


def best(measures: list[tuple[float, float, float]]) -> tuple[float, float, float]:
    return tuple(min(m[i] for m in measures) for i in range(3))


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
        process.send_signal(signal.SIGTERM)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        reap_orphans()
    return status["cpu"], status["VmRSS"] / 1024, status["VmHWM"] / 1024, wall


def import_offenders(checkout: Checkout, scratch: Path, top: int) -> list[tuple[str, float]]:
    """The top-level packages ``solve --help`` spends its import time on (own time of their modules, ms)."""
    result = subprocess.run([sys.executable, "-X", "importtime", "-m", "plantsolve.cli", "solve", "--help"],
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
    """``--before``: a directory as it is, a git revision checked out into a temporary worktree, '' for none."""
    if not spec:
        return None, None
    if Path(spec).is_dir():
        return Checkout(Path(spec).name, Path(spec).resolve()), None
    folder = scratch / "before"
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(folder), spec], check=True,
                   capture_output=True)
    return Checkout(spec, folder), folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--kinds", default="", help="comma-separated kinds (default: all)")
    parser.add_argument("--before", default="main",
                        help="the checkout to compare with: a directory, or a git revision (checked out for the run); "
                        "'' for this checkout alone")
    parser.add_argument("--no-api", action="store_true", help="leave out the API start-up")
    parser.add_argument("--importtime", action="store_true", help="the libraries `solve --help` imports, by time")
    args = parser.parse_args()
    kinds = {k for k in args.kinds.split(",") if k}
    become_subreaper()
    scratch = Path(tempfile.mkdtemp(prefix="bench-cli-"))
    before, worktree = before_checkout(args.before, scratch)
    sides = [side for side in (before, Checkout("this", REPO)) if side is not None]
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

    if args.importtime:
        print("\n`plantsolve solve --help`: import time by top-level package (own time of its modules, ms; "
              "-X importtime inflates it)")
        for side in sides:
            offenders = import_offenders(side, scratch, 10)
            print(f"{side.name:<10} " + ", ".join(f"{name} {ms:.0f}" for name, ms in offenders))


if __name__ == "__main__":
    main()
