"""Correspondence-free rigid matching of two point sets, verified both ways (paper Section
"Comparing point sets by estimating the rigid-body transformation", Eqs. 1-23, with its weak spots
fixed): the points are centred first (the paper's Eq. 3 scale from uncentred norms is not translation
invariant), the scale stays 1 unless asked for, no vertex order is assumed (a pose guess from the
principal axes with every sign and order ambiguity tried, plus anchor frames from the farthest points
when the axes are degenerate), Kabsch with its reflection guard (``plantsolve.solvers.geometry.kabsch``,
Eqs. 14-21) refines on nearest-neighbour correspondences, and every accepted transform is verified by
the two-way Hausdorff distance (Eq. 22 "checked against all pairs of points", without the pairs).

All numerics run on centred coordinates: world coordinates of 1e6 m would cost the fit six digits.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from plantsolve.solvers.dedup.nearest import NearestPoints
from plantsolve.solvers.geometry import kabsch

MAX_ICP_STEPS = 30
MAX_ANCHORS = 6
VERIFY_SAMPLE = 16  # points a transform is tried on before all of them
# tries verified together: the pool's first valid try is mostly among its first few (the tunnel: 2,389 of 3,703
# members find it in the first four of 5–11 tries), and every try after it need not be moved or looked up
TRIES_AT_ONCE = 4


@dataclass
class Shape:
    """A product's world points, centred, with what matching needs precomputed."""

    points: np.ndarray  # (n, 3) unique world points
    centre: np.ndarray  # (3,)
    local: np.ndarray  # points - centre
    eigenvalues: np.ndarray  # ascending, of the centred covariance
    axes: np.ndarray  # columns: principal axes (matching eigenvalues)
    radius: float  # RMS distance from the centre
    _nearest: NearestPoints | None = None
    memo: dict = field(default_factory=dict)  # what matching derives from this shape alone, kept for its next match

    @property
    def nearest(self) -> NearestPoints:
        """The nearest of ``local`` to given points (a k-d tree's answers, mostly without its search)."""
        if self._nearest is None:
            self._nearest = NearestPoints(self.local)
        return self._nearest

    @property
    def tree(self) -> cKDTree:
        return self.nearest.tree


def make_shape(points: np.ndarray) -> Shape:
    points = np.asarray(points, dtype=float)
    centre = points.mean(axis=0)
    local = points - centre
    cov = local.T @ local / max(len(local), 1)
    values, vectors = np.linalg.eigh(cov)
    return Shape(points, centre, local, values, vectors, float(np.sqrt(np.mean(np.sum(local * local, axis=1)))))


@dataclass
class Match:
    """``member ≈ R · scale · rep + t`` in world coordinates (R may be improper only with mirror allowed)."""

    rotation: np.ndarray
    scale: float
    translation: np.ndarray
    deviation: float  # two-way Hausdorff distance after the transform
    mirror: bool

    @property
    def matrix(self) -> np.ndarray:
        m = np.eye(4)
        m[:3, :3] = self.rotation * self.scale
        m[:3, 3] = self.translation
        return m


def det3(m: np.ndarray) -> float:
    """The determinant of a 3×3 matrix, written out (``np.linalg.det`` costs a LAPACK call; only its
    sign is asked of a rotation's ±1)."""
    (a, b, c), (d, e, f), (g, h, i) = m.tolist()
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def det3s(m: np.ndarray) -> np.ndarray:
    """:func:`det3` of a stack of 3×3 matrices (the same products and sums, element by element)."""
    a, b, c = m[:, 0, 0], m[:, 0, 1], m[:, 0, 2]
    d, e, f = m[:, 1, 0], m[:, 1, 1], m[:, 1, 2]
    g, h, i = m[:, 2, 0], m[:, 2, 1], m[:, 2, 2]
    return a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)


def one_to_one(idx: np.ndarray, n: int) -> bool:
    """Whether ``idx`` (``n`` indices into ``n`` points) names every point once."""
    hit = np.zeros(n, dtype=bool)
    hit[idx] = True
    return len(idx) == n and bool(hit.all())


