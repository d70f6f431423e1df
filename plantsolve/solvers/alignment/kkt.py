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
current ``H`` and ``A``, converges with a slightly stale preconditioner too; where it does not contract
(near a singular loop an earlier step's factorisation can be a poor inverse), the step is refactored
(:func:`_refine`).

The cost is block diagonal (one small block per component), so by default the system is solved
by eliminating it: the Schur complement ``A H^-1 A^T + delta I`` is symmetric positive definite and
factored by LDL^T (QDLDL, approximate minimum degree ordering, kept for a Gauss-Newton sequence in
the pattern of its constraints' couplings); a pivoted sparse LU of the regularised matrix where a pivot is not positive, the
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
solution back: the sequences then end up to 1e-5 mm apart on plant-like networks (3.3e-8 to 6.8e-6 mm at 5,000
to 20,000 components), 3e-11 mm on loop grids.
Where that refinement does not converge (at a singular point one elimination can be off by more than
the step itself), the system and its later right-hand sides go to the pivoted LU of the regularised
matrix instead.
Measured in one bench run (bench/alignment.py), refinements included: 0.45-0.55 of the LU's CPU time
and 0.6-0.7 of its peak memory on loop grids of 3,351 to 34,749 components, 0.86-0.93 of its time and
0.8 of its memory on plant-like networks of 10,000 and 100,000 (with one analysis per sequence: 0.78-0.87
and 0.82 in three and one runs). Where a connection has to be cut (solve.py), the cut is decided on
the pose where the network comes to rest with its connections as springs (direct.settle_conflict, each step a
:func:`regularised_factor` solve), which either factorisation gives to round-off, not on the plateau where a
conflict's round stopped (round-off's); so the first round is the LDL^T's even where it ends on a conflict, the round
after the first cut solves its feasibility steps on the LU and the rest here, the rounds after a second cut are all
the LU's.
The round after the cut is most of a cut network's time: the README's alignment section has the sums.
Another run on a machine loaded several times over (CPU seconds then vary by 10-20 % between runs of one code):
plant-like 4,839 / 9,965 / 19,365 / 39,867 components 0.98 / 0.80 / 0.76 / 0.87 of the LU's CPU time and
0.78 / 0.73 / 0.66 / 0.98 of its peak memory, the 39,867-component network's round after its cut 47 of 65 s.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np
import pymetis
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
    owner: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int]:
    """Minimise ``0.5 x'Hx + g'x`` subject to ``A x = b`` with ``residual(x) = b - A x``.

    ``owner`` (optional): the component of each variable, so that the factorised complement keeps one pattern
    while the connections stay (:func:`coupling_pattern`). Returns ``(x, residual(x), refinement steps)``.
    """
    n, m = H.shape[0], A.shape[0]
    if m == 0:
        x = splu(sp.csc_matrix(H)).solve(-g) if n else np.zeros(0)
        return x, residual(x), 1
    refused = 0  # refinement steps spent on a stale factorisation that was then refused (counted: they were spent)
    if cache is not None and cache.get("shape") == (n, m) and cache.get("reuse"):
        out = _refine(H, g, A, residual, cache["lu"], stop, max_iter, stale=True, slow=cache.get("crawl", False))
        if isinstance(out, tuple):
            return out
        refused = out
    if cache is not None:
        cache.pop("lu", None)  # never hold two factorisations at once (peak memory)
    lu = _factor(H, A, cache, owner)
    if cache is not None:
        cache.update(lu=lu, shape=(n, m))
    x, r, steps = _refine(H, g, A, residual, lu, stop, max_iter, stale=False)
    return x, r, steps + refused


