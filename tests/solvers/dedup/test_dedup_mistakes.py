"""The mistakes users make with dedup: a tolerance meant in millimetres given to a metre model, one meant in metres
given to a millimetre model, a file of another kind. Each is refused naming the field and what is wrong, warned
naming the quantity, or answered right in the file's unit, which the result names."""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.util.unit
import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.artifacts import classes_csv
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO
from tests.solvers.dedup.support import run

ZOO = REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc"


def codes(result) -> dict:
    return {w.code: w for w in result.report.warnings}


def zoo() -> ifcopenshell.file:
    return ifcopenshell.open(str(ZOO))


def test_a_tolerance_meant_in_mm_given_to_a_metre_model_is_refused_at_submission():
    with pytest.raises(InputRejected) as refused:
        run(zoo(), tolerance=1)
    (error,) = refused.value.errors
    assert error.loc == ("options", "tolerance")
    for said in ("tolerance 1 m (", "IfcUnitAssignment", "more than 0.1 m", "meant in mm"):
        assert said in error.msg, said
    # the same number in a millimetre model is 1 mm: accepted at submission
    model = ifcopenshell.util.unit.convert_file_length_units(zoo(), "MILLIMETER")
    source = StoredInput.from_bytes("model.ifc", model.to_string().encode())
    SPEC.check_input(SPEC.input_of(parse_upload(source, {"tolerance": 1}), source))
    source = StoredInput.from_bytes("model.ifc", model.to_string().encode())
    with pytest.raises(InputRejected) as refused:  # 200 mm is not
        SPEC.check_input(SPEC.input_of(parse_upload(source, {"tolerance": 200}), source))
    assert "tolerance 200 mm = 0.2 m" in refused.value.errors[0].msg


def test_a_tolerance_the_intake_scan_could_not_judge_is_refused_by_the_solve_naming_product_size_and_extent():
    source = StoredInput.from_path(ZOO)  # check_input not run: as for a file whose unit the text scan cannot read
    with pytest.raises(InputRejected) as refused:
        solve(SPEC.input_of(parse_upload(source, {"tolerance": 0.5}), source))
    (error,) = refused.value.errors
    assert error.loc == ("options", "tolerance")
    for said in ("tolerance 0.5 m", "24% of a product's size", "2.083 m across", "104.3 m", "meant in mm"):
        assert said in error.msg, said


def test_a_coarse_tolerance_below_the_refusal_is_warned_and_the_deviations_show_it():
    solved = run(zoo(), tolerance=0.02)
    warning = codes(solved.result)["implausible_tolerance"]
    assert warning.details["tolerance_m"] == pytest.approx(0.02) and warning.details["unit"] == "m"
    assert warning.details["median_product_size"] == pytest.approx(2.083, abs=1e-3)
    assert "options.tolerance" in warning.message
    assert solved.result.tolerance == 0.02 and solved.result.units == "m"


def test_the_default_tolerance_is_plausible_and_its_origin_is_stated():
    result = run(zoo()).result
    assert "implausible_tolerance" not in codes(result)
    assert result.units == "m" and result.metres_per_unit == 1.0 and result.length_unit == "METRE"
    units = result.report.details["source"]["units"]
    assert units == {"file_unit": "m", "ifc_name": "METRE", "metres_per_unit": 1.0, "basis": "IfcUnitAssignment",
                     "tolerance": 1e-5, "tolerance_unit": "m", "tolerance_from": "the model context's Precision"}


def test_a_millimetre_model_takes_its_tolerance_in_millimetres_and_says_so():
    metres = run(zoo()).result
    model = ifcopenshell.util.unit.convert_file_length_units(zoo(), "MILLIMETER")
    result = run(model, tolerance=1).result  # 1 mm: plausible in a mm model, the refusal above in a metre one
    assert result.units == "mm" and result.metres_per_unit == pytest.approx(1e-3) and result.tolerance == 1
    assert "implausible_tolerance" not in codes(result)
    assert sorted(len(c.members) for c in result.classes) == sorted(len(c.members) for c in metres.classes)
    moved = [t[3] for c in result.classes for t in c.transforms]  # translations in mm: the metre ones × 1000
    moved_m = [t[3] for c in metres.classes for t in c.transforms]
    assert sorted(moved) == pytest.approx(sorted(1000 * x for x in moved_m), rel=1e-9)
    # a tolerance meant in metres given to the mm model: below what its coordinates resolve
    tiny = run(ifcopenshell.util.unit.convert_file_length_units(zoo(), "MILLIMETER"), tolerance=1e-7).result
    warning = codes(tiny)["implausible_tolerance"]
    assert "mm" in warning.message and "metres given to a millimetre model" in warning.message


def test_another_kinds_json_is_refused_naming_it():
    content = (REPO / "examples" / "polyhedra" / "gable_house.json").read_bytes()
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("house.json", content), None)
    assert "a polyhedra request" in refused.value.errors[0].msg and "/v1/polyhedra/jobs" in refused.value.errors[0].msg


@pytest.mark.parametrize("path, holds", [("examples/polyhedra/two_offices.idf", "an EnergyPlus IDF"),
                                         ("examples/polyhedra/offices.xml", "a gbXML building model")])
def test_a_zone_file_named_ifc_is_refused_naming_what_it_holds(path, holds):
    with pytest.raises(InputRejected) as refused:
        parse_upload(StoredInput.from_bytes("model.ifc", (REPO / path).read_bytes()), None)
    assert holds in refused.value.errors[0].msg


def test_a_step_cad_model_is_refused_naming_its_schema():
    step = (b"ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION((''),'2;1');\nFILE_NAME('a','',(''),(''),'','','');\n"
            b"FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\nENDSEC;\nDATA;\n"
            b"#1=CARTESIAN_POINT('',(0.,0.,0.));\nENDSEC;\nEND-ISO-10303-21;\n")
    source = StoredInput.from_bytes("part.ifc", step)
    with pytest.raises(InputRejected) as refused:
        SPEC.check_input(SPEC.input_of(parse_upload(source, None), source))
    assert "STEP CAD model (AP214)" in refused.value.errors[0].msg


def test_a_tolerance_beyond_its_schema_bound_is_a_422_at_intake():
    source = StoredInput.from_path(ZOO)
    for bad in (0, -1, 1e4):
        with pytest.raises(InputRejected) as refused:
            parse_upload(source, {"tolerance": bad})
        assert refused.value.errors[0].loc == ("options", "tolerance")


def test_classes_csv_names_the_unit_of_its_lengths():
    model = ifcopenshell.util.unit.convert_file_length_units(zoo(), "MILLIMETER")
    header = classes_csv(run(model).result).decode().splitlines()[0].split(",")
    assert "class_max_deviation [mm]" in header and "t03 [mm]" in header and "t23 [mm]" in header
    assert "t00 [1]" in header and "t33 [1]" in header
