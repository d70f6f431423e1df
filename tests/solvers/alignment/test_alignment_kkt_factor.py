"""The block inverse of the cost, and the LU that takes over a Schur solve whose refinement does not converge."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from plantsolve.solvers.alignment.kkt import SchurSolve, block_inverse


def test_block_inverse_of_numbers_and_blocks():
    # fittings' costs are diagonal (blocks of one variable), pipes' 7 x 7: both in one matrix, shuffled
    rng = np.random.default_rng(2)
    blocks = []
    for k in range(40):
        if k % 3:
            blocks.append(np.array([[rng.uniform(0.5, 2.0)]]))
        else:
            B = rng.normal(size=(7, 7))
            blocks.append(B @ B.T + 0.5 * np.eye(7))
    H = sp.block_diag(blocks, format="csc")
    p = rng.permutation(H.shape[0])
    Hp = H[p][:, p].tocsc()
    Hi = block_inverse(Hp)
    assert Hi is not None
    np.testing.assert_allclose((Hi @ Hp).toarray(), np.eye(H.shape[0]), rtol=0, atol=1e-12)
    one = np.flatnonzero(np.diff(Hp.tocsr().indptr) == 1)
    assert len(one) == sum(len(b) == 1 for b in blocks)
    assert np.array_equal(Hi.diagonal()[one], 1.0 / Hp.diagonal()[one])  # numbers are inverted as numbers
    assert np.all(np.diff(Hi.indptr) == np.diff(Hp.tocsr().indptr))  # an inverse block has its block's pattern


@pytest.mark.parametrize("where", ["number", "block"])
def test_block_inverse_refuses_a_cost_that_is_not_positive_definite(where):
    blocks = [np.array([[2.0]]), np.eye(7) * 3.0, np.array([[1.0]])]
    if where == "number":
        blocks[2] = np.array([[-1.0]])
    else:
        blocks[1] = np.eye(7) * 3.0 - 4.0 * np.outer(np.eye(7)[0], np.eye(7)[0])
    assert block_inverse(sp.block_diag(blocks, format="csc")) is None


def _kkt(seed: int = 3):
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(10):
        B = rng.normal(size=(3, 3))
        blocks.append(B @ B.T + 0.5 * np.eye(3))
    H = sp.block_diag(blocks, format="csc")
    A = sp.csr_matrix(rng.normal(size=(12, 30)))
    return H, A, rng.normal(size=42)


class _Scaled:
    """A factor of ``scale`` times the complement: its elimination is off by a factor ``1 / scale``."""

    def __init__(self, S: sp.spmatrix, scale: float):
        self.lu = splu(sp.csc_matrix(scale * S))

    def solve(self, b):
        return self.lu.solve(b)


def test_a_schur_solve_that_does_not_converge_is_the_lus():
    H, A, rhs = _kkt()
    delta = 1e-14
    Hinv = block_inverse(H)
    S = A @ Hinv @ A.T + delta * sp.identity(12)
    K = sp.bmat([[H, A.T], [A, -delta * sp.identity(12)]], format="csc")
    lu = splu(K).solve(rhs)
    # a third of the complement: every refinement step multiplies the error by -2, it never converges
    diverging = SchurSolve(H, Hinv, A, _Scaled(S, 1 / 3), delta)
    assert np.array_equal(diverging.solve(rhs), lu)
    assert diverging.lu is not None
    assert np.array_equal(diverging.solve(2 * rhs), splu(K).solve(2 * rhs))  # later solves too
    # the complement itself: the elimination converges, no LU
    sound = SchurSolve(H, Hinv, A, _Scaled(S, 1.0), delta)
    x = sound.solve(rhs)
    assert sound.lu is None
    assert np.max(np.abs(x - lu)[:30]) < 1e-12 * np.max(np.abs(lu[:30]))