def regularised_factor(H: sp.spmatrix, A: sp.spmatrix, delta: float, cache: dict | None = None,
                       owner: np.ndarray | None = None):
    """A factorisation of ``[[H, A^T], [A, -delta I]]`` itself (``.solve(rhs)``): its own solutions, not the
    constrained ones that :func:`constrained_lstsq` refines towards. ``delta`` is a compliance (the rows of ``A``
    as springs), not a regularisation. By the Schur complement where it is in use and positive definite (its
    elimination refined on this same matrix: :class:`SchurSolve`), else the pivoted LU; ``cache`` and ``owner`` keep
    one ordering and analysis for a sequence of them, as in :func:`constrained_lstsq`."""
    return _factor(H, A, cache, owner, delta)


def _factor(H: sp.spmatrix, A: sp.spmatrix, cache: dict | None = None, owner: np.ndarray | None = None,
            delta: float | None = None):
    """Factorisation of the regularised (quasi-definite) KKT matrix: by its Schur complement when that is
    positive definite, else the sparse LU (see the module doc). ``delta``: 1e-14 of the matrices' scale unless
    given."""
    m = A.shape[0]
    if delta is None:
        hd = H.diagonal()
        Ar = sp.csr_matrix(A)  # no copy when it is one
        col = np.bincount(Ar.indices, weights=Ar.data**2, minlength=A.shape[1])  # squared column norms, no copy of A
        scale = np.median(hd[hd > 0]) if np.any(hd > 0) else 1.0
        acol = np.median(col[col > 0]) if np.any(col > 0) else 1.0
        delta = 1e-14 * acol / scale
    if _SCHUR.get():
        Hinv = _held_inverse(H, cache)
        if Hinv is not None:
            # the complement's upper triangle, then delta on its diagonal: the whole complement and a shifted copy
            # of it are never held side by side (the same numbers as triu(A H^-1 A^T + delta I))
            upper = sp.triu(A @ (Hinv @ A.T), format="csc")
            if owner is not None and cache is not None:
                upper = coupling_pattern(upper, A, owner, cache)  # one pattern for the sequence: one analysis
            upper.setdiag(upper.diagonal() + delta)
            ldl = complement_factor(upper, m, cache)
            del upper
            if ldl is not None:
                return SchurSolve(H, Hinv, A, ldl, delta)
    K = sp.bmat([[H, A.T], [A, -delta * sp.identity(m)]], format="csc")
    return splu(K)


def _held_inverse(H: sp.spmatrix, cache: dict | None) -> sp.csr_matrix | None:
    """:func:`block_inverse` of ``H``, kept in ``cache`` while the caller passes the same matrix (the rotation stage's
    cost stays one object for its sequence); another matrix lets the one held go first (peak memory)."""
    held = cache.pop("inverse", None) if cache is not None else None
    Hinv = held[1] if held is not None and held[0] is H else block_inverse(H)
    del held
    if cache is not None:
        cache["inverse"] = (H, Hinv)
    return Hinv


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
    # where the residual stops falling fourfold (its floor is the multipliers' round-off) while the correction of x
    # still halves a step, at most this many more eliminations before the elimination is judged no inverse: on the
    # 19,365-component plant-like network one feasibility step's residual fell 0.26 a step, its correction 0.18, and
    # the LU it went to cost 0.5 s to factor and five times an elimination (20 against 4 ms) for each of the crawl's
    # 49 refinement steps on it
    rescue = 8

    def __init__(self, H: sp.spmatrix, Hinv: sp.csr_matrix, A: sp.spmatrix, ldl, delta: float):
        # held by reference (the caller's matrices, A^T a view): a 100,000-component network's factorisation
        # is the largest thing alive during the solve, nothing beside it should be a copy
        self.H, self.Hinv, self.A, self.ldl, self.delta = H, Hinv, A, ldl, delta
        # the transpose once, a view of A's arrays: made per product, its construction's checks cost as much as a
        # product with it (each refinement takes two)
        self.AT = A.T
        self.lu = None  # the LU that replaces the elimination once it did not converge

    def _eliminate(self, rhs: np.ndarray) -> np.ndarray:
        n = self.Hinv.shape[0]
        w = self.Hinv @ rhs[:n]
        dl = self.ldl.solve(self.A @ w - rhs[n:])
        return np.concatenate([w - self.Hinv @ (self.AT @ dl), dl])

    def _residual(self, rhs: np.ndarray, sol: np.ndarray) -> np.ndarray:
        """``rhs`` minus the regularised KKT matrix times ``sol``."""
        n = self.Hinv.shape[0]
        x, lam = sol[:n], sol[n:]
        return rhs - np.concatenate([self.H @ x + self.AT @ lam, self.A @ x - self.delta * lam])

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
        size_x = float(np.max(np.abs(sol[:n]), initial=0.0))
        for _ in range(self.rescue if step > self.diverged * size_x else 0):
            fix = self._eliminate(self._residual(rhs, sol))
            sol += fix
            last_step, step = step, float(np.max(np.abs(fix[:n]), initial=0.0))
            size_x = float(np.max(np.abs(sol[:n]), initial=0.0))
            if not step < 0.5 * last_step or step <= self.diverged * size_x:
                break
        if step > self.diverged * size_x:
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


