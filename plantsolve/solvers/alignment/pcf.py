"""PCF (ISOGEN Piping Component File) in and out.

Reading: every top-level keyword block that carries END-POINT / CENTRE-POINT /
BRANCHn-POINT lines is a component (PIPE, ELBOW, BEND, TEE, CROSS, REDUCER-*, VALVE,
FLANGE, GASKET, CAP, OLET, INSTRUMENT, ...). Port directions come from the geometry
(centre to end point for elbows, tees, crosses, angle valves and olets; along the end-point
axis for pipes and inline items; eccentric items take the axis of the pipes they join, since
their end points are offset by the flat side); single-ended items (CAP, FLANGE-BLIND) take the
reversed direction of the port they touch. Zero-length items (a WELD, a GASKET without
thickness, a zero-length PIPE) are connection points, not components: their neighbours are
connected directly and they are written where that connection ends up. Connections are
inferred between end points closer than a tolerance that face each other. Component ids are
``<KEYWORD>-<n>`` with n the block's ordinal in the file, so the same text always gives the
same ids. SPINDLE-DIRECTION becomes a valve's up vector.

Writing: the original text is rewritten line by line, keeping its line endings; only the
three coordinates of the geometric lines of moved components change (bore, end type and every
other attribute stay as they were); CENTRE-POINTs follow their item, SUPPORT CO-ORDS follow
their pipe sideways. Numbers are printed as the shortest string that reads back to the same
double (or with the spelling the file already uses for that value), so the two ports of a
closed connection print identically.
"""

from __future__ import annotations

import re

import numpy as np
from scipy.spatial import cKDTree

from pydantic import ValidationError

from plantsolve.schemas.alignment import AlignmentOptions, AlignmentRequest, AlignmentResult
from plantsolve.solvers.base import FieldError, InputRejected, reject
from plantsolve.solvers.geometry import angle_between, rotation

POINT_KEYS = ("END-POINT", "CENTRE-POINT", "BRANCH1-POINT", "BRANCH2-POINT", "BRANCH3-POINT")
EXTRA_KEYS = ("CO-ORDS",)  # support / instrument locations: they follow the item they sit on
TYPE_OF = {
    "ELBOW": "elbow", "BEND": "bend", "TEE": "tee", "TEE-SET-ON": "tee", "TEE-STUB": "tee", "CROSS": "cross",
    "REDUCER-CONCENTRIC": "reducer", "REDUCER-ECCENTRIC": "reducer", "VALVE": "valve", "VALVE-ANGLE": "valve",
    "VALVE-3WAY": "valve", "VALVE-MULTIWAY": "valve", "FLANGE": "flange", "FLANGE-BLIND": "flange",
    "FLANGE-REDUCING-CONCENTRIC": "flange", "FLANGE-REDUCING-ECCENTRIC": "flange", "CAP": "cap", "OLET": "olet",
}
# Keywords an ISOGEN export may contain: header records, component records, materials. Anything else is
# kept verbatim with a warning (aligned as a generic fitting when it carries end points).
KNOWN = {
    "ISOGEN-FILES", "PIPELINE-REFERENCE", "PROJECT-IDENTIFIER", "AREA", "DATE-DMY", "REVISION", "SPOOL-IDENTIFIER",
    "MATERIALS", "ITEM-CODE", "PIPE", "PIPE-FIXED", "PIPE-BLOCK-FIXED", "PIPE-BLOCK-VARIABLE", "ELBOW", "BEND",
    "ELBOW-TEE", "TEE", "TEE-SET-ON", "TEE-STUB", "CROSS", "CROSS-SET-ON", "REDUCER-CONCENTRIC", "REDUCER-ECCENTRIC",
    "VALVE", "VALVE-ANGLE", "VALVE-3WAY", "VALVE-4WAY", "VALVE-MULTIWAY", "FLANGE", "FLANGE-BLIND",
    "FLANGE-REDUCING-CONCENTRIC", "FLANGE-REDUCING-ECCENTRIC", "GASKET", "WELD", "BOLT", "CAP", "OLET", "COUPLING",
    "UNION", "INSTRUMENT", "INSTRUMENT-ANGLE", "INSTRUMENT-3WAY", "INSTRUMENT-DIAL", "SUPPORT", "FILTER", "TRAP",
    "MISC-COMPONENT", "LAP-JOINT-STUBEND", "LAP-JOINT-RING", "ADAPTER", "BLIND", "SPECTACLE-BLIND", "SPACER",
    "PLUG", "NIPPLE", "SWAGE", "HOSE", "CLAMP", "END-CONNECTION-PIPELINE", "END-CONNECTION-EQUIPMENT",
    "END-CONNECTION-NULL", "END-POSITION-OPEN", "END-POSITION-CLOSED", "END-POSITION-NULL", "MESSAGE-SQUARE",
    "MESSAGE-CIRCLE", "MESSAGE-ROUND", "FLOW-ARROW", "DIMENSION", "TEXT", "LOCATION-POINT", "ISO-SPLIT-POINT",
    "FIELD-FIT-WELD", "TAPPING", "TAP-CONNECTION",
}
# ISOGEN spindle directions (plant axes: east = +x, north = +y, up = +z)
SPINDLE = {"UP": (0.0, 0.0, 1.0), "DOWN": (0.0, 0.0, -1.0), "NORTH": (0.0, 1.0, 0.0), "SOUTH": (0.0, -1.0, 0.0),
           "EAST": (1.0, 0.0, 0.0), "WEST": (-1.0, 0.0, 0.0)}
