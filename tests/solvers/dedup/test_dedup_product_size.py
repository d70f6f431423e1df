"""A model whose IfcUnitAssignment names another unit than its numbers are written in: the geometry comes out the
same, but `units` (and the tolerance, every deviation and translation with it) is 1000 times off. The median
product's size says so, naming the unit the numbers are likely in."""

from __future__ import annotations

import ifcopenshell
import ifcopenshell.util.unit
import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.dedup import SPEC
from plantsolve.solvers.dedup.solve import solve
from plantsolve.solvers.dedup.tolerance import judge_product_size
from plantsolve.solvers.dedup.upload import parse_upload
from tests.conftest import REPO

ZOO = REPO / "examples" / "dedup" / "zoo_ifc2x3.ifc"
METRE = "IFCSIUNIT(*,.LENGTHUNIT.,$,.METRE.)"


def _solve(tmp_path, text: str):
    path = tmp_path / "model.ifc"
    path.write_text(text)
    source = StoredInput.from_path(path)
    return solve(SPEC.input_of(parse_upload(source, {}), source)).result


def _codes(result) -> set[str]:
    return {w.code for w in result.report.warnings}


def test_millimetres_stated_over_numbers_in_metres_are_named_with_the_likely_unit(tmp_path):
    text = ZOO.read_text()
    assert text.count(METRE) == 1
    result = _solve(tmp_path, text.replace(METRE, "IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.)"))
    assert result.units == "mm"
    (warning,) = [w for w in result.report.warnings if w.code == "implausible_product_size"]
    assert warning.details["likely_units"][0] == "m"
    assert warning.details["metres"] == pytest.approx(warning.details["value"] * 1e-3)
    assert warning.details["metres"] < 0.005 and "written in m?" in warning.message


def test_metres_stated_over_numbers_in_millimetres_are_named(tmp_path):
    model = ifcopenshell.util.unit.convert_file_length_units(ifcopenshell.open(str(ZOO)), "MILLIMETER")
    text = model.to_string()
    millimetre_unit = "IFCSIUNIT(*,.LENGTHUNIT.,.MILLI.,.METRE.)"
    assert text.count(millimetre_unit) == 1
    (warning,) = [w for w in _solve(tmp_path, text.replace(millimetre_unit, METRE)).report.warnings
                  if w.code == "implausible_product_size"]
    assert warning.details["metres"] > 200 and warning.details["likely_units"][0] == "mm"


def test_a_model_in_its_stated_unit_says_nothing(tmp_path):
    assert "implausible_product_size" not in _codes(_solve(tmp_path, ZOO.read_text()))
    converted = ifcopenshell.util.unit.convert_file_length_units(ifcopenshell.open(str(ZOO)), "MILLIMETER")
    assert "implausible_product_size" not in _codes(_solve(tmp_path, converted.to_string()))


@pytest.mark.parametrize(("median", "unit", "mpu", "warned"), [
    (0.03, "m", 1.0, False),  # a bolt
    (60.0, "m", 1.0, False),  # a girder
    (4.9e-3, "m", 1.0, True), (250.0, "m", 1.0, True), (2.0, "mm", 1e-3, True), (2000.0, "mm", 1e-3, False)])
def test_the_range_is_the_readme_table(median, unit, mpu, warned):
    assert bool(judge_product_size(median, unit, mpu)) is warned
