"""Alignment: a conflict between tie-ins is cut at the same connections in another unit, after a rigid motion of
the whole network and with every component renamed.

The eight connections on the path between the two tie-ins carry the same share of the conflict; which of them
looked largest on the first round's plateau was decided by round-off (0.978 to 1 of the largest in cm, 0.9996 to 1
in mm), so the cut moved with the unit, the frame and the names (2 to 5 mm of port movement). Among impacts equal
within the margin the connection measured worst in the request is cut now.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from plantsolve.schemas.alignment import AlignmentRequest
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins

MM_PER = {"mm": 1.0, "cm": 10.0}
# positions agree to round-off in another unit or with other names; after a rotation the flat twist modes of
# the grid's loops are only determined to about the square root of the closing residual (the tolerance of
# test_alignment_properties' rigid-motion test)
FLAT_MODES_MM = 2e-2


@pytest.fixture(scope="module")
def conflict() -> dict:
    # the second tie-in placed 40 mm and 2 degrees from where the 3 x 3 grid has it
    return conflicting_tie_ins(3, 3, seed=2, shift=(40.0, 0.0, 0.0), turn=2.0).model_dump(mode="json", by_alias=True)


def _answer(body: dict, names: dict[str, str] | None = None) -> tuple[set, dict]:
    """(cut connections as sets of (component, port) ends, port positions in mm), under the original names."""
    back = {new: old for old, new in (names or {}).items()}
    result = solve(AlignmentRequest.model_validate(body)).result
    mm = MM_PER[body["units"]]
    cuts = {frozenset({(back.get(c.from_[0], c.from_[0]), c.from_[1]), (back.get(c.to[0], c.to[0]), c.to[1])})
            for c in result.connections if c.cut}
    ports = {(back.get(c.id, c.id), k): np.array(p.position) * mm for c in result.components for k, p in enumerate(c.ports)}
    assert result.converged
    return cuts, ports


def _in_cm(body: dict) -> dict:
    return {**body, "units": "cm", "components": [
        {**c, "radius": c["radius"] / 10, "ports": [{**p, "position": [x / 10 for x in p["position"]]} for p in c["ports"]]}
        for c in body["components"]]}


def _renamed(body: dict) -> tuple[dict, dict[str, str]]:
    """``body`` with every component renamed so that the ids sort the other way round, and the renaming."""
    ids = sorted(c["id"] for c in body["components"])
    names = {old: f"z{len(ids) - k:03d}" for k, old in enumerate(ids)}
    return {**body, "components": [{**c, "id": names[c["id"]]} for c in body["components"]],
            "connections": [{"from": [names[c["from"][0]], c["from"][1]], "to": [names[c["to"][0]], c["to"][1]]}
                            for c in body["connections"]]}, names


def _largest_move(a: dict, b: dict) -> float:
    return max(float(np.linalg.norm(a[k] - b[k])) for k in a)


def test_a_conflict_is_cut_at_the_moved_tie_in_whatever_the_unit_frame_or_names(conflict):
    cuts, ports = _answer(conflict)
    # the known answer: the two connections of the moved tie-in, nothing at the other one
    assert cuts == {frozenset({("P10", 1), ("N2-2", 0)}), frozenset({("P12", 1), ("N2-2", 1)})}

    cm_cuts, cm_ports = _answer(_in_cm(conflict))
    assert cm_cuts == cuts and _largest_move(ports, cm_ports) < 1e-6  # mm

    renamed_cuts, renamed_ports = _answer(*_renamed(conflict))
    assert renamed_cuts == cuts and _largest_move(ports, renamed_ports) < 1e-6  # mm

    R, t = Rotation.from_rotvec([0.3, -0.2, 0.5]), np.array([125.0, -40.0, 9.0])
    moved = {**conflict, "components": [
        {**c, "ports": [{"position": (R.apply(p["position"]) + t).tolist(), "direction": R.apply(p["direction"]).tolist()}
                        for p in c["ports"]]} for c in conflict["components"]]}
    moved_cuts, moved_ports = _answer(moved)
    assert moved_cuts == cuts
    assert _largest_move(ports, {k: R.inv().apply(p - t) for k, p in moved_ports.items()}) < FLAT_MODES_MM


def test_a_conflict_whose_plateau_moves_with_the_names_is_cut_at_the_same_connections():
    conflict = conflicting_tie_ins(4, 2, seed=4, shift=(0.0, 0.0, 30.0), turn=1.0).model_dump(mode="json", by_alias=True)
    cuts, ports = _answer(conflict)
    renamed_cuts, renamed_ports = _answer(*_renamed(conflict))
    assert renamed_cuts == cuts and _largest_move(ports, renamed_ports) < 1e-6  # mm
