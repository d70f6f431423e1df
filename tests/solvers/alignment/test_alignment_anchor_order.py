"""The component held still in a network without a fixed one does not depend on the names or order it is given in."""

import numpy as np
import pytest

from alignment_cases import conn, pipe, port, request
from plantsolve.solvers.alignment.solve import solve


def _flange(cid, a, b):
    u = (np.asarray(b, float) - np.asarray(a, float)) / np.linalg.norm(np.asarray(b, float) - np.asarray(a, float))
    return {"id": cid, "kind": "fitting", "type": "flange", "ports": [port(a, -u), port(b, u)]}


def _run(left: str, right: str, reverse: bool):
    # two end flanges alike, a pipe between them scanned 3 mm short and 0.5 degrees turned: whichever flange is
    # held, the other moves, so the answer differs by which one is held
    comps = [_flange(left, [0, 0, 0], [20, 0, 0]), pipe("P", [23, 0, 0], [1020, 8.7, 0]),
             _flange(right, [1020, 0, 0], [1040, 0, 0])]
    conns = [conn(left, 1, "P", 0), conn("P", 1, right, 0)]
    if reverse:
        comps, conns = comps[::-1], conns[::-1]
    result = solve(request(comps, conns)).result
    held = next(w for w in result.report.warnings if w.code == "anchored").details["anchors"]
    ports = {c.id: [p.position for p in c.ports] for c in result.components}
    return held, [ports[left], ports["P"], ports[right]]


@pytest.mark.parametrize("reverse", [False, True])
def test_end_flanges_alike_hold_the_one_that_lies_lowest_whatever_their_names_and_order(reverse):
    held_ab, ab = _run("FLANGE-1", "FLANGE-2", reverse=False)
    held_ba, ba = _run("FLANGE-2", "FLANGE-1", reverse=reverse)
    assert [h["id"] for h in held_ab] == ["FLANGE-1"] and [h["id"] for h in held_ba] == ["FLANGE-2"]
    assert ab[0] == [[0.0, 0.0, 0.0], [20.0, 0.0, 0.0]] and ba[0] == ab[0]  # the flange at the origin, by position
    assert np.max(np.abs(np.array(ab[1]) - np.array(ba[1]))) < 1e-9
    assert np.max(np.abs(np.array(ab[2]) - np.array(ba[2]))) < 1e-9
