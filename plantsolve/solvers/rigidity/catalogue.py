"""A catalogue of common LEGO parts: box shape and connection points (the seed's §3.2 structure).

Every coordinate is in LDraw units (LDU) in the part's own LDraw frame: 1 stud pitch = 20 LDU, a
brick is 24 LDU high, a plate 8; −y is up. Bricks and plates have their origin at the centre of
the top face, the long side along x (a 2×4 brick spans x ∈ [−40, 40], z ∈ [−20, 20], y ∈ [0, 24]).
Technic holes of the 1×N technic bricks run along z through y = 10, between the studs. Pins and
axles in this catalogue lie along their local z axis, centred on the origin.

A connection point is ``(type, point, direction)``: for studs and anti-studs the direction points
away from the part (studs up, −y; anti-studs down, +y); for pins, holes, axles and hinge halves it
is the axis (sign irrelevant). Compatible pairs (``MATES``) that meet at one point make a
connection: stud/anti-stud with opposite directions (one stud alone is a hinge about its axis;
two or more between the same two parts are rigid), pin/pin hole with parallel axes (a hinge),
axle/axle hole (rigid), axle/pin hole (a cylindrical joint: the axle turns and slides),
hinge_a/hinge_b with parallel axes (a hinge). Anti-studs sit under the studs only (the tubes
between them, which also grip studs, are not modelled).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BRICK = 24
PLATE = 8
PITCH = 20

UP = (0, -1, 0)
DOWN = (0, 1, 0)
Z = (0, 0, 1)
X = (1, 0, 0)


@dataclass(frozen=True)
class Connector:
    type: str
    point: tuple[int, int, int]
    direction: tuple[int, int, int]


@dataclass(frozen=True)
class PartShape:
    number: str
    name: str
    box_center: tuple[float, float, float]
    box_size: tuple[float, float, float]
    connectors: tuple[Connector, ...]

    def points(self) -> np.ndarray:
        return np.array([c.point for c in self.connectors], dtype=float).reshape(-1, 3)


MATES = {
    ("stud", "antistud"): "stud", ("antistud", "stud"): "stud",
    ("pin", "pinhole"): "pin", ("pinhole", "pin"): "pin",
    ("axle", "axlehole"): "axle", ("axlehole", "axle"): "axle",
    ("axle", "pinhole"): "axle_round", ("pinhole", "axle"): "axle_round",
    ("hinge_a", "hinge_b"): "hinge", ("hinge_b", "hinge_a"): "hinge",
}
"""Connector types that fit together -> the connection they make."""

OPPOSED = {"stud"}  # connections whose directions must be opposite (the others only parallel)


def _grid(width: int, length: int) -> list[tuple[int, int]]:
    """Stud (x, z) centres of a width × length part, length along x."""
    return [(PITCH * i - PITCH * (length - 1) // 2, PITCH * k - PITCH * (width - 1) // 2)
            for i in range(length) for k in range(width)]


def _block(number, name, width, length, height, studs=True, antistuds=True, extra=()) -> PartShape:
    connectors = []
    for x, z in _grid(width, length):
        if studs:
            connectors.append(Connector("stud", (x, 0, z), UP))
        if antistuds:
            connectors.append(Connector("antistud", (x, height, z), DOWN))
    connectors.extend(extra)
    return PartShape(number, name, (0.0, height / 2, 0.0),
                     (float(PITCH * length), float(height), float(PITCH * width)), tuple(connectors))


def _technic_brick(number, length, holes="pinhole") -> PartShape:
    xs = [PITCH * i - PITCH * (length - 2) // 2 for i in range(length - 1)] if length > 1 else [0]
    extra = [Connector(holes, (x, 10, 0), Z) for x in xs]
    return _block(number, f"Technic Brick 1 x {length} with Holes", 1, length, BRICK, extra=extra)


def _rod(number, name, kind, length_studs, half_width=4.0) -> PartShape:
    """A pin or an axle along z: connection points at the centre of each stud-pitch segment."""
    zs = [PITCH * i - PITCH * (length_studs - 1) // 2 for i in range(length_studs)] if length_studs > 1 else [0]
    if kind == "pin":
        zs = [-10, 10]
    connectors = tuple(Connector(kind, (0, 0, z), Z) for z in zs)
    length = PITCH * length_studs
    return PartShape(number, name, (0.0, 0.0, 0.0), (2 * half_width, 2 * half_width, float(length)), connectors)


def _build() -> dict[str, PartShape]:
    parts = {}
    bricks = {"3005": (1, 1), "3004": (1, 2), "3622": (1, 3), "3010": (1, 4), "3009": (1, 6), "3008": (1, 8),
              "3003": (2, 2), "3002": (2, 3), "3001": (2, 4), "2456": (2, 6), "3007": (2, 8), "3006": (2, 10)}
    plates = {"3024": (1, 1), "3023": (1, 2), "3623": (1, 3), "3710": (1, 4), "3666": (1, 6), "3460": (1, 8),
              "3022": (2, 2), "3021": (2, 3), "3020": (2, 4), "3795": (2, 6), "3034": (2, 8), "3832": (2, 10)}
    for number, (w, l) in bricks.items():
        parts[number] = _block(number, f"Brick {w} x {l}", w, l, BRICK)
    for number, (w, l) in plates.items():
        parts[number] = _block(number, f"Plate {w} x {l}", w, l, PLATE)
    for number, length in {"3700": 2, "3701": 4, "3894": 6, "3702": 8}.items():
        parts[number] = _technic_brick(number, length)
    parts["32064"] = _block("32064", "Technic Brick 1 x 2 with Axle Hole", 1, 2, BRICK,
                            extra=[Connector("axlehole", (0, 10, 0), Z)])
    parts["2780"] = _rod("2780", "Technic Pin with Friction Ridges", "pin", 2)
    for number, n in {"3704": 2, "3705": 4, "3706": 6, "3707": 8}.items():
        parts[number] = _rod(number, f"Technic Axle {n}", "axle", n, half_width=3.0)
    # Hinge brick 1 x 2: the base's hinge axis runs along x at the centre of its top; the top plate
    # sits on it with its own hinge line at the centre of its underside.
    parts["3937"] = _block("3937", "Hinge Brick 1 x 2 Base", 1, 2, BRICK, studs=False,
                           extra=[Connector("hinge_a", (0, 0, 0), X)])
    parts["3938"] = _block("3938", "Hinge Brick 1 x 2 Top Plate", 1, 2, PLATE, antistuds=False,
                           extra=[Connector("hinge_b", (0, PLATE, 0), X)])
    return parts


CATALOGUE: dict[str, PartShape] = _build()


def normalise_number(name: str) -> str:
    """'3001.dat', '3001.DAT', 'parts/3001.dat' -> '3001'."""
    base = name.strip().replace("\\", "/").rsplit("/", 1)[-1].lower()
    return base[:-4] if base.endswith(".dat") else base


def lookup(name: str) -> PartShape | None:
    return CATALOGUE.get(normalise_number(name))