def complement_factor(upper: sp.csc_matrix, n: int, cache: dict | None):
    """A factorisation of the symmetric matrix given by its upper triangle, or None when it is not positive definite
    in floating point (a pivot that is not positive).

    A new pattern is factored by QDLDL (LDL^T, approximate minimum degree), whose ordering and analysis are kept
    while the pattern is: a Gauss-Newton sequence hands its complements in the pattern of the couplings
    (:func:`coupling_pattern`, which stays while the connections do), so one analysis serves the sequence (the
    complement's own pattern lost entries at every step: a new minimum-degree ordering and analysis each time, 0.05 s
    of a 0.06 s factorisation in the rotation stage of a 40,000-component network, 0.2 of 0.26 s in its joint one).
    Where that factor filled in more than :data:`FILL_FOR_DISSECTION` times the matrix, as on loop grids, the rest
    of the sequence (``cache["dissect"]``) is ordered once by METIS's nested dissection and factored by SuperLU
    without pivoting: separators cost far less fill on a network that is a mesh of loops, and SuperLU's supernodes
    use BLAS. On a tree-like network minimum degree is near the best and QDLDL the fastest. A sequence whose
    factorisation was refused twice in a row (redundant constraints that stay) stops trying it."""
    if cache is not None and cache.get("ldl_refused", 0) >= 2:
        return None
    upper.sort_indices()
    pattern = (upper.indptr, upper.indices)
    old = cache.pop("ldl", None) if cache is not None else None
    known = old is not None and all(np.array_equal(x, y) for x, y in zip(old[1], pattern))
    kept = old[0] if known else None  # a QDLDL solver to refactor, or the dissection found for this pattern
    del old
    factor = None
    if cache is not None and cache.get("dissect") and not isinstance(kept, np.ndarray):
        kept = _dissection(upper)  # a sequence whose minimum-degree factor filled in: dissected from here on
    try:
        if isinstance(kept, np.ndarray):
            factor = DissectionFactor.of(upper, kept)
            ok = factor.positive_definite()
        else:
            if kept is not None:
                kept.update(upper, upper=True)
                factor = kept
            else:
                factor = qdldl.Solver(upper, upper=True)
            low, d, _ = factor.factors()
            # d belongs to the permuted matrix: only the counts of signs are comparable (Sylvester's law of inertia)
            ok = bool(np.all(np.isfinite(d)) and np.all(d > 0))
            if ok and kept is None and low.nnz > FILL_FOR_DISSECTION * upper.nnz and cache is not None:
                cache["dissect"] = True  # the next factorisations: the couplings' pattern, nested dissection
            if kept is None:
                kept = factor
            del low, d
    except (ValueError, RuntimeError):  # a zero pivot
        ok = False
    if cache is not None:
        cache["ldl_refused"] = 0 if ok else cache.get("ldl_refused", 0) + 1
        if ok:
            cache["ldl"] = (kept, pattern)
    return factor if ok else None


