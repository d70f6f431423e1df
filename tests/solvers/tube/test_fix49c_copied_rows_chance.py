"""Rows equal in every column are copies only when rows at one place agree far more often than rows at neighbouring
places do. A dense scan printed to 1 mm holds several samples at every printed position; with a narrow spread of
intensities (a uniform metal surface) and a constant colour, thousands of them coincide in every column by chance,
and 3,773 of 50,000 were dropped as "a file or scan pasted twice". Half the file pasted again in another order is
still read once, in a dense print as in a fine one, with the intensity drifting along the surface or not."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.read_log import ReadLog
from plantsolve.solvers.tube.synthetic import clear_tube, surface_samples
from plantsolve.solvers.tube.text_points import (
    SAME_PLACE_FACTOR,
    Columns,
    agreement_over_chance,
    read_text_points,
)
from plantsolve.solvers.tube.upload import parse_upload


def _scan(spread: float, drift: bool = False, decimals: int = 0, pasted: float = 0.0) -> list[str]:
    """50,000 samples of a 6 mm tube, x y z intensity r g b; ``drift``: the intensity's mean moves ±160 along the
    surface (angle of incidence); ``pasted``: that share of the rows written again, shuffled, at the end."""
    rng = np.random.default_rng(1)
    pts = surface_samples(clear_tube(rng, pipe_radius=6.0), 50_000, rng, noise=0.05)
    mean = 1500 + (80 * np.sin(pts[:, 0] / 7.0) + 80 * np.cos(pts[:, 1] / 5.0) if drift else 0)
    intensity = np.round(mean + rng.normal(0, spread, len(pts))).astype(int)
    lines = [f"{x:.{decimals}f} {y:.{decimals}f} {z:.{decimals}f} {i} 200 200 200"
             for (x, y, z), i in zip(pts, intensity)]
    return lines + [lines[k] for k in rng.permutation(len(lines))[: int(pasted * len(lines))]]


def _read(lines: list[str]) -> tuple[np.ndarray, ReadLog]:
    log = ReadLog("xyz")
    pts, _ = read_text_points(("\n".join(lines) + "\n").encode(), log)
    return pts, log


def _agreement(lines: list[str]) -> float:
    return agreement_over_chance([[float(v) for v in line.split()[:3]] for line in lines], lines, Columns())


@pytest.mark.parametrize("spread, drift", [(8.0, False), (30.0, False), (8.0, True)])
def test_a_dense_scan_printed_to_1_mm_keeps_the_rows_that_coincide_by_chance(spread, drift):
    lines = _scan(spread, drift)
    pts, log = _read(lines)
    # before: 3,773 (sd 8), 1,040 (sd 30) and 3,485 (drifting) rows dropped with duplicate_points
    assert len(set(lines)) < len(lines) and len(pts) == len(lines) and [w.code for w in log.notes] == []
    np.testing.assert_array_equal(pts, [[float(v) for v in line.split()[:3]] for line in lines])


def test_rows_at_one_place_agree_as_often_as_neighbours_unless_pasted():
    assert _agreement(_scan(8.0)) == pytest.approx(1.0, abs=0.05)  # independent of the place: the same rate
    assert 1.0 < _agreement(_scan(8.0, drift=True)) < 0.7 * SAME_PLACE_FACTOR  # close rows agree a little more
    assert _agreement(_scan(8.0, pasted=0.5)) > 1.5 * SAME_PLACE_FACTOR


@pytest.mark.parametrize("spread, drift, decimals", [(8.0, False, 0), (30.0, False, 0), (8.0, True, 0), (8.0, True, 3)])
def test_half_a_scan_pasted_again_shuffled_is_still_read_once(spread, drift, decimals):
    once = _scan(spread, drift, decimals)
    lines = _scan(spread, drift, decimals, pasted=0.5)
    pts, log = _read(lines)
    (warning,) = log.notes
    assert warning.code == "duplicate_points" and len(pts) == len(set(once))
    request = parse_upload(StoredInput.from_bytes("scan.txt", "\n".join(lines).encode()), {})
    assert [w.code for w in request.source.warnings] == ["duplicate_points"]
