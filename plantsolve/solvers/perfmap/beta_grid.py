"""Auxiliary coordinates (beta / R-lines) on the fitted speed lines, the way cycle codes tabulate a map.

Smooth C and GasTurb draw beta lines as parabolas (or straight lines) ``y - y_v = c (x - x_v)^p`` through a
common vertex; a map is then tabulated at the crossings of every speed line with every beta line. Along a
fitted speed line the flow rises and the pressure never rises, so above the vertex ``c`` falls strictly:
each beta line crosses each speed line once, and the crossing is found by bisection in the curve parameter.

Beta runs from 0 at choke to 1 at surge (GasTurb's convention); on each speed line the node of beta lies
where ``c = c_choke + beta (c_surge - c_choke)``, the two constants being those through the line's own
ends, so that beta = 1 is the surge line and beta = 0 the choke line exactly.

Which beta values the table holds is a choice of its own. Cycle codes read a table between its nodes
(linearly, or by splines through them); read linearly, a speed line becomes the chords between its nodes.
Evenly spaced beta values (Smooth C's) put few nodes where a line bends sharply, at a steep choke end or at
the kinks of a broken-line fit, and there the chords leave the fitted line by more than the fit leaves
the data. The 'adaptive' spacing places the beta values shared by all lines by Ramer-Douglas-Peucker
splitting: start from the two ends, split the segment whose chord leaves some line the most at the point
where it does, until the grid holds its number of values. Either way the table's departure from every fitted
line is measured (:func:`table_errors`) and stated with the result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from plantsolve.solvers.perfmap.families import CurveSet
from plantsolve.solvers.perfmap.setting_lines import CHOKE_FLOW_TOLERANCE

EXPONENT = {"parabola": 2, "straight": 1}
_CHECK_SAMPLES = 257
_BISECTIONS = 60
# the adaptive spacing picks beta values among multiples of 0.001 (printed exactly by every export)
_CANDIDATE_BETAS = 1001
# two nodes of a line closer in flow than this (fraction of its flow range) would read as a vertical choke
# segment to a reader that merges flows within CHOKE_FLOW_TOLERANCE: the adaptive spacing keeps them apart
_NODE_GAP = 2 * CHOKE_FLOW_TOLERANCE
_TABLE_CHECK_SAMPLES = 4097  # samples of each fitted line where the table's departure from it is measured


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
    pressure_error: np.ndarray  # (n,) see table_errors
    efficiency_error: np.ndarray


def _nodes(curves: CurveSet, frame: BetaFrame, beta: np.ndarray, c_choke: np.ndarray, c_surge: np.ndarray):
    """(t, x, y, eta), each (lines, len(beta)): every line's nodes at ``beta``."""
    idx = np.repeat(np.arange(curves.n)[:, None], len(beta), axis=1)
    B = np.broadcast_to(beta, idx.shape)
    t = node_parameters(curves, frame, idx.ravel(), B.ravel(), c_choke, c_surge).reshape(idx.shape)
    return (t, *curves.evaluate(idx, t))


def _chord_departure(x: np.ndarray, y: np.ndarray, i: int, j: int) -> np.ndarray:
    """|y - chord| / y at the candidates strictly between i and j, (lines, j - i - 1): the chord of each line
    from its candidate i to its candidate j."""
    xi, xj, yi, yj = x[:, i:i + 1], x[:, j:j + 1], y[:, i:i + 1], y[:, j:j + 1]
    xs, ys = x[:, i + 1:j], y[:, i + 1:j]
    return np.abs(ys - (yi + (yj - yi) * (xs - xi) / (xj - xi))) / np.abs(ys)


