"""Holes that lie outside their face: a hole is subtracted from its face's area, so one drawn beside the face, or
larger than it (a loop that was meant as another face, or its outer loop), gives a face of too little — even
negative — area without a word. Each hole's vertices must lie in the outer loop (or on it, within the merge
tolerance), measured in the outer loop's plane."""

from __future__ import annotations

import numpy as np
import shapely


def plane_frame(outer: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Two orthonormal in-plane axes of a loop (Newell normal), None for a degenerate loop."""
    nxt = np.roll(outer, -1, axis=0)
    normal = np.cross(outer, nxt).sum(axis=0)
    length = np.linalg.norm(normal)
    if length == 0:
        return None
    normal /= length
    u = outer[int(np.argmax(np.linalg.norm(outer - outer[0], axis=1)))] - outer[0]
    u -= normal * np.dot(u, normal)
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def holes_outside(loops: list[np.ndarray], tolerance: float) -> list[tuple[int, int]]:
    """(loop index, first vertex outside) of each hole (loops[1:]) with a vertex outside the outer loop."""
    frame = plane_frame(loops[0] - loops[0].mean(axis=0))
    if frame is None:
        return []
    origin = loops[0].mean(axis=0)
    basis = np.stack(frame, axis=1)
    face = shapely.Polygon((loops[0] - origin) @ basis)
    out = []
    for k, hole in enumerate(loops[1:], start=1):
        ok = shapely.dwithin(face, shapely.points((hole - origin) @ basis), tolerance)  # inside: distance 0
        if not ok.all():
            out.append((k, int(np.argmin(ok))))
    return out
