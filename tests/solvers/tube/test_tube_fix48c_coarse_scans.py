"""A scan printed coarsely (1 mm, 0.1 mm) has distinct measurements that print alike: each is a sample, not a
paste, and is kept. A paste is a run of rows repeating an earlier run, or more exact repeats than the print's
resolution explains."""

from __future__ import annotations

import io

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.upload import parse_upload
from tests.conftest import REPO

POINTS = np.loadtxt(io.BytesIO((REPO / "examples" / "tube" / "scan.xyz").read_bytes()))


def _text(points: np.ndarray, decimals: int) -> bytes:
    return "\n".join(" ".join(f"{v:.{decimals}f}" for v in p) for p in points).encode()


def _request(points: np.ndarray, decimals: int):
    return parse_upload(StoredInput.from_bytes("scan.xyz", _text(points, decimals)), {})


@pytest.mark.parametrize("decimals, coincide", [(0, 1138), (1, 8)])
def test_a_coarse_print_keeps_every_sample(decimals, coincide):
    printed = np.loadtxt(io.BytesIO(_text(POINTS, decimals)))
    assert len(printed) - len(np.unique(printed, axis=0)) == coincide  # distinct measurements that print alike
    request = _request(POINTS, decimals)
    # before: 1,138 of the 4,000 samples of the 1 mm print were dropped, "a file or scan pasted twice"
    assert [w.code for w in request.source.warnings] == []
    np.testing.assert_array_equal(np.asarray(request.points), printed)


def test_a_coarse_print_pasted_twice_is_read_once():
    once = _request(POINTS, 0)
    twice = _request(np.vstack([POINTS, POINTS]), 0)
    (warning,) = twice.source.warnings
    assert warning.code == "duplicate_points" and warning.details == {"repeated": 4000, "samples": 8000, "kept": 4000}
    np.testing.assert_array_equal(np.asarray(twice.points), np.asarray(once.points))


def test_scattered_repeats_beyond_a_fine_prints_resolution_are_left_out():
    # 3 decimals: no two samples print alike, so 50 rows repeated out of order are copies
    extra = np.random.default_rng(7).choice(len(POINTS), 50, replace=False)
    rows = np.vstack([POINTS, POINTS[extra]])
    rows = rows[np.random.default_rng(8).permutation(len(rows))]
    request = _request(rows, 3)
    (warning,) = request.source.warnings
    assert warning.details == {"repeated": 50, "samples": 4050, "kept": 4000}
    got = np.asarray(request.points)
    np.testing.assert_array_equal(np.unique(got, axis=0), np.unique(np.round(POINTS, 3), axis=0))
