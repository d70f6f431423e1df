"""A perfmap job's artifact step (``render_artifacts``: three figures as PNG and SVG, and the tables) on the shipped
N+3 fan map at the grids users and tests ask for, this tree beside another checkout (``--before DIR``, e.g. a
worktree of ``integ``) in the same run.

Per case and checkout a fresh process (the checkout first on its path) reads and solves the input, imports the
artifacts module, then times one ``render_artifacts`` call, a job's only one: CPU seconds (user + system of the
process, ``time.process_time``), the growth of the process's peak RSS over it (``ru_maxrss``) and the peak, and a
digest of every PNG and SVG (the same digest on both sides: the same pictures, byte for byte). The checkouts run in
turn (ABAB), ``--repeat`` times; CPU is the least over the repeats, as load only ever adds to it.

    python bench/perfmap_artifacts.py --before /work/wt/perfplot-base [--repeat 3] [--cases n3_64,n3_8]
    python bench/perfmap_artifacts.py --quick      # one repeat, two cases
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# case name -> (input file under examples/perfmap, upload options)
CASES = {
    "n3_json": ("n3_fan_map.json", None),  # the example as a JSON body: grid 64 x 64
    "n3_64": ("n3_fan_map.csv", {"grid": [64, 64]}),
    "n3_16": ("n3_fan_map.csv", {"grid": [16, 16]}),
    "n3_8": ("n3_fan_map.csv", {"grid": [8, 8]}),
}

CHILD = r"""
import hashlib, importlib, json, resource, sys, time
from pathlib import Path
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.kinds import KINDS

path, options = sys.argv[1], json.loads(sys.argv[2])
spec = KINDS["perfmap"]
source = StoredInput.from_path(Path(path))
job_input = spec.input_of(spec.parse_upload(source, options), source)
solved = spec.solve(job_input, lambda *_: None)
importlib.import_module("plantsolve.solvers.perfmap.artifacts")  # imported before the clock, as in a forked job
rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.process_time()
artifacts = spec.render_artifacts(job_input, solved)
cpu = time.process_time() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
plots = {a.name: hashlib.sha256(a.data).hexdigest()[:12] for a in artifacts if a.name.endswith((".png", ".svg"))}
print(json.dumps({"cpu": cpu, "rss_growth_mib": (peak - rss_before) / 1024, "peak_mib": peak / 1024, "plots": plots,
                  "bytes": sum(len(a.data) for a in artifacts)}))
"""


def run(root: Path, case: str) -> dict:
    name, options = CASES[case]
    env = {**os.environ, "PYTHONPATH": str(root), "MPLBACKEND": "Agg"}
    done = subprocess.run([sys.executable, "-c", CHILD, str(REPO / "examples" / "perfmap" / name), json.dumps(options)],
                          cwd=root, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"{case} in {root} failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", type=Path, help="another checkout (a worktree of integ), run beside this one")
    parser.add_argument("--cases", default=",".join(CASES), help=f"any of {', '.join(CASES)}")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="one repeat, the JSON example and grid 8")
    args = parser.parse_args()
    cases = [c for c in args.cases.split(",") if c]
    if args.quick:
        args.repeat, cases = 1, ["n3_json", "n3_8"]
    sides = ([("before", args.before.resolve())] if args.before else []) + [("after", REPO)]
    best: dict[tuple[str, str], dict] = {}
    for _ in range(args.repeat):
        for case in cases:
            for side, root in sides:  # in turn: a busy machine slows both alike
                got = run(root, case)
                old = best.setdefault((case, side), got)
                for key in ("cpu", "rss_growth_mib", "peak_mib"):
                    old[key] = min(old[key], got[key])
    print(f"perfmap render_artifacts, one call per process: CPU s (least of {args.repeat}), peak RSS growth over the "
          "call and the process's peak [MiB], artifact bytes, plots byte for byte as before")
    head = f"{'case':<8} {'side':<7} {'CPU s':>6} {'RSS growth':>10} {'peak RSS':>8} {'bytes':>8} {'same plots':>10}"
    print(head)
    print("-" * len(head))
    for case in cases:
        for side, _ in sides:
            b = best[(case, side)]
            same = "" if side == "before" or not args.before else \
                ("yes" if b["plots"] == best[(case, "before")]["plots"] else "NO")
            print(f"{case:<8} {side:<7} {b['cpu']:>6.2f} {b['rss_growth_mib']:>10.1f} {b['peak_mib']:>8.1f} "
                  f"{b['bytes']:>8} {same:>10}")
        if args.before:
            a, b = best[(case, "after")], best[(case, "before")]
            print(f"{'':<8} {'ratio':<7} {a['cpu'] / b['cpu']:>6.2f}")


if __name__ == "__main__":
    main()
