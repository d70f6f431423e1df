"""Arc-line splines and their LRA description (paper §5.3).

A tube is held as :class:`TubeModel` — start point, start frame and the LRA rows in radians.
Everything else (segments, control polygon, XYZ+CLR, distances, meshes) is derived from it,
so that LRA ↔ geometry conversions have exactly one implementation each.

Convention (documented publicly in ``schemas/tube.py``): frame columns are x = tangent,
y = in-plane normal toward the next bend centre, z = x × y. Row i: straight ``lengths[i]``,
rotate the normal about the tangent by ``rotations[i]``, bend by ``angles[i]`` with
``radii[i]`` toward the normal. The last row has no bend.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from plantsolve.solvers.geometry import any_perpendicular, quaternion, rotation, signed_angle
from plantsolve.solvers.tube.vec3 import cross

TWO_PI = 2.0 * np.pi


@dataclass
class TubeModel:
    start: np.ndarray  # (3,)
    frame: np.ndarray  # (3, 3), columns x, y, z of the local frame in world coordinates
    lengths: np.ndarray  # (n + 1,)
    rotations: np.ndarray  # (n + 1,) radians; [0] == 0 and [-1] unused (no bend)
    angles: np.ndarray  # (n,) radians, in (0, 2π)
    radii: np.ndarray  # (n,)
    pipe_radius: float = 0.0
    _spine_cache: tuple | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def n_bends(self) -> int:
        return len(self.angles)

    @property
    def spine(self) -> "Spine":
        """The segments of this model, built once and reused until a parameter changes (the
        solver edits models in place, so the cache is keyed on the parameters' bytes, which
        costs far less than rebuilding). The cached arrays are read-only."""
        key = (self.start.tobytes(), self.frame.tobytes(), self.lengths.tobytes(),
               self.rotations.tobytes(), self.angles.tobytes(), self.radii.tobytes())
        if self._spine_cache is None or self._spine_cache[0] != key:
            self._spine_cache = (key, _build_spine(self))
        return self._spine_cache[1]

    def copy(self) -> "TubeModel":
        return TubeModel(
            self.start.copy(), self.frame.copy(), self.lengths.copy(), self.rotations.copy(),
            self.angles.copy(), self.radii.copy(), float(self.pipe_radius),
        )


@dataclass
class Spine:
    """Segments of a centreline in order. Arrays are indexed by segment."""

    kind: np.ndarray  # (S,) 0 = line, 1 = arc
    start: np.ndarray  # (S, 3)
    end: np.ndarray  # (S, 3)
    tangent: np.ndarray  # (S, 3) tangent at the segment start
    normal: np.ndarray  # (S, 3) in-plane normal toward the centre (arcs); frame normal (lines)
    length: np.ndarray  # (S,) straight length (lines) or arc length (arcs)
    centre: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # (S, 3), arcs only meaningful
    radius: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (S,)
    angle: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (S,) radians

    @property
    def axis(self) -> np.ndarray:
        """Arc plane normals (t × n): the arc runs counter-clockwise about them."""
        return cross(self.tangent, self.normal)


def build_spine(model: TubeModel) -> Spine:
    """LRA → segments (line, arc, line, …, line); zero-length lines are kept. Cached on the
    model (:attr:`TubeModel.spine`)."""
    return model.spine


def _build_spine(model: TubeModel) -> Spine:
    """The forward kinematics on Python floats: a spine has a few segments, and numpy's per-call overhead on
    3-vectors cost more than the arithmetic (the solver builds spines hundreds of times per scan)."""
    n = model.n_bends
    px, py, pz = (float(v) for v in model.start)
    (tx, nx, _), (ty, ny, _), (tz, nz, _) = model.frame.tolist()
    lengths, rotations = model.lengths.tolist(), model.rotations.tolist()
    angles, radii = model.angles.tolist(), model.radii.tolist()
    S = 2 * n + 1
    kind = [0, 1] * n + [0]
    st, en, tg, nm, ce = [], [], [], [], []
    ln, ra, an = [], [], []
    for i in range(n + 1):
        st.append((px, py, pz)); tg.append((tx, ty, tz)); nm.append((nx, ny, nz))
        L = lengths[i]
        px, py, pz = px + L * tx, py + L * ty, pz + L * tz
        en.append((px, py, pz)); ln.append(L); ce.append((0.0, 0.0, 0.0)); ra.append(0.0); an.append(0.0)
        if i == n:
            break
        # the normal turned about the tangent by the rotation (Rodrigues, as ``vec3.rotate_about``)
        c, s = math.cos(rotations[i]), math.sin(rotations[i])
        cx, cy, cz = ty * nz - tz * ny, tz * nx - tx * nz, tx * ny - ty * nx
        k = (tx * nx + ty * ny + tz * nz) * (1.0 - c)
        nx, ny, nz = nx * c + cx * s + tx * k, ny * c + cy * s + ty * k, nz * c + cz * s + tz * k
        a, R = angles[i], radii[i]
        st.append((px, py, pz)); tg.append((tx, ty, tz)); nm.append((nx, ny, nz))
        cx, cy, cz = px + R * nx, py + R * ny, pz + R * nz
        ca, sa = math.cos(a), math.sin(a)
        px, py, pz = cx - R * (nx * ca) + R * (tx * sa), cy - R * (ny * ca) + R * (ty * sa), cz - R * (nz * ca) + R * (tz * sa)
        (tx, ty, tz), (nx, ny, nz) = ((tx * ca + nx * sa, ty * ca + ny * sa, tz * ca + nz * sa),
                                      (nx * ca - tx * sa, ny * ca - ty * sa, nz * ca - tz * sa))
        en.append((px, py, pz)); ce.append((cx, cy, cz)); ra.append(R); an.append(a); ln.append(R * a)
    arrays = [np.array(kind, dtype=int)] + [np.array(v, dtype=float).reshape(S, 3) for v in (st, en, tg, nm)] + [
        np.array(ln, dtype=float), np.array(ce, dtype=float).reshape(S, 3), np.array(ra, dtype=float),
        np.array(an, dtype=float)]
    for array in arrays:
        array.setflags(write=False)
    kind_, st_, en_, tg_, nm_, ln_, ce_, ra_, an_ = arrays
    return Spine(kind_, st_, en_, tg_, nm_, ln_, ce_, ra_, an_)


def end_frame(model: TubeModel) -> tuple[np.ndarray, np.ndarray]:
    """End point and end tangent of the centreline."""
    sp = build_spine(model)
    return sp.end[-1], sp.tangent[-1]


def model_from_spine(sp: Spine, pipe_radius: float) -> TubeModel:
    """Segments → LRA (inverse of :func:`build_spine`). Lines and arcs must alternate,
    starting and ending with a line (lines may have zero length)."""
    lines = np.flatnonzero(sp.kind == 0)
    arcs = np.flatnonzero(sp.kind == 1)
    n = len(arcs)
    t0 = sp.tangent[0] / np.linalg.norm(sp.tangent[0])
    if n:
        y0 = sp.normal[arcs[0]] - np.dot(sp.normal[arcs[0]], t0) * t0
        y0 /= np.linalg.norm(y0)
    else:
        y0 = sp.normal[0] - np.dot(sp.normal[0], t0) * t0
        y0 /= np.linalg.norm(y0)
    frame = np.column_stack([t0, y0, np.cross(t0, y0)])
    lengths = np.array([sp.length[k] for k in lines], float)
    rotations = np.zeros(n + 1)
    nprev = y0
    for i, k in enumerate(arcs):
        ni = sp.normal[k]
        rotations[i] = 0.0 if i == 0 else signed_angle(nprev, ni, sp.tangent[k])
        a = sp.angle[k]
        nprev = ni * np.cos(a) - sp.tangent[k] * np.sin(a)
    return TubeModel(sp.start[0].copy(), frame, lengths, rotations,
                     sp.angle[arcs].copy(), sp.radius[arcs].copy(), float(pipe_radius))


def reverse_spine(sp: Spine) -> Spine:
    """The same centreline walked from the other end."""
    o = slice(None, None, -1)
    kind = sp.kind[o].copy()
    start = sp.end[o].copy(); end = sp.start[o].copy()
    S = len(kind)
    tangent = np.zeros((S, 3)); normal = np.zeros((S, 3))
    for k in range(S):
        j = S - 1 - k
        if sp.kind[j] == 1:
            a = sp.angle[j]
            t_end = sp.tangent[j] * np.cos(a) + sp.normal[j] * np.sin(a)
            n_end = sp.normal[j] * np.cos(a) - sp.tangent[j] * np.sin(a)
            tangent[k] = -t_end; normal[k] = n_end
        else:
            tangent[k] = -sp.tangent[j]; normal[k] = sp.normal[j]
    return Spine(kind, start, end, tangent, normal, sp.length[o].copy(), sp.centre[o].copy(),
                 sp.radius[o].copy(), sp.angle[o].copy())


def reverse_model(model: TubeModel) -> TubeModel:
    return model_from_spine(reverse_spine(build_spine(model)), model.pipe_radius)


# --- control polygon / XYZ + CLR -------------------------------------------------------------

def control_polygon(model: TubeModel) -> tuple[np.ndarray, np.ndarray]:
    """Start, straight-line intersection points of the bends, end; and the bend radii.

    Bends of 180° or more have no intersection point and are skipped (paper §5.2)."""
    sp = build_spine(model)
    pts = [sp.start[0]]
    clr = []
    for k in np.flatnonzero(sp.kind == 1):
        a = sp.angle[k]
        if a >= np.pi - 1e-9:
            continue
        pts.append(sp.start[k] + sp.radius[k] * np.tan(a / 2) * sp.tangent[k])
        clr.append(sp.radius[k])
    pts.append(sp.end[-1])
    return np.array(pts), np.array(clr)


def with_radii(model: TubeModel, radii) -> TubeModel:
    """The model with other bend radii and the same control polygon: each straight shortened by the growth
    of its bends' tangent lengths R tan(θ/2) (bends of 170° or more, whose corner lies far off, keep their
    straights). A radius changed on its own moves everything after the bend by the change in its arc's
    chord, which a least-squares start many radii off can only partly undo."""
    m = model.copy()
    radii = np.asarray(radii, float)
    grow = np.where(m.angles < np.radians(170.0), (radii - m.radii) * np.tan(m.angles / 2), 0.0)
    m.lengths = m.lengths.copy()
    m.lengths[:-1] -= grow
    m.lengths[1:] -= grow
    m.lengths = np.maximum(m.lengths, 0.0)
    m.radii = radii.copy()
    return m


def model_from_control_polygon(pts: np.ndarray, clr: np.ndarray, pipe_radius: float = 0.0) -> TubeModel:
    """XYZ + CLR → LRA (bends below 180°). Inverse of :func:`control_polygon`."""
    pts = np.asarray(pts, float)
    legs = np.diff(pts, axis=0)
    leg_len = np.linalg.norm(legs, axis=1)
    d = legs / leg_len[:, None]
    n = len(pts) - 2
    ang = np.array([np.arccos(np.clip(np.dot(d[i], d[i + 1]), -1, 1)) for i in range(n)])
    tanlen = np.asarray(clr, float) * np.tan(ang / 2)
    lengths = leg_len.copy()
    lengths[:-1] -= tanlen
    lengths[1:] -= tanlen
    normals = []
    for i in range(n):
        v = d[i + 1] - np.dot(d[i + 1], d[i]) * d[i]
        normals.append(v / np.linalg.norm(v))
    t0 = d[0]
    if n:
        y0 = normals[0]
    else:
        y0 = any_perpendicular(t0)
    rotations = np.zeros(n + 1)
    nprev = y0
    for i in range(n):
        if i:
            rotations[i] = signed_angle(nprev, normals[i], d[i])
        nprev = normals[i] * np.cos(ang[i]) - d[i] * np.sin(ang[i])
    frame = np.column_stack([t0, y0, np.cross(t0, y0)])
    return TubeModel(pts[0].copy(), frame, lengths, rotations, ang, np.asarray(clr, float).copy(),
                     float(pipe_radius))


def frame_quaternion(frame: np.ndarray) -> list[float]:
    """``[w, x, y, z]`` (w ≥ 0) of the rotation that maps the world axes onto ``frame``'s columns."""
    return [float(v) for v in quaternion(Rotation.from_matrix(frame), positive_w=True)]


