"""Benchmark of the polyhedra solver.

    python bench/polyhedra.py            # 10, 100, 1,000-zone buildings and a 1,000,000-triangle torus
    python bench/polyhedra.py --quick    # 10 and 100 zones, a 100,000-triangle torus

Prints per generated building (floors x rooms, a window subsurface on every exterior wall; the
"paneled" one has every wall and slab split 4 x 4, 53,200 faces): zones, faces, time of the
request's validation, time of the whole solve (input checked, repaired, sewn, measured and
diagnosed, result built; the request is validated once at submission, timed apart) and of the
array analysis alone, peak memory (tracemalloc) and the largest
volume error. Then the closed triangle mesh, side by side in the same run with trimesh on the same
arrays: trimesh's volume + area (its mass properties), trimesh's watertight check, our measures
alone (Newell/divergence, no topology), our full analysis from arrays, and the agreement.
Targets: 1,000 zones < 2 s; the million-triangle mesh within 2x of trimesh.
"""

from __future__ import annotations

import argparse
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plantsolve.schemas.polyhedra import PolyhedraRequest  # noqa: E402
from plantsolve.solvers.polyhedra import check_input, solve  # noqa: E402
from plantsolve.solvers.polyhedra.measures import face_measures, use_terms  # noqa: E402
from plantsolve.solvers.polyhedra.polygons import from_mesh, from_request  # noqa: E402
from plantsolve.solvers.polyhedra.solve import analyse  # noqa: E402
from plantsolve.solvers.polyhedra.synthetic import building, torus_mesh  # noqa: E402

# label -> (floors, rooms_x, rooms_y, panels per wall side)
BUILDINGS = {"10": (2, 5, 1, 1), "100": (4, 5, 5, 1), "1,000": (10, 10, 10, 1), "1,000 paneled": (10, 10, 10, 4)}


def timed(fn, reps=3):
    best, out = float("inf"), None
    for _ in range(reps):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def peak(fn):
    tracemalloc.start()
    fn()
    _, top = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return top / 2 ** 20


def checked_solve(request: PolyhedraRequest):
    """What a job does with the request: the checks (once, at submission), then the solve."""
    check_input(request)
    return solve(request).result


def buildings(sizes):
    print("| zones | faces | validate request [s] | solve [s] | of which analysis [s] | peak memory of solve [MiB] "
          "| max volume error [m³] |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for label in sizes:
        floors, rx, ry, panels = BUILDINGS[label]
        n = floors * rx * ry
        body = building(floors, rx, ry, origin=(4.5e5, 5.2e6, 100.0), panels=panels)
        t_validate, request = timed(lambda: PolyhedraRequest.model_validate(body), reps=2)
        t_solve, result = timed(lambda: checked_solve(request), reps=2)
        poly = from_request(request)
        t_an, _ = timed(lambda: analyse(poly), reps=2)
        mem = peak(lambda: checked_solve(request))
        err = max(abs(z.volume - 60.0) for z in result.zones)
        assert len(result.zones) == n and all(z.closed for z in result.zones)
        print(f"| {label} | {len(body['faces']):,} | {t_validate:.3f} | {t_solve:.3f} | {t_an:.3f} | {mem:.0f} | {err:.1e} |")


def mesh(n_major, n_minor):
    vertices, triangles = torus_mesh(n_major, n_minor)
    n = len(triangles)

    def ours_measures():
        poly = from_mesh(vertices, triangles)
        m = face_measures(poly)
        use = np.arange(n)
        t = use_terms(m, use, np.zeros(n, dtype=np.int64), np.ones(n, dtype=np.int64), 1)
        return float(t.flux.sum() / 3.0), float(m.area.sum())

    def ours_full():
        an = analyse(from_mesh(vertices, triangles))
        return float(an.terms.flux.sum() / 3.0), float(an.measures.area.sum()), an

    def trimesh_measures():
        m = trimesh.Trimesh(vertices=vertices, faces=triangles, process=False)
        return float(m.volume), float(m.area)

    def trimesh_watertight():
        m = trimesh.Trimesh(vertices=vertices, faces=triangles, process=False)
        return float(m.volume), float(m.area), bool(m.is_watertight)

    t_tm, (v_tm, a_tm) = timed(trimesh_measures)
    t_tw, (_, _, watertight) = timed(trimesh_watertight)
    t_om, (v_om, a_om) = timed(ours_measures)
    t_of, (v_of, a_of, an) = timed(ours_full, reps=1)
    mem_tm = peak(trimesh_measures)
    mem_of = peak(ours_full)
    closed = an.topology.open_groups.size == 0 and an.topology.non_manifold_groups.size == 0
    genus = (2 - int(an.topology.euler[0])) // 2
    print(f"\nclosed torus mesh: {n:,} triangles, {len(vertices):,} vertices")
    print("| method | time [s] | ratio to trimesh volume+area | volume | area | peak memory [MiB] |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    print(f"| trimesh volume + area | {t_tm:.3f} | 1.00 | {v_tm:.9f} | {a_tm:.9f} | {mem_tm:.0f} |")
    print(f"| trimesh volume + area + is_watertight | {t_tw:.3f} | {t_tw / t_tm:.2f} | | watertight={watertight} | |")
    print(f"| polyhedra measures (Newell/divergence) | {t_om:.3f} | {t_om / t_tm:.2f} | {v_om:.9f} | {a_om:.9f} | |")
    print(f"| polyhedra full analysis (repair, G-map, measures, diagnostics) | {t_of:.3f} | {t_of / t_tm:.2f} | "
          f"{v_of:.9f} | {a_of:.9f} | {mem_of:.0f} |")
    print(f"agreement: volume {abs(v_om - v_tm) / v_tm:.1e} relative, area {abs(a_om - a_tm) / a_tm:.1e} relative; "
          f"closed={closed}, genus={genus}, darts={an.gmap.n_darts:,}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    buildings(["10", "100"] if args.quick else list(BUILDINGS))
    mesh(*((500, 100) if args.quick else (1000, 500)))


if __name__ == "__main__":
    main()
