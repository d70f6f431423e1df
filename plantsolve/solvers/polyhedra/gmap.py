"""The generalized map of the zones' surfaces: darts and the involutions α0, α1, α2, α3.

The paper (Soto-Francés, Sarabia-Escrivá, Pinazo-Ojer: consistently oriented dart-based 3-D
modelling with geometric algebra and combinatorial maps) keeps the topology of a polyhedral
complex in an n-G-map and attaches the geometry to its orbits. Vocabulary as in CGAL's
combinatorial maps: a *dart* is one (vertex, edge, face, zone) flag; αi sends a dart to the dart
that differs from it only in its i-cell:

- α0 — the other end of the same edge of the same face loop;
- α1 — the other edge of the same loop at the same vertex;
- α2 — the same edge and vertex in the neighbouring face of the same zone (fixed where the edge
  is open, and where more than two faces meet: a non-manifold edge has no α2 partner);
- α3 — the same edge and vertex of the same face seen from the other zone (a shared wall).

Orbits give the cells: ⟨α0, α1⟩ a face loop, ⟨α0, α2, α3⟩ an edge, ⟨α1, α2⟩ a vertex's fan in one
zone, ⟨α0, α1, α2⟩ a connected sheet of a zone's surface. Darts are stored as arrays: the edge-use
``e`` (one loop edge of one face use) owns darts ``2e`` (at its first vertex in loop order) and
``2e + 1`` (at its second).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from plantsolve.solvers.polyhedra.polygons import Polygons, expand_uses


@dataclass(frozen=True)
class EdgeGroups:
    """Edge-uses grouped by (zone, undirected edge): one group per edge of each zone's surface."""

    order: np.ndarray  # edge-uses sorted by group
    group: np.ndarray  # group of each edge-use
    starts: np.ndarray  # first index into ``order`` of each group
    counts: np.ndarray  # edge-uses per group (2 when manifold)
    lo: np.ndarray  # smaller vertex index of each edge-use's edge
    hi: np.ndarray
    zone: np.ndarray  # zone of each edge-use


def group_edges(poly: Polygons, use_zone: np.ndarray, position: np.ndarray, use: np.ndarray) -> EdgeGroups:
    nxt = poly.next_position()
    a = poly.loop_vertices[position]
    b = poly.loop_vertices[nxt[position]]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    zone = use_zone[use]
    n_points = max(len(poly.points), 1)
    n_zones = max(len(poly.zone_ids), 1)
    if n_zones * n_points * n_points < 2 ** 62:
        key = (zone * n_points + lo) * n_points + hi
        order = np.argsort(key)
        ks = key[order]
        new = np.ones(len(ks), dtype=bool)
        new[1:] = ks[1:] != ks[:-1]
    else:
        order = np.lexsort((hi, lo, zone))
        zs, ls, hs = zone[order], lo[order], hi[order]
        new = np.ones(len(order), dtype=bool)
        new[1:] = (zs[1:] != zs[:-1]) | (ls[1:] != ls[:-1]) | (hs[1:] != hs[:-1])
    starts = np.flatnonzero(new)
    counts = np.diff(np.append(starts, len(order)))
    group = np.empty(len(order), dtype=np.int64)
    group[order] = np.cumsum(new) - 1
    return EdgeGroups(order=order, group=group, starts=starts, counts=counts, lo=lo, hi=hi, zone=zone)