def quaternion_frame(q) -> np.ndarray:
    """The frame (columns x, y, z) of a ``[w, x, y, z]`` quaternion."""
    return rotation(q).as_matrix()


# --- distances ------------------------------------------------------------------------------

def _segment_frames(sp: Spine) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal frames of the segments, rows (e1, e2, e3): (S, 3, 3), and the frame
    origins' coordinates in them: (S, 3). Lines: (tangent, ⟂, ⟂) at the start; arcs:
    (centre → arc start, start tangent, plane normal) at the centre."""
    S = len(sp.kind)
    t = sp.tangent / np.linalg.norm(sp.tangent, axis=1)[:, None]
    e = np.eye(3)[np.argmin(np.abs(t), axis=1)]
    p = e - np.einsum("sk,sk->s", e, t)[:, None] * t
    p /= np.linalg.norm(p, axis=1)[:, None]
    line = (sp.kind == 0)[:, None]
    b1 = np.where(line, t, -sp.normal)
    b2 = np.where(line, p, sp.tangent)
    basis = np.stack([b1, b2, cross(b1, b2)], 1)
    origin = np.where(line, sp.start, sp.centre[:S] if len(sp.centre) else sp.start)
    return basis, np.einsum("sjk,sk->sj", basis, origin)


def distance_frames(sp: Spine) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What :func:`spine_distance` needs of a spine besides the points: the (3, 3S) matrix of
    segment frame axes (columns grouped as line e1, e2, e3 | arc e1, e2, e3), the origin
    offsets, and the line and arc indices. Precompute it when one spine is queried often."""
    basis, origin = _segment_frames(sp)
    lines = np.flatnonzero(sp.kind == 0)
    arcs = np.flatnonzero(sp.kind != 0)
    W = np.concatenate([basis[g].transpose(1, 0, 2).reshape(-1, 3) for g in (lines, arcs)]).T  # (3, 3S)
    off = np.concatenate([origin[g].T.reshape(-1) for g in (lines, arcs)])
    return W, off, lines, arcs


