"""What a PCF's items must still satisfy once interpreted, item by item (never the whole file).

An exporter can draw things with pipe fittings that are no piping: a converter draws a valve's
handwheel as two 180 degree ``BEND`` items sharing both end points. And an item can be read
without fault yet fail a rule of the model (a port pointing into its fitting, too many ports):
such items are held fixed or left out and listed with their line and reason, never a 422 for
the file.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from pydantic import ValidationError
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.validation import check_input
from plantsolve.solvers.base import InputRejected

TURNING = ("elbow", "bend")


def closed_rings(ports: list[list[np.ndarray]], turning: list[bool], eps: float) -> list[list[int]]:
    """Groups of turning fittings (elbows, bends) whose end points all pair up among themselves and touch
    nothing else: a closed ring (two half-circle bends sharing both ends, four quarter bends, one bend
    closing on itself). No pipe can flow through such a ring, so it is drawing geometry, not piping."""
    counts = np.array([len(p) for p in ports], dtype=int)
    if not np.any(np.array(turning, dtype=bool) & (counts == 2)):
        return []
    P = np.array([x for p in ports for x in p]).reshape(-1, 3)
    owner = np.repeat(np.arange(len(ports)), counts)
    pairs = cKDTree(P).query_pairs(r=eps, output_type="ndarray")
    touching = np.bincount(pairs.ravel(), minlength=len(P)) if len(pairs) else np.zeros(len(P), dtype=int)
    n = len(ports)
    graph = sp.coo_matrix((np.ones(len(pairs)), (owner[pairs[:, 0]], owner[pairs[:, 1]])), shape=(n, n)) if len(
        pairs) else sp.coo_matrix((n, n))
    _, label = connected_components(graph, directed=False)
    rings = []
    for group in np.unique(label):
        members = np.flatnonzero(label == group)
        if not all(turning[k] and counts[k] == 2 for k in members):
            continue
        mine = np.isin(owner, members)
        if np.all(touching[mine] == 1):
            rings.append([int(k) for k in members])
    return rings


def failing_components(body: dict) -> dict[int, list[tuple[int | None, str]]]:
    """Components of an interpreted request body that fail a rule of the model (the job domain's check at
    submission): (port or None, message) per failure; {} when the body passes or fails only elsewhere."""
    try:
        request = AlignmentRequest.model_validate(body)
    except ValidationError:  # a field pydantic refuses: reported as such when the body is validated
        return {}
    try:
        check_input(request)
    except InputRejected as exc:
        out: dict[int, list[tuple[int | None, str]]] = {}
        for err in exc.errors:
            loc = err.loc
            if len(loc) >= 2 and loc[0] == "components" and isinstance(loc[1], int):
                port = loc[3] if len(loc) >= 4 and loc[2] == "ports" and isinstance(loc[3], int) else None
                out.setdefault(loc[1], []).append((port, err.msg))
        return out
    return {}
