"""From a solver state to the public result: exact closure, transforms, report.

Connections the solver closed within tolerance are made bit-identical: both ports get the
very same float64 coordinates (a tie-in's own, else those of the port with the smaller
(id, port) key) and exactly opposite directions, so exported files print the same string.
Tie-ins keep their input coordinates bit for bit.
"""

from __future__ import annotations

import gc
import math
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
from pydantic import BaseModel
from scipy.spatial.transform import Rotation

from plantsolve.schemas.alignment import (
    AlignmentRequest, AlignmentResult, ComponentResult, ConnectionResult, Port, Transform,
)
from plantsolve.schemas.common import Diagnostic, Report
from plantsolve.solvers.alignment.dualquat import dq_from_rt, minimal_rotation, rotation_angle
from plantsolve.solvers.alignment.model import Model, collinear_fittings, connection_errors
from plantsolve.solvers.base import SolverError
from plantsolve.solvers.geometry import quaternion, rotation


@dataclass
class Outcome:
    """What a method hands to :func:`build_result`."""

    P: np.ndarray  # [np, 3] longdouble, centred frame
    D: np.ndarray  # [np, 3]
    iterations: int
    stop_reason: str
    active: np.ndarray  # [nk] bool, False = cut
    cut_reason: dict[int, str] = field(default_factory=dict)
    cut_errors: dict[int, tuple[float, float]] = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    snap: bool = True  # False: the input is returned as it is (already within tolerance)

    def reordered(self, ports: np.ndarray, conns: np.ndarray) -> Outcome:
        """This outcome of a reordered request in the request's own order: its port ``i`` is our port
        ``ports[i]``, its connection ``k`` our connection ``conns[k]`` (see :mod:`canonical`)."""
        back = np.empty_like(conns)
        back[conns] = np.arange(len(conns))
        return Outcome(P=self.P[ports], D=self.D[ports], iterations=self.iterations, stop_reason=self.stop_reason,
                       active=self.active[conns], cut_reason={int(back[k]): v for k, v in self.cut_reason.items()},
                       cut_errors={int(back[k]): v for k, v in self.cut_errors.items()}, extra=self.extra,
                       snap=self.snap)


def world_ports(model: Model, out: Outcome) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Final float64 world positions and directions, and which connections were snapped."""
    P = (out.P + model.center.astype(np.longdouble)).astype(float)
    D = out.D / np.linalg.norm(out.D, axis=1, keepdims=True)
    fixed_ports = model.fixed[model.port_comp]
    P[fixed_ports] = model.P_in[fixed_ports]
    D[fixed_ports] = model.D_in[fixed_ports]
    gap, ang = connection_errors(model, out.P, out.D)
    closed = out.active & (gap <= model.snap_pos) & (ang <= model.snap_ang)
    if not out.snap:
        return P, D, np.zeros_like(closed)
    a, b = model.conn_a[closed], model.conn_b[closed]
    fa, fb = fixed_ports[a], fixed_ports[b]
    a_first = np.array([model.key[i] <= model.key[j] for i, j in zip(a, b)], dtype=bool)
    rep_is_a = fa | (~fb & a_first)
    rep = np.where(rep_is_a, a, b)
    other = np.where(rep_is_a, b, a)
    movable = ~fixed_ports[other]
    P[other[movable]] = P[rep[movable]]
    D[other[movable]] = -D[rep[movable]]
    return P, D, closed


def _kabsch(model: Model, P_new: np.ndarray, D_new: np.ndarray, up_new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation quaternion and (centred-frame) translation of each component's rigid motion.

    Kabsch batched over all components at once (one stacked SVD), with port directions and up
    vectors as extra point pairs and pipes anchored at their first port: that is why it is not
    :func:`plantsolve.solvers.geometry.kabsch`, which fits one point set."""
    n = model.n_comp
    pc = model.port_comp
    old = model.P_in - model.center
    new = P_new - model.center
    counts = np.diff(model.port_start)
    c_old = np.zeros((n, 3)); np.add.at(c_old, pc, old); c_old /= counts[:, None]
    c_new = np.zeros((n, 3)); np.add.at(c_new, pc, new); c_new /= counts[:, None]
    scale = model.size[pc][:, None]
    H = np.zeros((n, 3, 3))
    np.add.at(H, pc, model.D_in[:, :, None] * D_new[:, None, :])
    np.add.at(H, pc, ((old - c_old[pc]) / scale)[:, :, None] * ((new - c_new[pc]) / scale)[:, None, :])
    has_up = ~np.isnan(model.up[:, 0])
    H[has_up] += model.up[has_up][:, :, None] * up_new[has_up][:, None, :]
    U, S, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(np.einsum("nji,nkj->nik", Vt, U)))
    Dm = np.zeros((n, 3, 3)); Dm[:, 0, 0] = 1; Dm[:, 1, 1] = 1; Dm[:, 2, 2] = np.where(d == 0, 1, d)
    R = np.einsum("nji,njk,nlk->nil", Vt, Dm, U)
    q = quaternion(Rotation.from_matrix(R))
    degenerate = S[:, 1] < 1e-9 * np.maximum(S[:, 0], 1e-300)
    first = model.port_start[:-1]
    if np.any(degenerate):
        q[degenerate] = minimal_rotation(model.D_in[first[degenerate]], D_new[first[degenerate]])
    q = np.where(q[:, :1] < 0, -q, q)
    Rm = rotation(q)
    anchor_old = np.where(model.is_pipe[:, None], old[first], c_old)
    anchor_new = np.where(model.is_pipe[:, None], new[first], c_new)
    t = anchor_new - Rm.apply(anchor_old)
    t[model.fixed] = 0.0
    q[model.fixed] = [1.0, 0, 0, 0]
    return q, t


