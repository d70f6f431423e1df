"""PCF (ISOGEN Piping Component File) in: a text read item by item, never refused for one item.

Reading (:func:`read_document`): header records (``ISOGEN-FILES``, ``UNITS-*``,
``PIPELINE-REFERENCE`` and its records, dates, revision, specs) and the MATERIALS section
(``ITEM-CODE``, ``DESCRIPTION``, ``MATERIAL-IDENTIFIER`` ...) are known records; every other
top-level block is an item. Item ids are what the exporting tool wrote: the item's
``COMPONENT-IDENTIFIER``, else its ``UCI``, else its ``ITEM-CODE`` (each only where its value
is unique in the file), else ``<KEYWORD>-<n>`` with n the item's ordinal among the items; that
positional id is always accepted as an alias (``fixed_components``) and listed in the report.

Interpreting (:func:`interpret_pcf`): port directions come from the geometry (centre to end
point for elbows, tees, crosses, angle valves and olets; along the end-point axis for pipes
and inline items; eccentric items take the axis of the pipes they join, since their end
points are offset by the flat side). What the geometry does not give is taken from the
neighbours: single-ended items (CAP, FLANGE-BLIND) and 180 degree return bends whose
CENTRE-POINT lies on their chord take the reversed direction of the ports they touch (a
return bend's two ports are parallel, normal to its chord); an OLET without a usable
CENTRE-POINT points away from the axis of the pipe it sits on. Zero-length items (a WELD,
a GASKET without thickness, a zero-length PIPE) are connection points: their neighbours are
connected directly and they are written where that connection ends up (a PIPE has a length: one without is
named in a warning, an END-POINT typed twice). Bores that disagree where they should agree (an item's two
END-POINTs, reducers excepted; two connected end points) are named with their lines. Facing flange faces a
gasket's thickness apart are joined by a rigid spacer, so the gap is kept, not closed. An
item that still cannot be interpreted is kept verbatim and held fixed (or, without readable
points, left out of the solve), and listed in the report with the reason. The interpreted
model must then pass the rules every request passes (:mod:`.pcf_model_check`): an item failing
one is held fixed with its directions from its neighbours (left out if it still fails), and a
closed ring of bends touching nothing else (a handwheel) is left out. Connected ports printed
with the same coordinates are one point. The file is refused only when no item is left.

Tolerances (:func:`pcf_tolerances`): the exporting tool named in the file (AVEVA E3D/PDMS,
Revit, AutoCAD Plant 3D) sets the profile; the coordinates' printed precision sets the
rounding floor: differences a rounding of the printed digits can cause are not errors.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.schemas.alignment import AlignmentOptions, AlignmentRequest
from plantsolve.schemas.common import MAX_COORDINATE
from plantsolve.solvers.alignment.pcf_bore_sizes import other_system_bores
from plantsolve.solvers.alignment.pcf_catalogue import print_quantum, snap_catalogue
from plantsolve.solvers.alignment.pcf_model_check import TURNING, closed_rings, failing_components
from plantsolve.solvers.alignment.plausibility import RADIUS_JUMP, radius_jumps
from plantsolve.solvers.base import FieldError, InputRejected, reject, validated

POINT_KEYS = ("END-POINT", "CENTRE-POINT", "BRANCH1-POINT", "BRANCH2-POINT", "BRANCH3-POINT")
EXTRA_KEYS = ("CO-ORDS",)  # support / instrument locations: they follow the item they sit on
TYPE_OF = {
    "ELBOW": "elbow", "BEND": "bend", "TEE": "tee", "TEE-SET-ON": "tee", "TEE-STUB": "tee", "CROSS": "cross",
    "REDUCER-CONCENTRIC": "reducer", "REDUCER-ECCENTRIC": "reducer", "VALVE": "valve", "VALVE-ANGLE": "valve",
    "VALVE-3WAY": "valve", "VALVE-MULTIWAY": "valve", "FLANGE": "flange", "FLANGE-BLIND": "flange",
    "FLANGE-REDUCING-CONCENTRIC": "flange", "FLANGE-REDUCING-ECCENTRIC": "flange", "CAP": "cap", "OLET": "olet",
}
# Top-level records of the header and of the MATERIALS section: never items.
HEADER_RECORDS = {
    "ISOGEN-FILES", "PIPELINE-REFERENCE", "PROJECT-IDENTIFIER", "AREA", "DATE-DMY", "DATE-MDY", "DATE-YMD",
    "REVISION", "SPOOL-IDENTIFIER", "SPOOL-PREFIX", "SHEET-REFERENCE", "PIPING-SPEC", "INSULATION-SPEC",
    "PAINTING-SPEC", "TRACING-SPEC", "JACKET-SPEC", "NOMINAL-CLASS", "PIPELINE-TEMP", "PIPELINE-TYPE",
    "START-CO-ORDS", "END-CO-ORDS", "MISC-SPEC1", "MISC-SPEC2", "MISC-SPEC3", "MISC-SPEC4", "MISC-SPEC5",
    "PROJECT-NAME", "DRAWING-NUMBER", "DRAWING-REFERENCE", "BATCH-REFERENCE", "MATERIALS",
}
MATERIAL_RECORDS = {"ITEM-CODE", "DESCRIPTION", "MATERIAL-IDENTIFIER", "ITEM-DESCRIPTION", "MATERIAL-DESCRIPTION"}
# Item keywords of the PCF specification (component records, markers, messages).
ITEM_KEYWORDS = {
    "PIPE", "PIPE-FIXED", "PIPE-BLOCK-FIXED", "PIPE-BLOCK-VARIABLE", "ELBOW", "BEND", "ELBOW-TEE", "TEE",
    "TEE-SET-ON", "TEE-STUB", "CROSS", "CROSS-SET-ON", "REDUCER-CONCENTRIC", "REDUCER-ECCENTRIC", "VALVE",
    "VALVE-ANGLE", "VALVE-3WAY", "VALVE-4WAY", "VALVE-MULTIWAY", "FLANGE", "FLANGE-BLIND",
    "FLANGE-REDUCING-CONCENTRIC", "FLANGE-REDUCING-ECCENTRIC", "GASKET", "WELD", "BOLT", "CAP", "OLET",
    "COUPLING", "UNION", "INSTRUMENT", "INSTRUMENT-ANGLE", "INSTRUMENT-3WAY", "INSTRUMENT-DIAL", "SUPPORT",
    "FILTER", "TRAP", "MISC-COMPONENT", "LAP-JOINT-STUBEND", "LAP-JOINT-RING", "ADAPTER", "BLIND",
    "SPECTACLE-BLIND", "SPACER", "PLUG", "NIPPLE", "SWAGE", "HOSE", "CLAMP", "END-CONNECTION-PIPELINE",
    "END-CONNECTION-EQUIPMENT", "END-CONNECTION-NULL", "END-POSITION-OPEN", "END-POSITION-CLOSED",
    "END-POSITION-NULL", "MESSAGE-SQUARE", "MESSAGE-CIRCLE", "MESSAGE-ROUND", "MESSAGE-TRIANGLE", "FLOW-ARROW",
    "DIMENSION", "TEXT", "LOCATION-POINT", "ISO-SPLIT-POINT", "FIELD-FIT-WELD", "TAPPING", "TAP-CONNECTION",
    "CONTINUATION",
}
ID_RECORDS = ("COMPONENT-IDENTIFIER", "UCI", "ITEM-CODE")
SINGLE_ENDED = ("CAP", "FLANGE-BLIND", "PLUG", "BLIND")
FLANGE_LIKE = ("FLANGE", "GASKET", "BLIND", "SPECTACLE-BLIND", "SPACER", "LAP-JOINT")
# ISOGEN spindle directions (plant axes: east = +x, north = +y, up = +z)
SPINDLE = {"UP": (0.0, 0.0, 1.0), "DOWN": (0.0, 0.0, -1.0), "NORTH": (0.0, 1.0, 0.0), "SOUTH": (0.0, -1.0, 0.0),
           "EAST": (1.0, 0.0, 0.0), "WEST": (-1.0, 0.0, 0.0)}
UNITS = {"MM": "mm", "MILLIMETRE": "mm", "MILLIMETRES": "mm", "MILLIMETER": "mm", "MILLIMETERS": "mm",
         "INCH": "in", "INCHES": "in", "IN": "in", "INCH-FRACTION": "in", "M": "m", "METRE": "m", "METRES": "m",
         "CM": "cm", "FT": "ft", "FEET": "ft"}
TO_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8}
UNIT_RECORDS = ("UNITS-CO-ORDS", "UNITS-BORE")
# Exporting tools recognised by name anywhere in the file, and E3D's database references (=1234/567).
TOOLS = (
    ("aveva_e3d", re.compile(r"\bAVEVA\b|\bE3D\b|\bPDMS\b|\bEverything3D\b", re.I)),
    ("revit", re.compile(r"\bREVIT\b", re.I)),
    ("autocad_plant3d", re.compile(r"\bPLANT\s?3D\b|\bAUTOCAD\b|\bP3D\b", re.I)),
)
E3D_REFERENCE = re.compile(r"^\s+UCI\s+=\d+/\d+\s*$", re.M)
# Largest flange face gap taken for a gasket (a spiral-wound gasket is 4.5 mm, ring joints need more).
GASKET_GAP_MM = 10.0
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
POINT_RE = re.compile(rf"^(\s*)(\S+)(\s+)({_NUM})(\s+)({_NUM})(\s+)({_NUM})(.*)$")
_EOL = re.compile(r"(\r\n|\r|\n)")


def needs_points(word: str) -> bool:
    """A component keyword: the item is nothing without END-POINT/CENTRE-POINT/BRANCH-POINT lines (markers,
    messages, supports and bolts place themselves by CO-ORDS or not at all)."""
    return (word.startswith(("PIPE", "ELBOW", "BEND", "TEE", "CROSS", "REDUCER-", "VALVE", "FLANGE", "INSTRUMENT"))
            or word in TYPE_OF or word.endswith("OLET")
            or word in ("GASKET", "WELD", "COUPLING", "UNION", "FILTER", "TRAP", "MISC-COMPONENT"))


class ItemProblem(Exception):
    """One item cannot be (fully) interpreted; the message says why."""


def split_lines(text: str) -> tuple[list[str], list[str]]:
    """Line contents and their own line endings (CRLF, LF or CR kept as found, '' for the last)."""
    parts = _EOL.split(text)
    contents, endings = parts[0::2], parts[1::2] + [""]
    if contents and contents[-1] == "" and len(contents) > 1:
        contents.pop()
        endings.pop()
    return contents, endings


def is_known_keyword(word: str) -> bool:
    return (word in ITEM_KEYWORDS or word in HEADER_RECORDS or word in MATERIAL_RECORDS
            or word.startswith(("UNITS-", "ATTRIBUTE", "REDUCER-", "VALVE-", "INSTRUMENT-", "FLANGE-", "MISC-"))
            or word.endswith("OLET"))


@dataclass
class Item:
    """One top-level block that is not a header or material record."""

    keyword: str
    ordinal: int  # 1-based among the items
    line: int  # 0-based line of the keyword
    point_lines: list[int] = field(default_factory=list)
    extra_lines: list[int] = field(default_factory=list)
    records: dict[str, str] = field(default_factory=dict)  # first value of each indented record
    id: str = ""

    @property
    def position_id(self) -> str:
        return f"{self.keyword}-{self.ordinal}"


@dataclass
class Document:
    lines: list[str]
    endings: list[str]
    header: dict[str, str]
    items: list[Item]
    unknown: list[str]
    id_source: dict[str, int]
    tool: str | None
    decimals: int
    # 0-based lines of the UNITS-CO-ORDS / UNITS-BORE records read as the file's (the header's, indented or not)
    unit_lines: tuple[int, ...] = ()

    @property
    def units(self) -> str | None:
        return UNITS.get(self.header.get("UNITS-CO-ORDS", "MM"))

    @property
    def bore_factor(self) -> float:
        """Bores (in UNITS-BORE) to coordinate units."""
        units = self.units or "mm"
        bore_units = UNITS.get(self.header.get("UNITS-BORE", self.header.get("UNITS-CO-ORDS", "MM")), units)
        return TO_MM[bore_units] / TO_MM[units]

    @property
    def quantum(self) -> float:
        """Half the last printed digit of the coordinates: how far rounding may have moved a point."""
        return 0.5 * 10.0 ** -self.decimals


@lru_cache(maxsize=8)
def read_document(text: str) -> Document:
    """Records, items and ids of a PCF text (the same text always gives the same items and ids)."""
    lines, endings = split_lines(text)
    header: dict[str, str] = {}
    items: list[Item] = []
    words: set[str] = set()
    current: Item | None = None
    in_materials = False
    decimals = 0
    unit_lines: list[int] = []
    for i, line in enumerate(lines):
        parts = line.split()
        if not parts:
            continue
        word = parts[0].upper()
        if line[0].isspace() and current is None and word in UNIT_RECORDS:
            # a UNITS record indented under the header's PIPELINE-REFERENCE (some writers indent the whole header):
            # still the file's unit; passed over, inch bores were read in millimetres and the file said to state none
            header.setdefault(word, parts[1].upper() if len(parts) > 1 else "")
            unit_lines.append(i)
            continue
        if not line[0].isspace():
            words.add(word)
            current = None
            if word.startswith(("UNITS-", "ATTRIBUTE", "PIPELINE-ATTRIBUTE")) or word in HEADER_RECORDS:
                header.setdefault(word, parts[1].upper() if len(parts) > 1 else "")
                in_materials = in_materials or word == "MATERIALS"
                if word in UNIT_RECORDS:
                    unit_lines.append(i)
                continue
            if word in MATERIAL_RECORDS and (in_materials or word != "ITEM-CODE" or not items):
                continue
            current = Item(keyword=word, ordinal=len(items) + 1, line=i)
            items.append(current)
        elif current is not None:
            if word in POINT_KEYS:
                current.point_lines.append(i)
                for tok in parts[1:4]:
                    mant = tok.lower().split("e")[0]
                    if "." in mant:
                        decimals = max(decimals, len(mant.split(".")[1]))
            elif word in EXTRA_KEYS:
                current.extra_lines.append(i)
            elif len(parts) > 1:
                current.records.setdefault(word, " ".join(parts[1:]))
    id_source = _assign_ids(items)
    unknown = sorted(w for w in words if not is_known_keyword(w))
    tool = next((name for name, pattern in TOOLS if pattern.search(text)), None)
    if tool is None and E3D_REFERENCE.search(text):
        tool = "aveva_e3d"
    return Document(lines=lines, endings=endings, header=header, items=items, unknown=unknown,
                    id_source=id_source, tool=tool, decimals=min(decimals, 12), unit_lines=tuple(unit_lines))


def _assign_ids(items: list[Item]) -> dict[str, int]:
    """The exporting tool's own ids where they identify one item; positional ids otherwise."""
    counts: dict[tuple[str, str], int] = {}
    for it in items:
        for rec in ID_RECORDS:
            if rec in it.records:
                counts[(rec, it.records[rec])] = counts.get((rec, it.records[rec]), 0) + 1
    taken: set[str] = set()
    source: dict[str, int] = {}
    positional = {it.position_id for it in items}
    for it in items:
        chosen, how = it.position_id, "position"
        for rec in ID_RECORDS:
            value = it.records.get(rec)
            if value and counts[(rec, value)] == 1 and value not in taken and (
                    value not in positional or value == it.position_id) and len(value) <= 200:
                chosen, how = value, rec
                break
        if chosen in taken:
            chosen, how = it.position_id, "position"
        it.id = chosen
        taken.add(chosen)
        source[how] = source.get(how, 0) + 1
    return source


