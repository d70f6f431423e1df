"""The canonical order of a scan's samples: results must not depend on the order of the input."""

from __future__ import annotations

import numpy as np


def lexicographic(pts: np.ndarray) -> np.ndarray:
    """``np.lexsort(pts.T[::-1])`` (by x, then y, then z, then input position) at the cost of one sort:
    the samples are sorted by x alone and only runs of equal x are sorted again by all three keys
    (lexsort sorts the whole array once per key, four times slower on ten million samples)."""
    x = pts[:, 0]
    order = np.argsort(x, kind="stable")
    xs = x[order]
    tied = np.zeros(len(xs), bool)
    eq = xs[1:] == xs[:-1]
    tied[1:] |= eq
    tied[:-1] |= eq
    if tied.any():
        idx = order[tied]  # runs of equal x, each in input order (the sort is stable)
        order[tied] = idx[np.lexsort((pts[idx, 2], pts[idx, 1], pts[idx, 0]))]
    return order
