"""Derive the rigidity kind's parts catalogue from the LDCad shadow library and the LDraw parts library.

Usage: ``python scripts/ldcad_catalogue.py --ldraw DIR --shadow DIR --out FILE.tsv.gz``

``--ldraw`` is an LDraw.org parts library (``parts/``, ``p/``; CC BY 4.0), ``--shadow`` a checkout of
the LDCad shadow library (``parts/``, ``p/``; CC BY-SA 4.0, by Roland Melkert and contributors). The
shadow library holds ``0 !LDCAD SNAP_*`` meta lines for a part or primitive under the same file name
as the LDraw file they belong to; LDCad appends them to that file when it loads it. A part's snap
information is therefore its own shadow lines plus, through every type-1 line of its LDraw file, the
snap information of the files it draws (``stud.dat``, ``connhole.dat``, subparts …), placed by that
line's matrix, unless the part's shadow clears the inherited information (``SNAP_CLEAR``, all or by
``id``). ``SNAP_INCL`` places another file's snap information (with ``pos``, ``ori`` and ``grid``).

What is read of each meta line (LDCad's meta syntax, ``[key=value]`` pairs):

- ``SNAP_CYL``: ``gender`` (M/F), ``caps``, ``secs`` (sections ``shape radius length``; shape R round,
  A axle, S square, ``L_``/``_L`` chamfers), ``center``, ``slide``, ``pos``, ``ori``, ``grid``,
  ``scale``. The cylinder's axis is the local −y of ``ori``: it runs from ``pos`` along −y for the
  sum of its section lengths (or is centred on ``pos`` with ``center=true``).
- ``SNAP_CLP`` (a clip: ``radius`` of the rod it grips, default 4, a bar's; ``length``, ``center``; with a ``group``
  a clip made for the cylinders of that group only, a pivot, and a ``SNAP_CYL`` of a group some clip names is also
  that group's pivot at its middle: a universal joint's end 3712 on an arm of its centre 3326b),
  ``SNAP_FGR`` (hinge fingers: ``genderOfs``, ``seq`` of finger widths, ``radius``; centred on ``pos``, or
  starting there along the local −y with ``center=false``), ``SNAP_GEN`` with ``bounding=sph`` (a ball joint
  when male, its socket when female), with a ``group`` (a fit made only within the group: a tyre on its rim),
  or an ungrouped ``box`` or ``cyl`` bounding (a fit of that shape and size only: a window's pane in its frame, a
  lid on its crate).

The output is gzip text: a first line of JSON ``{"source": …, "units": …}``, then one line per part,
``number<TAB>{"n": name, "b": [xmin, ymin, zmin, xmax, ymax, zmax], "s": [snap, …]}`` (JSON after the
tab, so a reader parses only the parts it looks up), in LDraw units in the part's frame, with ``b``
the bounding box of the part's drawn geometry and each snap one of

- ``["cyl", gender, caps, slide, start, axis, [[shape, radius, length], …]]``: sections from ``start``
  along the unit vector ``axis``;
- ``["clp", centre, axis, length, radius]`` (``radius``: the rod the clip grips);
  ``["fgr", gender, centre, axis, length]``;
- ``["sph", gender, centre, radius]``; ``["gen", gender, group, centre, axis]``; ``["shp", gender, bounding,
  centre, axis]`` (``bounding`` as ``box 20 54 2``: an ungrouped generic snap); ``["pvt", gender, group, centre,
  axis]`` (a grouped clip, ``F``, or the middle of a cylinder of its group, ``M``).

The open stud tube primitives (``stud4.dat``, ``stud4a.dat``, ``stud4f*.dat``, ``stud4h.dat``) get the
anti-stud the shadow library states for ``stud4o.dat`` when their own shadow states none (see ``TUBE``), and a
wheel holding pin primitive without shadow lines that does not draw ``wpin.dat`` (``wpin4.dat``) gets
``wpin.dat``'s pin (see ``WHEEL_PIN``). The open stud without base edges (``stud2a.dat``) gets the hole
(radius 4, 4 deep) the shadow library states for ``stud2.dat``, dropped in a file whose other snaps hold a female
radius-4 cylinder on the same axis over it (see ``OPEN_STUD``). The car steering wheel's hub (``3828.dat``), which the
shadow library states male, is read as the female bore its stand's column enters (see ``HUB_BORE``), and the solid
wheel 4288's bore, which the shadow library states as an axle hole from its mouth, is read as drawn: 3 LDU round
before the axle hole, the mouth a stud enters (see ``ROUND_MOUTH``). A primitive LDraw draws a second time without its
edge lines (``stud3a.dat``, ``studa.dat``, ``stud16a.dat``, ``hipstuda.dat``), which the shadow library leaves without
lines, states its edged twin's snaps, dropped in a file whose other snaps restate them (see ``EDGELESS``).

Parts whose snap information is empty are left out (the solver reports them as unknown). How snaps
become connection points and joints is the catalogue's business (plantsolve/solvers/rigidity/generated.py).

``--subfiles FILE.tsv.gz`` writes the same lines for the library's other files whose snap information is not
empty: primitives (``p/``, keyed as a part's type-1 line names them: ``stud.dat``, ``48/…``) and subparts
(``s/3001s01.dat``), keyed with ``.dat`` so that no key is a part number. A model's own (unofficial) part
draws them; the solver's reader resolves such a part down to them (plantsolve/solvers/rigidity/embedded.py).
A cylinder there carries an eighth field, 1 when a scaled placement stretches its sections (``scale``).

``--stickers FILE.txt.gz`` writes the numbers of the library's stickers (the header line, then one number a line):
the parts whose LDraw category is ``Sticker``, stated by a ``0 !CATEGORY`` line or, without one, the first word of the
title after LDraw's marks (``~`` moved or alias, ``_``, ``|``, ``=``). A sticker has no snap information (it is
drawn flat on a face): the solver leaves it out of the analysis rather than counting it unknown. ``Sticker
Shortcut`` (a part with its sticker applied) is another category: such a part has its own snaps.
"""

