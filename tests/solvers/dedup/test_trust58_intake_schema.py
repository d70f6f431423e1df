"""A model of another schema than its header's FILE_SCHEMA is refused at submission (a 422 naming the line and the
schema the content fits), no longer accepted and failed after the 202; a model of its header's schema passes; a
UTF-16 file without its mark is still named UTF-16 (base's test, used by the header check)."""

from __future__ import annotations

import re

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.ifcio import check_header
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

ZOO = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_text()
TUNNEL = (REPO / "examples" / "dedup" / "tunnel_3rings.ifc").read_text()


def _intake(text: str) -> None:
    source = StoredInput.from_bytes("model.ifc", text.encode())
    SPEC.check_input(SPEC.input_of(parse_upload(source, {}), source))


def _refused_at_intake(text: str) -> str:
    with pytest.raises(InputRejected) as refused:
        _intake(text)
    (error,) = refused.value.errors
    assert error.loc == ("file",)
    return error.msg


@pytest.mark.parametrize("text", [ZOO, TUNNEL], ids=["IFC2X3", "IFC4"])
def test_a_model_of_its_headers_schema_passes_intake(text):
    _intake(text)


@pytest.mark.parametrize("header", ["IFC4", "IFC4X3_ADD2"])
def test_an_ifc2x3_model_under_a_later_header_is_refused_at_intake_naming_its_first_misfit(header):
    assert ZOO.splitlines()[961].startswith("#955=IFCCOLUMN(")
    msg = _refused_at_intake(ZOO.replace("FILE_SCHEMA(('IFC2X3'))", f"FILE_SCHEMA(('{header}'))"))
    # before: accepted (202), the job failed in the parse
    assert msg.startswith(f"line 962: #955=IFCCOLUMN is written with 8 attributes, and IfcColumn has 9 in the header's "
                          f"FILE_SCHEMA {header} (8 in IFC2X3, ")
    assert "looks like IFC2X3" in msg


def test_an_ifc4_model_under_an_ifc2x3_header_is_refused_at_intake_naming_the_entity():
    lines = TUNNEL.splitlines()
    assert lines[68].startswith("#62=IFCCARTESIANPOINTLIST3D(")
    msg = _refused_at_intake(TUNNEL.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC2X3'))"))
    assert msg.startswith("line 69: #62=IFCCARTESIANPOINTLIST3D is no entity of the header's FILE_SCHEMA IFC2X3 (it "
                          "is one of IFC4 and IFC4X3_ADD2)")


def test_a_misfit_in_a_later_chunk_is_named_by_its_line_in_the_file():
    """Points of over 1 MB before the model: its products (and the misfit) are in the second chunk intake reads,
    and the line is counted across the chunks."""
    filler = "".join(f"#{900000 + k}=IFCCARTESIANPOINT((0.,0.,{k}.));\n" for k in range(40_000))
    text = ZOO.replace("FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4'))").replace("DATA;\n", "DATA;\n" + filler, 1)
    assert len(filler.encode()) > 1 << 20
    line = text[:text.index("#955=IFCCOLUMN(")].count("\n") + 1
    assert _refused_at_intake(text).startswith(f"line {line}: #955=IFCCOLUMN is written with 8 attributes")


def test_utf16_without_its_mark_is_named_as_such():
    text = re.sub(r"\s+", " ", ZOO[:200])
    with pytest.raises(InputRejected) as refused:
        check_header(text.encode("utf-16-le"), b"")
    assert "UTF-16" in refused.value.errors[0].msg
    with pytest.raises(InputRejected) as refused:  # zeros alone are no text: named as no IFC file
        check_header(b"\x00" * 80 + b"solid", b"")
    assert "not an IFC file" in refused.value.errors[0].msg
