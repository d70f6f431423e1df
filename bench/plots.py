"""Every kind's ``render_artifacts`` on its example (its plots, PNG and SVG, and its tables), this tree beside another
checkout (``--before DIR``, e.g. a worktree of ``main``) in the same run.

Per kind and checkout, a fresh process (the checkout first on its path) builds the kind's example input, solves it, and
then calls ``spec.render_artifacts`` ``--calls`` times: the CPU seconds (user + system) of the first call (a job
process's: its first drawing builds matplotlib's fonts and, where a figure uses it, the mathtext parser) and the
least of the later calls (the drawing itself), the growth of the process's peak RSS over the render (and the peak),
and the artifacts' count and bytes. The two checkouts run in turn, ``--repeat`` times; each number is the least over
the repeats.

    python bench/plots.py --before /work/wt/main52p [--kinds perfmap,tube] [--repeat 3] [--calls 4]
    python bench/plots.py --quick         # one repeat, two calls per process
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
KINDS = ("alignment", "dedup", "flowmeter", "perfmap", "polyhedra", "rigidity", "tube")

# run in the child: one kind's example rendered `calls` times; prints one JSON line
CHILD = r"""
import importlib, json, resource, sys, time
from plantsolve.solvers.kinds import KINDS

kind, calls = sys.argv[1], int(sys.argv[2])
spec = KINDS[kind]
job_input = spec.input_of(spec.request_model.model_validate(spec.example()))
solved = spec.solve(job_input, lambda *_: None)
# the kind's artifacts module imported before the clock starts, as in a job process forked from the warm parent
importlib.import_module(f"plantsolve.solvers.{kind}.artifacts")
rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
cpu, artifacts = [], []
for _ in range(calls):
    t0 = time.process_time()
    artifacts = spec.render_artifacts(job_input, solved)
    cpu.append(time.process_time() - t0)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps({"cpu": cpu, "rss_growth_mib": (peak - rss_before) / 1024, "peak_mib": peak / 1024,
                  "artifacts": sorted(a.name for a in artifacts), "bytes": sum(len(a.data) for a in artifacts)}))
"""


def run(root: Path, kind: str, calls: int) -> dict:
    env = {**os.environ, "PYTHONPATH": str(root), "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-c", CHILD, kind, str(calls)], cwd=root, env=env, capture_output=True,
                          text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{kind} in {root} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", type=Path, help="another checkout (a worktree of main), run beside this one")
    parser.add_argument("--kinds", default=",".join(KINDS))
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--calls", type=int, default=4, help="render_artifacts calls per process (the first is cold)")
    parser.add_argument("--quick", action="store_true", help="one repeat, two calls")
    args = parser.parse_args()
    if args.quick:
        args.repeat, args.calls = 1, 2
    sides = ([("before", args.before.resolve())] if args.before else []) + [("after", REPO)]
    kinds = [k for k in args.kinds.split(",") if k]
    best: dict[tuple[str, str], dict] = {}
    for _ in range(args.repeat):
        for kind in kinds:
            for side, root in sides:  # in turn: a busy machine slows both alike
                got = run(root, kind, args.calls)
                old = best.get((kind, side))
                if old is None:
                    best[(kind, side)] = {**got, "first": got["cpu"][0], "warm": min(got["cpu"][1:] or got["cpu"])}
                else:
                    old["first"] = min(old["first"], got["cpu"][0])
                    old["warm"] = min(old["warm"], *(got["cpu"][1:] or got["cpu"]))
                    old["rss_growth_mib"] = min(old["rss_growth_mib"], got["rss_growth_mib"])
                    old["peak_mib"] = min(old["peak_mib"], got["peak_mib"])
    print(f"render_artifacts on each kind's example: CPU s (least of {args.repeat} processes; 'warm': least of the "
          f"{max(args.calls - 1, 1)} later calls), peak RSS growth over the render and the process's peak [MiB]")
    head = f"{'kind':<10} {'side':<7} {'first CPU s':>11} {'warm CPU s':>10} {'RSS growth':>10} {'peak RSS':>8} " \
           f"{'files':>5} {'bytes':>9}"
    print(head)
    print("-" * len(head))
    for kind in kinds:
        for side, _ in sides:
            b = best[(kind, side)]
            print(f"{kind:<10} {side:<7} {b['first']:>11.3f} {b['warm']:>10.3f} {b['rss_growth_mib']:>10.1f} "
                  f"{b['peak_mib']:>8.1f} {len(b['artifacts']):>5} {b['bytes']:>9}")
        if args.before:
            a, b = best[(kind, "after")], best[(kind, "before")]
            if a["artifacts"] != b["artifacts"]:
                print(f"{'':<10} artifacts differ: before {b['artifacts']}, after {a['artifacts']}")
            print(f"{'':<10} {'ratio':<7} {a['first'] / b['first']:>11.2f} {a['warm'] / b['warm']:>10.2f}")


if __name__ == "__main__":
    main()
