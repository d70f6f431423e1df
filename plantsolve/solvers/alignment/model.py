"""Array form of a request: ports, connections and weights in a centred frame.

Coordinates reach 1e6 mm in plant models, where a double's spacing is above the 1e-10
tolerance, so the solvers work relative to a centre and keep base positions in
``np.longdouble`` (80-bit on x86-64: 64-bit mantissa) where the last digits are decided.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.pcf import profile_tolerances, resolve_pcf_tolerance
from plantsolve.solvers.base import InputRejected

def resolve_tolerances(request: AlignmentRequest) -> tuple[float, float, float]:
    """(position tolerance in request units, base angle tolerance in radians, rounding of printed
    coordinates in units: 0 unless a PCF's precision sets a floor)."""
    opts = request.options
    if request.source_pcf is not None:
        try:
            return resolve_pcf_tolerance(request.source_pcf, request.units, opts)
        except InputRejected:  # a source_pcf that does not belong to this request: JSON rules
            pass
    profile = "custom" if opts.tolerance_profile == "auto" else opts.tolerance_profile
    pos, ang = profile_tolerances(profile, request.units)
    if opts.position_tolerance is not None:
        pos = opts.position_tolerance
    if opts.angle_tolerance is not None:
        ang = np.radians(opts.angle_tolerance)
    return float(pos), float(ang), 0.0


@dataclass
class Model:
    ids: list[str]
    is_pipe: np.ndarray  # [n] bool
    fixed: np.ndarray  # [n] bool
    radius: np.ndarray  # [n] float, nan if unknown
    up: np.ndarray  # [n, 3] unit up vectors, nan if none
    ftype: list[str | None]
    port_comp: np.ndarray  # [np] component of each port
    port_start: np.ndarray  # [n + 1] ports of c are port_start[c]:port_start[c + 1]
    port_local: np.ndarray  # [np] index of the port within its component
    P_in: np.ndarray  # [np, 3] float64 input positions (world)
    D_in: np.ndarray  # [np, 3] float64 input directions, normalised
    center: np.ndarray  # [3] float64
    P0: np.ndarray  # [np, 3] longdouble positions relative to center
    D0: np.ndarray  # [np, 3] float64 directions used by the solver (pipes: +-axis)
    conn_a: np.ndarray  # [nk] port index of "from"
    conn_b: np.ndarray  # [nk] port index of "to"
    pos_tol: float
    ang_tol: np.ndarray  # [nk] radians, per connection (printed rounding over the shorter lever raises it)
    size: np.ndarray  # [n] "length" of a component (pipe length, fitting arm sum)
    lref: float  # typical length, makes weights dimensionless
    min_length: np.ndarray  # [n] minimum pipe length (0 for fittings)
    # [np] (id, port) of each port: which of two closed ports (within round-off) is the snapped one's copy, and the
    # order of a port_rank tie
    key: list[tuple[str, int]]

    @property
    def snap_pos(self) -> float:
        """Largest solver residual closed by snapping (the two ports made bit-identical): singular
        (orthogonal) loops stall the last digits of Gauss-Newton near 1e-12..1e-10 relative. Never more
        than 1e-6 of the typical length, so a loose tolerance (a millimetre) cannot distort short items."""
        return min(max(self.pos_tol, 1e-9 * self.lref), 1e-6 * self.lref)

    @property
    def snap_ang(self) -> np.ndarray:
        return np.minimum(np.maximum(self.ang_tol, 1e-9), 1e-6)

    @property
    def close_pos(self) -> float:
        """A gap that counts as closed: within tolerance or a snapped residue."""
        return max(self.pos_tol, self.snap_pos)

    @property
    def close_ang(self) -> np.ndarray:
        return np.maximum(self.ang_tol, self.snap_ang)

    @cached_property
    def measured_errors(self) -> tuple[np.ndarray, np.ndarray]:
        """Gap (units) and angle error (radians) of every connection as the request has them: what ranks the
        connections equally to blame for a conflict (:func:`cuts.worst_measured`)."""
        return connection_errors(self, self.P0, self.D0)

    @cached_property
    def port_rank(self) -> np.ndarray:
        """[np] each port's place in an order the network decides, not its listing nor its names: by the port's
        distance from the middle of all ports, then its position and its direction as written; only ports alike in
        all of these (none but a duplicated component's) by their (id, port). What a tie of equal measurements is
        decided by (:func:`cuts.connection_key`, a row's first port): decided by the names, a network renamed was cut
        at the other end of a symmetric run, 8 mm from the first answer."""
        n = len(self.key)
        by_name = np.empty(n, dtype=np.intp)
        by_name[sorted(range(n), key=self.key.__getitem__)] = np.arange(n)
        P = self.P_in
        # the mean of the positions in their own sorted order: the same bits however they were listed
        middle = P[np.lexsort(P.T[::-1])].mean(axis=0) if n else np.zeros(3)
        d2 = ((P - middle) ** 2).sum(axis=1)
        rank = np.empty(n, dtype=np.intp)
        rank[np.lexsort((by_name, *self.D_in.T[::-1], *P.T[::-1], d2))] = np.arange(n)
        return rank

    @property
    def n_comp(self) -> int:
        return len(self.ids)

    @property
    def n_conn(self) -> int:
        return len(self.conn_a)

    def pipe_ports(self) -> tuple[np.ndarray, np.ndarray]:
        """Port indices (port 0, port 1) of every component (meaningful for pipes)."""
        return self.port_start[:-1], self.port_start[:-1] + 1


def build_model(request: AlignmentRequest) -> Model:
    comps = request.components
    n = len(comps)
    fixed_extra = set(request.options.fixed_components)
    counts = np.array([len(c.ports) for c in comps])
    port_start = np.concatenate([[0], np.cumsum(counts)])
    port_comp = np.repeat(np.arange(n), counts)
    port_local = np.arange(port_start[-1]) - port_start[port_comp]
    P_in = np.array([p.position for c in comps for p in c.ports], dtype=float)
    D_raw = np.array([p.direction for c in comps for p in c.ports], dtype=float)
    D_in = D_raw / np.linalg.norm(D_raw, axis=1, keepdims=True)
    is_pipe = np.array([c.kind == "pipe" for c in comps])
    fixed = np.array([c.fixed or c.id in fixed_extra for c in comps])
    radius = np.array([np.nan if c.radius is None else c.radius for c in comps])
    up = np.full((n, 3), np.nan)
    for i, c in enumerate(comps):
        if c.up is not None and c.kind == "fitting":
            u = np.array(c.up, dtype=float)
            up[i] = u / np.linalg.norm(u)

    # A centre that is a round number keeps P_in - center exact for typical coordinates.
    center = np.round(P_in.mean(axis=0), 0) if len(P_in) else np.zeros(3)
    P0 = P_in.astype(np.longdouble) - center.astype(np.longdouble)

    D0 = D_in.copy()
    s = port_start[:-1]
    pipe_idx = np.flatnonzero(is_pipe)
    axis = (P0[s[pipe_idx] + 1] - P0[s[pipe_idx]]).astype(float)
    plen = np.linalg.norm(axis, axis=1)
    axis /= plen[:, None]
    D0[s[pipe_idx]] = -axis
    D0[s[pipe_idx] + 1] = axis
    # a tie-in keeps exactly what was measured, even a pipe whose ends are not quite on its axis
    D0[fixed[port_comp]] = D_in[fixed[port_comp]]

    size = np.zeros(n)
    size[pipe_idx] = plen
    fit_idx = np.flatnonzero(~is_pipe)
    if len(fit_idx):
        pc = P0.astype(float)
        cent = np.zeros((n, 3))
        np.add.at(cent, port_comp, pc)
        cent /= counts[:, None]
        arms = np.linalg.norm(pc - cent[port_comp], axis=1)
        arm_sum = np.bincount(port_comp, arms, minlength=n)
        rad = np.where(np.isnan(radius), 0.0, radius)
        size[fit_idx] = np.maximum(arm_sum[fit_idx], rad[fit_idx])
    # an up vector is a direction normal to the port axis of an inline fitting: drop any axial part
    has_up = np.flatnonzero(~np.isnan(up[:, 0]) & (counts >= 1))
    if len(has_up):
        ax = D_in[port_start[has_up]]
        v = up[has_up] - np.einsum("ij,ij->i", up[has_up], ax)[:, None] * ax
        up[has_up] = v / np.linalg.norm(v, axis=1, keepdims=True)
    lref = float(np.median(size[size > 0])) if np.any(size > 0) else 1.0
    size = np.maximum(size, 1e-3 * lref)

    factor = request.options.min_pipe_length_factor
    min_length = np.zeros(n)
    min_length[pipe_idx] = np.where(np.isnan(radius[pipe_idx]), 0.01 * plen, factor * radius[pipe_idx])

    index = {c.id: i for i, c in enumerate(comps)}
    conn_a = np.array([port_start[index[c.from_[0]]] + c.from_[1] for c in request.connections], dtype=np.intp)
    conn_b = np.array([port_start[index[c.to[0]]] + c.to[1] for c in request.connections], dtype=np.intp)
    pos_tol, ang_base, rounding = resolve_tolerances(request)
    ang_tol = np.full(len(conn_a), ang_base)
    if rounding > 0 and len(conn_a):
        # a direction read from printed points a lever L apart is only known to rounding / L
        far = np.zeros(len(P_in))
        for c in range(n):
            sl = slice(port_start[c], port_start[c + 1])
            Q = P_in[sl]
            far[sl] = np.max(np.linalg.norm(Q[:, None] - Q[None], axis=2), axis=1) if len(Q) > 1 else 0.0
        alone = far <= 0
        far[alone] = np.where(np.isnan(radius[port_comp[alone]]), lref, radius[port_comp[alone]])
        lever = np.minimum(far[conn_a], far[conn_b])
        ang_tol = np.maximum(ang_tol, rounding / np.maximum(lever, 1e-300))
    key = [(comps[c].id, int(k)) for c, k in zip(port_comp, port_local)]
    return Model(
        ids=[c.id for c in comps], is_pipe=is_pipe, fixed=fixed, radius=radius, up=up,
        ftype=[c.type for c in comps], port_comp=port_comp, port_start=port_start, port_local=port_local,
        P_in=P_in, D_in=D_in, center=center, P0=P0, D0=D0, conn_a=conn_a, conn_b=conn_b,
        pos_tol=pos_tol, ang_tol=ang_tol, size=size, lref=lref, min_length=min_length, key=key,
    )


def connection_errors(model: Model, P: np.ndarray, D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gap (units) and angle error (radians) of every connection for port positions P and directions D."""
    a, b = model.conn_a, model.conn_b
    gap = np.linalg.norm((P[a] - P[b]).astype(np.longdouble), axis=1).astype(float)
    s = np.linalg.norm(D[a] + D[b], axis=1)
    ang = 2.0 * np.arcsin(np.clip(s / 2.0, 0.0, 1.0))
    return gap, ang


def collinear_fittings(model: Model, tol_cos: float = np.cos(np.radians(1.0))) -> np.ndarray:
    """Fittings with two opposite, collinear ports (valves, flanges, concentric reducers)."""
    n = model.n_comp
    counts = np.diff(model.port_start)
    out = np.zeros(n, dtype=bool)
    cand = np.flatnonzero((~model.is_pipe) & (counts == 2))
    if len(cand) == 0:
        return out
    s = model.port_start[cand]
    d0, d1 = model.D0[s], model.D0[s + 1]
    opposite = np.einsum("ij,ij->i", d0, d1) < -tol_cos
    sep = (model.P0[s + 1] - model.P0[s]).astype(float)
    sl = np.linalg.norm(sep, axis=1)
    perp = np.linalg.norm(sep - np.einsum("ij,ij->i", sep, d1)[:, None] * d1, axis=1)
    inline = perp <= 1e-6 * np.maximum(sl, model.lref) + 1e-9
    out[cand] = opposite & inline
    return out
