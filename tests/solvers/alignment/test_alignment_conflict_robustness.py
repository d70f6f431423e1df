"""Conflicts are decided by the problem, not by the input order or round-off: shuffled requests cut the
same connections and put every port at the same place; impacts the solver cannot tell apart are ties,
broken by the connections' (id, port) keys."""

import numpy as np
import pytest

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.cuts import choose_cut, tie_width
from plantsolve.solvers.alignment.model import build_model
from plantsolve.solvers.alignment.synthetic import grid_network

from alignment_cases import (
    conflicting_tie_ins_and_a_free_branch,
    loop_grid_with_a_turned_tie_in,
    straight_run_between_tie_ins,
)


def _shuffled(req: AlignmentRequest, seed: int) -> AlignmentRequest:
    body = req.model_dump(mode="json", by_alias=True)
    rng = np.random.default_rng(seed)
    body["components"] = [body["components"][i] for i in rng.permutation(len(body["components"]))]
    conns = [body["connections"][i] for i in rng.permutation(len(body["connections"]))]
    body["connections"] = conns  # each keeps its orientation (see plantsolve.solvers.alignment.canonical)
    return AlignmentRequest.model_validate(body)


def _outcome(req: AlignmentRequest, res) -> tuple[set, dict]:
    cuts = {frozenset((tuple(res.connections[k].from_), tuple(res.connections[k].to))) for k in res.cut_connections}
    return cuts, {c.id: np.array([p.position for p in c.ports]) for c in res.components}


@pytest.mark.parametrize("case", [straight_run_between_tie_ins, conflicting_tie_ins_and_a_free_branch,
                                  loop_grid_with_a_turned_tie_in])
def test_conflicts_are_cut_the_same_whatever_the_input_order(case):
    req = case()
    ref = solve(req).result
    assert ref.cut_connections, "the case must be a conflict"
    cuts, P = _outcome(req, ref)
    for seed in (0, 1, 2):
        res = solve(_shuffled(req, seed)).result
        cuts2, P2 = _outcome(req, res)
        assert cuts2 == cuts and res.converged == ref.converged
        assert max(float(np.max(np.abs(P[cid] - P2[cid]))) for cid in P) < 1e-6  # mm


def test_impacts_within_the_snapped_residue_are_ties():
    req = straight_run_between_tie_ins()
    model = build_model(req)
    k = model.n_conn
    ang = np.zeros(k)
    gap = np.zeros(k)
    small, large = 1, 0  # connection 1 (P-0 to F-end) has the smaller key: ("F-end", 0) < ("F-start", 1)
    assert min(model.key[model.conn_a[small]], model.key[model.conn_b[small]]) < \
        min(model.key[model.conn_a[large]], model.key[model.conn_b[large]])
    for bump in (0.5, -0.5):  # either one larger by less than the solver can resolve
        gap[small], gap[large] = 5.0, 5.0 + bump * tie_width(model, 5.0)
        assert choose_cut(model, np.ones(k, dtype=bool), gap, ang) == small
    gap[large] = 5.0 + 2 * tie_width(model, 5.0)  # beyond it: the larger impact is cut
    assert choose_cut(model, np.ones(k, dtype=bool), gap, ang) == large


def test_shuffled_request_gives_the_bit_identical_result():
    # the solvers see every request in one canonical order (components by id, connections by their ends)
    req = grid_network(3, 3, valve_every=4, tie_ins=((0, 0),), seed=4, options={"method": "direct"})
    a = solve(req).result
    b = solve(_shuffled(req, 5)).result
    pa = {c.id: [p.position for p in c.ports] for c in a.components}
    pb = {c.id: [p.position for p in c.ports] for c in b.components}
    assert pa == pb
