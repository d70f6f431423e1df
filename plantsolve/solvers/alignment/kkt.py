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

The cost is block diagonal (one small block per component), so by default the system is solved
by eliminating it: the Schur complement ``A H^-1 A^T + delta I`` is symmetric positive definite and
factored by LDL^T (QDLDL, approximate minimum degree ordering, kept while a Gauss-Newton sequence
keeps the pattern); a pivoted sparse LU of the regularised matrix where a pivot is not positive, the
cost is not block diagonal, or within ``use_schur(False)``. Positive definiteness makes it stable
under any ordering, unlike an LDL^T of the quasi-definite KKT matrix itself, whose tiny ``-delta``
pivots, once the ordering takes them before their cost block, grow the factors by ``1/delta``
(measured: backward errors of 1e20 on a 47-row system whose inertia was right).

Forming the complement squares the condition number, which matters where a loop is nearly
singular: a planar loop of catalogue fittings is a singular point of its constraints (the
Jacobian loses rank at the solution, Gauss-Newton halves its distance per step there), and one
elimination is then off by up to 1e-2 of the step where the LU is not. The Gauss-Newton sequences
built on the two followed different paths along the loops' flat directions and ended up to
3.5e-4 mm apart (1.3e-4 mm on the 10,000-component plant-like bench network). Each Schur solve
is therefore refined on the same regularised matrix (:class:`SchurSolve`), which gives the LU's
solution back: the sequences then end 1e-7 mm apart on plant-like networks, 3e-11 mm on loop grids.
Where that refinement does not converge (at a singular point one elimination can be off by more than
the step itself), the system and its later right-hand sides go to the pivoted LU of the regularised
matrix instead.
Measured in one bench run (bench/alignment.py), refinements included: 0.45-0.55 of the LU's CPU time
and 0.6-0.7 of its peak memory on loop grids of 3,351 to 34,749 components, 0.86-0.93 of its time and
0.8 of its memory on plant-like networks of 10,000 and 100,000. Where a connection has to be cut,
the cut is decided on an LU pass (solve.py), one pass more per cut: 1.3 times the LU's time on the
40,000-component plant-like network, which needs one.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np
import qdldl
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

# per thread and task, as numpy's errstate: one solve's choice never leaks into another running beside it
_SCHUR: ContextVar[bool] = ContextVar("schur", default=True)


@contextmanager
def use_schur(on: bool = True) -> Iterator[None]:
    """Within this block KKT systems are solved through the Schur complement where it is positive
    definite (``on``), or all by the pivoted LU (``on=False``); see the module doc."""
    token = _SCHUR.set(on)
    try:
        yield
    finally:
        _SCHUR.reset(token)


def schur_in_use() -> bool:
    return _SCHUR.get()


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
    lu = _factor(H, A, cache)
    if cache is not None:
        cache.update(lu=lu, shape=(n, m))
    return _refine(H, g, A, residual, lu, stop, max_iter, stale=False)


def _factor(H: sp.spmatrix, A: sp.spmatrix, cache: dict | None = None):
    """Factorisation of the regularised (quasi-definite) KKT matrix: by its Schur complement when that is
    positive definite, else the sparse LU (see the module doc)."""
    m = A.shape[0]
    hd = H.diagonal()
    Ar = sp.csr_matrix(A)  # no copy when it is one
    col = np.bincount(Ar.indices, weights=Ar.data**2, minlength=A.shape[1])  # squared column norms, no copy of A
    scale = np.median(hd[hd > 0]) if np.any(hd > 0) else 1.0
    acol = np.median(col[col > 0]) if np.any(col > 0) else 1.0
    delta = 1e-14 * acol / scale
    if _SCHUR.get():
        Hinv = block_inverse(H)
        if Hinv is not None:
            # the complement's upper triangle, then delta on its diagonal: the whole complement and a shifted copy
            # of it are never held side by side (the same numbers as triu(A H^-1 A^T + delta I))
            upper = sp.triu(A @ (Hinv @ A.T), format="csc")
            upper.setdiag(upper.diagonal() + delta)
            ldl = _ldl(upper, m, cache)
            del upper
            if ldl is not None:
                return SchurSolve(H, Hinv, A, ldl, delta)
    K = sp.bmat([[H, A.T], [A, -delta * sp.identity(m)]], format="csc")
    return splu(K)


