"""Large meshes: a mesh given as arrays answers as the same triangles given as faces; the edges are grouped
once and shared; equal vertices are merged by hashing; results list faces, and zones.csv has a row per face, up
to 10,000 faces or as the options say (each independently); the bulk CSV writer and the sort helpers agree with
their slow references."""

from __future__ import annotations

import csv
import importlib
import io
import json

import numpy as np
import pytest
from pydantic import ValidationError
import trimesh

from plantsolve.schemas.polyhedra import MAX_VERTICES, PolyhedraRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra import artifacts, bulk_csv
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input
from plantsolve.solvers.polyhedra import synthetic as shapes
from plantsolve.solvers.polyhedra.polygons import from_mesh, from_request
from plantsolve.solvers.polyhedra.repair import merge_vertices

repair = importlib.import_module("plantsolve.solvers.polyhedra.repair")
from plantsolve.solvers.polyhedra.solve import analyse
from plantsolve.solvers.polyhedra.sorting import counts_of, dense_labels, distinct, stable_order

solve_module = importlib.import_module("plantsolve.solvers.polyhedra.solve")
TORUS_VOLUME = 2 * np.pi ** 2 * 3.0 * 1.0 ** 2  # 2π²Rr², approached from below by the inscribed mesh


def torus_body(n_major=40, n_minor=12, as_mesh=True):
    vertices, triangles = shapes.torus_mesh(n_major, n_minor)
    if as_mesh:
        return {"mesh": {"zone": "ring", "vertices": vertices.tolist(), "triangles": triangles.tolist()}}
    return {"vertices": vertices.tolist(),
            "faces": [{"id": f"t{k + 1}", "loops": [t], "zones": ["ring"]} for k, t in enumerate(triangles.tolist())]}


def test_a_mesh_answers_as_the_same_triangles_given_as_faces():
    as_mesh = solve(PolyhedraRequest.model_validate(torus_body())).result
    as_faces = solve(PolyhedraRequest.model_validate(torus_body(as_mesh=False))).result
    assert as_mesh.model_dump() == as_faces.model_dump()  # ids t1, t2, … and every number
    (zone,) = as_mesh.zones
    assert zone.closed and zone.genus == 1 and zone.euler_characteristic == 0 and zone.face_count == 960
    assert 0.95 * TORUS_VOLUME < zone.volume < TORUS_VOLUME


def test_a_mesh_in_a_json_body_is_checked_naming_the_field():
    body = torus_body(6, 4)
    request = PolyhedraRequest.model_validate_json(json.dumps(body), strict=True)
    assert request.mesh.triangles.shape == (48, 3) and request.mesh.triangles.dtype == np.int64
    bad = json.loads(json.dumps(body))
    bad["mesh"]["triangles"][5][2] = 24
    with pytest.raises(InputRejected) as error:
        check_input(PolyhedraRequest.model_validate(bad))
    assert error.value.errors[0].loc == ("mesh", "triangles", 5, 2)
    bad["mesh"]["triangles"][5] = [1, 1, 2]
    with pytest.raises(InputRejected) as error:
        check_input(PolyhedraRequest.model_validate(bad))
    assert error.value.errors[0].loc == ("mesh", "triangles", 5)
    clash = {**body, "faces": [{"id": "t3", "loops": [[0, 1, 2]], "zones": ["other"]}]}
    with pytest.raises(InputRejected, match="triangle 3"):
        check_input(PolyhedraRequest.model_validate(clash))
    with pytest.raises(InputRejected, match="no face"):
        check_input(PolyhedraRequest.model_validate({}))
    for broken in ({"vertices": [[0, 0, True]], "triangles": [[0, 1, 2]]},
                   {"vertices": [[0, 0, float("nan")]] * 3, "triangles": [[0, 1, 2]]}):
        with pytest.raises(Exception) as error:
            PolyhedraRequest.model_validate({"mesh": broken})
        assert error.value.errors()[0]["loc"][:2] == ("mesh", "vertices")


