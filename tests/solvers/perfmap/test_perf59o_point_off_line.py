"""One point of a rig table mistyped (a pressure ten times too large, a flow with a digit dropped) is named where it
lies — its speed line, its flow and pressure as written and its file row — by ``point_off_its_line``; the real maps of
the repository (the N+3 example, pyCycle's maps, GasTurb/GSPy's sample maps) raise none."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = ROOT / "examples" / "perfmap"
DATA = Path(__file__).resolve().parent / "data"


def _csv_with(line: int, column: int, factor: float) -> bytes:
    """The N+3 example table with one cell (file line ``line``, 1 = the header) multiplied by ``factor``."""
    lines = (EXAMPLE / "n3_fan_map.csv").read_text().splitlines()
    cells = lines[line - 1].split(",")
    cells[column] = f"{float(cells[column]) * factor:g}"
    lines[line - 1] = ",".join(cells)
    return ("\n".join(lines) + "\n").encode()


def _off(content: bytes, name: str) -> list:
    source = StoredInput(name, content=content)
    return [w for w in load(parse_upload(source, None), source).warnings if w.code == "point_off_its_line"]


def test_a_pressure_typed_ten_times_too_large_is_named_by_its_line_values_and_file_row():
    # line 25: theta 0, phi 0.8, flow 2054.9785, pressure 1.2386 -> 12.386
    (w,) = _off(_csv_with(25, 3, 10), "map.csv")
    d = w.details
    assert (d["setting"], d["row"], d["field"]) == ([0.0, 0.8], 25, "file.row.25")
    assert (d["flow"], d["pressure"]) == (2054.9785, 12.386)
    assert d["expected_pressure"] == pytest.approx(1.2386, rel=0.02)  # the line's curve without it
    assert "theta=0, phi=0.8" in w.message and "line 25" in w.message and "12.386" in w.message


def test_a_flow_with_a_digit_dropped_is_named_though_the_line_stays_decreasing_and_concave():
    # line 40: theta 0, phi 0.95, flow 2422.7034 -> 242.27, pressure 1.3703: the highest pressure at the smallest
    # flow, which a decreasing concave curve can follow (its floor stays 0.11 %), far off the line all the same
    (w,) = _off(_csv_with(40, 2, 0.1), "map.csv")
    d = w.details
    assert (d["setting"], d["row"], d["flow"], d["pressure"]) == ([0.0, 0.95], 40, 242.27, 1.3703)
    assert "flow 242.27" in w.message and "line 40" in w.message


def test_a_json_body_names_the_point_by_its_position_and_its_values_as_given_in_their_unit():
    body = json.loads((EXAMPLE / "n3_fan_map.json").read_text())
    body["units"] = {**body["units"], "pressure": "-", "flow": "kg/s"}
    position = body["positions"][3]  # theta 0, phi 0.8
    position["pressure"][2] /= 10
    (w,) = [w for w in load(PerfmapRequest.model_validate(body)).warnings if w.code == "point_off_its_line"]
    d = w.details
    assert (d["position"], d["point"], d["row"], d["field"]) == (3, 2, None, "positions.3")
    assert (d["flow"], d["pressure"]) == (position["flow"][2], position["pressure"][2])  # kg/s as given, not lbm/s
    assert "positions[3] point 2" in w.message


def test_a_map_file_names_the_point_by_its_place_in_the_speed_line_and_the_line_heading_it():
    text = (DATA / "gasturb" / "compmap.map").read_text()
    row = "     0.70000     11.75000     11.50000     11.30000     11.10000    10.75000"  # Mass Flow, Nc 0.7, line 8
    assert row in text
    text = text.replace(row, row.replace("11.10000", "1.110000"))  # its 4th flow, a digit dropped
    (w,) = _off(text.encode(), "compmap.map")
    assert (w.details["setting"], w.details["point"], w.details["flow"]) == ([0.7], 3, 1.11)
    assert "point 4 of the speed line at line 8" in w.message


def test_one_point_per_line_is_named_not_its_neighbours():
    content = _csv_with(25, 3, 10)
    lines = content.decode().splitlines()
    cells = lines[13 - 1].split(",")  # phi 0.6 (line 13) mistyped too
    cells[2] = f"{float(cells[2]) * 10:g}"
    lines[13 - 1] = ",".join(cells)
    rows = sorted(w.details["row"] for w in _off(("\n".join(lines) + "\n").encode(), "map.csv"))
    assert rows == [13, 25]


@pytest.mark.parametrize("path", [
    EXAMPLE / "n3_fan_map.csv", EXAMPLE / "n3_fan_map.json", DATA / "pycycle_fan_map.py",
    *sorted((DATA / "pycycle").glob("*.py")),
    *[DATA / "gasturb" / n for n in ("bigfanc.map", "bigfand.map", "compmap.map")],
], ids=lambda p: p.name)
def test_the_real_maps_of_the_repository_have_no_point_off_its_line(path):
    assert _off(path.read_bytes(), path.name) == []
