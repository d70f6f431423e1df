"""PCF exports through the whole path, per fixture and method: read, align, write, read back.

Fixtures are the exporter-style files in ``tests/solvers/alignment/data`` (E3D return bends, Revit caps
and MATERIALS, a 255 m tree with only rounding noise, flange faces a gasket apart, Plant 3D,
SmartPlant inch/TAB, an E3D line with inconsistent nozzles, a converter's valve handwheels drawn as
rings of BEND items), plus generated ones: a ~300-item network printed with 2 and 4 decimals, and a
line with three items that fail a model check once interpreted (direct method only). Tie-ins are the
ones a user of each file would fix (none for the tree and the Revit line: they are anchored).

    python bench/alignment_pcf.py                       # this tree
    python bench/alignment_pcf.py --baseline DIR        # DIR (e.g. a `git archive main` copy) first, same run

Columns: components, largest gap and angle before, the profile used, largest movement of any item,
largest pipe length change, cuts, items held / left out, converged, whether re-reading the written
file gives the same connections (closed ones within the position tolerance, their angle within what
the result left plus the rounding of both ends' printed points), the largest re-read gap of a
connection the result closed bit-identically (3 significant digits: it must be 0), how many lines of
unmoved items changed (must be 0), and CPU seconds (read + align + write + re-read check). A file
the code refuses shows its 422 message.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "solvers" / "alignment" / "data"
FILES = [
    ("e3d_return_bends.pcf", ["1"]),
    ("revit_caps_materials.pcf", []),
    ("tree_250m.pcf", []),
    ("flange_gasket_gaps.pcf", ["FLA0"]),
    ("plant3d_cw_line.pcf", ["FLANGE-1", "FLANGE-33"]),
    ("sp3d_inch_tabs.pcf", ["FLANGE-1", "FLANGE-18", "FLANGE-19"]),
    ("e3d_plant_conflict.pcf", ["1", "15"]),
    ("converter_handwheels.pcf", ["1"]),
]
DEGENERATE = (  # an inward-pointing bend and tee (CENTRE-POINT beyond an end) and an elbow with three END-POINTs
    "UNITS-CO-ORDS MM\nPIPE\n    END-POINT 0 0 0 100\n    END-POINT 1000 0 0 100\n"
    "BEND\n    END-POINT 1000 0 0 100\n    END-POINT 1300 0 0 100\n    CENTRE-POINT 900 -20 0\n"
    "PIPE\n    END-POINT 1300 0 0 100\n    END-POINT 2300 0 0 100\n"
    "TEE\n    END-POINT 2300 0 0 100\n    END-POINT 2600 0 0 100\n    CENTRE-POINT 2800 0 10\n"
    "    BRANCH1-POINT 2450 150 0 100\n"
    "PIPE\n    END-POINT 2600 0 0 100\n    END-POINT 3600 0 0 100\n"
    "ELBOW\n    END-POINT 3600 0 0 100\n    END-POINT 3900 0 0 100\n    END-POINT 3750 150 0 100\n"
    "    CENTRE-POINT 3750 0 0\n"
    "PIPE\n    END-POINT 3900 0 0 100\n    END-POINT 4900 0 0 100\n"
)


def inputs() -> list[tuple[str, bytes, list[str], tuple[str, ...]]]:
    sys.path.insert(0, str(DATA.parent))
    from pcf_exports import network_300

    rows = [(name, (DATA / name).read_bytes(), fixed, ("direct", "dual_quaternion")) for name, fixed in FILES]
    rows += [(f"network_300 ({d} decimals)", network_300(d).encode(), [], ("direct",)) for d in (2, 4)]
    rows.append(("degenerate_items (generated)", DEGENERATE.encode(), [], ("direct",)))
    return rows


def run(name: str, raw: bytes, fixed: list[str], method: str) -> dict:
    import numpy as np

    from plantsolve.schemas.alignment import AlignmentRequest
    from plantsolve.solvers.alignment.solve import solve
    from plantsolve.solvers.alignment.upload import parse_upload
    from plantsolve.solvers.alignment.validation import check_input
    from plantsolve.solvers.alignment.model import build_model, connection_errors
    from plantsolve.solvers.alignment.pcf import interpret_pcf, read_document
    from plantsolve.solvers.alignment.pcf_write import write_aligned_pcf
    from plantsolve.solvers.base import InputRejected, StoredInput

    t0 = time.process_time()
    try:
        req = parse_upload(StoredInput.from_bytes("x.pcf", raw), {"fixed_components": fixed, "method": method})
        check_input(req)  # as the job domain does at submission
    except InputRejected as exc:
        return {"file": name, "method": method, "refused": exc.errors[0].msg[:90]}
    res = solve(req).result
    out = write_aligned_pcf(req, res).encode()
    again = AlignmentRequest.model_validate(interpret_pcf(out.decode(), req.options).body)
    seconds = time.process_time() - t0
    key = lambda c: tuple(sorted((tuple(c.from_), tuple(c.to))))
    same = sorted(map(key, again.connections)) == sorted(map(key, req.connections))
    model = build_model(again)
    gap, ang = connection_errors(model, model.P0, model.D0)
    tol = res.report.details["position_tolerance"]
    closed = np.array([r.position_error <= tol and not r.cut for r in res.connections])
    exact = {key(c) for c, r in zip(req.connections, res.connections) if not r.cut and r.position_error == 0.0}
    reread_gap = max((float(gap[k]) for k, c in enumerate(again.connections) if key(c) in exact), default=0.0)
    if same:  # printing turns each end's direction by up to the rounding over its lever: twice the tolerance
        left = np.radians([r.angle_error for r in res.connections])
        same = bool(np.all(gap[closed] <= model.pos_tol) and np.all(ang[closed] <= left[closed] + 2 * model.ang_tol[closed]))
    doc = read_document(raw.decode())
    lines_in, lines_out = raw.decode().splitlines(), out.decode().splitlines()
    moved = {c.id for c in res.components if c.displacement > doc.quantum / 2}
    aligned = {c.id for c in res.components}
    neighbours = {c.id: set() for c in req.components}
    for c in req.connections:
        neighbours[c.from_[0]].add(c.to[0])
        neighbours[c.to[0]].add(c.from_[0])
    changed = 0
    for k, item in enumerate(doc.items):
        if item.id not in aligned or item.id in moved or neighbours[item.id] & moved:
            continue
        end = doc.items[k + 1].line if k + 1 < len(doc.items) else len(lines_in)
        changed += sum(lines_in[i] != lines_out[i] for i in range(item.line, end))
    d = res.report.details
    count = lambda code: sum(len(w.details.get("items", [])) for w in res.report.warnings if w.code == code)
    return {
        "file": name, "method": method, "components": len(req.components),
        "gap0": d["initial_max_gap"], "ang0": d["initial_max_angle_deg"], "profile": d["tolerance_profile"],
        "moved": max(c.displacement for c in res.components),
        "stretch": max((abs(c.length_change) for c in res.components if c.length_change is not None), default=0.0),
        "cuts": len(res.cut_connections), "held": count("pcf_items_held"), "left_out": count("pcf_items_left_out"),
        "converged": res.converged, "same": same, "reread_gap": reread_gap, "changed": changed,
        "seconds": seconds, "stop": d["stop_reason"],
    }


def measure(code: Path) -> list[dict]:
    """Every row with the plantsolve package of ``code`` (a fresh process, so two trees never mix)."""
    cmd = [sys.executable, __file__, "--rows", "--code", str(code)]
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)


def table(rows: list[dict]) -> None:
    print("| code | fixture | method | components | initial gap | initial angle ° | profile | moved max | pipe length "
          "change max | cuts | held / left out | converged | re-read same & closed | re-read gap (bit-identical) "
          "| unmoved lines changed | CPU s |")
    print("|---|---|---|---:|---:|---:|---|---:|---:|---:|---|---|---|---:|---:|---:|")
    for r in rows:
        if "refused" in r:
            print(f"| {r['code']} | {r['file']} | {r['method']} | refused (422): {r['refused']} |" + " |" * 12)
            continue
        print(f"| {r['code']} | {r['file']} | {r['method']} | {r['components']} | {r['gap0']:.3f} | {r['ang0']:.4f} "
              f"| {r['profile']} | {r['moved']:.3f} | {r['stretch']:.3f} | {r['cuts']} | {r['held']} / {r['left_out']} "
              f"| {'yes' if r['converged'] else 'no'} | {'yes' if r['same'] else 'NO'} | {r['reread_gap']:.3g} "
              f"| {r['changed']} | {r['seconds']:.2f} |")
    print()
    for r in rows:
        if "refused" not in r and not r["converged"]:
            print(f"- {r['code']} {r['file']} / {r['method']}: {r['stop']}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", type=Path, help="another tree (its plantsolve package) measured first")
    ap.add_argument("--code", type=Path, default=ROOT, help=argparse.SUPPRESS)
    ap.add_argument("--rows", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.rows:
        sys.path.insert(0, str(args.code.resolve()))
        import plantsolve

        assert Path(plantsolve.__file__).resolve().is_relative_to(args.code.resolve()), plantsolve.__file__
        rows = [run(name, raw, fixed, m) for name, raw, fixed, methods in inputs() for m in methods]
        print(json.dumps(rows))
        return
    rows = []
    for label, code in ([("baseline", args.baseline)] if args.baseline else []) + [("this tree", ROOT)]:
        rows += [{**r, "code": label} for r in measure(code)]
    if args.baseline:  # before and after side by side
        rows.sort(key=lambda r: (r["file"], r["method"], r["code"] != "baseline"))
    table(rows)


if __name__ == "__main__":
    main()
