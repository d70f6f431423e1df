"""IFC spaces whose body a garbled coordinate throws past the schema's ±1e12 m bound are skipped naming the space,
as the IDF, gbXML and OBJ readers skip the object holding such a coordinate naming its line: the whole file was
refused with the schema's errors naming vertex indices of no file ('file/vertices/0/0: Input should be less than or
equal to 1000000000000', forty times over)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

SPACES = (Path(__file__).parent / "data" / "ifcopenshell_spaces.ifc").read_bytes()
PROFILE_CENTRE = b"#20=IFCCARTESIANPOINT((2500.,2000.));"  # the centre of space 101's rectangle profile, in mm


def _request(content: bytes):
    return parse_upload(StoredInput.from_bytes("model.ifc", content), None)


def test_a_space_thrown_past_the_bound_is_skipped_naming_it_and_the_others_are_measured():
    request = _request(SPACES.replace(PROFILE_CENTRE, b"#20=IFCCARTESIANPOINT((2.5E300,2000.));"))
    result = solve(request).result
    assert {z.id: z.volume for z in result.zones} == {"102": pytest.approx(48.0), "103": pytest.approx(1.0)}
    skipped = {s["object"]: s["reason"] for s in request.source["skipped"]}
    assert "beyond ±1e+12 m" in skipped["#18 IfcSpace '101'"] and "2.5e+297 m" in skipped["#18 IfcSpace '101'"]
    warned = next(w for w in result.report.warnings if w.code == "skipped_lines").details["skipped"]
    assert "#18 IfcSpace '101'" in [entry["object"] for entry in warned]
    assert "101" not in request.source["declared"]  # its stated quantities are compared with nothing


def test_a_model_whose_every_space_is_thrown_past_the_bound_is_refused_naming_a_space():
    with pytest.raises(InputRejected) as refused:
        _request(_placed_far(SPACES))
    (error,) = refused.value.errors
    assert error.loc == ("file", "#18 IfcSpace '101'") and "1e+297 m from the origin, beyond ±1e+12 m" in error.msg
    assert "#37 IfcSpace '102'" in error.msg and "#54 IfcSpace '103'" in error.msg


def _placed_far(content: bytes) -> bytes:
    """Every space's profile centre moved to 1e300 mm."""
    text = content.decode("latin-1")
    spaces = re.findall(r"IFCRECTANGLEPROFILEDEF\(\.AREA\.,\$,#(\d+),", text)
    for placement in spaces:
        point = re.search(rf"#{placement}=IFCAXIS2PLACEMENT2D\(#(\d+),", text).group(1)
        text = re.sub(rf"#{point}=IFCCARTESIANPOINT\(\([^)]*\)\);", f"#{point}=IFCCARTESIANPOINT((1.E300,0.));", text)
    return text.encode("latin-1")


# space 101's body as an IFC4 triangulated face set: the same 5 x 4 x 3 m box, in mm
TESSELLATED = SPACES.replace(
    b"#26=IFCEXTRUDEDAREASOLID(#22,#24,#25,3000.);",
    b"#26=IFCTRIANGULATEDFACESET(#90,$,.T.,((1,3,2),(1,4,3),(5,6,7),(5,7,8),(1,2,6),(1,6,5),(2,3,7),(2,7,6),(3,4,8),"
    b"(3,8,7),(4,1,5),(4,5,8)),$);\n#90=IFCCARTESIANPOINTLIST3D(((0.,0.,0.),(5000.,0.,0.),(5000.,4000.,0.),"
    b"(0.,4000.,0.),(0.,0.,3000.),(5000.,0.,3000.),(5000.,4000.,3000.),(0.,4000.,3000.)));",
).replace(b"'Body','SweptSolid',(#26)", b"'Body','Tessellation',(#26)")


def test_an_ifc4_body_in_a_file_labelled_ifc2x3_is_named_with_its_line():
    """IfcOpenShell drops the instances the header's schema lacks without a word: the space came out as 'no triangles'
    and the zone was gone from the total with no reason a user could act on."""
    labelled = TESSELLATED.replace(b"FILE_SCHEMA(('IFC4'))", b"FILE_SCHEMA(('IFC2X3'))")
    request = _request(labelled)
    result = solve(request).result
    assert {z.id for z in result.zones} == {"102", "103"}
    (warning,) = [w for w in result.report.warnings if w.code == "ifc_lines_not_read"]
    lines = labelled.decode().splitlines()
    assert warning.details["foreign_entities"] == {"IFCTRIANGULATEDFACESET": 33, "IFCCARTESIANPOINTLIST3D": 34}
    assert lines[32].startswith("#26=IFCTRIANGULATEDFACESET") and lines[33].startswith("#90=IFCCARTESIANPOINTLIST3D")
    assert "FILE_SCHEMA IFC2X3 does not have: IFCTRIANGULATEDFACESET (line 33)" in warning.message
    assert warning.details["instances_defined"] - warning.details["instances_read"] == 2


def test_the_same_body_under_its_own_schema_is_measured_and_nothing_is_said():
    result = solve(_request(TESSELLATED)).result
    assert {z.id: z.volume for z in result.zones}["101"] == pytest.approx(60.0)
    assert "ifc_lines_not_read" not in [w.code for w in result.report.warnings]
