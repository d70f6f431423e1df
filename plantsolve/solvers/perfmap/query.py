"""Queries of a finished result: the best setting for duty points (flow, pressure), and the map as a cycle code
reads it, at (speed, beta)."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.perfmap import (
    BetaAnswer,
    PerfmapBetaQueryRequest,
    PerfmapBetaQueryResult,
    PerfmapQueryRequest,
    PerfmapQueryResult,
    PerfmapResult,
    QueryAnswer,
)
from plantsolve.solvers.base import FieldError, InputRejected, ResultNotUsable
from plantsolve.solvers.perfmap.beta_grid import BetaFrame, values_at
from plantsolve.solvers.perfmap.performance_map import distance_to_region, max_efficiency
from plantsolve.solvers.perfmap.families import CurveSet, curveset_from_fits
from plantsolve.solvers.perfmap.triangulation import locate


def _context(result: PerfmapResult):
    if result.map is None or not result.triangles:
        raise InputRejected(FieldError(("points",), "this job has no performance map (options.map "
                                       "was false, or the settings allow none: see the "
                                       "report): there is nothing to query"))
    curves = curveset_from_fits(result.settings)
    values = np.array([_values(s) for s in result.settings], dtype=float).reshape(len(result.settings), -1)
    ranges = (*result.flow_range, *result.pressure_range)
    t = np.linspace(0.0, 1.0, result.map.t_samples)
    return curves, np.asarray(result.triangles, dtype=int), values, ranges, t


def _values(s) -> list[float]:
    return list(s.setting) if s.setting else [s.theta, s.phi]


def answer_query(result: PerfmapResult, q: PerfmapQueryRequest) -> PerfmapQueryResult:
    """:func:`query` as the kind's result operation: a result without a map cannot answer."""
    if result.map is None:
        raise ResultNotUsable("computed no map (too few settings or map disabled); nothing to query.")
    return query(result, q)


def query(result: PerfmapResult, q: PerfmapQueryRequest) -> PerfmapQueryResult:
    """Max-efficiency setting for each duty point, by the same exact solve as the map.

    Points no setting reaches are reported infeasible with their distance to the reachable
    region instead of an extrapolated setting.
    """
    curves, triangles, values, ranges, t = _context(result)
    X = np.array([p.flow for p in q.points], dtype=float)
    Y = np.array([p.pressure for p in q.points], dtype=float)
    eta, best, _ = max_efficiency(curves, triangles, values, t, X, Y, ranges)
    two = values.shape[1] == 2
    feasible = np.isfinite(eta)
    dist = np.zeros(len(X))
    if (~feasible).any():
        dist[~feasible] = distance_to_region(curves, triangles, t, X[~feasible], Y[~feasible],
                                             ranges)
    dist = np.where(np.isfinite(dist), dist, np.finfo(float).max)  # a number, as the schema says
    answers = [
        QueryAnswer(flow=float(X[k]), pressure=float(Y[k]), feasible=bool(feasible[k]),
                    setting=[float(v) for v in best[k]] if feasible[k] else None,
                    theta=float(best[k, 0]) if feasible[k] and two else None,
                    phi=float(best[k, 1]) if feasible[k] and two else None,
                    efficiency=float(eta[k]) if feasible[k] else None,
                    distance_to_map=float(dist[k]))
        for k in range(len(X))
    ]
    return PerfmapQueryResult(points=answers, units=result.units)


