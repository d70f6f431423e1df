"""Alignment: a conflict whose candidate cuts are measured exactly alike (a symmetric run between two tie-ins, a
tee feeding two such runs) is cut at the same connections however the network is written: components and
connections in another order, ports listed otherwise, every id renamed, a PCF's blocks shuffled.

Where the measured impacts tie, the smaller (component id, port) end decided: the same network renamed was cut at
the other end of its run (8 mm of port movement in JSON, 6 mm in a PCF). Where the ends lie decides now
(``Model.port_rank``: distance from the network's middle, then position and direction as written).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.cuts import error_impact
from plantsolve.solvers.alignment.model import build_model
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput

ORIGIN = np.array([1.0e6, 2.0e5, 1.0e4])  # plant coordinates, mm


def _port(p, d) -> dict:
    return {"position": [float(v) for v in ORIGIN + p], "direction": [float(v) for v in d]}


def _straight_run(rise: float = 8.0) -> dict:
    """Fixed flange, pipe, fixed flange along x; the far flange ``rise`` mm high and the pipe half as high: both
    connections measure the same gap, and one cut lets the pipe close either one."""
    flange = lambda cid, x0, z: {"id": cid, "kind": "fitting", "type": "flange", "fixed": True, "radius": 50.0,
                                 "ports": [_port([x0, 0, z], [-1, 0, 0]), _port([x0 + 100, 0, z], [1, 0, 0])]}
    pipe = {"id": "P", "kind": "pipe", "radius": 50.0,
            "ports": [_port([0, 0, rise / 2], [-1, 0, 0]), _port([6000, 0, rise / 2], [1, 0, 0])]}
    return {"units": "mm", "components": [flange("FA", -100, 0.0), pipe, flange("FB", 6000, rise)],
            "connections": [{"from": ["FA", 1], "to": ["P", 0]}, {"from": ["P", 1], "to": ["FB", 0]}],
            "options": {"method": "direct"}}


def _renamed(body: dict, names: dict[str, str]) -> dict:
    out = copy.deepcopy(body)
    for c in out["components"]:
        c["id"] = names[c["id"]]
    for c in out["connections"]:
        c["from"][0], c["to"][0] = names[c["from"][0]], names[c["to"][0]]
    return out


def _written_otherwise(body: dict) -> dict:
    """Components and connections reversed, every connection named from its other end, every port list reversed."""
    out = copy.deepcopy(body)
    out["components"] = out["components"][::-1]
    for c in out["components"]:
        c["ports"] = c["ports"][::-1]
    count = {c["id"]: len(c["ports"]) for c in out["components"]}
    out["connections"] = [{"from": [c["to"][0], count[c["to"][0]] - 1 - c["to"][1]],
                           "to": [c["from"][0], count[c["from"][0]] - 1 - c["from"][1]]}
                          for c in out["connections"][::-1]]
    return out


def _answer(request: AlignmentRequest) -> tuple[frozenset, dict]:
    """(the cut connections and every port's result position, each port named by where the request has it)."""
    result = solve(request).result
    assert result.converged
    at = {(c.id, k): tuple(p.position) for c in request.components for k, p in enumerate(c.ports)}
    cuts = frozenset(frozenset({at[tuple(c.from_)], at[tuple(c.to)]}) for c in result.connections if c.cut)
    ports = {at[(c.id, k)]: np.array(p.position) for c in result.components for k, p in enumerate(c.ports)}
    return cuts, ports


def test_a_symmetric_run_is_cut_at_the_same_end_however_it_is_written_or_named():
    body = _straight_run()
    model = build_model(AlignmentRequest.model_validate(body))
    measured = error_impact(model, *model.measured_errors)
    assert measured[0] == measured[1] == pytest.approx(4.0)  # an exact tie: the tie-break decides
    cuts, ports = _answer(AlignmentRequest.model_validate(body))
    assert len(cuts) == 1
    for names in ({"FA": "z", "P": "y", "FB": "x"}, {"FA": "FB", "P": "P", "FB": "FA"}):
        for variant in (_renamed(body, names), _written_otherwise(_renamed(body, names))):
            again_cuts, again = _answer(AlignmentRequest.model_validate(variant))
            assert again_cuts == cuts
            assert max(float(np.linalg.norm(again[k] - ports[k])) for k in ports) < 1e-9  # mm


TEE_PCF = """ISOGEN-FILES ISOGEN.FLS
UNITS-BORE MM
UNITS-CO-ORDS MM
PIPELINE-REFERENCE 100-CW-1
    PIPING-SPEC A1
"""


def _tee_pcf(names: dict[str, str]) -> tuple[list[str], str]:
    """(the item blocks, the header) of a fixed tee feeding two pipes to two fixed flanges, each flange 6 mm high and
    each pipe 3 mm: a tie in each run."""
    def points(kw, *pts):
        return [f"    {kw} " + " ".join(f"{v:.4f}" for v in ORIGIN + p) + (" 100.0000" if kw != "CENTRE-POINT" else "")
                for p in pts]

    blocks = [["TEE", f"    COMPONENT-IDENTIFIER {names['T']}", *points("END-POINT", [150, 0, 0], [-150, 0, 0]),
               *points("CENTRE-POINT", [0, 0, 0]), *points("BRANCH1-POINT", [0, -150, 0])]]
    for side, s in (("R", 1), ("L", -1)):
        blocks.append(["PIPE", f"    COMPONENT-IDENTIFIER {names[side + 'P']}",
                       *points("END-POINT", [s * 150, 0, 3], [s * 4000, 0, 3])])
        blocks.append(["FLANGE", f"    COMPONENT-IDENTIFIER {names[side + 'F']}",
                       *points("END-POINT", [s * 4000, 0, 6], [s * 4100, 0, 6])])
    return ["\n".join(b) + "\n" for b in blocks], TEE_PCF


def _pcf_answer(blocks: list[str], head: str, names: dict[str, str]) -> tuple[frozenset, dict]:
    source = StoredInput.from_bytes("tee.pcf", (head + "".join(blocks)).encode())
    return _answer(parse_upload(source, {"fixed_components": [names["T"], names["RF"], names["LF"]]}))


def test_a_pcf_of_two_tied_runs_is_cut_alike_with_its_blocks_shuffled_or_its_ids_renamed():
    names = {k: k for k in ("T", "RP", "RF", "LP", "LF")}
    blocks, head = _tee_pcf(names)
    cuts, ports = _pcf_answer(blocks, head, names)
    assert len(cuts) == 2
    # one cut in each run, at its end nearer the network's middle (the tee's, both sides alike): where the ends lie
    ends_x = sorted(round(min(p[0] for p in cut) - ORIGIN[0]) for cut in cuts)
    assert ends_x == [-150, 150]
    rng = np.random.default_rng(3)
    for names in ({"T": "T", "RP": "A", "RF": "B", "LP": "C", "LF": "D"},
                  {"T": "a", "RP": "b", "RF": "c", "LP": "d", "LF": "e"}):  # the names sort the other way round
        blocks, head = _tee_pcf(names)
        shuffled = [blocks[i] for i in rng.permutation(len(blocks))]
        again_cuts, again = _pcf_answer(shuffled, head, names)
        assert again_cuts == cuts
        assert max(float(np.linalg.norm(again[k] - ports[k])) for k in ports) < 1e-9  # mm
