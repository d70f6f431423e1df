"""The FEM's linear solve is checked by its residual: multigrid CG that stops at its iteration cap without
converging (pyamg says nothing) gives way to the direct solve, so S is never read off an unconverged potential."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.flowmeter import fem


class _Stalled:
    """A multigrid solver that stops early: its answer is the right one scaled by 0.9 (a residual of 10 %)."""

    def __init__(self, a):
        self.a = a

    def solve(self, rhs, **_):
        from scipy.sparse.linalg import spsolve
        return 0.9 * spsolve(self.a.tocsc(), rhs)


def test_a_multigrid_solve_that_did_not_converge_is_replaced_by_the_direct_solve(monkeypatch):
    beta = np.radians(22.5)
    reference = fem.solve_patch(beta, 0.5, 2.0, h=0.12)  # 4,698 unknowns: the multigrid path
    assert reference.unknowns >= 3000
    monkeypatch.setattr(fem.pyamg, "smoothed_aggregation_solver", lambda a, **_: _Stalled(a))
    stalled = fem.solve_patch(beta, 0.5, 2.0, h=0.12)
    # main read S off the stalled potential: 0.9 of the electrode's reaction, S 10 % off with no word
    assert stalled.sensitivity == pytest.approx(reference.sensitivity, rel=1e-9)


def test_a_converged_multigrid_solve_is_kept_and_agrees_with_the_direct_one():
    from scipy.sparse import diags
    from scipy.sparse.linalg import spsolve

    n = 4000  # a 1-D Laplacian with a grounded end: SPD, the multigrid path
    a = diags([-np.ones(n - 1), 2 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1], format="csr")
    rhs = np.sin(np.linspace(0, 3, n))
    x = fem.potential(a, rhs)
    assert np.linalg.norm(rhs - a @ x) <= fem.AMG_RESIDUAL * np.linalg.norm(rhs)
    assert x == pytest.approx(spsolve(a.tocsc(), rhs), rel=1e-6, abs=1e-6 * np.abs(x).max())