from __future__ import annotations

import argparse
import gzip
import json
import re
import sys
from pathlib import Path

import numpy as np

from plantsolve.solvers.rigidity.ldraw_lines import drawn_points, placement
from plantsolve.solvers.rigidity.stickers import STICKER, category

META = re.compile(r"\[([A-Za-z]+)=([^\]]*)\]")
# The tubes under bricks and plates (LDraw's open stud tube primitives) grip a stud placed between four studs.
# The shadow library states this only for stud4o.dat and stud4od.dat (LDCad leaves it out of the others so that
# its editor does not offer those placements while a part is dragged); a solver that checks a model as built
# needs it for all of them: the same line, an anti-stud open at the tube's mouth (local y = -4, scaled with the
# tube's height).
TUBE = re.compile(r"^stud4(a|f\d[nsw]|h|o|od)?\.dat$")
TUBE_SNAP = "0 !LDCAD SNAP_CYL [ID=aStud] [gender=F] [caps=A] [secs=R 6 4] [scale=YOnly]"
# The wheel holding pin primitives draw one pin (radius 4, from y = 0 to y = -12, as wpin.dat); the shadow library
# states it for wpin.dat (and wpin2.dat by SNAP_INCL), wpin2a.dat and wpin3.dat draw wpin.dat, but wpin4.dat (the
# pull-back motor's, 2024) draws the pin itself and has no shadow: the axle of 10039 held no wheel. A wheel pin
# primitive without shadow lines that does not draw wpin.dat gets wpin.dat's snap.
WHEEL_PIN = re.compile(r"^wpin\d+a?\.dat$")
WHEEL_PIN_SNAP = "0 !LDCAD SNAP_INCL [ref=wpin.dat]"
# The open stud without base edges (stud2a.dat) is open: a bar (radius 4) goes into it, as 15395's stud takes the bar
# 30374 in set 21309. The shadow library states the hole for stud2.dat (radius 4, 4 deep from the stud's top) but not
# for stud2a.dat, leaving it to the parts because in many of them the hole runs deeper than the stud; most parts do
# not add it. stud2a.dat gets stud2.dat's hole line (same id, so a part that clears the stud by id clears the hole
# too), and a file drops that added hole where its other snaps already hold a female round radius-4 cylinder on the
# same axis that overlaps it (the part stated its own, deeper hole).
OPEN_STUD = "stud2a.dat"
OPEN_STUD_HOLE = "0 !LDCAD SNAP_CYL [ID=studO] [gender=F] [caps=one] [secs=R 4 4] [pos=0 -4 0] [ori=1 0 0 0 -1 0 0 0 -1]"
# The car steering wheel 3828 is pushed onto its stand's column (3829a states the column: a male round radius-4
# cylinder 6 long; 3829c01 draws both parts, the two cylinders on one axis from one point). The shadow library states
# the wheel's hub as a male cylinder as well, so no snap of the data puts a wheel on a column (1682-1 and 6544-1 float
# their wheels). The hub is the bore the column enters: its cylinder is read as female.
HUB_BORE = "3828.dat"
# The solid rubber wheel 4288 is pushed onto the wheel centre 20.dat (122c01's, 3137c01's: a radius-10 hub with a stud
# on its outer face): the hub sits in the wheel's recess and the stud in the round mouth of its bore, which 4288 draws
# radius 6 for 3 LDU before the axle hole starts. The shadow library states the whole bore as an axle hole (20 LDU from
# the mouth), into which no stud goes, so set 6831's four wheels floated. The bore is read as drawn: a round section
# 3 LDU long, then the axle hole.
ROUND_MOUTH = {"4288.dat": "0 !LDCAD SNAP_CYL [id=axleHole] [gender=F] [caps=none] [secs=R 6 3 A 6 17] [slide=true] "
                           "[pos=0 0 3] [ori=1 0 0 0 0 -1 0 1 0]"}
