"""bench/tube.py's comparison with the truth: it judges a result in the walking direction the solver took."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.tube.model import reverse_model
from plantsolve.solvers.tube.synthetic import make_model


@pytest.fixture
def bench(monkeypatch):
    path = Path(__file__).resolve().parents[3] / "bench" / "tube.py"
    spec = importlib.util.spec_from_file_location("tube_bench", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(module, "model_from_result", lambda model: model)  # the "result" is the model itself
    return module


@pytest.mark.parametrize("rows", [
    [[15.4, 0, 102.0, 5.0], [21.1, 0, 0, 0]],  # bench random-019: one bend, the angles tie both ways
    [[40.0, 0, 60.0, 9.0], [12.0, 35, 60.0, 9.0], [25.0, 0, 0, 0]],  # two equal bends: tie again
])
def test_a_result_walked_the_other_way_is_judged_against_the_truth_reversed(bench, rows):
    truth = make_model(rows, 2.3, start=(1.0, -2.0, 3.0))
    got = reverse_model(truth)
    got.lengths = got.lengths + 0.01  # end straights 0.01 off the truth's, in the result's walking direction
    da, dr, t, _ = bench.compare(truth, got)
    np.testing.assert_allclose(t.lengths, reverse_model(truth).lengths)
    assert np.abs(got.lengths[[0, -1]] - t.lengths[[0, -1]]).max() == pytest.approx(0.01)
    np.testing.assert_allclose(da, 0.0, atol=1e-9)


def test_a_result_walked_the_truths_way_keeps_it(bench):
    truth = make_model([[15.4, 0, 102.0, 5.0], [21.1, 0, 0, 0]], 2.3)
    _, _, t, _ = bench.compare(truth, truth.copy())
    np.testing.assert_allclose(t.lengths, truth.lengths)
