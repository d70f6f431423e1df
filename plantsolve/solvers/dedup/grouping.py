"""Phase 1 (paper Section "Basic algorithm", grouping) and phase 2's driver: products are grouped by
entity, ``ObjectType``, predefined type, the structure and styling of their body representation and
an invariant signature of their world geometry (point and triangle counts exactly; principal spreads
and centred-distance quantiles within the tolerance, through a k-d tree so that only plausible pairs
are ever compared). Within a group, the first unassigned product in GlobalId order becomes a
representative and every candidate near it in signature space is matched (``matching.match``); a
candidate that fails stays for a later representative. GlobalId order, not the file's: another
exporter writing the same model numbers its instances differently, and the representatives, the
transforms and the written file would follow the numbering."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.base import Progress, no_progress
from plantsolve.solvers.dedup.congruence import Candidate, CongruenceClass
from plantsolve.solvers.dedup.matching import (
    Match,
    Shape,
    first_verified,
    make_shape,
    match,
)
from plantsolve.solvers.dedup.representatives import cohere

QUANTILES = (0.0, 0.25, 0.5, 0.75, 1.0)
CANONICAL_DEPTH = 8


def canonical(value, depth: int = CANONICAL_DEPTH):
    """Content of an instance graph without instance ids (two equal styles give equal keys)."""
    if hasattr(value, "is_a") and hasattr(value, "id"):
        if depth <= 0:
            return (value.is_a(),)
        return (value.is_a(),) + tuple(canonical(v, depth - 1) for v in value)
    if isinstance(value, (tuple, list)):
        return tuple(canonical(v, depth) for v in value)
    if isinstance(value, float):
        return round(value, 12)
    return value


def style_key(model, representation) -> tuple:
    """The styles of the representation's items, by content."""
    keys = []
    for item in representation.Items or ():
        for styled in model.get_inverse(item):
            if styled.is_a("IfcStyledItem"):
                keys.append(canonical(styled.Styles))
    return tuple(sorted(map(repr, keys)))


def signatures(shapes: list[Shape]) -> np.ndarray:
    """Each shape's principal spreads, RMS radius and centred-distance quantiles, one row per shape. A
    group's shapes have as many points each (the group key counts them): their distances are one array
    and its quantiles one call, row by row the values of one shape's alone."""
    local = np.stack([s.local for s in shapes])
    d = np.sqrt(np.sum(local * local, axis=2))
    spreads = np.sqrt(np.maximum(np.stack([s.eigenvalues for s in shapes]), 0.0))
    radii = np.array([[s.radius] for s in shapes])
    return np.concatenate([spreads, radii, np.quantile(d, QUANTILES, axis=1).T], axis=1)


def product_key(product, representation, model, n_points: int, n_triangles: int) -> tuple:
    return (product.is_a(), getattr(product, "ObjectType", None), getattr(product, "PredefinedType", None),
            tuple(sorted(item.is_a() for item in representation.Items or ())), style_key(model, representation),
            n_points, n_triangles)


def canonical_order(candidates: list[Candidate]) -> list[Candidate]:
    """The candidates by GlobalId; products that repeat a GlobalId (an invalid file, warned about) by their
    world centre, then by every world point: an order no instance number decides, unless two products
    repeat both their GlobalId and their geometry."""
    global_ids = [str(c.product.GlobalId) for c in candidates]
    if len(set(global_ids)) == len(global_ids):  # no tie to break: the points' bytes are not made (15 MB, tunnel)
        return [candidates[i] for i in sorted(range(len(candidates)), key=global_ids.__getitem__)]
    return sorted(candidates, key=lambda c: (str(c.product.GlobalId), c.shape.centre.tolist(),
                                             c.shape.points.tobytes()))


