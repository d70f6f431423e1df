"""Work the tube solver does once: no model is assigned to the same samples twice (``fit.assign`` of equal
model, samples and margin), while the numbers it gives are those of the assignment computed anew."""

from __future__ import annotations

import hashlib

import numpy as np

from plantsolve.solvers.tube import fit
from plantsolve.solvers.tube.solve import solve

from .conftest import SHAPES, request, scan


def _digest(*arrays) -> str:
    h = hashlib.sha1()
    for a in arrays:
        h.update(np.ascontiguousarray(a, dtype=float).tobytes())
    return h.hexdigest()


def test_no_model_is_assigned_twice_to_the_same_samples(monkeypatch):
    calls: dict[tuple, int] = {}
    given: list[tuple] = []
    assign = fit.assign

    def counted(model, pts, margin):
        key = (_digest(model.start, model.frame, model.lengths, model.rotations, model.angles, model.radii,
                       [model.pipe_radius]), _digest(pts), float(margin))
        calls[key] = calls.get(key, 0) + 1
        out = assign(model, pts, margin)
        given.append((model, pts.copy(), margin, out[0], out[1]))  # the arrays handed out
        return out

    monkeypatch.setattr(fit, "assign", counted)
    # three bends: the bend count's re-check, the common and two-die radius models and the final inliers all run
    _, pts = scan(SHAPES["three_bends"], n=4000, seed=3, view=(1.0, 0.4, 0.2), noise=0.04, outliers=0.005)
    res = solve(request(pts)).result
    assert len(res.lra) == 4 and res.bend_radius_model is not None
    repeated = {k: n for k, n in calls.items() if n > 1}
    assert not repeated, f"{len(repeated)} assignments computed more than once"
    # what each call returned is what the assignment gives those inputs anew (nothing written into it since)
    for model, p, margin, r, s in given:
        r2, s2 = assign(model, p, margin)
        np.testing.assert_array_equal(r, r2)
        np.testing.assert_array_equal(s, s2)
