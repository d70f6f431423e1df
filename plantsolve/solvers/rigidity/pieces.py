"""What a LEGO model's joints say about its parts: each part's joints, the connected pieces, which pieces are
sub-builds that may stand apart, and parts placed implausibly far from the rest.

A piece besides the largest is a **sub-build** when it is exactly the known parts of whole placed LDraw
sub-models (every part of each placement and nothing else: a droid standing beside its vehicle, a minifigure
modelled as its own sub-model, a cart with the minifigure standing on it) none of whose parts touches a part of
the largest piece (:func:`clearance` under TOUCH_GAP: a sub-model lying against the build is a part of it whose
joint was not found, as OMR 10174's roof, tilted 9 degrees on the head), or when it holds minifigure parts only
(a minifigure whose hands hold nothing of the build). Pieces that are no sub-build each are one together when
they are the known parts of whole placed sub-models and stand LOOSE_CLEARANCE clear of the build
(:func:`loose_sub_builds`). Of the other pieces, one that the drawing itself places apart (:func:`drawn_apart`:
touching no part outside it, no connection point within APART_MISS of a mate, no part outside the catalogue beside it)
is a separate build: a second vehicle, an accessory or spare parts laid aside, or a part fallen off, which no joint
finding can join. Any other piece means joints the catalogue did not find, or a model that really is in pieces: the
solver warns about it.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np

LINE = re.compile(r"L(\d+)$")
# LDU: a part this far from the middle of the model (40 m of LEGO) is a typing slip or another unit; so is one
# FAR_FACTOR times further out than the parts' median distance from the middle.
FAR_LDU = 1e5
FAR_FACTOR = 100.0
PITCH = 20.0  # LDU: added to the median distance so that a model of a few stacked parts has a scale
MINIFIG = "minifig"  # LDraw names of minifigure parts start with it
# what LDraw puts before a part's name to mark it, not to name it: '~' an obsolete, moved or hidden part ("~Minifig Hips
# (Obsolete)"), '_' a physical colour's variant, '|' an alias
NAME_MARKS = "~_|"
MINIFIGURE = "minifigure"  # the sub_build of a piece of minifigure parts only
TOUCH_GAP = 0.5  # LDU: boxes this close touch (a part resting on another whose joint was not found meets it at 0)
# LDU: two stud pitches, how far pieces must stay from the build, parts without a collision shape counted at their
# origin, to be one sub-build together (loose_sub_builds). Hose and cable segments joined through parts not in
# the catalogue lie within a stud of the build (OMR 8002: 6-34 LDU, 21309: 20-23); a cart beside its X-wing 105.
LOOSE_CLEARANCE = 40.0
# LDU: half a stud pitch, how far a piece's nearest mate must lie (misses.Misses.nearest) for the piece to be drawn
# apart (drawn_apart). Up to a plate's height (8 LDU: a row a plate above the studs it would sit on) the gap may be a
# plate the model omits or one the library has thickened since, so such a piece stays one whose joint was not found.
APART_MISS = 10.0
LINED_UP = 0.5  # LDU: a mate this close to the line of a point's axis is straight above or below it (LDraw rounding)
# LDU: how far clear of every other part a piece must stand to be drawn apart: more than the slip that
# Assembly.join_pieces takes for a part drawn off its mate (assembly.OFFSET_REACH), so that a part drawn 2 LDU off
# what it is pressed on (a spare wheel on a truck's panel, set 4096) is not said to be apart.
APART_GAP = 3.1


def mostly_floating(floating: int, parts: int) -> bool:
    """More than half of three or more parts joined to nothing: positions in another unit, or no build."""
    return parts >= 3 and 2 * floating > parts


def joints_by_part(part_ids: Sequence[str],
                   joints: Iterable[tuple[str, Sequence[str]]]) -> dict[str, tuple[list, list]]:
    """part id -> (ids of the joints it is in, ids of the parts they join it to), for every part."""
    out: dict[str, tuple[list, list]] = {p: ([], []) for p in part_ids}
    for joint_id, bodies in joints:
        for b in bodies:
            if b in out:
                out[b][0].append(joint_id)
                out[b][1].extend(o for o in bodies if o != b and o not in out[b][1])
    return out


def pieces(part_ids: Sequence[str], joined: Mapping[str, Sequence[str]]) -> list[list[str]]:
    """The connected pieces of the parts (joined: part -> parts joined to it), largest first, parts in request
    order."""
    root = {p: p for p in part_ids}

    def find(x: str) -> str:
        while root[x] != x:
            root[x] = root[root[x]]
            x = root[x]
        return x

    for p in part_ids:
        for q in joined.get(p, ()):
            if q in root:
                root[find(q)] = find(p)
    groups: dict[str, list[str]] = {}
    for p in part_ids:
        groups.setdefault(find(p), []).append(p)
    order = {p: k for k, p in enumerate(part_ids)}
    return sorted(groups.values(), key=lambda g: (-len(g), order[g[0]]))


def sub_build(piece: Sequence[str], part_ids: Sequence[str], placements: Mapping[str, str],
              names: Mapping[str, str]) -> str | None:
    """What makes ``piece`` a sub-build that may stand apart: the file names of the placed sub-models whose known
    parts it is, whole (one, or several: a cart with the minifigure standing on it), joined by ' + '; 'minifigure'
    for a piece of minifigure parts only; else None."""
    members = set(piece)
    by_prefix: dict[str, set[str]] = {}
    for p in part_ids:
        for prefix in _prefixes(p):
            by_prefix.setdefault(prefix, set()).add(p)
    chosen: list[str] = []
    for p in piece:  # the outermost placement holding p whose known parts are all in the piece
        whole = next((prefix for prefix in _prefixes(p) if by_prefix[prefix] <= members), None)
        if whole is None:
            chosen = []
            break
        if whole not in chosen:
            chosen.append(whole)
    if chosen:
        return " + ".join(placements.get(prefix, prefix.rstrip("/")) for prefix in chosen)
    if all(names.get(p, "").lstrip(NAME_MARKS).lower().startswith(MINIFIG) for p in piece):
        return MINIFIGURE
    return None


def resting_on_smooth_faces(piece: Sequence[str], build: Sequence[str], lower: Mapping[str, np.ndarray],
                            upper: Mapping[str, np.ndarray], studs_up: Callable[[str], np.ndarray]) -> bool:
    """Whether ``piece`` touches ``build`` (boxes within TOUCH_GAP, as :func:`clearance` measures) only lying on top
    of it where the build has no stud: every part of the piece that touches a part of the build has that part under
    it (the build part's top, LDraw's y pointing down, at or below the piece part's bottom), and none of the touched
    parts has an upward stud (``studs_up``: part -> its studs' points pointing up, an (n, 3) array) within the piece
    part's footprint. Nothing there can hold the piece (a brick resting on a tile is held by nothing): a vehicle
    standing on a road of tiles (10214's four cars), a floor lifted onto a wall capped with tiles. A piece touching
    nothing is False (:func:`clearance` decides it)."""
    theirs = [p for p in build if p in lower]
    if not theirs:
        return False
    lo_b, hi_b = np.array([lower[p] for p in theirs]), np.array([upper[p] for p in theirs])
    touched_any = False
    for p in piece:
        if p not in lower:
            continue
        gaps = np.max(np.maximum(lower[p] - hi_b, lo_b - upper[p]), axis=1)
        for k in np.nonzero(gaps < TOUCH_GAP)[0]:
            touched_any = True
            if lo_b[k][1] < upper[p][1] - TOUCH_GAP:
                return False  # beside or under it, not only under it
            studs = studs_up(theirs[k])
            inside = ((studs[:, 0] > lower[p][0] - TOUCH_GAP) & (studs[:, 0] < upper[p][0] + TOUCH_GAP)
                      & (studs[:, 2] > lower[p][2] - TOUCH_GAP) & (studs[:, 2] < upper[p][2] + TOUCH_GAP))
            if inside.any():
                return False
    return touched_any


def drawn_apart(gap: float, nearest: float | None, beside_unknown: bool, lined_up: bool = False) -> bool:
    """A piece the drawing places apart from the rest of the model: its parts at least APART_GAP from every part
    outside it (``gap``, :func:`clearance` against all of them, parts without a collision shape at their origin), its
    nearest mate further than APART_MISS (``nearest`` in LDU, None: none within misses.REACH) and no part outside the
    catalogue beside it (``beside_unknown``: it may be what holds the piece), and that mate not straight along its
    point's axis (``lined_up``: studs facing anti-studs a brick's height off are a brick left out of the drawing, not a
    second build). Lying against the build (a roof on its walls), a plate's height off its mates, lined up with a
    mate within misses.REACH or beside a part the catalogue lacks, a piece may be joined in the model and is not said
    to be apart."""
    return (gap >= APART_GAP and (nearest is None or nearest > APART_MISS) and not beside_unknown
            and not lined_up)


def loose_sub_builds(apart: Sequence[Sequence[str]], part_ids: Sequence[str],
                     placements: Mapping[str, str]) -> list[str | None]:
    """For pieces that stand clear of the build (LOOSE_CLEARANCE) and are no sub-build each: the sub-build they
    are together, as :func:`sub_build` names it, where some of them are exactly the known parts of whole placed
    sub-models (a cart with the pilot on it and the cargo lying loose in it: OMR 7140), else None, per piece."""
    members = {p: k for k, piece in enumerate(apart) for p in piece}
    order = {p: k for k, p in enumerate(part_ids)}
    by_prefix: dict[str, set[str]] = {}
    for p in part_ids:
        for prefix in _prefixes(p):
            by_prefix.setdefault(prefix, set()).add(p)
    outermost: dict[str, str] = {}  # part -> the outermost placement holding it whose known parts all stand apart
    for p in members:
        whole = next((prefix for prefix in _prefixes(p) if by_prefix[prefix] <= members.keys()), None)
        if whole is not None:
            outermost[p] = whole
    groups: dict[str, set[int]] = {}  # placement -> the pieces its parts lie in
    for p, prefix in outermost.items():
        groups.setdefault(prefix, set()).add(members[p])
    # placements sharing a piece are one sub-build; it holds when each of its pieces lies in its placements only
    root = {prefix: prefix for prefix in groups}
    by_piece: dict[int, str] = {}
    for prefix, held in groups.items():
        for k in held:
            other = by_piece.setdefault(k, prefix)
            root[_root(root, other)] = _root(root, prefix)
    names: list[str | None] = [None] * len(apart)
    joined: dict[str, list[str]] = {}
    for prefix in groups:
        joined.setdefault(_root(root, prefix), []).append(prefix)
    for chosen in joined.values():
        pieces_in = set().union(*(groups[prefix] for prefix in chosen))
        if len(pieces_in) < 2 or any(p not in outermost or _root(root, outermost[p]) != _root(root, chosen[0])
                                     for k in pieces_in for p in apart[k]):
            continue  # one piece is judged by sub_build alone; a piece reaching beyond the placements is no part
        ordered = sorted(chosen, key=lambda prefix: min(order[p] for p in by_prefix[prefix]))
        for k in pieces_in:
            names[k] = " + ".join(placements.get(prefix, prefix.rstrip("/")) for prefix in ordered)
    return names


def _root(root: dict[str, str], x: str) -> str:
    while root[x] != x:
        root[x] = root[root[x]]
        x = root[x]
    return x


def clearance(piece: Sequence[str], build: Sequence[str], lower: Mapping[str, np.ndarray],
              upper: Mapping[str, np.ndarray]) -> float:
    """How far the parts of ``piece`` stay from those of ``build``: the least gap between a box of one and a box of
    the other (world-aligned, lower and upper corners by part id; parts not in them are left out), along the axis
    that separates them most (negative: the boxes overlap that deep); infinite when either side has no box. Boxes of
    turned parts are larger than the parts, so this errs towards close: towards calling a piece part of the build
    rather than a sub-build standing apart."""
    mine = [p for p in piece if p in lower]
    theirs = [p for p in build if p in lower]
    if not mine or not theirs:
        return float("inf")
    lo_b, hi_b = np.array([lower[p] for p in theirs]), np.array([upper[p] for p in theirs])
    return min(float(np.max(np.maximum(lower[p] - hi_b, lo_b - upper[p]), axis=1).min()) for p in mine)


def _prefixes(part_id: str) -> list[str]:
    """The sub-model placements a part id lies in, outermost first (``L3/L40/L7`` -> ``L3/``, ``L3/L40/``)."""
    return [part_id[:m.end() + 1] for m in re.finditer(r"L\d+(?=/)", part_id)]


def line_of(part_id: str) -> int | None:
    """The file line a part id names (``L12``, ``L3/L40`` -> 40): the id's last ``L<n>``."""
    m = LINE.search(part_id)
    return int(m.group(1)) if m else None


def far_parts(part_ids: Sequence[str], positions: np.ndarray) -> list[tuple[str, float, float]]:
    """(id, distance from the middle, the bound it passed) of parts implausibly far from the middle of the
    model (the median of the part positions): beyond FAR_LDU and beyond FAR_FACTOR times the median distance
    of the parts from the middle. Of two parts, whose middle is halfway, the median distance is their own: only
    FAR_LDU bounds them, and both are named (which one is off cannot be told)."""
    if len(part_ids) < 2:
        return []
    middle = np.median(positions, axis=0)
    distance = np.linalg.norm(positions - middle, axis=1)
    bound = FAR_LDU if len(part_ids) == 2 else max(FAR_LDU, FAR_FACTOR * (float(np.median(distance)) + PITCH))
    return [(p, float(d), bound) for p, d in zip(part_ids, distance) if d > bound]
