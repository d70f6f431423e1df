"""The faceted items read from the file's text (``skeleton``) against IfcOpenShell reading the whole file: the
same points in the same order, closures and counts, and the same optimized file byte for byte, on clean models and
on files the scan must leave (in part or whole) to IfcOpenShell."""

from __future__ import annotations

import re
from collections import Counter

import numpy as np
import pytest

import ifcopenshell

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.dedup import SPEC, ifcio, skeleton, synthetic
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.upload import parse_upload


def _text(rings: int = 3, face_set: str = "surface_model", schema: str = "IFC4", arcs: int = 4, **kw) -> str:
    return synthetic.build_model(synthetic.tunnel_spec(rings, schema, face_set=face_set, arcs=arcs, **kw)).to_string()


def _solved(text: str, **options):
    source = StoredInput.from_bytes("m.ifc", text.encode())
    value = SPEC.input_of(parse_upload(source, options), source)
    return solve(value)


def _both(monkeypatch, text: str, **options):
    """The solve as it is, and with the scan refusing every file (the whole file parsed, as before the scan), and
    how often the first parsed the whole file after all."""
    parses = []
    with monkeypatch.context() as m:
        m.setattr(ifcio, "open_path", lambda *a, _o=ifcio.open_path: parses.append(a) or _o(*a))
        streamed = _solved(text, **options)
    with monkeypatch.context() as m:
        m.setattr(skeleton, "read", lambda *a, **k: None)
        whole = _solved(text, **options)
    return streamed, whole, len(parses)


def _same(streamed, whole) -> None:
    a, b = streamed.result, whole.result
    assert streamed.files.get("optimized.ifc") == whole.files.get("optimized.ifc")
    assert a.entity_counts_before == b.entity_counts_before and a.entity_counts_after == b.entity_counts_after
    assert (a.products_shared, len(a.classes), a.verification.max_deviation, a.optimized_bytes) == \
           (b.products_shared, len(b.classes), b.verification.max_deviation, b.optimized_bytes)


def _read(tmp_path, text: str) -> skeleton.Skeleton | None:
    path = tmp_path / "m.ifc"
    path.write_text(text)
    return skeleton.read(path)


def test_the_scan_gives_what_traverse_walks(tmp_path):
    for face_set in ("surface_model", "brep"):
        text = _text(face_set=face_set)
        found = _read(tmp_path, text)
        model = ifcopenshell.file.from_string(text)
        assert found is not None and len(found.points) == 3 * 8
        for item, (points, faces) in found.points.items():
            walked = model.traverse(model.by_id(item))
            expected = np.asarray([i.get_argument(0) for i in walked if i.is_a("IfcCartesianPoint")], dtype=float)
            assert np.array_equal(points, expected)  # same values, same order
            assert faces == sum(1 for i in walked if i.is_a() == "IfcFace")
            assert sorted(found.closures[item].tolist()) == sorted(i.id() for i in walked)
            assert found.entities[item] == Counter(i.is_a() for i in walked)
        # the skeleton lacks exactly what lies under the items' children, and keeps every id's number
        skeleton_model = found.model()
        assert skeleton_model.get_max_id() == model.get_max_id()
        assert len(list(skeleton_model)) + sum(found.inner.values()) == len(list(model))


@pytest.mark.parametrize("sharing", ["product_shape", "mapped_item"])
def test_the_optimized_file_is_the_whole_parse_s_byte_for_byte(monkeypatch, sharing):
    streamed, whole, parses = _both(monkeypatch, _text(10, arcs=12), sharing=sharing)
    # 8 segment shapes: the other 72 products share them, and the model is rebuilt from the skeleton
    assert streamed.result.products_shared == 10 * 8 - 8 and streamed.files and parses == 0
    _same(streamed, whole)


