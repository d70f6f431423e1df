"""Users' mistakes judged in two trees, side by side: each tree's answers come from a child process (a bench's
CHILD script run in that tree, printing one JSON line per case: kind, case, verdict, code, said), and the table
prints every case's verdict per tree and a count of each verdict. Shared by bench/trust51t_mistakes.py,
bench/trust52m_mistakes.py and bench/trust53r_mistakes.py."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

VERDICTS = ("right", "WRONG", "REFUSED", "warned", "500")
BENCH = os.path.dirname(os.path.abspath(__file__))  # the benches' folder, first on a bench's sys.path
ROOT = os.path.dirname(BENCH)  # this tree

# imported by each mistakes bench before numpy: one BLAS thread, as the job processes run
for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

# the start of every child: the tree's code and the bench's module on sys.path, the tree's app, and one submission
# (a file with its options, or a JSON body when the name is None) waited for to its end
_CHILD_HEAD = r"""
import json, os, sys, tempfile, pathlib, time
sys.path.insert(0, sys.argv[1])
sys.path.insert(1, sys.argv[2])
import logging
logging.disable(logging.WARNING)
from fastapi.testclient import TestClient
from plantsolve.app.main import create_app
from tests.conftest import service_settings, wait_for
import MODULE as m
import plantsolve
assert plantsolve.__file__.startswith(sys.argv[1]), plantsolve.__file__

def submit(c, kind, name, data, options, limit=300):
    if name is None:  # a JSON body, no file
        r = c.post(f"/v1/{kind}/jobs", content=data, headers={"Content-Type": "application/json"})
    else:
        files = {"file": (name, data)}
        form = {"options": json.dumps(options)} if options else {}
        r = c.post(f"/v1/{kind}/jobs", files=files, data=form)
    if r.status_code != 202:
        doc = r.json() if r.headers.get("content-type", "").endswith("json") else {}
        errs = doc.get("errors") or doc.get("invalid_params") or []
        return (r.status_code, json.dumps(errs or doc.get("detail"))[:limit], None), None
    view = wait_for(c, r.json()["id"], timeout=300)
    res = c.get(f"/v1/jobs/{r.json()['id']}/result").json() if view["status"] == "succeeded" else None
    return (r.status_code, None, view), res

"""


def child_script(module: str, body: str) -> str:
    """A child's script: the common start, importing ``module`` (the bench) as ``m``, then the bench's ``body``."""
    return _CHILD_HEAD.replace("MODULE", module) + body


def answers(tree: str, child: str, bench_dir: str) -> list[dict]:
    """The child's verdict lines, run in ``tree`` (its plantsolve, its tests' settings)."""
    done = subprocess.run([sys.executable, "-c", child, tree, bench_dir], cwd=tree, capture_output=True, text=True,
                          env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}, check=False)
    rows = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    if done.returncode:
        sys.stderr.write(done.stderr[-3000:])
    return rows


def compare(description: str, child: str, root: str, bench_dir: str, width: int = 50) -> None:
    """The command line (``--ref DIR``, ``--verbose``) and the table: this tree beside the reference checkout."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--ref", default=None, help="a checkout to measure beside this tree (main's worktree)")
    parser.add_argument("--verbose", action="store_true", help="print what each answer said")
    args = parser.parse_args()
    trees = ([("ref", args.ref)] if args.ref else []) + [("this", root)]
    t0 = time.time()
    results = {label: answers(tree, child, bench_dir) for label, tree in trees}
    print(f"{'case':{width + 6}s} " + " ".join(f"{label:>8s}" for label, _ in trees))
    for i, row in enumerate(results["this"]):
        cells = [results[label][i]["verdict"] if i < len(results[label]) else "-" for label, _ in trees]
        print(f"{row['kind'][:5]} {row['case'][:width]:{width}s} " + " ".join(f"{c:>8s}" for c in cells))
        if args.verbose:
            for label, _ in trees:
                if i < len(results[label]):
                    print(f"      {label}: {results[label][i]['code']} {results[label][i]['said'][:240]}")
    for label, _ in trees:
        rows = results[label]
        print(f"{label}: {len(rows)} cases, " + ", ".join(f"{v} {sum(r['verdict'] == v for r in rows)}"
                                                       for v in VERDICTS))
    print(f"wall {time.time() - t0:.0f} s")
