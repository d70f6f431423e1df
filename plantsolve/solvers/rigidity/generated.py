"""The generated part of the catalogue: thousands of LDraw parts from the LDCad shadow library's snap data.

``data/ldcad_parts.tsv.gz`` is written by ``scripts/ldcad_catalogue.py`` (its docstring gives the
format; the data's licence and attribution are in ``data/README.md``). Each part there is its name,
the bounding box of its drawn geometry and its snaps (cylinders, clips, hinge fingers, ball joints,
grouped fits) in the part's LDraw frame. This module turns snaps into the catalogue's connection points, so that two
snaps that fit make a connection where their points meet (the assembly matches points on a 0.001 LDU
grid and compatible types, :data:`catalogue.MATES`):

- A stud is a male round (or square) section of radius 6 at most 6 LDU long, wherever it sits on its
  cylinder (a round plate's stud above its rim, a half pin's short end): one ``stud`` point at its
  base, pointing out along the cylinder; so is a closed male cylinder of radius 6 that does not slide
  (a minifigure's hip pegs), at its start. A female cylinder starting with radius 6 that does not slide
  through (or is under half a stud long) is an ``antistud`` at its mouth, pointing out of the part.
  Parts stacked as designed have their studs' bases on the anti-studs' mouths.
- Otherwise a cylinder (technic holes, pins, axles) is cut into 20 LDU slots from its start (one slot
  when shorter), one point at each slot's centre, typed by the section there: shape ``A`` an ``axle``
  or ``axlehole``, round radius 6 a ``pin`` or ``pinhole``. A male axle slides in its holes, so it has
  a point every 10 LDU (a hole meets it at whole or half studs), as the hand-coded axles do. A pin in a
  hole has both points at the hole's centre: coaxial, overlapping along the axis. A hole states its bore's
  length (its section's, or its slot's) as its ``depth``.
- A male round section of radius 4 is a ``bar``, a point every 2 LDU along it (a clip holds it
  anywhere); a clip (``SNAP_CLP``) is one point at its centre, its width along the bar its ``depth``, the radius of
  the rod it grips in its ``profile`` (``(("R", radius, width),)``): a ``clip`` when that radius is a bar's (within
  :data:`RADIUS_FIT`), else a ``rodclip``, which no bar meets (a spanner's radius-6 jaws, a wheel clip's radius-2
  ones: the shadow library states a clip's radius as that of the rod it is made for, 3711's 1.5 for its 1.5 pin
  ends). Clip on bar: a hinge about the bar.
  Female radius-4 holes (hollow studs, a pin's bore) make no point.
- Hinge fingers (``SNAP_FGR``) are one ``finger`` point at the centre of the finger run, along the
  hinge axis; two finger runs on one axis with one centre interlock (a hinge), whichever finger comes
  first (the data's ``genderOfs``), and so do a finger run and a hand-coded hinge half.
- A ball (``SNAP_GEN`` sphere, male) is a ``ball`` point at its centre, its socket a ``socket``: a
  ball joint, any direction.
- A generic snap of a ``group`` (a tyre on its rim, a drawer in its cabinet) is a ``group:<name>:M``
  or ``…:F`` point at its centre along its axis: male and female of one group at one point make a
  rigid connection (the fit holds).
- A clip of a ``group`` (a universal joint's end, 3712, clipped on the cross of its centre, 3326b) is a
  ``pivot:<name>:F`` point at its centre along its axis, and a cylinder of that group (each arm of the cross) also a
  ``pivot:<name>:M`` point at its middle: male and female of one group at one point on one axis make a hinge about
  it. Such a clip holds nothing else (it is made for its group's cylinder only).
- An ungrouped generic snap with a box or cylinder bounding (a window's pane, its frame's slot; a lid on its crate)
  is a ``shape:<bounding>:M`` or ``…:F`` point at its centre along its axis: male and female of one bounding shape
  and size at one point make a rigid connection, as a group's do.

Other snaps (tubes under plates, bar holes) make no point.

Collision shapes: the data has a part's bounding box only, which is the part itself only for plain rectangular parts. A part whose
LDraw name is a plain brick, plate, tile or technic brick (``Brick  2 x  4``, ``Technic Brick  1 x  4
with Holes``) gets that box less its studs (from y = 0 down) and less its technic holes; a studless
technic beam its bounding box less its holes. Every other generated part has no collision shape
(``collides`` false): it connects but is never reported in a collision.
"""

