"""Stage 5 — least-squares fit of the tube surface to the samples in LRA parameters (§5–6).

Unknowns: the first arc's start point, the start frame (rotation vector applied to the
initial frame), the inner straight lengths, the inner rotations, the bend angles, the bend
radii (per bend, one common radius, or fixed) and the pipe radius (unless given); the
segment count from stage 4 is fixed. The LRA parametrisation is the one the paper argues
for in §5.1/§6 (no representation has local control, and LRA covers the whole
configuration space).

Residual of a sample: distance to its assigned spine segment minus the pipe radius, with the
assignment (nearest segment of the bounded spine) held fixed during a solve and renewed
between solves; the first and last straights are infinite lines during a solve, their
lengths follow from the extent of their samples afterwards (a bounded end would cost
nothing when too long). The Jacobian is analytic per sample (derivative of the distance
with respect to the segment's line or circle) chained with the derivative of the segment
geometry with respect to the LRA parameters (central differences of the forward
kinematics, which is cheap: it involves no samples). Each round is solved by
Levenberg–Marquardt (Marquardt diagonal scaling, soft-L1 robust loss by iteratively
reweighted normal equations, bounds by projection). Written out rather than calling
scipy.optimize.least_squares because that solver takes an SVD of the full N×P Jacobian
every iteration; here only the P×P normal equations Jᵀ J are formed and solved,
which stays fast with many samples and on a loaded machine.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np

from plantsolve.solvers.tube.model import (
    Spine,
    TubeModel,
    build_spine,
    distance_frames,
    first_within,
    segment_distances_t,
    spine_distance,
)


@dataclass
class Layout:
    n: int
    radius_mode: str  # "free" | "common" | "dies" | "fixed"
    fixed_bend_radius: float | None
    fit_pipe_radius: bool
    dies: tuple[int, ...] = ()  # "dies": the die (radius parameter) of each bend
    fixed_radii: tuple[float, ...] = ()  # "fixed" without fixed_bend_radius: each bend's held radius

    @property
    def n_radii(self) -> int:
        if self.radius_mode == "dies":
            return max(self.dies) + 1 if self.n else 0
        return {"free": self.n, "common": 1 if self.n else 0, "fixed": 0}[self.radius_mode]

    @property
    def size(self) -> int:
        return 6 + 2 * max(self.n - 1, 0) + self.n + self.n_radii + int(self.fit_pipe_radius)


def pack(model: TubeModel, lay: Layout) -> np.ndarray:
    n = lay.n
    p0 = model.start + model.lengths[0] * model.frame[:, 0]
    parts = [p0, np.zeros(3), model.lengths[1:n], model.rotations[1:n], model.angles]
    if lay.radius_mode == "free":
        parts.append(model.radii)
    elif lay.radius_mode == "common" and n:
        parts.append([np.mean(model.radii)])
    elif lay.radius_mode == "dies" and n:
        die = np.asarray(lay.dies)
        parts.append([float(np.mean(model.radii[die == k])) for k in range(lay.n_radii)])
    if lay.fit_pipe_radius:
        parts.append([model.pipe_radius])
    return np.concatenate([np.atleast_1d(np.asarray(p, float)) for p in parts])


def unpack(x: np.ndarray, lay: Layout, frame0: np.ndarray, pipe_radius: float) -> TubeModel:
    n = lay.n
    i = 6
    lm = x[i:i + n - 1] if n > 1 else np.zeros(0); i += max(n - 1, 0)
    rm = x[i:i + n - 1] if n > 1 else np.zeros(0); i += max(n - 1, 0)
    ang = x[i:i + n]; i += n
    if lay.radius_mode == "free":
        rad = x[i:i + n]; i += n
    elif lay.radius_mode == "common":
        rad = np.full(n, x[i] if n else 0.0); i += 1 if n else 0
    elif lay.radius_mode == "dies":
        rad = x[i:i + lay.n_radii][np.asarray(lay.dies, dtype=int)]; i += lay.n_radii
    elif lay.fixed_radii:
        rad = np.asarray(lay.fixed_radii, dtype=float)
    else:
        rad = np.full(n, lay.fixed_bend_radius or 0.0)
    rp = x[i] if lay.fit_pipe_radius else pipe_radius
    frame = rotvec_matrices(x[None, 3:6])[0] @ frame0
    lengths = np.concatenate([[0.0], lm, [0.0]]) if n else np.zeros(1)
    rots = np.concatenate([[0.0], rm, [0.0]]) if n else np.zeros(1)
    return TubeModel(x[:3].copy(), frame, lengths, rots, ang.copy(), rad.copy(), float(rp))


def bounds(lay: Layout, rp: float) -> tuple[np.ndarray, np.ndarray]:
    n = lay.n
    lo = np.full(lay.size, -np.inf); hi = np.full(lay.size, np.inf)
    i = 6
    lo[i:i + n - 1] = 0.0 if n > 1 else lo[i:i]; i += max(n - 1, 0)
    i += max(n - 1, 0)
    lo[i:i + n] = 1e-6; hi[i:i + n] = 2 * np.pi - 1e-6; i += n
    lo[i:i + lay.n_radii] = 0.5 * rp  # no bender makes a CLR below the pipe radius; 0.5 r leaves room
    hi[i:i + lay.n_radii] = 200.0 * rp  # a 1° bend needs no more; beyond, the model degenerates
    i += lay.n_radii
    if lay.fit_pipe_radius:
        lo[i] = 1e-3 * rp
    return lo, hi


def _geometry(model: TubeModel) -> np.ndarray:
    """(S, 7): lines [start, tangent, 0]; arcs [centre, axis, radius]."""
    sp = build_spine(model)
    g = np.zeros((len(sp.kind), 7))
    line = sp.kind == 0
    g[line, :3] = sp.start[line]; g[line, 3:6] = sp.tangent[line]
    arc = ~line
    g[arc, :3] = sp.centre[arc]; g[arc, 3:6] = sp.axis[arc]; g[arc, 6] = sp.radius[arc]
    return g


_YXX, _ZZY, _XXY, _YZZ, _ZYX = (np.array(c) for c in ((1, 0, 0), (2, 2, 1), (0, 0, 1), (1, 2, 2), (2, 1, 0)))
_ENTRIES = np.array([0, 4, 8, 3, 2, 7, 1, 6, 5])  # flat (row-major) index of each entry of a 3 x 3 matrix


def rotvec_matrices(V: np.ndarray) -> np.ndarray:
    """Rotation matrices (B, 3, 3) of rotation vectors V (B, 3) by Rodrigues' formula; below 1e-3 rad the
    coefficients sin θ / θ and (1 - cos θ) / θ² from their Taylor series (the finite-difference steps of the
    Jacobian are 1e-6 rad, where 1 - cos θ has lost most of its digits). The entries' three kinds (diagonal,
    the products b·x·y that both off-diagonal entries of a pair share, a·z that one adds and the other
    subtracts) each computed for all three components in one operation: a batch of a few rows costs numpy's
    per-call overhead, not arithmetic."""
    th2 = np.einsum("bi,bi->b", V, V)
    th = np.sqrt(th2)
    small = th < 1e-3
    th4 = th2 * th2
    a = 1.0 - th2 / 6.0 + th4 / 120.0
    b = 0.5 - th2 / 24.0 + th4 / 720.0
    if not small.all():  # (the Jacobian's batches rotate by its steps only: all small)
        th_safe = np.where(small, 1.0, th)
        a = np.where(small, a, np.sin(th_safe) / th_safe)
        b = np.where(small, b, (1.0 - np.cos(th_safe)) / (th_safe * th_safe))
    sq = V * V
    # columns (y² + z², x² + z², x² + y²), (b x y, b x z, b y z) and (a z, a y, a x)
    bc, ac = b[:, None], a[:, None]
    diag = 1.0 - bc * (sq.take(_YXX, 1) + sq.take(_ZZY, 1))
    pair = (bc * V).take(_XXY, 1) * V.take(_YZZ, 1)
    av = ac * V.take(_ZYX, 1)
    # the matrix's entries in the order of the columns of diag, pair + av and pair - av: (0,0), (1,1), (2,2),
    # (1,0) bxy + az, (0,2) bxz + ay, (2,1) byz + ax, (0,1) bxy - az, (2,0) bxz - ay, (1,2) byz - ax
    M = np.empty((len(V), 9))
    M.T[_ENTRIES] = np.concatenate([diag, pair + av, pair - av], axis=1).T
    return M.reshape(-1, 3, 3)


def geometry_batch(X: np.ndarray, lay: Layout, frame0: np.ndarray, rp: float,
                   plan: JacobianBatch | None = None) -> np.ndarray:
    """Segment geometry for a batch of parameter vectors X (B, P): (B, S, 7).

    The same forward kinematics as model.build_spine, vectorised over the batch (the
    finite-difference Jacobian evaluates 2P models at once) and over the bends: each bend is a rigid
    step whose 4 × 4 matrix follows from its parameters elementwise, so the only loop over the bends is
    one matrix product per bend. With ``plan`` (X is ``plan``'s batch about its row 0) a row's start frame and
    its products of the steps before the first bend its parameter moves are row 0's, taken as such: every row
    computed on its own is what it computes in the whole batch (elementwise operations and a matrix product
    per row), so these are the very numbers its own products give."""
    B = len(X)
    n = lay.n
    i = 6
    lm = X[:, i:i + n - 1] if n > 1 else np.zeros((B, 0)); i += max(n - 1, 0)
    rm = X[:, i:i + n - 1] if n > 1 else np.zeros((B, 0)); i += max(n - 1, 0)
    ang = X[:, i:i + n]; i += n
    if lay.radius_mode == "free":
        rad = X[:, i:i + n]; i += n
    elif lay.radius_mode == "common":
        rad = np.repeat(X[:, i:i + 1], n, axis=1) if n else np.zeros((B, 0)); i += 1 if n else 0
    elif lay.radius_mode == "dies":
        rad = X[:, i:i + lay.n_radii][:, np.asarray(lay.dies, dtype=int)]; i += lay.n_radii
    elif lay.fixed_radii:
        rad = np.tile(np.asarray(lay.fixed_radii, dtype=float), (B, 1))
    else:
        rad = np.full((B, n), lay.fixed_bend_radius or 0.0)
    if plan is None:
        frames = rotvec_matrices(X[:, 3:6]) @ frame0
    else:  # the rows after the first ``turned`` + 1 have row 0's rotation vector: its frame
        own = rotvec_matrices(X[:plan.turned + 1, 3:6]) @ frame0
        frames = np.empty((B, 3, 3))
        frames[:plan.turned + 1] = own
        frames[plan.turned + 1:] = own[0]
    g = np.zeros((B, 2 * n + 1, 7))
    p0, t0 = X[:, :3], frames[:, :, 0]
    g[:, 0, :3] = p0
    g[:, 0, 3:6] = t0
    if not n:
        return g
    # bend k as one rigid step from its arc start (frame F_k, point p_k) to the next arc start: turn about the
    # tangent by the rotation (Rx), bend about the binormal by the angle (Rz, offset (R sin a, R (1 - cos a),
    # 0) in the turned frame), then the straight after it along the new tangent; in homogeneous 4 x 4 form
    # the frames of all bends are one product per bend for the whole batch
    rots = np.concatenate([np.zeros((B, 1)), rm], 1)
    after = np.concatenate([lm, np.zeros((B, 1))], 1)  # the straight after each bend (the end one: 0)
    c, s_ = np.cos(rots), np.sin(rots)
    ca, sa = np.cos(ang), np.sin(ang)
    M = np.zeros((B, n, 4, 4))
    M[..., 0, 0], M[..., 0, 1] = ca, -sa
    M[..., 1, 0], M[..., 1, 1], M[..., 1, 2] = c * sa, c * ca, -s_
    M[..., 2, 0], M[..., 2, 1], M[..., 2, 2] = s_ * sa, s_ * ca, c
    off = rad * (1.0 - ca)
    M[..., 0, 3] = rad * sa + after * ca
    M[..., 1, 3] = c * (off + after * sa)
    M[..., 2, 3] = s_ * (off + after * sa)
    M[..., 3, 3] = 1.0
    T = np.empty((B, n + 1, 4, 4))
    T[:, 0, :3, :3] = frames
    T[:, 0, :3, 3] = p0
    T[:, 0, 3] = (0.0, 0.0, 0.0, 1.0)
    for k in range(n):
        live = B if plan is None else plan.active[k]
        T[:live, k + 1] = T[:live, k] @ M[:live, k]
        if live < B:  # rows whose frames and steps up to bend k are row 0's
            T[live:, k + 1] = T[0, k + 1]
    F, P = T[:, :n, :3, :3], T[:, :n, :3, 3]  # each bend's arc start, before its rotation
    nt = F[..., 1] * c[..., None] + F[..., 2] * s_[..., None]  # the turned normal (toward the centre)
    bt = F[..., 2] * c[..., None] - F[..., 1] * s_[..., None]  # the turned binormal (the arc's axis)
    g[:, 1::2, :3] = P + rad[..., None] * nt
    g[:, 1::2, 3:6] = bt
    g[:, 1::2, 6] = rad
    # the straights after the bends start at the arc ends, along the next frames' tangents
    g[:, 2::2, :3] = P + (rad * sa)[..., None] * F[..., 0] + off[..., None] * nt
    g[:, 2::2, 3:6] = T[:, 1:, :3, 0]
    return g


def _radii_of(xs: list[float], i: int, lay: Layout) -> list[float]:
    """The bend radii of a parameter list whose radius parameters start at ``i`` (``geometry_batch``'s)."""
    n = lay.n
    if lay.radius_mode == "free":
        return xs[i:i + n]
    if lay.radius_mode == "common":
        return [xs[i]] * n if n else []
    if lay.radius_mode == "dies":
        return [xs[i + d] for d in lay.dies]
    if lay.fixed_radii:
        return [float(r) for r in lay.fixed_radii]
    return [float(lay.fixed_bend_radius or 0.0)] * n


def _rotvec_matrix(v: np.ndarray) -> np.ndarray:
    """``rotvec_matrices`` of one rotation vector ``v`` (3,) as (3, 3), the same numbers: its elementwise
    operations in Python floats (IEEE double, each rounded as numpy rounds it; libm's sin and cos, which numpy's
    float64 ones are), its θ² by numpy's einsum (whose sum of three products rounds its own way)."""
    x, y, z = v.tolist()
    th2 = float(np.einsum("i,i->", v, v))
    th = math.sqrt(th2)
    if th < 1e-3:
        th4 = th2 * th2
        a = 1.0 - th2 / 6.0 + th4 / 120.0
        b = 0.5 - th2 / 24.0 + th4 / 720.0
    else:
        a = math.sin(th) / th
        b = (1.0 - math.cos(th)) / (th * th)
    xx, yy, zz = x * x, y * y, z * z
    bx, by = b * x, b * y
    bxy, bxz, byz = bx * y, bx * z, by * z
    ax, ay, az = a * x, a * y, a * z
    return np.array([1.0 - b * (yy + zz), bxy - az, bxz + ay, bxy + az, 1.0 - b * (xx + zz), byz - ax,
                     bxz - ay, byz + ax, 1.0 - b * (xx + yy)]).reshape(3, 3)


def geometry_one(x: np.ndarray, lay: Layout, frame0: np.ndarray) -> np.ndarray:
    """``geometry_batch(x[None], ...)[0]`` to the last bit, for one parameter vector: each LM evaluation's
    model. The batch's arrays of one row cost numpy's per-call overhead dozens of times per bend (two fifths of
    a 6,000-sample evaluation: 120 µs for 7 bends, this 60 µs); here the elementwise arithmetic is in Python
    floats in the batch's order of operations, and the products the batch takes from BLAS (the start frame, one
    4 × 4 step per bend) are the same matrix products, so every number is the batch's."""
    n = lay.n
    xs = x.tolist()
    i = 6
    lm = xs[i:i + n - 1] if n > 1 else []
    i += max(n - 1, 0)
    rm = xs[i:i + n - 1] if n > 1 else []
    i += max(n - 1, 0)
    ang = xs[i:i + n]
    rad = _radii_of(xs, i + n, lay)
    frame = _rotvec_matrix(x[3:6]) @ frame0
    t0 = frame[:, 0].tolist()
    if not n:
        return np.array(xs[:3] + t0 + [0.0]).reshape(1, 7)
    cs = [(math.cos(r), math.sin(r)) for r in [0.0] + rm]
    csa = [(math.cos(a), math.sin(a)) for a in ang]
    flat = []
    for (c, s), (ca, sa), r, l in zip(cs, csa, rad, lm + [0.0]):
        run = r * (1.0 - ca) + l * sa
        flat += (ca, -sa, 0.0, r * sa + l * ca, c * sa, c * ca, -s, c * run, s * sa, s * ca, c, s * run,
                 0.0, 0.0, 0.0, 1.0)
    M = np.array(flat).reshape(n, 4, 4)
    T = np.empty((n + 1, 4, 4))
    T[0, :3, :3] = frame
    T[0, :3, 3] = x[:3]
    T[0, 3] = (0.0, 0.0, 0.0, 1.0)
    for k in range(n):
        np.matmul(T[k], M[k], out=T[k + 1])
    Ts = T[:, :3].tolist()
    out = xs[:3] + t0 + [0.0]
    for k in range(n):
        (f00, f01, f02, p0), (f10, f11, f12, p1), (f20, f21, f22, p2) = Ts[k]
        (c, s), (ca, sa), r = cs[k], csa[k], rad[k]
        off, rsa = r * (1.0 - ca), r * sa
        n0, n1, n2 = f01 * c + f02 * s, f11 * c + f12 * s, f21 * c + f22 * s  # the turned normal
        nxt = Ts[k + 1]
        out += (p0 + r * n0, p1 + r * n1, p2 + r * n2, f02 * c - f01 * s, f12 * c - f11 * s, f22 * c - f21 * s, r,
                p0 + rsa * f00 + off * n0, p1 + rsa * f10 + off * n1, p2 + rsa * f20 + off * n2,
                nxt[0][0], nxt[1][0], nxt[2][0], 0.0)
    return np.array(out).reshape(2 * n + 1, 7)


def _steps(P: int, lay: Layout, scale: float) -> np.ndarray:
    """Central-difference steps of the parameters: 1e-6 of the pipe radius for lengths, 1e-6 rad for angles."""
    steps = np.full(P, 1e-6)
    steps[:3] = 1e-6 * scale
    i = 6 + max(lay.n - 1, 0)
    steps[6:i] = 1e-6 * scale
    steps[i + max(lay.n - 1, 0) + lay.n:] = 1e-6 * scale
    return steps


@dataclass(frozen=True)
class JacobianBatch:
    """The central-difference batch of a round (:func:`jacobian_batch`): row 0 the point, then each parameter's
    + and − step (rows ``plus`` and ``minus``), ordered by the first bend the parameter moves (the start point and
    frame move them all; the rotation vector's rows first); ``span`` = 2 × steps as (P, 1, 1)."""

    shift: np.ndarray  # (P, P): the steps of the + and − rows 1 + 2m and 2 + 2m in row m (a permuted diagonal)
    plus: np.ndarray
    minus: np.ndarray
    span: np.ndarray
    turned: int  # rows 1 … turned change the rotation vector
    active: tuple[int, ...]  # per bend k: the rows [:active[k]] whose frames or steps up to bend k are their own


def jacobian_batch(lay: Layout, steps: np.ndarray) -> JacobianBatch:
    """The batch of :func:`geometry_and_jacobian` for the steps of a round (:func:`_steps`)."""
    pos, active = _batch_rows(len(steps), lay.n, lay.radius_mode, tuple(lay.dies))
    shift = np.zeros((len(steps), len(steps)))
    shift[pos, np.arange(len(steps))] = steps
    return JacobianBatch(shift, 1 + 2 * pos, 2 + 2 * pos, 2 * steps[:, None, None], 6, active)


@functools.lru_cache(maxsize=256)
def _batch_rows(P: int, n: int, radius_mode: str, dies: tuple[int, ...]) -> tuple[np.ndarray, tuple[int, ...]]:
    """The rows of :func:`jacobian_batch` of a layout (P parameters, n bends; a pipe radius parameter, if any, is
    the last): each parameter's position among the batch's pairs of rows, and per bend k the rows ``active[k]``
    of :class:`JacobianBatch`. The same for every round of a layout (the bend count's choice fits a few layouts
    dozens of times); the positions are shared: read only."""
    first = np.full(P, n)  # the first bend whose 4 × 4 step a parameter changes (n: none, the pipe radius)
    first[:6] = 0  # start point and frame: before the first bend
    i = 6
    first[i:i + max(n - 1, 0)] = np.arange(n - 1)  # the straight after bend k is in bend k's step
    i += max(n - 1, 0)
    first[i:i + max(n - 1, 0)] = np.arange(1, n)  # the rotation before bend k + 1
    i += max(n - 1, 0)
    first[i:i + n] = np.arange(n)
    i += n
    if radius_mode == "free":
        first[i:i + n] = np.arange(n)
    elif radius_mode == "common" and n:
        first[i] = 0
    elif radius_mode == "dies" and n:
        die = np.asarray(dies)
        first[i:i + max(dies) + 1] = [int(np.flatnonzero(die == d)[0]) for d in range(max(dies) + 1)]
    order = sorted(range(P), key=lambda p: (first[p], not 3 <= p < 6))
    pos = np.empty(P, int)
    pos[order] = np.arange(P)
    pos.setflags(write=False)
    first_sorted = first[order]
    return pos, tuple(1 + 2 * int(np.searchsorted(first_sorted, k, side="right")) for k in range(n))


def geometry_and_jacobian(x: np.ndarray, lay: Layout, frame0: np.ndarray, rp: float,
                          plan: JacobianBatch) -> tuple[np.ndarray, np.ndarray]:
    """The geometry at x (S, 7) and its derivative by central differences (S, 7, P), from one batch: the
    batch costs little more than one model (the forward kinematics is a loop over the bends). ``plan``: the
    round's :func:`jacobian_batch` (the same for all its calls)."""
    X = np.empty((2 * len(x) + 1, len(x)))
    X[0] = x
    np.add(x, plan.shift, out=X[1::2])  # (x ± a row of zeros but one: the rows x + diag(steps) and x - diag(steps))
    np.subtract(x, plan.shift, out=X[2::2])
    G = geometry_batch(X, lay, frame0, rp, plan)
    return G[0], ((G[plan.plus] - G[plan.minus]) / plan.span).transpose(1, 2, 0)


def _geometry_jacobian(x, lay, frame0, rp, scale):
    """d(geometry)/d(params) by central differences: (S, 7, P)."""
    P = len(x)
    steps = _steps(P, lay, scale)
    X = np.concatenate([x + np.diag(steps), x - np.diag(steps)])
    G = geometry_batch(X, lay, frame0, rp)
    return np.moveaxis((G[:P] - G[P:]) / (2 * steps[:, None, None]), 0, -1)


def _groups(seg: np.ndarray, block: int = 65_536) -> list[tuple[int, slice]]:
    """(segment, slice) runs of a segment array sorted by segment, cut into blocks of at most ``block``
    samples (the per-sample temporaries of a block stay in the processor's cache)."""
    ks, starts = np.unique(seg, return_index=True)
    ends = np.r_[starts[1:], len(seg)]
    return [(int(k), slice(int(a), int(min(a + block, b)))) for k, a0, b in zip(ks, starts, ends)
            for a in range(int(a0), int(b), block)]


def _run_distance(q: np.ndarray, gk: np.ndarray, arc: bool) -> tuple[np.ndarray, tuple]:
    """Distance of the points q to one (unbounded) line or circle ``gk`` (a row of :func:`_geometry`), and the
    terms :func:`_run_gradient` takes on from."""
    c, a = gk[:3], gk[3:6]
    w = q - c
    s = w @ a
    perp = w - s[:, None] * a
    rho = np.sqrt(np.einsum("nk,nk->n", perp, perp))
    if not arc:
        return rho, (w, s, perp, rho, a, None, rho)
    R = gk[6]
    dd = np.hypot(rho - R, s)
    return dd, (w, s, perp, rho, a, R, dd)


def _run_gradient(terms: tuple) -> np.ndarray:
    """d dist / d geometry (n, 7) from the terms of :func:`_run_distance`."""
    w, s, perp, rho, a, R, dd = terms
    e = perp / np.maximum(rho, 1e-300)[:, None]
    if R is None:  # a line
        grad = np.zeros((len(w), 7))
        grad[:, :3] = -e
        grad[:, 3:6] = -s[:, None] * e
        return grad
    grad = np.empty((len(w), 7))
    inv = 1.0 / np.maximum(dd, 1e-300)
    grad[:, :3] = -((rho - R)[:, None] * e + s[:, None] * a) * inv[:, None]
    grad[:, 3:6] = ((rho - R)[:, None] * (-s[:, None] * e) + s[:, None] * w) * inv[:, None]
    grad[:, 6] = -(rho - R) * inv
    return grad


def _run_dist_and_grad(q: np.ndarray, gk: np.ndarray, arc: bool, want_grad: bool):
    """Distance of the points q to one (unbounded) line or circle ``gk`` (a row of :func:`_geometry`)
    and d dist / d geometry (None unless ``want_grad``)."""
    d, terms = _run_distance(q, gk, arc)
    return d, (_run_gradient(terms) if want_grad else None)


def _dist_and_grad(pts: np.ndarray, groups: list[tuple[int, slice]], g: np.ndarray, kind: np.ndarray,
                   want_grad: bool):
    """Distance of each point to its (unbounded) assigned line / circle and d dist / d geometry.

    ``pts`` are sorted by assigned segment; ``groups`` are the runs (see :func:`_groups`)."""
    N = len(pts)
    d = np.empty(N)
    grad = np.zeros((N, 7)) if want_grad else None
    for k, m in groups:
        d[m], gr = _run_dist_and_grad(pts[m], g[k], bool(kind[k]), want_grad)
        if want_grad:
            grad[m] = gr
    return d, grad


def extended(model: TubeModel, margin: float) -> TubeModel:
    m = model.copy()
    m.start = m.start - margin * m.frame[:, 0]
    m.lengths = m.lengths.copy()
    m.lengths[0] += margin
    m.lengths[-1] += margin
    return m


def assign(model: TubeModel, pts: np.ndarray, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """Residual (bounded distance − pipe radius) and nearest segment of every sample."""
    d, seg = spine_distance(pts, build_spine(extended(model, margin)))
    d -= model.pipe_radius  # (in place: a large scan's distances are fresh memory of its size)
    return d, seg


INNER_CHUNK = 200_000  # points × segments per block of :class:`EndAssignment` (as ``spine_distance``)


class EndAssignment:
    """:func:`assign` of the same samples to models that differ in their end straights only (the start point
    and the first and last lengths; :func:`end_lengths`): the inner segments' nearest distance and index are
    computed once, each model then costs the distances to its two end segments. The same rule as
    ``spine_distance``: the first segment within round-off of the minimum."""

    def __init__(self, model: TubeModel, pts: np.ndarray, margin: float, full: bool = False):
        """With ``full`` the assignment of ``model`` itself comes from the same distances (``res``, ``seg``)."""
        self.pts, self.margin = pts, margin
        sp = build_spine(extended(model, margin))
        S = len(sp.kind)
        self.S = S
        rows = np.arange(S) if full else np.arange(1, S - 1)
        sub = _sub_spine(sp, rows)
        self.lo = np.empty(len(pts))
        # the inner segments' numbers in 16 bits when they fit (as spine_distance's): a large scan's end samples
        # are millions, and the numbers each model's assignment returns take this type too
        self.idx = np.empty(len(pts), np.int16 if S < 2 ** 15 else np.intp)
        if full:
            d, seg = np.empty(len(pts)), np.empty(len(pts), int)
        step = max(1, INNER_CHUNK // max(len(rows), 1))
        tol = self._tol(sp)
        for a in range(0, len(pts), step):
            m = segment_distances_t(pts[a:a + step], sub)
            if full:
                lo = m.min(axis=0)
                i = first_within(m, lo + tol)
                seg[a:a + step] = i
                d[a:a + step] = np.take_along_axis(m, i[None], 0)[0]
                m = m[1:S - 1]
            lo = m.min(axis=0)
            self.lo[a:a + step] = lo
            self.idx[a:a + step] = 1 + first_within(m, lo + tol)
        if full:
            self.res, self.seg = d - model.pipe_radius, seg


    def _tol(self, sp: Spine) -> float:
        p_abs = max(float(-self.pts.min(initial=0.0)), float(self.pts.max(initial=0.0))) if self.pts.size else 0.0
        return 1e-12 * (float(np.abs(sp.start).max(initial=0.0)) + p_abs + 1e-300)

    def __call__(self, model: TubeModel) -> tuple[np.ndarray, np.ndarray]:
        sp = build_spine(extended(model, self.margin))
        ends = _sub_spine(sp, np.array([0, self.S - 1]))
        frames = distance_frames(ends)
        tol = self._tol(sp)
        n = len(self.pts)
        res, seg = np.empty(n), np.empty(n, self.idx.dtype)
        # a block of samples at a time: the temporaries stay in the processor's cache, and a large scan's
        # end samples get no fresh arrays of their number but the two returned
        for b in _blocks(n):
            d0, d1 = segment_distances_t(self.pts[b], ends, frames)
            inner = self.lo[b]
            lo = np.minimum(np.minimum(d0, inner), d1)
            cut = lo + tol
            first = d0 <= cut
            mid = ~first & (inner <= cut)
            seg[b] = np.where(first, 0, np.where(mid, self.idx[b], self.S - 1))
            res[b] = np.where(first, d0, np.where(mid, inner, d1))
        res -= model.pipe_radius
        return res, seg


def _sub_spine(sp: Spine, k: np.ndarray) -> Spine:
    return Spine(sp.kind[k], sp.start[k], sp.end[k], sp.tangent[k], sp.normal[k], sp.length[k], sp.centre[k],
                 sp.radius[k], sp.angle[k])


SUMS_BY_REACH = 100_000  # samples from which :func:`sums_of_squares` bounds the moved segments' reach


def sums_of_squares(model: TubeModel, variants: list[TubeModel], pts: np.ndarray,
                    keep: np.ndarray | None = None) -> tuple[float, list[float]]:
    """Σ (distance − pipe radius)² of the samples to ``model`` and to each of ``variants`` (models that differ
    from it near a few segments, such as :func:`model.with_radii` of one bend), the distance to the nearest
    (bounded) segment. A variant's segments that did not move (further than round-off: a straight clipped to
    length 0 moves everything after it) are ``model``'s, whose distances each block of samples takes once. Its
    moved segments lie within a distance H of the ones they replace (:func:`_reach`), so a sample whose distance
    to those exceeds its distance to the kept segments by more than H is nearer a kept segment in the variant
    too: the moved segments' distances are taken of the other samples only. No array of the samples' size is
    made. ``keep``: the samples to sum over (a mask; default all). Below ``SUMS_BY_REACH`` samples all distances
    are taken at once (:func:`_sums_of_squares_joint`): the bounds and subsets cost more than they save."""
    if len(pts) < SUMS_BY_REACH:
        return _sums_of_squares_joint(model, variants, pts, keep)
    base = build_spine(model)
    S = len(base.kind)
    scale = float(np.abs(base.start).max(initial=0.0)) + float(np.abs(base.end).max(initial=0.0)) + model.pipe_radius
    moved_of = []  # each variant's moved segments: their spine and its frames, their rows of model's spine, H
    n_rows = S
    for v in variants:
        sp = build_spine(v)
        diff = _moved(base, sp, scale)
        moved = np.flatnonzero(diff)
        sub = _sub_spine(sp, moved)
        moved_of.append((sub, distance_frames(sub), moved, _reach(sub, _sub_spine(base, moved), model.pipe_radius)))
        n_rows += len(moved)
    frames = distance_frames(base)
    rp = model.pipe_radius
    # a bound's slack for the round-off of the distances it is compared with
    slack = 1e-9 * (scale + max(float(-pts.min(initial=0.0)), float(pts.max(initial=0.0))))
    rss0, rss = 0.0, [0.0] * len(variants)
    step = max(1, INNER_CHUNK // n_rows)  # (the blocks of the joint spine of all moved segments: the same sums)
    for a in range(0, len(pts), step):
        q = pts[a:a + step] if keep is None else pts[a:a + step][keep[a:a + step]]
        D = segment_distances_t(q, base, frames)
        # the minima over the first and over the last segments: a variant's kept segments are a run before
        # and a run after its moved ones (a bend and the straights beside it), whose minimum is the smaller
        # of the two (a minimum is exact: the numbers of the minimum over the kept rows)
        head, tail = _running_minima(D)
        r = head[-1] - rp
        rss0 += float(r @ r)
        for i, ((sub, sub_frames, moved, reach), v) in enumerate(zip(moved_of, variants)):
            if not len(moved):
                d = head[-1].copy()
            elif moved[-1] - moved[0] == len(moved) - 1:  # one run of segments
                lo, hi = moved[0], moved[-1]
                d = (np.minimum(head[lo - 1], tail[hi + 1]) if lo and hi < S - 1 else head[lo - 1].copy() if lo
                     else tail[hi + 1].copy() if hi < S - 1 else np.full(len(q), np.inf))
            else:
                d = np.delete(D, moved, axis=0).min(axis=0, initial=np.inf)
            if len(moved):
                near = np.flatnonzero(D[moved].min(axis=0) - reach <= d + slack)
                if len(near):
                    d[near] = np.minimum(d[near], segment_distances_t(np.take(q, near, axis=0), sub,
                                                                        sub_frames).min(axis=0))
            d -= v.pipe_radius
            rss[i] += float(d @ d)
    return rss0, rss


def _running_minima(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row k of the first: the minimum of rows 0 … k of D; of the second: of rows k … last (a row at a time: an
    accumulation down the columns of D walks them with a stride of a whole row)."""
    head, tail = np.empty_like(D), np.empty_like(D)
    head[0], tail[-1] = D[0], D[-1]
    for k in range(1, len(D)):
        np.minimum(head[k - 1], D[k], out=head[k])
        np.minimum(tail[-k], D[-k - 1], out=tail[-k - 1])
    return head, tail


def _moved(base, sp, scale: float) -> np.ndarray:
    """Which segments of spine ``sp`` moved from ``base``'s further than round-off (``scale``: the spine's size)."""
    diff = np.zeros(len(base.kind), bool)
    for x, y in ((base.start, sp.start), (base.end, sp.end), (base.centre, sp.centre), (base.tangent, sp.tangent),
                 (base.normal, sp.normal)):
        diff |= np.abs(x - y).max(axis=1) > 1e-12 * scale
    return diff | (np.abs(base.radius - sp.radius) > 1e-12 * scale) | (np.abs(base.angle - sp.angle) > 1e-12)


def _sums_of_squares_joint(model: TubeModel, variants: list[TubeModel], pts: np.ndarray,
                           keep: np.ndarray | None = None) -> tuple[float, list[float]]:
    """:func:`sums_of_squares` of a few samples: the segments of ``model`` and those of the variants that moved
    (further than round-off: a straight clipped to length 0 moves everything after it) are one spine, whose
    distances a block of samples takes at once; a variant's other segments are ``model``'s (the same to
    round-off)."""
    base = build_spine(model)
    S = len(base.kind)
    scale = float(np.abs(base.start).max(initial=0.0)) + float(np.abs(base.end).max(initial=0.0)) + model.pipe_radius
    parts, rows_of = [np.arange(S)], []  # each variant's moved segments, then its rows of the joint spine
    spines = [base]
    n_rows = S
    for v in variants:
        sp = build_spine(v)
        diff = _moved(base, sp, scale)
        moved = np.flatnonzero(diff)
        parts.append(moved)
        spines.append(sp)
        rows_of.append((np.arange(n_rows, n_rows + len(moved)), np.flatnonzero(~diff)))
        n_rows += len(moved)
    joint = Spine(*(np.concatenate([getattr(sp, f)[k] for sp, k in zip(spines, parts)])
                    for f in ("kind", "start", "end", "tangent", "normal", "length", "centre", "radius", "angle")))
    frames = distance_frames(joint)
    rp = model.pipe_radius
    rss0, rss = 0.0, [0.0] * len(variants)
    step = max(1, INNER_CHUNK // n_rows)
    for a in range(0, len(pts), step):
        q = pts[a:a + step] if keep is None else pts[a:a + step][keep[a:a + step]]
        D = segment_distances_t(q, joint, frames)
        r = D[:S].min(axis=0) - rp
        rss0 += float(r @ r)
        for i, ((own, kept), v) in enumerate(zip(rows_of, variants)):
            d = np.min(D[np.concatenate([own, kept])], axis=0) - v.pipe_radius
            rss[i] += float(d @ d)
    return rss0, rss


def _reach(moved: Spine, replaced: Spine, pipe_radius: float) -> float:
    """An upper bound of the distance from any point of the segments ``moved`` to the segments ``replaced``: the
    largest distance of points along them a tenth of a pipe radius apart, plus that step (each point of a
    segment lies within half a step of one of them, and a distance moves no faster than its point)."""
    h = 0.1 * pipe_radius
    pts = []
    for k in range(len(moved.kind)):
        s = np.linspace(0.0, 1.0, max(2, int(np.ceil(moved.length[k] / h)) + 1))
        if moved.kind[k] == 0:
            pts.append(moved.start[k] + np.outer(s * moved.length[k], moved.tangent[k]))
        else:
            a = s * moved.angle[k]
            R = moved.radius[k]
            pts.append(moved.centre[k] - R * np.outer(np.cos(a), moved.normal[k])
                       + R * np.outer(np.sin(a), moved.tangent[k]))
    if not pts:
        return 0.0
    return float(segment_distances_t(np.vstack(pts), replaced).min(axis=0).max()) + h


HALO_GAP = 15.0  # gap, in mean sample spacings of the end, that cuts a halo off (exponential gaps: e^-15 ≈ 3e-7)
HALO_DENSITY = 0.25  # a halo is at most this fraction of the end's density along the axis


def _halo_cut(p: np.ndarray) -> float | None:
    """Projection below which the samples are the tube's end, when the outermost of ``p`` (descending) are
    a sparse halo of stray samples beyond it; None when they are not.

    Along a straight the samples are uniform in projection up to the cut end, so the spacing between
    neighbours in projection is exponential with the end's density λ (from the middle half of ``p``). A
    halo is an outer minority (a quarter of ``p`` at most) that starts with a gap of ``HALO_GAP`` / λ and
    holds fewer samples than ``HALO_DENSITY`` times the end's density would over its span. Both are in
    units of the sample spacing, so the rule does not depend on the scan's density (a fixed neighbour
    count does: in a dense scan every stray within reach of the end has company)."""
    n = len(p)
    if n < 20:
        return None
    iqr = p[n // 4] - p[3 * n // 4]
    if iqr <= 0:
        return None
    lam = (3 * n // 4 - n // 4) / iqr
    gaps = p[:n // 4] - p[1:n // 4 + 1]
    k = np.arange(1, len(gaps) + 1)  # samples outside the gap after p[k - 1]
    halo = (gaps > HALO_GAP / lam) & (k < HALO_DENSITY * lam * (p[0] - p[1:n // 4 + 1]))
    if not halo.any():
        return None
    return float(p[np.flatnonzero(halo)[-1] + 1])


def _robust_max(proj: np.ndarray, pts: np.ndarray, rp: float, rows: np.ndarray | None = None) -> float:
    """Largest projection among samples that have company: an isolated stray sample just
    beyond a tube end must not lengthen the tube (≥ 3 neighbours within 0.5 r), nor a sparse
    halo of them (:func:`_halo_cut`), which in a dense scan has company from the end itself.
    ``rows``: the rows of ``pts`` whose projections ``proj`` holds (default all, in order).

    A halo cut leaves the samples at most the cut (whose largest projection is the cut itself), and the rule
    starts again on them: they are kept as a mask of ``proj`` rather than copies of ``proj`` and ``pts`` (a
    dense scan's end holds millions of samples), the candidates found in the same order as in such copies."""
    if len(proj) == 0:
        return 0.0
    top = proj.max()
    body = None  # the samples left by the halo cuts (None: all)
    while True:
        zone = proj >= top - 3.0 * rp
        if body is not None:
            zone &= body
        cand = np.flatnonzero(zone)
        if len(cand) > 2000:  # dense scans: the 2000 outermost samples decide
            cand = cand[np.argpartition(-proj[cand], 2000)[:2000]]
        cut = _halo_cut(np.sort(proj[cand])[::-1])
        if cut is None:
            break
        body = np.less_equal(proj, cut, out=body)  # (each cut lies below the last: the samples at most it)
        top = cut
    if len(cand) > 4:
        # the outermost candidates first, a few at a time: the first with company is the answer, and it is
        # nearly always among the first few (counts by brute force: no tree of all candidates per call)
        cand = cand[np.argsort(-proj[cand], kind="stable")]
        q = np.take(pts, cand if rows is None else rows[cand], axis=0)
        r2 = (0.5 * rp) ** 2
        a = 0
        for size in itertools.chain((4, 28), itertools.repeat(32)):  # the first 4, then 32 at a time
            if a >= len(cand):
                break
            diff = q[a:a + size, None, :] - q[None, :, :]
            cnt = np.count_nonzero(np.einsum("ijk,ijk->ij", diff, diff) <= r2, axis=1)
            dense = np.flatnonzero(cnt >= 4)
            if len(dense):
                return float(proj[cand[a + dense[0]]])
            a += size
    return float(np.percentile(proj if body is None else proj[body], 99.5))


def set_end_lengths(model: TubeModel, pts: np.ndarray, seg: np.ndarray, keep: np.ndarray | None = None) -> TubeModel:
    """First/last straight lengths from the extent of their samples (those ``keep`` marks, when given). An end's
    samples are taken as their row numbers, gathered a block at a time for their projections and by the few
    candidates :func:`_robust_max` checks for company (a dense scan's end straight holds millions of samples:
    copies of them were fresh memory of 24 bytes a sample per end and call, their numbers are 8)."""
    m = model.copy()
    rp = max(m.pipe_radius, 1e-12)
    sp = build_spine(model)  # (the copy's own would be built anew)
    last = len(sp.kind) - 1
    t0 = m.frame[:, 0]
    if last == 0:  # straight tube: one line holds both ends
        rows = np.flatnonzero(_on(seg, 0, keep))
        if len(rows):
            proj = _along(pts, rows, m.start, t0)
            hi = _robust_max(proj, pts, rp, rows)
            lo = -_robust_max(-proj, pts, rp, rows)
            m.start = m.start + lo * t0
            m.lengths = np.array([max(hi - lo, 0.0)])
        return m
    first_arc_start = sp.end[0]
    rows = np.flatnonzero(_on(seg, 0, keep))
    L0 = (max(0.0, _robust_max(np.negative(proj := _along(pts, rows, first_arc_start, t0), out=proj), pts, rp, rows))
          if len(rows) else 0.0)
    m.start = first_arc_start - L0 * t0
    lengths = m.lengths.copy()
    lengths[0] = L0
    rows = np.flatnonzero(_on(seg, last, keep))
    if len(rows):
        lengths[-1] = max(0.0, _robust_max(_along(pts, rows, sp.start[last], sp.tangent[last]), pts, rp, rows))
    else:
        lengths[-1] = 0.0
    m.lengths = lengths
    return m


def _along(pts: np.ndarray, rows: np.ndarray, origin: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``(pts[rows] - origin) @ t`` a block of rows at a time (the numbers of the whole product: each block's
    product is the one its rows' copy gave, whose blocks these are): no (n, 3) copy of a large scan's end
    samples."""
    out = np.empty(len(rows))
    buf = np.empty((min(BLOCK + 1, len(rows)), 3))
    for b in _blocks(len(rows)):
        # (mode "clip": rows from np.flatnonzero are in range, and "raise" copies through a buffer of its own)
        part = np.take(pts, rows[b], axis=0, out=buf[:b.stop - b.start], mode="clip")
        np.subtract(part, origin, out=part)
        np.matmul(part, t, out=out[b])
    return out


def _blocks(n: int) -> list[slice]:
    """Slices of ``BLOCK`` samples covering n, a last one of a single sample joined to the one before: a
    product of one row is a dot product in numpy, whose sums can differ in the last bit from the matrix
    product's that the whole array gives."""
    starts = list(range(0, n, BLOCK))
    if len(starts) > 1 and n - starts[-1] == 1:
        starts.pop()
    return [slice(a, b) for a, b in zip(starts, starts[1:] + [n])]


def _on(seg: np.ndarray, k: int, keep: np.ndarray | None) -> np.ndarray:
    sel = seg == k
    if keep is not None:
        sel &= keep
    return sel


def with_end_lengths(model: TubeModel, ends: TubeModel) -> TubeModel:
    """``model`` (a solve's, whose end straights have length 0: they are unbounded lines during it) with the
    end straight lengths of ``ends``, its first arc where it was: the start for :func:`end_lengths`, which
    then moves the ends by what the solve changed instead of growing them from nothing a margin at a time."""
    m = model.copy()
    m.lengths = m.lengths.copy()
    first_arc_start = m.start + m.lengths[0] * m.frame[:, 0]
    m.lengths[0] = ends.lengths[0]
    m.lengths[-1] = ends.lengths[-1]
    m.start = first_arc_start - m.lengths[0] * m.frame[:, 0]
    return m


def near_ends(model: TubeModel, seg: np.ndarray) -> np.ndarray:
    """Indices of the samples ``seg`` puts on the two outer segments at either end (the straight and the
    arc next to it): the ones a change of the end lengths or of the end margin moves (unless the tube
    passes within a few pipe radii of its own end)."""
    S = 2 * model.n_bends + 1
    # (two comparisons, not np.isin: that builds index arrays of the samples' size in 64 bits)
    near = seg <= 1
    near |= seg >= S - 2
    return np.flatnonzero(near)


def assign_for_ends(model: TubeModel, pts: np.ndarray, margin: float):
    """:func:`assign` of the samples to a model with bends, and the :class:`EndAssignment` of its end straights
    from the same distances (for :func:`end_lengths`); a straight tube's assignment and None."""
    if not model.n_bends:
        return *assign(model, pts, margin), None
    ea = EndAssignment(model, pts, margin, full=True)
    return ea.res, ea.seg, ea


def end_lengths(model: TubeModel, pts: np.ndarray, res: np.ndarray, seg: np.ndarray, thr: float, margin: float,
                max_rounds: int = 12, again: EndAssignment | None = None) -> tuple[TubeModel, np.ndarray, np.ndarray, bool]:
    """First/last straight lengths (:func:`set_end_lengths`) from the samples within ``thr`` of the surface,
    re-assigned until the ends stop moving (they grow by at most ``margin`` per assignment). ``res`` and
    ``seg`` are the samples' assignment (:func:`assign`) to ``model``, ``again`` its :class:`EndAssignment`
    when the caller has it. Returns the model, the last assignment and whether the ends settled (then that
    assignment is the returned model's)."""
    rp = model.pipe_radius
    seen = []  # (model, res, seg) of every iteration
    for i in range(max_rounds):
        if i:
            if again is None:
                again = EndAssignment(model, pts, margin) if model.n_bends else (lambda m: assign(m, pts, margin))
            res, seg = again(model)
        m_new = set_end_lengths(model, pts, seg, np.abs(res) <= thr)
        if np.abs(m_new.lengths[[0, -1]] - model.lengths[[0, -1]]).max() <= 1e-3 * rp:
            return model, res, seg, True
        seen.append((model, res, seg))
        if i >= 3:  # only the last two iterations' assignments can be returned (below): no older one is held
            seen[i - 3] = (seen[i - 3][0], None, None)
        if i >= 2 and np.array_equal(model.start, seen[i - 2][0].start) and np.array_equal(model.lengths,
                                                                                         seen[i - 2][0].lengths):
            # the ends swing between two lengths (the outermost samples with company differ by a stray sample
            # within the margin): every further iteration repeats one of the last two, so the outcome of all
            # of them is known
            def at(t: int) -> tuple:
                return seen[i - 2 + (t - (i - 2)) % 2]

            last = max_rounds - 1
            return at(last + 1)[0], at(last)[1], at(last)[2], False
        model = m_new
    return model, res, seg, False


BLOCK = 65_536  # samples per pass of fun and the normal equations (the per-sample temporaries stay in cache)


def _arc_samples(arc: np.ndarray) -> bool | np.ndarray:
    """Which samples of a block ``arc`` marks as on a circle: True when all are, False when none is, else their
    indices (:func:`_sample_distance` takes them; a round's blocks keep theirs)."""
    if not arc.any():
        return False
    return True if arc.all() else np.flatnonzero(arc)


def _sample_distance(q: np.ndarray, gs: np.ndarray, arc: np.ndarray,
                     on_arc: bool | np.ndarray | None = None) -> tuple[np.ndarray, tuple]:
    """Distance of each point to its own (unbounded) line or circle, all samples in one pass, and the terms
    :func:`_sample_gradient` takes on from. Component-major: ``q`` (3, n) the points, ``gs`` (7, n) the
    geometry of each one's segment (columns of :func:`_geometry`'s rows), ``arc`` marks the circles
    (``on_arc``: its :func:`_arc_samples`, when known); every operation then runs over rows of n samples (a
    sample-major (n, 3) array hands numpy loops of 3). In the terms ``arc`` is True or False when every sample
    is on an arc or none is."""
    c, a, R = gs[:3], gs[3:6], gs[6]
    w = q - c
    # the dot products summed in the order of the sample-major einsum they replace, (x + z) + y: the same
    # distances to the last bit
    # (in place into two rows of scratch: a fresh array per product costs more than the product)
    s, t = np.multiply(w[0], a[0]), np.multiply(w[2], a[2])
    s += t
    s += np.multiply(w[1], a[1], out=t)
    perp = np.multiply(s, a)
    np.subtract(w, perp, out=perp)
    rho = np.multiply(perp[0], perp[0])
    rho += np.multiply(perp[2], perp[2], out=t)
    rho += np.multiply(perp[1], perp[1], out=t)
    np.sqrt(rho, out=rho)
    # a line's R is 0 and its distance the perpendicular one; np.hypot (the arcs') costs some 20 times a
    # product, so it runs on the arcs' samples only
    # the samples are sorted by segment, so most blocks hold lines only or arcs only: those need no selection
    if on_arc is None:
        on_arc = _arc_samples(arc)
    if on_arc is True:
        dd = np.hypot(rho - R, s)
        return dd, (w, s, perp, rho, a, R, dd, True)
    if on_arc is False:
        return rho, (w, s, perp, rho, a, R, rho, False)
    dd = rho.copy()
    dd[on_arc] = np.hypot(rho.take(on_arc) - R.take(on_arc), s.take(on_arc))
    return dd, (w, s, perp, rho, a, R, dd, arc)


def _sample_gradient(terms: tuple, out: np.ndarray) -> None:
    """d dist / d geometry into the rows 0-6 of ``out`` (k, n) from the terms of :func:`_sample_distance`
    (the formulas of :func:`_run_gradient`, a line's as an arc's with (rho - R) / dist = 1 and s / dist = 0)."""
    w, s, perp, rho, a, R, dd, arc = terms
    e = perp / np.maximum(rho, 1e-300)
    if arc is False:  # lines only: u = 1, v = 0 (the same numbers but for the sign of a zero)
        np.negative(e, out=out[:3])
        # (-s) e is -(s e) to the bit (rounding is symmetric about zero): one pass over the strided rows, not two
        np.multiply(np.negative(s), e, out=out[3:6])
        out[6] = 0.0
        return
    inv = 1.0 / np.maximum(dd, 1e-300)
    if arc is True:  # arcs only
        u, v = (rho - R) * inv, s * inv
    else:
        u = np.where(arc, (rho - R) * inv, 1.0)
        v = np.where(arc, s * inv, 0.0)
    # -(u e + v a) and v w - (u s) e through two scratch arrays of three rows (each a fresh array per product
    # and a copy into the strided ``out`` cost more than the products)
    ue, va = np.multiply(u, e), np.multiply(v, a)
    np.negative(np.add(ue, va, out=ue), out=out[:3])
    np.multiply(u * s, e, out=ue)
    np.subtract(np.multiply(v, w, out=va), ue, out=out[3:6])
    out[6] = np.where(arc, -u, 0.0) if arc is not True else -u


def _problem(model: TubeModel, pts: np.ndarray, seg: np.ndarray, lay: Layout, keep: np.ndarray | None = None,
             f_scale: float | None = None, max_nfev: int | None = None):
    """Start vector, bounds, residual and Jacobian functions of one round with a fixed assignment; with ``keep``
    (a mask) of the samples it marks, as if given ``pts[keep]`` and ``seg[keep]``. With ``f_scale`` (the soft-L1
    scale :func:`levenberg_marquardt` weights by) a large scan (more than one block) also gets its cost function,
    which sums the normal equations at the same point, one pass over the samples instead of two, and keeps no
    array of their size; ``max_nfev``: the solver's evaluation limit (the last evaluation sums none). Returns
    x0, lo, hi, fun, normal_equations, frame0, rp and that cost function (None for a small scan)."""
    frame0 = model.frame.copy()
    rp = model.pipe_radius
    x0 = pack(model, lay)
    lo, hi = bounds(lay, rp)
    pad_lo = np.where(np.isfinite(lo), 1e-9 * (np.abs(lo) + 1), 0.0)
    pad_hi = np.where(np.isfinite(hi), 1e-9 * (np.abs(hi) + 1), 0.0)
    x0 = np.clip(x0, lo + pad_lo, hi - pad_hi)
    # the first/last segments are unbounded lines, middle ones unbounded too (fixed assignment); lines and
    # arcs alternate
    kind = np.arange(2 * lay.n + 1) % 2
    scale = max(rp, 1e-9)
    # samples sorted by their (fixed) segment: each segment's samples are runs of a block, whose
    # Gram matrix is one product; the residual order is irrelevant to the solver
    # (a stable sort of the segment numbers in the smallest integers that hold them: a radix sort)
    small = np.int16 if len(kind) < 2 ** 15 else np.int64
    if len(seg) <= BLOCK:
        if keep is None:
            order = np.argsort(seg.astype(small), kind="stable")
        else:
            rows = np.flatnonzero(keep)
            order = rows[np.argsort(seg[rows].astype(small), kind="stable")]
            del rows
        pts_t = np.empty((3, len(order)))
        for j in range(3):
            np.take(pts[:, j], order, out=pts_t[j])
        seg = seg[order].astype(small)
    else:
        pts_t, seg = _sorted_by_segment(pts, seg, keep, len(kind), small)
    is_arc = kind != 0
    N = pts_t.shape[1]
    blocks = [slice(b0, min(b0 + BLOCK, N)) for b0 in range(0, N, BLOCK)]
    runs = [_groups(seg[b]) for b in blocks]  # each block's segment runs, as slices of the block
    # each block's samples per segment: their geometry is each segment's repeated (the samples are sorted)
    counts = [np.bincount(seg[b], minlength=len(kind)) for b in blocks]
    arcs = [np.repeat(is_arc, c) for c in counts] if len(blocks) == 1 else None  # a large scan's: per pass
    on_arc = [_arc_samples(a) for a in arcs] if arcs is not None else None
    # a block of one segment's samples (nearly every block of a large scan) takes that segment's geometry as one
    # column, broadcast: elementwise operations give the numbers of its repeated copy, without the copy (7 rows
    # of the block's length written and read again per pass)
    alone = [runs_b[0][0] if len(runs_b) == 1 else None for runs_b in runs]

    keep_terms = len(blocks) == 1
    # a large scan's distances cannot all be kept for the normal equations (some 14 numbers a sample), and
    # computing them again costs a third of an LM iteration: with the weights' scale known, its solver takes the
    # cost (``cost``), which sums the normal equations on the way
    streamed = f_scale is not None and not keep_terms
    evaluations = [0]
    latest: dict = {}  # the latest evaluation: the normal equations come at the point fun has just accepted

    plan = jacobian_batch(lay, _steps(len(x0), lay, scale))

    def geometry(x, jacobian: bool = False):
        """The geometry at x, with its Jacobian when asked: a trial the solver rejects (nearly half of them)
        needs the residuals only, and the Jacobian's batch of 2P + 1 models costs several of one. (A row of the
        batch computes what it computes alone, so the geometry is the same numbers either way.)"""
        key = x.tobytes()
        if latest.get("x") != key:
            latest.clear()
            latest.update(x=key, g=geometry_one(x, lay, frame0))
        if jacobian and "dG" not in latest:
            latest["dG"] = geometry_and_jacobian(x, lay, frame0, rp, plan)[1]
        return latest["g"], latest.get("dG")

    def distance(g_t: np.ndarray, i: int, b: slice):
        k = alone[i]
        if k is not None:
            return _sample_distance(pts_t[:, b], g_t[:, k:k + 1], is_arc[k], bool(is_arc[k]))
        if arcs is None:
            return _sample_distance(pts_t[:, b], np.repeat(g_t, counts[i], axis=1), np.repeat(is_arc, counts[i]))
        return _sample_distance(pts_t[:, b], np.repeat(g_t, counts[i], axis=1), arcs[i], on_arc[i])

    def fun(x, out=None):
        """The residuals at x, into ``out`` when given."""
        g, _ = geometry(x)
        g_t = g.T.copy()
        d = np.empty(N) if out is None else out
        terms = []
        r_p = x[-1] if lay.fit_pipe_radius else rp
        evaluations[0] += 1
        for i, b in enumerate(blocks):
            d[b], t = distance(g_t, i, b)
            if keep_terms:
                terms.append(t)
        latest["terms"] = terms if keep_terms else None
        latest["sums"] = None
        d -= r_p
        return d

    def cost(x) -> float:
        """A large scan's soft-L1 cost at x (``_soft_l1``'s number to the last bit), each block's share of the
        normal equations summed while its distances are at hand: no array of the samples' size (its residuals,
        weights and their spares were five, some 40 bytes a sample, each page faulted in by the kernel). The
        weights are elementwise, so a block's are the very numbers ``_soft_l1`` gives over all samples; the
        cost's sum is numpy's pairwise sum over all of them, taken in its own splits (``PairwiseSum``). A
        rejected trial's sums are wasted, a quarter of the evaluations; the last evaluation the solver may make
        (``max_nfev``) sums none, as no normal equations follow it."""
        g, _ = geometry(x)
        g_t = g.T.copy()
        r_p = x[-1] if lay.fit_pipe_radius else rp
        evaluations[0] += 1
        summed = max_nfev is None or evaluations[0] < max_nfev
        sums = _gram_sums(7 + int(lay.fit_pipe_radius), len(kind)) if summed else None
        total = PairwiseSum(N)
        for i, b in enumerate(blocks):
            d_b, t = distance(g_t, i, b)
            rb = np.subtract(d_b, r_p)  # (the distances are terms of the gradient: not in place)
            # in place: the numbers of _soft_l1, (r / f) ** 2, sqrt(1 + z), 2 (sq - 1), 1 / sq
            sq = np.divide(rb, f_scale)
            np.square(sq, out=sq)
            sq += 1.0
            np.sqrt(sq, out=sq)
            part = np.subtract(sq, 1.0)
            part *= 2.0
            total.add(part)
            if summed:
                add_block(sums, i, t, np.divide(1.0, sq, out=sq), rb)
        latest["terms"] = None
        latest["sums"] = sums
        return float(f_scale * f_scale * total.value())

    def add_block(sums, i: int, t: tuple, w: np.ndarray, rb: np.ndarray) -> None:
        """A block's share of the normal equations' per-segment sums, Gᵀ W G and Gᵀ W r."""
        gram, rhs = sums
        # sample-major for the products below (the layout their BLAS calls have always had), written so by
        # the gradient through a transposed view: a transposing copy costs six times the writes
        G = np.empty((len(w), gram.shape[1]))
        _sample_gradient(t, G.T)
        if lay.fit_pipe_radius:
            G[:, 7] = 1.0
        Gw = G * w[:, None]
        if len(blocks) == 1:  # each segment's samples are one run: its sums are the products themselves
            for k, sl in runs[i]:
                np.matmul(G[sl].T, Gw[sl], out=gram[k])
                np.matmul(Gw[sl].T, rb[sl], out=rhs[k])
            return
        for k, sl in runs[i]:
            gram[k] += G[sl].T @ Gw[sl]
            rhs[k] += Gw[sl].T @ rb[sl]

    def normal_equations(x, w, r):
        """Jᵀ W J and Jᵀ W r without the (N, P) Jacobian J. A sample's row of J is its distance gradient
        with respect to its segment's geometry (7 numbers, and -1 for the pipe radius) times that
        segment's geometry Jacobian D_k (7 × P), so every segment's samples add D_kᵀ (Gᵀ W G) D_k with
        G their (n, 7) gradients: a 7 × 7 product per sample instead of a P × P one."""
        # the geometry and the distances' terms at x, as fun has just computed them (the same numbers again)
        g, dG = geometry(x, jacobian=True)
        terms = latest.get("terms")
        P = len(x)
        if lay.fit_pipe_radius:  # the constant -1 of the pipe radius as an 8th geometry gradient
            last = np.zeros((len(dG), 1, P))
            last[:, 0, -1] = -1.0
            dG = np.concatenate([dG, last], axis=1)
        sums = latest.get("sums")
        if sums is None:  # (streamed: cost has summed them at x with its weights)
            sums = _gram_sums(dG.shape[1], len(dG))
            g_t = g.T.copy() if terms is None else None
            for i, b in enumerate(blocks):
                add_block(sums, i, terms[i] if terms is not None else distance(g_t, i, b)[1], w[b], r[b])
        gram, rhs = sums
        D = dG.reshape(-1, P)
        return D.T @ np.matmul(gram, dG).reshape(-1, P), D.T @ rhs.reshape(-1)

    return x0, lo, hi, fun, normal_equations, frame0, rp, (cost if streamed else None)


def _sorted_by_segment(pts: np.ndarray, seg: np.ndarray, keep: np.ndarray | None, n_segments: int,
                       small: type) -> tuple[np.ndarray, np.ndarray]:
    """The samples ``keep`` marks (all without it) sorted by their segment, ties in sample order, as (3, n)
    component-major points and their sorted segment numbers: the order and numbers of a stable argsort of
    ``seg[keep]``. For a large scan: the samples a block at a time, each block's sorted by segment and its
    runs written where their segment's samples go (a counting sort: no order of the scan's size, nor the
    radix sort's buffer of that size beside it, 16 bytes a sample at the final round's peak), the left-out
    samples sorting last under a segment number of their own. Fresh memory of a scan's size costs the kernel
    a page fault per page, some 5 % of a 10 M-sample solve per such array."""
    key = seg.astype(small)
    if keep is not None:
        np.copyto(key, n_segments, where=~keep)
    # (bincount casts its input to 64 bits: a block at a time)
    per_block = [np.bincount(key[b], minlength=n_segments + 1)[:n_segments] for b in _blocks(len(key))]
    counts = sum(per_block)
    fill = np.concatenate([[0], np.cumsum(counts)[:-1]])  # where each segment's next sample goes
    pts_t = np.empty((3, int(counts.sum())))
    for b, n_b in zip(_blocks(len(key)), per_block):
        order = np.argsort(key[b], kind="stable")[:int(n_b.sum())]
        rows = np.take(pts[b], order, axis=0)
        at = 0
        for k in np.flatnonzero(n_b):
            pts_t[:, fill[k]:fill[k] + n_b[k]] = rows[at:at + n_b[k]].T
            fill[k] += n_b[k]
            at += n_b[k]
    return pts_t, np.repeat(np.arange(n_segments, dtype=small), counts)


def _gram_sums(k_dim: int, n_segments: int) -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((n_segments, k_dim, k_dim)), np.zeros((n_segments, k_dim))


class PairwiseSum:
    """``np.sum`` of ``n`` numbers handed over a part at a time, to the last bit, holding at most a leaf of them.

    numpy sums a contiguous float array pairwise: a range of more than 8 × 16 numbers splits at half its length
    rounded down to a multiple of 8, the halves summed alike and added. The ranges of at most ``leaf`` numbers
    are summed by numpy itself (``np.add.reduce`` from 0.0: the same splits from there on), the rest of the
    tree here, in its order."""

    def __init__(self, n: int, leaf: int = BLOCK):
        self.tree = self._split(n, leaf)
        self.sizes = list(self._leaves(self.tree))
        self.sums: list[float] = []
        self.parts: list[np.ndarray] = []  # numbers handed over, not yet summed
        self.held = 0

    @classmethod
    def _split(cls, n: int, leaf: int):
        if n <= leaf:
            return n
        half = n // 2
        half -= half % 8
        return (cls._split(half, leaf), cls._split(n - half, leaf))

    @classmethod
    def _leaves(cls, tree):
        if isinstance(tree, int):
            yield tree
        else:
            for sub in tree:
                yield from cls._leaves(sub)

    def add(self, part: np.ndarray) -> None:
        """The next numbers, in their order."""
        self.parts.append(part)
        self.held += len(part)
        while len(self.sums) < len(self.sizes) and self.held >= self.sizes[len(self.sums)]:
            size = self.sizes[len(self.sums)]
            numbers = np.concatenate(self.parts) if len(self.parts) > 1 else self.parts[0]
            self.sums.append(float(np.add.reduce(numbers[:size], initial=0.0)))
            rest = numbers[size:]
            self.parts, self.held = ([rest] if len(rest) else []), len(rest)

    def value(self) -> float:
        """The sum of all ``n`` numbers (all handed over)."""
        if len(self.sums) != len(self.sizes):
            raise ValueError(f"{sum(self.sizes[len(self.sums):]) - self.held} numbers not handed over")
        leaves = iter(self.sums)

        def total(tree) -> float:
            return next(leaves) if isinstance(tree, int) else total(tree[0]) + total(tree[1])

        return total(self.tree)


def solve_lm(model: TubeModel, pts: np.ndarray, seg: np.ndarray, lay: Layout, f_scale: float,
             max_nfev: int = 60, tick=None, keep: np.ndarray | None = None) -> tuple[TubeModel, dict]:
    """One least-squares round with a fixed sample-to-segment assignment (of the samples ``keep`` marks, when
    given)."""
    x0, lo, hi, fun, normal_equations, frame0, rp, cost = _problem(model, pts, seg, lay, keep, f_scale, max_nfev)
    x, info = levenberg_marquardt(fun, normal_equations, x0, lo, hi, f_scale, max_nfev, tick=tick, cost=cost)
    m = unpack(x, lay, frame0, rp)
    return m, info


def parameter_sigmas(model: TubeModel, pts: np.ndarray, seg: np.ndarray, lay: Layout,
                     keep: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Standard deviations of the LRA parameters at the solution (§6's least squares, linearised): the
    covariance s^2 (J^T J)^+ with s^2 = RSS / (N - P) from the residuals of the given (inlier) samples.
    Returns arrays 'lengths' (inner straights, n - 1), 'rotations' (n - 1), 'angles' (n, radians) and
    'radii' (n; a shared radius gives every bend its sigma, a held one 0). ``keep``: as :func:`solve_lm`'s."""
    x0, _, _, fun, normal_equations, _, _, _ = _problem(model, pts, seg, lay, keep)
    r = fun(x0)
    # unit weights as a view of one number (a large scan's array of ones was fresh memory of its size)
    A, _ = normal_equations(x0, np.broadcast_to(1.0, r.shape), r)
    N, P = len(r), len(x0)
    s2 = float(r @ r) / max(N - P, 1)
    cov = s2 * np.linalg.pinv(A)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    n = lay.n
    i = 6
    out = {"lengths": sd[i:i + n - 1] if n > 1 else np.zeros(0)}
    i += max(n - 1, 0)
    out["rotations"] = sd[i:i + n - 1] if n > 1 else np.zeros(0)
    i += max(n - 1, 0)
    out["angles"] = sd[i:i + n]
    i += n
    k = lay.n_radii
    rad = sd[i:i + k]
    if lay.radius_mode == "free":
        out["radii"] = rad
    elif lay.radius_mode == "common":
        out["radii"] = np.full(n, rad[0] if k else 0.0)
    elif lay.radius_mode == "dies":
        out["radii"] = rad[np.asarray(lay.dies, dtype=int)]
    else:
        out["radii"] = np.zeros(n)
    return out


def _soft_l1(r: np.ndarray, f: float, out: np.ndarray | None = None,
             scratch: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """Cost Σ f²·2(√(1+z) − 1), z = (r/f)², and the IRLS weights ρ'(z) = 1/√(1+z) (into ``out``, with
    ``scratch`` for √(1+z), when given: arrays of the samples' size, reused)."""
    # in place: the same numbers as (r / f) ** 2, sqrt(1 + z), 2 (sq - 1), 1 / sq
    sq = np.divide(r, f, out=scratch)
    np.square(sq, out=sq)
    sq += 1.0
    np.sqrt(sq, out=sq)
    terms = np.subtract(sq, 1.0, out=out)
    terms *= 2.0
    cost = float(f * f * np.sum(terms))
    np.divide(1.0, sq, out=terms)
    return cost, terms


def levenberg_marquardt(fun, normal_equations, x0, lo, hi, f_scale, max_nfev=60, tol=1e-10, tick=None, cost=None):
    """Bounded, robust Levenberg–Marquardt on the normal equations (see module doc):
    ``normal_equations(x, w, r)`` gives Jᵀ W J and Jᵀ W r for the sample weights w and residuals r.

    ``tick()`` is called once per iteration (progress / cancellation). ``fun(x, out)`` writes the residuals
    into ``out`` when it is an array: a trial's residuals and weights go into the arrays of the last rejected
    trial or the last replaced point. ``cost(x)``, when given, is the soft-L1 cost at x in place of ``fun`` and
    ``_soft_l1`` (a large scan's: ``normal_equations`` then takes its sums, and no residuals or weights)."""
    x = x0.copy()
    streamed = cost is not None
    cost_at = cost
    if streamed:
        cost, r, w = cost_at(x), None, None
    else:
        r = fun(x, out=None)
        scratch = np.empty_like(r)
        cost, w = _soft_l1(r, f_scale, scratch=scratch)
    spare_r = spare_w = None
    lam = 1e-3
    nfev, status = 1, 0
    it = 0
    last_rel = np.inf
    width = hi - lo
    bounded = np.isfinite(width)
    while nfev < max_nfev:
        it += 1
        if tick is not None:
            tick()
        A, g = normal_equations(x, w, r)
        diag = np.diag(A)
        dg = np.maximum(diag, 1e-12 * (np.max(diag) + 1e-300))
        # active set: a parameter on its bound whose descent direction points outward stays
        # there (a zero-length straight, say); clipping its step instead stalls the iteration
        span = np.where(bounded, width, np.abs(x) + 1.0)
        at_lo = (x <= lo + 1e-9 * span) & (g > 0)
        at_hi = (x >= hi - 1e-9 * span) & (g < 0)
        free = ~(at_lo | at_hi)
        # no parameter held (most iterations): the whole system, without the copies that select its free part
        all_free = bool(free.all())
        Af, dgf, rhs = (A, dg, -g) if all_free else (A[np.ix_(free, free)], dg[free], -g[free])
        improved = False
        while nfev < max_nfev:
            try:
                solved = np.linalg.solve(Af + lam * np.diag(dgf), rhs)
                if all_free:
                    step = solved
                else:
                    step = np.zeros_like(x)
                    step[free] = solved
            except np.linalg.LinAlgError:
                lam *= 10
                if lam > 1e12:
                    break
                continue
            xn = np.clip(x + step, lo, hi)
            nfev += 1
            if streamed:
                cn, rn, wn = cost_at(xn), None, None
            else:
                rn = fun(xn, out=spare_r)
                cn, wn = _soft_l1(rn, f_scale, out=spare_w, scratch=scratch)
            spare_r, spare_w = rn, wn  # a rejected trial's arrays take the next one
            if np.isfinite(cn) and cn <= cost:
                dcost = cost - cn
                last_rel = dcost / max(cost, 1e-300)
                small_step = np.all(np.abs(xn - x) <= tol * (np.abs(x) + 1e-3) * 1e3)
                spare_r, spare_w = r, w  # the point left behind
                x, r, w = xn, rn, wn
                lam = max(lam / 5, 1e-12)
                improved = True
                if dcost <= tol * max(cost, 1e-300) * 1e3 or small_step:
                    status = 2
                cost = cn
                break
            lam *= 4
            if lam > 1e12:
                status = 3  # no descent direction left: at a (local) minimum
                break
        if status or not improved:
            status = status or 3
            break
    return x, {"iterations": it, "nfev": nfev, "status": status, "success": status > 0, "cost": cost,
               "last_relative_decrease": float(last_rel) if np.isfinite(last_rel) else None}
