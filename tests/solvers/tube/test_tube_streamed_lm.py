"""A large scan's least-squares round keeps no array of its samples' size: its solver takes the soft-L1 cost
a block at a time (the normal equations summed on the way), which must be the numbers of the residuals and
weights over all samples to the last bit, and so the same fit."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.synthetic import make_model, surface_samples


@pytest.mark.parametrize("n", [1, 8, 129, fit.BLOCK, fit.BLOCK + 1, 3 * fit.BLOCK + 17, 40 * fit.BLOCK + 5])
def test_pairwise_sum_in_parts_is_numpys_sum_to_the_bit(n):
    rng = np.random.default_rng(n)
    a = rng.exponential(size=n) * 10.0 ** rng.uniform(-6, 6, n)  # wide magnitudes: the order of the adds shows
    total = fit.PairwiseSum(n)
    cuts = np.unique(np.r_[0, np.sort(rng.integers(0, n, 7)), n])
    for lo, hi in zip(cuts[:-1], cuts[1:]):  # parts of any size, none aligned to numpy's splits
        total.add(a[lo:hi])
    assert total.value() == np.sum(a)
    assert (total.value() == np.sum(a[::-1])) == (np.sum(a) == np.sum(a[::-1]))


def test_pairwise_sum_refuses_a_total_of_missing_numbers():
    total = fit.PairwiseSum(3 * fit.BLOCK)
    total.add(np.ones(fit.BLOCK))
    with pytest.raises(ValueError, match="not handed over"):
        total.value()


def test_a_streamed_round_is_the_round_over_arrays_of_all_samples_to_the_bit():
    # (2-3 s: a round streams only beyond one block of samples, 65,536)
    rng = np.random.default_rng(7)
    m = make_model([[30, 0, 40, 10], [12, 70, 100, 9], [20, -30, 15, 12], [25, 0, 0, 0]], 2.0)
    pts = surface_samples(m, 2 * fit.BLOCK + 900, rng, noise=0.02, outlier_fraction=0.01)
    _, seg = fit.assign(m, pts, 4.0)
    start = m.copy()
    start.angles = m.angles * 1.03
    start.radii = m.radii * 0.95
    keep = rng.uniform(size=len(pts)) > 0.05
    lay = fit.Layout(start.n_bends, "free", None, True)
    f_scale, max_nfev = 0.04, 6
    x0, lo, hi, fun, normal_equations, _, _, cost = fit._problem(start, pts, seg, lay, keep, f_scale, max_nfev)
    assert cost is not None  # more than one block: streamed
    streamed, info = fit.levenberg_marquardt(fun, normal_equations, x0, lo, hi, f_scale, max_nfev, cost=cost)
    # the same round with every sample's residuals and weights in arrays (the normal equations from them)
    x0, lo, hi, fun, normal_equations, _, _, _ = fit._problem(start, pts, seg, lay, keep, f_scale, max_nfev)
    arrays, info_arrays = fit.levenberg_marquardt(fun, normal_equations, x0, lo, hi, f_scale, max_nfev)
    assert info["nfev"] == info_arrays["nfev"] == max_nfev
    assert info["cost"] == info_arrays["cost"]
    assert np.array_equal(streamed, arrays)
    assert not np.array_equal(streamed, x0)
