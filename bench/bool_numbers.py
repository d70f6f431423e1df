"""What refusing ``true`` as a number costs: each kind's largest kind of JSON body validated as the API validates it,
in this checkout and in ``--before DIR`` (main's worktree), in one run.

Two ways in: ``body`` is a JSON request body (``model_validate_json(..., strict=True)``, as ``jobs.intake.read_json``)
and ``upload`` is the same document as an uploaded .json file or a form's options (parsed, then ``model_validate`` in
lax mode, as ``solvers.base.validated``). Each row runs in a process of its own: the CPU seconds and the growth of
the peak RSS of the validation alone (the body read and, for an upload, parsed before), and what it answered. The
``+true`` rows hold one ``true`` as the last number of the large array: main reads it as 1.0 in an upload. With
``--repeat N`` each row is the least CPU and the largest RSS of N runs, the trees taking turns (a shared machine's
noise is some 15 %).

    python bench/bool_numbers.py [--before /work/wt/boolnum53-base] [--scale 1.0] [--repeat 3] [--kinds tube ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent

CHILD = r'''
import gc, json, resource, sys, time
from pathlib import Path
from pydantic import ValidationError
import plantsolve
from plantsolve.solvers.kinds import load_kinds
assert plantsolve.__file__.startswith(sys.argv[1]), plantsolve.__file__
kind, mode, path = sys.argv[2], sys.argv[3], Path(sys.argv[4])
model = load_kinds(())[kind].request_model
data = path.read_bytes()
document = json.loads(data) if mode == "upload" else None
gc.collect()
rss, cpu = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, time.process_time()
try:
    if mode == "body":
        model.model_validate_json(data, strict=True)
    else:
        model.model_validate(document)
    answer = "accepted"
except ValidationError as error:
    first = error.errors()[0]
    answer = f"422 {'.'.join(map(str, first['loc']))[-40:]} ({first['type']})"
print(json.dumps({"cpu": time.process_time() - cpu,
                  "rss": (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss) / 1024, "answer": answer}))
'''


def tube(n: int) -> dict:
    return {"units": "mm", "points": [[i * 0.01, (i % 997) * 0.5, -(i % 13) * 1.25] for i in range(n)]}


def polyhedra(n: int) -> dict:
    vertices = [[float(i % 1000), float(i // 1000), (i % 7) * 0.5] for i in range(n)]
    faces = [{"id": f"f{k}", "loops": [[3 * k, 3 * k + 1, 3 * k + 2]]} for k in range(min(n // 3, 10_000))]
    return {"units": "m", "vertices": vertices, "faces": faces}


def perfmap(n: int) -> dict:
    points = 10_000
    return {"setting_names": ["speed"], "positions": [
        {"setting": [0.5 + p / n], "flow": [10.0 + i * 0.001 for i in range(points)],
         "pressure": [2.0 - i * 1e-5 for i in range(points)], "efficiency": [0.8] * points}
        for p in range(max(n // (3 * points), 1))]}


def flowmeter(n: int) -> dict:
    side = max(round((n / 2) ** (1 / 3)), 2)
    axis = [-60.0 + 120.0 * i / (side - 1) for i in range(side)]
    return {"units": "mm", "pipe": {"radius": 50.0},
            "magnetic_field": {"type": "grid", "x": axis, "y": axis, "z": axis,
                               "bx": [0.0] * side ** 3, "by": [0.01] * side ** 3}}


def alignment(n: int) -> dict:
    pipes = n // 12
    components = [{"id": f"P{k}", "kind": "pipe", "ports": [
        {"position": [1000.0 * k, 0.0, 0.0], "direction": [-1.0, 0.0, 0.0]},
        {"position": [1000.0 * k + 999.5, 0.0, 0.0], "direction": [1.0, 0.0, 0.0]}]} for k in range(pipes)]
    connections = [{"from": [f"P{k}", 1], "to": [f"P{k + 1}", 0]} for k in range(pipes - 1)]
    return {"units": "mm", "components": components, "connections": connections}


def rigidity(n: int) -> dict:
    joints = n // 6
    bodies = [{"id": f"B{k}"} for k in range(min(joints + 1, 20_000))]
    return {"units": "mm", "bodies": bodies, "joints": [
        {"id": f"J{k}", "type": "hinge", "bodies": [f"B{k % 20_000}", f"B{(k + 1) % 20_000}"],
         "point": [k * 1.0, 0.5, 0.0], "axis": [0.0, 0.0, 1.0]} for k in range(joints)]}


# kind -> (what the body holds, its maker, the path of its last array's numbers for the +true row)
CASES = {
    "tube": ("{n} points", tube, ("points", -1, 2)),
    "polyhedra": ("{n} vertices, 10k faces", polyhedra, ("vertices", -1, 2)),
    "perfmap": ("{n} numbers (10k-point characteristics)", perfmap, ("positions", -1, "efficiency", -1)),
    "flowmeter": ("grid field of {n} values", flowmeter, ("magnetic_field", "by", -1)),
    "alignment": ("{n} numbers (2-port pipes)", alignment, ("components", -1, "ports", 1, "direction", 0)),
    "rigidity": ("{n} numbers (hinge joints)", rigidity, ("joints", -1, "axis", 2)),
}
SIZES = {"tube": 1_000_000, "polyhedra": 1_000_000, "perfmap": 3_000_000, "flowmeter": 2_000_000,
         "alignment": 2_400_000, "rigidity": 600_000}


def with_true(document: dict, path: tuple) -> dict:
    node = document
    for step in path[:-1]:
        node = node[step]
    node[path[-1]] = True
    return document


def run(tree: Path, kind: str, mode: str, body: Path) -> dict:
    done = subprocess.run([sys.executable, "-c", CHILD, str(tree), kind, mode, str(body)], cwd=tree,
                          env={**os.environ, "PYTHONPATH": str(tree), "PYTHONDONTWRITEBYTECODE": "1"},
                          capture_output=True, text=True, check=False)
    if done.returncode:
        return {"cpu": float("nan"), "rss": float("nan"), "answer": "crashed: " + done.stderr.strip()[-60:]}
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path, help="another checkout (main's worktree), measured in the same run")
    parser.add_argument("--scale", type=float, default=1.0, help="multiplies every body's size")
    parser.add_argument("--kinds", nargs="*", default=list(CASES))
    parser.add_argument("--repeat", type=int, default=1, help="runs per row: the least CPU, the largest RSS")
    args = parser.parse_args()
    folder = Path(os.environ.get("TMPDIR", "/tmp")) / f"bool-numbers-{os.getpid()}"
    folder.mkdir(parents=True, exist_ok=True)
    trees = ([("main", args.before.resolve())] if args.before else []) + [("this", HERE)]
    print(f"{'kind':10} {'body':38} {'way in':10} " + " ".join(
        f"{label + ' CPU s':>10} {label + ' +MB':>9}" for label, _ in trees) + "  answers")
    for kind in args.kinds:
        what, make, last = CASES[kind]
        n = int(SIZES[kind] * args.scale)
        document = make(n)
        plain = folder / f"{kind}.json"
        plain.write_text(json.dumps(document))
        marked = folder / f"{kind}-true.json"
        marked.write_text(json.dumps(with_true(document, last)))
        del document
        size = f"{what.format(n=f'{n:,}')}, {plain.stat().st_size / 1e6:.0f} MB"
        for mode, body, label in (("body", plain, "body"), ("upload", plain, "upload"),
                                  ("upload", marked, "upload+true")):
            runs = [[run(tree, kind, mode, body) for _, tree in trees] for _ in range(args.repeat)]
            rows = [{"cpu": min(r[i]["cpu"] for r in runs), "rss": max(r[i]["rss"] for r in runs),
                     "answer": runs[0][i]["answer"]} for i in range(len(trees))]
            print(f"{kind:10} {size[:38]:38} {label:10} " + " ".join(
                f"{row['cpu']:>10.2f} {row['rss']:>9.0f}" for row in rows) + "  " +
                " | ".join(row["answer"] for row in rows), flush=True)
        plain.unlink()
        marked.unlink()
    folder.rmdir()


if __name__ == "__main__":
    main()
