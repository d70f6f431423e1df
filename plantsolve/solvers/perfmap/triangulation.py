"""Deterministic, unit-free triangulation of the (theta, phi) settings (paper §4, Fig. 15)."""

from __future__ import annotations

import numpy as np
from scipy.spatial import Delaunay

from plantsolve.solvers.perfmap.setting_lines import normalised_settings


def triangulate(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Delaunay triangles (indices, counter-clockwise) of range-normalised (theta, phi).

    Normalising each axis to [0, 1] makes the result independent of the units of theta and
    phi (degrees vs speed fraction). The input order is the caller's canonical (theta, phi)
    sort, and Qhull is deterministic for a given input, so the triangulation is too.
    Zero-area simplices (possible for co-circular grids) are dropped: they cover nothing.
    """
    pts = normalised_settings(theta, phi)
    tri = Delaunay(pts).simplices.astype(int)
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    keep = np.abs(area2) > 1e-12
    tri, area2 = tri[keep], area2[keep]
    tri[area2 < 0] = tri[area2 < 0][:, [0, 2, 1]]
    order = np.lexsort((tri.max(axis=1), tri.min(axis=1)))  # stable listing order
    return tri[order]


def chain(*columns: np.ndarray) -> np.ndarray:
    """Settings on one line (one setting parameter, e.g. speed lines): neighbours along the line as
    degenerate triangles (i, j, j). The map machinery then interpolates between neighbouring lines only
    (its edge pass), which is the one-parameter map: every point between two speed lines belongs to the
    speed between them."""
    pts = normalised_settings(*columns)
    centred = pts - pts.mean(axis=0)
    direction = (np.linalg.svd(centred, full_matrices=False)[2][0] if len(pts) > 1
                 else np.eye(pts.shape[1])[0])
    order = np.argsort(centred @ direction, kind="stable")
    if order[0] > order[-1]:  # a direction-independent listing: from the smaller index end
        order = order[::-1]
    return np.array([[order[k], order[k + 1], order[k + 1]] for k in range(len(order) - 1)], dtype=int).reshape(-1, 3)


def faces(values: np.ndarray) -> np.ndarray:
    """Three setting parameters: the triangular faces of the Delaunay tetrahedra of the range-normalised
    settings. For a fixed curve parameter the settings through a point (flow, pressure) inside a
    tetrahedron form a segment on which the efficiency is linear, so its maximum lies on a face: the
    map over faces is the map over the tetrahedra."""
    pts = normalised_settings(values)
    tet = Delaunay(pts).simplices.astype(int)
    tri = np.unique(np.sort(np.concatenate([tet[:, [0, 1, 2]], tet[:, [0, 1, 3]], tet[:, [0, 2, 3]],
                                            tet[:, [1, 2, 3]]]), axis=1), axis=0)
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    return tri[np.linalg.norm(np.cross(b - a, c - a), axis=1) > 1e-12]


def map_simplices(values: np.ndarray) -> tuple[np.ndarray, str]:
    """Triangles of the settings for the map, and what they are: 'chain' (settings on one line: one
    parameter), 'triangles' (a plane: two parameters, or three in one plane) or 'faces' (three)."""
    values = np.asarray(values, dtype=float)
    pts = normalised_settings(values)
    centred = pts - pts.mean(axis=0)
    sv, basis = np.linalg.svd(centred, full_matrices=False)[1:]
    rank = int(np.sum(sv > 1e-9 * max(sv[0], 1e-300))) if len(sv) else 0
    if rank <= 1:
        return chain(values), "chain"
    if values.shape[1] == 2:
        return triangulate(values[:, 0], values[:, 1]), "triangles"
    if rank == 2:
        plane = centred @ basis[:2].T
        return triangulate(plane[:, 0], plane[:, 1]), "triangles"
    return faces(values), "faces"


def locate(theta: np.ndarray, phi: np.ndarray, triangles: np.ndarray,
           q_theta: float, q_phi: float, tol: float = 1e-9):
    """(triangle index, barycentric weights) of a setting, or (None, None) outside the hull."""
    pts = normalised_settings(np.append(theta, q_theta), np.append(phi, q_phi))
    q, pts = pts[-1], pts[:-1]
    for k, (i, j, l) in enumerate(triangles):
        if j == l:  # a segment of a one-parameter chain
            d = pts[j] - pts[i]
            s = float((q - pts[i]) @ d / (d @ d))
            if -tol <= s <= 1 + tol and np.linalg.norm(pts[i] + s * d - q) <= 1e-9:
                return k, np.array([1.0 - s, s, 0.0])
            continue
        A = np.column_stack([pts[i] - pts[l], pts[j] - pts[l]])
        u, v = np.linalg.solve(A, q - pts[l])
        w = np.array([u, v, 1.0 - u - v])
        if np.all(w >= -tol):
            return k, w
    return None, None
