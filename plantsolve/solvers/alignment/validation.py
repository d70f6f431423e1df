"""Semantic checks of an alignment request (cross-field rules pydantic cannot express)."""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.plausibility import FAR, RADIUS_JUMP, far_ports, radius_jumps
from plantsolve.solvers.length_units import METRES
from plantsolve.solvers.base import FieldError, InputRejected

MIN_PORTS = {
    "elbow": 2, "bend": 2, "tee": 3, "cross": 4, "reducer": 2, "valve": 2,
    "flange": 1, "cap": 1, "olet": 1, "tie_in": 1, "other": 1, None: 1,
}
OUTWARD = ("elbow", "bend", "tee", "cross", "reducer", "valve", "flange")
MAX_PORTS = {"elbow": 2, "bend": 2, "tee": 3, "cross": 4, "reducer": 2, "cap": 2}  # a cap: 1 port, or 2 (Revit)


def check_input(request: AlignmentRequest) -> None:
    """Raise :class:`InputRejected` listing every bad field; return None when the request is usable."""
    errors: list[FieldError] = []
    opts = request.options
    comps = request.components
    index: dict[str, int] = {}
    cos_tol = np.cos(np.radians(opts.shape_tolerance))
    for i, comp in enumerate(comps):
        if comp.id in index:
            errors.append(FieldError(("components", i, "id"), f"duplicate component id {comp.id!r}"))
        else:
            index[comp.id] = i
    # all ports at once: the per-component rules below only look at flagged components
    counts = np.array([len(c.ports) for c in comps])
    start = np.concatenate([[0], np.cumsum(counts)])
    pos = np.array([p.position for c in comps for p in c.ports], dtype=float)
    dirs = np.array([p.direction for c in comps for p in c.ports], dtype=float)
    norms = np.linalg.norm(dirs, axis=1)
    zero = ~(norms > 1e-12)
    unit = dirs / np.where(zero, 1.0, norms)[:, None]
    bad_comp = np.zeros(len(comps), dtype=bool)
    owner = np.repeat(np.arange(len(comps)), counts)
    bad_comp[owner[zero]] = True
    for k in np.flatnonzero(zero):
        errors.append(FieldError(("components", int(owner[k]), "ports", int(k - start[owner[k]]), "direction"),
                                 "direction must be a non-zero vector"))
    is_pipe = np.array([c.kind == "pipe" for c in comps])
    two = is_pipe & (counts == 2) & ~bad_comp
    pi = np.flatnonzero(two)
    axis = pos[start[pi] + 1] - pos[start[pi]]
    length = np.linalg.norm(axis, axis=1)
    axis = axis / np.where(length > 0, length, 1.0)[:, None]
    d0, d1 = unit[start[pi]], unit[start[pi] + 1]
    not_straight = (np.einsum("ij,ij->i", d1, axis) < cos_tol) | (-np.einsum("ij,ij->i", d0, axis) < cos_tol)
    for i in np.flatnonzero(is_pipe & (counts != 2)):
        errors.append(FieldError(("components", int(i), "ports"), f"a pipe has exactly 2 ports, got {counts[i]}"))
    for i, ln, ns in zip(pi, length, not_straight):
        if not ln > 0:
            errors.append(FieldError(("components", int(i), "ports"), "a pipe's two ports are at the same point"))
        elif ns:
            errors.append(FieldError(
                ("components", int(i), "ports"),
                f"pipe ports are not collinear and opposite within {opts.shape_tolerance} deg "
                "(port directions must point out of the pipe along its axis)"))
    # catalogue fittings: every port points away from the fitting (a reversed port would make the solver
    # turn the fitting inside out to close it)
    cent = np.zeros((len(comps), 3))
    np.add.at(cent, owner, pos)
    cent /= np.maximum(counts, 1)[:, None]
    arm = pos - cent[owner]
    arm_len = np.linalg.norm(arm, axis=1)
    outward = np.einsum("ij,ij->i", arm, unit)
    typed = np.array([c.kind == "fitting" and c.type in OUTWARD for c in comps])
    inward = typed[owner] & (counts[owner] >= 2) & ~zero & (outward < -1e-9 * np.maximum(arm_len, 1e-300)) & (
        arm_len > 0)
    for k in np.flatnonzero(inward):
        errors.append(FieldError(("components", int(owner[k]), "ports", int(k - start[owner[k]]), "direction"),
                                 "a port direction must point out of the fitting (this one points into it)"))
    for i in np.flatnonzero(~is_pipe):
        comp = comps[i]
        need = MIN_PORTS.get(comp.type, 1)
        if counts[i] < need:
            errors.append(FieldError(("components", int(i), "ports"), f"a {comp.type} needs at least {need} ports, got {counts[i]}"))
        most = MAX_PORTS.get(comp.type)
        if most is not None and counts[i] > most:
            errors.append(FieldError(("components", int(i), "ports"), f"a {comp.type} has at most {most} ports, got {counts[i]}"))
    for i, comp in enumerate(comps):
        if comp.up is None or bad_comp[i]:
            continue
        up = np.array(comp.up, dtype=float)
        un = np.linalg.norm(up)
        if not un > 1e-12:
            errors.append(FieldError(("components", i, "up"), "up must be a non-zero vector"))
        elif comp.kind == "fitting" and abs(unit[start[i]] @ up) / un > np.cos(np.radians(1.0)):
            errors.append(FieldError(("components", i, "up"), "up must not be parallel to the port axis"))

    used: dict[tuple[str, int], tuple[int, str]] = {}
    joined: list[tuple[int, int]] = []
    for j, conn in enumerate(request.connections):
        ends = (("from", conn.from_), ("to", conn.to))
        ok = True
        for name, (cid, port) in ends:
            loc = ("connections", j, name)
            if cid not in index:
                errors.append(FieldError(loc, f"unknown component {cid!r}"))
                ok = False
                continue
            nports = len(request.components[index[cid]].ports)
            if not 0 <= port < nports:
                errors.append(FieldError(loc, f"component {cid!r} has no port {port} (it has {nports})"))
                ok = False
                continue
            if (cid, port) in used:
                other_j, other_name = used[(cid, port)]
                errors.append(
                    FieldError(loc, f"port {port} of {cid!r} is already used by connection {other_j} ({other_name})")
                )
                ok = False
            else:
                used[(cid, port)] = (j, name)
        if ok and conn.from_[0] == conn.to[0]:
            errors.append(FieldError(("connections", j, "to"), "a connection must join two different components"))
        elif ok:
            joined.append((index[conn.from_[0]], index[conn.to[0]]))
    errors += _radius_jumps(request, joined)
    far = _far_ports(request, pos, owner, start, joined, counts)
    if far:
        # a port far out also turns its fitting's centroid or its pipe's axis: those refusals only repeat it
        culprits = {e.loc[1] for e in far}
        errors = [e for e in errors if not (len(e.loc) > 2 and e.loc[0] == "components" and e.loc[1] in culprits
                                            and e.loc[2] == "ports")] + far

    for k, cid in enumerate(opts.fixed_components):
        if cid not in index:
            errors.append(FieldError(("options", "fixed_components", k), f"unknown component {cid!r}"))
    if errors:
        raise InputRejected(errors)


