"""EnergyPlus' simple-geometry objects as polygons: rectangles given by azimuth, tilt, a starting corner
and their sides (EnergyPlus Input Output Reference, "Surface(s) – Simple Geometry"; the vertex
construction of ``MakeRectangularVertices`` and ``MakeRelativeRectangularVertices``).

A base surface (``Wall:Exterior`` … ``Floor:Interzone``) starts at its lower-left corner as seen from
outside, runs ``Length`` to the right and ``Height`` (or ``Width``) up its plane. Its outward normal
points at compass bearing ``azimuth`` (clockwise from north = +y) tilted ``tilt`` from the zenith
(0: a roof facing up, 90: a wall, 180: a floor facing down). The rectangle's vertices are written
upper-left first, counter-clockwise seen from outside (the solver's face convention).

A subsurface (``Window``, ``Door``, … ``GlazedDoor:Interzone``) is placed in its base surface's plane:
``Starting X`` to the right and ``Starting Z`` up from the base's lower-left corner.
"""

from __future__ import annotations

import math

import numpy as np

from plantsolve.schemas.polyhedra import MAX_COORDINATE

# class -> (whether an Outside Boundary Condition Object field follows the zone/space name, default tilt)
SIMPLE_SURFACES = {
    "wall:exterior": (False, 90.0),
    "wall:adiabatic": (False, 90.0),
    "wall:underground": (False, 90.0),
    "wall:interzone": (True, 90.0),
    "roof": (False, 0.0),
    "ceiling:adiabatic": (False, 0.0),
    "ceiling:interzone": (True, 0.0),
    "floor:groundcontact": (False, 180.0),
    "floor:adiabatic": (False, 180.0),
    "floor:interzone": (True, 180.0),
}
# class -> the field counts it may have (Name … Height); the last four are Starting X, Starting Z,
# Length, Height. Window and GlazedDoor had a Shading Control Name field before EnergyPlus 9.0.
SIMPLE_SUBSURFACES = {
    "window": (9, 10),
    "door": (8,),
    "glazeddoor": (9, 10),
    "window:interzone": (9,),
    "door:interzone": (9,),
    "glazeddoor:interzone": (9,),
}


def _numbers(fields: list[str], names: tuple[str, ...], defaults: dict[str, float]) -> list[float]:
    values = []
    for name, field in zip(names, fields, strict=True):
        text = field.strip()
        if not text and name in defaults:
            values.append(defaults[name])
            continue
        try:
            x = float(text)
        except ValueError:
            raise ValueError(f"{name} is {field!r}, not a number") from None
        if not math.isfinite(x):
            raise ValueError(f"{name} is {field!r}, not finite")
        if abs(x) > MAX_COORDINATE:  # a writer's garbage: the schema's refusal would name a face index, not the line
            raise ValueError(f"{name} is {field!r}, beyond ±{MAX_COORDINATE:g}")
        values.append(x)
    return values


def _trimmed(fields: list[str]) -> list[str]:
    out = list(fields)
    while out and not out[-1].strip():
        out.pop()
    return out


def rectangle(azimuth: float, tilt: float, start: np.ndarray, length: float, height: float) -> list[list[float]]:
    """Upper-left, lower-left, lower-right, upper-right corners of the rectangle whose lower-left corner
    (seen from outside) is ``start``; azimuth and tilt in degrees."""
    if not (length > 0 and height > 0):
        raise ValueError(f"length {length:g} and height/width {height:g} must be positive")
    az, ti = math.radians(azimuth), math.radians(tilt)
    # right (seen from outside) is horizontal; up is normal × right
    right = np.array([-math.cos(az), math.sin(az), 0.0])
    up = np.array([-math.cos(ti) * math.sin(az), -math.cos(ti) * math.cos(az), math.sin(ti)])
    start = np.asarray(start, dtype=float)
    corners = (start + height * up, start, start + length * right, start + length * right + height * up)
    return [[float(c) for c in p] for p in corners]


def base_surface(cls: str, fields: list[str]) -> tuple[str, list[list[float]]]:
    """(zone name, four vertices in the zone's coordinates) of a simple base surface."""
    has_object, default_tilt = SIMPLE_SURFACES[cls]
    fields = _trimmed(fields)
    plain = 10 + has_object  # Name, Construction, Zone, [Outside Boundary Condition Object], 7 numbers
    if len(fields) not in (plain, plain + 1):  # +1: the Space Name field of EnergyPlus 9.6+
        raise ValueError(f"{len(fields)} fields; {cls} has {plain} (or {plain + 1} with a Space Name)")
    if not fields[2].strip():
        raise ValueError("no zone name")
    names = ("Azimuth Angle", "Tilt Angle", "Starting X Coordinate", "Starting Y Coordinate",
             "Starting Z Coordinate", "Length", "Height" if cls.startswith("wall") else "Width")
    azimuth, tilt, x, y, z, length, height = _numbers(fields[-7:], names, {"Tilt Angle": default_tilt})
    return fields[2], rectangle(azimuth, tilt, np.array([x, y, z]), length, height)


def subsurface(cls: str, fields: list[str], host: list[list[float]]) -> list[list[float]]:
    """The four vertices of a simple window or door on ``host`` (its base surface's loop, upper-left
    first and counter-clockwise from outside, as EnergyPlus keeps it: vertex 2 is the lower-left)."""
    fields = _trimmed(fields)
    counts = SIMPLE_SUBSURFACES[cls]
    if len(fields) not in counts:
        raise ValueError(f"{len(fields)} fields; {cls} has {' or '.join(map(str, counts))}")
    x, z, length, height = _numbers(fields[-4:], ("Starting X Coordinate", "Starting Z Coordinate", "Length",
                                                  "Height"), {})
    points = np.asarray(host, dtype=float)
    normal = np.zeros(3)
    for a, b in zip(points, np.roll(points, -1, axis=0), strict=True):  # Newell
        normal += np.cross(a, b)
    lower_left, right = points[1], points[2] - points[1]
    if np.linalg.norm(normal) == 0 or np.linalg.norm(right) == 0:
        raise ValueError("its base surface has no area")
    normal /= np.linalg.norm(normal)
    right /= np.linalg.norm(right)
    up = np.cross(normal, right)
    if not (length > 0 and height > 0):
        raise ValueError(f"length {length:g} and height {height:g} must be positive")
    start = lower_left + x * right + z * up
    corners = (start + height * up, start, start + length * right, start + length * right + height * up)
    return [[float(c) for c in p] for p in corners]
