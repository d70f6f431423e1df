"""LEGO parts: connections inferred from the catalogue, superbricks, hinges, pins, axles, the Assembly's
incremental updates, and docking."""

from __future__ import annotations

import numpy as np
import pytest

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.rigidity import synthetic
from plantsolve.solvers.rigidity.assembly import Assembly
from plantsolve.solvers.rigidity.catalogue import CATALOGUE
from plantsolve.solvers.rigidity.docking import dock
from plantsolve.solvers.rigidity.solve import solve

ROT_Y90 = synthetic.ROT_Y90


def run(parts, **options):
    return solve(RigidityRequest.model_validate({"parts": parts, "options": options})).result


def part(pid, number, x, y, z, rotation=None):
    return {"id": pid, "part": number, "position": [x, y, z], "rotation": rotation or synthetic.IDENTITY}


def test_stacked_on_eight_studs_is_one_superbrick():
    result = run(synthetic.stacked(8)["parts"])
    assert result.superbricks == [["low", "high"]] and result.rigid and result.dof == 0
    (joint,) = result.joints
    assert joint.type == "rigid" and joint.connections == 8 and joint.origin == "stud"
    assert result.collisions == [] and result.rank_method == "modular"


def test_on_one_stud_is_a_hinge_about_the_stud_axis():
    result = run(synthetic.stacked(1)["parts"])
    (joint,) = result.joints
    assert joint.type == "hinge" and joint.moves and joint.point == [30.0, 0.0, 10.0]
    assert abs(joint.axis[1]) == 1.0 and joint.axis[0] == joint.axis[2] == 0.0
    assert result.dof == 1 and len(result.superbricks) == 2


def test_two_studs_are_rigid_even_across_a_corner():
    # a 2x2 brick overlapping the corner of a 2x4 brick by two studs
    result = run([part("a", "3001", 0, 0, 0), part("b", "3003", 40, -24, 0)])
    assert result.rigid and result.joints[0].connections == 2


def test_a_turned_brick_connects_through_its_rotated_studs():
    result = run([part("a", "3001", 0, 0, 0), part("b", "3004", 10, -24, 0, ROT_Y90)])
    assert result.rigid and result.joints[0].connections == 2


def test_hinge_bricks_turn_about_their_hinge_line():
    # as in LDraw files: base and top at one position and rotation, a brick's height together
    parts = [part("base", "3001", 0, 0, 0), part("hb", "3937", -20, -24, 10), part("ht", "3938", -20, -24, 10),
             part("top", "3004", -20, -48, 10)]
    result = run(parts)
    assert result.dof == 1
    assert {frozenset(c) for c in result.clusters} == {frozenset({"base", "hb"}), frozenset({"ht", "top"})}
    hinge = next(j for j in result.joints if j.origin == "hinge")
    assert hinge.type == "hinge" and hinge.axis == [1.0, 0.0, 0.0] and hinge.point == [-20.0, -14.0, 10.0]
    assert {tuple(j.bodies) for j in result.joints if j.origin == "stud"} == {("base", "hb"), ("ht", "top")}
    assert all(j.type == "rigid" and j.connections == 2 for j in result.joints if j.origin == "stud")
    assert result.collisions == []  # the base's and the top's boxes touch at the hinge line's height


def test_two_hinges_on_parallel_axes_make_a_four_bar_that_moves():
    # two hinge-brick pairs side by side along x share one hinge line: the plate on top still turns
    parts = [part("base", "3001", 0, 0, 0), part("h1", "3937", -20, -24, 10), part("t1", "3938", -20, -24, 10),
             part("h2", "3937", 20, -24, 10), part("t2", "3938", 20, -24, 10), part("roof", "3020", 0, -32, 0)]
    result = run(parts)
    assert result.dof == 1 and result.generic_dof == 0 and result.special_position
    assert frozenset({"t1", "t2", "roof"}) in {frozenset(c) for c in result.clusters}


def test_two_pins_hold_two_technic_bricks_rigid_while_each_pin_spins():
    # the pins' own axis is x: turned a quarter turn about y into the bricks' z holes
    parts = [part("a", "3701", 0, 0, 0), part("b", "3701", 0, 0, 20),
             part("p1", "2780", -20, 10, 10, ROT_Y90), part("p2", "2780", 20, 10, 10, ROT_Y90)]
    result = run(parts)
    assert frozenset({"a", "b"}) in {frozenset(c) for c in result.clusters}
    assert ["a", "b"] in result.superbricks  # two pins in parallel holes are a rigid connection
    assert result.dof == 2 and {j.origin for j in result.joints} == {"pin"}
    assert result.collisions == []  # pins inside holes are not collisions
    one_pin = run(parts[:3])
    assert one_pin.dof == 2 and len(one_pin.clusters) == 3 and len(one_pin.superbricks) == 3


def test_axle_in_axle_hole_is_rigid_and_in_a_round_hole_turns_and_slides():
    rigid = run([part("brick", "32064", 0, 0, 0), part("axle", "3705", 0, 10, 10, ROT_Y90)])
    assert rigid.rigid and rigid.joints[0].type == "rigid" and rigid.joints[0].origin == "axle"
    loose = run([part("brick", "3700", 0, 0, 0), part("axle", "3705", 0, 10, 10, ROT_Y90)])
    assert loose.dof == 2 and loose.joints[0].type == "cylindrical"


