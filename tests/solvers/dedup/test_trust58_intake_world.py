"""A representation context's WorldCoordinateSystem no product can be placed in is refused at submission (a 422 naming
the instance, its line and the context's attribute, as the solve names it), no longer accepted and failed after the
202; a sound or merely far one (a georeferenced model's) passes intake."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

ZOO = (REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc").read_text()
TUNNEL = (REPO / "examples" / "dedup" / "tunnel_3rings.ifc").read_text()


def _intake(text: str) -> None:
    source = StoredInput.from_bytes("model.ifc", text.encode())
    SPEC.check_input(SPEC.input_of(parse_upload(source, {}), source))


@pytest.mark.parametrize("line, written, why", [
    ("#9=IFCCARTESIANPOINT((0.,0.,0.));", "#9=IFCCARTESIANPOINT((1.E308,0.,0.));",
     "#9=IfcCartesianPoint (line 16), the Location of #12=IfcAxis2Placement3D, the WorldCoordinateSystem of "
     "#13=IfcGeometricRepresentationContext: coordinate 1e+308 is not a finite number within ±1e+12"),
    ("#9=IFCCARTESIANPOINT((0.,0.,0.));", "#9=IFCCARTESIANPOINT((0.,0.,1.E11));",
     "more than the context's Precision 1e-05"),
    ("#10=IFCDIRECTION((0.,0.,1.));", "#10=IFCDIRECTION((0.,0.,0.));",
     "#10=IfcDirection (line 17), the Axis of #12=IfcAxis2Placement3D"),
    ("#11=IFCDIRECTION((1.,0.,0.));", "#11=IFCDIRECTION((0.,0.,-2.));",
     "#12=IfcAxis2Placement3D (line 19), the WorldCoordinateSystem of #13=IfcGeometricRepresentationContext: its "
     "Axis and RefDirection are parallel"),
])
def test_a_world_no_product_can_be_placed_in_is_refused_at_intake(line, written, why):
    assert line in ZOO
    with pytest.raises(InputRejected) as refused:
        _intake(ZOO.replace(line, written))  # before: accepted, the solve refused it after the 202
    (error,) = refused.value.errors
    assert error.loc == ("file",) and error.msg.startswith("the model's world coordinate system cannot place")
    assert why in error.msg


@pytest.mark.parametrize("text", [
    ZOO, TUNNEL, ZOO.replace("#9=IFCCARTESIANPOINT((0.,0.,0.));", "#9=IFCCARTESIANPOINT((1.E9,-2.5E6,30.));"),
], ids=["zoo", "tunnel", "georeferenced"])
def test_a_sound_world_passes_intake(text):
    _intake(text)