class SchurSolve:
    """Solves with the regularised KKT matrix by eliminating the block-diagonal cost first:
    ``(A H^-1 A^T + delta I) dl = A H^-1 r1 - r2``, ``dx = H^-1 (r1 - A^T dl)``.

    The Schur complement is symmetric positive definite, so its LDL^T is stable under any ordering;
    ``x`` only sees ``A^T dl``, in which the directions of redundant constraints (where the complement
    is singular but for ``delta``) cancel. But forming it squares the condition number: where a loop
    is nearly singular (the Jacobian of a planar loop of catalogue fittings loses rank at the solution)
    one elimination leaves errors of 1e-2 of the step in ``x`` (measured), where the LU of the
    regularised matrix itself leaves round-off. A few steps of refinement on that same regularised
    matrix recover the LU's solution, so that the Gauss-Newton sequences built on either are the
    same (see the module doc)."""

    refinements = 3  # at most; each costs one more elimination (measured: the third rarely helps)
    diverged = 0.1  # a last correction of x this large, relative to x, is no convergence

    def __init__(self, H: sp.spmatrix, Hinv: sp.csr_matrix, A: sp.spmatrix, ldl, delta: float):
        # held by reference (the caller's matrices, A^T a view): a 100,000-component network's factorisation
        # is the largest thing alive during the solve, nothing beside it should be a copy
        self.H, self.Hinv, self.A, self.ldl, self.delta = H, Hinv, A, ldl, delta
        self.lu = None  # the LU that replaces the elimination once it did not converge

    def _eliminate(self, rhs: np.ndarray) -> np.ndarray:
        n = self.Hinv.shape[0]
        w = self.Hinv @ rhs[:n]
        dl = self.ldl.solve(self.A @ w - rhs[n:])
        return np.concatenate([w - self.Hinv @ (self.A.T @ dl), dl])

    def _residual(self, rhs: np.ndarray, sol: np.ndarray) -> np.ndarray:
        """``rhs`` minus the regularised KKT matrix times ``sol``."""
        n = self.Hinv.shape[0]
        x, lam = sol[:n], sol[n:]
        return rhs - np.concatenate([self.H @ x + self.A.T @ lam, self.A @ x - self.delta * lam])

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        if self.lu is not None:
            return self.lu.solve(rhs)
        n = self.Hinv.shape[0]
        sol = self._eliminate(rhs)
        last = np.inf
        step = 0.0
        for _ in range(self.refinements):
            res = self._residual(rhs, sol)
            size = float(np.max(np.abs(res), initial=0.0))
            # the residual's floor is the round-off of the multipliers of redundant rows (1/delta times
            # their conflict), not the error of x: refine while it contracts, whatever its size
            if not 0.0 < size < 0.25 * last:
                break
            last = size
            fix = self._eliminate(res)
            sol += fix
            step = float(np.max(np.abs(fix[:n]), initial=0.0))
        if step > self.diverged * float(np.max(np.abs(sol[:n]), initial=0.0)):
            # the elimination is no approximate inverse here (a loop at its singular point: the complement's
            # condition number, the square of the KKT matrix's, past 1/eps), refinement does not converge on it:
            # this matrix and its later right-hand sides go to the pivoted LU of the regularised matrix itself
            m = self.A.shape[0]
            self.lu = splu(sp.bmat([[self.H, self.A.T], [self.A, -self.delta * sp.identity(m)]], format="csc"))
            return self.lu.solve(rhs)
        return sol


