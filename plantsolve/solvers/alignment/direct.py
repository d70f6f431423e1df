"""The direct method (not in the paper): rotation averaging, then a joint constrained Gauss-Newton.

Stage 1 — rotation averaging (:func:`solve_rotations`): every free component gets a
rotation; each connection asks for opposite port directions (two equations in the tangent
plane of the port). Gauss-Newton on the rotation increments, each step an
equality-constrained weighted least squares that keeps the rotations as close as possible to
the measured ones (pipes stiffer than fittings, long pipes stiffer than short, tie-ins are
constants). Fitting port angles stay catalogue-exact because fittings only rotate rigidly.

Stage 2 — joint solve (:func:`solve_joint`): one could fix these rotations and solve the
then-linear positions once, but on loops the averaged rotations leave a small
twist and that linear problem is infeasible (measured: 0.11 mm gaps on a 4-elbow ring). So
stage 1 is only the start: Gauss-Newton over all poses and pipe lengths together, every
connection an exact constraint, each step one sparse KKT solve (:mod:`kkt`). The cost keeps
pipe axes where they were measured (perpendicular movement of pipe ends is expensive,
sliding along the axis cheap) and fittings near their placement; minimum pipe lengths are
enforced by an active set. Constraint residuals are evaluated in extended precision in a
centred frame, so the closure is exact to the last digit.

A connection that cannot be closed (conflicting tie-ins, catalogue angles that do not fit a
loop) shows up as the residual left by :func:`constrained_lstsq`; the caller cuts it.
"""

from __future__ import annotations

import contextlib
import copy
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from plantsolve.solvers.alignment.dualquat import minimal_rotation, qmul, qrotate
from plantsolve.solvers.alignment.kkt import constrained_lstsq, regularised_factor, use_schur
from plantsolve.solvers.alignment.model import Model, collinear_fittings
from plantsolve.solvers.geometry import quaternion_to_rotvec, rotvec_to_quaternion


@dataclass
class Pose:
    """Solver state shared by both methods: per-component rotation and per-port geometry."""

    q: np.ndarray  # [n, 4] rotation of each component relative to its input pose
    P: np.ndarray  # [np, 3] longdouble port positions in the centred frame
    D: np.ndarray  # [np, 3] unit port directions
    iterations: int
    state: JointState | None = None  # the joint stage's variables (a continuation starts from them)


def _weights(model: Model, stiffness: float) -> tuple[np.ndarray, np.ndarray]:
    """Translational and rotational weight of each component (paper Remark 2, §3 items 5-6)."""
    rel = model.size / model.lref
    w = np.where(model.is_pipe, stiffness * rel, rel)
    return w, w * rel**2


