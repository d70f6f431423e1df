"""Benchmark of the alignment solver: both methods side by side.

Scan-like grid networks (every cell a loop, inline valves, two tie-ins at opposite corners,
plant-scale coordinates around 1e6 mm): pipes perturbed ~2 mm / 0.3 deg, fittings
~6 mm / 1.5 deg. Each run happens in a fresh process so its peak memory can be measured.

    python bench/alignment.py            # 100, 1,000 and 10,000 components
    python bench/alignment.py --quick    # 100 and 1,000 components

Targets: 1,000 components < 2 s, 10,000 < 30 s, memory linear.

Then the scaling table of the direct method: about 1,000, 3,500, 10,000 and 35,000 components
(35,000 not with --quick), wall and CPU time, peak memory, the largest gap left, and the
exponent k of CPU time ~ components^k (and of memory) fitted between each size and the one
before. With
``--before DIR`` the same sizes also run on the code in DIR (a checkout of another revision,
only read), side by side:

    python bench/alignment.py --scaling-only --before /path/to/other/checkout
"""

from __future__ import annotations

import argparse
import math
import multiprocessing as mp
import resource
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

SIZES = {100: 6, 1000: 18, 10000: 55}  # target size -> grid side
SCALING_SIDES = (18, 31, 55, 99)  # 1,161 / 3,351 / 10,661 / 34,749 components


def _rss_kib(field: str) -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field):
            return int(line.split()[1])
    return 0


def _cpu_s() -> float:
    use = resource.getrusage(resource.RUSAGE_SELF)
    return use.ru_utime + use.ru_stime


def _run(side: int, method: str, max_iterations: int | None, queue, code: str | None = None) -> None:
    if code is not None:
        # the child has imported nothing of plantsolve yet, so this checkout is the one it loads
        sys.path.insert(0, code)
    from plantsolve.solvers.alignment import solve
    from plantsolve.solvers.alignment.synthetic import grid_network

    req = grid_network(side, side, valve_every=7, tie_ins=((0, 0), (side - 1, side - 1)),
                       origin=(1.0e6, 2.0e5, 1.0e4), seed=2024,
                       options={"method": method} if max_iterations is None
                       else {"method": method, "max_iterations": max_iterations})
    base = _rss_kib("VmRSS")
    t0, c0 = time.perf_counter(), _cpu_s()
    solved = solve(req)
    res = getattr(solved, "result", solved)  # a --before checkout older than the Solved contract returns the result
    wall, cpu = time.perf_counter() - t0, _cpu_s() - c0
    d = res.report.details
    queue.put({
        "components": len(req.components), "connections": len(req.connections), "method": method, "converged": res.converged,
        "iterations": res.iterations, "wall_s": wall, "cpu_s": cpu, "peak_mib": (_rss_kib("VmHWM") - base) / 1024.0,
        "max_gap": res.max_position_error, "solver_residual": d["snap_distortion"]["position"] if res.converged else res.max_position_error,
        "pipe_axis_mean": d["pipe_axis_movement"]["mean"], "fitting_mean": d["fitting_displacement"]["mean"],
        "cuts": len(res.cut_connections), "stop": d["stop_reason"],
    })


def run_case(side: int, method: str, max_iterations: int | None, code: str | None = None) -> dict:
    ctx = mp.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_run, args=(side, method, max_iterations, q, code))
    p.start()
    out = q.get()
    p.join()
    return out


def _exponent(small: dict | None, large: dict, key: str) -> str:
    if small is None or small[key] <= 0 or large[key] <= 0:
        return ""
    return f"{math.log(large[key] / small[key]) / math.log(large['components'] / small['components']):.2f}"


def scaling(quick: bool, before: str | None) -> None:
    """Direct method on growing grids; with ``before``, the code in that directory on the same grids."""
    sides = SCALING_SIDES[:-1] if quick else SCALING_SIDES
    runs = [("this", None)] + ([("before", before)] if before else [])
    head = (f"{'code':>6} {'components':>10} {'connections':>11} {'wall s':>8} {'cpu s':>8} {'peak MiB':>9} {'max gap':>9} "
            f"{'k cpu':>6} {'k mem':>6} {'iter':>5}  stop")
    print("\nDirect method, scaling (k: exponent of CPU time or memory ~ components^k since the size before)")
    print(head)
    print("-" * len(head))
    rows: dict[str, list[dict]] = {}
    for side in sides:
        for label, code in runs:
            r = run_case(side, "direct", None, code)
            prev = rows.get(label, [None])[-1]
            rows.setdefault(label, []).append(r)
            print(f"{label:>6} {r['components']:>10} {r['connections']:>11} {r['wall_s']:>8.2f} {r['cpu_s']:>8.2f} "
                  f"{r['peak_mib']:>9.1f} {r['max_gap']:>9.2e} {_exponent(prev, r, 'cpu_s'):>6} {_exponent(prev, r, 'peak_mib'):>6} "
                  f"{r['iterations']:>5}  {r['stop']}", flush=True)
    if before:
        print("\nthis / before:")
        for now, old in zip(rows["this"], rows["before"]):
            print(f"  {now['components']:>6} components: CPU time {now['cpu_s'] / old['cpu_s']:.2f}, "
                  f"peak memory {now['peak_mib'] / max(old['peak_mib'], 1e-9):.2f}")
    print("cpu s: user + system time of the solve (what other load on the machine changes least); peak MiB: "
          "growth of the resident set during the solve (the request is built before).")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="only 100 and 1,000 components; scaling up to 10,000")
    ap.add_argument("--dq-iterations", type=int, default=4000, help="iteration cap of the dual-quaternion method")
    ap.add_argument("--scaling-only", action="store_true", help="only the scaling table of the direct method")
    ap.add_argument("--before", metavar="DIR", help="also run the scaling table on the plantsolve checkout in DIR")
    args = ap.parse_args()
    if not args.scaling_only:
        methods(args.quick, args.dq_iterations)
    scaling(args.quick, args.before)


def methods(quick: bool, dq_iterations: int) -> None:
    """Both methods side by side at 100, 1,000 and 10,000 components."""
    sizes = [100, 1000] if quick else [100, 1000, 10000]
    targets = {100: None, 1000: 2.0, 10000: 30.0}
    head = (f"{'components':>10} {'method':>15} {'conv':>5} {'iter':>6} {'wall s':>8} {'target':>7} {'peak MiB':>9} "
            f"{'max gap':>9} {'residual*':>9} {'pipe axis':>9} {'fitting':>8} {'cuts':>4}  stop")
    print(head)
    print("-" * len(head))
    for size in sizes:
        for method in ("direct", "dual_quaternion"):
            r = run_case(SIZES[size], method, dq_iterations)
            tgt = targets[size]
            mark = "" if tgt is None else ("ok" if r["wall_s"] < tgt else "MISS")
            print(f"{r['components']:>10} {method:>15} {str(r['converged']):>5} {r['iterations']:>6} {r['wall_s']:>8.2f} "
                  f"{mark:>7} {r['peak_mib']:>9.1f} {r['max_gap']:>9.2e} {r['solver_residual']:>9.2e} "
                  f"{r['pipe_axis_mean']:>9.3f} {r['fitting_mean']:>8.3f} {r['cuts']:>4}  {r['stop']}", flush=True)
    print("\nmax gap: largest gap left in the result (mm); residual*: solver residual that was snapped to "
          "bit-identical ports (converged runs) or the largest gap (others); pipe axis: mean distance of the "
          "measured pipe ends from the new axis (mm); fitting: mean largest port movement of fittings (mm).")


if __name__ == "__main__":
    main()
