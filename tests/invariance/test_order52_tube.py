"""Tube: a scan file's rows in another order give the same bits (the outliers named by their rows in the file as
given), and the scan moved as a whole gives the same LRA and verdict.

Tolerance of the rigid motion: the least-squares fit ends at another point of round-off on a moved scan (measured
on the example: 4e-5 mm in lengths and radii, 1e-4 degrees in angles and rotations); 1e-3 mm and 1e-2 degrees are
asserted, two orders below the inspection tolerances (1 mm, 0.5 degrees) and the LRA sigmas.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.upload import parse_upload

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "tube"


def _solved(path: Path, rows: list[str]):
    path.write_text("".join(rows))
    nominal = (EXAMPLES / "nominal_lra.csv").read_text()
    return solve(parse_upload(StoredInput.from_path(path), {"nominal_csv": nominal})).result


@pytest.fixture(scope="module")
def as_written(tmp_path_factory):
    rows = (EXAMPLES / "scan.xyz").read_text().splitlines(keepends=True)
    return rows, _solved(tmp_path_factory.mktemp("tube") / "scan.xyz", rows)


def test_scan_rows_in_another_order_give_the_same_bits(as_written, tmp_path):
    rows, result = as_written
    perm = np.random.default_rng(8).permutation(len(rows))
    again = _solved(tmp_path / "scan.xyz", [rows[i] for i in perm]).model_dump(mode="json")
    # outliers are named by their row in the file as given: the same samples, other numbers
    outliers = again.pop("outliers")
    named = sorted(zip((int(perm[i]) for i in outliers["indices"]), outliers["reasons"]))
    expected = result.model_dump(mode="json")
    expected_outliers = expected.pop("outliers")
    assert named == sorted(zip(expected_outliers["indices"], expected_outliers["reasons"]))
    assert outliers["count"] == expected_outliers["count"] > 0
    for r in (again, expected):
        r["report"]["details"].pop("timings_s")
    assert again == expected
    assert result.inspection.verdict == "fail"  # the example's known verdict, whatever the order


def test_the_scan_moved_as_a_whole_gives_the_same_lra_and_verdict(as_written, tmp_path):
    rows, result = as_written
    pts = np.loadtxt(rows)
    turn, shift = Rotation.from_rotvec([0.4, -0.3, 0.7]), np.array([1250.0, -400.0, 90.0])
    moved_rows = [f"{x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in turn.apply(pts) + shift]
    moved = _solved(tmp_path / "scan.xyz", moved_rows)
    assert moved.pipe_radius == pytest.approx(result.pipe_radius, abs=1e-3)
    assert len(moved.lra) == len(result.lra) == 4
    for a, b in zip(moved.lra, result.lra):
        assert (a.length, a.bend_radius) == pytest.approx((b.length, b.bend_radius), abs=1e-3)
        assert (a.rotation, a.angle) == pytest.approx((b.rotation, b.angle), abs=1e-2)
    assert moved.inspection.verdict == result.inspection.verdict
    assert moved.inspection.failed_rows == result.inspection.failed_rows
    assert [w.code for w in moved.report.warnings] == [w.code for w in result.report.warnings]
    assert moved.outliers.count == result.outliers.count
    # the start moves with the scan: world positions are the frame's
    assert np.allclose(moved.start, turn.apply(result.start) + shift, atol=1e-2)
