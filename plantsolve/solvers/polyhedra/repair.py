"""Repair before counting: coincident vertices, degenerate loop steps, hole orientation, T-junctions.

Exporters write the same corner several times with rounding differences, split a wall in two
against an unsplit roof, and put extra collinear vertices on roof edges; none of this changes the
solid, but every one of them would show up as an open edge. The repairs here are the ones
OpenStudio applies before it calls a zone enclosed (merge within a tolerance, insert the missing
collinear points), plus turning a hole that runs the same way as its outer loop.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from plantsolve.solvers.base import FieldError, InputRejected
from plantsolve.solvers.polyhedra.polygons import Polygons


@dataclass(frozen=True)
class Repairs:
    merged_vertices: int
    dropped_repeats: int
    holes_reversed: list[str]
    t_junctions_per_zone: np.ndarray  # vertices inserted into faces of each zone
    collapsed_faces: np.ndarray  # faces whose outer loop collapsed: kept, with no area, bounding no zone
    collapsed_holes: list[str]  # faces that lost an inner loop which collapsed


HASH = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xC2B2AE3D27D4EB4F), np.uint64(0x165667B19E3779F9))


def exact_labels(pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``pts`` that are equal (-0.0 equal to 0.0): the label of each row (0, 1, … by first
    occurrence order of the sort, not by value) and the first row of each label. One hash of the three
    coordinates' bits is sorted instead of the rows; rows that share a hash are compared, and a
    collision between different rows (never seen in practice) falls back to sorting the rows."""
    n = len(pts)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    bits = np.ascontiguousarray(pts + 0.0).view(np.uint64)  # + 0.0: -0.0 becomes 0.0
    h = np.zeros(n, dtype=np.uint64)
    for k in range(3):
        h ^= bits[:, k]
        h *= HASH[k]
        h ^= h >> np.uint64(29)  # the high bits into the low ones: float32 values read into doubles end in zeros
        h *= HASH[(k + 1) % 3]
    order = np.argsort(h)
    hs = h[order]
    new = np.ones(n, dtype=bool)
    new[1:] = hs[1:] != hs[:-1]
    group_sorted = np.cumsum(new) - 1
    first_sorted = np.minimum.reduceat(order, np.flatnonzero(new))  # smallest row of each hash group
    # every row equal to the one before it in the sort, where the two share a hash (one gather per coordinate)
    equal = np.ones(n - 1, dtype=bool)
    for k in range(3):
        column = bits[:, k][order]
        equal &= column[1:] == column[:-1]
    if not (new[1:] | equal).all():
        order = np.lexsort((bits[:, 2], bits[:, 1], bits[:, 0]))
        rows = bits[order]
        new = np.ones(n, dtype=bool)
        new[1:] = (rows[1:] != rows[:-1]).any(axis=1)
        group_sorted = np.cumsum(new) - 1
        first_sorted = np.minimum.reduceat(order, np.flatnonzero(new))
    label = np.empty(n, dtype=np.int64)
    label[order] = group_sorted
    return label, first_sorted