# LDraw draws some primitives twice, once without their edge lines (stud3a.dat "Stud Tube Solid without Base Edges" for
# stud3.dat, studa.dat for stud.dat, stud16a.dat, hipstuda.dat): the same solid. The shadow library states the snaps of
# the edged one only, so the posts under the Technic bricks 1 x N (3700-3703, 2730), the 45-degree slopes 2 x 1 (3040)
# and some 90 other parts that draw stud3a.dat had none. Such a primitive, named as its twin with an ``a`` and titled as
# its twin "without ...", that the shadow library leaves without lines and that inherits none, states its twin's snaps.
EDGELESS = re.compile(r"^([^/]+)a\.dat$")
SNAP_KINDS = ("SNAP_CYL", "SNAP_CLP", "SNAP_FGR", "SNAP_GEN", "SNAP_INCL", "SNAP_CLEAR")


class Library:
    """An LDraw-style folder tree (``parts/``, ``parts/s/``, ``p/``, ``p/48/``) looked up by file name."""

    def __init__(self, root: Path):
        self.files: dict[str, Path] = {}
        for folder in ("p", "parts"):  # parts/ wins over p/ for a name in both, as LDraw's search order has it
            base = root / folder
            if not base.is_dir():
                continue
            for path in base.rglob("*"):
                if path.is_file():
                    rel = path.relative_to(base).as_posix().lower()
                    self.files[rel] = path

    def find(self, name: str) -> Path | None:
        key = name.strip().replace("\\", "/").lower()
        return self.files.get(key)

    def text(self, name: str) -> str | None:
        path = self.find(name)
        return None if path is None else path.read_text(encoding="utf-8", errors="replace")


def _floats(value: str) -> list[float]:
    return [float(v) for v in value.split()]


def _grid_offsets(value: str | None) -> list[np.ndarray]:
    """The offsets (in the snap's local frame) of a ``grid=[C] nx [C] nz sx sz`` or 3-D ``[C] nx [C] ny [C] nz
    sx sy sz`` repetition; ``C`` centres that axis' run on the position."""
    if not value:
        return [np.zeros(3)]
    tokens = value.split()
    counts, centred, i = [], [], 0
    numbers = [t for t in tokens if t.upper() != "C"]
    dims = 2 if len(numbers) == 4 else 3
    while len(counts) < dims and i < len(tokens):
        if tokens[i].upper() == "C":
            centred.append(True)
            counts.append(int(float(tokens[i + 1])))
            i += 2
        else:
            centred.append(False)
            counts.append(int(float(tokens[i])))
            i += 1
    steps = [float(t) for t in tokens[i:i + dims]]
    axes = (0, 2) if dims == 2 else (0, 1, 2)
    runs = []
    for n, c, s in zip(counts, centred, steps):
        runs.append([(k - (n - 1) / 2 if c else k) * s for k in range(max(n, 1))])
    out = []
    for combo in np.array(np.meshgrid(*runs, indexing="ij")).reshape(len(runs), -1).T:
        offset = np.zeros(3)
        offset[list(axes)] = combo
        out.append(offset)
    return out


