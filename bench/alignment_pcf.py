"""PCF exports through the whole path, per fixture and method: read, align, write, read back.

Fixtures are the exporter-style files in ``tests/solvers/alignment/data`` (E3D return bends, Revit caps
and MATERIALS, a 255 m tree with only rounding noise, flange faces a gasket apart, Plant 3D,
SmartPlant inch/TAB, an E3D line with inconsistent nozzles). Tie-ins are the ones a user of
each file would fix (none for the tree and the Revit line: they are anchored).

    python bench/alignment_pcf.py

Columns: components, largest gap and angle before, the profile used, largest movement of any
item, largest pipe length change, cuts, converged, whether re-reading the written file gives
the same connections (closed ones within tolerance), how many lines of unmoved items changed
(must be 0), and time (read + align + write + re-read check).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plantsolve.schemas.alignment import AlignmentRequest  # noqa: E402
from plantsolve.solvers.base import StoredInput  # noqa: E402
from plantsolve.solvers.alignment import parse_upload, render_artifacts, solve  # noqa: E402
from plantsolve.solvers.alignment.model import build_model, connection_errors  # noqa: E402
from plantsolve.solvers.alignment.pcf import interpret_pcf, read_document  # noqa: E402

DATA = Path(__file__).resolve().parents[1] / "tests" / "solvers" / "alignment" / "data"
FILES = [
    ("e3d_return_bends.pcf", ["1"]),
    ("revit_caps_materials.pcf", []),
    ("tree_250m.pcf", []),
    ("flange_gasket_gaps.pcf", ["FLA0"]),
    ("plant3d_cw_line.pcf", ["FLANGE-1", "FLANGE-33"]),
    ("sp3d_inch_tabs.pcf", ["FLANGE-1", "FLANGE-18", "FLANGE-19"]),
    ("e3d_plant_conflict.pcf", ["1", "15"]),
]


def run(name: str, fixed: list[str], method: str) -> dict:
    raw = (DATA / name).read_bytes()
    t0 = time.perf_counter()
    req = parse_upload(StoredInput.from_bytes(name, raw), {"fixed_components": fixed, "method": method})
    solved = solve(req)
    res = solved.result
    out = render_artifacts(req, solved)[0].data
    again = AlignmentRequest.model_validate(interpret_pcf(out.decode(), req.options).body)
    seconds = time.perf_counter() - t0
    key = lambda c: tuple(sorted((tuple(c.from_), tuple(c.to))))
    same = sorted(map(key, again.connections)) == sorted(map(key, req.connections))
    model = build_model(again)
    gap, ang = connection_errors(model, model.P0, model.D0)
    closed = np.array([r.position_error <= res.report.details["position_tolerance"] for r in res.connections])
    if same:
        same = bool(np.all(gap[closed] <= model.pos_tol) and np.all(ang[closed] <= model.ang_tol[closed]))
    doc = read_document(raw.decode())
    lines_in, lines_out = raw.decode().splitlines(), out.decode().splitlines()
    moved = {c.id for c in res.components if c.displacement > doc.quantum / 2}
    solved = {c.id for c in res.components}
    neighbours = {c.id: set() for c in req.components}
    for c in req.connections:
        neighbours[c.from_[0]].add(c.to[0])
        neighbours[c.to[0]].add(c.from_[0])
    changed = 0
    for k, item in enumerate(doc.items):
        if item.id not in solved or item.id in moved or neighbours[item.id] & moved:
            continue
        end = doc.items[k + 1].line if k + 1 < len(doc.items) else len(lines_in)
        changed += sum(lines_in[i] != lines_out[i] for i in range(item.line, end))
    d = res.report.details
    return {
        "file": name, "method": method, "components": len(req.components),
        "gap0": d["initial_max_gap"], "ang0": d["initial_max_angle_deg"], "profile": d["tolerance_profile"],
        "moved": max(c.displacement for c in res.components),
        "stretch": max((abs(c.length_change) for c in res.components if c.length_change is not None), default=0.0),
        "cuts": len(res.cut_connections), "converged": res.converged, "same": same, "changed": changed,
        "seconds": seconds, "stop": d["stop_reason"],
    }


def main() -> None:
    rows = [run(name, fixed, method) for name, fixed in FILES for method in ("direct", "dual_quaternion")]
    print("| fixture | method | components | initial gap | initial angle ° | profile | moved max | pipe length "
          "change max | cuts | converged | re-read same & closed | unmoved lines changed | time s |")
    print("|---|---|---:|---:|---:|---|---:|---:|---:|---|---|---:|---:|")
    for r in rows:
        print(f"| {r['file']} | {r['method']} | {r['components']} | {r['gap0']:.3f} | {r['ang0']:.4f} | {r['profile']} "
              f"| {r['moved']:.3f} | {r['stretch']:.3f} | {r['cuts']} | {'yes' if r['converged'] else 'no'} "
              f"| {'yes' if r['same'] else 'NO'} | {r['changed']} | {r['seconds']:.2f} |")
    print()
    for r in rows:
        if not r["converged"]:
            print(f"- {r['file']} / {r['method']}: {r['stop']}")


if __name__ == "__main__":
    main()