def merge_vertices(poly: Polygons, tolerance: float) -> tuple[Polygons, int]:
    """Vertices within ``tolerance`` of each other become the one with the smallest index (chains
    of close vertices collapse together, as in a union-find). Equal vertices are collapsed first by
    hashing (an unwelded STL repeats every corner about six times); the KD-tree then sees each
    position once."""
    mask = np.zeros(len(poly.points), dtype=bool)
    mask[poly.loop_vertices] = True
    used = np.flatnonzero(mask)
    exact, first = exact_labels(poly.points if len(used) == len(poly.points) else poly.points[used])  # first: smallest position in ``used`` of each distinct point
    label = exact
    if tolerance > 0:
        pairs = cKDTree(poly.points[used[first]], balanced_tree=False, compact_nodes=False).query_pairs(
            tolerance, output_type="ndarray")
        if len(pairs):
            n = len(first)
            graph = coo_matrix((np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
            _, component = connected_components(graph, directed=False)
            label = component[exact]
    n_labels = int(label.max()) + 1 if len(label) else 0
    merged = int(len(used) - n_labels)
    if merged == 0:
        return poly, 0
    if label is exact:  # no tolerance pairs: each label is one distinct point, its first row represents it
        representative = first
    else:
        representative = np.full(n_labels, len(used), dtype=np.int64)
        np.minimum.at(representative, label[first], first)
    if len(used) == len(poly.points):  # every point used (an STL): positions in ``used`` are point indices
        return poly.with_loops(representative[label][poly.loop_vertices], poly.loop_start), merged
    mapping = np.arange(len(poly.points))
    mapping[used] = used[representative[label]]
    return poly.with_loops(mapping[poly.loop_vertices], poly.loop_start), merged


def drop_repeats(poly: Polygons) -> tuple[Polygons, int, np.ndarray, list[str]]:
    """Remove a vertex equal to the one after it along its loop (after merging, a closing vertex that
    repeats the first one, or two exporter points that became one).

    A loop left with fewer than three distinct vertices has no area: the sliver facets exporters
    write, a window narrower than the merge tolerance. An inner loop of that kind is removed; a face
    whose outer loop collapses is kept (its id, its area of 0) but bounds no zone any more, so the
    faces around it close up as they do in the solid. Returns the polygons, the vertices dropped, the
    collapsed faces and the ids of faces that lost a hole. Only when no face is left to bound a zone
    is the request refused, naming the loops."""
    lv = poly.loop_vertices
    keep = lv != lv[poly.next_position()]
    dropped = int((~keep).sum())
    none = np.zeros(0, dtype=np.int64)
    if dropped == 0:
        return poly, 0, none, []
    loop_of = poly.position_loop
    n_loops = len(poly.loop_start) - 1
    lengths = np.bincount(loop_of[keep], minlength=n_loops)
    short = lengths < 3
    if not short.any():
        start = np.zeros(n_loops + 1, dtype=np.int64)
        np.cumsum(lengths, out=start[1:])
        return poly.with_loops(lv[keep], start), dropped, none, []
    outer = np.zeros(n_loops, dtype=bool)
    outer[poly.face_loop_start[:-1]] = True
    collapsed = np.unique(poly.loop_face[short & outer])
    bounding = poly.face_zone[:, 0] >= 0
    bounding[collapsed] = False
    if not bounding.any():
        errors = []
        for loop in np.flatnonzero(short)[:50]:
            face = int(poly.loop_face[loop])
            k = int(loop - poly.face_loop_start[face])
            errors.append(FieldError(("faces", face, "loops", k), f"face {poly.face_ids[face]!r}: the loop has fewer "
                                     "than 3 distinct vertices after merging vertices closer than merge_tolerance"))
        raise InputRejected(errors)
    holes = short & ~outer
    # a collapsed outer loop keeps every position (its repeats give it no area); a collapsed hole goes
    keep_position = np.where(short[loop_of], outer[loop_of], keep)
    lengths = np.bincount(loop_of[keep_position], minlength=n_loops)[~holes]
    start = np.zeros(len(lengths) + 1, dtype=np.int64)
    np.cumsum(lengths, out=start[1:])
    face_zone = poly.face_zone.copy()
    face_zone[collapsed] = -1
    out = replace(poly, loop_vertices=lv[keep_position], loop_start=start, loop_face=poly.loop_face[~holes],
                  face_zone=face_zone)
    hole_faces = [poly.face_ids[f] for f in np.unique(poly.loop_face[holes])]
    return out, int(len(lv) - keep_position.sum()), collapsed, hole_faces


def loop_area_vectors(poly: Polygons, loops: np.ndarray) -> np.ndarray:
    """Newell area vectors of the given loops (each loop's points taken relative to its first)."""
    out = np.zeros((len(loops), 3))
    for i, loop in enumerate(loops):
        p = poly.points[poly.loop_vertices[poly.loop_start[loop]:poly.loop_start[loop + 1]]]
        p = p - p[0]
        out[i] = 0.5 * np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)
    return out


def orient_holes(poly: Polygons) -> tuple[Polygons, list[str]]:
    """An inner loop must run against its outer loop (its area is subtracted); one that runs with it
    is reversed and named in the report."""
    n_loops = np.diff(poly.face_loop_start)
    faces = np.flatnonzero(n_loops > 1)
    if len(faces) == 0:
        return poly, []
    lv = poly.loop_vertices.copy()
    reversed_faces = []
    for f in faces:
        loops = np.arange(poly.face_loop_start[f], poly.face_loop_start[f + 1])
        areas = loop_area_vectors(poly, loops)
        for loop, area in zip(loops[1:], areas[1:]):
            if float(area @ areas[0]) > 0:
                s, t = poly.loop_start[loop], poly.loop_start[loop + 1]
                lv[s:t] = lv[s:t][::-1]
                reversed_faces.append(poly.face_ids[f])
    return poly.with_loops(lv, poly.loop_start), sorted(set(reversed_faces))


def insert_t_junctions(poly: Polygons, tolerance: float, max_passes: int = 4) -> tuple[Polygons, np.ndarray]:
    """Insert into a face's loop every vertex of the same zone that lies on one of its open edges
    strictly between the ends (within ``tolerance``): a wall split in two against an unsplit roof,
    or collinear extra vertices on a roof edge, then share edges as the map needs. Only open edges
    are searched; an edge-manifold surface has none and costs one grouping, which the map and the
    diagnostics then use (``poly.edge_groups``)."""
    per_zone = np.zeros(len(poly.zone_ids), dtype=np.int64)
    tol = max(tolerance, 1e-12)
    for pass_no in range(max_passes + 1):
        groups = poly.edge_groups
        if groups.edge_manifold:
            break
        position, _ = poly.edge_uses
        odd = groups.counts % 2 == 1
        if not odd.any() or pass_no == max_passes:
            break
        open_eu = np.flatnonzero(odd[groups.group()])
        nxt = poly.next_position()
        lv = poly.loop_vertices
        inserts: dict[int, list[tuple[float, int]]] = {}
        zone_of_open = groups.zone[open_eu]
        for zone in np.unique(zone_of_open):
            eus = open_eu[zone_of_open == zone]
            ends = np.unique(np.concatenate([lv[position[eus]], lv[nxt[position[eus]]]]))
            tree = cKDTree(poly.points[ends])
            a_idx, b_idx = lv[position[eus]], lv[nxt[position[eus]]]
            a, b = poly.points[a_idx], poly.points[b_idx]
            mid, half = 0.5 * (a + b), 0.5 * np.linalg.norm(b - a, axis=1)
            near = tree.query_ball_point(mid, half + tol)
            for k, candidates in enumerate(near):
                if len(candidates) <= 2:
                    continue
                w = ends[np.asarray(candidates)]
                w = w[(w != a_idx[k]) & (w != b_idx[k])]
                if len(w) == 0:
                    continue
                d = b[k] - a[k]
                length2 = float(d @ d)
                if length2 == 0:
                    continue
                rel = poly.points[w] - a[k]
                t = rel @ d / length2
                off = np.linalg.norm(rel - np.outer(t, d), axis=1)
                on = (off <= tol) & (t * np.sqrt(length2) > tol) & ((1 - t) * np.sqrt(length2) > tol)
                if not on.any():
                    continue
                pos = int(position[eus[k]])
                entries = inserts.setdefault(pos, [])
                # the loop runs a -> b at this position in stored order
                before = len(entries)
                entries.extend((float(tt), int(ww)) for tt, ww in zip(t[on], w[on]) if ww not in {e[1] for e in entries})
                per_zone[zone] += len(entries) - before
        if not inserts:
            break
        counts = np.zeros(len(lv), dtype=np.int64)
        for pos, entries in inserts.items():
            counts[pos] = len(entries)
        new_lv = np.empty(len(lv) + int(counts.sum()), dtype=np.int64)
        target = np.arange(len(lv)) + np.concatenate([[0], np.cumsum(counts)[:-1]])
        new_lv[target] = lv
        for pos, entries in inserts.items():
            entries.sort()
            new_lv[target[pos] + 1: target[pos] + 1 + len(entries)] = [w for _, w in entries]
        loop_of = poly.position_loop
        added = np.bincount(loop_of, weights=counts, minlength=len(poly.loop_start) - 1).astype(np.int64)
        start = poly.loop_start + np.concatenate([[0], np.cumsum(added)])
        poly = poly.with_loops(new_lv, start)
    return poly, per_zone


def repair(poly: Polygons, merge_tolerance: float) -> tuple[Polygons, Repairs]:
    """The repairs in the order they depend on each other: merge, drop repeats, holes, T-junctions."""
    poly, merged = merge_vertices(poly, merge_tolerance)
    poly, dropped, collapsed, holes_collapsed = drop_repeats(poly)
    poly, holes = orient_holes(poly)
    poly, per_zone = insert_t_junctions(poly, merge_tolerance)
    return poly, Repairs(merged_vertices=merged, dropped_repeats=dropped, holes_reversed=holes,
                         t_junctions_per_zone=per_zone, collapsed_faces=collapsed, collapsed_holes=holes_collapsed)
