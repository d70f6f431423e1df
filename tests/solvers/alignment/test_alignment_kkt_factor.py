"""The block inverse of the cost, and the LU that takes over a Schur solve whose refinement does not converge."""

import numpy as np
import pytest
import qdldl
import scipy.sparse as sp
from alignment_cases import random_kkt_blocks
from scipy.sparse.linalg import splu, spsolve

from plantsolve.solvers.alignment.kkt import (
    DissectionFactor,
    SchurSolve,
    block_inverse,
    complement_factor,
    coupling_pattern,
    regularised_factor,
    use_schur,
)


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
    H, A, rng = random_kkt_blocks(seed)
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


def _laplacian_3d(side: int, shift: float) -> sp.csc_matrix:
    """The 7-point Laplacian of a side^3 grid plus ``shift`` on the diagonal: eigenvalues ``shift`` plus three of
    ``2 - 2 cos(k pi / (side + 1))``, so ``shift > 0`` is positive definite and ``shift = -1`` is not."""
    one = sp.diags([-np.ones(side - 1), 2 * np.ones(side), -np.ones(side - 1)], [-1, 0, 1])
    eye = sp.identity(side)
    lap = sp.kron(sp.kron(one, eye), eye) + sp.kron(sp.kron(eye, one), eye) + sp.kron(sp.kron(eye, eye), one)
    return (lap + shift * sp.identity(side**3)).tocsc()


def _tridiagonal(n: int, shift: float) -> sp.csc_matrix:
    """A path's Laplacian plus ``shift``: eigenvalues ``shift + 2 - 2 cos(k pi / (n + 1))``."""
    return (sp.diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1])
            + shift * sp.identity(n)).tocsc()


@pytest.mark.parametrize("matrix, dissected", [(_laplacian_3d(12, 1e-3), True), (_tridiagonal(500, 1e-3), False)],
                         ids=["grid", "path"])
def test_a_filling_sequence_is_dissected_from_its_second_factorisation(matrix, dissected):
    # QDLDL first; the 3-D grid's minimum-degree factor fills in many times the matrix, so the sequence's next
    # factorisations are ordered by nested dissection (SuperLU), once; the path's LDL^T has no fill and stays QDLDL's
    n = matrix.shape[0]
    b = np.random.default_rng(0).normal(size=n)
    x = spsolve(matrix, b)
    atol = 1e-10 * np.max(np.abs(x))
    cache: dict = {}
    first = complement_factor(sp.triu(matrix, format="csc"), n, cache)
    assert isinstance(first, qdldl.Solver)
    np.testing.assert_allclose(first.solve(b), x, rtol=0, atol=atol)
    assert bool(cache.get("dissect")) == dissected
    second = complement_factor(sp.triu(matrix, format="csc"), n, cache)
    assert isinstance(second, DissectionFactor) == dissected
    np.testing.assert_allclose(second.solve(b), x, rtol=0, atol=atol)
    if dissected:
        assert np.array_equal(np.sort(second.perm), np.arange(n)) and second.lu.nnz < 2 * first.factors()[0].nnz
        third = complement_factor(sp.triu(matrix * 1.5, format="csc"), n, cache)
        assert third.perm is second.perm  # the same pattern: the same ordering
        np.testing.assert_allclose(third.solve(b), x / 1.5, rtol=0, atol=atol)


@pytest.mark.parametrize("matrix", [_laplacian_3d(12, -1.0), _tridiagonal(500, -1.0)], ids=["grid", "path"])
def test_an_indefinite_matrix_is_refused_by_either_factorisation(matrix):
    n = matrix.shape[0]
    assert complement_factor(sp.triu(matrix, format="csc"), n, None) is None
    cache: dict = {}
    complement_factor(sp.triu(_laplacian_3d(12, 1e-3), format="csc"), 1728, cache)  # the pattern is dissected from here on
    assert complement_factor(sp.triu(_laplacian_3d(12, -1.0), format="csc"), 1728, cache) is None


def test_the_complement_keeps_the_couplings_pattern_when_the_jacobian_has_exact_zeros():
    # two steps of a 3-component chain: at the second, an axis-aligned run makes Jacobian entries and a coupling
    # exactly 0, and the product's pattern loses them; in the couplings' pattern the numbers are the same and the
    # pattern is not
    owner = np.repeat(np.arange(3), 3)
    rng = np.random.default_rng(4)
    dense = rng.normal(size=(4, 9))
    dense[:2, 6:] = 0.0  # rows 0, 1 join components 0 and 1; rows 2, 3 components 1 and 2
    dense[2:, :3] = 0.0
    Hinv = sp.block_diag([np.eye(3)] * 3, format="csr")
    patterns = []
    for step in range(2):
        A = dense.copy()
        if step:  # an axis-aligned step: rows 1 and 2 act on component 1 along perpendicular axes, their coupling is 0
            A[1, 3:6] = [1.0, 0.0, 0.0]
            A[2, 3:6] = [0.0, 1.0, 0.0]
        A = sp.csr_matrix(A)
        upper = sp.triu(A @ (Hinv @ A.T), format="csc")
        kept = coupling_pattern(upper.copy(), A, owner)
        np.testing.assert_array_equal(kept.toarray(), upper.toarray())
        patterns.append((kept.indptr.copy(), kept.indices.copy(), upper.nnz))
    assert patterns[0][2] != patterns[1][2]  # the product's own pattern changed
    assert all(np.array_equal(p, q) for p, q in zip(patterns[0][:2], patterns[1][:2]))


@pytest.mark.parametrize("schur", [True, False])
def test_the_regularised_factor_solves_the_matrix_with_its_compliance_not_the_constrained_one(schur):
    # springs, not constraints: [[H, A^T], [A, -delta I]] z = rhs as written (a penalised least squares), on the
    # Schur complement's LDL^T or the LU alike; the constrained solve would close A x = b exactly, this one does not
    rng = np.random.default_rng(5)
    n, m, delta = 30, 12, 1e-2
    blocks = [np.array([[rng.uniform(0.5, 2.0)]]) for _ in range(n)]
    H = sp.block_diag(blocks, format="csc")
    A = sp.random(m, n, density=0.3, random_state=3, format="csr") + sp.eye(m, n, format="csr")
    rhs = rng.normal(size=n + m)
    K = np.block([[H.toarray(), A.T.toarray()], [A.toarray(), -delta * np.eye(m)]])
    with use_schur(schur):
        z = regularised_factor(H, A, delta).solve(rhs)
    assert np.allclose(z, np.linalg.solve(K, rhs), rtol=0, atol=1e-12)
    assert np.max(np.abs(A @ z[:n] - rhs[n:])) > 1e-3  # the springs give: their force is (A x - b) / delta
