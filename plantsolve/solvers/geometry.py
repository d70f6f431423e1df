"""Geometry every solver kind shares: rotations, rigid fits, angles.

Conventions (as everywhere in plantsolve): quaternions are ``[w, x, y, z]`` (scalar first),
angles in radians inside solvers, arrays vectorised over leading axes. Rotations are
``scipy.spatial.transform.Rotation`` objects; this module only fixes the quaternion order
(``scalar_first=True``) and adds what scipy does not have: the vectorised Rodrigues formula
on plain vectors (cheap for one vector, where building a ``Rotation`` costs ~25 µs), reflection-
safe Kabsch/Umeyama fits with weights, and angle wrapping.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def rotation(q_wxyz: np.ndarray) -> Rotation:
    """``Rotation`` of quaternion(s) ``[w, x, y, z]`` (shape ``(4,)`` or ``(n, 4)``)."""
    return Rotation.from_quat(np.asarray(q_wxyz, dtype=float), scalar_first=True)


def quaternion(rot: Rotation, *, positive_w: bool = False) -> np.ndarray:
    """Quaternion(s) ``[w, x, y, z]`` of ``rot``; ``positive_w`` picks the sign with w ≥ 0."""
    q = rot.as_quat(scalar_first=True)
    if positive_w:
        q = np.where(q[..., :1] < 0, -q, q)
    return q


def rotvec_to_quaternion(rotvec: np.ndarray) -> np.ndarray:
    """Quaternion(s) ``[w, x, y, z]`` of rotation vector(s) (axis × angle in radians)."""
    return Rotation.from_rotvec(rotvec).as_quat(scalar_first=True)


def quaternion_to_rotvec(q_wxyz: np.ndarray) -> np.ndarray:
    """Rotation vector(s) of quaternion(s) ``[w, x, y, z]``."""
    return rotation(q_wxyz).as_rotvec()


def rotate_about(v: np.ndarray, axis: np.ndarray, angle: float | np.ndarray) -> np.ndarray:
    """Rodrigues rotation of vector(s) ``v`` about unit ``axis`` by ``angle`` (right hand)."""
    c, s = np.cos(angle), np.sin(angle)
    v = np.asarray(v, dtype=float)
    axis = np.asarray(axis, dtype=float)
    dot = np.sum(axis * v, axis=-1, keepdims=True) if v.ndim > 1 or axis.ndim > 1 else np.dot(axis, v)
    if np.ndim(angle):
        c, s = np.expand_dims(c, -1), np.expand_dims(s, -1)
    return v * c + np.cross(axis, v) * s + axis * dot * (1.0 - c)


def rotvec_matrix(w: np.ndarray) -> np.ndarray:
    """3 × 3 matrix of one rotation vector ``w`` (Rodrigues, series below 1e-6 rad)."""
    th2 = float(w @ w)
    if th2 < 1e-12:  # series to second order in θ
        a, b = 1.0 - th2 / 6.0, 0.5 - th2 / 24.0
    else:
        th = np.sqrt(th2)
        a, b = np.sin(th) / th, (1.0 - np.cos(th)) / th2
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    return np.eye(3) + a * K + b * (K @ K)


def kabsch(source: np.ndarray, target: np.ndarray, weights: np.ndarray | None = None,
           *, scale: bool = False) -> tuple[np.ndarray, np.ndarray, float]:
    """Best rigid motion (Kabsch; with ``scale``, Umeyama's similarity) mapping ``source`` onto
    ``target``: returns ``(R, t, s)`` with ``s · R @ p + t ≈ q`` in the weighted least-squares
    sense. ``R`` is a proper rotation (det +1) even when the points are planar or mirrored.
    """
    P = np.asarray(source, dtype=float)
    Q = np.asarray(target, dtype=float)
    if weights is None:
        cp, cq = P.mean(0), Q.mean(0)
        Pc, Qc = P - cp, Q - cq
        H = Pc.T @ Qc
        spread = float(np.sum(Pc * Pc))
    else:
        w = np.asarray(weights, dtype=float)
        w = w / w.sum()
        cp, cq = w @ P, w @ Q
        Pc, Qc = P - cp, Q - cq
        H = (Pc * w[:, None]).T @ Qc
        spread = float(w @ np.sum(Pc * Pc, axis=1))
    U, S, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T))
    D = np.diag([1.0, 1.0, d if d != 0 else 1.0])
    R = Vt.T @ D @ U.T
    s = float((S * np.diag(D)).sum() / spread) if scale else 1.0
    t = cq - R @ cp if not scale else cq - s * R @ cp
    return R, t, s


def wrap_angle(angle: float | np.ndarray, period: float = 2.0 * np.pi) -> float | np.ndarray:
    """Angle(s) wrapped into ``[-period/2, period/2)``; ``period=360`` for degrees."""
    half = 0.5 * period
    return (np.asarray(angle) + half) % period - half if np.ndim(angle) else (angle + half) % period - half


def angle_between(a: np.ndarray, b: np.ndarray) -> float | np.ndarray:
    """Unsigned angle between vectors, accurate near 0 and π too (arccos of the dot is not)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.ndim == b.ndim == 1:
        return float(np.arctan2(np.linalg.norm(np.cross(a, b)), a @ b))
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


def signed_angle(a: np.ndarray, b: np.ndarray, axis: np.ndarray) -> float:
    """Angle from ``a`` to ``b`` about ``axis`` (right-hand rule), in (-π, π]."""
    return float(np.arctan2(np.dot(np.cross(a, b), axis), np.dot(a, b)))


def any_perpendicular(v: np.ndarray) -> np.ndarray:
    """A deterministic unit vector ⟂ unit ``v`` (from the axis ``v`` leans on least)."""
    e = np.eye(3)[int(np.argmin(np.abs(v)))]
    p = e - np.dot(e, v) * v
    return p / np.linalg.norm(p)
