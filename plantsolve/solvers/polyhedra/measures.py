"""Measures per orbit: loop and face area vectors (Newell), perimeters, planarity, and per-use volume
and flux terms for the divergence theorem.

Every face is cut into triangles along its own edges: a triangle stays itself, a longer loop is a
fan around its vertex mean. The fan's area vectors sum to the loop's Newell vector exactly, and two
faces sharing an edge share that edge in their fans, so a closed surface of non-planar faces still
encloses a well-defined volume. Coordinates are taken relative to the face's first vertex for the
face terms and relative to the zone's centre for the zone terms (a building 1e6 m from the origin
keeps its digits); the shift between the two frames is added back exactly through the face's area
vector. The numbers are the Newell/divergence ones; no geometric-algebra package is used.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from plantsolve.solvers.polyhedra.polygons import Polygons


@dataclass(frozen=True)
class FaceMeasures:
    # origin and flux are what use_terms needs; None in an analysis, which keeps the use terms made of them
    origin: np.ndarray | None  # (F, 3) first vertex of the face: the frame of the face terms
    area_vector: np.ndarray  # (F, 3) Newell vector, holes subtracted (they run the other way)
    flux: np.ndarray | None  # (F, 3) per axis k: integral of (x_k - origin_k) n_k over the face
    # (F, 3) the mean of the face's vertices relative to its origin: the zone's frame is made of these, so that an
    # open zone's signed volume (which depends on its frame) does not move with where a loop starts
    centroid: np.ndarray | None
    perimeter: np.ndarray  # (F,)
    planarity_error: np.ndarray  # (F,)

    @cached_property
    def area(self) -> np.ndarray:
        return np.linalg.norm(self.area_vector, axis=1)

    @cached_property
    def normal(self) -> np.ndarray:
        area = self.area
        return np.divide(self.area_vector, area[:, None], out=np.zeros_like(self.area_vector), where=area[:, None] > 0)


def _face_sums(values: np.ndarray, face_of: np.ndarray, n_faces: int) -> np.ndarray:
    """Sum rows of ``values`` per face (``face_of`` non-decreasing)."""
    out = np.zeros((n_faces,) + values.shape[1:])
    if len(values) == 0:
        return out
    starts = np.flatnonzero(np.r_[True, face_of[1:] != face_of[:-1]])
    out[face_of[starts]] = np.add.reduceat(values, starts, axis=0)
    return out


def face_measures(poly: Polygons) -> FaceMeasures:
    """Newell area vectors and divergence-theorem flux terms of every face, from its fan triangles
    (the paper's per-orbit measures: each loop is an ⟨α0, α1⟩ orbit, each term a sum over its darts)."""
    lengths = poly.loop_lengths
    if len(lengths) == poly.n_faces and (lengths == 3).all():
        return _triangle_measures(poly)
    lv = poly.loop_vertices
    n_faces = poly.n_faces
    origin = poly.points[lv[poly.face_position_start[:-1]]]
    position_face = poly.position_face
    rel = poly.points[lv] - origin[position_face]  # every loop position in its face's frame
    loop_tri = lengths == 3
    # triangles: loops of three vertices as they are
    tri_loops = np.flatnonzero(loop_tri)
    s = poly.loop_start[tri_loops]
    t0, t1, t2 = rel[s], rel[s + 1], rel[s + 2]
    tri_face = poly.loop_face[tri_loops]
    # longer loops: a fan around the loop's vertex mean, one triangle per edge
    fan_loops = np.flatnonzero(~loop_tri)
    if len(fan_loops):
        fan_lengths = lengths[fan_loops]
        fan_pos = _ranges(poly.loop_start[fan_loops], fan_lengths)
        nxt = poly.next_position()
        loop_index = np.repeat(np.arange(len(fan_loops)), fan_lengths)
        sums = np.add.reduceat(rel[fan_pos], np.r_[0, np.cumsum(fan_lengths)[:-1]], axis=0)
        centre = sums / fan_lengths[:, None]
        f0, f1, f2 = centre[loop_index], rel[fan_pos], rel[nxt[fan_pos]]
        fan_face = poly.loop_face[fan_loops][loop_index]
        t0, t1, t2 = np.concatenate([t0, f0]), np.concatenate([t1, f1]), np.concatenate([t2, f2])
        tri_face = np.concatenate([tri_face, fan_face])
        order = np.argsort(tri_face, kind="stable")
        t0, t1, t2, tri_face = t0[order], t1[order], t2[order], tri_face[order]
    a = 0.5 * _cross(t1 - t0, t2 - t0)
    m = (t0 + t1 + t2) / 3.0
    area_vector = _face_sums(a, tri_face, n_faces)
    flux = _face_sums(m * a, tri_face, n_faces)

    nxt = poly.next_position()
    edge_len = np.linalg.norm(rel[nxt] - rel, axis=1)
    perimeter = np.bincount(position_face, weights=edge_len, minlength=n_faces)
    count = np.bincount(position_face, minlength=n_faces)
    centroid = np.stack([np.bincount(position_face, weights=rel[:, k], minlength=n_faces) for k in range(3)], axis=1)
    centroid /= np.maximum(count, 1)[:, None]
    norm = np.linalg.norm(area_vector, axis=1)
    normal = np.divide(area_vector, norm[:, None], out=np.zeros_like(area_vector), where=norm[:, None] > 0)
    distance = np.abs(np.einsum("ij,ij->i", rel - centroid[position_face], normal[position_face]))
    planarity = np.zeros(n_faces)
    starts = poly.face_position_start
    nonempty = starts[1:] > starts[:-1]
    if len(distance):
        planarity[nonempty] = np.maximum.reduceat(distance, starts[:-1][nonempty])
    return FaceMeasures(origin=origin, area_vector=area_vector, flux=flux, centroid=centroid, perimeter=perimeter,
                        planarity_error=planarity)


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Row-wise u × v (np.cross's products, without its temporaries)."""
    out = np.empty_like(u)
    out[:, 0] = u[:, 1] * v[:, 2] - u[:, 2] * v[:, 1]
    out[:, 1] = u[:, 2] * v[:, 0] - u[:, 0] * v[:, 2]
    out[:, 2] = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
    return out


def _row_norm(x: np.ndarray) -> np.ndarray:
    return np.sqrt(x[:, 0] * x[:, 0] + x[:, 1] * x[:, 1] + x[:, 2] * x[:, 2])


def _triangle_measures(poly: Polygons) -> FaceMeasures:
    """:func:`face_measures` of faces that are each one triangle (a mesh): the same terms, with no fan,
    no per-face sums and no per-position arrays."""
    p = poly.points
    tri = poly.loop_vertices.reshape(-1, 3)
    origin = p[tri[:, 0]]
    t1 = p[tri[:, 1]] - origin
    t2 = p[tri[:, 2]] - origin
    area_vector = _cross(t1, t2)
    area_vector *= 0.5
    flux = (t1 + t2) / 3.0
    flux *= area_vector
    e1, e2 = _row_norm(t1), _row_norm(t2 - t1)
    perimeter = e1 + e2
    perimeter += _row_norm(t2)
    # the largest distance of a corner from the plane through the corners' mean (zero up to rounding)
    norm = _row_norm(area_vector)
    normal = np.divide(area_vector, norm[:, None], out=np.zeros_like(area_vector), where=norm[:, None] > 0)
    centroid = (t1 + t2) / 3.0
    planarity = np.abs(np.einsum("ij,ij->i", centroid, normal))
    for corner in (t1, t2):
        np.maximum(planarity, np.abs(np.einsum("ij,ij->i", corner - centroid, normal)), out=planarity)
    return FaceMeasures(origin=origin, area_vector=area_vector, flux=flux, centroid=centroid, perimeter=perimeter,
                        planarity_error=planarity)


def _ranges(starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Concatenated ranges starts[i] .. starts[i] + lengths[i]."""
    offsets = np.cumsum(lengths) - lengths
    return np.arange(int(lengths.sum())) - np.repeat(offsets, lengths) + np.repeat(starts, lengths)


@dataclass(frozen=True)
class UseTerms:
    centre: np.ndarray  # (Z, 3) the frame of each zone
    area_vector: np.ndarray  # (U, 3) signed by the use's orientation
    flux: np.ndarray  # (U, 3) per axis, in the zone's frame


def use_terms(measures: FaceMeasures, use_face: np.ndarray, use_zone: np.ndarray, use_sign: np.ndarray,
              n_zones: int) -> UseTerms:
    """Each face use's area vector and flux terms in its zone's frame: flux_k = sign * (F_k + (o_k - c_k) A_k),
    the divergence theorem's ∫ (x_k - c_k) n_k dA; the zone volume is (Σ_k flux_k) / 3."""
    identity = len(use_face) == len(measures.origin) and bool((use_sign > 0).all()) and \
        np.array_equal(use_face, np.arange(len(use_face)))  # one use per face, as given (a mesh)
    origin = measures.origin if identity else measures.origin[use_face]
    counts = np.bincount(use_zone, minlength=n_zones)
    # the zone's frame: the mean of its faces' vertex means, each taken relative to the zone's first face
    # origin so that the mean of large coordinates loses nothing
    first = np.full(n_zones, len(use_zone), dtype=np.int64)
    np.minimum.at(first, use_zone, np.arange(len(use_zone)))
    base = origin[np.minimum(first, len(use_zone) - 1)] if len(use_zone) else np.zeros((n_zones, 3))
    shift = origin - base[use_zone]
    centroid = measures.centroid if identity else measures.centroid[use_face]
    mean_shift = np.stack([np.bincount(use_zone, weights=shift[:, k] + centroid[:, k], minlength=n_zones)
                           for k in range(3)], axis=1)
    centre_offset = mean_shift / np.maximum(counts, 1)[:, None]
    offset = shift - centre_offset[use_zone]  # o_f - c_z, small
    if identity:  # the same numbers without copying the face terms (a sign of +1 changes nothing)
        flux = offset
        flux *= measures.area_vector
        flux += measures.flux
        return UseTerms(centre=base + centre_offset, area_vector=measures.area_vector, flux=flux)
    area = measures.area_vector[use_face] * use_sign[:, None]
    flux = (measures.flux[use_face] + offset * measures.area_vector[use_face]) * use_sign[:, None]
    return UseTerms(centre=base + centre_offset, area_vector=area, flux=flux)
