"""A second round of mistakes with IFC files: a model context's Precision that is no tolerance (negative, or
metres across), an instance number written twice, a FILE_SCHEMA that is not the file's. Each is answered by the
right number with a warning naming the quantity, or refused naming the lines — never a model optimized from
the part IfcOpenShell happened to read."""

from __future__ import annotations

import re

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

ZOO = REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc"
TUNNEL = REPO / "examples" / "dedup" / "tunnel_3rings.ifc"
PRECISION = "'Model',3,1.E-05,"


def _solve(tmp_path, text: str, options: dict | None = None):
    path = tmp_path / "model.ifc"
    path.write_text(text)
    source = StoredInput.from_path(path)
    return solve(SPEC.input_of(parse_upload(source, options or {}), source))


def _refusal(tmp_path, text: str) -> str:
    with pytest.raises(InputRejected) as refused:
        _solve(tmp_path, text)
    return refused.value.errors[0].msg


@pytest.fixture(scope="module")
def zoo_result(tmp_path_factory):
    return _solve(tmp_path_factory.mktemp("zoo"), ZOO.read_text()).result


@pytest.mark.parametrize("precision, why", [("-1.E-05", "not a positive length"), ("0.", "not a positive length"),
                                            ("10.", "more than 0.1 m"), ("0.5", "more than 0.1 m")])
def test_a_precision_that_is_no_tolerance_is_not_used_and_is_named(tmp_path, zoo_result, precision, why):
    # before: a Precision of -1e-5 m was the tolerance (nothing verified), one of 10 m shared products 10 m apart
    result = _solve(tmp_path, ZOO.read_text().replace(PRECISION, f"'Model',3,{precision},")).result
    assert result.tolerance == pytest.approx(1e-5)
    warning = {w.code: w for w in result.report.warnings}["implausible_precision"]
    assert why in warning.message and f"Precision {float(precision):g} m" in warning.message
    assert warning.details["precision"] == pytest.approx(float(precision))
    assert result.report.details["source"]["units"]["tolerance"] == pytest.approx(1e-5)
    if float(precision) <= 0:  # a large Precision also coarsens the kernel's tessellation: other products are read
        assert [c.members for c in result.classes] == [c.members for c in zoo_result.classes]


def test_a_plausible_precision_is_the_tolerance_and_says_so(zoo_result):
    assert zoo_result.tolerance == pytest.approx(1e-5)
    assert "implausible_precision" not in {w.code for w in zoo_result.report.warnings}
    assert zoo_result.report.details["source"]["units"]["tolerance_from"] == "the model context's Precision"


def test_an_instance_number_defined_twice_is_refused_naming_both_lines(tmp_path):
    text = ZOO.read_text()
    # before: IfcOpenShell kept one of the two, a product went missing and the job "succeeded"
    twice = text.replace("#1016=IFCBUILDINGELEMENTPROXY", "#154=IFCBUILDINGELEMENTPROXY", 1)
    lines = twice.splitlines()
    first, second = [i + 1 for i, line in enumerate(lines) if line.startswith("#154=")]
    msg = _refusal(tmp_path, twice)
    assert f"#154 on lines {first} and {second}" in msg and "defined twice" in msg


def test_an_ifc4_model_labelled_ifc2x3_is_refused_naming_the_entities_it_lacks(tmp_path):
    text = TUNNEL.read_text()
    assert "FILE_SCHEMA(('IFC4'))" in text
    # before: the IFC4-only face sets were dropped and the job failed with "no product geometry could be processed"
    msg = _refusal(tmp_path, text.replace("FILE_SCHEMA(('IFC4'))", "FILE_SCHEMA(('IFC2X3'))"))
    line = next(i + 1 for i, row in enumerate(text.splitlines()) if re.match(r"#\d+=IFCPOLYGONALFACESET\(", row))
    assert "FILE_SCHEMA IFC2X3 does not have" in msg and f"IFCPOLYGONALFACESET (line {line})" in msg


def test_an_ifc2x3_model_labelled_ifc4x3_is_refused_rather_than_optimized_in_part(tmp_path):
    # before: the IFC2X3-only style assignments were dropped and the rest optimized, "succeeded"
    msg = _refusal(tmp_path, ZOO.read_text().replace("FILE_SCHEMA(('IFC2X3'))", "FILE_SCHEMA(('IFC4X3_ADD2'))"))
    assert "IFCPRESENTATIONSTYLEASSIGNMENT (line" in msg and "FILE_SCHEMA IFC4X3_ADD2" in msg


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be"])
def test_an_ifc_saved_as_utf16_is_refused_saying_so(encoding):
    # before: "not an IFC file (a STEP physical file starts with 'ISO-10303-21;')", which it does, in UTF-16
    source = StoredInput.from_bytes("model.ifc", ZOO.read_text().encode(encoding))
    with pytest.raises(InputRejected) as refused:
        parse_upload(source, {})
    assert "UTF-16" in refused.value.errors[0].msg


def test_a_complex_instance_is_not_named_an_entity_the_schema_lacks(tmp_path):
    # '#n=(IFCA(...)IFCB(...))' names its entities inside the brackets: before, its empty name was listed as an
    # entity the FILE_SCHEMA does not have, beside the real reason of the refusal
    text = ZOO.read_text().replace("#1016=IFCBUILDINGELEMENTPROXY", "#154=IFCBUILDINGELEMENTPROXY", 1)
    text = text.replace("ENDSEC;\nEND-ISO", "#99990=(IFCNAMEDUNIT(*,.LENGTHUNIT.)IFCSIUNIT(.MILLI.,.METRE.));\n"
                        "ENDSEC;\nEND-ISO", 1)
    assert "#99990=(" in text
    msg = _refusal(tmp_path, text)
    assert "defined twice" in msg and "does not have" not in msg


def test_a_model_with_no_length_unit_is_read_in_metres_and_says_so(tmp_path, zoo_result):
    # before: only report.details said 'none assigned: metres'; a model drawn in millimetres without a unit is
    # read 1000 times too large, with a tolerance in metres
    result = _solve(tmp_path, ZOO.read_text().replace("#8=IFCUNITASSIGNMENT((#7));", "#8=IFCUNITASSIGNMENT(());")).result
    (warning,) = [w for w in result.report.warnings if w.code == "length_unit_not_assigned"]
    assert "read in metres" in warning.message
    assert "length_unit_not_assigned" not in [w.code for w in zoo_result.report.warnings]
