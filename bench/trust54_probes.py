"""A user's mistakes in booleans, error locations and length units, sent through the real API (TestClient) in two
trees, side by side: what each tree answers at submission (the status and the first error's location and type, or
the job's id for a 202). Each tree runs in a child process of its own, with its own code first on ``sys.path``.

    python bench/trust54_probes.py [--before /work/wt/trust-base]

A probe is right when it is refused naming the field (422 with its user path), or accepted when the value is a
valid one; a 202 for ``"yes"`` as a boolean is a confident wrong reading (it was taken as true)."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CHILD = r'''
import copy, json, logging, os, sys, tempfile, pathlib
sys.path.insert(0, sys.argv[1])
logging.disable(logging.WARNING)
from fastapi.testclient import TestClient
import plantsolve
assert plantsolve.__file__.startswith(sys.argv[1]), plantsolve.__file__
from plantsolve.app.main import create_app
from tests.conftest import service_settings

ROOT = pathlib.Path(sys.argv[1])

def example(path):
    return json.loads((ROOT / path).read_text())

def changed(body, path, value):
    body = copy.deepcopy(body)
    node = body
    for step in path[:-1]:
        node = node.setdefault(step, {}) if isinstance(step, str) else node[step]
    node[path[-1]] = value
    return body

TUBE = lambda: example("examples/tube/scan_request.json")
ALIGN = lambda: example("examples/alignment/ladder.json")
PERF = lambda: example("examples/perfmap/n3_fan_map.json")
POLY = lambda: example("examples/polyhedra/gable_house.json")
FLOW = lambda: example("examples/flowmeter/meter.json")
RIG = lambda: example("examples/rigidity/four_bar_and_door.json")
XYZ = ("scan.xyz", (ROOT / "examples/tube/scan.xyz").read_bytes())
PCF = ("ladder.pcf", (ROOT / "examples/alignment/ladder.pcf").read_bytes())
CSV = ("map.csv", (ROOT / "examples/perfmap/n3_fan_map.csv").read_bytes())
IDF = ("zones.idf", (ROOT / "examples/polyhedra/two_offices.idf").read_bytes())
IFC = ("model.ifc", (ROOT / "examples/dedup/tunnel_3rings.ifc").read_bytes())

def as_file(name, body):
    return (name, json.dumps(body).encode())

CASES = [  # (case, kind, file (name, bytes) or None, options or JSON body)
    ("bool: tube .json options.common_bend_radius 'yes'", "tube",
     as_file("scan.json", changed(TUBE(), ("options", "common_bend_radius"), "yes")), None),
    ("bool: tube .xyz form common_bend_radius 1", "tube", XYZ, {"common_bend_radius": 1}),
    ("bool: tube body options.common_bend_radius 'true'", "tube", None,
     changed(TUBE(), ("options", "common_bend_radius"), "true")),
    ("bool: alignment .json components.0.fixed 'on'", "alignment",
     as_file("model.json", changed(ALIGN(), ("components", 0, "fixed"), "on")), None),
    ("bool: alignment .pcf form anchor 0", "alignment", PCF, {"anchor": 0}),
    ("bool: perfmap .csv form concave_efficiency 'true'", "perfmap", CSV, {"concave_efficiency": "true"}),
    ("bool: perfmap .json options.map 1", "perfmap", as_file("map.json", changed(PERF(), ("options", "map"), 1)),
     None),
    ("bool: polyhedra .idf form faces_csv '1'", "polyhedra", IDF, {"faces_csv": "1"}),
    ("bool: polyhedra .json options.list_faces 'yes'", "polyhedra",
     as_file("house.json", changed(POLY(), ("options", "list_faces"), "yes")), None),
    ("bool: dedup .ifc form allow_mirror 'yes'", "dedup", IFC, {"allow_mirror": "yes"}),
    ("bool: polyhedra .idf form faces_csv true (valid)", "polyhedra", IDF, {"faces_csv": True}),
    ("loc: tube .json points.0.0 'x'", "tube", as_file("scan.json", changed(TUBE(), ("points", 0, 0), "x")), None),
    ("loc: tube .json points.3 two numbers", "tube", as_file("scan.json", changed(TUBE(), ("points", 3), [1, 2])),
     None),
    ("loc: polyhedra .json faces.1.loops.0.2.1 'x'", "polyhedra",
     as_file("house.json", changed(POLY(), ("faces", 1, "loops", 0, 2, 1), "x")), None),
    ("loc: polyhedra body faces.1.loops.0.2.1 'x'", "polyhedra", None,
     changed(POLY(), ("faces", 1, "loops", 0, 2, 1), "x")),
    ("loc: rigidity .json bodies.0.shape.box.size.2 'x'", "rigidity",
     as_file("model.json", changed(RIG(), ("bodies", 0, "shape", "box", "size", 2), "x")), None),
    ("loc: flowmeter .json magnetic_field.magnitude 'x'", "flowmeter",
     as_file("meter.json", changed(FLOW(), ("magnetic_field", "magnitude"), "x")), None),
    ("loc: perfmap beta body points.1.beta 'half'", "perfmap/jobs/00000000-0000-4000-8000-000000000000/beta", None,
     {"points": [{"setting": [0.0, 0.9], "beta": 0.5}, {"speed": 0.9, "beta": "half"}]}),
    ("units: tube body units 'um'", "tube", None, changed(TUBE(), ("units",), "um")),
    ("units: tube body options.file_units 'um'", "tube", None, changed(TUBE(), ("options", "file_units"), "um")),
    ("units: tube .xyz form file_units 'µm'", "tube", XYZ, {"file_units": "µm"}),
    ("units: tube .xyz form file_units 'μm' (Greek mu)", "tube", XYZ, {"file_units": "μm"}),
    ("units: tube .xyz form units 'um'", "tube", XYZ, {"units": "um"}),
    ("units: polyhedra .idf form file_units 'um'", "polyhedra", IDF, {"file_units": "um"}),
    ("units: polyhedra .idf form file_units 'µm'", "polyhedra", IDF, {"file_units": "µm"}),
    ("units: polyhedra body options.file_units 'um'", "polyhedra", None,
     changed(POLY(), ("options", "file_units"), "um")),
    ("units: polyhedra body units 'µm'", "polyhedra", None, changed(POLY(), ("units",), "µm")),
    ("units: alignment .pcf form units 'um'", "alignment", PCF, {"units": "um"}),
    ("units: flowmeter body units 'um'", "flowmeter", None, changed(FLOW(), ("units",), "um")),
    ("units: rigidity body units 'µm'", "rigidity", None, changed(RIG(), ("units",), "µm")),
]

def answer(response):
    if response.status_code == 202:
        return "202 accepted"
    document = response.json()
    errors = document.get("errors") or [{}]
    first = errors[0]
    return f"{response.status_code} {'.'.join(map(str, first.get('loc', [])))} ({first.get('type')})"

with TestClient(create_app(service_settings(pathlib.Path(tempfile.mkdtemp())), run_jobs=False)) as client:
    for case, kind, upload, payload in CASES:
        if upload is None:
            response = client.post(f"/v1/{kind}" if "/" in kind else f"/v1/{kind}/jobs", json=payload)
        else:
            data = {"options": json.dumps(payload)} if payload is not None else {}
            response = client.post(f"/v1/{kind}/jobs", files={"file": upload}, data=data)
        print(json.dumps({"case": case, "answer": answer(response)}), flush=True)
'''


def answers(tree: str) -> dict[str, str]:
    env = {**os.environ, "PYTHONPATH": tree, "OPENBLAS_NUM_THREADS": "1"}
    done = subprocess.run([sys.executable, "-c", CHILD, tree], env=env, capture_output=True, text=True, cwd=tree)
    if done.returncode != 0:
        raise SystemExit(f"{tree}: the probes failed:\n{done.stderr[-3000:]}")
    rows = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    return {row["case"]: row["answer"] for row in rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", default="/work/wt/trust-base", help="the tree to compare with (main's copy)")
    args = parser.parse_args()
    before, after = answers(os.path.abspath(args.before)), answers(ROOT)
    width = max(map(len, after))
    print(f"| {'probe':{width}} | before ({args.before}) | after (this tree) |")
    print(f"| {'-' * width} | --- | --- |")
    for case in after:
        print(f"| {case:{width}} | {before.get(case, '-')} | {after[case]} |")


if __name__ == "__main__":
    main()