def _radius_jumps(request: AlignmentRequest, joined: list[tuple[int, int]]) -> list[FieldError]:
    """A refusal for every radius far beyond those of the components it is connected to (see
    :func:`plausibility.radius_jumps`)."""
    if not joined:
        return []
    ab = np.array(joined, dtype=np.intp)
    radius = np.array([np.nan if c.radius is None else c.radius for c in request.components], dtype=float)
    u = request.units
    return [FieldError(("components", c, "radius"), (
        f"radius {radius[c]:.4g} {u} of component {request.components[c].id!r} is more than {RADIUS_JUMP:g} times "
        f"the largest radius of the components it is connected to ({beside:.4g} {u}): connected ports share a bore "
        "(a reducer changes it a few times); a value in another unit or a wrong exponent? Correct the radius, or "
        "leave it out"), "value_error") for c, beside in radius_jumps(radius, ab[:, 0], ab[:, 1])[:50]]


def _far_ports(request: AlignmentRequest, pos: np.ndarray, owner: np.ndarray, start: np.ndarray,
               joined: list[tuple[int, int]], counts: np.ndarray) -> list[FieldError]:
    """A refusal for every port far outside its connected network (see :mod:`plausibility`)."""
    if not joined or not np.all(np.isfinite(pos)):
        return []
    ab = np.array(joined, dtype=np.intp)
    u = request.units
    pipes = np.flatnonzero(np.array([c.kind == "pipe" for c in request.components]) & (counts == 2))
    length = np.linalg.norm(pos[start[pipes] + 1] - pos[start[pipes]], axis=1)
    out = []
    for far in far_ports(pos, owner, ab[:, 0], ab[:, 1], len(request.components),
                         pipe_ends=(start[pipes], length * METRES[u]))[:50]:
        k = far["port"]
        c = int(owner[k])
        out.append(FieldError(
            ("components", c, "ports", int(k - start[c]), "position"),
            f"port {int(k - start[c])} of component {request.components[c].id!r} lies {far['distance']:.4g} {u} from "
            f"the middle of its network, more than {FAR:g} times further out than its {far['closer_in']} other "
            f"port(s) closer in (all within {far['extent']:.4g} {u}): a mistyped coordinate (a wrong digit or "
            "exponent, or a value in another unit such as m in a mm file)? Correct the position."))
    return out