def build_classes(candidates: list[Candidate], tol: float, *, allow_mirror: bool, allow_scale: bool,
                  progress: Progress = no_progress, span: tuple[float, float] = (0.0, 1.0)) -> list[CongruenceClass]:
    """Every candidate in exactly one class (singletons included), in the GlobalId order of their first members,
    each class's representative from the reference class's copy of the assembly where one is
    (:func:`representatives.cohere`)."""
    groups: dict[tuple, list[Candidate]] = {}
    for c in canonical_order(candidates):
        groups.setdefault(c.key, []).append(c)
    classes: list[CongruenceClass] = []
    done = 0
    lo, hi = span
    for group in groups.values():
        progress(lo + (hi - lo) * done / max(len(candidates), 1), f"matching {len(group)} products of "
                 f"{group[0].key[0]} {group[0].key[1] or ''}".rstrip())
        sig = signatures([c.shape for c in group])
        if allow_scale:  # scale-free: divide by the RMS radius
            sig = sig / np.maximum(sig[:, 3:4], 1e-300)
        tree = cKDTree(sig)
        assigned = np.zeros(len(group), dtype=bool)
        for i, rep in enumerate(group):
            if assigned[i]:
                continue
            assigned[i] = True
            identity = Match(np.eye(3), 1.0, np.zeros(3), 0.0, False)
            cls = CongruenceClass(rep, [(rep, identity)])
            r = (4 * tol / max(rep.shape.radius, 1e-300) + 1e-9) if allow_scale else 4 * tol + 1e-12
            for j in sorted(tree.query_ball_point(sig[i], r=r, p=np.inf)):
                if assigned[j]:
                    continue
                m = match(rep.shape, group[j].shape, tol, allow_mirror=allow_mirror, allow_scale=allow_scale)
                if m is not None:
                    assigned[j] = True
                    cls.members.append((group[j], m))
            classes.append(cls)
            done += len(cls.members)
            if len(classes) % 16 == 0:
                progress(lo + (hi - lo) * done / max(len(candidates), 1), "matching")
    cohere(classes, tol)
    return classes


def make_candidate(product, representation, model, points: np.ndarray, n_triangles: int) -> Candidate:
    return Candidate(product, product_key(product, representation, model, len(points), n_triangles), make_shape(points))


def pool_transforms(classes: list[CongruenceClass], tol: float, neighbours: int = 48) -> int:
    """The flyweight pool of transforms: a member takes the transform already used by a nearby member
    of an earlier class when that transform also verifies for it (two-way Hausdorff ≤ ``tol``). The
    eight segments of a tunnel ring then share one transform (whichever of a symmetric segment's
    valid rotations its own fit picked), and the post-pass merges their placements and operators.
    Candidates are the ``neighbours`` nearest members by centroid. Returns how many were replaced."""
    entries = [(ci, k) for ci, cls in enumerate(classes) for k in range(1, len(cls.members))]
    if len(entries) < 2:
        return 0
    centres = np.array([classes[ci].members[k][0].shape.centre for ci, k in entries])
    tree = cKDTree(centres - centres.mean(axis=0))
    _, near = tree.query(centres - centres.mean(axis=0), k=min(neighbours, len(entries)))
    class_of = np.array([ci for ci, _ in entries])
    replaced = 0
    final: dict[int, tuple] = {}  # entry → its transform's key and its match, read once (it is final when read)
    for index, (ci, k) in enumerate(entries):
        cls = classes[ci]
        cand, m = cls.members[k]
        tried: set[tuple] = set()
        tries = []
        row = np.atleast_1d(near[index])
        for n in row[class_of[row] < ci].tolist():  # only members of earlier classes, whose transforms are final
            got = final.get(n)
            if got is None:
                cj, kj = entries[n]
                other = classes[cj].members[kj][1]
                # a pooled transform is the same arrays in every member that took it: tried once
                got = final[n] = ((id(other.rotation), id(other.translation), other.scale), other)
            key, other = got
            if key in tried or other.mirror != m.mirror or abs(other.scale - m.scale) > 1e-12:
                continue
            tried.add(key)
            tries.append(other)
        found = first_verified(cls.representative.shape, cand.shape, tries, tol)
        if found is not None:
            other, dev = tries[found[0]], found[1]
            cls.members[k] = (cand, Match(other.rotation, other.scale, other.translation, dev, other.mirror))
            replaced += 1
    return replaced
