"""Closed answers of the exact pass: classical linkages, idler chains, invariances, and the exact
modular rank against a float SVD."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantsolve.schemas.rigidity import RigidityRequest
from plantsolve.solvers.rigidity import synthetic
from plantsolve.solvers.rigidity.mobility import Joint, analyse, dense_svd_dof
from plantsolve.solvers.rigidity.pebble import PebbleGame
from plantsolve.solvers.rigidity.screws import allowed_twists, constraint_rows
from plantsolve.solvers.rigidity.solve import solve


def run(body):
    return solve(RigidityRequest.model_validate(body)).result


def sets(clusters):
    return {frozenset(c) for c in clusters}


@pytest.mark.parametrize("name, dof, generic", [
    ("four_bar", 1, 0), ("collinear_hinges", 1, 0), ("sarrus", 1, 0), ("bennett", 1, 0),
    ("idler_chains", 2, 0), ("open_chain", 3, 3), ("ball_joint", 3, 3)])
def test_closed_answers(name, dof, generic):
    result = run(getattr(synthetic, name)())
    assert (result.dof, result.generic_dof) == (dof, generic)
    assert result.special_position == (dof > generic)
    assert result.rigid is False


def test_four_bar_is_special_with_three_redundant_constraints():
    result = run(synthetic.four_bar())
    assert result.rank_method == "modular"
    # 4 hinges x 5 rows = 20 rows on 18 unknowns with nullity 1: rank 17
    assert result.redundant_constraints == 3
    assert all(j.moves for j in result.joints)
    assert len(result.clusters) == 4


@pytest.mark.parametrize("n, dof", [(6, 0), (7, 1)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_loops(n, dof, seed):
    result = run(synthetic.random_loop(n, seed))
    assert result.dof == dof and result.generic_dof == dof and not result.special_position
    assert result.rigid == (dof == 0)


def test_idler_chains_keep_the_ends_rigid_while_every_hinge_turns():
    result = run(synthetic.idler_chains())
    assert result.dof == 2
    assert sets(result.clusters) == {frozenset("AB"), frozenset("C"), frozenset("D")}
    assert all(j.moves for j in result.joints)


def test_a_third_hinge_off_both_lines_locks_the_idlers_ends_but_not_the_idlers():
    body = synthetic.idler_chains()
    body["bodies"].append({"id": "E"})
    body["joints"] += [synthetic.hinge_joint("AE", "A", "E", (0, 0, 100), (0, 0, 1)),
                       synthetic.hinge_joint("EB", "E", "B", (5, 5, 100), (1, 1, 0))]
    result = run(body)
    # E's two hinges do not share a line: E cannot move relative to A and B, which are rigid anyway
    assert result.dof == 2 and frozenset("ABE") in sets(result.clusters)


def test_sarrus_moves_the_top_straight_up():
    result = run(synthetic.sarrus())
    assert result.dof == 1 and len(result.clusters) == 6


def test_rigid_joints_make_superbricks_and_redundancy():
    body = {"bodies": [{"id": x} for x in "ABC"], "joints": [
        {"id": "r1", "type": "rigid", "bodies": ["A", "B"], "point": [0, 0, 0]},
        {"id": "r2", "type": "rigid", "bodies": ["B", "C"], "point": [1, 0, 0]},
        {"id": "r3", "type": "rigid", "bodies": ["C", "A"], "point": [2, 0, 0]},
        {"id": "h", "type": "hinge", "bodies": ["A", "C"], "point": [0, 0, 0], "axis": [0, 0, 1]}]}
    result = run(body)
    assert result.dof == 0 and result.rigid and result.superbricks == [["A", "B", "C"]]
    assert result.redundant_constraints == 6 + 5


def test_unconnected_bodies_add_six_each():
    body = synthetic.four_bar()
    body["bodies"] += [{"id": "loose1"}, {"id": "loose2"}]
    result = run(body)
    assert result.dof == 1 + 12 and result.generic_dof == 12 and not result.rigid


def test_slider_and_cylindrical():
    body = {"bodies": [{"id": "A"}, {"id": "B"}], "joints": [
        {"id": "s", "type": "slider", "bodies": ["A", "B"], "point": [0, 0, 0], "axis": [1, 0, 0]}]}
    assert run(body).dof == 1
    body["joints"][0]["type"] = "cylindrical"
    assert run(body).dof == 2
    # a cylindrical joint and a hinge on the same line: only the turn is left
    body["joints"].append({"id": "h", "type": "hinge", "bodies": ["A", "B"], "point": [7, 0, 0], "axis": [-2, 0, 0]})
    result = run(body)
    assert result.dof == 1 and result.redundant_constraints == 4 + 5 - 5


@pytest.mark.parametrize("name", ["four_bar", "sarrus", "idler_chains", "collinear_hinges"])
def test_invariant_under_a_rigid_motion_of_the_whole_input(name):
    body = getattr(synthetic, name)()
    before = run(body)
    rotation = Rotation.from_rotvec([0.3, -1.1, 0.7])
    after = run(synthetic.moved(body, rotation, [1234.5, -77.25, 3.0]))
    assert before.rank_method == "modular" and after.rank_method == "svd"
    assert (after.dof, after.generic_dof, after.redundant_constraints) == (before.dof, before.generic_dof,
                                                                          before.redundant_constraints)
    assert sets(after.clusters) == sets(before.clusters)
    assert [j.moves for j in after.joints] == [j.moves for j in before.joints]


@pytest.mark.parametrize("name", ["four_bar", "sarrus", "idler_chains", "bennett"])
def test_invariant_under_reordering(name):
    body = getattr(synthetic, name)()
    before = run(body)
    rng = np.random.default_rng(5)
    shuffled = {**body, "bodies": [body["bodies"][k] for k in rng.permutation(len(body["bodies"]))],
                "joints": [body["joints"][k] for k in rng.permutation(len(body["joints"]))]}
    swapped = [dict(j, bodies=j["bodies"][::-1]) for j in shuffled["joints"]]
    for variant in (shuffled, {**shuffled, "joints": swapped}):
        after = run(variant)
        assert (after.dof, after.generic_dof, after.redundant_constraints) == (before.dof, before.generic_dof,
                                                                              before.redundant_constraints)
        assert sets(after.clusters) == sets(before.clusters)
        assert {j.id: j.moves for j in after.joints} == {j.id: j.moves for j in before.joints}


def _joints(body):
    index = {b["id"]: k for k, b in enumerate(body["bodies"])}
    return len(index), [Joint(j["type"], index[j["bodies"][0]], index[j["bodies"][1]], tuple(j["point"]),
                              tuple(j.get("axis") or (0, 0, 1))) for j in body["joints"]]


@pytest.mark.parametrize("body", [synthetic.four_bar(), synthetic.sarrus(), synthetic.idler_chains(),
                                  synthetic.collinear_hinges(), synthetic.open_chain(3), synthetic.ball_joint()]
                         + [synthetic.random_loop(n, s) for n in (5, 6, 7, 8) for s in range(3)])
def test_float_svd_rank_agrees_with_modular_rank(body):
    n, joints = _joints(body)
    exact = analyse(n, joints)
    floating = analyse(n, joints, exact=False)
    assert exact.rank_method == "modular" and floating.rank_method == "svd"
    assert floating.dof == exact.dof == dense_svd_dof(n, joints)
    assert floating.redundant_constraints == exact.redundant_constraints
    assert sets(floating.clusters) == sets(exact.clusters) and floating.moves == exact.moves


@pytest.mark.parametrize("exact", [True, False])
def test_loop_closure_and_body_twist_formulations_agree(exact):
    bodies = [synthetic.four_bar(), synthetic.sarrus(), synthetic.idler_chains(), synthetic.collinear_hinges(),
              synthetic.bennett()] + [synthetic.random_loop(n, s) for n in (6, 7, 9) for s in range(2)]
    for body in bodies:
        n, joints = _joints(body)
        if exact and body is bodies[4]:
            continue  # the Bennett linkage has irrational coordinates
        loops = analyse(n, joints, exact=exact)
        twists = analyse(n, joints, exact=exact, method="twists")
        assert (loops.dof, loops.redundant_constraints, loops.moves) == (twists.dof, twists.redundant_constraints,
                                                                        twists.moves)
        assert sets(loops.clusters) == sets(twists.clusters)


def test_a_nearly_special_position_is_generic_for_the_exact_rank():
    # the four-bar with one hinge tilted by one part in a thousand is rigid, exactly
    body = synthetic.four_bar()
    body["joints"][2]["axis"] = [0, 1, 1000]
    assert run(body).dof == 0


@pytest.mark.parametrize("kind", ["hinge", "ball", "slider", "cylindrical", "rigid"])
def test_constraint_rows_are_reciprocal_to_the_allowed_twists(kind):
    point, axis = np.array([3.0, -2.0, 5.0]), np.array([1.0, 2.0, -2.0])
    rows = constraint_rows(kind, point, axis)
    twists = allowed_twists(kind, point, axis)
    assert np.linalg.matrix_rank(rows) == rows.shape[0] == 6 - len(twists)
    if len(twists):
        assert np.abs(rows @ twists.T).max() < 1e-12


def test_pebble_game_counts_match_the_rank_of_a_random_realisation():
    rng = np.random.default_rng(3)
    for trial in range(10):
        n = int(rng.integers(3, 9))
        game = PebbleGame()
        joints = []
        for _ in range(int(rng.integers(2, 14))):
            a, b = rng.choice(n, 2, replace=False)
            kind = str(rng.choice(["hinge", "ball", "cylindrical", "slider"]))
            joints.append(Joint(kind, int(a), int(b), tuple(rng.normal(size=3)), tuple(rng.normal(size=3))))
            game.add_joint(int(a), int(b), {"hinge": 5, "ball": 3, "cylindrical": 4, "slider": 5}[kind])
        for k in range(n):
            game.add_body(k)
        assert game.generic_dof == analyse(n, joints).dof == dense_svd_dof(n, joints)


def test_two_balls_turn_about_their_line_which_the_count_misses():
    body = {"bodies": [{"id": "A"}, {"id": "B"}], "joints": [
        {"id": "b1", "type": "ball", "bodies": ["A", "B"], "point": [0, 0, 0]},
        {"id": "b2", "type": "ball", "bodies": ["A", "B"], "point": [3, 4, 12]}]}
    result = run(body)
    assert result.dof == 1 and result.generic_dof == 0 and result.special_position  # a documented limit