def test_catalogue_frames_are_the_ldraw_library_frames():
    def conns(number, kind):
        return sorted((c.point, c.direction) for c in CATALOGUE[number].connectors if c.type == kind)

    x, z = (1, 0, 0), (0, 0, 1)
    for pin in ("3673", "2780"):  # along x, centred, 40 LDU: two halves at x = -10 and +10
        assert conns(pin, "pin") == [((-10, 0, 0), x), ((10, 0, 0), x)] and CATALOGUE[pin].box_size[0] == 40
    for axle, n in {"3704": 2, "3705": 4, "3706": 6, "3707": 8}.items():  # along x, centred, 20 N LDU
        (run,) = [c for c in CATALOGUE[axle].connectors if c.type == "axle"]  # one run from end to end
        assert run.direction == x and CATALOGUE[axle].box_size[0] == 20 * n
        assert run.point == (-10 * n, 0, 0) and run.length == 20 * n
    assert conns("3700", "pinhole") == [((0, 10, 0), z)] and conns("32064", "axlehole") == [((0, 10, 0), z)]
    assert [p for p, _ in conns("3701", "pinhole")] == [(-20, 10, 0), (0, 10, 0), (20, 10, 0)]
    # hinge brick: both halves' axis along x through (0, 10, 0) of their own frame
    assert conns("3937", "hinge_a") == conns("3938", "hinge_b") == [((0, 10, 0), x)]
    assert conns("3937", "antistud") == [((-10, 24, 0), (0, 1, 0)), ((10, 24, 0), (0, 1, 0))]
    assert conns("3938", "stud") == [((-10, 0, 0), (0, -1, 0)), ((10, 0, 0), (0, -1, 0))]
    assert conns("3937", "stud") == [] and conns("3938", "antistud") == []
    base, top = CATALOGUE["3937"], CATALOGUE["3938"]  # boxes y in [10, 24] and [0, 10]: they touch
    assert base.box_center[1] - base.box_size[1] / 2 == top.box_center[1] + top.box_size[1] / 2 == 10


def test_a_pin_or_axle_left_along_x_does_not_enter_holes_along_z():
    # the same positions as above without the quarter turn: the rods lie across the holes
    pins = run([part("a", "3701", 0, 0, 0), part("b", "3701", 0, 0, 20), part("p1", "2780", -20, 10, 10)])
    assert pins.joints == [] and len(pins.clusters) == 3
    axle = run([part("brick", "32064", 0, 0, 0), part("axle", "3705", 0, 10, 10)])
    assert axle.joints == [] and axle.dof == 6
    # either quarter turn about y does: an axis has no sign
    other_turn = [0, 0, -1, 0, 1, 0, 1, 0, 0]
    turned = run([part("a", "3701", 0, 0, 0), part("b", "3701", 0, 0, 20), part("p1", "2780", -20, 10, 10, other_turn),
                  part("p2", "2780", 20, 10, 10, ROT_Y90)])
    assert turned.dof == 2 and ["a", "b"] in turned.superbricks


def test_an_axle_centred_in_a_one_wide_brick_is_held():
    centred = run([part("brick", "32064", 0, 0, 0), part("axle", "3706", 0, 10, 0, ROT_Y90)])
    assert centred.rigid and centred.joints[0].point == [0.0, 10.0, 0.0]
    half_out = run([part("brick", "3700", 0, 0, 0), part("axle", "3704", 0, 10, 10, ROT_Y90)])
    assert half_out.joints[0].type == "cylindrical" and half_out.dof == 2


def test_unknown_parts_are_reported_not_guessed():
    result = run([part("a", "3001", 0, 0, 0), part("x", "99999", 0, -24, 0)])
    assert [(u.id, u.part) for u in result.unknown_parts] == [("x", "99999")]
    assert result.clusters == [["a"]] and [w.code for w in result.report.warnings] == ["rigidity_not_determined",
                                                                                       "unknown_parts"]
    assert result.rigid is None  # one known part of two: no answer for the model


def test_every_catalogue_part_has_a_box_and_typed_connectors():
    kinds = {"stud", "antistud", "pin", "pinhole", "axle", "axlehole", "hinge_a", "hinge_b", "fit_m"}  # fit_m: pins as stated
    for number, shape in CATALOGUE.items():
        assert all(s > 0 for s in shape.box_size) and shape.connectors, number
        assert {c.type for c in shape.connectors} <= kinds
    for number in ("3001", "3003", "3004", "3005", "3010", "3009", "3008", "3002", "3007", "3024", "3023", "3623",
                   "3710", "3022", "3021", "3020", "3034", "3700", "3701", "3894", "3673", "2780", "3704", "3705", "3706",
                   "3937", "3938"):
        assert number in CATALOGUE
    assert len([c for c in CATALOGUE["3001"].connectors if c.type == "stud"]) == 8
    assert CATALOGUE["3001"].box_size == (80.0, 24.0, 40.0) and CATALOGUE["3020"].box_size[1] == 8.0


