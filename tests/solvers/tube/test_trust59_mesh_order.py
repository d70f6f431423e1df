"""A coarse mesh (a CAD-style tessellation of fewer than 2,000 vertices) is read as seeded samples on its faces. The
samples followed the order of the faces and of each face's corners, so the same tube exported with its faces in
another order, its corners rolled, its winding reversed or its vertices numbered otherwise was read to other samples
and fitted to another LRA (by up to 0.03 mm in a CLR of 30 mm). They are the same samples now."""

import numpy as np
import pytest
import trimesh

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.tube.model import sample_centreline
from plantsolve.solvers.tube.synthetic import make_model
from plantsolve.solvers.tube.upload import parse_upload


def _tube_mesh(r: float = 6.0, around: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """A two-bend tube of radius ``r`` as rings of ``around`` vertices along its centreline, two triangles a quad."""
    centre, tangent = sample_centreline(make_model([[80.0, 0.0, 90.0, 30.0], [60.0, 90.0, 45.0, 30.0],
                                                    [70.0, 0.0, 0.0, 0.0]], r), 6.0)
    normal = [np.cross(tangent[0], [0.0, 0.0, 1.0])]
    for t in tangent[1:]:  # parallel transport: no twist between rings
        n = normal[-1] - (normal[-1] @ t) * t
        normal.append(n / np.linalg.norm(n))
    normal = np.array(normal) / np.linalg.norm(normal[0])
    binormal = np.cross(tangent, normal)
    a = np.linspace(0.0, 2.0 * np.pi, around, endpoint=False)
    vertices = (centre[:, None] + r * (np.cos(a)[None, :, None] * normal[:, None]
                                       + np.sin(a)[None, :, None] * binormal[:, None])).reshape(-1, 3)
    faces = []
    for i in range(len(centre) - 1):
        for j in range(around):
            p, q = i * around + j, i * around + (j + 1) % around
            faces += [[p, q, p + around], [q, q + around, p + around]]
    return vertices, np.array(faces)


VERTICES, FACES = _tube_mesh()


def _points(vertices: np.ndarray, faces: np.ndarray, file_type: str) -> np.ndarray:
    data = trimesh.Trimesh(vertices, faces, process=False).export(file_type=file_type)
    data = data.encode() if isinstance(data, str) else data
    return np.asarray(parse_upload(StoredInput.from_bytes(f"tube.{file_type}", data), None).points)


def _renumbered(rng) -> tuple[np.ndarray, np.ndarray]:
    new_of_old = rng.permutation(len(VERTICES))
    vertices = np.empty_like(VERTICES)
    vertices[new_of_old] = VERTICES
    return vertices, new_of_old[FACES]


@pytest.mark.parametrize("file_type", ["stl", "obj", "ply"])
def test_a_coarse_mesh_written_in_another_order_is_read_to_the_same_samples(file_type):
    assert len(VERTICES) < 2000  # sampled on its faces
    rng = np.random.default_rng(59)
    clean = _points(VERTICES, FACES, file_type)
    assert len(clean) == 20_000
    for vertices, faces in ((VERTICES, FACES[rng.permutation(len(FACES))]),  # faces shuffled
                            (VERTICES, np.roll(FACES, 1, axis=1)),  # each face's corners rolled
                            (VERTICES, FACES[:, ::-1]),  # winding reversed
                            _renumbered(rng)):  # vertices numbered otherwise
        assert np.array_equal(_points(vertices, faces, file_type), clean)


def test_the_samples_lie_on_the_tube():
    points = _points(VERTICES, FACES, "stl")
    # every sample on a face of the mesh: no further from the nearest vertex than a face's longest edge
    edges = np.linalg.norm(VERTICES[FACES] - VERTICES[np.roll(FACES, 1, axis=1)], axis=2).max()
    from scipy.spatial import cKDTree
    distance, _ = cKDTree(VERTICES).query(points)
    assert distance.max() <= edges
