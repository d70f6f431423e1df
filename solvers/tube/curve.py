"""Stage 3 — polygonal curve from the spine point cloud (paper §1.3, §4.5).

1. Thinning: greedy Poisson-disk selection at spacing δ, each kept point replaced by the
   mean of the spine points within δ (removes the residual thickness of the MLS cloud, so
   the cloud is a "dense sample of a curve" as curve reconstruction requires).
2. NN-Crust (Dey & Kumar): every point joins its nearest neighbour and its nearest "half
   neighbour" (nearest point on the other side, angle > 90°). On a proper sample this is one
   simple path. If it is not (noise, branches), an equally sound fallback is used: the
   longest path (diameter) of the Euclidean minimum spanning tree.
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
    return np.array([points[n].mean(0) for n in nbrs])


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


def _path_if_simple(n: int, edges: list[tuple[int, int]]) -> list[int] | None:
    g = nx.Graph()
    g.add_nodes_from(range(n))
    g.add_edges_from(edges)
    comp = max(nx.connected_components(g), key=len)
    h = g.subgraph(comp)
    if len(comp) < 0.9 * n or max(dict(h.degree()).values()) > 2:
        return None
    ends = [v for v, dg in h.degree() if dg == 1]
    if len(ends) != 2:
        return None
    return nx.shortest_path(h, min(ends), max(ends))


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
    path = _path_if_simple(len(points), nn_crust(points))
    method = "nn_crust"
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


def simplify(poly: np.ndarray, eps: float) -> np.ndarray:
    """§4.5: minimum-vertex sub-polygon within ε, least squared error among minima."""
    n = len(poly)
    if n <= 2:
        return poly.copy()
    best = np.full(n, np.iinfo(np.int64).max)
    sse = np.full(n, np.inf)
    prev = np.full(n, -1)
    best[0] = 0
    sse[0] = 0.0
    ks = np.arange(n)
    for i in range(n - 1):
        if best[i] == np.iinfo(np.int64).max:
            continue
        js = np.arange(i + 1, n)
        # D[j, k] distance of vertex k to segment i→j for i < k < j
        D = _seg_dist(poly[None, :, :], poly[i][None, None, :], poly[js][:, None, :])
        inside = (ks[None, :] > i) & (ks[None, :] < js[:, None])
        Dm = np.where(inside, D, 0.0)
        ok = Dm.max(1) <= eps
        cost = (Dm ** 2).sum(1)
        for j, good, c in zip(js, ok, cost):
            if not good:
                continue
            nb, ns = best[i] + 1, sse[i] + c
            if nb < best[j] or (nb == best[j] and ns < sse[j]):
                best[j], sse[j], prev[j] = nb, ns, i
    out = [n - 1]
    while out[-1] != 0:
        out.append(int(prev[out[-1]]))
    return poly[out[::-1]]
