"""Collisions: touching is contact, overlapping is collision, overlapping bounding boxes are not enough."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.rigidity import synthetic
from plantsolve.solvers.rigidity.catalogue import CATALOGUE, collision_boxes
from plantsolve.solvers.rigidity.collisions import Solid, find_collisions
from plantsolve.solvers.rigidity.solve import build, solve


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


# ---------------------------------------------------------------- technic parts: holes and connections


def gearbox():
    from plantsolve.solvers.base import StoredInput
    from plantsolve.solvers.rigidity.upload import parse_upload
    from tests.solvers.rigidity.ldraw_files import GEARBOX

    return parse_upload(StoredInput.from_bytes("gearbox.ldr", GEARBOX.encode()), None)


EIGHT_TOOTH_PIECE = 10 * np.cos(np.pi / 6) - 6  # the widest piece of an 8-tooth gear beside its axle hole


def test_gearbox_collisions_are_only_the_two_parts_placed_twice():
    result = solve(gearbox()).result
    assert [(c.bodies, round(c.depth, 9)) for c in result.collisions] == [
        (["L12", "L25"], round(EIGHT_TOOTH_PIECE, 9)), (["L16", "L24"], 12.0)]
    assert result.unknown_parts == []
    warnings = {w.code: w for w in result.report.warnings}
    assert warnings["duplicate_parts"].details["pairs"] == [["L16", "L24"], ["L12", "L25"]]
    assert "L24 repeats L16" in warnings["duplicate_parts"].message
    joints = {frozenset(j.bodies): (j.type, j.origin) for j in result.joints}
    # the output axle turns and slides in both walls, the outer beam's and the brick's holes; the gears sit on
    # their axles; pins are hinges in the beams, the technic brick and the walls
    for host in ("L6", "L7", "L14", "L18"):
        assert joints[frozenset({"L11", host})] == ("cylindrical", "axle")
    assert joints[frozenset({"L9", "L10"})] == joints[frozenset({"L11", "L12"})] == ("rigid", "axle")
    for pin, hosts in {"L15": ("L6", "L14"), "L19": ("L7", "L18"), "L20": ("L7", "L18")}.items():
        for host in hosts:
            assert joints[frozenset({pin, host})] == ("hinge", "pin")
    # the 3-long axle through the wall's end hole 5 LDU off the half-stud grid: an axle slides, so it is in the
    # hole all the same (a cylindrical joint), and no collision
    assert joints[frozenset({"L6", "L22"})] == ("cylindrical", "axle")
    # motions: the axle in the end hole turning and sliding 2, five pins spinning 5, each axle with its gears turning and sliding 2 + 2, the
    # walls sliding apart along the axles 1 (the pinned beam and brick are rigid to their walls)
    assert result.dof == 12 and {"L6", "L14"} in [set(c) for c in result.clusters]


def test_holes_alone_keep_rods_from_colliding_where_one_box_per_part_did_not():
    assembly, unknown = build(gearbox())
    ids, solids = assembly.solids()
    pairs = {tuple(sorted((ids[i], ids[j]))) for i, j, _ in find_collisions(solids, 0.01)}
    assert unknown == [] and pairs == {("L12", "L25"), ("L16", "L24")}  # without leaving out connected pairs
    boxes = [Solid(center=p.rotation @ np.asarray(p.shape.box_center) + p.position,
                   size=np.asarray(p.shape.box_size, float), rotation=p.rotation) for p in assembly.parts.values()]
    index = {b: k for k, b in enumerate(ids)}
    # the off-grid axle's pair is not left out here: one box per part makes it a 15 LDU deep collision
    connected = {tuple(sorted((index[a], index[b]))) for a, b in assembly.inserted_pairs() if {a, b} != {"L6", "L22"}}
    one_box = {(ids[i], ids[j]): d for i, j, d in find_collisions(boxes, 0.01, connected)}
    assert set(one_box) == {("L6", "L22"), ("L12", "L25"), ("L16", "L24")} and one_box[("L6", "L22")] == pytest.approx(15)


def test_a_pin_through_a_beam_between_its_holes_collides():
    rod_y = [0, -1, 0, 1, 0, 0, 0, 0, 1]
    parts = [{"id": "beam", "part": "32524", "position": [0, 0, 0]},
             {"id": "in", "part": "2780", "position": [0, 10, 40], "rotation": rod_y},
             {"id": "between", "part": "2780", "position": [0, 10, 10], "rotation": rod_y}]
    result = run({"parts": parts})
    # the material between two holes is 8 LDU long and lies wholly inside the 12 LDU wide pin
    assert [(c.bodies, c.depth) for c in result.collisions] == [(["beam", "between"], pytest.approx(10.0))]
    assert [j.bodies for j in result.joints] == [["beam", "in"]]


@pytest.mark.parametrize("number, holes", [("32524", 7), ("3701", 3), ("32064", 1), ("3648", 1)])
def test_collision_boxes_are_the_part_less_its_holes(number, holes):
    shape = CATALOGUE[number]
    boxes = collision_boxes(shape)
    solids = list(shape.solids) or [(shape.box_center, shape.box_size)]
    assert len([c for c in shape.connectors if c.type in ("pinhole", "axlehole")]) == holes
    if number != "3648":  # one solid box: its volume less each hole's 12 x 12 prism through it
        depth = {"32524": 20, "3701": 20, "32064": 20}[number]
        assert sum(np.prod(s) for _, s in boxes) == pytest.approx(np.prod(shape.box_size) - holes * 144 * depth)
    lo_all, hi_all = np.full(3, np.inf), np.full(3, -np.inf)
    for c, s in boxes:
        lo, hi = np.subtract(c, np.divide(s, 2)), np.add(c, np.divide(s, 2))
        lo_all, hi_all = np.minimum(lo_all, lo), np.maximum(hi_all, hi)
        assert all(v > 0 for v in s)
        # no box enters a hole: each hole's square about its axis is free
        for hole in (h for h in shape.connectors if h.type in ("pinhole", "axlehole")):
            axis = np.flatnonzero(hole.direction)[0]
            across = [k for k in range(3) if k != axis]
            inside = all(lo[k] < hole.point[k] + 6 - 1e-9 and hi[k] > hole.point[k] - 6 + 1e-9 for k in across)
            assert not inside
        # every box lies within one of the part's solids
        assert any(np.all(lo >= np.subtract(sc, np.divide(ss, 2)) - 1e-9) and np.all(hi <= np.add(sc, np.divide(ss, 2)) + 1e-9)
                   for sc, ss in solids)
    if number == "3648":  # a 24-tooth gear: every corner inside its pitch circle (radius 30)
        for c, s in boxes:
            for sign in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
                assert np.hypot(c[0] + sign[0] * s[0] / 2, c[1] + sign[1] * s[1] / 2) <= 30 + 1e-9


def test_synthetic_gearbox_is_the_ldraw_fixture_and_its_copies_only_collide_where_placed_twice():
    from_file = [(p.part, p.position, p.rotation) for p in gearbox().parts]
    assert [(p["part"], p["position"], p["rotation"]) for p in synthetic.gearbox(1)] == from_file
    result = run({"parts": synthetic.gearbox(3)})
    assert [c.bodies for c in result.collisions] == [[f"g{k}p{a}", f"g{k}p{b}"] for k in range(3)
                                                     for a, b in ((5, 14), (8, 13))]
    assert run({"parts": synthetic.gearbox(2, twice=False)}).collisions == []


def test_bushes_on_an_axle_against_a_beam_touch_and_hold_the_axle():
    rod_y, bush_y = synthetic.ROD_ALONG_Y, synthetic.GEAR_ALONG_Y
    parts = [{"id": "beam", "part": "32524", "position": [0, 0, 0]},
             {"id": "axle", "part": "3705", "position": [0, 0, 0], "rotation": rod_y},
             {"id": "above", "part": "3713", "position": [0, -20, 0], "rotation": bush_y},
             {"id": "below", "part": "3713", "position": [0, 20, 0], "rotation": bush_y},
             {"id": "gear", "part": "3648b", "position": [0, 30, 40], "rotation": bush_y}]
    result = run({"parts": parts})
    # the 24-tooth gear's pitch disc reaches z = 40 - 30 cos 30° ≈ 14 along z: clear of the bush (9)
    assert result.collisions == [] and result.unknown_parts == []
    joints = {frozenset(j.bodies): (j.type, j.origin) for j in result.joints}
    assert joints == {frozenset({"beam", "axle"}): ("cylindrical", "axle"),
                      frozenset({"axle", "above"}): ("rigid", "axle"), frozenset({"axle", "below"}): ("rigid", "axle")}
    # moved onto the bush's plane 30 from the axle: its pitch disc (26 LDU across the axle's side) enters the
    # bush (flange radius 9) and the axle (radius 6)
    parts[-1]["position"] = [0, 20, 30]
    hits = {tuple(c.bodies): c.depth for c in run({"parts": parts}).collisions}
    assert set(hits) == {("axle", "gear"), ("below", "gear")}
    assert hits[("below", "gear")] == pytest.approx(9 - (30 - 30 * np.cos(np.pi / 6)))
