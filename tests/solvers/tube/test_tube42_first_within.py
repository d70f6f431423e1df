"""The first segment within round-off of a sample's nearest (``spine_distance``'s rule, and the end
re-assignment's) found as a bit per segment: the integers of ``np.argmax(m <= cut, axis=0)``."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.tube.model import first_within


@pytest.mark.parametrize("S", [1, 2, 3, 9, 16, 17, 32, 33, 63, 64, 70])
def test_first_row_within_the_cut_is_argmaxs(S):
    rng = np.random.default_rng(S)
    for n in (0, 1, 7, 3000):
        m = rng.integers(0, 4, (S, n)).astype(float)  # many ties
        m[:, :min(n, 2)] = np.nan  # no row within: row 0, as argmax gives
        cut = m.min(axis=0) + rng.integers(0, 2, n)
        got = first_within(m, cut)
        assert np.array_equal(got, np.argmax(m <= cut, axis=0))
        assert got.shape == (n,)


def test_a_column_of_hits_in_every_row_and_in_the_last_only():
    S, n = 9, 4
    m = np.zeros((S, n))
    m[:-1, 1] = 5.0  # column 1: only the last row within
    m[:, 2] = np.arange(S)[::-1]  # column 2: the rows fall, the last is the minimum
    m[:, 3] = 1.0  # column 3: every row ties
    cut = m.min(axis=0)
    assert first_within(m, cut).tolist() == [0, S - 1, S - 1, 0]