HEADER = ("ISOGEN-FILES", "PIPELINE-REFERENCE", "MATERIALS", "ITEM-CODE")
UNITS = {"MM": "mm", "MILLIMETRE": "mm", "MILLIMETRES": "mm", "MILLIMETER": "mm", "MILLIMETERS": "mm",
         "INCH": "in", "INCHES": "in", "IN": "in", "INCH-FRACTION": "in", "M": "m", "METRE": "m", "METRES": "m",
         "CM": "cm", "FT": "ft", "FEET": "ft"}
TO_MM = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8}
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_POINT_RE = re.compile(rf"^(\s*)(\S+)(\s+)({_NUM})(\s+)({_NUM})(\s+)({_NUM})(.*)$")
_EOL = re.compile(r"(\r\n|\r|\n)")


def split_lines(text: str) -> tuple[list[str], list[str]]:
    """Line contents and their own line endings (CRLF, LF or CR kept as found, '' for the last)."""
    parts = _EOL.split(text)
    contents, endings = parts[0::2], parts[1::2] + [""]
    if contents and contents[-1] == "" and len(contents) > 1:
        contents.pop()
        endings.pop()
    return contents, endings


def _is_known(word: str) -> bool:
    return (word in KNOWN or word.startswith(("UNITS-", "ATTRIBUTE", "REDUCER-", "VALVE-", "INSTRUMENT-", "FLANGE-"))
            or word.endswith("OLET"))


def _blocks(text: str):
    """Lines, component blocks (keyword, ordinal, point line numbers, CO-ORDS line numbers), header values,
    and the top-level keywords seen. A block is a line starting in column 0 plus its indented lines."""
    lines, _ = split_lines(text)
    blocks: list[tuple[str, int, list[int], list[int]]] = []
    header: dict[str, str] = {}
    words: list[str] = []
    spindle: dict[int, str] = {}  # block ordinal -> SPINDLE-DIRECTION word (valve stems)
    current = None
    ordinal = 0
    for i, line in enumerate(lines):
        parts = line.split()
        if not parts:
            continue
        word = parts[0].upper()
        if not line[0].isspace():
            words.append(word)
            if word.startswith("UNITS-") and len(parts) > 1:
                header[word] = parts[1].upper()
            current = None
            if word in HEADER or word.startswith("UNITS-"):
                continue
            ordinal += 1
            current = (word, ordinal, [], [])
            blocks.append(current)
        elif current is not None:
            if word in POINT_KEYS:
                current[2].append(i)
            elif word in EXTRA_KEYS:
                current[3].append(i)
            elif word == "SPINDLE-DIRECTION" and len(parts) > 1:
                spindle[current[1]] = parts[1].upper()
    return lines, blocks, header, words, spindle


