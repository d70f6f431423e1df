"""Docking (seed §5): where a new part can join the model, ranked by the connections it makes.

The seed's recommendation is to consider only the model's free connection points. For each free
point of the model and each compatible point of the new part, the new part is oriented in the
frame of the part it docks to, turned by each of the 24 axis-aligned rotations that bring its
connection direction onto the mate's (opposite for studs, parallel for pins, axles and hinges), and
moved so the two points meet. Every pair of points that yields the same pose is one connection of
that pose, so counting the pairs per distinct pose (one sort of integer pose keys) ranks the poses at
once; rotations that map the part onto itself (a 2 × 4 brick turned half a turn) are tried once.
Poses are then checked for collisions in that order (broad phase on boxes, FCL for the exact test)
until ``limit`` collision-free poses are found. A pose joined by pins or axles is not a collision
with the parts it is pinned to.
"""

from __future__ import annotations

import functools
import itertools

import numpy as np

from plantsolve.solvers.rigidity.assembly import INSERTED, Assembly, part_solid
from plantsolve.solvers.rigidity.catalogue import ANY_DIRECTION, OPPOSED, counterparts, lookup, mate
from plantsolve.solvers.rigidity.collisions import penetration


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


def _signature(shape, h: np.ndarray) -> frozenset:
    pts = np.round(shape.points() @ h.T, 6)
    dirs = np.array([c.direction for c in shape.connectors], dtype=float) @ h.T
    box = tuple(np.round(h @ np.asarray(shape.box_center), 6)) + tuple(np.round(np.abs(h) @ shape.box_size, 6))
    items = set()
    for c, p, d in zip(shape.connectors, pts, dirs):
        lead = np.flatnonzero(np.abs(d) > 1e-9)
        if c.type not in ("stud", "antistud") and lead.size and d[lead[0]] < 0:
            d = -d  # an axis (pin, hole, axle, hinge) has no sign
        items.add((c.type, tuple(p), tuple(np.round(d, 6))))
    return frozenset(items) | {box}


@functools.lru_cache(maxsize=256)
def coset_representatives(shape) -> list[int]:
    """Indices into :data:`CUBE` of one rotation per class of rotations that place the part alike:
    a 2 × 4 brick looks the same turned half a turn about its vertical axis, so only half of the 24
    rotations give distinct placements (a 2 × 2 brick: a quarter)."""
    base = _signature(shape, np.eye(3))
    symmetry = [h for h in CUBE if _signature(shape, h) == base]
    index = {tuple(np.round(g).astype(int).ravel()): k for k, g in enumerate(CUBE)}
    keep = []
    for k, g in enumerate(CUBE):
        if k == min(index[tuple(np.round(g @ h).astype(int).ravel())] for h in symmetry):
            keep.append(k)
    return keep


def dock(assembly: Assembly, number: str, limit: int = 10, tolerance: float = 0.01) -> list[dict]:
    """Collision-free poses of catalogue part ``number``, most connections first."""
    shape = lookup(number)
    if shape is None:
        raise KeyError(number)
    shape = shape.sampled()  # its axles and bars as points along them
    table = assembly.free_table()
    if table is None:
        return []
    owner, types, local_dir, world_pt, frame = table
    new_pts = shape.points()
    # rotations as small ids: the product (owner frame) x (cube rotation) for each distinct frame
    frame_keys, frame_id = np.unique(np.round(frame.reshape(-1, 9) * 1e6).astype(np.int64), axis=0, return_inverse=True)
    frame_id = frame_id.reshape(-1)
    rot_ids: dict[tuple, int] = {}
    rot_of = np.zeros((len(frame_keys), len(CUBE)), dtype=np.int64)
    rotations = []
    for f, key in enumerate(frame_keys):
        base = key.reshape(3, 3) / 1e6
        for gi, g in enumerate(CUBE):
            product = base @ g
            k = tuple(np.round(product * 1e6).astype(np.int64).ravel())
            if k not in rot_ids:
                rot_ids[k] = len(rotations)
                rotations.append(product)
            rot_of[f, gi] = rot_ids[k]
    pose_rot, pose_pos, sources, kinds = [], [], [], []
    groups: dict[tuple, list[int]] = {}  # connectors of one type and direction share their matches
    for ci, conn in enumerate(shape.connectors):
        groups.setdefault((conn.type, conn.direction), []).append(ci)
    reps = np.array(coset_representatives(shape))  # the part's own symmetries give no new placements
    for (ctype, direction), members_of_group in groups.items():
        turned_all = CUBE[reps] @ np.asarray(direction, dtype=float)  # the direction under each rotation
        for mate_type in counterparts(ctype):
            kind = mate(ctype, mate_type)
            sel = np.flatnonzero(types == mate_type)
            if sel.size == 0:
                continue
            dots = local_dir[sel] @ turned_all.T  # (k, 24)
            if kind in ANY_DIRECTION:
                match = np.ones_like(dots, dtype=bool)
            else:
                match = dots < -0.999 if kind in OPPOSED else np.abs(dots) > 0.999
            for ri in np.flatnonzero(match.any(axis=0)):
                ok = sel[match[:, ri]]
                gi = reps[ri]
                g = CUBE[gi]
                frames = frame[ok]
                rots = rot_of[frame_id[ok], gi]
                for ci in members_of_group:
                    pose_pos.append(world_pt[ok] - np.einsum("kij,j->ki", frames, g @ new_pts[ci]))
                    pose_rot.append(rots)
                    sources.append(ok)
                    kinds.append(np.full(ok.size, kind in INSERTED))
    if not pose_rot:
        return []
    rot_id = np.concatenate(pose_rot)
    position = np.concatenate(pose_pos)
    sources = np.concatenate(sources)
    inserted = np.concatenate(kinds)
    grid = np.round(position * 1000).astype(np.int64)
    grid -= grid.min(axis=0)
    span = [int(v) + 1 for v in grid.max(axis=0)]
    if len(rotations) * span[0] * span[1] * span[2] >= 2 ** 62:  # too wide for one key: rank each axis
        for axis in range(3):
            values, grid[:, axis] = np.unique(grid[:, axis], return_inverse=True)
            span[axis] = len(values)
    # one integer key per pose (rotation, position on a 0.001 LDU grid): a single sort groups the poses
    key = ((rot_id * span[0] + grid[:, 0]) * span[1] + grid[:, 1]) * span[2] + grid[:, 2]
    order_rows = np.argsort(key, kind="stable")
    change = np.diff(key[order_rows]) != 0
    starts = np.concatenate([[0], np.flatnonzero(change) + 1])
    counts = np.diff(np.concatenate([starts, [len(order_rows)]]))
    order = np.argsort(-counts, kind="stable")  # most connections first, ties in pose order
    ids, solids, lo, hi = assembly.solid_boxes()
    cache: dict[int, object] = {}
    out = []
    seen: set[frozenset] = set()
    new_types = [c.type for c in shape.connectors]
    for u in order:
        members = order_rows[starts[u]:starts[u] + counts[u]]
        first = members[0]
        rot = rotations[rot_id[first]]
        pos = position[first]
        # a symmetric part reaches the same placement under several rotations: keep one
        footprint = frozenset(zip(new_types, map(tuple, np.round((new_pts @ rot.T + pos) * 1000).astype(np.int64))))
        if footprint in seen:
            continue
        seen.add(footprint)
        pinned = {owner[sources[m]] for m in members if inserted[m]}
        candidate = part_solid(shape, rot, pos)
        if candidate is None:  # no collision shape: nothing can block it
            near = np.zeros(0, dtype=int)
        else:
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