def read_point(line: str) -> tuple[np.ndarray, float | None]:
    parts = line.split()
    try:
        xyz = np.array([float(v) for v in parts[1:4]])
    except (ValueError, IndexError) as exc:
        raise ItemProblem(f"cannot read the coordinates of {line.strip()!r}") from exc
    if len(xyz) < 3:
        raise ItemProblem(f"cannot read the coordinates of {line.strip()!r}")
    if not np.all(np.isfinite(xyz)):
        raise ItemProblem(f"non-finite coordinate in {line.strip()!r}")
    if np.any(np.abs(xyz) > MAX_COORDINATE):  # an absurd float: the item is held like a non-finite one
        raise ItemProblem(f"coordinate beyond {MAX_COORDINATE:g} in {line.strip()!r}")
    bore = None
    if len(parts) > 4:
        try:
            bore = float(parts[4])
        except ValueError:
            bore = None
        if bore is not None and not _readable_bore(bore):
            bore = None
    return xyz, bore


# the largest bore read: beyond it a bore is a typing accident (1e300 was refused by the request's radius bound
# naming ``components[i].radius``, not the file's line); a thousandth of the coordinates' bound, so that a bore in
# feet in a millimetre file stays within that bound too
MAX_BORE = MAX_COORDINATE / 1000


def _readable_bore(bore: float) -> bool:
    """A bore that is a positive number up to :data:`MAX_BORE`."""
    return bool(np.isfinite(bore) and 0 < bore <= MAX_BORE)


def _unit(x: np.ndarray) -> np.ndarray | None:
    n = np.linalg.norm(x)
    return x / n if n > 0 else None


def _coincident(points: list[np.ndarray], quantum: float) -> bool:
    """All points at one place (up to print rounding): a zero-length item such as a weld."""
    P = np.array(points)
    eps = max(1e-6, 2.0 * quantum) + 1e-12 * float(np.max(np.abs(P)))
    return bool(np.max(np.linalg.norm(P - P[0], axis=1)) <= eps)


# How far an elbow's ANGLE and BEND-RADIUS records may differ from what its end points and CENTRE-POINT give before
# the two are said to contradict each other (the printed digits of an export move the points' angle far less)
RECORD_ANGLE_DEG = 1.0
RECORD_RADIUS_SHARE = 0.02
# Bores a bend's radius may span (pulled bends reach about 10 D): a small turn read from an ANGLE in hundredths whose
# points give a larger radius is a 180° return bend whose CENTRE-POINT was nudged off its chord (a 6" bend 2 mm off
# gives 14.5 m, 95 bores)
SMALL_TURN_BORES = 10.0


def _angle_record(value: str | None, turn: float | None = None, radius_fits: bool = True) -> float | None:
    """ANGLE in degrees; E3D writes hundredths of a degree (ANGLE 18000, ANGLE 4500). A value up to 360 reads both
    ways (ANGLE 180 is 180° or E3D's 1.8°): the turn ``turn`` the item's points give (degrees, None without one)
    decides when it matches the hundredths alone and ``radius_fits`` (the BEND-RADIUS record, if any, agrees with
    the points at that turn); read as degrees, a 1.8° elbow became a 180° return bend whose ports pointed sideways
    and lost both its connections. The radius is what tells a 180° return bend whose CENTRE-POINT was nudged off
    its chord from such an elbow: the points alone agree with a small turn for both."""
    try:
        a = abs(float((value or "").split()[0]))
    except (ValueError, IndexError):
        return None
    if a > 360.0:
        return a / 100.0
    if turn is not None and radius_fits and abs(a / 100.0 - turn) <= RECORD_ANGLE_DEG < abs(a - turn):
        return a / 100.0
    return a


def _bend_radius(item: Item) -> float | None:
    """The BEND-RADIUS record (file units), None without a usable one."""
    try:
        radius = float(item.records.get("BEND-RADIUS", "").split()[0])
    except (ValueError, IndexError):
        return None
    return radius if np.isfinite(radius) and radius > 0 else None


def _radius_from_points(turn: float, arms: list[float]) -> tuple[float, float] | None:
    """The radius an elbow's points give (its arms are R·tan(turn / 2)) and tan(turn / 2); None where the turn
    does not fix one (no turn, or a return bend)."""
    if not 0.1 < turn < 179.0:
        return None
    half = float(np.tan(np.radians(turn) / 2.0))
    return float(np.mean(arms)) / half, half


def _radius_contradicts(radius: float, turn: float, arms: list[float], quantum: float) -> float | None:
    """The radius the points give when the BEND-RADIUS record ``radius`` differs from it by more than the records'
    share and the printed digits explain, else None."""
    found = _radius_from_points(turn, arms)
    if found is None:
        return None
    from_points, half = found
    if abs(radius - from_points) > RECORD_RADIUS_SHARE * from_points + 4.0 * quantum / half:
        return from_points
    return None


def _turn_from_points(e0: np.ndarray, e1: np.ndarray, c: np.ndarray) -> float | None:
    """The turn (degrees) of an elbow whose CENTRE-POINT is the corner of its two straights: 180° less the angle
    between its arms; None when an arm has no length."""
    a0, a1 = _unit(e0 - c), _unit(e1 - c)
    if a0 is None or a1 is None:
        return None
    return 180.0 - float(np.degrees(np.arccos(np.clip(a0 @ a1, -1.0, 1.0))))


def _record_line(item: Item, doc: Document, word: str) -> int:
    """The 1-based line of an item's first ``word`` record (the item's own line when it has none)."""
    for i in range(item.line + 1, len(doc.lines)):
        line = doc.lines[i]
        if line and not line[0].isspace():
            break
        parts = line.split()
        if parts and parts[0].upper() == word:
            return i + 1
    return item.line + 1