def test_the_mesh_json_schema_states_every_bound_the_validator_holds():
    # a schema-valid mesh is refused only for what no JSON Schema can say (an index past the vertices)
    schema = PolyhedraRequest.model_json_schema(mode="validation")["$defs"]["TriangleMesh"]["properties"]
    vertices, triangles = schema["vertices"], schema["triangles"]
    assert vertices["minItems"] == 3 and vertices["items"]["items"] == {"type": "number", "minimum": -1e12,
                                                                        "maximum": 1e12}
    assert triangles["minItems"] == 1 and triangles["items"]["items"]["maximum"] == MAX_VERTICES - 1
    for broken in ({"vertices": [[0, 0, 1.0000001e12], [0, 1, 0], [1, 0, 0]], "triangles": [[0, 1, 2]]},
                   {"vertices": [[0, 0, 0], [0, 1, 0]], "triangles": [[0, 1, 1]]},
                   {"vertices": [[0, 0, 0], [0, 1, 0], [1, 0, 0]], "triangles": []}):
        with pytest.raises(ValidationError):
            PolyhedraRequest.model_validate({"mesh": broken})
    PolyhedraRequest.model_validate({"mesh": {"vertices": [[0, 0, -1e12], [0, 1, 0], [1, 0, 0]], "triangles": [[0, 1, 2]]}})


def test_faces_given_with_a_mesh_come_first_and_keep_their_names():
    body = {**torus_body(8, 6), **{k: v for k, v in shapes.unit_cube(offset=(10.0, 0.0, 0.0)).items() if k != "options"}}
    result = solve(PolyhedraRequest.model_validate(body)).result
    zones = {z.id: z for z in result.zones}
    assert zones["default"].volume == pytest.approx(1.0) and zones["ring"].closed and zones["ring"].genus == 1
    assert [f.id for f in result.faces[:6]] == shapes.CUBE_NAMES and result.faces[6].id == "t1"


def test_the_edges_are_sorted_once_and_shared_by_repair_the_map_and_the_diagnostics():
    vertices, triangles = shapes.torus_mesh(30, 10)
    an = analyse(from_mesh(vertices, triangles))
    assert an.gmap.groups is an.poly.edge_groups and an.poly.edge_groups.edge_manifold
    assert an.repairs.t_junctions_per_zone.tolist() == [0]
    # the grouping against a plain np.unique of (zone, lo, hi), on an open, non-manifold mesh
    rng = np.random.default_rng(3)
    tri = rng.integers(0, 40, size=(300, 3))
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])]
    poly = from_mesh(rng.normal(size=(40, 3)), tri)
    groups = poly.edge_groups
    a, b = tri.reshape(-1), tri[:, [1, 2, 0]].reshape(-1)
    _, reference = np.unique(np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1), axis=0, return_counts=True)
    assert sorted(groups.counts.tolist()) == sorted(reference.tolist())
    assert (np.diff(groups.group()[groups.order]) >= 0).all()
    first = groups.order[groups.starts]  # each group's edge, kept once per group
    assert (groups.lo == np.minimum(a, b)[first]).all() and (groups.hi == np.maximum(a, b)[first]).all()


def test_an_unwelded_mesh_merges_by_hashing_to_the_welded_answer():
    vertices, triangles = shapes.torus_mesh(24, 8)
    soup = vertices[triangles].reshape(-1, 3)  # every triangle its own three vertices, as an STL stores them
    soup[np.isclose(soup, 0.0)] = -0.0  # a negative zero is the same coordinate
    welded = analyse(from_mesh(vertices, triangles))
    for tolerance in (0.0, 1e-6):
        poly, merged = merge_vertices(from_mesh(soup, np.arange(len(soup)).reshape(-1, 3)), tolerance)
        assert merged == len(soup) - len(vertices)
        an = analyse(poly, tolerance)
        assert an.terms.flux.sum() == pytest.approx(welded.terms.flux.sum(), rel=1e-12)
        assert an.topology.euler.tolist() == [0] and len(an.topology.open_groups) == 0


