"""One LDraw line read for its geometry: the points a drawing line (types 2, 3, 4) draws, and where a sub-file
reference (type 1) places its file. Shared by the solver's reading of embedded parts and the catalogue's generator,
so both read a line alike. Lines they cannot read (too few or non-numeric fields) give ``None``: LDraw readers skip
such lines."""

from __future__ import annotations

import numpy as np

DRAWING_TYPES = (["2"], ["3"], ["4"])


def drawn_points(tokens: list[str]) -> np.ndarray | None:
    """The ``count × 3`` points of a line, line type 2, 3 or 4 split into ``tokens`` (type, colour, coordinates)."""
    if tokens[:1] not in DRAWING_TYPES:
        return None
    count = int(tokens[0])
    try:
        return np.array([float(t) for t in tokens[2:2 + 3 * count]]).reshape(count, 3)
    except ValueError:
        return None


def placement(raw: str, tokens: list[str]) -> tuple[np.ndarray, np.ndarray, str] | None:
    """A type-1 line's rotation (3 × 3), position and the file it names (spaces in the name kept)."""
    if tokens[:1] != ["1"] or len(tokens) < 15:
        return None
    try:
        values = [float(t) for t in tokens[2:14]]
    except ValueError:
        return None
    return np.array(values[3:]).reshape(3, 3), np.array(values[:3]), raw.split(None, 14)[14].strip()
