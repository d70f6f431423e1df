"""Parts a model defines itself (unofficial parts embedded in an ``.mpd``), recognised from the files they draw.

LDCad gives a file the snap information of every file it draws (a type-1 line), placed by that line's matrix;
an unofficial part built of official primitives (``stud.dat``, ``stud4.dat``, ``connhole.dat``, ``axle.dat``)
and subparts therefore has their snaps. ``data/ldcad_subfiles.tsv.gz`` (written by
``scripts/ldcad_catalogue.py --subfiles``) holds the snaps of the official primitives and subparts, keyed by the
name a type-1 line gives them (``stud.dat``, ``s/3001s01.dat``, ``48/…``); the parts catalogue
(``ldcad_parts.tsv.gz``) those of the official parts. An embedded part's snaps are those of its type-1 lines,
found in that order: an official part, an official primitive or subpart (its data holds the shadow library's
own lines for it, which the embedded copy of an official subpart lacks), else an embedded sub-file, resolved
in turn. Its box is that of its drawn geometry (types 2–4) and of its sub-files' boxes. An embedded copy of an official
part or subpart, renamed with the model's prefix as the Official Model Repository names them (``8002 - 6643.dat``,
``s\\40190 - 93589s01.dat``: ``<model> - <official name>``), is that official file when what it draws lies inside the
official one's box (within ``COPY_BOX``: the same frame): it takes the official record, whose shadow lines
(a cable end's hole in 6643, 93589s01's underside) its primitives do not carry. The result is a record
of the parts catalogue's format (``{"n": name, "b": box, "s": snaps}``), so that the catalogue reads it as it
reads a generated part.
"""

from __future__ import annotations

import functools
import gzip
import json
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from plantsolve.solvers.rigidity import generated
from plantsolve.solvers.rigidity.ldraw_lines import drawn_points, placement

SUBFILES = Path(__file__).with_name("data") / "ldcad_subfiles.tsv.gz"
LIBRARY_FOLDERS = ("parts/", "p/")  # a packer writes the library folder into an embedded file's name
MAX_DEPTH = 32
# Snaps one embedded part may gather: a 48 x 48 base plate has 2 304 studs; sub-files placing sub-files ten times
# over eight levels would gather 10^8, so a part over this stays unknown rather than filling the memory.
MAX_SNAPS = 20_000
POSITION = {"cyl": 4, "clp": 1, "fgr": 2, "gen": 3, "shp": 3, "pvt": 3, "sph": 2}  # where a snap record holds its position
# ``<model> - <official name>``, in a subpart folder or not: an embedded copy of an official file as the OMR names it
COPY_NAME = re.compile(r"^(?P<folder>(?:s|48|8)[\\/])?[^\\/]+? - (?P<name>[^\\/]+\.dat)$", re.IGNORECASE)
# LDU: how far a copy's drawn points may lie outside the official part's box for the copy to be that part: a copy
# drawn with rounded coordinates or from another library version
COPY_BOX = 1.0

Lines = list[tuple[int, str]]


@functools.lru_cache(maxsize=1)
def _subfile_lines() -> dict[str, str]:
    with gzip.open(SUBFILES, "rt", encoding="utf-8") as handle:
        text = handle.read()
    return dict(line.split("\t", 1) for line in text.splitlines()[1:] if "\t" in line)


def _key(name: str) -> str:
    return name.strip().replace("\\", "/").lower()


def official(name: str) -> dict | None:
    """The catalogue record of an official part, primitive or subpart by the name a type-1 line gives it
    (parts first, as LDraw's search path has ``parts/`` before ``p/``); not to be changed by the caller."""
    return _official(_key(name))


@functools.lru_cache(maxsize=4096)
def _official(key: str) -> dict | None:
    for folder in LIBRARY_FOLDERS:
        key = key.removeprefix(folder)
    if key.endswith(".dat") and "/" not in key:
        part = generated.record(key[:-4])
        if part is not None:
            return part
    line = _subfile_lines().get(key)
    return None if line is None else json.loads(line)


def official_copy(name: str, drawn: np.ndarray | None) -> dict | None:
    """The record of the official part or subpart that embedded file ``name`` is a renamed copy of (:data:`COPY_NAME`),
    when its drawn points ``drawn`` lie inside the official one's box (within :data:`COPY_BOX`): drawn in the official
    part's frame, the drawn box no larger (primitives without snap data add no drawn points); else None."""
    found = COPY_NAME.match(name.strip())
    if found is None or drawn is None or not len(drawn):
        return None
    record = official((found["folder"] or "") + found["name"])
    if record is None:
        return None
    box = np.asarray(record["b"], float)
    inside = np.all(np.min(drawn, axis=0) >= box[:3] - COPY_BOX) and np.all(np.max(drawn, axis=0) <= box[3:] + COPY_BOX)
    return record if inside else None


def _placed(v, rot: np.ndarray, pos: np.ndarray) -> list[float]:
    return [round(float(x), 3) + 0.0 for x in rot @ np.asarray(v, float) + pos]


def _direction(v, rot: np.ndarray) -> tuple[list[float], float]:
    w = rot @ np.asarray(v, float)
    stretch = float(np.linalg.norm(w))
    unit = w / stretch if stretch > 0 else w
    return [round(float(x), 3) + 0.0 for x in unit], stretch


