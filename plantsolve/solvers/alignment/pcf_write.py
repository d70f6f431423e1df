"""PCF out: the source file with moved points rewritten, every other byte as it was read.

Items that did not move (by less than half the file's last printed digit) keep their lines
byte for byte. A moved coordinate is printed with as many decimals as the number it replaces
(the file's own precision); the two ports of a closed connection print the same string, and a
moved port joined to an unmoved one prints that one's own spelling. CENTRE-POINTs follow their
item's rigid motion, SUPPORT CO-ORDS follow their pipe sideways, zero-length items (welds) go
to the connection they sit on. The written text is read back before it is returned
(:func:`reread_check`): if the re-read model does not have the same connections, every one the
result made bit-identical with no gap and the others within tolerance, the moved values are
printed with more decimals (up to the shortest round-trip spelling).

Without a source file (JSON requests), :func:`generate_pcf` writes one from the result.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.schemas.alignment import AlignmentRequest, AlignmentResult
from plantsolve.solvers.alignment.model import build_model, connection_errors
from plantsolve.solvers.alignment.pcf import POINT_RE, ItemProblem, interpret_pcf, read_document, read_point
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.geometry import rotation

MORE_DECIMALS = (0, 1, 2, 3, 6, None)  # None: shortest spelling that reads back to the same double


def fmt(x: float) -> str:
    """Shortest decimal that reads back to the same double, at least 4 decimals, no exponent."""
    return np.format_float_positional(float(x), unique=True, trim="k", min_digits=4)


def _decimals(token: str) -> int:
    mant = token.lower().split("e")[0]
    return len(mant.split(".")[1]) if "." in mant else 0


def _spell(value: float, like: str, extra: int | None, decimals: int) -> str:
    """value printed with the file's decimals (or the token's own, if it has more), plus extra."""
    if extra is None:
        return fmt(value)
    d = max(_decimals(like), decimals) + extra
    s = f"{float(value):.{d}f}"
    return s[1:] if s.startswith("-") and float(s) == 0.0 else s


def _replace_xyz(line: str, xyz, extra: int | None, decimals: int,
                 tokens: tuple[str, str, str] | None = None) -> str:
    m = POINT_RE.match(line)
    if not m:
        return line
    g = list(m.groups())
    for n, (k, v) in enumerate(zip((3, 5, 7), xyz)):
        if tokens is not None:
            g[k] = tokens[n]
        elif float(g[k]) != float(v):  # unchanged numbers keep their original spelling
            g[k] = _spell(v, g[k], extra, decimals)
    return "".join(g)


def _tokens(line: str) -> tuple[str, str, str] | None:
    m = POINT_RE.match(line)
    return (m.group(4), m.group(6), m.group(8)) if m else None


def write_aligned_pcf(request: AlignmentRequest, result: AlignmentResult) -> str:
    if request.source_pcf is not None:
        try:
            return rewrite_pcf(request, result)
        except (InputRejected, ItemProblem):  # a source_pcf that does not belong to this request: start afresh
            pass
    return generate_pcf(request, result)


def rewrite_pcf(request: AlignmentRequest, result: AlignmentResult) -> str:
    """The source text with moved points rewritten; the first precision whose re-read keeps the model."""
    text = None
    for extra in MORE_DECIMALS:
        text = _rewrite(request, result, extra)
        if reread_check(request, result, text).ok:
            return text
    return text


@dataclass
class Reread:
    """What reading the written file back shows: ``ok`` when it keeps the aligned model; ``problems`` say
    which connection differs and by how much (printed to three significant digits, however small)."""

    ok: bool
    max_gap: float  # largest gap, on re-reading, of a connection the result closed (units)
    problems: list[str] = field(default_factory=list)


def reread_check(request: AlignmentRequest, result: AlignmentResult, text: str) -> Reread:
    """The written file read back has the same connections (cut ones may go either way), and every
    connection the result closed is closed on re-reading: one the result made bit-identical re-reads with
    no gap at all (both ends print the same string, which the format carries exactly), any other within
    the position tolerance; the angle within what the result itself left plus what printing both ends can
    turn it by (the re-read model's own tolerances, as a new upload)."""
    try:
        again = AlignmentRequest.model_validate(interpret_pcf(text, request.options).body)
        model = build_model(again)
    except (InputRejected, ValueError) as exc:
        return Reread(False, float("inf"), [f"the written file does not read back: {exc}"])
    cut = {_key(request.connections[k]) for k in result.cut_connections}
    keys = [_key(c) for c in again.connections]
    lost = ({_key(c) for c in request.connections} - cut) ^ (set(keys) - cut)
    problems = [f"connection {_name(k)} {'lost' if k not in keys else 'new'} on re-reading" for k in sorted(lost)]
    tol = float(result.report.details.get("position_tolerance", 0.0))
    closed = {_key(c): (0.0 if r.position_error == 0.0 else model.pos_tol, np.radians(r.angle_error))
              for c, r in zip(request.connections, result.connections) if not r.cut and r.position_error <= tol}
    gap, ang = connection_errors(model, model.P0, model.D0)
    max_gap = 0.0
    for k, key in enumerate(keys):
        if key not in closed:
            continue
        gap_tol, left = closed[key]
        max_gap = max(max_gap, float(gap[k]))
        if gap[k] > gap_tol:
            problems.append(f"connection {_name(key)} re-reads {gap[k]:.3g} {request.units} apart (closed in the "
                            f"aligned model; allowed {gap_tol:.3g})")
        # printing turns each of the two directions by up to the rounding over its lever (the angle tolerance
        # is that over the shorter one)
        allowed = left + 2.0 * model.ang_tol[k]
        if ang[k] > allowed:
            problems.append(f"connection {_name(key)} re-reads with an angle error of {np.degrees(ang[k]):.3g} deg "
                            f"(allowed {np.degrees(allowed):.3g})")
    return Reread(not problems, max_gap, problems)


def _name(key: tuple) -> str:
    return " - ".join(f"{cid}:{port}" for cid, port in key)


def _key(conn) -> tuple:
    return tuple(sorted((tuple(conn.from_), tuple(conn.to))))


def _rewrite(request: AlignmentRequest, result: AlignmentResult, extra: int | None) -> str:
    """The source text with the coordinates of moved points replaced, every other byte as it was."""
    text = request.source_pcf
    doc = read_document(text)
    interp = interpret_pcf(text, request.options)
    lines, endings = doc.lines, doc.endings
    quantum = doc.quantum
    dec = doc.decimals
    by_id = {c.id: c for c in result.components}
    req_by_id = {c.id: c for c in request.components}
    out = list(lines)

    def unmoved(cid: str) -> bool:
        comp, req = by_id.get(cid), req_by_id.get(cid)
        if comp is None or req is None:
            return True
        return req.fixed or comp.displacement <= 0.5 * quantum

    # a moved port closed onto an unmoved one prints that one's own spelling (no rounding step between them)
    port_line = {}
    for it in doc.items:
        g = interp.geometry.get(it.id)
        if g is not None and g.kind != "joint":
            for k, i in enumerate(g.port_lines):
                port_line[(it.id, k)] = i
    borrowed: dict[tuple[str, int], tuple[str, str, str]] = {}
    for conn, res in zip(request.connections, result.connections):
        if res.cut or res.position_error != 0.0:
            continue
        a, b = tuple(conn.from_), tuple(conn.to)
        for here, there in ((a, b), (b, a)):
            if not unmoved(here[0]) and unmoved(there[0]) and there in port_line:
                tok = _tokens(lines[port_line[there]])
                if tok is not None:
                    borrowed[here] = tok

    old = np.array([p.position for c in request.components for p in c.ports], dtype=float).reshape(-1, 3)
    new = [p.position for c in result.components for p in c.ports]
    owner = [c.id for c in request.components for _ in c.ports]
    port_key = [(c.id, j) for c in request.components for j in range(len(c.ports))]
    partner_of = {}
    for conn in request.connections:
        partner_of[tuple(conn.from_)], partner_of[tuple(conn.to)] = tuple(conn.to), tuple(conn.from_)

    def spelled(k: int):
        """How port k is printed: its own line if its item is unmoved, a borrowed spelling, or its value."""
        key = port_key[k]
        if unmoved(key[0]) and key in port_line:
            return _tokens(lines[port_line[key]])
        return borrowed.get(key)
    tree = cKDTree(old) if len(old) else None
    port_rad = np.array([c.radius or 0.0 for c in request.components for _ in c.ports])
    pipes = [(c, r) for c, r in zip(request.components, result.components) if c.kind == "pipe"]

    def motion(comp):
        tr = comp.transform
        R = rotation(tr.rotation)
        t = np.array(tr.translation)
        return lambda x: R.apply(x) + t

    for it in doc.items:
        comp = by_id.get(it.id)
        g = interp.geometry.get(it.id)
        if comp is None:
            if g is not None and g.kind == "joint" and tree is not None and it.point_lines:
                # all its points go to the aligned connection it sits on
                xyz, _ = read_point(lines[it.point_lines[0]])
                _, k = tree.query(xyz)
                other = partner_of.get(port_key[k])
                if not unmoved(owner[k]) or (other is not None and not unmoved(other[0])):
                    for i in it.point_lines:
                        out[i] = _replace_xyz(lines[i], new[k], extra, dec, spelled(k))
                continue
            for i in it.extra_lines:  # a support: follows the nearest pipe it sits on
                try:
                    xyz, _ = read_point(lines[i])
                except ItemProblem:
                    continue
                if it.keyword.startswith("END-CONNECTION") and tree is not None:
                    # a line's end marker sits on a port: it goes where that port went
                    dist, k = tree.query(xyz)
                    if dist <= 0.5 * port_rad[k] + 1e-9:
                        if not unmoved(owner[k]):
                            out[i] = _replace_xyz(lines[i], new[k], extra, dec, spelled(k))
                        continue
                host = _host_pipe(xyz, pipes)
                if host is not None and not unmoved(host.id):  # sideways with the pipe, not along it
                    moved = motion(host)(xyz)
                    u = np.array(host.ports[1].position) - np.array(host.ports[0].position)
                    u /= np.linalg.norm(u)
                    out[i] = _replace_xyz(lines[i], moved - np.dot(moved - xyz, u) * u, extra, dec)
            continue
        if unmoved(it.id) or g is None:
            continue
        for k, (line_no, port) in enumerate(zip(g.port_lines, comp.ports)):
            out[line_no] = _replace_xyz(lines[line_no], port.position, extra, dec, borrowed.get((it.id, k)))
        move = motion(comp)
        for i in list(it.point_lines) + list(it.extra_lines):  # other points (CENTRE-POINT, CO-ORDS) follow
            if i in g.port_lines:
                continue
            try:
                xyz, _ = read_point(lines[i])
            except ItemProblem:
                continue
            out[i] = _replace_xyz(lines[i], move(xyz), extra, dec)
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
