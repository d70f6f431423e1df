"""Mistakes users make with a rigidity model: a file of another kind, a part typed far away, an absurd option.
Each is refused naming the file or field, or warned naming the part and line — never a confident answer."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from plantsolve.schemas.rigidity import RigidityOptions, RigidityRequest
from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.rigidity import upload
from plantsolve.solvers.rigidity.catalogue import Connector, PartShape
from plantsolve.solvers.rigidity.solve import solve
from plantsolve.solvers.rigidity.upload import parse_upload

REPO = Path(__file__).resolve().parents[3]


def parse(name, text, options=None):
    return parse_upload(StoredInput.from_bytes(name, text.encode()), options)


OBJ = "# Blender 3.6\nmtllib room.mtl\no Room\nv 0 0 0\nv 5000 0 0\nv 5000 4000 0\nv 0 4000 3000\nf 1 2 3\nf 1 3 4\n"
IDF = "Version,9.2;\n\nZone,\n  Office,                  !- Name\n  0,                       !- Direction\n  1;\n"
CSV = "flow [m3/s],head [m],efficiency [%],speed [rpm],power [kW]\n0.1,25.2,71,1450,35.1\n0.2,24.1,80,1450,58.0\n"
XYZ = "10.5 2.25 3.0\n11.0 2.5 3.1\n11.5 2.75 3.2\n"
STEP = "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('x'),'2;1');\nENDSEC;\n"
IFC = "ISO-10303-21;\nHEADER;\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n#1=IFCPROJECT('x',$,$,$,$,$,$,$,$);\n"
STL = "solid part\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n" \
      "  endloop\n endfacet\nendsolid part\n"
DXF = "0\nSECTION\n2\nENTITIES\n0\nLINE\n8\n0\n10\n0.0\n20\n0.0\n0\nENDSEC\n0\nEOF\n"


@pytest.mark.parametrize("text, holds", [
    (OBJ, "a Wavefront OBJ mesh (4 vertex and 2 face lines"),
    (IDF, "an EnergyPlus IDF building model (objects such as Version, Zone)"),
    (CSV, "a table of 5 columns (flow [m3/s], head [m], efficiency [%], speed [rpm], power [kW])"),
    (XYZ, "a list of numbers, 3 per line"),
    (STEP, "a STEP model"),
    (IFC, "an IFC model"),
    (STL, "an ASCII STL mesh"),
    (DXF, "a DXF drawing"),
])
def test_a_file_of_another_kind_renamed_ldr_is_refused_naming_what_it_holds(text, holds):
    with pytest.raises(InputRejected) as caught:
        parse("model.ldr", text)
    (error,) = caught.value.errors
    assert error.loc == ("file",)
    assert error.msg.startswith("the file is not LDraw: it holds " + holds)


@pytest.mark.parametrize("kind", ["alignment", "tube", "perfmap", "flowmeter", "polyhedra"])
def test_another_kinds_json_request_is_refused_naming_that_kind_and_its_fields(kind):
    example = json.loads((REPO / "plantsolve" / "solvers" / kind / "example.json").read_text())
    with pytest.raises(InputRejected) as caught:
        parse("model.json", json.dumps(example))
    (error,) = caught.value.errors
    assert error.loc == ("file",)
    assert f"holds {'an' if kind == 'alignment' else 'a'} {kind} request (its fields: " in error.msg
    assert all(key in error.msg for key in sorted(example)[:3])


def test_a_json_of_no_kind_is_refused_naming_its_fields():
    with pytest.raises(InputRejected, match=r"holds no rigidity model \(its fields: colour, name\)"):
        parse("model.json", json.dumps({"name": "x", "colour": 4}))


STACK = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat\n" \
        "1 4 0 -48 0 1 0 0 0 1 0 0 0 1 3001.dat\n"


def test_a_part_typed_1e7_ldu_away_is_warned_naming_the_part_and_its_line():
    text = STACK + "1 4 10000000 -72 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
    result = solve(parse("far.ldr", text)).result
    warnings = {w.code: w for w in result.report.warnings}
    far = warnings["implausible_part_position"]
    assert [p["id"] for p in far.details["parts"]] == ["L4"] and far.details["parts"][0]["line"] == 4
    assert far.details["parts"][0]["distance_ldu"] == pytest.approx(1e7, rel=1e-6)
    assert "L4 (3001, line 4)" in far.message and "part position" in far.message and "LDU" in far.message
    # and the far part is joined to nothing
    assert [p["id"] for p in warnings["floating_parts"].details["parts"]] == ["L4"]


def test_a_large_model_spread_over_metres_is_not_warned():
    # four stacks 2,000 LDU (80 cm) apart: a big layout, every part plausible
    text = "".join(f"1 4 {x} 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 {x} -24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
                   for x in (0, 2000, 4000, 6000))
    result = solve(parse("layout.ldr", text)).result
    assert "implausible_part_position" not in {w.code for w in result.report.warnings}


@pytest.mark.parametrize("field, value", [("contact_tolerance", 1e6), ("contact_tolerance", -1.0),
                                          ("rank_tolerance", 1.0), ("rank_tolerance", 0.0)])
def test_absurd_scalar_options_are_refused_at_intake_naming_the_field(field, value):
    with pytest.raises(ValidationError) as caught:
        RigidityRequest.model_validate({"parts": [{"id": "a", "part": "3001", "position": [0, 0, 0]}],
                                        "options": {field: value}})
    assert [e["loc"] for e in caught.value.errors()] == [("options", field)]
    assert RigidityOptions.model_fields[field].metadata  # the bound is in the schema (OpenAPI), not in code


@pytest.mark.parametrize("unit, factor", [("mm", 2.5), ("studs", 20.0)])
def test_a_model_written_in_another_unit_is_warned_naming_the_unit(unit, factor):
    """The tests' official-parts model with every position divided by the unit's factor to LDU: nothing
    meets as written; scaled back, everything does."""
    lines = []
    for raw in (REPO / "tests" / "solvers" / "rigidity" / "official_parts.ldr").read_text().splitlines():
        tokens = raw.split()
        if tokens[:1] == ["1"]:
            tokens[2:5] = [repr(float(v) / factor) for v in tokens[2:5]]
            raw = " ".join(tokens)
        lines.append(raw)
    result = solve(parse("scaled.ldr", "\n".join(lines) + "\n")).result
    warning = next(w for w in result.report.warnings if w.code == "implausible_part_spacing")
    assert warning.details["unit"] == unit and warning.details["factor_to_ldu"] == factor
    assert warning.details["floating_scaled"] == 0 and warning.details["floating_as_written"] > 15
    assert f"positions written in {unit} read as LDU" in warning.message


def test_a_model_in_ldu_is_not_warned_about_its_spacing():
    result = solve(parse("stack.ldr", STACK)).result
    assert "implausible_part_spacing" not in {w.code for w in result.report.warnings}


def test_the_ldraw_unit_is_stated_in_the_source_with_its_factor():
    request = parse("stack.ldr", STACK)
    assert request.source["units"]["file_unit"] == request.source["units"]["result_unit"] == "ldu"
    assert request.source["units"]["factor"] == 1.0 and "0.4 mm" in request.source["units"]["from"]
    result = solve(request).result
    assert result.length_unit == "ldu" and result.report.details["source"]["units"]["file_unit"] == "ldu"


# A main model placing a sub-model of two stacked bricks, with a brick of its own on top: 3 parts in one piece.
MAIN = "0 FILE main.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 tower.ldr\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
TOWER = "0 FILE tower.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 3001.dat\n"


def placed(request):
    return sorted((p.part, tuple(p.position), tuple(p.rotation or ())) for p in request.parts)


@pytest.mark.parametrize("order", [(MAIN, TOWER), (TOWER, MAIN)])
def test_the_sections_of_an_mpd_may_come_in_any_order(order):
    """The format says the first '0 FILE' is the main model; a sub-model written first (sections sorted by a tool,
    or pasted by hand) is placed by another section, so it is not: the model read is the same either way."""
    request = parse("tower.mpd", "".join(order))
    assert request.source["main_model"] == "main.ldr"
    assert placed(request) == [("3001", (0.0, -24.0, 0.0), (1, 0, 0, 0, 1, 0, 0, 0, 1)),
                               ("3001", (0.0, 0.0, 0.0), (1, 0, 0, 0, 1, 0, 0, 0, 1)),
                               ("3001", (0.0, 24.0, 0.0), (1, 0, 0, 0, 1, 0, 0, 0, 1))]
    result = solve(request).result
    assert (result.dof, len(result.pieces), result.report.warnings) == (0, 1, [])


def test_two_sub_files_of_one_name_with_different_contents_are_refused_naming_both_lines():
    other = "0 FILE tower.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3003.dat\n"
    for text, lines in ((MAIN + TOWER + other, "lines 4 and 7"), (MAIN + other + TOWER, "lines 4 and 6")):
        with pytest.raises(InputRejected) as caught:
            parse("tower.mpd", text)
        (error,) = caught.value.errors
        assert error.loc == ("file",)
        assert f"defines sub-file 'tower.ldr' twice with different contents ('0 FILE' at {lines})" in error.msg


def test_a_sub_file_written_twice_alike_is_read_once():
    assert placed(parse("tower.mpd", MAIN + TOWER + TOWER.replace("\n", "  \n"))) == placed(parse("t.mpd", MAIN + TOWER))


def test_a_sub_model_the_main_model_never_places_is_warned_naming_it():
    request = parse("tower.mpd", MAIN + TOWER + "0 FILE old tower.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n")
    assert len(request.parts) == 3
    warning = next(w for w in solve(request).result.report.warnings if w.code == "unplaced_submodels")
    assert warning.details == {"submodels": ["old tower.ldr"], "main_model": "main.ldr"}
    assert "'old tower.ldr'" in warning.message and "not analysed" in warning.message


def test_a_section_headed_0_file_without_a_name_is_read():
    request = parse("stack.mpd", "0 FILE\n" + STACK)
    assert len(request.parts) == 3


def test_files_saved_with_a_byte_order_mark_and_joined_into_one_mpd_read_as_their_sections():
    """Notepad writes UTF-8 with a BOM: .ldr files joined into one .mpd carry one at each '0 FILE'. Read as a line
    type, it hid that header, and the tower's parts were read as the main model's, 40 LDU off where it places them."""
    main = MAIN.replace("1 4 0 0 0 1 0 0 0 1 0 0 0 1 tower.ldr", "1 4 40 0 0 1 0 0 0 1 0 0 0 1 tower.ldr")
    joined = parse("tower.mpd", "\ufeff" + main + "\ufeff" + TOWER)
    assert placed(joined) == placed(parse("tower.mpd", main + TOWER))
    assert sorted(p.position[0] for p in joined.parts) == [0.0, 40.0, 40.0]
    assert joined.source["skipped_count"] == 0


def test_a_loop_of_sub_models_is_skipped_naming_the_loop_and_deep_nesting_is_not_called_a_loop():
    loop = ("0 FILE a.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 b.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n"
            "0 FILE b.ldr\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 a.ldr\n1 4 0 24 0 1 0 0 0 1 0 0 0 1 3001.dat\n")
    request = parse("loop.mpd", loop)
    assert len(request.parts) == 2
    assert request.source["skipped"] == [{"line": 5, "reason": "sub-model 'a.ldr' includes itself (a.ldr -> b.ldr -> "
                                                                 "a.ldr)"}]
    chain = "".join(f"0 FILE m{k}.ldr\n1 4 0 -24 0 1 0 0 0 1 0 0 0 1 m{k + 1}.ldr\n"
                    f"1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n" for k in range(40))
    deep = parse("deep.mpd", chain + "0 FILE m40.ldr\n1 4 0 0 0 1 0 0 0 1 0 0 0 1 3001.dat\n")
    assert len(deep.parts) == 32
    (skip,) = deep.source["skipped"]
    assert "nested more than 32 levels deep" in skip["reason"] and "itself" not in skip["reason"]
    # the sub-models below the depth are placed, only too deep to read: not called unplaced
    assert "unplaced_submodels" not in [w.code for w in solve(deep).result.report.warnings]


# ---------------------------------------------------------------- mirrored parts

WING = "1 4 0 -32 0 1 0 0 0 1 0 0 0 1 41769.dat\n"  # Wing 2 x 4 Right on the stack (its twin is 41770, Left)


def test_a_handed_part_placed_mirrored_is_warned_naming_its_line_and_number():
    mirrored = WING.replace("1 0 0 0 1 0 0 0 1 41769", "-1 0 0 0 1 0 0 0 1 41769")
    result = solve(parse("wing.ldr", STACK + mirrored)).result
    (warning,) = [w for w in result.report.warnings if w.code == "mirrored_parts"]  # was accepted with no word
    assert warning.details == {"parts": ["L4"], "lines": [4], "numbers": ["41769"]}
    assert "line 4" in warning.message and "41769" in warning.message
    plain = solve(parse("wing.ldr", STACK + WING)).result
    assert not [w for w in plain.report.warnings if w.code == "mirrored_parts"]


def test_a_mirrored_sub_model_mirrors_its_parts_and_twice_mirrored_is_none():
    sub = "0 FILE wing.ldr\n" + WING
    once = "0 FILE main.ldr\n" + STACK + "1 16 0 0 0 1 0 0 0 1 0 0 0 -1 wing.ldr\n" + sub
    (warning,) = [w for w in parse("m.mpd", once).source["warnings"] if w["code"] == "mirrored_parts"]
    assert warning["details"]["parts"] == ["L5/L7"] and warning["details"]["lines"] == [7]  # placed at line 5
    twice = once.replace("0 0 0 1 41769", "0 0 0 -1 41769")  # the part mirrored back within the mirrored sub-model
    assert not [w for w in parse("m.mpd", twice).source["warnings"] if w["code"] == "mirrored_parts"]


def test_a_symmetric_part_placed_mirrored_is_read_as_the_rotation_it_equals():
    """A brick mirrored across its own middle is the same brick: read as a rotation, with the same joints."""
    mirrored = STACK.replace("0 -48 0 1 0 0", "0 -48 0 -1 0 0")
    request = parse("stack.ldr", mirrored)
    assert request.source["mirrors_of_symmetric_parts"] == 1
    assert not [w for w in request.source["warnings"] if w["code"] == "mirrored_parts"]
    assert request.parts[2].rotation == [1, 0, 0, 0, 1, 0, 0, 0, 1]
    a, b = solve(request).result, solve(parse("stack.ldr", STACK)).result
    assert (a.dof, a.rigid, len(a.joints)) == (b.dof, b.rigid, len(b.joints))


@pytest.mark.parametrize("number", ["2420", "2357", "4733"])
def test_a_part_symmetric_about_a_diagonal_plane_placed_mirrored_is_no_mirrored_part(number):
    """A corner plate, a corner brick, a brick with studs on its sides: each is its own mirror image about a
    diagonal plane of its frame (x = z or x = -z; 4733's side holes point either way), so placed mirrored it is
    one of its rotations, with the same joints (before: warned as a handed part)."""
    base = "1 4 0 0 0 1 0 0 0 1 0 0 0 1 3022.dat\n"
    drawn = f"1 4 0 -8 0 1 0 0 0 1 0 0 0 1 {number}.dat\n"
    mirrored = f"1 4 0 -8 0 -1 0 0 0 1 0 0 0 1 {number}.dat\n"
    request = parse("corner.ldr", base + mirrored)
    assert request.source["mirrors_of_symmetric_parts"] == 1
    assert not [w for w in request.source["warnings"] if w["code"] == "mirrored_parts"]
    assert np.isclose(np.linalg.det(np.reshape(request.parts[1].rotation, (3, 3))), 1.0)
    a, b = solve(request).result, solve(parse("corner.ldr", base + drawn)).result
    assert (a.dof, len(a.joints)) == (b.dof, len(b.joints))


def test_a_mirror_that_swaps_axes_swaps_the_box_too(monkeypatch):
    """A 20 x 8 x 60 LDU part with one stud at its middle is symmetric about its x and z planes, not about x = z,
    which would turn its box into 60 x 8 x 20 (the box's size was compared unswapped: 4 mirrors were found)."""
    part = PartShape("99999", "test block", (0.0, 4.0, 0.0), (20.0, 8.0, 60.0),
                     (Connector("stud", (0, 0, 0), (0, -1, 0)),))
    monkeypatch.setattr(upload, "lookup", lambda name: part)
    upload.symmetry_planes.cache_clear()
    try:
        found = upload.symmetry_planes("99999.dat")
        assert sorted(np.diag(m).tolist() for m in found) == [[-1.0, 1.0, 1.0], [1.0, 1.0, -1.0]]
    finally:
        upload.symmetry_planes.cache_clear()


# ---------------------------------------------------------------- lines after 0 NOFILE

def test_part_lines_after_nofile_are_warned_naming_them_and_alone_refused():
    """Text after '0 NOFILE' with no '0 FILE' belongs to no model: LDraw readers ignore it; before, its parts were
    dropped with no word (lines pasted after the end of hinged_wall.ldr, which ends so)."""
    wall = (REPO / "examples" / "rigidity" / "hinged_wall.ldr").read_text()
    assert wall.rstrip().endswith("0 NOFILE")
    request = parse("wall.ldr", wall + STACK)
    (warning,) = [w for w in request.source["warnings"] if w["code"] == "lines_outside_files"]
    n = len(wall.splitlines())
    assert warning["details"] == {"lines": [n + 1, n + 2, n + 3], "count": 3}
    assert len(request.parts) == 9  # the model's own parts, as before
    with pytest.raises(InputRejected) as refused:
        parse("stack.ldr", "0 NOFILE\n" + STACK)
    assert "after a '0 NOFILE'" in refused.value.errors[0].msg and "line 2, 3, 4" in refused.value.errors[0].msg


def test_the_order_of_part_lines_does_not_change_the_analysis():
    wall = (REPO / "examples" / "rigidity" / "hinged_wall.ldr").read_text().splitlines()
    at = [i for i, line in enumerate(wall) if line.startswith("1 ")]
    shuffled = list(wall)
    for i, line in zip(at, [wall[i] for i in at][::-1]):
        shuffled[i] = line
    a = solve(parse("a.ldr", "\n".join(wall) + "\n")).result
    b = solve(parse("b.ldr", "\n".join(shuffled) + "\n")).result
    assert (a.dof, a.rigid, len(a.joints)) == (b.dof, b.rigid, len(b.joints)) == (4, False, 9)


def test_an_idf_with_comment_lines_and_field_notes_renamed_mpd_is_named_as_an_idf():
    idf = (REPO / "examples" / "polyhedra" / "two_offices.idf").read_text()
    assert idf.startswith("!")  # was "places no part — line 1: line type '!' is not an LDraw line type"
    with pytest.raises(InputRejected) as refused:
        parse("offices.mpd", idf)
    assert "an EnergyPlus IDF building model" in refused.value.errors[0].msg