def connection_basis(ua: np.ndarray, ub: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tangent basis of each connection's common axis ``(ua - ub) / |ua - ub|`` (``ua`` where the two point the
    same way): the direction constraint is written in it. Swapping a connection's ends negates the axis, hence the
    first basis vector and its constraint row exactly (IEEE negation), and keeps the second: the system is the
    same up to the sign of rows, so the answer does not depend on which end a request names first."""
    w = ua - ub
    size = np.linalg.norm(w, axis=1, keepdims=True)
    w = np.where(size > 1e-3, w / np.where(size > 0, size, 1.0), ua)
    return _tangent_basis(w)


def _tangent_basis(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.where(np.abs(u[:, :1]) < 0.6, np.array([1.0, 0, 0]), np.array([0.0, 1, 0]))
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(u, e1)


def _variables(mask: np.ndarray, width: int) -> np.ndarray:
    var = np.full(len(mask), -1)
    var[mask] = np.arange(int(mask.sum())) * width
    return var


def solve_rotations(model: Model, active: np.ndarray, stiffness: float, max_gn: int = 30,
                    budget: int = 10**9, step=None) -> tuple[np.ndarray, int]:
    """Rotation of every component such that connected port directions are opposite; ``step(message)`` is
    called at every Gauss-Newton step (progress and cancellation)."""
    n = model.n_comp
    free = ~model.fixed
    var = _variables(free, 3)
    nv = 3 * int(free.sum())
    _, w_rot = _weights(model, stiffness)
    q = np.tile([1.0, 0, 0, 0], (n, 1))
    a, b = model.conn_a[active], model.conn_b[active]
    ca, cb = model.port_comp[a], model.port_comp[b]
    keep = free[ca] | free[cb]
    a, b, ca, cb = a[keep], b[keep], ca[keep], cb[keep]
    m = len(a)
    hdiag = np.repeat(w_rot[free], 3)
    H = sp.diags(hdiag, format="csc")
    steps = 0
    prev = np.inf
    use_cost = True
    best, first = (np.inf, q.copy()), np.inf
    cache: dict = {}  # never reused as a stale preconditioner here ("reuse" unset): it remembers refused LDL^Ts
    owner = _owners(var, free, nv)
    for it in range(max_gn):
        if steps >= budget:
            break
        if step is not None:
            step(f"rotation averaging, Gauss-Newton step {it + 1}")
        D = qrotate(q[model.port_comp], model.D0)
        ua, ub = D[a], D[b]
        r = ua + ub
        err = float(np.max(np.linalg.norm(r, axis=1))) if m else 0.0
        if not err <= max(4.0 * best[0], first) + 1e-12:
            # conflicting directions: Gauss-Newton walks off along the conflict; keep the best pose,
            # whose residual the cut logic reads
            q = best[1]
            break
        if err < best[0]:
            first = err if best[0] == np.inf else first
            best = (err, q.copy())
        if err <= 2e-16 or nv == 0 or (not use_cost and err >= 0.9 * prev):
            break
        if use_cost and err > 0.1 * prev:
            # the first-order cost model pulls against the exact manifold near the solution;
            # from here on take minimum-norm feasibility steps only
            use_cost = False
        prev = err
        e1, e2 = connection_basis(ua, ub)
        rows, cols, vals = [], [], []
        for side_u, side_c in ((ua, ca), (ub, cb)):
            ok = free[side_c]
            for i, e in enumerate((e1, e2)):
                coef = np.cross(side_u, e)[ok]
                rr = 2 * np.flatnonzero(ok) + i
                for j in range(3):
                    rows.append(rr)
                    cols.append(var[side_c[ok]] + j)
                    vals.append(coef[:, j])
        A = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(2 * m, nv)
        )
        rhs = -np.stack([np.einsum("ij,ij->i", e1, r), np.einsum("ij,ij->i", e2, r)], axis=1).ravel()
        # feasibility steps have no gradient: the rotation vectors are only needed with the cost
        g = hdiag * quaternion_to_rotvec(q[free]).ravel() if use_cost else np.zeros(nv)
        x, _, k = constrained_lstsq(H, g, A, lambda x: rhs - A @ x, stop=1e-17, max_iter=min(6, budget - steps),
                                    cache=cache, owner=owner)
        steps += k
        dq = rotvec_to_quaternion(x.reshape(-1, 3))
        q[free] = qmul(dq, q[free])
        q[free] /= np.linalg.norm(q[free], axis=1, keepdims=True)
    _reestablish_up(model, q)
    return q, steps


def _reestablish_up(model: Model, q: np.ndarray) -> None:
    """Roll collinear-port fittings about their axis so the up vector is the projection of the original (§3 item 3)."""
    cand = np.flatnonzero(collinear_fittings(model) & ~np.isnan(model.up[:, 0]) & ~model.fixed)
    if len(cand) == 0:
        return
    axis = qrotate(q[cand], model.D0[model.port_start[cand]])
    up0 = model.up[cand]
    target = up0 - np.einsum("ij,ij->i", up0, axis)[:, None] * axis
    target /= np.linalg.norm(target, axis=1, keepdims=True)
    current = qrotate(q[cand], up0)
    current -= np.einsum("ij,ij->i", current, axis)[:, None] * axis
    current /= np.linalg.norm(current, axis=1, keepdims=True)
    q[cand] = qmul(minimal_rotation(current, target), q[cand])
    q[cand] /= np.linalg.norm(q[cand], axis=1, keepdims=True)


def _skew(v: np.ndarray) -> np.ndarray:
    z = np.zeros(len(v))
    return np.stack([np.stack([z, -v[:, 2], v[:, 1]], -1), np.stack([v[:, 2], z, -v[:, 0]], -1),
                     np.stack([-v[:, 1], v[:, 0], z], -1)], axis=1)


class JointState:
    """Poses of all components: rotation q; fittings translate their port centroid by t;
    pipes are (start point e0 + ds, length L, axis q * u0). Positions are built in longdouble."""

    def __init__(self, model: Model, q: np.ndarray):
        self.m = model
        n = model.n_comp
        self.q = q.copy()
        self.t = np.zeros((n, 3))
        s0 = model.port_start[:-1]
        self.s0 = s0
        counts = np.diff(model.port_start)
        cent = np.zeros((n, 3), dtype=np.longdouble)
        np.add.at(cent, model.port_comp, model.P0)
        self.cent0 = cent / counts[:, None].astype(np.longdouble)
        self.arm0 = (model.P0 - self.cent0[model.port_comp]).astype(float)
        pipes = model.is_pipe
        self.L0 = np.where(pipes, np.linalg.norm((model.P0[np.minimum(s0 + 1, len(model.P0) - 1)] - model.P0[s0]).astype(float), axis=1), 0.0)
        self.L = self.L0.copy()
        self.pipe_port = pipes[model.port_comp]
        self.end1 = self.pipe_port & (model.port_local == 1)
        self.kkt: dict = {}  # solve_joint's KKT cache as its last step left it

    def moved(self, x: np.ndarray, var: np.ndarray, fr: np.ndarray, fits: np.ndarray, pipes: np.ndarray) -> JointState:
        """A copy with the step ``x`` applied (the model's arrays shared)."""
        out = copy.copy(self)
        out.q, out.t, out.L, out.kkt = self.q.copy(), self.t.copy(), self.L.copy(), {}
        _advance(out, x, var, fr, fits, pipes)
        return out

    def geometry(self) -> tuple[np.ndarray, np.ndarray]:
        m = self.m
        pc = m.port_comp
        D = qrotate(self.q[pc], m.D0)
        P = self.cent0[pc] + self.t[pc].astype(np.longdouble) + qrotate(self.q[pc], self.arm0).astype(np.longdouble)
        pp = np.flatnonzero(self.pipe_port)
        c = pc[pp]
        start = m.P0[self.s0[c]] + self.t[c].astype(np.longdouble)
        axis = qrotate(self.q[c], m.D0[self.s0[c] + 1])
        P[pp] = start + np.where(self.end1[pp][:, None], self.L[c][:, None] * axis, 0.0).astype(np.longdouble)
        fx = m.fixed[pc]
        P[fx] = m.P0[fx]
        D[fx] = m.D0[fx]
        return P, D


def _joint_layout(model: Model, active: np.ndarray, stiffness: float):
    """The joint solve's unknowns and weights: each free component's column offset (``var``, 6 columns, a pipe 7),
    their count, the weights, the active connections with a free end (``a``, ``b``), the free pipes and fittings."""
    free = ~model.fixed
    width = np.where(model.is_pipe, 7, 6)
    offs = np.concatenate([[0], np.cumsum(np.where(free, width, 0))])
    var = np.where(free, offs[:-1], -1)
    w, w_rot = _weights(model, stiffness)
    # a rotation by phi moves a component's ports by about size * phi: weigh it in the same length units as
    # the translations, so the answer does not depend on whether the request is in mm, m or inches
    w_rot = w_rot * model.lref**2
    pc = model.port_comp
    a, b = model.conn_a[active], model.conn_b[active]
    keep = free[pc[a]] | free[pc[b]]
    return (free, var, int(offs[-1]), w, w_rot, a[keep], b[keep], np.flatnonzero(model.is_pipe & free),
            np.flatnonzero(~model.is_pipe & free))


def solve_joint(model: Model, active: np.ndarray, q: np.ndarray, stiffness: float, max_gn: int = 25,
                budget: int = 10**9, step=None, feasibility_on_lu: bool = False) -> tuple[JointState, int]:
    """Gauss-Newton over all poses and pipe lengths with exact port constraints (see module doc)."""
    n = model.n_comp
    st = JointState(model, q)
    free, var, nv, w, w_rot, a, b, pipes, fits = _joint_layout(model, active, stiffness)
    w_along = 1e-3
    m_conn = len(a)
    locked = np.zeros(n, dtype=bool)
    steps = 0
    use_cost = True
    prev = np.inf
    stalls = 0
    cache: dict = {}
    pos_scale = model.lref
    sv = np.ones(nv)  # variable scales: radians for rotations, lref for translations and lengths
    fr = np.flatnonzero(free)
    sv[(var[fr][:, None] + 3 + np.arange(3)).ravel()] = model.lref
    pf = np.flatnonzero(free & model.is_pipe)
    sv[var[pf] + 6] = model.lref
    best, first = (np.inf, None), np.inf
    snapped = min(model.snap_pos / pos_scale, float(np.min(model.snap_ang, initial=1.0)))  # relative, as err
    owner = _owners(var, free, nv)
    switched = False  # feasibility steps on the LU have begun
    for it in range(max_gn):
        if step is not None:
            step(f"joint constrained Gauss-Newton, step {it + 1}")
        P, D = st.geometry()
        rp = (P[a] - P[b]).astype(float)
        rd = D[a] + D[b]
        err = max(float(np.max(np.abs(rp))) / pos_scale if m_conn else 0.0,
                  float(np.max(np.abs(rd))) if m_conn else 0.0)
        if not err <= max(4.0 * best[0], first) + 1e-12:
            # inconsistent constraints (conflicting tie-ins): after the least-squares step, Gauss-Newton
            # runs away along the conflict. Return the best pose; its open connections are the conflict.
            st.q, st.t, st.L = best[1]
            break
        if err < best[0]:
            first = err if best[0] == np.inf else first
            best = (err, (st.q.copy(), st.t.copy(), st.L.copy()))
        if steps >= budget:
            break
        short = model.is_pipe & free & (st.L < model.min_length * (1 - 1e-12)) & ~locked
        # 1e-14 relative is where float64 Gauss-Newton ends; what is left is snapped (see Model.snap_pos)
        tight = min(1e-3 * min(model.pos_tol / pos_scale, float(np.min(model.ang_tol, initial=1.0))), 1e-12)
        if nv == 0 or (not np.any(short) and err <= tight):
            break
        # near a singular loop feasibility steps crawl (the residual falls by ~0.9 a step, the Jacobian losing
        # rank at the solution). Once every connection is within what snapping closes, a stall is a step that
        # does not lower the residual at all or is at float64's end, so where the crawl stops is the problem's
        # (round-off or max_gn), not which side of 0.9 a ratio fell on (that moved the point by 2.4e-3 mm with
        # the connections given in another order). Above it (a conflict's plateau) less than 10% is a stall:
        # the pose the cut is chosen on stays the one it was
        crawl = err <= snapped
        if not use_cost and not np.any(short) and (err >= prev or err <= 1e-14 or (not crawl and err >= 0.9 * prev)):
            stalls += 1
            if stalls >= 3:
                break
        else:
            stalls = 0
        if use_cost and err > 0.5 * prev:
            use_cost = False
        prev = err
        locked |= short
        A, rhs = _joint_constraints(model, st, P, D, a, b, rp, rd, var, nv, locked, pos_scale)
        H, g = _joint_cost(model, st, P, var, nv, pipes, fits, w, w_rot, w_along, use_cost)
        on_lu = feasibility_on_lu and not use_cost
        if on_lu and not switched:
            # Only the last factorisation is kept: the first feasibility steps refine on it, as the all-LU path's
            # do on its LU (the Schur solve is refined to the same operator; a fresh LU there instead moved ports by
            # up to 0.64 mm, the crawl's flat directions). The rest (block inverse, analysis, couplings) goes, so
            # nothing of the LDL^T's is held once that factorisation is let go for the LU's (peak memory)
            cache = {key: cache[key] for key in ("lu", "shape") if key in cache}
            switched = True
        cache["reuse"] = not use_cost and not np.any(short)
        # an earlier step's factorisation is refused where its refinement does not contract (kkt._refine), but for the
        # crawl's slow refinement: its steps are the same on either factorisation, which keeps their answers together
        cache["crawl"] = crawl
        # solve in lengths of lref (x = sv * y) and cost / lref^2: every entry O(1) whatever the units
        Hs = scaled_cost(H, sv, model.lref)
        As = (A @ sp.diags(sv)).tocsr()
        del A, H  # only the scaled copies are needed from here (peak memory: never both held into the solve)
        with use_schur(False) if on_lu else contextlib.nullcontext():
            y, _, k = constrained_lstsq(Hs, sv * g / model.lref**2, As, lambda y: rhs - As @ y, stop=1e-20,
                                        max_iter=min(8 if use_cost else 30, budget - steps), cache=cache,
                                        owner=owner)
        Hs = As = None  # else held while the next step builds its own
        x = sv * y
        steps += k
        _advance(st, x, var, fr, fits, pipes)
    _reestablish_up(model, st.q)
    st.kkt = cache  # the last factorisation: a continuation's preconditioner (continue_closing)
    return st, steps


def _advance(st: JointState, x: np.ndarray, var: np.ndarray, fr: np.ndarray, fits: np.ndarray,
             pipes: np.ndarray) -> None:
    """Apply the Gauss-Newton step ``x`` to the joint state in place."""
    om = x[(var[fr][:, None] + np.arange(3))]
    dq = rotvec_to_quaternion(om)
    # fittings rotate about their current port centroid: keep that centroid where the step puts it
    st.q[fr] = qmul(dq, st.q[fr])
    st.q[fr] /= np.linalg.norm(st.q[fr], axis=1, keepdims=True)
    st.t[fits] += x[(var[fits][:, None] + 3 + np.arange(3))]
    st.t[pipes] += x[(var[pipes][:, None] + 3 + np.arange(3))]
    st.L[pipes] += x[var[pipes] + 6]


def _joint_constraints(model: Model, st: JointState, P: np.ndarray, D: np.ndarray, a: np.ndarray, b: np.ndarray,
                       rp: np.ndarray, rd: np.ndarray, var: np.ndarray, nv: int, locked: np.ndarray,
                       pos_scale: float) -> tuple[sp.csr_matrix, np.ndarray]:
    """Linearised connections ``a``-``b`` with position and direction residuals ``rp``, ``rd`` (positions in
    units of ``pos_scale``, directions in the tangent plane) and locked pipe lengths: ``A x = rhs``. Its own
    function, so the port Jacobians it is built from are freed before the KKT solve (peak memory)."""
    n = model.n_comp
    free = ~model.fixed
    pc = model.port_comp
    m_conn = len(a)
    # Jacobians of port position and direction w.r.t. the component variables
    rows, cols, vals = [], [], []

    def put(r, c, v):
        rows.append(r); cols.append(c); vals.append(v)

    Pf = P.astype(float)
    centre = np.zeros((n, 3)); cnt = np.diff(model.port_start)
    np.add.at(centre, pc, Pf); centre /= cnt[:, None]
    fp = np.flatnonzero(free[pc] & ~model.is_pipe[pc])
    arm = Pf[fp] - centre[pc[fp]]
    Sa = -_skew(arm)
    for i in range(3):
        for j in range(3):
            put(3 * fp + i, var[pc[fp]] + j, Sa[:, i, j])
        put(3 * fp + i, var[pc[fp]] + 3 + i, np.ones(len(fp)))
    pp = np.flatnonzero(free[pc] & model.is_pipe[pc])
    c = pc[pp]
    axis = qrotate(st.q[c], model.D0[st.s0[c] + 1])
    is1 = st.end1[pp]
    Su = -_skew(axis) * (st.L[c] * is1)[:, None, None]
    for i in range(3):
        for j in range(3):
            put(3 * pp + i, var[c] + j, Su[:, i, j])
        put(3 * pp + i, var[c] + 3 + i, np.ones(len(pp)))
        put(3 * pp + i, var[c] + 6, axis[:, i] * is1)
    Jp = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * len(pc), nv))
    rows, cols, vals = [], [], []
    fpp = np.flatnonzero(free[pc])
    Sd = -_skew(D[fpp])
    for i in range(3):
        for j in range(3):
            put(3 * fpp + i, var[pc[fpp]] + j, Sd[:, i, j])
    Jd = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(3 * len(pc), nv))
    ia = (3 * a[:, None] + np.arange(3)).ravel()
    ib = (3 * b[:, None] + np.arange(3)).ravel()
    Apos = (Jp[ia] - Jp[ib]) / pos_scale
    del Jp  # each port Jacobian is as large as what is taken from it
    e1b, e2b = connection_basis(D[a], D[b])
    Jdsum = (Jd[ia] + Jd[ib]).tocsr()
    del Jd
    er = np.repeat(np.arange(2 * m_conn), 3)
    ec = np.tile(np.arange(3), 2 * m_conn) + 3 * np.repeat(np.arange(m_conn), 6)
    E = sp.csr_matrix((np.stack([e1b, e2b], 1).ravel(), (er, ec)), shape=(2 * m_conn, 3 * m_conn))
    Adir = E @ Jdsum
    lk = np.flatnonzero(locked)
    Alen = sp.csr_matrix((np.ones(len(lk)), (np.arange(len(lk)), var[lk] + 6)), shape=(len(lk), nv))
    A = sp.vstack([Apos, Adir, Alen]).tocsr()
    rhs = np.concatenate([
        -rp.ravel() / pos_scale,
        -np.stack([np.einsum("ij,ij->i", e1b, rd), np.einsum("ij,ij->i", e2b, rd)], 1).ravel(),
        model.min_length[lk] - st.L[lk],
    ])
    return A, rhs


