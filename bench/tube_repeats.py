"""Repeated samples of a tube scan upload: which are left out as a paste, and what the rule costs, main's reader
against this tree's, each case in a fresh process (CPU seconds of parse_upload, the process's peak RSS).

    python bench/tube_repeats.py [--ref main] [--big 1000000]

Cases: the example scan (4,000 samples) printed to 3, 1 and 0 decimals (mm), the 0-decimal print pasted twice, and
a synthetic scan of ``--big`` samples as NPY rounded to 1 mm and to 0.001 mm (the rule's worst and usual case).
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
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.upload import parse_upload
name, path = sys.argv[2], sys.argv[3]
data = open(path, "rb").read()
t0 = time.process_time()
req = parse_upload(StoredInput.from_bytes(name, data), {})
cpu = time.process_time() - t0
hwm = next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmHWM"))
dup = [w.details for w in req.source.warnings if w.code == "duplicate_points"]
print(json.dumps({"kept": req.source.points, "dropped": dup[0]["repeated"] if dup else 0, "cpu_s": cpu,
                  "rss_mb": hwm / 1024}))
"""


def cases(tmp: str, big: int) -> list[tuple[str, str, str]]:
    import numpy as np

    sys.path.insert(0, ROOT)
    from plantsolve.solvers.tube.synthetic import clear_tube, surface_samples

    pts = np.loadtxt(os.path.join(ROOT, "examples", "tube", "scan.xyz"))
    out = []

    def text(label, rows, decimals):
        path = os.path.join(tmp, f"{label}.xyz")
        with open(path, "w") as fh:
            fh.write("\n".join(" ".join(f"{v:.{decimals}f}" for v in p) for p in rows))
        out.append((label, "scan.xyz", path))

    text("example 3 decimals", pts, 3)
    text("example 1 decimal", pts, 1)
    text("example 0 decimals", pts, 0)
    text("example 0 decimals pasted twice", np.vstack([pts, pts]), 0)
    rng = np.random.default_rng(1)
    m = clear_tube(rng, pipe_radius=20.0, n_bends=3)
    scan = surface_samples(m, big, rng, view=rng.normal(size=3), noise=0.25, outlier_fraction=0.005)
    for decimals in (0, 3):
        path = os.path.join(tmp, f"big{decimals}.npy")
        np.save(path, np.round(scan, decimals))
        out.append((f"synthetic {big:,} NPY {decimals} decimals", "scan.npy", path))
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--ref", default="main")
    ap.add_argument("--big", type=int, default=1_000_000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        ref = os.path.join(tmp, "ref")
        os.mkdir(ref)
        subprocess.run(f"git -C {ROOT} archive {args.ref} plantsolve | tar -x -C {ref}", shell=True, check=True)
        env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        print(f"{'case':42s} {'samples kept (' + args.ref + ' -> this)':>28s} {'dropped':>16s} {'CPU s':>14s} "
              f"{'peak RSS MB':>14s}")
        for label, name, path in cases(tmp, args.big):
            got = []
            for code in (ref, ROOT):
                run = subprocess.run([sys.executable, "-c", CHILD, code, name, path], env=env, capture_output=True,
                                     text=True, check=False)
                if run.returncode:
                    sys.exit(f"{label} with {code}: {run.stderr.strip().splitlines()[-1]}")
                got.append(json.loads(run.stdout))
            a, b = got
            print(f"{label:42s} {a['kept']:>13,} -> {b['kept']:<12,} {a['dropped']:>7,} -> {b['dropped']:<6,} "
                  f"{a['cpu_s']:6.2f} -> {b['cpu_s']:<5.2f} {a['rss_mb']:6.0f} -> {b['rss_mb']:<5.0f}")


if __name__ == "__main__":
    main()
