"""Dual-quaternion calculus (paper §2.1-2.2), vectorised over leading axes.

Quaternions are arrays ``[..., 4]`` = ``[w, x, y, z]``. Dual quaternions are arrays
``[..., 8]`` = real part ``[w, x, y, z]`` then dual part. A unit dual quaternion
``q = r + eps d`` with ``d = 0.5 * (0, t) * r`` is the rigid motion ``x -> R(r) x + t``;
``q`` and ``-q`` are the same motion (Study's sphere is a double cover of SE(3)).

Two slips in the paper's text are corrected here: the worked sandwich product for ``i``
writes ``q j q*`` in its first line (the result shown is that of ``q i q*``), and the point
transform is written ``p p q*``; it is ``q p q~`` with ``q~`` the combined quaternion and
dual conjugate (``q_r* - eps q_d*``), which is what :func:`transform_points` evaluates.
"""

from __future__ import annotations

import numpy as np

IDENTITY = np.array([1.0, 0, 0, 0, 0, 0, 0, 0])


def qmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions (broadcasting)."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        axis=-1,
    )


def qconj(q: np.ndarray) -> np.ndarray:
    """Quaternion conjugate q* (Definition 2)."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def qrotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Apply the sandwich operator q v q* to vectors ``v[..., 3]`` (unit q)."""
    w = q[..., :1]
    u = q[..., 1:]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def qmatrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix A of the paper (Euler parameters) for unit quaternions, shape [..., 3, 3]."""
    a, b, c, d = np.moveaxis(q, -1, 0)
    return np.stack(
        [
            np.stack([a * a + b * b - c * c - d * d, 2 * (b * c - a * d), 2 * (b * d + a * c)], -1),
            np.stack([2 * (b * c + a * d), a * a - b * b + c * c - d * d, 2 * (c * d - a * b)], -1),
            np.stack([2 * (b * d - a * c), 2 * (c * d + a * b), a * a - b * b - c * c + d * d], -1),
        ],
        axis=-2,
    )


def _vec_quat(v: np.ndarray) -> np.ndarray:
    return np.concatenate([np.zeros(v.shape[:-1] + (1,), dtype=v.dtype), v], axis=-1)


def dq_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Product of dual quaternions: (ar + eps ad)(br + eps bd) = ar br + eps(ar bd + ad br)."""
    ar, ad = a[..., :4], a[..., 4:]
    br, bd = b[..., :4], b[..., 4:]
    return np.concatenate([qmul(ar, br), qmul(ar, bd) + qmul(ad, br)], axis=-1)


def dq_conj(q: np.ndarray) -> np.ndarray:
    """Quaternion conjugation of both parts, q* = qr* + eps qd* (the inverse of a unit dual quaternion)."""
    return q * np.array([1.0, -1, -1, -1, 1, -1, -1, -1])


def dq_dual_conj(q: np.ndarray) -> np.ndarray:
    """Dual-number conjugation qr - eps qd."""
    return q * np.array([1.0, 1, 1, 1, -1, -1, -1, -1])