def _records_against_points(item: Item, doc: Document, turn: float, arms: list[float]) -> list[dict]:
    """The ANGLE and BEND-RADIUS records of an elbow or bend that contradict its points: the corner (its
    CENTRE-POINT) and end points give the turn and, with the arms' length R·tan(turn / 2), the radius. The points are
    what is aligned; a record that says otherwise is a mistyped record or a mistyped point, and the file does not
    say which."""
    out = []
    raw = item.records.get("ANGLE")
    radius = _bend_radius(item)
    from_points = None if radius is None else _radius_contradicts(radius, turn, arms, doc.quantum)
    angle = _angle_record(raw, turn, from_points is None)
    if angle is not None and abs(angle - turn) > RECORD_ANGLE_DEG:
        out.append({"record": "ANGLE", "record_line": _record_line(item, doc, "ANGLE"), "value": raw.split()[0],
                    "read_as": angle, "from_points": round(turn, 4), "unit": "deg"})
    if from_points is not None:
        out.append({"record": "BEND-RADIUS", "record_line": _record_line(item, doc, "BEND-RADIUS"),
                    "value": item.records["BEND-RADIUS"].split()[0], "read_as": radius,
                    "from_points": round(from_points, 6), "unit": doc.units or "mm"})
    found = _radius_from_points(turn, arms)
    if found is not None:
        out.extend(_unusable_radius(item, doc, found[0]))
    return out


def _unusable_radius(item: Item, doc: Document, from_points: float) -> list[dict]:
    """The BEND-RADIUS record of a bend when it is written but is no positive number (0, -152.4, nan): it was passed
    over without a word, as if the file had none."""
    raw = item.records.get("BEND-RADIUS")
    if raw is None or _bend_radius(item) is not None:
        return []
    try:
        float(raw.split()[0])
    except (ValueError, IndexError):  # a word (LR, 1.5D) is no number to weigh against the points
        return []
    return [{"record": "BEND-RADIUS", "record_line": _record_line(item, doc, "BEND-RADIUS"), "value": raw.split()[0],
             "read_as": None, "from_points": round(from_points, 6), "unit": doc.units or "mm"}]


@dataclass
class Geometry:
    """An item as the solver sees it: ports (direction None = to be taken from the neighbours)."""

    ports: list[tuple[np.ndarray, np.ndarray | None]]
    port_lines: list[int]
    kind: str  # pipe | fitting | joint
    ftype: str | None
    radius: float | None
    chord: np.ndarray | None = None  # return bend whose plane comes from its neighbours
    note: str | None = None  # what had to be taken from elsewhere
    suspect: str | None = None  # why its own lines look mistyped though they can be interpreted (it is then held)
    contradicted: list[dict] = field(default_factory=list)  # its ANGLE / BEND-RADIUS records its points contradict


def interpret_item(item: Item, doc: Document, snap: bool) -> Geometry:
    """Ports of one item from its own lines; raises :class:`ItemProblem` with the reason."""
    word, lines = item.keyword, doc.lines
    pts: dict[str, list] = {}
    for i in item.point_lines:
        key = lines[i].split()[0].upper()
        pts.setdefault(key, []).append((i,) + read_point(lines[i]))
    ends = pts.get("END-POINT", [])
    centre = pts.get("CENTRE-POINT", [])
    branches = [b for k in ("BRANCH1-POINT", "BRANCH2-POINT", "BRANCH3-POINT") for b in pts.get(k, [])]
    bores = [b for (_, _, b) in ends + branches if b]
    radius = 0.5 * max(bores) * doc.bore_factor if bores else None
    every = [p for _, p, _ in ends + branches + centre]
    q = doc.quantum
    if word.startswith(SINGLE_ENDED) and len(ends) == 2 and not branches and _coincident([p for _, p, _ in ends], q):
        return Geometry([(ends[0][1], None)], [ends[0][0]], "fitting", "cap" if word == "CAP" else "flange", radius,
                        note="two coincident END-POINTs: one port")
    if (len(every) >= 2 and _coincident(every, q) and not (centre and branches)) or (
            word in ("WELD", "GASKET") and len(every) == 1):
        return Geometry([], [i for i, _, _ in ends + branches], "joint", None, radius)
    c = centre[0][1] if centre else None
    if word == "PIPE" or word.startswith("PIPE-"):
        if len(ends) != 2:
            raise ItemProblem(f"a {word} needs two END-POINT lines, found {len(ends)}")
        axis = _unit(ends[1][1] - ends[0][1])
        return Geometry([(ends[0][1], -axis), (ends[1][1], axis)], [ends[0][0], ends[1][0]], "pipe", None, radius)
    ftype = TYPE_OF.get(word)
    if ftype is None:
        ftype = "olet" if word.endswith("OLET") else TYPE_OF.get(word.split("-")[0], "other")
    suspect = _uneven_arms(ends, c, q) if c is not None and len(ends) == 2 and not branches and (
        ftype in ("elbow", "bend") or word.startswith(("ELBOW", "BEND"))) else None
    chord = note = None
    contradicted: list[dict] = []
    if c is not None and len(ends) == 2 and not branches:
        e0, e1 = ends[0][1], ends[1][1]
        span = float(np.linalg.norm(e1 - e0))
        u = (e1 - e0) / span if span > 0 else None
        off = (c - e0) - np.dot(c - e0, u) * u if u is not None else None
        on_line = off is not None and np.linalg.norm(off) <= max(1e-3 * span, 4.0 * q)
        turn = _turn_from_points(e0, e1, c) if not on_line else None
        arms = [float(np.linalg.norm(e - c)) for e in (e0, e1)]
        bend_radius = _bend_radius(item)
        if bend_radius is not None:
            radius_fits = turn is None or _radius_contradicts(bend_radius, turn, arms, q) is None
        else:  # no record: a small turn must still be a bend a pipe of this bore is made to, not a nudged return bend
            implied = _radius_from_points(turn, arms) if turn is not None and radius else None
            radius_fits = implied is None or implied[0] <= SMALL_TURN_BORES * 2.0 * radius
        angle = _angle_record(item.records.get("ANGLE"), turn, radius_fits)
        turning = ftype in ("elbow", "bend") or word.startswith(("ELBOW", "BEND"))
        if turning and u is not None and (on_line or (angle is not None and abs(angle - 180.0) < 0.5)):
            # a 180 degree return bend: both ports parallel, normal to the chord, away from the CENTRE-POINT
            # side; a centre on the chord (the arc's centre) does not tell which side: the neighbours do
            ftype = "bend" if ftype not in ("elbow", "bend") else ftype
            if bend_radius is not None and abs(span / 2.0 - bend_radius) > RECORD_RADIUS_SHARE * bend_radius + 4.0 * q:
                # its chord is its diameter
                contradicted = [{"record": "BEND-RADIUS", "record_line": _record_line(item, doc, "BEND-RADIUS"),
                                 "value": item.records["BEND-RADIUS"].split()[0], "read_as": bend_radius,
                                 "from_points": round(span / 2.0, 6), "unit": doc.units or "mm"}]
            contradicted.extend(_unusable_radius(item, doc, span / 2.0))
            if on_line and angle is not None and abs(angle - 180.0) > RECORD_ANGLE_DEG:
                # its CENTRE-POINT midway between its END-POINTs makes it a return bend, whatever its ANGLE says (an
                # ANGLE 90 bend so written was aligned as a 180 degree one without a word)
                contradicted.append({"record": "ANGLE", "record_line": _record_line(item, doc, "ANGLE"),
                                     "value": item.records["ANGLE"].split()[0], "read_as": angle,
                                     "from_points": 180.0, "unit": "deg"})
            if not on_line:
                d = _unit(-off)
                return Geometry([(e0, d), (e1, d.copy())], [ends[0][0], ends[1][0]], "fitting", ftype, radius,
                                note="180 degree return bend: plane from the CENTRE-POINT offset", suspect=suspect,
                                contradicted=contradicted)
            return Geometry([(e0, None), (e1, None)], [ends[0][0], ends[1][0]], "fitting", ftype, radius, chord=u,
                            note="180 degree return bend with its CENTRE-POINT on the chord: plane from its neighbours",
                            suspect=suspect, contradicted=contradicted)
        if on_line:
            # an inline item with a CENTRE-POINT (instrument, some valves): ports exactly opposite along the line
            c = None
        elif turning and turn is not None:
            contradicted = _records_against_points(item, doc, turn, arms)
    ports, port_lines = [], []
    for k, (i, p, _) in enumerate(ends + branches):
        d = _unit(p - c) if c is not None else None
        if d is None and len(ends) == 2 and k < 2 and not (ftype in ("elbow", "bend")):
            d = _unit(p - ends[1 - k][1])  # inline item: along its end-point axis
        ports.append((p, d))
        port_lines.append(i)
    if not ports:
        raise ItemProblem(f"no END-POINT or BRANCH1-POINT line (a {word} needs at least one)")
    need = {"tee": 3, "cross": 4, "elbow": 2, "bend": 2, "reducer": 2, "valve": 2}.get(ftype, 1)
    if len(ports) < need and len(ends) == 2 and ftype in ("tee", "cross"):
        # a tee's run without its branch line: the branch pipe would be left unjoined there without a word
        suspect = (f"a {word} has {need - 2} BRANCH-POINT line(s) beside its two END-POINTs, this one "
                   f"{len(branches)}: the branch line was lost, and the pipe it joins is not connected to it")
    if len(ends) == 1 and need >= 2:
        # an item of two ends with one END-POINT line: the other was lost (cut, or typed as another record); read
        # as a set-on item of fewer ports it was aligned as if whole, what it joins there left open without a word
        suspect = (f"{'an' if word[0] in 'AEIOU' else 'a'} {word} has two END-POINT lines, this one 1 (line {ends[0][0] + 1}): the other was lost, and "
                   "what it joins there is not connected to it")
    if len(ports) < need:  # set-on tees and the like: only the branch is a port
        ftype = "olet" if len(ports) == 1 else "other"
    if ftype in ("elbow", "bend") and c is None:
        note = f"no CENTRE-POINT: the {word}'s port directions come from its neighbours"
    if ftype == "olet" and any(d is None for _, d in ports):
        note = "no usable CENTRE-POINT: direction from the pipe it sits on or its branch"
    if snap and c is not None and ftype in ("elbow", "bend", "tee", "cross") and all(d is not None for _, d in ports):
        ports = snap_catalogue(ports, c, print_quantum([lines[i] for i in item.point_lines]))
    return Geometry(ports, port_lines, "fitting", ftype, radius, chord=chord, note=note, suspect=suspect,
                    contradicted=contradicted)


ARM_RATIO = 1.5  # an elbow's or bend's end points lie at one distance from its CENTRE-POINT (both arms are its radius)


