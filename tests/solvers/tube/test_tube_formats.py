"""Scanner and CAD formats in (STL, OBJ, PLY meshes; LAS point clouds; E57 scans, with units) and the
DXF centreline out: read back and compared with what was written."""

from __future__ import annotations

import io
import struct
import tempfile

import numpy as np
import pytest
import trimesh

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube.artifacts import render_artifacts
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.upload import parse_upload
from plantsolve.solvers.tube.model import tube_mesh_arrays
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

ROWS = [(40, 0, 60, 12.0), (25, 45, 90, 16.0), (30, 0, 0, 0)]


def cloud(n=3000, seed=0):
    return surface_samples(make_model(ROWS, 4.0), n, np.random.default_rng(seed))


@pytest.mark.parametrize("file_type", ["stl", "obj", "ply"])
def test_meshes_give_their_vertices_or_samples_on_their_faces(file_type):
    verts, faces = tube_mesh_arrays(make_model(ROWS, 4.0))
    data = trimesh.Trimesh(verts, faces, process=False).export(file_type=file_type)
    data = data.encode() if isinstance(data, str) else data
    req = parse_upload(StoredInput.from_bytes(f"scan.{file_type.upper()}", data), {"pipe_radius": 4.0})
    pts = TubeScan(req).points
    if len(verts) >= 2000:  # a dense scan mesh: its vertices (STL repeats them per triangle)
        assert len(np.unique(pts.round(4), axis=0)) == len(np.unique(verts.round(4), axis=0))
    # every point lies on the tube surface
    res = solve(req).result
    assert len(res.lra) == 3 and res.residuals.max < 0.05
    coarse = trimesh.creation.cylinder(radius=4.0, height=80.0, sections=16)
    data = coarse.export(file_type=file_type)
    data = data.encode() if isinstance(data, str) else data
    pts = TubeScan(parse_upload(StoredInput.from_bytes(f"c.{file_type}", data), None)).points
    assert len(pts) == 20_000  # a coarse tessellation is sampled on its faces
    r = np.hypot(pts[:, 0], pts[:, 1])
    assert r.max() <= 4.0 + 1e-9


def _las_bytes(pts: np.ndarray, compress: bool = False) -> bytes:
    import laspy

    header = laspy.LasHeader(point_format=3, version="1.2")
    header.scales = np.array([1e-6, 1e-6, 1e-6])
    header.offsets = pts.min(axis=0)
    las = laspy.LasData(header)
    las.x, las.y, las.z = pts[:, 0], pts[:, 1], pts[:, 2]
    buf = io.BytesIO()
    las.write(buf, do_compress=compress)
    return buf.getvalue()


def test_las_point_cloud_with_declared_units():
    pts = cloud() / 1000.0  # metres in the file
    data = _las_bytes(pts)
    req = parse_upload(StoredInput.from_bytes("scan.las", data), {"file_units": "m", "pipe_radius": 4.0})
    assert np.allclose(TubeScan(req).points, pts * 1000.0, atol=2e-3)
    with pytest.raises(Exception) as e:
        parse_upload(StoredInput.from_bytes("scan.las", data), {"file_units": "furlong"})
    assert "file_units" in str(e.value)


def test_a_las_file_cut_short_reads_its_whole_points_and_says_so():
    """A LAS cut in transfer was refused as 'buffer size must be a multiple of element size'; it now reads as far
    as its whole point records go, like the other scan formats, with the declared and read counts."""
    pts = cloud() / 1000.0
    data = _las_bytes(pts)
    cut = data[:len(data) - 34 * 1000 - 17]  # point format 3: 34 bytes a record; the last one cut inside
    req = parse_upload(StoredInput.from_bytes("scan.las", cut), {"file_units": "m", "pipe_radius": 4.0})
    assert np.allclose(TubeScan(req).points, pts[:len(pts) - 1001] * 1000.0, atol=2e-3)
    (warning,) = [w for w in req.source.warnings if w.code == "file_truncated"]
    assert warning.details == {"declared": len(pts), "read": len(pts) - 1001} and req.source.truncated


def test_a_point_count_past_the_limit_is_refused_before_it_is_allocated_and_a_las_reads_what_it_holds():
    """A LAZ whose header was damaged to declare 4e9 points made laspy ask for 136 GB (a MemoryError here, a
    machine's memory where overcommit grants it); it is refused from its header. An uncompressed LAS with the same
    count holds only its records: those are read, with the declared and read counts."""
    import tracemalloc

    from plantsolve.solvers.base import InputRejected

    pts = cloud() / 1000.0
    for compress in (True, False):
        damaged = bytearray(_las_bytes(pts, compress))
        damaged[107:111] = np.uint32(4_000_000_000).tobytes()  # the point count of a LAS 1.2 header
        tracemalloc.start()
        try:
            if compress:
                with pytest.raises(InputRejected, match="declares 4,000,000,000 points"):
                    parse_upload(StoredInput.from_bytes("scan.laz", bytes(damaged)), {"file_units": "m"})
            else:
                req = parse_upload(StoredInput.from_bytes("scan.las", bytes(damaged)), {"file_units": "m"})
                (warning,) = [w for w in req.source.warnings if w.code == "file_truncated"]
                assert warning.details == {"declared": 4_000_000_000, "read": len(pts)}
            assert tracemalloc.get_traced_memory()[1] < 50 * 2**20
        finally:
            tracemalloc.stop()


