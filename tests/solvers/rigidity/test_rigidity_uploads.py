"""LDraw uploads item by item: what editors write is read, what cannot be read is skipped with its
line and reason, and a file with no part is refused."""

from __future__ import annotations

import json

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload
from tests.solvers.rigidity import ldraw_files as files


def parse(name, text, options=None):
    content = text.encode("utf-8") if isinstance(text, str) else text
    return parse_upload(StoredInput.from_bytes(name, content), options)


def test_ldcad_file_one_stud_hinge():
    request = parse("stacked.ldr", files.LDCAD)
    assert [(p.id, p.part, p.position) for p in request.parts] == [("L9", "3001", [0, 0, 0]), ("L11", "3005", [30, -24, 10])]
    result = solve(request).result
    assert result.dof == 1 and result.joints[0].type == "hinge"
    assert request.source["meta_lines"] == 10 and request.source["skipped_count"] == 0


def test_leocad_file_with_six_decimals_hinge_bricks():
    result = solve(parse("hinge.ldr", files.LEOCAD)).result
    assert result.dof == 1 and result.rank_method == "modular"
    assert {frozenset(c) for c in result.clusters} == {frozenset({"L5", "L7"}), frozenset({"L8"})}


def test_ldcad_technic_file_pins_axle_and_hinge_in_the_ldraw_frames():
    request = parse("technic.ldr", files.LDCAD_TECHNIC)
    assert [p.part for p in request.parts] == ["3701", "3701", "2780", "3673", "32064", "3705", "3937", "3938", "3004"]
    result = solve(request).result
    by_pair = {frozenset(j.bodies): j for j in result.joints}
    # each pin sits in one hole of each technic brick (a hinge about the hole's z axis)
    for pin in ("L11", "L12"):
        for brick in ("L8", "L10"):
            joint = by_pair[frozenset({pin, brick})]
            assert (joint.type, joint.origin) == ("hinge", "pin") and [abs(v) for v in joint.axis] == [0, 0, 1]
    assert by_pair[frozenset({"L11", "L8"})].point == [-20.0, 10.0, 0.0]
    # the centred axle is held in the axle hole; the hinge halves meet on the line y = -38 along x
    axle = by_pair[frozenset({"L14", "L15"})]
    assert (axle.type, axle.origin, axle.point) == ("rigid", "axle", [0.0, -14.0, 0.0])
    hinge = by_pair[frozenset({"L17", "L18"})]
    assert (hinge.type, hinge.origin, hinge.point, hinge.axis) == ("hinge", "hinge", [0.0, -38.0, 0.0], [1.0, 0.0, 0.0])
    for below, above in (("L8", "L14"), ("L14", "L17"), ("L18", "L19")):
        studs = by_pair[frozenset({below, above})]
        assert (studs.type, studs.origin, studs.connections) == ("rigid", "stud", 2)
    assert len(result.joints) == 9
    # two pins hold the bricks rigid while each spins, and the hinge turns: 3 degrees of freedom
    assert result.dof == 3 and result.rank_method == "modular"
    assert {frozenset(c) for c in result.clusters} == {frozenset({"L8", "L10", "L14", "L15", "L17"}),
                                                       frozenset({"L11"}), frozenset({"L12"}), frozenset({"L18", "L19"})}
    assert {frozenset(c) for c in result.superbricks} == {frozenset(c) for c in result.clusters}
    assert result.collisions == [] and result.unknown_parts == []


def test_mlcad_file_with_crlf_upper_case_names_and_drawn_geometry():
    request = parse("tower.ldr", files.MLCAD)
    assert [p.part for p in request.parts] == ["3001", "3001"]  # the GHOST line is a meta line
    assert request.source["geometry_lines"] == 4
    result = solve(request).result
    assert result.rigid and result.superbricks == [["L7", "L9"]]


