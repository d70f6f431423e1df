"""Semantic checks of an alignment request (cross-field rules pydantic cannot express)."""

from __future__ import annotations

import numpy as np

from schemas.alignment import AlignmentRequest
from solvers.base import FieldError, InputRejected

MIN_PORTS = {
    "elbow": 2, "bend": 2, "tee": 3, "cross": 4, "reducer": 2, "valve": 2,
    "flange": 1, "cap": 1, "olet": 1, "tie_in": 1, "other": 1, None: 1,
}
MAX_PORTS = {"elbow": 2, "bend": 2, "tee": 3, "cross": 4, "reducer": 2, "cap": 1}


def check_input(request: AlignmentRequest) -> None:
    """Raise :class:`InputRejected` listing every bad field; return None when the request is usable."""
    errors: list[FieldError] = []
    opts = request.options
    index: dict[str, int] = {}
    cos_tol = np.cos(np.radians(opts.shape_tolerance))
    for i, comp in enumerate(request.components):
        loc = ("components", i)
        if comp.id in index:
            errors.append(FieldError(loc + ("id",), f"duplicate component id {comp.id!r}"))
        else:
            index[comp.id] = i
        dirs = np.array([p.direction for p in comp.ports], dtype=float)
        pos = np.array([p.position for p in comp.ports], dtype=float)
        norms = np.linalg.norm(dirs, axis=1)
        for k in np.flatnonzero(~(norms > 1e-12)):
            errors.append(FieldError(loc + ("ports", int(k), "direction"), "direction must be a non-zero vector"))
        if np.any(~(norms > 1e-12)):
            continue
        dirs = dirs / norms[:, None]
        if comp.kind == "pipe":
            if len(comp.ports) != 2:
                errors.append(FieldError(loc + ("ports",), f"a pipe has exactly 2 ports, got {len(comp.ports)}"))
                continue
            axis = pos[1] - pos[0]
            length = float(np.linalg.norm(axis))
            if not length > 0:
                errors.append(FieldError(loc + ("ports",), "a pipe's two ports are at the same point"))
                continue
            axis /= length
            if dirs[1] @ axis < cos_tol or -(dirs[0] @ axis) < cos_tol:
                errors.append(
                    FieldError(
                        loc + ("ports",),
                        f"pipe ports are not collinear and opposite within {opts.shape_tolerance} deg "
                        "(port directions must point out of the pipe along its axis)",
                    )
                )
        else:
            need = MIN_PORTS.get(comp.type, 1)
            if len(comp.ports) < need:
                errors.append(
                    FieldError(loc + ("ports",), f"a {comp.type} needs at least {need} ports, got {len(comp.ports)}")
                )
            most = MAX_PORTS.get(comp.type)
            if most is not None and len(comp.ports) > most:
                errors.append(FieldError(loc + ("ports",), f"a {comp.type} has at most {most} ports, got {len(comp.ports)}"))
        if comp.up is not None:
            up = np.array(comp.up, dtype=float)
            un = np.linalg.norm(up)
            if not un > 1e-12:
                errors.append(FieldError(loc + ("up",), "up must be a non-zero vector"))
            elif comp.kind == "fitting" and abs(dirs[0] @ up) / un > np.cos(np.radians(1.0)):
                errors.append(FieldError(loc + ("up",), "up must not be parallel to the port axis"))

    used: dict[tuple[str, int], tuple[int, str]] = {}
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

    for k, cid in enumerate(opts.fixed_components):
        if cid not in index:
            errors.append(FieldError(("options", "fixed_components", k), f"unknown component {cid!r}"))
    if errors:
        raise InputRejected(errors)