from __future__ import annotations

import functools
import gzip
import json
import re
from pathlib import Path

import numpy as np

Point = tuple  # (type, point, direction): the catalogue's Connector fields, built there

DATA = Path(__file__).with_name("data") / "ldcad_parts.tsv.gz"
SEGMENT = 20.0  # LDU: one stud pitch, the length of a technic hole
RING_RADIUS = 8.0  # LDU: a round part's bottom ring, which fits between four studs (their gap is 10√2 − 6)
STUD_LENGTH_IN = 4.0  # LDU: how far a stud reaches into an anti-stud (stud.dat's height)
SLIDE_MIN = 0.5  # LDU: a sliding bore shorter than a stud and this is one anti-stud point at its mouth
STUD_LENGTH = 6.0  # LDU: a round section of radius 6 this short is a stud (a pin's halves are 16 long)
BAR_RADIUS = 4.0  # LDU: a bar's (LDraw's bar primitives, the shadow library's radius-4 sections)
# LDU: how far a section's radius may be from a size to count as that size (a bar, a stud), and a clip's radius from a
# rod's for the clip to hold it. The shadow library states radii to 0.1 LDU (3.6, 6.25), sizes 1 LDU apart or more.
RADIUS_FIT = 0.5
BOXED = re.compile(r"^(brick|plate|tile|technic brick)\s+\d+\s+x\s+\d+(\s+x\s+\d+)?(\s+with (holes|groove))?$")
BEAM = re.compile(r"^technic beam\s+\d+$")


@functools.lru_cache(maxsize=1)
def _lines() -> dict[str, str]:
    """Part number -> its line's JSON text (parsed when the part is looked up: the file is 22 MB of JSON)."""
    with gzip.open(DATA, "rt", encoding="utf-8") as handle:
        text = handle.read()
    return dict(line.split("\t", 1) for line in text.splitlines()[1:] if "\t" in line)


def record(number: str) -> dict | None:
    """Part ``number``'s line of the data file (``{"n": name, "b": box, "s": snaps}``), or None."""
    line = _lines().get(number)
    return None if line is None else json.loads(line)


def group_type(group: str, gender: str) -> str:
    """The connector type of a grouped generic snap: ``group:<name>:M`` fits ``group:<name>:F``."""
    return f"group:{group}:{gender}"


def shape_type(bounding: str, gender: str) -> str:
    """The connector type of an ungrouped generic snap: ``shape:<bounding>:M`` fits ``shape:<bounding>:F`` of the
    same bounding shape and size (``box 20 54 2``)."""
    return f"shape:{bounding}:{gender}"


def pivot_type(group: str, gender: str) -> str:
    """The connector type of a grouped clip (``F``) or of a cylinder of the clip's group (``M``): ``pivot:<name>:F``
    fits ``pivot:<name>:M``, a hinge about their common axis."""
    return f"pivot:{group}:{gender}"


def numbers() -> frozenset[str]:
    return frozenset(_lines())


def _near(value: float, target: float) -> bool:
    return abs(value - target) < RADIUS_FIT


def _section_at(secs: list, t: float) -> tuple[str, float, float] | None:
    """(shape, radius, length) of the section at ``t`` LDU along the cylinder."""
    run = 0.0
    for shape, radius, length in secs:
        if run <= t <= run + length:
            return shape, radius, length
        run += length
    return None


def _is_stud(shape: str, radius: float, length: float) -> bool:
    return shape in ("R", "S") and _near(radius, 6) and length <= STUD_LENGTH


