"""The one-model geometry of an LM evaluation (``fit.geometry_one``) is the batch's (``fit.geometry_batch``) to the
last bit: the fit's answers must not move when the evaluation takes the faster path."""

import numpy as np
import pytest

from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.synthetic import clear_tube, make_model


def _layouts(n: int, rng: np.random.Generator) -> list[fit.Layout]:
    lays = [fit.Layout(n, "free", None, True), fit.Layout(n, "common", None, False),
            fit.Layout(n, "fixed", 3.0, True)]
    if n >= 2:
        dies = (0,) + tuple(int(v) for v in rng.integers(0, 2, n - 2)) + (1,)  # both dies used
        lays += [fit.Layout(n, "dies", None, True, dies),
                 fit.Layout(n, "fixed", None, False, (), tuple(float(v) for v in rng.uniform(1.0, 5.0, n)))]
    return lays


@pytest.mark.parametrize("seed", range(4))
def test_geometry_one_is_the_batch_row_bit_for_bit(seed):
    # random tubes of 0-8 bends (angles up to 200°), every radius layout, start rotations on both sides of the
    # 1e-3 rad switch to the Taylor series, each parameter jittered off the model's exact values
    rng = np.random.default_rng(seed)
    checked = 0
    for _ in range(12):
        m = clear_tube(rng, pipe_radius=float(rng.uniform(1.0, 50.0)), n_bends=int(rng.integers(0, 9)))
        for lay in _layouts(m.n_bends, rng):
            x = fit.pack(m, lay)
            for turn in (0.0, 3e-4, 2e-3, 0.7, 3.0):
                xj = x + rng.normal(size=len(x)) * 1e-3
                xj[3:6] = rng.normal(size=3) * turn
                one = fit.geometry_one(xj, lay, m.frame)
                batch = fit.geometry_batch(xj[None], lay, m.frame, m.pipe_radius)[0]
                assert one.shape == batch.shape == (2 * m.n_bends + 1, 7)
                assert one.tobytes() == batch.tobytes()
                checked += 1
    assert checked >= 12 * 3 * 5


def test_geometry_one_of_a_known_tube():
    # one 90° bend of radius 10 after a straight along x in the identity frame, in the xy plane: the arc's
    # centre is 10 along the normal (y) from its start, its axis the binormal z; the next straight starts at
    # (40, 10, 0) along y
    m = make_model([[30, 0, 90, 10], [20, 0, 0, 0]], 2.0, frame=np.eye(3))
    lay = fit.Layout(1, "free", None, True)
    g = fit.geometry_one(fit.pack(m, lay), lay, m.frame)
    np.testing.assert_allclose(g[1], [30, 10, 0, 0, 0, 1, 10], atol=1e-12)
    np.testing.assert_allclose(g[2, :6], [40, 10, 0, 0, 1, 0], atol=1e-12)