def _point(line: str) -> tuple[np.ndarray, float | None]:
    parts = line.split()
    try:
        xyz = np.array([float(v) for v in parts[1:4]])
    except (ValueError, IndexError) as exc:
        raise reject(f"cannot read coordinates in line {line.strip()!r}") from exc
    bore = None
    if len(parts) > 4:
        try:
            bore = float(parts[4])
        except ValueError:
            bore = None
        if bore is not None and not (np.isfinite(bore) and bore > 0):
            bore = None
    if not np.all(np.isfinite(xyz)):
        raise reject(f"non-finite coordinate in line {line.strip()!r}")
    return xyz, bore


def _unit(x: np.ndarray) -> np.ndarray | None:
    n = np.linalg.norm(x)
    return x / n if n > 0 else None


def _coincident(points: list[np.ndarray]) -> bool:
    """All points at one place (up to print rounding): a zero-length item such as a weld."""
    P = np.array(points)
    eps = 1e-6 + 1e-12 * float(np.max(np.abs(P)))
    return bool(np.max(np.linalg.norm(P - P[0], axis=1)) <= eps)


def _component(word: str, ordinal: int, lines: list[str], idx: list[int], bore_factor: float, snap: bool = False):
    """Ports (position, direction or None), kind, type, radius, and for each port its line.

    kind 'joint' marks a zero-length item (a weld, a zero-thickness gasket, a zero-length pipe): all its
    points coincide, so it has no axis of its own. It is not a solver component but a connection point:
    the items on both sides connect to each other through it, and its points are written at the
    aligned position of that connection."""
    pts: dict[str, list] = {}
    for i in idx:
        key = lines[i].split()[0].upper()
        pts.setdefault(key, []).append((i,) + _point(lines[i]))
    ends = pts.get("END-POINT", [])
    centre = pts.get("CENTRE-POINT", [])
    branches = [b for k in ("BRANCH1-POINT", "BRANCH2-POINT", "BRANCH3-POINT") for b in pts.get(k, [])]
    bores = [b for (_, _, b) in ends + branches if b]
    radius = 0.5 * max(bores) * bore_factor if bores else None
    every = [p for _, p, _ in ends + branches + centre]
    if (len(every) >= 2 and _coincident(every) and not (centre and branches)) or (
            word in ("WELD", "GASKET") and len(every) == 1):
        return [], [i for i, _, _ in ends + branches], "joint", None, radius
    c = centre[0][1] if centre else None
    if word == "PIPE" or word.startswith("PIPE-"):
        if len(ends) != 2:
            raise reject(f"{word}-{ordinal}: a {word} needs two END-POINT lines, found {len(ends)}")
        axis = _unit(ends[1][1] - ends[0][1])
        ports = [(ends[0][1], -axis), (ends[1][1], axis)]
        return ports, [ends[0][0], ends[1][0]], "pipe", None, radius
    if c is not None and len(ends) == 2 and not branches:
        # an inline item that also carries a CENTRE-POINT (instrument, some valves): if the centre is on the
        # end-point line, the ports are exactly opposite along it (a rounded centre must not put a kink in)
        e0, e1 = ends[0][1], ends[1][1]
        span = float(np.linalg.norm(e1 - e0))
        u = (e1 - e0) / span if span > 0 else None
        if u is not None and np.linalg.norm((c - e0) - np.dot(c - e0, u) * u) <= 1e-3 * span:
            c = None
    ports, port_lines = [], []
    for k, (i, p, _) in enumerate(ends + branches):
        d = _unit(p - c) if c is not None else None
        if d is None and len(ends) == 2 and k < 2:  # inline item: along its end-point axis
            d = _unit(p - ends[1 - k][1])
        ports.append((p, d))
        port_lines.append(i)
    if not ports:
        raise reject(f"{word}-{ordinal}: no END-POINT or BRANCH1-POINT line (a {word} needs at least one)")
    ftype = TYPE_OF.get(word)
    if ftype is None:
        ftype = "olet" if word.endswith("OLET") else TYPE_OF.get(word.split("-")[0], "other")
    need = {"tee": 3, "cross": 4, "elbow": 2, "bend": 2, "reducer": 2, "valve": 2}.get(ftype, 1)
    if len(ports) < need:  # set-on tees and the like: only the branch is a port
        ftype = "olet" if len(ports) == 1 else "other"
    if ftype in ("elbow", "bend") and c is None:
        raise reject(f"{word}-{ordinal}: a {word} needs a CENTRE-POINT to know its port directions")
    if snap and c is not None and ftype in ("elbow", "bend", "tee", "cross") and all(d is not None for _, d in ports):
        ports = _snap_catalogue(ports, c, _quantum([lines[i] for i in idx]))
    return ports, port_lines, "fitting", ftype, radius


