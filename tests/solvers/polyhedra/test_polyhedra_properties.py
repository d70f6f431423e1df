"""Invariance under rigid motions and reordering, and bad input refused naming the field."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError
from scipy.spatial.transform import Rotation

from tests.solvers.polyhedra.openstudio_cases import TILTED_ROOF, TILTED_ROOF_VOLUME, request
from plantsolve.schemas.polyhedra import PolyhedraRequest
from plantsolve.solvers.base import InputRejected
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.validation import check_input
from plantsolve.solvers.polyhedra import synthetic as shapes


def measures(body):
    result = solve(PolyhedraRequest.model_validate(body)).result
    zones = {z.id: (z.volume, z.surface_area, z.net_surface_area, z.closed, z.orientation, z.genus,
                    z.open_edge_count, z.t_junctions_repaired) for z in result.zones}
    faces = {f.id: (f.area, f.net_area, f.perimeter) for f in result.faces}
    return zones, faces, sorted((tuple(a.zones), a.area) for a in result.adjacency)


def _same(a, b):
    za, fa, aa = a
    zb, fb, ab = b
    assert za.keys() == zb.keys() and fa.keys() == fb.keys()
    for key in za:
        assert za[key][3:] == zb[key][3:]
        assert np.allclose(np.array(za[key][:3], dtype=float), np.array(zb[key][:3], dtype=float), rtol=1e-9, atol=1e-9,
                           equal_nan=True)
    for key in fa:
        assert fa[key] == pytest.approx(fb[key], rel=1e-9, abs=1e-9)
    assert [p for p, _ in aa] == [p for p, _ in ab] and [x for _, x in aa] == pytest.approx([x for _, x in ab])


def _move(body, rotation, shift):
    body = {**body}
    if body.get("vertices"):
        body["vertices"] = (rotation.apply(np.asarray(body["vertices"], dtype=float)) + shift).tolist()
    faces = []
    for f in body["faces"]:
        loops = [(rotation.apply(np.asarray(loop, dtype=float)) + shift).tolist() if isinstance(loop[0], list) else loop
                 for loop in f["loops"]]
        faces.append({**f, "loops": loops})
    body["faces"] = faces
    return body


CASES = {
    "gable": shapes.gable_house,
    "hole": shapes.block_with_hole,
    "two zones": shapes.two_zones_sharing_a_wall,
    "window": shapes.wall_with_window,
    "open box": shapes.open_box,
    "tilted roof": lambda: request(TILTED_ROOF),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_rigid_motions_change_nothing(name):
    body = CASES[name]()
    reference = measures(body)
    rng = np.random.default_rng(7)
    for _ in range(3):
        rotation = Rotation.random(random_state=rng)
        _same(reference, measures(_move(body, rotation, rng.uniform(-1e5, 1e5, 3))))


@pytest.mark.parametrize("name", sorted(CASES))
def test_face_order_loop_start_and_vertex_numbering_change_nothing(name):
    body = CASES[name]()
    reference = measures(body)
    rng = np.random.default_rng(11)
    faces = [dict(f) for f in body["faces"]]
    rng.shuffle(faces)
    for f in faces:  # start every loop at another vertex
        f["loops"] = [loop[k:] + loop[:k] for loop in f["loops"] for k in [int(rng.integers(len(loop)))]]
    shuffled = {**body, "faces": faces}
    if body.get("vertices"):
        perm = rng.permutation(len(body["vertices"]))
        inverse = np.argsort(perm)
        shuffled["vertices"] = [body["vertices"][i] for i in perm]
        shuffled["faces"] = [{**f, "loops": [[int(inverse[i]) for i in loop] if not isinstance(loop[0], list) else loop
                                             for loop in f["loops"]]} for f in faces]
    _same(reference, measures(shuffled))


def test_tilted_roof_volume_survives_merging_of_noisy_vertices():
    body = request(TILTED_ROOF)
    rng = np.random.default_rng(3)
    for f in body["faces"]:
        f["loops"] = [(np.asarray(f["loops"][0]) + rng.uniform(-2e-7, 2e-7, (len(f["loops"][0]), 3))).tolist()]
    result = solve(PolyhedraRequest.model_validate(body)).result
    assert result.zones[0].closed and result.zones[0].volume == pytest.approx(TILTED_ROOF_VOLUME, rel=1e-6)
    body["options"] = {"merge_tolerance": 1e-9}  # too tight for that noise: open edges, no volume
    result = solve(PolyhedraRequest.model_validate(body)).result
    assert not result.zones[0].closed and result.zones[0].volume is None


def _rejected(body):
    with pytest.raises(InputRejected) as error:
        check_input(PolyhedraRequest.model_validate(body))
    return error.value.errors


def test_bad_input_names_the_field():
    cube = shapes.unit_cube()
    bad = {**cube, "faces": [*cube["faces"][:5], {"id": "west", "loops": [[3, 0, 0]]}]}
    assert [e.loc for e in _rejected(bad)] == [("faces", 5, "loops", 0)]
    bad = {**cube, "faces": [*cube["faces"][:5], {"id": "west", "loops": [[3, 0, 4, 70]]}]}
    assert [e.loc for e in _rejected(bad)] == [("faces", 5, "loops", 0, 3)]
    bad = {**cube, "faces": [*cube["faces"], {"id": "w", "parent": "nowhere", "loops": [[0, 1, 2]]}]}
    (error,) = _rejected(bad)
    assert error.loc == ("faces", 6, "parent") and "nowhere" in error.msg
    bad = {**cube, "faces": [*cube["faces"], {**cube["faces"][0]}]}
    assert [e.loc for e in _rejected(bad)] == [("faces", 6, "id")]
    bad = {**cube, "faces": [{**cube["faces"][0], "zones": ["A", "A"]}, *cube["faces"][1:]]}
    assert [e.loc for e in _rejected(bad)] == [("faces", 0, "zones")]
    points = {"faces": [{"id": "p", "loops": [[[0, 0, 0], [1, 0, 0], [0, 0, 0]]]}]}
    assert [e.loc for e in _rejected(points)] == [("faces", 0, "loops", 0)]


def test_non_finite_and_out_of_bounds_numbers_are_refused_by_the_schema():
    cube = shapes.unit_cube()
    for value in (float("nan"), float("inf"), 1e13):
        body = {**cube, "vertices": [[value, 0, 0], *cube["vertices"][1:]]}
        with pytest.raises(ValidationError) as error:
            PolyhedraRequest.model_validate(body)
        assert error.value.errors()[0]["loc"][:2] == ("vertices", 0)


def test_a_loop_that_collapses_when_merging_is_refused_naming_the_face():
    body = {"faces": [{"id": "sliver", "loops": [[[0, 0, 0], [1, 0, 0], [1, 1e-9, 0]]]}]}
    with pytest.raises(InputRejected) as error:
        solve(PolyhedraRequest.model_validate(body))
    assert error.value.errors[0].loc == ("faces", 0, "loops", 0) and "sliver" in error.value.errors[0].msg


def test_a_collapsed_hole_is_removed_and_a_zone_of_collapsed_faces_has_no_volume():
    """A window narrower than merge_tolerance is no hole: the wall keeps its whole area, with a warning.
    A second zone whose only face collapses is reported without a volume, while the cube beside it
    keeps its volume (the request is refused only when no face is left to bound a zone)."""
    cube = shapes.unit_cube()
    west = cube["faces"][0]
    ring = [[0.4, 0.5, 0.5], [0.4 + 1e-9, 0.5, 0.5], [0.4, 0.5, 0.5 + 1e-9]]
    corners = [cube["vertices"][i] for i in west["loops"][0]]
    holed = {**cube, "faces": [{"id": west["id"], "loops": [corners, ring[::-1]]}, *cube["faces"][1:],
                               {"id": "sliver", "zones": ["B"], "loops": [[[5, 0, 0], [6, 0, 0], [6, 1e-9, 0]]]}]}
    plain = solve(PolyhedraRequest.model_validate(cube)).result
    result = solve(PolyhedraRequest.model_validate(holed)).result
    a, b = result.zones
    assert a.closed and a.volume == pytest.approx(plain.zones[0].volume, rel=1e-12)
    assert a.surface_area == pytest.approx(plain.zones[0].surface_area, rel=1e-12)
    assert b.id == "B" and not b.closed and b.volume is None and result.total_volume is None
    codes = {w.code: w.details for w in result.report.warnings}
    assert codes["collapsed_holes_skipped"]["faces"] == [west["id"]]
    assert codes["collapsed_faces_skipped"]["faces"] == ["sliver"] and codes["zone_without_faces"] == {"zone": "B"}
