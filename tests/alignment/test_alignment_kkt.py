"""The constrained least-squares solve: the Schur-complement path gives the LU path's answer, and
systems where forming the Schur complement loses accuracy are recognised and go to the LU."""

import numpy as np
import scipy.sparse as sp

from plantsolve.solvers.alignment import kkt


def _block_diagonal(rng, sizes):
    blocks = []
    for s in sizes:
        M = rng.normal(size=(s, s))
        blocks.append(M @ M.T + s * np.eye(s))
    return sp.block_diag(blocks, format="csc")


def _problem(seed, redundant=False):
    rng = np.random.default_rng(seed)
    sizes = rng.choice([6, 7], size=40)
    H = _block_diagonal(rng, sizes)
    n = H.shape[0]
    A = sp.random(90, n, density=0.05, random_state=seed, format="csr") + sp.eye(90, n, format="csr")
    if redundant:
        A = sp.vstack([A, A[:10] + A[10:20]]).tocsr()  # exactly dependent rows
    g = rng.normal(size=n)
    b = A @ rng.normal(size=n)
    return H, g, A, b


def _dense_solution(H, g, A, b):
    n, m = H.shape[0], A.shape[0]
    K = np.block([[H.toarray(), A.T.toarray()], [A.toarray(), np.zeros((m, m))]])
    return np.linalg.lstsq(K, np.concatenate([-g, b]), rcond=None)[0][:n]


def test_block_inverse_is_exact_and_refuses_large_blocks():
    rng = np.random.default_rng(1)
    H = _block_diagonal(rng, [1, 3, 7, 2])
    Hinv = kkt._block_inverse(H)
    np.testing.assert_allclose((Hinv @ H).toarray(), np.eye(H.shape[0]), atol=1e-12)
    assert kkt._block_inverse(_block_diagonal(rng, [kkt._MAX_BLOCK + 1])) is None


def test_schur_path_matches_the_lu_of_the_whole_matrix():
    H, g, A, b = _problem(3)
    factor = kkt._factor(H, A)
    assert isinstance(factor, kkt._SchurFactor)
    x, r, _ = kkt._refine(H, g, A, lambda x: b - A @ x, factor, 1e-14, 12, stale=False)
    lu = kkt._factor(H, A, try_schur=False)
    x_lu, _, _ = kkt._refine(H, g, A, lambda x: b - A @ x, lu, 1e-14, 12, stale=False)
    np.testing.assert_allclose(x, x_lu, rtol=0, atol=1e-10 * np.max(np.abs(x_lu)))
    np.testing.assert_allclose(x, _dense_solution(H, g, A, b), rtol=0, atol=1e-9 * np.max(np.abs(x_lu)))
    assert np.max(np.abs(r)) <= 1e-12 * np.max(np.abs(b))


def test_redundant_constraints_give_the_same_minimiser_either_way():
    H, g, A, b = _problem(4, redundant=True)
    cache: dict = {}
    x, r, _ = kkt.constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-14, max_iter=12, cache=cache)
    x_lu, _, _ = kkt._refine(H, g, A, lambda x: b - A @ x, kkt._factor(H, A, try_schur=False), 1e-14, 12,
                             stale=False)
    np.testing.assert_allclose(x, x_lu, rtol=0, atol=1e-9 * np.max(np.abs(x_lu)))
    assert np.max(np.abs(r)) <= 1e-11 * np.max(np.abs(b))


def test_a_sequence_stops_trying_a_rejected_schur_complement():
    H, g, A, b = _problem(5)
    cache = {"schur_rejected": 2}
    kkt.constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-14, max_iter=12, cache=cache)
    assert not isinstance(cache["lu"], kkt._SchurFactor)
    cache = {"schur_rejected": 1}
    kkt.constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-14, max_iter=12, cache=cache)
    assert isinstance(cache["lu"], kkt._SchurFactor) and cache["schur_rejected"] == 0


def test_badly_scaled_weights_with_redundant_constraints_go_to_the_lu():
    # stiffness spread over eight decades: A H^-1 A^T keeps too few digits for its probe solve
    H, g, A, b = _problem(6, redundant=True)
    d = np.exp(np.random.default_rng(2).uniform(0, np.log(1e8), H.shape[0]))
    H = (sp.diags(np.sqrt(d)) @ H @ sp.diags(np.sqrt(d))).tocsc()
    assert not isinstance(kkt._factor(H, A), kkt._SchurFactor)
    x, r, _ = kkt.constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-14, max_iter=12)
    assert np.max(np.abs(r)) <= 1e-10 * np.max(np.abs(b))


def test_a_second_matrix_of_the_same_pattern_reuses_the_ordering_and_agrees_with_the_lu():
    H, g, A, b = _problem(7)
    cache: dict = {}
    kkt.constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-14, max_iter=12, cache=cache)
    assert cache["lu"].order is None
    H2 = H.copy()
    H2.data *= 1.5  # new values, same pattern
    x, _, _ = kkt.constrained_lstsq(H2, g, A, lambda x: b - A @ x, stop=1e-14, max_iter=12, cache=cache)
    assert cache["lu"].order is not None
    x_lu, _, _ = kkt._refine(H2, g, A, lambda x: b - A @ x, kkt._factor(H2, A, try_schur=False), 1e-14, 12,
                             stale=False)
    np.testing.assert_allclose(x, x_lu, rtol=0, atol=1e-10 * np.max(np.abs(x_lu)))