def transform(snap: list, rot: np.ndarray, pos: np.ndarray) -> list:
    """A snap record as the file placing its file with ``rot`` and ``pos`` sees it: a scaled placement stretches
    a cylinder's sections only when its eighth field says so (``axle.dat``), else the cylinder keeps its length
    about its stretched centre (as ``scripts/ldcad_catalogue.py`` places them)."""
    kind = snap[0]
    if kind == "cyl":
        gender, caps, slide, start, axis, secs = snap[1:7]
        scale = len(snap) > 7 and bool(snap[7])
        new_axis, stretch = _direction(axis, rot)
        length = sum(s[2] for s in secs)
        if abs(stretch - 1) > 1e-9 and scale:
            secs = [[s, r, round(piece * stretch, 3)] for s, r, piece in secs]
            new_start = _placed(start, rot, pos)
        elif abs(stretch - 1) > 1e-9:
            centre = rot @ (np.asarray(start, float) + np.asarray(axis, float) * length / 2) + pos
            new_start = [round(float(x), 3) + 0.0 for x in centre - np.asarray(new_axis) * length / 2]
        else:
            new_start = _placed(start, rot, pos)
        return ["cyl", gender, caps, slide, new_start, new_axis, secs, int(scale)]
    if kind == "clp":
        return ["clp", _placed(snap[1], rot, pos), _direction(snap[2], rot)[0], snap[3], snap[4]]
    if kind == "fgr":
        return ["fgr", snap[1], _placed(snap[2], rot, pos), _direction(snap[3], rot)[0], snap[4]]
    if kind in ("gen", "shp", "pvt"):  # gender, then a group or a bounding shape, then centre and axis
        return [kind, snap[1], snap[2], _placed(snap[3], rot, pos), _direction(snap[4], rot)[0]]
    return ["sph", snap[1], _placed(snap[2], rot, pos), snap[3]]


def _corners(box) -> np.ndarray:
    lo, hi = box[:3], box[3:]
    return np.array([[a, b, c] for a in (lo[0], hi[0]) for b in (lo[1], hi[1]) for c in (lo[2], hi[2])], float)


class _TooManySnaps(Exception):
    pass


class Resolver:
    """Resolves embedded sub-files (``files``: name -> numbered lines) through ``find`` (a type-1 line's file
    name -> the embedded file's name, or None)."""

    def __init__(self, files: dict[str, Lines], find: Callable[[str], str | None]):
        self.files, self.find = files, find
        self._done: dict[str, tuple[list, np.ndarray | None]] = {}

    def record(self, name: str) -> dict | None:
        """The catalogue record of embedded part ``name`` (its snaps from what it draws), or None without snaps
        or with more than :data:`MAX_SNAPS`."""
        try:
            snaps, points = self._walk(name, ())
        except _TooManySnaps:
            return None
        copied = official_copy(name, points)
        if copied is not None:
            return copied
        if not snaps:
            return None
        if points is None:  # nothing drawn but primitives without geometry: the snaps' own positions
            points = np.array([s[POSITION[s[0]]] for s in snaps], float)
        box = [round(float(v), 3) + 0.0 for v in (*points.min(axis=0), *points.max(axis=0))]
        return {"n": self._title(name), "b": box, "s": [s[:7] if s[0] == "cyl" else s for s in snaps]}

    def _title(self, name: str) -> str:
        for _, raw in self.files.get(name, ()):
            tokens = raw.split(None, 1)
            if tokens and tokens[0] == "0":
                return tokens[1].strip() if len(tokens) > 1 else ""
        return name

    def _walk(self, name: str, stack: tuple[str, ...]) -> tuple[list, np.ndarray | None]:
        if name in self._done:
            return self._done[name]
        if name in stack or len(stack) >= MAX_DEPTH:
            return [], None
        snaps: list = []
        points: list = []
        for _, raw in self.files.get(name, ()):
            tokens = raw.split()
            drawn = drawn_points(tokens)
            if drawn is not None:
                points.extend(drawn)
                continue
            placed = placement(raw, tokens)
            if placed is None:
                continue
            rot, pos, child = placed
            record = official(child)
            embedded = None if record is not None else self.find(child)
            if embedded is not None:
                record_of_embedded = official(embedded)
                if record_of_embedded is not None:
                    record = record_of_embedded
            if record is not None:
                child_snaps, box = record["s"], _corners(record["b"])
            elif embedded is not None:
                child_snaps, box = self._walk(embedded, (*stack, name))
                copied = official_copy(embedded, box)
                if copied is not None:
                    child_snaps, box = copied["s"], _corners(copied["b"])
            else:
                continue
            if len(snaps) + len(child_snaps) > MAX_SNAPS:
                raise _TooManySnaps
            snaps.extend(transform(s, rot, pos) for s in child_snaps)
            if box is not None and len(box):
                points.extend(np.asarray(box) @ rot.T + pos)
        box = None
        if points:
            drawn = np.array(points)
            box = _corners([*drawn.min(axis=0), *drawn.max(axis=0)])
        result = (snaps, box)
        self._done[name] = result
        return result
