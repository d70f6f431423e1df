"""Lone motions: the rigid clusters that turn alone about one line, moving no other part.

A cluster whose every joint with the rest of the model allows a turn about one common line (hinges and
cylindrical joints on that line, balls centred on it, planar contacts whose normal is along it) can turn about
that line while every other body stands still: the turn meets each of those joints' constraints, and the
cluster's own joints do not move. A pin spinning in the round holes of the beams it joins, an axle with its gears
and bushes turning in round holes, a wheel on its axle, a door on its hinge. Where every such joint is cylindrical
the cluster slides along the line too (an axle in round holes with nothing to stop it).

Each is a motion of the model supported on that cluster alone. The largest cluster of each connected piece is
the piece's reference and is not listed (its turn is the rest of the piece turning the other way); the others
are supported on disjoint sets of bodies none of which is a piece's reference, so their motions are independent
of each other and of the pieces' rigid motions: their dof add, and ``dof`` less their sum and less the pieces'
6 each is what moves several clusters relative to each other (a hinge chain, a linkage).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from plantsolve.solvers.rigidity.pieces import pieces

# Two joint axes are one line when their directions differ by at most this (radians, the cross product of unit
# vectors) and each point lies within LINE_TOLERANCE of the model's size from the other's line. A joint's point and
# axis come from one part's connectors, so a pin's two joints lie on its own line to rounding: a Technic robot of
# 197 parts placed with 0.707 rotations shows the same 97 lone clusters for tolerances from 1e-9 to 1e-2. No looser
# than the exact pass's float rank (RANK_TOLERANCE): a line that the rank holds apart is not taken for one.
ANGLE_TOLERANCE = 1e-9
LINE_TOLERANCE = 1e-9
TURNING = {"hinge", "cylindrical"}  # joints that have an axis the cluster can turn about


@dataclass(frozen=True)
class LoneMotion:
    parts: list[str]  # the cluster's bodies
    point: tuple[float, float, float]  # a point of the line it turns about
    axis: tuple[float, float, float]  # the line's unit direction
    slides: bool  # every joint cylindrical: it slides along the line too
    joints: int  # its joints with the rest of the model

    @property
    def dof(self) -> int:
        return 2 if self.slides else 1


def _unit(v) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    return a / np.linalg.norm(a)


def _on_line(point, origin: np.ndarray, axis: np.ndarray, reach: float) -> bool:
    d = np.asarray(point, dtype=float) - origin
    return float(np.linalg.norm(d - (d @ axis) * axis)) <= reach


def _parallel(direction, axis: np.ndarray) -> bool:
    return float(np.linalg.norm(np.cross(_unit(direction), axis))) <= ANGLE_TOLERANCE


def _turns_about_one_line(joints: list, reach: float) -> tuple[np.ndarray, np.ndarray] | None:
    """(point, unit axis) of the line every joint in ``joints`` lets its far side turn about, or None."""
    first = next((j for j in joints if j.type in TURNING and j.axis is not None), None)
    if first is None:
        return None
    origin, axis = np.asarray(first.point, dtype=float), _unit(first.axis)
    for j in joints:
        if j.type in TURNING:
            ok = j.axis is not None and _parallel(j.axis, axis) and _on_line(j.point, origin, axis, reach)
        elif j.type == "ball":
            ok = _on_line(j.point, origin, axis, reach)
        elif j.type == "planar":
            ok = j.axis is not None and _parallel(j.axis, axis)
        else:  # rigid, slider: no turn
            ok = False
        if not ok:
            return None
    return origin, axis


def _pieces(clusters: list[list[str]], joints: Sequence) -> list[int]:
    """The connected piece of each cluster (an index per cluster), joined by the joints (:func:`.pieces.pieces` over
    the clusters)."""
    of = {b: str(k) for k, c in enumerate(clusters) for b in c}
    joined: dict[str, list[str]] = {}
    for j in joints:
        joined.setdefault(of[j.bodies[0]], []).append(of[j.bodies[1]])
    piece = [0] * len(clusters)
    for number, group in enumerate(pieces([str(k) for k in range(len(clusters))], joined)):
        for k in group:
            piece[int(k)] = number
    return piece


def lone_motions(clusters: list[list[str]], joints: Sequence) -> list[LoneMotion]:
    """The clusters (lists of body ids, as the exact pass found them) that turn alone about one line, each piece's
    largest cluster excepted (module docstring); ``joints`` have ``type``, ``bodies``, ``point`` and ``axis``."""
    if len(clusters) < 2:
        return []
    points = np.array([j.point for j in joints], dtype=float).reshape(-1, 3)
    size = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    reach = LINE_TOLERANCE * max(size, 1.0)
    of = {b: k for k, c in enumerate(clusters) for b in c}
    across: dict[int, list] = {k: [] for k in range(len(clusters))}
    for j in joints:
        a, b = of[j.bodies[0]], of[j.bodies[1]]
        if a != b:
            across[a].append(j)
            across[b].append(j)
    piece = _pieces(clusters, joints)
    reference: dict[int, int] = {}
    for k, c in enumerate(clusters):
        best = reference.get(piece[k])
        if best is None or len(c) > len(clusters[best]):
            reference[piece[k]] = k
    out = []
    for k, c in enumerate(clusters):
        if reference[piece[k]] == k or not across[k]:
            continue
        line = _turns_about_one_line(across[k], reach)
        if line is None:
            continue
        origin, axis = line
        out.append(LoneMotion(parts=list(c), point=tuple(float(v) + 0.0 for v in origin),
                              axis=tuple(float(v) + 0.0 for v in axis),
                              slides=all(j.type == "cylindrical" for j in across[k]), joints=len(across[k])))
    return out
