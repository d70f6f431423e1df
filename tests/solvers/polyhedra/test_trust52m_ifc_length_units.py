"""An IFC project whose IfcUnitAssignment lists two length units: IfcOpenShell's kernel took one by their order (a
MILLIMETRE and FOOT project gave 60 m³ rooms one way round, 1.7e9 m³ the other) and the report's unit was their
product. Refused naming both; one unit listed twice is that unit."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

SPACES = (Path(__file__).parent / "data" / "ifcopenshell_spaces.ifc").read_text()  # MILLIMETRE (#2)
ASSIGNMENT = "#5=IFCUNITASSIGNMENT((#2,#3,#4));"
FOOT = ("#9001=IFCCONVERSIONBASEDUNIT(#9002,.LENGTHUNIT.,'FOOT',#9003);\n"
        "#9002=IFCDIMENSIONALEXPONENTS(1,0,0,0,0,0,0);\n#9003=IFCMEASUREWITHUNIT(IFCLENGTHMEASURE(0.3048),#9004);\n"
        "#9004=IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.);")


def _request(units: str, extra: str):
    text = SPACES.replace(ASSIGNMENT, f"#5=IFCUNITASSIGNMENT({units});\n{extra}")
    return parse_upload(StoredInput.from_bytes("model.ifc", text.encode()), None)


@pytest.mark.parametrize("units", ["(#2,#3,#4,#9001)", "(#9001,#3,#4,#2)"])
def test_two_length_units_are_refused_naming_both_whatever_their_order(units):
    with pytest.raises(InputRejected) as refused:
        _request(units, FOOT)
    (error,) = refused.value.errors
    assert error.loc == ("file",) and "MILLIMETRE (#2, 0.001 m)" in error.msg and "FOOT (#9001, 0.3048 m)" in error.msg


def test_one_length_unit_listed_twice_is_that_unit():
    request = _request("(#2,#3,#4,#9001)", "#9001=IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.);")
    assert request.source["units"]["factor"] == pytest.approx(1e-3)
    volumes = {z.id: z.volume for z in solve(request).result.zones}
    assert volumes == {"101": pytest.approx(60.0), "102": pytest.approx(48.0), "103": pytest.approx(1.0)}
