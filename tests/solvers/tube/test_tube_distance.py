"""Point-to-centreline distances (vectorised kernel) and the nominal alignment's Jacobian."""

import numpy as np
import pytest

from plantsolve.solvers.tube.model import (TubeModel, build_spine, closest_points, distance_frames, sample_centreline,
                                          segment_distances_t, spine_distance)
from plantsolve.solvers.tube.inspection import align
from plantsolve.solvers.tube.synthetic import random_tube


def _brute(pts, model, step):
    """Distance to a dense polyline through centreline samples (chords: error ≤ sagitta step²/8R)."""
    c, _ = sample_centreline(model, step)
    keep = np.linalg.norm(np.diff(c, axis=0), axis=1) > 0  # zero-length straights repeat a sample
    a, b = c[:-1][keep], c[1:][keep]
    ab = b - a
    t = np.clip(np.einsum("nsk,sk->ns", pts[:, None] - a[None], ab) / np.einsum("sk,sk->s", ab, ab), 0, 1)
    return np.linalg.norm(pts[:, None] - (a[None] + t[..., None] * ab[None]), axis=2).min(1)


@pytest.mark.parametrize("seed", range(6))
def test_spine_distance_matches_dense_polyline(seed):
    rng = np.random.default_rng(seed)
    m = random_tube(rng, n_bends=4)
    m.angles[0] = np.radians(250.0)  # an arc beyond 180°: the in-arc test has two branches
    sp = build_spine(m)
    lo, hi = sp.start.min(0) - 3 * m.pipe_radius, sp.start.max(0) + 3 * m.pipe_radius
    pts = rng.uniform(lo, hi, size=(400, 3))
    pts = np.vstack([pts, sp.centre[sp.kind == 1]])  # arc centres: equidistant from the whole arc
    step = 0.02 * m.pipe_radius
    d, idx = spine_distance(pts, sp, chunk=len(sp.kind) * 37)  # several chunks
    ref = _brute(pts, m, step)
    sagitta = step ** 2 / (8 * sp.radius[sp.kind == 1].min())
    np.testing.assert_allclose(d, ref, atol=sagitta + 1e-9 * m.pipe_radius, rtol=0)
    c = closest_points(pts, sp, idx)
    np.testing.assert_allclose(np.linalg.norm(pts - c, axis=1), d, atol=1e-9 * m.pipe_radius)


def _distances_fresh(pts, sp):
    """The segment distances written as plain expressions, a fresh array per operation: what the in-place
    kernel must give to the last bit (the fits' numbers, and so the benches' figures, rest on those bits)."""
    W, off, lines, arcs = distance_frames(sp)
    c = np.ascontiguousarray(W.T) @ np.ascontiguousarray(pts.T)
    c -= off[:, None]
    L, A = len(lines), len(arcs)
    out = np.empty((len(sp.kind), len(pts)))
    a, b, h = c[:L], c[L:2 * L], c[2 * L:3 * L]
    da = np.maximum(a - sp.length[lines][:, None], 0.0) + np.minimum(a, 0.0)
    out[lines] = np.sqrt(da * da + b * b + h * h)
    x, y, z = c[3 * L:3 * L + A], c[3 * L + A:3 * L + 2 * A], c[3 * L + 2 * A:]
    R, ang = sp.radius[arcs][:, None], sp.angle[arcs][:, None]
    ca, sa = np.cos(ang), np.sin(ang)
    d_in2 = (np.sqrt(x * x + y * y) - R) ** 2 + z * z
    d_s = (x - R) ** 2 + y * y + z * z
    d_e = (x - R * ca) ** 2 + (y - R * sa) ** 2 + z * z
    before_end, upper = ca * y - sa * x <= 0.0, y >= 0.0
    inside = np.where(ang <= np.pi, upper & before_end, upper | before_end)
    out[arcs] = np.sqrt(np.where(inside, d_in2, np.minimum(d_s, d_e)))
    return out


@pytest.mark.parametrize("seed", range(4))
def test_segment_distances_are_the_plain_formulas_to_the_bit(seed):
    rng = np.random.default_rng(seed)
    m = random_tube(rng, n_bends=5)
    m.angles[1] = np.radians(250.0)  # both branches of the in-arc test
    m.lengths[2] = 0.0  # a zero-length straight
    sp = build_spine(m)
    lo, hi = sp.start.min(0) - 3 * m.pipe_radius, sp.start.max(0) + 3 * m.pipe_radius
    pts = np.vstack([rng.uniform(lo, hi, size=(3000, 3)), sp.start, sp.end, sp.centre[sp.kind == 1]])
    got = segment_distances_t(pts, sp)
    assert np.array_equal(got.view(np.uint64), _distances_fresh(pts, sp).view(np.uint64))


def test_junction_ties_go_to_the_earlier_segment():
    m = TubeModel(np.zeros(3), np.eye(3), np.array([10.0, 0.0, 10.0]), np.zeros(3),
                  np.radians([90.0, 90.0]), np.array([5.0, 5.0]), 1.0)
    sp = build_spine(m)
    # each segment end is the next one's start; the zero-length straight (segment 2) ends
    # where the first arc (segment 1) ends, so that point belongs to the arc
    _, idx = spine_distance(sp.end[:-1], sp)
    np.testing.assert_array_equal(idx, [0, 1, 1, 3])


def test_alignment_recovers_a_rigid_motion():
    rng = np.random.default_rng(3)
    nominal = random_tube(rng, n_bends=3)
    nominal.start = np.zeros(3); nominal.frame = np.eye(3)
    measured = nominal.copy()
    ang = 0.3
    Rz = np.array([[np.cos(ang), -np.sin(ang), 0], [np.sin(ang), np.cos(ang), 0], [0, 0, 1]])
    measured.frame = Rz @ measured.frame
    measured.start = np.array([5.0, -3.0, 2.0])
    R, t, d = align(measured, nominal)
    np.testing.assert_allclose(R, Rz, atol=1e-7)
    np.testing.assert_allclose(t, measured.start, atol=1e-6 * nominal.pipe_radius)
    assert d.max() < 1e-6 * nominal.pipe_radius
