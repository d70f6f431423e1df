"""A Schur solve whose residual stops falling fourfold while its correction of x still halves is carried on by the
elimination, not handed to the pivoted LU (#42: on the 19,365-component plant-like network one feasibility step's
residual fell 0.26 a step, its correction 0.18, and the LU it went to cost the crawl a factorisation and 49 solves
five times as dear as an elimination)."""

import numpy as np
import scipy.sparse as sp
from alignment_cases import random_kkt_blocks
from scipy.sparse.linalg import splu

from plantsolve.solvers.alignment.kkt import SchurSolve, block_inverse


def _kkt(seed: int = 3):
    H, A, rng = random_kkt_blocks(seed)
    delta = 1e-14
    Hinv = block_inverse(H)
    S = A @ Hinv @ A.T + delta * sp.identity(12)
    K = sp.bmat([[H, A.T], [A, -delta * sp.identity(12)]], format="csc")
    rhs = np.concatenate([np.zeros(30), rng.normal(size=12)])  # a feasibility step: no gradient
    return H, Hinv, A, S, delta, rhs, splu(K).solve(rhs)


class _Scaled:
    """A factor of ``scale`` times the complement: each elimination leaves ``1 - 1 / scale`` of the multipliers'
    error."""

    def __init__(self, S: sp.spmatrix, scale: float):
        self.lu = splu(sp.csc_matrix(scale * S))

    def solve(self, b):
        return self.lu.solve(b)


def _first_steps(H, Hinv, A, ldl, delta, rhs, k):
    """The corrections of x of the first ``k`` refinement steps, each on the solution before."""
    solver = SchurSolve(H, Hinv, A, ldl, delta)
    sol, out = solver._eliminate(rhs), []
    for _ in range(k):
        fix = solver._eliminate(solver._residual(rhs, sol))
        sol += fix
        out.append(float(np.max(np.abs(fix[:30]))))
    return out


def test_a_slowly_converging_elimination_is_carried_on_not_replaced_by_the_lu():
    H, Hinv, A, S, delta, rhs, exact = _kkt()
    ldl = _Scaled(S, 0.7)  # the error falls to -0.43 a step: the residual's fourfold test stops it after one step
    steps = _first_steps(H, Hinv, A, ldl, delta, rhs, 3)
    size = float(np.max(np.abs(exact[:30])))
    assert steps[0] > SchurSolve.diverged * size  # where refinement stopped before, the LU took over
    assert steps[1] < 0.5 * steps[0]
    solver = SchurSolve(H, Hinv, A, ldl, delta)
    x = solver.solve(rhs)
    assert solver.lu is None
    # within what the elimination's own convergence test accepts of x, and closer than one step left it
    err = float(np.max(np.abs(x - exact)[:30]))
    assert err < SchurSolve.diverged * size
    assert err < steps[0]


def test_an_elimination_whose_correction_does_not_halve_still_goes_to_the_lu():
    H, Hinv, A, S, delta, rhs, exact = _kkt()
    ldl = _Scaled(S, 0.6)  # the error falls to -0.67 a step: no halving
    solver = SchurSolve(H, Hinv, A, ldl, delta)
    x = solver.solve(rhs)
    assert solver.lu is not None
    np.testing.assert_allclose(x, exact, rtol=0, atol=1e-12 * np.max(np.abs(exact)))
