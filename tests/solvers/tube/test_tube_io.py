"""Uploads, input validation and artifacts."""

import base64
import csv
import io
import json

import numpy as np
import pytest
import trimesh
from pydantic import ValidationError

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.tube import SPEC, __version__
from plantsolve.solvers.tube.artifacts import render_artifacts
from plantsolve.solvers.tube.scan import TubeScan
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.upload import parse_upload
from plantsolve.solvers.tube.validation import check_input
from plantsolve.solvers.tube.model import build_spine, model_from_control_polygon, spine_distance


@pytest.fixture(scope="module")
def cloud():
    from plantsolve.solvers.tube.synthetic import make_model, surface_samples

    m = make_model([[30, 0, 90, 12], [20, 45, 60, 10], [25, 0, 0, 0]], 4.0)
    return m, surface_samples(m, 3000, np.random.default_rng(0), noise=0.02)


def _npy_bytes(a):
    buf = io.BytesIO()
    np.save(buf, a)
    return buf.getvalue()


def test_public_contract():
    assert SPEC.upload_extensions == (".ply", ".stl", ".obj", ".e57", ".las", ".laz", ".xyz", ".csv", ".txt", ".npy",
                                      ".json")
    assert SPEC.soft_time_limit < SPEC.time_limit and isinstance(__version__, str)
    assert isinstance(SPEC.input_of(TubeRequest(points=[[0.0, 0.0, 0.0]] * 3)), TubeScan)


@pytest.mark.parametrize("fmt", ["ply_ascii", "ply_binary", "xyz", "csv", "txt", "npy", "json_request", "json_list"])
def test_parse_upload_formats(cloud, fmt):
    _, pts = cloud
    opts = {"tolerance": 0.3}
    if fmt.startswith("ply"):
        data = trimesh.PointCloud(pts).export(file_type="ply", encoding="ascii" if fmt == "ply_ascii" else "binary")
        name = "Scan.PLY"
    elif fmt == "xyz":
        data = "\n".join(" ".join(f"{v:.17g}" for v in p) for p in pts).encode()
        name = "scan.xyz"
    elif fmt == "csv":
        data = ("x,y,z\n" + "\n".join(",".join(f"{v:.17g}" for v in p) for p in pts)).encode()
        name = "scan.CSV"
    elif fmt == "txt":
        data = ("# scanner export\n" + "\n".join("\t".join(f"{v:.17g}" for v in p) for p in pts)).encode()
        name = "scan.txt"
    elif fmt == "npy":
        data, name = _npy_bytes(pts), "scan.npy"
    elif fmt == "json_request":
        data, name = json.dumps({"points": pts.tolist(), "units": "in"}).encode(), "req.json"
    else:
        data, name = json.dumps(pts.tolist()).encode(), "pts.json"
    req = parse_upload(StoredInput.from_bytes(name, data), opts)
    got = TubeScan(req).points
    tol = 1e-5 if fmt.startswith("ply") else 1e-12  # PLY export stores float32
    np.testing.assert_allclose(got, pts, rtol=tol, atol=tol)
    assert req.options.tolerance == 0.3
    if fmt == "json_request":
        assert req.units == "in"


def test_large_upload_travels_as_npy_base64():
    pts = np.random.default_rng(0).normal(size=(30_000, 3))
    req = parse_upload(StoredInput.from_bytes("big.npy", _npy_bytes(pts)), None)
    assert not isinstance(req.points, list)
    np.testing.assert_array_equal(TubeScan(req).points, pts)


@pytest.mark.parametrize("name,data,needle", [
    ("scan.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n", "PLY"),
    ("scan.xyz", b"1 2\n4 5 six\n", "lines 1, 2"),
    ("scan.xyz", b"1 2\n", "3 coordinates"),
    ("scan.csv", b"1,2,nan\n" * 200, "non-finite"),
    ("scan.npy", b"not an npy", "NPY"),
    ("scan.json", b"{not json", "JSON"),
    ("scan.stl", b"solid x", "no vertices"),
    ("scan.txt", b"\xff\xfe\x00", "UTF-8"),
])
def test_unreadable_files_are_rejected_with_reason(name, data, needle):
    with pytest.raises(InputRejected) as exc:
        parse_upload(StoredInput.from_bytes(name, data), None)
    assert exc.value.errors[0].loc[0] == "file"
    assert needle.lower() in exc.value.errors[0].msg.lower()