def test_a_model_that_keeps_most_of_itself_is_optimized_as_a_whole(monkeypatch):
    # few copies: removing them from the whole model is cheaper than rebuilding it; the result is the same
    text = _text(3, shuffle=True, seed=5)
    rng = np.random.default_rng(2)

    def jitter(match):  # every point moved by a millimetre or so: nothing is congruent any more
        x, y, z = (float(v) for v in match.group(1).split(","))
        return "IFCCARTESIANPOINT((%r,%r,%r))" % tuple(v + rng.uniform(-2e-3, 2e-3) for v in (x, y, z))
    text = re.sub(r"IFCCARTESIANPOINT\(\(([-0-9.E,]+,[-0-9.E,]+,[-0-9.E]+)\)\)", jitter, text)
    streamed, whole, parses = _both(monkeypatch, text)
    assert streamed.result.products_shared == 0 and parses == 1
    _same(streamed, whole)


def _mesh_points(text: str) -> list[int]:
    """The points the loops of the meshes name, in order."""
    return [int(i) for loop in re.findall(r"=IFCPOLYLOOP\(\(([^)]*)\)", text) for i in re.findall(r"#(\d+)", loop)]


def test_an_item_that_shares_an_instance_stays_whole_and_the_result_is_the_same(monkeypatch, tmp_path):
    text = _text(3)
    loops = re.findall(r"#(\d+)=IFCPOLYLOOP\(\(#(\d+),", text)
    first_loop, first_point = loops[0]
    last_loop = loops[-1][0]
    # the last item's first loop starts at a point of the first item: two items' closures meet
    text = re.sub(rf"#{last_loop}=IFCPOLYLOOP\(\(#\d+,", f"#{last_loop}=IFCPOLYLOOP((#{first_point},", text)
    found = _read(tmp_path, text)
    assert found is not None and len(found.points) == 3 * 8 - 2
    streamed, whole, _ = _both(monkeypatch, text)
    _same(streamed, whole)


def test_a_point_also_used_by_a_placement_keeps_its_item_in_the_skeleton(monkeypatch, tmp_path):
    text = _text(3)
    point = _mesh_points(text)[-1]
    # a placement's location is one of the mesh's points (a post-pass optimizer writes such files)
    placement = re.search(r"#(\d+)=IFCAXIS2PLACEMENT3D\(#(\d+),", text)
    text = text.replace(placement.group(0), f"#{placement.group(1)}=IFCAXIS2PLACEMENT3D(#{point},", 1)
    found = _read(tmp_path, text)
    assert found is not None and len(found.points) == 3 * 8 - 1
    streamed, whole, _ = _both(monkeypatch, text)
    _same(streamed, whole)


@pytest.mark.parametrize("edit", ["two_d", "comment", "comment_within", "wrapped", "text"])
def test_files_the_scan_does_not_vouch_for(monkeypatch, tmp_path, edit):
    text = _text(3)
    point = _mesh_points(text)[5]
    line = re.search(rf"#{point}=IFCCARTESIANPOINT\(\(([^)]*)\)\);", text)
    x, y, z = line.group(1).split(",")
    if edit == "two_d":  # one point of one item in 2D: that item is the kernel's (as before), the rest is streamed
        text = text.replace(line.group(0), f"#{point}=IFCCARTESIANPOINT(({x},{y}));")
    elif edit == "comment":
        text = text.replace(line.group(0), f"/* moved */ {line.group(0)}")
    elif edit == "comment_within":  # within a line the scan would otherwise read
        assert ",'Ring 1 segment A'," in text
        text = text.replace(",'Ring 1 segment A',", ",'Ring 1 segment A' /* named */,", 1)
    elif edit == "wrapped":  # one instance over two lines
        text = text.replace(line.group(0), f"#{point}=IFCCARTESIANPOINT(({x},\n{y},{z}));")
    else:  # a coordinate that is no number: the whole parse says so, as before
        text = text.replace(line.group(0), f"#{point}=IFCCARTESIANPOINT(({x},'{y}',{z}));")
    found = _read(tmp_path, text)
    assert (found is not None and len(found.points) == 3 * 8 - 1) if edit == "two_d" else found is None
    streamed, whole, _ = _both(monkeypatch, text)
    _same(streamed, whole)