def _joint_cost(model: Model, st: JointState, P: np.ndarray, var: np.ndarray, nv: int, pipes: np.ndarray,
                fits: np.ndarray, w: np.ndarray, w_rot: np.ndarray, w_along: float,
                use_cost: bool) -> tuple[sp.csc_matrix, np.ndarray]:
    """Gauss-Newton model of the cost, ``0.5 x'Hx + g'x`` (``g`` zero once only feasibility steps are taken)."""
    free = ~model.fixed
    # cost: rotations, fitting translations, pipe ends (perpendicular stiff, along cheap)
    hr, hc, hv = [], [], []
    g = np.zeros(nv)
    fr = np.flatnonzero(free)
    for j in range(3):
        hr.append(var[fr] + j); hc.append(var[fr] + j); hv.append(2 * w_rot[fr])
        hr.append(var[fits] + 3 + j); hc.append(var[fits] + 3 + j); hv.append(2 * w[fits])
    if use_cost:
        # the gradient only with the cost: feasibility steps (most of a round) skip the rotation vectors and the
        # pipes' gradient products, which are half of this function's time there
        phi = quaternion_to_rotvec(st.q[fr])
        np.add.at(g, (var[fr][:, None] + np.arange(3)).ravel(), (2 * w_rot[fr][:, None] * phi).ravel())
        np.add.at(g, (var[fits][:, None] + 3 + np.arange(3)).ravel(), (2 * w[fits][:, None] * st.t[fits]).ravel())
    if len(pipes):
        u = qrotate(st.q[pipes], model.D0[st.s0[pipes] + 1])
        uu = u[:, :, None] * u[:, None, :]
        M = w[pipes][:, None, None] * (np.eye(3) - uu) + w_along * uu
        B0 = np.zeros((len(pipes), 3, 7)); B0[:, :, 3:6] = np.eye(3)
        B1 = B0.copy(); B1[:, :, 0:3] = -_skew(u) * st.L[pipes][:, None, None]; B1[:, :, 6] = u
        # B0 picks the translation: its term is M in the translation block, exactly what the sum of products
        # over B0's zeros and ones gives, without the generic three-operand einsum (half of this function's time)
        Hp = np.einsum("kia,kij,kjb->kab", B1, M, B1)
        Hp[:, 3:6, 3:6] += M
        Hp *= 2
        for i in range(7):
            for j in range(7):
                hr.append(var[pipes] + i); hc.append(var[pipes] + j); hv.append(Hp[:, i, j])
        if use_cost:
            c0 = (P[st.s0[pipes]] - model.P0[st.s0[pipes]]).astype(float)
            c1 = (P[st.s0[pipes] + 1] - model.P0[st.s0[pipes] + 1]).astype(float)
            gp = 2 * (np.einsum("kia,kij,kj->ka", B0, M, c0) + np.einsum("kia,kij,kj->ka", B1, M, c1))
            np.add.at(g, (var[pipes][:, None] + np.arange(7)).ravel(), gp.ravel())
    H = sp.csc_matrix((np.concatenate(hv), (np.concatenate(hr), np.concatenate(hc))), shape=(nv, nv))
    return H, g