def test_studio_mpd_expands_submodels_with_their_placement_and_reports_unknown_parts():
    request = parse("main.mpd", files.STUDIO)
    parts = {p.id: p for p in request.parts}
    assert set(parts) == {"L7", "L8/L16", "L9/L16", "L10"}
    assert parts["L8/L16"].position == [-20, -24, 10]
    assert parts["L9/L16"].position == [20, -24, -10] and parts["L9/L16"].rotation[0] == -1
    assert parts["L10"].rotation[0] == 1  # 0.999999 as written by the exporter
    assert request.source["submodels"] == 1 and request.source["submodels_expanded"] == 2
    result = solve(request).result
    assert [(u.id, u.part) for u in result.unknown_parts] == [("L10", "99999")]
    # each 1x2 brick sits on two studs of the 2x4: all rigid
    assert result.rigid and len(result.superbricks) == 1


def test_broken_lines_are_skipped_one_by_one_with_reasons():
    request = parse("broken.ldr", files.BROKEN)
    assert [p.id for p in request.parts] == ["L2", "L7"]
    reasons = {s["line"]: s["reason"] for s in request.source["skipped"]}
    assert set(reasons) == {3, 4, 5, 6}
    assert "15 fields" in reasons[3] and "not a number" in reasons[4] and "singular" in reasons[5]
    assert "line type" in reasons[6]
    result = solve(request).result  # 3 of its 5 placements not read: the 2 bricks read are no verdict on the model
    assert result.rigid is None and result.report.warnings[0].code == "rigidity_not_determined"


def test_a_submodel_that_includes_itself_is_refused_at_its_line():
    request = parse("loop.mpd", files.SELF_INCLUDING)
    assert [p.part for p in request.parts] == ["3001"]
    assert request.source["skipped"][0]["line"] == 3 and "includes itself" in request.source["skipped"][0]["reason"]


@pytest.mark.parametrize("name, content, message", [
    ("empty.ldr", b"  \n", "empty"),
    ("nothing.ldr", files.ONLY_COMMENTS.encode(), "places no part"),
    ("model.json", b"[1, 2]", "request object"),
    ("model.ldr", b"\x00\x01binary", "binary"),
])
def test_files_that_give_nothing_are_refused_naming_the_file(name, content, message):
    with pytest.raises(InputRejected) as info:
        parse(name, content)
    assert info.value.errors[0].loc[0] == "file" and message in info.value.errors[0].msg


def test_json_upload_and_form_options():
    body = {"parts": [{"id": "a", "part": "3001", "position": [0, 0, 0]}]}
    request = parse("model.json", json.dumps(body), {"contact_tolerance": 0.5, "dock": {"part": "3003"}})
    assert request.options.contact_tolerance == 0.5 and request.options.dock.part == "3003"
    with pytest.raises(InputRejected) as info:
        parse("model.ldr", files.LDCAD, {"contact_tolerance": -1})
    assert info.value.errors[0].loc == ("contact_tolerance",) or info.value.errors[0].loc[0] == "options"


# ---------------------------------------------------------------- files cut short or with unreadable lines


def _ldcad_cut_in_its_last_part_line() -> tuple[str, int]:
    # LDCad saved the stack with a trailing 'STEP'; the copy stops inside the 3004's line, after its 't 1 30'
    text = files.LDCAD_TECHNIC[:files.LDCAD_TECHNIC.rindex("3004.dat") + 2]
    return text, text.count("\n") + 1


def test_ldcad_file_cut_inside_its_last_part_line_warns_naming_the_line():
    text, last = _ldcad_cut_in_its_last_part_line()
    request = parse("technic.ldr", text)
    assert [p.part for p in request.parts][-1] == "3938"  # the cut '30' is no part number: not read
    result = solve(request).result
    warnings = {w.code: w for w in result.report.warnings}
    assert result.report.status == "warning"
    assert warnings["truncated_file"].details["line"] == last and f"line {last}" in warnings["truncated_file"].message
    assert warnings["skipped_lines"].details["lines"] == [last]


def test_leocad_line_with_nan_is_skipped_with_a_warning_naming_it():
    lines = files.LEOCAD.splitlines(keepends=True)
    bad = next(n for n, ln in enumerate(lines, 1) if ln.rstrip().endswith("3938.dat"))
    lines[bad - 1] = lines[bad - 1].replace("-24.000000", "nan", 1)
    result = solve(parse("hinge.ldr", "".join(lines))).result
    (warning,) = [w for w in result.report.warnings if w.code == "skipped_lines"]
    assert warning.details["lines"] == [bad] and warning.details["count"] == 1
    assert f"line {bad}" in warning.message and "not finite" in warning.message