FILL_FOR_DISSECTION = 3.0  # factor entries per entry of the matrix's triangle above which dissection pays


def _dissection(upper: sp.csc_matrix) -> np.ndarray:
    """METIS's nested-dissection ordering of the graph of the symmetric matrix given by its upper triangle."""
    graph = (upper + upper.T).tocsr()
    graph.setdiag(0)
    graph.eliminate_zeros()
    perm, _ = pymetis.nested_dissection(pymetis.CSRAdjacency(graph.indptr.astype(np.int32),
                                                             graph.indices.astype(np.int32)))
    return np.asarray(perm, dtype=np.intp)


class DissectionFactor:
    """Solves with SuperLU's unpivoted factors of a symmetric matrix ordered by ``perm``."""

    def __init__(self, lu, perm: np.ndarray):
        self.lu, self.perm = lu, perm

    @classmethod
    def of(cls, upper: sp.csc_matrix, perm: np.ndarray) -> DissectionFactor:
        """The factors of the symmetric matrix given by its upper triangle, ordered by ``perm`` (row and column
        ``perm[k]`` become ``k``; SymmetricMode and no pivoting keep that one ordering, as a Cholesky's)."""
        full = (upper + sp.triu(upper, 1).T).tocsc()
        ordered = full[perm][:, perm].tocsc()
        del full
        return cls(splu(ordered, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True}), perm)

    def positive_definite(self) -> bool:
        """No row exchanged and every pivot positive and finite (the diagonal of U)."""
        lu = self.lu
        if not np.array_equal(lu.perm_r, lu.perm_c):
            return False
        d = lu.U.diagonal()
        return bool(np.all(np.isfinite(d)) and np.all(d > 0.0))

    def solve(self, b: np.ndarray) -> np.ndarray:
        y = self.lu.solve(np.asarray(b, dtype=float)[self.perm])
        x = np.empty_like(y)
        x[self.perm] = y
        return x


def coupling_pattern(upper: sp.csc_matrix, A: sp.spmatrix, owner: np.ndarray,
                     cache: dict | None = None) -> sp.csc_matrix:
    """``upper`` (the upper triangle of ``A H^-1 A^T``, H block diagonal by component) in the pattern of the
    couplings of constraint rows: rows i and j are coupled where both touch a variable of one component
    (``owner``: the component of each variable). Its own pattern changes at every Gauss-Newton step (an exact zero
    of the Jacobian on an axis-aligned run, a product that cancels: sparse products drop them); the couplings stay
    while the connections do, so a factorisation's ordering and analysis are kept for the sequence. The same
    numbers, explicit zeros where a coupling is zero at this step; ``upper`` as it is where an entry lies outside
    the couplings (a cost that is not block diagonal by component). The couplings are found once per sequence
    (``cache``) and number of rows: a row that gains a component later (an exact zero of the first step's
    Jacobian that is not one now) lies outside them, and they are found again."""
    m = A.shape[0]
    known = cache.get("couplings") if cache is not None else None
    for attempt in range(2):
        if known is None or known[0] != m:
            known = (m, *_couplings(A, owner))
            if cache is not None:
                cache["couplings"] = known
        _, indptr, indices = known
        keys = np.repeat(np.arange(m, dtype=np.int64), np.diff(indptr)) * m + indices
        upper.sort_indices()
        mine = np.repeat(np.arange(m, dtype=np.int64), np.diff(upper.indptr)) * m + upper.indices
        at = np.searchsorted(keys, mine)
        if not len(mine) or (at.max() < len(keys) and np.array_equal(keys[at], mine)):
            data = np.zeros(len(keys))
            data[at] = upper.data
            return sp.csc_matrix((data, indices, indptr), shape=(m, m))
        known = None  # found on an earlier step: find them on this one's Jacobian
    return upper


