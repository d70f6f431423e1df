"""Sparse equality-constrained least squares that tolerates redundant constraints.

Orthogonal loops make the constraint Jacobian rank deficient, so the plain KKT matrix
``[[H, A^T], [A, 0]]`` is singular. We factor the quasi-definite regularised matrix
``[[H, A^T], [A, -delta I]]`` and use it as the preconditioner of an iterative
refinement on the exact KKT system. For consistent constraints this converges to the
exact constrained minimiser; for inconsistent ones ``x`` converges to the minimiser under
the constraints' projection onto range(A) and the residual that remains is the conflict,
which is exactly what the cut logic needs. The residual callback may evaluate ``b - A x``
in extended precision, which is where the last digits of the closure are decided.

A factorisation may be passed back in (``cache``): near convergence of an outer
Gauss-Newton loop the matrix barely changes, and the refinement, which always uses the
current ``H`` and ``A``, converges with a slightly stale preconditioner too.

When ``H`` is block diagonal with small blocks (one block per component in the joint
solve) the regularised system is solved through its Schur complement
``S = A H^-1 A^T + delta I``: ``H^-1`` is exact and as sparse as ``H``, and ``S`` is
symmetric positive definite, so it is factored without pivoting under a symmetric
minimum-degree ordering. The indefinite KKT matrix instead needs threshold pivoting, which
breaks any symmetric ordering, and its column ordering fills in much faster than the network
grows. Forming ``S`` loses what ``H^-1`` and the redundant constraints put below round-off,
so each solve with it takes one refinement step on the regularised KKT matrix, and the
factorisation is only kept when its pivots are those of a positive definite matrix and a
probe solve is backward stable like the LU's (redundant rotation constraints on planar loops,
and small networks with nearly redundant ones, fail that and use the LU).

What remains superlinear is elimination itself: on a network where every cell is a loop (a
planar grid) any elimination order fills ~n log n entries and costs ~n^1.5 operations
(separator bound); measured on the bench grids, the factor of ``S`` grows with exponent 1.2 in
entries and 1.3-1.5 in time from 3,000 to 35,000 components. On a tree network ``S`` has an
elimination order without fill (from the leaves in).
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu


def constrained_lstsq(
    H: sp.spmatrix,
    g: np.ndarray,
    A: sp.spmatrix,
    residual: Callable[[np.ndarray], np.ndarray],
    *,
    stop: float,
    max_iter: int = 12,
    cache: dict | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Minimise ``0.5 x'Hx + g'x`` subject to ``A x = b`` with ``residual(x) = b - A x``.

    Returns ``(x, residual(x), refinement steps)``.
    """
    n, m = H.shape[0], A.shape[0]
    if m == 0:
        x = splu(sp.csc_matrix(H)).solve(-g) if n else np.zeros(0)
        return x, residual(x), 1
    if cache is not None and cache.get("shape") == (n, m) and cache.get("reuse"):
        out = _refine(H, g, A, residual, cache["lu"], stop, max_iter, stale=True)
        if out is not None:
            return out
    if cache is not None:
        cache.pop("lu", None)  # never hold two factorisations at once (peak memory)
    # a sequence whose Schur complement failed twice in a row (redundant constraints that stay) stops trying it
    try_schur = cache is None or cache.get("schur_rejected", 0) < 2
    lu = _factor(H, A, try_schur, cache)
    if cache is not None:
        cache.update(lu=lu, shape=(n, m))
        if try_schur:
            cache["schur_rejected"] = 0 if isinstance(lu, _SchurFactor) else cache.get("schur_rejected", 0) + 1
    return _refine(H, g, A, residual, lu, stop, max_iter, stale=False)


