"""The perfflow58 review's findings on perfmap: identical setting lines told by the setting named as the speed (not
the last) and named at the file's lines, and a refusal of a JSON body or upload named where the value was written."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from plantsolve.schemas.perfmap import PerfmapRequest
from plantsolve.solvers.base import FieldError, InputRejected, StoredInput
from plantsolve.solvers.perfmap.upload import parse_upload
from plantsolve.solvers.perfmap.validation import load, placed

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "perfmap"
ROWS = [r.split(",") for r in (EXAMPLES / "n3_fan_map.csv").read_text().splitlines()[1:] if r.startswith("0.0,")]
SPEEDS = sorted({r[1] for r in ROWS})


def _line(speed: str) -> dict:
    rows = [r for r in ROWS if r[1] == speed]
    return {k: [float(r[c]) for r in rows] for k, c in (("flow", 2), ("pressure", 3), ("efficiency", 4))}


def _speed_alpha_body(measured_at: dict[tuple[str, float], str] | None = None) -> dict:
    """Speed lines at alpha 0 and 1 with the same tables, pyCycle-style, speed first; ``measured_at`` pastes the
    line of another speed at (speed, alpha)."""
    positions = [{"setting": [float(v), alpha], **_line((measured_at or {}).get((v, alpha), v))}
                 for alpha in (0.0, 1.0) for v in SPEEDS]
    return {"setting_names": ["speed", "alpha"], "positions": positions, "options": {"map": False}}


def _identical(body: dict):
    return [w for w in load(PerfmapRequest.model_validate(body)).warnings if w.code == "setting_lines_identical"]


def test_repeated_alpha_planes_with_the_speed_named_first_are_not_warned():
    assert len(SPEEDS) >= 3
    assert _identical(_speed_alpha_body()) == []


def test_a_line_pasted_under_the_next_speed_is_warned_with_the_speed_named_first():
    (warning,) = _identical(_speed_alpha_body({(SPEEDS[2], 1.0): SPEEDS[1]}))
    assert warning.details["pairs"] == [{"settings": [[float(SPEEDS[1]), 1.0], [float(SPEEDS[2]), 1.0]],
                                         "positions": [len(SPEEDS) + 1, len(SPEEDS) + 2]}]


def test_a_pasted_line_repeated_in_every_alpha_plane_is_one_pair():
    pasted = {(SPEEDS[2], alpha): SPEEDS[1] for alpha in (0.0, 1.0)}
    (warning,) = _identical(_speed_alpha_body(pasted))
    assert [p["settings"] for p in warning.details["pairs"]] == [[[float(SPEEDS[1]), 0.0], [float(SPEEDS[2]), 0.0]]]


def _json_upload_refusal(body: dict):
    source = StoredInput.from_bytes("rig.json", json.dumps(body).encode())
    with pytest.raises(InputRejected) as rejected:
        load(parse_upload(source, {}), source)
    return rejected.value.errors


def _bad_efficiency_body() -> dict:
    body = _speed_alpha_body()
    body["positions"][0]["efficiency"][1] = 0.0  # efficiencies are positive
    return body


def test_a_json_upload_with_a_null_source_names_the_value_at_its_path_in_the_file():
    (error,) = _json_upload_refusal({**_bad_efficiency_body(), "source": None})
    assert error.loc == ("file", "positions", 0, "efficiency", 1)
    (same,) = _json_upload_refusal(_bad_efficiency_body())
    assert same.loc == error.loc


def test_a_bodys_own_form_and_document_are_not_taken_for_the_upload_readers():
    body = _bad_efficiency_body()
    rows = [[10 + 100 * i + k for k in range(len(p["flow"]))] for i, p in enumerate(body["positions"])]
    body["source"] = {"format": "csv", "rows": rows, "form": {"positions.0": ["x"]}}
    with pytest.raises(InputRejected) as rejected:
        load(PerfmapRequest.model_validate(body))
    (error,) = rejected.value.errors
    assert error.loc == ("file", "row", 11, "efficiency")  # the row the body's rows give, not the form it claims
    body["source"] = {"format": "json", "rows": rows, "document": "positions"}
    with pytest.raises(InputRejected) as rejected:
        load(PerfmapRequest.model_validate(body))
    assert rejected.value.errors[0].loc == ("file", "row", 11, "efficiency")


def test_a_form_place_before_list_indices_is_said_with_them():
    error = placed(FieldError(("options", "beta_grid", 2), "bad"), {"form": {"options.beta_grid": ["options", "b"]}},
                   lambda i: ())
    assert error.loc == ("options", "b", 2) and error.msg == "bad"
    error = placed(FieldError(("units", "flow", 0), "bad"), {"form": {"units.flow": ["options", "units", "flow"]}},
                   lambda i: ())
    assert error.msg == "options.units.flow.0: bad"


def test_identical_speed_lines_of_a_gasturb_map_are_named_at_their_lines_in_the_file():
    from tests.solvers.perfmap.test_perfmap_gasturb import closed_form_tables, write_map

    tables = [t.copy() for t in closed_form_tables()]
    for t in tables:
        t[1] = t[0]  # the 0.6 speed line pasted again as the 0.7 one
    text = write_map(*tables, wrapped=False)  # one record a line: the Mass Flow table's speed rows are lines 5..8
    source = StoredInput.from_bytes("pasted.map", text.encode())
    (warning,) = [w for w in load(parse_upload(source, {"map": False}), source).warnings
                  if w.code == "setting_lines_identical"]
    assert text.splitlines()[4].startswith("0.6 ") and text.splitlines()[5].startswith("0.7 ")
    assert "Nc=0.6 (line 5) and Nc=0.7 (line 6)" in warning.message and "positions[" not in warning.message


def test_a_unit_stated_alike_by_the_header_and_the_form_is_the_files():
    text = (EXAMPLES / "n3_fan_map.csv").read_text()
    header = text.splitlines()[0]
    assert header == "theta,phi,flow,pressure,efficiency"

    def form_places(head: str) -> dict:
        source = StoredInput.from_bytes("m.csv", text.replace(header, head, 1).encode())
        return parse_upload(source, {"map": False, "units": {"flow": "kg/s"}}).source.form

    assert "units.flow" not in form_places("theta,phi,flow [kg/s],pressure,efficiency")  # the header's was used
    assert form_places(header)["units.flow"] == ["options", "units", "flow"]  # the form's was used


def test_the_gasturb_reader_takes_the_speed_names_from_their_own_module_not_the_plausibility_checks():
    import ast

    import plantsolve.solvers.perfmap.gasturb_map as reader

    tree = ast.parse(Path(reader.__file__).read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert "plantsolve.solvers.perfmap.speed_names" in imported
    assert "plantsolve.solvers.perfmap.plausibility" not in imported


def test_without_a_speed_name_a_whole_repeated_plane_is_no_pair_and_an_isolated_pasted_line_is_one():
    def unnamed(body: dict) -> dict:
        return {**body, "setting_names": ["theta", "phi"]}  # the speed first, named as no speed: the last is taken

    assert _identical(unnamed(_speed_alpha_body())) == []  # each theta line repeated at phi 1: the whole plane
    speed_last = [{"setting": [alpha, float(v)], **_line(SPEEDS[0] if (alpha, v) == (1.0, SPEEDS[1]) else v)}
                  for alpha in (0.0, 1.0) for v in SPEEDS]  # alpha planes alike but one line pasted in the second
    (warning,) = _identical(unnamed({**_speed_alpha_body(), "positions": speed_last}))
    assert [p["settings"] for p in warning.details["pairs"]] == [[[1.0, float(SPEEDS[0])], [1.0, float(SPEEDS[1])]]]
