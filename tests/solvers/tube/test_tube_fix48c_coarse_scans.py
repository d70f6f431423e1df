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


class _ScaledIntegerXYZ:
    """libe57 as pye57's writer sees it, with x, y, z stored as ScaledInteger on a ``scale`` grid (metres) as
    scanners' E57 exports often are; pye57 itself writes floats."""

    def __init__(self, libe57, scale: float):
        self._lib, self._scale = libe57, scale

    def __getattr__(self, name):
        return getattr(self._lib, name)

    def FloatNode(self, imf, *args):
        if len(args) == 4:  # a point field's prototype: value, precision, minimum, maximum
            value, _, low, high = args
            s = self._scale
            return self._lib.ScaledIntegerNode(imf, round(value / s), int(np.floor(low / s)) - 1,
                                               int(np.ceil(high / s)) + 1, s, 0.0)
        return self._lib.FloatNode(imf, *args)


def _e57(points_mm: np.ndarray, monkeypatch, scale: float | None) -> bytes:
    import tempfile

    import pye57
    import pye57.e57

    metres = points_mm / 1000.0
    with monkeypatch.context() as patch, tempfile.NamedTemporaryFile(suffix=".e57") as handle:
        if scale is not None:
            patch.setattr(pye57.e57, "libe57", _ScaledIntegerXYZ(pye57.e57.libe57, scale))
        writer = pye57.E57(handle.name, mode="w")
        writer.write_scan_raw({"cartesianX": metres[:, 0], "cartesianY": metres[:, 1], "cartesianZ": metres[:, 2]})
        writer.close()
        return open(handle.name, "rb").read()


@pytest.mark.parametrize("scale", [1e-3, 1e-5])  # metres: a 1 mm grid (1,138 of the example's samples coincide), 0.01 mm
def test_a_scaled_integer_e57_keeps_every_sample_like_las(monkeypatch, scale):
    extra = POINTS[np.random.default_rng(7).choice(len(POINTS), 50, replace=False)]
    rows = np.vstack([POINTS, extra])[np.random.default_rng(8).permutation(len(POINTS) + 50)]
    scaled = parse_upload(StoredInput.from_bytes("scan.e57", _e57(rows, monkeypatch, scale)), {})
    # on its grid, distinct returns share positions, as in LAS: none is dropped
    assert [w.code for w in scaled.source.warnings] == []
    got = np.asarray(scaled.points)
    assert len(got) == len(rows)
    step = scale * 1000.0
    np.testing.assert_allclose(got / step, np.round(got / step), atol=1e-6)  # on the grid, a step from each sample
    assert np.abs(got - rows).max() <= step * (1 + 1e-9)
    # the same rows written as floats: 50 scattered repeats that a 0.0001 mm print does not explain are copies
    floats = parse_upload(StoredInput.from_bytes("scan.e57", _e57(rows, monkeypatch, None)), {})
    assert floats.source.warnings[0].details == {"repeated": 50, "samples": 4050, "kept": 4000}


def test_a_dense_scan_printed_to_one_mm_keeps_every_sample():
    from plantsolve.solvers.tube.synthetic import clear_tube, surface_samples

    rng = np.random.default_rng(1)
    tube = clear_tube(rng, pipe_radius=10.0, n_bends=2)
    scan = np.round(surface_samples(tube, 40_000, rng, view=rng.normal(size=3), noise=0.1), 0)
    distinct = len(np.unique(scan, axis=0))
    assert len(scan) > 3 * distinct  # several samples in each 1 mm cell: more coincide than lie one step apart
    buf = io.BytesIO()
    np.save(buf, scan)
    request = parse_upload(StoredInput.from_bytes("scan.npy", buf.getvalue()), {})
    assert [w.code for w in request.source.warnings] == []
    assert request.source.points == len(scan)
