"""Stage 3 — polygonal curve from the spine point cloud (paper §1.3, §4.5).

1. Thinning: greedy Poisson-disk selection at spacing δ, each kept point replaced by the
   mean of the spine points within δ (removes the residual thickness of the MLS cloud, so
   the cloud is a "dense sample of a curve" as curve reconstruction requires); points with
   almost no spine points around them are dropped (failed projections).
2. NN-Crust (Dey & Kumar): every point joins its nearest neighbour and its nearest "half
   neighbour" (nearest point on the other side, angle > 90°). On a proper sample this is one
   simple path; where a single-view scan leaves gaps it gives several paths, which are
   joined end to end (nearest free ends first). If a component branches (noise), an
   equally sound fallback is used: the longest path (diameter) of the Euclidean minimum
   spanning tree.
3. Optional simplification (§4.5): minimum-vertex polygon with vertices from the input
   whose segments stay within ε of the skipped vertices (shortcut graph + shortest path,
   Imai–Iri / Eu–Toussaint); among minimum solutions the least squared error.
"""

from __future__ import annotations

import networkx as nx
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree, shortest_path
from scipy.spatial import cKDTree

from plantsolve.solvers.tube.vec3 import cross


def thin(points: np.ndarray, spacing: float) -> np.ndarray:
    """Poisson-disk subsample at ``spacing``, each kept point averaged over its δ-ball."""
    # process in a rigid-motion independent order: along the principal axis
    c = points - points.mean(0)
    axis = np.linalg.svd(c, full_matrices=False)[2][0]
    order = np.argsort(c @ axis, kind="stable")
    tree = cKDTree(points)
    taken = np.zeros(len(points), bool)
    keep = []
    for i in order:
        if taken[i]:
            continue
        keep.append(i)
        taken[tree.query_ball_point(points[i], spacing)] = True
    centres = points[keep]
    nbrs = tree.query_ball_point(centres, spacing)
    counts = np.array([len(n) for n in nbrs])
    # a lone spine point is a failed projection, not a piece of the curve
    dense = counts >= max(3, 0.1 * np.median(counts))
    return np.array([points[n].mean(0) for n, d in zip(nbrs, dense) if d]).reshape(-1, 3)


def nn_crust(points: np.ndarray) -> list[tuple[int, int]]:
    """NN-Crust edges (Dey & Kumar)."""
    k = min(12, len(points))
    d, idx = cKDTree(points).query(points, k=k)
    nn = idx[:, 1]
    edges = {tuple(sorted((i, int(nn[i])))) for i in range(len(points))}
    v_nn = points[nn] - points
    for i in range(len(points)):
        cand = idx[i, 2:]
        dots = (points[cand] - points[i]) @ v_nn[i]
        other = np.flatnonzero(dots < 0)
        if len(other):
            edges.add(tuple(sorted((i, int(cand[other[0]])))))
    return sorted(edges)


def _bridged_path(n: int, edges: list[tuple[int, int]], points: np.ndarray) -> tuple[list[int] | None, int]:
    """Order the NN-Crust graph into one path. Components that are simple paths (gaps in a
    single-view scan split the curve) are joined end to end, nearest free ends first
    (Kruskal on the path ends). None when a component branches or closes a cycle."""
    g = nx.Graph()
    g.add_nodes_from(range(n))
    g.add_edges_from(edges)
    comps = list(nx.connected_components(g))
    for c in comps:
        h = g.subgraph(c)
        if h.number_of_edges() != len(c) - 1 or (len(c) > 1 and max(dict(h.degree()).values()) > 2):
            return None, 0
    comp_of = np.empty(n, int)
    for ci, c in enumerate(comps):
        comp_of[list(c)] = ci
    ends = np.array([v for v in range(n) if g.degree(v) < 2])
    bridges = 0
    if len(comps) > 1:
        tree = cKDTree(points[ends])
        k = min(len(ends), 16)
        d, idx = tree.query(points[ends], k=k)
        pairs = sorted((d[a, b], int(ends[a]), int(ends[idx[a, b]])) for a in range(len(ends)) for b in range(1, k)
                       if comp_of[ends[a]] != comp_of[ends[idx[a, b]]])
        parent = list(range(len(comps)))

        def find(x):
            while parent[x] != x:
                parent[x] = parent[parent[x]]
                x = parent[x]
            return x

        for _, u, v in pairs:
            cu, cv = find(comp_of[u]), find(comp_of[v])
            if cu == cv or g.degree(u) >= 2 or g.degree(v) >= 2:
                continue
            g.add_edge(u, v)
            parent[cu] = cv
            bridges += 1
            if bridges == len(comps) - 1:
                break
        if bridges != len(comps) - 1:
            return None, bridges
    path_ends = [v for v in range(n) if g.degree(v) == 1]
    if len(path_ends) != 2:
        return None, bridges
    return nx.shortest_path(g, min(path_ends), max(path_ends)), bridges


