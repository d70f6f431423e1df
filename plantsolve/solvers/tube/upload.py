"""Uploaded scan files read into a request; large point sets travel in it as base64 NPY (decoded by ``scan``)."""

from __future__ import annotations

import base64
import io
import json
import re
from dataclasses import replace

import numpy as np

from plantsolve.schemas.tube import TubeRequest
from plantsolve.solvers.base import FieldError, InputRejected, StoredInput, reject, validated

UPLOAD_EXTENSIONS = (".ply", ".stl", ".obj", ".e57", ".las", ".laz", ".xyz", ".csv", ".txt", ".npy", ".json")
TO_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8}
# a mesh with fewer vertices than this is a CAD-style tessellation: its faces are sampled instead
MESH_MIN_VERTICES = 2000
MESH_SAMPLES = 20_000
INLINE_LIST_MAX = 20_000  # larger uploads travel inside the request as base64 NPY


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


def _read_las(content: bytes) -> np.ndarray:
    """LAS/LAZ point clouds (laspy; LAZ needs a LAZ backend such as lazrs): scaled x, y, z."""
    import laspy

    try:
        las = laspy.read(io.BytesIO(content))
    except Exception as exc:  # laspy raises its own and OS errors on corrupt files
        raise reject(f"unreadable LAS/LAZ file: {exc}") from None
    return np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)]).astype(np.float64)


def _read_e57(source: StoredInput) -> np.ndarray:
    """E57 scans (pye57, which reads files on disk only): every scan's cartesian points, each in world
    coordinates (its pose applied)."""
    import pye57

    with source.as_file() as path:
        try:
            e57 = pye57.E57(str(path))
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


def _read_points(source: StoredInput) -> np.ndarray:
    """The samples of a scan file, by its extension (intake accepted only ``UPLOAD_EXTENSIONS``)."""
    ext = source.extension
    if ext == ".e57":
        return _read_e57(source)
    content = source.read()
    if ext in (".ply", ".stl", ".obj"):
        return _read_mesh(content, ext[1:])
    if ext in (".las", ".laz"):
        return _read_las(content)
    if ext == ".npy":
        return _read_npy(content)
    return _read_text(content)  # .xyz, .csv, .txt


def parse_upload(source: StoredInput, options: dict | None) -> TubeRequest:
    """Uploaded scan → :class:`TubeRequest` (format from the extension, case-insensitive)."""
    ext = source.extension
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
            doc = json.loads(source.read().decode("utf-8-sig"))
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
        pts = _read_points(source)
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
        return validated(TubeRequest, body, ())
    except InputRejected as exc:
        if ext != ".json":
            raise
        # the points of a JSON file are the file's; its options are merged with the form's, so they keep their own path
        raise InputRejected([replace(e, loc=("file", *e.loc)) if e.loc[:1] == ("points",) else e
                             for e in exc.errors]) from None
