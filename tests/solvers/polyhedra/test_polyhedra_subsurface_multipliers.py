"""EnergyPlus' Multiplier of a window or door (the number of identical items on the base surface): EnergyPlus
multiplies the subsurface's area, so its host's net area loses every copy; before, a window ×4 was subtracted once,
no word."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload
from plantsolve.solvers.polyhedra.validation import check_input

DATA = Path(__file__).parent / "data"
OFFICES = (DATA / "openstudio_two_offices.idf").read_text()
WINDOW_MULTIPLIER = "  1,                                      !- Multiplier"  # Office A Window's: the 3rd Multiplier
SHADED = (DATA / "4ZoneWithShading_Simple_1.idf").read_text()


def _solved(name: str, text: str):
    request = parse_upload(StoredInput.from_bytes(name, text.encode()), None)
    check_input(request)
    return solve(request).result


def _window_multiplier(value: str) -> tuple[str, int]:
    """The offices with Office A Window's Multiplier set, and that field's line."""
    lines = OFFICES.splitlines(keepends=True)
    at = [k for k, line in enumerate(lines) if line.rstrip("\n") == WINDOW_MULTIPLIER][2]
    assert "Office A Window" in lines[at - 7]
    lines[at] = f"  {value},  !- Multiplier\n"
    return "".join(lines), at + 1


def _faces(result) -> dict:
    return {f.id: f for f in result.faces}


def test_a_window_multiplier_subtracts_every_copy_from_its_host_and_says_so():
    plain = _faces(_solved("offices.idf", OFFICES))
    wall, window = plain["Office A South"], plain["Office A Window"]
    assert window.area == pytest.approx(3.0) and wall.net_area == pytest.approx(wall.area - 3.0)
    result = _solved("offices.idf", _window_multiplier("4")[0])
    faces = _faces(result)
    # the window's own area is one copy's; the wall loses four (was wall - 3 m²)
    assert faces["Office A Window"].area == pytest.approx(3.0) and faces["Office A Window"].multiplier == 4
    assert faces["Office A South"].net_area == pytest.approx(wall.area - 12.0)
    zone_a = next(z for z in result.zones if z.id == "Office A Thermal Zone")
    assert zone_a.net_surface_area == pytest.approx(zone_a.surface_area - 12.0)
    (warning,) = [w for w in result.report.warnings if w.code == "subsurface_multipliers_applied"]
    assert warning.details["faces"] == {"Office A Window": 4} and "'Office A South'" in warning.message
    assert warning.details["area_subtracted"]["Office A Window"] == pytest.approx(12.0)


def test_energyplus_truncates_a_fractional_multiplier_and_the_epjson_twin_agrees():
    wall = _faces(_solved("offices.idf", OFFICES))["Office A South"]
    truncated = _faces(_solved("offices.idf", _window_multiplier("2.9")[0]))
    assert truncated["Office A South"].net_area == pytest.approx(wall.area - 6.0)
    document = json.loads((DATA / "openstudio_two_offices.epJSON").read_text())
    document["FenestrationSurface:Detailed"]["Office A Window"]["multiplier"] = 4
    twin = _faces(_solved("offices.epJSON", json.dumps(document)))
    assert twin["Office A South"].net_area == pytest.approx(wall.area - 12.0)


def test_a_simple_window_and_door_multiplier_count_on_their_wall():
    plain = _faces(_solved("shaded.idf", SHADED))["Zn001:Wall001"]
    assert plain.net_area == pytest.approx(200.0 - 15.0 - 15.0)  # a 3 x 5 window and a 3 x 5 door on 20 x 10
    text = SHADED.replace("    1,                       !- Multiplier\n    4,", "    3,  !- Multiplier\n    4,", 1)
    text = text.replace("    1,                       !- Multiplier\n    14,", "    2,  !- Multiplier\n    14,", 1)
    faces = _faces(_solved("shaded.idf", text))
    assert faces["Zn001:Wall001"].net_area == pytest.approx(200.0 - 3 * 15.0 - 2 * 15.0)
    assert (faces["Zn001:Wall001:Win001"].multiplier, faces["Zn001:Wall001:Door001"].multiplier) == (3, 2)


@pytest.mark.parametrize("value", ["0.5", "0", "-2", "four", "inf", "nan"])
def test_a_multiplier_energyplus_refuses_is_refused_naming_its_line(value):
    text, line = _window_multiplier(value)
    with pytest.raises(InputRejected) as refused:
        _solved("offices.idf", text)
    (error,) = refused.value.errors
    assert error.loc == ("file", "line", line)
    assert "Office A Window" in error.msg and repr(value) in error.msg


def test_a_json_body_multiplying_a_face_that_is_no_subsurface_is_refused():
    body = parse_upload(StoredInput.from_bytes("o.idf", OFFICES.encode()), None).model_dump()
    body["subsurface_multipliers"] = {"Office A South": 2}
    with pytest.raises(InputRejected) as refused:
        _solved("body.json", json.dumps(body))
    assert refused.value.errors[0].loc == ("subsurface_multipliers", "Office A South")


@pytest.mark.parametrize("bulk", [False, True])
def test_zones_csv_face_rows_state_the_window_multiplier_so_the_rows_add_up_to_the_host(monkeypatch, bulk):
    """zones.csv listed the window ×4 with a blank multiplier, one copy's area and its wall's net area less four
    copies: its rows did not add up, no word. Now each face row states its multiplier, as the result does (the large
    tables' array writer too)."""
    import csv
    import io

    from plantsolve.solvers.polyhedra import artifacts

    if bulk:
        monkeypatch.setattr(artifacts, "MAX_LISTED_FACES", 3)
    request = parse_upload(StoredInput.from_bytes("offices.idf", _window_multiplier("4")[0].encode()),
                           {"options": {"faces_csv": True}})
    check_input(request)
    (table,) = [a for a in artifacts.render_artifacts(request, solve(request)) if a.name == "zones.csv"]
    rows = {row["id"]: row for row in csv.DictReader(io.StringIO(table.data.decode())) if row["record"] == "face"}
    window, wall = rows["Office A Window"], rows["Office A South"]
    assert (window["multiplier"], wall["multiplier"]) == ("4", "1")
    assert float(wall["net_area [m2]"]) == pytest.approx(
        float(wall["area [m2]"]) - int(window["multiplier"]) * float(window["area [m2]"]))
