"""The unit an OBJ header comment states (SketchUp's `# File units = inches`, `# units: meter`) is read: a room
exported in inches was read as metres, a 1.8e6 m³ hall 96 m high inside every plausible range, without a word."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

SKETCHUP = ("# Alias OBJ Model File\n# Exported from SketchUp, (c) 2000-2012 Trimble Navigation Limited\n"
            "# File units = {}\n\n")
CORNERS = ((1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4))


def box_obj(a: float, b: float, c: float, header: str = "") -> bytes:
    points = [(x, y, z) for x in (0, a) for y in (0, b) for z in (0, c)]
    return (header + "o room\n" + "".join(f"v {x} {y} {z}\n" for x, y, z in points)
            + "".join("f " + " ".join(map(str, q)) + "\n" for q in CORNERS)).encode()


def measured(content: bytes, options: dict | None = None):
    request = parse_upload(StoredInput.from_bytes("room.obj", content), options)
    return request, solve(request).result


@pytest.mark.parametrize("word, size", [("inches", 0.0254), ("feet", 0.3048), ("millimeters", 1e-3), ("meters", 1.0)])
def test_the_unit_a_sketchup_header_states_is_read(word, size):
    request, result = measured(box_obj(3 / size, 4 / size, 2.5 / size, SKETCHUP.format(word)))
    assert result.zones[0].volume == pytest.approx(30.0) and result.zones[0].floor_area == pytest.approx(12.0)
    assert request.source["units"]["basis"] == "header" and "line 3" in request.source["units"]["evidence"]


def test_the_header_unit_goes_to_the_request_units_and_an_option_overriding_it_is_said():
    _, in_feet = measured(box_obj(120, 160, 96, SKETCHUP.format("inches")), {"units": "ft"})
    assert in_feet.units == "ft" and in_feet.zones[0].volume == pytest.approx(10 * (40 / 3) * 8)
    _, overridden = measured(box_obj(3, 4, 2.5, SKETCHUP.format("inches")), {"options": {"file_units": "m"}})
    assert overridden.zones[0].volume == pytest.approx(30.0)
    assert "file_unit_overridden" in {w.code for w in overridden.report.warnings}


def test_yards_which_no_request_is_in_are_converted_too():
    request, result = measured(box_obj(3 / 0.9144, 4 / 0.9144, 2.5 / 0.9144, SKETCHUP.format("yards")))
    assert result.zones[0].volume == pytest.approx(30.0) and request.source["units"]["file_unit"] == "yd"


@pytest.mark.parametrize("header", ["", "o first\n# File units = inches\n"])
def test_no_header_unit_leaves_the_numbers_in_the_request_units(header):
    request, result = measured(box_obj(3, 4, 2.5, header))
    assert result.zones[0].volume == pytest.approx(30.0) and request.source["units"]["basis"] == "request"
    assert "file_unit_not_read" not in {w.code for w in result.report.warnings}


@pytest.mark.parametrize("header, line", [("# units: furlongs\n", 1), ("# File units = inches\n# units: meter\n", 2)])
def test_a_header_unit_not_read_is_warned_naming_its_line(header, line):
    request, result = measured(box_obj(3, 4, 2.5, header))
    assert result.zones[0].volume == pytest.approx(30.0) and request.source["units"]["basis"] == "request"
    (warning,) = [w for w in result.report.warnings if w.code == "file_unit_not_read"]
    assert warning.details["line"] == line and f"line {line}" in warning.message
