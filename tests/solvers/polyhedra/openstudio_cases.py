"""Zones of OpenStudio's Polyhedron unit tests, coordinates transcribed (no code copied).

Source: NREL/OpenStudio, ``src/utilities/geometry/Test/Polyhedron_GTest.cpp`` (commit 09472be5,
January 2025), tests ``Polyhedron_Enclosed``, ``Polyhedron_Titled_Roof`` and
``Polyhedron_Box_With_Hole``. OpenStudio(R), Copyright (c) 2008-2023, Alliance for Sustainable
Energy, LLC; BSD-style licence (redistribution with the copyright notice and conditions of its
LICENSE.md). The expected volumes are the ones those tests assert.
"""

from __future__ import annotations

# A 30 x 10 x 0.3 m plenum whose south wall is split at x = 15 (roof and floor are not): 90 m³.
PLENUM_SPLIT_WALL = {
    "1-SOUTH-1": [[0.0, 0.0, 0.3], [0.0, 0.0, 0.0], [15.0, 0.0, 0.0], [15.0, 0.0, 0.3]],
    "1-SOUTH-2": [[15.0, 0.0, 0.3], [15.0, 0.0, 0.0], [30.0, 0.0, 0.0], [30.0, 0.0, 0.3]],
    "4-NORTH": [[30.0, 10.0, 0.3], [30.0, 10.0, 0.0], [0.0, 10.0, 0.0], [0.0, 10.0, 0.3]],
    "3-EAST": [[30.0, 0.0, 0.3], [30.0, 0.0, 0.0], [30.0, 10.0, 0.0], [30.0, 10.0, 0.3]],
    "2-WEST": [[0.0, 10.0, 0.3], [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.3]],
    "ROOF": [[30.0, 0.0, 0.3], [30.0, 10.0, 0.3], [0.0, 10.0, 0.3], [0.0, 0.0, 0.3]],
    "FLOOR": [[0.0, 0.0, 0.0], [0.0, 10.0, 0.0], [30.0, 10.0, 0.0], [30.0, 0.0, 0.0]],
}
PLENUM_VOLUME = 30.0 * 10.0 * 0.3

# The same base with a tilted roof rising to 10.3 m at y = 0; the roof carries extra collinear
# vertices at x = 10 and 20 on its south edge, the south wall is split at x = 15: 1590 m³.
TILTED_ROOF = {
    "1-SOUTH-2": [[15.0, 0.0, 10.3], [15.0, 0.0, 0.0], [30.0, 0.0, 0.0], [30.0, 0.0, 10.3]],
    "ROOF": [[30.0, 0.0, 10.3], [30.0, 10.0, 0.3], [0.0, 10.0, 0.3], [0.0, 0.0, 10.3], [10.0, 0.0, 10.3],
             [20.0, 0.0, 10.3]],
    "3-EAST": [[30.0, 0.0, 10.3], [30.0, 0.0, 0.0], [30.0, 10.0, 0.0], [30.0, 10.0, 0.3]],
    "4-NORTH": [[30.0, 10.0, 0.3], [30.0, 10.0, 0.0], [0.0, 10.0, 0.0], [0.0, 10.0, 0.3]],
    "2-WEST": [[0.0, 10.0, 0.3], [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 10.3]],
    "1-SOUTH-1": [[0.0, 0.0, 10.3], [0.0, 0.0, 0.0], [15.0, 0.0, 0.0], [15.0, 0.0, 10.3]],
    "FLOOR": [[0.0, 0.0, 0.0], [0.0, 10.0, 0.0], [30.0, 10.0, 0.0], [30.0, 0.0, 0.0]],
}
TILTED_ROOF_VOLUME = 30.0 * 10.0 * 0.3 + 30.0 * 10.0 * 10.0 / 2.0

# A 10 x 10 x 1 m box with a 5 x 5 m shaft through it; roof and floor are single loops that reach
# the hole through a bridge edge walked twice (a keyhole), as OpenStudio writes them: 75 m³.
BOX_WITH_HOLE = {
    "ROOF": [[10.0, 0.0, 1.0], [10.0, 10.0, 1.0], [0.0, 10.0, 1.0], [0.0, 0.0, 1.0], [2.5, 2.5, 1.0],
             [2.5, 7.5, 1.0], [7.5, 7.5, 1.0], [7.5, 2.5, 1.0], [2.5, 2.5, 1.0], [0.0, 0.0, 1.0]],
    "EAST1": [[10.0, 0.0, 1.0], [10.0, 0.0, 0.0], [10.0, 10.0, 0.0], [10.0, 10.0, 1.0]],
    "EAST2": [[7.5, 7.5, 1.0], [7.5, 7.5, 0.0], [7.5, 2.5, 0.0], [7.5, 2.5, 1.0]],
    "NORTH1": [[10.0, 10.0, 1.0], [10.0, 10.0, 0.0], [0.0, 10.0, 0.0], [0.0, 10.0, 1.0]],
    "NORTH2": [[2.5, 7.5, 1.0], [2.5, 7.5, 0.0], [7.5, 7.5, 0.0], [7.5, 7.5, 1.0]],
    "WEST1": [[0.0, 10.0, 1.0], [0.0, 10.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
    "WEST2": [[2.5, 2.5, 1.0], [2.5, 2.5, 0.0], [2.5, 7.5, 0.0], [2.5, 7.5, 1.0]],
    "SOUTH1": [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [10.0, 0.0, 1.0]],
    "SOUTH2": [[7.5, 2.5, 1.0], [7.5, 2.5, 0.0], [2.5, 2.5, 0.0], [2.5, 2.5, 1.0]],
    "FLOOR": [[0.0, 10.0, 0.0], [10.0, 10.0, 0.0], [10.0, 0.0, 0.0], [0.0, 0.0, 0.0], [2.5, 2.5, 0.0],
              [7.5, 2.5, 0.0], [7.5, 7.5, 0.0], [2.5, 7.5, 0.0], [2.5, 2.5, 0.0], [0.0, 0.0, 0.0]],
}
BOX_WITH_HOLE_VOLUME = 10.0 * 10.0 * 1.0 - 5.0 * 5.0 * 1.0


def request(surfaces: dict[str, list[list[float]]], reverse: bool = False) -> dict:
    """A polyhedra request of one zone from named surfaces (OpenStudio's vertex order: counter-clockwise
    seen from outside)."""
    return {"units": "m", "faces": [{"id": name, "loops": [pts[::-1] if reverse else pts]}
                                    for name, pts in surfaces.items()]}
