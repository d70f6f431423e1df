"""Users' mistakes judged in this tree and reference checkouts, side by side: each tree's answers come from a child
process run in that tree (its plantsolve and tests first on ``sys.path``; the inputs and the judging are this
bench's), printing one JSON line per case, and the table prints every case's answer per tree.

Two ways to write a child: a CHILD script (``child_script``, ``compare``: one line per case with kind, case,
verdict, code, said; bench/trust51t_mistakes.py, trust52m, trust53r), or the bench file itself run with ``--child``
(``arguments``, ``trees``, ``markdown``, ``counts``: the bench's own row fields and columns;
bench/trust57_mistakes.py, trust58_* and trust59_*)."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

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


def tree_rows(tree: str | Path, argv: list[str]) -> list[dict]:
    """The JSON lines of ``python argv...`` run in ``tree`` (its plantsolve, its tests' settings)."""
    done = subprocess.run([sys.executable, *argv], cwd=tree, capture_output=True, text=True, check=False,
                          env={**os.environ, "PYTHONPATH": str(tree), "PYTHONDONTWRITEBYTECODE": "1"})
    if done.returncode:
        sys.stderr.write(done.stderr[-3000:])
    return [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]


def compare(description: str, child: str, root: str, bench_dir: str, width: int = 50) -> None:
    """The command line (``--ref DIR``, ``--verbose``) and the table: this tree beside the reference checkout."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--ref", default=None, help="a checkout to measure beside this tree (main's worktree)")
    parser.add_argument("--verbose", action="store_true", help="print what each answer said")
    args = parser.parse_args()
    trees = ([("ref", args.ref)] if args.ref else []) + [("this", root)]
    t0 = time.time()
    results = {label: tree_rows(tree, ["-c", child, tree, bench_dir]) for label, tree in trees}
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


def by_mistake(row: dict) -> tuple[str, str]:
    return row["kind"], row["mistake"]


def by_case(row: dict) -> str:
    return row["case"]


def arguments(doc: str, kinds: dict | None = None, cases: bool = True) -> argparse.ArgumentParser:
    """A ``--child`` bench's command line (``--ref``, ``--ref-rows``, ``--rows``, ``--child``, and ``--kinds`` of
    ``kinds``, ``--cases`` when asked): the bench adds its own arguments to it."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    if kinds is not None:
        parser.add_argument("--kinds", nargs="*", default=list(kinds))
    if cases:
        parser.add_argument("--cases", nargs="*", default=None, help="only the cases whose names hold one of these")
    parser.add_argument("--ref", nargs="+", action="extend", default=[],
                        help="checkouts to run beside this tree (main's worktree, the branch's start), a column each")
    parser.add_argument("--ref-rows", default=None, help="a reference's rows saved by --child, a column")
    parser.add_argument("--rows", default=None, help="this tree's rows saved by --child")
    parser.add_argument("--child", action="store_true", help="print this tree's rows as JSON lines, no table")
    return parser


def saved_rows(path: str, key: Callable, kinds: list[str] | None) -> list[dict]:
    """Rows saved from --child runs, of ``kinds``, the last of each case counting (a case run again after a change)."""
    rows = {}
    for line in Path(path).read_text().splitlines():
        if line.startswith("{"):
            row = json.loads(line)
            if kinds is None or row["kind"] in kinds:
                rows[key(row)] = row
    return list(rows.values())


def trees(args: argparse.Namespace, script: str, key: Callable = by_mistake, mine: str = "after",
          before: str | None = "before") -> list[tuple[str, list[dict]]]:
    """Each reference's rows (a ``--ref`` tree's from ``script --child`` run there, or ``--ref-rows``) labelled
    ``before`` when there is one, by folder or file name when several (or ``before`` is None); last this tree's
    (``--rows``, or run here) labelled ``mine``."""
    kinds = getattr(args, "kinds", None)
    argv = [str(Path(script).resolve()), "--child", *(["--kinds", *kinds] if kinds is not None else []),
            *(["--cases", *args.cases] if getattr(args, "cases", None) else [])]
    refs = [(Path(ref).name, lambda ref=ref: tree_rows(ref, argv)) for ref in args.ref]
    if args.ref_rows:
        refs.append((Path(args.ref_rows).name, lambda: saved_rows(args.ref_rows, key, kinds)))
    if before and len(refs) == 1:
        refs = [(before, refs[0][1])]
    this = saved_rows(args.rows, key, kinds) if args.rows else tree_rows(ROOT, argv)
    return [(label, rows()) for label, rows in refs] + [(mine, this)]


def case_lines(groups) -> None:
    """A child's rows where each of ``groups`` yields (case, what this tree says): a JSON line each."""
    for group in groups:
        for case, said in group():
            print(json.dumps({"case": case, "said": said}), flush=True)


def excerpt(said, width: int) -> str:
    """What an answer said, on one line of a markdown table."""
    return str(said).replace("|", "/").replace("\n", " ")[:width]


def markdown(trees: list[tuple[str, list[dict]]], columns: list[str], cells: Callable[[dict], list[str]],
             ref_cell: Callable[[dict], str], at: int = 2, key: Callable = by_mistake) -> None:
    """A row per case of this tree (the last of ``trees``): its ``cells`` under ``columns``, and at column ``at`` a
    column per reference tree, its ``ref_cell`` of the same case (``-`` where it has none)."""
    *refs, (_, mine) = trees
    found = [{key(row): row for row in rows} for _, rows in refs]
    heads = columns[:at] + [label for label, _ in refs] + columns[at:]
    print("| " + " | ".join(heads) + " |")
    print("|" + " --- |" * len(heads))
    for row in mine:
        own = cells(row)
        print("| " + " | ".join(own[:at] + [ref_cell(f[key(row)]) if key(row) in f else "-" for f in found]
                                + own[at:]) + " |")


def counts(trees: list[tuple[str, list[dict]]], summary: Callable[[list[dict]], str], started: float) -> None:
    """Each tree's ``summary`` of its rows (where it has any), then the wall time since ``started``."""
    for label, rows in trees:
        if rows:
            print(f"{label}: {summary(rows)}")
    print(f"wall {time.time() - started:.0f} s")
