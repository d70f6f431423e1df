"""The request in a canonical order, so that the answer does not depend on how it was sorted.

Components are sorted by id, connections by their two (id, port) ends, and every connection runs
from its smaller end to its larger. The solvers then see the same arrays, build the same sparse
matrices and get the same fill-reducing ordering whatever the input order was, so a shuffled request
(components, connections, or the ends of a connection swapped) gives the bit-identical result rather
than one that agrees only to round-off (which on singular loops and at conflicts is far from the last
digit). The direct method writes a connection's direction constraint in the tangent plane of its
common axis, not of one end's direction, so the orientation chosen here decides nothing but signs.
"""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.alignment import AlignmentRequest, Connection


def canonical_order(request: AlignmentRequest) -> tuple[AlignmentRequest, np.ndarray, np.ndarray]:
    """(canonical request, ``ports``, ``conns``): port ``i`` of the request is port ``ports[i]`` of the
    canonical one, connection ``k`` is connection ``conns[k]``."""
    comps = request.components
    order = sorted(range(len(comps)), key=lambda i: comps[i].id)
    counts = np.array([len(c.ports) for c in comps], dtype=np.intp)
    start = np.concatenate([[0], np.cumsum(counts)])
    new_start = np.zeros(len(comps), dtype=np.intp)
    new_start[order] = np.concatenate([[0], np.cumsum(counts[order])])[:-1]
    port_comp = np.repeat(np.arange(len(comps)), counts)
    ports = new_start[port_comp] + (np.arange(start[-1]) - start[port_comp])

    def ends(k: int) -> tuple[tuple[str, int], tuple[str, int]]:
        c = request.connections[k]
        a, b = (c.from_[0], int(c.from_[1])), (c.to[0], int(c.to[1]))
        return (a, b) if a <= b else (b, a)

    corder = sorted(range(len(request.connections)), key=ends)
    conns = np.zeros(len(corder), dtype=np.intp)
    conns[corder] = np.arange(len(corder))
    connections = [_oriented(request.connections[k], *ends(k)) for k in corder]
    turned = any(c is not request.connections[k] for c, k in zip(connections, corder))
    if order == list(range(len(comps))) and corder == list(range(len(corder))) and not turned:
        return request, ports, conns
    canon = request.model_copy(update={"components": [comps[i] for i in order], "connections": connections})
    return canon, ports, conns


def _oriented(conn: Connection, first: tuple[str, int], second: tuple[str, int]) -> Connection:
    """``conn`` running from ``first`` to ``second`` (itself when it already does)."""
    if (conn.from_[0], int(conn.from_[1])) == first:
        return conn
    return Connection.model_construct(from_=first, to=second)
