"""Diagnostics instead of silent numbers: open and non-manifold edges and vertices, sheets,
orientation, Euler characteristic and genus, all read from the generalized map's orbits."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from plantsolve.solvers.polyhedra.gmap import GMap, components
from plantsolve.solvers.polyhedra.sorting import counts_of, dense_labels, distinct


@dataclass(frozen=True)
class Orientation:
    factor: np.ndarray  # (U,) +1 where the use points out of its zone, -1 where it points in
    conflict: np.ndarray  # (U,) the use's sheet cannot be oriented consistently
    sheet: np.ndarray  # (U,) connected sheet of each use: its ⟨α0, α1, α2⟩ orbit


def orient(gmap: GMap, weight: np.ndarray, volume: np.ndarray, n_zones: int) -> Orientation:
    """Consistent orientation from the map (the paper's consistently oriented darts): each sheet is
    2-coloured across its α2-sewn edges (a use that runs along a shared edge the same way as its
    neighbour gets the other colour); the colour with the larger area is taken as the sheet's
    orientation, and the zone's sign of the volume so oriented says whether that is outward.
    The ⟨α0, α1⟩ orbits are the loops of one use, so the ⟨α0, α1, α2⟩ orbits (sheets) come out of
    the same quotient graph of uses joined by α2, with far fewer nodes than darts."""
    n = len(gmap.use_face)
    u1, u2 = gmap.use[gmap.pair_first], gmap.use[gmap.pair_second]
    c = gmap.pair_consistent
    comp = components(2 * n, (u1, u1 + n), (np.where(c, u2, u2 + n), np.where(c, u2 + n, u2)))
    mine, other = comp[:n], comp[n:]
    conflict = mine == other
    sheet_label = np.minimum(mine, other)
    parity = (mine != sheet_label).astype(np.int64)
    sheet = dense_labels(sheet_label, 2 * n)
    n_sheets = int(sheet.max()) + 1 if n else 0
    weight_flipped = np.bincount(sheet, weights=weight * parity, minlength=n_sheets)
    weight_total = np.bincount(sheet, weights=weight, minlength=n_sheets)
    majority = (weight_flipped > weight_total - weight_flipped).astype(np.int64)
    fixed = np.where(parity != majority[sheet], -1, 1)
    zone = gmap.use_zone
    oriented = np.bincount(zone, weights=fixed * volume, minlength=n_zones)
    zone_sign = np.where(oriented < 0, -1, 1)
    return Orientation(factor=fixed * zone_sign[zone], conflict=conflict, sheet=sheet)


@dataclass(frozen=True)
class Topology:
    open_groups: np.ndarray  # edge groups used an odd number of times
    non_manifold_groups: np.ndarray  # edge groups used more than twice
    non_manifold_vertices: list[np.ndarray]  # per zone, vertex indices
    vertices: np.ndarray  # (Z,) V
    edges: np.ndarray  # (Z,) E
    faces: np.ndarray  # (Z,) F
    inner_loops: np.ndarray  # (Z,)
    boundary_loops: np.ndarray  # (Z,) connected runs of open edges
    sheets: np.ndarray  # (Z,)

    @property
    def euler(self) -> np.ndarray:
        """V - E + F - (inner loops): a face with k holes counts as a disc less k (Euler-Poincaré)."""
        return self.vertices - self.edges + self.faces - self.inner_loops


def topology(gmap: GMap, loops_per_face: np.ndarray, sheet: np.ndarray, n_zones: int) -> Topology:
    """Cell counts per zone from the map's orbits and the edge defects (the paper's topology read from
    the G-map: edges as ⟨α0, α2⟩ groups, vertex fans as ⟨α1, α2⟩ orbits)."""
    groups = gmap.groups
    group_zone = groups.zone[groups.order[groups.starts]]
    open_groups = np.flatnonzero(groups.counts % 2 == 1)
    nm_groups = np.flatnonzero(groups.counts > 2)
    edges = np.bincount(group_zone, minlength=n_zones)
    faces = np.bincount(gmap.use_zone, minlength=n_zones)
    inner = np.bincount(gmap.use_zone, weights=loops_per_face[gmap.use_face] - 1, minlength=n_zones).astype(np.int64)
    # vertex fans: ⟨α1, α2⟩ orbits; more than one at a vertex of a zone means sheets touching there (found first:
    # their graph is the largest temporary here, and the per-corner keys below need not be alive meanwhile)
    fan = gmap.vertex_fans()
    corner_vertex = gmap.loop_vertices[gmap.position]  # every vertex of a loop is the first vertex of one edge-use
    n_points = int(corner_vertex.max()) + 1 if len(corner_vertex) else 1
    zv = gmap.use_zone[gmap.use] * n_points + corner_vertex
    del corner_vertex
    zv_bound = max(n_zones, 1) * n_points
    zv_unique = distinct(zv, zv_bound)
    vertices = np.bincount(zv_unique // n_points, minlength=n_zones)
    fan_first = np.full(int(fan.max()) + 1 if len(fan) else 0, -1, dtype=np.int64)
    fan_first[fan[::-1]] = np.arange(len(fan))[::-1]
    fan_keys, fans_per_vertex = counts_of(zv[fan_first], zv_bound)
    pinched = fan_keys[fans_per_vertex > 1]
    nm_vertices = [pinched[pinched // n_points == z] % n_points for z in range(n_zones)]
    # boundary loops: connected runs of open edges, per zone
    boundary = np.zeros(n_zones, dtype=np.int64)
    if len(open_groups):
        z = group_zone[open_groups]
        ends_lo = z * n_points + groups.lo[open_groups]
        ends_hi = z * n_points + groups.hi[open_groups]
        ends = np.concatenate([ends_lo, ends_hi])
        nodes = distinct(ends, zv_bound)
        inverse = np.searchsorted(nodes, ends)
        k = len(open_groups)
        label = components(len(nodes), (inverse[:k],), (inverse[k:],))
        comp_zone = np.zeros(label.max() + 1, dtype=np.int64)
        comp_zone[label] = nodes // n_points
        boundary = np.bincount(comp_zone, minlength=n_zones)
    sheet_zone = np.zeros(int(sheet.max()) + 1 if len(sheet) else 0, dtype=np.int64)
    sheet_zone[sheet] = gmap.use_zone
    return Topology(open_groups=open_groups, non_manifold_groups=nm_groups, non_manifold_vertices=nm_vertices,
                    vertices=vertices, edges=edges, faces=faces, inner_loops=inner, boundary_loops=boundary,
                    sheets=np.bincount(sheet_zone, minlength=n_zones))


def genus(euler: int, sheets: int, boundary_loops: int, manifold: bool, orientable: bool) -> int | None:
    """Handles of an orientable surface from χ = 2s - 2g - b; ``None`` where that formula does not hold."""
    if not (manifold and orientable):
        return None
    twice = 2 * sheets - euler - boundary_loops
    if twice < 0 or twice % 2:
        return None
    return twice // 2
