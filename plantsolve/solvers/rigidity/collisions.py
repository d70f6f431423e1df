"""Collisions between bodies: a broad phase on axis-aligned boxes, an exact narrow phase with FCL.

The seed's §4 screens pairs with bounding spheres then boxes before the exact test. Here the broad
phase compares the world axis-aligned bounding boxes of all bodies at once (numpy), keeping pairs
that overlap by more than the contact tolerance; the narrow phase runs python-fcl on the true
shapes (boxes as solid primitives, meshes as BVH triangle models) and reads the penetration depth.
A part with holes is a union of boxes (its pieces): a pair's depth is the largest over the pairs of
pieces whose boxes meet. A pair is a collision only when that depth exceeds ``contact_tolerance``: a
brick resting on another touches it along a face (depth 0) and is contact, not collision. Meshes are surfaces to
FCL: a mesh wholly inside another without crossing its surface is not reported, and the depth
FCL gives for two meshes is the largest of its triangle contacts' estimates (exact for boxes, not
for meshes: touching meshes give 0, crossing meshes a positive but approximate depth).
"""

from __future__ import annotations

from dataclasses import dataclass

import fcl
import numpy as np


@dataclass
class Solid:
    """A body's shape in world coordinates: a box (centre, size, rotation matrix), a mesh, or the union of
    solids (``pieces``: a part with holes as several boxes)."""

    center: np.ndarray | None = None
    size: np.ndarray | None = None
    rotation: np.ndarray | None = None
    vertices: np.ndarray | None = None
    faces: np.ndarray | None = None
    pieces: tuple[Solid, ...] = ()

    def aabb(self) -> tuple[np.ndarray, np.ndarray]:
        if self.pieces:
            boxes = [p.aabb() for p in self.pieces]
            return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)
        if self.vertices is not None:
            return self.vertices.min(axis=0), self.vertices.max(axis=0)
        half = np.abs(self.rotation) @ (self.size / 2)
        return self.center - half, self.center + half

    def fcl_object(self) -> Shapes:
        """The FCL objects of the solid with their world boxes: one per piece (one for a box or a mesh)."""
        pieces = self.pieces or (self,)
        boxes = [p.aabb() for p in pieces]
        return Shapes([p._fcl_single() for p in pieces], np.array([b[0] for b in boxes]),
                      np.array([b[1] for b in boxes]))

    def _fcl_single(self) -> fcl.CollisionObject:
        if self.vertices is not None:
            model = fcl.BVHModel()
            model.beginModel(len(self.vertices), len(self.faces))
            model.addSubModel(self.vertices, self.faces)
            model.endModel()
            return fcl.CollisionObject(model, fcl.Transform())
        rot = self.rotation
        if np.linalg.det(rot) < 0:  # a mirrored part: the box is symmetric, flip one axis
            rot = rot @ np.diag([1.0, 1.0, -1.0])
        return fcl.CollisionObject(fcl.Box(*self.size), fcl.Transform(rot, self.center))


@dataclass
class Shapes:
    """A solid's FCL objects and their world boxes (lower and upper corners), for the narrow phase."""

    objects: list
    lo: np.ndarray
    hi: np.ndarray


def overlapping_pairs(lo: np.ndarray, hi: np.ndarray, tolerance: float) -> np.ndarray:
    """Index pairs (i < j) whose boxes overlap by more than ``tolerance`` on every axis."""
    n = len(lo)
    pairs = []
    chunk = max(1, 2_000_000 // max(n, 1))
    for start in range(0, n, chunk):
        a = slice(start, min(n, start + chunk))
        ok = ((lo[a, None, :] < hi[None, :, :] - tolerance) & (lo[None, :, :] < hi[a, None, :] - tolerance)).all(axis=2)
        i, j = np.nonzero(ok)
        i = i + start
        keep = i < j
        pairs.append(np.stack([i[keep], j[keep]], axis=1))
    return np.concatenate(pairs) if pairs else np.zeros((0, 2), dtype=int)


def near_pieces(a: Shapes, b: Shapes, gap: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j) of ``a``'s and ``b``'s pieces whose world boxes meet, each grown by ``gap``."""
    return np.nonzero(((a.lo[:, None, :] <= b.hi[None, :, :] + gap) & (b.lo[None, :, :] <= a.hi[:, None, :] + gap))
                      .all(axis=2))


def collide(a: fcl.CollisionObject, b: fcl.CollisionObject, contacts: int = 16) -> fcl.CollisionResult | None:
    """FCL's contacts (at most ``contacts``) of two objects that collide, None when they do not."""
    request = fcl.CollisionRequest(enable_contact=True, num_max_contacts=contacts)
    result = fcl.CollisionResult()
    return result if fcl.collide(a, b, request, result) else None


def deepest(result: fcl.CollisionResult) -> float:
    """The largest penetration depth of a collision's contacts (0 when they only touch)."""
    return max((float(c.penetration_depth) for c in result.contacts), default=0.0)


def _depth(a: fcl.CollisionObject, b: fcl.CollisionObject) -> float:
    result = collide(a, b)
    return -1.0 if result is None else deepest(result)


def penetration(a: Shapes, b: Shapes) -> float:
    """FCL's largest penetration depth between two solids' pieces (0 when they only touch, -1 when apart);
    only pieces whose world boxes overlap are given to FCL."""
    if len(a.objects) == 1 and len(b.objects) == 1:  # two plain boxes: the broad phase has matched them
        return _depth(a.objects[0], b.objects[0])
    depth = -1.0
    for i, j in zip(*near_pieces(a, b)):
        depth = max(depth, _depth(a.objects[i], b.objects[j]))
    return depth


def find_collisions(solids: list[Solid | None], tolerance: float, exclude: set[tuple[int, int]] = frozenset(),
                    cache: dict | None = None) -> list[tuple[int, int, float]]:
    """(i, j, depth) of every pair of solids that interpenetrate deeper than ``tolerance``."""
    index = [k for k, s in enumerate(solids) if s is not None]
    if len(index) < 2:
        return []
    boxes = [solids[k].aabb() for k in index]
    lo = np.array([b[0] for b in boxes])
    hi = np.array([b[1] for b in boxes])
    cache = {} if cache is None else cache
    out = []
    for i, j in overlapping_pairs(lo, hi, tolerance):
        a, b = index[i], index[j]
        if (a, b) in exclude:
            continue
        for k in (a, b):
            if k not in cache:
                cache[k] = solids[k].fcl_object()
        depth = penetration(cache[a], cache[b])
        if depth > tolerance:
            out.append((a, b, depth))
    return out
