"""An IDF whose Zone has no surface read (its surfaces lost when the file was cut or edited after its zones, or all
skipped) gave the other zones' totals as the building's without a word: two_offices.idf without office B's surfaces
was 'total_volume 60 m³' for its two 60 m³ offices. The zone is named (``zones_without_surfaces``) with its line."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.polyhedra.solve import solve
from plantsolve.solvers.polyhedra.upload import parse_upload

ROOT = Path(__file__).resolve().parents[3]
IDF = (ROOT / "examples/polyhedra/two_offices.idf").read_text()
OBJECTS = re.split(r"(?m)^(?=\S)", IDF)


def solved(name: str, text: str):
    return solve(parse_upload(StoredInput.from_bytes(name, text.encode()), None)).result


def without_surfaces_of(zone: str) -> str:
    return "".join(o for o in OBJECTS if not (zone in o and o.startswith(("BuildingSurface", "Fenestration"))))


def test_a_zone_whose_surfaces_were_lost_is_named_with_its_line():
    result = solved("zones.idf", without_surfaces_of("Office B Thermal Zone"))
    assert [z.id for z in result.zones] == ["Office A Thermal Zone"] and result.total_volume == pytest.approx(60.0)
    (warning,) = [w for w in result.report.warnings if w.code == "zones_without_surfaces"]
    line = IDF[:IDF.index("Office B Thermal Zone,")].count("\n")  # the line of its "Zone," above the name
    assert warning.details["zones"] == ["Office B Thermal Zone"] and warning.details["lines"] == [line]
    assert warning.details["zones_measured"] == 1 and "total_volume" in warning.message


def test_every_zone_with_surfaces_says_nothing():
    assert "zones_without_surfaces" not in {w.code for w in solved("zones.idf", IDF).report.warnings}


def test_the_epjson_reader_names_it_too():
    epjson = json.loads((ROOT / "tests/solvers/polyhedra/data/1ZoneUncontrolled.epJSON").read_text())
    epjson["Zone"]["Storage Room"] = {"direction_of_relative_north": 0, "x_origin": 0, "y_origin": 0, "z_origin": 0}
    result = solved("model.epJSON", json.dumps(epjson))
    (warning,) = [w for w in result.report.warnings if w.code == "zones_without_surfaces"]
    assert warning.details["zones"] == ["Storage Room"] and warning.details["zones_measured"] == 1
