"""Stage 4 — G1 arc-line spline with the minimum number of arcs within ε (paper §4, Alg. 1).

Shortcut graph over the vertices of the (simplified) spine polygon: vertex i stands for the
tangent line l_i = p_i p_{i+1}; edge (i, j) exists when the chain p_i … p_{j+1} lies within ε
of "line on l_i, circular arc, line on l_j" (Fig. 4). Vertices are processed in order, so
the shortest (breadth-first) path is found by dynamic programming; among paths with the
fewest arcs the one with the least sum of squared vertex distances is kept (§4.5). As in
the paper, the line l_j is projected into the plane of the edge that reaches j first on the
best path, and that modified line is used for j's outgoing edges (G1 continuity).

Implementation choices (sound equivalents of the paper's constructions, or extensions):
* The plane of an edge is the least-squares plane through l_i of the chain vertices (less
  sensitive to one vertex than the paper's plane through p_i, p_{i+1}, p_{j+1}); when the
  chain hardly leaves l_i (rms offset < 2ε, small bends) that plane would be arbitrary and
  tilt the projected tangent l'_j by up to the bend angle, so the plane spanned by the two
  tangent directions (normal u_i × u_j) is used instead. Vertices farther than ε from the
  plane reject the edge; the in-plane tolerance is ε'_k = sqrt(ε² − h_k²) as in Alg. 1.
* The family of arcs tangent to both lines is parametrised by the arc's start t₁ on l_i
  instead of the centre on the bisector: radius and end point are linear in t₁ and the
  parametrisation stays regular for apex angles of 180° and more (where the bisector
  construction degenerates). The set of valid arcs — the paper's intersection of LLC
  (Apollonius) intervals — is searched on a t₁ grid zoomed in around the best (or least
  violating) sample, with the exact point-to-arc-line distance.
* p_{j+1} only fixes the direction of l_j and is checked by j's outgoing edge (at a junction
  of two bends it lies in the next bend's plane); an arc may start up to ε before the
  previous one ended (the straight between them is then 0).
* Up to ``beam`` states (modified tangent lines of different prefixes) are kept per vertex
  instead of one, because the best prefix so far can be a dead end later.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from plantsolve.solvers.tube.model import Spine, TubeModel, model_from_spine
from plantsolve.solvers.tube.vec3 import cross


_TOO_FAR = "too_far"  # the chain left every plane through l_i: longer chains fail too


@dataclass
class Edge:
    t1: float  # arc start on the incoming line (param from the line point)
    t2: float  # arc end on the outgoing line
    centre: np.ndarray  # 3D
    radius: float
    angle: float  # radians
    start: np.ndarray  # 3D arc start (B)
    end: np.ndarray  # 3D arc end (E)
    normal_in: np.ndarray  # 3D unit in-plane normal at the arc start, toward the centre
    out_point: np.ndarray  # 3D point of the modified outgoing line
    out_dir: np.ndarray  # 3D direction of the modified outgoing line
    cost: float


def _norm3(v: np.ndarray) -> float:
    """Norm of a 3-vector without np.linalg.norm's per-call overhead (hot loop)."""
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


_RAMPS: dict[int, np.ndarray] = {}


def _linspace(lo: float, hi: float, num: int) -> np.ndarray:
    """np.linspace(lo, hi, num) for scalars, bit for bit, without its per-call overhead."""
    delta = float(hi) - float(lo)
    step = delta / (num - 1)
    if step == 0.0 or num < 2:
        return np.linspace(lo, hi, num)
    ramp = _RAMPS.get(num)
    if ramp is None:
        ramp = _RAMPS.setdefault(num, np.arange(num, dtype=float))
    y = ramp * step
    y += lo
    y[-1] = hi
    return y


