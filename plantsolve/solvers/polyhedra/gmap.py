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
``2e + 1`` (at its second). The involutions are made when asked (``alpha``): the measures and
diagnostics read the same orbits from the edge groups and the loops (α2 pairs, corners), which
for a million-triangle mesh spares four arrays of six million darts.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from plantsolve.solvers.polyhedra.edges import EdgeGroups, group_edges  # noqa: F401  (re-exported)
from plantsolve.solvers.polyhedra.polygons import Polygons


@dataclass(frozen=True)
class GMap:
    """A 3-G-map over the enclosure faces of every zone (subsurfaces are not part of it)."""

    position: np.ndarray  # loop position of each edge-use
    use: np.ndarray  # face use of each edge-use
    use_face: np.ndarray
    use_zone: np.ndarray
    use_sign: np.ndarray
    groups: EdgeGroups
    pair_first: np.ndarray  # the two edge-uses of each manifold edge (α2-sewn)
    pair_second: np.ndarray
    pair_same_start: np.ndarray  # the two edge-uses of the pair start at the same vertex
    pair_consistent: np.ndarray  # the two faces run along the sewn edge in opposite directions
    next_edge_use: np.ndarray  # the edge-use after each one along its loop (α1 at its second dart)
    loop_vertices: np.ndarray = None  # the polygons' loop vertices (the darts' embedding)
    next_positions: np.ndarray = None

    @property
    def n_darts(self) -> int:
        return 2 * len(self.position)

    @cached_property
    def dart_vertex(self) -> np.ndarray:
        """Vertex (embedding of the 0-cell) of each dart."""
        out = np.empty(self.n_darts, dtype=np.int64)
        out[0::2] = self.loop_vertices[self.position]
        out[1::2] = self.loop_vertices[self.next_positions[self.position]]
        return out

    @cached_property
    def alpha(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """α0, α1, α2, α3 as arrays over the darts (each an involution)."""
        n_eu = len(self.position)
        darts = np.arange(2 * n_eu)
        alpha0 = darts ^ 1
        e = np.arange(n_eu)
        alpha1 = darts.copy()
        alpha1[2 * e + 1] = 2 * self.next_edge_use
        alpha1[2 * self.next_edge_use] = 2 * e + 1
        first, second, same_start = self.pair_first, self.pair_second, self.pair_same_start
        alpha2 = darts.copy()
        partner_of_start = np.where(same_start, 2 * second, 2 * second + 1)
        partner_of_end = np.where(same_start, 2 * second + 1, 2 * second)
        alpha2[2 * first] = partner_of_start
        alpha2[partner_of_start] = 2 * first
        alpha2[2 * first + 1] = partner_of_end
        alpha2[partner_of_end] = 2 * first + 1
        alpha3 = darts.copy()
        use_eu_start = np.searchsorted(self.use, np.arange(len(self.use_face) + 1))
        second_uses = np.flatnonzero(self.use_sign < 0)
        if len(second_uses):
            lengths = use_eu_start[second_uses + 1] - use_eu_start[second_uses]
            offsets = np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths, lengths)
            mine = np.repeat(use_eu_start[second_uses], lengths) + offsets
            theirs = np.repeat(use_eu_start[second_uses - 1], lengths) + offsets
            for k in (0, 1):
                alpha3[2 * mine + k] = 2 * theirs + k
                alpha3[2 * theirs + k] = 2 * mine + k
        return alpha0, alpha1, alpha2, alpha3

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
        are the corners joined by α2: each sewn pair joins the corners at its two ends — start with
        start where the two edge-uses run the same way, start with end where they run against each other."""
        n_eu = len(self.position)
        first, second = self.pair_first, self.pair_second
        first_end, second_end = self.next_edge_use[first], self.next_edge_use[second]
        same = self.pair_same_start
        return components(n_eu, (first, first_end),
                          (np.where(same, second, second_end), np.where(same, second_end, second)))

    def is_involution(self) -> bool:
        """Every αi is its own inverse (a well-formed G-map)."""
        return all(np.array_equal(a[a], np.arange(self.n_darts)) for a in self.alpha)


def components(n: int, a_parts: tuple[np.ndarray, ...], b_parts: tuple[np.ndarray, ...]) -> np.ndarray:
    """The connected component of each of ``n`` nodes joined by the edges ``a[i]``–``b[i]`` (``a``, ``b`` the
    parts concatenated). The edge lists are written straight into 32-bit indices and the graph handed over as
    CSR with float data (what ``connected_components`` converts to anyway): a third less peak memory than a
    COO matrix of 64-bit indices for the three million edge-uses of a million-triangle mesh."""
    index = np.int32 if n < 2 ** 31 else np.int64
    ends = []
    for parts in (a_parts, b_parts):
        out, at = np.empty(sum(len(p) for p in parts), dtype=index), 0
        for p in parts:
            out[at:at + len(p)] = p
            at += len(p)
        ends.append(out)
    graph = coo_matrix((np.ones(len(ends[0])), tuple(ends)), shape=(n, n)).tocsr()
    del ends
    return connected_components(graph, directed=False)[1]


def build_gmap(poly: Polygons, groups: EdgeGroups | None = None) -> GMap:
    """Sew the darts of every enclosure face use (the paper's model of the complex): α0 and α1 from
    the loops, α2 between the two faces of a manifold edge of a zone, α3 between the two uses of a
    face shared by two zones. The edges are grouped once per polygons value (``poly.edge_groups``)."""
    use_face, use_zone, use_sign = poly.uses()
    position, use = poly.edge_uses
    nxt = poly.next_position()
    lv = poly.loop_vertices
    e_next = np.arange(len(position)) + (nxt[position] - position)
    if groups is None:
        groups = poly.edge_groups
    sewn = groups.starts[groups.counts == 2]
    first, second = groups.order[sewn], groups.order[sewn + 1]
    same_start = lv[position[first]] == lv[position[second]]
    # Directed along the zone's orientation, the two faces must traverse the edge in opposite
    # directions; the same direction means one of them is turned the wrong way.
    sign = use_sign[use]
    consistent = same_start != (sign[first] == sign[second])
    return GMap(position=position, use=use, use_face=use_face, use_zone=use_zone, use_sign=use_sign, groups=groups,
                pair_first=first, pair_second=second, pair_same_start=same_start, pair_consistent=consistent,
                next_edge_use=e_next, loop_vertices=lv, next_positions=nxt)
