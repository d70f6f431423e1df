"""IFC spaces through IfcOpenShell's geometry kernel, set against their Qto_SpaceBaseQuantities."""

from __future__ import annotations

from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

DATA = Path(__file__).parent / "data"


def test_ifc_spaces_volumes_adjacency_and_base_quantities():
    request = parse_upload(StoredInput.from_path(DATA / "ifcopenshell_spaces.ifc"), None)
    result = solve(request).result
    zones = {z.id: z for z in result.zones}
    assert set(zones) == {"101", "102", "103"} and all(z.closed and z.orientation == "outward" for z in zones.values())
    # the file is in millimetres: the kernel's metres are kept, and the report says so
    assert zones["101"].volume == pytest.approx(5 * 4 * 3) and zones["102"].volume == pytest.approx(4 * 4 * 3)
    assert zones["103"].volume == pytest.approx(1.0) and zones["101"].surface_area == pytest.approx(94.0)
    (adjacent,) = result.adjacency
    assert adjacent.zones == ["101", "102"] and adjacent.area == pytest.approx(12.0)
    assert request.source["spaces"]["101"]["long_name"] == "Office"
    (skipped,) = request.source["skipped"]
    assert skipped["object"].endswith("IfcSpace '104'") and skipped["reason"] == "no representation"
    # 101 declares net 60 m3 / 20 m2 (as measured); 102 gross 50 m3 against 48 measured: warned
    rows = {r["zone"]: r for r in result.report.details["declared_comparison"]}
    assert set(rows) == {"101", "102"}
    assert rows["101"]["volume_difference"] == pytest.approx(0.0) and rows["101"]["floor_area"] == pytest.approx(20.0)
    assert rows["102"]["volume_difference"] == pytest.approx(-0.04)
    assert request.source["declared_quantities"]["102"] == {"volume": "GrossVolume", "floor_area": "GrossFloorArea"}
    codes = {w.code: w for w in result.report.warnings}
    assert codes["declared_measures_differ"].details["zones"] == ["102"] and "units_converted" in codes


def test_ifc_without_spaces_or_geometry_is_refused():
    text = (DATA / "ifcopenshell_spaces.ifc").read_text()
    no_spaces = "\n".join(line for line in text.splitlines() if "IFCSPACE(" not in line)
    with pytest.raises(InputRejected, match="no IfcSpace"):
        parse_upload(StoredInput.from_bytes("a.ifc", no_spaces.encode()), None)
    with pytest.raises(InputRejected, match="unreadable IFC file"):
        parse_upload(StoredInput.from_bytes("a.ifc", b"ISO-10303-21;\nHEADER;\ngarbage"), None)


def test_ifc2x3_exporters_base_quantities_set_is_read_too():
    text = (DATA / "ifcopenshell_spaces.ifc").read_text().replace("'Qto_SpaceBaseQuantities'", "'BaseQuantities'")
    assert "'BaseQuantities'" in text
    request = parse_upload(StoredInput.from_bytes("a.ifc", text.encode()), None)
    assert request.source["declared"]["101"] == {"volume": pytest.approx(60.0), "floor_area": pytest.approx(20.0)}


def _codes(result) -> dict:
    return {w.code: w for w in result.report.warnings}


def test_an_ifc_cut_short_is_read_as_far_as_it_goes_and_says_so():
    """Cut inside space 103's entities, the file used to be read without a word: zones went missing silently.
    Now the spaces read are kept and the report says where the file stops."""
    text = (DATA / "ifcopenshell_spaces.ifc").read_text()
    cut = text[:text.index("#56=")]
    request = parse_upload(StoredInput.from_bytes("cut.ifc", cut.encode()), None)
    result = solve(request).result
    assert {z.id for z in result.zones} == {"101", "102"}
    note = _codes(result)["truncated_file"]
    assert "END-ISO-10303-21" in note.message and note.details["line"] == cut.count("\n")
    with pytest.raises(InputRejected, match="no IfcSpace .the file was cut short"):
        parse_upload(StoredInput.from_bytes("cut.ifc", text[:text.index("#18=")].encode()), None)


def test_a_space_whose_quantities_name_a_missing_entity_keeps_its_zone_without_them():
    """Space 101's relation to its quantities names #32, which this damaged copy lacks: IfcOpenShell's get_psets
    raised and the file was refused as malformed. Now 101 is measured and its quantities are reported unreadable."""
    text = (DATA / "ifcopenshell_spaces.ifc").read_text()
    damaged = "\n".join(line for line in text.splitlines() if not line.startswith("#32="))
    request = parse_upload(StoredInput.from_bytes("damaged.ifc", damaged.encode()), None)
    result = solve(request).result
    assert {z.id for z in result.zones} == {"101", "102", "103"} and "101" not in request.source["declared"]
    assert _codes(result)["ifc_quantities_unreadable"].details["spaces"] == ["#18 IfcSpace '101'"]


@pytest.mark.parametrize("encode", [lambda t: b"\xef\xbb\xbf" + t.encode(), lambda t: t.encode("utf-16")])
def test_an_ifc_with_a_byte_order_mark_is_read(encode):
    """A STEP file re-saved by a Windows editor starts with a byte-order mark: 'No schema loaded' before."""
    text = (DATA / "ifcopenshell_spaces.ifc").read_text()
    request = parse_upload(StoredInput.from_bytes("bom.ifc", encode(text)), None)
    assert set(request.source["spaces"]) == {"101", "102", "103"}
