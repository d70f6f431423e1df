"""Speed changes of the direct method that must not change a number: each is compared with what it replaced."""

import numpy as np
import qdldl
import scipy.sparse as sp

from plantsolve.solvers.alignment import direct
from plantsolve.solvers.alignment.kkt import SchurSolve, block_inverse


def test_scaled_cost_is_the_two_diagonal_products_bit_for_bit():
    # a cost as the joint stage builds it: 7 x 7 pipe blocks and diagonal fitting entries, in COO with duplicates
    # (a pipe's rotation diagonal is entered twice), scaled by lengths of lref for translations and lengths
    rng = np.random.default_rng(6)
    lref = 3137.25
    rows, cols, vals = [], [], []
    start = 0
    for k in range(30):
        size = 7 if k % 2 else 6
        B = rng.normal(size=(size, size)) if k % 2 else np.diag(rng.uniform(0.1, 2.0, size))
        B = B @ B.T if k % 2 else B
        r, c = np.nonzero(np.ones((size, size)) if k % 2 else np.eye(size))
        rows += [start + r, start + np.arange(3)]; cols += [start + c, start + np.arange(3)]
        vals += [B[r, c], rng.uniform(0.5, 1.0, 3)]
        start += size
    H = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(start, start))
    H.data[::11] = 0.0  # explicit zeros: the products drop them
    sv = np.where(np.arange(start) % 7 >= 3, lref, 1.0)
    Ssv = sp.diags(sv)
    old = (Ssv @ H @ Ssv / lref**2).tocsc()
    new = direct.scaled_cost(H, sv, lref)
    assert H.nnz > new.nnz
    assert np.array_equal(new.indptr, old.indptr) and np.array_equal(new.indices, old.indices)
    assert np.array_equal(new.data, old.data)  # identical bits, not merely close


def test_schur_solve_with_held_transpose_is_the_regularised_kkt_solution():
    # the transpose held once is A's own arrays: solving after A's values change sees the change
    rng = np.random.default_rng(8)
    blocks = [np.array([[rng.uniform(0.5, 2.0)]]) for _ in range(12)]
    H = sp.block_diag(blocks, format="csc")
    A = sp.random(5, 12, density=0.4, random_state=4, format="csr") + sp.eye(5, 12, format="csr")
    delta = 1e-8
    upper = sp.triu(A @ block_inverse(H) @ A.T + delta * sp.identity(5), format="csc")
    ss = SchurSolve(H, block_inverse(H), A, qdldl.Solver(upper, upper=True), delta)
    assert np.shares_memory(ss.AT.data, A.data)
    rhs = rng.normal(size=17)
    K = sp.bmat([[H, A.T], [A, -delta * sp.identity(5)]], format="csc").toarray()
    np.testing.assert_allclose(ss.solve(rhs), np.linalg.solve(K, rhs), rtol=1e-9, atol=1e-12)
