"""Mistakes of the third probe: a zone's faces exported twice closed and gave twice the volume, with only a
non-manifold-edge count to say something was off; a hole outside its face was subtracted from the face's area."""

from __future__ import annotations

import pytest

from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

VERTICES = [(0, 0, 0), (5, 0, 0), (5, 4, 0), (0, 4, 0), (0, 0, 3), (5, 0, 3), (5, 4, 3), (0, 4, 3)]
FACES = [(1, 4, 3, 2), (5, 6, 7, 8), (1, 2, 6, 5), (2, 3, 7, 6), (3, 4, 8, 7), (4, 1, 5, 8)]  # outward


def _room(faces) -> str:
    return ("g room\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in VERTICES)
            + "".join("f " + " ".join(map(str, f)) + "\n" for f in faces))


def _solved(text: str):
    return solve(parse_upload(StoredInput.from_bytes("room.obj", text.encode()), {})).result


def test_a_room_whose_faces_are_listed_twice_gets_no_volume_and_a_warning_naming_the_copies():
    (zone,) = _solved(_room(FACES + FACES)).zones
    assert zone.volume is None  # was 120 m³ for a 60 m³ room
    (warning,) = [w for w in _solved(_room(FACES + FACES)).report.warnings if w.code == "duplicate_faces"]
    assert warning.details["zone"] == "room" and warning.details["count"] == 6
    assert ["f7", "f1"] in warning.details["faces"] and "'f7' = 'f1'" in warning.message


def test_the_room_once_and_a_membrane_face_and_its_reverse_keep_their_volume():
    (zone,) = _solved(_room(FACES)).zones
    assert zone.volume == 60.0
    # a face and its reverse cancel in the divergence sum: not a double count
    membrane = _room(FACES) + "v 0 2 0\nv 5 2 0\nv 5 2 3\nv 0 2 3\nf 9 10 11 12\nf 12 11 10 9\n"
    result = _solved(membrane)
    assert not [w for w in result.report.warnings if w.code == "duplicate_faces"]


# ---------------------------------------------------------------- holes outside their face

def _floor_with(hole: list) -> dict:
    from plantsolve.solvers.polyhedra import synthetic
    body = synthetic.gable_house(8.0, 10.0)
    body["faces"][0]["loops"].append(hole)
    return body


@pytest.mark.parametrize("hole, vertex", [
    ([[-1, -1, 0], [9, -1, 0], [9, 11, 0], [-1, 11, 0]], [-1.0, -1.0, 0.0]),  # larger than the floor: was area -40
    ([[2, 2, 0], [3, 2, 0], [3, 3, 0], [20, 20, 0]], [20.0, 20.0, 0.0]),  # one vertex beside it
])
def test_a_hole_outside_its_face_is_refused_naming_the_loop_and_the_vertex(hole, vertex):
    body = _floor_with(hole)
    assert body["faces"][0]["id"] == "floor"
    with pytest.raises(InputRejected) as refused:
        check_input(PolyhedraRequest.model_validate(body))
    (error,) = refused.value.errors
    assert error.loc[:4] == ("faces", 0, "loops", 1) and str(vertex) in error.msg and "'floor'" in error.msg


def test_a_hole_inside_or_touching_its_face_is_subtracted():
    from plantsolve.solvers.polyhedra import synthetic
    block = PolyhedraRequest.model_validate(synthetic.block_with_hole())
    check_input(block)  # a shaft through a block: its holes lie inside
    touching = _floor_with([[0, 2, 0], [2, 2, 0], [2, 4, 0], [0, 4, 0]])  # a notch on the floor's west edge
    request = PolyhedraRequest.model_validate(touching)
    check_input(request)
    floor = next(f for f in solve(request).result.faces if f.id == "floor")
    assert floor.area == pytest.approx(80.0 - 4.0, rel=1e-12)