# angles between port directions of catalogue fittings: 180 - (90, 45, 60, 30, 22.5, 11.25 elbows), 90, 180
STANDARD_ANGLES = np.radians([0.0, 90.0, 135.0, 120.0, 150.0, 157.5, 168.75, 180.0, 45.0, 60.0])


def _cos_sin(angle: float) -> tuple[float, float]:
    """cos and sin, exact at multiples of 45 degrees (so snapped right angles have exact zeros)."""
    k = angle / (np.pi / 4)
    if abs(k - round(k)) < 1e-12:
        h = np.sqrt(0.5)
        return [(1.0, 0.0), (h, h), (0.0, 1.0), (-h, h), (-1.0, 0.0)][int(round(k)) % 8] if 0 <= round(k) <= 4 else (
            float(np.cos(angle)), float(np.sin(angle)))
    return float(np.cos(angle)), float(np.sin(angle))


def _straight(angle: float | None) -> bool:
    return angle is not None and abs(angle - np.pi) < 1e-9


def _quantum(point_lines: list[str]) -> float:
    """Half the last printed digit of the coordinates: how far rounding may have moved a point."""
    decimals = 0
    for line in point_lines:
        for tok in line.split()[1:4]:
            mant = tok.lower().split("e")[0]
            decimals = max(decimals, len(mant.split(".")[1]) if "." in mant else 0)
    return 0.5 * 10.0 ** -decimals


def _snap_catalogue(ports, c: np.ndarray, quantum: float):
    """Catalogue fittings have exact angles (90, 45, 22.5 ... degrees; run ports exactly opposite), but a PCF
    prints coordinates rounded, which bends them by up to ~quantum / arm. Angles within that rounding of a
    multiple of 0.25 degree are restored exactly; otherwise loops of such fittings could never close."""
    P = [p for p, _ in ports]
    D = [d for _, d in ports]
    arm = [float(np.linalg.norm(p - c)) for p in P]
    if min(arm) <= 0:
        return ports
    slack = 3.0 * 2.0 * np.sqrt(3.0) * quantum / min(arm) + 1e-12  # radians
    # already exact up to the float spacing of the coordinates (e.g. a file this solver wrote): leave the bits
    exact = 64 * np.finfo(float).eps * max(1.0, float(np.max(np.abs(np.concatenate([c, *P]))))) / min(arm)

    def nice(angle: float) -> float | None:
        std = STANDARD_ANGLES[np.argmin(np.abs(STANDARD_ANGLES - angle))]
        if abs(std - angle) <= slack:
            return float(std)
        if slack < np.radians(0.05):  # fine print: any quarter degree (bends) is as good a catalogue angle
            target = np.radians(0.25) * round(np.degrees(angle) / 0.25)
            return float(target) if abs(target - angle) <= slack else None
        return None

    def towards(axis: np.ndarray, d: np.ndarray) -> np.ndarray:
        """d with its angle to the axis snapped (in the plane of axis and d)."""
        ang = angle_between(axis, d)
        tgt = nice(ang)
        e = d - (axis @ d) * axis
        n = np.linalg.norm(e)
        if tgt is None or n == 0 or abs(tgt - ang) <= exact:
            return d
        e /= n
        c_, s_ = _cos_sin(tgt)
        return c_ * axis + s_ * e

    if len(D) == 2:  # elbow / bend: symmetric about the bisector
        beta = angle_between(D[0], D[1])
        tgt = nice(beta)
        b, e = D[0] + D[1], D[1] - D[0]
        if tgt is not None and abs(tgt - beta) > exact and np.linalg.norm(b) > 0 and np.linalg.norm(e) > 0:
            b, e = b / np.linalg.norm(b), e / np.linalg.norm(e)
            c_, s_ = _cos_sin(tgt / 2)
            D = [c_ * b - s_ * e, c_ * b + s_ * e]
    else:  # tee / cross: run END-POINTs opposite, branches at exact angles to the run
        run = angle_between(D[0], D[1])
        straight = _straight(nice(run))
        a = (D[1] - D[0]) / np.linalg.norm(D[1] - D[0]) if straight else D[1]
        D[2] = towards(a, D[2])
        if len(D) > 3:
            opp = angle_between(D[2], D[3])
            if not (np.pi - opp <= exact and D[2] is ports[2][1]):
                D[3] = -D[2] if _straight(nice(opp)) else towards(a, D[3])
        if straight and (np.pi - run > exact or any(d is not d_in for d, (_, d_in) in zip(D[2:], ports[2:]))):
            D[0], D[1] = -a, a
    # the ports of a restored fitting move onto their exact catalogue axes through the centre (rounding also
    # put them a little off those axes, which would leave loops of such fittings out of plane)
    if all(d is d_in for d, (_, d_in) in zip(D, ports)):
        return ports
    return [(c + r * d, d) for r, d in zip(arm, D)]