def _cylinder(gender: str, caps: str, slide: int, start, axis, secs) -> list[Point]:
    start, axis = np.asarray(start, float), np.asarray(axis, float)
    length = sum(s[2] for s in secs)
    male = gender == "M"
    shape0, radius0 = secs[0][0], secs[0][1]
    if male and not slide and caps != "none" and shape0 in ("R", "S") and _near(radius0, 6):
        return [("stud", _point(start), _point(axis))]  # a closed peg that does not slide: a (long) stud
    out = []
    if not male:  # a stud enters any open mouth of radius 6 (a dish's or a cone's bore, a headlight brick's back)
        last = secs[-1]
        if caps not in ("two", "a") and shape0 in ("R", "S") and _near(radius0, 6):
            out.append(_mouth(start, axis, secs[0][2], slide))
        if caps in ("none", "a") and last[0] in ("R", "S") and _near(last[1], 6):
            out.append(_mouth(start + axis * length, -axis, last[2], slide))
        if out and (not slide or length < SEGMENT / 2) and all(sec[0] != "A" for sec in secs):
            return out  # an anti-stud (a brick's, a tube's): its mouths only, no technic hole
    if male and caps != "two":  # a ring of radius 8 at an open end: it stands between four studs (a round 1 x 1)
        if secs[0][0] == "R" and _near(secs[0][1], RING_RADIUS):
            out.append(("ring", _point(start), _point(-axis)))
        if secs[-1][0] == "R" and _near(secs[-1][1], RING_RADIUS):
            out.append(("ring", _point(start + axis * length), _point(axis)))
    run = 0.0
    axle_from = None
    for k, (shape, radius, piece) in enumerate(secs):
        if male and _is_stud(shape, radius, piece):  # a stud (a half pin's short end too): its base
            out.append(("stud", _point(start + axis * run), _point(axis)))
        elif male and shape == "R" and _near(radius, BAR_RADIUS):  # a bar: a clip or a bar hole holds it anywhere
            out.append(("bar", _point(start + axis * run), _point(axis), round(float(piece), 3)))
        elif not male and shape == "R" and _near(radius, BAR_RADIUS):
            # a bar hole (a hollow stud, a holder's bore): a bar enters it at an open mouth
            if k == 0 and caps not in ("two", "a"):
                out.append(("barhole", _point(start + axis * run), _point(axis)))
            if k == len(secs) - 1 and caps in ("none", "a"):
                out.append(("barhole", _point(start + axis * (run + piece)), _point(axis)))
        if male and shape == "A" and axle_from is None:
            axle_from = run
        if male and shape != "A" and axle_from is not None:
            out.append(("axle", _point(start + axis * axle_from), _point(axis), round(run - axle_from, 3)))
            axle_from = None
        if not male and shape == "A":  # an axle hole: its centre, wherever it is along the bore (a round plate's)
            out.append(("axlehole", _point(start + axis * (run + piece / 2)), _point(axis), 0.0, (),
                        round(float(piece), 3)))
        run += piece
    if axle_from is not None:  # one run from where the axle shape starts to its end: it slides in its holes
        out.append(("axle", _point(start + axis * axle_from), _point(axis), round(run - axle_from, 3)))
    # 20 LDU slots from the start (a pin's or a hole's length); a shorter cylinder is one slot
    centres = [length / 2] if length < SEGMENT else [SEGMENT / 2 + k * SEGMENT
                                                      for k in range(int(length / SEGMENT + 0.25))]
    for t in centres:
        section = _section_at(secs, t)
        if section is None:
            continue
        shape, radius, piece = section
        if shape == "A":
            continue  # axles are runs and axle holes centres of their sections, above
        elif shape in ("R", "S") and _near(radius, 6) and not (male and _is_stud(shape, radius, piece)):
            kind = "pin" if male else "pinhole"
        else:
            continue
        out.append((kind, _point(start + axis * t), _point(axis)) if male else
                   (kind, _point(start + axis * t), _point(axis), 0.0, (), min(float(length), SEGMENT)))
    return out


