"""The mistakes users make, each made as a user would make it: the answer is a refusal naming the field, a
warning naming the quantity, or the right number, never a confident wrong one."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from pydantic import ValidationError

from plantsolve.schemas.alignment import AlignmentOptions, AlignmentRequest
from plantsolve.solvers.alignment.plausibility import FAR, MOVE_EXTENT
from plantsolve.solvers.alignment.solve import solve
from plantsolve.solvers.alignment.synthetic import conflicting_tie_ins
from plantsolve.solvers.alignment.upload import parse_upload
from plantsolve.solvers.alignment.validation import check_input
from plantsolve.solvers.base import InputRejected, StoredInput
from tests.conftest import REPO

EXAMPLES = REPO / "examples" / "alignment"


def _ladder() -> dict:
    return json.loads((EXAMPLES / "ladder.json").read_text())


def _component(body: dict, cid: str) -> tuple[int, dict]:
    return next((i, c) for i, c in enumerate(body["components"]) if c["id"] == cid)


def _refusal(body: dict) -> InputRejected:
    with pytest.raises(InputRejected) as caught:
        check_input(AlignmentRequest.model_validate(body))
    return caught.value


def _messages(error: InputRejected) -> dict[tuple, str]:
    return {tuple(e.loc): e.msg for e in error.errors}


@pytest.mark.parametrize("axis, value", [(0, 1e11), (1, -3.2e9), (2, 1e8)])
def test_an_elbow_port_typed_far_outside_the_network_is_refused_naming_component_and_port(axis, value):
    body = _ladder()
    i, elbow = _component(body, "N0-1")
    elbow["ports"][0]["position"][axis] = value
    said = _messages(_refusal(body))
    msg = said[("components", i, "ports", 0, "position")]
    assert "'N0-1'" in msg and "port 0" in msg and f"{FAR:g} times" in msg
    assert len(said) == 1  # nothing else of the ladder is blamed


def test_a_pipe_end_typed_1e11_along_its_axis_is_refused_naming_the_pipe():
    body = _ladder()
    i, pipe = _component(body, "P1")
    a, b = (np.array(p["position"]) for p in pipe["ports"])
    pipe["ports"][1]["position"] = (a + 1e11 * (b - a) / np.linalg.norm(b - a)).tolist()  # still a straight pipe
    said = _messages(_refusal(body))
    assert list(said) == [("components", i, "ports", 1, "position")] and "'P1'" in next(iter(said.values()))


def test_a_coordinate_in_metres_in_a_millimetre_network_is_refused():
    body = _ladder()
    i, elbow = _component(body, "N2-1")
    elbow["ports"][1]["position"] = [v / 1000 for v in elbow["ports"][1]["position"]]  # 1005.99 "m" among mm
    assert ("components", i, "ports", 1, "position") in _messages(_refusal(body))


def test_far_apart_networks_and_long_runs_are_not_outliers():
    # two ladders 50 km apart, unconnected: each is judged against its own extent
    body = _ladder()
    other = copy.deepcopy(body)
    for c in other["components"]:
        c["id"] += "-far"
        for p in c["ports"]:
            p["position"][0] += 5.0e7
    for c in other["connections"]:
        c["from"][0] += "-far"
        c["to"][0] += "-far"
    body["components"] += other["components"]
    body["connections"] += other["connections"]
    check_input(AlignmentRequest.model_validate(body))
    # a 3 km straight pipe out of a 6 m ladder: a pipeline's run, no typo (a pipe reaches as far as it is long)
    body = _ladder()
    _, pipe = _component(body, "P1")
    a, b = (np.array(p["position"]) for p in pipe["ports"])
    pipe["ports"][1]["position"] = (a + 3.0e6 * (b - a) / np.linalg.norm(b - a)).tolist()
    check_input(AlignmentRequest.model_validate(body))


def test_a_port_typed_a_metre_off_is_solved_and_the_components_it_drags_are_named():
    body = _ladder()
    _, elbow = _component(body, "N0-1")
    elbow["ports"][0]["position"][1] += 1000.0  # a digit wrong: 1000 mm off
    res = solve(AlignmentRequest.model_validate(body)).result
    warning = next(w for w in res.report.warnings if w.code == "implausible_displacement")
    moved = {m["id"]: m for m in warning.details["components"]}
    assert "N0-1" in moved and all(m["displacement"] > m["limit"] for m in moved.values())
    assert warning.details["largest_starting_gap"]["from"][0] == "N0-1"  # the likely cause, named
    assert res.report.status == "warning" and "N0-1" in res.report.message and "moved beyond" in res.report.message
    # the same network without the typo moves nothing that far
    clean = solve(AlignmentRequest.model_validate(_ladder())).result
    assert not [w for w in clean.report.warnings if w.code == "implausible_displacement"]
    assert max(c.displacement for c in clean.components) < 20.0  # mm: scan gaps


def test_the_summary_names_each_cut_its_ports_and_its_gap():
    req = conflicting_tie_ins(3, 3, seed=2, turn=3.0)
    res = solve(req).result
    assert res.cut_connections
    for k in res.cut_connections:
        c = req.connections[k]
        a, b = sorted([(c.from_[0], c.from_[1]), (c.to[0], c.to[1])])
        assert f"{a[0]} port {a[1]} - {b[0]} port {b[1]} (input gap" in res.report.message
    assert "conflict" in res.report.message and f"Cut {len(res.cut_connections)} connection(s)" in res.report.message


@pytest.mark.parametrize("field, value", [
    ("position_tolerance", 1e6), ("angle_tolerance", 90.0), ("pipe_stiffness", 1e300), ("pipe_stiffness", 1e-300),
    ("min_pipe_length_factor", 1e9), ("step_limit", 1e300), ("explosion_factor", 1e300), ("max_cuts", 10**12),
    ("shape_tolerance", 180.0), ("connection_tolerance", 1e300), ("max_iterations", 10**9),
])
def test_absurd_scalar_options_are_refused_naming_the_field(field, value):
    with pytest.raises(ValidationError) as caught:
        AlignmentOptions.model_validate({field: value})
    assert [e["loc"] for e in caught.value.errors()] == [(field,)]


def test_every_scalar_option_has_both_bounds():
    schema = AlignmentOptions.model_json_schema()
    for name, prop in schema["properties"].items():
        kinds = [prop] + prop.get("anyOf", [])
        numeric = [k for k in kinds if k.get("type") in ("number", "integer")]
        if numeric:
            k = numeric[0]
            assert ("minimum" in k or "exclusiveMinimum" in k) and ("maximum" in k or "exclusiveMaximum" in k), name


def _upload(name: str, data: bytes):
    return parse_upload(StoredInput.from_bytes(name, data), None)


@pytest.mark.parametrize("path, holds", [
    ("examples/perfmap/n3_fan_map.csv", "table of 5 named column(s) (theta, phi, flow, pressure, efficiency)"),
    ("examples/tube/scan.xyz", "list of x y z points"),
    ("examples/dedup/tunnel_3rings.ifc", "STEP model (ISO-10303-21, schema IFC4"),
    ("examples/rigidity/hinged_wall.ldr", "LDraw model"),
    ("examples/polyhedra/two_offices.idf", "EnergyPlus IDF"),
])
def test_a_file_of_another_kind_uploaded_as_pcf_is_refused_naming_what_it_holds(path, holds):
    with pytest.raises(InputRejected) as caught:
        _upload("model.pcf", (REPO / path).read_bytes())
    assert holds in str(caught.value) and "this is no PCF" in str(caught.value)


@pytest.mark.parametrize("path, kind", [
    ("examples/flowmeter/meter.json", "flowmeter"), ("examples/perfmap/n3_fan_map.json", "perfmap"),
    ("examples/polyhedra/gable_house.json", "polyhedra"), ("examples/rigidity/four_bar_and_door.json", "rigidity"),
    ("examples/tube/scan_request.json", "tube"),
])
def test_a_json_request_of_another_kind_is_refused_naming_its_fields_and_kind(path, kind):
    with pytest.raises(InputRejected) as caught:
        _upload("model.json", (REPO / path).read_bytes())
    said = str(caught.value)
    assert f"a {kind} request" in said and "no 'components'" in said


@pytest.mark.parametrize("cut", [0.5, 6000, 0.99, 12])
def test_a_cut_json_upload_is_said_to_be_cut(cut):
    data = (EXAMPLES / "ladder.json").read_bytes()
    at = int(len(data) * cut) if cut < 1 else cut  # 6000: right after a minus sign, "Expecting value" before the end
    with pytest.raises(InputRejected, match="ends before its document is complete"):
        _upload("ladder.json", data[:at])


def test_an_invalid_but_complete_json_is_not_said_to_be_cut():
    with pytest.raises(InputRejected) as caught:
        _upload("ladder.json", b'{"units": "mm", "components": [1, 2,, 3]}')
    assert "invalid JSON" in str(caught.value) and "cut" not in str(caught.value)


@pytest.mark.parametrize("fraction", [0.5, 0.77, 0.95])
def test_a_cut_pcf_is_solved_for_what_it_holds_and_says_it_was_cut(fraction):
    text = (EXAMPLES / "ladder.pcf").read_bytes()
    req = _upload("ladder.pcf", text[: int(len(text) * fraction)])
    check_input(req)
    res = solve(req).result
    assert "truncated_file" in [w.code for w in res.report.warnings]
    assert res.report.status == "warning"


def test_the_implausible_displacement_limit_is_stated_in_the_readme():
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("### alignment"):readme.index("### tube")]
    assert "implausible_displacement" in section and f"{100 * MOVE_EXTENT:g} %" in section
    assert f"{FAR:g} times" in section


def _pcf_scaled(factor: float, header: str | None = None) -> bytes:
    """ladder.pcf with its coordinates (not its bores) multiplied by ``factor``, its UNITS-CO-ORDS set to ``header``."""
    out = []
    for line in (EXAMPLES / "ladder.pcf").read_text().splitlines():
        words = line.split()
        if words and words[0] in ("END-POINT", "CENTRE-POINT", "BRANCH1-POINT"):
            nums = [float(x) for x in words[1:]]
            line = "    " + " ".join([words[0]] + [f"{v * factor:.10g}" for v in nums[:3]] + words[4:])
        elif header and words[:1] == ["UNITS-CO-ORDS"]:
            line = f"UNITS-CO-ORDS {header}"
        out.append(line)
    return ("\n".join(out) + "\n").encode()


@pytest.mark.parametrize("factor, header, mixup", [
    (1e-3, None, "m read as mm"),  # metres under a MM header, bores in mm
    (1.0, "M", "mm read as m"),  # millimetres under an M header
    (1.0, "INCH", "mm read as inches"),
])
def test_a_pcf_header_that_contradicts_its_coordinates_is_said(factor, header, mixup):
    req = _upload("ladder.pcf", _pcf_scaled(factor, header))
    res = solve(req).result
    warning = next(w for w in res.report.warnings if w.code == "implausible_fitting_span")
    assert mixup in warning.message and "UNITS-CO-ORDS" in warning.message
    assert not 0.2 <= warning.details["median_span_in_bores"] <= 10.0
    assert res.report.status == "warning"
    clean = solve(_upload("ladder.pcf", (EXAMPLES / "ladder.pcf").read_bytes())).result
    assert not [w for w in clean.report.warnings if w.code.startswith("implausible_")]


def test_a_pcf_read_in_the_wrong_unit_that_connects_nothing_says_so():
    res = solve(_upload("ladder.pcf", _pcf_scaled(1.0, "M"))).result
    assert res.connections == []
    unconnected = next(w for w in res.report.warnings if w.code == "pcf_unconnected_items")
    assert len(unconnected.details["items"]) == 19


def test_a_json_request_in_the_wrong_unit_is_said():
    body = _ladder()
    body["units"] = "m"  # the ladder's numbers are millimetres
    res = solve(AlignmentRequest.model_validate(body)).result
    warning = next(w for w in res.report.warnings if w.code == "implausible_pipe_radius")
    assert "50 m" in warning.message and "mm read as m" in warning.message
    assert warning.details["median_radius_m"] == pytest.approx(50.0)


def test_a_pcf_whose_bore_header_contradicts_its_bores_names_the_bores_too():
    """Bores in mm under UNITS-BORE INCH make every fitting span 25.4 times fewer bores, as coordinates 25.4 times
    too small would: the warning must not blame the coordinates alone."""
    text = (EXAMPLES / "ladder.pcf").read_text().replace("UNITS-BORE MM", "UNITS-BORE INCH")
    res = solve(_upload("ladder.pcf", text.encode())).result
    warning = next(w for w in res.report.warnings if w.code == "implausible_fitting_span")
    assert "or the bores the other way round" in warning.message and "UNITS-BORE" in warning.message
    assert warning.details["median_span_in_bores"] < 0.2
