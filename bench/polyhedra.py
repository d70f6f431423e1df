"""Benchmark of the polyhedra solver.

    python bench/polyhedra.py            # 10, 100, 1,000-zone buildings and a 1,000,000-triangle torus
    python bench/polyhedra.py --quick    # 10 and 100 zones, a 100,000-triangle torus
    python bench/polyhedra.py --before /work/main   # also the code of another checkout (its .venv), same run
    python bench/polyhedra.py --formats-only     # the same rooms read from each upload format

Prints per generated building (floors x rooms, a window subsurface on every exterior wall; the
"paneled" one has every wall and slab split 4 x 4, 53,200 faces): zones, faces, time of the
request's validation, time of the whole solve (input checked, repaired, sewn, measured and
diagnosed, result built; the request is validated once at submission, timed apart) and of the
array analysis alone, peak memory (tracemalloc) and the largest
volume error. Then the closed triangle mesh, side by side in the same run with trimesh on the same
arrays: trimesh's volume + area (its mass properties), trimesh's watertight check, our measures
alone (Newell/divergence, no topology), our full analysis from arrays, and the agreement; then the
full analysis again in a fresh process each (CPU seconds, peak RSS of the process), ours and, with
``--before``, the other checkout's. Last, end to end: the mesh as a binary STL through
``plantsolve solve polyhedra`` (a child process: CPU seconds user + system, its peak RSS, the result
JSON's and the artifacts' sizes) against trimesh loading the same file and taking volume and area
in a child process of its own, each checkout without and with the per-face rows of zones.csv (180 MiB for
the million triangles, written above 10,000 faces only when options.faces_csv asks), each run ``--repeats``
times interleaved (median CPU, largest peak RSS). CPU seconds come from the children's ``wait4`` rusage.
Targets: 1,000 zones < 2 s; the million-triangle mesh within 2x of trimesh in process, under 1 GB;
end to end (`plantsolve solve`, its whole process) within 2x of trimesh's whole process reading the
file, under 1 GB peak RSS.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from plantsolve.schemas.polyhedra import PolyhedraRequest  # noqa: E402
from plantsolve.solvers.polyhedra.solve import solve  # noqa: E402
from plantsolve.solvers.polyhedra.validation import check_input  # noqa: E402
from plantsolve.solvers.polyhedra.measures import face_measures, use_terms  # noqa: E402
from plantsolve.solvers.polyhedra.polygons import from_mesh, from_request  # noqa: E402
from plantsolve.solvers.polyhedra.solve import analyse  # noqa: E402
from plantsolve.solvers.polyhedra.synthetic import building, torus_mesh  # noqa: E402

# label -> (floors, rooms_x, rooms_y, panels per wall side)
BUILDINGS = {"10": (2, 5, 1, 1), "100": (4, 5, 5, 1), "1,000": (10, 10, 10, 1), "1,000 paneled": (10, 10, 10, 4)}


def timed(fn, reps=3):
    """Best CPU seconds of ``reps`` runs (the machine may be shared: CPU time, not wall time)."""
    best, out = float("inf"), None
    for _ in range(reps):
        out = None
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
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
    print("| zones | faces | validate request CPU [s] | solve CPU [s] | of which analysis CPU [s] | peak memory of solve [MiB] "
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


REPO = Path(__file__).resolve().parents[1]

# run in a fresh interpreter (``sys.argv[1:] = [repo, n_major, n_minor]``): the analysis of the torus mesh,
# CPU seconds and volume printed as JSON; the code is the given checkout's
CHILD_ANALYSIS = """
import json, sys, time
sys.path.insert(0, sys.argv[1])
from plantsolve.solvers.polyhedra.polygons import from_mesh
from plantsolve.solvers.polyhedra.solve import analyse
from plantsolve.solvers.polyhedra.synthetic import torus_mesh
vertices, triangles = torus_mesh(int(sys.argv[2]), int(sys.argv[3]))
t0 = time.process_time()
an = analyse(from_mesh(vertices, triangles))
cpu = time.process_time() - t0
print(json.dumps({"cpu": cpu, "volume": float(an.terms.flux.sum() / 3.0), "area": float(an.measures.area.sum())}))
""" + "print(open('/proc/self/status').read().split('VmHWM:')[1].split()[0])"

CHILD_TRIMESH_FILE = """
import json, sys, time
import trimesh
t0 = time.process_time()
mesh = trimesh.load(sys.argv[1])
volume, area = float(mesh.volume), float(mesh.area)
print(json.dumps({"cpu": time.process_time() - t0, "volume": volume, "area": area}))
print(open('/proc/self/status').read().split('VmHWM:')[1].split()[0])
"""

# the command line in this interpreter, then its peak RSS (VmHWM: this process's own, whereas rusage's maxrss
# starts from the parent's at fork)
CHILD_CLI = """
import sys
from plantsolve.cli import main
code = main(sys.argv[1:])
print(open('/proc/self/status').read().split('VmHWM:')[1].split()[0])
sys.exit(code)
"""


# the job's steps in one process, without the job domain (no upload reader's time limit, no store): read the STL,
# check, solve, the result as JSON, the artifacts
CHILD_PIPELINE = """
import json, sys, time
sys.path.insert(0, sys.argv[1])
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.artifacts import render_artifacts
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input
t0 = time.process_time()
request = parse_upload(StoredInput.from_path(sys.argv[2]), None)
check_input(request)
solved = solve(request)
text = solved.result.model_dump_json()
files = render_artifacts(request, solved)
print(json.dumps({"cpu": time.process_time() - t0, "json": len(text), "volume": solved.result.total_volume,
                  "csv": sum(len(a.data) for a in files if a.name.endswith(".csv"))}))
