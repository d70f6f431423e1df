"""Nearest points of a product's few hundred points, answered as ``cKDTree.query(x, k=1)`` answers them (the same
distances, bit for bit, and the same indices), without a tree search for the points that land next to one point.

Matching, pooling, re-rooting and the proof ask the same question thousands of times: where do a few hundred moved
points land among a member's points? Almost always each lands within the tolerance of one point and far from every
other, and the tree then spends ~0.35 µs a point (plus ~10 µs a call) confirming it. Here the points are sorted by
their projection on one fixed direction: a query point whose projection window (half-width ``window``) holds one
point, and lies within ``window`` of it, has that point as its unique nearest (every other point differs by more
than ``window`` along the direction, so it is farther); with ``distance_upper_bound``, a window that holds none
means no point within the bound. Everything else (several points in the window, none in an unbounded query, a
distance on the window's edge) goes to the tree. The distance is computed as the tree computes it, the squares
summed in coordinate order, then the square root (the tests compare bits); every comparison keeps a margin for
rounding, so no answer rests on a tie.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

# a direction no axis, diagonal or simple ratio of a model's coordinates lies along: two points of a shape rarely
# share a projection on it
DIRECTION = np.array([1.0, np.sqrt(2.0), np.pi]) / np.sqrt(3.0 + np.pi ** 2)
# the rounding margin, relative to the points' extent and the window: projections and distances (three-term sums)
# err by under 1e-15 of the coordinates, so it covers query points out to 1e3 times as far, and one farther than
# that is farther than the window from every point (no answer then rests on the margin)
ROUNDING = 1e-12


class NearestPoints:
    """``cKDTree(points).query`` with k=1, the tree built only when a query needs it."""

    def __init__(self, points: np.ndarray):
        self.points = np.ascontiguousarray(points, dtype=float)
        along = self.points @ DIRECTION
        order = np.argsort(along, kind="stable")
        self.along = along[order]
        self.order = np.append(order, 0)  # a query past the last projection reads the sentinel (its count is 0)
        self.extent = float(np.abs(self.points).max()) if len(self.points) else 0.0
        self._tree: cKDTree | None = None

    @property
    def tree(self) -> cKDTree:
        if self._tree is None:
            self._tree = cKDTree(self.points)
        return self._tree

    def query(self, x: np.ndarray, k: int = 1, distance_upper_bound: float = np.inf,
              window: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(distances, indices)`` as ``cKDTree(points).query(x, k=1, distance_upper_bound=...)`` gives them (a
        point with none within the bound: ``inf`` and ``len(points)``). ``window``: how close a query point must
        land to one point for the answer to be found without the tree (an unbounded query's; a bounded one's is
        the bound)."""
        if k != 1:
            raise ValueError("only the nearest point (k=1)")
        x = np.asarray(x, dtype=float)
        n, m = len(self.points), len(x)
        bounded = math.isfinite(distance_upper_bound)
        width = float(distance_upper_bound) if bounded else (float(window) if window is not None else 0.0)
        if n == 0 or m == 0 or not width > 0:
            return self.tree.query(x, k=1, distance_upper_bound=distance_upper_bound)
        along = x @ DIRECTION
        slack = ROUNDING * (self.extent + width)
        lo = self.along.searchsorted(along - (width + slack), side="left")
        count = self.along.searchsorted(along + (width + slack), side="right") - lo
        near = self.order[lo]
        diff = x - self.points[near]
        diff *= diff  # the tree's sum: the squares in coordinate order
        d = np.sqrt(diff[:, 0] + diff[:, 1] + diff[:, 2])
        one = count == 1
        found = one & (d <= width - slack)
        if found.all() and np.isfinite(along).all():  # the usual answer: every point next to one point alone
            return d, near
        dist = np.where(found, d, np.inf)
        idx = np.where(found, near, n)
        settled = found
        if bounded:  # nothing in the window, or only a point past the bound: none within it
            settled = found | (count == 0) | (one & (d >= width + slack))
        settled &= np.isfinite(along)
        if not settled.all():
            rest = ~settled
            dist[rest], idx[rest] = self.tree.query(x[rest], k=1, distance_upper_bound=distance_upper_bound)
        return dist, idx
