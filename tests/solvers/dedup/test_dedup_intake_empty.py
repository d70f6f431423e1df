"""Models with nothing to share are refused at submission (a 422 naming why), not accepted and failed at stage
input: a STEP header with an empty DATA section, a model without products, products without geometry."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from tests.conftest import REPO

HEADER = ("ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('ViewDefinition [CoordinationView]'),'2;1');\n"
          "FILE_NAME('e.ifc','2026-01-01T00:00:00',(''),(''),'','','');\nFILE_SCHEMA(('IFC4'));\nENDSEC;\nDATA;\n")
END = "ENDSEC;\nEND-ISO-10303-21;\n"
# the tunnel example's project, units and contexts (#1-#14) and its site, building and their relations
PROJECT = "".join(line + "\n" for line in (REPO / "examples" / "dedup" / "tunnel_3rings.ifc").read_text().splitlines()
                  if line.startswith(tuple(f"#{i}=" for i in range(1, 24))))


def refusal(text: str) -> str:
    source = StoredInput.from_bytes("model.ifc", text.encode())
    with pytest.raises(InputRejected) as refused:
        SPEC.check_input(SPEC.input_of(SPEC.parse_upload(source, None), source))
    (error,) = refused.value.errors
    assert error.loc == ("file",)
    return error.msg


def test_a_header_with_an_empty_data_section_is_refused_at_submission():
    assert "DATA section has no instance" in refusal(HEADER + END)


def test_a_model_without_products_is_refused_naming_what_it_holds():
    without = "".join(line + "\n" for line in PROJECT.splitlines()
                      if "IFCSITE" not in line and "IFCBUILDING(" not in line)
    msg = refusal(HEADER + without + END)
    assert "has no product" in msg and "4 IfcDirection" in msg


def test_products_without_geometry_are_refused_at_submission():
    assert "IFCSITE" in PROJECT  # a site and a building: products, neither with a Representation
    assert "no product of the model has geometry" in refusal(HEADER + PROJECT + END)