def test_rows_whose_hashes_collide_are_told_apart(monkeypatch):
    rng = np.random.default_rng(5)
    pts = rng.integers(0, 3, size=(200, 3)).astype(float)
    monkeypatch.setattr(repair, "HASH", (np.uint64(0),) * 3)  # every row the same hash: the rows are sorted instead
    label, first = repair.exact_labels(pts)
    _, reference = np.unique(pts, axis=0, return_inverse=True)
    same = label[:, None] == label[None, :]
    assert np.array_equal(same, reference.reshape(-1)[:, None] == reference.reshape(-1)[None, :])
    assert np.array_equal(np.sort(first), np.sort(np.unique(reference.reshape(-1), return_index=True)[1]))


def test_a_binary_stl_is_read_into_a_mesh_with_its_bad_facets_skipped():
    vertices, triangles = shapes.torus_mesh(20, 8)
    content = bytearray(trimesh.exchange.stl.export_stl(trimesh.Trimesh(vertices, triangles, process=False)))
    # facet 3's first vertex not a number: skipped, named; the rest still reads
    content[84 + 2 * 50 + 12:84 + 2 * 50 + 16] = np.float32("nan").tobytes()
    request = parse_upload(StoredInput.from_bytes("ring.stl", bytes(content)), None)
    assert request.mesh.triangles.shape == (len(triangles) - 1, 3) and request.source["skipped"][0]["object"] == "facet 3"
    assert len(request.mesh.vertices) == 3 * (len(triangles) - 1)  # the skipped facet's vertices are gone
    (zone,) = solve(request).result.zones
    assert not zone.closed and zone.open_edge_count == 3


def test_a_binary_stl_facet_beyond_the_coordinate_bound_is_skipped_not_the_whole_file():
    vertices, triangles = shapes.torus_mesh(20, 8)
    content = bytearray(trimesh.exchange.stl.export_stl(trimesh.Trimesh(vertices, triangles, process=False)))
    content[84 + 4 * 50 + 20:84 + 4 * 50 + 24] = np.float32(3e20).tobytes()  # facet 5's first vertex, its y
    request = parse_upload(StoredInput.from_bytes("ring.stl", bytes(content)), None)
    assert request.mesh.triangles.shape == (len(triangles) - 1, 3)
    assert request.source["skipped"] == [{"object": "facet 5", "reason": "non-finite, beyond 1e+12 or repeated vertex"}]
    # random bytes (a cut binary STL whose triangles are mostly unreadable): test_polyhedra_uploads refuses them


def test_a_zero_area_stl_facet_with_a_repeated_corner_is_skipped_and_the_mesh_stays_closed():
    vertices, triangles = shapes.torus_mesh(20, 8)
    corners = vertices[triangles]
    sliver = np.array([[corners[0, 0], corners[0, 0], corners[0, 1]]])  # as exporters write degenerate facets
    both = np.concatenate([corners, sliver]).reshape(-1, 3)
    content = trimesh.exchange.stl.export_stl(trimesh.Trimesh(both, np.arange(len(both)).reshape(-1, 3), process=False))
    request = parse_upload(StoredInput.from_bytes("ring.stl", content), None)
    assert request.source["skipped"] == [{"object": f"facet {len(triangles) + 1}",
                                          "reason": "non-finite, beyond 1e+12 or repeated vertex"}]
    check_input(request)
    (zone,) = solve(request).result.zones
    welded = trimesh.Trimesh(vertices, triangles)
    assert zone.closed and zone.volume == pytest.approx(welded.volume, rel=1e-6)