def dq_norm(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Norm as a dual number (a, b) = sqrt(q q*): a = |qr|, b = <qr, qd> / |qr|."""
    a = np.linalg.norm(q[..., :4], axis=-1)
    b = np.einsum("...i,...i->...", q[..., :4], q[..., 4:]) / a
    return a, b


def dq_normalize(q: np.ndarray) -> np.ndarray:
    """Divide by the dual norm: the result lies on Study's sphere (|r| = 1, <r, d> = 0)."""
    r = q[..., :4]
    n = np.linalg.norm(r, axis=-1, keepdims=True)
    r = r / n
    d = q[..., 4:] / n
    d = d - np.einsum("...i,...i->...", r, d)[..., None] * r
    return np.concatenate([r, d], axis=-1)


def dq_from_rt(q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Unit dual quaternion of x -> R(q) x + t."""
    q = np.asarray(q, dtype=float)
    t = np.asarray(t, dtype=float)
    dual = 0.5 * qmul(_vec_quat(t), q)
    return np.concatenate([np.broadcast_to(q, dual.shape), dual], axis=-1)


def dq_to_rt(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation quaternion (scalar part >= 0) and translation of a unit dual quaternion."""
    r = q[..., :4]
    t = 2.0 * qmul(q[..., 4:], qconj(r))[..., 1:]
    sign = np.where(r[..., :1] < 0, -1.0, 1.0)
    return r * sign, t


def transform_points(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Euclidean displacement of points: the sandwich q (1 + eps p) q~ read in the dual part."""
    r = q[..., :4]
    t = 2.0 * qmul(q[..., 4:], qconj(r))[..., 1:]
    return qrotate(r, p) + t


def transform_vectors(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Directions only rotate."""
    return qrotate(q[..., :4], v)


def transform_lines(q: np.ndarray, direction: np.ndarray, moment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Plücker line (d, m = p x d) under x -> R x + t: d' = R d, m' = R m + t x R d."""
    r = q[..., :4]
    t = 2.0 * qmul(q[..., 4:], qconj(r))[..., 1:]
    d2 = qrotate(r, direction)
    return d2, qrotate(r, moment) + np.cross(t, d2)


def dq_weighted_mean(q: np.ndarray, w: np.ndarray, groups: np.ndarray | None = None, n_groups: int = 1) -> np.ndarray:
    """Weighted mean displacement on Study's sphere (paper Remark 2).

    The weighted dual vectors are summed and the sum normalised. ``q`` and ``-q`` are the
    same displacement, so every member is first sign-aligned with the group's provisional
    sum (built from members with a non-negative scalar part); the result therefore does not
    depend on the order or sign of the inputs. With ``groups`` (an index per member) one mean
    per group is returned, shape ``[n_groups, 8]``; empty groups give the identity.
    """
    q = np.asarray(q, dtype=float)
    w = np.asarray(w, dtype=float)
    if groups is None:
        groups = np.zeros(q.shape[0], dtype=np.intp)
    canon = np.where(q[:, :1] < 0, -q, q)
    ref = np.zeros((n_groups, 8))
    np.add.at(ref, groups, w[:, None] * canon)
    flip = np.einsum("ij,ij->i", canon[:, :4], ref[groups, :4]) < 0
    aligned = np.where(flip[:, None], -canon, canon)
    total = np.zeros((n_groups, 8))
    np.add.at(total, groups, w[:, None] * aligned)
    empty = np.linalg.norm(total[:, :4], axis=1) == 0
    total[empty] = IDENTITY
    return dq_normalize(total)


def minimal_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Unit quaternion of the smallest rotation taking unit vectors a to b (axis a x b).

    For opposite vectors any perpendicular axis is valid; a deterministic one is chosen.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    c = np.cross(a, b)
    dot = np.einsum("...i,...i->...", a, b)
    q = np.concatenate([(1.0 + dot)[..., None], c], axis=-1)
    opposite = (1.0 + dot) < 1e-12
    if np.any(opposite):
        ao = a[opposite]
        helper = np.where(np.abs(ao[:, :1]) < 0.9, np.array([1.0, 0, 0]), np.array([0.0, 1, 0]))
        axis = np.cross(ao, helper)
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        q[opposite] = np.concatenate([np.zeros((len(ao), 1)), axis], axis=-1)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def rotation_angle(q: np.ndarray) -> np.ndarray:
    """Rotation angle (radians, in [0, pi]) of unit quaternions, stable for small angles."""
    return 2.0 * np.arctan2(np.linalg.norm(q[..., 1:], axis=-1), np.abs(q[..., 0]))


def dq_pow(q: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Screw power q^s (ScLERP from the identity): same screw axis, s times angle and slide.

    Used to limit a step while keeping the direction of the transformation (paper §3, item 4).
    """
    s = np.asarray(s, dtype=float)
    r, t = dq_to_rt(q)
    theta = rotation_angle(r)
    vec = r[..., 1:]
    vn = np.linalg.norm(vec, axis=-1, keepdims=True)
    small = theta < 1e-9
    axis = np.where(small[..., None], np.array([0.0, 0.0, 1.0]), vec / np.where(vn == 0, 1.0, vn))
    along = np.einsum("...i,...i->...", t, axis)[..., None] * axis
    perp = t - along
    # point c on the screw axis: (I - R) c = perp, c = (perp + cot(theta/2) axis x perp) / 2
    cot = np.where(small, 0.0, 1.0 / np.tan(np.where(small, 1.0, theta) / 2.0))
    c = 0.5 * (perp + cot[..., None] * np.cross(axis, perp))
    half = 0.5 * theta * s
    rs = np.concatenate([np.cos(half)[..., None], np.sin(half)[..., None] * axis], axis=-1)
    rs = np.where(small[..., None], np.concatenate([np.ones_like(theta)[..., None], vec * s[..., None]], -1), rs)
    rs = rs / np.linalg.norm(rs, axis=-1, keepdims=True)
    ts = np.where(small[..., None], t * s[..., None], c - qrotate(rs, c) + s[..., None] * along)
    return dq_from_rt(rs, ts)
