"""PCF (ISOGEN Piping Component File) in and out.

Reading: every top-level keyword block that carries END-POINT / CENTRE-POINT /
BRANCHn-POINT lines is a component (PIPE, ELBOW, BEND, TEE, CROSS, REDUCER-*, VALVE,
FLANGE, GASKET, CAP, OLET, INSTRUMENT, ...). Port directions come from the geometry
(centre to end point for elbows, tees and crosses; along the end-point axis for pipes and
inline items); single-ended items (CAP, FLANGE-BLIND) take the reversed direction of the
port they touch. Connections are inferred between end points closer than a tolerance that
face each other. Component ids are ``<KEYWORD>-<n>`` with n the block's ordinal in the file,
so the same text always gives the same ids.

Writing: the original text is rewritten line by line; only the three coordinates of the
geometric lines of moved components change (bore, end type and every other attribute stay
as they were). Numbers are printed as the shortest string that reads back to the same
double, so the two ports of a closed connection print identically.
"""

from __future__ import annotations

import re

import numpy as np
from scipy.spatial import cKDTree

from schemas.alignment import AlignmentRequest, AlignmentResult
from solvers.base import FieldError, InputRejected

POINT_KEYS = ("END-POINT", "CENTRE-POINT", "BRANCH1-POINT", "BRANCH2-POINT", "BRANCH3-POINT")
TYPE_OF = {
    "ELBOW": "elbow", "BEND": "bend", "TEE": "tee", "TEE-SET-ON": "tee", "TEE-STUB": "tee", "CROSS": "cross",
    "REDUCER-CONCENTRIC": "reducer", "REDUCER-ECCENTRIC": "reducer", "VALVE": "valve", "VALVE-ANGLE": "valve",
    "VALVE-3WAY": "valve", "FLANGE": "flange", "FLANGE-BLIND": "flange", "CAP": "cap", "OLET": "olet",
}
UNITS = {"MM": "mm", "INCH": "in", "INCHES": "in", "M": "m", "CM": "cm", "FT": "ft", "FEET": "ft"}
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_POINT_RE = re.compile(rf"^(\s*)(\S+)(\s+)({_NUM})(\s+)({_NUM})(\s+)({_NUM})(.*)$")


def _reject(msg: str) -> InputRejected:
    return InputRejected([FieldError(("file",), msg)])


def _blocks(text: str) -> tuple[list[str], list[tuple[str, int, list[int]]], dict[str, str]]:
    """Lines, component blocks (keyword, ordinal, line numbers of point lines), header values."""
    lines = text.splitlines()
    blocks: list[tuple[str, int, list[int]]] = []
    header: dict[str, str] = {}
    current: tuple[str, int, list[int]] | None = None
    ordinal = 0
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        if not line[0].isspace():
            word = line.split()[0].upper()
            parts = line.split()
            if word.startswith("UNITS-") and len(parts) > 1:
                header[word] = parts[1].upper()
            current = None
            if word in ("ISOGEN-FILES", "PIPELINE-REFERENCE", "MATERIALS", "ITEM-CODE") or word.startswith("UNITS-"):
                continue
            ordinal += 1
            current = (word, ordinal, [])
            blocks.append(current)
        elif current is not None:
            word = line.split()[0].upper()
            if word in POINT_KEYS:
                current[2].append(i)
    return lines, [b for b in blocks if b[2]], header


def _point(line: str) -> tuple[np.ndarray, float | None]:
    parts = line.split()
    try:
        xyz = np.array([float(v) for v in parts[1:4]])
    except (ValueError, IndexError) as exc:
        raise _reject(f"cannot read coordinates in line {line.strip()!r}") from exc
    bore = None
    if len(parts) > 4:
        try:
            bore = float(parts[4])
        except ValueError:
            bore = None
    if not np.all(np.isfinite(xyz)):
        raise _reject(f"non-finite coordinate in line {line.strip()!r}")
    return xyz, bore