def _bore_factor(header: dict[str, str], units: str) -> float:
    bore_units = UNITS.get(header.get("UNITS-BORE", header.get("UNITS-CO-ORDS", "MM")), units)
    return TO_MM[bore_units] / TO_MM[units]


def pcf_notes(text: str) -> list[tuple[str, str, dict]]:
    """Warnings about a PCF's content: (code, message, details)."""
    lines, blocks, header, words, _ = _blocks(text)
    units = UNITS.get(header.get("UNITS-CO-ORDS", "MM"), "mm")
    factor = _bore_factor(header, units)
    unknown = sorted({w for w in words if not _is_known(w)})
    notes = []
    if unknown:
        notes.append(("pcf_unknown_keyword",
                      f"PCF keyword(s) {', '.join(unknown)} are not known ISOGEN records: kept verbatim; those with "
                      "end points were aligned as generic fittings.", {"keywords": unknown}))
    joints = []
    for word, ordinal, idx, _ in blocks:
        if idx:
            try:
                if _component(word, ordinal, lines, idx, factor)[2] == "joint":
                    joints.append(f"{word}-{ordinal}")
            except InputRejected:
                pass
    if joints:
        notes.append(("pcf_zero_length_items",
                      f"{len(joints)} zero-length item(s) (welds, gaskets without thickness) were treated as connection "
                      "points: their neighbours were connected directly and the item written at the closed connection.",
                      {"items": joints[:200]}))
    return notes


def _options(options) -> AlignmentOptions:
    """The upload's options, validated first: they decide how the file is read."""
    if options is not None and not isinstance(options, dict):
        raise InputRejected([FieldError(("options",), "options must be an object")])
    try:
        return AlignmentOptions.model_validate(options or {})
    except ValidationError as exc:
        raise InputRejected([FieldError(("options",) + tuple(e["loc"]), e["msg"]) for e in exc.errors()]) from exc