def _final_up(model: Model, D_new: np.ndarray, q_rot: np.ndarray | None = None) -> np.ndarray:
    up = np.full_like(model.up, np.nan)
    has_up = ~np.isnan(model.up[:, 0])
    inline = collinear_fittings(model)
    idx = np.flatnonzero(has_up & inline)
    if len(idx):
        axis = D_new[model.port_start[idx]]
        u0 = model.up[idx]
        v = u0 - np.einsum("ij,ij->i", u0, axis)[:, None] * axis
        up[idx] = v / np.linalg.norm(v, axis=1, keepdims=True)
    other = np.flatnonzero(has_up & ~inline)
    if len(other) and q_rot is not None:
        up[other] = rotation(q_rot[other]).apply(model.up[other])
    fx = np.flatnonzero(has_up & model.fixed)
    up[fx] = model.up[fx]
    return up


def build_result(request: AlignmentRequest, model: Model, out: Outcome, method: str) -> AlignmentResult:
    P, D, closed = world_ports(model, out)
    _check_finite(P=P, D=D)
    gap_solver, ang_solver = connection_errors(model, out.P, out.D)
    up = _final_up(model, D)
    q, t_local = _kabsch(model, P, D, np.nan_to_num(up))
    other = ~np.isnan(model.up[:, 0]) & ~collinear_fittings(model) & ~model.fixed
    if np.any(other):
        up[other] = rotation(q[other]).apply(model.up[other])
    R = rotation(q)
    t_world = t_local + model.center - R.apply(np.tile(model.center, (model.n_comp, 1)))
    t_world[model.fixed] = 0.0
    dq = dq_from_rt(q, t_world)
    angles = np.degrees(rotation_angle(q))

    gap, ang = connection_errors(model, P, D)
    act = out.active
    max_gap = float(np.max(gap[act])) if np.any(act) else 0.0
    max_ang = float(np.max(ang[act])) if np.any(act) else 0.0
    converged = bool(max_gap <= model.pos_tol and np.all(ang[act] <= model.ang_tol[act]))

    move = np.linalg.norm(P - model.P_in, axis=1)
    disp = np.zeros(model.n_comp)
    np.maximum.at(disp, model.port_comp, move)
    s0 = model.port_start[:-1]
    pipes = np.flatnonzero(model.is_pipe)
    length_old = np.linalg.norm(model.P_in[s0[pipes] + 1] - model.P_in[s0[pipes]], axis=1)
    length_new = np.linalg.norm(P[s0[pipes] + 1] - P[s0[pipes]], axis=1)
    # pipe-axis movement: mean distance of the measured end points from the new axis line
    axis = (P[s0[pipes] + 1] - P[s0[pipes]]) / length_new[:, None]
    axis_move = np.zeros(len(pipes))
    for end in (0, 1):
        v = model.P_in[s0[pipes] + end] - P[s0[pipes]]
        axis_move += 0.5 * np.linalg.norm(v - np.einsum("ij,ij->i", v, axis)[:, None] * axis, axis=1)
    fittings = np.flatnonzero(~model.is_pipe)
    length_change = np.full(model.n_comp, np.nan)
    length_change[pipes] = length_new - length_old

    # one model per component, port and connection built from whole arrays without re-validating each
    # (model_construct); the checks their schemas would make are made on the arrays, once
    _check_finite(dq=dq, t_world=t_world, disp=disp, angles=angles, gap=gap, ang=ang)
    if np.max(np.abs(P), initial=0.0) > 1e12:
        raise SolverError("result", "an aligned port lies beyond 1e12 units of the origin")
    with _no_cycle_collection():
        comps, conns = _result_models(request, model, P, D, up, dq, q, t_world, disp, angles, length_change, gap,
                                      ang, act)
    cut_idx = [int(k) for k in np.flatnonzero(~act)]

    warnings: list[Diagnostic] = []
    if cut_idx:
        warnings.append(
            Diagnostic(
                code="connections_cut",
                message=f"{len(cut_idx)} connection(s) were cut to make the model consistent; they are left open.",
                details={
                    "cuts": [
                        {
                            "index": k,
                            "from": list(request.connections[k].from_),
                            "to": list(request.connections[k].to),
                            "reason": out.cut_reason.get(k, "conflict"),
                            "position_error_before_cut": out.cut_errors.get(k, (float("nan"),) * 2)[0],
                            "angle_error_before_cut_deg": float(np.degrees(out.cut_errors.get(k, (float("nan"),) * 2)[1])),
                        }
                        for k in cut_idx
                    ]
                },
            )
        )
    above = np.flatnonzero(act & ((gap > model.pos_tol) | (ang > model.ang_tol)))
    if len(above):
        order = above[np.argsort(-(gap[above] + ang[above] * model.lref))][:100]
        warnings.append(
            Diagnostic(
                code="not_converged",
                message=f"{len(above)} connection(s) remain above tolerance ({model.pos_tol:.3g} {request.units}, "
                f"{np.degrees(np.min(model.ang_tol, initial=0.0)):.3g} deg): {out.stop_reason}.",
                details={
                    "connections": [
                        {"index": int(k), "from": list(request.connections[k].from_), "to": list(request.connections[k].to),
                         "position_error": float(gap[k]), "angle_error_deg": float(np.degrees(ang[k]))}
                        for k in order
                    ]
                },
            )
        )

    def stats(x: np.ndarray) -> dict[str, float]:
        return {"count": int(len(x)), "mean": float(np.mean(x)) if len(x) else 0.0, "max": float(np.max(x)) if len(x) else 0.0}

    details = {
        "method": method,
        "stop_reason": out.stop_reason,
        "position_tolerance": model.pos_tol,
        "angle_tolerance_deg": float(np.degrees(np.max(model.ang_tol, initial=0.0))),
        "angle_tolerance_deg_min": float(np.degrees(np.min(model.ang_tol, initial=0.0))),
        "center": model.center.tolist(),
        "pipe_axis_movement": stats(axis_move),
        "pipe_displacement": stats(disp[pipes]),
        "fitting_displacement": stats(disp[fittings]),
        "pipe_length_change": stats(np.abs(length_change[pipes])),
        "closed_bit_identical": int(np.sum(closed)),
        "snap_distortion": {
            "position": float(np.max(gap_solver[closed])) if np.any(closed) else 0.0,
            "angle_deg": float(np.degrees(np.max(ang_solver[closed]))) if np.any(closed) else 0.0,
        },
        **out.extra,
    }
    status = "ok" if converged and not cut_idx else "warning"
    unit = request.units
    message = (
        f"Converged ({out.stop_reason}); largest gap {max_gap:.3g} {unit}, largest angle {np.degrees(max_ang):.3g} deg."
        if converged
        else f"Not converged ({out.stop_reason}); largest gap {max_gap:.3g} {unit}, "
        f"largest angle {np.degrees(max_ang):.3g} deg."
    )
    return AlignmentResult(
        units=unit, converged=converged, iterations=int(out.iterations), max_position_error=max_gap,
        max_angle_error=float(np.degrees(max_ang)), components=comps, connections=conns,
        cut_connections=cut_idx, report=Report(status=status, message=message, warnings=warnings, details=details),
    )