def mst_diameter_path(points: np.ndarray) -> list[int]:
    """Longest path of the Euclidean MST (k-NN graph based)."""
    n = len(points)
    k = min(10, n)
    d, idx = cKDTree(points).query(points, k=k)
    rows = np.repeat(np.arange(n), k - 1)
    g = coo_matrix((d[:, 1:].ravel() + 1e-12, (rows, idx[:, 1:].ravel())), shape=(n, n)).tocsr()
    g = g.maximum(g.T)
    mst = minimum_spanning_tree(g)
    mst = mst + mst.T
    d0 = shortest_path(mst, indices=0, directed=False)
    d0[~np.isfinite(d0)] = -1
    a = int(np.argmax(d0))
    da, pred = shortest_path(mst, indices=a, directed=False, return_predecessors=True)
    da[~np.isfinite(da)] = -1
    b = int(np.argmax(da))
    path = [b]
    while path[-1] != a:
        path.append(int(pred[path[-1]]))
    return path[::-1]


def reconstruct_polyline(points: np.ndarray) -> tuple[np.ndarray, str]:
    """Ordered polyline through the spine points and the method that produced it."""
    if len(points) < 3:
        return points.copy(), "trivial"
    path, bridges = _bridged_path(len(points), nn_crust(points), points)
    method = "nn_crust" if bridges == 0 else f"nn_crust+{bridges}_gaps_bridged"
    if path is None:
        path = mst_diameter_path(points)
        method = "mst_diameter"
    return points[path], method


