"""An NPY of more than three columns (x y z intensity, a row number first) says which columns were read as x, y, z
and which were left out: its first three were read without a word, a row number among them (a tube 1 mm apart
along x, its x read from its y)."""

import io

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

POINTS = surface_samples(make_model([(120, 0, 90, 30), (100, 0, 0, 0)], 6.0), 500, np.random.default_rng(0))


def _request(arr: np.ndarray):
    buf = io.BytesIO()
    np.save(buf, arr)
    return parse_upload(StoredInput.from_bytes("scan.npy", buf.getvalue()), None)


def test_x_y_z_intensity_reads_the_first_three_and_names_the_fourth():
    intensity = np.random.default_rng(1).uniform(0, 255, (len(POINTS), 1))
    request = _request(np.hstack([POINTS, intensity]))
    (warning,) = request.source.warnings
    assert warning.code == "npy_columns_dropped" and warning.details["dropped_columns"] == [4]
    assert "column 4" in warning.message
    np.testing.assert_allclose(np.asarray(request.points), POINTS)


@pytest.mark.parametrize("start", [0, 1])
def test_a_row_number_first_is_left_out_and_x_y_z_read_after_it(start):
    numbers = np.arange(start, start + len(POINTS), dtype=np.float64)[:, None]
    request = _request(np.hstack([numbers, POINTS]))
    (warning,) = request.source.warnings
    assert warning.details["coordinate_columns"] == [2, 3, 4] and warning.details["row_numbers"]
    np.testing.assert_allclose(np.asarray(request.points), POINTS)


def test_three_columns_say_nothing():
    request = _request(POINTS)
    assert request.source.warnings == []
