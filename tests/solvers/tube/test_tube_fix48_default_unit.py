"""A scan file that states no unit, uploaded with no unit given, is read in the default unit (mm): the report's
``source.units`` says the default was taken, and a scan whose size is implausible for a tube in mm but plausible in
another unit (a scan in metres) is warned about at once (``file_units_assumed``), naming the likely unit."""

from __future__ import annotations

import io

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.solve import solve
from plantsolve.solvers.tube.synthetic import make_model, surface_samples
from plantsolve.solvers.tube.upload import parse_upload

ROWS = [(40, 0, 60, 12.0), (25, 45, 90, 16.0), (30, 0, 0, 0)]  # mm; pipe radius 4 mm
M = 1000.0  # mm per metre


def cloud_mm(n=3000, seed=0) -> np.ndarray:
    return surface_samples(make_model(ROWS, 4.0), n, np.random.default_rng(seed))


def _file(ext: str, pts: np.ndarray) -> bytes:
    if ext == ".npy":
        buf = io.BytesIO()
        np.save(buf, pts)
        return buf.getvalue()
    rows = "\n".join(" ".join(f"{v:.9f}" for v in p) for p in pts)
    if ext == ".ply":
        return (f"ply\nformat ascii 1.0\nelement vertex {len(pts)}\nproperty float x\nproperty float y\n"
                f"property float z\nend_header\n{rows}\n").encode()
    if ext == ".obj":
        return "\n".join("v " + " ".join(f"{v:.9f}" for v in p) for p in pts).encode() + b"\n"
    return rows.encode()


def _assumed(request) -> list:
    return [w for w in request.source.warnings if w.code == "file_units_assumed"]


@pytest.mark.parametrize("ext", [".xyz", ".csv", ".txt", ".npy", ".ply", ".obj"])
def test_a_scan_in_metres_read_in_the_default_mm_is_warned_naming_metres(ext):
    pts = cloud_mm() * 12.5 / M  # a 50 mm pipe radius written in metres: the scan spans about 1.2 (m)
    request = parse_upload(StoredInput.from_bytes(f"scan{ext}", _file(ext, pts)), None)
    (warning,) = _assumed(request)
    assert warning.details["likely_units"][0] == "m" and warning.details["basis"] == "default"
    assert warning.details["extent"] == pytest.approx(float(np.linalg.norm(np.ptp(pts, axis=0))), rel=1e-6)
    assert "likely in m" in warning.message and "options.file_units" in warning.message
    units = request.source.units
    assert (units.basis, units.file_unit, units.factor) == ("request", "mm", 1.0)
    assert "default units (none given), mm" in units.evidence


def test_the_warning_reaches_the_report_and_following_it_reads_the_scan_in_metres():
    pts = cloud_mm(1500) * 12.5 / M
    data = _file(".xyz", pts)
    result = solve(parse_upload(StoredInput.from_bytes("scan.xyz", data), None)).result
    assert "file_units_assumed" in {w.code for w in result.report.warnings}
    assert result.report.details["source"]["units"]["basis"] == "request"
    assert result.pipe_radius == pytest.approx(0.05, rel=0.01)  # 50 mm read as 0.05 mm
    # following the warning: the same file read in metres, converted to mm (x 1000), without the warning
    fixed = parse_upload(StoredInput.from_bytes("scan.xyz", data), {"file_units": "m"})
    assert not _assumed(fixed) and fixed.source.units.basis == "options.file_units"
    assert fixed.source.units.factor == 1000.0


def test_no_warning_for_a_plausible_scan_or_a_unit_the_user_gave():
    mm = _file(".xyz", cloud_mm())
    plain = parse_upload(StoredInput.from_bytes("scan.xyz", mm), None)
    assert not _assumed(plain) and "default units (none given), mm" in plain.source.units.evidence
    metres = _file(".xyz", cloud_mm() * 12.5 / M)
    given = parse_upload(StoredInput.from_bytes("scan.xyz", metres), {"units": "mm"})  # the user said mm
    assert not _assumed(given) and given.source.units.evidence.endswith("the request's units, mm")
    header = b"x [m], y [m], z [m]\n" + metres.replace(b" ", b", ")
    stated = parse_upload(StoredInput.from_bytes("scan.csv", header), None)  # the file says metres
    assert not _assumed(stated) and stated.source.units.basis == "header"
