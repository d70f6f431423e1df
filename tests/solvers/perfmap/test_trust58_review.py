"""Last review's left-overs: a GasTurb map's setting line named like its speed is refused by the map reader; a
refusal's place is decided in one place for the reader's schema check and the load's checks (a form option nested
as the form holds it, a bare list of positions' form option not put into the file); a point at zero flow is named
(row and quantity)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load
from tests.solvers.perfmap.test_uploads2_readers import _variable_geometry_map

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "perfmap"
HEADER = "theta,phi,flow,pressure,efficiency"
# two speed lines of the example fan map (file lines 2-8 and 9-15)
ROWS = [r for r in (EXAMPLES / "n3_fan_map.csv").read_text().splitlines()[1:] if r.startswith(("0.0,0.5,", "0.0,0.6,"))]


def _errors(name: str, text: str, options: dict | None = None):
    source = StoredInput.from_bytes(name, text.encode())
    with pytest.raises(InputRejected) as caught:
        load(parse_upload(source, options), source)
    return caught.value.errors


def _csv(rows: list[str]) -> str:
    return "\n".join([HEADER, *rows]) + "\n"


@pytest.mark.parametrize("label", ["Speed", "N/sqrt(theta)"])
def test_a_map_whose_setting_lines_carry_a_speed_name_is_refused_at_its_first_setting_line(label):
    error, = _errors("vg.map", _variable_geometry_map(label), {"units": {"flow": "kg/s"}})
    assert error.loc == ("file", "line", 3)
    assert error.msg.startswith("line 3:") and repr(label) in error.msg and "speed" in error.msg


def test_a_result_unit_nested_in_the_form_is_named_where_the_form_holds_it():
    """The load's check (a result unit asked for a flow without one) named the form's nested option as if it were
    flat (options.result_units.flow), a place the user never wrote."""
    error, = _errors("m.csv", _csv(ROWS), {"options": {"result_units": {"flow": "kg/s"}}})
    assert error.loc == ("options", "options", "result_units", "flow") and "units.flow" in error.msg
    error, = _errors("m.csv", _csv(ROWS), {"result_units": {"flow": "kg/s"}})
    assert error.loc == ("options", "result_units", "flow")


def test_a_bare_list_of_positions_with_a_form_option_names_the_form_not_the_file():
    """A JSON file holding only the positions has no options: the form's option was named 'file.options....'."""
    body = json.loads((EXAMPLES / "n3_fan_map.json").read_text())
    text = json.dumps(body["positions"])
    assert parse_upload(StoredInput.from_bytes("m.json", text.encode()), None).source.document == "positions"
    error, = _errors("m.json", text, {"options": {"result_units": {"flow": "kg/s"}}})
    assert error.loc == ("options", "options", "result_units", "flow")
    body["positions"][1]["efficiency"][2] = 85.0  # a per cent among fractions, found when loading
    error, = _errors("m.json", json.dumps(body["positions"]))
    assert error.loc == ("file", 1, "efficiency", 2)


@pytest.mark.parametrize("efficiency, said", [("0.6585", "flow 0 beside efficiency 0.6585"),
                                              ("0", "flow 0 and efficiency 0: a shut-off point")])
def test_a_point_at_zero_flow_is_refused_naming_its_row_and_the_flow(efficiency, said):
    """0.66 beside a flow of 0 is a flow left empty: it was fitted, and said only as a poor efficiency fit."""
    first = ROWS[0].split(",")
    error, = _errors("m.csv", _csv([",".join(first[:2] + ["0", first[3], efficiency])] + ROWS[1:]))
    assert error.loc == ("file", "row", 2, "flow")
    assert said in error.msg and "lines 2, 3" in error.msg


def test_a_json_files_request_wide_refusal_and_a_source_of_its_own_are_named_in_the_file():
    body = json.loads((EXAMPLES / "n3_fan_map.json").read_text())
    error, = _errors("m.json", json.dumps({**body, "setting_units": ["deg"]}))
    assert error.loc == ("file",) and "setting_units needs 2 entries" in error.msg
    error, = _errors("m.json", json.dumps({**body, "source": "csv"}))
    assert error.loc == ("file", "source")
