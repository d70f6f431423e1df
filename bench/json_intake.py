"""A large JSON submission's cost to the API process: a flowmeter request whose ``options.magnetic_field_file`` holds
a field file of 1.6 million rows (32 MB; the schema's 50 MB allows about two million rows of this spelling).

Each tree (this checkout, and ``--before DIR``'s in the same run) runs in a process of its own: the job service of a
private data dir takes the body (``JobService.take_json``: read, checked, stored) after a warm-up submission, and the
row says the API process's CPU seconds, the growth of its peak RSS, the wall seconds, and what it answered. On this
checkout a body above INLINE_INPUT_BYTES is read and checked by a bounded reading process (its CPU is not the API's).

    python bench/json_intake.py [--before /tmp/base] [--rows 1625151]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent

RUN = r'''
import gc, json, resource, sys, tempfile, time
from pathlib import Path
from plantsolve.app.settings import AppSettings
from plantsolve.jobs.context import ServiceContext
from plantsolve.jobs.errors import Unprocessable
from plantsolve.jobs.service import JobService

class Queue:
    def enqueue(self, *args): pass

body = Path(sys.argv[1]).read_bytes()
small = Path(sys.argv[2]).read_bytes()
ctx = ServiceContext.create(AppSettings(_env_file=None, data_dir=Path(tempfile.mkdtemp())), migrate=True)
service = JobService(ctx, Queue())
service.take_json("flowmeter", small, None)  # warm: imports, the reading processes' forkserver
gc.collect()
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
cpu, wall = time.process_time(), time.monotonic()
try:
    new = service.take_json("flowmeter", body, None)
    answer = f"taken ({new.fields['input_kind']})"
except Unprocessable as error:
    answer = f"422 {error.errors[0]['loc']}"
print(json.dumps({"cpu": time.process_time() - cpu, "wall": time.monotonic() - wall,
                  "rss": (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss) / 1024, "answer": answer}))
'''


def field_request(rows_wanted: int) -> bytes:
    """A patch meter whose field file is a rectilinear grid covering the pipe (radius 50 mm, liner 300 mm), B along
    +y: COMSOL's spreadsheet layout, integer coordinates in mm."""
    side = list(range(-60, 61))
    zs = list(range(-165, 166, 3))
    rows = ["% Length unit: mm", "% x y z mf.Bx (T) mf.By (T) mf.Bz (T)"]
    rows += [f"{x} {y} {z} 0 .01 0" for x in side for y in side for z in zs][:rows_wanted]
    return json.dumps({"units": "mm", "pipe": {"radius": 50.0, "liner_length": 300.0},
                       "electrodes": {"shape": "patch", "half_angle": 22.5, "half_length": 15.707963},
                       "options": {"magnetic_field_file": "\n".join(rows) + "\n"}}).encode()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, help="another checkout (e.g. main) run in the same way, first")
    parser.add_argument("--rows", type=int, default=121 * 121 * 111)
    args = parser.parse_args()
    folder = Path(os.environ.get("TMPDIR", "/tmp")) / f"json-intake-{os.getpid()}"
    folder.mkdir(parents=True, exist_ok=True)
    body, small = folder / "large.json", folder / "small.json"
    body.write_bytes(field_request(args.rows))
    small.write_bytes((HERE / "examples" / "flowmeter" / "meter.json").read_bytes())
    print(f"body: {body.stat().st_size / 1e6:.1f} MB, {args.rows} field rows")
    print(f"{'tree':<34} {'API CPU s':>10} {'API peak RSS +MB':>17} {'wall s':>8}  answer")
    for tree in ([args.before] if args.before else []) + [HERE]:
        env = {**os.environ, "PYTHONPATH": str(tree)}
        out = subprocess.run([sys.executable, "-c", RUN, str(body), str(small)], env=env, cwd=tree,
                             capture_output=True, text=True, check=True).stdout.strip().splitlines()[-1]
        row = json.loads(out)
        print(f"{str(tree):<34} {row['cpu']:>10.2f} {row['rss']:>17.0f} {row['wall']:>8.2f}  {row['answer']}")


if __name__ == "__main__":
    main()