def test_a_file_whose_only_part_line_is_cut_is_refused_naming_the_file():
    with pytest.raises(InputRejected) as error:
        parse("cut.ldr", "0 Name: one.ldr\r\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 300")
    (fe,) = error.value.errors
    assert fe.loc == ("file",) and "line 2" in fe.msg and "ends inside" in fe.msg


# ---------------------------------------------------------------- packed models and embedded part definitions


def test_threejs_packed_model_places_its_parts_not_their_drawn_definitions():
    request = parse("car_Packed.mpd", files.THREEJS_PACKED)
    assert [(p.id, p.part, p.position, p.rotation) for p in request.parts] == [
        ("L12", "3001", [0, 0, 0], [1, 0, 0, 0, 1, 0, 0, 0, 1]),
        ("L13", "3003", [0, -24, 0], [1, 0, 0, 0, 1, 0, 0, 0, 1]),
        ("L14/L18", "3004", [30, -24, 0], [0, 0, -1, 0, 1, 0, 1, 0, 0])]
    source = request.source
    assert source["main_model"] == "<main>" and source["submodels"] == 1 and source["submodels_expanded"] == 1
    assert source["embedded_parts"] == ["parts/3001.dat", "parts/3003.dat", "parts/3004.dat"]
    assert source["skipped_count"] == 0
    result = solve(request).result
    # the 2 x 2 on four studs, the turned 1 x 2 on two: one superbrick, nothing unknown
    assert result.rigid and result.superbricks == [["L12", "L13", "L14/L18"]] and result.unknown_parts == []
    assert sorted(j.connections for j in result.joints) == [2, 4]


def test_studio_embedded_unofficial_parts_known_number_is_the_part_custom_part_is_its_primitives():
    request = parse("main.mpd", files.STUDIO_EMBEDDED)
    assert [(p.id, p.part, p.position) for p in request.parts] == [
        ("L5", "3001", [0, 0, 0]), ("L6", "3701", [0, -24, 10]), ("L7", "custom bracket", [0, -24, -30])]
    assert request.source["embedded_parts"] == ["3701.dat", "custom bracket.dat"]
    assert request.source["submodels"] == 0 and request.source["main_model"] == "main.ldr"
    # the custom bracket draws one stud.dat: one stud at its origin, in the catalogue record the reader hands on
    assert request.source["parts_from_primitives"]["custom bracket"]["s"] == [
        ["cyl", "M", "one", 0, [0.0, 0.0, 0.0], [0.0, -1.0, 0.0], [["R", 6.0, 4.0]]]]
    result = solve(request).result
    assert result.unknown_parts == []
    (marked,) = [w for w in result.report.warnings if w.code == "parts_from_primitives"]
    assert marked.details["ids"] == ["L7"]
    assert next(p for p in result.parts if p.id == "L7").joints == []  # its stud stands beside the 2 x 4, clear of it
    (joint,) = result.joints  # the technic brick sits on the 2 x 4's back row of studs
    assert (joint.bodies, joint.type, joint.connections) == (["L5", "L6"], "rigid", 4)


def test_library_folder_case_and_separator_in_a_reference_find_the_embedded_section():
    # the same packed model written with '\' and upper case in the references and the sections' names
    text = (files.THREEJS_PACKED.replace("parts/3001.dat", "Parts\\3001.DAT")
            .replace("0 FILE Parts\\3001.DAT", "0 FILE PARTS/3001.dat"))
    assert "1 4 0 0 0 1 0 0 0 1 0 0 0 1 Parts\\3001.DAT" in text
    request = parse("car_Packed.mpd", text)
    assert [p.part for p in request.parts] == ["3001", "3003", "3004"]
    assert request.source["embedded_parts"][0] == "parts/3001.dat"
    # referenced without the folder (as the part library's search path allows), the section is found too
    bare = files.THREEJS_PACKED.replace(" parts/3003.dat\n", " 3003.dat\n")
    assert [p.part for p in parse("car_Packed.mpd", bare).parts] == ["3001", "3003", "3004"]


