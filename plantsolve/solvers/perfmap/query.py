"""Inverse query on a finished result: the best setting for duty points (flow, pressure)."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.perfmap import PerfmapQueryRequest, PerfmapQueryResult, PerfmapResult, QueryAnswer
from plantsolve.solvers.base import FieldError, InputRejected, ResultNotUsable
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
