"""The request in a canonical order, so that the answer does not depend on how it was sorted.

Components are sorted by id, the ports of each by their distance from the middle of the network,
connections by their two (id, port) ends, and every connection runs from its smaller end to its
larger. The solvers then see the same arrays, build the same sparse matrices and get the same
fill-reducing ordering whatever the input order was, so a shuffled request (components,
connections, a component's ports, or the ends of a connection swapped) gives the bit-identical
result rather than one that agrees only to round-off (which on singular loops and at conflicts is
far from the last digit). A port's number says nothing of the physics (a pipe's two ends are
alike), so the ports of a component are ordered by where they are, not by how they were listed
(listed the other way, the ladder's ports took 151 Gauss-Newton steps instead of 155 and ended
5e-5 mm elsewhere). The direct method writes a connection's direction constraint in the tangent
plane of its common axis, not of one end's direction, so the orientation chosen here decides
nothing but signs.
"""

from __future__ import annotations

import numpy as np

from plantsolve.schemas.alignment import AlignmentRequest, Connection


def canonical_order(request: AlignmentRequest) -> tuple[AlignmentRequest, np.ndarray, np.ndarray]:
    """(canonical request, ``ports``, ``conns``): port ``i`` of the request is port ``ports[i]`` of the
    canonical one, connection ``k`` is connection ``conns[k]``."""
    comps = request.components
    order = sorted(range(len(comps)), key=lambda i: comps[i].id)
    within = _port_orders(comps)  # within[i][k]: the port of comps[i] that comes k-th
    rank = {c.id: {old: new for new, old in enumerate(w)} for c, w in zip(comps, within)}
    counts = np.array([len(c.ports) for c in comps], dtype=np.intp)
    start = np.concatenate([[0], np.cumsum(counts)])
    new_start = np.zeros(len(comps), dtype=np.intp)
    new_start[order] = np.concatenate([[0], np.cumsum(counts[order])])[:-1]
    port_comp = np.repeat(np.arange(len(comps)), counts)
    local = np.arange(start[-1]) - start[port_comp]
    ranked = np.array([rank[comps[i].id][int(k)] for i, k in zip(port_comp, local)], dtype=np.intp)
    ports = new_start[port_comp] + ranked

    def ends(k: int) -> tuple[tuple[str, int], tuple[str, int]]:
        c = request.connections[k]
        a, b = _renumbered(c.from_, rank), _renumbered(c.to, rank)
        return (a, b) if a <= b else (b, a)

    corder = sorted(range(len(request.connections)), key=ends)
    conns = np.zeros(len(corder), dtype=np.intp)
    conns[corder] = np.arange(len(corder))
    connections = [_oriented(request.connections[k], *ends(k)) for k in corder]
    turned = any(c is not request.connections[k] for c, k in zip(connections, corder))
    moved = [w != list(range(len(w))) for w in within]
    if order == list(range(len(comps))) and corder == list(range(len(corder))) and not turned and not any(moved):
        return request, ports, conns
    listed = [comps[i].model_copy(update={"ports": [comps[i].ports[k] for k in within[i]]}) if moved[i] else comps[i]
              for i in order]
    canon = request.model_copy(update={"components": listed, "connections": connections})
    return canon, ports, conns


def _port_orders(comps: list) -> list[list[int]]:
    """Per component, the indices of its ports by their distance from the middle of all ports, then (a tie: a
    symmetric network) by position and direction as written, then index. The distance moves with neither the
    listing, nor the names, nor the frame (but for round-off), nor the unit: a pipe's first end, which the
    dual-quaternion iteration holds while its length changes, stays the same end when the network is turned or
    renamed, and the Gauss-Newton steps see the same unknowns in the same order."""
    P = np.array([p.position for c in comps for p in c.ports], dtype=float).reshape(-1, 3)
    # the mean of the positions in their own sorted order: the same bits however they were listed
    middle = P[np.lexsort(P.T[::-1])].mean(axis=0) if len(P) else np.zeros(3)
    d2 = ((P - middle) ** 2).sum(axis=1)
    out, at = [], 0
    for c in comps:
        n = len(c.ports)
        out.append(sorted(range(n), key=lambda k: (d2[at + k], tuple(c.ports[k].position),
                                                   tuple(c.ports[k].direction), k)))
        at += n
    return out


def _renumbered(end: tuple[str, int], rank: dict[str, dict[int, int]]) -> tuple[str, int]:
    """A connection's (component, port) end with the port numbered as in the canonical request (an end naming no
    component or port of the request is left as it is: the model refuses it)."""
    cid, k = end[0], int(end[1])
    return cid, rank.get(cid, {}).get(k, k)


def _oriented(conn: Connection, first: tuple[str, int], second: tuple[str, int]) -> Connection:
    """``conn`` running from ``first`` to ``second`` (itself when it already does)."""
    if (conn.from_[0], int(conn.from_[1])) == first and (conn.to[0], int(conn.to[1])) == second:
        return conn
    return Connection.model_construct(from_=first, to=second)
