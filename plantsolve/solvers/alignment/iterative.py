"""The paper's method (§3): alternating mean displacements of PipeRows and FixClusters.

Terms (paper §3):
- *FixCluster*: fittings joined fitting-to-fitting, moved as one rigid body after they were
  optimised in themselves (:func:`_optimise_clusters`).
- *FixGroup*: fittings of a cluster whose joints are already closed; the unit moved while a
  cluster is optimised in itself, so closed joints stay closed.
- *PipeRow*: pipes and fittings with two opposite collinear ports (valves, flanges,
  concentric reducers) chained end to end; straightened once, then moved as one line whose
  pipes stretch (fittings inside keep their length).

Each iteration: (1) every row moves toward the clusters at its ends (mean of the
displacements that put each end port onto its cluster port, then stretching so both ends
meet), (2) every cluster moves toward its rows (mean of the displacements that put each
cluster port onto the row's axis, opposite to the row's end direction). Means are weighted
dual-quaternion means on Study's sphere computed from the previous state for all bodies at
once (order independence, item 1); weights are lengths (Remark 2), tie-ins get an
overwhelming weight and never move. Steps are limited with the screw power q^s, which keeps
the direction of the motion (items 4-6: pipes half of fittings, long rows less); pipe
lengths never drop below the minimum (item 2); valve up vectors are re-established from the
row axis every step (item 3). After each iteration the explosion indicator (largest gap
grown beyond ``explosion_factor`` times the initial one) cuts the connection with the
highest error impact and restarts on the changed topology; the iteration cap returns the
best state seen with all its errors.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from plantsolve.schemas.alignment import AlignmentOptions
from plantsolve.solvers.alignment.cuts import choose_cut
from plantsolve.solvers.alignment.dualquat import (
    IDENTITY, dq_from_rt, dq_mul, dq_pow, dq_weighted_mean, minimal_rotation, qrotate, transform_points,
)
from plantsolve.solvers.alignment.finalize import Outcome
from plantsolve.solvers.alignment.model import Model, collinear_fittings, connection_errors
from plantsolve.solvers.base import Progress
from plantsolve.solvers.stages import Stages

FIXED_WEIGHT = 1e9
# The alternating means converge linearly at best; when the worst error has not dropped by 1 % in
# 300 iterations the run has stalled (a conflict it cannot resolve) and more iterations only cost time.
STALL_GAIN = 0.01
STALL_ITERATIONS = 300


def _components(n: int, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    g = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
    return connected_components(g, directed=False)[1]


class Network:
    """Bodies (rows, clusters) and the per-port state of the alternating iteration."""

    def __init__(self, model: Model, active: np.ndarray):
        self.m = model
        n = model.n_comp
        pc = model.port_comp
        self.row_member = model.is_pipe | collinear_fittings(model)
        ca, cb = pc[model.conn_a[active]], pc[model.conn_b[active]]
        pa, pb = model.conn_a[active], model.conn_b[active]
        rr = self.row_member[ca] & self.row_member[cb]
        cc = ~self.row_member[ca] & ~self.row_member[cb]
        body = np.full(n, -1)
        lab_r = _components(n, ca[rr], cb[rr])
        lab_c = _components(n, ca[cc], cb[cc])
        rows_u, rows_inv = np.unique(lab_r[self.row_member], return_inverse=True)
        body[self.row_member] = rows_inv
        self.n_rows = len(rows_u)
        cl_u, cl_inv = np.unique(lab_c[~self.row_member], return_inverse=True)
        body[~self.row_member] = self.n_rows + cl_inv
        self.n_clusters = len(cl_u)
        self.body = body
        nb = self.n_rows + self.n_clusters
        self.body_fixed = np.zeros(nb, dtype=bool)
        np.logical_or.at(self.body_fixed, body, model.fixed)
        self.body_size = np.bincount(body, model.size, minlength=nb)
        # boundary connections: row port <-> cluster port
        bnd = self.row_member[ca] != self.row_member[cb]
        a_is_row = self.row_member[ca[bnd]]
        self.b_row_port = np.where(a_is_row, pa[bnd], pb[bnd])
        self.b_cl_port = np.where(a_is_row, pb[bnd], pa[bnd])
        self.b_row = body[pc[self.b_row_port]]
        self.b_cl = body[pc[self.b_cl_port]] - self.n_rows
        self.internal_cluster = (pa[cc], pb[cc])
        self._init_rows(pa[rr], pb[rr])
        self.T = np.tile(IDENTITY, (self.n_clusters, 1))  # cluster motions
        self.Pc0 = model.P0.astype(float)  # cluster ports before the cluster motion
        self.Dc0 = model.D0.copy()

    def _init_rows(self, ia: np.ndarray, ib: np.ndarray) -> None:
        """Straighten every PipeRow: one axis, members laid end to end (paper: processed as one)."""
        m = self.m
        pc = m.port_comp
        npt = len(pc)
        partner = np.full(npt, -1)
        partner[ia], partner[ib] = ib, ia
        self.lam_rigid = np.zeros(npt)  # rigid length before the port along the row
        self.lam_pipe = np.zeros(npt)  # stretchable (pipe) length before the port
        self.sign = np.zeros(npt)  # port direction = sign * row axis
        self.o = np.zeros((self.n_rows, 3))
        self.u = np.zeros((self.n_rows, 3))
        self.lamA = np.zeros(self.n_rows)
        self.scale = np.ones(self.n_rows)
        self.pipe_total = np.zeros(self.n_rows)
        self.min_scale = np.zeros(self.n_rows)
        self.row_ports: list[np.ndarray] = []
        members = [[] for _ in range(self.n_rows)]
        for c in np.flatnonzero(self.row_member):
            members[self.body[c]].append(c)
        P0 = m.P0.astype(float)
        for r, mem in enumerate(members):
            # walk the chain from an end (a port whose partner is not in the row)
            ports = np.concatenate([np.arange(m.port_start[c], m.port_start[c + 1]) for c in mem])
            ends = ports[partner[ports] < 0]
            start = int(ends[np.argmin(m.port_rank[ends])]) if len(ends) else int(ports[0])
            order, p = [], start
            seen = set()
            while p >= 0 and pc[p] not in seen:
                c = pc[p]
                seen.add(c)
                q = m.port_start[c] + (1 - m.port_local[p])
                order.append((p, q))
                p = partner[q]
            pts = np.array([P0[x] for pq in order for x in pq])
            w = np.array([m.size[pc[x]] * (10.0 if m.is_pipe[pc[x]] else 1.0) * (FIXED_WEIGHT if m.fixed[pc[x]] else 1.0)
                          for pq in order for x in pq])
            centre = (w[:, None] * pts).sum(0) / w.sum()
            axis = P0[order[-1][1]] - P0[order[0][0]]
            span = np.linalg.norm(axis)
            # a row that closes on itself has no end-to-end span: orient it by its first port instead
            axis = axis / span if span > 0 else -m.D0[order[0][0]]
            X = (pts - centre) * np.sqrt(w)[:, None]
            v = np.linalg.svd(X, full_matrices=False)[2][0]
            axis = v if v @ axis > 0 else -v
            rigid = pipe = 0.0
            lam0 = float((P0[order[0][0]] - centre) @ axis)
            min_scale = 0.0
            for p, q in order:
                c = pc[p]
                length = float(np.linalg.norm(P0[q] - P0[p]))
                self.lam_rigid[p], self.lam_pipe[p], self.sign[p] = rigid, pipe, -1.0
                if m.is_pipe[c]:
                    pipe += length
                    min_scale = max(min_scale, m.min_length[c] / length)
                else:
                    rigid += length
                self.lam_rigid[q], self.lam_pipe[q], self.sign[q] = rigid, pipe, 1.0
            anchor = [x for pq in order for x in pq if m.fixed[pc[x]]]
            if anchor:  # lay the row out from its first tie-in so that tie-in is met exactly
                f = anchor[0]
                lam0 = float((P0[f] - centre) @ axis) - self.lam_rigid[f] - self.lam_pipe[f]
            self.o[r], self.u[r], self.lamA[r] = centre, axis, lam0
            self.pipe_total[r] = pipe
            self.min_scale[r] = min_scale
            self.row_ports.append(np.array([x for pq in order for x in pq]))
        self.row_of_port = np.full(npt, -1)
        rm = self.row_member[pc]
        self.row_of_port[rm] = self.body[pc[rm]]
        # tie-in rows keep their measured geometry: their ports are read from the model
        self.fixed_row_port = rm & m.fixed[pc]

    # ---- geometry -------------------------------------------------------------------
    def ports(self) -> tuple[np.ndarray, np.ndarray]:
        m = self.m
        pc = m.port_comp
        P = np.empty((len(pc), 3))
        D = np.empty((len(pc), 3))
        rm = self.row_of_port >= 0
        r = self.row_of_port[rm]
        lam = self.lamA[r] + self.lam_rigid[rm] + self.lam_pipe[rm] * self.scale[r]
        P[rm] = self.o[r] + lam[:, None] * self.u[r]
        D[rm] = self.sign[rm][:, None] * self.u[r]
        cm = ~rm
        cl = self.body[pc[cm]] - self.n_rows
        P[cm] = transform_points(self.T[cl], self.Pc0[cm])
        D[cm] = qrotate(self.T[cl][:, :4], self.Dc0[cm])
        fr = self.fixed_row_port
        P[fr] = m.P0[fr].astype(float)
        D[fr] = m.D0[fr]
        return P, D

    # ---- the two half steps ---------------------------------------------------------
    def _limit(self, T: np.ndarray, moving_pts: np.ndarray, owner: np.ndarray, limit: np.ndarray) -> np.ndarray:
        move = np.linalg.norm(transform_points(T[owner], moving_pts) - moving_pts, axis=1)
        worst = np.zeros(len(T))
        np.maximum.at(worst, owner, move)
        s = np.where(worst > limit, limit / np.maximum(worst, 1e-300), 1.0)
        out = T.copy()
        lim = s < 1.0
        if np.any(lim):
            out[lim] = dq_pow(T[lim], s[lim])
        return out

    def step_rows(self, P: np.ndarray, D: np.ndarray, lim_pipe: float) -> None:
        if len(self.b_row) == 0:
            return
        rp, cp = self.b_row_port, self.b_cl_port
        rho = minimal_rotation(D[rp], -D[cp])
        t = P[cp] - qrotate(rho, P[rp])
        dq = dq_from_rt(rho, t)
        w = self.body_size[self.n_rows + self.b_cl] * np.where(self.body_fixed[self.n_rows + self.b_cl], FIXED_WEIGHT, 1.0)
        T = dq_weighted_mean(dq, w, self.b_row, self.n_rows)
        row_len = self.body_size[: self.n_rows]
        limit = lim_pipe * np.minimum(1.0, self.m.lref / np.maximum(row_len, 1e-300))
        rm = np.flatnonzero(self.row_of_port >= 0)
        T = self._limit(T, P[rm], self.row_of_port[rm], limit)
        T[self.body_fixed[: self.n_rows]] = IDENTITY
        self.o = transform_points(T, self.o)
        self.u = qrotate(T[:, :4], self.u)
        self.u /= np.linalg.norm(self.u, axis=1, keepdims=True)
        # stretch: both ends onto the projections of their cluster ports
        desired = np.einsum("ij,ij->i", P[cp] - self.o[self.b_row], self.u[self.b_row])
        r = self.b_row
        k_lo = np.full(self.n_rows, -1); k_hi = np.full(self.n_rows, -1)
        key = self.lam_rigid[rp] + self.lam_pipe[rp]
        order = np.argsort(key, kind="stable")
        k_hi[r[order]] = order  # last write wins: largest key
        k_lo[r[order[::-1]]] = order[::-1]
        both = (k_lo >= 0) & (k_hi >= 0) & (k_lo != k_hi) & (self.pipe_total > 0) & ~self.body_fixed[: self.n_rows]
        lamA_new = self.lamA.copy()
        scale_new = self.scale.copy()
        if np.any(both):
            lo, hi = k_lo[both], k_hi[both]
            dc = self.lam_pipe[rp[hi]] - self.lam_pipe[rp[lo]]
            s_new = (desired[hi] - desired[lo] - (self.lam_rigid[rp[hi]] - self.lam_rigid[rp[lo]])) / np.where(dc > 0, dc, 1.0)
            s_new = np.where(dc > 0, s_new, self.scale[both])
            ds = np.clip(s_new - self.scale[both], -lim_pipe / np.maximum(self.pipe_total[both], 1e-300),
                         lim_pipe / np.maximum(self.pipe_total[both], 1e-300))
            scale_new[both] = np.maximum(self.scale[both] + ds, self.min_scale[both])
        one = (k_lo >= 0) & ~self.body_fixed[: self.n_rows]
        kk = k_lo[one]
        lam_now = self.lamA[one] + self.lam_rigid[rp[kk]] + self.lam_pipe[rp[kk]] * scale_new[one]
        lamA_new[one] = self.lamA[one] + np.clip(desired[kk] - lam_now, -lim_pipe, lim_pipe)
        self.lamA, self.scale = lamA_new, scale_new

    def step_clusters(self, P: np.ndarray, D: np.ndarray, lim_fit: float) -> None:
        if len(self.b_cl) == 0:
            return
        rp, cp = self.b_row_port, self.b_cl_port
        r = self.b_row
        o, u = self.o[r], self.u[r]
        stretch = (self.pipe_total[r] > 0) & ~self.body_fixed[r]
        proj = o + np.einsum("ij,ij->i", P[cp] - o, u)[:, None] * u
        target = np.where(stretch[:, None], proj, P[rp])
        rho = minimal_rotation(D[cp], -D[rp])
        t = target - qrotate(rho, P[cp])
        dq = dq_from_rt(rho, t)
        w = self.body_size[r] * np.where(self.body_fixed[r], FIXED_WEIGHT, 1.0)
        T = dq_weighted_mean(dq, w, self.b_cl, self.n_clusters)
        cm = np.flatnonzero(self.row_of_port < 0)
        T = self._limit(T, P[cm], self.body[self.m.port_comp[cm]] - self.n_rows, np.full(self.n_clusters, lim_fit))
        T[self.body_fixed[self.n_rows:]] = IDENTITY
        self.T = dq_mul(T, self.T)


def _optimise_clusters(net: Network, model: Model, max_iter: int) -> int:
    """First step of §3: fittings of each FixCluster aligned among themselves (by FixGroups)."""
    pa, pb = net.internal_cluster
    if len(pa) == 0:
        return 0
    pc = model.port_comp
    P, D = net.ports()
    gap = np.linalg.norm(P[pa] - P[pb], axis=1)
    closed = gap <= model.pos_tol
    n = model.n_comp
    group = _components(n, pc[pa][closed], pc[pb][closed])
    gfixed = np.zeros(n, dtype=bool)
    np.logical_or.at(gfixed, group, model.fixed)
    Tg = np.tile(IDENTITY, (n, 1))
    open_a, open_b = pa[~closed], pb[~closed]
    it = 0
    for it in range(1, max_iter + 1):
        Pg = transform_points(Tg[group[pc]], net.Pc0)
        Dg = qrotate(Tg[group[pc]][:, :4], net.Dc0)
        g_a = np.linalg.norm(Pg[open_a] - Pg[open_b], axis=1)
        ang = np.linalg.norm(Dg[open_a] + Dg[open_b], axis=1)
        if len(open_a) == 0 or (g_a.max() <= model.pos_tol and ang.max() <= np.min(model.ang_tol, initial=1.0)):
            break
        src = np.concatenate([open_a, open_b])
        dst = np.concatenate([open_b, open_a])
        mid = 0.5 * (Pg[src] + Pg[dst])
        dirt = Dg[src] - Dg[dst]
        dirt /= np.linalg.norm(dirt, axis=1, keepdims=True)
        rho = minimal_rotation(Dg[src], dirt)
        dq = dq_from_rt(rho, mid - qrotate(rho, Pg[src]))
        w = model.size[pc[dst]]
        T = dq_weighted_mean(dq, w, group[pc[src]], n)
        T[gfixed] = IDENTITY
        Tg = dq_mul(T, Tg)
    cm = ~net.row_member[pc]
    net.Pc0[cm] = transform_points(Tg[group[pc[cm]]], net.Pc0[cm])
    net.Dc0[cm] = qrotate(Tg[group[pc[cm]]][:, :4], net.Dc0[cm])
    return it


def solve_dual_quaternion(model: Model, options: AlignmentOptions, active: np.ndarray, progress: Progress,
                          may_cut: bool = True) -> Outcome:
    """The alternating iteration with the paper's explosion cuts, where cuts are justified.

    ``may_cut`` is False when the direct method closed every connection without a cut: the
    constraints then do not conflict (a tree, or loops that close), so an explosion means the steps
    were too long, not that a connection is wrong; the run restarts with half the step limit instead
    of cutting. ``options.max_iterations`` caps all steps of all restarts together; the best state
    seen is returned when the cap stops the run."""
    active = active.copy()
    reasons: dict[int, str] = {}
    errors: dict[int, tuple[float, float]] = {}
    total = 0
    budget = options.max_iterations
    stages = Stages(progress)
    stages.stage(0.7, 0.95, "dual-quaternion iteration")
    shrink = 1.0
    restarts = 0
    overall_best = None
    while True:
        net = Network(model, active)
        total += _optimise_clusters(net, model, max(min(500, budget - total), 0))
        P, D = net.ports()
        gap, ang = connection_errors(model, P, D)
        g0 = float(np.max(gap[active], initial=0.0))
        lim_fit = shrink * (options.step_limit or max(0.5 * g0, 10 * model.pos_tol))
        lim_pipe = 0.5 * lim_fit
        best = (np.inf, P, D)
        exploded = None
        stop = f"iteration cap ({budget}) reached"
        it = 0
        improved_at, reference = 0, np.inf
        for it in range(max(budget - total, 0) + 1):
            impact = float(np.max(gap[active] + ang[active] * model.lref, initial=0.0))
            if impact < best[0]:
                best = (impact, P, D)
            if best[0] < (1.0 - STALL_GAIN) * reference:
                improved_at, reference = it, best[0]
            elif it - improved_at >= STALL_ITERATIONS:
                stop = (f"stalled: the largest error has not dropped by {STALL_GAIN:.0%} in {STALL_ITERATIONS} "
                        f"iterations (at {total + it}; largest gap {np.max(gap[active], initial=0.0):.3g})")
                break
            if np.all(gap[active] <= model.close_pos) and np.all(ang[active] <= model.close_ang[active]):
                stop = f"all connections within tolerance after {total + it} iterations"
                break
            if np.max(gap[active], initial=0.0) > options.explosion_factor * max(g0, model.pos_tol):
                exploded = choose_cut(model, active, gap, ang, only_bad=False)
                break
            if total + it >= budget:
                break
            if it % 25 == 0:  # creeps toward the stage's end: the iteration count is not known in advance
                stages.tick(f"dual-quaternion iteration {total + it}")
            net.step_rows(P, D, lim_pipe)
            P, D = net.ports()
            net.step_clusters(P, D, lim_fit)
            P, D = net.ports()
            gap, ang = connection_errors(model, P, D)
        total += it
        if overall_best is None or best[0] < overall_best[0]:
            overall_best = best
        if exploded is not None and not may_cut and total < budget and restarts < 20:
            shrink *= 0.5
            restarts += 1
            continue
        if exploded is not None and may_cut and len(reasons) < options.max_cuts:
            active[exploded] = False
            reasons[exploded] = "explosion"
            errors[exploded] = (float(gap[exploded]), float(ang[exploded]))
            overall_best = None
            continue
        if exploded is not None:
            stop = (f"explosion indicator fired with the cut limit ({options.max_cuts}) reached" if may_cut else
                    f"explosion indicator fired after {restarts} restarts with shorter steps")
        break
    extra = {"step_limit_restarts": restarts} if restarts else {}
    if not stop.startswith("all connections"):
        _, P, D = overall_best
    return Outcome(P=P.astype(np.longdouble), D=D, iterations=total, stop_reason=stop, active=active,
                   cut_reason=reasons, cut_errors=errors, extra=extra)