def test_a_las_file_whose_points_leave_its_header_box_says_so():
    """A damaged x scale (1000 times the written one) misplaced every point silently; the header's box, which the
    writer computed from the same records, now tells. An intact file has no such warning."""
    pts = cloud() / 1000.0
    data = _las_bytes(pts)
    intact = parse_upload(StoredInput.from_bytes("scan.las", data), {"file_units": "m"})
    assert not [w for w in intact.source.warnings if w.code == "header_bounds_disagree"]
    damaged = bytearray(data)
    damaged[131:139] = np.float64(1e-3).tobytes()  # the x scale factor of a LAS 1.2 header
    req = parse_upload(StoredInput.from_bytes("scan.las", bytes(damaged)), {"file_units": "m"})
    (warning,) = [w for w in req.source.warnings if w.code == "header_bounds_disagree"]
    assert warning.details["axes"] == ["x"] and "x: points" in warning.message
    # a writer that stores the box in record units (the integers of the records, as laspy's test file
    # simple1_3.las has it): the points are where the scale puts them, so no warning
    raw = bytearray(data)
    offsets = pts.min(axis=0)
    lo, hi = np.round((pts.min(axis=0) - offsets) / 1e-6), np.round((pts.max(axis=0) - offsets) / 1e-6)
    for axis in range(3):  # LAS 1.2: max x, min x, max y, min y, max z, min z as doubles from byte 179
        raw[179 + 16 * axis:187 + 16 * axis] = np.float64(hi[axis]).tobytes()
        raw[187 + 16 * axis:195 + 16 * axis] = np.float64(lo[axis]).tobytes()
    quirk = parse_upload(StoredInput.from_bytes("scan.las", bytes(raw)), {"file_units": "m"})
    assert not [w for w in quirk.source.warnings if w.code == "header_bounds_disagree"]


def test_e57_scan_in_metres_by_its_standard():
    import pye57

    pts = cloud() / 1000.0
    with tempfile.NamedTemporaryFile(suffix=".e57") as handle:
        writer = pye57.E57(handle.name, mode="w")
        writer.write_scan_raw({"cartesianX": pts[:, 0], "cartesianY": pts[:, 1], "cartesianZ": pts[:, 2]})
        writer.close()
        data = open(handle.name, "rb").read()
    req = parse_upload(StoredInput.from_bytes("scan.e57", data), {"pipe_radius": 4.0})  # request units default mm
    assert np.allclose(TubeScan(req).points, pts * 1000.0, atol=1e-6)


def test_dxf_centreline_reads_back_as_the_segments():
    import ezdxf

    scan = TubeScan(TubeRequest.model_validate({"points": cloud().tolist(), "options": {"pipe_radius": 4.0}}))
    solved = solve(scan)
    res = solved.result
    dxf = next(a for a in render_artifacts(scan, solved) if a.name == "centreline.dxf")
    doc = ezdxf.read(io.StringIO(dxf.data.decode()))
    assert doc.units == 4  # millimetres
    msp = doc.modelspace()
    arcs = [e for e in msp if e.dxftype() == "ARC"]
    lines = [e for e in msp if e.dxftype() == "LINE"]
    segs = res.segments
    assert len(arcs) == sum(s.type == "arc" for s in segs) and len(lines) == sum(s.type == "line" for s in segs)
    for e, s in zip(arcs, [s for s in segs if s.type == "arc"]):
        assert np.allclose(e.start_point, s.start, atol=1e-6) and np.allclose(e.end_point, s.end, atol=1e-6)
        assert e.dxf.radius == pytest.approx(s.radius)
    (poly,) = [e for e in msp if e.dxftype() == "POLYLINE"]
    ends = [v.dxf.location for v in poly.vertices]
    assert np.allclose(ends[0], segs[0].start, atol=1e-6) and np.allclose(ends[-1], segs[-1].end, atol=1e-6)


@pytest.mark.parametrize("seed", [0, 1])
def test_random_bytes_named_stl_are_refused_as_no_stl(seed):
    """Random bytes read as a binary STL cut short: a 422 saying so (they were read and refused later as 'all
    points are coplanar', which sent the user looking at their scan)."""
    from plantsolve.solvers.base import InputRejected

    noise = np.random.default_rng(seed).bytes(20_000)
    with pytest.raises(InputRejected, match="not a binary STL"):
        TubeScan(parse_upload(StoredInput.from_bytes("noise.stl", noise), None))


@pytest.mark.parametrize("scale", [0.0, float("nan")])
def test_a_las_header_with_a_scale_of_zero_or_nan_is_refused_naming_the_scale(scale):
    data = bytearray(_las_bytes(cloud() / 1000.0))
    struct.pack_into("<d", data, 131, scale)  # the x scale factor of the public header block
    # before: "all points coincide" (scale 0) or "every point has a non-finite coordinate" (NaN): not why
    with pytest.raises(InputRejected, match=r"the LAS header's scale factors are (0|nan), 1e-06, 1e-06 \(x, y, z\)"):
        parse_upload(StoredInput.from_bytes("scan.las", bytes(data)), {"file_units": "m"})