def parse_pcf(text: str, options: dict | None) -> AlignmentRequest:
    opts = _options(options)
    lines, blocks, header, _, spindle = _blocks(text)
    units = UNITS.get(header.get("UNITS-CO-ORDS", "MM"), None)
    if units is None:
        raise reject(f"unsupported UNITS-CO-ORDS {header.get('UNITS-CO-ORDS')!r}")
    bore_factor = _bore_factor(header, units)
    comps = []
    for word, ordinal, idx, _ in blocks:
        if not idx:
            continue
        ports, _, kind, ftype, radius = _component(word, ordinal, lines, idx, bore_factor,
                                                   snap=f"{word}-{ordinal}" not in opts.fixed_components)
        if kind != "joint":
            comps.append({"id": f"{word}-{ordinal}", "word": word, "up": SPINDLE.get(spindle.get(ordinal, "")), "kind": kind, "type": ftype, "radius": radius, "ports": ports})
    if not comps:
        raise reject("no PCF components with END-POINT/CENTRE-POINT/BRANCH1-POINT lines were found")
    # infer connections: nearest facing end points within tolerance, each port used once
    counts = np.array([len(c["ports"]) for c in comps])
    start = np.concatenate([[0], np.cumsum(counts)])
    pos = np.array([p for c in comps for p, _ in c["ports"]])
    owner = np.repeat(np.arange(len(comps)), counts)
    local = np.arange(len(pos)) - start[owner]
    dirs = [d for c in comps for _, d in c["ports"]]
    known = [c["radius"] for c in comps if c["radius"]]
    # a component without a readable bore connects like a typical one of the file (10 mm if none has one)
    typical = float(np.median(known)) if known else 10.0 / TO_MM[units]
    rad = np.array([c["radius"] or typical for c in comps])[owner]
    tol_opt = opts.connection_tolerance
    reach = float(tol_opt) if tol_opt else max(float(np.max(rad)) * 0.5, 1e-6)
    pairs = cKDTree(pos).query_pairs(r=reach, output_type="ndarray")
    conns = []
    if len(pairs):
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
            conns.append((min(i, j), max(i, j)))
        conns.sort()  # file order, independent of the gaps
    for i, j in conns:  # single-ended items take the reversed direction of their partner
        if dirs[i] is None and dirs[j] is not None:
            dirs[i] = -dirs[j]
        elif dirs[j] is None and dirs[i] is not None:
            dirs[j] = -dirs[i]
    # An eccentric item's end points are offset sideways (flat side), so the line through them is not its
    # axis: its ports take the axis of the pipes they join (their mean when both sides are connected).
    partner = {}
    for i, j in conns:
        partner[i], partner[j] = j, i
    for k, c in enumerate(comps):
        if "ECCENTRIC" in c["word"] and len(c["ports"]) == 2:
            i0, i1 = start[k], start[k] + 1
            n0 = -dirs[partner[i0]] if i0 in partner and dirs[partner[i0]] is not None else None
            n1 = -dirs[partner[i1]] if i1 in partner and dirs[partner[i1]] is not None else None
            axis = _unit(n1 - n0) if n0 is not None and n1 is not None else n1 if n1 is not None else (
                -n0 if n0 is not None else None)
            if axis is not None:
                dirs[i0], dirs[i1] = -axis, axis
    for k, d in enumerate(dirs):
        if d is None:
            raise reject(f"{comps[owner[k]]['id']}: cannot determine the direction of end point {local[k]} "
                          "(single-ended item without a connected neighbour)")
    comps_json = []
    for k, c in enumerate(comps):
        ports = [{"position": p.tolist(), "direction": dirs[start[k] + j].tolist()} for j, (p, _) in enumerate(c["ports"])]
        entry = {"id": c["id"], "kind": c["kind"], "radius": c["radius"], "ports": ports}
        if c["kind"] == "fitting":
            entry["type"] = c["type"]
            if c["up"] is not None and len(ports) == 2:
                # a stem along the valve axis is no up vector (and would be rejected)
                axis = np.array(ports[1]["position"]) - np.array(ports[0]["position"])
                n = np.linalg.norm(axis)
                if n > 0 and abs(np.dot(axis / n, c["up"])) < np.cos(np.radians(10.0)):
                    entry["up"] = list(c["up"])
        comps_json.append(entry)
    fixed = set(opts.fixed_components)
    for entry in comps_json:
        entry["fixed"] = entry["id"] in fixed
    body = {
        "units": units,
        "components": comps_json,
        "connections": [{"from": [comps[owner[i]]["id"], int(local[i])], "to": [comps[owner[j]]["id"], int(local[j])]} for i, j in conns],
        "options": options or {},
        "source_pcf": text,
    }
    return AlignmentRequest.model_validate(body)


