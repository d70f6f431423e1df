"""What two intake rules cost, main against this tree, each case in a fresh process (the minimum of five runs of
``check_input``, one of ``parse_upload``: the machine is shared):

- the check of a given pipe radius against the one the scan shows: CPU seconds of ``check_input`` for a synthetic
  three-bend tube (pipe radius 25 mm, noise 0.05 mm) of 4,000, 100,000 and 1,000,000 samples with
  ``options.pipe_radius``;
- the search of a text file for rows copied in every column: CPU seconds of ``parse_upload`` of the same tube's
  1,000,000 samples as a PTS text file (x y z intensity r g b) printed to 0.1 mm.

    python bench/tube_trust49_intake.py [--ref main]
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

READ = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.upload import parse_upload
data = open(sys.argv[2], "rb").read()
t0 = time.process_time()
parse_upload(StoredInput.from_bytes("scan.txt", data), {})
print(json.dumps({"cpu_s": time.process_time() - t0}))
"""


def pts_file(path: str) -> None:
    import numpy as np

    sys.path.insert(0, ROOT)
    from plantsolve.solvers.tube.synthetic import make_model, surface_samples

    rng = np.random.default_rng(0)
    pts = surface_samples(make_model([(400, 0, 90, 120), (300, 60, 45, 120), (400, 0, 0, 0)], 25.0), 1_000_000, rng,
                          noise=0.05)
    other = np.column_stack([rng.integers(-2048, 2048, len(pts)), rng.integers(0, 256, (len(pts), 3))])
    with open(path, "w") as fh:
        fh.write("\n".join(f"{x:.1f} {y:.1f} {z:.1f} {i} {r} {g} {b}" for (x, y, z), (i, r, g, b)
                           in zip(pts.tolist(), other.tolist())))


def run(child: str, *args: str) -> float:
    done = subprocess.run([sys.executable, "-c", child, *args], env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"},
                          capture_output=True, text=True, check=False)
    if done.returncode:
        sys.exit(f"{args}: {done.stderr.strip().splitlines()[-1]}")
    return json.loads(done.stdout)["cpu_s"]


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--ref", default="main")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        ref = os.path.join(tmp, "ref")
        os.mkdir(ref)
        subprocess.run(f"git -C {ROOT} archive {args.ref} plantsolve | tar -x -C {ref}", shell=True, check=True)
        print(f"{'case':44s} {'CPU s (' + args.ref + ' -> this)':>24s}")
        for n in (4000, 100_000, 1_000_000):
            before, after = (run(CHILD, code, str(n)) for code in (ref, ROOT))
            print(f"{f'check_input, pipe_radius, {n:,} samples':44s} {before:>12.3f} -> {after:<.3f}")
        path = os.path.join(tmp, "scan.txt")
        pts_file(path)
        before, after = (run(READ, code, path) for code in (ref, ROOT))
        print(f"{'parse_upload, PTS text, 1,000,000 rows':44s} {before:>12.3f} -> {after:<.3f}")


if __name__ == "__main__":
    main()