def characteristic_at(result: PerfmapResult, theta: float, phi: float):
    """The interpolated characteristic of a setting inside the triangulation, as a function
    t -> (x, y, eta); None outside the convex hull of the settings."""
    curves: CurveSet = curveset_from_fits(result.settings)
    th = np.array([s.theta for s in result.settings])
    ph = np.array([s.phi for s in result.settings])
    k, w = locate(th, ph, np.asarray(result.triangles, dtype=int), theta, phi)
    if k is None:
        return None
    tri = np.asarray(result.triangles[k])

    def curve(t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        idx = np.broadcast_to(tri[:, None], (3, len(t)))
        x, y, e = curves.evaluate(idx, np.broadcast_to(t, (3, len(t))))
        return w @ x, w @ y, w @ e

    return curve


def _speed_bracket(speeds: np.ndarray, speed: float) -> tuple[int, int, float] | None:
    """(lower, upper, weight of upper) of ``speed`` among ascending ``speeds``; one line when it is one."""
    tol = 1e-9 * max(1.0, float(np.abs(speeds).max()))
    hit = np.flatnonzero(np.abs(speeds - speed) <= tol)
    if len(hit):
        return int(hit[0]), int(hit[0]), 0.0
    if not speeds[0] < speed < speeds[-1]:
        return None
    j = int(np.searchsorted(speeds, speed))
    return j - 1, j, float((speed - speeds[j - 1]) / (speeds[j] - speeds[j - 1]))


def _as_text(values) -> str:
    """Setting values as text: ``0, 5`` (no Python brackets or tuples in a message)."""
    return ", ".join(f"{float(v):g}" for v in values)


def answer_beta_query(result: PerfmapResult, q: PerfmapBetaQueryRequest) -> PerfmapBetaQueryResult:
    """Flow, pressure and efficiency at (setting, beta): exact on a fitted speed line (the node of beta on the
    fitted curve, not the table's interpolation), linear in speed between the two neighbouring lines at the
    same beta. Speeds outside the map's lines and leading settings (alpha) that are no map value are refused
    (422 naming the point), not extrapolated."""
    b = result.beta_map
    if b is None:
        raise ResultNotUsable("has no beta grid (see the report's 'beta_grid_not_possible' warning).")
    names = result.setting_names
    lines = b.lines
    errors, asks = [], []
    for i, p in enumerate(q.points):
        if p.speed is not None and len(names) != 1:
            errors.append(FieldError((*q.place(i), "speed"), f"this map has {len(names)} setting parameters "
                                     f"({', '.join(names)}): give 'setting' with all of them"))
            continue
        setting = [float(p.speed)] if p.speed is not None else [float(v) for v in p.setting]
        field = "speed" if p.speed is not None else "setting"
        if len(setting) != len(names):
            errors.append(FieldError((*q.place(i), field), f"needs {len(names)} values ({', '.join(names)})"))
            continue
        members = [k for k, line in enumerate(lines) if np.allclose(line.setting[:-1], setting[:-1], rtol=1e-9,
                                                                     atol=1e-12)]
        if not members:
            known = sorted({tuple(line.setting[:-1]) for line in lines})
            errors.append(FieldError((*q.place(i), field, 0), f"{', '.join(names[:-1])} = {_as_text(setting[:-1])} "
                                     f"is no value of the map (it has {'; '.join(_as_text(k) for k in known[:10])}"
                                     f"{' …' if len(known) > 10 else ''})"))
            continue
        members.sort(key=lambda k: lines[k].setting[-1])
        speeds = np.array([lines[k].setting[-1] for k in members])
        bracket = _speed_bracket(speeds, setting[-1])
        if bracket is None:
            errors.append(FieldError((*q.place(i), field) + ((len(names) - 1,) if field == "setting" else ()),
                                     f"{names[-1]} {setting[-1]:g} is outside the map's speed lines "
                                     f"({speeds[0]:g} to {speeds[-1]:g}); no extrapolation"))
            continue
        lo, hi, w = bracket
        asks.append((setting, float(p.beta), members[lo], members[hi], w))
    if errors:
        raise InputRejected(errors)
    curves = curveset_from_fits(result.settings)
    frame = BetaFrame(b.exponent, b.vertex_flow, b.vertex_pressure)
    c_choke = np.array([line.c_choke for line in lines])
    c_surge = np.array([line.c_surge for line in lines])
    idx = np.array([a[2] for a in asks] + [a[3] for a in asks], dtype=int)
    beta = np.array([a[1] for a in asks] * 2)
    x, y, e = values_at(curves, frame, idx, beta, c_choke, c_surge)
    n = len(asks)
    w = np.array([a[4] for a in asks])
    flow, pressure, eff = ((1 - w) * v[:n] + w * v[n:] for v in (x, y, e))
    answers = [BetaAnswer(setting=a[0], beta=a[1], flow=float(flow[j]), pressure=float(pressure[j]),
                          efficiency=float(eff[j]), on_speed_line=a[2] == a[3]) for j, a in enumerate(asks)]
    return PerfmapBetaQueryResult(points=answers, units=result.units)
