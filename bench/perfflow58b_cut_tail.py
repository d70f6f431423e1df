"""Peak memory and CPU of looking at a field file's end for a cut last value: the whole file split (perfflow58) against
its last 200 kB (perfflow58b), on a 1.6 M-row COMSOL-like export. Prints a table; least of 3, interleaved."""

from __future__ import annotations

import time
import tracemalloc

from plantsolve.solvers.cut_number import last_lines
from plantsolve.solvers.flowmeter.field_file import cut_last_value

ROWS = 1_600_000
TEXT = "x y z Bx By\n" + "\n".join(f"{k % 100} {k // 100 % 100} {k // 10000} 0.0009231279005 0.00{k:09d}"
                                   for k in range(ROWS)) + "\n9 9 9 9 0.0016"


def whole_split(text: str) -> list[str]:
    return [line for line in text.rstrip(" \t\x00\x1a").splitlines()[-1001:] if line.strip()]


def measure(tail) -> tuple[float, float]:
    tracemalloc.start()
    t0 = time.process_time()
    tail(TEXT)
    cpu = time.process_time() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return cpu, peak / 1e6


best = {"whole splitlines (before)": [], "last 200 kB (after)": []}
for _ in range(3):
    for name, tail in (("whole splitlines (before)", whole_split),
                       ("last 200 kB (after)", lambda text: last_lines(text, 1001))):
        best[name].append(measure(tail))
print(f"file: {ROWS:,} rows, {len(TEXT) / 1e6:.0f} MB; cut told: {cut_last_value(TEXT, None, 4)!r}")
print(f"{'tail taken by':28} {'CPU s':>8} {'peak MB':>9}")
for name, runs in best.items():
    print(f"{name:28} {min(r[0] for r in runs):8.3f} {min(r[1] for r in runs):9.1f}")