@dataclass(frozen=True)
class GMap:
    """A 3-G-map over the enclosure faces of every zone (subsurfaces are not part of it)."""

    alpha: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    dart_vertex: np.ndarray  # vertex (embedding of the 0-cell) of each dart
    position: np.ndarray  # loop position of each edge-use
    use: np.ndarray  # face use of each edge-use
    use_face: np.ndarray
    use_zone: np.ndarray
    use_sign: np.ndarray
    groups: EdgeGroups
    pair_first: np.ndarray  # the two edge-uses of each manifold edge (α2-sewn)
    pair_second: np.ndarray
    pair_consistent: np.ndarray  # the two faces run along the sewn edge in opposite directions

    @property
    def n_darts(self) -> int:
        return len(self.dart_vertex)

    def orbits(self, *indices: int) -> tuple[int, np.ndarray]:
        """Number of ⟨α_i, …⟩ orbits and the orbit of every dart."""
        n = self.n_darts
        rows = np.concatenate([np.arange(n)] * len(indices))
        cols = np.concatenate([self.alpha[i] for i in indices])
        graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(n, n)).tocsr()
        return connected_components(graph, directed=False)

    def vertex_fans(self) -> np.ndarray:
        """The ⟨α1, α2⟩ orbit of every edge-use's first corner. α1 pairs the two darts of a corner
        (edge-use ``e`` at its first vertex and the edge-use before it at its second), so these orbits
        are the corners joined by α2: the same orbits from half the nodes and a sixth of the links."""
        n_eu = len(self.position)
        darts = np.arange(2 * n_eu)
        # corner of a dart: 2e is edge-use e's first corner; 2e + 1 is the first corner of the next edge-use
        corner = np.where(darts % 2 == 0, darts // 2, self.alpha[1][darts] // 2)
        sewn = np.flatnonzero(self.alpha[2] != darts)
        graph = coo_matrix((np.ones(len(sewn), dtype=np.int8), (corner[sewn], corner[self.alpha[2][sewn]])),
                           shape=(n_eu, n_eu))
        return connected_components(graph, directed=False)[1]

    def is_involution(self) -> bool:
        """Every αi is its own inverse (a well-formed G-map)."""
        return all(np.array_equal(a[a], np.arange(self.n_darts)) for a in self.alpha)


def build_gmap(poly: Polygons, groups: EdgeGroups | None = None) -> GMap:
    """Sew the darts of every enclosure face use (the paper's model of the complex): α0 and α1 from
    the loops, α2 between the two faces of a manifold edge of a zone, α3 between the two uses of a
    face shared by two zones."""
    use_face, use_zone, use_sign = poly.uses()
    position, use = expand_uses(poly, use_face)
    n_eu = len(position)
    nxt = poly.next_position()
    lv = poly.loop_vertices
    darts = np.arange(2 * n_eu)
    dart_vertex = np.empty(2 * n_eu, dtype=np.int64)
    dart_vertex[0::2] = lv[position]
    dart_vertex[1::2] = lv[nxt[position]]

    alpha0 = darts ^ 1
    e = np.arange(n_eu)
    e_next = e + (nxt[position] - position)
    alpha1 = darts.copy()
    alpha1[2 * e + 1] = 2 * e_next
    alpha1[2 * e_next] = 2 * e + 1

    if groups is None:
        groups = group_edges(poly, use_zone, position, use)
    sewn = groups.starts[groups.counts == 2]
    first, second = groups.order[sewn], groups.order[sewn + 1]
    same_start = dart_vertex[2 * first] == dart_vertex[2 * second]
    alpha2 = darts.copy()
    partner_of_start = np.where(same_start, 2 * second, 2 * second + 1)
    partner_of_end = np.where(same_start, 2 * second + 1, 2 * second)
    alpha2[2 * first] = partner_of_start
    alpha2[partner_of_start] = 2 * first
    alpha2[2 * first + 1] = partner_of_end
    alpha2[partner_of_end] = 2 * first + 1
    # Directed along the zone's orientation, the two faces must traverse the edge in opposite
    # directions; the same direction means one of them is turned the wrong way.
    sign = use_sign[use]
    consistent = same_start != (sign[first] == sign[second])

    alpha3 = darts.copy()
    use_eu_start = np.searchsorted(use, np.arange(len(use_face) + 1))
    second_uses = np.flatnonzero(use_sign < 0)
    if len(second_uses):
        lengths = use_eu_start[second_uses + 1] - use_eu_start[second_uses]
        offsets = np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)
        mine = np.repeat(use_eu_start[second_uses], lengths) + offsets
        theirs = np.repeat(use_eu_start[second_uses - 1], lengths) + offsets
        for k in (0, 1):
            alpha3[2 * mine + k] = 2 * theirs + k
            alpha3[2 * theirs + k] = 2 * mine + k
    return GMap(alpha=(alpha0, alpha1, alpha2, alpha3), dart_vertex=dart_vertex, position=position, use=use,
                use_face=use_face, use_zone=use_zone, use_sign=use_sign, groups=groups,
                pair_first=first, pair_second=second, pair_consistent=consistent)