def test_faces_are_listed_only_when_asked_but_zones_csv_has_every_face(monkeypatch):
    body = shapes.inside_out_cube()
    listed = solve(PolyhedraRequest.model_validate(body)).result
    quiet = solve(PolyhedraRequest.model_validate({**body, "options": {"list_faces": False}}))
    (zone,) = quiet.result.zones
    assert quiet.result.faces == [] and not quiet.result.faces_listed and zone.faces == [] and zone.face_count == 6
    assert zone.misoriented_face_count == 6 and sorted(zone.misoriented_faces) == sorted(shapes.CUBE_NAMES)
    assert zone.volume == listed.zones[0].volume and listed.faces_listed and len(listed.faces) == 6
    request = PolyhedraRequest.model_validate(body)
    quiet_csv = _csv(artifacts.render_artifacts(request, quiet))
    listed_csv = _csv(artifacts.render_artifacts(request, solve(request)))
    assert quiet_csv == listed_csv and sum(row[0] == "face" for row in quiet_csv) == 6
    # above MAX_LISTED_FACES faces the default is not to list them, in the result nor in zones.csv
    monkeypatch.setattr(solve_module, "MAX_LISTED_FACES", 5)
    big = solve(request)
    assert big.result.faces == [] and solve_module.FACE_TABLE not in big.files
    assert _csv(artifacts.render_artifacts(request, big)) == [row for row in listed_csv if row[0] != "face"]
    assert len(solve(PolyhedraRequest.model_validate({**body, "options": {"list_faces": True}})).result.faces) == 6


@pytest.mark.parametrize(("options", "listed", "rows"), [
    ({"faces_csv": True}, False, 6), ({"faces_csv": False, "list_faces": True}, True, 0), ({}, False, 0)])
def test_the_face_rows_of_zones_csv_are_written_when_asked_whatever_the_result_lists(monkeypatch, options, listed,
                                                                                       rows):
    monkeypatch.setattr(solve_module, "MAX_LISTED_FACES", 5)  # the cube's 6 faces count as a large request
    request = PolyhedraRequest.model_validate({**shapes.inside_out_cube(), "options": options})
    solved = solve(request)
    table = _csv(artifacts.render_artifacts(request, solved))
    assert solved.result.faces_listed is listed and sum(row[0] == "face" for row in table) == rows
    assert [row[0] for row in table[:2]] == ["record", "zone"] and float(table[1][4]) == pytest.approx(1.0)
    if rows:  # the areas of a unit cube's faces, each once
        assert sorted(row[1] for row in table[2:]) == sorted(shapes.CUBE_NAMES)
        assert [float(row[6]) for row in table[2:]] == pytest.approx([1.0] * 6)


def _csv(artifact_list):
    (table,) = [a for a in artifact_list if a.name == "zones.csv"]
    return list(csv.reader(io.StringIO(table.data.decode())))


def test_the_bulk_face_rows_match_the_repr_rows(monkeypatch):
    body = shapes.wall_with_window()
    body["faces"] = [{**f, "id": f["id"] + ', "quoted"'} if f.get("parent") is None else
                     {**f, "parent": f["parent"] + ', "quoted"'} for f in body["faces"]]
    body.update({k: v for k, v in torus_body(10, 6).items()})
    request = PolyhedraRequest.model_validate(body)
    solved = solve(request)
    poly, table = from_request(request), np.load(io.BytesIO(solved.files[solve_module.FACE_TABLE]))
    slow = list(csv.reader(io.StringIO(artifacts._table(solved.result, poly, table).decode())))
    monkeypatch.setattr(artifacts, "MAX_LISTED_FACES", 3)
    fast = list(csv.reader(io.StringIO(artifacts._table(solved.result, poly, table).decode())))
    assert len(fast) == len(slow) > 120
    for a, b in zip(fast, slow):
        assert len(a) == len(b) and a[:6] == b[:6]  # record, id (quoted), zones, parent, blanks
        for x, y in zip(a[6:], b[6:]):
            assert x == y or float(x) == pytest.approx(float(y), rel=5e-16, abs=0)


