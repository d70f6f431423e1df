"""A scan file held twice in another order (reversed, shuffled, each row doubled) is read once, however coarsely it
is printed: every position then comes an even number of times, which a print's own coincidences do not give."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.upload import parse_upload
from tests.conftest import REPO

SCAN = np.loadtxt(REPO / "examples" / "tube" / "scan.xyz")


def _read(points: np.ndarray, decimals: int):
    text = "\n".join(" ".join(f"{v:.{decimals}f}" for v in p) for p in points).encode()
    return parse_upload(StoredInput.from_bytes("scan.xyz", text), {})


@pytest.mark.parametrize("decimals", [0, 1, 3])
@pytest.mark.parametrize("again", ["reversed", "shuffled", "each row doubled"])
def test_a_file_held_twice_in_any_order_is_read_once(decimals, again):
    once = np.array(_read(SCAN, decimals).points, dtype=float)
    twice = {"reversed": np.vstack([SCAN, SCAN[::-1]]),
             "shuffled": np.vstack([SCAN, SCAN[np.random.default_rng(1).permutation(len(SCAN))]]),
             "each row doubled": np.repeat(SCAN, 2, axis=0)}[again]
    request = _read(twice, decimals)
    got = np.array(request.points, dtype=float)
    # the same samples as the file held once, coarse coincidences included (a 1 mm print keeps all 4,000)
    assert len(got) == len(once) == len(SCAN)
    np.testing.assert_array_equal(np.unique(got, axis=0, return_counts=True)[1],
                                  np.unique(once, axis=0, return_counts=True)[1])
    (warning,) = [w for w in request.source.warnings if w.code == "duplicate_points"]
    assert warning.details == {"repeated": len(SCAN), "samples": 2 * len(SCAN), "kept": len(SCAN)}
