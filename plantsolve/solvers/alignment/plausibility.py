"""Ports far outside their network: a mistyped coordinate, refused at intake.

A scanned network's ports lie together: every port of a connected network is within the
network's extent of its middle. One typed with a wrong exponent or in the wrong unit lies
far outside it, and the solver would either stretch a pipe to it and drag every neighbour
along (a pipe end typed 1e11 along its axis moved other components by 1.16e6 mm) or cut
the connections around it and report a converged network. So a port is refused, naming the
component and port, when it lies more than :data:`FAR` times further from its network's middle
(the coordinate-wise median of its ports) than every port closer in, where at least half the
network's ports are closer in and "further" is measured from at least the typical component size
(so a compact network is not judged by its last millimetre). A long straight pipe is no mistake:
the ends of a pipe up to :data:`LONGEST_PIPE_M` long count as part of the network's extent, and what
lies beyond them is judged from there (a pipeline's run out to a tank); one of 1e8 m is a typo.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components


FAR = 100.0  # a port this many times further out than the rest of its network is a mistyped coordinate
LONGEST_PIPE_M = 10_000.0  # a straight pipe up to 10 km long reaches as far out as it is long


def far_ports(pos: np.ndarray, owner: np.ndarray, a: np.ndarray, b: np.ndarray, n_comp: int,
              pipe_ends: tuple[np.ndarray, np.ndarray] | None = None) -> list[dict]:
    """Ports (index into ``pos``) far outside their connected network, each with the numbers the refusal states.

    ``owner``: the component of each port; ``a``, ``b``: the components each connection joins; ``pipe_ends``:
    the first port of every straight pipe and its length in metres (a pipe up to :data:`LONGEST_PIPE_M` may
    reach far out with either end)."""
    if len(pos) < 3 or len(a) == 0:
        return []
    _, label = connected_components(sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(n_comp, n_comp)),
                                    directed=False)
    net = label[owner]
    order = np.lexsort((np.arange(len(pos)), net))
    net_sorted = net[order]
    first = np.flatnonzero(np.r_[True, net_sorted[1:] != net_sorted[:-1]])
    size = np.diff(np.r_[first, len(order)])
    group = np.repeat(np.arange(len(first)), size)
    middle = np.empty((len(first), 3))
    for axis in range(3):  # the coordinate-wise median of every network at once
        by = order[np.lexsort((pos[order, axis], group))]
        lo, hi = first + (size - 1) // 2, first + size // 2
        middle[:, axis] = 0.5 * (pos[by[lo], axis] + pos[by[hi], axis])
    r = np.linalg.norm(pos[order] - middle[group], axis=1)
    rank_order = np.lexsort((r, group))
    ranked = order[rank_order]
    rr = r[rank_order]
    rank = np.arange(len(ranked)) - first[group]
    extent = np.zeros(len(ranked))
    extent[1:] = rr[:-1]
    counts = np.bincount(owner, minlength=n_comp)
    spans = np.zeros(n_comp)
    np.maximum.at(spans, owner, np.linalg.norm(pos - pos[np.r_[0, np.cumsum(counts)[:-1]]][owner], axis=1))
    typical = float(np.median(spans[spans > 0])) if np.any(spans > 0) else 0.0
    reach = np.zeros(len(pos), dtype=bool)
    if pipe_ends is not None:
        first_port, metres = pipe_ends
        ok = first_port[metres <= LONGEST_PIPE_M]
        reach[ok] = reach[ok + 1] = True
    jump = ~reach[ranked] & (rank >= (size[group] + 1) // 2) & (size[group] >= 3) & (rr > FAR * np.maximum(extent, typical)) & (rr > 0)
    beyond = np.cumsum(jump)
    start = beyond[first] - jump[first]
    flagged = np.flatnonzero(beyond - start[group] > 0)
    out = []
    for k in flagged:
        g = group[k]
        jump_at = first[g] + int(np.argmax(jump[first[g]:first[g] + size[g]]))
        out.append({"port": int(ranked[k]), "distance": float(rr[k]), "extent": float(rr[jump_at - 1]),
                    "closer_in": int(jump_at - first[g]), "middle": middle[g].tolist()})
    return out


MOVE_GAPS = 10.0  # a component moved by more than this many times its network's median starting gap,
MOVE_ANGLES = 2.0  # by more than this many times its median starting angle error (rad) times the network's extent
MOVE_EXTENT = 0.01  # and by more than this fraction of the network's extent moved implausibly far


def moved_far(displacement: np.ndarray, pos: np.ndarray, owner: np.ndarray, comp_a: np.ndarray, comp_b: np.ndarray,
              gap0: np.ndarray, ang0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(components moved beyond their network's limit, largest first; the limit of every component).

    Closing scan gaps moves a component by about the gaps around it, plus what the angle errors turn into
    over the network's lever arms. A component moved by more than the largest of :data:`MOVE_GAPS` times
    the median starting gap of its network's connections, :data:`MOVE_ANGLES` times their median starting
    angle error (radians) times the network's extent (the diagonal of its ports' bounding box) and
    :data:`MOVE_EXTENT` of that extent was dragged by something else: a mistyped port, a wrong connection,
    a tie-in placed elsewhere."""
    n = len(displacement)
    if n == 0 or len(comp_a) == 0:
        return np.zeros(0, dtype=np.intp), np.full(n, np.inf)
    _, label = connected_components(sp.coo_matrix((np.ones(len(comp_a)), (comp_a, comp_b)), shape=(n, n)),
                                    directed=False)
    nets = int(label.max()) + 1
    lo = np.full((nets, 3), np.inf)
    hi = np.full((nets, 3), -np.inf)
    np.minimum.at(lo, label[owner], pos)
    np.maximum.at(hi, label[owner], pos)
    extent = np.linalg.norm(hi - lo, axis=1)
    net_of = label[comp_a]
    limit = np.maximum(MOVE_GAPS * _median_by(gap0, net_of, nets),
                       np.maximum(MOVE_ANGLES * _median_by(ang0, net_of, nets), MOVE_EXTENT) * extent)[label]
    far = np.flatnonzero(displacement > limit)
    return far[np.argsort(-displacement[far], kind="stable")], limit


