"""PLY files as other tools write them: the face element declared before the vertex element (the format lets the
elements come in any order; a scan exported with an empty face list first was refused as holding no vertex, a mesh
so written likewise), and the coordinates named ``X Y Z`` (refused as having no x, y, z)."""

import struct
from pathlib import Path

import numpy as np
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.upload import parse_upload

XYZ = Path(__file__).parents[3] / "examples" / "tube" / "scan.xyz"
POINTS = np.loadtxt(XYZ)


def _ply(vertices, faces, fmt: str, faces_first: bool, names: str = "xyz") -> bytes:
    vertex = f"element vertex {len(vertices)}\n" + "".join(f"property float {n}\n" for n in names)
    face = f"element face {len(faces)}\nproperty list uchar int vertex_indices\n"
    header = f"ply\nformat {fmt} 1.0\n" + (face + vertex if faces_first else vertex + face) + "end_header\n"
    if fmt == "ascii":
        v = "".join(f"{x:.3f} {y:.3f} {z:.3f}\n" for x, y, z in vertices)
        f = "".join(f"3 {a} {b} {c}\n" for a, b, c in faces)
        return (header + (f + v if faces_first else v + f)).encode()
    v = b"".join(struct.pack("<3f", *p) for p in vertices)
    f = b"".join(struct.pack("<B3i", 3, *t) for t in faces)
    return header.encode() + (f + v if faces_first else v + f)


def _points(data: bytes) -> np.ndarray:
    return np.asarray(parse_upload(StoredInput.from_bytes("scan.ply", data), None).points)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
@pytest.mark.parametrize("faces", [0, 1000], ids=["no faces", "a dense mesh's faces"])
def test_the_face_element_before_the_vertex_element_reads_the_same_points(fmt, faces):
    triangles = np.arange(3 * faces).reshape(-1, 3)
    first = _points(_ply(POINTS, triangles, fmt, faces_first=True))
    assert np.array_equal(first, _points(_ply(POINTS, triangles, fmt, faces_first=False)))
    assert np.allclose(first, POINTS, atol=1e-3)


@pytest.mark.parametrize("fmt", ["ascii", "binary_little_endian"])
def test_a_sparse_meshs_faces_before_its_vertices_are_sampled_as_after_them(fmt):
    # a tetrahedron's four corners: a CAD-style tessellation, read as samples on its faces
    corners = np.array([[0.0, 0.0, 0.0], [100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 100.0]])
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    first = _points(_ply(corners, faces, fmt, faces_first=True))
    assert len(first) == 20_000 and np.array_equal(first, _points(_ply(corners, faces, fmt, faces_first=False)))


def test_capitalised_coordinate_names_are_the_coordinates():
    assert np.allclose(_points(_ply(POINTS, np.zeros((0, 3), int), "ascii", False, names="XYZ")), POINTS, atol=1e-3)
