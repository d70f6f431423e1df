"""gbXML as OpenStudio, the gbXML test cases and Revit write it: surfaces, openings, closed shells, units."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

DATA = Path(__file__).parent / "data"
HEAD = '<?xml version="1.0"?>\n<gbXML xmlns="http://www.gbxml.org/schema" lengthUnit="Meters">\n<Campus id="c">\n'


def read(name: str):
    request = parse_upload(StoredInput.from_path(DATA / name), None)
    return request, solve(request).result


def upload(text: str):
    return parse_upload(StoredInput.from_bytes("model.xml", text.encode()), None)


def _surface(sid: str, spaces: list[str], points: list[tuple], extra: str = "") -> str:
    adjacent = "".join(f'<AdjacentSpaceId spaceIdRef="{s}"/>' for s in spaces)
    loop = "".join("<CartesianPoint>" + "".join(f"<Coordinate>{c}</Coordinate>" for c in p) + "</CartesianPoint>\n"
                   for p in points)
    return f'<Surface id="{sid}" surfaceType="ExteriorWall">{adjacent}\n<PlanarGeometry><PolyLoop>\n{loop}' \
           f"</PolyLoop></PlanarGeometry>{extra}</Surface>\n"


def test_openstudio_export_surfaces_openings_shells_and_declared_measures():
    request, result = read("openstudio_offices.xml")
    zones = {z.id: z for z in result.zones}
    assert set(zones) == {"Space_A", "Space_B", "Space_S"}
    assert all(z.closed and z.orientation == "outward" for z in zones.values())
    assert zones["Space_A"].volume == pytest.approx(60.0) and zones["Space_B"].volume == pytest.approx(60.0)
    assert zones["Space_S"].volume == pytest.approx(3 * 2 * 2.5)  # from its ShellGeometry alone
    # the window (2 x 1.5 m) comes off office A's south wall; the interior wall is written once
    assert zones["Space_A"].net_surface_area == pytest.approx(94.0 - 3.0)
    assert [(a.zones, a.faces, a.area) for a in result.adjacency] == [(["Space_A", "Space_B"], ["su-AB"],
                                                                      pytest.approx(12.0))]
    window = next(f for f in result.faces if f.id == "op-A-window")
    assert window.parent == "su-A-south" and window.area == pytest.approx(3.0)
    # the slab written with its one space twice is a floor of that space
    floor = next(f for f in result.faces if f.id == "su-A-floor")
    assert floor.zones == ["Space_A"] and floor.normal == pytest.approx([0, 0, -1])
    assert request.source["spaces"] == {"Space_A": "Office A", "Space_B": "Office B", "Space_S": "Store"}
    (shade,) = request.source["skipped"]
    assert shade["object"] == "Surface 'su-canopy'" and "no AdjacentSpaceId" in shade["reason"]
    lines = (DATA / "openstudio_offices.xml").read_text(encoding="utf-8-sig").splitlines()
    assert 'id="su-canopy"' in lines[shade["line"] - 1]
    # the file declares 61.5 m3 for office B, which measures 60: compared, and the difference warned
    rows = {r["zone"]: r for r in result.report.details["declared_comparison"]}
    assert rows["Space_A"]["volume_difference"] == pytest.approx(0.0)
    assert rows["Space_B"]["declared_volume"] == 61.5 and rows["Space_B"]["volume"] == pytest.approx(60.0)
    assert rows["Space_S"]["floor_area"] == pytest.approx(6.0) and rows["Space_S"]["declared_floor_area"] == 6.0
    (differ,) = [w for w in result.report.warnings if w.code == "declared_measures_differ"]
    assert differ.details["zones"] == ["Space_B"]


def test_revit_utf16_in_feet_is_converted_to_metres_and_says_so():
    request, result = read("revit_room_feet.xml")
    assert (DATA / "revit_room_feet.xml").read_bytes()[:2] == b"\xff\xfe"
    assert request.units == "m" and request.source["units"]["lengthUnit"] == "Feet"
    (z,) = result.zones
    assert z.closed and z.volume == pytest.approx(20 * 10 * 10 * 0.3048 ** 3, rel=1e-12)  # 2000 ft3
    (row,) = result.report.details["declared_comparison"]
    assert row["declared_volume"] == pytest.approx(2000 * 0.028316846592)
    assert row["declared_floor_area"] == pytest.approx(200 * 0.09290304)
    assert row["floor_area"] == pytest.approx(200 * 0.3048 ** 2)
    codes = [w.code for w in result.report.warnings]
    assert "units_converted" in codes and "declared_measures_differ" not in codes


def test_bad_surfaces_are_skipped_naming_the_line():
    square = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    text = HEAD + '<Building id="b"><Space id="S"/></Building>\n' + _surface("good", ["S"], square) + \
        _surface("nan", ["S"], [(0, 0, 0), (1, 0, "x"), (1, 1, 0)]) + _surface("stranger", ["T"], square) + \
        '<Surface id="rect" surfaceType="Roof"><AdjacentSpaceId spaceIdRef="S"/><RectangularGeometry/></Surface>\n' + \
        "</Campus></gbXML>"
    request = upload(text)
    skipped = {s["object"]: s for s in request.source["skipped"]}
    assert "CartesianPoint 2" in skipped["Surface 'nan'"]["reason"] and skipped["Surface 'nan'"]["line"] == 12
    assert "'T' names no Space" in skipped["Surface 'stranger'"]["reason"]
    assert "only RectangularGeometry" in skipped["Surface 'rect'"]["reason"]
    assert [f.id for f in request.faces] == ["good"]


@pytest.mark.parametrize(("text", "loc", "message"), [
    (HEAD + _surface("shade", [], [(0, 0, 0), (1, 0, 0), (1, 1, 0)]) + "</Campus></gbXML>", ("file", "line", 4),
     "no AdjacentSpaceId"),
    (HEAD + "<Surface id='a'>\n</Campus></gbXML>", ("file", "line", 5), "not well-formed XML: mismatched tag"),
    ('<?xml version="1.0"?>\n<!DOCTYPE gbXML [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;">]>\n<gbXML/>',
     ("file", "line", 2), "DOCTYPE"),
    ('<?xml version="1.0"?>\n<IFC/>', ("file",), "not gbXML"),
    ('<gbXML lengthUnit="Furlongs"><Campus/></gbXML>', ("file", "line", 1), "lengthUnit 'Furlongs'"),
    (HEAD + "</Campus></gbXML>", ("file",), "no Campus/Surface"),
])
def test_gbxml_with_nothing_usable_is_refused_naming_the_line(text, loc, message):
    with pytest.raises(InputRejected) as e:
        upload(text)
    (error,) = e.value.errors
    assert error.loc == loc and message in error.msg
