"""A Gauss-Newton step refined on an earlier step's factorisation is kept only while that refinement contracts
(``kkt._refine``): each step at least halves the constraint residual until it is a thousandth of its start, else a
fresh factorisation solves the step. Before, a refinement that crawled (5 % a step) or oscillated was returned as the
step, and the round's Gauss-Newton stalled on it: the 40,000-component plant-like network of ``bench/alignment.py``
stopped 0.018 mm open and was cut, the 4 x 3 grid below a third time after its tie-in's two cuts.

The stale factorisations here are of the same problem with its first constraint row scaled: refinement on them
contracts by ``|1 - 1/s|`` a step (2/3 for s = 0.6, 1/3 for s = 1.5)."""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from plantsolve.solvers.alignment.kkt import constrained_lstsq
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins

H = sp.identity(4, format="csc")
A = sp.csr_matrix(np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]))
B = np.array([1.0, 2.0])
EXACT = np.array([1.0, 2.0, 0.0, 0.0])  # the least-norm point on A x = B


def _stale(scale: float, crawl: bool = False) -> dict:
    """A cache holding the factorisation of the KKT matrix with A's first row scaled by ``scale``."""
    A0 = sp.csr_matrix(np.diag([scale, 1.0]) @ A.toarray())
    K0 = sp.bmat([[H, A0.T], [A0, -1e-14 * sp.identity(2)]], format="csc")
    return {"lu": splu(K0), "shape": (4, 2), "reuse": True, "crawl": crawl}


def _solve(cache: dict):
    return constrained_lstsq(H, np.zeros(4), A, lambda x: B - A @ x, stop=1e-14, max_iter=30, cache=cache)


def test_a_stale_factorisation_that_contracts_slowly_is_refused_for_a_fresh_one():
    cache = _stale(0.6)
    stale = cache["lu"]
    x, r, steps = _solve(cache)
    assert cache["lu"] is not stale  # refactored
    # the exact step (before: 5.2e-6 of constraint residual left after 30 steps)
    assert np.max(np.abs(x - EXACT)) < 1e-12 and np.max(np.abs(r)) < 1e-12
    assert 3 <= steps <= 6  # the refused refinement's steps are counted with the fresh one's


def test_a_stale_factorisation_that_contracts_is_kept():
    cache = _stale(1.5)
    stale = cache["lu"]
    x, _, _ = _solve(cache)
    assert cache["lu"] is stale
    assert np.max(np.abs(x - EXACT)) < 1e-12


def test_in_a_rounds_crawl_a_slowly_contracting_stale_factorisation_is_kept():
    # below what snapping closes (direct.solve_joint's crawl) the rounds keep refining on it, on either
    # factorisation alike, so that their answers stay together
    cache = _stale(0.6, crawl=True)
    stale = cache["lu"]
    _solve(cache)
    assert cache["lu"] is stale


def test_a_grid_whose_tie_in_is_cut_closes_without_a_third_cut():
    # the 4 x 3 loop grid of seed 0 with its second tie-in 40 mm off and turned 2 degrees: once the tie-in's two
    # connections are cut, the rest is a grid of loops held at one corner, which closes (before: its round stalled
    # 1.4e-4 mm open at ('N2-2', 1) and that connection was cut too)
    res = solve(conflicting_tie_ins(4, 3, seed=0, shift=(40.0, 0.0, 0.0), turn=2.0)).result
    assert res.converged
    cuts = {frozenset({tuple(c.from_), tuple(c.to)}) for c in res.connections if c.cut}
    assert cuts == {frozenset({("P15", 1), ("N3-2", 0)}), frozenset({("P17", 1), ("N3-2", 1)})}
    assert res.max_position_error == 0.0  # every connection left is closed (snapped)
