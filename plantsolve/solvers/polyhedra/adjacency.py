"""Multi-zone complexes: which zones share which faces, and how much area.

A face listed with two zones is one wall between them (α3 sews its two uses). Exporters that
write each side as a surface of its own (EnergyPlus interzone surfaces, SketchUp rooms) give two
faces of different zones in one plane, facing each other; they need not match: a wall of one zone
may face two walls of the next, and SketchUp triangulates the two sides along different diagonals.
Such faces are grouped by plane and their overlap is clipped in the plane (the outer loops; one of
each pair must be convex, as walls and their triangles are — a pair of non-convex faces counts only
when the two have the same vertices)."""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.polyhedra.polygons import Polygons

PLANE_GAP = 1e-3  # faces whose planes are closer than this (units) are one plane


def _clip(subject: np.ndarray, clip: np.ndarray) -> np.ndarray:
    """Sutherland–Hodgman: the part of polygon ``subject`` inside the convex, counter-clockwise ``clip``."""
    out = subject
    for a, b in zip(clip, np.roll(clip, -1, axis=0)):
        if len(out) == 0:
            break
        edge = b - a
        side = edge[0] * (out[:, 1] - a[1]) - edge[1] * (out[:, 0] - a[0])
        kept = []
        for i in range(len(out)):
            p, q, sp, sq = out[i], out[(i + 1) % len(out)], side[i], side[(i + 1) % len(out)]
            if sp >= 0:
                kept.append(p)
            if (sp >= 0) != (sq >= 0):
                kept.append(p + (q - p) * (sp / (sp - sq)))
        out = np.asarray(kept).reshape(-1, 2)
    return out


def _area(poly2: np.ndarray) -> float:
    if len(poly2) < 3:
        return 0.0
    x, y = poly2[:, 0], poly2[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _convex(poly2: np.ndarray) -> bool:
    d = np.roll(poly2, -1, axis=0) - poly2
    turn = d[:, 0] * np.roll(d[:, 1], -1) - d[:, 1] * np.roll(d[:, 0], -1)
    return bool((turn >= -1e-12 * np.abs(turn).max()).all()) if len(turn) else False


def _overlap(poly: Polygons, a: int, b: int, normal: np.ndarray) -> float:
    """Area of the overlap of faces a and b (outer loops), projected on the plane with unit normal ``normal``
    (counter-clockwise seen from its tip)."""
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    loops = []
    for f in (a, b):
        loop = poly.face_loop_start[f]
        pts = poly.points[poly.loop_vertices[poly.loop_start[loop]:poly.loop_start[loop + 1]]]
        pts = pts - poly.points[poly.loop_vertices[poly.loop_start[poly.face_loop_start[a]]]]
        p2 = np.stack([pts @ u, pts @ v], axis=1)
        loops.append(p2 if _area(p2) >= 0 else p2[::-1])
    first, second = loops
    if _convex(second):
        return _area(_clip(first, second))
    if _convex(first):
        return _area(_clip(second, first))
    same = sorted(poly.loop_vertices[poly.face_position_start[a]:poly.face_position_start[a + 1]].tolist()) == \
        sorted(poly.loop_vertices[poly.face_position_start[b]:poly.face_position_start[b + 1]].tolist())
    return abs(_area(first)) if same else 0.0


def adjacency(poly: Polygons, area: np.ndarray, normal: np.ndarray) -> list[dict]:
    """Shared faces per pair of zones: ``{"zones": [a, b], "faces": [...], "area": ...}``."""
    shared: dict[tuple[int, int], dict] = {}

    def add(pair: tuple[int, int], faces: list[int], face_area: float) -> None:
        entry = shared.setdefault(pair, {"faces": [], "area": 0.0})
        entry["faces"].extend(f for f in faces if f not in entry["faces"])
        entry["area"] += face_area

    fz = poly.face_zone
    for f in np.flatnonzero(fz[:, 1] >= 0):
        add((int(min(fz[f])), int(max(fz[f]))), [int(f)], float(area[f]))
    candidates = np.flatnonzero((fz[:, 0] >= 0) & (fz[:, 1] < 0) & (area > 0))
    if len(poly.zone_ids) > 1 and len(candidates) > 1:
        n = normal[candidates]
        sign = np.sign(n[np.arange(len(n)), np.argmax(np.abs(n), axis=1)])
        canon = n * sign[:, None]
        offset = np.einsum("ij,ij->i", canon, poly.points[poly.loop_vertices[poly.face_position_start[candidates]]])
        _, direction = np.unique(np.round(canon, 4), axis=0, return_inverse=True)
        direction = direction.reshape(-1)
        order = np.lexsort((offset, direction))
        new_plane = np.r_[True, (direction[order][1:] != direction[order][:-1]) |
                          (np.diff(offset[order]) > PLANE_GAP)]
        plane = np.empty(len(order), dtype=np.int64)
        plane[order] = np.cumsum(new_plane) - 1
        lo = np.full((poly.n_faces, 3), np.inf)
        hi = np.full((poly.n_faces, 3), -np.inf)
        pf = poly.position_face
        pts = poly.points[poly.loop_vertices]
        np.minimum.at(lo, pf, pts)
        np.maximum.at(hi, pf, pts)
        starts = np.flatnonzero(new_plane)
        for s, e in zip(starts, np.r_[starts[1:], len(order)]):
            members = order[s:e]
            if len(members) < 2 or len(np.unique(fz[candidates[members], 0])) < 2:
                continue
            front = members[sign[members] > 0]
            back = members[sign[members] < 0]
            for i in front:
                fa = candidates[i]
                for j in back:
                    fb = candidates[j]
                    if fz[fa, 0] == fz[fb, 0]:
                        continue
                    if (np.minimum(hi[fa], hi[fb]) - np.maximum(lo[fa], lo[fb]) < -PLANE_GAP).any():
                        continue
                    shared_area = _overlap(poly, fa, fb, canon[i])
                    if shared_area > 1e-9 * max(min(area[fa], area[fb]), 1e-12) and shared_area > 1e-12:
                        za, zb = int(fz[fa, 0]), int(fz[fb, 0])
                        add((min(za, zb), max(za, zb)), [int(fa), int(fb)], shared_area)
    out = []
    for (za, zb), entry in sorted(shared.items(), key=lambda item: (poly.zone_ids[item[0][0]], poly.zone_ids[item[0][1]])):
        out.append({"zones": sorted([poly.zone_ids[za], poly.zone_ids[zb]]),
                    "faces": [poly.face_ids[f] for f in entry["faces"]], "area": entry["area"]})
    return out
