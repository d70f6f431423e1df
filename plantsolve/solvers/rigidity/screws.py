"""Joint screw constraints: the wrenches a joint transmits, as rows acting on body twists.

A body's instantaneous motion is a twist ``t = (ω, v)``: angular velocity ω and the velocity v of the
point at the origin. A joint between bodies i and j allows the relative twist ``t_j − t_i`` to lie in
its screw space (a hinge through p along a: multiples of ``(a, p × a)``; a slider: ``(0, a)``). Its
constraint rows are a basis of the wrenches ``(f, m)`` reciprocal to that space (``f·v + m·ω = 0``):
forces through p and couples. Each row is written on the unknowns ``(ω, v)`` as ``[m, f]``.

Rows are built from the joint's point and axis as given; with integer points and axes every row is
an integer vector (no normalisation), which the modular rank uses exactly.
"""

from __future__ import annotations

import numpy as np

FREEDOM = {"rigid": 0, "hinge": 1, "slider": 1, "cylindrical": 2, "ball": 3, "planar": 3}
"""Degrees of freedom each joint type leaves between its two bodies. A planar joint (face on face: a LEGO
``contact`` joint, whose axis is the faces' normal) leaves the slide in the faces' plane and the turn about the
normal; it holds the normal's translation and the two tilts."""

E = np.eye(3)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b of two 3-vectors, keeping integer dtypes exact (numpy's cross is slow on tiny arrays)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]],
                    dtype=np.result_type(a, b))


def _perpendiculars(axis: np.ndarray) -> list[np.ndarray]:
    """Two independent vectors perpendicular to ``axis``: axis × e_k for the two coordinate axes other
    than the axis's largest component (so neither product vanishes). Integer when the axis is."""
    big = int(np.argmax(np.abs(axis)))
    e = np.eye(3, dtype=axis.dtype)
    return [cross(axis, e[k]) for k in range(3) if k != big]


def _one_arithmetic(point, axis) -> tuple[np.ndarray, np.ndarray]:
    """``point`` and ``axis`` as arrays of one dtype, the one both promote to."""
    p = np.asarray(point)
    a = np.asarray(axis)
    if p.dtype != a.dtype:
        zero = np.promote_types(p.dtype, a.dtype).type(0)
        p, a = zero + p, zero + a
    return p, a


def constraint_rows(kind: str, point, axis) -> np.ndarray:
    """The ``(6 − freedom) × 6`` constraint rows of a joint, on the relative twist ``(ω, v)``.

    ``point`` and ``axis`` may be integer or float arrays; the result has their dtype's arithmetic
    (object arrays of Python ints stay exact).
    """
    p, a = _one_arithmetic(point, axis)
    zero = np.zeros(3, dtype=p.dtype)
    e = np.eye(3, dtype=p.dtype)
    rows = []

    def force(f):  # a force f acting along a line through p: moment p × f
        rows.append(np.concatenate([cross(p, f), f]))

    def couple(m):
        rows.append(np.concatenate([m, zero]))

    if kind == "rigid":
        for k in range(3):
            force(e[k])
        for k in range(3):
            couple(e[k])
    elif kind == "ball":
        for k in range(3):
            force(e[k])
    elif kind == "hinge":
        for k in range(3):
            force(e[k])
        for m in _perpendiculars(a):
            couple(m)
    elif kind == "cylindrical":
        for f in _perpendiculars(a):
            force(f)
        for m in _perpendiculars(a):
            couple(m)
    elif kind == "slider":
        for f in _perpendiculars(a):
            force(f)
        for k in range(3):
            couple(e[k])
    elif kind == "planar":
        force(a)
        for m in _perpendiculars(a):
            couple(m)
    else:
        raise ValueError(f"unknown joint type {kind!r}")
    return np.array(rows)


def freedom_screws(kind: str, point, axis) -> np.ndarray:
    """The ``6 × freedom`` screws (columns ``(ω, v)``) a joint allows, in the inputs' arithmetic
    (integer points and axes give integer screws): the columns of the loop-closure matrix."""
    p, a = _one_arithmetic(point, axis)
    zero = np.zeros(3, dtype=p.dtype)
    e = np.eye(3, dtype=p.dtype)
    cols = {"rigid": [], "hinge": [np.concatenate([a, cross(p, a)])], "slider": [np.concatenate([zero, a])],
            "cylindrical": [np.concatenate([a, cross(p, a)]), np.concatenate([zero, a])],
            "ball": [np.concatenate([e[k], cross(p, e[k])]) for k in range(3)],
            "planar": [np.concatenate([a, cross(p, a)]), *(np.concatenate([zero, t]) for t in _perpendiculars(a))]}[kind]
    return np.array(cols, dtype=p.dtype).reshape(-1, 6).T


def allowed_twists(kind: str, point, axis) -> np.ndarray:
    """A basis (rows) of the relative twists a joint allows: used by tests to check reciprocity."""
    p = np.asarray(point, dtype=float)
    a = np.asarray(axis, dtype=float)
    if kind == "rigid":
        return np.zeros((0, 6))
    if kind == "hinge":
        return np.array([np.concatenate([a, cross(p, a)])])
    if kind == "slider":
        return np.array([np.concatenate([np.zeros(3), a])])
    if kind == "cylindrical":
        return np.array([np.concatenate([a, cross(p, a)]), np.concatenate([np.zeros(3), a])])
    if kind == "ball":
        return np.array([np.concatenate([E[k], cross(p, E[k])]) for k in range(3)])
    if kind == "planar":
        return np.array([np.concatenate([a, cross(p, a)]), *(np.concatenate([np.zeros(3), t]) for t in _perpendiculars(a))])
    raise ValueError(f"unknown joint type {kind!r}")