def _median_by(x: np.ndarray, group: np.ndarray, n: int) -> np.ndarray:
    """The median of ``x`` over each of ``n`` groups (0 for an empty one)."""
    order = np.lexsort((x, group))
    counts = np.bincount(group, minlength=n)
    first = np.r_[0, np.cumsum(counts)[:-1]]
    has = counts > 0
    out = np.zeros(n)
    xs = x[order]
    out[has] = 0.5 * (xs[first[has] + (counts[has] - 1) // 2] + xs[first[has] + counts[has] // 2])
    return out


FITTING_SPAN = (0.2, 10.0)  # plausible median span of a fitting's ports, in bores (outside diameters)
TYPICAL_SPAN = 2.5  # a typical one: elbows 2.1, tees 3


def fitting_span_in_bores(pos: np.ndarray, counts: np.ndarray, radius: np.ndarray,
                          is_fitting: np.ndarray) -> tuple[float, int] | None:
    """The median over fittings with two or more ports apart and a radius of the largest distance between two of
    their ports divided by their outside diameter, and how many fittings that is (None without any).

    A catalogue fitting spans about its bore: a long-radius elbow's ends are 2.1 bores apart, a tee's run 1-3,
    a valve 1-4, a flange 0.1-0.5. Coordinates in another unit than the bores (a PCF whose UNITS-CO-ORDS says MM
    over coordinates in metres, a JSON request in the wrong ``units``) put that median 25 or 1000 times off."""
    use = np.flatnonzero(is_fitting & (counts >= 2) & np.isfinite(radius) & (radius > 0))
    if len(use) == 0:
        return None
    start = np.r_[0, np.cumsum(counts)[:-1]]
    span = np.zeros(len(counts))
    for k in range(1, int(counts[use].max())):  # distances from the first port, then between the others
        for j in range(k):
            has = use[counts[use] > k]
            d = np.linalg.norm(pos[start[has] + k] - pos[start[has] + j], axis=1)
            span[has] = np.maximum(span[has], d)
    use = use[span[use] > 0]  # a zero-length item (a weld, a gasket, a degenerate valve) is a point: no size
    if len(use) == 0:
        return None
    return float(np.median(span[use] / (2.0 * radius[use]))), len(use)


RADIUS_JUMP = 100.0  # connected ports share a bore; a reducer changes it by a few times, never a hundred


def radius_jumps(radius: np.ndarray, comp_a: np.ndarray, comp_b: np.ndarray) -> list[tuple[int, float]]:
    """(component, the largest radius among those it is connected to) of every component whose radius is more than
    :data:`RADIUS_JUMP` times that largest one: a radius in another unit or with a wrong exponent (one elbow's 1e6 mm
    beside its 50 mm pipes weighted it so that the network was cut around it, said to be a conflict; one pipe's
    5e4 mm made it at least 5 m long and dragged eleven components 2.3 m). ``radius``: nan where not given."""
    if len(comp_a) == 0:
        return []
    known = np.where(np.isfinite(radius), radius, 0.0)
    beside = np.zeros(len(radius))
    np.maximum.at(beside, comp_a, known[comp_b])
    np.maximum.at(beside, comp_b, known[comp_a])
    jumps = np.flatnonzero((beside > 0) & (known > RADIUS_JUMP * beside))
    return [(int(c), float(beside[c])) for c in jumps]


PIPE_RADIUS_M = (0.002, 2.5)  # plausible median outside radius of a plant's pipes and fittings, in metres