def scaled_cost(H: sp.spmatrix, sv: np.ndarray, lref: float) -> sp.csc_matrix:
    """``diag(sv) H diag(sv) / lref^2`` as CSC, each entry ``(sv_i h_ij) sv_j / lref^2`` and exact zeros dropped: the
    numbers, pattern and order of the two sparse products with the diagonal it replaces, bit for bit, without their
    two copies of H per Gauss-Newton step. Shares H's index arrays where no entry drops out."""
    Hc = sp.csc_matrix(H)  # no copy when it is one
    if not Hc.has_canonical_format:
        Hc = Hc.copy()
        Hc.sum_duplicates()  # sorted rows in every column, duplicates summed, as the products' CSC
    data = sv[Hc.indices]
    data *= Hc.data
    data *= np.repeat(sv, np.diff(Hc.indptr))
    data *= 1.0 / lref**2  # a sparse matrix divided by a number is multiplied by its reciprocal
    Hs = sp.csc_matrix((data, Hc.indices, Hc.indptr), shape=Hc.shape)
    if not np.all(data):
        Hs.indices, Hs.indptr = Hs.indices.copy(), Hs.indptr.copy()  # H's stay as they are
        Hs.eliminate_zeros()
    return Hs


def solve_direct(model: Model, active: np.ndarray, stiffness: float, budget: int = 10**9, step=None,
                 feasibility_on_lu: bool = False) -> Pose:
    """Both stages; ``budget`` caps the Gauss-Newton and refinement steps (the pose reached is returned);
    ``step(message)`` at every step of either. ``feasibility_on_lu``: the joint stage's feasibility steps (those
    after the steps with the cost, the crawl near singular loops among them) solve their KKT systems by the
    pivoted LU (:func:`kkt.use_schur`); the other steps as the caller's context has them."""
    q, k1 = solve_rotations(model, active, stiffness, budget=budget, step=step)
    st, k2 = solve_joint(model, active, q, stiffness, budget=max(budget - k1, 0), step=step,
                         feasibility_on_lu=feasibility_on_lu)
    P, D = st.geometry()
    return Pose(q=st.q, P=P, D=D, iterations=k1 + k2, state=st)