def fmt(x: float) -> str:
    """Shortest decimal that reads back to the same double, at least 4 decimals, no exponent."""
    return np.format_float_positional(float(x), unique=True, trim="k", min_digits=4)


def _replace_xyz(line: str, xyz, spelling: dict[float, str]) -> str:
    m = _POINT_RE.match(line)
    if not m:
        return line
    g = list(m.groups())
    for k, v in zip((3, 5, 7), xyz):
        if float(g[k]) != float(v):  # unchanged numbers keep their original spelling
            # a value that appears in the file (e.g. the fixed partner of a closed connection) prints the same way
            g[k] = spelling.get(float(v)) or fmt(v)
    return "".join(g)


def write_aligned_pcf(request: AlignmentRequest, result: AlignmentResult) -> str:
    if request.source_pcf is not None:
        try:
            return _rewrite(request, result)
        except InputRejected:  # a source_pcf that does not belong to this request (edited JSON): start afresh
            pass
    return generate_pcf(request, result)


def _rewrite(request: AlignmentRequest, result: AlignmentResult) -> str:
    """The source text with the coordinates of moved points replaced, every other byte as it was."""
    text = request.source_pcf
    lines, blocks, header, _, _ = _blocks(text)
    _, endings = split_lines(text)
    factor = _bore_factor(header, request.units)
    spelling: dict[float, str] = {}
    for word, _, idx, extra in blocks:
        for i in idx:
            m = _POINT_RE.match(lines[i])
            if m:
                for k in (3, 5, 7):
                    spelling.setdefault(float(m.group(k + 1)), m.group(k + 1))
    by_id = {c.id: c for c in result.components}
    req_by_id = {c.id: c for c in request.components}
    out = list(lines)

    # every aligned port, located by its input position: zero-length items and supports find theirs
    old = np.array([p.position for c in request.components for p in c.ports], dtype=float)
    new = [p.position for c in result.components for p in c.ports]
    tree = cKDTree(old) if len(old) else None
    port_rad = np.array([c.radius or 0.0 for c in request.components for _ in c.ports])
    pipes = [(c, r) for c, r in zip(request.components, result.components) if c.kind == "pipe"]

    def motion(comp):
        tr = comp.transform
        R = rotation(tr.rotation)
        t = np.array(tr.translation)
        return lambda x: R.apply(x) + t

    for word, ordinal, idx, extra in blocks:
        cid = f"{word}-{ordinal}"
        comp = by_id.get(cid)
        if comp is None:
            if idx and tree is not None:
                _, port_lines, kind, _, _ = _component(word, ordinal, lines, idx, factor)
                if kind == "joint":  # all its points go to the aligned connection it sits on
                    xyz, _ = _point(lines[idx[0]])
                    _, k = tree.query(xyz)
                    for i in idx:
                        out[i] = _replace_xyz(lines[i], new[k], spelling)
                    continue
            for i in extra:  # a support: follows the nearest pipe it sits on
                xyz, _ = _point(lines[i])
                if word.startswith("END-CONNECTION") and tree is not None:
                    # a line's end marker sits on a port: it goes where that port went
                    dist, k = tree.query(xyz)
                    if dist <= 0.5 * port_rad[k] + 1e-9:
                        out[i] = _replace_xyz(lines[i], new[k], spelling)
                        continue
                host = _host_pipe(xyz, pipes)
                if host is not None:  # sideways with the pipe; along it the support stays where it stands
                    moved = motion(host)(xyz)
                    u = np.array(host.ports[1].position) - np.array(host.ports[0].position)
                    u /= np.linalg.norm(u)
                    out[i] = _replace_xyz(lines[i], moved - np.dot(moved - xyz, u) * u, spelling)
            continue
        _, port_lines, _, _, _ = _component(word, ordinal, lines, idx, factor)
        for line_no, port in zip(port_lines, comp.ports):
            out[line_no] = _replace_xyz(lines[line_no], port.position, spelling)
        if req_by_id[cid].fixed:
            continue
        move = motion(comp)
        for i in list(idx) + list(extra):  # other points (CENTRE-POINT, CO-ORDS) follow the rigid motion
            if i in port_lines:
                continue
            xyz, _ = _point(lines[i])
            out[i] = _replace_xyz(lines[i], move(xyz), spelling)
    return "".join(a + b for a, b in zip(out, endings))


