"""GlobalGeometryRules that differ, as a model merged from two files or typed by hand has them: EnergyPlus allows one
GlobalGeometryRules and only its keys, and refuses anything else. The reader took the first object's coordinate
system and any object's 'Clockwise', and read a misspelt key as the default (counterclockwise, World), each a silent
guess of which way every face points or where every zone lies."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

OFFICES = (Path(__file__).parents[3] / "examples" / "polyhedra" / "two_offices.idf").read_text()
RULES = re.search(r"GlobalGeometryRules,.*?;[^\n]*\n", OFFICES, flags=re.DOTALL).group(0)
RULES_LINE = OFFICES[:OFFICES.index(RULES)].count("\n") + 1


def _upload(name: str, text: str):
    return parse_upload(StoredInput.from_bytes(name, text.encode()), None)


@pytest.mark.parametrize("second", [RULES.replace("Counterclockwise", "Clockwise"),
                                    RULES.replace("Relative,", "World,", 1), RULES])
def test_a_second_global_geometry_rules_is_refused_naming_both_lines(second):
    text = OFFICES.replace(RULES, RULES + "\n" + second)
    second_line = RULES_LINE + RULES.count("\n") + 1
    with pytest.raises(InputRejected) as refused:
        _upload("merged.idf", text)
    (error,) = refused.value.errors
    assert error.loc == ("file", "line", second_line)
    assert f"line {second_line}" in error.msg and f"line {RULES_LINE}" in error.msg and "one" in error.msg


def test_a_second_global_geometry_rules_in_an_epjson_is_refused():
    rules = {"starting_vertex_position": "UpperLeftCorner", "vertex_entry_direction": "Counterclockwise",
             "coordinate_system": "Relative"}
    body = {"GlobalGeometryRules": {"A": rules, "B": {**rules, "vertex_entry_direction": "Clockwise"}},
            "Zone": {"Z": {}},
            "Wall:Exterior": {"S": {"zone_name": "Z", "azimuth_angle": 180, "starting_x_coordinate": 0,
                                    "starting_y_coordinate": 0, "starting_z_coordinate": 0, "length": 4,
                                    "height": 2.5}}}
    with pytest.raises(InputRejected) as refused:
        _upload("merged.epJSON", json.dumps(body))
    assert "second GlobalGeometryRules" in refused.value.errors[0].msg


@pytest.mark.parametrize("field, written, line_offset", [("Counterclockwise", "Clockwize", 2),
                                                         ("Counterclockwise", "CCW", 2),
                                                         ("Relative,                               !- Coordinate",
                                                          "Relativ,  !- Coordinate", 3)])
def test_a_global_geometry_rules_key_that_is_none_of_energyplus_keys_is_refused_naming_its_line(field, written,
                                                                                                  line_offset):
    text = OFFICES.replace(RULES, RULES.replace(field, written, 1))
    with pytest.raises(InputRejected) as refused:
        _upload("typo.idf", text)
    (error,) = refused.value.errors
    bad = written.split(",")[0]
    assert error.loc == ("file", "line", RULES_LINE + line_offset) and repr(bad) in error.msg


@pytest.mark.parametrize("written", ["clockwise", "CLOCKWISE", "Clockwise"])
def test_energyplus_keys_in_any_case_are_read(written):
    """EnergyPlus reads its keys case-insensitively; so does the reader (the vertices' order flips, not the volume)."""
    result = solve(_upload("cw.idf", OFFICES.replace(RULES, RULES.replace("Counterclockwise", written)))).result
    assert [z.volume for z in result.zones] == pytest.approx([60.0, 60.0])


def test_absolute_rectangles_are_world_rectangles():
    """EnergyPlus' keys for the Rectangular Surface Coordinate System are Relative, World and Absolute, World and
    Absolute one choice: the simple-geometry rectangles are placed as written, not from their zone's origin."""
    source = (Path(__file__).parents[3] / "examples" / "polyhedra" / "four_zones_simple.idf").read_text()

    def surfaces(word: str):
        text = source.replace("World;                   !- Coordinate System",
                              "World,                   !- Coordinate System\n    World,  !- Daylighting\n"
                              f"    {word};  !- Rectangular Surface Coordinate System")
        request = _upload("m.idf", text).model_dump(mode="json")
        return request["vertices"], request["faces"], request["mesh"]

    world, absolute, relative = surfaces("World"), surfaces("Absolute"), surfaces("Relative")
    assert world != relative  # the zones have origins: the choice moves the rectangles
    assert absolute == world