def test_incremental_assembly_matches_a_fresh_build():
    parts = synthetic.random_lego(60, seed=4)
    live = Assembly()
    for p in parts:
        live.add_part(p["id"], p["part"], p["position"], p["rotation"])
    rng = np.random.default_rng(0)
    removed = [parts[k] for k in rng.choice(len(parts), 15, replace=False) if parts[k]["id"] != "p0"]
    for p in removed:
        live.remove_part(p["id"])
    fresh = Assembly()
    for p in parts:
        if p not in removed:
            fresh.add_part(p["id"], p["part"], p["position"], p["rotation"])
    a, b = live.analyse(), fresh.analyse()
    assert a.mobility.dof == b.mobility.dof and a.generic_dof == b.generic_dof
    ca = {frozenset(a.ids[i] for i in c) for c in a.mobility.clusters}
    cb = {frozenset(b.ids[i] for i in c) for c in b.mobility.clusters}
    assert ca == cb
    # adding back is incremental: the pebble game follows every insertion
    for p in removed:
        live.add_part(p["id"], p["part"], p["position"], p["rotation"])
    full = Assembly()
    for p in parts:
        full.add_part(p["id"], p["part"], p["position"], p["rotation"])
    assert live.generic_dof == full.generic_dof and live.analyse().mobility.dof == full.analyse().mobility.dof


def test_docking_a_brick_on_a_brick_prefers_all_eight_studs_and_avoids_collisions():
    assembly = Assembly()
    assembly.add_part("a", "3001", [0, 0, 0])
    poses = dock(assembly, "3001", limit=50)
    best = poses[0]
    assert best["connections"] == 8 and best["connects_to"] == ["a"]
    assert best["position"] in ([0.0, -24.0, 0.0], [0.0, 24.0, 0.0])
    assert [p["connections"] for p in poses] == sorted((p["connections"] for p in poses), reverse=True)
    # no pose overlaps the brick: each is above or below it
    assert all(p["position"][1] in (-24.0, 24.0) for p in poses)
    assembly.add_part("b", "3001", [0, -24, 0])
    top = dock(assembly, "3001", limit=5)
    assert top[0]["connections"] == 8 and top[0]["position"] in ([0.0, -48.0, 0.0], [0.0, 24.0, 0.0])


def test_docking_skips_poses_that_collide():
    assembly = Assembly()
    assembly.add_part("a", "3001", [0, 0, 0])
    assembly.add_part("wall", "3001", [0, -24, 40])  # beside the top of a, over no stud of a
    for pose in dock(assembly, "3003", limit=100):
        assert not (pose["position"][1] == -24.0 and pose["position"][2] > 0)


def test_docking_through_the_job():
    result = run(synthetic.stacked(8)["parts"], dock={"part": "3005", "limit": 3})
    assert len(result.docking) == 3 and all(d.connections == 1 for d in result.docking)


def test_a_lego_model_under_a_general_rigid_motion_keeps_its_mobility():
    from scipy.spatial.transform import Rotation

    parts = synthetic.random_lego(40, seed=7)
    before = run(parts)
    rot = Rotation.from_rotvec([0.4, 0.9, -0.3]).as_matrix()
    shift = np.array([123.4, -56.7, 8.9])
    moved = [{**p, "position": (rot @ np.asarray(p["position"], float) + shift).tolist(),
              "rotation": (rot @ np.asarray(p["rotation"], float).reshape(3, 3)).ravel().tolist()} for p in parts]
    after = run(moved)
    assert before.rank_method == "modular" and after.rank_method == "svd"
    assert (after.dof, after.generic_dof, after.redundant_constraints) == (before.dof, before.generic_dof,
                                                                          before.redundant_constraints)
    assert {frozenset(c) for c in after.clusters} == {frozenset(c) for c in before.clusters}
    assert after.collisions == before.collisions == []


def test_a_lego_model_in_another_order_gives_the_same_answer():
    parts = synthetic.random_lego(60, seed=11)
    before = run(parts)
    shuffled = [parts[k] for k in np.random.default_rng(2).permutation(len(parts))]
    after = run(shuffled)
    assert (after.dof, after.generic_dof, after.redundant_constraints) == (before.dof, before.generic_dof,
                                                                          before.redundant_constraints)
    assert {frozenset(c) for c in after.clusters} == {frozenset(c) for c in before.clusters}
    assert {frozenset(c) for c in after.superbricks} == {frozenset(c) for c in before.superbricks}


def test_a_symmetric_part_is_turned_only_through_distinct_placements():
    from plantsolve.solvers.rigidity.docking import coset_representatives

    assert len(coset_representatives(CATALOGUE["3001"])) == 12  # a half turn about y maps it onto itself
    assert len(coset_representatives(CATALOGUE["3003"])) == 6  # so do quarter turns
    assert len(coset_representatives(CATALOGUE["3937"])) == 12  # a hinge axis has no sign
    assert len(coset_representatives(CATALOGUE["3010"])) == 12 and len(coset_representatives(CATALOGUE["3701"])) == 12
