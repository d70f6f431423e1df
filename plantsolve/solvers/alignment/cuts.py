"""Choosing which connection to cut (paper §3: explosion and over-constrained systems).

Shared by both methods. The error impact of a connection is its gap plus its angle error
times the model's typical length, so position and angle errors compare in one unit.

A conflict is a least-squares residual spread over the connections of a loop or a path between
tie-ins; where several carry nearly the same share, which one is largest is decided by the last
digits of the pose, and those depend on the factorisation: near a loop of catalogue fittings
(a singular point of its constraints) the pose is only resolved to about the square root of the
closing residual (measured: 5e-3 mm apart with LU and LDL^T on a 5 mm conflict, 1e-3 of it). So
impacts within :data:`CUT_MARGIN` of the largest (or within the snapped residue) count as equal,
and among them the connection whose smaller (component id, port) end sorts first is cut: never the
input order, never round-off.
"""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.alignment.model import Model

CUT_MARGIN = 0.01  # relative: impacts within 1 % of the largest are equally to blame


def error_impact(model: Model, gap: np.ndarray, ang: np.ndarray) -> np.ndarray:
    return gap + ang * model.lref


def tie_width(model: Model, top: float) -> float:
    """Impacts within this of the largest are equal for the cut choice (units)."""
    return max(model.snap_pos, CUT_MARGIN * top)


def connection_key(model: Model, k: int) -> tuple[str, int]:
    """The smaller (component id, port) end of connection ``k``: its place in the stable order of the tie-break."""
    return min(model.key[model.conn_a[k]], model.key[model.conn_b[k]])


def choose_cut(model: Model, active: np.ndarray, gap: np.ndarray, ang: np.ndarray, only_bad: bool = True) -> int | None:
    """Index of the connection to cut, or None if every active connection is within tolerance."""
    bad = active & ((gap > model.close_pos) | (ang > model.close_ang)) if only_bad else active.copy()
    if not np.any(bad):
        return None
    impact = error_impact(model, gap, ang)
    top = float(np.max(impact[bad]))
    near = np.flatnonzero(bad & (impact >= top - tie_width(model, top)))
    return int(min(near, key=lambda k: connection_key(model, k)))

