"""CPU seconds and peak RSS of reading the largest field file the schema takes.

    python bench/flowmeter_field_file.py            # 100 x 100 x 200 grid, 2,000,000 rows
    python bench/flowmeter_field_file.py --rows 20  # a smaller file: 20 x 20 x 40

Each case runs in a fresh process reading the file (peak RSS is per process): check_input of a CSV with a header
('x [mm],y [mm],z [mm],Bx [T],By [T]', plain rows) and of the same file with a comment line among its rows (read
line by line). Prints one table row per case: rows, MB, CPU s, peak RSS MB (the process's, the Python
interpreter and the imports included).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def field_file(n: int, comment: bool) -> str:
    x = np.linspace(-99, 99, n)
    z = np.linspace(-199, 199, 2 * n)
    gx, gy, gz = np.meshgrid(x, x, z, indexing="ij")
    by = 0.01 * (1 + 0.002 * gx)
    lines = [f"{a:g},{b:g},{c:g},0,{d:.6g}" for a, b, c, d in zip(gx.ravel(), gy.ravel(), gz.ravel(), by.ravel())]
    if comment:
        lines.insert(len(lines) // 2, "# the second half")
    return "x [mm],y [mm],z [mm],Bx [T],By [T]\n" + "\n".join(lines) + "\n"


def measure(path: str) -> dict:
    from plantsolve.schemas.flowmeter import FlowmeterRequest
    from plantsolve.solvers.base import validated
    from plantsolve.solvers.flowmeter.validation import check_input

    text = Path(path).read_text()
    request = validated(FlowmeterRequest, {
        "units": "mm", "pipe": {"radius": 50.0, "liner_length": 300.0},
        "electrodes": {"shape": "patch", "half_angle": 22.5, "half_length": 20.0},
        "velocity": {"type": "uniform", "mean": 1.0}, "options": {"magnetic_field_file": text}})
    before = resource.getrusage(resource.RUSAGE_SELF)
    check_input(request)
    after = resource.getrusage(resource.RUSAGE_SELF)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return {"rows": text.count("\n") - 1, "mb": len(text) / 1e6, "cpu_s": cpu, "peak_rss_mb": after.ru_maxrss / 1024}


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rows", type=int, default=100, help="points along x and y (z has twice as many)")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # the file to measure, in this process
    args = parser.parse_args()
    if args.one:
        print(json.dumps(measure(args.one)))
        return
    print(f"{'file':<10} {'rows':>10} {'MB':>6} {'CPU s':>7} {'peak RSS MB':>12}")
    with tempfile.TemporaryDirectory() as folder:
        for case in ("plain", "comment"):
            path = Path(folder) / f"{case}.csv"
            path.write_text(field_file(args.rows, case == "comment"))
            out = subprocess.run([sys.executable, __file__, "--one", str(path)], capture_output=True, text=True,
                                 check=True)
            r = json.loads(out.stdout)
            print(f"{case:<10} {r['rows']:>10} {r['mb']:>6.1f} {r['cpu_s']:>7.2f} {r['peak_rss_mb']:>12.0f}")


if __name__ == "__main__":
    main()