def _seg_dist(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances of pts (K, 3) to segments a→b, broadcast over leading axes of a, b."""
    ab = b - a
    L2 = np.maximum((ab * ab).sum(-1), 1e-300)
    t = np.clip(((pts - a) * ab).sum(-1) / L2, 0.0, 1.0)
    return np.linalg.norm(pts - a - t[..., None] * ab, axis=-1)


CONE_MARGIN = 1e-6  # radians: the disjoint-cone test below must hold beyond any round-off of its angles


def _reaches(poly: np.ndarray, eps: float, block: int = 200_000) -> np.ndarray:
    """For every vertex i but the last, the last vertex j that a shortcut i → j may reach: for every later j,
    two of the vertices it would skip cannot both lie within ε of it. Rows of vertices at a time; ``block``
    bounds the pairs held at once.

    A skipped vertex k at distance r_k > ε from p_i is within ε of the segment only if the segment's
    direction is within α_k = asin(ε / r_k) of the direction u_k to it (the segment lies on the ray from
    p_i, and the ray's distance is r_k sin θ, or r_k beyond 90°). Once the cone of a vertex K and that of
    the narrowest cone before it are disjoint (angle between the axes beyond the sum of the half-angles),
    no direction serves both, so no shortcut that skips both, i.e. none to a j > K, is within ε."""
    n = len(poly)
    out = np.empty(n - 1, dtype=np.int64)
    rows = max(1, block // n)
    for i0 in range(0, n - 1, rows):
        i = np.arange(i0, min(i0 + rows, n - 1))
        k = np.arange(n - 1 - i0)
        valid = k[None, :] < (n - 1 - i)[:, None]
        rel = poly[np.minimum(i[:, None] + 1 + k[None, :], n - 1)] - poly[i][:, None, :]
        r = np.sqrt((rel * rel).sum(-1))
        far = r > eps
        u = rel / np.where(far, r, 1.0)[..., None]
        alpha = np.where(far, np.arcsin(np.minimum(eps / np.where(far, r, 1.0), 1.0)), np.pi)
        narrowest = np.maximum.accumulate(np.where(alpha <= np.minimum.accumulate(alpha, axis=1), k, 0), axis=1)
        ur = np.take_along_axis(u, narrowest[..., None], axis=1)
        c = cross(ur.reshape(-1, 3), u.reshape(-1, 3)).reshape(u.shape)
        between = np.arctan2(np.sqrt((c ** 2).sum(-1)), (ur * u).sum(-1))
        apart = valid & (between > np.take_along_axis(alpha, narrowest, axis=1) + alpha + CONE_MARGIN)
        out[i] = np.where(apart.any(1), i + 1 + np.argmax(apart, axis=1), n - 1)
    return out


def _ragged_aranges(starts: np.ndarray, lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The ranges starts[r] ... starts[r] + lengths[r] - 1 one after another, and the r of each item."""
    owner = np.repeat(np.arange(len(lengths)), lengths)
    first = np.cumsum(lengths) - lengths
    return owner, starts[owner] + np.arange(len(owner)) - first[owner]


def _shortcut_rows(poly: np.ndarray, first_j: np.ndarray, count: np.ndarray, block: int = 250_000):
    """For every vertex i and the ``count[i]`` shortcuts i → j from j = ``first_j[i]`` on: the largest distance
    of a vertex the shortcut skips to it, and the sum of their squared distances. Vertices in blocks of a
    few array operations each (the search's loop over the vertices is left with the bookkeeping). The
    squared distances are summed over a row of all n vertices (zeros outside the skipped ones), as they
    have always been: the same additions in the same order give the same least-squares tie-break.
    ``block`` bounds the entries of those rows held at once."""
    n = len(poly)
    dmax, sums = [None] * (n - 1), [None] * (n - 1)
    rows_per_block = max(block // n, int(count.max(initial=1)))
    i0 = 0
    while i0 < n - 1:
        i1 = i0 + max(1, int(np.searchsorted(np.cumsum(count[i0:]), rows_per_block, side="right")))
        i = np.arange(i0, i1)
        owner, j = _ragged_aranges(first_j[i0:i1], count[i0:i1])
        first = i[owner]
        row, k = _ragged_aranges(first + 1, j - first - 1)
        # D[row, k] distance of vertex k to the row's segment i → j (zero where the shortcut keeps k)
        D = np.zeros((len(j), n))
        D[row, k] = _seg_dist(poly[k], poly[first[row]], poly[j[row]])
        row_max = D.max(1)
        row_sums = (D ** 2).sum(1)
        cuts = np.cumsum(count[i0:i1])[:-1]
        for ic, m_i, s_i in zip(i, np.split(row_max, cuts), np.split(row_sums, cuts)):
            dmax[ic], sums[ic] = m_i, s_i
        i0 = i1
    return dmax, sums


class Shortcuts:
    """The shortcut rows (:func:`_shortcut_rows`) of one polygon, computed as far as the tolerances asked so far
    reach. They do not depend on ε, and the solver simplifies one polygon with a few tolerances: pass the same
    object to each :func:`simplify` of that polygon and each computes only the shortcuts beyond the reaches of
    the ones before it."""

    def __init__(self, poly: np.ndarray):
        n = len(poly)
        self.poly = poly
        self.width = np.zeros(max(n - 1, 0), dtype=np.int64)
        self.dmax: list = [np.zeros(0)] * max(n - 1, 0)
        self.sums: list = [np.zeros(0)] * max(n - 1, 0)

    def rows(self, reach: np.ndarray) -> tuple[list, list]:
        n = len(self.poly)
        width = reach - np.arange(n - 1)
        more = np.maximum(width - self.width, 0)
        if more.any():
            dmax, sums = _shortcut_rows(self.poly, np.arange(n - 1) + 1 + self.width, more)
            for i in np.flatnonzero(more):
                self.dmax[i] = np.concatenate([self.dmax[i], dmax[i]])
                self.sums[i] = np.concatenate([self.sums[i], sums[i]])
            self.width = self.width + more
        return ([m[:w] for m, w in zip(self.dmax, width)], [s[:w] for s, w in zip(self.sums, width)])


def simplify(poly: np.ndarray, eps: float, shortcuts: Shortcuts | None = None) -> np.ndarray:
    """§4.5: minimum-vertex sub-polygon within ε, least squared error among minima. ``shortcuts``: the
    :class:`Shortcuts` of ``poly`` kept from its simplification with another tolerance."""
    n = len(poly)
    if n <= 2:
        return poly.copy()
    unreached = np.iinfo(np.int64).max
    best = np.full(n, unreached)
    sse = np.full(n, np.inf)
    prev = np.full(n, -1)
    best[0] = 0
    sse[0] = 0.0
    # none beyond the reach of i is within ε
    reach = _reaches(poly, eps)
    if shortcuts is None or shortcuts.poly is not poly:
        shortcuts = Shortcuts(poly)
    dmax, sums = shortcuts.rows(reach)
    for i in range(n - 1):
        if best[i] == unreached:
            continue
        nb = best[i] + 1
        js = np.arange(i + 1, reach[i] + 1)
        ns = sse[i] + sums[i]
        bj = best[js]
        better = (dmax[i] <= eps) & ((nb < bj) | ((nb == bj) & (ns < sse[js])))
        best[js[better]], sse[js[better]], prev[js[better]] = nb, ns[better], i
    out = [n - 1]
    while out[-1] != 0:
        out.append(int(prev[out[-1]]))
    return poly[out[::-1]]
