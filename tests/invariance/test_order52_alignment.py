"""Alignment: a component's ports listed in another order, or a PCF pipe written from its other end, give the
bit-identical answer (the same ports at the same places, the same iterations, the same cuts).

A port's number says nothing of the physics, but the solvers saw the ports in the order listed: the shipped ladder
with its ports listed the other way took 151 Gauss-Newton steps instead of 155 and ended 5e-5 mm elsewhere, a 3 x 3
conflict grid 248 instead of 254.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.base import StoredInput

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "alignment"


def _ports_listed_otherwise(body: dict, seed: int) -> tuple[dict, dict[str, list[int]]]:
    """``body`` with the ports of every component of two or more listed in another order (connections renumbered),
    and per component the permutation: its new port k is its old port perm[k]."""
    rng = np.random.default_rng(seed)
    body, perms = copy.deepcopy(body), {}
    for c in body["components"]:
        n = len(c["ports"])
        if n >= 2:
            perm = list(rng.permutation(n))
            if perm == list(range(n)):
                perm = perm[::-1]
            c["ports"] = [c["ports"][k] for k in perm]
            perms[c["id"]] = perm
    new = {cid: {old: k for k, old in enumerate(p)} for cid, p in perms.items()}
    for conn in body["connections"]:
        for end in ("from", "to"):
            cid, k = conn[end]
            conn[end] = [cid, new.get(cid, {}).get(k, k)]
    return body, perms


def _answer(result, perms: dict[str, list[int]] | None = None) -> tuple:
    """(iterations, ports by (id, original port), cut connections by their original ends, max gap, max angle)."""
    perms = perms or {}

    def original(cid: str, k: int) -> tuple[str, int]:
        return cid, int(perms[cid][k]) if cid in perms else int(k)

    ports = {original(c.id, k): (tuple(p.position), tuple(p.direction)) for c in result.components
             for k, p in enumerate(c.ports)}
    cuts = {frozenset({original(*c.from_), original(*c.to)}) for c in result.connections if c.cut}
    return result.iterations, ports, cuts, result.max_position_error, result.max_angle_error


@pytest.mark.parametrize("name", ["ladder", "conflict"])
def test_ports_listed_in_another_order_give_the_same_bits(name):
    if name == "ladder":
        body = json.loads((EXAMPLES / "ladder.json").read_text())
    else:  # the second tie-in 40 mm and 2 degrees off: two cuts
        body = conflicting_tie_ins(3, 3, seed=2, shift=(40.0, 0.0, 0.0), turn=2.0).model_dump(mode="json",
                                                                                              by_alias=True)
    as_given = _answer(solve(AlignmentRequest.model_validate(body)).result)
    listed, perms = _ports_listed_otherwise(body, seed=5)
    again = _answer(solve(AlignmentRequest.model_validate(listed)).result, perms)
    assert again == as_given  # exact: iterations, every port's coordinates, the cuts
    if name == "conflict":
        assert len(as_given[2]) == 2


def test_a_pcf_pipe_written_from_its_other_end_gives_the_same_bits(tmp_path):
    text = (EXAMPLES / "ladder.pcf").read_text()
    blocks = text.split("\nPIPE\n")
    swapped = [blocks[0]]
    for block in blocks[1:]:  # a PIPE's two END-POINT lines in the other order
        lines = block.split("\n")
        ends = [i for i, line in enumerate(lines) if line.strip().startswith("END-POINT")]
        lines[ends[0]], lines[ends[1]] = lines[ends[1]], lines[ends[0]]
        swapped.append("\n".join(lines))
    assert len(swapped) > 4

    def solved(content: str):
        path = tmp_path / "ladder.pcf"
        path.write_text(content)
        return solve(parse_upload(StoredInput.from_path(path), {"fixed_components": ["N0-0"]})).result

    as_written = solved(text)
    pipes = {c.id: [1, 0] for c in as_written.components if c.id.startswith("P")}
    assert _answer(solved("\nPIPE\n".join(swapped)), pipes) == _answer(as_written)