# continue_closing: a round whose largest residual falls by less than this share in each of STALL_STEPS steps, each
# taken as far along its Gauss-Newton direction as lowers the residual most (up to LINE_SEARCH times), cannot close,
# unless that residual is within CONFLICT_MARGIN times the closing tolerance: there only a step that lowers nothing ends
STALL_GAIN = 0.1
STALL_STEPS = 3
LINE_SEARCH = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0)
CONFLICT_MARGIN = 1e3


def continue_closing(model: Model, active: np.ndarray, pose: Pose, stiffness: float, closed, budget: int = 60,
                     step=None) -> tuple[Pose, int]:
    """Carry on from a round's pose with its connections still open: feasibility Gauss-Newton steps on the pivoted LU,
    each followed along its direction as far as lowers the largest residual most (1 to 32 steps' length).

    Near a singular loop the plain steps crawl (the residual falls by ~0.9 a step: the Jacobian loses rank at the
    solution and Gauss-Newton undershoots along the flat direction by a constant factor), and where the round's stall
    rule stopped the crawl was decided by round-off (the shipped ladder: 1.4e-9 of the typical length left, a micrometre
    in a kilometre-sized frame, cut in mm and closed when the same file was re-printed to 6 decimals). A longer step
    along the same direction undoes the undershoot. A conflict's residual is a least-squares residual: no step length
    along any Gauss-Newton direction lowers it, so :data:`STALL_STEPS` steps in a row that each lower it by less than
    :data:`STALL_GAIN` end the continuation, and the caller cuts, but only while the largest residual is more than
    :data:`CONFLICT_MARGIN` times the closing tolerance (``Model.close_pos``, at least 1e-9 of the typical length: so
    at least a micrometre per metre): below that a crawl goes on as long as any step lowers it, within ``budget``.
    Measured: the conflicts of the test and bench families stall 0.2 to 4,000 mm open, 1e5 times the margin and more;
    the ladder's crawl was 4e-6 mm open. ``closed(P, D)`` says when every connection is closed; returns the pose reached
    and the KKT steps taken (at most ``budget``)."""
    st = pose.state
    free, var, nv, w, w_rot, a, b, pipes, fits = _joint_layout(model, active, stiffness)
    fr = np.flatnonzero(free)
    sv = np.ones(nv)
    sv[(var[fr][:, None] + 3 + np.arange(3)).ravel()] = model.lref
    sv[var[pipes] + 6] = model.lref
    owner = _owners(var, free, nv)
    locked = model.is_pipe & free & (st.L <= model.min_length * (1 + 1e-12)) & (model.min_length > 0)
    pos_scale = model.lref
    margin = CONFLICT_MARGIN * model.close_pos / pos_scale  # relative, as err

    def residual(state: JointState):
        P, D = state.geometry()
        rp = (P[a] - P[b]).astype(float)
        rd = D[a] + D[b]
        err = max(float(np.max(np.abs(rp), initial=0.0)) / pos_scale, float(np.max(np.abs(rd), initial=0.0)))
        return P, D, rp, rd, err

    P, D, rp, rd, err = residual(st)
    steps = stalls = 0
    # the round's last factorisation preconditions the first steps (refined on the current system; a fresh one where
    # it does not contract, never the crawl's slow refinement: the continuation is above what snapping closes): a
    # conflict's continuation is then one solve and no factorisation
    cache: dict = {**st.kkt, "reuse": True, "crawl": False}
    st.kkt = {}  # handed over: a fresh factorisation below replaces it, never held beside it (peak memory)
    while steps < budget and nv and len(a) and not closed(P, D):
        if step is not None:
            step(f"continuing a stalled round, step {steps + 1}")
        A, rhs = _joint_constraints(model, st, P, D, a, b, rp, rd, var, nv, locked, pos_scale)
        H, g = _joint_cost(model, st, P, var, nv, pipes, fits, w, w_rot, 1e-3, False)
        Hs, As = scaled_cost(H, sv, model.lref), (A @ sp.diags(sv)).tocsr()
        with use_schur(False):
            y, _, k = constrained_lstsq(Hs, sv * g / model.lref**2, As, lambda y: rhs - As @ y, stop=1e-20,
                                        max_iter=min(30, budget - steps), cache=cache, owner=owner)
        steps += k
        x = sv * y
        best = None
        for alpha in LINE_SEARCH:
            trial = st.moved(alpha * x, var, fr, fits, pipes)
            found = residual(trial)
            if best is not None and found[-1] >= best[1][-1]:
                break
            best = (trial, found)
        if not best[1][-1] < err:
            break  # not even the plain step lowers it: the least-squares residual of a conflict
        stalls = stalls + 1 if best[1][-1] > (1 - STALL_GAIN) * err and best[1][-1] > margin else 0
        st, (P, D, rp, rd, err) = best
        if stalls >= STALL_STEPS:
            break
    st = st.moved(np.zeros(nv), var, fr, fits, pipes)  # a copy: the round's own pose stays as it was
    _reestablish_up(model, st.q)
    P, D = st.geometry()
    return Pose(q=st.q, P=P, D=D, iterations=pose.iterations + steps, state=st), steps


