"""A gbXML surface's RectangularGeometry (Width × Height) that its PlanarGeometry polygon contradicts is named: the
file disagrees with itself about the surface's size, and the result went on without a word. The polygon is what is
measured, and a polygon that fits its rectangle (a gable's triangle in its bounding rectangle) says nothing."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.gbxml_rectangles import differs
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from tests.conftest import REPO

OFFICES = (REPO / "examples" / "polyhedra" / "offices.xml").read_bytes()
OPENSTUDIO = (REPO / "tests" / "solvers" / "polyhedra" / "data" / "openstudio_offices.xml").read_bytes()


def _child(element: ET.Element, name: str) -> ET.Element | None:
    return element.find(name)


def _codes(result) -> list[str]:
    return [w.code for w in result.report.warnings]


def test_a_height_typed_ten_times_over_is_named_with_its_line_and_the_polygon_measured():
    typo = OFFICES.replace(b"<Height>3.000000</Height>", b"<Height>30.000000</Height>", 1)
    result = solve(parse_upload(StoredInput.from_bytes("offices.xml", typo), None)).result
    (warning,) = [w for w in result.report.warnings if w.code == "rectangular_geometry_differs"]
    (entry,) = warning.details["surfaces"]
    assert entry == {"surface": "su-A-south", "line": 162,
                     "differs": "RectangularGeometry 5 × 30 m, PlanarGeometry a 5 × 3 m rectangle"}
    assert typo.decode("utf-8-sig").splitlines()[161].strip().startswith('<Surface id="su-A-south"')
    assert {z.id: z.volume for z in result.zones}["Space_A"] == pytest.approx(60.0)


def test_the_files_as_exported_say_nothing():
    for content in (OFFICES, OPENSTUDIO):  # 13 RectangularGeometry each, walls, roofs, floors and windows
        result = solve(parse_upload(StoredInput.from_bytes("model.xml", content), None)).result
        assert "rectangular_geometry_differs" not in _codes(result)


def _surface(width: float, height: float) -> ET.Element:
    return ET.fromstring(f"<Surface><RectangularGeometry><Width>{width}</Width><Height>{height}</Height>"
                         "</RectangularGeometry></Surface>")


def test_a_gable_triangle_fits_its_bounding_rectangle_and_a_larger_polygon_does_not():
    gable = [[0, 0, 3], [6, 0, 3], [3, 0, 5]]  # 6 m wide, 2 m high: 6 m² in a 12 m² rectangle
    assert differs(_surface(6, 2), gable, 1.0, _child) is None
    assert differs(_surface(6, 1), gable, 1.0, _child) is None  # as large as the polygon: not a contradiction
    assert differs(_surface(5, 1), gable, 1.0, _child) == "RectangularGeometry 5 × 1 m = 5 m², PlanarGeometry 6 m²"


def test_width_and_height_in_feet_are_compared_in_metres_and_either_way_round():
    wall = [[0, 0, 0], [1.524, 0, 0], [1.524, 0, 0.9144], [0, 0, 0.9144]]  # 5 x 3 ft
    assert differs(_surface(3, 5), wall, 0.3048, _child) is None
    assert differs(_surface(5, 3.5), wall, 0.3048, _child) is not None
