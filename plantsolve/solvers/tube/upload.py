"""Reading samples: request ``points`` (JSON list or base64 NPY) and uploaded files."""

from __future__ import annotations

import base64
import binascii
import io
import json
import re

import numpy as np
from pydantic import ValidationError

from plantsolve.schemas.tube import MAX_POINTS, NpyPoints, TubeRequest
from plantsolve.solvers.base import FieldError, InputRejected, reject

UPLOAD_EXTENSIONS = (".ply", ".stl", ".obj", ".e57", ".las", ".laz", ".xyz", ".csv", ".txt", ".npy", ".json")
TO_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8}
# a mesh with fewer vertices than this is a CAD-style tessellation: its faces are sampled instead
MESH_MIN_VERTICES = 2000
MESH_SAMPLES = 20_000
INLINE_LIST_MAX = 20_000  # larger uploads travel inside the request as base64 NPY


class _DecodedPoints:
    """The decoded array of one ``points`` value, kept on the request. It remembers the value it
    came from (a request copied with other points, or given new ones, decodes again) and is
    invisible to equality: two requests with the same points compare equal, decoded or not."""

    __slots__ = ("source", "array")

    def __init__(self, source: object, array: np.ndarray):
        self.source, self.array = source, array

    def __eq__(self, other: object) -> bool:
        return True

    __hash__ = None  # type: ignore[assignment]


def request_points(request: TubeRequest) -> np.ndarray:
    """The samples of a request as an (N, 3) float64 array, decoded once per request object
    (checks, solve and artifacts share it; read-only so that no stage edits another's input).
    A bad NPY payload raises ValueError with the reason."""
    cached = request._points_array
    if isinstance(cached, _DecodedPoints) and cached.source is request.points:
        return cached.array
    if isinstance(request.points, NpyPoints):
        array = decode_npy_points(request.points.npy_base64)
    else:
        array = np.asarray(request.points, dtype=np.float64).reshape(-1, 3)
    array.setflags(write=False)
    request._points_array = _DecodedPoints(request.points, array)
    return array


def decode_npy_points(value: str) -> np.ndarray:
    """Decode a base64 NPY string into an (N, 3) float64 array; ValueError with a reason."""
    try:
        raw = base64.b64decode(value, validate=False)
    except (binascii.Error, ValueError) as exc:
        raise ValueError(f"not valid base64: {exc}") from None
    try:
        arr = np.load(io.BytesIO(raw), allow_pickle=False)
    except Exception as exc:  # numpy raises several types for corrupt headers
        raise ValueError(f"not a readable NPY array: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"NPY array must have shape (N, 3), got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.number):
        raise ValueError(f"NPY array must be numeric, got dtype {arr.dtype}")
    if arr.shape[0] > MAX_POINTS:
        raise ValueError(f"at most {MAX_POINTS} points are accepted, got {arr.shape[0]}")
    arr = np.asarray(arr, dtype=np.float64)
    if not np.isfinite(arr).all():
        bad = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
        raise ValueError(f"NPY array holds non-finite values (first at row {bad})")
    return arr


def points_field(pts: np.ndarray):
    """The ``points`` value for an array: a JSON list when small, base64 NPY otherwise."""
    if len(pts) <= INLINE_LIST_MAX:
        return pts.tolist()
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(pts, dtype=np.float64))
    return {"npy_base64": base64.b64encode(buf.getvalue()).decode("ascii")}


def _read_mesh(content: bytes, file_type: str) -> np.ndarray:
    """Scanner exports as meshes (STL, OBJ, PLY) or point clouds (PLY): the vertices, or, for a sparse
    CAD-style tessellation, samples on its faces (seeded, so the same file gives the same points)."""
    import trimesh

    try:
        geom = trimesh.load(io.BytesIO(content), file_type=file_type, process=False)
    except Exception as exc:  # trimesh raises many types on corrupt files
        raise reject(f"unreadable {file_type.upper()} file: {exc}") from None
    parts = list(geom.geometry.values()) if isinstance(geom, trimesh.Scene) else [geom]
    meshes = [g for g in parts if isinstance(g, trimesh.Trimesh) and len(g.faces)]
    verts = [np.asarray(g.vertices) for g in parts if getattr(g, "vertices", None) is not None]
    n_verts = sum(len(v) for v in verts)
    if meshes and n_verts < MESH_MIN_VERTICES:
        mesh = trimesh.util.concatenate(meshes)
        if mesh.area > 0:
            pts, _ = trimesh.sample.sample_surface(mesh, MESH_SAMPLES, seed=0)
            return np.asarray(pts, dtype=np.float64)
    if not verts:
        raise reject(f"{file_type.upper()} file holds no vertices")
    return np.vstack(verts).astype(np.float64)


def _read_ply(content: bytes) -> np.ndarray:
    return _read_mesh(content, "ply")