def _unit(x: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(x)
    return x / n if n > 0 else np.zeros(3)


def _component(word: str, ordinal: int, lines: list[str], idx: list[int], bore_factor: float):
    """Ports (position, direction or None), kind, type, radius, and for each port its line."""
    pts = {}
    for i in idx:
        key = lines[i].split()[0].upper()
        pts.setdefault(key, []).append((i,) + _point(lines[i]))
    ends = pts.get("END-POINT", [])
    centre = pts.get("CENTRE-POINT", [])
    branches = [b for k in ("BRANCH1-POINT", "BRANCH2-POINT", "BRANCH3-POINT") for b in pts.get(k, [])]
    bores = [b for (_, _, b) in ends + branches if b]
    radius = 0.5 * max(bores) * bore_factor if bores else None
    ports, port_lines = [], []
    c = centre[0][1] if centre else None
    if word == "PIPE":
        if len(ends) != 2:
            raise _reject(f"{word}-{ordinal}: a PIPE needs two END-POINT lines")
        axis = _unit(ends[1][1] - ends[0][1])
        ports = [(ends[0][1], -axis), (ends[1][1], axis)]
        port_lines = [ends[0][0], ends[1][0]]
        return ports, port_lines, "pipe", None, radius
    for i, p, _ in ends + branches:
        if c is not None and np.linalg.norm(p - c) > 0:
            d = _unit(p - c)
        elif len(ends) == 2 and not branches:
            other = ends[1][1] if p is ends[0][1] else ends[0][1]
            d = _unit(p - other)
        else:
            d = None
        ports.append((p, d))
        port_lines.append(i)
    if not ports and word == "OLET":
        raise _reject(f"{word}-{ordinal}: an OLET needs a BRANCH1-POINT")
    ftype = TYPE_OF.get(word, TYPE_OF.get(word.split("-")[0], "other"))
    if ftype in ("elbow", "bend", "tee", "cross") and c is None:
        raise _reject(f"{word}-{ordinal}: a {word} needs a CENTRE-POINT to know its port directions")
    return ports, port_lines, "fitting", ftype, radius


def parse_pcf(text: str, options: dict | None) -> AlignmentRequest:
    lines, blocks, header = _blocks(text)
    if not blocks:
        raise _reject("no PCF components with END-POINT/CENTRE-POINT/BRANCH1-POINT lines were found")
    units = UNITS.get(header.get("UNITS-CO-ORDS", "MM"), None)
    if units is None:
        raise _reject(f"unsupported UNITS-CO-ORDS {header.get('UNITS-CO-ORDS')!r}")
    bore_units = UNITS.get(header.get("UNITS-BORE", header.get("UNITS-CO-ORDS", "MM")), units)
    to_mm = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8}
    bore_factor = to_mm[bore_units] / to_mm[units]
    comps = []
    for word, ordinal, idx in blocks:
        ports, _, kind, ftype, radius = _component(word, ordinal, lines, idx, bore_factor)
        comps.append({"id": f"{word}-{ordinal}", "kind": kind, "type": ftype, "radius": radius, "ports": ports})
    # infer connections: nearest facing end points within tolerance, each port used once
    pos = np.array([p for c in comps for p, _ in c["ports"]])
    owner = np.array([k for k, c in enumerate(comps) for _ in c["ports"]])
    local = np.array([j for c in comps for j in range(len(c["ports"]))])
    dirs = [d for c in comps for _, d in c["ports"]]
    rad = np.array([c["radius"] or 0.0 for c in comps])[owner]
    tol_opt = (options or {}).get("connection_tolerance")
    pairs = cKDTree(pos).query_pairs(r=float(tol_opt) if tol_opt else max(float(np.max(rad)) * 0.5, 1e-6), output_type="ndarray")
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
    for k, d in enumerate(dirs):
        if d is None:
            raise _reject(f"{comps[owner[k]]['id']}: cannot determine the direction of end point {local[k]} "
                          "(single-ended item without a connected neighbour)")
    comps_json = []
    for k, c in enumerate(comps):
        ports = [{"position": p.tolist(), "direction": dirs[np.flatnonzero(owner == k)[j]].tolist()} for j, (p, _) in enumerate(c["ports"])]
        entry = {"id": c["id"], "kind": c["kind"], "radius": c["radius"], "ports": ports}
        if c["kind"] == "fitting":
            entry["type"] = c["type"]
        comps_json.append(entry)
    fixed = set((options or {}).get("fixed_components", []))
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


def _replace_xyz(line: str, xyz) -> str:
    m = _POINT_RE.match(line)
    if not m:
        return line
    g = list(m.groups())
    for k, v in zip((3, 5, 7), xyz):
        if float(g[k]) != float(v):  # unchanged numbers keep their original spelling
            g[k] = fmt(v)
    return "".join(g)


def write_aligned_pcf(request: AlignmentRequest, result: AlignmentResult) -> str:
    if request.source_pcf is not None:
        return _rewrite(request, result)
    return _generate(request, result)


def _rewrite(request: AlignmentRequest, result: AlignmentResult) -> str:
    from scipy.spatial.transform import Rotation

    text = request.source_pcf
    lines, blocks, header = _blocks(text)
    bore_units = UNITS.get(header.get("UNITS-BORE", header.get("UNITS-CO-ORDS", "MM")), request.units)
    to_mm = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8}
    by_id = {c.id: c for c in result.components}
    out = list(lines)
    for word, ordinal, idx in blocks:
        cid = f"{word}-{ordinal}"
        comp = by_id.get(cid)
        if comp is None:
            continue
        _, port_lines, _, _, _ = _component(word, ordinal, lines, idx, to_mm[bore_units] / to_mm[request.units])
        for line_no, port in zip(port_lines, comp.ports):
            out[line_no] = _replace_xyz(lines[line_no], port.position)
        tr = comp.transform
        R = Rotation.from_quat([tr.rotation[1], tr.rotation[2], tr.rotation[3], tr.rotation[0]])
        for i in idx:  # other points (CENTRE-POINT) follow the component's rigid motion
            if i in port_lines:
                continue
            xyz, _ = _point(lines[i])
            out[i] = _replace_xyz(lines[i], R.apply(xyz) + np.array(tr.translation))
    return "\n".join(out) + ("\n" if text.endswith("\n") else "")


def _generate(request: AlignmentRequest, result: AlignmentResult) -> str:
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
