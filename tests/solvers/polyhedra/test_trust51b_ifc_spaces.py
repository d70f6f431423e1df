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