def hausdorff(a: np.ndarray, b: np.ndarray, tree_b: cKDTree | NearestPoints | None = None, tree_a: cKDTree | None = None,
              bound: float = np.inf) -> float:
    """Two-way Hausdorff distance of point sets ``a`` and ``b`` (stops early past ``bound``)."""
    tree_b = tree_b or cKDTree(b)
    d_ab = tree_b.query(a, k=1, distance_upper_bound=bound * 1.0001 if np.isfinite(bound) else np.inf)[0]
    first = float(np.max(d_ab)) if len(d_ab) else 0.0
    if first > bound:
        return first
    tree_a = tree_a or cKDTree(a)
    d_ba = tree_a.query(b, k=1)[0]
    return max(first, float(np.max(d_ba)) if len(d_ba) else 0.0)


SIGNS = np.array(list(itertools.product((1.0, -1.0), repeat=3)))  # every sign flip of the three axes
FLIP_Z = np.diag([1.0, 1.0, -1.0])  # mirrors through the xy plane (never written to)
FLIP_Z.flags.writeable = False


def _axis_orders(rep: Shape, tol: float) -> list[list[int]]:
    """The orders of rep's principal axes whose eigenvalues cannot be told apart (rep's alone: asked
    once per representative, whatever the member)."""
    key = ("orders", tol)
    if key not in rep.memo:
        sd = np.sqrt(np.maximum(rep.eigenvalues, 0.0))
        same = lambda i, j: abs(sd[i] - sd[j]) < 2 * tol + 1e-9 * max(rep.radius, tol)  # noqa: E731
        rep.memo[key] = [list(p) for p in itertools.permutations(range(3)) if all(same(i, p[i]) for i in range(3))]
    return rep.memo[key]


def _axis_guesses(rep: Shape, member: Shape, tol: float, allow_mirror: bool) -> list[np.ndarray]:
    """Rotations that map rep's principal frame onto member's: all sign flips, and all orders of axes
    whose eigenvalues cannot be told apart."""
    guesses = []
    for perm in _axis_orders(rep, tol):
        flipped = (member.axes[:, perm] * SIGNS[:, None, :]) @ rep.axes.T  # the eight flips at once
        for r, det in zip(flipped, det3s(flipped).tolist()):
            if det < 0 and not allow_mirror:
                continue
            guesses.append(r)
    return guesses


def _frame(origin_dir: np.ndarray, second: np.ndarray) -> np.ndarray | None:
    x = origin_dir / np.linalg.norm(origin_dir)
    y = second - (second @ x) * x
    n = np.linalg.norm(y)
    if n < 1e-12:
        return None
    y = y / n
    return np.column_stack([x, y, np.cross(x, y)])


def _anchor_guesses(rep: Shape, member: Shape, tol: float, allow_mirror: bool) -> list[np.ndarray]:
    """Rotations from matched feature points: rep's farthest point and the point farthest from that
    direction, paired with every member point at the same two distances (few, for discrete symmetries)."""
    d_rep = np.linalg.norm(rep.local, axis=1)
    d_mem = np.linalg.norm(member.local, axis=1)
    i1 = int(np.argmax(d_rep))
    x = rep.local[i1] / max(d_rep[i1], 1e-300)
    off = np.linalg.norm(rep.local - np.outer(rep.local @ x, x), axis=1)
    i2 = int(np.argmax(off))
    f_rep = _frame(rep.local[i1], rep.local[i2])
    if f_rep is None:
        return []
    c1 = np.flatnonzero(np.abs(d_mem - d_rep[i1]) <= 2 * tol)[:MAX_ANCHORS * 4]
    c2 = np.flatnonzero(np.abs(d_mem - d_rep[i2]) <= 2 * tol)
    angle = rep.local[i1] @ rep.local[i2]
    guesses = []
    for a in c1:
        for b in c2:
            if a == b or abs(member.local[a] @ member.local[b] - angle) > 4 * tol * max(d_rep[i1], 1.0):
                continue
            f_mem = _frame(member.local[a], member.local[b])
            if f_mem is None:
                continue
            guesses.append(f_mem @ f_rep.T)
            if allow_mirror:
                flip = f_mem.copy()
                flip[:, 2] *= -1
                guesses.append(flip @ f_rep.T)
            if len(guesses) >= 8 * MAX_ANCHORS:
                return guesses
    return guesses


def first_steps(rep_local: np.ndarray, member: Shape, rotations: list[np.ndarray], window: float = 0.0) -> list[tuple]:
    """The nearest member points of ``rep_local`` moved by each rotation, as :func:`_refine`'s first step
    finds them: one stacked ``np.matmul`` (per matrix the same BLAS call as its ``@``: the same bits) and
    one tree query for all of them (a point's nearest neighbour does not depend on the other points); a point
    landing within ``window`` of one member point alone is answered without the tree's search."""
    if not rotations:
        return []
    moved = np.matmul(rep_local, np.stack(rotations).transpose(0, 2, 1)) + np.zeros(3)
    dist, idx = member.nearest.query(moved.reshape(-1, 3), k=1, window=window)
    n = len(rep_local)
    return [(dist[i * n:(i + 1) * n], idx[i * n:(i + 1) * n]) for i in range(len(rotations))]


