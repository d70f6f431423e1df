"""The ends of a dense scan: a sparse halo of stray samples just past a tube end must not lengthen the end
straights, at any sample density (at 10 million samples such strays have company from the end itself)."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.model import build_spine
from plantsolve.solvers.tube.synthetic import make_model, surface_samples

RP = 4.0
TRUTH = make_model([[40, 0, 60, 12], [20, 45, 80, 12], [30, 0, 0, 0]], RP)


def halo(rng, n: int, near: float, far: float) -> np.ndarray:
    """``n`` samples on the pipe surface between ``near`` and ``far`` past the last end, evenly around it."""
    sp = build_spine(TRUTH)
    t, nv = sp.tangent[-1], sp.normal[-1]
    b = np.cross(t, nv)
    s = TRUTH.lengths[-1] + rng.uniform(near, far, n)
    v = rng.uniform(0, 2 * np.pi, n)
    return sp.start[-1] + s[:, None] * t + RP * (np.cos(v)[:, None] * nv + np.sin(v)[:, None] * b)


def ends(pts: np.ndarray) -> np.ndarray:
    """End straight lengths that fit.end_lengths settles on, starting from ends one pipe radius short."""
    short = TRUTH.copy()
    short.start = short.start + RP * short.frame[:, 0]
    short.lengths = short.lengths.copy()
    short.lengths[[0, -1]] -= RP
    res, seg = fit.assign(short, pts, 2 * RP)
    m, _, _, settled = fit.end_lengths(short, pts, res, seg, 0.05 * RP, 2 * RP)
    assert settled
    return m.lengths[[0, -1]]


@pytest.mark.parametrize("n", [60_000, 240_000])
def test_a_halo_of_strays_past_a_dense_end_does_not_lengthen_it(n):
    # 8 strays 0.1-0.4 r past the end: each has more than three neighbours within 0.5 r (the end itself),
    # yet they are a thousand times sparser along the axis than the end
    rng = np.random.default_rng(3)
    pts = np.vstack([surface_samples(TRUTH, n, rng, noise=0.01 * RP), halo(rng, 8, 0.1 * RP, 0.4 * RP)])
    np.testing.assert_allclose(ends(pts), TRUTH.lengths[[0, -1]], atol=0.02 * RP)


def test_the_halo_cut_leaves_a_clean_end_and_a_sparse_scan_alone():
    rng = np.random.default_rng(4)
    # uniform samples up to a cut end: no halo at any density
    for n in (30, 2000):
        assert fit._halo_cut(np.sort(rng.uniform(0, 1, n))[::-1]) is None
    # a single stray past a sparse end is as far from it as the end's samples from each other: not a halo
    p = np.r_[1.0 + 1.0 / 30, np.sort(rng.uniform(0, 1, 30))[::-1]]
    assert fit._halo_cut(p) is None
    # the same stray past the same end sampled 100 times as densely is
    p = np.r_[1.0 + 1.0 / 30, np.sort(rng.uniform(0, 1, 3000))[::-1]]
    assert fit._halo_cut(p) == pytest.approx(p[1])


def test_the_ends_of_a_scan_without_strays_are_found_as_before():
    # the old rule (outermost sample with three neighbours within 0.5 r) decides when there is no halo
    rng = np.random.default_rng(5)
    pts = surface_samples(TRUTH, 60_000, rng, noise=0.01 * RP)
    np.testing.assert_allclose(ends(pts), TRUTH.lengths[[0, -1]], atol=0.02 * RP)