def test_bad_points_rejected():
    line = np.column_stack([np.linspace(0, 1, 200), np.zeros(200), np.zeros(200)])
    plane = np.random.default_rng(0).uniform(size=(200, 3)) * [1, 1, 0]
    for pts, needle in [(line, "line"), (plane, "coplanar"), (np.ones((50, 3)), "at least")]:
        with pytest.raises(InputRejected) as exc:
            check_input(TubeScan(TubeRequest(points=pts.tolist())))
        assert exc.value.errors[0].loc[0] == "points" and needle in exc.value.errors[0].msg
    with pytest.raises(ValidationError):
        TubeRequest(points=[[0, 0, float("nan")]] * 200)
    with pytest.raises(ValidationError):
        TubeRequest(points=[[0, 0, float("inf")]] * 200)
    # NPY payloads are decoded by the solver (schemas hold types, not codecs): the check that
    # runs at submission rejects them, naming the field
    bad = np.ones((200, 3)); bad[5, 1] = np.nan
    for payload, needle in [(_npy_bytes(bad), "non-finite"), (b"garbage", "NPY")]:
        with pytest.raises(InputRejected) as exc:
            check_input(TubeScan(TubeRequest(points={"npy_base64": base64.b64encode(payload).decode()})))
        assert exc.value.errors[0].loc == ("points",) and needle in exc.value.errors[0].msg
    with pytest.raises(ValidationError):
        TubeRequest(points=[[0, 0, 0]] * 200, options={"unknown": 1})


def test_check_input_nominal_and_radius_fields(cloud):
    _, pts = cloud
    req = TubeRequest(points=pts.tolist(), options={
        "pipe_radius": 4.0, "bend_radius": 2.0,
        "nominal": [{"length": 10, "rotation": 5, "angle": 0, "bend_radius": 0}, {"length": 5, "angle": 30}]})
    with pytest.raises(InputRejected) as exc:
        check_input(TubeScan(req))
    locs = {e.loc for e in exc.value.errors}
    assert ("options", "bend_radius") in locs
    assert ("options", "nominal", 0, "rotation") in locs
    assert ("options", "nominal", 0, "angle") in locs
    assert ("options", "nominal", 1, "angle") in locs


def test_artifacts(cloud):
    m, pts = cloud
    scan = TubeScan(TubeRequest(points=pts.tolist()))
    before = scan.request.model_dump()
    solved = solve(scan)
    res = solved.result
    res_before = res.model_dump()
    arts = render_artifacts(scan, solved)
    assert scan.request.model_dump() == before and res.model_dump() == res_before
    by = {a.name: a for a in arts}
    assert set(by) == {"tube.stl", "tube.glb", "deviation.ply", "lra.csv", "xyz_clr.csv", "centreline.dxf",
                       "overview.png"}
    assert by["overview.png"].data[:8] == b"\x89PNG\r\n\x1a\n" and by["overview.png"].media_type == "image/png"
    assert by["tube.stl"].media_type == "model/stl" and by["tube.glb"].media_type == "model/gltf-binary"
    mesh = trimesh.load(io.BytesIO(by["tube.stl"].data), file_type="stl")
    d, _ = spine_distance(mesh.vertices, build_spine(m))
    assert np.abs(d - 4.0).max() < 0.05  # the mesh is the reconstructed tube
    glb = trimesh.load(io.BytesIO(by["tube.glb"].data), file_type="glb")
    assert len(glb.geometry) == 1
    ply = trimesh.load(io.BytesIO(by["deviation.ply"].data), file_type="ply")
    assert len(ply.vertices) == len(pts) and ply.colors.shape == (len(pts), 4)
    rows = list(csv.reader(io.StringIO(by["lra.csv"].data.decode())))
    assert rows[0][1] == "length [mm]"
    np.testing.assert_allclose([float(r[3]) for r in rows[1:]], [r.angle for r in res.lra], atol=1e-6)
    xyz = list(csv.reader(io.StringIO(by["xyz_clr.csv"].data.decode())))[1:]
    P = np.array([[float(v) for v in r[1:4]] for r in xyz])
    clr = np.array([float(r[4]) for r in xyz[1:-1]])
    back = model_from_control_polygon(P, clr)
    np.testing.assert_allclose(np.degrees(back.angles), [r.angle for r in res.lra[:-1]], atol=1e-4)
    np.testing.assert_allclose(back.lengths, [r.length for r in res.lra], atol=1e-4)


def test_progress_is_reported_and_cancellation_propagates(cloud):
    from plantsolve.solvers.base import Cancelled

    _, pts = cloud
    seen = []

    def prog(f, msg=""):
        seen.append(f)
        if f > 0.5:
            raise Cancelled()

    with pytest.raises(Cancelled):
        solve(TubeRequest(points=pts.tolist()), prog)
    assert seen == sorted(seen) and len(seen) >= 4


def test_points_are_decoded_once_per_scan(cloud):
    _, pts = cloud
    npy = {"npy_base64": base64.b64encode(_npy_bytes(pts)).decode()}
    req = TubeRequest(points=npy)
    scan = TubeScan(req)
    first = scan.points
    assert scan.points is first and not first.flags.writeable  # one decode per scan, shared read-only
    np.testing.assert_array_equal(first, pts)
    assert req == TubeRequest(points=npy)  # the request holds no decoded state
    moved = req.model_copy(update={"points": (pts + 1.0).tolist()})
    np.testing.assert_array_equal(TubeScan(moved).points, pts + 1.0)  # a scan of other points decodes them
    req.points = [[0.0, 0.0, 0.0]] * 3
    assert TubeScan(req).points.shape == (3, 3)
