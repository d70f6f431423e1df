"""A field file whose coordinates are millimetres under another length unit ('% Length unit: in', 'x [cm]', a header
without units under a request in cm): the grid is 10 to 1000 times the meter, the pipe sees the middle of one or two
cells, and S moved from 0.914 to 0.963 without a word (the grid-reach warning fires only past 50 radii). Now warned,
naming the file and the likely unit, from the field's own structure (it changes by half only far beyond the liner
section); genuine fields, the shipped example and a coil's field exported over a large air box, read clean."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from plantsolve.schemas.flowmeter import FlowmeterRequest
from plantsolve.solvers.flowmeter.solve import solve
from plantsolve.solvers.flowmeter.validation import check_input
from tests.conftest import wait_for

EXAMPLES = Path(__file__).parents[3] / "examples" / "flowmeter"
COMSOL = (EXAMPLES / "magnet_comsol.txt").read_text()
STATED = "% Length unit:        mm"


def request(text: str, units: str = "mm") -> FlowmeterRequest:
    """The shipped example's meter (R 50 mm, liner 300 mm) in ``units``, its field the file ``text``."""
    body = json.loads((EXAMPLES / "field_points.json").read_text())
    del body["magnetic_field"]
    scale = {"mm": 1.0, "cm": 0.1, "in": 1 / 25.4, "m": 1e-3}[units]
    body["units"] = units
    body["pipe"] = {k: v * scale for k, v in body["pipe"].items()}
    body["electrodes"]["half_length"] *= scale
    body["options"]["probe_points"] = [[c * scale for c in p] for p in body["options"]["probe_points"]]
    body["options"]["magnetic_field_file"] = text
    return FlowmeterRequest.model_validate(body)


def solved(req: FlowmeterRequest):
    check_input(req)
    return solve(req).result


def grid_warnings(result) -> list:
    return [w for w in result.report.warnings if w.code == "implausible_field_grid"]


def test_the_shipped_field_file_in_mm_reads_clean():
    result = solved(request(COMSOL))
    assert result.sensitivity == pytest.approx(0.91426, abs=1e-5)
    assert not [w for w in result.report.warnings if w.code.startswith("implausible")]


@pytest.mark.parametrize("unit", ["in", "cm", "m", "ft"])
def test_millimetres_under_another_stated_unit_are_warned_naming_the_file_and_mm(unit):
    result = solved(request(COMSOL.replace(STATED, f"% Length unit:        {unit}")))
    assert abs(result.sensitivity - 0.91426) > 0.04  # the field's variation across the pipe is lost: hence the warning
    (warning,) = grid_warnings(result)
    assert warning.details["likely_unit"] == "mm" and warning.details["read_in"] == unit
    assert "options.magnetic_field_file" in warning.message or "options.magnetic_field_file" in warning.details["quantity"]
    assert f"in mm read as '{unit}'?" in warning.message


@pytest.mark.parametrize("units", ["cm", "in"])
def test_a_header_without_a_unit_under_a_request_in_cm_or_inches_is_warned_naming_mm(units):
    result = solved(request(COMSOL.replace(STATED + "\n", ""), units))
    (warning,) = grid_warnings(result)
    assert warning.details == {**warning.details, "quantity": "options.magnetic_field_file", "likely_unit": "mm",
                               "read_in": units}
    assert "states no length unit" in warning.message


def coil_on_a_large_box(length_unit: str, factor: float) -> str:
    """A saddle coil's field (R = 50 mm; B_y halves 80 mm along z, grows towards the windings at y = +-65 mm)
    exported over an air box of +-500 mm across and +-900 mm along: six liner sections out, the coil within one.
    Coordinates written as mm times ``factor`` under ``length_unit``."""
    x = np.linspace(-500.0, 500.0, 21)
    z = np.linspace(-900.0, 900.0, 37)
    gx, gy, gz = np.meshgrid(x, x, z, indexing="ij")
    by = 0.01 / (1 + (gz / 80.0) ** 2) * (1 + 0.3 * (gy**2 - gx**2) / (65.0**2 + gx**2 + gy**2))
    bx = 0.002 * gx * gy / 65.0**2 / (1 + (gz / 80.0) ** 2) / (1 + (gx**2 + gy**2) / 65.0**2)
    rows = np.column_stack([gx.ravel() * factor, gy.ravel() * factor, gz.ravel() * factor, bx.ravel(), by.ravel()])
    lines = [f"x [{length_unit}],y [{length_unit}],z [{length_unit}],Bx [T],By [T]"]
    lines += [",".join(f"{v:.9g}" for v in row) for row in rows]
    return "\n".join(lines) + "\n"


def test_a_coils_field_over_a_large_air_box_reads_clean_and_warns_under_cm():
    genuine = solved(request(coil_on_a_large_box("mm", 1.0)))
    assert not grid_warnings(genuine)
    slipped = solved(request(coil_on_a_large_box("cm", 1.0)))
    (warning,) = grid_warnings(slipped)
    assert warning.details["likely_unit"] == "mm" and warning.details["read_in"] == "cm"
    assert abs(slipped.sensitivity - genuine.sensitivity) > 0.01


def test_the_api_reports_the_warning_with_the_likely_unit(client):
    body = json.loads(request(COMSOL.replace(STATED, "% Length unit:        in")).model_dump_json(exclude_unset=True))
    response = client.post("/v1/flowmeter/jobs", json=body)
    assert response.status_code == 202, response.text
    view = wait_for(client, response.json()["id"], timeout=120)
    assert view["status"] == "succeeded", view["report"]
    result = client.get(f"/v1/jobs/{view['id']}/result").json()
    (warning,) = [w for w in result["report"]["warnings"] if w["code"] == "implausible_field_grid"]
    assert warning["details"]["likely_unit"] == "mm" and warning["details"]["quantity"] == "options.magnetic_field_file"


def test_points_in_mm_under_a_request_in_cm_are_warned_naming_the_points_and_mm():
    body = json.loads((EXAMPLES / "field_points.json").read_text())
    body["units"] = "cm"
    body["pipe"] = {k: v / 10 for k, v in body["pipe"].items()}
    body["electrodes"]["half_length"] /= 10
    body["options"]["probe_points"] = [[c / 10 for c in p] for p in body["options"]["probe_points"]]
    genuine = solved(FlowmeterRequest.model_validate({**body, "magnetic_field": {
        "type": "points", "points": [[*(c / 10 for c in row[:3]), *row[3:]] for row in body["magnetic_field"]["points"]]}}))
    assert genuine.sensitivity == pytest.approx(0.91426, abs=1e-5) and not grid_warnings(genuine)
    (warning,) = grid_warnings(solved(FlowmeterRequest.model_validate(body)))
    assert warning.details["quantity"] == "magnetic_field.points" and warning.details["likely_unit"] == "mm"
    assert "the request's units ('cm')" in warning.message
