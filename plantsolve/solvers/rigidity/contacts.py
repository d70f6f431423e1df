"""Face contact between two placed parts where no snap of the catalogue meets: the ``contact`` joint.

The snap data states where parts connect; where it states nothing on the faces two parts touch with, a part wedged
in a gap of a build, touching faces of it on opposite sides (:meth:`Assembly.join_by_contact`), is still held, by
friction. A contact is two collision boxes (one of each part) that touch as drawn: apart by at most
``CONTACT_GAP`` or overlapping by at most that depth (LDraw's rounding; deeper is a collision, one part drawn inside
the other, no contact). It is refused where the faces carry studs or anti-studs facing across the contact (a stud
or anti-stud of either part in the patch where the two boxes meet, its axis along the contact's normal): there the
snap data does say how the parts connect, and its studs not meeting says they do not (a brick on a brick drawn half
a stud along, a brick on a tile: resting, held by nothing).

A contact joint is planar (screws.FREEDOM): it holds the translation along the normal and the two tilts about axes
in the faces' plane (3 of 6 degrees of freedom; one stud holds 5, two studs 6) and leaves the slide in the plane and
the turn about the normal, which only friction holds. Its point is the middle of the patch, its axis the normal.
"""

from __future__ import annotations

import fcl
import numpy as np

from plantsolve.solvers.rigidity.collisions import Shapes, collide, deepest, near_pieces

CONTACT_GAP = 0.1  # LDU: faces this close (apart or into each other) touch as drawn (assembly.SNAP: LDraw's rounding)
# LDU: how wide the patch where two boxes meet must be across at least two axes to be faces touching (an edge or a
# corner touching another part's is no contact that can hold it)
FACE = 1.0
ALIGN = 0.999  # |cos| between a stud's axis and the contact normal for the stud to face across the contact
FACE_TYPES = ("stud", "antistud")  # connection points whose faces the snap data governs


def touching(a: Shapes, b: Shapes, gap: float = CONTACT_GAP,
             aligned: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Where two solids touch face on face: (normal from ``a`` to ``b``, lower and upper corner of the patch, the
    intersection of the two touching pieces' world boxes grown by ``gap``) of the first pair of pieces that touch over
    a patch at least FACE wide along two axes, or None when none do or any pair overlaps deeper than ``gap`` (one
    drawn inside the other: a collision, not a contact). ``aligned``: every piece of both is a box along the world
    axes, its world box itself, so the boxes alone answer (as FCL would: the depth of two boxes is their least overlap
    along an axis, the normal that axis) without FCL's objects."""
    found = None
    for i, j in zip(*near_pieces(a, b, gap)):
        overlap = np.minimum(a.hi[i], b.hi[j]) - np.maximum(a.lo[i], b.lo[j])  # negative: apart along that axis
        if aligned:
            if overlap.min() < -gap:
                continue
            if overlap.min() > gap:
                return None
            axis = int(np.argmin(overlap))
            normal = np.eye(3)[axis] * (1.0 if b.lo[j][axis] + b.hi[j][axis] >= a.lo[i][axis] + a.hi[i][axis] else -1.0)
            if found is None and (overlap >= FACE).sum() >= 2:
                found = (normal, np.maximum(a.lo[i], b.lo[j]) - gap, np.minimum(a.hi[i], b.hi[j]) + gap)
            continue
        result = collide(a.objects[i], b.objects[j], contacts=4)
        if result is not None:
            if deepest(result) > gap:
                return None
            normal = np.asarray(result.contacts[0].normal, float) if result.contacts else None
        else:
            out = fcl.DistanceResult()
            if fcl.distance(a.objects[i], b.objects[j], fcl.DistanceRequest(enable_nearest_points=True), out) > gap:
                continue
            normal = np.asarray(out.nearest_points[1], float) - np.asarray(out.nearest_points[0], float)
        if found is None and normal is not None and np.linalg.norm(normal) > 1e-9 and (overlap >= FACE).sum() >= 2:
            found = (normal / np.linalg.norm(normal), np.maximum(a.lo[i], b.lo[j]) - gap,
                     np.minimum(a.hi[i], b.hi[j]) + gap)
    return found


def studs_across(points: np.ndarray, directions: np.ndarray, normal: np.ndarray, lo: np.ndarray,
                 hi: np.ndarray) -> bool:
    """Whether any of the stud or anti-stud ``points`` (with their ``directions``) lies in the patch [lo, hi] with its
    axis along the contact ``normal``: the faces are stud faces, which the snap data governs."""
    if not len(points):
        return False
    inside = ((points >= lo) & (points <= hi)).all(axis=1)
    along = np.abs(directions @ normal) >= ALIGN
    return bool((inside & along).any())
