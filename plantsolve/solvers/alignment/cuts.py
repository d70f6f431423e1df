"""Choosing which connection to cut (paper §3: explosion and over-constrained systems).

Shared by both methods. The error impact of a connection is its gap plus its angle error
times the model's typical length, so position and angle errors compare in one unit.

The direct method reads the impacts on the pose where the network comes to rest with its connections
as springs (:func:`direct.settle_conflict`), which the network determines, not on the round's plateau,
where Gauss-Newton stopped running off along the conflict (round-off decides that one, hence the
factorisation, the frame, the unit and the order of the ids: measured on a 3 x 3 conflict grid, the
eight connections of the path between its tie-ins at 0.978 to 1 of the largest impact in cm and at
0.9996 to 1 in mm; the LDL^T's and the LU's plateaus 5 % apart). Connections in series on the path
of a conflict may still carry nearly the same share of it, and which of them looks largest is then
the last digits'. So impacts within :data:`CUT_MARGIN` of the largest (or within the
snapped residue) count as equal, and among them the connection that was measured worst is cut
(its gap and angle error in the request, which no solve, frame, unit or name changes); only where
those are equal too (a symmetric network) does where its ends lie decide (:attr:`Model.port_rank`):
never the input order, the names or round-off.
"""

from __future__ import annotations

import numpy as np

from plantsolve.solvers.alignment.model import Model

CUT_MARGIN = 0.05  # relative: impacts within 5 % of the largest are equally to blame (the factorisations' drift measured)
# the settled pose locates a conflict where the round's largest open impact is at least this share of the settled one's
SETTLED_SHARE = 0.01


def error_impact(model: Model, gap: np.ndarray, ang: np.ndarray) -> np.ndarray:
    return gap + ang * model.lref


def tie_width(model: Model, top: float) -> float:
    """Impacts within this of the largest are equal for the cut choice (units)."""
    return max(model.snap_pos, CUT_MARGIN * top)


def connection_key(model: Model, k: int) -> int:
    """The place of connection ``k`` in the stable order of the tie-break: its end first in :attr:`Model.port_rank`
    (where the network has its ports, never how they are listed or named)."""
    return int(min(model.port_rank[model.conn_a[k]], model.port_rank[model.conn_b[k]]))


def choose_cut(model: Model, active: np.ndarray, gap: np.ndarray, ang: np.ndarray, only_bad: bool = True) -> int | None:
    """Index of the connection to cut, or None if every active connection is within tolerance."""
    bad = active & ((gap > model.close_pos) | (ang > model.close_ang)) if only_bad else active.copy()
    if not np.any(bad):
        return None
    impact = error_impact(model, gap, ang)
    top = float(np.max(impact[bad]))
    near = np.flatnonzero(bad & (impact >= top - tie_width(model, top)))
    return worst_measured(model, near)


def worst_measured(model: Model, candidates: np.ndarray) -> int:
    """The candidate connection whose ends were furthest apart as measured (gap plus angle error times the
    typical length, in the request's pose); measured impacts within round-off of coordinates (the snapped
    residue, or 1e-9 of the largest) are equal, and where their ends lie decides among them (:func:`connection_key`)."""
    gap0, ang0 = model.measured_errors
    measured = error_impact(model, gap0[candidates], ang0[candidates])
    worst = float(np.max(measured))
    equal = candidates[measured >= worst - max(model.snap_pos, 1e-9 * worst)]
    return int(min(equal, key=lambda k: connection_key(model, k)))


def settled_locates(model: Model, left_open: np.ndarray, gap: np.ndarray, ang: np.ndarray, settled_gap: np.ndarray,
                    settled_ang: np.ndarray) -> bool:
    """Whether the settled pose's impacts say where the conflict of a round that left ``left_open`` open lies.

    The springs carry the conflict and a share of every scan gap the round closed. Where the round stalls far below
    the settled pose's impacts on the connections it left open (less than :data:`SETTLED_SHARE` of the largest), what
    is left open is no conflict of the size the springs carry: the scan gaps' shares decide the settled largest, and
    which connection that is says nothing of where the round stalled. Measured before the rounds refused a stale
    factorisation whose refinement does not contract (``kkt._refine``; since then those rounds close): the
    40,000-component plant-like network of ``bench/alignment.py`` (its tie-ins unmoved: it closes as built) stalled
    0.0187 mm open at one tee, where its settled impacts among the 241 connections left open reach 8.6 mm at another:
    cut there it stalled again (4 cuts where its own pose's largest took one); the 744 cut decisions of the 360
    conflicts of ``--conflicts`` stalled at 0.09 to 300 times the settled impacts but for 12, after the tie-in was cut
    on two 4 x 3 grids (4.5e-5 and 1e-4). The rule stays for a stall of another cause.
    Both impacts are in the request's unit, so the choice does not depend on it."""
    if not np.any(left_open):
        return False
    stalled = float(np.max(error_impact(model, gap[left_open], ang[left_open])))
    settled = float(np.max(error_impact(model, settled_gap[left_open], settled_ang[left_open])))
    return stalled >= SETTLED_SHARE * settled
