"""Rows equal in every column are copies only when they are far more than chance gives. A dense scan printed to 1 mm
holds several samples in every printed position; with a narrow spread of intensities (a uniform metal surface) and a
constant colour, thousands of them coincide in every column by chance, and 3,773 of 50,000 were dropped as "a file
or scan pasted twice". Half the file pasted again in another order is still read once."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.read_log import ReadLog
from plantsolve.solvers.tube.synthetic import clear_tube, surface_samples
from plantsolve.solvers.tube.text_points import (
    Columns,
    chance_repeats,
    read_text_points,
)
from plantsolve.solvers.tube.upload import parse_upload


def _dense_print(spread: float) -> list[str]:
    rng = np.random.default_rng(1)
    pts = surface_samples(clear_tube(rng, pipe_radius=6.0), 50_000, rng, noise=0.05)
    intensity = np.round(rng.normal(1500, spread, len(pts))).astype(int)
    return [f"{x:.0f} {y:.0f} {z:.0f} {i} 200 200 200" for (x, y, z), i in zip(pts, intensity)]


def _read(lines: list[str]) -> tuple[np.ndarray, ReadLog]:
    log = ReadLog("xyz")
    pts, _ = read_text_points(("\n".join(lines) + "\n").encode(), log)
    return pts, log


@pytest.mark.parametrize("spread", [8.0, 30.0])
def test_a_dense_scan_printed_to_1_mm_keeps_the_rows_that_coincide_by_chance(spread):
    lines = _dense_print(spread)
    pts, log = _read(lines)
    # before: 3,773 (sd 8) and 1,040 (sd 30) rows dropped with duplicate_points
    assert len(pts) == len(lines) and [w.code for w in log.notes] == []
    np.testing.assert_array_equal(pts, [[float(v) for v in line.split()[:3]] for line in lines])


def test_the_chance_of_a_whole_row_repeating_is_what_independent_columns_give():
    lines = _dense_print(8.0)
    repeats = len(lines) - len(set(lines))
    kept = [[float(v) for v in line.split()[:3]] for line in lines]
    assert repeats == 3773 and abs(chance_repeats(kept, lines, Columns()) - repeats) < 0.02 * repeats
    # one constant column beside x, y, z: every row at an earlier row's position repeats it
    constant = [" ".join(line.split()[:3]) + " 7" for line in lines]
    positions = len(lines) - len({tuple(k) for k in kept})
    assert chance_repeats(kept, constant, Columns()) == pytest.approx(positions)


def test_half_a_dense_scan_pasted_again_shuffled_is_still_read_once():
    lines = _dense_print(30.0)
    again = [lines[k] for k in np.random.default_rng(2).permutation(len(lines))[: len(lines) // 2]]
    pts, log = _read(lines + again)
    (warning,) = log.notes
    assert warning.code == "duplicate_points" and len(pts) == len(set(lines)) == 50_000 - 1040
    request = parse_upload(StoredInput.from_bytes("scan.txt", "\n".join(lines + again).encode()), {})
    assert [w.code for w in request.source.warnings] == ["duplicate_points"]