def _read_las(content: bytes) -> np.ndarray:
    """LAS/LAZ point clouds (laspy; LAZ needs a LAZ backend such as lazrs): scaled x, y, z."""
    import laspy

    try:
        las = laspy.read(io.BytesIO(content))
    except Exception as exc:  # laspy raises its own and OS errors on corrupt files
        raise reject(f"unreadable LAS/LAZ file: {exc}") from None
    return np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)]).astype(np.float64)


def _read_e57(content: bytes) -> np.ndarray:
    """E57 scans (pye57): every scan's cartesian points, each in world coordinates (its pose applied)."""
    import tempfile

    import pye57

    with tempfile.NamedTemporaryFile(suffix=".e57") as handle:
        handle.write(content)
        handle.flush()
        try:
            e57 = pye57.E57(handle.name)
            scans = [e57.read_scan(i, ignore_missing_fields=True, transform=True) for i in range(e57.scan_count)]
        except Exception as exc:  # libE57 raises its own errors on corrupt files
            raise reject(f"unreadable E57 file: {exc}") from None
    parts = [np.column_stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]]) for d in scans
             if "cartesianX" in d]
    if not parts:
        raise reject("E57 file holds no cartesian points")
    return np.vstack(parts).astype(np.float64)


_SPLIT = re.compile(r"[,;\s]+")


def _read_text(content: bytes) -> np.ndarray:
    try:
        text = content.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise reject("text file is not UTF-8") from None
    rows = []
    for lineno, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s[0] in "#/%":
            continue
        fields = [f for f in _SPLIT.split(s) if f]
        try:
            vals = [float(f) for f in fields[:3]]
        except ValueError:
            if not rows:  # a header line
                continue
            raise reject(f"line {lineno}: expected numbers 'x y z', got {s[:60]!r}") from None
        if len(vals) < 3:
            raise reject(f"line {lineno}: expected 3 coordinates, got {len(vals)}")
        rows.append(vals)
    if not rows:
        raise reject("no 'x y z' rows found")
    return np.array(rows, dtype=np.float64)


def _read_npy(content: bytes) -> np.ndarray:
    try:
        arr = np.load(io.BytesIO(content), allow_pickle=False)
    except Exception as exc:
        raise reject(f"unreadable NPY file: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] < 3 or not np.issubdtype(arr.dtype, np.number):
        raise reject(f"NPY array must be numeric with shape (N, 3), got {arr.shape} {arr.dtype}")
    return np.asarray(arr[:, :3], dtype=np.float64)


def parse_upload(filename: str, content: bytes, options: dict | None) -> TubeRequest:
    """Uploaded scan → :class:`TubeRequest` (format from the extension, case-insensitive)."""
    name = (filename or "").lower()
    ext = next((e for e in UPLOAD_EXTENSIONS if name.endswith(e)), None)
    if ext is None:
        raise reject(f"unsupported file type {filename!r}; accepted: {', '.join(UPLOAD_EXTENSIONS)}")
    units = None
    opts = dict(options or {})
    if "units" in opts:  # tolerate units passed among the options
        units = opts.pop("units")
    file_units = opts.pop("file_units", None)
    if file_units is not None and file_units not in TO_MM:
        raise InputRejected([FieldError(("options", "file_units"), f"unknown unit {file_units!r}; one of "
                                        f"{', '.join(TO_MM)}")])
    if ext == ".json":
        try:
            doc = json.loads(content.decode("utf-8-sig"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise reject(f"invalid JSON: {exc}") from None
        if isinstance(doc, list):
            doc = {"points": doc}
        if not isinstance(doc, dict):
            raise reject("JSON must be a request object or a list of [x, y, z]")
        body = dict(doc)
        body["options"] = {**(body.get("options") or {}), **opts}
        if units:
            body["units"] = units
    else:
        reader = {".ply": _read_ply, ".npy": _read_npy, ".stl": lambda c: _read_mesh(c, "stl"),
                  ".obj": lambda c: _read_mesh(c, "obj"), ".las": _read_las, ".laz": _read_las,
                  ".e57": _read_e57}.get(ext, _read_text)
        pts = reader(content)
        # the file's length unit: declared (options.file_units), E57's metres by its standard, else the request's
        declared = file_units or ("m" if ext == ".e57" else None)
        if declared is not None:
            target = units or "mm"
            if target not in TO_MM:
                raise InputRejected([FieldError(("options", "units"), f"unknown unit {target!r}")])
            pts = pts * (TO_MM[declared] / TO_MM[target])
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
            raise reject("file holds no 3D points")
        if not np.isfinite(pts).all():
            bad = int(np.flatnonzero(~np.isfinite(pts).all(1))[0])
            raise reject(f"non-finite coordinate in point {bad}")
        body = {"points": points_field(pts), "options": opts}
        if units:
            body["units"] = units
    try:
        return TubeRequest.model_validate(body)
    except ValidationError as exc:
        errs = [FieldError(loc=("file",) + tuple(e["loc"]) if ext == ".json" and e["loc"][:1] == ("points",)
                           else tuple(e["loc"]), msg=e["msg"]) for e in exc.errors()]
        raise InputRejected(errs) from None
