"""Every kind end to end through the command line: ``plantsolve solve`` on the shipped examples, as a user runs it.

For each kind and example file, a fresh ``plantsolve solve KIND FILE -o result.json --artifacts DIR`` process:
its CPU seconds (user + system, itself and the reader process it waits for, from ``wait4``), its peak resident
memory, the wall time, and the sizes of what it wrote (the result JSON and the artifacts). The floor in the same
run: the same command's start-up alone (``plantsolve solve --help``, which imports no solver) and ``python -c
pass``. Numbers are best of ``--repeat`` (CPU seconds hold on a loaded machine; wall time does not).

    python bench/cli.py [--repeat N] [--kinds tube,perfmap]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent
EXAMPLES = REPO / "examples"

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


def run_measured(command: list[str], cwd: Path) -> tuple[int, float, float, float]:
    """Run ``command``; returns (exit code, CPU seconds, peak RSS in MiB, wall seconds) of that process."""
    started = time.perf_counter()
    process = subprocess.Popen(command, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.perf_counter() - started
    process.returncode = os.waitstatus_to_exitcode(status)
    stderr = process.stderr.read().decode(errors="replace")
    process.stderr.close()
    if process.returncode != 0:
        raise SystemExit(f"{' '.join(command)} exited {process.returncode}:\n{stderr[-2000:]}")
    return process.returncode, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024, wall


def size_of(path: Path) -> int:
    if path.is_file():
        return path.stat().st_size
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file()) if path.exists() else 0


def best(measures: list[tuple[int, float, float, float]]) -> tuple[float, float, float]:
    return min(m[1] for m in measures), min(m[2] for m in measures), min(m[3] for m in measures)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--kinds", default="", help="comma-separated kinds (default: all)")
    args = parser.parse_args()
    kinds = {k for k in args.kinds.split(",") if k}
    plantsolve = str(BIN / "plantsolve")
    scratch = Path(tempfile.mkdtemp(prefix="bench-cli-"))

    floor_python = best([run_measured([sys.executable, "-c", "pass"], scratch) for _ in range(args.repeat)])
    floor_cli = best([run_measured([plantsolve, "solve", "--help"], scratch) for _ in range(args.repeat)])
    rows = []
    for kind, example, options in CASES:
        if kinds and kind not in kinds:
            continue
        source = EXAMPLES / example
        measures, result_size, artifact_size = [], 0, 0
        for attempt in range(args.repeat):
            out, artifacts = scratch / f"{kind}-{attempt}.json", scratch / f"{kind}-{attempt}-artifacts"
            command = [plantsolve, "solve", kind, str(source), "-o", str(out), "--artifacts", str(artifacts),
                       "--no-progress"]
            if options:
                command += ["--options", options]
            measures.append(run_measured(command, scratch))
            result_size, artifact_size = size_of(out), size_of(artifacts)
        rows.append((kind, example.split("/", 1)[1], size_of(source), *best(measures), result_size, artifact_size))

    print(f"\n`plantsolve solve` per kind on the shipped examples, best of {args.repeat}, {os.cpu_count()} cores "
          f"(CPU s and peak RSS of the solve process, from wait4)")
    header = (f"{'kind':<10} {'input':<22} {'input kB':>9} {'CPU s':>7} {'over start-up':>13} {'peak MiB':>9} "
              f"{'wall s':>7} {'result kB':>10} {'artifacts kB':>13}")
    print(header)
    print("-" * len(header))
    for name, (cpu, rss, wall) in (("python -c pass", floor_python), ("plantsolve solve --help", floor_cli)):
        print(f"{'(floor)':<10} {name:<22} {'':>9} {cpu:>7.2f} {'':>13} {rss:>9.0f} {wall:>7.2f}")
    for kind, name, input_size, cpu, rss, wall, result_size, artifact_size in rows:
        print(f"{kind:<10} {name:<22} {input_size / 1024:>9.1f} {cpu:>7.2f} {cpu - floor_cli[0]:>13.2f} {rss:>9.0f} "
              f"{wall:>7.2f} {result_size / 1024:>10.1f} {artifact_size / 1024:>13.1f}")
    print("over start-up: CPU s beyond `plantsolve solve --help` (the interpreter and the command line, no solver)")


if __name__ == "__main__":
    main()
