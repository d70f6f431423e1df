"""What fix49a's two checks cost: the decimal-comma check of polyhedra's ASCII STL reader on a clean file of 100,800
facets (its solid's name with and without a comma, the one case in which lines are looked at) and the field
structure check of a flowmeter grid of 2,000,000 points (100 x 100 x 200), in CPU seconds, best of three.

Each tree (this checkout, and ``--before DIR``'s in the same run) runs in a process of its own:

    python bench/fix49_mesh_and_grid_checks.py [--before /tmp/main]     # DIR: e.g. `git archive main` extracted
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
FACET = "  facet normal 0 0 1\n    outer loop\n" + "".join(f"      vertex {v}\n" for v in (
    "0.0000 0.0000 3.2500", "3.2500 0.0000 3.2500", "3.2500 3.2500 3.2500")) + "    endloop\n  endfacet\n"


def measure() -> dict:
    """In the tree on sys.path: best-of-three CPU seconds of each case."""
    import numpy as np

    from plantsolve.schemas.flowmeter import FlowmeterRequest
    from plantsolve.solvers.flowmeter.field import request_field
    from plantsolve.solvers.flowmeter.plausibility import request_warnings
    from plantsolve.solvers.polyhedra.upload import parse_stl

    def best(call) -> float:
        times = []
        for _ in range(3):
            start = time.process_time()
            call()
            times.append(time.process_time() - start)
        return min(times)

    out = {}
    for name in ("room", "room 1, level 2"):
        content = f"solid {name}\n{FACET * 100_800}endsolid {name}\n".encode()
        out[f"parse_stl, 100,800 facets, solid '{name}'"] = best(lambda: parse_stl(content))
    x, z = np.linspace(-60.0, 60.0, 100), np.linspace(-160.0, 160.0, 200)
    gx, gy, gz = np.meshgrid(x, x, z, indexing="ij")
    decay = np.exp(-(gz / 120.0) ** 2)
    request = FlowmeterRequest.model_validate({
        "units": "mm", "pipe": {"radius": 50.0, "liner_length": 300.0},
        "electrodes": {"shape": "patch", "half_angle": 22.5, "half_length": 15.7},
        "magnetic_field": {"type": "grid", "x": x.tolist(), "y": x.tolist(), "z": z.tolist(),
                           "bx": (0.001 * gx * gy / 3600 * decay).ravel().tolist(),
                           "by": (0.01 * (1 + 0.2 * gx / 60) * decay).ravel().tolist()}})
    given = request_field(request)
    out["request_warnings, 2,000,000-point grid"] = best(lambda: request_warnings(request, 0.01, None, given))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, help="another checkout (e.g. main) measured first, in the same run")
    parser.add_argument("--measure", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.measure:
        print(json.dumps(measure()))
        return
    rows: dict[str, dict[str, float]] = {}
    trees = ([("before", args.before)] if args.before else []) + [("this tree", HERE)]
    for label, tree in trees:
        env = {**os.environ, "PYTHONPATH": str(tree)}
        done = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--measure"], env=env, cwd=tree,
                              capture_output=True, text=True, check=True)
        for case, seconds in json.loads(done.stdout.splitlines()[-1]).items():
            rows.setdefault(case, {})[label] = seconds
    labels = [label for label, _ in trees]
    print(f"{'case':55s}" + "".join(f"{label + ' CPU s':>18s}" for label in labels))
    for case, by in rows.items():
        print(f"{case:55s}" + "".join(f"{by[label]:18.3f}" for label in labels))


if __name__ == "__main__":
    main()
