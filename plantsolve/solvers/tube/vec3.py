"""Cross products and rotations of 3-vectors written out on their components: numpy's ``np.cross`` moves
axes and checks shapes on every call, which costs more than the arithmetic on the few vectors of a spine
(the same products and differences in the same order, so the results are bit for bit numpy's)."""

from __future__ import annotations

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of two (3,) vectors or two (N, 3) arrays of rows."""
    if a.ndim == 1:
        return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])
    out = np.empty(a.shape)
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def rotate_about(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """``geometry.rotate_about`` for one (3,) vector and one angle: Rodrigues' rotation about the unit axis."""
    c, s = np.cos(angle), np.sin(angle)
    return v * c + cross(axis, v) * s + axis * np.dot(axis, v) * (1.0 - c)