def _factor(H: sp.spmatrix, A: sp.spmatrix, try_schur: bool = True, cache: dict | None = None):
    """Factorisation of the regularised (quasi-definite) KKT matrix: through the Schur complement
    when ``H`` is block diagonal and that is accurate, else a sparse LU of the whole matrix.
    ``cache`` keeps the Schur complement's ordering for the next matrix of the same pattern."""
    m = A.shape[0]
    hd = H.diagonal()
    col = np.asarray(abs(A).power(2).sum(axis=0)).ravel()
    scale = np.median(hd[hd > 0]) if np.any(hd > 0) else 1.0
    acol = np.median(col[col > 0]) if np.any(col > 0) else 1.0
    delta = 1e-14 * acol / scale
    Hinv = _block_inverse(H) if try_schur else None
    if Hinv is not None:
        try:
            schur = _SchurFactor(sp.csr_matrix(H), Hinv, sp.csr_matrix(A), delta, cache)
        except RuntimeError:  # a zero pivot: S is singular to working precision
            schur = None
        if schur is not None and schur.accurate():
            return schur
        del schur  # never hold two factorisations at once (peak memory)
    K = sp.bmat([[H, A.T], [A, -delta * sp.identity(m)]], format="csc")
    return splu(K)


_MAX_BLOCK = 16


def _block_inverse(H: sp.spmatrix) -> sp.csr_matrix | None:
    """Exact inverse of a block-diagonal ``H`` (blocks = connected parts of its pattern), or None
    when a block is larger than ``_MAX_BLOCK`` or singular."""
    H = sp.csr_matrix(H)
    n = H.shape[0]
    nb, label = connected_components(H, directed=False)
    size = np.bincount(label, minlength=nb)
    if n == 0 or size.max() > _MAX_BLOCK:
        return None
    s = int(size.max())
    by_block = np.argsort(label, kind="stable")
    first = np.concatenate([[0], np.cumsum(size)[:-1]])
    local = np.empty(n, dtype=np.intp)
    local[by_block] = np.arange(n) - first[label[by_block]]
    # blocks smaller than the largest are padded with an identity, which their inverse keeps apart
    B = np.zeros((nb, s, s))
    B[:, np.arange(s), np.arange(s)] = (np.arange(s)[None, :] >= size[:, None])
    C = H.tocoo()
    B[label[C.row], local[C.row], local[C.col]] = C.data
    try:
        Bi = np.linalg.inv(B)
    except np.linalg.LinAlgError:
        return None
    Bi = 0.5 * (Bi + Bi.transpose(0, 2, 1))  # S is then symmetric to the last bit
    index = np.full((nb, s), -1, dtype=np.intp)
    index[label[by_block], local[by_block]] = by_block
    keep = (index[:, :, None] >= 0) & (index[:, None, :] >= 0)
    rows = np.broadcast_to(index[:, :, None], B.shape)[keep]
    cols = np.broadcast_to(index[:, None, :], B.shape)[keep]
    return sp.csr_matrix((Bi[keep], (rows, cols)), shape=(n, n))