def _uneven_arms(ends: list, c: np.ndarray, quantum: float) -> str | None:
    """Why an elbow or bend looks mistyped, None when it does not. It is symmetric: its two end points lie at the
    same distance from its CENTRE-POINT (exports agree to their printed digits). One much further out than the
    other is a mistyped coordinate (a 0 for a plant coordinate, a digit dropped); interpreted, the item would point
    its port there and silently lose the connection it had."""
    arms = [float(np.linalg.norm(p - c)) for _, p, _ in ends]
    short, long = min(arms), max(arms)
    if long > ARM_RATIO * short + 8.0 * quantum:
        far = ends[int(np.argmax(arms))][0]
        return (f"its end point on line {far + 1} lies {long:.6g} from the CENTRE-POINT, the other {short:.6g}: an "
                "elbow's two arms are equal (a mistyped coordinate?)")
    return None


@dataclass
class Interpretation:
    """A PCF as a request body, and what the reading had to decide (report notes)."""

    body: dict
    notes: list[tuple[str, str, dict, str]]  # (code, message, details, 'warning' | 'detail')
    geometry: dict[str, Geometry]  # by item id, items that are solver components or joints
    nozzles: list[str] = field(default_factory=list)  # items at an END-CONNECTION-EQUIPMENT/-PIPELINE marker


def options_from(options) -> AlignmentOptions:
    """The upload's options, validated first: they decide how the file is read."""
    if isinstance(options, AlignmentOptions):
        return options
    if options is not None and not isinstance(options, dict):
        raise InputRejected([FieldError(("options",), "options must be an object")])
    return validated(AlignmentOptions, options or {}, ("options",))


PROFILES = {  # (position tolerance unit or None = drawing units, value, angle tolerance rad)
    "autocad_plant3d": (None, 1e-10, 1e-10),
    "aveva_e3d": ("mm", 1.0, 0.01),
    "revit": ("ft", 1e-9, 1e-10),
    "custom": (None, 1e-10, 1e-10),
}


def profile_tolerances(profile: str, units: str) -> tuple[float, float]:
    unit, value, ang = PROFILES[profile]
    return (value if unit is None else value * TO_MM[unit] / TO_MM[units]), ang


def pcf_tolerances(text: str, units: str) -> dict:
    """The tolerances a PCF's own exporter and printed precision imply (profile 'auto').

    Rounding to d decimals moves a point by up to q = 0.5e-d per coordinate, so two ends of one
    connection printed independently differ by up to 2 q sqrt(3) (``rounding``): the position
    tolerance is at least that. A direction taken from two printed points a lever L apart turns by
    up to rounding / L, so each connection's angle tolerance is at least rounding over the shorter
    lever of its two items (see :func:`plantsolve.solvers.alignment.model.build_model`)."""
    doc = read_document(text)
    rounding = 2.0 * np.sqrt(3.0) * doc.quantum
    if doc.tool is not None:
        pos_tool, ang_tool = profile_tolerances(doc.tool, units)
        reason = f"exporter named in the file ({doc.tool}); coordinates printed with {doc.decimals} decimals"
    else:
        pos_tool, ang_tool = profile_tolerances("custom", units)
        reason = f"no exporter named in the file; coordinates printed with {doc.decimals} decimals"
    return {"profile": doc.tool or "printed_precision", "position": max(pos_tool, rounding), "angle": ang_tool,
            "rounding": rounding, "reason": reason, "decimals": doc.decimals}


@lru_cache(maxsize=8)
def _interpret_cached(text: str, options_json: str) -> Interpretation:
    return _interpret(text, AlignmentOptions.model_validate_json(options_json))


def interpret_pcf(text: str, options) -> Interpretation:
    opts = options_from(options)
    return _interpret_cached(text, opts.model_dump_json())


def _interpret(text: str, opts: AlignmentOptions) -> Interpretation:
    doc = read_document(text)
    _refuse_unknown_units(doc)
    units = doc.units
    _refuse_contradicting_units(doc)
    alias = {it.position_id: it.id for it in doc.items}
    _refuse_ambiguous_fixed(doc, opts.fixed_components)
    fixed_ids = {alias.get(f, f) for f in opts.fixed_components}
    notes: list[tuple[str, str, dict, str]] = []
    held: list[dict] = []
    dropped: list[dict] = []
    resolved: list[dict] = []
    comps: list[dict] = []
    geometry: dict[str, Geometry] = {}
    for it in doc.items:
        if not it.point_lines:
            if needs_points(it.keyword) and not it.extra_lines:
                dropped.append({"id": it.id, "line": it.line + 1,
                                "reason": f"no END-POINT, CENTRE-POINT or BRANCH1-POINT line (a {it.keyword} needs them)"})
            continue
        try:
            g = interpret_item(it, doc, snap=it.id not in fixed_ids)
        except ItemProblem as exc:
            g = _held_geometry(it, doc)
            if g is None:
                dropped.append({"id": it.id, "line": it.line + 1, "reason": str(exc)})
                continue
            held.append({"id": it.id, "line": it.line + 1, "reason": str(exc)})
            g.kind, g.ftype, g.note = "held", "other", str(exc)
        geometry[it.id] = g
        if g.kind != "joint":
            spindle = SPINDLE.get(it.records.get("SPINDLE-DIRECTION", "").split(" ")[0].upper())
            comps.append({"id": it.id, "word": it.keyword, "up": spindle, "geometry": g, "line": it.line + 1})
    left_out: list[dict] = []
    comps = _without_rings(comps, doc, geometry, left_out)
    if not comps:
        _refuse(dropped, left_out)

    tol = resolve_pcf_tolerance(text, units, opts)
    # The interpreted model must pass the rules every request passes (the job domain checks them at
    # submission): an item failing one is held fixed with its directions taken from its neighbours, and left
    # out if it still fails; only the rest of the file is solved.
    held_read, forced = held, []
    for attempt in range(4):
        held, resolved = list(held_read) + forced, []
        net = _connect(comps, doc, opts, units, tol[0], held, resolved)
        comps_json, connections = _entries(comps, net, fixed_ids, {h["id"] for h in held})
        unsized = _without_jumping_radii(comps_json, connections)
        body = _body(units, comps_json, connections, opts, alias, text)
        failures = failing_components(body)
        # an elbow with uneven arms passes the model check pointing a port at its typo: held too (the model check's
        # reason first, where it has one)
        uneven = [k for k, c in enumerate(comps) if c["geometry"].suspect and c["geometry"].kind != "held"
                  and k not in failures]
        if (not failures and not uneven) or attempt == 3:
            break
        for k in uneven:
            c, g = comps[k], comps[k]["geometry"]
            forced.append({"id": c["id"], "line": c["line"], "reason": g.suspect})
            c["geometry"] = geometry[c["id"]] = Geometry([(p, None) for p, _ in g.ports], g.port_lines, "held",
                                                          "other", g.radius)
        forced_ids = {h["id"] for h in forced}
        gone = set()
        for n, found in failures.items():
            if n >= len(comps):  # a gasket spacer: goes with its flanges
                continue
            c = comps[n]
            g = c["geometry"]
            why = "; ".join((f"end point on line {_port_line(g, port)}: " if port is not None else "") + msg
                            for port, msg in found)
            if c["id"] in forced_ids or g.kind == "held":
                gone.add(c["id"])
                left_out.append({"id": c["id"], "line": c["line"], "reason": f"fails the model check even when held: {why}"})
                geometry.pop(c["id"], None)
                continue
            forced.append({"id": c["id"], "line": c["line"], "reason": f"fails the model check once interpreted: {why}"})
            c["geometry"] = geometry[c["id"]] = Geometry([(p, None) for p, _ in g.ports], g.port_lines, "held", "other",
                                                          g.radius)
        held_read = [h for h in held_read if h["id"] not in gone]
        forced = [h for h in forced if h["id"] not in gone]
        comps = [c for c in comps if c["id"] not in gone]
        if not comps:
            _refuse(dropped, left_out)
    cut = _cut_item(doc, {h["id"] for h in held + dropped + left_out})
    if cut is not None:
        notes.append(cut)
    notes.extend(_assumed_units_notes(doc))
    notes.extend(_bore_notes(doc))
    notes.extend(_bore_size_notes(doc))
    notes.extend(_missing_bore_notes(doc))
    notes.extend(_duplicate_notes(comps, doc))
    notes.extend(_record_notes(comps))
    notes.extend(_open_ends_inside_pipes(comps, net, doc))
    notes.extend(_zero_length_pipe_notes(doc, geometry))
    notes.extend(_bore_mismatch_notes(comps, net, doc))
    notes.extend(_unsized_notes(unsized, {c["id"]: c["line"] for c in comps}, units or "mm"))
    notes.extend(_notes(doc, geometry, held, dropped, resolved, net["gaps"], comps, net["owner"], left_out))
    return Interpretation(body=body, notes=notes, geometry=geometry,
                          nozzles=_at_end_connections(doc, net["pos"], net["owner"], net["rad"], comps))


def _refuse_unknown_units(doc: Document) -> None:
    """A 422 naming the line of a UNITS-CO-ORDS or UNITS-BORE record whose unit is none read here. An unknown
    UNITS-BORE was taken for the coordinates' unit without a word, so bores in another unit reached 25.4 or 1000
    times too far or too short when end points were joined."""
    for record in UNIT_RECORDS:
        for i in doc.unit_lines:
            words = doc.lines[i].split()
            # a bare UNITS-CO-ORDS states a unit without naming it: no default can be taken for it (it crashed the
            # joining of end points, a generic 422 or a crashed job)
            if len(words) == 1 and words[0].upper() == record == "UNITS-CO-ORDS":
                raise reject(f"line {i + 1}: {record} names no unit; write the unit the file's coordinates are in "
                             "(MM, CM, M, INCH, FT)")
            if len(words) > 1 and words[0].upper() == record and words[1].upper() not in UNITS:
                raise reject(f"line {i + 1}: {record} {words[1]!r} is no unit read here (MM, CM, M, INCH, FT and "
                             "their spellings); write the unit the file's numbers are in")


def _refuse_contradicting_units(doc: Document) -> None:
    """A 422 for a file whose UNITS-CO-ORDS (or UNITS-BORE) records name different units (two files pasted into
    one): the first was taken for every coordinate, those under the other are then read in the wrong unit."""
    for record in UNIT_RECORDS:
        found = [(i + 1, doc.lines[i].split()[1].upper()) for i in doc.unit_lines
                 if len(doc.lines[i].split()) > 1 and doc.lines[i].split()[0].upper() == record]
        if len({UNITS.get(value, value) for _, value in found}) > 1:
            raise reject(f"{record} names different units: " + ", ".join(f"line {n}: {v}" for n, v in found[:5])
                         + "; a file holds one unit for all its coordinates (two files pasted into one?)")


