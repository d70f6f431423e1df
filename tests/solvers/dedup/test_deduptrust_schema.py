"""A header whose FILE_SCHEMA is not the schema the content was written in is refused naming the first line whose
attribute count does not fit the declared schema (IfcOpenShell's parser pads or drops the values without failing,
and the model was optimized and written as the header's schema), with the entity's count in each schema dedup reads
(ifcopenshell's schema definitions); an entity the declared schema has not is named as before."""

from __future__ import annotations

import re
import tempfile
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC, skeleton
from plantsolve.solvers.dedup.ifcio import misfits_schema
from plantsolve.solvers.dedup.upload import parse_upload
from plantsolve.solvers.step_file import written_attributes
from tests.conftest import REPO

ZOO = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_text()
TUNNEL = (REPO / "examples" / "dedup" / "tunnel_3rings.ifc").read_text()
COLUMNS = re.compile(r"^(#\d+=IFCCOLUMN\(.*)\);$", re.MULTILINE)


def _refusal(text: str) -> str:
    """The solve's refusal (intake's check, which refuses what its scan sees first, is left out: see
    test_trust58_intake_schema)."""
    source = StoredInput.from_bytes("model.ifc", text.encode())
    value = SPEC.input_of(parse_upload(source, {}), source)
    with pytest.raises(InputRejected) as refused:
        SPEC.solve(value, lambda *a: None)
    (error,) = refused.value.errors
    assert error.loc == ("file",)
    return error.msg


def _whole_file_read(text: str) -> str:
    """The same model with a comment in its data section: the line scan declines it, IfcOpenShell parses it whole."""
    return text.replace("\n#2=", "\n/* the whole file is parsed */ #2=", 1)


@pytest.mark.parametrize("read", [lambda t: t, _whole_file_read], ids=["scanned", "parsed whole"])
def test_an_ifc2x3_model_labelled_ifc4_is_refused_naming_its_first_ifc2x3_line(read):
    assert ZOO.splitlines()[961].startswith("#955=IFCCOLUMN(") and len(COLUMNS.findall(ZOO)) == 4
    msg = _refusal(read(ZOO.replace("FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4'))")))
    # before: optimized as IFC4, its columns written with a ninth attribute ($), with no word
    assert msg.startswith("line 962: #955=IFCCOLUMN is written with 8 attributes, and IfcColumn has 9 in the header's "
                          "FILE_SCHEMA IFC4 (8 in IFC2X3, 9 in IFC4X3_ADD2); 4 instance(s) of IfcColumn are so")
    assert "looks like IFC2X3" in msg


def test_an_ifc4_model_labelled_ifc2x3_is_refused_naming_its_first_ifc4_line():
    """IFC4's columns (their PredefinedType written) under an IFC2X3 header: a ninth value IfcOpenShell dropped."""
    text = COLUMNS.sub(r"\1,.COLUMN.);", ZOO)
    msg = _refusal(text)
    assert msg.startswith("line 962: #955=IFCCOLUMN is written with 9 attributes, and IfcColumn has 8 in the header's "
                          "FILE_SCHEMA IFC2X3 (9 in IFC4, 9 in IFC4X3_ADD2)")
    assert "looks like IFC4 or IFC4X3_ADD2" in msg


def test_ifc4_content_under_other_headers_is_refused_naming_the_line():
    lines = TUNNEL.splitlines()
    assert lines[68].startswith("#62=IFCCARTESIANPOINTLIST3D(") and "FILE_SCHEMA(('IFC4'))" in TUNNEL
    msg = _refusal(TUNNEL.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC2X3'))"))
    assert "FILE_SCHEMA IFC2X3 does not have: IFCCARTESIANPOINTLIST3D (line 69)" in msg
    msg = _refusal(TUNNEL.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC4X3_ADD2'))"))
    assert msg.startswith("line 69: #62=IFCCARTESIANPOINTLIST3D is written with 1 attribute, and "
                          "IfcCartesianPointList3D has 2 in the header's FILE_SCHEMA IFC4X3_ADD2 (none in IFC2X3, 1 in "
                          "IFC4)") and "looks like IFC4" in msg


def test_an_ifc2x3_model_labelled_ifc4x3_is_refused_naming_a_line():
    msg = _refusal(ZOO.replace("FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4X3_ADD2'))"))
    assert "IFCPRESENTATIONSTYLEASSIGNMENT (line 993)" in msg


@pytest.mark.parametrize("line, count", [
    ("#955=IFCCOLUMN('3$BNBp3Jn5twsNIlAsNjjL',#5,'column_a',$,'column',#945,#954,$);", 8),
    ("#7=IFCPROPERTYSINGLEVALUE('a, (b)','it''s, (c',IFCLABEL('x,y'),$);", 4),  # commas and brackets in strings
    ("#8=IFCPOLYLOOP((#1,#2,#3));", 1),
    ("#9 = IFCCARTESIANPOINTLIST3D(((0.,0.,0.),(1.,0.,0.)),$);", 2),
    ("#10=IFCPRESENTATIONLAYERASSIGNMENT();", 0),
    ("#11=(IFCLENGTHMEASURE()IFCNAMEDUNIT(*,.LENGTHUNIT.));", None),  # a complex instance: its parts have their own
])
def test_the_attributes_a_line_writes_are_counted_at_its_first_bracket_level(line, count):
    assert written_attributes(line) == count


def test_the_line_scan_tells_a_model_of_another_schema_by_its_first_instances():
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "model.ifc"
        for header, misfits in (("IFC2X3", False), ("IFC4", True)):
            path.write_text(ZOO.replace("FILE_SCHEMA(('IFC2X3'))", f"FILE_SCHEMA(('{header}'))"))
            found = skeleton.read(path)
            assert misfits_schema(found.model(), found.skeleton, found.index.lines) is misfits