def _result_models(request: AlignmentRequest, model: Model, P, D, up, dq, q, t_world, disp, angles, length_change,
                   gap, ang, act) -> tuple[list[ComponentResult], list[ConnectionResult]]:
    """One model per component, port and connection, from whole arrays (see :func:`_trusted`)."""
    port = _trusted(Port)
    ports = [port(position=p, direction=d) for p, d in zip(P.tolist(), D.tolist())]
    starts = model.port_start.tolist()
    ups = [None if math.isnan(u[0]) else u for u in up.tolist()]  # NaN first entry: no up vector
    component, transform = _trusted(ComponentResult), _trusted(Transform)
    comps = [
        component(id=cid, ports=ports[starts[c]:starts[c + 1]],
                  transform=transform(dual_quaternion=dqc, rotation=qc, translation=tc), displacement=dc,
                  rotation_angle=ac, length_change=None if math.isnan(lc) else lc, up=uc)
        for c, (cid, dqc, qc, tc, dc, ac, lc, uc) in enumerate(zip(
            model.ids, dq.tolist(), q.tolist(), t_world.tolist(), disp.tolist(), angles.tolist(),
            length_change.tolist(), ups))
    ]
    connection = _trusted(ConnectionResult)
    conns = [
        connection(from_=c.from_, to=c.to, position_error=ge, angle_error=ae, cut=not ak)
        for c, ge, ae, ak in zip(request.connections, gap.tolist(), np.degrees(ang).tolist(), act.tolist())
    ]
    return comps, conns