def adaptive_beta(x: np.ndarray, y: np.ndarray, candidates: np.ndarray, n_beta: int) -> np.ndarray:
    """``n_beta`` of the ascending ``candidates`` (both ends among them) by Ramer-Douglas-Peucker splitting shared
    by all lines: ``x``, ``y`` (lines, candidates) are the lines at the candidates. The segment whose chords leave
    some line the most is split where they do, never closer to a node than _NODE_GAP of a line's flow range;
    a grid with no such split left takes the middle of its widest segment."""
    span = (x.max(axis=1) - x.min(axis=1))[:, None]
    m = x.shape[1]
    nodes = [0, m - 1]

    def split(i: int, j: int) -> tuple[float, int | None]:
        if j - i < 2:
            return -1.0, None
        worst = _chord_departure(x, y, i, j).max(axis=0)
        xs = x[:, i + 1:j]
        apart = np.all((np.abs(xs - x[:, i:i + 1]) >= _NODE_GAP * span)
                       & (np.abs(x[:, j:j + 1] - xs) >= _NODE_GAP * span), axis=0)
        if not apart.any():
            return -1.0, None
        return float(worst.max()), i + 1 + int(np.argmax(np.where(apart, worst, -1.0)))

    segments = {(0, m - 1): split(0, m - 1)}
    while len(nodes) < min(n_beta, m):
        (i, j), (err, k) = max(segments.items(), key=lambda s: s[1][0])
        if k is None:  # nothing left to split apart: the widest segment's middle
            (i, j) = max(segments, key=lambda s: s[1] - s[0])
            k = (i + j) // 2
            if k == i:
                break
        del segments[(i, j)]
        segments[(i, k)], segments[(k, j)] = split(i, k), split(k, j)
        nodes.append(k)
    return candidates[np.sort(nodes)]


def table_errors(curves: CurveSet, t_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per line, how far the table read linearly between its nodes (the chords) departs from the fitted line:
    the largest relative pressure and absolute efficiency difference at the same flow, sampled densely along
    the line, and at every knot of a broken-line fit (where the chords leave it most). At a measured point the
    table then departs from the data by at most this plus the fit's own error there."""
    dense = np.linspace(0.0, 1.0, _TABLE_CHECK_SAMPLES)
    idx = np.repeat(np.arange(curves.n)[:, None], t_nodes.shape[1], axis=1)
    xn, yn, en = curves.evaluate(idx, t_nodes)
    p_err, e_err = np.zeros(curves.n), np.zeros(curves.n)
    for k in range(curves.n):
        t = np.union1d(dense, curves.knots[k][0]) if k in curves.knots else dense
        x, y, e = curves.evaluate(np.full(t.size, k), t)
        order = np.argsort(xn[k])
        p_err[k] = np.max(np.abs(np.interp(x, xn[k][order], yn[k][order]) - y) / np.abs(y))
        e_err[k] = np.max(np.abs(np.interp(x, xn[k][order], en[k][order]) - e))
    return p_err, e_err


def tabulate(curves: CurveSet, n_beta: int, shape: str, pressure_is_ratio: bool, spacing: str = "adaptive"
             ) -> BetaTable:
    """Every speed line at ``n_beta`` beta values (0 = choke ... 1 = surge): evenly spaced (``spacing`` 'even')
    or placed where the chords between nodes would leave the lines most ('adaptive', :func:`adaptive_beta`),
    with the table's departure from each fitted line (:func:`table_errors`)."""
    frame = choose_frame(curves, shape, pressure_is_ratio)
    c_choke, c_surge = check_single_crossings(curves, frame)
    if spacing == "even":
        beta = np.linspace(0.0, 1.0, n_beta)
    else:
        candidates = np.round(np.linspace(0.0, 1.0, _CANDIDATE_BETAS), 12)
        _, xc, yc, _ = _nodes(curves, frame, candidates, c_choke, c_surge)
        beta = adaptive_beta(xc, yc, candidates, n_beta)
    t, x, y, e = _nodes(curves, frame, beta, c_choke, c_surge)
    p_err, e_err = table_errors(curves, t)
    return BetaTable(frame, beta, t, x, y, e, c_choke, c_surge, p_err, e_err)


def values_at(curves: CurveSet, frame: BetaFrame, idx: np.ndarray, beta: np.ndarray,
              c_choke: np.ndarray, c_surge: np.ndarray):
    """(flow, pressure, efficiency) at ``beta[j]`` on line ``idx[j]``, exactly on the fitted curve."""
    t = node_parameters(curves, frame, idx, beta, c_choke, c_surge)
    return curves.evaluate(np.asarray(idx, dtype=int), t)
