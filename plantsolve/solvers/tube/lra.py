"""LRA rows ↔ :class:`TubeModel`: what a CNC bender reads (length, rotation, angle, bend radius
per row, degrees) and the model the solver fits (radians). One implementation each way, used by
the solve, the inspection and the tests."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.tube import LraRow
from plantsolve.solvers.tube.model import TubeModel


def model_rows(model: TubeModel) -> list[LraRow]:
    """n + 1 rows for n bends; rotations in (-180°, 180°], the first and last row's zero."""
    n = model.n_bends
    rows = []
    for i in range(n + 1):
        rot = 0.0 if i in (0, n) else float(np.degrees(np.arctan2(np.sin(model.rotations[i]), np.cos(model.rotations[i]))))
        rows.append(LraRow(length=max(float(model.lengths[i]), 0.0), rotation=rot,
                           angle=float(np.degrees(model.angles[i])) if i < n else 0.0,
                           bend_radius=float(model.radii[i]) if i < n else 0.0))
    return rows


def model_from_rows(rows: list[LraRow], pipe_radius: float) -> TubeModel:
    """A model at the origin in the world frame from LRA rows (the last row has no bend)."""
    n = len(rows) - 1
    return TubeModel(np.zeros(3), np.eye(3), np.array([r.length for r in rows], float),
                     np.radians([r.rotation for r in rows]), np.radians([r.angle for r in rows[:n]]),
                     np.array([r.bend_radius for r in rows[:n]], float), float(pipe_radius))