def _segment_distances(pts: np.ndarray, sp: Spine, frames=None) -> np.ndarray:
    """Distance of each point to each (bounded) segment: (N, S) (a view of :func:`segment_distances_t`)."""
    return segment_distances_t(pts, sp, frames).T


def segment_distances_t(pts: np.ndarray, sp: Spine, frames=None) -> np.ndarray:
    """Distance of each point to each (bounded) segment, segments by rows: (S, N).

    All segments at once: one product gives every point's coordinates in every segment's
    frame; the distances then follow elementwise from those coordinates. Segment-major, so that every
    elementwise operation runs over contiguous rows of points (point-major slices of a few segments are
    strided, several times slower)."""
    S = len(sp.kind)
    W, off, lines, arcs = frames if frames is not None else distance_frames(sp)
    # both operands C-contiguous: numpy hands strided ones to a loop far slower than BLAS
    c = np.ascontiguousarray(W.T) @ np.ascontiguousarray(pts.T)
    c -= off[:, None]
    L, A = len(lines), len(arcs)
    out = np.empty((S, len(pts)))
    # the formulas' operations in their order, in place in a few scratch arrays: the same numbers to the last bit
    # as fresh temporaries, with a third of the memory passes (each temporary of a block's size was a fresh array)
    if L:
        a, b, h = c[:L], c[L:2 * L], c[2 * L:3 * L]
        # a − clip(a, 0, length): the offset beyond either end of the straight
        da = np.subtract(a, sp.length[lines][:, None])
        np.maximum(da, 0.0, out=da)
        sq = np.minimum(a, 0.0)
        da += sq
        da *= da
        da += np.multiply(b, b, out=sq)
        da += np.multiply(h, h, out=sq)  # (da² + b²) + h²
        out[lines] = np.sqrt(da, out=da)
    if A:
        o = 3 * L
        x, y, z = c[o:o + A], c[o + A:o + 2 * A], c[o + 2 * A:]
        R, ang = sp.radius[arcs][:, None], sp.angle[arcs][:, None]
        ca, sa = np.cos(ang), np.sin(ang)
        z2 = np.multiply(z, z)
        yy = np.multiply(y, y)
        d_in = np.multiply(x, x)  # (ρ − R)² + z², ρ = √(x² + y²)
        d_in += yy
        np.sqrt(d_in, out=d_in)
        d_in -= R
        d_in *= d_in
        d_in += z2
        # arc start is (R, 0, 0) and arc end (R cos a, R sin a, 0) in the arc frame
        d_s = np.subtract(x, R)  # ((x − R)² + y²) + z²
        d_s *= d_s
        d_s += yy
        d_s += z2
        d_e = np.subtract(x, R * ca)  # ((x − R cos a)² + (y − R sin a)²) + z²
        d_e *= d_e
        t = np.subtract(y, R * sa, out=yy)
        t *= t
        d_e += t
        d_e += z2
        np.minimum(d_s, d_e, out=d_s)
        # polar angle of (x, y) in [0, angle]: upper half plane and not beyond the end
        # direction (angles ≤ π), or either (angles > π); on the boundary both branches agree
        before_end = np.multiply(ca, y, out=d_e)
        before_end -= np.multiply(sa, x, out=t)
        before_end = np.less_equal(before_end, 0.0)
        inside = np.greater_equal(y, 0.0)
        for r in range(A):
            (np.logical_and if ang[r, 0] <= np.pi else np.logical_or)(inside[r], before_end[r], out=inside[r])
        # one square root of whichever squared distance applies (the same numbers as a root of each)
        np.copyto(d_s, d_in, where=inside)
        out[arcs] = np.sqrt(d_s, out=d_s)
    return out