def _frame(params: dict) -> tuple[np.ndarray, np.ndarray]:
    pos = np.array(_floats(params["pos"])) if "pos" in params else np.zeros(3)
    ori = np.array(_floats(params["ori"])).reshape(3, 3) if "ori" in params else np.eye(3)
    return pos, ori


def _sections(value: str) -> list[list]:
    tokens = value.split()
    out = []
    for k in range(0, len(tokens) - 2, 3):
        out.append([tokens[k], float(tokens[k + 1]), float(tokens[k + 2])])
    return out


def _own_snaps(line: str, params: dict, place, pivot_groups: frozenset = frozenset()) -> list[dict]:
    """The snaps of one SNAP_CYL/CLP/FGR/GEN line in the file's frame (one per grid position); a grouped cylinder of
    one of ``pivot_groups`` (the groups a clip states) is also that group's pivot at its middle."""
    kind = line.split()[2].upper()
    pos, ori = _frame(params)
    snap_id = (params.get("id") or params.get("ID") or "").lower()
    out = []
    for offset in _grid_offsets(params.get("grid")):
        origin = pos + ori @ offset
        down = ori @ np.array([0.0, -1.0, 0.0])  # the snap's axis: local −y
        if kind == "SNAP_CYL":
            secs = _sections(params.get("secs", ""))
            if not secs:
                continue
            length = sum(s[2] for s in secs)
            start = origin - down * length / 2 if params.get("center", "").lower() == "true" else origin
            out.append({"id": snap_id, "kind": "cyl", "gender": params.get("gender", "M").upper()[:1],
                        "caps": params.get("caps", "one").lower(), "slide": params.get("slide", "").lower() == "true",
                        "start": start, "axis": down, "secs": secs,
                        "scale": params.get("scale", "").lower() in ("yonly", "yandr")})
            if params.get("group", "").lower() in pivot_groups:
                out.append({"id": snap_id, "kind": "pvt", "gender": "M", "group": params["group"].lower(),
                            "centre": start + down * length / 2, "axis": down})
        elif kind == "SNAP_CLP" and params.get("group"):  # a clip made for its group's cylinder only (3712 on 3326b)
            length = float(params.get("length", 8))
            centre = origin if params.get("center", "").lower() == "true" else origin + down * length / 2
            out.append({"id": snap_id, "kind": "pvt", "gender": "F", "group": params["group"].lower(),
                        "centre": centre, "axis": down})
        elif kind == "SNAP_CLP":
            length = float(params.get("length", 8))
            centre = origin if params.get("center", "").lower() == "true" else origin + down * length / 2
            out.append({"id": snap_id, "kind": "clp", "centre": centre, "axis": down, "length": length,
                        "radius": float(params.get("radius", 4))})
        elif kind == "SNAP_FGR":
            seq = _floats(params.get("seq", "0"))
            # centred on pos unless center=false, when the run starts at pos (4715's two 11-LDU runs from x = -19
            # and x = 8: symmetric about the part's centre only so)
            centre = origin + down * sum(seq) / 2 if params.get("center", "").lower() == "false" else origin
            out.append({"id": snap_id, "kind": "fgr", "gender": params.get("genderOfs", "M").upper()[:1],
                        "centre": centre, "axis": down, "length": sum(seq)})
        elif kind == "SNAP_GEN":
            bounding = params.get("bounding", "").split()
            if bounding[:1] == ["sph"] and len(bounding) >= 2:
                out.append({"id": snap_id, "kind": "sph", "gender": params.get("gender", "M").upper()[:1],
                            "centre": origin, "radius": float(bounding[1])})
            elif params.get("group"):  # a fit only parts of one group make (a tyre on its rim, a drawer)
                out.append({"id": snap_id, "kind": "gen", "gender": params.get("gender", "M").upper()[:1],
                            "group": params["group"].lower(), "centre": origin, "axis": down})
            elif bounding[:1] in (["box"], ["cyl"]) and len(bounding) >= 3:  # a fit of one shape and size (a pane)
                out.append({"id": snap_id, "kind": "shp", "gender": params.get("gender", "M").upper()[:1],
                            "shape": " ".join([bounding[0]] + [f"{float(v):g}" for v in bounding[1:]]),
                            "centre": origin, "axis": down})
    return [place(s) for s in out]