print(open('/proc/self/status').read().split('VmHWM:')[1].split()[0])
"""


def child(argv: list[str], cwd: Path | None = None) -> tuple[float, float, str]:
    """(CPU seconds user + system, peak RSS in MiB, standard output but its last line) of a child process and the
    children it waited for (its own rusage from wait4); the last line of its output is its VmHWM in kB."""
    env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    proc = subprocess.Popen(argv, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    out, err = proc.stdout.read(), proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise RuntimeError(f"{argv[:3]} failed ({proc.returncode}): {err.decode()[-2000:]}")
    *lines, peak = out.decode().strip().splitlines()
    return usage.ru_utime + usage.ru_stime, int(peak) / 1024, "\n".join(lines)


def fresh_analysis(n_major: int, n_minor: int, checkouts: dict[str, Path]) -> None:
    print("\nfull analysis of the same mesh in a fresh process each (CPU of the analysis; peak RSS of the process, "
          "the mesh and the imports included)")
    print("| code | analysis CPU [s] | process peak RSS [MiB] | volume |")
    print("| --- | ---: | ---: | ---: |")
    for label, repo in checkouts.items():
        _, rss, out = child([str(python_of(repo)), "-c", CHILD_ANALYSIS, str(repo), str(n_major), str(n_minor)])
        got = json.loads(out)
        print(f"| {label} | {got['cpu']:.3f} | {rss:.0f} | {got['volume']:.9f} |")


def python_of(repo: Path) -> Path:
    venv = repo / ".venv" / "bin" / "python"
    return venv if venv.exists() else Path(sys.executable)


def end_to_end(n_major: int, n_minor: int, checkouts: dict[str, Path], repeats: int = 3) -> None:
    """The mesh as a binary STL through each checkout's whole pipeline and its command line, with and without the
    per-face rows, beside trimesh's process: each run ``repeats`` times, interleaved (the machine is shared), its
    median CPU seconds and its largest peak RSS."""
    vertices, triangles = torus_mesh(n_major, n_minor)
    with tempfile.TemporaryDirectory(prefix="bench-polyhedra-") as folder:
        work = Path(folder)
        stl = work / "torus.stl"
        trimesh.Trimesh(vertices=vertices, faces=triangles, process=False).export(stl)
        rows: dict[str, dict] = {"trimesh": {"argv": [sys.executable, "-c", CHILD_TRIMESH_FILE, str(stl)]}}
        for label, repo in checkouts.items():
            rows[f"pipeline ({label})"] = {"argv": [str(python_of(repo)), "-c", CHILD_PIPELINE, str(repo), str(stl)]}
        for options, asked in (([], ""), (["--options", '{"faces_csv": true}'], ", faces_csv asked")):
            for label, repo in checkouts.items():
                rows[f"cli ({label}{asked})"] = {"repo": repo, "options": options}
        for attempt in range(repeats):
            for k, (name, row) in enumerate(rows.items()):
                out_json = work / f"run{k}.json"
                argv = row.get("argv") or [str(python_of(row["repo"])), "-c", CHILD_CLI, "solve", "polyhedra", str(stl),
                                           "-o", str(out_json), "--no-progress", *row["options"]]
                try:
                    cpu, rss, out = child(argv, cwd=work)
                except RuntimeError as failed:
                    row["failed"] = " ".join(str(failed).split())[-160:]
                    continue
                row.setdefault("cpu", []).append(cpu)
                row["rss"] = max(row.get("rss", 0.0), rss)
                if "argv" in row:  # a child that times its own work, after its imports
                    row["got"] = json.loads(out)
                    row.setdefault("work", []).append(row["got"]["cpu"])
                else:
                    row["got"] = {"volume": json.loads(out_json.read_text())["total_volume"],
                                  "json": out_json.stat().st_size,
                                  "csv": (work / f"run{k}_artifacts" / "zones.csv").stat().st_size}
        trimesh_row = rows.pop("trimesh")
        t_cpu = float(np.median(trimesh_row["work"]))  # load + volume + area, after its imports
        t_process = float(np.median(trimesh_row["cpu"]))
        print(f"\nend to end: the {len(triangles):,}-triangle torus as a binary STL ({stl.stat().st_size / 2**20:.0f} MiB) "
              "through `plantsolve solve polyhedra torus.stl -o out.json` (a temporary store, artifacts written); "
              f"median CPU of {repeats} interleaved runs, largest peak RSS")
        print("| run | CPU [s] | ratio to trimesh's load + volume + area | ratio to trimesh's whole process "
              "| peak RSS [MiB] | result JSON [MiB] | CSV [MiB] | volume |")
        print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        print(f"| trimesh: load + volume + area, after its imports | {t_cpu:.2f} | 1.00 | | | | | |")
        print(f"| trimesh: its whole process (imports, load, volume, area) | {t_process:.2f} | "
              f"{t_process / t_cpu:.2f} | 1.00 | {trimesh_row['rss']:.0f} | | | {trimesh_row['got']['volume']:.9f} |")
        for name, row in rows.items():
            pipeline = name.startswith("pipeline")
            what = (f"read + check + solve + JSON + artifacts, after the imports, no job domain {name[9:]}" if pipeline
                    else f"plantsolve solve, its whole process {name[4:]}")
            if "cpu" not in row:
                print(f"| {what} | failed: {row.get('failed')} | | | | | | |")
                continue
            cpu, got = float(np.median(row["work" if pipeline else "cpu"])), row["got"]
            whole = "" if pipeline else f"{cpu / t_process:.2f}"
            print(f"| {what} | {cpu:.2f} | {cpu / t_cpu:.2f} | {whole} | {row['rss']:.0f} | "
                  f"{got['json'] / 2**20:.1f} | {got['csv'] / 2**20:.0f} | {got['volume']:.9f} |")


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
    t_of, (v_of, a_of, an) = timed(ours_full)
    mem_tm = peak(trimesh_measures)
    mem_of = peak(ours_full)
    closed = an.topology.open_groups.size == 0 and an.topology.non_manifold_groups.size == 0
    genus = (2 - int(an.topology.euler[0])) // 2
    print(f"\nclosed torus mesh: {n:,} triangles, {len(vertices):,} vertices")
    print("| method | CPU [s] | ratio to trimesh volume+area | volume | area | peak memory [MiB] |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    print(f"| trimesh volume + area | {t_tm:.3f} | 1.00 | {v_tm:.9f} | {a_tm:.9f} | {mem_tm:.0f} |")
    print(f"| trimesh volume + area + is_watertight | {t_tw:.3f} | {t_tw / t_tm:.2f} | | watertight={watertight} | |")
    print(f"| polyhedra measures (Newell/divergence) | {t_om:.3f} | {t_om / t_tm:.2f} | {v_om:.9f} | {a_om:.9f} | |")
    print(f"| polyhedra full analysis (repair, G-map, measures, diagnostics) | {t_of:.3f} | {t_of / t_tm:.2f} | "
          f"{v_of:.9f} | {a_of:.9f} | {mem_of:.0f} |")
    print(f"agreement: volume {abs(v_om - v_tm) / v_tm:.1e} relative, area {abs(a_om - a_tm) / a_tm:.1e} relative; "
          f"closed={closed}, genus={genus}, darts={an.gmap.n_darts:,}")


def _rooms(n_x: int, n_y: int, height: float = 3.0, size: float = 5.0):
    """A one-storey grid of size x size x height rooms: (zone, name, azimuth, tilt, start, length, height) of
    every rectangle, in world coordinates; shared walls written once per room, as EnergyPlus has them."""
    for i in range(n_x):
        for j in range(n_y):
            x, y, zone = i * size, j * size, f"R{i}_{j}"
            yield zone, f"{zone} S", 180, 90, (x, y, 0), size, height
            yield zone, f"{zone} E", 90, 90, (x + size, y, 0), size, height
            yield zone, f"{zone} N", 0, 90, (x + size, y + size, 0), size, height
            yield zone, f"{zone} W", 270, 90, (x, y + size, 0), size, height
            yield zone, f"{zone} F", 90, 180, (x, y, 0), size, size
            yield zone, f"{zone} C", 180, 0, (x, y, height), size, size


def format_texts(n_x: int, n_y: int) -> dict[str, tuple[str, bytes]]:
    """The same rooms as a detailed IDF (the reader before this work), a simple-geometry IDF, its epJSON
    and a gbXML file (each room's faces as Surfaces of one space)."""
    from plantsolve.solvers.polyhedra.idf_rectangles import rectangle  # noqa: PLC0415

    rules = "GlobalGeometryRules,UpperLeftCorner,Counterclockwise,World,World,World;\n"
    detailed, simple, epjson, gb = [rules], [rules], {"GlobalGeometryRules": {"g": {
        "starting_vertex_position": "UpperLeftCorner", "vertex_entry_direction": "Counterclockwise",
        "coordinate_system": "World", "rectangular_surface_coordinate_system": "World"}}}, []
    classes = {"S": "Wall:Exterior", "E": "Wall:Exterior", "N": "Wall:Exterior", "W": "Wall:Exterior",
               "F": "Floor:GroundContact", "C": "Roof"}
    for zone, name, az, tilt, start, length, height in _rooms(n_x, n_y):
        points = rectangle(az, tilt, np.array(start, dtype=float), length, height)
        coords = ",".join(f"{c:g}" for p in points for c in p)
        detailed.append(f"BuildingSurface:Detailed,{name},Wall,C,{zone},Outdoors,,SunExposed,WindExposed,,4,{coords};\n")
        cls = classes[name[-1]]
        simple.append(f"{cls},{name},C,{zone},{az},{tilt},{start[0]},{start[1]},{start[2]},{length},{height};\n")
        key = "height" if cls.startswith("Wall") else "width"
        epjson.setdefault(cls, {})[name] = {"zone_name": zone, "azimuth_angle": az, "tilt_angle": tilt,
                                            "starting_x_coordinate": start[0], "starting_y_coordinate": start[1],
                                            "starting_z_coordinate": start[2], "length": length, key: height}
        loop = "".join("<CartesianPoint>" + "".join(f"<Coordinate>{c:g}</Coordinate>" for c in p) + "</CartesianPoint>"
                       for p in points)
        gb.append(f'<Surface id="{name}" surfaceType="ExteriorWall"><AdjacentSpaceId spaceIdRef="{zone}"/>'
                  f"<PlanarGeometry><PolyLoop>{loop}</PolyLoop></PlanarGeometry></Surface>\n")
    spaces = "".join(f'<Space id="R{i}_{j}"><Volume>75</Volume><Area>25</Area></Space>'
                     for i in range(n_x) for j in range(n_y))
    gbxml = (f'<?xml version="1.0"?>\n<gbXML xmlns="http://www.gbxml.org/schema" lengthUnit="Meters"><Campus id="c">'
             f'<Building id="b">{spaces}</Building>\n{"".join(gb)}</Campus></gbXML>\n')
    return {"IDF *:Detailed (before)": (".idf", "".join(detailed).encode()),
            "IDF simple geometry": (".idf", "".join(simple).encode()),
            "epJSON simple geometry": (".epJSON", json.dumps(epjson).encode()),
            "gbXML": (".xml", gbxml.encode())}


def formats(n_x: int, n_y: int) -> None:
    """Reading the same rooms from each format, in this run: CPU seconds (best of 3) and peak memory of
    the reader, and the solve of what it read (every room must close at 75 m³)."""
    from plantsolve.solvers.base import StoredInput  # noqa: PLC0415
    from plantsolve.solvers.polyhedra.upload import parse_upload  # noqa: PLC0415

    print(f"\n{n_x * n_y} rooms of 5 x 5 x 3 m, {6 * n_x * n_y} faces, in each format:\n")
    print("| format | file [kB] | read CPU [s] | read peak [MiB] | solve CPU [s] | rooms closed at 75 m³ |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for label, (ext, content) in format_texts(n_x, n_y).items():
        def read(ext=ext, content=content):
            return parse_upload(StoredInput.from_bytes(f"b{ext}", content), None)
        t_read, request = timed(read)
        mem = peak(read)
        t_solve, result = timed(lambda request=request: solve(request).result, reps=1)
        good = sum(1 for z in result.zones if z.volume is not None and abs(z.volume - 75) < 1e-6)
        print(f"| {label} | {len(content) / 1000:.0f} | {t_read:.3f} | {mem:.1f} | {t_solve:.3f} | {good} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--before", type=Path, help="a checkout of other code (with its .venv) measured beside this one")
    parser.add_argument("--mesh-only", action="store_true", help="skip the buildings")
    parser.add_argument("--formats-only", action="store_true", help="only the same rooms read from each format")
    parser.add_argument("--end-to-end-only", action="store_true",
                        help="only the mesh through `plantsolve solve` beside trimesh reading the file")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each end-to-end row (median CPU, largest RSS)")
    args = parser.parse_args()
    if args.formats_only:
        formats(*((10, 10) if args.quick else (30, 30)))
        return
    if not (args.mesh_only or args.end_to_end_only):
        buildings(["10", "100"] if args.quick else list(BUILDINGS))
        formats(*((10, 10) if args.quick else (30, 30)))
    size = (500, 100) if args.quick else (1000, 500)
    checkouts = {"this": REPO, **({"before": args.before.resolve()} if args.before else {})}
    if not args.end_to_end_only:
        mesh(*size)
        fresh_analysis(*size, checkouts)
    end_to_end(*size, checkouts, args.repeats)


if __name__ == "__main__":
    main()
