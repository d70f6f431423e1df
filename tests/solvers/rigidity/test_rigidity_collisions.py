"""Collisions: touching is contact, overlapping is collision, overlapping bounding boxes are not enough."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.rigidity import synthetic
from plantsolve.solvers.rigidity.collisions import Solid, find_collisions
from plantsolve.solvers.rigidity.solve import solve


def box(bid, center, size, rotation=(1, 0, 0, 0)):
    return {"id": bid, "shape": {"box": {"center": list(center), "size": list(size), "rotation": list(rotation)}}}


def run(body):
    return solve(RigidityRequest.model_validate(body)).result


def test_stacked_bricks_touch_but_do_not_collide():
    assert run(synthetic.stacked(8)).collisions == []
    assert run(synthetic.stacked(1)).collisions == []


def test_bricks_side_by_side_touch_but_do_not_collide():
    parts = [{"id": "a", "part": "3001", "position": [0, 0, 0]}, {"id": "b", "part": "3001", "position": [80, 0, 0]},
             {"id": "c", "part": "3001", "position": [0, 0, 40]}]
    assert run({"parts": parts}).collisions == []


def test_overlapping_bricks_collide_with_their_depth():
    parts = [{"id": "a", "part": "3001", "position": [0, 0, 0]}, {"id": "b", "part": "3001", "position": [70, 0, 0]}]
    (hit,) = run({"parts": parts}).collisions
    assert hit.bodies == ["a", "b"] and hit.depth == pytest.approx(10.0)


def test_overlapping_boxes_collide_and_touching_boxes_do_not():
    body = {"bodies": [box("A", (0, 0, 0), (2, 2, 2)), box("B", (1.5, 0, 0), (2, 2, 2)), box("C", (0, 2, 0), (2, 2, 2))]}
    hits = {tuple(c.bodies): c.depth for c in run(body).collisions}
    assert set(hits) == {("A", "B")}  # C only touches A and B along faces
    assert hits[("A", "B")] == pytest.approx(0.5)


def test_long_boxes_at_45_degrees_with_overlapping_bounding_boxes_do_not_collide():
    a = Solid(center=np.zeros(3), size=np.array([100.0, 2, 2]), rotation=np.eye(3))
    rot = Rotation.from_euler("z", 45, degrees=True)
    b = Solid(center=np.array([-60.0, 30, 0]), size=np.array([100.0, 2, 2]), rotation=rot.as_matrix())
    (lo_a, hi_a), (lo_b, hi_b) = a.aabb(), b.aabb()
    assert ((lo_a < hi_b) & (lo_b < hi_a)).all()  # the broad phase alone would report them
    assert find_collisions([a, b], 0.01) == []
    moved = Solid(center=np.array([0.0, 30, 0]), size=b.size, rotation=b.rotation)  # now it crosses a
    assert len(find_collisions([a, moved], 0.01)) == 1
    q = rot.as_quat()
    body = {"bodies": [box("A", (0, 0, 0), (100, 2, 2)), box("B", (-60, 30, 0), (100, 2, 2), (q[3], q[0], q[1], q[2]))]}
    assert run(body).collisions == []


def test_meshes_collide_by_penetration_depth():
    cube = trimesh.creation.box([2, 2, 2])

    def mesh(bid, shift):
        return {"id": bid, "shape": {"mesh": {"vertices": (cube.vertices + shift).tolist(), "faces": cube.faces.tolist()}}}

    body = {"bodies": [mesh("A", [0, 0, 0]), mesh("B", [1.5, 0, 0]), mesh("C", [0, 2, 0]), mesh("D", [10, 0, 0])]}
    hits = {tuple(c.bodies): c.depth for c in run(body).collisions}
    # FCL's depth for triangle meshes is per triangle contact, not the true depth: only its sign is tested
    assert set(hits) == {("A", "B")} and hits[("A", "B")] > 0.01


def test_contact_tolerance_decides_what_is_contact():
    body = {"bodies": [box("A", (0, 0, 0), (2, 2, 2)), box("B", (1.95, 0, 0), (2, 2, 2))]}
    assert len(run(body).collisions) == 1
    body["options"] = {"contact_tolerance": 0.1}
    assert run(body).collisions == []
