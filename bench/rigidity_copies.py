"""Hostile input for the rigidity solver: many copies of one part at one pose, before and after a change, in one run.

    python bench/rigidity_copies.py                       # 1,500 plates 3024 at one spot, main and this checkout
    python bench/rigidity_copies.py --copies 100 1500 --before main

Each model is an LDraw upload of ``N`` lines placing a 1 x 1 plate 3024 at the origin, unturned (an editor's paste
repeated, or a file made to exhaust the service). Per model and side: the CPU seconds of parse and solve
(``time.process_time``), the peak RSS of the child process (``ru_maxrss``), and the answer's parts analysed, joints,
collisions and warnings, which must agree wherever they can (the copies beyond one repeat are left out after). The
baseline is the ``plantsolve`` package of git ``--before`` (default ``main``), taken out of git into a temporary
folder; each side runs in a child process of its own, the baseline first, on the same models.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tarfile
import tempfile
import time
from io import BytesIO
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINE = "1 15 0 0 0 1 0 0 0 1 0 0 0 1 3024.dat\n"


def measure(copies: int) -> dict:
    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.rigidity.solve import solve
    from plantsolve.solvers.rigidity.upload import parse_upload

    text = "0 copies of a 1 x 1 plate at one spot\n" + LINE * copies
    start = time.process_time()
    result = solve(parse_upload(StoredInput.from_bytes("copies.ldr", text.encode()), None)).result
    seconds = time.process_time() - start
    return {"copies": copies, "cpu_s": round(seconds, 3), "rss_mb": round(resource.getrusage(
        resource.RUSAGE_SELF).ru_maxrss / 1024, 1), "parts": len(result.parts), "joints": len(result.joints),
        "collisions": len(result.collisions), "warnings": [w.code for w in result.report.warnings]}


def side(folder: str | None, copies: list[int]) -> list[dict]:
    """The rows measured by the package in ``folder`` (this checkout's when None), one child process per model."""
    rows = []
    for n in copies:
        boot = ("import runpy, sys; sys.meta_path[:] = [f for f in sys.meta_path if '__editable__' not in "
                f"repr(f)]; sys.path.insert(0, {folder!r}); sys.argv = sys.argv[1:]; "
                "runpy.run_path(sys.argv[0], run_name='__main__')") if folder else \
            "import runpy, sys; sys.argv = sys.argv[1:]; runpy.run_path(sys.argv[0], run_name='__main__')"
        out = subprocess.run([sys.executable, "-c", boot, __file__, "--child", str(n)], check=True,
                             capture_output=True, text=True, cwd=ROOT).stdout
        rows.append(json.loads(out))
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--copies", type=int, nargs="+", default=[1500], help="copies of the plate per model")
    parser.add_argument("--before", default="main", help="git ref of the baseline, or 'none'")
    parser.add_argument("--child", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child is not None:
        print(json.dumps(measure(args.child)))
        return 0
    before = None
    if args.before != "none":
        archive = subprocess.run(["git", "archive", "--format=tar", args.before, "plantsolve"], cwd=ROOT, check=True,
                                 capture_output=True).stdout
        with tempfile.TemporaryDirectory() as folder:
            with tarfile.open(fileobj=BytesIO(archive)) as tar:
                tar.extractall(folder, filter="data")
            before = side(folder, args.copies)
    after = side(None, args.copies)
    print(f"| copies | CPU s ({args.before} -> this) | peak RSS MB | parts analysed | joints | collisions | warnings "
          "(this) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for k, row in enumerate(after):
        old = before[k] if before else None

        def pair(key, row=row, old=old):
            return f"{old[key]} -> {row[key]}" if old else str(row[key])

        print(f"| {row['copies']} | {pair('cpu_s')} | {pair('rss_mb')} | {pair('parts')} | {pair('joints')} | "
              f"{pair('collisions')} | {', '.join(row['warnings'])} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