def first_within(m: np.ndarray, cut: np.ndarray) -> np.ndarray:
    """``np.argmax(m <= cut, axis=0)``: per column of ``m`` (S, n) the first row at most ``cut`` (0 when none is).

    As a bit per row (rows up to 63): each column's hits form a number of 16, 32 or 64 bits, whose lowest set bit is
    the first row. numpy's argmax down the columns of a C-ordered array walks them with a stride of a whole row, seven
    times the time of the rows' comparisons here; the result is the same integers."""
    S, n = m.shape
    if S > 63:
        return np.argmax(m <= cut, axis=0)
    word = np.uint16 if S <= 16 else np.uint32 if S <= 32 else np.uint64
    bits = np.zeros(n, word)
    hit = np.empty(n, bool)
    one = word(1)
    for k in range(S - 1, -1, -1):
        bits <<= one
        bits |= np.less_equal(m[k], cut, out=hit)
    # the lowest set bit alone (x & -x), a power of two that a double holds exactly: its exponent is the row
    np.bitwise_and(bits, np.negative(bits), out=bits)
    row = np.frexp(bits.astype(np.float64))[1]
    row -= 1
    return np.maximum(row, 0, out=row)


def spine_distance(pts: np.ndarray, sp: Spine, chunk: int = 200_000,
                   frames=None) -> tuple[np.ndarray, np.ndarray]:
    """Distance of each point to the centreline and the index of the closest segment.

    ``chunk`` bounds points × segments per block: the (chunk,) temporaries stay in the processor's
    cache (twice as fast on a million samples as blocks of ten times the size)."""
    # the segment numbers in 16 bits when they fit: a large scan holds several such arrays (8 bytes a sample each)
    d = np.empty(len(pts)); idx = np.empty(len(pts), np.int16 if len(sp.kind) < 2 ** 15 else np.intp)
    step = max(1, chunk // max(len(sp.kind), 1))
    # max |coordinate| from the extremes: no |pts| temporary of the size of a large scan
    p_abs = max(float(-pts.min(initial=0.0)), float(pts.max(initial=0.0))) if pts.size else 0.0
    tol = 1e-12 * (float(np.abs(sp.start).max(initial=0.0)) + p_abs + 1e-300)
    frames = frames if frames is not None else distance_frames(sp)
    for a in range(0, len(pts), step):
        m = segment_distances_t(pts[a:a + step], sp, frames)
        # first segment within round-off of the minimum: a point at a junction (or at a
        # zero-length straight) goes to the earlier segment, independent of round-off
        lo = m.min(axis=0)
        i = first_within(m, lo + tol)
        idx[a:a + step] = i
        d[a:a + step] = np.take_along_axis(m, i[None], 0)[0]
    return d, idx


def closest_points(pts: np.ndarray, sp: Spine, idx: np.ndarray) -> np.ndarray:
    """Closest point of segment ``idx[i]`` (bounded) to each ``pts[i]``: (N, 3)."""
    st, en, tg = sp.start[idx], sp.end[idx], sp.tangent[idx]
    rel = pts - st
    s = np.clip(np.einsum("nk,nk->n", rel, tg), 0.0, sp.length[idx])
    c = st + s[:, None] * tg
    arc = sp.kind[idx] != 0
    if arc.any():
        ia = idx[arc]
        p = pts[arc]
        u, v = -sp.normal[ia], sp.tangent[ia]
        rel = p - sp.centre[ia]
        x, y = np.einsum("nk,nk->n", rel, u), np.einsum("nk,nk->n", rel, v)
        phi = np.mod(np.arctan2(y, x), TWO_PI)
        rho = np.maximum(np.hypot(x, y), 1e-300)
        on = sp.centre[ia] + (sp.radius[ia] / rho)[:, None] * (x[:, None] * u + y[:, None] * v)
        ds = np.einsum("nk,nk->n", p - st[arc], p - st[arc])
        de = np.einsum("nk,nk->n", p - en[arc], p - en[arc])
        ends = np.where((ds <= de)[:, None], st[arc], en[arc])
        c[arc] = np.where((phi <= sp.angle[ia])[:, None], on, ends)
    return c


def sample_centreline(model: TubeModel, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points along the centreline about ``step`` apart (all segment ends included) and tangents."""
    sp = build_spine(model)
    pts, tans = [], []
    for k in range(len(sp.kind)):
        m = max(1, int(np.ceil(sp.length[k] / step)))
        s = np.linspace(0.0, 1.0, m + 1)
        if k:
            s = s[1:]
        if sp.kind[k] == 0:
            pts.append(sp.start[k] + np.outer(s * sp.length[k], sp.tangent[k]))
            tans.append(np.repeat(sp.tangent[k][None], len(s), 0))
        else:
            a = s * sp.angle[k]
            R = sp.radius[k]
            t, nv = sp.tangent[k], sp.normal[k]
            pts.append(sp.centre[k] - R * np.outer(np.cos(a), nv) + R * np.outer(np.sin(a), t))
            tans.append(np.outer(np.cos(a), t) + np.outer(np.sin(a), nv))
    return np.vstack(pts), np.vstack(tans)


def tube_mesh_arrays(model: TubeModel, ring: int = 32, step: float | None = None):
    """Vertices and faces of the tube surface (open ends), parallel-transported rings."""
    r = model.pipe_radius
    step = step or max(r / 2, 1e-9)
    c, t = sample_centreline(model, step)
    u = model.frame[:, 1].copy()
    frames = []
    for i in range(len(c)):
        u = u - np.dot(u, t[i]) * t[i]
        nu = np.linalg.norm(u)
        u = u / nu if nu > 1e-12 else any_perpendicular(t[i])
        frames.append((u, np.cross(t[i], u)))
    th = np.linspace(0, TWO_PI, ring, endpoint=False)
    U = np.array([f[0] for f in frames]); V = np.array([f[1] for f in frames])
    verts = (c[:, None, :] + r * (np.cos(th)[None, :, None] * U[:, None, :]
                                   + np.sin(th)[None, :, None] * V[:, None, :])).reshape(-1, 3)
    i = np.arange(len(c) - 1)[:, None]
    j = np.arange(ring)[None, :]
    a = i * ring + j
    b = i * ring + (j + 1) % ring
    a2 = a + ring
    b2 = b + ring
    faces = np.concatenate([np.stack([a, b, b2], -1).reshape(-1, 3), np.stack([a, b2, a2], -1).reshape(-1, 3)])
    return verts, faces