def _refuse_ambiguous_fixed(doc: Document, fixed: list[str]) -> None:
    """A 422 for a fixed component named by an id that several items of the file carry (a COMPONENT-IDENTIFIER
    written twice): those items got their positional ids, and which of them was meant cannot be told."""
    ids = {it.id for it in doc.items}
    errors = []
    for k, name in enumerate(fixed):
        if name in ids:
            continue
        carriers = [it for it in doc.items if any(it.records.get(rec) == name for rec in ID_RECORDS)]
        if len(carriers) > 1:
            errors.append(FieldError(("options", "fixed_components", k), (
                f"{name!r} is the identifier of {len(carriers)} items (lines "
                f"{', '.join(str(it.line + 1) for it in carriers[:5])}): give the one meant by its positional id "
                f"({', '.join(it.position_id for it in carriers[:5])})")))
    if errors:
        raise InputRejected(errors)


def _connect(comps: list[dict], doc: Document, opts: AlignmentOptions, units: str, pos_tol: float,
             held: list[dict], resolved: list[dict]) -> dict:
    """Connections between the items' end points and the port directions the geometry left open (taken
    from neighbours; held items without one point away from their centroid). Appends to held and resolved."""
    counts = np.array([len(c["geometry"].ports) for c in comps])
    start = np.concatenate([[0], np.cumsum(counts)])
    pos = np.array([p for c in comps for p, _ in c["geometry"].ports]).reshape(-1, 3)
    owner = np.repeat(np.arange(len(comps)), counts)
    local = np.arange(len(pos)) - start[owner]
    dirs = [d for c in comps for _, d in c["geometry"].ports]
    known = [c["geometry"].radius for c in comps if c["geometry"].radius]
    # a component without a readable bore connects like a typical one of the file (10 mm if none has one)
    typical = float(np.median(known)) if known else 10.0 / TO_MM[units]
    rad = np.array([c["geometry"].radius or typical for c in comps])[owner]
    # a flange face: a flange-like item, or an end written with a flanged end type (FL, FLG) as valves have
    flange_like = np.array([c["word"].startswith(FLANGE_LIKE) or _flanged_end(doc.lines[i])
                            for c in comps for i in c["geometry"].port_lines], dtype=bool)
    conns, gaps = _infer_connections(pos, dirs, owner, rad, flange_like, opts.connection_tolerance, pos_tol,
                                     GASKET_GAP_MM / TO_MM[units])
    _join_printed_alike(comps, conns, pos, doc)
    partner = {}
    for i, j in conns:
        partner[i], partner[j] = j, i
    _directions_from_neighbours(comps, start, dirs, partner, resolved)
    # An eccentric item's end points are offset sideways (flat side), so the line through them is not its
    # axis: its ports take the axis of the pipes they join (their mean when both sides are connected).
    for k, c in enumerate(comps):
        if "ECCENTRIC" in c["word"] and len(c["geometry"].ports) == 2:
            i0, i1 = start[k], start[k] + 1
            n0 = -dirs[partner[i0]] if i0 in partner and dirs[partner[i0]] is not None else None
            n1 = -dirs[partner[i1]] if i1 in partner and dirs[partner[i1]] is not None else None
            axis = _unit(n1 - n0) if n0 is not None and n1 is not None else n1 if n1 is not None else (
                -n0 if n0 is not None else None)
            if axis is not None:
                dirs[i0], dirs[i1] = -axis, axis
    _olet_directions(comps, start, dirs, pos, resolved)
    held_ids = {h["id"] for h in held}
    for k, c in enumerate(comps):
        ks = range(start[k], start[k + 1])
        if c["id"] not in held_ids and any(dirs[i] is None for i in ks):
            held.append({"id": c["id"], "line": c["line"],
                         "reason": "cannot determine the direction of "
                                   + ", ".join(f"end point {local[i]}" for i in ks if dirs[i] is None)
                                   + " (no connected neighbour to take it from)"})
            held_ids.add(c["id"])
        if c["id"] in held_ids:
            centroid = pos[ks.start:ks.stop].mean(axis=0)
            for i in ks:
                if dirs[i] is None:
                    dirs[i] = _unit(pos[i] - centroid)
                    if dirs[i] is None:
                        dirs[i] = np.array([0.0, 0.0, 1.0])
    return {"start": start, "pos": pos, "owner": owner, "local": local, "dirs": dirs, "rad": rad, "conns": conns,
            "gaps": gaps}


def _port_line(g: Geometry, port: int) -> int | str:
    return g.port_lines[port] + 1 if 0 <= port < len(g.port_lines) else "?"


def _refuse(dropped: list[dict], left_out: list[dict]) -> None:
    """The file has nothing usable left: a 422 naming the lines of what was skipped and why."""
    skipped = sorted(dropped + left_out, key=lambda d: d["line"])
    why = "; ".join(f"line {d['line']}: {d['reason']}" for d in skipped[:5])
    more = f" (and {len(skipped) - 5} more)" if len(skipped) > 5 else ""
    raise reject("no PCF components with END-POINT/CENTRE-POINT/BRANCH1-POINT lines were found"
                 + (f" that could be used ({why}{more})" if why else ""))


def _without_rings(comps: list[dict], doc: Document, geometry: dict, left_out: list[dict]) -> list[dict]:
    """The components without closed rings of bends (a handwheel drawn with BEND items), which are left out."""
    ports = [[p for p, _ in c["geometry"].ports] for c in comps]
    turning = [c["geometry"].kind == "fitting" and c["geometry"].ftype in TURNING for c in comps]
    every = np.array([p for ps in ports for p in ps]).reshape(-1, 3)
    eps = max(1e-6, 2.0 * doc.quantum) + 1e-12 * float(np.max(np.abs(every), initial=0.0))
    ring_of = {}
    for ring in closed_rings(ports, turning, eps):
        for k in ring:
            ring_of[k] = ring
    for k, ring in sorted(ring_of.items()):
        c = comps[k]
        lines = ", ".join(str(comps[m]["line"]) for m in ring)
        left_out.append({"id": c["id"], "line": c["line"], "reason": (
            f"a closed ring of {len(ring)} {c['word']} item(s) (lines {lines}) whose end points pair up only with "
            "each other: no pipe can run through it (a handwheel or similar drawn with pipe fittings), not piping")})
        geometry.pop(c["id"], None)
    return [c for k, c in enumerate(comps) if k not in ring_of]


def _entries(comps: list[dict], net: dict, fixed_ids: set[str], held_ids: set[str]) -> tuple[list, list]:
    """Components and connections of the request body; spacers bridge the gasket gaps."""
    start, pos, dirs, owner, local, rad = (net[k] for k in ("start", "pos", "dirs", "owner", "local", "rad"))
    conns, gaps = net["conns"], net["gaps"]
    comps_json = []
    for k, c in enumerate(comps):
        g = c["geometry"]
        ports = [{"position": pos[start[k] + j].tolist(), "direction": dirs[start[k] + j].tolist()}
                 for j in range(len(g.ports))]
        kind = "pipe" if g.kind == "pipe" else "fitting"
        entry = {"id": c["id"], "kind": kind, "radius": g.radius, "ports": ports,
                 "fixed": c["id"] in fixed_ids or c["id"] in held_ids}
        if kind == "fitting":
            entry["type"] = "other" if c["id"] in held_ids else g.ftype
            if c["up"] is not None and len(ports) == 2:
                # a stem along the valve axis is no up vector (and would be rejected)
                axis = np.array(ports[1]["position"]) - np.array(ports[0]["position"])
                n = np.linalg.norm(axis)
                if n > 0 and abs(np.dot(axis / n, c["up"])) < np.cos(np.radians(10.0)):
                    entry["up"] = list(c["up"])
        comps_json.append(entry)
    connections = [{"from": [comps[owner[i]]["id"], int(local[i])], "to": [comps[owner[j]]["id"], int(local[j])]}
                   for i, j in conns]
    taken = {c["id"] for c in comps_json}
    for n, (i, j, gap) in enumerate(gaps, start=1):
        sid = f"gasket-gap-{n}"
        while sid in taken:
            sid += "'"
        taken.add(sid)
        a, b = comps[owner[i]]["id"], comps[owner[j]]["id"]
        comps_json.append({"id": sid, "kind": "fitting", "type": "other", "radius": float(min(rad[i], rad[j])),
                           "fixed": False, "ports": [{"position": pos[i].tolist(), "direction": (-dirs[i]).tolist()},
                                                     {"position": pos[j].tolist(), "direction": (-dirs[j]).tolist()}]})
        connections += [{"from": [a, int(local[i])], "to": [sid, 0]}, {"from": [b, int(local[j])], "to": [sid, 1]}]
    return comps_json, connections


def _without_jumping_radii(comps_json: list[dict], connections: list[dict]) -> list[dict]:
    """The items whose radius (from their bores) is more than :data:`plausibility.RADIUS_JUMP` times those of every
    item they join, each with its radius and theirs; their radius is taken out of the request (a bore typed in
    another unit or with a wrong exponent: as a radius, it weighted or lengthened the item so that the network was
    cut around it, or dragged metres; the model check held the item, which still failed it, and left it out)."""
    index = {c["id"]: k for k, c in enumerate(comps_json)}
    radius = np.array([np.nan if c["radius"] is None else c["radius"] for c in comps_json], dtype=float)
    ends = np.array([(index[c["from"][0]], index[c["to"][0]]) for c in connections], dtype=np.intp).reshape(-1, 2)
    out = []
    for k, beside in radius_jumps(radius, ends[:, 0], ends[:, 1]):
        out.append({"id": comps_json[k]["id"], "radius": float(radius[k]), "beside": beside})
        comps_json[k]["radius"] = None
    return out


def _unsized_notes(unsized: list[dict], lines: dict[str, int], units: str) -> list[tuple[str, str, dict, str]]:
    """``pcf_radius_ignored``: the items whose bore-given radius was not used (:func:`_without_jumping_radii`)."""
    if not unsized:
        return []
    listed = ", ".join(f"{u['id']} (line {lines.get(u['id'], '?')}) {u['radius']:.4g} {units} beside {u['beside']:.4g} "
                       f"{units}" for u in unsized[:5]) + (", ..." if len(unsized) > 5 else "")
    return [("pcf_radius_ignored",
             f"{len(unsized)} item(s) have a radius (half the bore) more than {RADIUS_JUMP:g} times that of every item "
             f"they join ({listed}): a bore in another unit or a mistyped exponent? Their bore was not used as their "
             "size (the alignment moves them as items of unknown bore); correct the bore.",
             {"items": unsized[:200], "units": units}, "warning")]


