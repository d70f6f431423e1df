"""What the fix49c intake rules cost, main against this tree, each case in a fresh process (minimum of three runs:
the machine is shared), CPU seconds:

- reading a dense PTS text file printed to 1 mm (x y z intensity r g b, intensity ~N(1500, 30), constant colour) of
  200,000 samples, where whole rows repeat by chance and rows at one place are now compared with rows at
  neighbouring places, and the same file with half of it pasted again shuffled;
- ``check_input`` of a 1 mm tube scanned from one side with 0.15 mm noise, 20,000 samples, ``options.pipe_radius``
  1 mm (the measurement now also gives the fits' noise), and whether the radius was refused.

    python bench/tube_fix49c_intake.py [--ref main]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CHILD = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
from plantsolve.solvers.tube.synthetic import clear_tube, surface_samples
case = sys.argv[2]
if case.startswith("pts"):
    from plantsolve.solvers.tube.read_log import ReadLog
    from plantsolve.solvers.tube.text_points import read_text_points
    rng = np.random.default_rng(1)
    pts = surface_samples(clear_tube(rng, pipe_radius=6.0), 200_000, rng, noise=0.05)
    intensity = np.round(rng.normal(1500, 30.0, len(pts))).astype(int)
    lines = [f"{x:.0f} {y:.0f} {z:.0f} {i} 200 200 200" for (x, y, z), i in zip(pts, intensity)]
    if case == "pts_pasted":
        lines += [lines[k] for k in rng.permutation(len(lines))[: len(lines) // 2]]
    content = ("\n".join(lines) + "\n").encode()
    t = time.process_time()
    log = ReadLog("xyz")
    read, _ = read_text_points(content, log)
    print(json.dumps({"cpu": time.process_time() - t, "rows": len(lines), "read": len(read)}))
else:
    from plantsolve.schemas.tube import TubeRequest
    from plantsolve.solvers.base import InputRejected
    from plantsolve.solvers.tube.scan import TubeScan
    from plantsolve.solvers.tube.validation import check_input
    rng = np.random.default_rng(200)
    pts = surface_samples(clear_tube(rng, pipe_radius=1.0), 20_000, rng, view=rng.normal(size=3) * 1000, noise=0.15,
                          outlier_fraction=0.02)
    scan = TubeScan(TubeRequest.model_construct(points=pts, options=TubeRequest.model_fields["options"].annotation(
        pipe_radius=1.0), units="mm"))
    scan.points
    t = time.process_time()
    try:
        check_input(scan)
        refused = False
    except InputRejected:
        refused = True
    print(json.dumps({"cpu": time.process_time() - t, "refused": refused}))
"""


def run(tree: str, case: str) -> dict:
    best = None
    for _ in range(3):
        out = subprocess.run([sys.executable, "-c", CHILD, tree, case], capture_output=True, text=True, check=True)
        got = json.loads(out.stdout.strip().splitlines()[-1])
        best = got if best is None or got["cpu"] < best["cpu"] else best
    return best


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--ref", default="main")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as ref_tree:
        archive = subprocess.run(["git", "-C", ROOT, "archive", args.ref], capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", ref_tree], input=archive, check=True)
        print(f"{'case':<34}{'tree':<8}{'CPU s':>8}  outcome")
        for case in ("pts", "pts_pasted", "pipe_radius"):
            for name, tree in ((args.ref, ref_tree), ("branch", ROOT)):
                r = run(tree, case)
                outcome = (f"{r['rows'] - r['read']} of {r['rows']} rows dropped" if "rows" in r else
                           f"true radius {'refused' if r['refused'] else 'taken'}")
                print(f"{case:<34}{name:<8}{r['cpu']:>8.2f}  {outcome}", flush=True)


if __name__ == "__main__":
    main()
