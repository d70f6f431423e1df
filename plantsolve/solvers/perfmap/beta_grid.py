"""Auxiliary coordinates (beta / R-lines) on the fitted speed lines, the way cycle codes tabulate a map.

Smooth C and GasTurb draw beta lines as parabolas (or straight lines) ``y - y_v = c (x - x_v)^p`` through a
common vertex; a map is then tabulated at the crossings of every speed line with every beta line. Along a
fitted speed line the flow rises and the pressure never rises, so above the vertex ``c`` falls strictly:
each beta line crosses each speed line once, and the crossing is found by bisection in the curve parameter.

Beta runs from 0 at choke to 1 at surge (GasTurb's convention); on each speed line the node of beta lies
where ``c = c_choke + beta (c_surge - c_choke)``, the two constants being those through the line's own
ends, so that beta = 1 is the surge line and beta = 0 the choke line exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantsolve.solvers.perfmap.families import CurveSet

EXPONENT = {"parabola": 2, "straight": 1}
_CHECK_SAMPLES = 257
_BISECTIONS = 60


class BetaGridError(ValueError):
    """A speed line some beta line would cross more than once (it dips to the vertex's pressure)."""

    def __init__(self, line: int, reason: str):
        super().__init__(reason)
        self.line = line
        self.reason = reason


@dataclass(frozen=True)
class BetaFrame:
    """The family of beta lines: exponent p and vertex (x_v, y_v)."""

    p: int
    xv: float
    yv: float

    def constant(self, x, y):
        """c of the beta line through (x, y)."""
        return (np.asarray(y, dtype=float) - self.yv) / (np.asarray(x, dtype=float) - self.xv) ** self.p


def choose_frame(curves: CurveSet, shape: str, pressure_is_ratio: bool) -> BetaFrame:
    """The vertex: flow 0 when every flow is positive (else one flow span below the smallest); pressure 1 for
    a pressure ratio above 1 everywhere (a compressor at zero flow and speed), else 0 when every pressure is
    positive, else one pressure span below the smallest."""
    X, Y, _ = curves.sample(np.linspace(0.0, 1.0, _CHECK_SAMPLES))
    x_lo, x_hi, y_lo, y_hi = X.min(), X.max(), Y.min(), Y.max()
    xv = 0.0 if x_lo > 0 else x_lo - max(x_hi - x_lo, 1.0)
    if pressure_is_ratio and y_lo > 1.0:
        yv = 1.0
    elif y_lo > 0:
        yv = 0.0
    else:
        yv = y_lo - max(y_hi - y_lo, 1.0)
    return BetaFrame(EXPONENT[shape], float(xv), float(yv))


def check_single_crossings(curves: CurveSet, frame: BetaFrame) -> tuple[np.ndarray, np.ndarray]:
    """(c_choke, c_surge) per line, after checking that c falls strictly along every line (sampled densely):
    then every beta line between them crosses it exactly once. Raises :class:`BetaGridError` otherwise."""
    t = np.linspace(0.0, 1.0, _CHECK_SAMPLES)
    X, Y, _ = curves.sample(t)
    for k in range(curves.n):
        if np.any(Y[k] <= frame.yv) or np.any(X[k] <= frame.xv):
            raise BetaGridError(k, "the speed line reaches the vertex of the beta lines")
        c = frame.constant(X[k], Y[k])
        if not np.all(np.diff(c) < 0):
            raise BetaGridError(k, "a beta line crosses the speed line more than once")
    c = frame.constant(X, Y)
    return c[:, -1], c[:, 0]


def node_parameters(curves: CurveSet, frame: BetaFrame, idx: np.ndarray, beta: np.ndarray,
                    c_choke: np.ndarray, c_surge: np.ndarray) -> np.ndarray:
    """Curve parameter t of the node of ``beta[j]`` on line ``idx[j]`` (bisection: c falls along t)."""
    idx = np.asarray(idx, dtype=int)
    beta = np.asarray(beta, dtype=float)
    target = c_choke[idx] + beta * (c_surge[idx] - c_choke[idx])
    lo, hi = np.zeros(len(idx)), np.ones(len(idx))
    for _ in range(_BISECTIONS):
        mid = 0.5 * (lo + hi)
        x, y = curves.evaluate_xy(idx, mid)
        above = frame.constant(x, y) > target  # still on the surge side of the beta line
        lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
    t = 0.5 * (lo + hi)
    # the ends are the line's own surge and choke points, not a bisection's approximation of them
    return np.where(beta >= 1.0, 0.0, np.where(beta <= 0.0, 1.0, t))


@dataclass(frozen=True)
class BetaTable:
    frame: BetaFrame
    beta: np.ndarray  # (m,)
    t: np.ndarray  # (n, m)
    flow: np.ndarray
    pressure: np.ndarray
    efficiency: np.ndarray
    c_choke: np.ndarray  # (n,)
    c_surge: np.ndarray


def tabulate(curves: CurveSet, n_beta: int, shape: str, pressure_is_ratio: bool) -> BetaTable:
    """Every speed line at ``n_beta`` evenly spaced beta values (0 = choke ... 1 = surge)."""
    frame = choose_frame(curves, shape, pressure_is_ratio)
    c_choke, c_surge = check_single_crossings(curves, frame)
    beta = np.linspace(0.0, 1.0, n_beta)
    idx = np.repeat(np.arange(curves.n)[:, None], n_beta, axis=1)
    B = np.broadcast_to(beta, idx.shape)
    t = node_parameters(curves, frame, idx.ravel(), B.ravel(), c_choke, c_surge).reshape(idx.shape)
    x, y, e = curves.evaluate(idx, t)
    return BetaTable(frame, beta, t, x, y, e, c_choke, c_surge)


def values_at(curves: CurveSet, frame: BetaFrame, idx: np.ndarray, beta: np.ndarray,
              c_choke: np.ndarray, c_surge: np.ndarray):
    """(flow, pressure, efficiency) at ``beta[j]`` on line ``idx[j]``, exactly on the fitted curve."""
    t = node_parameters(curves, frame, idx, beta, c_choke, c_surge)
    return curves.evaluate(np.asarray(idx, dtype=int), t)
