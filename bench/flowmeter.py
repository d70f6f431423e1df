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
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plantsolve.schemas.flowmeter import FlowmeterRequest  # noqa: E402
from plantsolve.solvers.base import no_progress  # noqa: E402
from plantsolve.solvers.flowmeter import solve  # noqa: E402
from plantsolve.solvers.flowmeter.synthetic import exact_full_length, grid_field, meter  # noqa: E402


def run(beta: float, a: float | None, method: str, tolerance: float = 1e-3, reynolds=None, field=None):
    body = meter(radius=1.0, units="m", half_angle=beta, half_length=a, liner_length=6.0, method=method,
                 tolerance=tolerance, velocity={"type": "uniform", "mean": 1.0}, reynolds=reynolds)
    if field is not None:
        body["magnetic_field"] = field
    t0 = time.perf_counter()
    result = solve(FlowmeterRequest.model_validate(body), no_progress)
    return result, time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
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
    reynolds = list(np.logspace(2.5, 6.5, 20))
    # a magnet whose field is strongest at the centre and falls off towards the wall and the liner ends
    grid = grid_field(1.0, 6.0, lambda x, y, z: 0.0 * x,
                      lambda x, y, z: 0.01 * (1 - 0.15 * (x * x + y * y)) * np.exp(-(z / 1.5) ** 2), nx=21, nz=25)
    for a, method, field in ((None, "auto", None), (np.pi / 10, "integral_equation", None), (np.pi / 10, "fem", None),
                             (None, "auto", grid), (np.pi / 10, "fem", grid)):
        r, t = run(22.5, a, method, reynolds=reynolds, field=field)
        spread = max(p.sensitivity for p in r.linearity) - min(p.sensitivity for p in r.linearity)
        print(f"linearity, 20 Reynolds numbers, beta 22.5, a/R {'inf' if a is None else 'pi/10'}, "
              f"{'grid' if field else 'uniform'} field ({r.method}): {t:.2f} s, S {r.linearity[0].sensitivity:.5f} "
              f"(Re {reynolds[0]:.0f}) .. {r.linearity[-1].sensitivity:.5f} (Re {reynolds[-1]:.0f}), spread {spread:.1e}, "
              f"ideal-meter residual {r.ideal_meter_residual:.3f}")


if __name__ == "__main__":
    main()
