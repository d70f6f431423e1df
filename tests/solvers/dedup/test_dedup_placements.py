"""A placement no kernel can place with (a writer's 1e300, a zero or parallel direction in the root placement) is
named, with its line, where the refusal said only that no geometry could be processed."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

ZOO = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_text()


def _solved(text: str):
    source = StoredInput.from_bytes("model.ifc", text.encode())
    value = SPEC.input_of(parse_upload(source, {}), source)
    SPEC.check_input(value)
    return SPEC.solve(value, lambda *a: None).result


@pytest.mark.parametrize("line, written, why", [
    ("#19=IFCCARTESIANPOINT((0.,0.,0.));", "#19=IFCCARTESIANPOINT((1.E300,0.,0.));",
     "#19=IfcCartesianPoint (line 26) in the placement of 15 of the 15 products with geometry: coordinate 1e+300 is "
     "not a finite number within ±1e+12"),
    ("#19=IFCCARTESIANPOINT((0.,0.,0.));", "#19=IFCCARTESIANPOINT((1.E20,0.,0.));", "coordinate 1e+20"),
    ("#20=IFCDIRECTION((0.,0.,1.));", "#20=IFCDIRECTION((0.,0.,0.));",
     "#20=IfcDirection (line 27) in the placement of 15 of the 15 products with geometry: direction ratios "
     "(0.0, 0.0, 0.0) have no length"),
    ("#21=IFCDIRECTION((1.,0.,0.));", "#21=IFCDIRECTION((0.,0.,1.));",
     "#22=IfcAxis2Placement3D (line 29) in the placement of 15 of the 15 products with geometry: its Axis and "
     "RefDirection are parallel"),
])
def test_a_root_placement_no_kernel_can_use_is_named_with_its_line(line, written, why):
    assert ZOO.splitlines()[25] == "#19=IFCCARTESIANPOINT((0.,0.,0.));"
    with pytest.raises(InputRejected) as refused:
        _solved(ZOO.replace(line, written))
    (error,) = refused.value.errors
    assert error.loc == ("file",) and why in error.msg  # before: "no product geometry could be processed", no more


def test_a_product_left_unchanged_for_its_placement_says_so():
    """One product's own placement broken: the others are shared as before, the one left names its placement."""
    text = ZOO.replace("#42=IFCAXIS2PLACEMENT3D(#39,#40,#41);", "#42=IFCAXIS2PLACEMENT3D(#9999,#40,#41);\n"
                       "#9999=IFCCARTESIANPOINT((1.E300,0.,0.));")
    result = _solved(text)
    (warning,) = [w for w in result.report.warnings if w.code == "left_unchanged"]
    reasons = [p["reason"] for p in warning.details["products"]]
    assert any("#9999=IfcCartesianPoint" in r and "coordinate 1e+300" in r for r in reasons)