def transform(snap: dict, rot: np.ndarray, pos: np.ndarray) -> dict:
    """``snap`` seen from a file that places its file with matrix ``rot`` at ``pos`` (a scaled placement
    stretches a cylinder's sections only when the snap allows it, as ``axle.dat``'s ``scale=YOnly``)."""
    out = dict(snap)
    for key in ("start", "centre"):
        if key in snap:
            out[key] = rot @ snap[key] + pos
    if "axis" in snap:
        v = rot @ snap["axis"]
        stretch = float(np.linalg.norm(v))
        out["axis"] = v / stretch if stretch > 0 else v
        if snap["kind"] == "cyl" and snap.get("scale") and abs(stretch - 1) > 1e-9:
            out["secs"] = [[s, r, length * stretch] for s, r, length in snap["secs"]]
        if snap["kind"] == "cyl" and not snap.get("scale") and abs(stretch - 1) > 1e-9:
            centre = snap["start"] + snap["axis"] * sum(s[2] for s in snap["secs"]) / 2
            out["start"] = rot @ centre + pos - out["axis"] * sum(s[2] for s in snap["secs"]) / 2
    return out


def _without_restated(snaps: list[dict]) -> list[dict]:
    """``snaps`` less the cylinders added where the shadow library states none (the open stud's hole,
    ``OPEN_STUD_HOLE``; an edgeless primitive's twin's snaps, ``EDGELESS``) that a stated cylinder of the same gender,
    with a section of the added one's shape and radius, overlaps on the same axis: the part stated its own."""
    if not any(s.get("added") for s in snaps):
        return snaps
    stated = [s for s in snaps if s["kind"] == "cyl" and not s.get("added")]
    return [s for s in snaps if not (s.get("added") and s["kind"] == "cyl" and any(
        t["gender"] == s["gender"] and _same_section(s, t) and _overlap(s, t) for t in stated))]


def _same_section(added: dict, stated: dict) -> bool:
    shape, radius, _ = added["secs"][0]
    return any(t.upper() == shape.upper() and abs(r - radius) < 1e-6 for t, r, _ in stated["secs"])


def _overlap(a: dict, b: dict, tol: float = 0.01) -> bool:
    """Whether cylinders ``a`` and ``b`` lie on one axis and their spans along it overlap."""
    if abs(abs(float(a["axis"] @ b["axis"])) - 1) > 1e-6:
        return False
    offset = b["start"] - a["start"]
    along = float(offset @ a["axis"])
    if np.linalg.norm(offset - along * a["axis"]) > tol:
        return False
    length_a = sum(s[2] for s in a["secs"])
    b_end = along + float(b["axis"] @ a["axis"]) * sum(s[2] for s in b["secs"])
    return min(along, b_end) < length_a - tol and max(along, b_end) > tol


def pivot_groups(shadow: Library) -> frozenset:
    """The groups that a clip (``SNAP_CLP``) of the shadow library names, lower case."""
    found = set()
    for path in shadow.files.values():
        for raw in path.read_text(encoding="utf-8", errors="replace").splitlines():
            if "SNAP_CLP" in raw.split()[2:3]:
                found.update(v.lower() for k, v in META.findall(raw) if k.lower() == "group")
    return frozenset(found)