def _dist_to_arcline(q: np.ndarray, t1: np.ndarray, R: np.ndarray, phi: float,
                     a2: np.ndarray, u2: np.ndarray, n2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """2D distances of chain points q (K, 2) to the left-turning curves given by t1 (G,):
    ray along +x ending at (t1, 0), arc about C = (t1, R) by phi, ray along u2 from T2."""
    # centre C = (t1, R), arc end T2 = C − R·n2; all (G, K) arrays built from coordinates
    T2x, T2y = t1 - R * n2[0], R - R * n2[1]
    t2 = (T2x - a2[0]) * u2[0] + (T2y - a2[1]) * u2[1]
    qx, qy = q[None, :, 0], q[None, :, 1]
    dx1 = qx - t1[:, None]
    dT1 = np.hypot(dx1, qy)
    d1 = np.where(qx <= t1[:, None], np.abs(qy), dT1)
    qa = q - a2
    s2 = (qa @ u2)[None]  # (1, K)
    dT2 = np.hypot(qx - T2x[:, None], qy - T2y[:, None])
    d3 = np.where(s2 >= t2[:, None], np.abs(qa @ n2)[None], dT2)
    vy = qy - R[:, None]  # v = q − C = (dx1, vy)
    # angle from the start direction (0, -1) counter-clockwise
    th = np.mod(np.arctan2(dx1, -vy), 2 * np.pi)
    rho = np.hypot(dx1, vy)
    d2 = np.where(th <= phi, np.abs(rho - R[:, None]), np.minimum(dT1, dT2))
    return np.minimum(np.minimum(d1, d2), d3), t2


def edge_fit(chain: np.ndarray, a1: np.ndarray, u1: np.ndarray, t_lo: float, pj: np.ndarray, pj1: np.ndarray,
             eps: float, r_min: float, grid: int = 64, t_hi: float | None = None, plane_only: bool = False):
    """Best arc (least squared error) joining l_i = (a1, u1) and l_j = p_j p_{j+1}, or None.

    ``chain`` holds the vertices that must lie within ε; ``t_hi`` bounds the arc end on l_j
    (default: the projection of p_{j+1}). Returns ``_TOO_FAR`` when a vertex is more than
    2ε off the best plane through l_i (then no longer chain can succeed either). With ``plane_only``
    only that test is made (None when it passes): the caller needs to know whether to go on, not the arc."""
    rel = chain - a1
    along = rel @ u1
    dj = (pj1 - pj) / max(_norm3(pj1 - pj), 1e-300)
    cr = cross(u1, dj)
    perp = rel - along[:, None] * u1
    cov = perp.T @ perp
    w, V = np.linalg.eigh(cov + np.outer(u1, u1) * (np.trace(cov) + 1.0) * 10)
    if np.sqrt(max(w[1], 0.0) / len(chain)) > 2 * eps or _norm3(cr) < 1e-9:
        # the chain bends well beyond the noise: its least-squares plane through l_i
        m = V[:, 0]
    else:
        # nearly straight chain (small bend): its own plane would be arbitrary; the plane
        # spanned by both tangent directions is well defined
        m = cr / _norm3(cr)
    h = rel @ m
    if np.any(np.abs(h) > eps):
        return _TOO_FAR if np.any(np.abs(h) > 2 * eps) else None
    if plane_only:
        return None
    epsk = np.sqrt(np.maximum(eps * eps - h * h, 0.0))
    Y = cross(m, u1)
    q = np.stack([along, rel @ Y], -1)
    a2 = np.array([(pj - a1) @ u1, (pj - a1) @ Y])
    d2 = np.array([(pj1 - pj) @ u1, (pj1 - pj) @ Y])
    nd = math.hypot(d2[0], d2[1])
    if nd < 1e-12 * (_norm3(pj1 - pj) + 1e-300):
        return None
    u2 = d2 / nd
    seg = np.diff(q, axis=0)
    seg = seg[np.linalg.norm(seg, axis=1) > 1e-12]
    dirs = np.vstack([[1.0, 0.0], seg, u2])
    turn = np.sum(np.arctan2(dirs[:-1, 0] * dirs[1:, 1] - dirs[:-1, 1] * dirs[1:, 0],
                             (dirs[:-1] * dirs[1:]).sum(1)))
    sign = 1.0 if turn >= 0 else -1.0
    if sign < 0:  # mirror to a left turn
        q = q * [1, -1]; a2 = a2 * [1, -1]; u2 = u2 * [1, -1]
    phi = np.mod(np.arctan2(u2[1], u2[0]), 2 * np.pi)
    if phi < 1e-7 or phi > 2 * np.pi - 1e-7:
        return None
    n2 = np.array([-u2[1], u2[0]])
    den = n2[1] - 1.0
    alpha = (a2 @ n2) / den
    beta = -(n2[0]) / den  # u1 = (1, 0)
    # t2 = t1·u2x − a2·u2 + R (n1·u2), n1 = (0, 1)
    gam0, gam1 = -(a2 @ u2), u2[0]
    pj1_2 = np.array([(pj1 - a1) @ u1, (pj1 - a1) @ Y * sign])
    t_hi_line = (pj1_2 - a2) @ u2 if t_hi is None else t_hi
    lo, hi = t_lo, max(q[:, 0].max(), pj1_2[0], t_lo)
    cons = [(beta, r_min - alpha), (-(gam1 + u2[1] * beta), -(t_hi_line - gam0 - u2[1] * alpha))]
    # constraints a·t1 ≥ b
    for a, b in cons:
        if abs(a) < 1e-14:
            if b > 0:
                return None
            continue
        if a > 0:
            lo = max(lo, b / a)
        else:
            hi = min(hi, b / a)
    if hi < lo:
        return None
    best = None
    t_grid = _linspace(lo, hi, grid) if hi > lo else np.array([lo])
    for _ in range(4):
        R = alpha + beta * t_grid
        d, t2 = _dist_to_arcline(q, t_grid, R, phi, a2, u2, n2)
        viol = np.max(d - epsk[None], axis=1)
        valid = (viol <= 1e-12) & (R >= r_min * (1 - 1e-9))
        cost = np.where(valid, (d * d).sum(1), np.inf)
        if valid.any():
            g = int(np.argmin(cost))
            if best is None or cost[g] < best[0]:
                best = (cost[g], t_grid[g], R[g], t2[g])
        else:
            g = int(np.argmin(viol))  # zoom in on the least violation: valid sets can be narrow
        if len(t_grid) == 1:
            break
        step = t_grid[1] - t_grid[0]
        t_grid = _linspace(max(lo, t_grid[g] - step), min(hi, t_grid[g] + step), 17)
    if best is None:
        return None
    cost, t1, R, t2 = best
    Ym = Y * sign
    to3 = lambda p: a1 + p[0] * u1 + p[1] * Ym  # noqa: E731
    centre = to3(np.array([t1, R]))
    start = to3(np.array([t1, 0.0]))
    out_point = to3(a2)
    out_dir = u2[0] * u1 + u2[1] * Ym
    end = out_point + t2 * out_dir
    return Edge(float(t1), float(t2), centre, float(R), float(phi), start, end, Ym.copy(),
                out_point, out_dir / np.linalg.norm(out_dir), float(cost))


@dataclass
class _State:
    """A way to reach vertex j: arc count, squared error, predecessor, modified line l'_j."""

    d: int
    sse: float
    prev: int
    prev_state: int
    point: np.ndarray
    direction: np.ndarray
    t_lo: float
    edge: Edge | None


def fit_arcline(poly: np.ndarray, eps: float, r_min: float, beam: int = 3) -> TubeModel | None:
    """Algorithm 1 with least-squares tie-breaking; None if no chain of arcs fits within ε.

    The paper keeps one state per vertex (the modified tangent line of its best prefix). A
    prefix that is optimal so far can be a dead end later (e.g. two small bends merged into
    one arc within ε leave a tangent a few degrees off), so up to ``beam`` states per vertex
    are kept, ordered by (arc count, squared error); with beam = 1 this is exactly Alg. 1."""
    n = len(poly)
    if n < 2:
        return None
    last = n - 2
    d0 = (poly[1] - poly[0]) / np.linalg.norm(poly[1] - poly[0])
    states: list[list[_State]] = [[] for _ in range(n - 1)]
    states[0].append(_State(0, 0.0, -1, -1, poly[0].copy(), d0, 0.0, None))
    for i in range(n - 1):
        if i == last:
            break
        for si, st in enumerate(states[i]):
            for j in range(i + 1, n - 1):
                worst = states[j][-1] if len(states[j]) >= beam else None
                if worst is not None and st.d + 1 > worst.d:
                    continue
                # a full beam keeps a state of as many arcs only if its error is smaller, and an edge
                # adds error: then only whether the chain leaves every plane (ending the j loop) matters
                lost = worst is not None and st.d + 1 == worst.d and st.sse >= worst.sse
                # p_{j+1} only fixes the direction of l_j; it is checked by j's outgoing edge (it
                # lies in the next bend's plane when two bends follow each other directly)
                chain = poly[i:j + 2] if j == last else poly[i:j + 1]
                # an arc may start up to ε before the previous one ended (the straight between
                # them is then 0): chord tangent estimates at a junction of two bends are off by
                # about that
                e = edge_fit(chain, st.point, st.direction, st.t_lo - (eps if i else 0.0), poly[j], poly[j + 1],
                             eps, r_min, plane_only=lost)
                if e is _TOO_FAR:
                    break
                if e is None:
                    continue
                cand = _State(st.d + 1, st.sse + e.cost, i, si, e.out_point, e.out_dir, e.t2, e)
                lst = states[j]
                lst.append(cand)
                lst.sort(key=lambda x: (x.d, x.sse))
                del lst[beam:]
    if not states[last]:
        return None
    path, edges = [last], []
    st = states[last][0]
    lines = {last: (st.point, st.direction)}
    while st.prev >= 0:
        edges.append(st.edge)
        j = st.prev
        st = states[j][st.prev_state]
        path.append(j)
        lines[j] = (st.point, st.direction)
    path, edges = path[::-1], edges[::-1]
    lp = {j: lines[j][0] for j in path}
    ld = {j: lines[j][1] for j in path}
    return _model_from_edges(poly, path, edges, lp, ld)


def _model_from_edges(poly, path, edges: list[Edge], lp, ld) -> TubeModel:
    nb = len(edges)
    S = 2 * nb + 1
    kind = np.zeros(S, int); kind[1::2] = 1
    start = np.zeros((S, 3)); end = np.zeros((S, 3)); tan = np.zeros((S, 3)); nrm = np.zeros((S, 3))
    length = np.zeros(S); centre = np.zeros((S, 3)); radius = np.zeros(S); angle = np.zeros(S)
    t_prev = 0.0
    for k, j in enumerate(path):
        u = ld[j]
        t_next = edges[k].t1 if k < nb else float((poly[-1] - lp[j]) @ u)
        start[2 * k] = lp[j] + t_prev * u
        end[2 * k] = lp[j] + t_next * u
        tan[2 * k] = u
        length[2 * k] = max(t_next - t_prev, 0.0)
        if k < nb:
            e = edges[k]
            a = 2 * k + 1
            start[a], end[a], tan[a], nrm[a] = e.start, e.end, u, e.normal_in
            centre[a], radius[a], angle[a] = e.centre, e.radius, e.angle
            length[a] = e.radius * e.angle
            t_prev = e.t2
    if nb == 0:
        nrm[0] = np.cross(tan[0], [1.0, 0, 0]) if abs(tan[0][0]) < 0.9 else np.cross(tan[0], [0, 1.0, 0])
    sp = Spine(kind, start, end, tan, nrm, length, centre, radius, angle)
    return model_from_spine(sp, 0.0)
