"""Edge-uses grouped by (zone, undirected edge): the one sort of the edges that repair, the generalized
map (α2) and the diagnostics share (``Polygons.edge_groups`` keeps it, trimesh-style, per mesh value)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantsolve.solvers.polyhedra.sorting import stable_order


@dataclass(frozen=True)
class EdgeGroups:
    """Edge-uses grouped by (zone, undirected edge): one group per edge of each zone's surface."""

    order: np.ndarray  # edge-uses sorted by group (stable: by edge-use within a group)
    starts: np.ndarray  # first index into ``order`` of each group
    counts: np.ndarray  # edge-uses per group (2 when manifold)
    lo: np.ndarray  # smaller vertex index of each group's edge (per group, not per edge-use: half the memory)
    hi: np.ndarray
    zone: np.ndarray  # zone of each edge-use

    def group(self) -> np.ndarray:
        """The group of each edge-use (made when asked: the map keeps the groups, and this is as long as the
        edge-uses)."""
        group = np.empty(len(self.order), dtype=np.int64)
        group[self.order] = np.repeat(np.arange(len(self.starts)), self.counts)
        return group

    @property
    def edge_manifold(self) -> bool:
        """Every edge of every zone is used exactly twice: nothing open, nothing non-manifold."""
        return bool((self.counts == 2).all())


def group_edges(a: np.ndarray, b: np.ndarray, zone: np.ndarray, n_points: int, n_zones: int) -> EdgeGroups:
    """Group the edge-uses running from vertex ``a`` to ``b`` in ``zone`` by (zone, undirected edge)."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    n_points, n_zones = max(n_points, 1), max(n_zones, 1)
    if n_zones * n_points * n_points < 2 ** 62:
        key = (zone * n_points + lo) * n_points + hi
        order = stable_order(key, n_zones * n_points * n_points)
        ks = key[order]
        new = np.ones(len(ks), dtype=bool)
        new[1:] = ks[1:] != ks[:-1]
        del key, ks
    else:
        order = np.lexsort((hi, lo, zone))
        zs, ls, hs = zone[order], lo[order], hi[order]
        new = np.ones(len(order), dtype=bool)
        new[1:] = (zs[1:] != zs[:-1]) | (ls[1:] != ls[:-1]) | (hs[1:] != hs[:-1])
    starts = np.flatnonzero(new)
    counts = np.diff(np.append(starts, len(order)))
    first = order[starts]
    return EdgeGroups(order=order, starts=starts, counts=counts, lo=lo[first], hi=hi[first], zone=zone)
