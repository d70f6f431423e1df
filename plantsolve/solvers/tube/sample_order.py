"""The canonical order of a scan's samples: results must not depend on the order of the input."""

from __future__ import annotations

import numpy as np


def lexicographic(pts: np.ndarray) -> np.ndarray:
    """``np.lexsort(pts.T[::-1])`` (by x, then y, then z, then input position) at the cost of one sort:
    the samples are sorted by x alone and only runs of equal x are sorted again by all four keys
    (lexsort sorts the whole array once per key, four times slower on ten million samples). The sort by x
    need not be stable (the position is the last key of the runs' sort; numpy's quicksort of a contiguous
    copy takes a quarter less time than the stable sort of the strided column)."""
    x = np.ascontiguousarray(pts[:, 0])
    order = np.argsort(x)
    xs = x[order]
    tied = np.zeros(len(xs), bool)
    eq = xs[1:] == xs[:-1]
    tied[1:] |= eq
    tied[:-1] |= eq
    if tied.any():
        idx = order[tied]  # runs of equal x, each in no particular order
        order[tied] = idx[np.lexsort((idx, pts[idx, 2], pts[idx, 1], pts[idx, 0]))]
    return order
