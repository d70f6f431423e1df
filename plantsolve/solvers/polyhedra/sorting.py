"""Integer keys sorted and counted at the speed of ``np.sort``.

A million-triangle mesh has three million edge-uses; ``np.argsort`` on them is several times slower
than ``np.sort``, and ``np.unique`` (a hash table in NumPy 2) slower still. Where the key and the
index fit together in 63 bits, the index rides in the key's low bits and one ``np.sort`` gives a
stable order; distinct values come from a sorted copy or, for keys below a small bound, a bitmap.
"""

from __future__ import annotations

import numpy as np


def stable_order(key: np.ndarray, bound: int) -> np.ndarray:
    """The stable sort order of non-negative ``key`` (every value < ``bound``), as int64 indices."""
    n = len(key)
    index_bits = max(int(n - 1).bit_length(), 1)
    if bound <= 0 or n == 0:
        return np.arange(n, dtype=np.int64)
    if int(bound - 1).bit_length() + index_bits <= 63:
        packed = key.astype(np.int64) << index_bits
        packed |= np.arange(n, dtype=np.int64)
        packed.sort()
        packed &= (1 << index_bits) - 1
        return packed
    return np.argsort(key, kind="stable")


def _table_fits(n: int, bound: int) -> bool:
    """Whether a table with an entry for every possible value (a bitmap, a bincount) beats sorting ``n`` keys:
    it does while the table is at most a few times as long as the keys."""
    return bound <= 8 * n + 1024


def _present(key: np.ndarray, bound: int) -> np.ndarray:
    """A bitmap over 0 … ``bound`` - 1: which values ``key`` holds."""
    seen = np.zeros(bound, dtype=bool)
    seen[key] = True
    return seen


def distinct(key: np.ndarray, bound: int) -> np.ndarray:
    """The distinct values of non-negative ``key`` (every value < ``bound``), sorted."""
    if len(key) == 0:
        return np.zeros(0, dtype=np.int64)
    if _table_fits(len(key), bound):
        return np.flatnonzero(_present(key, bound))
    s = np.sort(key)
    return s[np.r_[True, s[1:] != s[:-1]]]


def dense_labels(label: np.ndarray, bound: int) -> np.ndarray:
    """``label`` renumbered 0, 1, … in the order of its values (``np.unique``'s inverse); values < ``bound``."""
    if len(label) == 0:
        return np.zeros(0, dtype=np.int64)
    if _table_fits(len(label), bound):
        return (np.cumsum(_present(label, bound)) - 1)[label]
    return np.searchsorted(distinct(label, bound), label)


def counts_of(key: np.ndarray, bound: int) -> tuple[np.ndarray, np.ndarray]:
    """The distinct values of ``key`` (sorted) and how often each occurs (``np.unique(..., return_counts=True)``)."""
    if len(key) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    if _table_fits(len(key), bound):
        count = np.bincount(key, minlength=bound)
        values = np.flatnonzero(count)
        return values, count[values]
    s = np.sort(key)
    starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    return s[starts], np.diff(np.append(starts, len(s)))
