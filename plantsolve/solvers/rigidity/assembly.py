"""An assembly of parts and bodies that updates its connections as parts come and go.

This is the seed's online use (§3): adding a part looks up its connection points in a spatial hash
of the model's points (a dict keyed by the point rounded to ``SNAP`` LDU), records the connections
it makes, and inserts them into the incremental (6,6) pebble game, so the generic degrees of freedom
follow every insertion at once. The exact pass (:mod:`mobility`) is run on demand by
:meth:`Assembly.analyse`: the seed gives model updates "plenty of time" while the user picks the
next brick. Removing a part drops its points and connections; the pebble game, which has no
deletion, is rebuilt at the next query.

Between two parts: two or more stud connections, or any axle in an axle hole, make them rigid
(one superbrick); otherwise each connection is a joint — a single stud a hinge about its axis, a
pin in a pin hole a hinge, an axle in a round hole a cylindrical joint, two hinge halves a hinge.
Two parts held by two pins (or axles) in distinct parallel holes are reported in one superbrick
(:meth:`Assembly.rod_pairs`); the exact pass finds them rigid to each other on its own, with each
pin free to spin.

A whole model read from a file then gets four passes (the job runs them once all parts are placed):
:meth:`Assembly.seat_tyres` (a tyre on a wheel that states no rim), :meth:`Assembly.seat_clips_across_gaps` (a clip
whose jaws reach bar on both sides of a gap the data leaves in it, or round a rod thinner than a bar),
:meth:`Assembly.seat_offset_studs` (studs gripped between a tube and a wall where the data states no anti-stud) and
:meth:`Assembly.join_pieces` (pieces joined where a point misses its mate by at most ``OFFSET_REACH``, hinge fingers
by ``FINGER_REACH``, a stud the place where a one-wide part's walls grip it by ``OFFSET_REACH``, an anti-stud drawn on
a stud's tip: a part drawn off its mate; hinge fingers sharing their middle with their axes up to 30 degrees apart: a
part swung about another axis than its hinge's).
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field

import numpy as np

from plantsolve.solvers.rigidity.catalogue import (ANY_DIRECTION, CLIPS, FIT_OVERLAP, FITS, GROUP, HOLE_RADIUS,
                                                   NOT_DOCKED, OPPOSED, RING_REACH, Connector, PartShape,
                                                   collision_boxes, fit, fit_depth, lookup, mate, samples)
from plantsolve.solvers.rigidity.generated import BAR_RADIUS, RADIUS_FIT
from plantsolve.solvers.rigidity.collisions import Shapes, Solid, find_collisions
from plantsolve.solvers.rigidity.contacts import CONTACT_GAP, FACE_TYPES, studs_across, touching
from plantsolve.solvers.rigidity.mobility import Joint, Mobility, analyse
from plantsolve.solvers.rigidity.pebble import PebbleGame
from plantsolve.solvers.rigidity.pieces import mostly_floating, pieces
from plantsolve.solvers.rigidity.screws import FREEDOM

# LDU: connection points closer than this are one point. Editors write positions with 2 to 3 decimals and
# rotations with 6 (0.707107): a part on a turned plate, or in a turned sub-model, lands its studs 1e-3 to a few
# 1e-2 LDU off the grid the library's frames give; the closest distinct points of one part are a bar's, 2 LDU
# apart.
SNAP = 0.1
# LDU: a male snap cylinder whose axis is this close to a female bore's, over a depth they share, is inside it
# (beside it, it would cut the bore's wall). Looser than SNAP: a minifigure's arm turned by a rotation printed
# with 3 digits (0.985 0.17) puts the hand's peg 0.44 LDU off the arm's socket.
FIT_SNAP = 1.0
# LDU: how far a connection point may miss its mate for join_pieces to join two pieces the matching within rounding
# left apart. Models made with an older library keep parts where it drew them (OMR 4489 hangs a head on hinge
# fingers the 2024 library draws 2 LDU higher); editors' grid snapping leaves a part 2 LDU off (a turntable on a
# helicopter). Under a quarter of the closest spacing of like points (a stud and a tube 10√2 = 14 LDU apart), so a
# point still meets one mate at most.
OFFSET_REACH = 3.0 + SNAP
# LDU: how far apart the axes of two runs of hinge fingers may be drawn for join_pieces to join them: less than the
# diameter of the fingers' knuckles (LDCad states them radius 4 about the hinge axis). Closer than that, two runs that
# overlap along their axis share the room around it, which only fingers interleaved on one pin can: a hinge drawn
# off its pin (OMR-style arm linkages closed with angles printed to three digits miss by 5.3 to 5.8 LDU, 6544-1).
FINGER_REACH = 8.0
# LDU: the longest bore whose mouth the slip pass looks for past a run's end (a technic hole's, one stud long);
# a longer bore counts from this far around its centre, so the cells searched stay bounded.
SLIP_BORE = 20.0
# |cos| between a male snap cylinder and the bore it is in: a minifigure's arm swung about the torso's x axis
# instead of its socket's axis (tilted 10° from it) sits 5° off the socket; the axes must still stay within
# FIT_SNAP of each other over the depth they share.
FIT_ALIGN = math.cos(math.radians(10.0))
# |cos| between two runs of hinge fingers whose middles coincide (within SNAP) for join_pieces to join them as a hinge:
# a control stick 4593 drawn swung 15 to 25 degrees sideways on its base 4592 (sets 10179, 75827) still has its
# knuckle in the base's fingers, its axis turned off theirs. Two runs can share a middle only on one pin.
FINGER_TILT = math.cos(math.radians(30.0))
# LDU: a male round section thinner than this is a rod a clip holds but no bar hole (the data's bars are radius 4)
THIN_ROD = 3.5
HALF_PITCH = 10.0  # LDU: half a stud pitch
# studs that must share one shift across the plane of their anti-studs for join_pieces to join a part drawn beside the
# studs it lies on (Assembly._join_shifted_rows): two hold it rigid, and one shift shared by two is no chance
SHIFTED_ROW_STUDS = 2
# parts, each joined on SHIFTED_ROW_STUDS or more studs, that must show one part's grid drawn off by one shift for a
# part on fewer of its studs drawn by that shift to be joined (Assembly._join_on_shifted_grids): one partner's shift
# could be its own slip
GRID_SHIFT_PARTNERS = 2
# LDU: how far off one plane a stud's base and the anti-stud's mouth beside it may be drawn for that shift to be read
# (Assembly._join_shifted_rows): set 6761's base plate lies 0.16 LDU low as well as 3.2 LDU aside
SHIFT_PLANE = 0.5
STUD_LENGTH_IN = 4.0  # LDU: how far a stud reaches into the part above it (stud.dat's height)
RUN_CELL = 20.0  # LDU: the coarse cells that find the holes and clips along a run (an axle, a bar)
ALIGN = 0.999  # |cos| between directions that count as parallel
JOINT_OF = {"stud": "hinge", "pin": "hinge", "axle_round": "cylindrical", "hinge": "hinge", "axle": "rigid",
            "ball": "ball", "clip": "hinge", "group": "rigid", "bar": "cylindrical", "fit": "hinge",
            "fit_keyed": "rigid", "contact": "planar"}
ORIGIN_OF = {"axle_round": "axle", "fit_keyed": "fit"}  # the connection kinds results name by what is inserted
# one part inside (or interlocked with) the other: not a collision
INSERTED = {"pin", "axle", "axle_round", "ball", "clip", "hinge", "group", "bar", "fit", "fit_keyed"}


@dataclass
class Placed:
    id: str
    number: str
    shape: PartShape
    position: np.ndarray
    rotation: np.ndarray
    points: np.ndarray
    directions: np.ndarray
    keys: list

    def solid(self) -> Solid:
        return part_solid(self.shape, self.rotation, self.position)


def part_solid(shape: PartShape, rotation: np.ndarray, position: np.ndarray) -> Solid | None:
    """A catalogue part's collision shape placed in the world: one box, or its pieces with the holes cut;
    None for a part without a collision shape."""
    boxes = [Solid(center=rotation @ np.asarray(c, dtype=float) + position, size=np.asarray(s, dtype=float),
                   rotation=rotation) for c, s in collision_boxes(shape)]
    if not boxes:
        return None
    return boxes[0] if len(boxes) == 1 else Solid(pieces=tuple(boxes))


def natural_order(id: str) -> tuple[list[tuple[int, str]], str]:
    """Sort key of an id with its runs of ASCII digits compared as numbers (an upload's L7, line 7, before its L11),
    then the id itself, so that ids equal as numbers (p01, p1) still have one order whatever the input's."""
    runs = re.split(r"([0-9]+)", id)  # the digit runs at the odd places ('²' is a digit to str.isdigit, not to int)
    return [(int(run), "") if i % 2 else (-1, run) for i, run in enumerate(runs)], id


def _line_direction(axis: tuple | None) -> tuple | None:
    """``axis`` or its opposite, whichever has its first non-zero component positive: the sign a line has
    whichever of its two connectors it was read from (``None``, a ball's: no axis)."""
    if axis is None:
        return None
    first = next((v for v in axis if v != 0), 0)
    return tuple(0.0 - v for v in axis) if first < 0 else axis


@dataclass(frozen=True)
class Connection:
    a: str
    ca: int
    b: str
    cb: int
    kind: str  # stud, pin, axle, axle_round, hinge
    point: tuple
    axis: tuple


@dataclass
class JointSpec:
    id: str
    type: str
    bodies: tuple[str, str]
    point: tuple
    axis: tuple
    origin: str = "input"
    connections: int = 1


@dataclass
class Analysis:
    ids: list[str]
    joints: list[JointSpec]
    mobility: Mobility
    generic_dof: int
    details: dict = field(default_factory=dict)


POINT_CELL, POINT_OFFSET = 1.0, 0.37  # LDU: fine cells, their edges where no LDraw grid puts a point
RUN_OFFSET = 7.3  # LDU: the coarse cells' edges likewise off the stud grid


def _key(point, size: float, offset: float) -> tuple:
    return tuple(math.floor((float(v) - offset) / size) for v in point)


def _around(point, reach: float, size: float, offset: float) -> list[tuple]:
    """The cells (``size`` wide, edges at ``offset``) that hold every point within ``reach`` of ``point``: one
    for most points (cell edges lie off the LDraw grid), up to eight near an edge. (Plain floats: numpy's
    overhead on three numbers was most of the time of adding a part.)"""
    return list(itertools.product(*(range(math.floor((float(v) - reach - offset) / size),
                                          math.floor((float(v) + reach - offset) / size) + 1) for v in point)))


def _cell(point: np.ndarray) -> tuple:
    return _key(point, RUN_CELL, RUN_OFFSET)


def _run_samples(start: np.ndarray, axis: np.ndarray, length: float) -> np.ndarray:
    """Points along a run every LDU at most, both ends included."""
    return start + np.outer(np.linspace(0.0, length, int(np.ceil(length)) + 1), axis)


def _run_cells(start: np.ndarray, axis: np.ndarray, length: float) -> set:
    """The RUN_CELL cells a run passes (through its samples)."""
    return {_cell(p) for p in _run_samples(start, axis, length)}


def _cells_along(start: np.ndarray, axis: np.ndarray, length: float, reach: float) -> set:
    """The RUN_CELL cells that hold every point within ``reach`` of the run: those of the run's box grown by
    ``reach`` (runs are a few studs long, so the box's extra cells cost less than walking the run)."""
    end = start + axis * length
    lo, hi = np.minimum(start, end) - reach, np.maximum(start, end) + reach
    return set(itertools.product(*(range(math.floor((float(a) - RUN_OFFSET) / RUN_CELL),
                                         math.floor((float(b) - RUN_OFFSET) / RUN_CELL) + 1) for a, b in zip(lo, hi))))


def _on_run(point: np.ndarray, start: np.ndarray, axis: np.ndarray, length: float, reach: float = FIT_SNAP,
            beyond: float = SNAP) -> bool:
    """``point`` on the run: within ``reach`` of its line (FIT_SNAP: a hole or a clip that far off an axle's or a
    bar's axis holds it all the same; nearer, it would cut into the rod) and between its ends (within ``beyond``:
    SNAP, or in the slip pass how far a hole's centre may lie past an end, :func:`_slip_beyond`)."""
    v = np.asarray(point, float) - start
    t = float(v @ axis)
    return -beyond <= t <= length + beyond and float(np.linalg.norm(v - t * axis)) <= reach


def _clip_radius(clip: Connector) -> float:
    """The radius of the rod a clip grips (its profile's, :mod:`generated`); a bar's where it states none, as the
    shadow library's clips default to."""
    return float(clip.profile[0][1]) if clip.profile else BAR_RADIUS


def _slip_beyond(connector, slip: float) -> float:
    """How far past a run's end the centre of ``connector`` (a hole, a clip) may lie for the slip pass to join
    them: half its bore (its mouth at the end: a bush drawn on an axle's tip) and ``slip`` more; SNAP without a
    slip (the exact pass: its centre on the run)."""
    return SNAP if slip <= 0 else _half_bore(connector) + slip


def _half_bore(connector) -> float:
    """Half the bore of a hole along a run (at most SLIP_BORE long): how far its centre lies inside its mouth. 0 for a
    clip, whose width is its jaws': a clip past a bar's end is no bush on an axle's tip, its jaws at the end do not
    hold it (:meth:`Assembly.seat_clips_across_gaps` seats a clip whose jaws reach bar on both sides)."""
    return 0.0 if connector.type in CLIPS else min(connector.depth, SLIP_BORE) / 2


def _clean(x: float) -> float | int:
    """Integer-valued coordinates as ints (LDraw units), so the exact pass can use them."""
    r = round(float(x))
    return r if abs(float(x) - r) < 1e-9 else float(x)


def common_shift(pairs: list) -> tuple[np.ndarray | None, list]:
    """The one offset (within SNAP) that SHIFTED_ROW_STUDS or more distinct studs share with distinct anti-studs among
    ``pairs`` ((stud, anti-stud, offset) each), and the pairs with it; (None, []) when no offset is shared so, or two
    are (a grid shifted half a pitch meets two rows of mates equally well)."""
    best, ties = None, 0
    for _, _, shift in pairs:
        held = [p for p in pairs if float(np.linalg.norm(p[2] - shift)) <= SNAP]
        studs, mouths = {p[0] for p in held}, {p[1] for p in held}
        count = min(len(studs), len(mouths))
        if count < SHIFTED_ROW_STUDS:
            continue
        if best is None or count > best[0]:
            best, ties = (count, shift, held), 0
        elif count == best[0] and float(np.linalg.norm(shift - best[1])) > SNAP:
            ties += 1
    if best is None or ties:
        return None, []
    return best[1], best[2]


class Assembly:
    """Parts (catalogue LEGO parts), bodies (free shapes) and explicit joints, kept connected."""

    def __init__(self) -> None:
        self.parts: dict[str, Placed] = {}
        self.bodies: dict[str, Solid | None] = {}
        self.joints: dict[str, JointSpec] = {}
        self._slots: dict[tuple, list[tuple[str, int]]] = {}  # connection points by their SNAP cell
        self._coarse: dict[tuple, list[tuple[str, int]]] = {}  # the same by their RUN_CELL cell
        self._runs: dict[tuple, list[tuple[str, int]]] = {}  # runs by every RUN_CELL cell they pass
        self._rings: dict[tuple, list[tuple[str, int]]] = {}  # rings (kept apart: only studs look for them)
        self._links: dict[tuple[str, str], list[Connection]] = {}
        self._offsets: dict[tuple[str, str], float] = {}  # pairs joined by join_pieces: their offset
        self._tilts: dict[tuple[str, str], float] = {}  # pairs joined by turned hinge fingers: the angle (degrees)
        self._contacts: dict[tuple[str, str], tuple] = {}  # pairs joined by join_by_contact: the contact's normal
        self._neighbours: dict[str, set[str]] = {}
        self._pebble = PebbleGame()
        self._pebble_stale = False
        self._free_table = self._boxes = None  # docking's arrays of free connection points, rebuilt after a change

    # ---------------------------------------------------------------- building
    def add_part(self, id: str, number: str, position, rotation=None, shape: PartShape | None = None) -> list[Connection]:
        """Place a catalogue part (or a part of the given ``shape``); returns the connections it makes. Unknown
        parts raise KeyError."""
        if id in self.parts or id in self.bodies:
            raise ValueError(f"id {id!r} is already in the assembly")
        shape = shape or lookup(number)
        if shape is None:
            raise KeyError(number)
        rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float).reshape(3, 3)
        pos = np.asarray(position, dtype=float)
        local = shape.points()
        points = local @ rot.T + pos
        dirs = np.array([c.direction for c in shape.connectors], dtype=float).reshape(-1, 3) @ rot.T
        runs = np.array([c.length for c in shape.connectors], dtype=float)
        keys = [None if runs[k] > 0 else _key(points[k], POINT_CELL, POINT_OFFSET) for k in range(len(points))]
        placed = Placed(id, shape.number, shape, pos, rot, points, dirs, keys)
        self._free_table = self._boxes = None
        self.parts[id] = placed
        self._neighbours[id] = set()
        self._pebble.add_body(id)
        found = self._matches(id, SNAP, FIT_SNAP)
        for ci, key in enumerate(keys):  # its points go into the tables only now: a part does not meet itself
            mine = shape.connectors[ci].type
            if key is not None:
                self._slots.setdefault(key, []).append((id, ci))
                (self._rings if mine == "ring" else self._coarse).setdefault(_cell(points[ci]), []).append((id, ci))
            else:
                for cell in _run_cells(points[ci], dirs[ci], runs[ci]):
                    self._runs.setdefault(cell, []).append((id, ci))
        for other, conns in found.items():
            self._links[(other, id)] = conns
            self._neighbours[other].add(id)
            self._neighbours[id].add(other)
            if not self._pebble_stale:
                for j in self._pair_joints(other, id, conns):
                    self._pebble.add_joint(other, id, 6 - FREEDOM[j.type])
        return [c for conns in found.values() for c in conns]

    def _matches(self, id: str, reach: float, fit_reach: float, slip: float = 0.0) -> dict[str, list[Connection]]:
        """The connections placed part ``id`` makes with the parts in the tables (itself left out): points that meet
        within ``reach`` (a hole or a clip within ``fit_reach`` of a run's line, its centre on the run or, with a
        ``slip``, its bore within ``slip`` of the run's end: :func:`_slip_beyond`), cylinders that fit within
        ``fit_reach`` of a bore's line. A fit counts only between parts that no typed point joins."""
        placed = self.parts[id]
        shape, points, dirs = placed.shape, placed.points, placed.directions
        found: dict[str, list[Connection]] = {}
        fits: dict[str, list[Connection]] = {}
        for ci, key in enumerate(placed.keys):
            mine = shape.connectors[ci].type
            length = shape.connectors[ci].length
            if mine in FITS:
                for other, oi, kind, where in self._fits_along(shape.connectors[ci], points[ci], dirs[ci], fit_reach):
                    if other != id:
                        fits.setdefault(other, []).append(Connection(other, oi, id, ci, kind,
                                                                     tuple(_clean(v) for v in where),
                                                                     tuple(_clean(v) for v in dirs[ci])))
                continue
            if key is not None:
                candidates = [(o, oi, points[ci]) for o, oi in self._near(points[ci], reach)]
                candidates += [(o, oi, points[ci]) for o, oi in self._runs_near(
                    points[ci], fit_reach, _slip_beyond(shape.connectors[ci], slip) if slip > 0 else SNAP)]
            else:
                candidates = [(o, oi, self.parts[o].points[oi])
                              for o, oi in self._points_along(points[ci], dirs[ci], length, fit_reach, slip)]
            seen = set()
            for other, oi, where in candidates:
                if (other, oi) in seen or other == id:
                    continue
                seen.add((other, oi))
                theirs = self.parts[other].shape.connectors[oi].type
                kind = mate(mine, theirs)
                if kind is None or kind == "ring":  # a ring holds the studs around it, not one at its centre
                    continue
                cos = float(dirs[ci] @ self.parts[other].directions[oi])
                if kind in ANY_DIRECTION:
                    pass
                elif kind == "clip" and slip == 0 and FIT_ALIGN <= abs(cos) < ALIGN:
                    if not self._tilted_clip_holds(id, ci, other, oi):
                        continue
                elif (kind in OPPOSED and cos > -ALIGN) or (kind not in OPPOSED and abs(cos) < ALIGN):
                    continue
                point = tuple(_clean(v) for v in where)
                axis = None if kind in ANY_DIRECTION else tuple(  # a ball joint has no axis
                    _clean(v) for v in (dirs[ci] if kind not in OPPOSED else self.parts[other].directions[oi]))
                found.setdefault(other, []).append(Connection(other, oi, id, ci, kind, point, axis))
            if mine in ("ring", "stud"):
                for other, oi, where in self._ring_mates(mine, points[ci], dirs[ci], reach):
                    if other == id:
                        continue
                    axis = dirs[ci] if mine == "stud" else self.parts[other].directions[oi]
                    found.setdefault(other, []).append(Connection(other, oi, id, ci, "stud",
                                                                  tuple(_clean(v) for v in where),
                                                                  tuple(_clean(v) for v in axis)))
            if mine == "finger" and key is None:
                for other, oi, kind, where in self._fits_along(shape.connectors[ci], points[ci], dirs[ci],
                                                               max(fit_reach, FINGER_REACH) if slip > 0 else fit_reach):
                    if other != id:
                        found.setdefault(other, []).append(Connection(other, oi, id, ci, kind,
                                                                      tuple(_clean(v) for v in where),
                                                                      tuple(_clean(v) for v in dirs[ci])))
        for other, conns in fits.items():  # a fit the typed points do not already make (an arm in a torso)
            if other not in found:
                deep = [c for c in conns if not self._stub(c)]
                found[other] = deep or conns  # a stub only where nothing deeper fits (an arm's collar beside its peg)
        return found

    def _tilted_clip_holds(self, id: str, ci: int, other: str, oi: int) -> bool:
        """A bar up to 10° (FIT_ALIGN) off the axis of a clip its line passes through holds the clip where it stays
        within FIT_SNAP of the clip's axis across the clip's jaws (its width): a minifigure's hand, turned by
        rotations printed with 3 digits through arm and hand, holds a revolver's grip 4° off its axis (set 6755-1),
        the jaws' edges 0.4 LDU off the grip's line."""
        (cp, ck), (bp, bk) = ((id, ci), (other, oi))
        if self.parts[cp].shape.connectors[ck].type != "clip":
            (cp, ck), (bp, bk) = (bp, bk), (cp, ck)
        clip, bar = self.parts[cp], self.parts[bp]
        half = clip.shape.connectors[ck].depth / 2
        axis = bar.directions[bk]
        for s in (-half, half):
            w = clip.points[ck] + clip.directions[ck] * s - bar.points[bk]
            if float(np.linalg.norm(w - float(w @ axis) * axis)) > FIT_SNAP:
                return False
        return True

    def _stub(self, c: Connection) -> bool:
        """The male cylinder of a fit shorter than FIT_OVERLAP (in by all of its length: :func:`catalogue.fit_depth`)."""
        male = next(self.parts[p].shape.connectors[k] for p, k in ((c.a, c.ca), (c.b, c.cb))
                    if self.parts[p].shape.connectors[k].type == "fit_m")
        return male.length < FIT_OVERLAP

    def part_pieces(self) -> list[list[str]]:
        """The connected pieces of the parts as joined so far, largest first, parts in the order they were added."""
        return pieces(list(self.parts), {p: sorted(n) for p, n in self._neighbours.items()})

    def join_pieces(self, reach: float = OFFSET_REACH) -> list[tuple[str, str, float]]:
        """Join the pieces that the matching within rounding left apart where their connection points miss each
        other by at most ``reach`` (a part drawn a little off its mate: a slip of the model, or a part the library
        has redrawn since the model was made). Only between parts of different pieces as matched before this pass,
        so the result does not depend on the order of the pieces; not at all when most parts are joined to nothing.
        Returns (part, part, offset in LDU) of each pair joined, the offset the largest of its connections'
        (:meth:`_gap`)."""
        groups = self.part_pieces()
        if mostly_floating(sum(len(g) == 1 for g in groups), len(self.parts)):
            return []  # no slip is assumed where most parts meet nothing
        label = {p: k for k, g in enumerate(groups) for p in g}
        joined = []
        for group in groups[1:]:
            for id in group:
                for other, conns in self._matches(id, reach, reach, reach).items():
                    if label[other] == label[id] or (other, id) in self._links or (id, other) in self._links:
                        continue
                    gap = max(self._gap(c) for c in conns)
                    self._links[(other, id)] = conns
                    self._neighbours[other].add(id)
                    self._neighbours[id].add(other)
                    self._offsets[(other, id)] = gap
                    joined.append((other, id, gap))
        joined += self._join_slipped_grips(groups, label, reach)
        joined += self._join_stud_tips(groups, label)
        joined += self._join_shifted_rows(groups, label)
        joined += self._join_tilted_fingers(groups, label)
        if joined:
            self._pebble_stale = True
        return joined

    def _join_slipped_grips(self, groups: list[list[str]], label: dict, reach: float) -> list[tuple[str, str, float]]:
        """Join, as :meth:`join_pieces` joins a point drawn off its mate, a stud drawn up to ``reach`` off the place
        midway between two anti-studs of a part one stud wide where its long walls grip it (:meth:`seat_offset_studs`
        seats it there within rounding): 21325-1 lays fifteen 1 x 2 tiles on the side studs of 26604 bricks, each 2
        LDU along the tile from its middle. Only between different pieces as they were before the pass, so a stud or
        a gripping part is in a piece besides the largest; each pair once, its offset the stud's distance from the
        midway place."""
        found = []
        for group in groups[1:]:
            for id in group:
                placed = self.parts[id]
                for ci, c in enumerate(placed.shape.connectors):
                    if c.type == "stud" and c.length <= 0:  # this piece's stud in a part of another
                        found += [(id, ci, other, oi, gap) for other, oi, gap in self._midway_places(
                            id, placed.points[ci], placed.directions[ci], label, reach, "antistud")]
                for ci, a, b in self._antistud_pairs(placed):  # another piece's stud in this part
                    middle = (a + b) / 2
                    for other, oi, gap in self._midway_places(id, middle, placed.directions[ci], label, reach, "stud"):
                        if self._grips_midway(placed, a, b, self.parts[other].directions[oi]):
                            found.append((other, oi, id, ci, gap))
        joined = []
        for id, ci, other, oi, gap in found:
            if (other, id) not in self._links and (id, other) not in self._links:
                self._link_at(id, ci, other, oi, "stud")
                self._offsets[(other, id)] = gap
                joined.append((other, id, gap))
        return joined

    def _join_stud_tips(self, groups: list[list[str]], label: dict) -> list[tuple[str, str, float]]:
        """Join, as :meth:`join_pieces` joins a point drawn off its mate, an anti-stud whose mouth is drawn on the tip
        of a stud (STUD_LENGTH_IN out along the stud's axis, within SNAP, facing it): the part rests on the stud where
        a build presses it on, as official models draw dishes, cones and round bricks made with an older library (set
        10179's dish 4740 on a cone, 10019's dish 4285b on the four studs of a plate: every anti-stud on a stud's tip).
        Only between different pieces as they were before the pass; each pair's offset the stud's length."""
        found = []
        for group in groups[1:]:
            for id in group:
                placed = self.parts[id]
                for ci, c in enumerate(placed.shape.connectors):
                    if c.type == "stud" and c.length <= 0:
                        tip = placed.points[ci] + placed.directions[ci] * STUD_LENGTH_IN
                        found += [(id, ci, other, oi) for other, oi in self._mouths_at(
                            tip, placed.directions[ci], "antistud", label, label[id])]
                    elif c.type == "antistud":
                        mouth = placed.points[ci] + placed.directions[ci] * c.length
                        found += [(other, oi, id, ci) for other, oi in self._mouths_at(
                            mouth, placed.directions[ci], "stud", label, label[id])]
        joined, mine = [], set()
        for id, ci, other, oi in found:
            pair = frozenset((id, other))
            if pair not in mine and ((other, id) in self._links or (id, other) in self._links):
                continue  # joined already (within rounding, or by a slip)
            if pair not in mine:
                mine.add(pair)
                self._offsets[(other, id)] = STUD_LENGTH_IN
                joined.append((other, id, STUD_LENGTH_IN))
            if not any({(c.a, c.ca), (c.b, c.cb)} == {(id, ci), (other, oi)}
                       for c in self._links.get((other, id), []) + self._links.get((id, other), [])):
                self._link_at(id, ci, other, oi, "stud")  # every stud of the pair on a tip: two or more hold it rigid
        return joined

    def _join_shifted_rows(self, groups: list[list[str]], label: dict) -> list[tuple[str, str, float]]:
        """Join, as :meth:`join_pieces` joins a point drawn off its mate, two parts of different pieces whose studs and
        anti-studs face each other in one plane (the anti-studs' mouths within SHIFT_PLANE of the studs' bases along
        their axes), all shifted by one and the same offset across it, more than a slip (OFFSET_REACH) and less than
        half a pitch, on SHIFTED_ROW_STUDS or more studs: the part lies on the studs, drawn beside them. In that plane
        the studs stand inside the other part, which no build allows but in its anti-studs: set 6761 draws its base
        plate 9.8 LDU off the grid of the 18 parts standing on it. A single stud so shifted (a part that may turn on
        it) or offsets that differ (parts resting askew) are not joined. Only between different pieces as they were
        before the pass; the pair's offset the shift."""
        shifts: dict[tuple[str, str], dict[tuple, np.ndarray]] = {}  # part pair -> (stud, anti-stud) -> offset
        for group in groups[1:]:
            for id in group:
                placed = self.parts[id]
                for ci, c in enumerate(placed.shape.connectors):
                    if c.type not in ("stud", "antistud") or c.length > 0:
                        continue
                    for other, oi, v in self._shifted_mates(id, ci, label):
                        stud, mouth = ((id, ci), (other, oi)) if c.type == "stud" else ((other, oi), (id, ci))
                        shift = v if c.type == "stud" else -v  # from the stud's base to the anti-stud's mouth
                        pairs = shifts.setdefault(tuple(sorted((id, other))), {})
                        pairs.setdefault((stud, mouth), shift)  # met from both parts when both are apart: once
        joined, grids = [], {}  # grids: part -> the shifts (from its point to its partner's) it was joined at
        for (a, b), pairs in sorted(shifts.items()):
            if (a, b) in self._links or (b, a) in self._links:
                continue
            shift, held = common_shift([(stud, mouth, v) for (stud, mouth), v in pairs.items()])
            if shift is None:
                continue
            for (sid, si), (mid, mi), _ in held:
                self._link_at(mid, mi, sid, si, "stud")
            stud_part = held[0][0][0]
            for part, v in ((stud_part, shift), (b if stud_part == a else a, -shift)):
                grids.setdefault(part, []).append(v)
            gap = float(np.linalg.norm(shift))
            self._offsets[(a, b)] = gap
            joined.append((a, b, gap))
        joined += self._join_shifted_across_parts(shifts, {p for g in groups[1:] for p in g})
        return joined + self._join_on_shifted_grids(shifts, grids)

    def _join_shifted_across_parts(self, shifts: dict, lying: set[str]) -> list[tuple[str, str, float]]:
        """Join a part of a piece besides the largest (in ``lying``) whose points meet those of two or more other parts,
        one or a few of each, all shifted by one offset as :meth:`_join_shifted_rows` reads it (SHIFTED_ROW_STUDS or
        more of its own points sharing it): the part lies drawn beside the studs of several parts (set 21109 lays two
        1 x 3 tiles 63864 across three parts' single studs, every anti-stud 4 LDU aside), the shift its own, which
        the pairs of parts, one stud each, do not show. ``shifts`` as gathered there; pairs joined already are left."""
        own: dict[str, list] = {}  # lying part -> (stud, anti-stud, offset from its point to its partner's)
        for (a, b), pairs in sorted(shifts.items()):
            if (a, b) in self._links or (b, a) in self._links:
                continue
            for (stud, mouth), v in pairs.items():
                for part, sign in ((stud[0], 1.0), (mouth[0], -1.0)):
                    if part in lying:
                        own.setdefault(part, []).append((stud, mouth, sign * v))
        joined = []
        for part, found in sorted(own.items()):
            shift, held = common_shift(found)
            partners = {q for stud, mouth, _ in held for q in (stud[0], mouth[0]) if q != part}
            if shift is None or len(partners) < 2:
                continue  # one partner: the pair's own rule has decided
            fresh = {q for q in partners if (part, q) not in self._links and (q, part) not in self._links}
            for stud, mouth, _ in held:
                (pid, pi), (oid, oi) = (stud, mouth) if stud[0] == part else (mouth, stud)
                if oid in fresh:  # not joined by another lying part's shift in this pass
                    self._link_at(oid, oi, pid, pi, "stud")  # at the partner's point: the grid it lies on
            for other in sorted(fresh):
                self._offsets[(part, other)] = float(np.linalg.norm(shift))
                joined.append((part, other, float(np.linalg.norm(shift))))
        return joined

    def _join_on_shifted_grids(self, shifts: dict, grids: dict) -> list[tuple[str, str, float]]:
        """Join a part lying on fewer studs than :meth:`_join_shifted_rows` needs (one stud: the others of its row
        missing, as on a base plate's raised hill) when its stud is drawn beside its anti-stud by the very shift that
        GRID_SHIFT_PARTNERS or more other parts, each joined on two or more studs, show the other part's grid drawn off
        by: set 6761 draws its base plate 9.8 LDU off the grid of the parts on it, and a 1 x 4 plate over the hill has
        one stud of it under its row. Every point of the pair must share that shift (a second offset: the part stands
        otherwise). ``shifts`` as gathered there, ``grids`` part -> the shifts from its points to its partners' it was
        joined at."""
        established = {}
        for part, found in grids.items():
            for v in found:
                if sum(float(np.linalg.norm(w - v)) <= SNAP for w in found) >= GRID_SHIFT_PARTNERS:
                    established[part] = v
                    break
        joined = []
        for (a, b), pairs in sorted(shifts.items()):
            if (a, b) in self._links or (b, a) in self._links:
                continue
            for grid, other in ((a, b), (b, a)):
                if grid not in established:
                    continue
                shift = established[grid]
                # the shift from the grid part's point to the other's, whichever of the two holds the stud
                offsets = [v if stud[0] == grid else -v for (stud, _), v in pairs.items()]
                if not all(float(np.linalg.norm(v - shift)) <= SNAP for v in offsets):
                    continue
                for (sid, si), (mid, mi) in pairs:
                    self._link_at(mid, mi, sid, si, "stud")
                gap = float(np.linalg.norm(shift))
                self._offsets[(a, b)] = gap
                joined.append((a, b, gap))
                break
        return joined

    def _shifted_mates(self, id: str, ci: int, label: dict):
        """(part, connector, offset) of the points of parts of other pieces that mate connector ``ci`` of ``id`` (an
        anti-stud for a stud, a stud for an anti-stud, length 0) facing it in its plane (within SHIFT_PLANE along its
        axis) more than OFFSET_REACH and less than HALF_PITCH beside it (at half a pitch a part stands between two
        studs, where only a grip holds it: :meth:`seat_offset_studs`)."""
        placed = self.parts[id]
        point, direction = placed.points[ci], placed.directions[ci]
        wanted = "antistud" if placed.shape.connectors[ci].type == "stud" else "stud"
        for cell in _around(point, HALF_PITCH + SNAP, RUN_CELL, RUN_OFFSET):
            for other, oi in self._coarse.get(cell, ()):
                o = self.parts[other]
                c = o.shape.connectors[oi]
                if label[other] == label[id] or c.type != wanted or c.length > 0:
                    continue
                if float(direction @ o.directions[oi]) > -ALIGN:
                    continue
                v = o.points[oi] - point
                across = float(np.linalg.norm(v))
                if abs(float(v @ direction)) <= SHIFT_PLANE and OFFSET_REACH < across < HALF_PITCH - SNAP:
                    yield other, oi, v

    def _join_tilted_fingers(self, groups: list[list[str]], label: dict) -> list[tuple[str, str, float]]:
        """Join, as a hinge, two runs of hinge fingers of parts of different pieces whose middles lie within SNAP of
        each other and whose axes are turned less than 30 degrees (FINGER_TILT) but more than ALIGN off each other
        (parallel runs meet in the matching): a part swung about another axis than its hinge's, its knuckle still in
        the other's fingers (a control stick 4593 on its base 4592). Only between different pieces as they were before
        the pass; each pair once, its angle in :meth:`tilts`. Returns (part, part, 0) per pair: their fingers meet."""
        joined = []
        for group in groups[1:]:
            for id in group:
                placed = self.parts[id]
                for ci, c in enumerate(placed.shape.connectors):
                    if c.type != "finger" or c.length <= 0:
                        continue
                    middle = placed.points[ci] + placed.directions[ci] * (c.length / 2)
                    for other, oi in self._runs_at(middle):
                        o = self.parts[other]
                        theirs = o.shape.connectors[oi]
                        cos = abs(float(placed.directions[ci] @ o.directions[oi]))
                        if (label[other] == label[id] or theirs.type != "finger" or not FINGER_TILT <= cos < ALIGN
                                or (other, id) in self._links or (id, other) in self._links):
                            continue
                        if float(np.linalg.norm(o.points[oi] + o.directions[oi] * (theirs.length / 2) - middle)) > SNAP:
                            continue
                        self._link_at(id, ci, other, oi, "hinge")
                        self._tilts[(other, id)] = math.degrees(math.acos(min(cos, 1.0)))
                        joined.append((other, id, 0.0))
        return joined

    def join_by_contact(self) -> list[tuple[str, str]]:
        """Join, by ``contact`` joints (planar, :mod:`contacts`), a part clamped in a gap of another piece: its
        collision box touches two boxes of that piece's parts face on face as drawn (within CONTACT_GAP) on opposite
        sides (normals opposed), where neither part of each pair has a stud or anti-stud facing across the contact
        (faces the snap data says nothing about). Wedged between faces a build holds apart by the part's width, it is
        held by friction (a panel between two bricks of a wall, a part in a slot); touching on one side only (two
        bricks side by side, a brick resting on a tile), or between parts of two different pieces (bricks touching in
        a row, pressed by nothing), it is held by nothing, and stays apart. Run after every snap pass, only between
        pieces as they were before this pass (so the result does not depend on their order), not at all when most
        parts are joined to nothing. One contact per part and piece holding it, with that piece's part first in
        natural order among those clamping it (a second, parallel contact would hold nothing more), its normal in
        :meth:`contacts`. Returns the (part, part) pairs joined."""
        groups = self.part_pieces()
        if len(groups) < 2 or mostly_floating(sum(len(g) == 1 for g in groups), len(self.parts)):
            return []
        label = {p: k for k, g in enumerate(groups) for p in g}
        ids, solids, lo, hi = self.solid_boxes()
        index = {b: k for k, b in enumerate(ids)}
        shapes: dict[tuple[int, bool], Shapes] = {}  # (solid, boxes only) -> its shapes for contacts.touching
        aligned: dict[int, bool] = {}  # solid -> every piece a box along the world axes (contacts.touching)
        faces: dict[str, list[tuple[np.ndarray, str, tuple]]] = {}  # part -> (outward normal, other, contact)
        seen: set[frozenset] = set()
        for group in groups[1:]:
            for id in group:
                k = index[id]
                if solids[k] is None:
                    continue
                near = np.flatnonzero(((lo[k] <= hi + CONTACT_GAP) & (lo <= hi[k] + CONTACT_GAP)).all(axis=1))
                for j in near:
                    other = ids[j]
                    pair = frozenset((id, other))
                    if (other not in self.parts or solids[j] is None or label[other] == label[id] or pair in seen
                            or (other, id) in self._links or (id, other) in self._links):
                        continue
                    seen.add(pair)
                    for m in (k, j):
                        if m not in aligned:
                            boxes = solids[m].pieces or (solids[m],)
                            aligned[m] = all(b.rotation is not None and np.isin(b.rotation, (-1.0, 0.0, 1.0)).all()
                                             for b in boxes)
                    both = aligned[k] and aligned[j]
                    for m in (k, j):  # boxes along the axes need no FCL object: their world boxes answer
                        if (m, both) not in shapes:
                            boxes = solids[m].pieces or (solids[m],)
                            shapes[(m, both)] = (Shapes([], *map(np.array, zip(*(b.aabb() for b in boxes)))) if both
                                                 else solids[m].fcl_object())
                    contact = touching(shapes[(k, both)], shapes[(j, both)], aligned=both)
                    if contact is None or any(self._faces_studs(p, *contact) for p in (id, other)):
                        continue
                    normal, low, high = contact
                    point = tuple(_clean(v) for v in (low + high) / 2)
                    axis = _line_direction(tuple(_clean(v) for v in np.round(normal, 9)))
                    faces.setdefault(id, []).append((normal, other, (point, axis)))
                    faces.setdefault(other, []).append((-normal, id, (point, axis)))
        joined = []
        for id in sorted(faces, key=natural_order):
            sides = faces[id]
            # opposite faces of one other piece: the gap in that build holds the part (parts of two pieces would
            # only be parts touching in a row, pressed by nothing)
            clamps = {o for n, o, _ in sides
                      if any(float(n @ m) <= -ALIGN and label[o2] == label[o] for m, o2, _ in sides)}
            held = set()  # the pieces holding it: one contact each (a second, parallel, would hold nothing more)
            for normal, other, (point, axis) in sorted(sides, key=lambda side: natural_order(side[1])):
                if (other not in clamps or label[other] in held or (other, id) in self._links
                        or (id, other) in self._links):
                    continue
                held.add(label[other])
                a, b = sorted((id, other), key=natural_order)
                self._links[(a, b)] = [Connection(a, -1, b, -1, "contact", point, axis)]
                self._neighbours[a].add(b)
                self._neighbours[b].add(a)
                self._contacts[(a, b)] = axis
                joined.append((a, b))
        if joined:
            self._pebble_stale = True
        return joined

    def _faces_studs(self, id: str, normal: np.ndarray, low: np.ndarray, high: np.ndarray) -> bool:
        """Whether part ``id`` has a stud or anti-stud in the contact patch [low, high] facing along ``normal``."""
        placed = self.parts[id]
        rows = [k for k, c in enumerate(placed.shape.connectors) if c.type in FACE_TYPES]
        return studs_across(placed.points[rows], placed.directions[rows], normal, low, high)

    def contacts(self) -> dict[tuple[str, str], tuple]:
        """(part, part) -> the contact normal of the pairs :meth:`join_by_contact` joined."""
        return dict(self._contacts)

    def _runs_at(self, point: np.ndarray):
        """(part, connector) of the runs filed under the RUN_CELL cells within SNAP of ``point``, each once."""
        seen = set()
        for cell in _around(point, SNAP, RUN_CELL, RUN_OFFSET):
            for found in self._runs.get(cell, ()):
                if found not in seen:
                    seen.add(found)
                    yield found

    def tilts(self) -> dict[tuple[str, str], float]:
        """(part, part) -> the angle (degrees) between the axes of the hinge fingers :meth:`join_pieces` joined turned
        off each other."""
        return dict(self._tilts)

    def _mouths_at(self, place: np.ndarray, direction: np.ndarray, type: str, label: dict, piece: int):
        """(part, connector) of the ``type`` points of parts of pieces other than ``piece`` facing ``direction``: for
        "antistud" the anti-studs whose mouth (a sliding bore's outer end) lies within SNAP of ``place`` (a stud's tip),
        for "stud" the studs whose tip lies there (an anti-stud's mouth)."""
        seen = set()
        # a point is filed under its own cell, a run under every cell it passes (its mouth's too): a stud's base lies a
        # stud's length from its tip, an anti-stud's mouth at the place
        reach = SNAP + (STUD_LENGTH_IN if type == "stud" else 0.0)
        for cell in _around(place, reach, RUN_CELL, RUN_OFFSET):
            for other, oi in itertools.chain(self._coarse.get(cell, ()), self._runs.get(cell, ())):
                if (other, oi) in seen:
                    continue
                seen.add((other, oi))
                o = self.parts[other]
                c = o.shape.connectors[oi]
                if label[other] == piece or c.type != type or float(direction @ o.directions[oi]) > -ALIGN:
                    continue
                end = o.points[oi] + o.directions[oi] * (c.length if type == "antistud" else STUD_LENGTH_IN)
                if float(np.linalg.norm(end - place)) <= SNAP:
                    yield other, oi

    def _midway_places(self, id: str, point: np.ndarray, direction: np.ndarray, label: dict, reach: float,
                       type: str):
        """For a stud at ``point`` (``type`` "antistud"): (part, anti-stud, offset) of the parts of other pieces whose
        two anti-studs a pitch apart face it in its plane (within SNAP) with their midway place more than SNAP and at
        most ``reach`` from it, where the part grips it (:meth:`_grips_midway`). For the midway place ``point`` of two
        anti-studs of ``id`` facing along ``direction`` (``type`` "stud"): (part, stud, offset) of the studs of parts
        of other pieces facing them there."""
        near: dict[str, list[tuple[int, np.ndarray]]] = {}
        span = HALF_PITCH + reach if type == "antistud" else reach
        for cell in _around(point, span, RUN_CELL, RUN_OFFSET):
            for other, oi in self._coarse.get(cell, ()):
                o = self.parts[other]
                v = o.points[oi] - point
                if (label[other] != label[id] and o.shape.connectors[oi].type == type
                        and float(direction @ o.directions[oi]) <= -ALIGN and abs(float(v @ direction)) <= SNAP
                        and float(np.linalg.norm(v)) <= span):
                    near.setdefault(other, []).append((oi, o.points[oi]))
        for other, points in near.items():
            if type == "stud":
                for oi, q in points:
                    gap = float(np.linalg.norm(q - point))
                    if SNAP < gap <= reach:
                        yield other, oi, gap
                continue
            o = self.parts[other]
            for (oi, a), (_, b) in itertools.combinations(points, 2):
                gap = float(np.linalg.norm(point - (a + b) / 2))
                if (abs(float(np.linalg.norm(a - b)) - 2 * HALF_PITCH) <= SNAP and SNAP < gap <= reach
                        and self._grips_midway(o, a, b, direction)):
                    yield other, oi, gap
                    break

    @staticmethod
    def _antistud_pairs(placed: Placed):
        """(connector, point, point) of each two anti-studs of a placed part a pitch apart along an axis of its frame
        facing one way (found through the part's own coordinates, so a base plate's hundreds cost one look-up each)."""
        mouths = {(tuple(round(v) for v in c.point), c.direction): k for k, c in enumerate(placed.shape.connectors)
                  if c.type == "antistud" and c.length <= 0}
        for (point, direction), k in mouths.items():
            for step in ((2 * HALF_PITCH, 0, 0), (0, 2 * HALF_PITCH, 0), (0, 0, 2 * HALF_PITCH)):
                m = mouths.get((tuple(int(p + d) for p, d in zip(point, step)), direction))
                if m is not None:
                    yield k, placed.points[k], placed.points[m]

    def _grips_midway(self, o: Placed, a: np.ndarray, b: np.ndarray, direction: np.ndarray) -> bool:
        """``o`` one stud wide across its anti-studs ``a`` and ``b`` and stating no post between them: its long walls
        grip a stud pointing along ``direction`` midway between them."""
        middle = (a + b) / 2
        return not self._post_at(o, middle) and self._walls_across(o, middle, a - middle, direction)

    def seat_offset_studs(self) -> list[tuple[str, str]]:
        """Seat the studs of pieces left apart where a part above grips them between a tube and its walls although
        the snap data states no anti-stud there: half a stud along an outer row (midway between two of its
        anti-studs a pitch apart, a tube half a pitch inward, the part's side half a pitch outward: a half-stud
        offset under a 2-wide plate, as OMR 5935 hangs its skis), midway between two anti-studs of a part one stud
        wide that states no post there (its long walls grip it: a Technic brick on a jumper plate, as OMR 21309 hangs
        them), or under a part whose data states its tubes only (a tube half a pitch away diagonally, no anti-stud
        within half a pitch, the stud a stud's radius inside the part's sides). Returns the (stud's part, part) pairs
        seated."""
        groups = self.part_pieces()
        label = {p: k for k, g in enumerate(groups) for p in g}
        seated = []
        for group in groups:  # the largest piece's studs too: a part of another piece may sit on them
            for id in group:
                placed = self.parts[id]
                for ci, c in enumerate(placed.shape.connectors):
                    if c.type != "stud" or c.length > 0:
                        continue
                    for other, oi in self._grips(id, placed.points[ci], placed.directions[ci], label):
                        if self._link_at(id, ci, other, oi, "stud"):
                            seated.append((id, other))
        if seated:
            self._pebble_stale = True
        return seated

    def _link_at(self, id: str, ci: int, other: str, oi: int, kind: str) -> bool:
        """Record a connection of ``kind`` between part ``id``'s connector ``ci`` (where it is drawn) and ``other``'s
        connector ``oi``; True when it is the first link between the two parts."""
        placed = self.parts[id]
        key = (id, other) if (id, other) in self._links else (other, id)
        first = key not in self._links
        if first:
            self._neighbours[other].add(id)
            self._neighbours[id].add(other)
        self._links.setdefault(key, []).append(Connection(
            other, oi, id, ci, kind, tuple(_clean(v) for v in placed.points[ci]),
            tuple(_clean(v) for v in placed.directions[ci])))
        return first

    def _grips(self, id: str, point: np.ndarray, direction: np.ndarray, label: dict):
        """(part, tube anti-stud) of each part of another piece that grips the stud at ``point`` (pointing along
        ``direction``) between a tube and its walls (:meth:`seat_offset_studs`)."""
        mouths: dict[str, list[tuple[int, np.ndarray]]] = {}
        for cell in _around(point, RING_REACH + SNAP, RUN_CELL, RUN_OFFSET):
            for other, oi in self._coarse.get(cell, ()):
                o = self.parts[other]
                v = o.points[oi] - point
                if (label[other] != label[id] and o.shape.connectors[oi].type == "antistud"
                        and float(direction @ o.directions[oi]) <= -ALIGN and abs(float(v @ direction)) <= SNAP
                        and float(np.linalg.norm(v)) <= RING_REACH + SNAP):
                    mouths.setdefault(other, []).append((oi, v))
        for other, found in mouths.items():
            o = self.parts[other]
            ends = [(oi, v) for oi, v in found if abs(float(np.linalg.norm(v)) - HALF_PITCH) <= SNAP]
            pairs = [(a, b) for a, b in itertools.combinations(ends, 2) if float(np.linalg.norm(a[1] + b[1])) <= SNAP]
            gripped = next((oi for (_, row), _ in pairs for oi, v in found  # the tube half a pitch across the row
                            if abs(float(np.linalg.norm(v)) - HALF_PITCH) <= SNAP and abs(float(v @ row)) <= SNAP
                            and self._outside(o, point - v, v)), None)
            if gripped is None and pairs and not self._post_at(o, point):  # one stud wide, no post: its long walls
                gripped = next((oi for (oi, row), _ in pairs if self._walls_across(o, point, row, direction)), None)
            if gripped is None and all(float(np.linalg.norm(v)) > HALF_PITCH + SNAP for _, v in found):
                gripped = next((oi for oi, v in found  # a tube diagonally, the stud well inside the part's sides
                                if abs(float(np.linalg.norm(v)) - RING_REACH) <= SNAP and self._inside(o, point)),
                               None)
            if gripped is not None:
                yield other, gripped

    @staticmethod
    def _walls_across(o: Placed, point: np.ndarray, row: np.ndarray, direction: np.ndarray) -> bool:
        """``o``'s sides both half a pitch from ``point`` across the row of anti-studs (``row``: from the point to one
        of them) in the face the stud points into: the part is one stud wide there, and its walls grip the stud."""
        across = np.cross(row, direction)
        across = across / float(np.linalg.norm(across)) * HALF_PITCH
        return Assembly._outside(o, point + across, across) and Assembly._outside(o, point - across, -across)

    @staticmethod
    def _post_at(o: Placed, point: np.ndarray) -> bool:
        """A male snap cylinder of ``o`` within a stud's radius of ``point``'s line and reaching within a stud's length
        of it: the post under a 1 x N plate or brick between its anti-studs, which leaves no room for a stud there."""
        for k, c in enumerate(o.shape.connectors):
            if c.type != "fit_m":
                continue
            v = point - o.points[k]
            t = float(v @ o.directions[k])
            if (-STUD_LENGTH_IN - SNAP <= t <= c.length + STUD_LENGTH_IN + SNAP
                    and float(np.linalg.norm(v - t * o.directions[k])) < HOLE_RADIUS):
                return True
        return False

    @staticmethod
    def _inside(o: Placed, point: np.ndarray) -> bool:
        """``point`` (on a face of ``o``'s box) at least a stud's radius (6 LDU) inside the box in both directions
        along that face."""
        local = np.abs(o.rotation.T @ (point - o.position) - np.asarray(o.shape.box_center, float))
        room = np.asarray(o.shape.box_size, float) / 2 - local
        return bool(np.sort(room)[1] >= HOLE_RADIUS - SNAP)

    @staticmethod
    def _outside(o: Placed, point: np.ndarray, along: np.ndarray) -> bool:
        """``point`` on or beyond the side of ``o``'s box that the direction ``along`` crosses."""
        local = o.rotation.T @ (point - o.position) - np.asarray(o.shape.box_center, float)
        k = int(np.argmax(np.abs(o.rotation.T @ along)))
        return abs(float(local[k])) >= float(o.shape.box_size[k]) / 2 - SNAP

    def seat_tyres(self) -> list[tuple[str, str]]:
        """Seat the grouped female fits that no male of their group meets (a tyre whose wheel the snap data gives no
        rim, such as 122c01's) on the male snap cylinder of another part whose line passes through the fit's centre
        (within FIT_SNAP, parallel) inside the part's width along that line: the wheel the tyre is pushed onto. A
        rigid ``group`` connection at the centre. Returns the (tyre, wheel) pairs seated."""
        seated = []
        for id, placed in self.parts.items():
            tyres = [ci for ci, c in enumerate(placed.shape.connectors)
                     if c.type.startswith("group:") and c.type.endswith(":F")]
            if not tyres:
                continue
            linked = {c.cb if c.b == id else c.ca for other in self._neighbours[id]
                      for c in self._links.get((other, id), []) + self._links.get((id, other), []) if c.kind == GROUP}
            for ci in tyres:
                c = placed.shape.connectors[ci]
                if ci in linked:
                    continue
                centre, axis = placed.points[ci], placed.directions[ci]
                local = np.abs(np.asarray(c.direction, float))
                half = float(np.asarray(placed.shape.box_size, float) @ local) / 2 / float(np.linalg.norm(local))
                wheel = self._cylinder_through(id, centre, axis, half)
                if wheel is None or (wheel[0], id) in self._links or (id, wheel[0]) in self._links:
                    continue
                other, oi = wheel
                self._links[(other, id)] = [Connection(other, oi, id, ci, GROUP, tuple(_clean(v) for v in centre),
                                                       tuple(_clean(v) for v in axis))]
                self._neighbours[other].add(id)
                self._neighbours[id].add(other)
                seated.append((id, other))
        if seated:
            self._pebble_stale = True
        return seated

    def seat_clips_across_gaps(self) -> list[tuple[str, str]]:
        """Seat the clips that no bar meets at their centre where their jaws (their width along the bar) reach two bars
        of one other part on one line, one ending before the centre and one starting after it: the data states the bar
        in two pieces with the gap between them no wider than the clip (2921's handle: two 8 LDU bars either side of an
        8 LDU gap, where 6339-1 clips a tile on the handle's middle), and a clip held by bar on both sides is on the
        bar; or where a rod thinner than a bar, of the clip's radius, runs through the clip's centre along its axis
        (:meth:`_thin_rod_through`). A hinge about the bar or rod, as any clip on a bar. Returns the (clip's part,
        bar's part) pairs seated."""
        held = {(p, k) for conns in self._links.values() for c in conns if c.kind == "clip"
                for p, k in ((c.a, c.ca), (c.b, c.cb))}
        seated = []
        for id, placed in self.parts.items():
            for ci, c in enumerate(placed.shape.connectors):
                if c.type not in CLIPS or c.depth <= 0 or (id, ci) in held:
                    continue
                bar = ((c.type == "clip" and self._bar_across(id, placed.points[ci], placed.directions[ci],
                                                               c.depth / 2 + SNAP))
                       or self._thin_rod_through(id, placed.points[ci], placed.directions[ci], _clip_radius(c)))
                if bar is None:
                    continue
                other, oi = bar
                if self._link_at(id, ci, other, oi, "clip"):
                    seated.append((id, other))
        if seated:
            self._pebble_stale = True
        return seated

    def _bar_across(self, id: str, centre: np.ndarray, axis: np.ndarray, half: float):
        """(part, bar) of the first other part with two bars on the line through ``centre`` along ``axis`` (parallel,
        within FIT_SNAP) that reach within ``half`` of it from either side, one ending before it and one starting after
        it; the bar is the one before (:meth:`seat_clips_across_gaps`). None when no part has such bars."""
        sides: dict[str, dict[int, int]] = {}  # part -> side (-1 before the centre, +1 after) -> its bar
        for other, oi, ends in self._runs_on_line(id, "bar", centre, axis, half):
            if -half <= ends[1] <= SNAP:
                sides.setdefault(other, {}).setdefault(-1, oi)
            elif -SNAP <= ends[0] <= half:
                sides.setdefault(other, {}).setdefault(1, oi)
        return next(((other, found[-1]) for other, found in sorted(sides.items()) if len(found) == 2), None)

    def _thin_rod_through(self, id: str, centre: np.ndarray, axis: np.ndarray, radius: float):
        """(part, snap cylinder) of the first male snap cylinder of another part whose round section at the clip's
        centre is thinner than a bar and of the clip's ``radius`` (within RADIUS_FIT), on the
        clip's axis (parallel, within FIT_SNAP) and reaching past the centre on both sides: the data makes bars of
        radius-4 sections only, and states a thinner rod only as a cylinder (the chain tread link 3873 clips onto the
        next link's pin ends, radius 1.5, as set 10227 runs 36 of them); a rod through a clip's centre is inside its
        jaws, and held by them only when it is as thick as the rod they are made for (a bar's clip does not grip a
        radius-1.5 pin end). None when no part has one there."""
        for other, oi, ends in self._runs_on_line(id, "fit_m", centre, axis, SNAP):
            o = self.parts[other]
            t = float((centre - o.points[oi]) @ o.directions[oi])  # where the centre lies along the cylinder
            start = 0.0
            for shape, rod, length in o.shape.connectors[oi].profile:
                if start + SNAP < t < start + length - SNAP:
                    if shape == "R" and rod < THIN_ROD and abs(rod - radius) < RADIUS_FIT:
                        return other, oi
                    break
                start += length
        return None

    def _cylinder_through(self, id: str, centre: np.ndarray, axis: np.ndarray, half: float):
        """(part, connector) of the first male snap cylinder of another part on the line through ``centre`` along
        ``axis`` (parallel, within FIT_SNAP) that reaches within ``half`` of ``centre`` along it, or None."""
        for other, oi, ends in self._runs_on_line(id, "fit_m", centre, axis, half):
            if min(ends[1], half) - max(ends[0], -half) > SNAP:
                return other, oi
        return None

    def _runs_on_line(self, id: str, type: str, centre: np.ndarray, axis: np.ndarray, half: float):
        """(part, connector, (start, end)) of each run of ``type`` of a part other than ``id`` parallel to ``axis``
        (within ALIGN) on the line through ``centre`` (within FIT_SNAP), found in the cells within ``half`` of it;
        start <= end are where the run lies along ``axis`` from ``centre``."""
        for cell in sorted(_cells_along(centre - axis * half, axis, 2 * half, FIT_SNAP)):
            for other, oi in self._runs.get(cell, ()):
                o = self.parts[other]
                theirs = o.shape.connectors[oi]
                cos = float(axis @ o.directions[oi])
                if other == id or theirs.type != type or abs(cos) < ALIGN:
                    continue
                v = o.points[oi] - centre
                along = float(v @ axis)
                if float(np.linalg.norm(v - along * axis)) > FIT_SNAP:
                    continue
                start, end = sorted((along, along + theirs.length * cos))
                yield other, oi, (start, end)

    def _gap(self, c: Connection) -> float:
        """How far a connection's two points miss each other (LDU): between two points their distance; for a run
        (axle, bar, hinge fingers, a fit cylinder) the other's distance from its line, and for a point (a hole, a
        clip) how far its bore's mouth also lies past the run's end; for a ring how far the stud is off its place
        around it."""
        a, b = self.parts[c.a], self.parts[c.b]
        ca, cb = a.shape.connectors[c.ca], b.shape.connectors[c.cb]
        pa, pb = a.points[c.ca], b.points[c.cb]
        v = pb - pa
        if "ring" in (ca.type, cb.type):
            axis = a.directions[c.ca]
            along = float(v @ axis)
            return math.hypot(along, float(np.linalg.norm(v - along * axis)) - RING_REACH)
        if ca.length <= 0 and cb.length <= 0:
            return float(np.linalg.norm(v))
        axis = a.directions[c.ca] if ca.length > 0 else b.directions[c.cb]
        across = float(np.linalg.norm(v - float(v @ axis) * axis))
        if ca.length > 0 and cb.length > 0:
            return across
        run, point, along = (ca, cb, float(v @ axis)) if ca.length > 0 else (cb, ca, -float(v @ axis))
        past = max(0.0, -along, along - run.length) - _half_bore(point)
        return math.hypot(across, past) if past > 0 else across

    def offsets(self) -> dict[tuple[str, str], float]:
        """(part, part) -> offset (LDU) of the pairs :meth:`join_pieces` joined."""
        return dict(self._offsets)

    def _fits_along(self, mine, start: np.ndarray, axis: np.ndarray, reach: float = FIT_SNAP):
        """(part, connector, kind, point) of the placed fit cylinders of the other gender on the line of ``mine``
        (placed at ``start`` along ``axis``) that it fits (:func:`catalogue.fit`): kind ``fit`` (turns) or
        ``fit_keyed``; for a run of hinge fingers the runs of fingers it interlocks with (kind ``hinge``). The
        point is the middle of the overlap."""
        seen = set()
        for cell in _cells_along(start, axis, mine.length, reach):
            for other, oi in self._runs.get(cell, ()):
                if (other, oi) in seen:
                    continue
                seen.add((other, oi))
                o = self.parts[other]
                theirs = o.shape.connectors[oi]
                kind = mate(mine.type, theirs.type)
                cos = float(axis @ o.directions[oi])
                parallel = FIT_ALIGN if kind == "fit" else ALIGN
                if kind not in ("fit", "hinge") or theirs.length <= 0 or abs(cos) < parallel:
                    continue
                v = o.points[oi] - start
                along = float(v @ axis)
                o_end = along + theirs.length * cos
                if kind == "hinge":  # two runs of hinge fingers on one axis interlock where they overlap
                    lo, hi = max(0.0, min(along, o_end)), min(mine.length, max(along, o_end))
                    if float(np.linalg.norm(v - along * axis)) <= reach and hi - lo >= FIT_OVERLAP:
                        yield other, oi, "hinge", start + axis * (lo + hi) / 2
                    continue
                # a cylinder is in the other where their axes stay within reach of each other over their overlap
                lo, hi = max(0.0, min(along, o_end)), min(mine.length, max(along, o_end))
                if hi - lo < fit_depth((mine if mine.type == "fit_m" else theirs).length) or any(
                        float(np.linalg.norm(q - float(q @ axis) * axis)) > reach
                        for q in (v + o.directions[oi] * ((t - along) / cos) for t in (lo, hi))):
                    continue
                male, female = (mine, theirs) if mine.type == "fit_m" else (theirs, mine)
                m_span, f_span = ((0.0, mine.length), (along, o_end)) if mine.type == "fit_m" else (
                    (along, o_end), (0.0, mine.length))
                how = fit(male.profile, female.profile, *m_span, *f_span)
                if how is None:
                    continue
                lo, hi = max(min(m_span), min(f_span)), min(max(m_span), max(f_span))
                yield other, oi, ("fit_keyed" if how == "keyed" else "fit"), start + axis * (lo + hi) / 2

    def _ring_mates(self, mine: str, point: np.ndarray, direction: np.ndarray, reach: float = SNAP):
        """(part, connector, stud point) of the studs a ring stands between (for a stud: the rings it is one of
        the four studs around): facing it, in its plane (within ``reach``), RING_REACH from its centre (within
        FIT_SNAP / 2, or ``reach`` when that is more)."""
        table = self._coarse if mine == "ring" else self._rings
        if not table:
            return
        spread = max(FIT_SNAP / 2, reach)
        for cell in _around(point, RING_REACH + 2 * spread, RUN_CELL, RUN_OFFSET):
            for other, oi in table.get(cell, ()):
                o = self.parts[other]
                if mate(mine, o.shape.connectors[oi].type) != "ring" or float(direction @ o.directions[oi]) > -ALIGN:
                    continue
                v = o.points[oi] - point
                if abs(float(v @ direction)) <= reach and abs(float(np.linalg.norm(v)) - RING_REACH) <= spread:
                    yield other, oi, (point + v if mine == "ring" else point)

    def _runs_near(self, point: np.ndarray, reach: float = FIT_SNAP, beyond: float = SNAP):
        """The runs (axles, bars) that ``point`` lies on (within ``reach`` of their line, within ``beyond`` of
        their ends: :func:`_on_run`)."""
        if not self._runs:
            return
        seen = set()
        for cell in _around(point, max(reach, beyond) + 0.5, RUN_CELL, RUN_OFFSET):
            for other, oi in self._runs.get(cell, ()):
                o = self.parts[other]
                if (other, oi) not in seen and _on_run(point, o.points[oi], o.directions[oi],
                                                       o.shape.connectors[oi].length, reach, beyond):
                    seen.add((other, oi))
                    yield other, oi

    def _points_along(self, start: np.ndarray, axis: np.ndarray, length: float, reach: float = FIT_SNAP,
                      slip: float = 0.0):
        """The connection points within ``reach`` of the line of the run from ``start`` along ``axis`` for
        ``length`` (:func:`_on_run`), past its ends as far as :func:`_slip_beyond` lets each."""
        if slip <= 0:
            for cell in _cells_along(start, axis, length, reach):
                for other, oi in self._coarse.get(cell, ()):
                    if _on_run(self.parts[other].points[oi], start, axis, length, reach):
                        yield other, oi
            return
        past = SLIP_BORE / 2 + slip  # the run's line grown past its ends, not its box grown all round
        for cell in _cells_along(start - axis * past, axis, length + 2 * past, reach):
            for other, oi in self._coarse.get(cell, ()):
                if _on_run(self.parts[other].points[oi], start, axis, length, reach,
                           _slip_beyond(self.parts[other].shape.connectors[oi], slip)):
                    yield other, oi

    def _near(self, point: np.ndarray, reach: float):
        """The (part, connector) slots within ``reach`` of ``point`` (rings only within a fine cell's reach: further
        out only studs look for them, :meth:`_ring_mates`)."""
        table, size, offset = (self._slots, POINT_CELL, POINT_OFFSET) if reach <= POINT_CELL else (
            self._coarse, RUN_CELL, RUN_OFFSET)
        for cell in _around(point, reach, size, offset):
            for other, oi in table.get(cell, ()):
                if float(np.sum((self.parts[other].points[oi] - point) ** 2)) <= reach * reach:
                    yield other, oi

    def remove_part(self, id: str) -> None:
        placed = self.parts.pop(id)
        self._free_table = self._boxes = None
        registered = [(self._slots, key) for key in placed.keys if key is not None]
        for ci, key in enumerate(placed.keys):
            if key is not None:
                table = self._rings if placed.shape.connectors[ci].type == "ring" else self._coarse
                registered.append((table, _cell(placed.points[ci])))
            else:
                registered.extend((self._runs, cell) for cell in _run_cells(
                    placed.points[ci], placed.directions[ci], placed.shape.connectors[ci].length))
        for table, key in registered:
            slot = [s for s in table.get(key, []) if s[0] != id]
            if slot:
                table[key] = slot
            else:
                table.pop(key, None)
        for other in self._neighbours.pop(id):
            for pair in ((other, id), (id, other)):
                self._links.pop(pair, None)
                self._offsets.pop(pair, None)
                self._tilts.pop(pair, None)
                self._contacts.pop(pair, None)
            self._neighbours[other].discard(id)
        self._pebble_stale = True

    def add_body(self, id: str, solid: Solid | None = None) -> None:
        if id in self.parts or id in self.bodies:
            raise ValueError(f"id {id!r} is already in the assembly")
        self.bodies[id] = solid
        self._free_table = self._boxes = None
        self._pebble.add_body(id)

    def add_joint(self, spec: JointSpec) -> None:
        self.joints[spec.id] = spec
        if not self._pebble_stale:
            self._pebble.add_joint(spec.bodies[0], spec.bodies[1], 6 - FREEDOM[spec.type])

    def remove_joint(self, id: str) -> None:
        self.joints.pop(id)
        self._pebble_stale = True

    # ---------------------------------------------------------------- queries
    @staticmethod
    def _pair_joints(a: str, b: str, conns: list[Connection], ordered: bool = False) -> list[JointSpec]:
        """The joints inferred between parts ``a`` and ``b``, named and ordered by the parts' ids and the
        connections' places, not by which part the file placed first: a model written in another order
        answers with the same joint ids, points and axes (a connection's axis is its later part's connector,
        so an axis is given as the line's direction whose first non-zero component is positive)."""
        if not ordered:
            a, b = sorted((a, b), key=natural_order)
        conns = sorted(conns, key=lambda c: (c.point, c.kind, _line_direction(c.axis) or ()))
        studs = [c for c in conns if c.kind == "stud"]
        if len(studs) >= 2 or any(c.kind == "axle" for c in conns):
            c = conns[0]
            return [JointSpec(f"{a}~{b}", "rigid", (a, b), c.point, _line_direction(c.axis),
                              "axle" if any(x.kind == "axle" for x in conns) else "stud", len(conns))]
        return [JointSpec(f"{a}~{b}" + (f"#{k + 1}" if len(conns) > 1 else ""), JOINT_OF[c.kind], (a, b), c.point,
                          _line_direction(c.axis), ORIGIN_OF.get(c.kind, c.kind), 1) for k, c in enumerate(conns)]

    def all_joints(self) -> list[JointSpec]:
        out = list(self.joints.values())
        pairs = []  # each pair's ends in natural order, each id's key made once per end (a large model's joints)
        for (a, b), conns in self._links.items():
            key_a, key_b = natural_order(a), natural_order(b)
            pairs.append(((key_a, key_b), a, b, conns) if key_a <= key_b else ((key_b, key_a), b, a, conns))
        for _, a, b, conns in sorted(pairs, key=lambda pair: pair[0]):
            out.extend(self._pair_joints(a, b, conns, ordered=True))
        return out

    def rod_pairs(self) -> list[tuple[str, str]]:
        """Part pairs held by two or more pins (or axles in round holes) on distinct parallel lines: rigid
        to each other (seed §3's rigid connections), while each rod still turns in its holes."""
        lines: dict[tuple[str, str], list[tuple[np.ndarray, np.ndarray]]] = {}
        for rod in self.parts:
            ends = {}
            for other in self._neighbours.get(rod, ()):
                conns = self._links.get((other, rod)) or self._links.get((rod, other)) or []
                for c in conns:
                    if c.kind in ("pin", "axle_round") and other not in ends:
                        ends[other] = (np.asarray(c.point, float), np.asarray(c.axis, float))
            hosts = sorted(ends)
            for i, a in enumerate(hosts):
                for b in hosts[i + 1:]:
                    lines.setdefault((a, b), []).append(ends[a])
        pairs = []
        for pair, found in lines.items():
            for i, (p1, a1) in enumerate(found):
                if any(abs(abs(a1 @ a2) - np.linalg.norm(a1) * np.linalg.norm(a2)) < 1e-9
                       and np.linalg.norm(np.cross(p2 - p1, a1)) > 1e-6 for p2, a2 in found[i + 1:]):
                    pairs.append(pair)
                    break
        return pairs

    def ids(self) -> list[str]:
        return [*self.parts, *self.bodies]

    @property
    def generic_dof(self) -> int:
        if self._pebble_stale:
            game = PebbleGame()
            for body in self.ids():
                game.add_body(body)
            for j in self.all_joints():
                game.add_joint(j.bodies[0], j.bodies[1], 6 - FREEDOM[j.type])
            self._pebble, self._pebble_stale = game, False
        return self._pebble.generic_dof

    def analyse(self, **tolerances) -> Analysis:
        ids = self.ids()
        index = {b: k for k, b in enumerate(ids)}
        specs = self.all_joints()
        joints = [Joint(s.type, index[s.bodies[0]], index[s.bodies[1]], tuple(s.point),
                        tuple(s.axis) if s.axis is not None else (0, 0, 1)) for s in specs]
        mobility = analyse(len(ids), joints, **tolerances)
        return Analysis(ids, specs, mobility, self.generic_dof)

    def solids(self) -> tuple[list[str], list[Solid | None]]:
        ids = self.ids()
        return ids, [self.parts[i].solid() if i in self.parts else self.bodies[i] for i in ids]

    def solid_boxes(self):
        """(ids, solids, lower corners, upper corners) of the bodies' world boxes, kept until the next change."""
        if self._boxes is None:
            ids, solids = self.solids()
            boxes = [s.aabb() if s is not None else (np.full(3, np.inf), np.full(3, -np.inf)) for s in solids]
            self._boxes = (ids, solids, np.array([b[0] for b in boxes]).reshape(-1, 3),
                           np.array([b[1] for b in boxes]).reshape(-1, 3))
        return self._boxes

    def inserted_pairs(self) -> set[tuple[str, str]]:
        """Part pairs joined pin- or axle-in-hole: they overlap by design."""
        return {pair for pair, conns in self._links.items() if any(c.kind in INSERTED for c in conns)}

    def collisions(self, tolerance: float) -> list[tuple[str, str, float]]:
        ids, solids = self.solids()
        index = {b: k for k, b in enumerate(ids)}
        exclude = set()
        for a, b in self.inserted_pairs():
            i, j = sorted((index[a], index[b]))
            exclude.add((i, j))
        return [(ids[i], ids[j], d) for i, j, d in find_collisions(solids, tolerance, exclude)]

    def free_connectors(self) -> list[tuple[str, int]]:
        """Connection points not used by any connection, and every run (an axle or a bar takes more holes
        and clips along it)."""
        used = set()
        for conns in self._links.values():
            for c in conns:
                used.add((c.a, c.ca))
                used.add((c.b, c.cb))
        return [(pid, ci) for pid, p in self.parts.items() for ci in range(len(p.keys))
                if ((pid, ci) not in used or p.keys[ci] is None) and p.shape.connectors[ci].type not in NOT_DOCKED]

    def free_table(self):
        """(owner ids, types, directions in the owner's frame, world points, owner rotations) of the free
        connection points (runs as points along them, :func:`catalogue.samples`), as arrays for docking;
        kept until the next add or remove."""
        if self._free_table is None:
            free = []
            for pid, ci in self.free_connectors():
                placed = self.parts[pid]
                for c in samples(placed.shape.connectors[ci]):
                    free.append((pid, c, placed.rotation @ np.asarray(c.point, float) + placed.position))
            if not free:
                return None
            parts = self.parts
            self._free_table = (
                np.array([p for p, _, _ in free], dtype=object),
                np.array([c.type for _, c, _ in free], dtype=object),
                np.array([c.direction for _, c, _ in free], dtype=float),
                np.array([w for _, _, w in free]),
                np.array([parts[p].rotation for p, _, _ in free]))
        return self._free_table