def _body(units, comps_json, connections, opts, alias, text) -> dict:
    options_out = opts.model_dump(exclude_unset=True)
    if opts.fixed_components:
        options_out["fixed_components"] = [alias.get(f, f) for f in opts.fixed_components]
    return {"units": units, "components": comps_json, "connections": connections, "options": options_out,
            "source_pcf": text}


def _cut_item(doc: Document, unread: set[str]) -> tuple[str, str, dict, str] | None:
    """The ``truncated_file`` note when the file ends inside its last item: a component keyword with no point
    line after it (the file stops at 'PIPE'), or a last line without a line ending (exporters end every line)
    inside the item: one of its point lines, a line that leaves it unreadable, or one of its other records (the
    item is whole, what followed it is lost). An item followed by the MATERIALS section (or any record) was
    written whole."""
    tops = [i for i, line in enumerate(doc.lines) if line.strip() and not line[0].isspace()]
    cut_word = _cut_keyword(doc)
    if cut_word is not None:
        return cut_word
    if not doc.items or not tops or doc.items[-1].line != tops[-1]:
        return None
    item, last = doc.items[-1], len(doc.lines) - 1
    unterminated = doc.endings[-1] == "" and len(doc.lines) > 1
    if needs_points(item.keyword) and not item.point_lines and not item.extra_lines:
        lost = f"{item.keyword} {item.id!r} has no END-POINT line after it; it was not aligned."
    elif unterminated and last in item.point_lines + item.extra_lines and item.id not in unread:
        lost = (f"the last line ({last + 1}) has no line ending, so its last value may be cut; {item.keyword} "
                f"{item.id!r} was read as written.")
    elif unterminated and item.id in unread and last >= item.line:
        lost = (f"the last line ({last + 1}) has no line ending and {item.keyword} {item.id!r} could not be read "
                "whole (see pcf_items_held / pcf_items_unread).")
    elif unterminated and last > item.line:
        # cut inside a record after the points (SKEY, ITEM-CODE, UCI): the item is whole, what followed is gone
        lost = (f"the last line ({last + 1}) has no line ending; {item.keyword} {item.id!r} was read whole, any "
                "items the file held after it are missing.")
    else:
        return None
    line = item.line + 1
    return ("truncated_file", f"The file ends inside the item at line {line} (the file was cut?): {lost}",
            {"line": line, "id": item.id, "keyword": item.keyword, "last_line": last + 1}, "warning")


def _cut_keyword(doc: Document) -> tuple[str, str, dict, str] | None:
    """The ``truncated_file`` note when the file's last line has no line ending and is the start of an item
    keyword (``PI`` of PIPE, ``FLA`` of FLANGE): the file was cut as the next item began; read as an unknown
    keyword, the loss was said as a spelling."""
    last = len(doc.lines) - 1
    word = doc.lines[last].strip().upper() if last >= 0 else ""
    if (doc.endings[-1] != "" or not word or doc.lines[last][0].isspace() or " " in word or word in ITEM_KEYWORDS
            or is_known_keyword(word)):
        return None
    starts = sorted(k for k in ITEM_KEYWORDS if k.startswith(word))
    if not starts:
        return None
    return ("truncated_file", f"The file ends at line {last + 1} with {word!r} and no line ending: the start of "
            f"{' or '.join(starts[:3])}{', ...' if len(starts) > 3 else ''} (the file was cut as an item began?); "
            "the items the file held from there on are missing.",
            {"line": last + 1, "id": None, "keyword": word, "last_line": last + 1}, "warning")


def _at_end_connections(doc: Document, pos, owner, rad, comps) -> list[str]:
    """Items with a port at a line's end-connection marker (a nozzle or another line): tie-in-like."""
    marks = []
    for it in doc.items:
        if it.keyword in ("END-CONNECTION-EQUIPMENT", "END-CONNECTION-PIPELINE"):
            for i in it.extra_lines + it.point_lines:
                try:
                    marks.append(read_point(doc.lines[i])[0])
                except ItemProblem:
                    continue
    if not marks or len(pos) == 0:
        return []
    dist, k = cKDTree(pos).query(np.array(marks))
    return sorted({comps[owner[j]]["id"] for d, j in zip(dist, k) if d <= 0.5 * rad[j] + 1e-9})


def _flanged_end(line: str) -> bool:
    parts = line.split()
    return len(parts) > 5 and parts[5].upper().startswith("FL")


def _held_geometry(item: Item, doc: Document) -> Geometry | None:
    """The readable END/BRANCH points of an item that cannot be interpreted: ports of a fixed item."""
    ports, port_lines = [], []
    bores = []
    for i in item.point_lines:
        key = doc.lines[i].split()[0].upper()
        if key == "CENTRE-POINT":
            continue
        try:
            p, b = read_point(doc.lines[i])
        except ItemProblem:
            continue
        ports.append((p, None))
        port_lines.append(i)
        if b:
            bores.append(b)
    if not ports:
        return None
    radius = 0.5 * max(bores) * doc.bore_factor if bores else None
    return Geometry(ports, port_lines, "held", "other", radius)


def resolve_pcf_tolerance(text: str, units: str, opts: AlignmentOptions) -> tuple[float, float, float]:
    """(position, base angle in radians, rounding of the printed coordinates) the options ask for on this PCF;
    the rounding is 0 unless the profile is 'auto'."""
    rounding = 0.0
    if opts.tolerance_profile == "auto":
        t = pcf_tolerances(text, units)
        pos, ang, rounding = t["position"], t["angle"], t["rounding"]
    else:
        pos, ang = profile_tolerances(opts.tolerance_profile, units)
    if opts.position_tolerance is not None:
        pos = opts.position_tolerance
    if opts.angle_tolerance is not None:
        ang, rounding = float(np.radians(opts.angle_tolerance)), 0.0
    return float(pos), float(ang), float(rounding)


def _infer_connections(pos, dirs, owner, rad, flange_like, tol_opt, pos_tol, gasket_gap):
    """Nearest facing end points within reach, each port used once, in file order. Facing flange faces
    further apart than the tolerance but within a gasket's thickness (on their common axis) are returned
    as gaps to be bridged by a spacer, not closed."""
    reach = float(tol_opt) if tol_opt else max(float(np.max(rad)) * 0.5, 1e-6)
    pairs = cKDTree(pos).query_pairs(r=reach, output_type="ndarray")
    conns, gaps = [], []
    if len(pairs) == 0:
        return conns, gaps
    dist = np.linalg.norm(pos[pairs[:, 0]] - pos[pairs[:, 1]], axis=1)
    limit = float(tol_opt) if tol_opt else 0.5 * np.maximum(np.minimum(rad[pairs[:, 0]], rad[pairs[:, 1]]), 1e-6)
    used = np.zeros(len(pos), dtype=bool)
    for k in np.lexsort((pairs[:, 1], pairs[:, 0], dist)):
        i, j = pairs[k]
        if used[i] or used[j] or owner[i] == owner[j] or dist[k] > (limit if np.isscalar(limit) else limit[k]):
            continue
        if dirs[i] is not None and dirs[j] is not None and float(np.dot(dirs[i], dirs[j])) > -0.5:
            continue
        used[i] = used[j] = True
        a, b = (i, j) if i < j else (j, i)
        if (pos_tol < dist[k] <= gasket_gap and flange_like[i] and flange_like[j] and dirs[i] is not None
                and dirs[j] is not None and float(np.dot(dirs[i], dirs[j])) < -np.cos(np.radians(1.0))):
            v = pos[j] - pos[i]
            lateral = np.linalg.norm(v - np.dot(v, dirs[i]) * dirs[i])
            if lateral <= pos_tol and np.dot(v, dirs[i]) > 0:
                gaps.append((a, b, float(dist[k])))
                continue
        conns.append((a, b))
    conns.sort()  # file order, independent of the gaps
    gaps.sort()
    return conns, gaps


def _join_printed_alike(comps, conns, pos, doc: Document) -> None:
    """Two connected ports printed with the same coordinates are one point, as the file says. Restoring a
    fitting's catalogue angles moves its ports onto exact axes through its rounded CENTRE-POINT (up to the
    printed rounding off their END-POINTs), which would open a connection the file closes: a written-back
    file would re-read with gaps of half its last digit. The joined point is the restored port (their mean
    when both were restored); pipes and inline items adapt by less than the rounding."""
    printed = [read_point(doc.lines[i])[0] for c in comps for i in c["geometry"].port_lines]
    for i, j in conns:
        if not np.array_equal(printed[i], printed[j]) or np.array_equal(pos[i], pos[j]):
            continue
        moved_i, moved_j = not np.array_equal(pos[i], printed[i]), not np.array_equal(pos[j], printed[j])
        joined = 0.5 * (pos[i] + pos[j]) if moved_i == moved_j else pos[i] if moved_i else pos[j]
        pos[i] = pos[j] = joined


def _directions_from_neighbours(comps, start, dirs, partner, resolved) -> None:
    """Single-ended items and bends without a usable centre take the reversed direction of their partner;
    a return bend's two ports are made parallel and normal to its chord."""
    for k, c in enumerate(comps):
        g = c["geometry"]
        ks = list(range(start[k], start[k + 1]))
        if g.chord is not None:
            u = g.chord
            votes = []
            for side, i in enumerate(ks):
                j = partner.get(i)
                if j is not None and dirs[j] is not None:
                    n = -dirs[j] - np.dot(-dirs[j], u) * u
                    if np.linalg.norm(n) > 0.5:
                        votes.append(n / np.linalg.norm(n))
            if votes:
                d = _unit(np.sum(votes, axis=0))
                if d is not None:
                    for i in ks:
                        dirs[i] = d.copy()
                    resolved.append({"id": c["id"], "how": g.note})
            continue
        changed = False
        for i in ks:
            j = partner.get(i)
            if dirs[i] is None and j is not None and dirs[j] is not None:
                dirs[i] = -dirs[j]
                changed = True
        if changed and g.note:
            resolved.append({"id": c["id"], "how": g.note})
    for i, j in partner.items():  # partners that were themselves resolved above
        if dirs[i] is None and dirs[j] is not None:
            dirs[i] = -dirs[j]


