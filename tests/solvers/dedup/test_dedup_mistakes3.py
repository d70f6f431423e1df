"""A third round of mistakes with dedup's options and files: an entity type the file's schema lacks or that is no
product, one no product of the model is, a binary file of another kind; and the answer of a model whose instances
are written in another order."""

from __future__ import annotations

import random

import pytest
import trimesh

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

ZOO = REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc"


def _checked(content: bytes, options: dict | None = None):
    source = StoredInput.from_bytes("model.ifc", content)
    value = SPEC.input_of(parse_upload(source, options or {}), source)
    SPEC.check_input(value)
    return value


@pytest.mark.parametrize("names, index, why", [
    (["IfcColumn", "IfcWal"], 1, "'IfcWal' is no entity of the file's schema IFC2X3"),
    (["IfcPipeSegment"], 0, "'IfcPipeSegment' is no entity of the file's schema IFC2X3"),  # IFC4's name
    (["IfcCartesianPoint"], 0, "IfcCartesianPoint is no product (IfcProduct subtype) in IFC2X3"),
])
def test_an_entity_type_the_schema_lacks_or_that_is_no_product_is_refused_naming_it(names, index, why):
    # before: accepted; the run selected nothing and said "0 of 15 products share geometry", left_unchanged only
    with pytest.raises(InputRejected) as refused:
        _checked(ZOO.read_bytes(), {"entity_types": names})
    (error,) = refused.value.errors
    assert error.loc == ("options", "entity_types", index) and error.msg.startswith(why)


def test_an_entity_type_no_product_of_the_model_is_is_a_warning_naming_it():
    result = SPEC.solve(_checked(ZOO.read_bytes(), {"entity_types": ["IfcColumn", "ifcwall"]}), lambda *a: None).result
    warning = {w.code: w for w in result.report.warnings}["entity_types_unmatched"]
    assert warning.details == {"entity_types": ["ifcwall"]} and "IfcColumn" in warning.message
    assert result.products_shared == 1  # the columns that are copies of one another still share
    every = SPEC.solve(_checked(ZOO.read_bytes(), {"entity_types": ["IfcColumn"]}), lambda *a: None).result
    assert "entity_types_unmatched" not in {w.code for w in every.report.warnings}


def test_a_binary_stl_sent_as_ifc_is_not_called_utf16_text():
    stl = trimesh.creation.box().export(file_type="stl")  # its 80-byte header is zeros
    # before: "the file is UTF-16 text ... save it as UTF-8 or ANSI"
    with pytest.raises(InputRejected, match=r"not an IFC file: it holds a binary STL mesh \(a STEP physical file starts "
                                            r"with 'ISO-10303-21;'\)"):
        parse_upload(StoredInput.from_bytes("model.ifc", stl), {})


def test_the_instances_in_another_order_give_the_same_classes():
    text = ZOO.read_text()
    start, end = text.index("DATA;") + len("DATA;"), text.rindex("ENDSEC;")
    lines = [line for line in text[start:end].split("\n") if line.strip()]
    random.Random(7).shuffle(lines)
    shuffled = text[:start] + "\n" + "\n".join(lines) + "\n" + text[end:]

    def classes(content: str):
        result = SPEC.solve(_checked(content.encode()), lambda *a: None).result
        return result.products_shared, sorted(sorted(c.members) for c in result.classes), result.optimized_bytes

    before, after = classes(text), classes(shuffled)
    assert before == after and before[0] == 6
