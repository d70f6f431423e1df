"""dof told apart: the rigid clusters that turn alone about one line (a pin spinning in its holes, an axle with its
gears in round holes, a door on its hinge) are listed in result.lone_motions; linked_dof is what moves several
clusters together. A Technic frame held by pins has dof = its pins, every one named, and linked_dof 0."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from plantsolve.schemas.rigidity import LoneMotion, RigidityRequest
from plantsolve.solvers.rigidity import synthetic
from plantsolve.solvers.rigidity.screws import constraint_rows
from plantsolve.solvers.rigidity.solve import solve

ROT_Y90 = synthetic.ROT_Y90
EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "rigidity"


def run(body):
    return solve(RigidityRequest.model_validate(body)).result


def part(pid, number, x, y, z, rotation=None):
    return {"id": pid, "part": number, "position": [x, y, z], "rotation": rotation or synthetic.IDENTITY}


def turns_alone(result, lone) -> bool:
    """Every joint between the cluster and the rest allows the cluster's turn (and slide, if said) about its line:
    the twist (axis, point x axis) and the slide (0, axis) meet each joint's constraint rows."""
    inside = set(lone.parts)
    a, c = np.asarray(lone.axis), np.asarray(lone.point)
    twists = [np.concatenate([a, np.cross(c, a)])] + ([np.concatenate([np.zeros(3), a])] if lone.slides else [])
    across = [j for j in result.joints if (j.bodies[0] in inside) != (j.bodies[1] in inside)]
    return bool(across) and all(np.abs(constraint_rows(j.type, np.asarray(j.point, float),
                                                       np.asarray(j.axis if j.axis else (0, 0, 1), float)) @ t
                                       ).max() < 1e-9 for j in across for t in twists)


def test_a_frame_held_by_pins_moves_only_by_its_pins_spinning_each_named():
    # two Technic bricks face to face, two pins through both (turned into the bricks' z holes): the frame a-b is
    # rigid, each pin spins in its two holes
    parts = [part("a", "3701", 0, 0, 0), part("b", "3701", 0, 0, 20),
             part("p1", "2780", -20, 10, 10, ROT_Y90), part("p2", "2780", 20, 10, 10, ROT_Y90)]
    result = run({"parts": parts})
    assert result.dof == 2 and result.linked_dof == 0
    assert sorted(m.parts for m in result.lone_motions) == [["p1"], ["p2"]]
    for m in result.lone_motions:
        assert m.numbers == ["2780"] and m.dof == 1 and not m.slides
        assert m.axis in ([0.0, 0.0, 1.0], [0.0, 0.0, -1.0]) and m.point[:2] in ([-20.0, 10.0], [20.0, 10.0])
        assert turns_alone(result, m)
    assert "2 of them from 2 cluster(s) turning alone" in result.report.message


def test_the_frame_reference_is_not_listed_and_the_counts_add_up_to_dof():
    # a pin in one brick's hole: the brick is the reference; a pin's joint is a hinge (it stops at its collar)
    parts = [part("a", "3701", 0, 0, 0), part("p", "2780", -20, 10, 10, ROT_Y90)]
    result = run({"parts": parts})
    (m,) = result.lone_motions
    assert result.dof == 1 and m.parts == ["p"] and result.linked_dof == 0 and turns_alone(result, m)


def test_an_axle_in_a_round_hole_turns_and_slides_two_dof():
    result = run({"parts": [part("brick", "3700", 0, 0, 0), part("axle", "3705", 0, 10, 10, ROT_Y90)]})
    (m,) = result.lone_motions
    assert result.dof == 2 and m.parts == ["axle"] and m.slides and m.dof == 2 and result.linked_dof == 0
    assert turns_alone(result, m)


def test_a_door_is_a_lone_motion_and_a_four_bar_is_linked():
    body = json.loads((EXAMPLES / "four_bar_and_door.json").read_text())
    result = run(body)
    assert result.dof == 2
    (door,) = result.lone_motions
    assert door.parts == ["door"] and door.numbers == [] and door.axis == [0.0, 1.0, 0.0] and turns_alone(result, door)
    assert result.linked_dof == 1  # the crank, coupler and rocker turn together: no one of them turns alone


def test_a_cluster_held_on_two_lines_is_not_lone():
    # a crank hinged to the ground at one point and to the coupler at another: wrongly listing it would let
    # lone dof exceed dof
    body = json.loads((EXAMPLES / "four_bar_and_door.json").read_text())
    result = run(body)
    assert all(m.parts != ["crank"] for m in result.lone_motions)
    crank = LoneMotion(parts=["crank"], numbers=[], point=[0.0, 0.0, 0.0], axis=[0.0, 0.0, 1.0], slides=False, dof=1)
    assert not turns_alone(result, crank)  # its joint at (40, 0, 0) holds the turn about the ground's hinge
    assert sum(m.dof for m in result.lone_motions) + result.linked_dof == result.dof


def test_hinged_top_turns_alone_about_its_shared_hinge_line():
    # two hinge-brick pairs on one hinge line carry one roof: the roof's cluster turns alone about that line
    parts = [part("base", "3001", 0, 0, 0), part("h1", "3937", -20, -24, 10), part("t1", "3938", -20, -24, 10),
             part("h2", "3937", 20, -24, 10), part("t2", "3938", 20, -24, 10), part("roof", "3020", 0, -32, 0)]
    result = run({"parts": parts})
    (m,) = result.lone_motions
    assert result.dof == 1 and result.special_position and sorted(m.parts) == ["roof", "t1", "t2"]
    assert result.linked_dof == 0 and turns_alone(result, m)
    warning = next(w for w in result.report.warnings if w.code == "special_position")
    assert "1 x (3938 + 3938 + 3020)" not in warning.message and "2 x 3938 + 3020" in warning.message
    assert warning.details == {"lone_dof": 1, "linked_dof": 0}


def test_no_lone_motion_is_claimed_that_the_rank_does_not_count():
    # a door on two hinges 1e-11 off one line: the default rank takes them for one line (the door turns), a rank
    # cut at 1e-15 holds them apart (dof 0); the lone motions are sought among the rank's clusters, so none is listed
    # although the joints lie on one line to the lone test's own tolerance
    body = {"units": "mm", "bodies": [{"id": "ground"}, {"id": "door"}], "joints": [
        {"id": "top", "type": "hinge", "bodies": ["ground", "door"], "point": [0, 0, 0], "axis": [0, 1, 0]},
        {"id": "bottom", "type": "hinge", "bodies": ["ground", "door"], "point": [1e-11, 50, 0], "axis": [0, 1, 0]}]}
    turning = run(body)
    assert turning.dof == 1 and [m.parts for m in turning.lone_motions] == [["door"]] and turning.linked_dof == 0
    held = run({**body, "options": {"rank_tolerance": 1e-15}})
    assert held.dof == 0 and held.lone_motions == [] and held.linked_dof == 0