class Deriver:
    def __init__(self, ldraw: Library, shadow: Library):
        self.ldraw, self.shadow = ldraw, shadow
        self._snaps: dict[str, list[dict]] = {}
        self._boxes: dict[str, np.ndarray | None] = {}
        self._stack: set[str] = set()
        self.pivot_groups = pivot_groups(shadow)

    def snaps(self, name: str) -> list[dict]:
        key = name.strip().replace("\\", "/").lower()
        if key in self._snaps:
            return self._snaps[key]
        if key in self._stack:
            return []
        self._stack.add(key)
        own, clear_all, clear_ids = [], False, set()
        shadow = self.shadow.text(key) or ""
        unstated = not any(line.split()[:2] == ["0", "!LDCAD"] for line in shadow.splitlines())
        if TUBE.match(key) and unstated:
            shadow = TUBE_SNAP
        elif WHEEL_PIN.match(key) and unstated and all(child.lower() != "wpin.dat"
                                                        for _, _, child in self._children(key)):
            shadow = WHEEL_PIN_SNAP
        twin = self._edged_twin(key) if unstated else None
        if twin:
            shadow = f"0 !LDCAD SNAP_INCL [ref={twin}]"
        if key == HUB_BORE:
            shadow = shadow.replace("[gender=M]", "[gender=F]")
        if key in ROUND_MOUTH:
            shadow = ROUND_MOUTH[key]
        added_hole = key == OPEN_STUD and not any("gender=F" in line for line in shadow.splitlines())
        if added_hole:
            shadow += "\n" + OPEN_STUD_HOLE
        for raw in shadow.splitlines():
            tokens = raw.split()
            if len(tokens) < 3 or tokens[0] != "0" or tokens[1] != "!LDCAD" or tokens[2] not in SNAP_KINDS:
                continue
            params = dict(META.findall(raw))
            if tokens[2] == "SNAP_CLEAR":
                snap_id = (params.get("id") or params.get("ID") or "").lower()
                if snap_id:
                    clear_ids.add(snap_id)
                else:
                    clear_all = True
            elif tokens[2] == "SNAP_INCL":
                pos, ori = _frame(params)
                for offset in _grid_offsets(params.get("grid")):
                    own.extend(transform(s, ori, pos + ori @ offset) for s in self.snaps(params.get("ref", "")))
            else:
                own.extend(_own_snaps(raw, params, lambda s: s, self.pivot_groups))
        if added_hole:
            own = [dict(s, added=True) if s["kind"] == "cyl" and s["gender"] == "F" else s for s in own]
        if twin:
            own = [dict(s, added=True) for s in own]
        inherited = []
        if not clear_all:
            for rot, pos, child in self._children(key):
                inherited.extend(transform(s, rot, pos) for s in self.snaps(child) if s["id"] not in clear_ids)
        self._stack.discard(key)
        self._snaps[key] = _without_restated(own + inherited)
        return self._snaps[key]

    def _edged_twin(self, key: str) -> str | None:
        """The primitive whose snaps ``key`` states (``EDGELESS``), or None."""
        named = EDGELESS.match(key)
        if not named or not (text := self.ldraw.text(key)):
            return None
        twin = f"{named.group(1)}.dat"
        twin_title, title = _title(self.ldraw.text(twin) or ""), _title(text)
        stated = any(line.split()[:2] == ["0", "!LDCAD"] for line in (self.shadow.text(twin) or "").splitlines())
        if not (stated and twin_title and title.startswith(f"{twin_title} without ")):
            return None
        return None if any(self.snaps(child) for _, _, child in self._children(key)) else twin

    def _children(self, key: str):
        for raw in (self.ldraw.text(key) or "").splitlines():
            placed = placement(raw, raw.split())
            if placed is not None:
                yield placed

    def box(self, name: str) -> np.ndarray | None:
        """The bounding box (2 × 3: lower, upper corner) of the file's drawn geometry in its frame."""
        key = name.strip().replace("\\", "/").lower()
        if key in self._boxes:
            return self._boxes[key]
        self._boxes[key] = None  # a file that includes itself adds nothing
        points = []
        for raw in (self.ldraw.text(key) or "").splitlines():
            drawn = drawn_points(raw.split())
            if drawn is not None:
                points.extend(drawn)
        for rot, pos, child in self._children(key):
            sub = self.box(child)
            if sub is not None:
                corners = np.array([[sub[i, 0], sub[j, 1], sub[k, 2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
                points.extend(corners @ rot.T + pos)
        self._boxes[key] = np.array([np.min(points, axis=0), np.max(points, axis=0)]) if points else None
        return self._boxes[key]


def _r(v) -> list[float]:
    return [round(float(x), 3) + 0.0 for x in v]


def _record(snap: dict, scale: bool = False) -> list:
    if snap["kind"] == "cyl":
        out = ["cyl", snap["gender"], snap["caps"], int(snap["slide"]), _r(snap["start"]), _r(snap["axis"]),
               [[s, round(r, 3), round(length, 3)] for s, r, length in snap["secs"]]]
        return out + [int(bool(snap.get("scale")))] if scale else out
    if snap["kind"] == "clp":
        return ["clp", _r(snap["centre"]), _r(snap["axis"]), round(snap["length"], 3), round(snap["radius"], 3)]
    if snap["kind"] == "fgr":
        return ["fgr", snap["gender"], _r(snap["centre"]), _r(snap["axis"]), round(snap["length"], 3)]
    if snap["kind"] == "gen":
        return ["gen", snap["gender"], snap["group"], _r(snap["centre"]), _r(snap["axis"])]
    if snap["kind"] == "shp":
        return ["shp", snap["gender"], snap["shape"], _r(snap["centre"]), _r(snap["axis"])]
    if snap["kind"] == "pvt":
        return ["pvt", snap["gender"], snap["group"], _r(snap["centre"]), _r(snap["axis"])]
    return ["sph", snap["gender"], _r(snap["centre"]), round(snap["radius"], 3)]


def _title(text: str) -> str:
    for raw in text.splitlines():
        tokens = raw.split(None, 1)
        if tokens and tokens[0] == "0":
            return tokens[1].strip() if len(tokens) > 1 else ""
    return ""


def sticker_numbers(ldraw_root: Path) -> list[str]:
    """The numbers of the parts (``parts/*.dat``) whose category is ``Sticker``, sorted."""
    ldraw = Library(ldraw_root)
    return sorted(rel[:-4] for rel in ldraw.files if rel.endswith(".dat") and "/" not in rel
                  and ldraw.find(rel).parent.name == "parts" and category(ldraw.text(rel).splitlines()) == STICKER)


def derive(ldraw_root: Path, shadow_root: Path, subfiles: dict | None = None) -> dict:
    """The parts with snap information (keyed by number); the primitives and subparts with snap information go
    into ``subfiles`` (keyed by file name) when it is given."""
    ldraw, shadow = Library(ldraw_root), Library(shadow_root)
    deriver = Deriver(ldraw, shadow)
    parts = {}
    for rel in sorted(k for k in ldraw.files if k.endswith(".dat")):
        is_part = "/" not in rel and ldraw.find(rel).parent.name == "parts"
        if not is_part and subfiles is None:
            continue
        snaps = deriver.snaps(rel)
        box = deriver.box(rel)
        if not snaps or box is None:
            continue
        record = {"n": _title(ldraw.text(rel)), "b": _r(box.reshape(-1)),
                  "s": [_record(s, scale=not is_part) for s in snaps]}
        if is_part:
            parts[rel[:-4]] = record
        else:
            subfiles[rel] = record
    return parts


def _write(path: Path, header: dict, records: dict) -> None:
    _write_text(path, write_lines(header, records))


def _write_text(path: Path, text: str) -> None:
    data = text.encode()
    with open(path, "wb") as raw, gzip.GzipFile(filename="", fileobj=raw, mode="wb", compresslevel=9, mtime=0) as handle:
        handle.write(data)  # no name, mtime 0: the same libraries give the same bytes


def write_lines(header: dict, parts: dict) -> str:
    lines = [json.dumps(header, sort_keys=True)]
    lines.extend(f"{number}\t{json.dumps(parts[number], separators=(',', ':'), sort_keys=True)}" for number in sorted(parts))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--ldraw", type=Path, required=True, help="LDraw.org parts library folder (parts/, p/)")
    parser.add_argument("--shadow", type=Path, help="LDCad shadow library folder (parts/, p/); needed with --out")
    parser.add_argument("--out", type=Path, help="output .tsv.gz of the parts with snaps")
    parser.add_argument("--subfiles", type=Path, help="output .tsv.gz of the primitives and subparts with snaps")
    parser.add_argument("--stickers", type=Path, help="output .txt.gz of the numbers of the library's stickers")
    parser.add_argument("--source", default="", help="versions of the two libraries, recorded in the file")
    args = parser.parse_args(argv)
    header = {"source": args.source, "units": "LDU, part frame, -y up"}
    if args.stickers:
        numbers = sticker_numbers(args.ldraw)
        _write_text(args.stickers, "\n".join([json.dumps({"source": args.source}, sort_keys=True), *numbers]) + "\n")
        print(f"{len(numbers)} stickers written to {args.stickers}", file=sys.stderr)
    if args.out is None:
        return 0
    if args.shadow is None:
        parser.error("--out needs --shadow")
    subfiles: dict = {}
    parts = derive(args.ldraw, args.shadow, subfiles)
    _write(args.out, header, parts)
    print(f"{len(parts)} parts with snap information written to {args.out}", file=sys.stderr)
    if args.subfiles:
        _write(args.subfiles, header, subfiles)
        print(f"{len(subfiles)} primitives and subparts with snap information written to {args.subfiles}",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
