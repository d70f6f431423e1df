"""Scan files as users get them wrong, a third round: a file pasted twice, a mesh written triangle by triangle, an
NPY array saved transposed. Each is read to the right samples, with a warning naming what was done."""

from __future__ import annotations

import io

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.upload import parse_upload
from tests.conftest import REPO

SCAN_XYZ = (REPO / "examples" / "tube" / "scan.xyz").read_bytes()
POINTS = np.loadtxt(io.BytesIO(SCAN_XYZ))


def _request(name: str, content: bytes):
    return parse_upload(StoredInput.from_bytes(name, content), {})


def _codes(request) -> list[str]:
    return [w.code for w in request.source.warnings]


def test_a_scan_pasted_twice_keeps_the_sigmas_of_its_samples():
    once, twice = _request("scan.xyz", SCAN_XYZ), _request("scan.xyz", SCAN_XYZ + SCAN_XYZ)
    assert _codes(once) == []
    (warning,) = twice.source.warnings
    assert warning.code == "duplicate_points" and warning.details == {"repeated": 4000, "samples": 8000, "kept": 4000}
    # before: every sample counted twice, every sigma √2 too small (0.013 -> 0.009 degrees on the first bend); the
    # same samples as the scan given once, in its order, make the same fit and the same sigmas
    np.testing.assert_array_equal(np.asarray(twice.points), POINTS)
    np.testing.assert_array_equal(np.asarray(twice.points), np.asarray(once.points))
    assert twice.model_dump(exclude={"source"}) == once.model_dump(exclude={"source"})


def test_shuffled_and_repeated_rows_give_the_same_samples():
    order = np.random.default_rng(5).permutation(len(POINTS))
    text = "\n".join(" ".join(f"{v:.3f}" for v in POINTS[k]) for k in np.concatenate([order, order[:100]]))
    request = _request("scan.xyz", text.encode())
    assert request.source.warnings[0].details["repeated"] == 100
    np.testing.assert_array_equal(np.asarray(request.points), POINTS[order])


def _triangle_by_triangle_ply(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    corners = vertices[faces].reshape(-1, 3)
    head = (f"ply\nformat ascii 1.0\nelement vertex {len(corners)}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
    body = "".join(f"{x:.4f} {y:.4f} {z:.4f}\n" for x, y, z in corners)
    body += "".join(f"3 {3 * k} {3 * k + 1} {3 * k + 2}\n" for k in range(len(faces)))
    return (head + body).encode()


def test_a_mesh_written_triangle_by_triangle_gives_each_vertex_once_without_a_warning():
    import trimesh

    mesh = trimesh.creation.cylinder(radius=6.0, height=120.0, sections=64, segment=None)
    mesh = mesh.subdivide().subdivide()  # more vertices than a sparse tessellation: its vertices are the samples
    request = _request("tube.ply", _triangle_by_triangle_ply(np.asarray(mesh.vertices), np.asarray(mesh.faces)))
    assert _codes(request) == []
    got = np.asarray(request.points)
    assert len(got) == len(np.unique(np.round(mesh.vertices, 4), axis=0))


@pytest.mark.parametrize("dtype", ["<f8", "<f4"])
def test_an_npy_saved_transposed_is_read_as_its_points_and_says_so(dtype):
    buf = io.BytesIO()
    np.save(buf, POINTS.T.astype(dtype))
    request = _request("scan.npy", buf.getvalue())  # before: 3 points of 4,000 values, refused as too few points
    (warning,) = request.source.warnings
    assert warning.code == "npy_transposed" and warning.details == {"shape": [3, 4000]}
    np.testing.assert_allclose(np.asarray(request.points), POINTS, rtol=1e-6)


def _pts_rows(points: np.ndarray) -> str:
    # Leica PTS: x y z intensity r g b
    return "".join(f"{x:.3f} {y:.3f} {z:.3f} -1204 87 91 93\n" for x, y, z in points)


def test_a_pts_file_renamed_txt_reads_its_counts_as_counts():
    # before: each count was a record "with fewer than 3 coordinates", and the job a warning for a whole file
    one = _request("scan.txt", (f"{len(POINTS)}\n" + _pts_rows(POINTS)).encode())
    two = _request("scan.txt", (f"1500\n{_pts_rows(POINTS[:1500])}2500\n{_pts_rows(POINTS[1500:])}").encode())
    for request in (one, two):
        assert _codes(request) == []
        np.testing.assert_allclose(np.asarray(request.points), POINTS, atol=5e-4)


def test_a_pts_file_holding_fewer_rows_than_its_count_says_it_was_cut():
    request = _request("scan.xyz", (f"{len(POINTS)}\n" + _pts_rows(POINTS[:2500])).encode())
    (warning,) = request.source.warnings  # before: no word of the 1,500 rows missing
    assert warning.code == "file_truncated" and warning.details == {"declared": 4000, "read": 2500, "line": 1}
    assert len(request.points) == 2500 and request.source.truncated


def test_a_pts_count_the_rows_exceed_is_said():
    request = _request("scan.txt", ("1000\n" + _pts_rows(POINTS)).encode())
    (warning,) = request.source.warnings
    assert warning.code == "point_count_disagrees" and warning.details == {"line": 1, "declared": 1000, "read": 4000}
    assert len(request.points) == 4000
