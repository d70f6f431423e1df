"""A representation context's WorldCoordinateSystem that no product can be placed in (a writer's 1e308, a zero or
parallel axis, a location whose doubles are further apart than the context's Precision) is refused naming the
context's attribute, the instance and its line. The kernel tessellates without it, so the model was optimized and its
deviations 'verified' without a word for points that are all meaningless."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

ZOO = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_text()
WCS = ("#9=IFCCARTESIANPOINT((0.,0.,0.));", "#10=IFCDIRECTION((0.,0.,1.));", "#11=IFCDIRECTION((1.,0.,0.));",
       "#12=IFCAXIS2PLACEMENT3D(#9,#10,#11);", "#13=IFCGEOMETRICREPRESENTATIONCONTEXT($,'Model',3,1.E-05,#12,$);")


def _solved(text: str):
    source = StoredInput.from_bytes("model.ifc", text.encode())
    value = SPEC.input_of(parse_upload(source, {}), source)
    SPEC.check_input(value)
    return SPEC.solve(value, lambda *a: None).result


def test_the_zoo_places_its_world_as_the_tests_say():
    lines = ZOO.splitlines()
    assert [lines.index(line) + 1 for line in WCS] == [16, 17, 18, 19, 20]
    assert ZOO.count("#9,") == ZOO.count("#10,") == ZOO.count("#11)") == ZOO.count("#12,") == 1  # the WCS's alone


@pytest.mark.parametrize("written, why", [
    ("#9=IFCCARTESIANPOINT((1.E308,0.,0.));",
     ("#9=IfcCartesianPoint (line 16), the Location of #12=IfcAxis2Placement3D, the WorldCoordinateSystem of "
      "#13=IfcGeometricRepresentationContext: coordinate 1e+308 is not a finite number within ±1e+12")),
    ("#9=IFCCARTESIANPOINT((0.,-1.E20,0.));", "coordinate -1e+20 is not a finite number"),
    # 1e11: doubles there are 1.5e-5 apart, more than the context's Precision 1e-5 (1e10's are 1.9e-6)
    ("#9=IFCCARTESIANPOINT((0.,0.,1.E11));", "more than the context's Precision 1e-05"),
    ("#10=IFCDIRECTION((0.,0.,0.));",
     ("#10=IfcDirection (line 17), the Axis of #12=IfcAxis2Placement3D, the WorldCoordinateSystem of "
      "#13=IfcGeometricRepresentationContext: direction ratios (0.0, 0.0, 0.0) have no length")),
    ("#11=IFCDIRECTION((0.,0.,-2.));",
     ("#12=IfcAxis2Placement3D (line 19), the WorldCoordinateSystem of #13=IfcGeometricRepresentationContext: its "
      "Axis and RefDirection are parallel")),
])
def test_a_world_coordinate_system_no_product_can_be_placed_in_is_refused_naming_it(written, why):
    line = next(line for line in WCS if line.split("=")[0] == written.split("=")[0])
    with pytest.raises(InputRejected) as refused:
        _solved(ZOO.replace(line, written))  # before: optimized, every deviation 'verified', no warning
    (error,) = refused.value.errors
    assert error.loc == ("file",) and "world coordinate system" in error.msg and why in error.msg


def test_a_world_coordinate_system_away_from_the_origin_is_optimized_as_at_it():
    """1e9 (doubles 1.2e-7 apart, under the Precision 1e-5) and turned about Z: a georeferenced model's, shared the
    same (the kernel places without it, and the written file keeps it)."""
    clean = _solved(ZOO)
    moved = _solved(ZOO.replace(WCS[0], "#9=IFCCARTESIANPOINT((1.E9,-2.5E6,30.));")
                    .replace(WCS[2], "#11=IFCDIRECTION((0.6,0.8,0.));"))
    assert [c.members for c in moved.classes] == [c.members for c in clean.classes]
    assert moved.products_shared == clean.products_shared == 6
    assert moved.verification.semantic_counts_equal
    assert moved.verification.max_deviation == clean.verification.max_deviation
    assert {w.code for w in moved.report.warnings} == {w.code for w in clean.report.warnings}
