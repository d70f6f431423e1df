"""What the intake check of a given pipe radius against the one the scan shows costs: CPU seconds of
``check_input`` for scans with ``options.pipe_radius``, main's checks against this tree's, each case in a fresh
process (the minimum of five runs: the machine is shared).

    python bench/tube_pipe_radius_intake.py [--ref main]

Cases: a synthetic three-bend tube (pipe radius 25 mm, noise 0.05 mm) of 4,000, 100,000 and 1,000,000 samples.
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

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

CHILD = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
import numpy as np
from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.validation import check_input
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
model = make_model([(400, 0, 90, 120), (300, 60, 45, 120), (400, 0, 0, 0)], 25.0)
pts = surface_samples(model, int(sys.argv[2]), np.random.default_rng(0), noise=0.05)
scan = TubeScan(TubeRequest.model_construct(points=pts, options=TubeRequest.model_fields["options"].annotation(
    pipe_radius=25.0), units="mm"))
scan.points
runs = []
for _ in range(5):
    t0 = time.process_time()
    check_input(scan)
    runs.append(time.process_time() - t0)
print(json.dumps({"cpu_s": min(runs)}))
"""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--ref", default="main")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(f"git -C {ROOT} archive {args.ref} plantsolve | tar -x -C {tmp}", shell=True, check=True)
        env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        print(f"{'samples':>10s} {'check_input CPU s (' + args.ref + ' -> this)':>36s}")
        for n in (4000, 100_000, 1_000_000):
            got = []
            for code in (tmp, ROOT):
                run = subprocess.run([sys.executable, "-c", CHILD, code, str(n)], env=env, capture_output=True,
                                     text=True, check=False)
                if run.returncode:
                    sys.exit(f"{n} with {code}: {run.stderr.strip().splitlines()[-1]}")
                got.append(json.loads(run.stdout)["cpu_s"])
            print(f"{n:>10,} {got[0]:>22.3f} -> {got[1]:<.3f}")


if __name__ == "__main__":
    main()
