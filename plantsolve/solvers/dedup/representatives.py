"""Coherent representatives: each class's representative taken from the same copy of the repeated assembly as
the reference class's, so that the members of one copy share one transform across classes (the pool).

The classes come out of the matching with their first product in GlobalId order as representative: an order
no instance numbering decides, but one that scatters the representatives over the model (GlobalIds are random),
so a tunnel ring's eight segments would each need their own transform. The reference class is the largest (ties:
the smallest representative GlobalId); another class's representative ``c`` belongs to the reference's copy when
its transform is the inverse of a reference member's (the copy the class's first representative lies in, seen
from the reference's): the inverse of a reference member's transform takes the class's representative onto
``c`` (a transform the matching found may differ from it by a symmetry of the shape, so it is verified, not
compared). Re-rooted transforms are verified again, two ways, within the
tolerance; a class any of whose members would fail keeps its representative.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.dedup.congruence import CongruenceClass
from plantsolve.solvers.dedup.matching import Match, det3s, one_to_one, verify

TRIED = 64  # members tried as the reference copy's (each costs a query of every reference transform)


def _affine(m: Match) -> tuple[np.ndarray, np.ndarray]:
    return m.rotation * m.scale, m.translation


def _reference(classes: list[CongruenceClass]) -> CongruenceClass | None:
    shared = [c for c in classes if len(c.members) > 1]
    if not shared:
        return None
    return min(shared, key=lambda c: (-len(c.members), str(c.representative.product.GlobalId)))


def _in_reference_copy(cls: CongruenceClass, ref: CongruenceClass, tol: float) -> int | None:
    """The index of the member of ``cls`` in the reference's copy, else None.

    The reference's transforms take its copy onto every other copy: applied to the centre of the member in the
    reference's copy, each lands on the centre of a member of ``cls`` (a symmetry of a shape keeps its centre, so
    the transforms the matching happened to pick do not matter). A member of another copy lands on fewer (a
    straight row of copies: past its end), or on none (a copy turned or moved otherwise). The members nearest the
    reference's representative are tried first (then by GlobalId): the first on which every transform lands, else
    the one of the first ``TRIED`` that most land on. None when that is the representative already, or when no
    member is landed on more often than by chance (once: the identity)."""
    linear = np.stack([m.rotation * m.scale for _, m in ref.members])
    shift = np.stack([m.translation for _, m in ref.members])
    centres = np.stack([cand.shape.centre for cand, _ in cls.members])
    tree = cKDTree(centres)
    origin = ref.representative.shape.centre
    near = np.linalg.norm(centres - origin, axis=1).tolist()
    order = sorted(range(len(centres)), key=lambda k: (near[k], str(cls.members[k][0].product.GlobalId)))
    best, most = None, 1
    for k in order[:TRIED]:
        landed = linear @ centres[k] + shift
        hits = int(np.isfinite(tree.query(landed, k=1, distance_upper_bound=2 * tol)[0]).sum())
        if hits > most:
            best, most = k, hits
        if hits == len(ref.members):
            break
    return best


def _rerooted(cls: CongruenceClass, k: int, tol: float) -> CongruenceClass | None:
    """``cls`` with member ``k`` as representative, every transform verified again; None if one fails. The members'
    new transforms and moved points come from stacked products; each is then looked up in its member's tree once
    (a one-to-one nearest-point map within the tolerance is the two-way Hausdorff distance, as in ``verify``, which
    decides the rest)."""
    new_rep, via = cls.members[k]
    others = [(cand, m) for j, (cand, m) in enumerate(cls.members) if j != k]
    linear_c, shift_c = _affine(via)
    undo = np.linalg.inv(linear_c)
    scales = np.array([m.scale / via.scale for _, m in others])
    linear = np.stack([_affine(m)[0] for _, m in others]) @ undo  # (member, 3, 3): rotation × scale
    translations = np.stack([_affine(m)[1] for _, m in others]) - linear @ shift_c
    rotations = linear / scales[:, None, None]
    improper = det3s(rotations) < 0
    shape = new_rep.shape
    moved_all = (np.matmul(shape.local, linear.transpose(0, 2, 1)) + (linear @ shape.centre)[:, None, :]
                 + translations[:, None, :])
    members = [(new_rep, Match(np.eye(3), 1.0, np.zeros(3), 0.0, False))]
    for j, (cand, _) in enumerate(others):
        moved = Match(rotations[j], float(scales[j]), translations[j], 0.0, bool(improper[j]))
        dev = np.inf
        if len(shape.local) == len(cand.shape.local) > 0:
            dist, idx = cand.shape.nearest.query(moved_all[j] - cand.shape.centre, k=1,
                                                  distance_upper_bound=tol * 1.0001)
            if float(dist.max()) <= tol and one_to_one(idx, len(cand.shape.local)):
                dev = float(dist.max())
        if not dev <= tol:
            dev = verify(shape, cand.shape, moved, tol)
        if not dev <= tol:
            return None
        moved.deviation = dev
        members.append((cand, moved))
    return CongruenceClass(new_rep, members)


def cohere(classes: list[CongruenceClass], tol: float) -> int:
    """Re-root each class in the reference's copy where it verifies (in place); how many classes changed."""
    ref = _reference(classes)
    if ref is None:
        return 0
    changed = 0
    for i, cls in enumerate(classes):
        if cls is ref or len(cls.members) < 2:
            continue
        k = _in_reference_copy(cls, ref, tol)
        if not k:  # none, or the representative is in the reference's copy already
            continue
        rerooted = _rerooted(cls, k, tol)
        if rerooted is not None:
            classes[i] = rerooted
            changed += 1
    return changed
