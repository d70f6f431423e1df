"""Exact rank and null space of an integer matrix by Gaussian elimination modulo large primes.

The rank modulo a prime p never exceeds the rank over the rationals and equals it unless p divides
every maximal non-zero minor; two primes near 2³¹ make a wrong answer practically impossible (the
larger rank is the rational one). Entries are reduced mod p first, so integers of any size (Python
ints) are exact; products of two residues stay below 2⁶² and fit numpy's int64.
"""

from __future__ import annotations

import numpy as np

PRIMES = (2_147_483_647, 2_147_483_629)


def reduce_mod(matrix, p: int) -> np.ndarray:
    """An integer matrix (int64 or object array of Python ints) as int64 residues in [0, p)."""
    m = np.asarray(matrix)
    if m.dtype == object:
        return np.vectorize(lambda x: int(x) % p, otypes=[np.int64])(m) if m.size else np.zeros(m.shape, np.int64)
    return np.mod(m.astype(np.int64), p)


def rref_mod(matrix: np.ndarray, p: int) -> tuple[np.ndarray, list[int]]:
    """Reduced row echelon form of residues mod p and the pivot columns."""
    m = np.array(matrix, dtype=np.int64, copy=True)
    n_rows, n_cols = m.shape
    pivots: list[int] = []
    r = 0
    for c in range(n_cols):
        if r == n_rows:
            break
        nz = np.flatnonzero(m[r:, c])
        if nz.size == 0:
            continue
        i = r + int(nz[0])
        if i != r:
            m[[r, i]] = m[[i, r]]
        inv = pow(int(m[r, c]), p - 2, p)
        m[r] = (m[r] * inv) % p
        col = m[:, c].copy()
        col[r] = 0
        rows = np.flatnonzero(col)
        if rows.size:
            m[rows] = (m[rows] - (col[rows, None] * m[r]) % p) % p
        pivots.append(c)
        r += 1
    return m[:r], pivots


def nullspace_mod(matrix: np.ndarray, p: int) -> tuple[int, np.ndarray]:
    """(rank, basis) of the null space mod p: basis is ``n_cols × nullity`` residues."""
    n_cols = matrix.shape[1]
    if matrix.shape[0] == 0:
        return 0, np.eye(n_cols, dtype=np.int64)
    r, pivots = rref_mod(matrix, p)
    free = [c for c in range(n_cols) if c not in set(pivots)]
    basis = np.zeros((n_cols, len(free)), dtype=np.int64)
    for k, f in enumerate(free):
        basis[f, k] = 1
        basis[pivots, k] = (-r[:, f]) % p
    return len(pivots), basis


def exact_nullspace(matrix) -> tuple[int, np.ndarray, int]:
    """(rank over Q, null-space basis mod p, p): the larger rank over :data:`PRIMES`."""
    best = None
    for p in PRIMES:
        rank, basis = nullspace_mod(reduce_mod(matrix, p), p)
        if best is None or rank > best[0]:
            best = (rank, basis, p)
    return best
