"""Cuts that round-off cannot flip: the same network in any order, with either end of a connection named
first, and with either factorisation (pivoted LU or the Schur complement's LDL^T), cuts the same connections
and puts every port at the same place (bit for bit across orders)."""

import numpy as np
import pytest

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.canonical import canonical_order
from plantsolve.solvers.alignment.cuts import CUT_MARGIN, choose_cut, connection_key, error_impact, tie_width
from plantsolve.solvers.alignment.direct import connection_basis
from plantsolve.solvers.alignment.kkt import use_schur
from plantsolve.solvers.alignment.model import build_model
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins, reordered

from alignment_cases import conflicting_tie_ins_and_a_free_branch, straight_run_between_tie_ins

# scan-like loop grids whose second tie-in was placed off (shift in mm, turn in degrees): each must be cut
CASES = {
    "3x3 turned 3 deg": {"nx": 3, "ny": 3, "seed": 2, "turn": 3.0},
    "5x3 valves, shifted 30 mm and turned": {"nx": 5, "ny": 3, "seed": 11, "shift": (0.0, 30.0, 0.0), "turn": 2.0,
                                             "valve_every": 5},
    "3x2 valves, shifted in 3-d": {"nx": 3, "ny": 2, "seed": 13, "shift": (-12.0, 8.0, 4.0), "turn": 0.5,
                                   "valve_every": 2},
    "4x2 valves, shifted and turned": {"nx": 4, "ny": 2, "seed": 42, "shift": (4.4, -6.4, -3.6), "turn": 3.0,
                                       "valve_every": 3},
}


def _answer(res) -> tuple[set, dict]:
    cuts = {frozenset((tuple(res.connections[k].from_), tuple(res.connections[k].to))) for k in res.cut_connections}
    return cuts, {c.id: [p.position for p in c.ports] for c in res.components}


@pytest.fixture(scope="module")
def solved() -> dict:
    out = {}
    for name, case in CASES.items():
        req = conflicting_tie_ins(**case)
        out[name] = (req, solve(req).result)
    return out


@pytest.mark.parametrize("name", CASES)
def test_any_order_and_either_end_first_gives_the_bit_identical_answer(solved, name):
    req, ref = solved[name]
    cuts, positions = _answer(ref)
    assert cuts, "the case must be a conflict"
    for seed in (0, 1, 2):
        shuffled = reordered(req, seed)
        res = solve(shuffled).result
        assert _answer(res) == (cuts, positions)
        assert res.converged == ref.converged and res.report.message == ref.report.message
        # the result is in the shuffled request's own order
        assert [(c.from_, c.to) for c in res.connections] == [(tuple(c.from_), tuple(c.to)) for c in shuffled.connections]
        assert [c.id for c in res.components] == [c.id for c in shuffled.components]


@pytest.mark.parametrize("name", CASES)
def test_lu_and_ldl_cut_the_same_connections_and_put_every_port_at_the_same_place(solved, name):
    # every cut is decided on the settled pose, which either factorisation gives to round-off, and a network cut
    # more than once has every round after its second cut solved on the LU: its answer is the all-LU one bit for bit
    # (each round starts from the measured pose; its loops close
    # at a singular point of their constraints, where the last feasibility steps crawl: solving the last round's
    # feasibility steps on the LDL^T left one of these 5.3e-3 mm from the LU's answer)
    req, ref = solved[name]
    with use_schur(False):
        lu = solve(req).result
    assert _answer(lu) == _answer(ref) and lu.converged == ref.converged


def test_the_rounds_keep_the_ldl_until_a_second_cut_and_the_cuts_are_the_settled_poses(solved):
    # the cuts are decided on the settled pose (solve._continue_round, direct.settle_conflict), whichever factorisation
    # a round ran on: the LDL^T's first round is the answer's, the round after the first cut keeps the LDL^T but for
    # its feasibility steps, and every round after the second cut is the LU's, step for step the all-LU path's
    req, ref = solved["5x3 valves, shifted 30 mm and turned"]
    rounds = ref.report.details["rounds"]
    said = [r["factorisation"] for r in rounds if not r.get("continuation") and not r.get("settled")]
    assert said == ["LDL^T", "LDL^T/LU"] + ["LU"] * (len(said) - 2) and len(said) == len(ref.cut_connections) + 1
    assert all(r["counted"] for r in rounds)
    # a round that ends with a connection open is continued on the LU, then settled, before its cut
    assert all(r["factorisation"] == "LU" and not r["closed"] for r in rounds if r.get("continuation"))
    assert [r["factorisation"] for r in rounds if r.get("settled")] == ["LDL^T", "LDL^T"]
    assert sum(r["iterations"] for r in rounds) == ref.iterations
    with use_schur(False):
        lu = solve(req).result
    lu_rounds = lu.report.details["rounds"]
    assert {r["factorisation"] for r in lu_rounds} == {"LU"}
    assert [r.get("settled", False) for r in lu_rounds] == [r.get("settled", False) for r in rounds]
    # the settle is the same minimisation on either factorisation, so it takes the same steps; the LU rounds too
    assert [r["iterations"] for r in lu_rounds if r.get("settled")] == [r["iterations"] for r in rounds if r.get("settled")]
    assert lu_rounds[-1]["iterations"] == rounds[-1]["iterations"]