@contextmanager
def _no_cycle_collection() -> Iterator[None]:
    """The cyclic garbage collector paused: building half a million models on 100,000 components, none of them
    garbage, set off full collections that walked every object alive again and again (more than half of that
    time). Resumed after, only where it was running."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _trusted(cls: type[BaseModel]) -> Callable[..., BaseModel]:
    """A constructor of ``cls`` from every field by name, without validation: what ``cls.model_construct`` makes
    when it is given every field (the same ``__dict__``, in the order of the keywords, and fields set), without
    its per-call search of aliases and defaults, which was most of the result's time on 100,000 components (half
    a million models). The callers name the fields in declaration order, as ``model_construct`` stores them."""
    names = frozenset(cls.__pydantic_fields__)
    if cls.__pydantic_post_init__ or cls.__pydantic_root_model__ or cls.model_config.get("extra") == "allow":
        return cls.model_construct
    new, put = cls.__new__, object.__setattr__

    def make(**values):
        m = new(cls)
        put(m, "__dict__", values)
        put(m, "__pydantic_fields_set__", set(names))
        put(m, "__pydantic_extra__", None)
        put(m, "__pydantic_private__", None)
        return m

    return make


def _check_finite(**arrays: np.ndarray) -> None:
    """What the result schema refuses (NaN, infinity), said of the array it came from."""
    for name, x in arrays.items():
        if not np.all(np.isfinite(x)):
            raise SolverError("result", f"non-finite values in {name} at index {np.argwhere(~np.isfinite(x))[0].tolist()}")
