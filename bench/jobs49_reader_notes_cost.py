"""What saying an alignment PCF's reader warnings again costs a job (``SolverSpec.reader_notes``, read by the runner
as soon as it has read the input, so that a failed or lost job's report keeps them): CPU seconds of the runner's
read (the upload parsed into a request) before (main: no notes) and after (the request parsed, then its notes said
again), beside the solve, per PCF fixture. Each figure is the best of ``--repeat`` runs (the machine is shared), the
reader's interpretation cache missed on each read (each run's text ends in its own count of blank lines: the cache is
keyed on the text); ``notes s`` is the notes said right after the read, as the runner does (the reader keeps its last
interpretations: a hit), ``cold s`` of a text the reader has not seen (the worst case).

    python bench/jobs49_reader_notes_cost.py [--repeat 5]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "bench"))

from alignment_pcf import inputs

from plantsolve.jobs.reader_notes import reader_warnings
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.kinds import KINDS


def cpu(function, repeat: int) -> tuple[float, object]:
    """The least CPU seconds of ``function(run)`` over ``repeat`` runs, and its last value."""
    best, value = float("inf"), None
    for run in range(repeat):
        start = time.process_time()
        value = function(run)
        best = min(best, time.process_time() - start)
    return best, value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    spec = KINDS["alignment"]
    print(f"{'file':34} {'read s (main)':>13} {'notes s':>8} {'read s (branch)':>15} {'cold s':>7} {'solve s':>8} "
          f"{'added/job':>9} {'warnings':>8}")
    for name, raw, _fixed, _methods in inputs():
        try:
            read, request = cpu(lambda run, raw=raw: spec.parse_upload(
                StoredInput.from_bytes("line.pcf", raw + b"\n" * (run + 1)), {}), args.repeat)
        except InputRejected as error:  # a file the reader refuses (422): no job runs it
            print(f"{name:34} refused: {type(error).__name__}")
            continue
        notes, said = cpu(lambda run, request=request: reader_warnings(request, spec), args.repeat)
        cold, _ = cpu(lambda run, request=request: reader_warnings(request.model_copy(
            update={"source_pcf": request.source_pcf + "\n" * (args.repeat + run + 1)}), spec), args.repeat)
        solve, _ = cpu(lambda run, request=request: spec.solve(request, lambda fraction, message="": None), 1)
        print(f"{name:34} {read:13.3f} {notes:8.3f} {read + notes:15.3f} {cold:7.3f} {solve:8.3f} "
              f"{notes / (read + solve):9.1%} {len(said):8d}")


if __name__ == "__main__":
    main()