# settle_conflict: each connection's compliance beside the components' placement weights (both in typical lengths)
SETTLE_COMPLIANCE = 1e-2
SETTLE_STEPS = 50  # at most; measured: 3 to 12 on the conflicts of the tests and the bench


def settle_conflict(model: Model, active: np.ndarray, stiffness: float, budget: int = SETTLE_STEPS, step=None,
                    compliance: float = SETTLE_COMPLIANCE, tol: float = 1e-12) -> tuple[Pose, int]:
    """The pose where the network comes to rest with every active connection a spring: the minimiser of the joint
    stage's cost (each component held to where it was measured by its weights) plus the connections' squared
    residuals over ``2 * compliance`` (the rows of the constraints: positions in typical lengths, directions in their
    tangent planes), by Gauss-Newton from the measured pose, each step halved until that sum falls.

    A conflict's round stops on a plateau where Gauss-Newton stopped running off along it, which round-off, the
    factorisation and the order the unknowns are numbered in decide (so the components' names did: the canonical
    order follows them). This minimiser is the network's: the cost leaves it no flat direction and the springs make
    every step a well-conditioned system, so from the same start it is the same to round-off whatever the names, the
    order, the unit, the frame or the factorisation (measured: impacts 1e-10 of the largest apart on five conflict
    grids in each of those variants, where the plateaus' lay 0.3 % to 10 x apart). The springs' compliance decides how
    the conflict's share is spread: 1e-2 of the placement weights lets it gather where the network is stiffest against
    it; much stiffer springs (1e-6, near the constrained limit) spread it evenly over the connections in series, a
    5 % tie among many, which the measured-worst rule broke by cutting off the path. On 360 synthetic conflicts
    (``bench/alignment.py --conflicts``) beside the plateau's choice (1,171 cuts, 15 answers moving a component more
    than 145 mm): 1e-1, 1e-2 and 1e-3 744-750 cuts, none of them folded, 97 answers closer to the request by more
    than 20 mm and none further; 1e-4 752 cuts, 89 closer and one 50 mm further; 1e-6 777 cuts and 46 folded.
    A pipe that would get shorter than its minimum length is held at it from then on, as in the rounds. Ends when a
    step lowers the sum by less than ``tol`` of it, when no step length lowers it or after ``budget`` steps; returns
    the pose and the steps taken."""
    st = JointState(model, np.tile([1.0, 0, 0, 0], (model.n_comp, 1)))
    free, var, nv, w, w_rot, a, b, pipes, fits = _joint_layout(model, active, stiffness)
    fr = np.flatnonzero(free)
    sv = np.ones(nv)
    sv[(var[fr][:, None] + 3 + np.arange(3)).ravel()] = model.lref
    sv[var[pipes] + 6] = model.lref
    locked = np.zeros(model.n_comp, dtype=bool)
    pos_scale = model.lref
    w_along = 1e-3
    owner = _owners(var, free, nv)
    cache: dict = {}  # one ordering and analysis of the complement for the whole sequence

    def energy(state: JointState):
        """Positions, directions, their residuals and the sum minimised (the cost as _joint_cost models it)."""
        P, D = state.geometry()
        rp = (P[a] - P[b]).astype(float)
        rd = D[a] + D[b]
        e1, e2 = connection_basis(D[a], D[b])
        lk = np.flatnonzero(locked)
        springs = (float(np.sum(rp * rp)) / pos_scale**2 + float(np.sum(np.einsum("ij,ij->i", e1, rd) ** 2))
                   + float(np.sum(np.einsum("ij,ij->i", e2, rd) ** 2))
                   + float(np.sum((model.min_length[lk] - state.L[lk]) ** 2)) / pos_scale**2)
        phi = quaternion_to_rotvec(state.q[fr])
        cost = float(np.sum(w_rot[fr] * np.sum(phi * phi, axis=1))) + float(np.sum(w[fits] * np.sum(state.t[fits] ** 2,
                                                                                                     axis=1)))
        if len(pipes):
            u = qrotate(state.q[pipes], model.D0[state.s0[pipes] + 1])
            for end in (0, 1):
                moved = (P[state.s0[pipes] + end] - model.P0[state.s0[pipes] + end]).astype(float)
                along = np.einsum("ij,ij->i", moved, u)
                cost += float(np.sum(w[pipes] * (np.sum(moved * moved, axis=1) - along**2) + w_along * along**2))
        return P, D, rp, rd, cost / pos_scale**2 + springs / (2 * compliance)

    P, D, rp, rd, size = energy(st)
    steps = 0
    while steps < budget and nv and len(a):
        if step is not None:
            step(f"settling a conflict, step {steps + 1}")
        A, rhs = _joint_constraints(model, st, P, D, a, b, rp, rd, var, nv, locked, pos_scale)
        H, g = _joint_cost(model, st, P, var, nv, pipes, fits, w, w_rot, w_along, True)
        Hs, As = scaled_cost(H, sv, model.lref), (A @ sp.diags(sv)).tocsr()
        del A, H
        # the Gauss-Newton step of cost + springs: [[H, A^T], [A, -compliance I]] [y; f] = [-g; rhs], f the springs'
        # forces; quasi-definite and well conditioned, so either factorisation gives it to round-off
        y = regularised_factor(Hs, As, compliance, cache, owner).solve(np.concatenate([-sv * g / model.lref**2,
                                                                                        rhs]))[:nv]
        del Hs, As
        steps += 1
        x = sv * y
        alpha = 1.0
        while alpha >= 2.0**-20:
            trial = st.moved(alpha * x, var, fr, fits, pipes)
            found = energy(trial)
            if found[-1] < size:
                break
            alpha *= 0.5
        else:
            break  # no step length lowers it: its minimum to round-off
        gain = size - found[-1]
        st, (P, D, rp, rd, size) = trial, found
        short = model.is_pipe & free & (st.L < model.min_length * (1 - 1e-12)) & ~locked
        if np.any(short):
            locked |= short
            P, D, rp, rd, size = energy(st)
        elif gain <= tol * (size + gain):
            break
    return Pose(q=st.q, P=P, D=D, iterations=steps, state=st), steps


def _owners(var: np.ndarray, free: np.ndarray, nv: int) -> np.ndarray:
    """The component of each of the ``nv`` variables, where free component ``c``'s run starts at ``var[c]``."""
    starts = var[free]
    order = np.argsort(starts, kind="stable")
    return np.flatnonzero(free)[order][np.searchsorted(starts[order], np.arange(nv), side="right") - 1]