def _couplings(A: sp.spmatrix, owner: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(indptr, indices) of the upper triangle of the couplings of ``A``'s rows through components, CSC, sorted."""
    Ar = sp.csr_matrix(A)
    m = Ar.shape[0]
    rows = np.repeat(np.arange(m), np.diff(Ar.indptr))
    n_owners = int(owner.max()) + 1 if len(owner) else 0
    touch = sp.csr_matrix((np.ones(len(rows), dtype=np.float32), (rows, owner[Ar.indices])), shape=(m, n_owners))
    touch.data[:] = 1.0  # duplicates summed: one per component a row touches
    coupled = sp.triu(touch @ touch.T, format="csc")
    coupled.sort_indices()
    return coupled.indptr, coupled.indices


def _refine(H, g, A, residual, lu, stop, max_iter, stale, slow=False):
    """Iterative refinement: ``(x, residual, steps)``. With a stale factorisation (an earlier Gauss-Newton step's) the
    steps taken (an int) instead where it does not contract: a step that leaves both the constraint residual and the
    correction of ``x`` above :data:`STALE_CONTRACTION` of the step before's while the residual is still above
    :data:`STALE_REACH` of where it started (a conflict's inconsistent constraints leave a residual no refinement
    lowers, but its corrections still shrink where the factorisation serves)
    (``slow``: only where the first step does not lower it, as in the crawl of a round below what snapping closes,
    ``cache["crawl"]`` of :func:`constrained_lstsq`, whose slow refinements on the stale factorisation are the same on
    either factorisation and keep their answers together; see :func:`direct.solve_joint`).

    Near a singular loop an earlier step's factorisation is a poor inverse in the directions that are losing rank:
    measured on plant-like networks, refinement on it either oscillates (1.1e-5, 1.9e-6, 9.2e-6, 2.9e-6, 1.1e-5 on the
    40,000-component network, whose Gauss-Newton then stalled 0.018 mm open and was cut) or contracts by 5 % a step
    (each Gauss-Newton step of a closing round then lowered its residual by ~0.9, 16 of them up to the step cap, a
    crawl that ended where the cap did). A fresh factorisation there solves the step to round-off."""
    n, m = H.shape[0], A.shape[0]
    x = np.zeros(n)
    lam = np.zeros(m)
    r2 = residual(x)
    start = float(np.max(np.abs(r2))) if m else 0.0
    best = np.inf
    last, moved = start, np.inf  # the residual and the correction of x at the step before
    stall = 0
    steps = 0
    AT = A.T  # once: a view, see SchurSolve
    for steps in range(1, max_iter + 1):
        r1 = -(H @ x + g + AT @ lam)
        sol = lu.solve(np.concatenate([r1, r2]))
        if stale and not np.all(np.isfinite(sol)):
            return steps
        if stale and steps == 1 and float(np.max(np.abs(sol[:n]))) > 1e3 * (1.0 + start):
            return steps
        x += sol[:n]
        lam += sol[n:]
        r2 = residual(x)
        err = float(np.max(np.abs(r2)))
        if stale and (not np.isfinite(err) or (steps == 1 and not err < start)):
            return steps
        step = float(np.max(np.abs(sol[:n]))) if n else 0.0
        if (stale and not slow and err > STALE_CONTRACTION * last and step > STALE_CONTRACTION * moved
                and err > STALE_REACH * start):
            return steps
        last, moved = err, step
        if err <= stop and step <= max(stop, 1e-14 * (1.0 + float(np.max(np.abs(x))))):
            break
        if err < 0.5 * best:
            best, stall = err, 0
        else:
            stall += 1
            if stall >= 3:
                break
    return x, r2, steps


# a stale factorisation is kept while each refinement step at least halves the constraint residual or the correction,
# or once the residual is below a thousandth of where it started (round-off's floor, which no step halves, lies below
# that: measured 1e-10 to 3e-5 of the start with a fresh factorisation)
STALE_CONTRACTION = 0.5
STALE_REACH = 1e-3
