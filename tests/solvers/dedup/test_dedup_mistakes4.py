"""A fourth round of mistakes with dedup's files: an IFC 4.3 model labelled with a 4.3 name IfcOpenShell does not
read; products sharing a GlobalId."""

from __future__ import annotations

import re

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

TUNNEL = (REPO / "examples" / "dedup" / "tunnel_3rings.ifc").read_text()
ZOO = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_text()


def _checked(text: str):
    source = StoredInput.from_bytes("model.ifc", text.encode())
    value = SPEC.input_of(parse_upload(source, {}), source)
    SPEC.check_input(value)
    return value


@pytest.mark.parametrize("label", ["IFC4X3", "IFC4X3_ADD1", "IFC4X3_TC1"])
def test_an_ifc43_label_ifcopenshell_does_not_read_is_refused_at_submission_naming_the_one_it_does(label):
    """'IFC4X3' passed the check that listed IFC4X3 as accepted, and the job then failed in the parse with 'unknown or
    unsupported IFC schema: Unsupported schema: IFC4X3'. Now the submission is refused naming the label to write."""
    assert "FILE_SCHEMA(('IFC4'))" in TUNNEL
    with pytest.raises(InputRejected) as refused:
        _checked(TUNNEL.replace("FILE_SCHEMA(('IFC4'))", f"FILE_SCHEMA(('{label}'))"))
    (error,) = refused.value.errors
    assert error.loc == ("file",) and error.msg.startswith(f"FILE_SCHEMA {label!r}: IFC 4.3 is read as its final "
                                                           "release, 'IFC4X3_ADD2'")
    # the final label passes the label check; the tunnel's IFC4 content under it is then refused as such
    with pytest.raises(InputRejected) as refused:
        _checked(TUNNEL.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC4X3_ADD2'))"))
    assert "IFC 4.3 is read as" not in refused.value.errors[0].msg and "looks like IFC4" in refused.value.errors[0].msg



def test_products_sharing_a_globalid_are_named_and_each_is_verified():
    """Two columns with one GlobalId (a copy the exporter did not renumber): the proof keyed the products by GlobalId,
    so it checked 13 of the 14 processed and the class listed the same GlobalId twice, no word on which product. Now
    each is verified by its instance and the shared GlobalId is named with both instances."""
    first, second = re.findall(r"IFCCOLUMN\('([^']+)'", ZOO)[:2]
    whole = SPEC.solve(_checked(ZOO), lambda *a: None).result
    result = SPEC.solve(_checked(ZOO.replace(second, first)), lambda *a: None).result
    assert result.verification.products_checked == whole.verification.products_checked == 14
    (warning,) = [w for w in result.report.warnings if w.code == "duplicate_global_ids"]
    assert warning.details == {"global_ids": {first: ["#955", "#970"]}, "count": 1}
    assert "#955 IfcColumn 'column_a', #970 IfcColumn 'column_b'" in warning.message
    assert "duplicate_global_ids" not in {w.code for w in whole.report.warnings}


def test_a_json_request_uploaded_as_a_file_is_solved_from_its_base64_model():
    """A .json upload (the request, the model base64 in 'file', as the README offers) was refused 'not an IFC file: it
    holds a JSON document': the loader took the uploaded JSON for the model. Now its 'file' is the model."""
    import base64
    import json

    body = {"filename": "zoo.ifc", "file": base64.b64encode(ZOO.encode()).decode(), "options": {"postpass": False}}
    source = StoredInput.from_bytes("request.json", json.dumps(body).encode())
    value = SPEC.input_of(parse_upload(source, {}), source)
    SPEC.check_input(value)
    result = SPEC.solve(value, lambda *a: None).result
    direct = SPEC.solve(_checked(ZOO), lambda *a: None).result
    assert result.products_shared == direct.products_shared == 6 and result.schema_ == "IFC2X3"
    source = StoredInput.from_bytes("request.json", json.dumps({"filename": "zoo.ifc"}).encode())
    with pytest.raises(InputRejected, match="no file: send the IFC file as a multipart upload, or base64 in 'file'"):
        SPEC.check_input(SPEC.input_of(parse_upload(source, {}), source))
