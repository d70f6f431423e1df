"""Docking (seed §5): where a new part can join the model, ranked by the connections it makes.

The seed's recommendation is to consider only the model's free connection points. For each free
point of the model and each compatible point of the new part, the new part is oriented in the
frame of the part it docks to, turned by each of the 24 axis-aligned rotations that bring its
connection direction onto the mate's (opposite for studs, parallel for pins, axles and hinges), and
moved so the two points meet. Every pair of points that yields the same pose is one connection of
that pose, so counting the pairs per distinct pose (numpy ``unique``) ranks the poses at once.
Poses are then checked for collisions in that order (broad phase on boxes, FCL for the exact test)
until ``limit`` collision-free poses are found. A pose joined by pins or axles is not a collision
with the parts it is pinned to.
"""

from __future__ import annotations

import itertools

import numpy as np

from plantsolve.solvers.rigidity.assembly import INSERTED, Assembly
from plantsolve.solvers.rigidity.catalogue import MATES, OPPOSED, lookup
from plantsolve.solvers.rigidity.collisions import Solid, penetration


def _cube_group() -> np.ndarray:
    """The 24 proper rotations that map coordinate axes to coordinate axes."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1, -1), repeat=3):
            m = np.zeros((3, 3))
            for r, (c, s) in enumerate(zip(perm, signs)):
                m[r, c] = s
            if np.linalg.det(m) > 0:
                out.append(m)
    return np.array(out)


CUBE = _cube_group()


def dock(assembly: Assembly, number: str, limit: int = 10, tolerance: float = 0.01) -> list[dict]:
    """Collision-free poses of catalogue part ``number``, most connections first."""
    shape = lookup(number)
    if shape is None:
        raise KeyError(number)
    free = assembly.free_connectors()
    if not free:
        return []
    parts = assembly.parts
    owner = np.array([parts[p].id for p, _ in free], dtype=object)
    types = np.array([parts[p].shape.connectors[c].type for p, c in free], dtype=object)
    local_dir = np.array([parts[p].shape.connectors[c].direction for p, c in free], dtype=float)
    world_pt = np.array([parts[p].points[c] for p, c in free])
    frame = np.array([parts[p].rotation for p, _ in free])
    new_pts = shape.points()
    poses, counts_from, kinds = [], [], []
    for ci, conn in enumerate(shape.connectors):
        d_new = np.asarray(conn.direction, dtype=float)
        for mate_type in {t for (a, t), kind in MATES.items() if a == conn.type}:
            kind = MATES[(conn.type, mate_type)]
            sel = np.flatnonzero(types == mate_type)
            if sel.size == 0:
                continue
            for g in CUBE:
                gd = g @ d_new
                dots = local_dir[sel] @ gd
                ok = sel[dots < -0.999] if kind in OPPOSED else sel[np.abs(dots) > 0.999]
                if ok.size == 0:
                    continue
                rot = frame[ok] @ g  # (k, 3, 3)
                pos = world_pt[ok] - rot @ new_pts[ci]
                poses.append(np.concatenate([rot.reshape(-1, 9), pos], axis=1))
                counts_from.append(ok)
                kinds.extend([kind] * ok.size)
    if not poses:
        return []
    table = np.concatenate(poses)
    sources = np.concatenate(counts_from)
    kinds = np.array(kinds, dtype=object)
    keys = np.round(table * 1000).astype(np.int64)
    unique, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    order = np.lexsort((np.arange(len(unique)), -counts))
    ids, solids = assembly.solids()
    boxes = [s.aabb() if s is not None else (np.full(3, np.inf), np.full(3, -np.inf)) for s in solids]
    lo = np.array([b[0] for b in boxes])
    hi = np.array([b[1] for b in boxes])
    cache: dict[int, object] = {}
    out = []
    seen: set[frozenset] = set()
    new_types = [c.type for c in shape.connectors]
    for u in order:
        members = np.flatnonzero(inverse == u)
        first = members[0]
        rot = table[first, :9].reshape(3, 3)
        pos = table[first, 9:]
        # a symmetric part reaches the same placement under several rotations: keep one
        footprint = frozenset(zip(new_types, map(tuple, np.round((new_pts @ rot.T + pos) * 1000).astype(np.int64))))
        if footprint in seen:
            continue
        seen.add(footprint)
        pinned = {owner[sources[m]] for m in members if kinds[m] in INSERTED}
        candidate = Solid(center=rot @ np.asarray(shape.box_center) + pos, size=np.asarray(shape.box_size, float),
                          rotation=rot)
        c_lo, c_hi = candidate.aabb()
        near = np.flatnonzero(((c_lo < hi - tolerance) & (lo < c_hi - tolerance)).all(axis=1))
        blocked = False
        if near.size:
            obj = candidate.fcl_object()
            for k in near:
                if ids[k] in pinned:
                    continue
                if k not in cache:
                    cache[k] = solids[k].fcl_object()
                if penetration(obj, cache[k]) > tolerance:
                    blocked = True
                    break
        if blocked:
            continue
        out.append({"part": shape.number, "position": [float(v) for v in np.round(pos, 9)],
                    "rotation": [float(v) for v in np.round(rot.reshape(-1), 12)],
                    "connections": int(counts[u]), "connects_to": sorted({str(owner[sources[m]]) for m in members})})
        if len(out) >= limit:
            break
    return out
