"""Choosing which connection to cut (paper §3: explosion and over-constrained systems).

Shared by both methods. The error impact of a connection is its gap plus its angle error
times the model's typical length, so position and angle errors compare in one unit. Impacts
closer than the solver can resolve (the snapped residue, in units, or 1e-6 of the impact) are
ties: a conflict spread evenly over symmetric connections must not be decided by round-off.
Ties are broken by the connection's (component id, port) pair, never by input order, so the
choice does not depend on how the request was sorted or on the factorisation's round-off.
"""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.alignment.model import Model


def error_impact(model: Model, gap: np.ndarray, ang: np.ndarray) -> np.ndarray:
    return gap + ang * model.lref


def tie_width(model: Model, top: float) -> float:
    """Impacts within this of the largest are equal to the solver (units)."""
    return max(model.snap_pos, 1e-6 * top)


def choose_cut(model: Model, active: np.ndarray, gap: np.ndarray, ang: np.ndarray, only_bad: bool = True) -> int | None:
    """Index of the connection to cut, or None if every active connection is within tolerance."""
    bad = active & ((gap > model.close_pos) | (ang > model.close_ang)) if only_bad else active.copy()
    if not np.any(bad):
        return None
    impact = error_impact(model, gap, ang)
    top = float(np.max(impact[bad]))
    near = np.flatnonzero(bad & (impact >= top - tie_width(model, top)))
    keys = [min(model.key[model.conn_a[k]], model.key[model.conn_b[k]]) for k in near]
    return int(near[min(range(len(near)), key=lambda i: keys[i])])
