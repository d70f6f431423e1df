"""The KKT solve's two factorisations (LDL^T of the Schur complement, pivoted LU) and the result built from arrays."""

import importlib.util

import numpy as np
import pytest
import qdldl
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from plantsolve.schemas.alignment import AlignmentResult, Port
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.finalize import Outcome, build_result
from plantsolve.solvers.alignment.kkt import SchurSolve, block_inverse, constrained_lstsq, use_schur
from plantsolve.solvers.alignment.model import build_model
from plantsolve.solvers.alignment.synthetic import grid_network
from plantsolve.solvers.base import SolverError
from tests.conftest import REPO


def _problem(n=30, m=12, seed=0, duplicate=False):
    """Block-diagonal SPD cost (3x3 blocks, as the solver's per-component ones) and a full-rank constraint matrix."""
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(n // 3):
        B = rng.normal(size=(3, 3))
        blocks.append(B @ B.T + 0.5 * np.eye(3))
    H = sp.block_diag(blocks, format="csc")
    A = sp.random(m, n, density=0.3, random_state=seed, format="csr") + sp.eye(m, n, format="csr")
    if duplicate:  # a redundant constraint: the sum of the first two
        A = sp.vstack([A, A[0] + A[1]]).tocsr()
    g = rng.normal(size=n)
    b = A @ rng.normal(size=n)
    return H, g, A, b


def _dense_minimiser(H, g, A, b):
    """The exact constrained minimiser from the dense KKT system of the independent constraints."""
    Ad = A.toarray()
    keep = np.linalg.matrix_rank(Ad[:12]) == 12
    assert keep
    Ad, b = Ad[:12], b[:12]
    n, m = Ad.shape[1], Ad.shape[0]
    K = np.block([[H.toarray(), Ad.T], [Ad, np.zeros((m, m))]])
    return np.linalg.solve(K, np.concatenate([-g, b]))[:n]


def test_schur_solve_is_the_exact_constrained_minimiser():
    H, g, A, b = _problem()
    cache: dict = {}
    with use_schur():
        x, r, _ = constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-17, cache=cache)
    assert isinstance(cache["lu"], SchurSolve)  # the Schur complement's LDL^T was used, not the LU
    assert np.max(np.abs(x - _dense_minimiser(H, g, A, b))) < 1e-11 * np.max(np.abs(x))
    assert np.max(np.abs(r)) < 1e-12 * np.max(np.abs(b))


def test_default_is_the_schur_complement_and_the_lu_gives_the_same_minimiser():
    H, g, A, b = _problem(seed=3)
    cache: dict = {}
    x, _, _ = constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-17, cache=cache)
    assert isinstance(cache["lu"], SchurSolve)
    lu_cache: dict = {}
    with use_schur(False):
        y, _, _ = constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-17, cache=lu_cache)
    assert not isinstance(lu_cache["lu"], SchurSolve)
    assert np.max(np.abs(x - y)) < 1e-12 * np.max(np.abs(x))


@pytest.mark.parametrize("near", [1e-4, 1e-5])
def test_refined_schur_solve_is_the_lu_solve_of_the_regularised_matrix_near_a_singular_loop(near):
    # one constraint nearly the sum of two others (a loop near its singular configuration), one exactly
    # redundant: forming A H^-1 A^T squares the condition number, one elimination is off in x where the
    # LU of the regularised KKT matrix is not; refining on that matrix gives the LU's solution
    rng = np.random.default_rng(0)
    H, _, A, _ = _problem(n=60, m=30, seed=0)
    Ad = A.toarray()
    Ad[-1] = Ad[0] + Ad[1] + near * rng.normal(size=60)
    Ad[-2] = Ad[2] - Ad[3]
    A = sp.csr_matrix(Ad)
    delta = 1e-14
    Hinv = block_inverse(H)
    ldl = qdldl.Solver(sp.triu(A @ Hinv @ A.T + delta * sp.identity(30), format="csc"), upper=True)
    rhs = np.concatenate([rng.normal(size=60), A @ rng.normal(size=60)])
    K = sp.bmat([[H, A.T], [A, -delta * sp.identity(30)]], format="csc")
    factor = splu(K)
    exact = factor.solve(rhs)
    for _ in range(3):  # the LU's own refinement: the regularised system's solution to round-off
        exact += factor.solve(rhs - K @ exact)
    lu = exact[:60]
    once = SchurSolve(H, Hinv, A, ldl, delta)
    once.refinements = 0
    refined = SchurSolve(H, Hinv, A, ldl, delta)
    err_once, err_refined = (np.max(np.abs(s.solve(rhs)[:60] - lu)) / np.max(np.abs(lu)) for s in (once, refined))
    assert err_once > 1e-10  # measured 4e-10 and 1.3e-7 relative: cases where the elimination alone is off
    assert err_refined < 0.05 * err_once and err_refined < 1e-8  # measured 1000 and 3000 times closer


