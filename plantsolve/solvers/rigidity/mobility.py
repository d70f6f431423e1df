"""The exact pass: degrees of freedom, redundant constraints and maximal rigid clusters at the
actual positions of a body–joint mechanism.

Method (the exact counterpart of the seed's §6.2 constraint Jacobian, in screw form):
1. Superbricks: union-find over ``rigid`` joints (seed §3, 7.1).
2. The body–joint graph of the superbricks is split into biconnected blocks (networkx). Motions
   of different blocks are independent, so the relative-motion space is the direct sum of the
   blocks' spaces: a bridge joint adds its freedoms, a cyclic block adds the nullity of its
   constraint matrix, and each further connected component adds 6.
3. A cyclic block's loop-closure matrix: a spanning tree of the block (breadth first from its
   first body) and, for each joint off the tree (a chord), the closure of its cycle
   ``Σ ±S_j q_j = 0`` (6 rows), where ``S_j`` holds the screws the joint allows (``screws``) and
   ``q_j`` its joint rates. Its nullity is the block's mobility; the redundant constraints follow
   from it, ``Σ(6 − f_j) − 6(n − 1) + nullity``, as for the equivalent constraint matrix on body
   twists (one row per constraint wrench on ``t_j − t_i``, 6 unknowns per body, one body fixed),
   which ``method="twists"`` builds instead (tests compare the two). The loop form has one column
   per joint freedom and 6 rows per independent cycle: several times smaller for hinged models.
4. Rank and null space are exact when every joint point and axis is an integer vector (LDraw
   units, integer JSON input): Gaussian elimination modulo two primes near 2³¹ (``modrank``).
   Otherwise points are centred and divided by the model's size, axes normalised, and a float SVD
   is used: singular values below ``rank_tolerance · max(m, n) · σ_max`` count as zero. The
   tests check the two against each other.
5. Clusters come from a basis of the motion space (body twists follow from the joint rates
   along the tree): two bodies are one cluster when their relative twist is zero in every basis
   motion (equal residues mod p; in floats, equal within
   ``cluster_tolerance`` on the normalised, orthonormal basis). A joint moves when its relative
   twist is non-zero in some basis motion.

``dof`` counts motions of the bodies relative to each other: the whole model's 6 rigid motions are
excluded once, and every further unconnected piece adds 6.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import networkx as nx
import numpy as np

from plantsolve.solvers.rigidity import modrank
from plantsolve.solvers.rigidity.screws import FREEDOM, constraint_rows, freedom_screws

RANK_TOLERANCE = 1e-9
CLUSTER_TOLERANCE = 1e-6
# A singular value counted as zero but within this factor below the float rank's cut makes the dof uncertain: the
# 61 official models of the OMR fixtures and the LDrawParser.jl assets show none there (their smallest counted
# singular values lie 1.1 to 940 times above the cut, their zeros more than this factor below), while a joint 1e10
# model units from the others' 50 puts a four-bar's lever at 0.4 of the cut.
NEAR_CUT = 1e3
EXACT_LIMIT = 2 ** 30  # integer inputs above this are treated as floats (they are not LDraw units)


@dataclass(frozen=True)
class Joint:
    kind: str
    a: int  # body indices
    b: int
    point: tuple[float, float, float]
    axis: tuple[float, float, float]


@dataclass
class Mobility:
    dof: int
    clusters: list[list[int]]  # body indices, each body in exactly one
    superbricks: list[list[int]]
    moves: list[bool]  # per joint
    redundant_constraints: int
    rank_method: str  # "modular" or "svd"
    rows: int = 0
    blocks: int = 0
    largest_block: int = 0
    details: dict = field(default_factory=dict)


class _UnionFind:
    def __init__(self, n: int) -> None:
        self.parent = list(range(n))

    def find(self, x: int) -> int:
        while self.parent[x] != x:
            self.parent[x] = self.parent[self.parent[x]]
            x = self.parent[x]
        return x

    def union(self, x: int, y: int) -> bool:
        rx, ry = self.find(x), self.find(y)
        if rx == ry:
            return False
        self.parent[max(rx, ry)] = min(rx, ry)
        return True

    def groups(self, n: int) -> list[list[int]]:
        out: dict[int, list[int]] = {}
        for x in range(n):
            out.setdefault(self.find(x), []).append(x)
        return sorted(out.values(), key=lambda g: g[0])


def is_exact(joints: Sequence[Joint]) -> bool:
    """Every point and axis component an integer of modest size: the modular rank applies."""
    for j in joints:
        for x in (*j.point, *j.axis):
            if not float(x).is_integer() or abs(x) >= EXACT_LIMIT:
                return False
    return True


def _float_frame(joints: Sequence[Joint]) -> tuple[np.ndarray, float]:
    pts = np.array([j.point for j in joints], dtype=float) if joints else np.zeros((1, 3))
    centre = pts.mean(axis=0)
    size = float(np.abs(pts - centre).max()) or 1.0
    return centre, size


def _unit(axis) -> np.ndarray:
    a = np.asarray(axis, dtype=float)
    a = a / np.abs(a).max()  # first to order one: no overflow or underflow in the norm
    return a / np.linalg.norm(a)


def _frame(joint: Joint, exact: bool, centre, size) -> tuple[np.ndarray, np.ndarray]:
    """The joint's point and axis as the rank needs them: integers as they are for the modular rank;
    floats centred, scaled to order one and with a unit axis for the SVD."""
    if exact:
        return (np.array([int(x) for x in joint.point], dtype=np.int64),
                np.array([int(x) for x in joint.axis], dtype=np.int64))
    return (np.asarray(joint.point, dtype=float) - centre) / size, _unit(joint.axis)


def _rows(joint: Joint, exact: bool, centre, size) -> np.ndarray:
    return constraint_rows(joint.kind, *_frame(joint, exact, centre, size))


def block_matrix(bodies: list[int], joints: list[int], all_joints: Sequence[Joint], sb: list[int],
                 exact: bool, centre, size):
    """The constraint matrix of one block: rows of every joint, 6 columns per body but the first."""
    col = {b: 6 * k for k, b in enumerate(bodies[1:])}
    n_cols = 6 * (len(bodies) - 1)
    blocks = []
    for ji in joints:
        j = all_joints[ji]
        r = _rows(j, exact, centre, size)
        m = np.zeros((r.shape[0], n_cols), dtype=np.int64 if exact else float)
        a, b = sb[j.a], sb[j.b]
        if b in col:
            m[:, col[b]:col[b] + 6] += r
        if a in col:
            m[:, col[a]:col[a] + 6] -= r
        blocks.append(m)
    matrix = np.vstack(blocks) if blocks else np.zeros((0, n_cols))
    return matrix, col


def _screws(joint: Joint, exact: bool, centre, size) -> np.ndarray:
    return freedom_screws(joint.kind, *_frame(joint, exact, centre, size))


def loop_block(bodies: list[int], joints: list[int], all_joints: Sequence[Joint], sb: list[int], exact: bool,
               centre, size, rank_tolerance: float, near: list[float] | None = None):
    """(rank, basis of joint rates, body twists in the basis, joint columns, prime or None) of one block; ``near``
    gathers the float rank's singular values counted as zero within :data:`NEAR_CUT` of the cut (see
    :func:`_svd_nullspace`)."""
    screws = {k: _screws(all_joints[k], exact, centre, size) for k in joints}
    col, n_cols = {}, 0
    for k in joints:
        col[k] = n_cols
        n_cols += screws[k].shape[1]
    adjacency: dict[int, list[tuple[int, int, int]]] = {b: [] for b in bodies}
    for k in joints:
        a, b = sb[all_joints[k].a], sb[all_joints[k].b]
        adjacency[a].append((k, b, 1))
        adjacency[b].append((k, a, -1))
    root = bodies[0]
    parent: dict[int, tuple[int, int, int] | None] = {root: None}  # body -> (parent body, joint, sign)
    order = [root]
    tree = set()
    for x in order:
        for k, y, sign in adjacency[x]:
            if y not in parent:
                parent[y] = (x, k, sign)
                tree.add(k)
                order.append(y)
    dtype = np.int64 if exact else float
    rows = []
    for k in joints:
        if k in tree:
            continue
        block = np.zeros((6, n_cols), dtype=dtype)
        a, b = sb[all_joints[k].a], sb[all_joints[k].b]
        for end, outer in ((b, 1), (a, -1)):
            x = end
            while parent[x] is not None:
                px, kj, sign = parent[x]
                block[:, col[kj]:col[kj] + screws[kj].shape[1]] += outer * sign * screws[kj]
                x = px
        block[:, col[k]:col[k] + screws[k].shape[1]] -= screws[k]
        rows.append(block)
    matrix = np.vstack(rows)
    rank, basis, p = _nullspace(matrix, exact, rank_tolerance, near)
    nullity = basis.shape[1]
    twists = {root: np.zeros((6, nullity), dtype=basis.dtype)}
    for x in order[1:]:
        px, k, sign = parent[x]
        s_mat = screws[k]
        rates = basis[col[k]:col[k] + s_mat.shape[1]]
        if exact:
            acc = twists[px].copy()
            for c in range(s_mat.shape[1]):
                term = (np.mod(sign * s_mat[:, c], p)[:, None] * rates[c][None, :]) % p
                acc = (acc + term) % p
            twists[x] = acc
        else:
            twists[x] = twists[px] + sign * (s_mat @ rates)
    return rank, basis, twists, col, screws, p


def _nullspace(matrix: np.ndarray, exact: bool, tolerance: float,
               near: list[float] | None = None) -> tuple[int, np.ndarray, int | None]:
    """Rank and null-space basis of ``matrix``, with the prime of the arithmetic: exact (modular) for integer
    entries, else by SVD (prime None)."""
    if exact:
        return modrank.exact_nullspace(matrix)
    rank, basis = _svd_nullspace(matrix, tolerance, near)
    return rank, basis, None


def _svd_nullspace(matrix: np.ndarray, tolerance: float, near: list[float] | None = None) -> tuple[int, np.ndarray]:
    """Rank and null-space basis by SVD. Each singular value counted as zero that lies within a factor
    :data:`NEAR_CUT` below the cut is added to ``near`` as its ratio to the cut: a motion the rank grants only by
    that margin (a lever 1e-10 of the model's size lies just under it)."""
    n_cols = matrix.shape[1]
    if matrix.shape[0] == 0 or n_cols == 0:
        return 0, np.eye(n_cols)
    _, s, vt = np.linalg.svd(matrix, full_matrices=True)
    cut = tolerance * max(matrix.shape) * (s[0] if s.size else 0.0)
    rank = int((s > cut).sum()) if s.size and s[0] > 0 else 0
    if near is not None and rank:
        near.extend(float(v / cut) for v in s[rank:] if v > cut / NEAR_CUT)
    return rank, vt[rank:].T


def analyse(n_bodies: int, joints: Sequence[Joint], *, exact: bool | None = None, method: str = "loops",
            rank_tolerance: float = RANK_TOLERANCE, cluster_tolerance: float = CLUSTER_TOLERANCE) -> Mobility:
    """Degrees of freedom, clusters, moving joints and redundant constraints (module docstring)."""
    if exact is None:
        exact = is_exact(joints)
    centre, size = _float_frame(joints)
    uf = _UnionFind(n_bodies)
    near: list[float] = []
    redundant = 0
    moves = [False] * len(joints)
    for k, j in enumerate(joints):
        if j.kind == "rigid" and not uf.union(j.a, j.b):
            redundant += 6
    superbricks = uf.groups(n_bodies)
    sb_of = [0] * n_bodies
    for s, group in enumerate(superbricks):
        for b in group:
            sb_of[b] = s
    n_sb = len(superbricks)
    graph = nx.Graph()
    graph.add_nodes_from(range(n_sb))
    pair_joints: dict[tuple[int, int], list[int]] = {}
    for k, j in enumerate(joints):
        if j.kind == "rigid":
            continue
        a, b = sb_of[j.a], sb_of[j.b]
        if a == b:  # a joint inside a superbrick: all its constraints are redundant
            redundant += 6 - FREEDOM[j.kind]
            continue
        graph.add_edge(a, b)
        pair_joints.setdefault((min(a, b), max(a, b)), []).append(k)
    components = nx.number_connected_components(graph)
    dof = 6 * (components - 1) if n_sb else 0
    cluster_uf = _UnionFind(n_sb)
    total_rows = 0
    n_blocks = 0
    largest = 0
    for edges in nx.biconnected_component_edges(graph):
        block_joints = sorted(k for u, v in edges for k in pair_joints[(min(u, v), max(u, v))])
        bodies = sorted({x for e in edges for x in e})
        n_blocks += 1
        largest = max(largest, len(bodies))
        if len(block_joints) == 1:  # a bridge joint: its freedoms add, nothing is redundant
            k = block_joints[0]
            dof += FREEDOM[joints[k].kind]
            moves[k] = True
            total_rows += 6 - FREEDOM[joints[k].kind]
            continue
        if method == "loops":
            rank, basis, twists, jcol, screws, p = loop_block(bodies, block_joints, joints, sb_of, exact, centre,
                                                              size, rank_tolerance, near)
            nullity = basis.shape[1]
            n_rows = sum(6 - FREEDOM[joints[k].kind] for k in block_joints)
            total_rows += n_rows
            redundant += n_rows - 6 * (len(bodies) - 1) + nullity
            for k in block_joints:
                rates = basis[jcol[k]:jcol[k] + screws[k].shape[1]]
                moves[k] = bool((rates % p).any()) if exact else bool(np.abs(rates).max(initial=0.0) > cluster_tolerance)
        else:
            matrix, col = block_matrix(bodies, block_joints, joints, sb_of, exact, centre, size)
            total_rows += matrix.shape[0]
            rank, basis, p = _nullspace(matrix, exact, rank_tolerance, near)
            nullity = basis.shape[1]
            redundant += matrix.shape[0] - rank
            twists = {b: basis[col[b]:col[b] + 6] if b in col else np.zeros((6, nullity), dtype=basis.dtype)
                      for b in bodies}
        dof += nullity

        def same(x, y) -> bool:
            d = x - y
            if exact:
                return not (d % p).any()
            return bool(np.abs(d).max(initial=0.0) <= cluster_tolerance)

        if method != "loops":
            for k in block_joints:
                j = joints[k]
                moves[k] = not same(twists[sb_of[j.b]], twists[sb_of[j.a]])
        if exact:
            keyed: dict[bytes, int] = {}
            for b in bodies:
                key = (twists[b] % p).tobytes()
                if key in keyed:
                    cluster_uf.union(keyed[key], b)
                else:
                    keyed[key] = b
        else:
            for i, b in enumerate(bodies):
                for c in bodies[i + 1:]:
                    if cluster_uf.find(b) != cluster_uf.find(c) and same(twists[b], twists[c]):
                        cluster_uf.union(b, c)
    clusters = [[b for s in group for b in superbricks[s]] for group in cluster_uf.groups(n_sb)]
    clusters = sorted((sorted(c) for c in clusters), key=lambda c: c[0])
    return Mobility(dof=dof, clusters=clusters, superbricks=superbricks, moves=moves,
                    redundant_constraints=redundant, rank_method="modular" if exact else "svd",
                    rows=total_rows, blocks=n_blocks, largest_block=largest,
                    details={"components": components, "model_size": size,
                             "near_cut": sorted(near, reverse=True)[:10]})


def dense_svd_dof(n_bodies: int, joints: Sequence[Joint], rank_tolerance: float = RANK_TOLERANCE) -> int:
    """Baseline for the benchmark and tests: one dense float SVD of the whole constraint matrix
    (6 columns per body, every joint including rigid ones); dof = nullity − 6."""
    centre, size = _float_frame(joints)
    rows = []
    for j in joints:
        r = _rows(j, False, centre, size)
        m = np.zeros((r.shape[0], 6 * n_bodies))
        m[:, 6 * j.b:6 * j.b + 6] += r
        m[:, 6 * j.a:6 * j.a + 6] -= r
        rows.append(m)
    matrix = np.vstack(rows) if rows else np.zeros((0, 6 * n_bodies))
    if matrix.shape[0] == 0:
        return 6 * n_bodies - 6
    s = np.linalg.svd(matrix, compute_uv=False)
    rank = int((s > rank_tolerance * max(matrix.shape) * s[0]).sum())
    return 6 * n_bodies - rank - 6