def block_inverse(H: sp.spmatrix, largest: int = 16) -> sp.csr_matrix | None:
    """Inverse of a symmetric positive-definite block-diagonal matrix (the per-component cost), or None
    when it is not one (a block larger than ``largest`` or not positive definite).

    Blocks of one variable (a fitting's cost is diagonal: six of them per fitting) are inverted as numbers,
    the others as one stack padded to the largest: padding every block to a pipe's seven variables made the
    stack seven times as large as the blocks that need it on plant-like networks (time and peak memory)."""
    n = H.shape[0]
    if n == 0:
        return sp.csr_matrix((0, 0))
    nb, label = connected_components(H, directed=False)
    sizes = np.bincount(label, minlength=nb)
    big = int(sizes.max())
    if big > largest:
        return None
    C = sp.coo_matrix(H)
    one = sizes[label] == 1  # variables that are a block alone
    diag = np.zeros(n)
    on = one[C.row]  # an entry of a block of one is on the diagonal
    np.add.at(diag, C.row[on], C.data[on])
    if not np.all(diag[one] > 0):
        return None
    rest = np.flatnonzero(~one)
    rows_out, cols_out, vals_out = [np.flatnonzero(one)], [np.flatnonzero(one)], [1.0 / diag[one]]
    if len(rest):
        # blocks of two or more variables, renumbered 0..nr-1, padded to the largest as before
        blocks, local = np.unique(label[rest], return_inverse=True)
        nr, size = len(blocks), sizes[blocks]
        big = int(size.max())
        lab = np.full(nb, -1, dtype=np.intp)
        lab[blocks] = np.arange(nr)
        rl = lab[label]  # block of each variable in the stack, -1 for blocks of one
        order = rest[np.argsort(local, kind="stable")]
        start = np.concatenate([[0], np.cumsum(size)])
        pos = np.full(n, -1, dtype=np.intp)
        pos[order] = np.arange(len(rest)) - start[rl[order]]
        off = ~on
        B = np.zeros((nr, big, big))
        np.add.at(B, (rl[C.row[off]], pos[C.row[off]], pos[C.col[off]]), C.data[off])
        pad = np.arange(big)[None, :] >= size[:, None]
        B[:, np.arange(big), np.arange(big)] += pad  # unit diagonal in the padding
        try:
            np.linalg.cholesky(B)
        except np.linalg.LinAlgError:
            return None
        Bi = np.linalg.inv(B)
        member = np.full((nr, big), -1, dtype=np.intp)
        member[rl[rest], pos[rest]] = rest
        rows = np.broadcast_to(member[:, :, None], B.shape)
        cols = np.broadcast_to(member[:, None, :], B.shape)
        keep = (rows >= 0) & (cols >= 0)
        rows_out.append(rows[keep]); cols_out.append(cols[keep]); vals_out.append(Bi[keep])
    return sp.csr_matrix((np.concatenate(vals_out), (np.concatenate(rows_out), np.concatenate(cols_out))),
                         shape=(n, n))


def _ldl(upper: sp.csc_matrix, n: int, cache: dict | None):
    """QDLDL of the quasi-definite matrix given by its upper triangle, or None when a pivot has the wrong sign.

    A sequence whose LDL^T was refused twice in a row (redundant constraints that stay) stops trying it."""
    if cache is not None and cache.get("ldl_refused", 0) >= 2:
        return None
    upper.sort_indices()
    pattern = (upper.indptr, upper.indices)
    old = cache.pop("ldl", None) if cache is not None else None
    try:
        if old is not None and all(np.array_equal(x, y) for x, y in zip(old[1], pattern)):
            f = old[0]  # same pattern as the last Gauss-Newton step: keep its ordering, refactor the numbers
            f.update(upper, upper=True)
        else:
            del old
            f = qdldl.Solver(upper, upper=True)
        d = f.factors()[1]
    except (ValueError, RuntimeError):  # a zero pivot
        d = None
    # d belongs to the permuted matrix: only the counts of signs are comparable (Sylvester's law of inertia)
    ok = d is not None and bool(np.all(np.isfinite(d)) and np.sum(d > 0) == n and np.sum(d < 0) == len(d) - n)
    if cache is not None:
        cache["ldl_refused"] = 0 if ok else cache.get("ldl_refused", 0) + 1
        if ok:
            cache["ldl"] = (f, pattern)
    return f if ok else None



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
