"""Holes that lie outside their face: a hole is subtracted from its face's area, so one drawn beside the face, or
larger than it (a loop that was meant as another face, or its outer loop), gives a face of too little — even
negative — area without a word. Each hole's vertices must lie in the outer loop (or on it, within the merge
tolerance), measured in the outer loop's plane."""

from __future__ import annotations

import numpy as np


def _plane_frame(outer: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
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


def _inside_or_on(points: np.ndarray, polygon: np.ndarray, tolerance: float) -> np.ndarray:
    """Per 2-D point: inside the polygon (even-odd rule) or within ``tolerance`` of its boundary."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    x, y = points[:, :1], points[:, 1:]
    crosses = ((a[:, 1] > y) != (b[:, 1] > y))
    with np.errstate(divide="ignore", invalid="ignore"):
        at = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    inside = (crosses & (x < at)).sum(axis=1) % 2 == 1
    ab = b - a
    t = np.clip(((points[:, None, :] - a) * ab).sum(axis=2) / np.maximum((ab * ab).sum(axis=1), 1e-300), 0, 1)
    nearest = a + t[..., None] * ab
    on = (np.linalg.norm(points[:, None, :] - nearest, axis=2) <= tolerance).any(axis=1)
    return inside | on


def holes_outside(loops: list[np.ndarray], tolerance: float) -> list[tuple[int, int]]:
    """(loop index, first vertex outside) of each hole (loops[1:]) with a vertex outside the outer loop."""
    frame = _plane_frame(loops[0] - loops[0].mean(axis=0))
    if frame is None:
        return []
    origin = loops[0].mean(axis=0)
    basis = np.stack(frame, axis=1)
    outer = (loops[0] - origin) @ basis
    out = []
    for k, hole in enumerate(loops[1:], start=1):
        ok = _inside_or_on((hole - origin) @ basis, outer, tolerance)
        if not ok.all():
            out.append((k, int(np.argmin(ok))))
    return out