@pytest.mark.parametrize("case", [straight_run_between_tie_ins, conflicting_tie_ins_and_a_free_branch])
def test_the_round_after_a_single_cut_keeps_the_ldl_but_for_its_feasibility_steps_and_gives_the_lu_answer(case):
    # one cut closes these: the round after it keeps the LDL^T for its rotation stage and the steps with the cost
    # and solves its feasibility steps on the LU; it closes, so it is the answer, with the all-LU path's cut and its
    # ports (measured: at most 1e-6 mm apart on plant-like networks cut once)
    req = case()
    ref = solve(req).result
    said = [r["factorisation"] for r in ref.report.details["rounds"] if not r.get("continuation") and not r.get("settled")]
    assert said == ["LDL^T", "LDL^T/LU"]  # no LU pass: the cut is the settled pose's
    with use_schur(False):
        lu = solve(req).result
    cuts, ports = _answer(ref)
    lu_cuts, lu_ports = _answer(lu)
    assert len(cuts) == 1 and cuts == lu_cuts and ref.converged and lu.converged
    assert max(float(np.max(np.abs(np.subtract(ports[c], lu_ports[c])))) for c in ports) < 1e-6  # mm


def _two_conflicting(req: AlignmentRequest):
    model = build_model(req)
    gap, ang = np.zeros(model.n_conn), np.zeros(model.n_conn)
    keys = [connection_key(model, k) for k in range(model.n_conn)]
    first, second = sorted(range(model.n_conn), key=lambda k: keys[k])[:2]
    return model, gap, ang, first, second


def test_impacts_within_the_margin_are_cut_where_the_request_was_measured_worst():
    req = conflicting_tie_ins(3, 3, seed=2, turn=3.0)
    model, gap, ang, first, second = _two_conflicting(req)
    measured = error_impact(model, *model.measured_errors)
    worse, better = (first, second) if measured[first] > measured[second] else (second, first)
    active = np.ones(model.n_conn, dtype=bool)
    top = 5.0  # mm
    for bump in (0.9, 0.5, -0.5, -0.9):  # either one larger by less than the margin: the worse measured is cut
        gap[worse], gap[better] = top, top + bump * CUT_MARGIN * top
        assert choose_cut(model, active, gap, ang) == worse
    gap[better] = top * (1 + 2 * CUT_MARGIN)  # beyond the margin the larger impact is cut, however it was measured
    assert choose_cut(model, active, gap, ang) == better
    assert tie_width(model, top) == pytest.approx(CUT_MARGIN * top)


def test_impacts_equal_as_solved_and_as_measured_are_cut_in_the_stable_order_of_their_ends():
    req = conflicting_tie_ins(3, 3, seed=2, turn=3.0)
    model, gap, ang, first, second = _two_conflicting(req)
    model.measured_errors = (np.zeros(model.n_conn), np.zeros(model.n_conn))  # a request measured closed
    active = np.ones(model.n_conn, dtype=bool)
    gap[second], gap[first] = 5.0, 5.0 * (1 - 0.5 * CUT_MARGIN)
    assert choose_cut(model, active, gap, ang) == first


def test_the_cut_does_not_depend_on_which_end_a_connection_names_first():
    req = conflicting_tie_ins(3, 3, seed=2, turn=3.0)
    turned = req.model_copy(update={"connections": [c.model_copy(update={"from_": c.to, "to": c.from_})
                                                    for c in req.connections]})
    a, b = build_model(req), build_model(turned)
    assert [connection_key(a, k) for k in range(a.n_conn)] == [connection_key(b, k) for k in range(b.n_conn)]
    gap = np.linspace(1.0, 2.0, a.n_conn)[::-1].copy()
    gap[3] = gap[0] * (1 - 0.5 * CUT_MARGIN)  # a near-tie with the largest
    ang = np.zeros(a.n_conn)
    active = np.ones(a.n_conn, dtype=bool)
    assert choose_cut(a, active, gap, ang) == choose_cut(b, active, gap, ang)


def test_canonical_order_runs_every_connection_from_its_smaller_end():
    req = reordered(conflicting_tie_ins(3, 2, seed=13, valve_every=2), seed=4)
    canon, _, conns = canonical_order(req)
    ends = [((c.from_[0], c.from_[1]), (c.to[0], c.to[1])) for c in canon.connections]
    assert all(a < b for a, b in ends) and ends == sorted(ends)
    assert [c.id for c in canon.components] == sorted(c.id for c in req.components)
    # conns maps every connection of the request to its canonical place, which joins the same two ports (numbered
    # there in the canonical order of each component's ports)
    def port(r, end):
        comp = next(c for c in r.components if c.id == end[0])
        return end[0], tuple(comp.ports[end[1]].position)
    for k, c in enumerate(req.connections):
        assert {port(req, c.from_), port(req, c.to)} == {port(canon, e) for e in ends[conns[k]]}


def test_the_direction_constraint_of_a_swapped_connection_is_the_same_up_to_sign():
    rng = np.random.default_rng(3)
    ua = rng.normal(size=(50, 3)); ua /= np.linalg.norm(ua, axis=1, keepdims=True)
    ub = -ua + 0.05 * rng.normal(size=(50, 3)); ub /= np.linalg.norm(ub, axis=1, keepdims=True)
    e1, e2 = connection_basis(ua, ub)
    f1, f2 = connection_basis(ub, ua)
    assert np.array_equal(f1, -e1) and np.array_equal(f2, e2)  # exactly: IEEE negation, no round-off
    for e in (e1, e2):  # a basis of the plane normal to the connection's axis
        assert np.allclose(np.einsum("ij,ij->i", e, ua - ub), 0.0, atol=1e-12)
