"""Faces a zone lists twice: a surface exported twice (an OBJ group repeated, an IDF object pasted again) adds
its volume twice and still closes, so the closure check alone passes it. Found where a zone has non-manifold
edges (every repeated face makes them), so a clean model costs nothing."""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.polyhedra.polygons import Polygons


def repeated_faces(poly: Polygons, faces: np.ndarray, normals: np.ndarray) -> list[tuple[int, int]]:
    """(face, the earlier face it repeats) among ``faces`` of one zone: the same vertices (after merging) facing
    the same way. A face and its reverse are a membrane, whose volumes cancel, and are not listed."""
    starts = poly.face_position_start
    first: dict[tuple, int] = {}
    out = []
    for f in faces:
        if poly.face_parent[f] >= 0:
            continue
        key = tuple(sorted(poly.loop_vertices[starts[f]:starts[f + 1]].tolist()))
        g = first.setdefault(key, int(f))
        if g != f and float(np.dot(normals[f], normals[g])) > 0:
            out.append((int(f), g))
    return out