def test_primitives_and_subparts_placed_in_a_model_are_drawn_geometry_not_parts():
    text = files.THREEJS_PACKED.replace("0 FILE wing.ldr\n", "1 16 0 0 0 1 0 0 0 1 0 0 0 1 p/stud.dat\n"
                                        "1 16 0 0 0 1 0 0 0 1 0 0 0 1 s\\3001s02.dat\n0 FILE wing.ldr\n")
    request = parse("car_Packed.mpd", text)
    assert [p.part for p in request.parts] == ["3001", "3003", "3004"]
    assert request.source["geometry_lines"] == 2 and request.source["skipped_count"] == 0


def test_a_packed_file_whose_main_model_places_only_unknown_parts_is_read_not_refused():
    text = "0 FILE x.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 parts/u9001.dat\n0 FILE parts/u9001.dat\n" \
           "0 !LDRAW_ORG Unofficial_Part\n1 16 0 0 0 1 0 0 0 1 0 0 0 1 p/stud.dat\n"
    request = parse("x.mpd", text)
    assert [(p.id, p.part) for p in request.parts] == [("L2", "u9001")]
    result = solve(request).result  # u9001 draws a stud: known from its primitive, joined to nothing
    assert result.unknown_parts == [] and [(p.id, p.joints) for p in result.parts] == [("L2", [])]


def test_an_embedded_dat_without_header_is_a_part_when_it_only_draws_and_a_submodel_when_it_places_parts():
    text = ("0 FILE main.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 sticker.dat\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 layer.dat\n"
            "0 FILE sticker.dat\n0 Sticker\n3 16 0 0 0 10 0 0 0 0 10\n"
            "0 FILE layer.dat\n0 a sub-model named .dat with a drawn guide line\n2 24 0 0 0 80 0 0\n"
            "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n")
    request = parse("x.mpd", text)
    assert [(p.id, p.part) for p in request.parts] == [("L2", "sticker"), ("L3/L10", "3001")]
    assert request.source["embedded_parts"] == ["sticker.dat"] and request.source["submodels"] == 1


def test_an_official_model_with_rotations_printed_to_three_digits_passes_the_checks_as_rotations():
    """OMR 889 Radar Truck (CC BY 2.0, omr/README.md) writes its radar's tilt as ``0.985 -0.17 0`` (cos and sin of
    10 degrees to two and three digits); composed with its sub-model's placement the matrix was 1.2e-3 off
    orthonormal and the whole file was refused at /parts/31/rotation. Read as the nearest rotations, it passes."""
    from pathlib import Path

    import numpy as np

    from plantsolve.solvers.rigidity.validation import check_input

    content = (Path(__file__).parent / "omr" / "889-1-RadarTruck.mpd").read_bytes()
    request = parse("889-1-RadarTruck.mpd", content)
    check_input(request)
    assert request.source["rotations_rounded"] > 0 and request.source["skipped_count"] == 0
    for part in request.parts:
        m = np.array(part.rotation).reshape(3, 3)
        assert np.allclose(m @ m.T, np.eye(3), atol=1e-4)  # the reader tidies values within 1e-5 of an integer
    lines = content.decode().splitlines()
    written = [np.array([float(v) for v in lines[n - 1].split()[5:14]]).reshape(3, 3) for n in (15, 89)]
    tilted = next(p for p in request.parts if p.id == "L15/L89")  # line 89 placed by the sub-model at line 15
    assert np.allclose(np.reshape(tilted.rotation, (3, 3)), written[0] @ written[1], atol=2e-3)  # as written, rounded


