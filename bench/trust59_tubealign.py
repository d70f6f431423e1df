"""Alignment and tube mistakes of the trust59a session, in this tree and a reference checkout side by side (each tree
in a child process of its own, its code first on ``sys.path``; the inputs are this script's): what each answers, in
a word or two.

- PCF files as public viewers' samples write them: the header's UNITS records indented under PIPELINE-REFERENCE, a
  BEND whose CENTRE-POINT lies midway between its END-POINTs with ``ANGLE 90``, a 0.4 mm PIPE filling the gap
  between a flange and a bend, a BEND-RADIUS written as 0, a negative number or nan;
- a tube's coarse mesh (a CAD-style tessellation, read as samples on its faces) written with its faces shuffled, its
  corners rolled or its vertices renumbered: the same LRA?
- a PLY scan whose header declares an (empty) face element before the vertex element, or names the coordinates X Y Z;
- tube bend radius options that contradict each other (one of them silently won);
- a header-less scan writing an intensity before x, y, z;
- (trust59a2, the review) a PIPE typed twice where a weld meets a pipe (taken for a gap filler), one die with
  ``bend_radius_model: 'common'`` (refused), a whole-numbered x stepping down or before y, z and a reflectance
  written otherwise (left out as an attribute), a text column beside named x, y, z (refused as holding no rows),
  inspection tolerances without a nominal (ignored without a word).

    git -C /work/main worktree add --detach /work/wt/trust59a-ref main
    python bench/trust59_tubealign.py --ref /work/wt/trust59a-ref [--ref /work/wt/trust59a ...]
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import mistakes_table as table  # bench/, the script's folder, is first on sys.path; one BLAS thread

ROOT = Path(__file__).resolve().parent.parent

ROUTE = ("PIPE\n    END-POINT 0.0000 0.0000 0.0000 4.0000\n    END-POINT 1000.0000 0.0000 0.0000 4.0000\n"
         "BEND\n    END-POINT 1000.0000 0.0000 0.0000 4.0000\n    END-POINT 1152.4000 152.4000 0.0000 4.0000\n"
         "    CENTRE-POINT 1152.4000 0.0000 0.0000\n"
         "PIPE\n    END-POINT 1152.4000 152.4000 0.0000 4.0000\n    END-POINT 1152.4000 1152.4000 0.0000 4.0000\n")
HEADER = "PIPELINE-REFERENCE LINE-100\n    PIPING-SPEC CS150\n"
RETURN = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
          "PIPE\n    END-POINT 0.0 0.0 0.0 400.0\n    END-POINT 2000.0 0.0 0.0 400.0\n"
          "BEND\n    END-POINT 2000.0 0.0 0.0 400.0\n    END-POINT 2000.0 1000.0 0.0 400.0\n"
          "    CENTRE-POINT 2000.0 500.0 0.0\n    ANGLE {angle}\n    BEND-RADIUS 500.0\n"
          "PIPE\n    END-POINT 2000.0 1000.0 0.0 400.0\n    END-POINT 0.0 1000.0 0.0 400.0\n")
FILLER = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
          "FLANGE\n    END-POINT 0.0000 -263.8250 0.0000 152.4000\n    END-POINT 0.0000 -413.0490 0.0000 152.4000\n"
          "PIPE\n    END-POINT 0.0000 -413.0490 0.0000 152.4000\n    END-POINT 0.0000 -413.4490 0.0000 152.4000\n"
          "BEND\n    END-POINT 0.0000 -413.4490 0.0000 152.4000\n    END-POINT -228.6000 -642.0490 0.0000 152.4000\n"
          "    CENTRE-POINT 0.0000 -642.0490 0.0000\n"
          "PIPE\n    END-POINT -228.6000 -642.0490 0.0000 152.4000\n    END-POINT -1228.6000 -642.0490 0.0000 152.4000\n")
ELBOW = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
         "PIPE\n    END-POINT 0.0 0.0 0.0 100.0\n    END-POINT 1000.0 0.0 0.0 100.0\n"
         "ELBOW\n    END-POINT 1000.0 0.0 0.0 100.0\n    END-POINT 1152.4 152.4 0.0 100.0\n"
         "    CENTRE-POINT 1152.4 0.0 0.0\n    BEND-RADIUS {radius}\n"
         "PIPE\n    END-POINT 1152.4 152.4 0.0 100.0\n    END-POINT 1152.4 1152.4 0.0 100.0\n")
TYPED_TWICE = ("UNITS-BORE MM\nUNITS-CO-ORDS MM\n"
               "PIPE\n    END-POINT 0.0 0.0 0.0 100.0\n    END-POINT 1000.0 0.0 0.0 100.0\n"
               "WELD\n    END-POINT 1000.0 0.0 0.0 100.0\n    END-POINT 1000.0 0.0 0.0 100.0\n"
               "PIPE\n    END-POINT 1000.0 0.0 0.0 100.0\n    END-POINT {far} 0.0 0.0 100.0\n"
               "ELBOW\n    END-POINT 2000.0 0.0 0.0 100.0\n    END-POINT 2152.4 152.4 0.0 100.0\n"
               "    CENTRE-POINT 2152.4 0.0 0.0\n"
               "PIPE\n    END-POINT 2152.4 152.4 0.0 100.0\n    END-POINT 2152.4 1152.4 0.0 100.0\n")
WATCHED = ("pcf_units_assumed", "pcf_bore_units", "pcf_records_contradict_points", "pcf_zero_length_pipe",
           "implausible_fitting_span")


def _pcf_cases():
    from plantsolve.solvers.alignment.solve import solve
    from plantsolve.solvers.alignment.upload import parse_upload
    from plantsolve.solvers.base import InputRejected, StoredInput

    def said(text: str, what: str = "codes") -> str:
        try:
            request = parse_upload(StoredInput.from_bytes("line.pcf", text.encode()), None)
        except InputRejected as refused:
            return "422 " + refused.errors[0].msg[:60]
        codes = [w.code for w in solve(request).result.report.warnings if w.code in WATCHED]
        radius = f"radius {request.components[0].radius:g} mm; " if what == "radius" else ""
        return radius + (", ".join(codes) if codes else "no word")

    yield "PCF: UNITS-BORE INCH indented under PIPELINE-REFERENCE, 4 in bores", said(
        HEADER + "    UNITS-BORE INCH\n    UNITS-CO-ORDS MM\n" + ROUTE, "radius")
    yield "PCF: UNITS-CO-ORDS FURLONG indented", said(HEADER + "    UNITS-CO-ORDS FURLONG\n" + ROUTE)
    yield "PCF: return bend's points, ANGLE 90", said(RETURN.format(angle="90.0"))
    yield "PCF: return bend's points, ANGLE 18000 (guard)", said(RETURN.format(angle="18000"))
    yield "PCF: 0.4 mm pipe between flange and bend", said(FILLER)
    yield "PCF: 0.4 mm pipe, far end meets nothing (guard)", said(
        FILLER.replace("-413.4490 0.0000 152.4000\n    END-POINT -228.6000",
                       "-433.4490 0.0000 152.4000\n    END-POINT -228.6000"))
    for radius in ("0", "-152.4", "nan", "152.4"):
        yield f"PCF: elbow BEND-RADIUS {radius}", said(ELBOW.format(radius=radius))
    for far, what in (("1000.0", "typed twice where a weld meets a pipe"), ("2000.0", "as meant (guard)")):
        yield f"PCF: pipe {what}", said(TYPED_TWICE.format(far=far))


def _mesh_cases():
    import numpy as np
    import trimesh

    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.tube.model import sample_centreline
    from plantsolve.solvers.tube.solve import solve
    from plantsolve.solvers.tube.synthetic import make_model
    from plantsolve.solvers.tube.upload import parse_upload

    r, around = 6.0, 16
    centre, tangent = sample_centreline(make_model([[80.0, 0.0, 90.0, 30.0], [60.0, 90.0, 45.0, 30.0],
                                                    [70.0, 0.0, 0.0, 0.0]], r), 6.0)
    normal = [np.cross(tangent[0], [0.0, 0.0, 1.0])]
    for t in tangent[1:]:
        n = normal[-1] - (normal[-1] @ t) * t
        normal.append(n / np.linalg.norm(n))
    normal = np.array(normal) / np.linalg.norm(normal[0])
    binormal = np.cross(tangent, normal)
    a = np.linspace(0.0, 2.0 * np.pi, around, endpoint=False)
    vertices = (centre[:, None] + r * (np.cos(a)[None, :, None] * normal[:, None]
                                       + np.sin(a)[None, :, None] * binormal[:, None])).reshape(-1, 3)
    faces = np.array([f for i in range(len(centre) - 1) for j in range(around)
                      for f in ([i * around + j, i * around + (j + 1) % around, (i + 1) * around + j],
                                [i * around + (j + 1) % around, (i + 1) * around + (j + 1) % around,
                                 (i + 1) * around + j])])

    def lra(v, f):
        data = trimesh.Trimesh(v, f, process=False).export(file_type="stl")
        result = solve(parse_upload(StoredInput.from_bytes("tube.stl", data), None)).result
        return np.array([[row.length, row.rotation, row.angle, row.bend_radius] for row in result.lra])

    clean = lra(vertices, faces)
    rng = np.random.default_rng(59)
    new_of_old = rng.permutation(len(vertices))
    renumbered = np.empty_like(vertices)
    renumbered[new_of_old] = vertices
    for what, (v, f) in (("faces shuffled", (vertices, faces[rng.permutation(len(faces))])),
                         ("corners rolled", (vertices, np.roll(faces, 1, axis=1))),
                         ("vertices renumbered", (renumbered, new_of_old[faces]))):
        other = lra(v, f)
        gap = float(np.max(np.abs(other - clean))) if other.shape == clean.shape else float("inf")
        yield f"tube: coarse STL mesh, {what}", "same LRA" if gap == 0 else f"LRA differs by up to {gap:.3g}"


def _ply_cases():
    import struct

    import numpy as np

    from plantsolve.solvers.base import InputRejected, StoredInput
    from plantsolve.solvers.tube.upload import parse_upload

    points = np.loadtxt(ROOT / "examples" / "tube" / "scan.xyz")

    def said(header: str, body: bytes) -> str:
        try:
            read = np.asarray(parse_upload(StoredInput.from_bytes("scan.ply", header.encode() + body), None).points)
        except InputRejected as refused:
            return "422 " + refused.errors[0].msg[:50]
        return "the scan's points" if np.allclose(read, points, atol=1e-3) else f"{len(read)} other points"

    vertex = f"element vertex {len(points)}\nproperty float x\nproperty float y\nproperty float z\n"
    face = "element face 0\nproperty list uchar int vertex_indices\n"
    text = "".join(f"{x:.3f} {y:.3f} {z:.3f}\n" for x, y, z in points).encode()
    binary = b"".join(struct.pack("<3f", *p) for p in points)
    yield "PLY ascii: empty face element before the vertices", said(
        "ply\nformat ascii 1.0\n" + face + vertex + "end_header\n", text)
    yield "PLY binary: empty face element before the vertices", said(
        "ply\nformat binary_little_endian 1.0\n" + face + vertex + "end_header\n", binary)
    yield "PLY ascii: coordinates named X Y Z", said(
        "ply\nformat ascii 1.0\n" + vertex.replace(" x\n", " X\n").replace(" y\n", " Y\n").replace(" z\n", " Z\n")
        + "end_header\n", text)


def _option_cases():
    from plantsolve.solvers.base import InputRejected, StoredInput
    from plantsolve.solvers.tube.upload import parse_upload

    xyz = (ROOT / "examples" / "tube" / "scan.xyz").read_bytes()
    for options in ({"bend_radius": 18, "dies": [18, 30]}, {"common_bend_radius": True, "bend_radius_model": "per_bend"},
                    {"dies": [18, 30], "bend_radius_model": "common"}, {"bend_radius": 18, "bend_radius_model": "common"},
                    {"dies": [18], "bend_radius_model": "common"}, {"dies": [18], "bend_radius": 18},
                    {"dies": [18], "bend_radius": 20}):
        try:
            parse_upload(StoredInput.from_bytes("scan.xyz", xyz), options)
            said = "accepted"
        except InputRejected as refused:
            said = "422 " + ".".join(map(str, refused.errors[0].loc))
        yield f"tube options {json.dumps(options)}", said


def _column_cases():
    import numpy as np

    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.tube.solve import solve
    from plantsolve.solvers.tube.upload import parse_upload

    points = np.loadtxt(ROOT / "examples" / "tube" / "scan.xyz")
    intensity = np.random.default_rng(59).integers(0, 4096, len(points))
    for what, text in (("intensity x y z", "".join(f"{i} {x:.3f} {y:.3f} {z:.3f}\n"
                                                   for i, (x, y, z) in zip(intensity, points))),
                       ("x y z intensity (guard)", "".join(f"{x:.3f} {y:.3f} {z:.3f} {i}\n"
                                                           for i, (x, y, z) in zip(intensity, points)))):
        result = solve(parse_upload(StoredInput.from_bytes("scan.xyz", text.encode()), None)).result
        codes = [w.code for w in result.report.warnings]
        yield f"tube: header-less {what}", (f"{len(result.lra) - 1} bends, r {result.pipe_radius:.3g}, status "
                                           f"{result.report.status}" + (f" ({', '.join(codes)})" if codes else ""))


def _review_column_cases():
    import numpy as np

    from plantsolve.solvers.base import InputRejected, StoredInput
    from plantsolve.solvers.tube.upload import parse_upload

    points = np.loadtxt(ROOT / "examples" / "tube" / "scan.xyz")
    rng = np.random.default_rng(592)

    def read(name: str, text: str, meant: np.ndarray) -> str:
        try:
            request = parse_upload(StoredInput.from_bytes(name, text.encode()), None)
        except InputRejected as refused:
            return "422 " + refused.errors[0].msg[:50]
        got = np.asarray(request.points)
        codes = [w.code for w in request.source.warnings]
        right = got.shape == meant.shape and np.allclose(got, meant, atol=1e-3)
        return ("the file's x, y, z" if right else "other points") + (f" ({', '.join(codes)})" if codes else "")

    steps = np.repeat(np.arange(199, -1, -1), 5).astype(float)
    a = rng.uniform(0.0, 2.0 * np.pi, len(steps))
    profile = np.c_[steps, 12.5 * np.cos(a), 12.5 * np.sin(a)].round(3)
    yield "tube: x y z r, whole x stepping down (a profile scanner)", read("scan.xyz", "".join(
        f"{x:.0f} {y:.3f} {z:.3f} {r:.3f}\n" for (x, y, z), r in zip(profile, rng.uniform(0.2, 0.9, len(steps)))),
        profile)
    whole_x = np.c_[np.round(points[:, 0]), points[:, 1:]]
    yield "tube: x y z r, whole x, r to 0.01", read("scan.xyz", "".join(
        f"{x:.0f} {y:.3f} {z:.3f} {r:.2f}\n" for (x, y, z), r in zip(whole_x, rng.uniform(0, 1, len(points)))),
        whole_x)
    yield "tube: x y z r, whole x, r (0 to 1) to 0.001 as y, z", read("scan.xyz", "".join(
        f"{x:.0f} {y:.3f} {z:.3f} {r:.3f}\n" for (x, y, z), r in zip(whole_x, rng.uniform(0, 1, len(points)))),
        whole_x)
    yield "tube: Point,X,Y,Z over P0,...", read("scan.csv", "Point,X,Y,Z\n" + "".join(
        f"P{k},{x:.3f},{y:.3f},{z:.3f}\n" for k, (x, y, z) in enumerate(points)), points)
    yield "tube: name x y z", read("scan.txt", "name x y z\n" + "".join(
        f"pt-{k} {x:.3f} {y:.3f} {z:.3f}\n" for k, (x, y, z) in enumerate(points)), points)


def _inspection_cases():
    from plantsolve.schemas.tube import TubeRequest
    from plantsolve.solvers.tube.solve import solve
    from plantsolve.solvers.tube.synthetic import example

    for options in ({"inspection_tolerances": {"angle": 0.2}}, {"damping": 0.8},
                    {"inspection_tolerances": {"angle": 0.2},
                     "nominal": [{"length": 30.0, "angle": 90.0, "bend_radius": 12.0}, {"length": 30.0}]}):
        result = solve(TubeRequest.model_validate({**example(), "options": options})).result
        codes = [w.code for w in result.report.warnings]
        yield f"tube options {json.dumps(options)[:60]}", (f"status {result.report.status}, "
                                                           f"inspection {'made' if result.inspection else 'none'}"
                                                           + (f" ({', '.join(codes)})" if codes else ""))


def main() -> None:
    args = table.arguments(__doc__, cases=False).parse_args()
    if args.child:
        logging.disable(logging.WARNING)
        table.case_lines((_pcf_cases, _mesh_cases, _ply_cases, _option_cases, _column_cases, _review_column_cases,
                          _inspection_cases))
        return
    trees = table.trees(args, __file__, key=table.by_case, mine="this tree", before=None)
    table.markdown(trees, ["case", "this tree"], lambda r: [r["case"], r["said"]], lambda ref: ref["said"], at=1,
                   key=table.by_case)


if __name__ == "__main__":
    main()
