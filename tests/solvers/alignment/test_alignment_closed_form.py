"""Closed-form cases for both methods."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantsolve.solvers.geometry import rotation
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.synthetic import grid_network

from alignment_cases import conn, elbow, pipe, port, request

METHODS = ["direct", "dual_quaternion"]


def ports(res, cid):
    comp = next(c for c in res.components if c.id == cid)
    return np.array([p.position for p in comp.ports]), np.array([p.direction for p in comp.ports])


def assert_watertight(req, res):
    by_id = {c.id: c for c in res.components}
    for c, r in zip(req.connections, res.connections):
        if r.cut:
            continue
        pa = by_id[c.from_[0]].ports[c.from_[1]]
        pb = by_id[c.to[0]].ports[c.to[1]]
        assert pa.position == pb.position  # bit-identical
        assert pa.direction == [-v for v in pb.direction]
        assert r.position_error == 0.0 and r.angle_error == 0.0


@pytest.mark.parametrize("method", METHODS)
def test_pipe_between_two_fixed_elbows_takes_their_ports(method):
    e1 = elbow("E1", [0, 0, 0], [0, -1, 0], [1, 0, 0], fixed=True)
    e2 = elbow("E2", [2000, 0, 0], [-1, 0, 0], [0, 1, 0], fixed=True)
    p = pipe("P", [151.0, 0.8, -0.5], [1849.0, -0.6, 0.7])  # measured off by ~1 mm and tilted
    req = request([e1, e2, p], [conn("E1", 1, "P", 0), conn("P", 1, "E2", 0)], method=method)
    res = solve(req).result
    assert res.converged and not res.cut_connections
    P, D = ports(res, "P")
    assert P.tolist() == [[150.0, 0.0, 0.0], [1850.0, 0.0, 0.0]]
    np.testing.assert_allclose(D, [[-1, 0, 0], [1, 0, 0]], atol=1e-15)
    assert next(c for c in res.components if c.id == "P").length_change == pytest.approx(1700.0 - np.linalg.norm([1698, -1.4, 1.2]), abs=1e-9)
    assert_watertight(req, res)


@pytest.mark.parametrize("method", METHODS)
def test_elbow_gap_closes_onto_fixed_pipes(method):
    p1 = pipe("P1", [0, 0, 0], [1000, 0, 0], fixed=True)
    p2 = pipe("P2", [1150, 150, 0], [1150, 1150, 0], fixed=True)
    e = elbow("E", [1150, 0, 0], [-1, 0, 0], [0, 1, 0], rot=[0.01, -0.02, 0.015], shift=(2.0, -1.5, 3.0))
    req = request([p1, e, p2], [conn("P1", 1, "E", 0), conn("E", 1, "P2", 0)], method=method)
    res = solve(req).result
    assert res.converged
    P, D = ports(res, "E")
    np.testing.assert_array_equal(P, [[1000, 0, 0], [1150, 150, 0]])
    np.testing.assert_array_equal(D, [[-1, 0, 0], [0, 1, 0]])
    comp = next(c for c in res.components if c.id == "E")
    # the reported transform undoes the perturbation
    R = rotation(comp.transform.rotation)
    np.testing.assert_allclose(R.as_rotvec(), -np.array([0.01, -0.02, 0.015]), atol=1e-9)
    assert_watertight(req, res)


@pytest.mark.parametrize("method", METHODS)
def test_tee_with_three_fixed_pipes(method):
    R = Rotation.from_rotvec([0.004, 0.006, -0.01])
    arms = np.array([[-150, 0, 0], [150, 0, 0], [0, 150, 0.0]])
    tee = {"id": "T", "kind": "fitting", "type": "tee",
           "ports": [port(R.apply(a) + [0.5, -0.3, 0.2], R.apply(a / 150)) for a in arms]}
    comps = [tee, pipe("A", [-1150, 0, 0], [-150, 0, 0], fixed=True), pipe("B", [150, 0, 0], [1150, 0, 0], fixed=True),
             pipe("C", [0, 150, 0], [0, 1150, 0], fixed=True)]
    req = request(comps, [conn("T", 0, "A", 1), conn("T", 1, "B", 0), conn("T", 2, "C", 0)], method=method)
    res = solve(req).result
    assert res.converged
    P, _ = ports(res, "T")
    np.testing.assert_array_equal(P, arms)


@pytest.mark.parametrize("method", METHODS)
def test_tee_with_free_pipes_moves_the_tee_not_the_axes(method):
    R = Rotation.from_rotvec([0.004, 0.006, -0.01])
    arms = np.array([[-150, 0, 0], [150, 0, 0], [0, 150, 0.0]])
    tee = {"id": "T", "kind": "fitting", "type": "tee",
           "ports": [port(R.apply(a) + [0.5, -0.3, 0.2], R.apply(a / 150)) for a in arms]}
    comps = [tee, pipe("A", [-3150, 0, 0], [-150, 0, 0]), pipe("B", [150, 0, 0], [3150, 0, 0]),
             pipe("C", [0, 150, 0], [0, 3150, 0])]
    # nothing fixed and no anchor: the paper's weighting alone decides who moves
    req = request(comps, [conn("T", 0, "A", 1), conn("T", 1, "B", 0), conn("T", 2, "C", 0)], method=method,
                  anchor=False)
    res = solve(req).result
    assert res.converged
    assert_watertight(req, res)
    d = res.report.details
    factor = 0.25 if method == "direct" else 1.0
    assert d["pipe_axis_movement"]["max"] < factor * d["fitting_displacement"]["max"]


def test_rectangular_loop_closes_to_a_rectangle():
    req = grid_network(2, 2, origin=(1e6, 2e5, 1e4), seed=3)
    res = solve(req).result
    assert res.converged and not res.cut_connections
    assert_watertight(req, res)
    by_id = {c.id: c for c in res.components}
    axes, lengths = {}, {}
    for cid in ("P1", "P2", "P3", "P4"):
        P = np.array([p.position for p in by_id[cid].ports])
        axes[cid] = (P[1] - P[0]) / np.linalg.norm(P[1] - P[0])
        lengths[cid] = np.linalg.norm(P[1] - P[0])
    # P1: (0,0)->(1,0), P2: (0,0)->(0,1), P3: (0,1)->(1,1), P4: (1,0)->(1,1)
    # the planar ring is a singular point (first-order twist mode): closure is exact, the twist
    # is only determined to ~sqrt(residual), hence the looser parallelism check
    assert abs(axes["P1"] @ axes["P2"]) < 1e-9
    np.testing.assert_allclose(axes["P1"], axes["P3"], atol=1e-5)
    np.testing.assert_allclose(axes["P2"], axes["P4"], atol=1e-5)
    assert lengths["P1"] == pytest.approx(lengths["P3"], abs=1e-2)
    assert lengths["P2"] == pytest.approx(lengths["P4"], abs=1e-2)


def test_ladder_of_loops_closes_with_orthogonal_runs():
    req = grid_network(2, 4, valve_every=3, tie_ins=((0, 0),), origin=(5e5, 5e5, 0), seed=5)
    res = solve(req).result
    assert res.converged and not res.cut_connections
    assert_watertight(req, res)
    dirs = np.array([c.ports[1].direction for c, r in zip(res.components, req.components) if r.kind == "pipe"])
    # every pipe runs along one of two perpendicular directions of the fixed corner elbow
    ref = np.array(req.components[0].ports[0].direction)
    cos = np.abs(dirs @ ref)
    assert np.all((cos > 1 - 1e-9) | (cos < 1e-9))


@pytest.mark.parametrize("method", METHODS)
def test_valve_up_vector_is_re_established(method):
    tilt = Rotation.from_rotvec([0.0, 0.012, 0.0]) * Rotation.from_rotvec([0.05, 0, 0])
    ports = [port(tilt.apply([-150, 0, 0]) + [1150, 0, 0], tilt.apply([-1, 0, 0])),
             port(tilt.apply([150, 0, 0]) + [1150, 0, 0], tilt.apply([1, 0, 0]))]
    up0 = tilt.apply([0, 0.2, 1.0])
    valve = {"id": "V", "kind": "fitting", "type": "valve", "up": up0.tolist(), "ports": ports}
    comps = [pipe("A", [0, 0, 0], [1000, 0, 0], fixed=True), valve, pipe("B", [1300, 0, 0], [2300, 0, 0], fixed=True)]
    req = request(comps, [conn("A", 1, "V", 0), conn("V", 1, "B", 0)], method=method)
    res = solve(req).result
    assert res.converged
    comp = next(c for c in res.components if c.id == "V")
    np.testing.assert_array_equal([p.position for p in comp.ports], [[1000, 0, 0], [1300, 0, 0]])
    expected = np.array([0.0, up0[1], up0[2]]) / np.linalg.norm(up0[1:])
    np.testing.assert_allclose(comp.up, expected, atol=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_conflicting_tie_ins_cut_one_connection_and_close_the_rest(method):
    e1 = elbow("E1", [0, 0, 0], [0, -1, 0], [1, 0, 0], fixed=True)
    e2 = elbow("E2", [2000, 5.0, 0], [-1, 0, 0], [0, 1, 0], fixed=True)  # 5 mm off the line of E1
    p = pipe("P", [151.0, 0.8, -0.5], [1849.0, 3.0, 0.7])
    # a free branch elsewhere with a gap that must still close
    q = pipe("Q", [0, -150, 0], [0, -1150, 0])
    e3 = elbow("E3", [0, -1300, 0], [0, 1, 0], [1, 0, 0], shift=(1.0, -2.0, 0.5), rot=[0, 0, 0.01])
    r = pipe("R", [150, -1300, 0], [1150, -1300, 0])
    comps = [e1, e2, p, q, e3, r]
    conns = [conn("E1", 1, "P", 0), conn("P", 1, "E2", 0), conn("E1", 0, "Q", 0), conn("Q", 1, "E3", 0),
             conn("E3", 1, "R", 0)]
    req = request(comps, conns, method=method)
    res = solve(req).result
    assert len(res.cut_connections) == 1 and res.cut_connections[0] in (0, 1)
    assert res.converged
    assert res.report.status == "warning"
    assert any(w.code == "connections_cut" for w in res.report.warnings)
    cut = res.connections[res.cut_connections[0]]
    assert cut.cut and cut.position_error > 4.0
    assert_watertight(req, res)


def test_iteration_cap_returns_best_result_with_errors():
    req = grid_network(3, 3, seed=2, options={"method": "dual_quaternion", "max_iterations": 5})
    res = solve(req).result
    assert not res.converged
    assert res.iterations <= 5
    assert res.max_position_error > 1e-3
    assert len(res.components) == len(req.components)
    warn = next(w for w in res.report.warnings if w.code == "not_converged")
    assert max(c["position_error"] for c in warn.details["connections"]) == pytest.approx(res.max_position_error)
    assert "cap (5)" in res.report.details["stop_reason"] and "cap (5)" in res.report.message


@pytest.mark.parametrize("method", METHODS)
def test_iteration_cap_is_honoured_by_both_methods(method):
    req = grid_network(3, 3, seed=2, tie_ins=((0, 0),), options={"method": method, "max_iterations": 3,
                                                                "tolerance_profile": "custom"})
    res = solve(req).result
    assert res.iterations <= 3
    assert "iteration cap (3) reached" in res.report.details["stop_reason"]
    assert not res.converged and "Not converged" in res.report.message
    if method == "direct":
        full = solve(grid_network(3, 3, seed=2, tie_ins=((0, 0),), options={"method": method})).result
        assert full.converged and "cap" not in full.report.details["stop_reason"] and full.iterations > 3


def test_explosion_in_a_closable_network_shortens_the_steps_instead_of_cutting():
    # an absurd step limit makes the alternating scheme overshoot; the indicator fires, but the direct method
    # closed this grid without a cut, so nothing conflicts: the run restarts with shorter steps
    req = grid_network(3, 3, seed=2, options={"method": "dual_quaternion", "explosion_factor": 1.05,
                                              "step_limit": 500.0, "max_iterations": 400, "max_cuts": 2})
    res = solve(req).result
    assert not res.cut_connections
    assert res.report.details["step_limit_restarts"] >= 1
    stop = res.report.details["stop_reason"]
    assert stop.startswith("all connections within tolerance") if res.converged else ("cap (400)" in stop or "stalled" in stop)


def test_explosion_in_a_conflicting_network_cuts_the_worst_connection():
    # a tie-in turned 3 degrees against the grid: the constraints conflict, explosion cuts are allowed
    req = grid_network(3, 3, seed=2, tie_ins=((0, 0), (2, 2)), options={
        "method": "dual_quaternion", "explosion_factor": 1.05, "step_limit": 500.0, "max_iterations": 300,
        "max_cuts": 3})
    comps = [c.model_copy(deep=True) for c in req.components]
    turned = Rotation.from_rotvec([0.0, 0.0, np.radians(3.0)])
    moved = [c for c in comps if c.fixed][-1]
    for p in moved.ports:
        p.direction = turned.apply(p.direction).tolist()
    req = req.model_copy(update={"components": comps})
    res = solve(req).result
    cuts = next(w for w in res.report.warnings if w.code == "connections_cut").details["cuts"]
    assert cuts and {c["reason"] for c in cuts} <= {"conflict", "explosion"}
    assert res.cut_connections == sorted(c["index"] for c in cuts)
    assert all(res.connections[k].cut for k in res.cut_connections)


@pytest.mark.parametrize("method", METHODS)
def test_fitting_bolted_to_fitting_forms_a_cluster_that_closes(method):
    # run pipes A, B fixed; a tee on them; an elbow bolted straight onto the tee branch (a FixCluster
    # of two fittings with a 1 mm gap between them), then a free pipe C up from the elbow
    arms = np.array([[-150, 0, 0], [150, 0, 0], [0, 150, 0.0]])
    R = Rotation.from_rotvec([0.0, 0.0, 0.004])
    tee = {"id": "T", "kind": "fitting", "type": "tee",
           "ports": [port(R.apply(a) + [0.3, 0.4, 0.0], R.apply(a / 150)) for a in arms]}
    el = elbow("E", [0, 300, 0], [0, -1, 0], [0, 0, 1], shift=(0.8, -0.5, 0.6), rot=[0.01, 0, 0])
    comps = [pipe("A", [-1150, 0, 0], [-150, 0, 0], fixed=True), pipe("B", [150, 0, 0], [1150, 0, 0], fixed=True),
             tee, el, pipe("C", [0, 300, 150], [0, 300, 1150])]
    conns = [conn("T", 0, "A", 1), conn("T", 1, "B", 0), conn("T", 2, "E", 0), conn("E", 1, "C", 0)]
    req = request(comps, conns, method=method)
    res = solve(req).result
    assert res.converged and not res.cut_connections
    assert_watertight(req, res)
    P, D = ports(res, "T")
    np.testing.assert_allclose(P[:2], arms[:2], atol=1e-9)  # the run sits on the fixed pipes
    # the tee may only roll about the run axis: branch stays normal to it, 150 from the centre
    assert abs(D[2, 0]) < 1e-12 and np.linalg.norm(P[2]) == pytest.approx(150.0, abs=1e-9)
    assert abs(np.arctan2(D[2, 2], D[2, 1])) < 0.01
    # the elbow, a rigid 90-degree fitting, keeps its shape on the branch
    PE, DE = ports(res, "E")
    np.testing.assert_allclose(PE[0], P[2], atol=0)
    assert abs(DE[0] @ DE[1]) < 1e-12


def test_the_paper_method_stops_when_it_stalls_and_says_so():
    # two tie-ins whose nozzles do not line up: the alternating means settle on a residual gap and stay there
    req = grid_network(3, 3, seed=2, tie_ins=((0, 0), (2, 2)), options={"method": "dual_quaternion",
                                                                      "max_iterations": 100_000})
    comps = [c.model_copy(deep=True) for c in req.components]
    turned = Rotation.from_rotvec([0.0, 0.0, np.radians(2.0)])
    for p in [c for c in comps if c.fixed][-1].ports:
        p.direction = turned.apply(p.direction).tolist()
    res = solve(req.model_copy(update={"components": comps})).result
    stop = res.report.details["stop_reason"]
    assert not res.converged and stop.startswith("stalled") and res.iterations < 2_000
    assert "Not converged (stalled" in res.report.message
    assert any(w.code == "not_converged" for w in res.report.warnings)
