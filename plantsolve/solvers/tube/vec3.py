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


def rotvec_matrices(v: np.ndarray) -> np.ndarray:
    """Rotation matrices (B, 3, 3) of rotation vectors (B, 3): Rodrigues, R = cos θ I + sin θ / θ K + (1 − cos θ) / θ² v vᵀ,
    with the coefficients from the half angle (sin(θ/2) / (θ/2)), which has no cancellation for the small angles
    of a finite-difference step (1 − cos θ loses all its digits there)."""
    th2 = np.einsum("bk,bk->b", v, v)
    half = 0.5 * np.sqrt(th2)
    safe = np.where(half > 0.0, half, 1.0)
    sinc = np.where(half > 0.0, np.sin(half) / safe, 1.0)  # sin(θ/2) / (θ/2)
    a = sinc * np.cos(half)  # sin θ / θ
    b = 0.5 * sinc * sinc  # (1 − cos θ) / θ²
    out = (b[:, None, None] * v[:, :, None]) * v[:, None, :]
    diag = 1.0 - b * th2  # cos θ
    for k in range(3):
        out[:, k, k] += diag
    av = a[:, None] * v
    out[:, 0, 1] -= av[:, 2]; out[:, 1, 0] += av[:, 2]  # noqa: E702
    out[:, 0, 2] += av[:, 1]; out[:, 2, 0] -= av[:, 1]  # noqa: E702
    out[:, 1, 2] -= av[:, 0]; out[:, 2, 1] += av[:, 0]  # noqa: E702
    return out