def _olet_directions(comps, start, dirs, pos, resolved) -> None:
    """An OLET without a usable CENTRE-POINT points away from the axis of the pipe it sits on."""
    pipes = [k for k, c in enumerate(comps) if c["geometry"].kind == "pipe"]
    if not pipes:
        return
    A = np.array([pos[start[k]] for k in pipes])
    B = np.array([pos[start[k] + 1] for k in pipes])
    rad = np.array([comps[k]["geometry"].radius or 0.0 for k in pipes])
    for k, c in enumerate(comps):
        if c["geometry"].ftype != "olet":
            continue
        for i in range(start[k], start[k + 1]):
            if dirs[i] is not None:
                continue
            AB = B - A
            t = np.clip(np.einsum("ij,ij->i", pos[i] - A, AB) / np.maximum(np.einsum("ij,ij->i", AB, AB), 1e-300), 0, 1)
            foot = A + t[:, None] * AB
            d = np.linalg.norm(pos[i] - foot, axis=1)
            m = int(np.argmin(d))
            if d[m] <= 3.0 * max(rad[m], 1e-9) and d[m] > 0:
                dirs[i] = (pos[i] - foot[m]) / d[m]
                resolved.append({"id": c["id"], "how": "OLET direction from the axis of the pipe it sits on"})


def _notes(doc, geometry, held, dropped, resolved, gaps, comps, owner, left_out):
    notes = []
    if doc.unknown:
        notes.append(("pcf_unknown_keyword",
                      f"PCF keyword(s) {', '.join(doc.unknown)} are not records of the PCF specification: kept "
                      "verbatim; those with end points were aligned as generic fittings.",
                      {"keywords": doc.unknown}, "warning"))
    joints = [cid for cid, g in geometry.items() if g.kind == "joint"]
    if joints:
        notes.append(("pcf_zero_length_items",
                      f"{len(joints)} zero-length item(s) (welds, gaskets without thickness) were treated as connection "
                      "points: their neighbours were connected directly and the item written at the closed connection.",
                      {"items": joints[:200]}, "detail"))
    if held:
        notes.append(("pcf_items_held",
                      f"{len(held)} PCF item(s) could not be fully interpreted: kept verbatim and held fixed: "
                      + _first_reasons(held),
                      {"items": held[:200]}, "warning"))
    if dropped:
        notes.append(("pcf_items_unread",
                      f"{len(dropped)} PCF item(s) have no readable point: kept verbatim, not aligned: "
                      + _first_reasons(dropped),
                      {"items": dropped[:200]}, "warning"))
    if left_out:
        notes.append(("pcf_items_left_out",
                      f"{len(left_out)} PCF item(s) were left out of the alignment (kept verbatim, not moved): "
                      + _first_reasons(left_out),
                      {"items": left_out[:200]}, "warning"))
    if resolved:
        notes.append(("pcf_directions_from_neighbours",
                      f"{len(resolved)} item(s) took port directions from their neighbours or parent pipe.",
                      {"items": resolved[:200]}, "detail"))
    if gaps:
        ids = [c["id"] for c in comps]
        notes.append(("pcf_gasket_gaps",
                      f"{len(gaps)} gap(s) between facing flange faces within a gasket's thickness were kept (a rigid "
                      "spacer joins them) instead of being closed.",
                      {"gaps": [{"from": ids[owner[i]], "to": ids[owner[j]], "gap": g} for i, j, g in gaps[:200]]},
                      "warning"))
    notes.append(("pcf_items", "", {
        "id_source": doc.id_source,
        "items": [{"id": it.id, "keyword": it.keyword, "line": it.line + 1, "position_id": it.position_id}
                  for it in doc.items[:5000]]}, "detail"))
    return notes


def _record_notes(comps: list[dict]) -> list[tuple[str, str, dict, str]]:
    """A warning naming each elbow whose ANGLE or BEND-RADIUS record its points contradict (see
    :func:`_records_against_points`): it was aligned as its points say."""
    found = [{"id": c["id"], "line": c["line"], **r} for c in comps if c["geometry"].kind == "fitting"
             for r in c["geometry"].contradicted]
    if not found:
        return []
    said = "; ".join(f"line {f['record_line']}: {f['record']} {f['value']} of {f['id']} (line {f['line']}), its points "
                     f"give {f['from_points']:g} {f['unit']}" for f in found[:4]) + ("; ..." if len(found) > 4 else "")
    return [("pcf_records_contradict_points",
             f"{len(found)} record(s) of elbows or bends contradict their END-POINT and CENTRE-POINT lines ({said}): "
             "aligned as the points say. Check which of the two was mistyped.",
             {"records": found[:200]}, "warning")]


def _first_reasons(items: list[dict]) -> str:
    return "; ".join(f"line {d['line']}: {d['reason']}" for d in items[:3]) + ("; ..." if len(items) > 3 else "")


def _duplicate_notes(comps: list[dict], doc: Document) -> list[tuple[str, str, dict, str]]:
    """A warning naming items whose end points all coincide with another item's (to the printed precision): a
    block pasted twice. Only one of them can join its neighbours; the other stays where it was, unaligned."""
    q = max(doc.quantum, 1e-9)
    first: dict[tuple, dict] = {}
    pairs = []
    for c in comps:
        ports = c["geometry"].ports
        if len(ports) < 2:
            continue
        key = (c["word"],) + tuple(sorted(tuple(np.round(np.asarray(p) / (4.0 * q)).astype(np.int64).tolist())
                                          for p, _ in ports))
        if key in first:
            pairs.append({"id": c["id"], "line": c["line"], "same_as": first[key]["id"],
                          "same_as_line": first[key]["line"]})
        else:
            first[key] = c
    if not pairs:
        return []
    listed = ", ".join(f"{p['id']} (line {p['line']}) = {p['same_as']} (line {p['same_as_line']})" for p in pairs[:5])
    return [("pcf_duplicate_items",
             f"{len(pairs)} PCF item(s) have the same keyword and end points as an earlier one ({listed}"
             f"{', ...' if len(pairs) > 5 else ''}): a block written twice? Only one of each pair joins its "
             "neighbours; the other is left where it was.", {"items": pairs[:200]}, "warning")]


def _open_ends_inside_pipes(comps: list[dict], net: dict, doc: Document) -> list[tuple[str, str, dict, str]]:
    """A warning naming each pipe that runs through the open end point of another item (an olet's excepted: it sits
    on its pipe): pipes join items at their ends, never through them, so the two overlap or one of the pipe's end
    points was mistyped along its axis (a 0 for a plant coordinate): read as written, the pipe reaches past its
    neighbour and the connection between them is lost without a gap to show for it."""
    pos, owner, start, rad = net["pos"], net["owner"], net["start"], net["rad"]
    joined = np.zeros(len(pos), dtype=bool)
    for i, j in net["conns"]:
        joined[i] = joined[j] = True
    for i, j, _ in net["gaps"]:
        joined[i] = joined[j] = True
    open_ports = np.flatnonzero(~joined)
    if len(open_ports) == 0:
        return []
    tree = cKDTree(pos[open_ports])
    found = []
    for k, c in enumerate(comps):
        g = c["geometry"]
        if g.kind != "pipe" or len(g.ports) != 2:
            continue
        a, b, r = pos[start[k]], pos[start[k] + 1], float(rad[start[k]])
        length = float(np.linalg.norm(b - a))
        if not length > 2.0 * r:
            continue
        axis = (b - a) / length
        for m in tree.query_ball_point(0.5 * (a + b), 0.5 * length):
            i = open_ports[m]
            if owner[i] == k or comps[owner[i]]["geometry"].ftype == "olet":  # an olet sits on its pipe
                continue
            v = pos[i] - a
            along = float(v @ axis)
            if r < along < length - r and np.linalg.norm(v - along * axis) < r:
                found.append({"pipe": c["id"], "pipe_line": c["line"], "item": comps[owner[i]]["id"],
                              "end_point_line": comps[owner[i]]["geometry"].port_lines[i - start[owner[i]]] + 1})
    if not found:
        return []
    listed = ", ".join(f"{f['pipe']} (line {f['pipe_line']}) through the end point of {f['item']} on line "
                       f"{f['end_point_line']}" for f in found[:5])
    return [("pcf_open_end_inside_pipe",
             f"{len(found)} open end point(s) lie inside a pipe that runs past them ({listed}"
             f"{', ...' if len(found) > 5 else ''}): pipes join items at their ends, so the two overlap or one of the "
             "pipe's end points is mistyped along its axis; they are not connected. Correct the end point.",
             {"items": found[:200]}, "warning")]


# A pipe shorter than this share of its bore is no pipe cut to length (pups start at about one bore): its far END-POINT
# was typed onto, or next to, its near one
SHORT_PIPE_BORES = 0.1


def _end_points_met(doc: Document) -> tuple[cKDTree | None, np.ndarray, float]:
    """Every readable END-POINT / BRANCHn-POINT of the file (a tree over them, the item of each) and the distance
    within which two of them are one point as printed."""
    where, owner = [], []
    for k, it in enumerate(doc.items):
        for i in it.point_lines:
            if doc.lines[i].split()[0].upper() == "CENTRE-POINT":
                continue
            try:
                where.append(read_point(doc.lines[i])[0])
            except ItemProblem:
                continue
            owner.append(k)
    if not where:
        return None, np.zeros(0, dtype=int), 0.0
    P = np.array(where)
    eps = max(1e-6, 2.0 * doc.quantum) + 1e-12 * float(np.max(np.abs(P)))
    return cKDTree(P), np.array(owner), eps


def _fills_a_gap(k: int, ends: list[np.ndarray], met: tuple[cKDTree | None, np.ndarray, float]) -> bool:
    """Each of item ``k``'s two END-POINTs meets, as printed, an end point of an item the other END-POINT does not
    meet: a short pipe written to fill the gap between two items (exporters write pipes of 0.4 mm between a flange
    and a bend), whose both neighbours are joined. An END-POINT typed twice meets at both ends the items at its near
    end only (two of them where a weld or a branch joins there) and leaves the item at the real far end alone."""
    tree, owner, eps = met
    if tree is None:
        return False
    near = [{int(owner[j]) for j in tree.query_ball_point(e, eps)} - {k} for e in ends]
    return bool(near[0] - near[1]) and bool(near[1] - near[0])


