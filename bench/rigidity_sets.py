"""How much of an official LDraw set the rigidity solver joins: parts known, parts joined to nothing, pieces.

    python bench/rigidity_sets.py FOLDER [FOLDER ...]    # every .ldr / .mpd in the folders
    python bench/rigidity_sets.py FILE.mpd ...           # or the files themselves

Nothing is fetched: the models are read from what is named (the OMR sets of three.js' examples are
in ``tests/solvers/rigidity/omr/``). Per model:

- ``parts``: parts the file places; ``unknown``: not in the catalogue (left out of the analysis);
- ``floating``: known parts joined to nothing, and their share of the known parts (the target is
  at most 5 %);
- ``pieces``: connected pieces of the known parts (a set that is one build is one piece; held
  sub-builds such as a minifigure may stand apart), and ``held``: how many of the pieces the solver
  recognises as held sub-builds (``report.details.held_pieces``);
- ``dof`` of the whole model, joints found, CPU seconds of the solve;
- the part numbers of the floating parts (with counts).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload


def measure(path: Path) -> dict:
    request = parse_upload(StoredInput.from_bytes(path.name, path.read_bytes()), None)
    start = time.process_time()
    result = solve(request).result
    seconds = time.process_time() - start
    unknown = {u.id for u in result.unknown_parts}
    known = [p for p in request.parts if p.id not in unknown]
    joined = {b for j in result.joints for b in j.bodies}
    floating = [p for p in known if p.id not in joined]
    details = result.report.details
    return {"model": path.name, "parts": len(request.parts), "unknown": len(unknown), "known": len(known),
            "floating": len(floating), "pieces": details.get("connected_pieces"),
            "held": len(details.get("held_pieces") or []), "dof": result.dof, "joints": len(result.joints),
            "seconds": seconds, "floating_parts": Counter(p.part for p in floating)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("paths", nargs="+", type=Path, help="folders of .ldr/.mpd models, or model files")
    args = parser.parse_args(argv)
    files = []
    for path in args.paths:
        files.extend(sorted(p for p in path.iterdir() if p.suffix.lower() in (".ldr", ".mpd")) if path.is_dir()
                     else [path])
    print(f"{'model':38s} {'parts':>5s} {'unkn':>4s} {'floating':>12s} {'pieces':>6s} {'held':>4s} {'dof':>4s} "
          f"{'joints':>6s} {'cpu s':>6s}  floating parts")
    for path in files:
        row = measure(path)
        share = 100.0 * row["floating"] / row["known"] if row["known"] else 0.0
        names = ", ".join(f"{n} x{c}" if c > 1 else n for n, c in sorted(row["floating_parts"].items()))
        print(f"{row['model'][:38]:38s} {row['parts']:5d} {row['unknown']:4d} {row['floating']:4d} ({share:4.1f} %) "
              f"{row['pieces']:6d} {row['held']:4d} {row['dof']:4d} {row['joints']:6d} {row['seconds']:6.2f}  {names}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
