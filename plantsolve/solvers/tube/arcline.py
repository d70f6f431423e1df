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


TOO_FAR = "too_far"  # the chain left every plane through l_i: longer chains fail too
_X2 = np.array([1.0, 0.0])
_X3 = np.array([1.0, 0.0, 0.0])
_Y3 = np.array([0.0, 1.0, 0.0])
_MIRROR = np.array([1.0, -1.0])  # a right turn mirrored to a left one


@dataclass
class Edge:
    """The best arc of an edge: what the search needs of it (its cost and the modified outgoing line), and its
    points in 3D for the edges of the path kept (computed on demand: most edges are met and dropped)."""

    t1: float  # arc start on the incoming line (param from the line point)
    t2: float  # arc end on the outgoing line
    radius: float
    angle: float  # radians
    out_point: np.ndarray  # 3D point of the modified outgoing line
    out_dir: np.ndarray  # 3D direction of the modified outgoing line
    cost: float
    family: "_Arcs"  # the edge's plane frame (l_i, its second axis Ym)
    out_step: np.ndarray  # the outgoing direction as computed in the plane (before its normalisation)

    def _to3(self, x: float, y: float) -> np.ndarray:
        return self.family.a1 + x * self.family.u1 + y * self.family.Ym

    @property
    def centre(self) -> np.ndarray:
        return self._to3(self.t1, self.radius)

    @property
    def start(self) -> np.ndarray:
        """3D arc start (B)."""
        return self._to3(self.t1, 0.0)

    @property
    def end(self) -> np.ndarray:
        """3D arc end (E)."""
        return self.out_point + self.t2 * self.out_step

    @property
    def normal_in(self) -> np.ndarray:
        """3D unit in-plane normal at the arc start, toward the centre."""
        return self.family.Ym.copy()


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


@dataclass
class _Arcs:
    """The arcs that may join l_i and l_j, in the plane of the edge with l_i along +x (mirrored to a left turn):
    start t1 on l_i in [lo, hi], radius alpha + beta·t1; the chain points q must lie within epsk of the curve."""

    q: np.ndarray  # (K, 2) chain vertices in the plane
    epsk: np.ndarray  # (K,) in-plane tolerance of each
    a2: np.ndarray  # point of l_j
    u2: np.ndarray  # direction of l_j
    n2: np.ndarray  # its normal (toward the arc centres)
    along2: np.ndarray  # (K,) coordinate of each q along l_j from a2
    off2: np.ndarray  # (K,) distance of each q from l_j
    phi: float  # turning angle
    alpha: float
    beta: float
    lo: float
    hi: float
    a1: np.ndarray  # l_i in 3D
    u1: np.ndarray
    Ym: np.ndarray  # the plane's second axis in 3D (mirrored)


def arc_family(chain: np.ndarray, a1: np.ndarray, u1: np.ndarray, t_lo: float, pj: np.ndarray, pj1: np.ndarray,
               eps: float, r_min: float, t_hi: float | None = None, plane_only: bool = False):
    """The arcs joining l_i = (a1, u1) and l_j = p_j p_{j+1} that keep ``chain`` within ε (:class:`_Arcs`), or
    None when there are none; ``TOO_FAR`` when a vertex is more than 2ε off the best plane through l_i (then no
    longer chain can succeed either). ``t_hi`` bounds the arc end on l_j (default: the projection of p_{j+1}).
    With ``plane_only`` only that test is made (None when it passes): the caller needs to know whether to go on,
    not the arc."""
    rel = chain - a1
    dj = (pj1 - pj) / max(_norm3(pj1 - pj), 1e-300)
    cr = cross(u1, dj)
    # the least-squares planes through l_i: the offsets from l_i in a basis (e1, e2) of the plane normal to
    # it, and the 2 × 2 eigenproblem of their scatter in closed form (the plane's normal is the eigenvector
    # of the smaller eigenvalue)
    e1, e2 = _basis(u1)
    along, x1, x2 = (rel @ np.array((u1, e1, e2)).T).T
    a, b, d = float(x1 @ x1), float(x1 @ x2), float(x2 @ x2)
    half, mean = 0.5 * (a - d), 0.5 * (a + d)
    root = math.hypot(half, b)
    if math.sqrt(max(mean + root, 0.0) / len(chain)) > 2 * eps or _norm3(cr) < 1e-9:
        # the chain bends well beyond the noise: its least-squares plane through l_i
        small = mean - root
        # eigenvector of the smaller eigenvalue, from the row of (C - small I) with the larger entries
        v = (b, small - a) if abs(small - a) >= abs(small - d) else (small - d, b)
        nv = math.hypot(v[0], v[1])
        m1, m2 = (v[0] / nv, v[1] / nv) if nv > 0 else (1.0, 0.0)
    else:
        # nearly straight chain (small bend): its own plane would be arbitrary; the plane
        # spanned by both tangent directions is well defined
        m = cr / _norm3(cr)
        m1, m2 = float(m @ e1), float(m @ e2)
    # m = m1 e1 + m2 e2 is normal to u1, and Y = m × u1 = m2 e1 - m1 e2 (u1, e1, e2 right-handed)
    h = m1 * x1 + m2 * x2
    ah = np.abs(h)
    if ah.max() > eps:
        return TOO_FAR if ah.max() > 2 * eps else None
    if plane_only:
        return None
    return _arcs_in_plane(along, x1, x2, h, m1, m2, e1, e2, a1, u1, t_lo, pj, pj1, eps, r_min, t_hi)


