"""Four refusals of the perfmap readers that named no place or the wrong thing:

- a GasTurb/GSP map whose request the schema refused crashed (a KeyError: a 500): a variable-geometry map whose
  setting lines name the speed ('Nc = 0.9'), a flow unit longer than a unit's 40 characters;
- a pyCycle map value beyond 1e12 (1e308 typed for a missing one) was refused at its place in the request
  ('positions/0/flow/0') without the file's line;
- a .json or .py upload holding NUL bytes was called 'not a CSV text file'."""

from __future__ import annotations

import pytest

from plantsolve.solvers.base import InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from tests.solvers.perfmap.test_perfmap_gasturb import closed_form_tables, write_map

LONG_FLOW_UNIT = "kilogram / second * meter / meter * meter / meter"  # a flow, spelt out past 40 characters


def _refused(name: str, content: bytes, options: dict | None = None):
    with pytest.raises(InputRejected) as caught:
        parse_upload(StoredInput.from_bytes(name, content), options)
    (error,) = caught.value.errors
    return error


def _variable_geometry_map(label: str) -> str:
    W, E, P = closed_form_tables()
    sets = [write_map(w, E, P, head="3    variable geometry compressor").split("\n") for w in (W, 1.1 * W)]
    head, first, second = "\n".join(sets[0][:2]), "\n".join(sets[0][2:]), "\n".join(sets[1][2:])
    return f"{head}\n{label} = -5 [deg]\n{first}{label} = 5 [deg]\n{second}"


def test_a_map_whose_setting_lines_name_the_speed_is_refused_naming_the_line():
    error = _refused("vg.map", _variable_geometry_map("Nc").encode(), {"units": {"flow": "kg/s"}})
    assert error.loc == ("file", "line", 3)
    assert error.msg.startswith("line 3:") and "'Nc'" in error.msg and "speed" in error.msg


def test_the_same_map_with_its_setting_named_for_the_geometry_is_read():
    request = parse_upload(StoredInput.from_bytes("vg.map", _variable_geometry_map("VG angle").encode()),
                           {"units": {"flow": "kg/s"}})
    assert request.setting_names == ["VG angle", "Nc"]
    assert sorted({p.setting[0] for p in request.positions}) == [-5.0, 5.0]


def test_a_flow_unit_too_long_for_the_request_is_refused_naming_the_line_that_states_it():
    W, E, P = closed_form_tables()
    text = write_map(W, E, P)
    heading = text.split("\n").index("Mass Flow") + 1
    error = _refused("m.map", text.replace("Mass Flow", f"Mass Flow [{LONG_FLOW_UNIT}]", 1).encode())
    assert error.loc == ("file", "line", heading) and error.msg.startswith(f"line {heading}: units/flow")
    titled = text.replace("closed form compressor map", f"map of flow [{LONG_FLOW_UNIT}]")
    error = _refused("m.map", titled.encode())
    assert error.loc == ("file", "line", 1) and "40 characters" in error.msg


@pytest.mark.parametrize("name, content", [
    ("m.map", write_map(*closed_form_tables()).encode()),
    ("m.csv", b"theta,phi,flow,pressure,efficiency\n0,0,1,2,0.5\n0,0,2,1.8,0.6\n0,0,3,1.5,0.55\n"),
])
def test_a_flow_unit_option_too_long_is_named_as_the_option_not_the_file(name, content):
    error = _refused(name, content, {"units": {"flow": LONG_FLOW_UNIT}})
    assert error.loc == ("options", "units", "flow")


PYCYCLE_MAP = """import numpy as np
from pycycle.maps.map_data import MapData

M = MapData()
M.alphaMap = np.array([0.0])
M.NcMap = np.array([0.8, 1.0])
M.RlineMap = np.array([1.0, 2.0, 3.0])
M.WcMap = np.array([[[10.0, 11.0, 12.0],
                     [13.0, 14.0, 15.0]]])
M.PRmap = np.array([[[2.0, 1.8, 1.5],
                     [2.6, 2.3, 1.9]]])
M.effMap = np.array([[[0.80, 0.84, 0.81],
                      [0.79, 0.83, 0.80]]])
M.units = {'WcMap': 'kg/s'}
"""


@pytest.mark.parametrize("written, huge, line", [
    ("14.0", "1e308", 9), ("12.0", "-1e300", 8), ("1.9", "2e12", 11), ("0.79", "1e13", 13), ("1.0]", "1e308]", 6),
    ("15.0", "10000000000000", 9),
])
def test_a_pycycle_value_beyond_1e12_is_refused_naming_its_line(written, huge, line):
    text = PYCYCLE_MAP.replace(written, huge, 1)
    assert text != PYCYCLE_MAP
    error = _refused("m.py", text.encode())
    assert error.loc == ("file", "line", line)
    assert f"line {line}: {huge.rstrip(']')} is beyond 1e+12" in error.msg


def test_a_pycycle_map_within_the_bound_is_read_and_a_value_past_float_range_still_dropped():
    request = parse_upload(StoredInput.from_bytes("m.py", PYCYCLE_MAP.encode()), None)
    assert [p.flow for p in request.positions] == [[10.0, 11.0, 12.0], [13.0, 14.0, 15.0]]
    bound = PYCYCLE_MAP.replace("11.0", "1e12", 1).replace("14.0", "1" + "0" * 400, 1)
    request = parse_upload(StoredInput.from_bytes("m.py", bound.encode()), None)
    assert request.positions[0].flow == [10.0, 1e12, 12.0]
    assert [w.code for w in request.upload_warnings if w.code == "upload_points_dropped"]


@pytest.mark.parametrize("name, content, nul_at, what", [
    ("request.json", b'{"positions": [\x00\x00]}', 15, "JSON request"),
    ("m.py", PYCYCLE_MAP.encode()[:40] + b"\x00" + PYCYCLE_MAP.encode()[40:], 40, "pyCycle/NPSS map"),
    ("m.csv", b"flow,pressure\x00", 13, "CSV text file"),
])
def test_a_text_upload_holding_nul_bytes_is_named_binary_where_and_what_it_should_be(name, content, nul_at, what):
    error = _refused(name, content)
    assert error.loc == ("file",)
    assert f"NUL bytes, the first at byte offset {nul_at}" in error.msg and f"not a {what}" in error.msg
    assert name.endswith(".csv") or "CSV" not in error.msg


def test_a_zip_uploaded_as_json_is_not_told_to_save_a_sheet_as_csv():
    error = _refused("request.json", b"PK\x03\x04" + b"\x00" * 30)
    assert "zip archive" in error.msg and "JSON" in error.msg and "CSV" not in error.msg
