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
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
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
    lu = _factor(H, A)
    if cache is not None:
        cache.update(lu=lu, shape=(n, m))
    return _refine(H, g, A, residual, lu, stop, max_iter, stale=False)


def _factor(H: sp.spmatrix, A: sp.spmatrix):
    """Sparse LU of the regularised (quasi-definite) KKT matrix."""
    m = A.shape[0]
    hd = H.diagonal()
    col = np.asarray(abs(A).power(2).sum(axis=0)).ravel()
    scale = np.median(hd[hd > 0]) if np.any(hd > 0) else 1.0
    acol = np.median(col[col > 0]) if np.any(col > 0) else 1.0
    delta = 1e-14 * acol / scale
    K = sp.bmat([[H, A.T], [A, -delta * sp.identity(m)]], format="csc")
    return splu(K)



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
