"""A round that stalls far below what the settled pose's springs carry on the connections it left open is cut where it
stalled, on its own pose (``cuts.settled_locates``): there the springs' largest impact is a share of the scan gaps the
round closed, not the conflict, and cutting there leaves the stall where it was.

The 4 x 3 loop grid of seed 0 with its second tie-in 40 mm off and turned 2 degrees: cut twice at the tie-in, the third
round stalls 1.9e-4 mm open at ('N2-2', 1), where the settled impacts of the 19 connections it left open reach 3.9 to
4.2 mm; the settled pose's largest, ('N2-1', 3), is not where it stalled (the 40,000-component plant-like network of
``bench/alignment.py``: stalled 0.0187 mm open, settled 8.6 mm elsewhere, cut 4 times instead of once)."""

import numpy as np

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.cuts import SETTLED_SHARE, settled_locates
from plantsolve.solvers.alignment.model import build_model
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins


def _cuts(request: AlignmentRequest) -> set[frozenset]:
    res = solve(request).result
    assert res.converged
    return {frozenset({tuple(c.from_), tuple(c.to)}) for c in res.connections if c.cut}


def test_a_round_stalled_below_the_springs_is_cut_where_it_stalled():
    cuts = _cuts(conflicting_tie_ins(4, 3, seed=0, shift=(40.0, 0.0, 0.0), turn=2.0))
    at_tie_in = {frozenset({("P15", 1), ("N3-2", 0)}), frozenset({("P17", 1), ("N3-2", 1)})}
    assert cuts == at_tie_in | {frozenset({("P10", 1), ("N2-2", 1)})}


def test_settled_locates_compares_the_largest_open_impacts_in_any_unit():
    model = build_model(conflicting_tie_ins(2, 2, seed=0))
    n = model.n_conn
    left_open = np.zeros(n, dtype=bool)
    left_open[[0, 1]] = True
    none = np.zeros(n)
    settled = np.full(n, 4.0)
    settled[5] = 400.0  # a closed connection's share: not compared
    stalled = np.zeros(n)
    stalled[1] = 0.999 * SETTLED_SHARE * 4.0
    assert not settled_locates(model, left_open, stalled, none, settled, none)
    stalled[1] = SETTLED_SHARE * 4.0
    assert settled_locates(model, left_open, stalled, none, settled, none)
    assert not settled_locates(model, np.zeros(n, dtype=bool), stalled, none, settled, none)