def _mouth(mouth, inward, depth: float, slide: bool) -> Point:
    """The anti-stud of an open radius-6 mouth, pointing out of the part. A bore the stud slides in
    (``slide``: a dish's, a brick's through hole) holds its base anywhere from the mouth to where the stud's
    tip meets the end of the radius-6 section: a run from there out to the mouth."""
    reach = depth - STUD_LENGTH_IN if slide else 0.0
    if reach <= SLIDE_MIN:
        return ("antistud", _point(mouth), _point(-inward))
    return ("antistud", _point(mouth + inward * reach), _point(-inward), round(float(reach), 3))


def _point(v) -> tuple[float, float, float]:
    return tuple(round(float(x), 3) + 0.0 for x in v)


def _line(direction: tuple) -> tuple:
    """An axis without its sign (the first non-zero component made positive)."""
    lead = next((x for x in direction if abs(x) > 1e-9), 1.0)
    return tuple(x if lead > 0 else -x for x in direction)


def connectors(snaps: list) -> tuple[Point, ...]:
    """The connection points of a part's snaps (see the module docstring), each once."""
    out: list[Point] = []
    for snap in snaps:
        kind = snap[0]
        if kind == "cyl":
            out.extend(_cylinder(*snap[1:]))
            gender, _, _, start, axis, secs = snap[1:]
            length = round(float(sum(sec[2] for sec in secs)), 3)
            if length > 0:  # the cylinder as stated, for the fits the points above do not name
                out.append(("fit_m" if gender == "M" else "fit_f", _point(start), _point(axis), length,
                            tuple((str(shape), float(radius), float(piece)) for shape, radius, piece in secs)))
        elif kind == "clp":
            width, radius = round(float(snap[3]), 3), round(float(snap[4]), 3)
            out.append(("clip" if _near(radius, BAR_RADIUS) else "rodclip", _point(snap[1]), _point(snap[2]), 0.0,
                        (("R", radius, width),), width))
        elif kind == "fgr":  # a run of fingers along the hinge axis, centred on the snap's position
            centre, axis, length = np.asarray(snap[2], float), np.asarray(snap[3], float), float(snap[4])
            out.append(("finger", _point(centre - axis * length / 2), _point(axis), round(length, 3)))
        elif kind == "gen":
            out.append((group_type(snap[2], snap[1]), _point(snap[3]), _point(snap[4])))
        elif kind == "shp":
            out.append((shape_type(snap[2], snap[1]), _point(snap[3]), _point(snap[4])))
        elif kind == "pvt":
            out.append((pivot_type(snap[2], snap[1]), _point(snap[3]), _point(snap[4])))
        elif kind == "sph":
            out.append(("ball" if snap[1] == "M" else "socket", _point(snap[2]), (0.0, 0.0, 0.0)))
    unique, seen = [], set()
    for c in out:
        kind, point, direction = c[:3]
        key = (kind, point, direction if kind in ("stud", "antistud") else _line(direction), c[3:])
        if key not in seen:
            seen.add(key)
            unique.append(c)
    return tuple(unique)


def entry(number: str) -> dict | None:
    """The generated catalogue's part ``number`` (normalised) as the catalogue's PartShape fields, or None."""
    found = record(number)
    return None if found is None else fields(number, found)


def fields(number: str, entry: dict) -> dict:
    """A catalogue record (``{"n": name, "b": box, "s": snaps}``) as the catalogue's PartShape fields."""
    lo, hi = np.array(entry["b"][:3], float), np.array(entry["b"][3:], float)
    name = entry["n"]
    plain = " ".join(name.lower().split())
    conns = connectors(entry["s"])
    collides = True
    if BOXED.match(plain):
        lo[1] = max(lo[1], 0.0)  # the studs stand above y = 0 inside the anti-studs of the part on top
    elif not BEAM.match(plain):
        collides = False
    centre, size = (lo + hi) / 2, hi - lo
    return {"number": number, "name": name, "box_center": tuple(float(v) for v in centre),
            "box_size": tuple(float(v) for v in size), "connectors": conns, "collides": collides}