class _SchurFactor:
    """Solves ``K [x; y] = [r1; r2]`` with ``K = [[H, A^T], [A, -delta I]]`` as
    ``(A H^-1 A^T + delta I) y = A H^-1 r1 - r2``, ``x = H^-1 (r1 - A^T y)``, plus one step of
    iterative refinement on ``K``."""

    # normwise backward error a probe solve must reach: the unit round-off, which the LU of K meets
    # (measured 2e-19..5e-17); inaccurate Schur solves were at 4e-16 and above
    PROBE_TOL = 0.5 * np.finfo(float).eps

    def __init__(self, H: sp.csr_matrix, Hinv: sp.csr_matrix, A: sp.csr_matrix, delta: float,
                 cache: dict | None = None):
        self.n = H.shape[0]
        self.H, self.Hinv, self.A, self.delta = H, Hinv, A, delta
        self.C = (A @ Hinv).tocsr()  # A H^-1; its transpose is H^-1 A^T because H^-1 is symmetric
        S = (self.C @ A.T + delta * sp.identity(A.shape[0])).tocsc()
        S.sort_indices()
        # positive definite: no pivoting, so the minimum-degree ordering of S + S^T is kept
        options = {"diag_pivot_thresh": 0.0, "options": {"SymmetricMode": True}}
        known = cache.get("schur_order") if cache is not None else None
        if known is not None and np.array_equal(known[0], S.indptr) and np.array_equal(known[1], S.indices):
            # a Gauss-Newton sequence keeps the pattern of S: its ordering (a quarter of the factor time) is reused
            self.order = known[2]
            S = S[self.order][:, self.order].tocsc()
            S.sort_indices()
            self.lu = splu(S, permc_spec="NATURAL", **options)
        else:
            self.order = None
            self.lu = splu(S, permc_spec="MMD_AT_PLUS_A", **options)
            if cache is not None:
                cache["schur_order"] = (S.indptr, S.indices, np.argsort(self.lu.perm_c))

    def _apply(self, z: np.ndarray) -> np.ndarray:
        x, y = z[: self.n], z[self.n:]
        return np.concatenate([self.H @ x + self.A.T @ y, self.A @ x - self.delta * y])

    def _once(self, rhs: np.ndarray) -> np.ndarray:
        r1, r2 = rhs[: self.n], rhs[self.n:]
        b = self.C @ r1 - r2
        if self.order is None:
            y = self.lu.solve(b)
        else:
            y = np.empty_like(b)
            y[self.order] = self.lu.solve(b[self.order])
        return np.concatenate([self.Hinv @ r1 - self.C.T @ y, y])

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        z = self._once(rhs)
        return z + self._once(rhs - self._apply(z))

    def accurate(self) -> bool:
        """Positive pivots (S + delta I has none below delta) and a probe solved backward stably:
        ``|r - K z| <= tol (|K| |z| + |r|)`` in the max norm."""
        if not float(np.min(self.lu.U.diagonal())) >= 0.5 * self.delta:
            return False
        rng = np.random.default_rng(0)
        rhs = np.concatenate([rng.normal(size=self.n), self.A @ rng.normal(size=self.n)])
        z = self.solve(rhs)
        if not np.all(np.isfinite(z)):
            return False
        absA = abs(self.A)
        norm_k = max(float(np.max(np.asarray(abs(self.H).sum(axis=1)).ravel() + np.asarray(absA.sum(axis=0)).ravel())),
                     float(np.max(np.asarray(absA.sum(axis=1)).ravel())) + self.delta)
        err = float(np.max(np.abs(self._apply(z) - rhs)))
        return err <= self.PROBE_TOL * (norm_k * float(np.max(np.abs(z))) + float(np.max(np.abs(rhs))))


def _refine(H, g, A, residual, lu, stop, max_iter, stale):
    """Iterative refinement; with a stale factorisation returns None if it does not contract."""
    n, m = H.shape[0], A.shape[0]
    x = np.zeros(n)
    lam = np.zeros(m)
    r2 = residual(x)
    start = float(np.max(np.abs(r2))) if m else 0.0
    best = np.inf
    stall = 0
    steps = 0
    for steps in range(1, max_iter + 1):
        r1 = -(H @ x + g + A.T @ lam)
        sol = lu.solve(np.concatenate([r1, r2]))
        if stale and not np.all(np.isfinite(sol)):
            return None
        if stale and steps == 1 and float(np.max(np.abs(sol[:n]))) > 1e3 * (1.0 + start):
            return None
        x += sol[:n]
        lam += sol[n:]
        r2 = residual(x)
        err = float(np.max(np.abs(r2)))
        if stale and (not np.isfinite(err) or (steps == 1 and not err < start)):
            return None
        step = float(np.max(np.abs(sol[:n]))) if n else 0.0
        if err <= stop and step <= max(stop, 1e-14 * (1.0 + float(np.max(np.abs(x))))):
            break
        if err < 0.5 * best:
            best, stall = err, 0
        else:
            stall += 1
            if stall >= 3:
                break
    return x, r2, steps
