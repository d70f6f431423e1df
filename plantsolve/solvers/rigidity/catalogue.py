"""A catalogue of common LEGO parts: box shape and connection points (the seed's §3.2 structure).

Every coordinate is in LDraw units (LDU) in the part's own frame as the official LDraw library
draws it (so ``.ldr`` files from any editor place the parts as they are here): 1 stud pitch = 20
LDU, a brick is 24 LDU high, a plate 8; −y is up. Bricks and plates have their origin at the centre
of the top face, the long side along x (a 2×4 brick spans x ∈ [−40, 40], z ∈ [−20, 20],
y ∈ [0, 24]). The connection points follow the LDraw parts' connection data (the LDCad shadow
library's snap meta lines):

- 1×N technic bricks (3700, 3701, 3894, 3702): N − 1 pin holes between the studs at y = 10, their
  axis along z; 32064 has one axle hole there. Anti-studs at y = 24 under the studs.
- Pins (3673, 2780) and axles (3704–3707) lie along x, centred on the origin: a pin is 40 LDU long,
  its two 20-LDU halves centred at x = ±10 with the collar at x = 0; axle N is 20·N LDU long, one run
  from x = −10·N to 10·N (it slides: a hole may sit anywhere along it). A pin joining two side-by-side technic bricks is
  therefore placed turned a quarter turn about y (its x axis onto z), e.g. the LDraw matrix ``0 0 1 0 1 0
  −1 0 0``.
- Studless beams (32523 … 32278, 3 to 15 holes) as 32524 is drawn: along z, centred on the middle
  hole, holes along y every 20 LDU, 18 × 20 LDU in section. Gears 3647, 3648, 3649 (8, 24, 40 teeth)
  as 3647 is drawn: axis z through the origin, an axle hole there; so is the bush 3713 (20 LDU long,
  flanges of radius 9).
- Hinge brick 1 × 2 (3937 base, 3938 top plate): both have their hinge axis along x through
  (0, 10, 0) in their own frame, so a straight hinge has the top placed at the base's very position
  and rotation. The base has two anti-studs at y = 24 and no studs, the top two studs at y = 0; the
  base's box is y ∈ [10, 24], the top's y ∈ [0, 10], so the pair touches without overlapping.

A connection point is ``(type, point, direction)``: for studs and anti-studs the direction points
away from the part (studs up, −y; anti-studs down, +y); for pins, holes, axles and hinge halves it
is the axis (sign irrelevant). Compatible pairs (``MATES``) that meet at one point make a
connection: stud/anti-stud with opposite directions (one stud alone is a hinge about its axis;
two or more between the same two parts are rigid), pin/pin hole with parallel axes (a hinge),
axle/axle hole (rigid), axle/pin hole (a cylindrical joint: the axle turns and slides),
hinge_a/hinge_b with parallel axes (a hinge). Anti-studs sit under the studs and, on parts two or more
studs wide, at the tubes between each four studs (a stud placed there, half a pitch off in both
directions, is gripped by the tube).

Collision shapes (:func:`collision_boxes`): a part's ``solids`` (boxes; by default its bounding box)
less a square prism of side 12 LDU through every pin and axle hole, the diameter of LDraw's peghole;
pins and axles are 12 LDU across, so a rod in or through a hole touches its part without entering
it. A gear is its pitch disc (three boxes inscribed in the circle) and hub: gears in mesh do not
overlap. Everything here is numbers per part (frame, boxes, connection points).

:func:`lookup` finds a part here first, then in the catalogue generated from the LDCad shadow library
(:mod:`generated`: thousands of official parts, their connection points from snap data, a collision
shape only for plain rectangular parts), which adds ball/socket, clip/bar and hinge-finger connections.
:func:`recorded_part` reads a part from a record of the generated catalogue's format that a model brought
(an embedded part resolved from the primitives it draws: :mod:`embedded`).
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

from plantsolve.schemas.common import MAX_COORDINATE
from plantsolve.solvers.rigidity import generated

BRICK = 24
PLATE = 8
PITCH = 20

UP = (0, -1, 0)
DOWN = (0, 1, 0)
Z = (0, 0, 1)  # technic holes
X = (1, 0, 0)  # pins, axles, hinge lines


@dataclass(frozen=True)
class Connector:
    """A connection point, or with ``length`` > 0 a run along ``direction`` from ``point`` (an axle, a bar):
    a hole or a clip whose centre lies anywhere on the run meets it."""

    type: str
    point: tuple[int, int, int]
    direction: tuple[int, int, int]
    length: float = 0.0
    profile: tuple = ()  # a fit cylinder's sections ((shape, radius, length), …) from ``point`` along ``direction``
    depth: float = 0.0  # LDU: a hole's bore (a clip's width) along ``direction``, centred on ``point`` (0: not stated)


RING_REACH = 10.0 * 2 ** 0.5  # LDU: from a ring's centre to each of the four studs it stands between
FITS = ("fit_m", "fit_f")  # a snap cylinder as the data states it (male, female): see :func:`fit`
CLIPS = ("clip", "rodclip")  # a clip whose radius is a bar's, one for a rod of another radius (:mod:`generated`)
NOT_DOCKED = (*FITS, "ring")  # found between placed parts only (docking poses come from points that meet)
SAMPLE_STEP = {"axle": 10.0, "bar": 2.0}  # LDU: where docking tries a run (a hole every half stud, a clip anywhere)


def samples(connector: Connector) -> tuple[Connector, ...]:
    """A run as points (every SAMPLE_STEP from its start, inset by half a step for an axle so that a hole's
    centre meets it at whole or half studs); a point as itself."""
    if connector.length <= 0:
        return (connector,)
    step = SAMPLE_STEP.get(connector.type, PITCH / 2)
    inset = step if connector.type == "axle" and connector.length >= 2 * step else 0.0
    start, axis = np.asarray(connector.point, float), np.asarray(connector.direction, float)
    if connector.length > 2 * inset:
        ts = np.arange(inset, connector.length - inset + 1e-9, step)
    else:
        ts = [connector.length / 2]
    return tuple(Connector(connector.type, tuple(_tidy(v) for v in start + axis * t), connector.direction) for t in ts)


def _tidy(v: float) -> float | int:
    r = round(float(v))
    return r if abs(float(v) - r) < 1e-9 else round(float(v), 6)


Box = tuple[tuple[float, float, float], tuple[float, float, float]]  # (centre, size) in the part's frame


@dataclass(frozen=True)
class PartShape:
    """A part's bounding box, connection points and, when one box is too coarse, the solid boxes whose
    union is its material before the holes are cut (``solids``; empty: the bounding box). Everything a
    generated data file would give per part: numbers only, no code."""

    number: str
    name: str
    box_center: tuple[float, float, float]
    box_size: tuple[float, float, float]
    connectors: tuple[Connector, ...]
    solids: tuple[Box, ...] = ()
    collides: bool = True  # false: no collision shape known (a generated part that is not a plain box)

    def points(self) -> np.ndarray:
        return np.array([c.point for c in self.connectors], dtype=float).reshape(-1, 3)

    def sampled(self) -> PartShape:
        """The part with every run (axle, bar) as points along it and without its fit cylinders and rings: how
        docking tries poses."""
        if all(c.length <= 0 and c.type not in NOT_DOCKED for c in self.connectors):
            return self
        return replace(self, connectors=tuple(p for c in self.connectors if c.type not in NOT_DOCKED
                                              for p in samples(c)))


HOLE_RADIUS = 6  # LDU: a technic hole's and a pin's or axle's radius (LDraw's peghole and axle primitives)
HOLES = {"pinhole", "axlehole"}


def _cut(box: Box, hole: Connector) -> list[Box]:
    """``box`` less the square prism of half-width HOLE_RADIUS around the hole's axis, which runs through
    the whole box: up to four boxes (two beside the hole, one on each side between them)."""
    direction = np.abs(np.asarray(hole.direction, float))
    axis = int(np.argmax(direction))
    if direction[axis] < 0.999:  # a hole at an angle to the box: not cut (its part is then solid there)
        return [box]
    u, v = [k for k in range(3) if k != axis]
    center, size = np.asarray(box[0], float), np.asarray(box[1], float)
    lo, hi = center - size / 2, center + size / 2
    h_lo = np.asarray(hole.point, float) - HOLE_RADIUS
    h_hi = np.asarray(hole.point, float) + HOLE_RADIUS
    if h_lo[u] >= hi[u] or h_hi[u] <= lo[u] or h_lo[v] >= hi[v] or h_hi[v] <= lo[v]:
        return [box]
    cu0, cu1 = max(lo[u], h_lo[u]), min(hi[u], h_hi[u])
    pieces = [((lo[u], cu0), (lo[v], hi[v])), ((cu1, hi[u]), (lo[v], hi[v])),
              ((cu0, cu1), (lo[v], max(lo[v], h_lo[v]))), ((cu0, cu1), (min(hi[v], h_hi[v]), hi[v]))]
    out = []
    for (a0, a1), (b0, b1) in pieces:
        if a1 - a0 <= 1e-9 or b1 - b0 <= 1e-9:
            continue
        p_lo, p_hi = lo.copy(), hi.copy()
        p_lo[u], p_hi[u], p_lo[v], p_hi[v] = a0, a1, b0, b1
        out.append((tuple(float(x) for x in (p_lo + p_hi) / 2), tuple(float(x) for x in p_hi - p_lo)))
    return out


@functools.lru_cache(maxsize=1024)
def collision_boxes(shape: PartShape) -> tuple[Box, ...]:
    """The part's collision shape as boxes in its own frame: its solids (or its bounding box) with every
    pin and axle hole cut through, so a pin or an axle in a hole, or passing through it, touches the part
    without entering it (square holes and rods of side 2 · HOLE_RADIUS: a rod fits its hole exactly).
    Empty for a part without a collision shape."""
    if not shape.collides:
        return ()
    boxes = list(shape.solids) or [(shape.box_center, shape.box_size)]
    for hole in (c for c in shape.connectors if c.type in HOLES):
        boxes = [piece for box in boxes for piece in _cut(box, hole)]
    return tuple(boxes)


MATES = {
    ("stud", "antistud"): "stud", ("antistud", "stud"): "stud",
    ("pin", "pinhole"): "pin", ("pinhole", "pin"): "pin",
    ("axle", "axlehole"): "axle", ("axlehole", "axle"): "axle",
    ("axle", "pinhole"): "axle_round", ("pinhole", "axle"): "axle_round",
    ("hinge_a", "hinge_b"): "hinge", ("hinge_b", "hinge_a"): "hinge",
    ("finger", "finger"): "hinge", ("finger", "hinge_a"): "hinge", ("hinge_a", "finger"): "hinge",
    ("finger", "hinge_b"): "hinge", ("hinge_b", "finger"): "hinge",
    ("ball", "socket"): "ball", ("socket", "ball"): "ball",
    ("clip", "bar"): "clip", ("bar", "clip"): "clip",
    ("bar", "barhole"): "bar", ("barhole", "bar"): "bar",
    ("fit_m", "fit_f"): "fit", ("fit_f", "fit_m"): "fit",
    ("ring", "stud"): "ring", ("stud", "ring"): "ring",
}
"""Connector types that fit together -> the connection they make."""

GROUP = "group"  # the connection of a grouped generic snap pair (generated parts)


# generic snaps: of one group, ungrouped of one bounding shape and size, a grouped clip and its group's cylinder
GENERIC = ("group:", "shape:", "pivot:")


def mate(a: str, b: str) -> str | None:
    """The connection two connector types make, or None: :data:`MATES`, or the male and female of one
    generic snap group (``group:<name>:M`` with ``group:<name>:F``) or of one ungrouped bounding (``shape:box 20 54
    2:M`` with ``shape:box 20 54 2:F``), rigid, or of one clip group (``pivot:<name>:M`` with ``pivot:<name>:F``),
    a hinge."""
    kind = MATES.get((a, b))
    if kind is None and a.startswith(GENERIC) and b.startswith(GENERIC):
        ga, gb = a.rsplit(":", 1), b.rsplit(":", 1)
        if ga[0] == gb[0] and ga[1] != gb[1]:
            return "hinge" if a.startswith("pivot:") else GROUP
    return kind


def counterparts(a: str) -> set[str]:
    """Every connector type that fits a connector of type ``a``."""
    if a.startswith(GENERIC):
        name, gender = a.rsplit(":", 1)
        return {f"{name}:{'F' if gender == 'M' else 'M'}"}
    return {t for (x, t) in MATES if x == a}


OPPOSED = {"stud"}  # connections whose directions must be opposite (the others only parallel)
ANY_DIRECTION = {"ball"}  # connections at a point whatever the directions


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
    if antistuds and width >= 2 and length >= 2:  # the tubes between each four studs grip a stud too
        connectors.extend(Connector("antistud", (x, height, z), DOWN) for x, z in _grid(width - 1, length - 1))
    connectors.extend(extra)
    return PartShape(number, name, (0.0, height / 2, 0.0),
                     (float(PITCH * length), float(height), float(PITCH * width)), tuple(connectors))


def _technic_brick(number, length, holes="pinhole") -> PartShape:
    xs = [PITCH * i - PITCH * (length - 2) // 2 for i in range(length - 1)] if length > 1 else [0]
    extra = [Connector(holes, (x, 10, 0), Z, depth=float(PITCH)) for x in xs]
    return _block(number, f"Technic Brick 1 x {length} with Holes", 1, length, BRICK, extra=extra)


# (shape, radius, length) from one tip to the other: chamfered tips, two 16-LDU shafts, the collar between them
PIN_PROFILE = (("L_", 6.25, 2.0), ("R", 6.0, 16.0), ("R", 8.0, 4.0), ("R", 6.0, 16.0), ("_L", 6.25, 2.0))


def _rod(number, name, kind, length_studs, half_width=float(HOLE_RADIUS)) -> PartShape:
    """A pin or an axle along x, centred on the origin. A pin's points are its two halves' centres
    (x = ±10), and it is also its snap cylinder as the shadow library states 3673's (:data:`PIN_PROFILE`), so a
    hole that is not centred on a half holds it too (a half-thick liftarm's, 10 LDU deep); an axle slides in its
    holes, so it is one run from end to end: a hole whose centre lies on it meets it, however deep the axle went
    in."""
    half = PITCH // 2
    if kind == "pin":
        connectors = tuple(Connector(kind, (x, 0, 0), X) for x in (-half, half)) + (
            Connector("fit_m", (-PITCH, 0, 0), X, float(2 * PITCH), PIN_PROFILE),)
    else:  # an axle: one run along its length
        connectors = (Connector(kind, (-half * length_studs, 0, 0), X, float(PITCH * length_studs)),)
    return PartShape(number, name, (0.0, 0.0, 0.0), (float(PITCH * length_studs), 2 * half_width, 2 * half_width),
                     connectors)


def _beam(number, holes) -> PartShape:
    """A studless beam (liftarm) of an odd number of holes as the LDraw library draws 32524: along z,
    centred on its middle hole, holes every 20 LDU along y through its 20-LDU thickness, 18 LDU wide
    (x ∈ [−9, 9]) with round ends of radius 9 around the end holes (here square)."""
    reach = PITCH // 2 * (holes - 1)
    connectors = tuple(Connector("pinhole", (0, 0, z), DOWN, depth=float(PITCH))
                       for z in range(-reach, reach + 1, PITCH))
    return PartShape(number, f"Technic Beam {holes}", (0.0, 0.0, 0.0), (18.0, float(PITCH), 2.0 * (reach + 9)),
                     connectors)


def _inscribed_disc(radius: float, thickness: float) -> list[Box]:
    """A disc about z as three boxes with their corners on its circle (two crossed rectangles and a square):
    inside the disc everywhere, so gears that mesh at their pitch circles do not overlap."""
    c30, s30, c45 = (radius * math.cos(math.pi / 6), radius * math.sin(math.pi / 6), radius * math.cos(math.pi / 4))
    return [((0.0, 0.0, 0.0), (2 * c30, 2 * s30, thickness)), ((0.0, 0.0, 0.0), (2 * s30, 2 * c30, thickness)),
            ((0.0, 0.0, 0.0), (2 * c45, 2 * c45, thickness))]


def _gear(number, teeth, thickness) -> PartShape:
    """A spur gear as LDraw draws 3647: axis along z through the origin, an axle hole there. Its shape is
    the pitch disc (radius 1.25 LDU per tooth: module 1 mm = 2.5 LDU) and a hub 1 stud long and 16 LDU
    across; the teeth beyond the pitch circle are left out so meshing gears are not collisions."""
    radius = 1.25 * teeth
    hub = ((0.0, 0.0, 0.0), (16.0, 16.0, float(PITCH)))
    solids = tuple([hub, *_inscribed_disc(radius, thickness)]) if thickness < PITCH else tuple(
        _inscribed_disc(max(radius, 8.0), float(PITCH)))
    return PartShape(number, f"Technic Gear {teeth} Tooth", (0.0, 0.0, 0.0), (2 * radius, 2 * radius, float(PITCH)),
                     (Connector("axlehole", (0, 0, 0), Z, depth=float(PITCH)),), solids)  # through the hub


def _hinge_brick() -> tuple[PartShape, PartShape]:
    """3937 and 3938: the hinge axis along x through (0, 10, 0) in both frames; the base below it
    (anti-studs at y = 24), the top above it (studs at y = 0)."""
    hinge_y = 10
    base = PartShape("3937", "Hinge Brick 1 x 2 Base", (0.0, (hinge_y + BRICK) / 2, 0.0),
                     (2.0 * PITCH, float(BRICK - hinge_y), float(PITCH)),
                     tuple([Connector("antistud", (x, BRICK, 0), DOWN) for x in (-10, 10)]
                           + [Connector("hinge_a", (0, hinge_y, 0), X)]))
    top = PartShape("3938", "Hinge Brick 1 x 2 Top Plate", (0.0, hinge_y / 2, 0.0),
                    (2.0 * PITCH, float(hinge_y), float(PITCH)),
                    tuple([Connector("stud", (x, 0, 0), UP) for x in (-10, 10)]
                          + [Connector("hinge_b", (0, hinge_y, 0), X)]))
    return base, top


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
    for number, length in {"3700": 2, "3701": 4, "3894": 6, "3702": 8, "2730": 10, "3895": 12, "32018": 14,
                           "3703": 16}.items():
        parts[number] = _technic_brick(number, length)
    parts["32064"] = _block("32064", "Technic Brick 1 x 2 with Axle Hole", 1, 2, BRICK,
                            extra=[Connector("axlehole", (0, 10, 0), Z, depth=float(PITCH))])
    parts["3673"] = _rod("3673", "Technic Pin", "pin", 2)
    parts["2780"] = _rod("2780", "Technic Pin with Friction Ridges", "pin", 2)
    for number, n in {"3704": 2, "3705": 4, "3706": 6, "3707": 8}.items():
        parts[number] = _rod(number, f"Technic Axle {n}", "axle", n)
    for number, n in {"4519": 3, "32073": 5, "44294": 7, "60485": 9, "3737": 10, "3708": 12}.items():
        parts[number] = _rod(number, f"Technic Axle {n}", "axle", n)
    for number, holes in {"32523": 3, "32316": 5, "32524": 7, "40490": 9, "32525": 11, "41239": 13,
                          "32278": 15}.items():
        parts[number] = _beam(number, holes)
    parts["3647"] = _gear("3647", 8, PITCH)
    for number in ("3648", "3648a", "3648b"):  # the library renamed 3648 to 3648b; files carry either name
        parts[number] = _gear(number, 24, 8.0)
    parts["3713"] = PartShape("3713", "Technic Bush", (0.0, 0.0, 0.0), (18.0, 18.0, float(PITCH)),
                              (Connector("axlehole", (0, 0, 0), Z, depth=float(PITCH)),))
    parts["3649"] = _gear("3649", 40, 8.0)
    parts["3937"], parts["3938"] = _hinge_brick()
    return parts


CATALOGUE: dict[str, PartShape] = _build()


def normalise_number(name: str) -> str:
    """'3001.dat', '3001.DAT', 'parts/3001.dat' -> '3001'."""
    base = name.strip().replace("\\", "/").rsplit("/", 1)[-1].lower()
    return base[:-4] if base.endswith(".dat") else base


def lookup(name: str) -> PartShape | None:
    """A part by its file name: the hand-coded catalogue first, then the one generated from the LDCad shadow
    library (:mod:`generated`)."""
    number = normalise_number(name)
    found = CATALOGUE.get(number)
    if found is None:
        return generated_part(number)
    return _with_fits(found)


@functools.lru_cache(maxsize=256)
def _with_fits(shape: PartShape) -> PartShape:
    """A hand-coded part with the snap cylinders the generated catalogue gives the same part: its typed points
    (an axle, a pin hole) mate only typed points, so without them a hand-coded axle would join no generated
    part whose holes the data states as cylinders alone (an axle through a Technic plate's round hole). The
    generated part's lines are in the same LDraw part frame. A cylinder where the hand-coded part already has a
    stud or an anti-stud says nothing new and is left out: every such duplicate is one
    more point to match in every model the part is in (a 500-part build took half as long again)."""
    generated_shape = generated_part(shape.number)
    if generated_shape is None:
        return shape
    stated = {c.type for c in shape.connectors}  # a gender it states already (a pin's cylinder) is not doubled
    occupied = {tuple(round(v) for v in c.point) for c in shape.connectors if c.type in ("stud", "antistud")}
    extra = tuple(c for c in generated_shape.connectors if c.type in FITS and c.type not in stated
                  and tuple(round(v) for v in c.point) not in occupied)
    return replace(shape, connectors=shape.connectors + extra) if extra else shape


# Old part numbers whose drawings follow the frame of the part they were moved to, not the library's redirection:
# the 2022 library moved the open-centre Technic bricks 4 x 6 and 6 x 8 to 32531a and 32532a with a `~Moved to`
# file that turns the new part a quarter turn about y, yet the official models that name the old numbers place them
# in the new part's own frame (the pins of 10030, 10179, 10248, 10252 and 70816 in holes of 32531 that way; 10252's
# 19 LDU off a hole the other way; those of 75060 and 75827 in 32532's). Other moved parts keep the redirection: 2714's
# turned frame is the one the models (10212, 5571) are drawn in.
DRAWN_AS_MOVED = {"32531": "32531a", "32532": "32532a"}


@functools.lru_cache(maxsize=4096)
def generated_part(number: str) -> PartShape | None:
    moved = DRAWN_AS_MOVED.get(number)
    fields = generated.entry(moved or number)
    if fields is not None and moved:
        fields["number"] = number
    return None if fields is None else _shape(fields)


def _shape(fields: dict) -> PartShape:
    connectors = tuple(Connector(*c) for c in fields.pop("connectors"))
    return PartShape(connectors=connectors, **fields)


def recorded_part(number: str, record: dict) -> PartShape:
    """A part from a catalogue record outside the data file (an embedded part resolved from its primitives:
    :mod:`embedded`), read as a generated part; ValueError when the record is not one."""
    try:
        shape = _shape(generated.fields(number, record))
        numbers = np.concatenate([shape.points().ravel(), shape.box_center, shape.box_size])
    except (KeyError, TypeError, ValueError, IndexError, AttributeError) as error:
        raise ValueError(f"part {number!r}: its record is not a catalogue record ({error})") from error
    if not np.all(np.abs(numbers) <= MAX_COORDINATE):  # NaN fails too
        raise ValueError(f"part {number!r}: its record places a point beyond {MAX_COORDINATE:g} LDU")
    return shape


FIT_GRIP = 0.5  # LDU: a male section this close under the female's radius grips it (a stud in a round bore)
FIT_PLAY = 0.25  # LDU: a male section this much over the female's radius still fits (LDraw's rounding)
FIT_STEP = 0.5  # LDU: steps of the two profiles this close along the line are one step (a placement's rounding)
FIT_OVERLAP = 3.0  # LDU: the least depth of a fit (most of a stud's 4: a stud 2 LDU in is not held)
FIT_WHOLE = 0.1  # LDU: a male cylinder this close to all its length inside the bore is all the way in


def fit_depth(male_length: float) -> float:
    """The least overlap that makes a fit of a male cylinder this long: FIT_OVERLAP, or for a male the data states
    shorter than that (a flex-system hose end's 1-LDU stub) all of it: it is in as far as it goes."""
    return min(FIT_OVERLAP, male_length - FIT_WHOLE)
BAR_RADIUS = 4.0  # LDU: a bar's (3.2 mm), which an axle hole's ribs hold


def fit(male: tuple, female: tuple, m_start: float, m_end: float, f_start: float, f_end: float) -> str | None:
    """How a male snap cylinder sits in a female one on the same line, from the data's sections alone: None
    when they do not fit (too shallow, a section too wide for the bore, nowhere a grip, a round peg in an axle
    hole), ``"keyed"`` when an axle or square peg sits in an axle or square bore over its grip (no turning),
    else ``"round"`` (it turns). ``m_*`` and ``f_*`` are where each cylinder starts and ends along the common
    line; each profile runs from its start to its end."""
    lo, hi = max(min(m_start, m_end), min(f_start, f_end)), min(max(m_start, m_end), max(f_start, f_end))
    if hi - lo < fit_depth(abs(m_end - m_start)):
        return None
    cuts = {lo, hi}
    for start, end, profile in ((m_start, m_end, male), (f_start, f_end, female)):
        sign, run = (1.0 if end >= start else -1.0), 0.0
        for _, _, piece in profile:
            run += piece
            if lo < start + sign * run < hi:
                cuts.add(start + sign * run)
    edges = sorted(cuts)
    grip, keyed = False, True
    for a, b in itertools.pairwise(edges):
        t = (a + b) / 2
        m, f = _section(male, m_start, m_end, t), _section(female, f_start, f_end, t)
        if m is None or f is None or b - a < FIT_STEP:  # a sliver between two steps drawn a little apart
            continue
        (m_shape, m_radius), (f_shape, f_radius) = m, f
        bar_in_axle_hole = f_shape == "A" and m_shape != "A" and abs(m_radius - BAR_RADIUS) <= FIT_GRIP
        if m_radius > f_radius + FIT_PLAY or (f_shape == "A" and m_shape != "A" and not bar_in_axle_hole):
            return None
        if f_radius - m_radius <= FIT_GRIP or bar_in_axle_hole:  # a bar is held between an axle hole's ribs
            grip = True
            keyed = keyed and m_shape in ("A", "S") and f_shape == m_shape
    return None if not grip else ("keyed" if keyed else "round")


def _section(profile: tuple, start: float, end: float, t: float) -> tuple[str, float] | None:
    """(shape, radius) of the profile at ``t`` on the line (chamfers ``L_``/``_L`` as round)."""
    u = (t - start) if end >= start else (start - t)
    run = 0.0
    for shape, radius, piece in profile:
        if run <= u <= run + piece:
            return ("R" if "L" in shape else shape), float(radius)
        run += piece
    return None
