"""A third round of mistakes with alignment requests: a tolerance in another unit than the request's, and the
answer of a PCF whose items come in another order."""

from __future__ import annotations

import random

import numpy as np
import pytest

from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.alignment.validation import check_input
from plantsolve.solvers.base import StoredInput
from tests.conftest import REPO

CONFLICT = REPO / "tests" / "solvers" / "alignment" / "data" / "e3d_plant_conflict.pcf"
PLANT3D = REPO / "tests" / "solvers" / "alignment" / "data" / "plant3d_cw_line.pcf"


def _solve(text: str, options: dict | None = None):
    request = parse_upload(StoredInput.from_bytes("line.pcf", text.encode()), options)
    check_input(request)
    return request, solve(request).result


@pytest.mark.parametrize("field", ["position_tolerance", "connection_tolerance"])
def test_a_tolerance_wider_than_the_pipe_is_named(field):
    # before: position_tolerance 1000 (a metre in this mm file) left gaps of 2.3 mm, said only "anchored"
    _, result = _solve(CONFLICT.read_text(), {field: 1000.0})
    warning = {w.code: w for w in result.report.warnings}["implausible_tolerance"]
    assert warning.details["field"] == field and warning.details["value"] == 1000.0
    assert f"options.{field} 1000 mm is more than the components' median outside radius" in warning.message
    _, plausible = _solve(CONFLICT.read_text(), {field: 1.0})
    assert "implausible_tolerance" not in {w.code for w in plausible.report.warnings}


def _by_geometry(request, result) -> dict:
    """The result's ports by the component's input ports: positional ids follow the items' order."""
    given = {c.id: tuple(sorted(tuple(np.round(p.position, 3)) for p in c.ports)) for c in request.components}
    return {given[c.id]: np.array(sorted(tuple(p.position) for p in c.ports)) for c in result.components}


def test_a_pcf_whose_items_come_in_another_order_is_aligned_the_same():
    lines = PLANT3D.read_text().splitlines()
    first = lines.index("FLANGE")  # the header's records before it, each item a keyword line and indented lines
    items: list[list[str]] = []
    for line in lines[first:]:
        if not line[:1].isspace():
            items.append([])
        items[-1].append(line)
    random.Random(3).shuffle(items)
    shuffled = "\n".join(lines[:first] + [line for item in items for line in item]) + "\n"
    before, after = _by_geometry(*_solve("\n".join(lines) + "\n")), _by_geometry(*_solve(shuffled))
    assert before.keys() == after.keys() and len(before) == 29
    assert max(np.abs(before[k] - after[k]).max() for k in before) == 0.0