def _plant_network(side: int):
    """The bench's plant-like network (runs, branches, one loop, a tie-in at a run end)."""
    spec = importlib.util.spec_from_file_location("alignment_bench", REPO / "bench" / "alignment.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench.plant_network(side, options={"method": "direct"})


def test_schur_and_lu_give_the_same_gauss_newton_sequence_on_a_plant_like_network():
    # its loop is planar, singular at the solution: one elimination per Schur solve ended 3.5e-4 mm away
    req = _plant_network(20)
    with use_schur(False):
        lu = solve(req).result
    schur = solve(req).result
    P = [np.array([p.position for c in r.components for p in c.ports]) for r in (lu, schur)]
    assert lu.converged and schur.converged
    assert np.max(np.abs(P[0] - P[1])) < 1e-6  # mm (measured 7e-8), at coordinates of 1e6 mm


def test_redundant_constraint_still_gives_the_minimiser():
    H, g, A, b = _problem(seed=5, duplicate=True)
    with use_schur():
        x, r, _ = constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-17)
    assert np.max(np.abs(x - _dense_minimiser(H, g, A, b))) < 1e-9 * np.max(np.abs(x))
    assert np.max(np.abs(r)) < 1e-10 * np.max(np.abs(b))


def _kkt_point(H, g, A, b):
    n, m = H.shape[0], A.shape[0]
    K = np.block([[H.toarray(), A.toarray().T], [A.toarray(), np.zeros((m, m))]])
    return np.linalg.solve(K, np.concatenate([-g, b]))[:n]


def test_indefinite_cost_falls_back_to_the_lu():
    good, g, A, b = _problem(seed=1)
    bad = good.tolil()
    bad[0, 0] = -1.0  # an indefinite cost: the KKT matrix is no longer quasi-definite, no Schur complement
    bad = bad.tocsc()
    assert block_inverse(bad) is None
    cache: dict = {}
    with use_schur():
        x, _, _ = constrained_lstsq(bad, g, A, lambda x: b - A @ x, stop=1e-17, cache=cache)
    assert not isinstance(cache["lu"], SchurSolve)
    assert np.max(np.abs(x - _kkt_point(bad, g, A, b))) < 1e-9 * np.max(np.abs(x))  # the LU solved it


def test_block_inverse_of_the_per_component_cost():
    H, *_ = _problem(seed=6)
    Hp = H[np.random.default_rng(1).permutation(30)][:, np.random.default_rng(1).permutation(30)]
    for M in (H, Hp.tocsc()):
        np.testing.assert_allclose((block_inverse(M) @ M).toarray(), np.eye(30), atol=1e-12)
    assert block_inverse(sp.random(30, 30, density=0.5, random_state=0) + sp.eye(30)) is None  # one big block


def test_same_pattern_refactors_numbers_only():
    H, g, A, b = _problem(seed=2)
    cache: dict = {}
    with use_schur():
        constrained_lstsq(H, g, A, lambda x: b - A @ x, stop=1e-17, cache=cache)
        first = cache["ldl"][0]
        H2 = (2.5 * H).tocsc()
        x, _, _ = constrained_lstsq(H2, g, A, lambda x: b - A @ x, stop=1e-17, cache=cache)
    assert cache["ldl"][0] is first
    assert np.max(np.abs(x - _dense_minimiser(H2, g, A, b))) < 1e-11 * np.max(np.abs(x))


def test_schur_agrees_with_lu_on_a_loop_grid_at_plant_coordinates():
    req = grid_network(6, 6, valve_every=3, tie_ins=((0, 0), (5, 5)), origin=(1.0e6, 2.0e5, 1.0e4), seed=9,
                       options={"method": "direct"})
    with use_schur(False):
        lu = solve(req).result
    ldl = solve(req).result
    P = [np.array([p.position for c in r.components for p in c.ports]) for r in (lu, ldl)]
    assert lu.converged and ldl.converged and lu.cut_connections == ldl.cut_connections == []
    assert np.max(np.abs(P[0] - P[1])) < 1e-9  # mm, at coordinates of 1e6 mm (spacing of doubles there: 1.2e-10)


def test_result_built_from_arrays_serialises_like_validated_models():
    req = grid_network(3, 3, valve_every=2, tie_ins=((0, 0),), seed=4, options={"method": "direct"})
    res = solve(req).result
    assert isinstance(res.components[0].ports[0], Port)
    again = AlignmentResult.model_validate(res.model_dump(mode="json"))
    assert again.model_dump_json() == res.model_dump_json()
    assert res.connections[0].from_ == tuple(req.connections[0].from_)


def test_non_finite_result_names_the_array():
    req = grid_network(2, 2, tie_ins=((0, 0),), seed=1)
    model = build_model(req)
    P = model.P0.copy()
    P[3, 1] = np.nan
    out = Outcome(P=P, D=model.D0.copy(), iterations=1, stop_reason="test", active=np.ones(model.n_conn, dtype=bool),
                  snap=False)
    with pytest.raises(SolverError, match="non-finite values in P at index"):
        build_result(req, model, out, "direct")
