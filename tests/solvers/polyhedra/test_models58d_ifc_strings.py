"""Polyhedra's notes on an IFC file count the instances it defines, not what its strings and comments hold: a note
'a;#3=B' was an instance "left out" (ifc_lines_not_read, "left 1 of the file's 68 instances out ... FOO (line 8)");
and a file of CR line ends has its lines counted (a misfit was named on "line 1")."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from tests.conftest import REPO

IFC = (REPO / "tests" / "solvers" / "polyhedra" / "data" / "ifcopenshell_spaces.ifc").read_text()


def _read(text: str):
    return parse_upload(StoredInput.from_bytes("spaces.ifc", text.encode()), None)


def _warnings(request) -> dict[str, dict]:
    return {w["code"]: w for w in request.source["warnings"]}


@pytest.mark.parametrize("written", ["#999001=IFCPROPERTYSINGLEVALUE('Note',$,IFCTEXT('a;#777=FOO'),$);\n",
                                     "/* exported;\n#777=FOO( */\n"], ids=["string", "comment"])
def test_a_definition_inside_a_string_or_comment_is_no_instance_left_out(written):
    volumes = {z.id: z.volume for z in solve(_read(IFC)).result.zones}
    request = _read(IFC.replace("DATA;\n", "DATA;\n" + written, 1))
    assert not {"ifc_schema_misfit", "ifc_lines_not_read"} & set(_warnings(request))  # before: FOO (line 8) left out
    assert {z.id: z.volume for z in solve(request).result.zones} == pytest.approx(volumes)


def test_an_entity_left_out_is_still_named_by_its_line_in_a_file_of_cr_line_ends():
    text = IFC.replace("DATA;\n", "DATA;\n#999001=IFCFOO($);\n", 1)
    note = _warnings(_read(text.replace("\n", "\r")))["ifc_lines_not_read"]
    assert note["details"]["foreign_entities"] == {"IFCFOO": 8}  # before: line 1
    assert note["details"]["instances_defined"] - note["details"]["instances_read"] == 1


def test_a_misfit_in_a_file_of_cr_line_ends_is_named_by_its_line():
    text = IFC.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC2X3'))")
    line = text[:text.index("#34=IFCQUANTITYAREA(")].count("\n") + 1
    note = _warnings(_read(text.replace("\n", "\r")))["ifc_schema_misfit"]
    assert note["details"]["line"] == line and f"line {line}: #34=IFCQUANTITYAREA" in note["message"]  # before: 1
