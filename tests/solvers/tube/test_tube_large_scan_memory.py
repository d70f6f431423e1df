"""A large scan's end re-assignment makes no temporaries of the scan's size: fresh memory of a scan's size costs
the kernel a page fault per page (a fifth of a 10 M-sample solve was system time). tracemalloc sees numpy's
data buffers, so the peak of a call is the memory it asked for."""

import tracemalloc

import numpy as np

from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.model import TubeModel, sample_centreline


def _tube() -> TubeModel:
    frame = np.eye(3)
    return TubeModel(np.zeros(3), frame, np.array([40.0, 30.0, 50.0]), np.array([0.0, 0.7, 0.0]),
                     np.radians([90.0, 60.0]), np.array([25.0, 30.0]), 10.0)


def _samples(model: TubeModel, n: int) -> np.ndarray:
    """Points scattered about the tube's centreline (the assignment needs no surface)."""
    rng = np.random.default_rng(3)
    centre, _ = sample_centreline(model, 0.5)
    return centre[rng.integers(len(centre), size=n)] + rng.normal(scale=10.0, size=(n, 3))


def _peak_bytes(call):
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        out = call()
        return out, tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()


def test_end_reassignment_of_a_large_scan_holds_its_two_outputs_and_blocks():
    model = _tube()
    n = 300_000
    pts = _samples(model, n)
    again = fit.EndAssignment(model, pts, 20.0)
    longer = model.copy()  # the end straights moved, the first arc where it was
    longer.lengths = model.lengths + np.array([3.0, 0.0, -2.0])
    longer.start = model.start - 3.0 * model.frame[:, 0]
    (res, seg), peak = _peak_bytes(lambda: again(longer))
    # the known answer: the assignment of every sample to the whole spine
    res_all, seg_all = fit.assign(longer, pts, 20.0)
    np.testing.assert_array_equal(res, res_all)
    np.testing.assert_array_equal(seg, seg_all)
    # the two outputs (16 bytes a sample) and one block's temporaries; main made ten arrays of the
    # samples' size (112 bytes a sample)
    assert peak < 64 * n, peak / n
