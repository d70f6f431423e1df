"""The robust end of a straight after a halo cut: the samples left are a mask of the end's samples, not copies of
them, and the rule finds the very number it finds on copies (a dense scan's end holds millions of samples)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from plantsolve.solvers.tube import fit


def robust_max_on_copies(proj: np.ndarray, pts: np.ndarray, rp: float) -> float:
    """The rule as first written: after a halo cut it starts again on copies of the samples at most the cut."""
    if len(proj) == 0:
        return 0.0
    cand = np.flatnonzero(proj >= proj.max() - 3.0 * rp)
    if len(cand) > 2000:
        cand = cand[np.argpartition(-proj[cand], 2000)[:2000]]
    cut = fit._halo_cut(np.sort(proj[cand])[::-1])
    if cut is not None:
        body = proj <= cut
        return robust_max_on_copies(proj[body], pts[body], rp)
    if len(cand) > 4:
        cand = cand[np.argsort(-proj[cand], kind="stable")]
        q = pts[cand]
        a = 0
        for size in itertools.chain((4, 28), itertools.repeat(32)):
            if a >= len(cand):
                break
            d2 = ((q[a:a + size, None, :] - q[None, :, :]) ** 2).sum(-1)
            dense = np.flatnonzero(np.count_nonzero(d2 <= (0.5 * rp) ** 2, axis=1) >= 4)
            if len(dense):
                return float(proj[cand[a + dense[0]]])
            a += size
    return float(np.percentile(proj, 99.5))


def straight_end(rng, n: int, length: float, rp: float, halos: list[tuple[int, float, float]]):
    """``n`` samples on a pipe of radius ``rp`` along x from 0 to ``length``, and per halo (count, near, far) that
    many strays between ``near`` and ``far`` past the end; the projections on x and the samples."""
    x = np.r_[rng.uniform(0.0, length, n)] if n else np.zeros(0)
    for count, near, far in halos:
        x = np.r_[x, length + rng.uniform(near, far, count)]
    v = rng.uniform(0, 2 * np.pi, len(x))
    pts = np.column_stack([x, rp * np.cos(v), rp * np.sin(v)])
    return pts[:, 0].copy(), pts


@pytest.mark.parametrize("seed", range(6))
def test_a_halo_cut_end_is_found_as_on_copies_and_at_the_true_end(seed):
    rng = np.random.default_rng(seed)
    rp = 2.0
    # a dense end with a sparse halo 0.2-1.5 r past it (cut), and one far stray beyond the candidates' zone
    proj, pts = straight_end(rng, 200_000, 100.0, rp, [(6, 0.2 * rp, 1.5 * rp), (1, 2.0 * rp, 2.5 * rp)])
    got = fit._robust_max(proj, pts, rp)
    assert got == robust_max_on_copies(proj, pts, rp)
    assert got == pytest.approx(100.0, abs=0.01)


def test_an_end_without_a_halo_and_a_sparse_one_are_as_on_copies():
    rng = np.random.default_rng(9)
    for n, halos in ((50_000, []), (30, [(2, 0.0, 1.0)]), (3, [])):
        proj, pts = straight_end(rng, n, 50.0, 1.0, halos)
        assert fit._robust_max(proj, pts, 1.0) == robust_max_on_copies(proj, pts, 1.0)


def test_an_end_given_as_row_numbers_of_all_samples_is_as_on_its_copies():
    # set_end_lengths hands over an end's samples as their rows among all samples, not as copies of them
    rng = np.random.default_rng(11)
    proj, pts = straight_end(rng, 100_000, 80.0, 2.0, [(6, 0.4, 3.0)])
    order = rng.permutation(len(pts))
    everything = pts[order]  # the end's samples scattered among the others (here: all samples are the end's)
    rows = np.sort(rng.choice(len(pts), 70_000, replace=False))
    end = everything[rows]
    got = fit._robust_max(end[:, 0].copy(), everything, 2.0, rows)
    assert got == robust_max_on_copies(end[:, 0].copy(), end, 2.0)
    assert got == pytest.approx(80.0, abs=0.01)
    along = fit._along(everything, rows, np.array([1.0, 2.0, 3.0]), np.array([0.6, 0.0, 0.8]))
    np.testing.assert_array_equal(along, (end - [1.0, 2.0, 3.0]) @ np.array([0.6, 0.0, 0.8]))