def _basis(u1: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(e1, e2) with (u1, e1, e2) a right-handed orthonormal basis."""
    e1 = cross(u1, _X3 if abs(u1[0]) < 0.9 else _Y3)
    e1 = e1 / _norm3(e1)
    return e1, cross(u1, e1)


def _arcs_in_plane(along: np.ndarray, x1: np.ndarray, x2: np.ndarray, h: np.ndarray, m1: float, m2: float,
                   e1: np.ndarray, e2: np.ndarray, a1: np.ndarray, u1: np.ndarray, t_lo: float, pj: np.ndarray,
                   pj1: np.ndarray, eps: float, r_min: float, t_hi: float | None):
    """:func:`arc_family` once the chain passed its plane test: the chain's coordinates along l_i (``along``)
    and in (e1, e2), its offsets ``h`` from the plane of normal m1 e1 + m2 e2."""
    epsk = np.sqrt(np.maximum(eps * eps - h * h, 0.0))
    qy = m2 * x1 - m1 * x2
    sx, sy = along[1:] - along[:-1], qy[1:] - qy[:-1]
    keep = np.sqrt(sx * sx + sy * sy) > 1e-12
    return _arcs_of_chain(e1, e2, along, qy, epsk, sx[keep], sy[keep], m1, m2, a1, u1, t_lo, pj, pj1, r_min, t_hi)


def _arcs_in_planes(planes: list[tuple], asks: list[tuple], poly: np.ndarray, eps: float,
                    r_min: float) -> list[_Arcs | None]:
    """:func:`_arcs_in_plane` of every edge in ``asks`` at once: (state index into ``planes``, j, chain length k,
    index of j in the plane tests, the state's line point, direction and t_lo). The chains of one vertex are
    prefixes of its states' coordinates, so the elementwise steps run over them stacked (the plane's second
    axis, the vectors to p_j and p_{j+1}, the turning angles along each chain); the products of 3-vectors and
    the sums over a chain stay each edge's own calls (numpy's dot is not a sum in order). Each edge gets what
    :func:`_arcs_in_plane` gives it."""
    F = len(asks)
    if not F:
        return []
    si = np.array([a[0] for a in asks])
    jj = np.array([a[3] for a in asks])
    j = np.array([a[1] for a in asks])
    K = np.array([a[2] for a in asks])
    # (np.array of same-shape arrays stacks them as np.stack does, without its per-call overhead)
    along = np.array([p[2] for p in planes])[si]  # (F, L): every state of a vertex has L = n - i coordinates
    x1 = np.array([p[3] for p in planes])[si]
    x2 = np.array([p[4] for p in planes])[si]
    m1 = np.array([p[6] for p in planes])[si, jj]
    m2 = np.array([p[7] for p in planes])[si, jj]
    h = m1[:, None] * x1 + m2[:, None] * x2
    epsk = np.sqrt(np.maximum(eps * eps - h * h, 0.0))
    qy = m2[:, None] * x1 - m1[:, None] * x2
    # each chain's segments in the plane (the turning angles between consecutive directions below)
    sx, sy = along[:, 1:] - along[:, :-1], qy[:, 1:] - qy[:, :-1]
    seg_ok = np.sqrt(sx * sx + sy * sy) > 1e-12
    # the plane's second axis Y = m2 e1 - m1 e2 and the vectors from l_i's point to p_j, p_{j+1}
    a1 = np.array([a[4] for a in asks])
    u1 = [a[5] for a in asks]
    Y = m2[:, None] * np.array([p[0] for p in planes])[si] - m1[:, None] * np.array([p[1] for p in planes])[si]
    pj, pj1 = poly[j], poly[j + 1]
    rj, dj, rj1 = pj - a1, pj1 - pj, pj1 - a1
    lines = [_outgoing_line(rj[f], dj[f], u1[f], Y[f]) for f in range(F)]
    # the turning angles of every chain with its l_j (p_j p_{j+1} in the plane), as :func:`_turn` takes them:
    # the directions (1, 0) (l_i), the chain's segments, l_j's; a chain with a zero segment (a repeated vertex)
    # takes them alone, without it
    L = along.shape[1]
    dx, dy = np.zeros((F, L + 1)), np.zeros((F, L + 1))
    dx[:, 0] = 1.0
    dx[:, 1:L], dy[:, 1:L] = sx, sy
    rows = np.arange(F)
    dx[rows, K] = [ln[2] if ln is not None else 0.0 for ln in lines]
    dy[rows, K] = [ln[3] if ln is not None else 0.0 for ln in lines]
    turning = np.arctan2(dx[:, :-1] * dy[:, 1:] - dy[:, :-1] * dx[:, 1:], dx[:, :-1] * dx[:, 1:] + dy[:, :-1] * dy[:, 1:])
    whole = np.where(seg_ok.all(1), L, np.argmin(seg_ok, 1)) >= K - 1  # no zero segment among the chain's
    q = np.empty(along.shape + (2,))
    q[..., 0], q[..., 1] = along, qy
    top = np.maximum.accumulate(along, axis=1)[rows, K - 1].tolist()
    out: list[_Arcs | None] = []
    for f, (_, jf, k, _, a1f, u1f, t_lo) in enumerate(asks):
        line = lines[f]
        if line is None:
            out.append(None)
            continue
        if whole[f]:
            turn = np.sum(turning[f, :k])
        else:
            ok = seg_ok[f, :k - 1]
            turn = _turn(sx[f, :k - 1][ok], sy[f, :k - 1][ok], line[2], line[3])
        out.append(_family(q[f, :k], epsk[f, :k], top[f], turn, line, rj1[f], a1f, u1f, Y[f], t_lo, r_min, None))
    return out


def _arcs_of_chain(e1, e2, along, qy, epsk, sx, sy, m1, m2, a1, u1, t_lo, pj, pj1, r_min, t_hi):
    """:func:`_arcs_in_plane` once the chain's in-plane coordinates (``along``, ``qy``), tolerances and segments
    (``sx``, ``sy``, none of zero length) are known."""
    Y = m2 * e1 - m1 * e2
    line = _outgoing_line(pj - a1, pj1 - pj, u1, Y)
    if line is None:
        return None
    q = np.empty((len(along), 2))
    q[:, 0], q[:, 1] = along, qy
    return _family(q, epsk, float(along.max()), _turn(sx, sy, line[2], line[3]), line, pj1 - a1, a1, u1, Y, t_lo,
                   r_min, t_hi)


def _outgoing_line(rj: np.ndarray, dj: np.ndarray, u1: np.ndarray, Y: np.ndarray) -> tuple | None:
    """l_j in the plane of l_i (axes u1, Y): its point a2 (from l_i's point, ``rj`` = p_j - a1) and unit direction
    u2 (of ``dj`` = p_{j+1} - p_j), as (a2x, a2y, u2x, u2y); None when p_j p_{j+1} is normal to the plane."""
    a2x, a2y = float(rj @ u1), float(rj @ Y)
    d2x, d2y = float(dj @ u1), float(dj @ Y)
    nd = math.hypot(d2x, d2y)
    if nd < 1e-12 * (_norm3(dj) + 1e-300):
        return None
    return a2x, a2y, d2x / nd, d2y / nd


def _turn(sx: np.ndarray, sy: np.ndarray, u2x: float, u2y: float) -> float:
    """The angle the chain turns through from l_i (direction (1, 0)) along its segments to l_j (u2)."""
    dx = np.empty(len(sx) + 2)
    dy = np.empty(len(sx) + 2)
    dx[0], dy[0] = 1.0, 0.0
    dx[1:-1], dy[1:-1] = sx, sy
    dx[-1], dy[-1] = u2x, u2y
    return np.sum(np.arctan2(dx[:-1] * dy[1:] - dy[:-1] * dx[1:], dx[:-1] * dx[1:] + dy[:-1] * dy[1:]))


def _family(q: np.ndarray, epsk: np.ndarray, along_max: float, turn: float, line: tuple, rj1: np.ndarray,
            a1: np.ndarray, u1: np.ndarray, Y: np.ndarray, t_lo: float, r_min: float, t_hi: float | None):
    """The arc family of a chain (in-plane points ``q``, tolerances ``epsk``, largest coordinate along l_i
    ``along_max``) that turns by ``turn`` from l_i to l_j (``line``: :func:`_outgoing_line`), mirrored to a left
    turn; ``rj1`` = p_{j+1} - a1. None when no arc meets the constraints."""
    a2x, a2y, u2x, u2y = line
    sign = 1.0 if turn >= 0 else -1.0
    if sign < 0:  # mirror to a left turn
        q = q * _MIRROR; a2y = -a2y; u2y = -u2y
    phi = math.atan2(u2y, u2x) % (2 * math.pi)
    if phi < 1e-7 or phi > 2 * np.pi - 1e-7:
        return None
    n2x, n2y = -u2y, u2x
    den = n2y - 1.0
    alpha = (a2x * n2x + a2y * n2y) / den
    beta = -n2x / den  # u1 = (1, 0)
    # t2 = t1·u2x − a2·u2 + R (n1·u2), n1 = (0, 1)
    gam0, gam1 = -(a2x * u2x + a2y * u2y), u2x
    p1x, p1y = float(rj1 @ u1), float(rj1 @ Y) * sign
    t_hi_line = (p1x - a2x) * u2x + (p1y - a2y) * u2y if t_hi is None else t_hi
    lo, hi = t_lo, max(along_max, p1x, t_lo)
    cons = [(beta, r_min - alpha), (-(gam1 + u2y * beta), -(t_hi_line - gam0 - u2y * alpha))]
    for a, b in cons:  # constraints a·t1 ≥ b
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
    a2, u2, n2 = np.array([a2x, a2y]), np.array([u2x, u2y]), np.array([n2x, n2y])
    qa = q - a2
    return _Arcs(q, epsk, a2, u2, n2, qa @ u2, np.abs(qa @ n2), phi, alpha, beta, lo, hi, a1, u1, Y * sign)


def _dist_to_arclines(f: list[_Arcs], q: np.ndarray, t1: np.ndarray, R: np.ndarray, along2: np.ndarray,
                      off2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """2D distances of chain points to the left-turning curves of the arc families ``f`` (ray along +x ending at
    (t1, 0), arc about C = (t1, R) by phi, ray along u2 from its end T2), all families at once: chain points q
    (J, K, 2) (padded), arc starts t1 and radii R (J, G), the chain points' coordinates along l_j and distances
    from it (J, K). Returns (J, K, G) distances (a chain point's row over the grid is contiguous, so reductions
    over the chain are row operations) and (J, G) arc ends on l_j; the same operations on every element.
    Norms are square roots of sums of squares: np.hypot's overflow-safe loop costs 6x as much, and these
    coordinates (relative to l_i, within the 1e12 coordinate bound) square without overflow."""
    a2, u2, n2, phi = f if isinstance(f, tuple) else _family_lines(f)
    T2x, T2y = t1 - R * n2[:, 0], R - R * n2[:, 1]
    t2 = (T2x - a2[:, 0]) * u2[:, 0] + (T2y - a2[:, 1]) * u2[:, 1]
    qx, qy = q[:, :, 0, None], q[:, :, 1, None]
    t1_, R_ = t1[:, None, :], R[:, None, :]
    dx1 = qx - t1_
    dx1sq = dx1 * dx1
    qysq = qy * qy
    dT1 = np.sqrt(dx1sq + qysq)
    d1 = np.where(qx <= t1_, np.abs(qy), dT1)
    ex, ey = qx - T2x[:, None, :], qy - T2y[:, None, :]
    dT2 = np.sqrt(ex * ex + ey * ey)
    d3 = np.where(along2[:, :, None] >= t2[:, None, :], off2[:, :, None], dT2)
    vy = qy - R_
    # angle from the arc's start direction (0, -1) counter-clockwise, in [0, 2π)
    th = np.arctan2(dx1, -vy)
    th[th < 0] += 2 * np.pi
    rho = np.sqrt(dx1sq + vy * vy)
    d2 = np.where(th <= phi, np.abs(rho - R_), np.minimum(dT1, dT2))
    return np.minimum(np.minimum(d1, d2), d3), t2


def _family_lines(f: list[_Arcs]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """l_j of every family (point, direction, normal: (J, 2, 1)) and the turning angles (J, 1, 1)."""
    return (np.array([e.a2 for e in f])[:, :, None], np.array([e.u2 for e in f])[:, :, None],
            np.array([e.n2 for e in f])[:, :, None], np.array([e.phi for e in f])[:, None, None])


def best_arcs(families: list[_Arcs], r_min: float | list[float], grid: int = 64) -> list[Edge | None]:
    """The best arc (least squared error) of each family, or None: a t1 grid of ``grid`` points zoomed in three
    times around the best (or least violating) sample, all families at once (the arc search of the beam states
    of a vertex over every j they reach). Element for element the operations of a search of one family, and the sums of
    squares over exactly its chain, so the arcs are those a search of each alone finds. ``r_min``: the least
    bend radius, of all families or of each."""
    out: list[Edge | None] = [None] * len(families)
    r_mins = [float(r_min)] * len(families) if np.isscalar(r_min) else [float(r) for r in r_min]
    idx = [k for k, f in enumerate(families) if f.hi > f.lo]
    for k, f in enumerate(families):
        if not f.hi > f.lo:  # one start only
            out[k] = _best_arc_alone(f, r_mins[k])
    if not idx:
        return out
    f = [families[k] for k in idx]
    J = len(f)
    sizes = [len(e.q) for e in f]
    Kmax = max(sizes)
    q = np.empty((J, Kmax, 2))
    epsk = np.full((J, Kmax), np.inf)  # padding: never violates, never summed
    along2 = np.zeros((J, Kmax))
    off2 = np.zeros((J, Kmax))
    for r, (e, K) in enumerate(zip(f, sizes)):
        q[r, :K], q[r, K:] = e.q, e.q[0]
        epsk[r, :K], along2[r, :K], off2[r, :K] = e.epsk, e.along2, e.off2
    inside = (np.arange(Kmax)[None, :] < np.array(sizes)[:, None])[:, :, None].astype(float)
    lo = np.array([e.lo for e in f])
    hi = np.array([e.hi for e in f])
    alpha = np.array([e.alpha for e in f])[:, None]
    beta = np.array([e.beta for e in f])[:, None]
    r_least = np.array([r_mins[k] for k in idx])[:, None] * (1 - 1e-9)
    rows = np.arange(J)
    t_grid = _linspaces(lo, hi, grid)
    best_cost = np.full(J, np.inf)
    best_t1, best_R, best_t2 = np.zeros(J), np.zeros(J), np.zeros(J)
    lines = _family_lines(f)
    for _ in range(4):
        R = alpha + beta * t_grid
        d, t2 = _dist_to_arclines(lines, q, t_grid, R, along2, off2)
        viol = np.max(d - epsk[:, :, None], axis=1)
        valid = (viol <= 1e-12) & (R >= r_least)
        dd = d * d
        dd *= inside  # padding adds exact zeros to the row-by-row sums over each chain
        cost = np.where(valid, np.add.reduce(dd, axis=1), np.inf)
        some = valid.any(1)
        # the cheapest valid start, or the least violating one: valid sets can be narrow
        g = np.where(some, np.argmin(cost, 1), np.argmin(viol, 1))
        c = cost[rows, g]
        better = some & (c < best_cost)
        best_cost = np.where(better, c, best_cost)
        best_t1 = np.where(better, t_grid[rows, g], best_t1)
        best_R = np.where(better, R[rows, g], best_R)
        best_t2 = np.where(better, t2[rows, g], best_t2)
        step = t_grid[:, 1] - t_grid[:, 0]
        t = t_grid[rows, g]
        t_grid = _linspaces(np.maximum(lo, t - step), np.minimum(hi, t + step), 17)
    found = np.flatnonzero(np.isfinite(best_cost))
    for r, e in zip(found, _edges([f[r] for r in found], best_cost[found], best_t1[found], best_R[found],
                                  best_t2[found])):
        out[idx[r]] = e
    return out


def _linspaces(lo: np.ndarray, hi: np.ndarray, num: int) -> np.ndarray:
    """(J, num): :func:`_linspace` of every (lo, hi) pair, the same operations on every element."""
    ramp = _RAMPS.get(num)
    if ramp is None:
        ramp = _RAMPS.setdefault(num, np.arange(num, dtype=float))
    step = (hi - lo) / (num - 1)
    y = ramp[None, :] * step[:, None]
    y += lo[:, None]
    y[:, -1] = hi
    return y


def _best_arc_alone(f: _Arcs, r_min: float) -> Edge | None:
    """The search of a family whose arcs all start at one point."""
    t_grid = np.array([f.lo])
    R = f.alpha + f.beta * t_grid
    d, t2 = _dist_to_arclines([f], f.q[None], t_grid[None], R[None], f.along2[None], f.off2[None])
    d, t2 = d[0, :, 0], t2[0]
    if np.max(d - f.epsk) <= 1e-12 and R[0] >= r_min * (1 - 1e-9):
        # the chain's squares summed in order, as the batched search's row-by-row sums do
        return _edges([f], np.cumsum(d * d)[-1:], t_grid[:1], R[:1], t2[:1])[0]
    return None


def _edges(fams: list[_Arcs], cost: np.ndarray, t1: np.ndarray, R: np.ndarray, t2: np.ndarray) -> list[Edge]:
    """The edges of the arc families ``fams`` with their best arcs (arrays of each one's cost, start, radius and
    end): the outgoing lines of all of them at once, elementwise (l_j's point a1 + a2x u1 + a2y Ym in 3D), each
    direction's norm as np.linalg.norm takes it (the square root of its own dot product)."""
    if not fams:
        return []
    a1, u1, ym = (np.array([getattr(f, name) for f in fams]) for name in ("a1", "u1", "Ym"))
    a2, u2 = np.array([f.a2 for f in fams]), np.array([f.u2 for f in fams])
    out_point = a1 + a2[:, :1] * u1 + a2[:, 1:] * ym
    step = u2[:, :1] * u1 + u2[:, 1:] * ym
    unit = step / np.array([math.sqrt(v.dot(v)) for v in step])[:, None]
    return [Edge(a, b, c, f.phi, p, u, e, f, s) for a, b, c, p, u, e, f, s in
            zip(t1.tolist(), t2.tolist(), R.tolist(), out_point, unit, cost.tolist(), fams, step)]


def edge_fit(chain: np.ndarray, a1: np.ndarray, u1: np.ndarray, t_lo: float, pj: np.ndarray, pj1: np.ndarray,
             eps: float, r_min: float, grid: int = 64, t_hi: float | None = None, plane_only: bool = False):
    """Best arc (least squared error) joining l_i = (a1, u1) and l_j = p_j p_{j+1}, or None; ``TOO_FAR`` and
    ``plane_only`` as in :func:`arc_family`."""
    f = arc_family(chain, a1, u1, t_lo, pj, pj1, eps, r_min, t_hi, plane_only)
    if f is None or f is TOO_FAR:
        return f
    return best_arcs([f], r_min, grid)[0]


def _planes(poly: np.ndarray, i: int, last: int, a1: np.ndarray, u1: np.ndarray, eps: float):
    """The plane tests of :func:`arc_family` for the chains of every edge out of vertex i (j = i+1 … n-2, the
    chain p_i … p_j, and p_{j+1} too at the last vertex) at once: the chains grow by a vertex per j, so their
    coordinates are those of one array and their scatter sums running sums. Returns the basis (e1, e2), the
    coordinates (along, x1, x2) of p_i … p_{n-1}, and per j the chain length, the plane normal (m1, m2) and
    the largest distance of a chain vertex from the plane."""
    return _planes_of_states(poly, i, last, [a1], [u1], eps)[0]


def _planes_of_states(poly: np.ndarray, i: int, last: int, points: list[np.ndarray], directions: list[np.ndarray],
                      eps: float) -> list[tuple]:
    """:func:`_planes` of every state of vertex i (its modified tangent lines ``points``, ``directions``) at once:
    the products that depend on one line (its basis, the chain's coordinates in it, the normals' components)
    are each state's own calls, every elementwise step runs over the stacked states. The same operations on
    every element, so each state gets what it gets alone (:func:`_planes`)."""
    S = len(points)
    n = len(poly)
    bases = [_basis(u1) for u1 in directions]
    coords = np.array([((poly[i:] - a1) @ np.array((u1, e1, e2)).T).T
                       for a1, u1, (e1, e2) in zip(points, directions, bases)])  # (S, 3, L)
    along, x1, x2 = coords[:, 0], coords[:, 1], coords[:, 2]
    js = np.arange(i + 1, n - 1)
    K = js - i + 1 + (js == last)
    a = np.cumsum(x1 * x1, axis=1)[:, K - 1]
    b = np.cumsum(x1 * x2, axis=1)[:, K - 1]
    d = np.cumsum(x2 * x2, axis=1)[:, K - 1]
    dv = poly[js + 1] - poly[js]
    dj = dv / np.maximum(np.sqrt(np.einsum("jk,jk->j", dv, dv)), 1e-300)[:, None]
    J = len(js)
    cr = cross(np.repeat(np.asarray(directions), J, axis=0), np.tile(dj, (S, 1)))  # (S J, 3)
    crn = np.sqrt(np.einsum("jk,jk->j", cr, cr)).reshape(S, J)
    half, mean = 0.5 * (a - d), 0.5 * (a + d)
    root = np.hypot(half, b)
    own = (np.sqrt(np.maximum(mean + root, 0.0) / K) > 2 * eps) | (crn < 1e-9)
    small = mean - root
    row1 = np.abs(small - a) >= np.abs(small - d)
    v0, v1 = np.where(row1, b, small - d), np.where(row1, small - a, b)
    nv = np.hypot(v0, v1)
    nv_safe = np.where(nv > 0, nv, 1.0)
    mc = (cr / np.where(crn > 0, crn, 1.0).reshape(-1)[:, None]).reshape(S, J, 3)
    mc1 = np.array([mc[k] @ e1 for k, (e1, _) in enumerate(bases)])
    mc2 = np.array([mc[k] @ e2 for k, (_, e2) in enumerate(bases)])
    m1 = np.where(own, np.where(nv > 0, v0 / nv_safe, 1.0), mc1)
    m2 = np.where(own, np.where(nv > 0, v1 / nv_safe, 0.0), mc2)
    off = np.abs(m1[:, :, None] * x1[:, None, :] + m2[:, :, None] * x2[:, None, :])
    # the largest over each chain: the running maximum at its last vertex
    worst = np.maximum.accumulate(off, axis=2)[:, np.arange(J), K - 1]
    return [(e1, e2, along[k], x1[k], x2[k], K, m1[k], m2[k], worst[k]) for k, (e1, e2) in enumerate(bases)]


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
    return fit_arclines([(poly, eps, r_min, beam)])[0]


def fit_arclines(searches: list[tuple[np.ndarray, float, float, int]],
                 memos: list[dict] | None = None) -> list[TubeModel | None]:
    """:func:`fit_arcline` of every (polygon, ε, r_min, beam) in ``searches``, run in lockstep: the arcs that
    the current states of all of them ask for are searched in one :func:`best_arcs` call. That search is
    element for element the search of each family alone, so every result is the one its own run gives;
    the batch only spreads numpy's per-call overhead (the states of a vertex ask for ~10 arcs of ~8 chain points).
    ``memos``: a dict per search that keeps its plane tests and edges for another search of the same polygon, ε
    and r_min (a wider beam's, after a dead end: most of its states are the narrower one's, and a state's edges
    depend on nothing else)."""
    runs = [_search_states(*s, memo=memos[k] if memos is not None else None) for k, s in enumerate(searches)]
    out: list[TubeModel | None] = [None] * len(runs)
    asks: dict[int, list[_Arcs]] = {}
    answers: dict[int, list[Edge | None] | None] = {k: None for k in range(len(runs))}
    while answers:
        for k, edges in answers.items():
            try:
                asks[k] = runs[k].send(edges)
            except StopIteration as done:
                out[k] = done.value
        answers = {}
        if not asks:
            break
        fams = [f for k in asks for f in asks[k]]
        edges = best_arcs(fams, [searches[k][2] for k in asks for _ in asks[k]])
        at = 0
        for k, fs in asks.items():
            answers[k] = edges[at:at + len(fs)]
            at += len(fs)
        asks = {}
    return out


def _search_states(poly: np.ndarray, eps: float, r_min: float, beam: int, memo: dict | None = None):
    """Algorithm 1 as a generator: it yields the arc families the states of one vertex need searched (every edge
    out of them that passes the plane test) and is sent their best arcs (:func:`best_arcs`); it returns the
    model. ``memo``: the plane tests and edges of states met before (see :func:`fit_arclines`), added to."""
    memo = {} if memo is None else memo
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
        # the edges out of every state of vertex i searched at once: a state's edges change only the states of
        # the vertices they reach, never another state of i, so the order of the insertions below is all that
        # matters. The beam tests then see the states of j as they were before any edge of i: an edge they let
        # through that a sibling's insertion would have stopped sorts behind a full beam and is cut (the sort is
        # stable, and the skipped edges are those with more arcs, or as many and no smaller error)
        asks = []  # (state index, j, chain length, ...) of every edge out of vertex i that passed its plane test
        # every edge's plane test at once (:func:`arc_family`'s, the same rule), for every state of i not met before
        # (a state's tests are what it gets alone, whichever states are tested with it)
        keys = [(i, st.point.tobytes(), st.direction.tobytes(), st.t_lo) for st in states[i]]
        new = [si for si, key in enumerate(keys) if ("planes",) + key not in memo]
        if new:
            for si, pl in zip(new, _planes_of_states(poly, i, last, [states[i][si].point for si in new],
                                                     [states[i][si].direction for si in new], eps)):
                memo[("planes",) + keys[si]] = pl
        planes = [memo[("planes",) + key] for key in keys]
        for si, st in enumerate(states[i]):
            K, off = planes[si][5], planes[si][8]  # chain lengths and plane distances per j
            for jj, j in enumerate(range(i + 1, n - 1)):
                worst = states[j][-1] if len(states[j]) >= beam else None
                if worst is not None and st.d + 1 > worst.d:
                    continue
                # a full beam keeps a state of as many arcs only if its error is smaller, and an edge
                # adds error: then only whether the chain leaves every plane (ending the j loop) matters
                lost = worst is not None and st.d + 1 == worst.d and st.sse >= worst.sse
                # p_{j+1} only fixes the direction of l_j; it is checked by j's outgoing edge (it
                # lies in the next bend's plane when two bends follow each other directly): the chain is
                # p_i … p_j, and p_{j+1} too at the last vertex
                if off[jj] > eps:
                    if off[jj] > 2 * eps:  # TOO_FAR: longer chains leave every plane too
                        break
                    continue
                if lost:
                    continue
                # an arc may start up to ε before the previous one ended (the straight between
                # them is then 0): chord tangent estimates at a junction of two bends are off by
                # about that
                asks.append((si, j, int(K[jj]), jj, st.point, st.direction, st.t_lo - (eps if i else 0.0)))
        # each edge's best arc (None: no arc family, or no arc within ε), those met before from the memo
        edge_keys = [("edge", a[1]) + keys[a[0]] for a in asks]
        todo = [a for a, key in enumerate(edge_keys) if key not in memo]
        families = _arcs_in_planes(planes, [asks[a] for a in todo], poly, eps, r_min)
        reached = [(a, f) for a, f in zip(todo, families) if f is not None]
        for a, f in zip(todo, families):
            if f is None:
                memo[edge_keys[a]] = None
        if reached:
            # the arcs of all of them searched at once (with those other runs ask for)
            edges = yield [f for _, f in reached]
            for (a, _), e in zip(reached, edges):
                memo[edge_keys[a]] = e
        for (si, j, *_), key in zip(asks, edge_keys):
            e = memo[key]
            if e is None:
                continue
            st = states[i][si]
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