def _host_pipe(xyz: np.ndarray, pipes):
    """The pipe whose axis segment is nearest to a point, if the point is within two radii of it."""
    if not pipes:
        return None
    A = np.array([c.ports[0].position for c, _ in pipes], dtype=float)
    AB = np.array([c.ports[1].position for c, _ in pipes], dtype=float) - A
    rad = np.array([c.radius or 0.0 for c, _ in pipes])
    t = np.clip(np.einsum("ij,ij->i", xyz - A, AB) / np.maximum(np.einsum("ij,ij->i", AB, AB), 1e-300), 0.0, 1.0)
    d = np.linalg.norm(xyz - (A + t[:, None] * AB), axis=1)
    k = int(np.argmin(d))
    return pipes[k][1] if d[k] <= 2.0 * rad[k] + 1e-9 else None


def generate_pcf(request: AlignmentRequest, result: AlignmentResult) -> str:
    """A PCF written from the result alone (JSON requests, or a source PCF that does not match)."""
    scale = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 1.0, "ft": 12.0}[request.units]
    unit = "INCH" if request.units in ("in", "ft") else "MM"
    out = ["ISOGEN-FILES ISOGEN.FLS", f"UNITS-BORE {unit}", f"UNITS-CO-ORDS {unit}", "PIPELINE-REFERENCE plantsolve-aligned"]
    keyword = {"elbow": "ELBOW", "bend": "BEND", "tee": "TEE", "cross": "CROSS", "reducer": "REDUCER-CONCENTRIC",
               "valve": "VALVE", "flange": "FLANGE", "cap": "CAP", "olet": "OLET"}
    for comp, res in zip(request.components, result.components):
        bore = 2 * comp.radius * scale if comp.radius else 0.0
        P = [np.array(p.position) * scale for p in res.ports]
        D = [np.array(p.direction) for p in res.ports]
        word = "PIPE" if comp.kind == "pipe" else keyword.get(comp.type or "", "MISC-COMPONENT")
        out.append(word)
        out.append(f"    COMPONENT-IDENTIFIER {comp.id}")
        if word == "OLET":
            ends, branches = [], list(range(len(P)))
        elif len(P) >= 3:
            # the most opposite pair is the run, the rest are branches
            best = min(((i, j) for i in range(len(P)) for j in range(i + 1, len(P))), key=lambda ij: float(D[ij[0]] @ D[ij[1]]))
            ends = list(best)
            branches = [k for k in range(len(P)) if k not in best]
        else:
            ends, branches = list(range(len(P))), []
        for k in ends:
            out.append(f"    END-POINT {fmt(P[k][0])} {fmt(P[k][1])} {fmt(P[k][2])} {fmt(bore)}")
        if comp.kind == "fitting" and len(P) >= 2 and not all(abs(float(D[0] @ d)) > 1 - 1e-9 for d in D):
            # centre = point closest to all port axes
            A = sum(np.eye(3) - np.outer(d, d) for d in D)
            b = sum((np.eye(3) - np.outer(d, d)) @ p for p, d in zip(P, D))
            c = np.linalg.lstsq(A, b, rcond=None)[0]
            out.append(f"    CENTRE-POINT {fmt(c[0])} {fmt(c[1])} {fmt(c[2])}")
        elif word == "OLET":
            c = P[0] - D[0] * (comp.radius or 0.0)
            out.append(f"    CENTRE-POINT {fmt(c[0])} {fmt(c[1])} {fmt(c[2])}")
        for n, k in enumerate(branches, start=1):
            out.append(f"    BRANCH{n}-POINT {fmt(P[k][0])} {fmt(P[k][1])} {fmt(P[k][2])} {fmt(bore)}")
    return "\n".join(out) + "\n"
