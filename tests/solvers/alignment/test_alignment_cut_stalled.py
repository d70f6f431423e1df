"""A round that stalls far below what the settled pose's springs carry on the connections it left open is cut where it
stalled, on its own pose (``cuts.settled_locates``): there the springs' largest impact is a share of the scan gaps the
round closed, not the conflict, and cutting there leaves the stall where it was.

The stalls measured were a refinement on a stale factorisation returned as the Gauss-Newton step (the 4 x 3 grid of
seed 0 after its tie-in's cuts, 1.9e-4 mm open; the 40,000-component plant-like network of ``bench/alignment.py``,
0.0187 mm open where the settled impacts reached 8.6 mm elsewhere): those rounds now close
(test_align49_stale_refinement.py), and the rule stays for a stall of any other cause."""

import numpy as np

from plantsolve.solvers.alignment.cuts import SETTLED_SHARE, settled_locates
from plantsolve.solvers.alignment.model import build_model
from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins


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
