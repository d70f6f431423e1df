"""What the cut-IFC aggregation scan (polyhedra/ifc_cut.py) costs on text that is all IfcRelAggregates instances left
open, one a line (no ';' anywhere: the worst case for a scan that re-reads the rest of the text from every line
start), and on a well-formed file of as many closed relations, in CPU seconds, best of three.

Each tree (this checkout, and ``--before DIR``'s in the same run) runs in a process of its own:

    python bench/fix59p_ifc_aggregation_scan.py [--before /tmp/integ]   # DIR: e.g. `git archive integ` extracted
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
LINES = (2000, 4000, 8000, 16000)


class _Model:
    """Instances #1..#10 held, the rest past the cut; every one a spatial element."""

    def by_id(self, number: int) -> _Model:
        if number > 10:
            raise RuntimeError("no instance")
        return self

    def is_a(self, kind: str) -> bool:
        return True


def measure() -> dict:
    """In the tree on sys.path: best-of-three CPU seconds and the count found, per case and size."""
    from plantsolve.solvers.polyhedra.ifc_cut import aggregated_past_cut

    out = {}
    for n in LINES:
        for case, text in (("open", "\n".join(f"#{k}=IFCRELAGGREGATES('x',$,$,$,#2,(#3" for k in range(1, n))),
                           ("closed", "DATA;\n" + "\n".join(f"#{k}=IFCRELAGGREGATES('x',$,$,$,#2,(#{k + 10}));"
                                                           for k in range(1, n)))):
            best, found = float("inf"), None
            for _ in range(3 if n <= 4000 else 1):  # the quadratic scan takes tens of seconds at 16,000 lines
                start = time.process_time()
                found = aggregated_past_cut(text, _Model())
                best = min(best, time.process_time() - start)
            out[f"{case} {n}"] = (best, found)
    return out


def run(tree: Path) -> dict:
    done = subprocess.run([sys.executable, __file__, "--measure"], capture_output=True, text=True, check=True,
                          env={**os.environ, "PYTHONPATH": str(tree)}, cwd=tree)
    return json.loads(done.stdout)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--before", type=Path)
    parser.add_argument("--measure", action="store_true")
    args = parser.parse_args()
    if args.measure:
        print(json.dumps(measure()))
        return
    after = run(HERE)
    before = run(args.before) if args.before else {}
    print(f"{'case, lines':>16} | {'before s':>9} {'found':>6} | {'after s':>9} {'found':>6}")
    for key, (seconds, found) in after.items():
        was = before.get(key)
        print(f"{key:>16} | " + (f"{was[0]:9.3f} {was[1]:6d}" if was else f"{'':9} {'':6}")
              + f" | {seconds:9.3f} {found:6d}")


if __name__ == "__main__":
    main()