def test_bulk_numbers_read_back_within_a_few_units_in_the_last_place():
    rng = np.random.default_rng(7)
    x = np.r_[rng.normal(size=5000) * 10.0 ** rng.integers(-300, 300, 5000),
              [0.0, -0.0, 1.0, -2.5, 0.1, 1e-5, 123456789.0, 5e-324, 1.7976931348623157e308, 1e22, 9.999999999999999e22]]
    text = bulk_csv.rows([bulk_csv.number_cells(x), bulk_csv.literal("\n", len(x))]).decode().splitlines()
    back = np.array([float(v) for v in text])
    assert np.all(np.abs(back - x) <= 5e-16 * np.abs(x))
    assert text[-11:-4] == ["0.0e+00", "0.0e+00", "1.0e+00", "-2.5e+00", "1.0e-01", "1.0e-05", "1.23456789e+08"]
    ids = bulk_csv.rows([bulk_csv.numbered_cells("t", 9998, 4), bulk_csv.literal(",", 4)]).decode()
    assert ids == "t9998,t9999,t10000,t10001,"


def test_the_sort_helpers_agree_with_numpy_unique():
    rng = np.random.default_rng(11)
    for bound in (50, 10 ** 12):
        key = rng.integers(0, bound, size=3000)
        assert np.array_equal(key[stable_order(key, bound)], np.sort(key, kind="stable"))
        assert np.array_equal(stable_order(key, bound), np.argsort(key, kind="stable"))
        values, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
        assert np.array_equal(distinct(key, bound), values) and np.array_equal(dense_labels(key, bound), inverse)
        got_values, got_counts = counts_of(key, bound)
        assert np.array_equal(got_values, values) and np.array_equal(got_counts, counts)


def test_the_request_is_read_once_into_flat_arrays_with_lazy_names():
    poly = from_request(PolyhedraRequest.model_validate(torus_body(6, 4)))
    assert len(poly.face_ids) == 48 and poly.face_ids[0] == "t1" and poly.face_ids[-1] == "t48"
    assert list(poly.face_ids)[:3] == ["t1", "t2", "t3"] and poly.face_ids[1:3] == ["t2", "t3"]


def test_an_stl_edge_split_within_the_merge_tolerance_closes_with_its_slivers_named():
    """An exporter split one edge with a vertex 5e-7 from its end (apart in float32, within the default
    merge tolerance of 1e-6): after merging, the two triangles on
    the short part have two distinct corners. They are kept with no area and bound nothing (a warning
    names them); the torus closes with its volume, where the job used to fail at stage 'input'."""
    vertices, triangles = shapes.torus_mesh(20, 8)
    p, q, r = triangles[0]
    (s,) = [t[np.flatnonzero((t != p) & (t != q))[0]] for t in triangles[1:] if {p, q} <= set(t)]
    m = len(vertices)
    step = (vertices[p] - vertices[q]) / np.linalg.norm(vertices[p] - vertices[q])
    vertices = np.vstack([vertices, vertices[q] + 5e-7 * step])
    split = [[p, m, r], [m, q, r], [q, m, s], [m, p, s]]
    rest = [t for t in triangles[1:] if not {p, q} <= set(t)]
    corners = vertices[np.array(rest + split)].reshape(-1, 3)
    content = trimesh.exchange.stl.export_stl(trimesh.Trimesh(corners, np.arange(len(corners)).reshape(-1, 3),
                                                              process=False))
    request = parse_upload(StoredInput.from_bytes("ring.stl", content), None)
    check_input(request)
    result = solve(request).result
    (zone,) = result.zones
    welded = trimesh.Trimesh(*shapes.torus_mesh(20, 8))
    assert zone.closed and zone.open_edge_count == 0 and zone.volume == pytest.approx(welded.volume, rel=1e-6)  # float32 corners
    (warning,) = [w for w in result.report.warnings if w.code == "collapsed_faces_skipped"]
    assert warning.details["count"] == 2 and warning.details["faces"] == [f"t{len(rest) + 2}", f"t{len(rest) + 3}"]
    assert result.report.details["collapsed_faces"] == 2 and zone.face_count == len(rest) + 2