def _zero_length_pipe_notes(doc: Document, geometry: dict) -> list[tuple[str, str, dict, str]]:
    """A warning naming each PIPE whose two END-POINTs are one point (to the printed digits), or lie closer than
    :data:`SHORT_PIPE_BORES` of its bore: a weld or a gasket may have no length, a pipe has one, so an end point was
    typed twice, or next to the other. Read as a joint, the pipe joins nothing at
    its real far end and the item there is left open, warned about under its own name only. A short pipe whose ends
    meet two other items (:func:`_fills_a_gap`) is none of that: nothing is left open."""
    found = []
    met = None
    for k, it in enumerate(doc.items):
        g = geometry.get(it.id)
        if g is None or g.kind not in ("joint", "pipe") or not (it.keyword == "PIPE" or it.keyword.startswith("PIPE-")):
            continue
        ends = [read_point(doc.lines[i])[0] for i in it.point_lines if doc.lines[i].split()[0].upper() == "END-POINT"]
        if len(ends) != 2:
            continue
        if g.kind == "pipe" and not (g.radius and np.linalg.norm(ends[1] - ends[0]) < SHORT_PIPE_BORES * 2.0 * g.radius):
            continue
        met = met or _end_points_met(doc)
        if _fills_a_gap(k, ends, met):
            continue
        found.append({"id": it.id, "line": it.line + 1, "end_point_lines": [i + 1 for i in it.point_lines],
                      "length": float(np.linalg.norm(ends[1] - ends[0])), "unit": doc.units or "mm"})
    if not found:
        return []
    listed = ", ".join(f"{f['id']} (line {f['line']}, end points on lines "
                       f"{' and '.join(str(n) for n in f['end_point_lines'])}: length {f['length']:g} {f['unit']})"
                       for f in found[:5]) + (", ..." if len(found) > 5 else "")
    return [("pcf_zero_length_pipe",
             f"{len(found)} PIPE(s) have two END-POINTs at one place or within a tenth of their bore ({listed}): "
             "no pipe is that short, so the pipe joins nothing at its real far end and the item there is left "
             "unconnected. One END-POINT was typed twice, or next to the other: correct it.", {"items": found[:200]}, "warning")]


# Bores of a pipe's (a gasket's, a weld's) two END-POINTs, or of two mated end points, agree to a rounding; any other
# item may change bore (a reducer, a reducing elbow or coupling, a swage nipple to 8:1, an instrument), but by no
# more than this ratio: a larger step is a bore in another unit (152.4 written in an inch-bore file, 25.4:1) or a
# dropped digit.
BORE_SHARE = 0.01
FITTING_RATIO = 10.0
BORE_KEEPING = ("PIPE", "GASKET", "WELD")  # keywords of items whose two ends share one bore


def _bore_mismatch_notes(comps: list[dict], net: dict, doc: Document) -> list[tuple[str, str, dict, str]]:
    """A warning naming the lines and both bores where an item's two END-POINTs, or two connected end points of
    neighbours, disagree in bore beyond what reducers allow. The connection is made by position either way; a bore
    typo widens or narrows how far that item's end points reach, and the size the isometric shows is wrong."""
    unit = UNITS.get(doc.header.get("UNITS-BORE", doc.header.get("UNITS-CO-ORDS", "MM")), doc.units or "mm")

    def bore(line: int) -> float | None:
        try:
            return read_point(doc.lines[line])[1]
        except ItemProblem:
            return None

    def differ(a: float | None, b: float | None, ratio: float) -> bool:
        return a is not None and b is not None and max(a, b) > ratio * min(a, b) * (1.0 + BORE_SHARE)

    found = []
    for c in comps:
        lines = [i for i in c["geometry"].port_lines if doc.lines[i].split()[0].upper() == "END-POINT"]
        if len(lines) == 2:
            a, b = bore(lines[0]), bore(lines[1])
            if differ(a, b, 1.0 if c["word"] in BORE_KEEPING else FITTING_RATIO):
                found.append({"where": "item", "id": c["id"], "line": lines[0] + 1, "bore": a,
                              "other_id": c["id"], "other_line": lines[1] + 1, "other_bore": b})
    owner, start = net["owner"], net["start"]
    for i, j in [(i, j) for i, j in net["conns"]] + [(i, j) for i, j, _ in net["gaps"]]:
        ci, cj = comps[owner[i]], comps[owner[j]]
        li, lj = ci["geometry"].port_lines[i - start[owner[i]]], cj["geometry"].port_lines[j - start[owner[j]]]
        a, b = bore(li), bore(lj)
        if differ(a, b, 1.0):
            found.append({"where": "connection", "id": ci["id"], "line": li + 1, "bore": a,
                          "other_id": cj["id"], "other_line": lj + 1, "other_bore": b})
    if not found:
        return []
    found.sort(key=lambda f: (f["line"], f["other_line"]))
    listed = "; ".join(f"line {f['line']} bore {f['bore']:g} against line {f['other_line']} bore {f['other_bore']:g} "
                       + ("(two ends of " + f["id"] + ")" if f["where"] == "item" else
                          f"({f['id']} joins {f['other_id']})") for f in found[:5]) + ("; ..." if len(found) > 5 else "")
    return [("pcf_bore_mismatch",
             f"{len(found)} pair(s) of end points disagree in bore ({unit}) where they should agree ({listed}): a "
             "pipe keeps its bore and mated ends share one (fittings may change it, by less than "
             f"{FITTING_RATIO:g}:1). A bore in another unit or a mistyped digit? Correct the bore.",
             {"pairs": found[:200], "unit": unit}, "warning")]


def _bore_size_notes(doc: Document) -> list[tuple[str, str, dict, str]]:
    """``pcf_bore_units``: most end points' bores are nominal sizes of the other unit system alone
    (:func:`pcf_bore_sizes.other_system_bores`), naming the UNITS record that states the bores' unit and the first
    such bores' lines. Under INCH, a file written in millimetres is then read 25.4 times too large, its network with
    it, and no ratio the solve checks disagrees."""
    record = "UNITS-BORE" if "UNITS-BORE" in doc.header else "UNITS-CO-ORDS"
    unit = UNITS.get(doc.header.get(record, "MM"))
    bores = []
    for it in doc.items:
        for i in it.point_lines:
            parts = doc.lines[i].split()
            if parts[0].upper() != "CENTRE-POINT" and len(parts) >= 5:
                try:
                    bore = float(parts[4])
                except ValueError:
                    continue
                if _readable_bore(bore):
                    bores.append((i + 1, bore))
    found = other_system_bores(bores, unit) if unit else None
    if found is None:
        return []
    likely, other = found
    stated_on = next((i + 1 for i in doc.unit_lines if doc.lines[i].split()[0].upper() == record), None)
    where = f"line {stated_on}: {record} {doc.header.get(record)}" if stated_on else f"{record} (not written: MM)"
    listed = ", ".join(f"line {line} ({b:g})" for line, b in other[:5]) + (", ..." if len(other) > 5 else "")
    system = ("DN sizes in millimetres and no NPS (inch) size" if likely == "mm" else
              "NPS sizes in inches and below the smallest DN (6 mm)")
    words = {"in": "inches", "mm": "millimetres"}
    coords = (" UNITS-CO-ORDS states the same unit: the coordinates, and so every length of the result, are likely "
              "off by as much." if doc.units == unit else "")
    return [("pcf_bore_units",
             f"{where} reads the bores in {words[unit]}, but {len(other)} of the {len(bores)} end points' bores are "
             f"{system} ({listed}): is the file written in {words[likely]}? Read in {words[unit]}, every bore is "
             f"{TO_MM[unit] / TO_MM[likely]:.3g} times what was meant.{coords} Correct the UNITS records.",
             {"record": record, "line": stated_on, "unit": unit, "likely_unit": likely,
              "bores": [{"line": line, "bore": b} for line, b in other[:200]], "end_points": len(bores)}, "warning")]


def _bore_notes(doc: Document) -> list[tuple[str, str, dict, str]]:
    """A warning naming the point lines whose bore (the fifth field) is written but is no positive number (or one
    beyond :data:`MAX_BORE`): such an item connects as one without a bore, with the file's typical reach (10 mm
    when none has a bore)."""
    bad = []
    for it in doc.items:
        for i in it.point_lines:
            parts = doc.lines[i].split()
            if parts[0].upper() == "CENTRE-POINT" or len(parts) < 5:
                continue
            try:
                bore = float(parts[4])
            except ValueError:
                bore = float("nan")
            if not _readable_bore(bore):
                bad.append({"id": it.id, "line": i + 1, "bore": parts[4]})
    if not bad:
        return []
    listed = ", ".join(f"line {b['line']} ({b['bore']})" for b in bad[:5]) + (", ..." if len(bad) > 5 else "")
    return [("pcf_bore_unreadable",
             f"{len(bad)} end point(s) state a bore that is no positive number, or beyond {MAX_BORE:g} ({listed}): "
             "read as no bore, so their items connect with the file's typical bore (10 mm when none is readable) and may be left "
             "unconnected; write the bore in UNITS-BORE.", {"points": bad[:200]}, "warning")]


def _missing_bore_notes(doc: Document) -> list[tuple[str, str, dict, str]]:
    """A warning naming the END-POINT / BRANCHn-POINT lines written with three numbers and no bore: such an item
    connects with the file's typical bore, and with none in the file a connection reaches only 5 mm (half of 10 mm),
    so wider gaps of a large pipe are left open."""
    bare = [{"id": it.id, "line": i + 1} for it in doc.items for i in it.point_lines
            if doc.lines[i].split()[0].upper() != "CENTRE-POINT" and len(doc.lines[i].split()) == 4]
    if not bare:
        return []
    points = sum(1 for it in doc.items for i in it.point_lines if doc.lines[i].split()[0].upper() != "CENTRE-POINT")
    listed = ", ".join(f"line {b['line']}" for b in bare[:5]) + (", ..." if len(bare) > 5 else "")
    reach = ("no end point of the file has one, so every connection reaches only as far as a 10 mm bore's" if
             len(bare) == points else "their items connect with the file's typical bore")
    return [("pcf_bore_missing",
             f"{len(bare)} of {points} end point(s) give three coordinates and no bore ({listed}): {reach}; "
             "gaps wider than that are left open. Write the bore (in UNITS-BORE) as each END-POINT's fourth number.",
             {"points": bare[:200], "end_points": points}, "warning")]


def _assumed_units_notes(doc: Document) -> list[tuple[str, str, dict, str]]:
    """A warning when no UNITS-CO-ORDS record states the coordinates' unit: read in millimetres (the PCF default),
    an inch file's gaps and tolerances would be reported 25.4 times too small without a word."""
    if "UNITS-CO-ORDS" in doc.header:
        return []
    bore = "" if "UNITS-BORE" in doc.header else " and bores"
    return [("pcf_units_assumed",
             f"The file has no UNITS-CO-ORDS record: its coordinates{bore} are read in millimetres (the PCF "
             "default), and the result's gaps, tolerances and moves are in mm. If the file is in inches or metres, "
             "add UNITS-CO-ORDS (and UNITS-BORE) to its header.",
             {"quantity": "coordinate unit", "assumed": "MM"}, "warning")]


def parse_pcf(text: str, options: dict | None) -> AlignmentRequest:
    return validated(AlignmentRequest, interpret_pcf(text, options).body)


def pcf_notes(request: AlignmentRequest) -> list[tuple[str, str, dict, str]]:
    """Report notes about the request's source PCF: (code, message, details, 'warning' | 'detail'); none for a
    request that has no PCF (a JSON one)."""
    if request.source_pcf is None:
        return []
    try:
        return interpret_pcf(request.source_pcf, request.options).notes
    except InputRejected:  # a source_pcf that does not belong to this request (edited JSON)
        return []
