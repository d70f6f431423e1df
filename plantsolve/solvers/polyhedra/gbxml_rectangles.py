"""A gbXML surface's ``RectangularGeometry`` (Width × Height) set against the ``PlanarGeometry`` polygon it restates.

Exporters write both; the polygon is what is measured, and a RectangularGeometry that contradicts it (a height typed
30 for 3, a surface moved without its rectangle) says the file disagrees with itself about the surface's size, while
the result went on without a word. Width and Height are the polygon's extents in its own plane, so: a rectangular
polygon (four corners, right angles) must have those two sides, and any polygon must fit in Width × Height (its area
at most theirs).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from plantsolve.schemas.common import Diagnostic

RELATIVE = 0.01  # exporters round Width and Height to a few decimals
_LISTED = 20


def _number(element: Any, name: str, children: Any) -> float | None:
    found = children(element, name)
    if found is None:
        return None
    try:
        value = float((found.text or "").strip())
    except ValueError:
        return None
    return value if math.isfinite(value) and value > 0 else None


def _sides_if_rectangle(points: np.ndarray) -> tuple[float, float] | None:
    """The two side lengths of a four-cornered polygon with right angles, else None."""
    if len(points) != 4:
        return None
    edges = np.roll(points, -1, axis=0) - points
    lengths = np.linalg.norm(edges, axis=1)
    if (lengths <= 0).any():
        return None
    cosines = np.abs((edges * np.roll(edges, -1, axis=0)).sum(axis=1)) / (lengths * np.roll(lengths, -1))
    if (cosines > 1e-3).any():
        return None
    return float(lengths[0]), float(lengths[1])


def _area(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.cross(points, np.roll(points, -1, axis=0)).sum(axis=0)) / 2)


def differs(surface: Any, points: list[list[float]], scale: float, children: Any) -> str | None:
    """Why ``surface``'s RectangularGeometry contradicts its polygon ``points`` (metres), or None; ``scale`` is metres
    per file unit, ``children(element, name)`` the reader's first child by local name."""
    rectangle = children(surface, "RectangularGeometry")
    if rectangle is None:
        return None
    width, height = _number(rectangle, "Width", children), _number(rectangle, "Height", children)
    if width is None or height is None:
        return None
    width, height = width * scale, height * scale
    polygon = np.asarray(points, dtype=float)
    sides = _sides_if_rectangle(polygon)
    stated = sorted((width, height))
    if sides is not None:
        if all(abs(s - t) <= RELATIVE * t for s, t in zip(sorted(sides), stated, strict=True)):
            return None
        return (f"RectangularGeometry {width:g} × {height:g} m, PlanarGeometry a {sides[0]:g} × {sides[1]:g} m "
                "rectangle")
    area = _area(polygon)
    if area <= width * height * (1 + RELATIVE):
        return None
    return f"RectangularGeometry {width:g} × {height:g} m = {width * height:g} m², PlanarGeometry {area:g} m²"


def rectangles_differ(found: list[tuple[str, int | None, str]]) -> Diagnostic | None:
    """One warning for the surfaces (id, line, why) whose two geometries disagree."""
    if not found:
        return None
    named = "; ".join(f"{sid!r} (line {line}): {why}" for sid, line, why in found[:3])
    return Diagnostic(code="rectangular_geometry_differs", message=(
        f"{len(found)} surface(s) state a RectangularGeometry their PlanarGeometry polygon contradicts — {named}"
        f"{' …' if len(found) > 3 else ''}. The polygons were measured; check the exporter's output."),
        details={"count": len(found), "surfaces": [{"surface": sid, "line": line, "differs": why}
                                                    for sid, line, why in found[:_LISTED]]})
