"""Reading samples: request ``points`` (JSON list or base64 NPY) and uploaded files."""

from __future__ import annotations

import base64
import io
import json
import re

import numpy as np
from pydantic import ValidationError

from plantsolve.schemas.tube import NpyPoints, TubeRequest, decode_npy_points
from plantsolve.solvers.base import FieldError, InputRejected

UPLOAD_EXTENSIONS = (".ply", ".xyz", ".csv", ".txt", ".npy", ".json")
INLINE_LIST_MAX = 20_000  # larger uploads travel inside the request as base64 NPY


def request_points(request: TubeRequest) -> np.ndarray:
    if isinstance(request.points, NpyPoints):
        return decode_npy_points(request.points.npy_base64)
    return np.asarray(request.points, dtype=np.float64).reshape(-1, 3)


def points_field(pts: np.ndarray):
    """The ``points`` value for an array: a JSON list when small, base64 NPY otherwise."""
    if len(pts) <= INLINE_LIST_MAX:
        return pts.tolist()
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(pts, dtype=np.float64))
    return {"npy_base64": base64.b64encode(buf.getvalue()).decode("ascii")}


def _reject(msg: str) -> InputRejected:
    return InputRejected([FieldError(loc=("file",), msg=msg)])


def _read_ply(content: bytes) -> np.ndarray:
    import trimesh

    try:
        geom = trimesh.load(io.BytesIO(content), file_type="ply", process=False)
    except Exception as exc:  # trimesh raises many types on corrupt files
        raise _reject(f"unreadable PLY file: {exc}") from None
    if isinstance(geom, trimesh.Scene):
        parts = [g.vertices for g in geom.geometry.values() if hasattr(g, "vertices")]
        verts = np.vstack(parts) if parts else np.zeros((0, 3))
    else:
        verts = getattr(geom, "vertices", None)
        if verts is None:
            raise _reject("PLY file holds no vertices")
    return np.asarray(verts, dtype=np.float64)


_SPLIT = re.compile(r"[,;\s]+")


def _read_text(content: bytes) -> np.ndarray:
    try:
        text = content.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise _reject("text file is not UTF-8") from None
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
            raise _reject(f"line {lineno}: expected numbers 'x y z', got {s[:60]!r}") from None
        if len(vals) < 3:
            raise _reject(f"line {lineno}: expected 3 coordinates, got {len(vals)}")
        rows.append(vals)
    if not rows:
        raise _reject("no 'x y z' rows found")
    return np.array(rows, dtype=np.float64)


def _read_npy(content: bytes) -> np.ndarray:
    try:
        arr = np.load(io.BytesIO(content), allow_pickle=False)
    except Exception as exc:
        raise _reject(f"unreadable NPY file: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] < 3 or not np.issubdtype(arr.dtype, np.number):
        raise _reject(f"NPY array must be numeric with shape (N, 3), got {arr.shape} {arr.dtype}")
    return np.asarray(arr[:, :3], dtype=np.float64)


def parse_upload(filename: str, content: bytes, options: dict | None) -> TubeRequest:
    """Uploaded scan → :class:`TubeRequest` (format from the extension, case-insensitive)."""
    name = (filename or "").lower()
    ext = next((e for e in UPLOAD_EXTENSIONS if name.endswith(e)), None)
    if ext is None:
        raise _reject(f"unsupported file type {filename!r}; accepted: {', '.join(UPLOAD_EXTENSIONS)}")
    units = None
    opts = dict(options or {})
    if "units" in opts:  # tolerate units passed among the options
        units = opts.pop("units")
    if ext == ".json":
        try:
            doc = json.loads(content.decode("utf-8-sig"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise _reject(f"invalid JSON: {exc}") from None
        if isinstance(doc, list):
            doc = {"points": doc}
        if not isinstance(doc, dict):
            raise _reject("JSON must be a request object or a list of [x, y, z]")
        body = dict(doc)
        body["options"] = {**(body.get("options") or {}), **opts}
        if units:
            body["units"] = units
    else:
        reader = {".ply": _read_ply, ".npy": _read_npy}.get(ext, _read_text)
        pts = reader(content)
        if pts.ndim != 2 or pts.shape[1] != 3 or len(pts) == 0:
            raise _reject("file holds no 3D points")
        if not np.isfinite(pts).all():
            bad = int(np.flatnonzero(~np.isfinite(pts).all(1))[0])
            raise _reject(f"non-finite coordinate in point {bad}")
        body = {"points": points_field(pts), "options": opts}
        if units:
            body["units"] = units
    try:
        return TubeRequest.model_validate(body)
    except ValidationError as exc:
        errs = [FieldError(loc=("file",) + tuple(e["loc"]) if ext == ".json" and e["loc"][:1] == ("points",)
                           else tuple(e["loc"]), msg=e["msg"]) for e in exc.errors()]
        raise InputRejected(errs) from None
