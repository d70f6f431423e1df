"""Benchmark of the flowmeter solver.

    python bench/flowmeter.py            # full run (reference meshes h = 0.06 R)
    python bench/flowmeter.py --quick    # reference meshes h = 0.08 R

For beta in {5, 22.5, 45} deg and a/R in {0.1, pi/10, 1, inf} (L/R = 6, uniform B and flow):
S, |error| against the reference, the method's own error estimate and seconds for the closed form
(a = inf, exact pi/(2K(sin beta))), the integral equation (default tolerance 1e-3), the calibrated
FEM (default tolerance 1e-3; the uncalibrated value too) and the seed's first-order iterate
sin(beta)/beta. The reference for finite a is the integral equation extrapolated to 3200 modes
(tolerance 1e-6) and, side by side, the calibrated FEM on a finer mesh. Then the time of a
20-point linearity curve, uniform and grid field.

Further tables:
- buttons (flush r_e/R = 0.05, 0.1, 0.2 and protruding l_e/R = 0.05, 0.1 at r_e/R = 0.1): the
  integral equation (flush only), the FEM at the default and a finer mesh, the uniform-density first
  order, and the small-button limit 1 - (r_e/R)^2/6;
- independent checks of the integral equation at 1e-4: (a) a/R -> inf: S(a) on a/R = 4, 8, 16
  (liner ends 8 R beyond), fitted by S_inf + c/a + d/a^2, against the exact pi/(2K(sin beta));
  (b) Richardson extrapolation of the uncalibrated FEM over three meshes (order fitted) against
  the integral equation; (c) the integral equation's error estimate against its 1e-6 reference;
- a grid field varying across and along the pipe: the integral equation against the FEM on refined
  meshes, and their times;
- a field file job: a field varying along z given as ``options.magnetic_field_file`` (a CSV of n x n x 2n
  rows, 200 k and 2 M), the job (solve and artifacts) in a fresh process per size and code: CPU s, peak RSS
  (the process's, the file's text and its parse included) and S; with ``--before DIR`` the same job on
  the plantsolve checkout in DIR (e.g. ``git archive main`` extracted) in the same run, and the largest
  relative difference of any reported number. Only this table:

    python bench/flowmeter.py --field-file-job [--before DIR] [--sides 46 100]
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# a --one-job child given --code DIR loads the checkout in DIR: chosen here, before anything of plantsolve is imported
ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, sys.argv[sys.argv.index("--code") + 1] if "--code" in sys.argv else str(ROOT))

from plantsolve.schemas.flowmeter import FlowmeterRequest  # noqa: E402
from plantsolve.solvers.base import no_progress  # noqa: E402
from plantsolve.solvers.flowmeter.solve import solve  # noqa: E402
from plantsolve.solvers.flowmeter.synthetic import exact_full_length, grid_field, meter  # noqa: E402


def run(beta: float, a: float | None, method: str, tolerance: float = 1e-3, reynolds=None, field=None):
    body = meter(radius=1.0, units="m", half_angle=beta, half_length=a, liner_length=6.0, method=method,
                 tolerance=tolerance, velocity={"type": "uniform", "mean": 1.0}, reynolds=reynolds)
    if field is not None:
        body["magnetic_field"] = field
    t0 = time.perf_counter()
    result = solve(FlowmeterRequest.model_validate(body), no_progress).result
    return result, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--field-file-job", action="store_true", help="only the field file job table")
    parser.add_argument("--before", metavar="DIR", help="the field file job also on the plantsolve checkout in DIR")
    parser.add_argument("--sides", type=int, nargs="+", default=[46, 100],
                        help="field file grids n x n x 2n (46: 194,672 rows; 100: 2,000,000)")
    parser.add_argument("--one-job", nargs=2, metavar=("FILE", "OUT"), help=argparse.SUPPRESS)  # in this process
    parser.add_argument("--code", help=argparse.SUPPRESS)  # the checkout a --one-job child imports
    args = parser.parse_args()
    if args.one_job:
        one_field_file_job(*args.one_job)
        return
    if args.field_file_job:
        field_file_job(args.sides, args.before)
        return
    reference_tolerance = 4.4e-4 if args.quick else 2.5e-4  # mesh sizes 0.08 and 0.06 R
    print(f"{'beta':>5} {'a/R':>6} | {'method':<15} {'S':>9} {'|err|':>9} {'est.':>9} {'s':>6}")
    for beta in (5.0, 22.5, 45.0):
        for a in (0.1, np.pi / 10, 1.0, None):
            label = "inf" if a is None else f"{a:.3f}"
            rows = []
            if a is None:
                reference = exact_full_length(beta)
                r, t = run(beta, None, "auto")
                rows.append(("closed form", r, t))
                r, t = run(beta, None, "fem")
                rows.append(("fem", r, t))
            else:
                ref, _ = run(beta, a, "integral_equation", 1e-6)
                reference = ref.sensitivity
                fine, _ = run(beta, a, "fem", reference_tolerance)
                r, t = run(beta, a, "integral_equation")
                rows.append(("integral eq.", r, t))
                r, t = run(beta, a, "fem")
                rows.append(("fem", r, t))
            r, t = run(beta, a, "first_order")
            rows.append(("first order", r, t))
            for name, r, t in rows:
                print(f"{beta:5.1f} {label:>6} | {name:<15} {r.sensitivity:9.6f} {abs(r.sensitivity - reference):9.2e} "
                      f"{r.error_estimate:9.2e} {t:6.2f}")
                if name == "fem":
                    raw = r.report.details["uncalibrated_sensitivity"]
                    print(f"{beta:5.1f} {label:>6} | {'fem uncalibr.':<15} {raw:9.6f} {abs(raw - reference):9.2e}")
            print(f"{'':5} {'':>6} | {'reference':<15} {reference:9.6f}"
                  + ("" if a is None else f"   (fine FEM {fine.sensitivity:.6f}, differs by {abs(fine.sensitivity - reference):.1e})"))
    buttons(args.quick)
    independent_checks(args.quick)
    grid_fields(args.quick)
    reynolds = list(np.logspace(2.5, 6.5, 20))
    # a magnet whose field is strongest at the centre and falls off towards the wall and the liner ends
    grid = grid_field(1.0, 6.0, lambda x, y, z: 0.0 * x,
                      lambda x, y, z: 0.01 * (1 - 0.15 * (x * x + y * y)) * np.exp(-(z / 1.5) ** 2), nx=21, nz=25)
    for a, method, field in ((None, "auto", None), (np.pi / 10, "integral_equation", None), (np.pi / 10, "fem", None),
                             (None, "auto", grid), (np.pi / 10, "integral_equation", grid), (np.pi / 10, "fem", grid)):
        r, t = run(22.5, a, method, reynolds=reynolds, field=field)
        spread = max(p.sensitivity for p in r.linearity) - min(p.sensitivity for p in r.linearity)
        print(f"linearity, 20 Reynolds numbers, beta 22.5, a/R {'inf' if a is None else 'pi/10'}, "
              f"{'grid' if field else 'uniform'} field ({r.method}): {t:.2f} s, S {r.linearity[0].sensitivity:.5f} "
              f"(Re {reynolds[0]:.0f}) .. {r.linearity[-1].sensitivity:.5f} (Re {reynolds[-1]:.0f}), spread {spread:.1e}, "
              f"ideal-meter residual {r.ideal_meter_residual:.3f}")


def run_button(r_e: float, l_e: float, method: str, tolerance: float = 1e-3):
    body = meter(radius=1.0, units="m", shape="button", button_radius=r_e, protrusion=l_e, liner_length=6.0,
                 method=method, tolerance=tolerance, velocity={"type": "uniform", "mean": 1.0})
    t0 = time.perf_counter()
    result = solve(FlowmeterRequest.model_validate(body), no_progress).result
    return result, time.perf_counter() - t0


def buttons(quick: bool) -> None:
    fine_tolerance = 4.4e-4 if quick else 2.5e-4
    print()
    print("buttons (L/R = 6, uniform B and flow); S (error estimate, seconds)")
    print(f"{'r_e/R':>6} {'l_e/R':>6} | {'integral eq.':>30} | {'fem':>30} | {'finer fem':>30} | {'1st order':>9} | {'1 - r^2/6':>9}")
    for r_e, l_e in ((0.05, 0.0), (0.1, 0.0), (0.2, 0.0), (0.1, 0.05), (0.1, 0.1)):
        cells = []
        if l_e == 0:
            r, t = run_button(r_e, 0.0, "integral_equation")
            cells.append(f"{r.sensitivity:.6f} ({r.error_estimate:.1e}, {t:5.2f})")
        else:
            cells.append("— (protruding: FEM only)")
        for tolerance in (1e-3, fine_tolerance):
            r, t = run_button(r_e, l_e, "fem", tolerance)
            cells.append(f"{r.sensitivity:.6f} ({r.error_estimate:.1e}, {t:5.2f})")
        first = r.sensitivity_first_order
        print(f"{r_e:6.3f} {l_e:6.3f} | {cells[0]:>30} | {cells[1]:>30} | {cells[2]:>30} | {first:9.6f} | {1 - r_e**2 / 6:9.6f}")


def independent_checks(quick: bool) -> None:
    from plantsolve.solvers.flowmeter import fem, integral_equation

    print()
    print("independent check (a): a/R -> inf by the integral equation (L/2 = a + 8R), fit S_inf + c/a + d/a^2")
    print(f"{'beta':>5} | {'S(4)':>9} {'S(8)':>9} {'S(16)':>9} | {'S_inf':>9} {'exact':>9} {'|diff|':>8} | {'s':>5}")
    lengths = np.array([4.0, 8.0, 16.0])
    for beta in (5.0, 22.5, 45.0):
        t0 = time.perf_counter()
        values = [integral_equation.solve_patch(np.radians(beta), a, a + 8.0, 1e-6).sensitivity for a in lengths]
        fit = np.linalg.solve(np.column_stack([np.ones(3), 1 / lengths, 1 / lengths**2]), values)
        exact = exact_full_length(beta)
        print(f"{beta:5.1f} | {values[0]:9.6f} {values[1]:9.6f} {values[2]:9.6f} | {fit[0]:9.6f} {exact:9.6f} "
              f"{abs(fit[0] - exact):8.1e} | {time.perf_counter() - t0:5.2f}")
    print()
    print("independent check (b): the uncalibrated FEM (L/R = 6) on three meshes, Richardson-extrapolated from the two")
    print("finest with the order 1 of the square-root edge singularity (energy error O(h^(2 * 1/2))); the order fitted on")
    print("all three is shown too (far from 1 where the coarsest mesh is not yet asymptotic)")
    sizes = (0.18, 0.12, 0.08) if quick else (0.12, 0.08, 0.06)
    print(f"{'beta':>5} {'a/R':>6} | " + " ".join(f"{'h=' + str(h):>9}" for h in sizes)
          + f" | {'extrap.':>9} {'fit p':>5} | {'IE 1e-6':>9} {'|diff|':>8} | {'s':>5}")
    for beta, a in ((5.0, 0.1), (22.5, np.pi / 10), (45.0, np.pi / 10)):
        t0 = time.perf_counter()
        values = [fem.solve_patch(np.radians(beta), a, 3.0, h=h).sensitivity for h in sizes]
        h1, h2, h3 = sizes
        extrapolated = values[2] + (values[2] - values[1]) * h3 / (h2 - h3)
        ratio = (values[1] - values[0]) / (values[2] - values[1])
        fitted = float("nan")
        if ratio > 0:  # S_h = S + c h^p: (h1^p - h2^p) / (h2^p - h3^p) = ratio, by bisection
            lo, hi = 0.05, 6.0
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                if (h1**mid - h2**mid) / (h2**mid - h3**mid) < ratio:
                    lo = mid
                else:
                    hi = mid
            fitted = 0.5 * (lo + hi)
        reference = integral_equation.solve_patch(np.radians(beta), a, 3.0, 1e-6).sensitivity
        print(f"{beta:5.1f} {a:6.3f} | " + " ".join(f"{v:9.6f}" for v in values)
              + f" | {extrapolated:9.6f} {fitted:5.2f} | {reference:9.6f} {abs(extrapolated - reference):8.1e} | "
              f"{time.perf_counter() - t0:5.2f}")
    print()
    print("check (c): the integral equation's error estimate (default tolerance 1e-3) against its 1e-6 reference")
    print(f"{'beta':>5} {'a/R':>6} | {'S':>9} {'est.':>8} {'|S - ref|':>9} | {'honest':>6}")
    for beta, a in ((5.0, 0.1), (22.5, np.pi / 10), (22.5, 1.0), (45.0, 0.1), (45.0, np.pi / 10)):
        default = integral_equation.solve_patch(np.radians(beta), a, 3.0, 1e-3)
        reference = integral_equation.solve_patch(np.radians(beta), a, 3.0, 1e-6).sensitivity
        gap = abs(default.sensitivity - reference)
        print(f"{beta:5.1f} {a:6.3f} | {default.sensitivity:9.6f} {default.error_estimate:8.1e} {gap:9.1e} | "
              f"{'yes' if default.error_estimate >= gap else 'NO':>6}")


def grid_fields(quick: bool) -> None:
    from plantsolve.solvers.flowmeter.synthetic import grid_field

    print()
    print("grid field B_y = B0 (1 + 0.2 x + 0.1 y) exp(-(z/1.5R)^2), B_x = 0.3 B0 x y exp(-(z/1.5R)^2) (21 x 21 x 25 grid, L/R = 6):")
    print("the integral equation against the FEM on refined meshes; S (error estimate, seconds)")
    field = grid_field(1.0, 6.0, lambda x, y, z: 0.3 * 0.01 * x * y * np.exp(-(z / 1.5) ** 2),
                       lambda x, y, z: 0.01 * (1 + 0.2 * x + 0.1 * y) * np.exp(-(z / 1.5) ** 2), nx=21, nz=25)
    tolerances = (4e-3, 1e-3) if quick else (4e-3, 1e-3, 2.5e-4)
    print(f"{'electrodes':<26} | {'integral eq.':>28} | " + " | ".join(f"{'fem tol ' + format(t, '.1e'):>28}" for t in tolerances))
    for label, extra in (("patch 22.5 deg, a/R pi/10", {"half_angle": 22.5, "half_length": np.pi / 10}),
                         ("patch 45 deg, a/R 1", {"half_angle": 45.0, "half_length": 1.0}),
                         ("flush button r_e/R 0.2", {"shape": "button", "button_radius": 0.2})):
        cells = []
        for method, tolerance in (("auto", 1e-3), *(("fem", t) for t in tolerances)):
            body = meter(radius=1.0, units="m", liner_length=6.0, method=method, tolerance=tolerance,
                         velocity={"type": "uniform", "mean": 1.0}, **extra)
            body["magnetic_field"] = field
            t0 = time.perf_counter()
            r = solve(FlowmeterRequest.model_validate(body), no_progress).result
            cells.append(f"{r.sensitivity:.6f} ({r.error_estimate:.1e}, {time.perf_counter() - t0:5.2f})")
        print(f"{label:<26} | " + " | ".join(f"{c:>28}" for c in cells))


def field_file_text(n: int) -> str:
    """A CSV field file of n x n x 2n rows over a 100 mm pipe's section and +-200 mm along it (liner +-150 mm):
    B_y falls off along z and varies across, B_x varies across; mm and mT, short numbers (2 M rows stay within
    the schema's 50 MB)."""
    x = np.round(np.linspace(-99, 99, n), 1)
    z = np.round(np.linspace(-199, 199, 2 * n), 1)
    gx, gy, gz = np.meshgrid(x, x, z, indexing="ij")
    decay = np.exp(-(gz / 75.0) ** 2)
    by = (10.0 * (1 + 0.002 * gx + 0.001 * gy) * decay).ravel()
    bx = (0.3 * 0.0004 * gx * gy * decay).ravel()
    lines = [f"{a:g},{b:g},{c:g},{d:.2g},{e:.4g}" for a, b, c, d, e in zip(gx.ravel(), gy.ravel(), gz.ravel(), bx, by)]
    return "x [mm],y [mm],z [mm],Bx [mT],By [mT]\n" + "\n".join(lines) + "\n"


def one_field_file_job(path: str, out: str) -> None:
    """The job on the field file at ``path`` in this (fresh) process: solve and artifacts, as the worker runs
    them; CPU s, peak RSS, the checkout it ran and the result's JSON written to ``out``."""
    import plantsolve
    from plantsolve.schemas.flowmeter import FlowmeterRequest
    from plantsolve.solvers.base import validated
    from plantsolve.solvers.flowmeter.artifacts import render_artifacts
    from plantsolve.solvers.flowmeter.solve import solve

    request = validated(FlowmeterRequest, {
        "units": "mm", "pipe": {"radius": 50.0, "liner_length": 300.0},
        "electrodes": {"shape": "patch", "half_angle": 22.5, "half_length": 20.0},
        "velocity": {"type": "uniform", "mean": 1.0}, "options": {"magnetic_field_file": Path(path).read_text()}})
    before = resource.getrusage(resource.RUSAGE_SELF)
    solved = solve(request, no_progress)
    list(render_artifacts(request, solved))
    after = resource.getrusage(resource.RUSAGE_SELF)
    Path(out).write_text(json.dumps({
        "cpu_s": after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime,
        "peak_rss_mb": after.ru_maxrss / 1024, "code": str(Path(plantsolve.__file__).resolve().parents[1]),
        "result": solved.result.model_dump(mode="json")}))


def numbers(value, path="") -> dict[str, float]:
    """Every number in a result's JSON, keyed by its path."""
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in numbers(item, f"{path}.{key}").items()}
    if isinstance(value, list):
        return {k: v for i, item in enumerate(value) for k, v in numbers(item, f"{path}[{i}]").items()}
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return {path: float(value)}
    return {}


