"""What trust58b added, measured: the rigidity result's lone motions (dof told apart) and dedup's far products
(placement_beyond_tolerance, placement_outlier), each with the solve's CPU seconds with and without the new step
(interleaved, least of N, in this process), and what the result says.

    python bench/trust58b_models.py [--ldraw FILE ...] [--repeat N]
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import time
from pathlib import Path

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.dedup import SPEC as DEDUP
from plantsolve.solvers.dedup import solve as dedup_solve
from plantsolve.solvers.rigidity import solve as rigidity_solve
from plantsolve.solvers.rigidity.upload import parse_ldraw

TUNNEL = (ROOT / "examples/dedup/tunnel_3rings.ifc").read_bytes()
OMR = ROOT / "tests/solvers/rigidity/omr"


def _least_cpu(run, repeat: int, patches: list[tuple[object, str, object]]) -> tuple[float, float, object]:
    """(CPU s with the step, CPU s without it, the result with it), runs interleaved, the least of ``repeat``."""
    with_, without, result = [], [], None
    saved = [(obj, name, getattr(obj, name)) for obj, name, _ in patches]
    for _ in range(repeat):
        start = time.process_time()
        result = run()
        with_.append(time.process_time() - start)
        for obj, name, stand_in in patches:
            setattr(obj, name, stand_in)
        try:
            start = time.process_time()
            run()
            without.append(time.process_time() - start)
        finally:
            for obj, name, original in saved:
                setattr(obj, name, original)
    return min(with_), min(without), result


def rigidity_rows(files: list[Path], repeat: int) -> list[tuple]:
    rows = []
    for path in files:
        request = RigidityRequest.model_validate(parse_ldraw(path.read_text(encoding="utf-8", errors="replace")))
        cpu, base, solved = _least_cpu(lambda request=request: rigidity_solve.solve(request), repeat,
                                       [(rigidity_solve, "lone_motions", lambda clusters, joints: [])])
        r = solved.result
        lone = sum(m.dof for m in r.lone_motions)
        rows.append((f"rigidity {path.name}", f"dof {r.dof} (generic {r.generic_dof})",
                     f"{lone} lone in {len(r.lone_motions)} clusters, linked {r.linked_dof}", base, cpu))
    return rows


def _tunnel_with_one_segment_at(x: str) -> bytes:
    axes = re.findall(rb"#\d+=IFCLOCALPLACEMENT\(#\d+,#(\d+)\);", TUNNEL)
    origin = re.search(rb"#%s=IFCAXIS2PLACEMENT3D\(#(\d+)" % axes[len(axes) // 2], TUNNEL).group(1)
    return re.sub(rb"(#%s=IFCCARTESIANPOINT\(\()[^)]*(\)\))" % origin, rb"\g<1>" + x.encode() + rb",0.,0.\g<2>",
                  TUNNEL)


def dedup_rows(repeat: int) -> list[tuple]:
    rows = []
    cases = [("tunnel", TUNNEL), ("tunnel, one segment at 5e10 m", _tunnel_with_one_segment_at("5.E10")),
             ("tunnel, one segment at 2e11 m", _tunnel_with_one_segment_at("2.E11")),
             ("tunnel georeferenced (root at 1e9 m)",
              TUNNEL.replace(b"#19=IFCCARTESIANPOINT((0.,0.,0.));", b"#19=IFCCARTESIANPOINT((1.E9,-2.5E6,30.));"))]
    for name, content in cases:
        stored = StoredInput.from_bytes("tunnel.ifc", content)

        def run(stored=stored):
            return DEDUP.solve(DEDUP.input_of(DEDUP.parse_upload(stored, None), stored), lambda *a, **k: None)

        cpu, base, solved = _least_cpu(run, repeat, [(dedup_solve, "left_out_by_placement", lambda *a: []),
                                                     (dedup_solve, "placement_outliers", lambda *a: [])])
        r = solved.result
        codes = sorted({w.code for w in r.report.warnings} & {"placement_beyond_tolerance", "placement_outlier"})
        rows.append((f"dedup {name}", f"{r.products_shared} of {r.products_total} shared",
                     ", ".join(codes) or "-", base, cpu))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ldraw", nargs="*", type=Path, default=[OMR / "7140-1-X-wingFighter.mpd"])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    rows = rigidity_rows(args.ldraw, args.repeat) + dedup_rows(args.repeat)
    print(f"| {'case':<42} | {'answer':<26} | {'says':<48} | CPU s without | CPU s with |")
    print(f"|{'-' * 44}|{'-' * 28}|{'-' * 50}|---------------|------------|")
    for case, answer, says, base, cpu in rows:
        print(f"| {case:<42} | {answer:<26} | {says:<48} | {base:13.3f} | {cpu:10.3f} |")


if __name__ == "__main__":
    main()
