"""Benchmark of the tube inspection (nominal checks, tolerances, corrections, overlay plot) against the
inspection on ``main`` (loaded from git in the same run, same inputs).

    python bench/tube_inspection.py            # 12 random tubes
    python bench/tube_inspection.py --tubes 4  # fewer

Each random tube (``synthetic.random_tube``: 1–8 bends, pipe radius 1–50, back-to-back, tiny and >180°
bends) is the nominal; the made tube has every bend 1.5° short, one rotation 2° off and one straight 3 % of the
pipe radius × 30 long (the known errors). Rows: (a) the inspection alone on the exact made tube, CPU seconds of
``main``'s ``inspect`` and of this branch's (the rows' pass/fail and corrections are the only extra work);
(b) the whole solve of a simulated scan (6000 samples, noise 1 % r) with the nominal: the largest error of the
returned deviations against the known ones, in units of the reconstruction's own sigma, and whether the
failed rows are the right ones; (c) the plots with a nominal, ``main``'s ``figures`` and this branch's (which
adds the overlay), rendered to PNG. CPU time by ``time.process_time``; peak RSS of the process at the end.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time
import types

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))

import numpy as np

from plantsolve.schemas.tube import TubeOptions, TubeRequest
from plantsolve.solvers.base import SolverError
from plantsolve.solvers.plots import figure_bytes
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube import artifacts as new_artifacts
from plantsolve.solvers.tube import inspection as new_inspection
from plantsolve.solvers.tube.lra import model_rows
from plantsolve.solvers.tube.synthetic import clear_tube, surface_samples

REPO = os.path.join(os.path.dirname(__file__), "..")


def main_module(path: str, name: str) -> types.ModuleType:
    """A module's source as it is on ``main``, run against this checkout's other modules."""
    src = subprocess.check_output(["git", "show", f"main:{path}"], cwd=REPO, text=True)
    mod = types.ModuleType(name)
    exec(compile(src, f"main:{path}", "exec"), mod.__dict__)  # noqa: S102 - the repository's own source
    return mod


def case(seed: int):
    rng = np.random.default_rng(seed)
    made = clear_tube(rng, min_bends=2)
    nominal = model_rows(made)
    n = made.n_bends
    made.angles = made.angles - np.radians(1.5)
    rot_row, len_row = 1, int(rng.integers(0, n))
    made.rotations = made.rotations.copy()
    made.rotations[rot_row] += np.radians(2.0) if rot_row < n else 0.0
    made.lengths = made.lengths.copy()
    made.lengths[len_row] += 0.9 * made.pipe_radius
    known = np.zeros((n + 1, 3))
    known[:n, 2] = -1.5
    known[rot_row, 1] = 2.0
    known[len_row, 0] = 0.9 * made.pipe_radius
    return made, nominal, known, rng


def cpu(fn, *args, repeat: int = 3):
    t = time.process_time()
    for _ in range(repeat):
        out = fn(*args)
    return (time.process_time() - t) / repeat, out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--tubes", type=int, default=12)
    args = ap.parse_args()
    old_inspection = main_module("plantsolve/solvers/tube/inspection.py", "main_inspection")
    old_artifacts = main_module("plantsolve/solvers/tube/artifacts.py", "main_artifacts")
    print(f"{'seed':>4} {'bends':>5} {'r':>6} | {'inspect main':>12} {'inspect new':>11} | {'solve':>6} "
          f"{'max |err|/σ':>11} {'rows ok':>7} | {'plots main':>10} {'plots new':>9}")
    totals = []
    for seed in range(args.tubes):
        made, nominal, known, rng = case(seed)
        t_old, _ = cpu(old_inspection.inspect, made, nominal, 1.0)
        t_new, _ = cpu(new_inspection.inspect, made, nominal, 1.0, TubeOptions(), "mm")
        pts = surface_samples(made, 6000, rng, noise=0.01 * made.pipe_radius)
        scan = TubeScan(TubeRequest(points=pts.tolist(), options={"nominal": [r.model_dump() for r in nominal],
                                                                   "inspection_tolerances": {"angle": 0.75}}))
        t0 = time.process_time()
        try:
            res = solve(scan).result
        except SolverError as exc:
            print(f"{seed:>4} solve failed: {exc}")
            continue
        t_solve = time.process_time() - t0
        ins = res.inspection
        err, rows_ok = float("nan"), False
        if ins.matched:
            got = np.array([[r.length.deviation, r.rotation.deviation if r.rotation else 0.0,
                             r.angle.deviation if r.angle else 0.0] for r in ins.rows])
            sig = np.array([[r.sigma_length or np.nan, r.sigma_rotation or np.nan, r.sigma_angle or np.nan]
                            for r in res.lra])
            if ins.reversed:  # backwards, row i's straight and rotation are row n − i's, its bend is bend n − 1 − i
                n = len(sig) - 1
                sig = np.array([[sig[n - i, 0], sig[n - i, 1] if 0 < i < n else np.nan,
                                 sig[n - 1 - i, 2] if i < n else np.nan] for i in range(n + 1)])
            ratio = np.abs(got - known) / sig
            err = float(np.nanmax(ratio))
            want_fail = [i + 1 for i in range(len(known)) if np.any(np.abs(known[i]) > 0)]
            rows_ok = ins.failed_rows == want_fail
        t_plot_old, _ = cpu(lambda s=scan, r=res: [figure_bytes(f) for f in old_artifacts.figures(s, r).values()], repeat=1)
        t_plot_new, _ = cpu(lambda s=scan, r=res: [figure_bytes(f) for f in new_artifacts.figures(s, r).values()], repeat=1)
        totals.append((t_old, t_new, t_plot_old, t_plot_new))
        print(f"{seed:>4} {made.n_bends:>5} {made.pipe_radius:>6.2f} | {t_old:>12.3f} {t_new:>11.3f} | "
              f"{t_solve:>6.2f} {err:>11.2f} {rows_ok!s:>7} | {t_plot_old:>10.2f} {t_plot_new:>9.2f}")
    if totals:
        m = np.mean(totals, axis=0)
        print(f"mean CPU s: inspect main {m[0]:.3f}, new {m[1]:.3f}; plots main {m[2]:.2f}, new {m[3]:.2f}")
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")


if __name__ == "__main__":
    main()