def largest_relative_difference(a: dict, b: dict) -> tuple[float, str]:
    """The largest |a - b| / max(|a|, |b|) over the numbers both results report (and the path of it); a number
    only one of them reports counts as inf."""
    na, nb = numbers(a), numbers(b)
    worst, where = 0.0, ""
    for key in na.keys() | nb.keys():
        if key not in na or key not in nb:
            gap = float("inf")
        else:
            scale = max(abs(na[key]), abs(nb[key]))
            gap = 0.0 if na[key] == nb[key] else abs(na[key] - nb[key]) / scale
        if gap > worst:
            worst, where = gap, key
    return worst, where


def field_file_job(sides: list[int], before: str | None) -> None:
    print()
    print("field file job (options.magnetic_field_file, n x n x 2n rows, patch 22.5 deg, a 20 mm, R 50 mm, liner "
          "300 mm): solve and artifacts in a fresh process each; peak RSS of the process (file text and parse included)")
    print(f"{'rows':>10} {'code':<8} {'CPU s':>7} {'peak RSS MB':>12} {'S':>18} {'max rel. diff':>14}")
    codes = [("this", None)] + ([("before", before)] if before else [])
    with tempfile.TemporaryDirectory() as folder:
        for n in sides:
            path = Path(folder) / f"field_{n}.csv"
            text = field_file_text(n)
            path.write_text(text)
            rows = text.count("\n") - 1
            del text
            results = {}
            for label, code in codes:
                out = Path(folder) / f"{label}_{n}.json"
                command = [sys.executable, __file__, "--one-job", str(path), str(out)] + (["--code", code] if code else [])
                subprocess.run(command, check=True)
                results[label] = json.loads(out.read_text())
                ran = Path(results[label]["code"])
                assert ran == Path(code or ROOT).resolve(), f"{label} ran the code in {ran}"
            for label, _ in codes:
                r = results[label]
                gap = ""
                if label != "this":
                    worst, where = largest_relative_difference(results["this"]["result"], r["result"])
                    gap = f"{worst:.1e}" + (f" ({where})" if worst else "")
                print(f"{rows:>10} {label:<8} {r['cpu_s']:>7.2f} {r['peak_rss_mb']:>12.0f} "
                      f"{r['result']['sensitivity']:>18.15f} {gap:>14}")


if __name__ == "__main__":
    main()