@pytest.mark.parametrize("line, reason", [
    ("1 4 0 -24 0 2 0 0 0 1 0 0 0 1 3001.dat", "not a rotation (scaled or sheared"),
    ("1 4 0 -24 1e308 1 0 0 0 1 0 0 0 1 3001.dat", "beyond 1e+12 LDU"),
    ("1 4 1e13 -24 0 1 0 0 0 1 0 0 0 1 3001.dat", "beyond 1e+12 LDU"),
])
def test_a_part_line_scaled_or_placed_beyond_the_bound_is_skipped_not_the_file_refused(line, reason):
    """Before: a scaled matrix refused the whole file at /parts/1/rotation, and a 1e308 position overflowed the reader
    (a 422 calling the file malformed). Now the line is skipped with its reason and the rest is analysed."""
    from plantsolve.solvers.rigidity.validation import check_input

    request = parse("poisoned.ldr", "0 Untitled\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n" + line + "\n"
                    "1 4 0 -48 0 1 0 0 0 1 0 0 0 1 3001.dat\n")
    check_input(request)
    assert [p.id for p in request.parts] == ["L2", "L4"]
    (skipped,) = request.source["skipped"]
    assert skipped["line"] == 3 and reason in skipped["reason"]
    assert next(w for w in solve(request).result.report.warnings if w.code == "skipped_lines").details["lines"] == [3]


def test_a_sub_model_placed_by_a_hand_typed_rotation_is_read_as_the_nearest_rotation_and_said():
    """OMR 10174 (UCS AT-ST) places five sub-models with matrices like ``0 0 1.018 / 0.994 -0.171 0 / 0.176 0.958
    0.003`` (rows up to 0.051 off orthonormal); each line was skipped and with it all 291 parts of the sub-models.
    A sub-model placed 2.5 per cent off a quarter turn about y: its two bricks are read, stacked as the matrix's
    nearest rotation puts them, and a warning names the line; the same matrix on a part line still skips it, and
    a scaled primitive is drawn geometry, not a skipped line."""
    import numpy as np

    text = ("0 FILE main.ldr\n"
            "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
            "1 4 0 -24 0 0 0 1.025 0 1 0 -1 0 0 tower.ldr\n"
            "1 4 0 -72 0 0 0 1.025 0 1 0 -1 0 0 3001.dat\n"
            "1 16 0 0 0 2 0 0 0 1 0 0 0 2 p/4-4cyli.dat\n"
            "0 FILE tower.ldr\n"
            "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
            "1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat\n")
    request = parse("hand.mpd", text.encode())
    assert [p.id for p in request.parts] == ["L2", "L3/L7", "L3/L8"]
    assert [s["line"] for s in request.source["skipped"]] == [4]  # the part line; the primitive is geometry
    quarter = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float)  # the nearest rotation of the typed matrix
    for part, height in zip(request.parts[1:], (-24, -48)):
        assert np.allclose(np.reshape(part.rotation, (3, 3)), quarter, atol=1e-9)
        assert np.allclose(part.position, [0, height, 0])
    (warning,) = [w for w in request.source["warnings"] if w["code"] == "rotation_rounded"]
    assert warning["details"]["lines"] == [3] and abs(warning["details"]["max_off"] - 0.0506) < 1e-3
    result = solve(request).result
    assert result.report.details["connected_pieces"] == 1  # the sub-model's bricks stand on the first one


def test_an_mpd_cut_before_its_sub_models_or_inside_a_comment_says_so():
    """OMR 889 Radar Truck (CC BY 2.0, omr/README.md) cut after its main model placed its two sub-models as two
    'parts not in the catalogue'; cut inside a comment it lost the lines after it without a word."""
    from pathlib import Path

    content = (Path(__file__).parent / "omr" / "889-1-RadarTruck.mpd").read_bytes()
    main_end = content.index(b"889 - Minifig.ldr") + len(b"889 - Minifig.ldr\n")
    with pytest.raises(InputRejected) as refused:
        parse("cut.mpd", content[:main_end])
    message = refused.value.errors[0].msg
    assert "line 14: places sub-model '889 - Truck.ldr', which the file does not hold" in message
    comment = content.index(b"0 !LICENSE", main_end + 200)
    request = parse("cut.mpd", content[:comment + 20])
    note = next(w for w in solve(request).result.report.warnings if w.code == "truncated_file")
    assert note.details["line"] == content[:comment].count(b"\n") + 1 and "no line ending" in note.message