def _refine(rep_local: np.ndarray, member: Shape, rotation: np.ndarray, proper: bool, stop: float,
            first: tuple | None = None):
    """Nearest-neighbour (ICP) refinement of ``member.local ≈ R @ rep_local + t``; returns R, t and the
    final nearest-neighbour distances and indices. ``first``: the first step's (distances, indices), when
    :func:`first_steps` found them."""
    t = np.zeros(3)
    last = np.inf
    flip = FLIP_Z
    for step in range(MAX_ICP_STEPS):
        if step == 0 and first is not None:
            dist, idx = first
        else:
            moved = rep_local @ rotation.T + t
            dist, idx = member.tree.query(moved, k=1)
        err = float(dist.max())
        if err <= stop or err >= last * 0.999999:
            break
        last = err
        if proper:
            new_r, new_t, _ = kabsch(rep_local, member.local[idx])
        else:
            # an improper fit: mirror the rep through its own frame, fit properly, mirror back
            r, new_t, _ = kabsch(rep_local @ flip, member.local[idx])
            new_r = r @ flip
        rotation, t = new_r, new_t
    return rotation, t, dist, idx


def match(rep: Shape, member: Shape, tol: float, *, allow_mirror: bool = False, allow_scale: bool = False) -> Match | None:
    """The transform taking ``rep`` onto ``member`` within ``tol`` (two-way Hausdorff), or None.

    Ties between several valid transforms (a symmetric shape) go to the one nearest the identity,
    then to the smallest deviation, so the answer does not depend on the order of tries."""
    if len(rep.points) != len(member.points):
        return None
    scale = 1.0
    if allow_scale and rep.radius > 0:
        scale = member.radius / rep.radius
        if abs(scale - 1.0) * rep.radius <= 0.01 * tol:  # equal size within the tolerance: rigid, exactly
            scale = 1.0
    elif abs(member.radius - rep.radius) > 2 * tol:
        return None
    rep_local = rep.local * scale
    scaled_tol_ok = abs(member.radius - scale * rep.radius) <= 2 * tol
    if not scaled_tol_ok:
        return None
    candidates = _axis_guesses(rep, member, tol, allow_mirror)
    # quick ranking on a subsample keeps the refinement to the promising guesses
    sample = rep_local[:: max(1, len(rep_local) // 64)]
    if not candidates:
        return None
    stacked = np.stack(candidates)  # (g, 3, 3): every guess's sample in one tree query
    moved = np.einsum("gij,nj->gni", stacked, sample).reshape(-1, 3)
    # a right guess already lands the sample within the tolerance (plus fit noise); refine only those,
    # and all of the best eight only when none does (a rough guess that ICP still has to pull in). The
    # search stops past 4·tol: a point's distance within it is the one an unbounded search finds (the
    # same nearest point), one past it is only known to be past it, which is all 'close' asks
    d = member.nearest.query(moved, k=1, distance_upper_bound=4 * tol * 1.0001)[0]
    worst = d.reshape(len(candidates), -1).max(axis=1)
    close = [r for d, r in sorted(zip(worst.tolist(), candidates), key=lambda s: s[0]) if d <= 4 * tol]
    if not close:  # the best eight by their true distances
        d = member.tree.query(moved, k=1)[0]
        worst = d.reshape(len(candidates), -1).max(axis=1)
        close = [r for _, r in sorted(zip(worst.tolist(), candidates), key=lambda s: s[0])[:8]]
    tries = close
    best: Match | None = None

    def consider(r0: np.ndarray, first: tuple | None = None) -> None:
        nonlocal best
        proper = det3(r0) > 0
        r, t, dist, idx = _refine(rep_local, member, r0, proper, 1e-3 * tol, first)
        dev = float(dist.max())
        if dev > tol:
            return
        if not one_to_one(idx, len(member.local)):
            # not one-to-one: the way back needs its own search
            dev = hausdorff(rep_local @ r.T + t, member.local, member.nearest, bound=tol)
            if dev > tol:
                return
        # one-to-one within tol: every member point is within dev of its preimage, so the two-way
        # Hausdorff distance is dev itself
        cand = Match(r, scale, member.centre + t - r @ (rep.centre * scale), dev, bool(det3(r) < 0))
        key = (round(float(np.trace(r)), 9) * -1, dev)
        if best is None or key < (round(float(np.trace(best.rotation)), 9) * -1, best.deviation):
            best = cand

    for r0, first in zip(tries, first_steps(rep_local, member, tries, 4 * tol)):
        consider(r0, first)
    if best is None:
        for r0 in _anchor_guesses(rep, member, tol, allow_mirror):
            consider(r0)
    return best


def verify(rep: Shape, member: Shape, m: Match, tol: float) -> float:
    """Two-way Hausdorff distance between ``member`` and ``rep`` moved by ``m`` (world frame, centred
    on the member for accuracy); past ``tol`` only a value above ``tol``, found with one direction.

    When every moved point has a different nearest member point and the sets are equally large, the
    nearest-point map is one-to-one: every member point is then within the largest of those
    distances of its preimage, so the way back adds nothing and needs no tree of its own."""
    moved = rep.local @ (m.rotation * m.scale).T + (m.rotation * m.scale) @ rep.centre + m.translation - member.centre
    if len(moved) == 0 or len(moved) != len(member.local):
        return hausdorff(moved, member.local, member.tree)
    # a wrong transform (most the pool tries) already moves some of a few points farther than tol from the
    # member: that alone is a value above tol, and the whole set is queried only for the others
    few = member.nearest.query(_sample(moved), k=1, distance_upper_bound=tol * 1.0001)[0]
    if float(np.max(few)) > tol:
        return float(np.max(few))
    return _verify_all(moved, member, tol)


def _sample(moved: np.ndarray) -> np.ndarray:
    return moved[::max(1, len(moved) // VERIFY_SAMPLE)]


def _verify_all(moved: np.ndarray, member: Shape, tol: float) -> float:
    """:func:`verify` past its sample."""
    dist, idx = member.nearest.query(moved, k=1, distance_upper_bound=tol * 1.0001)
    first = float(np.max(dist))
    if first > tol:
        return first
    if one_to_one(idx, len(member.local)):
        return first
    return hausdorff(moved, member.local, member.tree)


def first_verified(rep: Shape, member: Shape, tries: list[Match], tol: float) -> tuple[int, float] | None:
    """The first of ``tries`` (in order) that :func:`verify` finds within ``tol``, and its deviation, else
    None: the same answer as verifying them one after another. The tries go ``TRIES_AT_ONCE`` at a time, in
    order, so those after the first valid one are never moved (see :func:`_first_verified_together`)."""
    n = len(rep.local)
    if not tries or n == 0 or n != len(member.local):
        for i, m in enumerate(tries):
            dev = verify(rep, member, m, tol)
            if dev <= tol:
                return i, dev
        return None
    for start in range(0, len(tries), TRIES_AT_ONCE):
        found = _first_verified_together(rep, member, tries[start:start + TRIES_AT_ONCE], tol)
        if found is not None:
            return start + found[0], found[1]
    return None


def _first_verified_together(rep: Shape, member: Shape, tries: list[Match], tol: float) -> tuple[int, float] | None:
    """:func:`first_verified` of a few tries at once (``rep`` and ``member`` equally large, neither empty). Every
    try's moved points come from one stacked ``np.matmul`` (per matrix the same BLAS call as ``verify``'s ``@``:
    the same bits, however many are stacked) and the elementwise sums in ``verify``'s order; the samples of all
    tries go through one tree query (a point's nearest neighbour does not depend on the other points asked with
    it)."""
    n = len(rep.local)
    scaled = np.stack([m.rotation * m.scale for m in tries])
    moved = (np.matmul(rep.local, scaled.transpose(0, 2, 1)) + np.matmul(scaled, rep.centre)[:, None, :]
             + np.stack([m.translation for m in tries])[:, None, :] - member.centre)
    samples = moved[:, ::max(1, n // VERIFY_SAMPLE)]
    few = member.nearest.query(samples.reshape(-1, 3), k=1, distance_upper_bound=tol * 1.0001)[0]
    worst = few.reshape(len(tries), -1).max(axis=1)
    for i in np.flatnonzero(~(worst > tol)).tolist():
        dev = _verify_all(moved[i], member, tol)
        if dev <= tol:
            return i, dev
    return None
